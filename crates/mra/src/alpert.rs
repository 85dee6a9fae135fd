//! Alpert's multiwavelets `M_k` on [0, 1] (Ziegler §3.1.2, after Alpert 1993, `alpe93`; the bases
//! `M_1`, `M_2`, `M_3` of VirtualMesh §5.2). `M_1` is the Haar MRA (Ziegler §3.1.1).
//!
//! On level `j` the interval is split into `2^j` cells; cell `c` carries the `k`
//! orthonormal shifted Legendre polynomials `φ_{j,ck+a}(x) = 2^{j/2} √(2a+1)
//! P_a(2(2^j x − c) − 1)`, `a < k`. The two-scale matrices are computed from this
//! definition, `h_{a,b} = ⟨φ_{0,a}, φ_{1,b}⟩` by a `k`-point Gauss rule on each half cell
//! (exact: the integrand has degree `2k − 2`). They do not depend on the level
//! (VirtualMesh §5.2): the row of `φ_{j,ck+a}` is the same `2k` numbers starting at child
//! `2ck`.
//!
//! The `k` wavelets of a cell are piecewise polynomials of degree `< k` on the two half
//! cells, orthogonal to all polynomials of degree `< k` (`k` vanishing moments). As in
//! Alpert's construction, `ψ_a` is additionally orthogonal to `x^k, …, x^{k+a−1}`:
//! `ψ_{k−1}` is determined first (orthogonal to degree `2k − 2`), then `ψ_{k−2}`, …, each
//! orthogonal to the ones before. Signs: for `k = 1` (Haar) `g = (1, −1)/√2` as in
//! Ziegler (3.2); for `k ≥ 2` the last non-zero coefficient (highest Legendre degree on
//! the right half) is positive, which reproduces Ziegler's §3.1.2 table for `M_2`.

use crate::linalg::{complement_vector, dotv};
use crate::poly::shifted_legendre_all;
use crate::{FilterRow, MAX_LEVEL, Mra, MraError, check_step_lengths, dot};
use wavelux_quadrature::GaussLegendre;

/// Largest supported number of functions per cell.
pub const MAX_ORDER: usize = 8;

/// Alpert's multiwavelet MRA `M_k` (`k` functions per cell, `k` vanishing moments,
/// polynomials of degree `k − 1` reproduced exactly).
#[derive(Debug, Clone, PartialEq)]
pub struct Alpert {
    k: usize,
    /// `h[a * 2k + b]`: coefficient of `φ_a` on child `b` (`b < k`: left half cell,
    /// `b ≥ k`: right half cell, Legendre index `b − k`).
    h: Vec<f64>,
    /// Same layout for the wavelets.
    g: Vec<f64>,
}

impl Alpert {
    /// `M_k` for `1 ≤ k ≤ 8`.
    ///
    /// # Errors
    /// [`MraError::UnsupportedOrder`] for `k = 0` or `k > 8`.
    pub fn new(k: usize) -> Result<Self, MraError> {
        if !(1..=MAX_ORDER).contains(&k) {
            return Err(MraError::UnsupportedOrder(k));
        }
        let two_k = 2 * k;
        // Quadrature exact for degree 2k - 1 + 2k - 1 on each half (moments up to 2k-2
        // times degree k-1 polynomials).
        let gl = GaussLegendre::new(2 * k).map_err(|_| MraError::UnsupportedOrder(k))?;
        let (pts, wts) = gl.unit();
        let mut h = vec![0.0; k * two_k];
        let mut parent = vec![0.0; k];
        let mut child = vec![0.0; k];
        // Moments (x - 1/2)^i, i < 2k - 1, of each child function.
        let n_mom = two_k - 1;
        let mut moments = vec![vec![0.0; two_k]; n_mom];
        for half in 0..2 {
            for (&s, &w) in pts.iter().zip(&wts) {
                // s in [0,1] is the child's local coordinate; x = (s + half)/2.
                let x = 0.5 * (s + half as f64);
                shifted_legendre_all(x, &mut parent);
                shifted_legendre_all(s, &mut child);
                // child function on [0,1]: sqrt(2) * child_b(2x - half); dx = ds / 2.
                for a in 0..k {
                    for b in 0..k {
                        h[a * two_k + half * k + b] +=
                            0.5 * w * parent[a] * std::f64::consts::SQRT_2 * child[b];
                    }
                }
                for (i, m) in moments.iter_mut().enumerate() {
                    let xi = (x - 0.5).powi(i as i32);
                    for b in 0..k {
                        m[half * k + b] += 0.5 * w * xi * std::f64::consts::SQRT_2 * child[b];
                    }
                }
            }
        }
        let mut g = vec![0.0; k * two_k];
        let mut found: Vec<Vec<f64>> = Vec::new();
        for a in (0..k).rev() {
            let mut cons: Vec<Vec<f64>> = moments[..k + a].to_vec();
            cons.extend(found.iter().cloned());
            let mut v = complement_vector(&cons, two_k);
            let sign_idx = if k == 1 {
                0
            } else {
                (0..two_k)
                    .rev()
                    .find(|&i| v[i].abs() > 1e-8)
                    .unwrap_or(two_k - 1)
            };
            if v[sign_idx] < 0.0 {
                v.iter_mut().for_each(|x| *x = -*x);
            }
            // Clean exact zeros that are rounding noise.
            v.iter_mut().for_each(|x| {
                if x.abs() < 1e-15 {
                    *x = 0.0;
                }
            });
            g[a * two_k..(a + 1) * two_k].copy_from_slice(&v);
            found.push(v);
        }
        debug_assert!(found.iter().all(|v| (dotv(v, v) - 1.0).abs() < 1e-12));
        Ok(Self { k, h, g })
    }

