//! Unit-square supports of surfaces: the maps, their areas and trim masks.
//!
//! Ziegler §3.3.1 puts a separate MRA on each surface `S_i`; its basis is made
//! orthonormal in `L²(S_i)` by the factor `1/√|S_i|`, which is exact when the map from
//! the unit square has a constant Jacobian (an *equal-area* map). This module builds
//! such maps:
//!
//! - parallelograms: `χ(s,t) = o + s·e_u + t·e_v` (affine);
//! - triangles: `χ(s,t) = a + √s·((1−t)(b−a) + t(c−a))`, the equal-area square →
//!   triangle map (Jacobian `2·area·½ = area`, constant; it collapses `s = 0` onto
//!   the vertex `a`);
//! - disks (a polygon whose outer loop is one full circle): Shirley–Chiu's
//!   concentric map (equal-area);
//! - complex polygons made of straight edges that are *rectilinear* (every edge
//!   parallel or perpendicular to the first one), e.g. a ceiling with a rectangular
//!   hole for a light: decomposed exactly into rectangles, one support each;
//! - every other planar polygon (circular arcs, oblique edges, holes): one *virtual
//!   support* (VirtualMesh §3.2–§3.3) — its minimal enclosing parallelogram
//!   (`wavelux_param::mep`) with the polygon as [`Mask`];
//! - analytic patches (sphere, spheroid, cylinder, cone, torus) and Bézier patches:
//!   [`SupportMap::Mapped`], the `wavelux-param` map Ψ (equal-area, VirtualMesh §3.1 and
//!   Appendix A, or natural for the Table 3 comparison) composed with the affine Λ onto
//!   the parallelogram enclosing the trim region in Ψ's unit square (identity when
//!   untrimmed), masked by the trim.
//!
//! The exact decompositions are kept where they exist (rectangles, disks, triangles):
//! they have no virtual points, their pieces are affine or planar (the singular and
//! exact near-field rules of `wavelux-solver`'s transfer module apply) and a single virtual support
//! would not be simpler for them. Masked supports answer [`Support::is_real`],
//! [`Support::coverage`], [`Support::real_fraction`] and [`Support::nearest_real`]
//! exactly for trims made of segments and circular arcs (see [`crate::mask`]).

use std::sync::Arc;

use glam::{DVec2, DVec3};
use wavelux_geometry::{Edge2, TrimRegion};
use wavelux_param::Parametrization;
use wavelux_quadrature::GaussLegendre;

use crate::error::SupportError;
use crate::mask::{Coverage, Mask};

/// The map of a support from the unit square `[0,1]²` to the surface.
///
/// Deliberately exhaustive: every method crate that evaluates supports must handle
/// every kind, so a new kind is a compile error there rather than a silent fallback.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SupportMap {
    /// `o + s·e_u + t·e_v`.
    Parallelogram {
        /// Corner `χ(0,0)`.
        origin: DVec3,
        /// `χ(1,0) − χ(0,0)`.
        edge_u: DVec3,
        /// `χ(0,1) − χ(0,0)`.
        edge_v: DVec3,
    },
    /// `a + √s·((1−t)(b−a) + t(c−a))` (equal-area).
    Triangle {
        /// Apex (image of the edge `s = 0`).
        a: DVec3,
        /// Image of `(1, 0)`.
        b: DVec3,
        /// Image of `(1, 1)`.
        c: DVec3,
    },
    /// Shirley–Chiu concentric map of the square onto the disk
    /// `centre + r(cos φ · u + sin φ · v)`, `r ≤ radius` (equal-area, continuous,
    /// piecewise smooth: not affine).
    Disk {
        /// Centre.
        center: DVec3,
        /// First in-plane unit axis.
        u: DVec3,
        /// Second in-plane unit axis (`u × v` is the front normal).
        v: DVec3,
        /// Radius.
        radius: f64,
    },
    /// A curved surface `Ψ(Λ(s,t))` (VirtualMesh §3, Fig. 3): `Λ(s,t) = origin +
    /// s·e1 + t·e2` maps the support square onto a parallelogram of the unit parameter
    /// square of the `wavelux-param` map `Ψ` held in [`Support::param`] (identity for
    /// untrimmed patches; the parallelogram enclosing the trim region otherwise).
    Mapped {
        /// `Λ(0,0)` in Ψ's parameter square.
        origin: DVec2,
        /// `Λ(1,0) − Λ(0,0)`.
        e1: DVec2,
        /// `Λ(0,1) − Λ(0,0)`.
        e2: DVec2,
    },
}

