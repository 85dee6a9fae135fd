//! Parallelograms (VirtualMesh §3.3) and natural quadrics (Appendix A.1): equal-area
//! properties, round trips, normals against implicit gradients, extremes, errors.

mod common;

use common::{Check, check_area_ratio, check_map, rng, sample};
use glam::{DVec2, DVec3};
use std::f64::consts::{FRAC_PI_2, PI, TAU};
use wavelux_param::{
    Cone, Cylinder, Frame, Parallelogram, ParamError, ParamKind, Parametrization, Sphere,
};

const SCALES: [f64; 5] = [1e-4, 1e-2, 1.0, 1e2, 1e4];

fn tilted(scale: f64) -> Frame {
    Frame::new(
        DVec3::new(0.3, -1.2, 0.7) * scale,
        DVec3::new(0.2, 0.5, 1.0),
        DVec3::new(1.0, 0.1, -0.3),
    )
    .unwrap()
}

#[test]
fn parallelogram_is_affine_and_equal_area() {
    for &s in &SCALES {
        let p = Parallelogram::new(
            DVec3::new(1.0, 2.0, -0.5) * s,
            DVec3::new(2.0, 0.3, 0.1) * s,
            DVec3::new(0.4, 1.5, -0.7) * s,
        )
        .unwrap();
        let n = p.unit_normal();
        check_map(&p, &Check::new(s).margin(0.0).gradient(move |_| n));
        assert!((p.area() - p.e1().cross(p.e2()).length()).abs() <= 1e-15 * p.area());
    }
}

#[test]
fn thin_parallelograms_keep_point_round_trips() {
    // Edges at 1e-6 rad: parameters are ill-conditioned by 1/sin(angle) but points
    // round-trip exactly.
    for &s in &SCALES {
        let angle: f64 = 1e-6;
        let e1 = DVec3::new(1.0, 0.0, 0.0) * s;
        let e2 = DVec3::new(angle.cos(), angle.sin(), 0.0) * (2.0 * s);
        let p = Parallelogram::new(DVec3::splat(0.5 * s), e1, e2).unwrap();
        assert!((p.area() / (2.0 * s * s * angle.sin()) - 1.0).abs() < 1e-9);
        let mut c = Check::new(s).margin(0.02).uv_tol(1e-12 / angle);
        // Difference quotients of a 1e-6-rad sliver lose six digits to cancellation in
        // the cross product; the analytic Jacobian check stays at 1e-9.
        c.fd_tol = 1e-9 / angle;
        check_map(&p, &c);
    }
}

#[test]
fn parallelogram_rejects_degenerate_input() {
    let o = DVec3::ZERO;
    assert!(matches!(
        Parallelogram::new(o, DVec3::X, DVec3::X * 2.0),
        Err(ParamError::Degenerate(_))
    ));
    assert!(matches!(
        Parallelogram::new(o, DVec3::ZERO, DVec3::Y),
        Err(ParamError::Degenerate(_))
    ));
    assert!(matches!(
        Parallelogram::new(o, DVec3::new(f64::NAN, 0.0, 0.0), DVec3::Y),
        Err(ParamError::NonFinite { .. })
    ));
}

#[test]
fn cylinder_maps() {
    for &s in &SCALES {
        let f = tilted(s);
        let cyl = Cylinder::new(f, 0.7 * s, (-0.4, 2.9), (-0.3 * s, 1.1 * s)).unwrap();
        let g = move |p: DVec3| {
            let q = f.point_to_local(p);
            f.vector_to_world(DVec3::new(q.x, q.y, 0.0))
        };
        check_map(&cyl, &Check::new(s).gradient(g));
        check_map(&cyl.natural(), &Check::new(s));
        check_area_ratio(&cyl, &cyl.natural(), 1, 1e-12);
        assert!((cyl.area() - 0.7 * s * 3.3 * 1.4 * s).abs() <= 1e-14 * cyl.area());
    }
}

