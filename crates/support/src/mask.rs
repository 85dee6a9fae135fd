//! Trim masks of virtual supports (VirtualMesh §4, §5.4): which points of a unit-square
//! support are *real* (have a pre-image on the input surface) and which are *virtual*.
//!
//! A [`Mask`] holds the real region as a `wavelux-geometry` [`TrimRegion`] (loops of
//! segments and circular arcs) in a *mask plane* — the polygon's 2D frame for a planar
//! polygon, the equal-area unit square of the surface for a trimmed curved patch —
//! and the affine map `Λ(s,t) = o + s·e₁ + t·e₂` from the support's unit square onto
//! the enclosing parallelogram in that plane (VirtualMesh §3.2, §3.3).
//!
//! Queries on a cell `[s0, s0+h] × [t0, t0+h]` of the support work on its image
//! `Λ(cell)`, a convex parallelogram `W` of the mask plane:
//!
//! - the real area `|R ∩ W|` is computed *exactly* (to rounding) for segment and arc
//!   boundaries by Green's theorem: `|R ∩ W| = ∮_{∂R ∩ W} ½(x dy − y dx) +
//!   Σ_{pieces of ∂W} wind_R(piece) ∮_piece ½(x dy − y dx)`, where the boundary of `R`
//!   is clipped to `W` (segments by Cyrus–Beck, arcs at their crossings with the four
//!   lines of `W`) and the edges of `W` are split where `∂R` crosses them; the winding
//!   number of each piece of `∂W` is read (in `O(log n)`) just inside `W`. Pieces of
//!   `∂R` that run along `∂W` (within `1e-12` of the cell size) are left to the winding
//!   term, so cells flush with a straight trim edge are exact too. Coordinates are
//!   taken relative to a corner of `W`, so deep cells keep full relative precision;
//! - the coverage class is `Partial` as soon as a piece of `∂R` lies strictly inside
//!   `W` (more than `1e-12` of the cell size from its border); otherwise the cell is
//!   `Full` or `Empty` by its real area. Conservative up to that relative `1e-12`
//!   sliver: a cell is never called `Empty` or `Full` while a boundary piece crosses
//!   its interior;
//! - the nearest real point is found in the mask plane (nearest point of `∂R`, then a
//!   step of `1e-9 · size` into `R`) — Euclidean in the polygon plane for planar
//!   polygons, in the equal-area parameter plane for curved patches (VirtualMesh §4.1
//!   asks for the nearest point of the surface; the parameter-plane distance is the
//!   documented approximation, exact for planar supports).

use glam::DVec2;
use wavelux_geometry::{Edge2, TrimRegion};

use crate::error::SupportError;

/// Classification of a support cell against the trim boundary (VirtualMesh §5.4:
/// empty, mixed and plain meshes).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Coverage {
    /// No real point (up to a sliver of relative width `1e-12` along the border).
    Empty,
    /// Real and virtual points (the trim boundary crosses the cell's interior).
    Partial,
    /// Every point is real (up to a sliver of relative width `1e-12` along the border).
    Full,
}

/// The real region of a virtual support and the affine map `Λ` from the support's unit
/// square to the mask plane (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct Mask {
    region: TrimRegion,
    origin: DVec2,
    e1: DVec2,
    e2: DVec2,
    /// `det [e1 e2]` (signed parameter-to-plane area factor).
    det: f64,
    /// Diameter of `Λ([0,1]²)`.
    size: f64,
    /// Real fraction of the whole support.
    total: f64,
}

/// Result of clipping the real region to a cell window.
struct Clip {
    area: f64,
    crossing: bool,
}

#[inline]
fn cross(a: DVec2, b: DVec2) -> f64 {
    a.perp_dot(b)
}

