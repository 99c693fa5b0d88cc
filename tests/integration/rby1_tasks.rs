//! The RB-Y1 tasks (paper Sec. VI-B): letters drawn in a 3-D plane, synthetic
//! reaching demonstrations, explicit test-condition lists and the `[M, R]` composition
//! without scaling. Skipped (with a message) when `robots/rby1a/` is absent.

use crossym::config::Config;
use crossym::data::augmentation::letter_augmenter;
use crossym::policy::{GroupGrid, SubGroup};
use crossym::symmetry::compose::Condition;

use crate::common;

use common::dist;

fn rby1_config(name: &str) -> Option<Config> {
    common::rby1_urdf()?;
    Some(common::load_config(name))
}

/// The config, robot and demonstrations of an RB-Y1 task (None without `robots/rby1a/`).
fn rby1_task(
    name: &str,
) -> Option<(
    Config,
    crossym::config::LoadedRobot,
    crossym::data::demonstrations::Demonstrations,
)> {
    common::rby1_urdf()?;
    Some(common::task(name))
}

#[test]
fn rby1_letters_are_drawn_in_the_configured_plane() {
    let Some((_, robot, demos)) = rby1_task("rby1-letters.toml") else {
        return;
    };
    let kin = &robot.kinematics;
    assert_eq!(demos.demos.len(), 7);
    assert!(
        demos.max_tracking_error < 1e-3,
        "tracking error {} m",
        demos.max_tracking_error
    );
    for d in &demos.demos {
        assert_eq!((d.n, d.m), (14, 6));
        for i in 0..d.len() {
            let x = d.x(i);
            // Both hands stay in the drawing plane x = 0.45 m, each on its side.
            assert!(
                (x[0] - 0.45).abs() < 1e-3 && (x[3] - 0.45).abs() < 1e-3,
                "{x:?}"
            );
            assert!(x[1] > 0.1 && x[4] < -0.1, "{x:?}");
            assert!(kin.within_limits(d.q(i)));
        }
    }
    // The letter box: 2 × half_range (12 cm) per in-plane axis, jointly over all demos.
    let (mut lo, mut hi) = (f64::MAX, f64::MIN);
    for d in &demos.demos {
        for i in 0..d.len() {
            lo = lo.min(d.x(i)[2]);
            hi = hi.max(d.x(i)[2]);
        }
    }
    assert!(
        hi - lo > 0.1 && hi - lo <= 0.12 + 1e-3,
        "height {}",
        hi - lo
    );
}

#[test]
fn reach_demonstrations_end_at_the_goal_and_the_other_arm_rests() {
    let Some((_, _, demos)) = rby1_task("rby1-pan.toml") else {
        return;
    };
    assert_eq!(demos.demos.len(), 2);
    let goal = [0.38, -0.18, -0.25];
    for d in &demos.demos {
        let last = d.x(d.len() - 1);
        assert!(
            dist(&last[3..], &goal) < 2e-3,
            "right hand ends at {last:?}"
        );
        let first = d.x(0);
        for i in 0..d.len() {
            // The left arm holds its rest posture (within the tracking's damping).
            assert!(dist(&d.x(i)[..3], &first[..3]) < 1e-6);
        }
        // Minimum jerk, its first 0.45 s dropped: starts moving (a first-order policy
        // cannot leave a rest point), ends at rest.
        let speed = |i: usize| d.qdot(i).iter().map(|v| v * v).sum::<f64>().sqrt();
        let peak = (0..d.len()).map(speed).fold(0.0, f64::max);
        assert!(peak > 0.2, "peak joint speed {peak}");
        assert!(
            speed(0) > 0.1 * peak,
            "start speed {} of peak {peak}",
            speed(0)
        );
        assert!(speed(d.len() - 1) < 0.05);
    }
    // The two demonstrations take different paths.
    let (a, b) = (&demos.demos[0], &demos.demos[1]);
    assert!(dist(a.x(a.len() / 3), b.x(b.len() / 3)) > 0.02);
}

