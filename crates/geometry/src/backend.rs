//! Occlusion backends (issue 17): the device-independent contract a GPU (or any other)
//! implementation of two-point visibility must meet, and the CPU reference.
//!
//! Every method traces its shadow rays (Ziegler §2.4: the visibility term of the
//! kernel) against an [`Accel`]. An [`OcclusionBackend`] prepares an [`Occluder`] for
//! one `Accel` (uploading it once); the occluder answers batches of
//! [`OcclusionQuery`]s into caller-owned slices.
//!
//! # Contract
//! `out[i]` must equal [`Accel::occluded`]`(q[i].p, q[i].q, q[i].ignore)` exactly, for
//! every query, whatever the device and the batch size. A device that cannot decide a
//! query with certainty (a floating-point comparison inside its error bound, a curved
//! primitive, a full traversal stack) hands it back to `Accel::occluded`: answers are
//! then bitwise those of the CPU, and deterministic for a given input. The
//! [`OcclusionStats`] say how many queries the device decided and how many it deferred.
//!
//! [`Accel`] itself is the CPU reference occluder ([`CpuOcclusion`] is its backend):
//! it answers every query in f64 on all rayon threads.
//!
//! The upload view of an `Accel` is [`Accel::export`]: the obvhs CWBVH nodes
//! ([`CwBvhNode`], `repr(C)`, 80 bytes), one [`ExportSlot`] per leaf slot in BVH leaf
//! order, in the normalised f32 frame `x' = (x − centre)·scale`, and the frame
//! constants ([`ExportFrame`]).

use std::fmt::Debug;

use glam::DVec3;

use crate::GeometryError;
use crate::accel::Accel;
pub use crate::accel::OcclusionQuery;
pub use obvhs::cwbvh::node::CwBvhNode;

/// What one batch of occlusion queries cost.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct OcclusionStats {
    /// Queries answered (the batch length).
    pub queries: usize,
    /// Queries the device decided by itself (0 for the CPU reference).
    pub device_rays: usize,
    /// Queries handed back to [`Accel::occluded`] (unsure answers, curved primitives,
    /// polygon interiors, stack overflow; for the CPU reference, every query).
    pub deferred_rays: usize,
}

impl std::ops::Add for OcclusionStats {
    type Output = OcclusionStats;

    /// Sums two batches' statistics.
    fn add(self, o: OcclusionStats) -> OcclusionStats {
        OcclusionStats {
            queries: self.queries + o.queries,
            device_rays: self.device_rays + o.device_rays,
            deferred_rays: self.deferred_rays + o.deferred_rays,
        }
    }
}

/// Answers batches of occlusion queries against one prepared [`Accel`], exactly as
/// [`Accel::occluded`] would (module docs: contract).
pub trait Occluder: Send + Sync {
    /// `out[i] = accel.occluded(q[i].p, q[i].q, q[i].ignore)` for every `i`.
    ///
    /// # Errors
    /// [`GeometryError::OutOfRange`] if `out` and `q` differ in length;
    /// [`GeometryError::Backend`] if the device failed (then `out` is unspecified and the
    /// caller may re-run the batch on the CPU).
    fn occluded_queries(
        &self,
        q: &[OcclusionQuery],
        out: &mut [bool],
    ) -> Result<OcclusionStats, GeometryError>;
}

/// A device able to answer occlusion queries: prepares (uploads) one [`Accel`].
pub trait OcclusionBackend: Send + Sync + Debug {
    /// Human-readable name (for GPUs: the adapter's name and API).
    fn name(&self) -> String;

    /// Prepares `a` once (uploads its nodes and primitives); the returned occluder
    /// answers any number of batches.
    ///
    /// # Errors
    /// [`GeometryError::Backend`] if the upload failed (e.g. the scene exceeds the
    /// device's buffer limits).
    fn occluder<'a>(&self, a: &'a Accel) -> Result<Box<dyn Occluder + 'a>, GeometryError>;
}

