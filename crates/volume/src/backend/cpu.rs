//! The CPU projector: rayon over receivers, one ray per framebuffer pixel, exact
//! cell-by-cell compositing (GlobalCube §3.1's slices, integrated exactly per cell).
//!
//! * [`Projection::Exact`]: every cell at full resolution ("every slice at full
//!   resolution"); the traversal steps from cell to cell of the active hierarchy, so a
//!   coarse leaf or an empty octree node is crossed in one step (homogeneous cells
//!   composite exactly: the result equals stepping through their voxels).
//! * [`Projection::Pyramid`]: beyond the distance where a pixel's footprint
//!   `t · √ΔΩ` reaches `2^l` voxels, the ray samples level `l` of a pyramid rebuilt from
//!   the current emission at every call (mean transmittance per voxel, summed power,
//!   isotropic emission); the level-of-detail sampling of volume rendering, needed at
//!   256³ where full-resolution rays are too long.
//!
//! Determinism: receivers are independent and each ray is summed in pixel order, so
//! the result does not depend on the thread count.

use rayon::prelude::*;

use super::{
    Emission, FaceRgb, GatherStats, ProjectionScene, Projector, Receiver, TraversalCell,
    check_inputs,
};
use crate::cell::{Collision, entry_weights, total_weight_fast};
use crate::cubemap::{CubeMap, Pixel, face_index};
use crate::error::VolumeError;

/// Transmittance below which a ray stops (relative loss of a uniform field ≤ this).
pub const MIN_TRANSMITTANCE: f64 = 1e-13;

/// Which samples the rays take.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Projection {
    /// Every cell at full resolution (default).
    #[default]
    Exact,
    /// Lowpass levels matching the pixel footprint.
    Pyramid,
}

/// Where the conserving escape puts pixel `i`'s points in their sub-squares (in
/// `[0, 1)²`): the R2 low-discrepancy sequence `frac(0.5 + i (1/g, 1/g²))`, `g` the
/// plastic number 1.3247179572447460 (`g³ = g + 1`); pixels in the order of
/// [`crate::cubemap::CubeMap::pixels`].
#[must_use]
pub fn escape_offset(i: usize) -> [f64; 2] {
    const G: f64 = 1.324_717_957_244_746;
    let i = i as f64;
    [(0.5 + i / G).fract(), (0.5 + i / (G * G)).fract()]
}

/// The CPU backend.
#[derive(Debug, Clone, Copy)]
pub struct CpuProjector {
    /// Sampling mode.
    pub projection: Projection,
    /// Adaptive supersampling.
    pub antialias: AntiAlias,
    /// Ray origins per axis of a receiver (1..=[`MAX_RECEIVER_SAMPLES`]): `k³` points
    /// of a cell that gathers at its centre, `k²` points of every entry face of a cell
    /// that gathers on its faces (opaque cells always do when `k > 1`), and `k²` points
    /// of every boundary square of the escape measurement; their radiances are
    /// averaged. With `k > 1` the escape is also the conserving one (the boundary
    /// cells' own outer faces counted exactly, [`super::boundary_emission`]).
    /// `1` is the paper's one ray per pixel from the centre; more samples
    /// integrate the receiver instead of point-sampling it, which removes the
    /// near-field bias of the transport (energy is then conserved more tightly: see
    /// the crate docs) at `k²`–`k³` times the cost.
    pub receiver_samples: u32,
}

/// Largest [`CpuProjector::receiver_samples`].
pub const MAX_RECEIVER_SAMPLES: u32 = 8;

/// [`CpuProjector::receiver_samples`] of [`CpuProjector::default`] and of the command's
/// `--receiver-samples`: two points per axis integrate the receiver instead of
/// point-sampling it (the paper's one point, [`CpuProjector::new`]), which brings the
/// energy account much closer to balance (see the crate docs, "Energy conservation").
pub const DEFAULT_RECEIVER_SAMPLES: u32 = 2;

impl Default for CpuProjector {
    /// Exact sampling, adaptive supersampling, [`DEFAULT_RECEIVER_SAMPLES`] receiver
    /// samples per axis: the conservative operator (see the crate docs, "Energy
    /// conservation").
    fn default() -> Self {
        Self::new(Projection::default(), AntiAlias::default())
            .with_receiver_samples(DEFAULT_RECEIVER_SAMPLES)
    }
}

impl CpuProjector {
    /// A projector with the given sampling mode and supersampling, one receiver sample
    /// (the paper's one ray per pixel from the receiver's centre).
    #[must_use]
    pub fn new(projection: Projection, antialias: AntiAlias) -> Self {
        Self {
            projection,
            antialias,
            receiver_samples: 1,
        }
    }

    /// The same projector with `k` receiver samples per axis (clamped to
    /// `1..=`[`MAX_RECEIVER_SAMPLES`]).
    #[must_use]
    pub fn with_receiver_samples(mut self, k: u32) -> Self {
        self.receiver_samples = k.clamp(1, MAX_RECEIVER_SAMPLES);
        self
    }
}

/// One level of the pyramid: per coarse cell the extinction per voxel edge and the
/// isotropic emission coefficient.
struct Level {
    side: usize,
    extinction: Vec<f64>,
    emission: Vec<[f64; 3]>,
}

struct Pyramid {
    /// `levels[l - 1]` is level `l` (cells of `2^l` voxels).
    levels: Vec<Level>,
}

impl Pyramid {
    fn build(scene: &ProjectionScene<'_>, emission: &Emission<'_>) -> Self {
        let n = scene.side;
        let max_level = n.trailing_zeros() as usize;
        let mut levels = Vec::with_capacity(max_level);
        for l in 1..=max_level {
            let side = n >> l;
            let mut trans = vec![0.0; side * side * side];
            let mut power = vec![[0.0; 3]; side * side * side];
            for (c, p) in scene.cells.iter().zip(emission.power) {
                let t = if c.extinction == f64::INFINITY {
                    0.0
                } else {
                    (-c.extinction).exp()
                };
                let size = c.size as usize;
                if size >= (1 << l) {
                    let k = size >> l;
                    let share = 1.0 / (k * k * k) as f64;
                    let vol = (1usize << (3 * l)) as f64;
                    let o = c.origin.map(|v| v as usize >> l);
                    for z in o[2]..o[2] + k {
                        for y in o[1]..o[1] + k {
                            for x in o[0]..o[0] + k {
                                let i = x + side * (y + side * z);
                                trans[i] += vol * t;
                                for ch in 0..3 {
                                    power[i][ch] += share * p[ch];
                                }
                            }
                        }
                    }
                } else {
                    let o = c.origin.map(|v| v as usize >> l);
                    let i = o[0] + side * (o[1] + side * o[2]);
                    trans[i] += (size * size * size) as f64 * t;
                    for ch in 0..3 {
                        power[i][ch] += p[ch];
                    }
                }
            }
            let vol = (1usize << (3 * l)) as f64;
            let edge = scene.voxel * (1usize << l) as f64;
            let mut extinction = vec![0.0; trans.len()];
            let mut em = vec![[0.0; 3]; trans.len()];
            for i in 0..trans.len() {
                let mean = (trans[i] / vol).clamp(0.0, 1.0);
                let k = if mean <= 0.0 {
                    f64::INFINITY
                } else {
                    -mean.ln()
                };
                extinction[i] = k;
                let a = if k == f64::INFINITY {
                    k
                } else {
                    k * (1usize << l) as f64
                };
                let scale = if k > 0.0 {
                    let g = total_weight_fast(a);
                    if g > 0.0 {
                        1.0 / (g * edge * edge)
                    } else {
                        0.0
                    }
                } else {
                    1.0 / (4.0 * std::f64::consts::PI * edge * edge * edge)
                };
                em[i] = power[i].map(|p| p * scale);
            }
            levels.push(Level {
                side,
                extinction,
                emission: em,
            });
        }
        Self { levels }
    }
}

