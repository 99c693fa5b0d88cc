//! Canonicalised policies from the outside: `crossym node` runs a *canonicalised* policy
//! `π(q, s) = dΦ_g|_{q₀} π₀(q₀)`, `q₀ = Φ_g⁻¹(q)` (the shipped π_MRT used as `π₀`) as a
//! separate process over DDS, against `crossym mock-hw` integrating its velocity commands.
//! The test process publishes conditions and reads `~/status`, the commands and the joint
//! states over DDS:
//!
//! - an off-grid condition feasible from the robot's state is accepted, and so is one
//!   outside the box the plain policy was trained on;
//! - a condition whose canonical pen point `g⁻¹·f(q)` lies beyond the arm's reach is
//!   rejected with the reason, the previous condition is kept, and the commands go on,
//!   finite and inside the URDF's limits. That the condition is infeasible is shown here
//!   without the code under test: forward kinematics, reach and limits come from the
//!   URDF (roxmltree, not crossym's parser) and the task-space action is written in closed
//!   form (rotation about the origin, scaling about the origin, the mirror across the
//!   x-axis swapping the arms; `config/letters.toml` gives `R` and `S` no `center`);
//! - a run recorded with `--record` under these conditions replays bit for bit.
//!
//! The robot starts at the first demonstration's first sample (`[mock_hw] initial_q`),
//! where these conditions were measured with the library before the tests were written:
//! from the rest posture `[check] reference_q` even λ = 0.73 is infeasible (the pen is
//! already 8.9 of the reach 12 from the base). Run inside `tools/netns-run`;
//! ROS_DOMAIN_ID 111 and 112 (no other test uses them).

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

use crossym::bag::Bag;
use crossym::config::Config;
use crossym::control::{NodeCore, StatusCode};
use crossym::kinematics::Kinematics;
use crossym::msg;
use crossym::policy::{AnyPolicy, ConditionDomain, DomainViolation, Policy};
use crossym::ros::dds::{self, DdsSettings, DiscoveryRange};
use crossym::ros::replay::{replay, ReplayTopics};
use crossym::sim::MockHwSummary;
use crossym::symmetry::compose::Condition;

use crate::common;
use crate::common::{log_tail, Proc};

/// Off the training grid (θ on neither the 30° nor the 15° grid, λ between 0.7 and 0.8),
/// reflected; feasible from the start and along the closed loop (measured with the library).
const FEASIBLE: Condition = Condition {
    theta: 0.296_705_972_839_036,
    scale: 0.73,
    reflection: -1,
};

/// θ = −100°, λ = 0.37: the canonical pen point is the pen's position scaled by 1/0.37
/// about the base, beyond the arm's reach wherever the robot is during the test.
const INFEASIBLE: Condition = Condition {
    theta: -1.745_329_251_994_33,
    scale: 0.37,
    reflection: 1,
};

/// λ = 1.2 lies outside the plain π_MRT's trained box (λ ∈ [0.5, 1]), but the canonical
/// point (the pen scaled by 1/1.2) is within reach: the canonicalised node accepts it.
const OUTSIDE_BOX: Condition = Condition {
    theta: 0.296_705_972_839_036,
    scale: 1.2,
    reflection: -1,
};

/// Generous deadline of every wait on DDS traffic (normally met within a second or two).
const DEADLINE: Duration = Duration::from_secs(30);

/// Ticks (commands) the node runs under a condition before the next step.
const TICKS_PER_STEP: u64 = 100;

/// The canonicalised copy of the shipped policy and a config driving the node with it.
struct Setup {
    dir: PathBuf,
    config: PathBuf,
    cfg: Config,
    kin: Kinematics,
    /// The controlled joints (command order).
    joints: Vec<String>,
    /// Where mock-hw starts: the first demonstration's first sample (rad).
    start: Vec<f64>,
    /// The plain π_MRT the canonicalised policy was made from.
    plain: Policy,
    /// The URDF the config names.
    urdf: PathBuf,
}

