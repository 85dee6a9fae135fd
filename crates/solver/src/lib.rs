//! wavelux-solver: Galerkin wavelet radiosity on surfaces (Ziegler ch. 2–4).
//!
//! The radiosity equation `B(x) = E(x) + ρ(x) ∫ G(x,y) V(x,y) B(y) dA_y` (Ziegler
//! §2.1; `E` is the emitted exitance of `wavelux-scene`) is discretized with
//! orthonormal tree bases (Haar, Alpert multiwavelets `M_k`) or the non-tree CDV-D4
//! basis ([`cdv`]) on the unit-square support of every surface side, and compressed by top-down refinement of links
//! between element pairs (Hanrahan et al. 1991, Gortler et al. 1993, Ziegler §2.2.3)
//! driven by an oracle (Ziegler §2.4.2, §3.3.2). The hierarchical system with
//! push/pull is the non-standard wavelet representation (see [`basis`] for the
//! correspondence) and is solved by Picard, hierarchical Gauss–Seidel, GMRES or CGNR
//! (`wavelux-linear`, Ziegler §2.3, §4.2).
//!
//! Modules:
//! - [`support`]: unit-square supports (exact, or Virtual Mesh virtual supports of
//!   complex polygons and curved patches) and patches (one per lit side);
//! - [`mask`]: trim masks of virtual supports (real/virtual points, exact coverage
//!   and real-area fractions, nearest real points; VirtualMesh §4, §5.4);
//! - [`basis`]: 2D tree bases from `wavelux-mra`, two-scale (push/pull) matrices;
//! - [`exact`]: exact unoccluded transfer of planar pieces (contour integrals, Lambert's
//!   point form factor, adaptive moments) that link blocks are corrected to;
//! - [`transfer`]: kernel, transfer blocks (regular Gauss, singular Sauter–Schwab
//!   rules for touching elements, visibility in quadrature or fractional), oracle;
//! - [`hierarchy`]: nodes, links, refinement, the compiled level-ordered hierarchy;
//! - [`closure`]: closure links that make every leaf's form-factor row sum exactly what
//!   its links see (so closed enclosures conserve energy at every level);
//! - [`cluster`]: hierarchical radiosity with clustering for the initial links (a
//!   bounding-volume hierarchy of the patches, cluster links by a conservative
//!   transport bound; Smits, Arvo & Greenberg 1994);
//! - [`cdv`]: Cohen–Daubechies–Vial wavelets (overlapping supports): vertex links,
//!   deduplicated refinement, push/pull by the CDV two-scale rows, its own system;
//! - [`system`]: matrix-free `K`, `Kᵀ` and Gauss–Seidel sweeps (rayon, deterministic);
//! - [`solution`]: [`Solution`], [`Energy`], [`Statistics`];
//! - [`estimate`]: the a-posteriori error estimate (fine-quadrature residual
//!   transported by the discrete operator) per leaf, per link and for the whole
//!   function;
//! - [`target`]: solving to a target error (refine–solve–estimate rounds with
//!   Dörfler marking of the links' error indicators);
//! - [`escape`]: escaped power measured by rays (independent of the operator);
//! - [`standard`]: the standard decomposition of the same links (tree wavelet basis,
//!   one assembled sparse matrix; Ziegler §2.2.3, Glossy §3.5), chosen by
//!   [`SolverConfig::decomposition`];
//! - [`shoot`]: the Virtual Mesh's linkless hierarchical shooting solver (VirtualMesh
//!   §5, Algorithm 1) with its own element trees, producing the same [`Solution`].
//!
//! Entry points: [`solve`] with a [`SolverConfig`] (gathering over links) and
//! [`shoot::shoot`] with a [`shoot::ShootConfig`] (linkless shooting).

pub mod basis;
pub mod cdv;
pub mod closure;
pub mod cluster;
pub mod error;
pub mod escape;
pub mod estimate;
pub mod exact;
pub mod hierarchy;
pub mod mask;
pub mod matvec;
pub mod replay;
pub(crate) mod shaft;
pub mod shoot;
pub mod solution;
pub mod standard;
pub mod support;
pub mod system;
pub mod target;
pub mod transfer;

use std::time::{Duration, Instant};

use glam::DVec3;
use wavelux_geometry::Accel;
use wavelux_geometry::backend::{Occluder, OcclusionBackend};
use wavelux_geometry::primitive::{ComplexPolygon, Parallelogram, PlaneFrame, Primitive, Triangle};
use wavelux_geometry::{Edge2, TrimLoop, TrimRegion};
use wavelux_linear::backend::{BackendOperator, MatVecBackend};
use wavelux_linear::{
    Convergence, IdentityMinus, IterationRecord, Operator, SolverOptions, StopReason, Work, cgnr,
    gmres, picard,
};
use wavelux_scene::Scene;

