//! Ray intersection of every primitive vs independent brute force on random rays.

use glam::{DVec2, DVec3};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;
use std::f64::consts::PI;
use std::sync::Arc;
use wavelux_geometry::*;
use wavelux_param as param;

fn rng(seed: u64) -> Pcg64 {
    Pcg64::seed_from_u64(seed)
}

fn rand_vec(r: &mut Pcg64, lo: DVec3, hi: DVec3) -> DVec3 {
    DVec3::new(
        r.random_range(lo.x..hi.x),
        r.random_range(lo.y..hi.y),
        r.random_range(lo.z..hi.z),
    )
}

/// Random rays aimed at random points of (an enlarged) box.
fn rays_at(b: Aabb, n: usize, seed: u64) -> Vec<Ray> {
    let mut r = rng(seed);
    let c = b.center();
    let d = b.diagonal();
    (0..n)
        .map(|_| {
            let o = rand_vec(&mut r, c - 1.5 * d, c + 1.5 * d);
            let target = rand_vec(&mut r, b.min - 0.1 * d, b.max + 0.1 * d);
            Ray::new(o, target - o).unwrap()
        })
        .collect()
}

fn bary_brute(v: &[DVec3; 3], ray: &Ray) -> Option<(f64, [f64; 3])> {
    let n = (v[1] - v[0]).cross(v[2] - v[0]);
    let den = ray.dir.dot(n);
    if den == 0.0 {
        return None;
    }
    let t = (v[0] - ray.origin).dot(n) / den;
    let p = ray.at(t);
    let area = |a: DVec3, b: DVec3, c: DVec3| (b - a).cross(c - a).dot(n) / n.length_squared();
    Some((
        t,
        [
            area(p, v[1], v[2]),
            area(v[0], p, v[2]),
            area(v[0], v[1], p),
        ],
    ))
}

#[test]
fn triangle_vs_area_coordinates() {
    let mut r = rng(1);
    for k in 0..200 {
        let s = 10f64.powi(k % 7 - 3);
        let v = [0; 3].map(|_| rand_vec(&mut r, DVec3::splat(-s), DVec3::splat(s)));
        let Ok(tri) = Triangle::new(v[0], v[1], v[2]) else {
            continue;
        };
        for ray in rays_at(tri.aabb(), 50, k as u64) {
            let got = tri.intersect(&ray, 0.0, f64::INFINITY);
            let Some((t, b)) = bary_brute(&tri.v, &ray) else {
                continue;
            };
            let margin = b.iter().copied().fold(f64::INFINITY, f64::min);
            if margin.abs() < 1e-9 {
                continue;
            }
            let want = margin > 0.0 && t >= 0.0;
            assert_eq!(got.is_some(), want, "triangle {k}");
            if let Some(h) = got {
                assert!((h.t - t).abs() <= 1e-9 * (t.abs() + s));
                assert!((tri.eval(h.uv) - h.point).length() <= 1e-9 * s);
                assert_eq!(h.front, ray.dir.dot(tri.normal()) < 0.0);
            }
        }
    }
}

