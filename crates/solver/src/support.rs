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
//!   hole for a light: decomposed exactly into rectangles, one support each.
//!
//! Other kinds (arcs, general polygons, trimmed patches, Bézier patches) need masked
//! supports — a bounding map plus the real area of each cell (VirtualMesh §4.2, §5) —
//! and are rejected with [`SolverError::UnsupportedSurface`]. The [`Support`] type
//! keeps a slot for that mask so the Virtual Mesh plugs in here.

use glam::{DVec2, DVec3};
use wavelux_scene::{LoopEdge, MeshElement, Scene, Shape, Sidedness};

use crate::error::SolverError;

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
}

/// A unit-square support: an equal-area map, its front normal and area, and an
/// optional per-cell real-area mask (reserved for the Virtual Mesh's masked
/// supports; `None` means the whole square is surface).
#[derive(Debug, Clone, PartialEq)]
pub struct Support {
    /// The map.
    pub map: SupportMap,
    /// Unit normal of the side this support is lit on.
    pub normal: DVec3,
    /// Area of the image (m² in scene units).
    pub area: f64,
    /// Reserved: real-area fraction per cell of a fixed grid (Virtual Mesh).
    pub mask: Option<Vec<f64>>,
}

impl Support {
    /// A parallelogram support with the normal `edge_u × edge_v`.
    pub fn parallelogram(origin: DVec3, edge_u: DVec3, edge_v: DVec3) -> Self {
        let n = edge_u.cross(edge_v);
        Self {
            map: SupportMap::Parallelogram {
                origin,
                edge_u,
                edge_v,
            },
            normal: n.normalize_or_zero(),
            area: n.length(),
            mask: None,
        }
    }

    /// A triangle support with the normal `(b − a) × (c − a)`.
    pub fn triangle(a: DVec3, b: DVec3, c: DVec3) -> Self {
        let n = (b - a).cross(c - a);
        Self {
            map: SupportMap::Triangle { a, b, c },
            normal: n.normalize_or_zero(),
            area: 0.5 * n.length(),
            mask: None,
        }
    }

    /// A disk support (`u`, `v` orthonormal; normal `u × v`).
    pub fn disk(center: DVec3, u: DVec3, v: DVec3, radius: f64) -> Self {
        Self {
            map: SupportMap::Disk {
                center,
                u,
                v,
                radius,
            },
            normal: u.cross(v).normalize_or_zero(),
            area: std::f64::consts::PI * radius * radius,
            mask: None,
        }
    }

    /// The same support seen from its back side (normal flipped, same map).
    pub fn flipped(&self) -> Self {
        let mut s = self.clone();
        s.normal = -s.normal;
        s
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

/// Splits a rectilinear polygon with holes (straight edges only) into rectangles in
/// the polygon's plane; returns parallelogram supports (front = polygon front).
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
    let mut loops: Vec<Vec<DVec2>> = Vec::new();
    for l in std::iter::once(&poly.outer).chain(poly.holes.iter()) {
        let mut pts = Vec::new();
        for e in &l.edges {
            match e {
                LoopEdge::Segment { start } => pts.push(*start),
                _ => {
                    return Err(unsupported(
                        scene,
                        i,
                        "polygon with circular arcs (needs a masked support)",
                    ));
                }
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
                return Err(unsupported(
                    scene,
                    i,
                    "non-rectilinear polygon (needs a masked support)",
                ));
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
    Ok(out)
}

fn shape_pieces(scene: &Scene, i: usize) -> Result<Vec<Support>, SolverError> {
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
        Shape::Bezier(_) => {
            return Err(unsupported(
                scene,
                i,
                "Bézier patch (needs a curved masked support)",
            ));
        }
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

/// Builds the patches of a scene: every surface is split into supports; every
/// support gets one patch for the front side and, for two-sided surfaces, one for the
/// back side (flipped normal, back material). Textured materials use the texture
/// mean (this solver has constant reflectance and emission per support).
///
/// # Errors
/// [`SolverError::UnsupportedSurface`] for shapes without an equal-area support,
/// [`SolverError::InvalidScene`] for bad materials or degenerate pieces.
pub fn build_patches(scene: &Scene) -> Result<PatchSet, SolverError> {
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
        for (j, s) in shape_pieces(scene, i)?.into_iter().enumerate() {
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
