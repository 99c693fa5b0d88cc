//! Joint-state recordings: `sensor_msgs/JointState` messages of one topic of a rosbag2 bag
//! (MCAP or SQLite3, as `ros2 bag record /joint_states` or `crossym record` writes them) as a
//! time series of the configured joints.
//!
//! For message `k` with names `nₖ` and positions `pₖ`, the sample is
//! `q_k[j] = pₖ[i]` where `nₖ[i]` is configured joint `j`: joints are matched by name, in
//! any order, and joints the robot config does not control (torso, head, wheels, grippers)
//! are ignored. Its time is the header stamp (default) or the bag's receive time
//! ([`StampSource`]), `t_k = stamp_k − stamp_0` in seconds. Every sample must name every
//! configured joint with a finite position, and stamps must increase strictly; a recording
//! that breaks either is refused with the bag, the message index and the problem — nothing
//! is repaired silently (resampling, trimming and differentiation are later steps).

use std::path::PathBuf;

use crossym_io::bag::{Bag, BagError};
use crossym_io::msg::JointState;

/// Which time a sample gets.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StampSource {
    /// `header.stamp` of the message (the measurement time; the default).
    #[default]
    Header,
    /// The bag's receive time (for drivers that leave the header stamp at zero).
    Receive,
}

/// A joint-state recording of the configured joints.
#[derive(Debug, Clone, PartialEq)]
pub struct JointRecording {
    /// The storage file read.
    pub bag: PathBuf,
    /// The topic read.
    pub topic: String,
    /// Configured joint names, the column order of `q`.
    pub joints: Vec<String>,
    /// Time of sample `k` since the first sample (s).
    pub t: Vec<f64>,
    /// Time of the first sample (ns since the Unix epoch, of the chosen stamp source).
    pub start_ns: i128,
    /// Positions, row-major `len × joints.len()` (rad or m).
    pub q: Vec<f64>,
    /// Names in the messages that are not configured joints (ignored), sorted.
    pub ignored: Vec<String>,
}

impl JointRecording {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// True without samples (never for a recording that was read successfully).
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// Positions of sample `k` in the configured joint order (rad or m).
    pub fn q(&self, k: usize) -> &[f64] {
        let n = self.joints.len();
        &self.q[k * n..(k + 1) * n]
    }

    /// Duration from the first to the last sample (s).
    pub fn duration(&self) -> f64 {
        self.t.last().copied().unwrap_or(0.0)
    }
}

/// Why a recording was refused; each names the bag (and the message, where one is at fault).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RecordingError {
    /// The bag itself cannot be read.
    #[error(transparent)]
    Bag {
        /// The reader's error.
        #[from]
        source: BagError,
    },
    /// The bag has no such topic.
    #[error("{bag}: no topic {topic} (the bag has: {available})")]
    TopicAbsent {
        /// The storage file.
        bag: PathBuf,
        /// The topic asked for.
        topic: String,
        /// The bag's topics with their types.
        available: String,
    },
    /// The topic carries another type.
    #[error("{bag}: topic {topic} is {ros_type}, not sensor_msgs/msg/JointState")]
    WrongType {
        /// The storage file.
        bag: PathBuf,
        /// The topic.
        topic: String,
        /// Its type.
        ros_type: String,
    },
    /// The topic has no message.
    #[error("{bag}: topic {topic} has no message")]
    Empty {
        /// The storage file.
        bag: PathBuf,
        /// The topic.
        topic: String,
    },
    /// A message is malformed or incomplete for the configured joints.
    #[error("{bag}: {topic} message {index} (t = {time_s:.3} s): {problem}")]
    Message {
        /// The storage file.
        bag: PathBuf,
        /// The topic.
        topic: String,
        /// 0-based index among the topic's messages.
        index: usize,
        /// Its time since the first message (s; receive time when the stamp is at fault).
        time_s: f64,
        /// What is wrong.
        problem: String,
    },
}

/// Reads the joint states of `topic` in `bag` as a recording of `joints` (configured order),
/// stamped by `stamps`.
pub fn read_joint_states(
    bag: &Bag,
    topic: &str,
    joints: &[String],
    stamps: StampSource,
) -> Result<JointRecording, RecordingError> {
    let path = bag.path.clone();
    let ti = joint_state_topic(bag, topic)?;
    let n = joints.len();
    let mut t_ns: Vec<i128> = Vec::new();
    let mut q = Vec::new();
    let mut layout = Layout::new(n);
    let first_receive = bag
        .messages
        .iter()
        .find(|m| m.topic == ti)
        .map_or(0, |m| m.log_ns);
    for (index, (i, raw)) in bag
        .messages
        .iter()
        .enumerate()
        .filter(|(_, m)| m.topic == ti)
        .enumerate()
    {
        let receive_s = (raw.log_ns as f64 - first_receive as f64) * 1e-9;
        let fail = |problem: String| RecordingError::Message {
            bag: bag.path.clone(),
            topic: topic.into(),
            index,
            time_s: receive_s,
            problem,
        };
        let js: JointState = bag.decode(i).map_err(|e| fail(e.to_string()))?;
        if js.position.len() != js.name.len() {
            return Err(fail(format!(
                "{} names but {} positions",
                js.name.len(),
                js.position.len()
            )));
        }
        layout.update(&js.name, joints).map_err(fail)?;
        layout
            .push_positions(&js.position, joints, &mut q)
            .map_err(fail)?;
        let ns = stamp_ns(&js, raw.log_ns, stamps);
        if let Some(&prev) = t_ns.last() {
            if ns <= prev {
                return Err(fail(not_after(stamps, ns, prev)));
            }
        }
        t_ns.push(ns);
    }
    let Some(&start_ns) = t_ns.first() else {
        return Err(RecordingError::Empty {
            bag: path,
            topic: topic.into(),
        });
    };
    Ok(JointRecording {
        bag: path,
        topic: topic.into(),
        joints: joints.to_vec(),
        t: t_ns
            .iter()
            .map(|&ns| (ns - start_ns) as f64 * 1e-9)
            .collect(),
        start_ns,
        q,
        ignored: layout.ignored.into_iter().collect(),
    })
}

