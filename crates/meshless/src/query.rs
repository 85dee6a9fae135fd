//! The surface interface of the meshless method (Meshless §5.1): everything the basis
//! construction and the transfer need from the geometry is "closest hit → point,
//! normal of the side hit, reflectance" and "is this segment blocked". The basis and
//! every algorithm of this crate see the scene only through [`SurfaceQuery`], so they
//! work unchanged on any surface representation ([`SceneSurfaces`]: the exact
//! primitives of a `wavelux-scene` scene through `wavelux-geometry`'s BVH;
//! [`SphereInterior`]: an analytic closed sphere for closed-form tests).
//!
//! One-sided surfaces reflect on their front only; a ray that reaches the back of a
//! one-sided surface is absorbed (its hit has no reflectance).

use glam::DVec3;
use wavelux_geometry::{Accel, Primitive, Ray};
use wavelux_scene::{Scene, Sidedness};

use crate::MeshlessError;

/// A ray's closest hit, resolved to the side it reached.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfaceHit {
    /// Distance along the unit ray direction.
    pub t: f64,
    /// Hit point.
    pub point: DVec3,
    /// Unit normal of the side that was hit (facing the ray's origin).
    pub normal: DVec3,
    /// Diffuse reflectance `ρ` of that side (RGB); `None` for the back of a one-sided
    /// surface, which absorbs.
    pub reflectance: Option<[f64; 3]>,
}

/// A point drawn uniformly by area on the emitting sides (for next-event estimation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EmitterSample {
    /// Position.
    pub point: DVec3,
    /// Unit normal of the emitting side.
    pub normal: DVec3,
    /// Emitted exitance `E` (W/m², RGB).
    pub exitance: [f64; 3],
    /// Total emitting area (m²; the pdf is its inverse).
    pub total_area: f64,
}

/// What the meshless method needs from a surface representation (Meshless §5.1).
pub trait SurfaceQuery: Sync {
    /// Closest hit of the ray `origin + t·dir` (`dir` unit), `t > 0`.
    fn closest_hit(&self, origin: DVec3, dir: DVec3) -> Option<SurfaceHit>;
    /// Whether the open segment `p → q` is blocked.
    fn occluded(&self, p: DVec3, q: DVec3) -> bool;
    /// Axis-aligned bounds of the geometry `(min, max)`.
    fn bounds(&self) -> (DVec3, DVec3);
    /// Offset of secondary ray origins along the normal (scene units); default
    /// `1e-7 ×` the bounds' diagonal.
    fn offset(&self) -> f64 {
        let (lo, hi) = self.bounds();
        1e-7 * (hi - lo).length()
    }
    /// A point drawn uniformly by area over the emitting sides from `u ∈ [0, 1)³`;
    /// `None` when there are no emitters (the default).
    fn sample_emitter(&self, _u: [f64; 3]) -> Option<EmitterSample> {
        None
    }
}

/// Reflectance and exitance of one side.
#[derive(Debug, Clone, Copy, PartialEq)]
struct SideMat {
    rho: [f64; 3],
    e: [f64; 3],
}

/// A scene's exact primitives in one BVH, with per-side materials (textures enter by
/// their mean, as in the solvers).
#[derive(Debug)]
pub struct SceneSurfaces {
    accel: Accel,
    prim_surface: Vec<u32>,
    sides: Vec<[Option<SideMat>; 2]>,
    /// Emitting sides `(primitive, back?, E)` and their cumulative areas.
    emitters: Vec<(u32, bool, [f64; 3])>,
    emitter_cdf: Vec<f64>,
    /// Names of emitting surfaces whose shape cannot be sampled here.
    unsampled: Vec<String>,
    bounds: (DVec3, DVec3),
}

fn side_mat(scene: &Scene, id: usize, surface: &str) -> Result<SideMat, MeshlessError> {
    let err = |reason: String| MeshlessError::Scene {
        scene: scene.name.clone(),
        reason,
    };
    let m = scene
        .materials
        .get(id)
        .ok_or_else(|| err(format!("surface {surface:?}: material {id} missing")))?;
    let mut rho = m.reflectance.0;
    let mut e = m.emission.0;
    if let Some(t) = m
        .reflectance_texture
        .and_then(|t| scene.textures.get(t.texture))
    {
        let t = t.mean().0;
        rho = std::array::from_fn(|c| rho[c] * t[c]);
    }
    if let Some(t) = m
        .emission_texture
        .and_then(|t| scene.textures.get(t.texture))
    {
        let t = t.mean().0;
        e = std::array::from_fn(|c| e[c] * t[c]);
    }
    for c in 0..3 {
        if !(rho[c].is_finite() && (0.0..1.0).contains(&rho[c])) {
            return Err(err(format!(
                "material {:?}: reflectance {} outside [0, 1)",
                m.name, rho[c]
            )));
        }
        if !(e[c].is_finite() && e[c] >= 0.0) {
            return Err(err(format!(
                "material {:?}: emission {} not finite and >= 0",
                m.name, e[c]
            )));
        }
    }
    Ok(SideMat { rho, e })
}

