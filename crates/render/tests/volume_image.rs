//! The emission–absorption image and slices of a solved medium against closed forms: a
//! clear emitting cube shows `χ ℓ / 4π` along a chord `ℓ`; a thin absorbing slab in
//! front of it multiplies that by its transmittance; slices show the emission density.

use glam::DVec3;
use ndarray::Array3;
use wavelux_render::{View, render_volume, volume_slice};
use wavelux_volume::{CpuProjector, GlobalCubeConfig, VolumeGrid, VolumeSolution};

const N: usize = 4;
const CHI: f64 = 2.0;

/// A unit cube of `N³` voxels: clear emitting cells (χ = CHI), and optionally a front
/// layer (`z = N − 1`) of opacity `front` that does not emit.
fn solve(front: Option<f64>) -> VolumeSolution {
    let mut op = Array3::zeros((N, N, N));
    let mut src = Array3::from_elem((N, N, N), CHI);
    if let Some(s) = front {
        for y in 0..N {
            for x in 0..N {
                op[(N - 1, y, x)] = s;
                src[(N - 1, y, x)] = 0.0;
            }
        }
    }
    let al = Array3::zeros((N, N, N));
    let g = VolumeGrid::new(
        "cube",
        1.0 / N as f64,
        DVec3::ZERO,
        op,
        [src.clone(), src.clone(), src],
        [al.clone(), al.clone(), al],
    )
    .unwrap();
    let cfg = GlobalCubeConfig {
        levels: 0,
        framebuffer: 4,
        ..GlobalCubeConfig::default()
    };
    wavelux_volume::solve(&g, &cfg, &CpuProjector::default(), &mut |_| {}).unwrap()
}

/// The centre pixel of a 3 × 3 image looking down −z through the cube's axis.
fn centre(sol: &VolumeSolution) -> [f64; 3] {
    let view = View::look_at(
        DVec3::new(0.5, 0.5, 3.0),
        DVec3::new(0.5, 0.5, 0.0),
        DVec3::Y,
        0.01,
        3,
        3,
    )
    .unwrap();
    render_volume(sol, &view, 1).unwrap().get(1, 1)
}

#[test]
fn clear_emitter_shows_chi_times_chord_over_four_pi() {
    let sol = solve(None);
    let want = CHI * 1.0 / (4.0 * std::f64::consts::PI);
    let got = centre(&sol);
    for c in got {
        assert!((c - want).abs() < 1e-9 * want, "{got:?} vs {want}");
    }
    // A ray missing the cube is black.
    let view = View::look_at(
        DVec3::new(3.0, 0.5, 3.0),
        DVec3::new(3.0, 0.5, 0.0),
        DVec3::Y,
        0.01,
        1,
        1,
    )
    .unwrap();
    assert_eq!(render_volume(&sol, &view, 2).unwrap().get(0, 0), [0.0; 3]);
    // Slices hold the emission density χ everywhere.
    for axis in 0..3 {
        let img = volume_slice(&sol, axis, 1).unwrap();
        assert!(
            img.pixels.iter().all(|p| (p[0] - CHI).abs() < 1e-9),
            "axis {axis}"
        );
    }
    assert!(volume_slice(&sol, 3, 0).is_err());
    assert!(volume_slice(&sol, 0, N).is_err());
    assert!(
        render_volume(
            &sol,
            &View::look_at(DVec3::Z, DVec3::ZERO, DVec3::Y, 0.5, 1, 1).unwrap(),
            0
        )
        .is_err()
    );
}

#[test]
fn absorbing_front_layer_attenuates_by_its_transmittance() {
    let sigma = 0.6;
    let sol = solve(Some(sigma));
    // The front layer emits what it scatters: nothing (albedo 0). Behind it, 3 of the
    // 4 voxels emit along the axis.
    let want = CHI * 0.75 / (4.0 * std::f64::consts::PI) * (1.0 - sigma);
    let got = centre(&sol);
    for c in got {
        assert!((c - want).abs() < 1e-9 * want, "{got:?} vs {want}");
    }
}
