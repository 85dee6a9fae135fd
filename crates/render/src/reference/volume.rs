//! Monte Carlo ground truth for volume radiosity (the reference of issue 14 §6): an
//! analog particle tracer on the voxel grid of a [`VolumeGrid`], written
//! independently of the global cube's projector (its own traversal, no shared code).
//!
//! Physics (the model of `wavelux-volume`, GlobalCube §2.1):
//! * a voxel of opacity `σ < 1` is a homogeneous medium of extinction
//!   `κ = −ln(1 − σ)/h` that scatters isotropically with albedo `ω` per channel;
//! * a voxel of `σ = 1` is an opaque Lambertian box: a particle hitting one of its
//!   faces collides there and is reflected with probability-weight `ω` in a
//!   cosine-distributed direction about that face;
//! * sources: a particle leaves a source voxel with its own voxel's self-attenuation
//!   shaping where and in which direction it leaves (a point uniform in the voxel and an
//!   isotropic direction, accepted with probability `e^{−κ s}`, `s` the distance to the
//!   voxel's boundary), but its power is not reduced by its own voxel: a source's first
//!   flight ignores its own cell (the model's `m_pp = 1`). An opaque source emits from
//!   its exposed faces (those not touching another opaque voxel) as a Lambertian
//!   surface; voxels with optical depth above [`VolumeReferenceOptions::opaque_depth`]
//!   count as opaque here.
//! * Outside the grid is black: particles leaving it escape.
//!
//! Tallies per voxel and channel: the collided power (W; the power arriving at
//! collisions inside the voxel or on its faces), with standard errors from
//! [`VolumeReferenceOptions::batches`] independent batches; totals of emitted,
//! absorbed and escaped power. Particles carry RGB weights; after every collision the
//! weights are multiplied by the albedo and Russian roulette keeps their largest
//! channel near its starting value (unbiased).
//!
//! Determinism: particle `i` draws from its own stream `(seed, i)`; tallies are summed
//! in a fixed order of fixed chunks, so results do not depend on the thread count.

use ndarray::Array3;
use rand::RngExt;
use rayon::prelude::*;
use serde::Serialize;
use wavelux_volume::VolumeGrid;

use crate::sampling::rng_for;
use crate::{RenderError, invalid};

/// Options of the particle tracer.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct VolumeReferenceOptions {
    /// Particles in total (split evenly over the batches).
    pub particles: u64,
    /// Independent batches for the standard errors (≥ 2).
    pub batches: usize,
    /// Seed.
    pub seed: u64,
    /// Optical depth per voxel above which a voxel is treated as opaque (default 50:
    /// transmittance `e^{−50}`).
    pub opaque_depth: f64,
    /// Hard cap on collisions per particle (a safety net; roulette ends paths).
    pub max_collisions: usize,
}

impl Default for VolumeReferenceOptions {
    /// 1 000 000 particles in 16 batches, seed 0.
    fn default() -> Self {
        Self {
            particles: 1_000_000,
            batches: 16,
            seed: 0,
            opaque_depth: 50.0,
            max_collisions: 1 << 20,
        }
    }
}

/// The estimate.
#[derive(Debug, Clone, PartialEq)]
pub struct VolumeEstimate {
    /// Mean collided power per voxel and channel (W), `[z, y, x]` over the padded grid.
    pub collided: [Array3<f64>; 3],
    /// Standard error of [`Self::collided`] (W).
    pub std_error: [Array3<f64>; 3],
    /// Source power per channel (W).
    pub emitted: [f64; 3],
    /// Absorbed power per channel (W), estimated.
    pub absorbed: [f64; 3],
    /// Power leaving the grid per channel (W), estimated.
    pub escaped: [f64; 3],
    /// Particles traced.
    pub particles: u64,
    /// Collisions simulated.
    pub collisions: u64,
}

/// Medium data in the tracer's own layout.
struct Medium {
    n: usize,
    /// Extinction per voxel edge (optical depth across one voxel; ∞ = opaque).
    depth: Vec<f64>,
    albedo: Vec<[f64; 3]>,
}

impl Medium {
    fn at(&self, v: [i64; 3]) -> Option<usize> {
        let n = self.n as i64;
        if v.iter().any(|&c| c < 0 || c >= n) {
            None
        } else {
            Some(v[0] as usize + self.n * (v[1] as usize + self.n * v[2] as usize))
        }
    }
    fn opaque(&self, i: usize) -> bool {
        self.depth[i] == f64::INFINITY
    }
}

