//! Hierarchical radiosity with clustering for the initial links (Smits, Arvo &
//! Greenberg 1994, "A clustering algorithm for radiosity in complex environments";
//! Sillion 1995, "A unified hierarchical algorithm for global illumination with
//! scattering volumes and object clusters").
//!
//! Without clustering the initial linking joins every pair of patch roots, so `n`
//! surfaces cost `O(n²)` links before refinement starts. Here the patch roots are
//! grouped by a bounding-volume hierarchy (obvhs' binary BVH, PLOC build; every node
//! a [`Cluster`] with its f64 bounds, real area, area-weighted centre and largest
//! reflectance). Linking starts at the root cluster's interaction with itself and
//! descends: a pair of distinct clusters whose conservative transport bound is small
//! becomes one *cluster link*; a pair of single patches becomes an ordinary root link
//! refined by [`crate::hierarchy::refine_link`] as before; any other pair splits the
//! cluster with the larger bounds (a cluster paired with itself splits into its
//! children's pairs).
//!
//! **The bound** (BF refinement, Hanrahan et al. 1991, applied to clusters as in
//! Smits et al. §4): a point `x` of `R` receives from `E` at most
//! `∫_E cos θ_x cos θ_y / (π r²) dA_y ≤ A_E / (π d²) =: F̄(R ← E)` (`d` the distance of
//! the two bounding boxes, `A_E` the real area of `E`'s members, capped at 1), so the
//! radiosity the link carries is at most `ρ_R · B̂_E · F̄` with `ρ_R` the largest
//! reflectance in `R` and `B̂_E` the largest brightness of `E`'s members plus the
//! scene's predicted mean reflected radiosity `B̄` ([`crate::target`]'s prediction:
//! emitted power over receiving area times the mean reflectance). A pair is linked
//! as a cluster when `ρ_R · B̂_E · F̄ ≤ tol · B̄`. Whatever the link's approximation,
//! its error at any point is at most that bound (both the link's value and the true
//! transport lie in `[0, ρ_R B̂_E F̄]`), so a cluster link's error is at most
//! `tol · B̄` wherever `B̂_E` bounds the emitters' radiosity.
//!
//! **The transfer** of a cluster link (Smits et al.'s α-link with per-member cosines,
//! rather than their isotropic average): member `j` of `E` is a point source of
//! power `Φ_j = ∫_{j, real} B dA` at the cluster centre seen from `R`, weighted by its
//! cosine factor `g_j` towards `R`'s centre (`max(0, n_j · ω)`, or its
//! Jacobian-weighted average over 3 × 3 points of a curved support) and by the square
//! root of its visible fraction `V_j` (the share of its rays to the [`VIS_MEMBERS`]
//! members of `R` that carry the most `g · A`); member `i` of `R` receives the
//! constant irradiance `H_i = g_i √V_i / (π D²) · Σ_j g_j √V_j Φ_j` (`D` the distance
//! of the centres). That is, per member pair, the point-to-point form factor
//! `A_j g_i g_j √(V_i V_j) / (π D²)`: reciprocal (`A_i F_ij = A_j F_ji`; one visible
//! fraction per link, as Smits et al. use, let a chair's legs under its seat receive
//! what the seat sees), made with `3 (|R| + |E|)` rays and applied in `O(|R| + |E|)`
//! per link: the emitters'
//! power is gathered (pulled from the leaves to the roots by the system's pull) and
//! the irradiance is pushed from the roots to the leaves by the system's push
//! ([`ClusterOp`], applied by [`crate::System`]'s gather and its transpose).
//!
//! What it does not do: cluster links are made once, before the first solve (later
//! multigrid stages re-refine the ordinary links only), carry only the constant
//! part of the emitters' radiosity and deposit a constant irradiance per member
//! root, and their error is bounded by the refinement, not estimated (the
//! a-posteriori estimate of [`crate::target`] is not run with clustering).

use std::time::Duration;

use glam::{DVec3, Vec3A};
use obvhs::BvhBuildParams;
use obvhs::aabb::Aabb as FAabb;
use obvhs::bvh2::Bvh2;
use obvhs::bvh2::builder::build_bvh2;
use rayon::prelude::*;

use crate::Prepared;
use crate::basis::TreeBasis;
use crate::hierarchy::{self, Hierarchy, LinkRec, NodeKey, RefineCounts, RefineParams};
use crate::support::Patch;
use crate::system::cell_real_moments;
use crate::transfer::TransferCtx;

/// Members per side whose centres the visibility rays of a cluster link join.
pub const VIS_MEMBERS: usize = 3;

/// A node of the cluster hierarchy: a group of patch roots.
#[derive(Debug, Clone, PartialEq)]
pub struct Cluster {
    /// Lower corner of the members' bounds (scene units).
    pub lo: DVec3,
    /// Upper corner of the members' bounds (scene units).
    pub hi: DVec3,
    /// Member patches (indices into the patch list), ascending.
    pub members: Vec<u32>,
    /// Child clusters (none for a single patch).
    pub children: Vec<u32>,
    /// Real area of the members that can emit or reflect (m²).
    pub area: f64,
    /// Area-weighted centre of the members' bounds.
    pub centre: DVec3,
    /// Largest reflectance of any member, any channel.
    pub rho: f64,
}

