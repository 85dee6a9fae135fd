//! The standard wavelet decomposition of the hierarchical system (Ziegler §2.2.3,
//! "standard vs. non-standard"; Glossy §3.5; Beylkin, Coifman and Rokhlin 1991).
//!
//! [`crate::system`] realises the *non-standard* operator: links join scaling blocks of
//! quadtree nodes, and every application pulls leaf coefficients to all nodes, gathers
//! over links and pushes back down (Ziegler eq. (2.15)). The *standard* form expresses
//! the same operator — the same links and transfer blocks — in one orthonormal basis
//! per patch, the patch's **tree wavelet basis**: the `k²` scaling functions of the
//! root plus, for every internal node, the `3k²` tensor wavelets `ψφ, φψ, ψψ` of its
//! cell (`wavelux-mra` Alpert filters). Its dimension equals the number of leaf
//! coefficients. Unknowns are the radiosity coefficients in that basis; the operator
//! is a block-sparse matrix assembled once, iterations are plain sparse
//! matrix–vector products (no push/pull), and there is one decomposition at the start
//! and one reconstruction at the end (Ziegler §2.2.3, the paragraph after eq. (2.15)).
//!
//! # Assembly
//!
//! With `Q` the (orthogonal, per patch) map from leaf coefficients to tree wavelet
//! coefficients, the standard matrix is `Q K Qᵀ`, `K = D_ρ P_down L P_up` (see
//! [`crate::system`]). The scaling block at a node `X` depends only on the root
//! scaling block and the wavelet blocks of the *strict ancestors* of `X` (the wavelets
//! of `X` and below are orthogonal to `X`'s scaling functions):
//! `s_X = M_cᵀ s_P + W_cᵀ d_P` for `X` child `c` of `P`. So a link `R ← E` with block
//! `T` contributes `C_{R,A}ᵀ T C_{E,B}` to every pair `(A, B)` of a root-scaling or
//! strict-ancestor wavelet block `A` of `R` and `B` of `E`: `(level R + 1)(level E + 1)`
//! blocks, Glossy's `O(n log n)` against the non-standard `O(n)`. We assemble in two
//! passes that merge shared ancestors: per receiver node, emitter-side blocks are
//! lifted from the deepest node up (`T ↦ T M_cᵀ` to the parent's scaling,
//! `T ↦ T W_cᵀ` to its wavelets); then per column block, receiver-side rows likewise
//! (`X ↦ M_c X`, `X ↦ W_c X`). Both passes run in parallel (rayon) over independent
//! groups and merge in a fixed order, so the matrix does not depend on thread count.
//!
//! The reflectance multiplies rows per channel at application time (it is constant per
//! patch, so it commutes with `Q`); the stored matrix is the channel-independent
//! irradiance operator `Q P_down L P_up Qᵀ`, whose entries [`StandardSystem::nonzeros`]
//! and [`StandardSystem::nonzeros_above`] count.
//!
//! In exact arithmetic every linear method produces the same iterates as on the
//! non-standard system (`Q` is orthogonal and maps the emission and the initial guess),
//! except Gauss–Seidel, which here is the point Gauss–Seidel of `wavelux-linear` over
//! wavelet coefficients (same fixed point, different sweeps).

use std::collections::BTreeMap;
use std::time::Instant;

use rayon::prelude::*;
use wavelux_linear::{
    Convergence, IdentityMinus, Operator, SolverOptions, Unsupported, cgnr, gauss_seidel, gmres,
    picard,
};
use wavelux_mra::Alpert;

use crate::basis::TreeBasis;
use crate::error::SolverError;
use crate::solution::{Solution, Statistics};
use crate::system::System;
use crate::{LinearMethod, Prepared};

/// Which wavelet decomposition of the linked operator the solver iterates on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[non_exhaustive]
pub enum Decomposition {
    /// Scaling blocks per level with push/pull (Ziegler eq. (2.15)); the default.
    #[default]
    NonStandard,
    /// The per-patch tree wavelet basis, one assembled sparse matrix ([`StandardSystem`]).
    Standard,
}

const NONE: u32 = u32::MAX;

/// Dense blocks keyed by basis block (or node), in key order.
type Keyed = Vec<(u32, Vec<f64>)>;

