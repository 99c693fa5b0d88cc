//! Task-induced symmetries (paper Sec. III-C, eq. 7): discovery of the cost-preserving
//! fields, the spanning / closure / completeness checks and their verdicts, and the flow
//! action with its group law.

use std::f64::consts::{FRAC_PI_2, PI};

use crossym::symmetry::field::{FnField, VectorField};
use crossym::symmetry::lie::TaskGroupAction;
use crossym::symmetry::task_induced::{
    check_fields, AffineGenerator, Cost, CostSpec, SampleRegion, TaskInducedError,
    TaskInducedFailure, TaskInducedSettings, TaskInducedSymmetry, WeightedCost,
};
use crossym::symmetry::transfer::flow::{FlowSettings, FlowWorkspace};
use crossym::symmetry::transfer::lift::LiftedAction;
use nalgebra::{DMatrix, DVector, Rotation3, Vector3};
use rand::Rng;

use crate::common;

fn point(p: &[f64]) -> CostSpec {
    CostSpec::DistanceToPoint { point: p.to_vec() }
}

fn line(p: &[f64], u: &[f64]) -> CostSpec {
    CostSpec::DistanceToLine {
        point: p.to_vec(),
        direction: u.to_vec(),
    }
}

fn plane(p: &[f64], n: &[f64]) -> CostSpec {
    CostSpec::HeightAbovePlane {
        point: p.to_vec(),
        normal: n.to_vec(),
    }
}

fn sum(terms: Vec<(f64, CostSpec)>) -> CostSpec {
    CostSpec::Sum {
        terms: terms
            .into_iter()
            .map(|(weight, cost)| WeightedCost { weight, cost })
            .collect(),
    }
}

fn discover(spec: &CostSpec, d: usize) -> TaskInducedSymmetry {
    TaskInducedSymmetry::from_spec("T", spec, d, 1, &TaskInducedSettings::default())
        .unwrap_or_else(|e| panic!("discovery of {spec:?} failed: {e}"))
}

fn skew(u: [f64; 3]) -> DMatrix<f64> {
    DMatrix::from_row_slice(
        3,
        3,
        &[0.0, -u[2], u[1], u[2], 0.0, -u[0], -u[1], u[0], 0.0],
    )
}

fn unit(u: [f64; 3]) -> [f64; 3] {
    let n = (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]).sqrt();
    [u[0] / n, u[1] / n, u[2] / n]
}

use common::dist;

fn assert_mat(a: &DMatrix<f64>, b: &DMatrix<f64>, tol: f64, what: &str) {
    assert!((a - b).norm() < tol, "{what}: {a} vs {b}");
}

/// `A p + b = 0`: the generator fixes `p`.
fn assert_fixes(g: &AffineGenerator, p: &[f64]) {
    let r = &g.linear * DVector::from_column_slice(p) + &g.offset;
    assert!(
        r.norm() < 1e-9,
        "generator {g:?} moves {p:?} at speed {}",
        r.norm()
    );
}

fn random_points(n: usize, seed: u64, center: &[f64], radius: f64) -> Vec<Vec<f64>> {
    let mut rng = common::rng(seed);
    (0..n)
        .map(|_| {
            center
                .iter()
                .map(|c| c + rng.random_range(-radius..radius))
                .collect()
        })
        .collect()
}

/// Checks report fields that every discovered (affine) symmetry must satisfy.
fn assert_invariant_closed_complete(sym: &TaskInducedSymmetry) {
    let r = sym.report();
    assert!(r.invariant, "invariance {:e}", r.invariance_residual);
    assert!(r.invariance_residual < 1e-12, "{:e}", r.invariance_residual);
    assert!(r.closed, "closure {:e}", r.closure_residual);
    assert!(r.complete, "{}", r.completeness_note);
    assert!(r.completeness_note.contains("affine fields are complete"));
    assert!(r.flow_failures.is_empty());
    assert!(r.samples >= 200, "{} samples", r.samples);
}

