//! Precomputed direct-to-indirect transfer and relighting (Meshless §3, §4.1).
//!
//! [`Precomputed::build`] places the points, builds the basis, refines `T` and sums the
//! bounces into `S`. A [`Relighter`] then turns a frame's direct lighting into
//! indirect illumination: direct irradiance `E←` at the sender points (any method,
//! [`DirectLighting`]), `e = P†E←` over the sender levels, senders with
//! `max_c |e_j,c| <= skip · max |e|` set inactive (ours: `skip = 1e-3`), and
//! `i = S·e` on a [`TransferBackend`]. The result ([`Indirect`]) is the RGB vector
//! irradiance expansion over all receiver levels; `n·i` is the indirect scalar
//! irradiance, and the shown exitance is `ρ(E_dir + n·i)`.
//!
//! [`Indirect::flatten`] resamples it into the one-level basis on all points (§4.1
//! "Flattening"): the expansion is evaluated at every point, then shown with one
//! Shepard normalisation over all points and their own radii.

use std::time::Instant;

use glam::DVec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use wavelux_scene::{Light, Scene};

use crate::MeshlessError;
use crate::backend::TransferBackend;
use crate::basis::{Basis, Csr};
use crate::bounce::{BounceStats, apply_q, bounces, eval_matrix};
use crate::config::MeshlessConfig;
use crate::direct::DirectLighting;
use crate::matrix::{MatrixStats, TransferMatrix};
use crate::points::{PlacementStats, place_points};
use crate::query::{SceneSurfaces, SurfaceQuery};
use crate::transfer::{RefineStats, refine};

/// Progress callback: `(phase, done, total)`.
pub type Progress<'a> = &'a (dyn Fn(&str, usize, usize) + Sync);

/// Statistics of a precomputation.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct PrecomputeStats {
    /// Point placement.
    pub placement: PlacementStats,
    /// Points per level.
    pub points_per_level: Vec<usize>,
    /// Refinement of `T`.
    pub refine: RefineStats,
    /// Bounces.
    pub bounce: BounceStats,
    /// `T`.
    pub t: MatrixStats,
    /// `S`.
    pub s: MatrixStats,
    /// Senders × receivers.
    pub potential_links: f64,
    /// Rays cast (placement and gathering).
    pub rays: u64,
    /// Bytes of the basis (points, grids, DAG).
    pub basis_bytes: usize,
    /// Bytes of `S` (f64 storage).
    pub s_bytes: usize,
    /// Bytes of `T` (f64 storage).
    pub t_bytes: usize,
    /// Phase wall times (ms): placement + basis, refinement, bounces, total.
    pub placement_ms: f64,
    /// Refinement of `T` (ms).
    pub refine_ms: f64,
    /// Bounces (ms).
    pub bounce_ms: f64,
    /// Total (ms).
    pub total_ms: f64,
    /// Non-fatal problems (ignored media, Ward lobes, emitters that cannot be sampled);
    /// left out of the serialized form when empty.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub warnings: Vec<String>,
}

/// The precomputed basis and transfer operators of a scene.
#[derive(Debug, Clone)]
pub struct Precomputed {
    /// The configuration used.
    pub config: MeshlessConfig,
    /// The basis (receivers: all levels; senders: the first `sender_levels`).
    pub basis: Basis,
    /// The single-bounce operator `T`.
    pub t: TransferMatrix,
    /// The multi-bounce operator `S = Σ_{b ≤ B} S_b`.
    pub s: TransferMatrix,
    /// Statistics.
    pub stats: PrecomputeStats,
    /// Hash of the scene it was computed for ([`scene_hash`]).
    pub scene_hash: u64,
}

/// FNV-1a over the bytes of the scene's geometry, sidedness and materials (a change
/// of any of them changes the hash).
pub fn scene_hash(scene: &Scene) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    let mut eat = |bytes: &[u8]| {
        for &b in bytes {
            h ^= u64::from(b);
            h = h.wrapping_mul(0x0100_0000_01b3);
        }
    };
    for s in &scene.surfaces {
        eat(format!("{:?}|{}|{:?}", s.shape, s.material, s.sides).as_bytes());
    }
    for m in &scene.materials {
        for v in m.reflectance.0.iter().chain(m.emission.0.iter()) {
            eat(&v.to_le_bytes());
        }
    }
    h
}

