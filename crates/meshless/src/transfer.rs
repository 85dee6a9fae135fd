//! The single-bounce operator `T` by receiver-centric hierarchical refinement
//! (Meshless §3.2, eqs. (16)–(17), Fig. 5, Appendix A).
//!
//! For a receiver `B_i` at `(x_i, n_i)`, eq. (16) gathers the links from *all* senders
//! at once with `N_g` rays over the hemisphere (stratified on `wavelux-param`'s
//! equal-area `ConcentricHemisphere`, seeded per receiver):
//! `T'_ij = ∫_Ω B_j(y(ω)) ρ(y)/π ω̄ dω ≈ (2π/N_g) Σ_rays B_j(y) ρ(y)/π ω̄`
//! (the seed omits the `1/π` of a Lambertian reflector; with it, `T'·e` is the vector
//! irradiance at `x_i` when the senders carry scalar irradiance `e`). Rays that escape
//! or reach the black back of a one-sided surface contribute nothing. Eq. (17)
//! subtracts the *kept* links of every ancestor receiver:
//! `T_ij = T'_ij − Σ_{k ∈ all-parents(i)} T_kj B_k(x_i)`, where a dropped link counts 0
//! (ours: so a child corrects its parents' truncation).
//!
//! Fig. 5: receivers are processed level by level from a queue seeded with level 0; a
//! link to a level-0 sender is kept when `‖T_ij‖ > ε`, a link to a finer sender when
//! also `max_{k ∈ neighbours(j)} ‖T_ij − T_ik‖ > ε` (a sender without neighbours keeps
//! the magnitude test alone, ours); a receiver that keeps any link queues its children.
//! With [`crate::LinkThreshold::SenderArea`] (ours) both tests of a
//! level-`l` sender use `ε/4^l`, the threshold scaled with the sender's support area.
//! With [`MeshlessConfig::max_dropped_share`] `= Some(δ)` (ours; the default
//! δ = [`crate::config::DEFAULT_MAX_DROPPED_SHARE`] = 0.05) a level-0 receiver
//! whose dropped links sum to more than `δ·Σ_j ‖T'_ij‖` keeps back the largest of them
//! until the dropped rest is within that bound; finer receivers then refine the kept
//! links by eq. (17) under the seed's criteria.
//! Receivers of one level are independent and run in parallel; their rows are written
//! in receiver order, so `T` does not depend on the thread count.

use std::time::Instant;

use glam::DVec2;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::MeshlessError;
use crate::basis::Basis;
use crate::config::MeshlessConfig;
use crate::matrix::{Link, TransferMatrix, link_diff_norm, link_norm};
use crate::query::SurfaceQuery;
use crate::sample::{hemisphere, rng_for, stratified, tangents};

/// Stream tag of the gather rays.
const TAG_GATHER: u64 = 4;

/// Statistics of one receiver level of the refinement.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct RefineLevelStats {
    /// Receiver functions on the level.
    pub functions: usize,
    /// Receivers processed (queued).
    pub processed: usize,
    /// Receivers that kept at least one link.
    pub refined: usize,
    /// Links computed (non-zero `T_ij` before the criteria).
    pub computed: usize,
    /// Links kept.
    pub kept: usize,
}

/// Statistics of the refinement.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct RefineStats {
    /// Per receiver level.
    pub levels: Vec<RefineLevelStats>,
    /// Gather rays cast.
    pub rays: u64,
    /// Wall time (ms).
    pub ms: f64,
}

/// Scratch of one worker: a dense accumulator over senders.
pub(crate) struct Scratch {
    acc: Vec<Link>,
    touched: Vec<u32>,
    mark: Vec<bool>,
    basis: Vec<(u32, f64)>,
    anc: Vec<(u32, f64)>,
    uv: Vec<DVec2>,
}

impl Scratch {
    pub(crate) fn new(senders: usize) -> Self {
        Self {
            acc: vec![[0.0; 9]; senders],
            touched: Vec::new(),
            mark: vec![false; senders],
            basis: Vec::new(),
            anc: Vec::new(),
            uv: Vec::new(),
        }
    }

    #[inline]
    fn add(&mut self, j: u32, f: f64, v: &Link) {
        let ju = j as usize;
        if !self.mark[ju] {
            self.mark[ju] = true;
            self.touched.push(j);
        }
        let a = &mut self.acc[ju];
        for k in 0..9 {
            a[k] += f * v[k];
        }
    }

