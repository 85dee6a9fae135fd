//! Matrix–vector product backends (issue 17 (b)): explicit matrices a device can
//! hold, the contract a device product must meet, the CPU reference and an
//! [`Operator`] adapter for the iterative solvers.
//!
//! A [`MatVecBackend`] prepares (uploads) one [`Matrix`] once; the
//! [`PreparedMatVec`] applies it, or its transpose, to `k ≤ 4` interleaved
//! right-hand sides (`x[j·k + l]` is entry `j` of right-hand side `l`) into a
//! caller-owned slice.
//!
//! # Contract (against [`CpuMatVec`])
//! For every row `i` and right-hand side,
//! `|y_dev − y_cpu|ᵢ ≤ 1e-6·(|A||x|)ᵢ + 1e-30·max|A|·max|x|` ([`CONTRACT_REL`],
//! [`CONTRACT_ABS`]), and the same input on the same device gives bitwise the same
//! output (fixed reduction order, no float atomics). The CPU reference sums in f64,
//! block row by block row, blocks in storage order, columns in order: it is
//! deterministic and independent of the thread count.

use std::fmt::Debug;
use std::sync::Mutex;

use crate::error::{LinearError, Unsupported};
use crate::operator::Operator;

/// Relative bound of the device contract (module docs).
pub const CONTRACT_REL: f64 = 1e-6;
/// Absolute bound of the device contract, times `max|A|·max|x|` (module docs).
pub const CONTRACT_ABS: f64 = 1e-30;
/// Largest block dimension of [`Bsr`] (rows and columns).
pub const MAX_BLOCK: usize = 16;
/// Largest number of interleaved right-hand sides.
pub const MAX_RHS: usize = 4;

/// A block-sparse matrix in block-row CSR form: `r×c` blocks (`r, c ≤ 16`), each
/// stored row-major; block row `I` holds blocks `row_ptr[I]..row_ptr[I+1]` at block
/// columns `col_idx[..]`. Dimensions are `block_rows·r × block_cols·c`.
#[derive(Debug, Clone, PartialEq)]
pub struct Bsr {
    r: usize,
    c: usize,
    block_rows: usize,
    block_cols: usize,
    row_ptr: Vec<usize>,
    col_idx: Vec<usize>,
    values: Vec<f64>,
}

impl Bsr {
    /// Validated block-sparse matrix.
    ///
    /// # Errors
    /// [`LinearError::InvalidParameter`] for block sizes outside `1..=16`;
    /// [`LinearError::DimensionMismatch`] for a `row_ptr` of the wrong length, not
    /// starting at 0, decreasing, or not ending at `col_idx.len()`, or `values` not
    /// `col_idx.len()·r·c` long; [`LinearError::IndexOutOfRange`] for a block column
    /// outside the matrix; [`LinearError::NonFiniteInput`] for NaN or ∞ values.
    pub fn new(
        (r, c): (usize, usize),
        (block_rows, block_cols): (usize, usize),
        row_ptr: Vec<usize>,
        col_idx: Vec<usize>,
        values: Vec<f64>,
    ) -> Result<Bsr, LinearError> {
        for (what, v) in [("block rows r", r), ("block columns c", c)] {
            if v == 0 || v > MAX_BLOCK {
                return Err(LinearError::InvalidParameter {
                    what,
                    value: v as f64,
                    requirement: "1 ≤ block size ≤ 16",
                });
            }
        }
        if row_ptr.len() != block_rows + 1 {
            return Err(LinearError::DimensionMismatch {
                what: "BSR row_ptr length",
                expected: block_rows + 1,
                got: row_ptr.len(),
            });
        }
        if row_ptr[0] != 0 || row_ptr[block_rows] != col_idx.len() {
            return Err(LinearError::DimensionMismatch {
                what: "BSR row_ptr end points",
                expected: col_idx.len(),
                got: row_ptr[block_rows],
            });
        }
        if let Some(i) = row_ptr.windows(2).position(|w| w[1] < w[0]) {
            return Err(LinearError::DimensionMismatch {
                what: "BSR row_ptr (decreasing at block row)",
                expected: row_ptr[i],
                got: row_ptr[i + 1],
            });
        }
        if values.len() != col_idx.len() * r * c {
            return Err(LinearError::DimensionMismatch {
                what: "BSR values length",
                expected: col_idx.len() * r * c,
                got: values.len(),
            });
        }
        for br in 0..block_rows {
            for &bc in &col_idx[row_ptr[br]..row_ptr[br + 1]] {
                if bc >= block_cols {
                    return Err(LinearError::IndexOutOfRange {
                        row: br,
                        col: bc,
                        n: block_cols,
                    });
                }
            }
        }
        if let Some(index) = values.iter().position(|v| !v.is_finite()) {
            return Err(LinearError::NonFiniteInput {
                what: "BSR values",
                index,
            });
        }
        Ok(Bsr {
            r,
            c,
            block_rows,
            block_cols,
            row_ptr,
            col_idx,
            values,
        })
    }

