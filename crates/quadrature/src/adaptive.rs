//! Adaptive cubature with error estimates, for reference values of transfer
//! coefficients (Ziegler §3.3.3, VirtualMesh §5.2, Glossy §3.3 all reduce to integrals
//! over mapped unit cubes; a trustworthy reference value is what the tests of the
//! fixed rules are measured against).
//!
//! - 1D: Gauss–Kronrod `G_n`–`K_{2n+1}` pairs built from scratch ([`GaussKronrod`]):
//!   the Kronrod nodes are the roots of the Stieltjes polynomial `E_{n+1}`, which is
//!   expanded in Legendre polynomials and determined by `∫ E_{n+1} P_n P_k = 0`,
//!   `k <= n` (a linear solve); they interlace the Gauss nodes and are found by
//!   bisection. The weights solve the Legendre–Vandermonde system for exactness up to
//!   degree `2n`; the Kronrod property then makes the rule exact to degree `3n+1`.
//!   [`integrate_1d`] bisects the interval with the largest `|K - G|` until the sum of
//!   `|K - G|` meets the tolerance or the evaluation budget is spent.
//! - 2..=10 D: the Genz–Malik degree-7 rule with its embedded degree-5 rule
//!   (A. C. Genz, A. A. Malik, J. Comput. Appl. Math. 6 (1980)), `2^d + 2d² + 2d + 1`
//!   points per box; [`genz_malik`] bisects the box with the largest `|I7 - I5|` along
//!   the axis with the largest fourth divided difference.
//!
//! The error estimate is the sum of the local `|higher - lower|` differences. It is an
//! *estimate*, not a bound: it is pessimistic for smooth integrands (it measures the
//! error of the lower-order rule) and can be fooled by features smaller than the
//! sampling (e.g. a spike between all points).

use crate::{GaussLegendre, QuadratureError, check_finite};
use nalgebra::{DMatrix, DVector};
use std::cmp::Ordering;
use std::collections::BinaryHeap;
use std::sync::OnceLock;

/// Largest Gauss order for which [`GaussKronrod::new`] builds a Kronrod extension.
pub const MAX_KRONROD_ORDER: usize = 40;

/// Largest dimension accepted by [`genz_malik`].
pub const MAX_GENZ_MALIK_DIM: usize = 10;

/// Absolute and relative tolerance: stop when `error <= max(abs, rel · |value|)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tolerance {
    /// Absolute tolerance (>= 0).
    pub abs: f64,
    /// Relative tolerance (>= 0).
    pub rel: f64,
}

impl Tolerance {
    /// A tolerance; both parts must be finite and non-negative and not both zero.
    ///
    /// # Errors
    /// [`QuadratureError::InvalidParameter`] otherwise.
    pub fn new(abs: f64, rel: f64) -> Result<Self, QuadratureError> {
        for (name, v) in [("abs tolerance", abs), ("rel tolerance", rel)] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(QuadratureError::InvalidParameter {
                    name,
                    value: v,
                    reason: "must be finite and non-negative",
                });
            }
        }
        if abs == 0.0 && rel == 0.0 {
            return Err(QuadratureError::InvalidParameter {
                name: "tolerance",
                value: 0.0,
                reason: "absolute and relative tolerance cannot both be zero",
            });
        }
        Ok(Self { abs, rel })
    }

    fn met(&self, value: f64, error: f64) -> bool {
        error <= self.abs.max(self.rel * value.abs())
    }
}

/// Result of an adaptive integration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Estimate {
    /// The integral estimate (the higher-order rule summed over all pieces).
    pub value: f64,
    /// Estimated absolute error (sum of local differences of the embedded rules).
    pub error: f64,
    /// Number of integrand evaluations spent.
    pub evaluations: usize,
    /// Whether the tolerance was met within the evaluation budget.
    pub converged: bool,
}

/// A Gauss–Kronrod pair: the n-point Gauss rule and its (2n+1)-point Kronrod
/// extension on [-1, 1].
#[derive(Debug, Clone, PartialEq)]
pub struct GaussKronrod {
    /// Kronrod nodes, increasing; the Gauss nodes are the odd-indexed ones.
    nodes: Vec<f64>,
    kronrod_weights: Vec<f64>,
    /// Gauss weights at the odd-indexed nodes.
    gauss_weights: Vec<f64>,
}

