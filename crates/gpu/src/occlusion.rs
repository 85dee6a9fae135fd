//! Two-point occlusion on the GPU (issue 17 (a)): [`GpuOcclusion`] implements
//! [`OcclusionBackend`]; its occluder answers exactly as [`Accel::occluded`].
//!
//! # Upload
//! Once per [`Accel`], from [`Accel::export`]: the accelerator's own CWBVH nodes (no
//! second build, same leaf order) and one 64-byte slot per leaf entry — triangle
//! vertices, convex quadrilateral corners, three points spanning a planar region's plane,
//! or nothing for a curved primitive — in the normalised f32 frame.
//!
//! # Kernel
//! One invocation per query: the segment `a → b` (end points in the frame, rounded
//! to f32) traverses the CWBVH with a node-group stack of 32 entries (one per level;
//! a full stack makes the answer unsure). Child boxes are decoded from the quantised
//! planes and widened by `4u` relative; the slab test (Ize 2013) widens every slab
//! parameter by `1e-6` relative and has no absolute entry clamp. A blocking leaf ends
//! the traversal (any hit).
//!
//! # Leaf tests and their error bound
//! With `u = 2⁻²⁴`, every decision is a sign of a 3×3 determinant
//! `det(x, y, z) = (x × y)·z` of differences of rounded inputs:
//! - edge functions `wᵢ = det(Vᵢ − a, Vᵢ₊₁ − a, b − a)` (which side of edge `i` the
//!   line passes);
//! - plane functions `f(p) = det(V₁ − V₀, V_last − V₀, p − V₀)` at `p = a, b` (which
//!   side of the plane each end point lies).
//!
//! A rounded input differs from its f64 value by at most `u·|value|`, and the f32
//! difference of two rounded inputs by at most `eₓ = 2u(|p| + |q|)` componentwise;
//! vertices carry `1e-8·size` more for the 1e-9 dilation of planar primitives. By
//! multilinearity, for inputs within `eₓ, e_y, e_z` of the exact ones,
//! `|det(x̃, ỹ, z̃) − det(x, y, z)| ≤ P(|x|+eₓ, |y|+e_y, |z|+e_z) − P(|x|, |y|, |z|)`
//! with `P(x, y, z) = Σ |xᵢ||yⱼ||z_k|` over the six terms; the f32 evaluation of the
//! determinant and of both `P` adds at most `16u·P(|x|+eₓ, …)`. That sum is the bound
//! `B` (shader `det_bound`); a sign is *sure* only when `|det| > B`. The f64 CPU test
//! errs by ~1e-15 of the same magnitudes, far inside `B`.
//!
//! A triangle or parallelogram is *surely hit* when every `wᵢ` is surely of one sign
//! (the line crosses the interior), both plane functions are surely of opposite signs
//! with the crossing `s* = |f(a)|/(|f(a)|+|f(b)|)` surely inside
//! `[ε/len, 1 − ε/len]` (margins `1e-5` relative and `1e-8` absolute, above the f64
//! test's own rounding for crossings that are not near-singular), and the segment is
//! surely more than 1e-9 rad from the plane (the CPU ignores rays within 1e-10 rad). It is
//! *surely missed* when two edge functions surely differ in sign, or the plane is
//! surely not crossed inside the interval. Planar regions (complex polygons) are only
//! ever surely missed by their plane; curved primitives are never decided. A ray is
//! blocked as soon as one leaf is surely hit, clear when every leaf reached is surely
//! missed and the stack never overflowed, unsure otherwise.
//!
//! The host hands unsure queries, and queries `occluded` answers without traversal
//! (coincident or non-finite end points, segments missing the scene box), to
//! [`Accel::occluded`]. The traversal is more conservative than obvhs' (wider boxes,
//! no entry clamp), so it reaches every leaf the CPU reaches: answers equal the CPU's.
//! Limitation: f32 rounding of the frame makes scenes whose end points lie far
//! outside the scene box (|x'| ≫ 1) unsure more often, never wrong.

use std::sync::{Arc, Mutex};

use wavelux_geometry::backend::{
    AccelExport, Occluder, OcclusionBackend, OcclusionQuery, OcclusionStats, SlotKind,
};
use wavelux_geometry::{Accel, GeometryError};

use crate::GpuError;
use crate::device::{Gpu, dispatch_dims};

const SHADER: &str = include_str!("shaders/occlusion.wgsl");
/// Queries per dispatch (the chunk of 2²⁰ rays).
pub const MAX_BATCH: usize = 1 << 20;
const QUERY_WORDS: usize = 12;

/// A device answer before the CPU re-trace.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RawAnswer {
    /// Surely not blocked.
    Clear,
    /// Surely blocked.
    Blocked,
    /// Not decided on the device (or not sent to it): the CPU answers.
    Unsure,
}

/// The GPU occlusion backend (module docs).
#[derive(Debug, Clone)]
pub struct GpuOcclusion {
    gpu: Arc<Gpu>,
    limit: Option<u64>,
}

