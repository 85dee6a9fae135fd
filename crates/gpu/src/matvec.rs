//! Matrix–vector products on the GPU (issue 17 (b)): [`GpuMatVec`] implements
//! [`MatVecBackend`] for dense and block-sparse (BSR, `r×c ≤ 16×16`) matrices.
//!
//! # Method
//! The matrix is scaled by `2^-a` and every right-hand side `l` by `2^-b_l` (powers
//! of two: exact), with `2^a ≥ max|A|` and `2^{b_l} ≥ max|x_l|`, then rounded to f32.
//! BSR runs one workgroup per block row, one invocation per (row of the block,
//! right-hand side); dense runs one invocation per row. Each invocation sums its
//! products in storage order with Knuth's TwoSum (sum and compensation in f32); the
//! host returns `(s + e)·2^{a+b_l}` in f64. No atomics, no reduction across
//! invocations: the same input on the same device gives bitwise the same output.
//!
//! # Error bound (contract of [`wavelux_linear::backend`])
//! With `u = 2⁻²⁴`: rounding `A` and `x` to f32 and the f32 product give each term a
//! relative error ≤ `3u + O(u²)`; TwoSum makes the summation error ≤ `u·|y| +
//! O(n u²)·Σ|a x|` (the compensation itself is summed in plain f32). Entries whose
//! scaled value or product falls below f32's normal range (< 2⁻¹²⁶, possibly flushed
//! to zero by the device) contribute at most `n·2⁻¹²⁶·max|A|·max|x|`. Together,
//! `|y_gpu − y_cpu|ᵢ ≤ 5u·(|A||x|)ᵢ + n·2⁻¹²⁶·max|A|·max|x| < 1e-6·(|A||x|)ᵢ +
//! 1e-30·max|A|·max|x|` for `n < 2⁹⁵` terms per row. Even if a driver fused a product
//! into the following addition (WGSL cannot forbid FMA contraction) the compensation
//! term only loses exactness, and the bound above still holds since it charges the
//! product's rounding to the `3u` term.
//!
//! # Limits
//! Matrices are cut into chunks of whole (block) rows whose buffers each fit the
//! device's storage-binding limit (128 MiB on lavapipe; lowered by
//! [`GpuMatVec::with_binding_limit`] to test chunking). The vector `x` must fit one
//! binding. The transpose is built in f64 on the host and uploaded on the first
//! transposed product.

use std::sync::{Arc, Mutex, OnceLock};

use wavelux_linear::LinearError;
use wavelux_linear::backend::{
    MAX_RHS, MatVecBackend, MatVecStats, Matrix, PreparedMatVec, check_lengths,
};

use crate::GpuError;
use crate::device::{Gpu, dispatch_dims};

const SHADER: &str = include_str!("shaders/matvec.wgsl");

/// The GPU matrix–vector backend (module docs).
#[derive(Debug, Clone)]
pub struct GpuMatVec {
    gpu: Arc<Gpu>,
    limit: Option<u64>,
}

impl GpuMatVec {
    /// A backend on `gpu` using the device's binding limit.
    pub fn new(gpu: Arc<Gpu>) -> GpuMatVec {
        GpuMatVec { gpu, limit: None }
    }

    /// Lowers the per-buffer binding limit to `bytes` (at least 64) so that smaller
    /// matrices are cut into several chunks (for tests).
    pub fn with_binding_limit(mut self, bytes: u64) -> GpuMatVec {
        self.limit = Some(bytes.max(64));
        self
    }

    fn limit(&self) -> u64 {
        let dev = self.gpu.max_binding();
        self.limit.map_or(dev, |l| l.min(dev))
    }
}

impl MatVecBackend for GpuMatVec {
    fn name(&self) -> String {
        let a = self.gpu.adapter();
        format!("{} ({})", a.name, a.backend)
    }

