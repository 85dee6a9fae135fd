//! The radiosity kernel, transfer blocks of links and the kernel-smoothness oracle.
//!
//! Kernel (Ziegler §2.1): `G(x,y) V(x,y)` with `G = cosθ_x cosθ_y / (π r²)` (zero when
//! either point is behind the other's surface) and `V` the binary visibility.
//!
//! Transfer block of a link between receiver node `R` and emitter node `E` (Ziegler
//! §3.3.3): `T_{ab} = ∫_R ∫_E φ_a(x) G(x,y) V(x,y) φ_b(y) dA_y dA_x` with the
//! `L²(S)`-orthonormal node functions `φ = ψ/√(area)`; the receiver's irradiance
//! coefficients are `H_R += T · B_E`. Quadrature:
//!
//! - well separated node pairs (`dist(centres) ≥ near_field · (r_R + r_E)` with
//!   bounding-sphere radii `r`): a tensor Gauss–Legendre rule with `n_samp` points per
//!   axis, i.e. `n_samp⁴` kernel samples (Ziegler's `n_samp`); far pairs probe their
//!   visibility with fewer rays first ([`FAR_RATIO`]);
//! - node pairs of affine supports that share a full edge or exactly one vertex: the
//!   Sauter–Schwab/Duffy rules of `wavelux-quadrature` (exponentially convergent for
//!   the `1/r²` singularity; Ziegler avoided such pairs, we cannot);
//! - other near pairs: both sub-squares are split in four (up to `max_split_depth`
//!   times) and the pieces integrated as above, so T-junctions and close pairs are
//!   resolved adaptively; at the depth limit the Gauss block of the pieces is
//!   rescaled so that its unoccluded constant part equals the exact `∫∫ G` of the two
//!   planar pieces (contour-integral form factor of `wavelux-geometry`; parallelogram
//!   and triangle supports), else the plain Gauss rule is used (finite: its points
//!   are interior). Without the rescaling, sliver wedges of triangle supports that
//!   share an edge got form factors up to ~2 (Cornell box, level 4).
//!
//! Virtual supports (VirtualMesh §4): the kernel takes each sample's own normal
//! (`Support::normal_at`; curved maps); receivers integrate over the whole support
//! (weights `area·h²`, the basis normalisation), emitters with the area element
//! `Support::jacobian` times the real fraction of each Gauss point's cell (the
//! partition of `[0,1]` by cumulative Gauss weights), so virtual points emit nothing
//! and a partial emitter emits exactly its real area; partial emitters are split up to
//! `max_split_depth` times even when far, and empty ones skipped. Shadow rays run
//! between the points' nearest real points (ṽ, §4.1) against the true trimmed
//! geometry. Curved supports are not affine: touching sub-squares of one curved
//! patch use the identical/edge/vertex rules in parameter space (the kernel is
//! bounded but direction-dependent there), identical sub-squares with a partial
//! emitter a `(q+1)`-point emitter rule (no coincident nodes); touching pairs of a
//! curved and another support are split and Gauss-integrated (no singular rule: the
//! weakest spot, ~1–4% on a cylinder's rim junction with its end disks).
//!
//! Visibility (Ziegler §3.3.3, §4.1.2): *in quadrature* (one shadow ray per sample
//! pair, the default), *fractional* (Hanrahan: the unoccluded block times the
//! visible fraction of 16 fixed ray pairs between 4×4 grids) or *off*.
//!
//! Oracle (Ziegler §2.4.2, §3.3.2, after Gortler et al. 1993): the kernel `G·V` is
//! sampled on a `(ν+1)⁴` grid over the node pair (ν = vanishing moments); along each
//! of the four axes the `ν`-th finite difference (divided by `2^{ν−1}`: for `ν = 1` the
//! difference of the two samples, for `ν = 2` twice the deviation of the midpoint from
//! the chord, exactly Ziegler's measures) is averaged over the other three axes; the
//! estimate is the largest of the four averages times `√(|R| |E|)`, the `L¹` norm of a
//! pair of normalized wavelets, so it bounds the size of the pair's wavelet
//! coefficients. Ziegler samples interval end points; we sample at the interval
//! *midpoints* `(i + ½)/(ν + 1)` so that touching elements give finite samples.

use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};

use glam::DVec3;
use wavelux_geometry::Accel;
use wavelux_geometry::backend::{Occluder, OcclusionQuery};
use wavelux_geometry::formfactor::{area_form_factor, point_to_polygon};
use wavelux_quadrature::{Corner, GaussLegendre, RuleNd, SquarePair, singular::square_pair_rule};

use crate::basis::TreeBasis;
use crate::error::SolverError;
use crate::exact::{self, Piece};
use crate::mask::Coverage;
use crate::replay::Rays;
use crate::shaft::{self, Blockers};
use crate::support::Patch;

/// How visibility enters the transfer blocks.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum Visibility {
    /// One shadow ray per quadrature sample pair (Ziegler's choice).
    InQuadrature,
    /// Hanrahan's fractional visibility: unoccluded block × visible fraction of a 4×4
    /// ray estimate.
    Fractional,
    /// No visibility (every pair mutually visible).
    Off,
}

/// What the shadow rays of a link's transfer block saw ([`TransferCtx::block_seen`]).
///
/// A sampled classification, not a proof: an occluder smaller than the spacing of the
/// block's sample pairs can hide from every ray. Consumers use it where the block
/// itself already trusts those rays (the error estimate skips the shadow rays of a
/// `Visible` link and the transport of a `Blocked` one).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[non_exhaustive]
pub enum LinkVisibility {
    /// Every shadow ray of the block (between sample pairs with a non-zero kernel)
    /// was unblocked.
    Visible,
    /// Every such ray was blocked (the block is zero).
    Blocked,
    /// Some rays were blocked and some not: a shadow boundary crosses the pair.
    Partial,
    /// No rays were shot (visibility off or fractional, no facing samples, or a
    /// link not made by [`TransferCtx::block_seen`]).
    #[default]
    Unknown,
    /// Not a transfer link: a leaf's closure link to itself ([`crate::closure`]),
    /// which carries its row-sum defect and no transport of its own.
    Closure,
}

/// `G(x, y) = max(0, cosθ_x) max(0, cosθ_y) / (π r²)`.
#[inline]
pub fn kernel(x: DVec3, nx: DVec3, y: DVec3, ny: DVec3) -> f64 {
    let d = y - x;
    let r2 = d.length_squared();
    if r2 <= 0.0 || !r2.is_finite() {
        return 0.0;
    }
    let cx = nx.dot(d);
    let cy = -ny.dot(d);
    if cx <= 0.0 || cy <= 0.0 {
        return 0.0;
    }
    cx * cy / (std::f64::consts::PI * r2 * r2)
}

/// A square `[s0, s0+h] × [t0, t0+h]` of a patch's unit parameter square.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Region {
    /// Patch index.
    pub patch: usize,
    /// Lower-left `s`.
    pub s0: f64,
    /// Lower-left `t`.
    pub t0: f64,
    /// Side length in parameter units.
    pub h: f64,
}

impl Region {
    /// The four quadrants, `c = cy·2 + cx`.
    pub(crate) fn split(&self) -> [Region; 4] {
        let h = 0.5 * self.h;
        std::array::from_fn(|c| Region {
            patch: self.patch,
            s0: self.s0 + h * (c % 2) as f64,
            t0: self.t0 + h * (c / 2) as f64,
            h,
        })
    }
}