/// Two-scale data of the 2D tree basis: scaling (`M_c`, `n × n`) and wavelet (`W_c`,
/// `3n × n`) matrices per child position `c = cy·2 + cx`, both `[parent_row * n +
/// child_function]`.
#[derive(Debug, Clone)]
struct TwoScale {
    m: [Vec<f64>; 4],
    w: [Vec<f64>; 4],
}

impl TwoScale {
    fn new(basis: &TreeBasis) -> Result<Self, SolverError> {
        let k = basis.k();
        let n = k * k;
        let mra = Alpert::new(k).map_err(|e| SolverError::Dependency {
            what: "mra",
            message: e.to_string(),
        })?;
        let (h, g) = (mra.scaling_block(), mra.wavelet_block());
        let m: [Vec<f64>; 4] = std::array::from_fn(|c| basis.child_matrix(c).to_vec());
        let mut w: [Vec<f64>; 4] = std::array::from_fn(|_| vec![0.0; 3 * n * n]);
        for (c, wc) in w.iter_mut().enumerate() {
            let (cx, cy) = (c % 2, c / 2);
            for t in 0..3 {
                // t = 0: ψ(s)φ(t), 1: φ(s)ψ(t), 2: ψ(s)ψ(t).
                let fx = if t == 1 { h } else { g };
                let fy = if t == 0 { h } else { g };
                for a2 in 0..k {
                    for a1 in 0..k {
                        for b2 in 0..k {
                            for b1 in 0..k {
                                wc[(t * n + a2 * k + a1) * n + b2 * k + b1] =
                                    fx[a1 * 2 * k + cx * k + b1] * fy[a2 * 2 * k + cy * k + b2];
                            }
                        }
                    }
                }
            }
            // The tree basis' scaling matrices must come from the same filters.
            for a2 in 0..k {
                for a1 in 0..k {
                    for b2 in 0..k {
                        for b1 in 0..k {
                            let v = h[a1 * 2 * k + cx * k + b1] * h[a2 * 2 * k + cy * k + b2];
                            if (m[c][(a2 * k + a1) * n + b2 * k + b1] - v).abs() > 1e-12 {
                                return Err(SolverError::Dependency {
                                    what: "mra",
                                    message: "tree basis two-scale matrices differ from the \
                                              Alpert scaling filters"
                                        .into(),
                                });
                            }
                        }
                    }
                }
            }
        }
        Ok(Self { m, w })
    }
}

/// A block of the tree wavelet basis: the root scaling block of a patch (`n`
/// coefficients) or the wavelet block of an internal node (`3n`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct BlockInfo {
    /// Node of the hierarchy.
    node: u32,
    /// Offset in the coefficient vector.
    offset: usize,
    /// Number of coefficients (`n` or `3n`).
    size: usize,
    /// Patch.
    patch: u32,
}

/// The standard decomposition of a [`System`]: tree wavelet coefficients per patch and
/// the block-sparse operator over them (module docs).
#[derive(Debug, Clone)]
pub struct StandardSystem<'a> {
    sys: &'a System,
    ts: TwoScale,
    /// Blocks, ordered by node (roots' scaling before their wavelets).
    blocks: Vec<BlockInfo>,
    /// Root scaling block of each node (`NONE` unless a root).
    scal_block: Vec<u32>,
    /// Wavelet block of each node (`NONE` for leaves).
    wav_block: Vec<u32>,
    /// Block of every coefficient.
    coeff_block: Vec<u32>,
    /// Reflectance per patch.
    patch_rho: Vec<[f64; 3]>,
    /// CSR over row blocks: stored blocks `row_ptr[r]..row_ptr[r+1]`.
    row_ptr: Vec<usize>,
    /// Column block of each stored block.
    col: Vec<u32>,
    /// Row block of each stored block.
    row: Vec<u32>,
    /// Value offset of each stored block (`size_row × size_col`, row-major).
    val_off: Vec<usize>,
    /// Values of all stored blocks.
    vals: Vec<f64>,
    /// Stored blocks grouped by column block (CSR over `col_ptr`).
    by_col: Vec<u32>,
    col_ptr: Vec<usize>,
}

/// `acc[r][c] += Σ_j a[r][j] b[c][j]` (`a`: rows × inner, `b`: cols × inner).
fn add_a_bt(acc: &mut [f64], a: &[f64], b: &[f64], rows: usize, cols: usize, inner: usize) {
    for r in 0..rows {
        let ar = &a[r * inner..][..inner];
        for c in 0..cols {
            let bc = &b[c * inner..][..inner];
            let mut s = 0.0;
            for j in 0..inner {
                s += ar[j] * bc[j];
            }
            acc[r * cols + c] += s;
        }
    }
}

