//! The active cells of the hierarchical global cube: leaves of an octree of mixed
//! levels (GlobalCube §4.2, Fig. 7), their refinement, and the traversal structure the
//! projector walks (the leaves plus maximal empty octree nodes, so rays cross void in
//! one step: a speed-up with identical results, since empty cells neither emit nor
//! attenuate).

use std::collections::HashMap;

use crate::backend::TraversalCell;
use crate::cell::{Collision, depth_of, total_weight};
use crate::hierarchy::Hierarchy;

/// One active cell: a cell of level `level` (side `2^level` voxels) at integer
/// position `pos = [x, y, z]` on that level's lattice.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize)]
pub struct Leaf {
    /// Level (0 = the input voxels).
    pub level: u8,
    /// Position on the level's lattice `[x, y, z]`.
    pub pos: [u32; 3],
}

impl Leaf {
    /// Edge in voxels.
    #[must_use]
    pub fn size(&self) -> u32 {
        1 << self.level
    }

    /// Minimum corner in voxels.
    #[must_use]
    pub fn origin(&self) -> [u32; 3] {
        self.pos.map(|p| p << self.level)
    }

    /// The eight children (level − 1), octant `k = x + 2y + 4z` at index `k`.
    #[must_use]
    pub fn children(&self) -> [Leaf; 8] {
        let l = self.level.saturating_sub(1);
        std::array::from_fn(|k| Leaf {
            level: l,
            pos: [
                2 * self.pos[0] + (k & 1) as u32,
                2 * self.pos[1] + ((k >> 1) & 1) as u32,
                2 * self.pos[2] + ((k >> 2) & 1) as u32,
            ],
        })
    }

    /// `[z, y, x]` index into the level's arrays.
    #[must_use]
    pub fn zyx(&self) -> [usize; 3] {
        [
            self.pos[2] as usize,
            self.pos[1] as usize,
            self.pos[0] as usize,
        ]
    }
}

/// Where a leaf of a refined set came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Origin {
    /// Kept: index of the same leaf in the previous set.
    Kept(usize),
    /// Child octant `k` of leaf `parent` of the previous set.
    Child {
        /// Parent index in the previous set.
        parent: usize,
        /// Octant `x + 2y + 4z`.
        octant: usize,
    },
}

/// The active leaves, in a deterministic order (children replace their parent in
/// place, octant order).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ActiveSet {
    /// Voxels per axis.
    pub side: usize,
    /// The leaves.
    pub leaves: Vec<Leaf>,
}

impl ActiveSet {
    /// Every cell of `level`, `z, y, x` order.
    #[must_use]
    pub fn uniform(side: usize, level: usize) -> Self {
        let m = (side >> level) as u32;
        let mut leaves = Vec::with_capacity((m * m * m) as usize);
        for z in 0..m {
            for y in 0..m {
                for x in 0..m {
                    leaves.push(Leaf {
                        level: level as u8,
                        pos: [x, y, z],
                    });
                }
            }
        }
        Self { side, leaves }
    }

    /// Replaces every leaf with `split[i]` (and level > 0) by its eight children.
    #[must_use]
    pub fn refine(&self, split: &[bool]) -> (Self, Vec<Origin>) {
        let mut leaves = Vec::with_capacity(self.leaves.len());
        let mut origin = Vec::with_capacity(self.leaves.len());
        for (i, leaf) in self.leaves.iter().enumerate() {
            if split.get(i).copied().unwrap_or(false) && leaf.level > 0 {
                for (k, c) in leaf.children().into_iter().enumerate() {
                    leaves.push(c);
                    origin.push(Origin::Child {
                        parent: i,
                        octant: k,
                    });
                }
            } else {
                leaves.push(*leaf);
                origin.push(Origin::Kept(i));
            }
        }
        (
            Self {
                side: self.side,
                leaves,
            },
            origin,
        )
    }

    /// Number of leaves per level (index = level).
    #[must_use]
    pub fn per_level(&self, levels: usize) -> Vec<usize> {
        let mut c = vec![0; levels + 1];
        for l in &self.leaves {
            if (l.level as usize) < c.len() {
                c[l.level as usize] += 1;
            }
        }
        c
    }
}

/// Per-leaf values read from the hierarchy.
#[derive(Debug, Clone, PartialEq)]
pub struct LeafData {
    /// Opacity across the leaf's side.
    pub opacity: Vec<f64>,
    /// Source (W/m³) per channel.
    pub source: Vec<[f64; 3]>,
    /// Albedo per channel.
    pub albedo: Vec<[f64; 3]>,
}

impl LeafData {
    /// Reads the values of every leaf.
    #[must_use]
    pub fn new(set: &ActiveSet, h: &Hierarchy) -> Self {
        let mut opacity = Vec::with_capacity(set.leaves.len());
        let mut source = Vec::with_capacity(set.leaves.len());
        let mut albedo = Vec::with_capacity(set.leaves.len());
        for l in &set.leaves {
            let (lv, i) = (l.level as usize, l.zyx());
            opacity.push(h.opacity[lv][i]);
            source.push([0, 1, 2].map(|c| h.source[lv][c][i]));
            albedo.push([0, 1, 2].map(|c| h.albedo[lv][c][i]));
        }
        Self {
            opacity,
            source,
            albedo,
        }
    }
}

