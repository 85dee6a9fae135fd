//! Shared property checks for every parametrization.
#![allow(dead_code)]

use glam::{DVec2, DVec3};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;
use wavelux_param::{Parametrization, SurfacePoint};
use wavelux_quadrature::GaussLegendre;

/// Seeded RNG.
pub fn rng(seed: u64) -> Pcg64 {
    Pcg64::seed_from_u64(seed)
}

/// A uniform point of [lo, hi]².
pub fn sample(rng: &mut Pcg64, lo: f64, hi: f64) -> DVec2 {
    DVec2::new(rng.random_range(lo..hi), rng.random_range(lo..hi))
}

/// Sixth-order central difference of `f` along `dir` at `x` with step `h`.
pub fn fd(f: &dyn Fn(DVec2) -> DVec3, x: DVec2, dir: DVec2, h: f64) -> DVec3 {
    let p = |k: f64| f(x + dir * (k * h));
    ((p(1.0) - p(-1.0)) * 45.0 - (p(2.0) - p(-2.0)) * 9.0 + (p(3.0) - p(-3.0))) / (60.0 * h)
}

/// Options for [`check_map`].
pub struct Check {
    /// Margin from the unit-square edges for samples (seams and poles).
    pub margin: f64,
    /// Length scale of the patch (for absolute point tolerances).
    pub scale: f64,
    /// Tolerance of uv round trips (absolute, in parameter units).
    pub uv_tol: f64,
    /// Relative tolerance of the Jacobian checks.
    pub jac_tol: f64,
    /// Relative (to `scale`) tolerance of point round trips.
    pub point_tol: f64,
    /// Relative tolerance of the finite-difference Jacobian (the difference quotient
    /// itself is ill-conditioned for very thin shapes).
    pub fd_tol: f64,
    /// Finite-difference step as a fraction of the distance to the square's edge.
    pub fd_step: f64,
    /// Number of random samples.
    pub samples: usize,
    /// Implicit function gradient (world point → gradient), if known.
    pub gradient: Option<Box<dyn Fn(DVec3) -> DVec3>>,
    /// Seed.
    pub seed: u64,
}

impl Check {
    pub fn new(scale: f64) -> Self {
        Self {
            margin: 0.02,
            scale,
            uv_tol: 1e-12,
            jac_tol: 1e-9,
            point_tol: 1e-12,
            fd_tol: 1e-9,
            fd_step: 1e-3,
            samples: 200,
            gradient: None,
            seed: 7,
        }
    }
    pub fn gradient(mut self, g: impl Fn(DVec3) -> DVec3 + 'static) -> Self {
        self.gradient = Some(Box::new(g));
        self
    }
    pub fn margin(mut self, m: f64) -> Self {
        self.margin = m;
        self
    }
    pub fn uv_tol(mut self, t: f64) -> Self {
        self.uv_tol = t;
        self
    }
    pub fn fd_step(mut self, h: f64) -> Self {
        self.fd_step = h;
        self
    }
    pub fn samples(mut self, n: usize) -> Self {
        self.samples = n;
        self
    }
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs().max(f64::MIN_POSITIVE)
}

/// Checks one map: Jacobian constancy (analytic, from tangents, finite differences),
/// round trips both ways, unit normals that agree with tangents (and the implicit
/// gradient when given), bounds containing the samples.
pub fn check_map(m: &dyn Parametrization, c: &Check) {
    let mut r = rng(c.seed);
    let area = m.area();
    assert!(area.is_finite() && area > 0.0, "area {area}");
    let bounds = m.bounds();
    let pos = |uv: DVec2| m.position(uv);
    for _ in 0..c.samples {
        let uv = sample(&mut r, c.margin, 1.0 - c.margin);
        let sp: SurfacePoint = m.eval(uv);
        let j = m.jacobian(uv);
        if m.is_equal_area() {
            assert!(
                rel(j, area) <= c.jac_tol,
                "jacobian {j} vs area {area} at {uv}"
            );
        }
        // Tangents vs the analytic Jacobian.
        let tj = sp.tangent_jacobian();
        assert!(
            rel(tj, j) <= c.jac_tol,
            "tangent jacobian {tj} vs {j} at {uv}"
        );
        // Finite differences of the position.
        let d = (uv.x.min(1.0 - uv.x)).min(uv.y.min(1.0 - uv.y)).min(0.1);
        let h = c.fd_step * d;
        let fu = fd(&pos, uv, DVec2::X, h);
        let fv = fd(&pos, uv, DVec2::Y, h);
        let fj = fu.cross(fv).length();
        assert!(
            rel(fj, j) <= c.fd_tol,
            "FD jacobian {fj} vs {j} at {uv} (h {h})"
        );
        assert!(
            (fu - sp.dp_du).length()
                <= c.fd_tol.max(1e-7) * sp.dp_du.length().max(sp.dp_dv.length()),
            "du {fu} vs {} at {uv}",
            sp.dp_du
        );
        assert!(
            (fv - sp.dp_dv).length()
                <= c.fd_tol.max(1e-7) * sp.dp_du.length().max(sp.dp_dv.length()),
            "dv {fv} vs {} at {uv}",
            sp.dp_dv
        );
        // Normal: unit, along du × dv.
        assert!((sp.normal.length() - 1.0).abs() < 1e-12);
        let tn = sp.dp_du.cross(sp.dp_dv).normalize();
        assert!(
            sp.normal.dot(tn) > 1.0 - 1e-9,
            "normal {} vs tangents {tn}",
            sp.normal
        );
        if let Some(g) = &c.gradient {
            let gn = g(sp.position).normalize();
            assert!(
                sp.normal.dot(gn).abs() > 1.0 - 1e-9,
                "normal {} vs gradient {gn} at {uv}",
                sp.normal
            );
        }
        // Round trips.
        let back = m
            .inverse(sp.position)
            .expect("inverse defined on the patch");
        assert!(
            (back - uv).abs().max_element() <= c.uv_tol,
            "inverse(map({uv})) = {back}, err {:e}",
            (back - uv).abs().max_element()
        );
        let again = m.position(back);
        assert!(
            (again - sp.position).length() <= c.point_tol * c.scale,
            "map(inverse(p)) off by {:e} (scale {})",
            (again - sp.position).length(),
            c.scale
        );
        assert!(
            bounds.contains(sp.position, 1e-9 * c.scale),
            "bounds {bounds:?} miss {}",
            sp.position
        );
    }
}

