//! Two-scale (push/pull) operators of the shooting solver's element trees
//! (VirtualMesh §5.2, eq. (4)–(5)).
//!
//! A node of level `m` on a patch carries the `k²` functions
//! `φ_a = ψ_a(local s, local t) / √A_m` with the *nominal* area `A_m = |S| 4^{-m}`
//! (the node's share of the support's area). Two variants:
//!
//! - [`PushPull::Precomputed`]: with an equal-area (constant-Jacobian) map the node
//!   functions are orthonormal in `L²(S)` and the push/pull coefficients are the
//!   level-independent two-scale matrices `M_c` of [`TreeBasis::child_matrix`]
//!   (VirtualMesh §5.2, "this means that the formula … reduces … to a single term");
//! - [`PushPull::Natural`]: with a varying Jacobian `J(s, t)` the functions are not
//!   orthonormal and §5.2's general formula applies per element and level:
//!   `H = A⁻¹ B` (pull) and `G = C⁻¹ D` (push) with the Gram matrices
//!   `A = ⟨φ^m, φ^m⟩_J` of the parent, `C = ⟨φ^{m+1}, φ^{m+1}⟩_J` of the child and the
//!   cross matrices `B = D = ⟨φ^m, φ^{m+1}⟩_J` on the child's cell, all integrated with
//!   a `gauss × gauss` Gauss–Legendre rule per child cell weighted by `J`. For a
//!   constant `J` they reproduce the precomputed matrices (to rounding, ~1e-15).
//!
//! Push is exact (a parent polynomial restricted to a child cell is a child
//! polynomial) in both variants; pull is the `J`-weighted `L²` projection. Transfer
//! blocks keep their receiver-side weights (the support's `area·h²`, VirtualMesh §4.2
//! "S is a receiver"); only real points count in the moments (energy).

use std::borrow::Cow;

use nalgebra::DMatrix;

use super::PushPull;
use crate::basis::TreeBasis;
use crate::error::SolverError;
use crate::hierarchy::NodeKey;
use crate::support::Patch;
use crate::system::cell_real_moments;

/// Push/pull matrices of one node and its four children (`n × n`, row-major,
/// `[a * n + b]` with `a` a parent function and `b` a child function):
/// `parent_a = Σ_c Σ_b pull[c][a·n+b] child_{c,b}` and
/// `child_{c,b} = Σ_a push[c][a·n+b] parent_a`.
#[derive(Debug, Clone, PartialEq)]
pub struct Mats {
    /// Pull (projection) matrices per child `c = cy·2 + cx`.
    pub pull: [Vec<f64>; 4],
    /// Push (exact restriction) matrices per child.
    pub push: [Vec<f64>; 4],
}

impl Mats {
    /// Bytes held.
    pub fn bytes(&self) -> usize {
        self.pull
            .iter()
            .chain(self.push.iter())
            .map(|v| v.capacity() * 8)
            .sum()
    }
}

/// The push/pull operators of a solve.
#[derive(Debug)]
pub struct TwoScale<'a> {
    basis: &'a TreeBasis,
    patches: &'a [Patch],
    n: usize,
    shared: Mats,
    /// Gauss–Legendre points and weights on `[0, 1]` (natural variant only).
    natural: Option<(Vec<f64>, Vec<f64>)>,
}

/// The Jacobian `|∂χ/∂s × ∂χ/∂t|` of a patch's map at `(s, t)` (world area per unit
/// parameter area): constant for equal-area maps.
fn jacobian(p: &Patch, s: f64, t: f64) -> f64 {
    p.support.jacobian(s, t)
}

impl<'a> TwoScale<'a> {
    /// The operators of a variant.
    ///
    /// # Errors
    /// [`SolverError::Dependency`] if the Gauss rule cannot be built.
    pub fn new(
        kind: PushPull,
        basis: &'a TreeBasis,
        patches: &'a [Patch],
    ) -> Result<Self, SolverError> {
        let n = basis.n();
        let shared = Mats {
            pull: std::array::from_fn(|c| basis.child_matrix(c).to_vec()),
            push: std::array::from_fn(|c| basis.child_matrix(c).to_vec()),
        };
        let natural = match kind {
            PushPull::Precomputed => None,
            PushPull::Natural { gauss } => {
                let g = wavelux_quadrature::GaussLegendre::new(gauss).map_err(|e| {
                    SolverError::Dependency {
                        what: "quadrature",
                        message: e.to_string(),
                    }
                })?;
                Some(g.unit())
            }
        };
        Ok(Self {
            basis,
            patches,
            n,
            shared,
            natural,
        })
    }

    /// Functions per node.
    pub fn n(&self) -> usize {
        self.n
    }

    /// Whether the operators are recomputed per node (natural variant).
    pub fn per_node(&self) -> bool {
        self.natural.is_some()
    }

