//! Fault campaign (`crossym stress`): randomized closed-loop episodes of the node's core
//! ([`NodeCore`], no DDS) and a simulated robot, counting every limit violation.
//!
//! The robot here is independent of the node and of [`super::MockHardware`]: it keeps time
//! in integer microseconds, integrates velocity commands exactly (piecewise constant
//! between events, so a position's extremes lie at event times) or jumps to position
//! commands (an ideal servo), holds the last command it received, and enforces nothing.
//! Commands reach it after a drawn latency (in order; some dropped), joint states reach the
//! node after a drawn delay. The checks use only the episode's limits:
//!
//! - **position**: the robot's true position beyond `[lower, upper]` (not the margin);
//! - **velocity**: a velocity command, or the implied velocity `(p_k − p_{k−1})/Δt` of
//!   position commands, beyond `v_max`;
//! - **acceleration**: `(u_k − u_{k−1})/Δt` of successive published velocities (or implied
//!   velocities) beyond `a_max`;
//! - **non-finite**: any published value that is NaN or infinite.
//!
//! The final shutdown command is not part of an episode. Each episode draws its geometry,
//! output mode, limits (tight: rest ± 0.15–0.5 rad, 0.2–1 × the velocity limit; or the
//! robot's own), a start state (anywhere inside, some joints within 0–5 mrad of a bound),
//! a condition (trained, or extrapolated with `accept_untrained_conditions`), a policy (the
//! real one or an adversary) and input faults (see [`Fault`]). The node's
//! `safety.latency_s` and `safety.state_delay_s` are set to the envelope the episode's
//! transport can reach: the guarantee is stated for that envelope.

use std::collections::VecDeque;

use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use rayon::prelude::*;

use crossym_control::safety::FilterDefect;
use crossym_control::{NodeConfig, NodeCore, OutputMode};
use crossym_io::msg;
use crossym_learn::policy::{ConditionDomain, Policy};
use crossym_math::kinematics::{JointLimits, Kinematics};
use crossym_math::symmetry::compose::Condition;

/// One robot the campaign can draw: kinematics, a policy for it and the node's settings.
#[derive(Clone)]
pub struct Geometry {
    /// Short name for the report (e.g. `planar`, `rby1`).
    pub name: String,
    /// Kinematics with the robot's own limits.
    pub kinematics: Kinematics,
    /// The policy the node runs when the episode draws the real one.
    pub policy: Policy,
    /// The node settings of the robot's config.
    pub node: NodeConfig,
    /// Rest posture (rad or m), the centre of tight limits.
    pub rest: Vec<f64>,
}

/// What a campaign runs.
#[derive(Debug, Clone)]
pub struct StressSettings {
    /// Episodes per output mode.
    pub episodes: usize,
    /// Seed of the whole campaign (episode `k` of mode `m` is reproducible from it).
    pub seed: u64,
    /// Output modes to run.
    pub modes: Vec<OutputMode>,
    /// Simulated time per episode (s).
    pub duration_s: f64,
    /// A deliberate filter defect (tests that must see the campaign fail).
    pub defect: FilterDefect,
}

impl Default for StressSettings {
    fn default() -> Self {
        Self {
            episodes: 1000,
            seed: 1,
            modes: vec![
                OutputMode::Velocity,
                OutputMode::Position,
                OutputMode::Trajectory,
            ],
            duration_s: 3.0,
            defect: FilterDefect::None,
        }
    }
}

/// An input fault active over a time window.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Fault {
    /// One controlled joint's position is NaN.
    NanPosition(usize),
    /// One controlled joint is missing from the message.
    MissingJoint(usize),
    /// One controlled joint appears twice.
    DuplicateJoint(usize),
    /// One controlled joint carries another name.
    RenamedJoint(usize),
    /// The driver republishes its last message unchanged (stamp included).
    Frozen,
    /// No joint states.
    Silent,
    /// Stamps lie this far (s) in the future.
    FutureStamp(f64),
    /// Stamps lie this far (s) in the past.
    PastStamp(f64),
}

