//! Unit tests of task-induced symmetries.

use super::discover::rref;
use super::*;
use nalgebra::{DMatrix, DVector};

fn fd_gradient(c: &Cost, x: &[f64]) -> Vec<f64> {
    let h = 1e-6;
    (0..x.len())
        .map(|i| {
            let mut p = x.to_vec();
            let mut m = x.to_vec();
            p[i] += h;
            m[i] -= h;
            (c.value(&p) - c.value(&m)) / (2.0 * h)
        })
        .collect()
}

#[test]
fn analytic_gradients_match_finite_differences() {
    let spec = CostSpec::Sum {
        terms: vec![
            WeightedCost {
                weight: 2.0,
                cost: CostSpec::DistanceToPoint {
                    point: vec![0.1, -0.2, 0.3],
                },
            },
            WeightedCost {
                weight: -0.5,
                cost: CostSpec::DistanceToLine {
                    point: vec![1.0, 0.0, 0.0],
                    direction: vec![0.0, 2.0, 1.0],
                },
            },
            WeightedCost {
                weight: 1.5,
                cost: CostSpec::HeightAbovePlane {
                    point: vec![0.0, 0.0, 1.0],
                    normal: vec![1.0, 1.0, 1.0],
                },
            },
        ],
    };
    let c = spec.build(3).unwrap();
    assert_eq!(c.terms(), 3);
    let x = [0.7, 0.4, -1.1];
    let mut g = [0.0; 3];
    assert!(c.gradient(&x, &mut g));
    let fd = fd_gradient(&c, &x);
    for i in 0..3 {
        assert!((g[i] - fd[i]).abs() < 1e-7, "{g:?} vs {fd:?}");
    }
    // Height is signed and uses the unit normal.
    let h = CostSpec::HeightAbovePlane {
        point: vec![0.0, 0.0],
        normal: vec![0.0, -3.0],
    }
    .build(2)
    .unwrap();
    assert!((h.value(&[5.0, 2.0]) + 2.0).abs() < 1e-15);
    // Undefined exactly at the point.
    let p = CostSpec::DistanceToPoint {
        point: vec![1.0, 2.0],
    }
    .build(2)
    .unwrap();
    assert!(!p.gradient(&[1.0, 2.0], &mut g[..2]));
}

#[test]
fn rref_reduces_and_reports_pivots() {
    let mut m = DMatrix::from_row_slice(2, 3, &[0.0, 2.0, 4.0, 1.0, 1.0, 1.0]);
    let p = rref(&mut m, 1e-12);
    assert_eq!(p, vec![0, 1]);
    let want = [1.0, 0.0, -1.0, 0.0, 1.0, 2.0];
    for (i, w) in want.iter().enumerate() {
        assert!((m[(i / 3, i % 3)] - w).abs() < 1e-15, "{m}");
    }
}

#[test]
fn numerical_structure_constants_match_exact_brackets() {
    let spec = CostSpec::HeightAbovePlane {
        point: vec![0.0, 0.0, 0.5],
        normal: vec![0.0, 0.0, 1.0],
    };
    let sym =
        TaskInducedSymmetry::from_spec("T", &spec, 3, 1, &TaskInducedSettings::default()).unwrap();
    let g = sym.generators();
    let c = &sym.report().structure_constants;
    for i in 0..g.len() {
        for j in 0..g.len() {
            if i == j {
                continue;
            }
            let exact = g[i].bracket(&g[j]);
            let mut fit = AffineGenerator::new(DMatrix::zeros(3, 3), DVector::zeros(3));
            for (l, gl) in g.iter().enumerate() {
                fit.linear += &gl.linear * c[i][j][l];
                fit.offset += &gl.offset * c[i][j][l];
            }
            assert!((exact.linear - fit.linear).norm() < 1e-8);
            assert!((exact.offset - fit.offset).norm() < 1e-8);
        }
    }
}

#[test]
fn settings_round_trip_and_reject_bad_values() {
    let s: TaskInducedSettings =
        toml::from_str("samples = 64\nseed = 3\n[region]\nlower = [0, 0]\nupper = [1, 2]\n")
            .unwrap();
    assert_eq!(s.samples, 64);
    assert!(s.validate(2).is_ok());
    assert!(s.validate(3).is_err());
    let bad = TaskInducedSettings {
        closure_tol: 0.0,
        ..TaskInducedSettings::default()
    };
    let e = bad.validate(3).unwrap_err().to_string();
    assert!(e.contains("closure_tol"), "{e}");
}