impl GpuOcclusion {
    /// A backend on `gpu`.
    pub fn new(gpu: Arc<Gpu>) -> GpuOcclusion {
        GpuOcclusion { gpu, limit: None }
    }

    /// Lowers the per-buffer binding limit (bytes, at least 1024) so that batches are
    /// cut into smaller dispatches (for tests).
    pub fn with_binding_limit(mut self, bytes: u64) -> GpuOcclusion {
        self.limit = Some(bytes.max(1024));
        self
    }

    /// Prepares `a` and returns the concrete occluder (with [`GpuOccluder::raw`]).
    ///
    /// # Errors
    /// [`GpuError::TooLarge`] if the nodes or slots exceed one binding, or
    /// [`GpuError::Device`].
    pub fn prepare<'a>(&self, a: &'a Accel) -> Result<GpuOccluder<'a>, GpuError> {
        let gpu = self.gpu.clone();
        let limit = self
            .limit
            .map_or(gpu.max_binding(), |l| l.min(gpu.max_binding()));
        let ex = a.export();
        let slot_words = pack_slots(&ex);
        let node_bytes: &[u8] = bytemuck::cast_slice(ex.nodes);
        for (what, n) in [
            ("BVH nodes", node_bytes.len() as u64),
            ("BVH slots", (slot_words.len() * 4) as u64),
        ] {
            if n > limit {
                return Err(GpuError::TooLarge {
                    adapter: gpu.adapter().name.clone(),
                    what,
                    needed: n,
                    limit,
                });
            }
        }
        let batch = ((limit / (QUERY_WORDS as u64 * 4)) as usize).clamp(1, MAX_BATCH);
        let inner = gpu.scoped(|| {
            let pipeline = gpu.pipeline("wavelux occlusion", SHADER, "occlude");
            let nodes = gpu.storage("wavelux bvh nodes", node_bytes, false);
            let slots = gpu.storage(
                "wavelux bvh slots",
                bytemuck::cast_slice(&slot_words),
                false,
            );
            let params = gpu.buffer(
                "wavelux occlusion params",
                16,
                wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            );
            let queries = gpu.buffer(
                "wavelux occlusion queries",
                (batch * QUERY_WORDS * 4) as u64,
                wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            );
            let answers = gpu.buffer(
                "wavelux occlusion answers",
                (batch * 4) as u64,
                wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            );
            let staging = gpu.buffer(
                "wavelux occlusion staging",
                (batch * 4) as u64,
                wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            );
            let layout = pipeline.get_bind_group_layout(0);
            let bind = gpu.device().create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("wavelux occlusion"),
                layout: &layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: params.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: nodes.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 2,
                        resource: slots.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 3,
                        resource: queries.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 4,
                        resource: answers.as_entire_binding(),
                    },
                ],
            });
            Ok(Inner {
                pipeline,
                bind,
                params,
                queries,
                answers,
                staging,
                _nodes: nodes,
                _slots: slots,
            })
        })?;
        Ok(GpuOccluder {
            accel: a,
            gpu,
            scale: ex.frame.scale,
            centre: ex.frame.centre,
            eps: ex.frame.eps,
            batch,
            inner: Mutex::new(inner),
        })
    }
}

fn pack_slots(ex: &AccelExport<'_>) -> Vec<u32> {
    let mut w = Vec::with_capacity(ex.slots.len() * 16);
    for s in &ex.slots {
        let kind = match s.kind {
            SlotKind::Triangle => 0u32,
            SlotKind::Quad => 1,
            SlotKind::Plane => 2,
            _ => 3,
        };
        w.extend([kind, s.prim, u32::from(s.planar), s.size.to_bits()]);
        for p in &s.points {
            w.extend(p.iter().map(|c| c.to_bits()));
        }
    }
    w
}

impl OcclusionBackend for GpuOcclusion {
    fn name(&self) -> String {
        let a = self.gpu.adapter();
        format!("{} ({})", a.name, a.backend)
    }

    fn occluder<'a>(&self, a: &'a Accel) -> Result<Box<dyn Occluder + 'a>, GeometryError> {
        Ok(Box::new(self.prepare(a)?))
    }
}

#[derive(Debug)]
struct Inner {
    pipeline: wgpu::ComputePipeline,
    bind: wgpu::BindGroup,
    params: wgpu::Buffer,
    queries: wgpu::Buffer,
    answers: wgpu::Buffer,
    staging: wgpu::Buffer,
    _nodes: wgpu::Buffer,
    _slots: wgpu::Buffer,
}

/// One [`Accel`] prepared on the device.
#[derive(Debug)]
pub struct GpuOccluder<'a> {
    accel: &'a Accel,
    gpu: Arc<Gpu>,
    scale: f64,
    centre: glam::DVec3,
    eps: f64,
    batch: usize,
    /// The query, answer and staging buffers are shared: one batch at a time.
    inner: Mutex<Inner>,
}

