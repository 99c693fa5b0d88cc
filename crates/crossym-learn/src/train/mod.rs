//! Imitation learning of `π(q, s) → q̇` with candle, following CONDOR's recipe
//! (Pérez-Dattari & Kober 2023), without its stability loss.
//!
//! Each iteration samples `B` windows `(τ, t)` uniformly over every valid start `t` of
//! every training trajectory `τ` (so long demonstrations weigh more), then, in normalised
//! coordinates `z` (see [`crossym_policy::features`]), with stride `s` (samples per step) and
//! `z_i` held at the last sample past a trajectory's end when [`TrainConfig::pad_end`]:
//!
//! - rolls the network out for `H` Euler steps of `s Δt` from the demonstrated `z_t`,
//!   optionally perturbed by Gaussian noise `ε ~ N(0, σ_n² I)` (DART-like, so the rollout
//!   must return to the demonstration): `ẑ_{k+1} = ẑ_k + s Δt g ⊙ π(ẑ_k, s)`,
//!   `ẑ_0 = z_t + ε`;
//! - `L = mean_{b,k,j} (ẑ_k − z_{t+ks})²  +  w_v · mean_{b,k,j} (π(z_{t+ks}, s) − y_{t+ks})²`
//!   for `k = 1..H` (positions) and `k = 0..H−1` (velocities, `y = q̇ ⊘ v`);
//! - takes one AdamW step with the scheduled learning rate.
//!
//! `H` may grow linearly from [`TrainConfig::horizon_start`] (a curriculum).
//!
//! With [`TrainConfig::task_features`] the network also reads the canonical task point
//! (see [`crossym_policy::canonical`]) of every rollout state, `E_s f(μ + σ_q ⊙ ẑ_k) + e_s`, with the
//! trajectory's affine map `(E_s, e_s)` (inverse group action and normalisation, exact in
//! `f64`, then `f32`) and `f` the batched candle FK ([`task_fk::CandleFk`]), so the
//! loss is differentiated through the FK as well.
//!
//! Scale: the position residuals are `O(H s Δt g)` times the velocity residuals (with
//! `g ≈ 0.1 /s` on the letter task, ~1e-2 for `H s = 100` samples), so any `w_v` of order 1
//! makes the velocity term dominate and training becomes plain behaviour cloning, whose
//! rollouts compound their errors. The letter task therefore trains CONDOR's way, on the
//! rollout term alone (`w_v = 0`), over windows of one second (`s = 10`, `H = 10`): see the
//! `[train]` section of `config/letters.toml` and docs/PERFORMANCE.md.
//!
//! Training runs in `f32` on the CPU. Everything random is seeded from
//! [`TrainConfig::seed`]: the weights are drawn from a seeded `StdRng` (Glorot uniform,
//! zero biases) instead of candle's own initialisers, the window sampler and the start
//! noise use two more streams, so a run is reproducible bit for bit from the
//! configuration and the data (candle's CPU matmul partitions outputs across threads,
//! never a reduction).

use std::time::Instant;

use candle_core::{DType, Device, Tensor, Var};
use candle_nn::optim::{AdamW, Optimizer, ParamsAdamW};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use serde::{Deserialize, Serialize};

use crossym_math::symmetry::compose::Condition;
use crossym_policy::activation::Activation;
use crossym_policy::canonical::TaskFeatures;
use crossym_policy::error::PolicyError;
use crossym_policy::features::{encode_condition, Normalizer, CONDITION_FEATURES};
use crossym_policy::mlp::{MlpInference, MlpSpec, Policy, PolicyMeta};
use crossym_policy::train_config::TrainConfig;
use crossym_policy::JointTrajectory;

pub mod task_fk;
pub use task_fk::CandleFk;