/// A ray's result: radiance per channel and cells composited.
struct Traced {
    radiance: [f64; 3],
    steps: u64,
}

/// Where a ray's contributions go: `add(w, h, entry, d)` adds `w` times the emission a
/// ray entering `h` through the faces `entry` (weights over the axes) along `d` sees.
trait Sink {
    fn add(&mut self, tracer: &Tracer<'_>, w: f64, h: &Hit, entry: [f64; 3], d: [f64; 3]);
}

/// Sums the radiance (the gather).
struct RadianceSink([f64; 3]);

impl Sink for RadianceSink {
    fn add(&mut self, tracer: &Tracer<'_>, w: f64, h: &Hit, entry: [f64; 3], d: [f64; 3]) {
        let e = tracer.emission_of(h, entry, d);
        for ch in 0..3 {
            self.0[ch] += w * e[ch];
        }
    }
}

/// One receiver's recorded transport entries: (sender column `6 · cell + face`, entry
/// face, weight).
type Entries = Vec<(u32, u8, f64)>;

/// Where recorded entries go: a plain list (kept in order), or the sums per (column,
/// entry face) of a receiver ([`Accumulator`]).
trait EntryOut {
    fn push(&mut self, col: u32, row: u8, w: f64);
}

impl EntryOut for Entries {
    fn push(&mut self, col: u32, row: u8, w: f64) {
        Vec::push(self, (col, row, w));
    }
}

/// One receiver's transport row being summed: per sender column its six entry-face
/// weights, found through an open-addressing table (linear probing) that is reused
/// from receiver to receiver. Each weight is summed in the order the traversal adds
/// it, so the sums are bitwise those of sorting the entries stably by (column, entry
/// face) and adding them in order, without sorting or storing every contribution.
#[derive(Default)]
struct Accumulator {
    /// Table of `(column + 1, index into vals)`; 0 marks a free slot; power-of-two length.
    table: Vec<(u32, u32)>,
    /// The columns in first-touch order.
    cols: Vec<u32>,
    /// Per touched column, its six entry faces' sums.
    vals: Vec<[f64; 6]>,
}

impl Accumulator {
    fn slot(&self, col: u32) -> usize {
        // Fibonacci hashing of the column; the table's length is a power of two.
        let mask = self.table.len() - 1;
        let mut i = (u64::from(col).wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 32) as usize & mask;
        while self.table[i].0 != 0 && self.table[i].0 != col + 1 {
            i = (i + 1) & mask;
        }
        i
    }

    fn grow(&mut self) {
        let len = (2 * self.table.len()).max(1024);
        self.table = vec![(0, 0); len];
        for (k, &c) in self.cols.iter().enumerate() {
            let i = self.slot(c);
            self.table[i] = (c + 1, k as u32);
        }
    }

    /// The sorted entries `(column, entry face, sum · scale)` with a non-zero weight,
    /// appended to `out`; the accumulator is left empty.
    fn drain_sorted(&mut self, scale: f64, out: &mut Entries) {
        let mut order: Vec<(u32, u32)> = self
            .cols
            .iter()
            .enumerate()
            .map(|(k, &c)| (c, k as u32))
            .collect();
        order.sort_unstable();
        for (c, k) in order {
            for (row, &w) in self.vals[k as usize].iter().enumerate() {
                let w = w * scale;
                if w != 0.0 {
                    out.push((c, row as u8, w));
                }
            }
        }
        if !self.cols.is_empty() {
            self.table.fill((0, 0));
        }
        self.cols.clear();
        self.vals.clear();
    }
}

impl EntryOut for Accumulator {
    fn push(&mut self, col: u32, row: u8, w: f64) {
        if 2 * (self.cols.len() + 1) > self.table.len() {
            self.grow();
        }
        let i = self.slot(col);
        let k = if self.table[i].0 == 0 {
            let k = self.cols.len();
            self.table[i] = (col + 1, k as u32);
            self.cols.push(col);
            self.vals.push([0.0; 6]);
            k
        } else {
            self.table[i].1 as usize
        };
        self.vals[k][row as usize] += w;
    }
}

/// Records the weights of the sender faces instead (the [`super::Transport`]): every
/// contribution goes to the receiver's entry faces with the factors `rows`.
struct RecordSink<'r, O: EntryOut> {
    rows: [f64; 6],
    out: &'r mut O,
}

impl<O: EntryOut> Sink for RecordSink<'_, O> {
    fn add(&mut self, _: &Tracer<'_>, w: f64, h: &Hit, entry: [f64; 3], d: [f64; 3]) {
        for (a, &ea) in entry.iter().enumerate() {
            if ea == 0.0 {
                continue;
            }
            let col = (6 * h.ci + entry_face(a, d)) as u32;
            for (row, &f) in self.rows.iter().enumerate() {
                if f != 0.0 {
                    self.out.push(col, row as u8, w * ea * f);
                }
            }
        }
    }
}

/// Sums the radiance and records the entries in one traversal (the recording's first
/// pass, whose radiances choose the supersampled pixels).
struct BothSink<'r, O: EntryOut> {
    radiance: RadianceSink,
    record: RecordSink<'r, O>,
}

impl<O: EntryOut> Sink for BothSink<'_, O> {
    fn add(&mut self, tracer: &Tracer<'_>, w: f64, h: &Hit, entry: [f64; 3], d: [f64; 3]) {
        self.radiance.add(tracer, w, h, entry, d);
        self.record.add(tracer, w, h, entry, d);
    }
}

/// The recording rows of one sample ray of a pixel of solid angle `solid_angle` with
/// collision weights `w` and entry faces `entries`: the ray's radiance reaches entry
/// face `e` (`Some`: a face sample) or all three (`None`: a cell sample) with the
/// weight `ΔΩ · w_e · inv · share`.
fn sample_rows(
    entries: [u8; 3],
    solid_angle: f64,
    w: [f64; 3],
    e: Option<usize>,
    inv: f64,
    share: f64,
) -> [f64; 6] {
    let mut rows = [0.0; 6];
    match e {
        Some(e) => {
            rows[entries[e] as usize] = solid_angle * w[e] * inv * share;
        }
        None => {
            for e in 0..3 {
                rows[entries[e] as usize] += solid_angle * w[e] * inv * share;
            }
        }
    }
    rows
}

