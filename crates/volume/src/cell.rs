//! Closed forms for one homogeneous cubic cell: how much of a parallel beam it
//! collides, split by the face the beam enters through (the exact form of
//! GlobalCube §3.2's directional and positional corrections, eqs. (30)–(31), Fig. 6),
//! its integral over all directions, the face-to-face form factors of the cube's
//! interior and the energy-exchange matrix Γ of eq. (32).
//!
//! Units: lengths in cell sides `H`, areas in `H²`, the optical depth `A = −ln(1 − σ)`
//! across one side (so the extinction is `A/H`), solid angles in steradians.
//!
//! **Opacity-weighted projected area.** A beam of radiance travelling along the unit
//! vector `d` meets a cube of side 1 and collides the fraction `1 − e^{−A ℓ(x)}` of
//! each ray, `ℓ(x)` its chord. Integrated over the beam's cross-section this is
//! `G(d) = ∫_{A⊥} (1 − e^{−Aℓ}) dA = A ∫_V e^{−A s(x)} dV`, `s(x)` the distance from
//! `x` back to the entry point. For the cube `[0,1]³` and `d` with components
//! `a, b, c ≥ 0` (by symmetry), `s = min(x/a, y/b, z/c)` and `P(s > t) = (1 − at)(1 −
//! bt)(1 − ct)` for `t ≤ 1/max(a, b, c)`, so the part entering through the face
//! `x = 0` is
//!
//! `G_x = A ∫₀^U e^{−At} a (1 − bt)(1 − ct) dt`, `U = 1/max(a, b, c)`,
//!
//! a combination of `∫₀^U A e^{−At} t^k dt = U^k Q_k(AU)`, `Q_k(x) = x ∫₀¹ e^{−xs} s^k ds`,
//! evaluated by a positive series for small `x` and the closed form otherwise (relative
//! error ≲ 1e-14). Limits: `G = A` (thin: the cell's volume times its extinction) as
//! `A → 0`; `G_x = a` (the face's projected area) for an opaque cell.
//!
//! The paper's plain weight (eq. (31): `σ` times the face's projected area) is
//! [`Collision::Plain`].

use std::f64::consts::PI;

use wavelux_quadrature::GaussLegendre;

/// How a cell collides (and, by the same weights, emits): the model's exact
/// opacity-weighted projected area, or the paper's `σ × cos` weight.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Collision {
    /// `G_i(d)` of the module docs: exact for a homogeneous cube (default).
    #[default]
    Exact,
    /// GlobalCube eq. (31): `σ ·` (projected area of entry face `i`).
    Plain,
}

/// `Q_k(x) = x ∫₀¹ e^{−xs} s^k ds` for `k ∈ {0, 1, 2}` and `x ∈ [0, ∞]`.
fn q_k(k: usize, x: f64) -> f64 {
    if x == f64::INFINITY {
        return if k == 0 { 1.0 } else { 0.0 };
    }
    if x <= 0.0 {
        return 0.0;
    }
    if x < 30.0 {
        // e^{−x} Σ_{j≥0} k! x^{j+1} / (k+1+j)!  (all terms positive).
        let kf = [1.0, 1.0, 2.0][k];
        let mut term = kf * x;
        for m in 1..=k + 1 {
            term /= m as f64;
        }
        let mut sum = term;
        let mut j = 0usize;
        loop {
            j += 1;
            term *= x / (k + 1 + j) as f64;
            sum += term;
            if term < sum * 1e-17 {
                break;
            }
        }
        sum * (-x).exp()
    } else {
        // (k!/x^k) (1 − e^{−x} Σ_{j≤k} x^j/j!); e^{−x} < 1e-13 here.
        let mut tail = 0.0;
        let mut t = 1.0;
        for j in 0..=k {
            if j > 0 {
                t *= x / j as f64;
            }
            tail += t;
        }
        let p = 1.0 - (-x).exp() * tail;
        match k {
            0 => p,
            1 => p / x,
            _ => 2.0 * p / (x * x),
        }
    }
}

