//! Lift (eqs. 13–18) and composition (eqs. 19–23): the paper's Examples 2–4 and
//! group-law properties of the lifted actions.

use std::f64::consts::{FRAC_PI_6, PI, TAU};

use crossym::symmetry::compose::{self, ComposeTolerance, Composition, Condition};
use crossym::symmetry::field::{FnField, VectorField, DEFAULT_FD_STEP};
use crossym::symmetry::finite::SignedPermutation;
use crossym::symmetry::lie::{AffineAction, LieGroupSpec};
use crossym::symmetry::transfer::flow::FlowSettings;
use crossym::symmetry::transfer::lift::{
    bracket_condition, periodicity_drift, LiftError, LiftedAction, LiftedField,
};
use rand::Rng;

use crate::common;

/// The paper's rest posture of the letter task: left q0, right −q0.
fn rest() -> Vec<f64> {
    let q0 = [PI / 4.0, -PI / 6.0, -PI / 8.0, -PI / 10.0];
    q0.iter().copied().chain(q0.iter().map(|v| -v)).collect()
}

/// Random configurations near the rest posture (the letter-task region).
fn near_rest(n: usize, seed: u64) -> Vec<Vec<f64>> {
    let mut rng = common::rng(seed);
    (0..n)
        .map(|_| {
            rest()
                .iter()
                .map(|v| v + rng.random_range(-0.3..0.3))
                .collect()
        })
        .collect()
}

fn planar_rotation() -> AffineAction {
    AffineAction::new("R", LieGroupSpec::So2 { axis: None }, 2, 2, None).unwrap()
}

fn planar_scaling() -> AffineAction {
    AffineAction::new("S", LieGroupSpec::Scaling, 2, 2, None).unwrap()
}

#[test]
fn example2_lifted_so2_is_f_related_and_equivariant() {
    let robot = common::planar();
    let k = &robot.kinematics;
    let r = planar_rotation();
    let lifted_field = LiftedField::new(k, r.basis_generator(0));
    let mut ws = k.workspace();
    let mut xq = vec![0.0; 8];
    let mut xx = vec![0.0; 4];
    for q in near_rest(50, 10) {
        // eq. 15: J X_Q(q) = X_X(f(q)) = Ω f(q).
        assert!(lifted_field.eval(&q, &mut xq));
        k.jacobian(&q, &mut ws);
        let x = ws.x.clone();
        r.basis_generator(0).eval(x.as_slice(), &mut xx);
        assert!(
            (x[0] * xx[1] - x[1] * xx[0] - (x[0] * x[0] + x[1] * x[1])).abs() < 1e-9,
            "Ω x is the rotation field"
        );
        let jxq = &ws.jac * nalgebra::DVector::from_column_slice(&xq);
        for i in 0..4 {
            assert!((jxq[i] - xx[i]).abs() < 1e-9, "f-relatedness");
        }
    }
    // eq. 19: f(Φ_Q(g, q)) = Φ_X(g, f(q)) for θ = 30° and for a range of angles, ≤ 1e-6 relative.
    let lifted = LiftedAction::new(k, &r, FlowSettings::default()).unwrap();
    let mut lws = lifted.workspace();
    let reach = 12.0;
    for (i, q) in near_rest(20, 11).iter().enumerate() {
        for theta in [FRAC_PI_6, -FRAC_PI_6, 1.0, -2.0 + 0.1 * i as f64] {
            let e = lifted.equivariance_residual(&[theta], q, &mut lws).unwrap();
            assert!(
                e / reach <= 1e-6,
                "equivariance residual {e:e} at θ={theta}"
            );
        }
    }
}

