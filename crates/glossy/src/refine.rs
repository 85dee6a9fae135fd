//! The refinement oracle (Glossy §5.3) and the bottom-up rebuild of coarse
//! coefficients (§5.4).
//!
//! **Candidates.** A new link `r ← s` is considered only if `r′ ← s` or `r ← s′` is
//! already linked (§6.5, Fig. 11; we read §5.3's `r′ ← s′` as a typo for `r ← s′`),
//! where the parent of a wavelet `ψʲᵢ` is the wavelet of the same type `ψʲ⁻¹_{⌊i/2⌋}`
//! and the parent of a `W⁰` wavelet the root `φ`. A link into a node's 15 wavelets
//! proposes the 16 children of that node; a link into a root `φ` proposes the root's
//! 15 wavelets; a link from a wavelet proposes the same type on the 16 children of
//! its node (only those that exist: a sender node without coefficients has `ℓ = 0`);
//! a link from a root `φ` proposes the root's 15 wavelets as senders.
//!
//! **Value** of a candidate: `max(|ℓ_s|·est·I_r, |Γ_s|·est·R_r)` with
//! `est = variation(parent link) × ‖b_r‖₁‖b_s‖₁` — ours: it bounds `|T_{r←s}|` by the
//! kernel's deviation from a constant over the supports (the paper uses the variation
//! alone) — and `I_r = ∫_{supp r} Γ(z, −ω) cos θ dA dω`, the importance arriving at
//! the receiving support from the point `z` that `y` sees along `ω` (the paper's
//! "integral of GΓ"), estimated — ours, the paper does not say how — in two parts:
//! the reflected part `Γ − Γ_e` by stratified directional rays, the emitted part `Γ_e`
//! by sampling points on the sources (patches with non-zero `Γ_e`, chosen by area ×
//! mean emission) with a shadow ray each, so that a source subtending a tiny solid
//! angle from the receiver is found whatever its size (directional rays alone miss a
//! 0.01² light 1.1 m away: `R_r` of the 0.01² receiver of Glossy Fig. 12 came out
//! ~1e-15 or 0 instead of 6.4e-9, its point estimate, which sampling the light finds
//! to 0.2 % with 16 samples, and the importance links into it never refined); plus the transparent eye's own `Γ_e`,
//! integrated over its small solid angle, and — ours — a named importance patch's own
//! `Γ_e`, so that the patch's own radiance counts as watched, which §7.1 observes:
//! importance emitted by a receiving patch refines the interactions at that patch.
//! `R_r` is its radiance twin (emitters as the sources). With
//! importance off, `I ≡ R ≡ 1`. Ours, where the paper is silent: `|ℓ_s|` is the
//! sender's *reach*, the largest `|ℓ_d|·‖b_d‖₁/‖b_s‖₁` over the sender and its
//! same-type descendants, so a wavelet whose coefficient vanishes by symmetry (the
//! level-0 angular wavelets of a spotlight's centred lobe) still leads refinement to
//! the finer wavelets that carry the lobe. A round computes every candidate whose value is at
//! least `fraction ×` the largest; with a largest value of 0 refinement stops.
//! Candidates whose samples are all zero (the sender's direction cell misses the
//! receiver, or everything is occluded) are remembered and never proposed again.
//!
//! **Rebuild.** After a round, links are revisited from the finest level pairs up: a
//! link whose receiving and sending nodes both have children linked pairwise (every
//! child pair that received samples when the link was computed has a `φ→φ`
//! coefficient) gets its coefficients recomputed from those finer `φ→φ` values — the
//! same Haar steps as [`crate::transport`], on 16× more samples. Ours, where the paper
//! is silent (some pairs missing): a link from a node's `φ` needs only the receiving
//! children's `φ→φ` values with the sending node (the sender's Haar step is the
//! average), and a link into a root `φ` only the sending children's with the
//! receiving node. Refinement is mostly receiver-side, so without these two the
//! rebuild never fired (0 links in 8 rounds on the Cornell box) and a receiver's mean
//! kept the root link's quadrature error for good (the floor under the blocks'
//! shadows: +10 % at `n = 2`; see `tests/diffuse.rs`). Otherwise the sampled values
//! are kept.

