//! Verification of one element `(O, ρ_Q)` on sampled configurations, the mimic-sign
//! refinement and the classification of `O`.

use nalgebra::{Matrix3, Rotation3, Vector3};

use super::super::chains::LimitMismatch;
use super::pairing::mapped_direction;
use super::structure::{axis_lines, Structure};
use super::{BodyElement, BodySettings, ElementKind};
use crate::kinematics::RobotModel;
use crate::symmetry::finite::SignedPermutation;
use crate::symmetry::transfer::descend::{sample_within_limits, SplitMix64};

/// Verifies `(O, ρ)`; when it fails and some paired joints lead mimic joints, tries the
/// opposite sign on each such pair and keeps the flips that lower the residual.
pub(super) fn refine_mimic_signs(
    st: &Structure,
    model: &RobotModel,
    o: &Matrix3<f64>,
    mut rho: SignedPermutation,
    settings: &BodySettings,
) -> (SignedPermutation, BodyElement) {
    let mut el = verify(st, model, o, &rho, settings);
    if el.within(settings.residual_tolerance) {
        return (rho, el);
    }
    for i in (0..rho.dim()).filter(|&i| st.leads_mimic[i]) {
        let k = rho.perm[i];
        if k < i && st.leads_mimic[k] {
            continue; // the pair was tried from k
        }
        let mut flipped = rho.clone();
        flipped.signs[i] = -flipped.signs[i];
        if k != i {
            flipped.signs[k] = -flipped.signs[k];
        }
        let e = verify(st, model, o, &flipped, settings);
        if e.relative_residual.max(e.orientation_residual)
            < el.relative_residual.max(el.orientation_residual)
        {
            rho = flipped;
            el = e;
        }
    }
    (rho, el)
}

/// A link `s` of the tree paired at `q = 0` with link `m` of the image body, and the
/// constant body reflection `E = R_s(0)ᵀ O R_m(0)`.
type LinkPair = (usize, usize, Matrix3<f64>);

/// Worst residuals over the samples of one element.
struct Residuals {
    /// Worst position residual over links and axis lines (m).
    position: f64,
    /// Worst entry of `R_M(ρq) − O R_L(q) E_L`.
    orientation: f64,
    /// Where the worst residual relative to the size occurs.
    worst: String,
}

/// Verifies `(O, ρ)` on sampled configurations: axis lines of every joint and poses of every
/// link paired at `q = 0`.
pub(super) fn verify(
    st: &Structure,
    model: &RobotModel,
    o: &Matrix3<f64>,
    rho: &SignedPermutation,
    settings: &BodySettings,
) -> BodyElement {
    let tree = &st.tree;
    // Joint of q that each joint's value moves to: q_i lands on slot π(i) with ρ's inverse.
    let inv = rho.inverse();
    let (link_pairs, unmatched) = pair_links(st, model, o, &inv, settings);
    let residuals = sampled_residuals(st, model, o, rho, &inv, &link_pairs, settings);
    let limit_mismatches = limit_mismatches(st, &inv, settings);
    BodyElement {
        kind: classify(o),
        space: *o,
        rho_q: rho.clone(),
        link_pairs: link_pairs
            .iter()
            .map(|&(s, m, _)| {
                (
                    model.links[tree.links[s].link].clone(),
                    model.links[tree.links[m].link].clone(),
                )
            })
            .collect(),
        unmatched_links: unmatched,
        relative_residual: residuals.position / st.size,
        orientation_residual: residuals.orientation,
        worst: residuals.worst,
        limit_mismatches,
    }
}

