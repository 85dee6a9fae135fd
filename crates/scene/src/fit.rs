//! Curved-surface recognition for mesh grouping (issue 11 §3: "recognise curved patches
//! where the input allows"): a closed triangle mesh whose vertices all lie on one sphere,
//! an open one whose vertices all lie on one cylinder or cone, a polygon loop whose
//! vertices all lie on one circle, and runs of a loop's edges that do (rounded corners,
//! a slot's ends), each fine enough to be meant as that surface, become that surface: a
//! sphere, cylinder or cone patch on the equal-area parametrization (VirtualMesh §3.1
//! and Appendix A.1) with one support, or a loop made of one circular arc (a disk, an
//! annulus, a round hole) or of arcs and segments (VirtualMesh §4's exact masks handle
//! arcs), instead of hundreds of facets or a polygon of hundreds of edges.
//!
//! A cone's axis is the direction every facet normal makes the same angle with (the
//! smallest eigenvector of the normals' area-weighted covariance; a cylinder's normals
//! are all orthogonal to it), its apex the point nearest to every facet's plane (a
//! cone's facets between two generators lie in planes through the apex).
//!
//! # Criteria (all must hold)
//!
//! Every tolerance is relative to the fitted radius `R`, so recognition does not depend
//! on the scene's scale or position.
//!
//! - **Vertices**: every vertex lies within [`SPHERE_VERTEX_REL`]` × R` of the
//!   least-squares sphere (circle, cylinder); algebraic fits on centred, scaled
//!   coordinates; the cylinder's axis is the direction its facet normals are
//!   orthogonal to (smallest eigenvector of `Σ area · n nᵀ`).
//! - **Facets / edges**: every facet's plane (every loop edge's line) is within
//!   [`SPHERE_FACET_REL`]` × R` of the surface, all on the same side: a facet or edge
//!   spans at most [`max_arc`]` = 2 acos(0.98) ≈ 23.1°` of arc. A 16-gon and a
//!   16-sector cylinder are recognised (22.5° per edge); a 12-gon, an icosahedron or an
//!   8 × 4 UV sphere (meant as polyhedra, or too coarse to tell) are not.
//! - **Coverage**: the facets cover the surface exactly once: signed solid angle `±4π`
//!   from the sphere's centre; for a cylinder, signed area `±Δθ·Δh` in the `(θ, h)`
//!   plane with every facet of one sign (no hole, fold or trimmed edge); a loop winds
//!   once around the circle's centre.
//! - **Enough evidence**: a circle needs [`MIN_CIRCLE_VERTICES`] vertices, a partial
//!   arc [`MIN_ARC_EDGES`] edges (and the outline must leave its circle at both ends,
//!   see [`fit_arcs`]); a cylinder or cone patch at least [`MIN_GENERATORS`] distinct
//!   generator lines and an azimuth span of at least [`MIN_CYLINDER_SPAN`] (a flat or
//!   barely bent strip stays facets); a cone's radius must change along the patch by at
//!   least ten times its vertices' scatter (less is a cylinder, or a jittered one).
//!   Cone tolerances are relative to the patch's largest radius.
//!
//! # Near misses
//!
//! A candidate whose vertices all lie within [`NEAR_MISS_REL`]` × R` of the fitted
//! surface but that fails a criterion above (an ellipse, jittered vertices, a cylinder
//! with a window cut out) stays facets or a polygon and
//! the caller reports why ([`crate::WarningKind::CurveNotRecognised`]); anything
//! farther from every circle, cylinder and sphere is a free-form or polyhedral surface
//! and stays facets silently.
//!
//! The recognised surface's area exceeds the facets' by about their relative sagitta
//! (0.1 % for a 72 × 36 UV sphere, 0.04 % for a 128-gon): the recognised surface is the
//! one the mesh approximates, which is the point; `MeshGrouping::Triangles` keeps the
//! facets.

use glam::{DMat3, DMat4, DVec2, DVec3, DVec4};

/// Vertex tolerance of the sphere fit, relative to the fitted radius: `1e-5` (about 100
/// `f32` ulps, room for positions computed in `f32` trigonometry).
pub const SPHERE_VERTEX_REL: f64 = 1e-5;

/// Facet tolerance of the sphere fit, relative to the fitted radius: every facet's plane
/// is within `0.02 R` of the sphere (see the module docs).
pub const SPHERE_FACET_REL: f64 = 0.02;