/// A unit-square support: a map onto the surface (equal-area for every kind except
/// natural-coordinate curved maps), its area and, for virtual supports, the trim mask
/// that tells real points from virtual ones (VirtualMesh §4).
#[derive(Debug, Clone)]
pub struct Support {
    /// The map.
    pub map: SupportMap,
    /// Unit normal of the side this support is lit on: constant for planar maps; for
    /// curved maps the normal at the centre `(½, ½)` (use [`Support::normal_at`]).
    pub normal: DVec3,
    /// Area of the whole support's image (m² in scene units), real and virtual
    /// points together: the `L²` normalisation of the basis. See
    /// [`Support::real_area`] for the surface's own area.
    pub area: f64,
    /// Trim mask of a virtual support (`None`: every point is real).
    pub mask: Option<Arc<Mask>>,
    /// The surface map `Ψ` of a [`SupportMap::Mapped`] support.
    pub param: Option<Arc<dyn Parametrization>>,
    /// `+1` for the front side, `−1` for a flipped (back) side.
    orientation: f64,
    /// Area of the real surface (see [`Support::real_area`]).
    real: f64,
}

impl PartialEq for Support {
    fn eq(&self, o: &Self) -> bool {
        self.map == o.map
            && self.normal == o.normal
            && self.area == o.area
            && self.orientation == o.orientation
            && match (&self.mask, &o.mask) {
                (None, None) => true,
                (Some(a), Some(b)) => a == b,
                _ => false,
            }
            && match (&self.param, &o.param) {
                (None, None) => true,
                (Some(a), Some(b)) => Arc::ptr_eq(a, b),
                _ => false,
            }
    }
}

/// Gauss points per axis of the numerical area of non-equal-area mapped supports.
const AREA_GAUSS: usize = 16;

impl Support {
    fn planar(map: SupportMap, normal: DVec3, area: f64) -> Self {
        Self {
            map,
            normal,
            area,
            mask: None,
            param: None,
            orientation: 1.0,
            real: area,
        }
    }

    /// A parallelogram support with the normal `edge_u × edge_v`.
    pub fn parallelogram(origin: DVec3, edge_u: DVec3, edge_v: DVec3) -> Self {
        let n = edge_u.cross(edge_v);
        Self::planar(
            SupportMap::Parallelogram {
                origin,
                edge_u,
                edge_v,
            },
            n.normalize_or_zero(),
            n.length(),
        )
    }

    /// A triangle support with the normal `(b − a) × (c − a)`.
    pub fn triangle(a: DVec3, b: DVec3, c: DVec3) -> Self {
        let n = (b - a).cross(c - a);
        Self::planar(
            SupportMap::Triangle { a, b, c },
            n.normalize_or_zero(),
            0.5 * n.length(),
        )
    }

    /// A disk support (`u`, `v` orthonormal; normal `u × v`).
    pub fn disk(center: DVec3, u: DVec3, v: DVec3, radius: f64) -> Self {
        Self::planar(
            SupportMap::Disk {
                center,
                u,
                v,
                radius,
            },
            u.cross(v).normalize_or_zero(),
            std::f64::consts::PI * radius * radius,
        )
    }