use std::collections::HashMap;

use glam::DVec2;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;
use rayon::prelude::*;
use wavelux_geometry::Ray;

use crate::basis::{CHILDREN, HaarStep, NodeKey, TYPES, l1_norm};
use crate::directions::DirectionKind;
use crate::link::{Link, LinkSet};
use crate::patch::GlossyScene;
use crate::tree::{BANDS, Functions, IMPORTANCE, RADIANCE};

/// `(I_r, R_r)` per receiving (patch, node).
pub type Arriving = HashMap<(u32, NodeKey), (f64, f64)>;

/// A proposed link.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Candidate {
    /// Sending function (global id).
    pub sender: u32,
    /// Receiving patch.
    pub recv_patch: u32,
    /// Receiving node key.
    pub recv_key: NodeKey,
    /// Into the root `φ`.
    pub recv_phi: bool,
    /// Estimated `|T|` (variation × norms).
    pub est: f64,
}

/// SplitMix64 finaliser (seeds of per-link and per-node streams).
pub(crate) fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// A stream seed for a node `(patch, key)`.
pub(crate) fn node_stream(seed: u64, patch: usize, key: &NodeKey) -> u64 {
    let k = key
        .idx
        .iter()
        .fold(u64::from(key.level), |a, &i| mix(a ^ u64::from(i)));
    mix(seed ^ mix(patch as u64) ^ k)
}

/// Proposes the candidates of one round (deduplicated, existing and dead links
/// removed), in a deterministic order.
pub fn candidates(
    funcs: &Functions,
    links: &LinkSet,
    dead: &std::collections::HashSet<(u32, u32, NodeKey, bool)>,
    max_level: u8,
) -> Vec<Candidate> {
    let mut out = Vec::new();
    let mut seen = std::collections::HashSet::new();
    let mut push = |c: Candidate, out: &mut Vec<Candidate>| {
        let key = (c.sender, c.recv_patch, c.recv_key, c.recv_phi);
        if dead.contains(&key) || !seen.insert(key) {
            return;
        }
        let exists = funcs.trees[c.recv_patch as usize]
            .find(&c.recv_key)
            .is_some_and(|n| links.contains(&(c.sender, c.recv_patch, n, c.recv_phi)));
        if !exists {
            out.push(c);
        }
    };
    for l in &links.links {
        let s = funcs.owner[l.sender as usize];
        let skey = funcs.trees[s.patch as usize].keys[s.node as usize];
        let rtree = &funcs.trees[l.recv_patch as usize];
        let rkey = rtree.keys[l.recv_node as usize];
        let var = f64::from(l.variation);
        // Refine the receiver.
        if l.recv_phi {
            push(
                Candidate {
                    sender: l.sender,
                    recv_patch: l.recv_patch,
                    recv_key: NodeKey::ROOT,
                    recv_phi: false,
                    est: var * l1_norm(0) * l1_norm(skey.level),
                },
                &mut out,
            );
        } else if rkey.level < max_level {
            for k in 0..CHILDREN {
                if l.masks[0] & (1 << k) == 0 {
                    continue;
                }
                let ck = rkey.child(k);
                push(
                    Candidate {
                        sender: l.sender,
                        recv_patch: l.recv_patch,
                        recv_key: ck,
                        recv_phi: false,
                        est: var * l1_norm(ck.level) * l1_norm(skey.level),
                    },
                    &mut out,
                );
            }
        }
        // Refine the sender.
        let stree = &funcs.trees[s.patch as usize];
        let rlevel = if l.recv_phi { 0 } else { rkey.level };
        let node_pair = l
            .phiphi
            .iter()
            .fold(0.0f64, |a, v| a.max(f64::from(v.abs())));
        if s.tau == 0 {
            for t in 1..=TYPES {
                push(
                    Candidate {
                        sender: stree.id(0, t),
                        recv_patch: l.recv_patch,
                        recv_key: rkey,
                        recv_phi: l.recv_phi,
                        est: sender_est(t, var * l1_norm(rlevel) * l1_norm(0), node_pair),
                    },
                    &mut out,
                );
            }
        } else if skey.level < max_level {
            for k in 0..CHILDREN {
                if l.masks[1] & (1 << k) == 0 {
                    continue;
                }
                if let Some(n) = stree.find(&skey.child(k)) {
                    push(
                        Candidate {
                            sender: stree.id(n, usize::from(s.tau)),
                            recv_patch: l.recv_patch,
                            recv_key: rkey,
                            recv_phi: l.recv_phi,
                            est: sender_est(
                                usize::from(s.tau),
                                var * l1_norm(rlevel) * l1_norm(skey.level + 1),
                                node_pair,
                            ),
                        },
                        &mut out,
                    );
                }
            }
        }
    }
    out
}

