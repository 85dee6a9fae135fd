//! One acceleration structure over all primitives (obvhs compressed wide BVH, CWBVH):
//! closest hit, occlusion between two points (Ziegler §2.4: the visibility term of the
//! kernel), batched over slices of queries and parallel with rayon.
//!
//! obvhs builds and traverses in f32; we hand it conservatively padded f32 boxes of
//! every primitive and do every primitive test exactly in f64 in the traversal
//! callbacks (triangles with the watertight test, everything else through
//! [`Primitive::intersect`]). Triangles are stored in BVH leaf order for locality.
//!
//! # Epsilons (scale aware)
//! With `D` the diagonal of the scene's bounding box:
//! - every occlusion query ignores hits within `EPS_REL · D` (1e-9 D) of either endpoint;
//! - primitives named in `ignore` (the surfaces the endpoints lie on) are skipped when
//!   planar (they cannot occlude a segment that starts on them) and, when curved, only
//!   hits within `SELF_EPS_REL · D` (1e-6 D) of an endpoint are ignored, so a torus or
//!   a Bézier patch still shadows itself;
//! - the f32 BVH is built and traversed in a normalised frame `x' = (x − c)·s` (`c` the
//!   box centre, `s` the power of two with `D·s ∈ (½, 1]`), so f32 rounding is relative
//!   to the scene at every scale; f32 boxes are padded by `1e-5 D·s + 1e-6` (normalised
//!   units) to absorb it;
//! - each f32 ray starts where the f64 ray enters the (padded) scene box, backed off by
//!   [`TRAVERSAL_BACKOFF`] normalised units: obvhs' node test clamps entry distances to
//!   an absolute `1e-4` (`cwbvh::node::EPSILON`), which would otherwise cull every box
//!   within `1e-4` of the origin — the whole scene when it is ~1e-4 units small.
//!
//! Planar primitives are dilated by 1e-9 of their size and triangles are watertight, so
//! rays through shared edges and corners do not leak.

use std::time::Duration;

use glam::{DVec3, Vec3A};
use obvhs::BvhBuildParams;
use obvhs::aabb::Aabb as FAabb;
use obvhs::cwbvh::CwBvh;
use obvhs::cwbvh::builder::build_cwbvh;
use obvhs::ray::{Ray as FRay, RayHit};
use rayon::prelude::*;

use crate::GeometryError;
use crate::backend::{AccelExport, ExportFrame, ExportSlot, OcclusionStats, SlotKind};
use crate::intersect::WatertightRay;
use crate::primitive::{Aabb, Hit, PrimId, Primitive, Ray, Triangle};

/// Relative end-point epsilon of occlusion queries (times the scene diagonal).
pub const EPS_REL: f64 = 1e-9;
/// Relative self-hit epsilon for curved primitives named in `ignore`.
pub const SELF_EPS_REL: f64 = 1e-6;
/// Distance (normalised units, scene diagonal ∈ (½, 1]) by which f32 rays start before
/// the query interval: ten times obvhs' absolute node-entry clamp of `1e-4`.
pub const TRAVERSAL_BACKOFF: f64 = 1e-3;
/// Batches of at least this many queries are answered in a coherent order (see
/// [`Accel::occluded_queries`]); smaller ones in their own order.
pub const COHERENT_MIN: usize = 4096;

#[derive(Debug, Clone, Copy)]
enum Slot {
    Tri([DVec3; 3], PrimId),
    Other(PrimId),
}

/// A two-point visibility query: is the open segment `p → q` blocked?
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OcclusionQuery {
    /// First end point.
    pub p: DVec3,
    /// Second end point.
    pub q: DVec3,
    /// Primitives the end points lie on (see the module docs).
    pub ignore: [Option<PrimId>; 2],
}

/// BVH over a set of primitives.
#[derive(Debug)]
pub struct Accel {
    prims: Vec<Primitive>,
    planar: Vec<bool>,
    bvh: Option<CwBvh>,
    slots: Vec<Slot>,
    bounds: Aabb,
    diag: f64,
    frame: Frame,
}

