//! Conservative shaft culling of the transfer blocks' shadow rays (the "shaft" of
//! Haines & Wallace 1994, *Shaft culling for efficient ray-cast radiosity*, in its
//! simplest conservative form).
//!
//! A transfer block shoots one shadow ray per sample pair
//! ([`crate::transfer::TransferCtx::block_seen`]); between two planar, unmasked node
//! cells the rays run between interior points of the two cells, so every ray lies in
//! the convex hull of the two cells' corners (the *shaft*). A primitive that cannot
//! meet that hull cannot block any of the rays; when no primitive can, the block is
//! computed without rays, and it is then the block the rays would have given (every
//! ray would have been visible, and the visible and unoccluded sums add the same terms
//! in the same order). The culling is an exact optimisation: it changes the number of
//! rays, not the geometry. Bitwise, a difference is possible only where the ray test
//! itself is decided by rounding: a ray starting on a cell and grazing a primitive
//! that lies in the cell's plane (a coplanar neighbour) can be reported blocked by the
//! accelerator; culling treats it as the visible ray it geometrically is. On the
//! Cornell box every block is bitwise the same (test below); on the office (default
//! solve, 109 560 links) 4 of 343 surface means moved in their last bit.
//!
//! A primitive is kept as a possible blocker unless one of two tests excludes it:
//!
//! - **boxes**: its bounding box and the shaft's bounding box are disjoint;
//! - **own plane** (planar primitives): both cells lie on the same side of the
//!   primitive's plane, each with all corners on that side or on the plane and at
//!   least one strictly off it. Interior points of such a cell are strictly off the
//!   plane, so no segment between two of them meets it (walls of a room never block
//!   the rays between other walls);
//! - **the cells' planes** (planar primitives): the primitive lies behind or on the
//!   plane of either cell. A ray is shot only between points in front of each
//!   other's planes (the kernel is zero otherwise), so past its end point it is
//!   strictly in front of both planes (a block's side faces never block the rays
//!   between its front face and the floor in front of it).
//!
//! Tests use a tolerance of `1e-9` of the accelerator's unit frame (sample points lie
//! at least ~`10⁻⁴` of a level-10 cell inside it). The two primitives the end points
//! lie on are never blockers (the shadow rays ignore them: [`Accel::occluded`]).
//! Curved or masked cells (Virtual Mesh visibility points may lie outside the cell)
//! are not culled. Candidate lists are inherited: a sub-pair of a near-field split
//! tests only its link's candidates. The oracle's visibility samples
//! ([`crate::transfer::TransferCtx::estimate`]) and the a-posteriori estimate's
//! point-to-piece rays ([`crate::estimate`], between the residual points' cell and
//! each emitter piece) are culled the same way.

use glam::{DVec2, DVec3};
use wavelux_geometry::{Accel, Primitive};

use crate::support::Patch;
use crate::transfer::Region;

/// Tolerance of the side tests in the accelerator's frame (unit size).
const TOL: f64 = 1e-9;

/// Scenes with more primitives than this are not culled at the link level (the test
/// is a linear scan; a BVH query would be needed).
pub(crate) const MAX_SCAN: usize = 4096;

/// A primitive as a possible blocker: box and, for planar primitives, plane.
#[derive(Debug, Clone, Copy)]
struct Blocker {
    lo: DVec3,
    hi: DVec3,
    /// `(n, d)` with `n · x = d` on the primitive, and four points whose convex hull
    /// holds it (planar primitives).
    plane: Option<(DVec3, f64, [DVec3; 4])>,
}

/// Every primitive of an accelerator as a possible blocker (in the accelerator's
/// frame, like its primitives).
#[derive(Debug, Clone, Default)]
pub(crate) struct Blockers {
    items: Vec<Blocker>,
}

impl Blockers {
    /// The blockers of `accel`'s primitives (empty when there are more than
    /// [`MAX_SCAN`]: culling off).
    pub(crate) fn new(accel: &Accel) -> Self {
        let prims = accel.primitives();
        if prims.len() > MAX_SCAN {
            return Self::default();
        }
        let items = prims
            .iter()
            .map(|p| {
                let b = p.aabb();
                let plane = match p {
                    Primitive::Triangle(_)
                    | Primitive::Parallelogram(_)
                    | Primitive::Polygon(_) => {
                        let n = p.normal(DVec2::ZERO);
                        let o = p.eval(DVec2::ZERO);
                        // The support map sends the unit square onto the primitive
                        // (triangle, parallelogram) or its bounding rectangle (polygon).
                        let hull = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]
                            .map(|(u, v)| p.eval(DVec2::new(u, v)));
                        (n.is_finite()
                            && hull.iter().all(|h| h.is_finite())
                            && n.length_squared() > 0.5)
                            .then(|| (n, n.dot(o), hull))
                    }
                    _ => None,
                };
                Blocker {
                    lo: b.min,
                    hi: b.max,
                    plane,
                }
            })
            .collect();
        Self { items }
    }

    /// Whether culling is available.
    pub(crate) fn enabled(&self) -> bool {
        !self.items.is_empty()
    }

    /// The indices among `within` (all primitives when `None`) of the primitives other
    /// than `ignore` that may meet the shaft between the planar cells `a` and `b`
    /// (corners in the accelerator's frame; front normals `na`, `nb`).
    pub(crate) fn candidates(
        &self,
        (a, na): (&[DVec3], DVec3),
        (b, nb): (&[DVec3], DVec3),
        ignore: [u32; 2],
        within: Option<&[u32]>,
    ) -> Vec<u32> {
        let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        for p in a.iter().chain(b) {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
        lo -= DVec3::splat(TOL);
        hi += DVec3::splat(TOL);
        let keep = |i: u32| {
            if i == ignore[0] || i == ignore[1] {
                return false;
            }
            let k = &self.items[i as usize];
            if k.lo.cmpgt(hi).any() || k.hi.cmplt(lo).any() {
                return false;
            }
            match &k.plane {
                Some((n, d, hull)) => {
                    let sa = side(a, *n, *d);
                    let split = sa != 0 && sa == side(b, *n, *d);
                    // Shadow rays run only between points in front of each other's
                    // plane (zero kernel otherwise), so they stay strictly in front of
                    // both cells' planes past their end points.
                    let behind = |pts: &[DVec3], nc: DVec3| {
                        let o = pts[0];
                        hull.iter().all(|h| nc.dot(*h - o) <= 0.0)
                    };
                    !(split || behind(a, na) || behind(b, nb))
                }
                None => true,
            }
        };
        match within {
            Some(w) => w.iter().copied().filter(|&i| keep(i)).collect(),
            None => (0..self.items.len() as u32).filter(|&i| keep(i)).collect(),
        }
    }
}

