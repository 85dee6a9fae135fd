//! The transport conserves power inside a medium: one face of one cell deep inside a
//! uniform grid emits 1 W, and the power every other cell collides plus what escapes
//! the grid adds up to 1 W (GlobalCube §3; the crate docs, "Energy conservation").
//! Inside a uniform medium the one-point gather's biases cancel by translation
//! symmetry, so this holds to the framebuffer's accuracy: checked for the open
//! defect's thick cells and nearly opaque ones, where little escapes (thinner media
//! send more to the escape measurement, whose `N = 8` error is a few per cent: +3.1 %
//! at `A = 0.5`). At the grid's boundary the paper's one-point escape does not
//! conserve (crate docs, "Thick, bright media"); the conserving escape of two or more
//! receiver samples counts a boundary cell's own outer face exactly and samples the
//! rest at moving points.

use wavelux_volume::TraversalCell;
use wavelux_volume::backend::cpu::{AntiAlias, CpuProjector, Projection};
use wavelux_volume::backend::{Emission, FaceRgb, ProjectionScene, Projector, Receiver};
use wavelux_volume::cell::{Collision, total_weight};

/// Collided plus escaped power when face `face` of voxel `at` of a uniform `n³` grid of
/// optical depth `a` per voxel emits 1 W.
fn column_sum(n: usize, a: f64, at: [usize; 3], face: usize, fb: u32, k: u32) -> (f64, f64) {
    let h = 1.0 / n as f64;
    let gh = total_weight(a, Collision::Exact);
    let cells: Vec<TraversalCell> = (0..n * n * n)
        .map(|i| TraversalCell {
            origin: [i % n, (i / n) % n, i / (n * n)].map(|v| v as u32),
            size: 1,
            extinction: a,
            total_weight: gh,
        })
        .collect();
    let map: Vec<u32> = (0..(n * n * n) as u32).collect();
    let scene = ProjectionScene {
        side: n,
        voxel: h,
        cells: &cells,
        cell_map: &map,
    };
    let q = at[0] + n * (at[1] + n * at[2]);
    let mut coefficients: Vec<FaceRgb> = vec![[[0.0; 3]; 6]; n * n * n];
    // e_s = 6 Chi_s / (Ĝ h²) emits Chi_s = 1 W over all directions.
    coefficients[q][face] = [6.0 / (gh * h * h); 3];
    let mut power = vec![[0.0; 3]; n * n * n];
    power[q] = [1.0; 3];
    let emission = Emission {
        coefficients: &coefficients,
        power: &power,
    };
    let p = CpuProjector::new(Projection::Exact, AntiAlias::OFF).with_receiver_samples(k);
    let receivers: Vec<Receiver> = (0..n * n * n)
        .map(|i| Receiver {
            cell: i as u32,
            framebuffer: fb,
        })
        .collect();
    let mut out = vec![[[0.0; 3]; 6]; receivers.len()];
    p.gather(&scene, &emission, Collision::Exact, &receivers, &mut out)
        .unwrap();
    let collided: f64 = out.iter().flatten().map(|f| f[0]).sum();
    let escaped = p.escape(&scene, &emission, fb).unwrap()[0];
    (collided, escaped)
}

#[test]
fn a_cell_inside_a_uniform_medium_loses_nothing() {
    // Depth per voxel: the defect's thick cells (τ 10 across 8 voxels), nearly opaque
    // (measured sums 1.0007 / 0.9975 and 1.0000 / 1.0000). Faces +x and −x of the voxel (4, 4, 4) (the grid is not symmetric about
    // it, so they differ).
    for a in [1.25, 10.0] {
        for face in [0, 1] {
            let (c, e) = column_sum(8, a, [4, 4, 4], face, 8, 1);
            eprintln!(
                "A {a} face {face}: collided {c:.4} escaped {e:.4} sum {:.4}",
                c + e
            );
            assert!(c.is_finite() && e >= 0.0 && c >= 0.0);
            assert!((c + e - 1.0).abs() <= 0.01, "A {a} face {face}: {}", c + e);
        }
    }
}

#[test]
fn the_conserving_escape_counts_boundary_faces_exactly() {
    // A boundary cell's outer face sends everything out of the grid: exactly 1 W with
    // the conserving escape (k = 2), 1.24 W from the square's centre (k = 1). Its side
    // faces and an edge cell's lose a little to the sampling of grazing light.
    let a = 1.25;
    let (c, e) = column_sum(8, a, [0, 4, 4], 1, 8, 1);
    eprintln!("k 1 outer face: collided {c:.4} escaped {e:.4}");
    assert!(c == 0.0 && (e - 1.2419).abs() < 1e-3, "{e}");
    let (c, e) = column_sum(8, a, [0, 4, 4], 1, 8, 2);
    eprintln!("k 2 outer face: collided {c:.4} escaped {e:.4}");
    assert!(c == 0.0 && (e - 1.0).abs() < 1e-12, "{e}");
    for (at, face, bound) in [([0, 4, 4], 2, LATERAL), ([0, 0, 4], 4, EDGE)] {
        let (c, e) = column_sum(8, a, at, face, 8, 2);
        eprintln!(
            "k 2 cell {at:?} face {face}: collided {c:.4} escaped {e:.4} sum {:.4}",
            c + e
        );
        assert!((c + e - 1.0).abs() <= bound, "{at:?} {face}: {}", c + e);
    }
}

/// Bound on a boundary cell's side face (measured 0.9993 with the conserving escape at
/// `k = 2`; 0.963 with regular points, 0.918 with one point at `k = 1`).
const LATERAL: f64 = 0.01;

/// Bound on an edge cell's face along the edge (measured 0.973; 0.936 with regular
/// points, 0.860 at `k = 1`): grazing light between two boundary squares.
const EDGE: f64 = 0.04;
