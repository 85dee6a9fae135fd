//! Krylov subspace methods: GMRES(m), CG, CGNR and BiCGSTAB.
//!
//! Ziegler §2.3.3 and §3.2 argue for Krylov methods on hierarchical (wavelet)
//! systems, where only matrix–vector products are available; §4.2 compares GMRES and
//! CGNR with Picard and finds GMRES clearly better per application and CGNR worse.
//! The implementations follow Saad, *Iterative Methods for Sparse Linear Systems*
//! (1996; Ziegler's `[saad95]`): GMRES Alg. 6.9 with Givens rotations and restarts,
//! CG Alg. 6.18, CGNR Alg. 8.4, and van der Vorst's BiCGSTAB (Saad Alg. 7.7).
//!
//! Cost per iteration: GMRES one application (plus one per restart for the true
//! residual), CG one, CGNR one application and one transpose application, BiCGSTAB
//! two applications.

use crate::error::{LinearError, Unsupported};
use crate::history::{Method, Solve, SolverOptions, StopReason};
use crate::operator::Operator;
use crate::util::{Recorder, axpy, check_inputs, dot, norm, residual_norm_of};

/// Relative size below which GMRES treats `h_{j+1,j}` as zero (happy breakdown).
const HAPPY: f64 = 1e-14;

/// Initial iterate and residual `r = b − A x₀` (no application for `x₀ = 0`).
fn start<A: Operator + ?Sized>(
    a: &A,
    b: &[f64],
    opts: &SolverOptions,
    rec: &mut Recorder<'_>,
) -> (Vec<f64>, Vec<f64>) {
    let n = b.len();
    match &opts.initial_guess {
        Some(x0) => {
            let mut ax = vec![0.0; n];
            a.apply(x0, &mut ax);
            rec.work.applications += 1;
            let r = b.iter().zip(&ax).map(|(bi, yi)| bi - yi).collect();
            (x0.clone(), r)
        }
        None => (vec![0.0; n], b.to_vec()),
    }
}

fn breakdown(
    rec: Recorder<'_>,
    a: &(impl Operator + ?Sized),
    b: &[f64],
    x: Vec<f64>,
    detail: &'static str,
) -> LinearError {
    let method = rec.method();
    let iteration = rec.next_iteration();
    let fin = residual_norm_of(a, b, &x);
    LinearError::Breakdown {
        method,
        iteration,
        detail,
        partial: Box::new(rec.finish(x, StopReason::Breakdown, fin)),
    }
}

/// Solves the upper-triangular `R y = g` where `cols[l][i] = R_il`.
fn back_substitute(cols: &[Vec<f64>], g: &[f64], k: usize) -> Vec<f64> {
    let mut y = vec![0.0; k];
    for i in (0..k).rev() {
        let mut s = g[i];
        for l in i + 1..k {
            s -= cols[l][i] * y[l];
        }
        y[i] = s / cols[i][i];
    }
    y
}

