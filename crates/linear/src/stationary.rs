//! Picard (Jacobi for the radiosity system) and general Jacobi iteration.
//!
//! Ziegler §2.3.2 eq. (2.16): for `M = I − K` with `diag(M) = I`, one Jacobi sweep is
//! the Picard step `x⁽ᵏ⁺¹⁾ = b + K x⁽ᵏ⁾ = x⁽ᵏ⁾ + r⁽ᵏ⁾`, a partial sum of the Neumann
//! series `Σ Kⁱ b` (eq. (2.3)): iteration `k` adds one more bounce of light. Ziegler
//! §3.3.5 uses 80 Picard iterations as the default solver for wavelet radiosity.
//! [`jacobi`] is the general form `x ← x + D⁻¹ (b − A x)` for an operator whose
//! diagonal is available.

use crate::error::LinearError;
use crate::history::{Method, Solve, SolverOptions, StopReason};
use crate::operator::Operator;
use crate::util::{Recorder, check_inputs, fixed_point_residual_norm, norm, residual_norm_of};

/// Picard iteration for the fixed-point problem `x = b + K x`, i.e. `(I − K) x = b`.
///
/// Record `k` holds `x⁽ᵏ⁾` and its exact residual `r⁽ᵏ⁾ = b + K x⁽ᵏ⁾ − x⁽ᵏ⁾`; it
/// costs one application of `K` per iteration (none for record 0 when no initial
/// guess is given, since then `x⁽⁰⁾ = 0` and `r⁽⁰⁾ = b`, so that `x⁽ᵏ⁾ = Σ_{i<k} Kⁱ b`).
/// Converges for any `b` iff the spectral radius of `K` is below 1; the residual
/// contracts by about that radius per iteration (slow as reflectance → 1).
///
/// Ziegler §4.2.2 starts from `x⁽⁰⁾ = b`; pass `b` as the initial guess to
/// reproduce his curves (record `k` then equals his iteration `k`, and record 0
/// costs one application). With the default `x⁽⁰⁾ = 0`, record `k + 1` is his `k`.
pub fn picard<K: Operator + ?Sized>(
    k: &K,
    b: &[f64],
    opts: &SolverOptions,
) -> Result<Solve, LinearError> {
    let n = k.dim();
    check_inputs(b, n, opts)?;
    let mut rec = Recorder::new(Method::Picard, b, opts);
    let mut kx = vec![0.0; n];
    let mut r = b.to_vec();
    let mut x = match &opts.initial_guess {
        Some(x0) => {
            let x0 = x0.clone();
            k.apply(&x0, &mut kx);
            rec.work.applications += 1;
            for i in 0..n {
                r[i] = b[i] + kx[i] - x0[i];
            }
            x0
        }
        None => vec![0.0; n],
    };
    let reason = loop {
        if rec.record(norm(&r), Some(&x))? {
            break StopReason::Converged;
        }
        if rec.next_iteration() > opts.max_iterations {
            break StopReason::MaxIterations;
        }
        for i in 0..n {
            x[i] += r[i];
        }
        k.apply(&x, &mut kx);
        rec.work.applications += 1;
        for i in 0..n {
            r[i] = b[i] + kx[i] - x[i];
        }
    };
    let fin = fixed_point_residual_norm(k, b, &x);
    Ok(rec.finish(x, reason, fin))
}

/// Jacobi iteration `x ← x + D⁻¹ (b − A x)` for a general operator `A` with
/// available, non-zero diagonal `D`. One application of `A` per iteration. For
/// `A = I − K` with zero-diagonal `K` this is exactly [`picard`] on `K`.
///
/// Converges for strictly diagonally dominant `A`.
pub fn jacobi<A: Operator + ?Sized>(
    a: &A,
    b: &[f64],
    opts: &SolverOptions,
) -> Result<Solve, LinearError> {
    let n = a.dim();
    check_inputs(b, n, opts)?;
    let mut d = vec![0.0; n];
    a.diagonal(&mut d)
        .map_err(|source| LinearError::Unsupported {
            method: Method::Jacobi,
            source,
        })?;
    if let Some(&bad) = d.iter().find(|v| **v == 0.0 || !v.is_finite()) {
        return Err(LinearError::InvalidParameter {
            what: "diagonal entry",
            value: bad,
            requirement: "Jacobi needs a finite, non-zero diagonal",
        });
    }
    let mut rec = Recorder::new(Method::Jacobi, b, opts);
    let mut ax = vec![0.0; n];
    let mut r = b.to_vec();
    let mut x = match &opts.initial_guess {
        Some(x0) => {
            a.apply(x0, &mut ax);
            rec.work.applications += 1;
            for i in 0..n {
                r[i] = b[i] - ax[i];
            }
            x0.clone()
        }
        None => vec![0.0; n],
    };
    let reason = loop {
        if rec.record(norm(&r), Some(&x))? {
            break StopReason::Converged;
        }
        if rec.next_iteration() > opts.max_iterations {
            break StopReason::MaxIterations;
        }
        for i in 0..n {
            x[i] += r[i] / d[i];
        }
        a.apply(&x, &mut ax);
        rec.work.applications += 1;
        for i in 0..n {
            r[i] = b[i] - ax[i];
        }
    };
    let fin = residual_norm_of(a, b, &x);
    Ok(rec.finish(x, reason, fin))
}