#[test]
fn distance_to_point_3d_gives_so3_about_the_point() {
    let p = [0.3, -0.2, 0.5];
    let sym = discover(&point(&p), 3);
    let r = sym.report();
    assert_eq!(sym.algebra_dim(), 3);
    assert_eq!((r.fields, r.level_set_dim, r.spanning_rank), (3, 2, 2));
    assert!(r.spanning && r.is_ok() && r.is_group(), "{}", r.verdict());
    assert!(r.verdict().starts_with("ok:"), "{}", r.verdict());
    assert_invariant_closed_complete(&sym);
    // Tidy basis: unit-rate rotations about e_x, e_y, e_z through p.
    for (k, g) in sym.generators().iter().enumerate() {
        let mut e = [0.0; 3];
        e[k] = 1.0;
        assert_mat(&g.linear, &skew(e), 1e-9, "so(3) basis");
        assert_fixes(g, &p);
        assert!(g.describe().starts_with("rotation"), "{}", g.describe());
    }
    // so(3) structure constants c_ij^l = ε_ijl: |c| = 1 on the third index, 0 elsewhere.
    let c = &r.structure_constants;
    assert_eq!(c.len(), 3);
    for (i, ci) in c.iter().enumerate() {
        for (j, cij) in ci.iter().enumerate() {
            for (l, v) in cij.iter().enumerate() {
                let eps = match (i, j, l) {
                    (0, 1, 2) | (1, 2, 0) | (2, 0, 1) => 1.0,
                    (1, 0, 2) | (2, 1, 0) | (0, 2, 1) => -1.0,
                    _ => 0.0,
                };
                assert!(
                    (v - eps).abs() < 1e-7,
                    "c[{i}][{j}][{l}] = {v} (want {eps})"
                );
            }
        }
    }
    // Exactly three null singular values among the seven candidates, well separated.
    let sv = sym.singular_values();
    assert_eq!(sv.len(), 7);
    assert!(sv[3] > 1e-3 && sv[4] < 1e-12, "{sv:?}");

    // The flow (eq. 7) preserves the cost and equals the closed-form rotation about p.
    let cost = sym.cost();
    let settings = FlowSettings::default();
    let mut ws = FlowWorkspace::new(3);
    let mut tws = sym.workspace();
    let mut out = [0.0; 3];
    let mut dv = [0.0; 3];
    let pv = Vector3::from(p);
    for (n, x) in random_points(20, 1, &p, 2.0).iter().enumerate() {
        let xi = [0.4 - 0.05 * n as f64, -0.7, 1.1 + 0.1 * n as f64];
        assert!(sym.act(&xi, x, &mut out, &settings, &mut ws).is_done());
        assert!(
            (cost.value(&out) - cost.value(x)).abs() < 1e-9,
            "cost changed from {} to {}",
            cost.value(x),
            cost.value(&out)
        );
        let rot = Rotation3::new(Vector3::from(xi));
        let want = pv + rot * (Vector3::from_column_slice(x) - pv);
        assert!(dist(&out, want.as_slice()) < 1e-9, "{out:?} vs {want:?}");
        // Differential: dΦ v = R v (variational equation).
        let v = [0.3, -1.0, 0.5];
        assert!(sym
            .differential(&xi, x, &v, &mut dv, &settings, &mut tws)
            .is_done());
        let rv = rot * Vector3::from(v);
        assert!(dist(&dv, rv.as_slice()) < 1e-7, "{dv:?} vs {rv:?}");
        assert!(dist(tws.point(), &out) < 1e-9);
    }
}

#[test]
fn distance_to_point_2d_gives_rotation_about_the_point() {
    let p = [1.5, -0.5];
    let sym = discover(&point(&p), 2);
    let r = sym.report();
    assert_eq!(sym.algebra_dim(), 1);
    assert_eq!((r.level_set_dim, r.spanning_rank), (1, 1));
    assert!(r.spanning && r.is_ok(), "{}", r.verdict());
    assert!(r.closure_worst_pair.is_none());
    assert_invariant_closed_complete(&sym);
    let g = &sym.generators()[0];
    assert_mat(
        &g.linear,
        &DMatrix::from_row_slice(2, 2, &[0.0, -1.0, 1.0, 0.0]),
        1e-9,
        "so(2)",
    );
    assert_fixes(g, &p);
    // A quarter turn about p.
    let mut out = [0.0; 2];
    let mut ws = FlowWorkspace::new(2);
    assert!(sym
        .act(
            &[FRAC_PI_2],
            &[2.5, -0.5],
            &mut out,
            &FlowSettings::default(),
            &mut ws
        )
        .is_done());
    assert!(dist(&out, &[1.5, 0.5]) < 1e-9, "{out:?}");
}

