//! Letter-task demonstrations and their augmentation by the lifted composed group
//! (Sec. VI-A, eq. 23): counts, tracking accuracy, and the defining property that an
//! augmented joint-space trajectory draws the transformed letter, `f(q') = ρ_X R(θ) λ x`.

use crossym::config::Config;
use crossym::data::augmentation::letter_augmenter;
use crossym::policy::JointTrajectory;
use crossym::policy::{GroupGrid, SubGroup};
use crossym::symmetry::check::build;
use crossym::symmetry::finite::SignedPermutation;
use crossym::symmetry::lie::{AffineAction, LieGroupSpec};
use crossym::symmetry::parts::composition_parts;
use nalgebra::DVector;

use crate::common;

fn letters_config() -> Config {
    common::load_config("letters.toml")
}

/// Demonstration 1 of the letter task reduced to the samples `keep(len)` picks (keeps tests
/// fast).
fn demo_1_at(
    cfg: &Config,
    kin: &crossym::kinematics::Kinematics,
    keep: impl FnOnce(usize) -> Vec<usize>,
) -> JointTrajectory {
    let mut d = cfg.load_demonstrations(kin).unwrap().demos.remove(0);
    let keep = keep(d.len());
    let pick = |v: &[f64], w: usize| -> Vec<f64> {
        keep.iter()
            .flat_map(|&i| v[i * w..(i + 1) * w].to_vec())
            .collect()
    };
    d.q = pick(&d.q, d.n);
    d.qdot = pick(&d.qdot, d.n);
    d.x = pick(&d.x, d.m);
    d
}

#[test]
fn letters_are_tracked_into_joint_space() {
    let cfg = letters_config();
    let robot = cfg.load_robot().unwrap();
    let demos = cfg.load_demonstrations(&robot.kinematics).unwrap();
    assert_eq!(demos.demos.len(), 7);
    // 1000 LASA samples − 10 − 2 (task) − 10 − 1 (joint).
    assert!(demos
        .demos
        .iter()
        .all(|d| d.len() == 977 && d.n == 8 && d.m == 4));
    assert!(
        demos.max_tracking_error < 1e-3,
        "tracking error {}",
        demos.max_tracking_error
    );
    assert_eq!(demos.select(&[1, 2, 3, 4, 5]).len(), 5);
    // q̇ is the forward difference over dt, and x is f(q).
    let d = &demos.demos[0];
    let mut ws = robot.kinematics.workspace();
    for i in [0, 100, 975] {
        for j in 0..8 {
            let fd = (d.q(i + 1)[j] - d.q(i)[j]) / d.dt;
            assert!((fd - d.qdot(i)[j]).abs() < 1e-9);
        }
        let x = robot.kinematics.forward(d.q(i), &mut ws);
        assert!(x.iter().zip(d.x(i)).all(|(a, b)| (a - b).abs() < 1e-12));
    }
    // Both letters sit inside the [-1.5, 1.5] box around f(q0) − o, i.e. x ∈ [3.2, 8.2] for the left arm.
    for d in &demos.demos {
        for i in 0..d.len() {
            let x = d.x(i);
            assert!(
                x[0] > 2.0 && x[0] < 9.5 && x[2] > 2.0 && x[2] < 9.5,
                "{x:?}"
            );
        }
    }
}

#[test]
fn paper_grids_give_780_train_and_600_test_conditions() {
    let aug = letters_config().augmentation.unwrap();
    assert_eq!(aug.train.conditions().len() * 5, 780);
    assert_eq!(aug.test.conditions().len() * 2, 600);
    assert_eq!(aug.train.angles().len(), 13); // −180°, −150°, …, 180°
    assert_eq!(aug.test.angles().len(), 25);
    let conds = aug.train.conditions();
    assert_eq!(conds.iter().filter(|c| SubGroup::R.contains(c)).count(), 13);
    assert_eq!(
        conds.iter().filter(|c| SubGroup::RT.contains(c)).count(),
        78
    );
    assert_eq!(
        conds
            .iter()
            .filter(|c| SubGroup::Identity.contains(c))
            .count(),
        1
    );
    assert_eq!(aug.train.restrict(SubGroup::RT).conditions().len(), 78);
    assert!(GroupGrid {
        rotation_step_deg: Some(0.0),
        scales: vec![1.0],
        reflection: false,
        ..GroupGrid::identity()
    }
    .validate()
    .is_err());
    assert!(GroupGrid {
        rotation_step_deg: None,
        scales: vec![-1.0],
        reflection: false,
        ..GroupGrid::identity()
    }
    .validate()
    .is_err());
}