impl GpuOccluder<'_> {
    /// The device's own answers (no CPU re-trace): [`RawAnswer::Unsure`] also for
    /// queries not sent to the device (those `occluded` answers without traversal).
    ///
    /// # Errors
    /// [`GpuError::Device`] if the device failed.
    pub fn raw(&self, q: &[OcclusionQuery]) -> Result<Vec<RawAnswer>, GpuError> {
        let mut out = vec![RawAnswer::Unsure; q.len()];
        let mut words = Vec::new();
        let mut index = Vec::new();
        for (i, qu) in q.iter().enumerate() {
            if let Some(w) = self.encode(qu) {
                words.extend_from_slice(&w);
                index.push(i);
            }
        }
        let inner = self
            .inner
            .lock()
            .map_err(|_| self.gpu.fail("occluder lock poisoned"))?;
        for (chunk, ids) in words
            .chunks(self.batch * QUERY_WORDS)
            .zip(index.chunks(self.batch))
        {
            let ans = self.dispatch(&inner, chunk, ids.len())?;
            for (&i, &a) in ids.iter().zip(&ans) {
                out[i] = match a {
                    0 => RawAnswer::Clear,
                    1 => RawAnswer::Blocked,
                    _ => RawAnswer::Unsure,
                };
            }
        }
        Ok(out)
    }

    /// The device encoding of a query, or `None` when `occluded` answers it without
    /// traversal (or its end points are not finite).
    fn encode(&self, qu: &OcclusionQuery) -> Option<[u32; QUERY_WORDS]> {
        let len = (qu.q - qu.p).length();
        // The same test as `Accel::occluded` (t0 = eps ≥ t1 = len − eps: clear).
        if !len.is_finite() || len == 0.0 || self.eps >= len - self.eps {
            return None;
        }
        self.accel.traversal_ray(qu.p, qu.q)?;
        let a = (qu.p - self.centre) * self.scale;
        let b = (qu.q - self.centre) * self.scale;
        let eps_s = (self.eps / len) as f32;
        let ig = |x: Option<u32>| x.unwrap_or(u32::MAX);
        Some([
            (a.x as f32).to_bits(),
            (a.y as f32).to_bits(),
            (a.z as f32).to_bits(),
            eps_s.to_bits(),
            (b.x as f32).to_bits(),
            (b.y as f32).to_bits(),
            (b.z as f32).to_bits(),
            0,
            ig(qu.ignore[0]),
            ig(qu.ignore[1]),
            0,
            0,
        ])
    }

    fn dispatch(&self, inner: &Inner, words: &[u32], n: usize) -> Result<Vec<u32>, GpuError> {
        let gpu = &self.gpu;
        let mut answers = gpu.scoped(|| {
            let q = gpu.queue();
            q.write_buffer(&inner.params, 0, bytemuck::cast_slice(&[n as u32, 0, 0, 0]));
            q.write_buffer(&inner.queries, 0, bytemuck::cast_slice(words));
            let mut enc = gpu
                .device()
                .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                    label: Some("wavelux occlusion"),
                });
            {
                let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("wavelux occlusion"),
                    timestamp_writes: None,
                });
                pass.set_pipeline(&inner.pipeline);
                pass.set_bind_group(0, &inner.bind, &[]);
                let (gx, gy) = dispatch_dims((n as u32).div_ceil(64));
                pass.dispatch_workgroups(gx, gy, 1);
            }
            enc.copy_buffer_to_buffer(&inner.answers, 0, &inner.staging, 0, (n * 4) as u64);
            gpu.submit_and_read(enc, &inner.staging, (n * 4) as u64)
        })?;
        answers.truncate(n);
        Ok(answers)
    }
}

impl Occluder for GpuOccluder<'_> {
    fn occluded_queries(
        &self,
        q: &[OcclusionQuery],
        out: &mut [bool],
    ) -> Result<OcclusionStats, GeometryError> {
        if out.len() != q.len() {
            return Err(GeometryError::OutOfRange {
                index: out.len(),
                len: q.len(),
            });
        }
        let raw = self.raw(q)?;
        let mut deferred = Vec::new();
        let mut slots = Vec::new();
        for (i, (r, o)) in raw.iter().zip(out.iter_mut()).enumerate() {
            match r {
                RawAnswer::Clear => *o = false,
                RawAnswer::Blocked => *o = true,
                RawAnswer::Unsure => {
                    deferred.push(q[i]);
                    slots.push(i);
                }
            }
        }
        let mut ans = vec![false; deferred.len()];
        self.accel.occluded_queries(&deferred, &mut ans)?;
        for (&i, &a) in slots.iter().zip(&ans) {
            out[i] = a;
        }
        Ok(OcclusionStats {
            queries: q.len(),
            device_rays: q.len() - deferred.len(),
            deferred_rays: deferred.len(),
        })
    }
}
