//! Rules on triangles (Stroud conical product) and on the unit disk (polar product).
//!
//! Triangles: the collapsed map `(ξ, η) ↦ (x, y) = (ξ, (1-ξ) η)` takes `[0,1]²` onto
//! the reference triangle `T = {x, y >= 0, x + y <= 1}` with Jacobian `1-ξ`. An
//! n-point Gauss–Jacobi rule for the weight `(1-ξ)` in ξ times an n-point
//! Gauss–Legendre rule in η (Stroud's conical product) integrates every polynomial of
//! total degree `<= 2n-1` over `T` exactly: `x^a y^b = ξ^a (1-ξ)^b η^b`, a polynomial
//! of degree `a+b` in ξ against the weight and of degree `b` in η.
//!
//! Disk: `(x, y) = (r cos θ, r sin θ)`, `dA = r dr dθ`; Gauss–Jacobi with weight `r` in
//! r and the trapezoidal rule in θ (exact for trigonometric polynomials of degree
//! `< m` with `m` equally spaced angles). A monomial of total degree `p` is `r^p` times
//! a trigonometric polynomial of degree `p`, so the rule is exact for total degree
//! `<= min(2 n_r - 1, m - 1)`.
//!
//! Triangles arise in the complex-polygon supports of VirtualMesh §4.2; the disk in
//! the gnomonic direction domain of Glossy §3.3 (a disk of radius π/2).

use crate::{GaussJacobi, GaussLegendre, QuadratureError, RuleNd, check_finite};

/// Stroud conical-product rule on the reference triangle `{x, y >= 0, x + y <= 1}` with
/// `n²` points, all strictly inside; weights sum to 1/2. Exact for polynomials of total
/// degree `<= 2n - 1`.
///
/// # Errors
/// [`QuadratureError::OrderOutOfRange`] unless `1 <= n <= 128`.
pub fn triangle(n: usize) -> Result<RuleNd, QuadratureError> {
    let (xi, wxi) = GaussJacobi::new(n, 1.0, 0.0)?.unit();
    let (eta, weta) = GaussLegendre::new(n)?.unit();
    let mut points = Vec::with_capacity(2 * n * n);
    let mut weights = Vec::with_capacity(n * n);
    for (&x, &wx) in xi.iter().zip(&wxi) {
        for (&e, &we) in eta.iter().zip(&weta) {
            points.push(x);
            points.push((1.0 - x) * e);
            weights.push(wx * we);
        }
    }
    Ok(RuleNd::from_parts(2, points, weights))
}

/// The reference-triangle rule [`triangle`] mapped affinely onto the triangle with
/// vertices `a, b, c` (each a point in any dimension `m >= 1`, e.g. 2D parameter space
/// or 3D). Point `(x, y)` maps to `a + x (b - a) + y (c - a)`, and weights are scaled
/// by `2 · area(abc)` (area from the Gram determinant, so it is the true area in 3D).
///
/// # Errors
/// [`QuadratureError::LengthMismatch`] if the vertices differ in dimension or the rule
/// is not 2D; [`QuadratureError::InvalidParameter`] for non-finite coordinates.
pub fn map_triangle(
    rule: &RuleNd,
    a: &[f64],
    b: &[f64],
    c: &[f64],
) -> Result<RuleNd, QuadratureError> {
    if rule.dim() != 2 {
        return Err(QuadratureError::LengthMismatch {
            expected: 2,
            got: rule.dim(),
        });
    }
    let m = a.len();
    for v in [b, c] {
        if v.len() != m {
            return Err(QuadratureError::LengthMismatch {
                expected: m,
                got: v.len(),
            });
        }
    }
    if m == 0 {
        return Err(QuadratureError::DimensionOutOfRange {
            dim: 0,
            min: 1,
            max: usize::MAX,
        });
    }
    for &x in a.iter().chain(b).chain(c) {
        check_finite("triangle vertex", x)?;
    }
    let e1: Vec<f64> = b.iter().zip(a).map(|(b, a)| b - a).collect();
    let e2: Vec<f64> = c.iter().zip(a).map(|(c, a)| c - a).collect();
    let dot = |u: &[f64], v: &[f64]| -> f64 { u.iter().zip(v).map(|(x, y)| x * y).sum() };
    let g11 = dot(&e1, &e1);
    let g22 = dot(&e2, &e2);
    let g12 = dot(&e1, &e2);
    let jac = (g11 * g22 - g12 * g12).max(0.0).sqrt(); // = 2 · area
    let mut points = Vec::with_capacity(m * rule.len());
    let mut weights = Vec::with_capacity(rule.len());
    for (p, w) in rule.iter() {
        for k in 0..m {
            points.push(a[k] + p[0] * e1[k] + p[1] * e2[k]);
        }
        weights.push(w * jac);
    }
    Ok(RuleNd::from_parts(m, points, weights))
}