/// `acc[r][c] += Σ_j a[r][j] b[j][c]` (`a`: rows × inner, `b`: inner × cols).
fn add_a_b(acc: &mut [f64], a: &[f64], b: &[f64], rows: usize, cols: usize, inner: usize) {
    for r in 0..rows {
        for j in 0..inner {
            let arj = a[r * inner + j];
            if arj == 0.0 {
                continue;
            }
            let bj = &b[j * cols..][..cols];
            for (o, &v) in acc[r * cols..][..cols].iter_mut().zip(bj) {
                *o += arj * v;
            }
        }
    }
}

/// `out[r] += Σ_j x[r][j] w[j]` (`x`: `out.len() × w.len()`, row-major).
fn add_matvec(out: &mut [f64], x: &[f64], w: &[f64]) {
    for (o, row) in out.iter_mut().zip(x.chunks_exact(w.len())) {
        *o += row.iter().zip(w).map(|(a, b)| a * b).sum::<f64>();
    }
}

impl<'a> StandardSystem<'a> {
    /// Decomposes `system` (built with `basis`) into the standard form and assembles
    /// its operator.
    ///
    /// # Errors
    /// [`SolverError::UnsupportedBasis`] if `basis` does not match the system's block
    /// size `n = k²`; [`SolverError::Dependency`] if the basis' two-scale matrices do
    /// not come from the Alpert filters; [`SolverError::InvalidScene`] if the
    /// reflectance varies within a patch (it must commute with the per-patch basis).
    pub fn from_system(system: &'a System, basis: &TreeBasis) -> Result<Self, SolverError> {
        let h = &system.h;
        let n = h.n;
        if basis.n() != n {
            return Err(SolverError::UnsupportedBasis(format!(
                "{} with {} functions per node for a system with {n}",
                basis.kind().name(),
                basis.n()
            )));
        }
        let ts = TwoScale::new(basis)?;
        let n_patches = h.roots.len();
        let mut patch_rho: Vec<Option<[f64; 3]>> = vec![None; n_patches];
        for (l, &i) in h.leaves.iter().enumerate() {
            let p = h.keys[i as usize].patch as usize;
            let rho = system.leaf_rho[l];
            match patch_rho[p] {
                None => patch_rho[p] = Some(rho),
                Some(r) if r != rho => {
                    return Err(SolverError::InvalidScene(format!(
                        "reflectance varies within patch {p}; the standard decomposition \
                         needs it constant per patch"
                    )));
                }
                Some(_) => {}
            }
        }
        let patch_rho: Vec<[f64; 3]> = patch_rho
            .into_iter()
            .map(|r| r.unwrap_or([0.0; 3]))
            .collect();
        let nn = h.node_count();
        let mut blocks = Vec::new();
        let mut scal_block = vec![NONE; nn];
        let mut wav_block = vec![NONE; nn];
        let mut offset = 0;
        for i in 0..nn {
            let patch = h.keys[i].patch;
            if h.parent[i] == NONE {
                scal_block[i] = blocks.len() as u32;
                blocks.push(BlockInfo {
                    node: i as u32,
                    offset,
                    size: n,
                    patch,
                });
                offset += n;
            }
            if h.children[i][0] != NONE {
                wav_block[i] = blocks.len() as u32;
                blocks.push(BlockInfo {
                    node: i as u32,
                    offset,
                    size: 3 * n,
                    patch,
                });
                offset += 3 * n;
            }
        }
        debug_assert_eq!(offset, system.dim());
        let mut coeff_block = vec![0u32; offset];
        for (b, info) in blocks.iter().enumerate() {
            coeff_block[info.offset..info.offset + info.size].fill(b as u32);
        }
        let mut s = Self {
            sys: system,
            ts,
            blocks,
            scal_block,
            wav_block,
            coeff_block,
            patch_rho,
            row_ptr: Vec::new(),
            col: Vec::new(),
            row: Vec::new(),
            val_off: Vec::new(),
            vals: Vec::new(),
            by_col: Vec::new(),
            col_ptr: Vec::new(),
        };
        s.assemble();
        Ok(s)
    }