/// `P_0(x) ..= P_m(x)` into `out`.
fn legendre_all(m: usize, x: f64, out: &mut Vec<f64>) {
    out.clear();
    out.push(1.0);
    if m >= 1 {
        out.push(x);
    }
    for k in 2..=m {
        let kf = k as f64;
        let p = ((2.0 * kf - 1.0) * x * out[k - 1] - (kf - 1.0) * out[k - 2]) / kf;
        out.push(p);
    }
}

impl GaussKronrod {
    /// Builds the `G_n`–`K_{2n+1}` pair. `n = 7` gives the classic 7–15 pair.
    ///
    /// # Errors
    /// [`QuadratureError::OrderOutOfRange`] unless `1 <= n <= 40`.
    pub fn new(n: usize) -> Result<Self, QuadratureError> {
        if !(1..=MAX_KRONROD_ORDER).contains(&n) {
            return Err(QuadratureError::OrderOutOfRange {
                order: n,
                min: 1,
                max: MAX_KRONROD_ORDER,
            });
        }
        let gauss = GaussLegendre::new(n)?;
        // Triple products ∫ P_j P_k P_n, exact with a Gauss rule of degree >= 3n + 1.
        let big = GaussLegendre::new((3 * n + 2).div_ceil(2) + 1)?;
        let mut pv = Vec::new();
        let mut tab = vec![vec![0.0; n + 2]; big.order()];
        for (q, &x) in big.nodes().iter().enumerate() {
            legendre_all(n + 1, x, &mut pv);
            tab[q].copy_from_slice(&pv);
        }
        let triple = |j: usize, k: usize| -> f64 {
            big.weights()
                .iter()
                .zip(&tab)
                .map(|(w, p)| w * p[j] * p[k] * p[n])
                .sum()
        };
        // E_{n+1} = P_{n+1} + Σ_{j<=n} c_j P_j with ∫ E P_n P_k = 0 for k = 0..=n.
        let mut m = DMatrix::<f64>::zeros(n + 1, n + 1);
        let mut rhs = DVector::<f64>::zeros(n + 1);
        for k in 0..=n {
            for j in 0..=n {
                m[(k, j)] = triple(j, k);
            }
            rhs[k] = -triple(n + 1, k);
        }
        let c = m
            .lu()
            .solve(&rhs)
            .ok_or(QuadratureError::InvalidParameter {
                name: "kronrod order",
                value: n as f64,
                reason: "Stieltjes system is singular",
            })?;
        let stieltjes = |x: f64| -> f64 {
            let mut p = Vec::with_capacity(n + 2);
            legendre_all(n + 1, x, &mut p);
            p[n + 1] + (0..=n).map(|j| c[j] * p[j]).sum::<f64>()
        };
        // Roots interlace the Gauss nodes: one in each gap, including (-1, x_1), (x_n, 1).
        let mut brackets = Vec::with_capacity(n + 2);
        brackets.push(-1.0);
        brackets.extend_from_slice(gauss.nodes());
        brackets.push(1.0);
        let mut nodes = Vec::with_capacity(2 * n + 1);
        for g in 0..=n {
            let (mut lo, mut hi) = (brackets[g], brackets[g + 1]);
            let mut flo = stieltjes(lo);
            for _ in 0..200 {
                let mid = 0.5 * (lo + hi);
                if mid <= lo || mid >= hi {
                    break;
                }
                let fm = stieltjes(mid);
                if (fm < 0.0) == (flo < 0.0) {
                    lo = mid;
                    flo = fm;
                } else {
                    hi = mid;
                }
            }
            nodes.push(0.5 * (lo + hi));
            if g < n {
                nodes.push(gauss.nodes()[g]);
            }
        }
        // Symmetrise (the exact rule is symmetric; bisection errors are sub-ulp anyway).
        let len = nodes.len();
        for i in 0..len / 2 {
            let x = 0.5 * (nodes[len - 1 - i] - nodes[i]);
            nodes[i] = -x;
            nodes[len - 1 - i] = x;
        }
        if len % 2 == 1 {
            nodes[len / 2] = 0.0;
        }
        // Weights: Σ_i w_i P_k(x_i) = 2 δ_{k0}, k = 0..=2n.
        let mut v = DMatrix::<f64>::zeros(len, len);
        for (i, &x) in nodes.iter().enumerate() {
            legendre_all(len - 1, x, &mut pv);
            for k in 0..len {
                v[(k, i)] = pv[k];
            }
        }
        let mut e0 = DVector::<f64>::zeros(len);
        e0[0] = 2.0;
        let w = v.lu().solve(&e0).ok_or(QuadratureError::InvalidParameter {
            name: "kronrod order",
            value: n as f64,
            reason: "Kronrod weight system is singular",
        })?;
        let mut kronrod_weights: Vec<f64> = w.iter().copied().collect();
        for i in 0..len / 2 {
            let s = 0.5 * (kronrod_weights[i] + kronrod_weights[len - 1 - i]);
            kronrod_weights[i] = s;
            kronrod_weights[len - 1 - i] = s;
        }
        Ok(Self {
            nodes,
            kronrod_weights,
            gauss_weights: gauss.weights().to_vec(),
        })
    }