/// The normalised f32 traversal frame `x' = (x − centre)·scale` (module docs).
#[derive(Debug, Clone, Copy)]
struct Frame {
    centre: DVec3,
    scale: f64,
    /// Box padding in normalised units.
    pad: f64,
}

impl Frame {
    fn new(bounds: &Aabb, diag: f64) -> Frame {
        let scale = if diag > 0.0 && diag.is_finite() {
            // Power of two: D·scale ∈ (½, 1]; exact scaling.
            2f64.powi(-(diag.log2().ceil() as i32))
        } else {
            1.0
        };
        Frame {
            centre: 0.5 * (bounds.min + bounds.max),
            scale,
            pad: 1e-5 * diag * scale + 1e-6,
        }
    }

    fn f32_box(&self, b: &Aabb) -> FAabb {
        let lo = (b.min - self.centre) * self.scale - DVec3::splat(self.pad);
        let hi = (b.max - self.centre) * self.scale + DVec3::splat(self.pad);
        FAabb::new(
            Vec3A::new(lo.x as f32, lo.y as f32, lo.z as f32),
            Vec3A::new(hi.x as f32, hi.y as f32, hi.z as f32),
        )
    }

    /// The f32 ray covering `t ∈ [tmin, tmax]` of `ray`, clipped to the padded scene box
    /// `bounds`, and the f64 parameter `t_start` its origin was taken at (backed off by
    /// [`TRAVERSAL_BACKOFF`]); `None` if the interval misses the box.
    fn ray(&self, bounds: &Aabb, ray: &Ray, tmin: f64, tmax: f64) -> Option<(FRay, f64)> {
        let pad = self.pad / self.scale;
        let (mut t0, mut t1) = (tmin, tmax);
        for a in 0..3 {
            let (o, d) = (ray.origin[a], ray.dir[a]);
            let (lo, hi) = (bounds.min[a] - pad, bounds.max[a] + pad);
            if d == 0.0 {
                if o < lo || o > hi {
                    return None;
                }
            } else {
                let (ta, tb) = ((lo - o) / d, (hi - o) / d);
                t0 = t0.max(ta.min(tb));
                t1 = t1.min(ta.max(tb));
            }
        }
        if t0 > t1 || t0.is_nan() || t1.is_nan() {
            return None;
        }
        let start = (ray.origin + ray.dir * t0 - self.centre) * self.scale;
        let o = start - ray.dir * TRAVERSAL_BACKOFF;
        // `+ 0.0` turns negative zeros into positive ones: obvhs's slab test takes
        // `1/d`, and `−∞` from `−0.0` culled every box (rays along `−X` missed
        // everything).
        let d = ray.dir + DVec3::ZERO;
        let t_max = self.param(t1, t0) * (1.0 + 1e-5) + self.pad;
        Some((
            FRay::new(
                Vec3A::new(o.x as f32, o.y as f32, o.z as f32),
                Vec3A::new(d.x as f32, d.y as f32, d.z as f32),
                0.0,
                t_max as f32,
            ),
            t0,
        ))
    }

    /// The f32 ray parameter of the f64 ray parameter `t` (origin taken at `t_start`).
    fn param(&self, t: f64, t_start: f64) -> f64 {
        (t - t_start) * self.scale + TRAVERSAL_BACKOFF
    }
}

impl Accel {
    /// Builds the BVH (obvhs PLOC + reinsertion, collapsed to CWBVH, `medium_build` preset).
    ///
    /// # Errors
    /// [`GeometryError::NonFinite`] if a primitive has a non-finite bounding box, or
    /// [`GeometryError::OutOfRange`] for more than `u32::MAX − 1` primitives.
    pub fn build(prims: Vec<Primitive>) -> Result<Accel, GeometryError> {
        Accel::build_with(prims, BvhBuildParams::medium_build())
    }

    /// Builds a triangle-only accelerator.
    ///
    /// # Errors
    /// As [`Accel::build`].
    pub fn from_triangles(tris: &[Triangle]) -> Result<Accel, GeometryError> {
        Accel::build(tris.iter().map(|t| Primitive::Triangle(*t)).collect())
    }

