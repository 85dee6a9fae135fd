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

/// Two disjoint scratch lines of length `n` from a reusable buffer.
fn split_scratch(buf: &mut Vec<f64>, n: usize) -> (&mut [f64], &mut [f64]) {
    if buf.len() < 2 * n {
        buf.resize(2 * n, 0.0);
    }
    buf[..2 * n].split_at_mut(n)
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
    nonstandard_decompose_with(mra, dim, level, j0, data, &mut Vec::new())
}

/// [`nonstandard_decompose`] with a caller-owned scratch buffer (grown to `2 len(level)`
/// on first use, then reused: no allocation in repeated calls).
///
/// # Errors
/// Dimension, level and length errors.
pub fn nonstandard_decompose_with<M: Mra + ?Sized>(
    mra: &M,
    dim: usize,
    level: u32,
    j0: u32,
    data: &mut [f64],
    scratch: &mut Vec<f64>,
) -> Result<(), MraError> {
    let n = check_shape(mra, dim, level, j0, data.len())?;
    for j in (j0..level).rev() {
        let m2 = mra.len(j + 1);
        for axis in 0..dim {
            step_axis(mra, dim, n, m2, axis, j, data, scratch, true)?;
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
    nonstandard_reconstruct_with(mra, dim, level, j0, data, &mut Vec::new())
}

/// [`nonstandard_reconstruct`] with a caller-owned scratch buffer.
///
/// # Errors
/// Dimension, level and length errors.
pub fn nonstandard_reconstruct_with<M: Mra + ?Sized>(
    mra: &M,
    dim: usize,
    level: u32,
    j0: u32,
    data: &mut [f64],
    scratch: &mut Vec<f64>,
) -> Result<(), MraError> {
    let n = check_shape(mra, dim, level, j0, data.len())?;
    for j in j0..level {
        let m2 = mra.len(j + 1);
        for axis in (0..dim).rev() {
            step_axis(mra, dim, n, m2, axis, j, data, scratch, false)?;
        }
    }
    Ok(())
}

/// One analysis (`forward`) or synthesis step along `axis` of the sub-cube `[0, m2)^dim`
/// of an array with side `n`. The last axis is contiguous and transformed line by line;
/// for the other axes the lines are processed together as the rows of an `m2 × m2` block
/// (the last axis as the vector index), so every filter tap is a contiguous axpy and
/// strided single-element gathers are avoided.
fn step_axis<M: Mra + ?Sized>(
    mra: &M,
    dim: usize,
    n: usize,
    m2: usize,
    axis: usize,
    j: u32,
    data: &mut [f64],
    scratch: &mut Vec<f64>,
    forward: bool,
) -> Result<(), MraError> {
    let m = m2 / 2;
    if axis + 1 == dim {
        let (line, out) = split_scratch(scratch, n);
        return for_each_line(dim, n, m2, axis, |base| {
            let l = &mut data[base..base + m2];
            line[..m2].copy_from_slice(l);
            if forward {
                let (c, d) = out[..m2].split_at_mut(m);
                mra.analysis_step(j, &line[..m2], c, d)?;
            } else {
                let (c, d) = line[..m2].split_at(m);
                mra.synthesis_step(j, c, d, &mut out[..m2])?;
            }
            l.copy_from_slice(&out[..m2]);
            Ok(())
        });
    }
    let block = m2 * m2;
    if scratch.len() < 2 * block {
        scratch.resize(2 * block, 0.0);
    }
    let (inp, out) = scratch[..2 * block].split_at_mut(block);
    let stride = n.pow((dim - 1 - axis) as u32);
    // Iterate over the lines of the last axis with index 0 along `axis`.
    let last_axis = dim - 1;
    for_each_line(dim, n, m2, last_axis, |base| {
        // `base` enumerates all combinations of the axes < dim-1; keep those with
        // index 0 along `axis`.
        if !(base / stride).is_multiple_of(n) {
            return Ok(());
        }
        for l in 0..m2 {
            let src = base + l * stride;
            inp[l * m2..(l + 1) * m2].copy_from_slice(&data[src..src + m2]);
        }
        out.fill(0.0);
        for k in 0..m {
            let h = mra.scaling_row(j, k)?;
            let g = mra.wavelet_row(j, k)?;
            if forward {
                let (oc, od) = out.split_at_mut(m * m2);
                let c = &mut oc[k * m2..(k + 1) * m2];
                for (t, &w) in h.coeffs.iter().enumerate() {
                    axpy(w, &inp[(h.start + t) * m2..(h.start + t + 1) * m2], c);
                }
                let d = &mut od[k * m2..(k + 1) * m2];
                for (t, &w) in g.coeffs.iter().enumerate() {
                    axpy(w, &inp[(g.start + t) * m2..(g.start + t + 1) * m2], d);
                }
            } else {
                let (c, d) = (k * m2, (m + k) * m2);
                for (t, &w) in h.coeffs.iter().enumerate() {
                    let l = h.start + t;
                    let (src, dst) = (&inp[c..c + m2], &mut out[l * m2..(l + 1) * m2]);
                    axpy(w, src, dst);
                }
                for (t, &w) in g.coeffs.iter().enumerate() {
                    let l = g.start + t;
                    let (src, dst) = (&inp[d..d + m2], &mut out[l * m2..(l + 1) * m2]);
                    axpy(w, src, dst);
                }
            }
        }
        for l in 0..m2 {
            let dst = base + l * stride;
            data[dst..dst + m2].copy_from_slice(&out[l * m2..(l + 1) * m2]);
        }
        Ok(())
    })
}

/// `y += a x`.
#[inline]
fn axpy(a: f64, x: &[f64], y: &mut [f64]) {
    for (yi, xi) in y.iter_mut().zip(x) {
        *yi += a * xi;
    }
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
    standard_with(mra, dim, level, j0, data, true, &mut Vec::new())
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
    standard_with(mra, dim, level, j0, data, false, &mut Vec::new())
}

/// [`standard_decompose`] (`forward = true`) or [`standard_reconstruct`] with a
/// caller-owned scratch buffer.
///
/// # Errors
/// Dimension, level and length errors.
pub fn standard_with<M: Mra + ?Sized>(
    mra: &M,
    dim: usize,
    level: u32,
    j0: u32,
    data: &mut [f64],
    forward: bool,
    buf: &mut Vec<f64>,
) -> Result<(), MraError> {
    let n = check_shape(mra, dim, level, j0, data.len())?;
    let (line, scratch) = split_scratch(buf, n);
    for axis in 0..dim {
        let stride = n.pow((dim - 1 - axis) as u32);
        for_each_line(dim, n, n, axis, |base| {
            for i in 0..n {
                line[i] = data[base + i * stride];
            }
            if forward {
                crate::transform::decompose_with(mra, level, j0, line, scratch)?;
            } else {
                crate::transform::reconstruct_with(mra, level, j0, line, scratch)?;
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
