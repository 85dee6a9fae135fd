//! Krylov methods: GMRES against Picard (Ziegler §4.2), ρ → 1, residual monotonicity,
//! happy breakdown, CG on SPD systems only, CGNR and BiCGSTAB on non-symmetric ones,
//! and the work counters.

mod common;

use common::{Radiosity, direct_solve, rel_err};
use nalgebra::DMatrix;
use wavelux_linear::{
    DenseOperator, FnOperator, IdentityMinus, LinearError, Method, Operator, SolverOptions,
    StopReason, Unsupported, bicgstab, cg, cgnr, gmres, picard,
};

fn nonsymmetric3() -> (DenseOperator, Vec<f64>, Vec<f64>) {
    let a = DMatrix::from_row_slice(3, 3, &[4.0, 1.0, 0.0, -1.0, 3.0, 1.0, 0.5, -1.0, 5.0]);
    let x = vec![1.0, -2.0, 3.0];
    let b: Vec<f64> = (&a * nalgebra::DVector::from_column_slice(&x))
        .as_slice()
        .to_vec();
    (DenseOperator::new(a).unwrap(), x, b)
}

fn non_increasing(v: &[f64], slack: f64) -> bool {
    v.windows(2).all(|w| w[1] <= w[0] * (1.0 + slack) + 1e-300)
}

#[test]
fn known_solution_every_krylov_method() {
    let (a, x, b) = nonsymmetric3();
    let opts = SolverOptions::default().with_tolerance(1e-14);
    for s in [
        gmres(&a, &b, &opts).unwrap(),
        cgnr(&a, &b, &opts).unwrap(),
        bicgstab(&a, &b, &opts).unwrap(),
    ] {
        assert!(s.history.converged, "{}", s.method);
        assert!(
            rel_err(&s.x, &x) < 1e-12,
            "{}: {:e}",
            s.method,
            rel_err(&s.x, &x)
        );
        assert!(s.history.final_relative_residual < 1e-12);
    }
    // GMRES without restart terminates within n = 3 iterations.
    let s = gmres(&a, &b, &opts).unwrap();
    assert!(s.history.iterations.len() <= 4);

    let spd = DMatrix::from_row_slice(3, 3, &[4.0, 1.0, 0.0, 1.0, 3.0, 1.0, 0.0, 1.0, 2.0]);
    let xs = vec![1.0, -2.0, 3.0];
    let bs: Vec<f64> = (&spd * nalgebra::DVector::from_column_slice(&xs))
        .as_slice()
        .to_vec();
    let s = cg(&DenseOperator::new(spd).unwrap(), &bs, &opts).unwrap();
    assert!(s.history.converged);
    assert!(s.history.iterations.len() <= 4, "CG terminates in n steps");
    assert!(rel_err(&s.x, &xs) < 1e-12);
}

/// Ziegler §4.2: reflectance close to 1. Picard contracts by ≈ ρ per iteration;
/// GMRES (no restart) must reach 1e-10 within n iterations.
#[test]
fn reflectance_near_one_gmres_converges_picard_crawls() {
    let n = 40;
    let sys = Radiosity::seeded_closed(7, n, 0.999);
    let k = sys.k_op();
    let a = IdentityMinus::new(&k);
    let opts = SolverOptions::default()
        .with_tolerance(1e-10)
        .with_restart(n)
        .with_max_iterations(n);
    let g = gmres(&a, &sys.b, &opts).unwrap();
    assert!(g.history.converged);
    let iters = g.history.last().iteration;
    assert!(iters <= n);
    assert!(g.history.final_relative_residual <= 1e-9);
    assert!(rel_err(&g.x, &sys.direct()) < 1e-7);

    let p = picard(&k, &sys.b, &opts.clone().with_max_iterations(iters)).unwrap();
    assert!(!p.history.converged);
    let p_res = p.history.last().relative_residual;
    let g_res = g.history.last().relative_residual;
    // Same number of operator applications, residuals many orders apart.
    assert_eq!(p.history.work().applications, g.history.work().applications);
    assert!(p_res > 0.1, "Picard relative residual {p_res:e}");
    assert!(p_res / g_res > 1e8, "ratio {:e}", p_res / g_res);
}