    fn prepare<'a>(&self, m: &'a Matrix) -> Result<Box<dyn PreparedMatVec + 'a>, LinearError> {
        let pipes = self.gpu.scoped(|| {
            Ok(Pipelines {
                bsr: self.gpu.pipeline("wavelux matvec bsr", SHADER, "bsr"),
                dense: self.gpu.pipeline("wavelux matvec dense", SHADER, "dense"),
            })
        })?;
        let fwd = Uploaded::new(&self.gpu, &pipes, m, self.limit())?;
        Ok(Box::new(GpuPrepared {
            gpu: self.gpu.clone(),
            limit: self.limit(),
            m,
            pipes,
            fwd,
            tr: OnceLock::new(),
            lock: Mutex::new(()),
        }))
    }
}

#[derive(Debug)]
struct Pipelines {
    bsr: wgpu::ComputePipeline,
    dense: wgpu::ComputePipeline,
}

#[derive(Debug)]
struct Chunk {
    params: wgpu::Buffer,
    bind: wgpu::BindGroup,
    y: wgpu::Buffer,
    /// Workgroups to dispatch.
    groups: u32,
    /// Block rows (BSR) or rows (dense) of the chunk.
    units: u32,
    /// First scalar row of the chunk.
    row0: usize,
    /// Scalar rows of the chunk.
    rows: usize,
}

/// One matrix (or its transpose) on the device.
#[derive(Debug)]
struct Uploaded {
    dense: bool,
    rows: usize,
    cols: usize,
    r: u32,
    c: u32,
    entries: usize,
    /// `2^a ≥ max|A|`.
    exp: i32,
    chunks: Vec<Chunk>,
    x: wgpu::Buffer,
    staging: wgpu::Buffer,
}

/// Smallest `e` with `2^e ≥ m` (0 for `m = 0`).
fn exponent(m: f64) -> i32 {
    if m > 0.0 {
        let mut e = m.log2().ceil() as i32;
        // Guard log2's rounding: make 2^e ≥ m and 2^(e−1) < m.
        while 2f64.powi(e) < m {
            e += 1;
        }
        while e > -1000 && 2f64.powi(e - 1) >= m {
            e -= 1;
        }
        e
    } else {
        0
    }
}

fn scaled_f32(v: &[f64], exp: i32) -> Vec<f32> {
    let s = 2f64.powi(-exp);
    v.iter().map(|&a| (a * s) as f32).collect()
}

impl Uploaded {
    fn new(gpu: &Gpu, pipes: &Pipelines, m: &Matrix, limit: u64) -> Result<Uploaded, GpuError> {
        let too_large = |what, needed: u64| GpuError::TooLarge {
            adapter: gpu.adapter().name.clone(),
            what,
            needed,
            limit,
        };
        let (rows, cols) = (m.rows(), m.cols());
        let x_bytes = (cols * MAX_RHS * 4) as u64;
        if x_bytes > limit {
            return Err(too_large("matvec x", x_bytes));
        }
        let maxa = m.stored_values().iter().fold(0.0f64, |a, v| a.max(v.abs()));
        let exp = exponent(maxa);
        let vals = scaled_f32(m.stored_values(), exp);
        gpu.scoped(|| {
            let x = gpu.buffer(
                "wavelux matvec x",
                x_bytes,
                wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            );
            let staging = gpu.buffer(
                "wavelux matvec staging",
                (rows * MAX_RHS * 8) as u64,
                wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            );
            let mut chunks = Vec::new();
            let (r, c, dense) = match m {
                Matrix::Dense { .. } => {
                    // Rows per chunk: values and y must each fit one binding.
                    let per_row = (cols as u64 * 4).max((MAX_RHS * 8) as u64);
                    if per_row > limit {
                        return Err(too_large("one dense row", per_row));
                    }
                    let step = ((limit / per_row) as usize).clamp(1, u32::MAX as usize / 64);
                    let mut row0 = 0;
                    while row0 < rows {
                        let n = step.min(rows - row0);
                        let v = &vals[row0 * cols..(row0 + n) * cols];
                        let params = [n as u32, 1, 1, 1, n as u32, cols as u32, 0, 0];
                        chunks.push(Chunk::new(
                            gpu,
                            &pipes.dense,
                            &params,
                            None,
                            v,
                            &x,
                            n,
                            (n as u32).div_ceil(64),
                            row0,
                        ));
                        row0 += n;
                    }
                    (1, 1, true)
                }
                Matrix::BlockSparse(b) => {
                    let (r, c) = b.block_size();
                    let (nbr, _) = b.block_dims();
                    let rp = b.row_ptr();
                    let block_bytes = (r * c * 4) as u64;
                    let row_y = (r * MAX_RHS * 8) as u64;
                    let mut br0 = 0;
                    while br0 < nbr {
                        // Grow the chunk while every buffer fits.
                        let mut br1 = br0;
                        while br1 < nbr {
                            let nb = (rp[br1 + 1] - rp[br0]) as u64;
                            let nrow = (br1 + 1 - br0) as u64;
                            let fits = nb * block_bytes <= limit
                                && (nrow + 1) * 4 <= limit
                                && nrow * row_y <= limit
                                && nrow < 65535 * 65535;
                            if !fits {
                                break;
                            }
                            br1 += 1;
                        }
                        if br1 == br0 {
                            let nb = (rp[br0 + 1] - rp[br0]) as u64;
                            return Err(too_large("one block row", nb * block_bytes));
                        }
                        let base = rp[br0];
                        let ptr: Vec<u32> =
                            rp[br0..=br1].iter().map(|&p| (p - base) as u32).collect();
                        let cols_idx: Vec<u32> = b.col_idx()[base..rp[br1]]
                            .iter()
                            .map(|&j| j as u32)
                            .collect();
                        let v = &vals[base * r * c..rp[br1] * r * c];
                        let n = br1 - br0;
                        let params = [n as u32, r as u32, c as u32, 1, 0, 0, 0, 0];
                        chunks.push(Chunk::new(
                            gpu,
                            &pipes.bsr,
                            &params,
                            Some((&ptr, &cols_idx)),
                            v,
                            &x,
                            n * r,
                            n as u32,
                            br0 * r,
                        ));
                        br0 = br1;
                    }
                    (r as u32, c as u32, false)
                }
                _ => return Err(gpu.fail("unsupported matrix kind")),
            };
            Ok(Uploaded {
                dense,
                rows,
                cols,
                r,
                c,
                entries: m.stored_values().len(),
                exp,
                chunks,
                x,
                staging,
            })
        })
    }