/// Collision weights of the three entry faces for a beam along a direction whose
/// absolute components are `d = [|dx|, |dy|, |dz|]` (a unit vector), through a cube
/// of side 1 and optical depth `a` per side (`a = ∞`: opaque). Entry `i` is the face
/// perpendicular to axis `i` that the beam enters through. Units: side².
///
/// The three values sum to the cell's opacity-weighted projected area `G(d)`.
#[must_use]
pub fn entry_weights(d: [f64; 3], a: f64, mode: Collision) -> [f64; 3] {
    match mode {
        Collision::Plain => {
            let sigma = sigma_of(a);
            [sigma * d[0], sigma * d[1], sigma * d[2]]
        }
        Collision::Exact => {
            let m = d[0].max(d[1]).max(d[2]);
            if m <= 0.0 || a <= 0.0 {
                return [0.0; 3];
            }
            if a == f64::INFINITY {
                return d;
            }
            let u = 1.0 / m;
            let x = a * u;
            let (q0, q1, q2) = (q_k(0, x), u * q_k(1, x), u * u * q_k(2, x));
            let face = |i: usize, j: usize, k: usize| {
                d[i] * (q0 - (d[j] + d[k]) * q1 + d[j] * d[k] * q2).max(0.0)
            };
            [face(0, 1, 2), face(1, 0, 2), face(2, 0, 1)]
        }
    }
}

/// Probability that light born uniformly and isotropically inside a cell of optical
/// depth `a` per side collides in the same cell before leaving it:
/// `1 − Ĝ(a)/(4π a)` (`Ĝ/(4πa)` is the mean escape probability `⟨e^{−a s}⟩`).
/// Zero for empty and for opaque cells (an opaque cell is a surface: what it reflects
/// leaves it).
#[must_use]
pub fn self_collision(a: f64) -> f64 {
    if a <= 0.0 || a == f64::INFINITY {
        return 0.0;
    }
    if a < 1e-9 {
        // Ĝ/(4πa) = 1 − O(a): the series' first term.
        return 0.0;
    }
    (1.0 - total_weight(a, Collision::Exact) / (4.0 * PI * a)).clamp(0.0, 1.0)
}

/// How a cell's own scattered light is treated.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum SelfInteraction {
    /// The fraction [`self_collision`] of the light a cell scatters collides in the
    /// cell again (a geometric series per cell: collided `C/(1 − ω p)`, leaving
    /// `ω (1 − p)` of it); light from sources leaves without (default).
    #[default]
    Uniform,
    /// None: `m_pp = 1` for scattered light too (GlobalCube §3.1 as printed).
    None,
}

/// `σ = 1 − e^{−a}` (exact at both ends: `a = 0 → 0`, `a = ∞ → 1`).
#[must_use]
pub fn sigma_of(a: f64) -> f64 {
    -(-a).exp_m1()
}

/// `a = −ln(1 − σ)` (`σ = 1 → ∞`).
#[must_use]
pub fn depth_of(sigma: f64) -> f64 {
    if sigma >= 1.0 {
        f64::INFINITY
    } else {
        -(-sigma).ln_1p()
    }
}

/// Gauss order per direction of the rule over the sphere's fundamental triangle.
const SPHERE_ORDER: usize = 24;

/// `Ĝ(a) = ∫_{S²} G(d) dΩ` in side² · sr: what a cell collides from (and, normalised
/// by, emits into) a uniform radiance field of 1. Limits `4π a` (thin) and `6π`
/// (opaque: the Lambertian box). Computed by a 24×24 Gauss rule on each of the 48
/// symmetric triangles of the sphere (the integrand is analytic inside each), accurate
/// to ~1e-13 relative; the plain mode has the closed form `6π σ`.
#[must_use]
pub fn total_weight(a: f64, mode: Collision) -> f64 {
    if mode == Collision::Plain {
        return 6.0 * PI * sigma_of(a);
    }
    if a == f64::INFINITY {
        return 6.0 * PI;
    }
    if a <= 0.0 {
        return 0.0;
    }
    let rule = sphere_rule();
    let mut s = 0.0;
    for &(d, w) in rule.iter() {
        let g = entry_weights(d, a, mode);
        s += w * (g[0] + g[1] + g[2]);
    }
    48.0 * s
}

