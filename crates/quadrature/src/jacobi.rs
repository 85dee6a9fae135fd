//! Gauss–Jacobi rules for the weight `(1-x)^α (1+x)^β` on [-1, 1], and the Gamma and
//! Beta functions needed for their normalisation.
//!
//! Gauss–Jacobi rules are the 1D building block for the collapsed-coordinate triangle
//! rules (Stroud conical product, weight `(1-x)`), the polar disk rule (weight `r`) and
//! endpoint-singular integrands such as `x^{-1/2}` (the graded alternative to Duffy
//! transforms for the weakly singular kernels that Ziegler §3.3.3 excluded).
//!
//! Construction: Golub–Welsch (eigenvalues of the symmetric tridiagonal Jacobi matrix,
//! via `nalgebra`) gives the nodes to about `n·1e-16`; each node is then polished by
//! Newton's method on the orthonormal three-term recurrence, and the weights come from
//! the Christoffel formula `w_i = μ₀ / Σ_{k<n} p̂_k(x_i)²` (a sum of positive terms, so
//! they are accurate to a few ulps relative). For α = β = 0 the rule agrees with
//! [`crate::GaussLegendre`] to about 1e-15.

use crate::gauss::MAX_ORDER;
use crate::{QuadratureError, check_finite};
use nalgebra::DMatrix;

/// `ln Γ(x)` for `x > 0`, relative accuracy about 1e-15 (Stirling series after shifting
/// the argument to `x >= 15`). Returns NaN for `x <= 0` or NaN.
#[must_use]
pub fn ln_gamma(x: f64) -> f64 {
    if x == f64::INFINITY {
        return x;
    }
    if x.is_nan() || x <= 0.0 {
        return f64::NAN;
    }
    let mut z = x;
    let mut log_shift = 0.0;
    let mut prod = 1.0;
    while z < 15.0 {
        prod *= z;
        if !(1e-250..=1e250).contains(&prod) {
            log_shift += prod.ln();
            prod = 1.0;
        }
        z += 1.0;
    }
    log_shift += prod.ln();
    (z - 0.5) * z.ln() - z + 0.5 * (2.0 * std::f64::consts::PI).ln() + stirling_series(z)
        - log_shift
}

/// Stirling series `Σ B_{2k} / (2k (2k-1) z^{2k-1})` for `z >= 15` (truncation error
/// below 1e-19).
fn stirling_series(z: f64) -> f64 {
    let inv = 1.0 / z;
    let inv2 = inv * inv;
    inv * (1.0 / 12.0
        + inv2
            * (-1.0 / 360.0
                + inv2
                    * (1.0 / 1260.0
                        + inv2
                            * (-1.0 / 1680.0
                                + inv2
                                    * (1.0 / 1188.0
                                        + inv2 * (-691.0 / 360_360.0 + inv2 / 156.0))))))
}

/// `Γ(x)` for `x > 0`. For `x <= 140` it is evaluated directly as
/// `sqrt(2π) z^{z-1/2} e^{-z} e^{S(z)} / (x (x+1) ⋯ (z-1))` with `z >= 15`, accurate to a
/// few ulps (about 1e-15 relative); beyond that as `exp(ln Γ(x))` (relative accuracy
/// about `1e-16 · ln Γ(x)`). Returns NaN for `x <= 0` or NaN, and `inf` on overflow.
#[must_use]
pub fn gamma(x: f64) -> f64 {
    if x.is_nan() || x <= 0.0 {
        return f64::NAN;
    }
    if x > 140.0 {
        return ln_gamma(x).exp();
    }
    let mut z = x;
    let mut prod = 1.0;
    while z < 15.0 {
        prod *= z;
        z += 1.0;
    }
    // z^{z-1/2} e^{-z} split as (z^{(z-1/2)/2} e^{-z/2})² to stay finite up to z ≈ 155.
    let half = z.powf(0.5 * (z - 0.5)) * (-0.5 * z).exp();
    (2.0 * std::f64::consts::PI).sqrt() * half * half * stirling_series(z).exp() / prod
}

/// The Beta function `B(a, b) = Γ(a)Γ(b)/Γ(a+b)` for `a, b > 0` (about 1e-15 relative
/// when `a + b <= 140`).
#[must_use]
pub fn beta(a: f64, b: f64) -> f64 {
    if a + b <= 140.0 {
        gamma(a) * gamma(b) / gamma(a + b)
    } else {
        (ln_gamma(a) + ln_gamma(b) - ln_gamma(a + b)).exp()
    }
}

/// An n-point Gauss–Jacobi rule on [-1, 1] for the weight `(1-x)^α (1+x)^β`,
/// nodes increasing. Exact for `∫ (1-x)^α (1+x)^β p(x) dx` with `deg p <= 2n-1`.
#[derive(Debug, Clone, PartialEq)]
pub struct GaussJacobi {
    alpha: f64,
    beta: f64,
    nodes: Vec<f64>,
    weights: Vec<f64>,
}

