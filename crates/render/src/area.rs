//! Uniform-by-area sampling of every `wavelux-geometry` primitive: the source of the
//! path tracer's surface points and of its light samples (next-event estimation).
//!
//! Each primitive is sampled by a *proposal* on a parameter domain whose image has a
//! known constant or bounded area element, followed by rejection (so the accepted
//! points have density exactly `1/area`, whatever the shape):
//!
//! - triangles: the equal-area square → triangle map (no rejection);
//! - parallelograms: the affine map (no rejection);
//! - complex polygons (segments, arcs, holes): uniform in the bounding rectangle of the
//!   region in its plane frame, rejected outside the region (the frame is isometric);
//! - trimmed analytic patches: `wavelux-param`'s *equal-area* map (VirtualMesh §3.1
//!   eq. (1): constant Jacobian, so uniform `(u, v)` is uniform by area), uniform in
//!   the bounding rectangle of the trim region and rejected outside the trim. Patches
//!   whose map is not equal-area have no known Jacobian bound and are rejected with an
//!   error (the scene crate builds every analytic patch on the equal-area map);
//! - bicubic Bézier patches: uniform `(u, v)` accepted with probability
//!   `J(u, v)/J_max`, `J = |∂u P × ∂v P|`, with the rigorous bound
//!   `J_max = 9 · max|P_{i+1,j} − P_{ij}| · max|P_{i,j+1} − P_{ij}|` (the derivative of a
//!   Bézier patch is a Bézier patch whose control points are those differences times
//!   the degree; the convex-hull property bounds it).
//!
//! The normal returned is the primitive's front normal at the sampled point (from the
//! parametrization for curved primitives: per-point shading normals).

use glam::{DVec2, DVec3};
use rand::RngExt;
use rand_pcg::Pcg64;
use wavelux_geometry::Primitive;

use crate::RenderError;

/// Proposals tried before a sampler gives up (an acceptance rate below `1e-6`; the
/// samplers are built so that this cannot happen for valid primitives).
const MAX_TRIES: u32 = 1_000_000;

/// How a primitive is sampled (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
enum Kind {
    /// Triangle or parallelogram: direct map.
    Direct,
    /// Complex polygon: rejection in the region's bounding rectangle `[lo, hi]`.
    Region { lo: DVec2, hi: DVec2 },
    /// Equal-area trimmed patch: rejection against the trim in `[lo, hi] ⊂ [0,1]²`.
    Trimmed { lo: DVec2, hi: DVec2 },
    /// Bézier patch: rejection with probability `J/jmax`.
    Bezier { jmax: f64 },
}

/// A uniform-by-area sampler of one primitive (precomputed bounds).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct AreaSampler {
    kind: Kind,
    /// Area of the proposal's image (m²): the primitive's area times the expected
    /// number of proposals per accepted point.
    proposal_area: f64,
}

/// A sampled point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct AreaSample {
    /// Position.
    pub point: DVec3,
    /// Unit front normal at the point.
    pub normal: DVec3,
    /// Proposals drawn to get it (`>= 1`).
    pub tries: u32,
}

fn scene_err(what: impl Into<String>) -> RenderError {
    RenderError::Scene(what.into())
}

fn lerp2(lo: DVec2, hi: DVec2, u: f64, v: f64) -> DVec2 {
    lo + (hi - lo) * DVec2::new(u, v)
}

impl AreaSampler {
    /// The sampler of a primitive.
    ///
    /// # Errors
    /// [`RenderError::Scene`] for a trimmed patch whose map is not equal-area, or a
    /// primitive with an empty or non-finite parameter domain.
    pub(crate) fn new(p: &Primitive) -> Result<Self, RenderError> {
        let (kind, proposal_area) = match p {
            Primitive::Triangle(_) | Primitive::Parallelogram(_) => (Kind::Direct, p.area()),
            Primitive::Polygon(poly) => {
                let (lo, hi) = poly.region.bounds();
                let d = hi - lo;
                (Kind::Region { lo, hi }, d.x * d.y)
            }
            Primitive::Trimmed(t) => {
                if !t.surface.is_equal_area() {
                    return Err(scene_err(
                        "a trimmed patch on a non-equal-area map cannot be sampled by area \
                         (build it on wavelux-param's equal-area map)",
                    ));
                }
                let (lo, hi) = match &t.trim {
                    Some(r) => {
                        let (lo, hi) = r.bounds();
                        (lo.max(DVec2::ZERO), hi.min(DVec2::ONE))
                    }
                    None => (DVec2::ZERO, DVec2::ONE),
                };
                let d = hi - lo;
                (Kind::Trimmed { lo, hi }, t.surface.area() * d.x * d.y)
            }
            Primitive::Bezier(b) => {
                let (mut du, mut dv) = (0.0f64, 0.0f64);
                for i in 0..4 {
                    for j in 0..4 {
                        if i < 3 {
                            du = du.max((b.p[i + 1][j] - b.p[i][j]).length());
                        }
                        if j < 3 {
                            dv = dv.max((b.p[i][j + 1] - b.p[i][j]).length());
                        }
                    }
                }
                let jmax = 9.0 * du * dv;
                (Kind::Bezier { jmax }, jmax)
            }
        };
        if !(proposal_area.is_finite() && proposal_area > 0.0) {
            return Err(scene_err(format!(
                "primitive with an empty sampling domain (proposal area {proposal_area})"
            )));
        }
        Ok(Self {
            kind,
            proposal_area,
        })
    }

