//! Multiple bounces by the truncated Neumann series (Meshless §3.2, "After the
//! refinement stops ..."): `S = Σ_{b ≤ B} S_b`, `S_1 = T`, `S_{b+1} = T₀·Q·S_b`.
//!
//! - `T₀`: the level-0 receiver rows of `T` (the seed computes `T²` and onwards "using
//!   only the coarsest functions as receivers");
//! - `Q = P†·(n·)·Eval` turns receiver coefficients (RGB vector irradiance) into sender
//!   coefficients: evaluate the receiver expansion at every sender point, dot it with
//!   the point's normal (scalar irradiance), and pull-push it over the sender levels.
//!
//! Cheapest order (ours): for each level-0 receiver `i`, `r = P†ᵀ T₀[i,·]` (one
//! adjoint pull-push of a sparse row), then `W_ik = Σ_p B_k(p) r_p ⊗ n_p` (3×3 per
//! channel) over the sender points `p`, so `(T₀Q)[i,k] = W_ik` and
//! `S_2[i,·] = Σ_k W_ik T[k,·]`; the level-0 block `M₀ = W|_{k ∈ level 0}` then gives
//! `S_{b+1}[i,·] = Σ_k M₀[i,k] S_b[k,·]` for `b >= 2`. Links with
//! `‖S_ij‖ < bounce_epsilon` (default `ε/10`) are dropped after each product (ours; the
//! seed drops at `ε`, see [`crate::MeshlessConfig::bounce_epsilon`]), scaled per sender
//! level like `T`'s threshold ([`crate::LinkThreshold`]). Rows run in parallel, each in
//! a fixed order.

use std::time::Instant;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::MeshlessError;
use crate::basis::{Basis, Csr};
use crate::config::MeshlessConfig;
use crate::matrix::{Link, TransferMatrix, link_norm};

/// Statistics of the bounce products.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct BounceStats {
    /// Links of `S_b` for `b = 2..=B` after dropping.
    pub links_per_bounce: Vec<usize>,
    /// Links of `S` (all bounces).
    pub links: usize,
    /// Entries of the evaluation matrix (sender points × receivers).
    pub eval_entries: usize,
    /// Wall time (ms).
    pub ms: f64,
}

/// `Eval`: for every sender point, the receivers that are non-zero there, `(k, B_k(p))`,
/// restricted to `keep(k)`.
pub(crate) fn eval_matrix(
    basis: &Basis,
    senders: usize,
    keep: &(dyn Fn(usize) -> bool + Sync),
) -> Csr<(u32, f64)> {
    let rows: Vec<Vec<(u32, f64)>> = (0..senders)
        .into_par_iter()
        .map_init(Vec::new, |tmp, p| {
            let mut out = Vec::new();
            for l in 0..basis.levels() {
                basis.basis_at(l, basis.position(p), basis.normal(p), tmp);
                out.extend(tmp.iter().filter(|e| keep(e.0 as usize)));
            }
            out
        })
        .collect();
    let mut ptr = Vec::with_capacity(senders + 1);
    ptr.push(0u32);
    let mut items = Vec::new();
    for r in rows {
        items.extend(r);
        ptr.push(items.len() as u32);
    }
    Csr { ptr, items }
}

/// `Q·v`: receiver coefficients `v` (9 per receiver) → sender coefficients (3 per
/// sender): evaluate at the sender points, dot with the normals, pull-push.
pub(crate) fn apply_q(
    basis: &Basis,
    eval: &Csr<(u32, f64)>,
    sender_levels: usize,
    v: &[f64],
) -> Result<Vec<f64>, MeshlessError> {
    let senders = basis.level_start(sender_levels);
    let mut s = vec![0.0; senders * 3];
    s.par_chunks_mut(3).enumerate().for_each(|(p, out)| {
        let n = basis.normal(p);
        for &(k, b) in eval.row(p) {
            let c = &v[k as usize * 9..k as usize * 9 + 9];
            for ch in 0..3 {
                out[ch] += b * (n.x * c[ch * 3] + n.y * c[ch * 3 + 1] + n.z * c[ch * 3 + 2]);
            }
        }
    });
    basis.pull_push(&s, 3, sender_levels)
}

