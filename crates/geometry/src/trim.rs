//! Trim loops made of segments and circular arcs, and the slab (trapezoidal)
//! decomposition that answers point-in-region queries in logarithmic time.
//!
//! VirtualMesh §4.2 and Fig. 6: the parameter plane is cut into horizontal slabs at every
//! vertex ordinate and at the ordinates where an arc turns (its top and bottom points),
//! so that inside one slab every boundary piece is y-monotone and no two pieces cross.
//! The pieces of a slab are sorted left to right; a query finds its slab by binary search
//! on `y` and then the number of pieces to its left by a second binary search, with
//! prefix sums of the pieces' up/down orientation giving the winding number.
//! Inside means non-zero winding (loops must not cross each other or themselves).

use glam::DVec2;
use std::f64::consts::{PI, TAU};

use crate::GeometryError;

/// One boundary edge in the plane.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Edge2 {
    /// Straight segment from `a` to `b`.
    Segment {
        /// Start point.
        a: DVec2,
        /// End point.
        b: DVec2,
    },
    /// Circular arc `center + radius (cos θ, sin θ)`, `θ` from `start` to `start + sweep`
    /// (counter-clockwise for positive `sweep`, `0 < |sweep| <= 2π`).
    Arc {
        /// Circle centre.
        center: DVec2,
        /// Circle radius (> 0).
        radius: f64,
        /// Start angle (radians).
        start: f64,
        /// Signed swept angle (radians).
        sweep: f64,
    },
}

impl Edge2 {
    /// Validated segment.
    ///
    /// # Errors
    /// Non-finite endpoints.
    pub fn segment(a: DVec2, b: DVec2) -> Result<Edge2, GeometryError> {
        if !a.is_finite() || !b.is_finite() {
            return Err(GeometryError::NonFinite("segment"));
        }
        Ok(Edge2::Segment { a, b })
    }

    /// Validated arc.
    ///
    /// # Errors
    /// Non-finite input, non-positive radius, zero sweep or `|sweep| > 2π`.
    pub fn arc(center: DVec2, radius: f64, start: f64, sweep: f64) -> Result<Edge2, GeometryError> {
        if !center.is_finite() || !radius.is_finite() || !start.is_finite() || !sweep.is_finite() {
            return Err(GeometryError::NonFinite("arc"));
        }
        if radius <= 0.0 || sweep == 0.0 || sweep.abs() > TAU * (1.0 + 1e-12) {
            return Err(GeometryError::Degenerate(
                "arc radius must be > 0 and 0 < |sweep| <= 2π",
            ));
        }
        Ok(Edge2::Arc {
            center,
            radius,
            start,
            sweep,
        })
    }

    /// Point at parameter `s ∈ [0, 1]` along the edge.
    pub fn point(&self, s: f64) -> DVec2 {
        match *self {
            Edge2::Segment { a, b } => a + s * (b - a),
            Edge2::Arc {
                center,
                radius,
                start,
                sweep,
            } => {
                let th = start + s * sweep;
                center + radius * DVec2::new(th.cos(), th.sin())
            }
        }
    }

    /// Start point.
    pub fn start(&self) -> DVec2 {
        self.point(0.0)
    }

    /// End point.
    pub fn end(&self) -> DVec2 {
        self.point(1.0)
    }

    /// The same edge traversed backwards.
    pub fn reversed(&self) -> Edge2 {
        match *self {
            Edge2::Segment { a, b } => Edge2::Segment { a: b, b: a },
            Edge2::Arc {
                center,
                radius,
                start,
                sweep,
            } => Edge2::Arc {
                center,
                radius,
                start: start + sweep,
                sweep: -sweep,
            },
        }
    }

