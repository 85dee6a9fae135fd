//! Cohen–Daubechies–Vial (CDV-D4) wavelet radiosity (Ziegler §3.1.3, §3.3).
//!
//! # Basis
//!
//! Every patch carries the 2D non-standard tensor basis of the CDV MRA on the interval
//! (`wavelux_mra::Cdv`, boundary functions included) on its unit-square support, from
//! the coarsest CDV level `j0 = 2` (4 functions per axis, Ziegler's "level 0") up to a
//! per-patch finest level `J_p ≤ max_level` (so `max_level` counts dyadic levels exactly
//! as for Haar: `4^max_level` functions per patch). A *vertex* `(patch, j, kx, ky)`
//! (Ziegler §3.3.4) carries one scaling function and three wavelets,
//! `a = fy·2 + fx` with `f ∈ {φ, ψ}`: `a = 0` is `φ(s)φ(t)`, `1` is `ψ(s)φ(t)`, `2` is
//! `φ(s)ψ(t)`, `3` is `ψ(s)ψ(t)`, all `L²(S)`-orthonormal (`/√|S|`, Ziegler §3.3.1).
//! Supports overlap (2–3 cells of level `j` per axis), so the hierarchy is not a tree:
//! a level-`j+1` vertex has up to 3 parents per axis.
//!
//! # Operator
//!
//! The non-standard representation (Ziegler §2.2.3): a *link* between a receiver and
//! an emitter vertex of the same level stores the 4 × 4 block
//! `T_ab = ⟨a_R, G V b_E⟩`; on level `j0` every facing vertex pair keeps its `φφ–φφ`
//! entry, and a pair whose kernel the oracle finds non-smooth (Ziegler §3.3.2, the
//! kernel-smoothness estimate of [`TransferCtx::estimate`] over the square that covers
//! both supports) is *refined*: its 15 wavelet entries are stored (16 on `j0`) and
//! every pair of their children (level `j+1` vertices in the two-scale rows) is
//! examined. Children reached from several refined parents are examined once (the
//! candidate set is deduplicated level by level — Ziegler §3.3.4's check "whether a
//! link had already been computed"). Ziegler's link count is refined pairs plus
//! unrefined root pairs ([`crate::Statistics::nonstandard_links`]).
//!
//! Applying `K`: per patch, the finest-level coefficients are analysed down to `j0`
//! with the CDV two-scale rows (pull: scaling and wavelet coefficients at every
//! vertex), gathered over links, synthesised back up (push), multiplied by `ρ`. The
//! analysis is orthogonal and the synthesis its transpose, so `Kᵀ` is as cheap (CGNR).
//!
//! # Transfer coefficients (deviation from Ziegler's sample-weight rule)
//!
//! Ziegler §3.3.3 interpolates the kernel linearly between 3 equidistant samples over
//! each support and integrates the hat functions against the CDV functions with
//! precomputed moments. We use a Galerkin form of the same idea: every CDV vertex
//! function is projected *exactly* (`Mra::legendre_products`, exact cell moments from
//! the refinement equation) onto the tensor piecewise polynomials `M_p` (Alpert scaling
//! functions, `p =` [`CDV_QUADRATURE_P`] `= 3` per axis: degree ≤ 2) of the level-`j`
//! cells of its support, and `T_ab = Σ_{c,c'} P_a[c]ᵀ M(c,c') P_b[c']` with `M(c,c')` the
//! `M_p` transfer block of the cell pair from [`TransferCtx::block`] (`n_samp` Gauss
//! points per axis and cell, singular rules for touching cells, near-field splitting,
//! visibility in quadrature with the accelerator). Like Ziegler's rule it is exact for
//! kernels that are (bi)linear on each cell pair (in fact of degree ≤ `p − 1` per
//! variable), so the wavelets' two vanishing moments are preserved exactly; its error
//! is `⟨(I−P)a, (I−P)Kb⟩`, of order `h^p` in the cell size `h`. Cell-pair blocks are computed once per level and shared by all the
//! overlapping vertex pairs that need them.
//!
//! # Solution
//!
//! [`CdvField`] evaluates the expansion exactly (point values of `wavelux-mra`, exact at
//! dyadic points `2^-(J+15)`, linear in between). [`crate::Solution`] keeps its tree
//! representation as a documented conversion: a complete Haar quadtree down to `J_p`
//! whose leaves hold the *exact* cell averages of the CDV expansion (radiosity and
//! irradiance), so node/patch/surface averages and energy are exact; point queries
//! ([`crate::Solution::radiosity`]) evaluate the CDV expansion itself.
//!
//! Supports must be planar, unmasked and equal-area (every point of the unit square
//! real, `dA = |S| ds dt`, no self-links); virtual (masked) and curved supports are
//! rejected with [`SolverError::UnsupportedSurface`] and are solved with the tree bases.

use std::sync::Arc;
use std::time::Instant;

use rayon::prelude::*;
use wavelux_linear::{Convergence, Operator, Unsupported};
use wavelux_mra::{Cdv, Mra};

use crate::Prepared;
use crate::basis::{BasisKind, TreeBasis};
use crate::error::SolverError;
use crate::hierarchy::{Hierarchy, NodeKey, Oracle, RefineCounts, RefineParams};
use crate::solution::{Energy, Solution, Statistics};
use crate::support::{Coverage, Patch};
use crate::system::System;
use crate::transfer::{Region, TransferCtx};

/// Coarsest CDV level (4 functions per axis; Ziegler's level 0).
pub const CDV_MIN_LEVEL: u8 = 2;

/// Largest quadrature basis `M_p` (functions per axis and cell).
const MAXP: usize = 4;

/// Functions per axis and cell of the quadrature basis the CDV transfer coefficients
/// are assembled from (`M_p`, piecewise polynomials of degree `p − 1`).
pub const CDV_QUADRATURE_P: usize = 3;

/// Orthonormal shifted Legendre polynomials `L̂_a(x) = √(2a+1) P_a(2x − 1)`, `a < MAXP`.
fn legendre(x: f64) -> [f64; MAXP] {
    let y = 2.0 * x - 1.0;
    let mut p = [0.0; MAXP];
    p[0] = 1.0;
    p[1] = y;
    for a in 1..MAXP - 1 {
        p[a + 1] = ((2 * a + 1) as f64 * y * p[a] - a as f64 * p[a - 1]) / (a + 1) as f64;
    }
    for (a, v) in p.iter_mut().enumerate() {
        *v *= ((2 * a + 1) as f64).sqrt();
    }
    p
}

fn mra_err(e: wavelux_mra::MraError) -> SolverError {
    SolverError::Dependency {
        what: "mra",
        message: e.to_string(),
    }
}

/// One-dimensional data of one CDV level `j`.
#[derive(Debug, Clone)]
struct Level1d {
    /// Functions on the level, `2^j`.
    n: usize,
    /// Scaling rows `(first child, coefficients)` on level `j + 1`.
    h: Vec<(usize, Vec<f64>)>,
    /// Wavelet rows on level `j + 1`.
    g: Vec<(usize, Vec<f64>)>,
    /// `(first cell, cell count)` of the support of `φ_{j,k}` / `ψ_{j,k}` on level `j`.
    cells: Vec<(usize, usize)>,
    /// `proj[f][k][c][m]`: inner products of `φ_{j,k}` (`f = 0`) / `ψ_{j,k}` (`f = 1`)
    /// with the `p` orthonormal 1D cell functions `m` of the quadrature basis `M_p` on
    /// the support's cell `c`.
    proj: [Vec<Vec<[f64; MAXP]>>; 2],
    /// `∫_cell φ_{j,k}` over the support's cells.
    cell_int: Vec<Vec<f64>>,
    /// `∫_0^1 φ_{j,k}`.
    integral: Vec<f64>,
    /// Children range `[lo, hi)` on level `j + 1` (union of both rows).
    children: Vec<(usize, usize)>,
    /// Parents on level `j − 1` of each function (inverse of the children ranges).
    parents: Vec<Vec<usize>>,
}

