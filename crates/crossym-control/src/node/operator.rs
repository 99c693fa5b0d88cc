//! The operator's runtime controls: pause and resume, reset, and the settings that may
//! change while the node runs (MoveIt Servo's `~/pause_servo` and its updatable
//! parameters).
//!
//! A request is checked where it arrives (a service or parameter callback, off the control
//! thread) against [`RuntimeBounds`], fixed at start, then handed to the control thread as
//! a `Copy` value and applied between two ticks ([`super::NodeCore::apply`]): the tick
//! stays allocation- and lock-free. Everything not listed here is sized or checked at
//! start (the QP, the buffers, the policy) and needs a restart.

use crossym_math::symmetry::compose::Condition;

use super::rejection::Rejection;

/// A change an operator asks for.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum OperatorRequest {
    /// Pause (brake to zero at the acceleration limits, then hold) or resume (from the
    /// measured state).
    Pause(bool),
    /// Lifecycle: activate (`true`: the policy from the measured state) or leave the active
    /// state (`false`: brake to zero at the acceleration limits, then publish nothing).
    Activate(bool),
    /// Clears a latched fault (`ROBOT_NOT_FOLLOWING`) and starts again from the measured
    /// state.
    Reset,
    /// `velocity_scale`: the policy's velocity is multiplied by it before the filter.
    VelocityScale(f64),
    /// `stale_timeout_s`.
    StaleTimeout(f64),
    /// `accept_untrained_conditions`.
    AcceptUntrained(bool),
    /// `safety.margin` (rad or m kept free inside the URDF limits).
    Margin(f64),
    /// `default_condition`: applied now, through the input gate like a condition message.
    DefaultCondition(Condition),
}

/// Why a request is refused (nothing changes).
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum OperatorRefusal {
    /// `velocity_scale` outside `(0, 1]`.
    #[error("velocity_scale must be in (0, 1], got {value}")]
    VelocityScale {
        /// The value asked for.
        value: f64,
    },
    /// `stale_timeout_s` not in `(0, max]`.
    #[error("stale_timeout_s must be in (0, {max_s}] s (the command history is sized at start for {max_s} s), got {value}")]
    StaleTimeout {
        /// The value asked for.
        value: f64,
        /// The start value: the most the buffers hold.
        max_s: f64,
    },
    /// `safety.margin` negative or not leaving room inside the smallest joint range.
    #[error("safety.margin must be in [0, {max}) (a margin may only tighten the URDF limits, and leave room inside the smallest joint range), got {value}")]
    Margin {
        /// The value asked for.
        value: f64,
        /// Half the smallest joint range.
        max: f64,
    },
    /// The condition is not valid.
    #[error("default_condition refused: {why}")]
    Condition {
        /// What is wrong.
        why: &'static str,
    },
    /// The input gate refused the condition (outside the trained box, infeasible here).
    #[error("default_condition refused by the input gate: {}", rejection.describe())]
    Gate {
        /// The gate's rejection.
        rejection: Rejection,
    },
}

/// What runtime requests may ask for, fixed at start.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RuntimeBounds {
    /// The start `stale_timeout_s` (the history buffers' span).
    pub max_stale_timeout_s: f64,
    /// Half the smallest finite joint range.
    pub max_margin: f64,
}

impl RuntimeBounds {
    /// Checks `r` (the value checks; a condition's acceptance is the gate's, on apply).
    pub fn check(&self, r: &OperatorRequest) -> Result<(), OperatorRefusal> {
        match *r {
            OperatorRequest::VelocityScale(s) if !(s > 0.0 && s <= 1.0) => {
                Err(OperatorRefusal::VelocityScale { value: s })
            }
            OperatorRequest::StaleTimeout(t) if !(t > 0.0 && t <= self.max_stale_timeout_s) => {
                Err(OperatorRefusal::StaleTimeout {
                    value: t,
                    max_s: self.max_stale_timeout_s,
                })
            }
            OperatorRequest::Margin(m) if !(m >= 0.0 && m < self.max_margin) => {
                Err(OperatorRefusal::Margin {
                    value: m,
                    max: self.max_margin,
                })
            }
            OperatorRequest::DefaultCondition(c) => {
                if !c.theta.is_finite() {
                    Err(OperatorRefusal::Condition {
                        why: "θ must be finite",
                    })
                } else if !(c.scale.is_finite() && c.scale > 0.0) {
                    Err(OperatorRefusal::Condition {
                        why: "λ must be finite and positive",
                    })
                } else if c.reflection != 1 && c.reflection != -1 {
                    Err(OperatorRefusal::Condition {
                        why: "σ must be +1 or -1",
                    })
                } else {
                    Ok(())
                }
            }
            _ => Ok(()),
        }
    }
}

/// The runtime settings in force (reported in the status).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RuntimeSettings {
    /// Paused by an operator.
    pub paused: bool,
    /// `velocity_scale`.
    pub velocity_scale: f64,
    /// `stale_timeout_s`.
    pub stale_timeout_s: f64,
    /// `accept_untrained_conditions`.
    pub accept_untrained: bool,
    /// `safety.margin`.
    pub margin: f64,
}