/// Restarted GMRES(m) with `m =` [`SolverOptions::restart`] (capped at `n`).
///
/// Arnoldi with modified Gram–Schmidt (a second pass when
/// [`SolverOptions::reorthogonalize`]), the Hessenberg least-squares problem reduced
/// by Givens rotations, so that the residual norm `|g_{j+1}|` of every inner
/// iteration is known without forming `x`; it is non-increasing within a cycle. At a
/// restart `x` is formed and the true residual recomputed (one application).
/// `h_{j+1,j} ≤ 1e-14 ‖A v_j‖` is a happy breakdown: the iterate is exact and the
/// solve ends with [`StopReason::HappyBreakdown`]. A zero pivot in the rotated
/// Hessenberg (singular `A` on the Krylov space) is a [`LinearError::Breakdown`].
/// Without restarts (`m ≥ n`) GMRES converges in at most `n` iterations in exact
/// arithmetic.
pub fn gmres<A: Operator + ?Sized>(
    a: &A,
    b: &[f64],
    opts: &SolverOptions,
) -> Result<Solve, LinearError> {
    let n = a.dim();
    check_inputs(b, n, opts)?;
    let mut rec = Recorder::new(Method::Gmres, b, opts);
    let (mut x, r0) = start(a, b, opts, &mut rec);
    let mut beta = norm(&r0);
    if rec.record(beta, Some(&x))? || n == 0 {
        let fin = residual_norm_of(a, b, &x);
        return Ok(rec.finish(x, StopReason::Converged, fin));
    }
    let m = opts.restart.min(n);
    let mut r = r0;
    let mut basis: Vec<Vec<f64>> = Vec::with_capacity(m + 1);
    let mut hcols: Vec<Vec<f64>> = Vec::with_capacity(m);
    let mut cs: Vec<f64> = Vec::with_capacity(m);
    let mut sn: Vec<f64> = Vec::with_capacity(m);
    let mut w = vec![0.0; n];
    loop {
        basis.clear();
        hcols.clear();
        cs.clear();
        sn.clear();
        basis.push(r.iter().map(|v| v / beta).collect());
        let mut g = vec![beta];
        let mut done = 0usize;
        let mut outcome: Option<StopReason> = None;
        for j in 0..m {
            a.apply(&basis[j], &mut w);
            rec.work.applications += 1;
            let w_norm0 = norm(&w);
            let mut h = vec![0.0; j + 2];
            let passes = if opts.reorthogonalize { 2 } else { 1 };
            for _ in 0..passes {
                for i in 0..=j {
                    let c = dot(&w, &basis[i]);
                    h[i] += c;
                    axpy(-c, &basis[i], &mut w);
                }
            }
            let h_next = norm(&w);
            h[j + 1] = h_next;
            for i in 0..j {
                let (hi, hi1) = (h[i], h[i + 1]);
                h[i] = cs[i] * hi + sn[i] * hi1;
                h[i + 1] = -sn[i] * hi + cs[i] * hi1;
            }
            let denom = h[j].hypot(h[j + 1]);
            if denom == 0.0 || !denom.is_finite() {
                // Apply what we have, then report.
                let y = back_substitute(&hcols, &g, done);
                for (i, yi) in y.iter().enumerate() {
                    axpy(*yi, &basis[i], &mut x);
                }
                return Err(breakdown(
                    rec,
                    a,
                    b,
                    x,
                    "zero pivot in the Hessenberg least-squares problem (singular operator)",
                ));
            }
            let (c, s) = (h[j] / denom, h[j + 1] / denom);
            h[j] = denom;
            h[j + 1] = 0.0;
            cs.push(c);
            sn.push(s);
            let gj = g[j];
            g[j] = c * gj;
            g.push(-s * gj);
            hcols.push(h);
            done = j + 1;
            let resid = g[j + 1].abs();
            let happy = h_next <= HAPPY * w_norm0;
            let x_now = if rec.wants_error() {
                let y = back_substitute(&hcols, &g, done);
                let mut xt = x.clone();
                for (i, yi) in y.iter().enumerate() {
                    axpy(*yi, &basis[i], &mut xt);
                }
                Some(xt)
            } else {
                None
            };
            let converged = rec.record(resid, x_now.as_deref())?;
            if happy {
                outcome = Some(StopReason::HappyBreakdown);
                break;
            }
            if converged {
                outcome = Some(StopReason::Converged);
                break;
            }
            if rec.next_iteration() > opts.max_iterations {
                outcome = Some(StopReason::MaxIterations);
                break;
            }
            if j + 1 < m {
                basis.push(w.iter().map(|v| v / h_next).collect());
            }
        }
        let y = back_substitute(&hcols, &g, done);
        for (i, yi) in y.iter().enumerate() {
            axpy(*yi, &basis[i], &mut x);
        }
        if let Some(reason) = outcome {
            let fin = residual_norm_of(a, b, &x);
            return Ok(rec.finish(x, reason, fin));
        }
        // Restart: true residual.
        a.apply(&x, &mut w);
        rec.work.applications += 1;
        for i in 0..n {
            r[i] = b[i] - w[i];
        }
        beta = norm(&r);
        if !beta.is_finite() {
            return Err(LinearError::NonFiniteIterate {
                method: Method::Gmres,
                iteration: rec.next_iteration(),
            });
        }
        if rec.is_converged(beta) || beta == 0.0 {
            return Ok(rec.finish(x, StopReason::Converged, beta));
        }
    }
}