    fn clear(&mut self) {
        for &j in &self.touched {
            self.acc[j as usize] = [0.0; 9];
            self.mark[j as usize] = false;
        }
        self.touched.clear();
    }
}

/// The links being built: kept rows so far, indexed by receiver.
pub(crate) struct Rows {
    pub(crate) row: Vec<Option<(usize, usize)>>,
    pub(crate) col: Vec<u32>,
    pub(crate) val: Vec<Link>,
}

impl Rows {
    fn get(&self, i: usize) -> (&[u32], &[Link]) {
        match self.row[i] {
            Some((a, b)) => (&self.col[a..b], &self.val[a..b]),
            None => (&[], &[]),
        }
    }
}

/// Eq. (16) for receiver `i` into the scratch (not cleared first): the gathered
/// `T'_i·`; returns the rays cast.
pub(crate) fn gather<Q: SurfaceQuery + ?Sized>(
    query: &Q,
    basis: &Basis,
    config: &MeshlessConfig,
    i: usize,
    s: &mut Scratch,
) -> u64 {
    let (x, n) = (basis.position(i), basis.normal(i));
    let mut rng = rng_for(config.seed, TAG_GATHER, i as u64);
    let mut uv = std::mem::take(&mut s.uv);
    stratified(config.gather_rays, &mut rng, &mut uv);
    let (t, b) = tangents(n);
    let origin = x + n * query.offset();
    // (2π/N_g)·(1/π): solid angle per ray and the Lambertian 1/π.
    let w = 2.0 / config.gather_rays as f64;
    for p in &uv {
        let d = hemisphere(n, t, b, *p);
        let Some(hit) = query.closest_hit(origin, d) else {
            continue;
        };
        let Some(rho) = hit.reflectance else {
            continue;
        };
        if rho == [0.0; 3] {
            continue;
        }
        let v: Link = [
            rho[0] * d.x,
            rho[0] * d.y,
            rho[0] * d.z,
            rho[1] * d.x,
            rho[1] * d.y,
            rho[1] * d.z,
            rho[2] * d.x,
            rho[2] * d.y,
            rho[2] * d.z,
        ];
        let mut bs = std::mem::take(&mut s.basis);
        for l in 0..config.sender_levels {
            basis.basis_at(l, hit.point, hit.normal, &mut bs);
            for &(j, bj) in &bs {
                s.add(j, w * bj, &v);
            }
        }
        s.basis = bs;
    }
    s.uv = uv;
    config.gather_rays as u64
}

/// Eq. (17): subtracts the kept links of every ancestor of `i`, weighted by
/// `B_k(x_i)`.
fn subtract_parents(basis: &Basis, rows: &Rows, i: usize, s: &mut Scratch) {
    let mut anc = std::mem::take(&mut s.anc);
    basis.ancestors(i, &mut anc);
    for &(k, bk) in &anc {
        let (c, v) = rows.get(k as usize);
        for (j, l) in c.iter().zip(v) {
            s.add(*j, -bk, l);
        }
    }
    s.anc = anc;
}

/// The mass `M_i = Σ_j ‖T'_ij‖` of the gathered row in the scratch.
fn row_mass(s: &Scratch) -> f64 {
    s.touched
        .iter()
        .map(|&j| link_norm(&s.acc[j as usize]))
        .sum()
}

/// Applies the Fig. 5 criteria to the scratch row with the threshold `eps[l]` of a
/// level-`l` sender, then, with `bound = Some(share · M_i)`, keeps back the largest
/// dropped links until the dropped rest sums to at most the bound
/// ([`MeshlessConfig::max_dropped_share`]); returns the kept links (sorted) and the
/// number computed.
fn select(
    basis: &Basis,
    eps: &[f64],
    bound: Option<f64>,
    s: &mut Scratch,
) -> (Vec<(u32, Link)>, usize) {
    s.touched.sort_unstable();
    let mut kept = Vec::new();
    let mut dropped = Vec::new();
    let mut dropped_mass = 0.0;
    let mut computed = 0;
    for &j in &s.touched {
        let t = &s.acc[j as usize];
        let norm = link_norm(t);
        if norm > 0.0 {
            computed += 1;
        }
        let level = basis.level_of(j as usize);
        let epsilon = eps[level];
        let keep = norm > epsilon
            && (level == 0 || {
                let nb = basis.neighbours(j as usize);
                nb.is_empty()
                    || nb
                        .iter()
                        .any(|&k| link_diff_norm(t, &s.acc[k as usize]) > epsilon)
            });
        if keep {
            kept.push((j, *t));
        } else if bound.is_some() && norm > 0.0 {
            dropped.push((norm, j));
            dropped_mass += norm;
        }
    }
    if let Some(bound) = bound
        && dropped_mass > bound
    {
        // Largest first; equal norms in sender order (deterministic).
        dropped.sort_unstable_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        for (norm, j) in dropped {
            if dropped_mass <= bound {
                break;
            }
            dropped_mass -= norm;
            kept.push((j, s.acc[j as usize]));
        }
        kept.sort_unstable_by_key(|k| k.0);
    }
    (kept, computed)
}

