//! The hierarchical (non-standard) linear system and its matrix-free application:
//! pull (projection of leaf coefficients to every node, VirtualMesh §5.2) → gather over
//! links (`H_R += T B_E`) → push (irradiance from every node down to the leaves) →
//! multiply by `ρ`. This is `K = D_ρ P_down L P_up` with `P_down = P_upᵀ` (orthonormal
//! two-scale matrices), so `Kᵀ = P_down Lᵀ P_up D_ρ` is as cheap (CGNR needs it).
//!
//! Unknowns are the leaf coefficients of one colour channel, `x[leaf·k² + a]`
//! (wavelux-linear solves scalar systems; the three channels are three solves with the
//! same links, or one when the scene is grey). Every parallel loop (rayon) runs over
//! nodes and accumulates each node's sum in a fixed order — no floating-point atomics
//! — so results do not depend on the number of threads.

use rayon::prelude::*;
use wavelux_linear::{Operator, Unsupported};

use crate::basis::TreeBasis;
use crate::hierarchy::{Hierarchy, NodeKey};
use crate::mask::Coverage;
use crate::support::{Patch, Support};
use crate::transfer::Region;

/// Gauss points per axis of [`real_integral`].
const MOMENT_GAUSS: usize = 4;
/// Subdivision depth of partial cells in [`real_integral`].
const MOMENT_DEPTH: u32 = 3;

/// `∫_{cell ∩ real} ψ_a(local) dA` over the sub-square `sub` of the leaf `leaf`
/// (accumulated into `m`) and the real area (returned): full cells by a 4×4 Gauss rule
/// of the area element, partial cells split 3 levels deep, then Gauss points weighted
/// by the real fraction of their Gauss cell (VirtualMesh §4.2, Fig. 7). The area is
/// exact for equal-area maps (the fractions are).
fn real_integral(
    sup: &Support,
    basis: &TreeBasis,
    leaf: &Region,
    sub: &Region,
    depth: u32,
    m: &mut [f64],
    buf: &mut [f64],
) -> f64 {
    let cov = sup.coverage(sub.s0, sub.t0, sub.h);
    if cov == Coverage::Empty {
        return 0.0;
    }
    if cov == Coverage::Partial && depth < MOMENT_DEPTH {
        let h = 0.5 * sub.h;
        let mut a = 0.0;
        for c in 0..4 {
            let r = Region {
                patch: sub.patch,
                s0: sub.s0 + h * (c % 2) as f64,
                t0: sub.t0 + h * (c / 2) as f64,
                h,
            };
            a += real_integral(sup, basis, leaf, &r, depth + 1, m, buf);
        }
        return a;
    }
    let Ok(g) = wavelux_quadrature::GaussLegendre::new(MOMENT_GAUSS) else {
        return 0.0;
    };
    let (x, w) = g.unit();
    let mut c = [0.0; MOMENT_GAUSS + 1];
    for i in 0..MOMENT_GAUSS {
        c[i + 1] = c[i] + w[i];
    }
    let mut area = 0.0;
    for j in 0..MOMENT_GAUSS {
        for i in 0..MOMENT_GAUSS {
            let (s, t) = (sub.s0 + sub.h * x[i], sub.t0 + sub.h * x[j]);
            let mut wt = w[i] * w[j] * sub.h * sub.h * sup.jacobian(s, t);
            if cov == Coverage::Partial {
                wt *= sup.real_fraction_rect(
                    sub.s0 + sub.h * c[i],
                    sub.t0 + sub.h * c[j],
                    sub.h * w[i],
                    sub.h * w[j],
                );
            }
            if wt == 0.0 {
                continue;
            }
            area += wt;
            basis.eval((s - leaf.s0) / leaf.h, (t - leaf.t0) / leaf.h, buf);
            for (mv, b) in m.iter_mut().zip(buf.iter()) {
                *mv += wt * b;
            }
        }
    }
    area
}