impl Occluder for Accel {
    fn occluded_queries(
        &self,
        q: &[OcclusionQuery],
        out: &mut [bool],
    ) -> Result<OcclusionStats, GeometryError> {
        Accel::occluded_queries(self, q, out)
    }
}

/// The CPU reference backend: the occluder is the [`Accel`] itself.
#[derive(Debug, Clone, Copy, Default)]
pub struct CpuOcclusion;

impl OcclusionBackend for CpuOcclusion {
    fn name(&self) -> String {
        "cpu".to_owned()
    }

    fn occluder<'a>(&self, a: &'a Accel) -> Result<Box<dyn Occluder + 'a>, GeometryError> {
        Ok(Box::new(a))
    }
}

impl<T: Occluder + ?Sized> Occluder for &T {
    fn occluded_queries(
        &self,
        q: &[OcclusionQuery],
        out: &mut [bool],
    ) -> Result<OcclusionStats, GeometryError> {
        (**self).occluded_queries(q, out)
    }
}

/// How a device must treat a leaf slot (see [`ExportSlot`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum SlotKind {
    /// A triangle: `points[0..3]` are its vertices (f32, normalised frame).
    Triangle,
    /// A convex planar quadrilateral: `points` are its corners in order around it
    /// (parallelograms `o, o+e1, o+e1+e2, o+e2`; convex four-sided complex polygons).
    /// Three-sided convex polygons are exported as [`SlotKind::Triangle`].
    Quad,
    /// Any other planar region (a complex polygon with holes, arcs, more than four
    /// sides or a reflex corner): `points[0..3]` span its plane (frame origin and origin plus
    /// each frame axis scaled by the region's size). A device may prove a miss from the
    /// plane alone; a crossing of the plane must be handed back to the CPU.
    Plane,
    /// A curved primitive: only its box is known to the device; a ray reaching it must
    /// be handed back to the CPU.
    Curved,
}

/// One leaf slot of the exported BVH (BVH leaf order, `slots[i]` is the primitive
/// `primitive_indices[i]`), in the normalised f32 frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ExportSlot {
    /// The primitive's [`crate::PrimId`] (what `ignore` names).
    pub prim: u32,
    /// How to test it.
    pub kind: SlotKind,
    /// True for planar primitives: an ignored planar primitive is skipped, an ignored
    /// curved one still shadows (module docs of [`crate::accel`]).
    pub planar: bool,
    /// Points in the normalised frame, rounded to nearest f32 from the f64 values (see
    /// [`SlotKind`] for their meaning; unused points are zero).
    pub points: [[f32; 3]; 4],
    /// The slot's size: the largest coordinate extent of its points (normalised units,
    /// rounded up), used by error bounds for the primitive's 1e-9 dilation.
    pub size: f32,
}

/// Constants of the normalised frame `x' = (x − centre)·scale` and of the query
/// epsilons, as [`Accel::occluded`] uses them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ExportFrame {
    /// Centre of the scene box (world units).
    pub centre: DVec3,
    /// Power-of-two scale: scene diagonal × scale ∈ (½, 1].
    pub scale: f64,
    /// Padding of every f32 box (normalised units).
    pub pad: f64,
    /// End-point epsilon of a query (world units, `EPS_REL ·` diagonal).
    pub eps: f64,
}

impl ExportFrame {
    /// `x' = (x − centre)·scale`, in f64 (the caller rounds).
    pub fn to_frame(&self, x: DVec3) -> DVec3 {
        (x - self.centre) * self.scale
    }
}

/// The upload view of an [`Accel`] ([`Accel::export`]).
#[derive(Debug, Clone)]
pub struct AccelExport<'a> {
    /// CWBVH nodes (node 0 is the root; empty for an empty accelerator).
    pub nodes: &'a [CwBvhNode],
    /// One slot per leaf entry, in BVH leaf order.
    pub slots: Vec<ExportSlot>,
    /// Frame and epsilon constants.
    pub frame: ExportFrame,
}