/// A sparse row of links, sorted by sender.
type LinkRow = Vec<(u32, Link)>;
/// A row of `M₀`: level-0 receiver and its 3×3-per-channel block.
type BlockRow = Vec<(u32, [f64; 27])>;

struct RowScratch {
    t: Vec<f64>,
    w: Vec<[f64; 27]>,
    wmark: Vec<bool>,
    wtouched: Vec<u32>,
    out: Vec<Link>,
    omark: Vec<bool>,
    otouched: Vec<u32>,
    anc: Vec<(u32, f64)>,
}

impl RowScratch {
    fn new(senders: usize, active: usize) -> Self {
        Self {
            t: vec![0.0; senders * 9],
            w: vec![[0.0; 27]; active],
            wmark: vec![false; active],
            wtouched: Vec::new(),
            out: vec![[0.0; 9]; senders],
            omark: vec![false; senders],
            otouched: Vec::new(),
            anc: Vec::new(),
        }
    }

    /// Adds `M·l` (per channel 3×3 times 3-vector) times `f` to output column `j`.
    #[inline]
    fn add_out(&mut self, j: u32, m: &[f64; 27], l: &Link) {
        let ju = j as usize;
        if !self.omark[ju] {
            self.omark[ju] = true;
            self.otouched.push(j);
        }
        let o = &mut self.out[ju];
        for c in 0..3 {
            for a in 0..3 {
                let r = &m[c * 9 + a * 3..c * 9 + a * 3 + 3];
                o[c * 3 + a] += r[0] * l[c * 3] + r[1] * l[c * 3 + 1] + r[2] * l[c * 3 + 2];
            }
        }
    }

    /// The output row with `‖·‖ >= eps[level of j]` kept, sorted; clears the output.
    fn take_out(&mut self, basis: &Basis, eps: &[f64]) -> Vec<(u32, Link)> {
        self.otouched.sort_unstable();
        let mut row = Vec::new();
        for &j in &self.otouched {
            let v = self.out[j as usize];
            let epsilon = eps[basis.level_of(j as usize)];
            if link_norm(&v) >= epsilon && link_norm(&v) > 0.0 {
                row.push((j, v));
            }
            self.out[j as usize] = [0.0; 9];
            self.omark[j as usize] = false;
        }
        self.otouched.clear();
        row
    }
}

