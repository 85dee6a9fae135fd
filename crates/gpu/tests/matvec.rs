//! GPU matrix–vector products against the f64 reference (`CpuMatVec`):
//! `|y_gpu − y_cpu|ᵢ ≤ 1e-6·(|A||x|)ᵢ + 1e-30·max|A|·max|x|`, bitwise repeatable.

mod common;

use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;
use wavelux_gpu::GpuMatVec;
use wavelux_linear::backend::{
    BackendOperator, Bsr, CONTRACT_ABS, CONTRACT_REL, CpuMatVec, MatVecBackend, Matrix,
};
use wavelux_linear::{Operator, SolverOptions, gmres};

fn random_bsr(seed: u64, (r, c): (usize, usize), (br, bc): (usize, usize), scale: f64) -> Matrix {
    let mut rng = Pcg64::seed_from_u64(seed);
    let mut row_ptr = vec![0];
    let mut col_idx = Vec::new();
    let mut values = Vec::new();
    for i in 0..br {
        // Every fourth block row is empty.
        if i % 4 != 3 {
            for j in 0..bc {
                if rng.random_range(0.0..1.0) < 0.3 {
                    col_idx.push(j);
                    for _ in 0..r * c {
                        // Mixed signs and magnitudes (cancellation in the sums).
                        let m = 10f64.powf(rng.random_range(-3.0..0.0));
                        values.push(scale * m * rng.random_range(-1.0..1.0));
                    }
                }
            }
        }
        row_ptr.push(col_idx.len());
    }
    Matrix::BlockSparse(Bsr::new((r, c), (br, bc), row_ptr, col_idx, values).unwrap())
}

fn random_dense(seed: u64, rows: usize, cols: usize, scale: f64) -> Matrix {
    let mut rng = Pcg64::seed_from_u64(seed);
    let v = (0..rows * cols)
        .map(|_| scale * rng.random_range(-1.0..1.0))
        .collect();
    Matrix::dense(rows, cols, v).unwrap()
}

fn random_x(seed: u64, n: usize, scale: f64) -> Vec<f64> {
    let mut rng = Pcg64::seed_from_u64(seed);
    (0..n)
        .map(|_| scale * rng.random_range(-1.0..1.0))
        .collect()
}

/// Checks the contract for `y = A x` (or `Aᵀ x`) with `k` right-hand sides.
fn check(m: &Matrix, gpu: &GpuMatVec, k: usize, x: &[f64], transpose: bool, what: &str) {
    let cpu = CpuMatVec.prepare(m).unwrap();
    let dev = gpu.prepare(m).unwrap();
    let abs = m.abs();
    let cabs = CpuMatVec.prepare(&abs).unwrap();
    let n_out = if transpose { m.cols() } else { m.rows() };
    let (mut yc, mut yg, mut yg2, mut bound) = (
        vec![0.0; n_out * k],
        vec![0.0; n_out * k],
        vec![0.0; n_out * k],
        vec![0.0; n_out * k],
    );
    let xabs: Vec<f64> = x.iter().map(|v| v.abs()).collect();
    if transpose {
        cpu.apply_transpose(k, x, &mut yc).unwrap();
        dev.apply_transpose(k, x, &mut yg).unwrap();
        dev.apply_transpose(k, x, &mut yg2).unwrap();
        cabs.apply_transpose(k, &xabs, &mut bound).unwrap();
    } else {
        cpu.apply(k, x, &mut yc).unwrap();
        dev.apply(k, x, &mut yg).unwrap();
        dev.apply(k, x, &mut yg2).unwrap();
        cabs.apply(k, &xabs, &mut bound).unwrap();
    }
    let maxa = m.stored_values().iter().fold(0.0f64, |a, v| a.max(v.abs()));
    let maxx = x.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    let mut worst: f64 = 0.0;
    for i in 0..yc.len() {
        let tol = CONTRACT_REL * bound[i] + CONTRACT_ABS * maxa * maxx;
        let err = (yg[i] - yc[i]).abs();
        assert!(
            err <= tol,
            "{what}: entry {i}: gpu {} cpu {} err {err:e} > {tol:e}",
            yg[i],
            yc[i]
        );
        if bound[i] > 0.0 {
            worst = worst.max(err / bound[i]);
        }
        assert_eq!(
            yg[i].to_bits(),
            yg2[i].to_bits(),
            "{what}: not repeatable at {i}"
        );
    }
    eprintln!("{what}: worst |err|/(|A||x|) = {worst:.2e}");
}