/// [`total_weight`] (exact collision) from a table: linear interpolation of
/// `ln Ĝ` in `ln a` with 32 nodes per decade on `[1e-6, 1e6]` and the limits outside
/// (relative error < 1e-3). Used where many aggregated cells need `Ĝ` (the pyramid
/// projection), never where exactness matters.
#[must_use]
pub fn total_weight_fast(a: f64) -> f64 {
    use std::sync::OnceLock;
    const LO: f64 = -6.0;
    const PER_DECADE: f64 = 32.0;
    const COUNT: usize = 12 * 32 + 1;
    static TABLE: OnceLock<Vec<f64>> = OnceLock::new();
    if a == f64::INFINITY || a >= 1e6 {
        return 6.0 * PI;
    }
    if a <= 0.0 {
        return 0.0;
    }
    if a <= 1e-6 {
        return 4.0 * PI * a;
    }
    let table = TABLE.get_or_init(|| {
        (0..COUNT)
            .map(|i| {
                let a = 10f64.powf(LO + i as f64 / PER_DECADE);
                total_weight(a, Collision::Exact).ln()
            })
            .collect()
    });
    let x = (a.log10() - LO) * PER_DECADE;
    let i = (x.floor() as usize).min(COUNT - 2);
    let f = x - i as f64;
    ((1.0 - f) * table[i] + f * table[i + 1]).exp()
}

/// Points and weights of the Gauss rule on the triangle `0 ≤ v ≤ u ≤ 1` of the `+x`
/// cube face, mapped to directions `(1, u, v)/r` with `dΩ = du dv / r³`.
fn sphere_rule() -> &'static [([f64; 3], f64)] {
    use std::sync::OnceLock;
    static RULE: OnceLock<Vec<([f64; 3], f64)>> = OnceLock::new();
    RULE.get_or_init(|| {
        let Ok(g) = GaussLegendre::new(SPHERE_ORDER) else {
            return Vec::new();
        };
        let mut out = Vec::with_capacity(SPHERE_ORDER * SPHERE_ORDER);
        for (xi, wi) in g.nodes().iter().zip(g.weights()) {
            let u = 0.5 * (xi + 1.0);
            for (xj, wj) in g.nodes().iter().zip(g.weights()) {
                let t = 0.5 * (xj + 1.0);
                let v = u * t;
                let r2 = 1.0 + u * u + v * v;
                let r = r2.sqrt();
                // Duffy: dv = u dt; Gauss weights on [0,1] are w/2.
                let w = 0.25 * wi * wj * u / (r2 * r);
                out.push(([1.0 / r, u / r, v / r], w));
            }
        }
        out
    })
}

/// Form factor between opposite interior faces of a cube (unit squares at distance
/// 1): 0.19982… (Howell's catalogue C-11 via `wavelux_geometry`).
#[must_use]
pub fn form_factor_opposite() -> f64 {
    wavelux_geometry::formfactor::parallel_rectangles(1.0, 1.0, 1.0).unwrap_or(0.0)
}

/// Form factor between adjacent interior faces of a cube (perpendicular unit squares
/// sharing an edge): 0.20004… (catalogue C-14).
#[must_use]
pub fn form_factor_adjacent() -> f64 {
    wavelux_geometry::formfactor::perpendicular_rectangles(1.0, 1.0, 1.0).unwrap_or(0.0)
}