/// Link pairs at `q = 0`: each link with the link of its image body at its mirrored origin
/// (itself on a tie); and the names of the links without one (ignored links left out).
fn pair_links(
    st: &Structure,
    model: &RobotModel,
    o: &Matrix3<f64>,
    inv: &SignedPermutation,
    settings: &BodySettings,
) -> (Vec<LinkPair>, Vec<String>) {
    let tree = &st.tree;
    let mut wa = tree.workspace();
    let zero = vec![0.0; inv.dim()];
    tree.forward(&zero, &mut wa);
    let tol = settings.position_tolerance * st.size;
    // Link pairs at q = 0: same image body, mirrored origin.
    let mut link_pairs = Vec::new();
    let mut unmatched = Vec::new();
    for (s, l) in tree.links.iter().enumerate() {
        let body = st.owner[s].map(|i| inv.perm[i]);
        let target = o * wa.poses[s].translation.vector;
        // The nearest link of the image body within the tolerance (itself on a tie).
        let gap = |m: usize| (wa.poses[m].translation.vector - target).norm();
        let m = (0..tree.links.len())
            .filter(|&m| st.owner[m] == body && gap(m) <= tol)
            .min_by(|&a, &b| gap(a).total_cmp(&gap(b)).then((a != s).cmp(&(b != s))));
        match m {
            Some(m) => {
                let e =
                    wa.poses[s].rotation.matrix().transpose() * o * wa.poses[m].rotation.matrix();
                link_pairs.push((s, m, e));
            }
            None => {
                let name = &model.links[l.link];
                if !settings.ignore_links.contains(name) {
                    unmatched.push(name.clone());
                }
            }
        }
    }
    (link_pairs, unmatched)
}

/// The worst residuals of `(O, ρ)` over the seeded samples: the paired links' positions and
/// orientations, and every joint's axis line and direction.
fn sampled_residuals(
    st: &Structure,
    model: &RobotModel,
    o: &Matrix3<f64>,
    rho: &SignedPermutation,
    inv: &SignedPermutation,
    link_pairs: &[LinkPair],
    settings: &BodySettings,
) -> Residuals {
    let n = rho.dim();
    let tree = &st.tree;
    let (mut wa, mut wb) = (tree.workspace(), tree.workspace());
    let mut rng = SplitMix64::new(settings.seed);
    let (mut q, mut q_img) = (vec![0.0; n], vec![0.0; n]);
    let mut lines = vec![(Vector3::zeros(), Vector3::zeros()); n];
    let mut lines_img = lines.clone();
    let (mut pos_res, mut rot_res) = (0.0_f64, 0.0_f64);
    let mut worst = (0.0_f64, String::new());
    let bad = |r: f64| if r.is_finite() { r } else { f64::INFINITY };
    let joint_name = |i: usize| {
        tree.links[st.child_slot[i]]
            .joint
            .as_ref()
            .map_or("?", |j| j.name.as_str())
    };
    for _ in 0..settings.samples {
        sample_within_limits(&st.limits, &mut rng, &mut q);
        rho.apply(&q, &mut q_img);
        tree.forward(&q, &mut wa);
        tree.forward(&q_img, &mut wb);
        for &(s, m, e) in link_pairs {
            let (a, b) = (&wa.poses[s], &wb.poses[m]);
            let r = bad((b.translation.vector - o * a.translation.vector).norm());
            let rr = bad((b.rotation.matrix() - o * a.rotation.matrix() * e).amax());
            if r / st.size > worst.0 || rr > worst.0 {
                worst = (
                    (r / st.size).max(rr),
                    format!("link `{}`", model.links[tree.links[s].link]),
                );
            }
            pos_res = pos_res.max(r);
            rot_res = rot_res.max(rr);
        }
        axis_lines(st, &wa, &mut lines);
        axis_lines(st, &wb, &mut lines_img);
        for i in 0..n {
            let k = inv.perm[i];
            let (p, z) = lines[i];
            let (pk, zk) = lines_img[k];
            let d = mapped_direction(o, &z, st.prismatic[i]);
            // The sign of a joint leading mimic joints may follow its mirrored follower
            // rather than its own axis: only the line is checked there.
            let dir = if st.leads_mimic[i] {
                (d - zk).norm().min((d + zk).norm())
            } else {
                (d - inv.signs[i] * zk).norm()
            };
            let off = bad((o * p - pk).cross(&zk).norm()).max(bad(dir * st.size));
            if off / st.size > worst.0 {
                worst = (off / st.size, format!("axis of joint `{}`", joint_name(i)));
            }
            pos_res = pos_res.max(off);
        }
    }
    Residuals {
        position: pos_res,
        orientation: rot_res,
        worst: worst.1,
    }
}

