//! Optional real-time settings of the node (`[node] realtime`), off by default, as the ROS 2
//! real-time guidance suggests: the control thread (the tick: FK, Jacobian, MLP, safety QP,
//! command) under `SCHED_FIFO` at a fixed priority, so a compiler or a logger on the same
//! cores cannot delay it, and the process's memory locked (`mlockall(MCL_CURRENT |
//! MCL_FUTURE)`), so a page fault never stalls a tick. The node's control thread is also
//! its DDS participant's event loop (it receives and sends every sample); optionally
//! RustDDS's other threads (`dds_priority`: its discovery thread, and the event loop of a
//! participant without a hook) run under `SCHED_FIFO` too.
//! And optionally a CPU wake-up latency limit (`cpu_latency_us`, the kernel's PM QoS
//! `/dev/cpu_dma_latency`, as `cyclictest` sets it), held while the node runs: with 0 an
//! idle CPU polls instead of halting, so the threads on the joint state → command path
//! (DDS receive, control thread, DDS send) wake in microseconds rather than tens to
//! hundreds — on a virtual machine a halted vCPU is the dominant cost of an idle round
//! trip. It applies to every CPU of the machine and costs their idle time. Where it has no
//! effect (no `cpuidle` driver, as on a Firecracker VM), `idle_poll = true` keeps them
//! polling from user space (`crossym_ros::idle_poll`); it needs no privilege.
//!
//! Both need privileges: `CAP_SYS_NICE` or an `rtprio` limit ≥ the priority (`ulimit -r`,
//! `/etc/security/limits.conf`, `docker run --cap-add SYS_NICE --ulimit rtprio=99`) and
//! `CAP_IPC_LOCK` or a `memlock` limit covering the process. Without them the node says so
//! and runs at normal priority.
//!
//! ```toml
//! [node]
//! realtime = { priority = 80, lock_memory = true, dds_priority = 79, cpu_latency_us = 0 }
//! # or, where idle CPUs halt whatever PM QoS asks:
//! realtime = { priority = 80, lock_memory = true, dds_priority = 79, idle_poll = true }
//! ```

use serde::{Deserialize, Serialize};

/// `[node] realtime`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RealtimeConfig {
    /// `SCHED_FIFO` priority of the control thread (1 … 99; higher runs first).
    pub priority: i32,
    /// Lock the process's current and future pages in RAM.
    #[serde(default)]
    pub lock_memory: bool,
    /// `SCHED_FIFO` priority (1 … 99) of RustDDS's own threads (discovery; the node's DDS
    /// event loop is its control thread, at `priority`); absent: they run at normal
    /// priority.
    #[serde(default)]
    pub dds_priority: Option<i32>,
    /// CPU wake-up latency limit (µs) requested through `/dev/cpu_dma_latency` while the node
    /// runs (0: idle CPUs poll); absent: the kernel's default.
    #[serde(default)]
    pub cpu_latency_us: Option<u32>,
    /// Keep every CPU from halting while the node runs: one `SCHED_IDLE` thread per CPU
    /// polls (`crossym_ros::idle_poll`, the stand-in for `idle=poll`; costs all idle CPU time).
    #[serde(default)]
    pub idle_poll: bool,
}

/// A real-time setting out of its domain.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum RealtimeConfigError {
    /// A SCHED_FIFO priority outside 1 … 99.
    #[error("{key} = {value} must be in 1 … 99 (SCHED_FIFO)")]
    Priority {
        /// The key (`priority`, `dds_priority`).
        key: &'static str,
        /// Its value.
        value: i32,
    },
}

impl RealtimeConfig {
    /// Checks the priority range.
    pub fn validate(&self) -> Result<(), RealtimeConfigError> {
        for (key, p) in [
            ("priority", Some(self.priority)),
            ("dds_priority", self.dds_priority),
        ] {
            if let Some(value) = p.filter(|p| !(1..=99).contains(p)) {
                return Err(RealtimeConfigError::Priority { key, value });
            }
        }
        Ok(())
    }
}

