//! Flows of vector fields: `dγ/dt = X(γ)`, `γ(0) = p` (paper eqs. 7, 18).
//!
//! The group action of a one-parameter subgroup is the flow of its generator,
//! `Φ(exp(tξ), p) = γ_ξ(t, p)` (eq. 7 for task-induced symmetries, eq. 18 for lifted
//! ones). The flow is integrated with the embedded Runge–Kutta 5(4) pair of Dormand &
//! Prince (1980) with FSAL and the standard step-size controller (Hairer, Nørsett &
//! Wanner, *Solving ODEs I*, Sec. II.4), so the step count follows an error estimate.
//!
//! The differential of the flow map, needed to transform velocities
//! (`q̇ ↦ dΦ_g|_q q̇`), is integrated together with it from the variational equation
//! `dδ/dt = dX|_γ δ`, `δ(0) = v`, where `dX|_γ δ` is a central difference of the field
//! along `δ` at the same point (no step-sequence noise).
//!
//! [`integrate`] allocates nothing; scratch lives in a caller-owned [`FlowWorkspace`].

use crate::symmetry::field::VectorField;

/// Tolerances and limits of the integrator.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FlowSettings {
    /// Relative tolerance per component.
    #[serde(default = "default_rtol")]
    pub rtol: f64,
    /// Absolute tolerance per component (units of the coordinates).
    #[serde(default = "default_atol")]
    pub atol: f64,
    /// Maximum number of attempted steps before giving up.
    #[serde(default = "default_max_steps")]
    pub max_steps: usize,
    /// Only the first `error_dims` components enter the step-size control (e.g. the
    /// positions of a variational system, whose tangent part follows the same steps);
    /// absent → all.
    #[serde(default)]
    pub error_dims: Option<usize>,
}

fn default_rtol() -> f64 {
    1e-10
}
fn default_atol() -> f64 {
    1e-12
}
fn default_max_steps() -> usize {
    20_000
}

impl Default for FlowSettings {
    fn default() -> Self {
        Self {
            rtol: default_rtol(),
            atol: default_atol(),
            max_steps: default_max_steps(),
            error_dims: None,
        }
    }
}

impl FlowSettings {
    /// Checks that tolerances are positive and finite.
    pub fn validate(&self) -> Result<(), String> {
        if !(self.rtol > 0.0 && self.rtol.is_finite() && self.atol > 0.0 && self.atol.is_finite()) {
            return Err(format!(
                "flow tolerances rtol={} atol={} must be positive",
                self.rtol, self.atol
            ));
        }
        if self.max_steps == 0 {
            return Err("flow max_steps must be positive".into());
        }
        Ok(())
    }
}

/// Numerical outcome of a flow integration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FlowStatus {
    /// Reached the final time.
    Done {
        /// Accepted steps.
        steps: usize,
        /// Rejected steps.
        rejected: usize,
    },
    /// The field was undefined (e.g. a kinematic singularity) at time `t`.
    FieldUndefined {
        /// Time reached before the failure.
        t: f64,
    },
    /// The state became non-finite at time `t`.
    NonFinite {
        /// Time reached.
        t: f64,
    },
    /// `max_steps` were used before reaching the final time.
    TooManySteps {
        /// Time reached.
        t: f64,
    },
}

impl FlowStatus {
    /// True for [`FlowStatus::Done`].
    pub fn is_done(&self) -> bool {
        matches!(self, Self::Done { .. })
    }
}

/// Scratch for flows on `R^d`.
#[derive(Debug, Clone)]
pub struct FlowWorkspace {
    k: [Vec<f64>; 7],
    y: Vec<f64>,
    tmp: Vec<f64>,
    y5: Vec<f64>,
}

impl FlowWorkspace {
    /// Scratch for dimension `d` (allocates; setup only).
    pub fn new(d: usize) -> Self {
        Self {
            k: std::array::from_fn(|_| vec![0.0; d]),
            y: vec![0.0; d],
            tmp: vec![0.0; d],
            y5: vec![0.0; d],
        }
    }

