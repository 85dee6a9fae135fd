//! The CPU projector does not depend on how the axes are labelled: a grid turned by the
//! cyclic permutation `x → y → z → x`, or transposed (`x ↔ y`), gives the same face
//! powers, faces permuted, up to rounding. The cube map is invariant under both (its
//! pixel directions are symmetric in `u`, `v` and under the cyclic turn), so what this
//! tests is the traversal's rule at exact edge and corner crossings, which cube-map
//! pixel centres produce systematically: with opaque cells and per-face emission a
//! rule that prefers one axis (the lowest first) changes the face powers by the
//! emission of the cells beside the edge (found by the GPU projector's tests, issue 17).

use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;
use wavelux_volume::TraversalCell;
use wavelux_volume::backend::cpu::{AntiAlias, CpuProjector, Projection};
use wavelux_volume::backend::{Emission, FaceRgb, ProjectionScene, Projector, Receiver};
use wavelux_volume::cell::{Collision, total_weight};

struct Scene {
    side: usize,
    cells: Vec<TraversalCell>,
    map: Vec<u32>,
    coefficients: Vec<FaceRgb>,
    power: Vec<[f64; 3]>,
}

impl Scene {
    fn push(&mut self, origin: [u32; 3], size: u32, ext: f64, e: FaceRgb) {
        let i = self.cells.len() as u32;
        let n = self.side;
        for z in 0..size {
            for y in 0..size {
                for x in 0..size {
                    let [a, b, c] =
                        [origin[0] + x, origin[1] + y, origin[2] + z].map(|v| v as usize);
                    self.map[a + n * (b + n * c)] = i;
                }
            }
        }
        self.cells.push(TraversalCell {
            origin,
            size,
            extinction: ext,
            total_weight: if ext > 0.0 {
                total_weight(ext * f64::from(size), Collision::Exact)
            } else {
                0.0
            },
        });
        self.coefficients.push(e);
        self.power.push([1.0; 3]);
    }

    fn view(&self) -> ProjectionScene<'_> {
        ProjectionScene {
            side: self.side,
            voxel: 1.0 / self.side as f64,
            cells: &self.cells,
            cell_map: &self.map,
        }
    }
}

/// An `n³` grid of single voxels and a few `2³` cells: opaque (a third), empty and
/// thin cells, random per-face emission.
fn random_scene(n: usize, seed: u64) -> Scene {
    let mut r = Pcg64::seed_from_u64(seed);
    let mut s = Scene {
        side: n,
        cells: Vec::new(),
        map: vec![u32::MAX; n * n * n],
        coefficients: Vec::new(),
        power: Vec::new(),
    };
    // Two coarse cells first.
    for o in [[0u32, 0, 0], [n as u32 - 2, 2, 0]] {
        let e: FaceRgb = std::array::from_fn(|_| [r.random_range(0.0..1.0), 0.3, 0.1]);
        s.push(o, 2, 0.7, e);
    }
    for z in 0..n {
        for y in 0..n {
            for x in 0..n {
                if s.map[x + n * (y + n * z)] != u32::MAX {
                    continue;
                }
                let u: f64 = r.random_range(0.0..1.0);
                let ext = if u < 0.33 {
                    f64::INFINITY
                } else if u < 0.5 {
                    0.0
                } else {
                    r.random_range(0.05..2.0)
                };
                let e: FaceRgb = std::array::from_fn(|_| {
                    [r.random_range(0.0..1.0), r.random_range(0.0..1.0), 0.5]
                });
                s.push([x as u32, y as u32, z as u32], 1, ext, e);
            }
        }
    }
    s
}

/// The scene with axis `a` relabelled `perm[a]` (cell order kept).
fn permuted(s: &Scene, perm: [usize; 3]) -> Scene {
    let mut out = Scene {
        side: s.side,
        cells: Vec::new(),
        map: vec![0; s.map.len()],
        coefficients: Vec::new(),
        power: Vec::new(),
    };
    for (c, e) in s.cells.iter().zip(&s.coefficients) {
        let mut o = [0u32; 3];
        let mut f: FaceRgb = [[0.0; 3]; 6];
        for a in 0..3 {
            o[perm[a]] = c.origin[a];
            f[2 * perm[a]] = e[2 * a];
            f[2 * perm[a] + 1] = e[2 * a + 1];
        }
        out.push(o, c.size, c.extinction, f);
    }
    out
}

