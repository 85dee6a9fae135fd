//! wavelux-linear benches: cost of a solve relative to one operator application.
//!
//! Scene: the deterministic closed enclosure of
//! `crates/linear/examples/convergence_table.rs` (n = 400, ρ = 0.8), as a full CSR
//! matrix (160 000 entries) and as a banded one (|i − j| ≤ 16). Each solve runs to
//! relative residual 1e-10; dividing a solve's time by the `apply` time gives its
//! cost in application equivalents, to compare with the work counters.
#![allow(missing_docs)] // reason: criterion's macros generate undocumented items

use criterion::{Criterion, criterion_group, criterion_main};
use std::hint::black_box;
use wavelux::linear::{
    CsrMatrix, IdentityMinus, Operator, OverrelaxationKind, SolverOptions, bicgstab, gauss_seidel,
    gmres, overrelaxation, picard, progressive_refinement,
};

fn scene(n: usize, rho: f64, band: usize) -> (CsrMatrix, Vec<f64>, Vec<f64>) {
    let a0: Vec<f64> = (0..n).map(|i| 1.0 + (i % 5) as f64 / 4.0).collect();
    let w = |i: usize, j: usize| {
        let d = (i as f64 - j as f64) / 8.0;
        a0[i] * a0[j] / (1.0 + d * d)
    };
    let mut trip = Vec::new();
    let mut areas = vec![0.0; n];
    for i in 0..n {
        for j in 0..n {
            if i != j && i.abs_diff(j) <= band {
                areas[i] += w(i, j);
            }
        }
    }
    for i in 0..n {
        for j in 0..n {
            if i != j && i.abs_diff(j) <= band {
                trip.push((i, j, rho * w(i, j) / areas[i]));
            }
        }
    }
    let mut b = vec![0.0; n];
    b[0] = 1.0;
    (
        CsrMatrix::from_triplets(n, &trip).expect("valid triplets"),
        areas,
        b,
    )
}

fn solves(c: &mut Criterion) {
    let n = 400;
    for (label, band) in [("full", n), ("band16", 16)] {
        let (k, areas, b) = scene(n, 0.8, band);
        let a = IdentityMinus::new(&k);
        let opts = SolverOptions::default()
            .with_tolerance(1e-10)
            .with_max_iterations(10_000)
            .with_areas(areas)
            .with_reflectance(vec![0.8; n]);
        let mut g = c.benchmark_group(format!("linear_{label}_n400_rho0.8"));
        g.sample_size(20);
        let x: Vec<f64> = (0..n).map(|i| (i as f64).sin()).collect();
        let mut y = vec![0.0; n];
        g.bench_function("apply", |bch| {
            bch.iter(|| k.apply(black_box(&x), black_box(&mut y)))
        });
        g.bench_function("picard", |bch| {
            bch.iter(|| picard(&k, black_box(&b), &opts))
        });
        g.bench_function("gmres30", |bch| {
            bch.iter(|| gmres(&a, black_box(&b), &opts))
        });
        g.bench_function("bicgstab", |bch| {
            bch.iter(|| bicgstab(&a, black_box(&b), &opts))
        });
        g.bench_function("gauss_seidel", |bch| {
            bch.iter(|| gauss_seidel(&k, black_box(&b), &opts))
        });
        g.bench_function("progressive_refinement", |bch| {
            bch.iter(|| progressive_refinement(&k, black_box(&b), &opts))
        });
        g.bench_function("xu", |bch| {
            bch.iter(|| overrelaxation(&k, black_box(&b), OverrelaxationKind::Xu, &opts))
        });
        g.finish();
    }
}

criterion_group!(benches, solves);
criterion_main!(benches);
