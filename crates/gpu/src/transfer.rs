//! The meshless relighting product `i = S·e` on the GPU (issue 17 (b)'s "meshless
//! `S e`"; Meshless §3.3): [`GpuTransfer`] implements
//! [`wavelux_meshless::TransferBackend`] on the layout every backend shares,
//! [`wavelux_meshless::PackedTransfer`] (receivers in blocks, each block's part of
//! `S` in compressed sparse columns, nine `f32` per link).
//!
//! # Method
//! `S` is packed exactly as the CPU backend packs it and scaled by `2^-a` with
//! `2^a ≥ max|S|` (a power of two: exact), `e` by `2^-b` with `2^b ≥ max|e|`. One
//! workgroup per block walks the active senders (those with a non-zero value, the same
//! rule as [`wavelux_meshless::CpuBackend`]) in increasing order; its invocations
//! split the sender's column (a column holds each receiver at most once) and add the
//! products into per-receiver TwoSum pairs (sum, compensation) in f32, with a barrier
//! between columns. The host returns `(s + c)·2^{a+b}` rounded to f32. No atomics:
//! the same input on the same device gives bitwise the same output.
//!
//! # Error bound against the CPU backend
//! The CPU backend accumulates the exact products of the same f32 values in f64 and
//! rounds once, so it is within `u·|i|` of the exact product (`u = 2⁻²⁴`). Here each
//! product is rounded once (`u` relative), TwoSum makes the summation exact up to the
//! compensation's own rounding (`O(n u²)` of `Σ|terms|`, `n` terms), and the final
//! rounding adds `u·|i|`; scaled values below f32's normal range may be flushed
//! (`≤ 2⁻¹²⁶` each before unscaling). So, component by component,
//! `|i_gpu − i_cpu| ≤ 4u·(|S||e|) + n·2⁻¹²⁶·2^{a+b} < 1e-6·(|S||e|) +
//! 1e-30·max|S|·max|e|` for `n < 2²⁰` links per receiver, the contract of
//! `wavelux_linear::backend` (the tests check it). A driver that fuses a product into
//! the following addition (WGSL cannot forbid FMA contraction) only makes that
//! product exact; the compensation then misses at most the product's rounding, which
//! the bound already charges.
//!
//! # Limits
//! Blocks are grouped into chunks whose buffers each fit the device's storage-binding
//! limit (lowered by [`GpuTransfer::with_limits`] to test chunking); a single
//! block that does not fit, or senders whose `e` does not fit one binding, are a
//! [`GpuError::TooLarge`].

use std::sync::{Arc, Mutex};

use wavelux_meshless::backend::BLOCK_ROWS;
use wavelux_meshless::{PackedTransfer, TransferBackend, TransferMatrix};

use crate::GpuError;
use crate::device::{Gpu, dispatch_dims};

const SHADER: &str = include_str!("shaders/transfer.wgsl");
/// Accumulator words per receiver: nine sums, nine compensations.
const ACC: usize = 18;

/// The GPU transfer backend (module docs).
#[derive(Debug, Clone)]
pub struct GpuTransfer {
    gpu: Arc<Gpu>,
    limit: Option<u64>,
    block_rows: usize,
}

impl GpuTransfer {
    /// A backend on `gpu` with the CPU backend's block size and the device's binding
    /// limit.
    pub fn new(gpu: Arc<Gpu>) -> GpuTransfer {
        GpuTransfer {
            gpu,
            limit: None,
            block_rows: BLOCK_ROWS,
        }
    }

    /// Lowers the per-buffer binding limit to `bytes` (at least 256) and the block size
    /// to `block_rows` (at least 1) so that small matrices are cut into several blocks
    /// and chunks (for tests).
    pub fn with_limits(mut self, bytes: u64, block_rows: usize) -> GpuTransfer {
        self.limit = Some(bytes.max(256));
        self.block_rows = block_rows.max(1);
        self
    }

    fn limit(&self) -> u64 {
        let dev = self.gpu.max_binding();
        self.limit.map_or(dev, |l| l.min(dev))
    }
}

/// Smallest `e` with `2^e ≥ m` (0 for `m = 0` or a non-finite `m`).
fn exponent(m: f64) -> i32 {
    if !(m > 0.0 && m.is_finite()) {
        return 0;
    }
    let mut e = m.log2().ceil() as i32;
    while 2f64.powi(e) < m {
        e += 1;
    }
    while 2f64.powi(e - 1) >= m {
        e -= 1;
    }
    e
}

/// One chunk of consecutive blocks on the device.
#[derive(Debug)]
struct Chunk {
    params: wgpu::Buffer,
    bind: wgpu::BindGroup,
    acc: wgpu::Buffer,
    blocks: u32,
    /// First receiver and receivers of the chunk.
    row0: usize,
    rows: usize,
}

