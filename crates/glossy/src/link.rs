//! Links (Glossy §6.5): one sending basis function to the 15 wavelets of a receiving
//! node, or to a patch's root `φ`, with the kernel variation met while computing them
//! and the scaling-to-scaling coefficient of the two nodes (for the bottom-up rebuild
//! of §5.4). Coefficients are stored as `f32` (the kernel samples behind them carry
//! far more error); a link takes 216 bytes.

use std::collections::{HashMap, HashSet};

use crate::basis::TYPES;

/// A link `sender → receiver`.
#[derive(Debug, Clone, PartialEq)]
pub struct Link {
    /// Global id of the sending function.
    pub sender: u32,
    /// Receiving patch.
    pub recv_patch: u32,
    /// Receiving node (index in the patch's tree; 0 for the root).
    pub recv_node: u32,
    /// Receives into the root `φ` (else into the node's 15 wavelets).
    pub recv_phi: bool,
    /// `T[c][τ − 1]`: transport coefficient from the sender to wavelet `τ` of the
    /// receiving node in colour channel `c` (for a root-`φ` link only `[c][0]`).
    pub coef: [[f32; TYPES]; 3],
    /// `T_{φ_R ← φ_S}` of the receiving and sending nodes, per channel (§5.4).
    pub phiphi: [f32; 3],
    /// Kernel variation (max − min of `A_s·G·V·f_r` over the samples, §5.3).
    pub variation: f32,
    /// Children of the receiving (bit `k` of `[0]`) and sending (`[1]`) node that
    /// received non-zero kernel samples.
    pub masks: [u16; 2],
}

impl Link {
    /// Bytes one link occupies in memory.
    pub const BYTES: usize = std::mem::size_of::<Self>();
}

/// Identity of a link: sending function, receiving patch, node, `φ` flag.
pub type LinkKey = (u32, u32, u32, bool);

/// The set of links, grouped by receiving patch after each [`LinkSet::sort`].
#[derive(Debug, Clone, Default)]
pub struct LinkSet {
    /// The links (sorted by receiving patch, then creation order).
    pub links: Vec<Link>,
    exists: HashSet<LinkKey>,
    /// `T_{φ_R ← φ_S}` per (receiving patch, node, sending patch, node).
    pub phiphi: HashMap<(u32, u32, u32, u32), [f32; 3]>,
    /// `ranges[p]`: the links into patch `p`.
    pub ranges: Vec<std::ops::Range<usize>>,
}

impl LinkSet {
    /// Whether a link with this identity exists.
    #[must_use]
    pub fn contains(&self, key: &LinkKey) -> bool {
        self.exists.contains(key)
    }

    /// Adds a link (the caller checks [`LinkSet::contains`] first); `send` is the
    /// sending (patch, node).
    pub fn push(&mut self, link: Link, send: (u32, u32)) {
        self.exists
            .insert((link.sender, link.recv_patch, link.recv_node, link.recv_phi));
        self.phiphi.insert(
            (link.recv_patch, link.recv_node, send.0, send.1),
            link.phiphi,
        );
        self.links.push(link);
    }

    /// Number of links.
    #[must_use]
    pub fn len(&self) -> usize {
        self.links.len()
    }

    /// Whether there are no links.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.links.is_empty()
    }

    /// Groups links by receiving patch (stable) and rebuilds [`LinkSet::ranges`].
    pub fn sort(&mut self, patches: usize) {
        self.links.sort_by_key(|l| l.recv_patch);
        self.ranges = vec![0..0; patches];
        let mut i = 0;
        for p in 0..patches {
            let start = i;
            while i < self.links.len() && self.links[i].recv_patch as usize == p {
                i += 1;
            }
            self.ranges[p] = start..i;
        }
    }

    /// Memory held by the links and their indices (bytes, approximate).
    #[must_use]
    pub fn bytes(&self) -> usize {
        self.links.capacity() * Link::BYTES
            + self.exists.capacity() * (std::mem::size_of::<LinkKey>() + 8)
            + self.phiphi.capacity() * (16 + 12 + 8)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_link_fits_in_256_bytes() {
        const { assert!(Link::BYTES <= 256) };
        assert_eq!(Link::BYTES, std::mem::size_of::<Link>());
    }
}
