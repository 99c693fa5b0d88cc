//! Ensembles, packed layers, allocation-free velocity calls and width checks.

use super::*;
use crate::activation::Activation;
use crate::features::Normalizer;
use crossym_math::symmetry::compose::Condition;

fn policy(n: usize, hidden: Vec<usize>) -> Policy {
    let spec = MlpSpec {
        input: n + 4,
        hidden,
        output: n,
        activation: Activation::Tanh,
    };
    let (mut w, mut b) = (Vec::new(), Vec::new());
    for l in 0..spec.num_layers() {
        let (o, i) = spec.layer_shape(l);
        // Deterministic, well-scaled weights without an RNG.
        w.push(
            (0..o * i)
                .map(|k| ((k * 7 + l) % 13) as f64 / 13.0 - 0.45)
                .collect(),
        );
        b.push((0..o).map(|k| 0.01 * k as f64).collect());
    }
    let mlp = MlpInference::new(spec, w, b).unwrap();
    Policy::new(Normalizer::identity(n), mlp, PolicyMeta::default()).unwrap()
}

/// The merged ensemble computes the mean of its members' outputs (each member
/// evaluated on its own), for one, two and three hidden layers of unequal widths.
#[test]
fn average_of_networks_is_the_mean_of_their_outputs() {
    for hidden in [vec![5], vec![6, 4], vec![3, 7, 5]] {
        let members: Vec<Policy> = (0..3u64)
            .map(|k| Policy::synthetic(4, Vec::new(), &hidden, 11 + k))
            .collect();
        let avg = Policy::average(&members).unwrap();
        assert_eq!(avg.mlp().spec().hidden[0], 3 * hidden[0]);
        let mut ws = avg.workspace();
        let mut wss: Vec<_> = members.iter().map(Policy::workspace).collect();
        let (mut out, mut one) = (vec![0.0; 4], vec![0.0; 4]);
        for t in 0..20 {
            let q: Vec<f64> = (0..4).map(|j| (0.3 * t as f64 + j as f64).sin()).collect();
            let s = Condition {
                theta: 0.1 * t as f64,
                scale: 0.8,
                reflection: if t % 2 == 0 { 1 } else { -1 },
            };
            avg.velocity(&q, &s, &mut out, &mut ws);
            let mut mean = [0.0; 4];
            for (p, w) in members.iter().zip(&mut wss) {
                p.velocity(&q, &s, &mut one, w);
                for j in 0..4 {
                    mean[j] += one[j] / 3.0;
                }
            }
            for j in 0..4 {
                assert!(
                    (out[j] - mean[j]).abs() < 1e-12,
                    "{hidden:?}: {out:?} vs {mean:?}"
                );
            }
        }
    }
    let other = Policy::synthetic(3, Vec::new(), &[5], 1);
    let one = Policy::synthetic(4, Vec::new(), &[5], 1);
    assert!(Policy::average(&[one, other]).is_err());
}

#[test]
fn block_diagonal_layers_are_packed_and_give_the_dense_result_bit_for_bit() {
    // (members, member hidden widths, expected blocks per layer).
    for (k, hidden, blocks) in [
        (4, vec![64, 64], vec![1, 4, 1]),
        (3, vec![16, 32, 16], vec![1, 3, 3, 1]),
        (2, vec![8, 8], vec![1, 1, 1]), // blocks of 8 columns: not packed
    ] {
        let members: Vec<MlpInference> = (0..k as u64)
            .map(|m| {
                Policy::synthetic(6, Vec::new(), &hidden, 40 + m)
                    .mlp()
                    .clone()
            })
            .collect();
        let avg = MlpInference::average(&members).unwrap();
        let found: Vec<usize> = (0..avg.spec().num_layers())
            .map(|l| avg.layer_blocks(l))
            .collect();
        assert_eq!(found, blocks, "{k} × {hidden:?}");
        assert_forward_bitwise_dense(&avg);
    }
    // An entry off the four 64-blocks of layer 1 but inside one of two 128-blocks:
    // packed as two blocks; one outside both: dense.
    let members: Vec<MlpInference> = (0..4u64)
        .map(|m| {
            Policy::synthetic(6, Vec::new(), &[64, 64], 40 + m)
                .mlp()
                .clone()
        })
        .collect();
    let avg = MlpInference::average(&members).unwrap();
    for (col, blocks) in [(100, 2), (200, 1)] {
        let mut weights: Vec<Vec<f64>> = (0..3).map(|l| avg.weight(l).to_vec()).collect();
        let biases: Vec<Vec<f64>> = (0..3).map(|l| avg.bias(l).to_vec()).collect();
        assert_eq!(weights[1][col], 0.0);
        weights[1][col] = 1e-3; // row 0, column `col`
        let net = MlpInference::new(avg.spec().clone(), weights, biases).unwrap();
        assert_eq!(net.layer_blocks(1), blocks, "entry at column {col}");
        assert_forward_bitwise_dense(&net);
    }
}

