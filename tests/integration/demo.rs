//! `crossym demo`'s preparation as library calls ([`crossym::demo::prepare`]), without a
//! process or DDS: conditions checked against the policy's trained box, one scenario step
//! per condition truncated to `--duration-s`, the offline scores. (The closed loop over DDS
//! is tested in `dds.rs`.)

use crossym::demo::{self, DemoError, DemoSettings};
use crossym::eval::{score, EvalConfig};
use crossym::policy::DomainViolation;

use crate::common;

/// Largest |a − b| of two equally long slices.
fn max_diff(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter().zip(b).fold(0.0, |m, (x, y)| m.max((x - y).abs()))
}

#[test]
fn demo_prepares_steps_and_refuses_conditions_outside_the_trained_box() {
    let (_, robot, demos) = common::task("letters.toml");
    let kin = &robot.kinematics;
    // The demonstration drawn by default: the first test one.
    let which = demos.test[0];
    let d = demos.demos.iter().find(|d| d.demo == which).unwrap();
    let mut s = DemoSettings::new(common::path("config/letters.toml"));
    // A plain joint-space policy trained on G_MRT's grid (sidecar: Δθ = 30° all round,
    // λ ∈ {0.5, …, 1}, both σ): its box is any θ, λ ∈ [0.5, 1], σ ∈ {1, −1}.
    s.policy = Some(common::path("data/policies/pi_mrt_planar.safetensors"));

    // λ = 1.2 lies above the box: refused, naming the condition, the part and the box.
    s.conditions = vec!["0.5:0.8:-1".into(), "0:1.2:1".into()];
    let Err(err) = demo::prepare(&s) else {
        panic!("a condition outside the trained box was accepted");
    };
    let text = err.to_string();
    assert!(
        matches!(&err, DemoError::OutsideDomain { condition, part: DomainViolation::Scale, domain }
            if condition == "0:1.2:1" && domain == "any θ, λ ∈ [0.5, 1], σ ∈ {1, −1}"),
        "{err:?}"
    );
    assert!(
        text.starts_with("--condition `0:1.2:1`: λ lies outside")
            && text.contains("(any θ, λ ∈ [0.5, 1], σ ∈ {1, −1})"),
        "{text}"
    );

    // Inside the box: one step per condition, in the order given, labelled by its text,
    // each nominal cut to the sample nearest 1.234 s (Δt = 0.01 s: 124 samples).
    s.conditions = vec!["0.5:0.8:-1".into(), "0:1:1".into()];
    s.duration_s = Some(1.234);
    let p = demo::prepare(&s).unwrap();
    assert_eq!(p.demo, which);
    assert!(p.left_out.is_empty());
    let keep = (1.234 / d.dt).round() as usize + 1;
    assert_eq!((d.dt, keep), (0.01, 124));
    assert!(d.len() > keep, "the letter is longer than 1.234 s");
    let (n, m) = (kin.dof(), kin.task_dim());
    assert_eq!(p.steps.len(), 2);
    for (step, (label, theta, scale, reflection)) in p
        .steps
        .iter()
        .zip([("0.5:0.8:-1", 0.5, 0.8, -1), ("0:1:1", 0.0, 1.0, 1)])
    {
        assert_eq!(step.label, label);
        let c = step.condition;
        assert_eq!((c.theta, c.scale, c.reflection), (theta, scale, reflection));
        assert_eq!(step.nominal.len(), keep);
        assert_eq!(
            (step.nominal.q.len(), step.nominal.qdot.len()),
            (keep * n, keep * n)
        );
        assert_eq!(step.nominal.x.len(), keep * m);
    }
    // The identity condition's nominal is the demonstration itself, cut.
    assert!(max_diff(&p.steps[1].nominal.q, &d.q[..keep * n]) < 1e-9);
    assert!(max_diff(&p.steps[1].nominal.x, &d.x[..keep * m]) < 1e-9);
    // Under (θ, λ, σ) = (0.5, 0.8, −1) the task path moved: its first point differs.
    assert!(max_diff(&p.steps[0].nominal.x[..m], &d.x[..m]) > 1e-3);
    // One offline score per step: the policy rolled out from the step's start.
    assert_eq!(p.offline.len(), 2);
    for (off, step) in p.offline.iter().zip(&p.steps) {
        let want = score(
            &p.policy,
            kin,
            &step.nominal,
            &step.condition,
            &EvalConfig::default(),
        );
        assert!(off.is_finite() && *off >= 0.0, "{off}");
        assert_eq!(*off, want.rmse);
    }
    // The kinematic mock allows no excess by default.
    assert_eq!(p.max_excess, 0.0);

    // Without --duration-s the whole letter is drawn.
    s.conditions = vec!["0:1:1".into()];
    s.duration_s = None;
    let whole = demo::prepare(&s).unwrap();
    assert_eq!(whole.steps[0].nominal.len(), d.len());

    // A non-positive duration is refused before anything is loaded.
    s.duration_s = Some(0.0);
    assert!(matches!(
        demo::prepare(&s),
        Err(DemoError::InvalidSetting {
            flag: "--duration-s",
            ..
        })
    ));

    // Default conditions with a task head of G_RT (trained without the reflection): the
    // two reflected defaults are left out, the other three kept in order.
    s.duration_s = Some(0.2);
    s.conditions.clear();
    s.policy = Some(common::path("data/policies/pi_rt_head_planar.safetensors"));
    let p = demo::prepare(&s).unwrap();
    assert_eq!(
        p.left_out,
        ["reflected", "rot 30° + scale 0.8 + refl"].map(String::from)
    );
    let labels: Vec<&str> = p.steps.iter().map(|s| s.label.as_str()).collect();
    assert_eq!(labels, ["original", "rotated 30°", "scaled 0.8"]);
    assert!(p.steps.iter().all(|s| s.nominal.len() == 21));
}

