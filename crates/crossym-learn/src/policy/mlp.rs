//! The policy network: a multilayer perceptron and its allocation-free inference.
//!
//! Layer `l` maps `h_{l+1} = φ(W_l h_l + b_l)` with `W_l ∈ ℝ^{out×in}` (row-major, the
//! `candle_nn::Linear` / PyTorch layout) and `φ = tanh` on every hidden layer; the output
//! layer is linear. `tanh` is chosen because the learned vector field `π(q, s)` is then
//! smooth (C^∞, so Euler rollouts and their gradients through time are well behaved), the
//! bounded hidden activations keep long training rollouts from blowing up, and it is
//! evaluated identically (to rounding) by candle and by [`tanh`](super::activation::tanh) here, so the control
//! loop reproduces the training forward pass.
//!
//! [`MlpInference`] holds the weights as plain `f64` vectors and runs the forward pass in
//! `f64` using a caller-owned [`MlpWorkspace`]; candle is not on this path.
//! [`Policy`] couples it with the [`Normalizer`] and provenance ([`PolicyMeta`]);
//! [`Policy::velocity`] is the control-loop entry point and allocates nothing.

use serde::{Deserialize, Serialize};

use super::activation::Activation;
use super::canonical::{TaskFeatureWorkspace, TaskFeatures};
use super::error::PolicyError;
use super::error::PolicyFitError;
use super::features::{encode_condition, Normalizer, CONDITION_FEATURES};
use super::train_config::TrainConfig;
use crossym_math::symmetry::compose::Condition;

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

/// Scratch buffers for [`MlpInference::forward`]: two ping-pong vectors of the widest
/// hidden layer.
#[derive(Debug, Clone)]
pub struct MlpWorkspace {
    a: Vec<f64>,
    b: Vec<f64>,
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

/// Column width a diagonal block must be a multiple of to be packed: the widest
/// accumulator count of [`dot`]'s kernels, so that a block's dot product accumulates the
/// same terms in the same lanes as the dense row (whose other terms are exact zeros) and
/// the packed forward is bit-identical to the dense one.
const BLOCK_ALIGN: usize = 16;

/// A block-diagonal layer stored compactly: `blocks` diagonal blocks of `[o/blocks ×
/// i/blocks]`, row `r` of the layer reading only its block's columns.
#[derive(Debug, Clone, PartialEq)]
struct PackedLayer {
    /// Number of diagonal blocks (≥ 2).
    blocks: usize,
    /// Row-major `[o × i/blocks]`: row `r` holds its block's columns.
    weights: Vec<f64>,
}

/// The network's weights as plain `f64` row-major vectors, with an allocation-free forward.
///
/// A layer whose weight matrix is block diagonal with exact zeros off the blocks (the
/// hidden layers of [`MlpInference::average`]) is also stored packed, and the forward pass
/// reads only its blocks: the same result bit for bit, a `K`-th of the multiply-adds and of
/// the weights in cache.
#[derive(Debug, Clone, PartialEq)]
pub struct MlpInference {
    spec: MlpSpec,
    weights: Vec<Vec<f64>>,
    biases: Vec<Vec<f64>>,
    /// Per layer: its packed block-diagonal form, `None` for a dense layer.
    packed: Vec<Option<PackedLayer>>,
}

/// The finest block-diagonal structure of the row-major `[o × i]` matrix `w`: the largest
/// `K ≥ 2` dividing `o` and `i`, with `i/K` a multiple of [`BLOCK_ALIGN`], such that every
/// entry off the `K` diagonal blocks is exactly zero; `None` when there is none.
fn find_blocks(w: &[f64], o: usize, i: usize) -> Option<PackedLayer> {
    let off_blocks_zero = |k: usize| {
        let (bo, bi) = (o / k, i / k);
        (0..o).all(|r| {
            let b = r / bo;
            let row = &w[r * i..(r + 1) * i];
            row[..b * bi].iter().all(|&v| v == 0.0) && row[(b + 1) * bi..].iter().all(|&v| v == 0.0)
        })
    };
    let k = (2..=i / BLOCK_ALIGN)
        .rev()
        .find(|&k| o % k == 0 && i % k == 0 && (i / k) % BLOCK_ALIGN == 0 && off_blocks_zero(k))?;
    let (bo, bi) = (o / k, i / k);
    let mut weights = Vec::with_capacity(o * bi);
    for r in 0..o {
        let b = r / bo;
        weights.extend_from_slice(&w[r * i + b * bi..r * i + (b + 1) * bi]);
    }
    Some(PackedLayer { blocks: k, weights })
}

impl MlpInference {
    /// Builds from per-layer row-major weights `[out × in]` and biases `[out]`; checks the
    /// spec, every shape and that all values are finite, and says what is wrong.
    pub fn new(
        spec: MlpSpec,
        weights: Vec<Vec<f64>>,
        biases: Vec<Vec<f64>>,
    ) -> Result<Self, PolicyFitError> {
        Self::new_inner(spec, weights, biases).map_err(PolicyFitError::network)
    }

