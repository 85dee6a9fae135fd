//! Numerically reparametrized surfaces (VirtualMesh §3.1.2 eq. (2), Appendix A.2):
//! surfaces of revolution, generalized cylinders, tangent developables and bicubic
//! Bézier patches, checked against closed forms where they exist.

mod common;

use common::{Check, adaptive, check_area_ratio, check_map, rng, sample};
use glam::{DVec2, DVec3};
use std::f64::consts::PI;
use std::sync::Arc;
use wavelux_param::{
    Aabb, BezierCurve, BezierPatch, Cardioid, Cone, Curve, Frame, GeneralizedCylinder, Helix,
    ParamError, Parametrization, Revolution, Sphere, TangentDevelopable,
};
use wavelux_quadrature::GaussLegendre;

fn tilted(scale: f64) -> Frame {
    Frame::new(
        DVec3::new(0.5, 0.2, -0.3) * scale,
        DVec3::new(0.1, -0.2, 1.0),
        DVec3::X,
    )
    .unwrap()
}

/// Unit semicircle profile (cos t, 0, sin t), t = latitude.
#[derive(Debug)]
struct Meridian(f64);

impl Curve for Meridian {
    fn point(&self, t: f64) -> DVec3 {
        DVec3::new(t.cos(), 0.0, t.sin()) * self.0
    }
    fn d1(&self, t: f64) -> DVec3 {
        DVec3::new(-t.sin(), 0.0, t.cos()) * self.0
    }
    fn d2(&self, t: f64) -> DVec3 {
        DVec3::new(-t.cos(), 0.0, -t.sin()) * self.0
    }
    fn bounds(&self, _: f64, _: f64) -> Aabb {
        Aabb {
            min: DVec3::splat(-self.0),
            max: DVec3::splat(self.0),
        }
    }
    fn derivative_bounds(&self, a: f64, b: f64) -> Aabb {
        self.bounds(a, b)
    }
}

#[test]
fn revolution_of_a_meridian_is_the_sphere_map() {
    for &s in &[1e-4, 1.0, 1e4] {
        let f = tilted(s);
        let rev = Revolution::new(f, Arc::new(Meridian(s)), (-1.0, 1.3), (0.2, 3.0)).unwrap();
        let sph = Sphere::new(f, s, (0.2, 3.0), (-1.0, 1.3)).unwrap();
        assert!((rev.area() - sph.area()).abs() <= 1e-13 * sph.area());
        let mut r = rng(3);
        for _ in 0..100 {
            let uv = sample(&mut r, 0.0, 1.0);
            assert!((rev.position(uv) - sph.position(uv)).length() <= 1e-12 * s);
            assert!((rev.normal(uv) - sph.normal(uv)).length() <= 1e-12);
        }
        let c = Check::new(s).gradient(move |p| p - f.origin());
        check_map(&rev, &c);
        check_map(&rev.natural(), &Check::new(s));
        check_area_ratio(&rev, &rev.natural(), 4, 1e-12);
    }
}

#[test]
fn revolution_of_a_line_is_the_cone_map() {
    let (a, b) = (0.6, 1.4);
    let line = BezierCurve::new(vec![
        DVec3::new(a * 0.2, 0.0, b * 0.2),
        DVec3::new(a * 1.5, 0.0, b * 1.5),
    ])
    .unwrap();
    let rev = Revolution::new(Frame::canonical(), Arc::new(line), (0.0, 1.0), (0.0, 2.0)).unwrap();
    let cone = Cone::new(Frame::canonical(), a, b, (0.0, 2.0), (0.2, 1.5)).unwrap();
    assert!((rev.area() - cone.area()).abs() <= 1e-13 * cone.area());
    let mut r = rng(4);
    for _ in 0..100 {
        let uv = sample(&mut r, 0.0, 1.0);
        assert!((rev.position(uv) - cone.position(uv)).length() <= 1e-13);
    }
}

#[test]
fn vase_shaped_revolution() {
    for &s in &[1e-4, 1.0, 1e4] {
        let prof = BezierCurve::new(
            [(0.5, 0.0), (1.4, 0.5), (0.2, 1.0), (0.9, 1.6)]
                .iter()
                .map(|&(x, z)| DVec3::new(x, 0.0, z) * s)
                .collect(),
        )
        .unwrap();
        let rev = Revolution::new(tilted(s), Arc::new(prof), (0.0, 1.0), (-PI, PI)).unwrap();
        check_map(&rev, &Check::new(s));
        check_map(&rev.natural(), &Check::new(s));
        check_area_ratio(&rev, &rev.natural(), 6, 1e-12);
    }
}

