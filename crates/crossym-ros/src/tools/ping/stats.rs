//! What a ping measurement yields: the answered probes and their order statistics
//! (nearest-rank quantiles), the lost probes, and the commands that answered no probe told
//! apart by their DDS source stamps.

/// Order statistics of round trips (µs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Latency {
    /// Median (µs).
    pub median: f64,
    /// 99th percentile (µs).
    pub p99: f64,
    /// 99.9th percentile (µs).
    pub p999: f64,
    /// Maximum (µs).
    pub max: f64,
}

/// Nearest-rank quantiles of `v` (µs), sorted in place; `None` when empty.
pub fn latency(v: &mut [f64]) -> Option<Latency> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let q = |p: f64| v[((p * v.len() as f64).ceil() as usize).clamp(1, v.len()) - 1];
    Some(Latency {
        median: q(0.5),
        p99: q(0.99),
        p999: q(0.999),
        max: v[v.len() - 1],
    })
}

/// One answered probe: the round trip and its parts (µs), split by the stamps DDS carries
/// (both processes read the same wall clock).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Probe {
    /// Probe published → its command held by ping (monotonic clock).
    pub rtt: f64,
    /// Probe published → command published (the command's source stamp): over DDS to the
    /// node and through it.
    pub forward: Option<f64>,
    /// Command published → received by ping's DDS event loop.
    pub back: Option<f64>,
    /// Received → held by ping.
    pub wake: Option<f64>,
}

impl Probe {
    /// A probe published at `sent_ns` whose command, published at `source_ns` and received
    /// at `received_ns` (wall clock, ns; `None` where DDS carried no stamp), ping held at
    /// `taken_ns`, `rtt` µs after the publish.
    pub fn from_stamps(
        rtt: f64,
        sent_ns: i64,
        taken_ns: i64,
        source_ns: Option<i64>,
        received_ns: Option<i64>,
    ) -> Self {
        let us = |a: i64, b: i64| (b - a) as f64 * 1e-3;
        Self {
            rtt,
            forward: source_ns.map(|tx| us(sent_ns, tx)),
            back: source_ns.zip(received_ns).map(|(tx, rx)| us(tx, rx)),
            wake: received_ns.map(|rx| us(rx, taken_ns)),
        }
    }
}

/// Commands that answer no probe, by what explains them (their DDS source stamps against
/// the previous probe's publish time): the node's own ticks once no joint state came for
/// its stale timeout (ping stalled: the node rightly commands the stale-input stop at its
/// period), a late answer to a lost probe, or a stray (a command nothing explains, e.g.
/// a second tick per joint state, which a driver would take for the answer to its next
/// state).
#[derive(Debug, Clone, PartialEq)]
pub struct Unanswered {
    /// Publish time of the previous probe (ns) and whether a command answered it.
    prev: (i64, bool),
    /// The node's stale timeout (at least its period), ns.
    stale_ns: i64,
    /// Commands nothing explains (published before their probe, or without a stamp).
    pub stray: usize,
    /// Commands of the node's own ticks (no probe for its stale timeout).
    pub own_ticks: usize,
    /// Late answers to lost probes.
    pub late: usize,
}

impl Unanswered {
    /// None counted yet; the last warm-up probe went out at `warm_sent_ns` (answered), the
    /// node's stale timeout is `stale_s`.
    pub fn new(warm_sent_ns: i64, stale_s: f64) -> Self {
        Self {
            prev: (warm_sent_ns, true),
            stale_ns: (stale_s * 1e9) as i64,
            stray: 0,
            own_ticks: 0,
            late: 0,
        }
    }

    /// The probe published at `sent_ns` was answered (or not).
    pub fn probe(&mut self, sent_ns: i64, answered: bool) {
        self.prev = (sent_ns, answered);
    }

    /// Counts a command that answers no probe, by its DDS source stamp (ns).
    pub fn count_stamp(&mut self, source_ns: Option<i64>) {
        let (sent, answered) = self.prev;
        match source_ns {
            Some(t) if t >= sent + self.stale_ns => self.own_ticks += 1,
            Some(t) if t >= sent && !answered => self.late += 1,
            _ => self.stray += 1,
        }
    }
}

