//! Mesh grouping: the connected coplanar triangles of one mesh become the complex
//! polygon they tile, holes and all, so that a wall, a disk or a floor with holes given
//! as triangles is one surface with one support (VirtualMesh §3.2: a complex polygon's
//! virtual support is its minimal enclosing parallelogram with the polygon as exact
//! mask, §4; rectilinear polygons and parallelograms keep exact supports).
//!
//! # Algorithm
//!
//! 1. Vertices within [`WELD_REL`]` × (mesh bounding diagonal)` of each other are
//!    welded (split or rounded vertices at seams).
//! 2. Smooth components (connected across manifold edges with creases below
//!    [`crate::fit::max_arc`]) that tessellate a sphere (closed) or a cylinder patch
//!    or a cone patch (open: a tube, a half-pipe, a curved wall, a lampshade, a
//!    funnel) become that analytic surface ([`crate::fit`]); near misses (jittered
//!    vertices, a tube with a window) stay facets with a
//!    [`WarningKind::CurveNotRecognised`].
//! 3. Groups grow from the largest ungrouped triangle across *manifold* edges (exactly
//!    two triangles, traversed in opposite directions, so the orientation agrees): a
//!    neighbour joins when all three of its vertices lie within
//!    `COPLANAR_REL × (mesh bounding diagonal)` of the seed's plane and its normal
//!    faces the same way. Non-manifold edges are never crossed.
//! 4. A group's boundary is its directed edges that no opposite edge cancels. Boundary
//!    edges with a boundary vertex on them (T-junctions, within the same tolerance)
//!    are split there and cancelled again. Loops are traced keeping the interior on
//!    the left (at a vertex where the boundary touches itself, the outgoing edge with
//!    the smallest clockwise turn from the way back).
//! 5. In the group's plane (normal: area-weighted, axis `u`: the outer loop's longest
//!    edge), vertices where a loop runs straight within `COPLANAR_REL × (group
//!    diagonal)` are removed, and hole loops of that width (cracks) are dropped.
//! 6. The result must be a proper region (one counter-clockwise outer loop, winding 0
//!    or 1 everywhere) whose area equals the triangles' area within the removed
//!    vertices' tolerance; otherwise the group's triangles are kept as triangles and
//!    a [`WarningKind::GroupingFallback`] says why. A wrong polygon is never produced.
//! 7. Each loop that tessellates a circle becomes that circle, one full arc: a disk
//!    (whose support is the exact concentric map), an annulus, a wall with round holes
//!    (masked virtual supports with exact arc masks); in any other loop, each run of
//!    co-circular edges that the outline leaves at both ends becomes that arc (rounded
//!    corners, a slot's ends: [`crate::fit::fit_arcs`]); near misses (an ellipse,
//!    jittered vertices) keep their edges with a [`WarningKind::CurveNotRecognised`].
//!
//! Groups of fewer than [`MIN_GROUP_TRIANGLES`] triangles stay in the mesh (a pair is
//! an exact parallelogram, merged as before, or a general quad, which in a curved
//! mesh's facets would only multiply surfaces). A group that simplifies to a triangle
//! or an exact parallelogram becomes that shape.

use std::collections::{BTreeMap, HashMap};

use glam::{DVec2, DVec3};

use crate::analytic::{AnalyticPatch, AnalyticSurface, Placement};
use crate::error::{SceneError, WarningKind};
use crate::fit::{
    ConeFit, CylinderFit, SphereFit, fit_arcs, fit_circle, fit_cone, fit_cylinder, fit_sphere,
    max_arc,
};
use crate::material::{Material, Rgb};
use crate::scene::{MaterialId, Scene, Sidedness};
use crate::shape::{Loop, LoopEdge, MERGE_REL, PlaneFrame, PolygonShape, Shape, TriangleMesh};

/// Coplanarity tolerance relative to the mesh's bounding-box diagonal: a triangle joins
/// a group when its vertices are within `COPLANAR_REL × diagonal` of the group's plane.
/// `1e-6` is about 16 `f32` ulps, the precision of glTF positions. The same factor,
/// relative to a group's own diagonal, bounds the removal of collinear boundary
/// vertices.
pub const COPLANAR_REL: f64 = 1e-6;

/// Weld tolerance relative to the mesh's bounding-box diagonal: a vertex within
/// `WELD_REL × diagonal` of an earlier vertex is the same vertex (near-duplicates at
/// seams, written by exporters that round positions separately per face). `1e-6`, as
/// [`COPLANAR_REL`]: about 16 `f32` ulps of the mesh's size.
pub const WELD_REL: f64 = 1e-6;

/// Smallest group that becomes its own polygon surface.
pub const MIN_GROUP_TRIANGLES: usize = 3;

