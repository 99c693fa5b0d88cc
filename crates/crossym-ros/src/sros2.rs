//! SROS2's environment read as rcl reads it (rcl/src/rcl/security.c and rmw_dds_common's
//! security files): whether a participant runs secured, from which enclave of which
//! keystore, and what happens when the files are missing.
//!
//! - `ROS_SECURITY_ENABLE`: security is on when it is exactly `true` (case-sensitive);
//! - `ROS_SECURITY_STRATEGY`: exactly `Enforce` enforces; anything else (unset included)
//!   is permissive;
//! - the enclave: `ROS_SECURITY_ENCLAVE_OVERRIDE` when non-empty, else `--ros-args
//!   --enclave`, else `/`;
//! - its directory: `$ROS_SECURITY_KEYSTORE/enclaves/<enclave>` holding `identity_ca.cert.pem`,
//!   `cert.pem`, `key.pem`, `permissions_ca.cert.pem`, `governance.p7s` and `permissions.p7s`.
//!
//! A keystore, directory or file missing: under `Enforce` the participant is not created
//! (the error names what is missing); permissive, it runs unsecured after a warning. A build
//! without the `security` feature asked for security: `Enforce` stops (saying how to build
//! with it), permissive warns. Files present but invalid (a wrong signature, another CA) stop
//! it under either strategy, as with rmw: RustDDS refuses them.
//!
//! This module reads and checks; [`crate::dds::DdsSettings::context_with_hook`] applies the
//! outcome to the participant it builds.

use std::path::{Path, PathBuf};

/// The enclave's files, in the order rmw_dds_common lists them.
pub const ENCLAVE_FILES: [&str; 6] = [
    "identity_ca.cert.pem",
    "cert.pem",
    "key.pem",
    "permissions_ca.cert.pem",
    "governance.p7s",
    "permissions.p7s",
];

/// True when this build has DDS Security (the cargo feature `security`).
pub const BUILT_WITH_SECURITY: bool = cfg!(feature = "security");

/// `ROS_SECURITY_STRATEGY`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Strategy {
    /// Exactly `Enforce`: no participant without valid files.
    Enforce,
    /// Anything else: missing files make an unsecured participant, after a warning.
    #[default]
    Permissive,
}

impl std::fmt::Display for Strategy {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Strategy::Enforce => "Enforce",
            Strategy::Permissive => "Permissive",
        })
    }
}

/// SROS2's variables of one process, plus its `--ros-args --enclave`.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct SecurityEnv {
    /// `ROS_SECURITY_ENABLE` is exactly `true`.
    pub enable: bool,
    /// `ROS_SECURITY_STRATEGY`.
    pub strategy: Strategy,
    /// `ROS_SECURITY_KEYSTORE` (non-empty).
    pub keystore: Option<PathBuf>,
    /// `ROS_SECURITY_ENCLAVE_OVERRIDE` (non-empty).
    pub enclave_override: Option<String>,
    /// `--ros-args --enclave` (or what a program sets for its own participants).
    pub ros_enclave: Option<String>,
}

/// Why security as asked cannot be had.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum Sros2Error {
    /// Enforce, and a file (or the keystore or enclave directory) is missing.
    #[error(
        "ROS_SECURITY_STRATEGY=Enforce: {} is missing (enclave {enclave}{}); \
         make it with `crossym security create-enclave` or `generate-artifacts` \
         (docs/guide/security.md), or run permissive",
        .missing.display(),
        .keystore.as_ref().map(|k| format!(" of keystore {}", k.display())).unwrap_or_default()
    )]
    Missing {
        /// The enclave.
        enclave: String,
        /// `ROS_SECURITY_KEYSTORE`, when set.
        keystore: Option<PathBuf>,
        /// The first file or directory not found (`ROS_SECURITY_KEYSTORE` itself when unset).
        missing: PathBuf,
    },
    /// Enforce, in a build without DDS Security.
    #[error(
        "ROS_SECURITY_ENABLE=true with ROS_SECURITY_STRATEGY=Enforce, but this build of \
         crossym has no DDS Security: build it with `cargo build --release --features security` \
         (docs/guide/security.md)"
    )]
    NotBuilt,
    /// The enclave's own identity certificate is not valid now (expired, or not yet valid):
    /// every peer would refuse it.
    #[error(
        "enclave {enclave}: its identity certificate {} {why}: every peer's DDS Security \
         would refuse this participant; make a new one with `crossym security create-enclave` \
         (docs/guide/security.md)",
        .cert.display()
    )]
    CertificateNotValid {
        /// The enclave.
        enclave: String,
        /// Its `cert.pem`.
        cert: PathBuf,
        /// Its validity.
        why: String,
    },
    /// An enclave name rcl would not take.
    #[error("enclave {0:?}: an enclave is an absolute name like /crossym/node")]
    EnclaveName(String),
}

