//! The global cube's projection on the GPU (issue 17 (c); GlobalCube §3.1–3.2):
//! [`GpuProjector`] implements [`wavelux_volume::Projector`] as a compute pass, the
//! grid in storage buffers (no samplers, no blending: blend precision varies by
//! device).
//!
//! # What it computes
//! Exactly what [`wavelux_volume::CpuProjector`] computes with
//! [`wavelux_volume::Projection::Exact`] and
//! [`AntiAlias::OFF`](wavelux_volume::backend::cpu::AntiAlias::OFF) (one ray per pixel,
//! every cell at full resolution; see [`wavelux_volume::backend`] for the model): one
//! workgroup per receiving cell, its 64 invocations striding over the `6 N²` pixels of
//! the cube map; each pixel's ray leaves the receiver's centre (or, for a receiver
//! touching an opaque cell, the centres of its entry faces) at the CPU's sample
//! position and composites front to back cell by cell, in the same order and with
//! the same tie rule and crossing decisions as the CPU (the paper's back-to-front slices, integrated
//! exactly per cell). The collision weights of eqs. (29)–(31) and the pixel solid
//! angles become tables computed on the host in f64 (one table per distinct receiver
//! depth and framebuffer side); the 18 face sums (6 entry faces × RGB) are reduced on
//! the GPU and only they come back. The host applies the normalisation
//! `Ĝ_p / Σ ΔΩ G_p` and the face area in f64.
//!
//! # Precision (contract: 1e-5 relative, grids up to 64³)
//! Rays run in f32: coordinates are in voxels (≤ 1024, exact in f32 at the sample
//! positions, which are multiples of ½), each chord carries a relative error of a few
//! `u = 2⁻²⁴`, the opacity `1 − e^{−κℓ}` is evaluated without cancellation (a Horner
//! series below `κℓ = ½`), transmittance products lose at most `u` per crossed cell,
//! and the per-pixel sums are compensated (TwoSum per invocation and in the fixed
//! tree of the workgroup reduction). Along a ray of `m` cells the radiance is within
//! about `4 m u` relative of the f64 one (`m ≤ 3·64` at 64³: ≤ 5e-5 worst case,
//! typically far less because errors of different cells do not align).
//!
//! # Ties
//! Exact edge and corner crossings follow the CPU's tie rule: where a ray leaves a box
//! across two or three faces at once, the crossing is the mean over every order of
//! stepping across the tied axes (an opaque cell beside the edge stops the orders
//! that meet it, the others enter the next cell through the mixture of faces they end
//! on). Cube-map pixel centres hit cell edges exactly and systematically (`|u| = |v|`,
//! odd ratios `|u| : |v| = 1 : 3, …`, and edges between the neighbours of a coarse
//! cell's face), and there every discrete decision of the traversal is made by
//! rounding: which planes a ray meets first and which at once (the CPU compares its
//! f64 distances `(b − o)·(1/d)`), and, leaving a coarse cell, which neighbouring
//! voxel the exit point `o + t·d` lies in. The shader takes each of these decisions
//! on the CPU's f64 values, formed exactly in integer arithmetic: the host uploads
//! each pixel's f64 `|1/d|` and `|d|`; `crossing_key` forms `2|b − o|·|1/d|` (an
//! integer below 2¹³ times a 53-bit significand) in 16-bit limbs and rounds it to 53
//! bits as the CPU's multiplication does (an order-preserving key: equal keys are the
//! CPU's ties); `exit_voxel` forms `t·|d|` as a 106-bit product rounded to 53 bits
//! and, where the f32 exit coordinate is within 1e-3 of an integer `n`, the exact
//! difference of `o ± t·|d|` and `n`, which the CPU's sum rounds to `n` itself iff it
//! is at most half the spacing of doubles at `n`. (Ray origins are multiples of ½
//! voxel, which keeps `b − o` exact.) Chord lengths, opacities and sums stay f32.
//! So the GPU takes the CPU's path through the grid ray for ray, and the f32
//! contract holds with opaque cells and per-face emission too (measured on lavapipe:
//! 2.1e-7 of the largest face on random grids with 4³ leaves; the earlier f32
//! decisions left up to 5.5e-2).
//!
//! Receiver samples ([`GpuProjector::with_receiver_samples`], `k` = 1, 2, 4 or 8): the
//! CPU's `k³` points of a cell or `k²` of each entry face, averaged in the shader;
//! with `k > 1` the conserving escape runs on the CPU.
//!
//! Not implemented here (the CPU projector has them): the pyramid projection and
//! adaptive supersampling; [`GpuProjector`] is the exact projector, one ray per pixel
//! and receiver sample.
//!
//! # Determinism
//! Each workgroup sums its pixels in a fixed order (invocation `i` takes pixels
//! `i, i + 64, …`, then a fixed binary tree): the same input on the same device gives
//! bitwise the same output. No atomics.