/// How the loaders turn triangle meshes into surfaces.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[non_exhaustive]
pub enum MeshGrouping {
    /// Connected coplanar triangles become complex polygons (this module); the default.
    #[default]
    Surfaces,
    /// One surface per mesh primitive, triangles as given (exact parallelogram pairs
    /// merged): the behaviour before grouping, kept for comparison.
    Triangles,
}

/// One surface made from a mesh: a name suffix (empty when the mesh made one surface)
/// and its shape.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshPart {
    /// Appended to the mesh's name: `""` when the mesh became one surface, else
    /// `.sphere{k}`, `.cylinder{k}` and `.face{k}` for the `k`-th sphere, cylinder patch
    /// and polygon, and `.rest` for the triangles left over.
    pub suffix: String,
    /// The shape: a sphere, a cylinder patch, a polygon (with circular loops where
    /// recognised), a triangle, a parallelogram, or the left-over mesh.
    pub shape: Shape,
    /// The shape's front side is the mesh's back side: a sphere or cylinder fitted to
    /// a mesh that faces inwards (an analytic surface's front side is always its outside). Give the
    /// part its sides with [`reversed_sides`].
    pub reversed: bool,
}

/// The front material and sidedness of a [`MeshPart::reversed`] part of a mesh whose
/// front material is `material` with `sides`: the sides swap; a one-sided mesh's
/// black back becomes a black front (a material with zero reflectance and emission,
/// found in or added to `scene`).
pub fn reversed_sides(
    scene: &mut Scene,
    material: MaterialId,
    sides: Sidedness,
) -> (MaterialId, Sidedness) {
    let front = match sides {
        Sidedness::TwoSided { back } => back,
        _ => scene
            .materials
            .iter()
            .position(|m| *m == Material::lambertian(m.name.clone(), Rgb::BLACK, Rgb::BLACK))
            .unwrap_or_else(|| {
                scene.add_material(Material::lambertian("black", Rgb::BLACK, Rgb::BLACK))
            }),
    };
    (front, Sidedness::TwoSided { back: material })
}

/// The surfaces of one grouped mesh.
#[derive(Debug, Clone, PartialEq)]
pub struct Grouped {
    /// The parts: spheres, cylinder patches, polygons (in the order of their largest
    /// triangle), the left-over triangles last.
    pub parts: Vec<MeshPart>,
    /// Groups kept as triangles, and why.
    pub warnings: Vec<WarningKind>,
    /// Number of input triangles now inside polygons.
    pub grouped_triangles: usize,
}

/// A triangle of the welded mesh.
#[derive(Debug, Clone, Copy)]
struct Tri {
    /// Original vertex indices.
    orig: [u32; 3],
    /// Welded vertex ids.
    v: [u32; 3],
    /// Unit normal (zero for a triangle degenerate after welding).
    n: DVec3,
    /// Area.
    area: f64,
}

/// Why a group cannot be a polygon.
type Reason = String;

