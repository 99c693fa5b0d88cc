//! `crossym check`: transfer every configured symmetry to the space where it is
//! composed, and test the paper's conditions numerically (Secs. IV–V).
//!
//! For each symmetry: morphological ones are derived from the URDF (Example 1) and
//! descended by testing FK equivariance (eq. 8); task-space Lie groups are lifted
//! (eq. 17) and their lifted actions tested for `f(Φ_Q(g, q)) = Φ_X(g, f(q))`, the
//! periodicity of SO(2) over 2π and, for multi-parameter groups, the bracket condition
//! (eq. 16). For each pair: direct product when the actions commute (eqs. 19–20),
//! semi-direct when the finite factor acts on the Lie factor by an automorphism (eq. 22),
//! otherwise incompatible. A pair is checked in `Q` when a finite symmetry acting on `Q` is
//! involved, and in `X` for two task-space groups, with the vertical part of their lifted
//! bracket reported alongside (it makes the lifted actions commute only up to a self-motion).

use std::cell::RefCell;
use std::f64::consts::TAU;

use nalgebra::Vector3;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

use super::built::BuiltSymmetry;
use super::compose::{self, ComposeTolerance, Composition};
use super::field::{VectorField, DEFAULT_FD_STEP};
use super::finite::SignedPermutation;
use super::lie::{AffineAction, LieGroupSpec, TaskGroupAction};
use super::spec::{CheckConfig, GroupSpec, SymmetryConfig};
use super::task_induced::{TaskInducedSettings, TaskInducedSymmetry};
use super::transfer::descend::{descend, DescendSettings};
use super::transfer::flow::FlowSettings;
use super::transfer::lift::{bracket_condition, periodicity_drift, LiftedAction, LiftedField};
use super::transfer::morpho::{
    derive_body_symmetries, derive_morphological, BodySettings, MorphoSettings,
};
use crate::kinematics::{Kinematics, PinvStatus};

/// One row of the symmetry table.
#[derive(Debug, Clone, PartialEq)]
pub struct SymmetryRow {
    /// Name.
    pub name: String,
    /// Group label.
    pub group: String,
    /// `Q` or `X`: where the symmetry is defined.
    pub acts_on: &'static str,
    /// How it was transferred, in words.
    pub transfer: String,
    /// Max equivariance residual `‖f(Φ_Q(g,q)) − Φ_X(g,f(q))‖` relative to the workspace size.
    pub equivariance: f64,
    /// SO(2) only: max joint drift after a 2π flow (rad).
    pub periodicity_drift: Option<f64>,
    /// Multi-parameter groups: max relative vertical component of lifted brackets (eq. 16).
    pub bracket_vertical: Option<f64>,
    /// Configurations where the lift hit a singularity.
    pub singular_samples: usize,
    /// Extra facts (P signs, limit mismatches, …).
    pub notes: Vec<String>,
    /// False when the transfer failed.
    pub ok: bool,
}

/// One row of the pair table.
#[derive(Debug, Clone, PartialEq)]
pub struct PairRow {
    /// First (outer) symmetry.
    pub a: String,
    /// Second (inner) symmetry.
    pub b: String,
    /// Space the pair was decided in.
    pub space: &'static str,
    /// The decision.
    pub composition: Composition,
    /// For two lifted groups: max relative vertical part of their lifted bracket in `Q`.
    pub lifted_vertical: Option<f64>,
    /// True when both symmetries are listed in `[composition] order` (i.e. requested).
    pub requested: bool,
}

/// The whole report.
#[derive(Debug, Clone, PartialEq)]
pub struct CheckReport {
    /// Robot name.
    pub robot: String,
    /// Configurations actually used (non-singular).
    pub samples: usize,
    /// Symmetry rows.
    pub symmetries: Vec<SymmetryRow>,
    /// Pair rows.
    pub pairs: Vec<PairRow>,
}

