//! Redundancy resolution: the null-space term `(I − J⁺J) v₀(q)` added to a task
//! head's lift leaves the task velocity, and so the head's exact task-space equivariance,
//! untouched; it is equivariant itself under a reflection that maps rest and limits onto
//! themselves; switched off it is the plain lift bit for bit.

use nalgebra::{DMatrix, DVector};

use crossym::config::{Config, RedundancyConfig};
use crossym::kinematics::{
    lift_with_secondary, Kinematics, NullSpaceSettings, NullSpaceTerm, SecondaryWorkspace,
};
use crossym::policy::{AnyPolicy, TaskHeadPolicy};
use crossym::symmetry::built::BuiltSymmetry;
use crossym::symmetry::compose::Condition;
use crossym::symmetry::transfer::composed::{ComposedLift, LiftIntegrator};
use crossym::symmetry::transfer::flow::FlowSettings;

use super::common;
use super::equivariant::{step, task_action};

/// Off any training grid: θ not a multiple of 10°, λ between the grid's scales, both σ.
const CONDITIONS: [Condition; 3] = [
    Condition {
        theta: 0.296_705_972_839_036, // 17°
        scale: 0.73,
        reflection: -1,
    },
    Condition {
        theta: -0.610_865_238_198_015, // −35°
        scale: 0.9,
        reflection: 1,
    },
    Condition {
        theta: 0.767_944_870_877_505, // 44°
        scale: 1.0,
        reflection: -1,
    },
];

/// `J⁺` by an SVD of `J` (independent of crossym's Cholesky-based pseudo-inverse).
fn svd_pinv(j: &DMatrix<f64>) -> DMatrix<f64> {
    j.clone().svd(true, true).pseudo_inverse(1e-12).unwrap()
}

fn with_redundancy(mut cfg: Config, weight: f64) -> Config {
    cfg.redundancy = Some(RedundancyConfig {
        weight,
        ..RedundancyConfig::default()
    });
    cfg
}

/// The config's task head with `[redundancy] weight` (0: none).
fn head(cfg: &Config, kin: &Kinematics, file: &str, weight: f64) -> TaskHeadPolicy {
    let cfg = with_redundancy(cfg.clone(), weight);
    match crossym::pipeline::load_any_policy(&cfg, kin, &common::path(file)).unwrap() {
        AnyPolicy::TaskHead(h) => *h,
        _ => panic!("{file} is not a task head"),
    }
}

/// On RB-Y1's two 7-DoF arms (a 8-D null space) at random postures: the lift with the
/// secondary term equals `J⁺v + (I − J⁺J)v₀` computed with an SVD pseudo-inverse, and
/// `J q̇ = v` to round-off, i.e. `J (I − J⁺J) v₀ = 0`.
#[test]
fn the_secondary_term_is_projected_into_the_null_space_on_rby1() {
    let Some(robot) = common::rby1() else { return };
    let cfg = common::load_config("rby1-letters.toml");
    let kin = &robot.kinematics;
    let (n, m) = (kin.dof(), kin.task_dim());
    assert_eq!((n, m), (14, 6));
    let term = with_redundancy(cfg, 2.0)
        .null_space_term(kin)
        .unwrap()
        .expect("weight 2: on");
    let mut rng = common::rng(37);
    let (mut kws, mut sws) = (kin.workspace(), SecondaryWorkspace::new(m));
    let mut checked = 0;
    for _ in 0..40 {
        let q = common::random_q(&mut rng, kin.limits());
        kin.jacobian(&q, &mut kws);
        let report = kin.factor(&mut kws);
        if report.status != crossym::kinematics::PinvStatus::Regular {
            continue;
        }
        let v: Vec<f64> = (0..m).map(|i| 0.1 * ((i as f64) - 2.5)).collect();
        let mut v0 = vec![0.0; n];
        term.secondary(&q, &mut v0);
        let mut out = vec![0.0; n];
        lift_with_secondary(kin, &mut kws, &v, &v0, &mut out, &mut sws);
        let j = kws.jac.clone();
        let jp = svd_pinv(&j);
        let (vv, vv0) = (
            DVector::from_column_slice(&v),
            DVector::from_column_slice(&v0),
        );
        let want = &jp * &vv + (DMatrix::identity(n, n) - &jp * &j) * &vv0;
        let scale = vv0.norm().max(1e-3) * jp.norm().max(1.0);
        let err = (DVector::from_column_slice(&out) - &want).amax();
        assert!(err <= 1e-8 * scale, "q {q:?}: {err} from the SVD lift");
        let jq = &j * DVector::from_column_slice(&out);
        let task_err = (jq - &vv).amax();
        assert!(
            task_err <= 1e-10 * (1.0 + j.norm() * vv0.norm()),
            "q {q:?}: J q̇ − v = {task_err}"
        );
        assert!(vv0.norm() > 1e-3, "the term does something at {q:?}");
        checked += 1;
    }
    assert!(checked >= 30, "only {checked} regular postures of 40");
}

