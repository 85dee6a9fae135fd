//! Exact geometric primitives, bounding boxes, rays and hit records.
//!
//! The primitive set follows the issue contract and VirtualMesh §3 (surfaces are kept
//! exact: trimmed parametric patches, planar regions with curved boundaries, triangles)
//! and Ziegler §2.1 (every surface carries a parametrization over the unit square so
//! that radiosity can be represented as a function of `(u, v)`).
//!
//! Every primitive `P` exposes a map `P::eval(uv)` from its *unit-square support*
//! `[0,1]²` to 3-D, and [`Hit::uv`] is always a point of that support with
//! `eval(hit.uv) == hit.point` up to rounding (tolerance ~1e-12 relative to the scene).
//!
//! | primitive | support map `(u, v) ↦ x` |
//! |---|---|
//! | [`Triangle`] | equal-area square→triangle map `(1−√u) a + √u (1−v) b + √u v c` |
//! | [`Parallelogram`] | `origin + u e1 + v e2` |
//! | [`ComplexPolygon`] | affine map of the square onto the region's bounding rectangle in the plane frame |
//! | [`TrimmedPatch`] | the surface's own map; the trim region lives in that `[0,1]²` |
//! | [`BezierPatch`] | Bernstein tensor product, bicubic |

use glam::{DVec2, DVec3};

use crate::GeometryError;
use crate::bezier;
use crate::trim::TrimRegion;
use std::sync::Arc;
use wavelux_param::Parametrization;

/// Index of a primitive inside a [`crate::Accel`] (its position in the slice it was built from).
pub type PrimId = u32;

/// Axis-aligned bounding box in f64 (metres, or whatever unit the scene uses).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    /// Lower corner.
    pub min: DVec3,
    /// Upper corner.
    pub max: DVec3,
}

impl Aabb {
    /// The empty box (min = +∞, max = −∞); the identity of [`Aabb::union`].
    pub const EMPTY: Aabb = Aabb {
        min: DVec3::splat(f64::INFINITY),
        max: DVec3::splat(f64::NEG_INFINITY),
    };

    /// Box of a set of points (empty if the iterator is empty).
    pub fn from_points<I: IntoIterator<Item = DVec3>>(points: I) -> Aabb {
        let mut b = Aabb::EMPTY;
        for p in points {
            b.grow(p);
        }
        b
    }

    /// Enlarges the box to contain `p`.
    pub fn grow(&mut self, p: DVec3) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }

    /// Smallest box containing both.
    pub fn union(&self, other: &Aabb) -> Aabb {
        Aabb {
            min: self.min.min(other.min),
            max: self.max.max(other.max),
        }
    }

    /// True if `min <= max` on every axis.
    pub fn is_valid(&self) -> bool {
        self.min.cmple(self.max).all()
    }

    /// `max − min` (zero vector for an empty box).
    pub fn diagonal(&self) -> DVec3 {
        if self.is_valid() {
            self.max - self.min
        } else {
            DVec3::ZERO
        }
    }

    /// Centre of the box.
    pub fn center(&self) -> DVec3 {
        0.5 * (self.min + self.max)
    }

    /// Box enlarged by `d` on every side.
    pub fn expanded(&self, d: f64) -> Aabb {
        Aabb {
            min: self.min - DVec3::splat(d),
            max: self.max + DVec3::splat(d),
        }
    }

    /// True if `p` lies in the closed box.
    pub fn contains(&self, p: DVec3) -> bool {
        p.cmpge(self.min).all() && p.cmple(self.max).all()
    }

    /// Slab test: the parameter interval `[t0, t1] ⊂ [tmin, tmax]` of `ray` inside the box, if any.
    pub fn intersect_ray(&self, ray: &Ray, tmin: f64, tmax: f64) -> Option<(f64, f64)> {
        let mut t0 = tmin;
        let mut t1 = tmax;
        for k in 0..3 {
            let o = ray.origin[k];
            let d = ray.dir[k];
            if d == 0.0 {
                if o < self.min[k] || o > self.max[k] {
                    return None;
                }
                continue;
            }
            let inv = 1.0 / d;
            let mut a = (self.min[k] - o) * inv;
            let mut b = (self.max[k] - o) * inv;
            if a > b {
                std::mem::swap(&mut a, &mut b);
            }
            t0 = t0.max(a);
            t1 = t1.min(b);
            if t0 > t1 {
                return None;
            }
        }
        Some((t0, t1))
    }
}