use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock};

use wavelux_volume::VolumeError;
use wavelux_volume::backend::cpu::{AntiAlias, CpuProjector, MIN_TRANSMITTANCE, Projection};
use wavelux_volume::backend::{
    Emission, FaceRgb, GatherStats, ProjectionScene, Projector, Receiver, TraversalCell,
    check_inputs,
};
use wavelux_volume::cell::{Collision, entry_weights};
use wavelux_volume::cubemap::{CubeMap, MAX_FRAMEBUFFER, face_index};

use crate::GpuError;
use crate::device::{Gpu, dispatch_dims};

const SHADER: &str = include_str!("shaders/projector.wgsl");
/// u32 words per job in the output: 18 sums, 18 compensations, the composited count.
const OUT_STRIDE: usize = 37;
/// Bytes of one job record (`Job` in the shader).
const JOB_BYTES: u64 = 32;
/// u32 words of one pixel record (`Pixel` in the shader).
const PIXEL_WORDS: usize = 20;

/// The GPU projector (module docs).
#[derive(Debug)]
pub struct GpuProjector {
    gpu: Arc<Gpu>,
    limit: Option<u64>,
    samples: u32,
    pipeline: OnceLock<Result<wgpu::ComputePipeline, GpuError>>,
    /// Calls share nothing on the device but the pipeline; one at a time keeps the
    /// device's memory bounded.
    lock: Mutex<()>,
}

impl GpuProjector {
    /// A projector on `gpu` using the device's binding limit.
    pub fn new(gpu: Arc<Gpu>) -> GpuProjector {
        GpuProjector {
            gpu,
            limit: None,
            samples: 1,
            pipeline: OnceLock::new(),
            lock: Mutex::new(()),
        }
    }

    /// Gathers from `k` ray origins per axis of each receiver, as
    /// [`CpuProjector::with_receiver_samples`] (`k³` points of a cell, `k²` of each entry
    /// face of a cell touching an opaque one or opaque itself). `k` must be 1, 2, 4 or 8
    /// (origins at multiples of `1/(2k)` voxel, which keeps the shader's crossing
    /// decisions exact; other values are a typed error at the call). With `k > 1` the
    /// escape is the CPU's conserving one ([`CpuProjector::escape`], run on the CPU: its
    /// points follow an irrational sequence the shader cannot place exactly).
    pub fn with_receiver_samples(mut self, k: u32) -> GpuProjector {
        self.samples = k;
        self
    }

    /// Lowers the per-buffer binding limit to `bytes` (at least 4096) so that smaller
    /// problems are cut into several dispatches (for tests).
    pub fn with_binding_limit(mut self, bytes: u64) -> GpuProjector {
        self.limit = Some(bytes.max(4096));
        self
    }

    /// The adapter this projector runs on.
    pub fn gpu(&self) -> &Arc<Gpu> {
        &self.gpu
    }

    fn limit(&self) -> u64 {
        let dev = self.gpu.max_binding();
        self.limit.map_or(dev, |l| l.min(dev))
    }

    fn pipeline(&self) -> Result<&wgpu::ComputePipeline, GpuError> {
        let p = self.pipeline.get_or_init(|| {
            self.gpu
                .scoped(|| Ok(self.gpu.pipeline("wavelux projector", SHADER, "main")))
        });
        p.as_ref().map_err(Clone::clone)
    }

