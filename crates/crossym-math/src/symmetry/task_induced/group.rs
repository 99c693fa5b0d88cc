//! The discovered group acting on task space by its flows (eq. 7), allocation-free.

use super::check::check_impl;
use super::check::TaskInducedReport;
use super::cost::Cost;
use super::cost::CostSpec;
use super::discover::discover_generators;
use super::error::TaskInducedError;
use super::generator::AffineGenerator;
use super::settings::TaskInducedSettings;

use nalgebra::{DMatrix, DVector};

use crate::symmetry::field::{VectorField, DEFAULT_FD_STEP};
use crate::symmetry::lie::TaskGroupAction;
use crate::symmetry::transfer::flow::{
    integrate, FlowSettings, FlowStatus, FlowWorkspace, VariationalField,
};

/// A task-induced symmetry: affine generators preserving a cost, acting on `B` task blocks by
/// their flows (eq. 7), with the evidence that they form a group.
#[derive(Debug, Clone)]
pub struct TaskInducedSymmetry {
    name: String,
    cost: Cost,
    blocks: usize,
    generators: Vec<AffineGenerator>,
    singular_values: Vec<f64>,
    report: TaskInducedReport,
    flow: FlowSettings,
}

impl TaskInducedSymmetry {
    /// Discovers the cost-preserving affine fields of `cost` (nullspace of `G`) and checks them.
    pub fn discover(
        name: &str,
        cost: &Cost,
        blocks: usize,
        settings: &TaskInducedSettings,
    ) -> Result<Self, TaskInducedError> {
        if blocks == 0 {
            return Err(TaskInducedError::NoBlocks);
        }
        settings.validate(cost.dim())?;
        let (generators, singular_values) = discover_generators(cost, settings)?;
        let refs: Vec<&dyn VectorField> =
            generators.iter().map(|g| g as &dyn VectorField).collect();
        let report = check_impl(cost, &refs, settings, true)?;
        Ok(Self {
            name: name.into(),
            cost: cost.clone(),
            blocks,
            generators,
            singular_values,
            report,
            flow: settings.flow,
        })
    }

    /// Builds the cost from `spec` on `block_dim`-dimensional blocks, then [`Self::discover`].
    pub fn from_spec(
        name: &str,
        spec: &CostSpec,
        block_dim: usize,
        blocks: usize,
        settings: &TaskInducedSettings,
    ) -> Result<Self, TaskInducedError> {
        Self::discover(name, &Cost::new(spec, block_dim)?, blocks, settings)
    }

    /// Uses the given affine generators (e.g. from a user) and checks them against `cost`.
    pub fn from_generators(
        name: &str,
        cost: &Cost,
        generators: Vec<AffineGenerator>,
        blocks: usize,
        settings: &TaskInducedSettings,
    ) -> Result<Self, TaskInducedError> {
        if blocks == 0 {
            return Err(TaskInducedError::NoBlocks);
        }
        let refs: Vec<&dyn VectorField> =
            generators.iter().map(|g| g as &dyn VectorField).collect();
        let report = check_impl(cost, &refs, settings, true)?;
        Ok(Self {
            name: name.into(),
            cost: cost.clone(),
            blocks,
            generators,
            singular_values: Vec::new(),
            report,
            flow: settings.flow,
        })
    }

    /// Name from configuration.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The cost whose level sets the group preserves (one block).
    pub fn cost(&self) -> &Cost {
        &self.cost
    }

    /// Block dimension `d`.
    pub fn block_dim(&self) -> usize {
        self.cost.dim()
    }

    /// Number of blocks `B`.
    pub fn blocks(&self) -> usize {
        self.blocks
    }

    /// Dimension `B·d` of the space acted on.
    pub fn dim(&self) -> usize {
        self.blocks * self.cost.dim()
    }

    /// Dimension `k` of the Lie algebra (number of generators).
    pub fn algebra_dim(&self) -> usize {
        self.generators.len()
    }

    /// The identity element's exponential coordinates (all zero).
    pub fn identity(&self) -> Vec<f64> {
        vec![0.0; self.algebra_dim()]
    }

    /// The affine generators `X_k(x) = A_k x + b_k` on one block.
    pub fn generators(&self) -> &[AffineGenerator] {
        &self.generators
    }

    /// Singular values of `G` relative to the largest, descending (empty if not discovered).
    pub fn singular_values(&self) -> &[f64] {
        &self.singular_values
    }

    /// Invariance, spanning, closure and completeness evidence.
    pub fn report(&self) -> &TaskInducedReport {
        &self.report
    }

    /// Integrator settings used by the [`TaskGroupAction`] implementation.
    pub fn flow_settings(&self) -> &FlowSettings {
        &self.flow
    }

    /// The infinitesimal generator `X_ξ = Σ_k ξ_k X_k` on all blocks (allocation-free).
    pub fn field(&self, xi: &[f64]) -> TaskInducedField {
        assert_eq!(
            xi.len(),
            self.algebra_dim(),
            "`{}`: ξ has {} coordinates, the algebra has dimension {}",
            self.name,
            xi.len(),
            self.algebra_dim()
        );
        let d = self.block_dim();
        let mut a = [[0.0; 3]; 3];
        let mut b = [0.0; 3];
        for (g, &t) in self.generators.iter().zip(xi) {
            for r in 0..d {
                b[r] += t * g.offset[r];
                for c in 0..d {
                    a[r][c] += t * g.linear[(r, c)];
                }
            }
        }
        TaskInducedField {
            block_dim: d,
            blocks: self.blocks,
            a,
            b,
        }
    }