fn gather(p: &CpuProjector, s: &Scene) -> Vec<FaceRgb> {
    let receivers: Vec<Receiver> = s
        .cells
        .iter()
        .enumerate()
        .filter(|(_, c)| c.extinction > 0.0)
        .map(|(i, _)| Receiver {
            cell: i as u32,
            framebuffer: [3, 4][i % 2],
        })
        .collect();
    let mut out = vec![[[0.0; 3]; 6]; receivers.len()];
    let emission = Emission {
        coefficients: &s.coefficients,
        power: &s.power,
    };
    p.gather(&s.view(), &emission, Collision::Exact, &receivers, &mut out)
        .unwrap();
    out
}

/// Worst over receivers of `max |a − b| / max |a|`, `b`'s faces mapped back by `perm`.
fn worst(a: &[FaceRgb], b: &[FaceRgb], perm: [usize; 3]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| {
            let scale = x.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
            let mut diff = 0.0f64;
            for a in 0..3 {
                for s in 0..2 {
                    for c in 0..3 {
                        diff = diff.max((x[2 * a + s][c] - y[2 * perm[a] + s][c]).abs());
                    }
                }
            }
            if scale > 0.0 { diff / scale } else { diff }
        })
        .fold(0.0, f64::max)
}

#[test]
fn face_powers_do_not_depend_on_axis_labels() {
    let s = random_scene(8, 5);
    let projectors = [
        CpuProjector::new(Projection::Exact, AntiAlias::OFF),
        CpuProjector::new(Projection::Exact, AntiAlias::default()),
        CpuProjector::new(Projection::Exact, AntiAlias::OFF).with_receiver_samples(2),
    ];
    for p in &projectors {
        let base = gather(p, &s);
        assert!(
            base.iter()
                .flatten()
                .flatten()
                .all(|v| v.is_finite() && *v >= 0.0)
        );
        for perm in [[1, 2, 0], [2, 0, 1], [1, 0, 2]] {
            let w = worst(&base, &gather(p, &permuted(&s, perm)), perm);
            eprintln!(
                "aa {} k {} perm {perm:?}: worst relative face difference {w:.2e}",
                p.antialias.subdivisions, p.receiver_samples
            );
            assert!(w <= 1e-12, "perm {perm:?}: {w:e}");
        }
    }
}

/// Opaque cells touching along an edge stay light-tight for rays through the edge: a
/// diagonal wall of opaque voxels in a plane (a staircase) hides the source behind it.
#[test]
fn an_opaque_staircase_is_light_tight_through_its_edges() {
    let n = 8;
    let mut s = Scene {
        side: n,
        cells: Vec::new(),
        map: vec![0; n * n * n],
        coefficients: Vec::new(),
        power: Vec::new(),
    };
    for z in 0..n {
        for y in 0..n {
            for x in 0..n {
                // Opaque voxels on the diagonal x = y (all z), black; a bright thin
                // source region on the side x > y + 1.
                let (ext, e) = if x == y {
                    (f64::INFINITY, [[0.0; 3]; 6])
                } else if x > y + 1 {
                    (0.5, [[1.0; 3]; 6])
                } else {
                    (0.5, [[0.0; 3]; 6])
                };
                s.push([x as u32, y as u32, z as u32], 1, ext, e);
            }
        }
    }
    // Receivers on the dark side, two or more voxels from the wall.
    let receivers: Vec<Receiver> = (0..s.cells.len())
        .filter(|&i| {
            let o = s.cells[i].origin;
            o[1] >= o[0] + 2
        })
        .map(|i| Receiver {
            cell: i as u32,
            framebuffer: 5,
        })
        .collect();
    let mut out = vec![[[0.0; 3]; 6]; receivers.len()];
    let emission = Emission {
        coefficients: &s.coefficients,
        power: &s.power,
    };
    let p = CpuProjector::new(Projection::Exact, AntiAlias::OFF);
    p.gather(&s.view(), &emission, Collision::Exact, &receivers, &mut out)
        .unwrap();
    let leak = out
        .iter()
        .flatten()
        .flatten()
        .fold(0.0f64, |m, v| m.max(*v));
    assert!(leak == 0.0, "light through the staircase: {leak:e}");
}
