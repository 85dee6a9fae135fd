//! Tests of the linkless shooting solver: agreement with the gathering solver and a
//! closed form, energy conservation at every shot, the white furnace, push/pull
//! variants, decoys, determinism, memory and configuration errors.

use glam::DVec3;
use std::f64::consts::{FRAC_PI_2, TAU};
use wavelux_geometry::formfactor::{area_form_factor, point_to_polygon};
use wavelux_scene::builtin::{cornell_box, unoccluded, white_furnace};

use wavelux_scene::shape::PlaneFrame;
use wavelux_scene::{
    AnalyticPatch, AnalyticSurface, Loop, Material, Placement, PolygonShape, Rgb, Scene, Shape,
    Sidedness, Surface,
};

use super::tree::Tree;
use super::twoscale::TwoScale;
use super::*;
use crate::basis::TreeBasis;
use crate::{SolverConfig, solve};

/// An open scene with occlusion: floor (ρ 0.5), a wall sharing an edge with it
/// (coloured ρ), a tilted light (E 10) and a blocker (ρ 0.3).
fn small_scene() -> Scene {
    let mut s = Scene::new("small");
    let floor = s.add_material(Material::lambertian("floor", Rgb::grey(0.5), Rgb::BLACK));
    let wall = s.add_material(Material::lambertian(
        "wall",
        Rgb::new(0.7, 0.4, 0.2),
        Rgb::BLACK,
    ));
    let light = s.add_material(Material::lambertian("light", Rgb::BLACK, Rgb::grey(10.0)));
    let block = s.add_material(Material::lambertian("block", Rgb::grey(0.3), Rgb::BLACK));
    let shapes = [
        (
            "floor",
            Shape::parallelogram(DVec3::ZERO, DVec3::X, DVec3::Y),
            floor,
        ),
        (
            "wall",
            Shape::parallelogram(DVec3::ZERO, DVec3::Y, DVec3::Z),
            wall,
        ),
        (
            "light",
            Shape::parallelogram(
                DVec3::new(0.3, 0.3, 1.0),
                DVec3::new(-0.1, 0.4, 0.05),
                DVec3::new(0.4, 0.1, 0.0),
            ),
            light,
        ),
        (
            "blocker",
            Shape::parallelogram(
                DVec3::new(0.4, 0.4, 0.5),
                DVec3::new(0.2, 0.05, 0.0),
                DVec3::new(-0.05, 0.2, 0.0),
            ),
            block,
        ),
    ];
    for (name, shape, material) in shapes {
        s.add_surface(Surface {
            name: name.into(),
            shape,
            material,
            sides: Sidedness::OneSided,
        });
    }
    s
}

fn small_cfg(basis: BasisKind) -> ShootConfig {
    ShootConfig {
        basis,
        eps: 1e-2,
        max_level: 3,
        convergence: 1.0 - 1e-6,
        ..ShootConfig::default()
    }
}

fn unoccluded_cfg(basis: BasisKind) -> ShootConfig {
    ShootConfig {
        basis,
        eps: 2e-3,
        max_level: 4,
        quad_points: 3,
        convergence: 1.0,
        ..ShootConfig::default()
    }
}

fn parallelogram_poly(shape: &Shape) -> Vec<DVec3> {
    let Shape::Parallelogram {
        origin,
        edge_u,
        edge_v,
    } = shape
    else {
        panic!("builtin S1 is a parallelogram");
    };
    vec![
        *origin,
        *origin + *edge_u,
        *origin + *edge_u + *edge_v,
        *origin + *edge_v,
    ]
}

/// The shooting bookkeeping `emitted = absorbed + unshot + operator_loss` (exact by
/// construction: it checks the accounting code, not the physics; the physics is
/// [`balance_error`] against the measured escape).
fn conservation_error(s: &Solution) -> f64 {
    let e = &s.energy;
    (0..3)
        .map(|c| {
            (e.emitted[c] - e.absorbed[c] - e.unshot[c] - e.operator_loss[c]).abs()
                / e.emitted[c].max(f64::MIN_POSITIVE)
        })
        .fold(0.0, f64::max)
}

/// `|emitted − absorbed − unshot − escaped|` over emitted, worst channel, with the
/// escaped power measured by rays (independent of the transfers).
fn balance_error(s: &Solution) -> f64 {
    let e = &s.energy;
    (0..3)
        .map(|c| e.imbalance()[c].abs() / e.emitted[c].max(f64::MIN_POSITIVE))
        .fold(0.0, f64::max)
}

