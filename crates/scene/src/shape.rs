//! Exact surface shapes as plain data: triangles, parallelograms, triangle meshes (with
//! exact parallelogram pairs merged), complex planar polygons with segment/arc loops
//! and holes (VirtualMesh §3.2), and Bézier patches (Glossy §6's teapot).
//!
//! These are the scene's own descriptions, independent of any intersection code; the
//! solver builds `wavelux-geometry` primitives from them. Orientation: the front side
//! of a triangle `(a, b, c)` is the side of `(b − a) × (c − a)` (counter-clockwise seen
//! from the front, glTF's convention); of a parallelogram, the side of `edge_u × edge_v`;
//! of a polygon, the side of its frame's `u × v`.

use glam::{DVec2, DVec3};

use crate::analytic::AnalyticPatch;
use crate::error::SceneError;

/// Relative tolerance under which a triangle or parallelogram counts as degenerate:
/// `|e1 × e2| <= DEGENERATE_REL · max(|e1|², |e2|²)`, i.e. the sine of its largest
/// angle-like ratio is below `1e-10`.
pub const DEGENERATE_REL: f64 = 1e-10;

/// Relative tolerance of the parallelogram test used when merging triangle pairs:
/// triangles `(r, p, q)` and `(s, q, p)` sharing the diagonal `pq` merge into a
/// parallelogram when `|r + s − p − q| <= MERGE_REL · |p − q|`. `1e-6` is a few ulps of
/// `f32`, the precision of glTF vertex data.
pub const MERGE_REL: f64 = 1e-6;

fn check_finite(v: DVec3, file: &str, element: &str, what: &str) -> Result<(), SceneError> {
    for c in v.to_array() {
        if !c.is_finite() {
            return Err(SceneError::NonFinite {
                file: file.into(),
                element: element.into(),
                what: what.into(),
                value: c,
            });
        }
    }
    Ok(())
}

/// Whether `(e1, e2)` spans a degenerate (zero-area) triangle or parallelogram.
pub fn is_degenerate(e1: DVec3, e2: DVec3) -> bool {
    let scale = e1.length_squared().max(e2.length_squared());
    let cross = e1.cross(e2).length();
    !(scale > 0.0) || !(cross > DEGENERATE_REL * scale)
}

/// One area element of a [`TriangleMesh`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum MeshElement {
    /// A triangle `[a, b, c]`, front side `(b − a) × (c − a)`.
    Triangle([DVec3; 3]),
    /// A parallelogram `origin + s·edge_u + t·edge_v`, `(s, t) ∈ [0,1]²`, front side
    /// `edge_u × edge_v`.
    Parallelogram {
        /// Corner.
        origin: DVec3,
        /// First edge.
        edge_u: DVec3,
        /// Second edge.
        edge_v: DVec3,
    },
}

impl MeshElement {
    /// Area in square scene units.
    pub fn area(&self) -> f64 {
        match self {
            Self::Triangle([a, b, c]) => 0.5 * (*b - *a).cross(*c - *a).length(),
            Self::Parallelogram { edge_u, edge_v, .. } => edge_u.cross(*edge_v).length(),
        }
    }

    /// Unit normal of the front side.
    pub fn normal(&self) -> DVec3 {
        match self {
            Self::Triangle([a, b, c]) => (*b - *a).cross(*c - *a).normalize_or_zero(),
            Self::Parallelogram { edge_u, edge_v, .. } => edge_u.cross(*edge_v).normalize_or_zero(),
        }
    }
}

/// A triangle mesh kept as one surface group (one glTF mesh primitive). Pairs of
/// triangles that form an exact parallelogram are stored as parallelograms (see
/// [`TriangleMesh::build`]) so that planar quads get one big unit-square support.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TriangleMesh {
    /// Vertex positions (world space).
    pub positions: Vec<DVec3>,
    /// Texture-coordinate sets (`TEXCOORD_n`); each has `positions.len()` entries.
    pub uv_sets: Vec<Vec<DVec2>>,
    /// Remaining triangles (vertex indices, counter-clockwise seen from the front).
    pub triangles: Vec<[u32; 3]>,
    /// Merged parallelograms `[o, a, c, b]` (vertex indices in boundary order): the
    /// parallelogram is `o + s (a − o) + t (b − o)`, and `c ≈ a + b − o` within
    /// [`MERGE_REL`].
    pub parallelograms: Vec<[u32; 4]>,
}

/// Result of [`TriangleMesh::build`].
#[derive(Debug, Clone, PartialEq)]
pub struct MeshBuild {
    /// The mesh.
    pub mesh: TriangleMesh,
    /// Number of degenerate triangles dropped.
    pub dropped: usize,
}

