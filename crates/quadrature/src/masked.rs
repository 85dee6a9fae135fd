//! Cell-centred `n×n` rules on the unit square and masked rules whose weights are the
//! real-area fraction of each cell of a trimmed support (VirtualMesh §4.2, Fig. 7).
//!
//! VirtualMesh §4.2: when a trimmed surface `S` emits, its virtual support `S̃ = [0,1]²`
//! holds energy on real *and* virtual points; to avoid re-propagating the virtual part,
//! the cell-centred rule `p_ij = ((2i-1)/2n, (2j-1)/2n)`, `w_ij = 1/n²` (Fig. 7a) keeps
//! its points but takes as weight the area of the real part of each cell (Fig. 7b).
//!
//! - Polygonal trims ([`Polygon`], any number of non-crossing loops, non-convex, with
//!   holes): the real area of each cell is computed *exactly* (to rounding) by
//!   Sutherland–Hodgman clipping of every loop against the cell and the shoelace
//!   formula. Clipping a non-convex loop against a convex window may leave degenerate
//!   edges along the window, but the signed area (the integral of the winding number
//!   over the window) is exact.
//! - Curved trims (any [`SignedDistance`]: a conservative signed distance, e.g.
//!   [`Disk`], unions/intersections/complements of regions, or a user closure through
//!   [`SdfFn`]): each cell is subdivided adaptively; a square of half-diagonal `r` whose
//!   centre has `d <= -r` is wholly inside, `d >= r` wholly outside, otherwise it is
//!   split, down to `max_depth` levels. An unresolved leaf gets the estimate
//!   `clamp(1/2 - d/(2r), 0, 1)` and contributes `max(est, 1-est) · area` to the stated
//!   error bound. The bound is rigorous for a conservative distance; it decays like
//!   `O(L · 2^{-max_depth} / n)` for a boundary of length `L` (unresolved leaves lie
//!   within `r` of the boundary).
//!
//! Accuracy of the masked centre rule for `∫_S f` (h = 1/n): every real sub-area is
//! approximated by `frac · h² · f(centre)`, so the error is at most
//! `A_full · h² (‖f_uu‖ + ‖f_vv‖)/24 + A_mixed · ‖∇f‖ h / √2 + ‖f‖ · bound`, where
//! `A_mixed = O(L h)` is the real area of the mixed cells: `O(h²)` overall, matching
//! the paper's remark that the mixed cells' area vanishes as the grid is refined. For
//! the per-cell Gauss variant ([`CellFractions::gauss_rule`]) the full-cell term is
//! smaller (exact for degree `2·order - 1` per axis) and the mixed-cell term uses the
//! cell diameter `h √2` in place of `h / √2`.

use crate::{GaussLegendre, QuadratureError, RuleNd, check_finite};

/// Largest grid size accepted by the cell rules.
pub const MAX_CELLS_PER_AXIS: usize = 4096;

/// Largest subdivision depth accepted by [`cell_fractions_adaptive`].
pub const MAX_DEPTH: u32 = 24;

fn check_n(n: usize) -> Result<(), QuadratureError> {
    if (1..=MAX_CELLS_PER_AXIS).contains(&n) {
        Ok(())
    } else {
        Err(QuadratureError::OrderOutOfRange {
            order: n,
            min: 1,
            max: MAX_CELLS_PER_AXIS,
        })
    }
}

/// The cell-centred `n×n` rule on `[0,1]²` of VirtualMesh §4.2 (Fig. 7a): points
/// `((2i+1)/2n, (2j+1)/2n)`, weights `1/n²`, `u` (index `i`) varying fastest. Exact
/// for polynomials of degree `<= 1` in each variable; `O(1/n²)` for smooth integrands.
///
/// # Errors
/// [`QuadratureError::OrderOutOfRange`] unless `1 <= n <= 4096`.
pub fn cell_centre_rule(n: usize) -> Result<RuleNd, QuadratureError> {
    check_n(n)?;
    let h = 1.0 / n as f64;
    let mut points = Vec::with_capacity(2 * n * n);
    for j in 0..n {
        for i in 0..n {
            points.push((i as f64 + 0.5) * h);
            points.push((j as f64 + 0.5) * h);
        }
    }
    Ok(RuleNd::from_parts(2, points, vec![h * h; n * n]))
}

