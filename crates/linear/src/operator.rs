//! Matrix-free linear operators.
//!
//! Krylov methods (Ziegler §2.3.3, §3.2) only need `y = A x` (CGNR also `y = Aᵀ x`);
//! Gauss–Seidel-like methods (Ziegler §2.3.2) need single columns (and for some
//! Table 2.1 methods single rows) of the transport operator `K`. [`Operator`] offers
//! the product as a required method and the rest as optional capabilities whose
//! default implementations report [`Unsupported`].
//!
//! Radiosity systems are written `(I − K) x = b` with `K = R G` (Ziegler §2.3.1,
//! `F = R G`); [`IdentityMinus`] turns an operator for `K` into one for `A = I − K`.
//! Unknowns are scalars: a caller with RGB radiosity solves each colour channel
//! separately with the same operator.

use nalgebra::DMatrix;

use crate::error::{LinearError, Unsupported};

/// A square linear operator of dimension [`Operator::dim`], applied matrix-free.
///
/// Implementors may panic if slices passed to them do not have length `dim()`; the
/// solvers of this crate validate lengths before calling.
pub trait Operator {
    /// Number of rows (= columns).
    fn dim(&self) -> usize;

    /// `y = A x` (overwrites `y`).
    fn apply(&self, x: &[f64], y: &mut [f64]);

    /// `y = Aᵀ x` (overwrites `y`), if supported.
    fn apply_transpose(&self, _x: &[f64], _y: &mut [f64]) -> Result<(), Unsupported> {
        Err(Unsupported::Transpose)
    }

    /// Row `i` as `(column, value)` pairs written into `out` (cleared first); zero
    /// entries may be omitted. Indices need not be sorted but must be unique.
    fn row(&self, _i: usize, _out: &mut Vec<(usize, f64)>) -> Result<(), Unsupported> {
        Err(Unsupported::Row)
    }

    /// Column `j` as `(row, value)` pairs written into `out` (cleared first); zero
    /// entries may be omitted. Indices need not be sorted but must be unique.
    fn column(&self, _j: usize, _out: &mut Vec<(usize, f64)>) -> Result<(), Unsupported> {
        Err(Unsupported::Column)
    }

    /// The diagonal written into `out` (length `dim()`).
    fn diagonal(&self, _out: &mut [f64]) -> Result<(), Unsupported> {
        Err(Unsupported::Diagonal)
    }
}

impl<T: Operator + ?Sized> Operator for &T {
    fn dim(&self) -> usize {
        (**self).dim()
    }
    fn apply(&self, x: &[f64], y: &mut [f64]) {
        (**self).apply(x, y)
    }
    fn apply_transpose(&self, x: &[f64], y: &mut [f64]) -> Result<(), Unsupported> {
        (**self).apply_transpose(x, y)
    }
    fn row(&self, i: usize, out: &mut Vec<(usize, f64)>) -> Result<(), Unsupported> {
        (**self).row(i, out)
    }
    fn column(&self, j: usize, out: &mut Vec<(usize, f64)>) -> Result<(), Unsupported> {
        (**self).column(j, out)
    }
    fn diagonal(&self, out: &mut [f64]) -> Result<(), Unsupported> {
        (**self).diagonal(out)
    }
}

/// A dense square matrix (nalgebra, column-major) as an [`Operator`] with every
/// capability.
#[derive(Debug, Clone, PartialEq)]
pub struct DenseOperator {
    m: DMatrix<f64>,
}

impl DenseOperator {
    /// Wraps a square matrix with finite entries.
    pub fn new(m: DMatrix<f64>) -> Result<Self, LinearError> {
        if m.nrows() != m.ncols() {
            return Err(LinearError::DimensionMismatch {
                what: "dense matrix columns",
                expected: m.nrows(),
                got: m.ncols(),
            });
        }
        if let Some(index) = m.iter().position(|v| !v.is_finite()) {
            return Err(LinearError::NonFiniteInput {
                what: "dense matrix (column-major index)",
                index,
            });
        }
        Ok(Self { m })
    }

    /// The wrapped matrix.
    pub fn matrix(&self) -> &DMatrix<f64> {
        &self.m
    }
}