impl TriangleMesh {
    /// Builds a mesh from positions and triangles: validates indices, coordinates and
    /// areas (a triangle whose area overflows is a [`SceneError::NonFinite`] error),
    /// drops degenerate triangles (counted in [`MeshBuild::dropped`]) and merges exact
    /// parallelogram pairs.
    ///
    /// Merge rule (deterministic, greedy in triangle order, each triangle's edges tried
    /// longest first): triangle `t = (r, p, q)`
    /// merges with the first unmerged triangle `t'` that traverses the edge `(q, p)`
    /// (the same edge in the opposite direction, i.e. consistent orientation) when
    /// `|r + s − p − q| <= MERGE_REL · |p − q|` with `s` the third vertex of `t'`:
    /// the two triangles then tile the parallelogram with diagonal `pq`. Edges are
    /// matched by vertex *position* (bitwise), so split vertices (seams) still merge.
    pub fn build(
        positions: Vec<DVec3>,
        uv_sets: Vec<Vec<DVec2>>,
        triangles: &[[u32; 3]],
        file: &str,
        element: &str,
    ) -> Result<MeshBuild, SceneError> {
        let n = positions.len();
        for (i, p) in positions.iter().enumerate() {
            check_finite(*p, file, element, &format!("vertex {i}"))?;
        }
        for (k, set) in uv_sets.iter().enumerate() {
            if set.len() != n {
                return Err(SceneError::Malformed {
                    file: file.into(),
                    element: element.into(),
                    what: format!(
                        "texture-coordinate set {k} has {} entries for {n} vertices",
                        set.len()
                    ),
                });
            }
        }
        let mut kept = Vec::with_capacity(triangles.len());
        let mut dropped = 0;
        for (t, tri) in triangles.iter().enumerate() {
            for &i in tri {
                if i as usize >= n {
                    return Err(SceneError::Malformed {
                        file: file.into(),
                        element: element.into(),
                        what: format!("triangle {t} refers to vertex {i} of {n}"),
                    });
                }
            }
            let [a, b, c] = tri.map(|i| positions[i as usize]);
            let twice = (b - a).cross(c - a).length();
            if !twice.is_finite() {
                return Err(SceneError::NonFinite {
                    file: file.into(),
                    element: element.into(),
                    what: format!("area of triangle {t}"),
                    value: 0.5 * twice,
                });
            }
            if is_degenerate(b - a, c - a) || is_degenerate(c - b, a - b) {
                dropped += 1;
            } else {
                kept.push(*tri);
            }
        }
        // Canonical vertex ids by exact position (the smallest index among equal
        // positions), so that seams still merge. Sorting keeps this deterministic and
        // free of hashing.
        let key_of = |p: DVec3| p.to_array().map(|c| (c + 0.0).to_bits());
        let mut order: Vec<u32> = (0..n as u32).collect();
        order.sort_unstable_by_key(|&i| (key_of(positions[i as usize]), i));
        let mut ids = vec![0u32; n];
        let mut g = 0;
        while g < order.len() {
            let first = order[g];
            let key = key_of(positions[first as usize]);
            let mut h = g;
            while h < order.len() && key_of(positions[order[h] as usize]) == key {
                ids[order[h] as usize] = first;
                h += 1;
            }
            g = h;
        }
        // Directed edges (a, b) → triangle, sorted for binary search.
        let mut edges: Vec<(u64, u32)> = Vec::with_capacity(3 * kept.len());
        for (t, tri) in kept.iter().enumerate() {
            for e in 0..3 {
                let (a, b) = (ids[tri[e] as usize], ids[tri[(e + 1) % 3] as usize]);
                edges.push(((u64::from(a) << 32) | u64::from(b), t as u32));
            }
        }
        edges.sort_unstable();
        let owners = |a: u32, b: u32| {
            let k = (u64::from(a) << 32) | u64::from(b);
            let lo = edges.partition_point(|e| e.0 < k);
            edges[lo..]
                .iter()
                .take_while(move |e| e.0 == k)
                .map(|e| e.1 as usize)
        };
        let mut merged = vec![false; kept.len()];
        let mut parallelograms = Vec::new();
        for t in 0..kept.len() {
            if merged[t] {
                continue;
            }
            let tri = kept[t];
            // Longest edge first: a parallelogram split into two triangles shares its
            // diagonal, which for rectangles and most quads is each triangle's longest
            // edge; trying it first avoids pairing across quad sides.
            let len = |e: usize| {
                (positions[tri[(e + 1) % 3] as usize] - positions[tri[e] as usize]).length_squared()
            };
            let mut order = [0usize, 1, 2];
            order.sort_by(|&x, &y| len(y).total_cmp(&len(x)));
            'edges: for e in order {
                // Edge (p, q) of t, opposite vertex r.
                let (pi, qi, ri) = (tri[e], tri[(e + 1) % 3], tri[(e + 2) % 3]);
                let key = (ids[qi as usize], ids[pi as usize]);
                for u in owners(key.0, key.1) {
                    if u == t || merged[u] {
                        continue;
                    }
                    let other = kept[u];
                    // Third vertex of the neighbour.
                    let Some(si) = other
                        .iter()
                        .copied()
                        .find(|&v| ids[v as usize] != key.0 && ids[v as usize] != key.1)
                    else {
                        continue;
                    };
                    let (p, q, r, s) = (
                        positions[pi as usize],
                        positions[qi as usize],
                        positions[ri as usize],
                        positions[si as usize],
                    );
                    let diag = (p - q).length();
                    if (r + s - p - q).length() <= MERGE_REL * diag {
                        merged[t] = true;
                        merged[u] = true;
                        // Boundary order r → p → s → q is counter-clockwise like (r, p, q).
                        parallelograms.push([ri, pi, si, qi]);
                        break 'edges;
                    }
                }
            }
        }
        let triangles = kept
            .iter()
            .zip(&merged)
            .filter(|(_, m)| !**m)
            .map(|(t, _)| *t)
            .collect();
        Ok(MeshBuild {
            mesh: TriangleMesh {
                positions,
                uv_sets,
                triangles,
                parallelograms,
            },
            dropped,
        })
    }

    /// The mesh's area elements: parallelograms first, then triangles.
    pub fn elements(&self) -> impl Iterator<Item = MeshElement> + '_ {
        let p = &self.positions;
        self.parallelograms
            .iter()
            .map(move |q| {
                let o = p[q[0] as usize];
                MeshElement::Parallelogram {
                    origin: o,
                    edge_u: p[q[1] as usize] - o,
                    edge_v: p[q[3] as usize] - o,
                }
            })
            .chain(
                self.triangles
                    .iter()
                    .map(move |t| MeshElement::Triangle(t.map(|i| p[i as usize]))),
            )
    }

    /// Number of area elements.
    pub fn element_count(&self) -> usize {
        self.parallelograms.len() + self.triangles.len()
    }

    /// Number of input triangles represented (each parallelogram counts two).
    pub fn triangle_count(&self) -> usize {
        2 * self.parallelograms.len() + self.triangles.len()
    }
}