#[test]
fn parallelogram_and_polygon_vs_brute() {
    let mut r = rng(2);
    for k in 0..60 {
        let o = rand_vec(&mut r, DVec3::splat(-1.0), DVec3::splat(1.0));
        let e1 = rand_vec(&mut r, DVec3::splat(-1.0), DVec3::splat(1.0));
        let e2 = rand_vec(&mut r, DVec3::splat(-1.0), DVec3::splat(1.0));
        let Ok(pg) = Parallelogram::new(o, e1, e2) else {
            continue;
        };
        // Brute: two triangles.
        let [a, b, c, d] = pg.corners();
        let t1 = Triangle::new(a, b, c).unwrap();
        let t2 = Triangle::new(a, c, d).unwrap();
        // Same region as a complex polygon with a triangular hole.
        let n = pg.normal();
        let m = o + 0.5 * e1 + 0.5 * e2;
        let hole = vec![m, m + 0.2 * e2, m + 0.2 * e1];
        let poly =
            ComplexPolygon::from_world_loops(&[a, b, c, d], std::slice::from_ref(&hole)).unwrap();
        assert!((poly.area() - 0.98 * pg.area()).abs() <= 1e-12 * pg.area());
        assert!(poly.normal().dot(n) > 0.999_999);
        let th = Triangle::new(hole[0], hole[1], hole[2]).unwrap();
        for ray in rays_at(pg.aabb(), 100, 100 + k) {
            let brute = t1
                .intersect(&ray, 0.0, f64::INFINITY)
                .or_else(|| t2.intersect(&ray, 0.0, f64::INFINITY));
            let got = pg.intersect(&ray, 0.0, f64::INFINITY);
            if let (Some(bh), Some(gh)) = (brute, got) {
                assert!((bh.t - gh.t).abs() <= 1e-9 * (1.0 + bh.t));
                assert!((pg.eval(gh.uv) - gh.point).length() <= 1e-9);
            }
            let in_hole = th.intersect(&ray, 0.0, f64::INFINITY).is_some();
            let gp = poly.intersect(&ray, 0.0, f64::INFINITY);
            // Skip rays within 1e-7 of an edge (either answer is legitimate there).
            let near_edge = |h: &Option<Hit>| {
                h.is_some_and(|h| {
                    let q = h.uv;
                    q.x.min(q.y).min(1.0 - q.x).min(1.0 - q.y) < 1e-7
                })
            };
            if near_edge(&got) || near_edge(&brute) {
                continue;
            }
            assert_eq!(brute.is_some(), got.is_some(), "parallelogram {k}");
            if let Some(h) = gp {
                assert!((poly.eval(h.uv) - h.point).length() <= 1e-9);
                assert!(
                    (pg.intersect(&ray, 0.0, f64::INFINITY).unwrap().t - h.t).abs()
                        <= 1e-9 * (1.0 + h.t)
                );
            }
            if let Some(gh) = got
                && !in_hole
            {
                let q = poly.frame.to_plane(gh.point);
                // Winding by brute force decides the polygon answer.
                let w = poly.region.winding_brute(q);
                assert_eq!(gp.is_some(), w != 0, "polygon {k}");
            }
        }
    }
}

/// Trim region: square [0.02, 0.98]² minus a disk, with one arc-bulged side.
fn trim_region() -> TrimRegion {
    let a = DVec2::new(0.02, 0.02);
    let b = DVec2::new(0.98, 0.02);
    let c = DVec2::new(0.98, 0.98);
    let d = DVec2::new(0.02, 0.98);
    // Side d→a replaced by an arc bulging inwards (clockwise about a centre left of it).
    let half = 0.48;
    let sweep = 1.0f64;
    let rad = half / (0.5 * sweep).sin();
    let centre = DVec2::new(0.02 - rad * (0.5 * sweep).cos(), 0.5);
    let start = (d - centre).to_angle();
    let outer = TrimLoop::new(vec![
        Edge2::segment(a, b).unwrap(),
        Edge2::segment(b, c).unwrap(),
        Edge2::segment(c, d).unwrap(),
        Edge2::arc(centre, rad, start, -sweep).unwrap(),
    ])
    .unwrap();
    let hole = TrimLoop::circle(DVec2::new(0.6, 0.45), 0.2)
        .unwrap()
        .reversed();
    TrimRegion::new(vec![outer, hole]).unwrap()
}

fn implicit_value(q: &dyn param::Parametrization, p: DVec3) -> f64 {
    match q.shape() {
        param::SurfaceShape::Sphere(x) => {
            let l = x.frame().point_to_local(p);
            l.length_squared() - x.radius() * x.radius()
        }
        param::SurfaceShape::Cylinder(x) => {
            let l = x.frame().point_to_local(p);
            l.x * l.x + l.y * l.y - x.radius() * x.radius()
        }
        param::SurfaceShape::Cone(x) => {
            let l = x.frame().point_to_local(p);
            let k = x.radius() / x.height();
            l.x.hypot(l.y) - k * l.z
        }
        param::SurfaceShape::Spheroid(x) => {
            let l = x.frame().point_to_local(p);
            let (a, c) = (x.equatorial_semi_axis(), x.polar_semi_axis());
            (l.x * l.x + l.y * l.y) / (a * a) + l.z * l.z / (c * c) - 1.0
        }
        param::SurfaceShape::Torus(x) => {
            let l = x.frame().point_to_local(p);
            let rho = l.x.hypot(l.y) - x.major_radius();
            rho * rho + l.z * l.z - x.minor_radius() * x.minor_radius()
        }
        _ => unreachable!(),
    }
}

