//! `crossym check`: the report on the shipped configs (paper Examples 1–4 end to end) and
//! the CLI's exit codes.

use std::process::Command;

use crossym::symmetry::check::check;
use crossym::symmetry::compose::Composition;

use crate::common;

fn pair<'a>(r: &'a crossym::symmetry::check::CheckReport, a: &str, b: &str) -> &'a Composition {
    &r.pairs
        .iter()
        .find(|p| p.a == a && p.b == b)
        .unwrap_or_else(|| panic!("pair {a}·{b}"))
        .composition
}

#[test]
fn letter_task_composes_to_g_mrt() {
    let cfg = common::load_config("letters.toml");
    let robot = cfg.load_robot().unwrap();
    let r = check(
        &robot.kinematics,
        &cfg.symmetries,
        &cfg.composition.order,
        &cfg.check,
    )
    .unwrap();
    assert!(r.ok());
    assert_eq!(r.samples, 24);
    for s in &r.symmetries {
        assert!(s.ok && s.equivariance < 1e-6, "{s:?}");
    }
    let m = &r.symmetries[0];
    assert_eq!((m.acts_on, m.group.as_str()), ("Q", "C2"));
    assert!(
        m.notes.iter().any(|n| n.contains("[-1, -1, -1, -1]")),
        "{:?}",
        m.notes
    );
    assert!(
        m.notes.iter().any(|n| n.contains("P_X = diag[1, -1]")),
        "{:?}",
        m.notes
    );
    // The lifted SO(2) is not periodic in Q with the identity metric (see README).
    assert!(r.symmetries[1].periodicity_drift.unwrap() > 0.1);
    match pair(&r, "M", "R") {
        Composition::SemiDirect { automorphism, .. } => {
            assert!((automorphism[(0, 0)] + 1.0).abs() < 1e-6)
        }
        other => panic!("M·R: {other:?}"),
    }
    assert!(matches!(pair(&r, "M", "S"), Composition::Direct { .. }));
    assert!(matches!(pair(&r, "R", "S"), Composition::Direct { .. }));
    assert_eq!(
        r.group_expression(&cfg.composition.order).as_deref(),
        Some("(R × S) ⋊ M")
    );
}

#[test]
fn rby1_reflection_and_pan_rotation() {
    if common::rby1_urdf().is_none() {
        return;
    }
    let cfg = common::load_config("rby1.toml");
    let robot = cfg.load_robot().unwrap();
    let r = check(
        &robot.kinematics,
        &cfg.symmetries,
        &cfg.composition.order,
        &cfg.check,
    )
    .unwrap();
    assert!(r.ok(), "{r:#?}");
    let m = &r.symmetries[0];
    assert!(
        m.notes
            .iter()
            .any(|n| n.contains("[1, -1, -1, 1, -1, 1, -1]")),
        "Example 1: {:?}",
        m.notes
    );
    assert!(
        m.notes.iter().any(|n| n.contains("P_X = diag[1, -1, 1]")),
        "{:?}",
        m.notes
    );
    // Reflecting across the sagittal plane reverses the pan's rotation: SO(2) ⋊ C2.
    assert!(matches!(pair(&r, "M", "R"), Composition::SemiDirect { .. }));
    assert_eq!(
        r.group_expression(&cfg.composition.order).as_deref(),
        Some("R ⋊ M")
    );
    // The task-induced symmetry of "distance to the pan axis" is found, checked and lifted.
    let t = r.symmetries.iter().find(|s| s.name == "T").unwrap();
    assert!(t.ok && t.equivariance < 1e-6, "{t:?}");
    assert!(
        t.notes.iter().any(|n| n.contains("2 field(s)")),
        "{:?}",
        t.notes
    );
}

fn write_config(name: &str, extra: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("crossym-check-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let base = std::fs::read_to_string(common::path("config/planar_dual_arm.toml")).unwrap();
    let urdf = common::path("urdf/planar_dual_arm.urdf");
    let text = base.replace("../urdf/planar_dual_arm.urdf", &urdf.display().to_string()) + extra;
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

const REST: &str = "[check]\nreference_q = [0.785, -0.524, -0.393, -0.314, -0.785, 0.524, 0.393, 0.314]\nsamples = 6\n";

#[test]
fn cli_exit_codes() {
    let exe = env!("CARGO_BIN_EXE_crossym");
    // 0: the shipped letter task.
    let text = common::run_ok(
        common::crossym(["check", "--config"]).arg(common::path("config/letters.toml")),
    );
    assert!(
        text.contains("composed group: (R × S) ⋊ M") && text.contains("verdict: ok"),
        "{text}"
    );
    // 1: two rotations about different centers cannot be composed (their bracket is a
    // translation in neither algebra).
    let p = write_config(
        "impossible.toml",
        &format!(
            "[[symmetries]]\nname = \"R\"\ngroup = {{ kind = \"so2\" }}\n[[symmetries]]\nname = \"R2\"\ngroup = {{ kind = \"so2\" }}\ncenter = [1.0, 0.0]\n[composition]\norder = [\"R\", \"R2\"]\n{REST}"
        ),
    );
    let out = Command::new(exe)
        .args(["check", "--config"])
        .arg(&p)
        .output()
        .unwrap();
    assert_eq!(
        out.status.code(),
        Some(1),
        "{}",
        String::from_utf8_lossy(&out.stdout)
    );
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("incompatible") && text.contains("verdict: FAILED"),
        "{text}"
    );
    // 2: a configuration error names the problem.
    let p = write_config("unknown.toml", &format!("[[symmetries]]\nname = \"R\"\ngroup = {{ kind = \"so2\" }}\n[composition]\norder = [\"R\", \"X\"]\n{REST}"));
    let out = Command::new(exe)
        .args(["check", "--config"])
        .arg(&p)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("unknown symmetry `X`"));
    let p = write_config(
        "badkind.toml",
        "[[symmetries]]\nname = \"R\"\ngroup = { kind = \"so5\" }\n",
    );
    let out = Command::new(exe)
        .args(["check", "--config"])
        .arg(&p)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("so5"));
}
