//! `crossym symmetries`: the morphological symmetry group of a robot from its URDF
//! ([`crossym::symmetry::transfer::morpho::body`]), printed as a table and written as TOML
//! and as MorphoSymm's YAML.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use anyhow::Context;
use crossym::kinematics::RobotModel;
use crossym::symmetry::transfer::morpho::export::{to_morphosymm_yaml, to_toml};
use crossym::symmetry::transfer::morpho::{
    derive_body_symmetries, BodyElement, BodySettings, BodySymmetries, ElementKind,
};
use nalgebra::{Matrix3, Vector3};

/// Options of `crossym symmetries`.
#[derive(Debug, clap::Args)]
pub struct SymmetriesArgs {
    /// URDF file of the robot.
    #[arg(long)]
    pub urdf: PathBuf,
    /// Base link: planes pass through its origin, only its subtree is considered
    /// (default: the URDF's root link).
    #[arg(long)]
    pub base: Option<String>,
    /// Joints forming q, comma-separated (default: every revolute, continuous and prismatic
    /// joint below the base without <mimic>; the others are held at 0).
    #[arg(long, value_delimiter = ',')]
    pub joints: Option<Vec<String>>,
    /// Try only this plane normal (base frame, `x,y,z`); repeatable. Default: search.
    #[arg(long = "plane", value_parser = parse_vec3, allow_hyphen_values = true)]
    pub planes: Vec<Vector3<f64>>,
    /// Tolerance relative to the robot's size, for axis lines, link origins and the
    /// sampled residual.
    #[arg(long, default_value_t = 1e-4)]
    pub tolerance: f64,
    /// Links left out of the link check (e.g. a sensor frame on one side), comma-separated.
    #[arg(long, value_delimiter = ',')]
    pub ignore_links: Vec<String>,
    /// Refuse a plane that leaves a (not ignored) link without a mirrored partner
    /// (default: such links are listed with the element).
    #[arg(long)]
    pub strict_links: bool,
    /// Refuse a plane under which joint limits do not map into each other (default: listed).
    #[arg(long)]
    pub require_limits: bool,
    /// Verification samples per group element.
    #[arg(long, default_value_t = 64)]
    pub samples: usize,
    /// Directory for `<robot>_symmetries.toml` and `<robot>_morphosymm.yaml`.
    #[arg(long, default_value = "results/symmetries")]
    pub out: PathBuf,
    /// Print every element's signed permutation, not only the generators'.
    #[arg(long)]
    pub all: bool,
}

fn parse_vec3(s: &str) -> Result<Vector3<f64>, String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|t| t.trim().parse::<f64>().map_err(|e| format!("`{t}`: {e}")))
        .collect::<Result<_, _>>()?;
    match v[..] {
        [x, y, z] => Ok(Vector3::new(x, y, z)),
        _ => Err(format!("`{s}` is not three comma-separated numbers")),
    }
}

/// `O` as a signed permutation of the axes, e.g. `(x, −y, z)`, or its rows.
fn space_label(o: &Matrix3<f64>) -> String {
    let axes = ["x", "y", "z"];
    let mut out = Vec::new();
    for r in 0..3 {
        let hit: Vec<(usize, f64)> = (0..3)
            .filter(|&c| o[(r, c)].abs() > 1e-9)
            .map(|c| (c, o[(r, c)]))
            .collect();
        match hit[..] {
            [(c, v)] if (v.abs() - 1.0).abs() < 1e-9 => {
                out.push(format!("{}{}", if v < 0.0 { "−" } else { "" }, axes[c]))
            }
            _ => return format!("{:.3?}", o.as_slice()),
        }
    }
    format!("({})", out.join(", "))
}