/// Real area, real moments `∫_{cell ∩ real} φ_a dA` (`φ_a = ψ_a/√a`, `a` the cell's
/// nominal area `area·h²`) and coverage of a cell of a support (closed form for full
/// cells of equal-area maps, else [`real_integral`]). Shared by [`System::new`] and the
/// shooting solver's element trees.
pub(crate) fn cell_real_moments(
    sup: &Support,
    basis: &TreeBasis,
    r: &Region,
    a: f64,
) -> (f64, Vec<f64>, Coverage) {
    let n = basis.n();
    let cov = sup.coverage(r.s0, r.t0, r.h);
    match cov {
        Coverage::Empty => (0.0, vec![0.0; n], cov),
        Coverage::Full if sup.is_equal_area() => (
            a,
            basis.integrals().iter().map(|v| v * a.sqrt()).collect(),
            cov,
        ),
        _ => {
            let mut m = vec![0.0; n];
            let mut buf = vec![0.0; n];
            let area = real_integral(sup, basis, r, r, 0, &mut m, &mut buf);
            m.iter_mut().for_each(|v| *v /= a.sqrt());
            (area, m, cov)
        }
    }
}

/// The assembled system: hierarchy, links, per-leaf reflectance and emission.
#[derive(Debug, Clone)]
pub struct System {
    /// The hierarchy and links.
    pub(crate) h: Hierarchy,
    /// Two-scale matrices (`n × n`, `[parent * n + child]`) per child position.
    child: [Vec<f64>; 4],
    /// `∫ψ_a` on the unit cell.
    integrals: Vec<f64>,
    /// Reflectance per leaf and channel.
    pub leaf_rho: Vec<[f64; 3]>,
    /// Area per node.
    pub node_area: Vec<f64>,
    /// Emission (exitance) per patch and channel.
    pub patch_emission: Vec<[f64; 3]>,
    /// Patch of each node.
    node_patch: Vec<u32>,
    /// World area of the real part of each leaf (VirtualMesh §4.2: only real points
    /// emit; exact for equal-area maps).
    pub leaf_real_area: Vec<f64>,
    /// `∫_{leaf ∩ real} φ_a dA` per leaf (`n` each): the real-area integrals of the
    /// leaf's orthonormal functions, so that `∫_real B dA = Σ_a b_a · m_a`.
    pub leaf_real_moments: Vec<f64>,
    /// Leaves by coverage: `[empty, partial, full]` (unmasked leaves are full).
    pub coverage_counts: [usize; 3],
    /// Nodes of each patch in level order.
    patch_nodes: Vec<Vec<u32>>,
    /// Irradiance per channel (leaf coefficients) that does not depend on the
    /// radiosity: the closure's emitted part ([`crate::closure::Closure::source`]),
    /// added to the right-hand side by [`Self::source`] (times the reflectance) and to
    /// a solution's irradiance; empty when none.
    extra_irradiance: [Vec<f64>; 3],
    /// Cluster links between groups of patch roots ([`crate::cluster`]), applied
    /// beside the links by every gather; `None` without clustering.
    clusters: Option<Box<crate::cluster::ClusterOp>>,
}

