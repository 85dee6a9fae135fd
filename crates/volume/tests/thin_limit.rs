//! Thin limit (issue 14 §6): two optically thin cells, one emitting; the power the
//! other collides is the first Neumann term of GlobalCube eq. (7), `K χᵗ`. The
//! model gathers at the receiver's centre, so it converges to the point-receiver term
//! `A_p h² ∫_{V_q} j / |x_p − x|² dV` (`j = P/(4π V)`); the volume–volume term of
//! eq. (18) differs from it by the receiver's finite size, `O((h/r)²)`, which the test
//! states and bounds.

mod common;

use common::{EMPTY, Vox, grid};
use glam::DVec3;
use wavelux_quadrature::GaussLegendre;
use wavelux_volume::active::{ActiveSet, WeightCache};
use wavelux_volume::backend::cpu::AntiAlias;
use wavelux_volume::hierarchy::{CoarseOpacity, Hierarchy};
use wavelux_volume::system::{System, SystemSettings, Work};
use wavelux_volume::{CpuProjector, Projection};

const N: usize = 16;
const SIGMA: f64 = 1e-6;
const POWER: f64 = 1.0;

fn nodes(k: usize) -> Vec<(f64, f64)> {
    let g = GaussLegendre::new(k).unwrap();
    g.nodes()
        .iter()
        .zip(g.weights())
        .map(|(x, w)| (0.5 * (x + 1.0), 0.5 * w))
        .collect()
}

/// `∫_{V_q} 1/|c − x|² dV` over the unit voxel at `q` (voxel units).
fn point_term(c: DVec3, q: DVec3) -> f64 {
    let g = nodes(16);
    let mut s = 0.0;
    for &(a, wa) in &g {
        for &(b, wb) in &g {
            for &(z, wz) in &g {
                s += wa * wb * wz / (c - (q + DVec3::new(a, b, z))).length_squared();
            }
        }
    }
    s
}

/// `∫_{V_p} ∫_{V_q} 1/|x − y|² dV dV` (voxel units).
fn volume_term(p: DVec3, q: DVec3) -> f64 {
    let g = nodes(8);
    let mut s = 0.0;
    for &(a, wa) in &g {
        for &(b, wb) in &g {
            for &(z, wz) in &g {
                s += wa * wb * wz * point_term(p + DVec3::new(a, b, z), q);
            }
        }
    }
    s
}

#[test]
fn two_thin_cells_match_the_first_neumann_term() {
    let q = [4usize, 8, 8];
    let a = -(-SIGMA).ln_1p();
    for (dx, dy) in [(2usize, 0usize), (3, 1), (5, 2), (8, 0)] {
        let p = [q[0] + dx, q[1] + dy, q[2]];
        let g = grid(N, 1.0, |x, y, z| {
            if [x, y, z] == q {
                Vox {
                    opacity: SIGMA,
                    source: [POWER; 3],
                    albedo: [0.0; 3],
                }
            } else if [x, y, z] == p {
                Vox {
                    opacity: SIGMA,
                    ..EMPTY
                }
            } else {
                EMPTY
            }
        });
        let h = Hierarchy::new(&g, 0, CoarseOpacity::Average).unwrap();
        let proj = CpuProjector::new(Projection::Exact, AntiAlias::default());
        let sys = System::new(
            &proj,
            SystemSettings {
                framebuffer: 64,
                ..SystemSettings::default()
            },
            &h,
            1.0,
            ActiveSet::uniform(N, 0),
            &mut WeightCache::default(),
        );
        let i = p[0] + N * (p[1] + N * p[2]);
        let c = sys
            .collide(&sys.sources, &[i], &mut Work::default())
            .unwrap();
        let model: f64 = c[0].iter().map(|f| f[0]).sum();
        let pc = DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64) + 0.5;
        let qv = DVec3::new(q[0] as f64, q[1] as f64, q[2] as f64);
        let j = POWER / (4.0 * std::f64::consts::PI);
        let point = a * j * point_term(pc, qv);
        let volume = a * j * volume_term(pc - 0.5, qv);
        let r = ((dx * dx + dy * dy) as f64).sqrt();
        let (e_point, gap) = (
            (model - point).abs() / point,
            (point - volume).abs() / volume,
        );
        eprintln!("r = {r:.2} h: model/point − 1 = {e_point:.2e}, point/volume − 1 = {gap:.2e}");
        assert!(e_point < 0.01, "r {r}: {e_point}");
        // The receiver-size gap of the centre gather: ≈ (h/r)²/8 (a cube's mean of 1/|x|²).
        assert!(gap < 0.2 / (r * r), "r {r}: gap {gap}");
    }
}