/// Tallies of one chunk.
struct Tally {
    collided: Vec<[f64; 3]>,
    absorbed: [f64; 3],
    escaped: [f64; 3],
    collisions: u64,
}

impl Tally {
    fn new(cells: usize) -> Self {
        Self {
            collided: vec![[0.0; 3]; cells],
            absorbed: [0.0; 3],
            escaped: [0.0; 3],
            collisions: 0,
        }
    }
    fn add(&mut self, o: &Tally) {
        for (a, b) in self.collided.iter_mut().zip(&o.collided) {
            for c in 0..3 {
                a[c] += b[c];
            }
        }
        for c in 0..3 {
            self.absorbed[c] += o.absorbed[c];
            self.escaped[c] += o.escaped[c];
        }
        self.collisions += o.collisions;
    }
}

/// A particle's position (voxel units), direction and voxel.
struct State {
    p: [f64; 3],
    d: [f64; 3],
    v: [i64; 3],
}

fn uniform_sphere(u: f64, v: f64) -> [f64; 3] {
    let z = 1.0 - 2.0 * u;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * std::f64::consts::PI * v;
    [r * phi.cos(), r * phi.sin(), z]
}

/// Cosine-distributed direction about the axis-aligned unit normal `axis`/`sign`.
fn cosine_about(axis: usize, sign: f64, u: f64, v: f64) -> [f64; 3] {
    let r = u.sqrt();
    let phi = 2.0 * std::f64::consts::PI * v;
    let mut d = [0.0; 3];
    d[axis] = sign * (1.0 - u).max(0.0).sqrt();
    d[(axis + 1) % 3] = r * phi.cos();
    d[(axis + 2) % 3] = r * phi.sin();
    d
}

/// Distance (voxel units) from `p` inside voxel `v` to its boundary along `d`, and the
/// axis crossed.
fn exit(p: [f64; 3], d: [f64; 3], v: [i64; 3]) -> (f64, usize) {
    let mut best = (f64::INFINITY, 0);
    for a in 0..3 {
        let t = if d[a] > 0.0 {
            (v[a] as f64 + 1.0 - p[a]) / d[a]
        } else if d[a] < 0.0 {
            (v[a] as f64 - p[a]) / d[a]
        } else {
            f64::INFINITY
        };
        if t < best.0 {
            best = (t, a);
        }
    }
    (best.0.max(0.0), best.1)
}

/// Exposed faces of opaque voxel `i` at `v` (neighbour outside or not opaque).
fn exposed(m: &Medium, v: [i64; 3]) -> Vec<(usize, f64)> {
    let mut out = Vec::new();
    for axis in 0..3 {
        for sign in [1.0, -1.0] {
            let mut w = v;
            w[axis] += sign as i64;
            if m.at(w).is_none_or(|j| !m.opaque(j)) {
                out.push((axis, sign));
            }
        }
    }
    out
}

/// Traces one particle with weights `w` from `s`; `init_max` is the roulette scale.
fn walk(
    m: &Medium,
    mut s: State,
    mut w: [f64; 3],
    rng: &mut impl RngExt,
    t: &mut Tally,
    max_collisions: usize,
) {
    let init_max = w[0].max(w[1]).max(w[2]);
    if init_max <= 0.0 {
        return;
    }
    let mut tau = -(1.0 - rng.random::<f64>()).ln();
    for _ in 0..max_collisions {
        let Some(i) = m.at(s.v) else {
            for c in 0..3 {
                t.escaped[c] += w[c];
            }
            return;
        };
        if m.opaque(i) {
            // Hit the face we entered through: collide, reflect about it.
            for c in 0..3 {
                t.collided[i][c] += w[c];
                t.absorbed[c] += w[c] * (1.0 - m.albedo[i][c]);
                w[c] *= m.albedo[i][c];
            }
            t.collisions += 1;
            // The face normal points back along the axis of entry: we came from the
            // neighbour opposite to the step; recover the axis from the position.
            let (axis, sign) = entry_face(&s);
            let q = (w[0].max(w[1]).max(w[2]) / init_max).min(1.0);
            if q <= 0.0 || rng.random::<f64>() >= q {
                return;
            }
            for c in &mut w {
                *c /= q;
            }
            s.d = cosine_about(axis, sign, rng.random(), rng.random());
            s.v[axis] += sign as i64;
            tau = -(1.0 - rng.random::<f64>()).ln();
            continue;
        }
        let (len, axis) = exit(s.p, s.d, s.v);
        let k = m.depth[i];
        if k * len > tau {
            // Collision inside the voxel.
            let l = tau / k;
            for a in 0..3 {
                s.p[a] += l * s.d[a];
            }
            for c in 0..3 {
                t.collided[i][c] += w[c];
                t.absorbed[c] += w[c] * (1.0 - m.albedo[i][c]);
                w[c] *= m.albedo[i][c];
            }
            t.collisions += 1;
            let q = (w[0].max(w[1]).max(w[2]) / init_max).min(1.0);
            if q <= 0.0 || rng.random::<f64>() >= q {
                return;
            }
            for c in &mut w {
                *c /= q;
            }
            s.d = uniform_sphere(rng.random(), rng.random());
            tau = -(1.0 - rng.random::<f64>()).ln();
            continue;
        }
        tau -= k * len;
        for a in 0..3 {
            s.p[a] += len * s.d[a];
        }
        // Snap the crossed coordinate onto the face and step.
        let sign = if s.d[axis] > 0.0 { 1 } else { -1 };
        s.p[axis] = (s.v[axis] + i64::from(sign > 0)) as f64;
        s.v[axis] += sign;
    }
}

