//! wavelux-solver benchmarks: full solves of Ziegler's "Unoccluded" scene per basis at
//! the settings that reach about 1% and 0.1% relative L1 error (see
//! `docs/reproductions/ziegler-4.1.md`), a Cornell-box solve per basis, and the
//! solver's shadow-ray rate against the raw occlusion throughput of the same BVH.
//! Memory (bytes held) and ray counts are printed once per configuration.

#![allow(missing_docs)] // reason: criterion's macros generate undocumented items

use std::hint::black_box;
use std::time::Instant;

use criterion::{Criterion, criterion_group, criterion_main};
use glam::DVec3;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;
use wavelux::geometry::formfactor::point_to_polygon;
use wavelux::scene::Shape;
use wavelux::scene::builtin::{ZIEGLER_EMISSION, ZIEGLER_RHO0, cornell_box, unoccluded};
use wavelux::solver::{BasisKind, Prepared, SolverConfig, solve};

/// Relative L1 error on S0 against `ρ₀ E F(p → S1)` on a 64² midpoint grid.
fn unoccluded_error(sol: &wavelux::solver::Solution, scene: &wavelux::scene::Scene) -> f64 {
    let Shape::Parallelogram {
        origin,
        edge_u,
        edge_v,
    } = scene.surfaces[1].shape
    else {
        return f64::NAN;
    };
    let poly = [
        origin,
        origin + edge_u,
        origin + edge_u + edge_v,
        origin + edge_v,
    ];
    let n = 64;
    let (mut num, mut den) = (0.0, 0.0);
    for j in 0..n {
        for i in 0..n {
            let (s, t) = ((i as f64 + 0.5) / n as f64, (j as f64 + 0.5) / n as f64);
            let x = DVec3::new(s, t, 0.0);
            let exact = ZIEGLER_RHO0
                * ZIEGLER_EMISSION
                * point_to_polygon(x, DVec3::Z, &poly).map_or(f64::NAN, f64::abs);
            num += (sol.radiosity(0, s, t)[0] - exact).abs();
            den += exact;
        }
    }
    num / den
}

fn unoccluded_solves(c: &mut Criterion) {
    let scene = unoccluded();
    let mut g = c.benchmark_group("solver/unoccluded");
    g.sample_size(10);
    for (label, basis, eps, level) in [
        ("Haar level 5", BasisKind::Haar, 1e-4, 5u8),
        ("M2 level 4", BasisKind::Multiwavelet(2), 1e-4, 4),
        ("M2 level 5", BasisKind::Multiwavelet(2), 1e-4, 5),
        ("M3 level 3", BasisKind::Multiwavelet(3), 1e-4, 3),
        ("M3 level 4", BasisKind::Multiwavelet(3), 1e-4, 4),
    ] {
        let cfg = SolverConfig {
            basis,
            eps,
            max_level: level,
            ..SolverConfig::default()
        };
        if let Ok(s) = solve(&scene, &cfg) {
            println!(
                "{label}: L1 error {:.3e}, links {}, elements {}, bytes {}, rays {}, refine {:?}, solve {:?}",
                unoccluded_error(&s, &scene),
                s.stats.links,
                s.stats.elements,
                s.stats.bytes,
                s.stats.rays,
                s.stats.time_refine,
                s.stats.time_solve
            );
        }
        g.bench_function(label, |b| b.iter(|| black_box(solve(&scene, &cfg))));
    }
    g.finish();
}

fn cornell_solves(c: &mut Criterion) {
    let scene = cornell_box();
    let mut g = c.benchmark_group("solver/cornell");
    g.sample_size(10);
    for basis in [
        BasisKind::Haar,
        BasisKind::Multiwavelet(2),
        BasisKind::Multiwavelet(3),
    ] {
        let cfg = SolverConfig {
            basis,
            eps: 1e-2,
            max_level: 3,
            ..SolverConfig::default()
        };
        g.bench_function(basis.name(), |b| b.iter(|| black_box(solve(&scene, &cfg))));
    }
    g.finish();
}