/// Canonicalises `data/policies/pi_mrt_planar.safetensors` by `config/letters.toml`'s
/// composition into `<tmp>/pi_eq.safetensors` and writes `letters_eq.toml`: the letters
/// config with absolute paths, `[node] policy` the copy and mock-hw starting at `start`.
fn setup(tag: &str) -> Setup {
    let root = common::root();
    let (cfg0, robot, demos) = common::task("letters.toml");
    let kin = robot.kinematics;
    let start = demos.demos[0].q(0).to_vec();
    let plain = Policy::load(root.join("data/policies/pi_mrt_planar.safetensors")).unwrap();
    assert!(
        plain.meta.canonicalised.is_none(),
        "the shipped π_MRT is plain"
    );
    let any = crossym::pipeline::canonicalise(&cfg0, &kin, plain.clone()).unwrap();
    assert!(matches!(any, AnyPolicy::Canonicalised(_)));
    let dir = common::temp_dir(&format!("eqnode-{tag}"));
    let policy = dir.join("pi_eq.safetensors");
    any.network().save(&policy).unwrap();
    let side = std::fs::read_to_string(dir.join("pi_eq.json")).unwrap();
    assert!(side.contains("\"canonicalised\""), "sidecar:\n{side}");

    let text = std::fs::read_to_string(root.join("config/letters.toml")).unwrap();
    let mut text = text.replace("\"../", &format!("\"{}/", root.display()));
    let shipped = format!(
        "policy = \"{}/data/policies/pi_mrt_head_planar.safetensors\"",
        root.display()
    );
    assert!(
        text.contains(&format!("\n{shipped}")),
        "letters.toml's [node] policy"
    );
    text = text.replace(
        &format!("\n{shipped}"),
        &format!("\npolicy = \"{}\"", policy.display()),
    );
    let p = text
        .find("\n[mock_hw]")
        .expect("letters.toml has [mock_hw]");
    text.truncate(p + 1);
    let q: Vec<String> = start.iter().map(|v| format!("{v:?}")).collect();
    text.push_str(&format!(
        "\n[mock_hw]\nrate_hz = 200.0\ninitial_q = [{}]\n",
        q.join(", ")
    ));
    let config = dir.join("letters_eq.toml");
    std::fs::write(&config, text).unwrap();
    let cfg = Config::from_file(&config).unwrap();
    // The node will load the copy as a canonicalised policy by the config's composition.
    let node = cfg.node_config();
    assert_eq!(node.policy.as_deref(), Some(policy.as_path()));
    let loaded = crossym::pipeline::load_any_policy(&cfg, &kin, &policy).unwrap();
    assert!(
        loaded.composition().is_some(),
        "the copy loads canonicalised"
    );
    assert_eq!(
        cfg.mock_hw.as_ref().unwrap().initial_q.as_ref(),
        Some(&start)
    );
    let urdf = cfg.resolve(&cfg.robot.urdf);
    Setup {
        dir,
        config,
        joints: kin.joint_names().to_vec(),
        cfg,
        kin,
        start,
        plain,
        urdf,
    }
}

// ---------------------------------------------------------------------------------------
// The robot read from its URDF without crossym, and the task-space action in closed form
// ---------------------------------------------------------------------------------------

/// One joint of a chain: its origin's planar offset, and whether it turns about z.
struct UrdfJoint {
    offset: [f64; 2],
    /// The controlled joint's index (command order) of a revolute joint.
    controlled: Option<usize>,
}

/// The planar dual arm as its URDF states it: both chains from `base` and the limits of
/// the controlled joints (command order).
struct UrdfRobot {
    /// Left (`left_ee`) and right (`right_ee`) chains, base → tip.
    arms: [Vec<UrdfJoint>; 2],
    lower: Vec<f64>,
    upper: Vec<f64>,
    velocity: Vec<f64>,
}

fn parse_vec(s: Option<&str>, default: [f64; 3]) -> [f64; 3] {
    match s {
        None => default,
        Some(s) => {
            let v: Vec<f64> = s
                .split_whitespace()
                .map(|t| t.parse().expect("a number"))
                .collect();
            assert_eq!(v.len(), 3, "{s}");
            [v[0], v[1], v[2]]
        }
    }
}