/// The Γ convention (GlobalCube eq. (32)): how a cell routes the power it collides
/// through one face to its six faces ([`crate::flight::routing`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum GammaMode {
    /// `Γ_ii = σ`, `Γ_ij = (1 − σ) F_ji`: every row sums to 1 (conserving; default).
    #[default]
    Normalized,
    /// The exact first-flight routing of a homogeneous cube
    /// ([`crate::flight::FirstFlight`]): conserving; against the Monte Carlo tracer
    /// better than `Normalized` in thin and medium media, worse in thick ones (crate
    /// docs, "Thick, bright media").
    FirstFlight,
    /// As printed: `Γ_ii = 1`; a row sums to `2 − σ` and creates energy.
    Printed,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `∫₀¹ x e^{−xs} s^k ds` by a 64-point Gauss rule.
    fn q_ref(k: usize, x: f64) -> f64 {
        let g = GaussLegendre::new(64).unwrap();
        g.nodes()
            .iter()
            .zip(g.weights())
            .map(|(xi, w)| {
                let s = 0.5 * (xi + 1.0);
                0.5 * w * x * (-x * s).exp() * s.powi(k as i32)
            })
            .sum()
    }

    #[test]
    fn q_matches_quadrature_on_both_branches() {
        for k in 0..3 {
            for &x in &[1e-12, 1e-6, 0.01, 0.5, 1.0, 5.0, 29.9, 30.1, 60.0] {
                let (a, b) = (q_k(k, x), q_ref(k, x));
                assert!(
                    (a - b).abs() <= 1e-13 * b.abs().max(1e-300),
                    "k {k} x {x}: {a} vs {b}"
                );
            }
        }
    }

    /// Brute-force `G` by a fine midpoint rule over the three entry faces.
    fn g_brute(d: [f64; 3], a: f64) -> [f64; 3] {
        let m = 400;
        let mut out = [0.0; 3];
        for i in 0..3 {
            let (j, k) = ((i + 1) % 3, (i + 2) % 3);
            let mut s = 0.0;
            for p in 0..m {
                for q in 0..m {
                    // Entry point on face x_i = 0; chord to the first exit plane.
                    let (yj, yk) = ((p as f64 + 0.5) / m as f64, (q as f64 + 0.5) / m as f64);
                    let mut l = 1.0 / d[i];
                    if d[j] > 0.0 {
                        l = l.min((1.0 - yj) / d[j]);
                    }
                    if d[k] > 0.0 {
                        l = l.min((1.0 - yk) / d[k]);
                    }
                    s += 1.0 - (-a * l).exp();
                }
            }
            out[i] = d[i] * s / (m * m) as f64;
        }
        out
    }

    #[test]
    fn entry_weights_match_brute_force() {
        let d = glam::DVec3::new(0.8, 0.5, 0.2).normalize();
        let d = [d.x, d.y, d.z];
        for &a in &[0.05, 1.0, 4.0] {
            let e = entry_weights(d, a, Collision::Exact);
            let b = g_brute(d, a);
            for i in 0..3 {
                assert!(
                    (e[i] - b[i]).abs() < 2e-4,
                    "a {a} face {i}: {} vs {}",
                    e[i],
                    b[i]
                );
            }
        }
    }

    #[test]
    fn limits_thin_and_opaque() {
        let d = glam::DVec3::new(0.3, -0.9, 0.4).normalize().abs();
        let d = [d.x, d.y, d.z];
        let thin = entry_weights(d, 1e-9, Collision::Exact);
        assert!(((thin.iter().sum::<f64>()) / 1e-9 - 1.0).abs() < 1e-8);
        let op = entry_weights(d, f64::INFINITY, Collision::Exact);
        assert_eq!(op, d);
        let big = entry_weights(d, 1e4, Collision::Exact);
        for i in 0..3 {
            assert!((big[i] - d[i]).abs() < 1e-3);
        }
        assert!((total_weight(f64::INFINITY, Collision::Exact) - 6.0 * PI).abs() < 1e-12);
        assert!((total_weight(1e6, Collision::Exact) / (6.0 * PI) - 1.0).abs() < 1e-5);
        assert!((total_weight(1e-8, Collision::Exact) / (4.0 * PI * 1e-8) - 1.0).abs() < 1e-7);
    }

    #[test]
    fn cube_form_factors_sum_to_one() {
        let (fo, fa) = (form_factor_opposite(), form_factor_adjacent());
        assert!((fo - 0.19982).abs() < 1e-5, "{fo}");
        assert!((fa - 0.20004).abs() < 1e-5, "{fa}");
        assert!((fo + 4.0 * fa - 1.0).abs() < 1e-12);
        for sigma in [0.0, 0.3, 1.0] {
            let g =
                crate::flight::routing(sigma, 1.0, GammaMode::Normalized, SelfInteraction::None)
                    .matrix();
            for i in 0..6 {
                let row: f64 = g[i].iter().sum();
                let col: f64 = (0..6).map(|j| g[j][i]).sum();
                assert!((row - 1.0).abs() < 1e-12 && (col - 1.0).abs() < 1e-12);
            }
            let p = crate::flight::routing(sigma, 1.0, GammaMode::Printed, SelfInteraction::None);
            assert!((p.leaving() - (2.0 - sigma)).abs() < 1e-12);
        }
    }
}
