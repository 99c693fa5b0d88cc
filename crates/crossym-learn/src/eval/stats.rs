//! Summary statistics of the scores.

/// Mean and standard deviation of `values` with `ddof` delta degrees of freedom (numpy's
/// `std(ddof=…)`: divisor `len − ddof`); the std is NaN when `len ≤ ddof` and `ddof > 0`,
/// and both are 0 for an empty slice with `ddof = 0`.
///
/// ```
/// assert_eq!(crossym_learn::eval::mean_std(&[1.0, 3.0], 0), (2.0, 1.0));
/// assert_eq!(crossym_learn::eval::mean_std(&[1.0, 3.0], 1), (2.0, 2f64.sqrt()));
/// ```
pub fn mean_std(values: &[f64], ddof: usize) -> (f64, f64) {
    let n = values.len();
    let mean = values.iter().sum::<f64>() / n.max(1) as f64;
    if ddof > 0 && n <= ddof {
        return (mean, f64::NAN);
    }
    let ss = values.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>();
    (mean, (ss / (n - ddof).max(1) as f64).sqrt())
}
