//! Form factors: catalog formulas vs contour integral vs Lambert vs quadrature;
//! reciprocity and closure in a cube and a polyhedral sphere.

use glam::DVec3;
use std::f64::consts::PI;
use wavelux_geometry::formfactor::*;
use wavelux_quadrature::GaussLegendre;

fn rect(o: DVec3, e1: DVec3, e2: DVec3) -> Vec<DVec3> {
    vec![o, o + e1, o + e1 + e2, o + e2]
}

/// Area integral of the point-to-polygon form factor over a parallelogram source (tensor GL).
fn quad_point_to_poly(src: (DVec3, DVec3, DVec3), dst: &[DVec3], n: usize) -> f64 {
    let gl = GaussLegendre::new(n).unwrap();
    let (x, w) = gl.unit();
    let (o, e1, e2) = src;
    let nrm = e1.cross(e2).normalize();
    let mut s = 0.0;
    for i in 0..n {
        for j in 0..n {
            let p = o + x[i] * e1 + x[j] * e2;
            s += w[i] * w[j] * point_to_polygon(p, nrm, dst).unwrap();
        }
    }
    s
}

#[test]
fn parallel_rectangles_three_ways() {
    for &(a, b, c) in &[
        (1.0, 1.0, 1.0),
        (2.0, 0.5, 0.7),
        (0.3, 3.0, 2.0),
        (1e-3, 2e-3, 1.5e-3),
        (1e3, 5e2, 7e2),
    ] {
        let cat = parallel_rectangles(a, b, c).unwrap();
        let lo = rect(
            DVec3::ZERO,
            DVec3::new(a, 0.0, 0.0),
            DVec3::new(0.0, b, 0.0),
        );
        // Upper rectangle faces down: reverse orientation.
        let hi = rect(
            DVec3::new(0.0, 0.0, c),
            DVec3::new(0.0, b, 0.0),
            DVec3::new(a, 0.0, 0.0),
        );
        let contour = polygon_to_polygon(&lo, &hi).unwrap();
        assert!(
            (contour - cat).abs() <= 1e-12 * cat.max(1e-3),
            "{a} {b} {c}: {contour} vs {cat}"
        );
        let q = quad_point_to_poly(
            (
                DVec3::ZERO,
                DVec3::new(a, 0.0, 0.0),
                DVec3::new(0.0, b, 0.0),
            ),
            &hi,
            24,
        );
        assert!((q - cat).abs() <= 1e-6 * cat.max(1e-3), "quad {q} vs {cat}");
    }
}

#[test]
fn perpendicular_rectangles_with_common_edge() {
    for &(l, w, h) in &[
        (1.0, 1.0, 1.0),
        (2.0, 0.5, 0.7),
        (0.3, 3.0, 2.0),
        (1e-2, 2e-2, 5e-3),
    ] {
        let cat = perpendicular_rectangles(l, w, h).unwrap();
        // Common edge along x from 0 to l; source in the z=0 plane (y in [0,w]), normal +z;
        // target in the y=0 plane (z in [0,h]), normal +y.
        let src = rect(
            DVec3::ZERO,
            DVec3::new(l, 0.0, 0.0),
            DVec3::new(0.0, w, 0.0),
        );
        let dst = rect(
            DVec3::ZERO,
            DVec3::new(0.0, 0.0, h),
            DVec3::new(l, 0.0, 0.0),
        );
        let contour = polygon_to_polygon(&src, &dst).unwrap();
        assert!(
            (contour - cat).abs() <= 1e-12,
            "{l} {w} {h}: {contour} vs {cat}"
        );
    }
}