/// Real-area fractions of the cells of an `n×n` grid on `[0,1]²`.
#[derive(Debug, Clone, PartialEq)]
pub struct CellFractions {
    n: usize,
    fractions: Vec<f64>,
    error_bound: f64,
}

impl CellFractions {
    /// Grid size per axis.
    #[must_use]
    pub fn n(&self) -> usize {
        self.n
    }

    /// Fractions in `[0, 1]`, row-major: cell `(i, j)` (i along u, j along v) is at
    /// `j * n + i`.
    #[must_use]
    pub fn fractions(&self) -> &[f64] {
        &self.fractions
    }

    /// Fraction of cell `(i, j)`.
    ///
    /// # Panics
    /// If `i >= n` or `j >= n`.
    #[must_use]
    pub fn fraction(&self, i: usize, j: usize) -> f64 {
        assert!(
            i < self.n && j < self.n,
            "cell ({i}, {j}) outside {0}×{0}",
            self.n
        );
        self.fractions[j * self.n + i]
    }

    /// Total real area `Σ fraction / n²`.
    #[must_use]
    pub fn real_area(&self) -> f64 {
        self.fractions.iter().sum::<f64>() / (self.n * self.n) as f64
    }

    /// Bound on `Σ |fraction error| / n²` (absolute area in the unit square): 0 up to
    /// rounding for polygons, the unresolved-leaf bound for adaptive fractions.
    #[must_use]
    pub fn error_bound(&self) -> f64 {
        self.error_bound
    }

    /// Fig. 7b: points at the cell centres, weight = real area of the cell
    /// (`fraction / n²`). Cells with fraction 0 are left out.
    #[must_use]
    pub fn centre_rule(&self) -> RuleNd {
        let n = self.n;
        let h = 1.0 / n as f64;
        let mut points = Vec::new();
        let mut weights = Vec::new();
        for j in 0..n {
            for i in 0..n {
                let f = self.fractions[j * n + i];
                if f > 0.0 {
                    points.push((i as f64 + 0.5) * h);
                    points.push((j as f64 + 0.5) * h);
                    weights.push(f * h * h);
                }
            }
        }
        RuleNd::from_parts(2, points, weights)
    }

    /// Fig. 7b with `order × order` Gauss–Legendre points per cell: the cell's Gauss
    /// rule with its weights scaled by the cell's real-area fraction. Cells with
    /// fraction 0 are left out.
    ///
    /// # Errors
    /// [`QuadratureError::OrderOutOfRange`] unless `1 <= order <= 128`.
    pub fn gauss_rule(&self, order: usize) -> Result<RuleNd, QuadratureError> {
        let (x, w) = GaussLegendre::new(order)?.unit();
        let n = self.n;
        let h = 1.0 / n as f64;
        let mut points = Vec::new();
        let mut weights = Vec::new();
        for j in 0..n {
            for i in 0..n {
                let f = self.fractions[j * n + i];
                if f <= 0.0 {
                    continue;
                }
                for (&xv, &wv) in x.iter().zip(&w) {
                    for (&xu, &wu) in x.iter().zip(&w) {
                        points.push((i as f64 + xu) * h);
                        points.push((j as f64 + xv) * h);
                        weights.push(f * wu * wv * h * h);
                    }
                }
            }
        }
        Ok(RuleNd::from_parts(2, points, weights))
    }
}

/// A polygonal region in the plane: one or more closed loops (vertices in order, the
/// closing edge implied) that do not cross or touch each other. Loops may be
/// non-convex; a loop nested inside an odd number of others is a hole. Orientation of
/// the input does not matter (it is normalised by nesting depth).
#[derive(Debug, Clone, PartialEq)]
pub struct Polygon {
    loops: Vec<Vec<[f64; 2]>>,
}

/// Twice the signed area of a closed loop (shoelace).
fn twice_signed_area(pts: &[[f64; 2]]) -> f64 {
    let m = pts.len();
    (0..m)
        .map(|k| {
            let a = pts[k];
            let b = pts[(k + 1) % m];
            a[0] * b[1] - a[1] * b[0]
        })
        .sum()
}