impl CheckReport {
    /// The composed group as an expression, built inner → outer from the pair decisions:
    /// `(R × S) ⋊ M` for the letter task. `None` when some requested pair is incompatible.
    pub fn group_expression(&self, order: &[String]) -> Option<String> {
        let pair = |a: &str, b: &str| {
            self.pairs
                .iter()
                .find(|p| (p.a == a && p.b == b) || (p.a == b && p.b == a))
                .map(|p| &p.composition)
        };
        let (last, rest) = order.split_last()?;
        let mut expr = last.clone();
        let mut inner = vec![last.as_str()];
        for outer in rest.iter().rev() {
            let kinds: Vec<&Composition> = inner.iter().filter_map(|i| pair(outer, i)).collect();
            if kinds.len() != inner.len()
                || kinds
                    .iter()
                    .any(|c| matches!(c, Composition::Incompatible { .. }))
            {
                return None;
            }
            let wrapped = if inner.len() > 1 {
                format!("({expr})")
            } else {
                expr.clone()
            };
            expr = if kinds
                .iter()
                .all(|c| matches!(c, Composition::Direct { .. }))
            {
                format!("{outer} × {wrapped}")
            } else {
                format!("{wrapped} ⋊ {outer}")
            };
            inner.push(outer);
        }
        Some(expr)
    }

    /// True when every symmetry transferred and no requested pair is incompatible.
    pub fn ok(&self) -> bool {
        self.symmetries.iter().all(|s| s.ok)
            && self
                .pairs
                .iter()
                .all(|p| !p.requested || !matches!(p.composition, Composition::Incompatible { .. }))
    }
}

/// Errors that stop the check before any numbers (bad configuration).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum CheckError {
    /// A symmetry entry is inconsistent with the robot or with itself.
    #[error("symmetry `{name}`: {message}")]
    Symmetry {
        /// Symmetry name.
        name: String,
        /// What is wrong.
        message: String,
    },
    /// `[composition]` or `[check]` is inconsistent.
    #[error("{message}")]
    Config {
        /// What is wrong.
        message: String,
    },
}

fn sym_err(name: &str, message: impl Into<String>) -> CheckError {
    CheckError::Symmetry {
        name: name.into(),
        message: message.into(),
    }
}

/// Sampled non-singular configurations around the reference (deterministic).
pub fn sample_configs(kin: &Kinematics, cfg: &CheckConfig) -> Result<Vec<Vec<f64>>, CheckError> {
    let n = kin.dof();
    let reference: Vec<f64> = match &cfg.reference_q {
        Some(r) if r.len() == n && r.iter().all(|v| v.is_finite()) => r.clone(),
        Some(r) => {
            return Err(CheckError::Config {
                message: format!(
                    "[check] reference_q has {} values, the robot has {n} joints",
                    r.len()
                ),
            })
        }
        None => kin.limits().iter().map(|l| l.centre()).collect(),
    };
    if cfg.samples == 0 || !(cfg.spread.is_finite() && cfg.spread >= 0.0) {
        return Err(CheckError::Config {
            message: "[check] samples must be positive and spread non-negative".into(),
        });
    }
    let mut rng = StdRng::seed_from_u64(cfg.seed);
    let mut ws = kin.workspace();
    let mut out = Vec::new();
    let mut tries = 0;
    while out.len() < cfg.samples && tries < cfg.samples * 20 {
        tries += 1;
        let q: Vec<f64> = reference
            .iter()
            .zip(kin.limits())
            .map(|(r, l)| (r + rng.random_range(-cfg.spread..=cfg.spread)).clamp(l.lower, l.upper))
            .collect();
        kin.jacobian(&q, &mut ws);
        if kin.factor(&mut ws).status == PinvStatus::Regular {
            out.push(q);
        }
    }
    if out.is_empty() {
        return Err(CheckError::Config {
            message: "[check] every sampled configuration is singular: set reference_q away from singularities".into(),
        });
    }
    Ok(out)
}