/// The CDV MRA with everything the solver needs per level (two-scale rows, exact
/// projections onto the `M_p` cell functions, integrals).
#[derive(Debug)]
pub struct CdvBasis {
    mra: Cdv,
    max_level: u8,
    levels: Vec<Level1d>,
    /// Functions per axis and cell of the quadrature basis `M_p`.
    pk: usize,
}

impl CdvBasis {
    /// Builds levels `CDV_MIN_LEVEL..=max_level`; `quad` must be the `M_p` basis of the
    /// transfer context (its cell functions define the projections).
    ///
    /// # Errors
    /// [`SolverError::InvalidConfig`] if `max_level < 2` or `quad` is not `M_p`, `2 ≤ p ≤ 4`;
    /// [`SolverError::Dependency`] if the MRA rejects a request.
    pub fn new(max_level: u8, quad: &TreeBasis) -> Result<Self, SolverError> {
        if max_level < CDV_MIN_LEVEL {
            return Err(SolverError::InvalidConfig {
                field: "max_level",
                value: max_level.to_string(),
                reason: "CDV needs max_level >= 2 (its coarsest level has 4 functions per axis)",
            });
        }
        if !(2..=MAXP).contains(&quad.k()) {
            return Err(SolverError::InvalidConfig {
                field: "basis",
                value: quad.kind().name(),
                reason: "the CDV quadrature basis must be M_p with 2 <= p <= 4",
            });
        }
        let mra = Cdv::new();
        let pk = quad.k();
        let g = wavelux_quadrature::GaussLegendre::new(8).map_err(|e| SolverError::Dependency {
            what: "quadrature",
            message: e.to_string(),
        })?;
        let (gx, gw) = g.unit();
        // Q[m][a] = ∫ ψ^{M_p}_m L̂_a over the unit cell (L̂ orthonormal Legendre).
        let mut q = [[0.0; MAXP]; MAXP];
        // conv[σ][a][b] = (1/√2) ∫_0^1 L̂_a((σ + y)/2) L̂_b(y) dy: level-(j+1) Legendre
        // products of child σ → level-j ones.
        let mut conv = [[[0.0; MAXP]; MAXP]; 2];
        for (x, w) in gx.iter().zip(&gw) {
            let mut v = [0.0; MAXP];
            quad.eval_1d(*x, &mut v[..pk]);
            let l = legendre(*x);
            for m in 0..pk {
                for a in 0..pk {
                    q[m][a] += w * v[m] * l[a];
                }
            }
            for (sigma, c) in conv.iter_mut().enumerate() {
                let lp = legendre((sigma as f64 + x) / 2.0);
                for a in 0..pk {
                    for b in 0..pk {
                        c[a][b] += w * lp[a] * l[b] / std::f64::consts::SQRT_2;
                    }
                }
            }
        }
        let to_mp = |leg: &[f64; MAXP]| -> [f64; MAXP] {
            let mut o = [0.0; MAXP];
            for m in 0..pk {
                o[m] = (0..pk).map(|a| q[m][a] * leg[a]).sum();
            }
            o
        };
        let mut levels = Vec::new();
        for j in CDV_MIN_LEVEL as u32..=max_level as u32 {
            let n = 1usize << j;
            let mut lv = Level1d {
                n,
                h: Vec::with_capacity(n),
                g: Vec::with_capacity(n),
                cells: Vec::with_capacity(n),
                proj: [Vec::with_capacity(n), Vec::with_capacity(n)],
                cell_int: Vec::with_capacity(n),
                integral: Vec::with_capacity(n),
                children: Vec::with_capacity(n),
                parents: Vec::new(),
            };
            let scale = 2f64.powf(-(j as f64) / 2.0);
            for k in 0..n {
                let hr = mra.scaling_row(j, k).map_err(mra_err)?;
                let gr = mra.wavelet_row(j, k).map_err(mra_err)?;
                lv.children.push((
                    hr.start.min(gr.start),
                    (hr.start + hr.coeffs.len()).max(gr.start + gr.coeffs.len()),
                ));
                lv.h.push((hr.start, hr.coeffs.to_vec()));
                lv.g.push((gr.start, gr.coeffs.to_vec()));
                let (a, b) = mra.support(j, k).map_err(mra_err)?;
                let c0 = (a * n as f64).round() as usize;
                let c1 = ((b * n as f64).round() as usize).min(n);
                let len = c1 - c0;
                lv.cells.push((c0, len));
                let mut leg = vec![[0.0; MAXP]; len];
                mra.legendre_products(j, k, pk, &mut |c, a, v| {
                    if c >= c0 && c < c1 {
                        leg[c - c0][a] += v;
                    }
                })
                .map_err(mra_err)?;
                // ψ_{j,k} = Σ_l g_l φ_{j+1,l}: products on level-(j+1) cells.
                let mut fine = vec![[0.0; MAXP]; 2 * n];
                for (i, &gc) in gr.coeffs.iter().enumerate() {
                    mra.legendre_products(j + 1, gr.start + i, pk, &mut |c, a, v| {
                        if c < 2 * n {
                            fine[c][a] += gc * v;
                        }
                    })
                    .map_err(mra_err)?;
                }
                let psi: Vec<[f64; MAXP]> = (c0..c1)
                    .map(|c| {
                        let mut u = [0.0; MAXP];
                        for (sigma, cm) in conv.iter().enumerate() {
                            let f = fine[2 * c + sigma];
                            for (a, ua) in u.iter_mut().enumerate().take(pk) {
                                *ua += (0..pk).map(|b| cm[a][b] * f[b]).sum::<f64>();
                            }
                        }
                        to_mp(&u)
                    })
                    .collect();
                lv.cell_int.push(leg.iter().map(|l| l[0] * scale).collect());
                lv.integral.push(leg.iter().map(|l| l[0] * scale).sum());
                lv.proj[0].push(leg.iter().map(to_mp).collect());
                lv.proj[1].push(psi);
            }
            levels.push(lv);
        }
        // Parents (inverse children ranges).
        for i in 1..levels.len() {
            let n = levels[i].n;
            let mut parents = vec![Vec::new(); n];
            for (k, &(lo, hi)) in levels[i - 1].children.iter().enumerate() {
                for p in parents.iter_mut().take(hi.min(n)).skip(lo) {
                    p.push(k);
                }
            }
            levels[i].parents = parents;
        }
        Ok(Self {
            mra,
            max_level,
            levels,
            pk,
        })
    }

    fn lv(&self, j: u8) -> &Level1d {
        &self.levels[(j - CDV_MIN_LEVEL) as usize]
    }

    /// Deepest level built.
    pub fn max_level(&self) -> u8 {
        self.max_level
    }

    /// Values `φ_{j,kx}(s) φ_{j,ky}(t)` summed against unit-square coefficients
    /// `coeffs[ky·2^j + kx]` at `(s, t) ∈ [0,1]²` (clamped).
    pub fn eval(&self, j: u8, coeffs: &[f64], s: f64, t: f64) -> f64 {
        let clamp = |x: f64| {
            if x.is_finite() {
                x.clamp(0.0, 1.0)
            } else {
                0.5
            }
        };
        let (s, t) = (clamp(s), clamp(t));
        let n = 1usize << j;
        let j = j as u32;
        let (Ok(rs), Ok(rt)) = (self.mra.nonzero_at(j, s), self.mra.nonzero_at(j, t)) else {
            return 0.0;
        };
        let vs: Vec<(usize, f64)> = rs
            .map(|k| (k, self.mra.eval_scaling(j, k, s).unwrap_or(0.0)))
            .collect();
        let mut sum = 0.0;
        for ky in rt {
            let vt = self.mra.eval_scaling(j, ky, t).unwrap_or(0.0);
            if vt == 0.0 {
                continue;
            }
            for &(kx, v) in &vs {
                sum += coeffs[ky * n + kx] * v * vt;
            }
        }
        sum
    }