/// Groups the triangles of `mesh` (already validated, degenerate triangles dropped) as
/// the module docs describe. Textures are not carried into polygons: callers keep
/// textured meshes as triangles.
///
/// # Errors
/// Only on inconsistent input that [`TriangleMesh::build`] would have rejected
/// ([`SceneError::Malformed`] naming `file` and `element`).
pub fn group_mesh(mesh: &TriangleMesh, file: &str, element: &str) -> Result<Grouped, SceneError> {
    let p = &mesh.positions;
    let mut input: Vec<[u32; 3]> = mesh.triangles.clone();
    for q in &mesh.parallelograms {
        input.push([q[0], q[1], q[2]]);
        input.push([q[0], q[2], q[3]]);
    }
    let n = p.len();
    if input.iter().flatten().any(|&i| i as usize >= n) {
        return Err(SceneError::Malformed {
            file: file.into(),
            element: element.into(),
            what: "vertex index out of range".into(),
        });
    }
    let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    for &i in input.iter().flatten() {
        lo = lo.min(p[i as usize]);
        hi = hi.max(p[i as usize]);
    }
    let diag = (hi - lo).length();
    let tol = COPLANAR_REL * diag;
    let ids = weld(p, WELD_REL * diag);
    let tris: Vec<Tri> = input
        .iter()
        .map(|t| {
            let v = t.map(|i| ids[i as usize]);
            let c =
                (p[v[1] as usize] - p[v[0] as usize]).cross(p[v[2] as usize] - p[v[0] as usize]);
            let distinct = v[0] != v[1] && v[1] != v[2] && v[0] != v[2];
            Tri {
                orig: *t,
                v,
                n: if distinct {
                    c.normalize_or_zero()
                } else {
                    DVec3::ZERO
                },
                area: 0.5 * c.length(),
            }
        })
        .collect();
    let edges = EdgeMap::new(&tris);
    let (fitted, taken, mut warnings) = fit_smooth(p, &tris, &edges);
    let groups = grow_groups(p, &tris, &edges, &taken, tol);
    let mut parts = Vec::new();
    let mut rest: Vec<[u32; 3]> = Vec::new();
    let mut grouped_triangles = 0;
    for g in &groups {
        if g.len() < MIN_GROUP_TRIANGLES {
            rest.extend(g.iter().map(|&t| tris[t].orig));
            continue;
        }
        match polygon_of(p, &tris, g, tol) {
            Ok((shape, misses)) => {
                grouped_triangles += g.len();
                parts.push(shape);
                warnings.extend(misses.into_iter().map(|(surface, reason)| {
                    WarningKind::CurveNotRecognised {
                        triangles: g.len(),
                        surface: surface.into(),
                        reason,
                    }
                }));
            }
            Err(reason) => {
                warnings.push(WarningKind::GroupingFallback {
                    triangles: g.len(),
                    reason,
                });
                rest.extend(g.iter().map(|&t| tris[t].orig));
            }
        }
    }
    // Triangles that welding collapsed (two vertices within the weld tolerance) are
    // dropped: their area is below `tol` times their longest edge, and their welded
    // neighbours now meet directly.
    let (mut welded, mut welded_area) = (0, 0.0);
    for t in tris.iter().filter(|t| t.n == DVec3::ZERO) {
        let [a, b, c] = t.orig.map(|i| p[i as usize]);
        welded += 1;
        welded_area += 0.5 * (b - a).cross(c - a).length();
    }
    if welded > 0 {
        warnings.push(WarningKind::WeldedTrianglesDropped {
            count: welded,
            area: welded_area,
        });
    }
    let single = fitted.len() + parts.len() + usize::from(!rest.is_empty()) == 1;
    let name = |kind: &str, k: usize| {
        if single {
            String::new()
        } else {
            format!(".{kind}{k}")
        }
    };
    let mut out: Vec<MeshPart> = Vec::new();
    let mut counts = [0usize; 3];
    for (count, fit) in fitted {
        grouped_triangles += count;
        let (kind, shape, reversed) = fit.part();
        let k = &mut counts[fit.order()];
        out.push(MeshPart {
            suffix: name(kind, *k),
            shape,
            reversed,
        });
        *k += 1;
    }
    out.extend(parts.into_iter().enumerate().map(|(k, shape)| MeshPart {
        suffix: name("face", k),
        shape,
        reversed: false,
    }));
    if !rest.is_empty() {
        rest.sort_unstable();
        let built = TriangleMesh::build(p.clone(), mesh.uv_sets.clone(), &rest, file, element)?;
        out.push(MeshPart {
            suffix: if single {
                String::new()
            } else {
                ".rest".into()
            },
            shape: Shape::Mesh(built.mesh),
            reversed: false,
        });
    }
    Ok(Grouped {
        parts: out,
        warnings,
        grouped_triangles,
    })
}

/// Welded id of every vertex (see [`WELD_REL`]): vertices are visited in index order;
/// one within `tol` of an earlier representative takes the id of the first such
/// representative, any other becomes a representative itself. Deterministic, and a
/// weld never chains: every vertex is within `tol` of its representative.
fn weld(p: &[DVec3], tol: f64) -> Vec<u32> {
    if !(tol > 0.0) {
        return weld_exact(p);
    }
    let cell = |q: DVec3| (q / tol).floor().to_array().map(|c| c as i64);
    let mut grid: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
    let mut ids = Vec::with_capacity(p.len());
    for (i, &q) in p.iter().enumerate() {
        let c = cell(q);
        let mut best: Option<u32> = None;
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    let key = [
                        c[0].saturating_add(dx),
                        c[1].saturating_add(dy),
                        c[2].saturating_add(dz),
                    ];
                    for &r in grid.get(&key).map_or(&[][..], Vec::as_slice) {
                        if (p[r as usize] - q).length() <= tol && best.is_none_or(|b| r < b) {
                            best = Some(r);
                        }
                    }
                }
            }
        }
        match best {
            Some(r) => ids.push(r),
            None => {
                grid.entry(c).or_default().push(i as u32);
                ids.push(i as u32);
            }
        }
    }
    ids
}

/// Welded id of every vertex: the smallest index with a bitwise-equal position.
fn weld_exact(p: &[DVec3]) -> Vec<u32> {
    let key = |q: DVec3| q.to_array().map(|c| (c + 0.0).to_bits());
    let mut order: Vec<u32> = (0..p.len() as u32).collect();
    order.sort_unstable_by_key(|&i| (key(p[i as usize]), i));
    let mut ids = vec![0u32; p.len()];
    let mut g = 0;
    while g < order.len() {
        let first = order[g];
        let k = key(p[first as usize]);
        let mut h = g;
        while h < order.len() && key(p[order[h] as usize]) == k {
            ids[order[h] as usize] = first;
            h += 1;
        }
        g = h;
    }
    ids
}

/// Sorted undirected edges `(min, max) → (triangle, forward)` of the welded triangles.
struct EdgeMap {
    edges: Vec<(u64, u32, bool)>,
}