/// Outcome of [`train()`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrainReport {
    /// Loss of the initial network on a fixed evaluation batch.
    pub initial_loss: f64,
    /// Loss of the trained network on the same evaluation batch.
    pub final_loss: f64,
    /// Optimiser steps taken.
    pub iterations: usize,
    /// Wall-clock time of the optimisation loop (s).
    pub seconds: f64,
    /// Number of distinct windows (of the final horizon) sampled from.
    pub windows: usize,
    /// Trajectories skipped because they are shorter than `horizon + 1` samples.
    pub skipped_short: usize,
}

/// The network as candle variables (`f32`, CPU): used for training and as the reference
/// forward pass.
#[derive(Debug, Clone)]
pub struct CandleMlp {
    spec: MlpSpec,
    weights: Vec<Var>,
    biases: Vec<Var>,
}

impl CandleMlp {
    /// Glorot-uniform weights `U(±√(6/(in+out)))` and zero biases, drawn from
    /// `StdRng::seed_from_u64(seed)` layer by layer, row-major.
    pub fn init(spec: &MlpSpec, seed: u64) -> Result<Self, PolicyError> {
        spec.validate().map_err(|message| PolicyError::Config {
            field: "hidden".into(),
            message: message.to_string(),
        })?;
        let mut rng = StdRng::seed_from_u64(seed);
        let mut weights = Vec::new();
        let mut biases = Vec::new();
        for l in 0..spec.num_layers() {
            let (o, i) = spec.layer_shape(l);
            let a = (6.0 / (o + i) as f64).sqrt() as f32;
            let w: Vec<f32> = (0..o * i).map(|_| rng.random_range(-a..a)).collect();
            weights.push(Var::from_tensor(&Tensor::from_vec(
                w,
                (o, i),
                &Device::Cpu,
            )?)?);
            biases.push(Var::from_tensor(&Tensor::zeros(
                o,
                DType::F32,
                &Device::Cpu,
            )?)?);
        }
        Ok(Self {
            spec: spec.clone(),
            weights,
            biases,
        })
    }

    /// The same network as candle variables (weights rounded to `f32`).
    pub fn from_inference(mlp: &MlpInference) -> Result<Self, PolicyError> {
        let spec = mlp.spec().clone();
        let mut weights = Vec::new();
        let mut biases = Vec::new();
        for l in 0..spec.num_layers() {
            let (o, i) = spec.layer_shape(l);
            let w: Vec<f32> = mlp.weight(l).iter().map(|&x| x as f32).collect();
            let b: Vec<f32> = mlp.bias(l).iter().map(|&x| x as f32).collect();
            weights.push(Var::from_tensor(&Tensor::from_vec(
                w,
                (o, i),
                &Device::Cpu,
            )?)?);
            biases.push(Var::from_tensor(&Tensor::from_vec(b, o, &Device::Cpu)?)?);
        }
        Ok(Self {
            spec,
            weights,
            biases,
        })
    }

    /// The architecture.
    pub fn spec(&self) -> &MlpSpec {
        &self.spec
    }

    /// All trainable variables (weights and biases, layer by layer).
    pub fn vars(&self) -> Vec<Var> {
        self.weights
            .iter()
            .zip(&self.biases)
            .flat_map(|(w, b)| [w.clone(), b.clone()])
            .collect()
    }

    /// Forward pass on a `[rows, input]` `f32` tensor, returning `[rows, output]`.
    pub fn forward(&self, x: &Tensor) -> candle_core::Result<Tensor> {
        let last = self.spec.num_layers() - 1;
        let mut h = x.clone();
        for l in 0..=last {
            h = h
                .matmul(&self.weights[l].as_tensor().t()?)?
                .broadcast_add(self.biases[l].as_tensor())?;
            if l < last {
                h = match self.spec.activation {
                    Activation::Tanh => h.tanh()?,
                };
            }
        }
        Ok(h)
    }

