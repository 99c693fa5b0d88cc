//! One episode: the node core against the simulated robot, event by event, with every
//! published command checked against the episode's limits.

use std::collections::VecDeque;

use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

use crossym_control::safety::BoundRules;
use crossym_control::{Command, NodeCore, OutputMode};
use crossym_io::msg;
use crossym_math::kinematics::{JointLimits, NullSpaceTerm};
use crossym_policy::AnyPolicy;

use super::adversary::AdversaryOutput;
use super::plan::EpisodePlan;
use super::robot::SimRobot;
use super::tally::Tally;
use super::Geometry;

/// Runs one episode; the tally of its violations.
///
/// `rules` are the safety filter's bound rules: [`ExactBounds`](crossym_control::safety::ExactBounds)
/// for the node's own filter, a deliberate defect for a campaign that must catch it.
pub fn run_episode<R: BoundRules + Clone>(
    geometries: &[Geometry],
    mode: OutputMode,
    seed: u64,
    duration_s: f64,
    rules: R,
) -> Result<Tally, String> {
    let mut rng = StdRng::seed_from_u64(seed);
    let mut tally = Tally {
        episodes: 1,
        ..Default::default()
    };
    let plan = EpisodePlan::draw(geometries, mode, duration_s, &mut rng, &mut tally);
    let mut ep = Episode::new(&plan, mode, seed, rng, tally, rules)?;
    ep.robot.check_position(&mut ep.tally);
    let mut next_tick = plan.tick_phase_us;
    let mut next_state = 0i64;
    let mut t = 0i64;
    while t < plan.t_end_us {
        let next_st = ep.pending_states.front().map_or(i64::MAX, |p| p.0);
        let t_next = next_tick
            .min(next_state)
            .min(ep.robot.next_command_at())
            .min(next_st)
            .min(plan.t_end_us);
        ep.robot.integrate(t, t_next, &mut ep.tally);
        t = t_next;
        if t >= plan.t_end_us {
            break;
        }
        ep.robot.receive(t, &mut ep.tally);
        ep.deliver_states(t);
        // The robot publishes a joint state.
        if t == next_state {
            next_state += plan.state_period_us;
            ep.publish_state(t);
        }
        // The node ticks.
        if t == next_tick {
            next_tick += plan.transport.period_us;
            ep.tick(t);
        }
    }
    let mut tally = ep.tally;
    if !tally.clean() {
        tally.failing_seeds.push(seed);
    }
    Ok(tally)
}

/// An episode under way: the node core, the simulated robot, the joint states and commands
/// between them, and the tally so far.
struct Episode<'p, 'g, R: BoundRules> {
    plan: &'p EpisodePlan<'g>,
    seed: u64,
    rng: StdRng,
    tally: Tally,
    core: NodeCore<AdversaryOutput, R>,
    robot: SimRobot<'p>,
    /// Joint states on their way to the node, with their arrival times (µs).
    pending_states: VecDeque<(i64, msg::JointState)>,
    /// Commands dropped in a row.
    burst: usize,
    cmd: Command,
    stream: CommandStream,
}

impl<'p, 'g, R: BoundRules> Episode<'p, 'g, R> {
    fn new(
        plan: &'p EpisodePlan<'g>,
        mode: OutputMode,
        seed: u64,
        rng: StdRng,
        tally: Tally,
        rules: R,
    ) -> Result<Self, String> {
        let core = node_core(plan, seed, rules)?;
        let names = core.joint_names().to_vec();
        let position_robot = mode != OutputMode::Velocity;
        let robot = SimRobot::new(plan.start.clone(), names, &plan.limits, position_robot);
        let cmd = core.command();
        let stream = CommandStream::new(plan.limits.len(), plan.transport.period, position_robot);
        Ok(Self {
            plan,
            seed,
            rng,
            tally,
            core,
            robot,
            pending_states: VecDeque::new(),
            burst: 0,
            cmd,
            stream,
        })
    }

    /// Joint states arriving at the node at `t`.
    fn deliver_states(&mut self, t: i64) {
        while self.pending_states.front().is_some_and(|p| p.0 <= t) {
            let (_, m) = self.pending_states.pop_front().expect("front");
            let _ = self.core.on_joint_state(&m, t as f64 * 1e-6);
        }
    }

    /// The robot publishes a joint state at `t` (unless a fault silences it), delayed in
    /// transport but never overtaking the one before.
    fn publish_state(&mut self, t: i64) {
        let tr = &self.plan.transport;
        let fault = self.plan.fault_at(t);
        if let Some(m) = self.robot.publish(t, fault, tr.noise, &mut self.rng) {
            let d = if tr.state_delay > 0.0 {
                self.rng.random_range(0.0..=tr.state_delay)
            } else {
                0.0
            };
            let at = t + (d * 1e6) as i64;
            let at = self.pending_states.back().map_or(at, |p| p.0.max(at));
            self.pending_states.push_back((at, m));
        }
    }

