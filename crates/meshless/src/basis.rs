//! The multilevel meshless basis (Meshless §2.1–§2.2): points `(x, n)` on `L` levels,
//! one support radius per level, Shepard-normalised weight functions per level
//! (eq. (2)), the coarse-to-fine projection `P` (eq. (7)), the pull-push projection
//! `P†`, evaluation of an expansion (eq. (6)) and the neighbour / parent / child DAG.
//!
//! # Indexing and values
//! Points are numbered across all levels with one index (level 0 first, as in the
//! seed). Functions of one level are normalised among that level only:
//! `B_j(p) = w_j(p) / Σ_{k ∈ level} w_k(p)`; where the level's weights all vanish
//! (`p` not covered by the level) every `B_j(p)` is zero, never NaN. Values and
//! coefficients are point-major `f64` slices with `k` components per point (1:
//! scalar, 3: RGB, 9: RGB vector irradiance).
//!
//! # DAG (§2.1 "Neighbors, Parents, and Children")
//! - neighbours of `B_i`: the other functions `B_n` of its level with `B_i(p_n) ≠ 0`;
//! - children of `B_i` (level `l`): the functions `B_c` of level `l + 1` with
//!   `B_i(p_c) ≠ 0`, stored with the raw weight `w_i(p_c)` (the pull weights of `P†`);
//! - ancestors of `B_i`: every function `B_k` of every coarser level with
//!   `B_k(p_i) ≠ 0`, with the value `B_k(p_i)` (eq. (7)'s "all levels above", eq.
//!   (17)'s all-parents); the parents are the ancestors on level `l − 1`. They are
//!   cached (CSR) for the first `cache_levels` levels — the sender levels, which the
//!   runtime's `P†` walks every frame — and found through the grids elsewhere.
//!
//! # `P†` (ours where the seed is terse)
//! Pull: the finest level keeps its samples; each coarser function takes the
//! `w_i(p_c)`-weighted mean of its children's (pulled) values, or its own sample if it
//! has no children. Push: eq. (7) applied to the pulled averages, coarse to fine.
//! Both `P` and `P†` reproduce constants where every level covers the points.

use std::ops::Range;

use glam::DVec3;
use rayon::prelude::*;

use crate::MeshlessError;
use crate::grid::Grid;
use crate::kernel::weight;

/// A basis point: position and unit normal.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BasisPoint {
    /// Position (scene units).
    pub x: DVec3,
    /// Unit normal of the lit side.
    pub n: DVec3,
}

/// Compressed sparse rows: `ptr[i]..ptr[i + 1]` indexes `items`.
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct Csr<T> {
    pub(crate) ptr: Vec<u32>,
    pub(crate) items: Vec<T>,
}

impl<T: Copy> Csr<T> {
    fn from_rows(rows: Vec<Vec<T>>) -> Self {
        let mut ptr = Vec::with_capacity(rows.len() + 1);
        ptr.push(0u32);
        let mut items = Vec::with_capacity(rows.iter().map(Vec::len).sum());
        for r in rows {
            items.extend_from_slice(&r);
            ptr.push(items.len() as u32);
        }
        Self { ptr, items }
    }

    #[inline]
    pub(crate) fn row(&self, i: usize) -> &[T] {
        match (self.ptr.get(i), self.ptr.get(i + 1)) {
            (Some(&a), Some(&b)) => &self.items[a as usize..b as usize],
            _ => &[],
        }
    }

    fn bytes(&self) -> usize {
        self.ptr.len() * 4 + self.items.len() * std::mem::size_of::<T>()
    }
}

/// The multilevel meshless basis.
#[derive(Debug, Clone)]
pub struct Basis {
    x: Vec<DVec3>,
    n: Vec<DVec3>,
    level_start: Vec<usize>,
    radius: Vec<f64>,
    grids: Vec<Grid>,
    children: Csr<(u32, f64)>,
    neighbours: Csr<u32>,
    ancestors: Csr<(u32, f64)>,
    cached_end: usize,
    dropped: usize,
}