/// Fewest vertices of a loop recognised as a circle (with the edge criterion, a full
/// circle needs 16 anyway).
pub const MIN_CIRCLE_VERTICES: usize = 16;

/// Fewest distinct generator lines (vertex azimuths) of a cylinder patch: with fewer,
/// three points always lie on some circle and the fit proves nothing.
pub const MIN_GENERATORS: usize = 5;

/// Smallest azimuth span of a recognised cylinder patch: `π/6` (30°).
pub const MIN_CYLINDER_SPAN: f64 = std::f64::consts::FRAC_PI_6;

/// A candidate whose vertices all lie within `NEAR_MISS_REL × R` of the fitted surface
/// but that is not recognised is reported (see the module docs).
pub const NEAR_MISS_REL: f64 = 0.25;

/// The largest arc one facet or loop edge may span: `2 acos(1 − SPHERE_FACET_REL)`
/// (radians; ≈ 23.07°).
pub fn max_arc() -> f64 {
    2.0 * (1.0 - SPHERE_FACET_REL).acos()
}

/// Why a candidate was not recognised: `None` when it is not a candidate at all (far
/// from the surface, too few vertices), else the failing criterion in words.
pub(crate) type Miss = Option<String>;

/// A sphere fitted to a closed mesh.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct SphereFit {
    /// Centre.
    pub centre: DVec3,
    /// Radius.
    pub radius: f64,
    /// The facets face the centre (the mesh's front side is the sphere's inside).
    pub inward: bool,
}

/// The sphere a closed, consistently oriented set of triangles (vertex indices into
/// `p`) tessellates, by the criteria of the module docs, or `None`.
pub(crate) fn fit_sphere(p: &[DVec3], tris: &[[u32; 3]]) -> Option<SphereFit> {
    let mut ids: Vec<u32> = tris.iter().flatten().copied().collect();
    ids.sort_unstable();
    ids.dedup();
    if ids.len() < 4 {
        return None;
    }
    let mean = ids.iter().map(|&i| p[i as usize]).sum::<DVec3>() / ids.len() as f64;
    let scale = ids
        .iter()
        .map(|&i| (p[i as usize] - mean).length())
        .fold(0.0, f64::max);
    if !(scale > 0.0) {
        return None;
    }
    // |x|² = 2 c·x + k, least squares on x = (p − mean)/scale: normal equations.
    let mut ata = [[0.0f64; 4]; 4];
    let mut atb = [0.0f64; 4];
    for &i in &ids {
        let x = (p[i as usize] - mean) / scale;
        let row = [2.0 * x.x, 2.0 * x.y, 2.0 * x.z, 1.0];
        let b = x.length_squared();
        for r in 0..4 {
            atb[r] += row[r] * b;
            for c in 0..4 {
                ata[r][c] += row[r] * row[c];
            }
        }
    }
    let m = DMat4::from_cols_array_2d(&ata);
    if !(m.determinant().abs() > 1e-12 * (ids.len() as f64).powi(4)) {
        return None;
    }
    let sol = m.inverse() * DVec4::from_array(atb);
    let c = DVec3::new(sol.x, sol.y, sol.z);
    let r2 = sol.w + c.length_squared();
    if !(r2 > 0.0) {
        return None;
    }
    let centre = mean + scale * c;
    let radius = scale * r2.sqrt();
    if ids
        .iter()
        .any(|&i| ((p[i as usize] - centre).length() - radius).abs() > SPHERE_VERTEX_REL * radius)
    {
        return None;
    }
    // Facets: all on one side, each within the facet tolerance of the sphere.
    let mut sign = 0.0;
    let mut solid = 0.0;
    for t in tris {
        let [a, b, d] = t.map(|i| p[i as usize] - centre);
        let n = (b - a).cross(d - a).normalize_or_zero();
        let h = n.dot(a);
        if sign == 0.0 {
            sign = h.signum();
        }
        if !(sign * h >= (1.0 - SPHERE_FACET_REL) * radius) {
            return None;
        }
        solid += solid_angle(a, b, d);
    }
    // Covered once: signed solid angle ±4π (its sign is the facets' side).
    let full = 4.0 * std::f64::consts::PI;
    if !((sign * solid - full).abs() <= 1e-6 * full) {
        return None;
    }
    Some(SphereFit {
        centre,
        radius,
        inward: sign < 0.0,
    })
}