impl EdgeMap {
    fn new(tris: &[Tri]) -> Self {
        let mut edges = Vec::with_capacity(3 * tris.len());
        for (t, tri) in tris.iter().enumerate() {
            if tri.n == DVec3::ZERO {
                continue;
            }
            for e in 0..3 {
                let (a, b) = (tri.v[e], tri.v[(e + 1) % 3]);
                edges.push((Self::key(a, b), t as u32, a < b));
            }
        }
        edges.sort_unstable();
        Self { edges }
    }

    fn key(a: u32, b: u32) -> u64 {
        let (x, y) = if a < b { (a, b) } else { (b, a) };
        (u64::from(x) << 32) | u64::from(y)
    }

    /// The other triangle of a manifold, consistently oriented edge `(a, b)` of `t`.
    fn neighbour(&self, t: usize, a: u32, b: u32) -> Option<usize> {
        let k = Self::key(a, b);
        let lo = self.edges.partition_point(|e| e.0 < k);
        let hi = self.edges.partition_point(|e| e.0 <= k);
        let owners = &self.edges[lo..hi];
        if owners.len() != 2 || owners[0].2 == owners[1].2 {
            return None;
        }
        owners.iter().map(|e| e.1 as usize).find(|&u| u != t)
    }
}

/// Region growing (see the module docs); every triangle that is not degenerate after
/// welding and not `taken` (by a fitted sphere) ends in exactly one group.
fn grow_groups(
    p: &[DVec3],
    tris: &[Tri],
    edges: &EdgeMap,
    taken: &[bool],
    tol: f64,
) -> Vec<Vec<usize>> {
    let mut order: Vec<usize> = (0..tris.len())
        .filter(|&t| tris[t].n != DVec3::ZERO && !taken[t])
        .collect();
    order.sort_by(|&a, &b| tris[b].area.total_cmp(&tris[a].area).then(a.cmp(&b)));
    let mut assigned = taken.to_vec();
    let mut groups = Vec::new();
    for seed in order {
        if assigned[seed] {
            continue;
        }
        assigned[seed] = true;
        let n = tris[seed].n;
        let o = p[tris[seed].v[0] as usize];
        let on_plane = |t: &Tri| {
            t.n.dot(n) > 0.0 && t.v.iter().all(|&i| n.dot(p[i as usize] - o).abs() <= tol)
        };
        let mut group = vec![seed];
        let mut k = 0;
        while k < group.len() {
            let t = group[k];
            k += 1;
            for e in 0..3 {
                let (a, b) = (tris[t].v[e], tris[t].v[(e + 1) % 3]);
                if let Some(u) = edges.neighbour(t, a, b)
                    && !assigned[u]
                    && on_plane(&tris[u])
                {
                    assigned[u] = true;
                    group.push(u);
                }
            }
        }
        group.sort_unstable();
        groups.push(group);
    }
    groups
}

/// A smooth component recognised as an analytic surface ([`crate::fit`]).
enum Fitted {
    Sphere(SphereFit),
    Cylinder(CylinderFit),
    Cone(ConeFit),
}

impl Fitted {
    /// Output order of the kind (spheres, cylinders, cones) and its index in the
    /// per-kind part counters.
    fn order(&self) -> usize {
        match self {
            Self::Sphere(_) => 0,
            Self::Cylinder(_) => 1,
            Self::Cone(_) => 2,
        }
    }

    /// Name of the kind in part suffixes, the analytic patch (front side outwards) and
    /// whether the mesh's front side is its inside ([`MeshPart::reversed`]).
    fn part(&self) -> (&'static str, Shape, bool) {
        match *self {
            Self::Sphere(f) => ("sphere", sphere_shape(f), f.inward),
            Self::Cylinder(f) => ("cylinder", cylinder_shape(f), f.inward),
            Self::Cone(f) => ("cone", cone_shape(f), f.inward),
        }
    }
}

/// The smooth components (see [`smooth_components`]) that tessellate a sphere (closed)
/// or a cylinder or cone patch (open), each with its triangle count, in the order
/// spheres, cylinders, cones (each in component order); which triangles they take; and
/// the near misses' warnings. A cone is tried where the cylinder is not recognised; a
/// near miss names the cone when the cone fit was a candidate, else the cylinder.
fn fit_smooth(
    p: &[DVec3],
    tris: &[Tri],
    edges: &EdgeMap,
) -> (Vec<(usize, Fitted)>, Vec<bool>, Vec<WarningKind>) {
    let mut taken = vec![false; tris.len()];
    let mut fitted = Vec::new();
    let mut warnings = Vec::new();
    for (comp, closed) in smooth_components(tris, edges) {
        let welded: Vec<[u32; 3]> = comp.iter().map(|&t| tris[t].v).collect();
        let fit = if closed {
            fit_sphere(p, &welded).map(Fitted::Sphere)
        } else {
            match fit_cylinder(p, &welded) {
                Ok(fit) => Some(Fitted::Cylinder(fit)),
                Err(cylinder) => match fit_cone(p, &welded) {
                    Ok(fit) => Some(Fitted::Cone(fit)),
                    Err(cone) => {
                        let miss = match (cone, cylinder) {
                            (Some(reason), _) => Some(("cone", reason)),
                            (None, Some(reason)) => Some(("cylinder", reason)),
                            (None, None) => None,
                        };
                        if let Some((surface, reason)) = miss {
                            warnings.push(WarningKind::CurveNotRecognised {
                                triangles: comp.len(),
                                surface: surface.into(),
                                reason,
                            });
                        }
                        None
                    }
                },
            }
        };
        if let Some(fit) = fit {
            for &t in &comp {
                taken[t] = true;
            }
            fitted.push((comp.len(), fit));
        }
    }
    fitted.sort_by_key(|f| f.1.order());
    (fitted, taken, warnings)
}

