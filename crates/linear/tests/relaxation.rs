//! Relaxation methods of Ziegler §2.3.2: Picard as Neumann partial sums, known
//! solutions, monotone approach for radiosity, the Table 2.1 steps against dense
//! evaluations of `e_iᵀ M̄ r`, and the ambient term of progressive refinement.

mod common;

use common::{Radiosity, direct_solve, rel_err};
use nalgebra::{DMatrix, DVector};
use wavelux_linear::{
    DenseOperator, IdentityMinus, OverrelaxationKind, SolverOptions, gauss_seidel, jacobi,
    overrelaxation, picard, progressive_refinement, sor, southwell,
};

fn small_known() -> (DenseOperator, Vec<f64>, Vec<f64>, Vec<f64>) {
    let k = DMatrix::from_row_slice(3, 3, &[0.0, 0.2, 0.1, 0.3, 0.0, 0.2, 0.1, 0.4, 0.0]);
    let x = vec![1.0, 2.0, 3.0];
    let m = DMatrix::identity(3, 3) - &k;
    let b = (&m * DVector::from_column_slice(&x)).as_slice().to_vec();
    let rho = (0..3).map(|i| k.row(i).sum()).collect();
    (DenseOperator::new(k).unwrap(), x, b, rho)
}

#[test]
fn known_solution_every_relaxation_method() {
    let (k, x, b, rho) = small_known();
    let opts = SolverOptions::default()
        .with_tolerance(1e-14)
        .with_max_iterations(10_000)
        .with_reflectance(rho);
    let mut sols = vec![
        picard(&k, &b, &opts).unwrap(),
        jacobi(&IdentityMinus::new(&k), &b, &opts).unwrap(),
        gauss_seidel(&k, &b, &opts).unwrap(),
        sor(&k, &b, &opts.clone().with_omega(1.1)).unwrap(),
        southwell(&k, &b, &opts).unwrap(),
        progressive_refinement(&k, &b, &opts).unwrap().solve,
    ];
    for kind in [
        OverrelaxationKind::Shao,
        OverrelaxationKind::Gortler,
        OverrelaxationKind::Feda,
        OverrelaxationKind::Xu,
    ] {
        sols.push(overrelaxation(&k, &b, kind, &opts).unwrap());
    }
    for s in sols {
        assert!(s.history.converged, "{}", s.method);
        assert!(
            rel_err(&s.x, &x) < 1e-12,
            "{}: {:e}",
            s.method,
            rel_err(&s.x, &x)
        );
        assert!(s.history.final_relative_residual < 1e-12, "{}", s.method);
    }
}

/// Ziegler eq. (2.16)/(2.3): `x⁽ᵏ⁾ = Σ_{i<k} Kⁱ b` and `r⁽ᵏ⁾ = Kᵏ b`.
#[test]
fn picard_is_the_neumann_series() {
    let sys = Radiosity::seeded(5, 12, 0.3, 0.9);
    let k = sys.k_op();
    let mut term = DVector::from_column_slice(&sys.b);
    let mut sum = DVector::zeros(12);
    for it in 0..8usize {
        let p = picard(
            &k,
            &sys.b,
            &SolverOptions::default().with_max_iterations(it),
        )
        .unwrap();
        assert_eq!(p.history.last().iteration, it);
        assert!(rel_err(&p.x, sum.as_slice()) < 1e-14 || it == 0);
        let rn = p.history.last().residual_norm;
        assert!((rn - term.norm()).abs() <= 1e-14 * term.norm().max(1.0));
        sum += &term;
        term = &sys.k * term;
    }
}

#[test]
fn sor_with_unit_omega_is_gauss_seidel_and_counts_columns() {
    let sys = Radiosity::seeded(9, 16, 0.3, 0.9);
    let k = sys.k_op();
    let opts = SolverOptions::default().with_tolerance(1e-12);
    let g = gauss_seidel(&k, &sys.b, &opts).unwrap();
    let s = sor(&k, &sys.b, &opts.clone().with_omega(1.0)).unwrap();
    assert_eq!(g.x, s.x);
    for r in &g.history.iterations {
        assert_eq!(r.work.columns, 16 * r.iteration as u64);
        assert_eq!(r.work.rows, 0);
        assert_eq!(r.work.applications, 0);
    }
}