    /// Forward pass on `rows` row-major inputs (`f64`, rounded to `f32`); row-major outputs.
    pub fn forward_rows(&self, input: &[f64], rows: usize) -> Result<Vec<f64>, PolicyError> {
        let x: Vec<f32> = input.iter().map(|&v| v as f32).collect();
        let x = Tensor::from_vec(x, (rows, self.spec.input), &Device::Cpu)?;
        let y = self.forward(&x)?.flatten_all()?.to_vec1::<f32>()?;
        Ok(y.into_iter().map(f64::from).collect())
    }

    /// The weights copied out into an [`MlpInference`] (exact `f32 → f64` widening).
    pub fn to_inference(&self) -> Result<MlpInference, PolicyError> {
        let mut w = Vec::new();
        let mut b = Vec::new();
        for l in 0..self.spec.num_layers() {
            let flat = |v: &Var| -> Result<Vec<f64>, PolicyError> {
                Ok(v.as_tensor()
                    .flatten_all()?
                    .to_vec1::<f32>()?
                    .into_iter()
                    .map(f64::from)
                    .collect())
            };
            w.push(flat(&self.weights[l])?);
            b.push(flat(&self.biases[l])?);
        }
        MlpInference::new(self.spec.clone(), w, b).map_err(|message| PolicyError::Backend {
            message: format!("trained weights rejected: {message}"),
        })
    }
}

/// One trajectory in normalised `f32` form.
struct Prepared {
    len: usize,
    z: Vec<f32>,
    y: Vec<f32>,
    cond: [f32; CONDITION_FEATURES],
    /// `stride · Δt g` per joint.
    step: Vec<f32>,
    /// Normalised task features of every sample (`len × m`; empty without them).
    feat: Vec<f32>,
    /// The trajectory's affine feature map `x ↦ E x + e` (`m × m` then `m`).
    canon: (Vec<f32>, Vec<f32>),
}

/// The differentiable task-feature path of the rollout: `q = μ + σ_q ⊙ z`, `x = f(q)`.
struct FeatureGraph {
    fk: CandleFk,
    q_mean: Tensor,
    q_std: Tensor,
}

/// Uniform sampler over all `(trajectory, start)` windows.
struct Sampler {
    /// `cum[i]` = windows in trajectories `< i`; last entry = total.
    cum: Vec<usize>,
    rng: StdRng,
}

impl Sampler {
    fn sample(&mut self) -> (usize, usize) {
        let total = *self.cum.last().unwrap_or(&0);
        let w = self.rng.random_range(0..total);
        let i = self.cum.partition_point(|&c| c <= w) - 1;
        (i, w - self.cum[i])
    }
}

/// Window geometry shared by every batch of a run.
#[derive(Clone, Copy)]
struct Windows {
    /// Rollout steps of this batch.
    h: usize,
    /// Samples per step.
    stride: usize,
    n: usize,
    /// Number of task features.
    m: usize,
    /// Std of the start-state noise (normalised units).
    noise: f32,
}

struct Batch {
    z0: Tensor,
    cond: Tensor,
    /// Per-window feature maps `E` (`[B, m, m]`) and `e` (`[B, m]`), with task features.
    canon: Option<(Tensor, Tensor)>,
    step: Tensor,
    target: Tensor,
    vel_in: Tensor,
    vel_target: Tensor,
}