/// The first shot of "Unoccluded" moves `E ∫∫G` onto S0 (exact contour-integral form
/// factor), S0's average agrees with the gathering solver, and the emitter (ρ = 0)
/// is never shot onto, so the run ends after S0's shot.
#[test]
fn unoccluded_matches_closed_form_and_gathering() {
    let scene = unoccluded();
    let s0 = vec![DVec3::ZERO, DVec3::X, DVec3::X + DVec3::Y, DVec3::Y];
    let s1 = parallelogram_poly(&scene.surfaces[1].shape);
    let aff = area_form_factor(&s1, &s0).unwrap();
    let e = 100.0;
    for basis in [BasisKind::Haar, BasisKind::Multiwavelet(2)] {
        let one = shoot(
            &scene,
            &ShootConfig {
                max_shots: 1,
                ..unoccluded_cfg(basis)
            },
        )
        .unwrap();
        let arrived = one.energy.absorbed[0] / (1.0 - 0.4);
        assert!(
            (arrived - e * aff).abs() <= 2e-3 * e * aff,
            "{}: arrived {arrived} vs exact {}",
            basis.name(),
            e * aff
        );
        let full = shoot(&scene, &unoccluded_cfg(basis)).unwrap();
        assert_eq!(full.stats.shots, 2, "S1 then S0");
        assert_eq!(full.stats.shooting_surfaces, 2);
        assert!(conservation_error(&full) < 1e-9);
        let gather = solve(
            &scene,
            &SolverConfig {
                basis,
                eps: 1e-4,
                max_level: 4,
                ..SolverConfig::default()
            },
        )
        .unwrap();
        let (a, b) = (full.surface_average(0)[0], gather.surface_average(0)[0]);
        assert!(
            (a - b).abs() <= 5e-3 * b,
            "{}: shoot {a} gather {b}",
            basis.name()
        );
        // Exact area average ρ E A1 F(1→0) / A0 with A0 = 1.
        assert!((a - 0.4 * e * aff).abs() <= 3e-3 * a);
        // Pointwise: the relative L1 error against `ρ E F(p → S1)` is that of the
        // gathering solver at the same depth (Haar needs the two-level control cells:
        // its four children are equal under the centred emitter).
        let l1 = |sol: &Solution| {
            let m = 32;
            let (mut num, mut den) = (0.0, 0.0);
            for j in 0..m {
                for i in 0..m {
                    let (u, v) = ((i as f64 + 0.5) / m as f64, (j as f64 + 0.5) / m as f64);
                    let exact = 0.4
                        * e
                        * point_to_polygon(DVec3::new(u, v, 0.0), DVec3::Z, &s1)
                            .unwrap()
                            .abs();
                    num += (sol.radiosity(0, u, v)[0] - exact).abs();
                    den += exact;
                }
            }
            num / den
        };
        let (es, eg) = (l1(&full), l1(&gather));
        assert!(
            es <= 1.3 * eg,
            "{}: L1 error shoot {es} gather {eg}",
            basis.name()
        );
    }
}

/// Emitted = absorbed + unshot + escaped after every shot (RGB), the unshot power
/// decreases, and the convergence record agrees with the energy.
#[test]
fn energy_is_conserved_at_every_shot() {
    let scene = small_scene();
    let cfg0 = small_cfg(BasisKind::Multiwavelet(2));
    let prep = Prepared::new(&scene, &cfg0.solver_config()).unwrap();
    let mut last_unshot = f64::INFINITY;
    for k in 1..=5 {
        let cfg = ShootConfig {
            max_shots: k,
            ..cfg0
        };
        let s = shoot_prepared(&prep, &cfg).unwrap();
        assert_eq!(s.stats.shots, k);
        let err = conservation_error(&s);
        assert!(err < 1e-9, "shot {k}: conservation error {err}");
        let e = s.energy;
        for c in 0..3 {
            assert!(e.escaped[c] > 0.0, "open scene");
            assert!(e.absorbed[c] > 0.0 && e.unshot[c] >= 0.0);
            assert!(
                e.imbalance()[c].abs() <= 4.0 * e.escaped_std_error[c] + 1e-2 * e.emitted[c],
                "shot {k} ch {c}: imbalance {} σ {}",
                e.imbalance()[c],
                e.escaped_std_error[c]
            );
        }
        let u: f64 = e.unshot.iter().sum();
        assert!(u < last_unshot, "unshot power decreases");
        last_unshot = u;
        let ei: f64 = e.emitted.iter().sum();
        let rate = *s.stats.shot_convergence.last().unwrap();
        assert!((rate - (ei - u) / ei).abs() < 1e-9);
    }
}

