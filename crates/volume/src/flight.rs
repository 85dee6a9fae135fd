//! First-flight routing of a homogeneous cubic cell: where the light a cell collides
//! through one entry face goes when it is scattered (the exact form of GlobalCube §3's
//! energy-exchange matrix Γ, eq. (32)), and the per-cell routing of every Γ convention
//! ([`Routing`]).
//!
//! Units: lengths in cell sides, the optical depth `A` across one side.
//!
//! **First flight.** Light enters the cube `[0,1]³` through the face `x = 0` under
//! uniform, isotropic radiance. Its first collisions have the density `A E_0(x)`,
//! where `E_j(x) = ∫_{face j} e^{−A r} cos θ / r² dA` is the attenuated solid angle of
//! face `j` seen from `x`; scattered isotropically at `x`, a photon leaves through
//! face `j` before colliding again with the probability `E_j(x)/4π`. So of the power
//! collided through face `i`, the fraction
//!
//! `Γ_ij = ∫_V E_i E_j dV / (4π ∫_V E_i dV)`
//!
//! leaves through face `j` after one scattering (symmetric in `i`, `j`), and `s = 1 −
//! Σ_j Γ_ij` collides in the cell again. By symmetry three numbers describe it: the
//! same face (`back`), the opposite one and each of the four adjacent ones. Limits:
//! thin (`A → 0`) `s → 0` and `Γ` the correlation of the faces' solid angles (back
//! 0.242, opposite 0.119, adjacent 0.160 each); thick, a half-space (`A = 30`: 0.205
//! leaves by the entry face, 0.79 collides again; `A = 1.25`: back 0.215, opposite
//! 0.042, adjacent 0.092, again 0.376). Light collided again is treated as born
//! uniformly in the cell: it collides once more with the probability `π` of
//! [`crate::cell::self_collision`] and leaves evenly through the six faces.
//!
//! **Computation.** `E_j(x)` in closed form over the angle around the foot of `x` on
//! the face's plane (`∫ e^{−c/u} du = u e^{−c/u} − c E₁(c/u)`, `u = cos θ`,
//! `c = A h`) by a Gauss rule in the angle on the four triangles from the foot to the
//! face's edges; the volume integral by a tensor Gauss rule graded geometrically
//! towards the faces (the boundary layer of thickness `1/A` and the faces' edges),
//! whose nodes serve as both distances and foot coordinates so that every `E_j` is
//! one table of `E` on the nodes (angular pieces split at the foot, at `±h` and
//! geometrically towards the edge's ends). Errors: `E` pointwise ~1e-6 (the six faces'
//! solid angles sum to 4π, tested), the quadrature's `∫ E_0` within 5e-4 of the exact
//! `Ĝ(A)/(6A)` (2.4e-4 at `A = 30`), the fractions within the noise of 400 000 Monte
//! Carlo paths (tested); [`first_flight_fast`] interpolates a table in `log A` (within
//! 3e-4 of the quadrature, tested).

use std::f64::consts::PI;
use std::sync::OnceLock;

use wavelux_quadrature::GaussLegendre;

use crate::cell::{GammaMode, SelfInteraction, form_factor_adjacent, form_factor_opposite};

/// First-flight fractions of a homogeneous cube: of the power collided through one
/// entry face, what leaves (after one isotropic scattering, before another collision)
/// through the same face, the opposite face and each adjacent face. The rest,
/// [`FirstFlight::recollided`], collides in the cell again.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct FirstFlight {
    /// Leaving through the entry face.
    pub back: f64,
    /// Leaving through the opposite face.
    pub opposite: f64,
    /// Leaving through each of the four adjacent faces.
    pub adjacent: f64,
}

impl FirstFlight {
    /// The fraction that collides in the cell again, `1 − back − opposite − 4 adjacent`
    /// (clamped at 0).
    #[must_use]
    pub fn recollided(&self) -> f64 {
        (1.0 - self.back - self.opposite - 4.0 * self.adjacent).max(0.0)
    }
}