    /// Unit-square coefficients of the constant 1 on level `j`: `∫φ_{j,kx} ∫φ_{j,ky}`.
    pub fn constant(&self, j: u8) -> Vec<f64> {
        let lv = self.lv(j);
        let mut v = vec![0.0; lv.n * lv.n];
        for ky in 0..lv.n {
            for kx in 0..lv.n {
                v[ky * lv.n + kx] = lv.integral[kx] * lv.integral[ky];
            }
        }
        v
    }

    /// Exact averages over the `4^j` cells of level `j` (index `cy·2^j + cx`) of the
    /// unit-square expansion `coeffs` on level `j`.
    pub fn cell_averages(&self, j: u8, coeffs: &[f64]) -> Vec<f64> {
        let lv = self.lv(j);
        let n = lv.n;
        // Along s first: row sums per (ky, cx).
        let mut tmp = vec![0.0; n * n];
        for ky in 0..n {
            for kx in 0..n {
                let c = coeffs[ky * n + kx];
                let (c0, _) = lv.cells[kx];
                for (i, v) in lv.cell_int[kx].iter().enumerate() {
                    tmp[ky * n + c0 + i] += c * v;
                }
            }
        }
        let mut out = vec![0.0; n * n];
        for ky in 0..n {
            let (c0, _) = lv.cells[ky];
            for (i, v) in lv.cell_int[ky].iter().enumerate() {
                for cx in 0..n {
                    out[(c0 + i) * n + cx] += v * tmp[ky * n + cx];
                }
            }
        }
        let inv = (n * n) as f64;
        out.iter_mut().for_each(|v| *v *= inv);
        out
    }

    /// Wavelet analysis of level-`j+1` coefficients (`4^{j+1}`, row-major in `t`) into
    /// the level-`j` vertices (`4^j × 4`, `[(ky·2^j + kx)·4 + a]`).
    pub fn analysis_2d(&self, j: u8, fine: &[f64], out: &mut [f64]) {
        let lv = self.lv(j);
        let n0 = lv.n;
        let n1 = 2 * n0;
        let mut cs = vec![0.0; n1 * n0];
        let mut ds = vec![0.0; n1 * n0];
        for ty in 0..n1 {
            analysis_1d(
                lv,
                &fine[ty * n1..][..n1],
                &mut cs[ty * n0..][..n0],
                &mut ds[ty * n0..][..n0],
            );
        }
        let mut col = vec![0.0; n1];
        let mut c = vec![0.0; n0];
        let mut d = vec![0.0; n0];
        for kx in 0..n0 {
            for (src, ac, ad) in [(&cs, 0, 2), (&ds, 1, 3)] {
                for (ty, v) in col.iter_mut().enumerate() {
                    *v = src[ty * n0 + kx];
                }
                analysis_1d(lv, &col, &mut c, &mut d);
                for ky in 0..n0 {
                    out[(ky * n0 + kx) * 4 + ac] = c[ky];
                    out[(ky * n0 + kx) * 4 + ad] = d[ky];
                }
            }
        }
    }

    /// The transpose of [`CdvBasis::analysis_2d`] (reconstruction), *added* to `fine`.
    pub fn synthesis_2d(&self, j: u8, vert: &[f64], fine: &mut [f64]) {
        let lv = self.lv(j);
        let n0 = lv.n;
        let n1 = 2 * n0;
        let mut cs = vec![0.0; n1 * n0];
        let mut ds = vec![0.0; n1 * n0];
        let mut col = vec![0.0; n1];
        let mut c = vec![0.0; n0];
        let mut d = vec![0.0; n0];
        for kx in 0..n0 {
            for (dst, ac, ad) in [(&mut cs, 0, 2), (&mut ds, 1, 3)] {
                for ky in 0..n0 {
                    c[ky] = vert[(ky * n0 + kx) * 4 + ac];
                    d[ky] = vert[(ky * n0 + kx) * 4 + ad];
                }
                col.iter_mut().for_each(|v| *v = 0.0);
                synthesis_1d(lv, &c, &d, &mut col);
                for (ty, v) in col.iter().enumerate() {
                    dst[ty * n0 + kx] = *v;
                }
            }
        }
        for ty in 0..n1 {
            synthesis_1d(
                lv,
                &cs[ty * n0..][..n0],
                &ds[ty * n0..][..n0],
                &mut fine[ty * n1..][..n1],
            );
        }
    }

    /// Coefficients of level `from` expressed on level `to` (synthesis with zero
    /// details upwards, analysis downwards; exact upwards, a projection downwards).
    pub fn change_level(&self, from: u8, to: u8, coeffs: &[f64]) -> Vec<f64> {
        let mut c = coeffs.to_vec();
        let mut j = from;
        while j < to {
            let n = 1usize << j;
            let mut vert = vec![0.0; n * n * 4];
            for (k, v) in c.iter().enumerate() {
                vert[4 * k] = *v;
            }
            let mut fine = vec![0.0; 4 * n * n];
            self.synthesis_2d(j, &vert, &mut fine);
            c = fine;
            j += 1;
        }
        while j > to {
            let n = 1usize << (j - 1);
            let mut vert = vec![0.0; n * n * 4];
            self.analysis_2d(j - 1, &c, &mut vert);
            c = (0..n * n).map(|k| vert[4 * k]).collect();
            j -= 1;
        }
        c
    }

    /// `M_p` projections of the four functions of vertex `(j, kx, ky)` on the cells of
    /// its support: `(first cell x, first cell y, nx, [cell (cy·nx + cx)][a·p² + m])`.
    fn vertex_proj(&self, j: u8, kx: usize, ky: usize) -> (usize, usize, usize, Vec<Vec<f64>>) {
        let lv = self.lv(j);
        let pk = self.pk;
        let n = pk * pk;
        let (cx0, nx) = lv.cells[kx];
        let (cy0, ny) = lv.cells[ky];
        let mut out = vec![vec![0.0; 4 * n]; nx * ny];
        for cy in 0..ny {
            for cx in 0..nx {
                let o = &mut out[cy * nx + cx];
                for a in 0..4 {
                    let (fx, fy) = (a % 2, a / 2);
                    let px = lv.proj[fx][kx][cx];
                    let py = lv.proj[fy][ky][cy];
                    for m in 0..n {
                        o[a * n + m] = px[m % pk] * py[m / pk];
                    }
                }
            }
        }
        (cx0, cy0, nx, out)
    }

    /// The square region that covers the support of vertex `(j, kx, ky)` (side
    /// `3·2^-j`, inside the unit square): the oracle's sampling domain.
    fn vertex_region(&self, patch: usize, j: u8, kx: usize, ky: usize) -> Region {
        let lv = self.lv(j);
        let w = 1.0 / lv.n as f64;
        let h = (3.0 * w).min(1.0);
        let s0 = (lv.cells[kx].0 as f64 * w).clamp(0.0, 1.0 - h);
        let t0 = (lv.cells[ky].0 as f64 * w).clamp(0.0, 1.0 - h);
        Region { patch, s0, t0, h }
    }
}

fn analysis_1d(lv: &Level1d, fine: &[f64], coarse: &mut [f64], detail: &mut [f64]) {
    for k in 0..lv.n {
        let (s, c) = &lv.h[k];
        coarse[k] = c.iter().zip(&fine[*s..]).map(|(a, b)| a * b).sum();
        let (s, c) = &lv.g[k];
        detail[k] = c.iter().zip(&fine[*s..]).map(|(a, b)| a * b).sum();
    }
}