#[test]
fn full_cylinder_seam() {
    let cyl = Cylinder::new(Frame::canonical(), 1.0, (0.0, TAU), (0.0, 1.0)).unwrap();
    // Points just either side of the seam invert near u = 0 and u = 1.
    let a = cyl.inverse(DVec3::new(1.0, 1e-9, 0.5)).unwrap();
    let b = cyl.inverse(DVec3::new(1.0, -1e-9, 0.5)).unwrap();
    assert!(a.x < 1e-8 && b.x > 1.0 - 1e-8, "{a} {b}");
    assert!(cyl.inverse(DVec3::new(0.0, 0.0, 0.5)).is_none());
}

fn cone_gradient(f: Frame, a: f64, b: f64) -> impl Fn(DVec3) -> DVec3 {
    move |p: DVec3| {
        let q = f.point_to_local(p);
        f.vector_to_world(DVec3::new(q.x / (a * a), q.y / (a * a), -q.z / (b * b)))
    }
}

#[test]
fn cone_maps() {
    for &s in &SCALES {
        let f = tilted(s);
        let (a, b) = (0.6 * s, 1.3 * s);
        let cone = Cone::new(f, a, b, (0.2, 4.0), (0.3, 1.7)).unwrap();
        check_map(&cone, &Check::new(s).gradient(cone_gradient(f, a, b)));
        check_map(
            &cone.natural(),
            &Check::new(s).gradient(cone_gradient(f, a, b)),
        );
        check_area_ratio(&cone, &cone.natural(), 2, 1e-12);
        // Closed form: lateral area of a frustum piece.
        let l = a.hypot(b);
        let expect = 3.8 * a * l * (1.7f64 * 1.7 - 0.3 * 0.3) / 2.0;
        assert!((cone.area() - expect).abs() <= 1e-14 * expect);
    }
}

#[test]
fn cone_rays_near_the_apex() {
    // A cone patch that includes its apex; points within 1e-9 (relative) of the apex
    // still round-trip and the Jacobian stays constant.
    let (a, b) = (0.5, 2.0);
    let cone = Cone::new(Frame::canonical(), a, b, (0.0, TAU), (0.0, 1.0)).unwrap();
    for k in 1..=9 {
        let t = 10f64.powi(-2 * k);
        let uv = DVec2::new(0.3, t);
        let sp = cone.eval(uv);
        let phi = t.sqrt();
        assert!((sp.position.z - b * phi).abs() <= 1e-15 * b * phi.max(1e-300) + 1e-300);
        let back = cone.inverse(sp.position).unwrap();
        assert!((back.x - 0.3).abs() < 1e-12, "{back}");
        assert!((back.y - t).abs() <= 1e-12 * t, "t {t}: {back}");
        assert!((sp.tangent_jacobian() / cone.area() - 1.0).abs() < 1e-12);
        // The normal stays the cone's normal (independent of φ).
        let g = cone_gradient(Frame::canonical(), a, b)(sp.position).normalize();
        assert!(sp.normal.dot(g).abs() > 1.0 - 1e-12);
    }
}

fn sphere_gradient(f: Frame) -> impl Fn(DVec3) -> DVec3 {
    move |p: DVec3| p - f.origin()
}

#[test]
fn sphere_maps() {
    for &s in &SCALES {
        let f = tilted(s);
        let sph = Sphere::new(f, 0.9 * s, (-1.0, 2.5), (-0.7, 1.2)).unwrap();
        check_map(&sph, &Check::new(s).gradient(sphere_gradient(f)));
        check_map(&sph.natural(), &Check::new(s).gradient(sphere_gradient(f)));
        check_area_ratio(&sph, &sph.natural(), 3, 1e-12);
        let expect = 0.81 * s * s * 3.5 * (1.2f64.sin() - (-0.7f64).sin());
        assert!((sph.area() - expect).abs() <= 1e-14 * expect);
    }
}

