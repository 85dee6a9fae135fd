//! Exact ray intersection for every primitive.
//!
//! - Triangles: the watertight test of Woop, Benthin & Wald (2013) in f64 (shear to ray
//!   space, three edge functions), so two triangles sharing an edge leave no crack.
//!   Rays within ~1e-10 rad of a planar primitive's plane do not hit it (grazing).
//! - Parallelograms and planar polygons: plane hit, then the parameter-space test; the
//!   test is dilated by 1e-9 of the primitive's size so abutting primitives never leak.
//! - Trimmed patches: the implicit form of the surface (plane, sphere, spheroid,
//!   cylinder, cone, torus) gives a polynomial in `t` whose roots in the clipped ray
//!   interval are found robustly ([`crate::poly`]; a quartic for the torus); every root
//!   is mapped to `(u, v)` by the surface's inverse and kept if the trim region
//!   (slab decomposition, VirtualMesh §4.2) contains it. `wavelux-param` Bézier
//!   patches use the Bézier search below on their control net; surfaces of revolution,
//!   generalized cylinders and tangent developables (and any future shape) use adaptive
//!   subdivision of their natural parametrization with Newton at the leaves
//!   ([`parametric_closest`]); the hit is mapped back by the surface's inverse.
//! - Bézier patches: de Casteljau subdivision with control-hull box culling (the
//!   interval part), then Newton on `S(u, v) = o + t d` from each surviving cell.

use glam::{DVec2, DVec3};
use wavelux_param::SurfaceShape;

use crate::bezier;
use crate::poly;
use crate::primitive::{
    Aabb, BezierPatch, ComplexPolygon, Hit, Parallelogram, Primitive, Ray, Triangle, TrimmedPatch,
};
use wavelux_param::Parametrization;

/// Relative parameter-space dilation of planar primitives (see the module docs).
pub const PLANAR_DILATION: f64 = 1e-9;

/// Watertight ray–triangle test; returns `(t, β, γ)` (barycentric weights of `b`, `c`).
#[inline]
pub fn triangle_raw(v: &[DVec3; 3], ray: &Ray, tmin: f64, tmax: f64) -> Option<(f64, f64, f64)> {
    WatertightRay::new(ray).triangle(v, tmin, tmax)
}

/// The per-ray part of the watertight test (Woop, Benthin & Wald 2013, §3: the
/// permutation that makes the ray's largest direction component `z` and the shear
/// constants), computed once per ray and reused for every triangle it meets.
/// [`WatertightRay::triangle`] returns bit for bit what [`triangle_raw`] returns.
#[derive(Debug, Clone, Copy)]
pub struct WatertightRay {
    origin: [f64; 3],
    dir: DVec3,
    /// Axis permutation `(kx, ky, kz)`.
    k: [usize; 3],
    /// Shear `(d_kx/d_kz, d_ky/d_kz, 1/d_kz)`.
    s: [f64; 3],
}