/// Ziegler §2.3.2 ("Comparison"): with `b ≥ 0` and `m_ij ≤ 0`, Gauss–Seidel and
/// progressive refinement keep `r ≥ 0`, so the iterates increase monotonically
/// towards the solution.
#[test]
fn gauss_seidel_and_pr_approach_monotonically_from_below() {
    let sys = Radiosity::seeded(21, 15, 0.2, 0.9);
    let k = sys.k_op();
    let exact = sys.direct();
    let mut prev_gs = vec![0.0; 15];
    let mut prev_pr = sys.b.clone();
    for updates in 1..40usize {
        let opts = SolverOptions::default()
            .with_tolerance(0.0)
            .with_updates_per_record(updates)
            .with_max_iterations(1);
        let g = gauss_seidel(&k, &sys.b, &opts).unwrap();
        let p = progressive_refinement(&k, &sys.b, &opts).unwrap();
        for i in 0..15 {
            assert!(g.x[i] >= prev_gs[i] - 1e-15 && g.x[i] <= exact[i] + 1e-12);
            assert!(p.solve.x[i] >= prev_pr[i] - 1e-15 && p.solve.x[i] <= exact[i] + 1e-12);
            assert!(p.unshot[i] >= -1e-15);
        }
        prev_gs = g.x;
        prev_pr = p.solve.x;
    }
}

/// Southwell shoots the largest (area-weighted) residual first.
#[test]
fn southwell_picks_largest_weighted_residual() {
    let sys = Radiosity::seeded(4, 8, 0.3, 0.9);
    let k = sys.k_op();
    let areas: Vec<f64> = (0..8).map(|i| 1.0 + i as f64).collect();
    let opts = SolverOptions::default()
        .with_updates_per_record(1)
        .with_max_iterations(1)
        .with_areas(areas.clone());
    let s = southwell(&k, &sys.b, &opts).unwrap();
    let expect = (0..8)
        .max_by(|&a, &b| (areas[a] * sys.b[a]).total_cmp(&(areas[b] * sys.b[b])))
        .unwrap();
    for i in 0..8 {
        if i == expect {
            assert_eq!(s.x[i], sys.b[i]);
        } else {
            assert_eq!(s.x[i], 0.0);
        }
    }
}