/// `E₁(z)`, the exponential integral, for `z > 0` (series below 1, continued fraction
/// above; relative error ~1e-15).
fn e1(z: f64) -> f64 {
    if z <= 0.0 {
        return f64::INFINITY;
    }
    if z > 700.0 {
        return 0.0;
    }
    if z < 1.0 {
        const EULER: f64 = 0.577_215_664_901_532_9;
        let mut sum = 0.0;
        let mut term = 1.0;
        for k in 1..60 {
            term *= -z / k as f64;
            let t = -term / k as f64;
            sum += t;
            if t.abs() < 1e-17 * sum.abs() {
                break;
            }
        }
        -EULER - z.ln() + sum
    } else {
        // Modified Lentz on the continued fraction of e^z E₁(z).
        let tiny = 1e-300;
        let mut b = z + 1.0;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..200 {
            let an = -((i * i) as f64);
            b += 2.0;
            d = 1.0 / (an * d + b);
            c = b + an / c;
            let del = c * d;
            h *= del;
            if (del - 1.0).abs() < 1e-16 {
                break;
            }
        }
        h * (-z).exp()
    }
}

/// `∫_{u0}^{1} e^{−c/u} du` for `c ≥ 0`, `0 ≤ u0 ≤ 1`.
fn attenuated(c: f64, u0: f64) -> f64 {
    if c <= 0.0 {
        return 1.0 - u0;
    }
    let f = |u: f64| -> f64 {
        if u <= 0.0 {
            return 0.0;
        }
        let z = c / u;
        if z > 700.0 {
            0.0
        } else {
            u * (-z).exp() - c * e1(z)
        }
    };
    (f(1.0) - f(u0)).max(0.0)
}

/// Gauss nodes per angular piece of [`phi`].
const ANGLE_ORDER: usize = 4;

/// `E(h; x0, y0)`: `∫ e^{−a r} cos θ / r² dA` over the unit square `[0,1]²` from a
/// point at height `h ≥ 0` above `(x0, y0) ∈ [0,1]²` (sr).
fn phi(a: f64, h: f64, x0: f64, y0: f64, g: &GaussLegendre) -> f64 {
    // Four triangles from the foot to the edges: (perpendicular distance p, offsets of
    // the edge's ends along it).
    let edges = [
        (x0, -y0, 1.0 - y0),
        (1.0 - x0, -y0, 1.0 - y0),
        (y0, -x0, 1.0 - x0),
        (1.0 - y0, -x0, 1.0 - x0),
    ];
    let c = a * h;
    let mut total = 0.0;
    let mut cuts: Vec<f64> = Vec::with_capacity(32);
    for (p, s1, s2) in edges {
        if p <= 0.0 {
            continue;
        }
        if h <= 0.0 {
            total += s2.atan2(p) - s1.atan2(p);
            continue;
        }
        // Pieces along the edge: at 0, ±h (where cos θ_max changes fastest) and at
        // ±p·4^k (the angle compresses the edge's far parts when p is small), each
        // integrated in the angle by Gauss (pointwise error ~1e-6).
        cuts.clear();
        cuts.extend([s1, s2]);
        for t in [0.0, h, -h] {
            if t > s1 && t < s2 {
                cuts.push(t);
            }
        }
        let far = (-s1).max(s2);
        let mut q = p;
        while q < far {
            for t in [q, -q] {
                if t > s1 && t < s2 {
                    cuts.push(t);
                }
            }
            q *= 4.0;
        }
        cuts.sort_by(f64::total_cmp);
        for w in cuts.windows(2) {
            let (lo, hi) = (w[0].atan2(p), w[1].atan2(p));
            let (mid, half) = (0.5 * (lo + hi), 0.5 * (hi - lo));
            for (xi, wi) in g.nodes().iter().zip(g.weights()) {
                let f = mid + half * xi;
                let cf = f.cos();
                let u0 = h * cf / (h * h * cf * cf + p * p).sqrt();
                total += half * wi * attenuated(c, u0);
            }
        }
    }
    total
}