fn synthesis_1d(lv: &Level1d, coarse: &[f64], detail: &[f64], fine: &mut [f64]) {
    for k in 0..lv.n {
        let (s, c) = &lv.h[k];
        for (f, w) in fine[*s..].iter_mut().zip(c) {
            *f += w * coarse[k];
        }
        let (s, c) = &lv.g[k];
        for (f, w) in fine[*s..].iter_mut().zip(c) {
            *f += w * detail[k];
        }
    }
}

/// A link between a receiver and an emitter vertex of the same level.
#[derive(Debug, Clone, PartialEq)]
pub struct CdvLink {
    /// Receiver patch.
    pub rp: u32,
    /// Level of both vertices.
    pub level: u8,
    /// Receiver vertex `ky·2^level + kx`.
    pub r: u32,
    /// Emitter patch.
    pub ep: u32,
    /// Emitter vertex.
    pub e: u32,
    /// `T_ab`, `[a_receiver·4 + b_emitter]` (`a = fy·2 + fx`, see the module docs);
    /// the `φφ–φφ` entry is zero except on level `j0`.
    pub block: [f64; 16],
}

/// Vertex pair key `[rp, rkx, rky, ep, ekx, eky]`.
type PairKey = [u32; 6];

const DROP: u8 = 0;
const ROOT: u8 = 1;
const REFINED: u8 = 2;

/// Top-down refinement over CDV vertex pairs (see the module docs). `brightness(patch,
/// region)` is the emitter's radiosity estimate (max channel, W/m²) for the brightness
/// oracle. Deterministic: candidates are sorted and deduplicated per level, and every
/// parallel map collects in order.
pub fn refine(
    ctx: &TransferCtx<'_>,
    basis: &CdvBasis,
    p: &RefineParams,
    brightness: &(dyn Fn(usize, &Region) -> f64 + Sync),
) -> (Vec<CdvLink>, RefineCounts) {
    let np = ctx.patches.len();
    let j0 = CDV_MIN_LEVEL;
    let n0 = 1u32 << j0;
    let mut counts = RefineCounts::default();
    let mut cands: Vec<PairKey> = Vec::new();
    for i in (0..np).filter(|&i| ctx.patches[i].reflects()) {
        for e in (0..np).filter(|&e| e != i && ctx.patches[e].can_emit()) {
            let root = |q: usize| Region {
                patch: q,
                s0: 0.0,
                t0: 0.0,
                h: 1.0,
            };
            if !ctx.facing(&root(i), &root(e)) {
                continue;
            }
            for ry in 0..n0 {
                for rx in 0..n0 {
                    for ey in 0..n0 {
                        for ex in 0..n0 {
                            cands.push([i as u32, rx, ry, e as u32, ex, ey]);
                        }
                    }
                }
            }
        }
    }
    // Sorted keys: `children` and `compute_links` group by receiver vertex.
    cands.sort_unstable();
    let mut links = Vec::new();
    let mut j = j0;
    while !cands.is_empty() {
        let lv = basis.lv(j);
        let can = j < p.max_level.min(basis.max_level);
        let child_ok = |q: u32| {
            ctx.patches[q as usize].support.area * 0.25f64.powi(j as i32 + 1) >= p.min_area
        };
        let status: Vec<(u8, bool)> = cands
            .par_iter()
            .map(|k| {
                let rr = basis.vertex_region(k[0] as usize, j, k[1] as usize, k[2] as usize);
                let er = basis.vertex_region(k[3] as usize, j, k[4] as usize, k[5] as usize);
                let keep = if j == j0 { ROOT } else { DROP };
                if !ctx.facing(&rr, &er) {
                    return (DROP, false);
                }
                if can && child_ok(k[0]) && child_ok(k[3]) {
                    let mut est = ctx.estimate(&rr, &er);
                    let rho = || {
                        ctx.patches[k[0] as usize]
                            .reflectance
                            .iter()
                            .fold(0.0f64, |a, &b| a.max(b))
                    };
                    est *= match p.oracle {
                        Oracle::Brightness => rho() * brightness(k[3] as usize, &er),
                        Oracle::Reflectance => rho(),
                        _ => 1.0,
                    };
                    if est > p.eps {
                        return (REFINED, true);
                    }
                    return (keep, true);
                }
                (keep, false)
            })
            .collect();
        let mut stored: Vec<(PairKey, u8)> = Vec::new();
        for (k, &(st, oracle)) in cands.iter().zip(&status) {
            counts.oracle_evals += oracle as u64;
            match st {
                REFINED => counts.refined += 1,
                ROOT => counts.unrefined_roots += 1,
                _ => continue,
            }
            stored.push((*k, st));
        }
        links.extend(compute_links(ctx, basis, j, &stored));
        // Children of the refined pairs, deduplicated, for the next level.
        let refined: Vec<PairKey> = stored
            .iter()
            .filter(|s| s.1 == REFINED)
            .map(|s| s.0)
            .collect();
        cands = if j + 1 < p.max_level.min(basis.max_level) {
            children(basis, j, lv, &refined)
        } else {
            Vec::new()
        };
        j += 1;
    }
    links.sort_by_key(|l| (l.rp, l.level, l.r, l.ep, l.e));
    (links, counts)
}

/// The deduplicated child pairs (level `j+1`) of refined pairs (sorted by key).
fn children(basis: &CdvBasis, j: u8, lv: &Level1d, refined: &[PairKey]) -> Vec<PairKey> {
    let fine = basis.lv(j + 1);
    // Child receivers.
    let mut recv: Vec<[u32; 3]> = Vec::new();
    let mut last: Option<[u32; 3]> = None;
    for k in refined {
        let r = [k[0], k[1], k[2]];
        if last == Some(r) {
            continue;
        }
        last = Some(r);
        let (x0, x1) = lv.children[k[1] as usize];
        let (y0, y1) = lv.children[k[2] as usize];
        for y in y0..y1 {
            for x in x0..x1 {
                recv.push([k[0], x as u32, y as u32]);
            }
        }
    }
    recv.sort_unstable();
    recv.dedup();
    let parts: Vec<Vec<PairKey>> = recv
        .par_iter()
        .map(|r| {
            let mut emit: Vec<[u32; 3]> = Vec::new();
            for &py in &fine.parents[r[2] as usize] {
                for &px in &fine.parents[r[1] as usize] {
                    let lo = [r[0], px as u32, py as u32, 0, 0, 0];
                    let start = refined.partition_point(|k| *k < lo);
                    for k in &refined[start..] {
                        if k[..3] != lo[..3] {
                            break;
                        }
                        emit.push([k[3], k[4], k[5]]);
                    }
                }
            }
            emit.sort_unstable();
            emit.dedup();
            let mut ce: Vec<[u32; 3]> = Vec::new();
            for e in &emit {
                let (x0, x1) = lv.children[e[1] as usize];
                let (y0, y1) = lv.children[e[2] as usize];
                for y in y0..y1 {
                    for x in x0..x1 {
                        ce.push([e[0], x as u32, y as u32]);
                    }
                }
            }
            ce.sort_unstable();
            ce.dedup();
            ce.iter()
                .map(|e| [r[0], r[1], r[2], e[0], e[1], e[2]])
                .collect()
        })
        .collect();
    parts.concat()
}