/// Test elements (exponential coordinates) of a Lie group for equivariance and commutation.
fn test_elements(spec: Option<&LieGroupSpec>, k: usize, cfg: &CheckConfig) -> Vec<Vec<f64>> {
    match spec {
        Some(LieGroupSpec::So2 { .. }) => cfg.rotation_test.iter().map(|t| vec![*t]).collect(),
        Some(LieGroupSpec::Scaling) => cfg.scaling_test.iter().map(|l| vec![l.ln()]).collect(),
        _ => {
            let s = cfg.generic_test;
            vec![
                (0..k).map(|i| s * (1.0 + 0.5 * i as f64)).collect(),
                (0..k).map(|i| -s * (0.7 + 0.3 * i as f64)).collect(),
            ]
        }
    }
}

/// The generator of the `k`-th basis element of a task-space group.
fn basis(action: &dyn TaskGroupAction, k: usize) -> Box<dyn VectorField + '_> {
    let mut xi = vec![0.0; action.algebra_dim()];
    xi[k] = 1.0;
    action.generator_field(&xi)
}

/// `ρ_Q` on the controlled joints of `kin` from the whole tree below the chains' common base,
/// across the plane with `normal`, and notes for the report.
fn whole_body_reflection(
    kin: &Kinematics,
    normal: [f64; 3],
) -> Result<(SignedPermutation, Vec<String>), String> {
    let chains = kin.chains();
    let base = &chains[0].base;
    if let Some(c) = chains.iter().find(|c| &c.base != base) {
        return Err(format!(
            "`whole_body` needs chains with one base: `{}` starts at `{}`, `{}` at `{}`",
            chains[0].name, base, c.name, c.base
        ));
    }
    let settings = BodySettings {
        planes: Some(vec![Vector3::from(normal)]),
        ..BodySettings::default()
    };
    let g = derive_body_symmetries(
        kin.model(),
        Some(base),
        Some(kin.joint_names()),
        kin.held(),
        &settings,
    )
    .map_err(|e| e.to_string())?;
    let Some(r) = g.reflections().first() else {
        let why = g
            .rejected
            .first()
            .map_or("no reason recorded".to_string(), |r| r.reason.clone());
        return Err(format!(
            "the plane with normal {normal:?} through `{base}` is not a symmetry of the tree: {why}"
        ));
    };
    let names = kin.joint_names();
    let own: Vec<String> = (0..names.len())
        .filter(|&i| r.rho_q.perm[i] == i)
        .map(|i| {
            format!(
                "{}{}",
                if r.rho_q.signs[i] < 0.0 { "−" } else { "+" },
                names[i]
            )
        })
        .collect();
    let mut notes = vec![format!(
        "ρ_Q derived from the whole tree below `{base}` ({} links mirrored, residual {:.1e} of {:.2} m)",
        r.link_pairs.len(),
        r.relative_residual,
        g.size
    )];
    // Two chains swapped joint by joint: the P of eq. 4 / Example 1.
    if let [a, b] = chains {
        let (oa, ob) = (kin.q_offset(0), kin.q_offset(1));
        if a.dof() == b.dof() && (0..a.dof()).all(|i| r.rho_q.perm[oa + i] == ob + i) {
            let p: Vec<i32> = (0..a.dof()).map(|i| r.rho_q.signs[oa + i] as i32).collect();
            notes.push(format!("P = diag{p:?}"));
        }
    }
    if !own.is_empty() {
        notes.push(format!("joints on the plane: {}", own.join(", ")));
    }
    if !r.limit_mismatches.is_empty() {
        notes.push(format!(
            "{} joint-limit pairs do not map consistently",
            r.limit_mismatches.len()
        ));
    }
    Ok((r.rho_q.clone(), notes))
}

