//! The projection backend (GlobalCube §3.1): the operation that, for every receiving
//! cell, renders the scene into the cell's global cube and reduces the six
//! framebuffers to the power the cell collides through each of its faces. It is the
//! method's whole cost, so it sits behind a trait: [`cpu::CpuProjector`] here, a wgpu
//! implementation in `wavelux-gpu` later. The data handed to a backend are plain
//! slices (no wgpu types, no solver state), and [`conformance`] is the test suite
//! every backend must pass.
//!
//! # What a backend computes
//! Cells are axis-aligned cubes on a dyadic grid of `side³` voxels of edge `voxel`
//! metres; [`TraversalCell`] gives a cell's box (in voxels), its extinction per voxel
//! edge `k` (optical depth across one voxel; `∞` opaque, `0` empty) and its total
//! collision weight `Ĝ` ([`crate::cell::total_weight`] of its optical depth across its
//! own side). `cell_map` sends every voxel (x fastest) to the cell that contains it.
//!
//! For receiver `p` with framebuffer `N`, for every pixel of [`crate::cubemap::CubeMap`]
//! `N` (direction `ω`, solid angle `ΔΩ`): a ray leaves `p`'s centre along `ω`, skips
//! `p` itself (no self-interaction, `m_pp = 1`, §3.1; a receiver touching an opaque
//! cell sends one ray per entry face from that face's centre) and composites front to back
//! (the same sum as the paper's back-to-front slices) every cell it crosses, exactly
//! cell by cell: a chord of length `ℓ` (metres) through cell `q` of extinction
//! `κ = k/voxel` has opacity `α = 1 − e^{−κℓ}` and adds
//! `T · α · e[q][s]` (`T` the transmittance so far), where `s` is the face the ray
//! enters `q` through (the face the light leaves `q` by towards `p`) and `e` is the
//! emission coefficient (W/(m²·sr)) of [`Emission`]; an empty cell (`k = 0`) with
//! emission adds `T · ℓ · e[q][s]` (then `e` is in W/(m³·sr)). Rays stop at an opaque cell,
//! when `T < 1e-13`, or at the grid's black boundary. The pixel's radiance `L` is
//! collided through `p`'s three entry faces with the weights
//! [`crate::cell::entry_weights`]`(|ω|, A_p)`, times `ΔΩ`; the six sums are scaled by
//! `Ĝ_p / Σ_pixels ΔΩ G_p(ω)` (so a uniform radiance is collided exactly) and by the
//! face area `(side_p · voxel)²`. The result is watts per entry face and channel.
//!
//! [`Projector::escape`] measures the power leaving through the grid's boundary:
//! for every boundary voxel square, the inward hemisphere of a cube map at its centre,
//! `Σ ΔΩ · L · cos θ · voxel²` (the paper's one point per square). The conserving form
//! (the CPU projector's with more than one receiver sample) counts what the boundary
//! cells emit through their own outer faces exactly, [`boundary_emission`] (a face `s`
//! emits `Chi_s` in total, all of it through the boundary), and gathers only the
//! light of the other cells through the boundary squares: its rays skip the first
//! cell's emission but not its opacity, and start at points that move from pixel to
//! pixel inside their sub-squares ([`cpu::escape_offset`], the R2 sequence), so that
//! light arriving at grazing angles from the neighbouring cells is sampled evenly. One
//! point per square at a thick boundary cell's centre counts the cell's own face 1.24
//! times at optical depth 1.25 per voxel (the longest chords); see the crate docs,
//! "Thick, bright media".

pub mod conformance;
pub mod cpu;

use crate::error::VolumeError;

/// RGB power (W) or radiance per face of a cell, faces ordered `+x, −x, +y, −y, +z, −z`.
pub type FaceRgb = [[f64; 3]; 6];

/// One cell the rays cross: an active leaf of the hierarchy, or an empty octree node
/// used to skip void space.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TraversalCell {
    /// Minimum corner, in voxels.
    pub origin: [u32; 3],
    /// Edge length in voxels (a power of two).
    pub size: u32,
    /// Optical depth across one voxel edge (`∞`: opaque; `0`: empty).
    pub extinction: f64,
    /// `Ĝ` of the cell ([`crate::cell::total_weight`] of its depth across its own side,
    /// in side²·sr); `0` for empty cells.
    pub total_weight: f64,
}

impl TraversalCell {
    /// Optical depth across the cell's own side.
    #[must_use]
    pub fn depth(&self) -> f64 {
        if self.extinction == f64::INFINITY {
            f64::INFINITY
        } else {
            self.extinction * self.size as f64
        }
    }
}

/// The geometry a backend projects: cells and the voxel-to-cell map.
#[derive(Debug, Clone, Copy)]
pub struct ProjectionScene<'a> {
    /// Voxels per axis (a power of two).
    pub side: usize,
    /// Voxel edge in metres (scene units).
    pub voxel: f64,
    /// The cells.
    pub cells: &'a [TraversalCell],
    /// `side³` cell indices, voxel `(x, y, z)` at `x + side (y + side z)`.
    pub cell_map: &'a [u32],
}