/// The smooth components of the welded triangles: maximal sets connected across
/// manifold, consistently oriented edges whose two facets' normals differ by at most
/// [`max_arc`] (a crease sharper than one facet of a recognisable curve separates
/// components: a cylinder's caps from its tube), each sorted, with whether it is
/// closed (every edge of its triangles is such an edge).
fn smooth_components(tris: &[Tri], edges: &EdgeMap) -> Vec<(Vec<usize>, bool)> {
    let cos_crease = max_arc().cos();
    let mut seen = vec![false; tris.len()];
    let mut out = Vec::new();
    for start in 0..tris.len() {
        if seen[start] || tris[start].n == DVec3::ZERO {
            continue;
        }
        seen[start] = true;
        let mut comp = vec![start];
        let mut closed = true;
        let mut k = 0;
        while k < comp.len() {
            let t = comp[k];
            k += 1;
            for e in 0..3 {
                let (a, b) = (tris[t].v[e], tris[t].v[(e + 1) % 3]);
                match edges.neighbour(t, a, b) {
                    Some(u) if tris[u].n.dot(tris[t].n) >= cos_crease => {
                        if !seen[u] {
                            seen[u] = true;
                            comp.push(u);
                        }
                    }
                    _ => closed = false,
                }
            }
        }
        comp.sort_unstable();
        out.push((comp, closed));
    }
    out
}

/// The cylinder patch of a fit, front side away from the axis (see
/// [`MeshPart::reversed`]).
fn cylinder_shape(fit: CylinderFit) -> Shape {
    Shape::Patch(AnalyticPatch {
        surface: AnalyticSurface::Cylinder {
            placement: Placement {
                origin: fit.origin,
                axis: fit.axis,
                reference: fit.reference,
            },
            radius: fit.radius,
            azimuth: fit.azimuth,
            height: fit.height,
        },
        trim: None,
    })
}

/// The cone patch of a fit, front side away from the axis (see [`MeshPart::reversed`]):
/// the apex at the placement's origin, `φ = 1` at the patch's far rim.
fn cone_shape(fit: ConeFit) -> Shape {
    let (h0, h1) = fit.height;
    Shape::Patch(AnalyticPatch {
        surface: AnalyticSurface::Cone {
            placement: Placement {
                origin: fit.apex,
                axis: fit.axis,
                reference: fit.reference,
            },
            radius: fit.slope * h1,
            height: h1,
            azimuth: fit.azimuth,
            generator: (h0 / h1, 1.0),
        },
        trim: None,
    })
}

/// The whole sphere of a fit: an analytic patch, front side outwards (see
/// [`MeshPart::reversed`]).
fn sphere_shape(fit: SphereFit) -> Shape {
    Shape::Patch(AnalyticPatch {
        surface: AnalyticSurface::Sphere {
            placement: Placement {
                origin: fit.centre,
                axis: DVec3::Z,
                reference: DVec3::X,
            },
            radius: fit.radius,
            azimuth: (0.0, std::f64::consts::TAU),
            latitude: (-std::f64::consts::FRAC_PI_2, std::f64::consts::FRAC_PI_2),
        },
        trim: None,
    })
}

/// The boundary of a set of triangles: directed edges with net multiplicity ±1 (by
/// sorting the undirected edges, each with `+1` in its `min → max` direction).
fn boundary_edges(edges: impl Iterator<Item = (u32, u32)>) -> Result<Vec<(u32, u32)>, Reason> {
    let mut all: Vec<(u32, u32, i32)> = edges
        .map(|(a, b)| if a < b { (a, b, 1) } else { (b, a, -1) })
        .collect();
    all.sort_unstable();
    let mut out = Vec::new();
    let mut k = 0;
    while k < all.len() {
        let (a, b) = (all[k].0, all[k].1);
        let mut c = 0;
        while k < all.len() && (all[k].0, all[k].1) == (a, b) {
            c += all[k].2;
            k += 1;
        }
        match c {
            0 => {}
            1 => out.push((a, b)),
            -1 => out.push((b, a)),
            _ => {
                return Err(format!(
                    "an edge is used {} times in the same direction (overlapping triangles)",
                    c.abs()
                ));
            }
        }
    }
    Ok(out)
}