    /// Contribution `½∮(x dy − y dx)` of this edge to its loop's signed area.
    pub fn area_term(&self) -> f64 {
        match *self {
            Edge2::Segment { a, b } => 0.5 * a.perp_dot(b),
            Edge2::Arc {
                center,
                radius,
                start,
                sweep,
            } => {
                // x = cx + r cos θ, y = cy + r sin θ; integrand x dy − y dx = (r² + r(cx cos θ + cy sin θ)) dθ.
                let (s0, c0) = start.sin_cos();
                let (s1, c1) = (start + sweep).sin_cos();
                0.5 * (radius * radius * sweep
                    + radius * (center.x * (s1 - s0) - center.y * (c1 - c0)))
            }
        }
    }

    /// Points whose bounding box is the edge's bounding box (endpoints plus arc extremes).
    pub fn bbox_points(&self) -> Vec<DVec2> {
        let mut v = vec![self.start(), self.end()];
        if let Edge2::Arc { center, radius, .. } = *self {
            for k in 0..4 {
                let th = k as f64 * 0.5 * PI;
                if self.param_of_angle(th).is_some() {
                    v.push(center + radius * DVec2::new(th.cos(), th.sin()));
                }
            }
        }
        v
    }

    /// For an arc, the parameter `s ∈ (0, 1)` at which the arc passes angle `th` (mod 2π), if it does.
    fn param_of_angle(&self, th: f64) -> Option<f64> {
        match *self {
            Edge2::Segment { .. } => None,
            Edge2::Arc { start, sweep, .. } => {
                // Smallest k with th + 2πk past start in the sweep direction.
                let d = if sweep > 0.0 {
                    (th - start).rem_euclid(TAU)
                } else {
                    (start - th).rem_euclid(TAU)
                };
                let s = d / sweep.abs();
                (s > 0.0 && s < 1.0).then_some(s)
            }
        }
    }

    /// Signed angle swept by `x − p` as `x` runs along the edge, exactly: the chord's
    /// subtended angle plus `±2π` when `p` lies in the circular segment between an arc
    /// and its chord (brute-force winding reference; not used by the slab queries).
    pub fn subtended_angle(&self, p: DVec2) -> f64 {
        let a = self.start() - p;
        let b = self.end() - p;
        let chord = a.perp_dot(b).atan2(a.dot(b));
        match *self {
            Edge2::Segment { .. } => chord,
            Edge2::Arc {
                center,
                radius,
                start,
                sweep,
            } => {
                if (p - center).length() >= radius {
                    return chord;
                }
                let (s0, s1) = (self.start(), self.end());
                let mid = center + radius * DVec2::from_angle(start + 0.5 * sweep);
                let in_segment = if (s1 - s0).length() <= 1e-15 * radius {
                    true
                } else {
                    let side = |q: DVec2| (s1 - s0).perp_dot(q - s0);
                    side(p) * side(mid) > 0.0
                };
                if in_segment {
                    chord + TAU * sweep.signum()
                } else {
                    chord
                }
            }
        }
    }
}

/// A closed loop of edges (each edge's end is the next edge's start, to 1e-9 of the loop size).
#[derive(Debug, Clone, PartialEq)]
pub struct TrimLoop {
    /// Edges in order.
    pub edges: Vec<Edge2>,
}

impl TrimLoop {
    /// Validated loop.
    ///
    /// # Errors
    /// Empty, non-closed (gap > 1e-9 × loop size), or non-finite edges.
    pub fn new(edges: Vec<Edge2>) -> Result<TrimLoop, GeometryError> {
        if edges.is_empty() {
            return Err(GeometryError::Degenerate("empty trim loop"));
        }
        let mut lo = DVec2::splat(f64::INFINITY);
        let mut hi = DVec2::splat(f64::NEG_INFINITY);
        for e in &edges {
            for q in e.bbox_points() {
                if !q.is_finite() {
                    return Err(GeometryError::NonFinite("trim edge"));
                }
                lo = lo.min(q);
                hi = hi.max(q);
            }
        }
        let size = (hi - lo).length().max(f64::MIN_POSITIVE);
        for i in 0..edges.len() {
            let j = (i + 1) % edges.len();
            if (edges[i].end() - edges[j].start()).length() > 1e-9 * size {
                return Err(GeometryError::Degenerate("trim loop is not closed"));
            }
        }
        Ok(TrimLoop { edges })
    }