    /// Receiver samples the shader places exactly (`with_receiver_samples`), with
    /// `2k·(side + 1) < 2¹⁶` for its crossing keys.
    fn check_samples(&self, scene: &ProjectionScene<'_>) -> Result<(), VolumeError> {
        let k = self.samples;
        if !matches!(k, 1 | 2 | 4 | 8) {
            return Err(self.backend_error(format!(
                "receiver samples {k}: the GPU projector takes 1, 2, 4 or 8"
            )));
        }
        if 2 * u64::from(k) * (scene.side as u64 + 1) >= 1 << 16 {
            return Err(self.backend_error(format!(
                "receiver samples {k} on a {}³ grid: ray origins need 2k·(side + 1) < 65536",
                scene.side
            )));
        }
        Ok(())
    }

    fn backend_error(&self, reason: String) -> VolumeError {
        VolumeError::Backend {
            backend: self.name(),
            reason,
        }
    }
}

/// The scene, emission and cube maps on the device for one call.
struct Uploaded {
    cells: wgpu::Buffer,
    map: wgpu::Buffer,
    emis: wgpu::Buffer,
    pixels: wgpu::Buffer,
    /// Per framebuffer side (sorted): first pixel in `pixels`.
    maps: Vec<(u32, u32, Arc<CubeMap>)>,
}

impl Uploaded {
    fn map_of(&self, side: u32) -> Option<(u32, &CubeMap)> {
        self.maps
            .iter()
            .find(|(s, _, _)| *s == side)
            .map(|(_, base, m)| (*base, m.as_ref()))
    }
}

/// One dispatch's jobs: `[lo.x, lo.y, lo.z, size, table, pix, npix, flags]`.
type JobRecord = [u32; 8];

impl GpuProjector {
    fn upload(
        &self,
        scene: &ProjectionScene<'_>,
        emission: &Emission<'_>,
        sides: &[u32],
    ) -> Result<Uploaded, VolumeError> {
        let limit = self.limit();
        let mut cells = Vec::with_capacity(scene.cells.len());
        for (i, c) in scene.cells.iter().enumerate() {
            if c.extinction.is_nan() || c.extinction < 0.0 {
                return Err(self.backend_error(format!(
                    "cell {i}: extinction {} is not a non-negative number",
                    c.extinction
                )));
            }
            let ext = if c.extinction == f64::INFINITY {
                -1.0f32
            } else {
                c.extinction.min(f64::from(f32::MAX)) as f32
            };
            cells.push([
                c.origin[0],
                c.origin[1],
                c.origin[2],
                c.size,
                ext.to_bits(),
                0,
                0,
                0,
            ]);
        }
        let emis: Vec<f32> = emission
            .coefficients
            .iter()
            .flat_map(|f| f.iter().flatten().map(|&v| v as f32))
            .collect();
        let mut maps = Vec::new();
        let mut pixels: Vec<[u32; PIXEL_WORDS]> = Vec::new();
        for &s in sides {
            let m = CubeMap::shared(s as usize);
            maps.push((s, pixels.len() as u32, m.clone()));
            for p in &m.pixels {
                let entry = u32::from(p.entry[0])
                    | u32::from(p.entry[1]) << 8
                    | u32::from(p.entry[2]) << 16;
                // The CPU's reciprocal direction `1/d` in f64 (bits of |1/d|, high and
                // low words), from which the shader rounds crossing distances as the
                // CPU does (module docs, "Ties").
                let inv = p.dir.map(|x| {
                    if x != 0.0 {
                        (1.0 / x).abs().to_bits()
                    } else {
                        0
                    }
                });
                let (hi, lo) = (inv.map(|b| (b >> 32) as u32), inv.map(|b| b as u32));
                // And |d| in f64, from which it forms the CPU's exit points.
                let dir = p.dir.map(|x| x.abs().to_bits());
                let (dh, dl) = (dir.map(|b| (b >> 32) as u32), dir.map(|b| b as u32));
                pixels.push([
                    (p.dir[0] as f32).to_bits(),
                    (p.dir[1] as f32).to_bits(),
                    (p.dir[2] as f32).to_bits(),
                    (p.solid_angle as f32).to_bits(),
                    entry,
                    hi[0],
                    hi[1],
                    hi[2],
                    lo[0],
                    lo[1],
                    lo[2],
                    dh[0],
                    dh[1],
                    dh[2],
                    dl[0],
                    dl[1],
                    dl[2],
                    0,
                    0,
                    0,
                ]);
            }
        }
        let gpu = &self.gpu;
        for (what, bytes) in [
            ("projector cells", cells.len() as u64 * 32),
            ("projector cell map", scene.cell_map.len() as u64 * 4),
            ("projector emission", emis.len() as u64 * 4),
            (
                "projector cube maps",
                (pixels.len() * PIXEL_WORDS * 4) as u64,
            ),
        ] {
            if bytes > limit {
                return Err(GpuError::TooLarge {
                    adapter: gpu.adapter().name.clone(),
                    what,
                    needed: bytes,
                    limit,
                }
                .into());
            }
        }
        Ok(gpu.scoped(|| {
            Ok(Uploaded {
                cells: gpu.storage(
                    "wavelux projector cells",
                    bytemuck::cast_slice(&cells),
                    false,
                ),
                map: gpu.storage(
                    "wavelux projector map",
                    bytemuck::cast_slice(scene.cell_map),
                    false,
                ),
                emis: gpu.storage(
                    "wavelux projector emission",
                    bytemuck::cast_slice(&emis),
                    false,
                ),
                pixels: gpu.storage(
                    "wavelux projector pixels",
                    bytemuck::cast_slice(&pixels),
                    false,
                ),
                maps,
            })
        })?)
    }