impl System {
    /// Builds the system from a compiled hierarchy.
    pub fn new(h: Hierarchy, basis: &TreeBasis, patches: &[Patch]) -> Self {
        let child = std::array::from_fn(|c| basis.child_matrix(c).to_vec());
        let node_area: Vec<f64> = h
            .keys
            .iter()
            .map(|k| patches[k.patch as usize].support.area * 0.25f64.powi(k.level as i32))
            .collect();
        let leaf_rho = h
            .leaves
            .iter()
            .map(|&i| patches[h.keys[i as usize].patch as usize].reflectance)
            .collect();
        let node_patch: Vec<u32> = h.keys.iter().map(|k| k.patch).collect();
        let n = h.n;
        let per_leaf: Vec<(f64, Vec<f64>, Coverage)> = h
            .leaves
            .par_iter()
            .map(|&i| {
                let k = h.keys[i as usize];
                let sup = &patches[k.patch as usize].support;
                cell_real_moments(sup, basis, &k.region(), node_area[i as usize])
            })
            .collect();
        let mut coverage_counts = [0usize; 3];
        let mut leaf_real_area = Vec::with_capacity(per_leaf.len());
        let mut leaf_real_moments = Vec::with_capacity(per_leaf.len() * n);
        for (a, m, c) in per_leaf {
            leaf_real_area.push(a);
            leaf_real_moments.extend(m);
            coverage_counts[match c {
                Coverage::Empty => 0,
                Coverage::Partial => 1,
                Coverage::Full => 2,
            }] += 1;
        }
        let mut patch_nodes = vec![Vec::new(); patches.len()];
        for (i, k) in h.keys.iter().enumerate() {
            patch_nodes[k.patch as usize].push(i as u32);
        }
        Self {
            h,
            child,
            integrals: basis.integrals().to_vec(),
            leaf_rho,
            node_area,
            patch_emission: patches.iter().map(|p| p.emission).collect(),
            node_patch,
            patch_nodes,
            leaf_real_area,
            leaf_real_moments,
            coverage_counts,
            extra_irradiance: std::array::from_fn(|_| Vec::new()),
            clusters: None,
        }
    }

    /// The system with the cluster links `clusters` ([`crate::cluster`]) applied beside
    /// the links (no change when `None` or empty).
    pub fn with_clusters(
        mut self,
        clusters: Option<&crate::cluster::ClusterLinks>,
        basis: &TreeBasis,
        patches: &[Patch],
    ) -> Self {
        self.clusters = clusters
            .filter(|c| !c.is_empty())
            .map(|c| Box::new(c.operator(&self.h, basis, patches)));
        self
    }

    /// Whether cluster links are applied (see [`Self::with_clusters`]).
    pub fn has_clusters(&self) -> bool {
        self.clusters.is_some()
    }

    /// The system with the closure's emitted part as an extra source: `source` holds
    /// per leaf node (by key) and channel the irradiance coefficients
    /// `Σ_l δ_il (E_{E_l} − E_i)` of [`crate::closure::Closure::source`] (`n` per
    /// channel, channel-major). Keys that are not leaves are ignored.
    pub fn with_closure_source(mut self, source: &[(NodeKey, Vec<f64>)]) -> Self {
        if source.is_empty() {
            return self;
        }
        let n = self.h.n;
        let dim = self.dim();
        let mut extra: [Vec<f64>; 3] = std::array::from_fn(|_| vec![0.0; dim]);
        for (key, s) in source {
            let Ok(node) = self.h.keys.binary_search(key) else {
                continue;
            };
            let leaf = self.h.leaf_of[node];
            if leaf == u32::MAX {
                continue;
            }
            let l = leaf as usize;
            for (c, e) in extra.iter_mut().enumerate() {
                for a in 0..n {
                    e[l * n + a] += s[c * n + a];
                }
            }
        }
        self.extra_irradiance = extra;
        self
    }

    /// The irradiance of channel `ch` that does not depend on the radiosity (leaf
    /// coefficients, [`Self::with_closure_source`]); `None` when there is none. A
    /// solution's irradiance is [`Self::irradiance`] of its radiosity plus this.
    pub fn closure_irradiance(&self, ch: usize) -> Option<&[f64]> {
        self.extra_irradiance
            .get(ch)
            .filter(|e| !e.is_empty())
            .map(Vec::as_slice)
    }

    /// The hierarchy and links (read-only).
    pub fn hierarchy(&self) -> &Hierarchy {
        &self.h
    }

    /// Number of unknowns per channel (`leaves × k²`).
    pub fn dim(&self) -> usize {
        self.h.leaves.len() * self.h.n
    }