/// Shooting to convergence agrees with the gathering solver's surface averages
/// (every channel) within the discretisation tolerance, on an open scene with a
/// shadow and on the Cornell box (coarse levels keep the test fast).
#[test]
fn agrees_with_gathering() {
    let cases = [
        (small_scene(), BasisKind::Haar, 3u8, 1e-2, 1e-2),
        (small_scene(), BasisKind::Multiwavelet(2), 2, 1e-2, 2e-2),
        // Level 1 is coarse: the solvers' quadratures differ (a shot deposits the
        // finer control cells' transfer, a link its own block).
        (cornell_box(), BasisKind::Haar, 1, 2e-2, 4e-2),
    ];
    for (scene, basis, level, eps, tol) in cases {
        let s = shoot(
            &scene,
            &ShootConfig {
                basis,
                eps,
                max_level: level,
                convergence: 1.0 - 1e-5,
                ..ShootConfig::default()
            },
        )
        .unwrap();
        assert!(conservation_error(&s) < 1e-9);
        let g = solve(
            &scene,
            &SolverConfig {
                basis,
                eps: 1e-3,
                max_level: level,
                ..SolverConfig::default()
            },
        )
        .unwrap();
        for surf in 0..scene.surfaces.len() {
            let (a, b) = (s.surface_average(surf), g.surface_average(surf));
            for c in 0..3 {
                assert!(
                    (a[c] - b[c]).abs() <= tol * b[c] + 1e-12,
                    "{} {} L{level} {} channel {c}: shoot {} gather {}",
                    scene.name,
                    basis.name(),
                    scene.surfaces[surf].name,
                    a[c],
                    b[c]
                );
            }
        }
    }
}

fn furnace(basis: BasisKind, level: u8, eps: f64) -> (f64, f64, Solution) {
    let scene = white_furnace(1.0, 0.5).unwrap();
    let exact = 2.0;
    let cfg = ShootConfig {
        basis,
        eps,
        max_level: level,
        quad_points: 4,
        singular_order: 5,
        near_field: 1.5,
        convergence: 1.0 - 1e-5,
        ..ShootConfig::default()
    };
    let s = shoot(&scene, &cfg).unwrap();
    let mut worst: f64 = 0.0;
    let mut worst_avg: f64 = 0.0;
    for p in 0..s.patches.len() {
        for (u, v) in [(0.1, 0.1), (0.5, 0.5), (0.9, 0.3), (0.3, 0.7)] {
            worst = worst.max((s.radiosity(p, u, v)[0] - exact).abs() / exact);
        }
        worst_avg = worst_avg.max((s.patch_average(p)[0] - exact).abs() / exact);
    }
    (worst, worst_avg, s)
}

/// White furnace `B = E/(1 − ρ)`: with one element per face (Haar, level 0) the only
/// error is the quadrature of the form-factor row sums; with refinement the face
/// averages stay exact (deposits are projections, which keep integrals) and the
/// pointwise error stays within the summed per-shot tolerances (`eps` relative, RMS;
/// a factor 10 allows for point values of the linear pieces).
#[test]
fn white_furnace_closed_form() {
    let (worst, _, s) = furnace(BasisKind::Haar, 0, 1e-2);
    assert!(worst < 2e-3, "Haar level 0: {worst}");
    assert!(conservation_error(&s) < 1e-9);
    assert_eq!(s.energy.escaped[0], 0.0, "closed furnace: no ray escapes");
    assert!(balance_error(&s) < 2e-3);
    let eps = 1e-3;
    let (worst, avg, s) = furnace(BasisKind::Multiwavelet(2), 1, eps);
    assert!(s.stats.elements > 6, "refined");
    assert!(avg < 2e-3, "averages {avg}");
    assert!(worst < 10.0 * eps, "pointwise {worst}");
}

fn max_rel_diff(a: &Solution, b: &Solution) -> f64 {
    let scale = a.node_b[0].iter().fold(0.0f64, |m, v| m.max(v.abs()));
    (0..3)
        .flat_map(|c| a.node_b[c].iter().zip(&b.node_b[c]))
        .map(|(x, y)| (x - y).abs() / scale)
        .fold(0.0, f64::max)
}