impl UrdfRobot {
    fn load(path: &Path, controlled: &[String]) -> UrdfRobot {
        let text = std::fs::read_to_string(path).unwrap();
        let doc = roxmltree::Document::parse(&text).unwrap();
        let n = controlled.len();
        let (mut lower, mut upper, mut velocity) =
            (vec![f64::NAN; n], vec![f64::NAN; n], vec![f64::NAN; n]);
        // child link → (parent link, joint)
        let mut up = std::collections::HashMap::new();
        for j in doc.descendants().filter(|e| e.has_tag_name("joint")) {
            let name = j.attribute("name").unwrap();
            let kind = j.attribute("type").unwrap();
            let child = |tag: &str| {
                j.children()
                    .find(|c| c.has_tag_name(tag))
                    .and_then(|c| c.attribute("link"))
                    .unwrap()
                    .to_string()
            };
            let origin = j.children().find(|c| c.has_tag_name("origin"));
            let xyz = parse_vec(origin.and_then(|o| o.attribute("xyz")), [0.0; 3]);
            let rpy = parse_vec(origin.and_then(|o| o.attribute("rpy")), [0.0; 3]);
            assert_eq!(
                rpy, [0.0; 3],
                "{name}: planar FK below assumes no rotated origins"
            );
            assert_eq!(xyz[2], 0.0, "{name}: planar");
            let k = controlled.iter().position(|c| c == name);
            if kind != "fixed" {
                assert_eq!(kind, "revolute", "{name}");
                let axis = j.children().find(|c| c.has_tag_name("axis")).unwrap();
                assert_eq!(
                    parse_vec(axis.attribute("xyz"), [1.0, 0.0, 0.0]),
                    [0.0, 0.0, 1.0],
                    "{name}: about z"
                );
                let k = k.unwrap_or_else(|| panic!("{name} is not controlled"));
                let lim = j.children().find(|c| c.has_tag_name("limit")).unwrap();
                let a = |key: &str| lim.attribute(key).unwrap().parse::<f64>().unwrap();
                (lower[k], upper[k], velocity[k]) = (a("lower"), a("upper"), a("velocity"));
            }
            up.insert(
                child("child"),
                (
                    child("parent"),
                    UrdfJoint {
                        offset: [xyz[0], xyz[1]],
                        controlled: k.filter(|_| kind != "fixed"),
                    },
                ),
            );
        }
        let mut chain = |tip: &str| {
            let mut link = tip.to_string();
            let mut joints = Vec::new();
            while link != "base" {
                let (parent, j) = up.remove(&link).unwrap_or_else(|| panic!("{link}"));
                joints.push(j);
                link = parent;
            }
            joints.reverse();
            joints
        };
        let arms = [chain("left_ee"), chain("right_ee")];
        assert!(
            lower
                .iter()
                .chain(&upper)
                .chain(&velocity)
                .all(|v| v.is_finite()),
            "every controlled joint has a <limit>"
        );
        UrdfRobot {
            arms,
            lower,
            upper,
            velocity,
        }
    }

    /// The pens `(x_l, y_l, x_r, y_r)` at `q` (command order).
    fn fk(&self, q: &[f64]) -> [f64; 4] {
        let mut x = [0.0; 4];
        for (a, arm) in self.arms.iter().enumerate() {
            let (mut px, mut py, mut angle) = (0.0, 0.0, 0.0);
            for j in arm {
                let (s, c) = f64::sin_cos(angle);
                px += c * j.offset[0] - s * j.offset[1];
                py += s * j.offset[0] + c * j.offset[1];
                if let Some(k) = j.controlled {
                    angle += q[k];
                }
            }
            (x[2 * a], x[2 * a + 1]) = (px, py);
        }
        x
    }

    /// An upper bound of the distance of arm `a`'s pen from the base: the sum of its
    /// link lengths (triangle inequality; both bases sit at the origin).
    fn reach(&self, a: usize) -> f64 {
        self.arms[a]
            .iter()
            .map(|j| j.offset[0].hypot(j.offset[1]))
            .sum()
    }
}

/// `g(s)⁻¹ x` for `g(s) = ρ(σ) ∘ R(θ) ∘ S(λ)` on `X = R²×R²` (left pen, right pen):
/// `R` turns both pens by `θ` about the origin, `S` scales them by `λ` about the origin,
/// `ρ(−1)` mirrors across the x-axis and swaps the arms (the URDF's mirror symmetry).
fn canonical_point(s: &Condition, x: &[f64; 4]) -> [f64; 4] {
    let y = if s.reflection == -1 {
        [x[2], -x[3], x[0], -x[1]]
    } else {
        *x
    };
    let (sn, cs) = f64::sin_cos(-s.theta);
    let mut out = [0.0; 4];
    for a in 0..2 {
        let (px, py) = (y[2 * a], y[2 * a + 1]);
        out[2 * a] = (cs * px - sn * py) / s.scale;
        out[2 * a + 1] = (sn * px + cs * py) / s.scale;
    }
    out
}