impl Fault {
    fn name(&self) -> &'static str {
        match self {
            Fault::NanPosition(_) => "nan",
            Fault::MissingJoint(_) => "missing",
            Fault::DuplicateJoint(_) => "duplicate",
            Fault::RenamedJoint(_) => "renamed",
            Fault::Frozen => "frozen",
            Fault::Silent => "silent",
            Fault::FutureStamp(_) => "future stamp",
            Fault::PastStamp(_) => "past stamp",
        }
    }
}

/// The adversarial policies an episode can draw instead of the real one.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Adversary {
    /// The trained policy.
    Real,
    /// 10 × the velocity limit toward one bound per joint.
    TowardLimit,
    /// NaN outputs on some ticks.
    Nan,
    /// ±1e9.
    Huge,
    /// ±∞.
    Infinite,
    /// Gaussian noise, 5 × the velocity limit.
    Noise,
    /// ±5 × the velocity limit, the sign flipping every tick.
    SignFlip,
}

const ADVERSARIES: [Adversary; 7] = [
    Adversary::Real,
    Adversary::TowardLimit,
    Adversary::Nan,
    Adversary::Huge,
    Adversary::Infinite,
    Adversary::Noise,
    Adversary::SignFlip,
];

/// Counts of one episode or a sum of them.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Tally {
    /// Episodes (count).
    pub episodes: u64,
    /// Node ticks (count).
    pub ticks: u64,
    /// Commands published (count).
    pub commands: u64,
    /// Position violations (count of robot samples beyond a limit).
    pub position: u64,
    /// Worst position excess beyond a limit (rad or m).
    pub position_worst: f64,
    /// Velocity violations (count).
    pub velocity: u64,
    /// Worst velocity excess (rad/s or m/s).
    pub velocity_worst: f64,
    /// Acceleration violations (count).
    pub acceleration: u64,
    /// Worst acceleration excess (rad/s² or m/s²).
    pub acceleration_worst: f64,
    /// Non-finite published values (count).
    pub nonfinite: u64,
    /// Input faults injected, by kind (name, count).
    pub faults: Vec<(&'static str, u64)>,
    /// Adversarial policies drawn, by kind (name, count).
    pub adversaries: Vec<(&'static str, u64)>,
    /// Episodes on tight limits (count).
    pub tight: u64,
    /// Episodes with an extrapolated condition (count).
    pub untrained: u64,
    /// Episodes starting within 5 mrad of a bound (count).
    pub near_bound: u64,
    /// Episodes with dropped commands (count).
    pub with_drops: u64,
    /// Seeds of the episodes with a violation (at most 20).
    pub failing_seeds: Vec<u64>,
}

impl Tally {
    /// True when nothing was violated.
    pub fn clean(&self) -> bool {
        self.position == 0 && self.velocity == 0 && self.acceleration == 0 && self.nonfinite == 0
    }

    fn bump(list: &mut Vec<(&'static str, u64)>, name: &'static str, by: u64) {
        match list.iter_mut().find(|(n, _)| *n == name) {
            Some((_, c)) => *c += by,
            None => list.push((name, by)),
        }
    }

    fn add(&mut self, o: &Tally) {
        self.episodes += o.episodes;
        self.ticks += o.ticks;
        self.commands += o.commands;
        self.position += o.position;
        self.position_worst = self.position_worst.max(o.position_worst);
        self.velocity += o.velocity;
        self.velocity_worst = self.velocity_worst.max(o.velocity_worst);
        self.acceleration += o.acceleration;
        self.acceleration_worst = self.acceleration_worst.max(o.acceleration_worst);
        self.nonfinite += o.nonfinite;
        for &(n, c) in &o.faults {
            Self::bump(&mut self.faults, n, c);
        }
        for &(n, c) in &o.adversaries {
            Self::bump(&mut self.adversaries, n, c);
        }
        self.tight += o.tight;
        self.untrained += o.untrained;
        self.near_bound += o.near_bound;
        self.with_drops += o.with_drops;
        for &s in &o.failing_seeds {
            if self.failing_seeds.len() < 20 {
                self.failing_seeds.push(s);
            }
        }
    }
}

/// The campaign's result per output mode.
#[derive(Debug, Clone)]
pub struct StressReport {
    /// (mode, its tally), in the order of [`StressSettings::modes`].
    pub modes: Vec<(OutputMode, Tally)>,
}

impl StressReport {
    /// True when no mode saw a violation.
    pub fn clean(&self) -> bool {
        self.modes.iter().all(|(_, t)| t.clean())
    }
}

/// The seed of episode `k` of mode index `m` in a campaign seeded `seed`.
pub fn episode_seed(seed: u64, m: usize, k: usize) -> u64 {
    // SplitMix64 of the triple: distinct, well-mixed seeds.
    let mut z = seed
        .wrapping_mul(0x9E37_79B9_7F4A_7C15)
        .wrapping_add((m as u64) << 40)
        .wrapping_add(k as u64);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Runs the campaign over `geometries` (episodes in parallel).
pub fn run_campaign(geometries: &[Geometry], s: &StressSettings) -> Result<StressReport, String> {
    if geometries.is_empty() {
        return Err("no geometry to run".into());
    }
    let mut modes = Vec::new();
    for (m, &mode) in s.modes.iter().enumerate() {
        let tallies: Result<Vec<Tally>, String> = (0..s.episodes)
            .into_par_iter()
            .map(|k| {
                let seed = episode_seed(s.seed, m, k);
                run_episode(geometries, mode, seed, s.duration_s, s.defect)
            })
            .collect();
        let mut total = Tally::default();
        for t in tallies? {
            total.add(&t);
        }
        modes.push((mode, total));
    }
    Ok(StressReport { modes })
}

/// The episode's draw of limits: tight around the rest posture or the robot's own.
fn draw_limits(
    g: &Geometry,
    rng: &mut StdRng,
    tight: bool,
    default_accel: f64,
) -> Vec<JointLimits> {
    g.kinematics
        .limits()
        .iter()
        .zip(&g.rest)
        .map(|(l, &r)| {
            let mut l = *l;
            if tight {
                let lo = r - rng.random_range(0.15..0.5);
                let hi = r + rng.random_range(0.15..0.5);
                l.lower = lo.max(l.lower);
                l.upper = hi.min(l.upper);
                l.velocity *= rng.random_range(0.2..1.0);
                l.acceleration =
                    Some(l.acceleration.unwrap_or(default_accel) * rng.random_range(0.1..1.0));
            }
            l
        })
        .collect()
}

struct Pending {
    at_us: i64,
    data: Vec<f64>,
}

/// Runs one episode; the tally of its violations.
pub fn run_episode(
    geometries: &[Geometry],
    mode: OutputMode,
    seed: u64,
    duration_s: f64,
    defect: FilterDefect,
) -> Result<Tally, String> {
    let mut rng = StdRng::seed_from_u64(seed);
    let g = &geometries[rng.random_range(0..geometries.len())];
    let n = g.kinematics.dof();
    let mut tally = Tally {
        episodes: 1,
        ..Default::default()
    };
    let default_accel = g.node.safety.default_acceleration;
    let tight = rng.random_bool(0.6);
    tally.tight = u64::from(tight);
    let limits = draw_limits(g, &mut rng, tight, default_accel);
    let accel: Vec<f64> = limits
        .iter()
        .map(|l| l.acceleration.unwrap_or(default_accel))
        .collect();

    // Transport: command latency, jitter, drops (bursts capped), state delay.
    let period = g.node.period_s;
    let period_us = (period * 1e6).round() as i64;
    let lat_base = rng.random_range(0.0..=3.0) * period;
    let lat_jitter = if rng.random_bool(0.5) {
        rng.random_range(0.0..=1.0) * period
    } else {
        0.0
    };
    let (drop_p, max_burst) = if rng.random_bool(0.3) {
        (rng.random_range(0.05..0.3), rng.random_range(1..=3usize))
    } else {
        (0.0, 0)
    };
    tally.with_drops = u64::from(drop_p > 0.0);
    let state_delay = if rng.random_bool(0.5) {
        rng.random_range(0.0..=2.0) * period
    } else {
        0.0
    };
    let noise = if rng.random_bool(0.5) {
        rng.random_range(0.0..1e-4)
    } else {
        0.0
    };

    // The node, configured for that envelope.
    let mut node = g.node.clone();
    node.output = mode;
    node.safety.latency_s = Some(lat_base + lat_jitter + max_burst as f64 * period + 2e-6);
    node.safety.state_delay_s = state_delay + 2e-6;
    node.check_stamps = true;
    let domain = ConditionDomain::from_meta(&g.policy.meta).ok().flatten();
    let untrained = rng.random_bool(0.3);
    tally.untrained = u64::from(untrained);
    let condition = if untrained {
        node.accept_untrained_conditions = true;
        Condition {
            theta: rng.random_range(-std::f64::consts::PI..std::f64::consts::PI),
            scale: rng.random_range(0.3..2.0),
            reflection: if rng.random_bool(0.5) { 1 } else { -1 },
        }
    } else {
        match &domain {
            Some(d) => Condition {
                theta: rng.random_range(-1.0..=1.0) * d.max_abs_theta.min(std::f64::consts::PI),
                scale: rng.random_range(d.scale_min..=d.scale_max),
                reflection: if d.reflection && rng.random_bool(0.5) {
                    -1
                } else {
                    1
                },
            },
            None => Condition::IDENTITY,
        }
    };
    node.default_condition = if domain.is_some() && !untrained {
        condition
    } else {
        node.default_condition
    };
    if untrained {
        node.default_condition = Condition::IDENTITY;
    }
    let kin = g
        .kinematics
        .clone()
        .with_limits(limits.clone())
        .ok_or("limits of the wrong length")?;
    let safety = node.safety;
    let mut core = NodeCore::new(kin, g.policy.clone(), safety, node.clone())
        .map_err(|e| format!("{}: {e}", g.name))?;
    core.inject_filter_defect(defect);
    let _ = core.on_condition(&msg::SymmetryCondition {
        header: msg::Header::default(),
        theta: condition.theta,
        scale: condition.scale,
        reflection: condition.reflection,
    });

    // The adversary.
    let adversary = ADVERSARIES[rng.random_range(0..ADVERSARIES.len())];
    Tally::bump(&mut tally.adversaries, adversary_name(adversary), 1);
    if adversary != Adversary::Real {
        let vmax: Vec<f64> = limits.iter().map(|l| l.velocity).collect();
        let signs: Vec<f64> = (0..n)
            .map(|_| if rng.random_bool(0.5) { 1.0 } else { -1.0 })
            .collect();
        let mut arng = StdRng::seed_from_u64(seed ^ 0xAD5E);
        core.set_policy_override(Some(Box::new(move |tick, _q, v| {
            for j in 0..v.len() {
                v[j] = match adversary {
                    Adversary::Real => v[j],
                    Adversary::TowardLimit => 10.0 * vmax[j] * signs[j],
                    Adversary::Nan => {
                        if arng.random_bool(0.5) {
                            f64::NAN
                        } else {
                            10.0 * vmax[j] * signs[j]
                        }
                    }
                    Adversary::Huge => 1e9 * signs[j],
                    Adversary::Infinite => f64::INFINITY * signs[j],
                    Adversary::Noise => {
                        let u1: f64 = arng.random::<f64>().max(1e-300);
                        let u2: f64 = arng.random();
                        5.0 * vmax[j]
                            * (-2.0 * u1.ln()).sqrt()
                            * (2.0 * std::f64::consts::PI * u2).cos()
                    }
                    Adversary::SignFlip => {
                        let s = if tick % 2 == 0 { 1.0 } else { -1.0 };
                        5.0 * vmax[j] * signs[j] * s
                    }
                };
            }
        })));
    }

    // Start state: inside the limits, some joints within 5 mrad of a bound.
    let mut q: Vec<f64> = (0..n)
        .map(|j| {
            let l = &limits[j];
            let (lo, hi) = (l.lower.max(g.rest[j] - 1.0), l.upper.min(g.rest[j] + 1.0));
            if rng.random_bool(0.5) {
                g.rest[j].clamp(lo, hi)
            } else {
                rng.random_range(lo..=hi)
            }
        })
        .collect();
    if rng.random_bool(0.4) {
        tally.near_bound = 1;
        for _ in 0..rng.random_range(1..=3usize) {
            let j = rng.random_range(0..n);
            let d = rng.random_range(0.0..0.005);
            q[j] = if rng.random_bool(0.5) {
                limits[j].upper - d
            } else {
                limits[j].lower + d
            };
        }
    }

    // Input faults: up to four windows.
    let t_end_us = (duration_s * 1e6) as i64;
    let mut faults: Vec<(i64, i64, Fault)> = Vec::new();
    for _ in 0..rng.random_range(0..=4usize) {
        let start = rng.random_range(0..t_end_us.max(1));
        let len = (rng.random_range(0.05..1.0) * 1e6) as i64;
        let j = rng.random_range(0..n);
        let f = match rng.random_range(0..8) {
            0 => Fault::NanPosition(j),
            1 => Fault::MissingJoint(j),
            2 => Fault::DuplicateJoint(j),
            3 => Fault::RenamedJoint(j),
            4 => Fault::Frozen,
            5 => Fault::Silent,
            6 => Fault::FutureStamp(rng.random_range(0.005..1.0)),
            _ => Fault::PastStamp(rng.random_range(0.005..0.09)),
        };
        Tally::bump(&mut tally.faults, f.name(), 1);
        faults.push((start, start + len, f));
    }
    let active = |t: i64| {
        faults
            .iter()
            .find(|(a, b, _)| t >= *a && t < *b)
            .map(|x| x.2)
    };

    // The simulated robot.
    let names = core.joint_names().to_vec();
    let position_robot = mode != OutputMode::Velocity;
    let mut robot_cmd = vec![0.0; n];
    let mut pending_cmds: VecDeque<Pending> = VecDeque::new();
    let mut pending_states: VecDeque<(i64, msg::JointState)> = VecDeque::new();
    let mut last_state: Option<msg::JointState> = None;
    let mut last_arrival = i64::MIN;
    let mut burst = 0usize;
    let tick_phase = rng.random_range(0..period_us);
    let state_period_us = if rng.random_bool(0.5) {
        period_us
    } else {
        period_us / 2
    };
    let mut next_tick = tick_phase;
    let mut next_state = 0i64;
    let mut t = 0i64;
    let mut cmd = core.command();
    let mut prev: Option<Vec<f64>> = None; // previous published velocity (or implied)
    let mut prev_pos: Option<Vec<f64>> = None;
    let mut implied = vec![0.0; n];

    let check_position = |q: &[f64], tally: &mut Tally| {
        for j in 0..n {
            let l = &limits[j];
            let e = (q[j] - l.upper).max(l.lower - q[j]);
            if e > 1e-9 {
                if std::env::var_os("CROSSYM_STRESS_TRACE").is_some() && tally.position < 3 {
                    eprintln!(
                        "position joint {j}: {:.5} outside [{:.4}, {:.4}] by {e:.2e}",
                        q[j], l.lower, l.upper
                    );
                }
                tally.position += 1;
                tally.position_worst = tally.position_worst.max(e);
            }
        }
    };
    check_position(&q, &mut tally);

    while t < t_end_us {
        let next_cmd = pending_cmds.front().map_or(i64::MAX, |p| p.at_us);
        let next_st = pending_states.front().map_or(i64::MAX, |p| p.0);
        let t_next = next_tick
            .min(next_state)
            .min(next_cmd)
            .min(next_st)
            .min(t_end_us);
        // Integrate the robot up to t_next (velocity constant in between).
        if !position_robot && t_next > t {
            let h = (t_next - t) as f64 * 1e-6;
            for j in 0..n {
                q[j] += robot_cmd[j] * h;
            }
            check_position(&q, &mut tally);
        }
        t = t_next;
        if t >= t_end_us {
            break;
        }
        // Commands arriving now.
        while pending_cmds.front().is_some_and(|p| p.at_us <= t) {
            let p = pending_cmds.pop_front().expect("front");
            robot_cmd.copy_from_slice(&p.data);
            if position_robot {
                q.copy_from_slice(&p.data);
                check_position(&q, &mut tally);
            }
        }
        // Joint states arriving at the node now.
        while pending_states.front().is_some_and(|p| p.0 <= t) {
            let (_, m) = pending_states.pop_front().expect("front");
            let _ = core.on_joint_state(&m, t as f64 * 1e-6);
        }
        // The robot publishes a joint state.
        if t == next_state {
            next_state += state_period_us;
            let fault = active(t);
            let stamp_s = t as f64 * 1e-6;
            let m = match fault {
                Some(Fault::Silent) => None,
                Some(Fault::Frozen) => last_state.clone(),
                _ => {
                    let mut name = names.clone();
                    let mut position: Vec<f64> = q
                        .iter()
                        .map(|&x| {
                            if noise > 0.0 {
                                let u1: f64 = rng.random::<f64>().max(1e-300);
                                let u2: f64 = rng.random();
                                x + noise
                                    * (-2.0 * u1.ln()).sqrt()
                                    * (2.0 * std::f64::consts::PI * u2).cos()
                            } else {
                                x
                            }
                        })
                        .collect();
                    let mut stamp = stamp_s;
                    match fault {
                        Some(Fault::NanPosition(j)) => position[j] = f64::NAN,
                        Some(Fault::MissingJoint(j)) => {
                            name.remove(j);
                            position.remove(j);
                        }
                        Some(Fault::DuplicateJoint(j)) => {
                            name.push(name[j].clone());
                            position.push(position[j] + 0.1);
                        }
                        Some(Fault::RenamedJoint(j)) => name[j] = format!("{}_renamed", name[j]),
                        Some(Fault::FutureStamp(d)) => stamp += d,
                        Some(Fault::PastStamp(d)) => stamp -= d,
                        _ => {}
                    }
                    let m = msg::JointState {
                        header: msg::Header {
                            stamp: msg::Time::from_secs_f64(stamp.max(1e-6)),
                            frame_id: String::new(),
                        },
                        name,
                        position,
                        velocity: Vec::new(),
                        effort: Vec::new(),
                    };
                    last_state = Some(m.clone());
                    Some(m)
                }
            };
            if let Some(m) = m {
                let d = if state_delay > 0.0 {
                    rng.random_range(0.0..=state_delay)
                } else {
                    0.0
                };
                let at = t + (d * 1e6) as i64;
                let at = pending_states.back().map_or(at, |p| p.0.max(at));
                pending_states.push_back((at, m));
            }
        }
        // The node ticks.
        if t == next_tick {
            next_tick += period_us;
            let rep = core.tick(t as f64 * 1e-6, &mut cmd);
            tally.ticks += 1;
            if !rep.publish {
                continue;
            }
            tally.commands += 1;
            let data = cmd.data().to_vec();
            tally.nonfinite += data.iter().filter(|x| !x.is_finite()).count() as u64;
            // Velocity and acceleration of the published stream.
            let vel: &[f64] = if position_robot {
                match &prev_pos {
                    Some(p) => {
                        for j in 0..n {
                            implied[j] = (data[j] - p[j]) / period;
                        }
                        &implied
                    }
                    None => &[],
                }
            } else {
                &data
            };
            if !vel.is_empty() {
                for j in 0..n {
                    let e = vel[j].abs() - limits[j].velocity;
                    if e > 1e-9 * limits[j].velocity + 1e-12 {
                        tally.velocity += 1;
                        tally.velocity_worst = tally.velocity_worst.max(e);
                    }
                }
                if let Some(p) = &prev {
                    for j in 0..n {
                        let a = (vel[j] - p[j]).abs() / period;
                        let e = a - accel[j];
                        if e > 1e-9 * accel[j] + 1e-9 {
                            if std::env::var_os("CROSSYM_STRESS_TRACE").is_some() {
                                eprintln!(
                                    "seed {seed} t {:.3} joint {j}: accel {a:.3} > {:.3} (v {:.4} -> {:.4}) code {:?} q {:.4} state {:?}",
                                    t as f64 * 1e-6, accel[j], p[j], vel[j], rep.code, q[j], core.joint_state().map(|(q, t)| (q[j], t))
                                );
                            }
                            tally.acceleration += 1;
                            tally.acceleration_worst = tally.acceleration_worst.max(e);
                        }
                    }
                }
                prev = Some(vel.to_vec());
            }
            if position_robot {
                prev_pos = Some(data.clone());
            }
            // Transport to the robot.
            if drop_p > 0.0 && burst < max_burst && rng.random_bool(drop_p) {
                burst += 1;
                continue;
            }
            burst = 0;
            let lat = lat_base
                + if lat_jitter > 0.0 {
                    rng.random_range(0.0..=lat_jitter)
                } else {
                    0.0
                };
            let at = (t + (lat * 1e6) as i64).max(last_arrival);
            last_arrival = at;
            pending_cmds.push_back(Pending { at_us: at, data });
        }
    }
    if !tally.clean() {
        tally.failing_seeds.push(seed);
    }
    Ok(tally)
}

fn adversary_name(a: Adversary) -> &'static str {
    match a {
        Adversary::Real => "real policy",
        Adversary::TowardLimit => "toward limit",
        Adversary::Nan => "NaN",
        Adversary::Huge => "±1e9",
        Adversary::Infinite => "±∞",
        Adversary::Noise => "noise",
        Adversary::SignFlip => "sign flips",
    }
}

/// The report as a Markdown table (one row per mode) with the fault mix below it.
pub fn report_table(r: &StressReport) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "| mode | episodes | ticks | commands | position viol. (worst) | velocity viol. (worst) | acceleration viol. (worst) | non-finite |"
    );
    let _ = writeln!(s, "|---|---:|---:|---:|---:|---:|---:|---:|");
    for (mode, t) in &r.modes {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} ({:.2e}) | {} ({:.2e}) | {} ({:.2e}) | {} |",
            mode_name(*mode),
            t.episodes,
            t.ticks,
            t.commands,
            t.position,
            t.position_worst,
            t.velocity,
            t.velocity_worst,
            t.acceleration,
            t.acceleration_worst,
            t.nonfinite
        );
    }
    let mut all = Tally::default();
    for (_, t) in &r.modes {
        all.add(t);
    }
    let list = |v: &[(&str, u64)]| {
        v.iter()
            .map(|(n, c)| format!("{n} {c}"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let _ = writeln!(
        s,
        "\nepisodes: {} on tight limits, {} with an extrapolated condition, {} starting within 5 mrad of a bound, {} with dropped commands",
        all.tight, all.untrained, all.near_bound, all.with_drops
    );
    let _ = writeln!(s, "policies: {}", list(&all.adversaries));
    let _ = writeln!(s, "input fault windows: {}", list(&all.faults));
    if !all.failing_seeds.is_empty() {
        let _ = writeln!(
            s,
            "episodes with a violation (seeds): {:?}",
            all.failing_seeds
        );
    }
    s
}

/// `velocity`, `position` or `trajectory`.
pub fn mode_name(m: OutputMode) -> &'static str {
    match m {
        OutputMode::Velocity => "velocity",
        OutputMode::Position => "position",
        OutputMode::Trajectory => "trajectory",
    }
}