pub use basis::{BasisKind, TreeBasis};
pub use error::SolverError;
pub use estimate::{
    DEFAULT_VIS_CELLS, ErrorEstimate, EstimateCache, EstimateOptions, estimate, estimate_cached,
};
pub use hierarchy::{Hierarchy, LinkRec, NodeKey, Oracle, RefineParams, SplitPolicy};
pub use mask::{Coverage, Mask};
pub use solution::{Energy, Solution, Statistics};
pub use standard::{Decomposition, StandardSystem};
pub use support::{Patch, PatchSet, Side, Support, SupportMap, build_patches, build_patches_with};
pub use system::System;
pub use target::{Choice, Round, TargetConfig, TargetOutcome, solve_to_target, solve_to_target_on};
pub use transfer::{LinkVisibility, TransferCtx, TransferOptions, Visibility};
pub use wavelux_param::ParamKind;

/// The linear solver of the discrete system.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum LinearMethod {
    /// Picard (Jacobi) iteration `x ← b + K x` (Ziegler §3.3.5).
    Picard,
    /// Hierarchical Gauss–Seidel: sweeps patch by patch over their links.
    GaussSeidel,
    /// Restarted GMRES on `(I − K) x = b`.
    Gmres {
        /// Restart length.
        restart: usize,
    },
    /// CGNR on `(I − K) x = b`.
    Cgnr,
}

/// The multigrid-like refine–solve loop (Ziegler Alg. 2.3.4): `stages` refine–solve
/// rounds with thresholds `eps · factor^(stages−1−i)`; each round refines the links of
/// the previous one and starts from its solution.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Multigrid {
    /// Number of rounds (≥ 1).
    pub stages: usize,
    /// Ratio between consecutive thresholds (> 1).
    pub factor: f64,
}

/// Solver configuration. `Default` gives Haar, `ε = 1e-3`, 5 levels, kernel
/// smoothness oracle, visibility in quadrature with 3 Gauss points per axis, Picard
/// with up to 200 iterations to a relative residual of `1e-10`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SolverConfig {
    /// Basis.
    pub basis: BasisKind,
    /// Refinement threshold `ε` (dimensionless for the kernel oracle, W/m² for the
    /// brightness oracle). `> 0`, finite.
    pub eps: f64,
    /// Deepest element level (`≤ 20`; for CDV the finest dyadic level, `≥ 2`, so the
    /// patch has at most `4^max_level` functions as with Haar).
    pub max_level: u8,
    /// Smallest element area (scene units², `≥ 0`).
    pub min_area: f64,
    /// Oracle.
    pub oracle: Oracle,
    /// Split policy of refined links.
    pub split: SplitPolicy,
    /// Visibility mode of transfer blocks.
    pub visibility: Visibility,
    /// Whether oracle samples include visibility (shadow boundaries refine).
    pub oracle_visibility: bool,
    /// Gauss points per axis (`n_samp`, `1..=16`).
    pub quad_points: usize,
    /// Gauss points per axis of the visibility probe of far pairs of unmasked affine
    /// nodes (`1..=16`; none, or from `quad_points` on, no probe): see
    /// [`transfer::FAR_RATIO`]. Off by default until its effect on the default run's
    /// texel error is measured.
    pub far_probe_points: Option<usize>,
    /// Order of the singular rules (`1..=8`).
    pub singular_order: usize,
    /// Admissibility factor of the regular rule (`≥ 0.5`).
    pub near_field: f64,
    /// Maximum recursive quadrature splits of near pairs (`≤ 8`).
    pub max_split_depth: u32,
    /// Linear method.
    pub linear_method: LinearMethod,
    /// Maximum iterations (sweeps) per channel solve (`≥ 1`).
    pub max_iterations: usize,
    /// Relative residual tolerance (`≥ 0`, finite).
    pub tolerance: f64,
    /// Optional refine–solve loop.
    pub multigrid: Option<Multigrid>,
    /// Wavelet decomposition the linear method iterates on (same links and solution
    /// up to rounding). With [`Decomposition::Standard`] the assembly of the standard
    /// operator counts into [`Statistics::time_refine`].
    pub decomposition: Decomposition,
    /// Clustering of the initial links ([`cluster`], Smits, Arvo & Greenberg 1994):
    /// `Some(tol)` links groups of surfaces whose conservative transport bound
    /// `ρ_R · B̂_E · F̄(R ← E)` is at most `tol` times the scene's predicted mean
    /// reflected radiosity (dimensionless, `> 0`, finite) by one cluster link instead
    /// of all their root pairs; `None` (the default) links every root pair. Not with
    /// the CDV basis or the standard decomposition.
    pub cluster: Option<f64>,
}

impl Default for SolverConfig {
    fn default() -> Self {
        Self {
            basis: BasisKind::Haar,
            eps: 1e-3,
            max_level: 5,
            min_area: 0.0,
            oracle: Oracle::KernelSmoothness,
            split: SplitPolicy::Both,
            visibility: Visibility::InQuadrature,
            oracle_visibility: true,
            quad_points: 3,
            far_probe_points: None,
            singular_order: 4,
            near_field: 1.0,
            max_split_depth: 3,
            linear_method: LinearMethod::Picard,
            max_iterations: 200,
            tolerance: 1e-10,
            multigrid: None,
            decomposition: Decomposition::NonStandard,
            cluster: None,
        }
    }
}