/// A ray: origin and direction in voxel units, where it starts and the face (as
/// weights over the three axes) it enters its first cell through.
#[derive(Clone, Copy)]
struct Ray {
    o: [f64; 3],
    d: [f64; 3],
    t: f64,
    /// The first voxel crossed (unused when `inside` is set).
    idx: [i64; 3],
    /// Entry weight per axis: the ray enters a cell through the face of axis `a` it
    /// meets moving along `d` ([`entry_face`]) with weight `entry[a]` (one axis, or a
    /// mixture after an exact edge or corner crossing; they sum to 1).
    entry: [f64; 3],
    /// The box `(lo, size)` the ray starts inside (the receiver): it contributes
    /// nothing and the ray leaves it by the same crossing rule as every other cell.
    inside: Option<([i64; 3], i64)>,
}

/// The face of a cell a ray moving along `d` enters through across axis `a`.
fn entry_face(a: usize, d: [f64; 3]) -> usize {
    face_index(a, d[a] > 0.0)
}

/// The entry weights of a crossing of axis `a` alone.
fn unit_entry(a: usize) -> [f64; 3] {
    let mut e = [0.0; 3];
    e[a] = 1.0;
    e
}

/// The voxel coordinate of position `x` for a ray moving with component `d`: a
/// position on a voxel boundary goes to the side the ray moves to (so the ray never
/// visits a voxel it only touches).
fn voxel_coordinate(x: f64, d: f64) -> i64 {
    let f = x.floor();
    if x == f && d < 0.0 {
        f as i64 - 1
    } else {
        f as i64
    }
}

/// The voxel a ray from `o` along `d` starts in (a coordinate on a voxel boundary goes
/// to the side the ray moves to).
fn start_voxel(o: [f64; 3], d: [f64; 3]) -> [i64; 3] {
    [0, 1, 2].map(|a| voxel_coordinate(o[a], d[a]))
}

/// The ray from the centre of face `face` of the box `[lo, lo + size)` along `d`.
fn face_ray(lo: [i64; 3], size: i64, face: usize, d: [f64; 3]) -> Ray {
    face_ray_at(lo, size, face, d, [0.5, 0.5])
}

/// The ray from the point of face `face` of the box `[lo, lo + size)` at fractions
/// `at` (in `(0, 1)`) of the side along the face's two tangent axes (the next axes
/// cyclically), along `d`.
fn face_ray_at(lo: [i64; 3], size: i64, face: usize, d: [f64; 3], at: [f64; 2]) -> Ray {
    let axis = face / 2;
    let negative = face % 2 == 1;
    let (ta, tb) = ((axis + 1) % 3, (axis + 2) % 3);
    let mut o = [0.0; 3];
    o[ta] = lo[ta] as f64 + at[0] * size as f64;
    o[tb] = lo[tb] as f64 + at[1] * size as f64;
    o[axis] = if negative {
        lo[axis] as f64
    } else {
        (lo[axis] + size) as f64
    };
    let mut idx = start_voxel(o, d);
    idx[axis] = if negative {
        lo[axis] - 1
    } else {
        lo[axis] + size
    };
    Ray {
        o,
        d,
        t: 0.0,
        idx,
        // The receiver's face `face` touches the next cell's opposite face.
        entry: unit_entry(axis),
        inside: None,
    }
}

/// The ray from the point at fractions `at` (in `(0, 1)`) of the box's side along `d`;
/// it starts inside the box and leaves it by the traversal's crossing rule.
fn box_ray_at(lo: [i64; 3], size: i64, d: [f64; 3], at: [f64; 3]) -> Ray {
    let o = [0, 1, 2].map(|a| lo[a] as f64 + at[a] * size as f64);
    Ray {
        o,
        d,
        t: 0.0,
        idx: lo,
        entry: unit_entry(0),
        inside: Some((lo, size)),
    }
}

/// One box a ray crosses: an active cell, or a pyramid cell standing in for the cells
/// it covers.
#[derive(Clone, Copy)]
struct Hit {
    lo: [i64; 3],
    size: i64,
    /// Optical depth per voxel edge.
    ext: f64,
    /// The active cell (emission coefficients) when `coarse` is `None`.
    ci: usize,
    /// A pyramid cell's isotropic emission.
    coarse: Option<[f64; 3]>,
}

impl Hit {
    fn same_box(&self, other: &Hit) -> bool {
        self.lo == other.lo && self.size == other.size
    }
}

/// The orderings of the axes a ray crosses at one point (edges: 2, corners: 6).
const ORDERS_2: [[usize; 2]; 2] = [[0, 1], [1, 0]];
const ORDERS_3: [[usize; 3]; 6] = [
    [0, 1, 2],
    [0, 2, 1],
    [1, 0, 2],
    [1, 2, 0],
    [2, 0, 1],
    [2, 1, 0],
];

struct Tracer<'a> {
    scene: &'a ProjectionScene<'a>,
    emission: &'a Emission<'a>,
    pyramid: Option<&'a Pyramid>,
    /// Receiver samples per axis ([`CpuProjector::receiver_samples`]).
    samples: usize,
}

