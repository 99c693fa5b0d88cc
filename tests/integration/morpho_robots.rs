//! Whole-body morphological symmetry groups derived from real robots' URDFs
//! (`transfer::morpho::body`), checked against hand-checked tables in
//! `tests/data/morpho/expected/` (MorphoSymm's catalog where it has the robot, by hand
//! otherwise, each verified by the independent numpy checker `check_expected.py`).
//! URDFs from PyPI `example-robot-data` (`tests/robots/install.sh`); skipped when absent.

use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::path::Path;

use crossym::kinematics::RobotModel;
use crossym::symmetry::finite::SignedPermutation;
use crossym::symmetry::transfer::morpho::export::{to_morphosymm_yaml, to_toml, SymmetryFile};
use crossym::symmetry::transfer::morpho::{
    derive_body_symmetries, BodyElement, BodySettings, BodySymmetries, ElementKind,
};
use nalgebra::Vector3;
use serde::Deserialize;

use crate::common;

#[derive(Debug, Deserialize)]
struct Expected {
    robot: String,
    urdf: String,
    group: String,
    order: usize,
    /// Position tolerance (m) the table needs, when the URDF is not exactly mirrored.
    tolerance_m: Option<f64>,
    reflection: Vec<ExpectedReflection>,
}

#[derive(Debug, Deserialize)]
struct ExpectedReflection {
    name: String,
    normal: [f64; 3],
    /// `[joint, image, sign]`: `(ρ q)[joint] = sign · q[image]`.
    map: Vec<(String, String, i32)>,
    #[serde(default)]
    limit_mismatches: Vec<[String; 2]>,
}

fn load_expected(name: &str) -> Expected {
    let p = common::root().join(format!("tests/data/morpho/expected/{name}.toml"));
    toml::from_str(&std::fs::read_to_string(&p).unwrap()).unwrap()
}

/// Derives at the default relative tolerance, or at the table's stated tolerance when larger.
fn derive(dir: &Path, e: &Expected, settings: BodySettings) -> BodySymmetries {
    let model = RobotModel::from_urdf_file(dir.join(&e.urdf)).unwrap();
    let g = derive_body_symmetries(&model, None, None, &HashMap::new(), &settings).unwrap();
    match e.tolerance_m {
        Some(t) if t / g.size > settings.position_tolerance => {
            let rel = t / g.size;
            let s = BodySettings {
                position_tolerance: rel,
                axis_tolerance: rel,
                residual_tolerance: rel,
                ..settings
            };
            derive_body_symmetries(&model, None, None, &HashMap::new(), &s).unwrap()
        }
        _ => g,
    }
}

/// `ρ` from a table's rows over `joints`.
fn table_rho(joints: &[String], map: &[(String, String, i32)]) -> SignedPermutation {
    let idx: HashMap<&str, usize> = joints
        .iter()
        .enumerate()
        .map(|(i, j)| (j.as_str(), i))
        .collect();
    let mut perm = vec![usize::MAX; joints.len()];
    let mut signs = vec![0.0; joints.len()];
    for (j, img, s) in map {
        let i = idx[j.as_str()];
        perm[i] = idx[img.as_str()];
        signs[i] = f64::from(*s);
    }
    SignedPermutation::new(perm, signs).expect("the table is a signed permutation")
}

fn element_with_normal<'a>(g: &'a BodySymmetries, n: &[f64; 3]) -> Option<&'a BodyElement> {
    let n = Vector3::from(*n).normalize();
    g.reflections().iter().find(
        |e| matches!(e.kind, ElementKind::Reflection { normal } if (normal - n).norm() < 1e-9),
    )
}

fn unordered(pairs: impl Iterator<Item = [String; 2]>) -> BTreeSet<[String; 2]> {
    pairs
        .map(|mut p| {
            p.sort();
            p
        })
        .collect()
}