/// A circle fitted to a closed planar loop (2D frame coordinates).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct CircleFit {
    /// Centre.
    pub centre: DVec2,
    /// Radius.
    pub radius: f64,
}

/// Least-squares circle `|x|² = 2 c·x + k` through 2D points (on centred, scaled
/// coordinates), or `None` for collinear or too few points.
fn kasa(pts: &[DVec2]) -> Option<(DVec2, f64)> {
    if pts.len() < 3 {
        return None;
    }
    let mean = pts.iter().copied().sum::<DVec2>() / pts.len() as f64;
    let scale = pts.iter().map(|&q| (q - mean).length()).fold(0.0, f64::max);
    if !(scale > 0.0) {
        return None;
    }
    let mut ata = [[0.0f64; 3]; 3];
    let mut atb = [0.0f64; 3];
    for &q in pts {
        let x = (q - mean) / scale;
        let row = [2.0 * x.x, 2.0 * x.y, 1.0];
        let b = x.length_squared();
        for r in 0..3 {
            atb[r] += row[r] * b;
            for c in 0..3 {
                ata[r][c] += row[r] * row[c];
            }
        }
    }
    let m = DMat3::from_cols_array_2d(&ata);
    if !(m.determinant().abs() > 1e-12 * (pts.len() as f64).powi(3)) {
        return None;
    }
    let sol = m.inverse() * DVec3::from_array(atb);
    let c = DVec2::new(sol.x, sol.y);
    let r2 = sol.z + c.length_squared();
    if !(r2 > 0.0) {
        return None;
    }
    Some((mean + scale * c, scale * r2.sqrt()))
}

/// The largest deviation `| |q − c| − r |` of the points from a circle, and where.
fn deviation(pts: impl Iterator<Item = DVec2>, c: DVec2, r: f64) -> (f64, usize) {
    pts.enumerate()
        .map(|(k, q)| (((q - c).length() - r).abs(), k))
        .fold((0.0, 0), |a, b| if b.0 > a.0 { b } else { a })
}

/// The circle a closed polygonal loop (vertices in order, either orientation)
/// approximates, by the criteria of the module docs, or why not.
pub(crate) fn fit_circle(pts: &[DVec2]) -> Result<CircleFit, Miss> {
    if pts.len() < MIN_CIRCLE_VERTICES {
        return Err(None);
    }
    let (c, r) = kasa(pts).ok_or(None)?;
    let n = pts.len();
    // Winds once around the centre.
    let turn: f64 = (0..n)
        .map(|k| {
            let (a, b) = (pts[k] - c, pts[(k + 1) % n] - c);
            a.perp_dot(b).atan2(a.dot(b))
        })
        .sum();
    if !((turn.abs() - std::f64::consts::TAU).abs() <= 1e-6 * std::f64::consts::TAU) {
        return Err(None);
    }
    let (dev, at) = deviation(pts.iter().copied(), c, r);
    if dev > NEAR_MISS_REL * r {
        return Err(None);
    }
    if dev > SPHERE_VERTEX_REL * r {
        return Err(Some(format!(
            "vertex {at} of {n} is {:.2e} R from the best circle (tolerance {SPHERE_VERTEX_REL:e} R)",
            dev / r
        )));
    }
    for k in 0..n {
        let (a, b) = (pts[k] - c, pts[(k + 1) % n] - c);
        let arc = a.perp_dot(b).atan2(a.dot(b)).abs();
        if arc > max_arc() {
            return Err(Some(format!(
                "edge {k} spans {:.1}° of arc (at most {:.1}° for a circle)",
                arc.to_degrees(),
                max_arc().to_degrees()
            )));
        }
    }
    Ok(CircleFit {
        centre: c,
        radius: r,
    })
}

/// Fewest edges of a run of a polygon loop recognised as a partial arc (a rounded
/// corner, a slot's end): 4 edges, 5 vertices on one circle (three always are).
pub const MIN_ARC_EDGES: usize = 4;

