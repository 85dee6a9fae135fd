//! Sparse link matrices (`T`, `S`): rows are receiver functions (every basis point),
//! columns sender functions (the points of the first `L_s` levels), and each link is
//! the RGB vector irradiance at the receiver per unit scalar irradiance at the sender:
//! nine dimensionless numbers `[r.x, r.y, r.z, g.x, g.y, g.z, b.x, b.y, b.z]`
//! (Meshless §3.1: senders carry scalar direct irradiance, receivers vector
//! irradiance). The link norm is the largest channel's vector length.

use serde::{Deserialize, Serialize};

/// One link: RGB × xyz, channel-major.
pub type Link = [f64; 9];

/// `‖T_ij‖`: the largest over the three channels of the vector length.
#[inline]
pub fn link_norm(l: &Link) -> f64 {
    let c = |k: usize| (l[k] * l[k] + l[k + 1] * l[k + 1] + l[k + 2] * l[k + 2]).sqrt();
    c(0).max(c(3)).max(c(6))
}

/// `‖a − b‖` without a temporary.
#[inline]
pub(crate) fn link_diff_norm(a: &Link, b: &Link) -> f64 {
    let c = |k: usize| {
        let (x, y, z) = (a[k] - b[k], a[k + 1] - b[k + 1], a[k + 2] - b[k + 2]);
        (x * x + y * y + z * z).sqrt()
    };
    c(0).max(c(3)).max(c(6))
}

/// A sparse link matrix in compressed rows (columns sorted within a row).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TransferMatrix {
    pub(crate) rows: usize,
    pub(crate) cols: usize,
    pub(crate) row_ptr: Vec<usize>,
    pub(crate) col: Vec<u32>,
    pub(crate) val: Vec<Link>,
}

/// Size summary of a link matrix.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct MatrixStats {
    /// Receivers (rows).
    pub rows: usize,
    /// Senders (columns).
    pub cols: usize,
    /// Stored links.
    pub links: usize,
    /// Rows with at least one link.
    pub rows_used: usize,
    /// `links / (rows · cols)`.
    pub fraction: f64,
}

impl TransferMatrix {
    /// An empty `rows × cols` matrix.
    pub fn zeros(rows: usize, cols: usize) -> Self {
        Self {
            rows,
            cols,
            row_ptr: vec![0; rows + 1],
            col: Vec::new(),
            val: Vec::new(),
        }
    }

    /// Builds from sorted rows `(row, entries)`, rows increasing (rows absent are empty).
    pub(crate) fn from_rows(
        rows: usize,
        cols: usize,
        list: Vec<(usize, Vec<(u32, Link)>)>,
    ) -> Self {
        let mut m = Self::zeros(rows, cols);
        let mut r = 0;
        for (i, entries) in list {
            while r < i {
                r += 1;
                m.row_ptr[r] = m.col.len();
            }
            for (j, v) in entries {
                m.col.push(j);
                m.val.push(v);
            }
        }
        while r < rows {
            r += 1;
            m.row_ptr[r] = m.col.len();
        }
        m
    }

    /// Number of rows (receivers).
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Number of columns (senders).
    pub fn cols(&self) -> usize {
        self.cols
    }

    /// Number of stored links.
    pub fn nnz(&self) -> usize {
        self.col.len()
    }

    /// Row `i` as `(sender columns, links)`.
    pub fn row(&self, i: usize) -> (&[u32], &[Link]) {
        let (a, b) = (self.row_ptr[i], self.row_ptr[i + 1]);
        (&self.col[a..b], &self.val[a..b])
    }

    /// The link `(i, j)` if stored.
    pub fn get(&self, i: usize, j: usize) -> Option<&Link> {
        let (c, v) = self.row(i);
        c.binary_search(&(j as u32)).ok().map(|k| &v[k])
    }

    /// Heap bytes (f64 storage).
    pub fn bytes(&self) -> usize {
        self.row_ptr.len() * 8 + self.col.len() * 4 + self.val.len() * 72
    }

    /// Size summary.
    pub fn stats(&self) -> MatrixStats {
        let rows_used = (0..self.rows)
            .filter(|&i| self.row_ptr[i + 1] > self.row_ptr[i])
            .count();
        let pot = self.rows as f64 * self.cols as f64;
        MatrixStats {
            rows: self.rows,
            cols: self.cols,
            links: self.nnz(),
            rows_used,
            fraction: if pot > 0.0 {
                self.nnz() as f64 / pot
            } else {
                0.0
            },
        }
    }

    /// `y = M x` in f64 (the reference the backends are tested against): `x` holds RGB
    /// sender values (3 per column), `y` RGB vectors (9 per row), overwritten.
    pub fn apply_f64(&self, x: &[f64], y: &mut [f64]) {
        for i in 0..self.rows {
            let out = &mut y[i * 9..(i + 1) * 9];
            out.iter_mut().for_each(|v| *v = 0.0);
            let (c, v) = self.row(i);
            for (j, l) in c.iter().zip(v) {
                let e = &x[*j as usize * 3..*j as usize * 3 + 3];
                for ch in 0..3 {
                    for a in 0..3 {
                        out[ch * 3 + a] += l[ch * 3 + a] * e[ch];
                    }
                }
            }
        }
    }

    /// `self + other` (same shape), keeping every stored entry of both.
    pub(crate) fn add(&self, other: &TransferMatrix) -> TransferMatrix {
        let mut list = Vec::with_capacity(self.rows);
        for i in 0..self.rows {
            let (ca, va) = self.row(i);
            let (cb, vb) = other.row(i);
            let mut out = Vec::with_capacity(ca.len() + cb.len());
            let (mut p, mut q) = (0, 0);
            while p < ca.len() || q < cb.len() {
                if q >= cb.len() || (p < ca.len() && ca[p] < cb[q]) {
                    out.push((ca[p], va[p]));
                    p += 1;
                } else if p >= ca.len() || cb[q] < ca[p] {
                    out.push((cb[q], vb[q]));
                    q += 1;
                } else {
                    let mut s = va[p];
                    for k in 0..9 {
                        s[k] += vb[q][k];
                    }
                    out.push((ca[p], s));
                    p += 1;
                    q += 1;
                }
            }
            list.push((i, out));
        }
        TransferMatrix::from_rows(self.rows, self.cols, list)
    }
}
