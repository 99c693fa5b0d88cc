//! The status period: the worst code of the ticks since the previous `~/status` and the
//! transient events counted since, so that a code that lasted one tick (a restart, a held
//! robot found) is seen by an operator who reads `~/status` every `status_period_s`.
//!
//! Codes are ranked by [`StatusCode::severity`]; the counts are differences of the node's
//! running totals ([`EventTotals`]) against their values at the start of the period.
//!
//! A new fault is not kept for the period's end: when a tick's code is a fault (not the
//! filter's shaping nor a restart from the measured state) more severe than the worst code
//! of the last status published, the period is [`escalated`] and the node
//! publishes its status at once, ending the period early (at most once per period, so a
//! flapping code costs at most two statuses a period). A robot found held is therefore
//! on `~/status` at the tick that found it, not up to `status_period_s` later.
//! Allocation-free.
//!
//! [`escalated`]: StatusPeriod::escalated

use super::code::StatusCode;

/// Running totals of the node's transient events (counts since start).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct EventTotals {
    /// Restarts from the measured state (position modes).
    pub restarts: u64,
    /// Robot-held detections.
    pub held: u64,
    /// Locked-joint detections.
    pub locked: u64,
    /// Rejected input messages (joint states and conditions).
    pub rejected: u64,
    /// Stale ticks.
    pub stale_ticks: u64,
    /// Safety fallbacks.
    pub fallback_ticks: u64,
    /// Ticks started more than half a period late.
    pub late_ticks: u64,
    /// Ticks never run.
    pub missed_ticks: u64,
}

impl EventTotals {
    /// `self − base`, each count saturating into `u32`.
    pub fn since(&self, base: &EventTotals) -> PeriodCounts {
        let d = |a: u64, b: u64| a.saturating_sub(b).min(u32::MAX as u64) as u32;
        PeriodCounts {
            restarts: d(self.restarts, base.restarts),
            held: d(self.held, base.held),
            locked: d(self.locked, base.locked),
            rejected: d(self.rejected, base.rejected),
            stale_ticks: d(self.stale_ticks, base.stale_ticks),
            fallback_ticks: d(self.fallback_ticks, base.fallback_ticks),
            late_ticks: d(self.late_ticks, base.late_ticks),
            missed_ticks: d(self.missed_ticks, base.missed_ticks),
        }
    }
}

/// Transient events of one status period (counts).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct PeriodCounts {
    /// Restarts from the measured state.
    pub restarts: u32,
    /// Robot-held detections.
    pub held: u32,
    /// Locked-joint detections.
    pub locked: u32,
    /// Rejected input messages.
    pub rejected: u32,
    /// Stale ticks.
    pub stale_ticks: u32,
    /// Safety fallbacks.
    pub fallback_ticks: u32,
    /// Ticks started more than half a period late.
    pub late_ticks: u32,
    /// Ticks never run.
    pub missed_ticks: u32,
}

/// The worst code and the events of the current status period.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StatusPeriod {
    worst: Option<StatusCode>,
    ticks: u32,
    base: EventTotals,
    /// The severity of the worst code of the last status published.
    reported: u8,
    /// This period began with a status published early (at an escalation).
    early: bool,
}

impl Default for StatusPeriod {
    fn default() -> Self {
        Self::new()
    }
}

impl StatusPeriod {
    /// An empty period.
    pub fn new() -> Self {
        Self {
            worst: None,
            ticks: 0,
            base: EventTotals::default(),
            reported: 0,
            early: false,
        }
    }

    /// One tick reported `code`.
    pub fn observe(&mut self, code: StatusCode) {
        self.ticks = self.ticks.saturating_add(1);
        self.worst = Some(match self.worst {
            Some(w) if w.severity() >= code.severity() => w,
            _ => code,
        });
    }

    /// The worst code of the period (`last` when no tick ran), the ticks and the events
    /// since its start.
    pub fn report(
        &self,
        last: StatusCode,
        totals: &EventTotals,
    ) -> (StatusCode, u32, PeriodCounts) {
        (
            self.worst.unwrap_or(last),
            self.ticks,
            totals.since(&self.base),
        )
    }