/// With equal-area supports the natural (Gram-based) push/pull reproduces the
/// precomputed one: same elements, same radiosity to rounding; it holds more memory.
#[test]
fn natural_push_pull_matches_precomputed_on_equal_area_supports() {
    let scene = small_scene();
    let base = ShootConfig {
        max_shots: 8,
        ..small_cfg(BasisKind::Multiwavelet(2))
    };
    let a = shoot(&scene, &base).unwrap();
    let b = shoot(
        &scene,
        &ShootConfig {
            push_pull: PushPull::Natural { gauss: 4 },
            ..base
        },
    )
    .unwrap();
    assert_eq!(a.system.h.keys, b.system.h.keys);
    let d = max_rel_diff(&a, &b);
    assert!(d < 1e-10, "relative difference {d}");
    assert!(b.stats.bytes > a.stats.bytes);
}

/// The Gram-based matrices equal the two-scale matrices to 1e-12 for an equal-area
/// map (constant Jacobian), on every basis and at several levels.
#[test]
fn gram_matrices_reproduce_two_scale_matrices() {
    let scene = cornell_box();
    let prep = Prepared::new(&scene, &SolverConfig::default()).unwrap();
    for kind in [
        BasisKind::Haar,
        BasisKind::Multiwavelet(2),
        BasisKind::Multiwavelet(3),
    ] {
        let basis = TreeBasis::new(kind).unwrap();
        let pre = TwoScale::new(PushPull::Precomputed, &basis, &prep.patches.patches).unwrap();
        let nat = TwoScale::new(
            PushPull::Natural { gauss: 3 },
            &basis,
            &prep.patches.patches,
        )
        .unwrap();
        for key in [
            NodeKey::root(0),
            NodeKey::root(3).child(2),
            NodeKey::root(5).child(1).child(3).child(0),
        ] {
            let (p, q) = (pre.mats(&key), nat.mats(&key));
            for c in 0..4 {
                for (x, y) in p.pull[c].iter().zip(&q.pull[c]) {
                    assert!((x - y).abs() < 1e-12, "pull {x} vs {y}");
                }
                for (x, y) in p.push[c].iter().zip(&q.push[c]) {
                    assert!((x - y).abs() < 1e-12, "push {x} vs {y}");
                }
            }
        }
    }
}

/// Shooting onto a decoy and copying it back equals depositing on the tree itself
/// (levels, residuals and subdivisions).
#[test]
fn decoy_copy_back_equals_direct_deposits() {
    let scene = cornell_box();
    let prep = Prepared::new(&scene, &SolverConfig::default()).unwrap();
    let basis = TreeBasis::new(BasisKind::Multiwavelet(2)).unwrap();
    let ts = TwoScale::new(PushPull::Precomputed, &basis, &prep.patches.patches).unwrap();
    let n = basis.n();
    let rho = [0.3, 0.5, 0.7];
    let mut direct = Tree::new(0, &ts);
    let mut orig = Tree::new(0, &ts);
    let first = NodeKey::root(0).child(1).child(2);
    for t in [&mut direct, &mut orig] {
        let h: Vec<f64> = (0..3 * n).map(|i| 0.1 * i as f64 + 1.0).collect();
        t.deposit(first, &h, rho, &ts);
    }
    let deps = [
        (NodeKey::root(0).child(1).child(2).child(3), 2.0),
        (NodeKey::root(0).child(3), -0.5),
        (NodeKey::root(0), 0.25),
    ];
    let mut decoy = Tree::new(0, &ts);
    for (k, f) in deps {
        let h: Vec<f64> = (0..3 * n).map(|i| f * (1.0 + i as f64)).collect();
        direct.deposit(k, &h, rho, &ts);
        decoy.deposit(k, &h, rho, &ts);
    }
    orig.absorb(&decoy, &ts);
    let mut a: Vec<NodeKey> = direct.keys.clone();
    let mut b: Vec<NodeKey> = orig.keys.clone();
    a.sort();
    b.sort();
    assert_eq!(a, b);
    for q in 0..3 {
        let (x, y) = match q {
            0 => (&direct.b, &orig.b),
            1 => (&direct.db, &orig.db),
            _ => (&direct.h, &orig.h),
        };
        let cx = direct.consistent(x, &ts);
        let cy = orig.consistent(y, &ts);
        for (i, k) in direct.keys.iter().enumerate() {
            let j = orig.keys.iter().position(|o| o == k).unwrap();
            for v in 0..3 * n {
                assert!((cx[i * 3 * n + v] - cy[j * 3 * n + v]).abs() < 1e-12);
            }
        }
    }
}

