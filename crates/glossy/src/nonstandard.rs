//! The non-standard operator decomposition (Glossy §3.5; Beylkin et al. 1991, Gortler
//! et al. 1993), the alternative the paper chose against: every link joins the
//! scaling functions `φ` of one receiving and one sending node (any level, any two
//! patches), so each basis function interacts with others at a single level of the
//! hierarchy, and every iteration is followed by a *push* and a *pull*.
//!
//! With Haar scaling links this is the non-standard form of the operator: the
//! `φ → φ` blocks of the leaves of the link hierarchy are the non-standard blocks
//! `{φ, ψ} ← {φ, ψ}` of their parents' level (Gortler et al. 1993, §4). The radiance
//! itself stays in the per-patch 4D trees of [`crate::tree`] (root `φ` and wavelets),
//! so evaluation, exitance, gather and images are shared with the standard form:
//! - **push** ([`push`]): the `φ` coefficient of every node, top-down by the
//!   synthesis step of [`HaarStep`] (a node's children's `φ` from its `φ` and its 15
//!   wavelets);
//! - **gather**: `a_r += T_{φ_r ← φ_s} φ_s` for every link (`T` from the same
//!   [`crate::transport`] samples as the standard links' `φ→φ` coefficients);
//! - **pull** ([`pull`]): every node's gathered `a_r` is carried up to the root by
//!   the analysis step: a node's `a` adds `H[τ][k]·a` to its parent's wavelet `τ`
//!   and `H[0][k]·a` (`= a/4`) to its parent's gathered `φ` — the Haar wavelet
//!   transform of the piecewise-constant gathered function.
//!
//! **Refinement** (ours, as in hierarchical radiosity; the paper gives no oracle for
//! this form): a link's value is `|φ_s| × variation × ‖φ_r‖₁‖φ_s‖₁`, the bound of what
//! the neglected finer interactions can carry (the standard oracle's estimate, with
//! the link's own kernel variation); a round replaces every link whose value is at
//! least `fraction ×` the round's largest by the links from its sender to the 16
//! children of its receiving node (the coarser end is split, the receiver on ties;
//! a sending node whose radiance has no detail — all wavelets of its subtree zero —
//! is never split, since its children would send the same constant). Children
//! whose samples are all zero get no link. Importance is not supported in this form
//! (the comparison of §3.5 is about the operator, and is made without it).

use crate::basis::{CHILDREN, HaarStep, NodeKey, TYPES, l1_norm};
use crate::error::GlossyError;
use crate::refine::magnitude;
use crate::solve::{SolveRecord, check_finite, rel_change};
use crate::tree::{BANDS, Functions, RADIANCE};

/// Which operator decomposition carries light (Glossy §3.5).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub enum Decomposition {
    /// The paper's: a sending function to the wavelets of a node at any level
    /// ([`crate::link`]); no push/pull.
    #[default]
    Standard,
    /// Scaling links between nodes' `φ` with push/pull (this module).
    NonStandard,
}

impl Decomposition {
    /// Lower-case name.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Standard => "standard",
            Self::NonStandard => "non-standard",
        }
    }
}

/// A scaling link `φ_r ← φ_s` between two nodes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScalingLink {
    /// Receiving patch.
    pub recv_patch: u32,
    /// Receiving node (index in the patch's tree).
    pub recv_node: u32,
    /// Sending patch.
    pub send_patch: u32,
    /// Sending node (index in the patch's tree).
    pub send_node: u32,
    /// `T_{φ_r ← φ_s}` per colour channel.
    pub t: [f32; 3],
    /// Kernel variation met while computing it (max − min of `A_s·G·V·f_r`).
    pub variation: f32,
}

impl ScalingLink {
    /// Bytes one link occupies.
    pub const BYTES: usize = std::mem::size_of::<Self>();
}

/// `φ` coefficient of every node of every patch (`[patch][node]`), bands `bands`,
/// from the tree coefficients `x` (top-down synthesis).
#[must_use]
pub fn push(
    funcs: &Functions,
    haar: &HaarStep,
    x: &[[f64; BANDS]],
    bands: std::ops::Range<usize>,
) -> Vec<Vec<[f64; BANDS]>> {
    funcs
        .trees
        .iter()
        .map(|tree| {
            let mut phi = vec![[0.0; BANDS]; tree.len()];
            phi[0] = x[tree.root_phi as usize];
            // Parents are created before their children: index order is top-down.
            for n in 1..tree.len() {
                let key = tree.keys[n];
                let Some(p) = key.parent().and_then(|k| tree.find(&k)) else {
                    continue;
                };
                let k = key.slot();
                let mut v = [0.0; BANDS];
                for b in bands.clone() {
                    let mut s = haar.at(0, k) * phi[p as usize][b];
                    for t in 1..CHILDREN {
                        s += haar.at(t, k) * x[tree.id(p, t) as usize][b];
                    }
                    v[b] = s;
                }
                phi[n] = v;
            }
            phi
        })
        .collect()
}

