//! Test systems: radiosity-like `(I − K) x = b` with `K = R F`, `F` built from a
//! symmetric coupling `W` (reciprocity `A_i F_ij = A_j F_ji`) with row sums ≤ 1.
#![allow(dead_code)]

use nalgebra::{DMatrix, DVector};
use proptest::prelude::*;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;
use wavelux_linear::DenseOperator;

/// A radiosity-like test system.
#[derive(Debug, Clone)]
pub struct Radiosity {
    pub n: usize,
    pub areas: Vec<f64>,
    pub rho: Vec<f64>,
    /// Form-factor-like matrix, rows sum to ≤ 1, zero diagonal.
    pub f: DMatrix<f64>,
    /// `K = diag(ρ) F`.
    pub k: DMatrix<f64>,
    pub b: Vec<f64>,
}

impl Radiosity {
    /// Builds from areas, strictly-upper coupling weights (row-major over i<j),
    /// a row-sum scale in (0, 1], reflectances and emission.
    pub fn build(areas: Vec<f64>, upper: &[f64], scale: f64, rho: Vec<f64>, b: Vec<f64>) -> Self {
        let n = areas.len();
        let mut w = DMatrix::zeros(n, n);
        let mut t = 0;
        for i in 0..n {
            for j in i + 1..n {
                w[(i, j)] = upper[t];
                w[(j, i)] = upper[t];
                t += 1;
            }
        }
        let mut f = DMatrix::zeros(n, n);
        for i in 0..n {
            for j in 0..n {
                f[(i, j)] = w[(i, j)] / areas[i];
            }
        }
        let max_row = (0..n)
            .map(|i| f.row(i).sum())
            .fold(0.0f64, f64::max)
            .max(1e-300);
        f *= scale / max_row;
        let k = DMatrix::from_diagonal(&DVector::from_vec(rho.clone())) * &f;
        Self {
            n,
            areas,
            rho,
            f,
            k,
            b,
        }
    }

    /// Deterministic random system from a seed.
    pub fn seeded(seed: u64, n: usize, rho_lo: f64, rho_hi: f64) -> Self {
        let mut rng = Pcg64::seed_from_u64(seed);
        let areas: Vec<f64> = (0..n).map(|_| rng.random_range(0.5..2.0)).collect();
        let upper: Vec<f64> = (0..n * (n - 1) / 2)
            .map(|_| rng.random_range(0.0..1.0))
            .collect();
        let rho: Vec<f64> = (0..n)
            .map(|_| {
                if rho_lo == rho_hi {
                    rho_lo
                } else {
                    rng.random_range(rho_lo..rho_hi)
                }
            })
            .collect();
        let mut b: Vec<f64> = (0..n)
            .map(|i| {
                if i % 4 == 0 {
                    rng.random_range(0.5..1.0)
                } else {
                    0.0
                }
            })
            .collect();
        b[0] = 1.0;
        Self::build(areas, &upper, 1.0, rho, b)
    }

    pub fn k_op(&self) -> DenseOperator {
        DenseOperator::new(self.k.clone()).unwrap()
    }

    pub fn m(&self) -> DMatrix<f64> {
        DMatrix::identity(self.n, self.n) - &self.k
    }

    /// Direct solution by LU.
    pub fn direct(&self) -> Vec<f64> {
        direct_solve(&self.m(), &self.b)
    }

    /// The symmetrised SPD system `D_A R⁻¹ M` (Ziegler §2.3.1) and its right-hand side.
    pub fn symmetrised(&self) -> (DMatrix<f64>, Vec<f64>) {
        let d = DMatrix::from_diagonal(&DVector::from_iterator(
            self.n,
            self.areas.iter().zip(&self.rho).map(|(a, r)| a / r),
        ));
        let s = &d * self.m();
        let rhs = (0..self.n)
            .map(|i| self.areas[i] / self.rho[i] * self.b[i])
            .collect();
        (s, rhs)
    }
}

pub fn direct_solve(a: &DMatrix<f64>, b: &[f64]) -> Vec<f64> {
    a.clone()
        .lu()
        .solve(&DVector::from_column_slice(b))
        .expect("test systems are non-singular")
        .as_slice()
        .to_vec()
}