impl WatertightRay {
    /// The ray's permutation and shear.
    #[inline]
    pub fn new(ray: &Ray) -> Self {
        let d = ray.dir;
        let ad = d.abs();
        let kz = if ad.x > ad.y {
            if ad.x > ad.z { 0 } else { 2 }
        } else if ad.y > ad.z {
            1
        } else {
            2
        };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        if d[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        Self {
            origin: ray.origin.to_array(),
            dir: d,
            k: [kx, ky, kz],
            s: [d[kx] / d[kz], d[ky] / d[kz], 1.0 / d[kz]],
        }
    }

    /// The watertight test against triangle `v` over `t ∈ [tmin, tmax]`: `(t, β, γ)`.
    #[inline]
    pub fn triangle(&self, v: &[DVec3; 3], tmin: f64, tmax: f64) -> Option<(f64, f64, f64)> {
        let [kx, ky, kz] = self.k;
        let [sx, sy, sz] = self.s;
        let o = self.origin;
        // Vertices relative to the origin, permuted: `[x, y, z]` in ray space.
        let rel = |p: &DVec3| {
            let p = p.to_array();
            [p[kx] - o[kx], p[ky] - o[ky], p[kz] - o[kz]]
        };
        let (a, b, c) = (rel(&v[0]), rel(&v[1]), rel(&v[2]));
        let ax = a[0] - sx * a[2];
        let ay = a[1] - sy * a[2];
        let bx = b[0] - sx * b[2];
        let by = b[1] - sy * b[2];
        let cx = c[0] - sx * c[2];
        let cy = c[1] - sy * c[2];
        let u = cx * by - cy * bx;
        let vv = ax * cy - ay * cx;
        let w = bx * ay - by * ax;
        if (u < 0.0 || vv < 0.0 || w < 0.0) && (u > 0.0 || vv > 0.0 || w > 0.0) {
            return None;
        }
        let det = u + vv + w;
        if det == 0.0 {
            return None;
        }
        // Edge-on triangles (ray in the triangle's plane, to ~1e-10 rad) are not hit: a
        // segment running inside a planar surface is not occluded by it (no acne between
        // points of coplanar neighbours); a ray through a shared edge still hits the
        // other, non-grazed face. Only evaluated for rays that passed the edge tests.
        let n = (v[1] - v[0]).cross(v[2] - v[0]);
        if n.dot(self.dir).abs() <= 1e-10 * n.length() {
            return None;
        }
        let t = (u * sz * a[2] + vv * sz * b[2] + w * sz * c[2]) / det;
        if !(t >= tmin && t <= tmax) {
            return None;
        }
        Some((t, vv / det, w / det))
    }
}

fn make_hit(ray: &Ray, t: f64, uv: DVec2, normal: DVec3) -> Hit {
    Hit {
        prim: 0,
        t,
        point: ray.at(t),
        uv,
        normal,
        front: ray.dir.dot(normal) < 0.0,
    }
}

impl Triangle {
    /// Closest intersection with `t ∈ [tmin, tmax]`.
    pub fn intersect(&self, ray: &Ray, tmin: f64, tmax: f64) -> Option<Hit> {
        let (t, b, c) = triangle_raw(&self.v, ray, tmin, tmax)?;
        Some(self.intersect_from(ray, t, b, c))
    }

    /// Hit record from the raw result of [`triangle_raw`].
    pub fn intersect_from(&self, ray: &Ray, t: f64, beta: f64, gamma: f64) -> Hit {
        make_hit(ray, t, Triangle::uv_from_bary(beta, gamma), self.normal())
    }
}

fn plane_t(ray: &Ray, p0: DVec3, n: DVec3, tmin: f64, tmax: f64) -> Option<f64> {
    let den = ray.dir.dot(n);
    // Rays in the plane (to ~1e-10 rad) do not hit it (see `triangle_raw`).
    if den.abs() <= 1e-10 * n.length() {
        return None;
    }
    let t = (p0 - ray.origin).dot(n) / den;
    (t >= tmin && t <= tmax).then_some(t)
}

impl Parallelogram {
    /// Closest intersection with `t ∈ [tmin, tmax]`.
    pub fn intersect(&self, ray: &Ray, tmin: f64, tmax: f64) -> Option<Hit> {
        let n = self.e1.cross(self.e2);
        let t = plane_t(ray, self.origin, n, tmin, tmax)?;
        let r = ray.at(t) - self.origin;
        let nn = n.length_squared();
        let u = r.cross(self.e2).dot(n) / nn;
        let v = self.e1.cross(r).dot(n) / nn;
        let d = PLANAR_DILATION;
        if u < -d || u > 1.0 + d || v < -d || v > 1.0 + d {
            return None;
        }
        Some(make_hit(
            ray,
            t,
            DVec2::new(u, v).clamp(DVec2::ZERO, DVec2::ONE),
            n / nn.sqrt(),
        ))
    }
}

impl ComplexPolygon {
    /// Closest intersection with `t ∈ [tmin, tmax]`.
    pub fn intersect(&self, ray: &Ray, tmin: f64, tmax: f64) -> Option<Hit> {
        let n = self.frame.normal();
        let t = plane_t(ray, self.frame.origin, n, tmin, tmax)?;
        let p = ray.at(t);
        let q = self.frame.to_plane(p);
        let (lo, hi) = self.region.bounds();
        let tol = PLANAR_DILATION * (hi - lo).max_element();
        if !self.region.contains_tol(q, tol) {
            return None;
        }
        let uv = ((q - lo) / (hi - lo)).clamp(DVec2::ZERO, DVec2::ONE);
        Some(make_hit(ray, t, uv, n))
    }
}

/// Implicit surfaces in local coordinates (see [`implicit_roots`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Implicit {
    /// The plane `z = 0`.
    Plane,
    /// `|x|² = r²`.
    Sphere(f64),
    /// `(x² + y²)/a² + z²/c² = 1`.
    Spheroid(f64, f64),
    /// `x² + y² = r²`.
    Cylinder(f64),
    /// Double cone `x² + y² = k² z²` (apex at the origin).
    Cone(f64),
    /// `(|x|² + R² − r²)² = 4R²(x² + y²)`.
    Torus(f64, f64),
}

