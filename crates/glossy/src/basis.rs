//! The per-patch basis: non-standard 4D tensor products of Haar functions on
//! `[0,1]⁴ = (s, t) × (u₃, u₄)` (Glossy §3.4, Fig. 6 right; data layout §6.4).
//!
//! A node `(j, i₀, i₁, i₂, i₃)` is the dyadic cell `Π_a [iₐ2⁻ʲ, (iₐ+1)2⁻ʲ)` (axes: `s`,
//! `t` on the patch's support, `u₃`, `u₄` on the direction square). It carries the 15
//! wavelets of level `j` with that support; the root (`j = 0`) also carries the single
//! scaling function `φ` of `V⁰`. A function of type `τ ∈ 0..16` (bit `a` set: `ψ` on
//! axis `a`; `τ = 0` is `φ`) is constant on each of the node's 16 children: on child
//! `k` (bit `a` of `k`: upper half on axis `a`) it equals `H[τ][k]·4^{j+1}`, where
//! `H = h⊗h⊗h⊗h`-style products of wavelux-mra's Haar two-scale rows
//! (`h = (1, 1)/√2`, `g = (1, −1)/√2`), i.e. the 16-point Walsh–Hadamard matrix / 4.
//! `H` is orthogonal, so one [`HaarStep::analysis`] turns the 16 child-cell scaling
//! coefficients into the node's `φ` and 15 wavelet coefficients (the same step as
//! `wavelux_mra::sparse::analysis_step` with `D = 4`; a test checks the two agree).
//!
//! Every basis function is orthonormal in the *parameter* measure `du` on `[0,1]⁴`;
//! with the paper's inner product `⟨f|g⟩ = ∫ f g dy dω` (§2.3) its dual is
//! `b̄ = b/(A·J_ω)` (patch area `A`, direction-map Jacobian `J_ω`), so a coefficient is
//! the parameter-measure projection `ℓ = ∫ b L du`.

use wavelux_mra::{Alpert, Mra};

/// Wavelet types per node (`2⁴ − 1`).
pub const TYPES: usize = 15;
/// Children per node.
pub const CHILDREN: usize = 16;
/// Deepest level a tree may reach (cells of side `2⁻¹²`).
pub const MAX_LEVEL: u8 = 12;

/// A node of a patch's tree: level and integer position on each of the 4 axes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize)]
pub struct NodeKey {
    /// Level `j` (side `2⁻ʲ`).
    pub level: u8,
    /// Position `iₐ < 2ʲ` on the axes `s, t, u₃, u₄`.
    pub idx: [u16; 4],
}

impl NodeKey {
    /// The root `(0; 0, 0, 0, 0)`.
    pub const ROOT: Self = Self {
        level: 0,
        idx: [0; 4],
    };

    /// Child `k` (bit `a` of `k`: upper half on axis `a`).
    #[inline]
    #[must_use]
    pub fn child(&self, k: usize) -> Self {
        Self {
            level: self.level + 1,
            idx: std::array::from_fn(|a| 2 * self.idx[a] + ((k >> a) & 1) as u16),
        }
    }

    /// The parent (`None` for the root).
    #[must_use]
    pub fn parent(&self) -> Option<Self> {
        (self.level > 0).then(|| Self {
            level: self.level - 1,
            idx: self.idx.map(|i| i / 2),
        })
    }

    /// Which child of its parent this node is.
    #[must_use]
    pub fn slot(&self) -> usize {
        (0..4).map(|a| ((self.idx[a] & 1) as usize) << a).sum()
    }

    /// Side `2⁻ʲ` of the cell.
    #[inline]
    #[must_use]
    pub fn size(&self) -> f64 {
        0.5f64.powi(i32::from(self.level))
    }

    /// Lower corner of the cell.
    #[inline]
    #[must_use]
    pub fn lo(&self) -> [f64; 4] {
        let h = self.size();
        self.idx.map(|i| f64::from(i) * h)
    }

    /// Whether `u` lies in the (half-open, closed at 1) cell.
    #[must_use]
    pub fn contains(&self, u: [f64; 4]) -> bool {
        let h = self.size();
        (0..4).all(|a| {
            let lo = f64::from(self.idx[a]) * h;
            u[a] >= lo && (u[a] < lo + h || (u[a] <= 1.0 && lo + h >= 1.0))
        })
    }