/// The larger distance of the two canonical pens from the base, each over its arm's reach.
fn reach_ratio(robot: &UrdfRobot, s: &Condition, q: &[f64]) -> f64 {
    let c = canonical_point(s, &robot.fk(q));
    (0..2)
        .map(|a| c[2 * a].hypot(c[2 * a + 1]) / robot.reach(a))
        .fold(0.0, f64::max)
}

/// The independent model agrees with crossym's robot (FK) and group (`g⁻¹` of the
/// canonicalised policy's stored task action), so its verdicts are about the same things;
/// and no configuration within the limits puts a pen beyond the reach bound (20 000 random
/// ones get within 1 % of it).
fn check_model(t: &Setup, robot: &UrdfRobot) {
    let mut rng = common::rng(18);
    let mut kws = t.kin.workspace();
    let any = crossym::pipeline::canonicalise(&t.cfg, &t.kin, t.plain.clone()).unwrap();
    let map = &any.composition().unwrap().task;
    let mut best = [0.0f64; 2];
    for k in 0..20_000 {
        let q = common::random_q(&mut rng, t.kin.limits());
        let x = robot.fk(&q);
        for a in 0..2 {
            let r = x[2 * a].hypot(x[2 * a + 1]);
            assert!(r <= robot.reach(a) + 1e-9, "{q:?}: pen {a} at {r}");
            best[a] = best[a].max(r);
        }
        if k < 50 {
            let theirs = t.kin.forward(&q, &mut kws);
            for i in 0..4 {
                assert!(
                    (theirs[i] - x[i]).abs() < 1e-9,
                    "FK {q:?}: {theirs} vs {x:?}"
                );
            }
            for s in [FEASIBLE, INFEASIBLE, OUTSIDE_BOX] {
                let mine = canonical_point(&s, &x);
                let (mut out, mut h, mut h2) = ([0.0; 4], [0.0; 4], [0.0; 4]);
                map.apply_inverse(&s, &x, &mut out, &mut h, &mut h2);
                for i in 0..4 {
                    assert!(
                        (out[i] - mine[i]).abs() < 1e-9 * (1.0 + mine[i].abs()),
                        "g⁻¹ of {s:?} at {x:?}: crossym {out:?}, closed form {mine:?}"
                    );
                }
            }
        }
    }
    for (a, best) in best.iter().enumerate() {
        assert!(
            *best >= 0.99 * robot.reach(a),
            "arm {a}: max |f(q)| {best} vs reach bound {}",
            robot.reach(a)
        );
    }
}

// ---------------------------------------------------------------------------------------
// The DDS side of the test
// ---------------------------------------------------------------------------------------

/// The test's DDS participant: publishes conditions, keeps every status, command and joint
/// state it receives (with its arrival time).
struct Observer {
    cond_pub: ros2_client::Publisher<msg::SymmetryCondition>,
    status_sub: ros2_client::Subscription<msg::Status>,
    cmd_sub: ros2_client::Subscription<msg::Float64MultiArray>,
    js_sub: ros2_client::Subscription<msg::JointState>,
    joints: Vec<String>,
    statuses: Vec<(Instant, msg::Status)>,
    commands: Vec<(Instant, Vec<f64>)>,
    /// Joint positions in command order.
    joint_states: Vec<(Instant, Vec<f64>)>,
    _node: ros2_client::Node,
    _ctx: ros2_client::Context,
}

impl Observer {
    fn new(domain: u16, cfg: &Config, joints: &[String]) -> Observer {
        let n = cfg.node.as_ref().unwrap();
        let topic = |t: &str| dds::expand_topic(t, &n.namespace, &n.name);
        let ctx = DdsSettings {
            domain_id: domain,
            range: DiscoveryRange::Localhost,
            distro: dds::DEFAULT_DISTRO,
            security: Default::default(),
        }
        .context()
        .unwrap();
        let mut node = ctx
            .new_node(
                dds::node_name("/", &format!("crossym_test_eq_{}", std::process::id())).unwrap(),
                ros2_client::NodeOptions::new().enable_rosout(false),
            )
            .unwrap();
        let q = || dds::qos_reliable(1000);
        Observer {
            cond_pub: dds::publisher(&mut node, &topic(&n.topics.symmetry_condition), q()).unwrap(),
            status_sub: dds::subscription(&mut node, &topic(&n.topics.status), q()).unwrap(),
            cmd_sub: dds::subscription(&mut node, &topic(&n.topics.command), q()).unwrap(),
            js_sub: dds::subscription(&mut node, &topic(&n.topics.joint_states), q()).unwrap(),
            joints: joints.to_vec(),
            statuses: Vec::new(),
            commands: Vec::new(),
            joint_states: Vec::new(),
            _node: node,
            _ctx: ctx,
        }
    }

