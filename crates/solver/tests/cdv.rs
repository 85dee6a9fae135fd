//! The CDV-D4 solver (Ziegler §3.1.3, §3.3): white furnace closed form, convergence to
//! the full Galerkin and analytic solutions, agreement with M2, energy accounting,
//! linear methods and determinism.

use wavelux_geometry::formfactor::point_to_polygon;
use wavelux_scene::builtin::{ZIEGLER_EMISSION, ZIEGLER_RHO0, unoccluded, white_furnace};
use wavelux_scene::{Scene, Shape};
use wavelux_solver::{
    BasisKind, Decomposition, LinearMethod, SolverConfig, SolverError, SplitPolicy, solve,
};

fn cdv(eps: f64, max_level: u8) -> SolverConfig {
    SolverConfig {
        basis: BasisKind::Cdv,
        eps,
        max_level,
        quad_points: 3,
        linear_method: LinearMethod::Gmres { restart: 30 },
        tolerance: 1e-12,
        max_iterations: 500,
        ..SolverConfig::default()
    }
}

/// Closed cube, `E = 1`: the constant `E/(1−ρ)` lies in the CDV space (constants are
/// reproduced), so the Galerkin solution is exactly uniform when the rows of the
/// operator sum to the closed-form form factor 1.
#[test]
fn white_furnace_closed_form() {
    for rho in [0.5, 0.9] {
        let scene = white_furnace(1.0, rho).unwrap();
        let c = SolverConfig {
            quad_points: 4,
            singular_order: 5,
            near_field: 1.5,
            tolerance: 1e-13,
            ..cdv(1e-4, 2)
        };
        let sol = solve(&scene, &c).unwrap();
        let exact = 1.0 / (1.0 - rho);
        let mut worst: f64 = 0.0;
        for p in 0..sol.patches.len() {
            for (s, t) in [(0.1, 0.1), (0.5, 0.5), (0.9, 0.3), (0.02, 0.98)] {
                let b = sol.radiosity(p, s, t)[0];
                worst = worst.max((b - exact).abs() / exact);
            }
            let avg = sol.patch_average(p)[0];
            worst = worst.max((avg - exact).abs() / exact);
        }
        let e = sol.energy;
        let rel = (e.emitted[0] - e.absorbed[0]).abs() / e.emitted[0];
        println!(
            "rho {rho}: worst {worst:.3e}, links {}, energy rel {rel:.2e}",
            sol.stats.links
        );
        assert!(worst < 1e-3, "rho {rho}: {worst}");
        assert!(rel < 1e-3 * (1.0 - rho).recip(), "rho {rho}: energy {rel}");
        assert!(e.unshot[0].abs() < 1e-8 * e.emitted[0]);
    }
}

fn analytic(scene: &Scene, n: usize) -> Vec<f64> {
    let Shape::Parallelogram {
        origin,
        edge_u,
        edge_v,
    } = scene.surfaces[1].shape
    else {
        panic!("emitter is a parallelogram");
    };
    let poly = [
        origin,
        origin + edge_u,
        origin + edge_u + edge_v,
        origin + edge_v,
    ];
    let mut v = Vec::new();
    for j in 0..n {
        for i in 0..n {
            let x = glam::DVec3::new(
                (i as f64 + 0.5) / n as f64,
                (j as f64 + 0.5) / n as f64,
                0.0,
            );
            let f = point_to_polygon(x, glam::DVec3::Z, &poly).unwrap().abs();
            v.push(ZIEGLER_RHO0 * ZIEGLER_EMISSION * f);
        }
    }
    v
}

fn grid(sol: &wavelux_solver::Solution, n: usize) -> Vec<f64> {
    let p = sol.by_surface[0][0];
    let mut v = Vec::new();
    for j in 0..n {
        for i in 0..n {
            v.push(sol.radiosity(p, (i as f64 + 0.5) / n as f64, (j as f64 + 0.5) / n as f64)[0]);
        }
    }
    v
}

fn l1(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y).abs()).sum::<f64>()
        / b.iter().map(|y| y.abs()).sum::<f64>()
}

