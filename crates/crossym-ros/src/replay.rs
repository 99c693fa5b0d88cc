//! Offline replay: feeds a recorded run's inputs through the node's logic without DDS and
//! compares the commands it computes with the recorded ones.
//!
//! Joint states and conditions go through an [`crossym_control::InputGate`] at their log times
//! (the node records the receipt time it validated them with), producing the same sequence
//! of input snapshots the node's I/O side produced. Each recorded command names, in its
//! MCAP `sequence`, the snapshot its tick used ([`crossym_control::Inputs::command_sequence`]);
//! the tick is re-run at the command's log time (the tick's clock) and the outputs compared
//! per joint; the final shutdown command (sequence bit 31) is recomputed as such. With the same policy and config the result is bit-identical.

use std::collections::VecDeque;

use crossym_control::node::{Command, InputGate, Inputs, SHUTDOWN_SEQUENCE_BIT};
use crossym_control::{NodeCore, OutputMode};
use crossym_io::bag::{Bag, BagError};
use crossym_io::msg;

/// Topics of the node being replayed (absolute names).
#[derive(Debug, Clone)]
pub struct ReplayTopics {
    /// Joint states.
    pub joint_states: String,
    /// Conditions.
    pub condition: String,
    /// `~/transition_event`: where the policy started or stopped (lifecycle).
    pub lifecycle: String,
    /// Commands.
    pub command: String,
}

impl ReplayTopics {
    /// The absolute topic names of a node configured by `n`.
    pub fn for_node(n: &crossym_control::NodeConfig) -> Self {
        let name = |t: &str| crate::dds::expand_topic(t, &n.namespace, &n.name);
        Self {
            joint_states: name(&n.topics.joint_states),
            condition: name(&n.topics.symmetry_condition),
            command: name(&n.topics.command),
            lifecycle: name(crate::node::LIFECYCLE_TOPIC),
        }
    }
}

/// Outcome of a replay.
#[derive(Debug, Clone, PartialEq)]
pub struct ReplayReport {
    /// Joint-state and condition messages fed (count).
    pub inputs: usize,
    /// Commands recomputed and compared (count).
    pub commands: usize,
    /// Commands whose input snapshot was not found (count).
    pub unmatched: usize,
    /// Largest |recorded − recomputed| per joint (rad/s or rad).
    pub max_abs_deviation: Vec<f64>,
}

impl ReplayReport {
    /// The largest deviation over all joints.
    pub fn max(&self) -> f64 {
        self.max_abs_deviation.iter().copied().fold(0.0, f64::max)
    }
}

/// Replays `bag` through `core` (built from the same config and policy as the recording).
pub fn replay(
    bag: &Bag,
    core: &mut NodeCore,
    topics: &ReplayTopics,
) -> Result<ReplayReport, BagError> {
    let missing = |t: &str| BagError::NotRos2 {
        path: bag.path.clone(),
        message: format!("no topic {t} in the bag"),
    };
    let js = bag
        .topic(&topics.joint_states)
        .ok_or_else(|| missing(&topics.joint_states))?;
    let cmd_topic = bag
        .topic(&topics.command)
        .ok_or_else(|| missing(&topics.command))?;
    let cond = bag.topic(&topics.condition);
    let life = bag.topic(&topics.lifecycle);
    crate::node::lifecycle::apply_autostart(core);
    let mut r = Replay::new(bag, core, topics, cmd_topic);
    for (i, m) in bag.messages.iter().enumerate() {
        let now = m.log_ns as f64 * 1e-9;
        if m.topic == js {
            let s: msg::JointState = bag.decode(i)?;
            let _ = r.gate.on_joint_state(&s, now);
        } else if Some(m.topic) == cond {
            let s: msg::SymmetryCondition = bag.decode(i)?;
            let _ = r.gate.on_condition(&s);
        } else if Some(m.topic) == life {
            // A lifecycle transition as the node applied it (between two ticks).
            let e: msg::TransitionEvent = bag.decode(i)?;
            let active = e.goal_state.id == crate::node::lifecycle::Primary::Active.id();
            let _ = core.apply(crossym_control::node::OperatorRequest::Activate(active));
            continue;
        } else if m.topic == cmd_topic {
            r.on_command(core, i, m.sequence, now)?;
            continue;
        } else {
            continue;
        }
        r.on_input();
    }
    Ok(r.report)
}