    /// Builds with explicit obvhs build parameters.
    ///
    /// # Errors
    /// As [`Accel::build`].
    pub fn build_with(
        prims: Vec<Primitive>,
        params: BvhBuildParams,
    ) -> Result<Accel, GeometryError> {
        if prims.len() >= u32::MAX as usize {
            return Err(GeometryError::OutOfRange {
                index: prims.len(),
                len: u32::MAX as usize - 1,
            });
        }
        let boxes: Vec<Aabb> = prims.par_iter().map(Primitive::aabb).collect();
        let mut bounds = Aabb::EMPTY;
        for b in &boxes {
            if !b.min.is_finite() || !b.max.is_finite() {
                return Err(GeometryError::NonFinite("primitive bounding box"));
            }
            bounds = bounds.union(b);
        }
        let diag = bounds.diagonal().length();
        let planar: Vec<bool> = prims.iter().map(Primitive::is_planar).collect();
        let frame = Frame::new(&bounds, diag);
        if prims.is_empty() {
            return Ok(Accel {
                prims,
                planar,
                bvh: None,
                slots: Vec::new(),
                bounds,
                diag,
                frame,
            });
        }
        let fboxes: Vec<FAabb> = boxes.iter().map(|b| frame.f32_box(b)).collect();
        let bvh = build_cwbvh(&fboxes, params, &mut Duration::default());
        let slots = bvh
            .primitive_indices
            .iter()
            .map(|&i| match &prims[i as usize] {
                Primitive::Triangle(t) => Slot::Tri(t.v, i),
                _ => Slot::Other(i),
            })
            .collect();
        Ok(Accel {
            prims,
            planar,
            bvh: Some(bvh),
            slots,
            bounds,
            diag,
            frame,
        })
    }

    /// Number of primitives.
    pub fn len(&self) -> usize {
        self.prims.len()
    }

    /// True if there are no primitives.
    pub fn is_empty(&self) -> bool {
        self.prims.is_empty()
    }

    /// The primitives, indexed by [`PrimId`].
    pub fn primitives(&self) -> &[Primitive] {
        &self.prims
    }

    /// Scene bounding box.
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// End-point epsilon of occlusion queries, `EPS_REL ·` scene diagonal.
    pub fn eps(&self) -> f64 {
        EPS_REL * self.diag
    }

    /// Closest hit with `t ∈ [tmin, tmax]` (use `tmax = f64::INFINITY` for an unbounded ray).
    pub fn closest_hit(&self, ray: &Ray, tmin: f64, tmax: f64) -> Option<Hit> {
        let bvh = self.bvh.as_ref()?;
        let mut best: Option<Hit> = None;
        let mut best_t = tmax;
        let mut rh = RayHit::none();
        let slack = 1e-5 * self.diag;
        let (fray, t_start) = self.frame.ray(&self.bounds, ray, tmin, tmax)?;
        let wray = WatertightRay::new(ray);
        bvh.ray_traverse(fray, &mut rh, |_, slot| {
            let hit = match &self.slots[slot] {
                Slot::Tri(v, id) => wray.triangle(v, tmin, best_t).map(|(t, b, c)| {
                    let tri = Triangle { v: *v };
                    let mut h = tri.intersect_from(ray, t, b, c);
                    h.prim = *id;
                    h
                }),
                &Slot::Other(id) => {
                    self.prims[id as usize]
                        .intersect(ray, tmin, best_t)
                        .map(|mut h| {
                            h.prim = id;
                            h
                        })
                }
            };
            match hit {
                Some(h) if h.t < best_t || best.is_none() => {
                    best_t = h.t;
                    best = Some(h);
                    self.frame.param(h.t + slack, t_start) as f32
                }
                _ => f32::INFINITY,
            }
        });
        best
    }

