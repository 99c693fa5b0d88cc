//! Optional real-time settings of the node (`[node] realtime`), off by default, as the ROS 2
//! real-time guidance suggests: the control thread (the tick: FK, Jacobian, MLP, safety QP,
//! command) under `SCHED_FIFO` at a fixed priority, so a compiler or a logger on the same
//! cores cannot delay it, and the process's memory locked (`mlockall(MCL_CURRENT |
//! MCL_FUTURE)`), so a page fault never stalls a tick.
//!
//! Both need privileges: `CAP_SYS_NICE` or an `rtprio` limit ≥ the priority (`ulimit -r`,
//! `/etc/security/limits.conf`, `docker run --cap-add SYS_NICE --ulimit rtprio=99`) and
//! `CAP_IPC_LOCK` or a `memlock` limit covering the process. Without them the node says so
//! and runs at normal priority.
//!
//! ```toml
//! [node]
//! realtime = { priority = 80, lock_memory = true }
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
}

impl RealtimeConfig {
    /// Checks the priority range.
    pub fn validate(&self) -> Result<(), String> {
        if !(1..=99).contains(&self.priority) {
            return Err(format!(
                "priority = {} must be in 1 … 99 (SCHED_FIFO)",
                self.priority
            ));
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
            format!(
                "pthread_setschedparam: {e}; grant CAP_SYS_NICE or an rtprio limit ≥ {} (ulimit -r, /etc/security/limits.conf; docker: --cap-add SYS_NICE --ulimit rtprio=99)",
                cfg.priority
            )
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
    out
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
            };
            assert!(c.validate().unwrap_err().contains("1 … 99"), "{p}");
        }
        let ok: RealtimeConfig = toml::from_str("priority = 80\nlock_memory = true").unwrap();
        assert_eq!(ok.validate(), Ok(()));
        assert!(toml::from_str::<RealtimeConfig>("priority = 80\nlock = true").is_err());
    }
}
