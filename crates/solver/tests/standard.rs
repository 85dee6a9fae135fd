//! The standard decomposition (Ziegler §2.2.3, Glossy §3.5) against the non-standard
//! push/pull system on the same links: identical solutions and energy accounting,
//! `K_std = Q K Qᵀ` on random vectors, orthogonality of the tree wavelet transform,
//! exact agreement when nothing is refined, and typed errors.

use std::sync::OnceLock;

use proptest::prelude::*;
use wavelux_linear::Operator;
use wavelux_scene::Scene;
use wavelux_scene::builtin::{cornell_box, unoccluded};
use wavelux_solver::standard::{self, Decomposition, StandardSystem};
use wavelux_solver::{
    BasisKind, LinearMethod, Multigrid, Prepared, Solution, SolverConfig, SolverError, Statistics,
    solve,
};

fn config(basis: BasisKind, eps: f64, max_level: u8) -> SolverConfig {
    SolverConfig {
        basis,
        eps,
        max_level,
        linear_method: LinearMethod::Gmres { restart: 60 },
        max_iterations: 400,
        tolerance: 1e-14,
        ..SolverConfig::default()
    }
}

fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0f64, |m, x| m.max(x.abs()))
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Solves `scene` both ways and checks leaf coefficients, node averages and energy.
fn agree(scene: &Scene, cfg: SolverConfig) {
    let ns = solve(scene, &cfg).unwrap();
    let st = solve(
        scene,
        &SolverConfig {
            decomposition: Decomposition::Standard,
            ..cfg
        },
    )
    .unwrap();
    assert_eq!(ns.stats.links, st.stats.links, "same links");
    assert!(ns.stats.links > ns.patches.len(), "the links are refined");
    for ch in 0..3 {
        let (a, b) = (ns.leaf_coefficients(ch), st.leaf_coefficients(ch));
        let scale = max_abs(&a).max(1e-300);
        let diff = a
            .iter()
            .zip(&b)
            .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
        assert!(
            diff <= 1e-10 * scale,
            "{}: channel {ch}: leaf coefficients differ by {diff:e} (scale {scale:e})",
            cfg.basis.name()
        );
        let rel = |x: f64, y: f64| (x - y).abs() <= 1e-10 * x.abs().max(y.abs()).max(1e-300);
        let (e1, e2) = (ns.energy, st.energy);
        assert!(rel(e1.emitted[ch], e2.emitted[ch]));
        assert!(rel(e1.absorbed[ch], e2.absorbed[ch]), "absorbed {ch}");
        let tot = e1.emitted[ch].max(1e-300);
        assert!(
            (e1.escaped[ch] - e2.escaped[ch]).abs() <= 1e-10 * tot,
            "escaped {ch}"
        );
        assert!(
            (e1.unshot[ch] - e2.unshot[ch]).abs() <= 1e-10 * tot,
            "unshot {ch}"
        );
    }
}

#[test]
fn standard_and_nonstandard_solutions_agree_on_unoccluded() {
    let scene = unoccluded();
    agree(&scene, config(BasisKind::Haar, 1e-3, 4));
    agree(&scene, config(BasisKind::Multiwavelet(2), 1e-3, 3));
}

#[test]
fn standard_decomposition_in_the_refine_solve_loop() {
    // Later stages start from the previous solution projected onto the new leaves,
    // which the standard path decomposes before iterating.
    let cfg = SolverConfig {
        multigrid: Some(Multigrid {
            stages: 2,
            factor: 10.0,
        }),
        ..config(BasisKind::Haar, 1e-3, 4)
    };
    agree(&unoccluded(), cfg);
}

#[test]
fn standard_and_nonstandard_solutions_agree_on_cornell_box() {
    agree(&cornell_box(), config(BasisKind::Haar, 0.05, 2));
}

