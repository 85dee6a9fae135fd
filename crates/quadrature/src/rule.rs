//! Plain-data cubature rules in `d` dimensions and tensor-product rules on `[0,1]^d`.
//!
//! A [`RuleNd`] is a list of points (flattened, `dim` coordinates each) and weights. It
//! is built once and applied many times: [`RuleNd::integrate`] and [`RuleNd::iter`]
//! allocate nothing. Tensor-product Gauss–Legendre rules on `[0,1]^d` with per-axis
//! orders cover the 4D form-factor integrals (Ziegler §3.3.3, VirtualMesh §5.2: all
//! coefficients are integrals over mapped unit squares) and the 6D glossy transport
//! integrals (Glossy §3.3: space × direction, both mapped to unit squares).

use crate::{GaussLegendre, QuadratureError, check_finite};

/// Largest dimension of the tensor-product rules built by [`RuleNd::tensor_unit`].
pub const MAX_TENSOR_DIM: usize = 6;

/// A cubature rule: `len()` points in `dim()` dimensions with one weight each.
///
/// Points are stored flattened (`points()[i*dim..(i+1)*dim]` is point `i`). The rule
/// approximates `∫ f ≈ Σ w_i f(p_i)`; weights already include every Jacobian, so they
/// sum to the measure of the domain for rules built by this crate.
#[derive(Debug, Clone, PartialEq)]
pub struct RuleNd {
    dim: usize,
    points: Vec<f64>,
    weights: Vec<f64>,
}

impl RuleNd {
    /// Builds a rule from flattened points and weights.
    ///
    /// # Errors
    /// [`QuadratureError::DimensionOutOfRange`] if `dim == 0`;
    /// [`QuadratureError::LengthMismatch`] if `points.len() != dim * weights.len()`;
    /// [`QuadratureError::InvalidParameter`] if any coordinate or weight is not finite.
    pub fn new(dim: usize, points: Vec<f64>, weights: Vec<f64>) -> Result<Self, QuadratureError> {
        if dim == 0 {
            return Err(QuadratureError::DimensionOutOfRange {
                dim,
                min: 1,
                max: usize::MAX,
            });
        }
        if points.len() != dim * weights.len() {
            return Err(QuadratureError::LengthMismatch {
                expected: dim * weights.len(),
                got: points.len(),
            });
        }
        for &x in &points {
            check_finite("point coordinate", x)?;
        }
        for &w in &weights {
            check_finite("weight", w)?;
        }
        Ok(Self {
            dim,
            points,
            weights,
        })
    }

    /// Internal constructor for data known to be consistent.
    pub(crate) fn from_parts(dim: usize, points: Vec<f64>, weights: Vec<f64>) -> Self {
        debug_assert_eq!(points.len(), dim * weights.len());
        Self {
            dim,
            points,
            weights,
        }
    }

    /// A 1D rule from a Gauss–Legendre rule mapped to [0, 1].
    #[must_use]
    pub fn from_gauss_unit(g: &GaussLegendre) -> Self {
        let (p, w) = g.unit();
        Self::from_parts(1, p, w)
    }

    /// Tensor-product Gauss–Legendre rule on `[0,1]^d` with `orders[k]` points along
    /// axis `k` (`d = orders.len()`, `1 <= d <= 6`). Exact for polynomials of degree
    /// `<= 2 orders[k] - 1` in coordinate `k` (to rounding, about 1e-15 relative).
    /// Points are ordered with the last axis varying fastest.
    ///
    /// # Errors
    /// [`QuadratureError::DimensionOutOfRange`] unless `1 <= d <= 6`;
    /// [`QuadratureError::OrderOutOfRange`] for an order outside `1..=128`.
    pub fn tensor_unit(orders: &[usize]) -> Result<Self, QuadratureError> {
        let d = orders.len();
        if !(1..=MAX_TENSOR_DIM).contains(&d) {
            return Err(QuadratureError::DimensionOutOfRange {
                dim: d,
                min: 1,
                max: MAX_TENSOR_DIM,
            });
        }
        let mut rule: Option<Self> = None;
        for &n in orders {
            let g = Self::from_gauss_unit(&GaussLegendre::new(n)?);
            rule = Some(match rule {
                None => g,
                Some(r) => r.product(&g),
            });
        }
        // `d >= 1`, so the loop ran at least once.
        rule.ok_or(QuadratureError::DimensionOutOfRange {
            dim: d,
            min: 1,
            max: MAX_TENSOR_DIM,
        })
    }

