//! How the safety filter computes each joint's bounds over a tick ([`BoundRules`]): the
//! exact rules of [`super::bounds`] ([`ExactBounds`], the only rules a node runs), or, for
//! the tests and fault campaigns that must see a broken filter caught, a deliberately broken
//! variant (`crate::faults::FilterDefect`, with the `fault-injection` feature). The filter
//! is generic over the rules, so a node's filter has no code path that breaks them.

/// The three places where the filter's bounds could be weakened.
pub trait BoundRules {
    /// The time (s) over which the acceleration limit lets the command change, given the
    /// exact one (`exact`) and the period `dt` (s).
    #[inline]
    fn since(&self, exact: f64, dt: f64) -> f64 {
        let _ = dt;
        exact
    }

    /// Whether the position bound covers the state's age, the latency and the commands in
    /// flight (else it is computed as if the state were measured now).
    #[inline]
    fn horizon_applies(&self) -> bool {
        true
    }

    /// Whether the position limits bound the command.
    #[inline]
    fn position_bound(&self) -> bool {
        true
    }
}

/// The filter's rules as the module docs of [`super::bounds`] state them.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ExactBounds;

impl BoundRules for ExactBounds {}