/// `est` of a sender refinement to wavelet type `tau`: `smooth` (the variation bound)
/// for purely spatial types; for types with an angular factor, `node_pair`, the
/// parent link's `T_{φ_R←φ_S}`. The transport evaluates a sender only along the
/// directions `x → y`, a 2D slice of its 4D cell on which an angular wavelet does not
/// average to zero, so the variation does not bound it (a small receiver under a
/// spotlight sees a smooth kernel, yet the lobe's wavelets carry all its light); the
/// kernel is non-negative and `|b| = φ` on a node's cell for every Haar type, so
/// `|T_{r←s}| ≤ T_{φ_R←φ_S}` of their nodes, which the parent's value approximates.
fn sender_est(tau: usize, smooth: f64, node_pair: f64) -> f64 {
    if tau & 0b1100 != 0 { node_pair } else { smooth }
}

/// Largest absolute value of a function's bands in `bands`.
pub(crate) fn magnitude(v: &[f64; BANDS], bands: std::ops::Range<usize>) -> f64 {
    bands.map(|b| v[b].abs()).fold(0.0, f64::max)
}

/// The sources of one band set (emitters for radiance, named importance patches for
/// importance; never the eye, whose `Γ_e` is integrated on its own): patches with a
/// non-zero emitted root `φ`, chosen with probability proportional to their area times
/// that mean (a power estimate), with the cumulative distribution.
#[derive(Debug, Clone, Default)]
pub struct Sources {
    /// `(patch, cumulative probability)`, the last equal to 1.
    cdf: Vec<(usize, f64)>,
    /// Probability of each patch (0 for a non-source).
    prob: Vec<f64>,
}

impl Sources {
    /// The sources of `bands` in `funcs.emit`.
    #[must_use]
    pub fn new(scene: &GlossyScene, funcs: &Functions, bands: std::ops::Range<usize>) -> Self {
        let w: Vec<f64> = scene
            .patches
            .iter()
            .enumerate()
            .map(|(q, p)| {
                if p.is_eye() {
                    return 0.0;
                }
                let m = magnitude(&funcs.emit[funcs.trees[q].root_phi as usize], bands.clone());
                if m.is_finite() {
                    m * p.support.area
                } else {
                    0.0
                }
            })
            .collect();
        let total: f64 = w.iter().sum();
        if !crate::positive(total) {
            return Self {
                cdf: Vec::new(),
                prob: vec![0.0; w.len()],
            };
        }
        let mut acc = 0.0;
        let mut cdf = Vec::new();
        for (q, &x) in w.iter().enumerate() {
            if x > 0.0 {
                acc += x / total;
                cdf.push((q, acc));
            }
        }
        if let Some(last) = cdf.last_mut() {
            last.1 = 1.0;
        }
        Self {
            cdf,
            prob: w.iter().map(|x| x / total).collect(),
        }
    }