/// Splits every boundary edge at the boundary vertices lying on it (T-junctions) and
/// cancels the pieces again; repeats until nothing splits (at most 8 passes).
fn split_t_junctions(
    p: &[DVec3],
    mut edges: Vec<(u32, u32)>,
    tol: f64,
) -> Result<Vec<(u32, u32)>, Reason> {
    for _ in 0..8 {
        let mut verts: Vec<u32> = edges.iter().flat_map(|&(a, b)| [a, b]).collect();
        verts
            .sort_unstable_by(|&a, &b| p[a as usize].x.total_cmp(&p[b as usize].x).then(a.cmp(&b)));
        verts.dedup();
        let xs: Vec<f64> = verts.iter().map(|&v| p[v as usize].x).collect();
        let mut split = false;
        let mut out = Vec::with_capacity(edges.len());
        for &(a, b) in &edges {
            let (pa, pb) = (p[a as usize], p[b as usize]);
            let d = pb - pa;
            let len2 = d.length_squared();
            let (x0, x1) = (pa.x.min(pb.x) - tol, pa.x.max(pb.x) + tol);
            let i0 = xs.partition_point(|&x| x < x0);
            let i1 = xs.partition_point(|&x| x <= x1);
            let mut on: Vec<(f64, u32)> = Vec::new();
            for &v in &verts[i0..i1] {
                if v == a || v == b {
                    continue;
                }
                let q = p[v as usize] - pa;
                let s = q.dot(d) / len2;
                if s > 0.0 && s < 1.0 && (q - s * d).length() <= tol {
                    on.push((s, v));
                }
            }
            if on.is_empty() {
                out.push((a, b));
                continue;
            }
            split = true;
            on.sort_by(|x, y| x.0.total_cmp(&y.0));
            let mut prev = a;
            for (_, v) in on {
                out.push((prev, v));
                prev = v;
            }
            out.push((prev, b));
        }
        if !split {
            return Ok(edges);
        }
        edges = boundary_edges(out.into_iter())?;
    }
    Err("T-junctions did not resolve".into())
}

/// Traces closed loops through directed boundary edges, interior on the left; at a
/// vertex with several outgoing edges, the one with the smallest clockwise turn from
/// the way back (angles measured in the plane with normal `n`).
fn trace_loops(p: &[DVec3], edges: &[(u32, u32)], n: DVec3) -> Result<Vec<Vec<u32>>, Reason> {
    let mut out_of: BTreeMap<u32, Vec<usize>> = BTreeMap::new();
    let mut in_deg: BTreeMap<u32, usize> = BTreeMap::new();
    for (k, &(a, b)) in edges.iter().enumerate() {
        out_of.entry(a).or_default().push(k);
        *in_deg.entry(b).or_default() += 1;
    }
    for (v, outs) in &out_of {
        if in_deg.get(v).copied().unwrap_or(0) != outs.len() {
            return Err("the boundary is open (a T-junction or crack that did not close)".into());
        }
    }
    if in_deg.keys().any(|v| !out_of.contains_key(v)) {
        return Err("the boundary is open (a T-junction or crack that did not close)".into());
    }
    let mut used = vec![false; edges.len()];
    let mut loops = Vec::new();
    for start in 0..edges.len() {
        if used[start] {
            continue;
        }
        let mut lp = Vec::new();
        let mut e = start;
        loop {
            used[e] = true;
            let (a, b) = edges[e];
            lp.push(a);
            let back = p[a as usize] - p[b as usize];
            let candidates = &out_of[&b];
            let next = candidates
                .iter()
                .copied()
                .filter(|&k| !used[k] || k == start)
                .min_by(|&x, &y| {
                    let turn = |k: usize| {
                        let d = p[edges[k].1 as usize] - p[b as usize];
                        // Clockwise angle from `back` to `d` about `n`, in (0, 2π].
                        let ccw = n.dot(back.cross(d)).atan2(back.dot(d));
                        let cw = (-ccw).rem_euclid(std::f64::consts::TAU);
                        if cw == 0.0 { std::f64::consts::TAU } else { cw }
                    };
                    turn(x).total_cmp(&turn(y)).then(x.cmp(&y))
                });
            match next {
                Some(k) if k == start => break,
                Some(k) => e = k,
                None => return Err("the boundary does not close".into()),
            }
            if lp.len() > edges.len() {
                return Err("the boundary does not close".into());
            }
        }
        loops.push(lp);
    }
    Ok(loops)
}

/// Signed area of a closed 2D polyline.
fn signed_area(pts: &[DVec2]) -> f64 {
    let n = pts.len();
    0.5 * (0..n)
        .map(|i| pts[i].perp_dot(pts[(i + 1) % n]))
        .sum::<f64>()
}