/// Nodes and weights on `[0, 1]`, symmetric under `t → 1 − t`, graded geometrically
/// towards both ends down to `min(1e-3, 0.02/a)`.
fn volume_rule(a: f64) -> (Vec<f64>, Vec<f64>) {
    const ORDER: usize = 4;
    const RATIO: f64 = 0.25;
    let smallest = 1e-3f64.min(0.02 / a.max(1e-300));
    let mut breaks = vec![0.5];
    while *breaks.last().unwrap_or(&0.0) > smallest {
        let b = breaks.last().copied().unwrap_or(0.0) * RATIO;
        breaks.push(b);
    }
    breaks.push(0.0);
    breaks.reverse();
    let g = GaussLegendre::new(ORDER).ok();
    let (mut t, mut w) = (Vec::new(), Vec::new());
    if let Some(g) = g {
        for iv in breaks.windows(2) {
            let (lo, hi) = (iv[0], iv[1]);
            for (xi, wi) in g.nodes().iter().zip(g.weights()) {
                t.push(0.5 * (lo + hi) + 0.5 * (hi - lo) * xi);
                w.push(0.5 * (hi - lo) * wi);
            }
        }
    }
    let n = t.len();
    for k in (0..n).rev() {
        t.push(1.0 - t[k]);
        w.push(w[k]);
    }
    (t, w)
}

/// The first-flight fractions of a cube of optical depth `a` per side, by quadrature
/// (module docs), and the quadrature's `∫_V E_0 dV` (exactly `Ĝ(a)/(6a)`; `4π/6` at
/// `a = 0`). `a = ∞` is not a medium: an opaque cell is a surface ([`routing`]); here
/// it returns the half-space's limit at `a = 1e4`.
#[must_use]
pub fn first_flight_quadrature(a: f64) -> (FirstFlight, f64) {
    let a = if a.is_finite() { a.max(0.0) } else { 1e4 };
    let (t, w) = volume_rule(a);
    let n = t.len();
    let Ok(g) = GaussLegendre::new(ANGLE_ORDER) else {
        return (
            FirstFlight {
                back: 0.0,
                opposite: 0.0,
                adjacent: 0.0,
            },
            0.0,
        );
    };
    // E on the nodes: e[h][u][v] = phi(h; t_u, t_v), symmetric in u ↔ v and under
    // mirroring u or v; computed on u ≤ v of the lower half and copied.
    let half = n / 2;
    let idx = |h: usize, u: usize, v: usize| (h * n + u) * n + v;
    let rows: Vec<Vec<f64>> = {
        use rayon::prelude::*;
        (0..n)
            .into_par_iter()
            .map(|h| {
                let mut row = vec![0.0; n * n];
                for u in 0..half {
                    for v in u..half {
                        let val = phi(a, t[h], t[u], t[v], &g);
                        for (uu, vv) in [
                            (u, v),
                            (v, u),
                            (n - 1 - u, v),
                            (v, n - 1 - u),
                            (u, n - 1 - v),
                            (n - 1 - v, u),
                            (n - 1 - u, n - 1 - v),
                            (n - 1 - v, n - 1 - u),
                        ] {
                            row[uu * n + vv] = val;
                        }
                    }
                }
                row
            })
            .collect()
    };
    let e: Vec<f64> = rows.into_iter().flatten().collect();
    let (mut norm, mut back, mut opp, mut adj) = (0.0, 0.0, 0.0, 0.0);
    for x in 0..n {
        for y in 0..n {
            for z in 0..n {
                let wt = w[x] * w[y] * w[z];
                // Entry face x = 0 at the point (t_x, t_y, t_z).
                let e0 = e[idx(x, y, z)];
                norm += wt * e0;
                back += wt * e0 * e0;
                opp += wt * e0 * e[idx(n - 1 - x, y, z)];
                adj += wt * e0 * e[idx(y, x, z)];
            }
        }
    }
    let d = 4.0 * PI * norm;
    (
        FirstFlight {
            back: back / d,
            opposite: opp / d,
            adjacent: adj / d,
        },
        norm,
    )
}

/// Table range of [`first_flight_fast`]: `ln a` from `ln 1e-3` to `ln 40` (`σ = 1 −
/// e^{−a}` rounds to 1 from `a ≈ 37`), 8 nodes per decade.
const TABLE_LO: f64 = -3.0;
const TABLE_HI: f64 = 1.602_059_991_327_962_4; // log10(40)
const TABLE_PER_DECADE: f64 = 4.0;