    /// `∫ψ_a` on the unit cell.
    pub fn integrals(&self) -> &[f64] {
        &self.integrals
    }

    /// The emission vector `b` of a channel: leaf coefficients of the (constant per
    /// patch) exitance, `E √A_leaf ∫ψ_a`.
    pub fn emission(&self, ch: usize) -> Vec<f64> {
        let n = self.h.n;
        let mut b = vec![0.0; self.dim()];
        for (l, &i) in self.h.leaves.iter().enumerate() {
            let e = self.patch_emission[self.node_patch[i as usize] as usize][ch];
            let s = self.node_area[i as usize].sqrt();
            for a in 0..n {
                b[l * n + a] = e * s * self.integrals[a];
            }
        }
        b
    }

    /// The right-hand side `b` of a channel's solve: [`Self::emission`] plus the
    /// closure's emitted part ([`Self::with_closure_source`]), so that the closure
    /// links act on the reflected radiosity `B − E` only.
    pub fn source(&self, ch: usize) -> Vec<f64> {
        let mut b = self.emission(ch);
        if let Some(extra) = self.closure_irradiance(ch) {
            let n = self.h.n;
            for (l, (b, e)) in b.chunks_mut(n).zip(extra.chunks(n)).enumerate() {
                let rho = self.leaf_rho[l][ch];
                b.iter_mut().zip(e).for_each(|(b, e)| *b += rho * e);
            }
        }
        b
    }

    /// Writes leaf values into a node vector and pulls them to every node.
    pub fn pull_from_leaves(&self, x: &[f64], nodes: &mut [f64]) {
        let n = self.h.n;
        nodes.iter_mut().for_each(|v| *v = 0.0);
        for (l, &i) in self.h.leaves.iter().enumerate() {
            nodes[i as usize * n..][..n].copy_from_slice(&x[l * n..][..n]);
        }
        self.pull(nodes);
    }

    /// Fills every internal node with the projection of its children (finest level
    /// first).
    pub fn pull(&self, nodes: &mut [f64]) {
        let n = self.h.n;
        let ls = &self.h.level_start;
        for l in (0..ls.len() - 2).rev() {
            let (lo, hi) = nodes.split_at_mut(ls[l + 1] * n);
            let base = ls[l + 1];
            lo[ls[l] * n..]
                .par_chunks_mut(n)
                .enumerate()
                .for_each(|(j, out)| {
                    let i = ls[l] + j;
                    let ch = self.h.children[i];
                    if ch[0] == u32::MAX {
                        return;
                    }
                    out.iter_mut().for_each(|v| *v = 0.0);
                    for (c, &ci) in ch.iter().enumerate() {
                        let cv = &hi[(ci as usize - base) * n..][..n];
                        let m = &self.child[c];
                        for a in 0..n {
                            let mut s = 0.0;
                            for b in 0..n {
                                s += m[a * n + b] * cv[b];
                            }
                            out[a] += s;
                        }
                    }
                });
        }
    }

    /// Adds every node's value to its children (coarsest level first), so the leaves
    /// hold the total.
    pub fn push(&self, nodes: &mut [f64]) {
        let n = self.h.n;
        let ls = &self.h.level_start;
        for l in 1..ls.len() - 1 {
            let (lo, hi) = nodes.split_at_mut(ls[l] * n);
            hi[..(ls[l + 1] - ls[l]) * n]
                .par_chunks_mut(n)
                .enumerate()
                .for_each(|(j, out)| {
                    let i = ls[l] + j;
                    let p = self.h.parent[i] as usize;
                    let pv = &lo[p * n..][..n];
                    let m = &self.child[self.h.keys[i].child_pos()];
                    for b in 0..n {
                        let mut s = 0.0;
                        for a in 0..n {
                            s += m[a * n + b] * pv[a];
                        }
                        out[b] += s;
                    }
                });
        }
    }

