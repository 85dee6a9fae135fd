//! One-dimensional fast wavelet transforms (Ziegler §2.2.3, eqs. (2.11)–(2.12)) and the
//! push/pull operations between levels (VirtualMesh §5.2, eq. (4)).
//!
//! Layout of a full decomposition of level `J` down to level `j0` ("Mallat layout"):
//! `[c_{j0} | d_{j0} | d_{j0+1} | … | d_{J−1}]`, total length `len(J)`; the block of
//! `d_j` starts at `len(j)`. Every step costs O(len) and allocates nothing beyond one
//! scratch buffer of length `len(J)` per call.
//!
//! Push/pull: the coefficients `h_{k,l}` do not depend on the level except through the
//! position of the boundary rows (VirtualMesh §5.2 proves this for dilated/translated
//! bases; the CDV edge rows are level-independent too). `pull` computes a coarse
//! scaling coefficient from its children (`α^{m}_k = Σ_l h_{k,l} α^{m+1}_l`); `push`
//! distributes a coarse scaling coefficient onto its children
//! (`α^{m+1}_l += h_{k,l} α^m_k`), i.e. represents `α φ_{m,k}` exactly on level `m + 1`.

use crate::{Mra, MraError};

/// Checks `j0 <= level` and both levels supported; returns `len(level)`.
fn check_range<M: Mra + ?Sized>(mra: &M, level: u32, j0: u32) -> Result<usize, MraError> {
    mra.check_level(level)?;
    mra.check_level(j0)?;
    if j0 > level {
        return Err(MraError::LevelOutOfRange {
            level: j0,
            min: mra.min_level(),
            max: level,
        });
    }
    Ok(mra.len(level))
}

/// Full decomposition in place: `data` holds the scaling coefficients of level `level`
/// and is overwritten by the Mallat layout down to level `j0` (the standard
/// decomposition `D_{S,m}` of Ziegler (2.11)). O(n); `scratch` must have the same length.
///
/// # Errors
/// Level errors; [`MraError::LengthMismatch`] for wrong buffer lengths.
pub fn decompose_with<M: Mra + ?Sized>(
    mra: &M,
    level: u32,
    j0: u32,
    data: &mut [f64],
    scratch: &mut [f64],
) -> Result<(), MraError> {
    let n = check_range(mra, level, j0)?;
    for got in [data.len(), scratch.len()] {
        if got != n {
            return Err(MraError::LengthMismatch { got, expected: n });
        }
    }
    for j in (j0..level).rev() {
        let m = mra.len(j);
        scratch[..2 * m].copy_from_slice(&data[..2 * m]);
        let (c, d) = data[..2 * m].split_at_mut(m);
        mra.analysis_step(j, &scratch[..2 * m], c, d)?;
    }
    Ok(())
}

/// [`decompose_with`] with an internally allocated scratch buffer.
///
/// # Errors
/// As [`decompose_with`].
pub fn decompose<M: Mra + ?Sized>(
    mra: &M,
    level: u32,
    j0: u32,
    data: &mut [f64],
) -> Result<(), MraError> {
    let mut scratch = vec![0.0; data.len()];
    decompose_with(mra, level, j0, data, &mut scratch)
}

/// Inverse of [`decompose_with`] (Ziegler's `D_{S,m}^{-1}`), in place. O(n).
///
/// # Errors
/// As [`decompose_with`].
pub fn reconstruct_with<M: Mra + ?Sized>(
    mra: &M,
    level: u32,
    j0: u32,
    data: &mut [f64],
    scratch: &mut [f64],
) -> Result<(), MraError> {
    let n = check_range(mra, level, j0)?;
    for got in [data.len(), scratch.len()] {
        if got != n {
            return Err(MraError::LengthMismatch { got, expected: n });
        }
    }
    for j in j0..level {
        let m = mra.len(j);
        scratch[..2 * m].copy_from_slice(&data[..2 * m]);
        let (c, d) = scratch[..2 * m].split_at(m);
        mra.synthesis_step(j, c, d, &mut data[..2 * m])?;
    }
    Ok(())
}

/// [`reconstruct_with`] with an internally allocated scratch buffer.
///
/// # Errors
/// As [`decompose_with`].
pub fn reconstruct<M: Mra + ?Sized>(
    mra: &M,
    level: u32,
    j0: u32,
    data: &mut [f64],
) -> Result<(), MraError> {
    let mut scratch = vec![0.0; data.len()];
    reconstruct_with(mra, level, j0, data, &mut scratch)
}