    /// Gauss order n.
    #[must_use]
    pub fn gauss_order(&self) -> usize {
        self.gauss_weights.len()
    }

    /// The 2n+1 Kronrod nodes on [-1, 1], increasing; `nodes()[2i+1]` is Gauss node i.
    #[must_use]
    pub fn nodes(&self) -> &[f64] {
        &self.nodes
    }

    /// Kronrod weights (sum 2).
    #[must_use]
    pub fn kronrod_weights(&self) -> &[f64] {
        &self.kronrod_weights
    }

    /// Gauss weights for the nodes `nodes()[2i+1]` (sum 2).
    #[must_use]
    pub fn gauss_weights(&self) -> &[f64] {
        &self.gauss_weights
    }

    /// `(K, G)`: the Kronrod and Gauss estimates of `∫_a^b f`, using 2n+1 evaluations.
    pub fn apply(&self, a: f64, b: f64, mut f: impl FnMut(f64) -> f64) -> (f64, f64) {
        let half = 0.5 * (b - a);
        let mid = 0.5 * (a + b);
        let (mut k, mut g) = (0.0, 0.0);
        for (i, (&x, &wk)) in self.nodes.iter().zip(&self.kronrod_weights).enumerate() {
            let fx = f(mid + half * x);
            k += wk * fx;
            if i % 2 == 1 {
                g += self.gauss_weights[i / 2] * fx;
            }
        }
        (half * k, half * g)
    }
}

/// A heap entry ordered by error (largest first), ties by insertion index.
#[derive(Debug, Clone, Copy)]
struct Keyed {
    error: f64,
    index: usize,
}

