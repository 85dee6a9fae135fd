//! Multiresolution analyses (MRAs) on [0, 1], their fast transforms and their
//! d-dimensional tensor products.
//!
//! The framework follows Ziegler §2.2.3 (hierarchy of spaces `V_j ⊕ W_j = V_{j+1}`,
//! dilation equation (2.10), standard and non-standard decompositions (2.11)–(2.12)) and
//! §3.1 (the three bases compared there):
//!
//! * [`Alpert`] — Alpert's multiwavelets `M_k` built from Legendre polynomials
//!   (Ziegler §3.1.2, VirtualMesh's `M_1`, `M_2`, `M_3`); `Alpert::haar()` is `M_1`,
//!   the Haar MRA of Ziegler §3.1.1 and GlobalCube §2.3;
//! * [`Cdv`] — the Cohen–Daubechies–Vial MRA on the interval derived from Daubechies'
//!   D4 (Ziegler §3.1.3), boundary functions included.
//!
//! All of them implement one trait, [`Mra`]: number of functions per level, two-scale
//! rows (the `h_{k,l}` and `g_{k,l}` of Ziegler eq. (2.10)), point evaluation of every
//! scaling function and wavelet, supports, vanishing moments and the polynomial degree
//! reproduced exactly. Every basis here is orthonormal, so decomposition and
//! reconstruction use the same rows (Ziegler §2.2.3).
//!
//! Modules:
//! * [`transform`] — O(n) one-level and full pyramid transforms in 1D, push/pull
//!   (VirtualMesh §5.2);
//! * [`tensor`] — d-dimensional (d = 1..4) standard and non-standard transforms on full
//!   grids (GlobalCube §2.3, Glossy §3.4–3.5, Ziegler Appendix A);
//! * [`sparse`] — the same transforms on sparse sets keyed by (level, index);
//! * [`project`] — projections onto `V_j` by Gauss rules and evaluation of expansions.
//!
//! Levels are dyadic: level `j` of an MRA has `len(j)` scaling functions and as many
//! wavelets, and `len(j + 1) = 2 len(j)`. For `M_k`, `len(j) = k 2^j` (cells of width
//! `2^-j`, `k` functions per cell); for CDV, `len(j) = 2^j` with `j ≥ 2`. Ziegler counts
//! CDV levels from the coarsest space with 4 functions, so his CDV level `j` is our
//! level `j + 2` (his "level 3, n = 32" is our level 5).
//!
//! ```
//! use wavelux_mra::project::{GaussOptions, evaluate, project};
//! use wavelux_mra::tensor::{nonstandard_decompose, nonstandard_reconstruct};
//! use wavelux_mra::Alpert;
//!
//! // Project f(x, y) = x·y onto V_3 ⊗ V_3 of the linear multiwavelets M_2 (exact: M_2
//! // reproduces linear functions in each variable).
//! let m = Alpert::new(2)?;
//! let c = project(&m, 2, 3, |p| p[0] * p[1], GaussOptions::default())?;
//! assert!((evaluate(&m, 2, 3, &c, &[0.3, 0.7])? - 0.21).abs() < 1e-12);
//! // Non-standard decomposition to level 0 and back.
//! let mut w = c.clone();
//! nonstandard_decompose(&m, 2, 3, 0, &mut w)?;
//! nonstandard_reconstruct(&m, 2, 3, 0, &mut w)?;
//! assert!(w.iter().zip(&c).all(|(a, b)| (a - b).abs() < 1e-12));
//! # Ok::<(), wavelux_mra::MraError>(())
//! ```

pub mod alpert;
pub mod cdv;
mod linalg;
pub mod poly;
pub mod project;
pub mod sparse;
pub mod tensor;
pub mod transform;

pub use alpert::Alpert;
pub use cdv::Cdv;

/// Deepest level any MRA here accepts (`len` stays far below `usize::MAX`).
pub const MAX_LEVEL: u32 = 40;