/// `(scaling, detail)` coefficient vectors per level, coarsest first.
pub type Pyramid = (Vec<Vec<f64>>, Vec<Vec<f64>>);

/// The non-standard decomposition `D_{N,m}` of Ziegler (2.12) in 1D: scaling
/// coefficients on every level `j0..=level` as well as the wavelet coefficients.
/// Returns `(scaling, detail)` where `scaling[j - j0]` has `len(j)` entries (`j0..=level`)
/// and `detail[j - j0]` has `len(j)` entries (`j0..level`).
///
/// # Errors
/// Level and length errors.
pub fn nonstandard_pyramid<M: Mra + ?Sized>(
    mra: &M,
    level: u32,
    j0: u32,
    fine: &[f64],
) -> Result<Pyramid, MraError> {
    let n = check_range(mra, level, j0)?;
    if fine.len() != n {
        return Err(MraError::LengthMismatch {
            got: fine.len(),
            expected: n,
        });
    }
    let mut scaling = vec![fine.to_vec()];
    let mut detail = Vec::new();
    for j in (j0..level).rev() {
        let m = mra.len(j);
        let mut c = vec![0.0; m];
        let mut d = vec![0.0; m];
        mra.analysis_step(j, scaling.last().map_or(&[][..], |v| v), &mut c, &mut d)?;
        scaling.push(c);
        detail.push(d);
    }
    scaling.reverse();
    detail.reverse();
    Ok((scaling, detail))
}

/// Pull (VirtualMesh §5.2 eq. (4)): the level-`level` scaling coefficient `k` from the
/// level-`level+1` coefficients given by `child(l)`: `Σ_l h_{k,l} child(l)`.
///
/// # Errors
/// Level/index errors.
pub fn pull<M: Mra + ?Sized>(
    mra: &M,
    level: u32,
    k: usize,
    mut child: impl FnMut(usize) -> f64,
) -> Result<f64, MraError> {
    let r = mra.scaling_row(level, k)?;
    Ok(r.coeffs
        .iter()
        .enumerate()
        .map(|(i, &h)| h * child(r.start + i))
        .sum())
}

/// Push (VirtualMesh §5.2 eq. (4)): distributes `value · φ_{level,k}` onto the
/// level-`level+1` scaling functions, calling `add(l, h_{k,l} · value)`.
///
/// # Errors
/// Level/index errors.
pub fn push<M: Mra + ?Sized>(
    mra: &M,
    level: u32,
    k: usize,
    value: f64,
    mut add: impl FnMut(usize, f64),
) -> Result<(), MraError> {
    let r = mra.scaling_row(level, k)?;
    for (i, &h) in r.coeffs.iter().enumerate() {
        add(r.start + i, h * value);
    }
    Ok(())
}

/// Pushes a whole level: `fine = H^T coarse` (the scaling part of a synthesis step);
/// represents the level-`level` expansion exactly on `level + 1`. O(n), no allocation.
///
/// # Errors
/// Level and length errors.
pub fn push_level<M: Mra + ?Sized>(
    mra: &M,
    level: u32,
    coarse: &[f64],
    fine: &mut [f64],
) -> Result<(), MraError> {
    crate::check_step_lengths(mra, level, fine.len(), coarse.len(), coarse.len())?;
    fine.fill(0.0);
    for (k, &c) in coarse.iter().enumerate() {
        let r = mra.scaling_row(level, k)?;
        for (f, &h) in fine[r.start..r.end()].iter_mut().zip(r.coeffs) {
            *f += h * c;
        }
    }
    Ok(())
}

/// Pulls a whole level: `coarse = H fine` (the orthogonal projection of the level-`level+1`
/// expansion onto `V_level`). O(n), no allocation.
///
/// # Errors
/// Level and length errors.
pub fn pull_level<M: Mra + ?Sized>(
    mra: &M,
    level: u32,
    fine: &[f64],
    coarse: &mut [f64],
) -> Result<(), MraError> {
    crate::check_step_lengths(mra, level, fine.len(), coarse.len(), coarse.len())?;
    for (k, c) in coarse.iter_mut().enumerate() {
        let r = mra.scaling_row(level, k)?;
        *c = crate::dot(r.coeffs, &fine[r.start..r.end()]);
    }
    Ok(())
}
