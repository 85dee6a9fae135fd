//! Curved-surface recognition for mesh grouping (issue 11 §3: "recognise curved patches
//! where the input allows"): a closed triangle mesh whose vertices all lie on one sphere,
//! fine enough to be meant as that sphere, becomes the sphere, one analytic patch on the
//! equal-area parametrization (VirtualMesh §3.1 and Appendix A.1) with one support,
//! instead of thousands of facet supports.
//!
//! # Criteria (all must hold; otherwise the mesh stays facets, no warning)
//!
//! - The component is closed and consistently oriented: every edge is shared by exactly
//!   two of its triangles, traversed in opposite directions (the caller checks this).
//! - Every vertex lies within [`SPHERE_VERTEX_REL`]` × R` of the least-squares sphere
//!   (centre `c`, radius `R`; algebraic fit on centred, scaled coordinates).
//! - Every facet's plane is within [`SPHERE_FACET_REL`]` × R` of the sphere, on the same
//!   side for all facets: the signed distance `n̂·(a − c)` of every facet lies in
//!   `[(1 − SPHERE_FACET_REL) R, R]` (all facing outwards) or in its negative (all
//!   inwards). A facet then spans at most `acos(0.98) ≈ 11.5°` of arc from its centre:
//!   a 24 × 12 UV sphere is recognised, an icosahedron or an 8 × 4 UV sphere (meant as
//!   polyhedra, or too coarse to tell) is not.
//! - The facets cover the sphere exactly once: the sum of their signed solid angles seen
//!   from `c` is `±4π` within `1e-6 × 4π`.
//!
//! The sphere's area `4πR²` exceeds the facets' by about the facets' relative sagitta
//! (0.1 % for a 72 × 36 UV sphere): the recognised surface is the sphere the mesh
//! approximates, which is the point; `MeshGrouping::Triangles` keeps the facets.

use glam::{DMat4, DVec3, DVec4};

/// Vertex tolerance of the sphere fit, relative to the fitted radius: `1e-5` (about 100
/// `f32` ulps, room for positions computed in `f32` trigonometry).
pub const SPHERE_VERTEX_REL: f64 = 1e-5;

/// Facet tolerance of the sphere fit, relative to the fitted radius: every facet's plane
/// is within `0.02 R` of the sphere (see the module docs).
pub const SPHERE_FACET_REL: f64 = 0.02;

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
