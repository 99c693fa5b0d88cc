//! The dot product of the forward pass: AVX2 + FMA where the CPU has them, else a
//! portable loop ([`dot_kernel`] says which).

/// Which dot-product kernel [`MlpInference::forward`](super::MlpInference::forward) uses on this CPU: `"avx2+fma"` or
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
pub(super) fn dot(a: &[f64], b: &[f64]) -> f64 {
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