    /// Tensor-product Gauss–Legendre rule with `n` points per axis on `[0,1]^d`.
    ///
    /// # Errors
    /// As [`RuleNd::tensor_unit`].
    pub fn tensor_unit_uniform(d: usize, n: usize) -> Result<Self, QuadratureError> {
        if !(1..=MAX_TENSOR_DIM).contains(&d) {
            return Err(QuadratureError::DimensionOutOfRange {
                dim: d,
                min: 1,
                max: MAX_TENSOR_DIM,
            });
        }
        Self::tensor_unit(&vec![n; d])
    }

    /// Tensor product `self × other`: points `(p, q)` with weights `w_p w_q`, in
    /// `self.dim() + other.dim()` dimensions; `other`'s index varies fastest.
    #[must_use]
    pub fn product(&self, other: &Self) -> Self {
        let dim = self.dim + other.dim;
        let len = self.len() * other.len();
        let mut points = Vec::with_capacity(dim * len);
        let mut weights = Vec::with_capacity(len);
        for (p, wp) in self.iter() {
            for (q, wq) in other.iter() {
                points.extend_from_slice(p);
                points.extend_from_slice(q);
                weights.push(wp * wq);
            }
        }
        Self::from_parts(dim, points, weights)
    }

    /// The rule mapped affinely from its current domain, assumed `[0,1]^d`, to the box
    /// `[lo, hi]` (per-axis). Weights are scaled by the box volume `Π (hi_k - lo_k)`.
    ///
    /// # Errors
    /// [`QuadratureError::LengthMismatch`] if `lo` or `hi` has the wrong length;
    /// [`QuadratureError::InvalidParameter`] for non-finite bounds.
    pub fn map_unit_to_box(&self, lo: &[f64], hi: &[f64]) -> Result<Self, QuadratureError> {
        for s in [lo, hi] {
            if s.len() != self.dim {
                return Err(QuadratureError::LengthMismatch {
                    expected: self.dim,
                    got: s.len(),
                });
            }
        }
        for (&a, &b) in lo.iter().zip(hi) {
            check_finite("box bound", a)?;
            check_finite("box bound", b)?;
        }
        let vol: f64 = lo.iter().zip(hi).map(|(a, b)| b - a).product();
        let mut points = self.points.clone();
        for p in points.chunks_exact_mut(self.dim) {
            for k in 0..self.dim {
                p[k] = lo[k] + (hi[k] - lo[k]) * p[k];
            }
        }
        let weights = self.weights.iter().map(|w| w * vol).collect();
        Ok(Self::from_parts(self.dim, points, weights))
    }

    /// Number of coordinates per point.
    #[must_use]
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// Number of points.
    #[must_use]
    pub fn len(&self) -> usize {
        self.weights.len()
    }