impl PartialEq for Keyed {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}
impl Eq for Keyed {}
impl PartialOrd for Keyed {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Keyed {
    fn cmp(&self, other: &Self) -> Ordering {
        self.error
            .total_cmp(&other.error)
            .then_with(|| other.index.cmp(&self.index))
    }
}

/// Adaptive Gauss–Kronrod (7–15) integration of `f` over `[a, b]` with at most
/// `max_evals` evaluations (at least one 15-point pass is always made).
///
/// # Errors
/// [`QuadratureError::NonFiniteInterval`] for non-finite bounds;
/// [`QuadratureError::NonFiniteIntegrand`] if `f` returns NaN or an infinity.
pub fn integrate_1d(
    f: impl FnMut(f64) -> f64,
    a: f64,
    b: f64,
    tol: Tolerance,
    max_evals: usize,
) -> Result<Estimate, QuadratureError> {
    static G7K15: OnceLock<GaussKronrod> = OnceLock::new();
    let rule = match G7K15.get() {
        Some(r) => r,
        None => {
            let r = GaussKronrod::new(7)?;
            G7K15.get_or_init(|| r)
        }
    };
    integrate_1d_with(rule, f, a, b, tol, max_evals)
}

/// [`integrate_1d`] with a caller-built Gauss–Kronrod pair (build once, reuse).
///
/// # Errors
/// As [`integrate_1d`].
pub fn integrate_1d_with(
    rule: &GaussKronrod,
    mut f: impl FnMut(f64) -> f64,
    a: f64,
    b: f64,
    tol: Tolerance,
    max_evals: usize,
) -> Result<Estimate, QuadratureError> {
    if !(a.is_finite() && b.is_finite()) {
        return Err(QuadratureError::NonFiniteInterval { a, b });
    }
    let per = rule.nodes().len();
    let mut bad = false;
    let mut eval = |lo: f64, hi: f64| {
        let (k, g) = rule.apply(lo, hi, |x| {
            let y = f(x);
            if !y.is_finite() {
                bad = true;
            }
            y
        });
        (k, (k - g).abs())
    };
    // (lo, hi, value, error)
    let mut pieces: Vec<(f64, f64, f64, f64)> = Vec::new();
    let (v0, e0) = eval(a, b);
    let mut evaluations = per;
    pieces.push((a, b, v0, e0));
    let mut heap = BinaryHeap::new();
    heap.push(Keyed {
        error: e0,
        index: 0,
    });
    let (mut value, mut error) = (v0, e0);
    let mut converged = tol.met(value, error);
    while !converged && evaluations + 2 * per <= max_evals {
        let Some(top) = heap.pop() else { break };
        let (lo, hi, v, e) = pieces[top.index];
        let mid = 0.5 * (lo + hi);
        if !(lo < mid && mid < hi) {
            // Cannot split further in f64; leave it and stop.
            break;
        }
        let (vl, el) = eval(lo, mid);
        let (vr, er) = eval(mid, hi);
        evaluations += 2 * per;
        value += vl + vr - v;
        error += el + er - e;
        pieces[top.index] = (lo, mid, vl, el);
        heap.push(Keyed {
            error: el,
            index: top.index,
        });
        pieces.push((mid, hi, vr, er));
        heap.push(Keyed {
            error: er,
            index: pieces.len() - 1,
        });
        // Re-sum occasionally to avoid drift of the running totals.
        if pieces.len().is_multiple_of(64) {
            value = pieces.iter().map(|p| p.2).sum();
            error = pieces.iter().map(|p| p.3).sum();
        }
        converged = tol.met(value, error);
    }
    if bad {
        return Err(QuadratureError::NonFiniteIntegrand);
    }
    value = pieces.iter().map(|p| p.2).sum();
    error = pieces.iter().map(|p| p.3).sum();
    Ok(Estimate {
        value,
        error,
        evaluations,
        converged: tol.met(value, error),
    })
}

/// The Genz–Malik generators and weights for dimension `d`.
struct GenzMalik {
    d: usize,
    l2: f64,
    l4: f64,
    l5: f64,
    w: [f64; 5],
    we: [f64; 4],
}

impl GenzMalik {
    fn new(d: usize) -> Self {
        let df = d as f64;
        Self {
            d,
            l2: (9.0f64 / 70.0).sqrt(),
            l4: (9.0f64 / 10.0).sqrt(),
            l5: (9.0f64 / 19.0).sqrt(),
            w: [
                (12824.0 - 9120.0 * df + 400.0 * df * df) / 19683.0,
                980.0 / 6561.0,
                (1820.0 - 400.0 * df) / 19683.0,
                200.0 / 19683.0,
                6859.0 / 19683.0 / (2.0f64).powi(d as i32),
            ],
            we: [
                (729.0 - 950.0 * df + 50.0 * df * df) / 729.0,
                245.0 / 486.0,
                (265.0 - 100.0 * df) / 1458.0,
                25.0 / 729.0,
            ],
        }
    }

    fn points(&self) -> usize {
        (1usize << self.d) + 2 * self.d * self.d + 2 * self.d + 1
    }

