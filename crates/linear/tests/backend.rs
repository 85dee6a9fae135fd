//! The matrix–vector backend contract's CPU side: `Matrix` validation, the reference
//! products (dense and block-sparse, transposes, interleaved right-hand sides) against
//! independent computations, and `BackendOperator` (device errors become NaN and a
//! kept error, never a panic).

use nalgebra::DMatrix;
use proptest::prelude::*;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;
use wavelux_linear::backend::{
    BackendOperator, Bsr, CpuMatVec, MatVecBackend, MatVecStats, Matrix, PreparedMatVec,
};
use wavelux_linear::{LinearError, Operator, SolverOptions, gmres};

/// A random BSR matrix with small integer values (so every product is exact in f64),
/// some empty block rows, and its dense expansion (row-major).
fn random_bsr(seed: u64, (r, c): (usize, usize), (br, bc): (usize, usize)) -> (Bsr, Vec<f64>) {
    let mut rng = Pcg64::seed_from_u64(seed);
    let mut row_ptr = vec![0];
    let mut col_idx = Vec::new();
    let mut values = Vec::new();
    let (rows, cols) = (br * r, bc * c);
    let mut dense = vec![0.0; rows * cols];
    for i in 0..br {
        if i % 4 != 3 {
            for j in 0..bc {
                if rng.random_range(0.0..1.0) < 0.4 {
                    col_idx.push(j);
                    for a in 0..r {
                        for b in 0..c {
                            let v = f64::from(rng.random_range(-8i32..9));
                            values.push(v);
                            dense[(i * r + a) * cols + j * c + b] = v;
                        }
                    }
                }
            }
        }
        row_ptr.push(col_idx.len());
    }
    (
        Bsr::new((r, c), (br, bc), row_ptr, col_idx, values).unwrap(),
        dense,
    )
}

fn dense_product(rows: usize, cols: usize, a: &[f64], k: usize, x: &[f64]) -> Vec<f64> {
    let mut y = vec![0.0; rows * k];
    for i in 0..rows {
        for l in 0..k {
            y[i * k + l] = (0..cols).map(|j| a[i * cols + j] * x[j * k + l]).sum();
        }
    }
    y
}

fn int_vec(seed: u64, n: usize) -> Vec<f64> {
    let mut rng = Pcg64::seed_from_u64(seed);
    (0..n)
        .map(|_| f64::from(rng.random_range(-9i32..10)))
        .collect()
}

#[test]
fn bsr_products_equal_the_dense_expansion_exactly() {
    for (seed, rc, brc) in [
        (1, (1, 1), (40, 30)),
        (2, (3, 1), (20, 25)),
        (3, (9, 9), (7, 5)),
        (4, (16, 16), (3, 4)),
    ] {
        let (bsr, dense) = random_bsr(seed, rc, brc);
        let m = Matrix::BlockSparse(bsr);
        let (rows, cols) = (m.rows(), m.cols());
        let p = CpuMatVec.prepare(&m).unwrap();
        assert_eq!((p.rows(), p.cols()), (rows, cols));
        for k in [1, 3] {
            let x = int_vec(seed + 10, cols * k);
            let mut y = vec![f64::NAN; rows * k];
            let s = p.apply(k, &x, &mut y).unwrap();
            assert_eq!(s.entries, m.stored_values().len());
            assert_eq!(y, dense_product(rows, cols, &dense, k, &x));
            // Transpose against the transposed dense matrix.
            let mut dt = vec![0.0; rows * cols];
            for i in 0..rows {
                for j in 0..cols {
                    dt[j * rows + i] = dense[i * cols + j];
                }
            }
            let xt = int_vec(seed + 20, rows * k);
            let mut yt = vec![f64::NAN; cols * k];
            p.apply_transpose(k, &xt, &mut yt).unwrap();
            assert_eq!(yt, dense_product(cols, rows, &dt, k, &xt));
            // Interleaved right-hand sides equal separate products bitwise.
            for l in 0..k {
                let x1: Vec<f64> = (0..cols).map(|j| x[j * k + l]).collect();
                let mut y1 = vec![0.0; rows];
                p.apply(1, &x1, &mut y1).unwrap();
                for i in 0..rows {
                    assert_eq!(y1[i].to_bits(), y[i * k + l].to_bits());
                }
            }
        }
    }
}

