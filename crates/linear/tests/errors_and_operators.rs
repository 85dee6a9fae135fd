//! Input validation (typed errors, never panics) and operator consistency (dense,
//! CSR, `I − K`, closures).

mod common;

use common::Radiosity;
use nalgebra::{DMatrix, DVector};
use proptest::prelude::*;
use wavelux_linear::{
    CsrMatrix, DenseOperator, FnOperator, IdentityMinus, LinearError, Method, Operator,
    OverrelaxationKind, Solve, SolverOptions, Unsupported, bicgstab, cg, cgnr, gauss_seidel, gmres,
    jacobi, overrelaxation, picard, progressive_refinement, sor, southwell,
};

type Runner = fn(&DenseOperator, &[f64], &SolverOptions) -> Result<Solve, LinearError>;

/// Every solver, taking `K` (fixed-point methods) and wrapping it for the others.
fn runners() -> Vec<(&'static str, Runner)> {
    vec![
        ("picard", |k, b, o| picard(k, b, o)),
        ("jacobi", |k, b, o| jacobi(&IdentityMinus::new(k), b, o)),
        ("gauss-seidel", |k, b, o| gauss_seidel(k, b, o)),
        ("sor", |k, b, o| sor(k, b, o)),
        ("southwell", |k, b, o| southwell(k, b, o)),
        ("pr", |k, b, o| {
            progressive_refinement(k, b, o).map(|p| p.solve)
        }),
        ("shao", |k, b, o| {
            overrelaxation(k, b, OverrelaxationKind::Shao, o)
        }),
        ("gortler", |k, b, o| {
            overrelaxation(k, b, OverrelaxationKind::Gortler, o)
        }),
        ("feda", |k, b, o| {
            overrelaxation(k, b, OverrelaxationKind::Feda, o)
        }),
        ("xu", |k, b, o| {
            overrelaxation(k, b, OverrelaxationKind::Xu, o)
        }),
        ("gmres", |k, b, o| gmres(&IdentityMinus::new(k), b, o)),
        ("cg", |k, b, o| cg(&IdentityMinus::new(k), b, o)),
        ("cgnr", |k, b, o| cgnr(&IdentityMinus::new(k), b, o)),
        ("bicgstab", |k, b, o| bicgstab(&IdentityMinus::new(k), b, o)),
    ]
}

#[test]
fn bad_inputs_are_typed_errors_for_every_solver() {
    let sys = Radiosity::seeded(1, 6, 0.3, 0.8);
    let k = sys.k_op();
    let ok = SolverOptions::default().with_reflectance(sys.rho.clone());
    let mut nan_b = sys.b.clone();
    nan_b[3] = f64::NAN;
    let mut inf_ref = sys.b.clone();
    inf_ref[1] = f64::INFINITY;
    for (name, run) in runners() {
        assert!(
            matches!(
                run(&k, &nan_b, &ok),
                Err(LinearError::NonFiniteInput { index: 3, .. })
            ),
            "{name}: NaN rhs"
        );
        assert!(
            matches!(
                run(&k, &sys.b[..5], &ok),
                Err(LinearError::DimensionMismatch {
                    expected: 6,
                    got: 5,
                    ..
                })
            ),
            "{name}: short rhs"
        );
        let cases = [
            ok.clone().with_tolerance(f64::NAN),
            ok.clone().with_tolerance(-1.0),
            ok.clone().with_reference(inf_ref.clone()),
            ok.clone().with_initial_guess(vec![0.0; 7]),
            ok.clone().with_omega(2.0),
            ok.clone().with_restart(0),
            ok.clone().with_updates_per_record(0),
            ok.clone().with_areas(vec![1.0, 1.0, 0.0, 1.0, 1.0, 1.0]),
            ok.clone()
                .with_reflectance(vec![0.5, 0.5, 1.0, 0.5, 0.5, 0.5]),
            ok.clone()
                .with_reflectance(vec![0.5, 0.5, f64::NAN, 0.5, 0.5, 0.5]),
        ];
        for (c, o) in cases.iter().enumerate() {
            let r = run(&k, &sys.b, o);
            assert!(
                matches!(
                    r,
                    Err(LinearError::InvalidParameter { .. }
                        | LinearError::NonFiniteInput { .. }
                        | LinearError::DimensionMismatch { .. })
                ),
                "{name}: case {c}: {r:?}"
            );
        }
    }
}