    /// The Haar MRA, `M_1` (Ziegler §3.1.1, GlobalCube §2.3).
    #[must_use]
    pub fn haar() -> Self {
        Self {
            k: 1,
            h: vec![std::f64::consts::FRAC_1_SQRT_2; 2],
            g: vec![
                std::f64::consts::FRAC_1_SQRT_2,
                -std::f64::consts::FRAC_1_SQRT_2,
            ],
        }
    }

    /// Functions per cell `k`.
    #[must_use]
    pub fn order(&self) -> usize {
        self.k
    }

    /// The level-independent scaling two-scale block, `k × 2k` row-major: row `a` holds
    /// the coefficients of `φ_a` on the left-cell children `0..k` then the right-cell
    /// children `k..2k` (VirtualMesh §5.2 push/pull coefficients).
    #[must_use]
    pub fn scaling_block(&self) -> &[f64] {
        &self.h
    }

    /// The level-independent wavelet two-scale block, same layout as
    /// [`Alpert::scaling_block`].
    #[must_use]
    pub fn wavelet_block(&self) -> &[f64] {
        &self.g
    }

    fn eval_block(&self, level: u32, k: usize, x: f64, wavelet: bool) -> Result<f64, MraError> {
        self.check_index(level, k)?;
        if !x.is_finite() {
            return Err(MraError::NonFinite("evaluation point"));
        }
        if !(0.0..=1.0).contains(&x) {
            return Ok(0.0);
        }
        let kk = self.k;
        let cells = 1usize << level;
        let cell = k / kk;
        let a = k % kk;
        let scaled = x * cells as f64;
        let cx = (scaled.floor() as usize).min(cells - 1);
        if cx != cell {
            return Ok(0.0);
        }
        let s = scaled - cell as f64;
        let mut buf = [0.0; MAX_ORDER];
        if !wavelet {
            shifted_legendre_all(s, &mut buf[..=a]);
            return Ok((0.5 * level as f64).exp2() * buf[a]);
        }
        let half = usize::from(s >= 0.5);
        let sc = 2.0 * s - half as f64;
        shifted_legendre_all(sc, &mut buf[..kk]);
        let row = &self.g[a * 2 * kk + half * kk..a * 2 * kk + half * kk + kk];
        Ok((0.5 * (level + 1) as f64).exp2() * dot(row, &buf[..kk]))
    }
}

