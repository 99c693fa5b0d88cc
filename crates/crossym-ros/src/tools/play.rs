//! A recorded bag's inputs published over DDS at the recorded rate, like `ros2 bag play`
//! (`crossym replay --live`), for a node or driver under test: the joint states and the
//! conditions of a node's topics, in the bag's order, each at its recorded log time (scaled
//! by the rate) after the first.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use crate::dds::{self, DdsError, DdsSettings};
use crate::replay::ReplayTopics;
use crossym_io::bag::{Bag, BagError};
use crossym_io::msg;

/// Errors of a live replay.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PlayError {
    /// The playback rate is not a positive number.
    #[error("rate = {value} must be positive")]
    Rate {
        /// The rate factor given.
        value: f64,
    },
    /// The discovery delay is negative or not a number.
    #[error("delay_s = {value} must be ≥ 0")]
    Delay {
        /// The delay given (s).
        value: f64,
    },
    /// The bag could not be read.
    #[error(transparent)]
    Bag(#[from] BagError),
    /// The bag has no joint-state topic of the node's name.
    #[error("{}: no {topic} topic", bag.display())]
    NoJointStates {
        /// The bag.
        bag: PathBuf,
        /// The joint-state topic looked for.
        topic: String,
    },
    /// The bag's joint-state and condition topics hold no message.
    #[error("{}: the bag has no joint states or conditions", bag.display())]
    Empty {
        /// The bag.
        bag: PathBuf,
    },
    /// DDS setup failed.
    #[error(transparent)]
    Dds(#[from] DdsError),
    /// A message could not be published.
    #[error("publish {what}: {message}")]
    Publish {
        /// `joint state` or `condition`.
        what: &'static str,
        /// The middleware's error text.
        message: String,
    },
}

/// How to play, validated once by [`play`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlaySettings {
    /// Playback rate factor (2: twice as fast as recorded).
    pub rate: f64,
    /// Keep the recorded header stamps (else joint states are stamped with the publish
    /// time, as a node checking stamps needs).
    pub keep_stamps: bool,
    /// Wait this long for discovery before the first message (s).
    pub delay_s: f64,
}

impl PlaySettings {
    /// Checks that the rate is positive and the delay ≥ 0.
    pub fn validate(&self) -> Result<(), PlayError> {
        if !(self.rate.is_finite() && self.rate > 0.0) {
            return Err(PlayError::Rate { value: self.rate });
        }
        if !(self.delay_s.is_finite() && self.delay_s >= 0.0) {
            return Err(PlayError::Delay {
                value: self.delay_s,
            });
        }
        Ok(())
    }
}

/// What was played.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlaySummary {
    /// Joint states published.
    pub joint_states: usize,
    /// Conditions published.
    pub conditions: usize,
    /// From the first message's due time to the last publish (s).
    pub elapsed_s: f64,
}

/// When the message logged at `log_ns` is due, after the first played message logged at
/// `first_ns`, at playback `rate`.
pub fn due(log_ns: u64, first_ns: u64, rate: f64) -> Duration {
    Duration::from_secs_f64((log_ns - first_ns) as f64 * 1e-9 / rate)
}

/// Publishes the joint states and conditions of the bag at `bag_path` on `topics` (reliable,
/// from a participant of `dds`) at the recorded rate; waits `delay_s` for discovery first
/// and 0.3 s after the last message for reliable delivery.
pub fn play(
    bag_path: &Path,
    topics: &ReplayTopics,
    settings: &PlaySettings,
    dds: &DdsSettings,
) -> Result<PlaySummary, PlayError> {
    settings.validate()?;
    let bag = Bag::open(bag_path)?;
    let js = bag
        .topic(&topics.joint_states)
        .ok_or_else(|| PlayError::NoJointStates {
            bag: bag_path.to_path_buf(),
            topic: topics.joint_states.clone(),
        })?;
    let cond = bag.topic(&topics.condition);
    let ctx = dds.context()?;
    let mut node = ctx
        .new_node(
            dds::node_name("/", &format!("crossym_player_{}", std::process::id()))?,
            ros2_client::NodeOptions::new().enable_rosout(false),
        )
        .map_err(|e| DdsError::Create {
            what: "player node".into(),
            message: format!("{e:?}"),
        })?;
    let js_pub =
        dds::publisher::<msg::JointState>(&mut node, &topics.joint_states, dds::qos_reliable(10))?;
    let cond_pub = dds::publisher::<msg::SymmetryCondition>(
        &mut node,
        &topics.condition,
        dds::qos_reliable(10),
    )?;
    // Give discovery time to match the subscribers before the first sample.
    std::thread::sleep(Duration::from_secs_f64(settings.delay_s));
    let played = |topic: usize| topic == js || Some(topic) == cond;
    let first = bag
        .messages
        .iter()
        .find(|m| played(m.topic))
        .map(|m| m.log_ns)
        .ok_or_else(|| PlayError::Empty {
            bag: bag_path.to_path_buf(),
        })?;
    let start = Instant::now();
    let mut summary = PlaySummary {
        joint_states: 0,
        conditions: 0,
        elapsed_s: 0.0,
    };
    for (i, m) in bag.messages.iter().enumerate() {
        if !played(m.topic) {
            continue;
        }
        if let Some(wait) = due(m.log_ns, first, settings.rate).checked_sub(start.elapsed()) {
            std::thread::sleep(wait);
        }
        if m.topic == js {
            let mut s: msg::JointState = bag.decode(i)?;
            if !settings.keep_stamps {
                s.header.stamp = msg::Time::from_secs_f64(dds::wall_time_s());
            }
            js_pub.publish(s).map_err(|e| PlayError::Publish {
                what: "joint state",
                message: format!("{e:?}"),
            })?;
            summary.joint_states += 1;
        } else {
            let s: msg::SymmetryCondition = bag.decode(i)?;
            cond_pub.publish(s).map_err(|e| PlayError::Publish {
                what: "condition",
                message: format!("{e:?}"),
            })?;
            summary.conditions += 1;
        }
    }
    // Let reliable writers deliver the tail.
    std::thread::sleep(Duration::from_millis(300));
    summary.elapsed_s = start.elapsed().as_secs_f64();
    Ok(summary)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn settings_are_checked() {
        let s = |rate, delay_s| PlaySettings {
            rate,
            keep_stamps: false,
            delay_s,
        };
        assert!(s(1.0, 0.0).validate().is_ok());
        for rate in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert!(matches!(
                s(rate, 1.0).validate(),
                Err(PlayError::Rate { .. })
            ));
        }
        for delay in [-0.1, f64::NAN] {
            assert!(matches!(
                s(1.0, delay).validate(),
                Err(PlayError::Delay { .. })
            ));
        }
    }

    #[test]
    fn messages_are_due_at_their_log_time_over_the_rate() {
        assert_eq!(due(1_000_000_000, 1_000_000_000, 1.0), Duration::ZERO);
        assert_eq!(
            due(3_000_000_000, 1_000_000_000, 1.0),
            Duration::from_secs(2)
        );
        assert_eq!(
            due(3_000_000_000, 1_000_000_000, 2.0),
            Duration::from_secs(1)
        );
    }
}
