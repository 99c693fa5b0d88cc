//! The I/O thread (tokio, one worker): the ros2-client spinner (graph, parameter
//! services), SIGINT/SIGTERM, and the node's log ([`NodeLog`]: console and `/rosout`, like
//! an rclcpp node) of what the control thread reports — each kind of rejection at once and
//! then at most once per second with a count, accepted condition changes, and transitions
//! read from the status snapshots (stale ↔ fresh, safety fallbacks, policy faults).

use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use std::sync::mpsc::{Receiver, SyncSender};
use std::sync::Arc;
use std::time::Duration;

use super::control::ToIo;
use super::lifecycle::{
    all_states, transition_graph, ChangeStateResponse, GetAvailableStatesResponse,
    GetAvailableTransitionsResponse, GetStateResponse, Lifecycle, LifecycleServices,
};
use super::params::Operator;
use super::services::{Services, SetBoolResponse, TriggerResponse};
use crate::dds;
use crate::log::{NodeLog, StatusWatch};
use crossym_control::node::{InputGate, OperatorRequest};
use crossym_control::Severity;

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
    /// Accepted parameter sets (from ros2-client's parameter service).
    pub(super) ops: Receiver<Operator>,
    /// Operator requests for the control thread.
    pub(super) to_control: SyncSender<(OperatorRequest, &'static str)>,
    /// `~/pause`, `~/reset`.
    pub(super) services: Services,
    /// Whether the last `~/pause` request paused.
    pub(super) paused: bool,
    /// The lifecycle state machine.
    pub(super) lifecycle: Lifecycle,
    /// `~/change_state`, `~/get_state`, … and `~/transition_event`.
    pub(super) lifecycle_services: LifecycleServices,
    /// Subscribers matched on the command topic, for the control thread (`u32::MAX`: not
    /// known yet).
    pub(super) command_subscribers: Arc<AtomicU32>,
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
            ToIo::Operator {
                request,
                source,
                result,
            } => match result {
                Ok(()) => self
                    .log
                    .log(Severity::Info, &format!("{source}: {} (applied)", describe(&request))),
                Err(e) => self.log.log(
                    Severity::Warn,
                    &format!("{source}: {} refused: {e}", describe(&request)),
                ),
            },
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

    /// Logs every event the control thread has sent so far; passes the accepted parameter
    /// sets on.
    pub(super) fn drain(&mut self) {
        while let Ok(op) = self.ops.try_recv() {
            match op {
                Operator::LogLevel(l) => {
                    self.log.set_min(l);
                    self.log.log(
                        Severity::Info,
                        &format!("parameter: log_level = {l:?} (applied)"),
                    );
                }
                Operator::Node { request, source } => {
                    self.forward(request, source);
                }
                Operator::Refused { name, reason } => self.log.log(
                    Severity::Warn,
                    &format!("parameter: set of `{name}` refused: {reason}"),
                ),
            }
        }
        while let Ok(e) = self.from_control.try_recv() {
            self.on_event(e);
        }
    }

    /// Hands a request to the control thread; false when its queue is full.
    fn forward(&mut self, request: OperatorRequest, source: &'static str) -> bool {
        if self.to_control.try_send((request, source)).is_err() {
            self.log.log(
                Severity::Warn,
                &format!(
                    "{source}: {} dropped: the control thread's queue is full",
                    describe(&request)
                ),
            );
            return false;
        }
        true
    }

    /// `~/pause` (`data`: pause or resume) from `caller`.
    fn on_pause(&mut self, data: bool, caller: &str) -> SetBoolResponse {
        self.log
            .log(Severity::Info, &format!("~/pause {data} from {caller}"));
        let was = self.paused;
        if !self.forward(OperatorRequest::Pause(data), "service") {
            return SetBoolResponse {
                success: false,
                message: "not applied: the control thread's queue is full".into(),
            };
        }
        self.paused = data;
        let message = match (was, data) {
            (false, true) => "pausing: braking to zero at the acceleration limits, then holding",
            (true, true) => "already paused",
            (true, false) => "resuming: the policy from the measured state",
            (false, false) => "not paused: nothing to resume",
        };
        SetBoolResponse {
            success: true,
            message: message.into(),
        }
    }

    /// `~/reset` from `caller`.
    fn on_reset(&mut self, caller: &str) -> TriggerResponse {
        self.log
            .log(Severity::Info, &format!("~/reset from {caller}"));
        let success = self.forward(OperatorRequest::Reset, "service");
        TriggerResponse {
            success,
            message: if success {
                "reset: a latched ROBOT_NOT_FOLLOWING is cleared; commands start again from the measured state".into()
            } else {
                "not applied: the control thread's queue is full".into()
            },
        }
    }

    /// `~/change_state` (a transition by id, or by label when one is given) from `caller`:
    /// takes it, hands the start or stop of the policy to the control thread, publishes the
    /// two transition events.
    fn on_change_state(&mut self, id: u8, label: &str, caller: &str) -> ChangeStateResponse {
        let change = match self.lifecycle.change(id, label) {
            Ok(c) => c,
            Err(e) => {
                self.log.log(
                    Severity::Warn,
                    &format!("~/change_state from {caller} refused: {e}"),
                );
                return ChangeStateResponse { success: false };
            }
        };
        if let Some(active) = change.activation() {
            if !self.forward(
                OperatorRequest::Activate(active),
                super::lifecycle::source_of(&change),
            ) {
                // Not applied: the state stays where the node is.
                self.lifecycle = Lifecycle::new(change.from);
                return ChangeStateResponse { success: false };
            }
        }
        self.log.log(
            Severity::Info,
            &format!(
                "lifecycle: {} → {} ({} from {caller}){}",
                change.from.label(),
                change.to.label(),
                change.events[0].transition.label,
                match change.activation() {
                    Some(true) => ": the policy runs from the measured state",
                    Some(false) => ": braking to zero, then no command",
                    None => "",
                }
            ),
        );
        for e in change.events {
            let ev = crossym_io::msg::TransitionEvent {
                timestamp: dds::wall_time_ns(),
                transition: e.transition,
                start_state: e.start_state,
                goal_state: e.goal_state,
            };
            if let Err(err) = self.lifecycle_services.events.publish(ev) {
                self.log.log(
                    Severity::Warn,
                    &format!("~/transition_event not published: {err:?}"),
                );
            }
        }
        ChangeStateResponse { success: true }
    }

    /// Answers the four lifecycle queries and `~/change_state`; `false` when no request
    /// came (nothing to do).
    async fn serve_lifecycle(&mut self, which: LifecycleRequest) {
        let s = &self.lifecycle_services;
        let sent = match which {
            LifecycleRequest::Change(id, req) => {
                let r = self.on_change_state(
                    req.transition.id,
                    &req.transition.label,
                    &format!("{:?}", id.writer_gid),
                );
                self.lifecycle_services
                    .change_state
                    .async_send_response(id, r)
                    .await
            }
            LifecycleRequest::GetState(id) => {
                let r = GetStateResponse {
                    current_state: self.lifecycle.state().state(),
                };
                s.get_state.async_send_response(id, r).await
            }
            LifecycleRequest::States(id) => {
                let r = GetAvailableStatesResponse {
                    available_states: all_states(),
                };
                s.get_available_states.async_send_response(id, r).await
            }
            LifecycleRequest::Transitions(id) => {
                let r = GetAvailableTransitionsResponse {
                    available_transitions: self.lifecycle.available_transitions(),
                };
                s.get_available_transitions.async_send_response(id, r).await
            }
            LifecycleRequest::Graph(id) => {
                let r = GetAvailableTransitionsResponse {
                    available_transitions: transition_graph(),
                };
                s.get_transition_graph.async_send_response(id, r).await
            }
        };
        if let Err(e) = sent {
            self.log.log(
                Severity::Warn,
                &format!("lifecycle: response not sent: {e:?}"),
            );
        }
    }

    /// The I/O loop: the spinner, signals, and every 20 ms the control thread's events and
    /// `stop`; returns on a signal or `stop`.
    /// `matched` counts the subscribers matched on the command topic (read every 20 ms and
    /// handed to the control thread).
    pub(super) async fn serve(
        &mut self,
        spinner: ros2_client::Spinner,
        stop: &AtomicBool,
        matched: &dyn Fn() -> usize,
    ) {
        tokio::spawn(spinner.spin());
        let signals = dds::shutdown_signal();
        tokio::pin!(signals);
        let mut poll = tokio::time::interval(Duration::from_millis(20));
        loop {
            tokio::select! {
                _ = &mut signals => break,
                r = self.services.pause.async_receive_request() => match r {
                    Ok((id, req)) => {
                        let resp = self.on_pause(req.data, &format!("{:?}", id.writer_gid));
                        if let Err(e) = self.services.pause.async_send_response(id, resp).await {
                            self.log.log(Severity::Warn, &format!("~/pause: response not sent: {e:?}"));
                        }
                    }
                    Err(e) => self.log.limited("service", Severity::Warn, &format!("~/pause: bad request: {e:?}")),
                },
                r = self.services.reset.async_receive_request() => match r {
                    Ok((id, _)) => {
                        let resp = self.on_reset(&format!("{:?}", id.writer_gid));
                        if let Err(e) = self.services.reset.async_send_response(id, resp).await {
                            self.log.log(Severity::Warn, &format!("~/reset: response not sent: {e:?}"));
                        }
                    }
                    Err(e) => self.log.limited("service", Severity::Warn, &format!("~/reset: bad request: {e:?}")),
                },
                r = self.lifecycle_services.change_state.async_receive_request() => match r {
                    Ok((id, req)) => self.serve_lifecycle(LifecycleRequest::Change(id, req)).await,
                    Err(e) => self.log.limited("service", Severity::Warn, &format!("~/change_state: bad request: {e:?}")),
                },
                r = self.lifecycle_services.get_state.async_receive_request() => match r {
                    Ok((id, _)) => self.serve_lifecycle(LifecycleRequest::GetState(id)).await,
                    Err(e) => self.log.limited("service", Severity::Warn, &format!("~/get_state: bad request: {e:?}")),
                },
                r = self.lifecycle_services.get_available_states.async_receive_request() => match r {
                    Ok((id, _)) => self.serve_lifecycle(LifecycleRequest::States(id)).await,
                    Err(e) => self.log.limited("service", Severity::Warn, &format!("~/get_available_states: bad request: {e:?}")),
                },
                r = self.lifecycle_services.get_available_transitions.async_receive_request() => match r {
                    Ok((id, _)) => self.serve_lifecycle(LifecycleRequest::Transitions(id)).await,
                    Err(e) => self.log.limited("service", Severity::Warn, &format!("~/get_available_transitions: bad request: {e:?}")),
                },
                r = self.lifecycle_services.get_transition_graph.async_receive_request() => match r {
                    Ok((id, _)) => self.serve_lifecycle(LifecycleRequest::Graph(id)).await,
                    Err(e) => self.log.limited("service", Severity::Warn, &format!("~/get_transition_graph: bad request: {e:?}")),
                },
                _ = poll.tick() => {
                    let n = matched().min(u32::MAX as usize - 1) as u32;
                    self.command_subscribers.store(n, Ordering::Release);
                    self.drain();
                    self.log.flush_due();
                    if stop.load(Ordering::Acquire) {
                        break;
                    }
                }
            }
        }
    }
}

