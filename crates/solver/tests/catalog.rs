//! Two-patch configurations against the analytic catalog (Howell C-11, C-14, C-40):
//! with a black emitter of exitance `E` the receiver's average radiosity is exactly
//! `ρ F E`. Link blocks carry the exact constant parts of their pieces, so every run is
//! accurate whatever `(ε, max_level)`: to rounding where every link joins leaves, and
//! otherwise to the closure links' `δ (B_E − B_i)` (see `wavelux_solver::closure`),
//! below 1e-4 here.

use glam::DVec3;
use wavelux_geometry::formfactor::{coaxial_disks, parallel_rectangles, perpendicular_rectangles};
use wavelux_scene::{
    Loop, Material, PlaneFrame, PolygonShape, Rgb, Scene, Shape, Sidedness, Surface,
};
use wavelux_solver::{BasisKind, SolverConfig, solve};

const RHO: f64 = 0.5;
const E: f64 = 2.0;

fn two_patch(receiver: Shape, emitter: Shape) -> Scene {
    let mut s = Scene::new("two-patch");
    let mr = s.add_material(Material::lambertian("r", Rgb::grey(RHO), Rgb::BLACK));
    let me = s.add_material(Material::lambertian("e", Rgb::BLACK, Rgb::grey(E)));
    for (name, shape, m) in [("receiver", receiver, mr), ("emitter", emitter, me)] {
        s.add_surface(Surface {
            name: name.into(),
            shape,
            material: m,
            sides: Sidedness::OneSided,
        });
    }
    s
}

fn disk(center: DVec3, r: f64, up: bool) -> Shape {
    let (u, v) = if up {
        (DVec3::X, DVec3::Y)
    } else {
        (DVec3::Y, DVec3::X)
    };
    Shape::Polygon(PolygonShape {
        frame: PlaneFrame::from_directions(center, u, v).unwrap(),
        outer: Loop::circle(glam::DVec2::ZERO, r),
        holes: vec![],
    })
}

fn check(name: &str, scene: &Scene, f: f64, tol: f64) {
    let exact = RHO * f * E;
    let mut errs = Vec::new();
    for (eps, level, basis) in [
        (1e-2, 1u8, BasisKind::Haar),
        (1e-3, 3, BasisKind::Haar),
        (1e-3, 2, BasisKind::Multiwavelet(2)),
        (1e-3, 2, BasisKind::Multiwavelet(3)),
    ] {
        let cfg = SolverConfig {
            basis,
            eps,
            max_level: level,
            ..SolverConfig::default()
        };
        let sol = solve(scene, &cfg).unwrap();
        let avg = sol.surface_average(0)[0];
        let err = (avg - exact).abs() / exact;
        println!(
            "{name}: {} eps {eps:e} level {level}: average {avg:.8} exact {exact:.8} rel err {err:.2e} ({} links)",
            basis.name(),
            sol.stats.links
        );
        errs.push(err);
    }
    for e in &errs {
        assert!(*e < tol, "{name}: relative error {e} above {tol}: {errs:?}");
    }
}

#[test]
fn parallel_rectangles_match_catalog() {
    // Receiver [0,1]×[0,2] at z = 0 facing up, emitter the same at z = 0.7 facing down.
    let r = Shape::parallelogram(DVec3::ZERO, DVec3::X, 2.0 * DVec3::Y);
    let e = Shape::parallelogram(0.7 * DVec3::Z, 2.0 * DVec3::Y, DVec3::X);
    let f = parallel_rectangles(1.0, 2.0, 0.7).unwrap();
    check("parallel", &two_patch(r, e), f, 1e-4);
}

#[test]
fn perpendicular_rectangles_sharing_an_edge_match_catalog() {
    // Common edge along x of length 1; receiver of width 0.8 (y), emitter of height 1.5 (z).
    let r = Shape::parallelogram(DVec3::ZERO, DVec3::X, 0.8 * DVec3::Y);
    let e = Shape::parallelogram(DVec3::ZERO, 1.5 * DVec3::Z, DVec3::X);
    let f = perpendicular_rectangles(1.0, 0.8, 1.5).unwrap();
    check("perpendicular", &two_patch(r, e), f, 1e-4);
}

#[test]
fn coaxial_disks_match_catalog() {
    let r = disk(DVec3::ZERO, 0.6, true);
    let e = disk(DVec3::new(0.0, 0.0, 0.5), 0.4, false);
    // Receiver → emitter: the catalog gives F from disk r1 to r2.
    let f = coaxial_disks(0.6, 0.4, 0.5).unwrap();
    check("coaxial disks", &two_patch(r, e), f, 1e-4);
}