/// Blocks of the stored pairs of level `j` from shared `M_p` cell-pair blocks.
fn compute_links(
    ctx: &TransferCtx<'_>,
    basis: &CdvBasis,
    j: u8,
    stored: &[(PairKey, u8)],
) -> Vec<CdvLink> {
    let lv = basis.lv(j);
    let h = 1.0 / lv.n as f64;
    // Cell pairs: per receiver vertex, the union of its emitters' cells.
    let mut cell_pairs: Vec<PairKey> = Vec::new();
    let mut i = 0;
    while i < stored.len() {
        let r = &stored[i].0;
        let mut ecells: Vec<[u32; 3]> = Vec::new();
        let mut k = i;
        while k < stored.len() && stored[k].0[..3] == r[..3] {
            let e = &stored[k].0;
            let (x0, nx) = lv.cells[e[4] as usize];
            let (y0, ny) = lv.cells[e[5] as usize];
            for y in y0..y0 + ny {
                for x in x0..x0 + nx {
                    ecells.push([e[3], x as u32, y as u32]);
                }
            }
            k += 1;
        }
        ecells.sort_unstable();
        ecells.dedup();
        let (x0, nx) = lv.cells[r[1] as usize];
        let (y0, ny) = lv.cells[r[2] as usize];
        for y in y0..y0 + ny {
            for x in x0..x0 + nx {
                for c in &ecells {
                    cell_pairs.push([r[0], x as u32, y as u32, c[0], c[1], c[2]]);
                }
            }
        }
        i = k;
    }
    cell_pairs.par_sort_unstable();
    cell_pairs.dedup();
    let region = |p: u32, x: u32, y: u32| Region {
        patch: p as usize,
        s0: x as f64 * h,
        t0: y as f64 * h,
        h,
    };
    let blocks: Vec<Option<Vec<f64>>> = cell_pairs
        .par_iter()
        .map(|k| {
            let a = region(k[0], k[1], k[2]);
            let b = region(k[3], k[4], k[5]);
            ctx.facing(&a, &b).then(|| ctx.block(&a, &b))
        })
        .collect();
    stored
        .par_iter()
        .map(|(k, st)| {
            let (rx0, ry0, rnx, pr) = basis.vertex_proj(j, k[1] as usize, k[2] as usize);
            let (ex0, ey0, enx, pe) = basis.vertex_proj(j, k[4] as usize, k[5] as usize);
            let n = basis.pk * basis.pk;
            let mut mw = vec![0.0; 4 * n];
            let mut t = [0.0; 16];
            for (ci, ur) in pr.iter().enumerate() {
                let (cx, cy) = ((rx0 + ci % rnx) as u32, (ry0 + ci / rnx) as u32);
                for (cj, ue) in pe.iter().enumerate() {
                    let (dx, dy) = ((ex0 + cj % enx) as u32, (ey0 + cj / enx) as u32);
                    let key = [k[0], cx, cy, k[3], dx, dy];
                    let Ok(idx) = cell_pairs.binary_search(&key) else {
                        continue;
                    };
                    let Some(m) = &blocks[idx] else { continue };
                    // mw[m·4 + b] = Σ_m' M[m][m'] ue[b][m'].
                    for (mm, row) in m.chunks_exact(n).enumerate() {
                        for b in 0..4 {
                            let ub = &ue[b * n..][..n];
                            mw[mm * 4 + b] = row.iter().zip(ub).map(|(x, y)| x * y).sum();
                        }
                    }
                    for a in 0..4 {
                        let ua = &ur[a * n..][..n];
                        for b in 0..4 {
                            t[a * 4 + b] += (0..n).map(|mm| ua[mm] * mw[mm * 4 + b]).sum::<f64>();
                        }
                    }
                }
            }
            match *st {
                ROOT => {
                    // Unrefined root pair: only ⟨Φ, K Φ⟩.
                    for v in t.iter_mut().skip(1) {
                        *v = 0.0;
                    }
                }
                _ if j > CDV_MIN_LEVEL => t[0] = 0.0,
                _ => {}
            }
            let n = lv.n as u32;
            CdvLink {
                rp: k[0],
                level: j,
                r: k[2] * n + k[1],
                ep: k[3],
                e: k[5] * n + k[4],
                block: t,
            }
        })
        .collect()
}

/// The assembled CDV system: per-patch finest levels, links, reflectance and emission.
#[derive(Debug, Clone)]
pub struct CdvSystem {
    basis: Arc<CdvBasis>,
    /// Finest level `J_p` of each patch.
    pub levels: Vec<u8>,
    /// Links sorted by receiver patch.
    pub links: Vec<CdvLink>,
    recv_off: Vec<usize>,
    /// `(link index)` grouped by emitter patch (offsets `emit_off`).
    by_emitter: Vec<u32>,
    emit_off: Vec<usize>,
    /// Offsets of each patch's unknowns (`4^{J_p}` each).
    x_off: Vec<usize>,
    /// Per patch, offsets of the vertex arrays of levels `j0..=J_p` (4 values per vertex).
    node_off: Vec<Vec<usize>>,
    /// Reflectance per patch.
    pub rho: Vec<[f64; 3]>,
    /// Emission per patch (W/m²).
    pub emission: Vec<[f64; 3]>,
    /// Area per patch.
    pub area: Vec<f64>,
}

impl CdvSystem {
    /// Builds the system; `J_p` is one above the deepest refined link touching the
    /// patch (at least `j0`).
    pub fn new(basis: Arc<CdvBasis>, links: Vec<CdvLink>, patches: &[Patch]) -> Self {
        let np = patches.len();
        let mut levels = vec![CDV_MIN_LEVEL; np];
        for l in &links {
            if l.level > CDV_MIN_LEVEL || l.block[1..].iter().any(|&v| v != 0.0) {
                let lv = l.level + 1;
                levels[l.rp as usize] = levels[l.rp as usize].max(lv);
                levels[l.ep as usize] = levels[l.ep as usize].max(lv);
            }
        }
        let mut recv_off = vec![0usize; np + 1];
        let mut emit_off = vec![0usize; np + 1];
        for l in &links {
            recv_off[l.rp as usize + 1] += 1;
            emit_off[l.ep as usize + 1] += 1;
        }
        for p in 0..np {
            recv_off[p + 1] += recv_off[p];
            emit_off[p + 1] += emit_off[p];
        }
        let mut by_emitter: Vec<u32> = (0..links.len() as u32).collect();
        by_emitter.sort_by_key(|&i| links[i as usize].ep);
        let mut x_off = vec![0usize; np + 1];
        let mut node_off = Vec::with_capacity(np);
        for p in 0..np {
            x_off[p + 1] = x_off[p] + (1usize << (2 * levels[p]));
            let mut off = vec![0usize];
            for j in CDV_MIN_LEVEL..=levels[p] {
                let last = *off.last().unwrap_or(&0);
                off.push(last + 4 * (1usize << (2 * j)));
            }
            node_off.push(off);
        }
        Self {
            basis,
            levels,
            links,
            recv_off,
            by_emitter,
            emit_off,
            x_off,
            node_off,
            rho: patches.iter().map(|p| p.reflectance).collect(),
            emission: patches.iter().map(|p| p.emission).collect(),
            area: patches.iter().map(|p| p.support.area).collect(),
        }
    }

    /// Unknowns per channel (`Σ 4^{J_p}`).
    pub fn dim(&self) -> usize {
        *self.x_off.last().unwrap_or(&0)
    }

    /// Vertices over all patches and levels.
    pub fn vertex_count(&self) -> usize {
        self.node_off
            .iter()
            .map(|o| o.last().unwrap_or(&0) / 4)
            .sum()
    }

    /// The basis.
    pub fn basis(&self) -> &CdvBasis {
        &self.basis
    }

    /// Unknowns of patch `p` within a vector.
    pub fn patch_range(&self, p: usize) -> std::ops::Range<usize> {
        self.x_off[p]..self.x_off[p + 1]
    }

    fn vert(&self, p: usize, level: u8, k: u32) -> usize {
        self.node_off[p][(level - CDV_MIN_LEVEL) as usize] + 4 * k as usize
    }

    /// The emission vector `b` of a channel: `E √|S| ∫φ ∫φ` on `J_p`.
    pub fn emission(&self, ch: usize) -> Vec<f64> {
        let mut b = vec![0.0; self.dim()];
        for p in 0..self.levels.len() {
            let e = self.emission[p][ch];
            if e == 0.0 {
                continue;
            }
            let c = self.basis.constant(self.levels[p]);
            let s = e * self.area[p].sqrt();
            for (o, v) in b[self.patch_range(p)].iter_mut().zip(c) {
                *o = s * v;
            }
        }
        b
    }