/// Compares a derivation with its table; returns a description of every difference.
fn differences(e: &Expected, g: &BodySymmetries, tol: f64) -> Vec<String> {
    let mut out = Vec::new();
    if g.group != e.group || g.elements.len() != e.order {
        out.push(format!(
            "group {} of order {}, expected {} of order {} (rejected: {:?})",
            g.group,
            g.elements.len(),
            e.group,
            e.order,
            g.rejected
        ));
    }
    let table_joints: BTreeSet<&String> = e.reflection[0].map.iter().map(|r| &r.0).collect();
    let derived: BTreeSet<&String> = g.joints.iter().collect();
    if table_joints != derived {
        out.push(format!(
            "joints differ: only in table {:?}, only derived {:?}",
            table_joints.difference(&derived).collect::<Vec<_>>(),
            derived.difference(&table_joints).collect::<Vec<_>>()
        ));
        return out;
    }
    let mut product = SignedPermutation::identity(g.joints.len());
    for r in &e.reflection {
        let want = table_rho(&g.joints, &r.map);
        product = want.compose(&product);
        let Some(el) = element_with_normal(g, &r.normal) else {
            out.push(format!(
                "{}: no reflection with normal {:?}",
                r.name, r.normal
            ));
            continue;
        };
        for i in 0..g.joints.len() {
            if el.rho_q.perm[i] != want.perm[i] || el.rho_q.signs[i] != want.signs[i] {
                out.push(format!(
                    "{}: {} → {} ({:+}), table {} ({:+})",
                    r.name,
                    g.joints[i],
                    g.joints[el.rho_q.perm[i]],
                    el.rho_q.signs[i],
                    g.joints[want.perm[i]],
                    want.signs[i]
                ));
            }
        }
        let got = unordered(
            el.limit_mismatches
                .iter()
                .map(|m| [m.joint_a.clone(), m.joint_b.clone()]),
        );
        let want_lim = unordered(r.limit_mismatches.iter().cloned());
        if got != want_lim {
            out.push(format!(
                "{}: limit mismatches {got:?}, table {want_lim:?}",
                r.name
            ));
        }
        if !el.within(tol) {
            out.push(format!(
                "{}: residual {:.2e} / {:.2e} above {tol:.1e} at {}",
                r.name, el.relative_residual, el.orientation_residual, el.worst
            ));
        }
    }
    // K4: the third element is the product of the two tables, a rotation by π.
    if e.reflection.len() == 2 {
        match g.elements.iter().find(|el| el.rho_q == product) {
            Some(el) => {
                if !matches!(el.kind, ElementKind::Rotation { angle, .. } if (angle - std::f64::consts::PI).abs() < 1e-9)
                {
                    out.push(format!("product element is {:?}", el.kind));
                }
                if !el.within(tol) {
                    out.push(format!("product residual {:.2e}", el.relative_residual));
                }
            }
            None => out.push("the product of the two reflections is not in the group".into()),
        }
    }
    out
}

const ROBOTS: [&str; 7] = [
    "baxter",
    "tiago_dual",
    "g1",
    "talos",
    "solo12",
    "anymal_c",
    "go2",
];

