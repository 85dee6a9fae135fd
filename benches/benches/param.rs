//! wavelux-param benches: map (unit square → surface) and inverse (point → unit square)
//! evaluations per second for every surface, equal-area against natural maps, the
//! direction maps, and minimal enclosing parallelograms.
#![allow(missing_docs)] // reason: criterion's macros generate undocumented items

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use std::hint::black_box;
use std::sync::Arc;
use wavelux::param::glam::{DVec2, DVec3};
use wavelux::param::{
    BezierCurve, BezierPatch, Cardioid, ConcentricHemisphere, Cone, Cylinder, DirectionMap, Frame,
    GeneralizedCylinder, GlossyHemisphere, Helix, OctahedralSphere, Parallelogram, Parametrization,
    Revolution, Sphere, Spheroid, TangentDevelopable, Torus, min_enclosing_parallelogram,
};

const N: usize = 256;

/// Deterministic low-discrepancy points of (0.02, 0.98)² (R2 sequence).
fn points(n: usize) -> Vec<DVec2> {
    let (a1, a2) = (0.754_877_666_246_692_7, 0.569_840_290_998_053_3);
    (0..n)
        .map(|i| {
            let i = i as f64 + 1.0;
            DVec2::new(
                0.02 + 0.96 * (i * a1).fract(),
                0.02 + 0.96 * (i * a2).fract(),
            )
        })
        .collect()
}

/// (name, equal-area map, natural map).
type Entry = (
    &'static str,
    Box<dyn Parametrization>,
    Box<dyn Parametrization>,
);

fn surfaces() -> Vec<Entry> {
    let f = Frame::new(
        DVec3::new(0.1, 0.2, 0.3),
        DVec3::new(0.2, 0.1, 1.0),
        DVec3::X,
    )
    .unwrap();
    let mut v: Vec<Entry> = Vec::new();
    let par = Parallelogram::new(
        DVec3::ZERO,
        DVec3::new(1.0, 0.2, 0.0),
        DVec3::new(0.3, 1.0, 0.1),
    )
    .unwrap();
    v.push(("parallelogram", Box::new(par), Box::new(par)));
    let cyl = Cylinder::new(f, 1.0, (0.0, 3.0), (0.0, 2.0)).unwrap();
    v.push(("cylinder", Box::new(cyl.clone()), Box::new(cyl.natural())));
    let cone = Cone::new(f, 0.5, 1.0, (0.0, 3.0), (0.2, 1.0)).unwrap();
    v.push(("cone", Box::new(cone.clone()), Box::new(cone.natural())));
    let sph = Sphere::new(f, 1.0, (0.0, 3.0), (-1.0, 1.2)).unwrap();
    v.push(("sphere", Box::new(sph.clone()), Box::new(sph.natural())));
    let spd = Spheroid::prolate(f, 1.0, 0.5, (0.0, 3.0), (-1.0, 1.2)).unwrap();
    v.push((
        "spheroid_e0.5",
        Box::new(spd.clone()),
        Box::new(spd.natural()),
    ));
    let tor = Torus::new(f, 2.0, 1.0, (0.0, 1.5), (0.0, 3.0)).unwrap();
    v.push(("torus", Box::new(tor.clone()), Box::new(tor.natural())));
    let prof = BezierCurve::new(vec![
        DVec3::new(0.5, 0.0, 0.0),
        DVec3::new(1.4, 0.0, 0.5),
        DVec3::new(0.2, 0.0, 1.0),
        DVec3::new(0.9, 0.0, 1.6),
    ])
    .unwrap();
    let rev = Revolution::new(f, Arc::new(prof), (0.0, 1.0), (0.0, 3.0)).unwrap();
    v.push((
        "revolution_bezier",
        Box::new(rev.clone()),
        Box::new(rev.natural()),
    ));
    let gc = GeneralizedCylinder::new(
        f,
        Arc::new(Cardioid::new(1.0).unwrap()),
        DVec3::Z,
        (0.0, 3.0),
        (0.0, 1.0),
    )
    .unwrap();
    v.push((
        "gen_cylinder_cardioid",
        Box::new(gc.clone()),
        Box::new(gc.natural()),
    ));
    let td = TangentDevelopable::new(
        f,
        Arc::new(Helix::new(1.0, 0.8).unwrap()),
        (0.0, 5.0),
        (0.1, 1.5),
    )
    .unwrap();
    v.push((
        "developable_helix",
        Box::new(td.clone()),
        Box::new(td.natural()),
    ));
    let mut ctrl = [[DVec3::ZERO; 4]; 4];
    for i in 0..4 {
        for j in 0..4 {
            let (x, y) = (i as f64, j as f64);
            ctrl[i][j] = DVec3::new(
                x + 0.3 * y,
                y * (1.0 + 0.2 * x),
                0.6 * ((x - 1.5) * (y - 1.5)).sin(),
            );
        }
    }
    let bp = BezierPatch::new(ctrl).unwrap();
    v.push((
        "bezier_bicubic",
        Box::new(bp.clone()),
        Box::new(bp.natural()),
    ));
    v
}

