//! Criterion benches for wavelux live in `benches/`; this library holds the scene and
//! query generators they share with the side-by-side tools in `examples/` (e.g.
//! `accel_vs_embree`), so that every measurement runs on the same triangles and rays,
//! and [`cpu_time`], criterion's measurement in CPU time.

pub mod cpu_time;

use glam::DVec3;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;
use wavelux_geometry::OcclusionQuery;

/// Icosphere triangles (outward), `level` subdivisions of the icosahedron.
pub fn icosphere(center: DVec3, r: f64, level: u32) -> Vec<[DVec3; 3]> {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let v0 = [
        (-1., t, 0.),
        (1., t, 0.),
        (-1., -t, 0.),
        (1., -t, 0.),
        (0., -1., t),
        (0., 1., t),
        (0., -1., -t),
        (0., 1., -t),
        (t, 0., -1.),
        (t, 0., 1.),
        (-t, 0., -1.),
        (-t, 0., 1.),
    ];
    let f0: [[usize; 3]; 20] = [
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    let mut tris: Vec<[DVec3; 3]> = f0
        .iter()
        .map(|f| f.map(|i| DVec3::new(v0[i].0, v0[i].1, v0[i].2).normalize()))
        .collect();
    for _ in 0..level {
        let mut next = Vec::with_capacity(tris.len() * 4);
        for [a, b, c] in tris {
            let (ab, bc, ca) = (
                (a + b).normalize(),
                (b + c).normalize(),
                (c + a).normalize(),
            );
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        tris = next;
    }
    tris.into_iter()
        .map(|t| t.map(|p| center + r * p))
        .collect()
}

/// Axis-aligned box room `size`, each wall an `n × n` grid of quads (2 triangles each).
pub fn room(size: DVec3, n: usize) -> Vec<[DVec3; 3]> {
    let mut out = Vec::new();
    let walls: [(DVec3, DVec3, DVec3); 6] = [
        (
            DVec3::ZERO,
            DVec3::new(size.x, 0.0, 0.0),
            DVec3::new(0.0, size.y, 0.0),
        ),
        (
            DVec3::new(0.0, 0.0, size.z),
            DVec3::new(0.0, size.y, 0.0),
            DVec3::new(size.x, 0.0, 0.0),
        ),
        (
            DVec3::ZERO,
            DVec3::new(0.0, 0.0, size.z),
            DVec3::new(size.x, 0.0, 0.0),
        ),
        (
            DVec3::new(0.0, size.y, 0.0),
            DVec3::new(size.x, 0.0, 0.0),
            DVec3::new(0.0, 0.0, size.z),
        ),
        (
            DVec3::ZERO,
            DVec3::new(0.0, size.y, 0.0),
            DVec3::new(0.0, 0.0, size.z),
        ),
        (
            DVec3::new(size.x, 0.0, 0.0),
            DVec3::new(0.0, 0.0, size.z),
            DVec3::new(0.0, size.y, 0.0),
        ),
    ];
    for (o, e1, e2) in walls {
        for i in 0..n {
            for j in 0..n {
                let p = |a: usize, b: usize| {
                    o + (a as f64 / n as f64) * e1 + (b as f64 / n as f64) * e2
                };
                out.push([p(i, j), p(i + 1, j), p(i + 1, j + 1)]);
                out.push([p(i, j), p(i + 1, j + 1), p(i, j + 1)]);
            }
        }
    }
    out
}

/// ~100k triangles: a 10×8×3 room (19 200 wall triangles) with 63 level-3 icospheres.
pub fn scene_room(r: &mut Pcg64) -> Vec<[DVec3; 3]> {
    let size = DVec3::new(10.0, 8.0, 3.0);
    let mut tris = room(size, 40);
    for _ in 0..63 {
        let c = DVec3::new(
            r.random_range(0.8..9.2),
            r.random_range(0.8..7.2),
            r.random_range(0.5..2.5),
        );
        tris.extend(icosphere(c, r.random_range(0.1..0.45), 3));
    }
    tris
}

/// ~1M triangles: a 60×60×20 hall (120k wall triangles) with 690 level-3 icospheres.
pub fn scene_big(r: &mut Pcg64) -> Vec<[DVec3; 3]> {
    let size = DVec3::new(60.0, 60.0, 20.0);
    let mut tris = room(size, 100);
    for _ in 0..690 {
        let c = DVec3::new(
            r.random_range(2.0..58.0),
            r.random_range(2.0..58.0),
            r.random_range(1.0..19.0),
        );
        tris.extend(icosphere(c, r.random_range(0.2..1.5), 3));
    }
    tris
}

/// Shadow-ray end points sampled uniformly on two random triangles each.
pub fn queries(tris: &[[DVec3; 3]], n: usize, r: &mut Pcg64) -> Vec<OcclusionQuery> {
    let sample = |r: &mut Pcg64| {
        let i = r.random_range(0..tris.len());
        let (mut a, mut b) = (r.random_range(0.0..1.0f64), r.random_range(0.0..1.0f64));
        if a + b > 1.0 {
            (a, b) = (1.0 - a, 1.0 - b);
        }
        let [p, q, s] = tris[i];
        (p + a * (q - p) + b * (s - p), i as u32)
    };
    (0..n)
        .map(|_| {
            let (p, i) = sample(r);
            let (q, j) = sample(r);
            OcclusionQuery {
                p,
                q,
                ignore: [Some(i), Some(j)],
            }
        })
        .collect()
}

/// The bench's `room_100k` triangles (seed 1, as `geometry`'s `occlusion` group).
pub fn room_100k() -> Vec<[DVec3; 3]> {
    scene_room(&mut Pcg64::seed_from_u64(1))
}