/// A finished measurement.
#[derive(Debug, Clone, PartialEq)]
pub struct PingReport {
    /// The answered probes, in order.
    pub probes: Vec<Probe>,
    /// Probes without a command within the reply timeout.
    pub lost: usize,
    /// Commands that answered no probe.
    pub unanswered: Unanswered,
}

impl PingReport {
    /// Order statistics of the round trips; `None` when every probe was lost.
    pub fn round_trips(&self) -> Option<Latency> {
        self.part(|p| Some(p.rtt))
    }

    /// Order statistics of probe published → command published.
    pub fn forward(&self) -> Option<Latency> {
        self.part(|p| p.forward)
    }

    /// Order statistics of command published → received by ping's DDS event loop.
    pub fn back(&self) -> Option<Latency> {
        self.part(|p| p.back)
    }

    /// Order statistics of received → held by ping.
    pub fn wake(&self) -> Option<Latency> {
        self.part(|p| p.wake)
    }

    fn part(&self, f: impl Fn(&Probe) -> Option<f64>) -> Option<Latency> {
        let mut v: Vec<f64> = self.probes.iter().filter_map(f).collect();
        latency(&mut v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearest_rank_quantiles() {
        let mut v: Vec<f64> = (1..=1000).rev().map(f64::from).collect();
        let l = latency(&mut v).unwrap();
        assert_eq!(
            (l.median, l.p99, l.p999, l.max),
            (500.0, 990.0, 999.0, 1000.0)
        );
        assert!(latency(&mut []).is_none());
        // One sample is every quantile.
        let l = latency(&mut [7.0]).unwrap();
        assert_eq!((l.median, l.p99, l.p999, l.max), (7.0, 7.0, 7.0, 7.0));
    }

    /// Unanswered commands by their source stamps (stale timeout 100 ms, probe at 1 s).
    #[test]
    fn unanswered_commands_are_told_apart_by_their_stamps() {
        const MS: i64 = 1_000_000;
        let mut u = Unanswered::new(0, 0.1);
        u.probe(1000 * MS, true);
        // A second command 10 ms after an answered probe: nothing explains it.
        u.count_stamp(Some(1010 * MS));
        // No stamp: cannot be explained either.
        u.count_stamp(None);
        // 100 ms and more after the probe: the node's stale-input ticks.
        u.count_stamp(Some(1100 * MS));
        u.count_stamp(Some(1110 * MS));
        // After a lost probe, a command inside its stale window is its late answer; one
        // from before it is still a stray.
        u.probe(2000 * MS, false);
        u.count_stamp(Some(2060 * MS));
        u.count_stamp(Some(1990 * MS));
        assert_eq!((u.stray, u.late, u.own_ticks), (3, 1, 2));
    }

    /// A round trip split by its stamps: 300 µs to the node's publish, 150 µs back over
    /// DDS, 50 µs to wake ping; no stamps, no parts.
    #[test]
    fn a_probe_is_split_by_the_stamps() {
        let p = Probe::from_stamps(
            510.0,
            1_000_000,
            1_500_000,
            Some(1_300_000),
            Some(1_450_000),
        );
        assert_eq!(
            (p.forward, p.back, p.wake),
            (Some(300.0), Some(150.0), Some(50.0))
        );
        let p = Probe::from_stamps(510.0, 1_000_000, 1_500_000, None, Some(1_450_000));
        assert_eq!((p.forward, p.back, p.wake), (None, None, Some(50.0)));
    }

    /// The report's statistics per part, over the probes that carry it.
    #[test]
    fn report_statistics_per_part() {
        let probe = |rtt: f64, fwd: Option<f64>| Probe {
            rtt,
            forward: fwd,
            back: None,
            wake: Some(1.0),
        };
        let r = PingReport {
            probes: vec![
                probe(300.0, Some(100.0)),
                probe(100.0, None),
                probe(200.0, Some(50.0)),
            ],
            lost: 1,
            unanswered: Unanswered::new(0, 0.1),
        };
        let rtt = r.round_trips().unwrap();
        assert_eq!((rtt.median, rtt.max), (200.0, 300.0));
        let fwd = r.forward().unwrap();
        assert_eq!((fwd.median, fwd.max), (50.0, 100.0));
        assert!(r.back().is_none());
        assert_eq!(r.wake().unwrap().max, 1.0);
        let empty = PingReport {
            probes: vec![],
            ..r
        };
        assert!(empty.round_trips().is_none());
    }
}
