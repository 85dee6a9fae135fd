//! The volume particle tracer (`reference::volume`, issue 14 §6) against closed forms:
//! Beer–Lambert escape from a source cell through an absorbing cube (an independent
//! quadrature of `e^{−κℓ}` over the source cell and all directions), the clear grid
//! (everything escapes, nothing collides), determinism whatever the thread count, and
//! typed errors.

use glam::DVec3;
use ndarray::Array3;
use wavelux_render::reference::volume::{VolumeReferenceOptions, trace_volume};
use wavelux_volume::VolumeGrid;

/// An `n³` grid (voxel edge 1) of extinction `kappa` per voxel edge, albedo `omega`,
/// with one clear source cell of power `power` at `src`.
fn grid(n: usize, kappa: f64, omega: f64, src: [usize; 3], power: f64) -> VolumeGrid {
    let mut op = Array3::from_elem((n, n, n), 1.0 - (-kappa).exp());
    let mut s = Array3::zeros((n, n, n));
    op[(src[2], src[1], src[0])] = 0.0;
    s[(src[2], src[1], src[0])] = power;
    let al = Array3::from_elem((n, n, n), omega);
    VolumeGrid::new(
        "test",
        1.0,
        DVec3::ZERO,
        op,
        [s.clone(), s.clone(), s],
        [al.clone(), al.clone(), al],
    )
    .unwrap()
}

/// Exit distance from the box `[lo, hi]³` of a point inside it along unit `d`.
fn exit(p: [f64; 3], d: [f64; 3], lo: f64, hi: f64) -> f64 {
    (0..3)
        .map(|a| {
            if d[a] > 0.0 {
                (hi - p[a]) / d[a]
            } else if d[a] < 0.0 {
                (lo - p[a]) / d[a]
            } else {
                f64::INFINITY
            }
        })
        .fold(f64::INFINITY, f64::min)
}

/// Escaped fraction of light born uniformly in the clear centre cell `[m, m+1]³` of an
/// `n = 2m + 1` cube of extinction `kappa`, isotropically: midpoint rules over the cell
/// (8³) and the sphere (64 × 128 in `cos θ`, φ).
fn escape_quadrature(n: usize, kappa: f64) -> f64 {
    let m = (n / 2) as f64;
    let (kx, km, kp) = (8, 64, 128);
    let mut sum = 0.0;
    for i in 0..kx * kx * kx {
        let p = [i % kx, (i / kx) % kx, i / (kx * kx)].map(|k| m + (k as f64 + 0.5) / kx as f64);
        for a in 0..km {
            let mu = -1.0 + 2.0 * (a as f64 + 0.5) / km as f64;
            let r = (1.0 - mu * mu).sqrt();
            for b in 0..kp {
                let phi = 2.0 * std::f64::consts::PI * (b as f64 + 0.5) / kp as f64;
                let d = [r * phi.cos(), r * phi.sin(), mu];
                let t = exit(p, d, 0.0, n as f64) - exit(p, d, m, m + 1.0);
                sum += (-kappa * t).exp();
            }
        }
    }
    sum / (kx * kx * kx * km * kp) as f64
}

#[test]
fn beer_lambert_escape_matches_quadrature() {
    let n = 9;
    for kappa in [0.1, 0.5] {
        let g = grid(n, kappa, 0.0, [4, 4, 4], 2.0);
        let particles = 200_000;
        let est = trace_volume(
            &g,
            &VolumeReferenceOptions {
                particles,
                seed: 3,
                ..VolumeReferenceOptions::default()
            },
        )
        .unwrap();
        let want = escape_quadrature(n, kappa);
        let got = est.escaped[0] / est.emitted[0];
        // ω = 0: every particle escapes or is absorbed (binomial noise).
        let se = (want * (1.0 - want) / particles as f64).sqrt();
        assert!(
            (got - want).abs() < 4.0 * se + 1e-3 * want,
            "κ {kappa}: escaped {got:.5}, quadrature {want:.5} (se {se:.1e})"
        );
        // Nothing is lost: absorbed + escaped = emitted (every particle ends once).
        let bal = (est.emitted[0] - est.absorbed[0] - est.escaped[0]).abs() / est.emitted[0];
        assert!(bal < 1e-9, "balance {bal}");
        // The collided power is the absorbed power (ω = 0).
        let coll = est.collided[0].sum();
        assert!(
            (coll - est.absorbed[0]).abs() < 1e-9 * coll,
            "{coll} vs {:?}",
            est.absorbed
        );
    }
}

#[test]
fn clear_grid_lets_everything_escape() {
    let g = grid(4, 0.0, 0.5, [1, 2, 3], 1.5);
    let est = trace_volume(
        &g,
        &VolumeReferenceOptions {
            particles: 10_000,
            ..VolumeReferenceOptions::default()
        },
    )
    .unwrap();
    assert_eq!(est.collided[0].sum(), 0.0);
    assert!((est.escaped[1] - 1.5).abs() < 1e-12, "{:?}", est.escaped);
}

#[test]
fn deterministic_whatever_the_thread_count() {
    let g = grid(6, 0.8, 0.9, [2, 3, 1], 1.0);
    let opts = VolumeReferenceOptions {
        particles: 20_000,
        seed: 7,
        ..VolumeReferenceOptions::default()
    };
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| trace_volume(&g, &opts).unwrap())
    };
    let (a, b) = (run(1), run(3));
    assert_eq!(a, b);
    assert!(a.collided[0].sum() > 0.0);
}

#[test]
fn bad_options_are_errors() {
    let g = grid(2, 0.5, 0.5, [0, 0, 0], 1.0);
    for opts in [
        VolumeReferenceOptions {
            batches: 1,
            ..VolumeReferenceOptions::default()
        },
        VolumeReferenceOptions {
            particles: 0,
            ..VolumeReferenceOptions::default()
        },
    ] {
        assert!(trace_volume(&g, &opts).is_err(), "{opts:?}");
    }
}
