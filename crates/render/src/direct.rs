//! Exact direct light for images: the irradiance a point receives straight from the
//! emitters, `H_d(x) = Σ_j E_j ∫_{A_j} cos θ_x cos θ_y V(x, y) / (π r²) dA_y`, computed
//! per pixel sample so that shadows and the shading of directly lit surfaces do not
//! depend on a solution's elements (issue 12 §4: the default image shows the smooth
//! answer radiosity promises).
//!
//! Each emitter's term is evaluated as `E_j · F_j(x) · V̄_j(x)`: `F_j` is the
//! *unoccluded* point-to-emitter form factor — exact by Lambert's contour formula
//! (`wavelux_geometry::formfactor::point_to_polygon`) for triangles and
//! parallelograms, else a midpoint quadrature over a fine area grid of the emitter —
//! and `V̄_j = Σ_i w_i V_i / Σ_i w_i` is the kernel-weighted visible fraction of the
//! shadow rays to a set of emitter points, `w_i` the unoccluded kernel at the point.
//! Where an emitter is entirely visible or entirely hidden the estimate is exact and
//! noise-free; only penumbrae need many points.
//!
//! On triangles and parallelograms the points are the same for every receiver point
//! (a fixed pattern per emitter), so `H_d` is a deterministic function of `x` and
//! images show no Monte Carlo grain in soft shadows:
//! - a first pass of `m` shadow rays (`√m × √m`) only *detects* penumbrae: its points
//!   are the vertices of a `√m × √m` grid of an equal-area map of the emitter, pulled
//!   in by `1e-3`, the emitter's corners among them. A straight occluder edge that
//!   covers part of the emitter separates two of its corners, so it is never missed
//!   (a grid of cell centres, or random points, misses a covered strip up to a cell
//!   wide: receiver points there randomly got the unshadowed value, the speckle of
//!   earlier images);
//! - where the first pass disagrees on visibility, `V̄` comes from a fixed jittered
//!   stratified pattern of `16×` as many points (at most 4096; the pattern is seeded by
//!   the emitter's index): a deterministic rule whose error changes smoothly between
//!   neighbouring points (banding in steps of at most `1/(16m)` of the emitter, not
//!   noise).
//!
//! With `m ≥ 256` (no finer pattern) the first pass is the fixed stratified pattern
//! itself. Other shapes draw `m` points uniformly by area from the caller's random
//! stream (16× as many in penumbrae). Points behind an emitter's lit side receive
//! nothing from it.

use glam::{DVec2, DVec3};
use rand::RngExt;
use rand_pcg::Pcg64;
use wavelux_geometry::{Accel, Primitive, formfactor::point_to_polygon};

use crate::RenderError;
use crate::area::{AreaSampler, GridPoint};

/// Quadrature points per emitter for the unoccluded form factor of shapes without a
/// closed form.
const FF_POINTS: f64 = 1024.0;
/// Penumbra refinement: a point whose first pass mixes visible and hidden samples is
/// resampled with `PENUMBRA_SIDE²` times as many (stratified on a grid
/// `PENUMBRA_SIDE` times finer per axis).
const PENUMBRA_SIDE: usize = 4;
/// Largest stratification grid side of one emitter (`MAX_SIDE²` = 4096 samples).
const MAX_SIDE: usize = 64;

/// How an emitter's unoccluded form factor is computed.
#[derive(Debug, Clone)]
enum Shape {
    /// Triangle or parallelogram: corners for Lambert's formula.
    Polygon(Vec<DVec3>),
    /// Anything else: an area grid (point, front normal, area).
    Grid(Vec<GridPoint>),
}

/// One emitting side.
#[derive(Debug, Clone)]
struct Emitter {
    prim: u32,
    /// `−1` for a back side (its lit normal is the opposite of the front normal).
    sign: f64,
    emission: [f64; 3],
    shape: Shape,
    sampler: AreaSampler,
}

/// The emitters of a field, for exact direct light (module docs).
#[derive(Debug, Clone, Default)]
pub struct DirectLight {
    emitters: Vec<Emitter>,
}