/// A run of consecutive vertices of a polygon loop that lie on one circle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct ArcRun {
    /// Index of the run's first vertex in the loop.
    pub first: usize,
    /// Number of edges of the run (its last vertex is `first + edges`, cyclically).
    pub edges: usize,
    /// Centre, equidistant from the run's two end vertices (to rounding).
    pub centre: DVec2,
    /// The run turns counter-clockwise about the centre.
    pub ccw: bool,
}

/// The maximal runs of at least [`MIN_ARC_EDGES`] edges of a closed polygonal loop
/// (vertices in order, no straight vertices) whose vertices lie on one circle by the
/// vertex and edge criteria of the module docs (each edge at most [`max_arc`], all
/// turning one way about the centre, less than a full turn in all) and that the
/// outline leaves at both ends (its neighbouring vertices at least half as far off the
/// circle as a tangent line one run edge long would be), in loop order;
/// runs may share an end vertex. The scan starts after the loop's longest edge (an
/// arc's edges are never longer than the straight edges beside it in the rounded
/// corners and slots this is for), so a run does not wrap past it.
pub(crate) fn fit_arcs(pts: &[DVec2]) -> Vec<ArcRun> {
    let n = pts.len();
    let mut runs = Vec::new();
    if n <= MIN_ARC_EDGES {
        return runs;
    }
    let longest = (0..n)
        .max_by(|&a, &b| {
            let len = |k: usize| (pts[(k + 1) % n] - pts[k]).length_squared();
            len(a).total_cmp(&len(b)).then(b.cmp(&a))
        })
        .unwrap_or(0);
    let s = (longest + 1) % n;
    let at = |k: usize| pts[(s + k) % n];
    let mut i = 0;
    while i + MIN_ARC_EDGES < n {
        let Some(mut best) = arc_through(&(i..=i + MIN_ARC_EDGES).map(at).collect::<Vec<_>>())
        else {
            i += 1;
            continue;
        };
        let mut j = i + MIN_ARC_EDGES;
        while j + 1 < n {
            match arc_through(&(i..=j + 1).map(at).collect::<Vec<_>>()) {
                Some(fit) => {
                    best = fit;
                    j += 1;
                }
                None => break,
            }
        }
        // The outline must leave the circle at both ends at least half as fast as a
        // tangent line would over one of the run's edges: a fillet meets straight edges
        // or corners, while a smooth curve that is no circle (an ellipse near its
        // apex, a spline) drifts off it slowly and stays segments.
        let r = (at(i) - best.0).length();
        let chord = (0..j - i)
            .map(|k| (at(i + k + 1) - at(i + k)).length())
            .sum::<f64>()
            / (j - i) as f64;
        let leave = 0.5 * ((chord / r).hypot(1.0) - 1.0) * r;
        let off = |q: DVec2| ((q - best.0).length() - r).abs();
        if off(at(i + n - 1)) >= leave && off(at(j + 1)) >= leave {
            runs.push(ArcRun {
                first: (s + i) % n,
                edges: j - i,
                centre: best.0,
                ccw: best.1,
            });
        }
        i = j;
    }
    runs
}

/// The circle through an open run of points (centre on the perpendicular bisector of
/// its ends) and its direction, when every point is within [`SPHERE_VERTEX_REL`]` × R`
/// of it, every edge spans at most [`max_arc`] turning the same way, and the run turns
/// less than once.
fn arc_through(run: &[DVec2]) -> Option<(DVec2, bool)> {
    let (c, _) = kasa(run)?;
    let (a, b) = (run[0], run[run.len() - 1]);
    let mid = 0.5 * (a + b);
    let dir = (b - a).perp().try_normalize()?;
    let centre = mid + dir * (c - mid).dot(dir);
    let r = (a - centre).length();
    if !(r > 0.0) || deviation(run.iter().copied(), centre, r).0 > SPHERE_VERTEX_REL * r {
        return None;
    }
    let mut total = 0.0;
    let mut sign = 0.0;
    for w in run.windows(2) {
        let (p, q) = (w[0] - centre, w[1] - centre);
        let arc = p.perp_dot(q).atan2(p.dot(q));
        if sign == 0.0 {
            sign = arc.signum();
        }
        if !(arc * sign > 0.0 && arc.abs() <= max_arc()) {
            return None;
        }
        total += arc.abs();
    }
    (total < std::f64::consts::TAU).then_some((centre, sign > 0.0))
}