/// A ray `origin + t · dir` with unit direction, so `t` is a distance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ray {
    /// Origin.
    pub origin: DVec3,
    /// Unit direction.
    pub dir: DVec3,
}

impl Ray {
    /// Ray from `origin` along `dir` (normalised here).
    ///
    /// # Errors
    /// [`GeometryError::NonFinite`] for NaN/∞ input, [`GeometryError::Degenerate`] for a zero direction.
    pub fn new(origin: DVec3, dir: DVec3) -> Result<Ray, GeometryError> {
        if !origin.is_finite() || !dir.is_finite() {
            return Err(GeometryError::NonFinite("ray"));
        }
        let n = dir.length();
        if n <= f64::MIN_POSITIVE {
            return Err(GeometryError::Degenerate("ray direction has zero length"));
        }
        Ok(Ray {
            origin,
            dir: dir / n,
        })
    }

    /// Point at distance `t`.
    pub fn at(&self, t: f64) -> DVec3 {
        self.origin + t * self.dir
    }
}

/// A ray–primitive intersection.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// The primitive that was hit (index in the accelerator's primitive slice; 0 for a single-primitive test).
    pub prim: PrimId,
    /// Distance along the (unit-direction) ray.
    pub t: f64,
    /// Hit point in world space.
    pub point: DVec3,
    /// Parameters of the hit point on the primitive's unit-square support (see the module docs).
    pub uv: DVec2,
    /// Unit geometric normal of the primitive at the hit point, on its *front* side
    /// (the side its orientation defines; not flipped towards the ray).
    pub normal: DVec3,
    /// True if the ray arrived from the front side (`dir · normal < 0`).
    pub front: bool,
}

fn check_finite(pts: &[DVec3], what: &'static str) -> Result<(), GeometryError> {
    if pts.iter().all(|p| p.is_finite()) {
        Ok(())
    } else {
        Err(GeometryError::NonFinite(what))
    }
}

/// A triangle `a, b, c`; the front side is the one `(b−a)×(c−a)` points to.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Triangle {
    /// Vertices in counter-clockwise order seen from the front.
    pub v: [DVec3; 3],
}

impl Triangle {
    /// Validated triangle.
    ///
    /// # Errors
    /// Non-finite vertices, or an area below `1e-14 ·` (longest edge)².
    pub fn new(a: DVec3, b: DVec3, c: DVec3) -> Result<Triangle, GeometryError> {
        check_finite(&[a, b, c], "triangle vertex")?;
        let n = (b - a).cross(c - a).length();
        let l2 = (b - a)
            .length_squared()
            .max((c - a).length_squared())
            .max((c - b).length_squared());
        if n <= 1e-14 * l2 {
            return Err(GeometryError::Degenerate("triangle has (near) zero area"));
        }
        Ok(Triangle { v: [a, b, c] })
    }

    /// Area.
    pub fn area(&self) -> f64 {
        0.5 * (self.v[1] - self.v[0])
            .cross(self.v[2] - self.v[0])
            .length()
    }

    /// Unit front normal.
    pub fn normal(&self) -> DVec3 {
        (self.v[1] - self.v[0])
            .cross(self.v[2] - self.v[0])
            .normalize()
    }

    /// Equal-area support map `(1−√u) a + √u (1−v) b + √u v c`.
    pub fn eval(&self, uv: DVec2) -> DVec3 {
        let s = uv.x.max(0.0).sqrt();
        (1.0 - s) * self.v[0] + s * (1.0 - uv.y) * self.v[1] + s * uv.y * self.v[2]
    }

    /// Inverse of [`Triangle::eval`] from barycentric weights of `b` and `c`.
    pub fn uv_from_bary(beta: f64, gamma: f64) -> DVec2 {
        let s = (beta + gamma).clamp(0.0, 1.0);
        let v = if s > 0.0 {
            (gamma / s).clamp(0.0, 1.0)
        } else {
            0.0
        };
        DVec2::new(s * s, v)
    }

    /// Bounding box.
    pub fn aabb(&self) -> Aabb {
        Aabb::from_points(self.v)
    }
}

/// A parallelogram `origin + u e1 + v e2`, `(u, v) ∈ [0,1]²`; front side along `e1 × e2`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Parallelogram {
    /// Corner at `(u, v) = (0, 0)`.
    pub origin: DVec3,
    /// Edge vector along `u`.
    pub e1: DVec3,
    /// Edge vector along `v`.
    pub e2: DVec3,
}