/// Polar product rule on the unit disk: `n_radial` Gauss–Jacobi radii (weight r) times
/// `n_angular` equally spaced angles `θ_j = 2π (j + 1/2) / n_angular`. Weights sum to π.
/// Exact for polynomials of total degree `<= min(2 n_radial - 1, n_angular - 1)`.
///
/// # Errors
/// [`QuadratureError::OrderOutOfRange`] unless `1 <= n_radial <= 128` and
/// `1 <= n_angular <= 4096`.
pub fn disk(n_radial: usize, n_angular: usize) -> Result<RuleNd, QuadratureError> {
    if !(1..=4096).contains(&n_angular) {
        return Err(QuadratureError::OrderOutOfRange {
            order: n_angular,
            min: 1,
            max: 4096,
        });
    }
    let (r, wr) = GaussJacobi::new(n_radial, 0.0, 1.0)?.unit();
    let dtheta = 2.0 * std::f64::consts::PI / n_angular as f64;
    let mut points = Vec::with_capacity(2 * n_radial * n_angular);
    let mut weights = Vec::with_capacity(n_radial * n_angular);
    for (&ri, &wi) in r.iter().zip(&wr) {
        for j in 0..n_angular {
            let th = dtheta * (j as f64 + 0.5);
            let (s, c) = th.sin_cos();
            points.push(ri * c);
            points.push(ri * s);
            weights.push(wi * dtheta);
        }
    }
    Ok(RuleNd::from_parts(2, points, weights))
}

