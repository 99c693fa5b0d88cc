//! Saving and loading a [`Policy`]: a safetensors weights file plus a JSON sidecar.
//!
//! `policy.safetensors` holds, for each affine layer `l`, `layers.{l}.weight` (`[out, in]`,
//! row-major) and `layers.{l}.bias` (`[out]`). They are written as **F64**, so a save/load
//! round trip reproduces the in-memory policy exactly (weights trained in `f32` widen
//! exactly); F32 files are accepted too and widened on load.
//!
//! `policy.json` (same stem, [`sidecar_path`]) holds the format tag and version, the crate
//! version, the normaliser, the layer sizes and activation, robot and joint names, the
//! caller's symmetry description, the training configuration and, for policies with
//! canonical task-space features, their FK chains, group map and normalisation
//! ([`super::canonical::TaskFeatureSpec`]), and for a canonicalised policy the composition
//! it is evaluated through ([`ComposedSpec`], `canonicalised`). [`Policy::load`] checks
//! the format version, the normaliser, that the layer sizes agree with `n`, that every
//! tensor exists with the right shape, and that every weight is finite, and names the
//! file and the offending field or tensor when something is wrong.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use safetensors::tensor::TensorView;
use safetensors::{Dtype, SafeTensors};
use serde::{Deserialize, Serialize};

use super::canonical::{TaskFeatureSpec, TaskFeatures};
use super::error::PolicyError;
use super::features::Normalizer;
use super::mlp::{MlpInference, MlpSpec, Policy, PolicyMeta};
use super::train_config::TrainConfig;
use crossym_math::symmetry::affine::CanonicalMap;
use crossym_math::symmetry::transfer::composed::ComposedSpec;

/// Format tag written in the sidecar's `format` field.
pub const FORMAT: &str = "crossym-policy";

/// Sidecar format version this build writes and reads.
pub const FORMAT_VERSION: u32 = 1;

/// The sidecar of a weights file: the same path with extension `.json`.
pub fn sidecar_path(weights: &Path) -> PathBuf {
    weights.with_extension("json")
}

/// The JSON sidecar's content.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct Sidecar {
    format: String,
    format_version: u32,
    crate_version: String,
    weights_file: String,
    dtype: String,
    normalizer: Normalizer,
    mlp: MlpSpec,
    robot: String,
    joint_names: Vec<String>,
    symmetry: serde_json::Value,
    train_config: Option<TrainConfig>,
    /// Canonical task-space features (absent in policies without them).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    task_features: Option<TaskFeatureSpec>,
    /// The composition a canonicalised policy is evaluated through (absent: plain).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    canonicalised: Option<ComposedSpec>,
    /// The group's action on `X` a task-space head is canonicalised by (absent: not a
    /// task head).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    task_head: Option<CanonicalMap>,
}

fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> PolicyError + '_ {
    move |source| PolicyError::Io {
        path: path.to_path_buf(),
        source,
    }
}

