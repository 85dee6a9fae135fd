//! Projection of a function onto `V_j^{⊗d}` and evaluation of expansions (Ziegler §3.1.4,
//! Figs. 3.5–3.6; the `P_j` of Ziegler §2.2.3).
//!
//! `⟨f, φ_{j,k}⟩` is computed in three exact steps from the Legendre moments of `f` on
//! the cells of a quadrature level `Q = j + extra` ([`Mra::projection_plan`]):
//! 1. moments `β_{c,a} = ∫ f ∏_i L_{Q,c_i,a_i}(x_i)`, `a_i < n_legendre`, supplied by
//!    the caller ([`project_moments`]) or by the built-in adaptive tensor Gauss rule
//!    ([`project`], [`GaussOptions`]);
//! 2. transfer to the level-`Q` scaling functions with the exact products
//!    [`Mra::legendre_products`] (the identity for `M_k`, where `Q = j`);
//! 3. pull (VirtualMesh §5.2) from `Q` down to `j` along every axis.
//!
//! For `M_k` (and Haar) the result is the exact L2 projection up to the moment
//! quadrature error. For CDV the result is the exact projection of the piecewise
//! polynomial (degree 5 on cells of width `2^-(j+3)`) L2 approximation of `f`.

use crate::poly::shifted_legendre_all;
use crate::{Mra, MraError};
use wavelux_quadrature::GaussLegendre;

/// Options of the built-in adaptive tensor Gauss rule.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GaussOptions {
    /// Gauss–Legendre points per axis on each box (≥ 1).
    pub order: usize,
    /// Absolute tolerance per cell on every moment, relative to the cell volume:
    /// a box is split when the whole-box and the 2^d-children estimates differ by more
    /// than `tolerance · volume` (0 disables refinement).
    pub tolerance: f64,
    /// Maximal number of bisections of a level-`Q` cell.
    pub max_depth: u32,
}

impl Default for GaussOptions {
    /// 8 points per axis, tolerance 1e-12, depth 8.
    fn default() -> Self {
        Self {
            order: 8,
            tolerance: 1e-12,
            max_depth: 8,
        }
    }
}

/// What the moment callback of [`project_moments`] is asked for.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CellQuery<'a> {
    /// Quadrature level `Q`: cells have width `2^-Q`.
    pub level: u32,
    /// Cell index per axis.
    pub cell: &'a [usize],
    /// Legendre polynomials per axis.
    pub n_legendre: usize,
}

impl CellQuery<'_> {
    /// Lower corner of the cell on axis `a`.
    #[must_use]
    pub fn lower(&self, a: usize) -> f64 {
        self.cell[a] as f64 * (-(self.level as f64)).exp2()
    }
    /// Cell width `2^-Q`.
    #[must_use]
    pub fn width(&self) -> f64 {
        (-(self.level as f64)).exp2()
    }
}

