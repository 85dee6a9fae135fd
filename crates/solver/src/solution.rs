//! The result of a solve: radiosity at `(patch, s, t)`, area averages per patch and
//! surface, energy accounting and statistics.

use std::sync::Arc;
use std::time::Duration;

use wavelux_linear::Convergence;

use crate::basis::TreeBasis;
use crate::cdv::CdvField;
use crate::escape::{self, Escape};
use crate::hierarchy::NodeKey;
use crate::support::{Patch, Side};
use crate::system::System;

/// Energy accounting (W, per RGB channel).
///
/// `escaped` is measured by rays from the geometry ([`crate::escape`]), not derived
/// from the other terms, so [`Energy::imbalance`] = `emitted − absorbed − unshot −
/// escaped` is a real check: it equals `operator_loss − escaped`, the transfer
/// operator's row-sum error against the geometry, plus the estimate's noise
/// (`escaped_std_error`).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Energy {
    /// Emitted power `Σ E·A` over real areas.
    pub emitted: [f64; 3],
    /// Absorbed power `Σ (1 − ρ) ∫H dA` over the real parts of all receiving sides.
    pub absorbed: [f64; 3],
    /// Power that leaves the modelled sides without arriving at a receiving side (open
    /// scenes, back sides of one-sided surfaces, black sides), measured by rays from
    /// the propagated radiosity ([`crate::escape`]; `B` for gathering, `B − ΔB̃` for
    /// shooting).
    pub escaped: [f64; 3],
    /// Standard error of `escaped` (the ray estimate's noise).
    pub escaped_std_error: [f64; 3],
    /// Rays cast to measure `escaped`.
    pub escape_rays: u64,
    /// The solver's own count of the power its discrete operator delivers to no
    /// receiver: `Σ∫B − Σ∫H` for gathering, `Σ_shots (P − ∫H)` for shooting. Equals
    /// `escaped` up to the transfer blocks' error (form factors, visibility,
    /// quadrature).
    pub operator_loss: [f64; 3],
    /// Power not yet propagated by the iteration: `Σ ∫ (E + ρH − B)` (gathering: the
    /// linear residual; shooting: the unshot residuals `∫ΔB̃`).
    pub unshot: [f64; 3],
}

impl Energy {
    /// `emitted − absorbed − unshot − escaped` per channel: zero for an exact operator
    /// and an exact escape measurement; in practice the operator's row-sum error
    /// (`operator_loss − escaped`) plus the noise of `escaped`.
    pub fn imbalance(&self) -> [f64; 3] {
        std::array::from_fn(|c| {
            self.emitted[c] - self.absorbed[c] - self.unshot[c] - self.escaped[c]
        })
    }
}

/// Statistics of a solve.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Statistics {
    /// Quadtree nodes (elements) over all patches.
    pub elements: usize,
    /// Leaves (unknown blocks).
    pub leaves: usize,
    /// Links (transfer blocks) stored.
    pub links: usize,
    /// Closure links (one per leaf whose row sum was corrected, see [`crate::closure`]);
    /// not counted in `links`.
    pub closure_links: usize,
    /// Cluster links (groups of surfaces linked as one, see [`crate::cluster`]); not
    /// counted in `links`.
    pub cluster_links: usize,
    /// Links split during refinement.
    pub refined_links: u64,
    /// Ziegler's count (§3.3.3): cell pairs whose 15 wavelet form factors (16 on
    /// level 0) were computed, i.e. refined links plus unrefined root links.
    pub nonstandard_links: u64,
    /// Oracle evaluations.
    pub oracle_evals: u64,
    /// Kernel evaluations (quadrature and oracle samples).
    pub kernel_evals: u64,
    /// Shadow rays.
    pub rays: u64,
    /// Shadow rays of the transfer blocks decided on an occlusion device
    /// ([`crate::solve_on`]; 0 on the CPU).
    pub device_rays: u64,
    /// Shadow rays of the device's batches answered on the CPU (its unsure answers,
    /// rays the replay had not recorded, the batch of a device error).
    pub deferred_rays: u64,
    /// The occlusion device's first error (the rest of the run used the CPU).
    pub device_failure: Option<String>,
    /// Bytes held by the hierarchy, links and solution vectors (capacity estimate).
    pub bytes: usize,
    /// Wall time of supports, accelerator and rule setup.
    pub time_setup: Duration,
    /// Wall time of refinement and link computation.
    pub time_refine: Duration,
    /// Wall time of the linear solves.
    pub time_solve: Duration,
    /// Iterations per channel solve.
    pub iterations: Vec<usize>,
    /// Refine–solve stages (1 without the multigrid-like loop).
    pub stages: usize,
    /// Leaves with no real point (virtual supports, VirtualMesh §5.4).
    pub cells_empty: usize,
    /// Leaves crossed by a trim boundary.
    pub cells_partial: usize,
    /// Leaves whose points are all real (every leaf of an unmasked support).
    pub cells_full: usize,
    /// Shots of the linkless shooting solver ([`crate::shoot`]; 0 for gathering).
    pub shots: usize,
    /// Input primitives (support pieces: a surface, a mesh element, a rectangle of a
    /// decomposed polygon; both sides of a two-sided piece count once) that shot at
    /// least once — VirtualMesh Table 1's "# shooting surfaces", whose unit is the
    /// input primitive. 0 for gathering.
    pub shooting_surfaces: usize,
    /// Convergence rate `(E_i − E_r)/E_i` after each shot (VirtualMesh §6: `E_i` the
    /// initial emitted power, `E_r` the power left to propagate; RGB summed). Empty for
    /// gathering.
    pub shot_convergence: Vec<f64>,
}