/// Errors of the MRA crate.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum MraError {
    /// A level outside `min_level()..=MAX_LEVEL` (or outside the level range a
    /// transform was asked for).
    #[error("level {level} is outside the supported range {min}..={max}")]
    LevelOutOfRange {
        /// Requested level.
        level: u32,
        /// Smallest allowed level.
        min: u32,
        /// Largest allowed level.
        max: u32,
    },
    /// An index `>= len(level)`.
    #[error("index {index} is out of range for level {level} (len {len})")]
    IndexOutOfRange {
        /// Level of the function.
        level: u32,
        /// Requested index.
        index: usize,
        /// Number of functions on that level.
        len: usize,
    },
    /// A multiplicity (functions per cell) outside the supported range.
    #[error("multiwavelet order {0} is outside the supported range 1..=8")]
    UnsupportedOrder(usize),
    /// A slice with the wrong length for the requested level and dimension.
    #[error("buffer has length {got}, expected {expected}")]
    LengthMismatch {
        /// Length found.
        got: usize,
        /// Length required.
        expected: usize,
    },
    /// A dimension outside 1..=4.
    #[error("dimension {0} is outside the supported range 1..=4")]
    UnsupportedDimension(usize),
    /// A non-finite evaluation point or parameter.
    #[error("non-finite input: {0}")]
    NonFinite(&'static str),
    /// A sparse key set that is not sorted and unique, or keys on the wrong level.
    #[error("malformed sparse input: {0}")]
    MalformedSparse(&'static str),
    /// An invalid parameter (e.g. a zero quadrature order).
    #[error("invalid parameter: {0}")]
    InvalidParameter(&'static str),
}

/// One row of a two-scale (dilation) matrix: the coefficients `h_{k,l}` (or `g_{k,l}`)
/// of a level-`j` function on the level-`j+1` scaling functions
/// `l = start, start + 1, …, start + coeffs.len() - 1` (Ziegler eq. (2.10)).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FilterRow<'a> {
    /// First child index.
    pub start: usize,
    /// Coefficients on consecutive children.
    pub coeffs: &'a [f64],
}

impl FilterRow<'_> {
    /// One past the last child index.
    #[must_use]
    pub fn end(&self) -> usize {
        self.start + self.coeffs.len()
    }
}