    // The checks of [`Self::new`], failing with a message.
    fn new_inner(
        spec: MlpSpec,
        weights: Vec<Vec<f64>>,
        biases: Vec<Vec<f64>>,
    ) -> Result<Self, String> {
        spec.validate()?;
        let l = spec.num_layers();
        if weights.len() != l || biases.len() != l {
            return Err(format!(
                "{l} layers expected, got {} weight matrices and {} bias vectors",
                weights.len(),
                biases.len()
            ));
        }
        for k in 0..l {
            let (o, i) = spec.layer_shape(k);
            if weights[k].len() != o * i {
                return Err(format!(
                    "layer {k}: weight has {} values, expected {o}×{i}",
                    weights[k].len()
                ));
            }
            if biases[k].len() != o {
                return Err(format!(
                    "layer {k}: bias has {} values, expected {o}",
                    biases[k].len()
                ));
            }
            if let Some(j) = weights[k].iter().position(|w| !w.is_finite()) {
                return Err(format!("layer {k}: weight[{j}] is not finite"));
            }
            if let Some(j) = biases[k].iter().position(|w| !w.is_finite()) {
                return Err(format!("layer {k}: bias[{j}] is not finite"));
            }
        }
        let packed = (0..l)
            .map(|k| {
                let (o, i) = spec.layer_shape(k);
                find_blocks(&weights[k], o, i)
            })
            .collect();
        Ok(Self {
            spec,
            weights,
            biases,
            packed,
        })
    }

    /// One network computing the mean of `members`' outputs, `(1/K) Σ_k MLP_k(x)`
    /// (an ensemble as a plain MLP): the first layers stacked, the hidden layers block
    /// diagonal, the output layer `[W_1 … W_K] / K` with the mean bias, so hidden widths
    /// are `K ×` the members'. Members must share input, output, depth and activation.
    pub fn average(members: &[MlpInference]) -> Result<Self, PolicyFitError> {
        Self::average_inner(members).map_err(PolicyFitError::network)
    }

    // The checks of [`Self::average`], failing with a message.
    fn average_inner(members: &[MlpInference]) -> Result<Self, String> {
        let Some(first) = members.first() else {
            return Err("an average of no networks".into());
        };
        let k = members.len();
        let base = &first.spec;
        for (m, net) in members.iter().enumerate() {
            let s = &net.spec;
            if s.input != base.input
                || s.output != base.output
                || s.hidden.len() != base.hidden.len()
                || s.activation != base.activation
            {
                return Err(format!(
                    "member {m} has layer sizes {:?} ({:?}), member 0 {:?} ({:?})",
                    s.layer_sizes(),
                    s.activation,
                    base.layer_sizes(),
                    base.activation
                ));
            }
        }
        let spec = MlpSpec {
            input: base.input,
            hidden: (0..base.hidden.len())
                .map(|l| members.iter().map(|n| n.spec.hidden[l]).sum())
                .collect(),
            output: base.output,
            activation: base.activation,
        };
        let last = spec.num_layers() - 1;
        let (mut weights, mut biases) = (Vec::new(), Vec::new());
        for l in 0..=last {
            let (o, i) = spec.layer_shape(l);
            let mut w = vec![0.0; o * i];
            let mut b = vec![0.0; o];
            // Offsets of member n's rows (outputs) and columns (inputs) in the merged layer.
            let (mut ro, mut co) = (0usize, 0usize);
            for net in members {
                let (mo, mi) = net.spec.layer_shape(l);
                let mw = &net.weights[l];
                for r in 0..mo {
                    for c in 0..mi {
                        let v = mw[r * mi + c];
                        match (l == 0, l == last) {
                            // Shared input: rows stacked, all columns.
                            (true, false) => w[(ro + r) * i + c] = v,
                            // Shared output: all rows, columns side by side, averaged.
                            (false, true) => w[r * i + co + c] = v / k as f64,
                            (true, true) => w[r * i + c] += v / k as f64,
                            (false, false) => w[(ro + r) * i + co + c] = v,
                        }
                    }
                    if l == last {
                        b[r] += net.biases[l][r] / k as f64;
                    } else {
                        b[ro + r] = net.biases[l][r];
                    }
                }
                if l != last {
                    ro += mo;
                }
                if l != 0 {
                    co += mi;
                }
            }
            weights.push(w);
            biases.push(b);
        }
        Ok(Self::new(spec, weights, biases)?)
    }

