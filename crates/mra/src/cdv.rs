//! The Cohen–Daubechies–Vial MRA on [0, 1] derived from Daubechies' D4 (Ziegler §3.1.3,
//! after Cohen–Daubechies–Vial 1993, `cohe93a`), boundary functions included.
//!
//! Notation: `φ` is the D4 scaling function shifted to the support `[-1, 2]`,
//! `φ(x) = √2 Σ_{p=-1}^{2} h_p φ(2x − p)`, with Ziegler's `h_0..h_3` as `h_{-1}..h_2`;
//! `ψ(x) = √2 Σ_p g_p φ(2x − p)`, `g_p = (−1)^p h_{1−p}` (Ziegler: `g_0 = −h_3`, …).
//! Level `j` has `L = 2^j ≥ 4` scaling functions: left edge functions `k = 0, 1`,
//! interior `φ_{j,k}(x) = 2^{j/2} φ(2^j x − k)` for `2 ≤ k < L − 2`, right edge functions
//! `k = L − 2, L − 1`; the same for wavelets (Ziegler: interior indices
//! `2 ≤ k < n_m − 2`).
//!
//! Construction of the left edge (the right edge is the same construction for the
//! reflected function `φ̄(t) = φ(−t)`, whose filter is `h` reversed). On the half line,
//! with `u_n = φ(· − n)|_{[0,∞)}`:
//! 1. the half-line Gram matrix `A_{n,m} = ∫_0^∞ u_n u_m` of the two straddling
//!    translates is the solution of the linear system given by the refinement equation
//!    (`A_{n,m} = Σ_{p,q} h_p h_q A_{2n+p, 2m+q}`, with `A = δ` for translates inside
//!    `[0, ∞)` and `0` for translates outside) — exact, no quadrature;
//! 2. the edge space is `{Σ_{n=-1}^{1} P(n) u_n : P linear}`, which together with the
//!    interior translates reproduces linear functions (D4 has two vanishing moments);
//!    the first edge function uses `P(n) = 1 − n` (support `[0, 2]`), the second is
//!    Gram–Schmidt of `P = 1` against it (support `[0, 3]`) — this is the staggered-
//!    support basis whose rows have 3 and 5 entries as in Ziegler's table;
//! 3. refinement rows are inner products with the orthonormal level-1 basis, computed
//!    from `A`; edge wavelets are the orthogonal complement of the edge scaling functions
//!    in the span of the first five level-1 functions that is also orthogonal to the
//!    first interior scaling function and wavelet: the first wavelet lives on the first
//!    three children (3 coefficients), the second on five.
//!
//! Signs follow Ziegler's table. Checked against that table (see the tests): all left
//! scaling and left wavelet rows and the right scaling rows agree to all printed digits
//! except the printing quirks listed in `tests`; the right wavelet rows are printed
//! with swapped labels.
//!
//! Point values: `φ` is tabulated exactly (up to rounding) at all dyadic points
//! `i 2^-16` from its values at the integers (eigenvector of the refinement matrix) by
//! the two-scale relation; edge functions and wavelets are finite combinations of those
//! values. Evaluation of a level-`j` function is exact at points `i 2^-(j+15)` and uses
//! linear interpolation in between (D4 is only Hölder-0.55 continuous, so the
//! interpolation error can reach ~1e-3 relative between grid points).
//!
//! Projection onto `V_j` does not use point values: [`Cdv::legendre_products`] gives
//! the exact inner products of the CDV scaling functions with Legendre polynomials on
//! dyadic cells (from exact cell moments of `φ`, again via the refinement equation), so
//! a piecewise-polynomial approximation of `f` is projected exactly.

use crate::linalg::{complement_vector, dotv, solve};
use crate::poly::{binom, shifted_legendre_coeffs};
use crate::{FilterRow, MAX_LEVEL, Mra, MraError, check_step_lengths, dot};

