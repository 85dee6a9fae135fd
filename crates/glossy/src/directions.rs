//! Directions of radiance on a patch (Glossy §3.3): the hemisphere above the surface
//! mapped onto the unit square `(u₃, u₄)` by [`CosineHemisphere`] (ours, the default
//! since session 27: equal *projected* solid angle), `wavelux-param`'s
//! [`GlossyHemisphere`] (the paper's gnomonic-like projection and radial stretch; the
//! reproductions name it) or the equal-area [`ConcentricHemisphere`], in the patch's
//! local shading frame (normal, tangent).
//!
//! **Why the cosine-weighted map.** Coefficients are parameter-measure projections
//! `ℓ = ∫ b L du` (see [`crate::basis`]), while the power a patch sends is
//! `∫ L cos θ J_ω du`. A coarse node therefore keeps a glossy lobe's energy only where
//! `cos θ J_ω` is constant over the node's direction cell. For the paper's map
//! `cos θ J_ω` runs from `π²` at the pole to 0 at the horizon, so a `V⁰` (or any coarse)
//! projection of a sharp lobe reflected at the normal keeps `1/π` of its energy (a Ward
//! lobe of α = 0.2: 0.45) and one reflected at 65° 1.14× (see `tests/energy.rs`); the
//! error shrinks only
//! as refinement resolves the lobe. With [`CosineHemisphere`] `cos θ J_ω = π`
//! everywhere, so the projection onto any Haar cell keeps the cell's exitance exactly
//! at every level: the energy a coarse node sends on is the energy it received. It is
//! the "flat projection" §3.3 rejects for its distortion near the horizon (grazing
//! directions get little parameter area), which matters for images at grazing angles,
//! not for exitance.
//!
//! Both maps are smooth inside each of the four triangles cut by the square's
//! diagonals (the radial stretch and the concentric map have derivative kinks there).
//! A dyadic cell meets a diagonal only corner to corner (cells with `i₃ = i₄`, or
//! `i₃ + i₄ = 2ʲ − 1`), so [`integrate_cell`] splits such cells into their two
//! triangles (the level-0 square into four) and applies a collapsed Gauss rule to each,
//! collapsed at the square's centre (the pole, where the maps are smooth only along
//! rays) when it is a vertex:
//! integrals of smooth functions of the direction (`cos θ J_ω`, cosine-power emitters)
//! converge exponentially instead of at the kink's `O(h²)` (the Glossy map's Jacobian
//! has a factor `1/(1 + t²)` with poles at `t = ±i`: 16 points per axis give 1e-12).

use glam::{DVec2, DVec3};
use wavelux_param::{
    ConcentricHemisphere, DirectionMap, GlossyHemisphere, concentric_disc_to_square,
    concentric_square_to_disc,
};
use wavelux_quadrature::GaussLegendre;

use crate::error::{GlossyError, dep};

/// Which hemisphere ↔ square map the angular coordinates use.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, serde::Serialize)]
pub enum DirectionKind {
    /// Glossy §3.3: equidistant ("gnomonic") projection plus radial stretch.
    Glossy,
    /// Shirley–Chiu concentric, equal-area (`J_ω = 2π`).
    Concentric,
    /// Cosine-weighted ([`CosineHemisphere`], ours): equal projected solid angle,
    /// `cos θ J_ω = π`, so every projection keeps its cell's exitance (default: on a
    /// Ward Cornell box the exitance error is 1.8 % against the paper's map's 12.0 %
    /// after 4 rounds, at the same cost; docs/architecture.md).
    #[default]
    Cosine,
}

static GLOSSY: GlossyHemisphere = GlossyHemisphere;
static CONCENTRIC: ConcentricHemisphere = ConcentricHemisphere;
static COSINE: CosineHemisphere = CosineHemisphere;

/// Cosine-weighted hemisphere ↔ square map (Malley's method): Shirley–Chiu's
/// concentric square → unit disc, then the disc point `p` lifted to the direction
/// `(p, √(1 − |p|²))`. The disc is the hemisphere's orthographic image, so
/// `cos θ dω = dA_disc = π du`: `J_ω = π / cos θ` (infinite at the horizon, where the
/// projected solid angle, not the solid angle, is what the parameter area measures).
/// Derivative kinks on the square's diagonals, like the other two maps.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct CosineHemisphere;

