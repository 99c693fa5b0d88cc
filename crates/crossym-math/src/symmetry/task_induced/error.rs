//! Why a task-induced symmetry could not be set up or checked.

/// Invalid cost specifications and settings, and costs that admit no analysis.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum TaskInducedError {
    /// Task blocks must be 2-D or 3-D.
    #[error("task-induced symmetries need 2-D or 3-D task blocks, got {dim}-D")]
    UnsupportedDim {
        /// Requested block dimension.
        dim: usize,
    },
    /// A point or vector has the wrong number of coordinates.
    #[error("cost `{path}`: {what} has {got} coordinates, but the task block is {expected}-D")]
    WrongDimension {
        /// Location in the spec, e.g. `cost.terms[1].cost`.
        path: String,
        /// Which parameter (`point`, `direction`, `normal`).
        what: &'static str,
        /// Block dimension `d`.
        expected: usize,
        /// Coordinates given.
        got: usize,
    },
    /// A point or vector has a NaN or infinite coordinate.
    #[error("cost `{path}`: {what} {values:?} has a non-finite coordinate")]
    NonFinite {
        /// Location in the spec.
        path: String,
        /// Which parameter.
        what: &'static str,
        /// The values given.
        values: Vec<f64>,
    },
    /// A line direction or plane normal is (numerically) zero.
    #[error("cost `{path}`: {what} {values:?} is a zero vector; it must have non-zero length")]
    ZeroVector {
        /// Location in the spec.
        path: String,
        /// Which parameter (`direction` or `normal`).
        what: &'static str,
        /// The values given.
        values: Vec<f64>,
    },
    /// A sum weight is zero or not finite.
    #[error("cost `{path}`: weight {weight} must be finite and non-zero (remove the term instead of weighting it by 0)")]
    BadWeight {
        /// Location of the term.
        path: String,
        /// The weight given.
        weight: f64,
    },
    /// A sum without terms.
    #[error("cost `{path}`: a sum needs at least one term")]
    EmptySum {
        /// Location of the sum.
        path: String,
    },
    /// A setting is out of its domain.
    #[error("invalid task-induced setting `{field}`: {message}")]
    InvalidSetting {
        /// Setting name.
        field: String,
        /// Why it is invalid.
        message: String,
    },
    /// The cost gradient vanishes (or is undefined) on too much of the sampled region.
    #[error("the cost gradient vanishes or is undefined at {rejected} of {attempts} sampled points (only {usable} usable, need {needed}): the cost is (nearly) constant on the region, e.g. its terms cancel, so its level sets are not hypersurfaces")]
    DegenerateCost {
        /// Points with a usable gradient.
        usable: usize,
        /// Points needed.
        needed: usize,
        /// Points rejected.
        rejected: usize,
        /// Points drawn.
        attempts: usize,
    },
    /// A field handed to [`check_fields`](super::check_fields) lives on another space than the cost.
    #[error("field {index} acts on R^{got}, but the cost is defined on R^{expected}")]
    FieldDimension {
        /// Index of the field.
        index: usize,
        /// Cost dimension `d`.
        expected: usize,
        /// Field dimension.
        got: usize,
    },
    /// A symmetry needs at least one task block.
    #[error("a task-induced symmetry needs at least one task block")]
    NoBlocks,
}