#[test]
fn distance_to_line_3d_gives_abelian_rotation_and_translation_along_it() {
    let p = [0.5, -1.0, 0.2];
    let u = unit([1.0, 1.0, 1.0]);
    let sym = discover(&line(&p, &[2.0, 2.0, 2.0]), 3);
    let r = sym.report();
    assert_eq!(sym.algebra_dim(), 2, "{:?}", sym.generators());
    assert_eq!((r.level_set_dim, r.spanning_rank), (2, 2));
    assert!(r.spanning && r.is_ok(), "{}", r.verdict());
    assert_invariant_closed_complete(&sym);
    let (rot, tr) = (&sym.generators()[0], &sym.generators()[1]);
    assert_mat(&rot.linear, &skew(u), 1e-9, "rotation about the line");
    assert_fixes(rot, &p);
    let q: Vec<f64> = (0..3).map(|i| p[i] + 3.0 * u[i]).collect();
    assert_fixes(rot, &q);
    assert!(tr.linear.norm() < 1e-12);
    let t = tr.offset.as_slice();
    assert!(
        dist(t, &u) < 1e-9 || dist(t, &u.map(|v| -v)) < 1e-9,
        "translation {t:?} not along {u:?}"
    );
    // Abelian: all structure constants vanish.
    for row in &r.structure_constants {
        for c in row {
            assert!(c.iter().all(|v| v.abs() < 1e-8), "{c:?}");
        }
    }
    assert!(r.closure_residual < 1e-8);
}

#[test]
fn height_above_plane_gives_se2() {
    let sym = discover(&plane(&[0.0, 0.0, 0.5], &[0.0, 0.0, 3.0]), 3);
    let r = sym.report();
    assert_eq!(sym.algebra_dim(), 3);
    assert_eq!((r.level_set_dim, r.spanning_rank), (2, 2));
    assert!(r.is_ok(), "{}", r.verdict());
    assert_invariant_closed_complete(&sym);
    let g = sym.generators();
    // Rotation about the normal (any axis ∥ n is a symmetry: it is taken through the box centre).
    assert_mat(
        &g[0].linear,
        &skew([0.0, 0.0, 1.0]),
        1e-9,
        "rotation about n",
    );
    assert!(g[0].offset[2].abs() < 1e-12);
    assert!(dist(g[1].offset.as_slice(), &[1.0, 0.0, 0.0]) < 1e-12 && g[1].linear.norm() == 0.0);
    assert!(dist(g[2].offset.as_slice(), &[0.0, 1.0, 0.0]) < 1e-12 && g[2].linear.norm() == 0.0);
    // se(2): [R, T_x] = T_y, [R, T_y] = −T_x, [T_x, T_y] = 0.
    let c = &r.structure_constants;
    let want = [
        (0, 1, [0.0, 0.0, 1.0]),
        (0, 2, [0.0, -1.0, 0.0]),
        (1, 2, [0.0, 0.0, 0.0]),
    ];
    for (i, j, w) in want {
        for l in 0..3 {
            assert!(
                (c[i][j][l] - w[l]).abs() < 1e-7,
                "c[{i}][{j}] = {:?}",
                c[i][j]
            );
            assert!((c[j][i][l] + w[l]).abs() < 1e-7);
        }
    }
}

#[test]
fn sum_of_two_plane_heights_is_a_tilted_plane_not_the_common_subalgebra() {
    // z + x = √2 · height above the plane with normal (1, 0, 1)/√2: its se(2) contains the
    // rotation about (1, 0, 1), which preserves neither term alone.
    let spec = sum(vec![
        (1.0, plane(&[0.0, 0.0, 0.0], &[0.0, 0.0, 1.0])),
        (1.0, plane(&[0.0, 0.0, 0.0], &[1.0, 0.0, 0.0])),
    ]);
    let sym = discover(&spec, 3);
    let r = sym.report();
    assert_eq!(sym.algebra_dim(), 3);
    assert!(r.is_ok(), "{}", r.verdict());
    let n = unit([1.0, 0.0, 1.0]);
    let g = sym.generators();
    assert_mat(
        &g[0].linear,
        &skew(n),
        1e-9,
        "rotation about the tilted normal",
    );
    for t in &g[1..] {
        assert!(t.linear.norm() == 0.0);
        let v = t.offset.as_slice();
        assert!((v.iter().zip(&n).map(|(a, b)| a * b).sum::<f64>()).abs() < 1e-12);
        assert!((dist(v, &[0.0; 3]) - 1.0).abs() < 1e-12);
    }
    assert!(g[1].offset.dot(&g[2].offset).abs() < 1e-12);
}