/// The face of the current (opaque) voxel the particle entered through: the axis on
/// which its position lies on the voxel's boundary, facing back along the direction.
fn entry_face(s: &State) -> (usize, f64) {
    let mut best = (0usize, f64::INFINITY);
    for a in 0..3 {
        let lo = s.v[a] as f64;
        let dist = if s.d[a] > 0.0 {
            (s.p[a] - lo).abs()
        } else {
            (s.p[a] - (lo + 1.0)).abs()
        };
        if dist < best.1 {
            best = (a, dist);
        }
    }
    let a = best.0;
    (a, if s.d[a] > 0.0 { -1.0 } else { 1.0 })
}

/// Traces `opts.particles` particles from the sources of `grid`.
///
/// # Errors
/// [`RenderError::Invalid`] for fewer than 2 batches, no particles, or a grid without
/// sources.
pub fn trace_volume(
    grid: &VolumeGrid,
    opts: &VolumeReferenceOptions,
) -> Result<VolumeEstimate, RenderError> {
    if opts.batches < 2 {
        return Err(invalid(
            "batches",
            "at least 2 batches are needed for standard errors",
        ));
    }
    if opts.particles < opts.batches as u64 {
        return Err(invalid("particles", "fewer particles than batches"));
    }
    let n = grid.side;
    let cells = n * n * n;
    let mut depth = vec![0.0; cells];
    let mut albedo = vec![[0.0; 3]; cells];
    let mut weight = vec![0.0; cells];
    let mut power = vec![[0.0; 3]; cells];
    let vol = grid.voxel.powi(3);
    let mut emitted = [0.0; 3];
    for z in 0..n {
        for y in 0..n {
            for x in 0..n {
                let i = x + n * (y + n * z);
                let s = grid.opacity[[z, y, x]];
                let a = if s >= 1.0 {
                    f64::INFINITY
                } else {
                    -(-s).ln_1p()
                };
                depth[i] = if a > opts.opaque_depth {
                    f64::INFINITY
                } else {
                    a
                };
                albedo[i] = [0, 1, 2].map(|c| grid.albedo[c][[z, y, x]]);
                power[i] = [0, 1, 2].map(|c| grid.source[c][[z, y, x]] * vol);
                weight[i] = power[i].iter().sum();
                for c in 0..3 {
                    emitted[c] += power[i][c];
                }
            }
        }
    }
    let m = Medium { n, depth, albedo };
    let mut cdf = Vec::with_capacity(cells);
    let mut total = 0.0;
    for w in &weight {
        total += w;
        cdf.push(total);
    }
    if total <= 0.0 {
        return Err(invalid("grid", "no sources: nothing to trace"));
    }
    let per_batch = opts.particles / opts.batches as u64;
    const CHUNK: u64 = 4096;
    const WAVE: usize = 8;
    let mut mean = vec![[0.0; 3]; cells];
    let mut m2 = vec![[0.0; 3]; cells];
    let (mut absorbed, mut escaped) = ([0.0; 3], [0.0; 3]);
    let mut collisions = 0;
    let scale = 1.0 / per_batch as f64;
    for b in 0..opts.batches {
        let first = b as u64 * per_batch;
        let chunks: Vec<(u64, u64)> = (0..per_batch.div_ceil(CHUNK))
            .map(|k| (first + k * CHUNK, first + ((k + 1) * CHUNK).min(per_batch)))
            .collect();
        let mut batch = Tally::new(cells);
        for wave in chunks.chunks(WAVE) {
            let parts: Vec<Tally> = wave
                .par_iter()
                .map(|&(lo, hi)| {
                    let mut t = Tally::new(cells);
                    for i in lo..hi {
                        let mut rng = rng_for(opts.seed, i, 0x766f6c);
                        emit_one(
                            &m,
                            &cdf,
                            total,
                            &power,
                            &mut rng,
                            &mut t,
                            opts.max_collisions,
                        );
                    }
                    t
                })
                .collect();
            for p in &parts {
                batch.add(p);
            }
        }
        // Each particle carries total/per_batch of the power (weights below are in
        // units of the total); Welford over batch means.
        let k = (b + 1) as f64;
        for (i, c) in batch.collided.iter().enumerate() {
            for ch in 0..3 {
                let x = c[ch] * scale;
                let d = x - mean[i][ch];
                mean[i][ch] += d / k;
                m2[i][ch] += d * (x - mean[i][ch]);
            }
        }
        for ch in 0..3 {
            absorbed[ch] += batch.absorbed[ch] * scale / opts.batches as f64;
            escaped[ch] += batch.escaped[ch] * scale / opts.batches as f64;
        }
        collisions += batch.collisions;
    }
    let bf = opts.batches as f64;
    let field = |f: &dyn Fn(usize, usize) -> f64| -> [Array3<f64>; 3] {
        [0, 1, 2].map(|c| Array3::from_shape_fn((n, n, n), |(z, y, x)| f(x + n * (y + n * z), c)))
    };
    let collided = field(&|i, c| mean[i][c]);
    let std_error = field(&|i, c| (m2[i][c] / (bf - 1.0) / bf).sqrt());
    Ok(VolumeEstimate {
        collided,
        std_error,
        emitted,
        absorbed,
        escaped,
        particles: per_batch * opts.batches as u64,
        collisions,
    })
}