/// Brute force: march the implicit function in 20 000 steps over the box interval,
/// bisect sign changes, keep the first root whose inverse-mapped `uv` the trim keeps
/// (trim decided by brute-force winding).
fn march(patch: &TrimmedPatch, ray: &Ray) -> Option<(f64, DVec2)> {
    let b = patch.aabb();
    let (t0, t1) =
        b.expanded(1e-6 * b.diagonal().length())
            .intersect_ray(ray, 0.0, f64::INFINITY)?;
    let n = 20_000;
    let f = |t: f64| implicit_value(patch.surface.as_ref(), ray.at(t));
    let q = &patch.surface;
    let mut ta = t0;
    let mut fa = f(ta);
    for i in 1..=n {
        let tb = t0 + (t1 - t0) * i as f64 / n as f64;
        let fb = f(tb);
        if fa.signum() != fb.signum() {
            let (mut lo, mut hi, flo) = (ta, tb, fa);
            for _ in 0..200 {
                let m = 0.5 * (lo + hi);
                if f(m).signum() == flo.signum() {
                    lo = m
                } else {
                    hi = m
                }
            }
            let t = 0.5 * (lo + hi);
            if let Some(uv) = q.inverse(ray.at(t))
                && uv.x >= 0.0
                && uv.x <= 1.0
                && uv.y >= 0.0
                && uv.y <= 1.0
                && patch
                    .trim
                    .as_ref()
                    .is_none_or(|tr| tr.winding_brute(uv) != 0)
            {
                return Some((t, uv));
            }
        }
        ta = tb;
        fa = fb;
    }
    None
}

fn frame(o: DVec3, axis: DVec3) -> param::Frame {
    param::Frame::from_axis(o, axis).unwrap()
}

fn param_surfaces() -> Vec<(&'static str, Arc<dyn param::Parametrization>)> {
    let f = frame(DVec3::new(0.3, -0.2, 0.1), DVec3::new(0.2, 0.3, 1.0));
    vec![
        ("sphere", Arc::new(param::Sphere::full(f, 1.3).unwrap())),
        (
            "sphere patch",
            Arc::new(param::Sphere::new(f, 0.8, (-1.0, 2.0), (-0.5, 1.2)).unwrap()),
        ),
        (
            "cylinder",
            Arc::new(param::Cylinder::new(f, 0.7, (0.0, 5.0), (-0.5, 1.0)).unwrap()),
        ),
        (
            "cone",
            Arc::new(param::Cone::new(f, 0.9, 1.4, (-PI, PI), (0.2, 1.0)).unwrap()),
        ),
        (
            "prolate",
            Arc::new(param::Spheroid::new(f, 0.6, 1.5, (-PI, PI), (-1.5, 1.5)).unwrap()),
        ),
        (
            "oblate",
            Arc::new(param::Spheroid::new(f, 1.4, 0.4, (0.0, 4.0), (-1.0, 1.3)).unwrap()),
        ),
        (
            "torus",
            Arc::new(param::Torus::new(f, 1.0, 0.35, (-PI, PI), (-PI, PI)).unwrap()),
        ),
        (
            "torus patch",
            Arc::new(param::Torus::new(f, 2.0, 0.9, (0.0, 3.0), (0.5, 5.5)).unwrap()),
        ),
    ]
}

