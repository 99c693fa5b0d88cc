//! Candidate planes and the pairing of joints at `q = 0` under one orthogonal map `O`.

use nalgebra::{Matrix3, Vector3};

use super::structure::Structure;
use super::BodySettings;
use crate::symmetry::finite::SignedPermutation;

/// Coordinate-plane normals first, then bisectors of equidistant joint-origin pairs.
pub(super) fn candidate_normals(
    st: &Structure,
    lines0: &[(Vector3<f64>, Vector3<f64>)],
    settings: &BodySettings,
) -> Vec<Vector3<f64>> {
    let tol = settings.position_tolerance * st.size;
    let mut out: Vec<Vector3<f64>> = vec![Vector3::x(), Vector3::y(), Vector3::z()];
    let n = lines0.len();
    for i in 0..n {
        for k in i + 1..n {
            if st.prismatic[i] != st.prismatic[k] || st.depth[i] != st.depth[k] {
                continue;
            }
            let (pi, pk) = (lines0[i].0, lines0[k].0);
            let d = pi - pk;
            if d.norm() <= tol || (pi.norm() - pk.norm()).abs() > tol {
                continue;
            }
            let v = d.normalize();
            let dup = out.iter().any(|u| {
                (u - v).norm() < 10.0 * settings.axis_tolerance
                    || (u + v).norm() < 10.0 * settings.axis_tolerance
            });
            if !dup {
                out.push(v);
            }
        }
    }
    out
}

/// Where `O` sends joint `i`'s axis direction: `det(O)·O z` for rotations (axial vector),
/// `O z` for translations (polar vector).
pub(super) fn mapped_direction(
    o: &Matrix3<f64>,
    z: &Vector3<f64>,
    prismatic: bool,
) -> Vector3<f64> {
    let m = o * z;
    if prismatic || o.determinant() > 0.0 {
        m
    } else {
        -m
    }
}

/// Sign with which `O` maps the line `(p, z)` of joint `i` onto the line `(pk, zk)` of
/// joint `k`, if it does within the tolerances; and the worst line distance.
fn line_match(
    o: &Matrix3<f64>,
    (p, z): (Vector3<f64>, Vector3<f64>),
    (pk, zk): (Vector3<f64>, Vector3<f64>),
    prismatic: bool,
    pos_tol: f64,
    axis_tol: f64,
) -> Option<f64> {
    let d = mapped_direction(o, &z, prismatic);
    let sign = if (d - zk).norm() <= axis_tol {
        1.0
    } else if (d + zk).norm() <= axis_tol {
        -1.0
    } else {
        return None;
    };
    ((o * p - pk).cross(&zk).norm() <= pos_tol).then_some(sign)
}

/// The signed permutation under which `O` maps the joint tree onto itself at `q = 0`.
pub(super) fn pair_joints(
    st: &Structure,
    lines0: &[(Vector3<f64>, Vector3<f64>)],
    o: &Matrix3<f64>,
    settings: &BodySettings,
) -> Result<SignedPermutation, String> {
    let n = lines0.len();
    let pos_tol = settings.position_tolerance * st.size;
    let cand = joint_candidates(st, lines0, o, settings, pos_tol);
    if let Some(i) = (0..n).find(|&i| cand[i].is_empty()) {
        return Err(format!(
            "joint `{}` has no mirrored counterpart",
            st.tree.links[st.child_slot[i]]
                .joint
                .as_ref()
                .map_or("?", |j| j.name.as_str())
        ));
    }
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by_key(|&i| st.topo[i]);
    let mut image: Vec<Option<(usize, f64)>> = vec![None; n];
    let mut preimage: Vec<Option<usize>> = vec![None; n];
    let mut budget = 200_000_usize;
    if !assign(0, &order, &cand, st, &mut image, &mut preimage, &mut budget) {
        return Err(if budget == 0 {
            "the pairing search gave up (too many ambiguous axes)".into()
        } else {
            "no pairing of the joints preserves the tree".into()
        });
    }
    signed_permutation_of(&image)
}