/// Builds every configured symmetry for `kin`, deriving morphological ones from the URDF.
pub fn build(
    kin: &Kinematics,
    symmetries: &[SymmetryConfig],
) -> Result<(Vec<BuiltSymmetry>, Vec<SymmetryRow>), CheckError> {
    let mut built = Vec::new();
    let mut rows = Vec::new();
    for s in symmetries {
        if symmetries.iter().filter(|o| o.name == s.name).count() > 1 {
            return Err(sym_err(&s.name, "name used twice"));
        }
        let (b, row) = match &s.group {
            GroupSpec::Morphological {
                chains: pair,
                plane_normal,
                signs,
                whole_body,
            } => {
                let (rho_q, notes) = if *whole_body {
                    if pair.is_some() || signs.is_some() {
                        return Err(sym_err(
                            &s.name,
                            "`whole_body` derives ρ_Q on every controlled joint: drop `chains` and `signs`",
                        ));
                    }
                    whole_body_reflection(kin, plane_normal.unwrap_or([0.0, 1.0, 0.0]))
                        .map_err(|e| sym_err(&s.name, e))?
                } else {
                    chain_swap(kin, &s.name, pair.as_ref(), *plane_normal, signs.as_deref())?
                };
                build_finite(kin, &s.name, rho_q, notes)?
            }
            other => build_lie(kin, s, other)?,
        };
        rows.push(row);
        built.push(b);
    }
    Ok((built, rows))
}

/// `ρ_Q` of the swap of a two-chain robot's chains (in order) and notes for the report: `P`
/// from `signs` when given, else derived from the URDF across the plane with `plane_normal`
/// (default `y`).
fn chain_swap(
    kin: &Kinematics,
    name: &str,
    pair: Option<&[String; 2]>,
    plane_normal: Option<[f64; 3]>,
    signs: Option<&[f64]>,
) -> Result<(SignedPermutation, Vec<String>), CheckError> {
    let chains = kin.chains();
    let idx = |chain: &str| {
        chains
            .iter()
            .position(|c| c.name == chain)
            .ok_or_else(|| sym_err(name, format!("no chain `{chain}`")))
    };
    let (a, b) = match pair {
        Some([x, y]) => (idx(x)?, idx(y)?),
        None if chains.len() >= 2 => (0, 1),
        None => return Err(sym_err(name, "needs two chains")),
    };
    if chains.len() != 2 || (a, b) != (0, 1) {
        return Err(sym_err(
            name,
            "only the swap of a two-chain robot (chains in order) is supported",
        ));
    }
    if chains[0].dof() != chains[1].dof() {
        return Err(sym_err(
            name,
            "the two chains have different numbers of joints",
        ));
    }
    let mut notes = Vec::new();
    let rho_q = if let Some(p) = signs {
        if p.len() != chains[0].dof() || p.iter().any(|v| *v != 1.0 && *v != -1.0) {
            return Err(sym_err(
                name,
                format!("signs must be {} values of ±1", chains[0].dof()),
            ));
        }
        notes.push(format!(
            "P = diag{:?} (given)",
            p.iter().map(|v| *v as i32).collect::<Vec<_>>()
        ));
        SignedPermutation::block_swap(p)
    } else {
        let n = Vector3::from(plane_normal.unwrap_or([0.0, 1.0, 0.0]));
        let rep = derive_morphological(kin, a, b, n, &MorphoSettings::default())
            .map_err(|e| sym_err(name, e.to_string()))?;
        notes.push(format!(
            "P = diag{:?} derived from the URDF ({:?}, residual {:.1e} m, {:.1e} of the chains' size)",
            rep.p_signs.iter().map(|v| *v as i32).collect::<Vec<_>>(),
            rep.status,
            rep.max_residual,
            rep.relative_residual
        ));
        if !rep.limit_mismatches.is_empty() {
            notes.push(format!(
                "{} joint-limit pairs do not map consistently under P",
                rep.limit_mismatches.len()
            ));
        }
        rep.rho_q.clone()
    };
    Ok((rho_q, notes))
}

