//! Quadrature benches: Gauss–Legendre rule generation for n = 8, 32, 128.
#![allow(missing_docs)] // reason: criterion's macros generate undocumented items

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use std::hint::black_box;
use wavelux::quadrature::GaussLegendre;

fn gauss_generation(c: &mut Criterion) {
    let mut g = c.benchmark_group("gauss_legendre_new");
    for n in [8usize, 32, 128] {
        g.bench_with_input(BenchmarkId::from_parameter(n), &n, |b, &n| {
            b.iter(|| GaussLegendre::new(black_box(n)))
        });
    }
    g.finish();
}

criterion_group!(benches, gauss_generation);
criterion_main!(benches);
