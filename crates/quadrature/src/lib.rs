//! Quadrature rules for every transfer coefficient in wavelux.
//!
//! Every coupling coefficient of every method (Ziegler §3.3.3, VirtualMesh §5.2,
//! Glossy §3.3) is a quadrature over mapped unit squares. This crate owns the rules:
//! Gauss–Legendre rules on intervals ([`gauss`]), and the higher-dimensional, singular,
//! masked and adaptive rules built on them.

pub mod gauss;

pub use gauss::GaussLegendre;

/// Errors raised when a rule cannot be built as requested.
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
}
