//! Prints iteration and work counts of every solver on a deterministic closed
//! radiosity-like enclosure, for the table in `docs/performance.md`
//! (`cargo run -p wavelux-linear --release --example convergence_table`).
//!
//! The scene: `n` patches with areas `A_i = 1 + (i mod 5)/4`, symmetric couplings
//! `W_ij = A_i A_j / (1 + ((i − j)/8)²)` (nearby patches see each other more), form
//! factors `F_ij = W_ij / Σ_l W_il` (closed: rows sum to 1, reciprocity
//! `A_i F_ij = A_j F_ji` holds after rescaling the areas to the row sums), constant
//! reflectance `ρ`, and one light (patch 0, emission 1). The banded variant keeps
//! only couplings with `|i − j| ≤ 16` (the sparse scene of `benches/benches/linear.rs`).

use nalgebra::DMatrix;
use wavelux_linear::{
    DenseOperator, IdentityMinus, OverrelaxationKind, Solve, SolverOptions, bicgstab, cg, cgnr,
    gauss_seidel, gmres, overrelaxation, picard, progressive_refinement, southwell,
};

fn scene(n: usize, rho: f64, band: usize) -> (DMatrix<f64>, Vec<f64>, Vec<f64>, Vec<f64>) {
    let a0: Vec<f64> = (0..n).map(|i| 1.0 + (i % 5) as f64 / 4.0).collect();
    let w = DMatrix::from_fn(n, n, |i, j| {
        if i == j || i.abs_diff(j) > band {
            0.0
        } else {
            let d = (i as f64 - j as f64) / 8.0;
            a0[i] * a0[j] / (1.0 + d * d)
        }
    });
    let areas: Vec<f64> = (0..n).map(|i| w.row(i).sum()).collect();
    let k = DMatrix::from_fn(n, n, |i, j| rho * w[(i, j)] / areas[i]);
    let mut b = vec![0.0; n];
    b[0] = 1.0;
    (k, areas, vec![rho; n], b)
}

fn row(name: &str, s: &Solve, n: usize) {
    let w = s.history.work();
    println!(
        "| {name} | {} | {:.1e} | {:.1} | {} |",
        s.history.last().iteration,
        s.history.final_relative_residual,
        w.application_equivalents(n),
        if s.history.converged { "yes" } else { "no" }
    );
}

fn main() -> Result<(), wavelux_linear::LinearError> {
    let n = 400;
    for (rho, band) in [(0.5, n), (0.8, n), (0.999, n), (0.8, 16)] {
        let (kmat, areas, refl, b) = scene(n, rho, band);
        let k = DenseOperator::new(kmat.clone())?;
        let a = IdentityMinus::new(&k);
        let exact = (DMatrix::identity(n, n) - &kmat)
            .lu()
            .solve(&nalgebra::DVector::from_column_slice(&b))
            .expect("non-singular")
            .as_slice()
            .to_vec();
        let opts = SolverOptions::default()
            .with_tolerance(1e-10)
            .with_max_iterations(20_000)
            .with_reference(exact.clone())
            .with_areas(areas.clone())
            .with_reflectance(refl.clone());
        println!("\nn = {n}, rho = {rho}, band = {band}: iterations to relative residual 1e-10\n");
        println!("| method | iterations | final rel. residual | work (applications) | converged |");
        println!("| --- | --- | --- | --- | --- |");
        let p = picard(&k, &b, &opts)?;
        row("Picard", &p, n);
        let g = gmres(&a, &b, &opts)?;
        row("GMRES(30)", &g, n);
        row(
            "GMRES(10)",
            &gmres(&a, &b, &opts.clone().with_restart(10))?,
            n,
        );
        row("CGNR", &cgnr(&a, &b, &opts)?, n);
        row("BiCGSTAB", &bicgstab(&a, &b, &opts)?, n);
        // CG on the symmetrised system D_A R⁻¹ M (Ziegler §2.3.1).
        let s = DMatrix::from_fn(n, n, |i, j| {
            areas[i] / refl[i] * (if i == j { 1.0 } else { 0.0 } - kmat[(i, j)])
        });
        let rhs: Vec<f64> = (0..n).map(|i| areas[i] / refl[i] * b[i]).collect();
        let c = cg(
            &DenseOperator::new(s)?,
            &rhs,
            &opts.clone().with_reference(exact.clone()),
        )?;
        row("CG (symmetrised)", &c, n);
        row("Gauss-Seidel (sweeps)", &gauss_seidel(&k, &b, &opts)?, n);
        row("Southwell (n updates)", &southwell(&k, &b, &opts)?, n);
        row(
            "PR (n updates)",
            &progressive_refinement(&k, &b, &opts)?.solve,
            n,
        );
        for kind in [
            OverrelaxationKind::Shao,
            OverrelaxationKind::Gortler,
            OverrelaxationKind::Feda,
            OverrelaxationKind::Xu,
        ] {
            let s = overrelaxation(&k, &b, kind, &opts)?;
            row(&format!("{kind:?} (n updates)"), &s, n);
        }
        // Ziegler §4.2.3: error after three iterations, Picard vs GMRES.
        let e = |s: &Solve, k: usize| s.history.iterations.get(k).and_then(|r| r.error);
        if let (Some(ep), Some(eg)) = (e(&p, 3), e(&g, 3)) {
            println!(
                "\nerror after 3 iterations: Picard {ep:.2e}, GMRES {eg:.2e}, ratio {:.1}",
                ep / eg
            );
        }
    }
    Ok(())
}