/// What a participant built under a [`SecurityEnv`] will be.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum SecurityMode {
    /// `ROS_SECURITY_ENABLE` is not `true`: an ordinary participant.
    Off,
    /// Secured with the files of `dir`.
    Secured {
        /// The enclave.
        enclave: String,
        /// Its directory in the keystore.
        dir: PathBuf,
        /// The strategy it was asked under.
        strategy: Strategy,
    },
    /// Security asked for, permissive, and not possible: unsecured, with `reason`.
    Unsecured {
        /// The enclave asked for.
        enclave: String,
        /// Why it runs unsecured.
        reason: String,
    },
}

impl SecurityMode {
    /// One line for a startup log: `secured as enclave /crossym/node (Enforce, DIR)`,
    /// `unsecured: …` or `not secured (ROS_SECURITY_ENABLE is not true)`.
    pub fn describe(&self) -> String {
        match self {
            SecurityMode::Off => {
                "DDS Security off (ROS_SECURITY_ENABLE is not `true`): unauthenticated, \
                 unencrypted"
                    .into()
            }
            SecurityMode::Secured {
                enclave,
                dir,
                strategy,
            } => format!(
                "DDS Security on: secured as enclave {enclave} (strategy {strategy}, {})",
                dir.display()
            ),
            SecurityMode::Unsecured { enclave, reason } => format!(
                "SECURITY WARNING: running UNSECURED (ROS_SECURITY_STRATEGY is not Enforce) — \
                 enclave {enclave}: {reason}"
            ),
        }
    }

    /// The warning of a permissive fallback, if this is one.
    pub fn warning(&self) -> Option<String> {
        matches!(self, SecurityMode::Unsecured { .. }).then(|| self.describe())
    }

    /// The enclave of a secured participant.
    pub fn enclave(&self) -> Option<&str> {
        match self {
            SecurityMode::Secured { enclave, .. } => Some(enclave),
            _ => None,
        }
    }
}

impl SecurityEnv {
    /// Reads the process environment.
    pub fn from_env() -> Self {
        Self::from_vars(|k| std::env::var(k).ok())
    }

    /// As [`SecurityEnv::from_env`], reading variables through `get` (testable).
    pub fn from_vars(get: impl Fn(&str) -> Option<String>) -> Self {
        let non_empty = |k: &str| get(k).filter(|v| !v.is_empty());
        Self {
            enable: get("ROS_SECURITY_ENABLE").as_deref() == Some("true"),
            strategy: match get("ROS_SECURITY_STRATEGY").as_deref() {
                Some("Enforce") => Strategy::Enforce,
                _ => Strategy::Permissive,
            },
            keystore: non_empty("ROS_SECURITY_KEYSTORE").map(PathBuf::from),
            enclave_override: non_empty("ROS_SECURITY_ENCLAVE_OVERRIDE"),
            ros_enclave: None,
        }
    }

    /// Security on, enforced, from `keystore`'s `enclave` (what a test or a program that
    /// secures its own participant asks).
    pub fn enforce(keystore: impl Into<PathBuf>, enclave: &str) -> Self {
        Self {
            enable: true,
            strategy: Strategy::Enforce,
            keystore: Some(keystore.into()),
            enclave_override: None,
            ros_enclave: Some(enclave.into()),
        }
    }

    /// These variables with `--ros-args --enclave` (`None`: unchanged).
    pub fn with_ros_enclave(mut self, enclave: Option<&str>) -> Self {
        if let Some(e) = enclave {
            self.ros_enclave = Some(e.to_string());
        }
        self
    }

    /// The enclave, as rcl picks it: the override, else `--enclave`, else `/`.
    pub fn enclave(&self) -> &str {
        self.enclave_override
            .as_deref()
            .or(self.ros_enclave.as_deref())
            .unwrap_or("/")
    }