    /// Lifts blocks attached to scaling blocks of nodes up to their root: `pending`
    /// holds, per node, a block whose one side is that node's scaling coefficients;
    /// `lift(c, x, node_scal, node_wav)` moves `x` (of child position `c`) into the
    /// parent's scaling block and wavelet block. Returns the final blocks keyed by
    /// basis block, in block order.
    fn lift_to_roots(
        &self,
        mut pending: BTreeMap<u32, Vec<f64>>,
        scal_len: usize,
        wav_len: usize,
        lift: impl Fn(usize, &[f64], &mut [f64], &mut [f64]),
    ) -> Keyed {
        let h = &self.sys.h;
        let mut done: BTreeMap<u32, Vec<f64>> = BTreeMap::new();
        // Children have larger node indices than their parents (level order), so the
        // deepest pending node is always complete when popped.
        while let Some((x_node, x)) = pending.pop_last() {
            let p = h.parent[x_node as usize];
            if p == NONE {
                done.insert(self.scal_block[x_node as usize], x);
                continue;
            }
            let c = h.keys[x_node as usize].child_pos();
            let wb = self.wav_block[p as usize];
            let mut wav = done.remove(&wb).unwrap_or_else(|| vec![0.0; wav_len]);
            let scal = pending.entry(p).or_insert_with(|| vec![0.0; scal_len]);
            lift(c, &x, scal, &mut wav);
            done.insert(wb, wav);
        }
        done.into_iter().collect()
    }

    fn assemble(&mut self) {
        let h = &self.sys.h;
        let n = h.n;
        let nn = h.node_count();
        let ts = &self.ts;
        // Pass 1 (emitter side), per receiver node: rows are R's scaling functions.
        let receivers: Vec<usize> = (0..nn)
            .filter(|&r| h.recv_offsets[r + 1] > h.recv_offsets[r])
            .collect();
        let pass1: Vec<(u32, Keyed)> = receivers
            .par_iter()
            .map(|&r| {
                let mut pending: BTreeMap<u32, Vec<f64>> = BTreeMap::new();
                for l in h.recv_offsets[r]..h.recv_offsets[r + 1] {
                    let e = h.link_emitter[l];
                    let blk = &h.blocks[l * n * n..][..n * n];
                    let acc = pending.entry(e).or_insert_with(|| vec![0.0; n * n]);
                    for (a, b) in acc.iter_mut().zip(blk) {
                        *a += b;
                    }
                }
                // s_E = M_cᵀ s_P + W_cᵀ d_P: T s_E = (T M_cᵀ) s_P + (T W_cᵀ) d_P.
                let cols = self.lift_to_roots(pending, n * n, n * 3 * n, |c, x, scal, wav| {
                    add_a_bt(scal, x, &ts.m[c], n, n, n);
                    add_a_bt(wav, x, &ts.w[c], n, 3 * n, n);
                });
                (r as u32, cols)
            })
            .collect();
        // Regroup by column block.
        let mut by_col: BTreeMap<u32, BTreeMap<u32, Vec<f64>>> = BTreeMap::new();
        for (r, cols) in pass1 {
            for (cb, x) in cols {
                by_col.entry(cb).or_default().insert(r, x);
            }
        }
        // Pass 2 (receiver side), per column block B: y_R ↦ M_c y_R (parent scaling),
        // W_c y_R (parent wavelets).
        let by_col: Vec<(u32, BTreeMap<u32, Vec<f64>>)> = by_col.into_iter().collect();
        let pass2: Vec<(u32, Keyed)> = by_col
            .into_par_iter()
            .map(|(cb, pending)| {
                let sb = self.blocks[cb as usize].size;
                let rows = self.lift_to_roots(pending, n * sb, 3 * n * sb, |c, x, scal, wav| {
                    add_a_b(scal, &ts.m[c], x, n, sb, n);
                    add_a_b(wav, &ts.w[c], x, 3 * n, sb, n);
                });
                (cb, rows)
            })
            .collect();
        let mut entries: Vec<(u32, u32, Vec<f64>)> = pass2
            .into_iter()
            .flat_map(|(cb, rows)| rows.into_iter().map(move |(rb, x)| (rb, cb, x)))
            .collect();
        entries.sort_unstable_by_key(|e| (e.0, e.1));
        let nb = self.blocks.len();
        let mut row_ptr = vec![0usize; nb + 1];
        let mut col = Vec::with_capacity(entries.len());
        let mut row = Vec::with_capacity(entries.len());
        let mut val_off = Vec::with_capacity(entries.len());
        let mut vals = Vec::new();
        for (rb, cb, x) in entries {
            row_ptr[rb as usize + 1] += 1;
            row.push(rb);
            col.push(cb);
            val_off.push(vals.len());
            vals.extend_from_slice(&x);
        }
        for i in 0..nb {
            row_ptr[i + 1] += row_ptr[i];
        }
        let mut order: Vec<u32> = (0..col.len() as u32).collect();
        order.sort_by_key(|&s| col[s as usize]);
        let mut col_ptr = vec![0usize; nb + 1];
        for &s in &order {
            col_ptr[col[s as usize] as usize + 1] += 1;
        }
        for i in 0..nb {
            col_ptr[i + 1] += col_ptr[i];
        }
        self.row_ptr = row_ptr;
        self.col = col;
        self.row = row;
        self.val_off = val_off;
        self.vals = vals;
        self.by_col = order;
        self.col_ptr = col_ptr;
    }