#[test]
fn lifted_action_group_laws() {
    let robot = common::planar();
    let k = &robot.kinematics;
    let r = planar_rotation();
    let lifted = LiftedAction::new(k, &r, FlowSettings::default()).unwrap();
    let mut ws = lifted.workspace();
    let (mut a, mut b, mut c) = (vec![0.0; 8], vec![0.0; 8], vec![0.0; 8]);
    let mut rng = common::rng(12);
    for q in near_rest(20, 13) {
        let t1: f64 = rng.random_range(-1.0..1.0);
        let t2: f64 = rng.random_range(-1.0..1.0);
        // Identity.
        lifted.act(&[0.0], &q, &mut a, &mut ws).unwrap();
        assert_eq!(a, q);
        // Inverse: Φ(−θ, Φ(θ, q)) = q (a flow, so exact up to integration error).
        lifted.act(&[t1], &q, &mut a, &mut ws).unwrap();
        lifted.act(&[-t1], &a, &mut b, &mut ws).unwrap();
        assert!(
            q.iter().zip(&b).all(|(x, y)| (x - y).abs() < 1e-8),
            "inverse law"
        );
        // Composition of a one-parameter group: Φ(θ2, Φ(θ1, q)) = Φ(θ1 + θ2, q).
        lifted.act(&[t2], &a, &mut b, &mut ws).unwrap();
        lifted.act(&[t1 + t2], &q, &mut c, &mut ws).unwrap();
        assert!(
            b.iter().zip(&c).all(|(x, y)| (x - y).abs() < 1e-8),
            "composition law"
        );
    }
}

#[test]
fn lifted_differential_matches_finite_differences_of_the_action() {
    let robot = common::planar();
    let k = &robot.kinematics;
    let s = planar_scaling();
    let r = planar_rotation();
    for action in [&r, &s] {
        let lifted = LiftedAction::new(k, action, FlowSettings::default()).unwrap();
        let mut ws = lifted.workspace();
        let mut rng = common::rng(14);
        for q in near_rest(5, 15) {
            let qdot: Vec<f64> = (0..8).map(|_| rng.random_range(-1.0..1.0)).collect();
            let xi = [if action.name == "S" { 0.8f64.ln() } else { 0.7 }];
            let (mut q1, mut v1) = (vec![0.0; 8], vec![0.0; 8]);
            lifted
                .act_with_differential(&xi, &q, &qdot, &mut q1, &mut v1, &mut ws)
                .unwrap();
            let (mut qp, mut qm) = (vec![0.0; 8], vec![0.0; 8]);
            let h = 1e-5;
            let q_plus: Vec<f64> = q.iter().zip(&qdot).map(|(a, b)| a + h * b).collect();
            let q_minus: Vec<f64> = q.iter().zip(&qdot).map(|(a, b)| a - h * b).collect();
            let tight = FlowSettings {
                rtol: 1e-13,
                atol: 1e-14,
                ..Default::default()
            };
            let precise = LiftedAction::new(k, action, tight).unwrap();
            let mut pws = precise.workspace();
            precise.act(&xi, &q_plus, &mut qp, &mut pws).unwrap();
            precise.act(&xi, &q_minus, &mut qm, &mut pws).unwrap();
            for i in 0..8 {
                let fd = (qp[i] - qm[i]) / (2.0 * h);
                assert!(
                    (fd - v1[i]).abs() < 1e-5 * (1.0 + fd.abs()),
                    "{}: dΦ q̇ [{i}] {} vs FD {fd}",
                    action.name,
                    v1[i]
                );
            }
            // The transformed velocity realises the transformed task velocity: J(q') q̇' = dΦ_X J(q) q̇.
            let mut kws = k.workspace();
            k.jacobian(&q, &mut kws);
            let xdot = &kws.jac * nalgebra::DVector::from_column_slice(&qdot);
            let mut want = vec![0.0; 4];
            action.differential(&xi, xdot.as_slice(), &mut want);
            k.jacobian(&q1, &mut kws);
            let got = &kws.jac * nalgebra::DVector::from_column_slice(&v1);
            for i in 0..4 {
                assert!(
                    (got[i] - want[i]).abs() < 1e-6,
                    "{}: task velocity {i}",
                    action.name
                );
            }
        }
    }
}