impl Tracer<'_> {
    fn cell_at(&self, idx: [i64; 3]) -> Option<&TraversalCell> {
        let n = self.scene.side as i64;
        if idx.iter().any(|&i| i < 0 || i >= n) {
            return None;
        }
        let lin = (idx[0] + n * (idx[1] + n * idx[2])) as usize;
        Some(&self.scene.cells[self.scene.cell_map[lin] as usize])
    }

    /// The box containing voxel `idx` for a ray at distance `t` (voxel units) whose
    /// pixel is `footprint` radians wide: the active cell, or with the pyramid the
    /// coarse cell matching the footprint. `None` outside the grid.
    fn hit(&self, idx: [i64; 3], t: f64, footprint: f64) -> Option<Hit> {
        let n = self.scene.side as i64;
        if idx.iter().any(|&i| i < 0 || i >= n) {
            return None;
        }
        let lin = (idx[0] + n * (idx[1] + n * idx[2])) as usize;
        let ci = self.scene.cell_map[lin] as usize;
        let cell: &TraversalCell = &self.scene.cells[ci];
        let mut h = Hit {
            lo: cell.origin.map(i64::from),
            size: i64::from(cell.size),
            ext: cell.extinction,
            ci,
            coarse: None,
        };
        if let Some(p) = self.pyramid {
            let w = t * footprint;
            if w >= 2.0 {
                let l = (w.log2().floor() as usize).min(p.levels.len());
                if (1i64 << l) > h.size {
                    let lev = &p.levels[l - 1];
                    let c = idx.map(|i| (i >> l) as usize);
                    let li = c[0] + lev.side * (c[1] + lev.side * c[2]);
                    h.lo = c.map(|c| (c as i64) << l);
                    h.size = 1 << l;
                    h.ext = lev.extinction[li];
                    h.coarse = Some(lev.emission[li]);
                }
            }
        }
        Some(h)
    }

    /// The emission a ray entering `h` with entry weights `entry` along `d` sees.
    fn emission_of(&self, h: &Hit, entry: [f64; 3], d: [f64; 3]) -> [f64; 3] {
        if let Some(e) = h.coarse {
            return e;
        }
        let c = &self.emission.coefficients[h.ci];
        let mut e = [0.0; 3];
        for (a, &w) in entry.iter().enumerate() {
            if w != 0.0 {
                let f = &c[entry_face(a, d)];
                for ch in 0..3 {
                    e[ch] += w * f[ch];
                }
            }
        }
        e
    }

    /// Composites front to back along `ray`; each cell contributes the emission of the
    /// face the ray enters it through. `footprint` is the pixel's angular width (rad),
    /// used by the pyramid.
    ///
    /// Crossings: a ray leaves a box across the faces whose planes it meets first. Where
    /// it meets two or three at once (an exact edge or corner crossing, which cube-map
    /// pixel centres produce systematically), the crossing is the mean over every
    /// order of stepping across those axes: in each order the ray passes the cells
    /// beside the edge (or corner) with zero-length chords, where an opaque one stops it
    /// (contributing its emission) and any other one changes nothing; the fraction of
    /// orders that pass multiplies the transmittance and the ray enters the cell beyond
    /// through the mixture of faces the passing orders end on. The rule treats the axes
    /// alike, so the projection does not depend on how the axes are labelled (a
    /// rotated or transposed grid gives the same face powers, faces permuted); it keeps
    /// opaque cells that touch along an edge light-tight (every order meets one of
    /// them).
    fn trace(&self, ray: Ray, footprint: f64) -> Traced {
        self.trace_skipping(ray, footprint, false)
    }

    /// [`Tracer::trace`]; with `skip_first` the first cell's emission is left out (its
    /// opacity is not): the conserving escape counts the boundary cells' own faces
    /// exactly instead ([`super::boundary_emission`]).
    fn trace_skipping(&self, ray: Ray, footprint: f64, skip_first: bool) -> Traced {
        let mut sink = RadianceSink([0.0; 3]);
        let steps = self.trace_into(ray, footprint, skip_first, &mut sink);
        Traced {
            radiance: sink.0,
            steps,
        }
    }

    /// The traversal of [`Tracer::trace_skipping`], handing every contribution to
    /// `sink`; returns the cells composited.
    fn trace_into<S: Sink>(
        &self,
        ray: Ray,
        footprint: f64,
        mut skip_first: bool,
        sink: &mut S,
    ) -> u64 {
        let Ray {
            o,
            d,
            mut t,
            mut idx,
            mut entry,
            mut inside,
        } = ray;
        let inv = d.map(|x| if x != 0.0 { 1.0 / x } else { f64::INFINITY });
        let mut trans = 1.0;
        let mut steps = 0u64;
        let h = self.scene.voxel;
        loop {
            let (cur, contributes) = match inside.take() {
                Some((lo, size)) => (
                    Hit {
                        lo,
                        size,
                        ext: 0.0,
                        ci: 0,
                        coarse: None,
                    },
                    false,
                ),
                None => match self.hit(idx, t, footprint) {
                    Some(c) => (c, true),
                    None => break,
                },
            };
            let (lo, size) = (cur.lo, cur.size);
            let hi = lo.map(|v| v + size);
            let mut te = f64::INFINITY;
            let mut ta = [f64::INFINITY; 3];
            for a in 0..3 {
                if d[a] > 0.0 {
                    ta[a] = (hi[a] as f64 - o[a]) * inv[a];
                } else if d[a] < 0.0 {
                    ta[a] = (lo[a] as f64 - o[a]) * inv[a];
                }
                te = te.min(ta[a]);
            }
            if contributes {
                let len = (te - t).max(0.0);
                let emits = !std::mem::take(&mut skip_first);
                steps += 1;
                let ext = cur.ext;
                if ext > 0.0 {
                    let tr = if ext == f64::INFINITY {
                        0.0
                    } else {
                        (-ext * len).exp()
                    };
                    if emits {
                        sink.add(self, trans * (1.0 - tr), &cur, entry, d);
                    }
                    trans *= tr;
                    if trans < MIN_TRANSMITTANCE {
                        break;
                    }
                } else if emits {
                    sink.add(self, trans * len * h, &cur, entry, d);
                }
            }
            if te == f64::INFINITY {
                break;
            }
            // The voxel beside the exit point inside the box, and the one across each
            // exit face.
            let mut base = [0i64; 3];
            let mut stepped = [0i64; 3];
            let mut tied = [0usize; 3];
            let mut n_tied = 0;
            for a in 0..3 {
                // (A one-voxel box has one voxel beside every exit point.)
                base[a] = if size == 1 {
                    lo[a]
                } else {
                    voxel_coordinate(o[a] + te * d[a], d[a]).clamp(lo[a], hi[a] - 1)
                };
                if ta[a] == te {
                    stepped[a] = if d[a] > 0.0 { hi[a] } else { lo[a] - 1 };
                    base[a] = if d[a] > 0.0 { hi[a] - 1 } else { lo[a] };
                    tied[n_tied] = a;
                    n_tied += 1;
                }
            }
            idx = base;
            for &a in &tied[..n_tied] {
                idx[a] = stepped[a];
            }
            t = te;
            if n_tied == 1 {
                entry = unit_entry(tied[0]);
                continue;
            }
            // An exact edge (2 axes) or corner (3 axes) crossing: average the orders.
            let beyond = self.hit(idx, t, footprint);
            let mut passed = 0usize;
            let mut mix = [0.0; 3];
            let orders = if n_tied == 2 { 2.0 } else { 6.0 };
            let w_stop = trans / orders;
            let mut one_order = |order: &[usize]| {
                let mut at = base;
                let mut last = order[order.len() - 1];
                for &a in &order[..order.len() - 1] {
                    at[a] = stepped[a];
                    let Some(side) = self.hit(at, t, footprint) else {
                        continue;
                    };
                    if beyond.is_some_and(|b| b.same_box(&side)) {
                        last = a;
                        break;
                    }
                    if side.ext == f64::INFINITY {
                        sink.add(self, w_stop, &side, unit_entry(a), d);
                        steps += 1;
                        return;
                    }
                }
                passed += 1;
                mix[last] += 1.0;
            };
            if n_tied == 2 {
                let ab = [tied[0], tied[1]];
                for o in ORDERS_2 {
                    one_order(&o.map(|k| ab[k]));
                }
            } else {
                for o in ORDERS_3 {
                    one_order(&o);
                }
            }
            trans *= passed as f64 / orders;
            if passed == 0 || trans < MIN_TRANSMITTANCE {
                break;
            }
            entry = mix.map(|m| m / passed as f64);
        }
        steps
    }

    /// Whether any face centre of the box touches an opaque cell (then every entry
    /// face gets its own ray, so that faces hidden by a touching opaque neighbour see
    /// it, not the light beyond).
    fn touches_opaque(&self, lo: [i64; 3], size: i64) -> bool {
        (0..6).any(|f| {
            let r = face_ray(lo, size, f, {
                let mut d = [0.0; 3];
                d[f / 2] = if f % 2 == 0 { 1.0 } else { -1.0 };
                d
            });
            self.cell_at(r.idx)
                .is_some_and(|c| c.extinction == f64::INFINITY)
        })
    }

    /// The receiver's sample rays along `d`: `k²` points of every entry face `e` with
    /// a positive weight (`v.per_face`; handed with `Some(e)`), or `k³` points of the box
    /// (handed with `None`: they serve all three entry faces), each with its share
    /// `1/k²` or `1/k³`.
    fn for_samples(
        &self,
        v: &ReceiverView,
        d: [f64; 3],
        entries: [u8; 3],
        weights: [f64; 3],
        mut each: impl FnMut(Ray, Option<usize>, f64),
    ) {
        let (lo, size) = (v.lo, v.size);
        let k = self.samples.max(1);
        let at = |j: usize| (j as f64 + 0.5) / k as f64;
        if v.per_face {
            // k × k points of each entry face (the midpoints of a k × k split).
            let inv = 1.0 / (k * k) as f64;
            for e in 0..3 {
                if weights[e] <= 0.0 {
                    continue;
                }
                for jb in 0..k {
                    for ja in 0..k {
                        let ray = face_ray_at(lo, size, entries[e] as usize, d, [at(ja), at(jb)]);
                        each(ray, Some(e), inv);
                    }
                }
            }
        } else {
            // k³ points of the cell (the midpoints of a k × k × k split).
            let inv = 1.0 / (k * k * k) as f64;
            for jz in 0..k {
                for jy in 0..k {
                    for jx in 0..k {
                        each(box_ray_at(lo, size, d, [at(jx), at(jy), at(jz)]), None, inv);
                    }
                }
            }
        }
    }

    /// Radiance per entry face `k` (of `entries`) along direction `d`. With `record`
    /// (the pixel's solid angle and a list), the same traversals also append the
    /// pixel's transport entries to the list, in the order and with the weights of
    /// [`Tracer::record_one`]'s own traversal of the pixel.
    fn radiances(
        &self,
        v: &ReceiverView,
        d: [f64; 3],
        entries: [u8; 3],
        weights: [f64; 3],
        footprint: f64,
        mut record: Option<(f64, &mut Entries)>,
    ) -> ([[f64; 3]; 3], u64) {
        let mut out = [[0.0; 3]; 3];
        let mut sum = [0.0; 3];
        let mut steps = 0;
        self.for_samples(v, d, entries, weights, |ray, e, inv| {
            let tr = match record.as_mut() {
                None => self.trace(ray, footprint),
                Some((solid_angle, list)) => {
                    let mut sink = BothSink {
                        radiance: RadianceSink([0.0; 3]),
                        record: RecordSink {
                            rows: sample_rows(entries, *solid_angle, weights, e, inv, 1.0),
                            out: &mut **list,
                        },
                    };
                    let steps = self.trace_into(ray, footprint, false, &mut sink);
                    Traced {
                        radiance: sink.radiance.0,
                        steps,
                    }
                }
            };
            steps += tr.steps;
            let acc = match e {
                Some(e) => &mut out[e],
                None => &mut sum,
            };
            for ch in 0..3 {
                acc[ch] += inv * tr.radiance[ch];
            }
        });
        if !v.per_face {
            out = [sum; 3];
        }
        (out, steps)
    }

    /// Whether a receiver gathers on its faces (see [`Tracer::gather_one`]).
    fn gathers_per_face(&self, cell: &TraversalCell) -> bool {
        let (lo, size) = (cell.origin.map(i64::from), i64::from(cell.size));
        self.touches_opaque(lo, size) || (self.samples > 1 && cell.extinction == f64::INFINITY)
    }

    /// The receiver `r`'s framebuffer settings: its box, collision depth, whether it
    /// gathers on its faces and the pixel footprint of `map`.
    fn receiver_view(&self, r: &Receiver, map: &CubeMap) -> ReceiverView {
        let cell = &self.scene.cells[r.cell as usize];
        ReceiverView {
            lo: cell.origin.map(i64::from),
            size: i64::from(cell.size),
            depth: cell.depth(),
            // Opaque receivers are surfaces: with more than one sample they gather on
            // their faces.
            per_face: self.gathers_per_face(cell),
            footprint: 2.0 / map.side as f64,
            total_weight: cell.total_weight,
        }
    }

    /// The first pass over one frustum's pixels `face` (of a map of side `n`): every
    /// pixel's collision weights and, with `trace`, the entry radiances of its centre
    /// ray(s); with supersampling on, the pixels it replaces (those whose weighted
    /// mean radiance contrasts with one of their neighbours, [`AntiAlias`]). With
    /// `record` (and `trace`), every pixel's transport entries of its centre ray(s)
    /// are kept too ([`PixelEntries`]). Returns the cells composited.
    fn centre_pass(
        &self,
        v: &ReceiverView,
        face: &[crate::cubemap::Pixel],
        collision: Collision,
        aa: &AntiAlias,
        trace: bool,
        pass: &mut FacePass,
        mut record: Option<&mut PixelEntries>,
    ) -> u64 {
        let n = pass.side;
        let mut steps = 0;
        if let Some(r) = record.as_mut() {
            r.list.clear();
            r.ends.clear();
        }
        for (k, pix) in face.iter().enumerate() {
            let w = entry_weights(pix.abs, v.depth, collision);
            pass.weights[k] = w;
            let wt = w[0] + w[1] + w[2];
            if wt <= 0.0 || !trace {
                pass.rad[k] = [[0.0; 3]; 3];
                pass.mean[k] = [0.0; 3];
                if let Some(r) = record.as_mut() {
                    r.ends.push(r.list.len());
                }
                continue;
            }
            let list = record.as_mut().map(|r| (pix.solid_angle, &mut r.list));
            let (l, s) = self.radiances(v, pix.dir, pix.entry, w, v.footprint, list);
            if let Some(r) = record.as_mut() {
                r.ends.push(r.list.len());
            }
            steps += s;
            pass.rad[k] = l;
            pass.mean[k] =
                [0, 1, 2].map(|c| (w[0] * l[0][c] + w[1] * l[1][c] + w[2] * l[2][c]) / wt);
        }
        pass.flag.fill(false);
        if aa.subdivisions > 1 && trace {
            for j in 0..n {
                for i in 0..n {
                    let k = i + n * j;
                    // Right, up, and both diagonals: a silhouette corner inside a
                    // pixel differs from its diagonal neighbour only.
                    for (di, dj) in [(1isize, 0isize), (0, 1), (1, 1), (1, -1)] {
                        let (ii, jj) = (i as isize + di, j as isize + dj);
                        if ii < 0 || jj < 0 || ii >= n as isize || jj >= n as isize {
                            continue;
                        }
                        let q = ii as usize + n * jj as usize;
                        if aa.contrasts(&pass.mean[k], &pass.mean[q]) {
                            pass.flag[k] = true;
                            pass.flag[q] = true;
                        }
                    }
                }
            }
        }
        steps
    }

    /// The per-pixel walk that [`Tracer::gather_one`] and [`Tracer::record_one`] share:
    /// per frustum of `map`, the first pass ([`Tracer::centre_pass`], tracing with
    /// `trace`, keeping its pixels' transport entries in `kept`), then every pixel with
    /// a positive collision weight, in pixel order, handed to `pixel` with its frustum,
    /// its index in the frustum, the pass (weights, centre radiances, supersampling
    /// flags) and the kept entries; `pixel` returns the cells it composited. Returns
    /// the scale `Ĝ · edge² / Σ ΔΩ (w₀ + w₁ + w₂)` (m², over the walked pixels) that
    /// turns the receiver's weighted radiance sums into collided power (0 when no
    /// pixel collides), and the cells composited in all.
    #[allow(clippy::too_many_arguments)] // reason: the two gathers' shared settings
    fn walk_pixels(
        &self,
        v: &ReceiverView,
        map: &CubeMap,
        collision: Collision,
        aa: &AntiAlias,
        trace: bool,
        mut kept: Option<&mut PixelEntries>,
        mut pixel: impl FnMut(usize, usize, &Pixel, &FacePass, Option<&PixelEntries>) -> u64,
    ) -> (f64, u64) {
        let n = map.side;
        let mut pass = FacePass::new(n);
        let mut norm = 0.0;
        let mut steps = 0;
        for f in 0..6 {
            let face = &map.pixels[f * n * n..(f + 1) * n * n];
            let keep = kept.as_deref_mut();
            steps += self.centre_pass(v, face, collision, aa, trace, &mut pass, keep);
            for (k, pix) in face.iter().enumerate() {
                let w = pass.weights[k];
                let wt = w[0] + w[1] + w[2];
                if wt <= 0.0 {
                    continue;
                }
                norm += pix.solid_angle * wt;
                steps += pixel(f, k, pix, &pass, kept.as_deref());
            }
        }
        let scale = if norm > 0.0 {
            let edge = v.size as f64 * self.scene.voxel;
            v.total_weight / norm * edge * edge
        } else {
            0.0
        };
        (scale, steps)
    }

    /// The transport row of receiver `r`: the weights with which the sender faces'
    /// coefficients reach its entry faces (the linear map of [`Tracer::gather_one`]
    /// with the same `aa`, the supersampled pixels being those the tracer's emission
    /// selects), sorted by (column, row) with duplicates summed (each in the order
    /// the traversals add it), appended to `out`. With supersampling the first pass
    /// records while it traces the radiances that choose the supersampled pixels, so
    /// a pixel that is not supersampled is traversed once. Returns the cells
    /// composited.
    fn record_one(
        &self,
        r: &Receiver,
        map: &CubeMap,
        collision: Collision,
        aa: &AntiAlias,
        scratch: &mut RecordScratch,
        out: &mut Entries,
    ) -> u64 {
        let v = self.receiver_view(r, map);
        let n = map.side;
        let supersampled = aa.subdivisions > 1;
        let RecordScratch { acc, pixels } = scratch;
        let kept = supersampled.then_some(pixels);
        let (scale, steps) = self.walk_pixels(
            &v,
            map,
            collision,
            aa,
            supersampled,
            kept,
            |f, k, pix, pass, kept| {
                let w = pass.weights[k];
                if let Some(kept) = kept.filter(|_| !pass.flag[k]) {
                    // Recorded by the first pass.
                    let from = if k == 0 { 0 } else { kept.ends[k - 1] };
                    for &(c, row, x) in &kept.list[from..kept.ends[k]] {
                        acc.push(c, row, x);
                    }
                    return 0;
                }
                // (direction, share of the pixel, footprint) of each ray direction.
                let dirs: Vec<([f64; 3], f64, f64)> = if pass.flag[k] {
                    let subs = sub_pixels(f, k % n, k / n, n, aa.subdivisions as usize);
                    let wsum: f64 = subs.iter().map(|s| s.1).sum();
                    let fp = v.footprint / aa.subdivisions as f64;
                    subs.into_iter().map(|(d, ws)| (d, ws / wsum, fp)).collect()
                } else {
                    vec![(pix.dir, 1.0, v.footprint)]
                };
                let mut steps = 0;
                for (d, share, fp) in dirs {
                    self.for_samples(&v, d, pix.entry, w, |ray, e, inv| {
                        // (A share of 1 leaves the products bitwise those of the
                        // unsupersampled map.)
                        let mut sink = RecordSink {
                            rows: sample_rows(pix.entry, pix.solid_angle, w, e, inv, share),
                            out: &mut *acc,
                        };
                        steps += self.trace_into(ray, fp, false, &mut sink);
                    });
                }
                steps
            },
        );
        acc.drain_sorted(scale, out);
        steps
    }

    /// The supersampled entry radiances of pixel `k` of frustum `f` (a map of side `n`,
    /// entry faces `entry`, collision weights `w`): `s²` sub-pixel rays in a correlated
    /// multi-jittered pattern, each weighted by the gnomonic Jacobian
    /// ([`sub_pixels`]), the pixel keeping its collision weights. Returns them and the
    /// cells composited.
    #[allow(clippy::too_many_arguments)] // reason: one pixel's coordinates and weights
    fn supersampled(
        &self,
        v: &ReceiverView,
        f: usize,
        k: usize,
        n: usize,
        entry: [u8; 3],
        w: [f64; 3],
        s: usize,
    ) -> ([[f64; 3]; 3], u64) {
        let mut sum = [[0.0; 3]; 3];
        let mut wsum = 0.0;
        let mut steps = 0;
        for (d, ws) in sub_pixels(f, k % n, k / n, n, s) {
            let (l, st) = self.radiances(v, d, entry, w, v.footprint / s as f64, None);
            steps += st;
            for e in 0..3 {
                for ch in 0..3 {
                    sum[e][ch] += ws * l[e][ch];
                }
            }
            wsum += ws;
        }
        (sum.map(|e| e.map(|x| x / wsum)), steps)
    }

    fn gather_one(
        &self,
        r: &Receiver,
        map: &CubeMap,
        collision: Collision,
        aa: &AntiAlias,
    ) -> (FaceRgb, u64) {
        let v = self.receiver_view(r, map);
        let n = map.side;
        let s = aa.subdivisions as usize;
        let mut acc = [[0.0; 3]; 6];
        let (scale, steps) =
            self.walk_pixels(&v, map, collision, aa, true, None, |f, k, pix, pass, _| {
                let w = pass.weights[k];
                let (rad, steps) = if pass.flag[k] {
                    self.supersampled(&v, f, k, n, pix.entry, w, s)
                } else {
                    (pass.rad[k], 0)
                };
                for e in 0..3 {
                    let fi = pix.entry[e] as usize;
                    let sw = pix.solid_angle * w[e];
                    for ch in 0..3 {
                        acc[fi][ch] += sw * rad[e][ch];
                    }
                }
                steps
            });
        // (With no colliding pixel `acc` is zero and so is `scale`.)
        for f in &mut acc {
            for x in f.iter_mut() {
                *x *= scale;
            }
        }
        (acc, steps)
    }
}