fn bad(field: &'static str, value: impl std::fmt::Display, reason: &'static str) -> SolverError {
    SolverError::InvalidConfig {
        field,
        value: value.to_string(),
        reason,
    }
}

impl SolverConfig {
    /// Checks every field against its documented range.
    ///
    /// # Errors
    /// [`SolverError::InvalidConfig`] naming the first bad field.
    pub fn validate(&self) -> Result<(), SolverError> {
        if !(self.eps.is_finite() && self.eps > 0.0) {
            return Err(bad("eps", self.eps, "must be finite and > 0"));
        }
        if self.max_level > 20 {
            return Err(bad("max_level", self.max_level, "must be <= 20"));
        }
        if !(self.min_area.is_finite() && self.min_area >= 0.0) {
            return Err(bad("min_area", self.min_area, "must be finite and >= 0"));
        }
        if !(1..=16).contains(&self.quad_points) {
            return Err(bad("quad_points", self.quad_points, "must be in 1..=16"));
        }
        if let Some(p) = self.far_probe_points
            && !(1..=16).contains(&p)
        {
            return Err(bad("far_probe_points", p, "must be in 1..=16"));
        }
        if !(1..=8).contains(&self.singular_order) {
            return Err(bad(
                "singular_order",
                self.singular_order,
                "must be in 1..=8",
            ));
        }
        if !(self.near_field.is_finite() && self.near_field >= 0.5) {
            return Err(bad(
                "near_field",
                self.near_field,
                "must be finite and >= 0.5",
            ));
        }
        if self.max_split_depth > 8 {
            return Err(bad("max_split_depth", self.max_split_depth, "must be <= 8"));
        }
        if self.max_iterations == 0 {
            return Err(bad("max_iterations", 0, "must be >= 1"));
        }
        if !(self.tolerance.is_finite() && self.tolerance >= 0.0) {
            return Err(bad("tolerance", self.tolerance, "must be finite and >= 0"));
        }
        if let LinearMethod::Gmres { restart: 0 } = self.linear_method {
            return Err(bad("linear_method.restart", 0, "must be >= 1"));
        }
        if self.basis == BasisKind::Cdv {
            if self.max_level < cdv::CDV_MIN_LEVEL {
                return Err(bad(
                    "max_level",
                    self.max_level,
                    "CDV needs max_level >= 2 (4 functions per axis on its coarsest level)",
                ));
            }
            if self.split != SplitPolicy::Both {
                return Err(bad(
                    "split",
                    format!("{:?}", self.split),
                    "CDV refines vertex pairs of equal level (non-standard form) only",
                ));
            }
            if self.decomposition != Decomposition::NonStandard {
                return Err(bad(
                    "decomposition",
                    format!("{:?}", self.decomposition),
                    "CDV is solved in the non-standard form only",
                ));
            }
        }
        if let Some(t) = self.cluster {
            if !(t.is_finite() && t > 0.0) {
                return Err(bad("cluster", t, "must be finite and > 0"));
            }
            if self.basis == BasisKind::Cdv || self.decomposition != Decomposition::NonStandard {
                return Err(bad(
                    "cluster",
                    t,
                    "cluster links are applied by the non-standard tree-basis system only",
                ));
            }
        }
        if let Some(m) = self.multigrid {
            if m.stages == 0 {
                return Err(bad("multigrid.stages", 0, "must be >= 1"));
            }
            if !(m.factor.is_finite() && m.factor > 1.0) {
                return Err(bad("multigrid.factor", m.factor, "must be finite and > 1"));
            }
        }
        Ok(())
    }

    fn transfer_options(&self) -> TransferOptions {
        TransferOptions {
            quad_points: self.quad_points,
            far_probe_points: self.far_probe_points,
            singular_order: self.singular_order,
            near_field: self.near_field,
            max_split_depth: self.max_split_depth,
            visibility: self.visibility,
            oracle_visibility: self.oracle_visibility,
        }
    }
}

/// Everything built once per scene: patches, accelerator, basis.
#[derive(Debug)]
pub struct Prepared {
    /// Patches.
    pub patches: PatchSet,
    /// Visibility accelerator over the supports (in the normalised frame).
    pub accel: Accel,
    /// `(centre, size)` of the normalised frame: the accelerator holds `(p − c)/s`.
    pub frame: (DVec3, f64),
    /// Tree basis; for [`BasisKind::Cdv`] the `M2` basis whose cell-pair transfer
    /// blocks the CDV coefficients are assembled from (see [`cdv`]).
    pub basis: TreeBasis,
    /// Configuration.
    pub config: SolverConfig,
    setup_time: Duration,
}