/// One edge of a planar loop, in the polygon's 2D frame coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LoopEdge {
    /// A straight segment from `start` to the next edge's start.
    Segment {
        /// Start point.
        start: DVec2,
    },
    /// A circular arc from `start` around `center` to the next edge's start,
    /// counter-clockwise when `ccw`. If the next start equals `start`, the arc is a
    /// full circle.
    Arc {
        /// Start point.
        start: DVec2,
        /// Circle centre.
        center: DVec2,
        /// Direction of travel.
        ccw: bool,
    },
}

impl LoopEdge {
    /// The start point.
    pub fn start(&self) -> DVec2 {
        match self {
            Self::Segment { start } | Self::Arc { start, .. } => *start,
        }
    }
}

/// A closed planar loop of segments and arcs.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Loop {
    /// The edges in order; edge `i` ends where edge `i + 1` (cyclically) starts.
    pub edges: Vec<LoopEdge>,
}

/// Signed angle swept by an arc from `p0` to `p1` around `center`: in `(0, 2π]` when
/// counter-clockwise (a full circle when `p1 == p0`), in `[−2π, 0)` when clockwise.
pub fn arc_sweep(p0: DVec2, p1: DVec2, center: DVec2, ccw: bool) -> f64 {
    let tau = std::f64::consts::TAU;
    let a0 = (p0 - center).to_angle();
    let a1 = (p1 - center).to_angle();
    let d = (a1 - a0).rem_euclid(tau);
    let d = if d == 0.0 || p0 == p1 { tau } else { d };
    match (ccw, d == tau) {
        (true, _) => d,
        (false, true) => -tau,
        (false, false) => d - tau,
    }
}

/// Relative tolerance for an arc's end point lying on its circle.
pub const ARC_REL: f64 = 1e-9;

impl Loop {
    /// A polygonal loop through `points`.
    pub fn polygon(points: &[DVec2]) -> Self {
        Self {
            edges: points
                .iter()
                .map(|p| LoopEdge::Segment { start: *p })
                .collect(),
        }
    }

    /// A full circle (one arc edge), counter-clockwise.
    pub fn circle(center: DVec2, radius: f64) -> Self {
        Self {
            edges: vec![LoopEdge::Arc {
                start: center + DVec2::new(radius, 0.0),
                center,
                ccw: true,
            }],
        }
    }

    /// Signed enclosed area (positive for counter-clockwise loops), exact for
    /// segments and arcs (Green's theorem: `½∮ x dy − y dx`; an arc of radius `r`
    /// sweeping `Δθ` around `c` from `p₀` to `p₁` contributes
    /// `½[r² Δθ + c × (p₁ − p₀)]`).
    pub fn signed_area(&self) -> f64 {
        let n = self.edges.len();
        let mut twice = 0.0;
        for i in 0..n {
            let p0 = self.edges[i].start();
            let p1 = self.edges[(i + 1) % n].start();
            match self.edges[i] {
                LoopEdge::Segment { .. } => twice += p0.perp_dot(p1),
                LoopEdge::Arc { center, ccw, .. } => {
                    let r = (p0 - center).length();
                    let sweep = arc_sweep(p0, p1, center, ccw);
                    twice += r * r * sweep + center.perp_dot(p1 - p0);
                }
            }
        }
        0.5 * twice
    }