    /// Area of the proposal's image (m²); `proposal_area × accepted / tries` is an
    /// unbiased (hit-or-miss) estimator of the primitive's area.
    #[cfg(test)]
    pub(crate) fn proposal_area(&self) -> f64 {
        self.proposal_area
    }

    /// A point uniformly distributed by area on `p` (the primitive this sampler was
    /// built for), with its front normal.
    ///
    /// # Errors
    /// [`RenderError::Scene`] if no proposal was accepted within a million tries.
    pub(crate) fn sample(&self, p: &Primitive, rng: &mut Pcg64) -> Result<AreaSample, RenderError> {
        for tries in 1..=MAX_TRIES {
            let (u, v): (f64, f64) = (rng.random(), rng.random());
            let hit = match (self.kind, p) {
                (Kind::Direct, Primitive::Triangle(t)) => {
                    let r = u.sqrt();
                    let (b, c) = (r * (1.0 - v), r * v);
                    Some((
                        t.v[0] + b * (t.v[1] - t.v[0]) + c * (t.v[2] - t.v[0]),
                        t.normal(),
                    ))
                }
                (Kind::Direct, Primitive::Parallelogram(q)) => {
                    Some((q.eval(DVec2::new(u, v)), q.normal()))
                }
                (Kind::Region { lo, hi }, Primitive::Polygon(poly)) => {
                    let q = lerp2(lo, hi, u, v);
                    poly.region
                        .contains(q)
                        .then(|| (poly.frame.to_world(q), poly.normal()))
                }
                (Kind::Trimmed { lo, hi }, Primitive::Trimmed(t)) => {
                    let q = lerp2(lo, hi, u, v);
                    t.trim.as_ref().is_none_or(|r| r.contains(q)).then(|| {
                        let sp = t.surface.eval(q);
                        (sp.position, sp.normal)
                    })
                }
                (Kind::Bezier { jmax }, Primitive::Bezier(b)) => {
                    let (x, su, sv) = wavelux_geometry::bezier::eval(&b.p, DVec2::new(u, v));
                    let j = su.cross(sv).length();
                    (rng.random::<f64>() * jmax < j).then(|| (x, b.normal(DVec2::new(u, v))))
                }
                _ => {
                    return Err(scene_err(
                        "area sampler used with a different primitive kind",
                    ));
                }
            };
            if let Some((point, normal)) = hit {
                return Ok(AreaSample {
                    point,
                    normal,
                    tries,
                });
            }
        }
        Err(scene_err(
            "no point accepted in a million proposals (primitive too thin to sample)",
        ))
    }
}

/// A point of a texel grid: position, unit front normal, area weight (m²).
pub(crate) type GridPoint = (DVec3, DVec3, f64);

/// Centres of `n` equal cells of `[0, 1]`.
fn centres(n: usize) -> impl Iterator<Item = f64> + Clone {
    (0..n).map(move |i| (i as f64 + 0.5) / n as f64)
}

/// Cells per axis for a side of `len` metres at `sqrt_density` cells per metre (≥ 1).
fn cells(len: f64, sqrt_density: f64) -> usize {
    ((len * sqrt_density).ceil() as usize).clamp(1, 1 << 14)
}

