//! Sparse (adaptive) transforms on coefficient sets keyed by `(level, index)`, in
//! d = 1..4 dimensions with the non-standard construction (Ziegler §2.2.3 and Appendix
//! A.1; the quadtrees of wavelet radiosity, Gortler et al. via Ziegler §3.3), and
//! push/pull of single nodes (VirtualMesh §5.2).
//!
//! A [`SparseLevel`] holds scaling coefficients of one level on a sorted set of keys
//! `[k_0, …, k_{D−1}]` (absent keys are zero). One analysis step produces the parents of
//! all present children: their scaling coefficients and, per node, the `2^D − 1` wavelet
//! coefficients ([`SparseDetail`], type bit `a` set = `ψ` on axis `a`). The results agree
//! exactly with the full-grid non-standard transform of the zero-filled array
//! ([`crate::tensor::nonstandard_decompose`]) — the tests check this.
//!
//! Cost: O(n · r^D · log n) for `n` present coefficients and rows of length `r` (2k for
//! `M_k`, ≤ 5 for CDV); the buffers grow once per call, never per coefficient.

use crate::{FilterRow, Mra, MraError};

/// Scaling coefficients of one level on a sparse, sorted key set.
#[derive(Debug, Clone, PartialEq)]
pub struct SparseLevel<const D: usize> {
    /// Level of every key.
    pub level: u32,
    keys: Vec<[usize; D]>,
    values: Vec<f64>,
}

impl<const D: usize> SparseLevel<D> {
    /// An empty set on `level`.
    #[must_use]
    pub fn new(level: u32) -> Self {
        Self {
            level,
            keys: Vec::new(),
            values: Vec::new(),
        }
    }

    /// Builds a set from `(key, value)` pairs in any order; values of repeated keys are
    /// summed (in input order).
    #[must_use]
    pub fn from_pairs(level: u32, mut pairs: Vec<([usize; D], f64)>) -> Self {
        pairs.sort_by_key(|a| a.0);
        let mut s = Self::new(level);
        s.keys.reserve(pairs.len());
        s.values.reserve(pairs.len());
        for (k, v) in pairs {
            if s.keys.last() == Some(&k) {
                if let Some(last) = s.values.last_mut() {
                    *last += v;
                }
            } else {
                s.keys.push(k);
                s.values.push(v);
            }
        }
        s
    }

    /// Number of stored keys.
    #[must_use]
    pub fn len(&self) -> usize {
        self.keys.len()
    }

    /// Whether no key is stored.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.keys.is_empty()
    }

    /// Sorted keys.
    #[must_use]
    pub fn keys(&self) -> &[[usize; D]] {
        &self.keys
    }

    /// Values, parallel to [`SparseLevel::keys`].
    #[must_use]
    pub fn values(&self) -> &[f64] {
        &self.values
    }

    /// Mutable values (the key set stays fixed).
    pub fn values_mut(&mut self) -> &mut [f64] {
        &mut self.values
    }

    /// The value at `key` (zero when absent), by binary search.
    #[must_use]
    pub fn get(&self, key: &[usize; D]) -> f64 {
        self.keys.binary_search(key).map_or(0.0, |i| self.values[i])
    }

    /// Checks that keys are within `len(level)` of `mra`.
    ///
    /// # Errors
    /// [`MraError::MalformedSparse`] or level errors.
    pub fn validate<M: Mra + ?Sized>(&self, mra: &M) -> Result<(), MraError> {
        mra.check_level(self.level)?;
        let n = mra.len(self.level);
        if self.keys.iter().any(|k| k.iter().any(|&i| i >= n)) {
            return Err(MraError::MalformedSparse("key index out of range"));
        }
        if self.keys.windows(2).any(|w| w[0] >= w[1]) {
            return Err(MraError::MalformedSparse("keys not sorted and unique"));
        }
        Ok(())
    }
}

/// Wavelet coefficients of one level of a non-standard sparse tree: per key,
/// `2^D − 1` values for the types `t = 1..2^D` (bit `a` of `t` set: `ψ` on axis `a`).
#[derive(Debug, Clone, PartialEq)]
pub struct SparseDetail<const D: usize> {
    /// Level of every key.
    pub level: u32,
    keys: Vec<[usize; D]>,
    values: Vec<f64>,
}