    /// Number of unknowns per channel (equals [`System::dim`]).
    pub fn dim(&self) -> usize {
        self.coeff_block.len()
    }

    /// The non-standard system this decomposes.
    pub fn system(&self) -> &System {
        self.sys
    }

    /// Stored entries of the operator (dense blocks `(A, B)` that some link reaches).
    pub fn stored(&self) -> usize {
        self.vals.len()
    }

    /// Stored blocks `(A, B)`.
    pub fn stored_blocks(&self) -> usize {
        self.col.len()
    }

    /// Entries of the channel-independent standard operator `Q P_down L P_up Qᵀ` that
    /// are not exactly zero.
    pub fn nonzeros(&self) -> usize {
        self.vals.iter().filter(|v| **v != 0.0).count()
    }

    /// Entries with `|v| > rel_tol · max |v|` (the sparsity question of Glossy §3.5).
    ///
    /// # Errors
    /// [`SolverError::InvalidConfig`] unless `rel_tol` is finite and `≥ 0`.
    pub fn nonzeros_above(&self, rel_tol: f64) -> Result<usize, SolverError> {
        count_above(&self.vals, rel_tol)
    }

    /// Tree wavelet coefficients of leaf coefficients `x` (one decomposition, `Q x`).
    ///
    /// # Errors
    /// [`SolverError::OutOfRange`] if `x.len() != dim()`.
    pub fn decompose(&self, x: &[f64]) -> Result<Vec<f64>, SolverError> {
        self.check_len("leaf vector", x.len())?;
        let h = &self.sys.h;
        let n = h.n;
        let mut nodes = vec![0.0; h.node_count() * n];
        self.sys.pull_from_leaves(x, &mut nodes);
        let mut w = vec![0.0; self.dim()];
        let ts = &self.ts;
        // Each block's coefficients are written by exactly one task.
        let parts: Vec<(usize, Vec<f64>)> = self
            .blocks
            .par_iter()
            .map(|b| {
                let i = b.node as usize;
                let out = if b.size == n {
                    nodes[i * n..][..n].to_vec()
                } else {
                    let mut d = vec![0.0; 3 * n];
                    for (c, &ci) in h.children[i].iter().enumerate() {
                        add_matvec(&mut d, &ts.w[c], &nodes[ci as usize * n..][..n]);
                    }
                    d
                };
                (b.offset, out)
            })
            .collect();
        for (off, v) in parts {
            w[off..off + v.len()].copy_from_slice(&v);
        }
        Ok(w)
    }

    /// Leaf coefficients of tree wavelet coefficients `w` (one reconstruction, `Qᵀ w`).
    ///
    /// # Errors
    /// [`SolverError::OutOfRange`] if `w.len() != dim()`.
    pub fn reconstruct(&self, w: &[f64]) -> Result<Vec<f64>, SolverError> {
        self.check_len("wavelet vector", w.len())?;
        let h = &self.sys.h;
        let n = h.n;
        let ts = &self.ts;
        let mut nodes = vec![0.0; h.node_count() * n];
        for &r in &h.roots {
            let off = self.blocks[self.scal_block[r as usize] as usize].offset;
            nodes[r as usize * n..][..n].copy_from_slice(&w[off..off + n]);
        }
        let ls = &h.level_start;
        for l in 1..ls.len() - 1 {
            let (lo, hi) = nodes.split_at_mut(ls[l] * n);
            hi[..(ls[l + 1] - ls[l]) * n]
                .par_chunks_mut(n)
                .enumerate()
                .for_each(|(j, out)| {
                    let i = ls[l] + j;
                    let p = h.parent[i] as usize;
                    let c = h.keys[i].child_pos();
                    let d = &w[self.blocks[self.wav_block[p] as usize].offset..][..3 * n];
                    // s_X = M_cᵀ s_P + W_cᵀ d_P.
                    add_a_b(out, &lo[p * n..][..n], &ts.m[c], 1, n, n);
                    add_a_b(out, d, &ts.w[c], 1, n, 3 * n);
                });
        }
        let mut x = vec![0.0; self.dim()];
        for (l, &i) in h.leaves.iter().enumerate() {
            x[l * n..][..n].copy_from_slice(&nodes[i as usize * n..][..n]);
        }
        Ok(x)
    }