    /// Closed polygon through `pts` (last point connects to the first).
    ///
    /// # Errors
    /// Fewer than 3 points or non-finite points.
    pub fn polygon(pts: &[DVec2]) -> Result<TrimLoop, GeometryError> {
        if pts.len() < 3 {
            return Err(GeometryError::Degenerate(
                "polygon loop needs at least 3 points",
            ));
        }
        let edges = (0..pts.len())
            .map(|i| Edge2::segment(pts[i], pts[(i + 1) % pts.len()]))
            .collect::<Result<Vec<_>, _>>()?;
        TrimLoop::new(edges)
    }

    /// Full circle, counter-clockwise.
    ///
    /// # Errors
    /// Invalid centre or radius.
    pub fn circle(center: DVec2, radius: f64) -> Result<TrimLoop, GeometryError> {
        TrimLoop::new(vec![Edge2::arc(center, radius, 0.0, TAU)?])
    }

    /// Axis-aligned rectangle `[lo, hi]`, counter-clockwise.
    ///
    /// # Errors
    /// Non-finite or empty rectangle.
    pub fn rect(lo: DVec2, hi: DVec2) -> Result<TrimLoop, GeometryError> {
        if !(hi.x > lo.x && hi.y > lo.y) {
            return Err(GeometryError::Degenerate("empty rectangle"));
        }
        TrimLoop::polygon(&[lo, DVec2::new(hi.x, lo.y), hi, DVec2::new(lo.x, hi.y)])
    }

    /// Signed area (positive for counter-clockwise loops).
    pub fn signed_area(&self) -> f64 {
        self.edges.iter().map(Edge2::area_term).sum()
    }

    /// The loop traversed backwards.
    pub fn reversed(&self) -> TrimLoop {
        TrimLoop {
            edges: self.edges.iter().rev().map(Edge2::reversed).collect(),
        }
    }

    /// Brute-force winding number of the loop around `p` (sum of subtended angles / 2π).
    pub fn winding_brute(&self, p: DVec2) -> i32 {
        (self.edges.iter().map(|e| e.subtended_angle(p)).sum::<f64>() / TAU).round() as i32
    }
}

/// A y-monotone boundary piece spanning one whole slab.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Piece {
    /// Line through `(x0, y0)` with slope `dxdy`.
    Line { x0: f64, y0: f64, dxdy: f64 },
    /// Half circle: `x = cx + side · sqrt(r² − (y − cy)²)`.
    Arc { cx: f64, cy: f64, r: f64, side: f64 },
}

impl Piece {
    fn x_at(&self, y: f64) -> f64 {
        match *self {
            Piece::Line { x0, y0, dxdy } => x0 + (y - y0) * dxdy,
            Piece::Arc { cx, cy, r, side } => {
                let d = y - cy;
                cx + side * (r * r - d * d).max(0.0).sqrt()
            }
        }
    }
}

/// One slab `[y0, y1)` with its pieces sorted by `x` and prefix sums of their orientation.
#[derive(Debug, Clone, PartialEq)]
struct Slab {
    pieces: Vec<Piece>,
    /// `prefix[k]` = winding contribution of pieces `0..k` (each piece is +1 going up, −1 down).
    prefix: Vec<i32>,
}

/// A region of the plane bounded by trim loops, with its slab decomposition.
#[derive(Debug, Clone, PartialEq)]
pub struct TrimRegion {
    /// Boundary loops (outer loops counter-clockwise, holes clockwise).
    pub loops: Vec<TrimLoop>,
    ys: Vec<f64>,
    slabs: Vec<Slab>,
    lo: DVec2,
    hi: DVec2,
}