/// Removes the vertices where the loop runs straight: every removed vertex lies within
/// `tol` of the chord that replaces it, between its ends. Starts at the vertex farthest
/// from the loop's mean (a convex corner, never removed).
fn simplify(pts: &[DVec2], tol: f64) -> Vec<DVec2> {
    let n = pts.len();
    let mean = pts.iter().copied().sum::<DVec2>() / n as f64;
    let start = (0..n)
        .max_by(|&a, &b| {
            (pts[a] - mean)
                .length_squared()
                .total_cmp(&(pts[b] - mean).length_squared())
                .then(b.cmp(&a))
        })
        .unwrap_or(0);
    let near = |q: DVec2, a: DVec2, c: DVec2| {
        let d = c - a;
        let len2 = d.length_squared();
        let s = (q - a).dot(d);
        len2 > 0.0 && s > 0.0 && s < len2 && (q - a).perp_dot(d).abs() <= tol * len2.sqrt()
    };
    let mut kept = vec![pts[start]];
    // Vertices after the last kept one, all within `tol` of the chord to the newest.
    let mut run: Vec<DVec2> = Vec::new();
    for k in 1..=n {
        let c = pts[(start + k) % n];
        if let Some(&last) = run.last() {
            let anchor = kept[kept.len() - 1];
            if !run.iter().all(|&q| near(q, anchor, c)) {
                kept.push(last);
                run.clear();
            }
        }
        run.push(c);
    }
    kept
}

