//! Two-dimensional tree bases on the unit square built from a one-dimensional
//! `wavelux-mra` MRA with `k` functions per dyadic cell (Alpert's `M_k`: Haar = `M_1`,
//! `M_2`, `M_3`; Ziegler §3.1.1–3.1.2).
//!
//! A quadtree node (cell of level `j`) carries the `k²` tensor scaling functions
//! `ψ_a(s) ψ_b(t)` of its cell, orthonormal on the cell and made orthonormal in
//! `L²(S)` by `1/√(cell area)` (Ziegler §3.3.1). The two-scale relation
//! `φ_{j,a} = Σ_b h_{a,b} φ_{j+1,b}` (Ziegler eq. (2.10)) gives, per child cell `c`,
//! a `k² × k²` matrix `M_c` with `parent_a = Σ_c Σ_b M_c[a][b] child_{c,b}` (pull,
//! projection) and `child_{c,b} += Σ_a M_c[a][b] parent_a` (push, reconstruction) —
//! VirtualMesh §5.2's push/pull.
//!
//! # Correspondence with the non-standard wavelet representation
//!
//! The 2D non-standard basis of a cell is its `k²` scaling functions plus `3k²`
//! wavelets; they span the same space as the `4k²` scaling functions of the four
//! children. A link between cells `(p, q)` of the same level that is *refined* is
//! replaced by the 16 child links, whose `(4k²)²` scaling coefficients are an
//! orthogonal change of basis of the pair's `(4k²)²` non-standard coefficients:
//! `(k²)²` scaling–scaling ones (`⟨Tφ, φ⟩`, kept by the parent link) and
//! `15 (k²)²` that involve at least one wavelet (Ziegler eq. (2.15)). Ziegler calls the
//! 15 (or, on level 0, 16) form factors of a cell pair a *link* (§3.3.3); our count of
//! those is [`crate::Statistics::nonstandard_links`].

use wavelux_mra::{Alpert, Mra};

use crate::error::SolverError;

/// Which basis the solver uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum BasisKind {
    /// Piecewise constants (`M_1`), one vanishing moment.
    Haar,
    /// Alpert multiwavelets `M_k` with `k` functions per cell and `k` vanishing
    /// moments (`k = 2` is Ziegler's "MW", `k = 3` VirtualMesh's `M_3`).
    Multiwavelet(usize),
    /// Cohen–Daubechies–Vial D4 on the interval (Ziegler §3.1.3). Not tree
    /// structured: solved by [`crate::cdv`] (not a [`TreeBasis`]).
    Cdv,
}

impl BasisKind {
    /// Short name ("Haar", "M2", "M3", "CDV").
    pub fn name(&self) -> String {
        match self {
            Self::Haar => "Haar".into(),
            Self::Multiwavelet(k) => format!("M{k}"),
            Self::Cdv => "CDV".into(),
        }
    }
}

/// A 2D tree basis: `k` functions per cell and axis, two-scale child matrices and
/// point evaluation on the unit cell.
#[derive(Debug, Clone)]
pub struct TreeBasis {
    kind: BasisKind,
    mra: Alpert,
    k: usize,
    /// `child[c]`: `n × n` row-major, `[a * n + b]` (parent `a`, child function `b`),
    /// children `c = cy * 2 + cx`.
    child: [Vec<f64>; 4],
    /// `∫_{[0,1]²} ψ_a` for each 2D index `a`.
    integrals: Vec<f64>,
}

