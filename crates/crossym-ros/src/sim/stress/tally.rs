//! The counts of an episode or a campaign: violations with their worst excess, and what
//! was drawn (faults, adversaries, tight limits, extrapolated conditions, drops).

/// Counts of one episode or a sum of them.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Tally {
    /// Episodes (count).
    pub episodes: u64,
    /// Node ticks (count).
    pub ticks: u64,
    /// Commands published (count).
    pub commands: u64,
    /// Position violations (count of robot samples beyond a limit).
    pub position: u64,
    /// Worst position excess beyond a limit (rad or m).
    pub position_worst: f64,
    /// Velocity violations (count).
    pub velocity: u64,
    /// Worst velocity excess (rad/s or m/s).
    pub velocity_worst: f64,
    /// Acceleration violations (count).
    pub acceleration: u64,
    /// Worst acceleration excess (rad/s² or m/s²).
    pub acceleration_worst: f64,
    /// Non-finite published values (count).
    pub nonfinite: u64,
    /// Input faults injected, by kind (name, count).
    pub faults: Vec<(&'static str, u64)>,
    /// Adversarial policies drawn, by kind (name, count).
    pub adversaries: Vec<(&'static str, u64)>,
    /// Episodes on tight limits (count).
    pub tight: u64,
    /// Episodes with an extrapolated condition (count).
    pub untrained: u64,
    /// Episodes starting within 5 mrad of a bound (count).
    pub near_bound: u64,
    /// Episodes with dropped commands (count).
    pub with_drops: u64,
    /// Seeds of the episodes with a violation (at most 20).
    pub failing_seeds: Vec<u64>,
}

impl Tally {
    /// True when nothing was violated.
    pub fn clean(&self) -> bool {
        self.position == 0 && self.velocity == 0 && self.acceleration == 0 && self.nonfinite == 0
    }

    pub(super) fn bump(list: &mut Vec<(&'static str, u64)>, name: &'static str, by: u64) {
        match list.iter_mut().find(|(n, _)| *n == name) {
            Some((_, c)) => *c += by,
            None => list.push((name, by)),
        }
    }

    pub(super) fn add(&mut self, o: &Tally) {
        self.episodes += o.episodes;
        self.ticks += o.ticks;
        self.commands += o.commands;
        self.position += o.position;
        self.position_worst = self.position_worst.max(o.position_worst);
        self.velocity += o.velocity;
        self.velocity_worst = self.velocity_worst.max(o.velocity_worst);
        self.acceleration += o.acceleration;
        self.acceleration_worst = self.acceleration_worst.max(o.acceleration_worst);
        self.nonfinite += o.nonfinite;
        for &(n, c) in &o.faults {
            Self::bump(&mut self.faults, n, c);
        }
        for &(n, c) in &o.adversaries {
            Self::bump(&mut self.adversaries, n, c);
        }
        self.tight += o.tight;
        self.untrained += o.untrained;
        self.near_bound += o.near_bound;
        self.with_drops += o.with_drops;
        for &s in &o.failing_seeds {
            if self.failing_seeds.len() < 20 {
                self.failing_seeds.push(s);
            }
        }
    }
}
