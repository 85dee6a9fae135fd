//! Ring tori (VirtualMesh §3.1.3) and spheroids (Appendix A.1): equal-area maps with
//! numerical inverses, including the extreme shapes of the issue.

mod common;

use common::{Check, check_area_ratio, check_map};
use glam::{DVec2, DVec3};
use std::f64::consts::{FRAC_PI_2, PI, TAU};
use wavelux_param::{Frame, ParamError, Parametrization, Spheroid, Torus};

const SCALES: [f64; 5] = [1e-4, 1e-2, 1.0, 1e2, 1e4];

fn tilted(scale: f64) -> Frame {
    Frame::new(
        DVec3::new(-0.4, 0.9, 2.0) * scale,
        DVec3::new(-0.3, 0.4, 1.0),
        DVec3::new(0.2, 1.0, 0.1),
    )
    .unwrap()
}

fn torus_gradient(f: Frame, big_r: f64) -> impl Fn(DVec3) -> DVec3 {
    move |p| {
        let q = f.point_to_local(p);
        let rho = q.x.hypot(q.y);
        f.vector_to_world(DVec3::new(
            (rho - big_r) * q.x / rho,
            (rho - big_r) * q.y / rho,
            q.z,
        ))
    }
}

#[test]
fn torus_maps_across_scales() {
    for &s in &SCALES {
        let f = tilted(s);
        let t = Torus::new(f, 2.0 * s, 0.7 * s, (0.3, 2.2), (-2.5, 3.0)).unwrap();
        check_map(&t, &Check::new(s).gradient(torus_gradient(f, 2.0 * s)));
        check_map(
            &t.natural(),
            &Check::new(s).gradient(torus_gradient(f, 2.0 * s)),
        );
        check_area_ratio(&t, &t.natural(), 5, 1e-12);
    }
}

#[test]
fn paper_torus_patch_matches_section_3_1_3() {
    // R = 2, r = 1, θ ∈ [0, π/2], φ ∈ [0, π): v ∝ φ + ½ sin φ.
    let t = Torus::new(Frame::canonical(), 2.0, 1.0, (0.0, FRAC_PI_2), (0.0, PI)).unwrap();
    for k in 0..=10 {
        let phi = PI * k as f64 / 10.0;
        let p = DVec3::new(phi.cos() + 2.0, 0.0, phi.sin());
        let uv = t.inverse(p).unwrap();
        let expect = (phi + 0.5 * phi.sin()) / PI;
        assert!((uv.y - expect).abs() < 1e-15, "{phi}: {} vs {expect}", uv.y);
    }
    // Jacobian of Ψ in the paper's [0, π]² domain (u = 2θ, v = φ + ½ sin φ) is 1/c = 1;
    // ours on [0, 1]² is that times π².
    assert!((t.area() - PI * PI).abs() < 1e-13);
    // Exact patch area ∫∫ r (R + r cos φ) dθ dφ = (π/2)·2π.
    assert!((t.area() - FRAC_PI_2 * 2.0 * PI).abs() < 1e-13);
    // Fig. 4: Jacobians measured by finite differences of the positions (not the
    // analytic formula) on a 32×32 grid of cell centres: Ψ's is constant (1/c = 1 on
    // [0, π]²), the natural map's ∝ R + r cos φ, max/min = (R + cos φ_lo)/(R + cos φ_hi).
    let measured = |m: &Torus, uv: DVec2| {
        let d = uv.x.min(1.0 - uv.x).min(uv.y.min(1.0 - uv.y)).min(0.1);
        let h = 1e-3 * d;
        let pos = |x: DVec2| m.position(x);
        common::fd(&pos, uv, DVec2::X, h)
            .cross(common::fd(&pos, uv, DVec2::Y, h))
            .length()
            / (PI * PI)
    };
    let (ea, nat) = (t.equal_area(), t.natural());
    let n = 32;
    let (mut ea_lo, mut ea_hi, mut nat_lo, mut nat_hi) = (f64::MAX, 0.0f64, f64::MAX, 0.0f64);
    for i in 0..n {
        for j in 0..n {
            let uv = DVec2::new((i as f64 + 0.5) / n as f64, (j as f64 + 0.5) / n as f64);
            let (a, b) = (measured(&ea, uv), measured(&nat, uv));
            (ea_lo, ea_hi) = (ea_lo.min(a), ea_hi.max(a));
            (nat_lo, nat_hi) = (nat_lo.min(b), nat_hi.max(b));
        }
    }
    assert!(
        (ea_lo - 1.0).abs() < 1e-9 && (ea_hi - 1.0).abs() < 1e-9,
        "{ea_lo} {ea_hi}"
    );
    let phi_lo = 0.5 * PI / n as f64;
    let closed = (2.0 + phi_lo.cos()) / (2.0 + (PI - phi_lo).cos());
    assert!(((nat_hi / nat_lo) - closed).abs() < 1e-9 * closed);
}

#[test]
fn torus_extreme_radius_ratios() {
    for &k in &[1e-6, 0.999] {
        for &s in &[1e-4, 1.0, 1e4] {
            let big = s;
            let small = k * s;
            let f = tilted(s);
            let t = Torus::new(f, big, small, (0.0, TAU), (-PI, PI)).unwrap();
            // Point coordinates carry rounding ~ε·R, i.e. ε·R/r relative to the tube.
            let uv_tol = 1e-12 + 8.0 * f64::EPSILON / k;
            let mut c = Check::new(small)
                .gradient(torus_gradient(f, big))
                .uv_tol(uv_tol);
            c.point_tol = 1e-12 * big / small;
            if k < 1e-3 {
                // Difference quotients of a 1e-6-thin tube: the v-tangent is r-sized
                // against R-sized coordinates.
                c.fd_tol = 1e-6;
                c.fd_step = 1e-2;
            }
            check_map(&t, &c);
            check_map(&t.natural(), &c);
            let exact = 4.0 * PI * PI * big * small;
            assert!((t.area() - exact).abs() <= 1e-13 * exact);
            // Corners are pulled back through the (ε·R/r-conditioned) inverse.
            check_area_ratio(&t, &t.natural(), 9, 1e-11 + uv_tol * 10.0);
        }
    }
}

