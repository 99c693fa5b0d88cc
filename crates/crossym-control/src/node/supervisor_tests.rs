//! The supervisor's rules, each on its own: the restart window, the not-following latch
//! and what releases it, the tracking envelope's restart, a controller's resume, a held
//! robot's dwell and the tracking warning. One joint, a robot placed by hand.

use crossym_math::kinematics::JointLimits;
use crossym_math::symmetry::compose::Condition;

use super::*;
use crate::node::config::OutputMode;

const DT: f64 = 0.01;

fn settings() -> FollowSettings {
    FollowSettings {
        tolerance: 0.01,
        window_s: 0.0,
        warning: Some(0.05),
        max_restarts: 2,
        restart_window_s: 1.0,
        held_dwell_s: 0.5,
        period_s: DT,
        state_delay_s: 0.0,
        latency_s: DT,
    }
}

fn limits() -> Vec<JointLimits> {
    vec![JointLimits {
        lower: -3.0,
        upper: 3.0,
        velocity: 2.0,
        effort: 10.0,
        acceleration: Some(1.0),
    }]
}

fn supervisor() -> Supervisor {
    Supervisor::new(1, settings(), MotionSettings::default(), 64)
}

/// A joint state `q` measured and received at `t`, the `seq`-th, under condition `cond`.
fn inputs(q: f64, t: f64, seq: u64, cond: u64) -> Inputs {
    let mut i = Inputs::new(1, Condition::IDENTITY);
    i.q[0] = q;
    i.state_time_s = Some(t);
    i.measured_time_s = t;
    i.joint_state_seq = seq;
    i.condition_seq = cond;
    i
}

/// Commands `q` at rest at `t` (what the core does after a go).
fn command(sup: &mut Supervisor, t: f64, q: f64) {
    let out = Command {
        mode: OutputMode::Position,
        velocities: vec![0.0],
        positions: vec![q],
        start_positions: vec![0.0],
        start_velocities: vec![0.0],
    };
    sup.commanded(t, true, &out);
}

/// One tick at `t` on the state `q`: admit, then follow; the verdict and the restart at
/// rest, and (on a go) the hold commanded again.
fn tick(sup: &mut Supervisor, c: &mut Counters, i: &Inputs, t: f64) -> (Verdict, bool) {
    if let Some(code) = sup.admit(t, i.condition_seq, c) {
        return (Verdict::Brake(code), false);
    }
    let (v, at_rest) = sup.follow(t, i, &limits(), false, c);
    if let Verdict::Go { .. } = v {
        let q = sup.q_hold()[0];
        command(sup, t, q);
    }
    (v, at_rest)
}

const GO: Verdict = Verdict::Go {
    restart: None,
    lagging: false,
};
const RESTARTED: Verdict = Verdict::Go {
    restart: Some(StatusCode::RestartedFromMeasured),
    lagging: false,
};
const NOT_FOLLOWING: Verdict = Verdict::Brake(StatusCode::RobotNotFollowing);

#[test]
fn more_than_max_restarts_within_the_window_is_not_following() {
    let mut w = RestartWindow::new(2, 1.0);
    assert!(!w.record(0.0));
    assert!(!w.record(0.5));
    // The third restart within 1 s: more than two.
    assert!(w.record(1.0), "3 restarts in exactly the window");
    // Spaced out: the oldest of the last three is more than the window ago.
    let mut w = RestartWindow::new(2, 1.0);
    assert!(!w.record(0.0));
    assert!(!w.record(0.6));
    assert!(!w.record(1.2));
    assert!(!w.record(1.8));
    assert!(w.record(2.0), "1.2, 1.8, 2.0 are within 1 s");
    // A clean count after clear.
    w.clear();
    assert!(!w.record(2.1));
    assert!(!w.record(2.2));
    assert!(w.record(2.3));
    // No restart allowed: the first one is already too many.
    assert!(RestartWindow::new(0, 1.0).record(5.0));
}

