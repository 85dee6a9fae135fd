//! d-dimensional tensor-product MRAs, d = 1..4, on full grids: the non-standard and the
//! standard construction (Beylkin et al.; Glossy §3.4–3.5, Ziegler Appendix A.1,
//! GlobalCube §2.3), generic over the 1D [`Mra`].
//!
//! Data layout: a level-`J` array has `n^d` entries, `n = len(J)`, row-major with axis 0
//! slowest: entry `(k_0, …, k_{d−1})` at `Σ_a k_a n^{d−1−a}`; it holds the coefficients
//! of `φ_{J,k_0}(x_0) ⋯ φ_{J,k_{d−1}}(x_{d−1})`.
//!
//! * Non-standard (Ziegler A.1 for d = 2; GlobalCube §2.3's 7 types for d = 3; Glossy
//!   §3.4's 15 types for d = 4): one step applies the 1D analysis step along every axis
//!   of the sub-cube `[0, len(j+1))^d`; the sub-cube `[0, len(j))^d` then holds the
//!   level-`j` scaling coefficients and the other `2^d − 1` blocks the wavelet types
//!   (each axis contributes `φ` if its index is `< len(j)`, else `ψ`). Repeated down to
//!   `j0`. Basis functions are products of 1D functions of the same level.
//! * Standard (Glossy §3.5, Ziegler A.2's `D_S`): the full 1D pyramid along each axis in
//!   turn; basis functions are products of 1D functions of independent levels.
//!
//! Both are orthonormal changes of basis, O(n^d), with scratch of one line per call.

use crate::{Mra, MraError};

/// Checks the dimension and array length; returns the side `len(level)`.
fn check_shape<M: Mra + ?Sized>(
    mra: &M,
    dim: usize,
    level: u32,
    j0: u32,
    len: usize,
) -> Result<usize, MraError> {
    if !(1..=4).contains(&dim) {
        return Err(MraError::UnsupportedDimension(dim));
    }
    mra.check_level(level)?;
    mra.check_level(j0)?;
    if j0 > level {
        return Err(MraError::LevelOutOfRange {
            level: j0,
            min: mra.min_level(),
            max: level,
        });
    }
    let n = mra.len(level);
    let expected = n
        .checked_pow(dim as u32)
        .ok_or(MraError::InvalidParameter("array too large"))?;
    if len != expected {
        return Err(MraError::LengthMismatch { got: len, expected });
    }
    Ok(n)
}

/// Calls `f(base)` for every line along `axis` inside the sub-cube `[0, m)^dim` of an
/// array with side `n`; `base` is the flat offset of the line's first entry.
pub(crate) fn for_each_line(
    dim: usize,
    n: usize,
    m: usize,
    axis: usize,
    mut f: impl FnMut(usize) -> Result<(), MraError>,
) -> Result<(), MraError> {
    let mut strides = [0usize; 4];
    for a in 0..dim {
        strides[a] = n.pow((dim - 1 - a) as u32);
    }
    let mut idx = [0usize; 4];
    loop {
        let base: usize = (0..dim).map(|a| idx[a] * strides[a]).sum();
        f(base)?;
        // Increment the multi-index over the axes other than `axis`.
        let mut a = dim;
        loop {
            if a == 0 {
                return Ok(());
            }
            a -= 1;
            if a == axis {
                continue;
            }
            idx[a] += 1;
            if idx[a] < m {
                break;
            }
            idx[a] = 0;
        }
        if (0..dim).all(|b| b == axis || idx[b] == 0) {
            return Ok(());
        }
    }
}

/// Non-standard decomposition in place (see the module docs). O(n^d).
///
/// # Errors
/// Dimension, level and length errors.
pub fn nonstandard_decompose<M: Mra + ?Sized>(
    mra: &M,
    dim: usize,
    level: u32,
    j0: u32,
    data: &mut [f64],
) -> Result<(), MraError> {
    let n = check_shape(mra, dim, level, j0, data.len())?;
    let mut line = vec![0.0; n];
    let mut out = vec![0.0; n];
    for j in (j0..level).rev() {
        let m2 = mra.len(j + 1);
        let m = mra.len(j);
        for axis in 0..dim {
            let stride = n.pow((dim - 1 - axis) as u32);
            for_each_line(dim, n, m2, axis, |base| {
                for i in 0..m2 {
                    line[i] = data[base + i * stride];
                }
                let (c, d) = out[..m2].split_at_mut(m);
                mra.analysis_step(j, &line[..m2], c, d)?;
                for i in 0..m2 {
                    data[base + i * stride] = out[i];
                }
                Ok(())
            })?;
        }
    }
    Ok(())
}