impl Mask {
    /// A mask of `region` seen through `Λ(s,t) = origin + s·e1 + t·e2`.
    ///
    /// # Errors
    /// [`SupportError::InvalidScene`] if `Λ` is degenerate or not finite.
    pub fn new(
        region: TrimRegion,
        origin: DVec2,
        e1: DVec2,
        e2: DVec2,
    ) -> Result<Self, SupportError> {
        let det = cross(e1, e2);
        if !(origin.is_finite() && e1.is_finite() && e2.is_finite())
            || det.abs() <= 1e-300
            || !det.is_finite()
        {
            return Err(SupportError::InvalidScene(
                "degenerate enclosing parallelogram of a trimmed support".into(),
            ));
        }
        let size = (e1 + e2).length().max((e1 - e2).length());
        let mut m = Self {
            region,
            origin,
            e1,
            e2,
            det,
            size,
            total: 0.0,
        };
        m.total = m.real_fraction(0.0, 0.0, 1.0);
        Ok(m)
    }

    /// The real region in the mask plane.
    pub fn region(&self) -> &TrimRegion {
        &self.region
    }

    /// `Λ`: `(origin, e1, e2)`.
    pub fn lambda(&self) -> (DVec2, DVec2, DVec2) {
        (self.origin, self.e1, self.e2)
    }

    /// `Λ(s, t)`.
    #[inline]
    pub fn to_plane(&self, s: f64, t: f64) -> DVec2 {
        self.origin + s * self.e1 + t * self.e2
    }

    /// `Λ⁻¹(p)`.
    #[inline]
    pub fn from_plane(&self, p: DVec2) -> (f64, f64) {
        let d = p - self.origin;
        (cross(d, self.e2) / self.det, cross(self.e1, d) / self.det)
    }

    /// Real fraction of the whole support (`real area / area` for equal-area maps).
    pub fn total_fraction(&self) -> f64 {
        self.total
    }

    /// Whether `(s, t)` is real (non-zero winding of the trim loops at `Λ(s,t)`;
    /// points exactly on the boundary may go either way).
    pub fn is_real(&self, s: f64, t: f64) -> bool {
        self.region.contains(self.to_plane(s, t))
    }

    /// The window `Λ([s0,s0+hs]×[t0,t0+ht])`, counter-clockwise.
    fn window(&self, s0: f64, t0: f64, hs: f64, ht: f64) -> [DVec2; 4] {
        let w = [
            self.to_plane(s0, t0),
            self.to_plane(s0 + hs, t0),
            self.to_plane(s0 + hs, t0 + ht),
            self.to_plane(s0, t0 + ht),
        ];
        if self.det > 0.0 {
            w
        } else {
            [w[0], w[3], w[2], w[1]]
        }
    }

    /// Exact real-area fraction of the cell `[s0,s0+h]×[t0,t0+h]` (to rounding, in
    /// `[0, 1]`).
    pub fn real_fraction(&self, s0: f64, t0: f64, h: f64) -> f64 {
        self.real_fraction_rect(s0, t0, h, h)
    }

    /// [`Mask::real_fraction`] of the rectangle `[s0,s0+hs]×[t0,t0+ht]`.
    pub fn real_fraction_rect(&self, s0: f64, t0: f64, hs: f64, ht: f64) -> f64 {
        if hs <= 0.0 || ht <= 0.0 {
            return if self.is_real(s0, t0) { 1.0 } else { 0.0 };
        }
        let c = self.clip(&self.window(s0, t0, hs, ht));
        let wa = self.det.abs() * hs * ht;
        (c.area / wa).clamp(0.0, 1.0)
    }

    /// Coverage class of the cell (see the module docs).
    pub fn coverage(&self, s0: f64, t0: f64, h: f64) -> Coverage {
        if h <= 0.0 {
            return if self.is_real(s0, t0) {
                Coverage::Full
            } else {
                Coverage::Empty
            };
        }
        let c = self.clip(&self.window(s0, t0, h, h));
        let f = c.area / (self.det.abs() * h * h);
        if c.crossing || (1e-9..=1.0 - 1e-9).contains(&f) {
            Coverage::Partial
        } else if f > 0.5 {
            Coverage::Full
        } else {
            Coverage::Empty
        }
    }