    /// Pull: vertex coefficients of every level of patch `p` from its unknowns.
    fn pull_patch(&self, p: usize, x: &[f64]) -> Vec<f64> {
        let off = &self.node_off[p];
        let top = self.levels[p];
        let mut nodes = vec![0.0; *off.last().unwrap_or(&0)];
        let o = off[(top - CDV_MIN_LEVEL) as usize];
        for (k, v) in x.iter().enumerate() {
            nodes[o + 4 * k] = *v;
        }
        for j in (CDV_MIN_LEVEL..top).rev() {
            let of = off[(j + 1 - CDV_MIN_LEVEL) as usize];
            let nf = 1usize << (2 * (j + 1));
            let fine: Vec<f64> = (0..nf).map(|k| nodes[of + 4 * k]).collect();
            let oc = off[(j - CDV_MIN_LEVEL) as usize];
            self.basis.analysis_2d(j, &fine, &mut nodes[oc..of]);
        }
        nodes
    }

    /// Push: the finest-level coefficients of the vertex irradiance `g` of patch `p`.
    fn push_patch(&self, p: usize, mut g: Vec<f64>, y: &mut [f64]) {
        let off = &self.node_off[p];
        let top = self.levels[p];
        for j in CDV_MIN_LEVEL..top {
            let oc = off[(j - CDV_MIN_LEVEL) as usize];
            let of = off[(j + 1 - CDV_MIN_LEVEL) as usize];
            let nf = 1usize << (2 * (j + 1));
            let mut fine: Vec<f64> = (0..nf).map(|k| g[of + 4 * k]).collect();
            self.basis.synthesis_2d(j, &g[oc..of], &mut fine);
            for (k, v) in fine.iter().enumerate() {
                g[of + 4 * k] = *v;
            }
        }
        let o = off[(top - CDV_MIN_LEVEL) as usize];
        for (k, v) in y.iter_mut().enumerate() {
            *v = g[o + 4 * k];
        }
    }

    fn pull_all(&self, x: &[f64]) -> Vec<Vec<f64>> {
        (0..self.levels.len())
            .into_par_iter()
            .map(|p| self.pull_patch(p, &x[self.patch_range(p)]))
            .collect()
    }

    fn gather_patch(&self, p: usize, nodes: &[Vec<f64>]) -> Vec<f64> {
        let mut g = vec![0.0; *self.node_off[p].last().unwrap_or(&0)];
        for l in &self.links[self.recv_off[p]..self.recv_off[p + 1]] {
            let o = self.vert(p, l.level, l.r);
            let ep = l.ep as usize;
            let oe = self.vert(ep, l.level, l.e);
            let src = &nodes[ep][oe..oe + 4];
            for a in 0..4 {
                g[o + a] += (0..4).map(|b| l.block[a * 4 + b] * src[b]).sum::<f64>();
            }
        }
        g
    }

    /// Irradiance coefficients (finest level, no reflectance) for radiosity `x`.
    pub fn irradiance(&self, x: &[f64]) -> Vec<f64> {
        let nodes = self.pull_all(x);
        let mut y = vec![0.0; self.dim()];
        let parts: Vec<Vec<f64>> = (0..self.levels.len())
            .into_par_iter()
            .map(|p| {
                let mut yp = vec![0.0; self.x_off[p + 1] - self.x_off[p]];
                if self.recv_off[p + 1] > self.recv_off[p] {
                    self.push_patch(p, self.gather_patch(p, &nodes), &mut yp);
                }
                yp
            })
            .collect();
        for (p, yp) in parts.into_iter().enumerate() {
            y[self.patch_range(p)].copy_from_slice(&yp);
        }
        y
    }

    /// `y = K x` for channel `ch`.
    pub fn apply_k(&self, ch: usize, x: &[f64], y: &mut [f64]) {
        let h = self.irradiance(x);
        for p in 0..self.levels.len() {
            let r = self.rho[p][ch];
            for (o, v) in y[self.patch_range(p)]
                .iter_mut()
                .zip(&h[self.patch_range(p)])
            {
                *o = r * v;
            }
        }
    }

    /// `y = Kᵀ x` for channel `ch`.
    pub fn apply_kt(&self, ch: usize, x: &[f64], y: &mut [f64]) {
        let mut rx = x.to_vec();
        for p in 0..self.levels.len() {
            let r = self.rho[p][ch];
            rx[self.patch_range(p)].iter_mut().for_each(|v| *v *= r);
        }
        let nodes = self.pull_all(&rx);
        let parts: Vec<Vec<f64>> = (0..self.levels.len())
            .into_par_iter()
            .map(|p| {
                let mut yp = vec![0.0; self.x_off[p + 1] - self.x_off[p]];
                if self.emit_off[p + 1] > self.emit_off[p] {
                    let mut g = vec![0.0; *self.node_off[p].last().unwrap_or(&0)];
                    for &li in &self.by_emitter[self.emit_off[p]..self.emit_off[p + 1]] {
                        let l = &self.links[li as usize];
                        let o = self.vert(p, l.level, l.e);
                        let rp = l.rp as usize;
                        let or = self.vert(rp, l.level, l.r);
                        let src = &nodes[rp][or..or + 4];
                        for b in 0..4 {
                            g[o + b] += (0..4).map(|a| l.block[a * 4 + b] * src[a]).sum::<f64>();
                        }
                    }
                    self.push_patch(p, g, &mut yp);
                }
                yp
            })
            .collect();
        for (p, yp) in parts.into_iter().enumerate() {
            y[self.patch_range(p)].copy_from_slice(&yp);
        }
    }

    /// One Gauss–Seidel sweep over patches: each patch gathers with the current
    /// radiosity of all emitters, sets `B = E + ρH` and is re-analysed before the next
    /// patch (sequential, deterministic).
    pub fn gauss_seidel_sweep(&self, ch: usize, b: &[f64], x: &mut [f64]) {
        let mut nodes = self.pull_all(x);
        for p in 0..self.levels.len() {
            let rg = self.patch_range(p);
            let mut yp = vec![0.0; rg.len()];
            if self.recv_off[p + 1] > self.recv_off[p] {
                self.push_patch(p, self.gather_patch(p, &nodes), &mut yp);
            }
            let r = self.rho[p][ch];
            for (i, v) in yp.iter().enumerate() {
                x[rg.start + i] = b[rg.start + i] + r * v;
            }
            nodes[p] = self.pull_patch(p, &x[rg]);
        }
    }

    /// `K` of one channel as a [`wavelux_linear::Operator`].
    pub fn channel(&self, ch: usize) -> CdvChannel<'_> {
        CdvChannel { sys: self, ch }
    }
}

/// `K` of one colour channel of a [`CdvSystem`] (apply and transpose).
#[derive(Debug, Clone, Copy)]
pub struct CdvChannel<'a> {
    sys: &'a CdvSystem,
    ch: usize,
}

impl Operator for CdvChannel<'_> {
    fn dim(&self) -> usize {
        self.sys.dim()
    }

    fn apply(&self, x: &[f64], y: &mut [f64]) {
        self.sys.apply_k(self.ch, x, y);
    }

    fn apply_transpose(&self, x: &[f64], y: &mut [f64]) -> Result<(), Unsupported> {
        self.sys.apply_kt(self.ch, x, y);
        Ok(())
    }
}

/// A CDV radiosity expansion: per patch the finest level and the `L²(S)` coefficients
/// `c_k` of `B = Σ c_k φ_{J,kx}(s) φ_{J,ky}(t) / √|S|` per channel.
#[derive(Debug, Clone)]
pub struct CdvField {
    basis: Arc<CdvBasis>,
    /// Finest level per patch.
    pub levels: Vec<u8>,
    /// Offsets of the patches' coefficients.
    pub offsets: Vec<usize>,
    /// Coefficients per channel.
    pub coeffs: [Vec<f64>; 3],
    /// Patch areas.
    pub area: Vec<f64>,
}