    /// Whether there is no source.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.cdf.is_empty()
    }

    /// Whether patch `q` is a source.
    #[must_use]
    pub fn contains(&self, q: usize) -> bool {
        self.prob.get(q).is_some_and(|&p| p > 0.0)
    }

    /// The source for a uniform number `xi ∈ [0, 1)` and its probability.
    fn pick(&self, xi: f64) -> (usize, f64) {
        let i = self
            .cdf
            .partition_point(|&(_, c)| c <= xi)
            .min(self.cdf.len() - 1);
        let q = self.cdf[i].0;
        (q, self.prob[q])
    }
}

/// The radiance and importance sources of a scene (see [`Sources`]).
#[derive(Debug, Clone, Default)]
pub struct AllSources {
    /// Emitters of `L_e`.
    pub radiance: Sources,
    /// Patches emitting `Γ_e` (named importance patches; not the eye).
    pub importance: Sources,
}

impl AllSources {
    /// The sources of both band sets.
    #[must_use]
    pub fn new(scene: &GlossyScene, funcs: &Functions) -> Self {
        Self {
            radiance: Sources::new(scene, funcs, RADIANCE),
            importance: Sources::new(scene, funcs, IMPORTANCE),
        }
    }

    /// Rays per receiving node for `rays` requested: the directional rays plus one
    /// shadow ray per source sample of each non-empty band set.
    #[must_use]
    pub fn rays_per_node(&self, rays: usize) -> usize {
        let n = rays.div_ceil(CHILDREN).max(1) * CHILDREN;
        n * (1 + usize::from(!self.radiance.is_empty()) + usize::from(!self.importance.is_empty()))
    }
}

/// `∫ A_e(x, ω_xy) cos θ_y dA_y dω` over the node's cell (`st` square `lo`, side `h`,
/// directions in its direction cell) from `n` samples: `y` stratified over the four
/// spatial quarters, `x` on a source chosen by [`Sources::pick`], a shadow ray each.
/// The emitted part of what [`arriving`] measures, estimated where it comes from so
/// that a source subtending a tiny solid angle is not missed by the directional rays.
#[allow(clippy::too_many_arguments)]
fn arriving_emitted(
    scene: &GlossyScene,
    funcs: &Functions,
    haar: &HaarStep,
    dirs: DirectionKind,
    patch: usize,
    key: NodeKey,
    sources: &Sources,
    bands: std::ops::Range<usize>,
    n: usize,
    rng: &mut Pcg64,
) -> f64 {
    if sources.is_empty() {
        return 0.0;
    }
    let p = &scene.patches[patch];
    let (h, lo) = (key.size(), key.lo());
    let (dlo, dhi) = (DVec2::new(lo[2], lo[3]), DVec2::new(lo[2] + h, lo[3] + h));
    let mut sum = 0.0;
    for i in 0..n {
        let st = DVec2::new(
            lo[0] + 0.5 * h * ((i & 1) as f64 + rng.random::<f64>()),
            lo[1] + 0.5 * h * (((i >> 1) & 1) as f64 + rng.random::<f64>()),
        );
        let (q, prob) = sources.pick(rng.random::<f64>());
        let xs = DVec2::new(rng.random::<f64>(), rng.random::<f64>());
        if q == patch || !p.support.is_real(st.x, st.y) {
            continue;
        }
        let src = &scene.patches[q];
        if !src.support.is_real(xs.x, xs.y) {
            continue;
        }
        let (y, n_y) = p.support.point_normal(st.x, st.y);
        let (x, n_x) = src.support.point_normal(xs.x, xs.y);
        let d = x - y;
        let r2 = d.length_squared();
        if !crate::positive(r2) {
            continue;
        }
        let w = d / r2.sqrt();
        let (cy, cx) = (n_y.dot(w), -n_x.dot(w));
        if !(cy > 0.0 && cx > 0.0) {
            continue;
        }
        let Some(uy) = dirs.inverse(p.frame(st.x, st.y).to_local(w)) else {
            continue;
        };
        if uy.x < dlo.x || uy.x > dhi.x || uy.y < dlo.y || uy.y > dhi.y {
            continue;
        }
        let Some(ux) = dirs.inverse(src.frame(xs.x, xs.y).to_local(-w)) else {
            continue;
        };
        let e = funcs.eval(
            haar,
            q,
            [xs.x, xs.y, ux.x, ux.y],
            bands.clone(),
            &funcs.emit,
        );
        let e = e.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        if e == 0.0 || scene.accel.occluded(y, x, [p.prim, src.prim]) {
            continue;
        }
        let da_y = p.support.jacobian(st.x, st.y) * h * h / n as f64;
        sum += e * cy * cx / r2 * src.support.jacobian(xs.x, xs.y) / prob * da_y;
    }
    sum
}