    fn clip(&self, w: &[DVec2; 4]) -> Clip {
        let o = w[0];
        let diam = (w[2] - w[0]).length().max((w[3] - w[1]).length());
        let tol = 1e-12 * diam;
        // Window edge directions and inward unit normals.
        let dirs: [DVec2; 4] = std::array::from_fn(|k| w[(k + 1) % 4] - w[k]);
        let nrm: [DVec2; 4] = std::array::from_fn(|k| dirs[k].perp().normalize_or_zero());
        let inside_dist = |p: DVec2| -> f64 {
            (0..4)
                .map(|k| nrm[k].dot(p - w[k]))
                .fold(f64::INFINITY, f64::min)
        };
        let (rlo, rhi) = self.region.bounds();
        let wlo = w.iter().fold(DVec2::splat(f64::INFINITY), |a, b| a.min(*b));
        let whi = w
            .iter()
            .fold(DVec2::splat(f64::NEG_INFINITY), |a, b| a.max(*b));
        if rlo.x > whi.x || rlo.y > whi.y || rhi.x < wlo.x || rhi.y < wlo.y {
            return Clip {
                area: 0.0,
                crossing: false,
            };
        }
        let mut area = 0.0;
        let mut crossing = false;
        // Split parameters along each window edge.
        let mut splits: [Vec<f64>; 4] = std::array::from_fn(|_| vec![0.0, 1.0]);
        let edge_u = |k: usize, p: DVec2| -> Option<f64> {
            let d = dirs[k];
            let l2 = d.length_squared();
            if l2 <= 0.0 {
                return None;
            }
            let u = (p - w[k]).dot(d) / l2;
            let dist = nrm[k].dot(p - w[k]).abs();
            (dist <= 4.0 * tol.max(1e-15 * diam) && u > 0.0 && u < 1.0).then_some(u)
        };
        for l in &self.region.loops {
            for e in &l.edges {
                match *e {
                    Edge2::Segment { a, b } => {
                        let d = b - a;
                        let (mut t0, mut t1) = (0.0f64, 1.0f64);
                        let mut keep = true;
                        for k in 0..4 {
                            let num = nrm[k].dot(a - w[k]);
                            let den = nrm[k].dot(d);
                            if den == 0.0 {
                                if num < 0.0 {
                                    keep = false;
                                    break;
                                }
                            } else {
                                let t = -num / den;
                                if den > 0.0 {
                                    t0 = t0.max(t);
                                } else {
                                    t1 = t1.min(t);
                                }
                            }
                            // Crossing with window edge k's segment.
                            let dk = dirs[k];
                            let den2 = cross(d, dk);
                            if den2 != 0.0 {
                                let ta = cross(w[k] - a, dk) / den2;
                                let uk = cross(w[k] - a, d) / den2;
                                if (0.0..=1.0).contains(&ta) && uk > 0.0 && uk < 1.0 {
                                    splits[k].push(uk);
                                }
                            }
                        }
                        for p in [a, b] {
                            for (k, sp) in splits.iter_mut().enumerate() {
                                if let Some(u) = edge_u(k, p) {
                                    sp.push(u);
                                }
                            }
                        }
                        if keep && t0 < t1 {
                            let p0 = a + t0 * d;
                            let p1 = a + t1 * d;
                            let m = 0.5 * (p0 + p1);
                            if inside_dist(m) > tol {
                                area += 0.5 * cross(p0 - o, p1 - o);
                                crossing = true;
                            }
                        }
                    }
                    Edge2::Arc {
                        center,
                        radius,
                        start,
                        sweep,
                    } => {
                        let mut cuts = vec![0.0, 1.0];
                        let sigma = |th: f64| -> Option<f64> {
                            let dth = if sweep > 0.0 {
                                (th - start).rem_euclid(std::f64::consts::TAU)
                            } else {
                                (start - th).rem_euclid(std::f64::consts::TAU)
                            };
                            let s = dth / sweep.abs();
                            (s > 0.0 && s < 1.0).then_some(s)
                        };
                        for k in 0..4 {
                            let n = nrm[k];
                            if n == DVec2::ZERO {
                                continue;
                            }
                            let kappa = -n.dot(center - w[k]) / radius;
                            if kappa.abs() > 1.0 {
                                continue;
                            }
                            let phi = n.y.atan2(n.x);
                            let acs = kappa.acos();
                            for th in [phi + acs, phi - acs] {
                                let p = center + radius * DVec2::new(th.cos(), th.sin());
                                if let Some(s) = sigma(th) {
                                    cuts.push(s);
                                    let l2 = dirs[k].length_squared();
                                    if l2 > 0.0 {
                                        let u = (p - w[k]).dot(dirs[k]) / l2;
                                        if u > 0.0 && u < 1.0 {
                                            splits[k].push(u);
                                        }
                                    }
                                }
                            }
                        }
                        for p in [e.start(), e.end()] {
                            for (k, sp) in splits.iter_mut().enumerate() {
                                if let Some(u) = edge_u(k, p) {
                                    sp.push(u);
                                }
                            }
                        }
                        cuts.sort_by(f64::total_cmp);
                        let c = center - o;
                        for win in cuts.windows(2) {
                            let (sa, sb) = (win[0], win[1]);
                            if sb <= sa {
                                continue;
                            }
                            let mid = e.point(0.5 * (sa + sb));
                            if inside_dist(mid) < 0.0 {
                                continue;
                            }
                            let (ta, tb) = (start + sa * sweep, start + sb * sweep);
                            let pa = e.point(sa) - o;
                            let pb = e.point(sb) - o;
                            area += 0.5 * (radius * radius * (tb - ta) + cross(c, pb - pa));
                            crossing = true;
                        }
                    }
                }
            }
        }
        // Window edges, weighted by the winding number just inside the window.
        let delta = 1e-10 * diam;
        for k in 0..4 {
            let sp = &mut splits[k];
            sp.sort_by(f64::total_cmp);
            for win in sp.windows(2) {
                let (ua, ub) = (win[0], win[1]);
                if ub <= ua {
                    continue;
                }
                let pa = w[k] + ua * dirs[k];
                let pb = w[k] + ub * dirs[k];
                let probe = 0.5 * (pa + pb) + delta * nrm[k];
                let wind = self.region.winding(probe);
                if wind != 0 {
                    area += f64::from(wind) * 0.5 * cross(pa - o, pb - o);
                }
            }
        }
        Clip { area, crossing }
    }