impl Prepared {
    /// Validates the configuration, builds patches (typed errors for unsupported
    /// surfaces), the BVH and the basis.
    ///
    /// # Errors
    /// [`SolverError`] variants for bad configuration, scene or basis.
    pub fn new(scene: &Scene, config: &SolverConfig) -> Result<Self, SolverError> {
        Self::with_kind(scene, config, ParamKind::EqualArea)
    }

    /// [`Prepared::new`] with the parametrization kind of curved supports
    /// ([`ParamKind::Natural`] for the VirtualMesh Table 3 comparison).
    ///
    /// # Errors
    /// As [`Prepared::new`].
    pub fn with_kind(
        scene: &Scene,
        config: &SolverConfig,
        kind: ParamKind,
    ) -> Result<Self, SolverError> {
        let t0 = Instant::now();
        config.validate()?;
        let patches = build_patches_with(scene, kind)?;
        if patches.patches.is_empty() {
            return Err(SolverError::InvalidScene(
                "the scene has no surfaces".into(),
            ));
        }
        // Normalise into a unit-size frame for the BVH (its f32 traversal is not
        // scale-independent: occlusion is missed for scenes of size ~1e-4). The
        // factor is a power of two, so unit-size scenes are untouched and scaled copies
        // of a scene by powers of two see bitwise the same rays.
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        for s in &patches.pieces {
            for p in s.corners(0.0, 0.0, 1.0) {
                lo = lo.min(p);
                hi = hi.max(p);
            }
            if let SupportMap::Disk { center, radius, .. } = s.map {
                lo = lo.min(center - DVec3::splat(radius));
                hi = hi.max(center + DVec3::splat(radius));
            }
            if !s.is_planar() {
                let (c, r) = s.bounding_sphere(0.0, 0.0, 1.0);
                lo = lo.min(c - DVec3::splat(r));
                hi = hi.max(c + DVec3::splat(r));
            }
        }
        let center = DVec3::ZERO;
        let diag = (hi - lo).length();
        if !(diag.is_finite() && diag > 0.0) {
            return Err(SolverError::InvalidScene("degenerate scene bounds".into()));
        }
        // A power of two, so the normalisation is exact: diag / size ∈ [1, 2).
        let size = 2f64.powi(diag.log2().floor() as i32);
        let frame = (center, size);
        let nrm = |p: DVec3| (p - center) / size;
        // Surface of each piece (pieces of one surface are consecutive).
        let mut piece_surface = vec![0usize; patches.pieces.len()];
        for p in &patches.patches {
            piece_surface[p.prim as usize] = p.surface;
        }
        let scale = glam::DMat4::from_scale(DVec3::splat(1.0 / size))
            * glam::DMat4::from_translation(-center);
        let prims: Vec<Primitive> = patches
            .pieces
            .iter()
            .zip(&piece_surface)
            .map(|(s, &surf)| -> Result<Primitive, SolverError> {
                let map_err =
                    |e: wavelux_geometry::GeometryError| SolverError::InvalidScene(e.to_string());
                if s.mask.is_some() || !s.is_planar() {
                    // A virtual or curved support: the blocker is the true (trimmed)
                    // surface (VirtualMesh §4.2, "S is a blocker"), one per surface.
                    let sf = &scene.surfaces[surf];
                    let shape = sf.shape.transformed(&scale).ok_or_else(|| {
                        SolverError::InvalidScene(format!(
                            "surface {:?} cannot be normalised for the accelerator",
                            sf.name
                        ))
                    })?;
                    let mut v = shape
                        .primitives("scene", &sf.name)
                        .map_err(|e| SolverError::InvalidScene(e.to_string()))?;
                    if v.len() != 1 {
                        return Err(SolverError::InvalidScene(format!(
                            "surface {:?}: expected one exact primitive, got {}",
                            sf.name,
                            v.len()
                        )));
                    }
                    return Ok(v.remove(0));
                }
                Ok(match s.map {
                    SupportMap::Parallelogram {
                        origin,
                        edge_u,
                        edge_v,
                    } => Primitive::Parallelogram(
                        Parallelogram::new(nrm(origin), edge_u / size, edge_v / size)
                            .map_err(map_err)?,
                    ),
                    SupportMap::Triangle { a, b, c } => {
                        Primitive::Triangle(Triangle::new(nrm(a), nrm(b), nrm(c)).map_err(map_err)?)
                    }
                    SupportMap::Disk {
                        center,
                        u,
                        v,
                        radius,
                    } => {
                        let frame = PlaneFrame::from_axes(nrm(center), u, v).map_err(map_err)?;
                        let edge = Edge2::arc(
                            glam::DVec2::ZERO,
                            radius / size,
                            0.0,
                            std::f64::consts::TAU,
                        )
                        .map_err(map_err)?;
                        let region =
                            TrimRegion::new(vec![TrimLoop::new(vec![edge]).map_err(map_err)?])
                                .map_err(map_err)?;
                        Primitive::Polygon(Box::new(
                            ComplexPolygon::new(frame, region).map_err(map_err)?,
                        ))
                    }
                    SupportMap::Mapped { .. } => {
                        return Err(SolverError::InvalidScene(
                            "curved support without its surface".into(),
                        ));
                    }
                })
            })
            .collect::<Result<_, _>>()?;
        let accel = Accel::build(prims).map_err(|e| SolverError::Dependency {
            what: "geometry",
            message: e.to_string(),
        })?;
        let basis = match config.basis {
            BasisKind::Cdv => TreeBasis::new(BasisKind::Multiwavelet(cdv::CDV_QUADRATURE_P))?,
            kind => TreeBasis::new(kind)?,
        };
        Ok(Self {
            patches,
            accel,
            frame,
            basis,
            config: *config,
            setup_time: t0.elapsed(),
        })
    }

