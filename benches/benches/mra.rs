//! wavelux-mra benches: non-standard decomposition throughput (coefficients/s) in 1D,
//! 2D, 3D and 4D for Haar, M2, M4 and CDV on arrays of about 2^20 coefficients, next to
//! a plain memory copy of the same data (the bandwidth bound). Each decomposition
//! iteration also copies the input back into the buffer (included in its time). The ratios are recorded
//! in docs/performance.md.
#![allow(missing_docs)] // reason: criterion's macros generate undocumented items

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use std::hint::black_box;
use std::time::Duration;
use wavelux::mra::tensor::nonstandard_decompose_with;
use wavelux::mra::{Alpert, Cdv, Mra};

/// Level whose side `len(level)` equals `side`.
fn level_for(m: &dyn Mra, side: usize) -> u32 {
    let mut j = m.min_level();
    while m.len(j) < side {
        j += 1;
    }
    j
}

fn decomposition(c: &mut Criterion) {
    let mras: Vec<Box<dyn Mra>> = vec![
        Box::new(Alpert::haar()),
        Box::new(Alpert::new(2).expect("M2")),
        Box::new(Alpert::new(4).expect("M4")),
        Box::new(Cdv::new()),
    ];
    // Sides with side^d ≈ 2^20 (2^21 in 3D).
    let sides = [
        (1usize, 1usize << 20),
        (2, 1 << 10),
        (3, 1 << 7),
        (4, 1 << 5),
    ];
    for (dim, side) in sides {
        let n = side.pow(dim as u32);
        let mut g = c.benchmark_group(format!("mra_decompose_{dim}d"));
        g.sample_size(10);
        g.warm_up_time(Duration::from_millis(500));
        g.measurement_time(Duration::from_secs(2));
        g.throughput(Throughput::Elements(n as u64));
        let data: Vec<f64> = (0..n).map(|i| ((i * 7919) % 1000) as f64 * 1e-3).collect();
        let mut buf = data.clone();
        let mut scratch = Vec::new();
        g.bench_function(BenchmarkId::new("memcpy", n), |b| {
            b.iter(|| {
                buf.copy_from_slice(black_box(&data));
                black_box(&buf);
            })
        });
        for m in &mras {
            let level = level_for(m.as_ref(), side);
            assert_eq!(m.len(level), side);
            g.bench_function(BenchmarkId::new(m.name(), n), |b| {
                b.iter(|| {
                    buf.copy_from_slice(&data);
                    nonstandard_decompose_with(
                        m.as_ref(),
                        dim,
                        level,
                        m.min_level(),
                        black_box(&mut buf),
                        &mut scratch,
                    )
                    .expect("valid sizes");
                })
            });
        }
        g.finish();
    }
}

criterion_group!(benches, decomposition);
criterion_main!(benches);