impl Operator for DenseOperator {
    fn dim(&self) -> usize {
        self.m.nrows()
    }
    fn apply(&self, x: &[f64], y: &mut [f64]) {
        let n = self.dim();
        y.iter_mut().for_each(|v| *v = 0.0);
        for j in 0..n {
            let xj = x[j];
            if xj != 0.0 {
                let col = self.m.column(j);
                for i in 0..n {
                    y[i] += col[i] * xj;
                }
            }
        }
    }
    fn apply_transpose(&self, x: &[f64], y: &mut [f64]) -> Result<(), Unsupported> {
        for (j, yj) in y.iter_mut().enumerate() {
            *yj = self.m.column(j).iter().zip(x).map(|(a, b)| a * b).sum();
        }
        Ok(())
    }
    fn row(&self, i: usize, out: &mut Vec<(usize, f64)>) -> Result<(), Unsupported> {
        out.clear();
        out.extend(
            self.m
                .row(i)
                .iter()
                .enumerate()
                .filter(|(_, v)| **v != 0.0)
                .map(|(j, v)| (j, *v)),
        );
        Ok(())
    }
    fn column(&self, j: usize, out: &mut Vec<(usize, f64)>) -> Result<(), Unsupported> {
        out.clear();
        out.extend(
            self.m
                .column(j)
                .iter()
                .enumerate()
                .filter(|(_, v)| **v != 0.0)
                .map(|(i, v)| (i, *v)),
        );
        Ok(())
    }
    fn diagonal(&self, out: &mut [f64]) -> Result<(), Unsupported> {
        for (i, d) in out.iter_mut().enumerate() {
            *d = self.m[(i, i)];
        }
        Ok(())
    }
}

/// A square sparse matrix in compressed sparse row form, with a compressed sparse
/// column copy so that single columns (Gauss–Seidel-like methods) and transpose
/// products are as cheap as rows and products.
#[derive(Debug, Clone, PartialEq)]
pub struct CsrMatrix {
    n: usize,
    row_ptr: Vec<usize>,
    col_idx: Vec<usize>,
    values: Vec<f64>,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    col_values: Vec<f64>,
}

impl CsrMatrix {
    /// Builds an `n × n` matrix from `(row, column, value)` triplets; duplicates are
    /// summed, explicit zeros kept.
    pub fn from_triplets(n: usize, triplets: &[(usize, usize, f64)]) -> Result<Self, LinearError> {
        for (k, &(r, c, v)) in triplets.iter().enumerate() {
            if r >= n || c >= n {
                return Err(LinearError::IndexOutOfRange { row: r, col: c, n });
            }
            if !v.is_finite() {
                return Err(LinearError::NonFiniteInput {
                    what: "sparse triplets",
                    index: k,
                });
            }
        }
        let mut sorted: Vec<(usize, usize, f64)> = triplets.to_vec();
        sorted.sort_by_key(|&(r, c, _)| (r, c));
        let mut row_ptr = vec![0usize; n + 1];
        let mut col_idx = Vec::with_capacity(sorted.len());
        let mut values: Vec<f64> = Vec::with_capacity(sorted.len());
        let mut last: Option<(usize, usize)> = None;
        for (r, c, v) in sorted {
            if last == Some((r, c)) {
                *values.last_mut().expect("a previous entry exists") += v;
            } else {
                col_idx.push(c);
                values.push(v);
                row_ptr[r + 1] += 1;
                last = Some((r, c));
            }
        }
        for i in 0..n {
            row_ptr[i + 1] += row_ptr[i];
        }
        // Column copy by counting sort.
        let mut col_ptr = vec![0usize; n + 1];
        for &c in &col_idx {
            col_ptr[c + 1] += 1;
        }
        for j in 0..n {
            col_ptr[j + 1] += col_ptr[j];
        }
        let mut fill = col_ptr.clone();
        let mut row_idx = vec![0usize; col_idx.len()];
        let mut col_values = vec![0.0; col_idx.len()];
        for i in 0..n {
            for k in row_ptr[i]..row_ptr[i + 1] {
                let c = col_idx[k];
                row_idx[fill[c]] = i;
                col_values[fill[c]] = values[k];
                fill[c] += 1;
            }
        }
        Ok(Self {
            n,
            row_ptr,
            col_idx,
            values,
            col_ptr,
            row_idx,
            col_values,
        })
    }

    /// Converts a dense matrix, keeping entries with `|a_ij| > drop_tolerance`.
    pub fn from_dense(m: &DMatrix<f64>, drop_tolerance: f64) -> Result<Self, LinearError> {
        if m.nrows() != m.ncols() {
            return Err(LinearError::DimensionMismatch {
                what: "dense matrix columns",
                expected: m.nrows(),
                got: m.ncols(),
            });
        }
        let mut t = Vec::new();
        for j in 0..m.ncols() {
            for i in 0..m.nrows() {
                let v = m[(i, j)];
                if !v.is_finite() || v.abs() > drop_tolerance {
                    t.push((i, j, v));
                }
            }
        }
        Self::from_triplets(m.nrows(), &t)
    }

    /// Number of stored entries.
    pub fn nnz(&self) -> usize {
        self.values.len()
    }
}