/// A cylinder patch fitted to an open mesh: `origin + R cos θ x + R sin θ y + h axis`
/// with `x = reference`, `y = axis × x`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct CylinderFit {
    /// A point of the axis (height 0).
    pub origin: DVec3,
    /// Unit axis.
    pub axis: DVec3,
    /// Unit azimuth-zero direction, orthogonal to `axis`.
    pub reference: DVec3,
    /// Radius.
    pub radius: f64,
    /// Azimuth range (radians, span `<= 2π`).
    pub azimuth: (f64, f64),
    /// Height range along the axis from `origin`.
    pub height: (f64, f64),
    /// The facets face the axis.
    pub inward: bool,
}

/// Unit eigenvector of the smallest eigenvalue of a symmetric 3 × 3 matrix (cyclic
/// Jacobi rotations).
fn smallest_eigenvector(m: [[f64; 3]; 3]) -> DVec3 {
    let mut a = m;
    let mut v = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    for _ in 0..64 {
        let off = a[0][1].abs() + a[0][2].abs() + a[1][2].abs();
        let diag = a[0][0].abs() + a[1][1].abs() + a[2][2].abs();
        if off <= 1e-15 * diag {
            break;
        }
        for (p, q) in [(0, 1), (0, 2), (1, 2)] {
            if a[p][q] == 0.0 {
                continue;
            }
            let theta = 0.5 * (2.0 * a[p][q]).atan2(a[q][q] - a[p][p]);
            let (s, c) = theta.sin_cos();
            // A ← Jᵀ A J, V ← V J with J the rotation in the (p, q) plane.
            for k in 0..3 {
                let (akp, akq) = (a[k][p], a[k][q]);
                a[k][p] = c * akp - s * akq;
                a[k][q] = s * akp + c * akq;
            }
            for k in 0..3 {
                let (apk, aqk) = (a[p][k], a[q][k]);
                a[p][k] = c * apk - s * aqk;
                a[q][k] = s * apk + c * aqk;
            }
            for row in &mut v {
                let (vp, vq) = (row[p], row[q]);
                row[p] = c * vp - s * vq;
                row[q] = s * vp + c * vq;
            }
        }
    }
    let k = (0..3)
        .min_by(|&i, &j| a[i][i].total_cmp(&a[j][j]))
        .unwrap_or(0);
    DVec3::new(v[0][k], v[1][k], v[2][k]).normalize_or_zero()
}

/// The cylinder patch an open, consistently oriented set of triangles (vertex indices
/// into `p`) tessellates, by the criteria of the module docs, or why not.
pub(crate) fn fit_cylinder(p: &[DVec3], tris: &[[u32; 3]]) -> Result<CylinderFit, Miss> {
    let ids = vertex_ids(tris);
    if tris.len() < 4 || ids.len() < 2 * MIN_GENERATORS {
        return Err(None);
    }
    // Axis: the direction the facet normals are orthogonal to.
    let mut m = [[0.0f64; 3]; 3];
    for (n, w, _) in facet_normals(p, tris).ok_or(None)? {
        add_outer(&mut m, n, w);
    }
    let axis = smallest_eigenvector(m);
    if axis == DVec3::ZERO {
        return Err(None);
    }
    let (x, _) = axis.any_orthonormal_pair();
    let y = axis.cross(x);
    let mean = ids.iter().map(|&i| p[i as usize]).sum::<DVec3>() / ids.len() as f64;
    let flat = |q: DVec3| DVec2::new((q - mean).dot(x), (q - mean).dot(y));
    let cross: Vec<DVec2> = ids.iter().map(|&i| flat(p[i as usize])).collect();
    let (c2, r) = kasa(&cross).ok_or(None)?;
    let (dev, at) = deviation(cross.iter().copied(), c2, r);
    let rev = Revolution {
        origin: mean + c2.x * x + c2.y * y,
        axis,
        x,
        radius: r,
        slope: 0.0,
    };
    let patch = rev.patch(p, tris, &ids, (dev, ids[at]), "cylinder")?;
    Ok(CylinderFit {
        origin: rev.origin,
        axis,
        reference: x,
        radius: r,
        azimuth: patch.azimuth,
        height: patch.height,
        inward: patch.inward,
    })
}