/// Everything needed to compute transfer blocks and oracle estimates; shared by the
/// refinement threads (counters are atomic integers, so totals are deterministic).
#[derive(Debug)]
pub struct TransferCtx<'a> {
    /// The patches.
    pub patches: &'a [Patch],
    accel: &'a Accel,
    /// Normalisation of ray end points into the accelerator's frame.
    frame: (DVec3, f64),
    basis: &'a TreeBasis,
    visibility: Visibility,
    oracle_visibility: bool,
    gx: Vec<f64>,
    gw: Vec<f64>,
    /// Cumulative Gauss weights `0 = c_0 < … < c_q = 1`: point `i` owns `[c_i, c_{i+1}]`
    /// (the nodes interlace with these partial sums), the cell whose real fraction
    /// weights it on a partial emitter (VirtualMesh §4.2, Fig. 7).
    gc: Vec<f64>,
    /// A `(q+1)`-point Gauss rule (points, weights, cumulative weights) for the emitter
    /// of a pair of identical sub-squares (self-links of curved supports): its nodes
    /// never coincide with the receiver's `q` nodes, where the kernel is undefined.
    alt: (Vec<f64>, Vec<f64>, Vec<f64>),
    /// The Gauss rule (points, weights, cumulative weights) of the far pairs'
    /// visibility probe, `None` when it has as many points as the regular one.
    far: Option<(Vec<f64>, Vec<f64>, Vec<f64>)>,
    /// Basis values at the `q×q` Gauss points of the unit cell: `[(jt·q + js)·n + a]`.
    table: Vec<f64>,
    near_field: f64,
    max_split_depth: u32,
    /// Edge rules `[re * 8 + ee * 2 + flip]` and vertex rules `[rc * 4 + ec]`.
    edge_rules: Vec<RuleNd>,
    vertex_rules: Vec<RuleNd>,
    /// Identical-square rule (self pairs of curved patches).
    identical_rule: RuleNd,
    /// Rules of the exact parts ([`crate::exact`]).
    rules: exact::Rules,
    /// Possible blockers for shaft culling of the shadow rays ([`crate::shaft`]).
    blockers: Blockers,
    /// Kernel evaluations so far.
    pub kernel_evals: AtomicU64,
    /// Shadow rays so far.
    pub rays: AtomicU64,
    /// The batched occluder of the transfer blocks' shadow rays, if any
    /// ([`Self::with_occluder`], [`crate::replay`]).
    occluder: Option<Device<'a>>,
    /// Shadow rays the occluder decided on its device.
    pub device_rays: AtomicU64,
    /// Shadow rays of the occluder's batches answered by [`Accel::occluded`] (the
    /// device's unsure answers, rays the replay had not recorded, batches after a
    /// device error).
    pub deferred_rays: AtomicU64,
}

/// A batched occluder and its first failure.
struct Device<'a> {
    occluder: &'a dyn Occluder,
    failure: Mutex<Option<String>>,
}

impl std::fmt::Debug for Device<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Device")
            .field("failure", &self.failure)
            .finish_non_exhaustive()
    }
}

/// Separation (centre distance over the sum of the bounding-sphere radii) from which a
/// pair of unmasked affine nodes probes its visibility first
/// ([`TransferOptions::far_probe_points`], issue 12 §3): `p⁴` shadow rays between the
/// `p×p` Gauss points of each side; when they agree (all visible or all blocked) the
/// block's `n_samp⁴` kernel samples take that visibility without rays of their own,
/// and when they disagree the block shoots its own rays as usual. The kernel samples,
/// hence the block, are those of the full rule (a lower-order kernel rule cannot
/// resolve M3's quadratic functions: 2 Gauss points zero them, and its linear
/// entries were off by up to 30 % of the constant on the Cornell box's far pairs).
/// What it risks: an occluder slipping between the probe rays of a pair they call
/// unanimous (counted in the test `far_probes_agree_with_the_full_rule`).
pub const FAR_RATIO: f64 = 3.0;

/// Options of [`TransferCtx::new`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TransferOptions {
    /// Gauss points per axis of regular pairs (`n_samp`), `1..=16`.
    pub quad_points: usize,
    /// Gauss points per axis of the visibility probe of far pairs ([`FAR_RATIO`]),
    /// `1..=16` (none, or from `quad_points` on, no probe).
    pub far_probe_points: Option<usize>,
    /// Gauss order per transformed variable of the singular rules, `1..=8`.
    pub singular_order: usize,
    /// Admissibility factor of the regular rule (≥ 0).
    pub near_field: f64,
    /// Maximum recursive splits of near pairs.
    pub max_split_depth: u32,
    /// Visibility mode.
    pub visibility: Visibility,
    /// Whether oracle samples include visibility.
    pub oracle_visibility: bool,
}

fn dep<E: std::fmt::Display>(what: &'static str) -> impl Fn(E) -> SolverError {
    move |e| SolverError::Dependency {
        what,
        message: e.to_string(),
    }
}

const EDGES: [(usize, usize); 4] = [(0, 1), (1, 2), (2, 3), (3, 0)];

impl<'a> TransferCtx<'a> {
    /// Builds the context (Gauss tables, all singular rules).
    ///
    /// # Errors
    /// [`SolverError::Dependency`] if a rule cannot be built.
    ///
    /// `frame = (c, s)`: the accelerator holds the supports mapped by
    /// `p ↦ (p − c)/s` (see [`crate::Prepared`]: a unit-size frame keeps the f32 BVH
    /// traversal scale-independent).
    pub fn new(
        patches: &'a [Patch],
        accel: &'a Accel,
        frame: (DVec3, f64),
        basis: &'a TreeBasis,
        opts: TransferOptions,
    ) -> Result<Self, SolverError> {
        let q = opts.quad_points;
        let g = GaussLegendre::new(q).map_err(dep("quadrature"))?;
        let (gx, gw) = g.unit();
        let mut gc = vec![0.0; q + 1];
        for i in 0..q {
            gc[i + 1] = gc[i] + gw[i];
        }
        gc[q] = 1.0;
        let alt = {
            let g = GaussLegendre::new(q + 1).map_err(dep("quadrature"))?;
            let (x, w) = g.unit();
            let mut c = vec![0.0; q + 2];
            for i in 0..=q {
                c[i + 1] = c[i] + w[i];
            }
            c[q + 1] = 1.0;
            (x, w, c)
        };
        let far = if let Some(p) = opts.far_probe_points.filter(|&p| p < q) {
            let g = GaussLegendre::new(p).map_err(dep("quadrature"))?;
            let (x, w) = g.unit();
            let mut c = vec![0.0; x.len() + 1];
            for i in 0..x.len() {
                c[i + 1] = c[i] + w[i];
            }
            c[x.len()] = 1.0;
            Some((x, w, c))
        } else {
            None
        };
        let n = basis.n();
        let mut table = vec![0.0; q * q * n];
        for jt in 0..q {
            for js in 0..q {
                basis.eval(gx[js], gx[jt], &mut table[(jt * q + js) * n..][..n]);
            }
        }
        let mut edge_rules = Vec::with_capacity(32);
        for (r0, r1) in EDGES {
            for (e0, e1) in EDGES {
                for flip in 0..2 {
                    let (f0, f1) = if flip == 0 { (e0, e1) } else { (e1, e0) };
                    let pair = SquarePair::common_edge(
                        Corner::ALL[r0],
                        Corner::ALL[r1],
                        Corner::ALL[f0],
                        Corner::ALL[f1],
                    )
                    .map_err(dep("quadrature"))?;
                    edge_rules.push(
                        square_pair_rule(pair, opts.singular_order).map_err(dep("quadrature"))?,
                    );
                }
            }
        }
        let mut vertex_rules = Vec::with_capacity(16);
        for rc in Corner::ALL {
            for ec in Corner::ALL {
                let pair = SquarePair::CommonVertex {
                    receiver: rc,
                    emitter: ec,
                };
                vertex_rules
                    .push(square_pair_rule(pair, opts.singular_order).map_err(dep("quadrature"))?);
            }
        }
        let identical_rule = square_pair_rule(SquarePair::Identical, opts.singular_order)
            .map_err(dep("quadrature"))?;
        let rules = exact::Rules::new().ok_or_else(|| SolverError::Dependency {
            what: "quadrature",
            message: "Gauss–Legendre rules of orders 3, 4, 8".into(),
        })?;
        Ok(Self {
            blockers: Blockers::new(accel),
            rules,
            identical_rule,
            patches,
            accel,
            frame,
            basis,
            visibility: opts.visibility,
            oracle_visibility: opts.oracle_visibility,
            gx,
            gw,
            gc,
            alt,
            far,
            table,
            near_field: opts.near_field,
            max_split_depth: opts.max_split_depth,
            edge_rules,
            vertex_rules,
            kernel_evals: AtomicU64::new(0),
            rays: AtomicU64::new(0),
            occluder: None,
            device_rays: AtomicU64::new(0),
            deferred_rays: AtomicU64::new(0),
        })
    }

