//! Task costs `c: X → R` ([`CostSpec`] as configured, [`Cost`] compiled): distances to a
//! point or a line, the height above a plane, weighted sums; analytic gradients.

use super::error::TaskInducedError;

use serde::{Deserialize, Serialize};

/// A task cost `c: R^d → R` as written in configuration (length units of the task space).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum CostSpec {
    /// Euclidean distance `|x − p|` to a point (length units).
    DistanceToPoint {
        /// The point `p` (block coordinates, length units).
        point: Vec<f64>,
    },
    /// Euclidean distance `|(I − u uᵀ)(x − p)|` to the line through `p` along `u` (length units).
    DistanceToLine {
        /// A point `p` on the line (block coordinates).
        point: Vec<f64>,
        /// Direction of the line (any non-zero length; normalised internally).
        direction: Vec<f64>,
    },
    /// Signed height `n·(x − p)/|n|` above the plane (a line in 2-D) through `p` with normal `n`.
    HeightAbovePlane {
        /// A point `p` on the plane (block coordinates).
        point: Vec<f64>,
        /// Normal `n` (any non-zero length; normalised internally), pointing to positive height.
        normal: Vec<f64>,
    },
    /// Weighted sum `Σ_i w_i c_i(x)` of costs.
    Sum {
        /// The terms (at least one).
        terms: Vec<WeightedCost>,
    },
}

fn unit_weight() -> f64 {
    1.0
}

/// One term `w · c(x)` of a [`CostSpec::Sum`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WeightedCost {
    /// Weight `w` (finite, non-zero; dimensionless; default 1).
    #[serde(default = "unit_weight")]
    pub weight: f64,
    /// The cost `c`.
    pub cost: CostSpec,
}

