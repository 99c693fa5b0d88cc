//! Idle CPUs that poll instead of halting (`[node] realtime idle_poll = true`): the
//! user-space stand-in for the kernel's `idle=poll` where neither it nor PM QoS is
//! available.
//!
//! A joint state → command round trip is a chain of thread wake-ups (the driver's DDS event
//! loop, the node's, the control thread, and back). When the CPU a thread is woken on has
//! halted, the wake waits for the hardware — on a virtual machine for the host to resume
//! the vCPU, whose caches the host has meanwhile given to others. Where the kernel has a
//! `cpuidle` driver, `cpu_latency_us = 0` (PM QoS) makes idle CPUs poll; without one
//! (`/sys/devices/system/cpu/cpuidle/current_driver` = `none`, e.g. a Firecracker VM) it
//! changes nothing, and `idle=poll` is a boot parameter.
//!
//! Here one thread per allowed CPU, pinned to it under `SCHED_IDLE`, runs a loop for as
//! long as the node runs: every other thread preempts it at once (the scheduler counts its
//! CPU as idle when placing a woken thread), so it takes no time from the machine's work,
//! but the CPU never halts. The cost is the machine's idle time: every CPU shows busy,
//! draws power and heats. Measured on a 2-vCPU VM (bench/runs/): the round trip's
//! median fell by 13–49 % at 100 Hz and 27–28 % at 1 kHz; keeping the CPUs awake only in
//! a window of ±0.3 … 3 ms around each expected joint state did not help — a vCPU that has
//! halted for milliseconds stays slow however early it is woken.
//!
//! ```toml
//! [node]
//! realtime = { priority = 80, lock_memory = true, dds_priority = 79, idle_poll = true }
//! ```

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread;

use crossym_control::realtime::RealtimeOutcome;

/// Loop iterations between two checks of `stop`.
const BATCH: u32 = 1 << 14;

/// The polling threads, one per allowed CPU; dropping stops and joins them.
#[derive(Debug)]
pub struct IdlePoll {
    stop: Arc<AtomicBool>,
    threads: Vec<thread::JoinHandle<()>>,
    /// Kernel thread ids of the pollers (for `/proc/self/task/<tid>`).
    tids: Vec<libc::pid_t>,
}

/// The CPUs this process may run on.
fn allowed_cpus() -> Vec<usize> {
    // SAFETY: a zeroed cpu_set_t is a valid empty set; the call fills it.
    let mut set: libc::cpu_set_t = unsafe { std::mem::zeroed() };
    let size = std::mem::size_of::<libc::cpu_set_t>();
    // SAFETY: pid 0 is this thread; `set` is `size` bytes and outlives the call.
    if unsafe { libc::sched_getaffinity(0, size, &mut set) } != 0 {
        return (0..thread::available_parallelism().map_or(1, |n| n.get())).collect();
    }
    (0..libc::CPU_SETSIZE as usize)
        // SAFETY: `c` < CPU_SETSIZE.
        .filter(|&c| unsafe { libc::CPU_ISSET(c, &set) })
        .collect()
}

/// Pins the calling thread to `cpu` and puts it under `SCHED_IDLE` (lowering its own
/// policy needs no privilege); the error names the call that failed.
fn become_poller(cpu: usize) -> Result<(), String> {
    // SAFETY: a zeroed cpu_set_t is a valid empty set; `cpu` < CPU_SETSIZE.
    let mut set: libc::cpu_set_t = unsafe { std::mem::zeroed() };
    unsafe { libc::CPU_SET(cpu, &mut set) };
    let size = std::mem::size_of::<libc::cpu_set_t>();
    // SAFETY: pid 0 is the calling thread; `set` outlives the call.
    if unsafe { libc::sched_setaffinity(0, size, &set) } != 0 {
        let e = std::io::Error::last_os_error();
        return Err(format!("sched_setaffinity(CPU {cpu}): {e}"));
    }
    let param = libc::sched_param { sched_priority: 0 };
    // SAFETY: pid 0 is the calling thread; `param` outlives the call.
    if unsafe { libc::sched_setscheduler(0, libc::SCHED_IDLE, &param) } != 0 {
        let e = std::io::Error::last_os_error();
        return Err(format!("sched_setscheduler(SCHED_IDLE): {e}"));
    }
    Ok(())
}