/// Inverse of [`nonstandard_decompose`], in place.
///
/// # Errors
/// Dimension, level and length errors.
pub fn nonstandard_reconstruct<M: Mra + ?Sized>(
    mra: &M,
    dim: usize,
    level: u32,
    j0: u32,
    data: &mut [f64],
) -> Result<(), MraError> {
    let n = check_shape(mra, dim, level, j0, data.len())?;
    let mut line = vec![0.0; n];
    let mut out = vec![0.0; n];
    for j in j0..level {
        let m2 = mra.len(j + 1);
        let m = mra.len(j);
        for axis in (0..dim).rev() {
            let stride = n.pow((dim - 1 - axis) as u32);
            for_each_line(dim, n, m2, axis, |base| {
                for i in 0..m2 {
                    line[i] = data[base + i * stride];
                }
                let (c, d) = line[..m2].split_at(m);
                mra.synthesis_step(j, c, d, &mut out[..m2])?;
                for i in 0..m2 {
                    data[base + i * stride] = out[i];
                }
                Ok(())
            })?;
        }
    }
    Ok(())
}

/// Standard decomposition in place: the full 1D pyramid (Mallat layout, see
/// [`crate::transform`]) along every axis. O(n^d).
///
/// # Errors
/// Dimension, level and length errors.
pub fn standard_decompose<M: Mra + ?Sized>(
    mra: &M,
    dim: usize,
    level: u32,
    j0: u32,
    data: &mut [f64],
) -> Result<(), MraError> {
    standard(mra, dim, level, j0, data, true)
}

/// Inverse of [`standard_decompose`], in place.
///
/// # Errors
/// Dimension, level and length errors.
pub fn standard_reconstruct<M: Mra + ?Sized>(
    mra: &M,
    dim: usize,
    level: u32,
    j0: u32,
    data: &mut [f64],
) -> Result<(), MraError> {
    standard(mra, dim, level, j0, data, false)
}

fn standard<M: Mra + ?Sized>(
    mra: &M,
    dim: usize,
    level: u32,
    j0: u32,
    data: &mut [f64],
    forward: bool,
) -> Result<(), MraError> {
    let n = check_shape(mra, dim, level, j0, data.len())?;
    let mut line = vec![0.0; n];
    let mut scratch = vec![0.0; n];
    for axis in 0..dim {
        let stride = n.pow((dim - 1 - axis) as u32);
        for_each_line(dim, n, n, axis, |base| {
            for i in 0..n {
                line[i] = data[base + i * stride];
            }
            if forward {
                crate::transform::decompose_with(mra, level, j0, &mut line, &mut scratch)?;
            } else {
                crate::transform::reconstruct_with(mra, level, j0, &mut line, &mut scratch)?;
            }
            for i in 0..n {
                data[base + i * stride] = line[i];
            }
            Ok(())
        })?;
    }
    Ok(())
}

/// A 1D factor of a tensor-product basis function.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Factor {
    /// Level of the 1D function.
    pub level: u32,
    /// `true` for a wavelet `ψ`, `false` for a scaling function `φ`.
    pub wavelet: bool,
    /// Index on that level.
    pub index: usize,
}

impl Factor {
    /// Evaluates this 1D factor at `x`.
    ///
    /// # Errors
    /// As [`Mra::eval_scaling`].
    pub fn eval<M: Mra + ?Sized>(&self, mra: &M, x: f64) -> Result<f64, MraError> {
        if self.wavelet {
            mra.eval_wavelet(self.level, self.index, x)
        } else {
            mra.eval_scaling(self.level, self.index, x)
        }
    }
}

/// The 1D function at position `p` of a Mallat-layout pyramid from `level` to `j0`.
fn mallat_factor<M: Mra + ?Sized>(mra: &M, j0: u32, p: usize) -> Factor {
    let n0 = mra.len(j0);
    if p < n0 {
        return Factor {
            level: j0,
            wavelet: false,
            index: p,
        };
    }
    let mut j = j0;
    while mra.len(j + 1) <= p {
        j += 1;
    }
    Factor {
        level: j,
        wavelet: true,
        index: p - mra.len(j),
    }
}

