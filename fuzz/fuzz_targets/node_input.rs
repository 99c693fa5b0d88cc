//! Arbitrary bytes as a session of the node's logic (`crossym::control::NodeCore`, no DDS):
//! joint states and symmetry conditions with any field values — names (controlled,
//! duplicated, unknown, renamed, empty), any lengths, any f64 (NaN, ±inf, 1e300, subnormal),
//! any header stamp, any θ / λ / σ — received at any time, interleaved with control ticks at
//! any time (forward, backward, equal, NaN, ±inf: the node's promises have no precondition
//! on the clock). After every tick and the final shutdown command the target asserts what
//! the node promises for a command it publishes: every value finite, velocities within the
//! joint velocity limits, positions (position / trajectory modes) within the joint limits.
//!
//! The robot, policy and `[node]` settings are `config/letters.toml`'s (planar dual arm,
//! shipped `data/policies/pi_mrt_planar`, loaded once); the first bytes of an input pick the
//! output mode, stamp checks, trained-domain checks, the end-effector barrier, the policy
//! (shipped, synthetic, or synthetic with fuzzed output weights and biases — up to
//! non-finite outputs), the control period and stale timeout, and whether inputs reach the
//! tick directly or through a separate `InputGate` + `load_inputs` (as `ros::node` does).
#![no_main]

use std::path::Path;
use std::sync::OnceLock;

use libfuzzer_sys::fuzz_target;

use crossym::config::Config;
use crossym::kinematics::{JointLimits, Kinematics};
use crossym::policy::{MlpInference, MlpSpec, Normalizer, Policy, PolicyMeta};
use crossym::msg::{Header, JointState, SymmetryCondition, Time};
use crossym::control::{Command, NodeConfig, NodeCore, OutputMode};

struct Setup {
    kin: Kinematics,
    node: NodeConfig,
    shipped: Policy,
    synthetic: Policy,
}

fn setup() -> &'static Setup {
    static SETUP: OnceLock<Setup> = OnceLock::new();
    SETUP.get_or_init(|| {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../config/letters.toml");
        let cfg = Config::from_file(&path).expect("config/letters.toml loads");
        let robot = cfg.load_robot().expect("the planar robot loads");
        let node = cfg.node_config();
        let shipped = Policy::load(node.policy.as_ref().expect("[node] policy"))
            .expect("the shipped planar policy loads");
        let kin = robot.kinematics;
        let synthetic = Policy::synthetic(kin.dof(), kin.joint_names().to_vec(), &[16], 7);
        Setup {
            kin,
            node,
            shipped,
            synthetic,
        }
    })
}

/// Reads the input front to back; zeros once it is exhausted.
struct Input<'a> {
    data: &'a [u8],
}

impl Input<'_> {
    fn is_empty(&self) -> bool {
        self.data.is_empty()
    }

    fn bytes<const N: usize>(&mut self) -> [u8; N] {
        let mut b = [0u8; N];
        let k = N.min(self.data.len());
        b[..k].copy_from_slice(&self.data[..k]);
        self.data = &self.data[k..];
        b
    }

    fn u8(&mut self) -> u8 {
        self.bytes::<1>()[0]
    }

    fn u16(&mut self) -> u16 {
        u16::from_le_bytes(self.bytes())
    }

    fn i32(&mut self) -> i32 {
        i32::from_le_bytes(self.bytes())
    }

    fn u32(&mut self) -> u32 {
        u32::from_le_bytes(self.bytes())
    }

    fn raw_f64(&mut self) -> f64 {
        f64::from_le_bytes(self.bytes())
    }

    /// Any f64, biased toward the values that matter: small ones, ones near a joint limit
    /// (`near`), and the special ones.
    fn f64(&mut self, near: Option<&JointLimits>) -> f64 {
        let sign = |x: f64, b: u8| if b & 0x80 != 0 { -x } else { x };
        match self.u8() % 16 {
            0..=5 => f64::from(self.u16() as i16) * 1e-3,
            6 => {
                let b = self.u8();
                let step = f64::from(b as i8) * 1e-4;
                match near {
                    Some(l) if b & 1 == 0 => l.lower + step,
                    Some(l) => l.upper + step,
                    None => step,
                }
            }
            7 => self.raw_f64(),
            8 => f64::NAN,
            9 => f64::INFINITY,
            10 => f64::NEG_INFINITY,
            11 => {
                let b = self.u8();
                sign(1e300, b)
            }
            12 => {
                let b = self.u8();
                sign(f64::MAX, b)
            }
            13 => {
                let b = self.u8();
                sign(
                    if b & 1 == 0 {
                        f64::MIN_POSITIVE
                    } else {
                        5e-324
                    },
                    b,
                )
            }
            14 => -0.0,
            _ => f64::from(self.i32()),
        }
    }

    /// A joint name: a controlled one (most often), an unknown, renamed, empty or raw one.
    fn name(&mut self, names: &[String]) -> String {
        match self.u8() % 10 {
            0..=4 => names[usize::from(self.u8()) % names.len()].clone(),
            5 => ["torso_0", "head_0", "wheel_left", "base"][usize::from(self.u8() % 4)].into(),
            6 => {
                let n = &names[usize::from(self.u8()) % names.len()];
                match self.u8() % 4 {
                    0 => n.to_uppercase(),
                    1 => format!("{n} "),
                    2 => format!("/{n}"),
                    _ => n[..n.len().saturating_sub(1)].to_string(),
                }
            }
            7 => String::new(),
            _ => {
                let len = usize::from(self.u8() % 12);
                let raw: Vec<u8> = (0..len).map(|_| self.u8()).collect();
                String::from_utf8_lossy(&raw).into_owned()
            }
        }
    }

    /// A header stamp relative to the clock `now` (s).
    fn stamp(&mut self, now: f64) -> Time {
        match self.u8() % 8 {
            0 | 1 => Time::default(),
            2 | 3 => Time::from_secs_f64(now),
            4 => Time::from_secs_f64(now - f64::from(self.u16()) * 1e-4),
            5 => Time::from_secs_f64(now + f64::from(self.u16()) * 1e-4),
            6 => Time {
                sec: self.i32(),
                nanosec: self.u32(),
            },
            _ => Time::from_secs_f64(self.f64(None)),
        }
    }
}