/// `(I_r, R_r)`: importance and radiance arriving at the support of node `key` of
/// `patch` (see the module docs): the reflected parts from `rays` stratified
/// directional rays, the emitted parts from as many samples of the [`AllSources`] (a
/// shadow ray each).
#[allow(clippy::too_many_arguments)]
pub fn arriving(
    scene: &GlossyScene,
    funcs: &Functions,
    haar: &HaarStep,
    dirs: DirectionKind,
    sources: &AllSources,
    patch: usize,
    key: NodeKey,
    rays: usize,
    seed: u64,
) -> (f64, f64) {
    let p = &scene.patches[patch];
    let mut rng = Pcg64::seed_from_u64(node_stream(seed ^ 0xA11, patch, &key));
    let h = key.size();
    let lo = key.lo();
    let per = rays.div_ceil(CHILDREN).max(1);
    let n = per * CHILDREN;
    let vol = h.powi(4) / n as f64;
    let eps = 1e-7 * scene.diagonal;
    let eye = scene.eye().map(|e| &scene.patches[e]);
    let (mut imp, mut rad) = (0.0, 0.0);
    // The value a ray finds at `q`: without the emitted part where `q` is a source
    // of the band set (that part is sampled at the sources).
    let found = |q: usize, uq: [f64; 4], bands: std::ops::Range<usize>, src: &Sources| {
        let v = funcs.eval(haar, q, uq, bands.clone(), &funcs.value);
        let v = if src.contains(q) {
            let e = funcs.eval(haar, q, uq, bands, &funcs.emit);
            std::array::from_fn::<f64, 3, _>(|c| v[c] - e[c])
        } else {
            v
        };
        v.iter().fold(0.0f64, |a, x| a.max(x.abs()))
    };
    for k in 0..CHILDREN {
        for _ in 0..per {
            let u: [f64; 4] = std::array::from_fn(|a| {
                lo[a] + 0.5 * h * (((k >> a) & 1) as f64 + rng.random::<f64>())
            });
            let st = DVec2::new(u[0], u[1]);
            if !p.support.is_real(st.x, st.y) {
                continue;
            }
            let (y, n_y) = p.support.point_normal(st.x, st.y);
            let frame = p.frame(st.x, st.y);
            let uw = DVec2::new(u[2], u[3]);
            let wl = dirs.direction(uw);
            let w = frame.to_world(wl);
            let weight = wl.z * dirs.jacobian(uw) * p.support.jacobian(st.x, st.y) * vol;
            if p.importance {
                // A named importance patch wants its own radiance right (Glossy §7.1:
                // "when the receiving patch emits importance … the interactions are
                // refined more at the receiver"): its `Γ_e = 1` counts as arriving.
                imp += weight;
            }
            let ray = Ray {
                origin: y + n_y * eps,
                dir: w,
            };
            if let Some(hit) = scene.accel.closest_hit(&ray, eps, f64::INFINITY)
                && let Some((q, qst)) = scene.resolve(&hit)
            {
                let qf = scene.patches[q].frame(qst.x, qst.y);
                let back = qf.to_local(-w);
                if back.z > 0.0
                    && let Some(qu) = dirs.inverse(back)
                {
                    let uq = [qst.x, qst.y, qu.x, qu.y];
                    imp += weight * found(q, uq, IMPORTANCE, &sources.importance);
                    rad += weight * found(q, uq, RADIANCE, &sources.radiance);
                }
            }
            // The transparent eye: Γ_e = 1 over its small solid angle.
            if let Some(e) = eye
                && let Some(fr) = e.frustum
            {
                let c = e.support.point(0.5, 0.5);
                let d = c - y;
                let r2 = d.length_squared();
                if r2 > 0.0 {
                    let dir = d / r2.sqrt();
                    let lw = frame.to_local(dir);
                    let inside = lw.z > 0.0
                        && dirs.inverse(lw).is_some_and(|a| {
                            a.x >= lo[2] && a.x <= lo[2] + h && a.y >= lo[3] && a.y <= lo[3] + h
                        });
                    let ce = fr.forward.dot(-dir);
                    if inside
                        && fr.contains(-dir)
                        && ce > 0.0
                        && !scene.accel.occluded(y, c, [p.prim, None])
                    {
                        let omega = e.support.area * ce / r2;
                        // ∫ Γ_e cos θ dω over the eye's solid angle ≈ cos θ·Ω_e, then
                        // the spatial integral by the n samples of the cell.
                        let spatial = p.support.jacobian(st.x, st.y) * h * h / (n as f64);
                        imp += spatial * lw.z * omega;
                    }
                }
            }
        }
    }
    imp += arriving_emitted(
        scene,
        funcs,
        haar,
        dirs,
        patch,
        key,
        &sources.importance,
        IMPORTANCE,
        n,
        &mut rng,
    );
    rad += arriving_emitted(
        scene,
        funcs,
        haar,
        dirs,
        patch,
        key,
        &sources.radiance,
        RADIANCE,
        n,
        &mut rng,
    );
    (imp, rad)
}

