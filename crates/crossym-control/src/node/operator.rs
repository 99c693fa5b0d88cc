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