impl Cluster {
    /// Distance between the bounds of two clusters (0 when they overlap or touch).
    pub fn distance(&self, o: &Cluster) -> f64 {
        let gap = (self.lo - o.hi).max(o.lo - self.hi).max(DVec3::ZERO);
        gap.length()
    }

    /// Length of the bounds' diagonal.
    pub fn diagonal(&self) -> f64 {
        (self.hi - self.lo).length()
    }
}

/// The cluster hierarchy over the roots of a patch list (root cluster first).
#[derive(Debug, Clone, PartialEq)]
pub struct ClusterTree {
    /// Clusters; `nodes[0]` holds every patch (absent for no patches).
    pub nodes: Vec<Cluster>,
}

/// Bounds and centre of one patch: the corners of a parallelogram, else the
/// support's bounding sphere.
fn patch_bounds(p: &Patch) -> (DVec3, DVec3, DVec3) {
    let sup = &p.support;
    if sup.is_affine() {
        let c = sup.corners(0.0, 0.0, 1.0);
        let lo = c.iter().fold(c[0], |a, b| a.min(*b));
        let hi = c.iter().fold(c[0], |a, b| a.max(*b));
        (lo, hi, 0.25 * (c[0] + c[1] + c[2] + c[3]))
    } else {
        let (m, r) = sup.bounding_sphere(0.0, 0.0, 1.0);
        (m - DVec3::splat(r), m + DVec3::splat(r), m)
    }
}

impl ClusterTree {
    /// Builds the hierarchy with obvhs (binary BVH, PLOC, one patch per leaf) and
    /// computes every cluster's f64 bounds and sums from its members.
    pub fn build(patches: &[Patch]) -> Self {
        let bounds: Vec<(DVec3, DVec3, DVec3)> = patches.iter().map(patch_bounds).collect();
        let mut nodes = Vec::new();
        if patches.is_empty() {
            return Self { nodes };
        }
        if patches.len() == 1 {
            nodes.push(leaf_cluster(patches, &bounds, &[0]));
            return Self { nodes };
        }
        let boxes: Vec<FAabb> = bounds
            .iter()
            .map(|(lo, hi, _)| {
                FAabb::new(
                    Vec3A::new(lo.x as f32, lo.y as f32, lo.z as f32),
                    Vec3A::new(hi.x as f32, hi.y as f32, hi.z as f32),
                )
            })
            .collect();
        // PLOC pairs each node with the best of its neighbours in Morton order;
        // obvhs scales each axis of the scene's bounds to [0, 1] before coding, so
        // in a flat scene the order interleaves far-apart layers. The widest window
        // from the first pass on lets the surface-area choice see past that.
        let params = BvhBuildParams {
            max_prims_per_leaf: 1,
            ploc_search_distance: obvhs::ploc::PlocSearchDistance::High,
            search_depth_threshold: 0,
            ..BvhBuildParams::medium_build()
        };
        let bvh = build_bvh2(&boxes, params, &mut Duration::default());
        convert(&bvh, 0, patches, &bounds, &mut nodes);
        Self { nodes }
    }
}

/// A cluster of the given members with no children.
fn leaf_cluster(patches: &[Patch], bounds: &[(DVec3, DVec3, DVec3)], members: &[u32]) -> Cluster {
    let mut c = Cluster {
        lo: DVec3::splat(f64::INFINITY),
        hi: DVec3::splat(f64::NEG_INFINITY),
        members: members.to_vec(),
        children: Vec::new(),
        area: 0.0,
        centre: DVec3::ZERO,
        rho: 0.0,
    };
    c.members.sort_unstable();
    let mut weight = 0.0;
    for &m in &c.members {
        let (lo, hi, centre) = bounds[m as usize];
        let p = &patches[m as usize];
        c.lo = c.lo.min(lo);
        c.hi = c.hi.max(hi);
        let a = p.support.real_area();
        if p.can_emit() {
            c.area += a;
        }
        c.centre += a * centre;
        weight += a;
        c.rho = p.reflectance.iter().fold(c.rho, |r, &v| r.max(v));
    }
    c.centre = if weight > 0.0 {
        c.centre / weight
    } else {
        0.5 * (c.lo + c.hi)
    };
    c
}

/// Appends the cluster of BVH node `node` (and, first, its subtree) to `out`; returns
/// its index. A leaf holding several patches gets one child per patch.
fn convert(
    bvh: &Bvh2,
    node: usize,
    patches: &[Patch],
    bounds: &[(DVec3, DVec3, DVec3)],
    out: &mut Vec<Cluster>,
) -> u32 {
    let b = &bvh.nodes[node];
    let me = out.len();
    out.push(leaf_cluster(patches, bounds, &[]));
    let children: Vec<u32> = if b.prim_count > 0 {
        let first = b.first_index as usize;
        let prims = &bvh.primitive_indices[first..first + b.prim_count as usize];
        if prims.len() == 1 {
            out[me] = leaf_cluster(patches, bounds, prims);
            return me as u32;
        }
        prims
            .iter()
            .map(|&p| {
                out.push(leaf_cluster(patches, bounds, &[p]));
                (out.len() - 1) as u32
            })
            .collect()
    } else {
        let f = b.first_index as usize;
        vec![
            convert(bvh, f, patches, bounds, out),
            convert(bvh, f + 1, patches, bounds, out),
        ]
    };
    let members: Vec<u32> = children
        .iter()
        .flat_map(|&c| out[c as usize].members.clone())
        .collect();
    out[me] = Cluster {
        children,
        ..leaf_cluster(patches, bounds, &members)
    };
    me as u32
}

