//! Analytic form factors: ground truth for tests and reproductions.
//!
//! - [`point_to_polygon`]: differential area → planar polygon, unoccluded, by Lambert's
//!   formula `F = (1/2π) Σ_i β_i n·ĝ_i` after clipping the polygon to the receiver's
//!   upper half-space (so polygons straddling the tangent plane are exact too).
//! - [`polygon_to_polygon`]: `A_i F_ij = (1/2π) ∮_{∂P_i} ∮_{∂P_j} ln r  dx_i·dx_j`
//!   (the contour form of Schröder & Hanrahan 1993). Per edge pair the inner line
//!   integral is done in closed form, `∫ ln|P − Q(t)| dt`; parallel and colinear
//!   edge pairs (shared edges) are closed form in both variables; skew pairs are
//!   integrated in the outer variable by Gauss–Legendre on panels split at every point
//!   where the integrand is not analytic (projections of the other edge's end points,
//!   closest approach) and geometrically graded towards them, which handles shared
//!   vertices and shared edges robustly to ~1e-14 relative. The number of Gauss points
//!   of a panel follows from its distance `d` to the other edge (the integrand's
//!   complex singularities lie at least `d` from the panel, so the rule converges like
//!   `ρ^{-2n}` with `ρ = δ + √(δ² + 1)`, `δ = 2d/len`): 20 points next to the other
//!   edge, down to 4 for distant pairs, which are one panel (no splitting). Each
//!   polygon is first clipped to the other's front half-space, so any relative
//!   position is exact.
//!   Deviation: the outer integral of skew pairs is not the dilogarithm closed form.
//! - Catalog configurations (Howell's catalog): [`parallel_rectangles`],
//!   [`perpendicular_rectangles`], [`coaxial_disks`], [`point_to_parallel_rectangle_corner`],
//!   [`point_to_parallel_disk`].

use glam::DVec3;
use std::f64::consts::PI;
use wavelux_quadrature::GaussLegendre;

use crate::GeometryError;

fn validate_polygon(p: &[DVec3]) -> Result<(), GeometryError> {
    if p.len() < 3 {
        return Err(GeometryError::Degenerate(
            "polygon needs at least 3 vertices",
        ));
    }
    if p.iter().any(|v| !v.is_finite()) {
        return Err(GeometryError::NonFinite("polygon vertex"));
    }
    Ok(())
}

/// Newell normal (area-weighted, length = 2 × area) of a planar polygon.
pub fn newell(p: &[DVec3]) -> DVec3 {
    let mut n = DVec3::ZERO;
    for i in 0..p.len() {
        let a = p[i] - p[0];
        let b = p[(i + 1) % p.len()] - p[0];
        n += a.cross(b);
    }
    n
}

/// Area of a planar polygon.
pub fn polygon_area(p: &[DVec3]) -> f64 {
    0.5 * newell(p).length()
}

/// Clips a polygon to the half-space `n·(x − x0) >= 0` (Sutherland–Hodgman).
pub fn clip_to_halfspace(p: &[DVec3], x0: DVec3, n: DVec3) -> Vec<DVec3> {
    let mut out = Vec::with_capacity(p.len() + 2);
    let d: Vec<f64> = p.iter().map(|v| n.dot(*v - x0)).collect();
    for i in 0..p.len() {
        let j = (i + 1) % p.len();
        if d[i] >= 0.0 {
            out.push(p[i]);
        }
        if (d[i] > 0.0 && d[j] < 0.0) || (d[i] < 0.0 && d[j] > 0.0) {
            let s = d[i] / (d[i] - d[j]);
            out.push(p[i] + s * (p[j] - p[i]));
        }
    }
    out
}