    fn validate(&self, file: &str, element: &str, which: &str) -> Result<(), SceneError> {
        let bad = |what: String| SceneError::Malformed {
            file: file.into(),
            element: element.into(),
            what,
        };
        if self.edges.is_empty() {
            return Err(bad(format!("{which} loop has no edges")));
        }
        let n = self.edges.len();
        for i in 0..n {
            let e = self.edges[i];
            let mut pts = vec![e.start()];
            if let LoopEdge::Arc { center, .. } = e {
                pts.push(center);
            }
            for p in pts {
                for c in p.to_array() {
                    if !c.is_finite() {
                        return Err(SceneError::NonFinite {
                            file: file.into(),
                            element: element.into(),
                            what: format!("{which} loop edge {i}"),
                            value: c,
                        });
                    }
                }
            }
            if let LoopEdge::Arc { start, center, .. } = e {
                let end = self.edges[(i + 1) % n].start();
                let (r0, r1) = ((start - center).length(), (end - center).length());
                if !(r0 > 0.0) || (r0 - r1).abs() > ARC_REL * r0.max(1.0) {
                    return Err(bad(format!(
                        "{which} loop arc {i}: start radius {r0} and end radius {r1} differ or are zero"
                    )));
                }
            }
        }
        if n < 3
            && self
                .edges
                .iter()
                .all(|e| matches!(e, LoopEdge::Segment { .. }))
        {
            return Err(bad(format!("{which} loop has fewer than 3 vertices")));
        }
        Ok(())
    }
}

/// An orthonormal frame of a plane: points are `origin + x·u + y·v`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlaneFrame {
    /// A point of the plane.
    pub origin: DVec3,
    /// First unit axis.
    pub u: DVec3,
    /// Second unit axis, orthogonal to `u`; the front normal is `u × v`.
    pub v: DVec3,
}

impl PlaneFrame {
    /// A frame from an origin and two (not necessarily orthonormal) in-plane
    /// directions: `u` is normalised, `v` is Gram–Schmidt-orthogonalised against it.
    /// Returns `None` if the directions are degenerate or not finite.
    pub fn from_directions(origin: DVec3, u: DVec3, v: DVec3) -> Option<Self> {
        let u = u.try_normalize()?;
        let v = (v - u * u.dot(v)).try_normalize()?;
        Some(Self { origin, u, v })
    }

    /// The 3D point of 2D frame coordinates `p`.
    pub fn point(&self, p: DVec2) -> DVec3 {
        self.origin + self.u * p.x + self.v * p.y
    }

    /// Unit front normal `u × v`.
    pub fn normal(&self) -> DVec3 {
        self.u.cross(self.v)
    }
}

/// A complex planar polygon (VirtualMesh §3.2): an outer loop and holes, each made of
/// segments and circular arcs, in a plane frame.
#[derive(Debug, Clone, PartialEq)]
pub struct PolygonShape {
    /// The plane.
    pub frame: PlaneFrame,
    /// Outer boundary (either orientation; the front side is the frame's normal).
    pub outer: Loop,
    /// Holes (either orientation), inside the outer loop and disjoint.
    pub holes: Vec<Loop>,
}

impl PolygonShape {
    /// Checks that the loops bound a proper region: no loop crosses itself, every hole
    /// lies inside the outer loop, no two holes overlap (touching along an edge or at a
    /// point is allowed). Exactly then [`PolygonShape::area`] is the region's area.
    ///
    /// # Errors
    /// [`SceneError::Malformed`] naming `file`, `element` and the offending loop.
    pub fn check_region(&self, file: &str, element: &str) -> Result<(), SceneError> {
        check_loops(&self.outer, &self.holes, file, element, "")
    }

    /// Area: `|outer| − Σ |hole|` (exact when [`PolygonShape::check_region`] holds).
    pub fn area(&self) -> f64 {
        self.outer.signed_area().abs()
            - self
                .holes
                .iter()
                .map(|h| h.signed_area().abs())
                .sum::<f64>()
    }
}

/// A tensor-product Bézier patch of degrees `(degree_u, degree_v)`, each in `1..=3`
/// (Glossy §6 uses bicubic patches; lower degrees are elevated exactly to bicubic for
/// `wavelux-param`/`wavelux-geometry`). Front side: `∂P/∂u × ∂P/∂v`.
#[derive(Debug, Clone, PartialEq)]
pub struct BezierPatch {
    /// Degree in `u` (`1..=3`).
    pub degree_u: usize,
    /// Degree in `v` (`1..=3`).
    pub degree_v: usize,
    /// `(degree_u + 1) × (degree_v + 1)` control points, index `i·(degree_v+1) + j`
    /// for `u`-index `i`, `v`-index `j`.
    pub control: Vec<DVec3>,
}