impl Mra for Alpert {
    fn name(&self) -> String {
        if self.k == 1 {
            "Haar".to_string()
        } else {
            format!("M{}", self.k)
        }
    }
    fn min_level(&self) -> u32 {
        0
    }
    fn len(&self, level: u32) -> usize {
        self.k << level.min(MAX_LEVEL)
    }
    fn functions_per_cell(&self) -> usize {
        self.k
    }
    fn vanishing_moments(&self) -> usize {
        self.k
    }
    fn polynomial_degree(&self) -> usize {
        self.k - 1
    }
    fn is_piecewise_polynomial(&self) -> bool {
        true
    }
    fn scaling_row(&self, level: u32, k: usize) -> Result<FilterRow<'_>, MraError> {
        self.check_index(level, k)?;
        let a = k % self.k;
        Ok(FilterRow {
            start: 2 * (k - a),
            coeffs: &self.h[a * 2 * self.k..(a + 1) * 2 * self.k],
        })
    }
    fn wavelet_row(&self, level: u32, k: usize) -> Result<FilterRow<'_>, MraError> {
        self.check_index(level, k)?;
        let a = k % self.k;
        Ok(FilterRow {
            start: 2 * (k - a),
            coeffs: &self.g[a * 2 * self.k..(a + 1) * 2 * self.k],
        })
    }
    fn parents(&self, level: u32, l: usize) -> Result<std::ops::Range<usize>, MraError> {
        self.check_level(level)?;
        self.check_index(level + 1, l)?;
        let pc = l / self.k / 2;
        Ok(pc * self.k..(pc + 1) * self.k)
    }
    fn support(&self, level: u32, k: usize) -> Result<(f64, f64), MraError> {
        self.check_index(level, k)?;
        let w = (-(level as f64)).exp2();
        let c = (k / self.k) as f64;
        Ok((c * w, (c + 1.0) * w))
    }
    fn eval_scaling(&self, level: u32, k: usize, x: f64) -> Result<f64, MraError> {
        self.eval_block(level, k, x, false)
    }
    fn eval_wavelet(&self, level: u32, k: usize, x: f64) -> Result<f64, MraError> {
        self.eval_block(level, k, x, true)
    }
    fn nonzero_at(&self, level: u32, x: f64) -> Result<std::ops::Range<usize>, MraError> {
        self.check_level(level)?;
        if !x.is_finite() {
            return Err(MraError::NonFinite("evaluation point"));
        }
        if !(0.0..=1.0).contains(&x) {
            return Ok(0..0);
        }
        let cells = 1usize << level;
        let c = ((x * cells as f64).floor() as usize).min(cells - 1);
        Ok(c * self.k..(c + 1) * self.k)
    }
    fn legendre_products(
        &self,
        level: u32,
        k: usize,
        n_legendre: usize,
        f: &mut dyn FnMut(usize, usize, f64),
    ) -> Result<(), MraError> {
        self.check_index(level, k)?;
        let a = k % self.k;
        if a < n_legendre {
            f(k / self.k, a, 1.0);
        }
        Ok(())
    }
    fn projection_plan(&self) -> (u32, usize) {
        (0, self.k)
    }
    fn analysis_step(
        &self,
        level: u32,
        fine: &[f64],
        coarse: &mut [f64],
        detail: &mut [f64],
    ) -> Result<(), MraError> {
        check_step_lengths(self, level, fine.len(), coarse.len(), detail.len())?;
        let k = self.k;
        let tk = 2 * k;
        if k == 1 {
            // Haar fast path (no inner loops).
            let (h0, h1, g0, g1) = (self.h[0], self.h[1], self.g[0], self.g[1]);
            for ((f, c), d) in fine
                .chunks_exact(2)
                .zip(coarse.iter_mut())
                .zip(detail.iter_mut())
            {
                *c = h0 * f[0] + h1 * f[1];
                *d = g0 * f[0] + g1 * f[1];
            }
            return Ok(());
        }
        for ((block, c), d) in fine
            .chunks_exact(tk)
            .zip(coarse.chunks_exact_mut(k))
            .zip(detail.chunks_exact_mut(k))
        {
            for a in 0..k {
                c[a] = dot(&self.h[a * tk..(a + 1) * tk], block);
                d[a] = dot(&self.g[a * tk..(a + 1) * tk], block);
            }
        }
        Ok(())
    }
    fn synthesis_step(
        &self,
        level: u32,
        coarse: &[f64],
        detail: &[f64],
        fine: &mut [f64],
    ) -> Result<(), MraError> {
        check_step_lengths(self, level, fine.len(), coarse.len(), detail.len())?;
        let k = self.k;
        let tk = 2 * k;
        if k == 1 {
            let (h0, h1, g0, g1) = (self.h[0], self.h[1], self.g[0], self.g[1]);
            for ((f, &c), &d) in fine.chunks_exact_mut(2).zip(coarse).zip(detail) {
                f[0] = h0 * c + g0 * d;
                f[1] = h1 * c + g1 * d;
            }
            return Ok(());
        }
        for ((block, c), d) in fine
            .chunks_exact_mut(tk)
            .zip(coarse.chunks_exact(k))
            .zip(detail.chunks_exact(k))
        {
            for (b, f) in block.iter_mut().enumerate() {
                let mut s = 0.0;
                for a in 0..k {
                    s += self.h[a * tk + b] * c[a] + self.g[a * tk + b] * d[a];
                }
                *f = s;
            }
        }
        Ok(())
    }
}