impl DirectionMap for CosineHemisphere {
    fn direction(&self, uv: DVec2) -> DVec3 {
        let p = concentric_square_to_disc(uv * 2.0 - 1.0);
        let z = (1.0 - p.length_squared()).max(0.0).sqrt();
        DVec3::new(p.x, p.y, z)
    }
    fn inverse(&self, d: DVec3) -> Option<DVec2> {
        let d = d.try_normalize()?;
        if d.z < 0.0 {
            return None;
        }
        Some((concentric_disc_to_square(DVec2::new(d.x, d.y)) + 1.0) * 0.5)
    }
    /// `π / cos θ`, finite (huge) on the square's boundary so that `cos θ J_ω` is 0
    /// there rather than NaN.
    fn jacobian(&self, uv: DVec2) -> f64 {
        cosine_jacobian(self.direction(uv))
    }
    fn solid_angle(&self) -> f64 {
        std::f64::consts::TAU
    }
    fn is_equal_area(&self) -> bool {
        false
    }
}

/// [`CosineHemisphere`]'s `J_ω = π / cos θ` of its direction `d`.
#[inline]
fn cosine_jacobian(d: DVec3) -> f64 {
    std::f64::consts::PI / d.z.max(f64::MIN_POSITIVE)
}

impl DirectionKind {
    /// The map.
    #[must_use]
    pub fn map(self) -> &'static dyn DirectionMap {
        match self {
            Self::Glossy => &GLOSSY,
            Self::Concentric => &CONCENTRIC,
            Self::Cosine => &COSINE,
        }
    }

    /// Lower-case name.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Glossy => "glossy",
            Self::Concentric => "concentric",
            Self::Cosine => "cosine",
        }
    }

    /// Local direction (`z` = normal) of `(u₃, u₄)`.
    #[inline]
    #[must_use]
    pub fn direction(self, u: DVec2) -> DVec3 {
        self.map().direction(u)
    }

    /// `(u₃, u₄)` of a local direction with `z ≥ 0` (`None` below the horizon),
    /// clamped to `[0,1]²`.
    #[inline]
    #[must_use]
    pub fn inverse(self, d: DVec3) -> Option<DVec2> {
        self.map()
            .inverse(d)
            .map(|u| u.clamp(DVec2::ZERO, DVec2::ONE))
    }

    /// Solid angle per unit parameter area at `u` (sr).
    #[inline]
    #[must_use]
    pub fn jacobian(self, u: DVec2) -> f64 {
        self.map().jacobian(u)
    }

    /// [`DirectionKind::jacobian`] at `u` given its direction `d = direction(u)`
    /// (bitwise the same value): the cosine map's `J_ω` follows from `d` without a
    /// second evaluation of the map.
    #[inline]
    #[must_use]
    pub fn jacobian_of(self, u: DVec2, d: DVec3) -> f64 {
        match self {
            Self::Cosine => cosine_jacobian(d),
            _ => self.map().jacobian(u),
        }
    }
}

/// Gauss rule on `[0,1]` used by [`integrate_cell`] (points, weights).
#[derive(Debug, Clone)]
pub struct CellRule {
    x: Vec<f64>,
    w: Vec<f64>,
}

impl CellRule {
    /// An `n`-point rule per axis of each triangle / square piece.
    ///
    /// # Errors
    /// [`GlossyError::Dependency`] for `n` outside the quadrature crate's range.
    pub fn new(n: usize) -> Result<Self, GlossyError> {
        let g = GaussLegendre::new(n).map_err(dep("quadrature"))?;
        let (x, w) = g.unit();
        Ok(Self {
            x: x.to_vec(),
            w: w.to_vec(),
        })
    }

    /// `∫_T f` over the triangle `(a, b, c)` by the collapsed (Duffy) tensor rule
    /// `p = a + ξ(b − a) + ξη(c − b)`, Jacobian `ξ·|det|`.
    fn triangle(&self, a: DVec2, b: DVec2, c: DVec2, f: &mut impl FnMut(DVec2) -> f64) -> f64 {
        // Collapse at the square's centre (the pole, where the maps are only
        // direction-wise smooth) when it is a vertex.
        let centre = DVec2::splat(0.5);
        let (a, b, c) = if b == centre {
            (b, c, a)
        } else if c == centre {
            (c, a, b)
        } else {
            (a, b, c)
        };
        let det = (b - a).perp_dot(c - b).abs();
        let mut s = 0.0;
        for (i, &xi) in self.x.iter().enumerate() {
            for (j, &eta) in self.x.iter().enumerate() {
                let p = a + xi * (b - a) + xi * eta * (c - b);
                s += self.w[i] * self.w[j] * xi * f(p);
            }
        }
        s * det
    }

    /// `∫ f` over the square `[lo, lo + h]²` by the tensor rule.
    fn square(&self, lo: DVec2, h: f64, f: &mut impl FnMut(DVec2) -> f64) -> f64 {
        let mut s = 0.0;
        for (i, &x) in self.x.iter().enumerate() {
            for (j, &y) in self.x.iter().enumerate() {
                s += self.w[i] * self.w[j] * f(lo + h * DVec2::new(x, y));
            }
        }
        s * h * h
    }
}

