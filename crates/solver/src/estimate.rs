//! A-posteriori error estimate of a gathered solution, per element, per link and for
//! the whole radiosity function.
//!
//! The Galerkin solution `B_h` of `B = E + K B` (Ziegler §2.1, `K = ρ ∫ G V ·`)
//! leaves the residual `r = E + K B_h − B_h` of the *continuous* equation; the error
//! `e = B − B_h` solves `e = r + K e`. We evaluate `r` at `p × p` Gauss points of
//! every leaf, with `K B_h` computed by a finer quadrature than the transfer blocks:
//! for every link `(R, E)` covering the leaf, the emitter's radiosity (its pulled
//! coefficients, the same function the link transports) is integrated point by point
//! with a `q × q` Gauss rule on pieces of `E` split until each piece is well separated
//! from the point (`dist ≥ near · radius`). Visibility: none where the link's
//! transfer block saw every ray visible (or no transport where it saw every ray
//! blocked); on partly visible links one ray per receiver point and cell of an
//! `N × N` grid on the emitter node, shared by the samples in that cell
//! (`EstimateOptions::vis_cells`, by default `N = 3`), or with `vis_cells` 0 one
//! shadow ray per point pair (on the Cornell box ~120 M of the default solve's ~160 M
//! rays, against ~62 M with 3 × 3 cells); and none
//! where no blocker can meet the shaft between the points'
//! cell and the piece ([`crate::shaft`]: those rays would all be visible). The
//! links of the hierarchy partition every receiver–emitter pair once, so their sum is
//! the whole irradiance. The transported part `y = K e = K r + K y` is approximated
//! on the discrete space, `y ≈ (I − K_h)⁻¹ K_h P r` (`P` the projection onto the leaf
//! bases, one linear solve with the existing links), and `e ≈ r + y`.
//!
//! The difference between a link's fine transport and what its block delivers,
//! `Δ_l(x) = ∫_E G V B_E dA − Σ_a (T B_E)_a φ_a(x)`, integrated as `∫_R ρ |Δ_l| dA`,
//! is the link's *indicator* `η_l` (W): the error that refining this link would remove
//! (kernel variation over the pair, receiver projection, the block's quadrature and
//! its visibility sampling). This is the "next level the oracle would add" measured
//! rather than bounded; [`crate::target`] refines the links with the largest `η_l`.
//!
//! On links whose transport is not smooth over the pair (near or partly visible
//! pairs, whose leaves are evaluated in detail) and whose emitter node is split, the
//! fine gather integrates the emitter's own finer radiosity, projected on each of its
//! pieces (the node's descendants' pulled coefficients, or the covering leaf's
//! polynomial), not the node's pulled coefficients that the link transports: the
//! difference is the link's averaging of its emitter, which only such a link can get
//! wrong by much (where the kernel is smooth it is second order). On the Cornell glTF
//! (one node per face) the pulled coefficients made the estimate blind to the block
//! faces' bias from the floor next to them: short_block.3's mean was 5.1 % too bright
//! in blue while the estimate said 0.2 %; the same solution estimated with the
//! emitters' leaves says 5.1 % (session 28, docs/performance.md). Those links'
//! transport depends on the solution and is not cached.
//!
//! What the estimate does not see: the error of representing the emitter's radiosity
//! by its pulled coefficients on `E` on the other links (the finer leaves under `E`
//! are averaged, as the link averages them), transport that no link carries (pairs dropped as not facing,
//! where the kernel vanishes), and errors of the fine quadrature itself (shadow
//! boundaries sampled by `q²` rays per point and piece, or resolved to one emitter
//! cell per point). Norms are over real points
//! (VirtualMesh §4: virtual points of masked supports neither count nor emit) in true
//! area; the relative error is `Σ_c ∫|e_c| / Σ_c ∫|B_h,c − E_c|` (relative to the
//! reflected radiosity, as the CLI's Monte Carlo check).

use std::collections::{HashMap, HashSet};
use std::time::{Duration, Instant};

use glam::DVec3;
use rayon::prelude::*;
use wavelux_quadrature::GaussLegendre;

use crate::error::SolverError;
use crate::hierarchy::NodeKey;
use crate::mask::Coverage;
use crate::solution::Solution;
use crate::support::Patch;
use crate::transfer::{LinkVisibility, Region, TransferCtx, Visibility, kernel, weight_in};
use crate::{LinearMethod, linear_solve};

/// Options of [`estimate`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EstimateOptions {
    /// Gauss points per axis and leaf at which the residual is evaluated (`0`: `max(k
    /// + 1, 3)` for a basis with `k` functions per axis; else `1..=8`).
    pub receiver_points: usize,
    /// Gauss points per axis on each emitter piece (`0`: 3; else `1..=8`).
    pub emitter_points: usize,
    /// Separation at which an emitter piece is integrated without splitting:
    /// `dist(point, piece centre) ≥ near · piece radius` (`≥ 1`).
    pub near: f64,
    /// Deepest split of an emitter piece around a point (`≤ 10`).
    pub max_depth: u32,
    /// Extra splits of an emitter piece whose shadow rays disagree (a shadow
    /// boundary crosses it), each quartering the piece (`≤ 6`). The default, 1,
    /// moves the estimate by at most 1.5 % of itself against depth 3 on the Cornell
    /// box (M3, level 2) and on Ziegler's occluded scene (Haar level 2, M2 level 1),
    /// with 4–5× fewer rays (each level multiplies a boundary piece's rays by ~4).
    pub vis_depth: u32,
    /// Whether to add the transported part `(I − K_h)⁻¹ K_h P r` (else `e ≈ r`).
    pub propagate: bool,
    /// Visibility of the fine gather on links whose block saw both visible and
    /// blocked rays (`≤ 8`). `0`: one shadow ray per receiver point and emitter
    /// sample (every sample of every piece, near-field and shadow-boundary splits
    /// included). `N ≥ 1`: per receiver point, at most one ray to the centre of each
    /// of the `N × N` equal cells of the link's emitter node, shared by every emitter
    /// sample in that cell, so a point costs at most `N²` rays however finely the
    /// emitter is split around it. See [`DEFAULT_VIS_CELLS`].
    pub vis_cells: usize,
}