#[test]
fn derived_groups_of_seven_robots_match_the_tables() {
    let Some(dir) = common::example_robots() else {
        return;
    };
    let mut failures = BTreeMap::new();
    for name in ROBOTS {
        let e = load_expected(name);
        let g = derive(&dir, &e, BodySettings::default());
        let tol = e.tolerance_m.map_or(1e-4, |t| (t / g.size).max(1e-4));
        eprintln!(
            "{:<10} {:<3} order {} joints {:>3} size {:.3} m residual {:.1e} ({} candidates)",
            e.robot,
            g.group,
            g.elements.len(),
            g.joints.len(),
            g.size,
            g.worst_relative_residual(),
            g.candidates
        );
        let mut d = differences(&e, &g, tol);
        if g.elements[0].relative_residual != 0.0 || !g.elements[0].unmatched_links.is_empty() {
            d.push(format!(
                "identity element: residual {:.1e}",
                g.elements[0].relative_residual
            ));
        }
        if !d.is_empty() {
            failures.insert(name, d);
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

#[test]
fn exactly_mirrored_robots_need_no_more_than_1e_9() {
    // Talos, Solo12, ANYmal C and Go2 are mirrored to rounding: a tolerance of 1e-9 of
    // their size finds the same groups; G1 (10 µm) and TIAGo dual (3 mm) lose their plane.
    let Some(dir) = common::example_robots() else {
        return;
    };
    let tight = || BodySettings {
        position_tolerance: 1e-9,
        axis_tolerance: 1e-9,
        residual_tolerance: 1e-9,
        ..BodySettings::default()
    };
    for name in ["talos", "solo12", "anymal_c", "go2", "baxter"] {
        let e = load_expected(name);
        let model = RobotModel::from_urdf_file(dir.join(&e.urdf)).unwrap();
        let g = derive_body_symmetries(&model, None, None, &HashMap::new(), &tight()).unwrap();
        assert_eq!(g.group, e.group, "{name}: {:?}", g.rejected);
    }
    for (name, why) in [("g1", "left_shoulder"), ("tiago_dual", "arm_")] {
        let e = load_expected(name);
        let model = RobotModel::from_urdf_file(dir.join(&e.urdf)).unwrap();
        let g = derive_body_symmetries(&model, None, None, &HashMap::new(), &tight()).unwrap();
        assert_eq!(g.group, "trivial", "{name}");
        let y = g
            .rejected
            .iter()
            .find(|r| (r.normal - Vector3::y()).norm() < 1e-12)
            .expect("the sagittal plane is refused with a reason");
        assert!(y.reason.contains(why), "{name}: {}", y.reason);
    }
}

#[test]
fn go2_frontal_plane_maps_kinematics_but_not_limits() {
    // MorphoSymm lists Go2 (as A1) with C2 only: the calves' ranges do not mirror front to
    // back. Requiring consistent limits gives that group.
    let Some(dir) = common::example_robots() else {
        return;
    };
    let e = load_expected("go2");
    let g = derive(
        &dir,
        &e,
        BodySettings {
            require_consistent_limits: true,
            ..BodySettings::default()
        },
    );
    assert_eq!(g.group, "C2");
    assert!(element_with_normal(&g, &[0.0, 1.0, 0.0]).is_some());
    let x = g
        .rejected
        .iter()
        .find(|r| (r.normal - Vector3::x()).norm() < 1e-12)
        .unwrap();
    assert!(x.reason.contains("calf"), "{}", x.reason);
}

#[test]
fn exports_round_trip_and_match_morphosymm_layout() {
    let Some(dir) = common::example_robots() else {
        return;
    };
    let e = load_expected("solo12");
    let g = derive(&dir, &e, BodySettings::default());
    let file: SymmetryFile = toml::from_str(&to_toml(&g)).unwrap();
    assert_eq!(file.group, "K4");
    assert_eq!(file.order, 4);
    assert_eq!(file.joints, g.joints);
    for (entry, el) in file.elements.iter().zip(&g.elements) {
        assert_eq!(entry.perm, el.rho_q.perm);
        let signs: Vec<f64> = entry.signs.iter().map(|s| f64::from(*s)).collect();
        assert_eq!(signs, el.rho_q.signs);
        for (i, (j, img, s)) in entry.map.iter().enumerate() {
            assert_eq!(j, &g.joints[i]);
            assert_eq!(img, &g.joints[entry.perm[i]]);
            assert_eq!(*s, entry.signs[i]);
        }
    }
    // The YAML parses with PyYAML (installed by tests/bags/install.sh) into MorphoSymm's keys.
    let yaml = to_morphosymm_yaml(&g);
    let tmp = common::temp_dir("morpho_yaml");
    let p = tmp.join("solo.yaml");
    std::fs::write(&p, &yaml).unwrap();
    let has_yaml = std::process::Command::new("python3")
        .args(["-c", "import yaml"])
        .status()
        .is_ok_and(|s| s.success());
    if !has_yaml {
        crate::skip::skip("YAML parse: python3 has no PyYAML (tests/bags/install.sh installs it)");
        return;
    }
    let out = std::process::Command::new("python3")
        .args([
            "-c",
            "import sys, yaml, json; d = yaml.safe_load(open(sys.argv[1])); \
             print(json.dumps([d['group_label'], d['permutation_Q_js'], d['reflection_Q_js'], d['joint_names']]))",
        ])
        .arg(&p)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "PyYAML refused the MorphoSymm YAML:\n{}\n{yaml}",
        String::from_utf8_lossy(&out.stderr)
    );
    /// `[group_label, permutation_Q_js, reflection_Q_js, joint_names]` as PyYAML read them.
    type Parsed = (String, Vec<Vec<usize>>, Vec<Vec<i32>>, Vec<String>);
    let parsed: Parsed = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(parsed.0, "K4");
    assert_eq!(parsed.3, g.joints);
    for (k, el) in g.reflections().iter().enumerate() {
        assert_eq!(parsed.1[k], el.rho_q.perm);
        let s: Vec<i32> = el.rho_q.signs.iter().map(|s| *s as i32).collect();
        assert_eq!(parsed.2[k], s);
    }
}

#[test]
fn rby1_whole_body_reflection_extends_example_1() {
    // Arms: paper Example 1, P = diag(1, −1, −1, 1, −1, 1, −1). Torso and head lie on the
    // plane y = 0 and map to themselves; their signs, read by hand from the vendor URDF's
    // axes (all origins rpy = 0, so base-frame axes are the written ones) with the axial
    // rule −S z, S = diag(1, −1, 1): torso_0 x → −1, torso_1..3 y → +1, torso_4 x → −1,
    // torso_5 z → −1, head_0 z → −1, head_1 y → +1.
    let Some(urdf) = common::rby1_urdf() else {
        return;
    };
    let model = RobotModel::from_urdf_file(&urdf).unwrap();
    let g = derive_body_symmetries(
        &model,
        None,
        None,
        &HashMap::new(),
        &BodySettings::default(),
    )
    .unwrap();
    assert_eq!(g.group, "C2", "{:?}", g.rejected);
    let r = &g.reflections()[0];
    let idx = |n: &str| g.joints.iter().position(|j| j == n).unwrap();
    let p = [1.0, -1.0, -1.0, 1.0, -1.0, 1.0, -1.0];
    for (k, s) in p.iter().enumerate() {
        let (l, rr) = (
            idx(&format!("left_arm_{k}")),
            idx(&format!("right_arm_{k}")),
        );
        assert_eq!(
            (r.rho_q.perm[l], r.rho_q.signs[l]),
            (rr, *s),
            "left_arm_{k}"
        );
        assert_eq!(
            (r.rho_q.perm[rr], r.rho_q.signs[rr]),
            (l, *s),
            "right_arm_{k}"
        );
    }
    for (j, s) in [
        ("torso_0", -1.0),
        ("torso_1", 1.0),
        ("torso_2", 1.0),
        ("torso_3", 1.0),
        ("torso_4", -1.0),
        ("torso_5", -1.0),
        ("head_0", -1.0),
        ("head_1", 1.0),
    ] {
        let i = idx(j);
        assert_eq!((r.rho_q.perm[i], r.rho_q.signs[i]), (i, s), "{j}");
    }
    assert_eq!(r.rho_q.perm[idx("right_wheel")], idx("left_wheel"));
    assert!(r.unmatched_links.is_empty(), "{:?}", r.unmatched_links);
    assert!(r.within(1e-6), "{:.2e}", r.relative_residual);
}

/// `ρ_Q`, `ρ_X` of the symmetry named `M` built from `symmetries` on `kin`.
fn built_m(
    kin: &crossym::kinematics::Kinematics,
    symmetries: &[crossym::symmetry::spec::SymmetryConfig],
) -> (SignedPermutation, Option<SignedPermutation>) {
    let (built, _) = crossym::symmetry::check::build(kin, symmetries).unwrap();
    built
        .into_iter()
        .find_map(|b| match b {
            crossym::symmetry::built::BuiltSymmetry::Finite { name, rho_q, rho_x }
                if name == "M" =>
            {
                Some((rho_q, rho_x))
            }
            _ => None,
        })
        .expect("M is built")
}

fn chain_swap_m() -> crossym::symmetry::spec::SymmetryConfig {
    crossym::symmetry::spec::SymmetryConfig {
        name: "M".into(),
        group: crossym::symmetry::spec::GroupSpec::Morphological {
            chains: Some(["left".into(), "right".into()]),
            plane_normal: Some([0.0, 1.0, 0.0]),
            signs: None,
            whole_body: false,
        },
        center: None,
    }
}

#[test]
fn whole_body_config_gives_the_chain_swap_on_shipped_robots() {
    // The RB-Y1 configs now derive M from the whole tree below link_torso_5; on the 14 arm
    // joints it must be the chain swap the policies were trained with (Example 1), and the
    // planar arm (two arms drawn on top of each other) must pick the swap, not −I per arm.
    let mut cases = vec![("letters.toml", common::load_config("letters.toml"))];
    if common::rby1_urdf().is_some() {
        for c in ["rby1.toml", "rby1-letters.toml", "rby1-pan.toml"] {
            cases.push((c, common::load_config(c)));
        }
    }
    for (name, cfg) in cases {
        let robot = cfg.load_robot().unwrap();
        let kin = &robot.kinematics;
        let whole = vec![crossym::symmetry::spec::SymmetryConfig {
            name: "M".into(),
            group: crossym::symmetry::spec::GroupSpec::Morphological {
                chains: None,
                plane_normal: Some([0.0, 1.0, 0.0]),
                signs: None,
                whole_body: true,
            },
            center: None,
        }];
        let (wq, wx) = built_m(kin, &whole);
        let (cq, cx) = built_m(kin, &[chain_swap_m()]);
        assert_eq!(wq, cq, "{name}: ρ_Q");
        assert_eq!(wx, cx, "{name}: ρ_X");
        // And the shipped config itself builds the same M.
        let (sq, _) = built_m(kin, &cfg.symmetries);
        assert_eq!(sq, cq, "{name}: shipped config");
    }
}

#[test]
fn whole_body_config_refuses_what_does_not_mirror() {
    let cfg = common::load_config("letters.toml");
    let robot = cfg.load_robot().unwrap();
    let bad = |normal: [f64; 3], chains: Option<[String; 2]>| {
        vec![crossym::symmetry::spec::SymmetryConfig {
            name: "M".into(),
            group: crossym::symmetry::spec::GroupSpec::Morphological {
                chains,
                plane_normal: Some(normal),
                signs: None,
                whole_body: true,
            },
            center: None,
        }]
    };
    let err =
        |s: Vec<crossym::symmetry::spec::SymmetryConfig>| match crossym::symmetry::check::build(
            &robot.kinematics,
            &s,
        ) {
            Ok(_) => panic!("accepted"),
            Err(e) => e.to_string(),
        };
    let e = err(bad([1.0, 0.0, 0.0], None));
    assert!(
        e.contains("not a symmetry") && e.contains("counterpart"),
        "{e}"
    );
    let e = err(bad([0.0, 1.0, 0.0], Some(["left".into(), "right".into()])));
    assert!(e.contains("drop `chains`"), "{e}");
}

#[test]
fn symmetries_cli_prints_and_writes_the_group() {
    // Out of process, as a user runs it: the planar arm shipped in urdf/ (always present),
    // and Solo12 when example-robot-data is installed.
    let out_dir = common::temp_dir("symmetries_cli");
    let stdout = common::run_ok(&mut common::crossym([
        "symmetries".as_ref(),
        "--urdf".as_ref(),
        common::path("urdf/planar_dual_arm.urdf").as_os_str(),
        "--out".as_ref(),
        out_dir.as_os_str(),
    ]));
    // The two arms are drawn on top of each other (one base point, both along x at q = 0):
    // across y = 0 they swap with P = −I, as in the paper; across z = 0 (the plane holding
    // the whole robot) they swap with P = +I; the product is −I on each arm. K4.
    assert!(stdout.contains("group K4 of order 4"), "{stdout}");
    let rows: Vec<Vec<&str>> = stdout
        .lines()
        .map(|l| l.split_whitespace().collect())
        .collect();
    assert!(
        rows.iter()
            .any(|r| r[..] == ["left_joint1", "right_joint1", "−1"]),
        "{stdout}"
    );
    let toml_text =
        std::fs::read_to_string(out_dir.join("planar_dual_arm_symmetries.toml")).unwrap();
    let file: SymmetryFile = toml::from_str(&toml_text).unwrap();
    assert_eq!(file.order, 4);
    assert!(out_dir.join("planar_dual_arm_morphosymm.yaml").exists());
    // A bad normal and a missing file are clear errors.
    let out = common::crossym([
        "symmetries".as_ref(),
        "--urdf".as_ref(),
        common::path("urdf/planar_dual_arm.urdf").as_os_str(),
        "--plane".as_ref(),
        "0,0,0".as_ref(),
        "--out".as_ref(),
        out_dir.as_os_str(),
    ])
    .output()
    .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("normal"));
    let out = common::crossym(["symmetries", "--urdf", "/nonexistent.urdf"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("/nonexistent.urdf"));
    if let Some(dir) = common::example_robots() {
        let stdout = common::run_ok(&mut common::crossym([
            "symmetries".as_ref(),
            "--urdf".as_ref(),
            dir.join("solo_description/robots/solo12.urdf").as_os_str(),
            "--out".as_ref(),
            out_dir.as_os_str(),
        ]));
        assert!(stdout.contains("group K4 of order 4"), "{stdout}");
        assert!(stdout.contains("rotation π about (0,0,1)"), "{stdout}");
    }
}