impl BezierPatch {
    /// Evaluates the patch and its partial derivatives at `(u, v) ∈ [0,1]²` by de
    /// Casteljau's algorithm; returns `(P, ∂P/∂u, ∂P/∂v)` (NaN for a patch whose
    /// control-point count does not match its degrees).
    pub fn eval(&self, u: f64, v: f64) -> (DVec3, DVec3, DVec3) {
        let (m, n) = (self.degree_u, self.degree_v);
        if m == 0 || n == 0 || self.control.len() != (m + 1) * (n + 1) {
            return (DVec3::NAN, DVec3::NAN, DVec3::NAN);
        }
        // Reduce along v for each u-row, keeping the last two points for ∂/∂v.
        let casteljau = |pts: &mut Vec<DVec3>, t: f64| -> (DVec3, DVec3) {
            let k = pts.len() - 1;
            for level in 1..k {
                for i in 0..=(k - level) {
                    pts[i] = pts[i].lerp(pts[i + 1], t);
                }
            }
            let (a, b) = (pts[0], pts[1]);
            (a.lerp(b, t), (b - a) * k as f64)
        };
        let mut rows = Vec::with_capacity(m + 1);
        let mut drows = Vec::with_capacity(m + 1);
        for i in 0..=m {
            let mut pts = self.control[i * (n + 1)..(i + 1) * (n + 1)].to_vec();
            let (p, d) = casteljau(&mut pts, v);
            rows.push(p);
            drows.push(d);
        }
        let (p, du) = casteljau(&mut rows.clone(), u);
        let (dv, _) = casteljau(&mut drows, u);
        (p, du, dv)
    }

    /// The same patch as a bicubic 4×4 control net `[i][j]` (`i` along `u`), by exact
    /// degree elevation; NaN for an invalid patch (see [`Shape::validate`]).
    pub fn bicubic(&self) -> [[DVec3; 4]; 4] {
        // Elevate one polygon of degree n by one: Q_i = i/(n+1) P_{i−1} + (1 − i/(n+1)) P_i.
        fn elevate(p: &[DVec3]) -> Vec<DVec3> {
            let n = p.len() - 1;
            (0..=n + 1)
                .map(|i| {
                    let a = i as f64 / (n + 1) as f64;
                    let prev = if i > 0 { p[i - 1] } else { DVec3::ZERO };
                    let cur = if i <= n { p[i] } else { DVec3::ZERO };
                    prev * a + cur * (1.0 - a)
                })
                .collect()
        }
        fn to_cubic(mut p: Vec<DVec3>) -> Vec<DVec3> {
            while p.len() < 4 {
                p = elevate(&p);
            }
            p
        }
        let (m, n) = (self.degree_u, self.degree_v);
        if !(1..=3).contains(&m) || !(1..=3).contains(&n) || self.control.len() != (m + 1) * (n + 1)
        {
            return [[DVec3::NAN; 4]; 4];
        }
        // Elevate along v for each u-row, then along u for each v-column.
        let rows: Vec<Vec<DVec3>> = (0..=m)
            .map(|i| to_cubic(self.control[i * (n + 1)..(i + 1) * (n + 1)].to_vec()))
            .collect();
        let mut out = [[DVec3::ZERO; 4]; 4];
        for j in 0..4 {
            let col = to_cubic(rows.iter().map(|r| r[j]).collect());
            for i in 0..4 {
                out[i][j] = col[i];
            }
        }
        out
    }

    fn validate(&self, file: &str, element: &str) -> Result<(), SceneError> {
        let ok_deg = |d: usize| (1..=3).contains(&d);
        if !ok_deg(self.degree_u) || !ok_deg(self.degree_v) {
            return Err(SceneError::Unsupported {
                file: file.into(),
                element: element.into(),
                what: format!(
                    "Bézier degrees ({}, {}) outside 1..=3",
                    self.degree_u, self.degree_v
                ),
            });
        }
        let want = (self.degree_u + 1) * (self.degree_v + 1);
        if self.control.len() != want {
            return Err(SceneError::Malformed {
                file: file.into(),
                element: element.into(),
                what: format!(
                    "Bézier patch has {} control points, expected {want}",
                    self.control.len()
                ),
            });
        }
        for (i, p) in self.control.iter().enumerate() {
            check_finite(*p, file, element, &format!("control point {i}"))?;
        }
        Ok(())
    }
}

/// The exact geometry of a surface.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum Shape {
    /// One triangle `[a, b, c]`.
    Triangle([DVec3; 3]),
    /// A parallelogram `origin + s·edge_u + t·edge_v`, `(s, t) ∈ [0, 1]²`.
    Parallelogram {
        /// Corner.
        origin: DVec3,
        /// First edge.
        edge_u: DVec3,
        /// Second edge.
        edge_v: DVec3,
    },
    /// A triangle mesh group (one glTF mesh primitive).
    Mesh(TriangleMesh),
    /// A complex planar polygon with holes.
    Polygon(PolygonShape),
    /// A Bézier patch.
    Bezier(BezierPatch),
    /// A (trimmed) analytic patch on an equal-area parametrization.
    Patch(AnalyticPatch),
}

impl Shape {
    /// An axis-aligned-or-not rectangle/parallelogram from its corner and edges.
    pub fn parallelogram(origin: DVec3, edge_u: DVec3, edge_v: DVec3) -> Self {
        Self::Parallelogram {
            origin,
            edge_u,
            edge_v,
        }
    }