/// On "Unoccluded" the compressed CDV solution converges to the full Galerkin one as
/// ε → 0, and the full one agrees with the analytic solution and with M2 (same number
/// of functions) to the discretisation error.
#[test]
fn unoccluded_converges_and_agrees_with_m2() {
    let scene = unoccluded();
    let n = 32;
    let exact = analytic(&scene, n);
    let level = 4;
    let full = solve(&scene, &cdv(1e-300, level)).unwrap();
    let gf = grid(&full, n);
    let mut last = f64::INFINITY;
    let mut rows = Vec::new();
    for eps in [1e-1, 1e-2, 1e-3, 1e-4, 1e-6] {
        let s = solve(&scene, &cdv(eps, level)).unwrap();
        let g = grid(&s, n);
        let (ef, ea) = (l1(&g, &gf), l1(&g, &exact));
        rows.push((eps, s.stats.nonstandard_links, ef, ea));
        assert!(ef <= last * 1.05 + 1e-12, "not converging: {rows:?}");
        last = ef;
    }
    println!("CDV full links {}: {rows:?}", full.stats.nonstandard_links);
    assert!(last < 1e-3, "{rows:?}");
    let m2 = solve(
        &scene,
        &SolverConfig {
            basis: BasisKind::Multiwavelet(2),
            ..cdv(1e-300, level - 1)
        },
    )
    .unwrap();
    let gm = grid(&m2, n);
    let (e_cdv, e_m2, d) = (l1(&gf, &exact), l1(&gm, &exact), l1(&gf, &gm));
    println!("analytic error CDV {e_cdv:.3e}, M2 {e_m2:.3e}, CDV vs M2 {d:.3e}");
    assert!(e_cdv < 0.1, "CDV error {e_cdv}");
    assert!(d <= 1.5 * (e_cdv + e_m2), "CDV vs M2 {d}");
}

/// Energy balances against the measured escape on an open scene; every linear method gives the same
/// solution; results are bitwise independent of the thread count.
#[test]
fn energy_methods_and_determinism() {
    let scene = unoccluded();
    let base = cdv(1e-3, 4);
    let reference = solve(&scene, &base).unwrap();
    let e = reference.energy;
    // The measured escape balances the operator within 4σ + 1 % (tests/energy.rs).
    assert!(
        e.imbalance()[0].abs() <= 4.0 * e.escaped_std_error[0] + 1e-2 * e.emitted[0],
        "imbalance {} (σ {})",
        e.imbalance()[0],
        e.escaped_std_error[0]
    );
    assert!(
        e.unshot[0].abs() < 1e-8 * e.emitted[0],
        "unshot {}",
        e.unshot[0]
    );
    assert!(e.absorbed[0] > 0.0 && e.escaped[0] > 0.0);
    let avg = reference.surface_average(0)[0];
    for method in [
        LinearMethod::Picard,
        LinearMethod::GaussSeidel,
        LinearMethod::Cgnr,
    ] {
        let sol = solve(
            &scene,
            &SolverConfig {
                linear_method: method,
                ..base
            },
        )
        .unwrap();
        let a = sol.surface_average(0)[0];
        assert!((a - avg).abs() <= 1e-8 * avg, "{method:?}: {a} vs {avg}");
    }
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| solve(&scene, &base).unwrap())
    };
    let (a, b) = (run(1), run(3));
    assert_eq!(a.stats.links, b.stats.links);
    assert_eq!(a.stats.rays, b.stats.rays);
    let (fa, fb) = (a.cdv_field().unwrap(), b.cdv_field().unwrap());
    assert_eq!(fa.coeffs, fb.coeffs);
}

#[test]
fn rejects_invalid_cdv_config() {
    let scene = unoccluded();
    for c in [
        cdv(1e-3, 1),
        SolverConfig {
            split: SplitPolicy::Larger,
            ..cdv(1e-3, 3)
        },
        SolverConfig {
            decomposition: Decomposition::Standard,
            ..cdv(1e-3, 3)
        },
    ] {
        assert!(matches!(
            solve(&scene, &c),
            Err(SolverError::InvalidConfig { .. })
        ));
    }
}

