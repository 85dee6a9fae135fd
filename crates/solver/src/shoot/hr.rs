//! HR-Transfer (VirtualMesh Algorithm 1 line 9): one shooter's consistent residual is
//! transferred onto one receiver, refining the *receiver* on the fly, with no links.
//!
//! For a receiver node `R` and a shooter node `E`:
//!
//! 1. if `E` has children and its representation is not accurate enough for `R` —
//!    `ρ_R · F̄(R←E) · δ_E > tol` with `δ_E` the RMS deviation of `E`'s projection from
//!    the finest residual below it and `F̄ = min(1, |E| / (π d²))` an upper bound of the
//!    mean form factor (`d` the gap between bounding spheres) — `E`'s children shoot
//!    instead ("the shooter at the level where its representation is accurate");
//! 2. else, if `R` may still be split, the oracle (in the spirit of Bekaert & Willems
//!    1996 and Cuny et al. 2000: "estimate errors on the radiosity function using
//!    control points on the receiver") computes the transfer onto the `4^d` *control
//!    cells* of `R` at depth `d` (their centres are the control points; each cell's
//!    irradiance coefficients come from [`TransferCtx::block`], so visibility, the
//!    near-field rules and any support weighting are those of the gathering solver),
//!    pulls them to `R` (the element's polynomial representation) and compares: the RMS
//!    radiosity difference `ρ_R ‖H_cells − push(P_R H_cells)‖ / √|R|` is exactly the
//!    size of the wavelet (detail) coefficients the representation at `R` drops (with
//!    Haar one level is not enough: under a centred emitter the four children are
//!    equal, so Haar looks two levels down by default). If it
//!    exceeds `tol`, `R`'s children receive recursively (they exist from then on);
//!    otherwise the pulled irradiance is deposited at `R`;
//! 3. at the deepest level (or below `min_area`) the node's own transfer is deposited
//!    (pulled from the parent's control cells when those were the node itself); so it
//!    is when the whole transfer is below the tolerance, `ρ_R · F̄ · RMS(ΔB_E) ≤ tol`
//!    (one block instead of the control cells' four: most receivers of a weak shot).
//!
//! Receiver cells without real points (virtual supports, VirtualMesh §5.4 "empty
//! meshes") neither receive nor count in the oracle; emitter cells without real points
//! never face anything ([`TransferCtx::facing`]), so they never shoot.
//!
//! Recursion over children runs in parallel (rayon) and collects deposits in a fixed
//! order, so results do not depend on the thread count.

use rayon::prelude::*;

use super::tree::{NONE, Shooter};
use super::twoscale::{TwoScale, pull_into, push_into};
use crate::hierarchy::NodeKey;
use crate::mask::Coverage;
use crate::transfer::{Region, TransferCtx};

/// Refinement parameters of a shot.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Params {
    /// Absolute radiosity tolerance (W/m²).
    pub tol: f64,
    /// Deepest receiver level.
    pub max_level: u8,
    /// Smallest receiver element area.
    pub min_area: f64,
    /// Depth of the control cells below a receiver node (≥ 1).
    pub control_depth: u8,
}

/// Irradiance coefficients (`3 n`, channel-major) to add at a receiver node.
#[derive(Debug, Clone)]
pub(crate) struct Deposit {
    /// Receiver node.
    pub key: NodeKey,
    /// `[ch · n + a]`.
    pub h: Vec<f64>,
}

/// Counters of a transfer.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Counts {
    /// Oracle decisions (receiver and shooter tests).
    pub oracle_evals: u64,
    /// Transfer blocks computed.
    pub blocks: u64,
}

impl Counts {
    pub fn add(&mut self, o: &Self) {
        self.oracle_evals += o.oracle_evals;
        self.blocks += o.blocks;
    }
}

/// One shooter transferring onto one receiver patch.
pub(crate) struct Transfer<'a> {
    pub ctx: &'a TransferCtx<'a>,
    pub ts: &'a TwoScale<'a>,
    pub shooter: &'a Shooter<'a>,
    pub p: Params,
}

