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
//! transport is kept as moments against the functions of the nodes their emitter
//! pieces lie in, times the solution's coefficients each round, and recomputed only
//! when a node holding a smaller piece has been split.
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
    /// Per patch, channel by channel: `[∫|e_c| dA, ∫|B_h,c − E_c| dA, ∫E_c dA]` (W),
    /// the parts of [`Self::patch_error`], [`Self::patch_reflected`] and
    /// [`Self::patch_emitted`] ([`Self::patch_relative_channels`]).
    pub patch_channels: Vec<[[f64; 3]; 3]>,
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
    /// Detailed links with a split emitter and `(link, leaf)` pairs under them whose
    /// finer-radiosity moments came from the [`EstimateCache`] (see the module docs).
    pub reused_finer: u64,
    /// Such moments the cache held but that were stale (a node holding a smaller
    /// emitter piece had been split since) and were gathered again.
    pub stale_finer: u64,
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

    /// Estimated relative L1 error of every patch in each channel: `∫|e_c|` over
    /// `max(∫|B_h,c − E_c| + ∫E_c, DARK_FACE · D̄_c · area)`, [`Self::patch_normaliser`]
    /// channel by channel (`D̄_c` the channel's mean reflected radiosity over the
    /// patches that reflect anything); `0` where there is no error. A coloured face's
    /// dim channel is judged against its own radiosity, as a per-channel comparison
    /// of the face's mean does (the `cornell-faces` reproduction).
    pub fn patch_relative_channels(&self) -> Vec<[f64; 3]> {
        self.patch_channels
            .iter()
            .zip(self.patch_normaliser_channels())
            .map(|(pc, den)| {
                std::array::from_fn(|c| {
                    if pc[0][c] > 0.0 && den[c] > 0.0 {
                        pc[0][c] / den[c]
                    } else {
                        0.0
                    }
                })
            })
            .collect()
    }

    /// The normaliser of [`Self::patch_relative_channels`] per patch and channel (W).
    pub fn patch_normaliser_channels(&self) -> Vec<[f64; 3]> {
        let (mut d, mut a) = ([0.0; 3], 0.0);
        for (pc, ar) in self.patch_channels.iter().zip(&self.patch_area) {
            if pc[1].iter().sum::<f64>() > 0.0 {
                (0..3).for_each(|c| d[c] += pc[1][c]);
                a += ar;
            }
        }
        let mean = d.map(|x| if a > 0.0 { x / a } else { 0.0 });
        self.patch_channels
            .iter()
            .zip(&self.patch_area)
            .map(|(pc, ar)| {
                std::array::from_fn(|c| (pc[1][c] + pc[2][c]).max(DARK_FACE * mean[c] * ar))
            })
            .collect()
    }

    /// Every patch's relative error as a face goal judges it: its worst channel
    /// ([`Self::patch_relative_channels`]) when `per_channel`, else the channels
    /// together ([`Self::patch_relative`]).
    pub fn face_errors(&self, per_channel: bool) -> Vec<f64> {
        if per_channel {
            self.patch_relative_channels()
                .iter()
                .map(|r| r.iter().fold(0.0f64, |a, &b| a.max(b)))
                .collect()
        } else {
            self.patch_relative()
        }
    }

    /// The patch with the largest [`Self::patch_relative`] error and that error
    /// (`None` without patches).
    pub fn worst_patch(&self) -> Option<(usize, f64)> {
        worst(self.patch_relative())
    }

    /// The patch with the largest [`Self::face_errors`] and that error (`None`
    /// without patches).
    pub fn worst_face(&self, per_channel: bool) -> Option<(usize, f64)> {
        worst(self.face_errors(per_channel))
    }
}