/// A standard normal draw (Box–Muller).
fn gauss(rng: &mut StdRng) -> f32 {
    let u1: f64 = rng.random_range(f64::MIN_POSITIVE..1.0);
    let u2: f64 = rng.random_range(0.0..1.0);
    ((-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()) as f32
}

fn make_batch(
    data: &[Prepared],
    sampler: &mut Sampler,
    noise_rng: &mut StdRng,
    b: usize,
    w: Windows,
) -> Result<Batch, PolicyError> {
    let Windows {
        h,
        stride,
        n,
        m,
        noise,
    } = w;
    let c = CONDITION_FEATURES;
    let mut z0 = Vec::with_capacity(b * n);
    let mut cond = Vec::with_capacity(b * c);
    let mut canon_e = Vec::with_capacity(b * m * m);
    let mut canon_b = Vec::with_capacity(b * m);
    let mut step = Vec::with_capacity(b * n);
    let mut target = Vec::with_capacity(b * h * n);
    let mut vel_in = Vec::with_capacity(b * h * (n + m + c));
    let mut vel_target = Vec::with_capacity(b * h * n);
    for _ in 0..b {
        let (i, t) = sampler.sample();
        let p = &data[i];
        // Sample index of window point k (held at the last sample past the end).
        let at = |k: usize| (t + k * stride).min(p.len - 1);
        let s0 = at(0);
        if noise > 0.0 {
            z0.extend(
                p.z[s0 * n..(s0 + 1) * n]
                    .iter()
                    .map(|&v| v + noise * gauss(noise_rng)),
            );
        } else {
            z0.extend_from_slice(&p.z[s0 * n..(s0 + 1) * n]);
        }
        cond.extend_from_slice(&p.cond);
        step.extend_from_slice(&p.step);
        canon_e.extend_from_slice(&p.canon.0);
        canon_b.extend_from_slice(&p.canon.1);
        for k in 1..=h {
            let s = at(k);
            target.extend_from_slice(&p.z[s * n..(s + 1) * n]);
        }
        for k in 0..h {
            let s = at(k);
            vel_in.extend_from_slice(&p.z[s * n..(s + 1) * n]);
            vel_in.extend_from_slice(&p.feat[s * m..(s + 1) * m]);
            vel_in.extend_from_slice(&p.cond);
            if at(k + 1) == s {
                // Holding at the goal: the demonstrated motion is zero.
                vel_target.extend(std::iter::repeat_n(0.0f32, n));
            } else {
                vel_target.extend_from_slice(&p.y[s * n..(s + 1) * n]);
            }
        }
    }
    let dev = &Device::Cpu;
    Ok(Batch {
        z0: Tensor::from_vec(z0, (b, n), dev)?,
        cond: Tensor::from_vec(cond, (b, c), dev)?,
        canon: if m > 0 {
            Some((
                Tensor::from_vec(canon_e, (b, m, m), dev)?,
                Tensor::from_vec(canon_b, (b, m), dev)?,
            ))
        } else {
            None
        },
        step: Tensor::from_vec(step, (b, n), dev)?,
        target: Tensor::from_vec(target, (b, h, n), dev)?,
        vel_in: Tensor::from_vec(vel_in, (b * h, n + m + c), dev)?,
        vel_target: Tensor::from_vec(vel_target, (b * h, n), dev)?,
    })
}

/// The network input `[z, E f(μ + σ_q ⊙ z) + e, cond]` (or `[z, cond]`) of a rollout state.
fn rollout_input(
    z: &Tensor,
    batch: &Batch,
    graph: Option<&FeatureGraph>,
) -> candle_core::Result<Tensor> {
    match (graph, &batch.canon) {
        (Some(g), Some((e_mat, e_off))) => {
            let q = z.broadcast_mul(&g.q_std)?.broadcast_add(&g.q_mean)?;
            let x = g.fk.forward(&q)?.unsqueeze(2)?;
            let feat = (e_mat.matmul(&x)?.squeeze(2)? + e_off)?;
            Tensor::cat(&[z, &feat, &batch.cond], 1)
        }
        _ => Tensor::cat(&[z, &batch.cond], 1),
    }
}

/// The CONDOR imitation loss of one batch (scalar tensor).
fn batch_loss(
    mlp: &CandleMlp,
    batch: &Batch,
    graph: Option<&FeatureGraph>,
    h: usize,
    w_v: f64,
) -> candle_core::Result<Tensor> {
    let mut z = batch.z0.clone();
    let mut zs = Vec::with_capacity(h);
    for _ in 0..h {
        let u = rollout_input(&z, batch, graph)?;
        let y = mlp.forward(&u)?;
        z = (z + y.mul(&batch.step)?)?;
        zs.push(z.clone());
    }
    let roll = Tensor::stack(&zs, 1)?;
    let pos = (roll - &batch.target)?.sqr()?.mean_all()?;
    if w_v == 0.0 {
        return Ok(pos);
    }
    let vel = (mlp.forward(&batch.vel_in)? - &batch.vel_target)?
        .sqr()?
        .mean_all()?;
    pos + (vel * w_v)?
}

fn scalar(t: &Tensor) -> Result<f64, PolicyError> {
    Ok(f64::from(t.to_scalar::<f32>()?))
}

/// Checks and normalises the training data; returns the prepared trajectories and the
/// number of short ones skipped.
fn prepare(
    data: &[(&JointTrajectory, Condition)],
    norm: &Normalizer,
    features: Option<&TaskFeatures>,
    min_len: usize,
    stride: usize,
) -> (Vec<Prepared>, usize) {
    let n = norm.dim();
    let m = features.map_or(0, TaskFeatures::dim);
    let mut fws = features.map(TaskFeatures::workspace);
    let mut fq = vec![0.0; m];
    let mut out = Vec::new();
    let mut skipped = 0;
    let mut zq = vec![0.0; n];
    let mut yq = vec![0.0; n];
    for (t, s) in data {
        let len = t.len();
        if len < min_len {
            skipped += 1;
            continue;
        }
        let mut z = Vec::with_capacity(len * n);
        let mut y = Vec::with_capacity(len * n);
        let mut feat = Vec::with_capacity(len * m);
        for i in 0..len {
            norm.normalize_q(t.q(i), &mut zq);
            norm.normalize_qdot(t.qdot(i), &mut yq);
            z.extend(zq.iter().map(|&v| v as f32));
            y.extend(yq.iter().map(|&v| v as f32));
            if let (Some(f), Some(ws)) = (features, fws.as_mut()) {
                f.encode(t.q(i), s, &mut fq, ws);
                feat.extend(fq.iter().map(|&v| v as f32));
            }
        }
        let canon = features.map_or((Vec::new(), Vec::new()), |f| {
            let (e, b) = f.affine_for(s);
            (
                e.iter().map(|&v| v as f32).collect(),
                b.iter().map(|&v| v as f32).collect(),
            )
        });
        let mut c = [0.0f64; CONDITION_FEATURES];
        encode_condition(s, &mut c);
        out.push(Prepared {
            len,
            z,
            y,
            cond: c.map(|v| v as f32),
            step: (0..n)
                .map(|j| (stride as f64 * t.dt * norm.gain(j)) as f32)
                .collect(),
            feat,
            canon,
        });
    }
    (out, skipped)
}

fn check_data(data: &[(&JointTrajectory, Condition)]) -> Result<(), PolicyError> {
    let bad = |message: String| Err(PolicyError::Data { message });
    let Some((first, _)) = data.first() else {
        return bad("no training trajectories".into());
    };
    let n = first.n;
    if n == 0 {
        return bad(format!("demonstration {} has zero joints", first.demo));
    }
    for (k, (t, s)) in data.iter().enumerate() {
        let what = format!("trajectory {k} (demo {})", t.demo);
        if t.n != n {
            return bad(format!("{what} has {} joints, expected {n}", t.n));
        }
        if t.q.len() % n != 0 || t.qdot.len() != t.q.len() {
            return bad(format!(
                "{what}: q has {} values and qdot {}, expected equal multiples of {n}",
                t.q.len(),
                t.qdot.len()
            ));
        }
        if !(t.dt.is_finite() && t.dt > 0.0) {
            return bad(format!("{what}: dt {} must be positive", t.dt));
        }
        if t.q.iter().chain(&t.qdot).any(|v| !v.is_finite()) {
            return bad(format!("{what} has non-finite positions or velocities"));
        }
        if let Err(m) = s.validate() {
            return bad(format!("{what}: condition: {m}"));
        }
    }
    Ok(())
}

/// Trains a policy on `(trajectory, condition)` pairs; `progress(iteration, loss)` is
/// called every [`TrainConfig::log_every`] iterations and after the last one, with the
/// number of completed iterations and that batch's loss.
///
/// `meta` is stored in the policy with `train_config` set to `config`.
pub fn train(
    data: &[(&JointTrajectory, Condition)],
    config: &TrainConfig,
    meta: PolicyMeta,
    progress: impl FnMut(usize, f64),
) -> Result<(Policy, TrainReport), PolicyError> {
    train_with_features(data, config, meta, None, progress)
}

/// [`train_with_features`] for `config.ensemble > 1`: one member per seed, progress
/// reported over all members' iterations, merged by [`Policy::average`].
fn train_ensemble(
    data: &[(&JointTrajectory, Condition)],
    config: &TrainConfig,
    meta: PolicyMeta,
    features: Option<TaskFeatures>,
    mut progress: impl FnMut(usize, f64),
) -> Result<(Policy, TrainReport), PolicyError> {
    let mut members = Vec::with_capacity(config.ensemble);
    let mut report: Option<TrainReport> = None;
    for k in 0..config.ensemble {
        let member = TrainConfig {
            ensemble: 1,
            seed: config.seed.wrapping_add(k as u64),
            ..config.clone()
        };
        let offset = k * config.iterations;
        // A `dyn` callback: one instantiation, however the caller's closure is typed.
        let each: &mut dyn FnMut(usize, f64) = &mut |it, l| progress(offset + it, l);
        let (p, r) = train_with_features(data, &member, meta.clone(), features.clone(), each)?;
        members.push(p);
        report = Some(match report {
            None => r,
            Some(acc) => TrainReport {
                initial_loss: acc.initial_loss + r.initial_loss,
                final_loss: acc.final_loss + r.final_loss,
                iterations: acc.iterations + r.iterations,
                seconds: acc.seconds + r.seconds,
                ..acc
            },
        });
    }
    let mut policy = Policy::average(&members)?;
    policy.meta.train_config = Some(config.clone());
    let mut report = report.expect("ensemble ≥ 2 members");
    // Mean losses of the members (each on its own evaluation batch).
    report.initial_loss /= config.ensemble as f64;
    report.final_loss /= config.ensemble as f64;
    Ok((policy, report))
}

/// [`train()`] for a policy with canonical task-space features (`features` with
/// [`TrainConfig::task_features`]; their normalisation is fitted on `data` here).
pub fn train_with_features(
    data: &[(&JointTrajectory, Condition)],
    config: &TrainConfig,
    mut meta: PolicyMeta,
    mut features: Option<TaskFeatures>,
    mut progress: impl FnMut(usize, f64),
) -> Result<(Policy, TrainReport), PolicyError> {
    config.validate()?;
    check_data(data)?;
    if config.ensemble > 1 {
        return train_ensemble(data, config, meta, features, progress);
    }
    fit_features(data, config, features.as_mut())?;
    let h = config.horizon;
    let stride = config.stride;
    // A window spans `h · stride` samples; padded windows only need two samples.
    let span = h * stride;
    let min_len = if config.pad_end { 2 } else { span + 1 };
    let normalizer = Normalizer::fit(data.iter().map(|(t, _)| *t))?;
    let n = normalizer.dim();
    let m = features.as_ref().map_or(0, TaskFeatures::dim);
    let (prepared, skipped_short) = prepare(data, &normalizer, features.as_ref(), min_len, stride);
    let graph = features
        .as_ref()
        .map(|f| feature_graph(f, &normalizer))
        .transpose()?;
    let cum = window_counts(&prepared, config.pad_end, span);
    let windows = *cum.last().unwrap_or(&0);
    if windows == 0 {
        return Err(too_short(h, stride));
    }
    let spec = MlpSpec {
        input: normalizer.input_dim() + m,
        hidden: config.hidden.clone(),
        output: n,
        activation: config.activation,
    };
    let mlp = CandleMlp::init(&spec, config.seed)?;
    // The loss reported before and after training: full horizon, no start noise.
    let full = Windows {
        h,
        stride,
        n,
        m,
        noise: 0.0,
    };
    let (initial_loss, final_loss, seconds) = fit_mlp(
        &mlp,
        config,
        &prepared,
        cum,
        graph.as_ref(),
        full,
        &mut progress,
    )?;
    meta.train_config = Some(config.clone());
    let policy = Policy::with_task_features(normalizer, mlp.to_inference()?, features, meta)?;
    Ok((
        policy,
        TrainReport {
            initial_loss,
            final_loss,
            iterations: config.iterations,
            seconds,
            windows,
            skipped_short,
        },
    ))
}

/// Trains `mlp` on windows of `prepared` (counts `cum`); the loss on one evaluation batch
/// of `full` windows before and after, and the seconds the optimisation took.
fn fit_mlp(
    mlp: &CandleMlp,
    config: &TrainConfig,
    prepared: &[Prepared],
    cum: Vec<usize>,
    graph: Option<&FeatureGraph>,
    full: Windows,
    progress: &mut impl FnMut(usize, f64),
) -> Result<(f64, f64, f64), PolicyError> {
    let h = full.h;
    let (mut sampler, mut eval_sampler, mut noise_rng) = samplers(cum, config.seed);
    let w_v = config.velocity_weight;
    let eval = make_batch(
        prepared,
        &mut eval_sampler,
        &mut noise_rng,
        config.batch_size.max(256),
        full,
    )?;
    let initial_loss = scalar(&batch_loss(mlp, &eval, graph, h, w_v)?)?;
    let mut opt = adamw(mlp, config)?;
    let start = Instant::now();
    let batches = Batches {
        prepared,
        sampler: &mut sampler,
        noise_rng: &mut noise_rng,
        full,
    };
    optimise(mlp, &mut opt, config, batches, graph, progress)?;
    let seconds = start.elapsed().as_secs_f64();
    let final_loss = scalar(&batch_loss(mlp, &eval, graph, h, w_v)?)?;
    if !final_loss.is_finite() {
        return Err(PolicyError::Diverged {
            iteration: config.iterations,
            loss: final_loss,
        });
    }
    Ok((initial_loss, final_loss, seconds))
}

/// The error for data without a trajectory long enough for one window.
fn too_short(h: usize, stride: usize) -> PolicyError {
    PolicyError::Data {
        message: format!(
            "no trajectory has the {} samples a horizon of {h} (stride {stride}) needs",
            h * stride + 1
        ),
    }
}

/// The training and evaluation window samplers over `cum` and the start-noise generator,
/// each seeded from `seed`.
fn samplers(cum: Vec<usize>, seed: u64) -> (Sampler, Sampler, StdRng) {
    let sampler = Sampler {
        cum: cum.clone(),
        rng: StdRng::seed_from_u64(seed ^ 0x9E37_79B9_7F4A_7C15),
    };
    let eval_sampler = Sampler {
        cum,
        rng: StdRng::seed_from_u64(seed ^ 0xD1B5_4A32_D192_ED03),
    };
    let noise_rng = StdRng::seed_from_u64(seed ^ 0x94D0_49BB_1331_11EB);
    (sampler, eval_sampler, noise_rng)
}

/// The AdamW optimiser of `mlp`'s variables with `config`'s rate and weight decay.
fn adamw(mlp: &CandleMlp, config: &TrainConfig) -> Result<AdamW, PolicyError> {
    Ok(AdamW::new(
        mlp.vars(),
        ParamsAdamW {
            lr: config.learning_rate,
            beta1: 0.9,
            beta2: 0.999,
            eps: 1e-8,
            weight_decay: config.weight_decay,
        },
    )?)
}

/// Checks that task features are given exactly when `config` asks for them and fits their
/// normalisation on `data`.
fn fit_features(
    data: &[(&JointTrajectory, Condition)],
    config: &TrainConfig,
    features: Option<&mut TaskFeatures>,
) -> Result<(), PolicyError> {
    if config.task_features != features.is_some() {
        return Err(PolicyError::Data {
            message: format!(
                "[train] task_features = {} but task features were{} given",
                config.task_features,
                if features.is_some() { "" } else { " not" }
            ),
        });
    }
    if let Some(f) = features {
        f.fit(data.iter().map(|(t, s)| (*t, *s)))
            .map_err(|message| PolicyError::Data {
                message: message.to_string(),
            })?;
    }
    Ok(())
}

/// The candle FK of the task features `f` and the joint normalisation it undoes.
fn feature_graph(f: &TaskFeatures, normalizer: &Normalizer) -> Result<FeatureGraph, PolicyError> {
    let n = normalizer.dim();
    let row = |v: &[f64]| {
        Tensor::from_vec(
            v.iter().map(|&x| x as f32).collect::<Vec<_>>(),
            (1, n),
            &Device::Cpu,
        )
    };
    Ok(FeatureGraph {
        fk: CandleFk::new(
            f.spec()
                .chains
                .iter()
                .map(|c| (c.q_offset, c.factors.clone()))
                .collect(),
        ),
        q_mean: row(&normalizer.q_mean)?,
        q_std: row(&normalizer.q_std)?,
    })
}

/// Cumulative window counts of `prepared` (`cum[i]` = windows in trajectories `< i`): a
/// window spans `span` samples, or starts anywhere but the last sample when `pad_end`.
fn window_counts(prepared: &[Prepared], pad_end: bool, span: usize) -> Vec<usize> {
    let mut cum = vec![0usize];
    for p in prepared {
        let starts = if pad_end { p.len - 1 } else { p.len - span };
        cum.push(cum.last().copied().unwrap_or(0) + starts);
    }
    cum
}

/// Where training batches come from: the prepared trajectories, the window sampler, the
/// start-noise generator and the full-horizon window shape.
struct Batches<'a> {
    prepared: &'a [Prepared],
    sampler: &'a mut Sampler,
    noise_rng: &'a mut StdRng,
    full: Windows,
}

