//! Radiosity fields: what the renderer evaluates at a ray hit.
//!
//! [`RadiosityField`] is the renderer's view of "any solution": geometry to trace
//! against, and the exitant radiosity, emission and reflectance of the side of a
//! surface a ray hit. [`SolutionField`] implements it for a
//! `wavelux_solver::Solution`: its accelerator holds one primitive per solver support
//! (the same pieces the solver meshed), and a hit is mapped to the solver's
//! `(patch, s, t)` by inverting the support's equal-area map (parallelogram: affine;
//! triangle: `a + √s((1−t)(b−a) + t(c−a))`; disk: Shirley–Chiu concentric).

use glam::{DVec2, DVec3};
use wavelux_geometry::{
    Accel, ComplexPolygon, Edge2, Hit, Parallelogram, PlaneFrame, Primitive, Triangle, TrimLoop,
    TrimRegion,
};
use wavelux_solver::{Side, Solution, SupportMap};

use crate::RenderError;

/// Where a ray landed on a field's geometry, resolved to a lit side.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfacePoint {
    /// Index of the scene surface.
    pub surface: usize,
    /// Field-specific index of the lit side (a solver patch for [`SolutionField`]).
    pub side_index: usize,
    /// Parameters on the side's unit-square support.
    pub st: DVec2,
    /// World position.
    pub point: DVec3,
    /// Unit normal of the lit side (pointing towards the viewer).
    pub normal: DVec3,
}

/// Anything the renderer can evaluate: traceable geometry plus the exitant radiosity
/// (W/m², RGB) of every lit side.
pub trait RadiosityField: Sync {
    /// The accelerator rays are traced against.
    fn accel(&self) -> &Accel;
    /// Resolves a hit to a lit side; `None` for the back of a one-sided surface (a
    /// black occluder) or a primitive the field does not know.
    fn resolve(&self, hit: &Hit) -> Option<SurfacePoint>;
    /// Exitant radiosity `B` at a resolved point (W/m², RGB).
    fn radiosity(&self, p: &SurfacePoint) -> [f64; 3];
    /// Emitted exitance `E` of the lit side (W/m², RGB).
    fn emission(&self, p: &SurfacePoint) -> [f64; 3];
    /// Diffuse reflectance `ρ` of the lit side.
    fn reflectance(&self, p: &SurfacePoint) -> [f64; 3];
    /// A point drawn uniformly by area over all emitting sides from `u ∈ [0,1)³`, for
    /// next-event estimation: `(point, unit normal of the emitting side, E, total
    /// emitting area, primitive id)`. `None` (the default) if the field cannot sample
    /// its emitters; the final gather then finds emitters by its own rays only.
    fn sample_emitter(&self, _u: [f64; 3]) -> Option<EmitterSample> {
        None
    }
}

/// A point on an emitter drawn uniformly by area (see
/// [`RadiosityField::sample_emitter`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EmitterSample {
    /// Position.
    pub point: DVec3,
    /// Unit normal of the emitting side.
    pub normal: DVec3,
    /// Emitted exitance (W/m²).
    pub emission: [f64; 3],
    /// Total area of all emitting sides (the pdf is its inverse).
    pub total_area: f64,
    /// Primitive id in the field's accelerator.
    pub prim: u32,
}

/// A `wavelux_solver::Solution` as a [`RadiosityField`].
#[derive(Debug)]
pub struct SolutionField<'a> {
    /// The solution.
    pub solution: &'a Solution,
    accel: Accel,
    /// `[front patch, back patch]` per primitive (support piece).
    sides: Vec<[Option<usize>; 2]>,
    pieces: Vec<SupportMap>,
    /// Emitting patches and the cumulative area.
    emitters: (Vec<usize>, Vec<f64>),
}

fn geo(e: wavelux_geometry::GeometryError) -> RenderError {
    RenderError::Scene(e.to_string())
}

/// The primitive that the support map covers.
pub(crate) fn support_primitive(map: &SupportMap) -> Result<Primitive, RenderError> {
    Ok(match *map {
        SupportMap::Parallelogram {
            origin,
            edge_u,
            edge_v,
        } => Primitive::Parallelogram(Parallelogram::new(origin, edge_u, edge_v).map_err(geo)?),
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
            let edge = Edge2::arc(DVec2::ZERO, radius, 0.0, std::f64::consts::TAU).map_err(geo)?;
            let region =
                TrimRegion::new(vec![TrimLoop::new(vec![edge]).map_err(geo)?]).map_err(geo)?;
            Primitive::Polygon(Box::new(ComplexPolygon::new(frame, region).map_err(geo)?))
        }
        #[allow(unreachable_patterns)]
        _ => {
            return Err(RenderError::Scene(
                "solver support kind not known to the renderer".into(),
            ));
        }
    })
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