impl CostSpec {
    /// Validates the spec for `d`-dimensional task blocks and compiles it into a [`Cost`].
    pub fn build(&self, dim: usize) -> Result<Cost, TaskInducedError> {
        Cost::new(self, dim)
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Term {
    /// `|x − p|`.
    Point { p: [f64; 3] },
    /// `|(I − u uᵀ)(x − p)|`, `|u| = 1`.
    Line { p: [f64; 3], u: [f64; 3] },
    /// `n·(x − p)`, `|n| = 1`.
    Plane { p: [f64; 3], n: [f64; 3] },
}

/// A validated task cost `c(x) = Σ_i w_i c_i(x)` on one task block `R^d` (length units).
#[derive(Debug, Clone, PartialEq)]
pub struct Cost {
    dim: usize,
    spec: CostSpec,
    terms: Vec<(f64, Term)>,
}

fn check_vec(
    path: &str,
    what: &'static str,
    v: &[f64],
    d: usize,
    nonzero: bool,
) -> Result<[f64; 3], TaskInducedError> {
    if v.len() != d {
        return Err(TaskInducedError::WrongDimension {
            path: path.into(),
            what,
            expected: d,
            got: v.len(),
        });
    }
    if v.iter().any(|a| !a.is_finite()) {
        return Err(TaskInducedError::NonFinite {
            path: path.into(),
            what,
            values: v.to_vec(),
        });
    }
    let mut out = [0.0; 3];
    out[..d].copy_from_slice(v);
    if nonzero {
        let n = norm3(&out);
        if n <= 1e-12 {
            return Err(TaskInducedError::ZeroVector {
                path: path.into(),
                what,
                values: v.to_vec(),
            });
        }
        for a in &mut out {
            *a /= n;
        }
    }
    Ok(out)
}

fn compile(
    spec: &CostSpec,
    d: usize,
    path: &str,
    weight: f64,
    out: &mut Vec<(f64, Term)>,
) -> Result<(), TaskInducedError> {
    match spec {
        CostSpec::DistanceToPoint { point } => {
            let p = check_vec(path, "point", point, d, false)?;
            out.push((weight, Term::Point { p }));
        }
        CostSpec::DistanceToLine { point, direction } => {
            let p = check_vec(path, "point", point, d, false)?;
            let u = check_vec(path, "direction", direction, d, true)?;
            out.push((weight, Term::Line { p, u }));
        }
        CostSpec::HeightAbovePlane { point, normal } => {
            let p = check_vec(path, "point", point, d, false)?;
            let n = check_vec(path, "normal", normal, d, true)?;
            out.push((weight, Term::Plane { p, n }));
        }
        CostSpec::Sum { terms } => {
            if terms.is_empty() {
                return Err(TaskInducedError::EmptySum { path: path.into() });
            }
            for (i, t) in terms.iter().enumerate() {
                let sub = format!("{path}.terms[{i}]");
                if !(t.weight.is_finite() && t.weight != 0.0) {
                    return Err(TaskInducedError::BadWeight {
                        path: sub,
                        weight: t.weight,
                    });
                }
                compile(&t.cost, d, &format!("{sub}.cost"), weight * t.weight, out)?;
            }
        }
    }
    Ok(())
}

pub(super) fn norm3(v: &[f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

pub(super) fn norm(v: &[f64]) -> f64 {
    v.iter().map(|a| a * a).sum::<f64>().sqrt()
}

pub(super) fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

impl Cost {
    /// Validates `spec` for `d`-dimensional blocks (`d` = 2 or 3) and compiles it.
    pub fn new(spec: &CostSpec, dim: usize) -> Result<Self, TaskInducedError> {
        if !(dim == 2 || dim == 3) {
            return Err(TaskInducedError::UnsupportedDim { dim });
        }
        let mut terms = Vec::new();
        compile(spec, dim, "cost", 1.0, &mut terms)?;
        Ok(Self {
            dim,
            spec: spec.clone(),
            terms,
        })
    }

    /// Dimension `d` of the task block the cost lives on.
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// The spec the cost was built from.
    pub fn spec(&self) -> &CostSpec {
        &self.spec
    }

    /// Number of elementary terms after flattening nested sums.
    pub fn terms(&self) -> usize {
        self.terms.len()
    }

    /// Sum of the absolute weights `Σ|w_i|`, an upper bound of `|∇c|` (dimensionless).
    pub fn gradient_bound(&self) -> f64 {
        self.terms.iter().map(|(w, _)| w.abs()).sum()
    }

    /// The anchor points `p` of the terms (block coordinates), used to place the sampling box.
    pub fn anchors(&self) -> Vec<Vec<f64>> {
        self.terms
            .iter()
            .map(|(_, t)| match t {
                Term::Point { p } | Term::Line { p, .. } | Term::Plane { p, .. } => {
                    p[..self.dim].to_vec()
                }
            })
            .collect()
    }

    /// The cost `c(x)` at a block point `x` (`x.len() == d`; length units).
    pub fn value(&self, x: &[f64]) -> f64 {
        debug_assert_eq!(x.len(), self.dim);
        let d = self.dim;
        let mut r = [0.0; 3];
        let mut c = 0.0;
        for (w, t) in &self.terms {
            let v = match t {
                Term::Point { p } => {
                    for i in 0..d {
                        r[i] = x[i] - p[i];
                    }
                    norm3(&r)
                }
                Term::Line { p, u } => {
                    for i in 0..d {
                        r[i] = x[i] - p[i];
                    }
                    let a = dot(&r, u);
                    for i in 0..d {
                        r[i] -= a * u[i];
                    }
                    norm3(&r)
                }
                Term::Plane { p, n } => (0..d).map(|i| (x[i] - p[i]) * n[i]).sum(),
            };
            c += w * v;
        }
        c
    }

    /// Writes the analytic gradient `∇c(x)` (dimensionless) into `out`.
    ///
    /// Returns `false` where `c` is not differentiable: exactly on a term's point (distance to
    /// a point) or line (distance to a line); `out` is then unspecified.
    pub fn gradient(&self, x: &[f64], out: &mut [f64]) -> bool {
        debug_assert_eq!(x.len(), self.dim);
        let d = self.dim;
        out[..d].fill(0.0);
        let mut r = [0.0; 3];
        for (w, t) in &self.terms {
            match t {
                Term::Point { p } | Term::Line { p, .. } => {
                    for i in 0..d {
                        r[i] = x[i] - p[i];
                    }
                    if let Term::Line { u, .. } = t {
                        let a = dot(&r, u);
                        for i in 0..d {
                            r[i] -= a * u[i];
                        }
                    }
                    let n = norm3(&r);
                    if n <= 0.0 || !n.is_finite() {
                        return false;
                    }
                    for i in 0..d {
                        out[i] += w * r[i] / n;
                    }
                }
                Term::Plane { n, .. } => {
                    for i in 0..d {
                        out[i] += w * n[i];
                    }
                }
            }
        }
        true
    }
}
