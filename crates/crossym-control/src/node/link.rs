//! The controller at the other end of the command topic, as the DDS graph tells it between
//! ticks: how many subscribers match the command topic, whether one ever did, and whether
//! the next fresh tick restarts from the measured state.
//!
//! Once a subscriber has matched, none means the controller was switched off: the node
//! brakes to a hold (`NO_COMMAND_SUBSCRIBER`) rather than command into the void, and when
//! one matches again the commands start from the measured state (the robot may have been
//! moved while nothing held it). Before any subscriber matched (a node started before its
//! controller) or while the count is not known, nothing is lost. Allocation-free.

/// The command topic's subscribers and the resume they owe (see the module docs).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(crate) struct ControllerLink {
    subscribers: Option<u32>,
    had_subscriber: bool,
    resume: bool,
}

impl ControllerLink {
    /// `n` subscribers match the command topic.
    pub fn set(&mut self, n: u32) {
        self.had_subscriber |= n > 0;
        self.subscribers = Some(n);
    }

    /// The subscribers matched on the command topic (`None`: not known).
    pub fn subscribers(&self) -> Option<u32> {
        self.subscribers
    }

    /// Whether the controller is gone (one matched before, none now); then the next tick
    /// that runs the policy restarts from the measured state.
    pub fn lost(&mut self) -> bool {
        let lost = self.had_subscriber && self.subscribers == Some(0);
        self.resume |= lost;
        lost
    }

    /// Whether a restart is owed (the controller was lost since the last call); clears it.
    pub fn take_resume(&mut self) -> bool {
        std::mem::take(&mut self.resume)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn no_subscriber_yet_or_unknown_is_not_lost() {
        let mut l = ControllerLink::default();
        assert!(!l.lost());
        assert_eq!(l.subscribers(), None);
        l.set(0);
        assert!(!l.lost(), "a node started before its controller");
        assert!(!l.take_resume());
    }

    #[test]
    fn a_controller_lost_is_reported_until_back_and_owes_one_restart() {
        let mut l = ControllerLink::default();
        l.set(1);
        assert!(!l.lost());
        l.set(0);
        assert!(l.lost());
        assert!(l.lost(), "lost on every tick until one matches again");
        l.set(2);
        assert!(!l.lost());
        assert_eq!(l.subscribers(), Some(2));
        assert!(l.take_resume());
        assert!(!l.take_resume(), "one restart, not one per lost tick");
    }
}
