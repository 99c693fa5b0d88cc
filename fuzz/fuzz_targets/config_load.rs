//! Arbitrary text as a configuration file: parsing (`Config::from_toml_str`) and everything
//! that validates it — `[node]` (`NodeConfig::validate`), `[mock_hw]`, `[augmentation]`,
//! `[train]`, the robot's chains, held joints, limit overrides and `[kinematics]` settings
//! (on the shipped planar dual-arm / 7-DoF test URDF, embedded: the file's `urdf` path is not
//! opened), the safety filter's settings, the `[[symmetries]]` and `[composition]` order,
//! and the node built from it all with a synthetic policy (`NodeCore::new`, no DDS). Errors
//! are fine; a panic, an abort or a hang is not.
#![no_main]

use std::collections::HashMap;
use std::path::Path;
use std::sync::OnceLock;

use libfuzzer_sys::fuzz_target;

use crossym::config::{Config, RobotConfig};
use crossym::kinematics::{Kinematics, KinematicsError, KinematicsSettings, RobotModel};
use crossym::policy::{Policy, TaskFeatures};
use crossym::control::NodeCore;
use crossym::safety::{SafetyFilter, SafetySettings};

const PLANAR: &str = include_str!("../../urdf/planar_dual_arm.urdf");
const ARM7: &str = include_str!("../../urdf/test_arm_7dof.urdf");

fn models() -> &'static (RobotModel, RobotModel) {
    static MODELS: OnceLock<(RobotModel, RobotModel)> = OnceLock::new();
    MODELS.get_or_init(|| {
        (
            RobotModel::from_urdf_str(PLANAR, "urdf/planar_dual_arm.urdf").expect("planar"),
            RobotModel::from_urdf_str(ARM7, "urdf/test_arm_7dof.urdf").expect("7-DoF arm"),
        )
    })
}

/// `RobotConfig::load` on an embedded URDF (the 7-DoF arm when the path names it).
fn load_robot(
    r: &RobotConfig,
    settings: &KinematicsSettings,
) -> Result<Kinematics, KinematicsError> {
    let (planar, arm7) = models();
    let mut model = if r.urdf.to_string_lossy().contains("7dof") {
        arm7.clone()
    } else {
        planar.clone()
    };
    for (joint, o) in &r.limits {
        if let Some(a) = o.acceleration {
            model.set_acceleration_limit(joint, a)?;
        }
        if let Some(v) = o.velocity {
            model.set_velocity_limit(joint, v)?;
        }
    }
    let held: HashMap<String, f64> = r.held.iter().map(|(k, v)| (k.clone(), *v)).collect();
    Kinematics::new(&model, &r.chains, &held, settings)
}

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(cfg) = Config::from_toml_str(text, Path::new("fuzz.toml")) else {
        return;
    };
    let node = cfg.node_config();
    let _ = node.validate().map_err(|e| e.to_string());
    let _ = node.default_condition.validate();
    if let Some(hw) = &cfg.mock_hw {
        let _ = hw.validate();
    }
    if let Some(a) = &cfg.augmentation {
        let _ = a.train.validate();
        let _ = a.test.validate();
    }
    if let Some(t) = &cfg.train {
        let _ = t.validate().map_err(|e| e.to_string());
    }
    let Ok(kin) = load_robot(&cfg.robot, &cfg.kinematics) else {
        return;
    };
    let _ = SafetyFilter::new(
        kin.limits(),
        SafetySettings {
            dt: node.period_s,
            ..node.safety
        },
    )
    .map_err(|e| e.to_string());
    let task = match crossym::symmetry::check::build(&kin, &cfg.symmetries) {
        Ok((built, _)) => TaskFeatures::for_robot(&kin, &built, &cfg.composition.order).ok(),
        Err(e) => {
            let _ = e.to_string();
            None
        }
    };
    let n = kin.dof();
    let policy = Policy::synthetic_with(n, kin.joint_names().to_vec(), &[4], 0, task);
    let safety = node.safety;
    if let Err(e) = NodeCore::new(kin, policy, safety, node) {
        let _ = e.to_string();
    }
});
