//! Point placement (Meshless §2.3): candidates from importance particles traced from
//! a viewpoint, then hierarchical dart throwing under the 5D distance `D` of eq. (11)
//! with a free-distance acceptance test.
//!
//! - Candidates: particles leave the viewpoint in uniform directions and bounce
//!   diffusely (cosine-distributed) `particle_bounces` times (30); every hit after the
//!   first `skip_bounces` (3) is a candidate `(x, n of the side hit)`. A particle that
//!   escapes or reaches the black back of a one-sided surface ends. Candidates are made
//!   lazily, in batches of particles, each particle with its own seeded stream; every
//!   level draws from its own streams (levels are independent, §2.3).
//! - Dart throwing on level `l` with spacing `R_l = R_coarse / 2^l`: a candidate
//!   conflicts with an accepted point `q` of the same level when `D(c, q) < R_l`
//!   (`D = ∞` for normals at 90° or more, so coincident points of opposite normals are
//!   both kept); a non-conflicting candidate is rejected when the harmonic mean of
//!   the free distances of `free_rays` stratified hemisphere rays of length `3R_l`
//!   (misses count `3R_l`) is below `free_reject · R_l` (ours: 32 rays); the level
//!   closes after `max_failures` (2000) consecutive failures.
//! - Batches of candidates are tested in parallel against the points accepted before
//!   the batch and then accepted in order, which is exactly the sequential algorithm:
//!   the result does not depend on the thread count.
//! - Support radii `r_l = C_l · R_l` (`C` linear from 1.5 to 2.5).
//! - Holes: probe candidates (a separate stream) not covered by a level's weights.

use glam::{DVec2, DVec3};
use rand::RngExt;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::MeshlessError;
use crate::basis::BasisPoint;
use crate::config::MeshlessConfig;
use crate::grid::{KeyMap, cell_of};
use crate::kernel::{poisson_distance, weight};
use crate::query::SurfaceQuery;
use crate::sample::{cosine, hemisphere, rng_for, sphere, stratified, tangents};

/// Particles traced per candidate batch.
const PARTICLE_BATCH: u64 = 512;
/// Candidates tested per dart-throwing batch.
const DART_BATCH: usize = 512;
/// Particles traced without a single candidate before the viewpoint is called blind.
const BLIND_PARTICLES: u64 = 1 << 16;
/// Probe candidates for the hole count.
const PROBES: usize = 4096;
/// Stream tags.
const TAG_PARTICLES: u64 = 1;
const TAG_FREE: u64 = 2;
const TAG_PROBES: u64 = 3;

/// Statistics of one level's placement.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct LevelStats {
    /// Poisson-disk spacing `R_l` (scene units).
    pub spacing: f64,
    /// Support radius `r_l = C_l R_l` (scene units).
    pub radius: f64,
    /// Points accepted.
    pub points: usize,
    /// Candidates drawn.
    pub candidates: usize,
    /// Candidates in conflict with an accepted point.
    pub conflicts: usize,
    /// Candidates rejected by the free-distance test.
    pub free_rejected: usize,
    /// Probe candidates not covered by this level (zero weight sum).
    pub holes: usize,
    /// Probe candidates tested for holes.
    pub probes: usize,
}

/// Statistics of the whole placement.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct PlacementStats {
    /// Per level.
    pub levels: Vec<LevelStats>,
    /// Importance particles traced.
    pub particles: u64,
    /// Rays cast (particles and free-distance tests).
    pub rays: u64,
    /// Candidates dropped for a zero or non-finite normal or position.
    pub dropped: usize,
    /// The viewpoint used.
    pub viewpoint: [f64; 3],
}

/// Points per level with their spacing and radius.
#[derive(Debug, Clone, PartialEq)]
pub struct Placement {
    /// Points per level (level 0 first).
    pub levels: Vec<Vec<BasisPoint>>,
    /// Support radius per level (scene units).
    pub radii: Vec<f64>,
    /// Statistics.
    pub stats: PlacementStats,
}

/// A lazily extended stream of candidates for one level.
struct Candidates<'a, Q: SurfaceQuery + ?Sized> {
    query: &'a Q,
    config: &'a MeshlessConfig,
    viewpoint: DVec3,
    tag: u64,
    next_particle: u64,
    buffer: Vec<BasisPoint>,
    pos: usize,
    particles: u64,
    rays: u64,
    dropped: usize,
}

impl<'a, Q: SurfaceQuery + ?Sized> Candidates<'a, Q> {
    fn new(query: &'a Q, config: &'a MeshlessConfig, viewpoint: DVec3, tag: u64) -> Self {
        Self {
            query,
            config,
            viewpoint,
            tag,
            next_particle: 0,
            buffer: Vec::new(),
            pos: 0,
            particles: 0,
            rays: 0,
            dropped: 0,
        }
    }

