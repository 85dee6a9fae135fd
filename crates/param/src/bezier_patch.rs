//! Bicubic Bézier patches with a numerical equal-area map (beyond VirtualMesh's future
//! work, built on §3.1.2 with both parameters reparametrized).
//!
//! With `J(s, t) = |P_s × P_t|`, the marginal `m(s) = ∫₀¹ J(s, τ) dτ` and the
//! conditional cumulative `K(s, t) = ∫₀ᵗ J(s, τ) dτ`, the map
//! `u = M(s)/M(1)` (M the cumulative of m), `v = K(s, t)/m(s)` has the triangular
//! Jacobian `(M(1)/m(s))·(m(s)/J)` in (s, t), so the area element on the surface is
//! the constant `M(1)` = patch area. Both integrals use composite Gauss–Legendre rules
//! (4 panels × 10 points in t, 16 panels × 10 points in s) and are inverted by
//! bracketed Newton; the point inverse is damped Gauss–Newton on the Bézier patch.
//! The marginal is tabulated once per patch: `m` at the 160 Gauss nodes in s, kept as
//! the degree-9 interpolant per panel (whose panel integrals are the composite rule's),
//! so `M` and its inverse cost no `J` evaluation; the area element of the map is then
//! `M(1)·m/m̃` (`m̃` the interpolant), constant to the interpolation error (≪ 1e-12
//! relative on smooth patches). The conditional `K(s, ·)` is built once per evaluation
//! (40 `J` values) and shared by the inverse in t and the tangents: an evaluation
//! costs about a hundred `J` evaluations (a few µs).

use crate::error::{ParamError, finite3};
use crate::frame::{Aabb, SurfacePoint};
use crate::numeric::{SmoothCumulative, closest_point, panel, solve_increasing};
use crate::surface::{ParamKind, Parametrization, SurfaceShape};
use glam::{DVec2, DVec3};
use std::sync::Arc;
use wavelux_quadrature::GaussLegendre;

const T_PANELS: usize = 4;
const S_PANELS: usize = 16;
const ORDER: usize = 10;

/// Cubic Bernstein basis and its first two derivatives at `t`.
fn bernstein(t: f64) -> ([f64; 4], [f64; 4], [f64; 4]) {
    let s = 1.0 - t;
    (
        [s * s * s, 3.0 * t * s * s, 3.0 * t * t * s, t * t * t],
        [
            -3.0 * s * s,
            3.0 * s * s - 6.0 * t * s,
            6.0 * t * s - 3.0 * t * t,
            3.0 * t * t,
        ],
        [6.0 * s, 18.0 * t - 12.0, 6.0 - 18.0 * t, 6.0 * t],
    )
}

/// A bicubic Bézier patch `P(s, t) = Σ B_i(s) B_j(t) P_ij`, `ctrl[i][j]` = P_ij.
#[derive(Debug, Clone)]
pub struct BezierPatch {
    ctrl: [[DVec3; 4]; 4],
    marginal: Arc<SmoothCumulative>,
    nodes: Arc<(Vec<f64>, Vec<f64>)>,
    kind: ParamKind,
}

/// The control net contracted along s at a fixed `s`: rows `Σ_i B_i(s) P_ij`,
/// `Σ_i B′_i(s) P_ij` and `Σ_i B″_i(s) P_ij`, so that `J(s, ·)` and `∂J/∂s(s, ·)` cost
/// a few vector products per `t` (the conditional integrals in t evaluate them tens of
/// times per point).
struct Row {
    q: [DVec3; 4],
    r: [DVec3; 4],
    rr: [DVec3; 4],
}

impl Row {
    /// `(P_s, P_t)` at `t`.
    #[inline]
    fn tangents(&self, t: f64) -> (DVec3, DVec3, [f64; 4], [f64; 4]) {
        let (bt, dbt, _) = bernstein(t);
        let mut ps = DVec3::ZERO;
        let mut pt = DVec3::ZERO;
        for j in 0..4 {
            ps += self.r[j] * bt[j];
            pt += self.q[j] * dbt[j];
        }
        (ps, pt, bt, dbt)
    }

    /// `J(s, t)`.
    #[inline]
    fn jac(&self, t: f64) -> f64 {
        let (ps, pt, _, _) = self.tangents(t);
        ps.cross(pt).length()
    }

    /// `(J, ∂J/∂s)` at `(s, t)`.
    #[inline]
    fn jac_ds(&self, t: f64) -> (f64, f64) {
        let (ps, pt, bt, dbt) = self.tangents(t);
        let mut pss = DVec3::ZERO;
        let mut pst = DVec3::ZERO;
        for j in 0..4 {
            pss += self.rr[j] * bt[j];
            pst += self.r[j] * dbt[j];
        }
        let n = ps.cross(pt);
        let jv = n.length();
        let dn = pss.cross(pt) + ps.cross(pst);
        (jv, n.dot(dn) / jv)
    }
}