impl DirectLight {
    /// The emitting sides `(primitive id in accel, back side?, exitance E)` of a field
    /// whose geometry is `accel`.
    ///
    /// # Errors
    /// [`RenderError::Scene`] for an unknown primitive id or an emitter that cannot be
    /// sampled by area.
    pub fn new(accel: &Accel, sides: &[(u32, bool, [f64; 3])]) -> Result<Self, RenderError> {
        let mut emitters = Vec::with_capacity(sides.len());
        for &(prim, back, emission) in sides {
            let p = accel.primitives().get(prim as usize).ok_or_else(|| {
                RenderError::Scene(format!("emitter primitive {prim} out of range"))
            })?;
            let sampler = AreaSampler::new(p)?;
            let shape = match p {
                Primitive::Triangle(t) => Shape::Polygon(t.v.to_vec()),
                Primitive::Parallelogram(q) => Shape::Polygon(q.corners().to_vec()),
                _ => Shape::Grid(sampler.grid(p, FF_POINTS / p.area())?),
            };
            emitters.push(Emitter {
                prim,
                sign: if back { -1.0 } else { 1.0 },
                emission,
                shape,
                sampler,
            });
        }
        Ok(Self { emitters })
    }

    /// True if there are no emitters.
    pub fn is_empty(&self) -> bool {
        self.emitters.is_empty()
    }

    /// Emitted irradiance (W/m², RGB) at `x` on a side with unit normal `n`, with
    /// `samples` shadow rays per emitter (≥ 1; rounded down to a square on triangles
    /// and parallelograms; 16× as many, at most 4096, where they disagree on
    /// visibility; module docs); `skip`: the primitive `x` lies on (never an occluder
    /// of its own point). `rng` is drawn from only for emitters of other shapes.
    /// Returns the irradiance and the number of shadow rays traced.
    pub fn irradiance(
        &self,
        accel: &Accel,
        x: DVec3,
        n: DVec3,
        skip: Option<u32>,
        samples: usize,
        rng: &mut Pcg64,
    ) -> ([f64; 3], u64) {
        let mut out = [0.0; 3];
        let mut rays = 0u64;
        let side = (samples.max(1) as f64).sqrt().floor().max(1.0) as usize;
        for (index, em) in self.emitters.iter().enumerate() {
            if Some(em.prim) == skip {
                continue;
            }
            let p = &accel.primitives()[em.prim as usize];
            let kernel = |y: DVec3, ny: DVec3| -> f64 {
                let d = y - x;
                let r2 = d.length_squared();
                if r2 <= 0.0 {
                    return 0.0;
                }
                let cx = n.dot(d);
                let cy = -ny.dot(d) * em.sign;
                if cx <= 0.0 || cy <= 0.0 {
                    0.0
                } else {
                    cx * cy / (r2 * r2)
                }
            };
            let f = match &em.shape {
                Shape::Polygon(v) => {
                    // Planar: nothing reaches points behind the lit side.
                    let c = v.iter().copied().sum::<DVec3>() / v.len() as f64;
                    if (x - c).dot(p.normal(DVec2::splat(0.5))) * em.sign <= 0.0 {
                        continue;
                    }
                    point_to_polygon(x, n, v).unwrap_or(0.0)
                }
                Shape::Grid(g) => {
                    g.iter().map(|&(y, ny, a)| a * kernel(y, ny)).sum::<f64>()
                        / std::f64::consts::PI
                }
            };
            if !(f > 0.0 && f.is_finite()) {
                continue;
            }
            // The fixed pattern of this emitter (module docs).
            let pattern_rng = || Pcg64::new(PATTERN_SEED, index as u128);
            // One pass over `m` points: kernel-weighted visible and total weights.
            let pass = |pattern: Pattern, m: usize, rng: &mut Pcg64| {
                let (mut wv, mut wt, mut n) = (0.0, 0.0, 0u64);
                let mut fixed = pattern_rng();
                for i in 0..m {
                    let (u, v) = match pattern {
                        Pattern::Vertices(side) => vertex(i, side),
                        Pattern::Cells(side) => cell(i, side, &mut fixed),
                        Pattern::Random => (0.0, 0.0),
                    };
                    let (y, ny) = match (pattern, p) {
                        (Pattern::Random, _) => match em.sampler.sample(p, rng) {
                            Ok(s) => (s.point, s.normal),
                            Err(_) => continue,
                        },
                        (_, Primitive::Triangle(t)) => {
                            let r = u.sqrt();
                            let (b, c) = (r * (1.0 - v), r * v);
                            (
                                t.v[0] + b * (t.v[1] - t.v[0]) + c * (t.v[2] - t.v[0]),
                                t.normal(),
                            )
                        }
                        (_, Primitive::Parallelogram(q)) => (q.eval(DVec2::new(u, v)), q.normal()),
                        _ => continue,
                    };
                    let w = kernel(y, ny);
                    if w <= 0.0 {
                        continue;
                    }
                    wt += w;
                    n += 1;
                    if !accel.occluded(x, y, [skip, Some(em.prim)]) {
                        wv += w;
                    }
                }
                (wv, wt, n)
            };
            let polygon = matches!(em.shape, Shape::Polygon(_));
            let fine_side = (side * PENUMBRA_SIDE).min(MAX_SIDE);
            let (first, m) = match (polygon, fine_side > side) {
                (true, true) => (Pattern::Vertices(side), side * side),
                (true, false) => (Pattern::Cells(side), side * side),
                (false, _) => (Pattern::Random, samples.max(1)),
            };
            let (mut wv, mut wt, n) = pass(first, m, rng);
            rays += n;
            // A penumbra (visibility disagrees between points): one finer pass with
            // PENUMBRA_SIDE² times the points (at most MAX_SIDE²) replaces the first.
            if wv > 0.0 && wv < wt {
                let (fine, count) = if polygon {
                    (Pattern::Cells(fine_side), fine_side * fine_side)
                } else {
                    (
                        Pattern::Random,
                        (m * PENUMBRA_SIDE * PENUMBRA_SIDE).min(MAX_SIDE * MAX_SIDE),
                    )
                };
                if count > m || matches!(first, Pattern::Vertices(_)) {
                    let (v2, t2, n2) = pass(fine, count, rng);
                    rays += n2;
                    if t2 > 0.0 {
                        (wv, wt) = (v2, t2);
                    }
                }
            }
            if wt > 0.0 {
                let g = f * wv / wt;
                for c in 0..3 {
                    out[c] += em.emission[c] * g;
                }
            }
        }
        (out, rays)
    }
}