/// All `t ∈ [tmin, tmax]` (ascending) where the ray with *local* origin `o` and unit
/// direction `d` meets the implicit surface.
pub fn implicit_roots(imp: Implicit, o: DVec3, d: DVec3, tmin: f64, tmax: f64) -> Vec<f64> {
    // Shift the origin to the start of the interval (conditioning), solve in s = t − tmin.
    let o = o + tmin * d;
    let span = tmax - tmin;
    let xy = |a: DVec3, b: DVec3| a.x * b.x + a.y * b.y;
    let coeffs: Vec<f64> = match imp {
        Implicit::Plane => vec![o.z, d.z],
        Implicit::Sphere(r) => vec![
            o.length_squared() - r * r,
            2.0 * o.dot(d),
            d.length_squared(),
        ],
        Implicit::Spheroid(a, c) => {
            let s = DVec3::new(1.0 / a, 1.0 / a, 1.0 / c);
            let (os, ds) = (o * s, d * s);
            vec![
                os.length_squared() - 1.0,
                2.0 * os.dot(ds),
                ds.length_squared(),
            ]
        }
        Implicit::Cylinder(r) => vec![xy(o, o) - r * r, 2.0 * xy(o, d), xy(d, d)],
        Implicit::Cone(k) => {
            let k2 = k * k;
            vec![
                xy(o, o) - k2 * o.z * o.z,
                2.0 * (xy(o, d) - k2 * o.z * d.z),
                xy(d, d) - k2 * d.z * d.z,
            ]
        }
        Implicit::Torus(big, small) => {
            let dd = d.length_squared();
            let b = o.dot(d);
            let kk = o.length_squared() + big * big - small * small;
            let e = xy(d, d);
            let f = xy(o, d);
            let g = xy(o, o);
            let r2 = 4.0 * big * big;
            vec![
                kk * kk - r2 * g,
                4.0 * b * kk - 2.0 * r2 * f,
                4.0 * b * b + 2.0 * kk * dd - r2 * e,
                4.0 * b * dd,
                dd * dd,
            ]
        }
    };
    poly::roots_in(&coeffs, 0.0, span)
        .into_iter()
        .map(|s| s + tmin)
        .collect()
}

/// A local orthonormal frame (origin and axes in world coordinates).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LocalFrame {
    /// Origin.
    pub origin: DVec3,
    /// Unit axes `x`, `y`, `z`.
    pub axes: [DVec3; 3],
}

impl LocalFrame {
    fn of(f: &wavelux_param::Frame) -> LocalFrame {
        LocalFrame {
            origin: f.origin(),
            axes: [f.x_axis(), f.y_axis(), f.z_axis()],
        }
    }

    /// Local coordinates of a world point.
    pub fn to_local(&self, p: DVec3) -> DVec3 {
        self.vec_to_local(p - self.origin)
    }

    /// Local components of a world vector.
    pub fn vec_to_local(&self, d: DVec3) -> DVec3 {
        DVec3::new(
            d.dot(self.axes[0]),
            d.dot(self.axes[1]),
            d.dot(self.axes[2]),
        )
    }
}

