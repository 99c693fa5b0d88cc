//! Latency statistics of a node run: the tick and each hop of the joint state → command
//! path, from fixed histograms of 1 µs bins (no allocation per sample).

/// Tick-duration statistics of one run (µs), from a fixed histogram of 1 µs bins.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TickStats {
    /// Ticks run (count).
    pub ticks: u64,
    /// Commands published (count).
    pub commands: u64,
    /// Publish errors (count).
    pub publish_errors: u64,
    /// Median tick duration (µs).
    pub median_us: f64,
    /// 99th percentile tick duration (µs).
    pub p99_us: f64,
    /// Maximum tick duration (µs).
    pub max_us: f64,
    /// Messages written to the bag (count).
    pub bag_messages: u64,
    /// Messages dropped because the bag writer fell behind (count).
    pub bag_dropped: u64,
    /// Joint state written by its publisher (its source stamp) → received by this node's
    /// DDS event loop (wall clock of both processes, µs).
    pub dds_in: HopStats,
    /// DDS receive → the control thread has taken the joint state from the reader (µs):
    /// one thread wake-up.
    pub to_control: HopStats,
    /// The command publish call (serialisation, hand-off to the DDS writer; µs).
    pub publish: HopStats,
    /// How late each tick started after its time (µs; `crossym_control::node::TickTiming`).
    pub late: HopStats,
    /// Ticks started more than half a period late (count).
    pub late_ticks: u64,
    /// Ticks never run (count).
    pub missed_ticks: u64,
}

/// Latency of one hop of the joint state → command path (µs), from a histogram of 1 µs bins.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct HopStats {
    /// Samples (count).
    pub count: u64,
    /// Median (µs).
    pub median_us: f64,
    /// 99th percentile (µs).
    pub p99_us: f64,
    /// Maximum (µs).
    pub max_us: f64,
}

impl std::fmt::Display for HopStats {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "median {:.0} µs, p99 {:.0} µs, max {:.0} µs ({} samples)",
            self.median_us, self.p99_us, self.max_us, self.count
        )
    }
}

/// Fixed-size histogram of durations, 1 µs bins up to 20 ms (no allocation per sample).
pub(super) struct Histogram {
    bins: Vec<u32>,
    n: u64,
    pub(super) max_us: f64,
}

impl Histogram {
    pub(super) fn new() -> Self {
        Self {
            bins: vec![0; 20_000],
            n: 0,
            max_us: 0.0,
        }
    }

    pub(super) fn record(&mut self, us: f64) {
        let last = self.bins.len() - 1;
        let b = if us.is_finite() && us >= 0.0 {
            (us as usize).min(last)
        } else {
            last
        };
        self.bins[b] = self.bins[b].saturating_add(1);
        self.n += 1;
        self.max_us = self.max_us.max(us);
    }

    pub(super) fn quantile(&self, p: f64) -> f64 {
        if self.n == 0 {
            return 0.0;
        }
        let target = (p * self.n as f64).ceil().max(1.0) as u64;
        let mut acc = 0u64;
        for (i, &c) in self.bins.iter().enumerate() {
            acc += u64::from(c);
            if acc >= target {
                return i as f64 + 0.5;
            }
        }
        self.max_us
    }

    pub(super) fn stats(&self) -> HopStats {
        HopStats {
            count: self.n,
            median_us: self.quantile(0.5),
            p99_us: self.quantile(0.99),
            max_us: self.max_us,
        }
    }
}

/// Microseconds from wall-clock stamp `from_ns` to `to_ns` (ns since the Unix epoch), at
/// least 0 (stamps of two threads or processes of one host).
pub(super) fn span_us(from_ns: i64, to_ns: i64) -> f64 {
    (to_ns.saturating_sub(from_ns)).max(0) as f64 * 1e-3
}