/// What applying one setting did.
#[derive(Debug, Clone, PartialEq, Eq)]
#[non_exhaustive]
pub enum RealtimeOutcome {
    /// Applied.
    Applied {
        /// What (for the log).
        what: String,
    },
    /// Refused by the kernel (usually a missing privilege).
    Refused {
        /// What was asked.
        what: String,
        /// The OS error and how to grant the privilege.
        reason: String,
    },
}

impl RealtimeOutcome {
    /// True when the kernel refused the setting.
    pub fn is_refused(&self) -> bool {
        matches!(self, Self::Refused { .. })
    }
}

impl std::fmt::Display for RealtimeOutcome {
    /// `realtime: <what>`, or `realtime: <what> REFUSED (<reason>); running without it`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Applied { what } => write!(f, "realtime: {what}"),
            Self::Refused { what, reason } => {
                write!(f, "realtime: {what} REFUSED ({reason}); running without it")
            }
        }
    }
}

/// How to grant the `SCHED_FIFO` privilege, for a refusal at `priority`.
fn rtprio_hint(priority: i32) -> String {
    format!("grant CAP_SYS_NICE or an rtprio limit ≥ {priority} (ulimit -r, /etc/security/limits.conf; docker: --cap-add SYS_NICE --ulimit rtprio=99)")
}

fn os_error(call: &str, hint: &str) -> String {
    let e = std::io::Error::last_os_error();
    // mlockall answers ENOMEM when the memlock limit is too small without CAP_IPC_LOCK.
    let denied = matches!(
        e.raw_os_error(),
        Some(libc::EPERM) | Some(libc::EACCES) | Some(libc::ENOMEM)
    );
    if denied {
        format!("{call}: {e}; {hint}")
    } else {
        format!("{call}: {e}")
    }
}

/// Puts thread `thread` (a running thread of this process) under `SCHED_FIFO` at
/// `cfg.priority`, and locks the process's memory when asked.
#[cfg(unix)]
pub fn apply(cfg: &RealtimeConfig, thread: libc::pthread_t) -> Vec<RealtimeOutcome> {
    let mut out = Vec::new();
    let param = libc::sched_param {
        sched_priority: cfg.priority,
    };
    let what = format!("control thread SCHED_FIFO priority {}", cfg.priority);
    // SAFETY: `thread` is a live thread of this process (its JoinHandle is held by the
    // caller) and `param` outlives the call.
    let rc = unsafe { libc::pthread_setschedparam(thread, libc::SCHED_FIFO, &param) };
    out.push(if rc == 0 {
        RealtimeOutcome::Applied { what }
    } else {
        let e = std::io::Error::from_raw_os_error(rc);
        let reason = if rc == libc::EPERM {
            format!("pthread_setschedparam: {e}; {}", rtprio_hint(cfg.priority))
        } else {
            format!("pthread_setschedparam: {e}")
        };
        RealtimeOutcome::Refused { what, reason }
    });
    if cfg.lock_memory {
        let what = "memory locked (mlockall current and future pages)".to_string();
        // SAFETY: mlockall takes flags only.
        let rc = unsafe { libc::mlockall(libc::MCL_CURRENT | libc::MCL_FUTURE) };
        out.push(if rc == 0 {
            RealtimeOutcome::Applied { what }
        } else {
            RealtimeOutcome::Refused {
                what,
                reason: os_error(
                    "mlockall",
                    "grant CAP_IPC_LOCK or a memlock limit covering the process (ulimit -l unlimited; docker: --cap-add IPC_LOCK --ulimit memlock=-1)",
                ),
            }
        });
    }
    if let Some(p) = cfg.dds_priority {
        out.push(apply_to_dds_threads(p));
    }
    out
}

/// A PM QoS CPU latency request, in force while this value lives (the kernel drops it when
/// the file is closed).
#[derive(Debug)]
pub struct CpuLatencyRequest {
    _file: std::fs::File,
}