/// Computes `S` from `T` (module docs).
///
/// # Errors
/// [`MeshlessError::Budget`] when `S` exceeds `config.max_links`.
pub fn bounces(
    basis: &Basis,
    t: &TransferMatrix,
    config: &MeshlessConfig,
) -> Result<(TransferMatrix, BounceStats), MeshlessError> {
    let start = Instant::now();
    let mut stats = BounceStats::default();
    if config.bounces <= 1 {
        stats.links = t.nnz();
        stats.ms = start.elapsed().as_secs_f64() * 1e3;
        return Ok((t.clone(), stats));
    }
    let ls = config.sender_levels.min(basis.levels());
    let senders = basis.level_start(ls);
    let level0 = basis.level_range(0);
    let n0 = level0.len();
    // Receivers that matter: those with links, and level 0 (for M₀).
    let mut active_of = vec![u32::MAX; t.rows()];
    let mut active = Vec::new();
    for k in 0..t.rows() {
        let (c, _) = t.row(k);
        if !c.is_empty() || k < n0 {
            active_of[k] = active.len() as u32;
            active.push(k as u32);
        }
    }
    let eval = eval_matrix(basis, senders, &|k| active_of[k] != u32::MAX);
    let eps = config.level_thresholds(true);
    stats.eval_entries = eval.items.len();
    // One parallel pass over the level-0 rows: S_2 rows and M₀ rows.
    let first: Vec<(LinkRow, BlockRow)> = level0
        .clone()
        .into_par_iter()
        .map_init(
            || RowScratch::new(senders, active.len()),
            |s, i| {
                let (c, v) = t.row(i);
                if c.is_empty() {
                    return (Vec::new(), Vec::new());
                }
                for (j, l) in c.iter().zip(v) {
                    s.t[*j as usize * 9..*j as usize * 9 + 9].copy_from_slice(l);
                }
                let mut anc = std::mem::take(&mut s.anc);
                basis.push_adjoint(&mut s.t, 9, ls, &mut anc);
                basis.pull_adjoint(&mut s.t, 9, ls);
                s.anc = anc;
                for p in 0..senders {
                    let r: [f64; 9] = std::array::from_fn(|q| s.t[p * 9 + q]);
                    if r.iter().all(|x| *x == 0.0) {
                        continue;
                    }
                    let n = basis.normal(p).to_array();
                    for &(k, b) in eval.row(p) {
                        let a = active_of[k as usize] as usize;
                        if !s.wmark[a] {
                            s.wmark[a] = true;
                            s.wtouched.push(a as u32);
                        }
                        let w = &mut s.w[a];
                        for q in 0..9 {
                            let br = b * r[q];
                            w[q * 3] += br * n[0];
                            w[q * 3 + 1] += br * n[1];
                            w[q * 3 + 2] += br * n[2];
                        }
                    }
                }
                s.t.iter_mut().for_each(|x| *x = 0.0);
                s.wtouched.sort_unstable();
                let touched = std::mem::take(&mut s.wtouched);
                let mut m0 = Vec::new();
                for &a in &touched {
                    let k = active[a as usize] as usize;
                    let w = s.w[a as usize];
                    let (c, v) = t.row(k);
                    for (j, l) in c.iter().zip(v) {
                        s.add_out(*j, &w, l);
                    }
                    if k < n0 {
                        m0.push((k as u32, w));
                    }
                    s.w[a as usize] = [0.0; 27];
                    s.wmark[a as usize] = false;
                }
                s.wtouched = touched;
                s.wtouched.clear();
                (s.take_out(basis, &eps), m0)
            },
        )
        .collect();
    let m0: Vec<Vec<(u32, [f64; 27])>> = first.iter().map(|r| r.1.clone()).collect();
    let mut sb: Vec<Vec<(u32, Link)>> = first.into_iter().map(|r| r.0).collect();
    let mut total: Vec<Vec<(u32, Link)>> = sb.clone();
    stats.links_per_bounce.push(sb.iter().map(Vec::len).sum());
    for _ in 3..=config.bounces {
        let next: Vec<Vec<(u32, Link)>> = (0..n0)
            .into_par_iter()
            .map_init(
                || RowScratch::new(senders, 0),
                |s, i| {
                    for (k, m) in &m0[i] {
                        for (j, l) in &sb[*k as usize] {
                            s.add_out(*j, m, l);
                        }
                    }
                    s.take_out(basis, &eps)
                },
            )
            .collect();
        stats.links_per_bounce.push(next.iter().map(Vec::len).sum());
        for (tot, row) in total.iter_mut().zip(&next) {
            *tot = merge(tot, row);
        }
        sb = next;
    }
    let higher =
        TransferMatrix::from_rows(t.rows(), t.cols(), total.into_iter().enumerate().collect());
    let s = t.add(&higher);
    if s.nnz() > config.max_links {
        return Err(MeshlessError::Budget {
            what: "links",
            limit: config.max_links,
        });
    }
    stats.links = s.nnz();
    stats.ms = start.elapsed().as_secs_f64() * 1e3;
    Ok((s, stats))
}

/// Sum of two sorted sparse rows.
fn merge(a: &[(u32, Link)], b: &[(u32, Link)]) -> Vec<(u32, Link)> {
    let mut out = Vec::with_capacity(a.len() + b.len());
    let (mut p, mut q) = (0, 0);
    while p < a.len() || q < b.len() {
        if q >= b.len() || (p < a.len() && a[p].0 < b[q].0) {
            out.push(a[p]);
            p += 1;
        } else if p >= a.len() || b[q].0 < a[p].0 {
            out.push(b[q]);
            q += 1;
        } else {
            let mut s = a[p].1;
            for k in 0..9 {
                s[k] += b[q].1[k];
            }
            out.push((a[p].0, s));
            p += 1;
            q += 1;
        }
    }
    out
}