    /// Takes everything that arrived.
    fn pump(&mut self) {
        let now = Instant::now();
        while let Ok(Some((s, _))) = self.status_sub.take() {
            self.statuses.push((now, s));
        }
        while let Ok(Some((c, _))) = self.cmd_sub.take() {
            self.commands.push((now, c.data));
        }
        while let Ok(Some((m, _))) = self.js_sub.take() {
            let q: Vec<f64> = self
                .joints
                .iter()
                .map(|j| {
                    let k = m
                        .name
                        .iter()
                        .position(|n| n == j)
                        .expect("controlled joint");
                    m.position[k]
                })
                .collect();
            self.joint_states.push((now, q));
        }
    }

    /// Pumps until `done` holds (true) or `DEADLINE` passes (false).
    fn wait(&mut self, mut done: impl FnMut(&Observer) -> bool) -> bool {
        let deadline = Instant::now() + DEADLINE;
        loop {
            self.pump();
            if done(self) {
                return true;
            }
            if Instant::now() > deadline {
                return false;
            }
            std::thread::sleep(Duration::from_millis(5));
        }
    }

    fn last_status(&self) -> &msg::Status {
        &self.statuses.last().expect("a status").1
    }

    fn publish(&self, s: &Condition) {
        self.cond_pub
            .publish(msg::SymmetryCondition {
                header: msg::Header::default(),
                theta: s.theta,
                scale: s.scale,
                reflection: s.reflection,
            })
            .unwrap();
    }

    /// Publishes `s` every 200 ms until a status echoes it (the first publication may
    /// precede discovery); the index of the echoing status.
    fn apply(&mut self, s: &Condition, log: &Path) -> usize {
        let deadline = Instant::now() + DEADLINE;
        let mut seen = self.statuses.len();
        let mut last = Instant::now() - Duration::from_secs(1);
        loop {
            if last.elapsed() >= Duration::from_millis(200) {
                self.publish(s);
                last = Instant::now();
            }
            self.pump();
            if let Some(k) = (seen..self.statuses.len()).find(|&k| echoes(&self.statuses[k].1, s)) {
                return k;
            }
            seen = self.statuses.len();
            assert!(
                Instant::now() < deadline,
                "no status echoed {s:?} within {DEADLINE:?}; last status {:?}\n{}",
                self.statuses.last().map(|s| &s.1),
                log_tail(log)
            );
            std::thread::sleep(Duration::from_millis(5));
        }
    }

    /// Waits until the node has ticked `n` more times than in the latest status.
    fn run_ticks(&mut self, n: u64, log: &Path) {
        let t0 = self.last_status().ticks;
        assert!(
            self.wait(|o| o.last_status().ticks >= t0 + n),
            "the node did not tick {n} times within {DEADLINE:?}\n{}",
            log_tail(log)
        );
    }
}

fn echoes(st: &msg::Status, s: &Condition) -> bool {
    let c = &st.condition;
    c.theta == s.theta && c.scale == s.scale && c.reflection == s.reflection
}

fn exe() -> Command {
    Command::new(env!("CARGO_BIN_EXE_crossym"))
}

/// `crossym mock-hw` (summary to `<dir>/mock.json`) and `crossym node` (recording to
/// `record`, if given) on `t`'s config in `domain`.
fn start(t: &Setup, domain: u16, record: Option<&Path>) -> (Proc, Proc, PathBuf, PathBuf) {
    let c = t.config.to_str().unwrap();
    let (hw_log, node_log) = (t.dir.join("mock.log"), t.dir.join("node.log"));
    let mut hw = exe();
    hw.args(["mock-hw", "--config", c, "--summary"])
        .arg(t.dir.join("mock.json"));
    let hw = Proc::spawn(hw, "mock-hw", domain, &hw_log);
    let mut node = exe();
    node.args(["node", "--config", c]);
    if let Some(r) = record {
        node.arg("--record").arg(r);
    }
    let node = Proc::spawn(node, "node", domain, &node_log);
    (hw, node, hw_log, node_log)
}