#[test]
fn trimmed_patches_vs_ray_marching() {
    for (name, surf) in param_surfaces() {
        for trim in [None, Some(trim_region())] {
            let patch = TrimmedPatch::new(surf.clone(), trim.clone()).unwrap();
            let size = patch.aabb().diagonal().length();
            let mut mismatches = 0;
            let rays = rays_at(patch.aabb(), 300, 7);
            for ray in &rays {
                let got = patch.intersect(ray, 0.0, f64::INFINITY);
                let brute = march(&patch, ray);
                match (got, brute) {
                    (Some(h), Some((t, _))) => {
                        assert!((h.t - t).abs() <= 1e-8 * size, "{name}: t {} vs {t}", h.t);
                        assert!(
                            (surf.position(h.uv) - h.point).length() <= 1e-8 * size,
                            "{name}: uv"
                        );
                        assert!(h.normal.dot(surf.normal(h.uv)) > 0.999_999);
                    }
                    (None, None) => {}
                    _ => mismatches += 1,
                }
            }
            // Grazing rays and roots within the marching step of the trim boundary may
            // legitimately differ; they are rare.
            assert!(
                mismatches <= 3,
                "{name} trimmed={}: {mismatches} mismatches",
                trim.is_some()
            );
        }
    }
}

#[test]
fn newton_fallback_agrees_with_implicit_roots() {
    for (name, surf) in param_surfaces() {
        let patch = TrimmedPatch::new(surf.clone(), Some(trim_region())).unwrap();
        let size = patch.aabb().diagonal().length();
        let mut mismatches = 0;
        for ray in rays_at(patch.aabb(), 100, 5) {
            let a = patch.intersect(&ray, 0.0, f64::INFINITY);
            let b = patch.intersect_newton(&ray, 0.0, f64::INFINITY);
            match (a, b) {
                (Some(a), Some(b)) => assert!(
                    (a.t - b.t).abs() <= 1e-9 * size,
                    "{name}: {} vs {}",
                    a.t,
                    b.t
                ),
                (None, None) => {}
                _ => mismatches += 1,
            }
        }
        assert!(mismatches <= 2, "{name}: {mismatches}");
    }
}

#[test]
fn torus_quartic_is_accurate_far_from_origin_and_at_small_scale() {
    for &(scale, off) in &[(1e-3, 0.0), (1.0, 1e3), (1e3, 0.0)] {
        let f = frame(DVec3::splat(off), DVec3::new(1.0, -0.5, 0.3));
        let tor = Arc::new(
            param::Torus::new(f, 1.0 * scale, 0.25 * scale, (-PI, PI), (-PI, PI)).unwrap(),
        );
        let patch = TrimmedPatch::new(tor.clone(), None).unwrap();
        let mut hits = 0;
        for ray in rays_at(patch.aabb(), 400, 11) {
            if let Some(h) = patch.intersect(&ray, 0.0, f64::INFINITY) {
                hits += 1;
                let l = f.point_to_local(h.point);
                let rho = l.x.hypot(l.y) - scale;
                let dist = (rho * rho + l.z * l.z).sqrt() - 0.25 * scale;
                assert!(dist.abs() <= 1e-10 * (scale + off), "residual {dist}");
            }
        }
        assert!(hits > 50);
    }
}

fn bezier_patch(seed: u64) -> BezierPatch {
    let mut r = rng(seed);
    let mut p = [[DVec3::ZERO; 4]; 4];
    for i in 0..4 {
        for j in 0..4 {
            p[i][j] = DVec3::new(i as f64, j as f64, 0.0)
                + rand_vec(&mut r, DVec3::splat(-0.6), DVec3::splat(0.6))
                + DVec3::new(0.0, 0.0, 1.5 * ((i as f64 - 1.5) * (j as f64 - 1.5)).sin());
        }
    }
    BezierPatch::new(p).unwrap()
}