    /// A curved support `Ψ(Λ(s,t))` with `Λ(s,t) = origin + s·e1 + t·e2` in Ψ's
    /// parameter square; front normal = Ψ's normal. The area is `Ψ.area()·|det Λ|`
    /// for equal-area maps, else a 16×16 Gauss rule of the Jacobian (smooth).
    ///
    /// # Errors
    /// [`SupportError::InvalidScene`] if `Λ` is degenerate or the area is not finite
    /// and positive.
    pub fn mapped(
        param: Arc<dyn Parametrization>,
        origin: DVec2,
        e1: DVec2,
        e2: DVec2,
    ) -> Result<Self, SupportError> {
        let det = e1.perp_dot(e2).abs();
        let mut s = Self {
            map: SupportMap::Mapped { origin, e1, e2 },
            normal: DVec3::ZERO,
            area: 0.0,
            mask: None,
            param: Some(param.clone()),
            orientation: 1.0,
            real: 0.0,
        };
        s.area = if param.is_equal_area() {
            param.area() * det
        } else {
            let g = GaussLegendre::new(AREA_GAUSS).map_err(|e| SupportError::Dependency {
                what: "quadrature",
                message: e.to_string(),
            })?;
            let (x, w) = g.unit();
            let mut a = 0.0;
            for j in 0..AREA_GAUSS {
                for i in 0..AREA_GAUSS {
                    a += w[i] * w[j] * s.jacobian(x[i], x[j]);
                }
            }
            a
        };
        if !(s.area.is_finite() && s.area > 0.0) {
            return Err(SupportError::InvalidScene(format!(
                "curved support with area {}",
                s.area
            )));
        }
        s.normal = s.normal_at(0.5, 0.5);
        s.real = s.area;
        Ok(s)
    }

    /// The same support with a trim mask (a virtual support, VirtualMesh §4). For a
    /// curved map with a varying Jacobian the real area is `∫_R J` over the mask's
    /// region `R` (Green's theorem on its boundary); else
    /// `area ×` the real parameter fraction.
    #[must_use]
    pub fn with_mask(mut self, mask: Mask) -> Self {
        self.real = match (&self.param, self.is_equal_area()) {
            (Some(p), false) => jacobian_integral(p.as_ref(), mask.region()),
            _ => self.area * mask.total_fraction(),
        };
        self.mask = Some(Arc::new(mask));
        self
    }

    /// The same support seen from its back side (normal flipped, same map).
    pub fn flipped(&self) -> Self {
        let mut s = self.clone();
        s.normal = -s.normal;
        s.orientation = -s.orientation;
        s
    }

    /// `Λ(s, t)` of a mapped support.
    #[inline]
    fn lambda(&self, s: f64, t: f64) -> DVec2 {
        match self.map {
            SupportMap::Mapped { origin, e1, e2 } => origin + s * e1 + t * e2,
            _ => DVec2::new(s, t),
        }
    }

    /// `χ(s, t)`.
    #[inline]
    pub fn point(&self, s: f64, t: f64) -> DVec3 {
        match self.map {
            SupportMap::Parallelogram {
                origin,
                edge_u,
                edge_v,
            } => origin + s * edge_u + t * edge_v,
            SupportMap::Triangle { a, b, c } => {
                let r = s.max(0.0).sqrt();
                a + r * ((1.0 - t) * (b - a) + t * (c - a))
            }
            SupportMap::Disk {
                center,
                u,
                v,
                radius,
            } => {
                let (x, y) = (2.0 * s - 1.0, 2.0 * t - 1.0);
                let q = std::f64::consts::FRAC_PI_4;
                let (r, phi) = if x == 0.0 && y == 0.0 {
                    (0.0, 0.0)
                } else if x.abs() > y.abs() {
                    (x, q * (y / x))
                } else {
                    (y, 2.0 * q - q * (x / y))
                };
                center + radius * r * (phi.cos() * u + phi.sin() * v)
            }
            SupportMap::Mapped { .. } => match &self.param {
                Some(p) => p.position(self.lambda(s, t)),
                None => DVec3::splat(f64::NAN),
            },
        }
    }