#[test]
fn differential_element_to_rectangle() {
    for &(a, b, c) in &[(1.0, 1.0, 1.0), (2.0, 0.5, 0.7), (1e-4, 3e-4, 2e-4)] {
        let cat = point_to_parallel_rectangle_corner(a, b, c).unwrap();
        let poly = rect(
            DVec3::new(0.0, 0.0, c),
            DVec3::new(a, 0.0, 0.0),
            DVec3::new(0.0, b, 0.0),
        );
        let lam = point_to_polygon(DVec3::ZERO, DVec3::Z, &poly).unwrap();
        assert!((lam - cat).abs() <= 1e-14, "{lam} vs {cat}");
        // Cosine-kernel quadrature over the rectangle.
        let gl = GaussLegendre::new(40).unwrap();
        let q = gl.integrate(0.0, a, |x| {
            gl.integrate(0.0, b, |y| {
                let r2 = x * x + y * y + c * c;
                c * c / (PI * r2 * r2)
            })
        });
        assert!((q - cat).abs() <= 1e-10 * cat, "{q} vs {cat}");
    }
}

#[test]
fn point_to_polygon_straddling_horizon_matches_quadrature() {
    // Receiver at origin with normal +z; a vertical square crossing z = 0.
    let poly = rect(
        DVec3::new(-1.0, 2.0, -0.5),
        DVec3::new(2.0, 0.0, 0.0),
        DVec3::new(0.0, 0.0, 1.5),
    );
    let f = point_to_polygon(DVec3::ZERO, DVec3::Z, &poly).unwrap();
    // Quadrature over the visible part z in [0, 1].
    let gl = GaussLegendre::new(48).unwrap();
    let q = gl.integrate(-1.0, 1.0, |x| {
        gl.integrate(0.0, 1.0, |z| {
            let d = DVec3::new(x, 2.0, z);
            let r2 = d.length_squared();
            // cos at receiver = z/r, cos at square (normal ±y) = 2/r.
            (z * 2.0) / (PI * r2 * r2)
        })
    });
    assert!((f - q).abs() <= 1e-10, "{f} vs {q}");
    // In-plane receiver sees a coplanar polygon edge-on.
    let flat = rect(DVec3::new(1.0, 1.0, 0.0), DVec3::X, DVec3::Y);
    assert_eq!(point_to_polygon(DVec3::ZERO, DVec3::Z, &flat).unwrap(), 0.0);
}

#[test]
fn coaxial_disks_catalog_vs_point_to_disk_quadrature() {
    for &(r1, r2, h) in &[(1.0, 1.0, 1.0), (0.5, 2.0, 0.8), (2.0, 0.3, 1.7)] {
        let cat = coaxial_disks(r1, r2, h).unwrap();
        // ∫_disk1 F(dA → disk2) dA / A1 with polar GL; integrand depends on radius only.
        let gl = GaussLegendre::new(40).unwrap();
        let q = gl.integrate(0.0, r1, |a| {
            2.0 * PI * a * point_to_parallel_disk(r2, h, a).unwrap()
        }) / (PI * r1 * r1);
        assert!((q - cat).abs() <= 1e-12, "{q} vs {cat}");
        // Lambert on a fine regular polygon inscribed in disk 2 converges to the on-axis value.
        let n = 4096;
        let poly: Vec<DVec3> = (0..n)
            .map(|k| {
                let t = 2.0 * PI * k as f64 / n as f64;
                DVec3::new(r2 * t.cos(), r2 * t.sin(), h)
            })
            .collect();
        let lam = point_to_polygon(DVec3::ZERO, DVec3::Z, &poly).unwrap();
        let axis = point_to_parallel_disk(r2, h, 0.0).unwrap();
        assert!((lam - axis).abs() <= 1e-5, "{lam} vs {axis}");
    }
}

fn cube_faces(s: f64) -> Vec<Vec<DVec3>> {
    // Inward-facing faces of [0,s]³ (vertices counter-clockwise seen from inside).
    let v = |x: f64, y: f64, z: f64| DVec3::new(x, y, z) * s;
    vec![
        vec![v(0., 0., 0.), v(1., 0., 0.), v(1., 1., 0.), v(0., 1., 0.)], // z=0, normal +z
        vec![v(0., 0., 1.), v(0., 1., 1.), v(1., 1., 1.), v(1., 0., 1.)], // z=1, normal −z
        vec![v(0., 0., 0.), v(0., 0., 1.), v(1., 0., 1.), v(1., 0., 0.)], // y=0, normal +y
        vec![v(0., 1., 0.), v(1., 1., 0.), v(1., 1., 1.), v(0., 1., 1.)], // y=1, normal −y
        vec![v(0., 0., 0.), v(0., 1., 0.), v(0., 1., 1.), v(0., 0., 1.)], // x=0, normal +x
        vec![v(1., 0., 0.), v(1., 0., 1.), v(1., 1., 1.), v(1., 1., 0.)], // x=1, normal −x
    ]
}