impl Transfer<'_> {
    /// HR-Transfer onto `receiver` from the shooter's root.
    pub fn run(&self, receiver: usize) -> (Vec<Deposit>, Counts) {
        let mut out = Vec::new();
        let mut cnt = Counts::default();
        self.go(NodeKey::root(receiver), 0, None, &mut out, &mut cnt);
        (out, cnt)
    }

    fn n(&self) -> usize {
        self.ts.n()
    }

    fn can_split(&self, r: &NodeKey) -> bool {
        r.level < self.p.max_level && 0.25 * self.ts.area(r) >= self.p.min_area
    }

    /// Upper bound of the mean form factor from `r` to `e`.
    fn ff_bound(&self, r: &Region, e: &Region) -> f64 {
        let pr = &self.ctx.patches[r.patch];
        let pe = &self.ctx.patches[e.patch];
        let (cr, rr) = pr.support.bounding_sphere(r.s0, r.t0, r.h);
        let (ce, re) = pe.support.bounding_sphere(e.s0, e.t0, e.h);
        let d = (cr - ce).length() - rr - re;
        let ae = pe.support.area * e.h * e.h;
        if d <= 0.0 {
            1.0
        } else {
            (ae / (std::f64::consts::PI * d * d)).min(1.0)
        }
    }

    /// Irradiance coefficients on `r` from shooter node `e`.
    fn irradiance(&self, r: &Region, e: usize) -> Vec<f64> {
        let n = self.n();
        let er = self.shooter.tree.keys[e].region();
        let t = self.ctx.block(r, &er);
        let src = &self.shooter.db[e * 3 * n..][..3 * n];
        let mut hv = vec![0.0; 3 * n];
        for ch in 0..3 {
            for a in 0..n {
                hv[ch * n + a] = (0..n).map(|b| t[a * n + b] * src[ch * n + b]).sum();
            }
        }
        hv
    }

    fn go(
        &self,
        r: NodeKey,
        e: usize,
        known: Option<Vec<f64>>,
        out: &mut Vec<Deposit>,
        cnt: &mut Counts,
    ) {
        let n = self.n();
        let tree = self.shooter.tree;
        let ek = tree.keys[e];
        let (rr, er) = (r.region(), ek.region());
        let src = &self.shooter.db[e * 3 * n..][..3 * n];
        if self.shooter.delta[e] == 0.0 && src.iter().all(|&v| v == 0.0) {
            return;
        }
        let rsup = &self.ctx.patches[r.patch as usize].support;
        // Cells without real points never receive (VirtualMesh §5.4: empty meshes).
        if rsup.mask.is_some() && rsup.coverage(rr.s0, rr.t0, rr.h) == Coverage::Empty {
            return;
        }
        if !self.ctx.facing(&rr, &er) {
            return;
        }
        let rho = self.ctx.patches[r.patch as usize].reflectance;
        let rho_max = rho.iter().fold(0.0f64, |a, &b| a.max(b));
        // 1. Shooter accuracy.
        let fc = tree.first_child[e];
        if fc != NONE && self.shooter.delta[e] > 0.0 {
            cnt.oracle_evals += 1;
            if rho_max * self.ff_bound(&rr, &er) * self.shooter.delta[e] > self.p.tol {
                let parts: Vec<(Vec<Deposit>, Counts)> = (0..4)
                    .into_par_iter()
                    .map(|c| {
                        let mut v = Vec::new();
                        let mut k = Counts::default();
                        self.go(r, fc as usize + c, None, &mut v, &mut k);
                        (v, k)
                    })
                    .collect();
                for (v, k) in parts {
                    out.extend(v);
                    cnt.add(&k);
                }
                return;
            }
        }
        // 3. Deepest level, or a transfer below the tolerance altogether (its detail
        // cannot exceed it: `ρ F̄ · RMS(ΔB_E) ≤ tol`): the node's own transfer.
        let weak = || {
            let area_e = self.ts.area(&ek);
            let rms = (0..3).fold(0.0f64, |a, ch| {
                let e2: f64 = src[ch * n..][..n].iter().map(|v| v * v).sum();
                a.max(rho[ch] * (e2 / area_e).sqrt())
            });
            rms * self.ff_bound(&rr, &er) <= self.p.tol
        };
        if !self.can_split(&r) || (known.is_none() && weak()) {
            let hv = known.unwrap_or_else(|| {
                cnt.blocks += 1;
                self.irradiance(&rr, e)
            });
            out.push(Deposit { key: r, h: hv });
            return;
        }
        // 2. Control cells at depth d, pulled level by level to r.
        let d = self.p.control_depth as u32;
        let side = 1u32 << d;
        let cells: Vec<NodeKey> = (0..side * side)
            .map(|i| NodeKey {
                level: r.level + d as u8,
                patch: r.patch,
                iy: (r.iy << d) + i / side,
                ix: (r.ix << d) + i % side,
            })
            .collect();
        let fine: Vec<Vec<f64>> = cells
            .par_iter()
            .map(|c| self.irradiance(&c.region(), e))
            .collect();
        cnt.blocks += fine.len() as u64;
        // levels[l]: 4^l nodes at depth l below r, row-major in (local iy, ix).
        let mut levels: Vec<Vec<Vec<f64>>> = vec![Vec::new(); d as usize + 1];
        levels[d as usize] = fine;
        for l in (0..d).rev() {
            let s = 1u32 << l;
            let mut cur = Vec::with_capacity((s * s) as usize);
            for i in 0..s * s {
                let (x, y) = (i % s, i / s);
                let key = NodeKey {
                    level: r.level + l as u8,
                    patch: r.patch,
                    iy: (r.iy << l) + y,
                    ix: (r.ix << l) + x,
                };
                let m = self.ts.mats(&key);
                let below = &levels[l as usize + 1];
                let mut v = vec![0.0; 3 * n];
                for ch in 0..3 {
                    let kids: [&[f64]; 4] = std::array::from_fn(|c| {
                        let (cx, cy) = (2 * x + (c as u32 % 2), 2 * y + (c as u32 / 2));
                        &below[(cy * 2 * s + cx) as usize][ch * n..][..n]
                    });
                    pull_into(&m, n, kids, &mut v[ch * n..][..n]);
                }
                cur.push(v);
            }
            levels[l as usize] = cur;
        }
        // Push r's representation back down and measure the difference.
        let mut pushed = vec![levels[0][0].clone()];
        for l in 0..d {
            let s = 1u32 << l;
            let mut next = vec![vec![0.0; 3 * n]; (4 * s * s) as usize];
            for i in 0..s * s {
                let (x, y) = (i % s, i / s);
                let key = NodeKey {
                    level: r.level + l as u8,
                    patch: r.patch,
                    iy: (r.iy << l) + y,
                    ix: (r.ix << l) + x,
                };
                let m = self.ts.mats(&key);
                for c in 0..4u32 {
                    let (cx, cy) = (2 * x + c % 2, 2 * y + c / 2);
                    let dst = &mut next[(cy * 2 * s + cx) as usize];
                    for ch in 0..3 {
                        push_into(
                            &m,
                            n,
                            c as usize,
                            &pushed[i as usize][ch * n..][..n],
                            &mut dst[ch * n..][..n],
                        );
                    }
                }
            }
            pushed = next;
        }
        let mut err2 = [0.0f64; 3];
        for ((p, f), c) in pushed.iter().zip(&levels[d as usize]).zip(&cells) {
            // Only cells with real points matter.
            let cr = c.region();
            if rsup.mask.is_some() && rsup.coverage(cr.s0, cr.t0, cr.h) == Coverage::Empty {
                continue;
            }
            for ch in 0..3 {
                err2[ch] += (0..n)
                    .map(|a| (p[ch * n + a] - f[ch * n + a]).powi(2))
                    .sum::<f64>();
            }
        }
        let inv = 1.0 / self.ts.area(&r).sqrt();
        let err = (0..3).fold(0.0f64, |a, ch| a.max(rho[ch] * err2[ch].sqrt() * inv));
        cnt.oracle_evals += 1;
        if err <= self.p.tol {
            let hv = levels[0].swap_remove(0);
            out.push(Deposit { key: r, h: hv });
            return;
        }
        let kids = std::mem::take(&mut levels[1]);
        let parts: Vec<(Vec<Deposit>, Counts)> = kids
            .into_par_iter()
            .enumerate()
            .map(|(c, hv)| {
                let mut v = Vec::new();
                let mut k = Counts::default();
                self.go(r.child(c), e, Some(hv), &mut v, &mut k);
                (v, k)
            })
            .collect();
        for (v, k) in parts {
            out.extend(v);
            cnt.add(&k);
        }
    }
}
