//! Radiosity fields: what the renderer evaluates at a ray hit.
//!
//! [`RadiosityField`] is the renderer's view of "any solution": geometry to trace
//! against, and the exitant radiosity, emission and reflectance of the side of a
//! surface a ray hit. [`SolutionField`] implements it for a
//! `wavelux_solver::Solution`: its accelerator holds one exact primitive per solver
//! support (the same pieces the solver meshed; for a Virtual Mesh *virtual* support
//! only its real part: the masked polygon, the trimmed patch), and a hit is mapped to
//! the solver's `(patch, s, t)` by inverting the support's map (parallelogram:
//! affine; triangle: `a + √s((1−t)(b−a) + t(c−a))`; disk: Shirley–Chiu concentric;
//! curved `Ψ(Λ(s,t))`: the hit's parameters on `Ψ` — the trimmed patch's own `(u, v)` —
//! through `Λ⁻¹`, VirtualMesh §3 Fig. 3).
//!
//! Emitters are sampled uniformly by *real* area (virtual points of a masked support
//! are rejected; the equal-area maps make uniform `(s, t)` uniform by area), with the
//! per-point normal of curved supports. Supports on non-equal-area maps are not
//! sampled (the final gather then finds their light by its own rays).
//!
//! [`side_average`] is the real-area average of one side of a surface (what a user
//! reads as the surface's radiosity).

use glam::{DVec2, DVec3};
use rand::RngExt;
use std::sync::OnceLock;
use wavelux_geometry::{Accel, Hit};
use wavelux_solver::{Side, Solution, Statistics, Support, SupportMap};

use crate::RenderError;
use crate::direct::DirectLight;
use crate::sampling::rng_for;

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
    /// The field's emitters for exact direct light ([`DirectLight`]); `None` (the
    /// default) if it cannot describe them.
    fn direct_light(&self) -> Option<&DirectLight> {
        None
    }
    /// The *indirect* part of the radiosity at `p` as the field represents it: the
    /// light that reached `p` after at least one reflection, `B − E − ρ·H_direct`
    /// (W/m², RGB). Rendering adds it to exact direct light. `None` (the default) if
    /// the field cannot separate it.
    fn indirect(&self, _p: &SurfacePoint) -> Option<[f64; 3]> {
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
    /// Emitters for exact direct light.
    direct: DirectLight,
    /// The indirect part `K(B − E)` as a solution on the same hierarchy, computed on
    /// first use (`None`: the solution cannot separate it).
    indirect: OnceLock<Option<Solution>>,
}

fn geo(e: wavelux_geometry::GeometryError) -> RenderError {
    RenderError::Scene(e.to_string())
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
        let mut pieces: Vec<Option<&Support>> = vec![None; n];
        for (i, p) in solution.patches.iter().enumerate() {
            let k = p.prim as usize;
            match p.side {
                Side::Front => {
                    sides[k][0] = Some(i);
                    pieces[k] = Some(&p.support);
                }
                Side::Back => {
                    sides[k][1] = Some(i);
                    if pieces[k].is_none() {
                        pieces[k] = Some(&p.support);
                    }
                }
            }
        }
        let pieces: Vec<&Support> = pieces
            .into_iter()
            .map(|m| m.ok_or_else(|| RenderError::Scene("solution has a gap in its pieces".into())))
            .collect::<Result<_, _>>()?;
        let prims = pieces
            .iter()
            .map(|s| s.primitive().map_err(|e| RenderError::Scene(e.to_string())))
            .collect::<Result<Vec<_>, _>>()?;
        let pieces: Vec<SupportMap> = pieces.iter().map(|s| s.map).collect();
        let accel = Accel::build(prims).map_err(geo)?;
        let mut emitters = (Vec::new(), Vec::new());
        let mut tot = 0.0;
        for (i, p) in solution.patches.iter().enumerate() {
            // Uniform (s, t) is uniform by area only on equal-area maps.
            if p.emission.iter().any(|&e| e > 0.0) && p.support.is_equal_area() {
                tot += p.support.real_area();
                emitters.0.push(i);
                emitters.1.push(tot);
            }
        }
        let lit: Vec<(u32, bool, [f64; 3])> = solution
            .patches
            .iter()
            .filter(|p| p.emission.iter().any(|&e| e > 0.0))
            .map(|p| (p.prim, p.side == Side::Back, p.emission))
            .collect();
        let direct = DirectLight::new(&accel, &lit)?;
        Ok(Self {
            solution,
            accel,
            sides,
            pieces,
            emitters,
            direct,
            indirect: OnceLock::new(),
        })
    }
}

