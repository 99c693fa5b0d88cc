//! Steps 2 and 3 of the demo: `mock-hw` and `node` as child processes of a `crossym`
//! executable (localhost-only DDS, the domain of `ROS_DOMAIN_ID`), the scenario run against
//! them, the children stopped and the mock hardware's summary read.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::Duration;

use crate::ros::dds::{DdsSettings, DiscoveryRange};
use crate::sim::physics::Plant;
use crate::sim::scenario::{self, ScenarioTopics, StepResult};
use crate::sim::MockHwSummary;

use super::{DemoError, DemoSettings, Prepared};

/// How long the scenario waits for the node and the mock hardware to be discovered.
const DISCOVERY_TIMEOUT: Duration = Duration::from_secs(30);

/// Under SROS2 (`ROS_SECURITY_ENABLE=true`, docs/guide/security.md): the node's enclave
/// (`--ros-args --enclave`; `ROS_SECURITY_ENCLAVE_OVERRIDE` wins, as in rcl).
pub const NODE_ENCLAVE: &str = "/crossym/node";
/// The mock hardware's enclave under SROS2.
pub const MOCK_HW_ENCLAVE: &str = "/crossym/mock_hw";
/// The enclave of the demo's own participant (conditions, resets, joint states, status,
/// lifecycle activation) under SROS2.
pub const DEMO_ENCLAVE: &str = "/crossym/demo";

/// A child process that is terminated (SIGTERM, then killed) when dropped.
struct Proc {
    name: &'static str,
    child: Option<Child>,
}

impl Proc {
    /// Starts `cmd` with its standard output and error in the new file `log`.
    fn spawn(name: &'static str, mut cmd: Command, log: &Path) -> Result<Self, DemoError> {
        let f = std::fs::File::create(log).map_err(DemoError::io("creating", log))?;
        let out = f.try_clone().map_err(DemoError::io("opening", log))?;
        let child = cmd
            .stdout(Stdio::from(out))
            .stderr(Stdio::from(f))
            .spawn()
            .map_err(|source| DemoError::Spawn { name, source })?;
        Ok(Self {
            name,
            child: Some(child),
        })
    }

    /// SIGTERM and wait (up to 10 s); the exit code.
    fn stop(&mut self) -> Result<i32, DemoError> {
        let Some(mut c) = self.child.take() else {
            return Ok(0);
        };
        let name = self.name;
        let failed = |message: String| DemoError::Process { name, message };
        let waited = |e: std::io::Error| failed(format!("could not be waited for: {e}"));
        if let Some(status) = c.try_wait().map_err(waited)? {
            return Err(failed(format!("exited early with {status}")));
        }
        let _ = Command::new("kill")
            .args(["-TERM", &c.id().to_string()])
            .status();
        for _ in 0..100 {
            if let Some(s) = c.try_wait().map_err(waited)? {
                return Ok(s.code().unwrap_or(-1));
            }
            std::thread::sleep(Duration::from_millis(100));
        }
        let _ = c.kill();
        Err(failed("did not stop within 10 s of SIGTERM".into()))
    }
}

