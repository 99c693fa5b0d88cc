//! Morphological symmetry derived from the robot description (paper eqs. 4, 9; Example 1).
//!
//! Two serial chains `a`, `b` of equal DoF sharing a base frame are mirror images across
//! the plane through the base origin with unit normal `n` when, for the reflection
//! `S = I − 2nnᵀ` and a signed permutation `P` of joints,
//!
//! `f_a(P q_b) = P_X f_b(q_b)  ∀ q_b`,
//!
//! with `P_X` the restriction of `S` to the task coordinates (Example 1: RB-Y1,
//! `P = diag(1, −1, −1, 1, −1, 1, −1)`, `P_X = diag(1, −1, 1)`). The action on the stacked
//! configuration is then `ρ_Q = [[0, P], [P⁻¹, 0]]` (eq. 4) and the descended task action
//! `ρ_X = [[0, P_X], [P_X, 0]]` (eq. 9). MorphoSymm (Ordoñez-Apraez et al.) needs `P`
//! written by hand; here it is read off the kinematic model:
//!
//! 1. at `q = 0`, every joint's world origin `p_i` and axis `z_i` is computed in both chains;
//! 2. joint `i` of `a` is paired with joint `j` of `b` of the same type whose mirrored axis
//!    line matches: for a revolute joint the line through `S p_j` (distance ≤ tolerance) with
//!    direction `−S z_j` — a rotation axis is an axial vector, so under a reflection it maps
//!    to `det(S) S z = −S z` — and for a prismatic joint the point `S p_j` with the polar
//!    direction `+S z_j`; the mirrored direction equals `±z_i`, which is the sign `P_ij`;
//! 3. several candidates (e.g. collinear axes at `q = 0`) are resolved by index order; a
//!    joint without candidates falls back to index order and makes the pairing inconsistent;
//! 4. distances are relative to the chains' size (the farthest joint origin or tip from
//!    the base at `q = 0`), so a URDF mirrored to 10 µm on a 1 m robot passes at the default
//!    `1e-4`, and the residual is reported both in metres and relative;
//! 5. the relation is verified on seeded samples inside the joint limits, both ways
//!    (`f_a(P q_b)` vs `P_X f_b(q_b)` and `f_b(P⁻¹ q_a)` vs `P_X f_a(q_a)`), together with the
//!    tip orientation `R_a(P q_b) = S R_b(q_b) E` for the constant tool-frame reflection
//!    `E = R_b(0)ᵀ S R_a(0)`;
//! 6. joint limits must map consistently: `[lo_a, hi_a] = [lo_b, hi_b]` for `P_ij = +1` and
//!    `[−hi_b, −lo_b]` for `P_ij = −1`; every mismatch is reported (not an error).
//!
//! Joint types are detected from the chain itself: a joint is revolute when moving it
//! rotates the tip.

use std::fmt;

use nalgebra::{Matrix3, Vector3};

use crate::kinematics::{Chain, ChainWorkspace, Kinematics, TaskSpace};
use crate::symmetry::finite::SignedPermutation;
use crate::symmetry::transfer::descend::{sample_within_limits, SplitMix64};

/// Settings of the derivation and its numerical verification.
#[derive(Debug, Clone, PartialEq)]
pub struct MorphoSettings {
    /// Samples per direction of the verification.
    pub samples: usize,
    /// Seed of the sampler (runs are deterministic).
    pub seed: u64,
    /// Largest distance between a mirrored joint axis line (or prismatic origin) and its
    /// partner, relative to the chains' size (dimensionless; see [`MorphoReport::size`]).
    pub position_tolerance: f64,
    /// Largest distance between a mirrored unit axis and `±` its partner's.
    pub axis_tolerance: f64,
    /// Largest difference of mapped joint limits counted as consistent (rad or m).
    pub limit_tolerance: f64,
    /// Largest verification residual counted as a symmetry, relative to the chains' size
    /// (dimensionless).
    pub residual_tolerance: f64,
}

impl Default for MorphoSettings {
    fn default() -> Self {
        Self {
            samples: 256,
            seed: 0x3a3a_0f0f,
            position_tolerance: 1e-4,
            axis_tolerance: 1e-4,
            limit_tolerance: 1e-6,
            residual_tolerance: 1e-4,
        }
    }
}