impl SceneSurfaces {
    /// Builds the BVH over the scene's exact primitives.
    ///
    /// # Errors
    /// [`MeshlessError::Scene`] for a scene without surfaces, invalid geometry or
    /// materials outside their ranges.
    pub fn new(scene: &Scene) -> Result<Self, MeshlessError> {
        let err = |reason: String| MeshlessError::Scene {
            scene: scene.name.clone(),
            reason,
        };
        let prims = scene
            .primitives(&scene.name)
            .map_err(|e| err(e.to_string()))?;
        if prims.is_empty() {
            return Err(err("the scene has no surfaces".into()));
        }
        let mut sides = Vec::with_capacity(scene.surfaces.len());
        for s in &scene.surfaces {
            let front = side_mat(scene, s.material, &s.name)?;
            let back = match s.sides {
                Sidedness::TwoSided { back } => Some(side_mat(scene, back, &s.name)?),
                _ => None,
            };
            sides.push([Some(front), back]);
        }
        let mut prim_surface = Vec::with_capacity(prims.len());
        let mut list = Vec::with_capacity(prims.len());
        let mut emitters = Vec::new();
        let mut emitter_cdf = Vec::new();
        let mut unsampled = Vec::new();
        let mut total = 0.0;
        for (k, (s, p)) in prims.into_iter().enumerate() {
            for back in [false, true] {
                let Some(m) = sides[s][usize::from(back)] else {
                    continue;
                };
                if m.e.iter().all(|v| *v <= 0.0) {
                    continue;
                }
                if matches!(p, Primitive::Triangle(_) | Primitive::Parallelogram(_)) {
                    total += p.area();
                    emitters.push((k as u32, back, m.e));
                    emitter_cdf.push(total);
                } else if !unsampled.contains(&scene.surfaces[s].name) {
                    unsampled.push(scene.surfaces[s].name.clone());
                }
            }
            prim_surface.push(s as u32);
            list.push(p);
        }
        let accel = Accel::build(list).map_err(|e| err(e.to_string()))?;
        let b = accel.bounds();
        Ok(Self {
            accel,
            prim_surface,
            sides,
            emitters,
            emitter_cdf,
            unsampled,
            bounds: (b.min, b.max),
        })
    }

    /// The accelerator (primitive ids index the scene's flattened primitives).
    pub fn accel(&self) -> &Accel {
        &self.accel
    }

    /// Scene surface index of a primitive.
    pub fn surface_of(&self, prim: u32) -> Option<usize> {
        self.prim_surface.get(prim as usize).map(|&s| s as usize)
    }

    /// Reflectance of a surface's side (`None`: a one-sided back).
    pub fn reflectance(&self, surface: usize, back: bool) -> Option<[f64; 3]> {
        self.sides.get(surface)?[usize::from(back)].map(|m| m.rho)
    }

    /// Exitance of a surface's side (`None`: a one-sided back).
    pub fn exitance(&self, surface: usize, back: bool) -> Option<[f64; 3]> {
        self.sides.get(surface)?[usize::from(back)].map(|m| m.e)
    }

    /// The scene surface and side (`true`: back) that the point `x` with unit normal
    /// `n` lies on: the first hit of a ray from just above `x` back along `−n`
    /// (`None` if nothing is within `1e-5 ×` the scene diagonal).
    pub fn side_at(&self, x: DVec3, n: DVec3) -> Option<(usize, bool)> {
        let d = 1e-6 * (self.bounds.1 - self.bounds.0).length();
        let hit = self.accel.closest_hit(
            &Ray {
                origin: x + n * d,
                dir: -n,
            },
            0.0,
            10.0 * d,
        )?;
        Some((self.surface_of(hit.prim)?, !hit.front))
    }

    /// Whether the scene has emitting sides.
    pub fn has_emitters(&self) -> bool {
        !self.emitters.is_empty() || !self.unsampled.is_empty()
    }

    /// Emitting surfaces whose shape (curved, polygon) the direct lighting cannot
    /// sample by area (only triangles and parallelograms are sampled).
    pub fn unsampled_emitters(&self) -> &[String] {
        &self.unsampled
    }
}