    /// The node ticks at `t`; a published command is checked, then sent to the robot (or
    /// dropped in transport).
    fn tick(&mut self, t: i64) {
        let (tr, seed) = (&self.plan.transport, self.seed);
        let (limits, accel) = (&self.plan.limits, &self.plan.accel);
        let rep = self.core.tick(t as f64 * 1e-6, &mut self.cmd);
        self.tally.ticks += 1;
        if !rep.publish {
            return;
        }
        self.tally.commands += 1;
        let data = self.cmd.data().to_vec();
        let (robot, core) = (&self.robot, &self.core);
        let trace = |j: usize, a: f64, p: f64, v: f64| {
            eprintln!(
                "seed {seed} t {:.3} joint {j}: accel {a:.3} > {:.3} (v {p:.4} -> {v:.4}) code {:?} q {:.4} state {:?}",
                t as f64 * 1e-6, accel[j], rep.code, robot.q[j], core.joint_state().map(|(q, t)| (q[j], t))
            );
        };
        self.stream
            .check(&data, limits, accel, &mut self.tally, trace);
        // Transport to the robot.
        if tr.drop_p > 0.0 && self.burst < tr.max_burst && self.rng.random_bool(tr.drop_p) {
            self.burst += 1;
            return;
        }
        self.burst = 0;
        let lat = tr.lat_base
            + if tr.lat_jitter > 0.0 {
                self.rng.random_range(0.0..=tr.lat_jitter)
            } else {
                0.0
            };
        self.robot.send(t + (lat * 1e6) as i64, data);
    }
}

/// The published command stream as the robot sees it: velocities (or, for a position
/// robot, the velocities implied by successive positions) and their changes, checked
/// against the episode's limits.
struct CommandStream {
    period: f64,
    position: bool,
    /// The previous published (or implied) velocity.
    prev: Option<Vec<f64>>,
    /// The previous published position (position robot).
    prev_pos: Option<Vec<f64>>,
    implied: Vec<f64>,
}

impl CommandStream {
    fn new(n: usize, period: f64, position: bool) -> Self {
        Self {
            period,
            position,
            prev: None,
            prev_pos: None,
            implied: vec![0.0; n],
        }
    }

    /// Counts the non-finite values of command `data` and its velocity and acceleration
    /// violations; `trace(joint, acceleration, previous, current velocity)` is called for
    /// each acceleration violation under `CROSSYM_STRESS_TRACE`.
    fn check(
        &mut self,
        data: &[f64],
        limits: &[JointLimits],
        accel: &[f64],
        tally: &mut Tally,
        trace: impl Fn(usize, f64, f64, f64),
    ) {
        let (n, period) = (limits.len(), self.period);
        tally.nonfinite += data.iter().filter(|x| !x.is_finite()).count() as u64;
        let vel: &[f64] = if self.position {
            match &self.prev_pos {
                Some(p) => {
                    for j in 0..n {
                        self.implied[j] = (data[j] - p[j]) / period;
                    }
                    &self.implied
                }
                None => &[],
            }
        } else {
            data
        };
        if !vel.is_empty() {
            for j in 0..n {
                let e = vel[j].abs() - limits[j].velocity;
                if e > 1e-9 * limits[j].velocity + 1e-12 {
                    tally.velocity += 1;
                    tally.velocity_worst = tally.velocity_worst.max(e);
                }
            }
            if let Some(p) = &self.prev {
                for j in 0..n {
                    let a = (vel[j] - p[j]).abs() / period;
                    let e = a - accel[j];
                    if e > 1e-9 * accel[j] + 1e-9 {
                        if std::env::var_os("CROSSYM_STRESS_TRACE").is_some() {
                            trace(j, a, p[j], vel[j]);
                        }
                        tally.acceleration += 1;
                        tally.acceleration_worst = tally.acceleration_worst.max(e);
                    }
                }
            }
            self.prev = Some(vel.to_vec());
        }
        if self.position {
            self.prev_pos = Some(data.to_vec());
        }
    }
}

/// The node core of the episode: the plan's limits and settings, the condition sent, the
/// drawn adversary as its output stage and the filter's bound rules `rules`.
fn node_core<R: BoundRules>(
    plan: &EpisodePlan,
    seed: u64,
    rules: R,
) -> Result<NodeCore<AdversaryOutput, R>, String> {
    let g = plan.geometry;
    let kin = g
        .kinematics
        .clone()
        .with_limits(plan.limits.clone())
        .ok_or("limits of the wrong length")?;
    let safety = plan.node.safety;
    let vmax: Vec<f64> = plan.limits.iter().map(|l| l.velocity).collect();
    let output = AdversaryOutput::new(plan.adversary, vmax, plan.signs.clone(), seed);
    // A task head runs with its config's null-space term, against this episode's limits.
    let mut policy =
        AnyPolicy::new(g.policy.clone(), &kin).map_err(|e| format!("{}: {e}", g.name))?;
    if let Some((settings, rest)) = &g.null_space {
        let term = NullSpaceTerm::new(*settings, rest, kin.limits())
            .map_err(|e| format!("{}: {e}", g.name))?;
        policy = policy
            .with_null_space(term)
            .map_err(|e| format!("{}: {e}", g.name))?
            .0;
    }
    let mut core = NodeCore::with_stages(kin, policy, safety, plan.node.clone(), output, rules)
        .map_err(|e| format!("{}: {e}", g.name))?;
    let c = plan.condition;
    let _ = core.on_condition(&msg::SymmetryCondition {
        header: msg::Header::default(),
        theta: c.theta,
        scale: c.scale,
        reflection: c.reflection,
    });
    Ok(core)
}