/// What a receiver's gather needs of its cell and framebuffer.
struct ReceiverView {
    lo: [i64; 3],
    size: i64,
    /// Optical depth across the cell.
    depth: f64,
    /// Whether it gathers on its faces ([`Tracer::gathers_per_face`]).
    per_face: bool,
    /// A pixel's angular width (rad).
    footprint: f64,
    /// `Ĝ` of the cell.
    total_weight: f64,
}

/// The transport entries of one frustum's pixels recorded by the first pass
/// ([`Tracer::centre_pass`]): pixel `k`'s are `list[ends[k − 1]..ends[k]]`.
#[derive(Default)]
struct PixelEntries {
    list: Entries,
    ends: Vec<usize>,
}

/// A recording thread's buffers, reused from receiver to receiver.
#[derive(Default)]
struct RecordScratch {
    acc: Accumulator,
    pixels: PixelEntries,
}

/// Per pixel of one frustum (a map of side `side`): collision weights, entry radiances,
/// their weighted mean (for the contrast test) and whether it is supersampled.
struct FacePass {
    side: usize,
    weights: Vec<[f64; 3]>,
    rad: Vec<[[f64; 3]; 3]>,
    mean: Vec<[f64; 3]>,
    flag: Vec<bool>,
}

impl FacePass {
    fn new(side: usize) -> Self {
        let m = side * side;
        Self {
            side,
            weights: vec![[0.0; 3]; m],
            rad: vec![[[0.0; 3]; 3]; m],
            mean: vec![[0.0; 3]; m],
            flag: vec![false; m],
        }
    }
}

