//! Position, velocity, acceleration and braking: the filter's commands drive a simulated
//! robot that integrates them (after a latency, from old states), and the checks read only
//! the joint limits and what the robot did.

use std::collections::VecDeque;

use crossym_control::safety::{Anchor, SafetyFilter, SafetySettings, SafetyStatus};
use crossym_math::kinematics::JointLimits;
use nalgebra::DMatrix;
use proptest::prelude::*;

use crate::support::{accel, config, joint, unit_range};

/// Slack for rounding in the checks (rad, rad/s).
const EPS: f64 = 1e-9;

/// One episode of a hostile policy against the filter.
#[derive(Debug, Clone)]
struct Episode {
    limits: Vec<JointLimits>,
    /// Where each joint starts, as a fraction of its range inside the margins.
    start: Vec<f64>,
    /// Each joint's push, in velocity limits (reversed halfway), and its wobble.
    push: Vec<(f64, f64)>,
    dt: f64,
    margin: f64,
    default_accel: f64,
    /// Periods a command takes to reach the robot (velocity commands).
    latency: usize,
    /// Periods a joint state is old when it reaches the filter (velocity commands).
    delay: usize,
    /// Position commands: the robot sits at the last commanded position.
    commanded: bool,
    /// A 2 × n task Jacobian (the QP path), or none (the clamp).
    jacobian: Option<Vec<f64>>,
}

fn episode() -> impl Strategy<Value = Episode> {
    (1usize..5).prop_flat_map(|n| {
        (
            prop::collection::vec(joint(0.1..3.0), n),
            prop::collection::vec(0.0..=1.0f64, n),
            prop::collection::vec((-10.0..10.0f64, 0.0..3.0f64), n),
            (0.002..0.02f64, 0.0..0.02f64, 1.0..30.0f64),
            (0usize..4, 0usize..3, any::<bool>()),
            prop::option::of(prop::collection::vec(-2.0..2.0f64, 2 * n)),
        )
            .prop_map(
                |(
                    limits,
                    start,
                    push,
                    (dt, margin, default_accel),
                    (latency, delay, commanded),
                    jacobian,
                )| {
                    Episode {
                        limits,
                        start,
                        push,
                        dt,
                        margin,
                        default_accel,
                        latency,
                        delay,
                        commanded,
                        jacobian,
                    }
                },
            )
    })
}

/// The policy's velocity for joint `i` at tick `k` of `ticks`: a push toward one side
/// (reversed halfway), a wobble, and now and then a non-finite or huge value.
fn policy(e: &Episode, i: usize, k: usize, ticks: usize) -> f64 {
    let (push, wobble) = e.push[i];
    let vmax = e.limits[i].velocity;
    let side = if k < ticks / 2 { 1.0 } else { -1.0 };
    match (k + 7 * i) % 41 {
        0 => f64::NAN,
        1 => f64::INFINITY,
        2 => -1e12,
        _ => vmax * (side * push + wobble * (0.3 * k as f64 + i as f64).sin()),
    }
}

/// The robot: positions integrated from the commands it runs, each reaching it `latency`
/// periods after it was issued (it runs the last one received).
struct Robot {
    q: Vec<f64>,
    /// Positions at the start of each period so far.
    past: Vec<Vec<f64>>,
    in_flight: VecDeque<Vec<f64>>,
    running: Vec<f64>,
}

impl Robot {
    fn step(&mut self, command: &[f64], dt: f64) {
        self.in_flight.push_back(command.to_vec());
        if let Some(c) = self.in_flight.pop_front() {
            self.running = c;
        }
        for (q, v) in self.q.iter_mut().zip(&self.running) {
            *q += v * dt;
        }
        self.past.push(self.q.clone());
    }
}