/// Position and derivatives of the patch.
struct Derivs {
    p: DVec3,
    ps: DVec3,
    pt: DVec3,
    pss: DVec3,
    pst: DVec3,
}

impl BezierPatch {
    /// A patch from its 4×4 control net (`ctrl[i][j]`, i along s, j along t).
    ///
    /// # Errors
    /// Non-finite control points, or a patch whose area element vanishes at an
    /// interior sample (folded or collapsed patch).
    pub fn new(ctrl: [[DVec3; 4]; 4]) -> Result<Self, ParamError> {
        for row in &ctrl {
            for p in row {
                finite3("Bézier patch control point", *p)?;
            }
        }
        let gl = GaussLegendre::new(ORDER).expect("order in range");
        let nodes = Arc::new(gl.unit());
        let mut me = Self {
            ctrl,
            marginal: Arc::new(SmoothCumulative::new(0.0, 1.0, 1, 1, |_| 1.0)),
            nodes,
            kind: ParamKind::EqualArea,
        };
        for i in 1..8 {
            for j in 1..8 {
                let j_ = me.jac(i as f64 / 8.0, j as f64 / 8.0);
                if !(j_.is_finite() && j_ > 0.0) {
                    return Err(ParamError::Degenerate(
                        "Bézier patch has a vanishing area element",
                    ));
                }
            }
        }
        me.marginal = Arc::new(SmoothCumulative::new(0.0, 1.0, S_PANELS, ORDER, |s| {
            me.m(s)
        }));
        Ok(me)
    }
    crate::map_kind_switch!(
        "The same patch with the equal-area map.",
        "The same patch with the natural (Bézier parameter) map."
    );
    /// Control net (`[i][j]`, i along s, j along t), world coordinates.
    pub fn control_points(&self) -> &[[DVec3; 4]; 4] {
        &self.ctrl
    }

    fn derivs(&self, s: f64, t: f64) -> Derivs {
        let (bs, dbs, ddbs) = bernstein(s);
        let (bt, dbt, _) = bernstein(t);
        let mut d = Derivs {
            p: DVec3::ZERO,
            ps: DVec3::ZERO,
            pt: DVec3::ZERO,
            pss: DVec3::ZERO,
            pst: DVec3::ZERO,
        };
        for i in 0..4 {
            for j in 0..4 {
                let c = self.ctrl[i][j];
                d.p += c * (bs[i] * bt[j]);
                d.ps += c * (dbs[i] * bt[j]);
                d.pt += c * (bs[i] * dbt[j]);
                d.pss += c * (ddbs[i] * bt[j]);
                d.pst += c * (dbs[i] * dbt[j]);
            }
        }
        d
    }

    /// Natural-parameter point: position and the two tangents.
    pub fn natural_point(&self, st: DVec2) -> (DVec3, DVec3, DVec3) {
        let d = self.derivs(st.x, st.y);
        (d.p, d.ps, d.pt)
    }

    fn jac(&self, s: f64, t: f64) -> f64 {
        self.row(s).jac(t)
    }

    /// The net contracted along s at `s`.
    fn row(&self, s: f64) -> Row {
        let (bs, dbs, ddbs) = bernstein(s);
        let mut row = Row {
            q: [DVec3::ZERO; 4],
            r: [DVec3::ZERO; 4],
            rr: [DVec3::ZERO; 4],
        };
        for j in 0..4 {
            for i in 0..4 {
                let c = self.ctrl[i][j];
                row.q[j] += c * bs[i];
                row.r[j] += c * dbs[i];
                row.rr[j] += c * ddbs[i];
            }
        }
        row
    }

    /// Composite rule on the t-panels: (K(s, t), ∂K/∂s(s, t)).
    fn k_and_ks(&self, row: &Row, t: f64) -> (f64, f64) {
        let (x, w) = (&self.nodes.0, &self.nodes.1);
        let h = 1.0 / T_PANELS as f64;
        let (mut k, mut ks) = (0.0, 0.0);
        for p in 0..T_PANELS {
            let a = p as f64 * h;
            if a >= t {
                break;
            }
            let b = (a + h).min(t);
            let len = b - a;
            for (xi, wi) in x.iter().zip(w) {
                let (j, js) = row.jac_ds(a + len * xi);
                k += wi * len * j;
                ks += wi * len * js;
            }
        }
        (k, ks)
    }