/// Twice the signed area of a closed loop, with coordinates taken relative to `o`
/// (a nearby point such as the clipping cell's corner) to avoid cancellation when the
/// loop is small compared with its distance from the origin.
fn twice_signed_area_about(pts: &[[f64; 2]], o: [f64; 2]) -> f64 {
    let m = pts.len();
    (0..m)
        .map(|k| {
            let a = pts[k];
            let b = pts[(k + 1) % m];
            (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])
        })
        .sum()
}

/// Even–odd crossing test of `p` against one loop.
fn loop_contains(pts: &[[f64; 2]], p: [f64; 2]) -> bool {
    let m = pts.len();
    let mut inside = false;
    for k in 0..m {
        let a = pts[k];
        let b = pts[(k + 1) % m];
        if (a[1] > p[1]) != (b[1] > p[1]) {
            let x = a[0] + (p[1] - a[1]) / (b[1] - a[1]) * (b[0] - a[0]);
            if p[0] < x {
                inside = !inside;
            }
        }
    }
    inside
}

/// Clips a loop to the half-plane `sign · (p[axis] - c) <= 0` (Sutherland–Hodgman).
fn clip_half_plane(
    input: &[[f64; 2]],
    axis: usize,
    c: f64,
    keep_below: bool,
    out: &mut Vec<[f64; 2]>,
) {
    out.clear();
    let m = input.len();
    if m == 0 {
        return;
    }
    let inside = |p: [f64; 2]| {
        if keep_below {
            p[axis] <= c
        } else {
            p[axis] >= c
        }
    };
    for k in 0..m {
        let cur = input[k];
        let prev = input[(k + m - 1) % m];
        let (ci, pi) = (inside(cur), inside(prev));
        if ci != pi {
            let t = (c - prev[axis]) / (cur[axis] - prev[axis]);
            let mut q = [
                prev[0] + t * (cur[0] - prev[0]),
                prev[1] + t * (cur[1] - prev[1]),
            ];
            q[axis] = c;
            out.push(q);
        }
        if ci {
            out.push(cur);
        }
    }
}