/// The finite symmetry `name` acting on `Q` by `rho_q`, descended to `X` by testing FK
/// equivariance (eq. 8), and its row.
fn build_finite(
    kin: &Kinematics,
    name: &str,
    rho_q: SignedPermutation,
    mut notes: Vec<String>,
) -> Result<(BuiltSymmetry, SymmetryRow), CheckError> {
    let d = descend(name, kin, &rho_q, &DescendSettings::default())
        .map_err(|e| sym_err(name, e.to_string()))?;
    let rho_x = d
        .task_action
        .as_ref()
        .and_then(|t| t.as_signed_permutation().cloned());
    if let Some(px) = &rho_x {
        let k = px.dim() / 2;
        notes.push(format!(
            "P_X = diag{:?}",
            px.signs[..k].iter().map(|v| *v as i32).collect::<Vec<_>>()
        ));
    }
    let row = SymmetryRow {
        name: name.into(),
        group: "C2".into(),
        acts_on: "Q",
        transfer: if d.descends() {
            "descended to X".into()
        } else {
            "does not descend".into()
        },
        equivariance: d.relative_residual,
        periodicity_drift: None,
        bracket_vertical: None,
        singular_samples: 0,
        notes,
        ok: d.descends(),
    };
    let built = BuiltSymmetry::Finite {
        name: name.into(),
        rho_q,
        rho_x,
    };
    Ok((built, row))
}

/// The continuous symmetry `s` of kind `group` acting on `X` (affine or task-induced), to be
/// lifted to `Q`, and its row.
fn build_lie(
    kin: &Kinematics,
    s: &SymmetryConfig,
    group: &GroupSpec,
) -> Result<(BuiltSymmetry, SymmetryRow), CheckError> {
    let chains = kin.chains();
    let dims: Vec<usize> = chains.iter().map(|c| c.task.dim()).collect();
    if dims.iter().any(|&d| d != dims[0]) {
        return Err(sym_err(
            &s.name,
            "chains have task spaces of different dimensions",
        ));
    }
    let mut notes = Vec::new();
    let mut ok = true;
    let (action, affine): (Box<dyn TaskGroupAction>, Option<LieGroupSpec>) = match group {
        GroupSpec::TaskInduced { cost } => {
            if s.center.is_some() {
                return Err(sym_err(
                    &s.name,
                    "`center` does not apply to task-induced symmetries",
                ));
            }
            let t = TaskInducedSymmetry::from_spec(
                &s.name,
                cost,
                dims[0],
                chains.len(),
                &TaskInducedSettings::default(),
            )
            .map_err(|e| sym_err(&s.name, e.to_string()))?;
            notes.push(format!("task-induced: {}", t.report().verdict()));
            ok = t.report().is_ok() || t.report().is_group();
            (Box::new(t), None)
        }
        _ => {
            let spec = group.lie().expect("continuous kinds have a Lie spec");
            let a = AffineAction::new(
                &s.name,
                spec.clone(),
                dims[0],
                chains.len(),
                s.center.as_deref(),
            )
            .map_err(|e| sym_err(&s.name, e.to_string()))?;
            (Box::new(a), Some(spec))
        }
    };
    let row = SymmetryRow {
        name: s.name.clone(),
        group: group.label().into(),
        acts_on: "X",
        transfer: "lifted to Q".into(),
        equivariance: 0.0,
        periodicity_drift: None,
        bracket_vertical: None,
        singular_samples: 0,
        notes,
        ok,
    };
    let built = BuiltSymmetry::Lie {
        name: s.name.clone(),
        action,
        affine,
    };
    Ok((built, row))
}

/// What every numerical test of the check shares: the robot, the sampled configurations,
/// the check's settings and the lifted flows' settings.
struct Probe<'a> {
    kin: &'a Kinematics,
    samples: &'a [Vec<f64>],
    cfg: &'a CheckConfig,
    flow: FlowSettings,
}