/// The default [`EstimateOptions::vis_cells`]: `3`, one ray per receiver point and
/// cell of a 3 × 3 grid on the link's emitter node. Measured on the built-in Cornell
/// box (default `--target-error 2%`, release, one thread, texel L1 against the
/// 32 768-walk reference, docs/performance.md), session 26, cells 1 / 2 / 3 / traced
/// (`0`): estimate rays 6.5 / 27.3 / 62.0 / 119.8 M, texel L1 0.948 / 1.010 / 1.051
/// / 1.097 %, CPU 59.2 / 63.4 / 68.4 / 73.8 s. One ray per point and link is not
/// honest everywhere: on Ziegler's occluded scene (M2, level 1) it estimates 18.8 %
/// against a measured 7.98 % (`tests/estimate.rs`), because a coarse emitter node is
/// then seen or hidden whole; 3 × 3 cells stay within the factor 2 there (6.85 %).
pub const DEFAULT_VIS_CELLS: usize = 3;

impl Default for EstimateOptions {
    fn default() -> Self {
        Self {
            receiver_points: 0,
            emitter_points: 0,
            near: 1.2,
            max_depth: 4,
            vis_depth: 1,
            propagate: true,
            vis_cells: DEFAULT_VIS_CELLS,
        }
    }
}

impl EstimateOptions {
    /// Checks the documented ranges.
    ///
    /// # Errors
    /// [`SolverError::InvalidConfig`] naming the first bad field.
    pub fn validate(&self) -> Result<(), SolverError> {
        let bad = |field, value: String, reason| SolverError::InvalidConfig {
            field,
            value,
            reason,
        };
        if self.receiver_points > 8 {
            return Err(bad(
                "estimate.receiver_points",
                self.receiver_points.to_string(),
                "must be in 0..=8",
            ));
        }
        if self.emitter_points > 8 {
            return Err(bad(
                "estimate.emitter_points",
                self.emitter_points.to_string(),
                "must be in 0..=8",
            ));
        }
        if !(self.near.is_finite() && self.near >= 1.0) {
            return Err(bad(
                "estimate.near",
                self.near.to_string(),
                "must be finite and >= 1",
            ));
        }
        if self.vis_depth > 6 {
            return Err(bad(
                "estimate.vis_depth",
                self.vis_depth.to_string(),
                "must be <= 6",
            ));
        }
        if self.vis_cells > MAX_VIS_CELLS {
            return Err(bad(
                "estimate.vis_cells",
                self.vis_cells.to_string(),
                "must be <= 8",
            ));
        }
        if self.max_depth > 10 {
            return Err(bad(
                "estimate.max_depth",
                self.max_depth.to_string(),
                "must be <= 10",
            ));
        }
        Ok(())
    }
}

/// The largest [`EstimateOptions::vis_cells`].
const MAX_VIS_CELLS: usize = 8;

/// The rays a receiver point has shot to the cells of a link's emitter
/// ([`EstimateOptions::vis_cells`]): `0` not yet shot, `1` visible, `2` blocked.
type CellMemo = [u8; MAX_VIS_CELLS * MAX_VIS_CELLS];

/// The estimate of [`estimate`].
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ErrorEstimate {
    /// `Σ_c ∫|e_c| dA / Σ_c ∫|B_h,c − E_c| dA` over real points of every patch
    /// (dimensionless; `0` when nothing is reflected).
    pub relative_l1: f64,
    /// `∫|e_c| dA` per channel (W).
    pub error_l1: [f64; 3],
    /// `∫|r_c| dA` per channel (W): the local part (the residual alone).
    pub residual_l1: [f64; 3],
    /// `∫|B_h,c − E_c| dA` per channel (W), the normaliser.
    pub reflected_l1: [f64; 3],
    /// `∫_leaf Σ_c |e_c| dA` per leaf, in the order of `Hierarchy::leaves` (W).
    pub leaf_error: Vec<f64>,
    /// `∫_leaf e_c dA` per leaf and channel (signed, W): the estimated error of the
    /// leaf's mean times its real area, so that sums over the leaves of a face
    /// estimate the error of the face's mean radiosity (`B − B_h`: positive when the
    /// solution is too low).
    pub leaf_mean_error: Vec<[f64; 3]>,
    /// `∫_leaf Σ_c |B_h,c − E_c| dA` per leaf (W): the leaf's part of the normaliser,
    /// so that per-face relative errors are `Σ leaf_error / Σ leaf_reflected`.
    pub leaf_reflected: Vec<f64>,
    /// `Σ_c ∫|e_c| dA` per patch (W): the sum of its leaves' [`Self::leaf_error`].
    pub patch_error: Vec<f64>,
    /// `Σ_c ∫|B_h,c − E_c| dA` per patch (W): the patch's part of the normaliser.
    pub patch_reflected: Vec<f64>,
    /// Real area of every patch (m²) as the residual points integrate it.
    pub patch_area: Vec<f64>,
    /// `Σ_c E_c · area` per patch (W): its emitted part, which
    /// [`Self::patch_relative`] adds to the normaliser (an emitter's error is seen
    /// against the radiosity it shows).
    pub patch_emitted: Vec<f64>,
    /// Indicator `η_l = ∫_R ρ Σ_c |Δ_l,c| dA` per link, in the receiver order of the
    /// compiled hierarchy (W).
    pub link_error: Vec<f64>,
    /// Kernel evaluations of the fine quadrature.
    pub kernel_evals: u64,
    /// Shadow rays of the fine quadrature.
    pub rays: u64,
    /// Residual points evaluated.
    pub points: u64,
    /// Links whose transport was evaluated at every leaf point under the receiver
    /// (partly visible or near pairs); the others are interpolated from the
    /// receiver's own points.
    pub detailed_links: u64,
    /// Links whose fine transport came from the [`EstimateCache`] of an earlier call
    /// (no kernel samples or rays this time).
    pub reused_links: u64,
    /// Links evaluated without shadow rays because every ray of their transfer block
    /// agreed ([`LinkVisibility::Visible`]: integrated unoccluded;
    /// [`LinkVisibility::Blocked`]: no transport).
    pub unshadowed_links: u64,
    /// Wall time.
    pub time: Duration,
}

/// Faces darker than this fraction of the scene's mean reflected radiosity are judged
/// relative to it instead of their own (a face that receives almost nothing has no
/// meaningful relative error): [`ErrorEstimate::patch_relative`].
pub const DARK_FACE: f64 = 0.01;

impl ErrorEstimate {
    /// The normaliser of every patch's relative error (W):
    /// `max(patch_reflected + patch_emitted, DARK_FACE · D̄ · area)`, the radiosity
    /// the face shows (an emitter's error is seen against its emission too), with
    /// `D̄` the scene's mean reflected radiosity (`Σ reflected / Σ area` over patches
    /// that reflect anything) as a floor for faces that receive almost nothing.
    pub fn patch_normaliser(&self) -> Vec<f64> {
        let (mut d, mut a) = (0.0, 0.0);
        for (r, ar) in self.patch_reflected.iter().zip(&self.patch_area) {
            if *r > 0.0 {
                d += r;
                a += ar;
            }
        }
        let mean = if a > 0.0 { d / a } else { 0.0 };
        (0..self.patch_error.len())
            .map(|p| {
                (self.patch_reflected[p] + self.patch_emitted[p])
                    .max(DARK_FACE * mean * self.patch_area[p])
            })
            .collect()
    }