    /// Wall time of [`Prepared::new`].
    pub fn setup_time(&self) -> Duration {
        self.setup_time
    }

    /// A transfer context over these patches.
    ///
    /// # Errors
    /// [`SolverError::Dependency`] if a quadrature rule cannot be built.
    pub fn transfer(&self) -> Result<TransferCtx<'_>, SolverError> {
        TransferCtx::new(
            &self.patches.patches,
            &self.accel,
            self.frame,
            &self.basis,
            self.config.transfer_options(),
        )
    }

    /// [`Self::transfer`] with the transfer blocks' shadow rays answered by an
    /// occluder prepared by `backend` for [`Self::accel`] ([`TransferCtx::with_occluder`]):
    /// the occluder (`None` without a backend) and, when the backend could not
    /// prepare one, its error (the CPU then answers every ray).
    pub fn occluder<'a>(
        &'a self,
        backend: Option<&dyn OcclusionBackend>,
    ) -> (Option<Box<dyn Occluder + 'a>>, Option<String>) {
        match backend.map(|b| (b.name(), b.occluder(&self.accel))) {
            None => (None, None),
            Some((_, Ok(o))) => (Some(o), None),
            Some((name, Err(e))) => (None, Some(format!("{name}: {e}"))),
        }
    }

    /// Refinement parameters of the configuration with threshold `eps`.
    pub fn refine_params(&self, eps: f64) -> RefineParams {
        RefineParams {
            eps,
            max_level: self.config.max_level,
            min_area: self.config.min_area,
            oracle: self.config.oracle,
            split: self.config.split,
        }
    }

    /// Whether every patch has equal channels (one solve serves all three).
    pub fn is_grey(&self) -> bool {
        self.patches.patches.iter().all(|p| {
            p.reflectance.iter().all(|&r| r == p.reflectance[0])
                && p.emission.iter().all(|&e| e == p.emission[0])
        })
    }
}

/// Solves one channel with a linear method; `x0` defaults to the emission `b`
/// (Ziegler §4.2.2's initial guess). `reference` adds error records.
///
/// # Errors
/// [`SolverError::Linear`] if the linear solver fails.
pub fn solve_channel(
    system: &System,
    ch: usize,
    method: LinearMethod,
    max_iterations: usize,
    tolerance: f64,
    x0: Option<Vec<f64>>,
    reference: Option<Vec<f64>>,
) -> Result<(Vec<f64>, Convergence), SolverError> {
    let b = system.source(ch);
    linear_solve(
        &system.channel(ch),
        &b,
        method,
        max_iterations,
        tolerance,
        x0,
        reference,
        &|b: &[f64], x: &mut [f64]| system.gauss_seidel_sweep(ch, b, x),
    )
}