    /// `(χ(s, t), normal_at(s, t))` with one evaluation of a curved map.
    #[inline]
    pub fn point_normal(&self, s: f64, t: f64) -> (DVec3, DVec3) {
        match (&self.map, &self.param) {
            (SupportMap::Mapped { .. }, Some(p)) => {
                let e = p.eval(self.lambda(s, t));
                (e.position, self.orientation * e.normal)
            }
            _ => (self.point(s, t), self.normal),
        }
    }

    /// Unit normal of this side at `(s, t)`: constant for planar maps, `±Ψ`'s normal
    /// for curved maps (flipped for back sides).
    #[inline]
    pub fn normal_at(&self, s: f64, t: f64) -> DVec3 {
        match (&self.map, &self.param) {
            (SupportMap::Mapped { .. }, Some(p)) => self.orientation * p.normal(self.lambda(s, t)),
            _ => self.normal,
        }
    }

    /// Area element at `(s, t)` (world area per unit parameter area): `area` for
    /// equal-area maps, `Ψ.jacobian(Λ(s,t))·|det Λ|` for curved maps.
    #[inline]
    pub fn jacobian(&self, s: f64, t: f64) -> f64 {
        match (&self.map, &self.param) {
            (SupportMap::Mapped { e1, e2, .. }, Some(p)) => {
                if p.is_equal_area() {
                    self.area
                } else {
                    p.jacobian(self.lambda(s, t)) * e1.perp_dot(*e2).abs()
                }
            }
            _ => self.area,
        }
    }

    /// Whether the map has a constant Jacobian (VirtualMesh §3: energy-preserving).
    pub fn is_equal_area(&self) -> bool {
        self.param.as_ref().is_none_or(|p| p.is_equal_area())
    }

    /// Whether the support is planar (every kind except [`SupportMap::Mapped`]).
    pub fn is_planar(&self) -> bool {
        !matches!(self.map, SupportMap::Mapped { .. })
    }

    /// Whether this side can send light to itself (VirtualMesh §5.3, self-shooting
    /// surfaces): never for planar supports; for curved ones, whether some pair of a
    /// 12×12 grid of real sample points faces each other (`n_x·(y−x) > 0` and
    /// `n_y·(x−y) > 0`). A concave island smaller than the grid spacing can be missed.
    pub fn sees_itself(&self) -> bool {
        if self.is_planar() {
            return false;
        }
        const K: usize = 12;
        let pts: Vec<(DVec3, DVec3)> = (0..K * K)
            .map(|i| ((i % K) as f64 + 0.5, (i / K) as f64 + 0.5))
            .map(|(a, b)| (a / K as f64, b / K as f64))
            .filter(|&(a, b)| self.is_real(a, b))
            .map(|(a, b)| (self.point(a, b), self.normal_at(a, b)))
            .collect();
        let (_, rad) = self.bounding_sphere(0.0, 0.0, 1.0);
        let tol = 1e-9 * rad;
        pts.iter().enumerate().any(|(i, (x, nx))| {
            pts[i + 1..]
                .iter()
                .any(|(y, ny)| nx.dot(*y - *x) > tol && ny.dot(*x - *y) > tol)
        })
    }

    /// Whether `(s, t)` is a real point of the surface (always for unmasked supports).
    #[inline]
    pub fn is_real(&self, s: f64, t: f64) -> bool {
        self.mask.as_ref().is_none_or(|m| m.is_real(s, t))
    }

    /// Coverage of the cell `[s0,s0+h]×[t0,t0+h]` by real points (VirtualMesh §5.4;
    /// exact classification, conservative: see [`crate::mask`]).
    pub fn coverage(&self, s0: f64, t0: f64, h: f64) -> Coverage {
        match &self.mask {
            None => Coverage::Full,
            Some(m) => m.coverage(s0, t0, h),
        }
    }