/// With `x⁽⁰⁾ = 0` the k-th Picard iterate lies in the Krylov space in which GMRES
/// minimises the residual, so GMRES's residual is never larger.
#[test]
fn gmres_residual_never_exceeds_picard() {
    for seed in 0..4u64 {
        let sys = Radiosity::seeded(seed, 30, 0.5, 0.95);
        let k = sys.k_op();
        let opts = SolverOptions::default()
            .with_tolerance(1e-13)
            .with_restart(30)
            .with_max_iterations(25)
            .with_reference(sys.direct());
        let g = gmres(&IdentityMinus::new(&k), &sys.b, &opts).unwrap();
        let p = picard(&k, &sys.b, &opts).unwrap();
        for (rg, rp) in g.history.iterations.iter().zip(&p.history.iterations) {
            assert_eq!(rg.iteration, rp.iteration);
            assert_eq!(rg.work.applications, rp.work.applications);
            assert!(
                rg.residual_norm <= rp.residual_norm * (1.0 + 1e-9) + 1e-15,
                "iteration {}: GMRES {:e} > Picard {:e}",
                rg.iteration,
                rg.residual_norm,
                rp.residual_norm
            );
            assert!(rg.error.is_some() && rp.error.is_some());
        }
    }
}

#[test]
fn gmres_residual_is_non_increasing_within_and_across_cycles() {
    let sys = Radiosity::seeded(11, 50, 0.8, 0.99);
    let k = sys.k_op();
    for (m, reorth) in [(4usize, true), (4, false), (7, true), (50, true)] {
        let opts = SolverOptions::default()
            .with_tolerance(1e-12)
            .with_restart(m)
            .with_reorthogonalize(reorth);
        let s = gmres(&IdentityMinus::new(&k), &sys.b, &opts).unwrap();
        assert!(s.history.converged, "m = {m}");
        let res: Vec<f64> = s
            .history
            .iterations
            .iter()
            .map(|r| r.residual_norm)
            .collect();
        assert!(non_increasing(&res, 1e-10), "m = {m}: {res:?}");
        // The least-squares estimate matches the true residual at the end.
        let est = s.history.last().relative_residual;
        let tru = s.history.final_relative_residual;
        assert!(
            (est - tru).abs() <= 1e-10,
            "estimate {est:e} vs true {tru:e}"
        );
        // Work: one application per iteration plus one per restart.
        let iters = s.history.last().iteration as u64;
        let restarts = (iters - 1) / m as u64;
        assert_eq!(s.history.work().applications, iters + restarts);
    }
}

#[test]
fn gmres_happy_breakdown_is_success() {
    // Two distinct eigenvalues: the Krylov space of b has dimension 2.
    let a = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(vec![1.0, 1.0, 2.0, 2.0]));
    let a = DenseOperator::new(a).unwrap();
    let b = vec![1.0, 1.0, 1.0, 1.0];
    let s = gmres(&a, &b, &SolverOptions::default().with_tolerance(0.0)).unwrap();
    assert!(s.history.converged);
    assert_eq!(s.history.reason, StopReason::HappyBreakdown);
    assert_eq!(s.history.last().iteration, 2);
    assert!(rel_err(&s.x, &[1.0, 1.0, 0.5, 0.5]) < 1e-14);
}

#[test]
fn gmres_initial_guess_and_matrix_free_operator() {
    let sys = Radiosity::seeded(3, 20, 0.4, 0.9);
    let kd = sys.k.clone();
    let a = FnOperator::new(20, move |x: &[f64], y: &mut [f64]| {
        let kx = &kd * nalgebra::DVector::from_column_slice(x);
        for i in 0..x.len() {
            y[i] = x[i] - kx[i];
        }
    });
    let exact = sys.direct();
    let x0: Vec<f64> = exact.iter().map(|v| v * 0.9).collect();
    let opts = SolverOptions::default()
        .with_tolerance(1e-12)
        .with_initial_guess(x0);
    let s = gmres(&a, &sys.b, &opts).unwrap();
    assert!(s.history.converged);
    assert!(rel_err(&s.x, &exact) < 1e-10);
    // The initial residual cost one application.
    assert_eq!(s.history.iterations[0].work.applications, 1);
    // CGNR needs the transpose, which a closure operator lacks.
    assert!(matches!(
        cgnr(&a, &sys.b, &SolverOptions::default()),
        Err(LinearError::Unsupported {
            method: Method::Cgnr,
            source: Unsupported::Transpose
        })
    ));
}

#[test]
fn cg_on_symmetrised_radiosity_has_monotone_error() {
    // Hestenes–Stiefel: for SPD systems the CG error decreases monotonically in the
    // Euclidean norm (and in the A-norm).
    for seed in 0..3u64 {
        let sys = Radiosity::seeded(seed, 40, 0.2, 0.95);
        let (s, rhs) = sys.symmetrised();
        let exact = direct_solve(&s, &rhs);
        let opts = SolverOptions::default()
            .with_tolerance(1e-13)
            .with_reference(exact.clone());
        let sol = cg(&DenseOperator::new(s).unwrap(), &rhs, &opts).unwrap();
        assert!(sol.history.converged);
        assert!(rel_err(&sol.x, &exact) < 1e-10);
        let errs: Vec<f64> = sol
            .history
            .iterations
            .iter()
            .map(|r| r.error.unwrap())
            .collect();
        assert!(non_increasing(&errs, 1e-9), "{errs:?}");
        // The symmetrised system solves the radiosity system.
        assert!(rel_err(&sol.x, &sys.direct()) < 1e-10);
    }
}