    /// Estimated relative L1 error of every patch (face side): `patch_error` over
    /// [`Self::patch_normaliser`]; `0` for a patch with no points or no error.
    pub fn patch_relative(&self) -> Vec<f64> {
        self.patch_error
            .iter()
            .zip(self.patch_normaliser())
            .map(|(e, den)| if *e > 0.0 && den > 0.0 { e / den } else { 0.0 })
            .collect()
    }

    /// The patch with the largest [`Self::patch_relative`] error and that error
    /// (`None` without patches).
    pub fn worst_patch(&self) -> Option<(usize, f64)> {
        self.patch_relative()
            .into_iter()
            .enumerate()
            .max_by(|a, b| a.1.total_cmp(&b.1).then(b.0.cmp(&a.0)))
    }
}

/// One residual point of a leaf.
#[derive(Debug, Clone, Copy)]
struct Point {
    s: f64,
    t: f64,
    x: DVec3,
    n: DVec3,
    /// ṽ (visibility point, VirtualMesh §4.1).
    v: DVec3,
    /// Galerkin weight (parameter measure: Gauss weight × leaf area).
    w: f64,
    /// True-area weight of the real part (Jacobian × real fraction of its cell).
    wr: f64,
}

/// Counters of the fine quadrature.
#[derive(Debug, Clone, Copy, Default)]
struct Tally {
    evals: u64,
    rays: u64,
    /// Shadow rays that found the pair visible / blocked.
    visible: u64,
    blocked: u64,
}

impl Tally {
    fn add(&mut self, o: &Tally) {
        self.evals += o.evals;
        self.rays += o.rays;
        self.visible += o.visible;
        self.blocked += o.blocked;
    }
}

/// A link's fine transport moments at its receiver's residual points: independent of
/// the solution, so they are kept between the rounds of [`crate::target`].
#[derive(Debug, Clone)]
struct Moments {
    /// `∫_E G V φ_b dA` per point (the `p × p` Gauss points of `R`) and emitter
    /// function `b`: `[point · n + b]`; empty when the pair is blocked (all zero).
    m: Vec<f64>,
    /// Whether the leaves under `R` need their own evaluation (the pair is partly
    /// visible or near, so the transport is not smooth over `R`) instead of the
    /// interpolation of the link's own values.
    detailed: bool,
}

/// Fine transport moments kept between calls of [`estimate_cached`] (the rounds of
/// [`crate::target`]): per link `(receiver, emitter)` at the receiver's residual
/// points, and per `(link, leaf)` at the points of leaves under the receiver where
/// the link is evaluated in detail. They depend only on the geometry, the basis and
/// the [`EstimateOptions`], never on the solution, so a link that survives a round
/// unchanged costs no kernel samples or rays in the next. A cache belongs to one
/// transfer context (scene, accelerator, basis); it empties itself when the options
/// or the basis change, and keeps only what the last call used.
#[derive(Debug, Clone, Default)]
pub struct EstimateCache {
    /// `(receiver points, emitter points, near bits, max_depth, vis_depth,
    /// vis_cells, n)`.
    key: Option<(usize, usize, u64, u32, u32, usize, usize)>,
    links: HashMap<(NodeKey, NodeKey), Moments>,
    leaves: HashMap<(NodeKey, NodeKey, NodeKey), Vec<f64>>,
}

impl EstimateCache {
    /// An empty cache.
    pub fn new() -> Self {
        Self::default()
    }

    /// Links held.
    pub fn len(&self) -> usize {
        self.links.len()
    }

    /// Whether nothing is held.
    pub fn is_empty(&self) -> bool {
        self.links.is_empty()
    }
}

/// A Gauss rule on `[0, 1]`: `(points, weights, cumulative weights)`.
type Rule = (Vec<f64>, Vec<f64>, Vec<f64>);

/// The `q`-point Gauss rule on `[0, 1]`.
fn rule(q: usize) -> Result<Rule, SolverError> {
    let g = GaussLegendre::new(q).map_err(|e| SolverError::Dependency {
        what: "quadrature",
        message: e.to_string(),
    })?;
    let (x, w) = g.unit();
    let mut c = vec![0.0; q + 1];
    for i in 0..q {
        c[i + 1] = c[i] + w[i];
    }
    c[q] = 1.0;
    Ok((x, w, c))
}

/// The residual points of a leaf region.
fn leaf_points(p: &Patch, r: &Region, g: &Rule) -> Vec<Point> {
    let q = g.0.len();
    let a = p.support.area * r.h * r.h;
    let mut pts = Vec::with_capacity(q * q);
    for jt in 0..q {
        for js in 0..q {
            let (s, t) = (r.s0 + r.h * g.0[js], r.t0 + r.h * g.0[jt]);
            let (x, n) = p.support.point_normal(s, t);
            let v = if p.support.mask.is_some() {
                p.support.visibility_point(s, t)
            } else {
                x
            };
            pts.push(Point {
                s,
                t,
                x,
                n,
                v,
                w: g.1[js] * g.1[jt] * a,
                wr: weight_in(p, r, (&g.0, &g.1, &g.2), js, jt),
            });
        }
    }
    pts
}

/// Context of the fine point-to-region gather.
struct Fine<'a> {
    ctx: &'a TransferCtx<'a>,
    rule: Rule,
    near: f64,
    max_depth: u32,
    vis_depth: u32,
    vis_cells: usize,
    vis: bool,
}

/// What [`Fine::gather`] integrates against on each emitter piece.
#[derive(Clone, Copy)]
enum Emit<'s> {
    /// Moments `∫ G V φ_b dA` against the functions `φ_b` of the link's emitter node
    /// (independent of the solution; the link's pulled coefficients make them its
    /// transport).
    Moments,
    /// The transport `∫ G V B_h dA` per channel with the solution's radiosity on each
    /// piece projected onto the piece's own functions (`P_piece B_h`: the pulled
    /// coefficients of the node at the piece, or the covering leaf's polynomial below
    /// the leaves): the radiosity the link's emitter averages, seen as finely as the
    /// pieces resolve it. `node` is the deepest node of `sol`'s hierarchy containing
    /// the piece.
    Values { sol: &'s Solution, node: u32 },
}