/// Form factor from a differential area at `x` with unit normal `n` to a planar polygon
/// (any orientation; unoccluded). Exact to rounding (Lambert's formula on the part of the
/// polygon above the receiver's tangent plane). Returns 0 for a polygon seen edge-on.
///
/// # Errors
/// Fewer than 3 vertices, non-finite input, or a zero normal.
pub fn point_to_polygon(x: DVec3, n: DVec3, poly: &[DVec3]) -> Result<f64, GeometryError> {
    validate_polygon(poly)?;
    if !x.is_finite() || !n.is_finite() {
        return Err(GeometryError::NonFinite("receiver point/normal"));
    }
    let n = n
        .try_normalize()
        .ok_or(GeometryError::Degenerate("zero receiver normal"))?;
    let clipped = clip_to_halfspace(poly, x, n);
    if clipped.len() < 3 {
        return Ok(0.0);
    }
    let mut sum = 0.0;
    for i in 0..clipped.len() {
        let a = clipped[i] - x;
        let b = clipped[(i + 1) % clipped.len()] - x;
        let c = a.cross(b);
        let cl = c.length();
        if cl == 0.0 {
            continue;
        }
        let beta = cl.atan2(a.dot(b));
        sum += beta * n.dot(c) / cl;
    }
    Ok((sum / (2.0 * PI)).abs())
}

/// `∫_{x0}^{x1} ½ ln(x² + h²) dx` in closed form.
fn int_log(x0: f64, x1: f64, h: f64) -> f64 {
    let f = |x: f64| -> f64 {
        if h == 0.0 {
            if x == 0.0 { 0.0 } else { x * x.abs().ln() - x }
        } else {
            0.5 * x * (x * x + h * h).ln() - x + h * (x / h).atan()
        }
    };
    f(x1) - f(x0)
}

/// `∫_0^L ln|p − (q0 + t u)| dt` for unit `u`, closed form.
fn line_log_integral(p: DVec3, q0: DVec3, u: DVec3, l: f64) -> f64 {
    let w = p - q0;
    let a = w.dot(u);
    let h2 = (w - a * u).length_squared();
    int_log(-a, l - a, h2.sqrt())
}

/// `∫_0^{L1} ∫_0^{L2} ½ ln((s − t + c)² + h²) dt ds` (parallel lines at distance `h`,
/// offset `c`), closed form via the second antiderivative.
fn parallel_double(l1: f64, l2: f64, c: f64, h: f64) -> f64 {
    // G''(x) = ½ ln(x² + h²). ∫∫ g(s − t + c) = G(L1 + c) − G(L1 − L2 + c) − G(c) + G(c − L2).
    let g = |x: f64| -> f64 {
        if h == 0.0 {
            if x == 0.0 {
                0.0
            } else {
                0.5 * x * x * x.abs().ln() - 0.75 * x * x
            }
        } else {
            let r2 = x * x + h * h;
            0.25 * (x * x - h * h) * r2.ln() - 0.75 * x * x + h * x * (x / h).atan()
        }
    };
    g(l1 + c) - g(l1 - l2 + c) - g(c) + g(c - l2)
}

/// Quadrature context for skew edge pairs.
struct Outer {
    /// `rules[n − MIN_POINTS]`: the `n`-point Gauss–Legendre rule.
    rules: Vec<GaussLegendre>,
    /// The 20-point rule (panels next to the other edge, graded panels).
    gl: GaussLegendre,
}

/// Fewest Gauss points of an outer panel.
const MIN_POINTS: usize = 4;
/// Most Gauss points of an outer panel (panels closer to the other edge than half
/// their length, and the graded panels).
const MAX_POINTS: usize = 20;