/// Orthonormal recurrence coefficients `(a_k, b_k)`: `x p_k = b_{k+1} p_{k+1} + a_k p_k +
/// b_k p_{k-1}`; returns `a_0..a_{n-1}` and `b_0..b_n` (`b_0 = 0`).
fn jacobi_recurrence(n: usize, al: f64, be: f64) -> (Vec<f64>, Vec<f64>) {
    let s = al + be;
    let mut a = Vec::with_capacity(n);
    let mut b = vec![0.0; n + 1];
    for k in 0..n {
        let kf = k as f64;
        let ak = if k == 0 {
            (be - al) / (s + 2.0)
        } else {
            (be * be - al * al) / ((2.0 * kf + s) * (2.0 * kf + s + 2.0))
        };
        a.push(ak);
    }
    for k in 1..=n {
        let kf = k as f64;
        let b2 = if k == 1 {
            4.0 * (1.0 + al) * (1.0 + be) / ((2.0 + s) * (2.0 + s) * (3.0 + s))
        } else {
            let t = 2.0 * kf + s;
            4.0 * kf * (kf + al) * (kf + be) * (kf + s) / (t * t * (t + 1.0) * (t - 1.0))
        };
        b[k] = b2.sqrt();
    }
    (a, b)
}

/// `(q_n(x), q_n'(x), Σ_{k<n} q_k(x)², d/dx Σ_{k<n} q_k(x)²)` for the
/// recurrence-normalised polynomials with `q_0 = 1` (orthonormal up to `1/sqrt(μ₀)`).
fn eval_recurrence(n: usize, a: &[f64], b: &[f64], x: f64) -> (f64, f64, f64, f64) {
    let (mut q0, mut q1) = (0.0, 1.0);
    let (mut d0, mut d1) = (0.0, 0.0);
    let mut sum = 0.0;
    let mut dsum = 0.0;
    for k in 0..n {
        sum += q1 * q1;
        dsum += 2.0 * q1 * d1;
        let q2 = ((x - a[k]) * q1 - b[k] * q0) / b[k + 1];
        let d2 = (q1 + (x - a[k]) * d1 - b[k] * d0) / b[k + 1];
        q0 = q1;
        q1 = q2;
        d0 = d1;
        d1 = d2;
    }
    (q1, d1, sum, dsum)
}

impl GaussJacobi {
    /// Builds the n-point rule for `(1-x)^α (1+x)^β` on [-1, 1].
    ///
    /// # Errors
    /// [`QuadratureError::OrderOutOfRange`] unless `1 <= n <= 128`;
    /// [`QuadratureError::InvalidParameter`] unless `α, β > -1` and finite.
    pub fn new(n: usize, alpha: f64, beta: f64) -> Result<Self, QuadratureError> {
        if !(1..=MAX_ORDER).contains(&n) {
            return Err(QuadratureError::OrderOutOfRange {
                order: n,
                min: 1,
                max: MAX_ORDER,
            });
        }
        for (name, v) in [("alpha", alpha), ("beta", beta)] {
            check_finite(name, v)?;
            if v <= -1.0 {
                return Err(QuadratureError::InvalidParameter {
                    name,
                    value: v,
                    reason: "Jacobi exponents must exceed -1",
                });
            }
        }
        let mu0 = (2.0f64).powf(alpha + beta + 1.0) * self::beta(alpha + 1.0, beta + 1.0);
        let (a, b) = jacobi_recurrence(n, alpha, beta);
        let mut m = DMatrix::<f64>::zeros(n, n);
        for k in 0..n {
            m[(k, k)] = a[k];
            if k + 1 < n {
                m[(k, k + 1)] = b[k + 1];
                m[(k + 1, k)] = b[k + 1];
            }
        }
        let eig = m.symmetric_eigenvalues();
        let mut nodes: Vec<f64> = eig.iter().copied().collect();
        nodes.sort_by(f64::total_cmp);
        let mut weights = Vec::with_capacity(n);
        for x in &mut nodes {
            // Newton polish; keep the eigenvalue if a step misbehaves.
            for _ in 0..4 {
                let (q, dq, _, _) = eval_recurrence(n, &a, &b, *x);
                if dq == 0.0 || !dq.is_finite() {
                    break;
                }
                let step = q / dq;
                let nx = *x - step;
                if !(nx > -1.0 && nx < 1.0) || step.abs() > 1e-8 {
                    break;
                }
                *x = nx;
                if step.abs() <= 1e-17 {
                    break;
                }
            }
            // Christoffel weight at the true root `x - δ` (δ = residual Newton step,
            // below one ulp) to first order: near ±1 the weight is sensitive to the
            // rounding of the node.
            let (q, dq, sum, dsum) = eval_recurrence(n, &a, &b, *x);
            let delta = if dq != 0.0 && dq.is_finite() {
                q / dq
            } else {
                0.0
            };
            let corrected = sum - dsum * delta;
            weights.push(mu0 / if corrected > 0.0 { corrected } else { sum });
        }
        Ok(Self {
            alpha,
            beta,
            nodes,
            weights,
        })
    }

    /// Number of points.
    #[must_use]
    pub fn order(&self) -> usize {
        self.nodes.len()
    }