/// Runs the whole check (allocates; analysis).
pub fn check(
    kin: &Kinematics,
    symmetries: &[SymmetryConfig],
    order: &[String],
    cfg: &CheckConfig,
) -> Result<CheckReport, CheckError> {
    for name in order {
        if !symmetries.iter().any(|s| &s.name == name) {
            return Err(CheckError::Config {
                message: format!("[composition] order names unknown symmetry `{name}`"),
            });
        }
    }
    let samples = sample_configs(kin, cfg)?;
    let (built, mut rows) = build(kin, symmetries)?;
    let mut ws = kin.workspace();
    let size = samples
        .iter()
        .map(|q| kin.forward(q, &mut ws).amax())
        .fold(0.0f64, f64::max)
        .max(1e-12);
    let probe = Probe {
        kin,
        samples: &samples,
        cfg,
        flow: FlowSettings::default(),
    };
    // Lifted-action checks.
    for (b, row) in built.iter().zip(rows.iter_mut()) {
        if let BuiltSymmetry::Lie { action, affine, .. } = b {
            check_lifted(&probe, action.as_ref(), affine.as_ref(), size, row)?;
        }
    }
    // Pairs.
    let requested = |a: &str, b: &str| order.iter().any(|o| o == a) && order.iter().any(|o| o == b);
    let x_samples: Vec<Vec<f64>> = samples
        .iter()
        .map(|q| kin.forward(q, &mut ws).as_slice().to_vec())
        .collect();
    let mut pairs = Vec::new();
    for i in 0..built.len() {
        for j in i + 1..built.len() {
            let (a, b) = (&built[i], &built[j]);
            let mut row = pair_row(&probe, a, b, &x_samples)?;
            row.requested = requested(a.name(), b.name());
            pairs.push(row);
        }
    }
    Ok(CheckReport {
        robot: kin.robot.clone(),
        samples: samples.len(),
        symmetries: rows,
        pairs,
    })
}

/// Tests the lifted action of the task-space group `action` (`affine`: which affine group,
/// if any) into `row`: equivariance relative to the workspace `size`, singular lifts, the
/// drift of SO(2) after 2π and, for several parameters, the bracket condition (eq. 16).
fn check_lifted(
    probe: &Probe<'_>,
    action: &dyn TaskGroupAction,
    affine: Option<&LieGroupSpec>,
    size: f64,
    row: &mut SymmetryRow,
) -> Result<(), CheckError> {
    let (kin, samples, cfg) = (probe.kin, probe.samples, probe.cfg);
    let lifted = LiftedAction::new(kin, action, probe.flow)
        .map_err(|e| sym_err(action.name(), e.to_string()))?;
    let mut lws = lifted.workspace();
    let mut worst: f64 = 0.0;
    let mut singular = 0;
    for q in samples {
        for xi in test_elements(affine, action.algebra_dim(), cfg) {
            match lifted.equivariance_residual(&xi, q, &mut lws) {
                Ok(e) => worst = worst.max(e / size),
                Err(_) => singular += 1,
            }
        }
    }
    row.equivariance = worst;
    row.singular_samples = singular;
    row.ok &= worst <= 1e-6 && singular < samples.len();
    if let Some(LieGroupSpec::So2 { .. }) = affine {
        row.periodicity_drift = samples
            .iter()
            .take(6)
            .filter_map(|q| periodicity_drift(&lifted, &[TAU], q, &mut lws).ok())
            .reduce(f64::max);
    }
    if action.algebra_dim() > 1 {
        let mut vertical: f64 = 0.0;
        for i in 0..action.algebra_dim() {
            for j in i + 1..action.algebra_dim() {
                let (gi, gj) = (basis(action, i), basis(action, j));
                let rep = bracket_condition(kin, &gi, &gj, samples, DEFAULT_FD_STEP);
                vertical = vertical.max(rep.vertical_relative);
            }
        }
        row.bracket_vertical = Some(vertical);
    }
    if singular > 0 {
        row.notes
            .push(format!("{singular} lifts hit a singularity"));
    }
    Ok(())
}