/// The index of the largest value and that value (the first of equal ones).
fn worst(v: Vec<f64>) -> Option<(usize, f64)> {
    v.into_iter()
        .enumerate()
        .max_by(|a, b| a.1.total_cmp(&b.1).then(b.0.cmp(&a.0)))
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
    /// [`Finer`] moments per `(receiver, emitter, cell)`.
    finer: HashMap<(NodeKey, NodeKey, NodeKey), Finer>,
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
    /// node's orthonormal basis `φ = ψ/√A_node` (or the transport of the solution's
    /// radiosity per channel, [`Emit`]), accumulated into `out[b]`, on piece `id` of
    /// `pieces` and its sub-pieces; shadow rays only when the call's `vis` and the
    /// shaft between the points' cell and the piece meets one of the call's candidate
    /// blockers ([`crate::shaft`]: a culled piece's rays would all be visible, and are
    /// counted so), one per sample or one per emitter cell kept in `memo`
    /// ([`EstimateOptions::vis_cells`]).
    #[allow(clippy::too_many_arguments)]
    fn gather(
        &self,
        pt: &Point,
        call: &Call<'_>,
        pieces: &mut Pieces<'_>,
        id: usize,
        depth: u32,
        vdepth: u32,
        out: &mut Vec<f64>,
        tally: &mut Tally,
        memo: &mut CellMemo,
    ) {
        let (cov, centre, radius) = {
            let p = &pieces.items[id];
            (p.cov, p.centre, p.radius)
        };
        if cov == Coverage::Empty {
            return;
        }
        let near = (pt.x - centre).length() < self.near * radius;
        let split_partial = cov == Coverage::Partial && depth < 3;
        if (near || split_partial) && depth < self.max_depth {
            for c in 0..4 {
                let child = pieces.child(call, id, c);
                self.gather(pt, call, pieces, child, depth + 1, vdepth, out, tally, memo);
            }
            return;
        }
        let open = call.vis && pieces.open(self, call, id);
        let n = self.ctx.basis().n();
        let mut acc = [0.0; 16];
        let (mut seen, mut hidden) = (false, false);
        pieces.sample(self, call, id);
        let piece = &pieces.items[id];
        let (k0, k1) = (piece.samples.0 as usize, piece.samples.1 as usize);
        for (k, s) in pieces.samples[k0..k1].iter().enumerate() {
            tally.evals += 1;
            let g = kernel(pt.x, pt.n, s.y, s.ny);
            if g == 0.0 {
                continue;
            }
            if call.vis && !open {
                tally.visible += 1;
                seen = true;
            } else if call.vis {
                let seen_here = if self.vis_cells == 0 {
                    self.ctx
                        .visible(pt.v, call.pr, s.vy, call.pe, &mut tally.rays)
                } else {
                    self.cell_visible(pt, call, s.uv, memo, &mut tally.rays)
                };
                if !seen_here {
                    tally.blocked += 1;
                    hidden = true;
                    continue;
                }
                tally.visible += 1;
                seen = true;
            }
            let fv = &pieces.f[(k0 + k) * n..][..n];
            match piece.emit {
                Emit::Moments => {
                    let f = s.w * g * piece.scale;
                    for b in 0..n {
                        acc[b] += f * fv[b];
                    }
                }
                Emit::Values { .. } => {
                    let f = s.w * g / piece.scale;
                    for b in 0..n {
                        acc[b] += f * fv[b];
                    }
                }
            }
        }
        if seen && hidden && vdepth < self.vis_depth {
            // A shadow boundary crosses the piece: its q² rays resolve the visible
            // part only to ~1/q²; integrate the quarters instead.
            for c in 0..4 {
                let child = pieces.child(call, id, c);
                self.gather(
                    pt,
                    call,
                    pieces,
                    child,
                    depth + 1,
                    vdepth + 1,
                    out,
                    tally,
                    memo,
                );
            }
            return;
        }
        let at = piece.slot * n;
        if out.len() < at + n {
            out.resize(at + n, 0.0);
        }
        out[at..at + n]
            .iter_mut()
            .zip(&acc)
            .for_each(|(o, a)| *o += a);
    }
    /// Whether the point sees the emitter sample at parameters `uv` of the call's
    /// emitter node, answered by the ray to the centre of the sample's cell among
    /// `vis_cells × vis_cells` equal cells of the node (its visibility point on a
    /// masked support, [`Call::cells`]), shot once per point and cell (`memo`).
    fn cell_visible(
        &self,
        pt: &Point,
        call: &Call<'_>,
        uv: (f64, f64),
        memo: &mut CellMemo,
        rays: &mut u64,
    ) -> bool {
        let en = &call.en;
        let g = self.vis_cells;
        let cells = g as f64;
        // Negative offsets (rounding at the node's edge) saturate to cell 0.
        let cell = |x: f64, x0: f64| (((x - x0) / en.h * cells) as usize).min(g - 1);
        let (i, j) = (cell(uv.0, en.s0), cell(uv.1, en.t0));
        let slot = &mut memo[j * g + i];
        if *slot == 0 {
            let vy = call.cells[j * g + i];
            *slot = if self.ctx.visible(pt.v, call.pr, vy, call.pe, rays) {
                1
            } else {
                2
            };
        }
        *slot == 1
    }
}