fn table() -> &'static (Vec<FirstFlight>, FirstFlight) {
    static TABLE: OnceLock<(Vec<FirstFlight>, FirstFlight)> = OnceLock::new();
    TABLE.get_or_init(|| {
        let count = ((TABLE_HI - TABLE_LO) * TABLE_PER_DECADE).ceil() as usize + 1;
        let nodes = (0..count)
            .map(|i| {
                let a = 10f64.powf(TABLE_LO + i as f64 / TABLE_PER_DECADE);
                first_flight_quadrature(a).0
            })
            .collect();
        (nodes, first_flight_quadrature(0.0).0)
    })
}

/// [`first_flight_quadrature`]'s fractions from a table: cubic (Catmull–Rom)
/// interpolation in `log10 a` at 4 nodes per decade on `[1e-3, 40]`, linear in `a`
/// from the thin limit below `1e-3`, the last node above 40 (absolute error < 3e-4,
/// tested). Computed once per process (20 quadratures, a few seconds at opt-level 1),
/// and only when some cell scatters.
#[must_use]
pub fn first_flight_fast(a: f64) -> FirstFlight {
    let (nodes, thin) = table();
    let count = nodes.len();
    if a <= 0.0 || count < 4 {
        return *thin;
    }
    let lo = 10f64.powf(TABLE_LO);
    if a <= lo {
        let f = a / lo;
        let mix = |x: f64, y: f64| (1.0 - f) * x + f * y;
        return FirstFlight {
            back: mix(thin.back, nodes[0].back),
            opposite: mix(thin.opposite, nodes[0].opposite),
            adjacent: mix(thin.adjacent, nodes[0].adjacent),
        };
    }
    let x = (a.log10() - TABLE_LO) * TABLE_PER_DECADE;
    if x >= (count - 1) as f64 {
        return nodes[count - 1];
    }
    let i = x.floor() as usize;
    let f = x - i as f64;
    let at = |k: isize| nodes[k.clamp(0, count as isize - 1) as usize];
    let (p0, p1, p2, p3) = (
        at(i as isize - 1),
        at(i as isize),
        at(i as isize + 1),
        at(i as isize + 2),
    );
    let cr = |a0: f64, a1: f64, a2: f64, a3: f64| {
        let (f2, f3) = (f * f, f * f * f);
        0.5 * (2.0 * a1
            + (a2 - a0) * f
            + (2.0 * a0 - 5.0 * a1 + 4.0 * a2 - a3) * f2
            + (3.0 * a1 - a0 - 3.0 * a2 + a3) * f3)
    };
    FirstFlight {
        back: cr(p0.back, p1.back, p2.back, p3.back),
        opposite: cr(p0.opposite, p1.opposite, p2.opposite, p3.opposite),
        adjacent: cr(p0.adjacent, p1.adjacent, p2.adjacent, p3.adjacent),
    }
}

/// How one cell turns the power `C_i` it collides from other cells through entry face
/// `i` into collisions and outgoing face powers, per channel. Faces are symmetric, so
/// the 6×6 routing has three values: the same face, the opposite face, each adjacent
/// face.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Routing {
    /// Total collisions (re-collisions in the cell included) per unit of `C_i`.
    pub multiplier: f64,
    /// Power leaving through the entry face per unit of *total* collisions through it
    /// (albedo included).
    pub back: f64,
    /// Leaving through the opposite face, per unit of total collisions.
    pub opposite: f64,
    /// Leaving through each adjacent face, per unit of total collisions.
    pub adjacent: f64,
}

impl Routing {
    /// The 6×6 matrix `R[i][j]` (faces `+x, −x, +y, −y, +z, −z`): power leaving through
    /// face `j` per unit of total collisions through face `i`.
    #[must_use]
    pub fn matrix(&self) -> [[f64; 6]; 6] {
        std::array::from_fn(|i| {
            std::array::from_fn(|j| {
                if i == j {
                    self.back
                } else if i / 2 == j / 2 {
                    self.opposite
                } else {
                    self.adjacent
                }
            })
        })
    }