    /// Traces one particle and returns its candidates and rays.
    fn particle(&self, k: u64) -> (Vec<BasisPoint>, u64, usize) {
        let cfg = self.config;
        let mut rng = rng_for(cfg.seed, self.tag, k);
        let eps = self.query.offset();
        let mut origin = self.viewpoint;
        let mut dir = sphere(rng.random(), rng.random());
        let mut out = Vec::new();
        let mut rays = 0;
        let mut dropped = 0;
        for b in 0..cfg.particle_bounces {
            rays += 1;
            let Some(hit) = self.query.closest_hit(origin, dir) else {
                break;
            };
            if hit.reflectance.is_none() {
                break;
            }
            let n = hit.normal;
            if !(hit.point.is_finite() && n.is_finite() && (n.length() - 1.0).abs() < 1e-6) {
                dropped += 1;
                break;
            }
            if b >= cfg.skip_bounces {
                out.push(BasisPoint { x: hit.point, n });
            }
            origin = hit.point + n * eps;
            dir = cosine(n, rng.random(), rng.random());
        }
        (out, rays, dropped)
    }

    /// The next candidate, tracing a new batch of particles when the buffer is empty.
    fn next(&mut self) -> Result<BasisPoint, MeshlessError> {
        let mut empty_particles = 0u64;
        while self.pos >= self.buffer.len() {
            let first = self.next_particle;
            let batch: Vec<(Vec<BasisPoint>, u64, usize)> = (first..first + PARTICLE_BATCH)
                .into_par_iter()
                .map(|k| self.particle(k))
                .collect();
            self.next_particle += PARTICLE_BATCH;
            self.particles += PARTICLE_BATCH;
            self.buffer.clear();
            self.pos = 0;
            for (c, r, d) in batch {
                self.rays += r;
                self.dropped += d;
                self.buffer.extend(c);
            }
            if self.buffer.is_empty() {
                empty_particles += PARTICLE_BATCH;
                if empty_particles >= BLIND_PARTICLES {
                    return Err(MeshlessError::Viewpoint {
                        viewpoint: self.viewpoint.to_array(),
                        reason: format!(
                            "{empty_particles} particles from it deposited no candidate (blind: outside the scene, inside a closed object, facing only black backs, or in an open scene where no path survives the first skip_bounces bounces)"
                        ),
                    });
                }
            }
        }
        let c = self.buffer[self.pos];
        self.pos += 1;
        Ok(c)
    }
}

/// Harmonic mean of the free distances around a candidate (`rays` stratified
/// hemisphere rays of length `len`; misses count `len`).
fn free_distance<Q: SurfaceQuery + ?Sized>(
    query: &Q,
    c: &BasisPoint,
    rays: usize,
    len: f64,
    seed: u64,
    key: u64,
) -> f64 {
    let mut rng = rng_for(seed, TAG_FREE, key);
    let mut uv: Vec<DVec2> = Vec::with_capacity(rays);
    stratified(rays, &mut rng, &mut uv);
    let (t, b) = tangents(c.n);
    let origin = c.x + c.n * query.offset();
    let mut inv = 0.0;
    for p in &uv {
        let d = hemisphere(c.n, t, b, *p);
        let dist = match query.closest_hit(origin, d) {
            Some(h) if h.t < len => h.t.max(1e-300),
            _ => len,
        };
        inv += 1.0 / dist;
    }
    rays as f64 / inv
}

/// The accepted points of a level with a grid of cell `R` for conflict tests.
struct Accepted {
    inv_cell: f64,
    cells: KeyMap<Vec<u32>>,
    points: Vec<BasisPoint>,
}

impl Accepted {
    fn new(spacing: f64) -> Self {
        Self {
            inv_cell: 1.0 / spacing,
            cells: KeyMap::default(),
            points: Vec::new(),
        }
    }

    fn key(&self, x: DVec3) -> [i64; 3] {
        cell_of(x, self.inv_cell)
    }

    fn pack(c: [i64; 3]) -> u64 {
        const M: i64 = (1 << 21) - 1;
        (((c[0] & M) << 42) | ((c[1] & M) << 21) | (c[2] & M)) as u64
    }

    /// Whether `c` is within `D < spacing` of an accepted point (indices `< limit`).
    fn conflicts(&self, c: &BasisPoint, spacing: f64, limit: usize) -> bool {
        let k = self.key(c.x);
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    if let Some(list) =
                        self.cells
                            .get(&Self::pack([k[0] + dx, k[1] + dy, k[2] + dz]))
                    {
                        for &i in list {
                            if (i as usize) < limit {
                                let q = &self.points[i as usize];
                                if poisson_distance(c.x, c.n, q.x, q.n) < spacing {
                                    return true;
                                }
                            }
                        }
                    }
                }
            }
        }
        false
    }

    fn push(&mut self, c: BasisPoint) {
        let key = Self::pack(self.key(c.x));
        let i = self.points.len() as u32;
        self.cells.entry(key).or_default().push(i);
        self.points.push(c);
    }
}