impl Basis {
    /// Builds the basis from points per level (level 0 first) and one support radius
    /// per level (scene units). Points with a non-finite position or a zero or
    /// non-finite normal are dropped and counted ([`Basis::dropped`]); normals are
    /// normalised. Ancestors are cached for the first `cache_levels` levels.
    ///
    /// # Errors
    /// [`MeshlessError::Config`] for no levels, more than 16, radii not finite and
    /// positive or not one per level; [`MeshlessError::EmptyLevel`] for a level left
    /// without points.
    pub fn from_levels(
        levels: &[Vec<BasisPoint>],
        radii: &[f64],
        cache_levels: usize,
    ) -> Result<Self, MeshlessError> {
        if levels.is_empty() || levels.len() > crate::MAX_LEVELS {
            return Err(MeshlessError::config(
                "levels",
                format!("{} not in 1..={}", levels.len(), crate::MAX_LEVELS),
            ));
        }
        if radii.len() != levels.len() {
            return Err(MeshlessError::config(
                "radii",
                format!("{} radii for {} levels", radii.len(), levels.len()),
            ));
        }
        for (l, &r) in radii.iter().enumerate() {
            if !(r.is_finite() && r > 0.0) {
                return Err(MeshlessError::config(
                    "radii",
                    format!("radius {r} of level {l} is not finite and > 0"),
                ));
            }
        }
        let mut x = Vec::new();
        let mut n = Vec::new();
        let mut level_start = vec![0];
        let mut dropped = 0;
        for (l, pts) in levels.iter().enumerate() {
            for p in pts {
                match p.n.try_normalize() {
                    Some(nn) if p.x.is_finite() => {
                        x.push(p.x);
                        n.push(nn);
                    }
                    _ => dropped += 1,
                }
            }
            if x.len() == level_start[l] {
                return Err(MeshlessError::EmptyLevel {
                    level: l,
                    spacing: radii[l],
                });
            }
            level_start.push(x.len());
        }
        if x.len() >= u32::MAX as usize {
            return Err(MeshlessError::Budget {
                what: "points",
                limit: u32::MAX as usize - 1,
            });
        }
        let grids = (0..levels.len())
            .map(|l| {
                Grid::build(
                    &x[level_start[l]..level_start[l + 1]],
                    level_start[l],
                    radii[l],
                )
            })
            .collect();
        let mut b = Self {
            x,
            n,
            level_start,
            radius: radii.to_vec(),
            grids,
            children: Csr::default(),
            neighbours: Csr::default(),
            ancestors: Csr::default(),
            cached_end: 0,
            dropped,
        };
        b.build_dag(cache_levels.min(levels.len()));
        Ok(b)
    }

    fn build_dag(&mut self, cache_levels: usize) {
        let total = self.x.len();
        // Parents of every point (level l + 1 → level l), with the raw weight.
        let parents: Vec<Vec<(u32, f64)>> = (0..total)
            .into_par_iter()
            .map(|c| {
                let l = self.level_of(c);
                let mut out = Vec::new();
                if l == 0 {
                    return out;
                }
                let (xc, nc) = (self.x[c], self.n[c]);
                let r = self.radius[l - 1];
                self.grids[l - 1].for_each_near(xc, |i| {
                    let w = weight(self.x[i as usize], self.n[i as usize], r, xc, nc);
                    if w > 0.0 {
                        out.push((i, w));
                    }
                });
                out.sort_unstable_by_key(|e| e.0);
                out
            })
            .collect();
        // Transpose into children (sorted by child index: parents are visited in
        // child order).
        let mut count = vec![0u32; total + 1];
        for ps in &parents {
            for &(i, _) in ps {
                count[i as usize + 1] += 1;
            }
        }
        for i in 0..total {
            count[i + 1] += count[i];
        }
        let mut fill = count.clone();
        let mut items = vec![(0u32, 0.0f64); count[total] as usize];
        for (c, ps) in parents.iter().enumerate() {
            for &(i, w) in ps {
                items[fill[i as usize] as usize] = (c as u32, w);
                fill[i as usize] += 1;
            }
        }
        self.children = Csr { ptr: count, items };
        let neighbours: Vec<Vec<u32>> = (0..total)
            .into_par_iter()
            .map(|i| {
                let l = self.level_of(i);
                let (xi, ni, r) = (self.x[i], self.n[i], self.radius[l]);
                let mut out = Vec::new();
                self.grids[l].for_each_near(xi, |k| {
                    if k as usize != i
                        && weight(xi, ni, r, self.x[k as usize], self.n[k as usize]) > 0.0
                    {
                        out.push(k);
                    }
                });
                out.sort_unstable();
                out
            })
            .collect();
        self.neighbours = Csr::from_rows(neighbours);
        let end = self.level_start[cache_levels];
        let anc: Vec<Vec<(u32, f64)>> = (0..end)
            .into_par_iter()
            .map(|i| {
                let mut out = Vec::new();
                self.ancestors_uncached(i, &mut out);
                out
            })
            .collect();
        self.ancestors = Csr::from_rows(anc);
        self.cached_end = end;
    }

