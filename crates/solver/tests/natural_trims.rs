//! Trimmed analytic patches with natural-coordinate maps (VirtualMesh §6 Table 3's
//! non-constant-Jacobian variant): the trim, given in the equal-area square, is
//! carried to the natural square; the real area (`∫_R J`) must equal the exact area,
//! the real region must be the same set of 3-D points, and the shooting solver's
//! natural push/pull must agree with the precomputed one on the chess set.

use std::f64::consts::{FRAC_PI_2, TAU};

use glam::{DVec2, DVec3};
use wavelux_scene::{
    AnalyticPatch, AnalyticSurface, Loop, LoopEdge, Material, Placement, Region, Rgb, Scene, Shape,
    Sidedness, Surface,
};
use wavelux_solver::shoot::{PushPull, ShootConfig, shoot};
use wavelux_solver::{BasisKind, ParamKind, Support, SupportMap, build_patches_with};

fn placement() -> Placement {
    Placement {
        origin: DVec3::new(0.1, -0.2, 0.3),
        axis: DVec3::Z,
        reference: DVec3::X,
    }
}

/// A trim with a slanted edge, an arc bite and a hole with an arc, inside `[0,1]²`
/// and touching the seam `u = 0, 1`.
fn trim() -> Region {
    Region {
        outer: Loop {
            edges: vec![
                LoopEdge::Segment {
                    start: DVec2::new(0.0, 0.05),
                },
                LoopEdge::Segment {
                    start: DVec2::new(1.0, 0.2),
                },
                LoopEdge::Segment {
                    start: DVec2::new(1.0, 0.95),
                },
                LoopEdge::Arc {
                    start: DVec2::new(0.7, 0.95),
                    center: DVec2::new(0.55, 0.95),
                    ccw: false,
                },
                LoopEdge::Segment {
                    start: DVec2::new(0.4, 0.95),
                },
                LoopEdge::Segment {
                    start: DVec2::new(0.0, 0.8),
                },
            ],
        },
        holes: vec![Loop {
            edges: vec![
                LoopEdge::Segment {
                    start: DVec2::new(0.2, 0.4),
                },
                LoopEdge::Arc {
                    start: DVec2::new(0.4, 0.4),
                    center: DVec2::new(0.3, 0.4),
                    ccw: true,
                },
            ],
        }],
    }
}

fn scene_of(surface: AnalyticSurface) -> (Scene, Shape) {
    let shape = Shape::Patch(AnalyticPatch {
        surface,
        trim: Some(trim()),
    });
    let mut s = Scene::new("natural-trim");
    let m = s.add_material(Material::lambertian("m", Rgb::grey(0.5), Rgb::grey(1.0)));
    s.add_surface(Surface {
        name: "patch".into(),
        shape: shape.clone(),
        material: m,
        sides: Sidedness::OneSided,
    });
    (s, shape)
}

fn support(s: &Scene, kind: ParamKind) -> Support {
    build_patches_with(s, kind).unwrap().patches[0]
        .support
        .clone()
}

/// `Λ⁻¹` of a mapped support.
fn lambda_inv(sup: &Support, uv: DVec2) -> DVec2 {
    let SupportMap::Mapped { origin, e1, e2 } = sup.map else {
        panic!("not mapped")
    };
    let d = uv - origin;
    let det = e1.perp_dot(e2);
    DVec2::new(d.perp_dot(e2) / det, e1.perp_dot(d) / det)
}

