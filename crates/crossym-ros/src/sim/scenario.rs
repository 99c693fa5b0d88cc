//! A closed-loop scenario over DDS: this process plays the user and the observer beside a
//! running node and mock hardware.
//!
//! For each step (a symmetry condition `s` and its nominal trajectory `(q_k, x_k)`,
//! `k = 0…T`, period `Δt`): publish `s` on the node's condition topic until `~/status`
//! echoes it, teleport the mock hardware to `q_0` (reset topic), record `/joint_states` for
//! `T·Δt` seconds, resample the measured `q(t)` at `t_k = kΔt` after the reset (linear
//! interpolation on the header stamps) and score
//! `RMSE = √(1/(T+1) Σ_k ‖f(q(t_k)) − x_k‖²)` (task units), as in `crossym_learn::eval::score`.
//! The status stream gives the tick timing and how often the safety filter intervened.

use std::time::{Duration, Instant};

use ros2_client::NodeOptions;

use crate::dds::{self, DdsError, DdsSettings};
use crossym_control::{NodeConfig, StatusCode};
use crossym_io::msg;
use crossym_math::kinematics::Kinematics;
use crossym_math::symmetry::compose::Condition;
use crossym_policy::JointTrajectory;

/// One step of a scenario.
#[derive(Debug, Clone)]
pub struct ScenarioStep {
    /// Label for reports.
    pub label: String,
    /// The condition to publish.
    pub condition: Condition,
    /// The nominal trajectory (start, duration and the RMSE reference).
    pub nominal: JointTrajectory,
}

/// What one step measured.
#[derive(Debug, Clone, serde::Serialize)]
pub struct StepResult {
    /// Label of the step.
    pub label: String,
    /// The condition.
    pub theta: f64,
    /// Scale λ.
    pub scale: f64,
    /// Reflection σ.
    pub reflection: i8,
    /// Task-space RMSE against the nominal trajectory (task units).
    pub rmse: f64,
    /// Joint-state samples recorded (count).
    pub samples: usize,
    /// Status messages with a safety bound active (count).
    pub statuses_on_bound: usize,
    /// Status messages received during the step (count).
    pub statuses: usize,
    /// Status codes other than NO_WARNING / JOINT_BOUND seen (code values).
    pub abnormal_codes: Vec<i8>,
    /// Median of the reported last-tick durations (µs).
    pub tick_median_us: f64,
    /// Largest reported tick duration (µs).
    pub tick_max_us: f64,
    /// Measured task path at `t_k` (row-major `(T+1) × m`), for plots.
    #[serde(skip)]
    pub path: Vec<f64>,
}

/// Topics the scenario talks to.
#[derive(Debug, Clone)]
pub struct ScenarioTopics {
    /// The node's condition topic (absolute).
    pub condition: String,
    /// The node's status topic (absolute).
    pub status: String,
    /// Joint states.
    pub joint_states: String,
    /// Mock hardware reset.
    pub reset: String,
    /// The node's fully qualified name (its lifecycle services).
    pub node: String,
}

impl ScenarioTopics {
    /// The topics of a node configured by `n` and a mock hardware resetting on `reset`.
    pub fn new(n: &NodeConfig, reset: &str) -> Self {
        Self {
            condition: dds::expand_topic(&n.topics.symmetry_condition, &n.namespace, &n.name),
            status: dds::expand_topic(&n.topics.status, &n.namespace, &n.name),
            joint_states: dds::expand_topic(&n.topics.joint_states, &n.namespace, &n.name),
            reset: reset.to_string(),
            node: format!("{}/{}", n.namespace.trim_end_matches('/'), n.name),
        }
    }
}

