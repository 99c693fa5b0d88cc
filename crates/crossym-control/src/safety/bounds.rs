//! Per-joint velocity bounds for one control period: velocity, acceleration and
//! position limits that hold over the whole time a command can act.
//!
//! For joint `i` with limits `[q_min, q_max]`, `|q̇| ≤ v_max`, `|q̈| ≤ a_max`, period `Δt`,
//! last command `u`:
//!
//! - velocity: `−v_max ≤ x ≤ v_max`;
//! - acceleration relative to the last command: `u − a_max δ ≤ x ≤ u + a_max δ`, `δ` the
//!   time since it (at most `Δt`);
//! - position over the horizon ([`Horizon`]): the state `q` was measured `age` seconds ago,
//!   since then the robot ran commands no larger than `M_a`, until the new command `x`
//!   arrives (latency `L`) it may still run commands up to `M_b`, then `x` acts for one
//!   period and later commands brake at `a_max` (each acting one period). The worst-case
//!   position is then
//!
//!   `q + M_a·age + ∫_t^{t+L} max(x, M_b) + Δt·x + Δt·Σ_{j≥1}(x − j a Δt)⁺`
//!   `≤ q + M_a·age + L·max(x, M_b) + Δt·x + (x⁺)²/(2a)`,
//!
//!   which must stay below `q_max − margin`; [`upper_position_bound`] returns the largest
//!   such `x` in closed form (mirrored for the lower side). With `age = L = 0` this is the
//!   classic braking bound `x Δt + x²/(2a) ≤ d`, `x ≤ a(√(Δt² + 2d/a) − Δt)`, used for
//!   position commands, whose robot sits at a commanded position. Beyond a limit (`d < 0`)
//!   the bound is negative: move back, never further.
//!
//! When the position bounds fall outside the velocity and acceleration box (noise, a start
//! beyond a limit, a model mismatch), the **acceleration limit wins**: the command brakes
//! at `a_max`, which is exactly the braking plan the previous tick's position bound
//! assumed, so the position stays inside the envelope that plan guaranteed; the margin
//! absorbs measurement noise. Joints without an acceleration limit use the configured
//! default acceleration.

use crossym_math::kinematics::JointLimits;

/// Bounds `lo ≤ x ≤ hi` (rad/s or m/s) for one joint and which limit set them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointBounds {
    /// Lower velocity bound.
    pub lo: f64,
    /// Upper velocity bound.
    pub hi: f64,
    /// True when the position bound is the binding one on either side.
    pub position_binding: bool,
    /// True when the position bound lay outside the velocity/acceleration box: the joint
    /// brakes at its acceleration limit instead.
    pub braking_saturated: bool,
}

/// How long the command of this tick can act and what the robot ran before it (one joint).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Horizon {
    /// Time from the measured state to now (s), `≥ 0`.
    pub age: f64,
    /// Actuation latency `L` (s), `≥ 0`.
    pub latency: f64,
    /// Largest command possibly executed since the measurement, `M_a` (rad/s or m/s).
    pub past_max: f64,
    /// Smallest command possibly executed since the measurement (rad/s or m/s).
    pub past_min: f64,
    /// Largest command possibly executed until the new one arrives, `M_b` (rad/s or m/s).
    pub recent_max: f64,
    /// Smallest command possibly executed until the new one arrives (rad/s or m/s).
    pub recent_min: f64,
}

impl Horizon {
    /// No latency and a state measured now: the robot is where the bound is evaluated.
    pub const NOW: Horizon = Horizon {
        age: 0.0,
        latency: 0.0,
        past_max: 0.0,
        past_min: 0.0,
        recent_max: 0.0,
        recent_min: 0.0,
    };

    fn mirrored(&self) -> Horizon {
        Horizon {
            age: self.age,
            latency: self.latency,
            past_max: -self.past_min,
            past_min: -self.past_max,
            recent_max: -self.recent_min,
            recent_min: -self.recent_max,
        }
    }
}

/// Largest `x` with `s·x + (x⁺)²/(2a) ≤ r` (`s > 0`, `a > 0`).
#[inline]
fn solve(s: f64, r: f64, a: f64) -> f64 {
    if r >= 0.0 {
        a * ((s * s + 2.0 * r / a).sqrt() - s)
    } else {
        r / s
    }
}

/// Braking-aware velocity bound toward a limit at distance `d ≥ 0` (one period, no latency).
#[inline]
pub fn braking_bound(d: f64, a: f64, dt: f64) -> f64 {
    solve(dt, d, a)
}

/// Largest velocity `x` (rad/s or m/s) whose worst-case position over horizon `h` stays
/// within `d = q_max − margin − q` (see the module docs); negative when the robot must
/// move back. `a > 0`, `dt > 0`.
#[inline]
pub fn upper_position_bound(d: f64, a: f64, dt: f64, h: &Horizon) -> f64 {
    let r = d - h.past_max * h.age;
    let x1 = solve(h.latency + dt, r, a);
    if x1 >= h.recent_max {
        x1
    } else {
        solve(dt, r - h.latency * h.recent_max, a)
    }
}

/// Worst-case position change (rad or m) of command `x` over horizon `h`: the left-hand
/// side that [`upper_position_bound`] keeps below `d` (for tests and diagnostics).
pub fn worst_case_travel(x: f64, a: f64, dt: f64, h: &Horizon) -> f64 {
    let xp = x.max(0.0);
    h.past_max * h.age + h.latency * x.max(h.recent_max) + dt * x + xp * xp / (2.0 * a)
}