    /// True if the rule has no points.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.weights.is_empty()
    }

    /// All coordinates, flattened point by point.
    #[must_use]
    pub fn points(&self) -> &[f64] {
        &self.points
    }

    /// All weights.
    #[must_use]
    pub fn weights(&self) -> &[f64] {
        &self.weights
    }

    /// Point `i`.
    ///
    /// # Panics
    /// If `i >= self.len()`.
    #[must_use]
    pub fn point(&self, i: usize) -> &[f64] {
        &self.points[i * self.dim..(i + 1) * self.dim]
    }

    /// Sum of the weights (the measure of the domain for this crate's rules), with
    /// compensated (Neumaier) summation.
    #[must_use]
    pub fn weight_sum(&self) -> f64 {
        let (mut s, mut c) = (0.0f64, 0.0f64);
        for &w in &self.weights {
            let t = s + w;
            c += if s.abs() >= w.abs() {
                (s - t) + w
            } else {
                (w - t) + s
            };
            s = t;
        }
        s + c
    }

    /// Iterates over `(point, weight)` pairs without allocating.
    pub fn iter(&self) -> impl ExactSizeIterator<Item = (&[f64], f64)> + '_ {
        self.points
            .chunks_exact(self.dim)
            .zip(self.weights.iter().copied())
    }

    /// `Σ w_i f(p_i)`. Allocates nothing.
    pub fn integrate(&self, mut f: impl FnMut(&[f64]) -> f64) -> f64 {
        self.iter().map(|(p, w)| w * f(p)).sum()
    }

    /// Applies the rule to a vector-valued integrand, accumulating
    /// `acc[k] += Σ w_i f(p_i)[k]`; `f` writes its values into the scratch slice it is
    /// given (length `acc.len()`, zeroed before each call). Allocates one scratch
    /// vector per call of this method, none per point.
    pub fn integrate_into(&self, acc: &mut [f64], mut f: impl FnMut(&[f64], &mut [f64])) {
        let mut scratch = vec![0.0; acc.len()];
        for (p, w) in self.iter() {
            scratch.iter_mut().for_each(|s| *s = 0.0);
            f(p, &mut scratch);
            for (a, s) in acc.iter_mut().zip(&scratch) {
                *a += w * s;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// ∫_0^1 x^k dx.
    fn mono(k: u32) -> f64 {
        1.0 / (f64::from(k) + 1.0)
    }

    #[test]
    fn tensor_rules_integrate_monomials_exactly_up_to_dim_6() {
        let orders = [3usize, 1, 4, 2, 5, 2];
        for d in 1..=6 {
            let r = RuleNd::tensor_unit(&orders[..d]).unwrap();
            assert_eq!(r.dim(), d);
            assert_eq!(r.len(), orders[..d].iter().product::<usize>());
            assert!((r.weight_sum() - 1.0).abs() < 1e-14);
            // Highest exact per-axis degree 2n-1 on every axis at once.
            let degs: Vec<u32> = orders[..d].iter().map(|&n| 2 * n as u32 - 1).collect();
            let v = r.integrate(|p| {
                p.iter()
                    .zip(&degs)
                    .map(|(x, &k)| x.powi(k as i32))
                    .product()
            });
            let exact: f64 = degs.iter().map(|&k| mono(k)).product();
            assert!(
                (v - exact).abs() < 1e-14 * exact.max(1e-3),
                "d={d} v={v} e={exact}"
            );
        }
    }

    #[test]
    fn tensor_rule_is_not_exact_one_degree_higher() {
        // Sanity check that the exactness test is sharp: degree 2n fails.
        let r = RuleNd::tensor_unit(&[3, 3]).unwrap();
        let v = r.integrate(|p| p[0].powi(6));
        assert!((v - mono(6)).abs() > 1e-6);
    }

    #[test]
    fn map_to_box_scales_volume_and_moments() {
        let r = RuleNd::tensor_unit(&[4, 4, 4]).unwrap();
        let b = r
            .map_unit_to_box(&[-1.0, 0.5, 2.0], &[1.0, 1.0, 5.0])
            .unwrap();
        assert!((b.weight_sum() - 2.0 * 0.5 * 3.0).abs() < 1e-13);
        // ∫ x² y z over the box = (2/3) (0.375) (10.5).
        let v = b.integrate(|p| p[0] * p[0] * p[1] * p[2]);
        let e = (2.0 / 3.0) * ((1.0 - 0.25) / 2.0) * ((25.0 - 4.0) / 2.0);
        assert!((v - e).abs() < 1e-12);
    }

    #[test]
    fn bad_inputs_are_errors() {
        assert!(RuleNd::tensor_unit(&[]).is_err());
        assert!(RuleNd::tensor_unit(&[2; 7]).is_err());
        assert!(RuleNd::tensor_unit(&[2, 0]).is_err());
        assert!(RuleNd::new(2, vec![0.0; 3], vec![1.0; 2]).is_err());
        assert!(RuleNd::new(1, vec![f64::NAN], vec![1.0]).is_err());
        let r = RuleNd::tensor_unit(&[2, 2]).unwrap();
        assert!(r.map_unit_to_box(&[0.0], &[1.0, 1.0]).is_err());
        assert!(
            r.map_unit_to_box(&[0.0, f64::INFINITY], &[1.0, 1.0])
                .is_err()
        );
    }

    #[test]
    fn integrate_into_matches_scalar_integration() {
        let r = RuleNd::tensor_unit(&[5, 5]).unwrap();
        let mut acc = [0.0; 3];
        r.integrate_into(&mut acc, |p, out| {
            out[0] = 1.0;
            out[1] = p[0];
            out[2] = p[0] * p[1] * p[1];
        });
        assert!((acc[0] - 1.0).abs() < 1e-14);
        assert!((acc[1] - 0.5).abs() < 1e-14);
        assert!((acc[2] - 1.0 / 6.0).abs() < 1e-14);
    }
}