    /// Block size `(r, c)`.
    pub fn block_size(&self) -> (usize, usize) {
        (self.r, self.c)
    }
    /// Number of block rows and block columns.
    pub fn block_dims(&self) -> (usize, usize) {
        (self.block_rows, self.block_cols)
    }
    /// Block-row pointers (length `block_rows + 1`).
    pub fn row_ptr(&self) -> &[usize] {
        &self.row_ptr
    }
    /// Block column of every stored block.
    pub fn col_idx(&self) -> &[usize] {
        &self.col_idx
    }
    /// Block values, `r·c` per block, row-major within a block.
    pub fn values(&self) -> &[f64] {
        &self.values
    }

    /// The transpose (`c×r` blocks, block rows in order, blocks sorted by block column
    /// within each block row, stable in the original storage order).
    pub fn transpose(&self) -> Bsr {
        let (r, c) = (self.r, self.c);
        let mut count = vec![0usize; self.block_cols + 1];
        for &bc in &self.col_idx {
            count[bc + 1] += 1;
        }
        for i in 0..self.block_cols {
            count[i + 1] += count[i];
        }
        let row_ptr = count.clone();
        let mut next = count;
        let nb = self.col_idx.len();
        let mut col_idx = vec![0usize; nb];
        let mut values = vec![0.0; nb * r * c];
        for br in 0..self.block_rows {
            for b in self.row_ptr[br]..self.row_ptr[br + 1] {
                let bc = self.col_idx[b];
                let dst = next[bc];
                next[bc] += 1;
                col_idx[dst] = br;
                let src = &self.values[b * r * c..(b + 1) * r * c];
                let out = &mut values[dst * r * c..(dst + 1) * r * c];
                for i in 0..r {
                    for j in 0..c {
                        out[j * r + i] = src[i * c + j];
                    }
                }
            }
        }
        Bsr {
            r: c,
            c: r,
            block_rows: self.block_cols,
            block_cols: self.block_rows,
            row_ptr,
            col_idx,
            values,
        }
    }
}

/// An explicit matrix a device can hold (f64).
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum Matrix {
    /// Dense, row-major: entry `(i, j)` is `values[i·cols + j]`.
    Dense {
        /// Number of rows.
        rows: usize,
        /// Number of columns.
        cols: usize,
        /// Row-major entries.
        values: Vec<f64>,
    },
    /// Block-sparse (block-row CSR).
    BlockSparse(Bsr),
}

impl Matrix {
    /// Validated dense matrix (row-major).
    ///
    /// # Errors
    /// [`LinearError::DimensionMismatch`] if `values.len() != rows·cols`;
    /// [`LinearError::NonFiniteInput`] for NaN or ∞ entries.
    pub fn dense(rows: usize, cols: usize, values: Vec<f64>) -> Result<Matrix, LinearError> {
        if values.len() != rows * cols {
            return Err(LinearError::DimensionMismatch {
                what: "dense matrix values",
                expected: rows * cols,
                got: values.len(),
            });
        }
        if let Some(index) = values.iter().position(|v| !v.is_finite()) {
            return Err(LinearError::NonFiniteInput {
                what: "dense matrix (row-major index)",
                index,
            });
        }
        Ok(Matrix::Dense { rows, cols, values })
    }

    /// Number of rows.
    pub fn rows(&self) -> usize {
        match self {
            Matrix::Dense { rows, .. } => *rows,
            Matrix::BlockSparse(b) => b.block_rows * b.r,
        }
    }

    /// Number of columns.
    pub fn cols(&self) -> usize {
        match self {
            Matrix::Dense { cols, .. } => *cols,
            Matrix::BlockSparse(b) => b.block_cols * b.c,
        }
    }

    /// The stored values (dense entries or block values).
    pub fn stored_values(&self) -> &[f64] {
        match self {
            Matrix::Dense { values, .. } => values,
            Matrix::BlockSparse(b) => &b.values,
        }
    }

    /// The transpose, in the same storage kind.
    pub fn transpose(&self) -> Matrix {
        match self {
            Matrix::Dense { rows, cols, values } => {
                let mut t = vec![0.0; values.len()];
                for i in 0..*rows {
                    for j in 0..*cols {
                        t[j * rows + i] = values[i * cols + j];
                    }
                }
                Matrix::Dense {
                    rows: *cols,
                    cols: *rows,
                    values: t,
                }
            }
            Matrix::BlockSparse(b) => Matrix::BlockSparse(b.transpose()),
        }
    }