#[test]
fn cardioid_generalized_cylinder_matches_appendix_a2() {
    // u ∝ √(1 − cos θ) = √2 sin(θ/2), Jacobian 2√2 a in the paper's (u, φ) units.
    for &a in &[1e-4, 1.0, 1e4] {
        let th1 = PI - 0.2;
        let gc = GeneralizedCylinder::new(
            Frame::canonical(),
            Arc::new(Cardioid::new(a).unwrap()),
            DVec3::Z,
            (0.0, th1),
            (0.0, 2.0 * a),
        )
        .unwrap();
        let expect = 4.0 * a * (th1 / 2.0).sin() * 2.0 * a;
        assert!(
            (gc.area() - expect).abs() <= 1e-13 * expect,
            "{} {expect}",
            gc.area()
        );
        for k in 0..=20 {
            let th = th1 * k as f64 / 20.0;
            let p = Cardioid::new(a).unwrap().point(th) + DVec3::Z * a;
            let uv = gc.inverse(p).unwrap();
            let u_paper = (1.0 - th.cos()).sqrt() / (1.0 - th1.cos()).sqrt();
            assert!(
                (uv.x - u_paper).abs() < 1e-12,
                "θ {th}: {} vs {u_paper}",
                uv.x
            );
            assert!((uv.y - 0.5).abs() < 1e-12);
        }
        check_map(&gc, &Check::new(a).margin(0.03));
        check_map(&gc.natural(), &Check::new(a).margin(0.03));
        check_area_ratio(&gc, &gc.natural(), 7, 1e-12);
    }
}

#[test]
fn oblique_generalized_cylinder_over_a_bezier_base() {
    let base = BezierCurve::new(vec![
        DVec3::new(0.0, 0.0, 0.0),
        DVec3::new(1.0, 1.5, 0.0),
        DVec3::new(2.0, -1.0, 0.2),
        DVec3::new(3.0, 0.5, 0.0),
    ])
    .unwrap();
    let gc = GeneralizedCylinder::new(
        tilted(1.0),
        Arc::new(base),
        DVec3::new(0.3, 0.2, 1.0),
        (0.0, 1.0),
        (-0.5, 1.0),
    )
    .unwrap();
    check_map(&gc, &Check::new(1.0));
    check_area_ratio(&gc, &gc.natural(), 8, 1e-12);
}

#[test]
fn cardioid_tangent_developable_matches_appendix_a2() {
    // Ψ⁻¹ = (θ + sin θ, φ²), Jacobian 3a²/2 in the paper's units.
    let a = 1.3;
    let (t0, t1) = (0.1, 2.5);
    let td = TangentDevelopable::new(
        Frame::canonical(),
        Arc::new(Cardioid::new(a).unwrap()),
        (t0, t1),
        (0.2, 1.1),
    )
    .unwrap();
    let du_paper = (t1 + t1.sin()) - (t0 + t0.sin());
    let dv_paper = 1.1f64 * 1.1 - 0.2 * 0.2;
    let expect = 1.5 * a * a * du_paper * dv_paper;
    assert!(
        (td.area() - expect).abs() <= 1e-12 * expect,
        "{} {expect}",
        td.area()
    );
    let card = Cardioid::new(a).unwrap();
    for k in 0..=10 {
        let th = t0 + (t1 - t0) * k as f64 / 10.0;
        let phi = 0.7;
        let p = card.point(th) + card.d1(th) * phi;
        let uv = td.inverse(p).unwrap();
        let u_paper = ((th + th.sin()) - (t0 + t0.sin())) / du_paper;
        let v_paper = (phi * phi - 0.04) / dv_paper;
        assert!(
            (uv - DVec2::new(u_paper, v_paper)).abs().max_element() < 1e-11,
            "{uv}"
        );
    }
    check_map(&td, &Check::new(a));
    check_map(&td.natural(), &Check::new(a));
    check_area_ratio(&td, &td.natural(), 9, 1e-12);
}

#[test]
fn helix_tangent_developable() {
    for &s in &[1e-4, 1.0, 1e4] {
        let td = TangentDevelopable::new(
            tilted(s),
            Arc::new(Helix::new(s, 0.8 * s).unwrap()),
            (0.0, 5.0),
            (0.0, 1.5),
        )
        .unwrap();
        // Constant curvature: u is linear in θ.
        let mut c = Check::new(s);
        c.margin = 0.05;
        check_map(&td, &c);
        let uv = td
            .inverse(td.natural().position(DVec2::new(0.3, 0.5)))
            .unwrap();
        assert!((uv.x - 0.3).abs() < 1e-12);
        check_area_ratio(&td, &td.natural(), 10, 1e-12);
    }
}

#[test]
fn flat_surface_errors() {
    let f = Frame::canonical();
    let line = Arc::new(BezierCurve::new(vec![DVec3::ZERO, DVec3::X]).unwrap());
    assert!(matches!(
        TangentDevelopable::new(f, line.clone(), (0.0, 1.0), (0.0, 1.0)),
        Err(ParamError::Degenerate(_))
    ));
    assert!(GeneralizedCylinder::new(f, line.clone(), DVec3::X, (0.0, 1.0), (0.0, 1.0)).is_err());
    assert!(
        GeneralizedCylinder::new(f, line.clone(), DVec3::ZERO, (0.0, 1.0), (0.0, 1.0)).is_err()
    );
    let neg = Arc::new(
        BezierCurve::new(vec![DVec3::new(-1.0, 0.0, 0.0), DVec3::new(-1.0, 0.0, 1.0)]).unwrap(),
    );
    assert!(Revolution::new(f, neg, (0.0, 1.0), (0.0, 1.0)).is_err());
    assert!(BezierCurve::new(vec![DVec3::ZERO]).is_err());
    assert!(Cardioid::new(0.0).is_err());
}