/// The default viewpoint: the scene's first camera, else the bounds' centre.
pub fn default_viewpoint(scene: &Scene, bounds: (DVec3, DVec3)) -> DVec3 {
    scene
        .cameras
        .first()
        .map(|c| c.position)
        .unwrap_or((bounds.0 + bounds.1) * 0.5)
}

impl Precomputed {
    /// Precomputes `T` and `S` for a scene (module docs); the viewpoint is
    /// `config.viewpoint`, else [`default_viewpoint`].
    ///
    /// # Errors
    /// Any [`MeshlessError`] of the configuration, the scene, the placement
    /// (viewpoint, empty level, budget) and the refinement (budget).
    pub fn build(
        scene: &Scene,
        config: &MeshlessConfig,
        progress: Progress<'_>,
    ) -> Result<Self, MeshlessError> {
        config.validate()?;
        let query = SceneSurfaces::new(scene)?;
        let viewpoint = config
            .viewpoint
            .map(DVec3::from_array)
            .unwrap_or_else(|| default_viewpoint(scene, query.bounds()));
        let mut pre = Self::build_with(&query, config, viewpoint, progress)?;
        pre.scene_hash = scene_hash(scene);
        if !scene.media.is_empty() {
            pre.stats.warnings.push(format!(
                "{} participating medium(s) ignored (surfaces only)",
                scene.media.len()
            ));
        }
        let ward = scene.materials.iter().filter(|m| m.ward.is_some()).count();
        if ward > 0 {
            pre.stats.warnings.push(format!(
                "{ward} Ward lobe(s) ignored (diffuse transport only)"
            ));
        }
        for name in query.unsampled_emitters() {
            pre.stats.warnings.push(format!(
                "emitter {name:?} is not a triangle or parallelogram: area-emitter direct lighting skips it"
            ));
        }
        Ok(pre)
    }

    /// Precomputes on any [`SurfaceQuery`] from an explicit viewpoint (scene hash 0).
    ///
    /// # Errors
    /// As [`Precomputed::build`].
    pub fn build_with<Q: SurfaceQuery + ?Sized>(
        query: &Q,
        config: &MeshlessConfig,
        viewpoint: DVec3,
        progress: Progress<'_>,
    ) -> Result<Self, MeshlessError> {
        config.validate()?;
        let t0 = Instant::now();
        let (lo, hi) = query.bounds();
        let diag = (hi - lo).length();
        if !(diag.is_finite() && diag > 0.0) {
            return Err(MeshlessError::Scene {
                scene: String::new(),
                reason: format!("degenerate bounds {lo:?} – {hi:?}"),
            });
        }
        let levels = config.receiver_levels;
        let placement = place_points(query, config, viewpoint, diag, &|l, n| {
            progress("points", l + 1, levels);
            let _ = n;
        })?;
        let basis = Basis::from_levels(&placement.levels, &placement.radii, config.sender_levels)?;
        let placement_ms = t0.elapsed().as_secs_f64() * 1e3;
        let (t, refine_stats) = refine(query, &basis, config, &|l, _| {
            progress("refine", l + 1, levels)
        })?;
        progress("bounces", 0, 1);
        let (s, bounce_stats) = bounces(&basis, &t, config)?;
        progress("bounces", 1, 1);
        let senders = basis.level_start(config.sender_levels);
        let stats = PrecomputeStats {
            points_per_level: (0..basis.levels())
                .map(|l| basis.level_range(l).len())
                .collect(),
            rays: placement.stats.rays + refine_stats.rays,
            placement: placement.stats,
            refine_ms: refine_stats.ms,
            bounce_ms: bounce_stats.ms,
            refine: refine_stats,
            bounce: bounce_stats,
            t: t.stats(),
            s: s.stats(),
            potential_links: senders as f64 * basis.len() as f64,
            basis_bytes: basis.bytes(),
            s_bytes: s.bytes(),
            t_bytes: t.bytes(),
            placement_ms,
            total_ms: t0.elapsed().as_secs_f64() * 1e3,
            warnings: Vec::new(),
        };
        Ok(Self {
            config: config.clone(),
            basis,
            t,
            s,
            stats,
            scene_hash: 0,
        })
    }

    /// Number of sender functions (points of the first `sender_levels` levels).
    pub fn senders(&self) -> usize {
        self.basis.level_start(self.config.sender_levels)
    }

    /// The sender points `(x, n)`, where direct irradiance is sampled.
    pub fn sender_points(&self) -> Vec<(DVec3, DVec3)> {
        (0..self.senders())
            .map(|i| (self.basis.position(i), self.basis.normal(i)))
            .collect()
    }