#[test]
fn explicit_test_conditions_are_produced_exactly() {
    let Some((cfg, robot, demos)) = rby1_task("rby1-pan.toml") else {
        return;
    };
    let kin = &robot.kinematics;
    let (built, _) = crossym::symmetry::check::build(kin, &cfg.symmetries).unwrap();
    let aug = letter_augmenter(kin, &built, &cfg.composition.order).unwrap();
    let grids = cfg.augmentation.as_ref().unwrap();
    grids.test.validate().unwrap();
    aug.supports(&grids.test).unwrap();
    let wanted = grids.test.conditions();
    assert_eq!(wanted.len(), 10);
    let set = aug.augment(&demos.select(&[1]), &grids.test, &|| {});
    assert_eq!(set.trajectories.len() + set.dropped.len(), 10);
    for a in &set.trajectories {
        assert!(wanted.contains(&a.condition), "{:?}", a.condition);
    }
    // The rotated grasp point: the right hand ends at the handle turned about the pan axis;
    // with σ = −1 the left hand ends at the mirrored handle.
    let (c, r) = ([0.38, 0.0, -0.25], [0.0, -0.18, 0.0]);
    for a in &set.trajectories {
        let t = a.condition.theta;
        let h = [
            c[0] + t.cos() * r[0] - t.sin() * r[1],
            c[1] + t.sin() * r[0] + t.cos() * r[1],
            c[2],
        ];
        let end = a.traj.x(a.traj.len() - 1);
        let hand = if a.condition.reflection == 1 {
            &end[3..]
        } else {
            &end[..3]
        };
        let target = if a.condition.reflection == 1 {
            h
        } else {
            [h[0], -h[1], h[2]]
        };
        // Rotation then reflection (eq. 23): ρ(σ) Φ_R(θ) — the mirrored handle of R(θ).
        assert!(
            dist(hand, &target) < 3e-3,
            "{:?}: {hand:?} vs {target:?}",
            a.condition
        );
    }
    // Sub-groups of an explicit list are filters of it.
    let r = grids.test.restrict(SubGroup::R).conditions();
    assert_eq!(r.len(), 5);
    assert!(r.iter().all(|c| c.reflection == 1));
    assert_eq!(
        grids.test.restrict(SubGroup::Identity).conditions().len(),
        0
    );
}

#[test]
fn grids_without_a_scaling_symmetry_and_mixed_grids_are_refused() {
    let Some(cfg) = rby1_config("rby1-pan.toml") else {
        return;
    };
    let robot = cfg.load_robot().unwrap();
    let kin = &robot.kinematics;
    let (built, _) = crossym::symmetry::check::build(kin, &cfg.symmetries).unwrap();
    let aug = letter_augmenter(kin, &built, &cfg.composition.order).unwrap();
    let scaled = GroupGrid {
        scales: vec![0.5, 1.0],
        ..GroupGrid::identity()
    };
    let e = aug.supports(&scaled).unwrap_err().to_string();
    assert!(e.contains("no scaling"), "{e}");
    let mixed = GroupGrid {
        rotation_step_deg: Some(30.0),
        conditions: Some(vec![[10.0, 1.0, 1.0]]),
        ..GroupGrid::identity()
    };
    assert!(mixed
        .validate()
        .unwrap_err()
        .to_string()
        .contains("conditions"));
    let bad = GroupGrid {
        conditions: Some(vec![[10.0, 1.0, 0.0]]),
        ..GroupGrid::identity()
    };
    assert!(bad.validate().is_err());
    let limited = GroupGrid {
        rotation_step_deg: Some(30.0),
        max_rotation_deg: Some(60.0),
        ..GroupGrid::identity()
    };
    assert_eq!(limited.angles().len(), 5);
    let _ = Condition::IDENTITY;
}

#[test]
fn broken_rby1_task_configs_are_refused_with_reasons() {
    let Some(cfg) = rby1_config("rby1-letters.toml") else {
        return;
    };
    let robot = cfg.load_robot().unwrap();
    let kin = &robot.kinematics;
    let err = |edit: &dyn Fn(&mut crossym::data::letters::ArmLetter, usize)| {
        common::demos_with(&cfg, kin, |d| {
            for (i, a) in d.sources[0].arms.iter_mut().enumerate() {
                edit(a, i);
            }
        })
        .unwrap_err()
        .to_string()
    };
    let e = err(&|a, i| {
        if i == 0 {
            a.plane = None
        }
    });
    assert!(e.contains("plane"), "{e}");
    let e = err(&|a, i| {
        if i == 0 {
            a.offset = Some(vec![0.0, 0.0, 0.0])
        }
    });
    assert!(e.contains("exactly one"), "{e}");
    let reach = |goal: Vec<f64>| crossym::data::letters::Reach {
        goal,
        via: vec![],
        duration_s: 1.0,
        start: None,
    };
    let e = err(&|a, i| {
        if i == 1 {
            a.reach = vec![reach(vec![0.5, -0.2, -0.2])]
        }
    });
    assert!(e.contains("not both"), "{e}");
    let e = err(&|a, i| {
        if i == 1 {
            a.letter = None;
            a.reach = vec![reach(vec![0.5, f64::NAN, -0.2])];
        }
    });
    assert!(e.contains("finite"), "{e}");
    let e = err(&|a, _| a.letter = None);
    assert!(e.contains("no arm") || e.contains("needs"), "{e}");
}