pub fn rel_err(x: &[f64], y: &[f64]) -> f64 {
    let d: f64 = x.iter().zip(y).map(|(a, b)| (a - b) * (a - b)).sum();
    let n: f64 = y.iter().map(|v| v * v).sum();
    (d / n).sqrt()
}

/// Proptest strategy for radiosity-like systems: `n ∈ [2, 14]`, areas in
/// `[0.5, 2]`, symmetric couplings, max row sum of `F` in `[0.3, 1]`,
/// `ρ ∈ (0.01, 0.95)`, emission in `[0, 1]` with at least one light.
pub fn radiosity_strategy() -> impl Strategy<Value = Radiosity> {
    (2usize..=14).prop_flat_map(|n| {
        (
            prop::collection::vec(0.5f64..2.0, n),
            prop::collection::vec(prop_oneof![Just(0.0), 0.0f64..1.0], n * (n - 1) / 2),
            0.3f64..=1.0,
            prop::collection::vec(0.01f64..0.95, n),
            prop::collection::vec(prop_oneof![Just(0.0), 0.0f64..1.0], n),
            0.1f64..1.0,
        )
            .prop_map(|(areas, upper, scale, rho, mut b, light)| {
                b[0] = light;
                Radiosity::build(areas, &upper, scale, rho, b)
            })
    })
}

impl Radiosity {
    /// A closed enclosure: areas are the row sums of the symmetric coupling `W`, so
    /// `F_ij = W_ij / A_i` has rows summing to exactly 1 and reciprocity holds
    /// (`A_i F_ij = A_j F_ji`), as for the form factors of a closed scene.
    pub fn closed(upper: &[f64], rho: Vec<f64>, b: Vec<f64>) -> Self {
        let n = rho.len();
        let mut w = DMatrix::zeros(n, n);
        let mut t = 0;
        for i in 0..n {
            for j in i + 1..n {
                w[(i, j)] = upper[t];
                w[(j, i)] = upper[t];
                t += 1;
            }
        }
        let areas: Vec<f64> = (0..n).map(|i| w.row(i).sum()).collect();
        let mut f = DMatrix::zeros(n, n);
        for i in 0..n {
            for j in 0..n {
                f[(i, j)] = w[(i, j)] / areas[i];
            }
        }
        let k = DMatrix::from_diagonal(&DVector::from_vec(rho.clone())) * &f;
        Self {
            n,
            areas,
            rho,
            f,
            k,
            b,
        }
    }
}

impl Radiosity {
    /// Deterministic random closed enclosure with constant reflectance `rho`.
    pub fn seeded_closed(seed: u64, n: usize, rho: f64) -> Self {
        let mut rng = Pcg64::seed_from_u64(seed);
        let upper: Vec<f64> = (0..n * (n - 1) / 2)
            .map(|_| rng.random_range(0.05..1.0))
            .collect();
        let mut b: Vec<f64> = (0..n)
            .map(|i| {
                if i % 4 == 0 {
                    rng.random_range(0.5..1.0)
                } else {
                    0.0
                }
            })
            .collect();
        b[0] = 1.0;
        Self::closed(&upper, vec![rho; n], b)
    }
}

impl Radiosity {
    /// The same closed geometry with other reflectances.
    pub fn closed_from(other: &Radiosity, rho: Vec<f64>) -> Self {
        let k = DMatrix::from_diagonal(&DVector::from_vec(rho.clone())) * &other.f;
        Self {
            n: other.n,
            areas: other.areas.clone(),
            rho,
            f: other.f.clone(),
            k,
            b: other.b.clone(),
        }
    }
}

/// Proptest strategy for closed enclosures (rows of `F` sum to 1): `n ∈ [3, 14]`,
/// couplings in `[0.05, 1]` (every patch sees every other), `ρ ∈ (0.01, 0.95)`.
pub fn closed_radiosity_strategy() -> impl Strategy<Value = Radiosity> {
    (3usize..=14).prop_flat_map(|n| {
        (
            prop::collection::vec(0.05f64..1.0, n * (n - 1) / 2),
            prop::collection::vec(0.01f64..0.95, n),
            prop::collection::vec(prop_oneof![Just(0.0), 0.0f64..1.0], n),
            0.1f64..1.0,
        )
            .prop_map(|(upper, rho, mut b, light)| {
                b[0] = light;
                Radiosity::closed(&upper, rho, b)
            })
    })
}
