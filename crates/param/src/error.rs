//! Typed errors of the crate's constructors (degenerate or non-finite inputs).

use thiserror::Error;

/// Why a surface, map or frame could not be built.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum ParamError {
    /// An input was NaN or infinite.
    #[error("{what} is not finite")]
    NonFinite {
        /// Which input.
        what: &'static str,
    },
    /// A length that must be strictly positive was not.
    #[error("{what} must be > 0, got {value}")]
    NonPositive {
        /// Which input.
        what: &'static str,
        /// The offending value.
        value: f64,
    },
    /// A parameter range was empty, reversed or too long.
    #[error("invalid range for {what}: [{lo}, {hi}] ({why})")]
    InvalidRange {
        /// Which range.
        what: &'static str,
        /// Lower end given.
        lo: f64,
        /// Upper end given.
        hi: f64,
        /// What is wrong with it.
        why: &'static str,
    },
    /// A ring torus needs minor radius < major radius.
    #[error("ring torus needs 0 < r < R, got r = {minor}, R = {major}")]
    NotRingTorus {
        /// Minor (tube) radius.
        minor: f64,
        /// Major radius.
        major: f64,
    },
    /// Spheroid eccentricity outside [0, 1).
    #[error("eccentricity must lie in [0, 1), got {0}")]
    Eccentricity(f64),
    /// Vectors that must span a plane (or a frame) are (nearly) parallel or zero.
    #[error("degenerate geometry: {0}")]
    Degenerate(&'static str),
    /// Too few points for the requested construction.
    #[error("need at least {needed} points, got {got}")]
    TooFewPoints {
        /// Minimum required.
        needed: usize,
        /// Number supplied.
        got: usize,
    },
}

/// Checks that `x` is finite.
pub(crate) fn finite(what: &'static str, x: f64) -> Result<f64, ParamError> {
    if x.is_finite() {
        Ok(x)
    } else {
        Err(ParamError::NonFinite { what })
    }
}

/// Checks that `x` is finite and strictly positive.
pub(crate) fn positive(what: &'static str, x: f64) -> Result<f64, ParamError> {
    finite(what, x)?;
    if x > 0.0 {
        Ok(x)
    } else {
        Err(ParamError::NonPositive { what, value: x })
    }
}

/// Checks that a 3-vector is finite.
pub(crate) fn finite3(what: &'static str, v: glam::DVec3) -> Result<glam::DVec3, ParamError> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(ParamError::NonFinite { what })
    }
}

/// Checks a range `lo < hi`, both finite.
pub(crate) fn range(what: &'static str, r: (f64, f64)) -> Result<(f64, f64), ParamError> {
    let (lo, hi) = r;
    finite(what, lo)?;
    finite(what, hi)?;
    if lo < hi {
        Ok(r)
    } else {
        Err(ParamError::InvalidRange {
            what,
            lo,
            hi,
            why: "need lo < hi",
        })
    }
}

/// Checks an angular range `lo < hi <= lo + 2π`.
pub(crate) fn angle_range(what: &'static str, r: (f64, f64)) -> Result<(f64, f64), ParamError> {
    let (lo, hi) = range(what, r)?;
    if hi - lo > std::f64::consts::TAU * (1.0 + 4.0 * f64::EPSILON) {
        return Err(ParamError::InvalidRange {
            what,
            lo,
            hi,
            why: "an angular range spans at most 2π",
        });
    }
    Ok((lo, hi))
}
