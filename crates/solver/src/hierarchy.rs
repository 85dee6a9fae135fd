//! Element quadtrees and links: top-down refinement (Hanrahan et al. 1991; Gortler et
//! al. 1993; Ziegler §2.2.3 "Computation of the Compressed Operator") and the
//! compiled, level-ordered hierarchy the solver iterates on.
//!
//! A node is `(patch, level, ix, iy)`: the cell `[ix, ix+1]·2^-level × [iy, iy+1]·2^-level`
//! of the patch's unit square. A link joins a receiver node and an emitter node (any
//! levels) and stores their `k² × k²` transfer block. Refinement starts from one link
//! per pair of root nodes that face each other and, while the oracle exceeds `ε` and
//! the elements may still be split (level `< max_level`, child area `≥ min_area`),
//! replaces a link by the links between the children (both sides split — the
//! non-standard scheme, Ziegler's 16 child pairs — or only the larger element,
//! Hanrahan's scheme). The recursion runs in parallel over child pairs with rayon and
//! collects results in a fixed order, so the link list does not depend on the thread
//! count.
//!
//! The element/link machinery only talks to supports through [`Region`]s and the
//! [`TransferCtx`]; masked supports (Virtual Mesh), clusters (Smits et al.) or
//! importance weights plug in there and in [`RefineParams`].

use std::collections::{HashMap, HashSet};

use rayon::prelude::*;

use crate::transfer::{LinkVisibility, Region, TransferCtx};

/// A quadtree node of a patch.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct NodeKey {
    /// Level (0 = whole support).
    pub level: u8,
    /// Patch index.
    pub patch: u32,
    /// Cell row.
    pub iy: u32,
    /// Cell column.
    pub ix: u32,
}

impl NodeKey {
    /// The root of a patch.
    pub fn root(patch: usize) -> Self {
        Self {
            level: 0,
            patch: patch as u32,
            iy: 0,
            ix: 0,
        }
    }

    /// The parameter square of the node.
    pub fn region(&self) -> Region {
        let h = 0.5f64.powi(self.level as i32);
        Region {
            patch: self.patch as usize,
            s0: self.ix as f64 * h,
            t0: self.iy as f64 * h,
            h,
        }
    }

    /// Child `c = cy·2 + cx`.
    pub fn child(&self, c: usize) -> Self {
        Self {
            level: self.level + 1,
            patch: self.patch,
            iy: 2 * self.iy + (c / 2) as u32,
            ix: 2 * self.ix + (c % 2) as u32,
        }
    }

    /// The parent (`None` for a root).
    pub fn parent(&self) -> Option<Self> {
        (self.level > 0).then(|| Self {
            level: self.level - 1,
            patch: self.patch,
            iy: self.iy / 2,
            ix: self.ix / 2,
        })
    }

    /// Position among the parent's children.
    pub fn child_pos(&self) -> usize {
        ((self.iy % 2) * 2 + self.ix % 2) as usize
    }
}

/// Which elements a refined link splits.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum SplitPolicy {
    /// Both elements (when both may be split): 16 child links, the non-standard
    /// scheme of Gortler et al. and Ziegler.
    Both,
    /// Only the element with the larger area (Hanrahan et al. 1991).
    Larger,
}

/// The refinement criterion.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum Oracle {
    /// Kernel smoothness only (Ziegler §2.4.2, §3.3.2).
    KernelSmoothness,
    /// Kernel smoothness times `ρ_receiver · B_emitter` (brightness-weighted, "BF"
    /// refinement of Hanrahan et al.); `ε` is then in radiosity units (W/m²).
    Brightness,
    /// Kernel smoothness of the transport kernel `ρ_receiver · G V` (Ziegler's
    /// `F = R G`): the estimate times the receiver's largest reflectance.
    Reflectance,
}

/// Parameters of the refinement.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RefineParams {
    /// Threshold `ε` on the oracle estimate.
    pub eps: f64,
    /// Deepest level of any element.
    pub max_level: u8,
    /// Smallest element area (scene units²); elements are not split below it.
    pub min_area: f64,
    /// Oracle.
    pub oracle: Oracle,
    /// Split policy.
    pub split: SplitPolicy,
}

/// A link: receiver node, emitter node and the `n × n` transfer block.
#[derive(Debug, Clone, PartialEq)]
pub struct LinkRec {
    /// Receiver.
    pub r: NodeKey,
    /// Emitter.
    pub e: NodeKey,
    /// Block `[a_receiver * n + b_emitter]`.
    pub block: Vec<f64>,
    /// What the block's shadow rays saw ([`TransferCtx::block_seen`]).
    pub seen: LinkVisibility,
}