/// Outcome of the derivation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum MorphoStatus {
    /// Every joint was paired geometrically and the relation holds on all samples.
    Symmetric,
    /// Some joints have no mirrored counterpart (see [`MorphoReport::unmatched`]).
    NoConsistentPairing,
    /// The pairing is complete but the sampled residual exceeds the tolerance.
    ResidualTooLarge,
}

/// A pair of joints whose limits do not map into each other under `P`.
#[derive(Debug, Clone, PartialEq)]
pub struct LimitMismatch {
    /// Joint of chain `a`.
    pub joint_a: String,
    /// Its partner in chain `b`.
    pub joint_b: String,
    /// Sign `P_ij` of the pair.
    pub sign: f64,
    /// `[lo_a, hi_a]` (rad or m).
    pub limits_a: [f64; 2],
    /// `[lo_b, hi_b]` (rad or m).
    pub limits_b: [f64; 2],
    /// What `[lo_a, hi_a]` should be: `[lo_b, hi_b]` or `[−hi_b, −lo_b]` (rad or m).
    pub expected_a: [f64; 2],
}

impl fmt::Display for LimitMismatch {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} [{}, {}] vs {} [{}, {}] (sign {:+}: expected [{}, {}])",
            self.joint_a,
            self.limits_a[0],
            self.limits_a[1],
            self.joint_b,
            self.limits_b[0],
            self.limits_b[1],
            self.sign,
            self.expected_a[0],
            self.expected_a[1]
        )
    }
}

/// The derived morphological symmetry of two chains and its verification.
#[derive(Debug, Clone, PartialEq)]
pub struct MorphoReport {
    /// Name of chain `a`.
    pub chain_a: String,
    /// Name of chain `b`.
    pub chain_b: String,
    /// Unit normal `n` of the reflection plane (base frame).
    pub normal: Vector3<f64>,
    /// Whether the chains are mirror images.
    pub status: MorphoStatus,
    /// `(i, j, s)`: joint `i` of `a` ↔ joint `j` of `b` with sign `s` (`(ρ_Q q)_{a,i} = s q_{b,j}`).
    pub pairing: Vec<(usize, usize, f64)>,
    /// Signs of `P` indexed by joint of `a` (`P = diag(p_signs)` for an index-order pairing).
    pub p_signs: Vec<f64>,
    /// `P` as a signed permutation of chain joints: `(P q_b)_i = s_i q_{b,π(i)}`.
    pub p: SignedPermutation,
    /// `P_X`: the reflection restricted to the chains' task coordinates.
    pub p_x: SignedPermutation,
    /// `ρ_Q = [[0, P], [P⁻¹, 0]]` on the stacked `q` (other chains, if any, fixed).
    pub rho_q: SignedPermutation,
    /// `ρ_X = [[0, P_X], [P_X, 0]]` on the stacked `x` (other chains, if any, fixed).
    pub rho_x: SignedPermutation,
    /// Joints of `a` without a mirrored counterpart (paired by index order as a fallback).
    pub unmatched: Vec<usize>,
    /// Joints of `a` with several mirrored candidates, resolved by index order.
    pub ambiguous: Vec<usize>,
    /// Worst task-point residual over both sampled directions (task units, m).
    pub max_residual: f64,
    /// Size of the chains: the largest distance of a joint origin or tip from the base at
    /// `q = 0` (m). Tolerances are relative to it.
    pub size: f64,
    /// `max_residual / size` (dimensionless).
    pub relative_residual: f64,
    /// Worst entry of `R_a(P q_b) − S R_b(q_b) E` over both directions (dimensionless).
    pub orientation_residual: f64,
    /// Pairs whose joint limits do not map into each other under `P`.
    pub limit_mismatches: Vec<LimitMismatch>,
    /// Samples per direction.
    pub samples: usize,
}

impl MorphoReport {
    /// True for [`MorphoStatus::Symmetric`].
    pub fn is_symmetric(&self) -> bool {
        self.status == MorphoStatus::Symmetric
    }
}