/// `+1` when every point is on the positive side of `n · x = d` or on it, and one is
/// strictly off it; `−1` likewise on the negative side; `0` otherwise.
fn side(pts: &[DVec3], n: DVec3, d: f64) -> i8 {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for p in pts {
        let s = n.dot(*p) - d;
        lo = lo.min(s);
        hi = hi.max(s);
    }
    if lo >= -TOL && hi > TOL {
        1
    } else if hi <= TOL && lo < -TOL {
        -1
    } else {
        0
    }
}

/// The corners of a node cell in the accelerator's frame `x ↦ (x − c)/s` and its
/// front normal, when the cell can be culled: planar straight-edged cells
/// (parallelogram and triangle supports) without a mask, whose shadow rays start at
/// the quadrature points themselves.
pub(crate) fn cell_corners(
    p: &Patch,
    r: &Region,
    frame: (DVec3, f64),
) -> Option<(Vec<DVec3>, DVec3)> {
    if p.support.mask.is_some() {
        return None;
    }
    let poly = p.support.cell_polygon(r.s0, r.t0, r.h)?;
    let (c, s) = frame;
    Some((
        poly.into_iter().map(|x| (x - c) / s).collect(),
        p.support.normal,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hierarchy::NodeKey;
    use crate::transfer::LinkVisibility;
    use crate::{Prepared, SolverConfig};
    use std::sync::atomic::Ordering;

    /// Culling changes no block, no visibility class and no oracle estimate (with
    /// visibility), bitwise, and saves rays: every
    /// pair of root cells of the Cornell box (walls, blocks, light, the masked ceiling)
    /// and of the floor's level-1 cells (around and under both blocks).
    #[test]
    fn culled_blocks_are_bitwise_the_traced_ones() {
        let scene = wavelux_scene::builtin::cornell_box();
        let cfg = SolverConfig {
            basis: crate::BasisKind::Multiwavelet(2),
            oracle_visibility: true,
            ..SolverConfig::default()
        };
        let prep = Prepared::new(&scene, &cfg).unwrap();
        let on = prep.transfer().unwrap();
        let off = prep.transfer().unwrap().without_shaft_culling();
        let np = on.patches.len();
        let mut cells: Vec<NodeKey> = (0..np).map(NodeKey::root).collect();
        cells.extend((0..4).map(|c| NodeKey::root(0).child(c)));
        let mut counts = [0usize; 3];
        for r in &cells {
            if !on.patches[r.patch as usize].reflects() {
                continue;
            }
            for e in &cells {
                if r.patch == e.patch {
                    continue;
                }
                let (rr, er) = (r.region(), e.region());
                if !on.facing(&rr, &er) {
                    continue;
                }
                let (a, sa) = on.block_seen(&rr, &er);
                let (b, sb) = off.block_seen(&rr, &er);
                assert_eq!(
                    on.estimate(&rr, &er).to_bits(),
                    off.estimate(&rr, &er).to_bits(),
                    "oracle {r:?} {e:?}"
                );
                assert_eq!(sa, sb, "{r:?} {e:?}");
                assert!(
                    a.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits()),
                    "{r:?} {e:?}"
                );
                match sa {
                    LinkVisibility::Visible => counts[0] += 1,
                    LinkVisibility::Partial => counts[1] += 1,
                    LinkVisibility::Blocked => counts[2] += 1,
                    _ => {}
                }
            }
        }
        let (ron, roff) = (
            on.rays.load(Ordering::Relaxed),
            off.rays.load(Ordering::Relaxed),
        );
        assert!(counts[0] > 0 && counts[1] > 0, "classes {counts:?}");
        assert!(ron * 2 < roff, "rays with culling {ron}, without {roff}");
    }

    #[test]
    fn side_needs_one_point_strictly_off_the_plane() {
        let n = DVec3::Y;
        let on = [DVec3::ZERO, DVec3::X];
        let above = [DVec3::ZERO, DVec3::new(0.0, 1.0, 0.0)];
        let below = [DVec3::new(0.0, -1.0, 0.0), DVec3::X];
        let across = [DVec3::new(0.0, -1.0, 0.0), DVec3::Y];
        assert_eq!(side(&on, n, 0.0), 0);
        assert_eq!(side(&above, n, 0.0), 1);
        assert_eq!(side(&below, n, 0.0), -1);
        assert_eq!(side(&across, n, 0.0), 0);
    }
}