/// What stays fixed over the receiver points of one [`fine_at`] call: the link's
/// patches and emitter node, the cell holding the points with the candidate blockers
/// of its shaft to the emitter ([`crate::shaft`]), whether rays are shot, and the
/// visibility points of the emitter node's `vis_cells × vis_cells` cell centres
/// ([`Fine::cell_visible`]).
struct Call<'a> {
    pr: &'a Patch,
    pe: &'a Patch,
    en: Region,
    cell: Region,
    cands: Option<Vec<u32>>,
    vis: bool,
    /// `1/√A_en` (the orthonormal scale of the emitter node's functions).
    inv: f64,
    cells: Vec<DVec3>,
}

impl<'a> Call<'a> {
    fn new(
        fine: &Fine<'_>,
        pr: &'a Patch,
        pe: &'a Patch,
        en: Region,
        cell: Region,
        vis: bool,
    ) -> Self {
        let cands = if vis {
            fine.ctx.shaft_candidates(&cell, &en, None)
        } else {
            None
        };
        let g = fine.vis_cells;
        let cells = if vis && g > 0 {
            let n = g as f64;
            (0..g * g)
                .map(|k| {
                    let (i, j) = (k % g, k / g);
                    let cu = en.s0 + en.h * (i as f64 + 0.5) / n;
                    let cv = en.t0 + en.h * (j as f64 + 0.5) / n;
                    if pe.support.mask.is_some() {
                        pe.support.visibility_point(cu, cv)
                    } else {
                        pe.support.point_normal(cu, cv).0
                    }
                })
                .collect()
        } else {
            Vec::new()
        };
        Self {
            pr,
            pe,
            inv: 1.0 / (pe.support.area * en.h * en.h).sqrt(),
            en,
            cell,
            cands,
            vis,
            cells,
        }
    }
}

/// One emitter sample of a piece with non-zero weight.
struct Sample {
    /// Parameters.
    uv: (f64, f64),
    /// Point and unit normal.
    y: DVec3,
    ny: DVec3,
    /// Visibility point (ṽ on a masked support, else `y`).
    vy: DVec3,
    /// Quadrature weight in true area ([`weight_in`]).
    w: f64,
}

/// An emitter piece visited by a [`fine_at`] call: what does not depend on the
/// receiver point, computed once for all the call's points.
struct Piece<'s> {
    region: Region,
    emit: Emit<'s>,
    cov: Coverage,
    centre: DVec3,
    radius: f64,
    /// Sub-pieces ([`Region::split`] order; `u32::MAX` until visited).
    children: [u32; 4],
    /// Whether the shaft test lets rays through (once asked).
    open: Option<bool>,
    /// Its samples with non-zero weight, `Pieces::samples[a..b]` (once the piece is
    /// integrated).
    samples: (u32, u32),
    sampled: bool,
    /// [`Emit::Moments`]: `1/√A_en`; [`Emit::Values`]: `√A` of the piece's node.
    scale: f64,
    /// Where the piece's moments go in a point's output: `0` ([`Emit::Moments`]), or
    /// the index of its node in [`Pieces::nodes`] ([`Emit::Values`]).
    slot: usize,
}