/// Inverse of a support map for a point on (or numerically near) its image.
pub(crate) fn invert_support(map: &SupportMap, p: DVec3) -> DVec2 {
    let st = match *map {
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
        #[allow(unreachable_patterns)]
        _ => DVec2::splat(0.5),
    };
    st.clamp(DVec2::ZERO, DVec2::ONE)
}

impl<'a> SolutionField<'a> {
    /// Builds the accelerator over the solution's supports.
    ///
    /// # Errors
    /// [`RenderError::Scene`] if a support is degenerate or the BVH cannot be built.
    pub fn new(solution: &'a Solution) -> Result<Self, RenderError> {
        let n = solution
            .patches
            .iter()
            .map(|p| p.prim as usize + 1)
            .max()
            .unwrap_or(0);
        let mut sides = vec![[None, None]; n];
        let mut pieces: Vec<Option<SupportMap>> = vec![None; n];
        for (i, p) in solution.patches.iter().enumerate() {
            let k = p.prim as usize;
            match p.side {
                Side::Front => {
                    sides[k][0] = Some(i);
                    pieces[k] = Some(p.support.map);
                }
                Side::Back => {
                    sides[k][1] = Some(i);
                    if pieces[k].is_none() {
                        pieces[k] = Some(p.support.map);
                    }
                }
            }
        }
        let pieces: Vec<SupportMap> = pieces
            .into_iter()
            .map(|m| m.ok_or_else(|| RenderError::Scene("solution has a gap in its pieces".into())))
            .collect::<Result<_, _>>()?;
        let prims = pieces
            .iter()
            .map(support_primitive)
            .collect::<Result<Vec<_>, _>>()?;
        let accel = Accel::build(prims).map_err(geo)?;
        let mut emitters = (Vec::new(), Vec::new());
        let mut tot = 0.0;
        for (i, p) in solution.patches.iter().enumerate() {
            if p.emission.iter().any(|&e| e > 0.0) {
                tot += p.support.area;
                emitters.0.push(i);
                emitters.1.push(tot);
            }
        }
        Ok(Self {
            solution,
            accel,
            sides,
            pieces,
            emitters,
        })
    }
}

impl RadiosityField for SolutionField<'_> {
    fn accel(&self) -> &Accel {
        &self.accel
    }

    fn resolve(&self, hit: &Hit) -> Option<SurfacePoint> {
        let k = hit.prim as usize;
        let [front, back] = *self.sides.get(k)?;
        let patch = if hit.front { front? } else { back? };
        let st = invert_support(&self.pieces[k], hit.point);
        let p = &self.solution.patches[patch];
        Some(SurfacePoint {
            surface: p.surface,
            side_index: patch,
            st,
            point: hit.point,
            normal: if hit.front { hit.normal } else { -hit.normal },
        })
    }

    fn radiosity(&self, p: &SurfacePoint) -> [f64; 3] {
        self.solution.radiosity(p.side_index, p.st.x, p.st.y)
    }

    fn emission(&self, p: &SurfacePoint) -> [f64; 3] {
        self.solution.patches[p.side_index].emission
    }

    fn reflectance(&self, p: &SurfacePoint) -> [f64; 3] {
        self.solution.patches[p.side_index].reflectance
    }

    fn sample_emitter(&self, u: [f64; 3]) -> Option<EmitterSample> {
        let (ids, cdf) = &self.emitters;
        let tot = *cdf.last()?;
        let x = u[0] * tot;
        let j = cdf.partition_point(|&c| c <= x).min(ids.len() - 1);
        let p = &self.solution.patches[ids[j]];
        // Every support map is equal-area, so uniform (s, t) is uniform by area.
        Some(EmitterSample {
            point: p.support.point(u[1], u[2]),
            normal: p.support.normal,
            emission: p.emission,
            total_area: tot,
            prim: p.prim,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use wavelux_solver::Support;

    #[test]
    fn support_maps_invert() {
        let supports = [
            Support::parallelogram(
                DVec3::new(0.1, 0.2, 0.3),
                DVec3::new(1.0, 0.2, 0.0),
                DVec3::new(0.3, 0.0, 2.0),
            ),
            Support::triangle(
                DVec3::new(0.0, 1.0, 0.0),
                DVec3::new(2.0, 0.5, 0.1),
                DVec3::new(0.4, 0.3, 1.5),
            ),
            Support::disk(DVec3::new(1.0, 2.0, 3.0), DVec3::X, DVec3::Z, 0.7),
        ];
        for s in &supports {
            for i in 1..10 {
                for j in 1..10 {
                    let (a, b) = (i as f64 / 10.0, j as f64 / 10.0);
                    let st = invert_support(&s.map, s.point(a, b));
                    assert!(
                        (st - DVec2::new(a, b)).length() < 1e-9,
                        "{:?} ({a},{b}) -> {st}",
                        s.map
                    );
                }
            }
        }
    }
}