    fn check_len(&self, what: &'static str, len: usize) -> Result<(), SolverError> {
        if len != self.dim() {
            return Err(SolverError::OutOfRange {
                what,
                index: len,
                len: self.dim(),
            });
        }
        Ok(())
    }

    /// `y = G w` with the channel-independent irradiance operator (no reflectance),
    /// rows scaled by `row_scale(patch)`.
    fn apply_scaled(&self, w: &[f64], y: &mut [f64], row_scale: impl Fn(usize) -> f64 + Sync) {
        self.split_blocks(y)
            .into_par_iter()
            .enumerate()
            .for_each(|(rb, out)| {
                let info = &self.blocks[rb];
                out.fill(0.0);
                for s in self.row_ptr[rb]..self.row_ptr[rb + 1] {
                    let cb = &self.blocks[self.col[s] as usize];
                    let x = &self.vals[self.val_off[s]..][..info.size * cb.size];
                    add_matvec(out, x, &w[cb.offset..][..cb.size]);
                }
                let f = row_scale(info.patch as usize);
                out.iter_mut().for_each(|v| *v *= f);
            });
    }

    /// `y` cut into the coefficient ranges of the blocks, in block order (the blocks
    /// tile `0..dim()` contiguously).
    fn split_blocks<'y>(&self, y: &'y mut [f64]) -> Vec<&'y mut [f64]> {
        let mut rest = y;
        let mut out = Vec::with_capacity(self.blocks.len());
        for b in &self.blocks {
            let (head, tail) = std::mem::take(&mut rest).split_at_mut(b.size);
            out.push(head);
            rest = tail;
        }
        out
    }

    /// `y = K w` for channel `ch` in tree wavelet coefficients (`ρ` per patch times
    /// the stored operator).
    ///
    /// # Panics
    /// If `w` or `y` is not of length [`Self::dim`] (as [`System::apply_k`]; the
    /// [`Operator`] callers in `wavelux-linear` validate lengths first).
    pub fn apply_k(&self, ch: usize, w: &[f64], y: &mut [f64]) {
        self.apply_scaled(w, y, |p| self.patch_rho[p][ch]);
    }

    /// `y = Kᵀ w` for channel `ch`.
    ///
    /// # Panics
    /// As [`Self::apply_k`].
    pub fn apply_kt(&self, ch: usize, w: &[f64], y: &mut [f64]) {
        self.split_blocks(y)
            .into_par_iter()
            .enumerate()
            .for_each(|(cb, out)| {
                let info = &self.blocks[cb];
                out.fill(0.0);
                for &s in &self.by_col[self.col_ptr[cb]..self.col_ptr[cb + 1]] {
                    let s = s as usize;
                    let rb = &self.blocks[self.row[s] as usize];
                    let x = &self.vals[self.val_off[s]..][..rb.size * info.size];
                    let f = self.patch_rho[rb.patch as usize][ch];
                    let v = &w[rb.offset..][..rb.size];
                    for (r, &vr) in v.iter().enumerate() {
                        let fr = f * vr;
                        if fr == 0.0 {
                            continue;
                        }
                        for (o, &xv) in out.iter_mut().zip(&x[r * info.size..][..info.size]) {
                            *o += fr * xv;
                        }
                    }
                }
            });
    }

    /// The right-hand side of channel `ch` in tree wavelet coefficients: the emission
    /// plus the closure's emitted part ([`System::source`]).
    ///
    /// # Errors
    /// [`SolverError::OutOfRange`] for `ch > 2`.
    pub fn emission(&self, ch: usize) -> Result<Vec<f64>, SolverError> {
        check_channel(ch)?;
        self.decompose(&self.sys.source(ch))
    }

    /// `K` of one channel as a [`wavelux_linear::Operator`] (apply, transpose, rows,
    /// columns, diagonal).
    ///
    /// # Errors
    /// [`SolverError::OutOfRange`] for `ch > 2`.
    pub fn channel(&self, ch: usize) -> Result<StandardOperator<'_, 'a>, SolverError> {
        check_channel(ch)?;
        Ok(StandardOperator { sys: self, ch })
    }

    /// Solves channel `ch` with `method`: decomposes the emission and the initial
    /// guess `x0` (leaf coefficients; default the emission), iterates on the standard
    /// operator and reconstructs the leaf coefficients. `reference` (leaf
    /// coefficients) adds error records. Residual norms equal those of the
    /// non-standard system (`Q` is orthogonal).
    ///
    /// # Errors
    /// [`SolverError::OutOfRange`] for a bad channel or vector length,
    /// [`SolverError::Linear`] if the linear solver fails.
    pub fn solve_channel(
        &self,
        ch: usize,
        method: LinearMethod,
        max_iterations: usize,
        tolerance: f64,
        x0: Option<Vec<f64>>,
        reference: Option<Vec<f64>>,
    ) -> Result<(Vec<f64>, Convergence), SolverError> {
        let b = self.emission(ch)?;
        let w0 = match x0 {
            Some(x) => self.decompose(&x)?,
            None => b.clone(),
        };
        let mut opts = SolverOptions::default()
            .with_max_iterations(max_iterations)
            .with_tolerance(tolerance)
            .with_initial_guess(w0);
        if let Some(r) = reference {
            opts = opts.with_reference(self.decompose(&r)?);
        }
        if let LinearMethod::Gmres { restart } = method {
            opts = opts.with_restart(restart);
        }
        let k = self.channel(ch)?;
        let lin = |e: wavelux_linear::LinearError| SolverError::Linear(e.to_string());
        let solve = match method {
            LinearMethod::Picard => picard(&k, &b, &opts).map_err(lin)?,
            LinearMethod::Gmres { .. } => gmres(&IdentityMinus::new(k), &b, &opts).map_err(lin)?,
            LinearMethod::Cgnr => cgnr(&IdentityMinus::new(k), &b, &opts).map_err(lin)?,
            LinearMethod::GaussSeidel => gauss_seidel(&k, &b, &opts).map_err(lin)?,
        };
        Ok((self.reconstruct(&solve.x)?, solve.history))
    }

    /// Solves every channel (one solve for grey scenes) with the linear method,
    /// iteration limit and tolerance of `prep.config` and returns the same
    /// [`Solution`] as the non-standard path (leaf coefficients reconstructed).
    /// `stats` is completed with the solve's counters and time.
    ///
    /// # Errors
    /// As [`Self::solve_channel`].
    pub fn solve(&self, prep: &Prepared, stats: Statistics) -> Result<Solution, SolverError> {
        let cfg = &prep.config;
        let t0 = Instant::now();
        let grey = prep.is_grey();
        let mut leaf_b: [Vec<f64>; 3] = std::array::from_fn(|_| Vec::new());
        let mut conv = Vec::new();
        let mut stats = stats;
        stats.iterations.clear();
        for ch in 0..if grey { 1 } else { 3 } {
            let (x, c) = self.solve_channel(
                ch,
                cfg.linear_method,
                cfg.max_iterations,
                cfg.tolerance,
                None,
                None,
            )?;
            stats.iterations.push(c.iterations.len() - 1);
            conv.push(c);
            leaf_b[ch] = x;
        }
        if grey {
            leaf_b[1] = leaf_b[0].clone();
            leaf_b[2] = leaf_b[0].clone();
        }
        stats.time_solve += t0.elapsed();
        stats.elements = self.sys.h.node_count();
        stats.leaves = self.sys.h.leaves.len();
        // The closure links (crate::closure) are counted apart, as in the gathering solve.
        let closing = (self.sys.h.links().iter())
            .filter(|l| crate::closure::is_closure_link(&prep.patches.patches, l))
            .count();
        stats.links = self.sys.h.link_count() - closing;
        stats.closure_links = closing;
        let mut sol = Solution::new(
            prep.patches.patches.clone(),
            prep.patches.by_surface.clone(),
            self.sys.clone(),
            prep.basis.clone(),
            leaf_b,
            stats,
            conv,
        );
        sol.measure_escape(prep);
        Ok(sol)
    }
}