#[test]
fn torus_rejects_horn_and_spindle() {
    let f = Frame::canonical();
    assert!(matches!(
        Torus::new(f, 1.0, 1.0, (0.0, 1.0), (0.0, 1.0)),
        Err(ParamError::NotRingTorus { .. })
    ));
    assert!(matches!(
        Torus::new(f, 1.0, 2.0, (0.0, 1.0), (0.0, 1.0)),
        Err(ParamError::NotRingTorus { .. })
    ));
    assert!(Torus::new(f, 1.0, 0.0, (0.0, 1.0), (0.0, 1.0)).is_err());
    assert!(Torus::new(f, f64::INFINITY, 0.5, (0.0, 1.0), (0.0, 1.0)).is_err());
}

#[test]
fn torus_uv_outside_the_square_extends_the_surface() {
    let t = Torus::new(Frame::canonical(), 3.0, 1.0, (0.0, 1.0), (0.0, 1.0)).unwrap();
    for &v in &[-0.5, 1.7] {
        let uv = DVec2::new(0.4, v);
        let p = t.position(uv);
        let back = t.inverse(p).unwrap();
        assert!((back - uv).abs().max_element() < 1e-12, "{uv} -> {back}");
    }
}

fn spheroid_gradient(f: Frame, a: f64, b: f64) -> impl Fn(DVec3) -> DVec3 {
    move |p| {
        let q = f.point_to_local(p);
        f.vector_to_world(DVec3::new(q.x / (a * a), q.y / (a * a), q.z / (b * b)))
    }
}

fn full_area(sp: &Spheroid) -> f64 {
    let (a, b, e) = (
        sp.equatorial_semi_axis(),
        sp.polar_semi_axis(),
        sp.eccentricity(),
    );
    if e == 0.0 {
        return 4.0 * PI * a * a;
    }
    if sp.is_prolate() {
        TAU * a * a * (1.0 + b / a * e.asin() / e)
    } else {
        TAU * a * a * (1.0 + b * b / (a * a) * e.atanh() / e)
    }
}

#[test]
fn spheroids_across_eccentricities_and_scales() {
    for &e in &[0.0, 1e-8, 0.5, 0.999999] {
        for &s in &SCALES {
            for prolate in [true, false] {
                let f = tilted(s);
                let whole = (-PI, PI);
                let lat = (-FRAC_PI_2, FRAC_PI_2);
                let sp = if prolate {
                    Spheroid::prolate(f, s, e, whole, lat).unwrap()
                } else {
                    Spheroid::oblate(f, s, e, whole, lat).unwrap()
                };
                let exact = full_area(&sp);
                assert!(
                    (sp.area() - exact).abs() <= 1e-12 * exact,
                    "e {e} prolate {prolate}: {} vs {exact}",
                    sp.area()
                );
                let (a, b) = (sp.equatorial_semi_axis(), sp.polar_semi_axis());
                let patch = Spheroid::new(f, a, b, (-0.5, 2.0), (-1.2, 1.4)).unwrap();
                let mut c = Check::new(s)
                    .gradient(spheroid_gradient(f, a, b))
                    .samples(60);
                if e > 0.9 {
                    // The rim (oblate) or tip (prolate) has features of relative size
                    // √(1 − e²) ≈ 1.4e-3; resolve them with smaller steps.
                    c.fd_step = 2e-4;
                    // The needle's u-tangent (prolate) or the disc's thickness (oblate)
                    // is √(1 − e²) ≈ 1.4e-3 of the coordinate size, so difference
                    // quotients lose ~3 digits to rounding of the positions; the
                    // analytic Jacobian checks stay at 1e-9.
                    c.fd_tol = 1e-8;
                }
                check_map(&patch, &c);
                check_map(&sp, &Check::new(s).margin(0.05).samples(30));
                let nat_check = Check {
                    gradient: Some(Box::new(spheroid_gradient(f, a, b))),
                    fd_tol: c.fd_tol,
                    ..Check::new(s).samples(60).fd_step(c.fd_step)
                };
                check_map(&patch.natural(), &nat_check);
                check_area_ratio(&patch, &patch.natural(), 13, 1e-11);
            }
        }
    }
}

#[test]
fn tiny_eccentricity_agrees_with_the_sphere_map() {
    let f = Frame::canonical();
    let sph = wavelux_param::Sphere::new(f, 1.0, (0.0, 1.0), (-0.3, 1.1)).unwrap();
    let sp = Spheroid::new(f, 1.0, 1.0 + 1e-14, (0.0, 1.0), (-0.3, 1.1)).unwrap();
    for k in 0..=8 {
        let uv = DVec2::new(0.5, k as f64 / 8.0);
        assert!((sph.position(uv) - sp.position(uv)).length() < 1e-13);
    }
}

#[test]
fn spheroid_rejects_bad_eccentricity() {
    let f = Frame::canonical();
    for e in [1.0, -0.1, f64::NAN, 2.0] {
        let r = Spheroid::prolate(f, 1.0, e, (0.0, 1.0), (0.0, 1.0));
        assert!(r.is_err(), "{e}");
    }
    assert!(matches!(
        Spheroid::oblate(f, 1.0, 1.0, (0.0, 1.0), (0.0, 1.0)),
        Err(ParamError::Eccentricity(_))
    ));
}