/// Same result twice and with 1 vs 2 rayon threads (bitwise).
#[test]
fn deterministic_across_runs_and_threads() {
    let scene = small_scene();
    let cfg = ShootConfig {
        max_shots: 6,
        ..small_cfg(BasisKind::Multiwavelet(2))
    };
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| shoot(&scene, &cfg).unwrap())
    };
    let a = run(1);
    let b = run(2);
    let c = run(2);
    for s in [&b, &c] {
        assert_eq!(a.system.h.keys, s.system.h.keys);
        assert_eq!(a.node_b, s.node_b);
        assert_eq!(a.leaf_h, s.leaf_h);
        assert_eq!(a.energy, s.energy);
        assert_eq!(a.stats.shot_convergence, s.stats.shot_convergence);
        assert_eq!(a.stats.kernel_evals, s.stats.kernel_evals);
    }
}

/// No links: the bytes held are a fixed amount per element.
#[test]
fn memory_is_proportional_to_elements() {
    let scene = small_scene();
    let mut per_element = Vec::new();
    for (shots, level) in [(1, 1u8), (10, 4)] {
        let s = shoot(
            &scene,
            &ShootConfig {
                max_shots: shots,
                max_level: level,
                ..small_cfg(BasisKind::Haar)
            },
        )
        .unwrap();
        assert_eq!(s.stats.links, 0);
        assert_eq!(s.system.h.link_count(), 0);
        per_element.push(s.stats.bytes as f64 / s.stats.elements as f64);
        assert!(s.stats.elements > 0);
    }
    // Capacity slack of growing vectors is at most 2×.
    let (a, b) = (per_element[0], per_element[1]);
    assert!(b <= 2.5 * a && a <= 2.5 * b, "bytes/element {a} vs {b}");
}

/// Shooting stops at the first shot that reaches the requested convergence rate.
#[test]
fn stops_at_requested_convergence() {
    let scene = small_scene();
    for target in [0.5, 0.9, 0.99] {
        let s = shoot(
            &scene,
            &ShootConfig {
                convergence: target,
                ..small_cfg(BasisKind::Haar)
            },
        )
        .unwrap();
        let r = &s.stats.shot_convergence;
        assert!(*r.last().unwrap() >= target);
        assert!(r[..r.len() - 1].iter().all(|&v| v < target));
        assert!(r.windows(2).all(|w| w[1] >= w[0]));
    }
}

/// A scene without emission has nothing to shoot.
#[test]
fn dark_scene_is_black() {
    let scene = white_furnace(0.0, 0.5).unwrap();
    let s = shoot(&scene, &ShootConfig::default()).unwrap();
    assert_eq!(s.stats.shots, 0);
    assert_eq!(s.patch_average(0), [0.0; 3]);
}

#[test]
fn rejects_bad_config() {
    let scene = cornell_box();
    let d = ShootConfig::default();
    let cases = [
        ("eps", ShootConfig { eps: 0.0, ..d }),
        ("eps", ShootConfig { eps: f64::NAN, ..d }),
        (
            "control_depth",
            ShootConfig {
                control_depth: 4,
                ..d
            },
        ),
        (
            "convergence",
            ShootConfig {
                convergence: 1.5,
                ..d
            },
        ),
        (
            "convergence",
            ShootConfig {
                convergence: 0.0,
                ..d
            },
        ),
        ("max_shots", ShootConfig { max_shots: 0, ..d }),
        (
            "push_pull.gauss",
            ShootConfig {
                push_pull: PushPull::Natural { gauss: 0 },
                ..d
            },
        ),
        ("max_level", ShootConfig { max_level: 21, ..d }),
        (
            "quad_points",
            ShootConfig {
                quad_points: 0,
                ..d
            },
        ),
        (
            "min_area",
            ShootConfig {
                min_area: -1.0,
                ..d
            },
        ),
    ];
    for (field, cfg) in cases {
        match shoot(&scene, &cfg) {
            Err(SolverError::InvalidConfig { field: f, .. }) => assert_eq!(f, field),
            other => panic!(
                "{field}: expected InvalidConfig, got {:?}",
                other.map(|_| ())
            ),
        }
    }
    assert!(matches!(
        shoot(&Scene::new("empty"), &d),
        Err(SolverError::InvalidScene(_))
    ));
    let prep = Prepared::new(&scene, &d.solver_config()).unwrap();
    let other = ShootConfig {
        basis: BasisKind::Multiwavelet(3),
        ..d
    };
    assert!(matches!(
        shoot_prepared(&prep, &other),
        Err(SolverError::InvalidConfig { field: "basis", .. })
    ));
}