/// Computes the bounds of one joint at position `q` (rad or m) over horizon `h`, with last
/// command `u` issued `since` seconds ago (the caller caps it at `dt`). `q` and `u` must be
/// finite.
#[inline]
#[allow(clippy::too_many_arguments)]
pub fn joint_bounds(
    l: &JointLimits,
    default_accel: f64,
    margin: f64,
    q: f64,
    u: f64,
    dt: f64,
    since: f64,
    h: &Horizon,
) -> JointBounds {
    let vmax = l.velocity;
    let a = l.acceleration.unwrap_or(default_accel);
    // Velocity ∩ acceleration box (never empty: |u| ≤ v_max up to rounding).
    let da = a * since.max(0.0);
    let mut lo = (-vmax).max(u - da);
    let mut hi = vmax.min(u + da);
    if lo > hi {
        // The last command lay outside the velocity box (a setting changed): the box edge nearest it.
        let e = u.clamp(-vmax, vmax);
        lo = e;
        hi = e;
    }
    // Position bounds over the horizon.
    let mut p_hi = f64::INFINITY;
    let mut p_lo = f64::NEG_INFINITY;
    if l.upper.is_finite() {
        p_hi = upper_position_bound(l.upper - margin - q, a, dt, h);
    }
    if l.lower.is_finite() {
        p_lo = -upper_position_bound(q - (l.lower + margin), a, dt, &h.mirrored());
    }
    if p_lo > p_hi {
        // A joint range narrower than the horizon needs: aim for the middle.
        let mid = 0.5 * (p_lo + p_hi);
        p_lo = mid;
        p_hi = mid;
    }
    let position_binding = p_hi <= hi || p_lo >= lo;
    let mut braking_saturated = false;
    if p_hi < lo {
        hi = lo;
        braking_saturated = true;
    } else if p_lo > hi {
        lo = hi;
        braking_saturated = true;
    } else {
        lo = lo.max(p_lo);
        hi = hi.min(p_hi);
    }
    JointBounds {
        lo,
        hi,
        position_binding,
        braking_saturated,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lim() -> JointLimits {
        JointLimits {
            lower: -1.0,
            upper: 1.0,
            velocity: 2.0,
            effort: 1.0,
            acceleration: Some(10.0),
        }
    }

    #[test]
    fn braking_bound_stops_before_the_limit() {
        let (a, dt) = (10.0, 0.01);
        for d in [0.0, 1e-4, 0.01, 0.5] {
            let x = braking_bound(d, a, dt);
            assert!(x >= 0.0);
            assert!((x * dt + x * x / (2.0 * a) - d).abs() < 1e-12);
        }
    }

    #[test]
    fn horizon_bound_is_the_largest_velocity_whose_worst_case_fits() {
        // Independent check: bisection on the worst-case travel (not the closed form).
        let (a, dt) = (10.0, 0.01);
        let mut cases = 0;
        for &d in &[-0.02, 0.0, 1e-4, 0.008, 0.05, 0.5] {
            for &(age, lat) in &[(0.0, 0.0), (0.0, 0.01), (0.013, 0.01), (0.1, 0.03)] {
                for &(pm, rm) in &[(0.0, 0.0), (0.4, 0.3), (0.4, -0.2), (-0.3, -0.3)] {
                    let h = Horizon {
                        age,
                        latency: lat,
                        past_max: pm,
                        past_min: pm.min(rm) - 0.1,
                        recent_max: rm,
                        recent_min: rm - 0.1,
                    };
                    let x = upper_position_bound(d, a, dt, &h);
                    let (mut lo, mut hi) = (-1e3, 1e3);
                    for _ in 0..200 {
                        let m = 0.5 * (lo + hi);
                        if worst_case_travel(m, a, dt, &h) <= d {
                            lo = m;
                        } else {
                            hi = m;
                        }
                    }
                    assert!((x - lo).abs() < 1e-9, "d {d} h {h:?}: {x} vs {lo}");
                    cases += 1;
                }
            }
        }
        assert_eq!(cases, 96);
    }

    #[test]
    fn bounds_are_ordered_and_acceleration_wins() {
        // Moving fast toward the upper limit, close to it: braking would need more than the
        // acceleration limit; the joint brakes at a_max instead.
        let b = joint_bounds(&lim(), 5.0, 0.0, 0.99, 2.0, 0.01, 0.01, &Horizon::NOW);
        assert!(b.braking_saturated);
        assert!((b.lo - 1.9).abs() < 1e-12 && (b.hi - 1.9).abs() < 1e-12);
        // Beyond the upper limit at rest: move back, never further.
        let b = joint_bounds(&lim(), 5.0, 0.0, 1.1, 0.0, 0.01, 0.01, &Horizon::NOW);
        assert!(b.hi < 0.0 && b.lo <= b.hi);
        // Free space: the acceleration box binds.
        let b = joint_bounds(&lim(), 5.0, 0.0, 0.0, 0.0, 0.01, 0.01, &Horizon::NOW);
        assert!((b.lo + 0.1).abs() < 1e-12 && (b.hi - 0.1).abs() < 1e-12);
        // An old state shrinks the upper bound: the robot may have moved since.
        let h = Horizon {
            age: 0.05,
            latency: 0.01,
            past_max: 0.5,
            past_min: 0.5,
            recent_max: 0.5,
            recent_min: 0.5,
        };
        let fresh = upper_position_bound(0.1, 10.0, 0.01, &Horizon::NOW);
        let old = upper_position_bound(0.1, 10.0, 0.01, &h);
        assert!(old < fresh - 0.1, "{old} vs {fresh}");
        // Near the limit the old state forces the joint to brake at a_max.
        let b = joint_bounds(&lim(), 5.0, 0.0, 0.99, 0.5, 0.01, 0.01, &h);
        assert!(b.braking_saturated && (b.hi - 0.4).abs() < 1e-12);
    }
}