/// Table resolution: `φ` values at `i 2^-TABLE_BITS`.
const TABLE_BITS: u32 = 16;
/// Extra levels used by projection (see [`Mra::projection_plan`]).
pub const PROJECTION_EXTRA_LEVELS: u32 = 3;
/// Legendre polynomials per cell used by projection.
pub const PROJECTION_LEGENDRE: usize = 6;
/// Largest Legendre degree for which cell products are tabulated.
pub const MAX_LEGENDRE: usize = 11;

/// One edge (left, or right in reflected coordinates) of the CDV construction.
#[derive(Debug, Clone, PartialEq)]
struct Edge {
    /// Coefficients of the two edge scaling functions on the generators `u_n`,
    /// `n = n0, n0+1, n0+2` (half-line coordinates of that edge).
    gens_c: [[f64; 3]; 2],
    /// First generator index (`-1` left, `0` reflected right).
    n0: i32,
    /// Rows in local level-1 coordinates (edge0, edge1, interior i0, i1, i2).
    h: [[f64; 5]; 2],
    /// Wavelet rows in the same coordinates.
    g: [[f64; 5]; 2],
    /// First interior index of the half-line (2 left, 3 right-reflected).
    first_interior: i32,
}

/// The CDV (Cohen–Daubechies–Vial) MRA on [0, 1] from Daubechies D4: 2 vanishing
/// moments, linear functions reproduced exactly, continuous functions.
#[derive(Debug, Clone, PartialEq)]
pub struct Cdv {
    h: [f64; 4],
    g: [f64; 4],
    left: Edge,
    right: Edge,
    /// Right-edge rows in increasing child order, for global index `L-1-e`:
    /// `(scaling, wavelet)` each `(len, coeffs)`.
    right_rows_h: [[f64; 5]; 2],
    right_rows_g: [[f64; 5]; 2],
    /// `φ(-1 + i 2^-TABLE_BITS)`, `i = 0..=3·2^TABLE_BITS`.
    table: Vec<f64>,
    /// `∫_0^1 L_a(s) φ(n + s) ds` for cell `n = -1, 0, 1` (index n+1), `a ≤ MAX_LEGENDRE`.
    cell_legendre: [[f64; MAX_LEGENDRE + 1]; 3],
}

impl Default for Cdv {
    fn default() -> Self {
        Self::new()
    }
}

impl Cdv {
    /// Builds the MRA (filters, edge functions and point-value tables; a few ms).
    #[must_use]
    pub fn new() -> Self {
        let s3 = 3f64.sqrt();
        let d = 4.0 * std::f64::consts::SQRT_2;
        // Ziegler §3.1.3: h_0..h_3, here indexed p = -1..2.
        let h = [
            (1.0 + s3) / d,
            (3.0 + s3) / d,
            (3.0 - s3) / d,
            (1.0 - s3) / d,
        ];
        // g_p = (-1)^p h_{1-p}: p=-1: -h_2, p=0: h_1, p=1: -h_0, p=2: h_{-1}.
        let g = [-h[3], h[2], -h[1], h[0]];
        let left = build_edge(h, g, -1);
        let hr = [h[3], h[2], h[1], h[0]];
        let gr = [g[3], g[2], g[1], g[0]];
        let right = build_edge(hr, gr, -2);
        let mut right_rows_h = [[0.0; 5]; 2];
        let mut right_rows_g = [[0.0; 5]; 2];
        for e in 0..2 {
            let len = if e == 0 { 3 } else { 5 };
            for i in 0..len {
                right_rows_h[e][i] = right.h[e][len - 1 - i];
                right_rows_g[e][i] = right.g[e][len - 1 - i];
            }
        }
        let table = phi_table(&h);
        let cell_legendre = cell_legendre_products(&h);
        Self {
            h,
            g,
            left,
            right,
            right_rows_h,
            right_rows_g,
            table,
            cell_legendre,
        }
    }