#[test]
fn periodicity_and_bracket_condition_are_reported() {
    let robot = common::planar();
    let k = &robot.kinematics;
    let r = planar_rotation();
    let s = planar_scaling();
    let lifted = LiftedAction::new(k, &r, FlowSettings::default()).unwrap();
    let mut ws = lifted.workspace();
    // A full turn of the letters returns the hands to where they were (task-space
    // periodicity), but with M = I the horizontal lift of SO(2) on a 4-link arm is not the
    // rigid rotation q1 += θ (e1 is not M-orthogonal to ker J): the flow carries a self-motion,
    // so the joint-space drift after 2π is large. This is the paper's caveat (Sec. IV-B, end):
    // periodicity survives only if the lifted flow generates no vertical motion. We report it.
    let mut kws = k.workspace();
    for q in near_rest(5, 16) {
        let drift = periodicity_drift(&lifted, &[TAU], &q, &mut ws).unwrap();
        let mut q1 = vec![0.0; 8];
        lifted.act(&[TAU], &q, &mut q1, &mut ws).unwrap();
        let x0 = k.forward(&q, &mut kws).clone();
        let x1 = k.forward(&q1, &mut kws).clone();
        assert!(
            (x1 - x0).amax() < 1e-6 * 12.0,
            "hands return after a full turn"
        );
        assert!(
            drift > 0.1,
            "expected a vertical drift with M = I, got {drift:e}"
        );
    }
    // eq. 16 for SO(2) × S: the task bracket is 0 (Example 3); the lifted bracket is
    // f-related to it, so what remains is vertical, and it is not zero for M = I here.
    let rg = r.basis_generator(0);
    let sg = s.basis_generator(0);
    let rep = bracket_condition(k, &rg, &sg, &near_rest(30, 17), DEFAULT_FD_STEP);
    assert_eq!(rep.samples, 30);
    assert!(
        rep.horizontal_mismatch < 1e-6,
        "J[X_Q^R, X_Q^S] must equal [X_X^R, X_X^S] = 0: {rep:?}"
    );
    assert!(
        (rep.residual - rep.vertical).abs() < 1e-6,
        "with a zero task bracket the residual is the vertical part: {rep:?}"
    );
    assert!(
        rep.vertical_relative > 1e-3,
        "expected a vertical bracket with M = I: {rep:?}"
    );
}

#[test]
fn singularity_along_the_flow_stops_with_an_error() {
    let robot = common::planar();
    let k = &robot.kinematics;
    let s = planar_scaling();
    let lifted = LiftedAction::new(k, &s, FlowSettings::default()).unwrap();
    let mut ws = lifted.workspace();
    let mut out = vec![0.0; 8];
    // Scaling the letters by e^1 ≈ 2.7 from the rest posture (reach ~10.7 of 12) leaves the
    // workspace: the arms stretch into the boundary singularity.
    let err = lifted.act(&[1.0], &rest(), &mut out, &mut ws).unwrap_err();
    assert!(matches!(err, LiftError::Singular { .. }), "{err}");
    assert!(err.to_string().contains("singularity"), "{err}");
    // Starting at the stretched singular posture is refused up front.
    let err = lifted
        .act(&[0.1], &[0.0; 8], &mut out, &mut ws)
        .unwrap_err();
    assert!(matches!(err, LiftError::BadStart { .. }), "{err}");
}

#[test]
fn example3_rotation_and_scaling_compose_directly() {
    // In X (Example 3) and in Q (lifted), SO(2) and S(2) commute: direct product.
    let r = planar_rotation();
    let s = planar_scaling();
    let mut rng = common::rng(18);
    let xs: Vec<Vec<f64>> = (0..20)
        .map(|_| (0..4).map(|_| rng.random_range(-5.0..5.0)).collect())
        .collect();
    let (rg, sg) = (r.basis_generator(0), s.basis_generator(0));
    let c = compose::classify_lie_lie(
        &[&rg],
        &[&sg],
        &xs,
        DEFAULT_FD_STEP,
        ComposeTolerance::default(),
    );
    assert!(matches!(c, Composition::Direct { .. }), "{c:?}");
    // Group level in X: R(θ) λ x = λ R(θ) x.
    let rot = |p: &[f64], o: &mut [f64]| {
        r.act(&[0.7], p, o);
        true
    };
    let sc = |p: &[f64], o: &mut [f64]| {
        s.act(&[0.3], p, o);
        true
    };
    assert!(compose::commutation_residual(&rot, &sc, &xs) < 1e-12);
    // Lifted to Q: the lifted fields' bracket is vertical and non-zero (see above), so the
    // lifted actions commute only up to a self-motion; the classifier says so, and the
    // composed actions still agree in task space in either order (f-equivariance).
    let robot = common::planar();
    let k = &robot.kinematics;
    let (lr, ls) = (
        LiftedField::new(k, r.basis_generator(0)),
        LiftedField::new(k, s.basis_generator(0)),
    );
    let c = compose::classify_lie_lie(
        &[&lr],
        &[&ls],
        &near_rest(20, 19),
        DEFAULT_FD_STEP,
        ComposeTolerance::default(),
    );
    assert!(
        matches!(c, Composition::Incompatible { commutation, .. } if commutation > 1e-3),
        "{c:?}"
    );
    let (ar, as_) = (
        LiftedAction::new(k, &r, FlowSettings::default()).unwrap(),
        LiftedAction::new(k, &s, FlowSettings::default()).unwrap(),
    );
    let mut ws = ar.workspace();
    let mut kws = k.workspace();
    for q in near_rest(5, 22) {
        let (mut a, mut rs, mut b, mut sr) =
            (vec![0.0; 8], vec![0.0; 8], vec![0.0; 8], vec![0.0; 8]);
        ar.act(&[1.0], &q, &mut a, &mut ws).unwrap();
        as_.act(&[0.7f64.ln()], &a, &mut rs, &mut ws).unwrap();
        as_.act(&[0.7f64.ln()], &q, &mut b, &mut ws).unwrap();
        ar.act(&[1.0], &b, &mut sr, &mut ws).unwrap();
        let x1 = k.forward(&rs, &mut kws).clone();
        let x2 = k.forward(&sr, &mut kws).clone();
        assert!((x1 - x2).amax() < 1e-6 * 12.0);
    }
}

