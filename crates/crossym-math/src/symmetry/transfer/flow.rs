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
//! `dδ/dt = dX|_γ δ`, `δ(0) = v`, where `dX|_γ δ` is the field's closed-form derivative
//! ([`VectorField::eval_derivative`], e.g. of a lifted field) or else a central (or
//! forward) difference of the field along `δ` at the same point (no step-sequence noise).
//!
//! An orbit sampled at several group elements `exp(t_1 ξ), exp(t_2 ξ), …` is one
//! integration through the checkpoints `t_i` ([`integrate_through`]), not one flow per
//! element; many flows of one field from nearby points (the samples of a trajectory)
//! can start from the previous flow's step size ([`FlowSettings::warm_start`]).
//!
//! [`integrate`] and [`integrate_through`] allocate nothing; scratch lives in a
//! caller-owned [`FlowWorkspace`].

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
    /// Start from the step size the controller had at the end of the previous
    /// integration with the same workspace (instead of the initial-step heuristic): for
    /// many flows of one field from nearby points, e.g. along a trajectory.
    #[serde(default)]
    pub warm_start: bool,
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
            warm_start: false,
        }
    }
}

impl FlowSettings {
    /// Checks that tolerances are positive and finite.
    pub fn validate(&self) -> Result<(), FlowSettingsError> {
        if !(self.rtol > 0.0 && self.rtol.is_finite() && self.atol > 0.0 && self.atol.is_finite()) {
            return Err(FlowSettingsError::Tolerances {
                rtol: self.rtol,
                atol: self.atol,
            });
        }
        if self.max_steps == 0 {
            return Err(FlowSettingsError::MaxSteps);
        }
        Ok(())
    }
}

/// What is wrong with [`FlowSettings`].
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum FlowSettingsError {
    /// A tolerance is not positive and finite.
    #[error("flow tolerances rtol={rtol} atol={atol} must be positive")]
    Tolerances {
        /// Relative tolerance given.
        rtol: f64,
        /// Absolute tolerance given.
        atol: f64,
    },
    /// `max_steps` is 0.
    #[error("flow max_steps must be positive")]
    MaxSteps,
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
    /// The controller's step size at the end of the last integration (0: none yet).
    h_last: f64,
}

