//! Numerical kernels behind the numerical equal-area maps: safeguarded Newton for
//! monotone scalar equations, cumulative-area tables built with composite
//! Gauss–Legendre rules (VirtualMesh §3.1.2 eq. (2)), and a damped Gauss–Newton
//! closest-point solver for surface inverses that have no closed form.

use glam::{DVec2, DVec3};
use wavelux_quadrature::GaussLegendre;

/// Solves `f(x) = target` for an increasing `f` on `[lo, hi]` by Newton's method,
/// falling back to bisection whenever a step leaves the bracket. `f` returns the value
/// and derivative. Converges to a few ulps of the bracket scale.
pub(crate) fn solve_increasing(
    mut lo: f64,
    mut hi: f64,
    target: f64,
    guess: f64,
    f: impl Fn(f64) -> (f64, f64),
) -> f64 {
    let scale = lo.abs().max(hi.abs()).max(f64::MIN_POSITIVE);
    let mut x = if guess.is_finite() {
        guess.clamp(lo, hi)
    } else {
        0.5 * (lo + hi)
    };
    for _ in 0..200 {
        let (fx, d) = f(x);
        let r = fx - target;
        if r == 0.0 {
            return x;
        }
        if r > 0.0 {
            hi = x;
        } else {
            lo = x;
        }
        let mut xn = x - r / d;
        if !(xn.is_finite() && xn >= lo && xn <= hi) {
            xn = 0.5 * (lo + hi);
        }
        let step = (xn - x).abs();
        x = xn;
        if step <= 2.0 * f64::EPSILON * scale || hi - lo <= 2.0 * f64::EPSILON * scale {
            break;
        }
    }
    x
}

/// Cumulative integral `C(t) = ∫_{t0}^{t} ρ` of a non-negative density on `[t0, t1]`,
/// tabulated at `panels + 1` equispaced breakpoints with an `order`-point
/// Gauss–Legendre rule per panel; values between breakpoints are completed by the same
/// rule on the partial panel, so `C` and its inverse are consistent to rounding.
#[derive(Debug, Clone)]
pub(crate) struct Cumulative {
    t0: f64,
    t1: f64,
    h: f64,
    nodes: Vec<f64>,
    weights: Vec<f64>,
    breaks: Vec<f64>,
}

impl Cumulative {
    pub fn new(t0: f64, t1: f64, panels: usize, order: usize, rho: impl Fn(f64) -> f64) -> Self {
        let gl = GaussLegendre::new(order).expect("orders used by the crate are in 1..=128");
        let (nodes, weights) = gl.unit();
        let h = (t1 - t0) / panels as f64;
        let mut breaks = Vec::with_capacity(panels + 1);
        let mut acc = 0.0;
        breaks.push(0.0);
        for k in 0..panels {
            let a = t0 + k as f64 * h;
            let b = if k + 1 == panels { t1 } else { a + h };
            acc += panel(&nodes, &weights, a, b, &rho);
            breaks.push(acc);
        }
        Self {
            t0,
            t1,
            h,
            nodes,
            weights,
            breaks,
        }
    }

    /// Total integral over `[t0, t1]`.
    pub fn total(&self) -> f64 {
        *self.breaks.last().expect("at least one breakpoint")
    }

    fn panel_of(&self, t: f64) -> usize {
        let n = self.breaks.len() - 1;
        let k = ((t - self.t0) / self.h).floor();
        if k.is_finite() && k > 0.0 {
            (k as usize).min(n - 1)
        } else {
            0
        }
    }

    fn start(&self, k: usize) -> f64 {
        self.t0 + k as f64 * self.h
    }

    /// `C(t)`; `t` outside `[t0, t1]` extrapolates with the end panel's rule.
    pub fn value(&self, t: f64, rho: impl Fn(f64) -> f64) -> f64 {
        let k = self.panel_of(t);
        self.breaks[k] + panel(&self.nodes, &self.weights, self.start(k), t, &rho)
    }

    /// The `t` with `C(t) = c`, for `c` in `[0, total]` (clamped).
    pub fn inverse(&self, c: f64, rho: impl Fn(f64) -> f64) -> f64 {
        let total = self.total();
        if c.is_nan() {
            return f64::NAN;
        }
        let c = c.clamp(0.0, total);
        // Last breakpoint <= c.
        let n = self.breaks.len() - 1;
        let k = match self
            .breaks
            .binary_search_by(|b| b.partial_cmp(&c).expect("finite"))
        {
            Ok(i) => i.min(n - 1),
            Err(i) => i.saturating_sub(1).min(n - 1),
        };
        let a = self.start(k);
        let b = if k + 1 == n { self.t1 } else { a + self.h };
        let (ca, cb) = (self.breaks[k], self.breaks[k + 1]);
        let guess = if cb > ca {
            a + (b - a) * (c - ca) / (cb - ca)
        } else {
            a
        };
        solve_increasing(a, b, c, guess, |t| {
            (ca + panel(&self.nodes, &self.weights, a, t, &rho), rho(t))
        })
    }
}

/// Gauss rule on `[a, b]` (unit-interval nodes and weights).
#[inline]
pub(crate) fn panel(
    nodes: &[f64],
    weights: &[f64],
    a: f64,
    b: f64,
    rho: impl Fn(f64) -> f64,
) -> f64 {
    let h = b - a;
    if h == 0.0 {
        return 0.0;
    }
    let mut s = 0.0;
    for (x, w) in nodes.iter().zip(weights) {
        s += w * rho(a + h * x);
    }
    s * h
}