/// The line `crossym demo` prints (stderr) when it could make no private network namespace.
const FALLBACK: &str = "crossym demo: no private network namespace";

/// `crossym demo` drawing 1 s of the letter under the identity condition into a fresh
/// directory, with `env` set: (exit status, stdout, stderr).
fn short_demo(tag: &str, env: &[(&str, &str)]) -> (std::process::ExitStatus, String, String) {
    let dir = common::temp_dir(tag);
    let mut cmd = common::crossym(["demo", "--duration-s", "1", "--condition", "0:1:1", "--out"]);
    cmd.arg(&dir)
        .current_dir(common::root())
        .env_remove("CROSSYM_PRIVATE_NETNS")
        .env_remove("CROSSYM_DEMO_UNSHARE")
        .envs(env.iter().copied());
    let out = cmd.output().expect("running crossym demo");
    let _ = std::fs::remove_dir_all(&dir);
    (
        out.status,
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// Where no namespace can be made (an unprivileged user where user namespaces are refused,
/// e.g. Ubuntu 24.04; `unshare` missing), forced here with `CROSSYM_DEMO_UNSHARE=/bin/false`:
/// the demo says so in ONE line — each way it tried and why it failed, what it does instead,
/// how to get isolation — then runs localhost-only to `demo: OK`, exit 0 (never a bare
/// `exit 1`). Run inside a network namespace (`.ci/run`: tools/netns-run), as the fallback's
/// DDS is then not isolated by the demo itself.
#[test]
fn demo_without_a_namespace_says_so_in_one_line_and_runs_localhost_only() {
    let (status, stdout, stderr) = short_demo(
        "demo-no-netns",
        &[
            ("CROSSYM_DEMO_UNSHARE", "/bin/false"),
            ("ROS_DOMAIN_ID", "157"),
        ],
    );
    let lines: Vec<&str> = stderr.lines().filter(|l| l.contains(FALLBACK)).collect();
    assert_eq!(
        lines.len(),
        1,
        "want one fallback line\nstdout:\n{stdout}\nstderr:\n{stderr}"
    );
    let line = lines[0];
    assert!(line.starts_with(FALLBACK), "{line}");
    // What failed: the user-namespace way is tried by everyone (root tries `--net` first).
    assert!(
        line.contains("`/bin/false --map-root-user --net`: exited with exit status: 1"),
        "{line}"
    );
    // What it does instead, and what to do.
    assert!(
        line.contains("running localhost-only instead")
            && line.contains("ROS_LOCALHOST_ONLY=1")
            && line.contains("For isolation")
            && line.contains("--no-isolation"),
        "{line}"
    );
    assert!(
        status.success() && stdout.contains("demo: OK"),
        "{status}\nstdout:\n{stdout}\nstderr:\n{stderr}"
    );
    assert!(!stdout.contains("private network namespace"), "{stdout}");
}

/// The demo as the README runs it isolates itself (as root `unshare --net`, as any other
/// user `unshare --map-root-user --net`) and passes there: no fallback line, and the run
/// says it is in a private network namespace. A machine that allows neither is a skip (a
/// failure under `CROSSYM_NO_SKIP`: CI's machine allows them).
#[test]
fn demo_isolates_itself_in_a_private_network_namespace() {
    let (status, stdout, stderr) = short_demo("demo-netns", &[("ROS_DOMAIN_ID", "158")]);
    if let Some(line) = stderr.lines().find(|l| l.contains(FALLBACK)) {
        crate::skip::skip(format!("no namespace for the demo here: {line}"));
        return;
    }
    assert!(
        status.success()
            && stdout.contains("demo: OK")
            && stdout.contains("localhost only, private network namespace)"),
        "{status}\nstdout:\n{stdout}\nstderr:\n{stderr}"
    );
}
