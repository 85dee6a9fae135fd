//! Minimal enclosing parallelograms (VirtualMesh §3.2): the virtual support of a planar
//! primitive with a polygonal or curved outer boundary.
//!
//! The convex hull is built with Andrew's monotone chain (O(n log n)). A minimal
//! enclosing parallelogram is the intersection of two strips, each flush with a hull
//! edge (on each arc between consecutive edge normals the area
//! `w(α1) w(α2) / |sin(α2 − α1)|` is monotone in either angle, Schwarz et al. 1995), so
//! the strip widths of all hull edges are found by rotating calipers in O(h) and the
//! best pair of edges by exhaustive search in O(h²) — simpler than Schwarz et al.'s
//! linear-time search and exact; h is the hull size. Boundaries with circular arcs are
//! replaced by circumscribed polygons (vertices outside the arc, so the result always
//! encloses the arcs) whose overshoot is at most the caller's tolerance.

use crate::error::{ParamError, finite, positive};
use crate::frame::cross2;
use crate::parallelogram::Parallelogram2;
use glam::DVec2;
use std::f64::consts::TAU;

/// Convex hull in counter-clockwise order, without repeated or collinear vertices.
/// Non-finite points are ignored.
pub fn convex_hull(points: &[DVec2]) -> Vec<DVec2> {
    let mut p: Vec<DVec2> = points.iter().copied().filter(|q| q.is_finite()).collect();
    p.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    p.dedup();
    if p.len() < 3 {
        return p;
    }
    let mut hull: Vec<DVec2> = Vec::with_capacity(2 * p.len());
    for pass in 0..2 {
        let start = hull.len();
        let iter: Box<dyn Iterator<Item = &DVec2>> = if pass == 0 {
            Box::new(p.iter())
        } else {
            Box::new(p.iter().rev())
        };
        for &q in iter {
            while hull.len() >= start + 2
                && cross2(
                    hull[hull.len() - 1] - hull[hull.len() - 2],
                    q - hull[hull.len() - 2],
                ) <= 0.0
            {
                hull.pop();
            }
            hull.push(q);
        }
        hull.pop();
    }
    hull
}

/// A piece of a planar boundary: a segment or a circular arc.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum BoundarySegment {
    /// Straight segment.
    Line {
        /// Start point.
        from: DVec2,
        /// End point.
        to: DVec2,
    },
    /// Circular arc `centre + radius (cos α, sin α)`, α from `start` through
    /// `start + sweep` (radians; negative sweep = clockwise).
    Arc {
        /// Centre of the circle.
        centre: DVec2,
        /// Radius (> 0).
        radius: f64,
        /// Start angle (radians).
        start: f64,
        /// Signed sweep (radians, |sweep| ≤ 2π).
        sweep: f64,
    },
}

/// Minimal-area parallelogram enclosing `points` (VirtualMesh §3.2), with
/// `e1 × e2 > 0`.
///
/// # Errors
/// Fewer than 3 finite points ([`ParamError::TooFewPoints`]) or all points collinear
/// ([`ParamError::Degenerate`]).
pub fn min_enclosing_parallelogram(points: &[DVec2]) -> Result<Parallelogram2, ParamError> {
    let finite_count = points.iter().filter(|q| q.is_finite()).count();
    if finite_count < 3 {
        return Err(ParamError::TooFewPoints {
            needed: 3,
            got: finite_count,
        });
    }
    let hull = convex_hull(points);
    if hull.len() < 3 {
        return Err(ParamError::Degenerate("points are collinear"));
    }
    let n = hull.len();
    // Unit edge directions and strip widths (rotating calipers: the farthest vertex
    // from edge i moves monotonically forward as i advances).
    let dirs: Vec<DVec2> = (0..n)
        .map(|i| (hull[(i + 1) % n] - hull[i]).normalize())
        .collect();
    let mut widths = vec![0.0; n];
    let mut j = 1usize;
    for i in 0..n {
        let h = |k: usize| cross2(dirs[i], hull[k % n] - hull[i]);
        if j < i + 1 {
            j = i + 1;
        }
        while h(j + 1) >= h(j) && j < i + n {
            j += 1;
        }
        widths[i] = h(j);
    }
    let mut best: Option<(f64, usize, usize)> = None;
    for i in 0..n {
        for k in (i + 1)..n {
            let s = cross2(dirs[i], dirs[k]).abs();
            if s <= 1e-15 {
                continue;
            }
            let area = widths[i] * widths[k] / s;
            if best.is_none_or(|b| area < b.0) {
                best = Some((area, i, k));
            }
        }
    }
    let (_, i, k) = best.ok_or(ParamError::Degenerate("hull has no two independent edges"))?;
    Ok(strips_to_parallelogram(&hull, &dirs, &widths, i, k))
}