/// One update from `x = 0` sets `x_i = e_iᵀ M̄ b`; compare each Table 2.1 closed
/// form with a dense evaluation of the Neumann-series definition of `M̄`.
#[test]
fn table_2_1_steps_match_dense_definitions() {
    for seed in 0..5u64 {
        let sys = Radiosity::seeded_closed(seed, 9, 0.0);
        let rho: Vec<f64> = (0..9).map(|i| 0.2 + 0.07 * i as f64).collect();
        let sys = Radiosity::closed_from(&sys, rho.clone());
        let n = sys.n;
        let k = sys.k_op();
        let b = DVector::from_column_slice(&sys.b);
        let total: f64 = sys.areas.iter().sum();
        let rho_bar: f64 = rho.iter().zip(&sys.areas).map(|(r, a)| r * a).sum::<f64>() / total;
        // F̂ = R 𝟏 D_A / |S|
        let fhat = DMatrix::from_fn(n, n, |kk, l| rho[kk] * sys.areas[l] / total);
        let id = DMatrix::<f64>::identity(n, n);
        let neumann_fhat = (&id - &fhat).try_inverse().unwrap();
        let opts = SolverOptions::default()
            .with_updates_per_record(1)
            .with_max_iterations(1)
            .with_areas(sys.areas.clone())
            .with_reflectance(rho.clone());
        let argmax = |v: &DVector<f64>| {
            (0..n)
                .max_by(|&a, &c| v[a].abs().total_cmp(&v[c].abs()))
                .unwrap()
        };
        let da = DMatrix::from_diagonal(&DVector::from_column_slice(&sys.areas));
        let weighted = &da * &b;
        for kind in [
            OverrelaxationKind::Shao,
            OverrelaxationKind::Gortler,
            OverrelaxationKind::Feda,
            OverrelaxationKind::Xu,
        ] {
            let (i, step) = match kind {
                OverrelaxationKind::Shao => {
                    let i = argmax(&weighted);
                    (i, ((&id + &sys.k) * &b)[i])
                }
                OverrelaxationKind::Gortler => {
                    let i = argmax(&weighted);
                    let mut ft = DMatrix::zeros(n, n);
                    for l in 0..n {
                        if l != i {
                            ft[(i, l)] = sys.k[(i, l)];
                            ft[(l, i)] = sys.k[(l, i)];
                        }
                    }
                    let y = direct_solve(&(&id - ft), b.as_slice());
                    (i, y[i])
                }
                OverrelaxationKind::Feda => {
                    let i = argmax(&(&da * &neumann_fhat * &b));
                    (i, (&neumann_fhat * &b)[i])
                }
                _ => {
                    let i = argmax(&(&da * &neumann_fhat * &b));
                    let mbar = &id + &sys.k + &fhat * &fhat * &neumann_fhat;
                    (i, (mbar * &b)[i])
                }
            };
            let s = overrelaxation(&k, &sys.b, kind, &opts).unwrap();
            for l in 0..n {
                if l == i {
                    assert!((s.x[l] - step).abs() <= 1e-13 * step.abs(), "{kind:?}");
                } else {
                    assert_eq!(s.x[l], 0.0, "{kind:?} updated {l}, expected {i}");
                }
            }
            // The closed forms of the table: Σ F̂ⁱ = I + F̂/(1 − ρ̄).
            let closed = &id + &fhat / (1.0 - rho_bar);
            assert!((&closed - &neumann_fhat).norm() < 1e-12);
            assert_eq!(s.history.work().columns, 1);
            let rows = matches!(kind, OverrelaxationKind::Feda) as u64;
            assert_eq!(s.history.work().rows, 1 - rows);
        }
    }
}

/// Cohen et al. 1988 ambient term: for the uniform enclosure `K = F̂` (`F_kl =
/// A_l/|S|`) the ambient estimate is exact, so the displayed solution equals the
/// exact solution at every record, while `x̂` itself is not.
#[test]
fn ambient_term_is_exact_for_the_uniform_enclosure() {
    let n = 7;
    let areas: Vec<f64> = (0..n).map(|i| 0.5 + 0.3 * i as f64).collect();
    let rho: Vec<f64> = (0..n).map(|i| 0.1 + 0.1 * i as f64).collect();
    let total: f64 = areas.iter().sum();
    let kmat = DMatrix::from_fn(n, n, |kk, l| rho[kk] * areas[l] / total);
    let b: Vec<f64> = (0..n).map(|i| if i < 2 { 1.0 } else { 0.0 }).collect();
    let exact = direct_solve(&(DMatrix::identity(n, n) - &kmat), &b);
    let opts = SolverOptions::default()
        .with_areas(areas)
        .with_reflectance(rho)
        .with_reference(exact.clone())
        .with_updates_per_record(1)
        .with_tolerance(1e-14);
    let p = progressive_refinement(&DenseOperator::new(kmat).unwrap(), &b, &opts).unwrap();
    assert!(p.solve.history.converged);
    assert_eq!(p.displayed_errors.len(), p.solve.history.iterations.len());
    for (d, rec) in p.displayed_errors.iter().zip(&p.solve.history.iterations) {
        assert!(d.unwrap() < 1e-13, "displayed error {:?}", d);
        if rec.iteration == 0 {
            assert!(rec.error.unwrap() > 1e-2);
        }
    }
    assert!(rel_err(p.displayed.as_ref().unwrap(), &exact) < 1e-13);
    assert!(p.ambient.unwrap().abs() < 1e-12);
}