fn curved_patch(scale: f64) -> BezierPatch {
    let mut ctrl = [[DVec3::ZERO; 4]; 4];
    for i in 0..4 {
        for j in 0..4 {
            let (x, y) = (i as f64, j as f64);
            let z = 0.6 * ((x - 1.5) * (y - 1.5)).sin() + 0.3 * x * x / 3.0;
            ctrl[i][j] = DVec3::new(x + 0.3 * y, y * (1.0 + 0.2 * x), z) * scale;
        }
    }
    BezierPatch::new(ctrl).unwrap()
}

#[test]
fn bezier_patch_equal_area() {
    for &s in &[1e-4, 1.0, 1e4] {
        let bp = curved_patch(s);
        check_map(&bp, &Check::new(s).samples(40));
        check_map(&bp.natural(), &Check::new(s).samples(40));
        // Area: independent adaptive quadrature of the natural Jacobian.
        let nat = bp.natural();
        let gl = GaussLegendre::new(24).unwrap();
        let (xs, ws) = gl.unit();
        let row = |t: f64| -> f64 {
            xs.iter()
                .zip(&ws)
                .map(|(x, w)| w * nat.jacobian(DVec2::new(*x, t)))
                .sum()
        };
        let exact = adaptive(&row, 0.0, 1.0, 1e-14, 20);
        assert!(
            (bp.area() - exact).abs() <= 1e-12 * exact,
            "{} {exact}",
            bp.area()
        );
        // Rectangles keep their area ratio: integrate the natural Jacobian over the
        // pre-image {s(u0) ≤ s ≤ s(u1), t(s, v0) ≤ t ≤ t(s, v1)}.
        let mut r = rng(12);
        for _ in 0..5 {
            let p = sample(&mut r, 0.05, 0.95);
            let q = sample(&mut r, 0.05, 0.95);
            let (a, b) = (p.min(q), p.max(q));
            let s0 = bp.natural_parameters(DVec2::new(a.x, 0.5)).x;
            let s1 = bp.natural_parameters(DVec2::new(b.x, 0.5)).x;
            let inner = |sv: f64| -> f64 {
                let u = bp.inverse(nat.position(DVec2::new(sv, 0.5))).unwrap().x;
                let t0 = bp.natural_parameters(DVec2::new(u, a.y)).y;
                let t1 = bp.natural_parameters(DVec2::new(u, b.y)).y;
                let g = GaussLegendre::new(20).unwrap();
                g.integrate(t0, t1, |t| nat.jacobian(DVec2::new(sv, t)))
            };
            let g = GaussLegendre::new(20).unwrap();
            let measured = g.integrate(s0, s1, inner);
            let expected = (b - a).x * (b - a).y * bp.area();
            assert!(
                (measured - expected).abs() <= 1e-9 * expected,
                "{measured} vs {expected}"
            );
        }
    }
}

#[test]
fn planar_bezier_parallelogram_is_affine() {
    let (o, e1, e2) = (
        DVec3::new(1.0, 2.0, 3.0),
        DVec3::new(2.0, 0.5, 0.0),
        DVec3::new(-0.3, 1.0, 0.4),
    );
    let mut ctrl = [[DVec3::ZERO; 4]; 4];
    for i in 0..4 {
        for j in 0..4 {
            ctrl[i][j] = o + e1 * (i as f64 / 3.0) + e2 * (j as f64 / 3.0);
        }
    }
    let bp = BezierPatch::new(ctrl).unwrap();
    assert!((bp.area() - e1.cross(e2).length()).abs() < 1e-13);
    let mut r = rng(1);
    for _ in 0..30 {
        let uv = sample(&mut r, 0.0, 1.0);
        assert!((bp.position(uv) - (o + e1 * uv.x + e2 * uv.y)).length() < 1e-13);
    }
    // Collapsed onto a line: zero area element.
    let mut flat = ctrl;
    for (i, row) in flat.iter_mut().enumerate() {
        for (j, p) in row.iter_mut().enumerate() {
            *p = o + e1 * ((i + j) as f64 / 6.0);
        }
    }
    assert!(matches!(
        BezierPatch::new(flat),
        Err(ParamError::Degenerate(_))
    ));
    let mut bad = ctrl;
    bad[1][2].x = f64::NAN;
    assert!(matches!(
        BezierPatch::new(bad),
        Err(ParamError::NonFinite { .. })
    ));
}