    /// The `k`-th basis generator `X_k` on all blocks.
    pub fn generator(&self, k: usize) -> TaskInducedField {
        let mut xi = vec![0.0; self.algebra_dim()];
        xi[k] = 1.0;
        self.field(&xi)
    }

    /// Scratch for [`Self::differential`] (allocates; setup only).
    pub fn workspace(&self) -> TaskInducedWorkspace {
        let n = self.dim();
        TaskInducedWorkspace {
            var: FlowWorkspace::new(2 * n),
            y0: vec![0.0; 2 * n],
            y1: vec![0.0; 2 * n],
        }
    }

    /// `out = Φ_T(exp(ξ), x)`: the flow of `X_ξ` for unit time (eq. 7); allocation-free.
    ///
    /// `ws` must have dimension [`Self::dim`].
    pub fn act(
        &self,
        xi: &[f64],
        x: &[f64],
        out: &mut [f64],
        settings: &FlowSettings,
        ws: &mut FlowWorkspace,
    ) -> FlowStatus {
        let field = self.field(xi);
        integrate(&field, 1.0, x, out, settings, ws)
    }

    /// `v_out = dΦ_{exp ξ}|_x v` by the variational equation; the moved point is
    /// [`TaskInducedWorkspace::point`] afterwards. Allocates the variational field's scratch.
    pub fn differential(
        &self,
        xi: &[f64],
        x: &[f64],
        v: &[f64],
        v_out: &mut [f64],
        settings: &FlowSettings,
        ws: &mut TaskInducedWorkspace,
    ) -> FlowStatus {
        let n = self.dim();
        let field = self.field(xi);
        let var = VariationalField::new(&field, DEFAULT_FD_STEP);
        ws.y0[..n].copy_from_slice(x);
        ws.y0[n..].copy_from_slice(v);
        let st = integrate(&var, 1.0, &ws.y0, &mut ws.y1, settings, &mut ws.var);
        v_out.copy_from_slice(&ws.y1[n..]);
        st
    }

    /// `(E, e)` with `[[E, e], [0, 1]] = exp([[A_ξ, b_ξ], [0, 0]])`: the exact block transform.
    pub fn block_transform(&self, xi: &[f64]) -> (DMatrix<f64>, DVector<f64>) {
        let d = self.block_dim();
        let f = self.field(xi);
        let mut aug = DMatrix::zeros(d + 1, d + 1);
        for r in 0..d {
            for c in 0..d {
                aug[(r, c)] = f.a[r][c];
            }
            aug[(r, d)] = f.b[r];
        }
        let ex = aug.exp();
        (
            ex.view((0, 0), (d, d)).into_owned(),
            ex.view((0, d), (d, 1)).column(0).into_owned(),
        )
    }

    /// `out = E x_b + e` on every block: the closed-form flow of affine generators (reference).
    pub fn act_closed_form(&self, xi: &[f64], x: &[f64], out: &mut [f64]) {
        let (e, t) = self.block_transform(xi);
        let d = self.block_dim();
        for b in 0..self.blocks {
            for r in 0..d {
                out[b * d + r] = t[r] + (0..d).map(|c| e[(r, c)] * x[b * d + c]).sum::<f64>();
            }
        }
    }
}

impl TaskGroupAction for TaskInducedSymmetry {
    fn name(&self) -> &str {
        &self.name
    }
    fn dim(&self) -> usize {
        TaskInducedSymmetry::dim(self)
    }
    fn algebra_dim(&self) -> usize {
        TaskInducedSymmetry::algebra_dim(self)
    }
    fn generator_field(&self, xi: &[f64]) -> Box<dyn VectorField + '_> {
        Box::new(self.field(xi))
    }
    fn act_on(&self, xi: &[f64], x: &[f64], out: &mut [f64]) -> bool {
        let mut ws = FlowWorkspace::new(self.dim());
        self.act(xi, x, out, &self.flow, &mut ws).is_done()
    }
    fn differential_on(&self, xi: &[f64], x: &[f64], v: &[f64], out: &mut [f64]) -> bool {
        let mut ws = self.workspace();
        self.differential(xi, x, v, out, &self.flow, &mut ws)
            .is_done()
    }
}

/// Scratch for [`TaskInducedSymmetry::differential`].
#[derive(Debug, Clone)]
pub struct TaskInducedWorkspace {
    var: FlowWorkspace,
    y0: Vec<f64>,
    y1: Vec<f64>,
}

impl TaskInducedWorkspace {
    /// The point `Φ_T(exp ξ, x)` reached by the last [`TaskInducedSymmetry::differential`].
    pub fn point(&self) -> &[f64] {
        &self.y1[..self.y1.len() / 2]
    }
}

/// The field `X_ξ(x) = A_ξ x_b + b_ξ` on every block `b` of `R^{B·d}` (stack only).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TaskInducedField {
    block_dim: usize,
    blocks: usize,
    a: [[f64; 3]; 3],
    b: [f64; 3],
}

impl VectorField for TaskInducedField {
    fn dim(&self) -> usize {
        self.block_dim * self.blocks
    }
    fn eval(&self, x: &[f64], out: &mut [f64]) -> bool {
        let d = self.block_dim;
        for blk in 0..self.blocks {
            let xb = &x[blk * d..(blk + 1) * d];
            for r in 0..d {
                out[blk * d + r] = self.b[r] + (0..d).map(|c| self.a[r][c] * xb[c]).sum::<f64>();
            }
        }
        true
    }
}