/// Invalid inputs to [`derive_morphological`].
#[derive(Debug, Clone, thiserror::Error)]
#[non_exhaustive]
pub enum MorphoError {
    /// A chain index is out of range.
    #[error("chain index {index} is out of range: the robot has {chains} chains")]
    ChainIndex {
        /// Offending index.
        index: usize,
        /// Number of chains.
        chains: usize,
    },
    /// Both indices name the same chain.
    #[error("chain `{chain}` cannot be mirrored onto itself by a joint swap")]
    SameChain {
        /// Chain name.
        chain: String,
    },
    /// The chains differ in DoF, task space or base link.
    #[error("chains `{a}` and `{b}` are not interchangeable: {reason}")]
    NotInterchangeable {
        /// Chain `a`.
        a: String,
        /// Chain `b`.
        b: String,
        /// What differs.
        reason: String,
    },
    /// The normal is zero or not finite.
    #[error("reflection normal {normal:?} is not a non-zero finite vector")]
    InvalidNormal {
        /// The given normal.
        normal: [f64; 3],
    },
    /// The reflection does not act on the task coordinates as a signed permutation.
    #[error("reflection with normal {normal:?} is not a signed permutation of the {task:?} task coordinates")]
    NotASignedPermutation {
        /// Unit normal.
        normal: [f64; 3],
        /// Task space of the chains.
        task: TaskSpace,
    },
    /// No samples requested.
    #[error("the verification needs at least one sample")]
    NoSamples,
    /// The whole-body derivation cannot start (base link, joint selection, tree).
    #[error("whole-body derivation: {message}")]
    Body {
        /// What is wrong.
        message: String,
    },
}

/// Geometry of a chain's movable joints at `q = 0`.
struct JointGeometry {
    origins: Vec<Vector3<f64>>,
    axes: Vec<Vector3<f64>>,
    prismatic: Vec<bool>,
    tip_rotation: Matrix3<f64>,
    tip_position: Vector3<f64>,
}

fn joint_geometry(chain: &Chain, ws: &mut ChainWorkspace) -> JointGeometry {
    let k = chain.dof();
    let mut q = vec![0.0; k];
    let t0 = *chain.forward(&q, ws);
    let r0 = t0.rotation;
    let origins = (0..k).map(|i| ws.joint_origin(i)).collect();
    let axes = (0..k).map(|i| ws.joint_axis(i)).collect();
    let prismatic = (0..k)
        .map(|i| {
            q[i] = 0.5;
            let r = chain.forward(&q, ws).rotation;
            q[i] = 0.0;
            (r0.inverse() * r).angle() < 1e-9
        })
        .collect();
    JointGeometry {
        origins,
        axes,
        prismatic,
        tip_rotation: *r0.matrix(),
        tip_position: t0.translation.vector,
    }
}

/// The largest distance from the base of a joint origin or tip at `q = 0` (m); 1 when all
/// of them sit at the base.
fn chains_size(ga: &JointGeometry, gb: &JointGeometry) -> f64 {
    let size = [ga, gb]
        .iter()
        .flat_map(|g| g.origins.iter().chain(std::iter::once(&g.tip_position)))
        .map(|p| p.norm())
        .fold(0.0, f64::max);
    if size > 0.0 && size.is_finite() {
        size
    } else {
        1.0
    }
}

/// Derives `P`, `P_X`, `ρ_Q`, `ρ_X` mirroring chain `b` onto chain `a` of `kin` across the
/// plane through the base origin with normal `normal` (base frame), and verifies them.
pub fn derive_morphological(
    kin: &Kinematics,
    a: usize,
    b: usize,
    normal: Vector3<f64>,
    settings: &MorphoSettings,
) -> Result<MorphoReport, MorphoError> {
    check_interchangeable(kin, a, b, settings)?;
    let chains = kin.chains();
    let (ca, cb) = (&chains[a], &chains[b]);
    let norm = normal.norm();
    if !norm.is_finite() || norm == 0.0 {
        return Err(MorphoError::InvalidNormal {
            normal: normal.into(),
        });
    }
    let n = normal / norm;
    let s = Matrix3::identity() - 2.0 * n * n.transpose();
    let d = ca.task.dim();
    let p_x = task_reflection(&s, d).ok_or(MorphoError::NotASignedPermutation {
        normal: n.into(),
        task: ca.task,
    })?;

    // 1–3: geometric pairing at q = 0.
    let (mut wa, mut wb) = (ca.workspace(), cb.workspace());
    let ga = joint_geometry(ca, &mut wa);
    let gb = joint_geometry(cb, &mut wb);
    let size = chains_size(&ga, &gb);
    let Pairing {
        pairing,
        unmatched,
        ambiguous,
    } = pair_chains(&ga, &gb, &s, settings.position_tolerance * size, settings);
    let p = SignedPermutation::new(
        pairing.iter().map(|&(_, j, _)| j).collect(),
        pairing.iter().map(|&(_, _, sign)| sign).collect(),
    )
    .expect("the pairing is a bijection");
    let (rho_q, rho_x) = stacked_actions(kin, a, b, &pairing, &p_x);

    // 4: verification in both directions.
    let e = gb.tip_rotation.transpose() * s * ga.tip_rotation;
    let (max_residual, orientation_residual) =
        verify_both_ways([(ca, &mut wa), (cb, &mut wb)], &p, &s, e, d, settings);

    // 5: joint limits.
    let limit_mismatches = limit_mismatches(ca, cb, &pairing, settings);

    let status = if !unmatched.is_empty() {
        MorphoStatus::NoConsistentPairing
    } else if max_residual > settings.residual_tolerance * size {
        MorphoStatus::ResidualTooLarge
    } else {
        MorphoStatus::Symmetric
    };
    Ok(MorphoReport {
        chain_a: ca.name.clone(),
        chain_b: cb.name.clone(),
        normal: n,
        status,
        p_signs: p.signs.clone(),
        pairing,
        p,
        p_x,
        rho_q,
        rho_x,
        unmatched,
        ambiguous,
        max_residual,
        size,
        relative_residual: max_residual / size,
        orientation_residual,
        limit_mismatches,
        samples: settings.samples,
    })
}