    /// The architecture.
    pub fn spec(&self) -> &MlpSpec {
        &self.spec
    }

    /// Row-major `[out × in]` weights of layer `l`.
    pub fn weight(&self, l: usize) -> &[f64] {
        &self.weights[l]
    }

    /// Bias of layer `l`.
    pub fn bias(&self, l: usize) -> &[f64] {
        &self.biases[l]
    }

    /// The same network with every layer dense: the reference of the packed forward.
    #[cfg(test)]
    fn dense_only(&self) -> Self {
        Self {
            packed: vec![None; self.packed.len()],
            ..self.clone()
        }
    }

    /// Number of diagonal blocks the forward pass uses for layer `l`: `K ≥ 2` when its
    /// weights are block diagonal (exact zeros elsewhere) and stored packed, 1 when dense.
    pub fn layer_blocks(&self, l: usize) -> usize {
        self.packed[l].as_ref().map_or(1, |p| p.blocks)
    }

    /// A workspace sized for this network.
    pub fn workspace(&self) -> MlpWorkspace {
        MlpWorkspace::new(&self.spec)
    }

    /// `out = MLP(input)`; `input` of length `spec.input`, `out` of length `spec.output`.
    /// Allocates nothing.
    ///
    /// # Panics
    /// On slice lengths that disagree with the spec or a workspace built for a narrower net.
    pub fn forward(&self, input: &[f64], out: &mut [f64], ws: &mut MlpWorkspace) {
        assert_eq!(input.len(), self.spec.input, "MLP input width");
        assert_eq!(out.len(), self.spec.output, "MLP output width");
        assert!(
            ws.capacity() >= self.spec.max_hidden(),
            "MLP workspace too narrow"
        );
        let last = self.spec.num_layers() - 1;
        if last == 0 {
            self.layer(0, input, out, false);
            return;
        }
        let MlpWorkspace { a, b } = ws;
        let h0 = self.spec.hidden[0];
        self.layer(0, input, &mut a[..h0], true);
        let mut in_a = true;
        for l in 1..last {
            let (o, i) = self.spec.layer_shape(l);
            if in_a {
                self.layer(l, &a[..i], &mut b[..o], true);
            } else {
                self.layer(l, &b[..i], &mut a[..o], true);
            }
            in_a = !in_a;
        }
        let i = self.spec.hidden[last - 1];
        if in_a {
            self.layer(last, &a[..i], out, false);
        } else {
            self.layer(last, &b[..i], out, false);
        }
    }

    /// `y = φ(W_l x + b_l)` (or without `φ` for the output layer).
    #[inline]
    fn layer(&self, l: usize, x: &[f64], y: &mut [f64], activate: bool) {
        // Dense: one block, the whole input; packed: block b's rows read block b's columns.
        let (w, blocks) = match &self.packed[l] {
            Some(p) => (&p.weights[..], p.blocks),
            None => (&self.weights[l][..], 1),
        };
        let (rows, cols) = (y.len() / blocks, x.len() / blocks);
        let per_block = y
            .chunks_mut(rows)
            .zip(self.biases[l].chunks(rows))
            .zip(w.chunks(rows * cols))
            .zip(x.chunks(cols));
        for (((yb, bb), wb), xb) in per_block {
            for ((yr, br), wr) in yb.iter_mut().zip(bb).zip(wb.chunks_exact(cols)) {
                let v = br + dot(wr, xb);
                *yr = if activate {
                    self.spec.activation.apply(v)
                } else {
                    v
                };
            }
        }
    }
}

/// Which dot-product kernel [`MlpInference::forward`] uses on this CPU: `"avx2+fma"` or
/// `"portable"`. They round differently, so bit-exact replays hold between machines of the
/// same kind.
pub fn dot_kernel() -> &'static str {
    if has_avx2_fma() {
        "avx2+fma"
    } else {
        "portable"
    }
}