/// Conjugate gradients for a symmetric positive definite operator `A` (Saad
/// Alg. 6.18). One application per iteration; the recursive residual is recorded.
/// Symmetry is not checked; `pᵀ A p ≤ 0` (not positive definite) is reported as a
/// [`LinearError::Breakdown`]. For radiosity use the symmetrised system
/// `D_A R⁻¹ M x = D_A R⁻¹ b` of Ziegler §2.3.1/§2.3.3 (needs `ρ_i > 0`).
pub fn cg<A: Operator + ?Sized>(
    a: &A,
    b: &[f64],
    opts: &SolverOptions,
) -> Result<Solve, LinearError> {
    let n = a.dim();
    check_inputs(b, n, opts)?;
    let mut rec = Recorder::new(Method::Cg, b, opts);
    let (mut x, mut r) = start(a, b, opts, &mut rec);
    let mut p = r.clone();
    let mut q = vec![0.0; n];
    let mut rr = dot(&r, &r);
    let reason = loop {
        if rec.record(rr.sqrt(), Some(&x))? || rr == 0.0 {
            break StopReason::Converged;
        }
        if rec.next_iteration() > opts.max_iterations {
            break StopReason::MaxIterations;
        }
        a.apply(&p, &mut q);
        rec.work.applications += 1;
        let pq = dot(&p, &q);
        if pq <= 0.0 || !pq.is_finite() {
            return Err(breakdown(
                rec,
                a,
                b,
                x,
                "pᵀAp ≤ 0: the operator is not positive definite",
            ));
        }
        let alpha = rr / pq;
        axpy(alpha, &p, &mut x);
        axpy(-alpha, &q, &mut r);
        let rr_new = dot(&r, &r);
        let beta = rr_new / rr;
        rr = rr_new;
        for i in 0..n {
            p[i] = r[i] + beta * p[i];
        }
    };
    let fin = residual_norm_of(a, b, &x);
    Ok(rec.finish(x, reason, fin))
}

/// CGNR: conjugate gradients on the normal equations `AᵀA x = Aᵀ b` (Saad
/// Alg. 8.4), which minimises `‖b − A x‖₂` over a Krylov space of `AᵀA`. Works for
/// any non-singular `A` but converges with the *squared* condition number; needs
/// [`Operator::apply_transpose`]. One application and one transpose application per
/// iteration; the true-recursive residual `b − A x` is recorded.
///
/// Ziegler §2.3.3 describes the variant that solves `A Aᵀ y = b`, `x = Aᵀ y`
/// (usually called CGNE); we follow Saad's CGNR, which Ziegler §3.2 cites as the
/// implementation he used. `Aᵀ r = 0` with `r ≠ 0` (singular `A`) is a
/// [`LinearError::Breakdown`].
pub fn cgnr<A: Operator + ?Sized>(
    a: &A,
    b: &[f64],
    opts: &SolverOptions,
) -> Result<Solve, LinearError> {
    let n = a.dim();
    check_inputs(b, n, opts)?;
    let mut rec = Recorder::new(Method::Cgnr, b, opts);
    let (mut x, mut r) = start(a, b, opts, &mut rec);
    let transpose = |v: &[f64], out: &mut [f64]| -> Result<(), LinearError> {
        a.apply_transpose(v, out)
            .map_err(|source: Unsupported| LinearError::Unsupported {
                method: Method::Cgnr,
                source,
            })
    };
    let mut z = vec![0.0; n];
    transpose(&r, &mut z)?;
    rec.work.transpose_applications += 1;
    let mut p = z.clone();
    let mut w = vec![0.0; n];
    let mut zz = dot(&z, &z);
    let reason = loop {
        let rn = norm(&r);
        if rec.record(rn, Some(&x))? || rn == 0.0 {
            break StopReason::Converged;
        }
        if rec.next_iteration() > opts.max_iterations {
            break StopReason::MaxIterations;
        }
        if zz == 0.0 {
            return Err(breakdown(
                rec,
                a,
                b,
                x,
                "Aᵀr = 0 with r ≠ 0: singular operator, least-squares solution reached",
            ));
        }
        a.apply(&p, &mut w);
        rec.work.applications += 1;
        let ww = dot(&w, &w);
        if ww == 0.0 || !ww.is_finite() {
            return Err(breakdown(rec, a, b, x, "A p = 0: singular operator"));
        }
        let alpha = zz / ww;
        axpy(alpha, &p, &mut x);
        axpy(-alpha, &w, &mut r);
        transpose(&r, &mut z)?;
        rec.work.transpose_applications += 1;
        let zz_new = dot(&z, &z);
        let beta = zz_new / zz;
        zz = zz_new;
        for i in 0..n {
            p[i] = z[i] + beta * p[i];
        }
    };
    let fin = residual_norm_of(a, b, &x);
    Ok(rec.finish(x, reason, fin))
}

