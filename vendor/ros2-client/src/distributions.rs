//! ROS 2 distribution identification.
//!
//! The distribution this crate is compiled for is selected via the Cargo
//! feature chain (see `Cargo.toml`): each distribution feature enables all
//! older ones, so `cfg!(feature = "X")` means "at least distribution X".
//!
//! [`COMPILED_ROS_DISTRO`] exposes the selected distribution as a runtime
//! constant, and [`crate::distributions::verify_ros_distro_env`] compares it
//! against the `ROS_DISTRO` environment variable at [`crate::Context`]
//! initialization.

use std::{
  fmt,
  sync::atomic::{AtomicU8, Ordering},
};

#[allow(unused_imports)]
use log::{error, info, warn};

/// A ROS 2 distribution.
///
/// Ordered chronologically, so comparisons (`<`, `>=`, ...) reflect release
/// order. Marked `#[non_exhaustive]` because future distributions will be
/// added.
#[non_exhaustive]
#[derive(Copy, Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum RosDistro {
  Galactic,
  Humble,
  Iron,
  Jazzy,
  Kilted,
  Lyrical,
}

impl RosDistro {
  /// The lower-case distribution name, matching the `ROS_DISTRO` value ROS 2
  /// sets when its environment is sourced (e.g. `"jazzy"`).
  pub const fn as_str(self) -> &'static str {
    match self {
      RosDistro::Galactic => "galactic",
      RosDistro::Humble => "humble",
      RosDistro::Iron => "iron",
      RosDistro::Jazzy => "jazzy",
      RosDistro::Kilted => "kilted",
      RosDistro::Lyrical => "lyrical",
    }
  }
}

impl fmt::Display for RosDistro {
  fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
    f.write_str(self.as_str())
  }
}

/// The ROS 2 distribution this crate was compiled for, i.e. the highest
/// activated distribution feature in the chain.
pub const COMPILED_ROS_DISTRO: RosDistro = compiled_distro();

const fn compiled_distro() -> RosDistro {
  // Features are additive and each enables all older ones, so the newest
  // enabled feature identifies the selected distribution.
  if cfg!(feature = "lyrical") {
    RosDistro::Lyrical
  } else if cfg!(feature = "kilted") {
    RosDistro::Kilted
  } else if cfg!(feature = "jazzy") {
    RosDistro::Jazzy
  } else if cfg!(feature = "iron") {
    RosDistro::Iron
  } else if cfg!(feature = "humble") {
    RosDistro::Humble
  } else {
    RosDistro::Galactic
  }
}

impl RosDistro {
  const ALL: [RosDistro; 6] = [
    RosDistro::Galactic,
    RosDistro::Humble,
    RosDistro::Iron,
    RosDistro::Jazzy,
    RosDistro::Kilted,
    RosDistro::Lyrical,
  ];

  /// The distribution named `name` (lower case, as `ROS_DISTRO`), if known.
  pub fn from_name(name: &str) -> Option<RosDistro> {
    Self::ALL.into_iter().find(|d| d.as_str() == name)
  }

  /// The length of `rmw_dds_common/msg/Gid` on the wire: 24 bytes up to Humble,
  /// 16 from Iron on.
  pub const fn gid_wire_length(self) -> usize {
    match self {
      RosDistro::Galactic | RosDistro::Humble => 24,
      _ => 16,
    }
  }
}

/// 0 = not set at run time (the compiled distribution); otherwise the index in
/// `RosDistro::ALL` + 1.
static RUNTIME_DISTRO: AtomicU8 = AtomicU8::new(0);

/// Selects the distribution whose wire formats (`ros_discovery_info`'s GIDs) this
/// process speaks, instead of the compiled one. Call before creating a
/// [`crate::Context`]; one process speaks one distribution. A build with 16-byte
/// GID storage (`iron` or newer) cannot speak Humble's 24-byte format: pick the
/// oldest distribution feature you need to speak (24-byte storage speaks both).
pub fn set_ros_distro(distro: RosDistro) {
  let i = RosDistro::ALL.iter().position(|d| *d == distro).unwrap_or(0);
  RUNTIME_DISTRO.store(i as u8 + 1, Ordering::Relaxed);
}

/// The distribution selected by [`set_ros_distro`], or the compiled one.
pub fn ros_distro() -> RosDistro {
  match RUNTIME_DISTRO.load(Ordering::Relaxed) {
    0 => COMPILED_ROS_DISTRO,
    i => RosDistro::ALL[(i - 1) as usize],
  }
}

/// The number of GID bytes written and read on the wire now.
pub(crate) fn wire_gid_length() -> usize {
  ros_distro()
    .gid_wire_length()
    .min(crate::gid::GID_LENGTH)
}

/// Compare the `ROS_DISTRO` environment variable against the distribution this
/// crate was compiled for, and log the outcome:
///
/// * unset -> warning (we cannot tell whether the build matches the runtime),
/// * equal -> info (all good),
/// * `"rolling"` -> warning (rolling tracks the newest, assume compatible),
/// * anything else -> error (likely wire-incompatible, e.g. wrong Gid format).
pub fn verify_ros_distro_env() {
  if RUNTIME_DISTRO.load(Ordering::Relaxed) != 0 {
    // The application chose the distribution at run time (set_ros_distro).
    info!("speaking ROS 2 '{}' (selected at run time).", ros_distro());
    return;
  }
  let built = ros_distro();
  match std::env::var("ROS_DISTRO") {
    Err(_) => warn!("ROS_DISTRO is not set; ros2-client was built for '{built}'."),
    Ok(distro) if distro == built.as_str() => {
      info!("ROS_DISTRO='{distro}' matches the ros2-client build.");
    }
    Ok(distro) if distro == "rolling" => {
      warn!(
        "ROS_DISTRO='rolling'; ros2-client was built for '{built}'. Assuming compatible, but \
         rolling may have diverged."
      );
    }
    Ok(distro) => {
      error!(
        "ROS_DISTRO='{distro}' but ros2-client was built for '{built}'. These may be \
         incompatible (e.g. different Gid format); rebuild with --features {distro}."
      );
    }
  }
}