    /// Dimension the workspace was made for.
    pub fn dim(&self) -> usize {
        self.y.len()
    }
}

// Dormand–Prince 5(4) tableau (autonomous fields: the nodes c_i are not needed).
// Row 6 of A is the 5th-order solution weights b (FSAL).
const A: [[f64; 6]; 7] = [
    [0.0; 6],
    [1.0 / 5.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [3.0 / 40.0, 9.0 / 40.0, 0.0, 0.0, 0.0, 0.0],
    [44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0, 0.0, 0.0, 0.0],
    [
        19372.0 / 6561.0,
        -25360.0 / 2187.0,
        64448.0 / 6561.0,
        -212.0 / 729.0,
        0.0,
        0.0,
    ],
    [
        9017.0 / 3168.0,
        -355.0 / 33.0,
        46732.0 / 5247.0,
        49.0 / 176.0,
        -5103.0 / 18656.0,
        0.0,
    ],
    [
        35.0 / 384.0,
        0.0,
        500.0 / 1113.0,
        125.0 / 192.0,
        -2187.0 / 6784.0,
        11.0 / 84.0,
    ],
];
const E: [f64; 7] = [
    71.0 / 57600.0,
    0.0,
    -71.0 / 16695.0,
    71.0 / 1920.0,
    -17253.0 / 339200.0,
    22.0 / 525.0,
    -1.0 / 40.0,
];

/// Integrates `dy/dt = X(y)` from `y0` over time `t` (may be negative) into `out`.
/// Allocation-free.
pub fn integrate(
    field: &dyn VectorField,
    t: f64,
    y0: &[f64],
    out: &mut [f64],
    settings: &FlowSettings,
    ws: &mut FlowWorkspace,
) -> FlowStatus {
    let d = y0.len();
    debug_assert_eq!(ws.dim(), d);
    ws.y.copy_from_slice(y0);
    if t == 0.0 {
        out.copy_from_slice(y0);
        return FlowStatus::Done {
            steps: 0,
            rejected: 0,
        };
    }
    let dir = t.signum();
    let total = t.abs();
    let mut s = 0.0; // |time| done
    let mut steps = 0;
    let mut rejected = 0;
    if !field.eval(&ws.y, &mut ws.k[0]) {
        return FlowStatus::FieldUndefined { t: 0.0 };
    }
    // Initial step (Hairer's heuristic, simplified).
    let norm = |v: &[f64], y: &[f64]| -> f64 {
        let mut acc = 0.0;
        for (a, b) in v.iter().zip(y) {
            let sc = settings.atol + settings.rtol * b.abs();
            acc += (a / sc) * (a / sc);
        }
        (acc / d as f64).sqrt()
    };
    let d0 = norm(&ws.y, &ws.y);
    let d1 = norm(&ws.k[0], &ws.y);
    let mut h = if d0 < 1e-5 || d1 < 1e-5 {
        1e-6
    } else {
        0.01 * d0 / d1
    };
    h = h.min(total).max(total * 1e-12);
    let mut attempts = 0;
    while s < total {
        attempts += 1;
        if attempts > settings.max_steps {
            return FlowStatus::TooManySteps { t: dir * s };
        }
        if s + h > total {
            h = total - s;
        }
        let hs = dir * h;
        let mut defined = true;
        for stage in 1..7 {
            for i in 0..d {
                let mut acc = ws.y[i];
                for (j, a) in A[stage].iter().enumerate().take(stage) {
                    acc += hs * a * ws.k[j][i];
                }
                ws.tmp[i] = acc;
            }
            let (_, tail) = ws.k.split_at_mut(stage);
            if !field.eval(&ws.tmp, &mut tail[0]) {
                defined = false;
                break;
            }
        }
        if !defined {
            // Shrink the step; a genuinely undefined region stops the flow.
            if h < total * 1e-9 {
                return FlowStatus::FieldUndefined { t: dir * s };
            }
            h *= 0.25;
            rejected += 1;
            continue;
        }
        // The 7th stage was evaluated at y5 (FSAL): tmp holds y5.
        ws.y5.copy_from_slice(&ws.tmp);
        let mut err = 0.0;
        let de = settings.error_dims.unwrap_or(d).clamp(1, d);
        for i in 0..de {
            let mut e = 0.0;
            for j in 0..7 {
                e += E[j] * ws.k[j][i];
            }
            let e = hs * e;
            let sc = settings.atol + settings.rtol * ws.y[i].abs().max(ws.y5[i].abs());
            err += (e / sc) * (e / sc);
        }
        let err = (err / de as f64).sqrt();
        if !err.is_finite() {
            if h < total * 1e-9 {
                return FlowStatus::NonFinite { t: dir * s };
            }
            h *= 0.25;
            rejected += 1;
            continue;
        }
        let fac = (0.9 * err.powf(-0.2)).clamp(0.2, 5.0);
        if err <= 1.0 {
            s += h;
            steps += 1;
            ws.y.copy_from_slice(&ws.y5);
            let (first, rest) = ws.k.split_at_mut(1);
            first[0].copy_from_slice(&rest[5]);
            h *= if rejected > 0 && err > 0.5 {
                fac.min(1.0)
            } else {
                fac
            };
        } else {
            rejected += 1;
            h *= fac.min(1.0);
        }
    }
    out.copy_from_slice(&ws.y);
    if out.iter().any(|v| !v.is_finite()) {
        return FlowStatus::NonFinite { t };
    }
    FlowStatus::Done { steps, rejected }
}

/// The field `(y, δ) ↦ (X(y), dX|_y δ)` on `R^{2d}` whose flow carries the flow map's
/// differential (variational equation). Uses interior scratch; not thread-safe.
pub struct VariationalField<'a> {
    field: &'a dyn VectorField,
    h: f64,
    forward: bool,
    scratch: std::cell::RefCell<[Vec<f64>; 3]>,
}