#[test]
fn example4_reflection_and_rotation_form_o2() {
    // In X = R²: ρ = diag(1, −1), R(θ) ↦ ρ R(θ) ρ⁻¹ = R(−θ): automorphism C = −1, not commuting.
    let r1 = AffineAction::new("R", LieGroupSpec::So2 { axis: None }, 2, 1, None).unwrap();
    let rho = SignedPermutation::new(vec![0, 1], vec![1.0, -1.0]).unwrap();
    let mut rng = common::rng(20);
    let xs: Vec<Vec<f64>> = (0..20)
        .map(|_| (0..2).map(|_| rng.random_range(-5.0..5.0)).collect())
        .collect();
    let g = r1.basis_generator(0);
    let act = |xi: &[f64], p: &[f64], o: &mut [f64]| {
        r1.act(xi, p, o);
        true
    };
    let c = compose::classify_finite_lie(
        &rho,
        &[&g],
        &act,
        &[vec![0.5], vec![-1.2]],
        &xs,
        ComposeTolerance::default(),
    );
    match &c {
        Composition::SemiDirect {
            automorphism,
            residual,
            commutation,
        } => {
            assert!(
                (automorphism[(0, 0)] + 1.0).abs() < 1e-9,
                "C = {automorphism}"
            );
            assert!(*residual < 1e-9 && *commutation > 0.1);
        }
        other => panic!("expected semi-direct, got {other:?}"),
    }
    // Group level: ρ R(θ) ρ⁻¹ x = R(−θ) x for all x.
    for x in &xs {
        let (mut a, mut b, mut want) = ([0.0; 2], [0.0; 2], [0.0; 2]);
        rho.apply(x, &mut a);
        r1.act(&[0.8], &a, &mut b);
        rho.apply(&b, &mut a);
        r1.act(&[-0.8], x, &mut want);
        assert!((a[0] - want[0]).abs() < 1e-12 && (a[1] - want[1]).abs() < 1e-12);
    }
    // In Q for the planar dual arm: C2 acts by ρ_Q = [[0, −I], [−I, 0]] and the lifted SO(2)
    // flips sign under it: the same semi-direct structure O(2) holds in joint space.
    let robot = common::planar();
    let k = &robot.kinematics;
    let r = planar_rotation();
    let rho_q = SignedPermutation::block_swap(&[-1.0; 4]);
    let lf = LiftedField::new(k, r.basis_generator(0));
    let lifted = LiftedAction::new(k, &r, FlowSettings::default()).unwrap();
    let ws = std::cell::RefCell::new(lifted.workspace());
    let act_q =
        |xi: &[f64], q: &[f64], o: &mut [f64]| lifted.act(xi, q, o, &mut ws.borrow_mut()).is_ok();
    let c = compose::classify_finite_lie(
        &rho_q,
        &[&lf],
        &act_q,
        &[vec![0.5]],
        &near_rest(20, 21),
        ComposeTolerance {
            commute: 1e-6,
            automorphism: 1e-6,
        },
    );
    match &c {
        Composition::SemiDirect { automorphism, .. } => {
            assert!((automorphism[(0, 0)] + 1.0).abs() < 1e-6, "{automorphism}")
        }
        other => panic!("expected semi-direct in Q, got {other:?}"),
    }
}

