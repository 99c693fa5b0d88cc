//! Block-diagonal layers stored compactly: the hidden layers of an averaged ensemble are
//! block diagonal, and reading only their blocks gives the dense result bit for bit.

/// Column width a diagonal block must be a multiple of to be packed: the widest
/// accumulator count of [`dot`](super::dot::dot)'s kernels, so that a block's dot product accumulates the
/// same terms in the same lanes as the dense row (whose other terms are exact zeros) and
/// the packed forward is bit-identical to the dense one.
pub(super) const BLOCK_ALIGN: usize = 16;

/// A block-diagonal layer stored compactly: `blocks` diagonal blocks of `[o/blocks ×
/// i/blocks]`, row `r` of the layer reading only its block's columns.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct PackedLayer {
    /// Number of diagonal blocks (≥ 2).
    pub(super) blocks: usize,
    /// Row-major `[o × i/blocks]`: row `r` holds its block's columns.
    pub(super) weights: Vec<f64>,
}

/// The finest block-diagonal structure of the row-major `[o × i]` matrix `w`: the largest
/// `K ≥ 2` dividing `o` and `i`, with `i/K` a multiple of [`BLOCK_ALIGN`], such that every
/// entry off the `K` diagonal blocks is exactly zero; `None` when there is none.
pub(super) fn find_blocks(w: &[f64], o: usize, i: usize) -> Option<PackedLayer> {
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