    /// Whether a tick of this period had a code more severe than the worst code of the last
    /// status published, and this period did not begin early: its status is due now. The
    /// filter's shaping (`JOINT_BOUND`, `DECELERATE_FOR_*`) is no fault, and a restart from
    /// the measured state (`RESTARTED_FROM_MEASURED`, e.g. after the robot was moved) is the
    /// node's own recovery: they wait for the period's end (its code and counts).
    pub fn escalated(&self) -> bool {
        !self.early
            && self
                .worst
                .is_some_and(|w| w.severity() > self.reported && w.is_news())
    }

    /// Starts the next period at `totals`, after the status of this one was published
    /// (`early`: at an escalation, before the period's end).
    pub fn restart(&mut self, totals: EventTotals, early: bool) {
        if let Some(w) = self.worst {
            self.reported = w.severity();
        }
        self.worst = None;
        self.ticks = 0;
        self.base = totals;
        self.early = early;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_worst_code_of_the_period_wins_and_a_new_period_forgets_it() {
        let mut p = StatusPeriod::new();
        for c in [
            StatusCode::NoWarning,
            StatusCode::RestartedFromMeasured,
            StatusCode::JointBound,
            StatusCode::NoWarning,
        ] {
            p.observe(c);
        }
        let totals = EventTotals {
            restarts: 3,
            ..EventTotals::default()
        };
        let (worst, ticks, counts) = p.report(StatusCode::NoWarning, &totals);
        assert_eq!(worst, StatusCode::RestartedFromMeasured);
        assert_eq!(ticks, 4);
        assert_eq!(counts.restarts, 3);
        p.restart(totals, false);
        let (worst, ticks, counts) = p.report(StatusCode::NoWarning, &totals);
        assert_eq!(
            (worst, ticks, counts),
            (StatusCode::NoWarning, 0, PeriodCounts::default())
        );
        p.observe(StatusCode::RobotHeld);
        p.observe(StatusCode::StaleJointStates);
        assert_eq!(
            p.report(StatusCode::NoWarning, &totals).0,
            StatusCode::RobotHeld
        );
    }

    #[test]
    fn a_new_fault_is_due_at_once_once_a_period() {
        let t = EventTotals::default();
        let (held, stale) = (StatusCode::RobotHeld, StatusCode::RobotNotFollowing);
        assert!(stale.severity() > held.severity());
        let mut p = StatusPeriod::new();
        p.observe(StatusCode::NoWarning);
        assert!(!p.escalated(), "nothing new");
        p.observe(held);
        assert!(
            p.escalated(),
            "a fault worse than the last status is due now"
        );
        p.restart(t, true);
        p.observe(held);
        assert!(!p.escalated(), "the same fault again is not news");
        p.observe(stale);
        assert!(
            !p.escalated(),
            "a second escalation in a period that began early waits for the period's end"
        );
        p.restart(t, false);
        p.observe(held);
        assert!(!p.escalated(), "less severe than the last status");
        p.observe(stale);
        assert!(!p.escalated(), "as severe as the last status");
        // Back to normal, then the fault again: news.
        p.restart(t, false);
        p.observe(StatusCode::NoWarning);
        p.restart(t, false);
        p.observe(held);
        assert!(p.escalated());
        // The filter's shaping and the node's own restart wait for the period's end.
        let mut p = StatusPeriod::new();
        p.observe(StatusCode::JointBound);
        p.observe(StatusCode::DecelerateForSingularity);
        assert!(!p.escalated());
        p.observe(StatusCode::HaltForSingularity);
        assert!(p.escalated());
        let mut p = StatusPeriod::new();
        p.observe(StatusCode::RestartedFromMeasured);
        assert!(!p.escalated());
        p.observe(StatusCode::InvalidInput);
        assert!(p.escalated());
    }

    #[test]
    fn severity_ranks_every_code_apart() {
        let mut s: Vec<u8> = StatusCode::ALL.iter().map(|c| c.severity()).collect();
        s.sort_unstable();
        s.dedup();
        assert_eq!(s.len(), StatusCode::ALL.len());
        assert_eq!(StatusCode::NoWarning.severity(), 0);
    }
}