/// Computes `(I, R)` for every receiving node of `cands` (parallel, deterministic)
/// and the rays traced.
pub fn arriving_all(
    scene: &GlossyScene,
    funcs: &Functions,
    haar: &HaarStep,
    dirs: DirectionKind,
    cands: &[Candidate],
    rays: usize,
    seed: u64,
) -> (Arriving, u64) {
    let sources = AllSources::new(scene, funcs);
    let mut keys: Vec<(u32, NodeKey)> = cands
        .iter()
        .map(|c| {
            (
                c.recv_patch,
                if c.recv_phi {
                    NodeKey::ROOT
                } else {
                    c.recv_key
                },
            )
        })
        .collect();
    keys.sort_unstable();
    keys.dedup();
    let vals: Vec<(f64, f64)> = keys
        .par_iter()
        .map(|&(p, k)| {
            arriving(
                scene, funcs, haar, dirs, &sources, p as usize, k, rays, seed,
            )
        })
        .collect();
    let traced = (keys.len() * sources.rays_per_node(rays)) as u64;
    (keys.into_iter().zip(vals).collect(), traced)
}

/// Per function, `[radiance, importance]` magnitude of what refining it as a sender
/// can reach: the largest `|ℓ_d|·‖b_d‖₁/‖b_s‖₁` over the function itself and its
/// descendants `d` of the same type (children of a wavelet's node, recursively; the
/// root `φ` has none). Without it a sender whose own coefficient vanishes by symmetry
/// — every level-0 angular wavelet of a lobe centred in the direction square — would
/// never be proposed, and the finer wavelets that carry the lobe never linked.
#[must_use]
pub fn reach(funcs: &Functions) -> Vec<[f64; 2]> {
    let mut out: Vec<[f64; 2]> = funcs
        .value
        .iter()
        .map(|v| [magnitude(v, RADIANCE), magnitude(v, IMPORTANCE)])
        .collect();
    let ratio = l1_norm(1);
    for tree in &funcs.trees {
        // Children are created after their parents: reverse order sees every child
        // before its parent passes the maximum on.
        for n in (1..tree.len()).rev() {
            let Some(p) = tree.keys[n].parent().and_then(|k| tree.find(&k)) else {
                continue;
            };
            for t in 1..=TYPES {
                let c = out[tree.id(n as u32, t) as usize];
                let q = &mut out[tree.id(p, t) as usize];
                q[0] = q[0].max(ratio * c[0]);
                q[1] = q[1].max(ratio * c[1]);
            }
        }
    }
    out
}