    /// Runs one dispatch of `jobs` and returns, per job, the 18 compensated sums (in
    /// f64) and the composited-cell count.
    fn dispatch(
        &self,
        up: &Uploaded,
        scene: &ProjectionScene<'_>,
        mode: u32,
        jobs: &[JobRecord],
        weights: &[f32],
    ) -> Result<Vec<([f64; 18], u64)>, GpuError> {
        let gpu = &self.gpu;
        let pipe = self.pipeline()?;
        let out_bytes = (jobs.len() * OUT_STRIDE * 4) as u64;
        let words = gpu.scoped(|| {
            let dev = gpu.device();
            let params = [
                jobs.len() as u32,
                scene.side as u32,
                (scene.voxel as f32).to_bits(),
                (MIN_TRANSMITTANCE as f32).to_bits(),
                mode,
                if mode == 0 { self.samples } else { 1 },
                0,
                0,
            ];
            let pbuf = gpu.buffer(
                "wavelux projector params",
                32,
                wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            );
            gpu.queue()
                .write_buffer(&pbuf, 0, bytemuck::cast_slice(&params));
            let jbuf = gpu.storage("wavelux projector jobs", bytemuck::cast_slice(jobs), false);
            let wbuf = gpu.storage(
                "wavelux projector weights",
                bytemuck::cast_slice(weights),
                false,
            );
            let obuf = gpu.buffer(
                "wavelux projector out",
                out_bytes,
                wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            );
            let staging = gpu.buffer(
                "wavelux projector staging",
                out_bytes,
                wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            );
            let layout = pipe.get_bind_group_layout(0);
            let entries: Vec<wgpu::BindGroupEntry<'_>> = [
                &pbuf, &up.cells, &up.map, &up.emis, &up.pixels, &wbuf, &jbuf, &obuf,
            ]
            .iter()
            .enumerate()
            .map(|(i, b)| wgpu::BindGroupEntry {
                binding: i as u32,
                resource: b.as_entire_binding(),
            })
            .collect();
            let bind = dev.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("wavelux projector"),
                layout: &layout,
                entries: &entries,
            });
            let mut enc = dev.create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("wavelux projector"),
            });
            {
                let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("wavelux projector"),
                    timestamp_writes: None,
                });
                pass.set_pipeline(pipe);
                pass.set_bind_group(0, &bind, &[]);
                let (gx, gy) = dispatch_dims(jobs.len() as u32);
                pass.dispatch_workgroups(gx, gy, 1);
            }
            enc.copy_buffer_to_buffer(&obuf, 0, &staging, 0, out_bytes);
            gpu.submit_and_read(enc, &staging, out_bytes)
        })?;
        Ok(words
            .chunks_exact(OUT_STRIDE)
            .map(|w| {
                let sums = std::array::from_fn(|i| {
                    f64::from(f32::from_bits(w[i])) + f64::from(f32::from_bits(w[18 + i]))
                });
                (sums, u64::from(w[36]))
            })
            .collect())
    }

    /// Jobs per dispatch so that the output and the job list each fit one binding.
    fn max_jobs(&self) -> usize {
        let per = (OUT_STRIDE as u64 * 4).max(JOB_BYTES);
        ((self.limit() / per) as usize).clamp(1, 1 << 22)
    }
}