/// Tree coefficients `emit + W a` for bands `bands` (other bands copied from `x`): the
/// gathered per-node `φ` coefficients `a[patch][node]` carried up to the root by the
/// analysis step (bottom-up).
#[must_use]
pub fn pull(
    funcs: &Functions,
    haar: &HaarStep,
    x: &[[f64; BANDS]],
    mut a: Vec<Vec<[f64; BANDS]>>,
    bands: std::ops::Range<usize>,
) -> Vec<[f64; BANDS]> {
    let mut out = x.to_vec();
    for (o, e) in out.iter_mut().zip(&funcs.emit) {
        for b in bands.clone() {
            o[b] = e[b];
        }
    }
    for (tree, a) in funcs.trees.iter().zip(a.iter_mut()) {
        // Children have larger indices than their ancestors: reverse order sees every
        // node after all of its descendants have passed their part up.
        for n in (1..tree.len()).rev() {
            let key = tree.keys[n];
            let Some(p) = key.parent().and_then(|k| tree.find(&k)) else {
                continue;
            };
            let k = key.slot();
            let an = a[n];
            for t in 1..CHILDREN {
                let o = &mut out[tree.id(p, t) as usize];
                for b in bands.clone() {
                    o[b] += haar.at(t, k) * an[b];
                }
            }
            for b in bands.clone() {
                a[p as usize][b] += haar.at(0, k) * an[b];
            }
        }
        let o = &mut out[tree.root_phi as usize];
        for b in bands.clone() {
            o[b] += a[0][b];
        }
    }
    out
}

/// One non-standard product `y = e + W_pull(T · push(x))`.
#[must_use]
pub fn step(
    funcs: &Functions,
    haar: &HaarStep,
    links: &[ScalingLink],
    x: &[[f64; BANDS]],
    bands: std::ops::Range<usize>,
) -> Vec<[f64; BANDS]> {
    let phi = push(funcs, haar, x, bands.clone());
    let mut a: Vec<Vec<[f64; BANDS]>> = funcs
        .trees
        .iter()
        .map(|t| vec![[0.0; BANDS]; t.len()])
        .collect();
    for l in links {
        let s = &phi[l.send_patch as usize][l.send_node as usize];
        let r = &mut a[l.recv_patch as usize][l.recv_node as usize];
        for b in bands.clone() {
            r[b] += f64::from(l.t[b % 3]) * s[b];
        }
    }
    pull(funcs, haar, x, a, bands)
}

/// Picard iteration of [`step`] from the current values until the relative change
/// falls below `tolerance` or `max_iterations` sweeps.
///
/// # Errors
/// [`GlossyError::NonFinite`] if the iteration diverges.
pub fn solve(
    funcs: &mut Functions,
    haar: &HaarStep,
    links: &[ScalingLink],
    bands: std::ops::Range<usize>,
    tolerance: f64,
    max_iterations: usize,
) -> Result<SolveRecord, GlossyError> {
    let mut rec = SolveRecord::default();
    for it in 0..max_iterations {
        let y = step(funcs, haar, links, &funcs.value, bands.clone());
        rec.change = rel_change(&funcs.value, &y, bands.clone());
        funcs.value = y;
        rec.iterations = it + 1;
        check_finite(&rec)?;
        if rec.change <= tolerance {
            rec.converged = true;
            break;
        }
    }
    if funcs.value.iter().any(|v| v.iter().any(|x| !x.is_finite())) {
        return Err(GlossyError::NonFinite {
            what: "solution coefficient",
            value: f64::NAN,
        });
    }
    Ok(rec)
}

/// Whether node `node` of `patch` carries detail: some wavelet of it or of a
/// descendant has a non-zero radiance coefficient (`reach` from
/// [`crate::refine::reach`], radiance part).
fn has_detail(funcs: &Functions, reach: &[[f64; 2]], patch: usize, node: u32) -> bool {
    let tree = &funcs.trees[patch];
    (1..=TYPES).any(|t| reach[tree.id(node, t) as usize][0] > 0.0)
}

/// Which end of a link a refinement splits.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Split {
    /// The receiving node into its 16 children.
    Receiver,
    /// The sending node into its 16 children.
    Sender,
}