#[test]
fn dense_products_match_nalgebra() {
    let mut rng = Pcg64::seed_from_u64(7);
    let (rows, cols) = (23, 17);
    let v: Vec<f64> = (0..rows * cols)
        .map(|_| rng.random_range(-1.0..1.0))
        .collect();
    let m = Matrix::dense(rows, cols, v.clone()).unwrap();
    let na = DMatrix::from_row_slice(rows, cols, &v);
    let x: Vec<f64> = (0..cols).map(|_| rng.random_range(-1.0..1.0)).collect();
    let p = CpuMatVec.prepare(&m).unwrap();
    let mut y = vec![0.0; rows];
    p.apply(1, &x, &mut y).unwrap();
    let want = &na * nalgebra::DVector::from_column_slice(&x);
    for i in 0..rows {
        assert!((y[i] - want[i]).abs() <= 1e-14, "{i}");
    }
    let xt: Vec<f64> = (0..rows).map(|_| rng.random_range(-1.0..1.0)).collect();
    let mut yt = vec![0.0; cols];
    p.apply_transpose(1, &xt, &mut yt).unwrap();
    let want = na.transpose() * nalgebra::DVector::from_column_slice(&xt);
    for j in 0..cols {
        assert!((yt[j] - want[j]).abs() <= 1e-14, "{j}");
    }
}

#[test]
fn bad_matrices_and_vectors_are_typed_errors() {
    let bad = |r: Result<Bsr, LinearError>| r.unwrap_err();
    assert!(matches!(
        bad(Bsr::new((17, 1), (1, 1), vec![0, 0], vec![], vec![])),
        LinearError::InvalidParameter { .. }
    ));
    assert!(matches!(
        bad(Bsr::new((1, 0), (1, 1), vec![0, 0], vec![], vec![])),
        LinearError::InvalidParameter { .. }
    ));
    assert!(matches!(
        bad(Bsr::new((1, 1), (2, 2), vec![0, 1], vec![0], vec![1.0])),
        LinearError::DimensionMismatch { .. }
    ));
    assert!(matches!(
        bad(Bsr::new(
            (1, 1),
            (2, 2),
            vec![0, 2, 1],
            vec![0, 1],
            vec![1.0, 1.0]
        )),
        LinearError::DimensionMismatch { .. }
    ));
    assert!(matches!(
        bad(Bsr::new((1, 1), (1, 2), vec![0, 1], vec![2], vec![1.0])),
        LinearError::IndexOutOfRange { .. }
    ));
    assert!(matches!(
        bad(Bsr::new(
            (1, 1),
            (1, 2),
            vec![0, 1],
            vec![0],
            vec![f64::NAN]
        )),
        LinearError::NonFiniteInput { .. }
    ));
    assert!(matches!(
        bad(Bsr::new((2, 2), (1, 2), vec![0, 1], vec![0], vec![1.0])),
        LinearError::DimensionMismatch { .. }
    ));
    assert!(Matrix::dense(2, 2, vec![1.0; 3]).is_err());
    assert!(Matrix::dense(1, 1, vec![f64::INFINITY]).is_err());
    let m = Matrix::dense(2, 3, vec![1.0; 6]).unwrap();
    let p = CpuMatVec.prepare(&m).unwrap();
    let mut y = vec![0.0; 2];
    for (k, x) in [(0usize, vec![]), (5, vec![0.0; 15])] {
        let mut yk = vec![0.0; 2 * k];
        assert!(matches!(
            p.apply(k, &x, &mut yk),
            Err(LinearError::InvalidParameter { .. })
        ));
    }
    assert!(p.apply(1, &[1.0; 2], &mut y).is_err());
    assert!(p.apply(1, &[1.0; 3], &mut [0.0; 3]).is_err());
    assert!(matches!(
        p.apply(1, &[1.0, f64::NAN, 1.0], &mut y),
        Err(LinearError::NonFiniteInput { .. })
    ));
    assert!(p.apply_transpose(1, &[1.0; 2], &mut [0.0; 3]).is_ok());
    // A rectangular matrix is no operator.
    assert!(BackendOperator::new(p).is_err());
}