impl AreaSampler {
    /// A lightmap-like grid over `p` at about `density` points per m²: the centres of
    /// equal-area cells of the primitive's equal-area parametrization (affine for
    /// triangles through the equal-area square map, parallelograms and polygons;
    /// `wavelux-param`'s equal-area map for trimmed patches), keeping the centres on
    /// real points (inside the polygon region or the trim) and giving each the area
    /// `area / kept` so the weights sum to the primitive's area exactly. Bézier patches
    /// (no equal-area map) take the natural `(u, v)` grid with weights proportional to
    /// the area element. A primitive too small for any centre to land on it gets one
    /// point (drawn uniformly by area with a fixed seed) carrying its whole area, so
    /// every real surface point is represented.
    ///
    /// # Errors
    /// [`RenderError::Invalid`] for a density that is not finite and positive; as
    /// [`AreaSampler::sample`] for the fallback point.
    pub(crate) fn grid(&self, p: &Primitive, density: f64) -> Result<Vec<GridPoint>, RenderError> {
        if !(density.is_finite() && density > 0.0) {
            return Err(crate::invalid(
                "texel density",
                format!("{density} is not a positive number of texels per m²"),
            ));
        }
        let sd = density.sqrt();
        let area = p.area();
        let mut pts: Vec<(DVec3, DVec3)> = Vec::new();
        let mut weights: Option<Vec<f64>> = None;
        match (self.kind, p) {
            (Kind::Direct, Primitive::Triangle(t)) => {
                let n = cells(area.sqrt(), sd);
                for u in centres(n) {
                    for v in centres(n) {
                        let r = u.sqrt();
                        let (b, c) = (r * (1.0 - v), r * v);
                        pts.push((
                            t.v[0] + b * (t.v[1] - t.v[0]) + c * (t.v[2] - t.v[0]),
                            t.normal(),
                        ));
                    }
                }
            }
            (Kind::Direct, Primitive::Parallelogram(q)) => {
                let (nu, nv) = (cells(q.e1.length(), sd), cells(q.e2.length(), sd));
                for u in centres(nu) {
                    for v in centres(nv) {
                        pts.push((q.eval(DVec2::new(u, v)), q.normal()));
                    }
                }
            }
            (Kind::Region { lo, hi }, Primitive::Polygon(poly)) => {
                let d = hi - lo;
                for u in centres(cells(d.x, sd)) {
                    for v in centres(cells(d.y, sd)) {
                        let q = lerp2(lo, hi, u, v);
                        if poly.region.contains(q) {
                            pts.push((poly.frame.to_world(q), poly.normal()));
                        }
                    }
                }
            }
            (Kind::Trimmed { lo, hi }, Primitive::Trimmed(t)) => {
                let d = hi - lo;
                // Square cells in the equal-area square, `≈ 1/density` m² each.
                let side = (t.surface.area()).sqrt();
                for u in centres(cells(side * d.x, sd)) {
                    for v in centres(cells(side * d.y, sd)) {
                        let q = lerp2(lo, hi, u, v);
                        if t.trim.as_ref().is_none_or(|r| r.contains(q)) {
                            let sp = t.surface.eval(q);
                            pts.push((sp.position, sp.normal));
                        }
                    }
                }
            }
            (Kind::Bezier { .. }, Primitive::Bezier(b)) => {
                let n = cells(area.sqrt(), sd);
                let mut w = Vec::with_capacity(n * n);
                for u in centres(n) {
                    for v in centres(n) {
                        let uv = DVec2::new(u, v);
                        let (x, su, sv) = wavelux_geometry::bezier::eval(&b.p, uv);
                        pts.push((x, b.normal(uv)));
                        w.push(su.cross(sv).length());
                    }
                }
                let tot: f64 = w.iter().sum();
                if tot > 0.0 {
                    weights = Some(w.iter().map(|j| j * area / tot).collect());
                }
            }
            _ => return Err(scene_err("area grid used with a different primitive kind")),
        }
        if pts.is_empty() {
            let mut rng = crate::sampling::rng_for(0x7e1, 0, 0);
            let s = self.sample(p, &mut rng)?;
            return Ok(vec![(s.point, s.normal, area)]);
        }
        let w = weights.unwrap_or_else(|| vec![area / pts.len() as f64; pts.len()]);
        Ok(pts
            .into_iter()
            .zip(w)
            .map(|((x, n), w)| (x, n, w))
            .collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::rng_for;
    use std::sync::Arc;
    use wavelux_geometry::{
        BezierPatch, ComplexPolygon, Edge2, Parallelogram, PlaneFrame, Triangle, TrimLoop,
        TrimRegion, TrimmedPatch,
    };
    use wavelux_param::{Frame, Sphere};

    /// A teapot-like curved net (non-planar, varying Jacobian).
    fn bezier() -> BezierPatch {
        let mut p = [[DVec3::ZERO; 4]; 4];
        for (i, row) in p.iter_mut().enumerate() {
            for (j, x) in row.iter_mut().enumerate() {
                let (u, v) = (i as f64 / 3.0, j as f64 / 3.0);
                *x = DVec3::new(
                    u * (1.0 + 0.5 * v),
                    v,
                    0.6 * (u - 0.5).powi(2) - 0.4 * v * u,
                );
            }
        }
        BezierPatch::new(p).expect("valid net")
    }

    fn shapes() -> Vec<(&'static str, Primitive)> {
        let frame =
            PlaneFrame::from_axes(DVec3::new(0.0, 0.0, 1.0), DVec3::X, DVec3::Y).expect("frame");
        // A 2 × 1 rectangle with a circular hole of radius 0.3 (clockwise).
        let outer = TrimLoop::rect(DVec2::ZERO, DVec2::new(2.0, 1.0)).expect("rect");
        let hole = TrimLoop::new(vec![
            Edge2::arc(DVec2::new(0.5, 0.5), 0.3, 0.0, -std::f64::consts::TAU).expect("arc"),
        ])
        .expect("loop");
        let poly = ComplexPolygon::new(frame, TrimRegion::new(vec![outer, hole]).expect("region"))
            .expect("poly");
        let sphere = Sphere::new(
            Frame::canonical(),
            0.7,
            (0.0, std::f64::consts::TAU),
            (-1.2, 1.4),
        )
        .expect("sphere")
        .equal_area();
        let trim = TrimRegion::new(vec![
            TrimLoop::new(vec![
                Edge2::arc(DVec2::new(0.5, 0.5), 0.4, 0.0, std::f64::consts::TAU).expect("arc"),
            ])
            .expect("loop"),
        ])
        .expect("trim");
        vec![
            (
                "triangle",
                Primitive::Triangle(
                    Triangle::new(DVec3::ZERO, DVec3::new(1.0, 0.2, 0.0), DVec3::Y).expect("tri"),
                ),
            ),
            (
                "parallelogram",
                Primitive::Parallelogram(
                    Parallelogram::new(DVec3::ZERO, DVec3::X, DVec3::new(0.3, 1.0, 0.2))
                        .expect("par"),
                ),
            ),
            (
                "polygon with an arc hole",
                Primitive::Polygon(Box::new(poly)),
            ),
            (
                "trimmed sphere patch",
                Primitive::Trimmed(Box::new(
                    TrimmedPatch::new(Arc::new(sphere), Some(trim)).expect("patch"),
                )),
            ),
            ("Bezier patch", Primitive::Bezier(Box::new(bezier()))),
        ]
    }

    /// Hit-or-miss area estimate `proposal_area · N / tries` equals the exact area
    /// (the sampler's pdf integrates to one), within 5 standard errors.
    #[test]
    fn area_estimators_match_exact_areas() {
        for (name, p) in shapes() {
            let s = AreaSampler::new(&p).expect("sampler");
            let mut rng = rng_for(3, 1, 4);
            let n = 40_000u64;
            let mut tries = 0u64;
            for _ in 0..n {
                tries += u64::from(s.sample(&p, &mut rng).expect("sample").tries);
            }
            let acc = n as f64 / tries as f64;
            let est = s.proposal_area() * acc;
            // Binomial acceptance: sd of the acceptance rate ≈ sqrt(acc(1−acc)/tries).
            let sd = s.proposal_area() * (acc * (1.0 - acc) / tries as f64).sqrt();
            let exact = p.area();
            assert!(
                (est - exact).abs() <= 5.0 * sd + 1e-12 * exact,
                "{name}: estimate {est} vs exact {exact} (sd {sd})"
            );
        }
    }

    /// The sample mean of `f(x) = x + 2y − z + |x|²` over the sampled points equals the
    /// area average `∫ f dA / A` computed by tensor Gauss–Legendre quadrature over the
    /// primitive's support (an independent estimator: uniformity by area, not just the
    /// normalisation), within 5 standard errors; normals are unit and match the
    /// primitive's normal at the point.
    #[test]
    fn sampled_points_are_uniform_by_area() {
        let f = |x: DVec3| x.x + 2.0 * x.y - x.z + x.length_squared();
        for (name, p) in shapes() {
            // Quadrature of ∫ f dA and ∫ dA over the unit-square support with the area
            // element by central differences (32 × 32 points, 8 panels per axis), with
            // the region/trim as an indicator where the support is larger.
            let inside = |uv: DVec2| match &p {
                Primitive::Polygon(poly) => {
                    let (lo, hi) = poly.region.bounds();
                    poly.region.contains(lo + uv * (hi - lo))
                }
                Primitive::Trimmed(t) => t.keeps(uv, 0.0),
                _ => true,
            };
            let gl = wavelux_quadrature::GaussLegendre::new(8).expect("rule");
            let (x, w) = gl.unit();
            let panels = 16;
            let (mut fa, mut aa) = (0.0, 0.0);
            for pi in 0..panels {
                for pj in 0..panels {
                    for a in 0..x.len() {
                        for b in 0..x.len() {
                            let uv = DVec2::new(
                                (pi as f64 + x[a]) / panels as f64,
                                (pj as f64 + x[b]) / panels as f64,
                            );
                            if !inside(uv) {
                                continue;
                            }
                            let h = 1e-6;
                            let du = (p.eval(uv + DVec2::new(h, 0.0))
                                - p.eval(uv - DVec2::new(h, 0.0)))
                                / (2.0 * h);
                            let dv = (p.eval(uv + DVec2::new(0.0, h))
                                - p.eval(uv - DVec2::new(0.0, h)))
                                / (2.0 * h);
                            let jw = du.cross(dv).length() * w[a] * w[b] / (panels * panels) as f64;
                            fa += f(p.eval(uv)) * jw;
                            aa += jw;
                        }
                    }
                }
            }
            let want = fa / aa;
            let s = AreaSampler::new(&p).expect("sampler");
            let mut rng = rng_for(5, 9, 2);
            let n = 40_000;
            let (mut m, mut m2) = (0.0, 0.0);
            for _ in 0..n {
                let smp = s.sample(&p, &mut rng).expect("sample");
                assert!((smp.normal.length() - 1.0).abs() < 1e-9, "{name}");
                let v = f(smp.point);
                m += v;
                m2 += v * v;
            }
            let mean = m / n as f64;
            let sd = ((m2 / n as f64 - mean * mean).max(0.0) / n as f64).sqrt();
            // The indicator quadrature is only accurate to a few 1e-4 at curved trim
            // boundaries; allow that on top of the statistical error.
            assert!(
                (mean - want).abs() <= 5.0 * sd + 2e-3 * want.abs(),
                "{name}: sample mean {mean} vs quadrature {want} (sd {sd})"
            );
        }
    }

    /// Grid weights sum to the exact area, every point lies on the primitive (its
    /// support map inverts to a real parameter point: checked through the area-weighted
    /// mean of `f`, which must match the quadrature of the uniformity test to the grid's
    /// midpoint-rule accuracy), and the point count follows the density.
    #[test]
    fn grids_cover_each_primitive_at_the_density() {
        for (name, p) in shapes() {
            let s = AreaSampler::new(&p).expect("sampler");
            for density in [1.0, 400.0, 10_000.0] {
                let g = s.grid(&p, density).expect("grid");
                let w: f64 = g.iter().map(|x| x.2).sum();
                assert!((w - p.area()).abs() <= 1e-12 * p.area(), "{name}: {w}");
                assert!(g.iter().all(|x| (x.1.length() - 1.0).abs() < 1e-9));
                let want = p.area() * density;
                let n = g.len() as f64;
                assert!(
                    n >= 1.0 && n <= 2.0 * want + 4.0 * want.sqrt() + 4.0,
                    "{name}: {n} for {want}"
                );
                if want > 1000.0 {
                    assert!(n >= 0.5 * want, "{name}: {n} for {want}");
                }
            }
            // Area-weighted means converge to the uniform-by-area mean of the samples.
            let f = |x: DVec3| x.x + 2.0 * x.y - x.z + x.length_squared();
            let g = s.grid(&p, 40_000.0).expect("grid");
            let mean: f64 = g.iter().map(|x| f(x.0) * x.2).sum::<f64>() / p.area();
            let mut rng = rng_for(11, 2, 3);
            let m = 100_000;
            let mc: f64 = (0..m)
                .map(|_| f(s.sample(&p, &mut rng).expect("sample").point))
                .sum::<f64>()
                / m as f64;
            assert!(
                (mean - mc).abs() < 0.02 * mc.abs().max(1.0),
                "{name}: {mean} vs {mc}"
            );
        }
        let p = &shapes()[0].1;
        assert!(AreaSampler::new(p).expect("s").grid(p, f64::NAN).is_err());
        assert!(AreaSampler::new(p).expect("s").grid(p, 0.0).is_err());
    }

    #[test]
    fn natural_map_patches_are_rejected() {
        let sphere = Sphere::new(
            Frame::canonical(),
            1.0,
            (0.0, std::f64::consts::TAU),
            (-1.0, 1.0),
        )
        .expect("sphere")
        .natural();
        let p = Primitive::Trimmed(Box::new(
            TrimmedPatch::new(Arc::new(sphere), None).expect("patch"),
        ));
        assert!(matches!(AreaSampler::new(&p), Err(RenderError::Scene(_))));
    }
}