/// A cone patch fitted to an open mesh: `apex + h (axis + slope (cos θ x + sin θ y))`
/// with `x = reference`, `y = axis × x`, `h` the height along the axis from the apex.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct ConeFit {
    /// Apex.
    pub apex: DVec3,
    /// Unit axis, from the apex towards the patch.
    pub axis: DVec3,
    /// Unit azimuth-zero direction, orthogonal to `axis`.
    pub reference: DVec3,
    /// Radius per unit height (`tan` of the half-angle, `> 0`).
    pub slope: f64,
    /// Azimuth range (radians, span `<= 2π`).
    pub azimuth: (f64, f64),
    /// Height range along the axis from the apex, `0 <= h0 < h1`.
    pub height: (f64, f64),
    /// The facets face the axis.
    pub inward: bool,
}

/// The cone patch (a frustum, a cone with its tip, or a part of either) an open,
/// consistently oriented set of triangles tessellates, by the criteria of the module
/// docs, or why not. The axis is the direction every facet normal makes the same angle
/// with (smallest eigenvector of the normals' area-weighted covariance); the apex is
/// the point nearest to every facet's plane (least squares; a cone's facets between
/// two generators lie in planes through its apex). Not a candidate (`Err(None)`) when
/// the radius changes along the patch by less than ten times the vertices' scatter
/// about the fitted cone: that is a (jittered) cylinder, reported by
/// [`fit_cylinder`].
pub(crate) fn fit_cone(p: &[DVec3], tris: &[[u32; 3]]) -> Result<ConeFit, Miss> {
    let ids = vertex_ids(tris);
    if tris.len() < 4 || ids.len() < 2 * MIN_GENERATORS {
        return Err(None);
    }
    let normals = facet_normals(p, tris).ok_or(None)?;
    let total: f64 = normals.iter().map(|f| f.1).sum();
    let mean_n = normals.iter().map(|f| f.1 * f.0).sum::<DVec3>() / total;
    let (mut cov, mut planes) = ([[0.0f64; 3]; 3], [[0.0f64; 3]; 3]);
    let mut rhs = DVec3::ZERO;
    for &(n, w, q) in &normals {
        add_outer(&mut cov, n - mean_n, w);
        add_outer(&mut planes, n, w);
        rhs += w * n.dot(q) * n;
    }
    let mut axis = smallest_eigenvector(cov);
    let planes = DMat3::from_cols_array_2d(&planes);
    if axis == DVec3::ZERO || !(planes.determinant().abs() > 1e-12 * total.powi(3)) {
        return Err(None);
    }
    let apex = planes.inverse() * rhs;
    let mean = ids.iter().map(|&i| p[i as usize]).sum::<DVec3>() / ids.len() as f64;
    if (mean - apex).dot(axis) < 0.0 {
        axis = -axis;
    }
    // Height and distance from the axis of every vertex; slope through the apex.
    let hr: Vec<(f64, f64)> = ids
        .iter()
        .map(|&i| {
            let d = p[i as usize] - apex;
            let h = d.dot(axis);
            (h, (d - h * axis).length())
        })
        .collect();
    let (shr, shh) = hr
        .iter()
        .fold((0.0, 0.0), |(a, b), &(h, r)| (a + h * r, b + h * h));
    let slope = shr / shh;
    let h1 = hr.iter().map(|v| v.0).fold(f64::NEG_INFINITY, f64::max);
    let h0 = hr.iter().map(|v| v.0).fold(f64::INFINITY, f64::min);
    let big = slope * h1;
    if !(slope > 0.0 && big.is_finite()) || h0 < -SPHERE_VERTEX_REL * big {
        return Err(None);
    }
    let cos = 1.0 / slope.hypot(1.0);
    let (dev, at) = hr
        .iter()
        .enumerate()
        .map(|(k, &(h, r))| ((r - slope * h).abs() * cos, k))
        .fold((0.0, 0), |a, b| if b.0 > a.0 { b } else { a });
    if slope * (h1 - h0.max(0.0)) < 10.0 * dev {
        return Err(None);
    }
    let (x, _) = axis.any_orthonormal_pair();
    let rev = Revolution {
        origin: apex,
        axis,
        x,
        radius: 0.0,
        slope,
    };
    let patch = rev.patch(p, tris, &ids, (dev, ids[at]), "cone")?;
    Ok(ConeFit {
        apex,
        axis,
        reference: x,
        slope,
        azimuth: patch.azimuth,
        height: (patch.height.0.max(0.0), patch.height.1),
        inward: patch.inward,
    })
}