/// Whether a face of the box `[lo, lo + size)` touches an opaque cell: then each entry
/// face sends its own ray (the CPU projector's rule, GlobalCube §3.1).
fn touches_opaque(scene: &ProjectionScene<'_>, lo: [i64; 3], size: i64) -> bool {
    let n = scene.side as i64;
    (0..6).any(|f| {
        let axis = f / 2;
        // The voxel across the face's centre.
        let mut idx = [0, 1, 2].map(|a| (lo[a] as f64 + 0.5 * size as f64).floor() as i64);
        idx[axis] = if f % 2 == 1 {
            lo[axis] - 1
        } else {
            lo[axis] + size
        };
        if idx.iter().any(|&i| i < 0 || i >= n) {
            return false;
        }
        let lin = (idx[0] + n * (idx[1] + n * idx[2])) as usize;
        let c: &TraversalCell = &scene.cells[scene.cell_map[lin] as usize];
        c.extinction == f64::INFINITY
    })
}

/// The weight table of one receiver depth: per pixel `ΔΩ·w_e` (f32) for the three
/// entry faces, and `Σ ΔΩ Σ_e w_e` in f64 (the CPU's normalisation, same order).
fn weight_table(map: &CubeMap, depth: f64, collision: Collision) -> (Vec<f32>, f64) {
    let mut table = Vec::with_capacity(3 * map.pixels.len());
    let mut norm = 0.0;
    for pix in &map.pixels {
        let w = entry_weights(pix.abs, depth, collision);
        let wt = w[0] + w[1] + w[2];
        if wt > 0.0 {
            norm += pix.solid_angle * wt;
            table.extend(w.map(|x| (pix.solid_angle * x) as f32));
        } else {
            table.extend([0.0f32; 3]);
        }
    }
    (table, norm)
}