/// Waits for the node to run on fresh joint states (identity condition, nothing rejected).
fn wait_running(o: &mut Observer, log: &Path) {
    assert!(
        o.wait(|o| o
            .statuses
            .last()
            .is_some_and(|(_, s)| s.code != StatusCode::StaleJointStates as i8 && s.ticks >= 20)
            && !o.joint_states.is_empty()),
        "the node never ran on fresh joint states within {DEADLINE:?}\n{}",
        log_tail(log)
    );
    let s = o.last_status();
    assert!(echoes(s, &Condition::IDENTITY), "{s:?}");
    assert_eq!(s.rejected_conditions, 0, "{s:?}");
}

/// Stops both processes (exit 0 each) and reads the mock hardware's summary.
fn stop(t: &Setup, mut hw: Proc, mut node: Proc, node_log: &Path) -> MockHwSummary {
    assert_eq!(node.term(), 0, "node exit code\n{}", log_tail(node_log));
    assert_eq!(hw.term(), 0, "mock-hw exit code");
    serde_json::from_str(&std::fs::read_to_string(t.dir.join("mock.json")).unwrap()).unwrap()
}

/// Under the canonicalised policy the node accepts an off-grid feasible condition and one
/// outside the plain policy's trained box, and rejects an infeasible one — its infeasibility
/// shown independently (the canonical pen point beyond the URDF's reach from every joint
/// state around its publication) — keeping the previous condition, with commands flowing
/// finite and inside the URDF's velocity limits and the robot inside its position limits.
#[test]
fn canonicalised_node_accepts_feasible_and_rejects_infeasible_conditions() {
    let t0 = Instant::now();
    let t = setup("gate");
    let robot = UrdfRobot::load(&t.urdf, &t.joints);
    check_model(&t, &robot);
    // The plain policy's box: FEASIBLE inside it, OUTSIDE_BOX not.
    let plain_box = ConditionDomain::from_meta(&t.plain.meta).unwrap().unwrap();
    assert_eq!(plain_box.check(&FEASIBLE), Ok(()));
    assert_eq!(plain_box.check(&OUTSIDE_BOX), Err(DomainViolation::Scale));

    let domain = 111u16;
    let (hw, node, _hw_log, log) = start(&t, domain, None);
    let mut o = Observer::new(domain, &t.cfg, &t.joints);
    wait_running(&mut o, &log);
    let q_first = o.joint_states[0].1.clone();
    assert!(
        common::dist(&q_first, &t.start) < 0.5,
        "mock-hw starts at the demonstration's first sample: {q_first:?}"
    );

    // 1. The feasible off-grid condition is accepted.
    let k1 = o.apply(&FEASIBLE, &log);
    let accepted_at = o.statuses[k1].0;
    let st = &o.statuses[k1].1;
    assert_eq!(st.rejected_conditions, 0, "{st:?}");
    assert!(st.last_error.is_empty(), "{st:?}");
    o.run_ticks(TICKS_PER_STEP, &log);
    let moved = common::dist(&o.joint_states.last().unwrap().1, &q_first);
    assert!(
        moved > 0.05,
        "the robot moves under {FEASIBLE:?}: {moved} rad"
    );

    // 2. The infeasible one, published once while the robot moves, is rejected.
    let published = Instant::now();
    o.publish(&INFEASIBLE);
    assert!(
        o.wait(|o| o.last_status().rejected_conditions >= 1),
        "{INFEASIBLE:?} was not rejected within {DEADLINE:?}: last status {:?}\n{}",
        o.last_status(),
        log_tail(&log)
    );
    let k2 = o.statuses.len() - 1;
    let (rejected_at, st) = (o.statuses[k2].0, o.statuses[k2].1.clone());
    assert_eq!(st.rejected_conditions, 1, "{st:?}");
    assert!(st.last_error.contains("infeasible"), "{st:?}");
    assert!(
        echoes(&st, &FEASIBLE),
        "the previous condition is kept: {st:?}"
    );
    assert_eq!(st.code, StatusCode::InvalidInput as i8, "{st:?}");
    eprintln!("rejected: {}", st.last_error);
    // Commands keep coming under the kept condition.
    o.run_ticks(TICKS_PER_STEP, &log);
    let after: Vec<&Vec<f64>> = o
        .commands
        .iter()
        .filter(|(at, _)| *at > rejected_at)
        .map(|(_, c)| c)
        .collect();
    assert!(
        after.len() >= 50,
        "{} commands after the rejection",
        after.len()
    );
    let vmax = after
        .iter()
        .flat_map(|c| c.iter())
        .fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(
        vmax > 1e-4,
        "the robot keeps drawing under {FEASIBLE:?}: |v| ≤ {vmax}"
    );
    for (_, s) in &o.statuses[k2..] {
        assert!(echoes(s, &FEASIBLE) && s.rejected_conditions == 1, "{s:?}");
    }

    // Independently: from every joint state around the publication the canonical pen
    // point lies beyond the arm's reach, so no configuration realises it.
    let window = |from: Instant, to: Instant| -> Vec<&Vec<f64>> {
        o.joint_states
            .iter()
            .filter(|(at, _)| *at >= from && *at <= to)
            .map(|(_, q)| q)
            .collect()
    };
    let around = window(
        published - Duration::from_millis(500),
        rejected_at + Duration::from_millis(100),
    );
    assert!(
        around.len() >= 10,
        "{} joint states around the publication",
        around.len()
    );
    let worst = around
        .iter()
        .map(|q| reach_ratio(&robot, &INFEASIBLE, q))
        .fold(f64::INFINITY, f64::min);
    eprintln!(
        "infeasible: canonical pen ≥ {worst:.3} × reach over {} joint states",
        around.len()
    );
    assert!(worst > 1.05, "canonical pen only {worst} × reach");
    // …whereas the accepted condition's canonical pen was within reach (not excluded).
    let at_accept = window(accepted_at - Duration::from_millis(500), accepted_at);
    let r = at_accept
        .iter()
        .map(|q| reach_ratio(&robot, &FEASIBLE, q))
        .fold(0.0, f64::max);
    assert!(
        !at_accept.is_empty() && r < 1.0,
        "feasible: canonical pen {r} × reach"
    );

    // 3. A condition outside the plain policy's box, feasible, is accepted.
    let k3 = o.apply(&OUTSIDE_BOX, &log);
    o.run_ticks(TICKS_PER_STEP, &log);
    for (_, s) in &o.statuses[k3..] {
        assert_eq!(s.rejected_conditions, 1, "{s:?}");
    }
    let st = o.last_status();
    assert!(echoes(st, &OUTSIDE_BOX), "{st:?}");
    assert_ne!(st.code, StatusCode::InvalidInput as i8, "{st:?}");

    // Throughout: no accepted condition's flow failed, every command finite and inside the
    // URDF's velocity limits, every joint state inside its position limits.
    let codes: Vec<i8> = o.statuses.iter().map(|(_, s)| s.code).collect();
    assert!(
        !codes.contains(&(StatusCode::ConditionInfeasible as i8)),
        "CONDITION_INFEASIBLE seen: {codes:?}"
    );
    let n = t.joints.len();
    for (_, c) in &o.commands {
        assert_eq!(c.len(), n);
        for (j, v) in c.iter().enumerate() {
            assert!(
                v.is_finite() && v.abs() <= robot.velocity[j] + 1e-9,
                "{}: command {v}",
                t.joints[j]
            );
        }
    }
    for (_, q) in &o.joint_states {
        for (j, p) in q.iter().enumerate() {
            assert!(
                *p >= robot.lower[j] - 1e-9 && *p <= robot.upper[j] + 1e-9,
                "{}: position {p}",
                t.joints[j]
            );
        }
    }
    let commands = o.commands.len();
    let s = stop(&t, hw, node, &log);
    assert_eq!(s.violation_count, 0, "{:?}", s.violations);
    assert_eq!(s.commands_invalid, 0, "{s:?}");
    assert!(s.commands_received as usize >= commands / 2, "{s:?}");
    eprintln!(
        "{} statuses, {commands} commands, {} joint states in {:.1} s",
        o.statuses.len(),
        o.joint_states.len(),
        t0.elapsed().as_secs_f64()
    );
}