/// Distance from `p` to the segment `ab`.
fn segment_distance(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let len2 = dx * dx + dy * dy;
    let t = if len2 > 0.0 {
        (((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (p[0] - a[0] - t * dx).hypot(p[1] - a[1] - t * dy)
}

impl Polygon {
    /// Builds a polygon from loops and orients them by nesting depth (outer loops
    /// counter-clockwise, holes clockwise), so that the region is the even–odd set.
    ///
    /// # Errors
    /// [`QuadratureError::InvalidRegion`] if there are no loops, a loop has fewer than
    /// three vertices or zero area; [`QuadratureError::InvalidParameter`] for
    /// non-finite coordinates.
    pub fn new(loops: Vec<Vec<[f64; 2]>>) -> Result<Self, QuadratureError> {
        if loops.is_empty() {
            return Err(QuadratureError::InvalidRegion(
                "a polygon needs at least one loop",
            ));
        }
        for l in &loops {
            if l.len() < 3 {
                return Err(QuadratureError::InvalidRegion(
                    "a loop needs at least three vertices",
                ));
            }
            for p in l {
                check_finite("polygon vertex", p[0])?;
                check_finite("polygon vertex", p[1])?;
            }
            if twice_signed_area(l) == 0.0 {
                return Err(QuadratureError::InvalidRegion("a loop has zero area"));
            }
        }
        let depths: Vec<usize> = (0..loops.len())
            .map(|k| {
                (0..loops.len())
                    .filter(|&m| m != k && loop_contains(&loops[m], loops[k][0]))
                    .count()
            })
            .collect();
        let loops = loops
            .into_iter()
            .zip(depths)
            .map(|(mut l, d)| {
                let want_ccw = d % 2 == 0;
                if (twice_signed_area(&l) > 0.0) != want_ccw {
                    l.reverse();
                }
                l
            })
            .collect();
        Ok(Self { loops })
    }

    /// A single-loop polygon.
    ///
    /// # Errors
    /// As [`Polygon::new`].
    pub fn simple(vertices: Vec<[f64; 2]>) -> Result<Self, QuadratureError> {
        Self::new(vec![vertices])
    }

    /// The oriented loops (outer counter-clockwise, holes clockwise).
    #[must_use]
    pub fn loops(&self) -> &[Vec<[f64; 2]>] {
        &self.loops
    }

    /// Area of the region (shoelace over the oriented loops).
    #[must_use]
    pub fn area(&self) -> f64 {
        0.5 * self.loops.iter().map(|l| twice_signed_area(l)).sum::<f64>()
    }

    /// Even–odd point-in-region test.
    #[must_use]
    pub fn contains(&self, p: [f64; 2]) -> bool {
        self.loops.iter().filter(|l| loop_contains(l, p)).count() % 2 == 1
    }

    /// Exact area (to rounding) of the region inside the axis-aligned box `[lo, hi]`.
    /// Returns 0 for an empty or inverted box.
    #[must_use]
    pub fn area_in_box(&self, lo: [f64; 2], hi: [f64; 2]) -> f64 {
        if !(lo[0] < hi[0] && lo[1] < hi[1]) {
            return 0.0;
        }
        let mut a = Vec::new();
        let mut b = Vec::new();
        let mut total = 0.0;
        for l in &self.loops {
            clip_half_plane(l, 0, lo[0], false, &mut a);
            clip_half_plane(&a, 0, hi[0], true, &mut b);
            clip_half_plane(&b, 1, lo[1], false, &mut a);
            clip_half_plane(&a, 1, hi[1], true, &mut b);
            if b.len() >= 3 {
                total += 0.5 * twice_signed_area_about(&b, lo);
            }
        }
        // Rounding can leave a tiny negative or over-full value; the true one is in
        // [0, box area].
        total.clamp(0.0, (hi[0] - lo[0]) * (hi[1] - lo[1]))
    }

    /// Exact real-area fractions of the `n×n` cells of `[0,1]²` (VirtualMesh Fig. 7b
    /// for polygonal trims). Each loop is clipped to each column strip once, then the
    /// strip pieces to each cell.
    ///
    /// # Errors
    /// [`QuadratureError::OrderOutOfRange`] unless `1 <= n <= 4096`.
    pub fn cell_fractions(&self, n: usize) -> Result<CellFractions, QuadratureError> {
        check_n(n)?;
        let h = 1.0 / n as f64;
        let cell_area = h * h;
        let mut fractions = vec![0.0; n * n];
        let mut strip = Vec::new();
        let mut tmp = Vec::new();
        let mut a = Vec::new();
        let mut b = Vec::new();
        for l in &self.loops {
            for i in 0..n {
                let (x0, x1) = (i as f64 * h, (i + 1) as f64 * h);
                clip_half_plane(l, 0, x0, false, &mut tmp);
                clip_half_plane(&tmp, 0, x1, true, &mut strip);
                if strip.len() < 3 {
                    continue;
                }
                let (ymin, ymax) = strip
                    .iter()
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
                        (lo.min(p[1]), hi.max(p[1]))
                    });
                let j0 = ((ymin / h).floor().max(0.0) as usize).min(n);
                let j1 = ((ymax / h).ceil().max(0.0) as usize).min(n);
                for j in j0..j1 {
                    let (y0, y1) = (j as f64 * h, (j + 1) as f64 * h);
                    clip_half_plane(&strip, 1, y0, false, &mut a);
                    clip_half_plane(&a, 1, y1, true, &mut b);
                    if b.len() >= 3 {
                        fractions[j * n + i] +=
                            0.5 * twice_signed_area_about(&b, [x0, y0]) / cell_area;
                    }
                }
            }
        }
        for f in &mut fractions {
            *f = f.clamp(0.0, 1.0);
        }
        Ok(CellFractions {
            n,
            fractions,
            error_bound: 0.0,
        })
    }
}

/// A region described by a conservative signed distance.
///
/// Contract: `signed_distance(p)` is negative inside, positive outside, and its
/// magnitude never exceeds the Euclidean distance from `p` to the region's boundary
/// (an exact signed distance qualifies; so do `min`/`max` combinations of them). The
/// error bounds of [`cell_fractions_adaptive`] rely on this.
pub trait SignedDistance {
    /// Conservative signed distance from `p` to the boundary (negative inside).
    fn signed_distance(&self, p: [f64; 2]) -> f64;
}

impl SignedDistance for Polygon {
    /// Exact: distance to the nearest edge, negative inside (even–odd).
    fn signed_distance(&self, p: [f64; 2]) -> f64 {
        let d = self
            .loops
            .iter()
            .flat_map(|l| {
                (0..l.len()).map(move |k| segment_distance(p, l[k], l[(k + 1) % l.len()]))
            })
            .fold(f64::INFINITY, f64::min);
        if self.contains(p) { -d } else { d }
    }
}

/// A disk, with its exact signed distance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Disk {
    /// Centre.
    pub centre: [f64; 2],
    /// Radius (> 0).
    pub radius: f64,
}

impl Disk {
    /// A disk of the given centre and radius.
    ///
    /// # Errors
    /// [`QuadratureError::InvalidParameter`] for a non-finite centre or a radius that
    /// is not finite and positive.
    pub fn new(centre: [f64; 2], radius: f64) -> Result<Self, QuadratureError> {
        check_finite("centre", centre[0])?;
        check_finite("centre", centre[1])?;
        if !(radius.is_finite() && radius > 0.0) {
            return Err(QuadratureError::InvalidParameter {
                name: "radius",
                value: radius,
                reason: "must be finite and positive",
            });
        }
        Ok(Self { centre, radius })
    }
}

impl SignedDistance for Disk {
    fn signed_distance(&self, p: [f64; 2]) -> f64 {
        (p[0] - self.centre[0]).hypot(p[1] - self.centre[1]) - self.radius
    }
}

/// Union of two regions (`min` of the distances; conservative).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Union<A, B>(pub A, pub B);

impl<A: SignedDistance, B: SignedDistance> SignedDistance for Union<A, B> {
    fn signed_distance(&self, p: [f64; 2]) -> f64 {
        self.0.signed_distance(p).min(self.1.signed_distance(p))
    }
}

/// Intersection of two regions (`max` of the distances; conservative).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Intersection<A, B>(pub A, pub B);

impl<A: SignedDistance, B: SignedDistance> SignedDistance for Intersection<A, B> {
    fn signed_distance(&self, p: [f64; 2]) -> f64 {
        self.0.signed_distance(p).max(self.1.signed_distance(p))
    }
}

/// Complement of a region (negated distance).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Complement<A>(pub A);

impl<A: SignedDistance> SignedDistance for Complement<A> {
    fn signed_distance(&self, p: [f64; 2]) -> f64 {
        -self.0.signed_distance(p)
    }
}

/// A user-supplied conservative signed distance (see [`SignedDistance`] for the
/// contract the closure must honour).
#[derive(Debug, Clone, Copy)]
pub struct SdfFn<F>(pub F);

impl<F: Fn([f64; 2]) -> f64> SignedDistance for SdfFn<F> {
    fn signed_distance(&self, p: [f64; 2]) -> f64 {
        (self.0)(p)
    }
}

/// Real-area fraction of the square with lower corner `(x, y)` and side `s`, by
/// adaptive subdivision; returns `(area, error bound)`.
fn adaptive_area(region: &impl SignedDistance, x: f64, y: f64, s: f64, depth: u32) -> (f64, f64) {
    let r = s * std::f64::consts::FRAC_1_SQRT_2;
    let d = region.signed_distance([x + 0.5 * s, y + 0.5 * s]);
    let area = s * s;
    if d.is_nan() {
        return (0.5 * area, 0.5 * area);
    }
    if d <= -r {
        return (area, 0.0);
    }
    if d >= r {
        return (0.0, 0.0);
    }
    if depth == 0 {
        let est = (0.5 - 0.5 * d / r).clamp(0.0, 1.0);
        return (est * area, est.max(1.0 - est) * area);
    }
    let h = 0.5 * s;
    let mut acc = (0.0, 0.0);
    for (dx, dy) in [(0.0, 0.0), (h, 0.0), (0.0, h), (h, h)] {
        let (a, e) = adaptive_area(region, x + dx, y + dy, h, depth - 1);
        acc.0 += a;
        acc.1 += e;
    }
    acc
}

/// Real-area fractions of the `n×n` cells for a curved trim given by a conservative
/// signed distance, by adaptive quadtree subdivision of each cell down to `max_depth`
/// levels (leaves of side `2^{-max_depth} / n`). The returned
/// [`CellFractions::error_bound`] bounds the total absolute area error; see the module
/// documentation. A NaN distance counts as an unresolved leaf.
///
/// # Errors
/// [`QuadratureError::OrderOutOfRange`] unless `1 <= n <= 4096` and
/// `max_depth <= 24`.
pub fn cell_fractions_adaptive(
    region: &impl SignedDistance,
    n: usize,
    max_depth: u32,
) -> Result<CellFractions, QuadratureError> {
    check_n(n)?;
    if max_depth > MAX_DEPTH {
        return Err(QuadratureError::OrderOutOfRange {
            order: max_depth as usize,
            min: 0,
            max: MAX_DEPTH as usize,
        });
    }
    let h = 1.0 / n as f64;
    let mut fractions = vec![0.0; n * n];
    let mut bound = 0.0;
    for j in 0..n {
        for i in 0..n {
            let (a, e) = adaptive_area(region, i as f64 * h, j as f64 * h, h, max_depth);
            fractions[j * n + i] = (a / (h * h)).clamp(0.0, 1.0);
            bound += e;
        }
    }
    Ok(CellFractions {
        n,
        fractions,
        error_bound: bound,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// A non-convex star (outer, counter-clockwise as given) with a square hole given
    /// counter-clockwise too (orientation must be normalised by `Polygon::new`).
    fn star_with_hole() -> Polygon {
        let outer: Vec<[f64; 2]> = (0..10)
            .map(|k| {
                let th = std::f64::consts::TAU * k as f64 / 10.0 + 0.1;
                let r = if k % 2 == 0 { 0.45 } else { 0.2 };
                [0.5 + r * th.cos(), 0.5 + r * th.sin()]
            })
            .collect();
        let hole = vec![[0.45, 0.45], [0.55, 0.45], [0.55, 0.55], [0.45, 0.55]];
        Polygon::new(vec![outer, hole]).unwrap()
    }

    /// Exact ∫_S u^a v^b by Green's theorem: ∮ u^{a+1} v^b / (a+1) dv, each edge by a
    /// Gauss rule exact for its polynomial degree a+b+1.
    fn green_moment(p: &Polygon, a: i32, b: i32) -> f64 {
        let g = GaussLegendre::new(((a + b + 2) as usize).div_ceil(2) + 1).unwrap();
        let mut total = 0.0;
        for l in p.loops() {
            for k in 0..l.len() {
                let (s, e) = (l[k], l[(k + 1) % l.len()]);
                total += g.integrate(0.0, 1.0, |t| {
                    let u = s[0] + t * (e[0] - s[0]);
                    let v = s[1] + t * (e[1] - s[1]);
                    u.powi(a + 1) * v.powi(b) / f64::from(a + 1) * (e[1] - s[1])
                });
            }
        }
        total
    }

    #[test]
    fn cell_centre_rule_is_the_midpoint_rule() {
        let r = cell_centre_rule(7).unwrap();
        assert_eq!(r.len(), 49);
        assert!((r.weight_sum() - 1.0).abs() < 1e-14);
        assert!((r.integrate(|p| p[0] * p[1]) - 0.25).abs() < 1e-15);
        // Second order: ∫ u² = 1/3, midpoint error exactly h²/12.
        for n in [4usize, 16] {
            let h = 1.0 / n as f64;
            let v = cell_centre_rule(n).unwrap().integrate(|p| p[0] * p[0]);
            assert!((v - (1.0 / 3.0 - h * h / 12.0)).abs() < 1e-14);
        }
        assert!(cell_centre_rule(0).is_err());
    }

    #[test]
    fn orientation_is_normalised_and_area_counts_holes() {
        let p = star_with_hole();
        let star_only = Polygon::simple(p.loops()[0].clone()).unwrap();
        assert!(p.loops()[0].len() == 10 && twice_signed_area(&p.loops()[0]) > 0.0);
        assert!(twice_signed_area(&p.loops()[1]) < 0.0);
        assert!((p.area() - (star_only.area() - 0.01)).abs() < 1e-15);
        assert!(!p.contains([0.5, 0.5]));
        assert!(p.contains([0.5 + 0.3, 0.5 + 0.03]));
        // Green's theorem independently gives the same area.
        assert!((green_moment(&p, 0, 0) - p.area()).abs() < 1e-15);
    }

    #[test]
    fn masked_weights_integrate_polygon_areas_exactly() {
        let p = star_with_hole();
        for n in [1usize, 2, 7, 32, 100] {
            let c = p.cell_fractions(n).unwrap();
            assert!(
                (c.real_area() - p.area()).abs() < 1e-14,
                "n={n} {:e}",
                c.real_area() - p.area()
            );
            assert!(
                (c.centre_rule().weight_sum() - p.area()).abs() < 1e-14,
                "{:e}",
                c.centre_rule().weight_sum() - p.area()
            );
            assert!((c.gauss_rule(3).unwrap().weight_sum() - p.area()).abs() < 1e-14);
            assert_eq!(c.error_bound(), 0.0);
            assert!(c.fractions().iter().all(|f| (0.0..=1.0).contains(f)));
        }
        // Refinement consistency: 2×2 blocks of the 2m grid give the m grid.
        let (c16, c32) = (p.cell_fractions(16).unwrap(), p.cell_fractions(32).unwrap());
        for j in 0..16 {
            for i in 0..16 {
                let s = c32.fraction(2 * i, 2 * j)
                    + c32.fraction(2 * i + 1, 2 * j)
                    + c32.fraction(2 * i, 2 * j + 1)
                    + c32.fraction(2 * i + 1, 2 * j + 1);
                assert!((0.25 * s - c16.fraction(i, j)).abs() < 1e-13);
            }
        }
    }

    #[test]
    fn rectangles_clip_to_the_product_of_overlaps() {
        let r = Polygon::simple(vec![[0.2, -0.5], [0.9, -0.5], [0.9, 0.7], [0.2, 0.7]]).unwrap();
        let overlap = |a0: f64, a1: f64, b0: f64, b1: f64| (a1.min(b1) - a0.max(b0)).max(0.0);
        for (lo, hi) in [
            ([0.0, 0.0], [1.0, 1.0]),
            ([0.5, 0.5], [0.6, 0.9]),
            ([0.95, 0.0], [1.0, 1.0]),
        ] {
            let e = overlap(0.2, 0.9, lo[0], hi[0]) * overlap(-0.5, 0.7, lo[1], hi[1]);
            assert!((r.area_in_box(lo, hi) - e).abs() < 1e-15);
        }
        let c = r.cell_fractions(10).unwrap();
        assert!((c.real_area() - 0.7 * 0.7).abs() < 1e-14);
        assert!((c.fraction(3, 3) - 1.0).abs() < 1e-14);
        assert_eq!(c.fraction(0, 3), 0.0);
        assert_eq!(c.fraction(3, 8), 0.0);
    }

    #[test]
    fn masked_rules_converge_at_second_order_on_polygons() {
        // ∫_S (u² v + v) over the star with a hole, exact by Green's theorem.
        let p = star_with_hole();
        let exact = green_moment(&p, 2, 1) + green_moment(&p, 0, 1);
        let f = |q: &[f64]| q[0] * q[0] * q[1] + q[1];
        let mut prev = f64::INFINITY;
        for n in [16usize, 32, 64, 128] {
            let c = p.cell_fractions(n).unwrap();
            let e_centre = (c.centre_rule().integrate(f) - exact).abs();
            let e_gauss = (c.gauss_rule(2).unwrap().integrate(f) - exact).abs();
            // Stated bound: A_full h²(‖f_uu‖+‖f_vv‖)/24 + A_mixed ‖∇f‖ h/√2, with
            // f_uu = 2v <= 2, f_vv = 0, ∇f = (2uv, u² + 1) so ‖∇f‖ <= √8 on the unit square.
            let h = 1.0 / n as f64;
            let mixed: f64 = c
                .fractions()
                .iter()
                .filter(|&&x| x > 0.0 && x < 1.0)
                .map(|x| x * h * h)
                .sum();
            let bound = p.area() * h * h * 2.0 / 24.0 + mixed * 8f64.sqrt() * h / 2f64.sqrt();
            // Gauss variant: full cells exact for this cubic, mixed cells use the diameter.
            let bound_gauss = mixed * 8f64.sqrt() * h * 2f64.sqrt();
            assert!(e_centre <= bound, "n={n}: {e_centre:e} > {bound:e}");
            assert!(
                e_gauss <= bound_gauss,
                "n={n}: {e_gauss:e} > {bound_gauss:e}"
            );
            // Mixed-cell area is O(h): the bound is O(h²).
            assert!(mixed < 4.0 * h, "n={n} mixed={mixed}");
            assert!(bound < prev / 3.0);
            prev = bound;
        }
    }

    #[test]
    fn adaptive_fractions_bound_their_error() {
        let disk = Disk::new([0.5, 0.45], 0.3).unwrap();
        let exact = std::f64::consts::PI * 0.09;
        let mut prev = f64::INFINITY;
        for depth in [0u32, 2, 4, 6, 8] {
            let c = cell_fractions_adaptive(&disk, 8, depth).unwrap();
            let err = (c.real_area() - exact).abs();
            assert!(
                err <= c.error_bound(),
                "depth={depth}: {err:e} > {:e}",
                c.error_bound()
            );
            // Unresolved leaves hug the boundary: the bound halves per level.
            assert!(c.error_bound() < 0.7 * prev || depth == 0);
            prev = c.error_bound();
        }
        assert!(prev < 2e-3);
        // Against exact polygon fractions (the polygon's own exact distance as SDF).
        let p = star_with_hole();
        let exact = p.cell_fractions(8).unwrap();
        let adaptive = cell_fractions_adaptive(&p, 8, 7).unwrap();
        let diff: f64 = exact
            .fractions()
            .iter()
            .zip(adaptive.fractions())
            .map(|(a, b)| (a - b).abs() / 64.0)
            .sum();
        assert!(
            diff <= adaptive.error_bound(),
            "{diff:e} > {:e}",
            adaptive.error_bound()
        );
        assert!(adaptive.error_bound() < 0.02);
    }

    #[test]
    fn combinators_and_closures() {
        // Annulus = disk minus a smaller disk; area π(R² - r²).
        let ring = Intersection(
            Disk::new([0.5, 0.5], 0.4).unwrap(),
            Complement(Disk::new([0.5, 0.5], 0.2).unwrap()),
        );
        let c = cell_fractions_adaptive(&ring, 16, 8).unwrap();
        let exact = std::f64::consts::PI * (0.16 - 0.04);
        assert!((c.real_area() - exact).abs() <= c.error_bound());
        let two = Union(
            Disk::new([0.25, 0.5], 0.2).unwrap(),
            SdfFn(|p: [f64; 2]| (p[0] - 0.75).hypot(p[1] - 0.5) - 0.2),
        );
        let c = cell_fractions_adaptive(&two, 16, 8).unwrap();
        let exact = 2.0 * std::f64::consts::PI * 0.04;
        assert!((c.real_area() - exact).abs() <= c.error_bound());
        assert!(cell_fractions_adaptive(&two, 16, 25).is_err());
    }

    #[test]
    fn invalid_polygons_are_errors() {
        assert!(Polygon::new(vec![]).is_err());
        assert!(Polygon::simple(vec![[0.0, 0.0], [1.0, 0.0]]).is_err());
        assert!(Polygon::simple(vec![[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]]).is_err());
        assert!(Polygon::simple(vec![[0.0, 0.0], [1.0, f64::NAN], [0.0, 1.0]]).is_err());
        assert!(Disk::new([0.0, 0.0], 0.0).is_err());
        let p = star_with_hole();
        assert!(p.cell_fractions(0).is_err());
        assert_eq!(p.area_in_box([0.5, 0.5], [0.5, 0.9]), 0.0);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        /// Random star-shaped (generally non-convex) polygons, possibly sticking out of
        /// the unit square: the cell weights sum to the area inside the square, which
        /// in turn matches the fractions of a grid of any size.
        #[test]
        fn cell_weights_sum_to_clipped_area(
            radii in proptest::collection::vec(0.05f64..0.8, 3..12),
            cx in 0.2f64..0.8,
            cy in 0.2f64..0.8,
            n in 1usize..40,
        ) {
            let m = radii.len();
            let pts: Vec<[f64; 2]> = radii
                .iter()
                .enumerate()
                .map(|(k, r)| {
                    let th = std::f64::consts::TAU * k as f64 / m as f64;
                    [cx + r * th.cos(), cy + r * th.sin()]
                })
                .collect();
            let p = Polygon::simple(pts).unwrap();
            let inside = p.area_in_box([0.0, 0.0], [1.0, 1.0]);
            prop_assert!(inside <= p.area() + 1e-15);
            let c = p.cell_fractions(n).unwrap();
            prop_assert!((c.real_area() - inside).abs() < 1e-13);
            let c1 = p.cell_fractions(1).unwrap();
            prop_assert!((c1.real_area() - inside).abs() < 1e-14);
        }
    }
}
