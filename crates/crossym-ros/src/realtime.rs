//! Real-time settings applied to a process that runs on a DDS event loop: the node
//! (`[node] realtime`) and `crossym ping --realtime` alike.
//!
//! [`crossym_control::realtime`] holds the settings and what needs no DDS (`SCHED_FIFO` for
//! one thread and RustDDS's threads, `mlockall`, the PM QoS CPU latency request); the
//! `SCHED_IDLE` pollers of `idle_poll = true` live on this floor ([`crate::idle_poll`]). This
//! module applies all of them in one place and hands back what must be held while the
//! process runs.

use crossym_control::realtime::{self, CpuLatencyRequest, RealtimeConfig, RealtimeOutcome};

use crate::idle_poll::IdlePoll;

/// What applied real-time settings keep alive: the CPU latency request (the kernel drops it
/// when the file closes) and the idle pollers (stopped and joined when dropped). Hold it
/// while the process should run under the settings.
#[derive(Debug, Default)]
pub struct RealtimeHold {
    /// The PM QoS CPU latency request (`cpu_latency_us`), when granted.
    pub cpu_latency: Option<CpuLatencyRequest>,
    /// The idle pollers (`idle_poll`), when started.
    pub idle_poll: Option<IdlePoll>,
}

/// Applies `rt` to `thread` (a running DDS event-loop thread of this process: `dds_priority`
/// concerns only RustDDS's other threads), the memory, the CPU latency and the idle
/// pollers, in that order; `report` receives each outcome (applied, or refused with the
/// reason and how to grant it). Returns what to hold while the settings should apply.
pub fn apply_realtime(
    rt: &RealtimeConfig,
    thread: libc::pthread_t,
    mut report: impl FnMut(&RealtimeOutcome),
) -> RealtimeHold {
    let mut hold = RealtimeHold::default();
    let mut outcomes = realtime::apply(rt, thread);
    if let Some(us) = rt.cpu_latency_us {
        let (request, outcome) = realtime::request_cpu_latency(us);
        hold.cpu_latency = request;
        outcomes.push(outcome);
    }
    if rt.idle_poll {
        let (pollers, outcome) = IdlePoll::start();
        hold.idle_poll = pollers;
        outcomes.push(outcome);
    }
    for o in &outcomes {
        report(o);
    }
    hold
}