impl Projector for GpuProjector {
    fn name(&self) -> String {
        format!("gpu-exact ({})", self.gpu.adapter().name)
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
        self.check_samples(scene)?;
        let _guard = self
            .lock
            .lock()
            .map_err(|_| self.backend_error("projector lock poisoned".into()))?;
        let mut sides: Vec<u32> = receivers.iter().map(|r| r.framebuffer).collect();
        sides.sort_unstable();
        sides.dedup();
        let up = self.upload(scene, emission, &sides)?;
        let limit = self.limit();
        let max_jobs = self.max_jobs();
        let mut stats = GatherStats::default();
        let mut start = 0;
        while start < receivers.len() {
            // Grow the chunk while the weight tables fit one binding.
            let mut tables: HashMap<(u64, u32), (u32, f64)> = HashMap::new();
            let mut weights: Vec<f32> = Vec::new();
            let mut jobs: Vec<JobRecord> = Vec::new();
            let mut norms: Vec<f64> = Vec::new();
            let mut end = start;
            while end < receivers.len() && jobs.len() < max_jobs {
                let r = receivers[end];
                let cell = &scene.cells[r.cell as usize];
                let depth = cell.depth();
                let Some((pix, map)) = up.map_of(r.framebuffer) else {
                    return Err(self.backend_error(format!(
                        "framebuffer {} outside 1..={MAX_FRAMEBUFFER}",
                        r.framebuffer
                    )));
                };
                let key = (depth.to_bits(), r.framebuffer);
                let (table, norm) = match tables.get(&key) {
                    Some(&t) => t,
                    None => {
                        let bytes = (3 * map.pixels.len() * 4) as u64;
                        if (weights.len() * 4) as u64 + bytes > limit {
                            if jobs.is_empty() {
                                return Err(GpuError::TooLarge {
                                    adapter: self.gpu.adapter().name.clone(),
                                    what: "projector weight table",
                                    needed: bytes,
                                    limit,
                                }
                                .into());
                            }
                            break;
                        }
                        let (t, norm) = weight_table(map, depth, collision);
                        let base = weights.len() as u32;
                        weights.extend(t);
                        tables.insert(key, (base, norm));
                        (base, norm)
                    }
                };
                let lo = cell.origin.map(i64::from);
                let size = i64::from(cell.size);
                let per_face = touches_opaque(scene, lo, size)
                    || (self.samples > 1 && cell.extinction == f64::INFINITY);
                jobs.push([
                    cell.origin[0],
                    cell.origin[1],
                    cell.origin[2],
                    cell.size,
                    table,
                    pix,
                    map.pixels.len() as u32,
                    u32::from(per_face),
                ]);
                norms.push(norm);
                end += 1;
            }
            let res = self.dispatch(&up, scene, 0, &jobs, &weights)?;
            for (k, (sums, steps)) in res.iter().enumerate() {
                let r = receivers[start + k];
                let cell = &scene.cells[r.cell as usize];
                let norm = norms[k];
                let scale = if norm > 0.0 {
                    let edge = f64::from(cell.size) * scene.voxel;
                    cell.total_weight / norm * edge * edge
                } else {
                    1.0
                };
                out[start + k] =
                    std::array::from_fn(|f| std::array::from_fn(|ch| sums[3 * f + ch] * scale));
                stats.composited += steps;
                stats.rays += 6 * u64::from(r.framebuffer) * u64::from(r.framebuffer);
            }
            start = end;
        }
        Ok(stats)
    }

    fn escape(
        &self,
        scene: &ProjectionScene<'_>,
        emission: &Emission<'_>,
        framebuffer: u32,
    ) -> Result<[f64; 3], VolumeError> {
        check_inputs(&self.name(), scene, emission, &[], 0)?;
        if framebuffer == 0 || framebuffer as usize > MAX_FRAMEBUFFER {
            return Err(self.backend_error(format!(
                "framebuffer {framebuffer} outside 1..={MAX_FRAMEBUFFER}"
            )));
        }
        self.check_samples(scene)?;
        if self.samples > 1 {
            // The conserving escape (see `with_receiver_samples`).
            return CpuProjector::new(Projection::Exact, AntiAlias::OFF)
                .with_receiver_samples(self.samples)
                .escape(scene, emission, framebuffer);
        }
        let _guard = self
            .lock
            .lock()
            .map_err(|_| self.backend_error("projector lock poisoned".into()))?;
        let up = self.upload(scene, emission, &[framebuffer])?;
        let npix = 6 * framebuffer * framebuffer;
        let n = scene.side as i64;
        // One job per boundary voxel square: the voxel just outside the grid, seen
        // through its inward face (the CPU's order: face, row, column).
        let mut jobs: Vec<JobRecord> = Vec::with_capacity(6 * scene.side * scene.side);
        for face in 0..6 {
            let axis = face / 2;
            let outward_negative = face % 2 == 1;
            let (ta, tb) = ((axis + 1) % 3, (axis + 2) % 3);
            for j in 0..n {
                for i in 0..n {
                    let mut lo = [0i64; 3];
                    lo[axis] = if outward_negative { -1 } else { n };
                    lo[ta] = i;
                    lo[tb] = j;
                    let inward = face_index(axis, !outward_negative) as u32;
                    jobs.push([
                        lo[0] as u32,
                        lo[1] as u32,
                        lo[2] as u32,
                        1,
                        inward,
                        0,
                        npix,
                        0,
                    ]);
                }
            }
        }
        let mut total = [0.0; 3];
        for chunk in jobs.chunks(self.max_jobs()) {
            for (sums, _) in self.dispatch(&up, scene, 1, chunk, &[])? {
                for ch in 0..3 {
                    total[ch] += sums[ch];
                }
            }
        }
        let area = scene.voxel * scene.voxel;
        Ok(total.map(|t| t * area))
    }
}