/// Closest point on a parametric patch `x(a, b)`, `(a, b)` in the box `[lo, hi]`, to
/// `p`: starts from the best of a `grid × grid` sample and runs damped Gauss–Newton
/// (Levenberg–Marquardt) on `|x(a, b) − p|²`, allowing parameters to leave the box by
/// up to its size (points just outside a patch still invert). `f` returns the point and
/// both partial derivatives. Returns `None` when no finite solution is found.
pub(crate) fn closest_point(
    lo: DVec2,
    hi: DVec2,
    grid: usize,
    p: DVec3,
    f: impl Fn(DVec2) -> (DVec3, DVec3, DVec3),
) -> Option<DVec2> {
    if !p.is_finite() {
        return None;
    }
    let ext = hi - lo;
    let mut best = (f64::INFINITY, lo);
    for i in 0..=grid {
        for j in 0..=grid {
            let q = lo + ext * DVec2::new(i as f64, j as f64) / grid as f64;
            let d = (f(q).0 - p).length_squared();
            if d < best.0 {
                best = (d, q);
            }
        }
    }
    let mut q = best.1;
    let (x0, _, _) = f(q);
    let mut err = (x0 - p).length_squared();
    let mut lambda = 1e-6;
    let llo = lo - ext;
    let lhi = hi + ext;
    for _ in 0..100 {
        let (x, da, db) = f(q);
        let r = x - p;
        let g = DVec2::new(da.dot(r), db.dot(r));
        let (a11, a12, a22) = (da.dot(da), da.dot(db), db.dot(db));
        let mut accepted = false;
        for _ in 0..30 {
            let m11 = a11 * (1.0 + lambda);
            let m22 = a22 * (1.0 + lambda);
            let det = m11 * m22 - a12 * a12;
            if !(det.is_finite() && det > 0.0) {
                lambda *= 10.0;
                continue;
            }
            let step = DVec2::new(
                -(m22 * g.x - a12 * g.y) / det,
                -(m11 * g.y - a12 * g.x) / det,
            );
            let qn = (q + step).clamp(llo, lhi);
            let en = (f(qn).0 - p).length_squared();
            if en <= err {
                let moved = (qn - q).abs();
                q = qn;
                err = en;
                lambda = (lambda * 0.1).max(1e-12);
                accepted = true;
                if moved.x <= 1e-15 * ext.x.max(q.x.abs())
                    && moved.y <= 1e-15 * ext.y.max(q.y.abs())
                {
                    return Some(q);
                }
                break;
            }
            lambda *= 10.0;
        }
        if !accepted {
            break;
        }
    }
    q.is_finite().then_some(q)
}

/// Parameter of the point of a planar curve `t ↦ c(t)` nearest to `q`: best of
/// `samples + 1` samples on `[t0, t1]`, then damped Newton on `(c − q)·c' = 0`, allowed
/// to leave the interval by its length. `f` returns c, c', c''.
pub(crate) fn closest_on_curve(
    t0: f64,
    t1: f64,
    samples: usize,
    q: DVec2,
    f: impl Fn(f64) -> (DVec2, DVec2, DVec2),
) -> f64 {
    let span = t1 - t0;
    let mut best = (f64::INFINITY, t0);
    for i in 0..=samples {
        let t = t0 + span * i as f64 / samples as f64;
        let d = (f(t).0 - q).length_squared();
        if d < best.0 {
            best = (d, t);
        }
    }
    let (mut t, mut err) = (best.1, best.0);
    let (lo, hi) = (t0 - span, t1 + span);
    for _ in 0..100 {
        let (c, d1, d2) = f(t);
        let g = (c - q).dot(d1);
        let h = d1.length_squared() + (c - q).dot(d2);
        let mut step = if h > 0.0 {
            -g / h
        } else {
            -g / d1.length_squared().max(f64::MIN_POSITIVE)
        };
        if !step.is_finite() {
            break;
        }
        let mut accepted = false;
        for _ in 0..40 {
            let tn = (t + step).clamp(lo, hi);
            let en = (f(tn).0 - q).length_squared();
            if en <= err {
                let moved = (tn - t).abs();
                t = tn;
                err = en;
                accepted = true;
                if moved <= 1e-15 * span.abs().max(t.abs()) {
                    return t;
                }
                break;
            }
            step *= 0.5;
        }
        if !accepted {
            break;
        }
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cumulative_matches_closed_form_and_inverts() {
        // ∫_0^t cos = sin t on [0, 1.5].
        let c = Cumulative::new(0.0, 1.5, 8, 8, f64::cos);
        for i in 0..=20 {
            let t = 1.5 * i as f64 / 20.0;
            assert!((c.value(t, f64::cos) - t.sin()).abs() < 1e-14);
            let back = c.inverse(t.sin(), f64::cos);
            assert!((back - t).abs() < 1e-13, "{t} {back}");
        }
    }

    #[test]
    fn newton_solves_cubic() {
        let x = solve_increasing(-2.0, 2.0, 1.0, 0.0, |x| (x * x * x, 3.0 * x * x));
        assert!((x - 1.0).abs() < 1e-15);
    }
}