fn summary_row(e: &BodyElement) -> String {
    let n = e.rho_q.dim();
    let own: Vec<usize> = (0..n).filter(|&i| e.rho_q.perm[i] == i).collect();
    let flipped_own = own.iter().filter(|&&i| e.rho_q.signs[i] < 0.0).count();
    format!(
        "| {} | {} | {} | {} ({} flip sign) | {:.1e} / {:.1e} | {} | {} | {} |",
        e.label(),
        space_label(&e.space),
        (n - own.len()) / 2,
        own.len(),
        flipped_own,
        e.relative_residual,
        e.orientation_residual,
        e.link_pairs.len(),
        e.unmatched_links.len(),
        if e.limit_mismatches.is_empty() {
            "consistent".to_string()
        } else {
            format!(
                "{} mismatched: {}",
                e.limit_mismatches.len(),
                e.limit_mismatches
                    .iter()
                    .take(3)
                    .map(|m| format!("{}↔{}", m.joint_a, m.joint_b))
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        }
    )
}

fn print_map(g: &BodySymmetries, e: &BodyElement) {
    println!("\n{}: (ρ_Q q)[joint] = sign · q[image]", e.label());
    let w = g.joints.iter().map(String::len).max().unwrap_or(5).max(5);
    println!("  {:<w$}  {:<w$}  sign", "joint", "image");
    for (i, (&p, &s)) in e.rho_q.perm.iter().zip(&e.rho_q.signs).enumerate() {
        println!(
            "  {:<w$}  {:<w$}  {}",
            g.joints[i],
            g.joints[p],
            if s < 0.0 { "−1" } else { "+1" }
        );
    }
}

/// `crossym symmetries`.
pub fn run(a: &SymmetriesArgs) -> anyhow::Result<ExitCode> {
    if !(a.tolerance.is_finite() && a.tolerance > 0.0) {
        anyhow::bail!("--tolerance {} is not a positive number", a.tolerance);
    }
    let model = RobotModel::from_urdf_file(&a.urdf)?;
    let settings = body_settings(a);
    let t0 = Instant::now();
    let g = derive_body_symmetries(
        &model,
        a.base.as_deref(),
        a.joints.as_deref(),
        &HashMap::new(),
        &settings,
    )
    .with_context(|| format!("{}", a.urdf.display()))?;
    let dt = t0.elapsed().as_secs_f64();
    print_summary(&g, a, dt);
    print_details(&g, a.all);
    write_files(&g, &a.out)?;
    Ok(ExitCode::SUCCESS)
}

/// The derivation's settings from the options.
fn body_settings(a: &SymmetriesArgs) -> BodySettings {
    BodySettings {
        samples: a.samples,
        position_tolerance: a.tolerance,
        axis_tolerance: a.tolerance,
        residual_tolerance: a.tolerance,
        planes: (!a.planes.is_empty()).then(|| a.planes.clone()),
        ignore_links: a.ignore_links.clone(),
        strict_links: a.strict_links,
        require_consistent_limits: a.require_limits,
        ..BodySettings::default()
    }
}

/// The robot, the group found (derived in `dt` s) and one row per element.
fn print_summary(g: &BodySymmetries, a: &SymmetriesArgs, dt: f64) {
    println!(
        "robot `{}` ({}): base `{}`, {} joints, size {:.3} m",
        g.robot,
        a.urdf.display(),
        g.base,
        g.joints.len(),
        g.size
    );
    println!(
        "group {} of order {} ({} generating reflection(s); {} candidate planes tried, {} samples per element, tolerance {:.1e} of the size; {:.3} s)\n",
        g.group,
        g.elements.len(),
        g.generators,
        g.candidates,
        g.samples,
        a.tolerance,
        dt
    );
    println!("| element | action on points | joint pairs | joints on themselves | residual (position rel. / orientation) | links paired | links without mirror | joint limits |");
    println!("|---|---|---|---|---|---|---|---|");
    for e in &g.elements {
        println!("{}", summary_row(e));
    }
    for e in g.elements.iter().filter(|e| !e.unmatched_links.is_empty()) {
        println!(
            "  {}: links without a mirrored partner (not checked): {}",
            e.label(),
            e.unmatched_links.join(", ")
        );
    }
}

/// The joint maps of the reflections (`all`: of every element), the planes that are not
/// symmetries, the joint limits a reflection does not preserve.
fn print_details(g: &BodySymmetries, all: bool) {
    let shown: Vec<&BodyElement> = if all {
        g.elements.iter().skip(1).collect()
    } else {
        g.reflections().iter().collect()
    };
    for e in shown {
        print_map(g, e);
    }
    if !g.rejected.is_empty() {
        println!("\nplanes that are not symmetries:");
        for r in &g.rejected {
            let o = Matrix3::identity() - 2.0 * r.normal * r.normal.transpose();
            println!(
                "  {} ({}): {}",
                fmt_normal(&r.normal),
                space_label(&o),
                r.reason
            );
        }
    }
    for e in g.reflections() {
        if let ElementKind::Reflection { .. } = e.kind {
            for m in &e.limit_mismatches {
                println!("  limits under {}: {m}", e.label());
            }
        }
    }
}

/// The group as a crossym config (`<robot>_symmetries.toml`) and for MorphoSymm
/// (`<robot>_morphosymm.yaml`) in directory `out`.
fn write_files(g: &BodySymmetries, out: &Path) -> anyhow::Result<()> {
    std::fs::create_dir_all(out).with_context(|| format!("{}", out.display()))?;
    let stem = g
        .robot
        .replace(|c: char| !c.is_ascii_alphanumeric() && c != '_', "_");
    let toml_path = out.join(format!("{stem}_symmetries.toml"));
    let yaml_path = out.join(format!("{stem}_morphosymm.yaml"));
    std::fs::write(&toml_path, to_toml(g)).with_context(|| format!("{}", toml_path.display()))?;
    std::fs::write(&yaml_path, to_morphosymm_yaml(g))
        .with_context(|| format!("{}", yaml_path.display()))?;
    println!(
        "\nwrote {} and {}",
        toml_path.display(),
        yaml_path.display()
    );
    Ok(())
}

fn fmt_normal(n: &Vector3<f64>) -> String {
    format!("n=({:.3}, {:.3}, {:.3})", n.x, n.y, n.z)
}
