//! The network's weights as plain `f64` vectors and its allocation-free forward pass
//! ([`MlpInference`]), including the average of an ensemble as one network.

use super::dot::dot;
use super::packed::{find_blocks, PackedLayer};
use super::spec::{MlpSpec, MlpWorkspace};
use crate::error::PolicyFitError;

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
    pub(super) fn dense_only(&self) -> Self {
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