#[test]
fn augmented_trajectories_draw_the_transformed_letters() {
    let cfg = letters_config();
    let robot = cfg.load_robot().unwrap();
    let kin = &robot.kinematics;
    // Keep the test fast: every 40th sample of demo 1.
    let demo = demo_1_at(&cfg, kin, |len| (0..len).step_by(40).collect());
    let (built, _) = build(kin, &cfg.symmetries).unwrap();
    let rho = composition_parts(&built, &cfg.composition.order)
        .unwrap()
        .reflection;
    assert_eq!(rho, SignedPermutation::block_swap(&[-1.0; 4]));
    // The shipped augmenter (its flow tolerances are what the data are made with).
    let aug = letter_augmenter(kin, &built, &cfg.composition.order).unwrap();
    let grid = GroupGrid {
        rotation_step_deg: Some(120.0),
        scales: vec![0.7, 1.0],
        reflection: true,
        ..GroupGrid::identity()
    };
    let set = aug.augment(&[&demo], &grid, &|| {});
    assert_eq!(set.trajectories.len() + set.dropped.len(), 3 * 2 * 2);
    assert!(set.dropped.is_empty(), "{:?}", set.dropped);
    // Task-space reference actions.
    let r = AffineAction::new("R", LieGroupSpec::So2 { axis: None }, 2, 2, None).unwrap();
    let s = AffineAction::new("S", LieGroupSpec::Scaling, 2, 2, None).unwrap();
    let rho_x = SignedPermutation::block_swap(&[1.0, -1.0]);
    let mut ws = kin.workspace();
    let (mut a, mut b, mut want) = (vec![0.0; 4], vec![0.0; 4], vec![0.0; 4]);
    let mut worst_x: f64 = 0.0;
    let mut worst_v: f64 = 0.0;
    for t in &set.trajectories {
        let c = t.condition;
        for i in 0..demo.len() {
            // f(q') = ρ_X^σ R(θ) λ x.
            s.act(&[c.scale.ln()], demo.x(i), &mut a);
            r.act(&[c.theta], &a, &mut b);
            if c.reflection == -1 {
                rho_x.apply(&b, &mut want)
            } else {
                want.copy_from_slice(&b)
            }
            let x = kin.forward(t.traj.q(i), &mut ws);
            worst_x = worst_x.max(
                x.iter()
                    .zip(&want)
                    .map(|(p, q)| (p - q).abs())
                    .fold(0.0, f64::max),
            );
            // J(q') q̇' = ρ_X^σ R(θ) λ J(q) q̇: velocities transform by the differential.
            kin.jacobian(demo.q(i), &mut ws);
            let xdot = &ws.jac * DVector::from_column_slice(demo.qdot(i));
            s.differential(&[c.scale.ln()], xdot.as_slice(), &mut a);
            r.differential(&[c.theta], &a, &mut b);
            if c.reflection == -1 {
                rho_x.apply(&b, &mut want)
            } else {
                want.copy_from_slice(&b)
            }
            kin.jacobian(t.traj.q(i), &mut ws);
            let got = &ws.jac * DVector::from_column_slice(t.traj.qdot(i));
            let scale = xdot.norm().max(1.0);
            worst_v = worst_v.max(
                got.iter()
                    .zip(&want)
                    .map(|(p, q)| (p - q).abs())
                    .fold(0.0, f64::max)
                    / scale,
            );
        }
    }
    eprintln!("equivariance of the shipped augmenter: x {worst_x:e}, velocity {worst_v:e}");
    // Reach is 12: 1e-6 of the workspace; velocities to 1e-5 relative.
    assert!(worst_x < 12e-6, "task-space equivariance {worst_x:e}");
    assert!(worst_v < 1e-5, "velocity equivariance {worst_v:e}");
}