/// The training iterations: per iteration the scheduled learning rate and horizon, a
/// batch, the loss (an error when not finite) and one AdamW step; `progress` every
/// `log_every` iterations and at the end.
fn optimise(
    mlp: &CandleMlp,
    opt: &mut AdamW,
    config: &TrainConfig,
    batches: Batches<'_>,
    graph: Option<&FeatureGraph>,
    progress: &mut impl FnMut(usize, f64),
) -> Result<(), PolicyError> {
    let w_v = config.velocity_weight;
    for k in 0..config.iterations {
        opt.set_learning_rate(
            config
                .lr_schedule
                .at(config.learning_rate, k, config.iterations),
        );
        let hk = config.horizon_at(k);
        let w = Windows {
            h: hk,
            noise: config.start_noise as f32,
            ..batches.full
        };
        let batch = make_batch(
            batches.prepared,
            batches.sampler,
            batches.noise_rng,
            config.batch_size,
            w,
        )?;
        let loss = batch_loss(mlp, &batch, graph, hk, w_v)?;
        let l = scalar(&loss)?;
        if !l.is_finite() {
            return Err(PolicyError::Diverged {
                iteration: k,
                loss: l,
            });
        }
        opt.backward_step(&loss)?;
        if (k + 1) % config.log_every == 0 || k + 1 == config.iterations {
            progress(k + 1, l);
        }
    }
    Ok(())
}