/// RB-Y1's morphological reflection (derived from the URDF) maps the letters' rest posture
/// and the arms' limits onto themselves, so `v₀(ρq) = ρ v₀(q)` at random postures; a rest
/// posture that is not mirrored is reported as not respecting it.
#[test]
fn the_rby1_term_is_equivariant_under_the_arm_swap() {
    let Some(robot) = common::rby1() else { return };
    let cfg = common::load_config("rby1-letters.toml");
    let kin = &robot.kinematics;
    let (built, _) = crossym::symmetry::check::build(kin, &cfg.symmetries).unwrap();
    let Some(BuiltSymmetry::Finite { rho_q, .. }) = built.iter().find(|b| b.name() == "M") else {
        panic!("M is finite")
    };
    let term = with_redundancy(cfg.clone(), 1.5)
        .null_space_term(kin)
        .unwrap()
        .unwrap();
    assert!(term.respects(&rho_q.perm, &rho_q.signs, 1e-9));
    let mut rng = common::rng(5);
    let n = kin.dof();
    for _ in 0..50 {
        let q = common::random_q(&mut rng, kin.limits());
        let mut rq = vec![0.0; n];
        rho_q.apply(&q, &mut rq);
        let (mut a, mut b, mut rb) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        term.secondary(&rq, &mut a);
        term.secondary(&q, &mut b);
        rho_q.apply(&b, &mut rb);
        assert!(common::dist(&a, &rb) <= 1e-12, "{q:?}: {a:?} vs {rb:?}");
    }
    let mut lopsided = with_redundancy(cfg, 1.5);
    let mut rest = lopsided.start_q().unwrap();
    rest[0] += 0.1;
    lopsided.redundancy.as_mut().unwrap().rest = Some(rest);
    let t = lopsided.null_space_term(kin).unwrap().unwrap();
    assert!(!t.respects(&rho_q.perm, &rho_q.signs, 1e-9));
}

/// A closed loop's right-hand side `q̇ = π(q, s)`.
type Velocity<'a> = dyn FnMut(&[f64], &Condition, &mut [f64]) + 'a;

/// Largest task-space distance over a 2 s RK4 rollout between the closed loop under `s`,
/// started where `g · f(q_start)` is drawn, and `g ·` the identity closed loop from
/// `q_start`; and how far the identity loop's task point travelled.
fn task_gap(
    kin: &Kinematics,
    built: &[BuiltSymmetry],
    lift: &ComposedLift,
    q_start: &[f64],
    s: &Condition,
    velocity: &mut Velocity<'_>,
) -> (f64, f64) {
    let n = q_start.len();
    let mut lws = lift.workspace();
    let mut kws = kin.workspace();
    let (mut q_s, mut scratch) = (vec![0.0; n], vec![0.0; n]);
    lift.act_with_differential(s, q_start, &vec![0.0; n], &mut q_s, &mut scratch, &mut lws)
        .unwrap();
    let mut q_e = q_start.to_vec();
    let x0 = kin.forward(&q_e, &mut kws).as_slice().to_vec();
    let (mut gap, mut travelled): (f64, f64) = (0.0, 0.0);
    for k in 0..=200 {
        let x_e = kin.forward(&q_e, &mut kws).as_slice().to_vec();
        let x_s = kin.forward(&q_s, &mut kws).as_slice().to_vec();
        gap = gap.max(common::dist(&x_s, &task_action(built, s, &x_e)));
        travelled = travelled.max(common::dist(&x_e, &x0));
        if k == 200 {
            break;
        }
        step(&mut q_e, 0.01, true, &mut |q, v| {
            velocity(q, &Condition::IDENTITY, v)
        });
        step(&mut q_s, 0.01, true, &mut |q, v| velocity(q, s, v));
    }
    (gap, travelled)
}