/// True when this CPU has AVX2 and FMA (std caches the detection: one atomic load, no lock,
/// no allocation).
#[inline]
fn has_avx2_fma() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// Dot product `Σ aᵢ bᵢ`: fused multiply-adds over 256-bit vectors where the CPU has AVX2
/// and FMA ([`has_avx2_fma`]), else a portable loop with eight independent accumulators.
/// The two differ in rounding only.
#[inline]
fn dot(a: &[f64], b: &[f64]) -> f64 {
    #[cfg(target_arch = "x86_64")]
    if has_avx2_fma() {
        // SAFETY: the CPU supports the features `dot_fma` is compiled for.
        return unsafe { dot_fma(a, b) };
    }
    dot_portable(a, b)
}

/// [`dot`] compiled for AVX2 + FMA: sixteen accumulators (four 4-lane registers) hide the
/// FMA latency.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn dot_fma(a: &[f64], b: &[f64]) -> f64 {
    dot_lanes::<16, true>(a, b)
}

/// Portable [`dot`]: eight independent accumulators (lets the compiler vectorise).
#[inline]
fn dot_portable(a: &[f64], b: &[f64]) -> f64 {
    dot_lanes::<8, false>(a, b)
}

/// `Σ aᵢ bᵢ` with `W` independent accumulators (a power of two), summed pairwise at the
/// end; fused multiply-adds when `FMA` (only worth it where the target has them).
#[inline(always)]
fn dot_lanes<const W: usize, const FMA: bool>(a: &[f64], b: &[f64]) -> f64 {
    let madd = |x: f64, y: f64, acc: f64| if FMA { x.mul_add(y, acc) } else { acc + x * y };
    let mut acc = [0.0f64; W];
    let ca = a.chunks_exact(W);
    let cb = b.chunks_exact(W);
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for k in 0..W {
            acc[k] = madd(x[k], y[k], acc[k]);
        }
    }
    let mut w = W;
    while w > 1 {
        w /= 2;
        for k in 0..w {
            acc[k] += acc[k + w];
        }
    }
    ra.iter().zip(rb).fold(acc[0], |s, (x, y)| madd(*x, *y, s))
}

/// Provenance stored in the sidecar: robot, joints, symmetry, training setup, crate version.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PolicyMeta {
    /// Robot name (free text, e.g. the URDF's robot name).
    pub robot: String,
    /// Joint names in the order of `q` (empty, or exactly `n` names).
    pub joint_names: Vec<String>,
    /// The symmetry the policy was trained with, as given by the caller (free-form).
    pub symmetry: serde_json::Value,
    /// The training configuration, when the policy was trained by [`super::train()`].
    pub train_config: Option<TrainConfig>,
    /// Version of `crossym` that created or last saved the policy.
    pub crate_version: String,
    /// For a canonicalised policy `π(q, s) = dΦ_g π₀(Φ_g⁻¹ q)`: the composition `Φ_g` is
    /// built from (this network is `π₀`); `None` for a plain `π(q, s)`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub canonicalised: Option<crossym_math::symmetry::transfer::composed::ComposedSpec>,
    /// For a task-space head `π(q, s) = J⁺(q) Dg(s) h(g(s)⁻¹ f(q))`
    /// ([`super::TaskHeadPolicy`]): the group's action on `X` (this network is `h`, over
    /// the task coordinates); `None` otherwise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub task_head: Option<super::CanonicalMap>,
}

impl PolicyMeta {
    /// Metadata with the current crate version and no training configuration.
    pub fn new(
        robot: impl Into<String>,
        joint_names: Vec<String>,
        symmetry: serde_json::Value,
    ) -> Self {
        Self {
            robot: robot.into(),
            joint_names,
            symmetry,
            train_config: None,
            crate_version: env!("CARGO_PKG_VERSION").to_string(),
            canonicalised: None,
            task_head: None,
        }
    }
}

impl Default for PolicyMeta {
    fn default() -> Self {
        Self::new("", Vec::new(), serde_json::Value::Null)
    }
}

/// Scratch buffers for [`Policy::velocity`].
#[derive(Debug, Clone)]
pub struct PolicyWorkspace {
    input: Vec<f64>,
    y: Vec<f64>,
    mlp: MlpWorkspace,
    task: Option<TaskFeatureWorkspace>,
}

impl PolicyWorkspace {
    /// Total number of `f64` held (for checking that it never grows).
    pub fn capacity(&self) -> usize {
        self.input.capacity()
            + self.y.capacity()
            + 2 * self.mlp.capacity()
            + self.task.as_ref().map_or(0, TaskFeatureWorkspace::capacity)
    }
}

