//! Quadrature benches: Gauss–Legendre / Gauss–Jacobi / Gauss–Kronrod rule generation,
//! tensor and singular 4D rule construction, rule application throughput (against a
//! plain loop over the same points), masked-rule weights, adaptive cubature.
#![allow(missing_docs)] // reason: criterion's macros generate undocumented items

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use std::hint::black_box;
use wavelux::quadrature::adaptive::{GaussKronrod, Tolerance, genz_malik, integrate_1d};
use wavelux::quadrature::masked::{Disk, Polygon, cell_fractions_adaptive};
use wavelux::quadrature::singular::{Corner, SquarePair, square_pair_rule};
use wavelux::quadrature::{GaussJacobi, GaussLegendre, RuleNd};

fn gauss_generation(c: &mut Criterion) {
    let mut g = c.benchmark_group("gauss_legendre_new");
    for n in [8usize, 32, 128] {
        g.bench_with_input(BenchmarkId::from_parameter(n), &n, |b, &n| {
            b.iter(|| GaussLegendre::new(black_box(n)))
        });
    }
    g.finish();
    let mut g = c.benchmark_group("gauss_jacobi_new");
    for n in [8usize, 32, 128] {
        g.bench_with_input(BenchmarkId::from_parameter(n), &n, |b, &n| {
            b.iter(|| GaussJacobi::new(black_box(n), 1.0, 0.0))
        });
    }
    g.finish();
    c.bench_function("gauss_kronrod_new/7", |b| {
        b.iter(|| GaussKronrod::new(black_box(7)))
    });
}

/// A smooth stand-in for a form-factor integrand between two parallel unit squares at
/// distance 1 (so no singularity): cos θ cos θ' / (π r²) with r² = Δ² + 1.
fn parallel_kernel(p: &[f64]) -> f64 {
    let (ds, dt) = (p[2] - p[0], p[3] - p[1]);
    let r2 = ds * ds + dt * dt + 1.0;
    1.0 / (std::f64::consts::PI * r2 * r2)
}

fn rule_construction(c: &mut Criterion) {
    let mut g = c.benchmark_group("rule_build");
    g.bench_function("tensor_4d_n8", |b| {
        b.iter(|| RuleNd::tensor_unit_uniform(4, black_box(8)))
    });
    g.bench_function("tensor_6d_n4", |b| {
        b.iter(|| RuleNd::tensor_unit_uniform(6, black_box(4)))
    });
    let edge = SquarePair::common_edge(Corner::C00, Corner::C10, Corner::C00, Corner::C10).unwrap();
    let vertex = SquarePair::CommonVertex {
        receiver: Corner::C10,
        emitter: Corner::C00,
    };
    for (name, pair) in [
        ("identical", SquarePair::Identical),
        ("edge", edge),
        ("vertex", vertex),
    ] {
        g.bench_function(format!("singular_{name}_n8"), |b| {
            b.iter(|| square_pair_rule(black_box(pair), 8))
        });
    }
    g.finish();
}

fn rule_application(c: &mut Criterion) {
    let tensor = RuleNd::tensor_unit_uniform(4, 8).unwrap();
    let edge = square_pair_rule(
        SquarePair::common_edge(Corner::C00, Corner::C10, Corner::C00, Corner::C10).unwrap(),
        8,
    )
    .unwrap();
    let mut g = c.benchmark_group("rule_apply_4d");
    for (name, rule) in [("tensor_n8", &tensor), ("edge_n8", &edge)] {
        g.throughput(Throughput::Elements(rule.len() as u64));
        g.bench_function(format!("{name}/rule_integrate"), |b| {
            b.iter(|| black_box(rule).integrate(parallel_kernel))
        });
        // Baseline: the same kernel over the same flattened points, no rule machinery.
        let pts = rule.points().to_vec();
        let w = rule.weights().to_vec();
        g.bench_function(format!("{name}/plain_loop"), |b| {
            b.iter(|| {
                let p = black_box(&pts);
                let mut s = 0.0;
                for (k, &wk) in w.iter().enumerate() {
                    s += wk * parallel_kernel(&p[4 * k..4 * k + 4]);
                }
                s
            })
        });
    }
    g.finish();
}

fn masked_rules(c: &mut Criterion) {
    let outer: Vec<[f64; 2]> = (0..10)
        .map(|k| {
            let th = std::f64::consts::TAU * k as f64 / 10.0 + 0.1;
            let r = if k % 2 == 0 { 0.45 } else { 0.2 };
            [0.5 + r * th.cos(), 0.5 + r * th.sin()]
        })
        .collect();
    let hole = vec![[0.45, 0.45], [0.55, 0.45], [0.55, 0.55], [0.45, 0.55]];
    let star = Polygon::new(vec![outer, hole]).unwrap();
    let disk = Disk::new([0.5, 0.45], 0.3).unwrap();
    let mut g = c.benchmark_group("masked_fractions");
    for n in [8usize, 32] {
        g.bench_with_input(BenchmarkId::new("polygon_exact", n), &n, |b, &n| {
            b.iter(|| star.cell_fractions(black_box(n)))
        });
        g.bench_with_input(BenchmarkId::new("disk_adaptive_depth6", n), &n, |b, &n| {
            b.iter(|| cell_fractions_adaptive(&disk, black_box(n), 6))
        });
    }
    g.finish();
}

fn adaptive_cubature(c: &mut Criterion) {
    let mut g = c.benchmark_group("adaptive");
    let tol = Tolerance::new(1e-12, 0.0).unwrap();
    g.bench_function("gk15_sqrt_1e-12", |b| {
        b.iter(|| integrate_1d(|x: f64| x.sqrt(), 0.0, black_box(1.0), tol, 1_000_000))
    });
    let rel = Tolerance::new(0.0, 1e-6).unwrap();
    g.bench_function("genz_malik_4d_parallel_kernel_1e-6", |b| {
        b.iter(|| {
            genz_malik(
                parallel_kernel,
                &[0.0; 4],
                black_box(&[1.0; 4]),
                rel,
                10_000_000,
            )
        })
    });
    g.finish();
}

criterion_group!(
    benches,
    gauss_generation,
    rule_construction,
    rule_application,
    masked_rules,
    adaptive_cubature
);
criterion_main!(benches);