/// Places the points of every level (module docs) from `viewpoint`; `diag` is the
/// scene's bounding-box diagonal (for the default `R_coarse`). `progress(level, points)` is called after each
/// level.
///
/// # Errors
/// [`MeshlessError::Viewpoint`] if the viewpoint sees nothing,
/// [`MeshlessError::EmptyLevel`] if a level gets no point,
/// [`MeshlessError::Budget`] past `max_points`.
pub fn place_points<Q: SurfaceQuery + ?Sized>(
    query: &Q,
    config: &MeshlessConfig,
    viewpoint: DVec3,
    diag: f64,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<Placement, MeshlessError> {
    config.validate()?;
    if !viewpoint.is_finite() {
        return Err(MeshlessError::Viewpoint {
            viewpoint: viewpoint.to_array(),
            reason: "not finite".into(),
        });
    }
    let mut stats = PlacementStats {
        viewpoint: viewpoint.to_array(),
        ..Default::default()
    };
    let mut levels = Vec::new();
    let mut radii = Vec::new();
    let mut total = 0usize;
    for l in 0..config.receiver_levels {
        let spacing = config.r_coarse_for(diag) / f64::from(1u32 << l);
        let radius = config.support_factor(l) * spacing;
        let mut st = LevelStats {
            spacing,
            radius,
            ..Default::default()
        };
        let tag = TAG_PARTICLES | ((l as u64) << 8);
        let mut cands = Candidates::new(query, config, viewpoint, tag);
        let mut acc = Accepted::new(spacing);
        let mut failures = 0usize;
        let mut drawn = 0u64;
        'level: while failures < config.max_failures {
            let mut batch = Vec::with_capacity(DART_BATCH);
            for _ in 0..DART_BATCH {
                batch.push((drawn, cands.next()?));
                drawn += 1;
            }
            let limit = acc.points.len();
            // Parallel: conflicts with the points accepted before the batch, then the
            // free-distance test of the rest.
            let pre: Vec<(bool, bool)> = batch
                .par_iter()
                .map(|(key, c)| {
                    if acc.conflicts(c, spacing, limit) {
                        return (true, false);
                    }
                    let free_ok = config.free_rays == 0
                        || free_distance(
                            query,
                            c,
                            config.free_rays,
                            3.0 * spacing,
                            config.seed,
                            key ^ ((l as u64) << 56),
                        ) >= config.free_reject * spacing;
                    (false, free_ok)
                })
                .collect();
            for ((_, c), (conflict, free_ok)) in batch.iter().zip(pre) {
                st.candidates += 1;
                if !conflict {
                    stats.rays += config.free_rays as u64;
                }
                if conflict || acc.conflicts_from(c, spacing, limit) {
                    st.conflicts += 1;
                    failures += 1;
                } else if !free_ok {
                    st.free_rejected += 1;
                    failures += 1;
                } else {
                    acc.push(*c);
                    failures = 0;
                    total += 1;
                    if total > config.max_points {
                        return Err(MeshlessError::Budget {
                            what: "points",
                            limit: config.max_points,
                        });
                    }
                }
                if failures >= config.max_failures {
                    break 'level;
                }
            }
        }
        stats.particles += cands.particles;
        stats.rays += cands.rays;
        stats.dropped += cands.dropped;
        if acc.points.is_empty() {
            return Err(MeshlessError::EmptyLevel { level: l, spacing });
        }
        st.points = acc.points.len();
        progress(l, st.points);
        stats.levels.push(st);
        levels.push(acc.points);
        radii.push(radius);
    }
    // Holes: probe candidates not covered by a level.
    let mut probes = Candidates::new(query, config, viewpoint, TAG_PROBES);
    let mut probe_points = Vec::with_capacity(PROBES);
    for _ in 0..PROBES {
        probe_points.push(probes.next()?);
    }
    stats.particles += probes.particles;
    stats.rays += probes.rays;
    for (l, pts) in levels.iter().enumerate() {
        let grid =
            crate::grid::Grid::build(&pts.iter().map(|p| p.x).collect::<Vec<_>>(), 0, radii[l]);
        let r = radii[l];
        let holes = probe_points
            .par_iter()
            .filter(|p| {
                let mut covered = false;
                grid.for_each_near(p.x, |j| {
                    let q = &pts[j as usize];
                    covered |= weight(q.x, q.n, r, p.x, p.n) > 0.0;
                });
                !covered
            })
            .count();
        stats.levels[l].holes = holes;
        stats.levels[l].probes = PROBES;
    }
    Ok(Placement {
        levels,
        radii,
        stats,
    })
}

impl Accepted {
    /// Conflicts with points accepted during the current batch (indices `>= from`).
    fn conflicts_from(&self, c: &BasisPoint, spacing: f64, from: usize) -> bool {
        self.points[from..]
            .iter()
            .any(|q| poisson_distance(c.x, c.n, q.x, q.n) < spacing)
    }
}