    /// `dst[R] = Σ_{links R←E} T · src[E]` for every node.
    pub fn gather(&self, src: &[f64], dst: &mut [f64]) {
        let n = self.h.n;
        let h = &self.h;
        dst.par_chunks_mut(n).enumerate().for_each(|(r, out)| {
            out.iter_mut().for_each(|v| *v = 0.0);
            for l in h.recv_offsets[r]..h.recv_offsets[r + 1] {
                let e = h.link_emitter[l] as usize;
                let blk = &h.blocks[l * n * n..][..n * n];
                let sv = &src[e * n..][..n];
                for a in 0..n {
                    let mut s = 0.0;
                    for b in 0..n {
                        s += blk[a * n + b] * sv[b];
                    }
                    out[a] += s;
                }
            }
        });
        if let Some(c) = &self.clusters {
            c.gather(src, dst);
        }
    }

    /// `dst[E] = Σ_{links R←E} Tᵀ · src[R]` for every node.
    pub fn scatter_transpose(&self, src: &[f64], dst: &mut [f64]) {
        let n = self.h.n;
        let h = &self.h;
        dst.par_chunks_mut(n).enumerate().for_each(|(e, out)| {
            out.iter_mut().for_each(|v| *v = 0.0);
            for &l in &h.by_emitter[h.emit_offsets[e]..h.emit_offsets[e + 1]] {
                let l = l as usize;
                let r = h.link_receiver[l] as usize;
                let blk = &h.blocks[l * n * n..][..n * n];
                let sv = &src[r * n..][..n];
                for b in 0..n {
                    let mut s = 0.0;
                    for a in 0..n {
                        s += blk[a * n + b] * sv[a];
                    }
                    out[b] += s;
                }
            }
        });
        if let Some(c) = &self.clusters {
            c.scatter_transpose(src, dst);
        }
    }

    /// Irradiance at the leaves for leaf radiosity `x` (no reflectance applied):
    /// `P_down L P_up x`.
    pub fn irradiance(&self, x: &[f64]) -> Vec<f64> {
        let n = self.h.n;
        let nn = self.h.node_count() * n;
        let mut b = vec![0.0; nn];
        self.pull_from_leaves(x, &mut b);
        let mut g = vec![0.0; nn];
        self.gather(&b, &mut g);
        self.push(&mut g);
        let mut y = vec![0.0; self.dim()];
        for (l, &i) in self.h.leaves.iter().enumerate() {
            y[l * n..][..n].copy_from_slice(&g[i as usize * n..][..n]);
        }
        y
    }

    /// `y = K x` for channel `ch`.
    pub fn apply_k(&self, ch: usize, x: &[f64], y: &mut [f64]) {
        let n = self.h.n;
        let hv = self.irradiance(x);
        for (l, rho) in self.leaf_rho.iter().enumerate() {
            for a in 0..n {
                y[l * n + a] = rho[ch] * hv[l * n + a];
            }
        }
    }

    /// `y = Kᵀ x` for channel `ch`.
    pub fn apply_kt(&self, ch: usize, x: &[f64], y: &mut [f64]) {
        let n = self.h.n;
        let nn = self.h.node_count() * n;
        let mut rx = vec![0.0; self.dim()];
        for (l, rho) in self.leaf_rho.iter().enumerate() {
            for a in 0..n {
                rx[l * n + a] = rho[ch] * x[l * n + a];
            }
        }
        let mut v = vec![0.0; nn];
        self.pull_from_leaves(&rx, &mut v);
        let mut g = vec![0.0; nn];
        self.scatter_transpose(&v, &mut g);
        self.push(&mut g);
        for (l, &i) in self.h.leaves.iter().enumerate() {
            y[l * n..][..n].copy_from_slice(&g[i as usize * n..][..n]);
        }
    }