    /// The D4 taps `h_{-1..2}` (Ziegler's `h_0..h_3`).
    #[must_use]
    pub fn interior_scaling_taps(&self) -> [f64; 4] {
        self.h
    }

    /// The D4 wavelet taps `g_{-1..2}` (Ziegler's `g_0..g_3`).
    #[must_use]
    pub fn interior_wavelet_taps(&self) -> [f64; 4] {
        self.g
    }

    /// Left boundary rows as in Ziegler's table: `(scaling rows, wavelet rows)`, row
    /// `e` for `k = e`, coefficients on children `l = 0..3` (`e = 0`) and `l = 0..5`
    /// (`e = 1`, trailing entries of row 0 are zero).
    #[must_use]
    pub fn left_rows(&self) -> ([[f64; 5]; 2], [[f64; 5]; 2]) {
        (self.left.h, self.left.g)
    }

    /// Right boundary rows ordered as in Ziegler's table: row `e` is the function
    /// `k = n − 1 − e`, coefficient `i` is on child `l = n' − 1 − i` (`n`, `n'` the
    /// numbers of functions on the two levels).
    #[must_use]
    pub fn right_rows(&self) -> ([[f64; 5]; 2], [[f64; 5]; 2]) {
        (self.right.h, self.right.g)
    }

    /// Value of the shifted D4 `φ` (support [-1, 2]) at `t`; exact on the dyadic grid
    /// `2^-16`, linear interpolation between.
    #[must_use]
    pub fn phi(&self, t: f64) -> f64 {
        if !(t > -1.0 && t < 2.0) {
            return 0.0;
        }
        let pos = (t + 1.0) * (1u64 << TABLE_BITS) as f64;
        let i = pos.floor() as usize;
        let f = pos - i as f64;
        let a = self.table[i];
        if f == 0.0 || i + 1 >= self.table.len() {
            a
        } else {
            a + f * (self.table[i + 1] - a)
        }
    }

    /// Level-0 shape of an edge scaling function in its half-line coordinate.
    fn edge_phi(&self, edge: &Edge, reflected: bool, e: usize, y: f64) -> f64 {
        if y < 0.0 {
            return 0.0;
        }
        let mut s = 0.0;
        for (i, &c) in edge.gens_c[e].iter().enumerate() {
            let n = (edge.n0 + i as i32) as f64;
            s += c * if reflected {
                self.phi(n - y)
            } else {
                self.phi(y - n)
            };
        }
        s
    }

    /// Level-0 shape of an edge wavelet in its half-line coordinate.
    fn edge_psi(&self, edge: &Edge, reflected: bool, e: usize, y: f64) -> f64 {
        if y < 0.0 {
            return 0.0;
        }
        let w = &edge.g[e];
        let y2 = 2.0 * y;
        let mut s = w[0] * self.edge_phi(edge, reflected, 0, y2)
            + w[1] * self.edge_phi(edge, reflected, 1, y2);
        for i in 0..3 {
            let m = (edge.first_interior + i as i32) as f64;
            let v = if reflected {
                self.phi(m - y2)
            } else {
                self.phi(y2 - m)
            };
            s += w[2 + i] * v;
        }
        std::f64::consts::SQRT_2 * s
    }

    fn interior_psi(&self, t: f64) -> f64 {
        let mut s = 0.0;
        for (i, &gp) in self.g.iter().enumerate() {
            s += gp * self.phi(2.0 * t - (i as f64 - 1.0));
        }
        std::f64::consts::SQRT_2 * s
    }