/// One cluster link: receiver cluster `r`, emitter cluster `e` and the terms of its
/// transfer (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct ClusterLink {
    /// Receiver cluster.
    pub r: u32,
    /// Emitter cluster.
    pub e: u32,
    /// The bound `F̄ = min(1, A_E / (π d²))` the link was admitted with.
    pub bound: f64,
    /// The `g`-weighted mean of the members' visible fractions (a summary; the
    /// transfer uses each member's own).
    pub visible: f64,
    /// `1 / (π d_c²)` (1/m²).
    pub kappa: f64,
    /// Receiving members and their factors `g_i √V_i` (zero ones left out).
    pub receivers: Vec<(u32, f64)>,
    /// Emitting members and their factors `g_j √V_j` (zero ones left out).
    pub emitters: Vec<(u32, f64)>,
}

impl ClusterLink {
    /// The link's point-to-point form factor from patch `j` of the emitter to patch
    /// `i` of the receiver, `A_j g_i g_j √(V_i V_j) / (π d_c²)` (0 for non-members).
    pub fn form_factor(&self, patches: &[Patch], i: u32, j: u32) -> f64 {
        let g = |v: &[(u32, f64)], p: u32| v.iter().find(|m| m.0 == p).map_or(0.0, |m| m.1);
        patches[j as usize].support.real_area()
            * g(&self.receivers, i)
            * g(&self.emitters, j)
            * self.kappa
    }
}

/// The cluster links of a scene and the hierarchy they join.
#[derive(Debug, Clone, PartialEq)]
pub struct ClusterLinks {
    /// The cluster hierarchy.
    pub tree: ClusterTree,
    /// The links, in refinement order.
    pub links: Vec<ClusterLink>,
    /// The tolerance they were made with (see [`crate::SolverConfig::cluster`]).
    pub tol: f64,
    /// The scene's predicted mean reflected radiosity `B̄` (W/m²).
    pub mean_reflected: f64,
}

impl ClusterLinks {
    /// Number of cluster links.
    pub fn len(&self) -> usize {
        self.links.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.links.is_empty()
    }

    /// The operator applying the links on a compiled hierarchy (see [`ClusterOp`]).
    pub fn operator(&self, h: &Hierarchy, basis: &TreeBasis, patches: &[Patch]) -> ClusterOp {
        let n = basis.n();
        let np = patches.len();
        let mut recv: Vec<Vec<(u32, f64)>> = vec![Vec::new(); np];
        let mut emit: Vec<Vec<(u32, f64)>> = vec![Vec::new(); np];
        for (l, link) in self.links.iter().enumerate() {
            for &(i, g) in &link.receivers {
                recv[i as usize].push((l as u32, g * link.kappa));
            }
            for &(j, g) in &link.emitters {
                emit[j as usize].push((l as u32, g));
            }
        }
        let moments: Vec<Vec<f64>> = (0..np)
            .into_par_iter()
            .map(|p| {
                if emit[p].is_empty() {
                    return Vec::new();
                }
                let sup = &patches[p].support;
                cell_real_moments(sup, basis, &NodeKey::root(p).region(), sup.area).1
            })
            .collect();
        let unit: Vec<Vec<f64>> = (0..np)
            .map(|p| {
                let s = patches[p].support.area.sqrt();
                basis.integrals().iter().map(|v| v * s).collect()
            })
            .collect();
        ClusterOp {
            n,
            roots: h.roots.clone(),
            links: self
                .links
                .iter()
                .map(|l| (l.receivers.clone(), l.emitters.clone(), l.kappa))
                .collect(),
            recv,
            emit,
            moments,
            unit,
        }
    }
}

/// A link's receivers, emitters (patch, `g`) and `κ`.
type OpLink = (Vec<(u32, f64)>, Vec<(u32, f64)>, f64);

/// The cluster links as an operator on node vectors (`n` coefficients per node):
/// `dst[root_i] += u_i · Σ_l κ_l g_li Σ_j g_lj (m_j · src[root_j])`, with `m_j` the
/// real moments of patch `j`'s root (`∫_real B dA = m_j · b_j`) and `u_i` the
/// coefficients of a unit constant on patch `i`'s root. Every sum runs in a fixed
/// order, so the result does not depend on the thread count.
#[derive(Debug, Clone)]
pub struct ClusterOp {
    n: usize,
    roots: Vec<u32>,
    links: Vec<OpLink>,
    /// Per patch, the links it receives from and `κ g_i`.
    recv: Vec<Vec<(u32, f64)>>,
    /// Per patch, the links it emits into and `g_j`.
    emit: Vec<Vec<(u32, f64)>>,
    /// Real moments of each emitting patch's root.
    moments: Vec<Vec<f64>>,
    /// Coefficients of a unit constant on each patch's root.
    unit: Vec<Vec<f64>>,
}

impl ClusterOp {
    fn dot(&self, a: &[f64], src: &[f64], p: usize) -> f64 {
        let node = self.roots[p] as usize;
        a.iter()
            .zip(&src[node * self.n..][..self.n])
            .map(|(x, y)| x * y)
            .sum()
    }