impl Parallelogram {
    /// Validated parallelogram.
    ///
    /// # Errors
    /// Non-finite input, or `|e1 × e2| <= 1e-14 · max(|e1|², |e2|²)`.
    pub fn new(origin: DVec3, e1: DVec3, e2: DVec3) -> Result<Parallelogram, GeometryError> {
        check_finite(&[origin, e1, e2], "parallelogram")?;
        let n = e1.cross(e2).length();
        if n <= 1e-14 * e1.length_squared().max(e2.length_squared()) {
            return Err(GeometryError::Degenerate(
                "parallelogram has (near) zero area",
            ));
        }
        Ok(Parallelogram { origin, e1, e2 })
    }

    /// Area `|e1 × e2|`.
    pub fn area(&self) -> f64 {
        self.e1.cross(self.e2).length()
    }

    /// Unit front normal.
    pub fn normal(&self) -> DVec3 {
        self.e1.cross(self.e2).normalize()
    }

    /// Support map.
    pub fn eval(&self, uv: DVec2) -> DVec3 {
        self.origin + uv.x * self.e1 + uv.y * self.e2
    }

    /// The four corners in order `(0,0), (1,0), (1,1), (0,1)`.
    pub fn corners(&self) -> [DVec3; 4] {
        [
            self.origin,
            self.origin + self.e1,
            self.origin + self.e1 + self.e2,
            self.origin + self.e2,
        ]
    }

    /// Bounding box.
    pub fn aabb(&self) -> Aabb {
        Aabb::from_points(self.corners())
    }
}

/// An orthonormal frame of a plane: points are `origin + x·ex + y·ey`, front normal `ex × ey`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlaneFrame {
    /// Origin of plane coordinates.
    pub origin: DVec3,
    /// Unit first axis.
    pub ex: DVec3,
    /// Unit second axis, orthogonal to `ex`.
    pub ey: DVec3,
}

impl PlaneFrame {
    /// Frame from an origin and a (not necessarily unit) normal; `ex` is chosen
    /// deterministically orthogonal to it.
    ///
    /// # Errors
    /// Non-finite input or zero normal.
    pub fn from_normal(origin: DVec3, normal: DVec3) -> Result<PlaneFrame, GeometryError> {
        check_finite(&[origin, normal], "plane frame")?;
        let n = normal
            .try_normalize()
            .ok_or(GeometryError::Degenerate("zero plane normal"))?;
        let ex = n.any_orthonormal_vector();
        Ok(PlaneFrame {
            origin,
            ex,
            ey: n.cross(ex),
        })
    }

    /// Frame from an origin and two axes; `ex` is normalised, `ey` is orthonormalised against it.
    ///
    /// # Errors
    /// Non-finite input or (nearly) parallel axes.
    pub fn from_axes(origin: DVec3, ex: DVec3, ey: DVec3) -> Result<PlaneFrame, GeometryError> {
        check_finite(&[origin, ex, ey], "plane frame")?;
        let ex = ex
            .try_normalize()
            .ok_or(GeometryError::Degenerate("zero plane axis"))?;
        let ey = (ey - ey.dot(ex) * ex)
            .try_normalize()
            .ok_or(GeometryError::Degenerate("parallel plane axes"))?;
        Ok(PlaneFrame { origin, ex, ey })
    }

    /// Unit front normal `ex × ey`.
    pub fn normal(&self) -> DVec3 {
        self.ex.cross(self.ey)
    }

    /// World point of plane coordinates `q`.
    pub fn to_world(&self, q: DVec2) -> DVec3 {
        self.origin + q.x * self.ex + q.y * self.ey
    }

    /// Plane coordinates of the orthogonal projection of `p`.
    pub fn to_plane(&self, p: DVec3) -> DVec2 {
        let d = p - self.origin;
        DVec2::new(d.dot(self.ex), d.dot(self.ey))
    }
}

/// A planar region bounded by closed loops of segments and circular arcs (non-convex, with
/// holes), in the coordinates of a [`PlaneFrame`]. Inside = non-zero winding number
/// (loops must not cross; outer loops counter-clockwise, holes clockwise).
#[derive(Debug, Clone, PartialEq)]
pub struct ComplexPolygon {
    /// Plane of the polygon.
    pub frame: PlaneFrame,
    /// Region in plane coordinates.
    pub region: TrimRegion,
}