impl CdvField {
    /// Radiosity (W/m², RGB) at `(s, t)` of a patch (exact expansion).
    ///
    /// # Panics
    /// If `patch` is out of range.
    pub fn radiosity(&self, patch: usize, s: f64, t: f64) -> [f64; 3] {
        let r = self.offsets[patch]..self.offsets[patch + 1];
        let inv = 1.0 / self.area[patch].sqrt();
        std::array::from_fn(|ch| {
            self.basis
                .eval(self.levels[patch], &self.coeffs[ch][r.clone()], s, t)
                * inv
        })
    }

    /// The MRA data.
    pub fn basis(&self) -> &CdvBasis {
        &self.basis
    }
}

/// Solves with the CDV basis (called by [`crate::solve_prepared`]).
///
/// # Errors
/// [`SolverError`] for invalid configuration and linear-solver failures.
pub fn solve(prep: &Prepared) -> Result<Solution, SolverError> {
    let cfg = &prep.config;
    let patches = &prep.patches.patches;
    // The expansion `B = Σ c φφ / √|S|` and the exact integrals assume every point of
    // the unit square is real and `dA = |S| ds dt`.
    for p in patches {
        let sup = &p.support;
        if !sup.is_planar() || !sup.is_equal_area() || sup.coverage(0.0, 0.0, 1.0) != Coverage::Full
        {
            return Err(SolverError::UnsupportedSurface {
                surface: format!("#{}", p.surface),
                kind: "CDV needs planar, unmasked, equal-area supports (virtual and curved \
                       supports are solved with the tree bases)"
                    .into(),
            });
        }
    }
    let ctx = prep.transfer()?;
    let basis = Arc::new(CdvBasis::new(cfg.max_level, &prep.basis)?);
    let stages = cfg.multigrid.map_or(1, |m| m.stages);
    let factor = cfg.multigrid.map_or(1.0, |m| m.factor);
    let mut stats = Statistics {
        time_setup: prep.setup_time(),
        ..Statistics::default()
    };
    let grey = prep.is_grey();
    let mut prev: Option<Solution> = None;
    for stage in 0..stages {
        let eps = cfg.eps * factor.powi((stages - 1 - stage) as i32);
        let params = prep.refine_params(eps);
        let t_ref = Instant::now();
        let bright = |p: usize, r: &Region| -> f64 {
            let maxc = |v: [f64; 3]| v.iter().fold(0.0f64, |a, &b| a.max(b));
            match &prev {
                Some(s) => {
                    // Largest of 3×3 point values of the previous solution over the
                    // region.
                    let mut best = 0.0f64;
                    for iy in 0..3 {
                        for ix in 0..3 {
                            let (u, v) = (
                                r.s0 + r.h * (ix as f64 + 0.5) / 3.0,
                                r.t0 + r.h * (iy as f64 + 0.5) / 3.0,
                            );
                            best = best.max(maxc(s.radiosity(p, u, v)));
                        }
                    }
                    best
                }
                None => maxc(patches[p].emission),
            }
        };
        let (links, counts) = refine(&ctx, &basis, &params, &bright);
        let system = CdvSystem::new(basis.clone(), links, patches);
        stats.time_refine += t_ref.elapsed();
        stats.refined_links += counts.refined;
        stats.oracle_evals += counts.oracle_evals;
        stats.nonstandard_links = counts.refined + counts.unrefined_roots;
        let t_sol = Instant::now();
        let mut leaf_b: [Vec<f64>; 3] = std::array::from_fn(|_| Vec::new());
        let mut conv = Vec::new();
        stats.iterations.clear();
        let channels = if grey { 1 } else { 3 };
        for ch in 0..channels {
            let x0 = prev.as_ref().and_then(|s| s.cdv_field()).map(|f| {
                let mut x = vec![0.0; system.dim()];
                for p in 0..patches.len() {
                    let c = &f.coeffs[ch][f.offsets[p]..f.offsets[p + 1]];
                    let v = basis.change_level(f.levels[p], system.levels[p], c);
                    x[system.patch_range(p)].copy_from_slice(&v);
                }
                x
            });
            let b = system.emission(ch);
            let (x, c) = crate::linear_solve(
                &system.channel(ch),
                &b,
                cfg.linear_method,
                cfg.max_iterations,
                cfg.tolerance,
                x0,
                None,
                &|b: &[f64], x: &mut [f64]| system.gauss_seidel_sweep(ch, b, x),
            )?;
            stats.iterations.push(c.iterations.len() - 1);
            conv.push(c);
            leaf_b[ch] = x;
        }
        if grey {
            leaf_b[1] = leaf_b[0].clone();
            leaf_b[2] = leaf_b[0].clone();
        }
        stats.time_solve += t_sol.elapsed();
        stats.stages = stage + 1;
        stats.elements = system.vertex_count();
        stats.leaves = system.dim();
        stats.links = system.links.len();
        stats.kernel_evals = ctx.kernel_evals.load(std::sync::atomic::Ordering::Relaxed);
        stats.rays = ctx.rays.load(std::sync::atomic::Ordering::Relaxed);
        stats.bytes =
            system.links.capacity() * std::mem::size_of::<CdvLink>() + 3 * system.dim() * 8;
        prev = Some(to_solution(prep, &system, leaf_b, stats.clone(), conv)?);
    }
    prev.ok_or_else(|| SolverError::InvalidScene("no stage ran".into()))
}