/// Checks that chains `a` and `b` exist, differ and can be swapped (same DoF, task space
/// and base link), and that the verification has samples.
fn check_interchangeable(
    kin: &Kinematics,
    a: usize,
    b: usize,
    settings: &MorphoSettings,
) -> Result<(), MorphoError> {
    let chains = kin.chains();
    for index in [a, b] {
        if index >= chains.len() {
            return Err(MorphoError::ChainIndex {
                index,
                chains: chains.len(),
            });
        }
    }
    let (ca, cb) = (&chains[a], &chains[b]);
    if a == b {
        return Err(MorphoError::SameChain {
            chain: ca.name.clone(),
        });
    }
    let differ = |reason: String| MorphoError::NotInterchangeable {
        a: ca.name.clone(),
        b: cb.name.clone(),
        reason,
    };
    if ca.dof() != cb.dof() {
        return Err(differ(format!("{} vs {} joints", ca.dof(), cb.dof())));
    }
    if ca.task != cb.task {
        return Err(differ(format!(
            "task spaces {:?} vs {:?}",
            ca.task, cb.task
        )));
    }
    if ca.base != cb.base {
        return Err(differ(format!("base links `{}` vs `{}`", ca.base, cb.base)));
    }
    if settings.samples == 0 {
        return Err(MorphoError::NoSamples);
    }
    Ok(())
}

/// The joint pairing of two chains: `(i, j, s)` per joint `i` of `a`, and the joints of `a`
/// without a mirrored counterpart or with several.
struct Pairing {
    pairing: Vec<(usize, usize, f64)>,
    unmatched: Vec<usize>,
    ambiguous: Vec<usize>,
}

/// Where `S` sends joint `j`'s axis direction: `−S z` for a rotation (axial vector), `S z`
/// for a translation.
fn mirrored_axis(g: &JointGeometry, s: &Matrix3<f64>, j: usize) -> Vector3<f64> {
    let m = s * g.axes[j];
    if g.prismatic[j] {
        m
    } else {
        -m
    }
}

/// Steps 1–3: pairs every joint of `a` with a joint of `b` whose mirrored axis line matches
/// (within `position_tolerance` in m), unique candidates first, then ambiguous ones, then
/// the unmatched by index order.
fn pair_chains(
    ga: &JointGeometry,
    gb: &JointGeometry,
    s: &Matrix3<f64>,
    position_tolerance: f64,
    settings: &MorphoSettings,
) -> Pairing {
    let k = ga.origins.len();
    let candidates = axis_candidates(ga, gb, s, position_tolerance, settings);
    let mut chosen: Vec<Option<(usize, f64)>> = vec![None; k];
    let mut used = vec![false; k];
    for i in 0..k {
        if let [(j, sign)] = candidates[i][..] {
            if !used[j] {
                chosen[i] = Some((j, sign));
                used[j] = true;
            }
        }
    }
    let mut ambiguous = Vec::new();
    for i in 0..k {
        if candidates[i].len() > 1 {
            ambiguous.push(i);
            let pick = candidates[i]
                .iter()
                .find(|&&(j, _)| j == i && !used[j])
                .or_else(|| candidates[i].iter().find(|&&(j, _)| !used[j]));
            if let Some(&(j, sign)) = pick {
                chosen[i] = Some((j, sign));
                used[j] = true;
            }
        }
    }
    let unmatched = pair_unmatched(ga, gb, s, &mut chosen, &mut used);
    let pairing = chosen
        .iter()
        .enumerate()
        .map(|(i, c)| {
            let (j, sign) = c.expect("every joint is paired");
            (i, j, sign)
        })
        .collect();
    Pairing {
        pairing,
        unmatched,
        ambiguous,
    }
}