    /// Adds the cluster links' irradiance for node radiosity `src` to `dst`.
    pub fn gather(&self, src: &[f64], dst: &mut [f64]) {
        let power: Vec<f64> = self
            .links
            .par_iter()
            .map(|(_, e, _)| {
                e.iter()
                    .map(|&(j, g)| g * self.dot(&self.moments[j as usize], src, j as usize))
                    .sum()
            })
            .collect();
        let received: Vec<f64> = self
            .recv
            .par_iter()
            .map(|r| r.iter().map(|&(l, w)| w * power[l as usize]).sum())
            .collect();
        for (p, h) in received.into_iter().enumerate() {
            if self.recv[p].is_empty() {
                continue;
            }
            let node = self.roots[p] as usize;
            for (d, u) in dst[node * self.n..][..self.n].iter_mut().zip(&self.unit[p]) {
                *d += h * u;
            }
        }
    }

    /// Adds the transpose of [`Self::gather`] applied to `src` to `dst`.
    pub fn scatter_transpose(&self, src: &[f64], dst: &mut [f64]) {
        let seen: Vec<f64> = self
            .links
            .par_iter()
            .map(|(r, _, k)| {
                r.iter()
                    .map(|&(i, g)| k * g * self.dot(&self.unit[i as usize], src, i as usize))
                    .sum()
            })
            .collect();
        let sent: Vec<f64> = self
            .emit
            .par_iter()
            .map(|e| e.iter().map(|&(l, g)| g * seen[l as usize]).sum())
            .collect();
        for (p, h) in sent.into_iter().enumerate() {
            if self.emit[p].is_empty() {
                continue;
            }
            let node = self.roots[p] as usize;
            for (d, m) in dst[node * self.n..][..self.n]
                .iter_mut()
                .zip(&self.moments[p])
            {
                *d += h * m;
            }
        }
    }
}

/// The cosine factor of a patch towards `target`: `max(0, n · ω)` from the centre of
/// a planar support, the Jacobian-weighted mean over 3 × 3 cell centres of a curved
/// one.
fn cos_factor(p: &Patch, centre: DVec3, target: DVec3) -> f64 {
    let sup = &p.support;
    if sup.is_planar() {
        return sup
            .normal
            .dot((target - centre).normalize_or_zero())
            .max(0.0);
    }
    let (mut s, mut w) = (0.0, 0.0);
    for a in 0..3 {
        for b in 0..3 {
            let (u, v) = ((a as f64 + 0.5) / 3.0, (b as f64 + 0.5) / 3.0);
            let (x, nx) = sup.point_normal(u, v);
            let j = sup.jacobian(u, v);
            s += j * nx.dot((target - x).normalize_or_zero()).max(0.0);
            w += j;
        }
    }
    if w > 0.0 { s / w } else { 0.0 }
}

/// The terms of the cluster link `(r, e)` admitted with bound `bound`; `None` when
/// no member pair faces.
fn make_link(
    ctx: &TransferCtx<'_>,
    tree: &ClusterTree,
    (r, e, bound): (u32, u32, f64),
) -> Option<ClusterLink> {
    let (cr, ce) = (&tree.nodes[r as usize], &tree.nodes[e as usize]);
    let patches = ctx.patches;
    let side = |c: &Cluster, target: DVec3, keep: &dyn Fn(&Patch) -> bool| -> Vec<(u32, f64)> {
        c.members
            .iter()
            .filter(|&&m| keep(&patches[m as usize]))
            .map(|&m| {
                let p = &patches[m as usize];
                (m, cos_factor(p, patch_bounds(p).2, target))
            })
            .filter(|&(_, g)| g > 0.0)
            .collect()
    };
    let mut receivers = side(cr, ce.centre, &|p| p.reflects());
    let mut emitters = side(ce, cr.centre, &|p| p.can_emit());
    if receivers.is_empty() || emitters.is_empty() {
        return None;
    }
    let mut rays = 0u64;
    let vr = member_visibility(ctx, &receivers, &emitters, &mut rays);
    let ve = member_visibility(ctx, &emitters, &receivers, &mut rays);
    ctx.rays
        .fetch_add(rays, std::sync::atomic::Ordering::Relaxed);
    let (mut seen, mut all) = (0.0, 0.0);
    for (side, v) in [(&mut receivers, vr), (&mut emitters, ve)] {
        for ((_, g), v) in side.iter_mut().zip(v) {
            seen += *g * v;
            all += *g;
            *g *= v.sqrt();
        }
    }
    let dc2 = (ce.centre - cr.centre).length_squared();
    Some(ClusterLink {
        r,
        e,
        bound,
        visible: if all > 0.0 { seen / all } else { 1.0 },
        kappa: 1.0 / (std::f64::consts::PI * dc2),
        receivers,
        emitters,
    })
}