    /// Area in square scene units. Exact (closed form) for triangles, parallelograms,
    /// meshes and polygons; analytic patches use `wavelux-param`'s area times the trim
    /// fraction (exact because the maps are equal-area; numerical for the torus and
    /// spheroids where `wavelux-param` integrates); Bézier patches use
    /// `wavelux-param`'s numerical area. NaN for shapes that fail validation.
    pub fn area(&self) -> f64 {
        match self {
            Self::Triangle([a, b, c]) => 0.5 * (*b - *a).cross(*c - *a).length(),
            Self::Parallelogram { edge_u, edge_v, .. } => edge_u.cross(*edge_v).length(),
            Self::Mesh(m) => m.elements().map(|e| e.area()).sum(),
            Self::Polygon(p) => p.area(),
            Self::Bezier(b) => bezier_area(b),
            Self::Patch(p) => patch_area(p),
        }
    }

    /// Checks coordinates (finite), structure (indices, loop closure, control-point
    /// counts, holes inside their outer loop and disjoint, no loop crossing itself) and
    /// the area: zero or non-finite area (e.g. a parallelogram with `1e308` edges) is an
    /// error, never a surface silently dropped.
    pub fn validate(&self, file: &str, element: &str) -> Result<(), SceneError> {
        self.validate_structure(file, element)?;
        let area = self.area();
        if !area.is_finite() {
            return Err(SceneError::NonFinite {
                file: file.into(),
                element: element.into(),
                what: "area".into(),
                value: area,
            });
        }
        if !(area > 0.0) {
            return Err(SceneError::Degenerate {
                file: file.into(),
                element: element.into(),
                what: format!("surface has zero area ({area})"),
            });
        }
        Ok(())
    }

    fn validate_structure(&self, file: &str, element: &str) -> Result<(), SceneError> {
        let degenerate = |what: &str| SceneError::Degenerate {
            file: file.into(),
            element: element.into(),
            what: what.into(),
        };
        let finite_area = |area: f64| {
            if area.is_finite() {
                Ok(())
            } else {
                Err(SceneError::NonFinite {
                    file: file.into(),
                    element: element.into(),
                    what: "area".into(),
                    value: area,
                })
            }
        };
        match self {
            Self::Triangle(v) => {
                for (i, p) in v.iter().enumerate() {
                    check_finite(*p, file, element, &format!("vertex {i}"))?;
                }
                finite_area(self.area())?;
                if is_degenerate(v[1] - v[0], v[2] - v[0]) {
                    return Err(degenerate("triangle has zero area"));
                }
            }
            Self::Parallelogram {
                origin,
                edge_u,
                edge_v,
            } => {
                check_finite(*origin, file, element, "origin")?;
                check_finite(*edge_u, file, element, "edge_u")?;
                check_finite(*edge_v, file, element, "edge_v")?;
                finite_area(self.area())?;
                if is_degenerate(*edge_u, *edge_v) {
                    return Err(degenerate("parallelogram has zero area"));
                }
            }
            Self::Mesh(m) => {
                for (i, p) in m.positions.iter().enumerate() {
                    check_finite(*p, file, element, &format!("vertex {i}"))?;
                }
                let n = m.positions.len();
                let bad = m
                    .triangles
                    .iter()
                    .flatten()
                    .chain(m.parallelograms.iter().flatten())
                    .any(|&i| i as usize >= n);
                if bad {
                    return Err(SceneError::Malformed {
                        file: file.into(),
                        element: element.into(),
                        what: "vertex index out of range".into(),
                    });
                }
                if m.element_count() == 0 {
                    return Err(degenerate("mesh has no non-degenerate triangle"));
                }
            }
            Self::Polygon(p) => {
                check_finite(p.frame.origin, file, element, "frame origin")?;
                check_finite(p.frame.u, file, element, "frame u")?;
                check_finite(p.frame.v, file, element, "frame v")?;
                let f = &p.frame;
                if (f.u.length() - 1.0).abs() > 1e-9
                    || (f.v.length() - 1.0).abs() > 1e-9
                    || f.u.dot(f.v).abs() > 1e-9
                {
                    return Err(SceneError::Malformed {
                        file: file.into(),
                        element: element.into(),
                        what: "polygon frame axes are not orthonormal".into(),
                    });
                }
                p.outer.validate(file, element, "outer")?;
                for (i, h) in p.holes.iter().enumerate() {
                    h.validate(file, element, &format!("hole {i}"))?;
                }
                p.check_region(file, element)?;
            }
            Self::Bezier(b) => {
                b.validate(file, element)?;
                self.primitives(file, element)?;
            }
            Self::Patch(p) => {
                if let Some(r) = &p.trim {
                    r.outer.validate(file, element, "trim outer")?;
                    for (i, h) in r.holes.iter().enumerate() {
                        h.validate(file, element, &format!("trim hole {i}"))?;
                    }
                    check_loops(&r.outer, &r.holes, file, element, "trim ")?;
                }
                p.surface.parametrization(file, element)?;
                self.primitives(file, element)?;
                if !(patch_area(p) > 0.0) {
                    return Err(degenerate("analytic patch has zero area"));
                }
            }
        }
        Ok(())
    }

