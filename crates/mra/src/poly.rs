//! Legendre polynomials, the building blocks of Alpert's multiwavelets
//! (Ziegler §3.1.2, VirtualMesh §5.2).
//!
//! `P_n` is evaluated by the three-term recurrence, which is stable on [-1, 1]; the
//! orthonormal shifted Legendre polynomials on [0, 1] are `√(2n+1) P_n(2x − 1)`.

/// `P_n(t)` for `t ∈ [-1, 1]` by the three-term recurrence (absolute error ~1e-16).
#[must_use]
pub fn legendre(n: usize, t: f64) -> f64 {
    let (mut p0, mut p1) = (1.0, t);
    if n == 0 {
        return 1.0;
    }
    for k in 2..=n {
        let kf = k as f64;
        let p2 = ((2.0 * kf - 1.0) * t * p1 - (kf - 1.0) * p0) / kf;
        p0 = p1;
        p1 = p2;
    }
    p1
}

/// Writes `√(2a+1) P_a(2s − 1)` for `a = 0..out.len()` into `out` (orthonormal on
/// [0, 1]); no allocation.
pub fn shifted_legendre_all(s: f64, out: &mut [f64]) {
    let t = 2.0 * s - 1.0;
    let (mut p0, mut p1) = (1.0, t);
    for (a, o) in out.iter_mut().enumerate() {
        let p = match a {
            0 => 1.0,
            1 => t,
            _ => {
                let kf = a as f64;
                let p2 = ((2.0 * kf - 1.0) * t * p1 - (kf - 1.0) * p0) / kf;
                p0 = p1;
                p1 = p2;
                p2
            }
        };
        *o = (2.0 * a as f64 + 1.0).sqrt() * p;
    }
}

/// Monomial coefficients `c_i` of `√(2a+1) P_a(2s − 1) = Σ_i c_i s^i` (exact integers
/// times `√(2a+1)`; fine for `a ≤ 12`).
#[must_use]
pub fn shifted_legendre_coeffs(a: usize) -> Vec<f64> {
    // P̃_a(s) = Σ_i (-1)^(a+i) C(a,i) C(a+i,i) s^i.
    let mut c = vec![0.0; a + 1];
    for (i, ci) in c.iter_mut().enumerate() {
        let sign = if (a + i).is_multiple_of(2) { 1.0 } else { -1.0 };
        *ci = sign * binom(a, i) * binom(a + i, i) * (2.0 * a as f64 + 1.0).sqrt();
    }
    c
}

/// Binomial coefficient as f64 (exact for the small arguments used here).
#[must_use]
pub fn binom(n: usize, k: usize) -> f64 {
    if k > n {
        return 0.0;
    }
    let mut r = 1.0;
    for i in 0..k {
        r = r * (n - i) as f64 / (i + 1) as f64;
    }
    r
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn coefficients_match_recurrence() {
        let mut v = [0.0; 8];
        for s in [0.0, 0.13, 0.5, 0.77, 1.0] {
            shifted_legendre_all(s, &mut v);
            for a in 0..8 {
                let c = shifted_legendre_coeffs(a);
                let p: f64 = c
                    .iter()
                    .enumerate()
                    .map(|(i, ci)| ci * s.powi(i as i32))
                    .sum();
                assert!((p - v[a]).abs() < 1e-11, "a={a} s={s}");
                let direct = (2.0 * a as f64 + 1.0).sqrt() * legendre(a, 2.0 * s - 1.0);
                assert!((direct - v[a]).abs() < 1e-13);
            }
        }
    }
}