/// The indirect part of a gathering solution, `K(B − E)` on the same hierarchy and
/// links (Galerkin: `B = E + K E + K(B − E)`, so this is what the solution holds beyond
/// the first bounce from the emitters); `None` for solutions without links (linkless
/// shooting, CDV's Haar conversion), whose operator is not stored.
fn indirect_solution(sol: &Solution) -> Option<Solution> {
    if sol.cdv_field().is_some() || sol.stats.links == 0 {
        return None;
    }
    let sys = sol.system();
    let leaf: [Vec<f64>; 3] = std::array::from_fn(|ch| {
        let mut x = sol.leaf_coefficients(ch);
        for (v, e) in x.iter_mut().zip(sys.emission(ch)) {
            *v -= e;
        }
        let mut y = vec![0.0; x.len()];
        sys.apply_k(ch, &x, &mut y);
        y
    });
    Some(Solution::new(
        sol.patches.clone(),
        sol.by_surface.clone(),
        sys.clone(),
        sol.basis().clone(),
        leaf,
        Statistics::default(),
        Vec::new(),
    ))
}

impl RadiosityField for SolutionField<'_> {
    fn accel(&self) -> &Accel {
        &self.accel
    }

    fn resolve(&self, hit: &Hit) -> Option<SurfacePoint> {
        let k = hit.prim as usize;
        let [front, back] = *self.sides.get(k)?;
        let patch = if hit.front { front? } else { back? };
        let st = SupportMap::invert(&self.pieces[k], hit.point, hit.uv);
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

    fn direct_light(&self) -> Option<&DirectLight> {
        Some(&self.direct)
    }

    fn indirect(&self, p: &SurfacePoint) -> Option<[f64; 3]> {
        self.indirect
            .get_or_init(|| indirect_solution(self.solution))
            .as_ref()
            .map(|s| s.radiosity(p.side_index, p.st.x, p.st.y))
    }

    fn sample_emitter(&self, u: [f64; 3]) -> Option<EmitterSample> {
        let (ids, cdf) = &self.emitters;
        let tot = *cdf.last()?;
        let x = u[0] * tot;
        let j = cdf.partition_point(|&c| c <= x).min(ids.len() - 1);
        let p = &self.solution.patches[ids[j]];
        let sup = &p.support;
        // Every sampled support map is equal-area, so uniform (s, t) is uniform by
        // area; virtual points of a masked support are rejected, further candidates
        // coming from a stream seeded by `u` (deterministic per sample).
        let (mut s, mut t) = (u[1], u[2]);
        if !sup.is_real(s, t) {
            let key = u.iter().fold(0u64, |a, v| a.rotate_left(21) ^ v.to_bits());
            let mut rng = rng_for(key, ids[j] as u64, 0xE417);
            let mut found = false;
            for _ in 0..100_000 {
                (s, t) = (rng.random(), rng.random());
                if sup.is_real(s, t) {
                    found = true;
                    break;
                }
            }
            if !found {
                return None;
            }
        }
        Some(EmitterSample {
            point: sup.point(s, t),
            normal: sup.normal_at(s, t),
            emission: p.emission,
            total_area: tot,
            prim: p.prim,
        })
    }
}

