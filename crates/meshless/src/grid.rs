//! A hashed uniform grid over the points of one level (Meshless §2.1 "Efficient
//! Reconstruction"; ours instead of the seed's R-tree): one support radius `r_l` per
//! level, cells of side `r_l`, so the 3×3×3 cells around a query hold every function
//! that can be non-zero there (`dist_j(x) >= ‖x − x_j‖`, see `kernel`).
//!
//! Cells are keyed by their integer coordinates packed into 63 bits (21 per axis,
//! wrapping); two far-apart cells that share a key merely add candidates that the
//! weight test then rejects, so the packing never loses a function. Points are stored
//! sorted by cell, each cell's points in increasing index order, and queries visit the
//! 27 cells in a fixed order: every sum over a query is in a deterministic order.

use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

use glam::DVec3;

/// A multiply–xorshift hasher for the packed cell keys (SipHash is needlessly slow
/// for 8-byte integer keys; the keys are not attacker-controlled).
#[derive(Default, Clone, Copy)]
pub(crate) struct KeyHasher(u64);

impl Hasher for KeyHasher {
    fn finish(&self) -> u64 {
        let mut z = self.0.wrapping_mul(0x9E37_79B9_7F4A_7C15);
        z ^= z >> 29;
        z
    }
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0 ^ u64::from(b)).wrapping_mul(0x0100_0000_01B3);
        }
    }
    fn write_u64(&mut self, v: u64) {
        self.0 = v;
    }
}

pub(crate) type KeyMap<V> = HashMap<u64, V, BuildHasherDefault<KeyHasher>>;

const MASK: i64 = (1 << 21) - 1;

fn pack(c: [i64; 3]) -> u64 {
    (((c[0] & MASK) << 42) | ((c[1] & MASK) << 21) | (c[2] & MASK)) as u64
}

/// Integer cell coordinates of `x` for cells of side `cell` (saturating for
/// non-finite input, which then finds nothing useful but never panics).
pub(crate) fn cell_of(x: DVec3, inv_cell: f64) -> [i64; 3] {
    let f = |v: f64| (v * inv_cell).floor() as i64;
    [f(x.x), f(x.y), f(x.z)]
}

/// The hashed grid of one level.
#[derive(Debug, Clone, Default)]
pub(crate) struct Grid {
    inv_cell: f64,
    /// Packed cell key → range in `order`.
    cells: KeyMap<(u32, u32)>,
    /// Point indices (global) sorted by cell, then index.
    order: Vec<u32>,
}

impl Grid {
    /// A grid of cell side `cell > 0` over the points `xs`, whose global indices are
    /// `first + k`.
    pub(crate) fn build(xs: &[DVec3], first: usize, cell: f64) -> Self {
        let inv_cell = 1.0 / cell;
        let mut keyed: Vec<(u64, u32)> = xs
            .iter()
            .enumerate()
            .map(|(k, x)| (pack(cell_of(*x, inv_cell)), (first + k) as u32))
            .collect();
        keyed.sort_unstable();
        let mut cells = KeyMap::default();
        let mut s = 0;
        while s < keyed.len() {
            let key = keyed[s].0;
            let mut e = s;
            while e < keyed.len() && keyed[e].0 == key {
                e += 1;
            }
            cells.insert(key, (s as u32, (e - s) as u32));
            s = e;
        }
        Self {
            inv_cell,
            cells,
            order: keyed.into_iter().map(|(_, i)| i).collect(),
        }
    }

    /// Calls `f(i)` for every point in the 27 cells around `x` (a superset of the
    /// points within distance `cell` of `x`), in a fixed order.
    #[inline]
    pub(crate) fn for_each_near(&self, x: DVec3, mut f: impl FnMut(u32)) {
        let c = cell_of(x, self.inv_cell);
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    let key = pack([c[0] + dx, c[1] + dy, c[2] + dz]);
                    if let Some(&(s, n)) = self.cells.get(&key) {
                        for &i in &self.order[s as usize..(s + n) as usize] {
                            f(i);
                        }
                    }
                }
            }
        }
    }

    /// Heap bytes held.
    pub(crate) fn bytes(&self) -> usize {
        self.order.len() * 4 + self.cells.capacity() * 24
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};

    #[test]
    fn finds_every_point_within_one_cell() {
        let mut rng = rand_pcg::Pcg64::seed_from_u64(7);
        let xs: Vec<DVec3> = (0..2000)
            .map(|_| DVec3::new(rng.random(), rng.random(), rng.random()) * 10.0 - 5.0)
            .collect();
        let cell = 0.7;
        let g = Grid::build(&xs, 100, cell);
        for _ in 0..200 {
            let q = DVec3::new(rng.random(), rng.random(), rng.random()) * 12.0 - 6.0;
            let mut found = Vec::new();
            g.for_each_near(q, |i| found.push(i));
            let want: Vec<u32> = (0..xs.len())
                .filter(|&k| (xs[k] - q).length() < cell)
                .map(|k| (k + 100) as u32)
                .collect();
            for w in want {
                assert!(found.contains(&w));
            }
        }
    }
}