    fn apply(
        &self,
        gpu: &Gpu,
        pipes: &Pipelines,
        k: usize,
        x: &[f64],
        y: &mut [f64],
    ) -> Result<MatVecStats, GpuError> {
        // Per right-hand-side power-of-two scale.
        let mut xe = [0i32; MAX_RHS];
        for (l, e) in xe.iter_mut().enumerate().take(k) {
            let mx = (0..self.cols).fold(0.0f64, |a, j| a.max(x[j * k + l].abs()));
            *e = exponent(mx);
        }
        let xs: Vec<f32> = x
            .iter()
            .enumerate()
            .map(|(i, &v)| (v * 2f64.powi(-xe[i % k])) as f32)
            .collect();
        let words = gpu.scoped(|| {
            let q = gpu.queue();
            if !xs.is_empty() {
                q.write_buffer(&self.x, 0, bytemuck::cast_slice(&xs));
            }
            let mut enc = gpu
                .device()
                .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                    label: Some("wavelux matvec"),
                });
            for ch in &self.chunks {
                let params = if self.dense {
                    [ch.units, 1, 1, k as u32, ch.units, self.cols as u32, 0, 0]
                } else {
                    [ch.units, self.r, self.c, k as u32, 0, 0, 0, 0]
                };
                q.write_buffer(&ch.params, 0, bytemuck::cast_slice(&params));
            }
            {
                let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("wavelux matvec"),
                    timestamp_writes: None,
                });
                pass.set_pipeline(if self.dense { &pipes.dense } else { &pipes.bsr });
                for ch in &self.chunks {
                    let (gx, gy) = dispatch_dims(ch.groups);
                    pass.set_bind_group(0, &ch.bind, &[]);
                    pass.dispatch_workgroups(gx, gy, 1);
                }
            }
            for ch in &self.chunks {
                let n = (ch.rows * k * 8) as u64;
                if n > 0 {
                    enc.copy_buffer_to_buffer(&ch.y, 0, &self.staging, (ch.row0 * k * 8) as u64, n);
                }
            }
            gpu.submit_and_read(enc, &self.staging, (self.rows * k * 8) as u64)
        })?;
        let pair = |j: usize| f64::from(f32::from_bits(words[j]));
        for (i, yi) in y.iter_mut().enumerate() {
            let s = 2f64.powi(self.exp + xe[i % k]);
            *yi = (pair(2 * i) + pair(2 * i + 1)) * s;
        }
        Ok(MatVecStats {
            entries: self.entries,
            dispatches: self.chunks.len(),
        })
    }
}