/// A run of the canonicalised policy recorded by `crossym node --record` — the off-grid
/// condition, the infeasible one rejected mid-motion, then one outside the plain box —
/// replays bit for bit through the node's logic: every recorded command recomputed from
/// its input snapshot (the feasibility gate included) to the same bits, in the library
/// and by `crossym replay`. The plain π_MRT does not reproduce it.
#[test]
fn canonicalised_node_recording_replays_bit_for_bit() {
    let t0 = Instant::now();
    let t = setup("bag");
    let domain = 112u16;
    let bag_dir = t.dir.join("bag");
    let (hw, node, _hw_log, log) = start(&t, domain, Some(&bag_dir));
    let mut o = Observer::new(domain, &t.cfg, &t.joints);
    wait_running(&mut o, &log);
    o.apply(&FEASIBLE, &log);
    o.run_ticks(TICKS_PER_STEP, &log);
    o.publish(&INFEASIBLE);
    assert!(
        o.wait(|o| o.last_status().rejected_conditions >= 1),
        "{INFEASIBLE:?} was not rejected within {DEADLINE:?}\n{}",
        log_tail(&log)
    );
    o.run_ticks(TICKS_PER_STEP / 2, &log);
    o.apply(&OUTSIDE_BOX, &log);
    o.run_ticks(TICKS_PER_STEP, &log);
    let s = stop(&t, hw, node, &log);
    assert_eq!(s.violation_count, 0, "{:?}", s.violations);

    let bag = Bag::open(&bag_dir).unwrap();
    let n = t.cfg.node_config();
    let topics = ReplayTopics::for_node(&n);
    let count = |name: &str| bag.topic(name).map_or(0, |i| bag.topics[i].count);
    let recorded = count(&topics.command);
    // The conditions as the node received them: the accepted ones and the infeasible one.
    let cond = bag.topic(&topics.condition).expect("conditions recorded");
    let got: Vec<Condition> = (0..bag.messages.len())
        .filter(|&i| bag.messages[i].topic == cond)
        .map(|i| {
            let m: msg::SymmetryCondition = bag.decode(i).unwrap();
            Condition {
                theta: m.theta,
                scale: m.scale,
                reflection: m.reflection,
            }
        })
        .collect();
    for s in [FEASIBLE, INFEASIBLE, OUTSIDE_BOX] {
        assert!(got.contains(&s), "{s:?} not in the bag's {got:?}");
    }
    assert_eq!(got.iter().filter(|&&s| s == INFEASIBLE).count(), 1);
    // The recorded statuses show the rejection.
    let st = bag
        .topic(&dds::expand_topic(&n.topics.status, &n.namespace, &n.name))
        .expect("status recorded");
    let rejected = (0..bag.messages.len())
        .filter(|&i| bag.messages[i].topic == st)
        .map(|i| bag.decode::<msg::Status>(i).unwrap())
        .find(|s| s.rejected_conditions == 1)
        .expect("a recorded status after the rejection");
    assert!(rejected.last_error.contains("infeasible"), "{rejected:?}");
    assert!(echoes(&rejected, &FEASIBLE), "{rejected:?}");

    let mut core = crossym::setup::node_core(&t.cfg, n.clone()).unwrap();
    assert!(
        core.policy().composition().is_some(),
        "replayed canonicalised"
    );
    let r = replay(&bag, &mut core, &topics).unwrap();
    eprintln!("replay: {r:?} of {recorded} recorded commands");
    assert!(r.commands >= 2 * TICKS_PER_STEP as usize, "{r:?}");
    assert_eq!(
        r.commands, recorded,
        "every recorded command recomputed: {r:?}"
    );
    assert_eq!(r.unmatched, 0, "{r:?}");
    assert_eq!(r.max(), 0.0, "bit for bit: {r:?}");
    // The CLI says the same.
    let out = exe()
        .arg("replay")
        .arg(&bag_dir)
        .arg("--config")
        .arg(&t.config)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success() && stdout.contains("replay: OK"),
        "{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // The plain policy the canonicalised one was made from does not reproduce the run
    // (accepting every condition, so that only the policy differs).
    let plain_cfg = crossym::control::NodeConfig {
        accept_untrained_conditions: true,
        ..n.clone()
    };
    let mut plain = NodeCore::new(t.kin.clone(), t.plain.clone(), n.safety, plain_cfg).unwrap();
    let r = replay(&bag, &mut plain, &topics).unwrap();
    assert!(r.max() > 1e-6, "the plain policy replays the run: {r:?}");
    eprintln!("bag test in {:.1} s", t0.elapsed().as_secs_f64());
}