/// The `s²` sub-pixel directions of pixel `(i, j)` of frustum `f` of a map of side `n`,
/// with their gnomonic Jacobians `(1 + u² + v²)^(−3/2)` as weights, in a correlated
/// multi-jittered pattern: all `s²` abscissae and ordinates distinct, so an edge along
/// either axis is resolved to `1/s²` of a pixel.
fn sub_pixels(f: usize, i: usize, j: usize, n: usize, s: usize) -> Vec<([f64; 3], f64)> {
    let axis = f / 2;
    let sign = if f.is_multiple_of(2) { 1.0 } else { -1.0 };
    let (ta, tb) = ((axis + 1) % 3, (axis + 2) % 3);
    let edge = |x: f64| -1.0 + 2.0 * x / n as f64;
    let s2 = (s * s) as f64;
    let mut out = Vec::with_capacity(s * s);
    for b in 0..s {
        for a in 0..s {
            let fu = (a * s + b) as f64 + 0.5;
            let fv = (b * s + a) as f64 + 0.5;
            let u = edge(i as f64 + fu / s2);
            let v = edge(j as f64 + fv / s2);
            let r2 = 1.0 + u * u + v * v;
            let rr = r2.sqrt();
            let mut d = [0.0; 3];
            d[axis] = sign / rr;
            d[ta] = u / rr;
            d[tb] = v / rr;
            out.push((d, 1.0 / (r2 * rr)));
        }
    }
    out
}