impl Emit<'_> {
    /// The emitter function on child `c` of the piece `es` ([`Region::split`] order,
    /// that of the hierarchy's children).
    fn child(self, es: &Region, c: usize) -> Self {
        match self {
            Emit::Values { sol, node } => {
                let h = &sol.system.h;
                let ch = h.children[node as usize];
                let at_node = h.keys[node as usize].region().h == es.h;
                if at_node && ch[0] != u32::MAX {
                    Emit::Values { sol, node: ch[c] }
                } else {
                    self
                }
            }
            Emit::Moments => self,
        }
    }
}

impl Fine<'_> {
    /// `∫_piece G V φ_b dA` for a receiver point and every emitter function `b` of the
    /// node's orthonormal basis `φ = ψ/√A_node`, accumulated into `out[b]`; shadow
    /// rays only when `vis` and the shaft between the point's cell `rc` and the piece
    /// meets one of the candidate blockers `cands` ([`crate::shaft`]: a culled piece's
    /// rays would all be visible, and are counted so), one per sample or one per
    /// emitter cell kept in `memo` ([`EstimateOptions::vis_cells`]).
    #[allow(clippy::too_many_arguments)]
    fn gather(
        &self,
        pt: &Point,
        pr: &Patch,
        pe: &Patch,
        en: &Region,
        es: &Region,
        emit: Emit<'_>,
        shaft: (&Region, Option<&[u32]>),
        depth: u32,
        vdepth: u32,
        vis: bool,
        out: &mut [f64],
        tally: &mut Tally,
        memo: &mut CellMemo,
    ) {
        let cov = if pe.support.mask.is_some() {
            pe.support.coverage(es.s0, es.t0, es.h)
        } else {
            Coverage::Full
        };
        if cov == Coverage::Empty {
            return;
        }
        let (c, rad) = pe.support.bounding_sphere(es.s0, es.t0, es.h);
        let near = (pt.x - c).length() < self.near * rad;
        let split_partial = cov == Coverage::Partial && depth < 3;
        if (near || split_partial) && depth < self.max_depth {
            for (c, b) in es.split().iter().enumerate() {
                self.gather(
                    pt,
                    pr,
                    pe,
                    en,
                    b,
                    emit.child(es, c),
                    shaft,
                    depth + 1,
                    vdepth,
                    vis,
                    out,
                    tally,
                    memo,
                );
            }
            return;
        }
        let basis = self.ctx.basis();
        let n = basis.n();
        let (gx, gw, gc) = (&self.rule.0, &self.rule.1, &self.rule.2);
        let q = gx.len();
        let inv = 1.0 / (pe.support.area * en.h * en.h).sqrt();
        let mut phi = [0.0; 16];
        let mut acc = [0.0; 16];
        let (mut seen, mut hidden) = (false, false);
        let open = vis && self.ctx.shaft_open(shaft.0, es, shaft.1);
        for kt in 0..q {
            for ks in 0..q {
                let w = weight_in(pe, es, (gx, gw, gc), ks, kt);
                if w == 0.0 {
                    continue;
                }
                let (u, v) = (es.s0 + es.h * gx[ks], es.t0 + es.h * gx[kt]);
                let (y, ny) = pe.support.point_normal(u, v);
                tally.evals += 1;
                let g = kernel(pt.x, pt.n, y, ny);
                if g == 0.0 {
                    continue;
                }
                if vis && !open {
                    tally.visible += 1;
                    seen = true;
                } else if vis {
                    let seen_here = if self.vis_cells == 0 {
                        let vy = if pe.support.mask.is_some() {
                            pe.support.visibility_point(u, v)
                        } else {
                            y
                        };
                        self.ctx.visible(pt.v, pr, vy, pe, &mut tally.rays)
                    } else {
                        self.cell_visible(pt, pr, pe, en, (u, v), memo, &mut tally.rays)
                    };
                    if !seen_here {
                        tally.blocked += 1;
                        hidden = true;
                        continue;
                    }
                    tally.visible += 1;
                    seen = true;
                }
                match emit {
                    Emit::Moments => {
                        let f = w * g * inv;
                        basis.eval((u - en.s0) / en.h, (v - en.t0) / en.h, &mut phi[..n]);
                        for b in 0..n {
                            acc[b] += f * phi[b];
                        }
                    }
                    Emit::Values { sol, node } => {
                        let sys = &sol.system;
                        let fr = sys.h.keys[node as usize].region();
                        let f = w * g / sys.node_area[node as usize].sqrt();
                        basis.eval((u - fr.s0) / fr.h, (v - fr.t0) / fr.h, &mut phi[..n]);
                        for (c, a) in acc.iter_mut().take(3).enumerate() {
                            let coef = &sol.node_b[c][node as usize * n..][..n];
                            *a += f * coef.iter().zip(&phi[..n]).map(|(x, y)| x * y).sum::<f64>();
                        }
                    }
                }
            }
        }
        if seen && hidden && vdepth < self.vis_depth {
            // A shadow boundary crosses the piece: its q² rays resolve the visible
            // part only to ~1/q²; integrate the quarters instead.
            for (c, b) in es.split().iter().enumerate() {
                self.gather(
                    pt,
                    pr,
                    pe,
                    en,
                    b,
                    emit.child(es, c),
                    shaft,
                    depth + 1,
                    vdepth + 1,
                    vis,
                    out,
                    tally,
                    memo,
                );
            }
            return;
        }
        out.iter_mut().zip(&acc).for_each(|(o, a)| *o += a);
    }

    /// Whether the point sees the emitter sample at parameters `uv` of the link's
    /// emitter node `en`, answered by the ray to the centre of the sample's cell
    /// among `vis_cells × vis_cells` equal cells of `en` (its visibility point on a
    /// masked support), shot once per point and cell (`memo`).
    #[allow(clippy::too_many_arguments)]
    fn cell_visible(
        &self,
        pt: &Point,
        pr: &Patch,
        pe: &Patch,
        en: &Region,
        uv: (f64, f64),
        memo: &mut CellMemo,
        rays: &mut u64,
    ) -> bool {
        let g = self.vis_cells;
        let cells = g as f64;
        // Negative offsets (rounding at the node's edge) saturate to cell 0.
        let cell = |x: f64, x0: f64| (((x - x0) / en.h * cells) as usize).min(g - 1);
        let (i, j) = (cell(uv.0, en.s0), cell(uv.1, en.t0));
        let slot = &mut memo[j * g + i];
        if *slot == 0 {
            let cu = en.s0 + en.h * (i as f64 + 0.5) / cells;
            let cv = en.t0 + en.h * (j as f64 + 0.5) / cells;
            let vy = if pe.support.mask.is_some() {
                pe.support.visibility_point(cu, cv)
            } else {
                pe.support.point_normal(cu, cv).0
            };
            *slot = if self.ctx.visible(pt.v, pr, vy, pe, rays) {
                1
            } else {
                2
            };
        }
        *slot == 1
    }
}