#[test]
fn bezier_vs_fine_tessellation() {
    for seed in 0..4 {
        let bz = bezier_patch(seed);
        let n = 96;
        let mut tris = Vec::new();
        for i in 0..n {
            for j in 0..n {
                let q = |a: usize, b: usize| {
                    bz.eval(DVec2::new(a as f64 / n as f64, b as f64 / n as f64))
                };
                let (a, b, c, d) = (q(i, j), q(i + 1, j), q(i + 1, j + 1), q(i, j + 1));
                if let Ok(t) = Triangle::new(a, b, c) {
                    tris.push(t);
                }
                if let Ok(t) = Triangle::new(a, c, d) {
                    tris.push(t);
                }
            }
        }
        let size = bz.aabb().diagonal().length();
        let mut mismatch = 0;
        let rays = rays_at(bz.aabb(), 200, seed);
        for ray in &rays {
            let got = bz.intersect(ray, 0.0, f64::INFINITY);
            let tess = tris
                .iter()
                .filter_map(|t| t.intersect(ray, 0.0, f64::INFINITY))
                .map(|h| h.t)
                .fold(f64::INFINITY, f64::min);
            if let Some(h) = got {
                assert!(
                    (bz.eval(h.uv) - h.point).length() <= 1e-9 * size,
                    "on surface"
                );
            }
            match got {
                Some(h) if tess.is_finite() => assert!(
                    (h.t - tess).abs() <= 2e-3 * size,
                    "seed {seed}: {} vs {tess}",
                    h.t
                ),
                None if !tess.is_finite() => {}
                _ => mismatch += 1,
            }
        }
        assert!(mismatch <= 4, "seed {seed}: {mismatch} hit/miss mismatches");
    }
}

#[test]
fn trimmed_patch_area_natural_and_equal_area() {
    // Natural torus map: θ = −π + 2π u, φ = −π + 2π v. Trim to a rectangle with a
    // circular hole; the area is ∫ J over the trim, checked against the closed form of
    // the rectangle minus a fine polar quadrature of the hole.
    let f = frame(DVec3::new(0.2, 0.1, -0.3), DVec3::new(0.1, 0.2, 1.0));
    let (big, small) = (1.5, 0.4);
    let tor = param::Torus::new(f, big, small, (-PI, PI), (-PI, PI)).unwrap();
    let nat: Arc<dyn param::Parametrization> = Arc::new(tor.natural());
    let (u0, u1, v0, v1) = (0.1, 0.7, 0.2, 0.9);
    let trim = TrimRegion::new(vec![
        TrimLoop::rect(DVec2::new(u0, v0), DVec2::new(u1, v1)).unwrap(),
        TrimLoop::circle(DVec2::new(0.4, 0.5), 0.1)
            .unwrap()
            .reversed(),
    ])
    .unwrap();
    let patch = TrimmedPatch::new(nat.clone(), Some(trim)).unwrap();
    let phi = |v: f64| -PI + 2.0 * PI * v;
    let rect_area = small
        * 2.0
        * PI
        * (u1 - u0)
        * (big * (phi(v1) - phi(v0)) + small * (phi(v1).sin() - phi(v0).sin()));
    let gl = wavelux_quadrature::GaussLegendre::new(40).unwrap();
    let hole = gl.integrate(0.0, 0.1, |rr| {
        gl.integrate(0.0, 2.0 * PI, |a| {
            rr * nat.jacobian(DVec2::new(0.4 + rr * a.cos(), 0.5 + rr * a.sin()))
        })
    });
    assert!(
        (patch.area() - (rect_area - hole)).abs() <= 1e-10 * rect_area,
        "{} vs {}",
        patch.area(),
        rect_area - hole
    );
    // Equal-area map: area = total × trim area.
    let ea: Arc<dyn param::Parametrization> = Arc::new(tor.equal_area());
    let p2 = TrimmedPatch::new(ea.clone(), patch.trim.clone()).unwrap();
    let t = patch.trim.as_ref().unwrap();
    assert!((p2.area() - ea.area() * t.area()).abs() <= 1e-12 * ea.area());
    assert!((t.integrate(16, |uv| ea.jacobian(uv)) - p2.area()).abs() <= 1e-10 * ea.area());
}