/// The emitter pieces of one [`fine_at`] call, a quadtree under the link's emitter
/// node grown as the receiver points' near-field and shadow-boundary splits ask. The
/// points share each piece's coverage, bounding sphere, shaft test, samples and
/// emitter functions; what is computed per point (kernel, rays, sums) is the same
/// arithmetic in the same order as without sharing, so the fine transport is bitwise
/// the same.
struct Pieces<'s> {
    items: Vec<Piece<'s>>,
    /// Every piece's samples, contiguous per piece ([`Piece::samples`]).
    samples: Vec<Sample>,
    /// Per sample, the `n` functions `ψ_b` of the emitter node ([`Emit::Moments`]) or
    /// of the piece's node ([`Emit::Values`]).
    f: Vec<f64>,
    /// [`Emit::Values`]: the hierarchy nodes the pieces lie in, in the order first
    /// met, and whether a piece lay strictly inside the node (a leaf then: see
    /// [`Finer`]).
    nodes: Vec<(u32, bool)>,
}

impl<'s> Pieces<'s> {
    /// The pieces with the emitter node as the root (index 0).
    fn new(call: &Call<'_>, emit: Emit<'s>) -> Self {
        let mut p = Self {
            items: Vec::with_capacity(16),
            samples: Vec::with_capacity(64),
            f: Vec::with_capacity(64 * 9),
            nodes: Vec::new(),
        };
        p.push(call, call.en, emit);
        p
    }

    fn push(&mut self, call: &Call<'_>, region: Region, emit: Emit<'s>) -> usize {
        let sup = &call.pe.support;
        let cov = if sup.mask.is_some() {
            sup.coverage(region.s0, region.t0, region.h)
        } else {
            Coverage::Full
        };
        let (centre, radius) = if cov == Coverage::Empty {
            (DVec3::ZERO, 0.0)
        } else {
            sup.bounding_sphere(region.s0, region.t0, region.h)
        };
        let slot = match emit {
            Emit::Moments => 0,
            Emit::Values { sol, node } => {
                let strict = region.h < sol.system.h.keys[node as usize].region().h;
                match self.nodes.iter().position(|&(k, _)| k == node) {
                    Some(i) => {
                        self.nodes[i].1 |= strict;
                        i
                    }
                    None => {
                        self.nodes.push((node, strict));
                        self.nodes.len() - 1
                    }
                }
            }
        };
        self.items.push(Piece {
            region,
            emit,
            cov,
            centre,
            radius,
            children: [u32::MAX; 4],
            open: None,
            samples: (0, 0),
            sampled: false,
            scale: 0.0,
            slot,
        });
        self.items.len() - 1
    }

    /// Index of child `c` of piece `id`, created on first use.
    fn child(&mut self, call: &Call<'_>, id: usize, c: usize) -> usize {
        let k = self.items[id].children[c];
        if k != u32::MAX {
            return k as usize;
        }
        let (region, emit) = {
            let p = &self.items[id];
            (p.region.split()[c], p.emit.child(&p.region, c))
        };
        let k = self.push(call, region, emit);
        self.items[id].children[c] = k as u32;
        k
    }

    /// Whether the shaft between the call's cell and piece `id` may be blocked.
    fn open(&mut self, fine: &Fine<'_>, call: &Call<'_>, id: usize) -> bool {
        let p = &mut self.items[id];
        *p.open.get_or_insert_with(|| {
            fine.ctx
                .shaft_open(&call.cell, &p.region, call.cands.as_deref())
        })
    }

    /// Gives piece `id` its samples and emitter functions (once).
    fn sample(&mut self, fine: &Fine<'_>, call: &Call<'_>, id: usize) {
        if !self.items[id].sampled {
            let a = self.samples.len() as u32;
            let p = &mut self.items[id];
            p.sampled = true;
            sample_piece(fine, call, p, &mut self.samples, &mut self.f);
            p.samples = (a, self.samples.len() as u32);
        }
    }
}