/// [`disk`] with `n` radii and `2n` angles: exact for total degree `<= 2n - 1`, mapped
/// to the disk of the given `centre` and `radius` (weights sum to `π radius²`).
///
/// # Errors
/// As [`disk`]; [`QuadratureError::InvalidParameter`] for a non-finite centre or a
/// radius that is not finite and positive.
pub fn disk_mapped(n: usize, centre: [f64; 2], radius: f64) -> Result<RuleNd, QuadratureError> {
    check_finite("centre", centre[0])?;
    check_finite("centre", centre[1])?;
    if !(radius.is_finite() && radius > 0.0) {
        return Err(QuadratureError::InvalidParameter {
            name: "radius",
            value: radius,
            reason: "must be finite and positive",
        });
    }
    let base = disk(n, 2 * n)?;
    let mut points = Vec::with_capacity(base.points().len());
    for (p, _) in base.iter() {
        points.push(centre[0] + radius * p[0]);
        points.push(centre[1] + radius * p[1]);
    }
    let weights = base.weights().iter().map(|w| w * radius * radius).collect();
    Ok(RuleNd::from_parts(2, points, weights))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::jacobi::gamma;

    fn factorial(k: u32) -> f64 {
        (1..=k).map(f64::from).product()
    }

    /// ∫_T x^a y^b = a! b! / (a + b + 2)!.
    fn triangle_moment(a: u32, b: u32) -> f64 {
        factorial(a) * factorial(b) / factorial(a + b + 2)
    }

    #[test]
    fn triangle_exact_for_total_degree_2n_minus_1() {
        for n in [1usize, 2, 3, 5, 8, 12] {
            let r = triangle(n).unwrap();
            assert_eq!(r.len(), n * n);
            let deg = 2 * n as u32 - 1;
            for a in 0..=deg {
                for b in 0..=deg - a {
                    let v = r.integrate(|p| p[0].powi(a as i32) * p[1].powi(b as i32));
                    let e = triangle_moment(a, b);
                    assert!(
                        (v - e).abs() < 1e-15 + 1e-13 * e,
                        "n={n} a={a} b={b} v={v} e={e}"
                    );
                }
            }
            for (p, _) in r.iter() {
                assert!(p[0] > 0.0 && p[1] > 0.0 && p[0] + p[1] < 1.0);
            }
        }
    }

    #[test]
    fn triangle_not_exact_beyond_2n_minus_1() {
        let r = triangle(3).unwrap();
        let v = r.integrate(|p| p[0].powi(6));
        assert!((v - triangle_moment(6, 0)).abs() > 1e-8);
    }

    #[test]
    fn mapped_triangle_area_and_centroid_in_3d() {
        let r = triangle(4).unwrap();
        let (a, b, c) = ([1.0, 0.0, 2.0], [3.0, 1.0, 2.0], [1.0, 2.0, 5.0]);
        let m = map_triangle(&r, &a, &b, &c).unwrap();
        let e1 = [2.0, 1.0, 0.0];
        let e2 = [0.0, 2.0, 3.0];
        let cross: [f64; 3] = [
            e1[1] * e2[2] - e1[2] * e2[1],
            e1[2] * e2[0] - e1[0] * e2[2],
            e1[0] * e2[1] - e1[1] * e2[0],
        ];
        let area = 0.5 * (cross[0] * cross[0] + cross[1] * cross[1] + cross[2] * cross[2]).sqrt();
        assert!((m.weight_sum() - area).abs() < 1e-13);
        for k in 0..3 {
            let c_k = m.integrate(|p| p[k]) / area;
            assert!((c_k - (a[k] + b[k] + c[k]) / 3.0).abs() < 1e-13);
        }
        assert!(map_triangle(&r, &a, &b[..2], &c).is_err());
    }

    /// ∫_{unit disk} x^a y^b = 2 Γ((a+1)/2) Γ((b+1)/2) / ((a+b+2) Γ((a+b+2)/2)) for a, b
    /// even, 0 otherwise.
    fn disk_moment(a: u32, b: u32) -> f64 {
        if a % 2 == 1 || b % 2 == 1 {
            return 0.0;
        }
        let (a, b) = (f64::from(a), f64::from(b));
        2.0 * gamma((a + 1.0) / 2.0) * gamma((b + 1.0) / 2.0)
            / ((a + b + 2.0) * gamma((a + b + 2.0) / 2.0))
    }

    #[test]
    fn disk_exact_for_stated_degree() {
        for (nr, na) in [(1usize, 2usize), (3, 6), (4, 5), (6, 12), (10, 20)] {
            let r = disk(nr, na).unwrap();
            let deg = (2 * nr - 1).min(na - 1) as u32;
            assert!((r.weight_sum() - std::f64::consts::PI).abs() < 1e-14);
            for a in 0..=deg {
                for b in 0..=deg - a {
                    let v = r.integrate(|p| p[0].powi(a as i32) * p[1].powi(b as i32));
                    let e = disk_moment(a, b);
                    assert!(
                        (v - e).abs() < 1e-14,
                        "nr={nr} na={na} a={a} b={b} v={v} e={e}"
                    );
                }
            }
        }
        assert!(disk(0, 4).is_err());
        assert!(disk(4, 0).is_err());
    }

    #[test]
    fn mapped_disk_area() {
        let r = disk_mapped(5, [2.0, -1.0], 0.5).unwrap();
        assert!((r.weight_sum() - std::f64::consts::PI * 0.25).abs() < 1e-14);
        let cx = r.integrate(|p| p[0]) / r.weight_sum();
        assert!((cx - 2.0).abs() < 1e-13);
        assert!(disk_mapped(5, [0.0, 0.0], -1.0).is_err());
        assert!(disk_mapped(5, [f64::NAN, 0.0], 1.0).is_err());
    }
}