#[test]
fn the_first_tick_starts_at_rest_from_the_measured_state_and_a_follower_goes_on() {
    let mut sup = supervisor();
    let mut c = Counters::default();
    // Beyond the upper limit: the hold is clamped into the limits.
    assert_eq!(
        tick(&mut sup, &mut c, &inputs(3.5, 0.0, 1, 1), 0.0),
        (GO, true)
    );
    assert_eq!(sup.q_hold(), &[3.0]);
    assert!(sup.has_hold());
    // The robot where the commands are, and within the tolerance of them: no restart.
    assert_eq!(
        tick(&mut sup, &mut c, &inputs(3.0, DT, 2, 1), DT),
        (GO, false)
    );
    assert_eq!(
        tick(&mut sup, &mut c, &inputs(2.995, 2.0 * DT, 3, 1), 2.0 * DT),
        (GO, false)
    );
    assert_eq!(c.restarts, 0);
    assert_eq!(sup.q_hold(), &[3.0]);
}

#[test]
fn a_robot_outside_the_envelope_restarts_from_the_measured_state() {
    let mut sup = supervisor();
    let mut c = Counters::default();
    tick(&mut sup, &mut c, &inputs(0.0, 0.0, 1, 1), 0.0);
    // Farther than the tolerance from every command: restarted there, counted.
    assert_eq!(
        tick(&mut sup, &mut c, &inputs(0.5, DT, 2, 1), DT),
        (RESTARTED, true)
    );
    assert_eq!(sup.q_hold(), &[0.5]);
    assert_eq!(c.restarts, 1);
    assert_eq!(sup.tracking_error(), 0.0);
    assert_eq!(sup.v_last(), &[0.0]);
}

/// Restarts the supervisor `k` times by moving the robot 0.3 rad a tick from `t0`;
/// returns the verdicts.
fn push_around(
    sup: &mut Supervisor,
    c: &mut Counters,
    t0: f64,
    cond: u64,
    k: usize,
) -> Vec<Verdict> {
    (1..=k)
        .map(|i| {
            let t = t0 + i as f64 * DT;
            let q = sup.q_hold()[0] + 0.3;
            tick(sup, c, &inputs(q, t, 100 * cond + i as u64, cond), t).0
        })
        .collect()
}

#[test]
fn repeated_restarts_latch_not_following_until_a_new_condition() {
    let mut sup = supervisor();
    let mut c = Counters::default();
    tick(&mut sup, &mut c, &inputs(0.0, 0.0, 1, 1), 0.0);
    // Two restarts are allowed, the third within the window latches.
    let v = push_around(&mut sup, &mut c, 0.0, 1, 3);
    assert_eq!(v, [RESTARTED, RESTARTED, NOT_FOLLOWING]);
    assert_eq!((c.restarts, c.not_following_ticks), (3, 1));
    // Latched: held whatever the robot does, every tick counted, while the condition is
    // the one it was found under.
    let hold = sup.q_hold()[0];
    for k in 1..=3 {
        let t = 0.03 + k as f64 * DT;
        let v = tick(&mut sup, &mut c, &inputs(hold, t, 200 + k, 1), t);
        assert_eq!(v, (NOT_FOLLOWING, false), "tick {k} of the latch");
    }
    assert_eq!(c.not_following_ticks, 4);
    assert_eq!(sup.q_hold(), &[hold], "the latch keeps the hold");
    // A new condition: released, from the measured state, with a clean count: two
    // restarts are allowed again.
    assert_eq!(
        tick(&mut sup, &mut c, &inputs(1.0, 0.1, 300, 2), 0.1),
        (GO, true)
    );
    assert_eq!(sup.q_hold(), &[1.0]);
    let v = push_around(&mut sup, &mut c, 0.1, 2, 3);
    assert_eq!(v, [RESTARTED, RESTARTED, NOT_FOLLOWING]);
    assert_eq!(c.restarts, 6);
}