#[test]
fn sum_of_distances_to_two_points_keeps_only_the_axis_rotation_and_does_not_span() {
    let (p, q) = ([0.0, 0.0, 0.0], [1.0, 1.0, 0.5]);
    let spec = sum(vec![(1.0, point(&p)), (1.0, point(&q))]);
    let sym = discover(&spec, 3);
    let r = sym.report();
    assert_eq!(sym.algebra_dim(), 1, "{:?}", sym.generators());
    let u = unit([1.0, 1.0, 0.5]);
    let g = &sym.generators()[0];
    assert_mat(&g.linear, &skew(u), 1e-9, "rotation about the axis pq");
    assert_fixes(g, &p);
    assert_fixes(g, &q);
    assert_eq!((r.level_set_dim, r.spanning_rank), (2, 1));
    assert!(!r.spanning && r.closed && r.complete && r.invariant);
    assert_eq!(r.failures(), vec![TaskInducedFailure::NotSpanning]);
    assert!(r.is_group() && !r.is_ok());
    let v = r.verdict();
    assert!(
        v.starts_with("not spanning") && v.contains("only 1 of the 2 level-set directions"),
        "{v}"
    );
    assert!(v.contains("still generate a Lie group"), "{v}");
    // The one-field group still preserves the cost.
    let mut out = [0.0; 3];
    let mut ws = FlowWorkspace::new(3);
    let x = [0.7, -0.3, 1.2];
    assert!(sym
        .act(&[2.0], &x, &mut out, &FlowSettings::default(), &mut ws)
        .is_done());
    assert!((sym.cost().value(&out) - sym.cost().value(&x)).abs() < 1e-9);
    assert!(dist(&out, &x) > 0.5);
}

#[test]
fn height_plus_distance_to_vertical_axis_keeps_only_rotation_about_z() {
    // c = z + sqrt(x² + y²): level sets are cones about the z axis. Translations along z and
    // the radial dilation change c, translations in the plane change the distance term; only
    // the rotation about z survives, so one field for a 2-D level set: not spanning.
    let spec = sum(vec![
        (1.0, plane(&[0.0, 0.0, 0.0], &[0.0, 0.0, 1.0])),
        (1.0, line(&[0.0, 0.0, 0.0], &[0.0, 0.0, 1.0])),
    ]);
    let sym = discover(&spec, 3);
    let r = sym.report();
    assert_eq!(sym.algebra_dim(), 1, "{:?}", sym.generators());
    let g = &sym.generators()[0];
    assert_mat(&g.linear, &skew([0.0, 0.0, 1.0]), 1e-9, "rotation about z");
    assert!(g.offset.norm() < 1e-9, "{}", g.offset);
    assert_eq!(r.spanning_rank, 1);
    assert_eq!(r.failures(), vec![TaskInducedFailure::NotSpanning]);
    assert!(r.verdict().contains("not spanning"), "{}", r.verdict());
    // Different weights do not change the answer.
    let spec = sum(vec![
        (3.0, plane(&[0.0, 0.0, 1.0], &[0.0, 0.0, 1.0])),
        (-0.5, line(&[0.0, 0.0, 0.0], &[0.0, 0.0, -2.0])),
    ]);
    assert_eq!(discover(&spec, 3).algebra_dim(), 1);
}

#[test]
fn user_fields_that_are_not_closed_are_reported() {
    // Rotations about x and y preserve |x| and span its spheres at generic points, but their
    // bracket is the rotation about z: not a combination of the two.
    let cost = Cost::new(&point(&[0.0, 0.0, 0.0]), 3).unwrap();
    let gens = vec![
        AffineGenerator::rotation_about(skew([1.0, 0.0, 0.0]), &[0.0; 3]),
        AffineGenerator::rotation_about(skew([0.0, 1.0, 0.0]), &[0.0; 3]),
    ];
    let sym = TaskInducedSymmetry::from_generators(
        "R_xy",
        &cost,
        gens,
        1,
        &TaskInducedSettings::default(),
    )
    .unwrap();
    let r = sym.report();
    assert!(r.invariant && r.spanning && r.complete, "{}", r.verdict());
    assert!(
        !r.closed && r.closure_residual > 0.1,
        "{:e}",
        r.closure_residual
    );
    assert_eq!(r.closure_worst_pair, Some((0, 1)));
    assert_eq!(r.failures(), vec![TaskInducedFailure::NotClosed]);
    let v = r.verdict();
    assert!(v.starts_with("not closed: the bracket [X_0, X_1]"), "{v}");
    assert!(v.contains("no group action"), "{v}");
}