    fn eval(&self, level: u32, k: usize, x: f64, wavelet: bool) -> Result<f64, MraError> {
        self.check_index(level, k)?;
        if !x.is_finite() {
            return Err(MraError::NonFinite("evaluation point"));
        }
        if !(0.0..=1.0).contains(&x) {
            return Ok(0.0);
        }
        let n = 1usize << level;
        let scale = (0.5 * level as f64).exp2();
        let t = x * n as f64;
        let v = if k < 2 {
            if wavelet {
                self.edge_psi(&self.left, false, k, t)
            } else {
                self.edge_phi(&self.left, false, k, t)
            }
        } else if k >= n - 2 {
            let e = n - 1 - k;
            let y = n as f64 - t;
            if wavelet {
                self.edge_psi(&self.right, true, e, y)
            } else {
                self.edge_phi(&self.right, true, e, y)
            }
        } else if wavelet {
            self.interior_psi(t - k as f64)
        } else {
            self.phi(t - k as f64)
        };
        Ok(scale * v)
    }

    /// See [`Mra::legendre_products`]; level-independent (only cell offsets move).
    fn legendre_products_impl(
        &self,
        level: u32,
        k: usize,
        n_legendre: usize,
        f: &mut dyn FnMut(usize, usize, f64),
    ) -> Result<(), MraError> {
        self.check_index(level, k)?;
        if n_legendre > MAX_LEGENDRE + 1 {
            return Err(MraError::InvalidParameter("n_legendre > 12"));
        }
        let n = 1usize << level;
        let t = &self.cell_legendre;
        if k >= 2 && k < n - 2 {
            for (off, row) in t.iter().enumerate() {
                let c = k + off - 1;
                for (a, &v) in row.iter().enumerate().take(n_legendre) {
                    f(c, a, v);
                }
            }
            return Ok(());
        }
        let (edge, e, reflected) = if k < 2 {
            (&self.left, k, false)
        } else {
            (&self.right, n - 1 - k, true)
        };
        for m in 0..3i32 {
            let c = if reflected {
                n - 1 - m as usize
            } else {
                m as usize
            };
            for a in 0..n_legendre {
                let mut s = 0.0;
                for (i, &cn) in edge.gens_c[e].iter().enumerate() {
                    let ng = edge.n0 + i as i32;
                    // Left: <phi(.-n), L_a(cell m)> = T[m-n]; reflected: T[n-m-1].
                    let off = if reflected { ng - m - 1 } else { m - ng };
                    if (-1..=1).contains(&off) {
                        s += cn * t[(off + 1) as usize][a];
                    }
                }
                f(c, a, s);
            }
        }
        Ok(())
    }
}

/// Half-line Gram value `∫_0^∞ φ(x−x1) φ(x−x2)` given the unknown block.
fn gram_get(a: i32, sx: i32, inside: i32, x: i32, y: i32, unknown: &[f64]) -> f64 {
    // Translates with index < sx vanish on [0,∞); index >= inside lie inside.
    if x < sx || y < sx {
        return 0.0;
    }
    if x >= inside || y >= inside {
        return f64::from(u8::from(x == y));
    }
    let _ = a;
    let w = (inside - sx) as usize;
    unknown[(x - sx) as usize * w + (y - sx) as usize]
}