    /// The same context answering the shadow rays of [`Self::blocks_seen`] with
    /// `occluder` (which must answer exactly as the context's accelerator does, the
    /// contract of [`Occluder`]): blocks are recorded, answered in batches and
    /// replayed ([`crate::replay`]), bitwise as without it. Oracle estimates, single
    /// blocks ([`Self::block`]) and the closure's visible fractions keep asking the
    /// accelerator.
    pub fn with_occluder(mut self, occluder: &'a dyn Occluder) -> Self {
        self.occluder = Some(Device {
            occluder,
            failure: Mutex::new(None),
        });
        self
    }

    /// Whether [`Self::blocks_seen`] batches its shadow rays on an occluder (so that
    /// refinement should collect its links first and compute their blocks together).
    pub fn batches_blocks(&self) -> bool {
        self.occluder().is_some()
    }

    /// The occluder, unless there is none or it failed.
    pub(crate) fn occluder(&self) -> Option<&'a dyn Occluder> {
        let d = self.occluder.as_ref()?;
        let failed = d.failure.lock().map(|f| f.is_some()).unwrap_or(true);
        (!failed).then_some(d.occluder)
    }

    /// The occluder's first error, after which every block was computed on the CPU.
    pub fn device_failure(&self) -> Option<String> {
        let d = self.occluder.as_ref()?;
        d.failure.lock().ok().and_then(|f| f.clone())
    }

    /// Records the occluder's error (the first one is kept).
    pub(crate) fn fail_device(&self, message: String) {
        if let Some(d) = &self.occluder
            && let Ok(mut f) = d.failure.lock()
        {
            f.get_or_insert(message);
        }
    }

    /// The accelerator (the reference every occluder answers like).
    pub(crate) fn accel(&self) -> &'a Accel {
        self.accel
    }

    /// The same context with shaft culling off (every block shoots all its rays), for
    /// tests that culling changes no block.
    #[cfg(test)]
    pub(crate) fn without_shaft_culling(mut self) -> Self {
        self.blockers = Blockers::default();
        self
    }

    /// The basis.
    pub fn basis(&self) -> &TreeBasis {
        self.basis
    }

    /// The visibility mode of transfer blocks.
    pub fn visibility_mode(&self) -> Visibility {
        self.visibility
    }

    /// Whether `x` (on `pr`) and `y` (on `pe`) see each other; counts the ray.
    #[inline]
    pub(crate) fn visible(
        &self,
        x: DVec3,
        pr: &Patch,
        y: DVec3,
        pe: &Patch,
        rays: &mut u64,
    ) -> bool {
        *rays += 1;
        let (c, s) = self.frame;
        !self
            .accel
            .occluded((x - c) / s, (y - c) / s, [Some(pr.prim), Some(pe.prim)])
    }

    /// [`Self::visible`] for the rays of a transfer block, answered as `rays` says
    /// (directly, recorded or replayed, [`crate::replay`]).
    #[inline]
    fn shadow(&self, x: DVec3, pr: &Patch, y: DVec3, pe: &Patch, rays: &mut Rays<'_>) -> bool {
        let (c, s) = self.frame;
        let q = OcclusionQuery {
            p: (x - c) / s,
            q: (y - c) / s,
            ignore: [Some(pr.prim), Some(pe.prim)],
        };
        rays.visible(self.accel, q)
    }

    /// Whether some point of `e` is strictly in front of `r`'s plane and vice versa
    /// (a necessary condition for a non-zero kernel). A curved side has no single
    /// plane: its half of the test is skipped (conservative), and an emitter region
    /// without real points ([`Coverage::Empty`]) never faces anything.
    pub fn facing(&self, r: &Region, e: &Region) -> bool {
        let pr = &self.patches[r.patch];
        let pe = &self.patches[e.patch];
        if pe.support.mask.is_some() && pe.support.coverage(e.s0, e.t0, e.h) == Coverage::Empty {
            return false;
        }
        let cr = sample_points(pr, r);
        let ce = sample_points(pe, e);
        let (_, rad_r) = pr.support.bounding_sphere(r.s0, r.t0, r.h);
        let (_, rad_e) = pe.support.bounding_sphere(e.s0, e.t0, e.h);
        let tol = 1e-9 * (rad_r + rad_e);
        let front = |pts: &[DVec3], o: DVec3, n: DVec3| pts.iter().any(|p| n.dot(*p - o) > tol);
        (!pr.support.is_planar() || front(&ce, cr[0], pr.support.normal))
            && (!pe.support.is_planar() || front(&cr, ce[0], pe.support.normal))
    }

    /// The transfer block (`n × n`, `[a_receiver * n + b_emitter]`) of the node pair.
    ///
    /// The quadrature (regular Gauss, singular rules, near-field splitting) gives the
    /// block with visibility `T_v` and, from the same samples, the unoccluded block
    /// `T_u`. Where both nodes are planar polygons, the entries that carry energy are
    /// also known exactly without occlusion ([`Self::exact_parts`]): the
    /// constant–constant entry from the contour-integral form factor, the receiver
    /// moments against the constant emitter and the emitter moments against the
    /// constant receiver from Lambert's point-to-polygon formula at the Gauss points
    /// (on the real part of a partly masked emitter node, its clipped loops). Those entries become `T_v + α (X − T_u)` with
    /// `α = T_v[0,0] / T_u[0,0]` the kernel-weighted visible fraction of the pair:
    /// exact when the pair is unoccluded, zero when it is blocked, and never more than
    /// the exact unoccluded value. Every form-factor row therefore sums to at most one
    /// and to exactly one in a closed enclosure, whatever the quadrature's error.
    pub fn block(&self, r: &Region, e: &Region) -> Vec<f64> {
        self.block_seen(r, e).0
    }

    /// [`Self::block`] and what its shadow rays saw ([`LinkVisibility`]): every
    /// sample pair with a non-zero kernel visible, every one blocked, or some of
    /// each (`Unknown` when the block shot no rays: visibility off or fractional, or
    /// no sample pair faces the other).
    pub fn block_seen(&self, r: &Region, e: &Region) -> (Vec<f64>, LinkVisibility) {
        self.block_with(r, e, &mut Rays::direct())
    }

    /// [`Self::block_seen`] with its shadow rays answered as `rays` says
    /// ([`crate::replay`]); the record pass returns an empty block and adds nothing
    /// to the counters.
    pub(crate) fn block_with(
        &self,
        r: &Region,
        e: &Region,
        rays: &mut Rays<'_>,
    ) -> (Vec<f64>, LinkVisibility) {
        let n = self.basis.n();
        let nn = n * n;
        let mut evals = 0u64;
        let with_vis = self.visibility == Visibility::InQuadrature;
        let cands = if with_vis {
            self.shaft_candidates(r, e, None)
        } else {
            None
        };
        let shoot = with_vis && cands.as_ref().is_none_or(|c| !c.is_empty());
        let pr = &self.patches[r.patch];
        let pe = &self.patches[e.patch];
        let ar = pr.support.area * r.h * r.h;
        let ae = pe.support.area * e.h * e.h;
        let scale = 1.0 / (ar * ae).sqrt();
        if rays.recording() && !shoot && self.visibility != Visibility::Fractional {
            return (Vec::new(), LinkVisibility::Unknown);
        }
        // Piecewise constants between planar pieces that no blocker's shaft meets: the
        // block is its exact constant entry alone (visible fraction one), so the
        // quadrature, whose only use would be that fraction, is skipped.
        if n == 1
            && with_vis
            && !shoot
            && let Some(x) = self.exact_parts(r, e, &mut evals)
        {
            self.kernel_evals.fetch_add(evals, Ordering::Relaxed);
            let seen = if x.constant > 0.0 {
                LinkVisibility::Visible
            } else {
                LinkVisibility::Unknown
            };
            return (vec![x.constant * scale], seen);
        }
        // A far pair's unanimous probe stands for the block's own rays.
        let probe = if shoot && self.is_far(r, e) {
            self.probe(r, e, &mut evals, rays)
        } else {
            None
        };
        let mut acc = vec![0.0; 2 * nn];
        self.accumulate(
            r,
            e,
            r,
            e,
            0,
            shoot && probe.is_none(),
            cands.as_deref(),
            &mut acc,
            &mut evals,
            rays,
        );
        for v in &mut acc {
            *v *= scale;
        }
        let unocc = acc.split_off(nn);
        let mut out = acc;
        if probe == Some(false) {
            out.iter_mut().for_each(|v| *v = 0.0);
        }
        // The visible and unoccluded sums add the same terms in the same order when
        // every ray is visible, and the visible one has no terms when every ray is
        // blocked (ψ₀ = 1 and the kernel weights are positive).
        let seen = if !with_vis || unocc[0] <= 0.0 {
            LinkVisibility::Unknown
        } else if out[0] == unocc[0] {
            LinkVisibility::Visible
        } else if out[0] == 0.0 {
            LinkVisibility::Blocked
        } else {
            LinkVisibility::Partial
        };
        let mut frac = None;
        if self.visibility == Visibility::Fractional {
            let f = self.fractional_visibility(r, e, rays);
            for (o, u) in out.iter_mut().zip(&unocc) {
                *o = f * u;
            }
            frac = Some(f);
        }
        if rays.recording() {
            // The exact parts need no rays, except for grazing pairs.
            if with_vis && unocc[0] <= 0.0 {
                self.fractional_visibility(r, e, rays);
            }
            return (Vec::new(), LinkVisibility::Unknown);
        }
        if let Some(x) = self.exact_parts(r, e, &mut evals) {
            let alpha = match (self.visibility, frac) {
                (_, Some(f)) => f,
                (Visibility::Off, _) => 1.0,
                _ if unocc[0] > 0.0 => (out[0] / unocc[0]).clamp(0.0, 1.0),
                // No Gauss sample pair faces the other (grazing pieces): the exact part
                // is tiny; take the visible fraction of fixed rays.
                _ => self.fractional_visibility(r, e, rays),
            };
            for (idx, exact) in x.entries(n) {
                out[idx] += alpha * (exact * scale - unocc[idx]);
            }
        }
        self.kernel_evals.fetch_add(evals, Ordering::Relaxed);
        self.rays.fetch_add(rays.count, Ordering::Relaxed);
        (out, seen)
    }

    /// Whether the pair is probed first ([`FAR_RATIO`]): a probe is configured, both
    /// supports are affine without a mask, and the nodes are at least [`FAR_RATIO`]
    /// (and the near-field factor) times the sum of their bounding-sphere radii apart.
    fn is_far(&self, r: &Region, e: &Region) -> bool {
        if self.far.is_none() {
            return false;
        }
        let (pr, pe) = (&self.patches[r.patch], &self.patches[e.patch]);
        if !(pr.support.is_affine() && pe.support.is_affine())
            || pr.support.mask.is_some()
            || pe.support.mask.is_some()
        {
            return false;
        }
        let (cr, rad_r) = pr.support.bounding_sphere(r.s0, r.t0, r.h);
        let (ce, rad_e) = pe.support.bounding_sphere(e.s0, e.t0, e.h);
        (cr - ce).length() >= FAR_RATIO.max(self.near_field) * (rad_r + rad_e)
    }

    /// The visibility probe of a far pair ([`FAR_RATIO`]): `Some(true)` when every
    /// shadow ray between the probe rule's points of the two nodes with a non-zero
    /// kernel is unblocked, `Some(false)` when every one is blocked, `None` when they
    /// disagree or no such pair exists.
    fn probe(&self, r: &Region, e: &Region, evals: &mut u64, rays: &mut Rays<'_>) -> Option<bool> {
        let (pr, pe) = (&self.patches[r.patch], &self.patches[e.patch]);
        let (xr, _) = self.side_samples(pr, r, r, false, false, true);
        let (xe, _) = self.side_samples(pe, e, e, true, false, true);
        let (mut vis, mut blocked) = (false, false);
        for a in &xr {
            for b in &xe {
                *evals += 1;
                if kernel(a.x, a.n, b.x, b.n) == 0.0 {
                    continue;
                }
                if self.shadow(a.v, pr, b.v, pe, rays) {
                    vis = true;
                } else {
                    blocked = true;
                }
                if vis && blocked {
                    return None;
                }
            }
        }
        if rays.recording() {
            // Record the block's own rays too (the replay may need them).
            return None;
        }
        match (vis, blocked) {
            (true, false) => Some(true),
            (false, true) => Some(false),
            _ => None,
        }
    }

    /// The kernel-weighted visible fraction `∫∫ G V / ∫∫ G` of the node pair by the
    /// block's own quadrature (the `α` of [`Self::block`]), or `None` when visibility
    /// is not sampled in quadrature or no sample pair faces the other. The closure
    /// links ([`crate::closure`]) take it at each leaf below a partly visible link.
    pub(crate) fn visible_fraction(&self, r: &Region, e: &Region) -> Option<f64> {
        if self.visibility != Visibility::InQuadrature {
            return None;
        }
        let nn = self.basis.n() * self.basis.n();
        let mut acc = vec![0.0; 2 * nn];
        let (mut evals, mut rays) = (0u64, Rays::direct());
        let cands = self.shaft_candidates(r, e, None);
        let shoot = cands.as_ref().is_none_or(|c| !c.is_empty());
        if !shoot {
            // No blocker's shaft meets the pair: wholly visible.
            return Some(1.0);
        }
        self.accumulate(
            r,
            e,
            r,
            e,
            0,
            shoot,
            cands.as_deref(),
            &mut acc,
            &mut evals,
            &mut rays,
        );
        self.kernel_evals.fetch_add(evals, Ordering::Relaxed);
        self.rays.fetch_add(rays.count, Ordering::Relaxed);
        (acc[nn] > 0.0).then(|| (acc[0] / acc[nn]).clamp(0.0, 1.0))
    }

    /// The exactly known unoccluded parts of the block of two planar nodes (see
    /// [`crate::exact`]), unnormalised (`∫∫ ψ_a G ψ_b` with the unit-square basis, i.e.
    /// before the `1/√(|R| |E|)` factor): `∫_R ∫_E G`, the receiver moments
    /// `∫_R ψ_a(x) F(x → E) dA_x` and the emitter moments `∫_E ψ_b(y) F(y → R) dA_y`
    /// (over the real part of a partly masked emitter node, [`exact::real_moments`]).
    fn exact_parts(&self, r: &Region, e: &Region, evals: &mut u64) -> Option<ExactParts> {
        let (pr, pe) = self.exact_pieces(r, e)?;
        let constant = self.exact_constant(&pr, &pe)?;
        if self.basis.n() == 1 {
            // Piecewise constants: the constant entry is the whole block.
            return (constant.is_finite() && constant >= 0.0).then_some(ExactParts {
                constant,
                receiver: Vec::new(),
                emitter: None,
            });
        }
        let receiver = self.exact_moments(r, &pe, evals)?;
        let pat = &self.patches[e.patch];
        let whole =
            pat.support.mask.is_none() || pat.support.coverage(e.s0, e.t0, e.h) == Coverage::Full;
        let emitter = if whole {
            self.exact_moments(e, &pr, evals)
        } else {
            exact::real_moments(self.patches, self.basis, &self.rules, e, &pr, evals)
        };
        (constant.is_finite() && constant >= 0.0).then_some(ExactParts {
            constant,
            receiver,
            emitter,
        })
    }

    /// The exact pieces of a receiver node and an emitter node (its real part), or
    /// `None` where either has no exact form ([`exact::piece`]).
    pub(crate) fn exact_pieces(&self, r: &Region, e: &Region) -> Option<(Piece, Piece)> {
        Some((
            exact::piece(&self.patches[r.patch], r, false)?,
            exact::piece(&self.patches[e.patch], e, true)?,
        ))
    }

    /// `∫_R ∫_E G` of two exact pieces ([`exact::constant`]).
    pub(crate) fn exact_constant(&self, r: &Piece, e: &Piece) -> Option<f64> {
        exact::constant(self.patches, &self.rules, r, e)
    }

    /// `∫_g ψ_a(x) F(x → P) dA_x` ([`exact::moments`]).
    pub(crate) fn exact_moments(&self, g: &Region, p: &Piece, evals: &mut u64) -> Option<Vec<f64>> {
        exact::moments(self.patches, self.basis, &self.rules, g, p, evals)
    }

    /// The possible blockers of the shadow rays between the cells `r` and `e`
    /// ([`crate::shaft`]), among `within` (every primitive when `None`); `None` when
    /// the pair cannot be culled (curved or masked cells, culling off).
    pub(crate) fn shaft_candidates(
        &self,
        r: &Region,
        e: &Region,
        within: Option<&[u32]>,
    ) -> Option<Vec<u32>> {
        if !self.blockers.enabled() {
            return None;
        }
        let (pr, pe) = (&self.patches[r.patch], &self.patches[e.patch]);
        let (a, na) = shaft::cell_corners(pr, r, self.frame)?;
        let (b, nb) = shaft::cell_corners(pe, e, self.frame)?;
        Some(
            self.blockers
                .candidates((&a, na), (&b, nb), [pr.prim, pe.prim], within),
        )
    }

    /// Whether the shadow rays between the sub-cells `rs` and `es` must be shot:
    /// `false` when the link's candidate blockers `cands` cannot meet their shaft.
    pub(crate) fn shaft_open(&self, rs: &Region, es: &Region, cands: Option<&[u32]>) -> bool {
        match cands {
            None => true,
            Some([]) => false,
            Some(c) => self
                .shaft_candidates(rs, es, Some(c))
                .is_none_or(|v| !v.is_empty()),
        }
    }

    /// Visible fraction from 16 fixed ray pairs between 4×4 grids (Hanrahan 1991).
    fn fractional_visibility(&self, r: &Region, e: &Region, rays: &mut Rays<'_>) -> f64 {
        let pr = &self.patches[r.patch];
        let pe = &self.patches[e.patch];
        let mut vis = 0;
        for i in 0..16usize {
            let j = (5 * i + 7) % 16;
            let (si, ti) = ((i % 4) as f64 + 0.5, (i / 4) as f64 + 0.5);
            let (sj, tj) = ((j % 4) as f64 + 0.5, (j / 4) as f64 + 0.5);
            let x = pr
                .support
                .visibility_point(r.s0 + r.h * si / 4.0, r.t0 + r.h * ti / 4.0);
            let y = pe
                .support
                .visibility_point(e.s0 + e.h * sj / 4.0, e.t0 + e.h * tj / 4.0);
            if self.shadow(x, pr, y, pe, rays) {
                vis += 1;
            }
        }
        vis as f64 / 16.0
    }

    #[allow(clippy::too_many_arguments)]
    fn accumulate(
        &self,
        rn: &Region,
        en: &Region,
        rs: &Region,
        es: &Region,
        depth: u32,
        with_vis: bool,
        cands: Option<&[u32]>,
        out: &mut [f64],
        evals: &mut u64,
        rays: &mut Rays<'_>,
    ) {
        let pr = &self.patches[rs.patch];
        let pe = &self.patches[es.patch];
        let (cr, rad_r) = pr.support.bounding_sphere(rs.s0, rs.t0, rs.h);
        let (ce, rad_e) = pe.support.bounding_sphere(es.s0, es.t0, es.h);
        let dist = (cr - ce).length();
        let emitter_cov = if pe.support.mask.is_some() {
            pe.support.coverage(es.s0, es.t0, es.h)
        } else {
            Coverage::Full
        };
        if dist >= self.near_field * (rad_r + rad_e) {
            if emitter_cov == Coverage::Partial && depth < self.max_split_depth {
                // A partial emitter: split it (only it) so that the cell-constant real
                // fraction of VirtualMesh Fig. 7 is applied on cells a quarter the
                // size; empty children are dropped by `facing`.
                for b in es.split() {
                    if self.facing(rs, &b) {
                        self.accumulate(
                            rn,
                            en,
                            rs,
                            &b,
                            depth + 1,
                            with_vis,
                            cands,
                            out,
                            evals,
                            rays,
                        );
                    }
                }
                return;
            }
            let with_vis = with_vis && self.shaft_open(rs, es, cands);
            self.regular(rn, en, rs, es, with_vis, None, out, evals, rays);
            return;
        }
        let emitter_full = emitter_cov == Coverage::Full;
        let rule = if !emitter_full {
            None
        } else if pr.support.is_affine() && pe.support.is_affine() {
            let rc = pr.support.corners(rs.s0, rs.t0, rs.h);
            let ec = pe.support.corners(es.s0, es.t0, es.h);
            self.touching_rule(&rc, &ec, (rad_r, rad_e))
        } else if rs.patch == es.patch && !pr.support.is_planar() {
            self.param_rule(rs, es)
        } else {
            self.mapped_rule(pr, rs, pe, es, (rad_r, rad_e))
        };
        if let Some(rule) = rule {
            let with_vis = with_vis && self.shaft_open(rs, es, cands);
            self.apply_rule(rule, rn, en, rs, es, with_vis, out, evals, rays);
            return;
        }
        if depth >= self.max_split_depth {
            let with_vis = with_vis && self.shaft_open(rs, es, cands);
            self.near_limit(rn, en, rs, es, with_vis, out, evals, rays);
            return;
        }
        let ratio = rad_r / rad_e.max(f64::MIN_POSITIVE);
        let rparts: Vec<Region> = if ratio > 0.5 {
            rs.split().to_vec()
        } else {
            vec![*rs]
        };
        let eparts: Vec<Region> = if ratio < 2.0 {
            es.split().to_vec()
        } else {
            vec![*es]
        };
        for a in &rparts {
            for b in &eparts {
                if self.facing(a, b) {
                    self.accumulate(rn, en, a, b, depth + 1, with_vis, cands, out, evals, rays);
                }
            }
        }
    }

    /// A near pair at the splitting limit. The plain Gauss rule on the `1/r²` kernel
    /// can overestimate touching pieces badly (a factor 7 was seen for sliver wedges
    /// of triangle supports sharing an edge at their collapsed vertex, which made the
    /// Cornell-box operator's spectral radius exceed 1). Where both pieces are planar
    /// polygons (parallelogram and triangle supports: the images of sub-squares are
    /// exact quadrilaterals), the Gauss block is rescaled so that its unoccluded
    /// constant part equals the exact `∫∫ G` from the contour-integral form factor
    /// of `wavelux-geometry` (robust for shared edges and vertices). Without it, where
    /// the emitter is a polygon (a curved receiver, or a partly masked emitter), the
    /// rule's emitter sum at each receiver point `x`, its estimate of `F(x → E)`, is
    /// capped by the exact point-to-polygon form factor to `E`'s whole square (a
    /// bound, not a replacement: as the value, on the teapot at level 0, the
    /// unbisected outer rule raised a row sum from 0.9999 to 1.0101; as a bound it
    /// removes the rule's overshoots only, and leaves its undershoots: the pair below
    /// converges 6 % low, 0.0255 against 0.0272 at split depth 6): a
    /// crease that is an edge of neither node (the rim of the quadric teapot's collar
    /// running under the inside of its lid rim) put Gauss points a sub-square's
    /// fraction apart across it, where `1/r²` peaks, and gave a collar node a form
    /// factor of 1.3 to one lid-rim node (row sums 1.8, `ρK`'s spectral radius 7.1 at
    /// level 2, Picard's iterate non-finite). Visibility and the basis-function shape
    /// still come from the Gauss rule.
    #[allow(clippy::too_many_arguments)]
    fn near_limit(
        &self,
        rn: &Region,
        en: &Region,
        rs: &Region,
        es: &Region,
        with_vis: bool,
        out: &mut [f64],
        evals: &mut u64,
        rays: &mut Rays<'_>,
    ) {
        let pr = &self.patches[rs.patch];
        let pe = &self.patches[es.patch];
        let emitter_polygon = exact::node_polygon(pe, es);
        let exact = match (exact::node_polygon(pr, rs), &emitter_polygon) {
            (Some(a), Some(b)) => area_form_factor(&a, b).ok(),
            _ => None,
        };
        // The exact value is that of the whole emitter piece: rescale only when it is
        // all real.
        let exact = exact.filter(|_| {
            pe.support.mask.is_none() || pe.support.coverage(es.s0, es.t0, es.h) == Coverage::Full
        });
        // Without it (a curved receiver, a partly masked emitter), each receiver
        // point's emitter sum is capped by its exact form factor to the emitter's
        // polygon (its whole square).
        let cap = emitter_polygon.as_deref().filter(|_| exact.is_none());
        let mut tmp = vec![0.0; out.len()];
        self.regular(rn, en, rs, es, with_vis, cap, &mut tmp, evals, rays);
        // The unoccluded constant entry of the pieces' block (ψ_0 = 1) is the Gauss
        // value of ∫∫ G over the pieces.
        let gauss = tmp[out.len() / 2];
        let scale = match exact {
            Some(x) if x.is_finite() && x >= 0.0 && gauss > 0.0 => x / gauss,
            _ => 1.0,
        };
        for (o, t) in out.iter_mut().zip(&tmp) {
            *o += scale * t;
        }
    }

    /// The rule for touching sub-squares of one curved patch, found in parameter
    /// space: the Sauter–Schwab/Duffy rules make the bounded, direction-dependent
    /// kernel of a smooth surface with itself (`cos·cos/(πr²)` tends to a curvature
    /// term on the diagonal) smooth, for identical squares and for same-size squares
    /// sharing an edge or a corner. Pairs across a periodic seam are not detected
    /// (they are merely near: bounded kernel, split and Gauss).
    fn param_rule(&self, rs: &Region, es: &Region) -> Option<&RuleNd> {
        if rs.h != es.h {
            return None;
        }
        if rs.s0 == es.s0 && rs.t0 == es.t0 {
            return Some(&self.identical_rule);
        }
        let c = |r: &Region| {
            [
                DVec3::new(r.s0, r.t0, 0.0),
                DVec3::new(r.s0 + r.h, r.t0, 0.0),
                DVec3::new(r.s0 + r.h, r.t0 + r.h, 0.0),
                DVec3::new(r.s0, r.t0 + r.h, 0.0),
            ]
        };
        self.rule_for_corners(&c(rs), &c(es), 1e-12 * rs.h, true)
    }

    /// The singular rule for touching sub-squares of two different supports, one of
    /// them not affine (a teapot's spheroid body meeting its conical foot along a rim,
    /// a tube meeting its end disk): their images share exactly a full edge, traced
    /// alike (the edges' midpoints coincide too, so that the rule's linear
    /// correspondence of the two edges holds), or, same size, exactly one corner. The
    /// plain Gauss rule at the splitting limit put its points a few percent of a
    /// sub-square from the crease, where `1/r²` peaks: it made the teapot's body ↔ foot
    /// form factors 0.77 and 0.56 at level 0 and `ρK`'s spectral radius 2.4 (Picard
    /// diverged in `transfer-accuracy`'s contractivity section).
    fn mapped_rule(
        &self,
        pr: &Patch,
        rs: &Region,
        pe: &Patch,
        es: &Region,
        radii: (f64, f64),
    ) -> Option<&RuleNd> {
        let rc = pr.support.corners(rs.s0, rs.t0, rs.h);
        let ec = pe.support.corners(es.s0, es.t0, es.h);
        let tol = 1e-9 * radii.0.max(radii.1);
        let shared: Vec<(usize, usize)> = (0..4)
            .flat_map(|i| (0..4).map(move |j| (i, j)))
            .filter(|&(i, j)| (rc[i] - ec[j]).length() <= tol)
            .collect();
        if let [(i0, j0), (i1, j1)] = shared.as_slice() {
            let mid = |sup: &crate::support::Support, g: &Region, a: usize, b: usize| {
                let uv = |k: usize| [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)][k];
                let ((sa, ta), (sb, tb)) = (uv(a), uv(b));
                sup.point(g.s0 + 0.5 * g.h * (sa + sb), g.t0 + 0.5 * g.h * (ta + tb))
            };
            if (mid(&pr.support, rs, *i0, *i1) - mid(&pe.support, es, *j0, *j1)).length() > tol {
                return None;
            }
        }
        self.touching_rule(&rc, &ec, radii)
    }

    /// The singular rule for touching sub-squares (affine ones, or curved ones whose
    /// shared edge [`Self::mapped_rule`] checked) with corners `rc`, `ec` (their
    /// images, order `(0,0), (1,0), (1,1), (0,1)`) and bounding-sphere radii `radii`,
    /// if they share exactly a full edge or, same size, exactly one corner (within
    /// `1e-9` of the larger radius). Each caller maps the corners once.
    fn touching_rule(
        &self,
        rc: &[DVec3; 4],
        ec: &[DVec3; 4],
        (a, b): (f64, f64),
    ) -> Option<&RuleNd> {
        // Same-size squares only for a shared corner (otherwise a partial edge may be
        // shared).
        let same = (a - b).abs() <= 1e-6 * a.max(b);
        self.rule_for_corners(rc, ec, 1e-9 * a.max(b), same)
    }

    /// The edge or vertex rule for squares whose corners `rc`, `ec` (order `(0,0),
    /// (1,0), (1,1), (0,1)`) coincide (within `tol`) along one full edge, or at one
    /// corner when `same_size`.
    fn rule_for_corners(
        &self,
        rc: &[DVec3; 4],
        ec: &[DVec3; 4],
        tol: f64,
        same_size: bool,
    ) -> Option<&RuleNd> {
        let mut matches = Vec::new();
        for (i, p) in rc.iter().enumerate() {
            for (j, q) in ec.iter().enumerate() {
                if (*p - *q).length() <= tol {
                    matches.push((i, j));
                }
            }
        }
        match matches.as_slice() {
            [(i, j)] => same_size.then(|| &self.vertex_rules[i * 4 + j]),
            [(i0, j0), (i1, j1)] => {
                // Order the receiver corners as one of EDGES.
                let (r0, r1, e0, e1) = if EDGES.contains(&(*i0, *i1)) {
                    (*i0, *i1, *j0, *j1)
                } else if EDGES.contains(&(*i1, *i0)) {
                    (*i1, *i0, *j1, *j0)
                } else {
                    return None;
                };
                let re = EDGES.iter().position(|&x| x == (r0, r1))?;
                let (ee, flip) = if let Some(p) = EDGES.iter().position(|&x| x == (e0, e1)) {
                    (p, 0)
                } else {
                    (EDGES.iter().position(|&x| x == (e1, e0))?, 1)
                };
                Some(&self.edge_rules[re * 8 + ee * 2 + flip])
            }
            _ => None,
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn apply_rule(
        &self,
        rule: &RuleNd,
        rn: &Region,
        en: &Region,
        rs: &Region,
        es: &Region,
        with_vis: bool,
        out: &mut [f64],
        evals: &mut u64,
        rays: &mut Rays<'_>,
    ) {
        let n = self.basis.n();
        let pr = &self.patches[rs.patch];
        let pe = &self.patches[es.patch];
        let ar = pr.support.area * rs.h * rs.h;
        let mut br = [0.0; 16];
        let mut be = [0.0; 16];
        for (p, w) in rule.iter() {
            let (s, t, u, v) = (
                rs.s0 + rs.h * p[0],
                rs.t0 + rs.h * p[1],
                es.s0 + es.h * p[2],
                es.t0 + es.h * p[3],
            );
            let (x, nx) = pr.support.point_normal(s, t);
            let (y, ny) = pe.support.point_normal(u, v);
            *evals += 1;
            let g = kernel(x, nx, y, ny);
            if g == 0.0 {
                continue;
            }
            let vx = if pr.support.mask.is_some() {
                pr.support.visibility_point(s, t)
            } else {
                x
            };
            let vy = if pe.support.mask.is_some() {
                pe.support.visibility_point(u, v)
            } else {
                y
            };
            let visible = !with_vis || self.shadow(vx, pr, vy, pe, rays);
            self.basis
                .eval((s - rn.s0) / rn.h, (t - rn.t0) / rn.h, &mut br[..n]);
            self.basis
                .eval((u - en.s0) / en.h, (v - en.t0) / en.h, &mut be[..n]);
            let f = w * ar * pe.support.jacobian(u, v) * es.h * es.h * g;
            let (vis, unocc) = out.split_at_mut(n * n);
            for a in 0..n {
                let fa = f * br[a];
                for b in 0..n {
                    unocc[a * n + b] += fa * be[b];
                }
            }
            if visible {
                for a in 0..n {
                    let fa = f * br[a];
                    for b in 0..n {
                        vis[a * n + b] += fa * be[b];
                    }
                }
            }
        }
    }

    /// The `q×q` × `q×q` Gauss rule of a sub-pair, added into `out` (visible block,
    /// then unoccluded block). `cap`: the emitter's polygon, whose exact point form
    /// factor bounds each receiver point's emitter sum (the sums of the other entries
    /// are scaled alike; [`Self::near_limit`]).
    #[allow(clippy::too_many_arguments)]
    fn regular(
        &self,
        rn: &Region,
        en: &Region,
        rs: &Region,
        es: &Region,
        with_vis: bool,
        cap: Option<&[DVec3]>,
        out: &mut [f64],
        evals: &mut u64,
        rays: &mut Rays<'_>,
    ) {
        let n = self.basis.n();
        let pr = &self.patches[rs.patch];
        let pe = &self.patches[es.patch];
        let (xr, vr) = self.side_samples(pr, rn, rs, false, false, false);
        let (xe, ve) = self.side_samples(pe, en, es, true, rs == es, false);
        // Emitter integrals at one receiver point: with visibility, unoccluded.
        let mut tv = vec![0.0; n];
        let mut tu = vec![0.0; n];
        let (vis, unocc) = out.split_at_mut(n * n);
        for (i, sr) in xr.iter().enumerate() {
            if sr.w == 0.0 {
                continue;
            }
            tv.iter_mut().for_each(|v| *v = 0.0);
            tu.iter_mut().for_each(|v| *v = 0.0);
            for (j, se) in xe.iter().enumerate() {
                if se.w == 0.0 {
                    continue;
                }
                *evals += 1;
                let g = kernel(sr.x, sr.n, se.x, se.n);
                if g == 0.0 {
                    continue;
                }
                let f = g * se.w;
                let psi = &ve[j * n..][..n];
                for b in 0..n {
                    tu[b] += f * psi[b];
                }
                if !with_vis || self.shadow(sr.v, pr, se.v, pe, rays) {
                    for b in 0..n {
                        tv[b] += f * psi[b];
                    }
                }
            }
            // `tu[0]` (ψ₀ = 1) is the rule's `F(x → es)`, which cannot exceed the
            // exact form factor to the emitter's polygon.
            if let Some(poly) = cap
                && let Ok(bound) = point_to_polygon(sr.x, sr.n, poly)
                && tu[0] > bound
            {
                let k = bound / tu[0];
                tu.iter_mut().chain(tv.iter_mut()).for_each(|v| *v *= k);
            }
            for a in 0..n {
                let fa = sr.w * vr[i * n + a];
                for b in 0..n {
                    vis[a * n + b] += fa * tv[b];
                    unocc[a * n + b] += fa * tu[b];
                }
            }
        }
    }

    /// The `q×q` Gauss samples of a sub-square: point, normal, ṽ point and weight
    /// (receivers: the whole support's `area·h²`, VirtualMesh §4.2 "S is a receiver";
    /// emitters: Gauss weight × area element × real fraction of the point's Gauss cell,
    /// VirtualMesh §4.2), and the node's basis values there. `alt`: the `(q+1)`-point
    /// rule; `far`: the far pairs' probe rule (when one is configured).
    fn side_samples(
        &self,
        p: &Patch,
        node: &Region,
        sub: &Region,
        emitter: bool,
        alt: bool,
        far: bool,
    ) -> (Vec<Sample>, Vec<f64>) {
        let n = self.basis.n();
        let (gx, gw, gc) = match (&self.far, alt) {
            (_, true) => (&self.alt.0, &self.alt.1, &self.alt.2),
            (Some(f), false) if far => (&f.0, &f.1, &f.2),
            _ => (&self.gx, &self.gw, &self.gc),
        };
        let q = gx.len();
        let same = node == sub && std::ptr::eq(gx, &self.gx);
        let mut pts = Vec::with_capacity(q * q);
        let mut vals = vec![0.0; q * q * n];
        let a = p.support.area * sub.h * sub.h;
        let cov = if emitter && p.support.mask.is_some() {
            p.support.coverage(sub.s0, sub.t0, sub.h)
        } else {
            Coverage::Full
        };
        for jt in 0..q {
            for js in 0..q {
                let s = sub.s0 + sub.h * gx[js];
                let t = sub.t0 + sub.h * gx[jt];
                let w = match (emitter, cov) {
                    (_, Coverage::Empty) => 0.0,
                    (false, _) => gw[js] * gw[jt] * a,
                    (true, Coverage::Full) => {
                        gw[js] * gw[jt] * sub.h * sub.h * p.support.jacobian(s, t)
                    }
                    (true, Coverage::Partial) => weight_in(p, sub, (gx, gw, gc), js, jt),
                };
                let (x, nx) = p.support.point_normal(s, t);
                pts.push(Sample {
                    x,
                    n: nx,
                    v: if p.support.mask.is_some() {
                        p.support.visibility_point(s, t)
                    } else {
                        x
                    },
                    w,
                });
                let dst = &mut vals[(jt * q + js) * n..][..n];
                if same {
                    dst.copy_from_slice(&self.table[(jt * q + js) * n..][..n]);
                } else {
                    self.basis
                        .eval((s - node.s0) / node.h, (t - node.t0) / node.h, dst);
                }
            }
        }
        (pts, vals)
    }

    /// The oracle estimate of a node pair (see the module docs); also returns the
    /// mean sampled kernel times `|R| |E|` (an estimate of the unnormalized form
    /// factor integral, used by brightness-weighted refinement).
    pub fn estimate(&self, r: &Region, e: &Region) -> f64 {
        let nu = self.basis.vanishing_moments().max(1);
        let m = nu + 1;
        let pr = &self.patches[r.patch];
        let pe = &self.patches[e.patch];
        let pos: Vec<f64> = (0..m).map(|i| (i as f64 + 0.5) / m as f64).collect();
        // A curved self pair samples the emitter a quarter cell off the receiver's
        // points: the kernel is undefined (zero) at coincident points and would fake
        // a discontinuity on the diagonal.
        let shift = if r == e { 0.25 / m as f64 } else { 0.0 };
        let grid = |p: &Patch, g: &Region, d: f64| -> Vec<(DVec3, DVec3, DVec3)> {
            (0..m * m)
                .map(|i| {
                    let (s, t) = (g.s0 + g.h * (pos[i % m] + d), g.t0 + g.h * (pos[i / m] + d));
                    let (x, n) = p.support.point_normal(s, t);
                    let v = if p.support.mask.is_some() {
                        p.support.visibility_point(s, t)
                    } else {
                        x
                    };
                    (x, n, v)
                })
                .collect()
        };
        let xs = grid(pr, r, 0.0);
        let ys = grid(pe, e, shift);
        let mut k = vec![0.0; m * m * m * m];
        let mut rays = 0u64;
        // Shaft culling as for the blocks: interior grid points, rays only where the
        // kernel is positive.
        let with_vis = self.oracle_visibility
            && self.visibility != Visibility::Off
            && self
                .shaft_candidates(r, e, None)
                .is_none_or(|c| !c.is_empty());
        for (i, (x, nx, vx)) in xs.iter().enumerate() {
            for (j, (y, ny, vy)) in ys.iter().enumerate() {
                let mut g = kernel(*x, *nx, *y, *ny);
                if g > 0.0 && with_vis && !self.visible(*vx, pr, *vy, pe, &mut rays) {
                    g = 0.0;
                }
                k[i * m * m + j] = g;
            }
        }
        self.kernel_evals
            .fetch_add((m * m * m * m) as u64, Ordering::Relaxed);
        self.rays.fetch_add(rays, Ordering::Relaxed);
        // Finite-difference coefficients of order nu.
        let coef: Vec<f64> = (0..=nu)
            .map(|i| {
                let b = binom(nu, i);
                if (nu - i).is_multiple_of(2) { b } else { -b }
            })
            .collect();
        let norm = 2f64.powi(nu as i32 - 1);
        // Index of sample (i0, i1, i2, i3) = ((i3*m + i2)*m + i1)*m + i0 with
        // receiver (s = i0, t = i1), emitter (u = i2, v = i3).
        let stride = [1, m, m * m, m * m * m];
        let mut best: f64 = 0.0;
        for &st in &stride {
            let mut sum = 0.0;
            let mut cnt = 0;
            for idx in 0..m * m * m * m {
                // Base points with coordinate 0 along `axis`.
                if (idx / st) % m != 0 {
                    continue;
                }
                let mut d = 0.0;
                for (i, c) in coef.iter().enumerate() {
                    d += c * k[idx + i * st];
                }
                sum += d.abs() / norm;
                cnt += 1;
            }
            best = best.max(sum / cnt as f64);
        }
        let ar = pr.support.area * r.h * r.h;
        let ae = pe.support.area * e.h * e.h;
        best * (ar * ae).sqrt()
    }
}

fn binom(n: usize, k: usize) -> f64 {
    let mut r = 1.0;
    for i in 0..k {
        r = r * (n - i) as f64 / (i + 1) as f64;
    }
    r
}

fn sample_points(p: &Patch, r: &Region) -> Vec<DVec3> {
    let mut v = p.support.corners(r.s0, r.t0, r.h).to_vec();
    if !p.support.is_affine() {
        v.push(p.support.point(r.s0 + 0.5 * r.h, r.t0));
        v.push(p.support.point(r.s0 + 0.5 * r.h, r.t0 + r.h));
    }
    v
}

/// Weight of point `(ks, kt)` of a tensor rule `(x, w, c)` on an emitter sub-square:
/// rule weight × area element × real fraction of the point's cell `[c_k, c_{k+1}]²`.
pub(crate) fn weight_in(
    pe: &Patch,
    es: &Region,
    rule: (&[f64], &[f64], &[f64]),
    ks: usize,
    kt: usize,
) -> f64 {
    let (x, w, c) = rule;
    let (s, t) = (es.s0 + es.h * x[ks], es.t0 + es.h * x[kt]);
    let mut wt = w[ks] * w[kt] * es.h * es.h * pe.support.jacobian(s, t);
    if pe.support.mask.is_some() {
        wt *= pe.support.real_fraction_rect(
            es.s0 + es.h * c[ks],
            es.t0 + es.h * c[kt],
            es.h * w[ks],
            es.h * w[kt],
        );
    }
    wt
}

/// One quadrature sample of a side: point, unit normal, the point used for
/// visibility (ṽ, VirtualMesh §4.1) and the weight.
struct Sample {
    x: DVec3,
    n: DVec3,
    v: DVec3,
    w: f64,
}

/// The exactly known unoccluded entries of a block (see [`TransferCtx::exact_parts`]).
struct ExactParts {
    /// `∫_R ∫_E G` (= `|R| F_RE`).
    constant: f64,
    /// `∫_R ψ_a F(x → E)`, `a = 0..n` (empty for piecewise constants, `n = 1`).
    receiver: Vec<f64>,
    /// `∫_E ψ_b F(y → R)`, `b = 0..n`, over the emitter node's real part (`None` where
    /// it has no exact form: an arc crossing the node).
    emitter: Option<Vec<f64>>,
}

impl ExactParts {
    /// `(index into the n × n block, exact value)` of every known entry: `[0, 0]`,
    /// `[a, 0]` and `[0, b]`.
    fn entries(&self, n: usize) -> impl Iterator<Item = (usize, f64)> + '_ {
        std::iter::once((0, self.constant))
            .chain((1..n).map(move |a| (a * n, self.receiver[a])))
            .chain(
                self.emitter
                    .iter()
                    .flat_map(move |m| (1..n).map(move |b| (b, m[b]))),
            )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hierarchy::NodeKey;
    use crate::{BasisKind, Prepared, SolverConfig};

    /// The visibility probe of far pairs against the full rule's own rays on the
    /// Cornell box's cells of levels 0–2 (M3): where both agree on the class
    /// (visible, blocked) and where the probe disagrees within itself (the block then
    /// shoots its own rays) the blocks are bitwise those of the full rule; the pairs
    /// the probe calls unanimous but the full rule sees partly shadowed (an occluder
    /// between the probe rays) are few; and the probe saves rays.
    #[test]
    fn far_probes_agree_with_the_full_rule() {
        let scene = wavelux_scene::builtin::cornell_box();
        let cfg = |probe| SolverConfig {
            basis: BasisKind::Multiwavelet(3),
            far_probe_points: probe,
            ..SolverConfig::default()
        };
        let (pa, pb) = (
            Prepared::new(&scene, &cfg(Some(2))).unwrap(),
            Prepared::new(&scene, &cfg(None)).unwrap(),
        );
        let (probed, full) = (pa.transfer().unwrap(), pb.transfer().unwrap());
        let np = probed.patches.len();
        let mut cells: Vec<NodeKey> = Vec::new();
        for p in 0..np {
            let root = NodeKey::root(p);
            cells.push(root);
            for c in 0..4 {
                cells.push(root.child(c));
                cells.push(root.child(c).child(3 - c));
            }
        }
        let (mut pairs, mut unanimous, mut missed) = (0usize, 0usize, 0usize);
        for r in &cells {
            for e in &cells {
                let (rr, er) = (r.region(), e.region());
                if r.patch == e.patch || !probed.is_far(&rr, &er) || !probed.facing(&rr, &er) {
                    continue;
                }
                pairs += 1;
                let (a, sa) = probed.block_seen(&rr, &er);
                let (b, sb) = full.block_seen(&rr, &er);
                let bitwise = a.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits());
                if sa == LinkVisibility::Partial {
                    // The probe disagreed: the block shot its own rays.
                    assert!(sb == sa && bitwise, "{r:?} {e:?}");
                    continue;
                }
                unanimous += 1;
                if sa == sb {
                    assert!(bitwise, "{r:?} {e:?}");
                } else {
                    assert_eq!(sb, LinkVisibility::Partial, "{r:?} {e:?}");
                    missed += 1;
                }
            }
        }
        let (ra, rb) = (
            probed.rays.load(Ordering::Relaxed),
            full.rays.load(Ordering::Relaxed),
        );
        println!(
            "{pairs} far pairs, {unanimous} unanimous probes, {missed} of them partly shadowed for the full rule; rays {ra} vs {rb}"
        );
        assert!(
            pairs > 100 && unanimous > pairs / 2,
            "{pairs} pairs, {unanimous} unanimous"
        );
        assert!(missed * 20 <= unanimous, "{missed} of {unanimous}");
        assert!(ra * 2 < rb, "rays {ra} (probed) vs {rb}");
    }
}