/// Estimates the error of a gathered tree-basis solution (see the module docs).
/// `ctx` must be the transfer context the solution's links were computed with (same
/// patches, accelerator and basis).
///
/// # Errors
/// [`SolverError::InvalidConfig`] for bad options or a CDV solution (no links to
/// estimate from), [`SolverError::Dependency`] if a rule cannot be built,
/// [`SolverError::Linear`] if the propagation solve fails.
pub fn estimate(
    ctx: &TransferCtx<'_>,
    sol: &Solution,
    opts: &EstimateOptions,
) -> Result<ErrorEstimate, SolverError> {
    estimate_cached(ctx, sol, opts, &mut EstimateCache::new())
}

/// [`estimate`] keeping the solution-independent fine transport of every link in
/// `cache` and reusing what an earlier call left there (same transfer context). The
/// result is the same with a full, an empty or a foreign-option cache.
///
/// # Errors
/// As [`estimate`].
pub fn estimate_cached(
    ctx: &TransferCtx<'_>,
    sol: &Solution,
    opts: &EstimateOptions,
    cache: &mut EstimateCache,
) -> Result<ErrorEstimate, SolverError> {
    let t0 = Instant::now();
    let (fine, recv_rule) = prepare(ctx, sol, opts, cache)?;
    let h = &sol.system.h;
    let patches = &sol.patches;
    let pts: Vec<Vec<Point>> = h
        .leaves
        .par_iter()
        .map(|&i| {
            let key = h.keys[i as usize];
            leaf_points(&patches[key.patch as usize], &key.region(), &recv_rule)
        })
        .collect();
    let mut est = ErrorEstimate {
        link_error: vec![0.0; h.link_count()],
        leaf_error: vec![0.0; h.leaves.len()],
        leaf_mean_error: vec![[0.0; 3]; h.leaves.len()],
        leaf_reflected: vec![0.0; h.leaves.len()],
        patch_error: vec![0.0; patches.len()],
        patch_reflected: vec![0.0; patches.len()],
        patch_area: vec![0.0; patches.len()],
        patch_emitted: vec![0.0; patches.len()],
        ..ErrorEstimate::default()
    };
    let hf = fine_irradiance(&fine, sol, &pts, &recv_rule, cache, &mut est);
    let (resid, bh, proj) = residuals(sol, &pts, &hf);
    let y = if opts.propagate {
        propagated(sol, &proj)?
    } else {
        std::array::from_fn(|_| vec![0.0; sol.system.dim()])
    };
    accumulate(sol, &pts, (&resid, &bh, &y), &mut est);
    let num: f64 = est.error_l1.iter().sum();
    let den: f64 = est.reflected_l1.iter().sum();
    est.relative_l1 = if den > 0.0 { num / den } else { 0.0 };
    est.time = t0.elapsed();
    Ok(est)
}

/// Checks the options and the solution, empties `cache` when its options differ, and
/// returns the fine gather's context and the receiver rule.
fn prepare<'a>(
    ctx: &'a TransferCtx<'a>,
    sol: &Solution,
    opts: &EstimateOptions,
    cache: &mut EstimateCache,
) -> Result<(Fine<'a>, Rule), SolverError> {
    opts.validate()?;
    if sol.cdv_field().is_some() {
        return Err(SolverError::InvalidConfig {
            field: "basis",
            value: "CDV".into(),
            reason: "the a-posteriori estimate needs a tree-basis solution with links",
        });
    }
    let basis = sol.basis();
    let n = basis.n();
    if ctx.basis().n() != n {
        return Err(SolverError::InvalidConfig {
            field: "basis",
            value: basis.kind().name(),
            reason: "the transfer context has a different basis than the solution",
        });
    }
    let p = if opts.receiver_points == 0 {
        (basis.k() + 1).max(3)
    } else {
        opts.receiver_points
    };
    let q = if opts.emitter_points == 0 {
        3
    } else {
        opts.emitter_points
    };
    let key = (
        p,
        q,
        opts.near.to_bits(),
        opts.max_depth,
        opts.vis_depth,
        opts.vis_cells,
        n,
    );
    if cache.key != Some(key) {
        *cache = EstimateCache {
            key: Some(key),
            ..EstimateCache::default()
        };
    }
    let fine = Fine {
        ctx,
        rule: rule(q)?,
        near: opts.near,
        max_depth: opts.max_depth,
        vis_depth: opts.vis_depth,
        vis_cells: opts.vis_cells,
        vis: ctx.visibility_mode() != Visibility::Off,
    };
    Ok((fine, rule(p)?))
}

/// What the fine gather of [`fine_irradiance`] used of the cache, and its counters.
#[derive(Default)]
struct Gathered {
    tally: Tally,
    links: HashSet<(NodeKey, NodeKey)>,
    leaves: HashSet<(NodeKey, NodeKey, NodeKey)>,
}

/// The fine irradiance `H_fine` per channel at every residual point (`pts` per leaf),
/// patch by patch (bounded memory), from the cached or freshly computed moments of
/// every link; fills the links' indicators and the work counters of `est` and keeps
/// in `cache` only what this call used.
fn fine_irradiance(
    fine: &Fine<'_>,
    sol: &Solution,
    pts: &[Vec<Point>],
    recv_rule: &Rule,
    cache: &mut EstimateCache,
    est: &mut ErrorEstimate,
) -> Vec<Vec<[f64; 3]>> {
    let h = &sol.system.h;
    let patches = &sol.patches;
    let mut hf: Vec<Vec<[f64; 3]>> = pts.iter().map(|v| vec![[0.0; 3]; v.len()]).collect();
    let mut by_patch: Vec<Vec<u32>> = vec![Vec::new(); patches.len()];
    for (i, key) in h.keys.iter().enumerate() {
        by_patch[key.patch as usize].push(i as u32);
    }
    let mut used = Gathered::default();
    for (pi, nodes) in by_patch.iter().enumerate() {
        if patches[pi].reflects() {
            let links: Vec<usize> = nodes
                .iter()
                .flat_map(|&r| h.recv_offsets[r as usize]..h.recv_offsets[r as usize + 1])
                .collect();
            let detailed = gather_links(fine, sol, &links, pts, recv_rule, cache, est, &mut hf);
            gather_detailed(fine, sol, &detailed, pts, cache, &mut used, &mut hf);
            used.links.extend(links.iter().map(|&l| link_key(h, l)));
        }
    }
    cache.links.retain(|k, _| used.links.contains(k));
    cache.leaves.retain(|k, _| used.leaves.contains(k));
    est.kernel_evals += used.tally.evals;
    est.rays += used.tally.rays;
    hf
}