/// The edge construction for taps `t_p`, `p = a..a+3` (support `[a, a+3]`).
fn build_edge(t: [f64; 4], tg: [f64; 4], a: i32) -> Edge {
    let b = a + 3;
    let sx = 1 - b; // first straddling translate
    let inside = -a; // first translate inside [0, inf)
    let w = (inside - sx) as usize; // number of straddling translates (2)
    // Linear system for the unknown Gram block (w*w entries).
    let nn = w * w;
    let mut mat = vec![0.0; nn * nn];
    let mut rhs = vec![0.0; nn];
    for n in 0..w {
        for m in 0..w {
            let row = n * w + m;
            mat[row * nn + row] += 1.0;
            let (gn, gm) = (sx + n as i32, sx + m as i32);
            for (p, &tp) in t.iter().enumerate() {
                for (q, &tq) in t.iter().enumerate() {
                    let x = 2 * gn + a + p as i32;
                    let y = 2 * gm + a + q as i32;
                    if x < sx || y < sx {
                        continue;
                    }
                    if x >= inside || y >= inside {
                        rhs[row] += tp * tq * f64::from(u8::from(x == y));
                    } else {
                        let col = (x - sx) as usize * w + (y - sx) as usize;
                        mat[row * nn + col] -= tp * tq;
                    }
                }
            }
        }
    }
    let unknown = solve(mat, rhs).expect("half-line Gram system is regular for D4");
    let gram = |x: i32, y: i32| gram_get(a, sx, inside, x, y, &unknown);
    // Generators n = sx..=inside (3 of them).
    let n0 = sx;
    let gens: Vec<i32> = (sx..=inside).collect();
    let inner = |c1: &[f64], c2: &[f64]| {
        let mut s = 0.0;
        for (i, &x) in gens.iter().enumerate() {
            for (j, &y) in gens.iter().enumerate() {
                s += c1[i] * c2[j] * gram(x, y);
            }
        }
        s
    };
    let e0: Vec<f64> = gens.iter().map(|&n| f64::from(inside - n)).collect();
    let n_e0 = inner(&e0, &e0).sqrt();
    let c0: Vec<f64> = e0.iter().map(|x| x / n_e0).collect();
    let e1 = vec![1.0; gens.len()];
    let p = inner(&e1, &c0);
    let r1: Vec<f64> = e1.iter().zip(&c0).map(|(x, y)| x - p * y).collect();
    let n_r1 = inner(&r1, &r1).sqrt();
    let c1: Vec<f64> = r1.iter().map(|x| x / n_r1).collect();
    let gens_c = [[c0[0], c0[1], c0[2]], [c1[0], c1[1], c1[2]]];
    // Refinement: phi^E_k = sum_n c_{k,n} sqrt2 sum_p t_p u1_{2n+p}.
    let first_interior = inside + 1;
    let mut hrows = [[0.0; 5]; 2];
    for (k, ck) in gens_c.iter().enumerate() {
        // a_{k,m} over m from 2*sx + a .. 2*inside + b.
        let m_lo = 2 * sx + a;
        let m_hi = 2 * inside + b;
        let mut am = vec![0.0; (m_hi - m_lo + 1) as usize];
        for (i, &n) in gens.iter().enumerate() {
            for (pi, &tp) in t.iter().enumerate() {
                let m = 2 * n + a + pi as i32;
                am[(m - m_lo) as usize] += std::f64::consts::SQRT_2 * ck[i] * tp;
            }
        }
        // Edge coordinates: <phi^E_k, b_i> = sum_{m,n} a_m sqrt2 c_{i,n} A(m,n)/2.
        for (i, ci) in gens_c.iter().enumerate() {
            let mut s = 0.0;
            for (mi, &amv) in am.iter().enumerate() {
                let m = m_lo + mi as i32;
                for (ni, &n) in gens.iter().enumerate() {
                    s += amv * std::f64::consts::SQRT_2 * ci[ni] * gram(m, n) * 0.5;
                }
            }
            hrows[k][i] = s;
        }
        for j in 0..3 {
            let m = first_interior + j;
            hrows[k][2 + j as usize] = am[(m - m_lo) as usize] * std::f64::consts::FRAC_1_SQRT_2;
        }
        let norm2 = dotv(&hrows[k], &hrows[k]);
        debug_assert!(
            (norm2 - 1.0).abs() < 1e-12,
            "edge row not complete: {norm2}"
        );
        // Children beyond the local five must carry no weight.
        for m in first_interior + 3..=m_hi {
            debug_assert!(am[(m - m_lo) as usize].abs() < 1e-12);
        }
    }
    // Wavelets.
    let v_h = [0.0, 0.0, 0.0, t[0], t[1]];
    let c3 = |r: &[f64; 5]| vec![r[0], r[1], r[2]];
    let w0 = complement_vector(&[c3(&hrows[0]), c3(&hrows[1])], 3);
    let w0 = [w0[0], w0[1], w0[2], 0.0, 0.0];
    let w1 = complement_vector(
        &[
            hrows[0].to_vec(),
            hrows[1].to_vec(),
            v_h.to_vec(),
            w0.to_vec(),
        ],
        5,
    );
    let mut g0 = w0;
    let mut g1 = [w1[0], w1[1], w1[2], w1[3], w1[4]];
    // Signs as in Ziegler's table: first wavelet's first coefficient negative (left) /
    // its first coefficient negative in reflected order too; second wavelet's last
    // interior coefficient with the sign of the matching interior wavelet tap.
    if g0[0] > 0.0 {
        g0.iter_mut().for_each(|x| *x = -*x);
    }
    let _ = tg;
    if a == -1 {
        if g1[4] < 0.0 {
            g1.iter_mut().for_each(|x| *x = -*x);
        }
    } else if g1[0] < 0.0 {
        g1.iter_mut().for_each(|x| *x = -*x);
    }
    for r in [&mut g0, &mut g1] {
        r.iter_mut().for_each(|x| {
            if x.abs() < 1e-15 {
                *x = 0.0;
            }
        });
    }
    Edge {
        gens_c,
        n0,
        h: hrows,
        g: [g0, g1],
        first_interior,
    }
}