fn maps(c: &mut Criterion) {
    let uv = points(N);
    for (name, ea, nat) in surfaces() {
        let mut g = c.benchmark_group(format!("param_{name}"));
        g.sample_size(20);
        // The numerical Bézier map costs ~1e4 area-element evaluations per point.
        let uv = if name.starts_with("bezier") {
            &uv[..16]
        } else {
            &uv[..]
        };
        g.throughput(Throughput::Elements(uv.len() as u64));
        let pts: Vec<DVec3> = uv.iter().map(|p| ea.position(*p)).collect();
        for (kind, m) in [("equal_area", &ea), ("natural", &nat)] {
            g.bench_with_input(BenchmarkId::new("map", kind), uv, |b, uv| {
                b.iter(|| {
                    let mut acc = DVec3::ZERO;
                    for p in uv {
                        acc += m.eval(black_box(*p)).position;
                    }
                    acc
                })
            });
            g.bench_with_input(BenchmarkId::new("inverse", kind), &pts[..], |b, pts| {
                b.iter(|| {
                    let mut acc = DVec2::ZERO;
                    for p in pts {
                        acc += m.inverse(black_box(*p)).unwrap_or(DVec2::ZERO);
                    }
                    acc
                })
            });
        }
        g.finish();
    }
}

fn direction_maps(c: &mut Criterion) {
    let uv = points(N);
    let all: [(&str, &dyn DirectionMap); 3] = [
        ("glossy_hemisphere", &GlossyHemisphere),
        ("concentric_hemisphere", &ConcentricHemisphere),
        ("octahedral_sphere", &OctahedralSphere),
    ];
    let mut g = c.benchmark_group("direction_maps");
    g.throughput(Throughput::Elements(N as u64));
    for (name, m) in all {
        let dirs: Vec<DVec3> = uv.iter().map(|p| m.direction(*p)).collect();
        g.bench_with_input(BenchmarkId::new("map", name), &uv, |b, uv| {
            b.iter(|| {
                uv.iter()
                    .fold(DVec3::ZERO, |a, p| a + m.direction(black_box(*p)))
            })
        });
        g.bench_with_input(BenchmarkId::new("inverse", name), &dirs, |b, d| {
            b.iter(|| {
                d.iter().fold(DVec2::ZERO, |a, p| {
                    a + m.inverse(black_box(*p)).unwrap_or(DVec2::ZERO)
                })
            })
        });
    }
    g.finish();
}

fn mep(c: &mut Criterion) {
    let mut g = c.benchmark_group("min_enclosing_parallelogram");
    for n in [64usize, 1024] {
        let pts: Vec<DVec2> = points(n)
            .iter()
            .map(|p| DVec2::new(p.x * 3.0, p.y + 0.3 * p.x))
            .collect();
        g.throughput(Throughput::Elements(n as u64));
        g.bench_with_input(BenchmarkId::from_parameter(n), &pts, |b, pts| {
            b.iter(|| min_enclosing_parallelogram(black_box(pts)))
        });
    }
    g.finish();
}

criterion_group!(benches, maps, direction_maps, mep);
criterion_main!(benches);