/// The sorted, distinct vertex indices of `tris`.
fn vertex_ids(tris: &[[u32; 3]]) -> Vec<u32> {
    let mut ids: Vec<u32> = tris.iter().flatten().copied().collect();
    ids.sort_unstable();
    ids.dedup();
    ids
}

/// Unit normal, area and first corner of every facet; `None` for a degenerate facet or
/// a planar set (every normal the same).
fn facet_normals(p: &[DVec3], tris: &[[u32; 3]]) -> Option<Vec<(DVec3, f64, DVec3)>> {
    let mut out = Vec::with_capacity(tris.len());
    let mut planar = true;
    for t in tris {
        let [a, b, c] = t.map(|i| p[i as usize]);
        let cr = (b - a).cross(c - a);
        let len = cr.length();
        if !(len > 0.0) {
            return None;
        }
        let n = cr / len;
        if let Some(first) = out.first().map(|f: &(DVec3, f64, DVec3)| f.0)
            && n.dot(first) < 1.0 - 1e-12
        {
            planar = false;
        }
        out.push((n, 0.5 * len, a));
    }
    (!planar).then_some(out)
}

/// `m += w v vᵀ`.
fn add_outer(m: &mut [[f64; 3]; 3], v: DVec3, w: f64) {
    let v = v.to_array();
    for r in 0..3 {
        for c in 0..3 {
            m[r][c] += w * v[r] * v[c];
        }
    }
}

/// A surface of revolution whose distance from its axis grows linearly with the height:
/// `radius + slope · h` at height `h` along `axis` from `origin` (a cylinder: `slope`
/// 0; a cone: `radius` 0, `origin` the apex). Azimuth 0 along `x`, `y = axis × x`.
struct Revolution {
    origin: DVec3,
    axis: DVec3,
    x: DVec3,
    radius: f64,
    slope: f64,
}

/// The part of a [`Revolution`] a mesh covers.
struct RevolutionPatch {
    azimuth: (f64, f64),
    height: (f64, f64),
    inward: bool,
}

impl Revolution {
    /// The patch the facets `tris` tessellate, by the generator, vertex, facet and
    /// coverage criteria of the module docs, given the vertices' largest distance from
    /// the surface and the vertex where it is (`worst`); `what` names the surface in
    /// the reasons. Tolerances are relative to the largest radius of the patch.
    fn patch(
        &self,
        p: &[DVec3],
        tris: &[[u32; 3]],
        ids: &[u32],
        worst: (f64, u32),
        what: &str,
    ) -> Result<RevolutionPatch, Miss> {
        let y = self.axis.cross(self.x);
        let height = |q: DVec3| (q - self.origin).dot(self.axis);
        let theta = |q: DVec3| {
            let d = q - self.origin;
            d.dot(y).atan2(d.dot(self.x))
        };
        let heights: Vec<f64> = ids.iter().map(|&i| height(p[i as usize])).collect();
        let h0 = heights.iter().copied().fold(f64::INFINITY, f64::min);
        let h1 = heights.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let rho = |h: f64| self.radius + self.slope * h;
        let big = rho(h0).max(rho(h1));
        if worst.0 > NEAR_MISS_REL * big {
            return Err(None);
        }
        let mut az: Vec<f64> = ids.iter().map(|&i| theta(p[i as usize])).collect();
        let (full, t0, span) = azimuth_range(&mut az)?;
        if worst.0 > SPHERE_VERTEX_REL * big {
            return Err(Some(format!(
                "vertex {} is {:.2e} R from the best {what} (tolerance {SPHERE_VERTEX_REL:e} R)",
                worst.1,
                worst.0 / big
            )));
        }
        // Facets: one side, each within the facet tolerance (of the distance from the
        // axis to the surface along its normal, `ρ cos α`); coverage in (θ, u) with
        // `u(h) = ∫ ρ dh`, in which the surface's area element is `cos α⁻¹ dθ du`.
        let tau = std::f64::consts::TAU;
        let cos = 1.0 / self.slope.hypot(1.0);
        let u = |h: f64| self.radius * h + 0.5 * self.slope * h * h;
        let mut sign = 0.0;
        let mut covered = 0.0;
        for t in tris {
            let q = t.map(|i| p[i as usize]);
            let n = (q[1] - q[0]).cross(q[2] - q[0]).normalize();
            let hg = height((q[0] + q[1] + q[2]) / 3.0);
            let foot = self.origin + self.axis * hg;
            let hf = n.dot(q[0] - foot);
            if sign == 0.0 {
                sign = hf.signum();
            }
            if !(sign * hf >= (1.0 - SPHERE_FACET_REL) * rho(hg) * cos) {
                return Err(Some(if sign * hf < 0.0 {
                    "the facets do not all face the same way (away from or towards the axis)".into()
                } else {
                    format!(
                        "a facet spans more than {:.1}° of arc",
                        max_arc().to_degrees()
                    )
                }));
            }
            // (θ, u) of the corners, unwrapped next to the first (full turn) or into
            // [t0, t0 + 2π) (partial patch).
            let a0 = theta(q[0]);
            let uw = |a: f64| {
                if full {
                    a0 + (a - a0 + std::f64::consts::PI).rem_euclid(tau) - std::f64::consts::PI
                } else {
                    t0 + (a - t0).rem_euclid(tau)
                }
            };
            let th = q.map(|v| DVec2::new(uw(theta(v)), u(height(v))));
            let area = 0.5 * (th[1] - th[0]).perp_dot(th[2] - th[0]);
            if area * sign <= 0.0 {
                return Err(Some("the facets fold over in azimuth".into()));
            }
            covered += area;
        }
        let want = span * (u(h1) - u(h0));
        if !((sign * covered - want).abs() <= 1e-5 * want) {
            return Err(Some(format!(
                "the facets cover {:.6} of the patch {:.1}° × {:.3e} once (a hole, an overlap or a trimmed edge)",
                sign * covered / want,
                span.to_degrees(),
                h1 - h0
            )));
        }
        Ok(RevolutionPatch {
            azimuth: (t0, t0 + span),
            height: (h0, h1),
            inward: sign < 0.0,
        })
    }
}