/// Solves `x = b + K x` with a linear method (shared by the tree and CDV systems);
/// `sweep(b, x)` is one Gauss–Seidel sweep of the system.
#[allow(clippy::too_many_arguments)]
pub(crate) fn linear_solve<K: Operator>(
    k: &K,
    b: &[f64],
    method: LinearMethod,
    max_iterations: usize,
    tolerance: f64,
    x0: Option<Vec<f64>>,
    reference: Option<Vec<f64>>,
    sweep: &dyn Fn(&[f64], &mut [f64]),
) -> Result<(Vec<f64>, Convergence), SolverError> {
    let x0 = x0.unwrap_or_else(|| b.to_vec());
    let mut opts = SolverOptions::default()
        .with_max_iterations(max_iterations)
        .with_tolerance(tolerance)
        .with_initial_guess(x0.clone());
    if let Some(r) = reference.clone() {
        opts = opts.with_reference(r);
    }
    if let LinearMethod::Gmres { restart } = method {
        opts = opts.with_restart(restart);
    }
    let lin = |e: wavelux_linear::LinearError| SolverError::Linear(e.to_string());
    let solve = match method {
        LinearMethod::Picard => picard(k, b, &opts).map_err(lin)?,
        LinearMethod::Gmres { .. } => gmres(&IdentityMinus::new(k), b, &opts).map_err(lin)?,
        LinearMethod::Cgnr => cgnr(&IdentityMinus::new(k), b, &opts).map_err(lin)?,
        LinearMethod::GaussSeidel => {
            return Ok(gauss_seidel(
                k,
                sweep,
                b,
                x0,
                max_iterations,
                tolerance,
                reference,
            ));
        }
    };
    Ok((solve.x, solve.history))
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

fn fixed_point_residual<K: Operator>(k: &K, b: &[f64], x: &[f64]) -> f64 {
    let mut kx = vec![0.0; x.len()];
    k.apply(x, &mut kx);
    let r: Vec<f64> = (0..x.len()).map(|i| b[i] + kx[i] - x[i]).collect();
    norm(&r)
}

fn gauss_seidel<K: Operator>(
    k: &K,
    sweep: &dyn Fn(&[f64], &mut [f64]),
    b: &[f64],
    mut x: Vec<f64>,
    max_iterations: usize,
    tolerance: f64,
    reference: Option<Vec<f64>>,
) -> (Vec<f64>, Convergence) {
    let t0 = Instant::now();
    let bn = norm(b);
    let scale = if bn > 0.0 { bn } else { 1.0 };
    let err = |x: &[f64]| {
        reference.as_ref().map(|r| {
            let d: Vec<f64> = x.iter().zip(r).map(|(a, b)| a - b).collect();
            let rn = norm(r);
            norm(&d) / if rn > 0.0 { rn } else { 1.0 }
        })
    };
    let mut records = Vec::new();
    let mut work = Work::default();
    let mut res = fixed_point_residual(k, b, &x);
    records.push(IterationRecord {
        iteration: 0,
        residual_norm: res,
        relative_residual: res / scale,
        error: err(&x),
        elapsed: t0.elapsed(),
        work,
    });
    let mut reason = StopReason::MaxIterations;
    for it in 1..=max_iterations {
        if res / scale <= tolerance {
            reason = StopReason::Converged;
            break;
        }
        sweep(b, &mut x);
        work.applications += 1;
        res = fixed_point_residual(k, b, &x);
        records.push(IterationRecord {
            iteration: it,
            residual_norm: res,
            relative_residual: res / scale,
            error: err(&x),
            elapsed: t0.elapsed(),
            work,
        });
    }
    if res / scale <= tolerance {
        reason = StopReason::Converged;
    }
    let conv = Convergence {
        iterations: records,
        converged: reason == StopReason::Converged,
        reason,
        final_relative_residual: res / scale,
        safeguarded_updates: 0,
    };
    (x, conv)
}

/// Projects a previous solution onto a new hierarchy's leaves (channel `ch`): a leaf
/// that existed takes its coefficients, a new leaf takes its deepest old ancestor's
/// expansion pushed down.
pub fn project_solution(
    prev: &Solution,
    system: &System,
    basis: &TreeBasis,
    ch: usize,
) -> Vec<f64> {
    let n = system.h.n;
    let old = &prev.system.h;
    let mut x = vec![0.0; system.dim()];
    for (l, &i) in system.h.leaves.iter().enumerate() {
        let key = system.h.keys[i as usize];
        let mut path = Vec::new();
        let mut k = key;
        let found = loop {
            if let Ok(j) = old.keys.binary_search(&k) {
                break Some(j);
            }
            path.push(k.child_pos());
            match k.parent() {
                Some(p) => k = p,
                None => break None,
            }
        };
        let Some(j) = found else { continue };
        let mut v = prev.node_b[ch][j * n..][..n].to_vec();
        for &c in path.iter().rev() {
            let m = basis.child_matrix(c);
            let mut w = vec![0.0; n];
            for bb in 0..n {
                for a in 0..n {
                    w[bb] += m[a * n + bb] * v[a];
                }
            }
            v = w;
        }
        x[l * n..][..n].copy_from_slice(&v);
    }
    x
}

/// The brightness of a node for the brightness oracle: the largest channel of its
/// average radiosity in `prev` (its deepest existing ancestor's), else the largest
/// emitted exitance of its patch (W/m²).
pub(crate) fn brightness(prev: Option<&Solution>, patches: &[Patch], k: &NodeKey) -> f64 {
    match prev {
        Some(s) => {
            let mut key = *k;
            loop {
                if let Some(v) = s.node_average(&key) {
                    break v.iter().fold(0.0f64, |a, &b| a.max(b));
                }
                match key.parent() {
                    Some(p) => key = p,
                    None => break 0.0,
                }
            }
        }
        None => patches[k.patch as usize]
            .emission
            .iter()
            .fold(0.0f64, |a, &b| a.max(b)),
    }
}

/// Compiles `links` into a system (plus the standard form when configured), solves
/// every channel (warm-started from `prev` projected onto the new leaves, else from
/// the emission) to relative residual `tolerance` and returns the solution. Compile
/// and assembly time go into `stats.time_refine`, the solves into `stats.time_solve`;
/// the counts of the hierarchy and the context's kernel and ray totals are updated.
/// The closure's geometric terms are taken from and left in `closure_cache`
/// ([`closure::ClosureCache`]: one per transfer context, kept between the rounds).
///
/// # Errors
/// [`SolverError::Linear`] if a linear solve fails, [`SolverError`] from the standard
/// assembly.
#[allow(clippy::too_many_arguments)]
pub(crate) fn solve_links(
    prep: &Prepared,
    ctx: &TransferCtx<'_>,
    links: &[LinkRec],
    prev: Option<&Solution>,
    stats: &mut Statistics,
    tolerance: f64,
    matvec: Option<&dyn MatVecBackend>,
    closure_cache: &mut closure::ClosureCache,
    clusters: Option<&cluster::ClusterLinks>,
) -> Result<Solution, SolverError> {
    let cfg = &prep.config;
    let patches = &prep.patches.patches;
    let t_ref = Instant::now();
    let h = Hierarchy::compile(prep.basis.n(), patches.len(), links);
    // Closure links (one per leaf whose row sum the links' pushed projections miss).
    let closure::Closure {
        links: closing,
        source,
    } = closure::closure_links_cached(ctx, &h, links, closure_cache);
    let h = if closing.is_empty() {
        h
    } else {
        let all: Vec<LinkRec> = links.iter().chain(&closing).cloned().collect();
        Hierarchy::compile(prep.basis.n(), patches.len(), &all)
    };
    let system = System::new(h, &prep.basis, patches)
        .with_closure_source(&source)
        .with_clusters(clusters, &prep.basis, patches);
    let standard = match cfg.decomposition {
        Decomposition::Standard => Some(StandardSystem::from_system(&system, &prep.basis)?),
        _ => None,
    };
    // The gather on the matrix–vector device (crate::matvec).
    let gather_m = match matvec {
        Some(_)
            if standard.is_none()
                && cfg.linear_method != LinearMethod::GaussSeidel
                && !system.has_clusters() =>
        {
            Some(matvec::gather_matrix(&system.h)?)
        }
        _ => None,
    };
    let gather_op = match (matvec, &gather_m) {
        (Some(mv), Some(m)) => match mv.prepare(m).and_then(BackendOperator::new) {
            Ok(op) => Some(op),
            Err(e) => {
                stats
                    .device_failure
                    .get_or_insert(format!("{}: {e}", mv.name()));
                None
            }
        },
        _ => None,
    };
    stats.time_refine += t_ref.elapsed();
    let t_sol = Instant::now();
    let grey = prep.is_grey();
    let mut leaf_b: [Vec<f64>; 3] = std::array::from_fn(|_| Vec::new());
    let mut conv = Vec::new();
    stats.iterations.clear();
    let channels = if grey { 1 } else { 3 };
    for ch in 0..channels {
        let x0 = prev.map(|p| project_solution(p, &system, &prep.basis, ch));
        let (x, c) = match &standard {
            Some(s) => s.solve_channel(
                ch,
                cfg.linear_method,
                cfg.max_iterations,
                tolerance,
                x0,
                None,
            )?,
            None => {
                let on_device = gather_op.as_ref().and_then(|g| {
                    let dev = matvec::DeviceK::new(&system, ch, g);
                    let out = matvec::solve_refined(
                        &system.channel(ch),
                        &dev,
                        &system.source(ch),
                        cfg.linear_method,
                        cfg.max_iterations,
                        tolerance,
                        x0.clone(),
                    );
                    match (out, g.error()) {
                        (Ok(v), None) => Some(v),
                        (out, err) => {
                            let why = err.map_or_else(
                                || format!("{:?}", out.err()),
                                |e| format!("matvec device: {e}"),
                            );
                            stats.device_failure.get_or_insert(why);
                            None
                        }
                    }
                });
                match on_device {
                    Some(v) if stats.device_failure.is_none() => v,
                    _ => solve_channel(
                        &system,
                        ch,
                        cfg.linear_method,
                        cfg.max_iterations,
                        tolerance,
                        x0,
                        None,
                    )?,
                }
            }
        };
        stats.iterations.push(c.iterations.len() - 1);
        conv.push(c);
        leaf_b[ch] = x;
    }
    if grey {
        leaf_b[1] = leaf_b[0].clone();
        leaf_b[2] = leaf_b[0].clone();
    }
    drop(standard);
    stats.time_solve += t_sol.elapsed();
    stats.elements = system.h.node_count();
    stats.leaves = system.h.leaves.len();
    stats.links = system.h.link_count() - closing.len();
    stats.closure_links = closing.len();
    stats.cluster_links = clusters.map_or(0, cluster::ClusterLinks::len);
    [stats.cells_empty, stats.cells_partial, stats.cells_full] = system.coverage_counts;
    stats.kernel_evals = ctx.kernel_evals.load(std::sync::atomic::Ordering::Relaxed);
    stats.rays = ctx.rays.load(std::sync::atomic::Ordering::Relaxed);
    stats.device_rays = ctx.device_rays.load(std::sync::atomic::Ordering::Relaxed);
    stats.deferred_rays = ctx.deferred_rays.load(std::sync::atomic::Ordering::Relaxed);
    if stats.device_failure.is_none() {
        stats.device_failure = ctx.device_failure();
    }
    stats.bytes = system.h.bytes()
        + std::mem::size_of_val(links)
        + links.iter().map(|l| l.block.capacity() * 8).sum::<usize>();
    Ok(Solution::new(
        patches.clone(),
        prep.patches.by_surface.clone(),
        system,
        prep.basis.clone(),
        leaf_b,
        stats.clone(),
        conv,
    ))
}

/// Optional devices of a solve beside its `Copy` configuration (issue 17): the
/// transfer blocks' shadow rays ([`crate::replay`], bitwise the CPU's answers) and
/// the linear solve's gather ([`crate::matvec`], within the device contract, then
/// refined in f64 to the tolerance). `Backends::default()` is the CPU.
#[derive(Debug, Clone, Copy, Default)]
pub struct Backends<'a> {
    /// Occlusion device of the transfer blocks' shadow rays.
    pub occlusion: Option<&'a dyn OcclusionBackend>,
    /// Matrix–vector device of the non-standard gather (Picard, GMRES and CGNR; the
    /// Gauss–Seidel sweep and the standard decomposition stay on the CPU).
    pub matvec: Option<&'a dyn MatVecBackend>,
}

