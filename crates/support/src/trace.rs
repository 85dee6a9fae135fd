//! Supports as ray-traceable geometry: the exact primitive a support covers and the
//! inverse of its map at a hit (VirtualMesh §3 Fig. 3: a hit on the trimmed patch is
//! taken back to the support square through `Λ⁻¹`).
//!
//! Shared by the renderer (images of solutions) and the glossy method (rays between
//! patches for importance and final gathering); it moved down from `wavelux-render`
//! when the glossy method became its second user.

use glam::{DVec2, DVec3};
use wavelux_geometry::{
    ComplexPolygon, Edge2, Parallelogram, PlaneFrame, Primitive, Triangle, TrimLoop, TrimRegion,
    TrimmedPatch,
};

use crate::error::SupportError;
use crate::piece::{Support, SupportMap};

fn geo(e: wavelux_geometry::GeometryError) -> SupportError {
    SupportError::InvalidScene(e.to_string())
}

/// Solves `d = x·e1 + y·e2` in the least-squares sense (the point is in the plane).
fn plane_coords(d: DVec3, e1: DVec3, e2: DVec3) -> (f64, f64) {
    let (a, b, c) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
    let (p, q) = (d.dot(e1), d.dot(e2));
    let det = a * c - b * b;
    if det.abs() <= f64::MIN_POSITIVE {
        return (0.0, 0.0);
    }
    ((p * c - q * b) / det, (a * q - b * p) / det)
}

impl Support {
    /// The exact primitive this support covers: the whole image of its map, or for a
    /// virtual (masked) support only its real part — the polygon in the plane of a
    /// masked parallelogram, the trimmed patch of a curved map. A hit's `uv` on it is
    /// what [`SupportMap::invert`] takes for curved maps.
    ///
    /// # Errors
    /// [`SupportError::InvalidScene`] for a degenerate support or a curved support
    /// without its map.
    pub fn primitive(&self) -> Result<Primitive, SupportError> {
        Ok(match self.map {
            SupportMap::Parallelogram {
                origin,
                edge_u,
                edge_v,
            } => match &self.mask {
                None => Primitive::Parallelogram(
                    Parallelogram::new(origin, edge_u, edge_v).map_err(geo)?,
                ),
                Some(mask) => {
                    // The mask plane is the polygon's orthonormal frame F(p) = O + L p with
                    // F(Λ(s,t)) = origin + s·edge_u + t·edge_v: L = [edge_u edge_v]·[e1 e2]⁻¹.
                    let (mo, e1, e2) = mask.lambda();
                    let det = e1.perp_dot(e2);
                    if det.abs() <= f64::MIN_POSITIVE {
                        return Err(SupportError::InvalidScene(
                            "degenerate masked support".into(),
                        ));
                    }
                    let lx = (edge_u * e2.y - edge_v * e1.y) / det;
                    let ly = (edge_v * e1.x - edge_u * e2.x) / det;
                    let o = origin - lx * mo.x - ly * mo.y;
                    let frame = PlaneFrame::from_axes(o, lx, ly).map_err(geo)?;
                    Primitive::Polygon(Box::new(
                        ComplexPolygon::new(frame, mask.region().clone()).map_err(geo)?,
                    ))
                }
            },
            SupportMap::Triangle { a, b, c } => {
                Primitive::Triangle(Triangle::new(a, b, c).map_err(geo)?)
            }
            SupportMap::Disk {
                center,
                u,
                v,
                radius,
            } => {
                let frame = PlaneFrame::from_axes(center, u, v).map_err(geo)?;
                let edge =
                    Edge2::arc(DVec2::ZERO, radius, 0.0, std::f64::consts::TAU).map_err(geo)?;
                let region =
                    TrimRegion::new(vec![TrimLoop::new(vec![edge]).map_err(geo)?]).map_err(geo)?;
                Primitive::Polygon(Box::new(ComplexPolygon::new(frame, region).map_err(geo)?))
            }
            SupportMap::Mapped { .. } => {
                let param = self.param.clone().ok_or_else(|| {
                    SupportError::InvalidScene("curved support without its map".into())
                })?;
                let trim = self.mask.as_ref().map(|m| m.region().clone());
                Primitive::Trimmed(Box::new(TrimmedPatch::new(param, trim).map_err(geo)?))
            }
        })
    }
}

impl SupportMap {
    /// Inverse of the map for a point on (or numerically near) its image, clamped to
    /// `[0,1]²`; `uv`: the point's parameters on a curved support's map `Ψ` (the hit's
    /// parameters on the trimmed patch of [`Support::primitive`]), from which
    /// `(s, t) = Λ⁻¹(uv)`. Parallelogram: affine; triangle: `a + √s((1−t)(b−a) +
    /// t(c−a))`; disk: Shirley–Chiu concentric.
    #[must_use]
    pub fn invert(&self, p: DVec3, uv: DVec2) -> DVec2 {
        let st = match *self {
            SupportMap::Parallelogram {
                origin,
                edge_u,
                edge_v,
            } => {
                let (s, t) = plane_coords(p - origin, edge_u, edge_v);
                DVec2::new(s, t)
            }
            SupportMap::Triangle { a, b, c } => {
                let (beta, gamma) = plane_coords(p - a, b - a, c - a);
                let r = (beta + gamma).clamp(0.0, 1.0);
                let t = if r > 0.0 { gamma / (beta + gamma) } else { 0.0 };
                DVec2::new(r * r, t)
            }
            SupportMap::Disk {
                center,
                u,
                v,
                radius,
            } => {
                let d = (p - center) / radius;
                let (x, y) = (d.dot(u), d.dot(v));
                let rho = (x * x + y * y).sqrt().min(1.0);
                let q = std::f64::consts::FRAC_PI_4;
                // θ in [−π/4, 7π/4).
                let mut th = y.atan2(x);
                if th < -q {
                    th += std::f64::consts::TAU;
                }
                let (sx, sy) = if th < q {
                    (rho, rho * th / q)
                } else if th < 3.0 * q {
                    (rho * (2.0 * q - th) / q, rho)
                } else if th < 5.0 * q {
                    (-rho, -rho * (th - 4.0 * q) / q)
                } else {
                    (-rho * (2.0 * q - (th - 4.0 * q)) / q, -rho)
                };
                DVec2::new(0.5 * (sx + 1.0), 0.5 * (sy + 1.0))
            }
            SupportMap::Mapped { origin, e1, e2 } => {
                let det = e1.perp_dot(e2);
                let d = uv - origin;
                DVec2::new(d.perp_dot(e2) / det, e1.perp_dot(d) / det)
            }
        };
        st.clamp(DVec2::ZERO, DVec2::ONE)
    }
}