impl TreeBasis {
    /// The basis of a kind.
    ///
    /// # Errors
    /// [`SolverError::UnsupportedBasis`] for CDV or `M_k` with `k ∉ 1..=4`.
    pub fn new(kind: BasisKind) -> Result<Self, SolverError> {
        let k = match kind {
            BasisKind::Haar => 1,
            BasisKind::Multiwavelet(k) if (1..=4).contains(&k) => k,
            _ => return Err(SolverError::UnsupportedBasis(kind.name())),
        };
        let mra = Alpert::new(k).map_err(|e| SolverError::Dependency {
            what: "mra",
            message: e.to_string(),
        })?;
        let n = k * k;
        // 1D rows h[a][half*k + b].
        let mut h = vec![0.0; k * 2 * k];
        for a in 0..k {
            let row = mra.scaling_row(0, a).map_err(|e| SolverError::Dependency {
                what: "mra",
                message: e.to_string(),
            })?;
            for (j, &v) in row.coeffs.iter().enumerate() {
                let l = row.start + j;
                if l < 2 * k {
                    h[a * 2 * k + l] = v;
                }
            }
        }
        let mut child: [Vec<f64>; 4] = std::array::from_fn(|_| vec![0.0; n * n]);
        for (c, m) in child.iter_mut().enumerate() {
            let (cx, cy) = (c % 2, c / 2);
            for a1 in 0..k {
                for a2 in 0..k {
                    for b1 in 0..k {
                        for b2 in 0..k {
                            m[(a2 * k + a1) * n + (b2 * k + b1)] =
                                h[a1 * 2 * k + cx * k + b1] * h[a2 * 2 * k + cy * k + b2];
                        }
                    }
                }
            }
        }
        // Integrals by a Gauss rule exact for degree k - 1.
        let g = wavelux_quadrature::GaussLegendre::new(k.max(1)).map_err(|e| {
            SolverError::Dependency {
                what: "quadrature",
                message: e.to_string(),
            }
        })?;
        let (x, w) = g.unit();
        let mut i1 = vec![0.0; k];
        for (a, v) in i1.iter_mut().enumerate() {
            for (xi, wi) in x.iter().zip(&w) {
                *v += wi * mra.eval_scaling(0, a, *xi).unwrap_or(0.0);
            }
        }
        let mut integrals = vec![0.0; n];
        for a1 in 0..k {
            for a2 in 0..k {
                integrals[a2 * k + a1] = i1[a1] * i1[a2];
            }
        }
        Ok(Self {
            kind,
            mra,
            k,
            child,
            integrals,
        })
    }

    /// The kind.
    pub fn kind(&self) -> BasisKind {
        self.kind
    }

    /// Functions per cell and axis.
    pub fn k(&self) -> usize {
        self.k
    }

    /// Functions per cell, `k²`.
    pub fn n(&self) -> usize {
        self.k * self.k
    }

    /// Vanishing moments `ν = k` of the wavelets.
    pub fn vanishing_moments(&self) -> usize {
        self.mra.vanishing_moments()
    }

    /// Two-scale matrix of child `c = cy·2 + cx` (`n × n`, `[parent * n + child]`).
    pub fn child_matrix(&self, c: usize) -> &[f64] {
        &self.child[c]
    }

    /// `∫ ψ_a` over the unit cell.
    pub fn integrals(&self) -> &[f64] {
        &self.integrals
    }

    /// 1D values `ψ_a(x)`, `a < k`, at `x ∈ [0,1]` (clamped). Alpert's level-0
    /// scaling functions are the orthonormal shifted Legendre polynomials
    /// `√(2a+1) P_a(2x − 1)`: all `k` come from one three-term recurrence (the one
    /// `wavelux-mra` evaluates them with, so the values are identical).
    pub fn eval_1d(&self, x: f64, out: &mut [f64]) {
        let x = if x.is_finite() {
            x.clamp(0.0, 1.0)
        } else {
            0.5
        };
        let m = out.len().min(self.k);
        wavelux_mra::poly::shifted_legendre_all(x, &mut out[..m]);
    }

    /// 2D values `ψ_{a}(s, t)` (index `a = a_t·k + a_s`) at a point of the unit cell.
    pub fn eval(&self, s: f64, t: f64, out: &mut [f64]) {
        let k = self.k;
        let mut es = [0.0; 8];
        let mut et = [0.0; 8];
        self.eval_1d(s, &mut es[..k]);
        self.eval_1d(t, &mut et[..k]);
        for a2 in 0..k {
            for a1 in 0..k {
                out[a2 * k + a1] = es[a1] * et[a2];
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The recurrence in `eval_1d` gives exactly the values of `wavelux-mra`'s
    /// Alpert scaling functions (level 0), for every tree basis and many points.
    #[test]
    fn eval_1d_is_the_mra_scaling_function() {
        for kind in [
            BasisKind::Haar,
            BasisKind::Multiwavelet(2),
            BasisKind::Multiwavelet(3),
            BasisKind::Multiwavelet(4),
        ] {
            let b = TreeBasis::new(kind).unwrap();
            let mut v = [0.0; 4];
            for i in 0..=1000 {
                let x = i as f64 / 1000.0;
                b.eval_1d(x, &mut v[..b.k()]);
                for a in 0..b.k() {
                    let m = b.mra.eval_scaling(0, a, x).unwrap();
                    assert_eq!(v[a].to_bits(), m.to_bits(), "{kind:?} a={a} x={x}");
                }
            }
        }
    }
}