impl Drop for Proc {
    fn drop(&mut self) {
        if let Some(mut c) = self.child.take() {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

/// The mock hardware and the node, running ([`start`]); killed when dropped.
pub struct Started {
    hw: Proc,
    node: Proc,
    settings: DdsSettings,
    summary: PathBuf,
}

/// What the closed loop measured ([`Started::finish`]).
#[derive(Debug, Clone)]
pub struct Run {
    /// One result per step, in order.
    pub results: Vec<StepResult>,
    /// The node's exit code after SIGTERM.
    pub node_rc: i32,
    /// The mock hardware's exit code after SIGTERM.
    pub hw_rc: i32,
    /// The mock hardware's summary.
    pub summary: MockHwSummary,
}

/// Step 2: creates `out`, then starts `exe mock-hw` (writing its summary) and `exe node`
/// (recording into `out/bag`, replaced) with the settings' config, policy and plant, in the
/// DDS domain of `ROS_DOMAIN_ID`, localhost only; their logs go to `out/mock_hw.log` and
/// `out/node.log`. Under SROS2's variables (inherited by the children) each process runs
/// as its enclave: `/crossym/node`, `/crossym/mock_hw`, this one `/crossym/demo`.
pub fn start(s: &DemoSettings, exe: &Path) -> Result<Started, DemoError> {
    std::fs::create_dir_all(&s.out).map_err(DemoError::io("creating", &s.out))?;
    let mut settings = DdsSettings::from_env()?.with_enclave(Some(DEMO_ENCLAVE));
    settings.range = DiscoveryRange::Localhost;
    // Enforce without the files stops here, before any child starts.
    settings.security_mode()?;
    let secured = settings.security.enable;
    let enclave = |c: &mut Command, e: &str| {
        if secured {
            c.args(["--ros-args", "--enclave", e]);
        }
    };
    let child = |sub: &str| {
        let mut c = Command::new(exe);
        c.arg(sub)
            .arg("--config")
            .arg(&s.config)
            .env("ROS_LOCALHOST_ONLY", "1")
            .env("ROS_DOMAIN_ID", settings.domain_id.to_string());
        c
    };
    let summary = s.summary_path();
    let _ = std::fs::remove_file(&summary);
    let mut hw_cmd = child("mock-hw");
    hw_cmd.arg("--summary").arg(&summary);
    if let Some(p) = s.plant {
        hw_cmd.arg("--plant").arg(match p {
            Plant::Kinematic => "kinematic",
            Plant::Mujoco => "mujoco",
        });
    }
    if s.plant != Some(Plant::Mujoco) {
        enclave(&mut hw_cmd, MOCK_HW_ENCLAVE);
    }
    let hw = Proc::spawn("mock-hw", hw_cmd, &s.out.join("mock_hw.log"))?;
    let bag_dir = s.bag_dir();
    if bag_dir.exists() {
        std::fs::remove_dir_all(&bag_dir).map_err(DemoError::io("removing", &bag_dir))?;
    }
    let mut node_cmd = child("node");
    node_cmd.arg("--record").arg(&bag_dir);
    if let Some(p) = &s.policy {
        node_cmd.arg("--policy").arg(p);
    }
    enclave(&mut node_cmd, NODE_ENCLAVE);
    let node = Proc::spawn("node", node_cmd, &s.out.join("node.log"))?;
    Ok(Started {
        hw,
        node,
        settings,
        summary,
    })
}

impl Started {
    /// The DDS domain the children run in.
    pub fn domain_id(&self) -> u16 {
        self.settings.domain_id
    }

    /// Under SROS2 (`ROS_SECURITY_ENABLE=true`): how the demo's own participant runs
    /// (secured as `/crossym/demo`, or the permissive fallback's warning); `None` without.
    pub fn security(&self) -> Option<String> {
        let mode = self.settings.security_mode().ok()?;
        self.settings.security.enable.then(|| mode.describe())
    }

    /// Step 3: runs the prepared steps against the children, stops them (SIGTERM) and reads
    /// the mock hardware's summary.
    pub fn finish(mut self, p: &Prepared) -> Result<Run, DemoError> {
        let kin = &p.robot.kinematics;
        let topics = ScenarioTopics::new(&p.node, &p.mock_hw.reset_topic);
        let results = scenario::run(
            self.settings.clone(),
            &topics,
            kin,
            kin.joint_names(),
            &p.steps,
            DISCOVERY_TIMEOUT,
        );
        let node_rc = self.node.stop();
        let hw_rc = self.hw.stop();
        let results = results?;
        let node_rc = node_rc?;
        let hw_rc = hw_rc?;
        let text = std::fs::read_to_string(&self.summary)
            .map_err(DemoError::io("reading", &self.summary))?;
        let summary: MockHwSummary =
            serde_json::from_str(&text).map_err(|e| DemoError::Summary {
                path: self.summary.clone(),
                message: e.to_string(),
            })?;
        Ok(Run {
            results,
            node_rc,
            hw_rc,
            summary,
        })
    }
}