fn check_channel(ch: usize) -> Result<(), SolverError> {
    if ch > 2 {
        return Err(SolverError::OutOfRange {
            what: "channel",
            index: ch,
            len: 3,
        });
    }
    Ok(())
}

fn count_above(vals: &[f64], rel_tol: f64) -> Result<usize, SolverError> {
    if !(rel_tol.is_finite() && rel_tol >= 0.0) {
        return Err(SolverError::InvalidConfig {
            field: "rel_tol",
            value: rel_tol.to_string(),
            reason: "must be finite and >= 0",
        });
    }
    let max = vals.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    Ok(vals.iter().filter(|v| v.abs() > rel_tol * max).count())
}

/// Stored transfer-block entries of the non-standard system (`links × n²`), the
/// count the standard operator's [`StandardSystem::stored`] compares with.
pub fn link_coefficients(system: &System) -> usize {
    system.h.blocks.len()
}

/// Transfer-block entries with `|v| > rel_tol · max |v|` (as
/// [`StandardSystem::nonzeros_above`], over the non-standard links).
///
/// # Errors
/// [`SolverError::InvalidConfig`] unless `rel_tol` is finite and `≥ 0`.
pub fn link_coefficients_above(system: &System, rel_tol: f64) -> Result<usize, SolverError> {
    count_above(&system.h.blocks, rel_tol)
}