impl Outer {
    /// The shared rules (built once: the solver evaluates the contour integral for
    /// every link).
    fn get() -> Result<&'static Outer, GeometryError> {
        static OUTER: std::sync::OnceLock<Option<Outer>> = std::sync::OnceLock::new();
        OUTER
            .get_or_init(|| {
                let rules = (MIN_POINTS..=MAX_POINTS)
                    .map(|n| GaussLegendre::new(n).ok())
                    .collect::<Option<Vec<_>>>()?;
                let gl = GaussLegendre::new(MAX_POINTS).ok()?;
                Some(Outer { rules, gl })
            })
            .as_ref()
            .ok_or(GeometryError::Degenerate(
                "Gauss–Legendre rules of orders 4..=20 unavailable",
            ))
    }

    /// The Gauss rule for a panel of length `len` whose integrand's singularities lie
    /// at least `dist` from it (in the complex plane of the outer variable; for the
    /// contour integrand, the distance from the panel to the other edge), or `None`
    /// when the panel is closer than half its length (split and graded instead).
    ///
    /// The integrand is analytic inside the Bernstein ellipse with `ρ = δ + √(δ² + 1)`,
    /// `δ = 2 dist/len` (that ellipse lies within `dist` of the panel), so an
    /// `n`-point rule errs by about `ρ^{−2n}` of the integrand's size: `n = ⌈20 / ln ρ⌉`
    /// puts that below `e^{−40} ≈ 4·10⁻¹⁸` (clamped to 4..=20; at `δ = 1`, `n = 23`
    /// would be needed and the 20-point rule of the near panels is used, as before).
    fn rule_for(&self, len: f64, dist: f64) -> Option<&GaussLegendre> {
        let delta = 2.0 * dist / len;
        if delta.is_nan() || delta < 1.0 {
            return None;
        }
        let rho = delta + (delta * delta + 1.0).sqrt();
        let n = (20.0 / rho.ln()).ceil();
        let n = if n.is_finite() {
            (n as usize).clamp(MIN_POINTS, MAX_POINTS)
        } else {
            MIN_POINTS
        };
        Some(&self.rules[n - MIN_POINTS])
    }

    /// `∫_a^b f` on a panel graded geometrically towards the end points `a`/`b` flagged.
    fn graded(&self, a: f64, b: f64, grade_a: bool, grade_b: bool, f: &impl Fn(f64) -> f64) -> f64 {
        if b <= a {
            return 0.0;
        }
        if grade_a && grade_b {
            let m = 0.5 * (a + b);
            return self.graded(a, m, true, false, f) + self.graded(m, b, false, true, f);
        }
        if !grade_a && !grade_b {
            return self.gl.integrate(a, b, f);
        }
        let sigma = 0.15;
        let len = b - a;
        let mut total = 0.0;
        let mut d_hi = len;
        // Panels [d·σ, d] measured from the singular end, down to 1e-16 relative.
        while d_hi > 1e-16 * len {
            let d_lo = d_hi * sigma;
            let (x0, x1) = if grade_a {
                (a + d_lo, a + d_hi)
            } else {
                (b - d_hi, b - d_lo)
            };
            total += self.gl.integrate(x0, x1, f);
            d_hi = d_lo;
        }
        total
    }
}