#[test]
fn an_operators_reset_releases_the_latch_with_a_clean_count() {
    let mut sup = supervisor();
    let mut c = Counters::default();
    tick(&mut sup, &mut c, &inputs(0.0, 0.0, 1, 1), 0.0);
    push_around(&mut sup, &mut c, 0.0, 1, 3);
    assert_eq!(
        tick(&mut sup, &mut c, &inputs(0.0, 0.05, 50, 1), 0.05).0,
        NOT_FOLLOWING
    );
    sup.reset();
    // Same condition, yet released: starts at rest from the measured state.
    assert_eq!(
        tick(&mut sup, &mut c, &inputs(0.2, 0.06, 51, 1), 0.06),
        (GO, true)
    );
    assert_eq!(sup.q_hold(), &[0.2]);
    let v = push_around(&mut sup, &mut c, 0.06, 1, 2);
    assert_eq!(v, [RESTARTED, RESTARTED], "a clean count after the reset");
}

#[test]
fn restarts_spread_over_more_than_the_window_never_latch() {
    let mut sup = supervisor();
    let mut c = Counters::default();
    tick(&mut sup, &mut c, &inputs(0.0, 0.0, 1, 1), 0.0);
    for k in 1..=10u64 {
        let t = k as f64 * 0.6;
        let q = sup.q_hold()[0] + if k % 2 == 0 { 0.5 } else { -0.5 };
        assert_eq!(
            tick(&mut sup, &mut c, &inputs(q, t, k + 1, 1), t).0,
            RESTARTED,
            "restart {k}"
        );
    }
    assert_eq!((c.restarts, c.not_following_ticks), (10, 0));
}

#[test]
fn a_controller_back_restarts_from_the_measured_state_and_counts() {
    let mut sup = supervisor();
    let mut c = Counters::default();
    tick(&mut sup, &mut c, &inputs(0.0, 0.0, 1, 1), 0.0);
    let i = inputs(0.001, DT, 2, 1);
    assert_eq!(sup.admit(DT, 1, &mut c), None);
    let (v, at_rest) = sup.follow(DT, &i, &limits(), true, &mut c);
    assert_eq!((v, at_rest), (RESTARTED, true));
    assert_eq!(sup.q_hold(), &[0.001]);
    assert_eq!(c.restarts, 1);
    // No hold yet: a resume is nothing to restart.
    let mut fresh = supervisor();
    let (v, _) = fresh.follow(0.0, &i, &limits(), true, &mut c);
    assert_eq!(v, GO);
    assert_eq!(c.restarts, 1);
}

#[test]
fn a_held_robot_dwells_then_is_tried_again_from_the_measured_state() {
    let mut sup = supervisor();
    let mut c = Counters::default();
    tick(&mut sup, &mut c, &inputs(0.0, 0.0, 1, 1), 0.0);
    sup.held = Held::Dwell(0.5);
    assert_eq!(sup.admit(0.49, 1, &mut c), Some(StatusCode::RobotHeld));
    assert!(sup.has_hold(), "held at the hold during the dwell");
    assert!(!sup.probing());
    // The dwell over: tried again, from the measured state (no hold), reported held.
    assert_eq!(sup.admit(0.5, 1, &mut c), None);
    assert!(sup.probing());
    assert!(!sup.has_hold());
    let (v, at_rest) = sup.follow(0.5, &inputs(0.3, 0.5, 2, 1), &limits(), false, &mut c);
    assert_eq!((v, at_rest), (GO, true));
    assert_eq!(sup.q_hold(), &[0.3]);
    // A reset clears it.
    sup.reset();
    assert!(!sup.probing());
}

#[test]
fn the_tracking_warning_holds_after_the_window_and_counts() {
    let s = FollowSettings {
        window_s: 0.05,
        ..settings()
    };
    let mut w = TrackingWatch {
        high_since: None,
        error: 0.06,
    };
    let mut count = 0;
    assert!(!w.watch(0.0, &s, &mut count));
    assert!(!w.watch(0.04, &s, &mut count));
    assert!(w.watch(0.05, &s, &mut count));
    assert!(w.watch(0.06, &s, &mut count));
    assert_eq!(count, 2);
    // Back under: the watch starts again.
    w.error = 0.05;
    assert!(!w.watch(0.07, &s, &mut count));
    w.error = 0.06;
    assert!(!w.watch(0.08, &s, &mut count));
    // No warning configured: never.
    let off = FollowSettings { warning: None, ..s };
    assert!(!w.watch(10.0, &off, &mut count));
    assert_eq!(count, 2);
}

