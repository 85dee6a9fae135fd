//! The runtime transfer product `i = S·e` behind a backend trait (Meshless §3.3:
//! "processing one sender at a time rather than one receiver at a time means that
//! links that carry no energy in the current frame can be skipped").
//!
//! # The f32 layout ([`PackedTransfer`], shared by every backend)
//! Receivers are cut into blocks of `block_rows` consecutive rows; each block stores
//! its part of `S` in compressed sparse *columns*: for block `b` and sender `j`, the
//! entries are `col_ptr[b·(cols + 1) + j] .. col_ptr[b·(cols + 1) + j + 1]` of `row`
//! (global receiver index, `u32`) and `val` (nine `f32` per entry, channel-major
//! `[r.x, r.y, r.z, g.x, g.y, g.z, b.x, b.y, b.z]`). Within a column, entries are in
//! increasing row order. Inputs are `e`: three `f32` per sender (RGB); outputs `i`:
//! nine `f32` per receiver. A sender whose three values are all zero is inactive and
//! its columns are never read.
//!
//! [`CpuBackend`] runs the blocks in parallel (rayon), visits the active senders in
//! increasing order and accumulates each block in f64 before rounding to f32: the
//! result is the same for any thread count and equals the f64 product to f32
//! rounding. `wavelux-gpu` implements the trait on the same layout.

use rayon::prelude::*;

use crate::matrix::TransferMatrix;

/// Default receivers per block.
pub const BLOCK_ROWS: usize = 2048;

/// `S` in the f32 row-block CSC layout of the module docs.
#[derive(Debug, Clone, PartialEq)]
pub struct PackedTransfer {
    /// Receivers (rows).
    pub rows: usize,
    /// Senders (columns).
    pub cols: usize,
    /// Receivers per block.
    pub block_rows: usize,
    /// Per block, `cols + 1` offsets into `row`/`val` (absolute).
    pub col_ptr: Vec<u32>,
    /// Global receiver index of each entry.
    pub row: Vec<u32>,
    /// Nine `f32` per entry.
    pub val: Vec<f32>,
}

impl PackedTransfer {
    /// Packs `s` with `block_rows` receivers per block (at least 1).
    pub fn pack(s: &TransferMatrix, block_rows: usize) -> Self {
        let block_rows = block_rows.max(1);
        let (rows, cols) = (s.rows(), s.cols());
        let blocks = rows.div_ceil(block_rows);
        let mut col_ptr = Vec::with_capacity(blocks * (cols + 1));
        let mut row = Vec::with_capacity(s.nnz());
        let mut val = Vec::with_capacity(s.nnz() * 9);
        for b in 0..blocks {
            let (lo, hi) = (b * block_rows, ((b + 1) * block_rows).min(rows));
            // Count per column, then fill in row order.
            let mut count = vec![0u32; cols + 1];
            for i in lo..hi {
                for &j in s.row(i).0 {
                    count[j as usize + 1] += 1;
                }
            }
            let base = row.len() as u32;
            let mut start = vec![0u32; cols + 1];
            for j in 0..cols {
                start[j + 1] = start[j] + count[j + 1];
            }
            col_ptr.extend(start.iter().map(|s| s + base));
            let n = start[cols] as usize;
            let mut brow = vec![0u32; n];
            let mut bval = vec![0f32; n * 9];
            let mut fill = start.clone();
            for i in lo..hi {
                let (c, v) = s.row(i);
                for (j, l) in c.iter().zip(v) {
                    let k = fill[*j as usize] as usize;
                    fill[*j as usize] += 1;
                    brow[k] = i as u32;
                    for q in 0..9 {
                        bval[k * 9 + q] = l[q] as f32;
                    }
                }
            }
            row.extend(brow);
            val.extend(bval);
        }
        Self {
            rows,
            cols,
            block_rows,
            col_ptr,
            row,
            val,
        }
    }

    /// Number of blocks.
    pub fn blocks(&self) -> usize {
        self.rows.div_ceil(self.block_rows)
    }

    /// Heap bytes.
    pub fn bytes(&self) -> usize {
        self.col_ptr.len() * 4 + self.row.len() * 4 + self.val.len() * 4
    }
}

/// A device (or the CPU) that applies a packed transfer matrix.
pub trait TransferBackend: Sync {
    /// The backend's form of a prepared matrix (device buffers, or the packed arrays).
    type Prepared: Send + Sync;
    /// The backend's error.
    type Error: std::error::Error + Send + Sync + 'static;
    /// A short name for reports (`cpu`, `wgpu:<adapter>`).
    fn name(&self) -> String;
    /// Packs / uploads `S` once.
    ///
    /// # Errors
    /// Backend-specific (e.g. a device out of memory).
    fn prepare(&self, s: &TransferMatrix) -> Result<Self::Prepared, Self::Error>;
    /// `out = S·e`: `e` three `f32` per sender (inactive senders all zero), `out` nine
    /// `f32` per receiver (overwritten).
    ///
    /// # Errors
    /// Backend-specific; lengths are checked by the caller.
    fn apply(
        &self,
        prepared: &Self::Prepared,
        e: &[f32],
        out: &mut [f32],
    ) -> Result<(), Self::Error>;
}

/// The CPU backend (module docs).
#[derive(Debug, Clone, Copy, Default)]
pub struct CpuBackend;

/// The CPU backend never fails.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("unreachable CPU backend error")]
pub struct NoError;

impl TransferBackend for CpuBackend {
    type Prepared = PackedTransfer;
    type Error = NoError;

    fn name(&self) -> String {
        "cpu".into()
    }

    fn prepare(&self, s: &TransferMatrix) -> Result<PackedTransfer, NoError> {
        Ok(PackedTransfer::pack(s, BLOCK_ROWS))
    }

    fn apply(&self, p: &PackedTransfer, e: &[f32], out: &mut [f32]) -> Result<(), NoError> {
        let active: Vec<u32> = (0..p.cols as u32)
            .filter(|&j| {
                let j = j as usize;
                e[j * 3] != 0.0 || e[j * 3 + 1] != 0.0 || e[j * 3 + 2] != 0.0
            })
            .collect();
        let stride = p.cols + 1;
        out.par_chunks_mut(p.block_rows * 9)
            .enumerate()
            .for_each_init(Vec::new, |acc: &mut Vec<f64>, (b, chunk)| {
                acc.clear();
                acc.resize(chunk.len(), 0.0);
                let lo = b * p.block_rows;
                let ptr = &p.col_ptr[b * stride..(b + 1) * stride];
                for &j in &active {
                    let j = j as usize;
                    let (s, t) = (ptr[j] as usize, ptr[j + 1] as usize);
                    if s == t {
                        continue;
                    }
                    let ej = [
                        f64::from(e[j * 3]),
                        f64::from(e[j * 3 + 1]),
                        f64::from(e[j * 3 + 2]),
                    ];
                    for k in s..t {
                        let r = (p.row[k] as usize - lo) * 9;
                        let v = &p.val[k * 9..k * 9 + 9];
                        for c in 0..3 {
                            for a in 0..3 {
                                acc[r + c * 3 + a] += f64::from(v[c * 3 + a]) * ej[c];
                            }
                        }
                    }
                }
                for (o, a) in chunk.iter_mut().zip(acc.iter()) {
                    *o = *a as f32;
                }
            });
        Ok(())
    }
}
