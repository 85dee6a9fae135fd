//! Robust real roots of low-degree polynomials on an interval.
//!
//! Used for ray–quadric (degree 2) and ray–torus (degree 4) intersection. The roots of
//! `p` in `[lo, hi]` are isolated by the roots of `p'` (recursively), so that `p` is
//! monotone between consecutive critical points; each sign change is then refined by
//! safeguarded Newton–bisection to full double precision. Unlike closed-form Ferrari
//! formulas this never loses roots to cancellation; tangential (double) roots without a
//! sign change are reported only when `|p|` vanishes at the critical point to rounding.

/// Evaluates `Σ c[k] t^k` and its derivative (Horner).
pub fn eval(c: &[f64], t: f64) -> (f64, f64) {
    let mut p = 0.0;
    let mut dp = 0.0;
    for &a in c.iter().rev() {
        dp = dp * t + p;
        p = p * t + a;
    }
    (p, dp)
}

fn magnitude(c: &[f64], t: f64) -> f64 {
    let at = t.abs();
    let mut m = 0.0;
    for &a in c.iter().rev() {
        m = m * at + a.abs();
    }
    m
}

/// Real roots of `Σ c[k] t^k` in `[lo, hi]`, ascending (coefficients ascending in degree).
pub fn roots_in(c: &[f64], lo: f64, hi: f64) -> Vec<f64> {
    let mut c = c.to_vec();
    while c.len() > 1 && c[c.len() - 1] == 0.0 {
        c.pop();
    }
    let mut out = Vec::new();
    if c.len() <= 1 || lo.is_nan() || hi.is_nan() || lo > hi {
        return out;
    }
    if c.len() == 2 {
        let t = -c[0] / c[1];
        if t >= lo && t <= hi {
            out.push(t);
        }
        return out;
    }
    if c.len() == 3 {
        let (a, b, cc) = (c[2], c[1], c[0]);
        let disc = b * b - 4.0 * a * cc;
        if disc < 0.0 {
            return out;
        }
        let q = -0.5 * (b + b.signum() * disc.sqrt());
        let mut r = [q / a, if q != 0.0 { cc / q } else { q / a }];
        r.sort_by(f64::total_cmp);
        for t in r {
            // One Newton polish step on the original polynomial.
            let (p, dp) = eval(&c, t);
            let t = if dp != 0.0 { t - p / dp } else { t };
            if t >= lo && t <= hi && out.last().is_none_or(|&l| t > l) {
                out.push(t);
            }
        }
        return out;
    }
    let d: Vec<f64> = (1..c.len()).map(|k| k as f64 * c[k]).collect();
    let crit = roots_in(&d, lo, hi);
    let mut knots = Vec::with_capacity(crit.len() + 2);
    knots.push(lo);
    knots.extend(crit.iter().copied().filter(|&t| t > lo && t < hi));
    knots.push(hi);
    for w in knots.windows(2) {
        let (a, b) = (w[0], w[1]);
        let (pa, _) = eval(&c, a);
        let (pb, _) = eval(&c, b);
        if pa == 0.0 {
            push_root(&mut out, a);
            continue;
        }
        if pa.signum() == pb.signum() {
            continue;
        }
        push_root(&mut out, refine(&c, a, b, pa));
    }
    let (ph, _) = eval(&c, hi);
    if ph == 0.0 {
        push_root(&mut out, hi);
    }
    // Tangential roots at critical points where |p| is at rounding level.
    for &t in &crit {
        let (p, _) = eval(&c, t);
        if p.abs() <= 8.0 * f64::EPSILON * magnitude(&c, t) && t >= lo && t <= hi {
            push_root(&mut out, t);
        }
    }
    out.sort_by(f64::total_cmp);
    out
}

fn push_root(out: &mut Vec<f64>, t: f64) {
    if !out
        .iter()
        .any(|&r| (r - t).abs() <= 1e-14 * (1.0 + t.abs()))
    {
        out.push(t);
    }
}

/// Safeguarded Newton–bisection on a bracket `[a, b]` with a sign change (`p(a) = pa`).
fn refine(c: &[f64], mut a: f64, mut b: f64, pa: f64) -> f64 {
    let sa = pa.signum();
    let mut t = 0.5 * (a + b);
    for _ in 0..200 {
        let (p, dp) = eval(c, t);
        if p == 0.0 {
            return t;
        }
        if p.signum() == sa {
            a = t;
        } else {
            b = t;
        }
        let newton = if dp != 0.0 { t - p / dp } else { f64::NAN };
        let next = if newton > a && newton < b {
            newton
        } else {
            0.5 * (a + b)
        };
        if (next - t).abs() <= 2.0 * f64::EPSILON * t.abs().max(f64::MIN_POSITIVE)
            || b - a <= 2.0 * f64::EPSILON * a.abs().max(b.abs())
        {
            return next;
        }
        t = next;
    }
    t
}