#[test]
fn incomplete_and_non_invariant_fields_are_reported() {
    // c = y on R^2. X = (1 + x², 0) preserves c and spans its lines, but its flow
    // x(t) = tan(t + atan x0) blows up before t = π/2 < 10: not complete.
    let cost = Cost::new(&plane(&[0.0, 0.0], &[0.0, 1.0]), 2).unwrap();
    let blow_up = FnField::new(2, |p: &[f64], o: &mut [f64]| {
        o[0] = 1.0 + p[0] * p[0];
        o[1] = 0.0;
    });
    let settings = TaskInducedSettings {
        samples: 64,
        ..TaskInducedSettings::default()
    };
    let r = check_fields(&cost, &[&blow_up], &settings).unwrap();
    assert!(r.invariant && r.spanning && r.closed, "{}", r.verdict());
    assert!(!r.complete && !r.flow_failures.is_empty());
    assert!(r.flow_failures.iter().all(|f| !f.status.is_done()));
    assert_eq!(r.failures(), vec![TaskInducedFailure::NotComplete]);
    let v = r.verdict();
    assert!(
        v.starts_with("not complete:") && v.contains("did not reach"),
        "{v}"
    );

    // A bounded nonlinear field along the level sets is complete (numerically).
    let bounded = FnField::new(2, |p: &[f64], o: &mut [f64]| {
        o[0] = 1.5 + p[0].sin();
        o[1] = 0.0;
    });
    let r = check_fields(&cost, &[&bounded], &settings).unwrap();
    assert!(r.is_ok(), "{}", r.verdict());
    assert!(
        r.completeness_note.contains("not a proof"),
        "{}",
        r.completeness_note
    );

    // Translation along the normal changes the cost.
    let up = FnField::new(2, |_: &[f64], o: &mut [f64]| {
        o[0] = 0.0;
        o[1] = 1.0;
    });
    let r = check_fields(&cost, &[&up], &settings).unwrap();
    assert!(!r.invariant && (r.invariance_residual - 1.0).abs() < 1e-12);
    assert!(r.verdict().starts_with("not invariant"), "{}", r.verdict());

    // Fields on the wrong space are rejected.
    let wrong = FnField::new(3, |_: &[f64], o: &mut [f64]| o.fill(0.0));
    assert!(matches!(
        check_fields(&cost, &[&wrong], &settings),
        Err(TaskInducedError::FieldDimension {
            index: 0,
            expected: 2,
            got: 3
        })
    ));
}