fn joint_state(inp: &mut Input, names: &[String], limits: &[JointLimits], now: f64) -> JointState {
    let mut m = JointState {
        header: Header {
            stamp: inp.stamp(now),
            frame_id: String::new(),
        },
        ..Default::default()
    };
    let mode = inp.u8();
    if !mode.is_multiple_of(4) {
        // Every controlled joint once (rotated), perhaps with extra unknown joints.
        let n = names.len();
        let rot = usize::from(inp.u8()) % n;
        let extra = usize::from(mode >> 5);
        for k in 0..n {
            let j = (k + rot) % n;
            m.name.push(names[j].clone());
            let v = inp.f64(Some(&limits[j]));
            m.position.push(v);
        }
        for _ in 0..extra {
            m.name.insert(0, inp.name(names));
            m.position.insert(0, inp.f64(None));
        }
    } else {
        // Anything: independent name and position counts.
        let names_len = usize::from(inp.u8() % 20);
        let positions_len = if mode & 0x10 != 0 {
            usize::from(inp.u8() % 20)
        } else {
            names_len
        };
        for _ in 0..names_len {
            m.name.push(inp.name(names));
        }
        for k in 0..positions_len {
            let v = inp.f64(limits.get(k));
            m.position.push(v);
        }
    }
    // velocity / effort are not read by the node; give them a length anyway.
    if mode & 0x08 != 0 {
        m.velocity = vec![inp.f64(None); usize::from(inp.u8() % 4)];
    }
    m
}

fn condition(inp: &mut Input, now: f64) -> SymmetryCondition {
    let stamp = Time::from_secs_f64(now);
    let kind = inp.u8();
    let (theta, scale, reflection) = if kind.is_multiple_of(2) {
        // Plausible: θ ∈ ±32 rad, λ ∈ [0, 1.3], σ = ±1.
        let theta = f64::from(inp.u16() as i16) * 1e-3;
        let scale = f64::from(inp.u8()) / 200.0;
        (theta, scale, if kind & 2 == 0 { 1 } else { -1 })
    } else {
        (inp.f64(None), inp.f64(None), inp.u8() as i8)
    };
    SymmetryCondition {
        header: Header {
            stamp,
            frame_id: String::new(),
        },
        theta,
        scale,
        reflection,
    }
}

/// A synthetic policy whose output layer has the fuzzed weight scale and biases (finite,
/// possibly huge: its outputs may overflow to ±inf). `None` when the MLP rejects them.
fn fuzzed_policy(inp: &mut Input, n: usize) -> Option<Policy> {
    let hidden = 6;
    let spec = MlpSpec {
        input: n + 4,
        hidden: vec![hidden],
        output: n,
        activation: Default::default(),
    };
    let w0: Vec<f64> = (0..hidden * (n + 4))
        .map(|k| 0.3 * (k as f64 * 0.7).sin())
        .collect();
    let scale = inp.f64(None);
    let w1: Vec<f64> = (0..n * hidden)
        .map(|k| scale * (k as f64 * 1.3).cos())
        .collect();
    let b1: Vec<f64> = (0..n).map(|_| inp.f64(None)).collect();
    let mlp = MlpInference::new(spec, vec![w0, w1], vec![vec![0.01; hidden], b1]).ok()?;
    Policy::new(Normalizer::identity(n), mlp, PolicyMeta::default()).ok()
}