/// The decision for the pair `(a, b)` (not yet marked requested): two finite symmetries
/// and a finite with a Lie one in `Q`, two Lie groups in `X` (`x_samples`: the sampled
/// configurations' task points).
fn pair_row(
    probe: &Probe<'_>,
    a: &BuiltSymmetry,
    b: &BuiltSymmetry,
    x_samples: &[Vec<f64>],
) -> Result<PairRow, CheckError> {
    let (space, composition, lifted_vertical) = match (a, b) {
        (BuiltSymmetry::Finite { rho_q: ra, .. }, BuiltSymmetry::Finite { rho_q: rb, .. }) => {
            ("Q", compose::classify_finite_finite(ra, rb), None)
        }
        (BuiltSymmetry::Finite { rho_q, .. }, BuiltSymmetry::Lie { action, affine, .. })
        | (BuiltSymmetry::Lie { action, affine, .. }, BuiltSymmetry::Finite { rho_q, .. }) => {
            let c = finite_lie(probe, rho_q, action.as_ref(), affine.as_ref())?;
            let (fin, lie) = if matches!(a, BuiltSymmetry::Finite { .. }) {
                (a, b)
            } else {
                (b, a)
            };
            return Ok(PairRow {
                a: fin.name().into(),
                b: lie.name().into(),
                space: "Q",
                composition: c,
                lifted_vertical: None,
                requested: false,
            });
        }
        (BuiltSymmetry::Lie { action: xa, .. }, BuiltSymmetry::Lie { action: xb, .. }) => {
            let (c, vertical) = lie_lie(probe, xa.as_ref(), xb.as_ref(), x_samples);
            ("X", c, Some(vertical))
        }
    };
    Ok(PairRow {
        a: a.name().into(),
        b: b.name().into(),
        space,
        composition,
        lifted_vertical,
        requested: false,
    })
}

/// A finite symmetry `ρ_Q` with a lifted Lie group, decided in `Q` (eqs. 19–22).
fn finite_lie(
    probe: &Probe<'_>,
    rho_q: &SignedPermutation,
    action: &dyn TaskGroupAction,
    affine: Option<&LieGroupSpec>,
) -> Result<Composition, CheckError> {
    let kin = probe.kin;
    let lifted = LiftedAction::new(kin, action, probe.flow)
        .map_err(|e| sym_err(action.name(), e.to_string()))?;
    let lws = RefCell::new(lifted.workspace());
    let act =
        |xi: &[f64], q: &[f64], o: &mut [f64]| lifted.act(xi, q, o, &mut lws.borrow_mut()).is_ok();
    let fields: Vec<LiftedField<'_, _>> = (0..action.algebra_dim())
        .map(|k| LiftedField::new(kin, basis(action, k)))
        .collect();
    let refs: Vec<&dyn VectorField> = fields.iter().map(|f| f as &dyn VectorField).collect();
    Ok(compose::classify_finite_lie(
        rho_q,
        &refs,
        &act,
        &test_elements(affine, action.algebra_dim(), probe.cfg),
        probe.samples,
        ComposeTolerance {
            commute: 1e-6,
            automorphism: 1e-5,
        },
    ))
}

/// Two task-space groups, decided in `X` at `x_samples`, and the largest relative vertical
/// part of their lifted brackets in `Q`.
fn lie_lie(
    probe: &Probe<'_>,
    xa: &dyn TaskGroupAction,
    xb: &dyn TaskGroupAction,
    x_samples: &[Vec<f64>],
) -> (Composition, f64) {
    let ga: Vec<_> = (0..xa.algebra_dim()).map(|k| basis(xa, k)).collect();
    let gb: Vec<_> = (0..xb.algebra_dim()).map(|k| basis(xb, k)).collect();
    let ra: Vec<&dyn VectorField> = ga.iter().map(|g| g.as_ref() as &dyn VectorField).collect();
    let rb: Vec<&dyn VectorField> = gb.iter().map(|g| g.as_ref() as &dyn VectorField).collect();
    let c = compose::classify_lie_lie(
        &ra,
        &rb,
        x_samples,
        DEFAULT_FD_STEP,
        ComposeTolerance::default(),
    );
    let mut vertical: f64 = 0.0;
    for g1 in &ga {
        for g2 in &gb {
            vertical = vertical.max(
                bracket_condition(
                    probe.kin,
                    g1.as_ref(),
                    g2.as_ref(),
                    probe.samples,
                    DEFAULT_FD_STEP,
                )
                .vertical_relative,
            );
        }
    }
    (c, vertical)
}