impl ComplexPolygon {
    /// Validated polygon.
    ///
    /// # Errors
    /// Propagates region validation; the region must have positive area.
    pub fn new(frame: PlaneFrame, region: TrimRegion) -> Result<ComplexPolygon, GeometryError> {
        if region.area() <= 0.0 {
            return Err(GeometryError::Degenerate(
                "polygon region has non-positive area",
            ));
        }
        Ok(ComplexPolygon { frame, region })
    }

    /// Polygon whose outer boundary is the given straight-edged world-space loop (planar
    /// to 1e-9 relative), with straight-edged holes. Orientation of the outer loop defines
    /// the front side (counter-clockwise seen from the front).
    ///
    /// # Errors
    /// Fewer than 3 vertices, non-planar input, or degenerate loops.
    pub fn from_world_loops(
        outer: &[DVec3],
        holes: &[Vec<DVec3>],
    ) -> Result<ComplexPolygon, GeometryError> {
        if outer.len() < 3 {
            return Err(GeometryError::Degenerate(
                "polygon needs at least 3 vertices",
            ));
        }
        check_finite(outer, "polygon vertex")?;
        // Newell normal.
        let mut n = DVec3::ZERO;
        for i in 0..outer.len() {
            let a = outer[i];
            let b = outer[(i + 1) % outer.len()];
            n += (a - outer[0]).cross(b - outer[0]);
        }
        let frame = PlaneFrame::from_normal(outer[0], n)?;
        let scale = Aabb::from_points(outer.iter().copied()).diagonal().length();
        let nn = frame.normal();
        let mut loops = Vec::with_capacity(1 + holes.len());
        for (k, lp) in std::iter::once(outer)
            .chain(holes.iter().map(|h| h.as_slice()))
            .enumerate()
        {
            check_finite(lp, "polygon vertex")?;
            for p in lp {
                if (*p - frame.origin).dot(nn).abs() > 1e-9 * scale {
                    return Err(GeometryError::Degenerate(
                        "polygon vertices are not coplanar",
                    ));
                }
            }
            let pts: Vec<DVec2> = lp.iter().map(|p| frame.to_plane(*p)).collect();
            let mut l = crate::trim::TrimLoop::polygon(&pts)?;
            // Outer CCW, holes CW.
            if (k == 0) != (l.signed_area() > 0.0) {
                l = l.reversed();
            }
            loops.push(l);
        }
        ComplexPolygon::new(frame, TrimRegion::new(loops)?)
    }

    /// Area of the region.
    pub fn area(&self) -> f64 {
        self.region.area()
    }

    /// Unit front normal.
    pub fn normal(&self) -> DVec3 {
        self.frame.normal()
    }

    /// Support map: the square onto the region's bounding rectangle.
    pub fn eval(&self, uv: DVec2) -> DVec3 {
        let (lo, hi) = self.region.bounds();
        self.frame.to_world(lo + uv * (hi - lo))
    }

    /// Inverse of [`ComplexPolygon::eval`] for a point of the plane.
    pub fn uv_of(&self, p: DVec3) -> DVec2 {
        let (lo, hi) = self.region.bounds();
        (self.frame.to_plane(p) - lo) / (hi - lo)
    }

    /// Bounding box (exact for arcs: uses arc extremal points).
    pub fn aabb(&self) -> Aabb {
        let mut b = Aabb::EMPTY;
        for l in &self.region.loops {
            for e in &l.edges {
                for q in e.bbox_points() {
                    b.grow(self.frame.to_world(q));
                }
            }
        }
        b
    }
}

/// A `wavelux-param` surface patch restricted to a trim region of its unit-square
/// parameter domain (VirtualMesh §3–4: trimmed surfaces; trim loops are segments and
/// arcs). The surface's own `(u, v)` map and inverse are used throughout; ray
/// intersection dispatches on its `shape()` (plane, sphere, spheroid, cylinder, cone,
/// torus: analytic).
#[derive(Debug, Clone)]
pub struct TrimmedPatch {
    /// The untrimmed surface patch.
    pub surface: Arc<dyn Parametrization>,
    /// Kept part of `[0,1]²` (`None` = the whole square).
    pub trim: Option<TrimRegion>,
}