#[test]
fn composed_condition_acts_in_paper_order_and_validates() {
    // eq. 23 in X for s = (θ, λ, σ): x ↦ ρ(σ) R(θ) λ x.
    let r = planar_rotation();
    let s = planar_scaling();
    let rho_x = SignedPermutation::block_swap(&[1.0, -1.0]);
    let rot = |t: f64, p: &[f64], o: &mut [f64]| {
        r.act(&[t], p, o);
        true
    };
    let sc = |t: f64, p: &[f64], o: &mut [f64]| {
        s.act(&[t], p, o);
        true
    };
    let x = [10.0, 1.0, 10.0, -1.0];
    let mut out = [0.0; 4];
    let cond = Condition {
        theta: PI / 2.0,
        scale: 0.5,
        reflection: -1,
    };
    assert!(compose::apply_condition(
        &cond, &rho_x, &rot, &sc, &x, &mut out
    ));
    // λx = (5, .5, 5, −.5); R(90°) → (−.5, 5, .5, 5); swap with P_X = diag(1, −1) → (.5, −5, −.5, −5).
    let want = [0.5, -5.0, -0.5, -5.0];
    for i in 0..4 {
        assert!((out[i] - want[i]).abs() < 1e-12, "{out:?}");
    }
    assert!(Condition::IDENTITY.validate().is_ok());
    assert!(Condition {
        theta: 0.0,
        scale: 0.0,
        reflection: 1
    }
    .validate()
    .unwrap_err()
    .to_string()
    .contains("scale"));
    assert!(Condition {
        theta: 0.0,
        scale: 1.0,
        reflection: 3
    }
    .validate()
    .unwrap_err()
    .to_string()
    .contains("reflection"));
    assert!(Condition {
        theta: f64::NAN,
        scale: 1.0,
        reflection: 1
    }
    .validate()
    .is_err());
}

#[test]
fn lifted_rotation_on_rby1_is_equivariant() {
    let Some(robot) = common::rby1() else { return };
    let k = &robot.kinematics;
    // SO(2) about the vertical axis of the torso frame, on both hands' positions.
    let r = AffineAction::new(
        "R",
        LieGroupSpec::So2 {
            axis: Some([0.0, 0.0, 1.0]),
        },
        3,
        2,
        None,
    )
    .unwrap();
    let lifted = LiftedAction::new(k, &r, FlowSettings::default()).unwrap();
    let mut ws = lifted.workspace();
    // A comfortable bimanual posture: elbows bent, hands in front of the torso.
    let arm = [0.3, 0.4, 0.0, -1.6, 0.0, 0.6, 0.0];
    let q: Vec<f64> = arm
        .iter()
        .copied()
        .chain(
            arm.iter()
                .enumerate()
                .map(|(i, v)| if [1, 2, 4, 6].contains(&i) { -v } else { *v }),
        )
        .collect();
    let e = lifted
        .equivariance_residual(&[FRAC_PI_6 / 3.0], &q, &mut ws)
        .unwrap();
    assert!(e < 1e-6, "RB-Y1 lifted rotation residual {e:e} m");
}