/// Refines, assembles and solves (see the crate docs).
///
/// # Errors
/// [`SolverError`] for invalid configuration or scene, unsupported surfaces or basis,
/// and linear-solver failures.
pub fn solve(scene: &Scene, config: &SolverConfig) -> Result<Solution, SolverError> {
    let prep = Prepared::new(scene, config)?;
    solve_prepared(&prep)
}

/// [`solve`] on a prepared scene.
///
/// # Errors
/// As [`solve`].
pub fn solve_prepared(prep: &Prepared) -> Result<Solution, SolverError> {
    solve_prepared_on(prep, Backends::default())
}

/// [`solve`] on devices ([`Backends`], issue 17). With an occlusion backend alone
/// the solution is bitwise that of [`solve`] (the backend's contract and
/// [`crate::replay`]); a matrix–vector backend changes it within the tolerance
/// ([`crate::matvec`]). [`Statistics::device_rays`], [`Statistics::deferred_rays`]
/// and [`Statistics::device_failure`] say what the devices did (a failing device
/// hands the rest of the run to the CPU). Oracle estimates, the closure and the error
/// estimate trace on the CPU; the CDV basis and the shooting solver use no backend.
///
/// # Errors
/// As [`solve`].
pub fn solve_on(
    scene: &Scene,
    config: &SolverConfig,
    backends: Backends<'_>,
) -> Result<Solution, SolverError> {
    let prep = Prepared::new(scene, config)?;
    solve_prepared_on(&prep, backends)
}