fn sphere(origin: DVec3, radius: f64) -> Shape {
    Shape::Patch(AnalyticPatch {
        surface: AnalyticSurface::Sphere {
            placement: Placement {
                origin,
                axis: DVec3::Z,
                reference: DVec3::X,
            },
            radius,
            azimuth: (0.0, TAU),
            latitude: (-FRAC_PI_2, FRAC_PI_2),
        },
        trim: None,
    })
}

fn grey(s: &mut Scene, name: &str, rho: f64, e: f64) -> usize {
    s.add_material(Material::lambertian(name, Rgb::grey(rho), Rgb::grey(e)))
}

fn add(s: &mut Scene, name: &str, shape: Shape, material: usize, sides: Sidedness) {
    s.add_surface(Surface {
        name: name.into(),
        shape,
        material,
        sides,
    });
}

/// The inside of a closed sphere sees only itself (a self-shooting surface, shot onto
/// a decoy): the kernel `1/(4πR²)` is constant, so `B = E/(1 − ρ)` exactly and no power
/// escapes.
#[test]
fn closed_sphere_interior_self_shoots_to_the_furnace_value() {
    let mut s = Scene::new("sphere furnace");
    let black = grey(&mut s, "black", 0.0, 0.0);
    let wall = grey(&mut s, "wall", 0.6, 1.0);
    add(
        &mut s,
        "sphere",
        sphere(DVec3::new(0.3, -0.2, 0.1), 1.7),
        black,
        Sidedness::TwoSided { back: wall },
    );
    let cfg = ShootConfig {
        max_level: 1,
        max_split_depth: 1,
        convergence: 1.0 - 1e-10,
        ..ShootConfig::default()
    };
    let sol = shoot(&s, &cfg).unwrap();
    let inside = sol.by_surface[0][1];
    let want = 1.0 / (1.0 - 0.6);
    for (a, b) in [(0.1, 0.1), (0.5, 0.5), (0.9, 0.7), (0.3, 0.99)] {
        let got = sol.radiosity(inside, a, b)[0];
        assert!((got - want).abs() < 1e-6 * want, "B({a},{b}) = {got}");
    }
    let e = sol.energy;
    assert!(conservation_error(&sol) < 1e-9);
    assert_eq!(e.escaped[0], 0.0, "closed: no ray escapes");
    assert!(balance_error(&sol) < 1e-6);
    assert!(sol.stats.shots > 10 && sol.stats.shooting_surfaces == 1);
}

/// The inside of a closed cylinder (a self-shooting tube and two disks) conserves
/// energy at every shot and converges to the furnace value on average.
#[test]
fn closed_cylinder_interior_conserves_energy() {
    let mut s = Scene::new("cylinder furnace");
    let black = grey(&mut s, "black", 0.0, 0.0);
    let wall = grey(&mut s, "wall", 0.5, 1.0);
    let (r, h) = (1.0, 1.5);
    add(
        &mut s,
        "tube",
        Shape::Patch(AnalyticPatch {
            surface: AnalyticSurface::Cylinder {
                placement: Placement {
                    origin: DVec3::ZERO,
                    axis: DVec3::Z,
                    reference: DVec3::X,
                },
                radius: r,
                azimuth: (0.0, TAU),
                height: (0.0, h),
            },
            trim: None,
        }),
        black,
        Sidedness::TwoSided { back: wall },
    );
    for (name, o, u, v) in [
        ("bottom", DVec3::ZERO, DVec3::X, DVec3::Y),
        ("top", DVec3::new(0.0, 0.0, h), DVec3::Y, DVec3::X),
    ] {
        add(
            &mut s,
            name,
            Shape::Polygon(PolygonShape {
                frame: PlaneFrame::from_directions(o, u, v).unwrap(),
                outer: Loop::circle(glam::DVec2::ZERO, r),
                holes: vec![],
            }),
            wall,
            Sidedness::OneSided,
        );
    }
    let cfg = ShootConfig {
        eps: 1e-2,
        max_level: 1,
        quad_points: 4,
        max_split_depth: 2,
        convergence: 1.0 - 1e-6,
        ..ShootConfig::default()
    };
    let sol = shoot(&s, &cfg).unwrap();
    assert!(conservation_error(&sol) < 1e-9);
    // A closed enclosure leaks only the transfer quadrature's error near the rims
    // (shared with the gathering solver, which leaks 3.6 % at these settings and 0.9 %
    // with 6 Gauss points; the shooter 3.0 % and 0.5 %).
    let e = sol.energy;
    assert!(
        e.escaped[0] <= 1e-3 * e.emitted[0],
        "rays escaped {}",
        e.escaped[0]
    );
    assert!(
        balance_error(&sol) < 0.04,
        "imbalance {}",
        balance_error(&sol)
    );
    assert!(sol.stats.shooting_surfaces == 3);
    let inside = sol.by_surface[0][1];
    let got = sol.patch_average(inside)[0];
    assert!((got - 2.0).abs() < 0.04 * 2.0, "tube average {got}");
}