/// Each member's visible fraction of the other side: the `g · A`-weighted share of
/// its rays to the [`VIS_MEMBERS`] members of `other` with the largest `g · A` that
/// are unblocked (centres of the supports, or the nearest real points to them); 1
/// when those weights vanish.
fn member_visibility(
    ctx: &TransferCtx<'_>,
    members: &[(u32, f64)],
    other: &[(u32, f64)],
    rays: &mut u64,
) -> Vec<f64> {
    let mut top: Vec<(u32, f64)> = other
        .iter()
        .map(|&(m, g)| (m, g * ctx.patches[m as usize].support.real_area()))
        .collect();
    top.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
    top.truncate(VIS_MEMBERS);
    members
        .iter()
        .map(|&(i, _)| {
            let pi = &ctx.patches[i as usize];
            let x = pi.support.visibility_point(0.5, 0.5);
            let (mut seen, mut all) = (0.0, 0.0);
            for &(j, w) in &top {
                let pj = &ctx.patches[j as usize];
                all += w;
                if ctx.visible(x, pi, pj.support.visibility_point(0.5, 0.5), pj, rays) {
                    seen += w;
                }
            }
            if all > 0.0 { seen / all } else { 1.0 }
        })
        .collect()
}

/// What the descent found: root pairs to refine and admitted cluster pairs.
#[derive(Default)]
struct Descent {
    pairs: Vec<(usize, usize)>,
    clusters: Vec<(u32, u32, f64)>,
}

/// The descent's fixed inputs.
struct Criterion<'c, 'a> {
    ctx: &'c TransferCtx<'a>,
    tree: &'c ClusterTree,
    /// `B̂` per cluster: largest member brightness plus `B̄`.
    bright: Vec<f64>,
    /// Whether a cluster holds a receiver (a member that reflects).
    receives: Vec<bool>,
    /// The admissible transport bound, `tol · B̄` (W/m²).
    limit: f64,
}

impl Criterion<'_, '_> {
    /// The bound `F̄` when `(r, e)` may be one cluster link.
    fn admit(&self, r: u32, e: u32) -> Option<f64> {
        let (cr, ce) = (&self.tree.nodes[r as usize], &self.tree.nodes[e as usize]);
        let d = cr.distance(ce);
        if d <= 0.0 {
            return None;
        }
        let f = (ce.area / (std::f64::consts::PI * d * d)).min(1.0);
        (cr.rho * self.bright[e as usize] * f <= self.limit).then_some(f)
    }

    fn descend(&self, r: u32, e: u32, out: &mut Descent) {
        let nodes = &self.tree.nodes;
        let (cr, ce) = (&nodes[r as usize], &nodes[e as usize]);
        if !self.receives[r as usize] || ce.area <= 0.0 {
            return;
        }
        if r == e {
            if cr.children.is_empty() {
                let i = cr.members[0] as usize;
                if hierarchy::may_link(self.ctx, i, i) {
                    out.pairs.push((i, i));
                }
                return;
            }
            for &a in &cr.children {
                for &b in &cr.children {
                    self.descend(a, b, out);
                }
            }
            return;
        }
        if cr.children.is_empty() && ce.children.is_empty() {
            let (i, j) = (cr.members[0] as usize, ce.members[0] as usize);
            if hierarchy::may_link(self.ctx, i, j) {
                out.pairs.push((i, j));
            }
            return;
        }
        if let Some(f) = self.admit(r, e) {
            out.clusters.push((r, e, f));
            return;
        }
        let split_r =
            !cr.children.is_empty() && (ce.children.is_empty() || cr.diagonal() >= ce.diagonal());
        if split_r {
            for &a in &cr.children {
                self.descend(a, e, out);
            }
        } else {
            for &b in &ce.children {
                self.descend(r, b, out);
            }
        }
    }
}