impl Chunk {
    fn new(
        gpu: &Gpu,
        pipe: &wgpu::ComputePipeline,
        params: &[u32; 8],
        sparse: Option<(&[u32], &[u32])>,
        vals: &[f32],
        x: &wgpu::Buffer,
        rows: usize,
        groups: u32,
        row0: usize,
    ) -> Chunk {
        let dev = gpu.device();
        let pbuf = gpu.buffer(
            "wavelux matvec params",
            32,
            wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        );
        gpu.queue()
            .write_buffer(&pbuf, 0, bytemuck::cast_slice(params));
        let vbuf = gpu.storage("wavelux matvec values", bytemuck::cast_slice(vals), false);
        let y = gpu.buffer(
            "wavelux matvec y",
            (rows * MAX_RHS * 8) as u64,
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        );
        let layout = pipe.get_bind_group_layout(0);
        let sparse_bufs = sparse.map(|(p, c)| {
            (
                gpu.storage("wavelux matvec row_ptr", bytemuck::cast_slice(p), false),
                gpu.storage("wavelux matvec col_idx", bytemuck::cast_slice(c), false),
            )
        });
        let mut entries = vec![
            wgpu::BindGroupEntry {
                binding: 0,
                resource: pbuf.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 3,
                resource: vbuf.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 4,
                resource: x.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 5,
                resource: y.as_entire_binding(),
            },
        ];
        if let Some((p, c)) = &sparse_bufs {
            entries.push(wgpu::BindGroupEntry {
                binding: 1,
                resource: p.as_entire_binding(),
            });
            entries.push(wgpu::BindGroupEntry {
                binding: 2,
                resource: c.as_entire_binding(),
            });
        }
        let bind = dev.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("wavelux matvec"),
            layout: &layout,
            entries: &entries,
        });
        Chunk {
            params: pbuf,
            bind,
            y,
            groups,
            units: params[0],
            row0,
            rows,
        }
    }
}

/// A matrix uploaded by [`GpuMatVec`].
struct GpuPrepared<'a> {
    gpu: Arc<Gpu>,
    limit: u64,
    m: &'a Matrix,
    pipes: Pipelines,
    fwd: Uploaded,
    tr: OnceLock<Result<Uploaded, GpuError>>,
    /// Products share the x and staging buffers: one at a time.
    lock: Mutex<()>,
}

impl GpuPrepared<'_> {
    fn run(
        &self,
        up: &Uploaded,
        k: usize,
        x: &[f64],
        y: &mut [f64],
    ) -> Result<MatVecStats, LinearError> {
        check_lengths(up.rows, up.cols, k, x, y)?;
        let _guard = self
            .lock
            .lock()
            .map_err(|_| LinearError::from(self.gpu.fail("matvec lock poisoned")))?;
        Ok(up.apply(&self.gpu, &self.pipes, k, x, y)?)
    }
}

impl PreparedMatVec for GpuPrepared<'_> {
    fn rows(&self) -> usize {
        self.fwd.rows
    }
    fn cols(&self) -> usize {
        self.fwd.cols
    }
    fn apply(&self, k: usize, x: &[f64], y: &mut [f64]) -> Result<MatVecStats, LinearError> {
        self.run(&self.fwd, k, x, y)
    }
    fn apply_transpose(
        &self,
        k: usize,
        x: &[f64],
        y: &mut [f64],
    ) -> Result<MatVecStats, LinearError> {
        let t = self
            .tr
            .get_or_init(|| Uploaded::new(&self.gpu, &self.pipes, &self.m.transpose(), self.limit));
        match t {
            Ok(up) => self.run(up, k, x, y),
            Err(e) => Err(e.clone().into()),
        }
    }
}
