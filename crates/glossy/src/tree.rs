//! Coefficient storage (Glossy §6.4): per patch a tree of nodes keyed by
//! [`NodeKey`]; every basis function (each patch's root `φ` and the 15 wavelets of
//! every node) has a global id into flat arrays of six bands — red, green, blue
//! radiance and red, green, blue importance — for the current solution and for the
//! emitted terms `L_e`, `Γ_e`. Ids are appended as nodes are created, never moved, so
//! links can hold them.

use std::collections::HashMap;

use crate::basis::{CHILDREN, HaarStep, NodeKey, TYPES};

/// Bands per function: RGB radiance then RGB importance.
pub const BANDS: usize = 6;
/// The radiance bands.
pub const RADIANCE: std::ops::Range<usize> = 0..3;
/// The importance bands.
pub const IMPORTANCE: std::ops::Range<usize> = 3..6;

/// Which basis function a global id is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct FnRef {
    /// Patch.
    pub patch: u32,
    /// Node index in the patch's tree (0 = root).
    pub node: u32,
    /// Type `τ` (0: the root's `φ`; 1..=15 wavelets).
    pub tau: u8,
}

/// The tree of one patch.
#[derive(Debug, Clone, Default)]
pub struct PatchTree {
    /// Node keys (index 0 is the root).
    pub keys: Vec<NodeKey>,
    index: HashMap<NodeKey, u32>,
    /// Global id of wavelet type 1 of each node (type `τ` at `base + τ − 1`).
    pub base: Vec<u32>,
    /// Global id of the root's `φ`.
    pub root_phi: u32,
}

impl PatchTree {
    /// Node index of `key`, if present.
    #[must_use]
    pub fn find(&self, key: &NodeKey) -> Option<u32> {
        self.index.get(key).copied()
    }

    /// Number of nodes.
    #[must_use]
    pub fn len(&self) -> usize {
        self.keys.len()
    }

    /// Whether the tree has no node (never after construction: the root exists).
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.keys.is_empty()
    }

    /// Global id of type `τ` of node `node`.
    #[inline]
    #[must_use]
    pub fn id(&self, node: u32, tau: usize) -> u32 {
        if tau == 0 {
            self.root_phi
        } else {
            self.base[node as usize] + tau as u32 - 1
        }
    }

    /// All global ids of this patch (root `φ` first, then node by node).
    pub fn ids(&self) -> impl Iterator<Item = u32> + '_ {
        std::iter::once(self.root_phi).chain(
            self.base
                .iter()
                .flat_map(|&b| (0..TYPES as u32).map(move |t| b + t)),
        )
    }
}

/// Every patch's tree and the coefficient arrays.
#[derive(Debug, Clone, Default)]
pub struct Functions {
    /// One tree per patch.
    pub trees: Vec<PatchTree>,
    /// Current coefficients per global id.
    pub value: Vec<[f64; BANDS]>,
    /// Emitted coefficients (`L_e`, `Γ_e`) per global id.
    pub emit: Vec<[f64; BANDS]>,
    /// What each global id is.
    pub owner: Vec<FnRef>,
}

impl Functions {
    /// Root nodes for `patches` patches.
    #[must_use]
    pub fn new(patches: usize) -> Self {
        let mut f = Self::default();
        for p in 0..patches {
            let root_phi = f.push(FnRef {
                patch: p as u32,
                node: 0,
                tau: 0,
            });
            f.trees.push(PatchTree {
                root_phi,
                ..PatchTree::default()
            });
            f.add_node(p, NodeKey::ROOT);
        }
        f
    }

    fn push(&mut self, r: FnRef) -> u32 {
        let id = self.value.len() as u32;
        self.value.push([0.0; BANDS]);
        self.emit.push([0.0; BANDS]);
        self.owner.push(r);
        id
    }