    /// One hierarchical Gauss–Seidel sweep over patches ("Gauss–Seidel over links"):
    /// patch by patch, gather over the links of its nodes with the current radiosity
    /// of every emitter, push, set `B = E + ρH` at its leaves and pull, so later patches
    /// see the update. Deterministic (sequential over patches).
    pub fn gauss_seidel_sweep(&self, ch: usize, b: &[f64], x: &mut [f64]) {
        let n = self.h.n;
        let nn = self.h.node_count() * n;
        let mut nodes = vec![0.0; nn];
        self.pull_from_leaves(x, &mut nodes);
        let mut hv = vec![0.0; nn];
        // Cluster links gather from the radiosity at the start of the sweep (their
        // transport is bounded small, see crate::cluster): a Jacobi part of the sweep.
        let lagged = self.clusters.as_ref().map(|c| {
            let mut g = vec![0.0; nn];
            c.gather(&nodes, &mut g);
            g
        });
        for list in &self.patch_nodes {
            if list.is_empty() {
                continue;
            }
            // Gather into this patch's nodes (level order), then push within it.
            for &i in list {
                let i = i as usize;
                let out = &mut hv[i * n..][..n];
                match &lagged {
                    Some(g) => out.copy_from_slice(&g[i * n..][..n]),
                    None => out.iter_mut().for_each(|v| *v = 0.0),
                }
                for l in self.h.recv_offsets[i]..self.h.recv_offsets[i + 1] {
                    let e = self.h.link_emitter[l] as usize;
                    let blk = &self.h.blocks[l * n * n..][..n * n];
                    for a in 0..n {
                        let mut s = 0.0;
                        for bb in 0..n {
                            s += blk[a * n + bb] * nodes[e * n + bb];
                        }
                        out[a] += s;
                    }
                }
            }
            for &i in list {
                let i = i as usize;
                let p = self.h.parent[i];
                if p == u32::MAX {
                    continue;
                }
                let m = &self.child[self.h.keys[i].child_pos()];
                for bb in 0..n {
                    let mut s = 0.0;
                    for a in 0..n {
                        s += m[a * n + bb] * hv[p as usize * n + a];
                    }
                    hv[i * n + bb] += s;
                }
            }
            // Leaves: B = E + ρ H; then pull within the patch (reverse level order).
            for &i in list {
                let i = i as usize;
                let l = self.h.leaf_of[i];
                if l == u32::MAX {
                    continue;
                }
                let l = l as usize;
                let rho = self.leaf_rho[l][ch];
                for a in 0..n {
                    let v = b[l * n + a] + rho * hv[i * n + a];
                    x[l * n + a] = v;
                    nodes[i * n + a] = v;
                }
            }
            for &i in list.iter().rev() {
                let i = i as usize;
                let ch4 = self.h.children[i];
                if ch4[0] == u32::MAX {
                    continue;
                }
                for a in 0..n {
                    let mut s = 0.0;
                    for (c, &ci) in ch4.iter().enumerate() {
                        let m = &self.child[c];
                        for bb in 0..n {
                            s += m[a * n + bb] * nodes[ci as usize * n + bb];
                        }
                    }
                    nodes[i * n + a] = s;
                }
            }
        }
    }

    /// The operator `K` of one channel for `wavelux-linear`.
    pub fn channel(&self, ch: usize) -> ChannelOperator<'_> {
        ChannelOperator { sys: self, ch }
    }
}

/// `K` of one colour channel as a [`wavelux_linear::Operator`] (apply and transpose).
#[derive(Debug, Clone, Copy)]
pub struct ChannelOperator<'a> {
    sys: &'a System,
    ch: usize,
}

impl Operator for ChannelOperator<'_> {
    fn dim(&self) -> usize {
        self.sys.dim()
    }

    fn apply(&self, x: &[f64], y: &mut [f64]) {
        self.sys.apply_k(self.ch, x, y);
    }

    fn apply_transpose(&self, x: &[f64], y: &mut [f64]) -> Result<(), Unsupported> {
        self.sys.apply_kt(self.ch, x, y);
        Ok(())
    }
}