/// The refine–solve loop (Ziegler Alg. 2.3.4) with the brightness oracle: later stages
/// re-refine with the previous stage's radiosity and start from its projected
/// coefficients. On "Unoccluded" the emitter's radiosity is its emission (ρ₁ = 0), so
/// the brightness oracle is `ρ₀ E = 40` times the kernel oracle and the last stage
/// must reproduce the direct kernel-oracle solve at `ε/40`.
#[test]
fn multigrid_with_brightness_oracle() {
    use wavelux_solver::{Multigrid, Oracle};
    let scene = unoccluded();
    let direct = solve(&scene, &cdv(1e-3, 4)).unwrap();
    let mg = solve(
        &scene,
        &SolverConfig {
            oracle: Oracle::Brightness,
            multigrid: Some(Multigrid {
                stages: 2,
                factor: 10.0,
            }),
            // W/m²: ρ₀ E = 40 times the kernel threshold of `direct`.
            ..cdv(4e-2, 4)
        },
    )
    .unwrap();
    assert_eq!(mg.stats.stages, 2);
    assert!(
        mg.stats.links < 4352,
        "not fully refined: {}",
        mg.stats.links
    );
    assert_eq!(mg.stats.links, direct.stats.links);
    let (a, b) = (direct.surface_average(0)[0], mg.surface_average(0)[0]);
    println!(
        "direct {a}, multigrid {b}, links {} vs {}",
        direct.stats.links, mg.stats.links
    );
    assert!((a - b).abs() < 1e-2 * a, "{a} vs {b}");
}

/// Reciprocity of the CDV transfer at refined levels (issue 13 §2): the kernel
/// `G(x, y) V(x, y) / π` is symmetric and the CDV functions are `L²(S)`-orthonormal, so
/// the link block of a receiver/emitter vertex pair is the transpose of the block of
/// the reversed pair, `T(R, E)_ab = T(E, R)_ba`, on every level, with occlusion. Ziegler's
/// occluded scene at `max_level = 4` refines links from level 2 to level 3 (vertices
/// up to level 4); the projection onto `M_3` cells, the singular rules of touching cells and the
/// shadow rays must treat both orders alike. Tolerance 1e-7 of the largest entry of the
/// two blocks (as for the tree bases in `properties.rs` and `virtual_mesh.rs`).
#[test]
fn refined_links_are_reciprocal() {
    use std::collections::HashMap;
    use wavelux_solver::Prepared;
    use wavelux_solver::cdv::{CDV_MIN_LEVEL, CdvBasis, refine};

    let scene = wavelux_scene::builtin::occluded();
    let cfg = cdv(3e-3, 4);
    let prep = Prepared::new(&scene, &cfg).unwrap();
    let ctx = prep.transfer().unwrap();
    let basis = CdvBasis::new(cfg.max_level, &prep.basis).unwrap();
    let (links, _) = refine(&ctx, &basis, &prep.refine_params(cfg.eps), &|_, _| 1.0);
    let by_pair: HashMap<_, _> = links
        .iter()
        .map(|l| ((l.rp, l.level, l.r, l.ep, l.e), &l.block))
        .collect();
    let (mut compared, mut deepest) = (0usize, 0u8);
    for l in &links {
        let Some(back) = by_pair.get(&(l.ep, l.level, l.e, l.rp, l.r)) else {
            continue;
        };
        let scale = l
            .block
            .iter()
            .chain(back.iter())
            .fold(0.0f64, |m, v| m.max(v.abs()));
        for a in 0..4 {
            for b in 0..4 {
                let (x, y) = (l.block[a * 4 + b], back[b * 4 + a]);
                assert!(
                    (x - y).abs() <= 1e-7 * scale.max(1e-300),
                    "level {}: patch {} vertex {} <- patch {} vertex {}, entry ({a},{b}): \
                     {x} vs {y} (scale {scale})",
                    l.level,
                    l.rp,
                    l.r,
                    l.ep,
                    l.e
                );
            }
        }
        if scale > 0.0 && l.level > CDV_MIN_LEVEL {
            compared += 1;
            deepest = deepest.max(l.level);
        }
    }
    println!(
        "{} links, {compared} refined pairs compared, deepest level {deepest}",
        links.len()
    );
    assert!(
        compared > 100 && deepest > CDV_MIN_LEVEL,
        "{compared}, {deepest}"
    );
}