/// Values `max(|ℓ_s|·est·I_r, |Γ_s|·est·R_r)` of the candidates, where `|ℓ_s|` and
/// `|Γ_s|` are the sender's [`reach`] (`arrive`: `None` when importance is off).
pub fn values(reach: &[[f64; 2]], cands: &[Candidate], arrive: Option<&Arriving>) -> Vec<f64> {
    cands
        .iter()
        .map(|c| {
            let [l, g] = reach[c.sender as usize];
            match arrive {
                None => l * c.est,
                Some(m) => {
                    let key = (
                        c.recv_patch,
                        if c.recv_phi {
                            NodeKey::ROOT
                        } else {
                            c.recv_key
                        },
                    );
                    let (i, r) = m.get(&key).copied().unwrap_or((0.0, 0.0));
                    (l * c.est * i).max(g * c.est * r)
                }
            }
        })
        .collect()
}

/// The finer `φ→φ` values a link's rebuild reads (see the module docs).
enum Fine {
    /// `T_{φ_{r_k} ← φ_{s_l}}` of every child pair.
    Both(Box<[[[f64; 3]; CHILDREN]; CHILDREN]>),
    /// `T_{φ_{r_k} ← φ_S}` of every receiving child and the sending node (sender `φ`).
    Receiver([[f64; 3]; CHILDREN]),
    /// `T_{φ_R ← φ_{s_l}}` of the receiving node and every sending child (root-`φ`
    /// receiver).
    Sender([[f64; 3]; CHILDREN]),
}

/// The `φ→φ` values of `(receiving node, sending node)` for the children of the
/// masked ones, or `None` if one is missing. `pair(k)` names the pair of child `k`.
fn gather_fine(
    links: &LinkSet,
    mask: u16,
    pair: impl Fn(usize) -> Option<(u32, u32, u32, u32)>,
) -> Option<[[f64; 3]; CHILDREN]> {
    let mut out = [[0.0; 3]; CHILDREN];
    for (k, o) in out.iter_mut().enumerate() {
        if mask & (1 << k) != 0 {
            *o = links.phiphi.get(&pair(k)?)?.map(f64::from);
        }
    }
    Some(out)
}

/// The finest complete set of finer values for link `l`: every child pair, else
/// (sender `φ`) the receiving children alone, else (root-`φ` receiver) the sending
/// children alone.
fn fine_values(funcs: &Functions, links: &LinkSet, l: &Link) -> Option<Fine> {
    let s = funcs.owner[l.sender as usize];
    let stree = &funcs.trees[s.patch as usize];
    let rtree = &funcs.trees[l.recv_patch as usize];
    let skey = stree.keys[s.node as usize];
    let rkey = rtree.keys[l.recv_node as usize];
    if l.masks[0] == 0 {
        return None;
    }
    let rchild = |k: usize| rtree.find(&rkey.child(k));
    let schild = |k: usize| stree.find(&skey.child(k));
    let both = (|| {
        let mut phi = Box::new([[[0.0f64; 3]; CHILDREN]; CHILDREN]);
        for (kr, row) in phi.iter_mut().enumerate() {
            if l.masks[0] & (1 << kr) == 0 {
                continue;
            }
            let nr = rchild(kr)?;
            *row = gather_fine(links, l.masks[1], |ks| {
                Some((l.recv_patch, nr, s.patch, schild(ks)?))
            })?;
        }
        Some(Fine::Both(phi))
    })();
    both.or_else(|| {
        (s.tau == 0)
            .then(|| {
                gather_fine(links, l.masks[0], |kr| {
                    Some((l.recv_patch, rchild(kr)?, s.patch, s.node))
                })
            })
            .flatten()
            .map(Fine::Receiver)
    })
    .or_else(|| {
        l.recv_phi
            .then(|| {
                gather_fine(links, l.masks[1], |ks| {
                    Some((l.recv_patch, l.recv_node, s.patch, schild(ks)?))
                })
            })
            .flatten()
            .map(Fine::Sender)
    })
}

