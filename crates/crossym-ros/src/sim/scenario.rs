//! A closed-loop scenario over DDS: this process plays the user and the observer beside a
//! running node and mock hardware.
//!
//! For each step (a symmetry condition `s` and its nominal trajectory `(q_k, x_k)`,
//! `k = 0…T`, period `Δt`): publish `s` on the node's condition topic until `~/status`
//! echoes it, teleport the mock hardware to `q_0` (reset topic), record `/joint_states` for
//! `T·Δt` seconds, resample the measured `q(t)` at `t_k = kΔt` after the reset (linear
//! interpolation on the header stamps) and score
//! `RMSE = √(1/(T+1) Σ_k ‖f(q(t_k)) − x_k‖²)` (task units), as in [`crossym_learn::eval::score`].
//! The status stream gives the tick timing and how often the safety filter intervened.

use std::time::{Duration, Instant};

use ros2_client::NodeOptions;

use crate::dds::{self, DdsError, DdsSettings};
use crossym_control::{NodeConfig, StatusCode};
use crossym_io::msg;
use crossym_learn::data::letters::JointTrajectory;
use crossym_math::kinematics::Kinematics;
use crossym_math::symmetry::compose::Condition;

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
}

impl ScenarioTopics {
    /// The topics of a node configured by `n` and a mock hardware resetting on `reset`.
    pub fn new(n: &NodeConfig, reset: &str) -> Self {
        Self {
            condition: dds::expand_topic(&n.topics.symmetry_condition, &n.namespace, &n.name),
            status: dds::expand_topic(&n.topics.status, &n.namespace, &n.name),
            joint_states: dds::expand_topic(&n.topics.joint_states, &n.namespace, &n.name),
            reset: reset.to_string(),
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
    /// Publishing failed.
    #[error("publish on {topic}: {message}")]
    Publish {
        /// Topic.
        topic: String,
        /// Middleware error.
        message: String,
    },
}

/// Runs `steps` against a node + mock hardware already running in the same DDS domain.
pub fn run(
    settings: DdsSettings,
    topics: &ScenarioTopics,
    kin: &Kinematics,
    joint_names: &[String],
    steps: &[ScenarioStep],
    discovery_timeout: Duration,
) -> Result<Vec<StepResult>, ScenarioError> {
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
    let reset_pub =
        dds::publisher::<msg::Float64MultiArray>(&mut node, &topics.reset, dds::qos_reliable(10))?;
    let js_sub = dds::subscription::<msg::JointState>(
        &mut node,
        &topics.joint_states,
        dds::qos_reliable(100),
    )?;
    let status_sub =
        dds::subscription::<msg::Status>(&mut node, &topics.status, dds::qos_reliable(100))?;

    // Map joint-state names onto the controlled order once the first message arrives.
    let n = joint_names.len();
    let mut map: Option<Vec<usize>> = None;
    let mut kws = kin.workspace();
    let deadline = Instant::now() + discovery_timeout;
    let (mut have_js, mut have_status) = (false, false);
    while !(have_js && have_status) {
        if Instant::now() > deadline {
            return Err(ScenarioError::Timeout {
                what: format!(
                    "within {discovery_timeout:?}: joint states on {} {}, status on {} {}",
                    topics.joint_states,
                    if have_js { "seen" } else { "never seen" },
                    topics.status,
                    if have_status { "seen" } else { "never seen" },
                ),
            });
        }
        while let Ok(Some((m, _))) = js_sub.take() {
            have_js = true;
            if map.is_none() {
                map = Some(index_map(&m.name, joint_names)?);
            }
        }
        while let Ok(Some(_)) = status_sub.take() {
            have_status = true;
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    let map = map.expect("set when have_js");

    let mut results = Vec::with_capacity(steps.len());
    for step in steps {
        let c = step.condition;
        let nominal = &step.nominal;
        // 1. The condition, until the node's status echoes it.
        let cmsg = msg::SymmetryCondition {
            header: msg::Header::default(),
            theta: c.theta,
            scale: c.scale,
            reflection: c.reflection,
        };
        let deadline = Instant::now() + Duration::from_secs(10);
        let mut last_pub = Instant::now() - Duration::from_secs(1);
        'echo: loop {
            if Instant::now() > deadline {
                return Err(ScenarioError::Timeout {
                    what: format!("{} never echoed condition {c:?}", topics.status),
                });
            }
            if last_pub.elapsed() >= Duration::from_millis(200) {
                cond_pub
                    .publish(cmsg.clone())
                    .map_err(|e| ScenarioError::Publish {
                        topic: topics.condition.clone(),
                        message: format!("{e:?}"),
                    })?;
                last_pub = Instant::now();
            }
            while let Ok(Some((s, _))) = status_sub.take() {
                let e = &s.condition;
                if e.theta == c.theta && e.scale == c.scale && e.reflection == c.reflection {
                    break 'echo;
                }
            }
            std::thread::sleep(Duration::from_millis(5));
        }
        // 2. Teleport the robot to the start and record until the trajectory's duration.
        let q0 = nominal.q(0).to_vec();
        reset_pub
            .publish(msg::Float64MultiArray {
                layout: msg::MultiArrayLayout::default(),
                data: q0.clone(),
            })
            .map_err(|e| ScenarioError::Publish {
                topic: topics.reset.clone(),
                message: format!("{e:?}"),
            })?;
        let len = nominal.len();
        let duration = (len - 1) as f64 * nominal.dt;
        let mut times: Vec<f64> = Vec::with_capacity(len * 3);
        let mut qs: Vec<f64> = Vec::with_capacity(len * 3 * n);
        let mut t0: Option<f64> = None;
        let mut statuses = 0usize;
        let mut on_bound = 0usize;
        let mut abnormal: Vec<i8> = Vec::new();
        let mut tick_us: Vec<f64> = Vec::new();
        let mut tick_max = 0.0f64;
        let start_wait = Instant::now();
        let mut q = vec![0.0; n];
        loop {
            while let Ok(Some((m, _))) = js_sub.take() {
                if m.position.len() != m.name.len() {
                    continue;
                }
                for j in 0..n {
                    q[j] = m.position[map[j]];
                }
                let t = m.header.stamp.as_secs_f64();
                if t0.is_none() {
                    // The first state at the reset pose marks t = 0.
                    let at_start = q.iter().zip(&q0).all(|(a, b)| (a - b).abs() < 1e-9);
                    if at_start {
                        t0 = Some(t);
                    } else {
                        continue;
                    }
                }
                times.push(t - t0.unwrap_or(t));
                qs.extend_from_slice(&q);
            }
            while let Ok(Some((s, _))) = status_sub.take() {
                if t0.is_none() {
                    continue;
                }
                statuses += 1;
                if s.active_constraints > 0 {
                    on_bound += 1;
                }
                let code = s.code;
                if code != StatusCode::NoWarning as i8
                    && code != StatusCode::JointBound as i8
                    && !abnormal.contains(&code)
                {
                    abnormal.push(code);
                }
                tick_us.push(s.tick_time_us);
                tick_max = tick_max.max(s.tick_time_max_us);
            }
            if t0.is_none() && start_wait.elapsed() > Duration::from_secs(10) {
                return Err(ScenarioError::Timeout {
                    what: format!(
                        "the mock hardware never reported the reset pose on {}",
                        topics.joint_states
                    ),
                });
            }
            if times.last().is_some_and(|&t| t >= duration) {
                break;
            }
            if start_wait.elapsed() > Duration::from_secs_f64(duration + 30.0) {
                return Err(ScenarioError::Timeout {
                    what: format!("joint states stopped during step `{}`", step.label),
                });
            }
            std::thread::sleep(Duration::from_millis(2));
        }
        // 3. Resample at t_k and score.
        let m = nominal.m;
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
        tick_us.sort_by(f64::total_cmp);
        results.push(StepResult {
            label: step.label.clone(),
            theta: c.theta,
            scale: c.scale,
            reflection: c.reflection,
            rmse: (sum / len as f64).sqrt(),
            samples: times.len(),
            statuses_on_bound: on_bound,
            statuses,
            abnormal_codes: abnormal,
            tick_median_us: tick_us.get(tick_us.len() / 2).copied().unwrap_or(0.0),
            tick_max_us: tick_max,
            path,
        });
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