impl TrimRegion {
    /// Builds the region and its slab decomposition (`O(n log n)` events, `O(n)` pieces per slab).
    ///
    /// # Errors
    /// No loops.
    pub fn new(loops: Vec<TrimLoop>) -> Result<TrimRegion, GeometryError> {
        if loops.is_empty() {
            return Err(GeometryError::Degenerate("trim region without loops"));
        }
        let mut lo = DVec2::splat(f64::INFINITY);
        let mut hi = DVec2::splat(f64::NEG_INFINITY);
        // Monotone sub-edges: (y_start, y_end, piece)
        let mut monos: Vec<(f64, f64, Piece)> = Vec::new();
        let mut ys: Vec<f64> = Vec::new();
        for l in &loops {
            for e in &l.edges {
                for q in e.bbox_points() {
                    lo = lo.min(q);
                    hi = hi.max(q);
                }
                match *e {
                    Edge2::Segment { a, b } => {
                        ys.push(a.y);
                        ys.push(b.y);
                        if a.y != b.y {
                            monos.push((
                                a.y,
                                b.y,
                                Piece::Line {
                                    x0: a.x,
                                    y0: a.y,
                                    dxdy: (b.x - a.x) / (b.y - a.y),
                                },
                            ));
                        }
                    }
                    Edge2::Arc {
                        center,
                        radius,
                        start,
                        sweep,
                    } => {
                        // Split at angles π/2 and 3π/2 (top and bottom of the circle).
                        let mut cuts = vec![0.0, 1.0];
                        for th in [0.5 * PI, 1.5 * PI] {
                            if let Some(s) = e.param_of_angle(th) {
                                cuts.push(s);
                            }
                        }
                        cuts.sort_by(f64::total_cmp);
                        for w in cuts.windows(2) {
                            let (s0, s1) = (w[0], w[1]);
                            if s1 - s0 <= 0.0 {
                                continue;
                            }
                            let p0 = e.point(s0);
                            let p1 = e.point(s1);
                            ys.push(p0.y);
                            ys.push(p1.y);
                            let mid = start + 0.5 * (s0 + s1) * sweep;
                            let side = if mid.cos() >= 0.0 { 1.0 } else { -1.0 };
                            // Snap the exact extreme ordinates so slabs line up.
                            let y0 = snap_extreme(p0.y, center.y, radius);
                            let y1 = snap_extreme(p1.y, center.y, radius);
                            if y0 != y1 {
                                monos.push((
                                    y0,
                                    y1,
                                    Piece::Arc {
                                        cx: center.x,
                                        cy: center.y,
                                        r: radius,
                                        side,
                                    },
                                ));
                            }
                        }
                    }
                }
            }
        }
        for (_, _, p) in &monos {
            if let Piece::Arc { cy, r, .. } = p {
                ys.push(cy + r);
                ys.push(cy - r);
            }
        }
        ys.sort_by(f64::total_cmp);
        ys.dedup();
        let nslab = ys.len().saturating_sub(1);
        let mut slab_pieces: Vec<Vec<(f64, Piece, i32)>> = vec![Vec::new(); nslab];
        for (ya, yb, piece) in monos {
            let (y0, y1, dir) = if ya < yb { (ya, yb, 1) } else { (yb, ya, -1) };
            let i0 = ys.partition_point(|&y| y < y0);
            let i1 = ys.partition_point(|&y| y < y1);
            for k in i0..i1.min(nslab) {
                let ym = 0.5 * (ys[k] + ys[k + 1]);
                slab_pieces[k].push((piece.x_at(ym), piece, dir));
            }
        }
        let slabs = slab_pieces
            .into_iter()
            .map(|mut v| {
                v.sort_by(|a, b| a.0.total_cmp(&b.0));
                let mut prefix = Vec::with_capacity(v.len() + 1);
                prefix.push(0);
                let mut acc = 0;
                for (_, _, d) in &v {
                    acc += d;
                    prefix.push(acc);
                }
                Slab {
                    pieces: v.into_iter().map(|x| x.1).collect(),
                    prefix,
                }
            })
            .collect();
        Ok(TrimRegion {
            loops,
            ys,
            slabs,
            lo,
            hi,
        })
    }