impl Policy {
    /// Writes the weights to `path` (conventionally `*.safetensors`, F64) and the sidecar to
    /// [`sidecar_path`]`(path)`, stamped with this crate's version.
    pub fn save(&self, path: impl AsRef<Path>) -> Result<(), PolicyError> {
        let path = path.as_ref();
        let side = sidecar_path(path);
        if side == path {
            return Err(PolicyError::Invalid {
                path: path.to_path_buf(),
                field: "path".into(),
                message: "the weights file must not have a .json extension".into(),
            });
        }
        self.check(path)?;
        let spec = self.mlp().spec();
        let mut bytes: Vec<(String, Vec<u8>, Vec<usize>)> = Vec::new();
        for l in 0..spec.num_layers() {
            let (o, i) = spec.layer_shape(l);
            let enc = |v: &[f64]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
            bytes.push((
                MlpSpec::weight_name(l),
                enc(self.mlp().weight(l)),
                vec![o, i],
            ));
            bytes.push((MlpSpec::bias_name(l), enc(self.mlp().bias(l)), vec![o]));
        }
        let mut views = Vec::with_capacity(bytes.len());
        for (name, data, shape) in &bytes {
            let view = TensorView::new(Dtype::F64, shape.clone(), data).map_err(|e| {
                PolicyError::Weights {
                    path: path.to_path_buf(),
                    message: e.to_string(),
                }
            })?;
            views.push((name.clone(), view));
        }
        let info = HashMap::from([("format".to_string(), FORMAT.to_string())]);
        let buf = safetensors::serialize(views, Some(info)).map_err(|e| PolicyError::Weights {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
        std::fs::write(path, buf).map_err(io_err(path))?;

        let sidecar = Sidecar {
            format: FORMAT.into(),
            format_version: FORMAT_VERSION,
            crate_version: env!("CARGO_PKG_VERSION").into(),
            weights_file: path
                .file_name()
                .map(|f| f.to_string_lossy().into_owned())
                .unwrap_or_default(),
            dtype: "F64".into(),
            normalizer: self.normalizer().clone(),
            mlp: spec.clone(),
            robot: self.meta.robot.clone(),
            joint_names: self.meta.joint_names.clone(),
            symmetry: self.meta.symmetry.clone(),
            train_config: self.meta.train_config.clone(),
            task_features: self.task_features().map(|t| t.spec().clone()),
            canonicalised: self.meta.canonicalised.clone(),
            task_head: self.meta.task_head.clone(),
        };
        let json = serde_json::to_string_pretty(&sidecar).map_err(|e| PolicyError::Sidecar {
            path: side.clone(),
            message: e.to_string(),
        })?;
        std::fs::write(&side, json).map_err(io_err(&side))?;
        Ok(())
    }

    /// Reads a policy written by [`Policy::save`]; `path` is the weights file or its sidecar.
    pub fn load(path: impl AsRef<Path>) -> Result<Self, PolicyError> {
        let path = path.as_ref();
        let (weights_path, side) = if path.extension().is_some_and(|e| e == "json") {
            (path.with_extension("safetensors"), path.to_path_buf())
        } else {
            (path.to_path_buf(), sidecar_path(path))
        };
        let sc = read_sidecar(&side)?;
        let task = check_sidecar(&sc, &side)?;
        let (weights, biases) = read_weights(&weights_path, &sc.mlp)?;
        let invalid = |field: &str, message: String| PolicyError::Invalid {
            path: side.clone(),
            field: field.into(),
            message,
        };
        let mlp = MlpInference::new(sc.mlp.clone(), weights, biases).map_err(|message| {
            PolicyError::Weights {
                path: weights_path.clone(),
                message: message.to_string(),
            }
        })?;
        let meta = PolicyMeta {
            robot: sc.robot,
            joint_names: sc.joint_names,
            symmetry: sc.symmetry,
            train_config: sc.train_config,
            crate_version: sc.crate_version,
            canonicalised: sc.canonicalised,
            task_head: sc.task_head,
        };
        let policy =
            Policy::with_task_features(sc.normalizer, mlp, task, meta).map_err(|e| match e {
                PolicyError::Invalid { field, message, .. } => invalid(&field, message),
                e => e,
            })?;
        Ok(policy)
    }
}

/// Reads the sidecar `side`: its format and version first (so that a future format gives
/// a version error, not a field error), then its fields.
fn read_sidecar(side: &Path) -> Result<Sidecar, PolicyError> {
    let side = side.to_path_buf();
    let text = std::fs::read_to_string(&side).map_err(io_err(&side))?;
    let value: serde_json::Value =
        serde_json::from_str(&text).map_err(|e| PolicyError::Sidecar {
            path: side.clone(),
            message: e.to_string(),
        })?;
    // Version first, so that a future format gives a version error, not a field error.
    match value.get("format").and_then(|f| f.as_str()) {
        Some(FORMAT) => {}
        other => {
            return Err(PolicyError::Sidecar {
                path: side,
                message: format!("`format` is {other:?}, expected \"{FORMAT}\""),
            })
        }
    }
    let found = value
        .get("format_version")
        .and_then(|v| v.as_u64())
        .ok_or_else(|| PolicyError::Sidecar {
            path: side.clone(),
            message: "missing or non-integer `format_version`".into(),
        })?;
    if found != u64::from(FORMAT_VERSION) {
        return Err(PolicyError::Version {
            path: side,
            found: u32::try_from(found).unwrap_or(u32::MAX),
            supported: FORMAT_VERSION,
        });
    }
    let sc: Sidecar = serde_json::from_value(value).map_err(|e| PolicyError::Sidecar {
        path: side.clone(),
        message: e.to_string(),
    })?;
    Ok(sc)
}

/// Checks the sidecar's normaliser, architecture and task features against each other;
/// returns the task features.
fn check_sidecar(sc: &Sidecar, side: &Path) -> Result<Option<TaskFeatures>, PolicyError> {
    let invalid = |field: &str, message: String| PolicyError::Invalid {
        path: side.to_path_buf(),
        field: field.into(),
        message,
    };
    sc.normalizer
        .validate()
        .map_err(|m| invalid("normalizer", m.to_string()))?;
    sc.mlp
        .validate()
        .map_err(|m| invalid("mlp", m.to_string()))?;
    let task = sc
        .task_features
        .clone()
        .map(TaskFeatures::new)
        .transpose()
        .map_err(|m| invalid("task_features", m.to_string()))?;
    let n = sc.normalizer.dim();
    let input = sc.normalizer.input_dim() + task.as_ref().map_or(0, TaskFeatures::dim);
    if sc.mlp.input != input || sc.mlp.output != n {
        return Err(invalid(
            "mlp",
            format!(
                "layer sizes {:?} do not fit {n} joints (input must be {input}, output {n})",
                sc.mlp.layer_sizes(),
            ),
        ));
    }
    Ok(task)
}

/// Per layer, the row-major weights and the bias.
type LayerParams = (Vec<Vec<f64>>, Vec<Vec<f64>>);

/// Reads the weights and biases of every layer of `spec` from the safetensors file
/// `weights_path`, refusing tensors it does not name.
fn read_weights(weights_path: &Path, spec: &MlpSpec) -> Result<LayerParams, PolicyError> {
    let bytes = std::fs::read(weights_path).map_err(io_err(weights_path))?;
    let st = SafeTensors::deserialize(&bytes).map_err(|e| PolicyError::Weights {
        path: weights_path.to_path_buf(),
        message: e.to_string(),
    })?;
    let mut weights = Vec::with_capacity(spec.num_layers());
    let mut biases = Vec::with_capacity(spec.num_layers());
    for l in 0..spec.num_layers() {
        let (o, i) = spec.layer_shape(l);
        weights.push(read_tensor(
            &st,
            weights_path,
            &MlpSpec::weight_name(l),
            &[o, i],
        )?);
        biases.push(read_tensor(
            &st,
            weights_path,
            &MlpSpec::bias_name(l),
            &[o],
        )?);
    }
    let expected = 2 * spec.num_layers();
    if st.len() != expected {
        let mut extra: Vec<&str> = st
            .names()
            .into_iter()
            .filter(|n| {
                !(0..spec.num_layers())
                    .any(|l| *n == MlpSpec::weight_name(l) || *n == MlpSpec::bias_name(l))
            })
            .collect();
        extra.sort_unstable();
        return Err(PolicyError::Weights {
            path: weights_path.to_path_buf(),
            message: format!(
                "unexpected tensors {extra:?} for layer sizes {:?}",
                spec.layer_sizes()
            ),
        });
    }
    Ok((weights, biases))
}

/// Reads one F32 or F64 tensor of the given shape as `f64`, rejecting non-finite values.
fn read_tensor(
    st: &SafeTensors<'_>,
    path: &Path,
    name: &str,
    shape: &[usize],
) -> Result<Vec<f64>, PolicyError> {
    let t = st.tensor(name).map_err(|_| PolicyError::MissingTensor {
        path: path.to_path_buf(),
        tensor: name.into(),
    })?;
    let values: Vec<f64> = match t.dtype() {
        Dtype::F64 if t.shape() == shape => t
            .data()
            .chunks_exact(8)
            .map(|c| f64::from_le_bytes(c.try_into().expect("8-byte chunk")))
            .collect(),
        Dtype::F32 if t.shape() == shape => t
            .data()
            .chunks_exact(4)
            .map(|c| f64::from(f32::from_le_bytes(c.try_into().expect("4-byte chunk"))))
            .collect(),
        d => {
            return Err(PolicyError::Shape {
                path: path.to_path_buf(),
                tensor: name.into(),
                expected: format!("F64 or F32 {shape:?}"),
                found: format!("{d:?} {:?}", t.shape()),
            })
        }
    };
    if let Some(index) = values.iter().position(|v| !v.is_finite()) {
        return Err(PolicyError::NonFinite {
            path: path.to_path_buf(),
            tensor: name.into(),
            index,
        });
    }
    Ok(values)
}