impl<const D: usize> SparseDetail<D> {
    /// Number of wavelet types per node, `2^D − 1`.
    pub const TYPES: usize = (1 << D) - 1;

    /// An empty set on `level`.
    #[must_use]
    pub fn new(level: u32) -> Self {
        Self {
            level,
            keys: Vec::new(),
            values: Vec::new(),
        }
    }

    /// Sorted keys.
    #[must_use]
    pub fn keys(&self) -> &[[usize; D]] {
        &self.keys
    }

    /// The `2^D − 1` wavelet coefficients of node `i` (type `t` at `t − 1`).
    #[must_use]
    pub fn node(&self, i: usize) -> &[f64] {
        &self.values[i * Self::TYPES..(i + 1) * Self::TYPES]
    }

    /// Mutable wavelet coefficients of node `i`.
    pub fn node_mut(&mut self, i: usize) -> &mut [f64] {
        &mut self.values[i * Self::TYPES..(i + 1) * Self::TYPES]
    }

    /// Number of nodes.
    #[must_use]
    pub fn len(&self) -> usize {
        self.keys.len()
    }

    /// Whether no node is stored.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.keys.is_empty()
    }

    /// The coefficients of `key` (`None` when absent).
    #[must_use]
    pub fn get(&self, key: &[usize; D]) -> Option<&[f64]> {
        self.keys.binary_search(key).ok().map(|i| self.node(i))
    }
}

/// A full sparse non-standard decomposition: scaling coefficients on the coarsest level
/// and wavelet coefficients on every level from the coarsest up to the finest − 1.
#[derive(Debug, Clone, PartialEq)]
pub struct SparseTree<const D: usize> {
    /// Scaling coefficients on the coarsest level `j0`.
    pub coarse: SparseLevel<D>,
    /// Wavelet coefficients, `details[i]` on level `j0 + i`.
    pub details: Vec<SparseDetail<D>>,
}

/// Per-axis rows of one parent: union range of the scaling and wavelet rows.
#[derive(Clone, Copy)]
struct AxisRows<'a> {
    h: FilterRow<'a>,
    g: FilterRow<'a>,
    lo: usize,
    hi: usize,
}

impl AxisRows<'_> {
    #[inline]
    fn coeff(&self, wavelet: bool, l: usize) -> f64 {
        let r = if wavelet { &self.g } else { &self.h };
        if l >= r.start && l < r.end() {
            r.coeffs[l - r.start]
        } else {
            0.0
        }
    }
}

fn axis_rows<M: Mra + ?Sized>(mra: &M, level: u32, k: usize) -> Result<AxisRows<'_>, MraError> {
    let h = mra.scaling_row(level, k)?;
    let g = mra.wavelet_row(level, k)?;
    Ok(AxisRows {
        h,
        g,
        lo: h.start.min(g.start),
        hi: h.end().max(g.end()),
    })
}