fn edge_pair(outer: &Outer, p0: DVec3, p1: DVec3, q0: DVec3, q1: DVec3) -> f64 {
    let lp = (p1 - p0).length();
    let lq = (q1 - q0).length();
    if lp == 0.0 || lq == 0.0 {
        return 0.0;
    }
    let up = (p1 - p0) / lp;
    let uq = (q1 - q0) / lq;
    let cosang = up.dot(uq);
    if cosang == 0.0 {
        return 0.0;
    }
    let cr = up.cross(uq).length();
    let scale = lp.max(lq).max((q0 - p0).length());
    if cr <= 1e-13 {
        // Parallel (or anti-parallel) edges: |P(s) − Q(t)|² = (s − σ t + c)² + h² with σ = ±1.
        let w = p0 - q0;
        let a = w.dot(uq);
        let h = (w - a * uq).length();
        let h = if h <= 1e-15 * scale { 0.0 } else { h };
        let sigma = cosang.signum();
        // Along uq: P(s)·uq = a + σ s; Q(t) = t. Difference x = a + σ s − t.
        // Substitute s' = σ s: for σ = −1 integrate s' ∈ [−lp, 0].
        let v = if sigma > 0.0 {
            parallel_double(lp, lq, a, h)
        } else {
            // ∫_{-lp}^0 ∫_0^lq ½ ln((s' − t + a)² + h²) = shift s' = s'' − lp.
            parallel_double(lp, lq, a - lp, h)
        };
        return cosang * v;
    }
    // Skew: outer integral over s ∈ [0, lp] of the closed-form inner integral.
    let f = |s: f64| line_log_integral(p0 + s * up, q0, uq, lq);
    // Edges far apart (relative to the outer one's length): one panel, few points.
    if let Some(rule) = outer.rule_for(lp, segment_distance(p0, p1, q0, q1)) {
        return cosang * rule.integrate(0.0, lp, f);
    }
    let mut breaks = vec![0.0, lp];
    for q in [q0, q1] {
        breaks.push((q - p0).dot(up));
    }
    // Closest approach of the two lines.
    let w0 = p0 - q0;
    let b = cosang;
    let d = up.dot(w0);
    let e = uq.dot(w0);
    let den = 1.0 - b * b;
    breaks.push((b * e - d) / den);
    let mut bs: Vec<f64> = breaks
        .into_iter()
        .filter(|s| s.is_finite())
        .map(|s| s.clamp(0.0, lp))
        .collect();
    bs.sort_by(f64::total_cmp);
    bs.dedup_by(|x, y| (*x - *y).abs() <= 1e-14 * lp);
    let seg_dist = |s: f64| -> f64 {
        let x = p0 + s * up;
        let t = (x - q0).dot(uq).clamp(0.0, lq);
        (x - (q0 + t * uq)).length()
    };
    let mut total = 0.0;
    for w in bs.windows(2) {
        let (a, bnd) = (w[0], w[1]);
        let len = bnd - a;
        if len <= 0.0 {
            continue;
        }
        // The distance to the other edge is convex along this one and least at a
        // break: on a panel it is least at an end.
        let (da, db) = (seg_dist(a), seg_dist(bnd));
        let (ga, gb) = (da < 0.5 * len, db < 0.5 * len);
        let rule = if ga || gb {
            None
        } else {
            outer.rule_for(len, da.min(db))
        };
        total += match rule {
            Some(rule) => rule.integrate(a, bnd, &f),
            None => outer.graded(a, bnd, ga, gb, &f),
        };
    }
    cosang * total
}

/// `∫∫ ln|p − q| dp·dq` over the segments `p0 → p1` and `q0 → q1` in closed form (the
/// inner integral analytic, the outer one by Gauss rules graded towards the other
/// segment): the edge-pair term of [`area_form_factor`]'s contour form, finite and
/// exact for touching, overlapping and collinear segments (m² ln m).
///
/// # Errors
/// Non-finite end points, or the Gauss–Legendre rules unavailable.
pub fn segment_pair_log_integral(
    p0: DVec3,
    p1: DVec3,
    q0: DVec3,
    q1: DVec3,
) -> Result<f64, GeometryError> {
    if ![p0, p1, q0, q1].iter().all(|v| v.is_finite()) {
        return Err(GeometryError::Degenerate("non-finite segment end point"));
    }
    Ok(edge_pair(Outer::get()?, p0, p1, q0, q1))
}

