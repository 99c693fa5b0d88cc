//! Recordings (rosbag2 joint-state topics, joint CSV files) cleaned into demonstrations
//! ([`super::clean`]) with their task paths `x_i = f(q_i)` and a report — the `bag` and
//! joint `csv` sources of `[demonstrations]` ([`super::demonstrations`]).

use std::path::PathBuf;

use super::clean::{clean, CleanConfig, CleanReport};
use super::recording::JointRecording;
use crossym_math::kinematics::Kinematics;
use crossym_policy::JointTrajectory;

/// What reading and cleaning did to one recording.
#[derive(Debug, Clone)]
pub struct Recorded {
    /// The storage file read.
    pub file: PathBuf,
    /// Raw samples and duration (s) of the recording.
    pub raw: (usize, f64),
    /// Joints in the messages that are not configured (ignored).
    pub ignored: Vec<String>,
    /// Start of each demonstration in the recording (s since its first stamp).
    pub starts_s: Vec<f64>,
    /// What cleaning did.
    pub report: CleanReport,
}

/// Cleans `rec` onto a `dt` (s) grid for `kin`'s joints (limits flagged) and adds the task
/// path of each demonstration; the error text names the file and the problem.
pub fn load_recording(
    rec: &JointRecording,
    dt: f64,
    cleaning: &CleanConfig,
    kin: &Kinematics,
) -> Result<(Recorded, Vec<JointTrajectory>), String> {
    let (demos, report) = clean(rec, dt, cleaning, Some(kin.limits()))
        .map_err(|e| format!("{}: {e}", rec.bag.display()))?;
    let (n, m) = (kin.dof(), kin.task_dim());
    let mut ws = kin.workspace();
    let trajs = demos
        .iter()
        .map(|d| {
            let mut x = Vec::with_capacity(d.len() * m);
            for q in d.q.chunks_exact(n) {
                x.extend_from_slice(kin.forward(q, &mut ws).as_slice());
            }
            JointTrajectory {
                demo: 0,
                n,
                m,
                dt: d.dt,
                q: d.q.clone(),
                qdot: d.qdot.clone(),
                x,
            }
        })
        .collect();
    Ok((
        Recorded {
            file: rec.bag.clone(),
            raw: (rec.len(), rec.duration()),
            ignored: rec.ignored.clone(),
            starts_s: demos.iter().map(|d| d.start_s).collect(),
            report,
        },
        trajs,
    ))
}