/// Runs `e` for `ticks` periods of the policy, then brakes (no usable state) until the
/// robot stands still; asserts every limit on every period. Returns the ticks run.
fn run(e: &Episode, ticks: usize) -> Result<usize, TestCaseError> {
    let n = e.limits.len();
    let dt = e.dt;
    let settings = SafetySettings {
        dt,
        margin: e.margin,
        default_acceleration: e.default_accel,
        latency_s: Some(e.latency as f64 * dt + 1e-9),
        ..SafetySettings::default()
    };
    let mut filter = SafetyFilter::new(&e.limits, settings).unwrap();
    let q0: Vec<f64> = (0..n)
        .map(|i| {
            let l = &e.limits[i];
            l.lower + e.margin + e.start[i] * (l.upper - l.lower - 2.0 * e.margin)
        })
        .collect();
    let latency = if e.commanded { 0 } else { e.latency };
    let mut robot = Robot {
        q: q0.clone(),
        past: vec![q0],
        in_flight: (0..latency).map(|_| vec![0.0; n]).collect(),
        running: vec![0.0; n],
    };
    let jac = e
        .jacobian
        .as_ref()
        .map(|j| DMatrix::from_row_slice(2, n, j));
    let a: Vec<f64> = e.limits.iter().map(|l| accel(l, e.default_accel)).collect();
    let (mut out, mut prev, mut v) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    let slowest = (0..n)
        .map(|i| e.limits[i].velocity / (a[i] * dt))
        .fold(0.0, f64::max);
    let braking = slowest.ceil() as usize + latency + 2;
    for k in 0..ticks + braking {
        let now = k as f64 * dt;
        if k < ticks {
            for (i, v) in v.iter_mut().enumerate() {
                *v = policy(e, i, k, ticks);
            }
            let seen = k.saturating_sub(e.delay);
            let anchor = if e.commanded {
                Anchor::Commanded { q: &robot.q }
            } else {
                Anchor::Measured {
                    q: &robot.past[seen],
                    time_s: seen as f64 * dt,
                }
            };
            let report = filter.filter(now, anchor, &v, jac.as_ref(), None, &mut out);
            prop_assert_ne!(report.status, SafetyStatus::InvalidState);
        } else {
            prop_assert_eq!(filter.brake(now, &mut out).status, SafetyStatus::Braking);
            for i in 0..n {
                // Toward zero, never past it.
                prop_assert!(out[i] * prev[i] >= 0.0 && out[i].abs() <= prev[i].abs());
            }
        }
        for i in 0..n {
            let l = &e.limits[i];
            prop_assert!(
                out[i].is_finite(),
                "tick {}: joint {} command {}",
                k,
                i,
                out[i]
            );
            prop_assert!(
                out[i].abs() <= l.velocity + EPS,
                "tick {}: joint {} at {} rad/s, limit {}",
                k,
                i,
                out[i],
                l.velocity
            );
            let step = (out[i] - prev[i]).abs();
            prop_assert!(
                step <= a[i] * dt * (1.0 + 1e-9) + EPS,
                "tick {}: joint {} changed by {} rad/s in one period, limit {} rad/s²",
                k,
                i,
                step,
                a[i]
            );
        }
        robot.step(&out, dt);
        for i in 0..n {
            let (l, q) = (&e.limits[i], robot.q[i]);
            prop_assert!(
                q <= l.upper - e.margin + EPS && q >= l.lower + e.margin - EPS,
                "tick {}: joint {} at {}, limits [{}, {}] less margin {}",
                k,
                i,
                q,
                l.lower,
                l.upper,
                e.margin
            );
        }
        prev.copy_from_slice(&out);
    }
    prop_assert!(
        out.iter().all(|&x| x == 0.0),
        "still moving after braking: {:?}",
        out
    );
    Ok(ticks + braking)
}

proptest! {
    #![proptest_config(config(256))]

    /// Never past a position (less the margin), velocity or acceleration limit, while the
    /// policy pushes and while the filter brakes for want of a state: with commands that
    /// reach the robot late, states that are old, position or velocity commands, and with
    /// or without the weighted QP.
    #[test]
    fn a_robot_driven_by_the_filter_stays_within_every_limit(e in episode()) {
        run(&e, 150)?;
    }
}

/// Largest `x` with `travel(x) ≤ d` (`travel` increasing), by bisection on `[lo, hi]`.
fn largest_within(d: f64, lo: f64, hi: f64, travel: impl Fn(f64) -> f64) -> f64 {
    let (mut lo, mut hi) = (lo, hi);
    if travel(lo) > d {
        return f64::NEG_INFINITY;
    }
    for _ in 0..200 {
        let m = 0.5 * (lo + hi);
        if travel(m) <= d {
            lo = m;
        } else {
            hi = m;
        }
    }
    lo
}

/// One joint's case for a single tick of position commands.
#[derive(Debug, Clone)]
struct Tick {
    limits: JointLimits,
    /// Commanded position (may lie beyond a limit).
    q: f64,
    /// The last command, in velocity limits.
    last: f64,
    /// The policy's velocity, in velocity limits (NaN: not finite).
    v: f64,
}

fn tick(n: usize) -> impl Strategy<Value = Vec<Tick>> {
    prop::collection::vec(
        (
            joint(1.0..3.0),
            -0.2..1.2f64,
            -1.0..=1.0f64,
            prop_oneof![4 => -3.0..3.0f64, 1 => Just(f64::NAN)],
        )
            .prop_map(|(limits, at, last, v)| Tick {
                q: limits.lower + at * (limits.upper - limits.lower),
                limits,
                last,
                v,
            }),
        n,
    )
}

