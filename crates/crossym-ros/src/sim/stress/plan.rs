//! What an episode draws before it runs: the robot, its limits, the transport, the node's
//! settings for that envelope, the condition, the adversary, the start state, the input
//! fault windows and the phases of ticks and joint states. The draws come from the
//! episode's one random stream in a fixed order (an episode is reproducible from its seed).

use rand::rngs::StdRng;
use rand::Rng;

use crossym_control::{NodeConfig, OutputMode};
use crossym_math::kinematics::JointLimits;
use crossym_math::symmetry::compose::Condition;
use crossym_policy::ConditionDomain;

use super::adversary::{Adversary, ADVERSARIES};
use super::robot::Fault;
use super::tally::Tally;
use super::Geometry;

/// Command latency, jitter and drops toward the robot, joint-state delay and noise.
pub(super) struct Transport {
    /// The node's period (s) and in µs.
    pub period: f64,
    pub period_us: i64,
    /// Command latency (s): `lat_base + U(0, lat_jitter)`.
    pub lat_base: f64,
    pub lat_jitter: f64,
    /// Probability of dropping a command, and the longest burst of drops.
    pub drop_p: f64,
    pub max_burst: usize,
    /// Joint-state delay `U(0, state_delay)` (s).
    pub state_delay: f64,
    /// Standard deviation of the published positions' noise (rad or m).
    pub noise: f64,
}

/// One episode, drawn.
pub(super) struct EpisodePlan<'g> {
    pub geometry: &'g Geometry,
    /// The episode's limits (tight or the robot's own) and their accelerations.
    pub limits: Vec<JointLimits>,
    pub accel: Vec<f64>,
    pub transport: Transport,
    /// The node's settings for the transport's envelope.
    pub node: NodeConfig,
    /// The condition sent to the node.
    pub condition: Condition,
    pub adversary: Adversary,
    /// One sign per joint for the adversary (empty for the real policy).
    pub signs: Vec<f64>,
    /// The robot's start state.
    pub start: Vec<f64>,
    /// Input fault windows `[from, to)` (µs).
    pub faults: Vec<(i64, i64, Fault)>,
    /// Simulated time of the episode (µs).
    pub t_end_us: i64,
    /// Time of the first tick (µs) and the joint states' period (µs).
    pub tick_phase_us: i64,
    pub state_period_us: i64,
}

impl<'g> EpisodePlan<'g> {
    /// Draws an episode of output mode `mode` over `geometries` from `rng`, counting what
    /// it drew in `tally`.
    pub fn draw(
        geometries: &'g [Geometry],
        mode: OutputMode,
        duration_s: f64,
        rng: &mut StdRng,
        tally: &mut Tally,
    ) -> Self {
        let g = &geometries[rng.random_range(0..geometries.len())];
        let n = g.kinematics.dof();
        let default_accel = g.node.safety.default_acceleration;
        let tight = rng.random_bool(0.6);
        tally.tight = u64::from(tight);
        let limits = draw_limits(g, rng, tight, default_accel);
        let accel: Vec<f64> = limits
            .iter()
            .map(|l| l.acceleration.unwrap_or(default_accel))
            .collect();
        let transport = Transport::draw(g.node.period_s, rng);
        tally.with_drops = u64::from(transport.drop_p > 0.0);
        let (node, condition) = node_for(g, mode, &transport, rng, tally);
        let adversary = ADVERSARIES[rng.random_range(0..ADVERSARIES.len())];
        Tally::bump(&mut tally.adversaries, adversary.name(), 1);
        let signs: Vec<f64> = if adversary != Adversary::Real {
            (0..n)
                .map(|_| if rng.random_bool(0.5) { 1.0 } else { -1.0 })
                .collect()
        } else {
            Vec::new()
        };
        let start = draw_start(g, &limits, rng, tally);
        let t_end_us = (duration_s * 1e6) as i64;
        let faults = draw_faults(n, t_end_us, rng, tally);
        let tick_phase_us = rng.random_range(0..transport.period_us);
        let state_period_us = if rng.random_bool(0.5) {
            transport.period_us
        } else {
            transport.period_us / 2
        };
        Self {
            geometry: g,
            limits,
            accel,
            transport,
            node,
            condition,
            adversary,
            signs,
            start,
            faults,
            t_end_us,
            tick_phase_us,
            state_period_us,
        }
    }

    /// The input fault active at `t` (µs), if any.
    pub fn fault_at(&self, t: i64) -> Option<Fault> {
        self.faults
            .iter()
            .find(|(a, b, _)| t >= *a && t < *b)
            .map(|x| x.2)
    }
}

impl Transport {
    fn draw(period: f64, rng: &mut StdRng) -> Self {
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
        Self {
            period,
            period_us,
            lat_base,
            lat_jitter,
            drop_p,
            max_burst,
            state_delay,
            noise,
        }
    }
}

/// The node's settings for the transport's envelope, and the condition it is sent
/// (trained, or extrapolated with `accept_untrained_conditions`).
fn node_for(
    g: &Geometry,
    mode: OutputMode,
    tr: &Transport,
    rng: &mut StdRng,
    tally: &mut Tally,
) -> (NodeConfig, Condition) {
    let mut node = g.node.clone();
    node.output = mode;
    node.safety.latency_s =
        Some(tr.lat_base + tr.lat_jitter + tr.max_burst as f64 * tr.period + 2e-6);
    node.safety.state_delay_s = tr.state_delay + 2e-6;
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
    (node, condition)
}

/// Start state: inside the limits, some joints within 5 mrad of a bound.
fn draw_start(
    g: &Geometry,
    limits: &[JointLimits],
    rng: &mut StdRng,
    tally: &mut Tally,
) -> Vec<f64> {
    let n = limits.len();
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
    q
}

/// Input faults: up to four windows.
fn draw_faults(
    n: usize,
    t_end_us: i64,
    rng: &mut StdRng,
    tally: &mut Tally,
) -> Vec<(i64, i64, Fault)> {
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
    faults
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