/// A symmetry-conditioned joint-space policy `π(q, s) → q̇` ready for the control loop.
///
/// Its input is `[ (q − μ) ⊘ σ_q, x̃ features (when it has [`TaskFeatures`]), cos θ, sin θ,
/// ln λ, σ ]`.
#[derive(Debug, Clone, PartialEq)]
pub struct Policy {
    normalizer: Normalizer,
    mlp: MlpInference,
    task: Option<TaskFeatures>,
    /// Provenance (free to edit; checked against `n` when saving and loading).
    pub meta: PolicyMeta,
}

impl Policy {
    /// Couples a normaliser and a network; checks `input = n + 4`, `output = n` and the
    /// joint-name count.
    pub fn new(
        normalizer: Normalizer,
        mlp: MlpInference,
        meta: PolicyMeta,
    ) -> Result<Self, PolicyError> {
        Self::with_task_features(normalizer, mlp, None, meta)
    }

    /// As [`Policy::new`], with canonical task-space features (`input = n + m + 4`).
    pub fn with_task_features(
        normalizer: Normalizer,
        mlp: MlpInference,
        task: Option<TaskFeatures>,
        meta: PolicyMeta,
    ) -> Result<Self, PolicyError> {
        let p = Self {
            normalizer,
            mlp,
            task,
            meta,
        };
        p.check(std::path::Path::new("<memory>"))?;
        Ok(p)
    }

    /// The ensemble of `members` as one policy: the mean of their outputs
    /// ([`MlpInference::average`]). Members must share the normaliser, the task features
    /// and the layer sizes' shape; the first member's metadata is kept.
    pub fn average(members: &[Policy]) -> Result<Self, PolicyError> {
        let bad = |message: String| PolicyError::Config {
            field: "ensemble".into(),
            message,
        };
        let first = members
            .first()
            .ok_or_else(|| bad("an ensemble of no policies".into()))?;
        if let Some(k) = members
            .iter()
            .position(|p| p.normalizer != first.normalizer || p.task != first.task)
        {
            return Err(bad(format!(
                "member {k} has another normaliser or task features than member 0"
            )));
        }
        let nets: Vec<MlpInference> = members.iter().map(|p| p.mlp.clone()).collect();
        let mlp = MlpInference::average(&nets).map_err(|e| bad(e.to_string()))?;
        Self::with_task_features(
            first.normalizer.clone(),
            mlp,
            first.task.clone(),
            first.meta.clone(),
        )
    }

    /// A policy with deterministic pseudo-random weights (tanh, uniform in ±0.2, biases
    /// 0.01) and an identity normaliser: the shape of a real one, for benchmarks and tests.
    /// Not a trained policy.
    pub fn synthetic(n: usize, joint_names: Vec<String>, hidden: &[usize], seed: u64) -> Self {
        Self::synthetic_with(n, joint_names, hidden, seed, None)
    }

    /// [`Policy::synthetic`] with canonical task features (input `n + m + 4`): the shape of
    /// a real one, for benchmarks and tests. Not a trained policy.
    ///
    /// # Panics
    /// When `task` reads more than `n` joints.
    pub fn synthetic_with(
        n: usize,
        joint_names: Vec<String>,
        hidden: &[usize],
        seed: u64,
        task: Option<TaskFeatures>,
    ) -> Self {
        use rand::{Rng, SeedableRng};
        let spec = MlpSpec {
            input: n + 4 + task.as_ref().map_or(0, TaskFeatures::dim),
            hidden: hidden.to_vec(),
            output: n,
            activation: Activation::Tanh,
        };
        let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
        let sizes = spec.layer_sizes();
        let weights = sizes
            .windows(2)
            .map(|w| {
                (0..w[0] * w[1])
                    .map(|_| rng.random_range(-0.2..0.2))
                    .collect()
            })
            .collect();
        let biases = sizes[1..].iter().map(|&o| vec![0.01; o]).collect();
        let mlp = MlpInference::new(spec, weights, biases).expect("synthetic shapes are valid");
        Policy::with_task_features(
            Normalizer::identity(n),
            mlp,
            task,
            PolicyMeta::new("synthetic", joint_names, serde_json::Value::Null),
        )
        .expect("synthetic policy is consistent")
    }

