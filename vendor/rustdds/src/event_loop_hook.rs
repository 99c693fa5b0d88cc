//! Running application code on the participant's event-loop thread.
//!
//! RustDDS receives, delivers and transmits on one thread per participant (the
//! event loop). An application that reacts to a sample by writing one (a
//! controller: state in, command out) otherwise pays two thread hand-offs per
//! sample: the event loop wakes the application's thread when the sample is in
//! the reader's cache, and the application's `write` wakes the event loop to
//! transmit. An [`EventLoopHook`] given to
//! [`DomainParticipantBuilder::event_loop_hook`](crate::DomainParticipantBuilder::event_loop_hook)
//! runs on the event-loop thread itself, right after the loop has delivered
//! what arrived: it reads with the usual non-blocking `take`, and what it
//! writes is transmitted before the loop sleeps again, on the same thread.
//!
//! The loop is not re-entrant: a hook must not block on the participant (for
//! example wait for an acknowledgement or a blocking `write` on a full reliable
//! window), since the loop that would make progress is the caller. Everything
//! the hook does delays the loop's own work (receiving, heartbeats, repairs,
//! other readers and writers of the participant) by as long as it takes.

use std::time::Duration;

use crate::polling::LoopWaker;

/// Code run on a participant's event-loop thread (see the module docs).
///
/// The hook is moved to the event-loop thread when the participant is built
/// and dropped there when the loop stops (when the participant is dropped).
pub trait EventLoopHook: Send {
  /// Called once on the event-loop thread, before its first poll. `waker`
  /// makes the loop call [`run`](Self::run) soon, from any thread.
  fn start(&mut self, waker: EventLoopWaker) {
    let _ = waker;
  }

  /// Called after every wake-up of the loop (a datagram, a command, a timer, a
  /// wake-up through the [`EventLoopWaker`], or the timeout this returned last
  /// time), once the loop has delivered what arrived to the readers' caches.
  /// Samples written here are transmitted before the loop polls again. Returns
  /// the longest the loop may wait before calling again (`None`: the loop's
  /// own timeout).
  fn run(&mut self) -> Option<Duration>;
}

/// Wakes a participant's event loop (and so its [`EventLoopHook`]) from any
/// thread. Wake-ups are coalesced.
#[derive(Clone)]
pub struct EventLoopWaker {
  waker: LoopWaker,
}

impl EventLoopWaker {
  pub(crate) fn new(waker: LoopWaker) -> Self {
    Self { waker }
  }

  /// Makes the event loop wake up and call its hook.
  pub fn wake(&self) {
    self.waker.wake();
  }
}