/// Counters of a refinement.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RefineCounts {
    /// Links that were split.
    pub refined: u64,
    /// Oracle evaluations.
    pub oracle_evals: u64,
    /// Root pairs kept unrefined (their single `⟨Tφ₀, φ₀⟩` block is Ziegler's 16th
    /// coefficient).
    pub unrefined_roots: u64,
}

impl RefineCounts {
    fn add(&mut self, o: &Self) {
        self.refined += o.refined;
        self.oracle_evals += o.oracle_evals;
        self.unrefined_roots += o.unrefined_roots;
    }
}

pub(crate) fn can_split(ctx: &TransferCtx<'_>, k: &NodeKey, p: &RefineParams) -> bool {
    if k.level >= p.max_level {
        return false;
    }
    let sup = &ctx.patches[k.patch as usize].support;
    let a = sup.area * 0.25f64.powi(k.level as i32 + 1);
    // Empty cells of virtual supports are never split (VirtualMesh §5.4).
    a >= p.min_area && {
        let r = k.region();
        sup.mask.is_none() || sup.coverage(r.s0, r.t0, r.h) != crate::mask::Coverage::Empty
    }
}

/// The factor the oracle multiplies the kernel-smoothness estimate by.
fn oracle_weight(
    ctx: &TransferCtx<'_>,
    p: &RefineParams,
    r: &NodeKey,
    e: &NodeKey,
    brightness: &(dyn Fn(&NodeKey) -> f64 + Sync),
) -> f64 {
    let rho = || {
        ctx.patches[r.patch as usize]
            .reflectance
            .iter()
            .fold(0.0f64, |a, &b| a.max(b))
    };
    match p.oracle {
        Oracle::KernelSmoothness => 1.0,
        Oracle::Brightness => rho() * brightness(e),
        Oracle::Reflectance => rho(),
    }
}

/// Refines the link `(r, e)` (see the module docs). `brightness(e)` is the emitter's
/// current radiosity estimate (max channel, W/m²) for the brightness oracle. Links
/// whose elements do not face each other are dropped.
pub fn refine_link(
    ctx: &TransferCtx<'_>,
    p: &RefineParams,
    r: NodeKey,
    e: NodeKey,
    brightness: &(dyn Fn(&NodeKey) -> f64 + Sync),
    out: &mut Vec<LinkRec>,
) -> RefineCounts {
    let mut counts = RefineCounts::default();
    let (rr, er) = (r.region(), e.region());
    if !ctx.facing(&rr, &er) {
        return counts;
    }
    let cr = can_split(ctx, &r, p);
    let ce = can_split(ctx, &e, p);
    if cr || ce {
        let mut est = ctx.estimate(&rr, &er);
        counts.oracle_evals += 1;
        est *= oracle_weight(ctx, p, &r, &e, brightness);
        if est > p.eps {
            counts.refined += 1;
            let (sr, se) = split_sides(ctx, p, &r, &e, &rr, &er, cr, ce);
            let rs: Vec<NodeKey> = if sr {
                (0..4).map(|c| r.child(c)).collect()
            } else {
                vec![r]
            };
            let es: Vec<NodeKey> = if se {
                (0..4).map(|c| e.child(c)).collect()
            } else {
                vec![e]
            };
            let pairs: Vec<(NodeKey, NodeKey)> = rs
                .iter()
                .flat_map(|a| es.iter().map(move |b| (*a, *b)))
                .collect();
            let parts: Vec<(Vec<LinkRec>, RefineCounts)> = pairs
                .par_iter()
                .map(|(a, b)| {
                    let mut v = Vec::new();
                    let c = refine_link(ctx, p, *a, *b, brightness, &mut v);
                    (v, c)
                })
                .collect();
            for (v, c) in parts {
                out.extend(v);
                counts.add(&c);
            }
            return counts;
        }
    }
    if r.level == 0 && e.level == 0 {
        counts.unrefined_roots += 1;
    }
    let (block, seen) = if ctx.batches_blocks() {
        (Vec::new(), LinkVisibility::Unknown)
    } else {
        ctx.block_seen(&rr, &er)
    };
    out.push(LinkRec { r, e, block, seen });
    counts
}