/// Fills the scale of a piece and appends its samples and emitter functions (see
/// [`Piece`], [`Pieces`]).
fn sample_piece(
    fine: &Fine<'_>,
    call: &Call<'_>,
    p: &mut Piece<'_>,
    samples: &mut Vec<Sample>,
    f: &mut Vec<f64>,
) {
    let basis = fine.ctx.basis();
    let n = basis.n();
    let (gx, gw, gc) = (&fine.rule.0, &fine.rule.1, &fine.rule.2);
    let q = gx.len();
    let (pe, es, en) = (call.pe, &p.region, &call.en);
    let mut phi = [0.0; 16];
    p.scale = match p.emit {
        Emit::Moments => call.inv,
        Emit::Values { sol, node } => sol.system.node_area[node as usize].sqrt(),
    };
    for kt in 0..q {
        for ks in 0..q {
            let w = weight_in(pe, es, (gx, gw, gc), ks, kt);
            if w == 0.0 {
                continue;
            }
            let (u, v) = (es.s0 + es.h * gx[ks], es.t0 + es.h * gx[kt]);
            let (y, ny) = pe.support.point_normal(u, v);
            let vy = if fine.vis_cells == 0 && pe.support.mask.is_some() {
                pe.support.visibility_point(u, v)
            } else {
                y
            };
            samples.push(Sample {
                uv: (u, v),
                y,
                ny,
                vy,
                w,
            });
            let fr = match p.emit {
                Emit::Moments => *en,
                Emit::Values { sol, node } => sol.system.h.keys[node as usize].region(),
            };
            basis.eval((u - fr.s0) / fr.h, (v - fr.t0) / fr.h, &mut phi[..n]);
            f.extend_from_slice(&phi[..n]);
        }
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
        patch_channels: vec![[[0.0; 3]; 3]; patches.len()],
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
    finer: HashSet<(NodeKey, NodeKey, NodeKey)>,
    /// [`Finer`] moments reused and found stale.
    finer_counts: [u64; 2],
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
            let detailed = gather_links(
                fine, sol, &links, pts, recv_rule, cache, est, &mut used, &mut hf,
            );
            gather_detailed(fine, sol, &detailed, pts, cache, &mut used, &mut hf);
            used.links.extend(links.iter().map(|&l| link_key(h, l)));
        }
    }
    cache.links.retain(|k, _| used.links.contains(k));
    cache.leaves.retain(|k, _| used.leaves.contains(k));
    cache.finer.retain(|k, _| used.finer.contains(k));
    [est.reused_finer, est.stale_finer] = used.finer_counts;
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
    used: &mut Gathered,
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
    // radiosity ([`Finer`]).
    let finer_key = |l: usize| {
        let (r, e) = link_key(h, l);
        (r, e, r)
    };
    let finer: Vec<Option<FinerOut>> = links
        .par_iter()
        .map(|&l| {
            let mom = &cache.links[&link_key(h, l)];
            (mom.detailed && split_emitter(h, l)).then(|| {
                let rk = h.keys[h.link_receiver[l] as usize];
                let rp = leaf_points(&sol.patches[rk.patch as usize], &rk.region(), recv_rule);
                let cached = cache.finer.get(&finer_key(l));
                Finer::transport(fine, sol, l, &rk.region(), &rp, cached)
            })
        })
        .collect();
    let mut detailed: Vec<(usize, usize)> = Vec::new();
    for (&l, finer) in links.iter().zip(finer) {
        let mom = &cache.links[&link_key(h, l)];
        let f = match finer {
            Some((f, how, fresh)) => {
                let mut t = Tally::default();
                how.count(&mut t, &mut used.finer_counts);
                est.kernel_evals += t.evals;
                est.rays += t.rays;
                if let Some(fresh) = fresh {
                    cache.finer.insert(finer_key(l), fresh);
                }
                used.finer.insert(finer_key(l));
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
    // Pairs under a split emitter: the transport of its finer radiosity ([`Finer`]).
    let finer: Vec<Option<FinerOut>> = detailed
        .par_iter()
        .map(|&(l, li)| {
            split_emitter(h, l).then(|| {
                let leaf = h.keys[h.leaves[li] as usize].region();
                let cached = cache.finer.get(&leaf_key(l, li));
                Finer::transport(fine, sol, l, &leaf, &pts[li], cached)
            })
        })
        .collect();
    let extra: Vec<(Vec<f64>, Tally)> = missing
        .par_iter()
        .map(|&(l, li)| {
            let leaf = h.keys[h.leaves[li] as usize].region();
            fine_at(fine, sol, l, &leaf, &pts[li])
        })
        .collect();
    for (&(l, li), (m, t)) in missing.iter().zip(extra) {
        used.tally.add(&t);
        cache.leaves.insert(leaf_key(l, li), m);
    }
    for (&(l, li), finer) in detailed.iter().zip(finer) {
        let v = match finer {
            Some((v, how, fresh)) => {
                how.count(&mut used.tally, &mut used.finer_counts);
                if let Some(fresh) = fresh {
                    cache.finer.insert(leaf_key(l, li), fresh);
                }
                used.finer.insert(leaf_key(l, li));
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
                let pc = &mut est.patch_channels[key.patch as usize];
                pc[0][c] += pt.wr * e.abs();
                pc[1][c] += pt.wr * d;
                pc[2][c] += pt.wr * patch.emission[c];
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

/// The fine gather of link `l` at the given points of the cell `cell` (its receiver
/// or a leaf under it) against `emit`: per point, the moments of every piece slot
/// (`n` per slot, [`Piece::slot`]), and the pieces; `None` when the link carries
/// nothing.
fn gather_points<'s>(
    fine: &Fine<'_>,
    sol: &'s Solution,
    l: usize,
    cell: &Region,
    pts: &[Point],
    emit: Emit<'s>,
    tally: &mut Tally,
) -> Option<(Vec<Vec<f64>>, Pieces<'s>)> {
    let h = &sol.system.h;
    let vis = link_rays(fine, sol, l)?;
    let pr = &sol.patches[h.keys[h.link_receiver[l] as usize].patch as usize];
    let ek = h.keys[h.link_emitter[l] as usize];
    let pe = &sol.patches[ek.patch as usize];
    let call = Call::new(fine, pr, pe, ek.region(), *cell, vis);
    let mut pieces = Pieces::new(&call, emit);
    let out = pts
        .iter()
        .map(|pt| {
            let mut out = vec![0.0; h.n];
            let mut memo: CellMemo = [0; MAX_VIS_CELLS * MAX_VIS_CELLS];
            fine.gather(pt, &call, &mut pieces, 0, 0, 0, &mut out, tally, &mut memo);
            out
        })
        .collect();
    Some((out, pieces))
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
) -> (Vec<f64>, Tally) {
    let mut tally = Tally::default();
    let m = gather_points(fine, sol, l, cell, pts, Emit::Moments, &mut tally)
        .map_or_else(Vec::new, |(out, _)| out.concat());
    (m, tally)
}

/// The fine transport of a detailed link whose emitter node is split, at the points
/// of a cell, as moments against the functions of the hierarchy nodes its emitter
/// pieces lie in ([`Emit::Values`]): the transport is then the solution's
/// coefficients of those nodes times the moments ([`Finer::values`]). The moments
/// depend on the geometry and on which node each piece lies in, not on the solution,
/// so they are kept between the rounds of [`crate::target`] while every node that
/// held a piece strictly inside it is still a leaf (a split one would now give that
/// piece a finer function).
#[derive(Debug, Clone)]
struct Finer {
    /// The nodes, in slot order, and whether a piece lay strictly inside.
    nodes: Vec<(NodeKey, bool)>,
    /// `[point · nodes · n + slot · n + b]`; empty when the link carries nothing.
    m: Vec<f64>,
}

impl Finer {
    /// The gather of link `l` at the points of `cell` ([`Finer`]),
    /// and the transport it gives with `sol`'s coefficients ([`Self::values`]).
    fn at(
        fine: &Fine<'_>,
        sol: &Solution,
        l: usize,
        cell: &Region,
        pts: &[Point],
    ) -> (Self, Vec<[f64; 3]>, Tally) {
        let h = &sol.system.h;
        let mut tally = Tally::default();
        let emit = Emit::Values {
            sol,
            node: h.link_emitter[l],
        };
        let Some((out, pieces)) = gather_points(fine, sol, l, cell, pts, emit, &mut tally) else {
            let none = Self {
                nodes: Vec::new(),
                m: Vec::new(),
            };
            return (none, vec![[0.0; 3]; pts.len()], tally);
        };
        let width = pieces.nodes.len().max(1) * h.n;
        let mut m = Vec::with_capacity(pts.len() * width);
        for mut o in out {
            o.resize(width, 0.0);
            m.extend(o);
        }
        let nodes = pieces
            .nodes
            .iter()
            .map(|&(i, strict)| (h.keys[i as usize], strict))
            .collect();
        let f = Self { nodes, m };
        let idx: Vec<usize> = pieces.nodes.iter().map(|&(i, _)| i as usize).collect();
        let v = f.dot(sol, &idx, pts.len());
        (f, v, tally)
    }

    /// The transport per point and channel with `sol`'s coefficients, `None` when a
    /// node that held a piece strictly inside is no longer a leaf of `sol`'s
    /// hierarchy (or is missing): the moments are then stale.
    fn values(&self, sol: &Solution, l: usize, points: usize) -> Option<Vec<[f64; 3]>> {
        let h = &sol.system.h;
        let e = h.link_emitter[l];
        let idx = self
            .nodes
            .iter()
            .map(|&(k, strict)| {
                let i = descend(h, e, k)?;
                (!strict || h.children[i as usize][0] == u32::MAX).then_some(i as usize)
            })
            .collect::<Option<Vec<usize>>>()?;
        Some(self.dot(sol, &idx, points))
    }

    /// The transport per point and channel with the coefficients of `sol`'s nodes
    /// `idx` (one per slot).
    fn dot(&self, sol: &Solution, idx: &[usize], points: usize) -> Vec<[f64; 3]> {
        if self.m.is_empty() {
            return vec![[0.0; 3]; points];
        }
        let n = sol.system.h.n;
        let width = idx.len().max(1) * n;
        self.m
            .chunks_exact(width)
            .map(|mp| {
                std::array::from_fn(|c| {
                    let mut v = 0.0;
                    for (j, &i) in idx.iter().enumerate() {
                        let coef = &sol.node_b[c][i * n..][..n];
                        v += coef
                            .iter()
                            .zip(&mp[j * n..][..n])
                            .map(|(a, b)| a * b)
                            .sum::<f64>();
                    }
                    v
                })
            })
            .collect()
    }

    /// The transport of link `l` at the points of `cell` with `sol`'s coefficients:
    /// from `cached` while its moments hold, else gathered afresh (and returned to be
    /// kept).
    fn transport(
        fine: &Fine<'_>,
        sol: &Solution,
        l: usize,
        cell: &Region,
        pts: &[Point],
        cached: Option<&Self>,
    ) -> FinerOut {
        if let Some(v) = cached.and_then(|f| f.values(sol, l, pts.len())) {
            return (v, Finery::Reused, None);
        }
        let (f, v, t) = Self::at(fine, sol, l, cell, pts);
        let how = if cached.is_some() {
            Finery::Stale(t)
        } else {
            Finery::Fresh(t)
        };
        (v, how, Some(f))
    }
}

/// The node of `key` in `h`, found from its ancestor node `from`; `None` when `key`
/// is not under `from` or not in `h`.
fn descend(h: &crate::hierarchy::Hierarchy, from: u32, key: NodeKey) -> Option<u32> {
    let top = h.keys[from as usize];
    let mut path = Vec::new();
    let mut k = key;
    while k.level > top.level {
        path.push(k.child_pos());
        k = k.parent()?;
    }
    if k != top {
        return None;
    }
    let mut i = from;
    for &c in path.iter().rev() {
        i = h.children[i as usize][c];
        if i == u32::MAX {
            return None;
        }
    }
    Some(i)
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
    let (m, tally) = fine_at(fine, sol, l, &rreg, &pts);
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

/// What [`Finer::transport`] gives: the transport per point and channel, how it was
/// obtained, and fresh moments to keep.
type FinerOut = (Vec<[f64; 3]>, Finery, Option<Finer>);

/// How [`Finer::transport`] got its moments: from the cache, gathered for the first
/// time, or gathered again because the cached ones were stale (with the work done).
enum Finery {
    Reused,
    Fresh(Tally),
    Stale(Tally),
}

impl Finery {
    /// Adds the work to `tally` and the cache outcome to `counts` (reused, stale).
    fn count(&self, tally: &mut Tally, counts: &mut [u64; 2]) {
        match self {
            Finery::Reused => counts[0] += 1,
            Finery::Fresh(t) => tally.add(t),
            Finery::Stale(t) => {
                counts[1] += 1;
                tally.add(t);
            }
        }
    }
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