/// Errors of a scenario run.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ScenarioError {
    /// DDS setup failed.
    #[error(transparent)]
    Dds(#[from] DdsError),
    /// The node or the mock hardware did not answer in time.
    #[error("timeout: {what}")]
    Timeout {
        /// What we waited for.
        what: String,
    },
    /// The node started inactive and could not be activated.
    #[error("activating the node: {0}")]
    Lifecycle(#[from] crate::lifecycle_client::LifecycleCallError),
    /// Publishing failed.
    #[error("publish on {topic}: {message}")]
    Publish {
        /// Topic.
        topic: String,
        /// Middleware error.
        message: String,
    },
}

/// The scenario's DDS endpoints: it sends conditions and resets, watches joint states and
/// the node's status. `map[j]`: where controlled joint `j` is in the joint states.
struct Endpoints {
    cond_pub: ros2_client::Publisher<msg::SymmetryCondition>,
    reset_pub: ros2_client::Publisher<msg::Float64MultiArray>,
    js_sub: ros2_client::Subscription<msg::JointState>,
    status_sub: ros2_client::Subscription<msg::Status>,
    map: Vec<usize>,
    // Owns the endpoints' participant: kept alive while they are used, and dropped after
    // them (fields drop in order; a participant dropped first leaves the endpoints to
    // remove themselves from a stopped event loop, which RustDDS logs as errors).
    _node: ros2_client::Node,
}

/// Waits until both joint states and a status arrived (within `discovery_timeout`); returns
/// the map of joint-state names onto the controlled order (from the first joint state) and
/// the last status code.
fn first_messages(
    js_sub: &ros2_client::Subscription<msg::JointState>,
    status_sub: &ros2_client::Subscription<msg::Status>,
    topics: &ScenarioTopics,
    joint_names: &[String],
    discovery_timeout: Duration,
) -> Result<(Vec<usize>, i8), ScenarioError> {
    let mut map: Option<Vec<usize>> = None;
    let deadline = Instant::now() + discovery_timeout;
    // The node's status, and one saying it sees the robot's joint states: each pair of
    // participants discovers (and, secured, exchanges keys) on its own, so the node may
    // hear this scenario before it hears the robot.
    let (mut have_js, mut have_status, mut node_sees_robot) = (false, false, false);
    let mut last_code = 0i8;
    let stale = crossym_control::node::StatusCode::StaleJointStates.value();
    while !(have_js && node_sees_robot) {
        if Instant::now() > deadline {
            return Err(ScenarioError::Timeout {
                what: format!(
                    "within {discovery_timeout:?}: joint states on {} {}, status on {} {}",
                    topics.joint_states,
                    if have_js { "seen" } else { "never seen" },
                    topics.status,
                    match (have_status, node_sees_robot) {
                        (false, _) => "never seen",
                        (true, false) => "seen, but the node never saw joint states",
                        (true, true) => "seen",
                    },
                ),
            });
        }
        while let Ok(Some((m, _))) = js_sub.take() {
            have_js = true;
            if map.is_none() {
                map = Some(index_map(&m.name, joint_names)?);
            }
        }
        while let Ok(Some((s, _))) = status_sub.take() {
            have_status = true;
            node_sees_robot = s.joint_state_age_s >= 0.0 && s.code != stale;
            last_code = s.code;
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    Ok((map.expect("set when have_js"), last_code))
}

/// What one step recorded from the reset pose on: joint-state times (s since the reset
/// pose was first reported) and positions (controlled order), and the node's status.
#[derive(Default)]
struct Recording {
    /// Controlled joints.
    n: usize,
    times: Vec<f64>,
    qs: Vec<f64>,
    statuses: usize,
    on_bound: usize,
    abnormal: Vec<i8>,
    tick_us: Vec<f64>,
    tick_max: f64,
}

impl Endpoints {
    /// Creates the endpoints and waits until both joint states and a status arrived (the
    /// first joint state fixes the name map).
    fn connect(
        settings: DdsSettings,
        topics: &ScenarioTopics,
        joint_names: &[String],
        discovery_timeout: Duration,
    ) -> Result<Self, ScenarioError> {
        let ctx = settings.context()?;
        let mut node = ctx
            .new_node(
                dds::node_name("/", &format!("crossym_scenario_{}", std::process::id()))?,
                NodeOptions::new().enable_rosout(false),
            )
            .map_err(|e| DdsError::Create {
                what: "scenario node".into(),
                message: format!("{e:?}"),
            })?;
        let cond_pub = dds::publisher::<msg::SymmetryCondition>(
            &mut node,
            &topics.condition,
            dds::qos_reliable(10),
        )?;
        let reset_pub = dds::publisher::<msg::Float64MultiArray>(
            &mut node,
            &topics.reset,
            dds::qos_reliable(10),
        )?;
        let js_sub = dds::subscription::<msg::JointState>(
            &mut node,
            &topics.joint_states,
            dds::qos_reliable(100),
        )?;
        let status_sub =
            dds::subscription::<msg::Status>(&mut node, &topics.status, dds::qos_reliable(100))?;
        let (map, last_code) =
            first_messages(&js_sub, &status_sub, topics, joint_names, discovery_timeout)?;
        // A node that starts inactive (`[node] autostart = false`, the RB-Y1 configs) runs
        // the policy once someone says so: the scenario activates it, as an operator would
        // with `ros2 lifecycle set <node> activate`.
        if last_code == crossym_control::node::StatusCode::Inactive.value() {
            let client = crate::lifecycle_client::LifecycleClient::new(&ctx, &topics.node)?;
            let state = client.change_state("activate", discovery_timeout)?;
            log::info!(
                "scenario: {} was inactive, now {}",
                topics.node,
                state.label
            );
        }
        Ok(Self {
            _node: node,
            cond_pub,
            reset_pub,
            js_sub,
            status_sub,
            map,
        })
    }

    /// Step 1: publishes condition `c` (every 200 ms) until the node's status echoes it.
    fn send_condition(&self, topics: &ScenarioTopics, c: Condition) -> Result<(), ScenarioError> {
        let cmsg = msg::SymmetryCondition {
            header: msg::Header::default(),
            theta: c.theta,
            scale: c.scale,
            reflection: c.reflection,
        };
        let deadline = Instant::now() + Duration::from_secs(10);
        let mut last_pub = Instant::now() - Duration::from_secs(1);
        loop {
            if Instant::now() > deadline {
                return Err(ScenarioError::Timeout {
                    what: format!("{} never echoed condition {c:?}", topics.status),
                });
            }
            if last_pub.elapsed() >= Duration::from_millis(200) {
                self.cond_pub
                    .publish(cmsg.clone())
                    .map_err(|e| ScenarioError::Publish {
                        topic: topics.condition.clone(),
                        message: format!("{e:?}"),
                    })?;
                last_pub = Instant::now();
            }
            while let Ok(Some((s, _))) = self.status_sub.take() {
                let e = &s.condition;
                if e.theta == c.theta && e.scale == c.scale && e.reflection == c.reflection {
                    return Ok(());
                }
            }
            std::thread::sleep(Duration::from_millis(5));
        }
    }

    /// Step 2: teleports the robot to `q0` and records until `duration` (s) after the
    /// first joint state at `q0`.
    fn record(
        &self,
        topics: &ScenarioTopics,
        label: &str,
        q0: &[f64],
        duration: f64,
        capacity: usize,
    ) -> Result<Recording, ScenarioError> {
        let n = self.map.len();
        self.reset_pub
            .publish(msg::Float64MultiArray {
                layout: msg::MultiArrayLayout::default(),
                data: q0.to_vec(),
            })
            .map_err(|e| ScenarioError::Publish {
                topic: topics.reset.clone(),
                message: format!("{e:?}"),
            })?;
        let mut rec = Recording {
            n,
            times: Vec::with_capacity(capacity),
            qs: Vec::with_capacity(capacity * n),
            ..Recording::default()
        };
        let mut t0: Option<f64> = None;
        let start_wait = Instant::now();
        let mut q = vec![0.0; n];
        loop {
            while let Ok(Some((m, _))) = self.js_sub.take() {
                if m.position.len() != m.name.len() {
                    continue;
                }
                for j in 0..n {
                    q[j] = m.position[self.map[j]];
                }
                let t = m.header.stamp.as_secs_f64();
                if t0.is_none() {
                    // The first state at the reset pose marks t = 0.
                    let at_start = q.iter().zip(q0).all(|(a, b)| (a - b).abs() < 1e-9);
                    if at_start {
                        t0 = Some(t);
                    } else {
                        continue;
                    }
                }
                rec.times.push(t - t0.unwrap_or(t));
                rec.qs.extend_from_slice(&q);
            }
            while let Ok(Some((s, _))) = self.status_sub.take() {
                if t0.is_some() {
                    rec.status(&s);
                }
            }
            if t0.is_none() && start_wait.elapsed() > Duration::from_secs(10) {
                return Err(ScenarioError::Timeout {
                    what: format!(
                        "the mock hardware never reported the reset pose on {}",
                        topics.joint_states
                    ),
                });
            }
            if rec.times.last().is_some_and(|&t| t >= duration) {
                return Ok(rec);
            }
            if start_wait.elapsed() > Duration::from_secs_f64(duration + 30.0) {
                return Err(ScenarioError::Timeout {
                    what: format!("joint states stopped during step `{label}`"),
                });
            }
            std::thread::sleep(Duration::from_millis(2));
        }
    }
}

impl Recording {
    /// Counts one status of the node.
    fn status(&mut self, s: &msg::Status) {
        self.statuses += 1;
        if s.active_constraints > 0 {
            self.on_bound += 1;
        }
        let code = s.code;
        if code != StatusCode::NoWarning as i8
            && code != StatusCode::JointBound as i8
            && !self.abnormal.contains(&code)
        {
            self.abnormal.push(code);
        }
        self.tick_us.push(s.tick_time_us);
        self.tick_max = self.tick_max.max(s.tick_time_max_us);
    }

    /// Step 3: the recording resampled at the nominal's `t_k` (linear interpolation), its
    /// task path and RMSE against the nominal.
    fn score(mut self, kin: &Kinematics, step: &ScenarioStep) -> StepResult {
        let nominal = &step.nominal;
        let c = step.condition;
        let (times, qs, n) = (&self.times, &self.qs, self.n);
        let len = nominal.len();
        let m = nominal.m;
        let mut kws = kin.workspace();
        let mut path = Vec::with_capacity(len * m);
        let mut sum = 0.0;
        let mut qk = vec![0.0; n];
        let mut seg = 0usize;
        for k in 0..len {
            let t = k as f64 * nominal.dt;
            while seg + 1 < times.len() && times[seg + 1] < t {
                seg += 1;
            }
            let (a, b) = (seg, (seg + 1).min(times.len() - 1));
            let w = if b > a && times[b] > times[a] {
                ((t - times[a]) / (times[b] - times[a])).clamp(0.0, 1.0)
            } else {
                0.0
            };
            for j in 0..n {
                qk[j] = (1.0 - w) * qs[a * n + j] + w * qs[b * n + j];
            }
            let x = kin.forward(&qk, &mut kws);
            let e2: f64 = x
                .iter()
                .zip(nominal.x(k))
                .map(|(p, r)| (p - r) * (p - r))
                .sum();
            sum += e2;
            path.extend(x.iter());
        }
        self.tick_us.sort_by(f64::total_cmp);
        StepResult {
            label: step.label.clone(),
            theta: c.theta,
            scale: c.scale,
            reflection: c.reflection,
            rmse: (sum / len as f64).sqrt(),
            samples: self.times.len(),
            statuses_on_bound: self.on_bound,
            statuses: self.statuses,
            tick_median_us: self
                .tick_us
                .get(self.tick_us.len() / 2)
                .copied()
                .unwrap_or(0.0),
            tick_max_us: self.tick_max,
            abnormal_codes: self.abnormal,
            path,
        }
    }
}

/// Runs `steps` against a node + mock hardware already running in the same DDS domain:
/// per step, the condition until the node echoes it, a reset to the nominal's start, the
/// joint states for the nominal's duration, scored against it.
pub fn run(
    settings: DdsSettings,
    topics: &ScenarioTopics,
    kin: &Kinematics,
    joint_names: &[String],
    steps: &[ScenarioStep],
    discovery_timeout: Duration,
) -> Result<Vec<StepResult>, ScenarioError> {
    let ends = Endpoints::connect(settings, topics, joint_names, discovery_timeout)?;
    let mut results = Vec::with_capacity(steps.len());
    for step in steps {
        ends.send_condition(topics, step.condition)?;
        let nominal = &step.nominal;
        let len = nominal.len();
        let duration = (len - 1) as f64 * nominal.dt;
        let rec = ends.record(topics, &step.label, nominal.q(0), duration, len * 3)?;
        results.push(rec.score(kin, step));
    }
    Ok(results)
}

fn index_map(names: &[String], wanted: &[String]) -> Result<Vec<usize>, ScenarioError> {
    wanted
        .iter()
        .map(|w| {
            names
                .iter()
                .position(|n| n == w)
                .ok_or_else(|| ScenarioError::Timeout {
                    what: format!("joint_states lack controlled joint `{w}`"),
                })
        })
        .collect()
}