    /// The whole unit square `[0,1]²`.
    ///
    /// # Errors
    /// None in practice (the square is valid); kept fallible like every constructor.
    pub fn unit_square() -> Result<TrimRegion, GeometryError> {
        TrimRegion::new(vec![TrimLoop::rect(DVec2::ZERO, DVec2::ONE)?])
    }

    /// Winding number of the boundary around `p` in `O(log n)`: slab by binary search,
    /// then pieces to the left of `p` by binary search. Points exactly on the boundary
    /// may go either way.
    pub fn winding(&self, p: DVec2) -> i32 {
        if !(p.y >= self.lo.y && p.y < self.hi.y && p.x >= self.lo.x && p.x <= self.hi.x) {
            return 0;
        }
        let k = self.ys.partition_point(|&y| y <= p.y);
        if k == 0 || k > self.slabs.len() {
            return 0;
        }
        let slab = &self.slabs[k - 1];
        let n_left = slab.pieces.partition_point(|pc| pc.x_at(p.y) < p.x);
        // Pieces to the right of p: winding = −(sum of their orientations) for a ray to +x
        // crossing upward pieces... use: winding = total − prefix[n_left] measured to the right,
        // with upward crossings on the right counting +1 for counter-clockwise loops.
        slab.prefix[slab.pieces.len()] - slab.prefix[n_left]
    }

    /// True if `p` is inside (non-zero winding).
    pub fn contains(&self, p: DVec2) -> bool {
        self.winding(p) != 0
    }

    /// [`TrimRegion::contains`] dilated by `tol` along the axes: also true if one of the
    /// four points `p ± tol·e_x`, `p ± tol·e_y` is inside. Used so that abutting regions
    /// leave no crack for a ray through their common boundary.
    pub fn contains_tol(&self, p: DVec2, tol: f64) -> bool {
        self.contains(p)
            || (tol > 0.0
                && [DVec2::X, DVec2::NEG_X, DVec2::Y, DVec2::NEG_Y]
                    .iter()
                    .any(|d| self.contains(p + tol * *d)))
    }

    /// Brute-force winding number (sum over loops of subtended angles), `O(n)`; for tests.
    pub fn winding_brute(&self, p: DVec2) -> i32 {
        self.loops.iter().map(|l| l.winding_brute(p)).sum()
    }