/// Computes the blocks refinement left empty (when the context batches its shadow
/// rays on an occluder, [`TransferCtx::batches_blocks`]), all together and in link
/// order ([`TransferCtx::blocks_seen`]); bitwise the blocks refinement would have
/// computed itself.
fn fill_blocks(ctx: &TransferCtx<'_>, links: &mut [LinkRec]) {
    if !ctx.batches_blocks() {
        return;
    }
    let todo: Vec<usize> = (0..links.len())
        .filter(|&i| links[i].block.is_empty())
        .collect();
    let pairs: Vec<(Region, Region)> = todo
        .iter()
        .map(|&i| (links[i].r.region(), links[i].e.region()))
        .collect();
    for (i, (block, seen)) in todo.into_iter().zip(ctx.blocks_seen(&pairs)) {
        links[i].block = block;
        links[i].seen = seen;
    }
}

/// Whether the root pair `(receiver i, emitter j)` can interact: the receiver
/// reflects, the emitter emits or reflects, and they are different pieces — or the
/// same patch when its curved support sees itself ([`crate::Support::sees_itself`],
/// VirtualMesh §5.3; planar patches never self-link). The two sides of one curved
/// piece are not linked (light between them has to cross the sheet).
pub(crate) fn may_link(ctx: &TransferCtx<'_>, i: usize, j: usize) -> bool {
    let (a, b) = (&ctx.patches[i], &ctx.patches[j]);
    let pair = if a.prim == b.prim {
        i == j && a.support.sees_itself()
    } else {
        true
    };
    a.reflects() && pair && b.can_emit()
}

/// Refines every root pair `(receiver, emitter)` of patches that can interact
/// ([`may_link`]): all pairs, the initial linking without clustering.
pub fn refine_all(
    ctx: &TransferCtx<'_>,
    p: &RefineParams,
    brightness: &(dyn Fn(&NodeKey) -> f64 + Sync),
) -> (Vec<LinkRec>, RefineCounts) {
    let np = ctx.patches.len();
    let pairs: Vec<(usize, usize)> = (0..np)
        .flat_map(|i| (0..np).map(move |j| (i, j)))
        .filter(|&(i, j)| may_link(ctx, i, j))
        .collect();
    refine_pairs(ctx, p, &pairs, brightness)
}

/// Refines the given root pairs `(receiver, emitter)` (each through [`refine_link`],
/// in parallel, collected in the order of `pairs`) and fills the blocks a batching
/// context left empty.
pub(crate) fn refine_pairs(
    ctx: &TransferCtx<'_>,
    p: &RefineParams,
    pairs: &[(usize, usize)],
    brightness: &(dyn Fn(&NodeKey) -> f64 + Sync),
) -> (Vec<LinkRec>, RefineCounts) {
    let parts: Vec<(Vec<LinkRec>, RefineCounts)> = pairs
        .par_iter()
        .map(|&(i, j)| {
            let mut v = Vec::new();
            let c = refine_link(
                ctx,
                p,
                NodeKey::root(i),
                NodeKey::root(j),
                brightness,
                &mut v,
            );
            (v, c)
        })
        .collect();
    let mut links = Vec::new();
    let mut counts = RefineCounts::default();
    for (v, c) in parts {
        links.extend(v);
        counts.add(&c);
    }
    fill_blocks(ctx, &mut links);
    (links, counts)
}

/// Re-examines existing links with new parameters (the refine step of Ziegler Alg.
/// 2.3.4): links the oracle now rejects are refined further; the others keep their
/// blocks.
pub fn rerefine(
    ctx: &TransferCtx<'_>,
    p: &RefineParams,
    links: Vec<LinkRec>,
    brightness: &(dyn Fn(&NodeKey) -> f64 + Sync),
) -> (Vec<LinkRec>, RefineCounts) {
    let parts: Vec<(Vec<LinkRec>, RefineCounts)> = links
        .into_par_iter()
        .map(|l| {
            let cr = can_split(ctx, &l.r, p);
            let ce = can_split(ctx, &l.e, p);
            let mut counts = RefineCounts::default();
            if cr || ce {
                let (rr, er) = (l.r.region(), l.e.region());
                let mut est = ctx.estimate(&rr, &er);
                counts.oracle_evals += 1;
                est *= oracle_weight(ctx, p, &l.r, &l.e, brightness);
                if est > p.eps {
                    // Force the split: refine_link re-evaluates the oracle, which
                    // gives the same answer.
                    let mut v = Vec::new();
                    let c = refine_link(ctx, p, l.r, l.e, brightness, &mut v);
                    counts.add(&c);
                    counts.oracle_evals -= 1;
                    return (v, counts);
                }
            }
            if l.r.level == 0 && l.e.level == 0 {
                counts.unrefined_roots += 1;
            }
            (vec![l], counts)
        })
        .collect();
    let mut links = Vec::new();
    let mut counts = RefineCounts::default();
    for (v, c) in parts {
        links.extend(v);
        counts.add(&c);
    }
    fill_blocks(ctx, &mut links);
    (links, counts)
}