    /// The child whose cell contains `u` (`u` inside this cell).
    #[must_use]
    pub fn child_of(&self, u: [f64; 4]) -> usize {
        let h = self.size();
        (0..4)
            .map(|a| {
                let mid = (f64::from(self.idx[a]) + 0.5) * h;
                usize::from(u[a] >= mid) << a
            })
            .sum()
    }

    /// The node of `level` whose cell contains `u ∈ [0,1]⁴`.
    #[must_use]
    pub fn containing(level: u8, u: [f64; 4]) -> Self {
        let n = 1u32 << level;
        Self {
            level,
            idx: u.map(|x| ((x * f64::from(n)) as u32).min(n - 1) as u16),
        }
    }

    /// The same spatial cell's position `(i₀, i₁)` and angular cell's `(i₂, i₃)`.
    #[must_use]
    pub fn split(&self) -> ([u16; 2], [u16; 2]) {
        ([self.idx[0], self.idx[1]], [self.idx[2], self.idx[3]])
    }
}

/// `‖b‖₁` of every basis function of level `j` (`4⁻ʲ`; `‖b‖₂ = 1`).
#[inline]
#[must_use]
pub fn l1_norm(level: u8) -> f64 {
    0.25f64.powi(i32::from(level))
}

/// `‖b‖_∞` of every basis function of level `j` (`4ʲ`).
#[inline]
#[must_use]
pub fn sup_norm(level: u8) -> f64 {
    4f64.powi(i32::from(level))
}

/// Whether type `τ` is constant in space (`φ` on `s` and `t`): the only types with a
/// non-zero spatial integral.
#[inline]
#[must_use]
pub fn spatially_constant(tau: usize) -> bool {
    tau & 3 == 0
}

/// Whether type `τ` is constant in direction (`φ` on `u₃` and `u₄`).
#[inline]
#[must_use]
pub fn angularly_constant(tau: usize) -> bool {
    tau & 12 == 0
}

/// The 4D Haar two-scale matrix `H[τ][k]` (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct HaarStep {
    h: [[f64; CHILDREN]; CHILDREN],
}

impl Default for HaarStep {
    fn default() -> Self {
        Self::new()
    }
}

impl HaarStep {
    /// Builds `H` from wavelux-mra's Haar rows.
    #[must_use]
    pub fn new() -> Self {
        let haar = Alpert::haar();
        let row = |w: bool| -> [f64; 2] {
            let r = if w {
                haar.wavelet_row(0, 0)
            } else {
                haar.scaling_row(0, 0)
            };
            match r {
                Ok(r) if r.coeffs.len() == 2 && r.start == 0 => [r.coeffs[0], r.coeffs[1]],
                // The Haar rows are (1, ±1)/√2 by definition (Ziegler (3.2)).
                _ => {
                    let s = std::f64::consts::FRAC_1_SQRT_2;
                    if w { [s, -s] } else { [s, s] }
                }
            }
        };
        let (hr, gr) = (row(false), row(true));
        let mut h = [[0.0; CHILDREN]; CHILDREN];
        for (t, ht) in h.iter_mut().enumerate() {
            for (k, v) in ht.iter_mut().enumerate() {
                *v = (0..4)
                    .map(|a| {
                        let r = if (t >> a) & 1 == 1 { &gr } else { &hr };
                        r[(k >> a) & 1]
                    })
                    .product();
            }
        }
        Self { h }
    }

    /// `H[τ][k]`.
    #[inline]
    #[must_use]
    pub fn at(&self, tau: usize, k: usize) -> f64 {
        self.h[tau][k]
    }

    /// The row of type `τ`.
    #[inline]
    #[must_use]
    pub fn row(&self, tau: usize) -> &[f64; CHILDREN] {
        &self.h[tau]
    }

    /// Coefficients `c[τ] = Σ_k H[τ][k] x[k]` of the node's 16 functions from its
    /// children's scaling coefficients.
    #[must_use]
    pub fn analysis(&self, x: &[f64; CHILDREN]) -> [f64; CHILDREN] {
        std::array::from_fn(|t| (0..CHILDREN).map(|k| self.h[t][k] * x[k]).sum())
    }