/// Oracle value of every link and the end it would split (`None`: at the deepest
/// level on the side to split, or nothing to gain).
#[must_use]
pub fn values(
    funcs: &Functions,
    haar: &HaarStep,
    links: &[ScalingLink],
    max_level: u8,
) -> Vec<(f64, Option<Split>)> {
    let phi = push(funcs, haar, &funcs.value, RADIANCE);
    let reach = crate::refine::reach(funcs);
    links
        .iter()
        .map(|l| {
            let kr = funcs.trees[l.recv_patch as usize].keys[l.recv_node as usize];
            let ks = funcs.trees[l.send_patch as usize].keys[l.send_node as usize];
            let s = magnitude(&phi[l.send_patch as usize][l.send_node as usize], RADIANCE);
            let v = s * f64::from(l.variation) * l1_norm(kr.level) * l1_norm(ks.level);
            let sender_ok = ks.level < max_level
                && has_detail(funcs, &reach, l.send_patch as usize, l.send_node);
            let recv_ok = kr.level < max_level;
            let split = match (recv_ok, sender_ok) {
                (true, true) if ks.level < kr.level => Some(Split::Sender),
                (true, _) => Some(Split::Receiver),
                (false, true) => Some(Split::Sender),
                (false, false) => None,
            };
            (if split.is_some() { v } else { 0.0 }, split)
        })
        .collect()
}

/// The 16 (receiving key, sending key) pairs replacing a link split at `split`.
#[must_use]
pub fn children(kr: NodeKey, ks: NodeKey, split: Split) -> [(NodeKey, NodeKey); CHILDREN] {
    std::array::from_fn(|k| match split {
        Split::Receiver => (kr.child(k), ks),
        Split::Sender => (kr, ks.child(k)),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// A small tree on one patch: root, child 5 and its child 9, child 12.
    fn funcs() -> Functions {
        let mut f = Functions::new(1);
        f.node(0, NodeKey::ROOT.child(5).child(9));
        f.node(0, NodeKey::ROOT.child(12));
        f
    }

    /// `Σ_n a_n φ_n(u)` for per-node coefficients `a` (band 0).
    fn direct(f: &Functions, a: &[f64], u: [f64; 4]) -> f64 {
        f.trees[0]
            .keys
            .iter()
            .zip(a)
            .filter(|(k, _)| k.contains(u))
            .map(|(k, v)| v * 4f64.powi(i32::from(k.level)))
            .sum()
    }

    proptest! {
        /// Pull turns per-node `φ` coefficients into tree coefficients of the same
        /// function (zero emission).
        #[test]
        fn pull_keeps_the_function(
            a in proptest::collection::vec(-1.0f64..1.0, 4),
            u in proptest::array::uniform4(0.0f64..1.0),
        ) {
            let f = funcs();
            let haar = HaarStep::new();
            let mut per = vec![[0.0; BANDS]; 4];
            for (p, v) in per.iter_mut().zip(&a) {
                p[0] = *v;
            }
            let got = pull(&f, &haar, &f.value, vec![per], 0..1);
            let v = f.eval(&haar, 0, u, 0..1, &got)[0];
            let want = direct(&f, &a, u);
            prop_assert!((v - want).abs() < 1e-12, "{v} vs {want}");
        }

        /// Push gives every node's `φ` coefficient `4ʲ ∫_node f du` of the tree's
        /// function (integrated exactly on the level-3 cells it is constant on).
        #[test]
        fn push_projects_on_every_node(vals in proptest::collection::vec(-1.0f64..1.0, 61)) {
            let mut f = funcs();
            let haar = HaarStep::new();
            for (v, x) in f.value.iter_mut().zip(&vals) {
                v[0] = *x;
            }
            let phi = push(&f, &haar, &f.value, 0..1);
            for (n, key) in f.trees[0].keys.iter().enumerate() {
                let m = 1usize << (3 - key.level);
                let lo = key.lo();
                let h = key.size() / m as f64;
                let mut sum = 0.0;
                for i in 0..m.pow(4) {
                    let u: [f64; 4] = std::array::from_fn(|a| lo[a] + h * ((i / m.pow(a as u32)) % m) as f64 + 0.5 * h);
                    sum += f.eval(&haar, 0, u, 0..1, &f.value)[0];
                }
                let want = 4f64.powi(i32::from(key.level)) * sum * 8f64.powi(-4);
                prop_assert!((phi[0][n][0] - want).abs() < 1e-12, "{n}: {} vs {want}", phi[0][n][0]);
            }
        }
    }

    #[test]
    fn push_of_a_constant_is_constant_per_level() {
        // Only the root φ set: every node's φ is 4^{-j} of it (φ_j = 4^j on a cell
        // of volume 16^{-j}).
        let mut f = funcs();
        f.value[f.trees[0].root_phi as usize][1] = 2.0;
        let phi = push(&f, &HaarStep::new(), &f.value, 0..BANDS);
        for (n, key) in f.trees[0].keys.iter().enumerate() {
            let want = 2.0 * 0.25f64.powi(i32::from(key.level));
            assert!((phi[0][n][1] - want).abs() < 1e-14);
            assert_eq!(phi[0][n][0], 0.0);
        }
    }

    #[test]
    fn a_link_fits_in_32_bytes() {
        const { assert!(ScalingLink::BYTES <= 32) };
    }
}