/// The `(receiver, emitter)` key of link `l`.
fn link_key(h: &crate::hierarchy::Hierarchy, l: usize) -> (NodeKey, NodeKey) {
    (
        h.keys[h.link_receiver[l] as usize],
        h.keys[h.link_emitter[l] as usize],
    )
}

/// The links' fine transport at their receivers' points (moments computed where the
/// cache lacks them), added to `hf` at the leaves it covers: at the receiver's own
/// points, interpolated at the points of the leaves under it, or (returned as
/// `(link, leaf)` pairs) to be evaluated there in detail. Fills the links'
/// indicators and counters in `est`.
#[allow(clippy::too_many_arguments)]
fn gather_links(
    fine: &Fine<'_>,
    sol: &Solution,
    links: &[usize],
    pts: &[Vec<Point>],
    recv_rule: &Rule,
    cache: &mut EstimateCache,
    est: &mut ErrorEstimate,
    hf: &mut [Vec<[f64; 3]>],
) -> Vec<(usize, usize)> {
    let h = &sol.system.h;
    let missing: Vec<usize> = links
        .iter()
        .copied()
        .filter(|&l| !cache.links.contains_key(&link_key(h, l)))
        .collect();
    est.reused_links += (links.len() - missing.len()) as u64;
    let fresh: Vec<(Moments, Tally)> = missing
        .par_iter()
        .map(|&l| link_moments(fine, sol, l, recv_rule))
        .collect();
    for (&l, (m, t)) in missing.iter().zip(fresh) {
        est.kernel_evals += t.evals;
        est.rays += t.rays;
        est.unshadowed_links += u64::from(matches!(
            h.link_seen[l],
            LinkVisibility::Visible | LinkVisibility::Blocked
        ));
        cache.links.insert(link_key(h, l), m);
    }
    // Detailed links with a split emitter: their transport with the emitter's finer
    // radiosity ([`Emit::Values`]), which depends on the solution (not cached).
    let finer: Vec<Option<(Vec<[f64; 3]>, Tally)>> = links
        .par_iter()
        .map(|&l| {
            let mom = &cache.links[&link_key(h, l)];
            (mom.detailed && split_emitter(h, l)).then(|| {
                let rk = h.keys[h.link_receiver[l] as usize];
                let rp = leaf_points(&sol.patches[rk.patch as usize], &rk.region(), recv_rule);
                let (v, t) = fine_at(fine, sol, l, &rk.region(), &rp, true);
                (rgb(&v), t)
            })
        })
        .collect();
    let mut detailed: Vec<(usize, usize)> = Vec::new();
    for (&l, finer) in links.iter().zip(finer) {
        let mom = &cache.links[&link_key(h, l)];
        let f = match finer {
            Some((f, t)) => {
                est.kernel_evals += t.evals;
                est.rays += t.rays;
                f
            }
            None => transport(sol, l, &mom.m, recv_rule.0.len().pow(2)),
        };
        let eta = indicator(sol, l, &f, recv_rule);
        est.link_error[l] = eta;
        est.detailed_links += u64::from(mom.detailed);
        let r = h.link_receiver[l] as usize;
        let rreg = h.keys[r].region();
        for leaf in leaves_under(h, r) {
            let li = h.leaf_of[leaf] as usize;
            if leaf == r {
                for (acc, f) in hf[li].iter_mut().zip(&f) {
                    (0..3).for_each(|c| acc[c] += f[c]);
                }
            } else if mom.detailed {
                detailed.push((l, li));
            } else {
                for (j, pt) in pts[li].iter().enumerate() {
                    let v = interpolate(&recv_rule.0, &rreg, pt.s, pt.t, &f);
                    (0..3).for_each(|c| hf[li][j][c] += v[c]);
                }
            }
        }
    }
    detailed
}

/// The fine transport of the `(link, leaf)` pairs evaluated in detail, at the leaf's
/// own points (moments computed where the cache lacks them), added to `hf`.
fn gather_detailed(
    fine: &Fine<'_>,
    sol: &Solution,
    detailed: &[(usize, usize)],
    pts: &[Vec<Point>],
    cache: &mut EstimateCache,
    used: &mut Gathered,
    hf: &mut [Vec<[f64; 3]>],
) {
    let h = &sol.system.h;
    let leaf_key = |l: usize, li: usize| {
        let (r, e) = link_key(h, l);
        (r, e, h.keys[h.leaves[li] as usize])
    };
    let missing: Vec<(usize, usize)> = detailed
        .iter()
        .copied()
        .filter(|&(l, li)| !split_emitter(h, l) && !cache.leaves.contains_key(&leaf_key(l, li)))
        .collect();
    // Pairs under a split emitter: the transport of its finer radiosity (not cached).
    let finer: Vec<Option<(Vec<[f64; 3]>, Tally)>> = detailed
        .par_iter()
        .map(|&(l, li)| {
            split_emitter(h, l).then(|| {
                let leaf = h.keys[h.leaves[li] as usize].region();
                let (v, t) = fine_at(fine, sol, l, &leaf, &pts[li], true);
                (rgb(&v), t)
            })
        })
        .collect();
    let extra: Vec<(Vec<f64>, Tally)> = missing
        .par_iter()
        .map(|&(l, li)| {
            let leaf = h.keys[h.leaves[li] as usize].region();
            fine_at(fine, sol, l, &leaf, &pts[li], false)
        })
        .collect();
    for (&(l, li), (m, t)) in missing.iter().zip(extra) {
        used.tally.add(&t);
        cache.leaves.insert(leaf_key(l, li), m);
    }
    for (&(l, li), finer) in detailed.iter().zip(finer) {
        let v = match finer {
            Some((v, t)) => {
                used.tally.add(&t);
                v
            }
            None => {
                let k = leaf_key(l, li);
                used.leaves.insert(k);
                transport(sol, l, &cache.leaves[&k], pts[li].len())
            }
        };
        for (acc, f) in hf[li].iter_mut().zip(&v) {
            (0..3).for_each(|c| acc[c] += f[c]);
        }
    }
}