/// Solver rays per second (refinement phase of a Cornell-box solve) divided by the raw
/// `Accel::occluded` throughput on random segments between the same supports.
fn ray_efficiency(c: &mut Criterion) {
    let scene = cornell_box();
    let cfg = SolverConfig {
        eps: 1e-2,
        max_level: 3,
        ..SolverConfig::default()
    };
    let prep = Prepared::new(&scene, &cfg).expect("cornell box prepares");
    let t = Instant::now();
    let sol = solve(&scene, &cfg).expect("cornell box solves");
    let _ = t.elapsed();
    let solver_rate = sol.stats.rays as f64 / sol.stats.time_refine.as_secs_f64();
    let pieces = &prep.patches.pieces;
    let mut rng = Pcg64::seed_from_u64(7);
    let (c0, s) = prep.frame;
    let segs: Vec<(DVec3, DVec3, u32, u32)> = (0..200_000)
        .map(|_| {
            let i = rng.random_range(0..pieces.len());
            let j = rng.random_range(0..pieces.len());
            let p = pieces[i].point(rng.random(), rng.random());
            let q = pieces[j].point(rng.random(), rng.random());
            ((p - c0) / s, (q - c0) / s, i as u32, j as u32)
        })
        .collect();
    let t = Instant::now();
    let blocked = segs
        .iter()
        .filter(|(p, q, i, j)| prep.accel.occluded(*p, *q, [Some(*i), Some(*j)]))
        .count();
    let raw_rate = segs.len() as f64 / t.elapsed().as_secs_f64();
    println!(
        "rays: solver {solver_rate:.3e}/s (all threads, incl. quadrature), raw single-thread \
{raw_rate:.3e}/s, ratio {:.3} ({} of {} raw segments blocked)",
        solver_rate / raw_rate,
        blocked,
        segs.len()
    );
    let mut g = c.benchmark_group("solver/rays");
    g.sample_size(10);
    g.bench_function("raw occlusion, 10k segments", |b| {
        b.iter(|| {
            segs[..10_000]
                .iter()
                .filter(|(p, q, i, j)| prep.accel.occluded(*p, *q, [Some(*i), Some(*j)]))
                .count()
        })
    });
    g.finish();
}

/// Linkless shooting (VirtualMesh §5) against gathering over links on "Unoccluded":
/// same basis and deepest level; the shooter runs to convergence. Elements, bytes and
/// kernel evaluations are printed once.
fn shoot_vs_gather(c: &mut Criterion) {
    use wavelux::solver::shoot::{ShootConfig, shoot};
    let scene = unoccluded();
    let gather = SolverConfig {
        basis: BasisKind::Multiwavelet(2),
        eps: 1e-4,
        max_level: 4,
        ..SolverConfig::default()
    };
    let shooting = ShootConfig {
        basis: BasisKind::Multiwavelet(2),
        eps: 2e-3,
        max_level: 4,
        convergence: 1.0,
        ..ShootConfig::default()
    };
    if let (Ok(a), Ok(b)) = (solve(&scene, &gather), shoot(&scene, &shooting)) {
        println!(
            "gather: L1 error {:.3e}, elements {}, links {}, bytes {}, kernel evals {}; \
shoot: L1 error {:.3e}, elements {}, shots {}, bytes {}, kernel evals {}",
            unoccluded_error(&a, &scene),
            a.stats.elements,
            a.stats.links,
            a.stats.bytes,
            a.stats.kernel_evals,
            unoccluded_error(&b, &scene),
            b.stats.elements,
            b.stats.shots,
            b.stats.bytes,
            b.stats.kernel_evals
        );
    }
    let mut g = c.benchmark_group("solver/shoot-vs-gather");
    g.sample_size(10);
    g.bench_function("gather M2 level 4", |b| {
        b.iter(|| black_box(solve(&scene, &gather)))
    });
    g.bench_function("shoot M2 level 4", |b| {
        b.iter(|| black_box(shoot(&scene, &shooting)))
    });
    g.finish();
}

criterion_group!(
    benches,
    unoccluded_solves,
    cornell_solves,
    ray_efficiency,
    shoot_vs_gather
);
criterion_main!(benches);