#[test]
fn broken_letter_configs_are_refused_with_reasons() {
    use crossym::data::demonstrations::Pick;
    let cfg = letters_config();
    let robot = cfg.load_robot().unwrap();
    let kin = &robot.kinematics;
    let e = common::demos_with(&cfg, kin, |d| {
        d.sources[0].arms[0].letter = Some("../data/lasa/missing.mat".into())
    })
    .unwrap_err();
    assert!(e.to_string().contains("missing.mat"), "{e}");
    let e =
        common::demos_with(&cfg, kin, |d| d.sources[0].arms[1].chain = "left".into()).unwrap_err();
    assert!(e.to_string().contains("chain"), "{e}");
    let e = common::demos_with(&cfg, kin, |d| d.test = vec![Pick::Number(9)]).unwrap_err();
    assert!(e.to_string().contains('9'), "{e}");
    let e =
        common::demos_with(&cfg, kin, |d| d.test = vec![Pick::Name("lasa#8".into())]).unwrap_err();
    assert!(e.to_string().contains("lasa#8"), "{e}");
    assert!(common::demos_with(&cfg, kin, |d| d.sources[0].arms[0].rest = vec![0.0; 3]).is_err());
}

/// An orbit that stops partway (here: the flow runs out of its step budget before ±180°)
/// keeps the angles it reached, exactly as a full orbit gives them, and drops every angle
/// further out, for both reflections, with the reason.
#[test]
fn an_orbit_that_fails_partway_keeps_what_it_reached() {
    use crossym::data::augmentation::{Augmenter, DropReason};
    use crossym::symmetry::transfer::flow::FlowSettings;
    use crossym::symmetry::transfer::lift::LiftedAction;
    let cfg = letters_config();
    let robot = cfg.load_robot().unwrap();
    let kin = &robot.kinematics;
    // Three samples keep it fast.
    let demo = demo_1_at(&cfg, kin, |_| vec![0, 400, 800]);
    let (built, _) = build(kin, &cfg.symmetries).unwrap();
    let parts = composition_parts(&built, &cfg.composition.order).unwrap();
    let (rho, rot) = (parts.reflection, parts.rotation);
    let grid = GroupGrid {
        rotation_step_deg: Some(30.0),
        scales: vec![1.0],
        reflection: true,
        max_rotation_deg: None,
        conditions: None,
    };
    let full = letter_augmenter(kin, &built, &cfg.composition.order)
        .unwrap()
        .augment_one(&demo, &grid);
    assert_eq!((full.trajectories.len(), full.dropped.len()), (26, 0));
    // The smallest step budget at which some angles are reached and some are not.
    let partial = (1..200)
        .map(|max_steps| {
            let settings = FlowSettings {
                rtol: 1e-7,
                atol: 1e-9,
                max_steps,
                ..Default::default()
            };
            let lifted = LiftedAction::new(kin, rot, settings).unwrap();
            Augmenter::new(kin, lifted, None, rho.clone())
                .unwrap()
                .augment_one(&demo, &grid)
        })
        .find(|s| s.trajectories.len() > 2 && !s.dropped.is_empty())
        .expect("a step budget that stops the orbit partway");
    assert_eq!(partial.trajectories.len() + partial.dropped.len(), 26);
    assert!(partial
        .dropped
        .iter()
        .all(|d| d.2 == DropReason::Integration && d.0 == demo.demo));
    let kept = |theta: f64, sigma: i8| {
        partial
            .trajectories
            .iter()
            .find(|a| a.condition.theta == theta && a.condition.reflection == sigma)
    };
    for a in &partial.trajectories {
        let c = a.condition;
        // Both reflections share the flow, and every angle nearer to 0 was reached too.
        assert!(kept(c.theta, -c.reflection).is_some(), "{c:?}");
        for b in &full.trajectories {
            let t = b.condition.theta;
            if t * c.theta >= 0.0 && t.abs() < c.theta.abs() {
                assert!(kept(t, c.reflection).is_some(), "{c:?} kept, {t} not");
            }
        }
        // What was reached is what the full orbit gives.
        let f = full.trajectories.iter().find(|b| b.condition == c).unwrap();
        let err = a
            .traj
            .q
            .iter()
            .zip(&f.traj.q)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max);
        assert!(err < 1e-5, "{c:?}: {err}");
    }
}