    /// The nearest real point to `(s, t)` (itself when real), found in the mask plane
    /// (see the module docs), as support parameters.
    pub fn nearest_real(&self, s: f64, t: f64) -> (f64, f64) {
        let p = self.to_plane(s, t);
        if self.region.contains(p) {
            return (s, t);
        }
        let mut best: Option<(f64, DVec2, DVec2)> = None;
        for l in &self.region.loops {
            for e in &l.edges {
                let (q, inward) = closest_on_edge(e, p);
                let d = (q - p).length_squared();
                if best.is_none_or(|b| d < b.0) {
                    best = Some((d, q, inward));
                }
            }
        }
        let Some((_, q, inward)) = best else {
            return (s, t);
        };
        // Step into the region: along p → q, along the edge's inner normal, then (sharp
        // corners) around a circle of growing radius, keeping the candidate nearest p.
        let toward = (q - p).normalize_or_zero();
        let eps = 1e-9 * self.size;
        let mut k = 1.0;
        for _ in 0..14 {
            let r = eps * k;
            for dir in [toward, inward] {
                if dir != DVec2::ZERO && self.region.contains(q + r * dir) {
                    return self.from_plane(q + r * dir);
                }
            }
            let mut found: Option<(f64, DVec2)> = None;
            for j in 0..32 {
                let c = q + r * DVec2::from_angle(std::f64::consts::TAU * j as f64 / 32.0);
                let d = (c - p).length_squared();
                if self.region.contains(c) && found.is_none_or(|f| d < f.0) {
                    found = Some((d, c));
                }
            }
            if let Some((_, c)) = found {
                return self.from_plane(c);
            }
            k *= 4.0;
        }
        self.from_plane(q)
    }
}

