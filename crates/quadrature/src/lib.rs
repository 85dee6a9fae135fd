//! Quadrature rules for every transfer coefficient in wavelux.
//!
//! Every coupling coefficient of every method (Ziegler §3.3.3, VirtualMesh §5.2,
//! Glossy §3.3) is a quadrature over mapped unit squares. This crate owns the rules:
//!
//! - [`gauss`]: Gauss–Legendre rules of order 1..=128 on intervals;
//! - [`jacobi`]: Gauss–Jacobi rules (weight `(1-x)^α (1+x)^β`), used for triangles,
//!   the disk and endpoint singularities, plus the Gamma/Beta functions they need;
//! - [`rule`]: [`RuleNd`], a plain-data point/weight rule in `d` dimensions, and
//!   tensor-product rules on `[0,1]^d`, `d <= 6` (form factors are 4D, glossy
//!   transport 6D: Glossy §3.3);
//! - [`singular`]: Duffy / Sauter–Schwab rules for the weakly singular `1/r²` kernel
//!   between unit squares that coincide, share an edge or share a vertex, and 2D
//!   Duffy rules for point singularities (Ziegler §3.3.3 avoided these; we do not);
//! - [`simplex`]: Stroud conical-product rules on triangles and polar rules on disks;
//! - [`masked`]: cell-centred `n×n` rules and masked rules whose weights are the real
//!   area of each cell of a trimmed support (VirtualMesh §4.2, Fig. 7);
//! - [`adaptive`]: adaptive Gauss–Kronrod (1D) and Genz–Malik (2..=10 D) cubature with
//!   error estimates, for reference values.

pub mod adaptive;
pub mod gauss;
pub mod jacobi;
pub mod masked;
pub mod rule;
pub mod simplex;
pub mod singular;

pub use adaptive::{Estimate, GaussKronrod, Tolerance, genz_malik, integrate_1d};
pub use gauss::GaussLegendre;
pub use jacobi::GaussJacobi;
pub use masked::{CellFractions, Disk, Polygon, SignedDistance};
pub use rule::RuleNd;
pub use singular::{Corner, SquarePair};

/// Errors raised when a rule cannot be built or applied as requested.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum QuadratureError {
    /// The requested order is outside the supported range.
    #[error("quadrature order {order} is outside the supported range {min}..={max}")]
    OrderOutOfRange {
        /// The order that was asked for.
        order: usize,
        /// Smallest supported order.
        min: usize,
        /// Largest supported order.
        max: usize,
    },
    /// An interval endpoint was NaN or infinite.
    #[error("interval [{a}, {b}] has a non-finite endpoint")]
    NonFiniteInterval {
        /// Left endpoint.
        a: f64,
        /// Right endpoint.
        b: f64,
    },
    /// The requested dimension is outside the supported range.
    #[error("dimension {dim} is outside the supported range {min}..={max}")]
    DimensionOutOfRange {
        /// The dimension that was asked for.
        dim: usize,
        /// Smallest supported dimension.
        min: usize,
        /// Largest supported dimension.
        max: usize,
    },
    /// Slices that must have matching lengths do not.
    #[error("length mismatch: expected {expected}, got {got}")]
    LengthMismatch {
        /// The length that was required.
        expected: usize,
        /// The length that was given.
        got: usize,
    },
    /// A real parameter is NaN, infinite or outside its admissible range.
    #[error("parameter `{name}` = {value} is invalid: {reason}")]
    InvalidParameter {
        /// Name of the parameter.
        name: &'static str,
        /// The offending value.
        value: f64,
        /// What was expected.
        reason: &'static str,
    },
    /// Two corners that were required to span a common edge are not adjacent.
    #[error("corners {0:?} and {1:?} of the unit square are not adjacent")]
    CornersNotAdjacent(singular::Corner, singular::Corner),
    /// A polygon or trim region is malformed.
    #[error("invalid region: {0}")]
    InvalidRegion(&'static str),
    /// The integrand returned NaN or an infinity at a quadrature point.
    #[error("the integrand returned a non-finite value at a quadrature point")]
    NonFiniteIntegrand,
}

/// Checks that `x` is finite, naming it in the error otherwise.
pub(crate) fn check_finite(name: &'static str, x: f64) -> Result<f64, QuadratureError> {
    if x.is_finite() {
        Ok(x)
    } else {
        Err(QuadratureError::InvalidParameter {
            name,
            value: x,
            reason: "must be finite",
        })
    }
}
