//! Per-joint velocity bounds for one control period: velocity, acceleration and
//! braking-aware position limits, intersected with braking taking precedence.
//!
//! For joint `i` at position `q`, last command `u`, period `Δt`, limits
//! `[q_min, q_max]`, `|q̇| ≤ v_max`, `|q̈| ≤ a_max`:
//!
//! - velocity: `−v_max ≤ x ≤ v_max`;
//! - acceleration relative to the last command: `u − a_max Δt ≤ x ≤ u + a_max Δt`;
//! - braking-aware position with one period of latency: moving at `x` for one period and
//!   then braking at `a_max` must stop before the limit, `x Δt + x²/(2 a_max) ≤ d` with
//!   `d = q_max − q − margin`, i.e. `x ≤ a_max (√(Δt² + 2d/a_max) − Δt)` (the classic
//!   `√(2 a d)` bound with the latency period taken out); mirrored for the lower side.
//!   Beyond a limit (`d < 0`) the bound is `−min(v_max, a_max Δt, |d|/Δt)`: move back
//!   gently, never further.
//!
//! When the sets conflict (e.g. the arm moves fast toward a limit and the acceleration
//! box would not allow enough braking), the position bounds win: we never swap or widen
//! them, unlike ros2_control's joint limiter. Joints without an acceleration limit use
//! the configured default acceleration.

use crate::kinematics::JointLimits;

/// Bounds `lo ≤ x ≤ hi` (rad/s or m/s) for one joint and which limit set them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointBounds {
    /// Lower velocity bound.
    pub lo: f64,
    /// Upper velocity bound.
    pub hi: f64,
    /// True when the position (braking) bound is the binding one on either side.
    pub position_binding: bool,
    /// True when the acceleration bound had to give way to braking.
    pub accel_overridden: bool,
}

/// Braking-aware velocity bound toward a limit at distance `d ≥ 0` (one period of latency).
#[inline]
pub fn braking_bound(d: f64, a: f64, dt: f64) -> f64 {
    a * ((dt * dt + 2.0 * d / a).sqrt() - dt)
}

/// Computes the bounds of one joint. `q` and `u` must be finite (checked by the caller).
#[inline]
pub fn joint_bounds(
    l: &JointLimits,
    default_accel: f64,
    margin: f64,
    q: f64,
    u: f64,
    dt: f64,
) -> JointBounds {
    let vmax = l.velocity;
    let a = l.acceleration.unwrap_or(default_accel);
    let (mut lo, mut hi) = (-vmax, vmax);
    // Position (braking) bounds.
    let mut p_hi = f64::INFINITY;
    let mut p_lo = f64::NEG_INFINITY;
    if l.upper.is_finite() {
        let d = l.upper - margin - q;
        p_hi = if d >= 0.0 {
            braking_bound(d, a, dt)
        } else {
            -(vmax.min(a * dt).min(-d / dt))
        };
    }
    if l.lower.is_finite() {
        let d = q - (l.lower + margin);
        p_lo = if d >= 0.0 {
            -braking_bound(d, a, dt)
        } else {
            vmax.min(a * dt).min(-d / dt)
        };
    }
    // A joint range narrower than twice the margin: hold still in the middle.
    if p_lo > p_hi {
        let mid = 0.5 * (p_lo + p_hi);
        p_lo = mid;
        p_hi = mid;
    }
    lo = lo.max(p_lo);
    hi = hi.min(p_hi);
    let position_binding = hi == p_hi || lo == p_lo;
    if lo > hi {
        // Out-of-range recovery faster than the velocity limit allows: the position side wins.
        lo = p_lo.min(hi);
        hi = lo.max(hi);
    }
    // Acceleration box relative to the last command; braking wins on conflict.
    let (a_lo, a_hi) = (u - a * dt, u + a * dt);
    let mut accel_overridden = false;
    if a_lo > hi {
        lo = hi;
        accel_overridden = true;
    } else if a_hi < lo {
        hi = lo;
        accel_overridden = true;
    } else {
        lo = lo.max(a_lo);
        hi = hi.min(a_hi);
    }
    JointBounds {
        lo,
        hi,
        position_binding,
        accel_overridden,
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
    fn bounds_are_ordered_and_braking_wins() {
        // Moving fast toward the upper limit, close to it: acceleration box [1.9, 2.1] conflicts
        // with braking; braking wins.
        let b = joint_bounds(&lim(), 5.0, 0.0, 0.99, 2.0, 0.01);
        assert!(b.lo <= b.hi);
        assert!(b.accel_overridden);
        assert!(b.hi <= braking_bound(0.01, 10.0, 0.01) + 1e-12);
        // Beyond the upper limit: must move back.
        let b = joint_bounds(&lim(), 5.0, 0.0, 1.1, 0.0, 0.01);
        assert!(b.hi < 0.0 && b.lo <= b.hi);
        // Free space: the acceleration box binds.
        let b = joint_bounds(&lim(), 5.0, 0.0, 0.0, 0.0, 0.01);
        assert!((b.lo + 0.1).abs() < 1e-12 && (b.hi - 0.1).abs() < 1e-12);
    }
}