#[test]
fn invalid_specs_are_rejected_with_clear_messages() {
    let err = |spec: CostSpec, d: usize| Cost::new(&spec, d).unwrap_err();

    let e = err(line(&[0.0, 0.0, 0.0], &[0.0, 0.0, 0.0]), 3);
    assert!(matches!(
        e,
        TaskInducedError::ZeroVector {
            what: "direction",
            ..
        }
    ));
    assert!(
        e.to_string().contains("direction") && e.to_string().contains("zero vector"),
        "{e}"
    );

    let e = err(plane(&[0.0, 0.0], &[0.0, 0.0]), 2);
    assert!(e.to_string().contains("normal"), "{e}");

    let e = err(point(&[1.0, 2.0]), 3);
    assert_eq!(
        e.to_string(),
        "cost `cost`: point has 2 coordinates, but the task block is 3-D"
    );

    let nested = sum(vec![
        (1.0, point(&[0.0, 0.0, 0.0])),
        (2.0, line(&[0.0, 0.0, 0.0], &[1.0, 0.0])),
    ]);
    let e = err(nested, 3);
    assert!(
        matches!(&e, TaskInducedError::WrongDimension { path, what: "direction", expected: 3, got: 2 } if path == "cost.terms[1].cost"),
        "{e:?}"
    );

    let e = err(point(&[f64::NAN, 0.0, 0.0]), 3);
    assert!(matches!(
        e,
        TaskInducedError::NonFinite { what: "point", .. }
    ));
    assert!(e.to_string().contains("non-finite"), "{e}");
    let e = err(line(&[0.0, 0.0, 0.0], &[f64::INFINITY, 0.0, 0.0]), 3);
    assert!(matches!(
        e,
        TaskInducedError::NonFinite {
            what: "direction",
            ..
        }
    ));

    let e = err(sum(vec![(0.0, point(&[0.0, 0.0]))]), 2);
    assert!(e.to_string().contains("weight 0"), "{e}");
    let e = err(sum(vec![(f64::NAN, point(&[0.0, 0.0]))]), 2);
    assert!(matches!(e, TaskInducedError::BadWeight { .. }));
    let e = err(sum(vec![]), 2);
    assert!(e.to_string().contains("at least one term"), "{e}");
    let e = err(point(&[0.0; 4]), 4);
    assert!(e.to_string().contains("2-D or 3-D"), "{e}");

    // A cost whose terms cancel is constant: no level sets to analyse.
    let flat = sum(vec![
        (1.0, plane(&[0.0, 0.0, 0.0], &[0.0, 0.0, 1.0])),
        (-1.0, plane(&[0.0, 0.0, 0.0], &[0.0, 0.0, 1.0])),
    ]);
    let e = TaskInducedSymmetry::from_spec("F", &flat, 3, 1, &TaskInducedSettings::default())
        .unwrap_err();
    assert!(
        matches!(e, TaskInducedError::DegenerateCost { usable: 0, .. }),
        "{e:?}"
    );
    assert!(e.to_string().contains("gradient vanishes"), "{e}");

    // No blocks, bad settings.
    let ok = point(&[0.0, 0.0]);
    assert!(matches!(
        TaskInducedSymmetry::from_spec("T", &ok, 2, 0, &TaskInducedSettings::default()),
        Err(TaskInducedError::NoBlocks)
    ));
    let bad = TaskInducedSettings {
        samples: 3,
        ..TaskInducedSettings::default()
    };
    let e = TaskInducedSymmetry::from_spec("T", &ok, 2, 1, &bad).unwrap_err();
    assert!(e.to_string().contains("`samples`"), "{e}");
}

#[test]
fn specs_deserialize_from_toml_and_json_and_reject_unknown_fields() {
    let spec: CostSpec = toml::from_str(
        r#"
kind = "sum"
[[terms]]
cost = { kind = "distance_to_point", point = [0.0, 0.0, 0.0] }
[[terms]]
weight = 2.0
cost = { kind = "height_above_plane", point = [0.0, 0.0, 1.0], normal = [0.0, 0.0, 1.0] }
"#,
    )
    .unwrap();
    match &spec {
        CostSpec::Sum { terms } => {
            assert_eq!(terms.len(), 2);
            assert_eq!(terms[0].weight, 1.0, "default weight");
            assert_eq!(terms[1].weight, 2.0);
        }
        other => panic!("{other:?}"),
    }
    let c = Cost::new(&spec, 3).unwrap();
    assert!((c.value(&[0.0, 3.0, 4.0]) - (5.0 + 2.0 * 3.0)).abs() < 1e-12);

    let json = serde_json::to_string(&spec).unwrap();
    let back: CostSpec = serde_json::from_str(&json).unwrap();
    assert_eq!(back, spec);

    let unknown: Result<CostSpec, _> =
        toml::from_str("kind = \"distance_to_point\"\npoint = [0, 0]\nradius = 1.0\n");
    assert!(unknown.unwrap_err().to_string().contains("radius"));
    let kind: Result<CostSpec, _> = toml::from_str("kind = \"distance_to_circle\"\n");
    assert!(kind.is_err());
}