/// Column of each configured joint in the previous message's name list (messages of one
/// driver share their layout; looked up again when it changes), and the names ignored.
struct Layout {
    names: Vec<String>,
    cols: Vec<usize>,
    ignored: std::collections::BTreeSet<String>,
}

impl Layout {
    /// No layout seen yet, for `n` configured joints.
    fn new(n: usize) -> Self {
        Self {
            names: Vec::new(),
            cols: vec![0; n],
            ignored: std::collections::BTreeSet::new(),
        }
    }

    /// Looks the configured `joints` up again in `names` when they are a new layout.
    fn update(&mut self, names: &[String], joints: &[String]) -> Result<(), String> {
        if names != self.names {
            joint_columns(names, joints, &mut self.cols)?;
            for nm in names {
                if !joints.contains(nm) {
                    self.ignored.insert(nm.clone());
                }
            }
            self.names = names.to_vec();
        }
        Ok(())
    }

    /// Appends the configured joints' positions (all finite) to `q`.
    fn push_positions(
        &self,
        position: &[f64],
        joints: &[String],
        q: &mut Vec<f64>,
    ) -> Result<(), String> {
        for (j, &c) in self.cols.iter().enumerate() {
            let v = position[c];
            if !v.is_finite() {
                return Err(format!("position of `{}` is {v}", joints[j]));
            }
            q.push(v);
        }
        Ok(())
    }
}

/// A message's time (ns) by `stamps`: its header stamp or its receive time `log_ns`.
fn stamp_ns(js: &JointState, log_ns: u64, stamps: StampSource) -> i128 {
    match stamps {
        StampSource::Header => {
            i128::from(js.header.stamp.sec) * 1_000_000_000 + i128::from(js.header.stamp.nanosec)
        }
        StampSource::Receive => i128::from(log_ns),
    }
}

/// Index of `topic` in `bag`, which must carry `sensor_msgs/msg/JointState`.
fn joint_state_topic(bag: &Bag, topic: &str) -> Result<usize, RecordingError> {
    let ti = bag
        .topic(topic)
        .ok_or_else(|| RecordingError::TopicAbsent {
            bag: bag.path.clone(),
            topic: topic.into(),
            available: bag
                .topics
                .iter()
                .map(|t| format!("{} ({})", t.name, t.ros_type))
                .collect::<Vec<_>>()
                .join(", "),
        })?;
    let ros_type = &bag.topics[ti].ros_type;
    if ros_type != "sensor_msgs/msg/JointState" {
        return Err(RecordingError::WrongType {
            bag: bag.path.clone(),
            topic: topic.into(),
            ros_type: ros_type.clone(),
        });
    }
    Ok(ti)
}

/// Sets `cols[j]` to the column of configured joint `joints[j]` in a message's `names`;
/// the problem when one is missing or named twice.
fn joint_columns(names: &[String], joints: &[String], cols: &mut [usize]) -> Result<(), String> {
    for (j, want) in joints.iter().enumerate() {
        let hits: Vec<usize> = names
            .iter()
            .enumerate()
            .filter(|(_, nm)| *nm == want)
            .map(|(c, _)| c)
            .collect();
        cols[j] = match hits.as_slice() {
            [c] => *c,
            [] => {
                return Err(format!(
                    "configured joint `{want}` is missing (the message names: {})",
                    names.join(", ")
                ))
            }
            _ => return Err(format!("joint `{want}` is named twice")),
        };
    }
    Ok(())
}

/// The problem of a stamp `ns` (from `stamps`) not after the previous one `prev` (ns).
fn not_after(stamps: StampSource, ns: i128, prev: i128) -> String {
    format!(
        "{} stamp {:.6} s is not after the previous one ({:+.6} s){}",
        match stamps {
            StampSource::Header => "header",
            StampSource::Receive => "receive",
        },
        ns as f64 * 1e-9,
        (ns - prev) as f64 * 1e-9,
        if ns == prev { ": a duplicate" } else { "" }
    )
}

/// Opens the bag at `path` (a rosbag2 directory, `.mcap` or `.db3`) and reads its joint
/// states ([`read_joint_states`]).
pub fn open_joint_states(
    path: &std::path::Path,
    topic: &str,
    joints: &[String],
    stamps: StampSource,
) -> Result<JointRecording, RecordingError> {
    let bag = Bag::open(path)?;
    read_joint_states(&bag, topic, joints, stamps)
}