/// A lifecycle service request to answer.
enum LifecycleRequest {
    Change(
        ros2_client::service::RmwRequestId,
        super::lifecycle::ChangeStateRequest,
    ),
    GetState(ros2_client::service::RmwRequestId),
    States(ros2_client::service::RmwRequestId),
    Transitions(ros2_client::service::RmwRequestId),
    Graph(ros2_client::service::RmwRequestId),
}

/// One line for an operator request.
fn describe(r: &OperatorRequest) -> String {
    match r {
        OperatorRequest::Activate(true) => "activate".into(),
        OperatorRequest::Activate(false) => "deactivate".into(),
        OperatorRequest::Pause(true) => "pause".into(),
        OperatorRequest::Pause(false) => "resume".into(),
        OperatorRequest::Reset => "reset".into(),
        OperatorRequest::VelocityScale(s) => format!("velocity_scale = {s}"),
        OperatorRequest::StaleTimeout(t) => format!("stale_timeout_s = {t}"),
        OperatorRequest::AcceptUntrained(a) => format!("accept_untrained_conditions = {a}"),
        OperatorRequest::Margin(m) => format!("safety.margin = {m}"),
        OperatorRequest::DefaultCondition(c) => format!(
            "default_condition = [θ {}, λ {}, σ {:+}]",
            c.theta, c.scale, c.reflection
        ),
    }
}