#[test]
fn flow_action_satisfies_the_group_law() {
    let settings = FlowSettings::default();
    // Commuting fields (rotation about and translation along a line): exp(ξ)exp(ζ) = exp(ξ+ζ).
    let sym = discover(&line(&[0.2, 0.1, -0.3], &[0.0, 1.0, 1.0]), 3);
    assert_eq!(sym.algebra_dim(), 2);
    let mut ws = FlowWorkspace::new(3);
    let (mut a, mut b, mut c) = ([0.0; 3], [0.0; 3], [0.0; 3]);
    for (n, x) in random_points(15, 7, &[0.0, 0.0, 0.0], 2.0)
        .iter()
        .enumerate()
    {
        let xi = [0.3 + 0.1 * n as f64, -0.8];
        let zeta = [-1.4, 0.25 * n as f64];
        let both = [xi[0] + zeta[0], xi[1] + zeta[1]];
        assert!(sym.act(&xi, x, &mut a, &settings, &mut ws).is_done());
        assert!(sym.act(&zeta, &a, &mut b, &settings, &mut ws).is_done());
        assert!(sym.act(&both, x, &mut c, &settings, &mut ws).is_done());
        assert!(dist(&b, &c) < 1e-9, "{b:?} vs {c:?}");
        // Inverse: exp(−ξ) exp(ξ) = e.
        let minus = [-xi[0], -xi[1]];
        assert!(sym.act(&minus, &a, &mut b, &settings, &mut ws).is_done());
        assert!(dist(&b, x) < 1e-9, "{b:?} vs {x:?}");
        // Matches the closed form (matrix exponential of the affine generator).
        sym.act_closed_form(&xi, x, &mut b);
        assert!(dist(&a, &b) < 1e-9);
    }
    // Non-commuting so(3): the inverse law still holds, exp(ξ)exp(ζ) ≠ exp(ξ+ζ) in general.
    let so3 = discover(&point(&[0.0, 0.5, 0.0]), 3);
    let x = [1.0, -0.5, 0.7];
    let xi = [0.9, 0.0, 0.0];
    let zeta = [0.0, 0.9, 0.0];
    assert!(so3.act(&xi, &x, &mut a, &settings, &mut ws).is_done());
    assert!(so3
        .act(&[-0.9, 0.0, 0.0], &a, &mut b, &settings, &mut ws)
        .is_done());
    assert!(dist(&b, &x) < 1e-9);
    assert!(so3.act(&zeta, &a, &mut b, &settings, &mut ws).is_done());
    assert!(so3
        .act(&[0.9, 0.9, 0.0], &x, &mut c, &settings, &mut ws)
        .is_done());
    assert!(
        dist(&b, &c) > 1e-2,
        "so(3) flows should not compose additively"
    );
    // A full turn is the identity.
    assert!(so3
        .act(&[0.0, 0.0, 2.0 * PI], &x, &mut a, &settings, &mut ws)
        .is_done());
    assert!(dist(&a, &x) < 1e-8);
}

#[test]
fn acts_identically_on_every_block_and_as_a_task_group_action() {
    let spec = point(&[0.5, 0.5]);
    let settings = TaskInducedSettings::default();
    let one = TaskInducedSymmetry::from_spec("T", &spec, 2, 1, &settings).unwrap();
    let two = TaskInducedSymmetry::from_spec("T", &spec, 2, 2, &settings).unwrap();
    assert_eq!((two.dim(), two.blocks(), two.block_dim()), (4, 2, 2));
    assert_eq!(two.report(), one.report());
    let x = [1.0, 0.0, -1.0, 2.0];
    let mut out = [0.0; 4];
    let mut ws = FlowWorkspace::new(4);
    let mut ws1 = FlowWorkspace::new(2);
    assert!(two
        .act(&[0.7], &x, &mut out, &FlowSettings::default(), &mut ws)
        .is_done());
    for b in 0..2 {
        let mut o = [0.0; 2];
        assert!(one
            .act(
                &[0.7],
                &x[2 * b..2 * b + 2],
                &mut o,
                &FlowSettings::default(),
                &mut ws1
            )
            .is_done());
        // Step-size control sees all blocks at once: equal to integration accuracy.
        assert!(dist(&o, &out[2 * b..2 * b + 2]) < 1e-9);
    }
    let mut exact = [0.0; 4];
    two.act_closed_form(&[0.7], &x, &mut exact);
    assert!(dist(&exact, &out) < 1e-9);
    // Through the TaskGroupAction trait (what the lift uses).
    let action: &dyn TaskGroupAction = &two;
    assert_eq!(
        (action.name(), action.dim(), action.algebra_dim()),
        ("T", 4, 1)
    );
    let mut via = [0.0; 4];
    assert!(action.act_on(&[0.7], &x, &mut via));
    assert!(dist(&via, &out) < 1e-9);
    let mut gen = [0.0; 4];
    assert!(action.generator_field(&[1.0]).eval(&x, &mut gen));
    // Rotation about (0.5, 0.5): X(x) = J (x − p).
    assert!(dist(&gen, &[0.5, 0.5, -1.5, -1.5]) < 1e-12, "{gen:?}");
    let v = [1.0, 0.0, 0.0, 1.0];
    let mut dv = [0.0; 4];
    assert!(action.differential_on(&[FRAC_PI_2], &x, &v, &mut dv));
    assert!(dist(&dv, &[0.0, 1.0, -1.0, 0.0]) < 1e-7, "{dv:?}");
}