/// BiCGSTAB (van der Vorst 1992; Saad Alg. 7.7) for non-symmetric `A`. Two
/// applications per iteration; the recursive residual is recorded. Convergence is
/// also tested after the half step (`s`), which then ends the solve.
///
/// Breakdowns (`r̂ᵀ r ≈ 0`, `r̂ᵀ A p ≈ 0` or `ω ≈ 0`, each relative to the vector
/// norms, threshold `1e-14`) restart the method with the shadow residual `r̂ = r`;
/// a breakdown immediately after such a restart is a [`LinearError::Breakdown`].
pub fn bicgstab<A: Operator + ?Sized>(
    a: &A,
    b: &[f64],
    opts: &SolverOptions,
) -> Result<Solve, LinearError> {
    const TINY: f64 = 1e-14;
    let n = a.dim();
    check_inputs(b, n, opts)?;
    let mut rec = Recorder::new(Method::BiCgStab, b, opts);
    let (mut x, mut r) = start(a, b, opts, &mut rec);
    let mut r_hat = r.clone();
    let mut p = vec![0.0; n];
    let mut v = vec![0.0; n];
    let mut s = vec![0.0; n];
    let mut t = vec![0.0; n];
    let (mut rho_old, mut alpha, mut omega) = (1.0f64, 1.0f64, 1.0f64);
    let mut fresh = true;
    if rec.record(norm(&r), Some(&x))? {
        let fin = residual_norm_of(a, b, &x);
        return Ok(rec.finish(x, StopReason::Converged, fin));
    }
    let reason = loop {
        if rec.next_iteration() > opts.max_iterations {
            break StopReason::MaxIterations;
        }
        let rho = dot(&r_hat, &r);
        if rho.abs() <= TINY * norm(&r_hat) * norm(&r) {
            if fresh {
                return Err(breakdown(rec, a, b, x, "r̂ᵀr = 0 right after a restart"));
            }
            r_hat.copy_from_slice(&r);
            (rho_old, alpha, omega) = (1.0, 1.0, 1.0);
            p.iter_mut().for_each(|e| *e = 0.0);
            v.iter_mut().for_each(|e| *e = 0.0);
            fresh = true;
            continue;
        }
        let beta = (rho / rho_old) * (alpha / omega);
        for i in 0..n {
            p[i] = r[i] + beta * (p[i] - omega * v[i]);
        }
        a.apply(&p, &mut v);
        rec.work.applications += 1;
        let rv = dot(&r_hat, &v);
        if rv.abs() <= TINY * norm(&r_hat) * norm(&v) || !rv.is_finite() {
            if fresh {
                return Err(breakdown(rec, a, b, x, "r̂ᵀAp = 0 right after a restart"));
            }
            r_hat.copy_from_slice(&r);
            (rho_old, alpha, omega) = (1.0, 1.0, 1.0);
            p.iter_mut().for_each(|e| *e = 0.0);
            v.iter_mut().for_each(|e| *e = 0.0);
            fresh = true;
            continue;
        }
        alpha = rho / rv;
        for i in 0..n {
            s[i] = r[i] - alpha * v[i];
        }
        let s_norm = norm(&s);
        if rec.is_converged(s_norm) {
            axpy(alpha, &p, &mut x);
            r.copy_from_slice(&s);
            rec.record(s_norm, Some(&x))?;
            break StopReason::Converged;
        }
        a.apply(&s, &mut t);
        rec.work.applications += 1;
        let tt = dot(&t, &t);
        omega = if tt > 0.0 { dot(&t, &s) / tt } else { 0.0 };
        axpy(alpha, &p, &mut x);
        axpy(omega, &s, &mut x);
        for i in 0..n {
            r[i] = s[i] - omega * t[i];
        }
        rho_old = rho;
        fresh = false;
        if rec.record(norm(&r), Some(&x))? {
            break StopReason::Converged;
        }
        if omega.abs() <= TINY || !omega.is_finite() {
            // Stagnation of the stabilising step: restart with r̂ = r.
            if tt == 0.0 {
                return Err(breakdown(
                    rec,
                    a,
                    b,
                    x,
                    "A s = 0 with s ≠ 0: singular operator",
                ));
            }
            r_hat.copy_from_slice(&r);
            (rho_old, alpha, omega) = (1.0, 1.0, 1.0);
            p.iter_mut().for_each(|e| *e = 0.0);
            v.iter_mut().for_each(|e| *e = 0.0);
            fresh = true;
        }
    };
    let fin = residual_norm_of(a, b, &x);
    Ok(rec.finish(x, reason, fin))
}