    /// Children's scaling coefficients `x[k] = Σ_τ H[τ][k] c[τ]` (inverse of
    /// [`HaarStep::analysis`]).
    #[must_use]
    pub fn synthesis(&self, c: &[f64; CHILDREN]) -> [f64; CHILDREN] {
        std::array::from_fn(|k| (0..CHILDREN).map(|t| self.h[t][k] * c[t]).sum())
    }

    /// Value of type `τ` of a level-`j` node on its child `k`: `H[τ][k]·4^{j+1}`.
    #[inline]
    #[must_use]
    pub fn value(&self, tau: usize, level: u8, k: usize) -> f64 {
        self.h[tau][k] * 4f64.powi(i32::from(level) + 1)
    }

    /// Value of type `τ` of `node` at `u` (0 outside the cell).
    #[must_use]
    pub fn eval(&self, node: &NodeKey, tau: usize, u: [f64; 4]) -> f64 {
        if !node.contains(u) {
            return 0.0;
        }
        self.value(tau, node.level, node.child_of(u))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use wavelux_mra::sparse::{SparseDetail, SparseLevel, analysis_step};

    #[test]
    fn step_is_orthogonal() {
        let h = HaarStep::new();
        for a in 0..16 {
            for b in 0..16 {
                let d: f64 = (0..16).map(|k| h.at(a, k) * h.at(b, k)).sum();
                let e = if a == b { 1.0 } else { 0.0 };
                assert!((d - e).abs() < 1e-15);
            }
        }
    }

    #[test]
    fn matches_the_sparse_4d_transform() {
        let h = HaarStep::new();
        let haar = Alpert::haar();
        let x: [f64; 16] = std::array::from_fn(|k| (k as f64 * 0.37).sin() + 0.1 * k as f64);
        let pairs: Vec<([usize; 4], f64)> = (0..16)
            .map(|k| (std::array::from_fn(|a| (k >> a) & 1), x[k]))
            .collect();
        let fine = SparseLevel::<4>::from_pairs(1, pairs);
        let mut coarse = SparseLevel::new(0);
        let mut detail = SparseDetail::new(0);
        analysis_step(&haar, &fine, &mut coarse, &mut detail).unwrap();
        let c = h.analysis(&x);
        assert!((c[0] - coarse.get(&[0; 4])).abs() < 1e-14);
        let d = detail.get(&[0; 4]).unwrap();
        for t in 1..16 {
            assert!((c[t] - d[t - 1]).abs() < 1e-14, "type {t}");
        }
    }

    #[test]
    fn functions_are_orthonormal_in_the_parameter_measure() {
        // Integrate products of all 16 functions of the root and of one child node by
        // their piecewise-constant values on the level-2 grid.
        let h = HaarStep::new();
        let nodes = [NodeKey::ROOT, NodeKey::ROOT.child(5)];
        let mut fs: Vec<(NodeKey, usize)> = Vec::new();
        for n in nodes {
            for t in 0..16 {
                if t == 0 && n.level > 0 {
                    continue;
                }
                fs.push((n, t));
            }
        }
        let cells = 4usize.pow(4);
        let vol = 0.25f64.powi(4);
        for (a, b) in fs.iter().flat_map(|a| fs.iter().map(move |b| (a, b))) {
            let mut s = 0.0;
            for c in 0..cells {
                let u: [f64; 4] =
                    std::array::from_fn(|ax| ((c >> (2 * ax)) & 3) as f64 * 0.25 + 0.125);
                s += h.eval(&a.0, a.1, u) * h.eval(&b.0, b.1, u) * vol;
            }
            let e = if a == b { 1.0 } else { 0.0 };
            assert!((s - e).abs() < 1e-12, "{a:?} {b:?}: {s}");
        }
    }

    proptest! {
        #[test]
        fn round_trip(x in proptest::array::uniform16(-10.0f64..10.0)) {
            let h = HaarStep::new();
            let y = h.synthesis(&h.analysis(&x));
            for k in 0..16 {
                prop_assert!((x[k] - y[k]).abs() < 1e-12);
            }
        }

        #[test]
        fn keys(level in 0u8..6, u in proptest::array::uniform4(0.0f64..1.0)) {
            let n = NodeKey::containing(level, u);
            prop_assert!(n.contains(u));
            let c = n.child(n.child_of(u));
            prop_assert!(c.contains(u));
            prop_assert_eq!(c.parent(), Some(n));
            prop_assert_eq!(n.child(c.slot()), c);
        }
    }
}