/// The joint pairs of `ρ` (inverse `inv`) whose limits do not map into each other, each
/// pair once (`i ≤` its image), joints on themselves included.
fn limit_mismatches(
    st: &Structure,
    inv: &SignedPermutation,
    settings: &BodySettings,
) -> Vec<LimitMismatch> {
    let tree = &st.tree;
    (0..inv.dim())
        .filter(|&i| i <= inv.perm[i])
        .filter_map(|i| {
            let (k, s) = (inv.perm[i], inv.signs[i]);
            let (li, lk) = (st.limits[i], st.limits[k]);
            let expected = if s > 0.0 {
                [lk.lower, lk.upper]
            } else {
                [-lk.upper, -lk.lower]
            };
            let close = |x: f64, y: f64| x == y || (x - y).abs() <= settings.limit_tolerance;
            let name = |j: usize| {
                tree.links[st.child_slot[j]]
                    .joint
                    .as_ref()
                    .map_or(String::new(), |j| j.name.clone())
            };
            (!(close(li.lower, expected[0]) && close(li.upper, expected[1]))).then(|| {
                LimitMismatch {
                    joint_a: name(i),
                    joint_b: name(k),
                    sign: s,
                    limits_a: [li.lower, li.upper],
                    limits_b: [lk.lower, lk.upper],
                    expected_a: expected,
                }
            })
        })
        .collect()
}

/// Identity, reflection (normal), rotation (axis, angle) or rotoreflection.
fn classify(o: &Matrix3<f64>) -> ElementKind {
    if (o - Matrix3::identity()).amax() < 1e-9 {
        return ElementKind::Identity;
    }
    if o.determinant() < 0.0 {
        // A reflection is symmetric with eigenvalues (−1, 1, 1): I − O = 2nnᵀ.
        let m = (Matrix3::identity() - o) * 0.5;
        if (o - o.transpose()).amax() < 1e-9 && (m.trace() - 1.0).abs() < 1e-9 {
            let c = (0..3)
                .max_by(|&a, &b| m.column(a).norm().total_cmp(&m.column(b).norm()))
                .unwrap_or(0);
            let mut n = m.column(c).normalize();
            if n.iter().find(|x| x.abs() > 1e-12).is_some_and(|x| *x < 0.0) {
                n = -n;
            }
            return ElementKind::Reflection { normal: n };
        }
        return ElementKind::Rotoreflection;
    }
    let angle = ((o.trace() - 1.0) / 2.0).clamp(-1.0, 1.0).acos();
    let axis = if std::f64::consts::PI - angle < 1e-6 {
        // R = 2aaᵀ − I at angle π: the axis is the largest column of (R + I)/2.
        let m = (o + Matrix3::identity()) * 0.5;
        let c = (0..3)
            .max_by(|&a, &b| m.column(a).norm().total_cmp(&m.column(b).norm()))
            .unwrap_or(0);
        m.column(c).normalize()
    } else {
        match Rotation3::from_matrix_unchecked(*o).axis() {
            Some(a) => a.into_inner(),
            None => return ElementKind::Identity,
        }
    };
    let mut a = axis;
    // At π the sense is irrelevant: the axis is written with its first non-zero entry positive.
    if std::f64::consts::PI - angle < 1e-6
        && a.iter().find(|x| x.abs() > 1e-12).is_some_and(|x| *x < 0.0)
    {
        a = -a;
    }
    ElementKind::Rotation { axis: a, angle }
}