/// What the cells emit in one gather.
#[derive(Debug, Clone, Copy)]
pub struct Emission<'a> {
    /// Per cell and face the emission coefficient `e[s][channel]` of the module docs
    /// (W/(m²·sr); W/(m³·sr) for empty cells).
    pub coefficients: &'a [FaceRgb],
    /// Per cell the total emitted power (W per channel); used by backends that
    /// aggregate cells (the pyramid projection).
    pub power: &'a [[f64; 3]],
}

/// A receiving cell and the side of its framebuffer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Receiver {
    /// Index into [`ProjectionScene::cells`].
    pub cell: u32,
    /// Framebuffer side `N` (1..=1024).
    pub framebuffer: u32,
}

/// Work done by one call (for throughput reports).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct GatherStats {
    /// Rays (pixels) traced.
    pub rays: u64,
    /// Cells composited (ray–cell chords).
    pub composited: u64,
}

impl std::ops::AddAssign for GatherStats {
    fn add_assign(&mut self, o: Self) {
        self.rays += o.rays;
        self.composited += o.composited;
    }
}

/// The recorded linear map of [`Projector::gather`] for one scene, collision mode and
/// receiver list: the gather is linear in the emission coefficients (opacities are
/// fixed while an active set is relaxed; adaptive choices such as supersampled pixels
/// are fixed when the map is recorded), so a backend may record, per receiver, the
/// weight with which every sender face's coefficient reaches each of its entry faces
/// once, and every later gather is a sparse product ([`Transport::apply`]). Entries of
/// one receiver are sorted by (sender face, entry face) and summed in that order, so
/// the product is deterministic whatever the thread count; it equals the backend's
/// gather up to the order of the floating-point sums (relative 1e-12 in the
/// conformance suite).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Transport {
    /// Per receiver, its entries are `offsets[r]..offsets[r + 1]`.
    pub offsets: Vec<usize>,
    /// Per entry, the sender cell's face `6 · cell + face`.
    pub columns: Vec<u32>,
    /// Per entry, the receiver's entry face (`0..6`).
    pub rows: Vec<u8>,
    /// Per entry, the weight (m²·sr: watts collided per W/(m²·sr) of coefficient; m³·sr
    /// for empty cells' coefficients).
    pub weights: Vec<f64>,
}

impl Transport {
    /// Bytes an entry takes.
    pub const ENTRY_BYTES: usize = 4 + 1 + 8;

    /// Number of receivers.
    #[must_use]
    pub fn receivers(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    /// Number of entries.
    #[must_use]
    pub fn entries(&self) -> usize {
        self.columns.len()
    }

    /// Memory of the entries (bytes).
    #[must_use]
    pub fn bytes(&self) -> usize {
        self.entries() * Self::ENTRY_BYTES + self.offsets.len() * 8
    }

    /// The gather of the receivers `range` (indices into the recorded receiver list)
    /// for the emission coefficients `coefficients`, written to `out` (one per receiver
    /// of the range).
    ///
    /// # Errors
    /// [`VolumeError::Backend`] when the range, `out` or a column does not fit.
    pub fn apply(
        &self,
        coefficients: &[FaceRgb],
        range: std::ops::Range<usize>,
        out: &mut [FaceRgb],
    ) -> Result<(), VolumeError> {
        use rayon::prelude::*;
        if range.end > self.receivers() || out.len() != range.len() {
            return Err(VolumeError::Backend {
                backend: "transport".into(),
                reason: format!(
                    "receivers {range:?} of {} into {} outputs",
                    self.receivers(),
                    out.len()
                ),
            });
        }
        let n_cols = coefficients.len() * 6;
        if self.columns.iter().any(|&c| c as usize >= n_cols) {
            return Err(VolumeError::Backend {
                backend: "transport".into(),
                reason: format!("a column beyond the {} cells' faces", coefficients.len()),
            });
        }
        out.par_iter_mut()
            .enumerate()
            .with_min_len(16)
            .for_each(|(k, o)| {
                let r = range.start + k;
                *o = [[0.0; 3]; 6];
                for j in self.offsets[r]..self.offsets[r + 1] {
                    let c = self.columns[j] as usize;
                    let e = &coefficients[c / 6][c % 6];
                    let w = self.weights[j];
                    let f = &mut o[self.rows[j] as usize];
                    for ch in 0..3 {
                        f[ch] += w * e[ch];
                    }
                }
            });
        Ok(())
    }
}

/// A projection backend. Implementations must be deterministic: the same inputs give
/// bitwise the same outputs whatever the thread count.
pub trait Projector: Sync {
    /// Short name for reports (`cpu-exact`, `cpu-pyramid`, `wgpu` ...).
    fn name(&self) -> String;

