//! Element trees of the linkless shooting solver: one quadtree per patch holding the
//! radiosity `B`, the unshot residual `ΔB` and the irradiance `H` (per RGB channel,
//! `k²` coefficients per node) — memory proportional to the elements, no links
//! (VirtualMesh §5.1, after Stamminger et al. 1998).
//!
//! Values are kept in *hierarchical* form: the function is the sum over nodes of each
//! node's expansion (a deposit at a coarse node is not pushed down at once). Push/pull
//! ([`Tree::consistent`], VirtualMesh Algorithm 1 line 7) turns it into *consistent*
//! form — leaves hold the function, every internal node its projection — which is what
//! a shooter needs to shoot from any level. Splitting a leaf appends four zero
//! children, so the represented function is unchanged.
//!
//! A self-shooting surface shoots onto a *decoy* ([`Tree::new`] of the same patch: same
//! geometry, zero levels) whose levels, residuals and subdivisions are then copied back
//! with [`Tree::absorb`] (VirtualMesh §5.3).

use std::borrow::Cow;

use super::twoscale::{Mats, TwoScale, pull_into, push_into};
use crate::hierarchy::NodeKey;

/// No child.
pub(crate) const NONE: u32 = u32::MAX;

/// The element quadtree of one patch.
#[derive(Debug, Clone, Default)]
pub(crate) struct Tree {
    /// Node keys; node 0 is the root; children are appended after their parent.
    pub keys: Vec<NodeKey>,
    /// Index of the first of four consecutive children, or [`NONE`].
    pub first_child: Vec<u32>,
    /// Radiosity, hierarchical form, `[(node·3 + ch)·n + a]`.
    pub b: Vec<f64>,
    /// Unshot radiosity, hierarchical form.
    pub db: Vec<f64>,
    /// Irradiance, hierarchical form.
    pub h: Vec<f64>,
    /// Natural push/pull: matrices per node (empty for precomputed).
    mats: Vec<Mats>,
    /// Real moments per node (`n` each), see [`TwoScale::moments`].
    moments: Vec<f64>,
    n: usize,
}

impl Tree {
    /// A root-only tree of `patch` with zero values (also a decoy).
    pub fn new(patch: usize, ts: &TwoScale<'_>) -> Self {
        let mut t = Self {
            n: ts.n(),
            ..Self::default()
        };
        t.push_node(NodeKey::root(patch), ts);
        t
    }

    fn push_node(&mut self, key: NodeKey, ts: &TwoScale<'_>) {
        let n = self.n;
        self.keys.push(key);
        self.first_child.push(NONE);
        for v in [&mut self.b, &mut self.db, &mut self.h] {
            v.extend(std::iter::repeat_n(0.0, 3 * n));
        }
        if ts.per_node() {
            self.mats.push(ts.mats(&key).into_owned());
        }
        let mut m = vec![0.0; n];
        ts.moments(&key, &mut m);
        self.moments.extend(m);
    }

    /// Number of nodes.
    pub fn len(&self) -> usize {
        self.keys.len()
    }

    /// Splits leaf `i` into four zero children.
    fn split(&mut self, i: usize, ts: &TwoScale<'_>) {
        debug_assert_eq!(self.first_child[i], NONE);
        self.first_child[i] = self.keys.len() as u32;
        let k = self.keys[i];
        for c in 0..4 {
            self.push_node(k.child(c), ts);
        }
    }

    /// The node of `key` (same patch, any level), creating it and its ancestors'
    /// siblings by splitting leaves on the way.
    pub fn find_or_create(&mut self, key: NodeKey, ts: &TwoScale<'_>) -> usize {
        let mut i = 0usize;
        for l in 1..=key.level {
            if self.first_child[i] == NONE {
                self.split(i, ts);
            }
            let shift = key.level - l;
            let (ix, iy) = (key.ix >> shift, key.iy >> shift);
            let c = ((iy & 1) * 2 + (ix & 1)) as usize;
            i = self.first_child[i] as usize + c;
        }
        debug_assert_eq!(self.keys[i], key);
        i
    }