#[test]
fn standard_solve_of_given_links_agrees_on_cornell_box_m2() {
    // The fixture's links, solved through `StandardSystem::solve` (no second
    // refinement): every channel (the walls are coloured) and the energy accounting.
    let sol = fixture();
    let prep = Prepared::new(&cornell_box(), &fixture_config()).unwrap();
    let sys = StandardSystem::from_system(sol.system(), sol.basis()).unwrap();
    let st = sys.solve(&prep, Statistics::default()).unwrap();
    assert_eq!(st.stats.links, sol.stats.links);
    for ch in 0..3 {
        let (a, b) = (sol.leaf_coefficients(ch), st.leaf_coefficients(ch));
        let diff = a
            .iter()
            .zip(&b)
            .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
        assert!(diff <= 1e-10 * max_abs(&a), "channel {ch}: {diff:e}");
        let tot = sol.energy.emitted[ch];
        for (x, y) in [
            (sol.energy.emitted[ch], st.energy.emitted[ch]),
            (sol.energy.absorbed[ch], st.energy.absorbed[ch]),
            (sol.energy.escaped[ch], st.energy.escaped[ch]),
            (sol.energy.unshot[ch], st.energy.unshot[ch]),
        ] {
            assert!(
                (x - y).abs() <= 1e-10 * tot,
                "energy, channel {ch}: {x} vs {y}"
            );
        }
    }
}

#[test]
fn gauss_seidel_in_the_wavelet_basis_reaches_the_same_solution() {
    let ns = fixture();
    let sys = StandardSystem::from_system(ns.system(), ns.basis()).unwrap();
    let (x, conv) = sys
        .solve_channel(0, LinearMethod::GaussSeidel, 200, 1e-13, None, None)
        .unwrap();
    assert!(conv.converged);
    let a = ns.leaf_coefficients(0);
    let diff = a
        .iter()
        .zip(&x)
        .fold(0.0f64, |m, (p, q)| m.max((p - q).abs()));
    assert!(diff <= 1e-10 * max_abs(&a), "{diff:e}");
}

fn fixture_config() -> SolverConfig {
    config(BasisKind::Multiwavelet(2), 0.02, 2)
}

/// A refined Cornell box system (M2, 2 levels) shared by several tests.
fn fixture() -> &'static Solution {
    static SOL: OnceLock<Solution> = OnceLock::new();
    SOL.get_or_init(|| {
        let sol = solve(&cornell_box(), &fixture_config()).unwrap();
        assert!(sol.stats.refined_links > 10, "the fixture must be refined");
        sol
    })
}

fn fixture_dim() -> usize {
    fixture().system().dim()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(16))]

    /// `K_std w = Q (D_ρ P_down L P_up) Qᵀ w`: the assembled standard operator equals
    /// decomposition ∘ non-standard push/pull application ∘ reconstruction, and its
    /// transpose is the adjoint.
    #[test]
    fn standard_operator_is_q_k_qt(
        w in proptest::collection::vec(-1.0f64..1.0, fixture_dim()),
        v in proptest::collection::vec(-1.0f64..1.0, fixture_dim()),
        ch in 0usize..3,
    ) {
        let sol = fixture();
        let sys = StandardSystem::from_system(sol.system(), sol.basis()).unwrap();
        let x = sys.reconstruct(&w).unwrap();
        let mut kx = vec![0.0; x.len()];
        sol.system().apply_k(ch, &x, &mut kx);
        let expect = sys.decompose(&kx).unwrap();
        let mut got = vec![0.0; w.len()];
        sys.apply_k(ch, &w, &mut got);
        let scale = max_abs(&expect).max(1e-300);
        for (g, e) in got.iter().zip(&expect) {
            prop_assert!((g - e).abs() <= 1e-12 * scale, "{g} vs {e}");
        }
        let mut ktv = vec![0.0; v.len()];
        sys.apply_kt(ch, &v, &mut ktv);
        let (l, r) = (dot(&v, &got), dot(&ktv, &w));
        prop_assert!((l - r).abs() <= 1e-12 * (l.abs() + r.abs() + scale));
    }

    /// The tree wavelet transform is orthogonal: reconstruction inverts decomposition
    /// and norms are kept.
    #[test]
    fn tree_wavelet_transform_is_orthogonal(
        x in proptest::collection::vec(-1.0f64..1.0, fixture_dim()),
    ) {
        let sol = fixture();
        let sys = StandardSystem::from_system(sol.system(), sol.basis()).unwrap();
        let w = sys.decompose(&x).unwrap();
        prop_assert!((dot(&w, &w) - dot(&x, &x)).abs() <= 1e-12 * dot(&x, &x));
        let back = sys.reconstruct(&w).unwrap();
        for (a, b) in back.iter().zip(&x) {
            prop_assert!((a - b).abs() <= 1e-13);
        }
    }
}