/// The parallelogram cut out by the strips flush with hull edges `i` and `k`.
fn strips_to_parallelogram(
    hull: &[DVec2],
    dirs: &[DVec2],
    widths: &[f64],
    i: usize,
    k: usize,
) -> Parallelogram2 {
    // Inward (left) normals of the CCW hull edges.
    let ni = DVec2::new(-dirs[i].y, dirs[i].x);
    let nk = DVec2::new(-dirs[k].y, dirs[k].x);
    let (ci, ck) = (ni.dot(hull[i]), nk.dot(hull[k]));
    let det = ni.x * nk.y - ni.y * nk.x;
    let origin = DVec2::new((ci * nk.y - ck * ni.y) / det, (ni.x * ck - nk.x * ci) / det);
    let e1 = dirs[i] * (widths[k] / nk.dot(dirs[i]));
    let e2 = dirs[k] * (widths[i] / ni.dot(dirs[k]));
    if cross2(e1, e2) >= 0.0 {
        Parallelogram2 { origin, e1, e2 }
    } else {
        Parallelogram2 {
            origin,
            e1: e2,
            e2: e1,
        }
    }
}

/// Minimal enclosing parallelogram of a boundary made of segments and circular arcs.
/// Arcs are replaced by circumscribed polygons that stay within `arc_tolerance` (world
/// units) of the arc, so the result encloses the exact boundary and exceeds the exact
/// minimum by O(`arc_tolerance` × perimeter).
///
/// # Errors
/// Non-finite or non-positive tolerance, invalid arcs, or a degenerate boundary.
pub fn min_enclosing_parallelogram_of_boundary(
    segments: &[BoundarySegment],
    arc_tolerance: f64,
) -> Result<Parallelogram2, ParamError> {
    let tol = positive("arc tolerance", arc_tolerance)?;
    let mut pts = Vec::new();
    for s in segments {
        match *s {
            BoundarySegment::Line { from, to } => {
                pts.push(from);
                pts.push(to);
            }
            BoundarySegment::Arc {
                centre,
                radius,
                start,
                sweep,
            } => {
                let r = positive("arc radius", radius)?;
                finite("arc start", start)?;
                finite("arc sweep", sweep)?;
                if sweep.abs() > TAU * (1.0 + 1e-12) {
                    return Err(ParamError::InvalidRange {
                        what: "arc sweep",
                        lo: start,
                        hi: start + sweep,
                        why: "an arc sweeps at most 2π",
                    });
                }
                // Circumscribed polygon with pieces of angle δ: overshoot r(1/cos(δ/2) − 1).
                let max_delta = 2.0 * (1.0 / (1.0 + tol / r)).acos();
                let m = ((sweep.abs() / max_delta).ceil() as usize).max(1);
                let delta = sweep / m as f64;
                let at = |a: f64, rad: f64| centre + DVec2::new(a.cos(), a.sin()) * rad;
                pts.push(at(start, r));
                pts.push(at(start + sweep, r));
                let rr = r / (0.5 * delta).cos();
                for kk in 0..m {
                    pts.push(at(start + (kk as f64 + 0.5) * delta, rr));
                }
            }
        }
    }
    min_enclosing_parallelogram(&pts)
}