/// Step 1: per joint `i` of `a`, the joints `j` of `b` of its kind whose mirrored axis line
/// matches `i`'s (within `position_tolerance` in m), with the sign.
fn axis_candidates(
    ga: &JointGeometry,
    gb: &JointGeometry,
    s: &Matrix3<f64>,
    position_tolerance: f64,
    settings: &MorphoSettings,
) -> Vec<Vec<(usize, f64)>> {
    let k = ga.origins.len();
    (0..k)
        .map(|i| {
            (0..k)
                .filter(|&j| ga.prismatic[i] == gb.prismatic[j])
                .filter(|&j| {
                    let gap = s * gb.origins[j] - ga.origins[i];
                    let dist = if ga.prismatic[i] {
                        gap.norm()
                    } else {
                        gap.cross(&ga.axes[i]).norm()
                    };
                    dist <= position_tolerance
                })
                .filter_map(|j| {
                    let m = mirrored_axis(gb, s, j);
                    if (m - ga.axes[i]).norm() <= settings.axis_tolerance {
                        Some((j, 1.0))
                    } else if (m + ga.axes[i]).norm() <= settings.axis_tolerance {
                        Some((j, -1.0))
                    } else {
                        None
                    }
                })
                .collect()
        })
        .collect()
}

/// Step 3: pairs the joints still without a partner, by index order; returns them.
fn pair_unmatched(
    ga: &JointGeometry,
    gb: &JointGeometry,
    s: &Matrix3<f64>,
    chosen: &mut [Option<(usize, f64)>],
    used: &mut [bool],
) -> Vec<usize> {
    let k = ga.origins.len();
    let mut unmatched = Vec::new();
    for i in 0..k {
        if chosen[i].is_none() {
            unmatched.push(i);
            let j = if used[i] {
                (0..k).find(|&j| !used[j]).expect("a free partner remains")
            } else {
                i
            };
            let sign = if mirrored_axis(gb, s, j).dot(&ga.axes[i]) < 0.0 {
                -1.0
            } else {
                1.0
            };
            chosen[i] = Some((j, sign));
            used[j] = true;
        }
    }
    unmatched
}

/// `ρ_Q = [[0, P], [P⁻¹, 0]]` and `ρ_X = [[0, P_X], [P_X⁻¹, 0]]` on the stacked `q` and `x`
/// of `kin` (other chains fixed).
fn stacked_actions(
    kin: &Kinematics,
    a: usize,
    b: usize,
    pairing: &[(usize, usize, f64)],
    p_x: &SignedPermutation,
) -> (SignedPermutation, SignedPermutation) {
    let (qa, qb) = (kin.q_offset(a), kin.q_offset(b));
    let mut rho_q = SignedPermutation::identity(kin.dof());
    for &(i, j, sign) in pairing {
        rho_q.perm[qa + i] = qb + j;
        rho_q.signs[qa + i] = sign;
        rho_q.perm[qb + j] = qa + i;
        rho_q.signs[qb + j] = sign;
    }
    let (xa, xb) = (kin.x_offset(a), kin.x_offset(b));
    let p_x_inv = p_x.inverse();
    let mut rho_x = SignedPermutation::identity(kin.task_dim());
    for r in 0..p_x.dim() {
        rho_x.perm[xa + r] = xb + p_x.perm[r];
        rho_x.signs[xa + r] = p_x.signs[r];
        rho_x.perm[xb + r] = xa + p_x_inv.perm[r];
        rho_x.signs[xb + r] = p_x_inv.signs[r];
    }
    (rho_q, rho_x)
}