/// A one-dimensional orthonormal multiresolution analysis on [0, 1].
///
/// Functions are indexed by `(level, index)` with `index < len(level)`. Scaling
/// functions `φ_{j,k}` and wavelets `ψ_{j,k}` share the index range and support.
/// Implementations guarantee (and the tests check to 1e-12):
/// `φ_{j,k} = Σ_l h_{k,l} φ_{j+1,l}` with `h` = [`Mra::scaling_row`],
/// `ψ_{j,k} = Σ_l g_{k,l} φ_{j+1,l}` with `g` = [`Mra::wavelet_row`], and the stacked
/// matrix `[h; g]` is orthogonal.
pub trait Mra: Send + Sync + std::fmt::Debug {
    /// Short name used in reports ("Haar", "M2", "CDV4").
    fn name(&self) -> String;
    /// Coarsest level supported.
    fn min_level(&self) -> u32;
    /// Number of scaling functions (= number of wavelets) on `level`.
    /// Defined for any level; meaningful for `min_level()..=MAX_LEVEL`.
    fn len(&self, level: u32) -> usize;
    /// Scaling functions per dyadic cell (`k` for `M_k`, 1 for CDV).
    fn functions_per_cell(&self) -> usize;
    /// Number of vanishing moments `ν` of every wavelet: `∫ ψ x^μ = 0` for `μ < ν`
    /// (Ziegler §2.2.3).
    fn vanishing_moments(&self) -> usize;
    /// Largest degree `p` such that every polynomial of degree `≤ p` lies in `V_j`
    /// (and is reproduced exactly by projection).
    fn polynomial_degree(&self) -> usize;
    /// Whether every function is a polynomial on each cell of width `2^-(level+1)`
    /// (Gauss rules on those cells are then exact for Gram matrices).
    fn is_piecewise_polynomial(&self) -> bool;
    /// Two-scale row `h_{k,·}` of `φ_{level,k}` on the scaling functions of `level + 1`.
    ///
    /// # Errors
    /// [`MraError::LevelOutOfRange`] or [`MraError::IndexOutOfRange`].
    fn scaling_row(&self, level: u32, k: usize) -> Result<FilterRow<'_>, MraError>;
    /// Two-scale row `g_{k,·}` of `ψ_{level,k}` on the scaling functions of `level + 1`.
    ///
    /// # Errors
    /// [`MraError::LevelOutOfRange`] or [`MraError::IndexOutOfRange`].
    fn wavelet_row(&self, level: u32, k: usize) -> Result<FilterRow<'_>, MraError>;
    /// The half-open range of indices `k` on `level` whose rows (scaling or wavelet)
    /// may contain child `l` of `level + 1`.
    ///
    /// # Errors
    /// [`MraError::LevelOutOfRange`] or [`MraError::IndexOutOfRange`] (for `l`).
    fn parents(&self, level: u32, l: usize) -> Result<std::ops::Range<usize>, MraError>;
    /// Support `[a, b] ⊂ [0, 1]` of `φ_{level,k}` and `ψ_{level,k}`.
    ///
    /// # Errors
    /// [`MraError::LevelOutOfRange`] or [`MraError::IndexOutOfRange`].
    fn support(&self, level: u32, k: usize) -> Result<(f64, f64), MraError>;
    /// `φ_{level,k}(x)`; zero outside the support and outside [0, 1].
    /// At a discontinuity the right limit is returned (left limit at `x = 1`).
    ///
    /// # Errors
    /// Level/index errors, [`MraError::NonFinite`] for a NaN or infinite `x`.
    fn eval_scaling(&self, level: u32, k: usize, x: f64) -> Result<f64, MraError>;
    /// `ψ_{level,k}(x)`; same conventions as [`Mra::eval_scaling`].
    ///
    /// # Errors
    /// Level/index errors, [`MraError::NonFinite`] for a NaN or infinite `x`.
    fn eval_wavelet(&self, level: u32, k: usize, x: f64) -> Result<f64, MraError>;
    /// Indices `k` on `level` whose functions (scaling or wavelet) may be non-zero at `x`
    /// (a superset, at most a few entries).
    ///
    /// # Errors
    /// Level errors, [`MraError::NonFinite`].
    fn nonzero_at(&self, level: u32, x: f64) -> Result<std::ops::Range<usize>, MraError>;
    /// Exact inner products of `φ_{level,k}` with the orthonormal Legendre polynomials
    /// `2^{j/2} √(2a+1) P_a(2(2^j x − c) − 1)`, `a < n_legendre`, on the cells `c` of
    /// level `j = level`: calls `f(c, a, value)` for every cell of the support.
    /// Projection onto `V_j` ([`crate::project`]) is built on this.
    ///
    /// # Errors
    /// Level/index errors; [`MraError::InvalidParameter`] for too many polynomials.
    fn legendre_products(
        &self,
        level: u32,
        k: usize,
        n_legendre: usize,
        f: &mut dyn FnMut(usize, usize, f64),
    ) -> Result<(), MraError>;
    /// How [`crate::project`] computes `⟨f, φ_{j,k}⟩`: Legendre moments of `f` of degree
    /// `< n_legendre` on the cells of level `j + extra_levels`, transferred exactly by
    /// [`Mra::legendre_products`] and pulled down to level `j`. `(extra_levels,
    /// n_legendre)`; `(0, k)` for piecewise polynomials (exact projection).
    fn projection_plan(&self) -> (u32, usize);
    /// Checks that `level` is supported.
    ///
    /// # Errors
    /// [`MraError::LevelOutOfRange`].
    fn check_level(&self, level: u32) -> Result<(), MraError> {
        if level < self.min_level() || level > MAX_LEVEL {
            return Err(MraError::LevelOutOfRange {
                level,
                min: self.min_level(),
                max: MAX_LEVEL,
            });
        }
        Ok(())
    }
    /// Checks that `level` is supported and `k < len(level)`.
    ///
    /// # Errors
    /// [`MraError::LevelOutOfRange`] or [`MraError::IndexOutOfRange`].
    fn check_index(&self, level: u32, k: usize) -> Result<(), MraError> {
        self.check_level(level)?;
        let len = self.len(level);
        if k >= len {
            return Err(MraError::IndexOutOfRange {
                level,
                index: k,
                len,
            });
        }
        Ok(())
    }
    /// One analysis step on a full level: `coarse[k] = Σ_l h_{k,l} fine[l]`,
    /// `detail[k] = Σ_l g_{k,l} fine[l]`, O(n), no allocation.
    /// `fine.len() = len(level + 1)`, `coarse.len() = detail.len() = len(level)`.
    ///
    /// # Errors
    /// Level errors and [`MraError::LengthMismatch`].
    fn analysis_step(
        &self,
        level: u32,
        fine: &[f64],
        coarse: &mut [f64],
        detail: &mut [f64],
    ) -> Result<(), MraError> {
        check_step_lengths(self, level, fine.len(), coarse.len(), detail.len())?;
        for k in 0..coarse.len() {
            let h = self.scaling_row(level, k)?;
            let g = self.wavelet_row(level, k)?;
            coarse[k] = dot(h.coeffs, &fine[h.start..h.end()]);
            detail[k] = dot(g.coeffs, &fine[g.start..g.end()]);
        }
        Ok(())
    }
    /// One synthesis step, the inverse (transpose) of [`Mra::analysis_step`]:
    /// `fine[l] = Σ_k h_{k,l} coarse[k] + g_{k,l} detail[k]`. O(n), no allocation.
    ///
    /// # Errors
    /// Level errors and [`MraError::LengthMismatch`].
    fn synthesis_step(
        &self,
        level: u32,
        coarse: &[f64],
        detail: &[f64],
        fine: &mut [f64],
    ) -> Result<(), MraError> {
        check_step_lengths(self, level, fine.len(), coarse.len(), detail.len())?;
        fine.fill(0.0);
        for k in 0..coarse.len() {
            let h = self.scaling_row(level, k)?;
            let g = self.wavelet_row(level, k)?;
            let (c, d) = (coarse[k], detail[k]);
            for (f, &w) in fine[h.start..h.end()].iter_mut().zip(h.coeffs) {
                *f += w * c;
            }
            for (f, &w) in fine[g.start..g.end()].iter_mut().zip(g.coeffs) {
                *f += w * d;
            }
        }
        Ok(())
    }
}