#[test]
fn whole_sphere_and_polar_caps() {
    let sph = Sphere::full(Frame::canonical(), 2.0).unwrap();
    assert!((sph.area() - 16.0 * PI).abs() < 1e-12);
    check_map(&sph, &Check::new(2.0).margin(0.01));
    // A tiny cap at the north pole keeps full relative precision.
    let cap = Sphere::new(
        Frame::canonical(),
        1.0,
        (0.0, TAU),
        (FRAC_PI_2 - 1e-5, FRAC_PI_2),
    )
    .unwrap();
    // The cap's angular size as represented after rounding φ0.
    let delta = FRAC_PI_2 - (FRAC_PI_2 - 1e-5);
    let expect = TAU * 2.0 * (0.5 * delta).sin().powi(2);
    assert!(
        (cap.area() - expect).abs() <= 1e-12 * expect,
        "{} {expect}",
        cap.area()
    );
    check_map(&cap, &Check::new(1e-5).uv_tol(1e-9));
    // Southern cap too.
    let south = Sphere::new(
        Frame::canonical(),
        1.0,
        (0.0, 1.0),
        (-FRAC_PI_2, -FRAC_PI_2 + 1e-3),
    )
    .unwrap();
    check_map(&south, &Check::new(1e-3).uv_tol(1e-10));
}

#[test]
fn points_off_the_patch_invert_outside_the_unit_square() {
    let sph = Sphere::new(Frame::canonical(), 1.0, (0.0, 1.0), (0.0, 0.5)).unwrap();
    let uv = sph.inverse(DVec3::new(0.0, -1.0, 0.0)).unwrap();
    assert!(uv.x < 0.0 || uv.x > 1.0);
    let mut r = rng(11);
    for _ in 0..50 {
        let uv = sample(&mut r, 0.0, 1.0);
        // Radial offsets project back to the same parameters.
        let p = sph.position(uv) * 1.5;
        let back = sph.inverse(p).unwrap();
        assert!((back - uv).abs().max_element() < 1e-12);
    }
}

#[test]
fn constructors_reject_bad_input() {
    let f = Frame::canonical();
    assert!(matches!(
        Sphere::new(f, 0.0, (0.0, 1.0), (0.0, 1.0)),
        Err(ParamError::NonPositive { .. })
    ));
    assert!(matches!(
        Sphere::new(f, f64::NAN, (0.0, 1.0), (0.0, 1.0)),
        Err(ParamError::NonFinite { .. })
    ));
    assert!(matches!(
        Sphere::new(f, 1.0, (0.0, 7.0), (0.0, 1.0)),
        Err(ParamError::InvalidRange { .. })
    ));
    assert!(matches!(
        Sphere::new(f, 1.0, (0.0, 1.0), (0.0, 2.0)),
        Err(ParamError::InvalidRange { .. })
    ));
    assert!(matches!(
        Sphere::new(f, 1.0, (1.0, 1.0), (0.0, 1.0)),
        Err(ParamError::InvalidRange { .. })
    ));
    assert!(matches!(
        Cylinder::new(f, -1.0, (0.0, 1.0), (0.0, 1.0)),
        Err(ParamError::NonPositive { .. })
    ));
    assert!(matches!(
        Cone::new(f, 1.0, 1.0, (0.0, 1.0), (-0.5, 1.0)),
        Err(ParamError::InvalidRange { .. })
    ));
    assert!(matches!(
        Cone::new(f, 1.0, 0.0, (0.0, 1.0), (0.0, 1.0)),
        Err(ParamError::NonPositive { .. })
    ));
    assert!(Frame::new(DVec3::ZERO, DVec3::Z, DVec3::Z).is_err());
    assert!(Frame::from_axis(DVec3::ZERO, DVec3::ZERO).is_err());
}

#[test]
fn trait_objects_and_kinds() {
    let f = Frame::canonical();
    let v: Vec<Box<dyn Parametrization>> = vec![
        Box::new(Sphere::full(f, 1.0).unwrap().natural()),
        Box::new(Cone::new(f, 1.0, 1.0, (0.0, 1.0), (0.0, 1.0)).unwrap()),
        Box::new(
            Cylinder::new(f, 1.0, (0.0, 1.0), (0.0, 1.0))
                .unwrap()
                .natural(),
        ),
    ];
    assert_eq!(v[0].kind(), ParamKind::Natural);
    assert!(!v[0].is_equal_area());
    assert!(v[1].is_equal_area());
    assert!(
        v[2].is_equal_area(),
        "natural cylinder coordinates are equal-area"
    );
    fn assert_send_sync<T: Send + Sync + ?Sized>(_: &T) {}
    assert_send_sync(&v);
}