#[test]
fn primitive_area_and_normal() {
    // A bilinear-equivalent (flat) Bézier patch of a parallelogram: area and normal exact.
    let (o, e1, e2) = (
        DVec3::new(0.1, 0.2, 0.3),
        DVec3::new(2.0, 0.1, 0.0),
        DVec3::new(0.3, 1.5, 0.2),
    );
    let mut p = [[DVec3::ZERO; 4]; 4];
    for i in 0..4 {
        for j in 0..4 {
            p[i][j] = o + (i as f64 / 3.0) * e1 + (j as f64 / 3.0) * e2;
        }
    }
    let bz: Primitive = BezierPatch::new(p).unwrap().into();
    let pg: Primitive = Parallelogram::new(o, e1, e2).unwrap().into();
    assert!((bz.area() - pg.area()).abs() <= 1e-12 * pg.area());
    let uv = DVec2::new(0.3, 0.7);
    assert!((bz.normal(uv) - pg.normal(uv)).length() <= 1e-12);
    assert!((bz.eval(uv) - pg.eval(uv)).length() <= 1e-12);
    // Full sphere: area 4πr², outward normal.
    let f = frame(DVec3::new(1.0, 2.0, 3.0), DVec3::Z);
    let sph: Primitive = TrimmedPatch::new(Arc::new(param::Sphere::full(f, 0.7).unwrap()), None)
        .unwrap()
        .into();
    assert!((sph.area() - 4.0 * PI * 0.49).abs() <= 1e-12);
    let q = sph.eval(uv);
    assert!((sph.normal(uv) - (q - DVec3::new(1.0, 2.0, 3.0)) / 0.7).length() <= 1e-12);
}

type Surf = Arc<dyn param::Parametrization>;

/// Numerically mapped surfaces, each with the same surface under its natural map
/// (cheap to evaluate; used to tessellate).
fn numeric_surfaces() -> Vec<(&'static str, Surf, Surf)> {
    let f = frame(DVec3::new(-0.2, 0.4, 0.1), DVec3::new(0.1, -0.3, 1.0));
    let vase: Arc<dyn param::Curve> = Arc::new(
        param::BezierCurve::new(vec![
            DVec3::new(0.5, 0.0, 0.0),
            DVec3::new(1.4, 0.0, 0.5),
            DVec3::new(0.2, 0.0, 1.0),
            DVec3::new(0.7, 0.0, 1.6),
        ])
        .unwrap(),
    );
    let base: Arc<dyn param::Curve> = Arc::new(
        param::BezierCurve::new(vec![
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(1.0, 1.2, 0.0),
            DVec3::new(2.0, -0.8, 0.1),
            DVec3::new(3.0, 0.3, 0.0),
        ])
        .unwrap(),
    );
    let helix: Arc<dyn param::Curve> = Arc::new(param::Helix::new(1.0, 0.8).unwrap());
    let mut net = [[DVec3::ZERO; 4]; 4];
    for i in 0..4 {
        for j in 0..4 {
            net[i][j] = DVec3::new(i as f64, j as f64, ((i * 3 + j * 5) % 4) as f64 * 0.4 - 0.6);
        }
    }
    let rev = param::Revolution::new(f, vase.clone(), (0.0, 1.0), (-PI, PI)).unwrap();
    let rev_n = param::Revolution::new(f, vase, (0.0, 1.0), (0.0, 4.0))
        .unwrap()
        .natural();
    let gc =
        param::GeneralizedCylinder::new(f, base, DVec3::new(0.2, 0.1, 1.0), (0.0, 1.0), (0.0, 1.5))
            .unwrap();
    let td = param::TangentDevelopable::new(f, helix, (0.0, 3.0), (0.1, 1.2)).unwrap();
    let bz = param::BezierPatch::new(net).unwrap();
    vec![
        ("revolution", Arc::new(rev.clone()), Arc::new(rev.natural())),
        (
            "revolution natural",
            Arc::new(rev_n.clone()),
            Arc::new(rev_n),
        ),
        (
            "generalized cylinder",
            Arc::new(gc.clone()),
            Arc::new(gc.natural()),
        ),
        (
            "tangent developable",
            Arc::new(td.clone()),
            Arc::new(td.natural()),
        ),
        ("bezier patch", Arc::new(bz.clone()), Arc::new(bz.natural())),
    ]
}