/// One sparse analysis step: from the scaling coefficients on `fine.level` to the
/// scaling and wavelet coefficients of every parent on `fine.level − 1`.
/// `coarse` and `detail` are overwritten (their buffers are reused).
///
/// # Errors
/// Level errors; [`MraError::MalformedSparse`] for invalid keys or
/// `fine.level <= min_level()`.
pub fn analysis_step<M: Mra + ?Sized, const D: usize>(
    mra: &M,
    fine: &SparseLevel<D>,
    coarse: &mut SparseLevel<D>,
    detail: &mut SparseDetail<D>,
) -> Result<(), MraError> {
    fine.validate(mra)?;
    if fine.level <= mra.min_level() {
        return Err(MraError::MalformedSparse(
            "cannot decompose below the coarsest level",
        ));
    }
    let j = fine.level - 1;
    // Candidate parents.
    let mut cand: Vec<[usize; D]> = std::mem::take(&mut coarse.keys);
    cand.clear();
    for key in &fine.keys {
        let mut ranges: [std::ops::Range<usize>; D] = std::array::from_fn(|_| 0..0);
        for a in 0..D {
            ranges[a] = mra.parents(j, key[a])?;
        }
        for_each_in_product(&ranges, |p| cand.push(p));
    }
    cand.sort_unstable();
    cand.dedup();
    let types = 1usize << D;
    coarse.level = j;
    detail.level = j;
    coarse.values.clear();
    detail.keys.clear();
    detail.values.clear();
    let mut acc = vec![0.0; types];
    for p in &cand {
        let mut rows: [Option<AxisRows<'_>>; D] = [None; D];
        for a in 0..D {
            rows[a] = Some(axis_rows(mra, j, p[a])?);
        }
        let rows: [AxisRows<'_>; D] = std::array::from_fn(|a| rows[a].expect("set above"));
        acc.fill(0.0);
        let ranges: [std::ops::Range<usize>; D] = std::array::from_fn(|a| rows[a].lo..rows[a].hi);
        for_each_in_product(&ranges, |child| {
            let v = fine.get(&child);
            if v == 0.0 {
                return;
            }
            for (t, slot) in acc.iter_mut().enumerate() {
                let mut w = v;
                for a in 0..D {
                    w *= rows[a].coeff((t >> a) & 1 == 1, child[a]);
                }
                *slot += w;
            }
        });
        coarse.values.push(acc[0]);
        detail.keys.push(*p);
        detail.values.extend_from_slice(&acc[1..]);
    }
    coarse.keys = cand;
    Ok(())
}

/// One sparse synthesis step, the inverse of [`analysis_step`]: scatters the scaling
/// and wavelet coefficients of level `coarse.level` onto the children on the next
/// level; `fine` is overwritten.
///
/// # Errors
/// Level errors; [`MraError::MalformedSparse`] for mismatched levels.
pub fn synthesis_step<M: Mra + ?Sized, const D: usize>(
    mra: &M,
    coarse: &SparseLevel<D>,
    detail: &SparseDetail<D>,
    fine: &mut SparseLevel<D>,
) -> Result<(), MraError> {
    coarse.validate(mra)?;
    if detail.level != coarse.level {
        return Err(MraError::MalformedSparse("coarse and detail levels differ"));
    }
    let j = coarse.level;
    mra.check_level(j + 1)?;
    let types = 1usize << D;
    let mut pairs: Vec<([usize; D], f64)> = Vec::with_capacity(4 * (coarse.len() + detail.len()));
    let mut coef = vec![0.0; types];
    // Walk the union of both key sets in order.
    let (mut ic, mut id) = (0usize, 0usize);
    while ic < coarse.keys.len() || id < detail.keys.len() {
        let kc = coarse.keys.get(ic);
        let kd = detail.keys.get(id);
        let key = match (kc, kd) {
            (Some(a), Some(b)) => *a.min(b),
            (Some(a), None) => *a,
            (None, Some(b)) => *b,
            (None, None) => break,
        };
        coef.fill(0.0);
        if kc == Some(&key) {
            coef[0] = coarse.values[ic];
            ic += 1;
        }
        if kd == Some(&key) {
            coef[1..].copy_from_slice(detail.node(id));
            id += 1;
        }
        let mut rows: [Option<AxisRows<'_>>; D] = [None; D];
        for a in 0..D {
            rows[a] = Some(axis_rows(mra, j, key[a])?);
        }
        let rows: [AxisRows<'_>; D] = std::array::from_fn(|a| rows[a].expect("set above"));
        let ranges: [std::ops::Range<usize>; D] = std::array::from_fn(|a| rows[a].lo..rows[a].hi);
        for_each_in_product(&ranges, |child| {
            let mut s = 0.0;
            for (t, &c) in coef.iter().enumerate() {
                if c == 0.0 {
                    continue;
                }
                let mut w = c;
                for a in 0..D {
                    w *= rows[a].coeff((t >> a) & 1 == 1, child[a]);
                }
                s += w;
            }
            pairs.push((child, s));
        });
    }
    *fine = SparseLevel::from_pairs(j + 1, pairs);
    Ok(())
}

/// Full sparse non-standard decomposition from `fine.level` down to `j0`.
///
/// # Errors
/// As [`analysis_step`]; level errors when `j0 > fine.level`.
pub fn decompose<M: Mra + ?Sized, const D: usize>(
    mra: &M,
    fine: &SparseLevel<D>,
    j0: u32,
) -> Result<SparseTree<D>, MraError> {
    mra.check_level(j0)?;
    if j0 > fine.level {
        return Err(MraError::LevelOutOfRange {
            level: j0,
            min: mra.min_level(),
            max: fine.level,
        });
    }
    let mut cur = fine.clone();
    let mut details = Vec::new();
    while cur.level > j0 {
        let mut c = SparseLevel::new(cur.level - 1);
        let mut d = SparseDetail::new(cur.level - 1);
        analysis_step(mra, &cur, &mut c, &mut d)?;
        details.push(d);
        cur = c;
    }
    details.reverse();
    Ok(SparseTree {
        coarse: cur,
        details,
    })
}

/// Inverse of [`decompose`]: the scaling coefficients on the finest level.
///
/// # Errors
/// As [`synthesis_step`].
pub fn reconstruct<M: Mra + ?Sized, const D: usize>(
    mra: &M,
    tree: &SparseTree<D>,
) -> Result<SparseLevel<D>, MraError> {
    let mut cur = tree.coarse.clone();
    for d in &tree.details {
        let mut f = SparseLevel::new(cur.level + 1);
        synthesis_step(mra, &cur, d, &mut f)?;
        cur = f;
    }
    Ok(cur)
}

/// Pull for one d-dimensional node (VirtualMesh §5.2, 2D tensor form): the scaling
/// coefficient of `key` on `level` from the children on `level + 1` given by `child`.
///
/// # Errors
/// Level/index errors.
pub fn pull_node<M: Mra + ?Sized, const D: usize>(
    mra: &M,
    level: u32,
    key: [usize; D],
    mut child: impl FnMut(&[usize; D]) -> f64,
) -> Result<f64, MraError> {
    let mut rows: [Option<FilterRow<'_>>; D] = [None; D];
    for a in 0..D {
        rows[a] = Some(mra.scaling_row(level, key[a])?);
    }
    let rows: [FilterRow<'_>; D] = std::array::from_fn(|a| rows[a].expect("set above"));
    let ranges: [std::ops::Range<usize>; D] = std::array::from_fn(|a| rows[a].start..rows[a].end());
    let mut s = 0.0;
    for_each_in_product(&ranges, |c| {
        let mut w = child(&c);
        for a in 0..D {
            w *= rows[a].coeffs[c[a] - rows[a].start];
        }
        s += w;
    });
    Ok(s)
}

/// Push for one d-dimensional node (VirtualMesh §5.2): calls `add(child, h · value)` for
/// every child on `level + 1`, so that `value · φ_key` is represented exactly there.
///
/// # Errors
/// Level/index errors.
pub fn push_node<M: Mra + ?Sized, const D: usize>(
    mra: &M,
    level: u32,
    key: [usize; D],
    value: f64,
    mut add: impl FnMut(&[usize; D], f64),
) -> Result<(), MraError> {
    let mut rows: [Option<FilterRow<'_>>; D] = [None; D];
    for a in 0..D {
        rows[a] = Some(mra.scaling_row(level, key[a])?);
    }
    let rows: [FilterRow<'_>; D] = std::array::from_fn(|a| rows[a].expect("set above"));
    let ranges: [std::ops::Range<usize>; D] = std::array::from_fn(|a| rows[a].start..rows[a].end());
    for_each_in_product(&ranges, |c| {
        let mut w = value;
        for a in 0..D {
            w *= rows[a].coeffs[c[a] - rows[a].start];
        }
        add(&c, w);
    });
    Ok(())
}

/// Calls `f` for every key in the cartesian product of `ranges` (lexicographic order).
fn for_each_in_product<const D: usize>(
    ranges: &[std::ops::Range<usize>; D],
    mut f: impl FnMut([usize; D]),
) {
    if ranges.iter().any(|r| r.is_empty()) {
        return;
    }
    let mut idx: [usize; D] = std::array::from_fn(|a| ranges[a].start);
    loop {
        f(idx);
        let mut a = D;
        loop {
            if a == 0 {
                return;
            }
            a -= 1;
            idx[a] += 1;
            if idx[a] < ranges[a].end {
                break;
            }
            idx[a] = ranges[a].start;
        }
    }
}