    fn add_node(&mut self, patch: usize, key: NodeKey) -> u32 {
        let node = self.trees[patch].keys.len() as u32;
        let base = self.value.len() as u32;
        for t in 1..=TYPES {
            self.push(FnRef {
                patch: patch as u32,
                node,
                tau: t as u8,
            });
        }
        let tree = &mut self.trees[patch];
        tree.keys.push(key);
        tree.index.insert(key, node);
        tree.base.push(base);
        node
    }

    /// The node of `key` on `patch`, created (with its missing ancestors) if absent.
    pub fn node(&mut self, patch: usize, key: NodeKey) -> u32 {
        if let Some(n) = self.trees[patch].find(&key) {
            return n;
        }
        if let Some(parent) = key.parent() {
            self.node(patch, parent);
        }
        self.add_node(patch, key)
    }

    /// Number of functions.
    #[must_use]
    pub fn len(&self) -> usize {
        self.value.len()
    }

    /// Whether there are no functions.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.value.is_empty()
    }

    /// The key of a function's node.
    #[must_use]
    pub fn key(&self, id: u32) -> NodeKey {
        let r = self.owner[id as usize];
        self.trees[r.patch as usize].keys[r.node as usize]
    }

    /// Reconstructs bands `bands` of `patch`'s expansion at `u ∈ [0,1]⁴` (descending
    /// the tree along `u`; O(depth · 15)).
    #[must_use]
    pub fn eval(
        &self,
        haar: &HaarStep,
        patch: usize,
        u: [f64; 4],
        bands: std::ops::Range<usize>,
        values: &[[f64; BANDS]],
    ) -> [f64; 3] {
        let tree = &self.trees[patch];
        let mut out = [0.0; 3];
        let root = &values[tree.root_phi as usize];
        for (o, b) in out.iter_mut().zip(bands.clone()) {
            *o = root[b];
        }
        let mut node = 0u32;
        loop {
            let key = tree.keys[node as usize];
            let k = key.child_of(u);
            let scale = 4f64.powi(i32::from(key.level) + 1);
            let base = tree.base[node as usize] as usize;
            for t in 1..CHILDREN {
                let h = haar.at(t, k) * scale;
                if h == 0.0 {
                    continue;
                }
                let v = &values[base + t - 1];
                for (o, b) in out.iter_mut().zip(bands.clone()) {
                    *o += h * v[b];
                }
            }
            match tree.find(&key.child(k)) {
                Some(c) => node = c,
                None => break,
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nodes_get_ancestors_and_stable_ids() {
        let mut f = Functions::new(2);
        assert_eq!(f.len(), 2 * 16);
        let deep = NodeKey::ROOT.child(3).child(7).child(15);
        let n = f.node(1, deep);
        assert_eq!(f.trees[1].len(), 4);
        assert_eq!(f.trees[1].keys[n as usize], deep);
        let id = f.trees[1].id(n, 5);
        assert_eq!(f.key(id), deep);
        assert_eq!(f.owner[id as usize].tau, 5);
        assert_eq!(f.node(1, deep), n);
    }

    #[test]
    fn eval_reconstructs_a_piecewise_constant_function() {
        // Put the analysis of 16 child values on the root and check point values.
        let haar = HaarStep::new();
        let mut f = Functions::new(1);
        let x: [f64; 16] = std::array::from_fn(|k| k as f64 - 3.0);
        // Scaling coefficients of the children: value × sqrt(volume) = v · 4^{-1}.
        let c = haar.analysis(&x.map(|v| v / 4.0));
        let t = &f.trees[0].clone();
        f.value[t.root_phi as usize][0] = c[0];
        for tau in 1..16 {
            f.value[t.id(0, tau) as usize][0] = c[tau];
        }
        for k in 0..16 {
            let u: [f64; 4] = std::array::from_fn(|a| if (k >> a) & 1 == 1 { 0.75 } else { 0.25 });
            let v = f.eval(&haar, 0, u, 0..3, &f.value)[0];
            assert!((v - x[k]).abs() < 1e-12, "{k}: {v}");
        }
    }
}