    /// Marginal m(s) = K(s, 1) with the composite t-rule.
    fn m(&self, s: f64) -> f64 {
        let (x, w) = (&self.nodes.0, &self.nodes.1);
        let h = 1.0 / T_PANELS as f64;
        let row = self.row(s);
        (0..T_PANELS)
            .map(|p| panel(x, w, p as f64 * h, (p + 1) as f64 * h, |t| row.jac(t)))
            .sum()
    }

    /// Natural parameters (s, t) of unit-square coordinates.
    pub fn natural_parameters(&self, uv: DVec2) -> DVec2 {
        match self.kind {
            ParamKind::Natural => uv,
            ParamKind::EqualArea => self.equal_area_to_natural(uv).0,
        }
    }

    /// Natural `(s, t)` of equal-area `uv` and `m(s)` (the conditional's total).
    fn equal_area_to_natural(&self, uv: DVec2) -> (DVec2, f64) {
        let s = self.marginal.inverse(uv.x * self.marginal.total());
        let row = self.row(s);
        let (x, w) = (&self.nodes.0, &self.nodes.1);
        let h = 1.0 / T_PANELS as f64;
        // K(s, ·) at the panel breaks, then the panel holding uv.y·m(s).
        let mut breaks = [0.0; T_PANELS + 1];
        for p in 0..T_PANELS {
            let a = p as f64 * h;
            breaks[p + 1] = breaks[p] + panel(x, w, a, a + h, |t| row.jac(t));
        }
        let m = breaks[T_PANELS];
        let c = uv.y * m;
        if c.is_nan() || !m.is_finite() {
            return (DVec2::new(s, f64::NAN), m);
        }
        let c = c.clamp(0.0, m);
        let k = (1..T_PANELS).take_while(|&p| breaks[p] <= c).count();
        let (a, ca, cb) = (k as f64 * h, breaks[k], breaks[k + 1]);
        let guess = if cb > ca {
            a + h * (c - ca) / (cb - ca)
        } else {
            a
        };
        let t = solve_increasing(a, a + h, c, guess, |t| {
            (ca + panel(x, w, a, t, |t| row.jac(t)), row.jac(t))
        });
        (DVec2::new(s, t), m)
    }
}

impl Parametrization for BezierPatch {
    fn eval(&self, uv: DVec2) -> SurfacePoint {
        match self.kind {
            ParamKind::Natural => {
                let d = self.derivs(uv.x, uv.y);
                SurfacePoint {
                    position: d.p,
                    normal: d.ps.cross(d.pt).normalize(),
                    dp_du: d.ps,
                    dp_dv: d.pt,
                }
            }
            ParamKind::EqualArea => {
                let (st, m) = self.equal_area_to_natural(uv);
                let (s, t) = (st.x, st.y);
                let d = self.derivs(s, t);
                let n = d.ps.cross(d.pt);
                let j = n.length();
                let row = self.row(s);
                let (_, ks) = self.k_and_ks(&row, t);
                let (_, ms) = self.k_and_ks(&row, 1.0);
                // u = M̃(s)/M̃(1) with M̃′ = m̃, the tabulated marginal.
                let ds_du = self.marginal.total() / self.marginal.value(s).1;
                let dt_du = (uv.y * ms - ks) * ds_du / j;
                let dt_dv = m / j;
                SurfacePoint {
                    position: d.p,
                    normal: n / j,
                    dp_du: d.ps * ds_du + d.pt * dt_du,
                    dp_dv: d.pt * dt_dv,
                }
            }
        }
    }
    fn inverse(&self, p: DVec3) -> Option<DVec2> {
        let st = closest_point(DVec2::ZERO, DVec2::ONE, 8, p, |a| self.natural_point(a))?;
        match self.kind {
            ParamKind::Natural => Some(st),
            ParamKind::EqualArea => {
                let u = self.marginal.value(st.x).0 / self.marginal.total();
                let (k, _) = self.k_and_ks(&self.row(st.x), st.y.min(1.0));
                let k = if st.y > 1.0 {
                    // Beyond the patch edge: extend K linearly with the edge density.
                    k + (st.y - 1.0) * self.jac(st.x, 1.0)
                } else if st.y < 0.0 {
                    st.y * self.jac(st.x, 0.0)
                } else {
                    k
                };
                Some(DVec2::new(u, k / self.m(st.x)))
            }
        }
    }
    fn jacobian(&self, uv: DVec2) -> f64 {
        match self.kind {
            ParamKind::EqualArea => self.area(),
            ParamKind::Natural => self.jac(uv.x, uv.y),
        }
    }
    fn area(&self) -> f64 {
        self.marginal.total()
    }
    fn bounds(&self) -> Aabb {
        Aabb::from_points(self.ctrl.iter().flatten().copied())
    }
    fn kind(&self) -> ParamKind {
        self.kind
    }
    fn shape(&self) -> SurfaceShape<'_> {
        SurfaceShape::BezierPatch(self)
    }
}