/// For each joint, the joints of its kind and depth whose line `O` maps onto its line, with
/// the sign, the partner whose origin is the mirrored point first.
fn joint_candidates(
    st: &Structure,
    lines0: &[(Vector3<f64>, Vector3<f64>)],
    o: &Matrix3<f64>,
    settings: &BodySettings,
    pos_tol: f64,
) -> Vec<Vec<(usize, f64)>> {
    let n = lines0.len();
    let cand: Vec<Vec<(usize, f64)>> = (0..n)
        .map(|i| {
            (0..n)
                .filter(|&k| st.prismatic[k] == st.prismatic[i] && st.depth[k] == st.depth[i])
                .filter_map(|k| {
                    line_match(
                        o,
                        lines0[i],
                        lines0[k],
                        st.prismatic[i],
                        pos_tol,
                        settings.axis_tolerance,
                    )
                    .map(|s| (k, s))
                })
                .collect::<Vec<_>>()
        })
        .collect();
    // Several lines may coincide (wheels on one axle, collinear wrist axes): try first the
    // partner whose joint origin is the mirrored point.
    cand.into_iter()
        .enumerate()
        .map(|(i, mut c)| {
            // On a tie (two arms drawn on top of each other at q = 0) the swap comes first.
            let key = |k: usize| {
                let gap = (o * lines0[i].0 - lines0[k].0).norm();
                (gap > pos_tol, gap, k == i)
            };
            c.sort_by(|a, b| {
                let (ka, kb) = (key(a.0), key(b.0));
                ka.0.cmp(&kb.0)
                    .then(if ka.0 {
                        ka.1.total_cmp(&kb.1)
                    } else {
                        std::cmp::Ordering::Equal
                    })
                    .then(ka.2.cmp(&kb.2))
            });
            c
        })
        .collect()
}

/// The signed permutation acting on joint values that sends joint `i` to its image.
fn signed_permutation_of(image: &[Option<(usize, f64)>]) -> Result<SignedPermutation, String> {
    let n = image.len();
    let (perm, signs): (Vec<usize>, Vec<f64>) = image
        .iter()
        .map(|c| c.expect("every joint assigned"))
        .unzip();
    // (ρ q)_i = s_i q_{π⁻¹... }: joint i's value lands on its image; for the involutions
    // found here π = π⁻¹, and in general the output slot k receives s · q_i for k = π(i).
    let mut out_perm = vec![0; n];
    let mut out_signs = vec![1.0; n];
    for i in 0..n {
        out_perm[perm[i]] = i;
        out_signs[perm[i]] = signs[i];
    }
    SignedPermutation::new(out_perm, out_signs).map_err(|e| e.to_string())
}

/// Depth-first assignment of joint images in topological order, preserving parents.
fn assign(
    at: usize,
    order: &[usize],
    cand: &[Vec<(usize, f64)>],
    st: &Structure,
    image: &mut [Option<(usize, f64)>],
    preimage: &mut [Option<usize>],
    budget: &mut usize,
) -> bool {
    let Some(&i) = order.get(at) else {
        return true;
    };
    for &(k, s) in &cand[i] {
        if *budget == 0 {
            return false;
        }
        *budget -= 1;
        if preimage[k].is_some() {
            continue;
        }
        let parent_ok = match (st.parent[i], st.parent[k]) {
            (None, None) => true,
            (Some(pi), Some(pk)) => image[pi].map(|(x, _)| x) == Some(pk),
            _ => false,
        };
        if !parent_ok {
            continue;
        }
        image[i] = Some((k, s));
        preimage[k] = Some(i);
        if assign(at + 1, order, cand, st, image, preimage, budget) {
            return true;
        }
        image[i] = None;
        preimage[k] = None;
    }
    false
}