#[test]
fn missing_capabilities_and_inputs_are_reported() {
    let sys = Radiosity::seeded(2, 5, 0.3, 0.8);
    let kd = sys.k.clone();
    let f = FnOperator::new(5, move |x: &[f64], y: &mut [f64]| {
        let v = &kd * DVector::from_column_slice(x);
        y.copy_from_slice(v.as_slice());
    });
    let o = SolverOptions::default();
    for r in [
        gauss_seidel(&f, &sys.b, &o),
        southwell(&f, &sys.b, &o),
        overrelaxation(&f, &sys.b, OverrelaxationKind::Shao, &o),
    ] {
        assert!(matches!(
            r,
            Err(LinearError::Unsupported {
                source: Unsupported::Column,
                ..
            })
        ));
    }
    assert!(matches!(
        jacobi(&f, &sys.b, &o),
        Err(LinearError::Unsupported {
            source: Unsupported::Diagonal,
            ..
        })
    ));
    // Picard needs only products.
    assert!(picard(&f, &sys.b, &o).unwrap().history.converged);
    let k = sys.k_op();
    for kind in [OverrelaxationKind::Feda, OverrelaxationKind::Xu] {
        assert!(matches!(
            overrelaxation(&k, &sys.b, kind, &o),
            Err(LinearError::MissingInput {
                method: Method::Overrelaxation(_),
                ..
            })
        ));
    }
}

#[test]
fn divergence_and_non_finite_operators_are_errors_not_panics() {
    // Spectral radius 2: Picard overflows to infinity.
    let k = DenseOperator::new(DMatrix::identity(3, 3) * 2.0).unwrap();
    let r = picard(
        &k,
        &[1.0, 0.0, 0.0],
        &SolverOptions::default().with_max_iterations(5000),
    );
    assert!(matches!(r, Err(LinearError::NonFiniteIterate { .. })));
    // An operator that returns NaN.
    let bad = FnOperator::new(3, |_x: &[f64], y: &mut [f64]| y.fill(f64::NAN));
    let o = SolverOptions::default();
    let b = [1.0, 2.0, 3.0];
    assert!(gmres(&bad, &b, &o).is_err());
    assert!(bicgstab(&bad, &b, &o).is_err());
    assert!(cg(&bad, &b, &o).is_err());
    assert!(picard(&bad, &b, &o).is_err());
    // A singular operator: GMRES reports a breakdown with the partial result.
    let zero = FnOperator::new(3, |_x: &[f64], y: &mut [f64]| y.fill(0.0));
    match gmres(&zero, &b, &o) {
        Err(LinearError::Breakdown { partial, .. }) => assert_eq!(partial.x.len(), 3),
        other => panic!("{other:?}"),
    }
    assert!(matches!(
        bicgstab(&zero, &b, &o),
        Err(LinearError::Breakdown { .. })
    ));
}

#[test]
fn operator_construction_validates() {
    let mut m = DMatrix::zeros(2, 2);
    m[(1, 0)] = f64::NAN;
    assert!(matches!(
        DenseOperator::new(m),
        Err(LinearError::NonFiniteInput { index: 1, .. })
    ));
    assert!(DenseOperator::new(DMatrix::zeros(2, 3)).is_err());
    assert!(matches!(
        CsrMatrix::from_triplets(2, &[(0, 2, 1.0)]),
        Err(LinearError::IndexOutOfRange { .. })
    ));
    assert!(CsrMatrix::from_triplets(2, &[(0, 1, f64::INFINITY)]).is_err());
}

fn sparse_strategy() -> impl Strategy<Value = (usize, Vec<(usize, usize, f64)>, Vec<f64>)> {
    (1usize..12).prop_flat_map(|n| {
        (
            Just(n),
            prop::collection::vec((0..n, 0..n, -2.0f64..2.0), 0..3 * n),
            prop::collection::vec(-1.0f64..1.0, n),
        )
    })
}