/// The azimuth range the vertex azimuths `az` (radians, sorted here) cover: whether it
/// is a full turn, its start and its span. The largest gap between consecutive
/// distinct generators (cyclically) is the patch's missing part, unless every gap is
/// one facet wide ([`max_arc`]). `Err(None)` for fewer than [`MIN_GENERATORS`]
/// generators or a span below [`MIN_CYLINDER_SPAN`].
fn azimuth_range(az: &mut [f64]) -> Result<(bool, f64, f64), Miss> {
    az.sort_by(f64::total_cmp);
    let tau = std::f64::consts::TAU;
    let mut generators = vec![az[0]];
    for &a in &az[1..] {
        if a - generators[generators.len() - 1] > 1e-6 {
            generators.push(a);
        }
    }
    if generators.len() > 1 && generators[0] + tau - generators[generators.len() - 1] <= 1e-6 {
        generators.pop();
    }
    if generators.len() < MIN_GENERATORS {
        return Err(None);
    }
    let ng = generators.len();
    let (gap, after) = (0..ng)
        .map(|k| {
            let next = if k + 1 < ng {
                generators[k + 1]
            } else {
                generators[0] + tau
            };
            (next - generators[k], (k + 1) % ng)
        })
        .fold((0.0, 0), |a, b| if b.0 > a.0 { b } else { a });
    let full = gap <= max_arc();
    let (t0, span) = if full {
        (0.0, tau)
    } else {
        (generators[after], tau - gap)
    };
    if span < MIN_CYLINDER_SPAN {
        return Err(None);
    }
    Ok((full, t0, span))
}

/// Signed solid angle of the triangle `(a, b, c)` seen from the origin (Van Oosterom
/// and Strackee), positive when the triangle is counter-clockwise seen from the
/// origin's far side (its normal points away from the origin).
fn solid_angle(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let (la, lb, lc) = (a.length(), b.length(), c.length());
    let num = a.dot(b.cross(c));
    let den = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
    2.0 * num.atan2(den)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solid_angle_of_an_octant_is_half_pi() {
        let o = solid_angle(DVec3::X, DVec3::Y, DVec3::Z);
        assert!((o - std::f64::consts::FRAC_PI_2).abs() < 1e-15);
        assert!((solid_angle(DVec3::X, DVec3::Z, DVec3::Y) + o).abs() < 1e-15);
    }
}