fn exact_lift(kin: &Kinematics, built: &[BuiltSymmetry], order: &[String]) -> ComposedLift {
    ComposedLift::from_symmetries(
        kin,
        built,
        order,
        LiftIntegrator::Adaptive {
            settings: FlowSettings {
                rtol: 1e-11,
                atol: 1e-13,
                ..FlowSettings::default()
            },
        },
    )
    .unwrap()
}

/// The planar head with a strong null-space term (weight 2/s): the closed loop under an
/// off-grid condition still draws `g ·` the identity drawing in task space (≤ 1e-6 × reach)
/// while the joints move differently from the plain lift's; the same term added without
/// the projection (`J⁺v + v₀`) breaks it — the test sees the difference.
#[test]
fn the_null_space_term_keeps_the_planar_head_exactly_equivariant_in_task_space() {
    let (cfg, robot, demos) = common::task("letters.toml");
    let kin = &robot.kinematics;
    let (built, _) = crossym::symmetry::check::build(kin, &cfg.symmetries).unwrap();
    let lift = exact_lift(kin, &built, &cfg.composition.order);
    let file = "data/policies/pi_mrt_head_planar.safetensors";
    let (plain, with) = (head(&cfg, kin, file, 0.0), head(&cfg, kin, file, 2.0));
    assert!(plain.null_space().is_none() && with.null_space().is_some());
    let q_start = demos.demos[0].q(0).to_vec();
    let reach = demos.demos[0]
        .x
        .chunks(2)
        .map(|p| p[0].hypot(p[1]))
        .fold(0.0, f64::max);
    let (mut pws, mut wws) = (plain.workspace(), with.workspace());
    let term = with.null_space().unwrap().clone();
    for s in &CONDITIONS {
        let (gap, travelled) = task_gap(kin, &built, &lift, &q_start, s, &mut |q, s, v| {
            with.velocity(q, s, v, &mut wws).expect("regular")
        });
        println!("{s:?}: task-space gap {gap:.3e} with the null-space term, motion {travelled:.3}");
        assert!(travelled > 0.1 * reach, "{s:?}: the head barely moved");
        assert!(gap <= 1e-6 * reach, "{s:?}: gap {gap}");
        // Not projected: the secondary velocity leaks into the task.
        let mut v0 = vec![0.0; kin.dof()];
        let (broken, _) = task_gap(kin, &built, &lift, &q_start, s, &mut |q, s, v| {
            plain.velocity(q, s, v, &mut pws).expect("regular");
            term.secondary(q, &mut v0);
            v.iter_mut().zip(&v0).for_each(|(v, w)| *v += w);
        });
        println!("{s:?}: task-space gap {broken:.3e} with the term not projected");
        assert!(
            broken > 1e-3 * reach,
            "{s:?}: the broken term went unseen ({broken})"
        );
    }
    // The joints do follow another path than the plain lift's.
    let (mut a, mut b) = (q_start.clone(), q_start.clone());
    for _ in 0..200 {
        step(&mut a, 0.01, true, &mut |q, v| {
            plain.velocity(q, &CONDITIONS[0], v, &mut pws).unwrap()
        });
        step(&mut b, 0.01, true, &mut |q, v| {
            with.velocity(q, &CONDITIONS[0], v, &mut wws).unwrap()
        });
    }
    assert!(
        common::dist(&a, &b) > 1e-3,
        "the term changed nothing: {a:?} vs {b:?}"
    );
}

