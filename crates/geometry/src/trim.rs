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
    /// Builds the region and its slab decomposition (`O(n log n)` events, `O(n)` pieces per slab)
    /// and checks that the loops bound a proper region: every cell's winding number is 0
    /// or 1 and no two boundary pieces cross (outer loops counter-clockwise, holes
    /// clockwise inside an outer loop and apart, no loop crossing itself or another).
    /// Loops may touch: cells and crossings thinner than `1e-12 ×` the loops' bounding
    /// box diagonal are ignored.
    ///
    /// # Errors
    /// No loops ([`GeometryError::Degenerate`]); loops that do not bound a proper region
    /// ([`GeometryError::Region`], naming the loop or pair at fault).
    pub fn new(loops: Vec<TrimLoop>) -> Result<TrimRegion, GeometryError> {
        if loops.is_empty() {
            return Err(GeometryError::Degenerate("trim region without loops"));
        }
        let region = TrimRegion::build(loops);
        let tol = region.tolerance();
        if region.is_proper(tol) {
            Ok(region)
        } else {
            Err(GeometryError::Region(region_fault(&region.loops, tol)))
        }
    }

    /// The slab decomposition of `loops` (non-empty), unchecked.
    fn build(loops: Vec<TrimLoop>) -> TrimRegion {
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
        TrimRegion {
            loops,
            ys,
            slabs,
            lo,
            hi,
        }
    }

    /// Thinness below which cells and crossings are ignored: `1e-12 ×` the bounding box
    /// diagonal.
    fn tolerance(&self) -> f64 {
        let d = (self.hi - self.lo).length();
        if d.is_finite() { 1e-12 * d } else { 0.0 }
    }

    /// True if every cell's winding number is 0 or 1 and no two adjacent pieces of a
    /// slab cross inside it (the slab cuts lie at vertices and arc extremes only, so a
    /// crossing between two cuts is invisible to [`TrimRegion::winding_bounds`]; any
    /// transversal crossing of two boundary curves makes three winding numbers meet).
    fn is_proper(&self, tol: f64) -> bool {
        let (lo, hi) = self.winding_bounds(tol);
        lo >= 0 && hi <= 1 && !self.has_crossing(tol)
    }

    /// True if two pieces adjacent at mid-height of some slab (taller than `tol`) swap
    /// order inside it by more than `tol`. Checking adjacent pairs suffices: the first
    /// crossing above or below mid-height is between neighbours.
    fn has_crossing(&self, tol: f64) -> bool {
        self.slabs.iter().enumerate().any(|(k, slab)| {
            let (y0, y1) = (self.ys[k], self.ys[k + 1]);
            y1 - y0 > tol
                && slab
                    .pieces
                    .windows(2)
                    .any(|w| pieces_cross(&w[0], &w[1], y0, y1, tol))
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
    /// Cells are sampled at mid-height of each slab, and the slabs are cut at vertices
    /// and arc extremes only, so two pieces crossing between two cuts can hide a cell
    /// of winding `−1` or `2`; [`TrimRegion::new`] also checks for such crossings, and
    /// every region it returns has bounds within `(0, 1)`. A hole outside its outer loop
    /// or two overlapping holes give `−1`, a loop winding twice or two overlapping
    /// outer loops `2`.
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

/// How trim loops fail to bound a proper region ([`TrimRegion::new`]). Indices are
/// positions in the loops given to [`TrimRegion::new`]; a hole is a clockwise loop
/// (negative signed area), an outer loop a counter-clockwise one.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RegionFault {
    /// The loop crosses or overlaps itself (alone, it winds other than once around some
    /// point).
    SelfCrossing {
        /// The loop.
        index: usize,
    },
    /// The hole lies outside every outer loop, or crosses one.
    HoleOutside {
        /// The hole.
        index: usize,
    },
    /// Two loops of the same kind overlap or cross (two holes, or two outer loops).
    Overlap {
        /// The first loop.
        a: usize,
        /// The second loop.
        b: usize,
    },
    /// The loops overlap in a way no single loop or pair explains (or there are more
    /// than [`MAX_DIAGNOSED_LOOPS`] loops, beyond which pairs are not searched).
    Unresolved,
}

/// Most loops whose pairs [`TrimRegion::new`] searches to name an improper region's fault.
pub const MAX_DIAGNOSED_LOOPS: usize = 64;

impl std::fmt::Display for RegionFault {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match *self {
            RegionFault::SelfCrossing { index } => {
                write!(f, "trim loop {index} crosses or overlaps itself")
            }
            RegionFault::HoleOutside { index } => write!(
                f,
                "hole (trim loop {index}) is not inside an outer loop (it lies outside or crosses it)"
            ),
            RegionFault::Overlap { a, b } => write!(f, "trim loops {a} and {b} overlap"),
            RegionFault::Unresolved => write!(f, "trim loops overlap"),
        }
    }
}

/// Names the fault of loops that do not bound a proper region: a loop that is not
/// proper alone, then a pair whose boundaries cross, then a loop lying in the wrong cell
/// of the others (a hole needs winding 1 around it, an outer loop 0).
fn region_fault(loops: &[TrimLoop], tol: f64) -> RegionFault {
    let ccw = |l: &TrimLoop| {
        if l.signed_area() < 0.0 {
            l.reversed()
        } else {
            l.clone()
        }
    };
    let is_hole = |i: usize| loops[i].signed_area() < 0.0;
    for (index, l) in loops.iter().enumerate() {
        if !TrimRegion::build(vec![ccw(l)]).is_proper(tol) {
            return RegionFault::SelfCrossing { index };
        }
    }
    if loops.len() > MAX_DIAGNOSED_LOOPS {
        return RegionFault::Unresolved;
    }
    let blame = |a: usize, b: usize| match (is_hole(a), is_hole(b)) {
        (true, false) => RegionFault::HoleOutside { index: a },
        (false, true) => RegionFault::HoleOutside { index: b },
        _ => RegionFault::Overlap { a, b },
    };
    for a in 0..loops.len() {
        for b in a + 1..loops.len() {
            if partly_overlap(ccw(&loops[a]), ccw(&loops[b]), tol) {
                return blame(a, b);
            }
        }
    }
    for i in 0..loops.len() {
        let rest: Vec<TrimLoop> = (0..loops.len())
            .filter(|&j| j != i)
            .map(|j| loops[j].clone())
            .collect();
        let rest = (!rest.is_empty()).then(|| TrimRegion::build(rest));
        let around = loop_sample_winding(&loops[i], |p| rest.as_ref().map_or(0, |r| r.winding(p)));
        if around == i32::from(is_hole(i)) {
            continue;
        }
        // The loop lies in the wrong cell: inside a loop of its own kind, or (a hole)
        // outside every outer loop.
        let inside = (0..loops.len()).find(|&j| {
            j != i
                && is_hole(j) == is_hole(i)
                && loop_sample_winding(&loops[i], |p| loops[j].winding_brute(p)) != 0
        });
        return match inside {
            Some(j) => RegionFault::Overlap {
                a: i.min(j),
                b: i.max(j),
            },
            None if is_hole(i) => RegionFault::HoleOutside { index: i },
            None => RegionFault::Unresolved,
        };
    }
    RegionFault::Unresolved
}

/// True if the interiors of two counter-clockwise loops, each proper alone, overlap
/// without one containing the other: their boundaries cross inside a slab, or the two
/// together wind twice somewhere while `a` minus `b` and `b` minus `a` are both
/// non-empty (taken with `b` reversed, windings `1` and `−1` both occur).
fn partly_overlap(a: TrimLoop, b: TrimLoop, tol: f64) -> bool {
    let both = TrimRegion::build(vec![a.clone(), b.clone()]);
    if both.has_crossing(tol) {
        return true;
    }
    if both.winding_bounds(tol).1 < 2 {
        return false;
    }
    let (lo, hi) = TrimRegion::build(vec![a, b.reversed()]).winding_bounds(tol);
    lo < 0 && hi > 0
}

/// The most frequent value of `winding` at one point inside each edge of `l` (so that a
/// loop touching another along some edges is still placed by its other edges).
fn loop_sample_winding(l: &TrimLoop, winding: impl Fn(DVec2) -> i32) -> i32 {
    let mut values: Vec<i32> = l.edges.iter().map(|e| winding(e.point(0.37))).collect();
    values.sort_unstable();
    let mut best = (0, values.first().copied().unwrap_or(0));
    let mut k = 0;
    while k < values.len() {
        let run = values[k..].iter().take_while(|&&v| v == values[k]).count();
        if run > best.0 {
            best = (run, values[k]);
        }
        k += run;
    }
    best.1
}

/// A piece as a whole curve: the line `x = p + k y`, or the circle `(cx, cy, r)`.
enum Curve {
    Line { p: f64, k: f64 },
    Circle { c: DVec2, r: f64 },
}

fn curve(piece: &Piece) -> Curve {
    match *piece {
        Piece::Line { x0, y0, dxdy } => Curve::Line {
            p: x0 - y0 * dxdy,
            k: dxdy,
        },
        Piece::Arc { cx, cy, r, .. } => Curve::Circle {
            c: DVec2::new(cx, cy),
            r,
        },
    }
}

/// Ordinates where the line `x = p + k y` meets the circle (NaN where it does not).
fn line_circle(p: f64, k: f64, c: DVec2, r: f64) -> [f64; 2] {
    // (p + k y − cx)² + (y − cy)² = r².
    let u = p - c.x;
    let a = 1.0 + k * k;
    let b = 2.0 * (k * u - c.y);
    let cc = u * u + c.y * c.y - r * r;
    let s = (b * b - 4.0 * a * cc).max(0.0).sqrt();
    [(-b - s) / (2.0 * a), (-b + s) / (2.0 * a)]
}

/// Ordinates where the two pieces' whole curves meet (at most two; NaN for none, as for
/// parallel lines or concentric circles).
fn meeting_ordinates(a: &Piece, b: &Piece) -> [f64; 2] {
    match (curve(a), curve(b)) {
        (Curve::Line { p: pa, k: ka }, Curve::Line { p: pb, k: kb }) => {
            [(pb - pa) / (ka - kb), f64::NAN]
        }
        (Curve::Line { p, k }, Curve::Circle { c, r })
        | (Curve::Circle { c, r }, Curve::Line { p, k }) => line_circle(p, k, c, r),
        (Curve::Circle { c: c1, r: r1 }, Curve::Circle { c: c2, r: r2 }) => {
            // Radical line: 2 x dx + 2 y dy = r1² − r2² + |c2|² − |c1|².
            let d = c2 - c1;
            let rhs = r1 * r1 - r2 * r2 + c2.length_squared() - c1.length_squared();
            if d.x != 0.0 {
                line_circle(rhs / (2.0 * d.x), -d.y / d.x, c1, r1)
            } else {
                [rhs / (2.0 * d.y), f64::NAN]
            }
        }
    }
}

/// True if `right` (to the right of `left` at mid-slab) passes left of it by more than
/// `tol` somewhere in `(y0, y1)`: the gap is checked between consecutive ordinates
/// where the two curves meet, where its sign is constant.
fn pieces_cross(left: &Piece, right: &Piece, y0: f64, y1: f64, tol: f64) -> bool {
    let [m0, m1] = meeting_ordinates(left, right);
    // Non-finite and outside ordinates are clamped onto the slab's ends.
    let inside = |y: f64| if y > y0 && y < y1 { y } else { y0 };
    let mut cuts = [y0, inside(m0), inside(m1), y1];
    cuts.sort_by(f64::total_cmp);
    cuts.windows(2).any(|w| {
        let y = 0.5 * (w[0] + w[1]);
        w[1] > w[0] && right.x_at(y) - left.x_at(y) < -tol
    })
}