    /// Is the open segment `p → q` blocked by any primitive (see the module docs for
    /// epsilons and `ignore`)? Coincident end points are never occluded.
    pub fn occluded(&self, p: DVec3, q: DVec3, ignore: [Option<PrimId>; 2]) -> bool {
        let Some(bvh) = self.bvh.as_ref() else {
            return false;
        };
        let len = (q - p).length();
        if len == 0.0 || !len.is_finite() {
            return false;
        }
        let ray = Ray {
            origin: p,
            dir: (q - p) / len,
        };
        let eps = EPS_REL * self.diag;
        let self_eps = SELF_EPS_REL * self.diag;
        let (t0, t1) = (eps, len - eps);
        if t0 >= t1 {
            return false;
        }
        let is_ignored = |id: PrimId| ignore[0] == Some(id) || ignore[1] == Some(id);
        // What `traversal_ray(p, q)` returns, without recomputing the ray.
        let Some((fray, _)) = self.frame.ray(&self.bounds, &ray, 0.0, len) else {
            return false;
        };
        let wray = WatertightRay::new(&ray);
        !bvh.ray_traverse_miss(fray, |_, slot| {
            let blocked = match &self.slots[slot] {
                Slot::Tri(v, id) => !is_ignored(*id) && wray.triangle(v, t0, t1).is_some(),
                &Slot::Other(id) => {
                    if is_ignored(id) {
                        !self.planar[id as usize]
                            && self.prims[id as usize]
                                .intersect(&ray, self_eps, len - self_eps)
                                .is_some()
                    } else {
                        self.prims[id as usize].intersect(&ray, t0, t1).is_some()
                    }
                }
            };
            if blocked { 0.0 } else { f32::INFINITY }
        })
    }

    /// Occlusion of many segments in parallel (rayon); `out[i]` answers `pairs[i]` with
    /// no `ignore` (end-point epsilon only). Batches of [`COHERENT_MIN`] or more are
    /// traversed in a coherent order (same answers, about twice the throughput on
    /// random segments).
    ///
    /// # Errors
    /// [`GeometryError::OutOfRange`] if `out` and `pairs` differ in length.
    pub fn occluded_batch(
        &self,
        pairs: &[(DVec3, DVec3)],
        out: &mut [bool],
    ) -> Result<(), GeometryError> {
        if out.len() != pairs.len() {
            return Err(GeometryError::OutOfRange {
                index: out.len(),
                len: pairs.len(),
            });
        }
        self.in_coherent_order(pairs.iter().map(|&(p, q)| (p, q - p)), out, |i| {
            let (p, q) = pairs[i];
            self.occluded(p, q, [None, None])
        });
        Ok(())
    }

    /// Occlusion of many queries with per-query `ignore` lists, in parallel (rayon).
    /// The statistics count every query as deferred to the CPU (the reference
    /// [`crate::backend::Occluder`]). Batches of [`COHERENT_MIN`] or more are traversed
    /// in a coherent order (same answers, about 1.5× the throughput on random
    /// segments).
    ///
    /// # Errors
    /// [`GeometryError::OutOfRange`] if `out` and `queries` differ in length.
    pub fn occluded_queries(
        &self,
        queries: &[OcclusionQuery],
        out: &mut [bool],
    ) -> Result<OcclusionStats, GeometryError> {
        if out.len() != queries.len() {
            return Err(GeometryError::OutOfRange {
                index: out.len(),
                len: queries.len(),
            });
        }
        self.in_coherent_order(queries.iter().map(|q| (q.p, q.q - q.p)), out, |i| {
            let qu = &queries[i];
            self.occluded(qu.p, qu.q, qu.ignore)
        });
        Ok(OcclusionStats {
            queries: queries.len(),
            device_rays: 0,
            deferred_rays: queries.len(),
        })
    }

    /// Closest hits of many rays in parallel (rayon), each over `t ∈ [tmin, tmax]`;
    /// batches of [`COHERENT_MIN`] or more in a coherent order (same answers).
    ///
    /// # Errors
    /// [`GeometryError::OutOfRange`] if `out` and `rays` differ in length.
    pub fn closest_hit_batch(
        &self,
        rays: &[Ray],
        tmin: f64,
        tmax: f64,
        out: &mut [Option<Hit>],
    ) -> Result<(), GeometryError> {
        if out.len() != rays.len() {
            return Err(GeometryError::OutOfRange {
                index: out.len(),
                len: rays.len(),
            });
        }
        self.in_coherent_order(rays.iter().map(|r| (r.origin, r.dir)), out, |i| {
            self.closest_hit(&rays[i], tmin, tmax)
        });
        Ok(())
    }