/// Distance from the point `x` to the segment `ab` (m).
pub fn point_segment_distance(x: DVec3, a: DVec3, b: DVec3) -> f64 {
    let d = b - a;
    let l2 = d.length_squared();
    let t = if l2 > 0.0 {
        ((x - a).dot(d) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (a + t * d - x).length()
}

/// Distance between the segments `a0a1` and `b0b1` (m): the smaller of the four
/// end-point distances and the distance at the lines' closest approach when it falls
/// inside both segments.
pub fn segment_distance(a0: DVec3, a1: DVec3, b0: DVec3, b1: DVec3) -> f64 {
    let (d1, d2, r) = (a1 - a0, b1 - b0, a0 - b0);
    let (a, e, f) = (d1.length_squared(), d2.length_squared(), d2.dot(r));
    let ends = point_segment_distance(a0, b0, b1)
        .min(point_segment_distance(a1, b0, b1))
        .min(point_segment_distance(b0, a0, a1))
        .min(point_segment_distance(b1, a0, a1));
    if a <= 0.0 || e <= 0.0 {
        return ends;
    }
    let (b, c) = (d1.dot(d2), d1.dot(r));
    let den = a * e - b * b;
    if den <= 1e-14 * a * e {
        return ends;
    }
    let s = ((b * f - c * e) / den).clamp(0.0, 1.0);
    let t = ((b * s + f) / e).clamp(0.0, 1.0);
    ends.min((a0 + d1 * s - (b0 + d2 * t)).length())
}

/// `A_i F_ij` between two planar polygons (vertices counter-clockwise about each
/// polygon's front normal), unoccluded, for any relative position: `pi` is first
/// clipped to the front half-space of `pj` and `pj` to that of `pi` (where both
/// cosines are positive), then the contour integral is evaluated on the clipped
/// polygons. Robust when they share edges or vertices; 0 for coplanar or
/// back-to-back polygons.
///
/// # Errors
/// Fewer than 3 vertices or non-finite vertices.
pub fn area_form_factor(pi: &[DVec3], pj: &[DVec3]) -> Result<f64, GeometryError> {
    validate_polygon(pi)?;
    validate_polygon(pj)?;
    let ci = clip_to_halfspace(pi, pj[0], newell(pj));
    let cj = clip_to_halfspace(pj, pi[0], newell(pi));
    if ci.len() < 3 || cj.len() < 3 {
        return Ok(0.0);
    }
    let outer = Outer::get()?;
    // `∮∮ ln r0 dx·dy = 0` on closed contours, so the integral is `r0²` times that of
    // the polygons mapped by `v ↦ (v − c)/r0`: with `r0` the distance between their
    // centroids the logarithms of distant pairs are near zero instead of `ln r0`,
    // which cuts the rounding of the edge pairs' sum (each pair is `O(size² ln r0)`
    // while the sum is `O(size⁴/r0²)`), and the result does not depend on the
    // coordinates' origin and unit.
    let mean = |p: &[DVec3]| p.iter().copied().sum::<DVec3>() / p.len() as f64;
    let (mi, mj) = (mean(&ci), mean(&cj));
    let size = ci
        .iter()
        .chain(&cj)
        .map(|v| (*v - mi).length().max((*v - mj).length()))
        .fold(0.0, f64::max);
    let r0 = (mi - mj).length().max(1e-3 * size);
    if !(r0 > 0.0 && r0.is_finite()) {
        return Ok(0.0);
    }
    let c = 0.5 * (mi + mj);
    let map = |p: &[DVec3]| p.iter().map(|v| (*v - c) / r0).collect::<Vec<_>>();
    let (ci, cj) = (map(&ci), map(&cj));
    let mut sum = 0.0;
    for a in 0..ci.len() {
        let (p0, p1) = (ci[a], ci[(a + 1) % ci.len()]);
        for b in 0..cj.len() {
            let (q0, q1) = (cj[b], cj[(b + 1) % cj.len()]);
            sum += edge_pair(outer, p0, p1, q0, q1);
        }
    }
    Ok(r0 * r0 * sum / (2.0 * PI))
}

/// Form factor `F_ij` from polygon `pi` to polygon `pj` (see [`area_form_factor`]).
///
/// # Errors
/// As [`area_form_factor`], or a zero-area `pi`.
pub fn polygon_to_polygon(pi: &[DVec3], pj: &[DVec3]) -> Result<f64, GeometryError> {
    let a = polygon_area(pi);
    if a <= 0.0 {
        return Err(GeometryError::Degenerate("zero-area source polygon"));
    }
    Ok(area_form_factor(pi, pj)? / a)
}

fn pos(x: f64, what: &'static str) -> Result<f64, GeometryError> {
    if !x.is_finite() {
        Err(GeometryError::NonFinite(what))
    } else if x <= 0.0 {
        Err(GeometryError::Degenerate(what))
    } else {
        Ok(x)
    }
}

/// Directly opposed parallel `a × b` rectangles at distance `c` (catalog C-11).
///
/// # Errors
/// Non-positive or non-finite dimensions.
pub fn parallel_rectangles(a: f64, b: f64, c: f64) -> Result<f64, GeometryError> {
    let x = pos(a, "rectangle side")? / pos(c, "distance")?;
    let y = pos(b, "rectangle side")? / c;
    let (x2, y2) = (x * x, y * y);
    let s = 0.5 * ((1.0 + x2) * (1.0 + y2) / (1.0 + x2 + y2)).ln()
        + x * (1.0 + y2).sqrt() * (x / (1.0 + y2).sqrt()).atan()
        + y * (1.0 + x2).sqrt() * (y / (1.0 + x2).sqrt()).atan()
        - x * x.atan()
        - y * y.atan();
    Ok(2.0 * s / (PI * x * y))
}

/// Perpendicular rectangles with a common edge of length `l`: from the rectangle of width
/// `w` (perpendicular to the edge) to the one of height `h` (catalog C-14).
///
/// # Errors
/// Non-positive or non-finite dimensions.
pub fn perpendicular_rectangles(l: f64, w: f64, h: f64) -> Result<f64, GeometryError> {
    let l = pos(l, "common edge")?;
    let ww = pos(w, "width")? / l;
    let hh = pos(h, "height")? / l;
    let (w2, h2) = (ww * ww, hh * hh);
    let s = (w2 + h2).sqrt();
    let ln_terms = ((1.0 + w2) * (1.0 + h2) / (1.0 + w2 + h2)).ln()
        + w2 * (w2 * (1.0 + w2 + h2) / ((1.0 + w2) * (w2 + h2))).ln()
        + h2 * (h2 * (1.0 + h2 + w2) / ((1.0 + h2) * (h2 + w2))).ln();
    let v =
        ww * (1.0 / ww).atan() + hh * (1.0 / hh).atan() - s * (1.0 / s).atan() + 0.25 * ln_terms;
    Ok(v / (PI * ww))
}

/// Coaxial parallel disks of radii `r1` (source) and `r2` at distance `h` (catalog C-40).
///
/// # Errors
/// Non-positive or non-finite dimensions.
pub fn coaxial_disks(r1: f64, r2: f64, h: f64) -> Result<f64, GeometryError> {
    let h = pos(h, "distance")?;
    let a = pos(r1, "radius")? / h;
    let b = pos(r2, "radius")? / h;
    let x = 1.0 + (1.0 + b * b) / (a * a);
    Ok(0.5 * (x - (x * x - 4.0 * (b / a) * (b / a)).sqrt()))
}

/// Differential element facing a parallel `a × b` rectangle at distance `c`, on the
/// normal through one of its corners (catalog B-3).
///
/// # Errors
/// Non-positive or non-finite dimensions.
pub fn point_to_parallel_rectangle_corner(a: f64, b: f64, c: f64) -> Result<f64, GeometryError> {
    let x = pos(a, "rectangle side")? / pos(c, "distance")?;
    let y = pos(b, "rectangle side")? / c;
    let sx = (1.0 + x * x).sqrt();
    let sy = (1.0 + y * y).sqrt();
    Ok((x / sx * (y / sx).atan() + y / sy * (x / sy).atan()) / (2.0 * PI))
}

/// Differential element facing a parallel disk of radius `r` at distance `h`, offset
/// radially by `a` from the disk's axis (catalog B-13).
///
/// # Errors
/// Non-finite input, non-positive `r`/`h`, or negative `a`.
pub fn point_to_parallel_disk(r: f64, h: f64, a: f64) -> Result<f64, GeometryError> {
    let r = pos(r, "radius")?;
    let h = pos(h, "distance")?;
    if !a.is_finite() {
        return Err(GeometryError::NonFinite("offset"));
    }
    if a < 0.0 {
        return Err(GeometryError::Degenerate("negative offset"));
    }
    let s = a * a + h * h + r * r;
    Ok(0.5 * (1.0 - (a * a + h * h - r * r) / (s * s - 4.0 * a * a * r * r).sqrt()))
}