/// The basis function of the **standard** decomposition at flat index `flat`: one
/// factor per axis, levels independent.
///
/// # Errors
/// Dimension, level errors; [`MraError::IndexOutOfRange`] for `flat >= n^d`.
pub fn standard_basis_function<M: Mra + ?Sized>(
    mra: &M,
    dim: usize,
    level: u32,
    j0: u32,
    flat: usize,
) -> Result<Vec<Factor>, MraError> {
    let n = multi_check(mra, dim, level, j0, flat)?;
    Ok(unflatten(flat, n, dim)
        .into_iter()
        .map(|p| mallat_factor(mra, j0, p))
        .collect())
}

/// The basis function of the **non-standard** decomposition at flat index `flat`: all
/// factors share one level `j`; `φ` on axes whose index is `< len(j)`.
///
/// # Errors
/// Dimension, level errors; [`MraError::IndexOutOfRange`] for `flat >= n^d`.
pub fn nonstandard_basis_function<M: Mra + ?Sized>(
    mra: &M,
    dim: usize,
    level: u32,
    j0: u32,
    flat: usize,
) -> Result<Vec<Factor>, MraError> {
    let n = multi_check(mra, dim, level, j0, flat)?;
    let idx = unflatten(flat, n, dim);
    let pmax = idx.iter().copied().max().unwrap_or(0);
    let j = if pmax < mra.len(j0) {
        j0
    } else {
        mallat_factor(mra, j0, pmax).level
    };
    let m = mra.len(j);
    Ok(idx
        .into_iter()
        .map(|p| {
            if p < m {
                Factor {
                    level: j,
                    wavelet: false,
                    index: p,
                }
            } else {
                Factor {
                    level: j,
                    wavelet: true,
                    index: p - m,
                }
            }
        })
        .collect())
}

fn multi_check<M: Mra + ?Sized>(
    mra: &M,
    dim: usize,
    level: u32,
    j0: u32,
    flat: usize,
) -> Result<usize, MraError> {
    let n = mra.len(level);
    let total = n.checked_pow(dim as u32).unwrap_or(usize::MAX);
    check_shape(mra, dim, level, j0, total)?;
    if flat >= total {
        return Err(MraError::IndexOutOfRange {
            level,
            index: flat,
            len: total,
        });
    }
    Ok(n)
}

/// Splits a flat row-major index into per-axis indices (axis 0 first).
#[must_use]
pub fn unflatten(mut flat: usize, n: usize, dim: usize) -> Vec<usize> {
    let mut out = vec![0; dim];
    for a in (0..dim).rev() {
        out[a] = flat % n;
        flat /= n;
    }
    out
}

/// Number of wavelet types per non-standard node, `2^d − 1` (3 on surfaces, 7 in
/// GlobalCube §2.3, 15 in Glossy §3.4).
#[must_use]
pub fn wavelet_types(dim: usize) -> usize {
    (1usize << dim) - 1
}

/// Evaluates an expansion in the standard or non-standard basis (output of
/// [`standard_decompose`] / [`nonstandard_decompose`]) at a point by summing every basis
/// function — O(n^d) per point, meant for tests and small examples.
///
/// # Errors
/// Dimension, level, length errors; [`MraError::NonFinite`].
pub fn eval_decomposed<M: Mra + ?Sized>(
    mra: &M,
    dim: usize,
    level: u32,
    j0: u32,
    coeffs: &[f64],
    standard: bool,
    x: &[f64],
) -> Result<f64, MraError> {
    check_shape(mra, dim, level, j0, coeffs.len())?;
    if x.len() != dim {
        return Err(MraError::LengthMismatch {
            got: x.len(),
            expected: dim,
        });
    }
    let mut s = 0.0;
    for (flat, &c) in coeffs.iter().enumerate() {
        if c == 0.0 {
            continue;
        }
        let fs = if standard {
            standard_basis_function(mra, dim, level, j0, flat)?
        } else {
            nonstandard_basis_function(mra, dim, level, j0, flat)?
        };
        let mut v = c;
        for (f, &xa) in fs.iter().zip(x) {
            v *= f.eval(mra, xa)?;
            if v == 0.0 {
                break;
            }
        }
        s += v;
    }
    Ok(s)
}