/// `net`'s forward equals, bit for bit, the forward with every layer dense, on inputs
/// that drive the tanh layers through their range.
fn assert_forward_bitwise_dense(net: &MlpInference) {
    let dense = net.dense_only();
    let (mut ws, mut wd) = (net.workspace(), dense.workspace());
    let n_out = net.spec().output;
    let (mut a, mut b) = (vec![0.0; n_out], vec![0.0; n_out]);
    for t in 0..50 {
        let x: Vec<f64> = (0..net.spec().input)
            .map(|j| 3.0 * (0.37 * t as f64 + 1.3 * j as f64).sin())
            .collect();
        net.forward(&x, &mut a, &mut ws);
        dense.forward(&x, &mut b, &mut wd);
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&a), bits(&b), "input {t}: {a:?} vs {b:?}");
    }
}

#[test]
fn velocity_10k_calls_without_workspace_growth() {
    let p = policy(8, vec![64, 48, 64]);
    let mut ws = p.workspace();
    let cap = ws.capacity();
    let mut q = [0.0; 8];
    let mut out = [0.0; 8];
    let mut first = [0.0; 8];
    for i in 0..10_000 {
        let s = Condition {
            theta: (i as f64 * 1e-3).sin() * 3.0,
            scale: 0.5 + 0.5 * ((i % 7) as f64 / 7.0),
            reflection: if i % 2 == 0 { 1 } else { -1 },
        };
        for (j, qj) in q.iter_mut().enumerate() {
            *qj = ((i + j) as f64 * 1e-2).cos();
        }
        p.velocity(&q, &s, &mut out, &mut ws);
        assert!(out.iter().all(|v| v.is_finite()));
        if i == 0 {
            first = out;
        }
        assert_eq!(ws.capacity(), cap);
    }
    // Same input as call 0 gives the same output: no state leaks between calls.
    let mut q0 = [0.0; 8];
    for (j, qj) in q0.iter_mut().enumerate() {
        *qj = (j as f64 * 1e-2).cos();
    }
    p.velocity(
        &q0,
        &Condition {
            theta: 0.0,
            scale: 0.5,
            reflection: 1,
        },
        &mut out,
        &mut ws,
    );
    assert_eq!(out, first);
}

#[test]
fn forward_without_hidden_layers_is_affine() {
    let p = policy(2, vec![]);
    let mut ws = p.workspace();
    let mut out = [0.0; 2];
    p.velocity(&[0.0, 0.0], &Condition::IDENTITY, &mut out, &mut ws);
    // u = [0, 0, 1, 0, 0, 1]: y_r = b_r + W_r2 + W_r5.
    let w = p.mlp().weight(0);
    for r in 0..2 {
        assert!((out[r] - (p.mlp().bias(0)[r] + w[r * 6 + 2] + w[r * 6 + 5])).abs() < 1e-15);
    }
}

#[test]
fn rejects_inconsistent_widths() {
    let spec = MlpSpec {
        input: 6,
        hidden: vec![3],
        output: 2,
        activation: Activation::Tanh,
    };
    assert!(MlpInference::new(spec.clone(), vec![vec![0.0; 18]], vec![vec![0.0; 3]]).is_err());
    let mlp = MlpInference::new(
        spec,
        vec![vec![0.0; 18], vec![0.0; 6]],
        vec![vec![0.0; 3], vec![0.0; 2]],
    )
    .unwrap();
    let e = Policy::new(Normalizer::identity(3), mlp, PolicyMeta::default()).unwrap_err();
    assert!(e.to_string().contains("mlp.input"), "{e}");
}