    /// `e = P†E←`: the sender coefficients of direct irradiance sampled at
    /// [`Precomputed::sender_points`].
    ///
    /// # Errors
    /// [`MeshlessError::Length`] / [`MeshlessError::BadValue`] for a vector of the
    /// wrong length or a non-finite or negative value (naming its index).
    pub fn project_direct(&self, direct: &[[f64; 3]]) -> Result<Vec<f64>, MeshlessError> {
        let n = self.senders();
        if direct.len() != n {
            return Err(MeshlessError::Length {
                what: "direct irradiance",
                len: direct.len(),
                expected: n,
            });
        }
        for (index, v) in direct.iter().enumerate() {
            for &c in v {
                if !(c.is_finite() && c >= 0.0) {
                    return Err(MeshlessError::BadValue {
                        what: "direct irradiance",
                        index,
                        value: c,
                        sign: " and >= 0",
                    });
                }
            }
        }
        let flat: Vec<f64> = direct.iter().flatten().copied().collect();
        self.basis.pull_push(&flat, 3, self.config.sender_levels)
    }

    /// The fully converged indirect illumination (all bounces): GMRES
    /// (`wavelux-linear`) on `(I − Q·T) x = e` per channel, then `i = T x`; `e` as from
    /// [`Precomputed::project_direct`]. Returns receiver coefficients (9 per receiver)
    /// and the GMRES iterations per channel.
    ///
    /// # Errors
    /// [`MeshlessError::Length`] for a wrong `e`; [`MeshlessError::Config`] if GMRES
    /// fails (naming its error).
    pub fn converged(
        &self,
        e: &[f64],
        tolerance: f64,
    ) -> Result<(Vec<f64>, [usize; 3]), MeshlessError> {
        let ns = self.senders();
        if e.len() != ns * 3 {
            return Err(MeshlessError::Length {
                what: "sender coefficients",
                len: e.len(),
                expected: ns * 3,
            });
        }
        let eval = eval_matrix(&self.basis, ns, &|_| true);
        let ls = self.config.sender_levels;
        let mut x = vec![0.0; ns * 3];
        let mut iters = [0; 3];
        for c in 0..3 {
            let b: Vec<f64> = (0..ns).map(|j| e[j * 3 + c]).collect();
            let op = wavelux_linear::FnOperator::new(ns, |v: &[f64], y: &mut [f64]| {
                // y = v − Q T v for channel c (other channels zero).
                let mut ev = vec![0.0; ns * 3];
                for j in 0..ns {
                    ev[j * 3 + c] = v[j];
                }
                let mut iv = vec![0.0; self.t.rows() * 9];
                self.t.apply_f64(&ev, &mut iv);
                let q = apply_q(&self.basis, &eval, ls, &iv).unwrap_or_else(|_| vec![0.0; ns * 3]);
                for j in 0..ns {
                    y[j] = v[j] - q[j * 3 + c];
                }
            });
            let opts = wavelux_linear::SolverOptions::default()
                .with_tolerance(tolerance)
                .with_max_iterations(500);
            let sol = wavelux_linear::gmres(&op, &b, &opts)
                .map_err(|err| MeshlessError::config("converged solve", err.to_string()))?;
            iters[c] = sol.history.iterations.len().saturating_sub(1);
            for j in 0..ns {
                x[j * 3 + c] = sol.x[j];
            }
        }
        let mut out = vec![0.0; self.t.rows() * 9];
        self.t.apply_f64(&x, &mut out);
        Ok((out, iters))
    }

    /// Heap bytes of the basis and `S` (what the runtime needs; Meshless Table 1's
    /// memory column).
    pub fn runtime_bytes(&self) -> usize {
        self.basis.bytes() + self.s.bytes()
    }
}

/// Wall times of one relit frame (ms).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct FrameTimes {
    /// Direct irradiance at the sender points.
    pub direct_ms: f64,
    /// Pull-push `e = P†E←`.
    pub pull_push_ms: f64,
    /// Transfer product `i = S·e`.
    pub transport_ms: f64,
    /// Active senders (not skipped).
    pub active_senders: usize,
}

/// Indirect illumination in the hierarchical receiver basis.
#[derive(Debug, Clone)]
pub struct Indirect<'a> {
    basis: &'a Basis,
    /// RGB vector irradiance coefficients, nine per receiver.
    pub coeffs: Vec<f64>,
    /// Frame times.
    pub times: FrameTimes,
}