/// `weight = 0` is today's lift bit for bit; a config without `[redundancy]` too.
#[test]
fn weight_zero_is_the_plain_lift_bit_for_bit() {
    let (cfg, robot, demos) = common::task("letters.toml");
    let kin = &robot.kinematics;
    let file = "data/policies/pi_mrt_head_planar.safetensors";
    let none = match crossym::pipeline::load_any_policy(&cfg, kin, &common::path(file)).unwrap() {
        AnyPolicy::TaskHead(h) => *h,
        _ => unreachable!(),
    };
    let zero = head(&cfg, kin, file, 0.0);
    assert!(none.null_space().is_none() && zero.null_space().is_none());
    let (mut a, mut b) = (none.workspace(), zero.workspace());
    let (mut va, mut vb) = (vec![0.0; 8], vec![0.0; 8]);
    for k in 0..demos.demos[0].len() {
        let q = demos.demos[0].q(k);
        none.velocity(q, &CONDITIONS[0], &mut va, &mut a).unwrap();
        zero.velocity(q, &CONDITIONS[0], &mut vb, &mut b).unwrap();
        assert_eq!(va, vb);
    }
    let term = NullSpaceTerm::new(
        NullSpaceSettings {
            weight: 1.0,
            ..NullSpaceSettings::default()
        },
        &[0.0; 8],
        kin.limits(),
    );
    assert!(term.is_ok());
}