/// Which emitter points a pass uses (module docs).
#[derive(Debug, Clone, Copy)]
enum Pattern {
    /// The vertices of a `side × side` grid, pulled in by [`VERTEX_INSET`].
    Vertices(usize),
    /// The fixed jittered stratified pattern of `side × side` cells.
    Cells(usize),
    /// Uniform by area from the caller's stream (shapes without an equal-area map).
    Random,
}

/// Stream of the fixed patterns (one stream per emitter index).
const PATTERN_SEED: u128 = 0x005e_edd1_2ec7_1194;
/// How far the detection vertices are pulled into the emitter (fraction of its
/// parameter square): shadow rays end on the emitter, not on its neighbours' edges.
const VERTEX_INSET: f64 = 1e-3;

/// Vertex `i` of a `side × side` grid over `[δ, 1 − δ]²` (`δ` = [`VERTEX_INSET`];
/// the centre for `side = 1`).
fn vertex(i: usize, side: usize) -> (f64, f64) {
    if side < 2 {
        return (0.5, 0.5);
    }
    let at = |k: usize| VERTEX_INSET + (1.0 - 2.0 * VERTEX_INSET) * k as f64 / (side - 1) as f64;
    (at(i % side), at(i / side))
}

/// A jittered point in cell `i` of a `side × side` grid of `[0, 1]²`.
fn cell(i: usize, side: usize, rng: &mut Pcg64) -> (f64, f64) {
    let (a, b) = (i % side, i / side);
    (
        (a as f64 + rng.random::<f64>()) / side as f64,
        (b as f64 + rng.random::<f64>()) / side as f64,
    )
}