    /// The exponent α of `(1-x)^α`.
    #[must_use]
    pub fn alpha(&self) -> f64 {
        self.alpha
    }

    /// The exponent β of `(1+x)^β`.
    #[must_use]
    pub fn beta(&self) -> f64 {
        self.beta
    }

    /// Nodes on [-1, 1], increasing.
    #[must_use]
    pub fn nodes(&self) -> &[f64] {
        &self.nodes
    }

    /// Weights; they sum to `2^{α+β+1} B(α+1, β+1)`.
    #[must_use]
    pub fn weights(&self) -> &[f64] {
        &self.weights
    }

    /// The rule on [0, 1] for the weight `(1-t)^α t^β`: `(points, weights)`, weights
    /// summing to `B(α+1, β+1)`.
    #[must_use]
    pub fn unit(&self) -> (Vec<f64>, Vec<f64>) {
        let scale = (2.0f64).powf(-(self.alpha + self.beta + 1.0));
        let p = self.nodes.iter().map(|x| 0.5 * (x + 1.0)).collect();
        let w = self.weights.iter().map(|w| w * scale).collect();
        (p, w)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::GaussLegendre;

    #[test]
    fn gamma_matches_factorials_and_half_integers() {
        let mut fact = 1.0f64;
        for n in 1..=30u32 {
            // Γ(n) = (n-1)!
            assert!((gamma(f64::from(n)) / fact - 1.0).abs() < 2e-15, "n={n}");
            fact *= f64::from(n);
        }
        let sqrt_pi = std::f64::consts::PI.sqrt();
        // Γ(k + 1/2) = (2k)! / (4^k k!) √π, built by the recurrence Γ(x+1) = xΓ(x).
        let mut g = sqrt_pi;
        for k in 0..20 {
            let x = f64::from(k) + 0.5;
            assert!((gamma(x) / g - 1.0).abs() < 2e-15, "x={x}");
            g *= x;
        }
        assert!(ln_gamma(-1.0).is_nan());
        assert!(ln_gamma(f64::NAN).is_nan());
    }

    /// ∫_0^1 t^k (1-t)^α t^β dt = B(k+β+1, α+1) by the recurrence in k.
    fn unit_moments(kmax: usize, al: f64, be: f64) -> Vec<f64> {
        let mut m = vec![beta(be + 1.0, al + 1.0)];
        for k in 1..=kmax {
            let kb = k as f64 + be;
            let prev = m[k - 1];
            m.push(prev * kb / (kb + al + 1.0));
        }
        m
    }

    #[test]
    fn exact_for_degree_2n_minus_1_for_several_weights() {
        for &(al, be) in &[
            (0.0, 0.0),
            (1.0, 0.0),
            (0.0, 1.0),
            (-0.5, 0.0),
            (0.0, -0.5),
            (0.3, -0.7),
            (2.0, 3.5),
        ] {
            for n in [1usize, 2, 5, 10, 20] {
                let g = GaussJacobi::new(n, al, be).unwrap();
                let (p, w) = g.unit();
                let m = unit_moments(2 * n - 1, al, be);
                for k in 0..2 * n {
                    let v: f64 = p.iter().zip(&w).map(|(x, w)| w * x.powi(k as i32)).sum();
                    assert!(
                        (v - m[k]).abs() < 1e-14 * m[0].max(1.0),
                        "al={al} be={be} n={n} k={k} v={v} m={}",
                        m[k]
                    );
                }
            }
        }
    }

    #[test]
    fn legendre_case_agrees_with_gauss_legendre() {
        for n in [1usize, 2, 7, 32, 128] {
            let j = GaussJacobi::new(n, 0.0, 0.0).unwrap();
            let g = GaussLegendre::new(n).unwrap();
            for i in 0..n {
                assert!((j.nodes()[i] - g.nodes()[i]).abs() < 1e-14, "n={n} i={i}");
                assert!(
                    (j.weights()[i] / g.weights()[i] - 1.0).abs() < 1e-13,
                    "n={n} i={i}"
                );
            }
        }
    }

    #[test]
    fn high_order_radial_rule_is_exact() {
        // Weight t on [0,1]: ∫ t^{k+1} = 1/(k+2); all k <= 2n-1 for n = 128, on the
        // Legendre-like basis monomials of moderate degree (monomials of very high degree
        // are tiny and equally exact).
        let g = GaussJacobi::new(128, 0.0, 1.0).unwrap();
        let (p, w) = g.unit();
        for k in [0usize, 1, 10, 100, 255] {
            let v: f64 = p.iter().zip(&w).map(|(x, w)| w * x.powi(k as i32)).sum();
            assert!((v - 1.0 / (k as f64 + 2.0)).abs() < 1e-14, "k={k}");
        }
    }

    #[test]
    fn rejects_bad_parameters() {
        assert!(GaussJacobi::new(0, 0.0, 0.0).is_err());
        assert!(GaussJacobi::new(129, 0.0, 0.0).is_err());
        assert!(GaussJacobi::new(3, -1.0, 0.0).is_err());
        assert!(GaussJacobi::new(3, 0.0, f64::NAN).is_err());
    }
}