    /// Answers `out[i] = answer(i)` for every query `i`, in parallel, visiting the
    /// queries in an order in which neighbours traverse similar parts of the BVH (the
    /// batched traversal: random shadow rays are memory-bound, and answering them in
    /// this order halves the cache misses; `room_100k` in docs/performance.md). The
    /// order sorts by the octant of the direction, then by the Morton code of the
    /// origin on a 2¹⁰ grid of the scene box; batches below [`COHERENT_MIN`] keep
    /// their own order. The answers do not depend on the order.
    fn in_coherent_order<T: Send>(
        &self,
        rays: impl Iterator<Item = (DVec3, DVec3)>,
        out: &mut [T],
        answer: impl Fn(usize) -> T + Sync,
    ) {
        if out.len() < COHERENT_MIN {
            out.par_iter_mut()
                .with_min_len(256)
                .enumerate()
                .for_each(|(i, o)| *o = answer(i));
            return;
        }
        let ext = (self.bounds.max - self.bounds.min).max(DVec3::splat(f64::MIN_POSITIVE));
        // Spreads the 10 low bits of `v` to every third bit.
        let spread = |v: u64| {
            let mut x = v & 0x3ff;
            x = (x | (x << 16)) & 0x0300_00ff;
            x = (x | (x << 8)) & 0x0300_f00f;
            x = (x | (x << 4)) & 0x030c_30c3;
            (x | (x << 2)) & 0x0924_9249
        };
        let mut keys: Vec<(u64, u32)> = rays
            .enumerate()
            .map(|(i, (o, d))| {
                let oct =
                    u64::from(d.x < 0.0) | u64::from(d.y < 0.0) << 1 | u64::from(d.z < 0.0) << 2;
                // NaN end points land in cell 0 (`as` saturates); `occluded` answers them.
                let g =
                    ((o - self.bounds.min) / ext * 1023.0).clamp(DVec3::ZERO, DVec3::splat(1023.0));
                let m = spread(g.x as u64) | spread(g.y as u64) << 1 | spread(g.z as u64) << 2;
                (oct << 30 | m, i as u32)
            })
            .collect();
        keys.par_sort_unstable();
        let sorted: Vec<T> = keys
            .par_iter()
            .with_min_len(256)
            .map(|&(_, i)| answer(i as usize))
            .collect();
        for ((_, i), a) in keys.into_iter().zip(sorted) {
            out[i as usize] = a;
        }
    }

    /// Brute-force closest hit over all primitives (reference for tests).
    pub fn closest_hit_brute(&self, ray: &Ray, tmin: f64, tmax: f64) -> Option<Hit> {
        let mut best: Option<Hit> = None;
        for (i, p) in self.prims.iter().enumerate() {
            let bt = best.map_or(tmax, |b| b.t);
            if let Some(mut h) = p.intersect(ray, tmin, bt) {
                h.prim = i as PrimId;
                best = Some(h);
            }
        }
        best
    }

    /// Brute-force occlusion with the same epsilon rules as [`Accel::occluded`] (reference for tests).
    pub fn occluded_brute(&self, p: DVec3, q: DVec3, ignore: [Option<PrimId>; 2]) -> bool {
        let len = (q - p).length();
        if len == 0.0 || !len.is_finite() || self.prims.is_empty() {
            return false;
        }
        let ray = Ray {
            origin: p,
            dir: (q - p) / len,
        };
        let eps = EPS_REL * self.diag;
        let self_eps = SELF_EPS_REL * self.diag;
        if 2.0 * eps >= len {
            return false;
        }
        self.prims.iter().enumerate().any(|(i, pr)| {
            let id = i as PrimId;
            if ignore.contains(&Some(id)) {
                !self.planar[i] && pr.intersect(&ray, self_eps, len - self_eps).is_some()
            } else {
                pr.intersect(&ray, eps, len - eps).is_some()
            }
        })
    }
}

