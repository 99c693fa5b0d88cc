//! Test robots for the parts' unit tests: kinematics from URDF text and chains, planar
//! (`xy` tasks).

use std::collections::HashMap;

use crossym_math::kinematics::{ChainSpec, Kinematics, KinematicsSettings, RobotModel, TaskSpace};

/// The kinematics of `urdf` with the planar chains `(name, base, tip)`.
pub(crate) fn planar(urdf: &str, chains: &[(&str, &str, &str)]) -> Kinematics {
    let model = RobotModel::from_urdf_str(urdf, "test.urdf").unwrap();
    let chains: Vec<ChainSpec> = chains
        .iter()
        .map(|&(name, base, tip)| ChainSpec::new(name, base, tip, TaskSpace::Xy))
        .collect();
    Kinematics::new(
        &model,
        &chains,
        &HashMap::new(),
        &KinematicsSettings::default(),
    )
    .unwrap()
}