/// Requests a CPU wake-up latency of at most `us` µs from the kernel (writes it to
/// `/dev/cpu_dma_latency` and keeps the file open in the returned request).
pub fn request_cpu_latency(us: u32) -> (Option<CpuLatencyRequest>, RealtimeOutcome) {
    use std::io::Write;
    let what = format!("CPU wake-up latency ≤ {us} µs (/dev/cpu_dma_latency)");
    let hint = "needs root or write access to /dev/cpu_dma_latency (docker: --device /dev/cpu_dma_latency)";
    let r = std::fs::OpenOptions::new()
        .write(true)
        .open("/dev/cpu_dma_latency")
        .and_then(|mut f| {
            // The device takes the value as a native-endian 32-bit integer.
            f.write_all(&(us as i32).to_ne_bytes())?;
            Ok(f)
        });
    match r {
        Ok(f) => (
            Some(CpuLatencyRequest { _file: f }),
            RealtimeOutcome::Applied { what },
        ),
        Err(e) => (
            None,
            RealtimeOutcome::Refused {
                what,
                reason: format!("/dev/cpu_dma_latency: {e}; {hint}"),
            },
        ),
    }
}

/// The start of the names (`comm`) of RustDDS's threads: `RustDDS discovery thread`,
/// `RustDDS Participant {id} event loop` (a hooked event loop is renamed by its hook).
const DDS_EVENT_LOOP_COMM: &str = "RustDDS";

/// Puts this process's RustDDS threads (found by name in `/proc/self/task`)
/// under `SCHED_FIFO` at `priority`.
#[cfg(unix)]
fn apply_to_dds_threads(priority: i32) -> RealtimeOutcome {
    let what = format!("RustDDS threads SCHED_FIFO priority {priority}");
    let tids: Vec<libc::pid_t> = std::fs::read_dir("/proc/self/task")
        .into_iter()
        .flatten()
        .flatten()
        .filter_map(|e| {
            let tid = e.file_name().to_str()?.parse().ok()?;
            let comm = std::fs::read_to_string(e.path().join("comm")).ok()?;
            comm.starts_with(DDS_EVENT_LOOP_COMM).then_some(tid)
        })
        .collect();
    if tids.is_empty() {
        return RealtimeOutcome::Refused {
            what,
            reason: format!("no thread named `{DDS_EVENT_LOOP_COMM}…` in /proc/self/task"),
        };
    }
    let param = libc::sched_param {
        sched_priority: priority,
    };
    for &tid in &tids {
        // SAFETY: `param` outlives the call; a tid that has exited makes it fail (ESRCH).
        if unsafe { libc::sched_setscheduler(tid, libc::SCHED_FIFO, &param) } != 0 {
            return RealtimeOutcome::Refused {
                what,
                reason: os_error("sched_setscheduler", &rtprio_hint(priority)),
            };
        }
    }
    RealtimeOutcome::Applied {
        what: format!(
            "{what} ({} thread{})",
            tids.len(),
            if tids.len() == 1 { "" } else { "s" }
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn priorities_outside_sched_fifo_are_refused() {
        for p in [0, 100, -1] {
            let c = RealtimeConfig {
                priority: p,
                lock_memory: false,
                dds_priority: None,
                cpu_latency_us: None,
                idle_poll: false,
            };
            assert!(
                c.validate().unwrap_err().to_string().contains("1 … 99"),
                "{p}"
            );
            let d = RealtimeConfig {
                priority: 80,
                lock_memory: false,
                dds_priority: Some(p),
                cpu_latency_us: None,
                idle_poll: false,
            };
            assert!(
                d.validate()
                    .unwrap_err()
                    .to_string()
                    .starts_with("dds_priority"),
                "{p}"
            );
        }
        let ok: RealtimeConfig = toml::from_str("priority = 80\nlock_memory = true").unwrap();
        assert_eq!(ok.validate(), Ok(()));
        assert!(toml::from_str::<RealtimeConfig>("priority = 80\nlock = true").is_err());
    }
}