/// `S` uploaded by [`GpuTransfer::prepare`].
#[derive(Debug)]
pub struct GpuPreparedTransfer {
    rows: usize,
    cols: usize,
    block_rows: usize,
    /// `2^a ≥ max|S|`.
    exp: i32,
    chunks: Vec<Chunk>,
    e: wgpu::Buffer,
    active: wgpu::Buffer,
    staging: wgpu::Buffer,
    pipeline: wgpu::ComputePipeline,
    /// Products share the `e`, `active` and staging buffers: one at a time.
    lock: Mutex<()>,
}

impl GpuPreparedTransfer {
    /// Dispatches (chunks) per product.
    pub fn chunks(&self) -> usize {
        self.chunks.len()
    }
}

impl TransferBackend for GpuTransfer {
    type Prepared = GpuPreparedTransfer;
    type Error = GpuError;

    fn name(&self) -> String {
        format!("wgpu:{}", self.gpu.adapter().name)
    }

    fn prepare(&self, s: &TransferMatrix) -> Result<GpuPreparedTransfer, GpuError> {
        let packed = PackedTransfer::pack(s, self.block_rows);
        upload(&self.gpu, &packed, self.limit())
    }

    fn apply(&self, p: &GpuPreparedTransfer, e: &[f32], out: &mut [f32]) -> Result<(), GpuError> {
        if e.len() != p.cols * 3 || out.len() != p.rows * 9 {
            return Err(self.gpu.fail(format!(
                "transfer product: e has {} values for {} senders, out {} for {} receivers",
                e.len(),
                p.cols,
                out.len(),
                p.rows
            )));
        }
        let _guard = p
            .lock
            .lock()
            .map_err(|_| self.gpu.fail("transfer lock poisoned"))?;
        apply(&self.gpu, p, e, out)
    }
}

fn upload(gpu: &Gpu, m: &PackedTransfer, limit: u64) -> Result<GpuPreparedTransfer, GpuError> {
    let too_large = |what, needed: u64| GpuError::TooLarge {
        adapter: gpu.adapter().name.clone(),
        what,
        needed,
        limit,
    };
    let (rows, cols, br) = (m.rows, m.cols, m.block_rows);
    let e_bytes = (cols * 3 * 4) as u64;
    if e_bytes > limit {
        return Err(too_large("transfer e", e_bytes));
    }
    if rows > u32::MAX as usize / ACC || m.row.len() > u32::MAX as usize / 9 {
        return Err(too_large("transfer S", (m.val.len() * 4) as u64));
    }
    let maxs = m.val.iter().fold(0.0f64, |a, &v| a.max(f64::from(v).abs()));
    let exp = exponent(maxs);
    let scale = 2f64.powi(-exp);
    gpu.scoped(|| {
        let pipeline = gpu.pipeline("wavelux transfer", SHADER, "main");
        let e = gpu.buffer(
            "wavelux transfer e",
            e_bytes,
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        );
        let active = gpu.buffer(
            "wavelux transfer active",
            (cols * 4) as u64,
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        );
        let staging = gpu.buffer(
            "wavelux transfer staging",
            (rows * ACC * 4) as u64,
            wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        );
        let blocks = m.blocks();
        let stride = cols + 1;
        let ptr_bytes = (stride * 4) as u64;
        let mut chunks = Vec::new();
        let mut b0 = 0;
        while b0 < blocks {
            // Grow the chunk while every buffer fits one binding.
            let start = m.col_ptr[b0 * stride] as usize;
            let mut b1 = b0;
            while b1 < blocks {
                let end = m.col_ptr[b1 * stride + cols] as usize;
                let nb = (b1 + 1 - b0) as u64;
                let nrows = (((b1 + 1) * br).min(rows) - b0 * br) as u64;
                let fits = nb * ptr_bytes <= limit
                    && ((end - start) * 9 * 4) as u64 <= limit
                    && nrows * (ACC * 4) as u64 <= limit
                    && nb < 65535 * 65535;
                if !fits {
                    break;
                }
                b1 += 1;
            }
            if b1 == b0 {
                let end = m.col_ptr[b0 * stride + cols] as usize;
                let need = (ptr_bytes)
                    .max(((end - start) * 36) as u64)
                    .max((br * ACC * 4) as u64);
                return Err(too_large("one block of S", need));
            }
            let end = m.col_ptr[(b1 - 1) * stride + cols] as usize;
            let (row0, row1) = (b0 * br, (b1 * br).min(rows));
            let ptr: Vec<u32> = m.col_ptr[b0 * stride..b1 * stride]
                .iter()
                .map(|&q| q - start as u32)
                .collect();
            let rel: Vec<u32> = m.row[start..end].iter().map(|&r| r - row0 as u32).collect();
            let vals: Vec<f32> = m.val[start * 9..end * 9]
                .iter()
                .map(|&v| (f64::from(v) * scale) as f32)
                .collect();
            chunks.push(Chunk::new(
                gpu,
                &pipeline,
                [&ptr, &rel],
                &vals,
                [&e, &active],
                (b1 - b0, row0, row1 - row0),
            ));
            b0 = b1;
        }
        Ok(GpuPreparedTransfer {
            rows,
            cols,
            block_rows: br,
            exp,
            chunks,
            e,
            active,
            staging,
            pipeline,
            lock: Mutex::new(()),
        })
    })
}