/// The structure the projector walks: the leaves (indices `0..leaves`) followed by
/// maximal empty octree nodes, and the voxel-to-cell map.
#[derive(Debug, Clone, PartialEq)]
pub struct Traversal {
    /// Cells (leaves first).
    pub cells: Vec<TraversalCell>,
    /// `side³` map, x fastest.
    pub map: Vec<u32>,
}

/// Memo of `Ĝ` by optical depth (bit pattern): homogeneous regions share values.
#[derive(Debug, Default, Clone)]
pub struct WeightCache {
    map: HashMap<(u64, bool), f64>,
}

impl WeightCache {
    /// `Ĝ(depth)` under `mode`.
    pub fn get(&mut self, depth: f64, mode: Collision) -> f64 {
        *self
            .map
            .entry((depth.to_bits(), mode == Collision::Plain))
            .or_insert_with(|| total_weight(depth, mode))
    }
}

impl Traversal {
    /// Builds the cells and the map for `set` with per-leaf `data`. Octree nodes made
    /// only of empty leaves (σ = 0, no source) become single cells.
    #[must_use]
    pub fn new(
        set: &ActiveSet,
        data: &LeafData,
        collision: Collision,
        cache: &mut WeightCache,
    ) -> Self {
        let n = set.side;
        let mut cells = Vec::with_capacity(set.leaves.len());
        for (i, l) in set.leaves.iter().enumerate() {
            let size = l.size();
            let depth = depth_of(data.opacity[i]);
            let extinction = if depth == f64::INFINITY {
                f64::INFINITY
            } else {
                depth / f64::from(size)
            };
            cells.push(TraversalCell {
                origin: l.origin(),
                size,
                extinction,
                total_weight: cache.get(depth, collision),
            });
        }
        let mut map = vec![0u32; n * n * n];
        let mut empty_voxel = vec![false; n * n * n];
        for (i, c) in cells.iter().enumerate() {
            paint(&mut map, n, c.origin, c.size, i as u32);
            if data.opacity[i] == 0.0 && data.source[i].iter().all(|&s| s == 0.0) {
                paint_flag(&mut empty_voxel, n, c.origin, c.size);
            }
        }
        // Maximal empty nodes of level >= 1.
        let top = n.trailing_zeros() as usize;
        let mut empty: Vec<Vec<bool>> = vec![empty_voxel];
        for l in 1..=top {
            let m = n >> l;
            let prev = &empty[l - 1];
            let pm = 2 * m;
            let mut cur = vec![false; m * m * m];
            for z in 0..m {
                for y in 0..m {
                    for x in 0..m {
                        let mut all = true;
                        for k in 0..8 {
                            let (dx, dy, dz) = (k & 1, (k >> 1) & 1, k >> 2);
                            all &= prev[(2 * x + dx) + pm * ((2 * y + dy) + pm * (2 * z + dz))];
                        }
                        cur[x + m * (y + m * z)] = all;
                    }
                }
            }
            empty.push(cur);
        }
        for l in (1..=top).rev() {
            let m = n >> l;
            for z in 0..m {
                for y in 0..m {
                    for x in 0..m {
                        if !empty[l][x + m * (y + m * z)] {
                            continue;
                        }
                        let parent_empty = l < top && {
                            let pm = m / 2;
                            empty[l + 1][x / 2 + pm * (y / 2 + pm * (z / 2))]
                        };
                        if parent_empty {
                            continue;
                        }
                        let origin = [x, y, z].map(|v| (v << l) as u32);
                        let idx = cells.len() as u32;
                        cells.push(TraversalCell {
                            origin,
                            size: 1 << l,
                            extinction: 0.0,
                            total_weight: 0.0,
                        });
                        paint(&mut map, n, origin, 1 << l, idx);
                    }
                }
            }
        }
        Self { cells, map }
    }
}

fn paint(map: &mut [u32], n: usize, origin: [u32; 3], size: u32, v: u32) {
    let [x0, y0, z0] = origin.map(|o| o as usize);
    let s = size as usize;
    for z in z0..z0 + s {
        for y in y0..y0 + s {
            let row = n * (y + n * z);
            map[row + x0..row + x0 + s].fill(v);
        }
    }
}

fn paint_flag(map: &mut [bool], n: usize, origin: [u32; 3], size: u32) {
    let [x0, y0, z0] = origin.map(|o| o as usize);
    let s = size as usize;
    for z in z0..z0 + s {
        for y in y0..y0 + s {
            let row = n * (y + n * z);
            map[row + x0..row + x0 + s].fill(true);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refine_replaces_in_place_and_covers_the_grid() {
        let s = ActiveSet::uniform(8, 2);
        assert_eq!(s.leaves.len(), 8);
        let mut split = vec![false; 8];
        split[3] = true;
        let (r, o) = s.refine(&split);
        assert_eq!(r.leaves.len(), 15);
        assert_eq!(
            o[3],
            Origin::Child {
                parent: 3,
                octant: 0
            }
        );
        assert_eq!(o[11], Origin::Kept(4));
        let vol: u32 = r.leaves.iter().map(|l| l.size().pow(3)).sum();
        assert_eq!(vol, 512);
    }
}