/// Splits the marked links one level (the a-posteriori refinement step of
/// [`crate::target`]): a marked link is replaced by the links between the children of
/// the elements the split policy selects (both when both may split, else the one that
/// may), with their blocks and without consulting the oracle; pairs that do not face
/// each other are dropped. Unmarked links, and marked ones whose elements may not be
/// split (level or area limit), are kept as they are. `marked[i]` refers to
/// `links[i]`. The output keeps the input order (children in place of their parent),
/// so it does not depend on the thread count.
pub fn split_marked(
    ctx: &TransferCtx<'_>,
    p: &RefineParams,
    links: Vec<LinkRec>,
    marked: &[bool],
) -> (Vec<LinkRec>, RefineCounts) {
    let parts: Vec<(Vec<LinkRec>, RefineCounts)> = links
        .into_par_iter()
        .zip(marked.par_iter())
        .map(|(l, &m)| {
            let mut counts = RefineCounts::default();
            let cr = can_split(ctx, &l.r, p);
            let ce = can_split(ctx, &l.e, p);
            if !m || !(cr || ce) {
                if l.r.level == 0 && l.e.level == 0 {
                    counts.unrefined_roots += 1;
                }
                return (vec![l], counts);
            }
            counts.refined += 1;
            let (rr, er) = (l.r.region(), l.e.region());
            let (sr, se) = split_sides(ctx, p, &l.r, &l.e, &rr, &er, cr, ce);
            let rs: Vec<NodeKey> = if sr {
                (0..4).map(|c| l.r.child(c)).collect()
            } else {
                vec![l.r]
            };
            let es: Vec<NodeKey> = if se {
                (0..4).map(|c| l.e.child(c)).collect()
            } else {
                vec![l.e]
            };
            let pairs: Vec<(NodeKey, NodeKey)> = rs
                .iter()
                .flat_map(|a| es.iter().map(move |b| (*a, *b)))
                .collect();
            let v: Vec<LinkRec> = pairs
                .par_iter()
                .filter_map(|(a, b)| {
                    let (ar, br) = (a.region(), b.region());
                    ctx.facing(&ar, &br).then(|| {
                        let (block, seen) = if ctx.batches_blocks() {
                            (Vec::new(), LinkVisibility::Unknown)
                        } else {
                            ctx.block_seen(&ar, &br)
                        };
                        LinkRec {
                            r: *a,
                            e: *b,
                            block,
                            seen,
                        }
                    })
                })
                .collect();
            (v, counts)
        })
        .collect();
    let mut out = Vec::new();
    let mut counts = RefineCounts::default();
    for (v, c) in parts {
        out.extend(v);
        counts.add(&c);
    }
    fill_blocks(ctx, &mut out);
    (out, counts)
}

/// Which sides of a link the split policy splits, given which may split.
#[allow(clippy::too_many_arguments)]
fn split_sides(
    ctx: &TransferCtx<'_>,
    p: &RefineParams,
    r: &NodeKey,
    e: &NodeKey,
    rr: &Region,
    er: &Region,
    cr: bool,
    ce: bool,
) -> (bool, bool) {
    match p.split {
        SplitPolicy::Both => (cr, ce),
        SplitPolicy::Larger => {
            let ar = ctx.patches[r.patch as usize].support.area * rr.h * rr.h;
            let ae = ctx.patches[e.patch as usize].support.area * er.h * er.h;
            if cr && (ar >= ae || !ce) {
                (true, false)
            } else {
                (false, true)
            }
        }
    }
}