/// The held robot tried again: the dwell over, the policy commands away from the robot,
/// which does not move. Returns the verdict of the tick that finds it held again, at `t`.
fn try_held_robot(sup: &mut Supervisor, c: &mut Counters, t: f64, seq: &mut u64) -> Verdict {
    assert_eq!(sup.admit(t, 1, c), None, "the dwell is over at {t}");
    assert!(sup.probing());
    *seq += 1;
    let (v, at_rest) = tick(sup, c, &inputs(0.3, t, *seq, 1), t);
    assert_eq!(
        (v, at_rest),
        (GO, true),
        "tried again from the measured state"
    );
    // The policy pulls the command beyond the tolerance; the robot stays where it is.
    command(sup, t + DT, 0.3 + 2.0 * settings().tolerance);
    *seq += 1;
    let i = inputs(0.3, t + 2.0 * DT, *seq, 1);
    sup.follow(t + 2.0 * DT, &i, &limits(), false, c).0
}

#[test]
fn a_robot_held_through_repeated_tries_latches_not_following() {
    let s = FollowSettings {
        held_dwell_s: 0.2,
        ..settings()
    };
    let mut sup = Supervisor::new(1, s, MotionSettings::default(), 64);
    let mut c = Counters::default();
    let mut seq = 1;
    tick(&mut sup, &mut c, &inputs(0.3, 0.0, seq, 1), 0.0);
    sup.held = Held::Dwell(0.2);
    // Each try held again counts as a restart: the first two brake as held, ...
    let held = Verdict::Brake(StatusCode::RobotHeld);
    assert_eq!(try_held_robot(&mut sup, &mut c, 0.2, &mut seq), held);
    assert_eq!((c.held_events, c.restarts), (1, 1));
    assert_eq!(sup.q_hold(), &[0.3], "held at the measured state");
    assert_eq!(try_held_robot(&mut sup, &mut c, 0.5, &mut seq), held);
    // ... the third within the window (more than max_restarts = 2) latches.
    assert_eq!(
        try_held_robot(&mut sup, &mut c, 0.8, &mut seq),
        NOT_FOLLOWING
    );
    assert_eq!((c.held_events, c.restarts), (3, 3));
    assert_eq!(
        sup.q_hold(),
        &[0.3],
        "the latch holds at the measured state"
    );
    assert!(!sup.probing());
    let i = inputs(0.3, 1.0, seq + 1, 1);
    assert_eq!(tick(&mut sup, &mut c, &i, 1.0).0, NOT_FOLLOWING);
    // A release within the tries goes on: the try that moves is no restart.
    let mut sup = Supervisor::new(1, s, MotionSettings::default(), 64);
    let mut c = Counters::default();
    let mut seq = 1;
    tick(&mut sup, &mut c, &inputs(0.3, 0.0, seq, 1), 0.0);
    sup.held = Held::Dwell(0.2);
    assert_eq!(try_held_robot(&mut sup, &mut c, 0.2, &mut seq), held);
    assert_eq!(sup.admit(0.5, 1, &mut c), None);
    let (v, _) = tick(&mut sup, &mut c, &inputs(0.3, 0.5, seq + 1, 1), 0.5);
    assert_eq!(v, GO);
    command(&mut sup, 0.51, 0.32);
    let i = inputs(0.32, 0.52, seq + 2, 1);
    assert_eq!(sup.follow(0.52, &i, &limits(), false, &mut c).0, GO);
    assert!(!sup.probing(), "released: the robot moved with its command");
    assert_eq!(c.restarts, 1, "one try held again, the release none");
}