fn entries_to_dense(n: usize, e: &[(usize, f64)]) -> Vec<f64> {
    let mut v = vec![0.0; n];
    for &(i, x) in e {
        v[i] += x;
    }
    v
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn csr_dense_and_identity_minus_agree((n, trip, x) in sparse_strategy()) {
        let mut dense = DMatrix::zeros(n, n);
        for &(i, j, v) in &trip {
            dense[(i, j)] += v;
        }
        let csr = CsrMatrix::from_triplets(n, &trip).unwrap();
        let den = DenseOperator::new(dense.clone()).unwrap();
        let xv = DVector::from_column_slice(&x);
        let ax = (&dense * &xv).as_slice().to_vec();
        let atx = (dense.transpose() * &xv).as_slice().to_vec();
        let close = |a: &[f64], b: &[f64]| a.iter().zip(b).all(|(p, q)| (p - q).abs() <= 1e-12);
        for op in [&csr as &dyn Operator, &den as &dyn Operator] {
            let mut y = vec![7.0; n];
            op.apply(&x, &mut y);
            prop_assert!(close(&y, &ax));
            op.apply_transpose(&x, &mut y).unwrap();
            prop_assert!(close(&y, &atx));
            let mut d = vec![0.0; n];
            op.diagonal(&mut d).unwrap();
            prop_assert!(close(&d, dense.diagonal().as_slice()));
            let mut e = Vec::new();
            for i in 0..n {
                op.row(i, &mut e).unwrap();
                let row: Vec<f64> = dense.row(i).iter().copied().collect();
                prop_assert!(close(&entries_to_dense(n, &e), &row));
                op.column(i, &mut e).unwrap();
                prop_assert!(close(&entries_to_dense(n, &e), dense.column(i).as_slice()));
            }
        }
        // I − K, through a reference, keeps every capability.
        let im = IdentityMinus::new(&csr);
        let idm = DMatrix::identity(n, n) - &dense;
        let mut y = vec![0.0; n];
        im.apply(&x, &mut y);
        prop_assert!(close(&y, (&idm * &xv).as_slice()));
        im.apply_transpose(&x, &mut y).unwrap();
        prop_assert!(close(&y, (idm.transpose() * &xv).as_slice()));
        let mut e = Vec::new();
        for i in 0..n {
            im.column(i, &mut e).unwrap();
            prop_assert!(close(&entries_to_dense(n, &e), idm.column(i).as_slice()));
            im.row(i, &mut e).unwrap();
            let row: Vec<f64> = idm.row(i).iter().copied().collect();
            prop_assert!(close(&entries_to_dense(n, &e), &row));
        }
        let from_dense = CsrMatrix::from_dense(&dense, 0.0).unwrap();
        let mut y2 = vec![0.0; n];
        from_dense.apply(&x, &mut y2);
        prop_assert!(close(&y2, &ax));
    }
}

/// Dense and CSR operators give the same iterates.
#[test]
fn csr_and_dense_solvers_agree() {
    let sys = Radiosity::seeded(17, 25, 0.3, 0.9);
    let csr = CsrMatrix::from_dense(&sys.k, 0.0).unwrap();
    let den = sys.k_op();
    let o = SolverOptions::default().with_tolerance(1e-12);
    let a = gauss_seidel(&csr, &sys.b, &o).unwrap();
    let b = gauss_seidel(&den, &sys.b, &o).unwrap();
    assert_eq!(a.history.iterations.len(), b.history.iterations.len());
    let d: f64 =
        a.x.iter()
            .zip(&b.x)
            .map(|(p, q)| (p - q).abs())
            .fold(0.0, f64::max);
    assert!(d < 1e-13);
    let g1 = gmres(&IdentityMinus::new(&csr), &sys.b, &o).unwrap();
    let g2 = gmres(&IdentityMinus::new(&den), &sys.b, &o).unwrap();
    assert_eq!(g1.history.iterations.len(), g2.history.iterations.len());
}