    /// Number of points (functions) on all levels.
    pub fn len(&self) -> usize {
        self.x.len()
    }

    /// True if there are no points (never, for a built basis).
    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }

    /// Number of levels.
    pub fn levels(&self) -> usize {
        self.radius.len()
    }

    /// The global indices of level `l`'s points.
    pub fn level_range(&self, l: usize) -> Range<usize> {
        self.level_start[l]..self.level_start[l + 1]
    }

    /// Number of points on levels `0..l` (the first index of level `l`).
    pub fn level_start(&self, l: usize) -> usize {
        self.level_start[l]
    }

    /// Level of point `i`.
    pub fn level_of(&self, i: usize) -> usize {
        self.level_start.partition_point(|&s| s <= i) - 1
    }

    /// Position of point `i`.
    pub fn position(&self, i: usize) -> DVec3 {
        self.x[i]
    }

    /// Unit normal of point `i`.
    pub fn normal(&self, i: usize) -> DVec3 {
        self.n[i]
    }

    /// Support radius `r_l` of level `l` (scene units).
    pub fn radius(&self, l: usize) -> f64 {
        self.radius[l]
    }

    /// Points dropped at construction for a non-finite position or a zero or
    /// non-finite normal.
    pub fn dropped(&self) -> usize {
        self.dropped
    }

    /// The raw weight `w_j(x, n)` of eq. (8).
    #[inline]
    pub fn weight(&self, j: usize, x: DVec3, n: DVec3) -> f64 {
        weight(self.x[j], self.n[j], self.radius[self.level_of(j)], x, n)
    }

    /// The non-zero normalised functions `B_j(x, n)` of level `l` (eq. (2)) into `out`
    /// (cleared first) as `(j, B_j)`, in a fixed order; returns the level's weight sum
    /// `Σ w_k(x, n)` (zero where the level does not cover `(x, n)`, and `out` empty).
    pub fn basis_at(&self, l: usize, x: DVec3, n: DVec3, out: &mut Vec<(u32, f64)>) -> f64 {
        out.clear();
        let r = self.radius[l];
        let mut sum = 0.0;
        self.grids[l].for_each_near(x, |j| {
            let w = weight(self.x[j as usize], self.n[j as usize], r, x, n);
            if w > 0.0 {
                sum += w;
                out.push((j, w));
            }
        });
        if sum > 0.0 {
            let inv = 1.0 / sum;
            for e in out.iter_mut() {
                e.1 *= inv;
            }
        }
        sum
    }

    /// Children of function `i` as `(c, w_i(p_c))` (level `l + 1`, sorted by `c`).
    pub fn children(&self, i: usize) -> &[(u32, f64)] {
        self.children.row(i)
    }

    /// Neighbours of function `i` (same level, `B_i(p_n) ≠ 0`, sorted).
    pub fn neighbours(&self, i: usize) -> &[u32] {
        self.neighbours.row(i)
    }

    /// Ancestors of point `i`, `(k, B_k(p_i))` for every non-zero function of every
    /// coarser level, coarsest level first, into `out` (cleared first).
    pub fn ancestors(&self, i: usize, out: &mut Vec<(u32, f64)>) {
        if i < self.cached_end {
            out.clear();
            out.extend_from_slice(self.ancestors.row(i));
        } else {
            self.ancestors_uncached(i, out);
        }
    }

    fn ancestors_uncached(&self, i: usize, out: &mut Vec<(u32, f64)>) {
        out.clear();
        let l = self.level_of(i);
        let mut tmp = Vec::new();
        for m in 0..l {
            self.basis_at(m, self.x[i], self.n[i], &mut tmp);
            out.extend_from_slice(&tmp);
        }
    }

    fn check_len(&self, what: &'static str, len: usize, want: usize) -> Result<(), MeshlessError> {
        if len == want {
            Ok(())
        } else {
            Err(MeshlessError::Length {
                what,
                len,
                expected: want,
            })
        }
    }

    /// The coarse-to-fine projection `P` (eq. (7)): samples `f` at every point (`k`
    /// components each) → coefficients `α`: `α_j = f_j` on level 0, `f_j − F_{l−1}(p_j)`
    /// on level `l`.
    ///
    /// # Errors
    /// [`MeshlessError::Length`] unless `f.len() == len() · k` and `k >= 1`.
    pub fn project(&self, f: &[f64], k: usize) -> Result<Vec<f64>, MeshlessError> {
        self.check_len("samples", f.len(), self.len() * k.max(1))?;
        Ok(self.push(f.to_vec(), k, self.levels()))
    }

    /// The pull-push projection `P†` on the first `levels` levels (module docs):
    /// samples `f` at the points of those levels (`k` components each) → coefficients.
    ///
    /// # Errors
    /// [`MeshlessError::Length`] unless `f.len() == level_start(levels) · k`, `k >= 1`
    /// and `1 <= levels <= self.levels()`.
    pub fn pull_push(&self, f: &[f64], k: usize, levels: usize) -> Result<Vec<f64>, MeshlessError> {
        if levels == 0 || levels > self.levels() {
            return Err(MeshlessError::config(
                "levels",
                format!("pull-push over {levels} of {} levels", self.levels()),
            ));
        }
        self.check_len("samples", f.len(), self.level_start[levels] * k.max(1))?;
        let a = self.pull(f.to_vec(), k, levels);
        Ok(self.push(a, k, levels))
    }

    /// Pull: level by level from the second finest of `levels` to 0, each function takes
    /// the weighted mean of its children's values (or keeps its own).
    fn pull(&self, mut a: Vec<f64>, k: usize, levels: usize) -> Vec<f64> {
        for l in (0..levels.saturating_sub(1)).rev() {
            let (head, tail) = a.split_at_mut(self.level_start[l + 1] * k);
            let fine = &tail[..];
            let base = self.level_start[l + 1];
            let lo = self.level_start[l] * k;
            head[lo..].par_chunks_mut(k).enumerate().for_each_init(
                || vec![0.0; k],
                |acc, (q, out)| {
                    let i = self.level_start[l] + q;
                    acc.iter_mut().for_each(|v| *v = 0.0);
                    let mut sw = 0.0;
                    for &(c, w) in self.children(i) {
                        let c = c as usize - base;
                        sw += w;
                        for t in 0..k {
                            acc[t] += w * fine[c * k + t];
                        }
                    }
                    if sw > 0.0 {
                        for t in 0..k {
                            out[t] = acc[t] / sw;
                        }
                    }
                },
            );
        }
        a
    }

    /// Push: eq. (7) on the values `a` of the first `levels` levels.
    fn push(&self, mut a: Vec<f64>, k: usize, levels: usize) -> Vec<f64> {
        for l in 1..levels {
            let (coarse, rest) = a.split_at_mut(self.level_start[l] * k);
            let coarse = &coarse[..];
            let n = (self.level_start[l + 1] - self.level_start[l]) * k;
            rest[..n]
                .par_chunks_mut(k)
                .enumerate()
                .for_each_init(Vec::new, |anc, (q, out)| {
                    let i = self.level_start[l] + q;
                    self.ancestors(i, anc);
                    for &(j, b) in anc.iter() {
                        let j = j as usize;
                        for t in 0..k {
                            out[t] -= b * coarse[j * k + t];
                        }
                    }
                });
        }
        a
    }

    /// Adjoint of the push of the first `levels` levels, in place (sequential).
    pub(crate) fn push_adjoint(
        &self,
        t: &mut [f64],
        k: usize,
        levels: usize,
        anc: &mut Vec<(u32, f64)>,
    ) {
        for l in (1..levels).rev() {
            for i in self.level_range(l) {
                if t[i * k..(i + 1) * k].iter().all(|v| *v == 0.0) {
                    continue;
                }
                self.ancestors(i, anc);
                for &(j, b) in anc.iter() {
                    let j = j as usize;
                    for c in 0..k {
                        t[j * k + c] -= b * t[i * k + c];
                    }
                }
            }
        }
    }

    /// Adjoint of the pull of the first `levels` levels, in place (sequential).
    pub(crate) fn pull_adjoint(&self, s: &mut [f64], k: usize, levels: usize) {
        for l in 0..levels.saturating_sub(1) {
            for i in self.level_range(l) {
                let ch = self.children(i);
                let sw: f64 = ch.iter().map(|e| e.1).sum();
                if !(sw > 0.0) || s[i * k..(i + 1) * k].iter().all(|v| *v == 0.0) {
                    continue;
                }
                for &(c, w) in ch {
                    let c = c as usize;
                    let f = w / sw;
                    for t in 0..k {
                        s[c * k + t] += f * s[i * k + t];
                    }
                }
                for t in 0..k {
                    s[i * k + t] = 0.0;
                }
            }
        }
    }

    /// Evaluates the expansion `Σ_l Σ_{j ∈ l} α_j B_j(x, n)` (eq. (6)) over the levels
    /// `levels` into `out` (`k` components; zeroed first). `alpha` holds `k`
    /// coefficients for every point of levels `0..levels.end`.
    pub fn evaluate(
        &self,
        alpha: &[f64],
        k: usize,
        levels: Range<usize>,
        x: DVec3,
        n: DVec3,
        out: &mut [f64],
        scratch: &mut Vec<(u32, f64)>,
    ) {
        out.iter_mut().for_each(|v| *v = 0.0);
        for l in levels {
            self.basis_at(l, x, n, scratch);
            for &(j, b) in scratch.iter() {
                let j = j as usize;
                for t in 0..k {
                    out[t] += b * alpha[j * k + t];
                }
            }
        }
    }

    /// Heap bytes of the basis (points, grids, DAG).
    pub fn bytes(&self) -> usize {
        self.x.len() * 48
            + self.grids.iter().map(Grid::bytes).sum::<usize>()
            + self.children.bytes()
            + self.neighbours.bytes()
            + self.ancestors.bytes()
    }

    /// Entries of the cached DAG: `(children, neighbours, cached ancestors)`.
    pub fn dag_sizes(&self) -> (usize, usize, usize) {
        (
            self.children.items.len(),
            self.neighbours.items.len(),
            self.ancestors.items.len(),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sample::rng_for;
    use proptest::prelude::*;
    use rand::RngExt;

    /// Jittered grids on the two faces of a folded sheet (z = 0 and x = 0), `4^l`-ish
    /// points per level.
    pub(crate) fn folded_basis(levels: usize, seed: u64) -> Basis {
        let mut rng = rng_for(seed, 0, 0);
        let mut pts = Vec::new();
        let mut radii = Vec::new();
        for l in 0..levels {
            let m = 3usize << l;
            let h = 1.0 / m as f64;
            let mut lv = Vec::new();
            for i in 0..m {
                for j in 0..m {
                    let (a, b): (f64, f64) = (rng.random(), rng.random());
                    let (u, v) = (
                        (i as f64 + 0.2 + 0.6 * a) * h,
                        (j as f64 + 0.2 + 0.6 * b) * h,
                    );
                    lv.push(BasisPoint {
                        x: DVec3::new(u, v, 0.0),
                        n: DVec3::Z,
                    });
                    lv.push(BasisPoint {
                        x: DVec3::new(0.0, u, v),
                        n: DVec3::X,
                    });
                }
            }
            pts.push(lv);
            radii.push(2.0 * h);
        }
        Basis::from_levels(&pts, &radii, levels).unwrap()
    }

    #[test]
    fn partition_of_unity_where_covered() {
        let b = folded_basis(3, 1);
        let mut rng = rng_for(9, 9, 9);
        let mut out = Vec::new();
        for _ in 0..500 {
            let (u, v): (f64, f64) = (rng.random(), rng.random());
            for (x, n) in [
                (DVec3::new(u, v, 0.0), DVec3::Z),
                (DVec3::new(0.0, u, v), DVec3::X),
            ] {
                for l in 0..b.levels() {
                    let w = b.basis_at(l, x, n, &mut out);
                    assert!(w > 0.0, "level {l} must cover the sheet");
                    let s: f64 = out.iter().map(|e| e.1).sum();
                    assert!((s - 1.0).abs() < 1e-12);
                }
            }
        }
        // Off the sheet, facing away: not covered, no NaN.
        let w = b.basis_at(0, DVec3::new(0.5, 0.5, 0.0), -DVec3::Z, &mut out);
        assert_eq!(w, 0.0);
        assert!(out.is_empty());
    }

    #[test]
    fn projections_reproduce_constants() {
        let b = folded_basis(4, 2);
        let f = vec![2.5; b.len()];
        let a = b.project(&f, 1).unwrap();
        let ap = b.pull_push(&f, 1, b.levels()).unwrap();
        let mut out = [0.0];
        let mut s = Vec::new();
        for (coef, name) in [(&a, "P"), (&ap, "P†")] {
            for l in 0..b.levels() {
                for i in b.level_range(l) {
                    let want = if l == 0 { 2.5 } else { 0.0 };
                    assert!(
                        (coef[i] - want).abs() < 1e-12,
                        "{name} level {l}: {}",
                        coef[i]
                    );
                }
            }
            b.evaluate(
                coef,
                1,
                0..b.levels(),
                DVec3::new(0.3, 0.7, 0.0),
                DVec3::Z,
                &mut out,
                &mut s,
            );
            assert!((out[0] - 2.5).abs() < 1e-12);
        }
    }

    #[test]
    fn project_interpolates_at_finest_points_in_the_limit() {
        // P's coefficients reproduce f at every point when evaluated with the
        // functions of the point's own and coarser levels... only up to the
        // Shepard smoothing of its own level; but eq. (7) is exact on level 0 sums:
        // F_0(p_j) + α_j = f_j for level-1 points by construction.
        let b = folded_basis(2, 3);
        let f: Vec<f64> = (0..b.len()).map(|i| b.position(i).length()).collect();
        let a = b.project(&f, 1).unwrap();
        let mut out = [0.0];
        let mut s = Vec::new();
        for i in b.level_range(1) {
            b.evaluate(&a, 1, 0..1, b.position(i), b.normal(i), &mut out, &mut s);
            assert!((out[0] + a[i] - f[i]).abs() < 1e-12);
        }
    }

    #[test]
    fn pull_push_adjoint_is_the_transpose() {
        let b = folded_basis(3, 4);
        let levels = 3;
        let n = b.level_start(levels);
        let k = 3;
        let mut rng = rng_for(5, 5, 5);
        let f: Vec<f64> = (0..n * k).map(|_| rng.random::<f64>() - 0.5).collect();
        let t: Vec<f64> = (0..n * k).map(|_| rng.random::<f64>() - 0.5).collect();
        let pf = b.pull_push(&f, k, levels).unwrap();
        let mut g = t.clone();
        let mut anc = Vec::new();
        b.push_adjoint(&mut g, k, levels, &mut anc);
        b.pull_adjoint(&mut g, k, levels);
        let lhs: f64 = t.iter().zip(&pf).map(|(a, b)| a * b).sum();
        let rhs: f64 = g.iter().zip(&f).map(|(a, b)| a * b).sum();
        assert!(
            (lhs - rhs).abs() < 1e-10 * lhs.abs().max(1.0),
            "{lhs} vs {rhs}"
        );
    }

    #[test]
    fn dag_is_consistent() {
        let b = folded_basis(3, 6);
        let mut anc = Vec::new();
        for c in b.level_range(2) {
            b.ancestors(c, &mut anc);
            // Parents (level 1) are exactly the functions listing c as a child.
            for &(p, bp) in anc.iter().filter(|e| b.level_of(e.0 as usize) == 1) {
                assert!(bp > 0.0);
                assert!(b.children(p as usize).iter().any(|e| e.0 as usize == c));
            }
        }
        for i in b.level_range(1) {
            for &nb in b.neighbours(i) {
                assert_eq!(b.level_of(nb as usize), 1);
                assert!(b.weight(i, b.position(nb as usize), b.normal(nb as usize)) > 0.0);
            }
        }
    }

    #[test]
    fn bad_points_are_dropped_and_counted() {
        let lv = vec![
            BasisPoint {
                x: DVec3::ZERO,
                n: DVec3::Z,
            },
            BasisPoint {
                x: DVec3::X,
                n: DVec3::ZERO,
            },
            BasisPoint {
                x: DVec3::Y,
                n: DVec3::splat(f64::NAN),
            },
            BasisPoint {
                x: DVec3::splat(f64::NAN),
                n: DVec3::Z,
            },
        ];
        let b = Basis::from_levels(&[lv], &[1.0], 1).unwrap();
        assert_eq!((b.len(), b.dropped()), (1, 3));
        let e = Basis::from_levels(
            &[vec![BasisPoint {
                x: DVec3::X,
                n: DVec3::ZERO,
            }]],
            &[1.0],
            1,
        );
        assert!(matches!(e, Err(MeshlessError::EmptyLevel { level: 0, .. })));
        assert!(Basis::from_levels(&[], &[], 0).is_err());
        assert!(Basis::from_levels(&[vec![]], &[0.0], 0).is_err());
    }

    #[test]
    fn coincident_opposite_points_do_not_mix() {
        // A two-sided sheet: the same position with opposite normals, one level.
        let lv = vec![
            BasisPoint {
                x: DVec3::ZERO,
                n: DVec3::Z,
            },
            BasisPoint {
                x: DVec3::ZERO,
                n: -DVec3::Z,
            },
        ];
        let b = Basis::from_levels(&[lv], &[1.0], 1).unwrap();
        let mut out = Vec::new();
        b.basis_at(0, DVec3::new(0.1, 0.0, 0.0), DVec3::Z, &mut out);
        assert_eq!(out, vec![(0, 1.0)]);
        b.basis_at(0, DVec3::new(0.1, 0.0, 0.0), -DVec3::Z, &mut out);
        assert_eq!(out, vec![(1, 1.0)]);
    }

    proptest! {
        #[test]
        fn shepard_sums_to_one_or_zero(
            pts in prop::collection::vec((prop::array::uniform3(-1.0f64..1.0), prop::array::uniform3(-1.0f64..1.0)), 1..40),
            q in prop::array::uniform3(-1.0f64..1.0),
            qn in prop::array::uniform3(-1.0f64..1.0),
            r in 0.05f64..2.0,
        ) {
            let lv: Vec<BasisPoint> = pts.iter().map(|(x, n)| BasisPoint { x: DVec3::from_array(*x), n: DVec3::from_array(*n) }).collect();
            let Ok(b) = Basis::from_levels(&[lv], &[r], 1) else { return Ok(()); };
            let qn = DVec3::from_array(qn);
            prop_assume!(qn.length() > 1e-3);
            let mut out = Vec::new();
            let w = b.basis_at(0, DVec3::from_array(q), qn.normalize(), &mut out);
            let s: f64 = out.iter().map(|e| e.1).sum();
            prop_assert!(s.is_finite());
            if w > 0.0 { prop_assert!((s - 1.0).abs() < 1e-12); } else { prop_assert!(out.is_empty()); }
        }
    }
}