    /// Number of elementary pieces (1 except for meshes).
    pub fn element_count(&self) -> usize {
        match self {
            Self::Mesh(m) => m.element_count(),
            _ => 1,
        }
    }

    /// Applies an affine map `x ↦ m·x + t` given as a 4×4 matrix to every point
    /// (polygons: the frame is re-orthonormalised only if the map is a similarity, so
    /// non-similarity maps return `None` for polygons; Bézier patches and meshes
    /// are affine-invariant).
    pub fn transformed(&self, m: &glam::DMat4) -> Option<Self> {
        let p = |x: DVec3| m.transform_point3(x);
        let d = |x: DVec3| m.transform_vector3(x);
        Some(match self {
            Self::Triangle(v) => Self::Triangle(v.map(p)),
            Self::Parallelogram {
                origin,
                edge_u,
                edge_v,
            } => Self::Parallelogram {
                origin: p(*origin),
                edge_u: d(*edge_u),
                edge_v: d(*edge_v),
            },
            Self::Mesh(mesh) => {
                let mut mesh = mesh.clone();
                for x in &mut mesh.positions {
                    *x = p(*x);
                }
                if m.determinant() < 0.0 {
                    for t in &mut mesh.triangles {
                        t.swap(1, 2);
                    }
                    for q in &mut mesh.parallelograms {
                        q.swap(1, 3);
                    }
                }
                Self::Mesh(mesh)
            }
            Self::Polygon(poly) => {
                let (u, v) = (d(poly.frame.u), d(poly.frame.v));
                let s = u.length();
                if !(s > 0.0)
                    || (v.length() - s).abs() > 1e-12 * s
                    || u.dot(v).abs() > 1e-12 * s * s
                {
                    return None;
                }
                let scale = |l: &Loop| Loop {
                    edges: l
                        .edges
                        .iter()
                        .map(|e| match *e {
                            LoopEdge::Segment { start } => LoopEdge::Segment { start: start * s },
                            LoopEdge::Arc { start, center, ccw } => LoopEdge::Arc {
                                start: start * s,
                                center: center * s,
                                ccw,
                            },
                        })
                        .collect(),
                };
                Self::Polygon(PolygonShape {
                    frame: PlaneFrame {
                        origin: p(poly.frame.origin),
                        u: u / s,
                        v: v / s,
                    },
                    outer: scale(&poly.outer),
                    holes: poly.holes.iter().map(scale).collect(),
                })
            }
            Self::Patch(p) => Self::Patch(AnalyticPatch {
                surface: p.surface.transformed(m)?,
                trim: p.trim.clone(),
            }),
            Self::Bezier(b) => Self::Bezier(BezierPatch {
                degree_u: b.degree_u,
                degree_v: b.degree_v,
                control: b.control.iter().map(|x| p(*x)).collect(),
            }),
        })
    }
}

/// Bézier patch area from `wavelux-param` (NaN if the patch is invalid).
fn bezier_area(b: &BezierPatch) -> f64 {
    use wavelux_param::Parametrization;
    if b.validate(crate::error::MEMORY_FILE, "").is_err() {
        return f64::NAN;
    }
    wavelux_param::BezierPatch::new(b.bicubic()).map_or(f64::NAN, |p| p.area())
}

/// Analytic patch area: untrimmed area × trim fraction (NaN if invalid).
fn patch_area(p: &AnalyticPatch) -> f64 {
    p.surface
        .parametrization(crate::error::MEMORY_FILE, "")
        .map_or(f64::NAN, |s| s.area() * p.trim_fraction())
}

fn gerr(file: &str, element: &str, e: wavelux_geometry::GeometryError) -> SceneError {
    match e {
        wavelux_geometry::GeometryError::Degenerate(what) => SceneError::Degenerate {
            file: file.into(),
            element: element.into(),
            what: what.into(),
        },
        other => SceneError::Malformed {
            file: file.into(),
            element: element.into(),
            what: other.to_string(),
        },
    }
}

impl Loop {
    /// The loop as a `wavelux-geometry` trim loop, counter-clockwise if `ccw`, else
    /// clockwise.
    pub fn to_trim_loop(
        &self,
        ccw: bool,
        file: &str,
        element: &str,
    ) -> Result<wavelux_geometry::TrimLoop, SceneError> {
        use wavelux_geometry::{Edge2, TrimLoop};
        let n = self.edges.len();
        let mut edges = Vec::with_capacity(n);
        for i in 0..n {
            let p0 = self.edges[i].start();
            let p1 = self.edges[(i + 1) % n].start();
            let e = match self.edges[i] {
                LoopEdge::Segment { .. } => Edge2::segment(p0, p1),
                LoopEdge::Arc { center, ccw, .. } => Edge2::arc(
                    center,
                    (p0 - center).length(),
                    (p0 - center).to_angle(),
                    arc_sweep(p0, p1, center, ccw),
                ),
            }
            .map_err(|e| gerr(file, element, e))?;
            edges.push(e);
        }
        let l = TrimLoop::new(edges).map_err(|e| gerr(file, element, e))?;
        Ok(if (l.signed_area() > 0.0) == ccw {
            l
        } else {
            l.reversed()
        })
    }
}