    /// `∫_region f(u, v) du dv` by an `n × n` Gauss–Legendre rule on every inside cell of
    /// the slab decomposition (a curvilinear trapezoid between two boundary pieces).
    /// Where an arc reaches its top or bottom at a slab end, `x(y)` has a square-root
    /// singularity; the `y` rule is then mapped by `y = y_end ± h s²`, which makes the
    /// cell smooth again. Exact for polynomials of degree < 2n−1 on polygonal regions.
    /// `n` is clamped to `1..=64`.
    pub fn integrate(&self, n: usize, mut f: impl FnMut(DVec2) -> f64) -> f64 {
        let n = n.clamp(1, 64);
        let Ok(gl) = wavelux_quadrature::GaussLegendre::new(n) else {
            return f64::NAN;
        };
        let (xs, ws) = gl.unit();
        let mut total = 0.0;
        for (k, slab) in self.slabs.iter().enumerate() {
            let (y0, y1) = (self.ys[k], self.ys[k + 1]);
            let all = slab.prefix[slab.pieces.len()];
            for m in 0..slab.pieces.len().saturating_sub(1) {
                if all - slab.prefix[m + 1] == 0 {
                    continue;
                }
                let (l, r) = (slab.pieces[m], slab.pieces[m + 1]);
                let at_extreme = |y: f64| {
                    [l, r].iter().any(|p| match *p {
                        Piece::Arc { cy, r: rad, .. } => {
                            let tol = 1e-12 * (rad + cy.abs());
                            (y - (cy + rad)).abs() <= tol || (y - (cy - rad)).abs() <= tol
                        }
                        Piece::Line { .. } => false,
                    })
                };
                let (s0, s1) = (at_extreme(y0), at_extreme(y1));
                let mut cell = |ya: f64, yb: f64, sing_lo: bool, sing_hi: bool| {
                    let h = yb - ya;
                    let mut acc = 0.0;
                    for i in 0..n {
                        let s = xs[i];
                        let (y, jac) = if sing_lo {
                            (ya + h * s * s, 2.0 * h * s)
                        } else if sing_hi {
                            (yb - h * (1.0 - s) * (1.0 - s), 2.0 * h * (1.0 - s))
                        } else {
                            (ya + h * s, h)
                        };
                        let (xl, xr) = (l.x_at(y), r.x_at(y));
                        let mut inner = 0.0;
                        for j in 0..n {
                            inner += ws[j] * f(DVec2::new(xl + (xr - xl) * xs[j], y));
                        }
                        acc += ws[i] * jac * (xr - xl) * inner;
                    }
                    acc
                };
                let w = f64::from(all - slab.prefix[m + 1]).signum();
                total += w * if s0 && s1 {
                    let ym = 0.5 * (y0 + y1);
                    cell(y0, ym, true, false) + cell(ym, y1, false, true)
                } else {
                    cell(y0, y1, s0, s1)
                };
            }
        }
        total
    }

    /// Area (sum of the loops' signed areas).
    pub fn area(&self) -> f64 {
        self.loops.iter().map(TrimLoop::signed_area).sum()
    }

    /// Bounding rectangle `(lo, hi)`.
    pub fn bounds(&self) -> (DVec2, DVec2) {
        (self.lo, self.hi)
    }

    /// Smallest and largest winding number over the region's cells (the gaps between
    /// consecutive boundary pieces of every slab, and the outside, winding 0), ignoring
    /// cells thinner than `tol` (slab height, or gap width at mid-height), where
    /// coincident boundary pieces make the order, and so the winding, arbitrary.
    ///
    /// A region is a proper point set bounded by its loops (outer loops
    /// counter-clockwise, holes clockwise, inside their outer loop and disjoint, no loop
    /// crossing itself or another) exactly when this is `(0, 1)`: a hole outside its
    /// outer loop or two overlapping holes give `−1`, a loop winding twice or two
    /// overlapping outer loops `2`.
    pub fn winding_bounds(&self, tol: f64) -> (i32, i32) {
        let (mut lo, mut hi) = (0, 0);
        for (k, slab) in self.slabs.iter().enumerate() {
            let (y0, y1) = (self.ys[k], self.ys[k + 1]);
            if y1 - y0 <= tol || y1.is_nan() || y0.is_nan() {
                continue;
            }
            let ym = 0.5 * (y0 + y1);
            let all = slab.prefix[slab.pieces.len()];
            for m in 0..slab.pieces.len().saturating_sub(1) {
                let width = slab.pieces[m + 1].x_at(ym) - slab.pieces[m].x_at(ym);
                if width <= tol || width.is_nan() {
                    continue;
                }
                let w = all - slab.prefix[m + 1];
                lo = lo.min(w);
                hi = hi.max(w);
            }
        }
        (lo, hi)
    }

    /// Number of slabs in the decomposition.
    pub fn slab_count(&self) -> usize {
        self.slabs.len()
    }
}

fn snap_extreme(y: f64, cy: f64, r: f64) -> f64 {
    let tol = 1e-12 * r.max(cy.abs());
    if (y - (cy + r)).abs() <= tol {
        cy + r
    } else if (y - (cy - r)).abs() <= tol {
        cy - r
    } else {
        y
    }
}