/// What a polygon loop nearly is, and why it was not recognised (see [`crate::fit`]).
type LoopMiss = (&'static str, String);

/// The polygon (or triangle, or parallelogram) tiled by group `g`, its loops that
/// tessellate circles made circles (a disk, an annulus, round holes; [`fit_circle`]),
/// with the loops that nearly do and why they were not; or why there is no polygon.
fn polygon_of(
    p: &[DVec3],
    tris: &[Tri],
    g: &[usize],
    tol: f64,
) -> Result<(Shape, Vec<LoopMiss>), Reason> {
    // Plane: area-weighted normal and centroid.
    let mut nsum = DVec3::ZERO;
    let mut csum = DVec3::ZERO;
    let mut area3 = 0.0;
    let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    for &t in g {
        let v = tris[t].v.map(|i| p[i as usize]);
        nsum += (v[1] - v[0]).cross(v[2] - v[0]);
        csum += tris[t].area * (v[0] + v[1] + v[2]) / 3.0;
        area3 += tris[t].area;
        for q in v {
            lo = lo.min(q);
            hi = hi.max(q);
        }
    }
    let normal = nsum
        .try_normalize()
        .ok_or("the triangles' normals cancel")?;
    let centre = csum / area3;
    for &t in g {
        for &i in &tris[t].v {
            if normal.dot(p[i as usize] - centre).abs() > 2.0 * tol {
                return Err("the triangles are not coplanar within the tolerance".into());
            }
        }
    }
    let edges = boundary_edges(g.iter().flat_map(|&t| {
        let v = tris[t].v;
        [(v[0], v[1]), (v[1], v[2]), (v[2], v[0])]
    }))?;
    let edges = split_t_junctions(p, edges, tol)?;
    let loops = trace_loops(p, &edges, normal)?;
    // Frame: u along the longest boundary edge (of the loop with the largest extent).
    let (mut best, mut u) = (0.0, DVec3::ZERO);
    for &(a, b) in &edges {
        let d = p[b as usize] - p[a as usize];
        let d = d - normal * normal.dot(d);
        if d.length_squared() > best {
            best = d.length_squared();
            u = d;
        }
    }
    let u = u.try_normalize().ok_or("the boundary has no extent")?;
    let v = normal.cross(u);
    let origin = centre;
    let frame = PlaneFrame { origin, u, v };
    let to2 = |q: DVec3| DVec2::new((q - origin).dot(u), (q - origin).dot(v));
    let gdiag = (hi - lo).length();
    let simplify_tol = COPLANAR_REL * gdiag;
    let mut outer: Option<Vec<DVec2>> = None;
    let mut holes: Vec<Vec<DVec2>> = Vec::new();
    let mut raw_area = 0.0;
    let mut perimeter = 0.0;
    for lp in &loops {
        let pts: Vec<DVec2> = lp.iter().map(|&i| to2(p[i as usize])).collect();
        let a = signed_area(&pts);
        raw_area += a;
        let per: f64 = (0..pts.len())
            .map(|k| (pts[(k + 1) % pts.len()] - pts[k]).length())
            .sum();
        perimeter += per;
        if a > 0.0 {
            if outer.is_some() {
                return Err("the triangles have several outer boundaries (they overlap)".into());
            }
            outer = Some(simplify(&pts, simplify_tol));
        } else if -a > simplify_tol * per {
            holes.push(simplify(&pts, simplify_tol));
        }
        // A hole thinner than the tolerance is a crack between triangles: dropped.
    }
    let outer = outer.ok_or("the boundary has no counter-clockwise outer loop")?;
    // The triangles' (3D) area must be what the boundary encloses.
    if (raw_area - area3).abs() > 4.0 * tol * perimeter + 1e-9 * area3 {
        return Err(format!(
            "the boundary encloses {raw_area} but the triangles cover {area3} (overlapping or folded triangles)"
        ));
    }
    let poly = PolygonShape {
        frame,
        outer: Loop::polygon(&outer),
        holes: holes.iter().map(|h| Loop::polygon(h)).collect(),
    };
    check_region(&poly).map_err(|e| format!("the boundary is not a simple region: {e}"))?;
    let simple_area = poly.area();
    if (simple_area - area3).abs() > 4.0 * simplify_tol * perimeter + 1e-9 * area3 {
        return Err(format!(
            "straightening the boundary changed the area from {area3} to {simple_area}"
        ));
    }
    if holes.is_empty() && outer.len() == 3 {
        let tri = Shape::Triangle([0, 1, 2].map(|k| frame.point(outer[k])));
        return Ok((tri, Vec::new()));
    }
    if holes.is_empty() && outer.len() == 4 {
        let [a, b, c, d] = [0, 1, 2, 3].map(|k| frame.point(outer[k]));
        if (a + c - b - d).length() <= MERGE_REL * (c - a).length() {
            return Ok((Shape::parallelogram(a, b - a, d - a), Vec::new()));
        }
    }
    let (poly, misses) = circles(poly, &outer, &holes);
    Ok((Shape::Polygon(poly), misses))
}

/// The polygon with every loop that tessellates a circle replaced by that circle (one
/// full arc, same orientation), and the loops that nearly do with why not. In a loop
/// that is no circle, every run of at least [`crate::fit::MIN_ARC_EDGES`] edges on one
/// circle ([`fit_arcs`]: rounded corners, a slot's round ends, an arched window)
/// becomes that arc. A circle or arcs that would make the region improper (a round hole
/// bulging into another loop by its sagitta) keep the polygon's edges, and say so.
fn circles(
    poly: PolygonShape,
    outer: &[DVec2],
    holes: &[Vec<DVec2>],
) -> (PolygonShape, Vec<LoopMiss>) {
    let mut misses = Vec::new();
    let mut out = poly.clone();
    let loops =
        std::iter::once((outer, "disk")).chain(holes.iter().map(|h| (&h[..], "circular hole")));
    for (k, (pts, what)) in loops.enumerate() {
        // The circle, else the arcs (whose success silences the circle's near miss).
        let (curved, what, miss) = match fit_circle(pts) {
            Ok(fit) => (
                Some(Loop {
                    edges: vec![LoopEdge::Arc {
                        start: fit.centre + DVec2::new(fit.radius, 0.0),
                        center: fit.centre,
                        ccw: k == 0,
                    }],
                }),
                what,
                None,
            ),
            Err(miss) => match with_arcs(pts) {
                Some(arcs) => (Some(arcs), "arcs", None),
                None => (None, what, miss),
            },
        };
        match curved {
            Some(curved) => {
                let mut next = out.clone();
                if k == 0 {
                    next.outer = curved;
                } else {
                    next.holes[k - 1] = curved;
                }
                match check_region(&next) {
                    Ok(()) => out = next,
                    Err(e) => misses.push((
                        what,
                        format!("the curve would not bound a proper region: {e}"),
                    )),
                }
            }
            None => {
                if let Some(reason) = miss {
                    misses.push((what, reason));
                }
            }
        }
    }
    (out, misses)
}

/// The loop `pts` with its runs of co-circular edges ([`fit_arcs`]) made arcs, or
/// `None` when it has none.
fn with_arcs(pts: &[DVec2]) -> Option<Loop> {
    let runs = fit_arcs(pts);
    let n = pts.len();
    let first = runs.first()?.first;
    let mut edges = Vec::with_capacity(n);
    let mut next = runs.iter().peekable();
    let mut k = 0;
    while k < n {
        let v = (first + k) % n;
        match next.peek() {
            Some(run) if run.first == v => {
                edges.push(LoopEdge::Arc {
                    start: pts[v],
                    center: run.centre,
                    ccw: run.ccw,
                });
                k += run.edges;
                next.next();
            }
            _ => {
                edges.push(LoopEdge::Segment { start: pts[v] });
                k += 1;
            }
        }
    }
    Some(Loop { edges })
}

/// Checks that a polygon's loops bound a proper region, as a reason string.
fn check_region(poly: &PolygonShape) -> Result<(), Reason> {
    poly.check_region(crate::error::MEMORY_FILE, "")
        .map_err(|e| match e {
            SceneError::Malformed { what, .. } | SceneError::Degenerate { what, .. } => what,
            other => other.to_string(),
        })
}