impl<'a> VariationalField<'a> {
    /// Wraps `field` with central-difference step `h` (relative to the state norm).
    pub fn new(field: &'a dyn VectorField, h: f64) -> Self {
        let d = field.dim();
        Self {
            field,
            h,
            forward: false,
            scratch: std::cell::RefCell::new([vec![0.0; d], vec![0.0; d], vec![0.0; d]]),
        }
    }

    /// Forward differences `(X(y + hδ) − X(y)) / h` instead of central ones: one field
    /// evaluation per stage instead of two, error `O(h)` instead of `O(h²)` (use
    /// `h ≈ 1e-8`, about `√ε`).
    pub fn forward(field: &'a dyn VectorField, h: f64) -> Self {
        Self {
            forward: true,
            ..Self::new(field, h)
        }
    }
}

impl VectorField for VariationalField<'_> {
    fn dim(&self) -> usize {
        2 * self.field.dim()
    }
    fn eval(&self, p: &[f64], out: &mut [f64]) -> bool {
        let d = self.field.dim();
        let (y, delta) = p.split_at(d);
        let (oy, od) = out.split_at_mut(d);
        if !self.field.eval(y, oy) {
            return false;
        }
        let dn = delta.iter().map(|a| a * a).sum::<f64>().sqrt();
        if dn == 0.0 {
            od.fill(0.0);
            return true;
        }
        let yn = y.iter().map(|a| a * a).sum::<f64>().sqrt();
        let step = self.h * yn.max(1.0) / dn;
        let mut sc = self.scratch.borrow_mut();
        let [probe, fp, fm] = &mut *sc;
        for i in 0..d {
            probe[i] = y[i] + step * delta[i];
        }
        if !self.field.eval(probe, fp) {
            return false;
        }
        if self.forward {
            for i in 0..d {
                od[i] = (fp[i] - oy[i]) / step;
            }
            return true;
        }
        for i in 0..d {
            probe[i] = y[i] - step * delta[i];
        }
        if !self.field.eval(probe, fm) {
            return false;
        }
        for i in 0..d {
            od[i] = (fp[i] - fm[i]) / (2.0 * step);
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::symmetry::field::FnField;

    #[test]
    fn rotation_flow_is_exact_and_periodic() {
        let rot = FnField::new(2, |p: &[f64], o: &mut [f64]| {
            o[0] = -p[1];
            o[1] = p[0];
        });
        let mut ws = FlowWorkspace::new(2);
        let mut out = [0.0; 2];
        let st = integrate(
            &rot,
            1.0,
            &[2.0, 0.0],
            &mut out,
            &FlowSettings::default(),
            &mut ws,
        );
        assert!(st.is_done());
        assert!(
            (out[0] - 2.0 * 1f64.cos()).abs() < 1e-9 && (out[1] - 2.0 * 1f64.sin()).abs() < 1e-9,
            "{out:?}"
        );
        let st = integrate(
            &rot,
            -std::f64::consts::TAU,
            &[2.0, 0.0],
            &mut out,
            &FlowSettings::default(),
            &mut ws,
        );
        assert!(st.is_done());
        assert!(
            (out[0] - 2.0).abs() < 1e-8 && out[1].abs() < 1e-8,
            "{out:?}"
        );
    }

    #[test]
    fn variational_flow_gives_the_differential() {
        // Flow of x' = x² from x0: x(t) = x0 / (1 − t x0); dx/dx0 = 1 / (1 − t x0)².
        let f = FnField::new(1, |p: &[f64], o: &mut [f64]| o[0] = p[0] * p[0]);
        let var = VariationalField::new(&f, 1e-6);
        let mut ws = FlowWorkspace::new(2);
        let mut out = [0.0; 2];
        let st = integrate(
            &var,
            0.5,
            &[1.0, 1.0],
            &mut out,
            &FlowSettings::default(),
            &mut ws,
        );
        assert!(st.is_done());
        assert!((out[0] - 2.0).abs() < 1e-8, "{out:?}");
        assert!((out[1] - 4.0).abs() < 1e-6, "{out:?}");
        // Forward differences with step control on the position only (the augmentation's
        // setting) give the same differential to ~1e-6.
        let var = VariationalField::forward(&f, 1e-8);
        let settings = FlowSettings {
            rtol: 1e-8,
            atol: 1e-10,
            error_dims: Some(1),
            ..Default::default()
        };
        let st = integrate(&var, 0.5, &[1.0, 1.0], &mut out, &settings, &mut ws);
        assert!(st.is_done());
        assert!((out[0] - 2.0).abs() < 1e-6, "{out:?}");
        assert!((out[1] - 4.0).abs() < 1e-5, "{out:?}");
    }

    #[test]
    fn undefined_field_is_reported() {
        let f = FnField::new(1, |_: &[f64], o: &mut [f64]| o[0] = 1.0);
        struct Wall<'a>(&'a dyn VectorField);
        impl VectorField for Wall<'_> {
            fn dim(&self) -> usize {
                1
            }
            fn eval(&self, p: &[f64], o: &mut [f64]) -> bool {
                p[0] < 0.5 && self.0.eval(p, o)
            }
        }
        let mut ws = FlowWorkspace::new(1);
        let mut out = [0.0];
        let st = integrate(
            &Wall(&f),
            1.0,
            &[0.0],
            &mut out,
            &FlowSettings::default(),
            &mut ws,
        );
        match st {
            FlowStatus::FieldUndefined { t } => assert!(t <= 0.5 && t > 0.4, "{t}"),
            other => panic!("{other:?}"),
        }
    }
}