    /// Real fraction of the cell `[s0,s0+h]×[t0,t0+h]` in parameter measure (exact to
    /// rounding for trims of segments and circular arcs; equal to the real *area*
    /// fraction for equal-area maps).
    pub fn real_fraction(&self, s0: f64, t0: f64, h: f64) -> f64 {
        match &self.mask {
            None => 1.0,
            Some(m) => m.real_fraction(s0, t0, h),
        }
    }

    /// [`Support::real_fraction`] of the rectangle `[s0,s0+hs]×[t0,t0+ht]`.
    pub fn real_fraction_rect(&self, s0: f64, t0: f64, hs: f64, ht: f64) -> f64 {
        match &self.mask {
            None => 1.0,
            Some(m) => m.real_fraction_rect(s0, t0, hs, ht),
        }
    }

    /// The point the extended visibility ṽ uses for `(s, t)` (VirtualMesh §4.1): the
    /// image of [`Support::nearest_real`] (the point itself when real).
    #[inline]
    pub fn visibility_point(&self, s: f64, t: f64) -> DVec3 {
        if self.is_real(s, t) {
            self.point(s, t)
        } else {
            let (a, b) = self.nearest_real(s, t);
            self.point(a, b)
        }
    }

    /// Area of the real surface: `area ×` the real fraction of the whole support, or
    /// for a masked curved support with a varying Jacobian the Jacobian's integral over
    /// the real region (Gauss rules on the region's boundary, relative error ≲ 1e-12
    /// for smooth maps).
    pub fn real_area(&self) -> f64 {
        self.real
    }

    /// The nearest real point to `(s, t)`, as support parameters (`(s, t)` itself
    /// when real). Distances are measured in the mask plane: the polygon's plane for
    /// planar polygons (exact), the equal-area parameter square for curved patches.
    pub fn nearest_real(&self, s: f64, t: f64) -> (f64, f64) {
        match &self.mask {
            None => (s, t),
            Some(m) => m.nearest_real(s, t),
        }
    }

    /// Whether the map is affine (corners of sub-squares are exact and the singular
    /// rules of `wavelux-quadrature` apply to touching cells).
    pub fn is_affine(&self) -> bool {
        matches!(self.map, SupportMap::Parallelogram { .. })
    }

    /// Image of the sub-square `[s0, s0+h] × [t0, t0+h]`: corners in the order
    /// `(0,0), (1,0), (1,1), (0,1)` of the sub-square.
    pub fn corners(&self, s0: f64, t0: f64, h: f64) -> [DVec3; 4] {
        [
            self.point(s0, t0),
            self.point(s0 + h, t0),
            self.point(s0 + h, t0 + h),
            self.point(s0, t0 + h),
        ]
    }

    /// The exact planar polygon of the sub-square `[s0, s0+h] × [t0, t0+h]` of a
    /// parallelogram or triangle support (both maps send sub-squares to straight-edged
    /// quadrilaterals: on a triangle, `s = const` is a segment between the edges and
    /// `t = const` a ray from `a`), counter-clockwise about [`Support::normal`], with
    /// coincident corners (a triangle's collapsed vertex) merged. `None` for other
    /// maps or a degenerate image. The whole sub-square, virtual points included.
    pub fn cell_polygon(&self, s0: f64, t0: f64, h: f64) -> Option<Vec<DVec3>> {
        if !matches!(
            self.map,
            SupportMap::Parallelogram { .. } | SupportMap::Triangle { .. }
        ) {
            return None;
        }
        let (_, rad) = self.bounding_sphere(s0, t0, h);
        let tol = 1e-12 * rad.max(f64::MIN_POSITIVE);
        let mut poly: Vec<DVec3> = Vec::with_capacity(4);
        for v in self.corners(s0, t0, h) {
            if poly.last().is_none_or(|l| (*l - v).length() > tol) {
                poly.push(v);
            }
        }
        while poly.len() > 1 && (poly[0] - poly[poly.len() - 1]).length() <= tol {
            poly.pop();
        }
        if poly.len() < 3 {
            return None;
        }
        // Orientation from the polygon's Newell normal (taken about its first corner).
        if wavelux_geometry::formfactor::newell(&poly).dot(self.normal) < 0.0 {
            poly.reverse();
        }
        Some(poly)
    }