#[test]
fn numerically_mapped_surfaces_vs_tessellation_and_seeded_newton() {
    for (name, surf, natural) in numeric_surfaces() {
        // Brute force: a 96×96 tessellation of the surface's natural map, through a
        // BVH; the hit point's uv (inverse) is tested against the trim by brute-force winding.
        let n = 96;
        let mut tris = Vec::new();
        for i in 0..n {
            for j in 0..n {
                let q = |a: usize, b: usize| DVec2::new(a as f64 / n as f64, b as f64 / n as f64);
                let (a, b, c, d) = (q(i, j), q(i + 1, j), q(i + 1, j + 1), q(i, j + 1));
                for tri in [[a, b, c], [a, c, d]] {
                    if let Ok(t) = Triangle::new(
                        natural.position(tri[0]),
                        natural.position(tri[1]),
                        natural.position(tri[2]),
                    ) {
                        tris.push(t);
                    }
                }
            }
        }
        let tess = Accel::from_triangles(&tris).unwrap();
        for trim in [None, Some(trim_region())] {
            let patch = TrimmedPatch::new(surf.clone(), trim.clone()).unwrap();
            let size = patch.aabb().diagonal().length();
            let keeps = |uv: DVec2| patch.trim.as_ref().is_none_or(|t| t.winding_brute(uv) != 0);
            let mut mismatch = 0;
            let mut both = 0;
            let mut tess_missed = 0;
            // Rays aimed at points of the surface so that most of them hit.
            let mut r = rng(21);
            let rays: Vec<Ray> = (0..150)
                .map(|_| {
                    let target = natural.position(DVec2::new(
                        r.random_range(0.0..1.0),
                        r.random_range(0.0..1.0),
                    ));
                    let o = target + size * rand_vec(&mut r, DVec3::splat(-1.0), DVec3::splat(1.0));
                    Ray::new(o, target - o).unwrap()
                })
                .collect();
            for (k, ray) in rays.into_iter().enumerate() {
                let got = patch.intersect(&ray, 0.0, f64::INFINITY);
                if let Some(h) = got {
                    assert!(
                        (surf.position(h.uv) - h.point).length() <= 1e-7 * size,
                        "{name}: hit off the surface"
                    );
                    assert!(patch.keeps(h.uv, 1e-9), "{name}: trimmed hit returned");
                }
                // First tessellation hit whose uv (the surface's inverse of the hit point)
                // the trim keeps by brute-force winding.
                let mut tmin = 0.0;
                let mut brute = None;
                while let Some(h) = tess.closest_hit(&ray, tmin, f64::INFINITY) {
                    let Some(uv) = surf.inverse(h.point) else {
                        tmin = h.t + 1e-9 * size;
                        continue;
                    };
                    if keeps(uv) {
                        brute = Some(h.t);
                        break;
                    }
                    tmin = h.t + 1e-9 * size;
                }
                // Our hits are verified on the surface above. The tessellation's chords
                // can miss grazing hits (ours earlier or alone: counted, allowed) or
                // report near-misses; a hit of ours later than the tessellation's by
                // more than its chord error, or none, is a suspected missed root.
                match (got, brute) {
                    (Some(h), Some(t)) => {
                        both += 1;
                        if h.t > t + 1e-3 * size {
                            mismatch += 1;
                        } else if h.t < t - 1e-3 * size {
                            tess_missed += 1;
                        }
                    }
                    (Some(_), None) => tess_missed += 1,
                    (None, Some(_)) => mismatch += 1,
                    (None, None) => {}
                }
                // The seeded-Newton search agrees wherever it finds the same root (20
                // rays; not on the Bézier patch, whose equal-area map costs ~1 ms per
                // evaluation in the dev profile).
                if k < 20
                    && name != "bezier patch"
                    && let (Some(a), Some(b)) =
                        (got, patch.intersect_newton(&ray, 0.0, f64::INFINITY))
                    && (a.t - b.t).abs() <= 1e-3 * size
                {
                    assert!(
                        (a.t - b.t).abs() <= 1e-9 * size,
                        "{name}: {} vs newton {}",
                        a.t,
                        b.t
                    );
                }
            }
            assert!(both > 40, "{name}: too few hits to compare ({both})");
            assert!(
                mismatch <= 3,
                "{name} trimmed={}: {mismatch} suspected missed roots",
                trim.is_some()
            );
            assert!(
                tess_missed <= 20,
                "{name}: {tess_missed} grazing hits beyond the tessellation"
            );
        }
    }
}