/// RB-Y1's shipped heads as every command loads them (their configs' `[redundancy]` term in
/// the lift), under off-grid conditions: the closed loop under `s` draws `g ·` the identity
/// closed loop in task space (≤ 1e-6 × reach) — letters (`G_MRT`) and pan (`SO(2) ⋊ C2`,
/// λ = 1); the term not projected breaks it.
#[test]
fn rby1_heads_with_the_null_space_term_are_exactly_equivariant_in_task_space() {
    if common::rby1_urdf().is_none() {
        return;
    }
    for (config, file, conditions) in [
        (
            "rby1-letters.toml",
            "data/policies/pi_mrt_head_rby1_letters.safetensors",
            CONDITIONS.to_vec(),
        ),
        (
            "rby1-pan.toml",
            "data/policies/pi_mr_head_rby1_pan.safetensors",
            CONDITIONS
                .iter()
                .map(|c| Condition { scale: 1.0, ..*c })
                .collect(),
        ),
    ] {
        let (cfg, robot, demos) = common::task(config);
        let kin = &robot.kinematics;
        let (built, _) = crossym::symmetry::check::build(kin, &cfg.symmetries).unwrap();
        let lift = exact_lift(kin, &built, &cfg.composition.order);
        let any = crossym::pipeline::load_any_policy(&cfg, kin, &common::path(file)).unwrap();
        let AnyPolicy::TaskHead(with) = any else {
            panic!("{file} is not a task head")
        };
        let term = with
            .null_space()
            .unwrap_or_else(|| panic!("{config} ships a [redundancy] term"))
            .clone();
        let plain = (*with).clone().without_null_space();
        let demo = &demos.demos[0];
        let q_start = demo.q(0).to_vec();
        let reach = demo
            .x
            .chunks(3)
            .map(|p| (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt())
            .fold(0.0, f64::max);
        let (mut wws, mut pws) = (with.workspace(), plain.workspace());
        for s in &conditions {
            let (gap, travelled) = task_gap(kin, &built, &lift, &q_start, s, &mut |q, s, v| {
                with.velocity(q, s, v, &mut wws).expect("regular")
            });
            println!("{config} {s:?}: task-space gap {gap:.3e}, motion {travelled:.3} m");
            assert!(travelled > 0.02, "{config} {s:?}: the head barely moved");
            assert!(gap <= 1e-6 * reach, "{config} {s:?}: gap {gap}");
            let mut v0 = vec![0.0; kin.dof()];
            let (broken, _) = task_gap(kin, &built, &lift, &q_start, s, &mut |q, s, v| {
                plain.velocity(q, s, v, &mut pws).expect("regular");
                term.secondary(q, &mut v0);
                v.iter_mut().zip(&v0).for_each(|(v, w)| *v += w);
            });
            assert!(
                broken > 1e-3 * reach,
                "{config} {s:?}: the term not projected went unseen ({broken})"
            );
        }
    }
}

/// The endurance run of `config` for `seconds` with the null-space weight `weight`.
fn endurance(config: &str, seconds: f64, weight: f64) -> crossym::sim::endurance::EnduranceReport {
    let cfg = with_redundancy(common::load_config(config), weight);
    let (mut core, start, settings) = crossym::setup::endurance(&cfg, None, seconds, 10.0).unwrap();
    let r = crossym::sim::endurance::run(&mut core, &start, &settings);
    println!("{config}, weight {weight}: {r}");
    r
}

/// Endurance (shortened to 200 s of the 17 test conditions, a new one every 10 s, no reset):
/// RB-Y1's letters head with its null-space term keeps every joint ≥ 5 % of its range
/// from a limit and its posture drift bounded; with the term off (the plain lift) a joint
/// comes within 5 % and the drift grows — the test fails on it.
#[test]
fn rby1_letters_endurance_keeps_margins_and_posture_with_the_null_space_term() {
    if common::rby1_urdf().is_none() {
        return;
    }
    let on = endurance("rby1-letters.toml", 200.0, 1.0);
    let off = endurance("rby1-letters.toml", 200.0, 0.0);
    for r in [&on, &off] {
        assert_eq!(r.violation_ticks, 0, "{r}");
        assert_eq!(r.other_status_ticks, 0, "{r}");
        assert_eq!(r.conditions_accepted, 20, "{r}");
    }
    assert!(on.min_margin >= 0.05, "with the term: {on}");
    assert!(
        off.min_margin < 0.05,
        "the plain lift kept its margins: {off}"
    );
    assert!(on.bound_share() < off.bound_share(), "{on}\n{off}");
    // Drift: bounded with the term (each tenth's mean below 0.2 rad: it follows the drawing,
    // measured 0.003–0.125), growing without (measured 0.055 → 0.464 rad).
    assert!(on.drift_by_tenth.iter().all(|&d| d < 0.2), "{on}");
    assert!(off.drift_by_tenth[9] > 3.0 * off.drift_by_tenth[0], "{off}");
    assert!(
        off.drift_by_tenth[9] > 2.0 * on.drift_by_tenth[9],
        "{on}\n{off}"
    );
}

/// The planar arms (wide limits) over 120 s of their test conditions: the plain lift
/// drifts to ≈ 1.9 rad from rest in the null space, the term holds it near rest.
#[test]
fn planar_endurance_null_space_term_holds_the_posture() {
    let on = endurance("letters.toml", 120.0, 1.0);
    let off = endurance("letters.toml", 120.0, 0.0);
    for r in [&on, &off] {
        assert_eq!(r.violation_ticks, 0, "{r}");
    }
    assert!(on.final_drift < 0.1, "{on}");
    assert!(off.final_drift > 1.0, "{off}");
}

/// The pan head's group has no scaling (`[composition] order = ["M", "R"]`): the node takes
/// every rotation and either arm at λ = 1 and refuses another scale (the head could not
/// apply it); the letters head takes any valid condition.
#[test]
fn the_pan_head_accepts_every_rotation_and_arm_at_unit_scale_only() {
    if common::rby1_urdf().is_none() {
        return;
    }
    let (cfg, robot, _) = common::task("rby1-pan.toml");
    let kin = &robot.kinematics;
    let file = common::path("data/policies/pi_mr_head_rby1_pan.safetensors");
    let any = crossym::pipeline::load_any_policy(&cfg, kin, &file).unwrap();
    let d = cfg
        .node_config()
        .condition_domain(&any)
        .unwrap()
        .expect("a box: λ = 1");
    for (theta, reflection) in [(2.5, -1), (-3.0, 1), (0.0, 1), (1.2, -1)] {
        let s = Condition {
            theta,
            scale: 1.0,
            reflection,
        };
        assert!(d.check(&s).is_ok(), "{s:?}");
    }
    let scaled = Condition {
        theta: 0.3,
        scale: 0.8,
        reflection: 1,
    };
    assert!(d.check(&scaled).is_err());
    let (cfg, robot, _) = common::task("rby1-letters.toml");
    let file = common::path("data/policies/pi_mrt_head_rby1_letters.safetensors");
    let any = crossym::pipeline::load_any_policy(&cfg, &robot.kinematics, &file).unwrap();
    assert!(cfg.node_config().condition_domain(&any).unwrap().is_none());
}
