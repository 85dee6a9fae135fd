//! Every method converges to the direct (LU) solution on random diagonally dominant
//! radiosity-like systems `(I − R F) x = b` (Ziegler §2.3.1 properties). The Feda and
//! Xu overrelaxations assume a closed scene (their ambient estimate `F̂` stands in
//! for `F`); they are tested on closed enclosures only, everything else on both.

mod common;

use common::{Radiosity, closed_radiosity_strategy, radiosity_strategy, rel_err};
use proptest::prelude::*;
use wavelux_linear::{
    DenseOperator, IdentityMinus, OverrelaxationKind, Solve, SolverOptions, bicgstab, cg, cgnr,
    gauss_seidel, gmres, jacobi, overrelaxation, picard, progressive_refinement, sor, southwell,
};

/// Runs every method on `sys`; returns (name, solution, reported convergence).
fn run_all(sys: &Radiosity, tol: f64, closed: bool) -> Vec<(&'static str, Vec<f64>, bool)> {
    let k = sys.k_op();
    let a = IdentityMinus::new(&k);
    let base = SolverOptions::default()
        .with_tolerance(tol)
        .with_max_iterations(5000)
        .with_areas(sys.areas.clone())
        .with_reflectance(sys.rho.clone());
    let b = &sys.b;
    let mut out = Vec::new();
    let mut push = |name: &'static str, s: Solve| out.push((name, s.x, s.history.converged));
    push("picard", picard(&k, b, &base).unwrap());
    push("jacobi", jacobi(&a, b, &base).unwrap());
    push("gauss-seidel", gauss_seidel(&k, b, &base).unwrap());
    push(
        "sor 1.2",
        sor(&k, b, &base.clone().with_omega(1.2)).unwrap(),
    );
    push(
        "sor 0.8",
        sor(&k, b, &base.clone().with_omega(0.8)).unwrap(),
    );
    push("southwell", southwell(&k, b, &base).unwrap());
    push("pr", progressive_refinement(&k, b, &base).unwrap().solve);
    let kinds: &[OverrelaxationKind] = if closed {
        &[
            OverrelaxationKind::Shao,
            OverrelaxationKind::Gortler,
            OverrelaxationKind::Feda,
            OverrelaxationKind::Xu,
        ]
    } else {
        &[OverrelaxationKind::Shao, OverrelaxationKind::Gortler]
    };
    for &kind in kinds {
        let name = match kind {
            OverrelaxationKind::Shao => "shao",
            OverrelaxationKind::Gortler => "gortler",
            OverrelaxationKind::Feda => "feda",
            _ => "xu",
        };
        push(name, overrelaxation(&k, b, kind, &base).unwrap());
    }
    push("gmres(30)", gmres(&a, b, &base).unwrap());
    push(
        "gmres(3)",
        gmres(&a, b, &base.clone().with_restart(3)).unwrap(),
    );
    push("cgnr", cgnr(&a, b, &base).unwrap());
    push("bicgstab", bicgstab(&a, b, &base).unwrap());
    let (s, rhs) = sys.symmetrised();
    let sop = DenseOperator::new(s).unwrap();
    push("cg (symmetrised)", cg(&sop, &rhs, &base).unwrap());
    out
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn every_method_reaches_the_direct_solution(sys in radiosity_strategy()) {
        let exact = sys.direct();
        for (name, x, converged) in run_all(&sys, 1e-13, false) {
            prop_assert!(converged, "{name} did not converge");
            let e = rel_err(&x, &exact);
            prop_assert!(e <= 1e-10, "{name}: relative error {e:e}");
        }
    }

    #[test]
    fn every_method_reaches_the_direct_solution_in_closed_scenes(
        sys in closed_radiosity_strategy()
    ) {
        let exact = sys.direct();
        for (name, x, converged) in run_all(&sys, 1e-13, true) {
            prop_assert!(converged, "{name} did not converge");
            let e = rel_err(&x, &exact);
            prop_assert!(e <= 1e-10, "{name}: relative error {e:e}");
        }
    }
}

#[test]
fn seeded_larger_systems() {
    for (seed, n) in [(1u64, 40usize), (2, 60)] {
        let sys = Radiosity::seeded(seed, n, 0.3, 0.9);
        let exact = sys.direct();
        for (name, x, converged) in run_all(&sys, 1e-13, false) {
            assert!(converged, "{name} did not converge (n = {n})");
            let e = rel_err(&x, &exact);
            assert!(e <= 1e-10, "{name}: relative error {e:e} (n = {n})");
        }
    }
}