/// The operator's state in the node: paused, the lifecycle's inactive state, the velocity
/// scale, and the bounds requests are checked against. Pause and inactive are orders not
/// to run the policy (the core brakes); leaving either starts position modes again from
/// the measured state, since the robot may have been moved meanwhile.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct OperatorState {
    /// Paused by an operator.
    pub paused: bool,
    /// Lifecycle state not active: braking, then no command.
    pub inactive: bool,
    /// The factor on the policy's velocity, in `(0, 1]`.
    pub velocity_scale: f64,
    /// What requests may ask for (fixed at start).
    pub bounds: RuntimeBounds,
}

/// What applying a request to the [`OperatorState`] asks of the rest of the node.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum OperatorEffect {
    /// Nothing more.
    Done,
    /// Start position modes again from the measured state (a resume, an activation).
    Restart,
    /// Not the operator state's own request (reset, the settings of the gate and the
    /// filter, the default condition): the caller applies it.
    Elsewhere,
}

impl OperatorState {
    /// Running, active, at `velocity_scale`.
    pub fn new(velocity_scale: f64, bounds: RuntimeBounds) -> Self {
        Self {
            paused: false,
            inactive: false,
            velocity_scale,
            bounds,
        }
    }

    /// Applies `r` if it is a pause, an activation or a velocity scale (`r` already
    /// checked against the bounds). Allocation-free.
    pub fn apply(&mut self, r: &OperatorRequest) -> OperatorEffect {
        match *r {
            OperatorRequest::Pause(p) => {
                let resumed = self.paused && !p;
                self.paused = p;
                effect(resumed)
            }
            OperatorRequest::Activate(a) => {
                let activated = self.inactive && a;
                self.inactive = !a;
                effect(activated)
            }
            OperatorRequest::VelocityScale(s) => {
                self.velocity_scale = s;
                OperatorEffect::Done
            }
            _ => OperatorEffect::Elsewhere,
        }
    }

    /// Multiplies the policy's velocity by the scale. Allocation-free.
    pub fn scale(&self, v: &mut [f64]) {
        for x in v.iter_mut() {
            *x *= self.velocity_scale;
        }
    }
}

fn effect(restart: bool) -> OperatorEffect {
    if restart {
        OperatorEffect::Restart
    } else {
        OperatorEffect::Done
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn state() -> OperatorState {
        OperatorState::new(
            1.0,
            RuntimeBounds {
                max_stale_timeout_s: 0.5,
                max_margin: 1.0,
            },
        )
    }

    #[test]
    fn leaving_a_pause_restarts_and_pausing_twice_does_not() {
        let mut s = state();
        assert_eq!(
            s.apply(&OperatorRequest::Pause(false)),
            OperatorEffect::Done
        );
        assert_eq!(s.apply(&OperatorRequest::Pause(true)), OperatorEffect::Done);
        assert!(s.paused);
        assert_eq!(s.apply(&OperatorRequest::Pause(true)), OperatorEffect::Done);
        assert_eq!(
            s.apply(&OperatorRequest::Pause(false)),
            OperatorEffect::Restart
        );
        assert!(!s.paused);
        assert_eq!(
            s.apply(&OperatorRequest::Pause(false)),
            OperatorEffect::Done
        );
    }

    #[test]
    fn an_activation_after_inactive_restarts_and_one_while_active_does_not() {
        let mut s = state();
        assert_eq!(
            s.apply(&OperatorRequest::Activate(true)),
            OperatorEffect::Done
        );
        assert_eq!(
            s.apply(&OperatorRequest::Activate(false)),
            OperatorEffect::Done
        );
        assert!(s.inactive);
        assert_eq!(
            s.apply(&OperatorRequest::Activate(true)),
            OperatorEffect::Restart
        );
        assert!(!s.inactive);
        // Pause and lifecycle are independent.
        s.apply(&OperatorRequest::Pause(true));
        assert_eq!(
            s.apply(&OperatorRequest::Activate(false)),
            OperatorEffect::Done
        );
        assert!(s.paused && s.inactive);
    }

    #[test]
    fn the_scale_multiplies_the_velocity_and_other_requests_are_not_its_own() {
        let mut s = state();
        assert_eq!(
            s.apply(&OperatorRequest::VelocityScale(0.25)),
            OperatorEffect::Done
        );
        let mut v = [2.0, -4.0, f64::NAN];
        s.scale(&mut v);
        assert_eq!(&v[..2], &[0.5, -1.0]);
        assert!(
            v[2].is_nan(),
            "a non-finite velocity stays for the filter to replace"
        );
        let before = s;
        for r in [
            OperatorRequest::Reset,
            OperatorRequest::StaleTimeout(0.1),
            OperatorRequest::AcceptUntrained(true),
            OperatorRequest::Margin(0.1),
        ] {
            assert_eq!(s.apply(&r), OperatorEffect::Elsewhere, "{r:?}");
        }
        assert_eq!(s, before);
    }

    #[test]
    fn requests_outside_the_bounds_are_refused() {
        let b = state().bounds;
        assert!(b.check(&OperatorRequest::VelocityScale(0.0)).is_err());
        assert!(b.check(&OperatorRequest::VelocityScale(1.5)).is_err());
        assert!(b.check(&OperatorRequest::VelocityScale(1.0)).is_ok());
        assert!(b.check(&OperatorRequest::StaleTimeout(0.6)).is_err());
        assert!(b.check(&OperatorRequest::Margin(1.0)).is_err());
        assert!(b.check(&OperatorRequest::Margin(0.0)).is_ok());
    }
}