impl Operator for CsrMatrix {
    fn dim(&self) -> usize {
        self.n
    }
    fn apply(&self, x: &[f64], y: &mut [f64]) {
        for i in 0..self.n {
            let (s, e) = (self.row_ptr[i], self.row_ptr[i + 1]);
            y[i] = self.col_idx[s..e]
                .iter()
                .zip(&self.values[s..e])
                .map(|(&c, v)| v * x[c])
                .sum();
        }
    }
    fn apply_transpose(&self, x: &[f64], y: &mut [f64]) -> Result<(), Unsupported> {
        for j in 0..self.n {
            let (s, e) = (self.col_ptr[j], self.col_ptr[j + 1]);
            y[j] = self.row_idx[s..e]
                .iter()
                .zip(&self.col_values[s..e])
                .map(|(&r, v)| v * x[r])
                .sum();
        }
        Ok(())
    }
    fn row(&self, i: usize, out: &mut Vec<(usize, f64)>) -> Result<(), Unsupported> {
        out.clear();
        let (s, e) = (self.row_ptr[i], self.row_ptr[i + 1]);
        out.extend(
            self.col_idx[s..e]
                .iter()
                .copied()
                .zip(self.values[s..e].iter().copied()),
        );
        Ok(())
    }
    fn column(&self, j: usize, out: &mut Vec<(usize, f64)>) -> Result<(), Unsupported> {
        out.clear();
        let (s, e) = (self.col_ptr[j], self.col_ptr[j + 1]);
        out.extend(
            self.row_idx[s..e]
                .iter()
                .copied()
                .zip(self.col_values[s..e].iter().copied()),
        );
        Ok(())
    }
    fn diagonal(&self, out: &mut [f64]) -> Result<(), Unsupported> {
        for i in 0..self.n {
            let (s, e) = (self.row_ptr[i], self.row_ptr[i + 1]);
            out[i] = self.col_idx[s..e]
                .iter()
                .zip(&self.values[s..e])
                .filter(|(c, _)| **c == i)
                .map(|(_, v)| *v)
                .sum();
        }
        Ok(())
    }
}

/// `A = I − K` for an operator `K`: the radiosity matrix `M = I − R G` of Ziegler
/// §2.3.1 built from the transport operator. Every capability of `K` carries over.
#[derive(Debug, Clone, Copy)]
pub struct IdentityMinus<K> {
    k: K,
}

impl<K: Operator> IdentityMinus<K> {
    /// Wraps `K` (pass a reference to keep ownership: `IdentityMinus::new(&k)`).
    pub fn new(k: K) -> Self {
        Self { k }
    }

    /// The wrapped transport operator.
    pub fn inner(&self) -> &K {
        &self.k
    }
}

fn identity_minus_entries(i: usize, out: &mut Vec<(usize, f64)>) {
    let mut seen = false;
    for (j, v) in out.iter_mut() {
        *v = -*v;
        if *j == i {
            *v += 1.0;
            seen = true;
        }
    }
    if !seen {
        out.push((i, 1.0));
    }
}

impl<K: Operator> Operator for IdentityMinus<K> {
    fn dim(&self) -> usize {
        self.k.dim()
    }
    fn apply(&self, x: &[f64], y: &mut [f64]) {
        self.k.apply(x, y);
        for (yi, xi) in y.iter_mut().zip(x) {
            *yi = xi - *yi;
        }
    }
    fn apply_transpose(&self, x: &[f64], y: &mut [f64]) -> Result<(), Unsupported> {
        self.k.apply_transpose(x, y)?;
        for (yi, xi) in y.iter_mut().zip(x) {
            *yi = xi - *yi;
        }
        Ok(())
    }
    fn row(&self, i: usize, out: &mut Vec<(usize, f64)>) -> Result<(), Unsupported> {
        self.k.row(i, out)?;
        identity_minus_entries(i, out);
        Ok(())
    }
    fn column(&self, j: usize, out: &mut Vec<(usize, f64)>) -> Result<(), Unsupported> {
        self.k.column(j, out)?;
        identity_minus_entries(j, out);
        Ok(())
    }
    fn diagonal(&self, out: &mut [f64]) -> Result<(), Unsupported> {
        self.k.diagonal(out)?;
        for d in out.iter_mut() {
            *d = 1.0 - *d;
        }
        Ok(())
    }
}

/// A matrix-free operator from a closure `(x, y) ↦ y = A x`: the form the
/// hierarchical (wavelet) solvers use, where only products are available (Ziegler
/// §2.3.4). It supports [`Operator::apply`] only; Gauss–Seidel-like methods report
/// [`Unsupported`] on it, Krylov methods except CGNR work.
pub struct FnOperator<F> {
    n: usize,
    f: F,
}

impl<F: Fn(&[f64], &mut [f64])> FnOperator<F> {
    /// Wraps `f`, which must overwrite all of `y` (length `n`) with `A x`.
    pub fn new(n: usize, f: F) -> Self {
        Self { n, f }
    }
}

impl<F> std::fmt::Debug for FnOperator<F> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FnOperator").field("n", &self.n).finish()
    }
}

impl<F: Fn(&[f64], &mut [f64])> Operator for FnOperator<F> {
    fn dim(&self) -> usize {
        self.n
    }
    fn apply(&self, x: &[f64], y: &mut [f64]) {
        (self.f)(x, y)
    }
}