impl FlowWorkspace {
    /// Scratch for dimension `d` (allocates; setup only).
    pub fn new(d: usize) -> Self {
        Self {
            k: std::array::from_fn(|_| vec![0.0; d]),
            y: vec![0.0; d],
            tmp: vec![0.0; d],
            y5: vec![0.0; d],
            h_last: 0.0,
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
    let st = integrate_through(field, &[t], y0, settings, ws, &mut |_, y| {
        out.copy_from_slice(y)
    });
    if st.is_done() && out.iter().any(|v| !v.is_finite()) {
        return FlowStatus::NonFinite { t };
    }
    st
}

/// Integrates `dy/dt = X(y)` from `y0` over time `t` (may be negative) into `out` with
/// `steps` classical Runge–Kutta 4 steps of size `t / steps` (four field evaluations each,
/// global error `O((t / steps)⁴)`, no error control). Allocation-free; `steps = 0` copies.
///
/// For a fixed cost per call (the control tick); [`integrate`] controls the error instead.
///
/// ```
/// use crossym_math::symmetry::field::FnField;
/// use crossym_math::symmetry::transfer::flow::{integrate_rk4, FlowWorkspace};
///
/// // Rotation generator (x, y) ↦ (−y, x): the flow for time t rotates by t.
/// let rot = FnField::new(2, |p: &[f64], o: &mut [f64]| {
///     o[0] = -p[1];
///     o[1] = p[0];
/// });
/// let (mut out, mut ws) = ([0.0; 2], FlowWorkspace::new(2));
/// assert!(integrate_rk4(&rot, -1.0, 8, &[1.0, 0.0], &mut out, &mut ws).is_done());
/// // RK4 at step 1/8: error ≈ (1/8)⁴ / 120 per unit time.
/// assert!((out[0] - 1f64.cos()).abs() < 1e-5 && (out[1] + 1f64.sin()).abs() < 1e-5);
/// ```
pub fn integrate_rk4(
    field: &dyn VectorField,
    t: f64,
    steps: usize,
    y0: &[f64],
    out: &mut [f64],
    ws: &mut FlowWorkspace,
) -> FlowStatus {
    let d = y0.len();
    debug_assert_eq!(ws.dim(), d);
    out.copy_from_slice(y0);
    if steps == 0 || t == 0.0 {
        return FlowStatus::Done {
            steps: 0,
            rejected: 0,
        };
    }
    let h = t / steps as f64;
    let [k1, k2, k3, k4, ..] = &mut ws.k;
    let tmp = &mut ws.tmp;
    for i in 0..steps {
        let t_i = i as f64 * h;
        if !field.eval(out, k1) {
            return FlowStatus::FieldUndefined { t: t_i };
        }
        for j in 0..d {
            tmp[j] = out[j] + 0.5 * h * k1[j];
        }
        if !field.eval(tmp, k2) {
            return FlowStatus::FieldUndefined { t: t_i };
        }
        for j in 0..d {
            tmp[j] = out[j] + 0.5 * h * k2[j];
        }
        if !field.eval(tmp, k3) {
            return FlowStatus::FieldUndefined { t: t_i };
        }
        for j in 0..d {
            tmp[j] = out[j] + h * k3[j];
        }
        if !field.eval(tmp, k4) {
            return FlowStatus::FieldUndefined { t: t_i };
        }
        for j in 0..d {
            out[j] += h / 6.0 * (k1[j] + 2.0 * (k2[j] + k3[j]) + k4[j]);
        }
        if out.iter().any(|v| !v.is_finite()) {
            return FlowStatus::NonFinite { t: t_i + h };
        }
    }
    FlowStatus::Done { steps, rejected: 0 }
}

/// Integrates `dy/dt = X(y)` from `y0` through the checkpoints `ts` and calls
/// `visit(i, y(ts[i]))` at each one reached. Allocation-free.
///
/// The orbit of a point under the flow of the rotation generator `(x, y) ↦ (−y, x)` is
/// `exp(tξ)·p` (eq. 7), a rotation by `t`:
///
/// ```
/// use crossym_math::symmetry::field::FnField;
/// use crossym_math::symmetry::transfer::flow::{integrate_through, FlowSettings, FlowWorkspace};
///
/// let rot = FnField::new(2, |p: &[f64], o: &mut [f64]| {
///     o[0] = -p[1];
///     o[1] = p[0];
/// });
/// let angles = [0.5, 1.0, 2.0, 3.0];
/// let mut ws = FlowWorkspace::new(2);
/// let mut orbit = Vec::new();
/// let status = integrate_through(&rot, &angles, &[1.0, 0.0], &FlowSettings::default(), &mut ws,
///     &mut |i, p| orbit.push((angles[i], p[0], p[1])));
/// assert!(status.is_done());
/// for (t, x, y) in orbit {
///     assert!((x - t.cos()).abs() < 1e-8 && (y - t.sin()).abs() < 1e-8);
/// }
/// ```
///
/// The checkpoints lie on one side of 0 with `|ts[i]|` non-decreasing (e.g. the angles
/// `30°, 60°, …` of one orbit); anything else is reported as
/// [`FlowStatus::NonFinite`] at `t = 0` without integrating. Steps are shortened to land
/// on each checkpoint, but the integration is not restarted there: the FSAL stage and
/// the step size carry over, so a sequence of checkpoints costs about what one flow to
/// the last of them costs. On failure the status holds the time reached, and every
/// checkpoint before it has been visited.
pub fn integrate_through(
    field: &dyn VectorField,
    ts: &[f64],
    y0: &[f64],
    settings: &FlowSettings,
    ws: &mut FlowWorkspace,
    visit: &mut dyn FnMut(usize, &[f64]),
) -> FlowStatus {
    let (mut next, dir, total) = match start_through(field, ts, y0, ws, visit) {
        Ok(start) => start,
        Err(status) => return status,
    };
    let mut s = 0.0; // |time| done
    let mut steps = 0;
    let mut rejected = 0;
    // `h` is the controller's step; a step is shortened to land on the next checkpoint
    // without changing `h`.
    let mut h = initial_step(&ws.y, &ws.k[0], ws.h_last, total, settings);
    let mut attempts = 0;
    while next < ts.len() {
        attempts += 1;
        if attempts > settings.max_steps {
            return FlowStatus::TooManySteps { t: dir * s };
        }
        let target = ts[next].abs();
        let landing = s + h >= target;
        let hh = if landing { target - s } else { h };
        let hs = dir * hh;
        if !dormand_prince_stages(field, ws, hs) {
            // Shrink the step; a genuinely undefined region stops the flow.
            if hh < total * 1e-9 {
                return FlowStatus::FieldUndefined { t: dir * s };
            }
            h = hh * 0.25;
            rejected += 1;
            continue;
        }
        // The 7th stage was evaluated at y5 (FSAL): tmp holds y5.
        ws.y5.copy_from_slice(&ws.tmp);
        let err = error_norm(ws, hs, settings);
        if !err.is_finite() || ws.y5.iter().any(|v| !v.is_finite()) {
            if hh < total * 1e-9 {
                return FlowStatus::NonFinite { t: dir * s };
            }
            h = hh * 0.25;
            rejected += 1;
            continue;
        }
        let fac = (0.9 * err.powf(-0.2)).clamp(0.2, 5.0);
        if err <= 1.0 {
            s = if landing { target } else { s + hh };
            steps += 1;
            ws.y.copy_from_slice(&ws.y5);
            let (first, rest) = ws.k.split_at_mut(1);
            first[0].copy_from_slice(&rest[5]);
            h = step_after_accept(h, hh, fac, err, rejected, landing);
            if landing {
                visit_reached(ts, visit, &mut next, s, &ws.y);
            }
        } else {
            rejected += 1;
            h = hh * fac.min(1.0);
        }
    }
    ws.h_last = h;
    FlowStatus::Done { steps, rejected }
}

/// Checks the checkpoints, visits those at `t = 0` and evaluates the first stage into
/// `ws`: `(first checkpoint not visited, direction ±1, |last checkpoint|)`, or the status
/// to return at once.
fn start_through(
    field: &dyn VectorField,
    ts: &[f64],
    y0: &[f64],
    ws: &mut FlowWorkspace,
    visit: &mut dyn FnMut(usize, &[f64]),
) -> Result<(usize, f64, f64), FlowStatus> {
    let d = y0.len();
    debug_assert_eq!(ws.dim(), d);
    ws.y.copy_from_slice(y0);
    let Some(&last) = ts.last() else {
        return Err(FlowStatus::Done {
            steps: 0,
            rejected: 0,
        });
    };
    let dir = if last < 0.0 { -1.0 } else { 1.0 };
    if !checkpoints_ordered(ts, dir) {
        return Err(FlowStatus::NonFinite { t: 0.0 });
    }
    let mut next = 0; // first checkpoint not yet visited
    visit_reached(ts, visit, &mut next, 0.0, y0);
    if next == ts.len() {
        return Err(FlowStatus::Done {
            steps: 0,
            rejected: 0,
        });
    }
    let total = last.abs();
    if !field.eval(&ws.y, &mut ws.k[0]) {
        return Err(FlowStatus::FieldUndefined { t: 0.0 });
    }
    Ok((next, dir, total))
}

/// Visits every checkpoint from `next` on with `|t| ≤ s` at the state `y`.
fn visit_reached(
    ts: &[f64],
    visit: &mut dyn FnMut(usize, &[f64]),
    next: &mut usize,
    s: f64,
    y: &[f64],
) {
    while *next < ts.len() && ts[*next].abs() <= s {
        visit(*next, y);
        *next += 1;
    }
}

/// The controller's step after an accepted step `hh` (of the controller's `h`) with error
/// `err` and growth factor `fac`.
fn step_after_accept(h: f64, hh: f64, fac: f64, err: f64, rejected: usize, landing: bool) -> f64 {
    let grown = hh
        * if rejected > 0 && err > 0.5 {
            fac.min(1.0)
        } else {
            fac
        };
    // A step cut short by a checkpoint says little about the step size: keep the
    // controller's step unless the error asks for a smaller one.
    if landing && fac >= 1.0 {
        h.max(grown)
    } else {
        grown
    }
}

/// True when the checkpoints are finite, on the side of 0 given by `dir` (±1) and
/// non-decreasing in `|t|`.
fn checkpoints_ordered(ts: &[f64], dir: f64) -> bool {
    ts.iter().all(|t| t.is_finite() && t * dir >= 0.0)
        && ts.windows(2).all(|w| w[1] * dir >= w[0] * dir)
}

/// The first step of a flow over `|t| = total` from `y` with `X(y) = k0`: the step the
/// controller ended the previous integration with (`h_last`) under `warm_start`, else
/// Hairer's heuristic (simplified); clamped to `[total · 1e-12, total]`.
fn initial_step(y: &[f64], k0: &[f64], h_last: f64, total: f64, settings: &FlowSettings) -> f64 {
    let d = y.len();
    let norm = |v: &[f64], y: &[f64]| -> f64 {
        let mut acc = 0.0;
        for (a, b) in v.iter().zip(y) {
            let sc = settings.atol + settings.rtol * b.abs();
            acc += (a / sc) * (a / sc);
        }
        (acc / d as f64).sqrt()
    };
    let d0 = norm(y, y);
    let d1 = norm(k0, y);
    let h = if settings.warm_start && h_last > 0.0 {
        h_last
    } else if d0 < 1e-5 || d1 < 1e-5 {
        1e-6
    } else {
        0.01 * d0 / d1
    };
    h.min(total).max(total * 1e-12)
}

/// Stages 1–6 of one Dormand–Prince step of signed size `hs` from `ws.y` (stage 0 in
/// `ws.k[0]`) into `ws.k[1..]`; the last is evaluated at the 5th-order solution, which is
/// left in `ws.tmp` (FSAL). False when the field is undefined at a stage.
#[inline]
fn dormand_prince_stages(field: &dyn VectorField, ws: &mut FlowWorkspace, hs: f64) -> bool {
    let d = ws.y.len();
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
            return false;
        }
    }
    true
}