/// The initial links of a solve: with `tol` none, every root pair
/// ([`hierarchy::refine_all`]); with a tolerance, the root pairs the cluster descent
/// leaves (refined as [`hierarchy::refine_all`] refines them, in ascending pair
/// order) and the cluster links (see the module docs). `brightness` is the patch
/// roots' brightness of the refinement (W/m², e.g. their emission before a solve).
pub fn initial_links(
    ctx: &TransferCtx<'_>,
    p: &RefineParams,
    tol: Option<f64>,
    prep: &Prepared,
    brightness: &(dyn Fn(&NodeKey) -> f64 + Sync),
) -> (Vec<LinkRec>, RefineCounts, Option<ClusterLinks>) {
    let Some(tol) = tol else {
        let (l, c) = hierarchy::refine_all(ctx, p, brightness);
        return (l, c, None);
    };
    let mean_reflected = crate::target::mean_reflected(prep);
    let tree = ClusterTree::build(ctx.patches);
    let crit = Criterion {
        ctx,
        tree: &tree,
        bright: tree
            .nodes
            .iter()
            .map(|c| {
                c.members
                    .iter()
                    .map(|&m| brightness(&NodeKey::root(m as usize)))
                    .fold(0.0f64, f64::max)
                    + mean_reflected
            })
            .collect(),
        receives: tree
            .nodes
            .iter()
            .map(|c| {
                c.members
                    .iter()
                    .any(|&m| ctx.patches[m as usize].reflects())
            })
            .collect(),
        limit: tol * mean_reflected,
    };
    let mut found = Descent::default();
    if !tree.nodes.is_empty() {
        crit.descend(0, 0, &mut found);
    }
    found.pairs.sort_unstable();
    let links: Vec<ClusterLink> = found
        .clusters
        .par_iter()
        .filter_map(|&c| make_link(ctx, &tree, c))
        .collect();
    let (l, c) = hierarchy::refine_pairs(ctx, p, &found.pairs, brightness);
    (
        l,
        c,
        Some(ClusterLinks {
            tree,
            links,
            tol,
            mean_reflected,
        }),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hierarchy::Hierarchy;
    use crate::{BasisKind, LinearMethod, SolverConfig, solve};
    use glam::DVec3;
    use proptest::prelude::*;
    use wavelux_scene::{Material, Rgb, Scene, Shape, Sidedness, Surface};

    /// A 3 × 3 grid of squares of side `a` (pitch `2a`) in the plane `z`, facing
    /// `+z` (`up`) or `−z`; the first one emits `e` when `e > 0`.
    fn grid(s: &mut Scene, name: &str, z: f64, up: bool, a: f64, e: f64, rho: f64) {
        let wall = s.add_material(Material::lambertian(
            format!("{name}-wall"),
            Rgb::grey(rho),
            Rgb::grey(0.0),
        ));
        let lamp = s.add_material(Material::lambertian(
            format!("{name}-lamp"),
            Rgb::grey(rho),
            Rgb::grey(e),
        ));
        for k in 0..9 {
            let o = DVec3::new((k % 3) as f64 * 2.0 * a, (k / 3) as f64 * 2.0 * a, z);
            let (u, v) = (DVec3::X * a, DVec3::Y * a);
            let (edge_u, edge_v) = if up { (u, v) } else { (v, u) };
            s.add_surface(Surface {
                name: format!("{name}{k}"),
                shape: Shape::Parallelogram {
                    origin: o,
                    edge_u,
                    edge_v,
                },
                material: if k == 0 && e > 0.0 { lamp } else { wall },
                sides: Sidedness::OneSided,
            });
        }
    }

    /// Two grids of small squares facing each other `d` apart, a lamp in each.
    fn far_grids(d: f64) -> Scene {
        let mut s = Scene::new("far-grids");
        grid(&mut s, "a", 0.0, true, 0.1, 10.0, 0.6);
        grid(&mut s, "b", d, false, 0.1, 5.0, 0.6);
        s
    }

    fn config(cluster: Option<f64>) -> SolverConfig {
        SolverConfig {
            basis: BasisKind::Haar,
            max_level: 0,
            linear_method: LinearMethod::Gmres { restart: 30 },
            tolerance: 1e-13,
            cluster,
            ..SolverConfig::default()
        }
    }

    /// The cluster links of a scene (and its preparation) at tolerance `tol`.
    fn links_of(scene: &Scene, tol: f64) -> (Prepared, ClusterLinks) {
        let prep = Prepared::new(scene, &config(Some(tol))).unwrap();
        let ctx = prep.transfer().unwrap();
        let bright = |k: &NodeKey| crate::brightness(None, &prep.patches.patches, k);
        let p = prep.refine_params(prep.config.eps);
        let (_, _, cl) = initial_links(&ctx, &p, Some(tol), &prep, &bright);
        (prep, cl.unwrap())
    }

    /// Centre distance `D` and `s = rad_R + rad_E` (each the largest distance from a
    /// cluster's centre to a corner of its bounds) of a link.
    fn spread(tree: &ClusterTree, l: &ClusterLink) -> (f64, f64) {
        let (r, e) = (&tree.nodes[l.r as usize], &tree.nodes[l.e as usize]);
        let rad = |c: &Cluster| {
            (c.centre - c.lo)
                .abs()
                .max((c.hi - c.centre).abs())
                .length()
        };
        ((e.centre - r.centre).length(), rad(r) + rad(e))
    }

    /// The far-field bound of `|F^cl_ij − F_ij|` for unoccluded planar members per
    /// unit emitter area (derived below), or `None` when the clusters' balls overlap.
    fn far_field(d: f64, s: f64) -> Option<f64> {
        (s < d).then(|| {
            let dir = 2.0 * s / d;
            ((1.0 / (d - s).powi(2) - 1.0 / (d * d)) + 2.0 * dir / (d - s).powi(2))
                / std::f64::consts::PI
        })
    }

    /// The exact unoccluded form factor `F_ij` of two patch roots (Haar level 0: the
    /// block's single entry is the contour-integral form factor, `F_ij = T √(A_j/A_i)`).
    fn exact(ctx: &TransferCtx<'_>, i: u32, j: u32) -> f64 {
        let (ri, rj) = (
            NodeKey::root(i as usize).region(),
            NodeKey::root(j as usize).region(),
        );
        let t = ctx.block(&ri, &rj)[0];
        let a = |p: u32| ctx.patches[p as usize].support.area;
        t * (a(j) / a(i)).sqrt()
    }

    /// Every cluster link against the exact unoccluded form factors of the root pairs
    /// it replaces. (1) Conservative bound: for every receiving member the link's
    /// form factor and the exact one both lie in `[0, F̄]`. (2) Where the clusters
    /// are separated, each member pair's `A_j g_i g_j / (π D²)` is the exact `F_ij`
    /// within the far-field bound. Derivation: every direction from the ball
    /// `(c_R, rad_R)` to `(c_E, rad_E)` lies within `asin(s/D)` of the centres' axis
    /// (`s = rad_R + rad_E`), so a member's cosine `g` and the kernel's cosine at any
    /// point pair differ by at most `|u − v| ≤ 2s/D`, hence `|g_i g_j − cos cos| ≤
    /// 4s/D`; the distance lies in `[D − s, D + s]`, so `|g g/D² − cos cos/r²| ≤
    /// (1/(D − s)² − 1/D²) + (4s/D)/(D − s)²`, integrated over `j` (area `A_j`,
    /// divided by `π`).
    #[test]
    fn cluster_form_factors_are_the_exact_ones_within_their_bounds() {
        let scene = far_grids(12.0);
        let (prep, cl) = links_of(&scene, 0.05);
        assert!(!cl.is_empty(), "no cluster link formed");
        let ctx = prep.transfer().unwrap();
        let patches = &prep.patches.patches;
        let mut far_pairs = 0;
        for l in &cl.links {
            let (d, s) = spread(&cl.tree, l);
            for &(i, _) in &l.receivers {
                let (mut f_cl, mut f_ex) = (0.0, 0.0);
                for &(j, _) in &l.emitters {
                    let (ex, f) = (exact(&ctx, i, j), l.form_factor(patches, i, j));
                    f_cl += f;
                    f_ex += ex;
                    if let Some(b) = far_field(d, s) {
                        let bound = patches[j as usize].support.area * b + 1e-12 * ex;
                        assert!(
                            (f - ex).abs() <= bound,
                            "pair ({i}, {j}): cluster {f:e}, exact {ex:e}, bound {bound:e}"
                        );
                        assert!(bound < 0.5 * ex, "bound {bound:e} vacuous for {ex:e}");
                        far_pairs += 1;
                    }
                }
                let slack = 1e-12 * l.bound;
                assert!(
                    f_cl <= l.bound + slack && f_ex <= l.bound + slack,
                    "{f_cl} {f_ex} {}",
                    l.bound
                );
            }
        }
        assert!(far_pairs >= 9, "only {far_pairs} member pairs far apart");
    }

    /// The clustered solution differs from the unclustered one by at most
    /// `ρ Δ / (1 − ρ)`: with `e = B¹ − B⁰`, `e = ρ (K¹ − K⁰) B¹ + ρ K⁰ e`, the row sums
    /// of `K⁰` are at most 1 (Haar, closure), and `|(K¹ − K⁰) B¹|_i ≤ Δ_i`, the sum over
    /// the links into `i` of the smaller of `F̄ · max_j B¹_j` and `Σ_j b_ij B¹_j` (`b_ij`
    /// the far-field bound of each member pair, previous test).
    #[test]
    fn clustering_far_apart_small_patches_matches_the_unclustered_solution() {
        let scene = far_grids(12.0);
        let (prep, cl) = links_of(&scene, 0.05);
        let patches = &prep.patches.patches;
        let with = solve(&scene, &config(Some(0.05))).unwrap();
        let without = solve(&scene, &config(None)).unwrap();
        assert_eq!(with.stats.cluster_links, cl.len());
        assert!(with.stats.links < without.stats.links);
        let b1: Vec<f64> = (0..patches.len())
            .map(|p| with.patch_average(p)[0])
            .collect();
        let area = |j: u32| patches[j as usize].support.area;
        let mut delta = vec![0.0f64; patches.len()];
        for l in &cl.links {
            let (d, s) = spread(&cl.tree, l);
            let top = l
                .emitters
                .iter()
                .map(|m| b1[m.0 as usize])
                .fold(0.0, f64::max);
            let far = far_field(d, s).map_or(f64::INFINITY, |b| {
                l.emitters
                    .iter()
                    .map(|m| area(m.0) * b * b1[m.0 as usize])
                    .sum()
            });
            for &(i, _) in &l.receivers {
                delta[i as usize] += far.min(l.bound * top);
            }
        }
        let rho = 0.6;
        let bound = rho * delta.iter().fold(0.0f64, |a, &b| a.max(b)) / (1.0 - rho);
        let mut worst = 0.0f64;
        for (p, b) in b1.iter().enumerate() {
            let diff = (b - without.patch_average(p)[0]).abs();
            worst = worst.max(diff);
            assert!(diff <= bound + 1e-9, "patch {p}: |ΔB| {diff:e} > {bound:e}");
        }
        assert!(worst > 0.0, "the cluster links changed nothing");
        let top = b1.iter().fold(0.0f64, |a, &b| a.max(b));
        assert!(
            bound < 0.05 * top,
            "bound {bound:e} vacuous against {top:e}"
        );
    }

    /// A closed white furnace whose faces are split into 3 × 3 patches (every patch
    /// emits `E` and reflects `ρ`): `B = E/(1 − ρ)` exactly. Cluster links change a
    /// leaf's row sum by at most `δ_i = Σ_l F̄_l` over its links (the link's value and
    /// the true transport both lie in `[0, F̄]`), so with row sums in `[1 − δ, 1 + δ]`
    /// and a non-negative operator, `E/(1 − ρ(1 − δ)) ≤ B ≤ E/(1 − ρ(1 + δ))`.
    #[test]
    fn a_clustered_furnace_stays_within_its_row_sum_bound() {
        let mut s = Scene::new("split-furnace");
        let (e, rho) = (1.0, 0.5);
        let m = s.add_material(Material::lambertian("w", Rgb::grey(rho), Rgb::grey(e)));
        let h = 1.0 / 3.0;
        for axis in 0..3 {
            for side in [0.0, 1.0] {
                let n = DVec3::AXES[axis] * if side == 0.0 { 1.0 } else { -1.0 };
                let (mut u, mut v) = (DVec3::AXES[(axis + 1) % 3], DVec3::AXES[(axis + 2) % 3]);
                if u.cross(v).dot(n) < 0.0 {
                    std::mem::swap(&mut u, &mut v);
                }
                for k in 0..9 {
                    let origin = DVec3::AXES[axis] * side
                        + u * ((k % 3) as f64 * h)
                        + v * ((k / 3) as f64 * h);
                    s.add_surface(Surface {
                        name: format!("f{axis}{side}{k}"),
                        shape: Shape::Parallelogram {
                            origin,
                            edge_u: u * h,
                            edge_v: v * h,
                        },
                        material: m,
                        sides: Sidedness::OneSided,
                    });
                }
            }
        }
        let tol = 0.15;
        let (prep, cl) = links_of(&s, tol);
        assert!(!cl.is_empty(), "no cluster link formed");
        let np = prep.patches.patches.len();
        let mut delta = vec![0.0f64; np];
        for l in &cl.links {
            for &(i, _) in &l.receivers {
                delta[i as usize] += l.bound;
            }
        }
        let d = delta.iter().fold(0.0f64, |a, &b| a.max(b));
        assert!(rho * (1.0 + d) < 1.0, "bound vacuous: δ {d}");
        let sol = solve(&s, &config(Some(tol))).unwrap();
        let (lo, hi) = (e / (1.0 - rho * (1.0 - d)), e / (1.0 - rho * (1.0 + d)));
        let mut off = 0.0f64;
        for p in 0..np {
            let b = sol.patch_average(p)[0];
            off = off.max((b - e / (1.0 - rho)).abs());
            assert!(
                (lo - 1e-9..=hi + 1e-9).contains(&b),
                "patch {p}: {b} not in [{lo}, {hi}]"
            );
        }
        assert!(off > 0.0);
    }

    /// Every cluster holds the disjoint union of its children's members, its bounds
    /// hold theirs, and the root holds every patch.
    fn check_tree(tree: &ClusterTree, np: usize) {
        assert_eq!(tree.nodes[0].members, (0..np as u32).collect::<Vec<_>>());
        for c in &tree.nodes {
            if c.children.is_empty() {
                assert_eq!(c.members.len(), 1);
                continue;
            }
            let mut m: Vec<u32> = c
                .children
                .iter()
                .flat_map(|&k| tree.nodes[k as usize].members.clone())
                .collect();
            m.sort_unstable();
            assert_eq!(m, c.members);
            for &k in &c.children {
                let k = &tree.nodes[k as usize];
                assert!(c.lo.cmple(k.lo).all() && c.hi.cmpge(k.hi).all());
            }
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(24))]

        /// Random scenes of squares: the tree partitions the patches, and the cluster
        /// operator's transpose is its adjoint (`yᵀ G x = (Gᵀ y)ᵀ x`).
        #[test]
        fn random_cluster_trees_partition_and_apply_adjointly(
            pos in prop::collection::vec(-6.0f64..6.0, 3..36),
            seed in 0u64..1000,
        ) {
            let mut s = Scene::new("random");
            let m = s.add_material(Material::lambertian("w", Rgb::grey(0.5), Rgb::grey(1.0)));
            for (k, p) in pos.chunks_exact(3).enumerate() {
                let (u, v) = (DVec3::AXES[(k + 1) % 3] * 0.3, DVec3::AXES[(k + 2) % 3] * 0.3);
                let (u, v) = if (k / 3) % 2 == 0 { (u, v) } else { (v, u) };
                s.add_surface(Surface {
                    name: format!("s{k}"),
                    shape: Shape::Parallelogram {
                        origin: DVec3::new(p[0], p[1], p[2]),
                        edge_u: u,
                        edge_v: v,
                    },
                    material: m,
                    sides: Sidedness::OneSided,
                });
            }
            let (prep, cl) = links_of(&s, 0.9);
            let patches = &prep.patches.patches;
            check_tree(&cl.tree, patches.len());
            let h = Hierarchy::compile(prep.basis.n(), patches.len(), &[]);
            let op = cl.operator(&h, &prep.basis, patches);
            let dim = h.node_count() * prep.basis.n();
            let mut rng = seed;
            let mut next = || {
                rng = rng.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                (rng >> 11) as f64 / (1u64 << 53) as f64 - 0.5
            };
            let x: Vec<f64> = (0..dim).map(|_| next()).collect();
            let y: Vec<f64> = (0..dim).map(|_| next()).collect();
            let (mut gx, mut gty) = (vec![0.0; dim], vec![0.0; dim]);
            op.gather(&x, &mut gx);
            op.scatter_transpose(&y, &mut gty);
            let a: f64 = y.iter().zip(&gx).map(|(p, q)| p * q).sum();
            let b: f64 = gty.iter().zip(&x).map(|(p, q)| p * q).sum();
            let scale: f64 = gx.iter().chain(&gty).map(|v| v.abs()).sum::<f64>() + 1e-300;
            prop_assert!((a - b).abs() <= 1e-12 * scale, "{a} vs {b}");
        }
    }
}