/// Per leaf and point, the residual `r = E + ρ H_fine − B_h` and `B_h` per channel,
/// and the residual's projection `P r` onto the leaf bases per channel.
#[allow(clippy::type_complexity)]
fn residuals(
    sol: &Solution,
    pts: &[Vec<Point>],
    hf: &[Vec<[f64; 3]>],
) -> (Vec<Vec<[f64; 3]>>, Vec<Vec<[f64; 3]>>, [Vec<f64>; 3]) {
    let sys = &sol.system;
    let h = &sys.h;
    let basis = sol.basis();
    let n = basis.n();
    let mut resid: Vec<Vec<[f64; 3]>> = Vec::with_capacity(h.leaves.len());
    let mut bh: Vec<Vec<[f64; 3]>> = Vec::with_capacity(h.leaves.len());
    let mut proj: [Vec<f64>; 3] = std::array::from_fn(|_| vec![0.0; sys.dim()]);
    let mut psi = [0.0; 16];
    for (l, &leaf) in h.leaves.iter().enumerate() {
        let key = h.keys[leaf as usize];
        let patch = &sol.patches[key.patch as usize];
        let reg = key.region();
        let inv = 1.0 / sys.node_area[leaf as usize].sqrt();
        let mut rl = Vec::with_capacity(pts[l].len());
        let mut bl = Vec::with_capacity(pts[l].len());
        for (j, pt) in pts[l].iter().enumerate() {
            basis.eval(
                (pt.s - reg.s0) / reg.h,
                (pt.t - reg.t0) / reg.h,
                &mut psi[..n],
            );
            let b: [f64; 3] = std::array::from_fn(|c| {
                (0..n)
                    .map(|a| sol.node_b[c][leaf as usize * n + a] * psi[a])
                    .sum::<f64>()
                    * inv
            });
            let r: [f64; 3] = std::array::from_fn(|c| {
                patch.emission[c] + patch.reflectance[c] * hf[l][j][c] - b[c]
            });
            for c in 0..3 {
                for a in 0..n {
                    proj[c][l * n + a] += pt.w * r[c] * psi[a] * inv;
                }
            }
            rl.push(r);
            bl.push(b);
        }
        resid.push(rl);
        bh.push(bl);
    }
    (resid, bh, proj)
}

/// The transported part `y = (I − K_h)⁻¹ K_h P r` per channel (one channel solved
/// when the scene and `P r` are grey).
fn propagated(sol: &Solution, proj: &[Vec<f64>; 3]) -> Result<[Vec<f64>; 3], SolverError> {
    let sys = &sol.system;
    let mut y: [Vec<f64>; 3] = std::array::from_fn(|_| vec![0.0; sys.dim()]);
    if sys.dim() == 0 {
        return Ok(y);
    }
    let grey = sol.patches.iter().all(|p| {
        p.reflectance.iter().all(|&r| r == p.reflectance[0])
            && p.emission.iter().all(|&e| e == p.emission[0])
    }) && proj[1] == proj[0]
        && proj[2] == proj[0];
    let channels = if grey { 1 } else { 3 };
    for c in 0..channels {
        let mut kr = vec![0.0; sys.dim()];
        sys.apply_k(c, &proj[c], &mut kr);
        let (x, _) = linear_solve(
            &sys.channel(c),
            &kr,
            LinearMethod::Gmres { restart: 30 },
            60,
            1e-4,
            None,
            None,
            &|b: &[f64], x: &mut [f64]| sys.gauss_seidel_sweep(c, b, x),
        )?;
        y[c] = x;
    }
    if grey {
        y[1] = y[0].clone();
        y[2] = y[0].clone();
    }
    Ok(y)
}

/// Adds `e = r + y` at every real residual point to the norms of `est` (scene,
/// leaves, patches) with the normaliser `|B_h − E|`; `parts` is `(r, B_h, y)`.
#[allow(clippy::type_complexity)]
fn accumulate(
    sol: &Solution,
    pts: &[Vec<Point>],
    parts: (&[Vec<[f64; 3]>], &[Vec<[f64; 3]>], &[Vec<f64>; 3]),
    est: &mut ErrorEstimate,
) {
    let (resid, bh, y) = parts;
    let sys = &sol.system;
    let h = &sys.h;
    let basis = sol.basis();
    let n = basis.n();
    let mut psi = [0.0; 16];
    for (l, &leaf) in h.leaves.iter().enumerate() {
        let key = h.keys[leaf as usize];
        let patch = &sol.patches[key.patch as usize];
        let reg = key.region();
        let inv = 1.0 / sys.node_area[leaf as usize].sqrt();
        for (j, pt) in pts[l].iter().enumerate() {
            if pt.wr == 0.0 {
                continue;
            }
            basis.eval(
                (pt.s - reg.s0) / reg.h,
                (pt.t - reg.t0) / reg.h,
                &mut psi[..n],
            );
            for c in 0..3 {
                let yv: f64 = (0..n).map(|a| y[c][l * n + a] * psi[a]).sum::<f64>() * inv;
                let r = resid[l][j][c];
                let e = r + yv;
                let d = (bh[l][j][c] - patch.emission[c]).abs();
                est.error_l1[c] += pt.wr * e.abs();
                est.residual_l1[c] += pt.wr * r.abs();
                est.reflected_l1[c] += pt.wr * d;
                est.leaf_error[l] += pt.wr * e.abs();
                est.leaf_mean_error[l][c] += pt.wr * e;
                est.leaf_reflected[l] += pt.wr * d;
            }
            est.points += 1;
            est.patch_area[key.patch as usize] += pt.wr;
            est.patch_emitted[key.patch as usize] += pt.wr * patch.emission.iter().sum::<f64>();
        }
        est.patch_error[key.patch as usize] += est.leaf_error[l];
        est.patch_reflected[key.patch as usize] += est.leaf_reflected[l];
    }
}

/// The link's emitter coefficients per channel and `T B_E` per channel.
fn link_parts(sol: &Solution, l: usize) -> ([&[f64]; 3], [[f64; 16]; 3]) {
    let h = &sol.system.h;
    let n = h.n;
    let e = h.link_emitter[l] as usize;
    let coef: [&[f64]; 3] = std::array::from_fn(|c| &sol.node_b[c][e * n..][..n]);
    let blk = &h.blocks[l * n * n..][..n * n];
    let tb = std::array::from_fn(|c| {
        let mut v = [0.0; 16];
        for a in 0..n {
            v[a] = (0..n).map(|b| blk[a * n + b] * coef[c][b]).sum();
        }
        v
    });
    (coef, tb)
}

/// The transport `∫_E G V B_E dA` per point and channel of link `l` from its moments
/// (`m[point · n + b]`; empty: blocked, zero).
fn transport(sol: &Solution, l: usize, m: &[f64], points: usize) -> Vec<[f64; 3]> {
    if m.is_empty() {
        return vec![[0.0; 3]; points];
    }
    let n = sol.system.h.n;
    let (coef, _) = link_parts(sol, l);
    m.chunks_exact(n)
        .map(|mp| std::array::from_fn(|c| (0..n).map(|b| coef[c][b] * mp[b]).sum()))
        .collect()
}