    /// What a participant will be: checks the keystore, the enclave directory and its
    /// files (their existence, and the dates of the enclave's own certificate, which every
    /// peer checks; RustDDS verifies the rest when the participant is built).
    pub fn resolve(&self) -> Result<SecurityMode, Sros2Error> {
        if !self.enable {
            return Ok(SecurityMode::Off);
        }
        let enclave = self.enclave().to_string();
        let unsecured = |reason: String| SecurityMode::Unsecured {
            enclave: enclave.clone(),
            reason,
        };
        if !BUILT_WITH_SECURITY {
            return match self.strategy {
                Strategy::Enforce => Err(Sros2Error::NotBuilt),
                Strategy::Permissive => Ok(unsecured(
                    "this build of crossym has no DDS Security (build it with `--features \
                     security`)"
                        .into(),
                )),
            };
        }
        if !enclave.starts_with('/') || enclave.contains("//") || enclave.contains("..") {
            return Err(Sros2Error::EnclaveName(enclave));
        }
        let missing = |missing: PathBuf| Sros2Error::Missing {
            enclave: enclave.clone(),
            keystore: self.keystore.clone(),
            missing,
        };
        let found = match &self.keystore {
            None => Err(missing("ROS_SECURITY_KEYSTORE (unset)".into())),
            Some(ks) => enclave_dir(ks, &enclave).map_err(missing),
        };
        match (found, self.strategy) {
            (Ok(dir), strategy) => match (own_certificate_valid_now(&enclave, &dir), strategy) {
                (Ok(()), _) => Ok(SecurityMode::Secured {
                    enclave,
                    dir,
                    strategy,
                }),
                (Err(e), Strategy::Enforce) => Err(e),
                (Err(e), Strategy::Permissive) => Ok(unsecured(e.to_string())),
            },
            (Err(e), Strategy::Enforce) => Err(e),
            (Err(Sros2Error::Missing { missing, .. }), Strategy::Permissive) => {
                Ok(unsecured(format!("{} is missing", missing.display())))
            }
            (Err(e), Strategy::Permissive) => Err(e),
        }
    }
}

/// The participant's own certificate (`DIR/cert.pem` of `enclave`) checked as its peers
/// will (its dates); a build without DDS Security never gets here.
#[cfg(feature = "security")]
fn own_certificate_valid_now(enclave: &str, dir: &Path) -> Result<(), Sros2Error> {
    let cert = dir.join("cert.pem");
    crate::security::pki::valid_now(&cert).map_err(|why| Sros2Error::CertificateNotValid {
        enclave: enclave.to_string(),
        cert,
        why,
    })
}

#[cfg(not(feature = "security"))]
fn own_certificate_valid_now(_enclave: &str, _dir: &Path) -> Result<(), Sros2Error> {
    Ok(())
}