    /// For every receiver, the power (W) collided through each entry face and channel,
    /// written to `out[i]` (same order as `receivers`).
    ///
    /// # Errors
    /// Inconsistent slices (lengths, indices out of range) or a framebuffer outside
    /// `1..=1024`, as [`VolumeError::Backend`].
    fn gather(
        &self,
        scene: &ProjectionScene<'_>,
        emission: &Emission<'_>,
        collision: crate::cell::Collision,
        receivers: &[Receiver],
        out: &mut [FaceRgb],
    ) -> Result<GatherStats, VolumeError>;

    /// Records the linear map of [`Projector::gather`] for `receivers` ([`Transport`]),
    /// or `None` when the backend does not record (the default) or the map would take
    /// more than `max_bytes`; the caller then keeps calling `gather`. A backend whose
    /// gather makes choices that depend on the radiance (the CPU projector's adaptive
    /// supersampling) makes them for `emission` and records the map with those choices
    /// fixed: applied to `emission` it gives the gather of `emission`.
    ///
    /// # Errors
    /// As [`Projector::gather`].
    fn record(
        &self,
        scene: &ProjectionScene<'_>,
        emission: &Emission<'_>,
        collision: crate::cell::Collision,
        receivers: &[Receiver],
        max_bytes: usize,
    ) -> Result<Option<Transport>, VolumeError> {
        let _ = (scene, emission, collision, receivers, max_bytes);
        Ok(None)
    }

    /// Power (W per channel) leaving through the grid's boundary, seen from every
    /// boundary voxel square through the inward half of a framebuffer of side
    /// `framebuffer`.
    ///
    /// # Errors
    /// As [`Projector::gather`].
    fn escape(
        &self,
        scene: &ProjectionScene<'_>,
        emission: &Emission<'_>,
        framebuffer: u32,
    ) -> Result<[f64; 3], VolumeError>;
}

/// Checks the slices of a call (shared by the backends).
///
/// # Errors
/// [`VolumeError::Backend`] naming the first inconsistency.
pub fn check_inputs(
    backend: &str,
    scene: &ProjectionScene<'_>,
    emission: &Emission<'_>,
    receivers: &[Receiver],
    out_len: usize,
) -> Result<(), VolumeError> {
    let fail = |reason: String| {
        Err(VolumeError::Backend {
            backend: backend.into(),
            reason,
        })
    };
    let n = scene.side;
    if !(n.is_power_of_two() && scene.voxel.is_finite() && scene.voxel > 0.0) {
        return fail(format!("side {n} / voxel {} invalid", scene.voxel));
    }
    if scene.cell_map.len() != n * n * n {
        return fail(format!(
            "cell map has {} entries, expected {}",
            scene.cell_map.len(),
            n * n * n
        ));
    }
    let nc = scene.cells.len();
    if emission.coefficients.len() != nc || emission.power.len() != nc {
        return fail(format!(
            "{} cells but {} emission coefficients and {} powers",
            nc,
            emission.coefficients.len(),
            emission.power.len()
        ));
    }
    if scene.cell_map.iter().any(|&c| c as usize >= nc) {
        return fail("cell map refers past the cell list".into());
    }
    if out_len != receivers.len() {
        return fail(format!(
            "{} receivers but an output of {}",
            receivers.len(),
            out_len
        ));
    }
    for r in receivers {
        if r.cell as usize >= nc {
            return fail(format!("receiver cell {} out of range", r.cell));
        }
        if r.framebuffer == 0 || r.framebuffer as usize > crate::cubemap::MAX_FRAMEBUFFER {
            return fail(format!(
                "framebuffer {} outside 1..={}",
                r.framebuffer,
                crate::cubemap::MAX_FRAMEBUFFER
            ));
        }
    }
    Ok(())
}

/// What the cells touching the grid's boundary emit through their outer faces (W per
/// channel), exactly: a face `s` of a cell of edge `E` (metres) emits `e_s Ĝ E²/6` in
/// total (`e_s 4π E³/6` for an empty cell's thin emission; the normalisation of the
/// module docs), all of it out of the grid when the face lies on the boundary. Part of
/// the conserving escape measurement (module docs); shared by the backends.
#[must_use]
pub fn boundary_emission(scene: &ProjectionScene<'_>, emission: &Emission<'_>) -> [f64; 3] {
    let n = scene.side as u32;
    let mut total = [0.0; 3];
    for (c, e) in scene.cells.iter().zip(emission.coefficients) {
        let edge = f64::from(c.size) * scene.voxel;
        let w = if c.extinction > 0.0 {
            c.total_weight * edge * edge / 6.0
        } else {
            4.0 * std::f64::consts::PI * edge * edge * edge / 6.0
        };
        for axis in 0..3 {
            let (lo, hi) = (c.origin[axis], c.origin[axis] + c.size);
            // Faces +axis (2·axis) and −axis (2·axis + 1).
            for (on, face) in [(hi == n, 2 * axis), (lo == 0, 2 * axis + 1)] {
                if on {
                    for ch in 0..3 {
                        total[ch] += w * e[face][ch];
                    }
                }
            }
        }
    }
    total
}