/// A radiosity solution.
///
/// For the CDV basis (not tree structured, see [`crate::cdv`]) `system`, `node_b` and
/// `leaf_h` hold a documented conversion: a complete Haar quadtree whose leaves are the
/// exact cell averages of the CDV expansion on its finest level, with no links;
/// [`Solution::radiosity`] evaluates the CDV expansion itself ([`Solution::cdv_field`]).
#[derive(Debug, Clone)]
pub struct Solution {
    /// Patches (supports with materials) the solution lives on.
    pub patches: Vec<Patch>,
    /// Patch indices per scene surface.
    pub by_surface: Vec<Vec<usize>>,
    /// The system (hierarchy and links) that was solved.
    pub(crate) system: System,
    basis: TreeBasis,
    /// Radiosity coefficients at every node (pulled), per channel.
    pub node_b: [Vec<f64>; 3],
    /// Irradiance coefficients at every leaf, per channel.
    pub leaf_h: [Vec<f64>; 3],
    /// Energy accounting.
    pub energy: Energy,
    /// Statistics.
    pub stats: Statistics,
    /// Convergence records of the (last stage's) channel solves.
    pub convergence: Vec<Convergence>,
    cdv: Option<Arc<CdvField>>,
}

impl Solution {
    /// The system (hierarchy and links) that was solved (read-only).
    pub fn system(&self) -> &System {
        &self.system
    }

    /// Assembles a solution from leaf radiosity coefficients per channel.
    pub fn new(
        patches: Vec<Patch>,
        by_surface: Vec<Vec<usize>>,
        system: System,
        basis: TreeBasis,
        leaf_b: [Vec<f64>; 3],
        stats: Statistics,
        convergence: Vec<Convergence>,
    ) -> Self {
        let n = system.h.n;
        let nn = system.h.node_count() * n;
        let mut node_b: [Vec<f64>; 3] = std::array::from_fn(|_| vec![0.0; nn]);
        let mut leaf_h: [Vec<f64>; 3] = std::array::from_fn(|_| Vec::new());
        let mut energy = Energy::default();
        for ch in 0..3 {
            system.pull_from_leaves(&leaf_b[ch], &mut node_b[ch]);
            leaf_h[ch] = system.irradiance(&leaf_b[ch]);
            if let Some(extra) = system.closure_irradiance(ch) {
                leaf_h[ch].iter_mut().zip(extra).for_each(|(h, e)| *h += e);
            }
            let mut sum_b = 0.0;
            let mut sum_h = 0.0;
            let mut abs = 0.0;
            let mut unshot = 0.0;
            for (l, &i) in system.h.leaves.iter().enumerate() {
                let p = system.h.keys[i as usize].patch as usize;
                let rho = system.leaf_rho[l][ch];
                let e = system.patch_emission[p][ch];
                let mut ib = 0.0;
                let mut ih = 0.0;
                // Only real points emit, absorb and receive (VirtualMesh §4.2).
                let mom = &system.leaf_real_moments[l * n..][..n];
                for a in 0..n {
                    ib += leaf_b[ch][l * n + a] * mom[a];
                    ih += leaf_h[ch][l * n + a] * mom[a];
                }
                let area = system.leaf_real_area[l];
                sum_b += ib;
                sum_h += ih;
                abs += (1.0 - rho) * ih;
                unshot += e * area + rho * ih - ib;
                energy.emitted[ch] += e * area;
            }
            energy.absorbed[ch] = abs;
            energy.operator_loss[ch] = sum_b - sum_h;
            energy.unshot[ch] = unshot;
        }
        Self::from_parts(
            patches,
            by_surface,
            system,
            basis,
            node_b,
            leaf_h,
            energy,
            stats,
            convergence,
        )
    }