/// The loops as a checked `wavelux-geometry` trim region (outer counter-clockwise,
/// holes clockwise). Loops that do not bound a proper region give
/// [`SceneError::Malformed`] naming the loop; `which` prefixes the loop names
/// (`"trim "` for trims).
fn trim_region(
    outer: &Loop,
    holes: &[Loop],
    file: &str,
    element: &str,
    which: &str,
) -> Result<wavelux_geometry::TrimRegion, SceneError> {
    use wavelux_geometry::{GeometryError, RegionFault};
    let mut loops = vec![outer.to_trim_loop(true, file, element)?];
    for h in holes {
        loops.push(h.to_trim_loop(false, file, element)?);
    }
    // Region loop 0 is the outer loop, loop k + 1 is hole k.
    let name = |i: usize| match i {
        0 => "outer loop".to_string(),
        i => format!("hole {}", i - 1),
    };
    wavelux_geometry::TrimRegion::new(loops).map_err(|e| match e {
        GeometryError::Region(fault) => SceneError::Malformed {
            file: file.into(),
            element: element.into(),
            what: match fault {
                RegionFault::SelfCrossing { index } => {
                    format!("{which}{} crosses or overlaps itself", name(index))
                }
                RegionFault::HoleOutside { index } => format!(
                    "{which}{} is not inside the outer loop (it lies outside or crosses it)",
                    name(index)
                ),
                RegionFault::Overlap { a, b } if a > 0 => {
                    format!("{which}holes {} and {} overlap", a - 1, b - 1)
                }
                RegionFault::Overlap { b, .. } => {
                    format!("{which}outer loop and {} overlap", name(b))
                }
                RegionFault::Unresolved => format!("{which}holes overlap each other"),
            },
        },
        other => gerr(file, element, other),
    })
}

/// Checks an outer loop and its holes (see [`PolygonShape::check_region`]); `which`
/// prefixes the loop names (`"trim "` for trims).
fn check_loops(
    outer: &Loop,
    holes: &[Loop],
    file: &str,
    element: &str,
    which: &str,
) -> Result<(), SceneError> {
    trim_region(outer, holes, file, element, which).map(|_| ())
}

impl Shape {
    /// Builds the exact `wavelux-geometry` primitives of the shape (one per mesh
    /// element; one otherwise). `file` and `element` name the shape in errors.
    pub fn primitives(
        &self,
        file: &str,
        element: &str,
    ) -> Result<Vec<wavelux_geometry::Primitive>, SceneError> {
        use wavelux_geometry as g;
        let err = |e| gerr(file, element, e);
        Ok(match self {
            Self::Triangle([a, b, c]) => {
                vec![g::Primitive::Triangle(
                    g::Triangle::new(*a, *b, *c).map_err(err)?,
                )]
            }
            Self::Parallelogram {
                origin,
                edge_u,
                edge_v,
            } => vec![g::Primitive::Parallelogram(
                g::Parallelogram::new(*origin, *edge_u, *edge_v).map_err(err)?,
            )],
            Self::Mesh(m) => m
                .elements()
                .map(|e| match e {
                    MeshElement::Triangle([a, b, c]) => {
                        g::Triangle::new(a, b, c).map(g::Primitive::Triangle)
                    }
                    MeshElement::Parallelogram {
                        origin,
                        edge_u,
                        edge_v,
                    } => g::Parallelogram::new(origin, edge_u, edge_v)
                        .map(g::Primitive::Parallelogram),
                })
                .collect::<Result<_, _>>()
                .map_err(err)?,
            Self::Polygon(p) => {
                let frame =
                    g::PlaneFrame::from_axes(p.frame.origin, p.frame.u, p.frame.v).map_err(err)?;
                let region = trim_region(&p.outer, &p.holes, file, element, "")?;
                vec![g::Primitive::Polygon(Box::new(
                    g::ComplexPolygon::new(frame, region).map_err(err)?,
                ))]
            }
            Self::Bezier(b) => {
                b.validate(file, element)?;
                vec![g::Primitive::Bezier(Box::new(
                    g::BezierPatch::new(b.bicubic()).map_err(err)?,
                ))]
            }
            Self::Patch(p) => {
                let surface = p.surface.parametrization(file, element)?;
                let trim = match &p.trim {
                    Some(r) => Some(trim_region(&r.outer, &r.holes, file, element, "trim ")?),
                    None => None,
                };
                vec![g::Primitive::Trimmed(Box::new(
                    g::TrimmedPatch::new(surface, trim).map_err(err)?,
                ))]
            }
        })
    }
}
