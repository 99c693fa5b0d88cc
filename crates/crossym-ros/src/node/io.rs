//! The I/O thread (tokio, one worker): the ros2-client spinner (graph, parameter
//! services), SIGINT/SIGTERM, and the node's log ([`NodeLog`]: console and `/rosout`, like
//! an rclcpp node) of what the control thread reports — each kind of rejection at once and
//! then at most once per second with a count, accepted condition changes, and transitions
//! read from the status snapshots (stale ↔ fresh, safety fallbacks, policy faults).

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::Receiver;
use std::time::Duration;

use super::control::ToIo;
use crate::dds;
use crate::log::{NodeLog, Severity, StatusWatch};
use crossym_control::node::InputGate;

/// The I/O thread's state: the log and what it needs to explain an event.
pub(super) struct IoSide {
    /// A gate of the node's configuration, used only to explain rejections (joint names,
    /// the trained condition box).
    pub(super) gate: InputGate,
    /// The controlled joint names.
    pub(super) names: Vec<String>,
    pub(super) watch: StatusWatch,
    pub(super) from_control: Receiver<ToIo>,
    pub(super) log: NodeLog,
}

impl IoSide {
    /// Logs one event of the control thread.
    fn on_event(&mut self, e: ToIo) {
        match e {
            ToIo::Status(s) => self.watch.observe(&s, &mut self.log),
            ToIo::JointStateRejected(r) => self.log.limited(
                r.describe(),
                Severity::Warn,
                &format!("rejected joint_states: {}", r.explain(&self.names)),
            ),
            ToIo::ConditionRejected {
                rejection: r,
                kept: a,
            } => {
                let why = self.gate.explain(&r);
                self.log.limited(
                    r.describe(),
                    Severity::Warn,
                    &format!(
                        "rejected symmetry_condition (keeping θ = {:.4} rad, λ = {}, σ = {:+}): {why}",
                        a.theta, a.scale, a.reflection
                    ),
                );
            }
            ToIo::ConditionAccepted(c) => self.log.log(
                Severity::Info,
                &format!(
                    "symmetry condition accepted: θ = {:.4} rad ({:.1}°), λ = {}, σ = {:+}",
                    c.theta,
                    c.theta.to_degrees(),
                    c.scale,
                    c.reflection
                ),
            ),
            ToIo::PoseRejected(r) => self.log.limited(
                "task_pose",
                Severity::Warn,
                &format!("rejected task_pose (keeping the condition in force): {r}"),
            ),
            ToIo::TfRefused(e) => self.log.limited(
                "tf",
                Severity::Warn,
                &format!("TF edge ignored: {e}"),
            ),
            ToIo::ConditionSource { from_pose, tilt } => self.log.log(
                Severity::Info,
                &if from_pose {
                    format!(
                        "conditions now from the task pose (the last source wins; object tilt {:.1}° ignored)",
                        tilt.to_degrees()
                    )
                } else {
                    "conditions now from symmetry_condition (the last source wins)".to_string()
                },
            ),
            ToIo::Undecodable { topic, error } => self.log.limited(
                "undecodable",
                Severity::Warn,
                &format!("{topic} not decodable: {error}"),
            ),
        }
    }

    /// Logs every event the control thread has sent so far.
    pub(super) fn drain(&mut self) {
        while let Ok(e) = self.from_control.try_recv() {
            self.on_event(e);
        }
    }

    /// The I/O loop: the spinner, signals, and every 20 ms the control thread's events and
    /// `stop`; returns on a signal or `stop`.
    pub(super) async fn serve(&mut self, spinner: ros2_client::Spinner, stop: &AtomicBool) {
        tokio::spawn(spinner.spin());
        let signals = dds::shutdown_signal();
        tokio::pin!(signals);
        let mut poll = tokio::time::interval(Duration::from_millis(20));
        loop {
            tokio::select! {
                _ = &mut signals => break,
                _ = poll.tick() => {
                    self.drain();
                    if stop.load(Ordering::Acquire) {
                        break;
                    }
                }
            }
        }
    }
}