/// Real-area average radiosity of one side of a scene surface over all its pieces
/// (W/m², RGB): `Σ ∫_real B dA / Σ |real area|` from the solver's per-patch real
/// integrals (`Solution::patch_real_integral`, VirtualMesh §4.2: the virtual points of
/// a masked support do not count). The front side is `Solution::surface_average`; the
/// back side of a two-sided surface (e.g. the inside of a closed curved surface) has
/// no solver counterpart. `None` if the surface is out of range or has no piece lit on
/// that side.
pub fn side_average(solution: &Solution, surface: usize, side: Side) -> Option<[f64; 3]> {
    let mut acc = [0.0; 3];
    let mut area = 0.0;
    for &p in solution.by_surface.get(surface)? {
        if solution.patches[p].side != side {
            continue;
        }
        let (int, a) = solution.patch_real_integral(p);
        for c in 0..3 {
            acc[c] += int[c];
        }
        area += a;
    }
    (area > 0.0).then(|| acc.map(|v| v / area))
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
                    let st = s.map.invert(s.point(a, b), DVec2::ZERO);
                    assert!(
                        (st - DVec2::new(a, b)).length() < 1e-9,
                        "{:?} ({a},{b}) -> {st}",
                        s.map
                    );
                }
            }
        }
    }

    /// Rays aimed at real points of every support kind the solver builds (curved
    /// trimmed patches, masked polygons with arcs, disks, rectangles) hit the support's
    /// primitive there, and the hit maps back to the same `(s, t)`.
    #[test]
    fn hits_on_every_support_kind_map_back_to_their_parameters() {
        use wavelux_scene::{
            AnalyticPatch, AnalyticSurface, Loop, LoopEdge, Material, Placement, PolygonShape,
            Region, Rgb, Scene, Shape, Sidedness, Surface,
        };
        let mut sc = Scene::new("kinds");
        let m = sc.add_material(Material::lambertian("m", Rgb::grey(0.5), Rgb::BLACK));
        let pl = |o: DVec3| Placement {
            origin: o,
            axis: DVec3::Z,
            reference: DVec3::X,
        };
        let shapes = [
            Shape::Patch(AnalyticPatch {
                surface: AnalyticSurface::Sphere {
                    placement: pl(DVec3::new(0.0, 0.0, 3.0)),
                    radius: 0.7,
                    azimuth: (0.0, std::f64::consts::TAU),
                    latitude: (-1.2, 1.3),
                },
                trim: None,
            }),
            Shape::Patch(AnalyticPatch {
                surface: AnalyticSurface::Cylinder {
                    placement: pl(DVec3::new(3.0, 0.0, 0.0)),
                    radius: 0.5,
                    azimuth: (0.0, 5.0),
                    height: (0.0, 1.0),
                },
                trim: Some(Region {
                    outer: Loop::circle(DVec2::splat(0.5), 0.4),
                    holes: vec![],
                }),
            }),
            Shape::Polygon(PolygonShape {
                frame: wavelux_scene::PlaneFrame::from_directions(
                    DVec3::new(-3.0, 0.0, 0.0),
                    DVec3::new(1.0, 0.2, 0.0),
                    DVec3::Z,
                )
                .unwrap(),
                outer: Loop {
                    edges: vec![
                        LoopEdge::Segment {
                            start: DVec2::new(0.0, 0.0),
                        },
                        LoopEdge::Segment {
                            start: DVec2::new(2.0, 0.0),
                        },
                        LoopEdge::Arc {
                            start: DVec2::new(2.0, 1.0),
                            center: DVec2::new(1.0, 1.0),
                            ccw: true,
                        },
                        LoopEdge::Segment {
                            start: DVec2::new(0.0, 1.0),
                        },
                    ],
                },
                holes: vec![Loop::circle(DVec2::new(1.0, 0.8), 0.2)],
            }),
            Shape::Polygon(PolygonShape {
                frame: wavelux_scene::PlaneFrame::from_directions(
                    DVec3::new(0.0, -3.0, 0.0),
                    DVec3::X,
                    DVec3::Y,
                )
                .unwrap(),
                outer: Loop::circle(DVec2::ZERO, 0.6),
                holes: vec![],
            }),
            Shape::parallelogram(DVec3::new(0.0, 3.0, 0.0), DVec3::X, DVec3::Z),
        ];
        for (k, shape) in shapes.into_iter().enumerate() {
            sc.add_surface(Surface {
                name: format!("s{k}"),
                shape,
                material: m,
                sides: Sidedness::OneSided,
            });
        }
        let set = wavelux_solver::build_patches(&sc).unwrap();
        let mut kinds = std::collections::BTreeSet::new();
        for p in &set.patches {
            let sup = &p.support;
            kinds.insert(format!(
                "{}{}",
                match sup.map {
                    SupportMap::Mapped { .. } => "mapped",
                    SupportMap::Disk { .. } => "disk",
                    SupportMap::Triangle { .. } => "triangle",
                    _ => "parallelogram",
                },
                if sup.mask.is_some() { "+mask" } else { "" }
            ));
            let prim = sup.primitive().unwrap();
            let mut checked = 0;
            for i in 1..12 {
                for j in 1..12 {
                    let (a, b) = (i as f64 / 12.0, j as f64 / 12.0);
                    if !sup.is_real(a, b) {
                        continue;
                    }
                    let x = sup.point(a, b);
                    let n = sup.normal_at(a, b);
                    let ray = wavelux_geometry::Ray::new(x + 1e-3 * n, -n).unwrap();
                    let hit = prim.intersect(&ray, 0.0, 1.0).expect("hit at a real point");
                    assert!((hit.point - x).length() < 1e-6);
                    let st = sup.map.invert(hit.point, hit.uv);
                    assert!(
                        (st - DVec2::new(a, b)).length() < 1e-6,
                        "{:?} ({a},{b}) -> {st}",
                        sup.map
                    );
                    checked += 1;
                }
            }
            assert!(checked > 10, "{:?}", sup.map);
        }
        for k in [
            "mapped",
            "mapped+mask",
            "parallelogram+mask",
            "disk",
            "parallelogram",
        ] {
            assert!(kinds.contains(k), "{k} missing from {kinds:?}");
        }
    }
}