/// The compiled hierarchy: nodes ordered by `(level, patch, iy, ix)` (each level a
/// contiguous range), complete quadtrees (every split node has its four children),
/// leaves as unknowns, links grouped by receiver (CSR) with an emitter-ordered
/// permutation for the transpose.
#[derive(Debug, Clone)]
pub struct Hierarchy {
    /// Functions per node (`k²`).
    pub(crate) n: usize,
    /// Node keys.
    pub(crate) keys: Vec<NodeKey>,
    /// Children (`u32::MAX` where absent; all four or none).
    pub(crate) children: Vec<[u32; 4]>,
    /// Parent (`u32::MAX` for roots).
    pub(crate) parent: Vec<u32>,
    /// `level_start[l]..level_start[l+1]` are the nodes of level `l`.
    pub(crate) level_start: Vec<usize>,
    /// Node index of each leaf (unknown block).
    pub(crate) leaves: Vec<u32>,
    /// Leaf index of each node (`u32::MAX` for internal nodes).
    pub(crate) leaf_of: Vec<u32>,
    /// Root node of each patch.
    pub(crate) roots: Vec<u32>,
    /// CSR offsets of links by receiver node (`len = nodes + 1`).
    pub(crate) recv_offsets: Vec<usize>,
    /// Emitter node of each link (receiver order).
    pub(crate) link_emitter: Vec<u32>,
    /// Receiver node of each link (receiver order).
    pub(crate) link_receiver: Vec<u32>,
    /// Blocks, `n²` per link (receiver order).
    pub(crate) blocks: Vec<f64>,
    /// What each block's shadow rays saw (receiver order).
    pub(crate) link_seen: Vec<LinkVisibility>,
    /// Links in emitter order (indices into the receiver-ordered arrays).
    pub(crate) by_emitter: Vec<u32>,
    /// CSR offsets of `by_emitter` by emitter node.
    pub(crate) emit_offsets: Vec<usize>,
}

impl Hierarchy {
    /// Functions per node (`k²`).
    pub fn n(&self) -> usize {
        self.n
    }

    /// Node keys (patch, level, cell), in level order.
    pub fn keys(&self) -> &[NodeKey] {
        &self.keys
    }

    /// Node index of each leaf (unknown block), in unknown order.
    pub fn leaves(&self) -> &[u32] {
        &self.leaves
    }

    /// Root node of each patch.
    pub fn roots(&self) -> &[u32] {
        &self.roots
    }