/// The documented conversion into a [`Solution`]: exact CDV point evaluation plus a
/// complete Haar quadtree (down to `J_p`) of exact cell averages of radiosity and
/// irradiance; energy from the exact integrals.
fn to_solution(
    prep: &Prepared,
    system: &CdvSystem,
    leaf_b: [Vec<f64>; 3],
    stats: Statistics,
    conv: Vec<Convergence>,
) -> Result<Solution, SolverError> {
    let patches = &prep.patches.patches;
    let np = patches.len();
    let basis = &system.basis;
    let mut fine_cells = Vec::new();
    for p in 0..np {
        let j = system.levels[p];
        let n = 1u32 << j;
        for iy in 0..n {
            for ix in 0..n {
                fine_cells.push(NodeKey {
                    level: j,
                    patch: p as u32,
                    iy,
                    ix,
                });
            }
        }
    }
    let h = Hierarchy::compile_with_nodes(1, np, &fine_cells, &[]);
    let haar = TreeBasis::new(BasisKind::Haar)?;
    let tree = System::new(h, &haar, patches);
    let leaf_h: [Vec<f64>; 3] = std::array::from_fn(|ch| system.irradiance(&leaf_b[ch]));
    // Cell averages per patch, as Haar leaf coefficients (average · √area).
    let to_leaves = |v: &[f64]| -> Vec<f64> {
        let mut per_patch: Vec<Vec<f64>> = Vec::with_capacity(np);
        for p in 0..np {
            let inv = 1.0 / system.area[p].sqrt();
            per_patch.push(
                basis
                    .cell_averages(system.levels[p], &v[system.patch_range(p)])
                    .into_iter()
                    .map(|a| a * inv)
                    .collect(),
            );
        }
        tree.h
            .leaves
            .iter()
            .map(|&i| {
                let k = tree.h.keys[i as usize];
                let n = 1usize << k.level;
                per_patch[k.patch as usize][k.iy as usize * n + k.ix as usize]
                    * tree.node_area[i as usize].sqrt()
            })
            .collect()
    };
    let mut node_b: [Vec<f64>; 3] = std::array::from_fn(|_| vec![0.0; tree.h.node_count()]);
    let mut tree_h: [Vec<f64>; 3] = std::array::from_fn(|_| Vec::new());
    let mut energy = Energy::default();
    for ch in 0..3 {
        let lb = to_leaves(&leaf_b[ch]);
        tree.pull_from_leaves(&lb, &mut node_b[ch]);
        tree_h[ch] = to_leaves(&leaf_h[ch]);
        let (mut sb, mut sh, mut abs, mut unshot) = (0.0, 0.0, 0.0, 0.0);
        for p in 0..np {
            let r = system.patch_range(p);
            let c = basis.constant(system.levels[p]);
            let s = system.area[p].sqrt();
            let ib: f64 = leaf_b[ch][r.clone()]
                .iter()
                .zip(&c)
                .map(|(a, b)| a * b)
                .sum::<f64>()
                * s;
            let ih: f64 = leaf_h[ch][r]
                .iter()
                .zip(&c)
                .map(|(a, b)| a * b)
                .sum::<f64>()
                * s;
            let rho = system.rho[p][ch];
            let e = system.emission[p][ch] * system.area[p];
            sb += ib;
            sh += ih;
            abs += (1.0 - rho) * ih;
            unshot += e + rho * ih - ib;
            energy.emitted[ch] += e;
        }
        energy.absorbed[ch] = abs;
        energy.operator_loss[ch] = sb - sh;
        energy.unshot[ch] = unshot;
    }
    let field = CdvField {
        basis: system.basis.clone(),
        levels: system.levels.clone(),
        offsets: system.x_off.clone(),
        coeffs: leaf_b,
        area: system.area.clone(),
    };
    let mut sol = Solution::from_cdv(
        patches.clone(),
        prep.patches.by_surface.clone(),
        tree,
        haar,
        node_b,
        tree_h,
        energy,
        stats,
        conv,
        Arc::new(field),
    );
    sol.measure_escape(prep);
    Ok(sol)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn basis(max: u8) -> CdvBasis {
        let m2 = TreeBasis::new(BasisKind::Multiwavelet(2)).unwrap();
        CdvBasis::new(max, &m2).unwrap()
    }

    /// The exact `M_p` projections agree with Gauss quadrature of point values, and
    /// the wavelets' projections keep both vanishing moments.
    #[test]
    fn projections_match_point_values_and_keep_moments() {
        let g = wavelux_quadrature::GaussLegendre::new(8).unwrap();
        let (gx, gw) = g.unit();
        for pk in [2usize, 3] {
            let mp = TreeBasis::new(BasisKind::Multiwavelet(pk)).unwrap();
            let b = CdvBasis::new(4, &mp).unwrap();
            for j in 2..4u8 {
                let lv = b.lv(j);
                let n = lv.n;
                let h = 1.0 / n as f64;
                for k in 0..n {
                    for f in 0..2 {
                        let (c0, len) = lv.cells[k];
                        let (mut m0, mut m1) = (0.0, 0.0);
                        for c in 0..len {
                            // Quadrature on 64 sub-intervals of the cell.
                            let mut q = [0.0; MAXP];
                            for sub in 0..64 {
                                for (x, w) in gx.iter().zip(&gw) {
                                    let u = (sub as f64 + x) / 64.0;
                                    let xs = ((c0 + c) as f64 + u) * h;
                                    let v = if f == 0 {
                                        b.mra.eval_scaling(j as u32, k, xs).unwrap()
                                    } else {
                                        b.mra.eval_wavelet(j as u32, k, xs).unwrap()
                                    };
                                    let mut e = [0.0; MAXP];
                                    mp.eval_1d(u, &mut e[..pk]);
                                    for m in 0..pk {
                                        q[m] += w * v * e[m] * h.sqrt() / 64.0;
                                    }
                                }
                            }
                            let p = lv.proj[f][k][c];
                            for m in 0..pk {
                                assert!(
                                    (p[m] - q[m]).abs() < 2e-3,
                                    "p {pk} j {j} k {k} f {f} cell {c}: {p:?} vs {q:?}"
                                );
                            }
                            // Moments ∫1 and ∫x of the projected function on the cell.
                            let x0 = (c0 + c) as f64 * h;
                            for (x, w) in gx.iter().zip(&gw) {
                                let mut e = [0.0; MAXP];
                                mp.eval_1d(*x, &mut e[..pk]);
                                let val: f64 = (0..pk).map(|m| p[m] * e[m]).sum::<f64>() / h.sqrt();
                                m0 += w * val * h;
                                m1 += w * val * (x0 + h * x) * h;
                            }
                        }
                        if f == 1 {
                            assert!(m0.abs() < 1e-12 && m1.abs() < 1e-12, "{m0} {m1}");
                        }
                    }
                }
            }
        }
    }

    /// Linear functions are reproduced on every level and have no wavelet
    /// coefficients; analysis and synthesis are mutual inverses.
    #[test]
    fn linear_functions_have_no_details() {
        let b = basis(5);
        let j = 5u8;
        let n = 1usize << j;
        // Project p(s, t) = 1 + 2s − 3t + 0.5 st on level 5 via the exact cell moments
        // (p is bilinear on each cell: its M2 coefficients are exact).
        let lv = b.lv(j);
        let mut c = vec![0.0; n * n];
        // 1D moments ∫φ_k and ∫x φ_k from the M2 projections.
        let m2 = TreeBasis::new(BasisKind::Multiwavelet(2)).unwrap();
        let mut e = [0.0; 2];
        m2.eval_1d(1.0, &mut e);
        let h = 1.0 / n as f64;
        let mom = |k: usize| -> (f64, f64) {
            let (c0, _) = lv.cells[k];
            let mut a = 0.0;
            let mut bx = 0.0;
            for (i, p) in lv.proj[0][k].iter().enumerate() {
                // ψ0 = 1, ψ1 = ±√3(2u−1): ∫ψ0 = 1, ∫u ψ0 = 1/2, ∫ u ψ1 = ±√3/6.
                let sign = e[1].signum();
                let x0 = (c0 + i) as f64 * h;
                a += p[0] * h.sqrt();
                bx += h.sqrt() * (p[0] * (x0 + 0.5 * h) + p[1] * sign * 3f64.sqrt() / 6.0 * h);
            }
            (a, bx)
        };
        let m: Vec<(f64, f64)> = (0..n).map(mom).collect();
        for ky in 0..n {
            for kx in 0..n {
                let (ax, bx) = m[kx];
                let (ay, by) = m[ky];
                c[ky * n + kx] = ax * ay + 2.0 * bx * ay - 3.0 * ax * by + 0.5 * bx * by;
            }
        }
        for (s, t) in [(0.3, 0.7), (0.01, 0.5), (0.99, 0.98), (0.5, 0.5)] {
            let v = b.eval(j, &c, s, t);
            let exact = 1.0 + 2.0 * s - 3.0 * t + 0.5 * s * t;
            assert!((v - exact).abs() < 1e-3, "{v} vs {exact}");
        }
        let mut cur = c.clone();
        for jj in (2..j).rev() {
            let nn = 1usize << jj;
            let mut vert = vec![0.0; nn * nn * 4];
            b.analysis_2d(jj, &cur, &mut vert);
            let max_detail = (0..nn * nn)
                .flat_map(|k| vert[4 * k + 1..4 * k + 4].to_vec())
                .fold(0.0f64, |a, v| a.max(v.abs()));
            assert!(max_detail < 1e-12, "level {jj}: detail {max_detail}");
            let mut back = vec![0.0; 4 * nn * nn];
            b.synthesis_2d(jj, &vert, &mut back);
            for (x, y) in back.iter().zip(&cur) {
                assert!((x - y).abs() < 1e-12);
            }
            cur = (0..nn * nn).map(|k| vert[4 * k]).collect();
        }
        // Cell averages of the constant are exactly 1.
        for v in b.cell_averages(3, &b.constant(3)) {
            assert!((v - 1.0).abs() < 1e-12);
        }
    }
}