/// `φ` at `-1 + i 2^-TABLE_BITS` by the two-scale relation from its integer values.
fn phi_table(h: &[f64; 4]) -> Vec<f64> {
    let r = 1usize << TABLE_BITS;
    let mut tab = vec![0.0; 3 * r + 1];
    // Integer values: phi(0), phi(1) solve the eigenproblem; sum = 1.
    // (sqrt2 h_0 - 1) phi0 + sqrt2 h_{-1} phi1 = 0.
    let s2 = std::f64::consts::SQRT_2;
    let ratio = (1.0 - s2 * h[1]) / (s2 * h[0]);
    let phi0 = 1.0 / (1.0 + ratio);
    tab[r] = phi0;
    tab[2 * r] = phi0 * ratio;
    for bits in 1..=TABLE_BITS {
        let step = 1usize << (TABLE_BITS - bits);
        let mut i = step;
        while i < 3 * r {
            if (i / step) % 2 == 1 {
                let mut s = 0.0;
                for (p, &hp) in h.iter().enumerate() {
                    // index of 2x - p (p = -1..2) is 2i - (p+1+... ) see module docs
                    let j = 2 * i as i64 - (p as i64) * r as i64;
                    if j >= 0 && j <= 3 * r as i64 {
                        s += hp * tab[j as usize];
                    }
                }
                tab[i] = s2 * s;
            }
            i += step;
        }
    }
    tab
}

/// Exact `∫_0^1 √(2a+1) P_a(2s−1) φ(n+s) ds` for `n = -1, 0, 1` from the cell moments
/// of `φ`, which follow from the refinement equation.
fn cell_legendre_products(h: &[f64; 4]) -> [[f64; MAX_LEGENDRE + 1]; 3] {
    let deg = MAX_LEGENDRE;
    // nu[i][n+1] = ∫_0^1 s^i φ(n+s) ds.
    let mut nu = vec![[0.0f64; 3]; deg + 1];
    let s2 = std::f64::consts::SQRT_2;
    let get = |nu: &Vec<[f64; 3]>, i: usize, n: i32| -> f64 {
        if (-1..=1).contains(&n) {
            nu[i][(n + 1) as usize]
        } else {
            0.0
        }
    };
    for i in 0..=deg {
        let fac = s2 * 0.5f64.powi(i as i32 + 1);
        let mut mat = vec![0.0; 9];
        let mut rhs = vec![0.0; 3];
        for n in -1..=1i32 {
            let row = (n + 1) as usize;
            mat[row * 3 + row] += 1.0;
            for (pi, &hp) in h.iter().enumerate() {
                let p = pi as i32 - 1;
                let m1 = 2 * n - p;
                let m2 = m1 + 1;
                for (m, with_binom) in [(m1, false), (m2, true)] {
                    if with_binom {
                        for r in 0..i {
                            rhs[row] += fac * hp * binom(i, r) * get(&nu, r, m);
                        }
                    }
                    if (-1..=1).contains(&m) {
                        mat[row * 3 + (m + 1) as usize] -= fac * hp;
                    }
                }
            }
        }
        if i == 0 {
            // Singular (eigenvalue 1): replace the last equation by ∫φ = 1.
            for c in 0..3 {
                mat[6 + c] = 1.0;
            }
            rhs[2] = 1.0;
        }
        let sol = solve(mat, rhs).expect("cell-moment system is regular");
        nu[i] = [sol[0], sol[1], sol[2]];
    }
    let mut out = [[0.0; MAX_LEGENDRE + 1]; 3];
    for a in 0..=deg {
        let c = shifted_legendre_coeffs(a);
        for n in 0..3 {
            out[n][a] = c.iter().enumerate().map(|(i, ci)| ci * nu[i][n]).sum();
        }
    }
    out
}