#[test]
fn lie_pairs_semi_direct_when_one_algebra_is_an_ideal() {
    // SE(2) = T(2) ⋊ SO(2): [rotation, translation] is a translation, so T(2) is an ideal.
    let r = AffineAction::new("R", LieGroupSpec::So2 { axis: None }, 2, 1, None).unwrap();
    let t = AffineAction::new(
        "T",
        LieGroupSpec::Translation { directions: vec![] },
        2,
        1,
        None,
    )
    .unwrap();
    let mut rng = common::rng(40);
    let xs: Vec<Vec<f64>> = (0..10)
        .map(|_| (0..2).map(|_| rng.random_range(-3.0..3.0)).collect())
        .collect();
    let rg = r.basis_generator(0);
    let (t0, t1) = (t.basis_generator(0), t.basis_generator(1));
    let c = compose::classify_lie_lie(
        &[&rg],
        &[&t0, &t1],
        &xs,
        DEFAULT_FD_STEP,
        ComposeTolerance::default(),
    );
    match &c {
        // ad_Ω on span{∂x, ∂y} is the rotation generator itself: [[0, −1], [1, 0]] up to sign convention.
        Composition::SemiDirect {
            automorphism,
            residual,
            ..
        } => {
            assert!(*residual < 1e-8, "{c:?}");
            assert!(
                (automorphism[(0, 1)].abs() - 1.0).abs() < 1e-6
                    && (automorphism[(1, 0)].abs() - 1.0).abs() < 1e-6,
                "{automorphism}"
            );
            assert!(automorphism[(0, 0)].abs() < 1e-6 && automorphism[(1, 1)].abs() < 1e-6);
        }
        other => panic!("expected semi-direct, got {other:?}"),
    }
    // Two rotations about different centers: their bracket is a translation, in neither
    // algebra: incompatible.
    let r2 = AffineAction::new(
        "R2",
        LieGroupSpec::So2 { axis: None },
        2,
        1,
        Some(&[1.0, 0.0]),
    )
    .unwrap();
    let g2 = r2.basis_generator(0);
    let c = compose::classify_lie_lie(
        &[&rg],
        &[&g2],
        &xs,
        DEFAULT_FD_STEP,
        ComposeTolerance::default(),
    );
    assert!(matches!(c, Composition::Incompatible { .. }), "{c:?}");
}

/// The lifted field's closed-form derivative `dX_Q|_q δ` (used by the variational
/// equation) against central differences of `X_Q`, undamped with `M = I` and damped with
/// a diagonal metric.
#[test]
fn lifted_field_derivative_matches_finite_differences() {
    let planar = common::planar();
    let mut cfg = common::load_config("planar_dual_arm.toml");
    cfg.kinematics.damping = 0.05;
    cfg.kinematics.metric_diagonal = Some(vec![1.0, 2.0, 0.5, 1.5, 1.0, 3.0, 0.7, 1.2]);
    let damped = cfg.load_robot().unwrap().kinematics;
    let r = planar_rotation();
    let s = planar_scaling();
    let kins = [&planar.kinematics, &damped];
    let mut rng = common::rng(11);
    for k in kins {
        // A task field without a closed-form derivative: the lift differences it.
        let nonlinear = FnField::new(4, |x: &[f64], o: &mut [f64]| {
            o[0] = -x[1] + 0.1 * x[0] * x[0];
            o[1] = x[0] + 0.5 * x[1].sin();
            o[2] = 0.1 * x[2] * x[3];
            o[3] = -x[2];
        });
        let fields: Vec<Box<dyn VectorField + '_>> = vec![
            Box::new(LiftedField::new(k, r.basis_generator(0))),
            Box::new(LiftedField::new(k, s.basis_generator(0))),
            Box::new(LiftedField::new(k, &nonlinear)),
        ];
        for field in &fields {
            for q in near_rest(20, 12) {
                let delta: Vec<f64> = (0..8).map(|_| rng.random_range(-1.0..1.0)).collect();
                let (mut x, mut dx) = (vec![0.0; 8], vec![0.0; 8]);
                assert_eq!(
                    field.eval_derivative(&q, &delta, &mut x, &mut dx),
                    Some(true)
                );
                let mut plain = vec![0.0; 8];
                assert!(field.eval(&q, &mut plain));
                assert_eq!(x, plain, "same X_Q as eval");
                let h = 1e-6;
                let (mut xp, mut xm) = (vec![0.0; 8], vec![0.0; 8]);
                let qp: Vec<f64> = q.iter().zip(&delta).map(|(a, d)| a + h * d).collect();
                let qm: Vec<f64> = q.iter().zip(&delta).map(|(a, d)| a - h * d).collect();
                assert!(field.eval(&qp, &mut xp) && field.eval(&qm, &mut xm));
                for i in 0..8 {
                    let fd = (xp[i] - xm[i]) / (2.0 * h);
                    assert!(
                        (dx[i] - fd).abs() < 1e-6 * fd.abs().max(1.0),
                        "{i}: {} vs {fd}",
                        dx[i]
                    );
                }
            }
        }
    }
}