/// [`solve_on`] on a prepared scene.
///
/// # Errors
/// As [`solve`].
pub fn solve_prepared_on(prep: &Prepared, backends: Backends<'_>) -> Result<Solution, SolverError> {
    if prep.config.basis == BasisKind::Cdv {
        return cdv::solve(prep);
    }
    let cfg = &prep.config;
    let (occluder, failure) = prep.occluder(backends.occlusion);
    let ctx = match &occluder {
        Some(o) => prep.transfer()?.with_occluder(o.as_ref()),
        None => prep.transfer()?,
    };
    let stages = cfg.multigrid.map_or(1, |m| m.stages);
    let factor = cfg.multigrid.map_or(1.0, |m| m.factor);
    let mut links: Vec<LinkRec> = Vec::new();
    let mut prev: Option<Solution> = None;
    let mut stats = Statistics {
        time_setup: prep.setup_time,
        device_failure: failure,
        ..Statistics::default()
    };
    let patches = &prep.patches.patches;
    let mut closure_cache = closure::ClosureCache::new();
    let mut clusters = None;
    for stage in 0..stages {
        let eps = cfg.eps * factor.powi((stages - 1 - stage) as i32);
        let params = prep.refine_params(eps);
        let t_ref = Instant::now();
        let bright = |k: &NodeKey| brightness(prev.as_ref(), patches, k);
        let (new_links, counts) = if stage == 0 {
            let (l, c, cl) = cluster::initial_links(&ctx, &params, cfg.cluster, prep, &bright);
            clusters = cl;
            (l, c)
        } else {
            hierarchy::rerefine(&ctx, &params, std::mem::take(&mut links), &bright)
        };
        links = new_links;
        stats.refined_links += counts.refined;
        stats.oracle_evals += counts.oracle_evals;
        stats.nonstandard_links = counts.refined + counts.unrefined_roots;
        stats.time_refine += t_ref.elapsed();
        stats.stages = stage + 1;
        prev = Some(solve_links(
            prep,
            &ctx,
            &links,
            prev.as_ref(),
            &mut stats,
            cfg.tolerance,
            backends.matvec,
            &mut closure_cache,
            clusters.as_ref(),
        )?);
    }
    let mut sol = prev.ok_or_else(|| SolverError::InvalidScene("no stage ran".into()))?;
    sol.measure_escape(prep);
    Ok(sol)
}