/// `∫ f(u₃, u₄) du` over the dyadic angular cell `(level; i₃, i₄)`, split along the
/// square's diagonals where they cross it (see the module docs).
pub fn integrate_cell(
    rule: &CellRule,
    level: u8,
    i: [u16; 2],
    mut f: impl FnMut(DVec2) -> f64,
) -> f64 {
    let n = 1u32 << level;
    let h = 1.0 / f64::from(n);
    let lo = DVec2::new(f64::from(i[0]) * h, f64::from(i[1]) * h);
    let (p00, p10, p11, p01) = (
        lo,
        lo + DVec2::new(h, 0.0),
        lo + DVec2::new(h, h),
        lo + DVec2::new(0.0, h),
    );
    let main = i[0] == i[1];
    let anti = u32::from(i[0]) + u32::from(i[1]) + 1 == n;
    match (main, anti) {
        (true, true) => {
            let c = lo + DVec2::splat(0.5 * h);
            rule.triangle(c, p00, p10, &mut f)
                + rule.triangle(c, p10, p11, &mut f)
                + rule.triangle(c, p11, p01, &mut f)
                + rule.triangle(c, p01, p00, &mut f)
        }
        (true, false) => {
            rule.triangle(p00, p10, p11, &mut f) + rule.triangle(p00, p11, p01, &mut f)
        }
        (false, true) => {
            rule.triangle(p10, p11, p01, &mut f) + rule.triangle(p10, p01, p00, &mut f)
        }
        (false, false) => rule.square(lo, h, &mut f),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn projected_solid_angle_is_pi_for_every_map() {
        // Inside each triangle the Glossy Jacobian carries 1/(1 + t²) (poles at
        // t = ±i): 16 points per axis reach 1e-12. The cosine map's `cos θ J_ω` is the
        // constant π; its `J_ω` alone has a 1/√(1 − r²) rim singularity that Gauss
        // rules do not reach 1e-11 on, so its solid angle is left to the
        // finite-difference test below.
        let rule = CellRule::new(16).unwrap();
        let kinds = [
            DirectionKind::Glossy,
            DirectionKind::Concentric,
            DirectionKind::Cosine,
        ];
        for kind in kinds {
            for level in 0..4u8 {
                let n = 1u16 << level;
                let mut s = 0.0;
                let mut omega = 0.0;
                for a in 0..n {
                    for b in 0..n {
                        s += integrate_cell(&rule, level, [a, b], |u| {
                            kind.direction(u).z * kind.jacobian(u)
                        });
                        omega += integrate_cell(&rule, level, [a, b], |u| kind.jacobian(u));
                    }
                }
                assert!(
                    (s - std::f64::consts::PI).abs() < 1e-11,
                    "{kind:?} {level}: {s}"
                );
                assert!(
                    kind == DirectionKind::Cosine || (omega - std::f64::consts::TAU).abs() < 1e-11,
                    "{kind:?} {level}: {omega}"
                );
            }
        }
    }

    #[test]
    fn jacobian_is_the_maps_area_element() {
        // |∂ω/∂u₃ × ∂ω/∂u₄| by central differences at points off the diagonals (where
        // every map is smooth) against `jacobian`.
        let h = 1e-6;
        for kind in [
            DirectionKind::Glossy,
            DirectionKind::Concentric,
            DirectionKind::Cosine,
        ] {
            for i in 0..16 {
                for j in 0..16 {
                    let u = DVec2::new((i as f64 + 0.3) / 16.0, (j as f64 + 0.6) / 16.0);
                    let du = (kind.direction(u + DVec2::X * h) - kind.direction(u - DVec2::X * h))
                        / (2.0 * h);
                    let dv = (kind.direction(u + DVec2::Y * h) - kind.direction(u - DVec2::Y * h))
                        / (2.0 * h);
                    let fd = du.cross(dv).length();
                    let j_u = kind.jacobian(u);
                    assert!((fd - j_u).abs() < 1e-6 * j_u, "{kind:?} {u}: {fd} vs {j_u}");
                }
            }
        }
    }

    #[test]
    fn inverse_round_trip() {
        for kind in [
            DirectionKind::Glossy,
            DirectionKind::Concentric,
            DirectionKind::Cosine,
        ] {
            for i in 0..20 {
                for j in 0..20 {
                    let u = DVec2::new((i as f64 + 0.5) / 20.0, (j as f64 + 0.5) / 20.0);
                    let d = kind.direction(u);
                    let v = kind.inverse(d).unwrap();
                    assert!((u - v).length() < 1e-12, "{kind:?} {u} {v}");
                }
            }
        }
    }
}