/// Closest point of an edge to `p` and the edge's left normal there (the inside of a
/// counter-clockwise outer loop or of a clockwise hole).
fn closest_on_edge(e: &Edge2, p: DVec2) -> (DVec2, DVec2) {
    match *e {
        Edge2::Segment { a, b } => {
            let d = b - a;
            let l2 = d.length_squared();
            let t = if l2 > 0.0 {
                ((p - a).dot(d) / l2).clamp(0.0, 1.0)
            } else {
                0.0
            };
            (a + t * d, d.perp().normalize_or_zero())
        }
        Edge2::Arc {
            center,
            radius,
            start,
            sweep,
        } => {
            let rel = p - center;
            let th = rel.y.atan2(rel.x);
            let dth = if sweep > 0.0 {
                (th - start).rem_euclid(std::f64::consts::TAU)
            } else {
                (start - th).rem_euclid(std::f64::consts::TAU)
            };
            let s = dth / sweep.abs();
            let s = if rel.length_squared() > 0.0 && s <= 1.0 {
                s
            } else {
                // Nearer end point.
                let (a, b) = (e.start(), e.end());
                if (a - p).length_squared() <= (b - p).length_squared() {
                    0.0
                } else {
                    1.0
                }
            };
            let q = e.point(s);
            let radial = (q - center) / radius;
            // Left of the direction of travel: inward for ccw travel.
            let inward = if sweep > 0.0 { -radial } else { radial };
            (q, inward)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use wavelux_geometry::TrimLoop;
    use wavelux_quadrature::masked::Polygon;

    /// A star-shaped polygon with `k` vertices around `c` (radii in `rs`), and a
    /// clockwise hole (a smaller copy) when `hole`.
    fn star(c: DVec2, rs: &[f64], phase: f64) -> Vec<DVec2> {
        let k = rs.len();
        (0..k)
            .map(|i| {
                c + rs[i] * DVec2::from_angle(phase + std::f64::consts::TAU * i as f64 / k as f64)
            })
            .collect()
    }

    fn mask_of(loops: Vec<TrimLoop>, o: DVec2, e1: DVec2, e2: DVec2) -> Mask {
        Mask::new(TrimRegion::new(loops).unwrap(), o, e1, e2).unwrap()
    }

    /// Midpoint-grid estimate of the real fraction of a cell (`m × m` samples) and
    /// whether samples were real / virtual.
    fn grid_estimate(m: &Mask, s0: f64, t0: f64, h: f64, k: usize) -> (f64, bool, bool) {
        let (mut inn, mut any_in, mut any_out) = (0usize, false, false);
        for j in 0..k {
            for i in 0..k {
                let s = s0 + h * (i as f64 + 0.5) / k as f64;
                let t = t0 + h * (j as f64 + 0.5) / k as f64;
                if m.is_real(s, t) {
                    inn += 1;
                    any_in = true;
                } else {
                    any_out = true;
                }
            }
        }
        (inn as f64 / (k * k) as f64, any_in, any_out)
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(48))]

        /// Straight trims in an axis-aligned frame: exact against the independent
        /// Sutherland–Hodgman clipping of `wavelux-quadrature`.
        #[test]
        fn polygon_fraction_matches_independent_clipping(
            rs in proptest::collection::vec(0.2f64..1.0, 3..9),
            phase in 0.0f64..6.0,
            hole in proptest::bool::ANY,
            sx in 2.1f64..3.0, sy in 2.1f64..3.0,
            level in 0u32..5, ix in 0u32..16, iy in 0u32..16,
        ) {
            let outer = star(DVec2::ZERO, &rs, phase);
            let mut loops = vec![TrimLoop::polygon(&outer).unwrap()];
            let mut q = vec![outer.iter().map(|p| [p.x, p.y]).collect::<Vec<_>>()];
            if hole {
                // Inside the outer loop for every draw: a star with k vertices at radii
                // ≥ 0.2 keeps every edge at least 0.2·min(sin 2π/k, cos π/k) ≥ 0.1 from
                // the origin (k = 3 is the worst case), and this hole reaches 0.06 +
                // |(0.02, −0.01)| ≈ 0.082 from it. (A radius of 0.1, 0.122, poked out of
                // the equilateral rs = [0.2; 3] star: such a region is no valid trim and
                // the two areas disagree, found by a PROPTEST_RNG_SEED sweep, seed 211.)
                let h: Vec<DVec2> = star(DVec2::new(0.02, -0.01), &[0.06; 5], 0.4)
                    .into_iter().rev().collect();
                loops.push(TrimLoop::polygon(&h).unwrap());
                q.push(h.iter().map(|p| [p.x, p.y]).collect());
            }
            let o = DVec2::new(-0.5 * sx, -0.5 * sy);
            let m = mask_of(loops, o, DVec2::new(sx, 0.0), DVec2::new(0.0, sy));
            let poly = Polygon::new(q).unwrap();
            let n = 1u32 << level;
            let h = 1.0 / n as f64;
            let (s0, t0) = ((ix % n) as f64 * h, (iy % n) as f64 * h);
            let lo = m.to_plane(s0, t0);
            let hi = m.to_plane(s0 + h, t0 + h);
            let want = poly.area_in_box([lo.x, lo.y], [hi.x, hi.y]) / ((hi.x - lo.x) * (hi.y - lo.y));
            let got = m.real_fraction(s0, t0, h);
            prop_assert!((got - want).abs() < 1e-11, "{got} vs {want}");
            // Total real area.
            prop_assert!((m.total_fraction() * sx * sy - poly.area()).abs() < 1e-11);
        }

        /// Arcs, oblique Λ: the exact fraction against a 96×96 midpoint grid, and the
        /// coverage class consistent with the samples.
        #[test]
        fn arc_fraction_and_coverage_match_sampling(
            cx in -0.3f64..0.3, cy in -0.3f64..0.3, r in 0.2f64..0.9,
            hr in 0.05f64..0.15,
            shear in -0.5f64..0.5, ang in 0.0f64..6.0,
            level in 0u32..5, ix in 0u32..16, iy in 0u32..16,
        ) {
            let c = DVec2::new(cx, cy);
            let loops = vec![
                TrimLoop::circle(c, r).unwrap(),
                TrimLoop::circle(c + DVec2::new(0.5 * r, 0.0), hr.min(0.4 * r)).unwrap().reversed(),
            ];
            let e1 = DVec2::from_angle(ang) * 6.0;
            let e2 = DVec2::from_angle(ang + 1.3 + shear) * 5.5;
            let o = -0.5 * (e1 + e2);
            let m = mask_of(loops, o, e1, e2);
            let n = 1u32 << level;
            let h = 1.0 / n as f64;
            let (s0, t0) = ((ix % n) as f64 * h, (iy % n) as f64 * h);
            let got = m.real_fraction(s0, t0, h);
            let (est, any_in, any_out) = grid_estimate(&m, s0, t0, h, 96);
            // Boundary length inside the cell over the grid spacing bounds the error.
            prop_assert!((got - est).abs() < 0.03, "{got} vs grid {est}");
            match m.coverage(s0, t0, h) {
                Coverage::Empty => prop_assert!(!any_in && got < 1e-12, "empty: {} {}", any_in, got),
                Coverage::Full => prop_assert!(!any_out && got > 1.0 - 1e-12, "full: {} {}", any_out, got),
                Coverage::Partial => {}
            }
            if any_in && any_out {
                prop_assert_eq!(m.coverage(s0, t0, h), Coverage::Partial);
            }
            // The hole is exact: total = π(r² − hr'²).
            let hr2 = hr.min(0.4 * r);
            let want = std::f64::consts::PI * (r * r - hr2 * hr2) / e1.perp_dot(e2).abs();
            prop_assert!((m.total_fraction() - want).abs() < 1e-12);
        }

        /// `nearest_real` is real and no farther (in the mask plane) than any real
        /// sample of a grid.
        #[test]
        fn nearest_real_is_real_and_nearest(
            s in 0.0f64..1.0, t in 0.0f64..1.0,
            rs in proptest::collection::vec(0.3f64..1.0, 3..7),
        ) {
            let outer = star(DVec2::ZERO, &rs, 0.1);
            let loops = vec![
                TrimLoop::polygon(&outer).unwrap(),
                TrimLoop::circle(DVec2::new(0.05, 0.0), 0.12).unwrap().reversed(),
            ];
            let m = mask_of(loops, DVec2::splat(-1.0), DVec2::new(2.0, 0.3), DVec2::new(-0.2, 2.0));
            let (a, b) = m.nearest_real(s, t);
            prop_assert!(m.is_real(a, b));
            let p = m.to_plane(s, t);
            let d = (m.to_plane(a, b) - p).length();
            for j in 0..40 {
                for i in 0..40 {
                    let (u, v) = ((i as f64 + 0.5) / 40.0, (j as f64 + 0.5) / 40.0);
                    if m.is_real(u, v) {
                        prop_assert!(d <= (m.to_plane(u, v) - p).length() + 1e-7);
                    }
                }
            }
            if m.is_real(s, t) {
                prop_assert_eq!((a, b), (s, t));
            }
        }
    }

    /// Cells flush with straight trim edges, a hole touching the enclosing
    /// parallelogram, and a trim of 1e-6 of the square.
    #[test]
    fn extreme_trims() {
        // Square with a hole touching its right edge: the support is the square.
        let sq = TrimLoop::rect(DVec2::ZERO, DVec2::ONE).unwrap();
        let hole = TrimLoop::polygon(&[
            DVec2::new(0.5, 0.25),
            DVec2::new(1.0, 0.25),
            DVec2::new(1.0, 0.75),
            DVec2::new(0.5, 0.75),
        ])
        .unwrap()
        .reversed();
        let m = mask_of(vec![sq, hole], DVec2::ZERO, DVec2::X, DVec2::Y);
        assert!((m.total_fraction() - 0.75).abs() < 1e-15);
        assert_eq!(m.coverage(0.0, 0.0, 0.5), Coverage::Full);
        assert_eq!(m.coverage(0.5, 0.25, 0.25), Coverage::Empty);
        assert_eq!(m.real_fraction(0.5, 0.25, 0.25), 0.0);
        assert_eq!(m.real_fraction(0.0, 0.0, 0.25), 1.0);
        assert_eq!(m.coverage(0.5, 0.0, 0.5), Coverage::Partial);
        assert!((m.real_fraction(0.5, 0.0, 0.5) - 0.5).abs() < 1e-15);
        // Tiny disk: 1e-6 of the square.
        let r = (1e-6 / std::f64::consts::PI).sqrt();
        let m = mask_of(
            vec![TrimLoop::circle(DVec2::new(0.3, 0.7), r).unwrap()],
            DVec2::ZERO,
            DVec2::X,
            DVec2::Y,
        );
        assert!((m.total_fraction() - 1e-6).abs() < 1e-18);
        assert_eq!(m.coverage(0.0, 0.5, 0.5), Coverage::Partial);
        assert_eq!(m.coverage(0.5, 0.5, 0.5), Coverage::Empty);
        let mut sum = 0.0;
        for j in 0..64 {
            for i in 0..64 {
                sum += m.real_fraction(i as f64 / 64.0, j as f64 / 64.0, 1.0 / 64.0) / 4096.0;
            }
        }
        assert!((sum - 1e-6).abs() < 1e-17, "{sum}");
        // A sliver triangle (height 1e-7) in an oblique frame.
        let sl = TrimLoop::polygon(&[
            DVec2::new(-1.0, 0.0),
            DVec2::new(1.0, 0.0),
            DVec2::new(0.2, 1e-7),
        ])
        .unwrap();
        let m = mask_of(
            vec![sl],
            DVec2::new(-1.0, 0.0),
            DVec2::new(2.0, 0.0),
            DVec2::new(0.0, 1e-7),
        );
        assert!((m.total_fraction() - 0.5).abs() < 1e-12);
        let (a, b) = m.nearest_real(0.9, 0.9);
        assert!(m.is_real(a, b));
    }
}