    /// What leaves per unit of total collisions, `back + opposite + 4 adjacent`
    /// (the rest is absorbed: `1 − ω` of every collision).
    #[must_use]
    pub fn leaving(&self) -> f64 {
        self.back + self.opposite + 4.0 * self.adjacent
    }
}

/// The routing of a cell of opacity `sigma` (`σ = 1 − e^{−A}`) and albedo `omega` (one
/// channel) under the Γ convention `mode` and the self-interaction `si`:
///
/// * [`GammaMode::FirstFlight`]: light collided through face `i` scatters
///   (`ω`) along [`FirstFlight`]; the re-collided part `s` scatters again as light
///   born uniformly in the cell (re-collides with `π`, leaves evenly): total
///   collisions `1 + ω s/(1 − ω π)` per first collision. With
///   [`SelfInteraction::None`] the re-collided part leaves along the first-flight
///   fractions instead (`Γ_ij / (1 − s)`).
/// * [`GammaMode::Normalized`] (default) / [`GammaMode::Printed`]: `Γ_ii = σ` (or 1), `Γ_ij =
///   (1 − σ) F_ij`, scattered light re-collides with `π` (total `1/(1 − ω π)`), the
///   rest leaves along Γ.
///
/// An opaque cell (`σ ≥ 1`) is a Lambertian surface in every convention: `ω` of what
/// it collides leaves through the face it was collided on.
#[must_use]
pub fn routing(sigma: f64, omega: f64, mode: GammaMode, si: SelfInteraction) -> Routing {
    let a = crate::cell::depth_of(sigma);
    let pi = match si {
        SelfInteraction::Uniform => crate::cell::self_collision(a),
        SelfInteraction::None => 0.0,
    };
    if sigma >= 1.0 || omega == 0.0 {
        return Routing {
            multiplier: 1.0,
            back: omega,
            opposite: 0.0,
            adjacent: 0.0,
        };
    }
    match mode {
        GammaMode::FirstFlight => {
            let ff = first_flight_fast(a);
            let s = ff.recollided();
            match si {
                SelfInteraction::Uniform => {
                    let q = omega * s * (1.0 - pi) / (6.0 * (1.0 - omega * pi));
                    let m = 1.0 + omega * s / (1.0 - omega * pi);
                    Routing {
                        multiplier: m,
                        back: omega * (ff.back + q) / m,
                        opposite: omega * (ff.opposite + q) / m,
                        adjacent: omega * (ff.adjacent + q) / m,
                    }
                }
                SelfInteraction::None => {
                    let l = (1.0 - s).max(f64::MIN_POSITIVE);
                    Routing {
                        multiplier: 1.0,
                        back: omega * ff.back / l,
                        opposite: omega * ff.opposite / l,
                        adjacent: omega * ff.adjacent / l,
                    }
                }
            }
        }
        GammaMode::Normalized | GammaMode::Printed => {
            let own = if mode == GammaMode::Printed {
                1.0
            } else {
                sigma
            };
            let leave = omega * (1.0 - pi);
            Routing {
                multiplier: 1.0 / (1.0 - omega * pi),
                back: leave * own,
                opposite: leave * (1.0 - sigma) * form_factor_opposite(),
                adjacent: leave * (1.0 - sigma) * form_factor_adjacent(),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cell::{Collision, total_weight};

    #[test]
    fn exponential_integral_on_both_branches() {
        // E₁(z) reference values (Abramowitz & Stegun table 5.1).
        for (z, want) in [
            (0.1, 1.822_923_958_419_39),
            (0.5, 0.559_773_594_776_16),
            (1.0, 0.219_383_934_395_52),
            (2.0, 0.048_900_510_708_06),
            (5.0, 0.001_148_295_591_275_3),
        ] {
            assert!((e1(z) / want - 1.0).abs() < 1e-12, "E1({z}) = {}", e1(z));
        }
    }

    #[test]
    fn attenuated_solid_angle_matches_brute_force() {
        // A point above the unit square: midpoint rule over the square.
        let (a, h, x0, y0) = (1.3, 0.2, 0.3, 0.8);
        let g = GaussLegendre::new(ANGLE_ORDER).unwrap();
        let got = phi(a, h, x0, y0, &g);
        let m = 1500;
        let mut s = 0.0;
        for i in 0..m {
            for j in 0..m {
                let (x, y) = ((i as f64 + 0.5) / m as f64, (j as f64 + 0.5) / m as f64);
                let r2 = (x - x0).powi(2) + (y - y0).powi(2) + h * h;
                let r = r2.sqrt();
                s += (-a * r).exp() * h / (r2 * r);
            }
        }
        s /= (m * m) as f64;
        assert!((got / s - 1.0).abs() < 1e-4, "{got} vs {s}");
        // Inside the cube the six faces' solid angles (A = 0) sum to 4π.
        let sum = phi(0.0, 0.01, 0.5, 0.3, &g)
            + phi(0.0, 0.99, 0.5, 0.3, &g)
            + phi(0.0, 0.5, 0.01, 0.3, &g)
            + phi(0.0, 0.5, 0.99, 0.3, &g)
            + phi(0.0, 0.3, 0.01, 0.5, &g)
            + phi(0.0, 0.7, 0.01, 0.5, &g);
        assert!((sum / (4.0 * PI) - 1.0).abs() < 1e-5, "{sum}");
        // On the face: the full hemisphere of the square, 2π.
        assert!((phi(a, 0.0, x0, y0, &g) - 2.0 * PI).abs() < 1e-12);
    }

    #[test]
    fn quadrature_collides_the_exact_weight() {
        // ∫ A E_0 dV over the cube is the entry face's share of Ĝ (A = 0: 4π/6).
        let (_, n0) = first_flight_quadrature(0.0);
        assert!((n0 / (4.0 * PI / 6.0) - 1.0).abs() < 1e-4, "{n0}");
        for a in [0.01, 0.3, 1.25, 5.0, 30.0] {
            let (ff, n) = first_flight_quadrature(a);
            let want = total_weight(a, Collision::Exact) / (6.0 * a);
            assert!((n / want - 1.0).abs() < 5e-4, "A {a}: {n} vs {want}");
            let s = ff.recollided();
            assert!((0.0..1.0).contains(&s), "A {a}: {ff:?}");
        }
    }

    #[test]
    fn thin_limit_leaves_everything_and_thick_limit_returns_by_the_entry_face() {
        let (thin, _) = first_flight_quadrature(0.0);
        assert!(thin.recollided() < 1e-4, "{thin:?}");
        // Light collided near the entry face leaves by it more often than by the
        // opposite one.
        assert!(thin.back > thin.adjacent && thin.adjacent > thin.opposite);
        let (thick, _) = first_flight_quadrature(30.0);
        assert!(thick.opposite < 1e-6 && thick.adjacent < 0.01, "{thick:?}");
        // A half-space: a fifth leaves by the entry face after one scattering.
        assert!(thick.back > 0.15 && thick.recollided() > 0.7, "{thick:?}");
    }

    /// Monte Carlo first flights through the face `z = 0` of the unit cube: cosine-
    /// weighted entry, exponential flight, isotropic scattering, exit face or second
    /// collision. Fractions (back, opposite, adjacent each, recollided) and the number
    /// of first collisions.
    fn first_flight_mc(a: f64, paths: usize, seed: u64) -> ([f64; 4], f64) {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
        let exit = |p: [f64; 3], d: [f64; 3]| -> (f64, usize) {
            let mut best = (f64::INFINITY, 0);
            for k in 0..3 {
                let (t, face) = if d[k] > 0.0 {
                    ((1.0 - p[k]) / d[k], 2 * k)
                } else if d[k] < 0.0 {
                    (-p[k] / d[k], 2 * k + 1)
                } else {
                    continue;
                };
                if t < best.0 {
                    best = (t, face);
                }
            }
            best
        };
        let (mut collided, mut counts) = (0usize, [0usize; 6]);
        for _ in 0..paths {
            let (u1, u2): (f64, f64) = (rng.random(), rng.random());
            let (ct, ph) = (u1.sqrt(), 2.0 * PI * u2);
            let st = (1.0 - ct * ct).sqrt();
            let d = [st * ph.cos(), st * ph.sin(), ct];
            let p = [rng.random::<f64>(), rng.random::<f64>(), 0.0];
            let t = -(1.0 - rng.random::<f64>()).ln() / a;
            if t >= exit(p, d).0 {
                continue;
            }
            collided += 1;
            let x = [p[0] + t * d[0], p[1] + t * d[1], p[2] + t * d[2]];
            let z: f64 = 2.0 * rng.random::<f64>() - 1.0;
            let phi2 = 2.0 * PI * rng.random::<f64>();
            let r = (1.0 - z * z).sqrt();
            let v = [r * phi2.cos(), r * phi2.sin(), z];
            let t2 = -(1.0 - rng.random::<f64>()).ln() / a;
            let (s2, face) = exit(x, v);
            if t2 >= s2 {
                counts[face] += 1;
            }
        }
        let c = collided as f64;
        // Entry face z = 0 is −z (5); opposite +z (4); adjacent the four others.
        let back = counts[5] as f64 / c;
        let opposite = counts[4] as f64 / c;
        let adjacent = counts[..4].iter().sum::<usize>() as f64 / (4.0 * c);
        (
            [
                back,
                opposite,
                adjacent,
                1.0 - back - opposite - 4.0 * adjacent,
            ],
            c,
        )
    }

    #[test]
    fn quadrature_agrees_with_monte_carlo_first_flights() {
        // Independent estimator: 400 000 entering paths; 5 standard errors of a
        // fraction of the first collisions.
        for (a, seed) in [(0.3, 1u64), (1.25, 2), (6.0, 3)] {
            let (mc, n) = first_flight_mc(a, 400_000, seed);
            let (q, _) = first_flight_quadrature(a);
            let got = [q.back, q.opposite, q.adjacent, q.recollided()];
            eprintln!("A {a}: quadrature {got:.4?} Monte Carlo {mc:.4?}");
            for k in 0..4 {
                let p = mc[k].clamp(1e-4, 1.0);
                let se = (p * (1.0 - p) / n).sqrt();
                assert!(
                    (got[k] - mc[k]).abs() < 5.0 * se + 1e-4,
                    "A {a} entry {k}: {} vs {}",
                    got[k],
                    mc[k]
                );
            }
        }
    }

    #[test]
    fn table_follows_the_quadrature() {
        for a in [0.0, 2e-4, 0.0123, 0.77, 1.25, 3.3, 17.0, 39.0] {
            let (q, _) = first_flight_quadrature(a);
            let f = first_flight_fast(a);
            for (x, y) in [
                (q.back, f.back),
                (q.opposite, f.opposite),
                (q.adjacent, f.adjacent),
            ] {
                assert!((x - y).abs() < 3e-4, "A {a}: {q:?} vs {f:?}");
            }
        }
    }

    #[test]
    fn every_routing_conserves_energy() {
        for mode in [
            GammaMode::FirstFlight,
            GammaMode::Normalized,
            GammaMode::Printed,
        ] {
            for si in [SelfInteraction::Uniform, SelfInteraction::None] {
                for sigma in [0.0, 1e-6, 0.2, 0.7135, 0.99, 1.0] {
                    for w in [0.0, 0.5, 0.99, 0.999] {
                        let r = routing(sigma, w, mode, si);
                        // Per unit collided from outside: absorbed (1 − ω) and leaving
                        // of every collision, re-collisions included, give it back.
                        let total = ((1.0 - w) + r.leaving()) * r.multiplier;
                        let pi = match si {
                            SelfInteraction::Uniform => {
                                crate::cell::self_collision(crate::cell::depth_of(sigma))
                            }
                            SelfInteraction::None => 0.0,
                        };
                        let want = if mode == GammaMode::Printed && sigma < 1.0 {
                            // Printed: Γ_ii = 1 creates (1 − σ) of what leaves.
                            1.0 + w * (1.0 - pi) * (1.0 - sigma) / (1.0 - w * pi)
                        } else {
                            1.0
                        };
                        assert!(
                            (total - want).abs() < 1e-12,
                            "{mode:?} {si:?} σ {sigma} ω {w}: {total} vs {want}"
                        );
                        assert!(r.multiplier >= 1.0 && r.multiplier.is_finite());
                    }
                }
            }
        }
    }
}