/// Local frame and implicit form of a surface, if its shape has one (all current
/// `wavelux-param` shapes do).
pub fn implicit_of(s: &dyn Parametrization) -> Option<(LocalFrame, Implicit)> {
    match s.shape() {
        SurfaceShape::Parallelogram(pg) => {
            let n = pg.e1().cross(pg.e2()).try_normalize()?;
            let x = n.any_orthonormal_vector();
            Some((
                LocalFrame {
                    origin: pg.origin(),
                    axes: [x, n.cross(x), n],
                },
                Implicit::Plane,
            ))
        }
        SurfaceShape::Sphere(s) => Some((LocalFrame::of(s.frame()), Implicit::Sphere(s.radius()))),
        SurfaceShape::Cylinder(c) => {
            Some((LocalFrame::of(c.frame()), Implicit::Cylinder(c.radius())))
        }
        SurfaceShape::Cone(c) => Some((
            LocalFrame::of(c.frame()),
            Implicit::Cone(c.radius() / c.height()),
        )),
        SurfaceShape::Spheroid(s) => Some((
            LocalFrame::of(s.frame()),
            Implicit::Spheroid(s.equatorial_semi_axis(), s.polar_semi_axis()),
        )),
        SurfaceShape::Torus(t) => Some((
            LocalFrame::of(t.frame()),
            Implicit::Torus(t.major_radius(), t.minor_radius()),
        )),
        _ => None,
    }
}

/// Parameter-space tolerance of the patch-boundary test for curved patches.
const PATCH_UV_TOL: f64 = 1e-10;

impl TrimmedPatch {
    /// Closest intersection with `t ∈ [tmin, tmax]` that the trim keeps. Quadrics,
    /// torus and planes: implicit roots; Bézier patches: [`bezier_closest`] on the
    /// control net; other shapes (revolution, generalized cylinder, tangent
    /// developable, future ones): [`parametric_closest`] on the surface's natural map
    /// (cheap to evaluate), the hit mapped back by the surface's inverse.
    pub fn intersect(&self, ray: &Ray, tmin: f64, tmax: f64) -> Option<Hit> {
        let bb = self.aabb();
        let size = bb.diagonal().length();
        let pad = 1e-9 * size;
        let (t0, t1) = bb.expanded(pad).intersect_ray(ray, tmin, tmax)?;
        let surf = self.surface.as_ref();
        if let Some((frame, imp)) = implicit_of(surf) {
            let o = frame.to_local(ray.origin);
            let d = frame.vec_to_local(ray.dir);
            for t in implicit_roots(imp, o, d, t0, t1) {
                if t < tmin || t > tmax {
                    continue;
                }
                let Some(uv) = surf.inverse(ray.at(t)) else {
                    continue;
                };
                if self.keeps(uv, PATCH_UV_TOL) {
                    let uv = uv.clamp(DVec2::ZERO, DVec2::ONE);
                    return Some(make_hit(ray, t, uv, surf.normal(uv)));
                }
            }
            return None;
        }
        let mut found: Option<DVec2> = None;
        let mut accept = |_: DVec2, x: DVec3| match surf.inverse(x) {
            Some(uv) if self.keeps(uv, PATCH_UV_TOL) => {
                found = Some(uv.clamp(DVec2::ZERO, DVec2::ONE));
                true
            }
            _ => false,
        };
        let (t, _) = match surf.shape() {
            SurfaceShape::BezierPatch(b) => {
                bezier_closest(b.control_points(), ray, t0, t1, &mut accept)?
            }
            _ => {
                let search = natural_of(surf);
                let s: &dyn Parametrization = search.as_deref().unwrap_or(surf);
                let eval = |q: DVec2| {
                    let sp = s.eval(q);
                    (sp.position, sp.dp_du, sp.dp_dv)
                };
                parametric_closest(eval, size, ray, t0, t1, &mut accept)?
            }
        };
        // `found` holds the uv of the last accepted root, which is the returned one
        // (each accepted root lowers the search's upper bound).
        let uv = found?;
        Some(make_hit(ray, t, uv, surf.normal(uv)))
    }