/// Validates the buffer lengths of one transform step.
pub(crate) fn check_step_lengths<M: Mra + ?Sized>(
    mra: &M,
    level: u32,
    fine: usize,
    coarse: usize,
    detail: usize,
) -> Result<(), MraError> {
    mra.check_level(level)?;
    mra.check_level(level + 1)?;
    let n = mra.len(level);
    if fine != 2 * n {
        return Err(MraError::LengthMismatch {
            got: fine,
            expected: 2 * n,
        });
    }
    for got in [coarse, detail] {
        if got != n {
            return Err(MraError::LengthMismatch { got, expected: n });
        }
    }
    Ok(())
}

/// Dot product of two equally long slices.
#[inline]
pub(crate) fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// The MRAs compared in Ziegler §3.1, by name: `"haar"`, `"m1"`..`"m8"`, `"cdv"`.
///
/// # Errors
/// [`MraError::InvalidParameter`] for an unknown name.
pub fn by_name(name: &str) -> Result<Box<dyn Mra>, MraError> {
    let lower = name.to_ascii_lowercase();
    match lower.as_str() {
        "haar" => Ok(Box::new(Alpert::haar())),
        "cdv" | "cdv4" => Ok(Box::new(Cdv::new())),
        _ => {
            if let Some(k) = lower
                .strip_prefix('m')
                .and_then(|s| s.parse::<usize>().ok())
            {
                Ok(Box::new(Alpert::new(k)?))
            } else {
                Err(MraError::InvalidParameter("unknown MRA name"))
            }
        }
    }
}