/// A replay between two messages: the gate, the input snapshots no recorded command has
/// used yet, the command buffer and the report so far.
struct Replay<'a> {
    bag: &'a Bag,
    topics: &'a ReplayTopics,
    cmd_topic: usize,
    mode: OutputMode,
    n: usize,
    gate: InputGate,
    history: VecDeque<Inputs>,
    cmd: Command,
    report: ReplayReport,
}

impl<'a> Replay<'a> {
    fn new(bag: &'a Bag, core: &NodeCore, topics: &'a ReplayTopics, cmd_topic: usize) -> Self {
        let n = core.joint_names().len();
        let gate = core.input_gate();
        let mut history: VecDeque<Inputs> = VecDeque::new();
        history.push_back(gate.inputs().clone());
        Self {
            bag,
            topics,
            cmd_topic,
            mode: core.config().output,
            n,
            gate,
            history,
            cmd: core.command(),
            report: ReplayReport {
                inputs: 0,
                commands: 0,
                unmatched: 0,
                max_abs_deviation: vec![0.0; n],
            },
        }
    }

    /// An input message went through the gate: its snapshot is kept (the last 4096).
    fn on_input(&mut self) {
        self.report.inputs += 1;
        self.history.push_back(self.gate.inputs().clone());
        if self.history.len() > 4096 {
            self.history.pop_front();
        }
    }

    /// The recorded command `i` (MCAP `sequence`, logged at `now`): its tick re-run on the
    /// snapshot it names and the outputs compared.
    fn on_command(
        &mut self,
        core: &mut NodeCore,
        i: usize,
        sequence: u32,
        now: f64,
    ) -> Result<(), BagError> {
        let recorded = self.recorded(i)?;
        let shutdown = sequence & SHUTDOWN_SEQUENCE_BIT != 0;
        let seq = sequence & !SHUTDOWN_SEQUENCE_BIT;
        let Some(k) = self
            .history
            .iter()
            .rposition(|s| s.command_sequence() == seq)
        else {
            self.report.unmatched += 1;
            return Ok(());
        };
        core.load_inputs(&self.history[k]);
        self.history.drain(..k);
        if shutdown {
            core.shutdown_command(&mut self.cmd);
        } else {
            core.tick(now, &mut self.cmd);
        }
        self.report.commands += 1;
        self.compare(i, &recorded)
    }

    /// The values of recorded command `i` (a trajectory's last point).
    fn recorded(&self, i: usize) -> Result<Vec<f64>, BagError> {
        Ok(match self.mode {
            OutputMode::Velocity | OutputMode::Position => {
                self.bag.decode::<msg::Float64MultiArray>(i)?.data
            }
            OutputMode::Trajectory => self
                .bag
                .decode::<msg::JointTrajectory>(i)?
                .points
                .last()
                .map(|p| p.positions.clone())
                .unwrap_or_default(),
        })
    }

    /// Folds |recorded − recomputed| per joint into the report (NaN counts as infinite).
    fn compare(&mut self, i: usize, recorded: &[f64]) -> Result<(), BagError> {
        let n = self.n;
        let data = self.cmd.data();
        if recorded.len() != n {
            return Err(BagError::Decode {
                path: self.bag.path.clone(),
                topic: self.topics.command.clone(),
                ros_type: self.bag.topics[self.cmd_topic].ros_type.clone(),
                index: i,
                message: format!("{} values, the node controls {n} joints", recorded.len()),
            });
        }
        for j in 0..n {
            let d = (recorded[j] - data[j]).abs();
            let d = if d.is_nan() { f64::INFINITY } else { d };
            self.report.max_abs_deviation[j] = self.report.max_abs_deviation[j].max(d);
        }
        Ok(())
    }
}