impl SurfaceQuery for SceneSurfaces {
    fn closest_hit(&self, origin: DVec3, dir: DVec3) -> Option<SurfaceHit> {
        let hit = self
            .accel
            .closest_hit(&Ray { origin, dir }, 0.0, f64::INFINITY)?;
        let s = *self.prim_surface.get(hit.prim as usize)? as usize;
        let back = !hit.front;
        let normal = if back { -hit.normal } else { hit.normal };
        Some(SurfaceHit {
            t: hit.t,
            point: hit.point,
            normal,
            reflectance: self.sides[s][usize::from(back)].map(|m| m.rho),
        })
    }

    fn occluded(&self, p: DVec3, q: DVec3) -> bool {
        self.accel.occluded(p, q, [None, None])
    }

    fn bounds(&self) -> (DVec3, DVec3) {
        self.bounds
    }

    fn sample_emitter(&self, u: [f64; 3]) -> Option<EmitterSample> {
        let total = *self.emitter_cdf.last()?;
        let x = u[0] * total;
        let j = self
            .emitter_cdf
            .partition_point(|&c| c <= x)
            .min(self.emitters.len() - 1);
        let (k, back, e) = self.emitters[j];
        let (point, normal) = match &self.accel.primitives()[k as usize] {
            Primitive::Triangle(t) => {
                // Equal-area square → triangle map.
                let su = u[1].sqrt();
                let (b, c) = (su * (1.0 - u[2]), su * u[2]);
                let p = t.v[0] + b * (t.v[1] - t.v[0]) + c * (t.v[2] - t.v[0]);
                (p, t.normal())
            }
            Primitive::Parallelogram(q) => (q.origin + u[1] * q.e1 + u[2] * q.e2, q.normal()),
            _ => return None,
        };
        Some(EmitterSample {
            point,
            normal: if back { -normal } else { normal },
            exitance: e,
            total_area: total,
        })
    }
}

/// The inside of a closed sphere of uniform reflectance (normals point inwards; the
/// outside is a black back): an analytic [`SurfaceQuery`] for closed-form tests
/// (Meshless §5.1: the algorithms need nothing else).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SphereInterior {
    /// Centre.
    pub center: DVec3,
    /// Radius (> 0).
    pub radius: f64,
    /// Reflectance of the inside.
    pub reflectance: [f64; 3],
}

impl SurfaceQuery for SphereInterior {
    fn closest_hit(&self, origin: DVec3, dir: DVec3) -> Option<SurfaceHit> {
        let oc = origin - self.center;
        let b = oc.dot(dir);
        let c = oc.length_squared() - self.radius * self.radius;
        let disc = b * b - c;
        if !(disc >= 0.0) {
            return None;
        }
        let s = disc.sqrt();
        // Stable roots of t² + 2bt + c = 0.
        let q = -b - s.copysign(b);
        let (t0, t1) = if q == 0.0 { (0.0, 0.0) } else { (c / q, q) };
        let (lo, hi) = (t0.min(t1), t0.max(t1));
        let eps = 1e-12 * self.radius;
        let t = if lo > eps {
            lo
        } else if hi > eps {
            hi
        } else {
            return None;
        };
        let point = origin + dir * t;
        let outward = (point - self.center) / self.radius;
        let inside = dir.dot(outward) > 0.0;
        Some(SurfaceHit {
            t,
            point,
            normal: if inside { -outward } else { outward },
            reflectance: inside.then_some(self.reflectance),
        })
    }

    fn occluded(&self, p: DVec3, q: DVec3) -> bool {
        // Two points inside (or on) a sphere see each other: the ball is convex.
        let r = self.radius * (1.0 + 1e-9);
        !((p - self.center).length() <= r && (q - self.center).length() <= r)
    }

    fn bounds(&self) -> (DVec3, DVec3) {
        (
            self.center - DVec3::splat(self.radius),
            self.center + DVec3::splat(self.radius),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sphere_hits_from_inside_have_inward_normals() {
        let s = SphereInterior {
            center: DVec3::new(1.0, 2.0, 3.0),
            radius: 2.0,
            reflectance: [0.5; 3],
        };
        let o = s.center + DVec3::new(0.5, 0.0, 0.0);
        let h = s.closest_hit(o, DVec3::X).unwrap();
        assert!((h.t - 1.5).abs() < 1e-12);
        assert!((h.normal + DVec3::X).length() < 1e-12);
        assert_eq!(h.reflectance, Some([0.5; 3]));
        // From outside: the black back.
        let o = s.center + DVec3::new(-5.0, 0.0, 0.0);
        let h = s.closest_hit(o, DVec3::X).unwrap();
        assert!((h.t - 3.0).abs() < 1e-12);
        assert_eq!(h.reflectance, None);
        assert!(s.closest_hit(o, -DVec3::X).is_none());
    }
}