/// One processed receiver: index, kept links, links computed, rays.
type ReceiverResult = (usize, Vec<(u32, Link)>, usize, u64);

/// Refines `T` (module docs). `progress(level, processed)` is called after each level.
///
/// # Errors
/// [`MeshlessError::Budget`] when the links exceed `config.max_links`.
pub fn refine<Q: SurfaceQuery + ?Sized>(
    query: &Q,
    basis: &Basis,
    config: &MeshlessConfig,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<(TransferMatrix, RefineStats), MeshlessError> {
    config.validate()?;
    let start = Instant::now();
    let senders = basis.level_start(config.sender_levels.min(basis.levels()));
    let receivers = basis.len();
    let levels = basis.levels();
    let mut rows = Rows {
        row: vec![None; receivers],
        col: Vec::new(),
        val: Vec::new(),
    };
    let mut stats = RefineStats::default();
    let eps = config.level_thresholds(false);
    let mut queue: Vec<usize> = basis.level_range(0).collect();
    for l in 0..levels {
        let mut ls = RefineLevelStats {
            functions: basis.level_range(l).len(),
            processed: queue.len(),
            ..Default::default()
        };
        let results: Vec<ReceiverResult> = queue
            .par_iter()
            .map_init(
                || Scratch::new(senders),
                |s, &i| {
                    let rays = gather(query, basis, config, i, s);
                    // A share of 1 may drop the whole row: the seed's criteria alone.
                    let bound = config
                        .max_dropped_share
                        .filter(|&d| l == 0 && d < 1.0)
                        .map(|d| d * row_mass(s));
                    subtract_parents(basis, &rows, i, s);
                    let (kept, computed) = select(basis, &eps, bound, s);
                    s.clear();
                    (i, kept, computed, rays)
                },
            )
            .collect();
        let mut next = Vec::new();
        for (i, kept, computed, rays) in results {
            stats.rays += rays;
            ls.computed += computed;
            if kept.is_empty() {
                continue;
            }
            ls.refined += 1;
            ls.kept += kept.len();
            let a = rows.col.len();
            if a + kept.len() > config.max_links {
                return Err(MeshlessError::Budget {
                    what: "links",
                    limit: config.max_links,
                });
            }
            for (j, v) in kept {
                rows.col.push(j);
                rows.val.push(v);
            }
            rows.row[i] = Some((a, rows.col.len()));
            if l + 1 < levels {
                next.extend(basis.children(i).iter().map(|c| c.0 as usize));
            }
        }
        next.sort_unstable();
        next.dedup();
        progress(l, ls.processed);
        stats.levels.push(ls);
        queue = next;
    }
    let list = (0..receivers)
        .filter_map(|i| {
            let (c, v) = rows.get(i);
            (!c.is_empty()).then(|| (i, c.iter().copied().zip(v.iter().copied()).collect()))
        })
        .collect();
    stats.ms = start.elapsed().as_secs_f64() * 1e3;
    Ok((TransferMatrix::from_rows(receivers, senders, list), stats))
}

/// The gathered row `T'_i·` of eq. (16) alone (no subtraction, no criteria), sorted by
/// sender: the reference of the eq. (17) test.
pub fn gathered_row<Q: SurfaceQuery + ?Sized>(
    query: &Q,
    basis: &Basis,
    config: &MeshlessConfig,
    i: usize,
) -> Vec<(u32, Link)> {
    let senders = basis.level_start(config.sender_levels.min(basis.levels()));
    let mut s = Scratch::new(senders);
    gather(query, basis, config, i, &mut s);
    s.touched.sort_unstable();
    s.touched.iter().map(|&j| (j, s.acc[j as usize])).collect()
}