    /// Consistency checks shared by [`Policy::new`], save and load.
    pub(crate) fn check(&self, path: &std::path::Path) -> Result<(), PolicyError> {
        let invalid = |field: &str, message: String| PolicyError::Invalid {
            path: path.to_path_buf(),
            field: field.into(),
            message,
        };
        self.normalizer
            .validate()
            .map_err(|m| invalid("normalizer", m.to_string()))?;
        let n = self.normalizer.dim();
        let spec = self.mlp.spec();
        if let Some(t) = &self.task {
            if t.joints_read() > n {
                return Err(invalid(
                    "task_features",
                    format!(
                        "the chains read {} joints, the policy has {n}",
                        t.joints_read()
                    ),
                ));
            }
        }
        if spec.input != self.input_dim() {
            return Err(invalid(
                "mlp.input",
                format!(
                    "{} but the policy has {n} joints and {} task features (input must be \
                     n + m + 4 = {})",
                    spec.input,
                    self.task.as_ref().map_or(0, TaskFeatures::dim),
                    self.input_dim()
                ),
            ));
        }
        if spec.output != n {
            return Err(invalid(
                "mlp.output",
                format!("{} but the normaliser has {n} joints", spec.output),
            ));
        }
        if !(self.meta.joint_names.is_empty() || self.meta.joint_names.len() == n) {
            return Err(invalid(
                "joint_names",
                format!("{} names for {n} joints", self.meta.joint_names.len()),
            ));
        }
        Ok(())
    }

    /// Joint-space dimension `n`.
    pub fn dim(&self) -> usize {
        self.normalizer.dim()
    }

    /// The input/output normalisation.
    pub fn normalizer(&self) -> &Normalizer {
        &self.normalizer
    }

    /// The network.
    pub fn mlp(&self) -> &MlpInference {
        &self.mlp
    }

    /// The canonical task-space features, when the policy has them.
    pub fn task_features(&self) -> Option<&TaskFeatures> {
        self.task.as_ref()
    }

    /// Network input width `n + m + 4` (`m = 0` without task features).
    pub fn input_dim(&self) -> usize {
        self.normalizer.input_dim() + self.task.as_ref().map_or(0, TaskFeatures::dim)
    }

    /// A workspace sized for this policy (allocate once, before the control loop).
    pub fn workspace(&self) -> PolicyWorkspace {
        PolicyWorkspace {
            input: vec![0.0; self.input_dim()],
            y: vec![0.0; self.dim()],
            mlp: self.mlp.workspace(),
            task: self.task.as_ref().map(TaskFeatures::workspace),
        }
    }

    /// `out = π(q, s)`: joint velocity (rad/s) at joint position `q` (rad) for condition
    /// `s`. Allocates nothing; `s` is not validated here (validate it once, upstream).
    ///
    /// # Panics
    /// When `q` or `out` is not of length `n`, or `ws` was built for a smaller policy.
    pub fn velocity(&self, q: &[f64], s: &Condition, out: &mut [f64], ws: &mut PolicyWorkspace) {
        self.velocity_impl(q, None, s, out, ws);
    }

    /// [`Policy::velocity`] with the task point `x = f(q)` (m, stacked chain points in their
    /// base frames, as `KinematicsWorkspace::x` after `Kinematics::jacobian(q)`) supplied by
    /// the caller instead of recomputed from the policy's stored chains: the node's tick
    /// already has it. Same result bit for bit when `x` is that FK (the stored chains are
    /// checked against the robot with [`TaskFeatures::check_kinematics`]); `x` is unused by
    /// a policy without task features. Allocates nothing.
    ///
    /// # Panics
    /// As [`Policy::velocity`]; in debug builds also when `x` has the wrong length.
    pub fn velocity_at(
        &self,
        q: &[f64],
        x: &[f64],
        s: &Condition,
        out: &mut [f64],
        ws: &mut PolicyWorkspace,
    ) {
        self.velocity_impl(q, Some(x), s, out, ws);
    }

    fn velocity_impl(
        &self,
        q: &[f64],
        x: Option<&[f64]>,
        s: &Condition,
        out: &mut [f64],
        ws: &mut PolicyWorkspace,
    ) {
        let n = self.dim();
        assert_eq!(q.len(), n, "policy q length");
        assert_eq!(out.len(), n, "policy output length");
        let PolicyWorkspace {
            input,
            y,
            mlp,
            task,
        } = ws;
        let input = &mut input[..self.input_dim()];
        let y = &mut y[..n];
        self.normalizer.normalize_q(q, &mut input[..n]);
        let mut c = n;
        if let (Some(t), Some(tw)) = (&self.task, task.as_mut()) {
            c += t.dim();
            match x {
                Some(x) => t.encode_at(x, s, &mut input[n..c], tw),
                None => t.encode(q, s, &mut input[n..c], tw),
            }
        }
        encode_condition(s, &mut input[c..c + CONDITION_FEATURES]);
        self.mlp.forward(input, y, mlp);
        self.normalizer.denormalize_qdot(y, out);
    }