    /// The seeded-Newton search on a 24×24 parameter grid (kept as an independent
    /// cross-check of the other paths in tests): Newton on `S(u,v) − (o + t d)` from the
    /// centre of every cell whose doubled box the ray crosses, `t` seeded by projecting
    /// the centre on the ray; a root is accepted only within 1.5 cells of its seed.
    /// Roots at grazing incidence or closer than a cell to the patch boundary may be missed.
    pub fn intersect_newton(&self, ray: &Ray, tmin: f64, tmax: f64) -> Option<Hit> {
        let p = &self.surface;
        let n = 24;
        let h = 1.0 / n as f64;
        let mut best: Option<Hit> = None;
        for i in 0..n {
            for j in 0..n {
                let c = DVec2::new((i as f64 + 0.5) * h, (j as f64 + 0.5) * h);
                let corners = [
                    DVec2::new(i as f64 * h, j as f64 * h),
                    DVec2::new((i + 1) as f64 * h, (j + 1) as f64 * h),
                    DVec2::new(i as f64 * h, (j + 1) as f64 * h),
                    DVec2::new((i + 1) as f64 * h, j as f64 * h),
                ];
                let b = Aabb::from_points(
                    corners
                        .iter()
                        .map(|q| p.position(*q))
                        .chain(std::iter::once(p.position(c))),
                );
                let b = b.expanded(0.5 * b.diagonal().length());
                let Some((ta, tb)) = b.intersect_ray(ray, tmin, tmax) else {
                    continue;
                };
                let seed_t = (p.position(c) - ray.origin).dot(ray.dir).clamp(ta, tb);
                let eval = |uv: DVec2| {
                    let sp = p.eval(uv);
                    (sp.position, sp.dp_du, sp.dp_dv)
                };
                if let Some((t, uv)) = newton_surface(eval, ray, c, seed_t, tmin, tmax)
                    && (uv - c).abs().max_element() <= 1.5 * h
                    && self.keeps(uv, PATCH_UV_TOL)
                    && best.as_ref().is_none_or(|bh| t < bh.t)
                {
                    best = Some(make_hit(ray, t, uv, p.normal(uv)));
                }
            }
        }
        best
    }
}

/// The same surface with its natural (cheap) parametrization, for shapes whose
/// equal-area map is numerical.
fn natural_of(s: &dyn Parametrization) -> Option<std::sync::Arc<dyn Parametrization>> {
    match s.shape() {
        SurfaceShape::Revolution(r) => Some(std::sync::Arc::new(r.natural())),
        SurfaceShape::GeneralizedCylinder(g) => Some(std::sync::Arc::new(g.natural())),
        SurfaceShape::TangentDevelopable(t) => Some(std::sync::Arc::new(t.natural())),
        _ => None,
    }
}

/// Newton iteration for `S(u,v) = o + t d` from a seed; returns `(t, uv)` on convergence
/// (residual below 1e-12 of the point's magnitude scale) with `uv ∈ [0,1]²` (to 1e-9).
fn newton_surface<F: Fn(DVec2) -> (DVec3, DVec3, DVec3)>(
    eval: F,
    ray: &Ray,
    mut uv: DVec2,
    mut t: f64,
    tmin: f64,
    tmax: f64,
) -> Option<(f64, DVec2)> {
    for _ in 0..30 {
        let (s, su, sv) = eval(uv);
        let r = s - ray.at(t);
        let scale = 1.0 + s.abs().max_element() + su.length() + sv.length();
        if r.length() <= 1e-13 * scale {
            let inside =
                uv.cmpge(DVec2::splat(-1e-9)).all() && uv.cmple(DVec2::splat(1.0 + 1e-9)).all();
            return (inside && t >= tmin && t <= tmax)
                .then_some((t, uv.clamp(DVec2::ZERO, DVec2::ONE)));
        }
        // Solve [su sv −d] [du dv dt]ᵀ = −r.
        let m = glam::DMat3::from_cols(su, sv, -ray.dir);
        let det = m.determinant();
        if det.abs() <= 1e-300 || !det.is_finite() {
            return None;
        }
        let x = m.inverse() * (-r);
        uv += DVec2::new(x.x, x.y);
        t += x.z;
        if !uv.is_finite() || uv.min_element() < -0.5 || uv.max_element() > 1.5 {
            return None;
        }
    }
    None
}