/// The link's coefficients and `φ→φ` value (per channel) from finer values: the same
/// Haar steps as [`crate::transport`].
fn rebuilt_values(
    haar: &HaarStep,
    fine: &Fine,
    tau_s: usize,
    recv_phi: bool,
) -> ([[f32; TYPES]; 3], [f32; 3]) {
    let mut coef = [[0.0f32; TYPES]; 3];
    let mut pp = [0.0f32; 3];
    for c in 0..3 {
        let sum = |t: usize, x: &[f64; CHILDREN]| (0..CHILDREN).map(|k| haar.at(t, k) * x[k]).sum();
        // `v[k_r]`: the receiving child `k_r`'s coefficient from the sender; `w[k_r]`
        // the same from the sending node's `φ`.
        let (v, w): ([f64; CHILDREN], [f64; CHILDREN]) = match fine {
            Fine::Both(phi) => (
                std::array::from_fn(|kr| sum(tau_s, &phi[kr].map(|x| x[c]))),
                std::array::from_fn(|kr| sum(0, &phi[kr].map(|x| x[c]))),
            ),
            Fine::Receiver(u) => {
                let u = u.map(|x| x[c]);
                (u, u)
            }
            Fine::Sender(u) => {
                // Root-`φ` receiver: only the sender's Haar step is needed.
                let u = u.map(|x| x[c]);
                coef[c][0] = sum(tau_s, &u) as f32;
                pp[c] = sum(0, &u) as f32;
                continue;
            }
        };
        if recv_phi {
            coef[c][0] = sum(0, &v) as f32;
        } else {
            for t in 1..CHILDREN {
                coef[c][t - 1] = sum(t, &v) as f32;
            }
        }
        pp[c] = sum(0, &w) as f32;
    }
    (coef, pp)
}

/// The §5.4 rebuild (see the module docs); returns how many links were rebuilt.
pub fn rebuild(funcs: &Functions, links: &mut LinkSet, haar: &HaarStep) -> usize {
    let mut order: Vec<usize> = (0..links.links.len()).collect();
    let level_sum = |l: &Link| -> u32 {
        let s = funcs.owner[l.sender as usize];
        let sk = funcs.trees[s.patch as usize].keys[s.node as usize];
        let rk = funcs.trees[l.recv_patch as usize].keys[l.recv_node as usize];
        u32::from(sk.level) + u32::from(rk.level)
    };
    order.sort_by_key(|&i| std::cmp::Reverse(level_sum(&links.links[i])));
    let mut rebuilt = 0;
    for i in order {
        let l = &links.links[i];
        let Some(fine) = fine_values(funcs, links, l) else {
            continue;
        };
        let s = funcs.owner[l.sender as usize];
        let (coef, pp) = rebuilt_values(haar, &fine, usize::from(s.tau), l.recv_phi);
        let l = &mut links.links[i];
        l.coef = coef;
        l.phiphi = pp;
        let key = (l.recv_patch, l.recv_node, s.patch, s.node);
        links.phiphi.insert(key, pp);
        rebuilt += 1;
    }
    rebuilt
}
