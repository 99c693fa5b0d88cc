//! The bag recorder of a running node: every input, command and status, handed over a
//! bounded channel (never blocking the sender) to a writer thread.

use std::path::Path;
use std::sync::atomic::Ordering;
use std::sync::Arc;
use std::thread;

use super::error::NodeRunError;
use crate::dds;
use crossym_control::node::OutputMode;
use crossym_io::bag::{BagError, BagWriter};
use crossym_io::msg;

/// A message for the bag recorder (sent off the tick over a bounded channel).
pub(super) enum RecordItem {
    JointState(msg::JointState, u64, u32),
    Condition(msg::SymmetryCondition, u64, u32),
    Array(msg::Float64MultiArray, u64, u32),
    Trajectory(msg::JointTrajectory, u64, u32),
    /// Boxed: the largest message, a few per second (its strings allocate anyway).
    Status(Box<msg::Status>, u64),
    /// The policy started or stopped (a lifecycle transition as the control thread applied
    /// it): replay applies it at the same point.
    Lifecycle(msg::TransitionEvent, u64),
}

/// The lifecycle events' topic (rcl's name).
pub const LIFECYCLE_TOPIC: &str = "~/transition_event";

/// The sending side of the recorder; `send` never blocks (drops and counts when full).
#[derive(Clone)]
pub(super) struct Recorder {
    pub(super) tx: std::sync::mpsc::SyncSender<RecordItem>,
    pub(super) dropped: Arc<std::sync::atomic::AtomicU64>,
}

impl Recorder {
    pub(super) fn send(&self, item: RecordItem) {
        if self.tx.try_send(item).is_err() {
            self.dropped.fetch_add(1, Ordering::Relaxed);
        }
    }
}

/// Opens the bag and starts the writer thread; returns the sender and the thread handle.
pub(super) fn start_recorder(
    dir: &Path,
    cfg: &crossym_control::NodeConfig,
) -> Result<(Recorder, thread::JoinHandle<Result<u64, BagError>>), NodeRunError> {
    use crossym_io::bag::Qos;
    let mut w = BagWriter::create(dir).map_err(|e| NodeRunError::Runtime {
        message: format!("recording: {e}"),
    })?;
    let name = |t: &str| dds::expand_topic(t, &cfg.namespace, &cfg.name);
    let topics = (|| -> Result<_, BagError> {
        let js =
            w.add_topic::<msg::JointState>(&name(&cfg.topics.joint_states), Qos::best_effort(5))?;
        let cond = w.add_topic::<msg::SymmetryCondition>(
            &name(&cfg.topics.symmetry_condition),
            Qos::reliable(10),
        )?;
        let cmd = match cfg.output {
            OutputMode::Trajectory => {
                w.add_topic::<msg::JointTrajectory>(&name(&cfg.topics.command), Qos::reliable(10))?
            }
            _ => w.add_topic::<msg::Float64MultiArray>(
                &name(&cfg.topics.command),
                Qos::reliable(10),
            )?,
        };
        let status = w.add_topic::<msg::Status>(&name(&cfg.topics.status), Qos::reliable(10))?;
        let life =
            w.add_topic::<msg::TransitionEvent>(&name(LIFECYCLE_TOPIC), Qos::reliable(10))?;
        Ok((js, cond, cmd, status, life))
    })()
    .map_err(|e| NodeRunError::Runtime {
        message: format!("recording: {e}"),
    })?;
    let (tx, rx) = std::sync::mpsc::sync_channel::<RecordItem>(4096);
    let handle = thread::Builder::new()
        .name("crossym-bag".into())
        .spawn(move || {
            let (js, cond, cmd, status, life) = topics;
            let mut first_err: Option<BagError> = None;
            for item in rx {
                let r = match item {
                    RecordItem::JointState(m, t, q) => w.write(js, &m, t, q),
                    RecordItem::Condition(m, t, q) => w.write(cond, &m, t, q),
                    RecordItem::Array(m, t, q) => w.write(cmd, &m, t, q),
                    RecordItem::Trajectory(m, t, q) => w.write(cmd, &m, t, q),
                    RecordItem::Status(m, t) => w.write(status, &m, t, 0),
                    RecordItem::Lifecycle(m, t) => w.write(life, &m, t, 0),
                };
                if let Err(e) = r {
                    first_err.get_or_insert(e);
                }
            }
            let n = w.message_count();
            w.finish()?;
            match first_err {
                Some(e) => Err(e),
                None => Ok(n),
            }
        })
        .map_err(|e| NodeRunError::Runtime {
            message: format!("bag thread: {e}"),
        })?;
    Ok((
        Recorder {
            tx,
            dropped: Arc::new(std::sync::atomic::AtomicU64::new(0)),
        },
        handle,
    ))
}