/// Adaptive supersampling of the framebuffer: a pixel whose radiance differs from one
/// of its eight neighbours (same frustum) by more than `contrast` relative to the larger of the two
/// is replaced by the solid-angle-weighted mean of `subdivisions²` sub-pixel rays in a
/// correlated multi-jittered pattern (deterministic).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct AntiAlias {
    /// Sub-pixels per side (1 = off).
    pub subdivisions: u32,
    /// Relative contrast that triggers supersampling.
    pub contrast: f64,
}

impl Default for AntiAlias {
    /// 8 × 8 sub-pixels where neighbours differ by more than 50 % (silhouettes of
    /// bright or dark objects, not the gentle gradients of a medium).
    fn default() -> Self {
        Self {
            subdivisions: 8,
            contrast: 0.5,
        }
    }
}

impl AntiAlias {
    /// No supersampling (the paper's one ray per pixel).
    pub const OFF: Self = Self {
        subdivisions: 1,
        contrast: f64::INFINITY,
    };

    fn contrasts(&self, a: &[f64; 3], b: &[f64; 3]) -> bool {
        (0..3).any(|c| {
            let m = a[c].abs().max(b[c].abs());
            m > 0.0 && (a[c] - b[c]).abs() > self.contrast * m
        })
    }
}

/// The cube maps of a receiver list's framebuffer sides.
struct Maps {
    sides: Vec<u32>,
    maps: Vec<std::sync::Arc<CubeMap>>,
}

impl Maps {
    fn new(receivers: &[Receiver]) -> Self {
        let mut sides: Vec<u32> = receivers.iter().map(|r| r.framebuffer).collect();
        sides.sort_unstable();
        sides.dedup();
        let maps = sides.iter().map(|&s| CubeMap::shared(s as usize)).collect();
        Self { sides, maps }
    }

    /// The map of side `s` (one of the receivers').
    fn of(&self, s: u32) -> &CubeMap {
        let i = self.sides.binary_search(&s).unwrap_or(0);
        &self.maps[i]
    }
}

impl Projector for CpuProjector {
    fn name(&self) -> String {
        match self.projection {
            Projection::Exact => "cpu-exact".into(),
            Projection::Pyramid => "cpu-pyramid".into(),
        }
    }

    fn gather(
        &self,
        scene: &ProjectionScene<'_>,
        emission: &Emission<'_>,
        collision: Collision,
        receivers: &[Receiver],
        out: &mut [FaceRgb],
    ) -> Result<GatherStats, VolumeError> {
        check_inputs(&self.name(), scene, emission, receivers, out.len())?;
        let pyramid =
            (self.projection == Projection::Pyramid).then(|| Pyramid::build(scene, emission));
        let tracer = Tracer {
            scene,
            emission,
            pyramid: pyramid.as_ref(),
            samples: self.receiver_samples.max(1) as usize,
        };
        let maps = Maps::new(receivers);
        let steps: u64 = out
            .par_iter_mut()
            .zip(receivers.par_iter())
            .with_min_len(8)
            .map(|(o, r)| {
                let (acc, s) =
                    tracer.gather_one(r, maps.of(r.framebuffer), collision, &self.antialias);
                *o = acc;
                s
            })
            .sum();
        let rays = receivers
            .iter()
            .map(|r| 6 * u64::from(r.framebuffer) * u64::from(r.framebuffer))
            .sum();
        Ok(GatherStats {
            rays,
            composited: steps,
        })
    }

