//! Small dense linear algebra used once, at construction time, to build two-scale
//! matrices (Gram–Schmidt, Gaussian elimination). Not used in transform loops.

/// Solves `a x = b` (row-major `n × n`) by Gaussian elimination with partial pivoting.
/// Returns `None` for a numerically singular matrix.
pub(crate) fn solve(mut a: Vec<f64>, mut b: Vec<f64>) -> Option<Vec<f64>> {
    let n = b.len();
    for col in 0..n {
        let piv =
            (col..n).max_by(|&i, &j| a[i * n + col].abs().total_cmp(&a[j * n + col].abs()))?;
        if a[piv * n + col].abs() < 1e-300 {
            return None;
        }
        if piv != col {
            for c in 0..n {
                a.swap(col * n + c, piv * n + c);
            }
            b.swap(col, piv);
        }
        for r in col + 1..n {
            let f = a[r * n + col] / a[col * n + col];
            if f != 0.0 {
                for c in col..n {
                    a[r * n + c] -= f * a[col * n + c];
                }
                b[r] -= f * b[col];
            }
        }
    }
    let mut x = vec![0.0; n];
    for r in (0..n).rev() {
        let mut s = b[r];
        for c in r + 1..n {
            s -= a[r * n + c] * x[c];
        }
        x[r] = s / a[r * n + r];
    }
    Some(x)
}

/// Euclidean dot product.
pub(crate) fn dotv(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Orthonormalises `vs` in place (modified Gram–Schmidt, applied twice for accuracy).
/// Vectors that become numerically zero (norm < 1e-10 of their original) are dropped.
pub(crate) fn orthonormalize(vs: Vec<Vec<f64>>) -> Vec<Vec<f64>> {
    let mut out: Vec<Vec<f64>> = Vec::new();
    for mut v in vs {
        let n0 = dotv(&v, &v).sqrt();
        for _ in 0..2 {
            for q in &out {
                let p = dotv(&v, q);
                for (vi, qi) in v.iter_mut().zip(q) {
                    *vi -= p * qi;
                }
            }
        }
        let n = dotv(&v, &v).sqrt();
        if n > 1e-10 * n0.max(1e-300) {
            v.iter_mut().for_each(|x| *x /= n);
            out.push(v);
        }
    }
    out
}

/// A unit vector orthogonal to all of `constraints` (dimension `dim`), assuming their
/// span has dimension `dim − 1`. Picks the unit basis vector with the largest residual
/// and projects it; the sign is left to the caller.
pub(crate) fn complement_vector(constraints: &[Vec<f64>], dim: usize) -> Vec<f64> {
    let q = orthonormalize(constraints.to_vec());
    let mut best: Option<(f64, Vec<f64>)> = None;
    for e in 0..dim {
        let mut v = vec![0.0; dim];
        v[e] = 1.0;
        for _ in 0..2 {
            for qv in &q {
                let p = dotv(&v, qv);
                for (vi, qi) in v.iter_mut().zip(qv) {
                    *vi -= p * qi;
                }
            }
        }
        let n = dotv(&v, &v).sqrt();
        if best.as_ref().is_none_or(|(bn, _)| n > *bn) {
            best = Some((n, v));
        }
    }
    let (n, mut v) = best.unwrap_or((1.0, vec![0.0; dim]));
    v.iter_mut().for_each(|x| *x /= n);
    v
}