/// `keystore/enclaves/<enclave>` when it and its six files exist; else the first missing
/// path.
fn enclave_dir(keystore: &Path, enclave: &str) -> Result<PathBuf, PathBuf> {
    if !keystore.is_dir() {
        return Err(keystore.to_path_buf());
    }
    let mut dir = keystore.join("enclaves");
    for part in enclave.split('/').filter(|p| !p.is_empty()) {
        dir.push(part);
    }
    if !dir.is_dir() {
        return Err(dir);
    }
    for f in ENCLAVE_FILES {
        let p = dir.join(f);
        if !p.is_file() {
            return Err(p);
        }
    }
    Ok(dir)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn env(vars: &[(&str, &str)]) -> SecurityEnv {
        let vars: Vec<(String, String)> = vars
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect();
        SecurityEnv::from_vars(move |k| {
            vars.iter()
                .find(|(name, _)| name == k)
                .map(|(_, v)| v.clone())
        })
    }

    #[test]
    fn variables_are_read_as_rcl_reads_them() {
        assert!(!env(&[]).enable);
        assert!(env(&[("ROS_SECURITY_ENABLE", "true")]).enable);
        for not_true in ["True", "TRUE", "1", "yes", " true", ""] {
            assert!(
                !env(&[("ROS_SECURITY_ENABLE", not_true)]).enable,
                "{not_true}"
            );
        }
        let s = |v: &str| env(&[("ROS_SECURITY_STRATEGY", v)]).strategy;
        assert_eq!(s("Enforce"), Strategy::Enforce);
        for other in ["enforce", "ENFORCE", "Permissive", "", "Enforce "] {
            assert_eq!(s(other), Strategy::Permissive, "{other:?}");
        }
        assert_eq!(env(&[]).strategy, Strategy::Permissive);
        // The enclave: the override (non-empty) wins over --enclave, which wins over /.
        assert_eq!(env(&[]).enclave(), "/");
        let e = env(&[]).with_ros_enclave(Some("/crossym/node"));
        assert_eq!(e.enclave(), "/crossym/node");
        let e = env(&[("ROS_SECURITY_ENCLAVE_OVERRIDE", "/crossym/operator")])
            .with_ros_enclave(Some("/crossym/node"));
        assert_eq!(e.enclave(), "/crossym/operator");
        let e = env(&[("ROS_SECURITY_ENCLAVE_OVERRIDE", "")]).with_ros_enclave(Some("/a"));
        assert_eq!(e.enclave(), "/a");
        assert_eq!(env(&[("ROS_SECURITY_KEYSTORE", "")]).keystore, None);
    }

    #[test]
    fn off_unless_enabled() {
        let e = env(&[
            ("ROS_SECURITY_STRATEGY", "Enforce"),
            ("ROS_SECURITY_KEYSTORE", "/nowhere"),
        ]);
        assert_eq!(e.resolve(), Ok(SecurityMode::Off));
    }

    #[test]
    fn missing_files_stop_enforce_and_warn_permissive() {
        let dir = std::env::temp_dir().join(format!("crossym-sros2-{}", std::process::id()));
        let enclave = dir.join("enclaves/crossym/node");
        std::fs::create_dir_all(&enclave).unwrap();
        for f in &ENCLAVE_FILES[..5] {
            std::fs::write(enclave.join(f), "x").unwrap();
        }
        let ks = dir.to_str().unwrap();
        let base = [
            ("ROS_SECURITY_ENABLE", "true"),
            ("ROS_SECURITY_KEYSTORE", ks),
        ];
        let enforce = |extra: &[(&str, &str)]| {
            let mut v = base.to_vec();
            v.push(("ROS_SECURITY_STRATEGY", "Enforce"));
            v.extend_from_slice(extra);
            env(&v)
        };
        let node = [("ROS_SECURITY_ENCLAVE_OVERRIDE", "/crossym/node")];
        if !BUILT_WITH_SECURITY {
            assert_eq!(enforce(&node).resolve(), Err(Sros2Error::NotBuilt));
            let m = env(&base).resolve().unwrap();
            assert!(
                m.warning().unwrap().contains("--features security"),
                "{m:?}"
            );
            return;
        }
        let e = enforce(&node).resolve().unwrap_err().to_string();
        assert!(e.contains("permissions.p7s is missing"), "{e}");
        let e = enforce(&[("ROS_SECURITY_ENCLAVE_OVERRIDE", "/crossym/other")])
            .resolve()
            .unwrap_err()
            .to_string();
        assert!(e.contains("enclaves/crossym/other is missing"), "{e}");
        let e = enforce(&[]).resolve().unwrap_err().to_string();
        assert!(e.contains("enclave /"), "{e}");
        let mut v = base.to_vec();
        v.extend_from_slice(&node);
        let m = env(&v).resolve().unwrap();
        let w = m.warning().expect("a warning");
        assert!(
            w.contains("UNSECURED") && w.contains("permissions.p7s is missing"),
            "{w}"
        );
        std::fs::write(enclave.join("permissions.p7s"), "x").unwrap();
        let m = enforce(&node).resolve().unwrap();
        assert_eq!(m.enclave(), Some("/crossym/node"));
        assert!(m.describe().contains("secured as enclave /crossym/node"));
        expired_own_certificate_stops_enforce_and_warns_permissive(&enclave, &env(&v));
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// The enclave's own certificate expired (issued in 1970 for 3650 days): Enforce stops
    /// naming its dates; permissive (`permissive`, as the test above) runs unsecured with
    /// the same words.
    #[cfg(feature = "security")]
    fn expired_own_certificate_stops_enforce_and_warns_permissive(
        enclave: &Path,
        permissive: &SecurityEnv,
    ) {
        let old = crate::security::pki::new_key_and_cert("/crossym/node", None, 0).unwrap();
        std::fs::write(enclave.join("cert.pem"), old.cert.to_pem().unwrap()).unwrap();
        let enforce = SecurityEnv {
            strategy: Strategy::Enforce,
            ..permissive.clone()
        };
        let e = enforce.resolve().unwrap_err().to_string();
        assert!(
            e.contains("enclave /crossym/node: its identity certificate")
                && e.contains("valid from 1969-12-31T00:00:00 to 1979-12-30T00:00:00 UTC, not now"),
            "{e}"
        );
        let w = permissive.resolve().unwrap().warning().expect("a warning");
        assert!(w.contains("UNSECURED") && w.contains("not now"), "{w}");
    }

    #[cfg(not(feature = "security"))]
    fn expired_own_certificate_stops_enforce_and_warns_permissive(_: &Path, _: &SecurityEnv) {}
}