fn lit_sphere() -> Scene {
    let mut s = Scene::new("lit sphere");
    let lamp = grey(&mut s, "lamp", 0.0, 1.0);
    let ball = grey(&mut s, "ball", 0.7, 0.0);
    add(
        &mut s,
        "lamp",
        Shape::parallelogram(
            DVec3::new(-1.0, -1.0, 3.0),
            DVec3::new(0.0, 2.0, 0.0),
            DVec3::new(2.0, 0.0, 0.0),
        ),
        lamp,
        Sidedness::OneSided,
    );
    add(
        &mut s,
        "ball",
        sphere(DVec3::ZERO, 1.0),
        ball,
        Sidedness::OneSided,
    );
    s
}

/// A sphere lit by a square lamp on its axis: 4-fold symmetric about the axis, so with
/// uniform refinement the solution repeats every quarter turn (`s + ¼`).
#[test]
fn sphere_lit_symmetrically_has_a_symmetric_solution() {
    let s = lit_sphere();
    let cfg = ShootConfig {
        eps: 1e-12,
        max_level: 2,
        max_split_depth: 1,
        ..ShootConfig::default()
    };
    let sol = shoot(&s, &cfg).unwrap();
    let p = sol.by_surface[1][0];
    let mut top: f64 = 0.0;
    for iy in 0..8 {
        for ix in 0..8 {
            let (s0, t0) = ((ix as f64 + 0.5) / 8.0, (iy as f64 + 0.5) / 8.0);
            let a = sol.radiosity(p, s0, t0)[0];
            let b = sol.radiosity(p, (s0 + 0.25) % 1.0, t0)[0];
            top = top.max(a);
            assert!(
                (a - b).abs() <= 1e-9 * a.abs().max(1e-12),
                "({s0},{t0}): {a} vs {b}"
            );
        }
    }
    assert!(top > 0.0);
    assert_eq!(
        sol.radiosity(p, 0.3, 0.1)[0],
        0.0,
        "lower hemisphere is dark"
    );
}

/// VirtualMesh Table 3's two variants on a curved patch: natural coordinates with
/// per-element Gram push/pull against equal-area maps with the precomputed
/// matrices give the same answer (within the discretisation), and precomputed
/// push/pull on a natural map is rejected.
#[test]
fn natural_coordinates_agree_with_equal_area() {
    let s = lit_sphere();
    let base = ShootConfig {
        eps: 1e-2,
        max_level: 2,
        max_split_depth: 1,
        basis: BasisKind::Multiwavelet(2),
        ..ShootConfig::default()
    };
    let a = shoot(&s, &base).unwrap();
    let nat = ShootConfig {
        push_pull: PushPull::Natural { gauss: 6 },
        ..base
    };
    let b = shoot(&s, &nat).unwrap();
    let (x, y) = (a.surface_average(1)[0], b.surface_average(1)[0]);
    assert!((x - y).abs() < 0.02 * x, "equal-area {x} vs natural {y}");
    assert!(conservation_error(&b) < 1e-9);
    let prep = Prepared::with_kind(&s, &base.solver_config(), ParamKind::Natural).unwrap();
    assert!(matches!(
        shoot_prepared(&prep, &base),
        Err(SolverError::InvalidConfig {
            field: "push_pull",
            ..
        })
    ));
}