impl Chunk {
    fn new(
        gpu: &Gpu,
        pipeline: &wgpu::ComputePipeline,
        [ptr, rel]: [&[u32]; 2],
        vals: &[f32],
        [e, active]: [&wgpu::Buffer; 2],
        (blocks, row0, rows): (usize, usize, usize),
    ) -> Chunk {
        let params = gpu.buffer(
            "wavelux transfer params",
            32,
            wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        );
        let ptr = gpu.storage("wavelux transfer col_ptr", bytemuck::cast_slice(ptr), false);
        let rel = gpu.storage("wavelux transfer row", bytemuck::cast_slice(rel), false);
        let val = gpu.storage("wavelux transfer val", bytemuck::cast_slice(vals), false);
        let acc = gpu.buffer(
            "wavelux transfer acc",
            (rows * ACC * 4) as u64,
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        );
        let layout = pipeline.get_bind_group_layout(0);
        let entries: Vec<wgpu::BindGroupEntry<'_>> = [&params, &ptr, &rel, &val, e, active, &acc]
            .iter()
            .enumerate()
            .map(|(i, b)| wgpu::BindGroupEntry {
                binding: i as u32,
                resource: b.as_entire_binding(),
            })
            .collect();
        let bind = gpu.device().create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("wavelux transfer"),
            layout: &layout,
            entries: &entries,
        });
        Chunk {
            params,
            bind,
            acc,
            blocks: blocks as u32,
            row0,
            rows,
        }
    }
}

fn apply(gpu: &Gpu, p: &GpuPreparedTransfer, e: &[f32], out: &mut [f32]) -> Result<(), GpuError> {
    // Active senders: the CPU backend's rule (any of the three values non-zero).
    let active: Vec<u32> = (0..p.cols)
        .filter(|&j| e[j * 3] != 0.0 || e[j * 3 + 1] != 0.0 || e[j * 3 + 2] != 0.0)
        .map(|j| j as u32)
        .collect();
    if let Some(j) = e.iter().position(|v| !v.is_finite()) {
        return Err(gpu.fail(format!(
            "transfer product: e of sender {} is not finite ({})",
            j / 3,
            e[j]
        )));
    }
    let maxe = e.iter().fold(0.0f64, |a, &v| a.max(f64::from(v).abs()));
    let be = exponent(maxe);
    let es: Vec<f32> = e
        .iter()
        .map(|&v| (f64::from(v) * 2f64.powi(-be)) as f32)
        .collect();
    let words = gpu.scoped(|| {
        let q = gpu.queue();
        if !es.is_empty() {
            q.write_buffer(&p.e, 0, bytemuck::cast_slice(&es));
        }
        if !active.is_empty() {
            q.write_buffer(&p.active, 0, bytemuck::cast_slice(&active));
        }
        let mut enc = gpu
            .device()
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("wavelux transfer"),
            });
        for ch in &p.chunks {
            let (gx, _) = dispatch_dims(ch.blocks);
            let params = [
                ch.blocks,
                p.block_rows as u32,
                ch.rows as u32,
                p.cols as u32,
                active.len() as u32,
                gx,
                0,
                0,
            ];
            q.write_buffer(&ch.params, 0, bytemuck::cast_slice(&params));
        }
        {
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("wavelux transfer"),
                timestamp_writes: None,
            });
            pass.set_pipeline(&p.pipeline);
            for ch in &p.chunks {
                let (gx, gy) = dispatch_dims(ch.blocks);
                pass.set_bind_group(0, &ch.bind, &[]);
                pass.dispatch_workgroups(gx, gy, 1);
            }
        }
        for ch in &p.chunks {
            let n = (ch.rows * ACC * 4) as u64;
            if n > 0 {
                enc.copy_buffer_to_buffer(&ch.acc, 0, &p.staging, (ch.row0 * ACC * 4) as u64, n);
            }
        }
        gpu.submit_and_read(enc, &p.staging, (p.rows * ACC * 4) as u64)
    })?;
    let words: Vec<f32> = words.into_iter().map(f32::from_bits).collect();
    let s = 2f64.powi(p.exp + be);
    for (i, o) in out.chunks_mut(9).enumerate() {
        let a = &words[i * ACC..(i + 1) * ACC];
        for (k, v) in o.iter_mut().enumerate() {
            *v = ((f64::from(a[k]) + f64::from(a[k + 9])) * s) as f32;
        }
    }
    Ok(())
}