/// The step's error estimate from its stages (step `hs`, from `ws.y` to `ws.y5`): the RMS
/// over the first `error_dims` components, each scaled by `atol + rtol · max(|y|, |y5|)`.
#[inline]
fn error_norm(ws: &FlowWorkspace, hs: f64, settings: &FlowSettings) -> f64 {
    let d = ws.y.len();
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
    (err / de as f64).sqrt()
}

/// The field `(y, δ) ↦ (X(y), dX|_y δ)` on `R^{2d}` whose flow carries the flow map's
/// differential (variational equation): `dX|_y δ` in closed form when the field provides
/// it ([`VectorField::eval_derivative`]), else by finite differences with step `h`.
/// Uses interior scratch; not thread-safe.
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
        if let Some(defined) = self.field.eval_derivative(y, delta, oy, od) {
            return defined;
        }
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

    #[test]
    fn checkpoints_match_separate_flows_and_warm_start_saves_steps() {
        let rot = FnField::new(2, |p: &[f64], o: &mut [f64]| {
            o[0] = -p[1];
            o[1] = p[0];
        });
        let settings = FlowSettings {
            rtol: 1e-9,
            atol: 1e-11,
            ..Default::default()
        };
        let mut ws = FlowWorkspace::new(2);
        let ts = [-0.5, -1.0, -1.0, -2.5];
        let mut seen = Vec::new();
        let st = integrate_through(&rot, &ts, &[1.0, 0.0], &settings, &mut ws, &mut |i, y| {
            seen.push((i, y[0], y[1]))
        });
        let FlowStatus::Done { steps: through, .. } = st else {
            panic!("{st:?}")
        };
        assert_eq!(seen.iter().map(|s| s.0).collect::<Vec<_>>(), [0, 1, 2, 3]);
        let mut separate = 0;
        for (&t, &(_, x, y)) in ts.iter().zip(&seen) {
            assert!((x - t.cos()).abs() < 1e-8 && (y - t.sin()).abs() < 1e-8);
            let mut out = [0.0; 2];
            let st = integrate(&rot, t, &[1.0, 0.0], &mut out, &settings, &mut ws);
            if let FlowStatus::Done { steps, .. } = st {
                separate += steps;
            }
        }
        assert!(through < separate, "{through} vs {separate}");
        // Unordered checkpoints are refused without integrating.
        let st = integrate_through(
            &rot,
            &[1.0, 0.5],
            &[1.0, 0.0],
            &settings,
            &mut ws,
            &mut |_, _| panic!("visited"),
        );
        assert_eq!(st, FlowStatus::NonFinite { t: 0.0 });
        // Warm start: the same flow from a nearby point takes fewer steps, same answer.
        let warm = FlowSettings {
            warm_start: true,
            ..settings
        };
        let mut out = [0.0; 2];
        let mut cold_ws = FlowWorkspace::new(2);
        let cold = integrate(&rot, 0.7, &[1.0, 0.0], &mut out, &settings, &mut cold_ws);
        let mut warm_ws = FlowWorkspace::new(2);
        integrate(&rot, 0.7, &[1.0, 0.0], &mut out, &warm, &mut warm_ws);
        let again = integrate(&rot, 0.7, &[1.0, 1e-3], &mut out, &warm, &mut warm_ws);
        let (FlowStatus::Done { steps: c, .. }, FlowStatus::Done { steps: w, .. }) = (cold, again)
        else {
            panic!("{cold:?} {again:?}")
        };
        assert!(w < c, "warm {w} vs cold {c}");
        let (s, co) = 0.7f64.sin_cos();
        assert!((out[0] - (co - 1e-3 * s)).abs() < 1e-8 && (out[1] - (s + 1e-3 * co)).abs() < 1e-8);
    }
}
