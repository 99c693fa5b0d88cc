//! The network's architecture ([`MlpSpec`]) and the scratch buffers of its forward pass
//! ([`MlpWorkspace`]).

use serde::{Deserialize, Serialize};

use crate::activation::Activation;
use crate::error::PolicyFitError;

/// Architecture of the network: input width, hidden widths, output width, activation.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MlpSpec {
    /// Input width (`n + 4` for a policy, `n + m + 4` with `m` task features).
    pub input: usize,
    /// Hidden-layer widths, input side first (may be empty: a linear map).
    pub hidden: Vec<usize>,
    /// Output width (`n` for a policy).
    pub output: usize,
    /// Hidden-layer nonlinearity.
    #[serde(default)]
    pub activation: Activation,
}

impl MlpSpec {
    /// All widths `[input, hidden…, output]`.
    pub fn layer_sizes(&self) -> Vec<usize> {
        let mut v = Vec::with_capacity(self.hidden.len() + 2);
        v.push(self.input);
        v.extend_from_slice(&self.hidden);
        v.push(self.output);
        v
    }

    /// Number of affine layers (`hidden.len() + 1`).
    pub fn num_layers(&self) -> usize {
        self.hidden.len() + 1
    }

    /// `(out, in)` of affine layer `l`.
    pub fn layer_shape(&self, l: usize) -> (usize, usize) {
        let fan_in = if l == 0 {
            self.input
        } else {
            self.hidden[l - 1]
        };
        let fan_out = if l == self.hidden.len() {
            self.output
        } else {
            self.hidden[l]
        };
        (fan_out, fan_in)
    }

    /// Largest hidden width (0 without hidden layers).
    pub fn max_hidden(&self) -> usize {
        self.hidden.iter().copied().max().unwrap_or(0)
    }

    /// Total number of weights and biases.
    pub fn num_params(&self) -> usize {
        (0..self.num_layers())
            .map(|l| {
                let (o, i) = self.layer_shape(l);
                o * i + o
            })
            .sum()
    }

    /// Safetensors name of layer `l`'s weight matrix (`layers.{l}.weight`, shape `[out, in]`).
    pub fn weight_name(l: usize) -> String {
        format!("layers.{l}.weight")
    }

    /// Safetensors name of layer `l`'s bias (`layers.{l}.bias`, shape `[out]`).
    pub fn bias_name(l: usize) -> String {
        format!("layers.{l}.bias")
    }

    /// Checks that every width is positive; says what is wrong.
    pub fn validate(&self) -> Result<(), PolicyFitError> {
        self.validate_inner().map_err(PolicyFitError::network)
    }

    // The checks of [`Self::validate`], failing with a message.
    fn validate_inner(&self) -> Result<(), String> {
        if self.input == 0 || self.output == 0 {
            return Err(format!(
                "input {} and output {} widths must be positive",
                self.input, self.output
            ));
        }
        if let Some(l) = self.hidden.iter().position(|&h| h == 0) {
            return Err(format!("hidden layer {l} has width 0"));
        }
        Ok(())
    }
}

/// Scratch buffers for [`MlpInference::forward`](super::MlpInference::forward): two ping-pong vectors of the widest
/// hidden layer.
#[derive(Debug, Clone)]
pub struct MlpWorkspace {
    pub(super) a: Vec<f64>,
    pub(super) b: Vec<f64>,
}

impl MlpWorkspace {
    /// Buffers for networks whose hidden layers are at most `spec.max_hidden()` wide.
    pub fn new(spec: &MlpSpec) -> Self {
        let w = spec.max_hidden();
        Self {
            a: vec![0.0; w],
            b: vec![0.0; w],
        }
    }

    /// Width each buffer can hold (number of `f64`); never changes after construction.
    pub fn capacity(&self) -> usize {
        self.a.len()
    }
}