    /// The matrix of absolute values `|A|` (for the contract's bound `|A||x|`).
    pub fn abs(&self) -> Matrix {
        let mut m = self.clone();
        match &mut m {
            Matrix::Dense { values, .. } => values.iter_mut().for_each(|v| *v = v.abs()),
            Matrix::BlockSparse(b) => b.values.iter_mut().for_each(|v| *v = v.abs()),
        }
        m
    }

    /// `y = A x` for `k` interleaved right-hand sides, in f64 in the reference order
    /// (module docs). Lengths are checked by [`check_lengths`].
    fn apply_f64(&self, k: usize, x: &[f64], y: &mut [f64]) {
        y.iter_mut().for_each(|v| *v = 0.0);
        match self {
            Matrix::Dense { rows, cols, values } => {
                for i in 0..*rows {
                    let row = &values[i * cols..(i + 1) * cols];
                    for l in 0..k {
                        let mut s = 0.0;
                        for (j, a) in row.iter().enumerate() {
                            s += a * x[j * k + l];
                        }
                        y[i * k + l] = s;
                    }
                }
            }
            Matrix::BlockSparse(b) => {
                let (r, c) = (b.r, b.c);
                for br in 0..b.block_rows {
                    for i in 0..r {
                        for l in 0..k {
                            let mut s = 0.0;
                            for blk in b.row_ptr[br]..b.row_ptr[br + 1] {
                                let bc = b.col_idx[blk];
                                let vals =
                                    &b.values[blk * r * c + i * c..blk * r * c + (i + 1) * c];
                                for (j, a) in vals.iter().enumerate() {
                                    s += a * x[(bc * c + j) * k + l];
                                }
                            }
                            y[(br * r + i) * k + l] = s;
                        }
                    }
                }
            }
        }
    }
}

/// Checks `k ∈ 1..=4`, `x.len() = cols·k`, `y.len() = rows·k` and finite `x`.
///
/// # Errors
/// [`LinearError::InvalidParameter`], [`LinearError::DimensionMismatch`] or
/// [`LinearError::NonFiniteInput`].
pub fn check_lengths(
    rows: usize,
    cols: usize,
    k: usize,
    x: &[f64],
    y: &[f64],
) -> Result<(), LinearError> {
    if k == 0 || k > MAX_RHS {
        return Err(LinearError::InvalidParameter {
            what: "right-hand sides k",
            value: k as f64,
            requirement: "1 ≤ k ≤ 4",
        });
    }
    if x.len() != cols * k {
        return Err(LinearError::DimensionMismatch {
            what: "matvec x",
            expected: cols * k,
            got: x.len(),
        });
    }
    if y.len() != rows * k {
        return Err(LinearError::DimensionMismatch {
            what: "matvec y",
            expected: rows * k,
            got: y.len(),
        });
    }
    if let Some(index) = x.iter().position(|v| !v.is_finite()) {
        return Err(LinearError::NonFiniteInput {
            what: "matvec x",
            index,
        });
    }
    Ok(())
}

/// What one product cost.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct MatVecStats {
    /// Stored matrix entries read (`nnz` of the applied matrix, once per product).
    pub entries: usize,
    /// Device dispatches (chunks) used; 0 on the CPU.
    pub dispatches: usize,
}

/// A matrix prepared on a device (module docs: contract).
pub trait PreparedMatVec: Send + Sync {
    /// Rows of `A`.
    fn rows(&self) -> usize;
    /// Columns of `A`.
    fn cols(&self) -> usize;
    /// `y = A x` for `k` interleaved right-hand sides (`x.len() = cols·k`,
    /// `y.len() = rows·k`).
    ///
    /// # Errors
    /// Bad lengths or `k` ([`check_lengths`]); [`LinearError::Backend`] if the device
    /// failed (then `y` is unspecified).
    fn apply(&self, k: usize, x: &[f64], y: &mut [f64]) -> Result<MatVecStats, LinearError>;
    /// `y = Aᵀ x` for `k` interleaved right-hand sides (`x.len() = rows·k`,
    /// `y.len() = cols·k`).
    ///
    /// # Errors
    /// As [`PreparedMatVec::apply`].
    fn apply_transpose(
        &self,
        k: usize,
        x: &[f64],
        y: &mut [f64],
    ) -> Result<MatVecStats, LinearError>;
}