    /// A bounding sphere (centre, radius) of the image of a sub-square.
    pub fn bounding_sphere(&self, s0: f64, t0: f64, h: f64) -> (DVec3, f64) {
        match self.map {
            SupportMap::Parallelogram { .. } => {
                let c = self.corners(s0, t0, h);
                let m = 0.25 * (c[0] + c[1] + c[2] + c[3]);
                let r = c.iter().map(|p| (*p - m).length()).fold(0.0, f64::max);
                (m, r)
            }
            SupportMap::Triangle { .. } | SupportMap::Disk { .. } => {
                // The image is bounded by the images of the sub-square's corners and of
                // its s-extreme edges (curved in s only through √s, convex hull of the
                // corners and the mid-edge points is a safe over-estimate after padding).
                let pts = [
                    self.point(s0, t0),
                    self.point(s0 + h, t0),
                    self.point(s0 + h, t0 + h),
                    self.point(s0, t0 + h),
                    self.point(s0 + 0.5 * h, t0),
                    self.point(s0 + 0.5 * h, t0 + h),
                    self.point(s0, t0 + 0.5 * h),
                    self.point(s0 + h, t0 + 0.5 * h),
                ];
                let m = pts.iter().copied().sum::<DVec3>() / pts.len() as f64;
                let r = pts.iter().map(|p| (*p - m).length()).fold(0.0, f64::max);
                (m, 1.1 * r)
            }
            SupportMap::Mapped { .. } => {
                // A 3×3 grid of the smooth image, padded by a quarter for the sag
                // between samples.
                let mut pts = [DVec3::ZERO; 9];
                for (k, p) in pts.iter_mut().enumerate() {
                    *p = self.point(s0 + h * (k % 3) as f64 / 2.0, t0 + h * (k / 3) as f64 / 2.0);
                }
                let m = pts.iter().copied().sum::<DVec3>() / 9.0;
                let r = pts.iter().map(|p| (*p - m).length()).fold(0.0, f64::max);
                (m, 1.25 * r)
            }
        }
    }
}

/// `∫_R J(u, v) du dv` of a map's Jacobian over a region of its unit square, by
/// Green's theorem `∮ F dv`, `F(u, v) = ∫_0^u J(x, v) dx` (16-point Gauss), with an
/// 8-point Gauss rule on pieces of each boundary edge no longer than 1/16.
pub(crate) fn jacobian_integral(param: &dyn Parametrization, region: &TrimRegion) -> f64 {
    let (Ok(inner), Ok(outer)) = (GaussLegendre::new(16), GaussLegendre::new(8)) else {
        return f64::NAN;
    };
    let (xi, wi) = inner.unit();
    let (xo, wo) = outer.unit();
    let f = |p: DVec2| -> f64 {
        p.x * xi
            .iter()
            .zip(&wi)
            .map(|(&x, &w)| w * param.jacobian(DVec2::new(x * p.x, p.y)))
            .sum::<f64>()
    };
    let mut total = 0.0;
    for e in region.loops.iter().flat_map(|l| l.edges.iter()) {
        let len = match *e {
            Edge2::Segment { a, b } => (b - a).length(),
            Edge2::Arc { radius, sweep, .. } => radius * sweep.abs(),
        };
        let n = (len * 16.0).ceil().max(1.0) as usize;
        for k in 0..n {
            let (s0, h) = (k as f64 / n as f64, 1.0 / n as f64);
            for (&x, &w) in xo.iter().zip(&wo) {
                let s = s0 + h * x;
                let dv = match *e {
                    Edge2::Segment { a, b } => b.y - a.y,
                    Edge2::Arc {
                        radius,
                        start,
                        sweep,
                        ..
                    } => radius * sweep * (start + s * sweep).cos(),
                };
                total += w * h * f(e.point(s)) * dv;
            }
        }
    }
    total
}