    /// Push/pull matrices of node `i`.
    pub fn mats<'t>(&'t self, i: usize, ts: &'t TwoScale<'_>) -> Cow<'t, Mats> {
        if ts.per_node() {
            Cow::Borrowed(&self.mats[i])
        } else {
            ts.mats(&self.keys[i])
        }
    }

    /// `∫_{node ∩ real} φ_a dA` of node `i` (computed when the node was created).
    pub fn moments(&self, i: usize, out: &mut [f64]) {
        out[..self.n].copy_from_slice(&self.moments[i * self.n..][..self.n]);
    }

    /// Consistent form of a hierarchical-form quantity (push to the leaves, then pull
    /// to every node): Push/Pull-Residuals of VirtualMesh Algorithm 1.
    pub fn consistent(&self, q: &[f64], ts: &TwoScale<'_>) -> Vec<f64> {
        let n = self.n;
        let mut v = q.to_vec();
        // Push, parents first (children are stored after their parent).
        for i in 0..self.len() {
            let fc = self.first_child[i];
            if fc == NONE {
                continue;
            }
            let m = self.mats(i, ts);
            let parent: Vec<f64> = v[i * 3 * n..][..3 * n].to_vec();
            for c in 0..4 {
                let ci = fc as usize + c;
                for ch in 0..3 {
                    push_into(
                        &m,
                        n,
                        c,
                        &parent[ch * n..][..n],
                        &mut v[(ci * 3 + ch) * n..][..n],
                    );
                }
            }
        }
        // Pull, children first.
        for i in (0..self.len()).rev() {
            let fc = self.first_child[i];
            if fc == NONE {
                continue;
            }
            let m = self.mats(i, ts);
            let fc = fc as usize;
            for ch in 0..3 {
                let mut out = vec![0.0; n];
                let kids: [&[f64]; 4] = std::array::from_fn(|c| &v[((fc + c) * 3 + ch) * n..][..n]);
                pull_into(&m, n, kids, &mut out);
                v[(i * 3 + ch) * n..][..n].copy_from_slice(&out);
            }
        }
        v
    }

    /// `∫ q dA` per channel of a hierarchical-form quantity (W for radiosity).
    pub fn integral(&self, q: &[f64]) -> [f64; 3] {
        let n = self.n;
        let mut mom = [0.0; 16];
        let mut out = [0.0; 3];
        for i in 0..self.len() {
            let vals = &q[i * 3 * n..][..3 * n];
            if vals.iter().all(|&x| x == 0.0) {
                continue;
            }
            self.moments(i, &mut mom);
            for (ch, o) in out.iter_mut().enumerate() {
                *o += (0..n).map(|a| vals[ch * n + a] * mom[a]).sum::<f64>();
            }
        }
        out
    }

    /// Adds irradiance `hv` (`3 n` coefficients) at `key`: `H += hv`,
    /// `B += ρ hv`, `ΔB += ρ hv`. Returns the arriving power `∫ hv` and the reflected
    /// power `ρ ∫ hv` per channel (W).
    pub fn deposit(
        &mut self,
        key: NodeKey,
        hv: &[f64],
        rho: [f64; 3],
        ts: &TwoScale<'_>,
    ) -> ([f64; 3], [f64; 3]) {
        let n = self.n;
        let i = self.find_or_create(key, ts);
        let mut mom = [0.0; 16];
        self.moments(i, &mut mom);
        let mut arrived = [0.0; 3];
        let mut reflected = [0.0; 3];
        for ch in 0..3 {
            let o = (i * 3 + ch) * n;
            let mut p = 0.0;
            for a in 0..n {
                let v = hv[ch * n + a];
                self.h[o + a] += v;
                self.b[o + a] += rho[ch] * v;
                self.db[o + a] += rho[ch] * v;
                p += v * mom[a];
            }
            arrived[ch] = p;
            reflected[ch] = rho[ch] * p;
        }
        (arrived, reflected)
    }

    /// Copies a decoy's levels, residuals and subdivisions back (VirtualMesh §5.3): its
    /// nodes are created here and its hierarchical values added.
    pub fn absorb(&mut self, decoy: &Tree, ts: &TwoScale<'_>) {
        let n = self.n;
        for (j, key) in decoy.keys.iter().enumerate() {
            let i = self.find_or_create(*key, ts);
            for (dst, src) in [
                (&mut self.b, &decoy.b),
                (&mut self.db, &decoy.db),
                (&mut self.h, &decoy.h),
            ] {
                for (d, s) in dst[i * 3 * n..][..3 * n]
                    .iter_mut()
                    .zip(&src[j * 3 * n..][..3 * n])
                {
                    *d += s;
                }
            }
        }
    }

    /// Sets the unshot residual to zero (VirtualMesh Algorithm 1 line 12).
    pub fn clear_unshot(&mut self) {
        self.db.iter_mut().for_each(|v| *v = 0.0);
    }

    /// Bytes held (capacity estimate).
    pub fn bytes(&self) -> usize {
        use std::mem::size_of;
        self.keys.capacity() * size_of::<NodeKey>()
            + self.first_child.capacity() * 4
            + (self.b.capacity() + self.db.capacity() + self.h.capacity()) * 8
            + self.mats.iter().map(Mats::bytes).sum::<usize>()
            + self.mats.capacity() * size_of::<Mats>()
            + self.moments.capacity() * 8
    }
}

/// A shooter's consistent residual with the accuracy of every node's representation.
#[derive(Debug)]
pub(crate) struct Shooter<'t> {
    /// The shooter's tree (structure).
    pub tree: &'t Tree,
    /// Consistent `ΔB`, `[(node·3 + ch)·n + a]`.
    pub db: Vec<f64>,
    /// Per node: the largest over channels of the RMS deviation (W/m²) between the
    /// node's projection and the finest representation below it.
    pub delta: Vec<f64>,
}

impl<'t> Shooter<'t> {
    /// Push/pull of the tree's residual and the deviations (bottom-up, exact for
    /// orthonormal node functions: `‖f − P f‖² = Σ_c ‖f − P_c f‖² + ‖P_c f − push_c P f‖²`).
    pub fn new(tree: &'t Tree, ts: &TwoScale<'_>) -> Self {
        let n = tree.n;
        let db = tree.consistent(&tree.db, ts);
        let mut d2 = vec![[0.0f64; 3]; tree.len()];
        let mut delta = vec![0.0; tree.len()];
        for i in (0..tree.len()).rev() {
            let fc = tree.first_child[i];
            if fc == NONE {
                continue;
            }
            let m = tree.mats(i, ts);
            let mut acc = [0.0; 3];
            for c in 0..4 {
                let ci = fc as usize + c;
                for ch in 0..3 {
                    let mut pushed = vec![0.0; n];
                    push_into(&m, n, c, &db[(i * 3 + ch) * n..][..n], &mut pushed);
                    let cv = &db[(ci * 3 + ch) * n..][..n];
                    let e: f64 = pushed.iter().zip(cv).map(|(p, q)| (p - q) * (p - q)).sum();
                    acc[ch] += d2[ci][ch] + e;
                }
            }
            d2[i] = acc;
            let area = ts.area(&tree.keys[i]);
            delta[i] = acc.iter().fold(0.0f64, |a, &v| a.max((v / area).sqrt()));
        }
        Self { tree, db, delta }
    }
}