    /// Nominal area `|S| 4^{-level}` of a node.
    pub fn area(&self, key: &NodeKey) -> f64 {
        self.patches[key.patch as usize].support.area * 0.25f64.powi(key.level as i32)
    }

    /// The push/pull matrices of a node: shared (precomputed) or computed from Gram
    /// matrices (natural).
    pub fn mats(&self, key: &NodeKey) -> Cow<'_, Mats> {
        match &self.natural {
            None => Cow::Borrowed(&self.shared),
            Some((x, w)) => Cow::Owned(self.gram_mats(key, x, w)),
        }
    }

    /// `∫_{node ∩ real} φ_a dA` for every function `a` (units: √m²): only real points
    /// emit, receive and absorb (VirtualMesh §4.2); the same rule as
    /// [`crate::System`]'s leaf moments.
    pub fn moments(&self, key: &NodeKey, out: &mut [f64]) {
        let p = &self.patches[key.patch as usize];
        let (_, m, _) = cell_real_moments(&p.support, self.basis, &key.region(), self.area(key));
        out[..self.n].copy_from_slice(&m);
    }

    fn gram_mats(&self, key: &NodeKey, x: &[f64], w: &[f64]) -> Mats {
        let n = self.n;
        let p = &self.patches[key.patch as usize];
        let r = key.region();
        let ap = self.area(key);
        let ac = 0.25 * ap;
        let hc = 0.5 * r.h;
        let mut gp = vec![0.0; n * n];
        let mut gc: [Vec<f64>; 4] = std::array::from_fn(|_| vec![0.0; n * n]);
        let mut cross: [Vec<f64>; 4] = std::array::from_fn(|_| vec![0.0; n * n]);
        let mut vp = [0.0; 16];
        let mut vc = [0.0; 16];
        for c in 0..4 {
            let (cs0, ct0) = (r.s0 + hc * (c % 2) as f64, r.t0 + hc * (c / 2) as f64);
            for (tj, wj) in x.iter().zip(w) {
                for (si, wi) in x.iter().zip(w) {
                    let (s, t) = (cs0 + hc * si, ct0 + hc * tj);
                    let jw = wi * wj * hc * hc * jacobian(p, s, t);
                    self.basis
                        .eval((s - r.s0) / r.h, (t - r.t0) / r.h, &mut vp[..n]);
                    self.basis.eval(*si, *tj, &mut vc[..n]);
                    for a in 0..n {
                        for b in 0..n {
                            gp[a * n + b] += jw * vp[a] * vp[b] / ap;
                            gc[c][a * n + b] += jw * vc[a] * vc[b] / ac;
                            cross[c][a * n + b] += jw * vp[a] * vc[b] / (ap * ac).sqrt();
                        }
                    }
                }
            }
        }
        let inv = |g: &[f64]| -> Option<DMatrix<f64>> {
            let m = DMatrix::from_row_slice(n, n, g);
            m.cholesky().map(|c| c.inverse())
        };
        let (Some(ip), Some(ic)) = (
            inv(&gp),
            gc.iter().map(|g| inv(g)).collect::<Option<Vec<_>>>(),
        ) else {
            // A singular Gram matrix needs J = 0 on a whole cell (never for the
            // supports built today); the equal-area operators are the limit.
            return self.shared.clone();
        };
        let mut pull: [Vec<f64>; 4] = std::array::from_fn(|_| vec![0.0; n * n]);
        let mut push: [Vec<f64>; 4] = std::array::from_fn(|_| vec![0.0; n * n]);
        for c in 0..4 {
            let bm = DMatrix::from_row_slice(n, n, &cross[c]);
            // pull_c = A_p⁻¹ B_c  (parent a from child b).
            let h = &ip * &bm;
            // push_c: child = C_c⁻¹ B_cᵀ parent, stored transposed ([a parent][b child]).
            let g = &ic[c] * bm.transpose();
            for a in 0..n {
                for b in 0..n {
                    pull[c][a * n + b] = h[(a, b)];
                    push[c][a * n + b] = g[(b, a)];
                }
            }
        }
        Mats { pull, push }
    }
}

/// `out += Σ_c pull_c · child_c` for one channel block of `n` values per child.
pub(crate) fn pull_into(m: &Mats, n: usize, children: [&[f64]; 4], out: &mut [f64]) {
    for (c, cv) in children.iter().enumerate() {
        let pm = &m.pull[c];
        for a in 0..n {
            let mut s = 0.0;
            for b in 0..n {
                s += pm[a * n + b] * cv[b];
            }
            out[a] += s;
        }
    }
}

/// `out += push_c · parent` for one channel block.
pub(crate) fn push_into(m: &Mats, n: usize, c: usize, parent: &[f64], out: &mut [f64]) {
    let pm = &m.push[c];
    for b in 0..n {
        let mut s = 0.0;
        for a in 0..n {
            s += pm[a * n + b] * parent[a];
        }
        out[b] += s;
    }
}