    /// Links received by node `r`: `(emitter node, block)` with the `n × n` block
    /// (row = receiver function, column = emitter function) of each link.
    pub fn links_into(&self, r: usize) -> impl Iterator<Item = (usize, &[f64])> + '_ {
        let nn = self.n * self.n;
        (self.recv_offsets[r]..self.recv_offsets[r + 1])
            .map(move |k| (self.link_emitter[k] as usize, &self.blocks[k * nn..][..nn]))
    }

    /// Compiles links into the hierarchy of `n_patches` patches.
    pub fn compile(n: usize, n_patches: usize, links: &[LinkRec]) -> Self {
        Self::compile_with_nodes(n, n_patches, &[], links)
    }

    /// [`Hierarchy::compile`] with extra nodes that must exist (their ancestors and
    /// siblings are added too); e.g. every cell of a level gives a complete quadtree.
    pub fn compile_with_nodes(
        n: usize,
        n_patches: usize,
        nodes: &[NodeKey],
        links: &[LinkRec],
    ) -> Self {
        let mut set: HashSet<NodeKey> = HashSet::new();
        for p in 0..n_patches {
            set.insert(NodeKey::root(p));
        }
        let mut stack: Vec<NodeKey> = links.iter().flat_map(|l| [l.r, l.e]).collect();
        stack.extend_from_slice(nodes);
        while let Some(k) = stack.pop() {
            if !set.insert(k) {
                continue;
            }
            if let Some(p) = k.parent() {
                for c in 0..4 {
                    let s = p.child(c);
                    if s != k {
                        stack.push(s);
                    }
                }
                stack.push(p);
            }
        }
        let mut keys: Vec<NodeKey> = set.into_iter().collect();
        keys.sort_unstable();
        let index: HashMap<NodeKey, u32> = keys
            .iter()
            .enumerate()
            .map(|(i, k)| (*k, i as u32))
            .collect();
        let nn = keys.len();
        let mut children = vec![[u32::MAX; 4]; nn];
        let mut parent = vec![u32::MAX; nn];
        for (i, k) in keys.iter().enumerate() {
            if let Some(p) = k.parent() {
                let pi = index[&p];
                parent[i] = pi;
                children[pi as usize][k.child_pos()] = i as u32;
            }
        }
        let max_level = keys.last().map_or(0, |k| k.level as usize);
        let mut level_start = vec![0usize; max_level + 2];
        for k in &keys {
            level_start[k.level as usize + 1] += 1;
        }
        for l in 0..=max_level {
            level_start[l + 1] += level_start[l];
        }
        let mut leaves = Vec::new();
        let mut leaf_of = vec![u32::MAX; nn];
        for i in 0..nn {
            if children[i][0] == u32::MAX {
                leaf_of[i] = leaves.len() as u32;
                leaves.push(i as u32);
            }
        }
        let roots = (0..n_patches).map(|p| index[&NodeKey::root(p)]).collect();
        // Links by receiver (stable: refinement order within a receiver).
        let mut order: Vec<usize> = (0..links.len()).collect();
        order.sort_by_key(|&i| index[&links[i].r]);
        let mut recv_offsets = vec![0usize; nn + 1];
        let mut link_emitter = Vec::with_capacity(links.len());
        let mut link_receiver = Vec::with_capacity(links.len());
        let mut blocks = Vec::with_capacity(links.len() * n * n);
        let mut link_seen = Vec::with_capacity(links.len());
        for &i in &order {
            link_seen.push(links[i].seen);
            let r = index[&links[i].r];
            recv_offsets[r as usize + 1] += 1;
            link_receiver.push(r);
            link_emitter.push(index[&links[i].e]);
            blocks.extend_from_slice(&links[i].block);
        }
        for i in 0..nn {
            recv_offsets[i + 1] += recv_offsets[i];
        }
        let mut by_emitter: Vec<u32> = (0..links.len() as u32).collect();
        by_emitter.sort_by_key(|&l| link_emitter[l as usize]);
        let mut emit_offsets = vec![0usize; nn + 1];
        for &l in &by_emitter {
            emit_offsets[link_emitter[l as usize] as usize + 1] += 1;
        }
        for i in 0..nn {
            emit_offsets[i + 1] += emit_offsets[i];
        }
        Self {
            n,
            keys,
            children,
            parent,
            level_start,
            leaves,
            leaf_of,
            roots,
            recv_offsets,
            link_emitter,
            link_receiver,
            blocks,
            link_seen,
            by_emitter,
            emit_offsets,
        }
    }

    /// The links in the compiled (receiver) order, the order of
    /// [`crate::ErrorEstimate::link_error`].
    pub fn links(&self) -> Vec<LinkRec> {
        let nn = self.n * self.n;
        (0..self.link_count())
            .map(|l| LinkRec {
                r: self.keys[self.link_receiver[l] as usize],
                e: self.keys[self.link_emitter[l] as usize],
                block: self.blocks[l * nn..][..nn].to_vec(),
                seen: self.link_seen[l],
            })
            .collect()
    }

    /// Number of nodes.
    pub fn node_count(&self) -> usize {
        self.keys.len()
    }

    /// Number of links.
    pub fn link_count(&self) -> usize {
        self.link_emitter.len()
    }

    /// Deepest level.
    pub fn max_level(&self) -> usize {
        self.level_start.len() - 2
    }

    /// The leaf containing parameter point `(s, t)` of a patch.
    pub fn leaf_at(&self, patch: usize, s: f64, t: f64) -> u32 {
        let mut i = self.roots[patch];
        let s = s.clamp(0.0, 1.0);
        let t = t.clamp(0.0, 1.0);
        loop {
            let ch = self.children[i as usize];
            if ch[0] == u32::MAX {
                return i;
            }
            let k = self.keys[i as usize];
            let h = 0.5f64.powi(k.level as i32 + 1);
            let cx = ((s / h).floor() as i64 - 2 * k.ix as i64).clamp(0, 1) as usize;
            let cy = ((t / h).floor() as i64 - 2 * k.iy as i64).clamp(0, 1) as usize;
            i = ch[cy * 2 + cx];
        }
    }

    /// Approximate bytes held (vector capacities).
    pub fn bytes(&self) -> usize {
        use std::mem::size_of;
        self.keys.capacity() * size_of::<NodeKey>()
            + self.children.capacity() * 16
            + self.parent.capacity() * 4
            + self.leaves.capacity() * 4
            + self.leaf_of.capacity() * 4
            + self.recv_offsets.capacity() * 8
            + self.emit_offsets.capacity() * 8
            + (self.link_emitter.capacity()
                + self.link_receiver.capacity()
                + self.by_emitter.capacity())
                * 4
            + self.blocks.capacity() * 8
            + self.link_seen.capacity() * size_of::<LinkVisibility>()
    }
}