impl PartialEq for TrimmedPatch {
    /// Same surface object (pointer equality) and equal trims.
    fn eq(&self, other: &Self) -> bool {
        Arc::ptr_eq(&self.surface, &other.surface) && self.trim == other.trim
    }
}

impl TrimmedPatch {
    /// Validated patch; the trim region must lie within `[0,1]²` (to 1e-12).
    ///
    /// # Errors
    /// Trim region outside the unit square or of non-positive area.
    pub fn new(
        surface: Arc<dyn Parametrization>,
        trim: Option<TrimRegion>,
    ) -> Result<TrimmedPatch, GeometryError> {
        if let Some(t) = &trim {
            let (lo, hi) = t.bounds();
            if lo.min_element() < -1e-12 || hi.max_element() > 1.0 + 1e-12 {
                return Err(GeometryError::Degenerate(
                    "trim region leaves the unit square",
                ));
            }
            if t.area() <= 0.0 {
                return Err(GeometryError::Degenerate(
                    "trim region has non-positive area",
                ));
            }
        }
        Ok(TrimmedPatch { surface, trim })
    }

    /// True if `uv` is kept by the trim (and lies in `[0,1]²`, to `tol`).
    pub fn keeps(&self, uv: DVec2, tol: f64) -> bool {
        if !(uv.x >= -tol && uv.x <= 1.0 + tol && uv.y >= -tol && uv.y <= 1.0 + tol) {
            return false;
        }
        match &self.trim {
            None => true,
            Some(t) => t.contains_tol(uv, tol),
        }
    }

    /// Support map (the surface's map).
    pub fn eval(&self, uv: DVec2) -> DVec3 {
        self.surface.position(uv)
    }

    /// Unit normal at `uv` (the surface's orientation).
    pub fn normal(&self, uv: DVec2) -> DVec3 {
        self.surface.normal(uv)
    }

    /// Area of the kept part: `surface area × trim area` for equal-area maps (exact),
    /// otherwise `∫_trim J(u,v)` by Gauss–Legendre of order 16 on the trim's slab cells
    /// ([`TrimRegion::integrate`]).
    pub fn area(&self) -> f64 {
        match &self.trim {
            None => self.surface.area(),
            Some(t) if self.surface.is_equal_area() => self.surface.area() * t.area(),
            Some(t) => t.integrate(16, |uv| self.surface.jacobian(uv)),
        }
    }

    /// Bounding box of the whole untrimmed surface patch (conservative).
    pub fn aabb(&self) -> Aabb {
        let b = self.surface.bounds();
        Aabb {
            min: b.min,
            max: b.max,
        }
    }
}

/// A bicubic Bézier patch, control points `p[i][j]` with `i` along `u`, `j` along `v`;
/// front side along `∂u × ∂v`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BezierPatch {
    /// 4×4 control net.
    pub p: [[DVec3; 4]; 4],
}

impl BezierPatch {
    /// Validated patch (finite control points, non-degenerate control hull).
    ///
    /// # Errors
    /// Non-finite control points or all control points (nearly) collinear.
    pub fn new(p: [[DVec3; 4]; 4]) -> Result<BezierPatch, GeometryError> {
        let flat: Vec<DVec3> = p.iter().flatten().copied().collect();
        check_finite(&flat, "bezier control point")?;
        let b = Aabb::from_points(flat.iter().copied());
        let s = b.diagonal().length();
        let a = flat[0];
        let far = flat
            .iter()
            .copied()
            .max_by(|x, y| (*x - a).length().total_cmp(&(*y - a).length()));
        let far = far.unwrap_or(a);
        let spread = flat
            .iter()
            .map(|q| (*q - a).cross(far - a).length())
            .fold(0.0, f64::max);
        if spread <= 1e-12 * s * s {
            return Err(GeometryError::Degenerate(
                "bezier control net is degenerate",
            ));
        }
        Ok(BezierPatch { p })
    }

    /// Point at `(u, v)`.
    pub fn eval(&self, uv: DVec2) -> DVec3 {
        bezier::eval(&self.p, uv).0
    }

    /// Unit normal `∂u × ∂v / |∂u × ∂v|` (falls back to the control-net normal at
    /// degenerate points).
    pub fn normal(&self, uv: DVec2) -> DVec3 {
        let (_, su, sv) = bezier::eval(&self.p, uv);
        su.cross(sv)
            .try_normalize()
            .or_else(|| {
                (self.p[3][0] - self.p[0][0])
                    .cross(self.p[0][3] - self.p[0][0])
                    .try_normalize()
            })
            .unwrap_or(DVec3::Z)
    }