/// `K` of one channel of a [`StandardSystem`] (see [`StandardSystem::channel`]).
#[derive(Debug, Clone, Copy)]
pub struct StandardOperator<'s, 'a> {
    sys: &'s StandardSystem<'a>,
    ch: usize,
}

impl StandardOperator<'_, '_> {
    /// Writes the `(other index, value)` entries of coefficient `i`'s row (`by_row`)
    /// or column into `out`.
    fn line(&self, i: usize, by_row: bool, out: &mut Vec<(usize, f64)>) {
        let s = self.sys;
        out.clear();
        let b = s.coeff_block[i] as usize;
        let info = s.blocks[b];
        let local = i - info.offset;
        if by_row {
            let f = s.patch_rho[info.patch as usize][self.ch];
            for k in s.row_ptr[b]..s.row_ptr[b + 1] {
                let cb = &s.blocks[s.col[k] as usize];
                let x = &s.vals[s.val_off[k] + local * cb.size..][..cb.size];
                out.extend(x.iter().enumerate().map(|(j, v)| (cb.offset + j, f * v)));
            }
        } else {
            for &k in &s.by_col[s.col_ptr[b]..s.col_ptr[b + 1]] {
                let k = k as usize;
                let rb = &s.blocks[s.row[k] as usize];
                let f = s.patch_rho[rb.patch as usize][self.ch];
                let x = &s.vals[s.val_off[k]..][..rb.size * info.size];
                out.extend((0..rb.size).map(|r| (rb.offset + r, f * x[r * info.size + local])));
            }
        }
    }
}

impl Operator for StandardOperator<'_, '_> {
    fn dim(&self) -> usize {
        self.sys.dim()
    }

    fn apply(&self, x: &[f64], y: &mut [f64]) {
        self.sys.apply_k(self.ch, x, y);
    }

    fn apply_transpose(&self, x: &[f64], y: &mut [f64]) -> Result<(), Unsupported> {
        self.sys.apply_kt(self.ch, x, y);
        Ok(())
    }

    fn row(&self, i: usize, out: &mut Vec<(usize, f64)>) -> Result<(), Unsupported> {
        self.line(i, true, out);
        Ok(())
    }

    fn column(&self, j: usize, out: &mut Vec<(usize, f64)>) -> Result<(), Unsupported> {
        self.line(j, false, out);
        Ok(())
    }

    fn diagonal(&self, out: &mut [f64]) -> Result<(), Unsupported> {
        let s = self.sys;
        out.iter_mut().for_each(|v| *v = 0.0);
        for (b, info) in s.blocks.iter().enumerate() {
            let f = s.patch_rho[info.patch as usize][self.ch];
            for k in s.row_ptr[b]..s.row_ptr[b + 1] {
                if s.col[k] as usize == b {
                    let x = &s.vals[s.val_off[k]..];
                    for a in 0..info.size {
                        out[info.offset + a] = f * x[a * info.size + a];
                    }
                }
            }
        }
        Ok(())
    }
}