#[test]
fn bsr_and_dense_products_meet_the_contract() {
    for gpu in common::gpus("matvec_contract") {
        let be = GpuMatVec::new(gpu.clone());
        for (seed, rc, brc) in [
            (1, (1, 1), (300, 200)),
            (2, (3, 1), (40, 90)),
            (3, (9, 9), (30, 20)),
            (4, (16, 16), (9, 7)),
        ] {
            let m = random_bsr(seed, rc, brc, 1.0);
            for k in [1, 3] {
                let x = random_x(seed + 100, m.cols() * k, 1.0);
                check(&m, &be, k, &x, false, &format!("bsr {rc:?} k={k}"));
                let xt = random_x(seed + 200, m.rows() * k, 1.0);
                check(
                    &m,
                    &be,
                    k,
                    &xt,
                    true,
                    &format!("bsr {rc:?} k={k} transposed"),
                );
            }
        }
        let d = random_dense(5, 70, 130, 1.0);
        for k in [1, 3, 4] {
            check(
                &d,
                &be,
                k,
                &random_x(6, 130 * k, 1.0),
                false,
                &format!("dense k={k}"),
            );
            check(
                &d,
                &be,
                k,
                &random_x(7, 70 * k, 1.0),
                true,
                &format!("dense k={k} transposed"),
            );
        }
    }
}

#[test]
fn extreme_scales_and_zeros_meet_the_contract() {
    for gpu in common::gpus("matvec_scales") {
        let be = GpuMatVec::new(gpu.clone());
        for (sa, sx) in [
            (1e-30, 1e30),
            (1e30, 1e-30),
            (1e-30, 1e-30),
            (1e30, 1e30),
            (1.0, 0.0),
        ] {
            let m = random_bsr(11, (3, 3), (20, 20), sa);
            let x = random_x(12, m.cols() * 2, sx);
            check(&m, &be, 2, &x, false, &format!("bsr A~{sa:e} x~{sx:e}"));
            let d = random_dense(13, 17, 19, sa);
            check(
                &d,
                &be,
                1,
                &random_x(14, 19, sx),
                false,
                &format!("dense A~{sa:e} x~{sx:e}"),
            );
        }
        // An all-zero matrix and an empty one.
        let z = Matrix::dense(4, 4, vec![0.0; 16]).unwrap();
        check(&z, &be, 1, &[1.0, 2.0, 3.0, 4.0], false, "zero matrix");
        let e = Matrix::BlockSparse(Bsr::new((2, 2), (3, 3), vec![0; 4], vec![], vec![]).unwrap());
        check(&e, &be, 1, &[1.0; 6], false, "empty bsr");
    }
}

#[test]
fn lowered_binding_limit_forces_chunks_with_the_same_answer() {
    for gpu in common::gpus("matvec_chunks") {
        let m = random_bsr(21, (9, 9), (40, 30), 1.0);
        let x = random_x(22, m.cols() * 3, 1.0);
        let full = GpuMatVec::new(gpu.clone());
        let small = GpuMatVec::new(gpu.clone()).with_binding_limit(8192);
        check(&m, &small, 3, &x, false, "bsr chunked");
        let (pf, ps) = (full.prepare(&m).unwrap(), small.prepare(&m).unwrap());
        let (mut a, mut b) = (vec![0.0; m.rows() * 3], vec![0.0; m.rows() * 3]);
        pf.apply(3, &x, &mut a).unwrap();
        let st = ps.apply(3, &x, &mut b).unwrap();
        assert!(st.dispatches > 1, "{st:?}");
        // Rows never straddle chunks, so chunking changes no sum.
        assert_eq!(a, b);
        let d = random_dense(23, 50, 40, 1.0);
        check(
            &d,
            &small,
            1,
            &random_x(24, 40, 1.0),
            false,
            "dense chunked",
        );
        // A dense row larger than the limit is a typed error.
        let wide = random_dense(25, 2, 3000, 1.0);
        assert!(small.prepare(&wide).is_err());
    }
}

#[test]
fn gmres_on_the_device_operator_meets_its_tolerance() {
    for gpu in common::gpus("matvec_gmres") {
        // (I − K) x = b, K with row sums 0.9 (a radiosity-like system).
        let n = 200;
        let mut rng = Pcg64::seed_from_u64(31);
        let mut v = vec![0.0; n * n];
        for i in 0..n {
            let row: Vec<f64> = (0..n).map(|_| rng.random_range(0.0..1.0)).collect();
            let s: f64 = row.iter().sum();
            for j in 0..n {
                v[i * n + j] = -0.9 * row[j] / s;
            }
            v[i * n + i] += 1.0;
        }
        let m = Matrix::dense(n, n, v).unwrap();
        let be = GpuMatVec::new(gpu.clone());
        let op = BackendOperator::new(be.prepare(&m).unwrap()).unwrap();
        let b: Vec<f64> = (0..n).map(|i| 1.0 + (i % 5) as f64).collect();
        let opts = SolverOptions::default().with_tolerance(1e-6);
        let s = gmres(&op, &b, &opts).unwrap();
        assert!(s.history.converged);
        assert!(op.error().is_none());
        // The f64 residual of the device solution.
        let cpu = BackendOperator::new(CpuMatVec.prepare(&m).unwrap()).unwrap();
        let mut r = vec![0.0; n];
        cpu.apply(&s.x, &mut r);
        let rn = r
            .iter()
            .zip(&b)
            .map(|(a, c)| (a - c).powi(2))
            .sum::<f64>()
            .sqrt();
        let bn = b.iter().map(|v| v * v).sum::<f64>().sqrt();
        eprintln!("gmres: f64 relative residual {:.2e}", rn / bn);
        assert!(rn / bn < 1e-5, "{}", rn / bn);
    }
}
