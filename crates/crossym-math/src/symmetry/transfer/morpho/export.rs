//! The derived group written for people and tools: crossym TOML and MorphoSymm's YAML.
//!
//! Each element `(O, ρ_Q)` is written as `O` (the 3 × 3 action on points of the base
//! frame) and `ρ_Q` as `perm` / `signs` with `(ρ_Q q)_i = signs_i · q_{perm_i}`, plus a
//! readable `map` of `[joint, image joint, sign]`. MorphoSymm's robot catalog
//! (`cfg/robot/*.yaml`) lists, per generator `g`, `permutation_Q_js[g]` and
//! `reflection_Q_js[g]` over the joints in its own order; [`to_morphosymm_yaml`] writes the
//! generating reflections in that layout over [`BodySymmetries::joints`] (named in
//! `joint_names`, since the order of a MorphoSymm model may differ).

use serde::{Deserialize, Serialize};

use super::body::{BodyElement, BodySymmetries, ElementKind};

/// One group element in the TOML file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ElementEntry {
    /// Readable label (`reflection n=(0,1,0)`, `rotation π about (0,0,1)`).
    pub label: String,
    /// `identity`, `reflection`, `rotation` or `rotoreflection`.
    pub kind: String,
    /// True for a generating reflection.
    pub generator: bool,
    /// Plane normal of a reflection (base frame).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub normal: Option<[f64; 3]>,
    /// Axis of a rotation (base frame).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub axis: Option<[f64; 3]>,
    /// Angle of a rotation (rad).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub angle: Option<f64>,
    /// `O`, row by row: the action on points of the base frame.
    pub space: [[f64; 3]; 3],
    /// `π`: `(ρ_Q q)_i = signs_i · q_{perm_i}` (indices into `joints`).
    pub perm: Vec<usize>,
    /// `s_i = ±1`.
    pub signs: Vec<i32>,
    /// `[joint, image joint, sign]` per joint, the same map by name.
    pub map: Vec<(String, String, i32)>,
    /// Worst sampled residual relative to the robot's size.
    pub relative_residual: f64,
    /// `[joint, image]` pairs whose limits do not map into each other.
    #[serde(default)]
    pub limit_mismatches: Vec<[String; 2]>,
}

/// The TOML form of a [`BodySymmetries`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SymmetryFile {
    /// Robot name.
    pub robot: String,
    /// Base link (planes through its origin, vectors in its frame).
    pub base: String,
    /// Robot size (m): tolerances and residuals are relative to it.
    pub size_m: f64,
    /// Group name (`C2`, `K4`, …).
    pub group: String,
    /// Group order.
    pub order: usize,
    /// Joints forming `q`, in order.
    pub joints: Vec<String>,
    /// Every element, identity first.
    pub elements: Vec<ElementEntry>,
}

fn entry(g: &BodySymmetries, e: &BodyElement, generator: bool) -> ElementEntry {
    let (kind, normal, axis, angle) = match e.kind {
        ElementKind::Identity => ("identity", None, None, None),
        ElementKind::Reflection { normal } => ("reflection", Some(normal.into()), None, None),
        ElementKind::Rotation { axis, angle } => ("rotation", None, Some(axis.into()), Some(angle)),
        ElementKind::Rotoreflection => ("rotoreflection", None, None, None),
    };
    let o = e.space;
    let clean = |x: f64| if x.abs() < 1e-12 { 0.0 } else { x };
    ElementEntry {
        label: e.label(),
        kind: kind.into(),
        generator,
        normal,
        axis,
        angle,
        space: [0, 1, 2].map(|r| [0, 1, 2].map(|c| clean(o[(r, c)]))),
        perm: e.rho_q.perm.clone(),
        signs: e.rho_q.signs.iter().map(|s| *s as i32).collect(),
        map: e
            .rho_q
            .perm
            .iter()
            .zip(&e.rho_q.signs)
            .enumerate()
            .map(|(i, (&p, &s))| (g.joints[i].clone(), g.joints[p].clone(), s as i32))
            .collect(),
        relative_residual: e.relative_residual,
        limit_mismatches: e
            .limit_mismatches
            .iter()
            .map(|m| [m.joint_a.clone(), m.joint_b.clone()])
            .collect(),
    }
}

impl From<&BodySymmetries> for SymmetryFile {
    fn from(g: &BodySymmetries) -> Self {
        Self {
            robot: g.robot.clone(),
            base: g.base.clone(),
            size_m: g.size,
            group: g.group.clone(),
            order: g.elements.len(),
            joints: g.joints.clone(),
            elements: g
                .elements
                .iter()
                .enumerate()
                .map(|(i, e)| entry(g, e, i >= 1 && i <= g.generators))
                .collect(),
        }
    }
}

/// The group as crossym TOML ([`SymmetryFile`]).
pub fn to_toml(g: &BodySymmetries) -> String {
    let body = toml::to_string(&SymmetryFile::from(g)).expect("plain data serializes");
    format!(
        "# Morphological symmetry group of `{}` derived from its URDF by `crossym symmetries`.\n\
         # (ρ_Q q)_i = signs_i · q_{{perm_i}}; `space` is the action on points of the base frame.\n{}",
        g.robot, body
    )
}

/// The generating reflections in MorphoSymm's robot-catalog layout (YAML).
pub fn to_morphosymm_yaml(g: &BodySymmetries) -> String {
    let list = |v: Vec<String>| format!("[{}]", v.join(", "));
    let gens = g.reflections();
    let perms = list(
        gens.iter()
            .map(|e| list(e.rho_q.perm.iter().map(|p| p.to_string()).collect()))
            .collect(),
    );
    let signs = list(
        gens.iter()
            .map(|e| {
                list(
                    e.rho_q
                        .signs
                        .iter()
                        .map(|s| format!("{}", *s as i32))
                        .collect(),
                )
            })
            .collect(),
    );
    let names = list(g.joints.iter().map(|n| format!("'{n}'")).collect());
    let planes = list(
        gens.iter()
            .filter_map(|e| match e.kind {
                ElementKind::Reflection { normal } => Some(list(
                    normal
                        .iter()
                        .map(|x| format!("{}", (x * 1e9).round() / 1e9))
                        .collect(),
                )),
                _ => None,
            })
            .collect(),
    );
    format!(
        "# Morphological symmetries of `{robot}` in MorphoSymm's robot-catalog layout,\n\
         # derived from its URDF by `crossym symmetries` (one entry per generating reflection).\n\
         # Joint order is `joint_names` (a MorphoSymm model may order joints differently).\n\
         name: '{robot}'\n\
         group_label: '{group}'\n\
         joint_names: {names}\n\
         reflection_planes: {planes}\n\
         permutation_Q_js: {perms}\n\
         reflection_Q_js: {signs}\n",
        robot = g.robot,
        group = g.group,
    )
}