fn check(surface: AnalyticSurface) -> f64 {
    let (s, shape) = scene_of(surface);
    let ea = support(&s, ParamKind::EqualArea);
    let nat = support(&s, ParamKind::Natural);
    assert!(ea.is_equal_area() && !nat.is_equal_area());
    let exact = shape.area();
    let err = (nat.real_area() - exact).abs() / exact;
    assert!(
        err < 1e-6,
        "natural real area {} vs {exact}",
        nat.real_area()
    );
    assert!((ea.real_area() - exact).abs() < 1e-9 * exact);
    // Same real points: random real-or-virtual points of the equal-area square.
    let (pe, pn) = (ea.param.clone().unwrap(), nat.param.clone().unwrap());
    let (re, rn) = (ea.mask.clone().unwrap(), nat.mask.clone().unwrap());
    let mut n_real = 0;
    // R2 low-discrepancy sequence (deterministic, well spread).
    let (g1, g2) = (0.754_877_666_246_692_8, 0.569_840_290_998_053_3);
    for k in 0..2000 {
        let uv = DVec2::new((0.5 + g1 * k as f64).fract(), (0.5 + g2 * k as f64).fract());
        let p = pe.position(uv);
        let q = pn.inverse(p).unwrap();
        let (a, b) = (lambda_inv(&ea, uv), lambda_inv(&nat, q));
        let inside = |x: DVec2| (0.0..=1.0).contains(&x.x) && (0.0..=1.0).contains(&x.y);
        let real_e = inside(a) && ea.is_real(a.x, a.y);
        let real_n = inside(b) && nat.is_real(b.x, b.y);
        // Points within 1e-6 of either boundary may fall either way.
        let near = re.region().contains_tol(uv, 1e-6) != re.region().contains(uv)
            || rn.region().contains_tol(q, 1e-6) != rn.region().contains(q)
            || [DVec2::X, DVec2::Y].iter().any(|&d| {
                re.region().contains(uv + 1e-6 * d) != re.region().contains(uv - 1e-6 * d)
            });
        assert!(real_e == real_n || near, "disagree at {uv} → {q}");
        n_real += usize::from(real_e);
        assert!((pn.position(q) - p).length() < 1e-9);
    }
    assert!(n_real > 200 && n_real < 1900, "{n_real}");
    err
}

#[test]
fn trimmed_sphere_keeps_area_and_real_points() {
    let err = check(AnalyticSurface::Sphere {
        placement: placement(),
        radius: 1.3,
        azimuth: (0.0, TAU),
        latitude: (-FRAC_PI_2, 0.9),
    });
    eprintln!("sphere natural real-area rel. error {err:.2e}");
}

#[test]
fn trimmed_cone_keeps_area_and_real_points() {
    let err = check(AnalyticSurface::Cone {
        placement: placement(),
        radius: 0.7,
        height: 1.1,
        azimuth: (0.0, TAU),
        generator: (0.3, 1.4),
    });
    eprintln!("cone natural real-area rel. error {err:.2e}");
}

#[test]
fn chess_set_shoots_with_natural_push_pull() {
    // Every trimmed patch of the full set keeps its area in natural coordinates.
    let full = wavelux_scene::virtual_mesh::chess_set_files(8).unwrap();
    let ea = build_patches_with(&full, ParamKind::EqualArea).unwrap();
    let nat = build_patches_with(&full, ParamKind::Natural).unwrap();
    let mut worst: f64 = 0.0;
    let varying = nat
        .patches
        .iter()
        .filter(|p| p.support.mask.is_some() && !p.support.is_equal_area())
        .count();
    eprintln!("chess set: {varying} trimmed natural patches with a varying Jacobian");
    for (a, b) in ea.patches.iter().zip(&nat.patches) {
        assert_eq!((a.surface, a.piece), (b.surface, b.piece));
        let e = (a.support.real_area() - b.support.real_area()).abs() / a.support.real_area();
        worst = worst.max(e);
    }
    eprintln!("chess set: worst natural/equal-area real-area rel. difference {worst:.2e}");
    assert!(varying > 0 && worst < 1e-6, "{varying} {worst}");
    let scene = wavelux_scene::virtual_mesh::chess_set_files(1).unwrap();
    let cfg = |push_pull| ShootConfig {
        basis: BasisKind::Haar,
        max_level: 1,
        convergence: 0.5,
        push_pull,
        ..ShootConfig::default()
    };
    let a = shoot(&scene, &cfg(PushPull::Precomputed)).unwrap();
    let b = shoot(&scene, &cfg(PushPull::Natural { gauss: 5 })).unwrap();
    let mean = |sol: &wavelux_solver::Solution| {
        (0..scene.surfaces.len())
            .map(|i| sol.surface_average(i)[0])
            .collect::<Vec<_>>()
    };
    let (ma, mb) = (mean(&a), mean(&b));
    let scale = ma.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let mut worst = 0.0f64;
    for (x, y) in ma.iter().zip(&mb) {
        worst = worst.max((x - y).abs() / scale);
    }
    eprintln!("chess set: worst surface-average difference {worst:.3} of the largest");
    assert!(worst < 0.05, "{worst}");
}