proptest! {
    #![proptest_config(config(256))]

    /// One tick of position commands (the robot at the commanded `q`, last command `u`),
    /// each joint on its own: the command lies in the acceleration box around `u` and
    /// the velocity box, and it is the policy's velocity clamped to the documented braking
    /// bound `x·Δt + (x⁺)²/(2a) ≤ q_max − margin − q` (mirrored below), found here by
    /// bisection; where that bound lies outside the box the joint brakes at `a`. Whatever
    /// the command, the exact discrete braking plan after it stops before the limit.
    #[test]
    fn one_tick_is_the_clamp_to_the_braking_bound(
        ticks in (1usize..7).prop_flat_map(tick),
        dt in 0.002..0.02f64,
        margin in 0.0..0.05f64,
        default_accel in 1.0..30.0f64,
    ) {
        let limits: Vec<JointLimits> = ticks.iter().map(|t| t.limits).collect();
        let settings = SafetySettings { dt, margin, default_acceleration: default_accel, ..SafetySettings::default() };
        let mut filter = SafetyFilter::new(&limits, settings).unwrap();
        let last: Vec<f64> = ticks.iter().map(|t| t.last * t.limits.velocity).collect();
        filter.reset(&last);
        let q: Vec<f64> = ticks.iter().map(|t| t.q).collect();
        let v: Vec<f64> = ticks.iter().map(|t| t.v * t.limits.velocity).collect();
        let mut out = vec![0.0; q.len()];
        let report = filter.filter(0.0, Anchor::Commanded { q: &q }, &v, None, None, &mut out);
        prop_assert_eq!(report.policy_nonfinite, v.iter().any(|x| !x.is_finite()));
        for (i, t) in ticks.iter().enumerate() {
            let (l, u, x) = (&t.limits, last[i], out[i]);
            let a = accel(l, default_accel);
            let box_lo = (-l.velocity).max(u - a * dt);
            let box_hi = l.velocity.min(u + a * dt);
            prop_assert!(x >= box_lo - EPS && x <= box_hi + EPS, "joint {}: {} outside [{}, {}]", i, x, box_lo, box_hi);
            // The documented bound, from the travel it keeps below the distance.
            let travel = |x: f64| x * dt + x.max(0.0).powi(2) / (2.0 * a);
            let far = 1e3;
            let hi = largest_within(l.upper - margin - q[i], -far, far, travel);
            let lo = -largest_within(q[i] - l.lower - margin, -far, far, travel);
            let v = if v[i].is_finite() { v[i] } else { 0.0 };
            let expected = if hi < box_lo {
                box_lo
            } else if lo > box_hi {
                box_hi
            } else {
                v.clamp(box_lo.max(lo), box_hi.min(hi))
            };
            prop_assert!((x - expected).abs() <= 1e-9 * (1.0 + expected.abs()),
                "joint {}: {} where the braking clamp gives {} (bounds [{}, {}])", i, x, expected, lo, hi);
            // The plan the bound promises: x for one period, then a·Δt less each period.
            let mut stop = q[i];
            let mut s = x;
            while s.abs() > 0.0 {
                stop += s * dt;
                s = if s > 0.0 { (s - a * dt).max(0.0) } else { (s + a * dt).min(0.0) };
            }
            let inside = stop <= l.upper - margin + EPS && stop >= l.lower + margin - EPS;
            let braking_hardest = x == box_lo || x == box_hi;
            prop_assert!(inside || braking_hardest,
                "joint {}: stops at {} past [{}, {}] less {}", i, stop, l.lower, l.upper, margin);
        }
    }
}

#[test]
fn a_state_that_is_not_a_number_brakes_every_joint() {
    let mut limits = unit_range(3, 2.0, Some(4.0));
    limits[1].acceleration = None;
    let settings = SafetySettings::default();
    let (dt, default_accel) = (settings.dt, settings.default_acceleration);
    let mut filter = SafetyFilter::new(&limits, settings).unwrap();
    let last = [1.5, -0.02, 0.0];
    let mut out = [9.0; 3];
    for (q, now) in [([0.0, f64::NAN, 0.0], 0.0), ([0.0; 3], f64::INFINITY)] {
        filter.reset(&last);
        let report = filter.filter(
            now,
            Anchor::Commanded { q: &q },
            &[2.0; 3],
            None,
            None,
            &mut out,
        );
        assert_eq!(report.status, SafetyStatus::InvalidState);
        // Toward zero by a·Δt (4 rad/s², the default 10 for joint 1), never past it.
        assert_eq!(out[0], 1.5 - 4.0 * dt);
        assert_eq!(out[1], (-0.02 + default_accel * dt).min(0.0));
        assert_eq!(out[2], 0.0);
        assert_eq!(filter.last_command(), &out);
    }
}

#[test]
fn a_policy_inside_every_bound_passes_bit_for_bit() {
    let limits = unit_range(4, 1.0, Some(10.0));
    let mut filter = SafetyFilter::new(&limits, SafetySettings::default()).unwrap();
    let v = [0.05, -0.03, 0.0999, -0.1];
    let jac = DMatrix::from_fn(3, 4, |r, c| (r as f64 - c as f64) * 0.3);
    let mut out = [0.0; 4];
    let anchor = Anchor::Measured {
        q: &[0.0, 0.5, -0.5, 0.9],
        time_s: 0.0,
    };
    let report = filter.filter(0.0, anchor, &v, Some(&jac), None, &mut out);
    assert_eq!(report.status, SafetyStatus::Passthrough);
    assert_eq!(report.iterations, 0);
    assert_eq!(out, v);
}