impl<'a> Indirect<'a> {
    /// Wraps coefficients (nine per receiver) of `basis`.
    ///
    /// # Errors
    /// [`MeshlessError::Length`] for a wrong length.
    pub fn new(basis: &'a Basis, coeffs: Vec<f64>) -> Result<Self, MeshlessError> {
        if coeffs.len() != basis.len() * 9 {
            return Err(MeshlessError::Length {
                what: "receiver coefficients",
                len: coeffs.len(),
                expected: basis.len() * 9,
            });
        }
        Ok(Self {
            basis,
            coeffs,
            times: FrameTimes::default(),
        })
    }

    /// The RGB vector irradiance at `(x, n)` (eq. (6) over all receiver levels).
    pub fn vector_at(&self, x: DVec3, n: DVec3) -> [DVec3; 3] {
        let mut out = [0.0; 9];
        let mut s = Vec::new();
        self.basis.evaluate(
            &self.coeffs,
            9,
            0..self.basis.levels(),
            x,
            n,
            &mut out,
            &mut s,
        );
        [0, 1, 2].map(|c| DVec3::new(out[c * 3], out[c * 3 + 1], out[c * 3 + 2]))
    }

    /// Indirect scalar irradiance `n·i` at `(x, n)` (W/m², RGB).
    pub fn irradiance_at(&self, x: DVec3, n: DVec3) -> [f64; 3] {
        self.vector_at(x, n).map(|v| v.dot(n))
    }

    /// Indirect irradiance at many points (a vertex bake), in parallel.
    pub fn bake(&self, points: &[(DVec3, DVec3)]) -> Vec<[f64; 3]> {
        points
            .par_iter()
            .map(|&(x, n)| self.irradiance_at(x, n))
            .collect()
    }

    /// Resamples into the one-level basis on all points (module docs).
    pub fn flatten(&self, op: &FlattenOperator) -> Flat<'a> {
        let values = op.apply(&self.coeffs);
        Flat {
            basis: self.basis,
            values,
        }
    }
}

/// The cached evaluation matrix of [`Indirect::flatten`]: for every point, every
/// receiver function non-zero there (all levels) with `B_k(p)` in f32.
#[derive(Debug, Clone)]
pub struct FlattenOperator {
    rows: Csr<(u32, f32)>,
}

impl FlattenOperator {
    /// Builds the matrix (one grid query per point and level).
    pub fn new(basis: &Basis) -> Self {
        let rows: Vec<Vec<(u32, f32)>> = (0..basis.len())
            .into_par_iter()
            .map_init(Vec::new, |tmp, p| {
                let mut out = Vec::new();
                for l in 0..basis.levels() {
                    basis.basis_at(l, basis.position(p), basis.normal(p), tmp);
                    out.extend(tmp.iter().map(|&(k, b)| (k, b as f32)));
                }
                out
            })
            .collect();
        let mut ptr = Vec::with_capacity(rows.len() + 1);
        ptr.push(0u32);
        let mut items = Vec::new();
        for r in rows {
            items.extend(r);
            ptr.push(items.len() as u32);
        }
        Self {
            rows: Csr { ptr, items },
        }
    }

    /// Heap bytes.
    pub fn bytes(&self) -> usize {
        self.rows.ptr.len() * 4 + self.rows.items.len() * 8
    }

    fn apply(&self, coeffs: &[f64]) -> Vec<[f32; 9]> {
        (0..self.rows.ptr.len() - 1)
            .into_par_iter()
            .map(|p| {
                let mut v = [0.0f64; 9];
                for &(k, b) in self.rows.row(p) {
                    let c = &coeffs[k as usize * 9..k as usize * 9 + 9];
                    if c.iter().all(|x| *x == 0.0) {
                        continue;
                    }
                    let b = f64::from(b);
                    for q in 0..9 {
                        v[q] += b * c[q];
                    }
                }
                v.map(|x| x as f32)
            })
            .collect()
    }
}

/// Indirect illumination resampled into the one-level basis on all points (§4.1).
#[derive(Debug, Clone)]
pub struct Flat<'a> {
    basis: &'a Basis,
    /// RGB vector irradiance per point (f32, channel-major).
    pub values: Vec<[f32; 9]>,
}