/// Projects onto `V_level^{⊗dim}` from caller-supplied moments. `moments(q, out)` must
/// write `∫_cell f(x) ∏_i 2^{Q/2} √(2a_i+1) P_{a_i}(2(2^Q x_i − c_i) − 1) dx` for every
/// multi-index `a` (row-major, `a_0` slowest, `out.len() = n_legendre^dim`).
/// Returns the `len(level)^dim` coefficients in the layout of [`crate::tensor`].
///
/// # Errors
/// Dimension and level errors.
pub fn project_moments<M: Mra + ?Sized>(
    mra: &M,
    dim: usize,
    level: u32,
    mut moments: impl FnMut(&CellQuery<'_>, &mut [f64]),
) -> Result<Vec<f64>, MraError> {
    if !(1..=4).contains(&dim) {
        return Err(MraError::UnsupportedDimension(dim));
    }
    mra.check_level(level)?;
    let (extra, nl) = mra.projection_plan();
    let q = level + extra;
    mra.check_level(q)?;
    let cells = 1usize << q;
    let m = cells * nl;
    let total = m.pow(dim as u32);
    let mut beta = vec![0.0; total];
    let mut out = vec![0.0; nl.pow(dim as u32)];
    let mut cell = [0usize; 4];
    let n_cells = cells.pow(dim as u32);
    for cflat in 0..n_cells {
        let mut r = cflat;
        for a in (0..dim).rev() {
            cell[a] = r % cells;
            r /= cells;
        }
        out.fill(0.0);
        moments(
            &CellQuery {
                level: q,
                cell: &cell[..dim],
                n_legendre: nl,
            },
            &mut out,
        );
        for (aflat, &v) in out.iter().enumerate() {
            let mut r = aflat;
            let mut idx = 0usize;
            let mut mul = 1usize;
            for ax in (0..dim).rev() {
                let aa = r % nl;
                r /= nl;
                idx += (cell[ax] * nl + aa) * mul;
                mul *= m;
            }
            beta[idx] = v;
        }
    }
    // Transfer Legendre moments -> level-Q scaling coefficients, axis by axis.
    let nq = mra.len(q);
    let mut rows: Vec<Vec<(usize, f64)>> = Vec::with_capacity(nq);
    for k in 0..nq {
        let mut r = Vec::new();
        mra.legendre_products(q, k, nl, &mut |c, a, v| r.push((c * nl + a, v)))?;
        rows.push(r);
    }
    let identity = nq == m
        && rows
            .iter()
            .enumerate()
            .all(|(k, r)| r.len() == 1 && r[0].0 == k && r[0].1 == 1.0);
    let mut data = beta;
    if !identity {
        for axis in 0..dim {
            let shape = cube(dim, m, axis, nq);
            data = map_axis_shape(&data, dim, &shape, axis, nq, |inp, outp| {
                for (o, r) in outp.iter_mut().zip(&rows) {
                    *o = r.iter().map(|&(i, v)| v * inp[i]).sum();
                }
            });
        }
    }
    // Pull from Q down to level.
    let mut j = q;
    while j > level {
        let nf = mra.len(j);
        let nc = mra.len(j - 1);
        let mut err = None;
        for axis in 0..dim {
            data = map_axis_shape(
                &data,
                dim,
                &cube(dim, nf, axis, nc),
                axis,
                nc,
                |inp, outp| {
                    if let Err(e) = crate::transform::pull_level(mra, j - 1, inp, outp) {
                        err = Some(e);
                    }
                },
            );
        }
        if let Some(e) = err {
            return Err(e);
        }
        j -= 1;
    }
    Ok(data)
}

/// Shape before mapping `axis` when axes `< axis` were already mapped to `nc`.
fn cube(dim: usize, nf: usize, axis: usize, nc: usize) -> Vec<usize> {
    (0..dim).map(|a| if a < axis { nc } else { nf }).collect()
}

/// Maps every line along `axis` of an array with the given shape (row-major) to a line
/// of length `new_len`; returns the new array.
fn map_axis_shape(
    data: &[f64],
    dim: usize,
    shape: &[usize],
    axis: usize,
    new_len: usize,
    mut f: impl FnMut(&[f64], &mut [f64]),
) -> Vec<f64> {
    let mut new_shape = shape.to_vec();
    new_shape[axis] = new_len;
    let stride_of = |sh: &[usize], a: usize| -> usize { sh[a + 1..dim].iter().product() };
    let (s_in, s_out) = (stride_of(shape, axis), stride_of(&new_shape, axis));
    let outer: usize = shape[..axis].iter().product();
    let inner: usize = shape[axis + 1..dim].iter().product();
    let mut out = vec![0.0; new_shape.iter().product()];
    let mut lin = vec![0.0; shape[axis]];
    let mut lout = vec![0.0; new_len];
    for o in 0..outer {
        for i in 0..inner {
            let base_in = o * shape[axis] * inner + i;
            for (t, v) in lin.iter_mut().enumerate() {
                *v = data[base_in + t * s_in];
            }
            f(&lin, &mut lout);
            let base_out = o * new_len * inner + i;
            for (t, &v) in lout.iter().enumerate() {
                out[base_out + t * s_out] = v;
            }
        }
    }
    out
}

/// Projects `f: [0,1]^dim → R` onto `V_level^{⊗dim}` with the adaptive tensor Gauss rule
/// for the moments (see the module docs).
///
/// # Errors
/// Dimension/level errors; [`MraError::InvalidParameter`] for `order = 0` or `> 128`.
pub fn project<M: Mra + ?Sized>(
    mra: &M,
    dim: usize,
    level: u32,
    f: impl Fn(&[f64]) -> f64,
    opts: GaussOptions,
) -> Result<Vec<f64>, MraError> {
    let gl = GaussLegendre::new(opts.order)
        .map_err(|_| MraError::InvalidParameter("Gauss order must be in 1..=128"))?;
    let (pts, wts) = gl.unit();
    let mut scratch = MomentScratch::new(dim, mra.projection_plan().1, pts.len());
    project_moments(mra, dim, level, |q, out| {
        let lo: Vec<f64> = (0..dim).map(|a| q.lower(a)).collect();
        let w = q.width();
        adaptive_box(&f, q, &lo, w, &pts, &wts, opts, 0, None, out, &mut scratch);
    })
}

/// Reusable buffers for box integration.
struct MomentScratch {
    dim: usize,
    nl: usize,
    leg: Vec<f64>,
    x: Vec<f64>,
}

impl MomentScratch {
    fn new(dim: usize, nl: usize, _np: usize) -> Self {
        Self {
            dim,
            nl,
            leg: vec![0.0; dim * nl],
            x: vec![0.0; dim],
        }
    }
}

/// Tensor Gauss estimate of the Legendre moments of the cell `q` restricted to the box
/// `[lo, lo + w]^d`, accumulated into `out`.
fn box_estimate(
    f: &impl Fn(&[f64]) -> f64,
    q: &CellQuery<'_>,
    lo: &[f64],
    w: f64,
    pts: &[f64],
    wts: &[f64],
    out: &mut [f64],
    s: &mut MomentScratch,
) {
    let dim = s.dim;
    let nl = s.nl;
    let np = pts.len();
    let cw = q.width();
    let norm = (0.5 * q.level as f64).exp2();
    let total = np.pow(dim as u32);
    let vol = w.powi(dim as i32);
    for p in 0..total {
        let mut r = p;
        let mut wt = vol;
        for a in (0..dim).rev() {
            let i = r % np;
            r /= np;
            s.x[a] = lo[a] + w * pts[i];
            wt *= wts[i];
            let loc = (s.x[a] - q.lower(a)) / cw;
            shifted_legendre_all(loc, &mut s.leg[a * nl..(a + 1) * nl]);
        }
        let fv = f(&s.x[..dim]) * wt;
        if fv == 0.0 {
            continue;
        }
        // out[a multi-index] += fv * prod L
        let nmom = out.len();
        for (aflat, o) in out.iter_mut().enumerate().take(nmom) {
            let mut rr = aflat;
            let mut prod = fv;
            for a in (0..dim).rev() {
                let aa = rr % nl;
                rr /= nl;
                prod *= norm * s.leg[a * nl + aa];
            }
            *o += prod;
        }
    }
}

#[allow(clippy::too_many_arguments)]
fn adaptive_box(
    f: &impl Fn(&[f64]) -> f64,
    q: &CellQuery<'_>,
    lo: &[f64],
    w: f64,
    pts: &[f64],
    wts: &[f64],
    opts: GaussOptions,
    depth: u32,
    whole: Option<Vec<f64>>,
    out: &mut [f64],
    s: &mut MomentScratch,
) {
    let dim = s.dim;
    let whole = whole.unwrap_or_else(|| {
        let mut v = vec![0.0; out.len()];
        box_estimate(f, q, lo, w, pts, wts, &mut v, s);
        v
    });
    if depth >= opts.max_depth || opts.tolerance <= 0.0 {
        out.iter_mut().zip(&whole).for_each(|(o, v)| *o += v);
        return;
    }
    let h = 0.5 * w;
    let mut kids: Vec<Vec<f64>> = Vec::with_capacity(1 << dim);
    let mut sum = vec![0.0; out.len()];
    let mut clo = vec![0.0; dim];
    for child in 0..(1usize << dim) {
        for a in 0..dim {
            clo[a] = lo[a] + h * ((child >> a) & 1) as f64;
        }
        let mut v = vec![0.0; out.len()];
        box_estimate(f, q, &clo, h, pts, wts, &mut v, s);
        sum.iter_mut().zip(&v).for_each(|(t, x)| *t += x);
        kids.push(v);
    }
    let diff = sum
        .iter()
        .zip(&whole)
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    let cell_vol = q.width().powi(dim as i32);
    let scale = (0.5 * q.level as f64 * dim as f64).exp2();
    if diff <= opts.tolerance * cell_vol * scale || !diff.is_finite() {
        out.iter_mut().zip(&sum).for_each(|(o, v)| *o += v);
        return;
    }
    for (child, v) in kids.into_iter().enumerate() {
        for a in 0..dim {
            clo[a] = lo[a] + h * ((child >> a) & 1) as f64;
        }
        let c = clo.clone();
        adaptive_box(f, q, &c, h, pts, wts, opts, depth + 1, Some(v), out, s);
    }
}

/// Evaluates `Σ_k c_k ∏_i φ_{level,k_i}(x_i)` at `x` (the layout of [`crate::tensor`]),
/// touching only the few functions non-zero at `x`.
///
/// # Errors
/// Dimension/level/length errors, [`MraError::NonFinite`].
pub fn evaluate<M: Mra + ?Sized>(
    mra: &M,
    dim: usize,
    level: u32,
    coeffs: &[f64],
    x: &[f64],
) -> Result<f64, MraError> {
    if !(1..=4).contains(&dim) {
        return Err(MraError::UnsupportedDimension(dim));
    }
    mra.check_level(level)?;
    let n = mra.len(level);
    let expected = n.pow(dim as u32);
    if coeffs.len() != expected || x.len() != dim {
        return Err(MraError::LengthMismatch {
            got: coeffs.len(),
            expected,
        });
    }
    let mut ranges = [0usize..0, 0..0, 0..0, 0..0];
    let mut vals = [[0.0f64; 16]; 4];
    for a in 0..dim {
        let r = mra.nonzero_at(level, x[a])?;
        if r.len() > 16 {
            return Err(MraError::InvalidParameter("too many overlapping functions"));
        }
        for (i, k) in r.clone().enumerate() {
            vals[a][i] = mra.eval_scaling(level, k, x[a])?;
        }
        ranges[a] = r;
    }
    let lens: Vec<usize> = (0..dim).map(|a| ranges[a].len()).collect();
    let count: usize = lens.iter().product();
    let mut s = 0.0;
    for t in 0..count {
        let mut r = t;
        let mut flat = 0usize;
        let mut prod = 1.0;
        let mut mul = 1usize;
        for a in (0..dim).rev() {
            let i = r % lens[a];
            r /= lens[a];
            flat += (ranges[a].start + i) * mul;
            mul *= n;
            prod *= vals[a][i];
        }
        s += prod * coeffs[flat];
    }
    Ok(s)
}
