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
//! [`Policy`] couples it with the [`Normalizer`](super::Normalizer) and provenance ([`PolicyMeta`]);
//! [`Policy::velocity`] is the control-loop entry point and allocates nothing.
//!
//! Files: [`spec`] (architecture and workspace), `packed` (block-diagonal layers stored
//! compactly), [`inference`] (the weights and the forward pass), `dot` (the dot-product
//! kernels), [`policy`] (the control-loop policy and its provenance).

mod dot;
pub mod inference;
mod packed;
pub mod policy;
pub mod spec;

#[cfg(test)]
mod tests;

pub use dot::dot_kernel;
pub use inference::MlpInference;
pub use policy::{Policy, PolicyMeta, PolicyWorkspace};
pub use spec::{MlpSpec, MlpWorkspace};