    /// `(I7, I5, split axis)` on the box `centre ± half`.
    fn apply(
        &self,
        centre: &[f64],
        half: &[f64],
        x: &mut [f64],
        f: &mut dyn FnMut(&[f64]) -> f64,
    ) -> (f64, f64, usize) {
        let d = self.d;
        x.copy_from_slice(centre);
        let f0 = f(x);
        let (mut s2, mut s3, mut s4, mut s5) = (0.0, 0.0, 0.0, 0.0);
        let mut split = 0;
        let mut best = f64::NEG_INFINITY;
        for i in 0..d {
            let mut at = |t: f64, x: &mut [f64]| {
                x[i] = centre[i] + t * half[i];
                let y = f(x);
                x[i] = centre[i];
                y
            };
            let a = at(self.l2, x) + at(-self.l2, x);
            let b = at(self.l4, x) + at(-self.l4, x);
            s2 += a;
            s3 += b;
            let diff =
                ((a - 2.0 * f0) - (self.l2 * self.l2 / (self.l4 * self.l4)) * (b - 2.0 * f0)).abs();
            // Largest fourth difference; ties go to the wider axis, then lower index.
            let key = diff + 1e-300 * half[i];
            if key > best || (key == best && half[i] > half[split]) {
                best = key;
                split = i;
            }
        }
        for i in 0..d {
            for j in i + 1..d {
                for (si, sj) in [(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)] {
                    x[i] = centre[i] + si * self.l4 * half[i];
                    x[j] = centre[j] + sj * self.l4 * half[j];
                    s4 += f(x);
                }
                x[i] = centre[i];
                x[j] = centre[j];
            }
        }
        for mask in 0..(1usize << d) {
            for k in 0..d {
                let s = if mask >> k & 1 == 1 { 1.0 } else { -1.0 };
                x[k] = centre[k] + s * self.l5 * half[k];
            }
            s5 += f(x);
        }
        let vol: f64 = half.iter().map(|h| 2.0 * h).product();
        let i7 = vol
            * (self.w[0] * f0 + self.w[1] * s2 + self.w[2] * s3 + self.w[3] * s4 + self.w[4] * s5);
        let i5 = vol * (self.we[0] * f0 + self.we[1] * s2 + self.we[2] * s3 + self.we[3] * s4);
        (i7, i5, split)
    }