/// The ambient term improves the displayed solution early in a closed scene.
#[test]
fn ambient_term_helps_early_display_in_closed_scenes() {
    let sys = Radiosity::seeded_closed(13, 60, 0.7);
    let exact = sys.direct();
    let opts = SolverOptions::default()
        .with_areas(sys.areas.clone())
        .with_reflectance(sys.rho.clone())
        .with_reference(exact)
        .with_updates_per_record(6)
        .with_max_iterations(4);
    let p = progressive_refinement(&sys.k_op(), &sys.b, &opts).unwrap();
    for (d, rec) in p.displayed_errors.iter().zip(&p.solve.history.iterations) {
        assert!(d.unwrap() < rec.error.unwrap(), "record {}", rec.iteration);
    }
}

/// Regression: closed 3-patch scenes on which the literal Shao and Gortler steps
/// stalled (residual frozen) before the safeguards of `relaxation` were added.
#[test]
fn table_2_1_safeguards_prevent_stalls() {
    let cases: [(&[f64], [f64; 3]); 2] = [
        (
            &[
                0.0, 0.0374, 0.3200, 0.0014, 0.0, 0.5265, 0.0086, 0.3711, 0.0,
            ],
            [0.3515, 0.5461, 0.7976],
        ),
        (
            &[
                0.0, 0.0092, 0.0095, 0.3408, 0.0, 0.0005, 0.5992, 0.0008, 0.0,
            ],
            [1.4968, 0.5928, 1.0041],
        ),
    ];
    for (kcols, areas) in cases {
        let kmat = DMatrix::from_column_slice(3, 3, kcols);
        let rho: Vec<f64> = (0..3).map(|i| kmat.row(i).sum()).collect();
        let b = [0.1, 0.0, 0.0];
        let exact = direct_solve(&(DMatrix::identity(3, 3) - &kmat), &b);
        let k = DenseOperator::new(kmat).unwrap();
        let opts = SolverOptions::default()
            .with_tolerance(1e-13)
            .with_areas(areas.to_vec())
            .with_reflectance(rho);
        for kind in [OverrelaxationKind::Shao, OverrelaxationKind::Gortler] {
            let s = overrelaxation(&k, &b, kind, &opts).unwrap();
            assert!(s.history.converged, "{kind:?}");
            assert!(rel_err(&s.x, &exact) < 1e-11);
        }
    }
}

/// Feda overshoots by the ambient estimate, which assumes a closed scene: with no
/// exchange at all the literal step multiplies the residual of patch 0 by ≈ −2.3.
/// The safeguard (Southwell update when the step is unusable) rescues this case.
#[test]
fn feda_safeguard_rescues_the_open_two_patch_scene() {
    let k = DenseOperator::new(DMatrix::zeros(2, 2)).unwrap();
    let opts = SolverOptions::default()
        .with_areas(vec![1.77, 0.5])
        .with_reflectance(vec![0.888, 0.01])
        .with_updates_per_record(1);
    let s = overrelaxation(&k, &[0.1, 0.0], OverrelaxationKind::Feda, &opts).unwrap();
    assert!(s.history.converged);
    assert!(s.history.safeguarded_updates >= 1);
    assert!(rel_err(&s.x, &[0.1, 0.0]) < 1e-12);
    // The first (literal) step overshoots: x₀ = 0.1 · (1 + ρ₀ A₀ / (|S| (1 − ρ̄))).
    let first = overrelaxation(
        &k,
        &[0.1, 0.0],
        OverrelaxationKind::Feda,
        &opts.clone().with_max_iterations(1),
    )
    .unwrap();
    let total = 2.27;
    let rho_bar = (1.77 * 0.888 + 0.5 * 0.01) / total;
    let expect = 0.1 * (1.0 + 0.888 * 1.77 / (total * (1.0 - rho_bar)));
    assert!(
        (first.x[0] - expect).abs() < 1e-12,
        "{} vs {expect}",
        first.x[0]
    );
}