impl Flat<'_> {
    /// Indirect scalar irradiance `n·i` at `(x, n)`: one Shepard normalisation over the
    /// functions of all levels with their own radii (zero where nothing covers).
    pub fn irradiance_at(&self, x: DVec3, n: DVec3) -> [f64; 3] {
        let mut acc = [0.0f64; 9];
        let mut wsum = 0.0;
        let mut s = Vec::new();
        for l in 0..self.basis.levels() {
            let w = self.basis.basis_at(l, x, n, &mut s);
            for &(j, b) in &s {
                let wj = b * w;
                wsum += wj;
                let v = &self.values[j as usize];
                for q in 0..9 {
                    acc[q] += wj * f64::from(v[q]);
                }
            }
        }
        if !(wsum > 0.0) {
            return [0.0; 3];
        }
        [0, 1, 2].map(|c| (n.x * acc[c * 3] + n.y * acc[c * 3 + 1] + n.z * acc[c * 3 + 2]) / wsum)
    }
}

/// Relights a precomputed scene frame by frame on a transfer backend.
pub struct Relighter<'a, B: TransferBackend> {
    pre: &'a Precomputed,
    backend: B,
    prepared: B::Prepared,
}

impl<B: TransferBackend> std::fmt::Debug for Relighter<'_, B> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Relighter")
            .field("backend", &self.backend.name())
            .finish_non_exhaustive()
    }
}

impl<'a, B: TransferBackend> Relighter<'a, B> {
    /// Prepares `S` on the backend.
    ///
    /// # Errors
    /// The backend's error.
    pub fn new(pre: &'a Precomputed, backend: B) -> Result<Self, B::Error> {
        let prepared = backend.prepare(&pre.s)?;
        Ok(Self {
            pre,
            backend,
            prepared,
        })
    }

    /// The backend's name.
    pub fn backend_name(&self) -> String {
        self.backend.name()
    }

    /// Relights from direct irradiance at [`Precomputed::sender_points`] (any direct
    /// method): pull-push, skip, `S·e`.
    ///
    /// # Errors
    /// [`MeshlessError::Length`] / [`MeshlessError::BadValue`] for a bad vector;
    /// [`MeshlessError::Config`] wrapping a backend failure.
    pub fn relight_direct(&self, direct: &[[f64; 3]]) -> Result<Indirect<'a>, MeshlessError> {
        let t0 = Instant::now();
        let e = self.pre.project_direct(direct)?;
        let pull_push_ms = t0.elapsed().as_secs_f64() * 1e3;
        let t1 = Instant::now();
        let max = e.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let cut = self.pre.config.skip * max;
        let mut ef = vec![0f32; e.len()];
        let mut active = 0;
        for j in 0..e.len() / 3 {
            let m = e[j * 3]
                .abs()
                .max(e[j * 3 + 1].abs())
                .max(e[j * 3 + 2].abs());
            if m > cut && m > 0.0 {
                active += 1;
                for c in 0..3 {
                    ef[j * 3 + c] = e[j * 3 + c] as f32;
                }
            }
        }
        let mut out = vec![0f32; self.pre.s.rows() * 9];
        self.backend
            .apply(&self.prepared, &ef, &mut out)
            .map_err(|err| MeshlessError::config("transfer backend", err.to_string()))?;
        let transport_ms = t1.elapsed().as_secs_f64() * 1e3;
        let mut ind = Indirect::new(&self.pre.basis, out.into_iter().map(f64::from).collect())?;
        ind.times = FrameTimes {
            direct_ms: 0.0,
            pull_push_ms,
            transport_ms,
            active_senders: active,
        };
        Ok(ind)
    }

    /// Relights with `direct` lighting evaluated at the sender points through `query`
    /// (shadow rays).
    ///
    /// # Errors
    /// As [`DirectLighting::irradiance`] and [`Relighter::relight_direct`].
    pub fn relight_with<Q: SurfaceQuery + ?Sized>(
        &self,
        query: &Q,
        direct: &DirectLighting,
    ) -> Result<Indirect<'a>, MeshlessError> {
        let t0 = Instant::now();
        let e = direct.irradiance(query, &self.pre.sender_points())?;
        let direct_ms = t0.elapsed().as_secs_f64() * 1e3;
        let mut ind = self.relight_direct(&e)?;
        ind.times.direct_ms = direct_ms;
        Ok(ind)
    }

    /// Relights with punctual lights (shadow rays through `query`).
    ///
    /// # Errors
    /// [`MeshlessError::Light`] for an invalid light; as [`Relighter::relight_with`].
    pub fn relight<Q: SurfaceQuery + ?Sized>(
        &self,
        query: &Q,
        lights: &[Light],
    ) -> Result<Indirect<'a>, MeshlessError> {
        self.relight_with(query, &DirectLighting::Lights(lights.to_vec()))
    }
}