/// A device that fails every product.
struct Broken(usize);
impl PreparedMatVec for Broken {
    fn rows(&self) -> usize {
        self.0
    }
    fn cols(&self) -> usize {
        self.0
    }
    fn apply(&self, _k: usize, _x: &[f64], _y: &mut [f64]) -> Result<MatVecStats, LinearError> {
        Err(LinearError::Backend {
            device: "broken".into(),
            message: "lost".into(),
        })
    }
    fn apply_transpose(
        &self,
        k: usize,
        x: &[f64],
        y: &mut [f64],
    ) -> Result<MatVecStats, LinearError> {
        self.apply(k, x, y)
    }
}

#[test]
fn backend_operator_solves_and_reports_device_errors() {
    // (I − K) x = b with a BSR K of row sums 0.5: GMRES through the backend operator
    // equals GMRES through the dense reference.
    let n = 12;
    let mut v = vec![0.0; n * n];
    for i in 0..n {
        v[i * n + i] = 1.0;
        for j in 0..n {
            if j != i {
                v[i * n + j] -= 0.5 / (n - 1) as f64;
            }
        }
    }
    let m = Matrix::dense(n, n, v.clone()).unwrap();
    let op = BackendOperator::new(CpuMatVec.prepare(&m).unwrap()).unwrap();
    let b: Vec<f64> = (0..n).map(|i| (i % 3) as f64).collect();
    let opts = SolverOptions::default().with_tolerance(1e-12);
    let s = gmres(&op, &b, &opts).unwrap();
    assert!(s.history.converged);
    let mut r = vec![0.0; n];
    op.apply(&s.x, &mut r);
    for i in 0..n {
        assert!((r[i] - b[i]).abs() < 1e-10);
    }
    assert!(op.error().is_none());
    assert!(op.stats().entries >= n * n);

    let broken = BackendOperator::new(Box::new(Broken(n))).unwrap();
    let mut y = vec![0.0; n];
    broken.apply(&b, &mut y);
    assert!(y.iter().all(|v| v.is_nan()));
    assert!(matches!(broken.error(), Some(LinearError::Backend { .. })));
    // The solver stops with a typed error (a breakdown or a non-finite iterate).
    assert!(matches!(
        gmres(&broken, &b, &opts),
        Err(LinearError::NonFiniteIterate { .. } | LinearError::Breakdown { .. })
    ));
}

proptest! {
    #[test]
    fn transpose_is_an_involution_and_adjoint(seed in 0u64..1000, r in 1usize..5, c in 1usize..5) {
        let (bsr, _) = random_bsr(seed, (r, c), (5, 6));
        let m = Matrix::BlockSparse(bsr);
        prop_assert_eq!(&m.transpose().transpose(), &m);
        // <y, A x> = <Aᵀ y, x> exactly with integer entries.
        let x = int_vec(seed + 1, m.cols());
        let yv = int_vec(seed + 2, m.rows());
        let p = CpuMatVec.prepare(&m).unwrap();
        let (mut ax, mut aty) = (vec![0.0; m.rows()], vec![0.0; m.cols()]);
        p.apply(1, &x, &mut ax).unwrap();
        p.apply_transpose(1, &yv, &mut aty).unwrap();
        let lhs: f64 = yv.iter().zip(&ax).map(|(a, b)| a * b).sum();
        let rhs: f64 = aty.iter().zip(&x).map(|(a, b)| a * b).sum();
        prop_assert_eq!(lhs, rhs);
    }
}