/// The node's promises for a command it publishes.
fn check(core: &NodeCore, cmd: &Command, publish: bool, what: &str, now: f64) {
    if !publish {
        return;
    }
    let limits = core.limits();
    assert_eq!(cmd.data().len(), limits.len(), "{what}: command length");
    for (j, v) in cmd.data().iter().enumerate() {
        assert!(v.is_finite(), "{what} at t = {now}: data[{j}] = {v}");
    }
    let velocities_published = cmd.mode != OutputMode::Position;
    if velocities_published {
        for (j, (v, l)) in cmd.velocities.iter().zip(limits).enumerate() {
            assert!(v.is_finite(), "{what} at t = {now}: velocity[{j}] = {v}");
            let vmax = l.velocity * (1.0 + 1e-9) + 1e-12;
            assert!(
                v.abs() <= vmax,
                "{what} at t = {now}: velocity[{j}] = {v} beyond ±{}",
                l.velocity
            );
        }
    }
    if cmd.mode != OutputMode::Velocity {
        for (j, (p, l)) in cmd.positions.iter().zip(limits).enumerate() {
            assert!(
                p.is_finite() && *p >= l.lower && *p <= l.upper,
                "{what} at t = {now}: position[{j}] = {p} outside [{}, {}]",
                l.lower,
                l.upper
            );
        }
    }
}

fuzz_target!(|data: &[u8]| {
    let s = setup();
    let mut inp = Input { data };
    let n = s.kin.dof();
    let names = s.kin.joint_names().to_vec();
    let limits = s.kin.limits().to_vec();

    // Settings.
    let flags = inp.u8();
    let timing = inp.u8();
    let mut cfg = s.node.clone();
    cfg.output = match flags & 3 {
        1 => OutputMode::Position,
        2 => OutputMode::Trajectory,
        _ => OutputMode::Velocity,
    };
    cfg.check_stamps = flags & 4 == 0;
    cfg.accept_untrained_conditions = flags & 8 != 0;
    cfg.period_s = [0.01, 0.002, 0.05, 0.001][usize::from(timing & 3)];
    cfg.stale_timeout_s = cfg.period_s * [10.0, 1.0, 2.5, 100.0][usize::from((timing >> 2) & 3)];
    let mut safety = cfg.safety;
    if flags & 16 != 0 {
        safety.min_ee_distance = Some([0.5, 0.0, 3.0, 100.0][usize::from((timing >> 4) & 3)]);
    }
    let policy = match (flags >> 5) & 3 {
        0 => s.shipped.clone(),
        1 | 2 => s.synthetic.clone(),
        _ => match fuzzed_policy(&mut inp, n) {
            Some(p) => p,
            None => return,
        },
    };
    let via_gate = flags & 0x80 != 0;
    let Ok(mut core) = NodeCore::new(s.kin.clone(), policy, safety, cfg) else {
        return;
    };
    let mut gate = core.input_gate();
    let mut cmd = core.command();
    let mut now = if timing & 0x40 != 0 { 1.7e9 } else { 0.0 };
    let period = core.config().period_s;

    // At most 64 inputs and ticks per session: a tick of the shipped policy is the
    // expensive part (its MLP is 128 × 128 × 128 wide).
    let mut ops = 0;
    while !inp.is_empty() && ops < 64 {
        ops += 1;
        match inp.u8() % 12 {
            0..=2 => {
                let m = joint_state(&mut inp, &names, &limits, now);
                let at = match inp.u8() % 4 {
                    0 => now - f64::from(inp.u8()) * 1e-3,
                    1 => inp.f64(None),
                    _ => now,
                };
                let r = if via_gate {
                    gate.on_joint_state(&m, at)
                } else {
                    core.on_joint_state(&m, at)
                };
                if let Err(e) = r {
                    let _ = gate.explain(&e);
                }
            }
            3 => {
                let m = condition(&mut inp, now);
                let r = if via_gate {
                    gate.on_condition(&m)
                } else {
                    core.on_condition(&m)
                };
                if let Err(e) = r {
                    let _ = gate.explain(&e);
                }
            }
            op => {
                // Clock: forward by a fraction of the period (most often), back, or anywhere.
                now = match op {
                    4..=7 => now + f64::from(inp.u8()) * period * 0.25,
                    8 => now,
                    9 => now - f64::from(inp.u16()) * 1e-3,
                    10 => now + f64::from(inp.u16()) * period,
                    _ => inp.f64(None),
                };
                if via_gate {
                    core.load_inputs(gate.inputs());
                }
                let report = core.tick(now, &mut cmd);
                check(&core, &cmd, report.publish, "tick", now);
                core.record_tick_time(12.5);
                let status = core.status();
                let _ = status.to_msg(Time::from_secs_f64(now), &names);
            }
        }
    }
    let publish = core.shutdown_command(&mut cmd);
    check(&core, &cmd, publish, "shutdown", now);
});