    /// Assembles a solution whose node radiosity coefficients (every node, pulled),
    /// leaf irradiance and energy were computed by the caller: the linkless shooting
    /// solver ([`crate::shoot`]) passes a `system` with zero links, so neither
    /// irradiance nor energy can be recomputed from it. Adds the vectors' bytes to
    /// `stats.bytes`.
    #[allow(clippy::too_many_arguments)]
    pub fn from_parts(
        patches: Vec<Patch>,
        by_surface: Vec<Vec<usize>>,
        system: System,
        basis: TreeBasis,
        node_b: [Vec<f64>; 3],
        leaf_h: [Vec<f64>; 3],
        energy: Energy,
        stats: Statistics,
        convergence: Vec<Convergence>,
    ) -> Self {
        let mut stats = stats;
        stats.bytes += (node_b.iter().map(|v| v.capacity()).sum::<usize>()
            + leaf_h.iter().map(|v| v.capacity()).sum::<usize>())
            * 8;
        Self {
            patches,
            by_surface,
            system,
            basis,
            node_b,
            leaf_h,
            energy,
            stats,
            convergence,
            cdv: None,
        }
    }

    /// A CDV solution from its parts (see the type docs and [`crate::cdv`]).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn from_cdv(
        patches: Vec<Patch>,
        by_surface: Vec<Vec<usize>>,
        system: System,
        basis: TreeBasis,
        node_b: [Vec<f64>; 3],
        leaf_h: [Vec<f64>; 3],
        energy: Energy,
        stats: Statistics,
        convergence: Vec<Convergence>,
        field: Arc<CdvField>,
    ) -> Self {
        Self {
            patches,
            by_surface,
            system,
            basis,
            node_b,
            leaf_h,
            energy,
            stats,
            convergence,
            cdv: Some(field),
        }
    }

    /// The CDV expansion, for solutions computed with [`crate::BasisKind::Cdv`].
    pub fn cdv_field(&self) -> Option<&CdvField> {
        self.cdv.as_deref()
    }

    /// The tree basis of `system` (Haar for CDV solutions, see the type docs).
    pub fn basis(&self) -> &TreeBasis {
        &self.basis
    }

    /// Radiosity (W/m², RGB) at parameter point `(s, t) ∈ [0,1]²` of a patch.
    ///
    /// # Panics
    /// If `patch` is out of range.
    pub fn radiosity(&self, patch: usize, s: f64, t: f64) -> [f64; 3] {
        if let Some(f) = &self.cdv {
            return f.radiosity(patch, s, t);
        }
        eval_nodes(&self.system, &self.basis, &self.node_b, patch, s, t)
    }

    /// Measures the escaped power by rays with this solution's radiosity as the
    /// propagated radiosity (gathering; see [`crate::escape`]), setting
    /// `energy.escaped`, `escaped_std_error` and `escape_rays`.
    pub fn measure_escape(&mut self, prep: &crate::Prepared) {
        let e = escape::measure(prep, &self.system.h, &|p, s, t| self.radiosity(p, s, t));
        self.set_escape(e);
    }

    /// Records a ray measurement of the escaped power.
    pub(crate) fn set_escape(&mut self, e: Escape) {
        self.energy.escaped = e.power;
        self.energy.escaped_std_error = e.std_error;
        self.energy.escape_rays = e.rays;
    }

    /// Average radiosity over a node's cell, if the node exists.
    pub fn node_average(&self, key: &NodeKey) -> Option<[f64; 3]> {
        let h = &self.system.h;
        let i = h.keys.binary_search(key).ok()?;
        Some(self.average_of(i))
    }

    fn average_of(&self, i: usize) -> [f64; 3] {
        let n = self.system.h.n;
        let ints = self.system.integrals();
        let inv = 1.0 / self.system.node_area[i].sqrt();
        std::array::from_fn(|ch| {
            (0..n)
                .map(|a| self.node_b[ch][i * n + a] * ints[a])
                .sum::<f64>()
                * inv
        })
    }

    /// Area-average radiosity of a patch over its whole support (parameter measure;
    /// real and virtual points of a virtual support alike).
    ///
    /// # Panics
    /// If `patch` is out of range.
    pub fn patch_average(&self, patch: usize) -> [f64; 3] {
        self.average_of(self.system.h.roots[patch] as usize)
    }

    /// `(∫_real B dA, real area)` of a patch (VirtualMesh §4: only real points count;
    /// `O(leaves)`).
    ///
    /// # Panics
    /// If `patch` is out of range.
    pub fn patch_real_integral(&self, patch: usize) -> ([f64; 3], f64) {
        let h = &self.system.h;
        let n = h.n;
        let mut acc = [0.0; 3];
        let mut area = 0.0;
        for (l, &i) in h.leaves.iter().enumerate() {
            if h.keys[i as usize].patch as usize != patch {
                continue;
            }
            let m = &self.system.leaf_real_moments[l * n..][..n];
            for (c, a) in acc.iter_mut().enumerate() {
                *a += (0..n)
                    .map(|k| self.node_b[c][i as usize * n + k] * m[k])
                    .sum::<f64>();
            }
            area += self.system.leaf_real_area[l];
        }
        (acc, area)
    }

    /// Average radiosity of a scene surface's front side over its real area (all its
    /// pieces; for unmasked equal-area supports the plain area average).
    ///
    /// # Panics
    /// If `surface` is out of range.
    pub fn surface_average(&self, surface: usize) -> [f64; 3] {
        self.side_average(surface, false)
    }

    /// [`Solution::surface_average`] of the front (`back = false`) or the back side
    /// (NaN for the back of a one-sided surface, which has no patches).
    ///
    /// # Panics
    /// If `surface` is out of range.
    pub fn side_average(&self, surface: usize, back: bool) -> [f64; 3] {
        let want = if back { Side::Back } else { Side::Front };
        let mut acc = [0.0; 3];
        let mut area = 0.0;
        for &p in &self.by_surface[surface] {
            if self.patches[p].side != want {
                continue;
            }
            let sup = &self.patches[p].support;
            let (v, a) = if sup.mask.is_none() && sup.is_equal_area() {
                let a = sup.area;
                (self.patch_average(p).map(|x| x * a), a)
            } else {
                self.patch_real_integral(p)
            };
            for c in 0..3 {
                acc[c] += v[c];
            }
            area += a;
        }
        acc.map(|v| v / area)
    }

    /// Average radiosity (W/m², RGB) of a scene surface over the real area of every
    /// patch that reflects or emits, whichever side it is on (the lit inside of a
    /// closed curved surface is its back side): `Σ ∫_real B dA / Σ |real area|` from
    /// [`Solution::patch_real_integral`]. NaN if no patch of the surface is lit.
    ///
    /// # Panics
    /// If `surface` is out of range.
    pub fn lit_average(&self, surface: usize) -> [f64; 3] {
        let mut acc = [0.0; 3];
        let mut area = 0.0;
        for &p in &self.by_surface[surface] {
            if !self.patches[p].can_emit() {
                continue;
            }
            let (v, a) = self.patch_real_integral(p);
            for c in 0..3 {
                acc[c] += v[c];
            }
            area += a;
        }
        acc.map(|v| v / area)
    }

    /// Leaf radiosity coefficients of one channel (the solver's unknowns).
    pub fn leaf_coefficients(&self, ch: usize) -> Vec<f64> {
        let n = self.system.h.n;
        let mut x = vec![0.0; self.system.dim()];
        for (l, &i) in self.system.h.leaves.iter().enumerate() {
            x[l * n..][..n].copy_from_slice(&self.node_b[ch][i as usize * n..][..n]);
        }
        x
    }
}

/// Value at `(s, t)` of patch `patch` of the tree expansion with node coefficients
/// `coeffs` (per channel, every node of `system.h`, orthonormal basis functions
/// scaled by `1/√area`): the leaf containing the point evaluates its functions.
pub(crate) fn eval_nodes(
    system: &System,
    basis: &TreeBasis,
    coeffs: &[Vec<f64>; 3],
    patch: usize,
    s: f64,
    t: f64,
) -> [f64; 3] {
    let h = &system.h;
    let n = h.n;
    let leaf = h.leaf_at(patch, s, t) as usize;
    let reg = h.keys[leaf].region();
    let mut vals = [0.0; 16];
    basis.eval(
        (s.clamp(0.0, 1.0) - reg.s0) / reg.h,
        (t.clamp(0.0, 1.0) - reg.t0) / reg.h,
        &mut vals[..n],
    );
    let inv = 1.0 / system.node_area[leaf].sqrt();
    std::array::from_fn(|ch| {
        (0..n)
            .map(|a| coeffs[ch][leaf * n + a] * vals[a])
            .sum::<f64>()
            * inv
    })
}
