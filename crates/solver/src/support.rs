//! Unit-square supports of the surfaces and the patches (one per lit side of a
//! support) that carry the element hierarchies.
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
//! exact near-field rules of [`crate::transfer`] apply) and a single virtual support
//! would not be simpler for them. Masked supports answer [`Support::is_real`],
//! [`Support::coverage`], [`Support::real_fraction`] and [`Support::nearest_real`]
//! exactly for trims made of segments and circular arcs (see [`crate::mask`]).

use std::sync::Arc;

use glam::{DVec2, DVec3};
use wavelux_geometry::{Edge2, TrimRegion};
use wavelux_param::mep::{BoundarySegment, min_enclosing_parallelogram_of_boundary};
use wavelux_param::{Parallelogram2, ParamKind, Parametrization, SurfaceShape};
use wavelux_quadrature::GaussLegendre;
use wavelux_scene::{AnalyticPatch, LoopEdge, MeshElement, Scene, SceneError, Shape, Sidedness};

use crate::error::SolverError;
pub use crate::mask::{Coverage, Mask};

/// The map of a support from the unit square `[0,1]²` to the surface.
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
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
    /// [`SolverError::InvalidScene`] if `Λ` is degenerate or the area is not finite
    /// and positive.
    pub fn mapped(
        param: Arc<dyn Parametrization>,
        origin: DVec2,
        e1: DVec2,
        e2: DVec2,
    ) -> Result<Self, SolverError> {
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
            let g = GaussLegendre::new(AREA_GAUSS).map_err(|e| SolverError::Dependency {
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
            return Err(SolverError::InvalidScene(format!(
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

/// Which side of a surface a patch is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Side {
    /// The front side (normal as the shape defines it).
    Front,
    /// The back side of a two-sided surface.
    Back,
}

/// One lit side of one support: the unit that carries an element quadtree.
#[derive(Debug, Clone, PartialEq)]
pub struct Patch {
    /// Index of the scene surface.
    pub surface: usize,
    /// Index of the piece within the surface (mesh element or polygon rectangle).
    pub piece: usize,
    /// Which side.
    pub side: Side,
    /// The support (normal of this side).
    pub support: Support,
    /// Diffuse reflectance per RGB channel, `0 ≤ ρ < 1`.
    pub reflectance: [f64; 3],
    /// Emitted exitance per RGB channel (W/m²).
    pub emission: [f64; 3],
    /// Primitive id of the support in the visibility accelerator.
    pub prim: u32,
}

impl Patch {
    /// Whether the patch can receive (reflects in some channel).
    pub fn reflects(&self) -> bool {
        self.reflectance.iter().any(|&r| r > 0.0)
    }

    /// Whether the patch can ever be bright (emits or reflects).
    pub fn can_emit(&self) -> bool {
        self.reflects() || self.emission.iter().any(|&e| e > 0.0)
    }
}

/// Patches and geometric primitives of a scene.
#[derive(Debug, Clone)]
pub struct PatchSet {
    /// The patches.
    pub patches: Vec<Patch>,
    /// One support per geometric piece (front orientation), indexed by [`Patch::prim`].
    pub pieces: Vec<Support>,
    /// For each surface, the indices of its patches.
    pub by_surface: Vec<Vec<usize>>,
}

/// Relative tolerance of the rectilinearity test of polygon edges.
const RECT_TOL: f64 = 1e-9;

fn unsupported(scene: &Scene, i: usize, kind: &str) -> SolverError {
    SolverError::UnsupportedSurface {
        surface: scene.surfaces[i].name.clone(),
        kind: kind.to_string(),
    }
}

/// Supports of a planar polygon: a disk (one full circle, no holes), the exact
/// rectangles of a rectilinear polygon, or else one virtual support — the minimal
/// enclosing parallelogram with the polygon as mask (VirtualMesh §3.2).
fn polygon_pieces(
    scene: &Scene,
    i: usize,
    poly: &wavelux_scene::PolygonShape,
) -> Result<Vec<Support>, SolverError> {
    if let ([], [LoopEdge::Arc { start, center, .. }]) =
        (poly.holes.as_slice(), poly.outer.edges.as_slice())
    {
        let radius = (*start - *center).length();
        let c = poly.frame.point(*center);
        return Ok(vec![Support::disk(c, poly.frame.u, poly.frame.v, radius)]);
    }
    if let Some(v) = rectilinear_pieces(scene, i, poly)? {
        return Ok(v);
    }
    Ok(vec![masked_polygon(scene, i, poly)?])
}

fn scene_err(e: SceneError) -> SolverError {
    SolverError::InvalidScene(e.to_string())
}

fn geometry_err(e: wavelux_geometry::GeometryError) -> SolverError {
    SolverError::InvalidScene(e.to_string())
}

fn param_err(e: wavelux_param::ParamError) -> SolverError {
    SolverError::InvalidScene(e.to_string())
}

/// The trim region of an outer loop and holes (outer counter-clockwise, holes
/// clockwise).
fn region_of(
    scene: &Scene,
    i: usize,
    outer: &wavelux_scene::Loop,
    holes: &[wavelux_scene::Loop],
) -> Result<TrimRegion, SolverError> {
    let name = &scene.surfaces[i].name;
    let mut loops = vec![outer.to_trim_loop(true, "scene", name).map_err(scene_err)?];
    for h in holes {
        loops.push(h.to_trim_loop(false, "scene", name).map_err(scene_err)?);
    }
    TrimRegion::new(loops).map_err(geometry_err)
}

/// Minimal enclosing parallelogram of a region's outer loops (arcs circumscribed to
/// `1e-4` of the region size: the support only needs to enclose).
fn enclosing_parallelogram(region: &TrimRegion) -> Result<Parallelogram2, SolverError> {
    let (lo, hi) = region.bounds();
    let size = (hi - lo).length();
    let segs: Vec<BoundarySegment> = region
        .loops
        .iter()
        .filter(|l| l.signed_area() > 0.0)
        .flat_map(|l| l.edges.iter())
        .map(|e| match *e {
            Edge2::Segment { a, b } => BoundarySegment::Line { from: a, to: b },
            Edge2::Arc {
                center,
                radius,
                start,
                sweep,
            } => BoundarySegment::Arc {
                centre: center,
                radius,
                start,
                sweep,
            },
        })
        .collect();
    min_enclosing_parallelogram_of_boundary(&segs, 1e-4 * size).map_err(param_err)
}

/// The virtual support of a general planar polygon (arcs, oblique edges, holes).
fn masked_polygon(
    scene: &Scene,
    i: usize,
    poly: &wavelux_scene::PolygonShape,
) -> Result<Support, SolverError> {
    let region = region_of(scene, i, &poly.outer, &poly.holes)?;
    let par = enclosing_parallelogram(&region)?;
    let f = &poly.frame;
    let o = f.point(par.origin);
    let eu = f.point(par.origin + par.e1) - o;
    let ev = f.point(par.origin + par.e2) - o;
    let mut s = Support::parallelogram(o, eu, ev);
    if s.normal.dot(f.normal()) < 0.0 {
        s = Support::parallelogram(o, ev, eu);
        let mask = Mask::new(region, par.origin, par.e2, par.e1)?;
        return Ok(s.with_mask(mask));
    }
    let mask = Mask::new(region, par.origin, par.e1, par.e2)?;
    Ok(s.with_mask(mask))
}

/// The same surface map with the requested parametrization kind.
fn with_kind(p: Arc<dyn Parametrization>, kind: ParamKind) -> Arc<dyn Parametrization> {
    if p.kind() == kind {
        return p;
    }
    match p.shape() {
        SurfaceShape::Cylinder(x) => Arc::new(x.with_kind(kind)),
        SurfaceShape::Cone(x) => Arc::new(x.with_kind(kind)),
        SurfaceShape::Sphere(x) => Arc::new(x.with_kind(kind)),
        SurfaceShape::Spheroid(x) => Arc::new(x.with_kind(kind)),
        SurfaceShape::Torus(x) => Arc::new(x.with_kind(kind)),
        SurfaceShape::Revolution(x) => Arc::new(x.with_kind(kind)),
        SurfaceShape::GeneralizedCylinder(x) => Arc::new(x.with_kind(kind)),
        SurfaceShape::TangentDevelopable(x) => Arc::new(x.with_kind(kind)),
        SurfaceShape::BezierPatch(x) => Arc::new(x.with_kind(kind)),
        _ => p,
    }
}

/// Relative tolerance for an enclosing parallelogram to count as inside `[0,1]²`.
const SQUARE_TOL: f64 = 1e-9;

/// The parallelogram of a trim region inside the unit parameter square: the minimal
/// enclosing parallelogram when it stays inside `[0,1]²` (Ψ need not extend beyond
/// it, e.g. a sphere past its poles), else the region's bounding box.
fn trim_parallelogram(region: &TrimRegion) -> Result<Parallelogram2, SolverError> {
    if let Ok(p) = enclosing_parallelogram(region) {
        let inside = p.corners().iter().all(|c| {
            c.x >= -SQUARE_TOL
                && c.y >= -SQUARE_TOL
                && c.x <= 1.0 + SQUARE_TOL
                && c.y <= 1.0 + SQUARE_TOL
        });
        if inside {
            return Ok(p);
        }
    }
    let (lo, hi) = region.bounds();
    let lo = lo.clamp(DVec2::ZERO, DVec2::ONE);
    let hi = hi.clamp(DVec2::ZERO, DVec2::ONE);
    if !(hi.x > lo.x && hi.y > lo.y) {
        return Err(SolverError::InvalidScene(
            "trim region outside the unit parameter square".into(),
        ));
    }
    Ok(Parallelogram2 {
        origin: lo,
        e1: DVec2::new(hi.x - lo.x, 0.0),
        e2: DVec2::new(0.0, hi.y - lo.y),
    })
}

/// Largest chordal deviation (in the unit parameter square) of a remapped trim loop
/// from the exact image of the original loop (see [`remap_region`]).
const REMAP_TOL: f64 = 1e-7;
/// Deepest bisection of one trim edge in [`remap_region`] (`2^24` pieces at most).
const REMAP_DEPTH: u32 = 24;

/// The point of `to`'s square with the same 3-D position as `from(uv)`: `to`'s
/// inverse, or among the equivalent parameters (periodic shifts by ±1, a pole's free
/// coordinate) the one nearest to `uv`. `None` where `to` has no inverse.
fn remap_point(uv: DVec2, from: &dyn Parametrization, to: &dyn Parametrization) -> Option<DVec2> {
    let p = from.position(uv);
    let res = to.inverse(p)?;
    if !res.is_finite() {
        return None;
    }
    let b = to.bounds();
    let tol = 1e-9 * (b.max - b.min).length().max(1e-300);
    let err = |c: DVec2| (to.position(c) - p).length();
    let ok = err(res).max(tol);
    let mut best = res;
    let mut cands = vec![DVec2::new(uv.x, res.y), DVec2::new(res.x, uv.y)];
    for kx in -1..=1 {
        for ky in -1..=1 {
            cands.push(res + DVec2::new(kx as f64, ky as f64));
        }
    }
    for c in cands {
        if (c - uv).length() < (best - uv).length() && err(c) <= ok {
            best = c;
        }
    }
    Some(best)
}

/// The image of `region` (in `from`'s unit square) in `to`'s unit square, for two
/// maps of the same surface: every edge (segment or arc) is mapped point-wise by
/// [`remap_point`] and replaced by a polyline, bisected until each piece's midpoint
/// lies within [`REMAP_TOL`] of its chord (at least 4 pieces per edge). `None` if a
/// point has no preimage, or the map reverses a loop's orientation.
fn remap_region(
    region: &TrimRegion,
    from: &dyn Parametrization,
    to: &dyn Parametrization,
) -> Option<TrimRegion> {
    fn bisect(
        f: &dyn Fn(f64) -> Option<DVec2>,
        (s0, p0): (f64, DVec2),
        (s1, p1): (f64, DVec2),
        depth: u32,
        out: &mut Vec<DVec2>,
    ) -> Option<()> {
        let sm = 0.5 * (s0 + s1);
        let pm = f(sm)?;
        let d = p1 - p0;
        let len = d.length();
        let dev = if len > 0.0 {
            (pm - p0).perp_dot(d).abs() / len
        } else {
            (pm - p0).length()
        };
        if dev > REMAP_TOL && depth < REMAP_DEPTH {
            bisect(f, (s0, p0), (sm, pm), depth + 1, out)?;
            bisect(f, (sm, pm), (s1, p1), depth + 1, out)?;
        } else {
            out.push(p1);
        }
        Some(())
    }
    let mut loops = Vec::with_capacity(region.loops.len());
    for l in &region.loops {
        let mut pts: Vec<DVec2> = Vec::new();
        for e in &l.edges {
            let f = |s: f64| remap_point(e.point(s), from, to);
            let mut prev = (0.0, f(0.0)?);
            for k in 1..=4 {
                let s = k as f64 / 4.0;
                let next = (s, f(s)?);
                bisect(&f, prev, next, 0, &mut pts)?;
                prev = next;
            }
        }
        pts.dedup_by(|a, b| (*a - *b).length() <= 1e-15);
        while pts.len() > 1 && (pts[0] - pts[pts.len() - 1]).length() <= 1e-15 {
            pts.pop();
        }
        if pts.len() < 3 {
            return None;
        }
        let edges: Vec<Edge2> = (0..pts.len())
            .map(|k| Edge2::Segment {
                a: pts[k],
                b: pts[(k + 1) % pts.len()],
            })
            .collect();
        let mapped = wavelux_geometry::TrimLoop::new(edges).ok()?;
        if (mapped.signed_area() > 0.0) != (l.signed_area() > 0.0) {
            return None;
        }
        loops.push(mapped);
    }
    TrimRegion::new(loops).ok()
}

/// `∫_R J(u, v) du dv` of a map's Jacobian over a region of its unit square, by
/// Green's theorem `∮ F dv`, `F(u, v) = ∫_0^u J(x, v) dx` (16-point Gauss), with an
/// 8-point Gauss rule on pieces of each boundary edge no longer than 1/16.
fn jacobian_integral(param: &dyn Parametrization, region: &TrimRegion) -> f64 {
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

/// The support of an analytic patch: Ψ composed with the parallelogram enclosing its
/// trim (identity when untrimmed), masked by the trim.
fn patch_support(
    scene: &Scene,
    i: usize,
    p: &AnalyticPatch,
    kind: ParamKind,
) -> Result<Support, SolverError> {
    let name = &scene.surfaces[i].name;
    let psi = with_kind(
        p.surface
            .parametrization("scene", name)
            .map_err(scene_err)?,
        kind,
    );
    match &p.trim {
        None => Support::mapped(psi, DVec2::ZERO, DVec2::X, DVec2::Y),
        Some(r) => {
            let mut region = region_of(scene, i, &r.outer, &r.holes)?;
            if !psi.is_equal_area() {
                // Trims live in the equal-area square: carry them over to Ψ's square.
                let ea = with_kind(psi.clone(), ParamKind::EqualArea);
                region = remap_region(&region, ea.as_ref(), psi.as_ref()).ok_or_else(|| {
                    unsupported(
                        scene,
                        i,
                        "trim loop with a point that has no natural-coordinate preimage",
                    )
                })?;
            }
            let par = trim_parallelogram(&region)?;
            let mask = Mask::new(region, par.origin, par.e1, par.e2)?;
            Ok(Support::mapped(psi, par.origin, par.e1, par.e2)?.with_mask(mask))
        }
    }
}

/// Splits a rectilinear polygon with holes (straight edges only) into rectangles in
/// the polygon's plane; returns parallelogram supports (front = polygon front), or
/// `None` if the polygon has arcs or oblique edges.
fn rectilinear_pieces(
    scene: &Scene,
    i: usize,
    poly: &wavelux_scene::PolygonShape,
) -> Result<Option<Vec<Support>>, SolverError> {
    let mut loops: Vec<Vec<DVec2>> = Vec::new();
    for l in std::iter::once(&poly.outer).chain(poly.holes.iter()) {
        let mut pts = Vec::new();
        for e in &l.edges {
            match e {
                LoopEdge::Segment { start } => pts.push(*start),
                _ => return Ok(None),
            }
        }
        if pts.len() < 3 {
            return Err(unsupported(
                scene,
                i,
                "polygon loop with fewer than 3 points",
            ));
        }
        loops.push(pts);
    }
    let dir = loops[0][1] - loops[0][0];
    let len = dir.length();
    if len.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return Err(unsupported(scene, i, "degenerate polygon edge"));
    }
    let a = dir / len;
    let b = DVec2::new(-a.y, a.x);
    let rot = |p: DVec2| DVec2::new(p.dot(a), p.dot(b));
    let rl: Vec<Vec<DVec2>> = loops
        .iter()
        .map(|l| l.iter().map(|p| rot(*p)).collect())
        .collect();
    let mut scale: f64 = 0.0;
    for l in &rl {
        for p in l {
            scale = scale.max(p.abs().max_element());
        }
    }
    let tol = RECT_TOL * scale.max(f64::MIN_POSITIVE);
    let mut xs = Vec::new();
    let mut ys = Vec::new();
    for l in &rl {
        for k in 0..l.len() {
            let p = l[k];
            let q = l[(k + 1) % l.len()];
            let d = q - p;
            if d.x.abs() > tol && d.y.abs() > tol {
                return Ok(None);
            }
            xs.push(p.x);
            ys.push(p.y);
        }
    }
    let dedup = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v.dedup_by(|x, y| (*x - *y).abs() <= tol);
    };
    dedup(&mut xs);
    dedup(&mut ys);
    let inside = |p: DVec2| {
        let mut c = false;
        for l in &rl {
            for k in 0..l.len() {
                let u = l[k];
                let w = l[(k + 1) % l.len()];
                if (u.y > p.y) != (w.y > p.y) {
                    let x = u.x + (p.y - u.y) / (w.y - u.y) * (w.x - u.x);
                    if p.x < x {
                        c = !c;
                    }
                }
            }
        }
        c
    };
    let inv = |p: DVec2| a * p.x + b * p.y;
    let mut out = Vec::new();
    for jy in 0..ys.len().saturating_sub(1) {
        let (y0, y1) = (ys[jy], ys[jy + 1]);
        let mut jx = 0;
        while jx + 1 < xs.len() {
            let c = DVec2::new(0.5 * (xs[jx] + xs[jx + 1]), 0.5 * (y0 + y1));
            if !inside(c) {
                jx += 1;
                continue;
            }
            let start = jx;
            while jx + 1 < xs.len()
                && inside(DVec2::new(0.5 * (xs[jx] + xs[jx + 1]), 0.5 * (y0 + y1)))
            {
                jx += 1;
            }
            let (x0, x1) = (xs[start], xs[jx]);
            let o = poly.frame.point(inv(DVec2::new(x0, y0)));
            let pu = poly.frame.point(inv(DVec2::new(x1, y0)));
            let pv = poly.frame.point(inv(DVec2::new(x0, y1)));
            let mut s = Support::parallelogram(o, pu - o, pv - o);
            // Keep the polygon's front side.
            if s.normal.dot(poly.frame.normal()) < 0.0 {
                s = Support::parallelogram(o, pv - o, pu - o);
            }
            out.push(s);
        }
    }
    if out.is_empty() {
        return Err(unsupported(scene, i, "polygon with empty interior"));
    }
    Ok(Some(out))
}

fn shape_pieces(scene: &Scene, i: usize, kind: ParamKind) -> Result<Vec<Support>, SolverError> {
    let shape = &scene.surfaces[i].shape;
    let mut out = Vec::new();
    match shape {
        Shape::Parallelogram {
            origin,
            edge_u,
            edge_v,
        } => out.push(Support::parallelogram(*origin, *edge_u, *edge_v)),
        Shape::Triangle([a, b, c]) => out.push(Support::triangle(*a, *b, *c)),
        Shape::Mesh(m) => {
            for e in m.elements() {
                match e {
                    MeshElement::Parallelogram {
                        origin,
                        edge_u,
                        edge_v,
                    } => out.push(Support::parallelogram(origin, edge_u, edge_v)),
                    MeshElement::Triangle([a, b, c]) => out.push(Support::triangle(a, b, c)),
                }
            }
        }
        Shape::Polygon(p) => out.extend(polygon_pieces(scene, i, p)?),
        Shape::Bezier(b) => {
            let name = &scene.surfaces[i].name;
            shape.validate("scene", name).map_err(scene_err)?;
            let psi = wavelux_param::BezierPatch::new(b.bicubic()).map_err(param_err)?;
            let psi: Arc<dyn Parametrization> = Arc::new(psi.with_kind(kind));
            out.push(Support::mapped(psi, DVec2::ZERO, DVec2::X, DVec2::Y)?);
        }
        Shape::Patch(p) => out.push(patch_support(scene, i, p, kind)?),
        #[allow(unreachable_patterns)]
        _ => return Err(unsupported(scene, i, "unknown shape kind")),
    }
    for s in &out {
        if !(s.area.is_finite() && s.area > 0.0) {
            return Err(SolverError::InvalidScene(format!(
                "surface {:?} has a degenerate or non-finite piece (area {})",
                scene.surfaces[i].name, s.area
            )));
        }
    }
    Ok(out)
}

fn material_values(
    scene: &Scene,
    id: usize,
    what: &str,
) -> Result<([f64; 3], [f64; 3]), SolverError> {
    let m = scene.materials.get(id).ok_or_else(|| {
        SolverError::InvalidScene(format!("{what}: material id {id} out of range"))
    })?;
    let mut rho = m.reflectance.0;
    let mut e = m.emission.0;
    if let Some(tex) = m
        .reflectance_texture
        .and_then(|t| scene.textures.get(t.texture))
    {
        let t = tex.mean().0;
        rho = std::array::from_fn(|c| rho[c] * t[c]);
    }
    if let Some(tex) = m
        .emission_texture
        .and_then(|t| scene.textures.get(t.texture))
    {
        let t = tex.mean().0;
        e = std::array::from_fn(|c| e[c] * t[c]);
    }
    for c in 0..3 {
        if !(rho[c].is_finite() && (0.0..1.0).contains(&rho[c])) {
            return Err(SolverError::InvalidScene(format!(
                "{what}: reflectance {} outside [0, 1)",
                rho[c]
            )));
        }
        if !(e[c].is_finite() && e[c] >= 0.0) {
            return Err(SolverError::InvalidScene(format!(
                "{what}: emission {} not finite and >= 0",
                e[c]
            )));
        }
    }
    Ok((rho, e))
}

/// Builds the patches of a scene with equal-area supports
/// (`build_patches_with(scene, ParamKind::EqualArea)`).
///
/// # Errors
/// As [`build_patches_with`].
pub fn build_patches(scene: &Scene) -> Result<PatchSet, SolverError> {
    build_patches_with(scene, ParamKind::EqualArea)
}

/// Builds the patches of a scene: every surface is split into supports; every
/// support gets one patch for the front side and, for two-sided surfaces, one for the
/// back side (flipped normal, back material). Textured materials use the texture
/// mean (this solver has constant reflectance and emission per support).
///
/// Supports: parallelograms, triangles and mesh elements as they are; a polygon that
/// is one full circle → a disk; a rectilinear polygon → its exact rectangles; any
/// other polygon → its minimal enclosing parallelogram masked by the polygon; an
/// analytic patch → its `wavelux-param` map (`kind`) composed with the parallelogram
/// enclosing its trim, masked by the trim; a Bézier patch → its map. `kind` only
/// changes curved maps (planar maps are equal-area either way); the trims of a patch
/// are given in the equal-area square and, for a natural map with a varying
/// Jacobian, carried over to its square as polylines (chordal deviation ≤ 1e-7, see
/// `remap_region`).
///
/// # Errors
/// [`SolverError::UnsupportedSurface`] for a trimmed patch whose trim has a point
/// without a natural-coordinate preimage (with `ParamKind::Natural`),
/// [`SolverError::InvalidScene`] for bad materials or degenerate pieces.
pub fn build_patches_with(scene: &Scene, kind: ParamKind) -> Result<PatchSet, SolverError> {
    let mut patches = Vec::new();
    let mut pieces = Vec::new();
    let mut by_surface = Vec::with_capacity(scene.surfaces.len());
    for (i, surf) in scene.surfaces.iter().enumerate() {
        let what = format!("surface {:?}", surf.name);
        let front = material_values(scene, surf.material, &what)?;
        let back = match surf.sides {
            Sidedness::TwoSided { back } => Some(material_values(scene, back, &what)?),
            _ => None,
        };
        let mut ids = Vec::new();
        for (j, s) in shape_pieces(scene, i, kind)?.into_iter().enumerate() {
            let prim = pieces.len() as u32;
            pieces.push(s.clone());
            ids.push(patches.len());
            patches.push(Patch {
                surface: i,
                piece: j,
                side: Side::Front,
                support: s.clone(),
                reflectance: front.0,
                emission: front.1,
                prim,
            });
            if let Some((rho, e)) = back {
                ids.push(patches.len());
                patches.push(Patch {
                    surface: i,
                    piece: j,
                    side: Side::Back,
                    support: s.flipped(),
                    reflectance: rho,
                    emission: e,
                    prim,
                });
            }
        }
        by_surface.push(ids);
    }
    Ok(PatchSet {
        patches,
        pieces,
        by_surface,
    })
}