/// Whether link `l`'s fine transport is integrated with shadow rays, and whether it
/// carries any: a link whose block saw every ray unblocked is integrated unoccluded,
/// one whose block saw every ray blocked carries nothing (see [`LinkVisibility`]),
/// nor does a closure link (its block is a row-sum correction, not a transfer).
fn link_rays(fine: &Fine<'_>, sol: &Solution, l: usize) -> Option<bool> {
    match sol.system.h.link_seen[l] {
        LinkVisibility::Blocked | LinkVisibility::Closure => None,
        LinkVisibility::Visible => Some(false),
        _ => Some(fine.vis),
    }
}

/// Fine transport moments of link `l` at the given points of the cell `cell` (its
/// receiver or a leaf under it): `[point · n + b]`, empty when the link carries
/// nothing.
fn fine_at(
    fine: &Fine<'_>,
    sol: &Solution,
    l: usize,
    cell: &Region,
    pts: &[Point],
    values: bool,
) -> (Vec<f64>, Tally) {
    let h = &sol.system.h;
    let (n, emit) = if values {
        (
            3,
            Emit::Values {
                sol,
                node: h.link_emitter[l],
            },
        )
    } else {
        (h.n, Emit::Moments)
    };
    let mut tally = Tally::default();
    let Some(vis) = link_rays(fine, sol, l) else {
        return (Vec::new(), tally);
    };
    let pr = &sol.patches[h.keys[h.link_receiver[l] as usize].patch as usize];
    let ek = h.keys[h.link_emitter[l] as usize];
    let pe = &sol.patches[ek.patch as usize];
    let ereg = ek.region();
    let mut m = vec![0.0; pts.len() * n];
    // The blockers that may meet the shaft between the points' cell and the emitter.
    let cands = if vis {
        fine.ctx.shaft_candidates(cell, &ereg, None)
    } else {
        None
    };
    for (pt, out) in pts.iter().zip(m.chunks_exact_mut(n)) {
        let mut memo: CellMemo = [0; MAX_VIS_CELLS * MAX_VIS_CELLS];
        fine.gather(
            pt,
            pr,
            pe,
            &ereg,
            &ereg,
            emit,
            (cell, cands.as_deref()),
            0,
            0,
            vis,
            out,
            &mut tally,
            &mut memo,
        );
    }
    (m, tally)
}

/// The fine transport moments of link `l` at the residual points of its receiver
/// `R`, and whether the leaves under `R` need their own evaluation.
fn link_moments(fine: &Fine<'_>, sol: &Solution, l: usize, rule: &Rule) -> (Moments, Tally) {
    let h = &sol.system.h;
    let rk = h.keys[h.link_receiver[l] as usize];
    let rreg = rk.region();
    let pr = &sol.patches[rk.patch as usize];
    let ek = h.keys[h.link_emitter[l] as usize];
    let pe = &sol.patches[ek.patch as usize];
    let pts = leaf_points(pr, &rreg, rule);
    let (m, tally) = fine_at(fine, sol, l, &rreg, &pts, false);
    let (cr, rr) = pr.support.bounding_sphere(rreg.s0, rreg.t0, rreg.h);
    let ereg = ek.region();
    let (ce, re) = pe.support.bounding_sphere(ereg.s0, ereg.t0, ereg.h);
    let near = (cr - ce).length() < rr + re;
    let partial = tally.visible > 0 && tally.blocked > 0;
    let detailed = !m.is_empty() && (near || partial);
    (Moments { m, detailed }, tally)
}

/// The indicator `η_l = ∫_R ρ Σ_c |Δ_c|` of link `l` from its fine transport `f` at
/// its receiver's residual points.
fn indicator(sol: &Solution, l: usize, f: &[[f64; 3]], rule: &Rule) -> f64 {
    let sys = &sol.system;
    let h = &sys.h;
    let n = h.n;
    let basis = sol.basis();
    let r = h.link_receiver[l] as usize;
    let rreg = h.keys[r].region();
    let pr = &sol.patches[h.keys[r].patch as usize];
    let pts = leaf_points(pr, &rreg, rule);
    let (_, tb) = link_parts(sol, l);
    let rinv = 1.0 / sys.node_area[r].sqrt();
    let mut psi = [0.0; 16];
    let mut eta = 0.0;
    for (pt, fv) in pts.iter().zip(f) {
        basis.eval(
            (pt.s - rreg.s0) / rreg.h,
            (pt.t - rreg.t0) / rreg.h,
            &mut psi[..n],
        );
        for c in 0..3 {
            let d: f64 = (0..n).map(|a| tb[c][a] * psi[a]).sum::<f64>() * rinv;
            eta += pt.wr * pr.reflectance[c] * (fv[c] - d).abs();
        }
    }
    eta
}

/// Whether link `l`'s emitter node is split in the solution's hierarchy (its
/// radiosity is finer than the node's own functions).
fn split_emitter(h: &crate::hierarchy::Hierarchy, l: usize) -> bool {
    h.children[h.link_emitter[l] as usize][0] != u32::MAX
}

/// Per-channel triples from a flat `[point · 3 + c]` vector.
fn rgb(v: &[f64]) -> Vec<[f64; 3]> {
    v.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()
}

/// Node indices of the leaves in the subtree of `node`.
fn leaves_under(h: &crate::hierarchy::Hierarchy, node: usize) -> Vec<usize> {
    let mut out = Vec::new();
    let mut stack = vec![node];
    while let Some(i) = stack.pop() {
        let ch = h.children[i];
        if ch[0] == u32::MAX {
            out.push(i);
        } else {
            stack.extend(ch.iter().rev().map(|&c| c as usize));
        }
    }
    out
}

/// Lagrange interpolation at `(s, t)` of values `f[jt·p + js]` given at the tensor
/// nodes `x` of the region `r`.
fn interpolate(x: &[f64], r: &Region, s: f64, t: f64, f: &[[f64; 3]]) -> [f64; 3] {
    let p = x.len();
    let lag = |u: f64, out: &mut [f64]| {
        for i in 0..p {
            let mut v = 1.0;
            for j in 0..p {
                if j != i {
                    v *= (u - x[j]) / (x[i] - x[j]);
                }
            }
            out[i] = v;
        }
    };
    let (mut ls, mut lt) = ([0.0; 8], [0.0; 8]);
    lag((s - r.s0) / r.h, &mut ls[..p]);
    lag((t - r.t0) / r.h, &mut lt[..p]);
    let mut out = [0.0; 3];
    for jt in 0..p {
        for js in 0..p {
            let w = ls[js] * lt[jt];
            (0..3).for_each(|c| out[c] += w * f[jt * p + js][c]);
        }
    }
    out
}