#[test]
fn cube_closure_and_reciprocity() {
    for &s in &[1.0, 1e-3, 1e3] {
        let faces = cube_faces(s);
        for (i, fi) in faces.iter().enumerate() {
            let ni = newell(fi).normalize();
            let c = fi.iter().copied().sum::<DVec3>() / 4.0;
            assert!(
                ni.dot(DVec3::splat(0.5 * s) - c) > 0.0,
                "face {i} must face inwards"
            );
            let mut sum = 0.0;
            for (j, fj) in faces.iter().enumerate() {
                if i == j {
                    continue;
                }
                let fij = polygon_to_polygon(fi, fj).unwrap();
                let fji = polygon_to_polygon(fj, fi).unwrap();
                let (ai, aj) = (polygon_area(fi), polygon_area(fj));
                assert!(
                    (ai * fij - aj * fji).abs() <= 1e-12 * ai,
                    "reciprocity {i} {j}"
                );
                sum += fij;
            }
            assert!(
                (sum - 1.0).abs() <= 1e-10,
                "closure face {i} scale {s}: {sum}"
            );
        }
    }
}

/// Icosphere (subdivided once: 80 triangles), faces oriented inwards.
fn icosphere_inward() -> Vec<Vec<DVec3>> {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let mut v: Vec<DVec3> = [
        (-1., t, 0.),
        (1., t, 0.),
        (-1., -t, 0.),
        (1., -t, 0.),
        (0., -1., t),
        (0., 1., t),
        (0., -1., -t),
        (0., 1., -t),
        (t, 0., -1.),
        (t, 0., 1.),
        (-t, 0., -1.),
        (-t, 0., 1.),
    ]
    .iter()
    .map(|&(x, y, z)| DVec3::new(x, y, z).normalize())
    .collect();
    let mut f: Vec<[usize; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    let mut mid = std::collections::HashMap::new();
    let mut nf = Vec::new();
    for tri in &f {
        let mut m = [0usize; 3];
        for k in 0..3 {
            let (a, b) = (tri[k].min(tri[(k + 1) % 3]), tri[k].max(tri[(k + 1) % 3]));
            m[k] = *mid.entry((a, b)).or_insert_with(|| {
                v.push((v[a] + v[b]).normalize());
                v.len() - 1
            });
        }
        nf.push([tri[0], m[0], m[2]]);
        nf.push([tri[1], m[1], m[0]]);
        nf.push([tri[2], m[2], m[1]]);
        nf.push([m[0], m[1], m[2]]);
    }
    f = nf;
    // Outward CCW → reverse for inward.
    f.iter().map(|t| vec![v[t[0]], v[t[2]], v[t[1]]]).collect()
}

#[test]
fn polyhedral_sphere_closure_and_reciprocity() {
    let faces = icosphere_inward();
    assert_eq!(faces.len(), 80);
    // A subset of sources keeps the test fast; each row sums over all 80 faces.
    for i in (0..80).step_by(9) {
        let fi = &faces[i];
        assert!(newell(fi).dot(-fi[0]) > 0.0);
        let mut sum = 0.0;
        for (j, fj) in faces.iter().enumerate() {
            if j == i {
                continue;
            }
            let fij = polygon_to_polygon(fi, fj).unwrap();
            if j % 7 == 0 {
                let fji = polygon_to_polygon(fj, fi).unwrap();
                assert!(
                    (polygon_area(fi) * fij - polygon_area(fj) * fji).abs() <= 1e-13,
                    "reciprocity {i} {j}"
                );
            }
            sum += fij;
        }
        assert!((sum - 1.0).abs() <= 1e-10, "closure {i}: {}", sum - 1.0);
    }
}

#[test]
fn contour_matches_lambert_quadrature_for_skew_triangles() {
    // Two non-coplanar triangles facing each other, well separated: the contour integral
    // equals the area integral of Lambert's formula.
    let src = [
        DVec3::new(0.0, 0.0, 0.0),
        DVec3::new(1.0, 0.1, 0.0),
        DVec3::new(0.2, 0.9, 0.1),
    ];
    let dst = vec![
        DVec3::new(0.3, 0.2, 1.5),
        DVec3::new(0.1, 1.1, 1.2),
        DVec3::new(1.2, 0.4, 1.3),
    ];
    let n = (src[1] - src[0]).cross(src[2] - src[0]);
    let area = 0.5 * n.length();
    let nrm = n.normalize();
    let gl = GaussLegendre::new(30).unwrap();
    let (x, w) = gl.unit();
    let mut q = 0.0;
    for i in 0..30 {
        for j in 0..30 {
            // Collapsed square → triangle (Duffy).
            let (u, v) = (x[i], x[j] * x[i]);
            let p = src[0] + u * (src[1] - src[0]) + v * (src[2] - src[1]);
            q += w[i] * w[j] * x[i] * 2.0 * point_to_polygon(p, nrm, &dst).unwrap();
        }
    }
    // The Duffy Jacobian is 2·area·u; dividing by the area leaves 2u (applied above).
    let c = polygon_to_polygon(&src, &dst).unwrap();
    assert!(area > 0.0);
    assert!((c - q).abs() <= 1e-9 * c, "{c} vs {q}");
}

/// Nested adaptive Gauss–Kronrod (wavelux-quadrature) of Lambert's formula over a
/// parallelogram source: an independent reference for the contour integral.
fn adaptive_point_to_poly(src: (DVec3, DVec3, DVec3), dst: &[DVec3], tol: f64) -> f64 {
    use wavelux_quadrature::{Tolerance, integrate_1d};
    let (o, e1, e2) = src;
    let nrm = e1.cross(e2).normalize();
    let t = Tolerance::new(tol, tol).unwrap();
    integrate_1d(
        |y| {
            integrate_1d(
                |x| point_to_polygon(o + x * e1 + y * e2, nrm, dst).unwrap(),
                0.0,
                1.0,
                t,
                200_000,
            )
            .unwrap()
            .value
        },
        0.0,
        1.0,
        t,
        200_000,
    )
    .unwrap()
    .value
}

#[test]
fn catalog_contour_and_adaptive_quadrature_agree_with_shared_edge() {
    // Perpendicular rectangles sharing an edge: the integrand of the area integral is
    // non-smooth along the common edge, which the adaptive rule resolves.
    for &(l, w, h) in &[(1.0, 1.0, 1.0), (2.0, 0.5, 0.7)] {
        let cat = perpendicular_rectangles(l, w, h).unwrap();
        let src = (
            DVec3::ZERO,
            DVec3::new(l, 0.0, 0.0),
            DVec3::new(0.0, w, 0.0),
        );
        let dst = rect(
            DVec3::ZERO,
            DVec3::new(0.0, 0.0, h),
            DVec3::new(l, 0.0, 0.0),
        );
        let adaptive = adaptive_point_to_poly(src, &dst, 1e-11);
        let contour = polygon_to_polygon(&rect(src.0, src.1, src.2), &dst).unwrap();
        assert!(
            (adaptive - cat).abs() <= 1e-8,
            "adaptive {adaptive} vs catalog {cat}"
        );
        assert!(
            (adaptive - contour).abs() <= 1e-8,
            "adaptive {adaptive} vs contour {contour}"
        );
    }
    // Parallel opposed rectangles.
    let cat = parallel_rectangles(1.0, 2.0, 0.5).unwrap();
    let hi = rect(
        DVec3::new(0.0, 0.0, 0.5),
        DVec3::new(0.0, 2.0, 0.0),
        DVec3::new(1.0, 0.0, 0.0),
    );
    let adaptive = adaptive_point_to_poly(
        (DVec3::ZERO, DVec3::X, DVec3::new(0.0, 2.0, 0.0)),
        &hi,
        1e-12,
    );
    assert!((adaptive - cat).abs() <= 1e-9, "{adaptive} vs {cat}");
}

#[test]
fn coplanar_pairs_and_invalid_input() {
    // Two coplanar squares sharing an edge exchange nothing.
    let a = rect(DVec3::ZERO, DVec3::X, DVec3::Y);
    let b = rect(DVec3::X, DVec3::X, DVec3::Y);
    let f = polygon_to_polygon(&a, &b).unwrap();
    assert!(f.abs() <= 1e-14, "coplanar: {f}");
    // Bad input is an error, not a panic.
    assert!(polygon_to_polygon(&a[..2], &b).is_err());
    assert!(point_to_polygon(DVec3::ZERO, DVec3::ZERO, &b).is_err());
    assert!(parallel_rectangles(-1.0, 1.0, 1.0).is_err());
    assert!(coaxial_disks(1.0, f64::NAN, 1.0).is_err());
}

#[test]
fn straddling_and_back_to_back_polygons() {
    // Floor [−1,1]×[0,1] (normal +z) and a wall in x = 0 spanning z ∈ [−1,1] (normal +x):
    // only the floor's x > 0 half and the wall's z > 0 half exchange, as perpendicular
    // rectangles with a common edge of length 1, width 1, height 1.
    let floor = rect(
        DVec3::new(-1.0, 0.0, 0.0),
        DVec3::new(2.0, 0.0, 0.0),
        DVec3::Y,
    );
    let wall = rect(
        DVec3::new(0.0, 0.0, -1.0),
        DVec3::Y,
        DVec3::new(0.0, 0.0, 2.0),
    );
    let f = polygon_to_polygon(&floor, &wall).unwrap();
    let want = 0.5 * perpendicular_rectangles(1.0, 1.0, 1.0).unwrap();
    assert!((f - want).abs() <= 1e-13, "{f} vs {want}");
    let back = polygon_to_polygon(&wall, &floor).unwrap();
    assert!(
        (2.0 * f - 2.0 * back).abs() <= 1e-13,
        "reciprocity (equal areas)"
    );
    // Back to back: nothing.
    let up = rect(DVec3::ZERO, DVec3::X, DVec3::Y);
    let down = rect(DVec3::new(0.0, 0.0, -1.0), DVec3::X, DVec3::Y);
    assert_eq!(polygon_to_polygon(&up, &down).unwrap(), 0.0);
}

/// A random unit vector from the generator `r` (uniform in `[0, 1)`).
fn random_unit(r: &mut impl FnMut() -> f64) -> DVec3 {
    DVec3::new(2.0 * r() - 1.0, 2.0 * r() - 1.0, 2.0 * r() - 1.0).normalize()
}

#[test]
fn contour_of_skew_pairs_at_every_distance_matches_lambert_quadrature() {
    // The outer panels of skew edge pairs take fewer Gauss points the farther they are
    // from the other edge (down to 4, one panel): the contour must stay as accurate
    // as with 20 points everywhere. Reference: a 32×32 Gauss rule of Lambert's exact
    // point-to-polygon form factor over the source, which converges geometrically when
    // the destination stays clear of the source's plane (at least 0.4 above it, for a
    // source of size 1: error below 1e-18).
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut rnd = || {
        state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        ((state >> 11) as f64) / ((1u64 << 53) as f64)
    };
    let src = (
        DVec3::ZERO,
        DVec3::new(1.0, 0.0, 0.0),
        DVec3::new(0.3, 0.8, 0.0),
    );
    let src_poly = rect(src.0, src.1, src.2);
    let centre = src.0 + 0.5 * (src.1 + src.2);
    let (mut worst, mut recip): (f64, f64) = (0.0, 0.0);
    let mut per_d = [0.0f64; 5];
    let mut cases = 0;
    for k in 0..150 {
        // Destination: a rotated parallelogram (or triangle) at distance `d` from the
        // source's centre, facing it.
        let d = [1.5, 2.0, 3.5, 6.0, 12.0][k % 5];
        let mut dir = random_unit(&mut rnd);
        if dir.z < 0.3 {
            dir = (dir + DVec3::Z).normalize();
        }
        let c = centre + d * dir;
        let a = random_unit(&mut rnd);
        let b = (random_unit(&mut rnd) - 0.3 * a).normalize();
        let (e1, e2) = (0.9 * a, 0.6 * b);
        let mut dst = if k % 3 == 0 {
            vec![c, c + e1, c + e2]
        } else {
            rect(c - 0.5 * (e1 + e2), e1, e2)
        };
        if newell(&dst).dot(centre - c) < 0.0 {
            dst.reverse();
        }
        // Each wholly in front of the other (Lambert's formula does not know which
        // side of the destination a point sees), the destination clear of the
        // source's plane.
        let nd = newell(&dst).normalize();
        if dst.iter().any(|p| p.z < 0.4) || src_poly.iter().any(|p| nd.dot(*p - c) < 0.1) {
            continue;
        }
        // `quad_point_to_poly` is the mean over the source: times its area.
        let reference = quad_point_to_poly(src, &dst, 32) * src.1.cross(src.2).length();
        let contour = area_form_factor(&src_poly, &dst).unwrap();
        let back = area_form_factor(&dst, &src_poly).unwrap();
        let err = (contour - reference).abs() / reference;
        // Rounding: both the contour's edge pairs and Lambert's edge terms are larger
        // than their sum by a factor growing like d², and so is the relative rounding
        // error of either (measured up to 3.4e-11 at d = 12, as with 20 points on every
        // panel).
        assert!(
            reference > 0.0 && err <= 1e-12 + 5e-13 * d * d,
            "case {k}, d {d}: {contour} vs {reference}"
        );
        per_d[k % 5] = per_d[k % 5].max(err);
        // Reciprocity of the contour form (A_i F_ij = A_j F_ji).
        recip = recip.max((contour - back).abs() / contour);
        assert!(
            (contour - back).abs() <= 2e-11 * contour,
            "case {k}: {contour} vs {back}"
        );
        worst = worst.max(err);
        cases += 1;
    }
    println!(
        "{cases} cases, worst relative deviation {worst:.2e} (per distance 1.5/2/3.5/6/12: {per_d:?}), reciprocity {recip:.2e}"
    );
    assert!(cases >= 60, "{cases}");
}

/// The closed-form edge pair `∫∫ ln|p − q| dp·dq`: a segment with itself is
/// `L² (ln L − 3/2)` (the integral of `ln|s − t|` over a square of side `L`); reversing
/// one segment flips the sign; skew segments apart agree with a 40×40 Gauss rule and
/// the pair is symmetric.
#[test]
fn segment_pair_log_integral_matches_closed_forms_and_quadrature() {
    let (a, b) = (DVec3::new(0.2, -0.1, 0.3), DVec3::new(1.4, 0.5, -0.2));
    let l = (b - a).length();
    let own = segment_pair_log_integral(a, b, a, b).unwrap();
    let want = l * l * (l.ln() - 1.5);
    assert!(
        (own - want).abs() < 1e-12 * want.abs().max(1.0),
        "{own} vs {want}"
    );
    let rev = segment_pair_log_integral(a, b, b, a).unwrap();
    assert!((rev + want).abs() < 1e-12 * want.abs().max(1.0), "{rev}");
    let (c, d) = (DVec3::new(0.0, 1.0, 1.0), DVec3::new(0.7, 2.1, 0.4));
    let gl = GaussLegendre::new(40).unwrap();
    let (x, w) = gl.unit();
    let mut quad = 0.0;
    for (u, wu) in x.iter().zip(&w) {
        for (v, wv) in x.iter().zip(&w) {
            let (p, q) = (a + (b - a) * *u, c + (d - c) * *v);
            quad += wu * wv * (p - q).length().ln();
        }
    }
    quad *= (b - a).dot(d - c);
    let closed = segment_pair_log_integral(a, b, c, d).unwrap();
    assert!(
        (closed - quad).abs() < 1e-10 * quad.abs(),
        "{closed} vs {quad}"
    );
    let swapped = segment_pair_log_integral(c, d, a, b).unwrap();
    assert!(
        (closed - swapped).abs() < 1e-12 * quad.abs(),
        "{closed} vs {swapped}"
    );
    assert!(segment_pair_log_integral(a, DVec3::splat(f64::NAN), c, d).is_err());
}
