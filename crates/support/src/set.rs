//! The supports of a scene: every surface split into unit-square supports, one
//! entry per lit side (VirtualMesh §3–§4; Ziegler §3.3.1).
//!
//! Parallelograms, triangles and mesh elements keep their own supports; a polygon
//! that is one full circle becomes a disk; a rectilinear polygon its exact
//! rectangles; any other polygon its minimal enclosing parallelogram masked by the
//! polygon (a virtual support, VirtualMesh §3.2); an analytic patch its
//! `wavelux-param` map composed with the parallelogram enclosing its trim; a Bézier
//! patch its map. Materials are not read here: each side carries its material index,
//! and a method crate turns it into what it models (diffuse reflectance and exitance
//! in `wavelux-solver`, a BRDF in `wavelux-glossy`).

use std::sync::Arc;

use glam::DVec2;
use wavelux_geometry::{Edge2, TrimRegion};
use wavelux_param::mep::{BoundarySegment, min_enclosing_parallelogram_of_boundary};
use wavelux_param::{Parallelogram2, ParamKind, Parametrization, SurfaceShape};
use wavelux_scene::{AnalyticPatch, LoopEdge, MeshElement, Scene, SceneError, Shape, Sidedness};

use crate::error::SupportError;
use crate::mask::Mask;
use crate::piece::Support;

/// Which side of a surface a patch is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Side {
    /// The front side (normal as the shape defines it).
    Front,
    /// The back side of a two-sided surface.
    Back,
}

/// Relative tolerance of the rectilinearity test of polygon edges.
const RECT_TOL: f64 = 1e-9;

fn unsupported(scene: &Scene, i: usize, kind: &str) -> SupportError {
    SupportError::UnsupportedSurface {
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
) -> Result<Vec<Support>, SupportError> {
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

fn scene_err(e: SceneError) -> SupportError {
    SupportError::InvalidScene(e.to_string())
}

fn geometry_err(e: wavelux_geometry::GeometryError) -> SupportError {
    SupportError::InvalidScene(e.to_string())
}

fn param_err(e: wavelux_param::ParamError) -> SupportError {
    SupportError::InvalidScene(e.to_string())
}

/// The trim region of an outer loop and holes (outer counter-clockwise, holes
/// clockwise).
fn region_of(
    scene: &Scene,
    i: usize,
    outer: &wavelux_scene::Loop,
    holes: &[wavelux_scene::Loop],
) -> Result<TrimRegion, SupportError> {
    let name = &scene.surfaces[i].name;
    let mut loops = vec![outer.to_trim_loop(true, "scene", name).map_err(scene_err)?];
    for h in holes {
        loops.push(h.to_trim_loop(false, "scene", name).map_err(scene_err)?);
    }
    TrimRegion::new(loops).map_err(geometry_err)
}

/// Minimal enclosing parallelogram of a region's outer loops (arcs circumscribed to
/// `1e-4` of the region size: the support only needs to enclose).
fn enclosing_parallelogram(region: &TrimRegion) -> Result<Parallelogram2, SupportError> {
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
) -> Result<Support, SupportError> {
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
fn trim_parallelogram(region: &TrimRegion) -> Result<Parallelogram2, SupportError> {
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
        return Err(SupportError::InvalidScene(
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

/// The support of an analytic patch: Ψ composed with the parallelogram enclosing its
/// trim (identity when untrimmed), masked by the trim.
fn patch_support(
    scene: &Scene,
    i: usize,
    p: &AnalyticPatch,
    kind: ParamKind,
) -> Result<Support, SupportError> {
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
) -> Result<Option<Vec<Support>>, SupportError> {
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

fn shape_pieces(scene: &Scene, i: usize, kind: ParamKind) -> Result<Vec<Support>, SupportError> {
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
            return Err(SupportError::InvalidScene(format!(
                "surface {:?} has a degenerate or non-finite piece (area {})",
                scene.surfaces[i].name, s.area
            )));
        }
    }
    Ok(out)
}

/// One lit side of one support.
#[derive(Debug, Clone, PartialEq)]
pub struct SideSupport {
    /// Index of the scene surface.
    pub surface: usize,
    /// Index of the piece within the surface (mesh element or polygon rectangle).
    pub piece: usize,
    /// Which side.
    pub side: Side,
    /// The support, with the normal of this side.
    pub support: Support,
    /// Index into `Scene::materials` of this side's material.
    pub material: usize,
    /// Primitive id of the support in the visibility accelerator (the index of its
    /// piece in [`SupportSet::pieces`]).
    pub prim: u32,
}

/// The supports of a scene.
#[derive(Debug, Clone)]
pub struct SupportSet {
    /// One entry per lit side: the front of every piece, then (for two-sided
    /// surfaces) its back, surface by surface.
    pub sides: Vec<SideSupport>,
    /// One support per geometric piece (front orientation), indexed by
    /// [`SideSupport::prim`].
    pub pieces: Vec<Support>,
    /// For each surface, the indices into `sides` of its sides.
    pub by_surface: Vec<Vec<usize>>,
}

/// Builds the supports of a scene: every surface split into supports (see the module
/// docs), each with one side for the front and, for two-sided surfaces, one for the
/// back (flipped normal, back material). `kind` only changes curved maps (planar maps
/// are equal-area either way); the trims of a patch are given in the equal-area square
/// and, for a natural map with a varying Jacobian, carried over to its square as
/// polylines (chordal deviation ≤ 1e-7).
///
/// # Errors
/// [`SupportError::UnsupportedSurface`] for a trimmed patch whose trim has a point
/// without a natural-coordinate preimage (with `ParamKind::Natural`), a degenerate
/// polygon; [`SupportError::InvalidScene`] for degenerate or non-finite pieces.
pub fn build_supports(scene: &Scene, kind: ParamKind) -> Result<SupportSet, SupportError> {
    let mut sides = Vec::new();
    let mut pieces = Vec::new();
    let mut by_surface = Vec::with_capacity(scene.surfaces.len());
    for (i, surf) in scene.surfaces.iter().enumerate() {
        let back = match surf.sides {
            Sidedness::TwoSided { back } => Some(back),
            _ => None,
        };
        let mut ids = Vec::new();
        for (j, s) in shape_pieces(scene, i, kind)?.into_iter().enumerate() {
            let prim = pieces.len() as u32;
            pieces.push(s.clone());
            ids.push(sides.len());
            if let Some(material) = back {
                sides.push(SideSupport {
                    surface: i,
                    piece: j,
                    side: Side::Front,
                    support: s.clone(),
                    material: surf.material,
                    prim,
                });
                ids.push(sides.len());
                sides.push(SideSupport {
                    surface: i,
                    piece: j,
                    side: Side::Back,
                    support: s.flipped(),
                    material,
                    prim,
                });
            } else {
                sides.push(SideSupport {
                    surface: i,
                    piece: j,
                    side: Side::Front,
                    support: s,
                    material: surf.material,
                    prim,
                });
            }
        }
        by_surface.push(ids);
    }
    Ok(SupportSet {
        sides,
        pieces,
        by_surface,
    })
}
