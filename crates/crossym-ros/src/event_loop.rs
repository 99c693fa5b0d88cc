//! Code on the DDS participant's event-loop thread.
//!
//! RustDDS receives, delivers and transmits on one thread per participant. crossym's
//! vendored RustDDS (vendor/README.md) adds an event-loop hook: application code called
//! on that thread each time the loop has delivered what arrived, whose writes are
//! transmitted before the loop sleeps again. The node's control thread and `crossym ping`
//! are such hooks, so a sample in → sample out path crosses no thread boundary: the one
//! wake-up per message is the socket's, as with Cyclone DDS's synchronous delivery.
//!
//! [`LoopThread`] is what a hook shares with the threads around it: the waker that makes
//! the loop call the hook, and the thread itself (for real-time settings).

use std::sync::OnceLock;
use std::thread;
use std::time::{Duration, Instant};

use ros2_client::dds::rustdds::EventLoopWaker;

/// The event-loop thread of a hooked participant, as its hook reports it.
#[derive(Default)]
pub struct LoopThread {
    waker: OnceLock<EventLoopWaker>,
    thread: OnceLock<libc::pthread_t>,
}

impl LoopThread {
    /// Called by the hook's `start`, on the loop's thread: keeps `waker` and the thread,
    /// and names the thread `name` (at most 15 bytes, as the kernel's `comm`).
    pub fn started(&self, waker: EventLoopWaker, name: &std::ffi::CStr) {
        let _ = self.waker.set(waker);
        // SAFETY: pthread_self has no preconditions; `name` is NUL-terminated (a longer
        // name is refused with ERANGE, leaving the thread's name as it was).
        let me = unsafe { libc::pthread_self() };
        unsafe { libc::pthread_setname_np(me, name.as_ptr()) };
        let _ = self.thread.set(me);
    }

    /// Wakes the loop, which then calls its hook; false before the loop has started.
    pub fn wake(&self) -> bool {
        self.waker.get().map(EventLoopWaker::wake).is_some()
    }

    /// The loop's thread, once started (the participant is built before the loop's first
    /// poll, so in practice at once); `None` after `timeout`.
    pub fn wait(&self, timeout: Duration) -> Option<libc::pthread_t> {
        let start = Instant::now();
        loop {
            if let Some(t) = self.thread.get() {
                return Some(*t);
            }
            if start.elapsed() > timeout {
                return None;
            }
            thread::sleep(Duration::from_millis(1));
        }
    }
}