/// The poller's loop: plain loads, not `spin_loop` (PAUSE), whose loops make a KVM guest
/// exit to the host (pause-loop exiting), the very cost this avoids.
fn poll(stop: &AtomicBool) {
    while !stop.load(Ordering::Relaxed) {
        for i in 0..BATCH {
            std::hint::black_box(i);
        }
    }
}

impl IdlePoll {
    /// Starts one poller per allowed CPU (allocates; call at setup). Refused when a poller
    /// could not be pinned or lowered: the node then runs without.
    pub fn start() -> (Option<IdlePoll>, RealtimeOutcome) {
        let what = "idle CPUs poll instead of halting".to_string();
        let stop = Arc::new(AtomicBool::new(false));
        let cpus = allowed_cpus();
        let (ready_tx, ready_rx) = std::sync::mpsc::channel();
        let mut pollers = IdlePoll {
            stop: stop.clone(),
            threads: Vec::with_capacity(cpus.len()),
            tids: Vec::with_capacity(cpus.len()),
        };
        for &cpu in &cpus {
            let stop = stop.clone();
            let ready = ready_tx.clone();
            let spawned = thread::Builder::new()
                .name(format!("crossym-idle{cpu}"))
                .spawn(move || {
                    // SAFETY: gettid takes no arguments.
                    let tid = unsafe { libc::gettid() };
                    let r = become_poller(cpu);
                    let ok = r.is_ok();
                    let _ = ready.send(r.map(|()| tid));
                    if ok {
                        poll(&stop);
                    }
                });
            match spawned {
                Ok(h) => pollers.threads.push(h),
                Err(e) => {
                    let reason = format!("thread: {e}");
                    return (None, RealtimeOutcome::Refused { what, reason });
                }
            }
        }
        drop(ready_tx);
        let mut refused = None;
        for r in ready_rx.iter().take(pollers.threads.len()) {
            match r {
                Ok(t) => pollers.tids.push(t),
                Err(e) => refused = Some(e),
            }
        }
        if let Some(reason) = refused {
            return (None, RealtimeOutcome::Refused { what, reason });
        }
        let what = format!(
            "{what} ({} SCHED_IDLE thread{} on CPUs {:?}; they show busy)",
            cpus.len(),
            if cpus.len() == 1 { "" } else { "s" },
            cpus
        );
        (Some(pollers), RealtimeOutcome::Applied { what })
    }

    /// The pollers' kernel thread ids.
    pub fn tids(&self) -> &[libc::pid_t] {
        &self.tids
    }
}

impl Drop for IdlePoll {
    /// Stops and joins the pollers.
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    /// What the kernel says of thread `tid` of this process (`/proc/self/task/<tid>/stat`):
    /// its state (`R`, `S`, …) and policy (field 41: 5 = `SCHED_IDLE`); `None` once it
    /// has exited.
    fn kernel_view(tid: libc::pid_t) -> Option<(char, u32)> {
        let stat = std::fs::read_to_string(format!("/proc/self/task/{tid}/stat")).ok()?;
        let after: Vec<&str> = stat[stat.rfind(')')? + 2..].split(' ').collect();
        // `after[0]` is field 3 (state); field 41 (policy) is `after[38]`.
        Some((after[0].chars().next()?, after[38].parse().ok()?))
    }

    /// The pollers, as the kernel sees them: one per allowed CPU, `SCHED_IDLE`, never
    /// asleep while they live (sampled 20 times over 0.2 s), gone once dropped.
    #[test]
    fn pollers_keep_every_cpu_busy_at_idle_priority_and_end_when_dropped() {
        let (pollers, outcome) = IdlePoll::start();
        let pollers = pollers.unwrap_or_else(|| panic!("{outcome}"));
        assert_eq!(pollers.tids().len(), allowed_cpus().len());
        let tids = pollers.tids().to_vec();
        for _ in 0..20 {
            thread::sleep(Duration::from_millis(10));
            for &t in &tids {
                let (state, policy) = kernel_view(t).expect("poller alive");
                assert_eq!(state, 'R', "poller {t} not running or runnable");
                assert_eq!(policy, libc::SCHED_IDLE as u32, "poller {t} policy");
            }
        }
        drop(pollers);
        for &t in &tids {
            assert_eq!(kernel_view(t), None, "poller {t} still alive");
        }
    }
}