/// Outcome of Newton at a leaf cell of a subdivision search.
enum Leaf {
    /// A root inside the cell that the caller accepted: `(t, uv)`.
    Accepted(f64, DVec2),
    /// A root inside the cell that the caller rejected (e.g. trimmed away).
    Rejected,
    /// No root found inside the cell.
    Missed,
}

fn leaf_newton<F: Fn(DVec2) -> (DVec3, DVec3, DVec3)>(
    eval: F,
    ray: &Ray,
    lo: DVec2,
    hi: DVec2,
    t_seed: f64,
    tmin: f64,
    tmax: f64,
    accept: &mut dyn FnMut(DVec2, DVec3) -> bool,
) -> Leaf {
    let c = 0.5 * (lo + hi);
    match newton_surface(eval, ray, c, t_seed, tmin, tmax) {
        Some((t, uv)) => {
            let m = 1e-9 + 1e-6 * (hi - lo).max_element();
            if uv.x < lo.x - m || uv.x > hi.x + m || uv.y < lo.y - m || uv.y > hi.y + m {
                Leaf::Missed
            } else if accept(uv, ray.at(t)) {
                Leaf::Accepted(t, uv)
            } else {
                Leaf::Rejected
            }
        }
        None => Leaf::Missed,
    }
}

/// Closest root of a bicubic Bézier patch along the ray that `accept(st, point)` keeps:
/// de Casteljau subdivision with control-hull boxes (conservative: the convex-hull
/// property), Newton at cells below 1/64 of the patch size, deeper subdivision
/// (to 1/4096, depth ≤ 20) where Newton leaves the cell or fails.
pub fn bezier_closest(
    p: &[[DVec3; 4]; 4],
    ray: &Ray,
    tmin: f64,
    tmax: f64,
    accept: &mut dyn FnMut(DVec2, DVec3) -> bool,
) -> Option<(f64, DVec2)> {
    let size = Aabb::from_points(p.iter().flatten().copied())
        .diagonal()
        .length();
    let pad = 1e-9 * size;
    let mut best: Option<(f64, DVec2)> = None;
    let mut stack: Vec<([[DVec3; 4]; 4], DVec2, DVec2, u32)> =
        vec![(*p, DVec2::ZERO, DVec2::ONE, 0)];
    while let Some((net, lo, hi, depth)) = stack.pop() {
        let cur_max = best.map_or(tmax, |b| b.0);
        let b = Aabb::from_points(net.iter().flatten().copied()).expanded(pad);
        let Some((ta, tb)) = b.intersect_ray(ray, tmin, cur_max) else {
            continue;
        };
        let diag = b.diagonal().length();
        if diag <= size / 64.0 || depth >= 20 {
            match leaf_newton(
                |q| bezier::eval(p, q),
                ray,
                lo,
                hi,
                0.5 * (ta + tb),
                tmin,
                cur_max,
                accept,
            ) {
                Leaf::Accepted(t, uv) => {
                    best = Some((t, uv));
                    continue;
                }
                Leaf::Rejected => continue,
                Leaf::Missed if depth >= 20 || diag <= size / 4096.0 => continue,
                Leaf::Missed => {}
            }
        }
        let (mid_u, mid_v) = (0.5 * (lo.x + hi.x), 0.5 * (lo.y + hi.y));
        let (a, bnet) = bezier::split_u(&net);
        for (half, l, h) in [
            (a, lo, DVec2::new(mid_u, hi.y)),
            (bnet, DVec2::new(mid_u, lo.y), hi),
        ] {
            let (c0, c1) = bezier::split_v(&half);
            stack.push((c0, l, DVec2::new(h.x, mid_v), depth + 1));
            stack.push((c1, DVec2::new(l.x, mid_v), h, depth + 1));
        }
    }
    best
}