    /// Euler rollout `q_{k+1} = q_k + Δt π(q_k, s)` for `steps` steps from `q0` (rad);
    /// returns the `(steps + 1) × n` row-major positions, `q0` first (rad). Allocates.
    pub fn rollout(&self, q0: &[f64], s: &Condition, dt: f64, steps: usize) -> Vec<f64> {
        let n = self.dim();
        let mut ws = self.workspace();
        let mut traj = Vec::with_capacity((steps + 1) * n);
        traj.extend_from_slice(q0);
        let mut v = vec![0.0; n];
        let mut q = q0.to_vec();
        for _ in 0..steps {
            self.velocity(&q, s, &mut v, &mut ws);
            for j in 0..n {
                q[j] += dt * v[j];
            }
            traj.extend_from_slice(&q);
        }
        traj
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn policy(n: usize, hidden: Vec<usize>) -> Policy {
        let spec = MlpSpec {
            input: n + 4,
            hidden,
            output: n,
            activation: Activation::Tanh,
        };
        let (mut w, mut b) = (Vec::new(), Vec::new());
        for l in 0..spec.num_layers() {
            let (o, i) = spec.layer_shape(l);
            // Deterministic, well-scaled weights without an RNG.
            w.push(
                (0..o * i)
                    .map(|k| ((k * 7 + l) % 13) as f64 / 13.0 - 0.45)
                    .collect(),
            );
            b.push((0..o).map(|k| 0.01 * k as f64).collect());
        }
        let mlp = MlpInference::new(spec, w, b).unwrap();
        Policy::new(Normalizer::identity(n), mlp, PolicyMeta::default()).unwrap()
    }

    /// The merged ensemble computes the mean of its members' outputs (each member
    /// evaluated on its own), for one, two and three hidden layers of unequal widths.
    #[test]
    fn average_of_networks_is_the_mean_of_their_outputs() {
        for hidden in [vec![5], vec![6, 4], vec![3, 7, 5]] {
            let members: Vec<Policy> = (0..3u64)
                .map(|k| Policy::synthetic(4, Vec::new(), &hidden, 11 + k))
                .collect();
            let avg = Policy::average(&members).unwrap();
            assert_eq!(avg.mlp().spec().hidden[0], 3 * hidden[0]);
            let mut ws = avg.workspace();
            let mut wss: Vec<_> = members.iter().map(Policy::workspace).collect();
            let (mut out, mut one) = (vec![0.0; 4], vec![0.0; 4]);
            for t in 0..20 {
                let q: Vec<f64> = (0..4).map(|j| (0.3 * t as f64 + j as f64).sin()).collect();
                let s = Condition {
                    theta: 0.1 * t as f64,
                    scale: 0.8,
                    reflection: if t % 2 == 0 { 1 } else { -1 },
                };
                avg.velocity(&q, &s, &mut out, &mut ws);
                let mut mean = [0.0; 4];
                for (p, w) in members.iter().zip(&mut wss) {
                    p.velocity(&q, &s, &mut one, w);
                    for j in 0..4 {
                        mean[j] += one[j] / 3.0;
                    }
                }
                for j in 0..4 {
                    assert!(
                        (out[j] - mean[j]).abs() < 1e-12,
                        "{hidden:?}: {out:?} vs {mean:?}"
                    );
                }
            }
        }
        let other = Policy::synthetic(3, Vec::new(), &[5], 1);
        let one = Policy::synthetic(4, Vec::new(), &[5], 1);
        assert!(Policy::average(&[one, other]).is_err());
    }

    #[test]
    fn block_diagonal_layers_are_packed_and_give_the_dense_result_bit_for_bit() {
        // (members, member hidden widths, expected blocks per layer).
        for (k, hidden, blocks) in [
            (4, vec![64, 64], vec![1, 4, 1]),
            (3, vec![16, 32, 16], vec![1, 3, 3, 1]),
            (2, vec![8, 8], vec![1, 1, 1]), // blocks of 8 columns: not packed
        ] {
            let members: Vec<MlpInference> = (0..k as u64)
                .map(|m| {
                    Policy::synthetic(6, Vec::new(), &hidden, 40 + m)
                        .mlp()
                        .clone()
                })
                .collect();
            let avg = MlpInference::average(&members).unwrap();
            let found: Vec<usize> = (0..avg.spec().num_layers())
                .map(|l| avg.layer_blocks(l))
                .collect();
            assert_eq!(found, blocks, "{k} × {hidden:?}");
            assert_forward_bitwise_dense(&avg);
        }
        // An entry off the four 64-blocks of layer 1 but inside one of two 128-blocks:
        // packed as two blocks; one outside both: dense.
        let members: Vec<MlpInference> = (0..4u64)
            .map(|m| {
                Policy::synthetic(6, Vec::new(), &[64, 64], 40 + m)
                    .mlp()
                    .clone()
            })
            .collect();
        let avg = MlpInference::average(&members).unwrap();
        for (col, blocks) in [(100, 2), (200, 1)] {
            let mut weights: Vec<Vec<f64>> = (0..3).map(|l| avg.weight(l).to_vec()).collect();
            let biases: Vec<Vec<f64>> = (0..3).map(|l| avg.bias(l).to_vec()).collect();
            assert_eq!(weights[1][col], 0.0);
            weights[1][col] = 1e-3; // row 0, column `col`
            let net = MlpInference::new(avg.spec().clone(), weights, biases).unwrap();
            assert_eq!(net.layer_blocks(1), blocks, "entry at column {col}");
            assert_forward_bitwise_dense(&net);
        }
    }

    /// `net`'s forward equals, bit for bit, the forward with every layer dense, on inputs
    /// that drive the tanh layers through their range.
    fn assert_forward_bitwise_dense(net: &MlpInference) {
        let dense = net.dense_only();
        let (mut ws, mut wd) = (net.workspace(), dense.workspace());
        let n_out = net.spec().output;
        let (mut a, mut b) = (vec![0.0; n_out], vec![0.0; n_out]);
        for t in 0..50 {
            let x: Vec<f64> = (0..net.spec().input)
                .map(|j| 3.0 * (0.37 * t as f64 + 1.3 * j as f64).sin())
                .collect();
            net.forward(&x, &mut a, &mut ws);
            dense.forward(&x, &mut b, &mut wd);
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&a), bits(&b), "input {t}: {a:?} vs {b:?}");
        }
    }

    #[test]
    fn velocity_10k_calls_without_workspace_growth() {
        let p = policy(8, vec![64, 48, 64]);
        let mut ws = p.workspace();
        let cap = ws.capacity();
        let mut q = [0.0; 8];
        let mut out = [0.0; 8];
        let mut first = [0.0; 8];
        for i in 0..10_000 {
            let s = Condition {
                theta: (i as f64 * 1e-3).sin() * 3.0,
                scale: 0.5 + 0.5 * ((i % 7) as f64 / 7.0),
                reflection: if i % 2 == 0 { 1 } else { -1 },
            };
            for (j, qj) in q.iter_mut().enumerate() {
                *qj = ((i + j) as f64 * 1e-2).cos();
            }
            p.velocity(&q, &s, &mut out, &mut ws);
            assert!(out.iter().all(|v| v.is_finite()));
            if i == 0 {
                first = out;
            }
            assert_eq!(ws.capacity(), cap);
        }
        // Same input as call 0 gives the same output: no state leaks between calls.
        let mut q0 = [0.0; 8];
        for (j, qj) in q0.iter_mut().enumerate() {
            *qj = (j as f64 * 1e-2).cos();
        }
        p.velocity(
            &q0,
            &Condition {
                theta: 0.0,
                scale: 0.5,
                reflection: 1,
            },
            &mut out,
            &mut ws,
        );
        assert_eq!(out, first);
    }

    #[test]
    fn forward_without_hidden_layers_is_affine() {
        let p = policy(2, vec![]);
        let mut ws = p.workspace();
        let mut out = [0.0; 2];
        p.velocity(&[0.0, 0.0], &Condition::IDENTITY, &mut out, &mut ws);
        // u = [0, 0, 1, 0, 0, 1]: y_r = b_r + W_r2 + W_r5.
        let w = p.mlp().weight(0);
        for r in 0..2 {
            assert!((out[r] - (p.mlp().bias(0)[r] + w[r * 6 + 2] + w[r * 6 + 5])).abs() < 1e-15);
        }
    }

    #[test]
    fn rejects_inconsistent_widths() {
        let spec = MlpSpec {
            input: 6,
            hidden: vec![3],
            output: 2,
            activation: Activation::Tanh,
        };
        assert!(MlpInference::new(spec.clone(), vec![vec![0.0; 18]], vec![vec![0.0; 3]]).is_err());
        let mlp = MlpInference::new(
            spec,
            vec![vec![0.0; 18], vec![0.0; 6]],
            vec![vec![0.0; 3], vec![0.0; 2]],
        )
        .unwrap();
        let e = Policy::new(Normalizer::identity(3), mlp, PolicyMeta::default()).unwrap_err();
        assert!(e.to_string().contains("mlp.input"), "{e}");
    }
}