    /// `(I7, |I7 - I5|, split axis)`.
    fn apply_err(
        &self,
        centre: &[f64],
        half: &[f64],
        x: &mut [f64],
        f: &mut dyn FnMut(&[f64]) -> f64,
    ) -> (f64, f64, usize) {
        let (i7, i5, split) = self.apply(centre, half, x, f);
        (i7, (i7 - i5).abs(), split)
    }
}

/// One application of the Genz–Malik degree-7 rule on the box `[lo, hi]`:
/// `(I7, I5)`. Exact for polynomials of total degree 7 (I7) and 5 (I5).
///
/// # Errors
/// [`QuadratureError::DimensionOutOfRange`] unless `2 <= d <= 10`;
/// [`QuadratureError::LengthMismatch`] / [`QuadratureError::InvalidParameter`] for
/// inconsistent or non-finite bounds.
pub fn genz_malik_rule(
    mut f: impl FnMut(&[f64]) -> f64,
    lo: &[f64],
    hi: &[f64],
) -> Result<(f64, f64), QuadratureError> {
    let d = check_box(lo, hi)?;
    let gm = GenzMalik::new(d);
    let centre: Vec<f64> = lo.iter().zip(hi).map(|(a, b)| 0.5 * (a + b)).collect();
    let half: Vec<f64> = lo.iter().zip(hi).map(|(a, b)| 0.5 * (b - a)).collect();
    let mut x = vec![0.0; d];
    let (i7, i5, _) = gm.apply(&centre, &half, &mut x, &mut f);
    Ok((i7, i5))
}

fn check_box(lo: &[f64], hi: &[f64]) -> Result<usize, QuadratureError> {
    let d = lo.len();
    if !(2..=MAX_GENZ_MALIK_DIM).contains(&d) {
        return Err(QuadratureError::DimensionOutOfRange {
            dim: d,
            min: 2,
            max: MAX_GENZ_MALIK_DIM,
        });
    }
    if hi.len() != d {
        return Err(QuadratureError::LengthMismatch {
            expected: d,
            got: hi.len(),
        });
    }
    for (&a, &b) in lo.iter().zip(hi) {
        check_finite("box bound", a)?;
        check_finite("box bound", b)?;
    }
    Ok(d)
}

/// Adaptive Genz–Malik cubature of `f` over the box `[lo, hi]` (`2 <= d <= 10`;
/// `d = lo.len()`) with at most `max_evals` evaluations (at least one application of
/// the rule, `2^d + 2d² + 2d + 1` points, is always made). Boxes are bisected, worst
/// estimated error first, along the axis with the largest fourth difference.
///
/// # Errors
/// As [`genz_malik_rule`]; [`QuadratureError::NonFiniteIntegrand`] if `f` returns
/// NaN or an infinity.
pub fn genz_malik(
    mut f: impl FnMut(&[f64]) -> f64,
    lo: &[f64],
    hi: &[f64],
    tol: Tolerance,
    max_evals: usize,
) -> Result<Estimate, QuadratureError> {
    let d = check_box(lo, hi)?;
    let gm = GenzMalik::new(d);
    let per = gm.points();
    let mut bad = false;
    let mut g = |p: &[f64]| {
        let y = f(p);
        if !y.is_finite() {
            bad = true;
        }
        y
    };
    let mut x = vec![0.0; d];
    // Box storage: centres and half-widths flattened; per box (value, error, axis).
    let mut centres: Vec<f64> = lo.iter().zip(hi).map(|(a, b)| 0.5 * (a + b)).collect();
    let mut halves: Vec<f64> = lo.iter().zip(hi).map(|(a, b)| 0.5 * (b - a)).collect();
    let (v0, e0, s0) = gm.apply_err(&centres, &halves, &mut x, &mut g);
    let mut info = vec![(v0, e0, s0)];
    let mut evaluations = per;
    let mut heap = BinaryHeap::new();
    heap.push(Keyed {
        error: e0,
        index: 0,
    });
    let (mut value, mut error) = (v0, e0);
    let mut converged = tol.met(value, error);
    let mut c = vec![0.0; d];
    let mut h = vec![0.0; d];
    while !converged && evaluations + 2 * per <= max_evals {
        let Some(top) = heap.pop() else { break };
        let k = top.index;
        let (v, e, axis) = info[k];
        c.copy_from_slice(&centres[k * d..(k + 1) * d]);
        h.copy_from_slice(&halves[k * d..(k + 1) * d]);
        h[axis] *= 0.5;
        if h[axis] == 0.0 || c[axis] - h[axis] == c[axis] {
            break;
        }
        let mut children = [(0.0, 0.0, 0); 2];
        let mut child_centres = [c.clone(), c.clone()];
        child_centres[0][axis] -= h[axis];
        child_centres[1][axis] += h[axis];
        for (slot, cc) in children.iter_mut().zip(&child_centres) {
            *slot = gm.apply_err(cc, &h, &mut x, &mut g);
        }
        evaluations += 2 * per;
        value += children[0].0 + children[1].0 - v;
        error += children[0].1 + children[1].1 - e;
        centres[k * d..(k + 1) * d].copy_from_slice(&child_centres[0]);
        halves[k * d..(k + 1) * d].copy_from_slice(&h);
        info[k] = children[0];
        heap.push(Keyed {
            error: children[0].1,
            index: k,
        });
        centres.extend_from_slice(&child_centres[1]);
        halves.extend_from_slice(&h);
        info.push(children[1]);
        heap.push(Keyed {
            error: children[1].1,
            index: info.len() - 1,
        });
        if info.len().is_multiple_of(64) {
            value = info.iter().map(|b| b.0).sum();
            error = info.iter().map(|b| b.1).sum();
        }
        converged = tol.met(value, error);
    }
    if bad {
        return Err(QuadratureError::NonFiniteIntegrand);
    }
    value = info.iter().map(|b| b.0).sum();
    error = info.iter().map(|b| b.1).sum();
    Ok(Estimate {
        value,
        error,
        evaluations,
        converged: tol.met(value, error),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::GaussJacobi;

    #[test]
    fn kronrod_extensions_are_exact_to_degree_3n_plus_1() {
        let mut p = Vec::new();
        for n in [1usize, 2, 3, 5, 7, 10, 15, 20, 30, 40] {
            let gk = GaussKronrod::new(n).unwrap();
            let x = gk.nodes();
            assert_eq!(x.len(), 2 * n + 1);
            assert!(x.windows(2).all(|w| w[0] < w[1]) && x[0] > -1.0 && x[2 * n] < 1.0);
            assert!(gk.kronrod_weights().iter().all(|&w| w > 0.0), "n={n}");
            let g = GaussLegendre::new(n).unwrap();
            for i in 0..n {
                assert_eq!(x[2 * i + 1], g.nodes()[i]);
            }
            let deg = 3 * n + 1;
            let mut sums = vec![0.0; deg + 1];
            for (&xi, &wi) in x.iter().zip(gk.kronrod_weights()) {
                legendre_all(deg, xi, &mut p);
                for k in 0..=deg {
                    sums[k] += wi * p[k];
                }
            }
            assert!((sums[0] - 2.0).abs() < 1e-14, "n={n}");
            for (k, s) in sums.iter().enumerate().skip(1) {
                assert!(s.abs() < 1e-14, "n={n} k={k} {s:e}");
            }
        }
        assert!(GaussKronrod::new(0).is_err());
        assert!(GaussKronrod::new(41).is_err());
    }

    #[test]
    fn adaptive_1d_meets_tolerance_and_its_estimate_covers_the_error() {
        let tol = Tolerance::new(1e-12, 0.0).unwrap();
        type Case<'a> = (&'a dyn Fn(f64) -> f64, f64, f64, f64);
        let cases: [Case<'_>; 4] = [
            (&|x: f64| x.sqrt(), 0.0, 1.0, 2.0 / 3.0),
            (&|x: f64| x.sin(), 0.0, std::f64::consts::PI, 2.0),
            (
                &|x: f64| 1.0 / (1.0 + 25.0 * x * x),
                -1.0,
                1.0,
                0.4 * 5f64.atan(),
            ),
            (&|x: f64| (x - 0.3).abs(), 0.0, 1.0, 0.5 * (0.09 + 0.49)),
        ];
        for (k, (f, a, b, exact)) in cases.into_iter().enumerate() {
            let est = integrate_1d(f, a, b, tol, 100_000).unwrap();
            assert!(est.converged, "case {k}: {est:?}");
            assert!(
                (est.value - exact).abs() <= est.error.max(1e-15),
                "case {k}: {est:?} vs {exact}"
            );
            assert!((est.value - exact).abs() < 1e-12, "case {k}");
        }
    }

    #[test]
    fn adaptive_1d_agrees_with_gauss_jacobi_on_an_endpoint_singularity() {
        // ∫_0^1 cos(x) / √x: adaptive GK against the Gauss–Jacobi rule for t^{-1/2}.
        let gj = GaussJacobi::new(20, 0.0, -0.5).unwrap();
        let (p, w) = gj.unit();
        let reference: f64 = p.iter().zip(&w).map(|(x, w)| w * x.cos()).sum();
        let est = integrate_1d(
            |x| x.cos() / x.sqrt(),
            0.0,
            1.0,
            Tolerance::new(1e-10, 0.0).unwrap(),
            1_000_000,
        )
        .unwrap();
        assert!(est.converged);
        assert!(
            (est.value - reference).abs() < 1e-9,
            "{est:?} vs {reference}"
        );
    }

    #[test]
    fn budget_and_bad_integrands() {
        let tol = Tolerance::new(1e-14, 0.0).unwrap();
        let est = integrate_1d(|x: f64| x.sqrt(), 0.0, 1.0, tol, 15).unwrap();
        assert!(!est.converged && est.evaluations == 15);
        assert!(matches!(
            integrate_1d(|x| 1.0 / x, 0.0, 1.0, tol, 1000),
            Ok(_) | Err(QuadratureError::NonFiniteIntegrand)
        ));
        assert_eq!(
            integrate_1d(|_| f64::NAN, 0.0, 1.0, tol, 1000),
            Err(QuadratureError::NonFiniteIntegrand)
        );
        assert!(integrate_1d(|x| x, 0.0, f64::INFINITY, tol, 1000).is_err());
        assert!(Tolerance::new(0.0, 0.0).is_err());
        assert!(Tolerance::new(-1.0, 0.0).is_err());
        assert!(genz_malik(|p| p[0], &[0.0], &[1.0], tol, 1000).is_err());
        assert!(genz_malik(|p| p[0], &[0.0; 3], &[1.0; 2], tol, 1000).is_err());
        assert_eq!(
            genz_malik(|_| f64::INFINITY, &[0.0; 2], &[1.0; 2], tol, 1000),
            Err(QuadratureError::NonFiniteIntegrand)
        );
    }

    /// All exponent vectors of total degree exactly `deg` in `d` variables.
    fn exponents(d: usize, deg: usize) -> Vec<Vec<usize>> {
        if d == 1 {
            return vec![vec![deg]];
        }
        let mut out = Vec::new();
        for first in 0..=deg {
            for mut rest in exponents(d - 1, deg - first) {
                rest.insert(0, first);
                out.push(rest);
            }
        }
        out
    }

    #[test]
    fn genz_malik_rule_has_degrees_7_and_5() {
        for d in 2..=6 {
            let lo: Vec<f64> = (0..d).map(|k| -0.3 + 0.1 * k as f64).collect();
            let hi: Vec<f64> = (0..d).map(|k| 0.9 + 0.2 * k as f64).collect();
            for deg in 0..=8 {
                let mut worst7: f64 = 0.0;
                let mut worst5: f64 = 0.0;
                for e in exponents(d, deg) {
                    let f = |p: &[f64]| {
                        p.iter()
                            .zip(&e)
                            .map(|(x, &k)| x.powi(k as i32))
                            .product::<f64>()
                    };
                    let exact: f64 = (0..d)
                        .map(|k| {
                            (hi[k].powi(e[k] as i32 + 1) - lo[k].powi(e[k] as i32 + 1))
                                / (e[k] as f64 + 1.0)
                        })
                        .product();
                    let (i7, i5) = genz_malik_rule(f, &lo, &hi).unwrap();
                    worst7 = worst7.max((i7 - exact).abs());
                    worst5 = worst5.max((i5 - exact).abs());
                }
                if deg <= 7 {
                    assert!(worst7 < 1e-13, "d={d} deg={deg} {worst7:e}");
                } else {
                    assert!(worst7 > 1e-8, "d={d}: degree 8 unexpectedly exact");
                }
                if deg <= 5 {
                    assert!(worst5 < 1e-13, "d={d} deg={deg} {worst5:e}");
                } else {
                    assert!(worst5 > 1e-8, "d={d}: embedded rule exact at degree {deg}");
                }
            }
        }
    }

    #[test]
    fn genz_malik_adaptive_on_genz_test_functions() {
        // Product peak ∏ 1/(c⁻² + (x - w)²) on [0,1]^d: ∏ c (atan(c(1-w)) + atan(c w)).
        let (c, w) = (5.0f64, 0.35f64);
        for (d, rel) in [(2usize, 1e-8), (3, 1e-7), (4, 1e-5)] {
            let f = |p: &[f64]| {
                p.iter()
                    .map(|x| 1.0 / (1.0 / (c * c) + (x - w) * (x - w)))
                    .product::<f64>()
            };
            let exact = (c * ((c * (1.0 - w)).atan() + (c * w).atan())).powi(d as i32);
            let tol = Tolerance::new(0.0, rel).unwrap();
            let est = genz_malik(f, &vec![0.0; d], &vec![1.0; d], tol, 2_000_000).unwrap();
            assert!(est.converged, "d={d} {est:?}");
            let err = (est.value - exact).abs();
            assert!(
                err <= est.error && err < rel * exact,
                "d={d}: {err:e} vs {est:?}"
            );
        }
        // Smooth 6D: ∫ exp(Σ x) = (e - 1)^6.
        let est = genz_malik(
            |p: &[f64]| p.iter().sum::<f64>().exp(),
            &[0.0; 6],
            &[1.0; 6],
            Tolerance::new(0.0, 1e-6).unwrap(),
            1_000_000,
        )
        .unwrap();
        let exact = (std::f64::consts::E - 1.0).powi(6);
        assert!(est.converged, "{est:?}");
        assert!(
            (est.value - exact).abs() <= est.error.max(1e-14 * exact),
            "{est:?} vs {exact}"
        );
    }
}
