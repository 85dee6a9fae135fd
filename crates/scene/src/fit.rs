//! Curved-surface recognition for mesh grouping (issue 11 §3: "recognise curved patches
//! where the input allows"): a closed triangle mesh whose vertices all lie on one sphere,
//! an open one whose vertices all lie on one cylinder, and a polygon loop whose vertices
//! all lie on one circle, each fine enough to be meant as that surface, become that
//! surface: a sphere or cylinder patch on the equal-area parametrization (VirtualMesh
//! §3.1 and Appendix A.1) with one support, or a loop made of one circular arc (a disk,
//! an annulus, a round hole: VirtualMesh §4's exact masks handle arcs), instead of
//! hundreds of facets or a polygon of hundreds of edges.
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
//! - **Enough evidence**: a circle needs [`MIN_CIRCLE_VERTICES`] vertices; a cylinder
//!   patch at least [`MIN_GENERATORS`] distinct generator lines and an azimuth span of
//!   at least [`MIN_CYLINDER_SPAN`] (a flat or barely bent strip stays facets).
//!
//! # Near misses
//!
//! A candidate whose vertices all lie within [`NEAR_MISS_REL`]` × R` of the fitted
//! surface but that fails a criterion above (an ellipse, a slightly tapered cone,
//! jittered vertices, a cylinder with a window cut out) stays facets or a polygon and
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
    let mut ids: Vec<u32> = tris.iter().flatten().copied().collect();
    ids.sort_unstable();
    ids.dedup();
    if tris.len() < 4 || ids.len() < 2 * MIN_GENERATORS {
        return Err(None);
    }
    // Axis: the direction the facet normals are orthogonal to.
    let mut m = [[0.0f64; 3]; 3];
    let mut first = DVec3::ZERO;
    let mut planar = true;
    for t in tris {
        let [a, b, c] = t.map(|i| p[i as usize]);
        let cr = (b - a).cross(c - a);
        let len = cr.length();
        if !(len > 0.0) {
            return Err(None);
        }
        let n = cr / len;
        if first == DVec3::ZERO {
            first = n;
        } else if n.dot(first) < 1.0 - 1e-12 {
            planar = false;
        }
        let w = n.to_array();
        for r in 0..3 {
            for c in 0..3 {
                m[r][c] += 0.5 * len * w[r] * w[c];
            }
        }
    }
    if planar {
        return Err(None);
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
    let origin = mean + c2.x * x + c2.y * y;
    let (dev, at) = deviation(cross.iter().copied(), c2, r);
    if dev > NEAR_MISS_REL * r {
        return Err(None);
    }
    // Azimuths of the vertices, and the distinct generator lines.
    let theta = |q: DVec3| {
        let d = q - origin;
        d.dot(y).atan2(d.dot(x))
    };
    let mut az: Vec<f64> = ids.iter().map(|&i| theta(p[i as usize])).collect();
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
    // The largest gap between consecutive generators (cyclically) is the patch's
    // missing part, unless every gap is one facet wide (a full tube).
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
    if dev > SPHERE_VERTEX_REL * r {
        return Err(Some(format!(
            "vertex {} is {:.2e} R from the best cylinder (tolerance {SPHERE_VERTEX_REL:e} R)",
            ids[at],
            dev / r
        )));
    }
    let heights: Vec<f64> = ids
        .iter()
        .map(|&i| (p[i as usize] - origin).dot(axis))
        .collect();
    let h0 = heights.iter().copied().fold(f64::INFINITY, f64::min);
    let h1 = heights.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    // Facets: one side, each within the facet tolerance; (θ, h) coverage.
    let mut sign = 0.0;
    let mut covered = 0.0;
    for t in tris {
        let q = t.map(|i| p[i as usize]);
        let n = (q[1] - q[0]).cross(q[2] - q[0]).normalize();
        let g = (q[0] + q[1] + q[2]) / 3.0;
        let foot = origin + axis * (g - origin).dot(axis);
        let hf = n.dot(q[0] - foot);
        if sign == 0.0 {
            sign = hf.signum();
        }
        if !(sign * hf >= (1.0 - SPHERE_FACET_REL) * r) {
            return Err(Some(if sign * hf < 0.0 {
                "the facets do not all face the same way (away from or towards the axis)".into()
            } else {
                format!(
                    "a facet spans more than {:.1}° of arc",
                    max_arc().to_degrees()
                )
            }));
        }
        // (θ, h) of the corners, unwrapped next to the first (full tube) or into
        // [t0, t0 + 2π) (partial patch).
        let a0 = theta(q[0]);
        let uw = |a: f64| {
            if full {
                a0 + (a - a0 + std::f64::consts::PI).rem_euclid(tau) - std::f64::consts::PI
            } else {
                t0 + (a - t0).rem_euclid(tau)
            }
        };
        let th = q.map(|v| DVec2::new(uw(theta(v)), (v - origin).dot(axis)));
        let area = 0.5 * (th[1] - th[0]).perp_dot(th[2] - th[0]);
        if area * sign <= 0.0 {
            return Err(Some("the facets fold over in azimuth".into()));
        }
        covered += area;
    }
    let want = span * (h1 - h0);
    if !((sign * covered - want).abs() <= 1e-5 * want) {
        return Err(Some(format!(
            "the facets cover {:.6} of the patch {:.1}° × {:.3e} once (a hole, an overlap or a trimmed edge)",
            sign * covered / want,
            span.to_degrees(),
            h1 - h0
        )));
    }
    Ok(CylinderFit {
        origin,
        axis,
        reference: x,
        radius: r,
        azimuth: (t0, t0 + span),
        height: (h0, h1),
        inward: sign < 0.0,
    })
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