    /// Records the gather's linear map ([`super::Transport`]) in [`Projection::Exact`]
    /// (the pyramid is rebuilt from the emission at every call: `None`), or `None` when
    /// the map outgrows `max_bytes` (receivers are recorded in blocks of 256 and the
    /// size checked after each). With supersampling, which pixels are supersampled
    /// depends on the radiance, so the gather is linear only for a fixed choice: the
    /// recorded map keeps the pixels that `emission` selects (the gather of `emission`
    /// itself is reproduced up to the order of the sums), and its product with another
    /// emission is the gather with those pixels supersampled, not the ones that
    /// emission would select.
    fn record(
        &self,
        scene: &ProjectionScene<'_>,
        emission: &Emission<'_>,
        collision: Collision,
        receivers: &[Receiver],
        max_bytes: usize,
    ) -> Result<Option<super::Transport>, VolumeError> {
        check_inputs(&self.name(), scene, emission, receivers, receivers.len())?;
        if self.projection != Projection::Exact {
            return Ok(None);
        }
        let tracer = Tracer {
            scene,
            emission,
            pyramid: None,
            samples: self.receiver_samples.max(1) as usize,
        };
        let maps = Maps::new(receivers);
        let mut t = super::Transport {
            offsets: vec![0],
            ..super::Transport::default()
        };
        for block in receivers.chunks(256) {
            let rows: Vec<Entries> = block
                .par_iter()
                .map_init(RecordScratch::default, |scratch, r| {
                    let mut row = Entries::new();
                    let map = maps.of(r.framebuffer);
                    tracer.record_one(r, map, collision, &self.antialias, scratch, &mut row);
                    row
                })
                .collect();
            for row in rows {
                for (c, f, w) in row {
                    t.columns.push(c);
                    t.rows.push(f);
                    t.weights.push(w);
                }
                t.offsets.push(t.columns.len());
            }
            if t.bytes() > max_bytes {
                return Ok(None);
            }
        }
        Ok(Some(t))
    }

    fn escape(
        &self,
        scene: &ProjectionScene<'_>,
        emission: &Emission<'_>,
        framebuffer: u32,
    ) -> Result<[f64; 3], VolumeError> {
        check_inputs(&self.name(), scene, emission, &[], 0)?;
        if framebuffer == 0 || framebuffer as usize > crate::cubemap::MAX_FRAMEBUFFER {
            return Err(VolumeError::Backend {
                backend: self.name(),
                reason: format!("framebuffer {framebuffer} outside 1..=1024"),
            });
        }
        let pyramid =
            (self.projection == Projection::Pyramid).then(|| Pyramid::build(scene, emission));
        let tracer = Tracer {
            scene,
            emission,
            pyramid: pyramid.as_ref(),
            samples: self.receiver_samples.max(1) as usize,
        };
        let map = CubeMap::shared(framebuffer as usize);
        let n = scene.side;
        let footprint = 2.0 / framebuffer as f64;
        let area = scene.voxel * scene.voxel;
        // More than one receiver sample: the conserving escape (module docs of
        // `backend`): the boundary cells' own faces exactly, the rays skip them.
        let conserving = tracer.samples > 1;
        // One task per boundary face and row; rows summed in order.
        let rows: Vec<[f64; 3]> = (0..6 * n)
            .into_par_iter()
            .map(|task| {
                let (face, j) = (task / n, task % n);
                let axis = face / 2;
                let outward_negative = face % 2 == 1;
                let (ta, tb) = ((axis + 1) % 3, (axis + 2) % 3);
                let mut sum = [0.0; 3];
                for i in 0..n {
                    let mut lo = [0i64; 3];
                    lo[axis] = if outward_negative { -1 } else { n as i64 };
                    lo[ta] = i as i64;
                    lo[tb] = j as i64;
                    // The voxel just outside the boundary; its inward face is the square.
                    let inward_face = face_index(axis, !outward_negative);
                    for (pi, pix) in map.pixels.iter().enumerate() {
                        let c = if outward_negative {
                            pix.dir[axis]
                        } else {
                            -pix.dir[axis]
                        };
                        if c <= 0.0 {
                            continue;
                        }
                        let k = tracer.samples;
                        let w = pix.solid_angle * c / (k * k) as f64;
                        // The conserving escape moves each pixel's points within
                        // their sub-squares along the R2 sequence (pixel index `pi`),
                        // so that the pixels of one square sample it evenly.
                        let off = if conserving {
                            escape_offset(pi)
                        } else {
                            [0.5, 0.5]
                        };
                        for jb in 0..k {
                            for ja in 0..k {
                                let at = [(ja, off[0]), (jb, off[1])]
                                    .map(|(j, o)| (j as f64 + o) / k as f64);
                                let ray = face_ray_at(lo, 1, inward_face, pix.dir, at);
                                let tr = tracer.trace_skipping(ray, footprint, conserving);
                                for ch in 0..3 {
                                    sum[ch] += w * tr.radiance[ch];
                                }
                            }
                        }
                    }
                }
                sum
            })
            .collect();
        let mut total = if conserving {
            super::boundary_emission(scene, emission)
        } else {
            [0.0; 3]
        };
        for r in rows {
            for ch in 0..3 {
                total[ch] += r[ch] * area;
            }
        }
        Ok(total)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// The sums of sorting `raw` stably by (column, entry face), adding duplicates in
    /// order and scaling: what the accumulator must reproduce bitwise.
    fn sorted_sums(mut raw: Entries, scale: f64) -> Entries {
        raw.sort_by_key(|&(c, row, _)| (c, row));
        let mut merged: Entries = Vec::new();
        for (c, row, w) in raw {
            match merged.last_mut() {
                Some(last) if last.0 == c && last.1 == row => last.2 += w,
                _ => merged.push((c, row, w)),
            }
        }
        for m in &mut merged {
            m.2 *= scale;
        }
        merged.retain(|m| m.2 != 0.0);
        merged
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        /// The accumulator's rows equal the stable sort-and-sum bitwise, for lists that
        /// overflow its table more than once (up to 1,500 distinct columns against a
        /// first table of 1,024 slots), and it is empty again afterwards (a second list
        /// gives its own sums).
        #[test]
        fn accumulator_sums_like_a_stable_sort(
            lists in prop::collection::vec(
                prop::collection::vec((0u32..1500, 0u8..6, 0.0f64..1e3), 0..3000),
                2,
            ),
            scale in 1e-3f64..1e3,
        ) {
            let mut acc = Accumulator::default();
            for raw in lists {
                for &(c, row, w) in &raw {
                    acc.push(c, row, w);
                }
                let mut got = Entries::new();
                acc.drain_sorted(scale, &mut got);
                let want = sorted_sums(raw, scale);
                prop_assert_eq!(got.len(), want.len());
                for (g, w) in got.iter().zip(&want) {
                    prop_assert_eq!((g.0, g.1), (w.0, w.1));
                    prop_assert_eq!(g.2.to_bits(), w.2.to_bits());
                }
            }
        }
    }
}