/// Step 4: the worst task-point residual over the first `d` coordinates (m) and the worst
/// orientation residual of `f_a(P q_b) = S f_b(q_b)` (tip `R_a = S R_b E`) and
/// `f_b(P⁻¹ q_a) = S f_a(q_a)` (`R_b = S R_a Eᵀ`) on seeded samples inside the limits.
fn verify_both_ways(
    [(ca, wa), (cb, wb)]: [(&Chain, &mut ChainWorkspace); 2],
    p: &SignedPermutation,
    s: &Matrix3<f64>,
    e: Matrix3<f64>,
    d: usize,
    settings: &MorphoSettings,
) -> (f64, f64) {
    let p_inv = p.inverse();
    let k = ca.dof();
    let mut rng = SplitMix64::new(settings.seed);
    let (mut q_src, mut q_img) = (vec![0.0; k], vec![0.0; k]);
    let (mut max_residual, mut orientation_residual) = (0.0_f64, 0.0_f64);
    // Target chain, source chain, map on joints, body reflection on the target side.
    for a_is_target in [true, false] {
        let (tgt, wt, src, wsrc, map, body) = if a_is_target {
            (ca, &mut *wa, cb, &mut *wb, p, e)
        } else {
            (cb, &mut *wb, ca, &mut *wa, &p_inv, e.transpose())
        };
        for _ in 0..settings.samples {
            sample_within_limits(&src.limits, &mut rng, &mut q_src);
            map.apply(&q_src, &mut q_img);
            let t_img = *tgt.forward(&q_img, wt);
            let t_src = *src.forward(&q_src, wsrc);
            let gap = t_img.translation.vector - s * t_src.translation.vector;
            let r = gap.rows(0, d).norm();
            max_residual = max_residual.max(if r.is_finite() { r } else { f64::INFINITY });
            let rot = t_img.rotation.matrix() - s * t_src.rotation.matrix() * body;
            orientation_residual = orientation_residual.max(rot.amax());
        }
    }
    (max_residual, orientation_residual)
}

/// Step 5: the pairs whose joint limits do not map into each other under their sign.
fn limit_mismatches(
    ca: &Chain,
    cb: &Chain,
    pairing: &[(usize, usize, f64)],
    settings: &MorphoSettings,
) -> Vec<LimitMismatch> {
    pairing
        .iter()
        .filter_map(|&(i, j, sign)| {
            let (la, lb) = (ca.limits[i], cb.limits[j]);
            let expected = if sign > 0.0 {
                [lb.lower, lb.upper]
            } else {
                [-lb.upper, -lb.lower]
            };
            let close = |x: f64, y: f64| x == y || (x - y).abs() <= settings.limit_tolerance;
            (!(close(la.lower, expected[0]) && close(la.upper, expected[1]))).then(|| {
                LimitMismatch {
                    joint_a: ca.joint_names[i].clone(),
                    joint_b: cb.joint_names[j].clone(),
                    sign,
                    limits_a: [la.lower, la.upper],
                    limits_b: [lb.lower, lb.upper],
                    expected_a: expected,
                }
            })
        })
        .collect()
}

/// `S` restricted to the first `d` coordinates, if it maps them onto themselves as a signed permutation.
fn task_reflection(s: &Matrix3<f64>, d: usize) -> Option<SignedPermutation> {
    const TOL: f64 = 1e-12;
    let mut perm = Vec::with_capacity(d);
    let mut signs = Vec::with_capacity(d);
    for r in 0..d {
        let mut hit = None;
        for c in 0..3 {
            let v = s[(r, c)];
            if v.abs() <= TOL {
                continue;
            }
            if c >= d || (v.abs() - 1.0).abs() > TOL || hit.is_some() {
                return None;
            }
            hit = Some((c, v.signum()));
        }
        let (c, sign) = hit?;
        perm.push(c);
        signs.push(sign);
    }
    SignedPermutation::new(perm, signs).ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn task_reflection_restricts_axis_aligned_planes_only() {
        let refl = |n: Vector3<f64>| Matrix3::identity() - 2.0 * n * n.transpose();
        let y = task_reflection(&refl(Vector3::y()), 3).unwrap();
        assert_eq!(y.signs, vec![1.0, -1.0, 1.0]);
        assert_eq!(
            task_reflection(&refl(Vector3::y()), 2).unwrap().signs,
            vec![1.0, -1.0]
        );
        let diag = Vector3::new(1.0, 1.0, 0.0).normalize();
        let sw = task_reflection(&refl(diag), 2).unwrap();
        assert_eq!((sw.perm, sw.signs), (vec![1, 0], vec![-1.0, -1.0]));
        assert!(task_reflection(&refl(Vector3::new(1.0, 2.0, 0.0).normalize()), 2).is_none());
        assert!(task_reflection(&refl(Vector3::new(0.0, 1.0, 1.0).normalize()), 2).is_none());
    }
}