/// Closest root along the ray of a general parametric surface (`eval` gives position
/// and both tangents over `[0,1]²`) that `accept(uv, point)` keeps: adaptive
/// subdivision from an 8×8 grid, each cell bounded by the box of 9 samples inflated
/// by twice the deviation of its centre from the bilinear interpolation of its corners
/// plus `1e-9` of the surface size (a heuristic bound, tight for smooth surfaces once
/// cells are small), Newton at cells of 1/128 (deeper to 1/1024 where it fails).
pub fn parametric_closest<F: Fn(DVec2) -> (DVec3, DVec3, DVec3)>(
    eval: F,
    size: f64,
    ray: &Ray,
    tmin: f64,
    tmax: f64,
    accept: &mut dyn FnMut(DVec2, DVec3) -> bool,
) -> Option<(f64, DVec2)> {
    let pad = 1e-9 * size;
    let mut best: Option<(f64, DVec2)> = None;
    let n0 = 8;
    let mut stack: Vec<(DVec2, DVec2, u32)> = Vec::with_capacity(n0 * n0 + 64);
    for i in 0..n0 {
        for j in 0..n0 {
            let lo = DVec2::new(i as f64, j as f64) / n0 as f64;
            stack.push((lo, lo + DVec2::splat(1.0 / n0 as f64), 3));
        }
    }
    while let Some((lo, hi, depth)) = stack.pop() {
        let cur_max = best.map_or(tmax, |b| b.0);
        let mut pts = [DVec3::ZERO; 9];
        for a in 0..3 {
            for b in 0..3 {
                let q = lo + (hi - lo) * DVec2::new(a as f64, b as f64) * 0.5;
                pts[3 * a + b] = eval(q).0;
            }
        }
        let bilinear = 0.25 * (pts[0] + pts[2] + pts[6] + pts[8]);
        let dev = (pts[4] - bilinear).length();
        let bx = Aabb::from_points(pts).expanded(2.0 * dev + pad);
        let Some((ta, tb)) = bx.intersect_ray(ray, tmin, cur_max) else {
            continue;
        };
        let cell = (hi - lo).max_element();
        if cell <= 1.0 / 128.0 {
            match leaf_newton(&eval, ray, lo, hi, 0.5 * (ta + tb), tmin, cur_max, accept) {
                Leaf::Accepted(t, uv) => {
                    best = Some((t, uv));
                    continue;
                }
                Leaf::Rejected => continue,
                Leaf::Missed if cell <= 1.0 / 1024.0 => continue,
                Leaf::Missed => {}
            }
        }
        let m = 0.5 * (lo + hi);
        stack.push((lo, m, depth + 1));
        stack.push((DVec2::new(m.x, lo.y), DVec2::new(hi.x, m.y), depth + 1));
        stack.push((DVec2::new(lo.x, m.y), DVec2::new(m.x, hi.y), depth + 1));
        stack.push((m, hi, depth + 1));
    }
    best
}

impl BezierPatch {
    /// Closest intersection with `t ∈ [tmin, tmax]` ([`bezier_closest`]).
    pub fn intersect(&self, ray: &Ray, tmin: f64, tmax: f64) -> Option<Hit> {
        let (t, uv) = bezier_closest(&self.p, ray, tmin, tmax, &mut |_, _| true)?;
        Some(make_hit(ray, t, uv, self.normal(uv)))
    }
}

impl Primitive {
    /// Closest intersection with `t ∈ [tmin, tmax]` (`Hit::prim` is 0; the accelerator sets it).
    pub fn intersect(&self, ray: &Ray, tmin: f64, tmax: f64) -> Option<Hit> {
        match self {
            Primitive::Triangle(t) => t.intersect(ray, tmin, tmax),
            Primitive::Parallelogram(p) => p.intersect(ray, tmin, tmax),
            Primitive::Polygon(p) => p.intersect(ray, tmin, tmax),
            Primitive::Trimmed(p) => p.intersect(ray, tmin, tmax),
            Primitive::Bezier(b) => b.intersect(ray, tmin, tmax),
        }
    }

    /// True for planar primitives (a ray from a point on them cannot hit them again).
    pub fn is_planar(&self) -> bool {
        match self {
            Primitive::Triangle(_) | Primitive::Parallelogram(_) | Primitive::Polygon(_) => true,
            Primitive::Trimmed(p) => {
                matches!(implicit_of(p.surface.as_ref()), Some((_, Implicit::Plane)))
            }
            Primitive::Bezier(_) => false,
        }
    }
}