/// The upload view for device backends (issue 17; kept apart from the traversal code).
impl Accel {
    /// The f32 ray [`Accel::occluded`] traverses for the segment `p → q` (normalised
    /// frame, clipped to the padded scene box and backed off by [`TRAVERSAL_BACKOFF`]);
    /// `None` when `occluded` answers without traversal (empty scene, coincident or
    /// non-finite end points, a segment missing the scene box).
    pub fn traversal_ray(&self, p: DVec3, q: DVec3) -> Option<FRay> {
        self.bvh.as_ref()?;
        let len = (q - p).length();
        if len == 0.0 || !len.is_finite() {
            return None;
        }
        let ray = Ray {
            origin: p,
            dir: (q - p) / len,
        };
        self.frame
            .ray(&self.bounds, &ray, 0.0, len)
            .map(|(fray, _)| fray)
    }

    /// The upload view: this accelerator's own CWBVH nodes, one [`ExportSlot`] per
    /// leaf entry in leaf order (the order `occluded` visits them through), and the
    /// frame constants (see [`crate::backend`]).
    pub fn export(&self) -> AccelExport<'_> {
        let f = self.frame;
        let to = |x: DVec3| {
            let y = (x - f.centre) * f.scale;
            [y.x as f32, y.y as f32, y.z as f32]
        };
        let slots = match &self.bvh {
            None => Vec::new(),
            Some(bvh) => bvh
                .primitive_indices
                .iter()
                .map(|&i| {
                    let prim = &self.prims[i as usize];
                    let (kind, pts): (SlotKind, Vec<DVec3>) = match prim {
                        Primitive::Triangle(t) => (SlotKind::Triangle, t.v.to_vec()),
                        Primitive::Parallelogram(g) => (SlotKind::Quad, g.corners().to_vec()),
                        Primitive::Polygon(poly) if convex_corners(&poly.region).is_some() => {
                            let c = convex_corners(&poly.region).unwrap_or_default();
                            let kind = if c.len() == 3 {
                                SlotKind::Triangle
                            } else {
                                SlotKind::Quad
                            };
                            (kind, c.iter().map(|q| poly.frame.to_world(*q)).collect())
                        }
                        Primitive::Polygon(poly) => {
                            let (lo, hi) = poly.region.bounds();
                            let fr = &poly.frame;
                            (
                                SlotKind::Plane,
                                vec![
                                    fr.to_world(lo),
                                    fr.to_world(glam::DVec2::new(hi.x, lo.y)),
                                    fr.to_world(glam::DVec2::new(lo.x, hi.y)),
                                ],
                            )
                        }
                        _ => (SlotKind::Curved, Vec::new()),
                    };
                    let mut points = [[0f32; 3]; 4];
                    for (dst, p) in points.iter_mut().zip(&pts) {
                        *dst = to(*p);
                    }
                    let size = if pts.is_empty() {
                        0.0
                    } else {
                        let b = Aabb::from_points(pts.iter().copied());
                        // Rounded up so the error bounds stay bounds.
                        ((b.max - b.min).max_element() * f.scale * (1.0 + 1e-6)) as f32
                    };
                    ExportSlot {
                        prim: i,
                        kind,
                        planar: self.planar[i as usize],
                        points,
                        size,
                    }
                })
                .collect(),
        };
        AccelExport {
            nodes: self.bvh.as_ref().map_or(&[][..], |b| &b.nodes[..]),
            slots,
            frame: ExportFrame {
                centre: f.centre,
                scale: f.scale,
                pad: f.pad,
                eps: EPS_REL * self.diag,
            },
        }
    }
}

/// The corners of a region that is one strictly convex loop of three or four straight
/// segments (counter-clockwise), or `None`.
fn convex_corners(region: &crate::trim::TrimRegion) -> Option<Vec<glam::DVec2>> {
    let [lp] = region.loops.as_slice() else {
        return None;
    };
    let mut pts = Vec::new();
    for e in &lp.edges {
        match e {
            crate::trim::Edge2::Segment { a, .. } => pts.push(*a),
            _ => return None,
        }
    }
    if !(3..=4).contains(&pts.len()) {
        return None;
    }
    let n = pts.len();
    let size = (region.bounds().1 - region.bounds().0).max_element();
    for i in 0..n {
        let (a, b, c) = (pts[i], pts[(i + 1) % n], pts[(i + 2) % n]);
        // Strictly convex turn at every corner, well above rounding.
        if (b - a).perp_dot(c - b) <= 1e-9 * size * size {
            return None;
        }
    }
    Some(pts)
}