#[test]
fn cg_reports_breakdown_on_indefinite_operator() {
    let a = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(vec![1.0, -1.0]));
    let err = cg(
        &DenseOperator::new(a).unwrap(),
        &[1.0, 1.0],
        &SolverOptions::default(),
    )
    .unwrap_err();
    match err {
        LinearError::Breakdown {
            method, partial, ..
        } => {
            assert_eq!(method, Method::Cg);
            assert_eq!(partial.x, vec![0.0, 0.0]);
            assert_eq!(partial.history.reason, StopReason::Breakdown);
            assert!(!partial.history.converged);
            assert_eq!(partial.history.iterations.len(), 1);
        }
        e => panic!("unexpected {e:?}"),
    }
}

#[test]
fn cgnr_and_bicgstab_on_nonsymmetric_radiosity() {
    for seed in 0..3u64 {
        let sys = Radiosity::seeded(seed + 100, 45, 0.3, 0.95);
        let k = sys.k_op();
        let a = IdentityMinus::new(&k);
        let exact = sys.direct();
        let opts = SolverOptions::default()
            .with_tolerance(1e-12)
            .with_reference(exact.clone());
        let c = cgnr(&a, &sys.b, &opts).unwrap();
        assert!(c.history.converged);
        assert!(rel_err(&c.x, &exact) < 1e-10);
        // CGNR minimises ‖b − A x‖ over nested spaces: non-increasing residual.
        let res: Vec<f64> = c
            .history
            .iterations
            .iter()
            .map(|r| r.residual_norm)
            .collect();
        assert!(non_increasing(&res, 1e-9));
        for r in &c.history.iterations {
            assert_eq!(r.work.applications, r.iteration as u64);
            assert_eq!(r.work.transpose_applications, r.iteration as u64 + 1);
        }

        let s = bicgstab(&a, &sys.b, &opts).unwrap();
        assert!(s.history.converged);
        assert!(rel_err(&s.x, &exact) < 1e-10);
        assert!(s.history.final_relative_residual < 1e-10);
        let last = s.history.last();
        let full = last.iteration as u64 * 2;
        assert!(last.work.applications == full || last.work.applications + 1 == full);
    }
}

#[test]
fn zero_right_hand_side_converges_immediately() {
    let sys = Radiosity::seeded(1, 10, 0.5, 0.9);
    let k = sys.k_op();
    let a = IdentityMinus::new(&k);
    let b = vec![0.0; 10];
    let o = SolverOptions::default();
    for s in [
        gmres(&a, &b, &o).unwrap(),
        cgnr(&a, &b, &o).unwrap(),
        bicgstab(&a, &b, &o).unwrap(),
        picard(&k, &b, &o).unwrap(),
    ] {
        assert!(s.history.converged);
        assert_eq!(s.x, vec![0.0; 10]);
        assert_eq!(s.history.work().applications, 0);
    }
    let _ = a.dim();
}

#[test]
fn convergence_records_round_trip_through_json() {
    let sys = Radiosity::seeded(8, 12, 0.3, 0.9);
    let k = sys.k_op();
    let s = gmres(
        &IdentityMinus::new(&k),
        &sys.b,
        &SolverOptions::default().with_reference(sys.direct()),
    )
    .unwrap();
    let json = serde_json::to_string(&s).unwrap();
    let back: wavelux_linear::Solve = serde_json::from_str(&json).unwrap();
    // serde_json's default float parser may differ in the last ulp; compare the
    // structure exactly and the numbers to rounding.
    assert_eq!(back.method, s.method);
    assert_eq!(back.history.iterations.len(), s.history.iterations.len());
    assert_eq!(back.history.reason, s.history.reason);
    assert!(rel_err(&back.x, &s.x) < 1e-15);
    for (a, b) in back.history.iterations.iter().zip(&s.history.iterations) {
        assert_eq!(a.work, b.work);
        assert_eq!(a.elapsed, b.elapsed);
        assert!((a.residual_norm - b.residual_norm).abs() <= 1e-15 * b.residual_norm);
    }
    assert_eq!(
        s.history.relative_residuals().len(),
        s.history.iterations.len()
    );
    assert!(s.history.errors().iter().all(Option::is_some));
}