#[test]
fn task_induced_rotation_lifts_to_the_planar_dual_arm() {
    // A distance-to-a-point cost on both end effectors of the paper's planar dual arm: its
    // rotation about the point lifts through the kinematics (eqs. 17–19).
    let robot = common::planar();
    let k = &robot.kinematics;
    assert_eq!(k.task_dim(), 4);
    let sym = TaskInducedSymmetry::from_spec(
        "T",
        &point(&[0.5, 1.0]),
        2,
        2,
        &TaskInducedSettings::default(),
    )
    .unwrap();
    let lifted = LiftedAction::new(k, &sym, FlowSettings::default()).unwrap();
    let mut lws = lifted.workspace();
    let q0 = [PI / 4.0, -PI / 6.0, -PI / 8.0, -PI / 10.0];
    let q: Vec<f64> = q0.iter().copied().chain(q0.iter().map(|v| -v)).collect();
    for theta in [0.2, -0.3] {
        let e = lifted
            .equivariance_residual(&[theta], &q, &mut lws)
            .unwrap();
        assert!(e < 1e-6, "equivariance residual {e:e} at θ = {theta}");
    }
}

#[test]
fn caller_region_and_seed_do_not_change_the_algebra() {
    // A box not centred on the point, another seed, fewer samples: still so(3) about p.
    let p = [0.3, -0.2, 0.5];
    let settings = TaskInducedSettings {
        samples: 64,
        seed: 42,
        region: Some(SampleRegion {
            lower: vec![-3.0, -1.0, -2.0],
            upper: vec![1.0, 4.0, 0.5],
        }),
        ..TaskInducedSettings::default()
    };
    let sym = TaskInducedSymmetry::from_spec("T", &point(&p), 3, 1, &settings).unwrap();
    assert_eq!(sym.algebra_dim(), 3);
    assert!(sym.report().is_ok(), "{}", sym.report().verdict());
    for (k, g) in sym.generators().iter().enumerate() {
        let mut e = [0.0; 3];
        e[k] = 1.0;
        assert_mat(&g.linear, &skew(e), 1e-9, "so(3) basis");
        assert_fixes(g, &p);
    }
    // Deterministic given the seed.
    let again = TaskInducedSymmetry::from_spec("T", &point(&p), 3, 1, &settings).unwrap();
    assert_eq!(again.report(), sym.report());
    assert_eq!(again.generators(), sym.generators());
}

#[test]
fn two_points_in_the_plane_have_no_continuous_symmetry() {
    // |x − p| + |x − q| in 2-D: ellipses; the only symmetries are reflections (discrete).
    let spec = sum(vec![(1.0, point(&[0.0, 0.0])), (1.0, point(&[2.0, 1.0]))]);
    let sym = discover(&spec, 2);
    assert_eq!(sym.algebra_dim(), 0);
    let r = sym.report();
    assert_eq!((r.fields, r.level_set_dim, r.spanning_rank), (0, 1, 0));
    assert_eq!(r.failures(), vec![TaskInducedFailure::NotSpanning]);
    assert!(
        r.verdict().contains("no continuous symmetry"),
        "{}",
        r.verdict()
    );
    // The trivial group acts as the identity.
    let mut out = [0.0; 2];
    let mut ws = FlowWorkspace::new(2);
    assert!(sym
        .act(
            &[],
            &[0.3, 0.4],
            &mut out,
            &FlowSettings::default(),
            &mut ws
        )
        .is_done());
    assert_eq!(out, [0.3, 0.4]);
}