#[test]
fn rows_columns_and_diagonal_match_application() {
    let sol = fixture();
    let sys = StandardSystem::from_system(sol.system(), sol.basis()).unwrap();
    let k = sys.channel(1).unwrap();
    let n = k.dim();
    let mut diag = vec![0.0; n];
    k.diagonal(&mut diag).unwrap();
    let mut col = Vec::new();
    let mut row = Vec::new();
    let mut e = vec![0.0; n];
    let mut ke = vec![0.0; n];
    let mut kte = vec![0.0; n];
    for i in (0..n).step_by((n / 23).max(1)) {
        e[i] = 1.0;
        k.apply(&e, &mut ke);
        k.apply_transpose(&e, &mut kte).unwrap();
        e[i] = 0.0;
        k.column(i, &mut col).unwrap();
        k.row(i, &mut row).unwrap();
        let mut dense_col = vec![0.0; n];
        for &(j, v) in &col {
            dense_col[j] += v;
        }
        let mut dense_row = vec![0.0; n];
        for &(j, v) in &row {
            dense_row[j] += v;
        }
        assert_eq!(dense_col, ke, "column {i}");
        assert_eq!(dense_row, kte, "row {i}");
        assert_eq!(diag[i], ke[i]);
    }
}

#[test]
fn unrefined_links_are_the_same_matrix_in_both_forms() {
    // With nothing refined every link joins two roots: the standard matrix is the
    // non-standard one, block for block.
    let sol = solve(&cornell_box(), &config(BasisKind::Multiwavelet(2), 1e9, 2)).unwrap();
    assert_eq!(sol.stats.refined_links, 0);
    let sys = StandardSystem::from_system(sol.system(), sol.basis()).unwrap();
    assert_eq!(sys.stored(), standard::link_coefficients(sol.system()));
    assert_eq!(
        sys.nonzeros_above(1e-6).unwrap(),
        standard::link_coefficients_above(sol.system(), 1e-6).unwrap()
    );
}

#[test]
fn sparsity_counts_are_consistent() {
    let sol = fixture();
    let sys = StandardSystem::from_system(sol.system(), sol.basis()).unwrap();
    let nz = sys.nonzeros();
    assert!(nz <= sys.stored() && nz > 0);
    let a = sys.nonzeros_above(1e-6).unwrap();
    let b = sys.nonzeros_above(1e-3).unwrap();
    assert!(b <= a && a <= nz);
    assert_eq!(sys.nonzeros_above(0.0).unwrap(), nz);
    // Every link reaches at least its own pair of root-scaling blocks, and refined
    // links reach ancestors' wavelets too: more stored blocks than root pairs.
    assert!(sys.stored_blocks() > 0);
    assert!(standard::link_coefficients(sol.system()) > 0);
}

#[test]
fn typed_errors() {
    let sol = fixture();
    let sys = StandardSystem::from_system(sol.system(), sol.basis()).unwrap();
    let n = sys.dim();
    assert!(matches!(
        sys.decompose(&vec![0.0; n + 1]),
        Err(SolverError::OutOfRange { .. })
    ));
    assert!(matches!(
        sys.reconstruct(&[]),
        Err(SolverError::OutOfRange { .. })
    ));
    assert!(matches!(
        sys.channel(3),
        Err(SolverError::OutOfRange { .. })
    ));
    assert!(matches!(
        sys.emission(7),
        Err(SolverError::OutOfRange { .. })
    ));
    for bad in [-1e-3, f64::NAN, f64::INFINITY] {
        assert!(matches!(
            sys.nonzeros_above(bad),
            Err(SolverError::InvalidConfig { .. })
        ));
        assert!(matches!(
            standard::link_coefficients_above(sol.system(), bad),
            Err(SolverError::InvalidConfig { .. })
        ));
    }
    assert!(matches!(
        sys.solve_channel(0, LinearMethod::Picard, 10, 1e-8, Some(vec![0.0; 3]), None),
        Err(SolverError::OutOfRange { .. })
    ));
    let haar = wavelux_solver::TreeBasis::new(BasisKind::Haar).unwrap();
    assert!(matches!(
        StandardSystem::from_system(sol.system(), &haar),
        Err(SolverError::UnsupportedBasis(_))
    ));
}