impl Mra for Cdv {
    fn name(&self) -> String {
        "CDV4".to_string()
    }
    fn min_level(&self) -> u32 {
        2
    }
    fn len(&self, level: u32) -> usize {
        1usize << level.min(MAX_LEVEL)
    }
    fn functions_per_cell(&self) -> usize {
        1
    }
    fn vanishing_moments(&self) -> usize {
        2
    }
    fn polynomial_degree(&self) -> usize {
        1
    }
    fn is_piecewise_polynomial(&self) -> bool {
        false
    }
    fn scaling_row(&self, level: u32, k: usize) -> Result<FilterRow<'_>, MraError> {
        self.check_index(level, k)?;
        let n = 1usize << level;
        Ok(if k < 2 {
            FilterRow {
                start: 0,
                coeffs: &self.left.h[k][..3 + 2 * k],
            }
        } else if k >= n - 2 {
            let e = n - 1 - k;
            let len = 3 + 2 * e;
            FilterRow {
                start: 2 * n - len,
                coeffs: &self.right_rows_h[e][..len],
            }
        } else {
            FilterRow {
                start: 2 * k - 1,
                coeffs: &self.h,
            }
        })
    }
    fn wavelet_row(&self, level: u32, k: usize) -> Result<FilterRow<'_>, MraError> {
        self.check_index(level, k)?;
        let n = 1usize << level;
        Ok(if k < 2 {
            FilterRow {
                start: 0,
                coeffs: &self.left.g[k][..3 + 2 * k],
            }
        } else if k >= n - 2 {
            let e = n - 1 - k;
            let len = 3 + 2 * e;
            FilterRow {
                start: 2 * n - len,
                coeffs: &self.right_rows_g[e][..len],
            }
        } else {
            FilterRow {
                start: 2 * k - 1,
                coeffs: &self.g,
            }
        })
    }
    fn parents(&self, level: u32, l: usize) -> Result<std::ops::Range<usize>, MraError> {
        self.check_level(level)?;
        self.check_index(level + 1, l)?;
        let n = 1usize << level;
        let lo = if l <= 4 { 0 } else { (l - 2) / 2 };
        let mut hi = if l + 5 >= 2 * n {
            n
        } else {
            (l.div_ceil(2) + 1).min(n)
        };
        if l <= 4 {
            hi = hi.max(2);
        }
        Ok(lo..hi)
    }
    fn support(&self, level: u32, k: usize) -> Result<(f64, f64), MraError> {
        self.check_index(level, k)?;
        let n = 1usize << level;
        let w = 1.0 / n as f64;
        Ok(if k < 2 {
            (0.0, (2 + k) as f64 * w)
        } else if k >= n - 2 {
            let e = n - 1 - k;
            (1.0 - (2 + e) as f64 * w, 1.0)
        } else {
            ((k - 1) as f64 * w, (k + 2) as f64 * w)
        })
    }
    fn eval_scaling(&self, level: u32, k: usize, x: f64) -> Result<f64, MraError> {
        self.eval(level, k, x, false)
    }
    fn eval_wavelet(&self, level: u32, k: usize, x: f64) -> Result<f64, MraError> {
        self.eval(level, k, x, true)
    }
    fn nonzero_at(&self, level: u32, x: f64) -> Result<std::ops::Range<usize>, MraError> {
        self.check_level(level)?;
        if !x.is_finite() {
            return Err(MraError::NonFinite("evaluation point"));
        }
        if !(0.0..=1.0).contains(&x) {
            return Ok(0..0);
        }
        let n = 1usize << level;
        let t = x * n as f64;
        let c = (t.floor() as usize).min(n - 1);
        // Interior k covers cells k-1..=k+1; edges cover cells 0..=2 / n-3..=n-1.
        let lo = if c <= 3 { 0 } else { c - 1 };
        let hi = if c + 4 >= n { n } else { c + 2 };
        Ok(lo..hi)
    }
    fn legendre_products(
        &self,
        level: u32,
        k: usize,
        n_legendre: usize,
        f: &mut dyn FnMut(usize, usize, f64),
    ) -> Result<(), MraError> {
        self.legendre_products_impl(level, k, n_legendre, f)
    }
    fn projection_plan(&self) -> (u32, usize) {
        (PROJECTION_EXTRA_LEVELS, PROJECTION_LEGENDRE)
    }
    fn analysis_step(
        &self,
        level: u32,
        fine: &[f64],
        coarse: &mut [f64],
        detail: &mut [f64],
    ) -> Result<(), MraError> {
        check_step_lengths(self, level, fine.len(), coarse.len(), detail.len())?;
        let n = coarse.len();
        for k in [0, 1, n - 2, n - 1] {
            let hr = self.scaling_row(level, k)?;
            let gr = self.wavelet_row(level, k)?;
            coarse[k] = dot(hr.coeffs, &fine[hr.start..hr.end()]);
            detail[k] = dot(gr.coeffs, &fine[gr.start..gr.end()]);
        }
        let (h, g) = (self.h, self.g);
        for k in 2..n - 2 {
            let f = &fine[2 * k - 1..2 * k + 3];
            coarse[k] = h[0] * f[0] + h[1] * f[1] + h[2] * f[2] + h[3] * f[3];
            detail[k] = g[0] * f[0] + g[1] * f[1] + g[2] * f[2] + g[3] * f[3];
        }
        Ok(())
    }
    fn synthesis_step(
        &self,
        level: u32,
        coarse: &[f64],
        detail: &[f64],
        fine: &mut [f64],
    ) -> Result<(), MraError> {
        check_step_lengths(self, level, fine.len(), coarse.len(), detail.len())?;
        let n = coarse.len();
        fine.fill(0.0);
        for k in [0, 1, n - 2, n - 1] {
            let hr = self.scaling_row(level, k)?;
            let gr = self.wavelet_row(level, k)?;
            for (f, &w) in fine[hr.start..hr.end()].iter_mut().zip(hr.coeffs) {
                *f += w * coarse[k];
            }
            for (f, &w) in fine[gr.start..gr.end()].iter_mut().zip(gr.coeffs) {
                *f += w * detail[k];
            }
        }
        let (h, g) = (self.h, self.g);
        for k in 2..n - 2 {
            let (c, d) = (coarse[k], detail[k]);
            let f = &mut fine[2 * k - 1..2 * k + 3];
            f[0] += h[0] * c + g[0] * d;
            f[1] += h[1] * c + g[1] * d;
            f[2] += h[2] * c + g[2] * d;
            f[3] += h[3] * c + g[3] * d;
        }
        Ok(())
    }
}