/// A device able to hold matrices.
pub trait MatVecBackend: Send + Sync + Debug {
    /// Human-readable name (for GPUs: adapter name and API).
    fn name(&self) -> String;
    /// Uploads `m` once.
    ///
    /// # Errors
    /// [`LinearError::Backend`] if the device cannot hold it.
    fn prepare<'a>(&self, m: &'a Matrix) -> Result<Box<dyn PreparedMatVec + 'a>, LinearError>;
}

/// The CPU reference backend (f64, fixed order; module docs).
#[derive(Debug, Clone, Copy, Default)]
pub struct CpuMatVec;

/// A matrix prepared by [`CpuMatVec`]: the matrix and its transpose.
#[derive(Debug, Clone)]
pub struct CpuPrepared<'a> {
    m: &'a Matrix,
    t: Matrix,
}

impl MatVecBackend for CpuMatVec {
    fn name(&self) -> String {
        "cpu".to_owned()
    }
    fn prepare<'a>(&self, m: &'a Matrix) -> Result<Box<dyn PreparedMatVec + 'a>, LinearError> {
        Ok(Box::new(CpuPrepared {
            m,
            t: m.transpose(),
        }))
    }
}

impl CpuPrepared<'_> {
    fn run(m: &Matrix, k: usize, x: &[f64], y: &mut [f64]) -> Result<MatVecStats, LinearError> {
        check_lengths(m.rows(), m.cols(), k, x, y)?;
        m.apply_f64(k, x, y);
        Ok(MatVecStats {
            entries: m.stored_values().len(),
            dispatches: 0,
        })
    }
}

impl PreparedMatVec for CpuPrepared<'_> {
    fn rows(&self) -> usize {
        self.m.rows()
    }
    fn cols(&self) -> usize {
        self.m.cols()
    }
    fn apply(&self, k: usize, x: &[f64], y: &mut [f64]) -> Result<MatVecStats, LinearError> {
        Self::run(self.m, k, x, y)
    }
    fn apply_transpose(
        &self,
        k: usize,
        x: &[f64],
        y: &mut [f64],
    ) -> Result<MatVecStats, LinearError> {
        Self::run(&self.t, k, x, y)
    }
}

/// A prepared square matrix as an [`Operator`] for the iterative solvers: a device
/// error writes NaN into `y` (the solver then stops with a typed error,
/// [`LinearError::NonFiniteIterate`] or [`LinearError::Breakdown`]) and is kept for
/// the report ([`Self::error`]).
pub struct BackendOperator<'a> {
    prepared: Box<dyn PreparedMatVec + 'a>,
    error: Mutex<Option<LinearError>>,
    stats: Mutex<MatVecStats>,
}

impl std::fmt::Debug for BackendOperator<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("BackendOperator")
            .field("dim", &self.prepared.rows())
            .finish_non_exhaustive()
    }
}

impl<'a> BackendOperator<'a> {
    /// Wraps a prepared square matrix.
    ///
    /// # Errors
    /// [`LinearError::DimensionMismatch`] if it is not square.
    pub fn new(prepared: Box<dyn PreparedMatVec + 'a>) -> Result<Self, LinearError> {
        if prepared.rows() != prepared.cols() {
            return Err(LinearError::DimensionMismatch {
                what: "backend operator columns",
                expected: prepared.rows(),
                got: prepared.cols(),
            });
        }
        Ok(BackendOperator {
            prepared,
            error: Mutex::new(None),
            stats: Mutex::new(MatVecStats::default()),
        })
    }

    /// The first device error met, if any.
    pub fn error(&self) -> Option<LinearError> {
        self.error.lock().ok().and_then(|e| e.clone())
    }

    /// Accumulated statistics of every product so far.
    pub fn stats(&self) -> MatVecStats {
        self.stats.lock().map(|s| *s).unwrap_or_default()
    }

    fn record(&self, r: Result<MatVecStats, LinearError>, y: &mut [f64]) {
        match r {
            Ok(s) => {
                if let Ok(mut t) = self.stats.lock() {
                    t.entries += s.entries;
                    t.dispatches += s.dispatches;
                }
            }
            Err(e) => {
                y.iter_mut().for_each(|v| *v = f64::NAN);
                if let Ok(mut slot) = self.error.lock() {
                    slot.get_or_insert(e);
                }
            }
        }
    }
}

impl Operator for BackendOperator<'_> {
    fn dim(&self) -> usize {
        self.prepared.rows()
    }
    fn apply(&self, x: &[f64], y: &mut [f64]) {
        let r = self.prepared.apply(1, x, y);
        self.record(r, y);
    }
    fn apply_transpose(&self, x: &[f64], y: &mut [f64]) -> Result<(), Unsupported> {
        let r = self.prepared.apply_transpose(1, x, y);
        self.record(r, y);
        Ok(())
    }
}