/// Emits one particle (power in units of the per-particle share: the caller scales).
fn emit_one(
    m: &Medium,
    cdf: &[f64],
    total: f64,
    power: &[[f64; 3]],
    rng: &mut impl RngExt,
    t: &mut Tally,
    max_collisions: usize,
) {
    let u = rng.random::<f64>() * total;
    let i = cdf.partition_point(|&c| c <= u).min(cdf.len() - 1);
    let n = m.n;
    let v = [(i % n) as i64, ((i / n) % n) as i64, (i / (n * n)) as i64];
    let wsum: f64 = power[i].iter().sum();
    let w = power[i].map(|p| p / wsum * total);
    if m.opaque(i) {
        let faces = exposed(m, v);
        if faces.is_empty() {
            // Enclosed by opaque voxels: the power never leaves the voxel.
            for c in 0..3 {
                t.absorbed[c] += w[c];
            }
            return;
        }
        let k = ((rng.random::<f64>() * faces.len() as f64) as usize).min(faces.len() - 1);
        let (axis, sign) = faces[k];
        let mut p = [0.0; 3];
        for a in 0..3 {
            p[a] = v[a] as f64 + rng.random::<f64>();
        }
        p[axis] = v[axis] as f64 + if sign > 0.0 { 1.0 } else { 0.0 };
        let d = cosine_about(axis, sign, rng.random(), rng.random());
        let mut nv = v;
        nv[axis] += sign as i64;
        walk(m, State { p, d, v: nv }, w, rng, t, max_collisions);
        return;
    }
    let k = m.depth[i];
    loop {
        let p = [0, 1, 2].map(|a| v[a] as f64 + rng.random::<f64>());
        let d = uniform_sphere(rng.random(), rng.random());
        let (len, axis) = exit(p, d, v);
        if k > 0.0 && rng.random::<f64>() >= (-k * len).exp() {
            continue;
        }
        let mut q = p;
        for a in 0..3 {
            q[a] += len * d[a];
        }
        let sign = if d[axis] > 0.0 { 1 } else { -1 };
        q[axis] = (v[axis] + i64::from(sign > 0)) as f64;
        let mut nv = v;
        nv[axis] += sign;
        walk(m, State { p: q, d, v: nv }, w, rng, t, max_collisions);
        return;
    }
}