    /// Area `∫∫ |∂u × ∂v|` by a 24×24 Gauss–Legendre rule.
    pub fn area(&self) -> f64 {
        let Ok(gl) = wavelux_quadrature::GaussLegendre::new(24) else {
            return f64::NAN;
        };
        let (x, w) = gl.unit();
        let mut a = 0.0;
        for i in 0..x.len() {
            for j in 0..x.len() {
                let (_, su, sv) = bezier::eval(&self.p, DVec2::new(x[i], x[j]));
                a += w[i] * w[j] * su.cross(sv).length();
            }
        }
        a
    }

    /// Bounding box of the control net (convex-hull property).
    pub fn aabb(&self) -> Aabb {
        Aabb::from_points(self.p.iter().flatten().copied())
    }
}

/// Any primitive the accelerator can hold.
#[derive(Debug, Clone, PartialEq)]
pub enum Primitive {
    /// A triangle.
    Triangle(Triangle),
    /// A parallelogram.
    Parallelogram(Parallelogram),
    /// A planar region with segment/arc boundaries and holes (boxed: keeps the enum small).
    Polygon(Box<ComplexPolygon>),
    /// A trimmed surface patch (boxed).
    Trimmed(Box<TrimmedPatch>),
    /// A bicubic Bézier patch (boxed).
    Bezier(Box<BezierPatch>),
}

impl Primitive {
    /// Bounding box.
    pub fn aabb(&self) -> Aabb {
        match self {
            Primitive::Triangle(t) => t.aabb(),
            Primitive::Parallelogram(p) => p.aabb(),
            Primitive::Polygon(p) => p.aabb(),
            Primitive::Trimmed(p) => p.aabb(),
            Primitive::Bezier(b) => b.aabb(),
        }
    }

    /// Area. Exact for planar primitives and equal-area trimmed patches; natural-map
    /// trimmed patches use [`TrimmedPatch::area`]; Bézier patches integrate
    /// `|∂u × ∂v|` with a 24×24 Gauss–Legendre rule (smooth integrand; ~1e-12 relative
    /// for well-shaped nets).
    pub fn area(&self) -> f64 {
        match self {
            Primitive::Triangle(t) => t.area(),
            Primitive::Parallelogram(p) => p.area(),
            Primitive::Polygon(p) => p.area(),
            Primitive::Trimmed(p) => p.area(),
            Primitive::Bezier(b) => b.area(),
        }
    }

    /// Unit front normal at `uv` of the support.
    pub fn normal(&self, uv: DVec2) -> DVec3 {
        match self {
            Primitive::Triangle(t) => t.normal(),
            Primitive::Parallelogram(p) => p.normal(),
            Primitive::Polygon(p) => p.normal(),
            Primitive::Trimmed(p) => p.normal(uv),
            Primitive::Bezier(b) => b.normal(uv),
        }
    }

    /// Support map `[0,1]² → ℝ³` (see the module docs for each primitive's convention).
    pub fn eval(&self, uv: DVec2) -> DVec3 {
        match self {
            Primitive::Triangle(t) => t.eval(uv),
            Primitive::Parallelogram(p) => p.eval(uv),
            Primitive::Polygon(p) => p.eval(uv),
            Primitive::Trimmed(p) => p.eval(uv),
            Primitive::Bezier(b) => b.eval(uv),
        }
    }
}

impl From<Triangle> for Primitive {
    fn from(t: Triangle) -> Self {
        Primitive::Triangle(t)
    }
}
impl From<Parallelogram> for Primitive {
    fn from(p: Parallelogram) -> Self {
        Primitive::Parallelogram(p)
    }
}
impl From<ComplexPolygon> for Primitive {
    fn from(p: ComplexPolygon) -> Self {
        Primitive::Polygon(Box::new(p))
    }
}
impl From<TrimmedPatch> for Primitive {
    fn from(p: TrimmedPatch) -> Self {
        Primitive::Trimmed(Box::new(p))
    }
}
impl From<BezierPatch> for Primitive {
    fn from(p: BezierPatch) -> Self {
        Primitive::Bezier(Box::new(p))
    }
}