/// Surface area of the image of the rectangle `[a, b]` in the map's unit square, by a
/// 24×24 Gauss rule on the tangent Jacobian.
pub fn rect_area_from_tangents(m: &dyn Parametrization, a: DVec2, b: DVec2) -> f64 {
    let gl = GaussLegendre::new(24).unwrap();
    let (xu, wu) = gl.on_interval(a.x, b.x).unwrap();
    let (xv, wv) = gl.on_interval(a.y, b.y).unwrap();
    let mut s = 0.0;
    for i in 0..xu.len() {
        for k in 0..xv.len() {
            s += wu[i] * wv[k] * m.eval(DVec2::new(xu[i], xv[k])).tangent_jacobian();
        }
    }
    s
}

/// Adaptive Gauss–Legendre (8 vs 16 points, bisection) of `f` on `[a, b]`.
pub fn adaptive(f: &dyn Fn(f64) -> f64, a: f64, b: f64, tol: f64, depth: u32) -> f64 {
    let g8 = GaussLegendre::new(8).unwrap();
    let g16 = GaussLegendre::new(16).unwrap();
    let q8 = g8.integrate(a, b, f);
    let q16 = g16.integrate(a, b, f);
    if (q8 - q16).abs() <= tol * q16.abs() || depth == 0 {
        q16
    } else {
        let m = 0.5 * (a + b);
        adaptive(f, a, m, tol, depth - 1) + adaptive(f, m, b, tol, depth - 1)
    }
}

/// Surface area of the image of the rectangle `[a, b]` of the natural map `nat`, by
/// adaptive Gauss rules on its Jacobian (24 points across u, adaptive along v).
pub fn rect_area_natural(nat: &dyn Parametrization, a: DVec2, b: DVec2) -> f64 {
    let gl = GaussLegendre::new(24).unwrap();
    let (xu, wu) = gl.on_interval(a.x, b.x).unwrap();
    let row = |v: f64| -> f64 {
        xu.iter()
            .zip(&wu)
            .map(|(&u, &w)| w * nat.jacobian(DVec2::new(u, v)))
            .sum()
    };
    adaptive(&row, a.y, b.y, 1e-14, 30)
}

/// For separable maps: random parameter rectangles of the equal-area map `ea` keep their
/// area ratio on the surface, the surface area being measured independently through
/// the natural map `nat` (rectangle corners pulled back with `nat.inverse`).
pub fn check_area_ratio(ea: &dyn Parametrization, nat: &dyn Parametrization, seed: u64, tol: f64) {
    let mut r = rng(seed);
    let total = ea.area();
    assert!(
        rel(nat.area(), total) <= tol,
        "areas {} vs {}",
        nat.area(),
        total
    );
    for _ in 0..20 {
        let p = sample(&mut r, 0.02, 0.98);
        let q = sample(&mut r, 0.02, 0.98);
        let (a, b) = (p.min(q), p.max(q));
        let na = nat.inverse(ea.position(a)).unwrap();
        let nb = nat.inverse(ea.position(b)).unwrap();
        let measured = rect_area_natural(nat, na.min(nb), na.max(nb));
        let expected = (b.x - a.x) * (b.y - a.y) * total;
        assert!(
            rel(measured, expected) <= tol,
            "rect {a}..{b}: surface area {measured} vs ratio·area {expected}"
        );
    }
}
