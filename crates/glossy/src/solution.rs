//! The glossy solver and its solution (Glossy §5.1): project `L_e` and `Γ_e`, link
//! every mutually visible ordered pair of patches root `φ` to root `φ` and solve in
//! `V⁰`, then alternate refinement rounds ([`crate::refine`]) and solves until the
//! round budget, a link/memory budget, a zero oracle maximum or a converged eye image
//! stops it. The result evaluates radiance and importance at `(patch, s, t, ω)`,
//! side exitances, the final gather (§5.5) and reports counts, costs and times.

use std::collections::HashSet;
use std::time::{Duration, Instant};

use glam::{DVec2, DVec3};
use rand::SeedableRng;
use rand_pcg::Pcg64;
use rayon::prelude::*;
use wavelux_geometry::Ray;
use wavelux_scene::Scene;
use wavelux_support::Side;

use crate::basis::{CHILDREN, HaarStep, NodeKey, TYPES, spatially_constant};
use crate::config::{GatherMode, GlossyConfig};
use crate::directions::{CellRule, integrate_cell};
use crate::emission::project_emission;
use crate::error::GlossyError;
use crate::link::{Link, LinkSet};
use crate::nonstandard::{self, Decomposition, ScalingLink};
use crate::patch::{GlossyScene, ImportanceSource};
use crate::refine::{self, Candidate, mix, node_stream};
use crate::solve::{SolveRecord, solve};
use crate::transport::{End, LinkValues, Transport};
use crate::tree::{BANDS, Functions, IMPORTANCE, RADIANCE};

/// Statistics of one refinement round.
#[derive(Debug, Clone, PartialEq, Default, serde::Serialize)]
pub struct RoundStats {
    /// Round number (1-based).
    pub round: usize,
    /// Candidates proposed.
    pub candidates: usize,
    /// Largest oracle value.
    pub max_value: f64,
    /// Candidates whose oracle value is 0 (standard decomposition; with importance
    /// off: the sending wavelet and its same-type descendants have no coefficient yet,
    /// as a patch's wavelets get one only once a link reaches them).
    pub zero_value: usize,
    /// Candidates computed (value ≥ fraction × max, within budgets).
    pub computed: usize,
    /// New links stored (the rest had only zero samples).
    pub new_links: usize,
    /// Links after the round.
    pub links: usize,
    /// Links rebuilt from finer `φ→φ` values (§5.4).
    pub rebuilt: usize,
    /// Kernel evaluations of the round.
    pub samples: u64,
    /// Rays of the round (shadow rays and importance rays).
    pub rays: u64,
    /// Radiance solve.
    pub radiance_solve: SolveRecord,
    /// Importance solve (when importance is on).
    pub importance_solve: Option<SolveRecord>,
    /// Relative L² change of the watch image (when enabled).
    pub image_change: Option<f64>,
    /// Wall time of the round (s).
    pub seconds: f64,
}

/// Wall time per phase.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
pub struct PhaseTimes {
    /// Scene preparation and emitter projection.
    pub setup: f64,
    /// Initial root-to-root links.
    pub initial_links: f64,
    /// Initial `V⁰` solve.
    pub initial_solve: f64,
    /// Refinement (oracle, importance rays, new links, rebuild).
    pub refine: f64,
    /// Solves after refinement.
    pub solve: f64,
}

/// Counts, costs and times of a solution.
#[derive(Debug, Clone, PartialEq, Default, serde::Serialize)]
pub struct GlossyStats {
    /// Patches (lit sides, plus the eye).
    pub patches: usize,
    /// Ordered pairs with a non-zero root link (the initial links).
    pub visible_pairs: usize,
    /// Unordered visible pairs (both directions counted once).
    pub visible_unordered: usize,
    /// Links stored.
    pub links: usize,
    /// Link computations whose samples were all zero (not stored, never re-proposed).
    pub empty_links: usize,
    /// Non-zero radiance coefficients per space: `[V⁰, W⁰, W¹, …]`.
    pub spaces: Vec<usize>,
    /// Basis functions allocated.
    pub functions: usize,
    /// Kernel evaluations.
    pub samples: u64,
    /// Rays traced by the solver (shadow and importance rays).
    pub rays: u64,
    /// Bytes of the links and their indices.
    pub link_bytes: usize,
    /// Bytes of the coefficient arrays and trees.
    pub coefficient_bytes: usize,
    /// Wall times.
    pub times: PhaseTimes,
    /// Refinement rounds.
    pub rounds: Vec<RoundStats>,
    /// Why refinement stopped (empty while it may continue).
    pub stop: String,
    /// Emitted power of the projected `L_e` (W, RGB).
    pub emitted_power: [f64; 3],
    /// Emitted power of the exact emitters (W, RGB).
    pub exact_emitted_power: [f64; 3],
    /// Warnings (scene preparation).
    pub warnings: Vec<String>,
}

/// A glossy solution and the solver state that can refine it further.
#[derive(Debug)]
pub struct GlossySolution {
    /// The prepared scene.
    pub scene: GlossyScene,
    /// The configuration.
    pub config: GlossyConfig,
    /// Trees and coefficients.
    pub funcs: Functions,
    /// Links (standard decomposition).
    pub links: LinkSet,
    /// Scaling links (non-standard decomposition; empty otherwise).
    pub scaling: Vec<ScalingLink>,
    dead: HashSet<(u32, u32, NodeKey, bool)>,
    haar: HaarStep,
    /// Counts, costs and times.
    pub stats: GlossyStats,
    /// `value − emit` (the reflected part), refreshed after every solve.
    reflected: Vec<[f64; BANDS]>,
    last_image: Option<Vec<[f64; 3]>>,
    rule: CellRule,
}

fn secs(d: Duration) -> f64 {
    d.as_secs_f64()
}

fn to_link(v: &LinkValues, sender: u32, recv_patch: u32, recv_node: u32, recv_phi: bool) -> Link {
    Link {
        sender,
        recv_patch,
        recv_node,
        recv_phi,
        coef: v.coef.map(|r| r.map(|x| x as f32)),
        phiphi: v.phiphi.map(|x| x as f32),
        variation: v.variation as f32,
        masks: v.masks,
    }
}

fn scaling_link(v: &LinkValues, recv: (u32, u32), send: (u32, u32)) -> ScalingLink {
    ScalingLink {
        recv_patch: recv.0,
        recv_node: recv.1,
        send_patch: send.0,
        send_node: send.1,
        t: v.phiphi.map(|x| x as f32),
        variation: v.variation as f32,
    }
}

/// Side of the watch image used by the image-change stop.
pub const WATCH_SIZE: usize = 24;

impl GlossySolution {
    /// Prepares the scene, projects the emitters and the eye, builds the initial
    /// links and solves in `V⁰` (no refinement yet: see [`GlossySolution::run`]).
    ///
    /// # Errors
    /// [`GlossyError`] for invalid knobs, scenes (naming file and element), a missing
    /// importance source, or a diverging solve.
    pub fn new(scene: &Scene, file: &str, config: GlossyConfig) -> Result<Self, GlossyError> {
        config.validate()?;
        let t0 = Instant::now();
        let gs = GlossyScene::new(scene, file, config.variant, &config.importance)?;
        let mut funcs = Functions::new(gs.patches.len());
        project_emission(
            &gs,
            config.directions,
            &mut funcs,
            config.emitter_level,
            config.emitter_tolerance,
        )?;
        let mut stats = GlossyStats {
            patches: gs.patches.len(),
            warnings: gs.warnings.clone(),
            ..GlossyStats::default()
        };
        let mut sol = Self {
            scene: gs,
            config,
            funcs,
            links: LinkSet::default(),
            scaling: Vec::new(),
            dead: HashSet::new(),
            haar: HaarStep::new(),
            stats: GlossyStats::default(),
            reflected: Vec::new(),
            last_image: None,
            rule: CellRule::new(16)?,
        };
        sol.funcs.value = sol.funcs.emit.clone();
        stats.times.setup = secs(t0.elapsed());
        let t1 = Instant::now();
        sol.initial_links(&mut stats)?;
        stats.times.initial_links = secs(t1.elapsed());
        let t2 = Instant::now();
        sol.stats = stats;
        let (r, _) = sol.solve_all()?;
        sol.stats.times.initial_solve = secs(t2.elapsed());
        let _ = r;
        sol.stats.exact_emitted_power = sol.exact_emitted_power();
        sol.stats.emitted_power = sol.projected_emitted_power();
        sol.refresh_stats();
        Ok(sol)
    }

    /// Whether importance drives the refinement.
    #[must_use]
    pub fn importance_on(&self) -> bool {
        !matches!(self.config.importance, ImportanceSource::Off)
    }

    fn transport(&self) -> Result<Transport<'_>, GlossyError> {
        Transport::new(&self.scene, self.config.directions, self.config.transport)
    }

    fn stream(&self, sender: u32, recv_patch: usize, key: &NodeKey, phi: bool) -> u64 {
        node_stream(
            self.config.seed ^ mix(u64::from(sender) ^ 0x5EED),
            recv_patch,
            key,
        ) ^ u64::from(phi)
    }

    /// Whether a patch can send anything (light or importance).
    fn sends(&self, p: usize) -> bool {
        let q = &self.scene.patches[p];
        q.is_emitter() || q.reflects() || q.importance || q.is_eye()
    }

    /// Whether `a` may see `b` (bounding-sphere test against planar sides' planes).
    fn may_see(&self, a: usize, b: usize) -> bool {
        let (pa, pb) = (&self.scene.patches[a], &self.scene.patches[b]);
        let behind = |p: &crate::patch::Patch, q: &crate::patch::Patch| {
            if !p.support.is_planar() {
                return false;
            }
            let o = p.support.point(0.5, 0.5);
            let (c, r) = q.support.bounding_sphere(0.0, 0.0, 1.0);
            (c - o).dot(p.support.normal) + r <= 0.0
        };
        !behind(pa, pb) && !behind(pb, pa)
    }

    fn initial_links(&mut self, stats: &mut GlossyStats) -> Result<(), GlossyError> {
        let n = self.scene.patches.len();
        let mut pairs = Vec::new();
        for r in 0..n {
            let pr = &self.scene.patches[r];
            if pr.is_eye() || !pr.reflects() {
                continue;
            }
            for s in 0..n {
                if s != r && self.sends(s) && self.may_see(s, r) {
                    pairs.push((s, r));
                }
            }
        }
        let tr = self.transport()?;
        let vals: Vec<LinkValues> = pairs
            .par_iter()
            .map(|&(s, r)| {
                let sender = self.funcs.trees[s].root_phi;
                tr.compute(
                    End {
                        patch: s,
                        key: NodeKey::ROOT,
                        tau: 0,
                    },
                    End {
                        patch: r,
                        key: NodeKey::ROOT,
                        tau: 0,
                    },
                    self.stream(sender, r, &NodeKey::ROOT, true),
                )
            })
            .collect();
        let mut unordered = HashSet::new();
        for ((s, r), v) in pairs.into_iter().zip(vals) {
            stats.samples += v.samples;
            stats.rays += v.rays;
            let sender = self.funcs.trees[s].root_phi;
            if !v.nonzero {
                self.dead.insert((sender, r as u32, NodeKey::ROOT, true));
                stats.empty_links += 1;
                continue;
            }
            stats.visible_pairs += 1;
            unordered.insert((s.min(r), s.max(r)));
            if self.config.decomposition == Decomposition::NonStandard {
                self.scaling
                    .push(scaling_link(&v, (r as u32, 0), (s as u32, 0)));
            } else {
                self.links
                    .push(to_link(&v, sender, r as u32, 0, true), (s as u32, 0));
            }
        }
        stats.visible_unordered = unordered.len();
        self.links.sort(n);
        Ok(())
    }

    /// Solves radiance (and importance when on); refreshes the reflected part.
    fn solve_all(&mut self) -> Result<(SolveRecord, Option<SolveRecord>), GlossyError> {
        let c = &self.config;
        if c.decomposition == Decomposition::NonStandard {
            // Importance is off (checked by the config).
            let r = nonstandard::solve(
                &mut self.funcs,
                &self.haar,
                &self.scaling,
                RADIANCE,
                c.tolerance,
                c.max_iterations,
            )?;
            self.refresh_reflected();
            return Ok((r, None));
        }
        let r = solve(
            &mut self.funcs,
            &self.links,
            RADIANCE,
            c.solver,
            c.tolerance,
            c.max_iterations,
        )?;
        let i = if self.importance_on() {
            Some(solve(
                &mut self.funcs,
                &self.links,
                IMPORTANCE,
                c.solver,
                c.tolerance,
                c.max_iterations,
            )?)
        } else {
            None
        };
        self.refresh_reflected();
        Ok((r, i))
    }

    fn refresh_reflected(&mut self) {
        self.reflected = self
            .funcs
            .value
            .iter()
            .zip(&self.funcs.emit)
            .map(|(v, e)| std::array::from_fn(|b| v[b] - e[b]))
            .collect();
    }

    /// Whether refinement has stopped (see [`GlossyStats::stop`]).
    #[must_use]
    pub fn stopped(&self) -> bool {
        !self.stats.stop.is_empty()
    }

    /// Bytes of links and coefficients.
    #[must_use]
    pub fn bytes(&self) -> usize {
        self.links.bytes()
            + self.scaling.capacity() * ScalingLink::BYTES
            + self.funcs.len() * (2 * BANDS * 8 + 12)
    }

    /// One refinement round: oracle, new links, rebuild, solve. `None` when refinement
    /// has stopped (the reason is in [`GlossyStats::stop`]).
    ///
    /// # Errors
    /// As [`GlossySolution::new`].
    pub fn refine_round(&mut self) -> Result<Option<RoundStats>, GlossyError> {
        if self.stopped() {
            return Ok(None);
        }
        let t0 = Instant::now();
        let mut rs = RoundStats {
            round: self.stats.rounds.len() + 1,
            ..RoundStats::default()
        };
        let refined = match self.config.decomposition {
            Decomposition::Standard => self.refine_standard(&mut rs)?,
            Decomposition::NonStandard => self.refine_nonstandard(&mut rs)?,
        };
        let Some(budget_hit) = refined else {
            return Ok(None);
        };
        let t_refine = t0.elapsed();
        let t1 = Instant::now();
        let (r, i) = self.solve_all()?;
        rs.radiance_solve = r;
        rs.importance_solve = i;
        self.stats.times.refine += secs(t_refine);
        self.stats.times.solve += secs(t1.elapsed());
        rs.links = self.links.len() + self.scaling.len();
        if let (Some(tol), Some(img)) = (self.config.image_tolerance, self.watch_image()) {
            if let Some(prev) = &self.last_image {
                let (mut d, mut n) = (0.0, 0.0);
                for (a, b) in prev.iter().zip(&img) {
                    for c in 0..3 {
                        d += (a[c] - b[c]).powi(2);
                        n += b[c] * b[c];
                    }
                }
                let ch = if n > 0.0 { (d / n).sqrt() } else { 0.0 };
                rs.image_change = Some(ch);
                if ch <= tol {
                    self.stats.stop = format!("eye image changed by {ch:.3e} <= {tol:.3e}");
                }
            }
            self.last_image = Some(img);
        }
        if budget_hit {
            self.stats.stop = "link or memory budget reached".into();
        } else if rs.computed == 0 {
            self.stats.stop = "no candidate reached the fraction of the maximum".into();
        }
        rs.seconds = secs(t0.elapsed());
        self.stats.samples += rs.samples;
        self.stats.rays += rs.rays;
        self.stats.rounds.push(rs.clone());
        self.refresh_stats();
        Ok(Some(rs))
    }

    /// The standard decomposition's round (oracle, new links, §5.4 rebuild); `None`
    /// when refinement stops, else whether a budget ended it.
    fn refine_standard(&mut self, rs: &mut RoundStats) -> Result<Option<bool>, GlossyError> {
        let cands = refine::candidates(&self.funcs, &self.links, &self.dead, self.config.max_level);
        rs.candidates = cands.len();
        let arrive = if self.importance_on() {
            let (m, traced) = refine::arriving_all(
                &self.scene,
                &self.funcs,
                &self.haar,
                self.config.directions,
                &cands,
                self.config.importance_rays,
                self.config.seed ^ (rs.round as u64),
            );
            rs.rays += traced;
            Some(m)
        } else {
            None
        };
        let reach = refine::reach(&self.funcs);
        let vals = refine::values(&reach, &cands, arrive.as_ref());
        let max = vals.iter().copied().fold(0.0, f64::max);
        rs.max_value = max;
        rs.zero_value = vals.iter().filter(|&&v| v == 0.0).count();
        if !crate::positive(max) {
            self.stats.stop = "no candidate link has a non-zero oracle value".into();
            return Ok(None);
        }
        let cut = self.config.fraction * max;
        let mut chosen: Vec<Candidate> = Vec::new();
        let per_link = Link::BYTES + 64;
        let mut budget_hit = false;
        for (c, v) in cands.iter().zip(&vals) {
            if *v < cut {
                continue;
            }
            if self.links.len() + chosen.len() >= self.config.max_links
                || self.bytes() + (chosen.len() + 1) * per_link > self.config.max_bytes
            {
                budget_hit = true;
                break;
            }
            chosen.push(*c);
        }
        rs.computed = chosen.len();
        // Receiving nodes first (sequential: ids are appended).
        let mut ends = Vec::with_capacity(chosen.len());
        for c in &chosen {
            let node = if c.recv_phi {
                0
            } else {
                self.funcs.node(c.recv_patch as usize, c.recv_key)
            };
            let o = self.funcs.owner[c.sender as usize];
            let skey = self.funcs.trees[o.patch as usize].keys[o.node as usize];
            ends.push((
                End {
                    patch: o.patch as usize,
                    key: skey,
                    tau: usize::from(o.tau),
                },
                End {
                    patch: c.recv_patch as usize,
                    key: c.recv_key,
                    tau: usize::from(!c.recv_phi),
                },
                node,
            ));
        }
        let tr = self.transport()?;
        let out: Vec<LinkValues> = chosen
            .par_iter()
            .zip(&ends)
            .map(|(c, (s, r, _))| {
                tr.compute(
                    *s,
                    *r,
                    self.stream(c.sender, c.recv_patch as usize, &c.recv_key, c.recv_phi),
                )
            })
            .collect();
        drop(tr);
        for ((c, (s, _, node)), v) in chosen.iter().zip(&ends).zip(out) {
            rs.samples += v.samples;
            rs.rays += v.rays;
            if !v.nonzero {
                self.dead
                    .insert((c.sender, c.recv_patch, c.recv_key, c.recv_phi));
                self.stats.empty_links += 1;
                continue;
            }
            let send_node = self.funcs.owner[c.sender as usize].node;
            self.links.push(
                to_link(&v, c.sender, c.recv_patch, *node, c.recv_phi),
                (s.patch as u32, send_node),
            );
            rs.new_links += 1;
        }
        self.links.sort(self.scene.patches.len());
        rs.rebuilt = refine::rebuild(&self.funcs, &mut self.links, &self.haar);
        Ok(Some(budget_hit))
    }

    /// The non-standard decomposition's round ([`crate::nonstandard`]): every link
    /// whose value reaches `fraction ×` the largest is replaced by the links of its
    /// split end's 16 children. `None` when refinement stops, else whether a budget
    /// ended it.
    fn refine_nonstandard(&mut self, rs: &mut RoundStats) -> Result<Option<bool>, GlossyError> {
        let vals = nonstandard::values(
            &self.funcs,
            &self.haar,
            &self.scaling,
            self.config.max_level,
        );
        rs.candidates = vals.iter().filter(|v| v.1.is_some()).count();
        let max = vals.iter().map(|v| v.0).fold(0.0, f64::max);
        rs.max_value = max;
        if !crate::positive(max) {
            self.stats.stop = "no link has a non-zero oracle value".into();
            return Ok(None);
        }
        let cut = self.config.fraction * max;
        let mut split = Vec::new();
        let mut budget_hit = false;
        for (i, (v, sp)) in vals.iter().enumerate() {
            let Some(sp) = sp else { continue };
            if *v < cut {
                continue;
            }
            let grown = 15 * (split.len() + 1);
            if self.scaling.len() + grown > self.config.max_links
                || self.bytes() + grown * ScalingLink::BYTES > self.config.max_bytes
            {
                budget_hit = true;
                break;
            }
            split.push((i, *sp));
        }
        rs.computed = split.len() * CHILDREN;
        // (sending patch, key, receiving patch, key) of every child link.
        let mut jobs = Vec::with_capacity(rs.computed);
        for &(i, sp) in &split {
            let l = self.scaling[i];
            let kr = self.funcs.trees[l.recv_patch as usize].keys[l.recv_node as usize];
            let ks = self.funcs.trees[l.send_patch as usize].keys[l.send_node as usize];
            for (cr, cs) in nonstandard::children(kr, ks, sp) {
                jobs.push((l.send_patch, cs, l.recv_patch, cr));
            }
        }
        let tr = self.transport()?;
        let seed = self.config.seed;
        let out: Vec<LinkValues> = jobs
            .par_iter()
            .map(|&(sp, cs, rp, cr)| {
                let kh = cs
                    .idx
                    .iter()
                    .fold(u64::from(cs.level), |h, &i| mix(h ^ u64::from(i)));
                tr.compute(
                    End {
                        patch: sp as usize,
                        key: cs,
                        tau: 0,
                    },
                    End {
                        patch: rp as usize,
                        key: cr,
                        tau: 0,
                    },
                    node_stream(seed ^ mix(u64::from(sp) ^ kh), rp as usize, &cr),
                )
            })
            .collect();
        drop(tr);
        let mut gone = vec![false; self.scaling.len()];
        for &(i, _) in &split {
            gone[i] = true;
        }
        let mut kept: Vec<ScalingLink> = self
            .scaling
            .iter()
            .zip(&gone)
            .filter(|(_, g)| !**g)
            .map(|(l, _)| *l)
            .collect();
        for ((sp, cs, rp, cr), v) in jobs.into_iter().zip(out) {
            rs.samples += v.samples;
            rs.rays += v.rays;
            if !v.nonzero {
                self.stats.empty_links += 1;
                continue;
            }
            let rn = self.funcs.node(rp as usize, cr);
            let sn = self.funcs.node(sp as usize, cs);
            kept.push(scaling_link(&v, (rp, rn), (sp, sn)));
            rs.new_links += 1;
        }
        self.scaling = kept;
        Ok(Some(budget_hit))
    }

    /// Runs refinement rounds until [`GlossyConfig::rounds`] rounds have been done in
    /// total or refinement stops; `progress` sees every round.
    ///
    /// # Errors
    /// As [`GlossySolution::refine_round`].
    pub fn run(&mut self, mut progress: impl FnMut(&RoundStats)) -> Result<(), GlossyError> {
        while self.stats.rounds.len() < self.config.rounds {
            match self.refine_round()? {
                Some(r) => progress(&r),
                None => break,
            }
        }
        if self.stats.stop.is_empty() {
            self.stats.stop = format!("{} refinement rounds done", self.stats.rounds.len());
        }
        Ok(())
    }

    fn refresh_stats(&mut self) {
        let mut spaces: Vec<usize> = vec![0];
        for (id, o) in self.funcs.owner.iter().enumerate() {
            let v = &self.funcs.value[id];
            if refine::magnitude(v, RADIANCE) == 0.0 {
                continue;
            }
            if o.tau == 0 {
                spaces[0] += 1;
            } else {
                let lvl =
                    usize::from(self.funcs.trees[o.patch as usize].keys[o.node as usize].level);
                if spaces.len() < lvl + 2 {
                    spaces.resize(lvl + 2, 0);
                }
                spaces[lvl + 1] += 1;
            }
        }
        self.stats.spaces = spaces;
        self.stats.functions = self.funcs.len();
        self.stats.links = self.links.len() + self.scaling.len();
        self.stats.link_bytes = self.links.bytes() + self.scaling.capacity() * ScalingLink::BYTES;
        self.stats.coefficient_bytes = self.funcs.len() * (2 * BANDS * 8 + 12)
            + self.funcs.trees.iter().map(|t| t.len() * 32).sum::<usize>();
    }

    /// The Haar step.
    #[must_use]
    pub fn haar(&self) -> &HaarStep {
        &self.haar
    }

    /// `u ∈ [0,1]⁴` of `(patch, s, t, ω)` (`ω` a world direction away from the
    /// surface); `None` below the horizon.
    #[must_use]
    pub fn coordinates(&self, patch: usize, st: DVec2, w: DVec3) -> Option<[f64; 4]> {
        let f = self.scene.patches[patch].frame(st.x, st.y);
        let l = f.to_local(w.normalize());
        if !crate::positive(l.z) {
            return None;
        }
        let u = self.config.directions.inverse(l)?;
        Some([st.x, st.y, u.x, u.y])
    }

    /// Radiance expansion (W/(m²·sr), RGB) of `patch` at `(s, t)` in the world
    /// direction `w`, including the projected emission; 0 below the horizon.
    #[must_use]
    pub fn radiance(&self, patch: usize, st: DVec2, w: DVec3) -> [f64; 3] {
        self.coordinates(patch, st, w).map_or([0.0; 3], |u| {
            self.funcs
                .eval(&self.haar, patch, u, RADIANCE, &self.funcs.value)
        })
    }

    /// The reflected part of the radiance expansion (without the projected emission).
    #[must_use]
    pub fn reflected(&self, patch: usize, st: DVec2, w: DVec3) -> [f64; 3] {
        self.coordinates(patch, st, w).map_or([0.0; 3], |u| {
            self.funcs
                .eval(&self.haar, patch, u, RADIANCE, &self.reflected)
        })
    }

    /// Exact emission plus the reflected expansion: what an image shows without
    /// final gather (emitters stay crisp).
    #[must_use]
    pub fn radiance_exact_emission(&self, patch: usize, st: DVec2, w: DVec3) -> [f64; 3] {
        let f = self.scene.patches[patch].frame(st.x, st.y);
        let l = f.to_local(w.normalize());
        let e = self.scene.emitted(patch, st.x, st.y, l);
        let r = self.reflected(patch, st, w);
        std::array::from_fn(|c| e[c] + r[c])
    }

    /// Importance expansion of `patch` at `(s, t)` in direction `w` (RGB).
    #[must_use]
    pub fn importance(&self, patch: usize, st: DVec2, w: DVec3) -> [f64; 3] {
        self.coordinates(patch, st, w).map_or([0.0; 3], |u| {
            self.funcs
                .eval(&self.haar, patch, u, IMPORTANCE, &self.funcs.value)
        })
    }

    /// `∫ cos θ J_ω` over the direction cell `(level; i)`.
    fn cos_integral(&self, level: u8, i: [u16; 2]) -> f64 {
        let d = self.config.directions;
        integrate_cell(&self.rule, level, i, |u| d.direction(u).z * d.jacobian(u))
    }

    /// `∫ b cos θ J_ω du` of every spatially constant type of a node (index = type).
    fn type_moments(&self, key: &NodeKey) -> [f64; CHILDREN] {
        let mut q = [0.0; 4];
        for (a, v) in q.iter_mut().enumerate() {
            let i = [
                2 * key.idx[2] + (a & 1) as u16,
                2 * key.idx[3] + (a >> 1) as u16,
            ];
            *v = self.cos_integral(key.level + 1, i);
        }
        std::array::from_fn(|t| {
            if !spatially_constant(t) {
                return 0.0;
            }
            (0..CHILDREN).map(|k| self.haar.at(t, k) * q[k >> 2]).sum()
        })
    }

    /// Mean radiant exitance of `patch` over its support (W/m², RGB) of the values
    /// `vals` in bands `bands`: `Σ ℓ ∫ b cos θ J_ω du`.
    fn exitance_of(
        &self,
        patch: usize,
        vals: &[[f64; BANDS]],
        bands: std::ops::Range<usize>,
    ) -> [f64; 3] {
        let tree = &self.funcs.trees[patch];
        let mut out = [0.0; 3];
        let root = &vals[tree.root_phi as usize];
        for (o, b) in out.iter_mut().zip(bands.clone()) {
            *o = root[b] * std::f64::consts::PI;
        }
        for (n, key) in tree.keys.iter().enumerate() {
            let m = self.type_moments(key);
            for t in 1..CHILDREN {
                if m[t] == 0.0 {
                    continue;
                }
                let v = &vals[tree.id(n as u32, t) as usize];
                for (o, b) in out.iter_mut().zip(bands.clone()) {
                    *o += m[t] * v[b];
                }
            }
        }
        out
    }

    /// Mean radiant exitance of a patch (W/m², RGB): `M = ∫∫ L cos θ dω dA / A`.
    #[must_use]
    pub fn exitance(&self, patch: usize) -> [f64; 3] {
        self.exitance_of(patch, &self.funcs.value, RADIANCE)
    }

    /// Real-area mean exitance of one side of a scene surface (`None`: no such lit
    /// side).
    #[must_use]
    pub fn side_exitance(&self, surface: usize, side: Side) -> Option<[f64; 3]> {
        let mut s = [0.0; 3];
        let mut a = 0.0;
        for (i, p) in self.scene.patches.iter().enumerate() {
            if p.surface == surface && p.side == side {
                let m = self.exitance(i);
                let ar = p.support.real_area();
                for c in 0..3 {
                    s[c] += ar * m[c];
                }
                a += ar;
            }
        }
        (a > 0.0).then(|| s.map(|v| v / a))
    }

    fn projected_emitted_power(&self) -> [f64; 3] {
        let mut p = [0.0; 3];
        for (i, q) in self.scene.patches.iter().enumerate() {
            if q.is_emitter() {
                let m = self.exitance_of(i, &self.funcs.emit, RADIANCE);
                for c in 0..3 {
                    p[c] += m[c] * q.support.area;
                }
            }
        }
        p
    }

    fn exact_emitted_power(&self) -> [f64; 3] {
        let mut p = [0.0; 3];
        for (i, q) in self.scene.patches.iter().enumerate() {
            if !q.is_emitter() {
                continue;
            }
            // 8 × 8 midpoint samples of the (possibly textured) exitance.
            let mut e = [0.0; 3];
            for k in 0..64 {
                let st = DVec2::new((k % 8) as f64 + 0.5, (k / 8) as f64 + 0.5) / 8.0;
                let x = self.scene.exitance_at(i, st.x, st.y);
                for c in 0..3 {
                    e[c] += x[c] / 64.0;
                }
            }
            for c in 0..3 {
                p[c] += e[c] * q.support.real_area();
            }
        }
        p
    }

    /// Final gather (Glossy §5.5) at `(patch, s, t)` toward the world direction `w`:
    /// `L_e(y, ω) + Σ_s ℓ_s ∫_x f_r(ω_xy, y, ω) G(x, y) b_s(x, ω_xy) dx` over the senders
    /// `mode` selects, with `rays` stratified rays per sending node (every type of a
    /// node shares its rays). `emitted`: add the exact emission of `y`.
    pub fn gather(
        &self,
        patch: usize,
        st: DVec2,
        w: DVec3,
        mode: GatherMode,
        rays: usize,
        rng: &mut Pcg64,
        emitted: bool,
    ) -> [f64; 3] {
        let p = &self.scene.patches[patch];
        let (y, ny, fy) = p.point_frame(st.x, st.y);
        let wo = fy.to_local(w.normalize());
        if !crate::positive(wo.z) {
            return [0.0; 3];
        }
        let mut out = if emitted {
            self.scene.emitted(patch, st.x, st.y, wo)
        } else {
            [0.0; 3]
        };
        let brdf = self.scene.brdf_at(patch, st.x, st.y);
        if brdf.is_black() || rays == 0 {
            return out;
        }
        let yv = if p.support.is_real(st.x, st.y) {
            y
        } else {
            p.support.visibility_point(st.x, st.y)
        };
        // Sending nodes with a bit mask of types (bit 0: root φ).
        let mut senders: Vec<((u32, u32), u16)> = Vec::new();
        let add = |q: u32, node: u32, tau: u8, senders: &mut Vec<((u32, u32), u16)>| match senders
            .iter_mut()
            .find(|(k, _)| *k == (q, node))
        {
            Some((_, m)) => *m |= 1 << tau,
            None => senders.push(((q, node), 1 << tau)),
        };
        match mode {
            GatherMode::All => {
                for (q, t) in self.funcs.trees.iter().enumerate() {
                    if q == patch || self.scene.patches[q].is_eye() {
                        continue;
                    }
                    for n in 0..t.len() {
                        let mask = if n == 0 { 0xFFFF } else { 0xFFFE };
                        senders.push(((q as u32, n as u32), mask));
                    }
                }
            }
            GatherMode::Linked | GatherMode::Root if !self.scaling.is_empty() => {
                // Non-standard: every node of the patches linked into this one (a
                // node's `φ` is not one of the gather's types).
                let mut from: Vec<u32> = self
                    .scaling
                    .iter()
                    .filter(|l| l.recv_patch as usize == patch)
                    .map(|l| l.send_patch)
                    .collect();
                from.sort_unstable();
                from.dedup();
                for q in from {
                    for n in 0..self.funcs.trees[q as usize].len() {
                        let mask = if n == 0 { 0xFFFF } else { 0xFFFE };
                        senders.push(((q, n as u32), mask));
                    }
                }
            }
            GatherMode::Linked | GatherMode::Root => {
                let u = self.coordinates(patch, st, w);
                if let Some(range) = self.links.ranges.get(patch) {
                    for l in &self.links.links[range.clone()] {
                        let take = if l.recv_phi {
                            true
                        } else if mode == GatherMode::Linked {
                            let key = self.funcs.trees[patch].keys[l.recv_node as usize];
                            u.is_some_and(|u| key.contains(u))
                        } else {
                            false
                        };
                        if take {
                            let o = self.funcs.owner[l.sender as usize];
                            add(o.patch, o.node, o.tau, &mut senders);
                        }
                    }
                }
            }
        }
        for ((q, node), mask) in senders {
            let (q, node) = (q as usize, node as usize);
            let pq = &self.scene.patches[q];
            let tree = &self.funcs.trees[q];
            let key = tree.keys[node];
            let h = key.size();
            let lo = key.lo();
            let scale = 4f64.powi(i32::from(key.level) + 1);
            let cell = h * h / rays as f64;
            for i in 0..rays {
                let xs = DVec2::new(lo[0], lo[1]) + h * crate::transport::stratified(i, rays, rng);
                if !pq.support.is_real(xs.x, xs.y) {
                    continue;
                }
                // One evaluation of a curved map gives the point, normal and frame.
                let (x, nx, fx) = pq.point_frame(xs.x, xs.y);
                let d = y - x;
                let r2 = d.length_squared();
                if !crate::positive(r2) {
                    continue;
                }
                let dir = d / r2.sqrt();
                let cx = nx.dot(dir);
                let cy = -ny.dot(dir);
                if !(cx > 0.0 && cy > 0.0) {
                    continue;
                }
                let Some(ua) = self.config.directions.inverse(fx.to_local(dir)) else {
                    continue;
                };
                let u = [xs.x, xs.y, ua.x, ua.y];
                if !key.contains(u) {
                    continue;
                }
                let k = key.child_of(u);
                let mut lv = [0.0; 3];
                for t in 0..CHILDREN {
                    if mask & (1 << t) == 0 {
                        continue;
                    }
                    let (id, hv) = if t == 0 {
                        (tree.root_phi, 1.0)
                    } else {
                        (tree.id(node as u32, t), self.haar.at(t, k) * scale)
                    };
                    let v = &self.funcs.value[id as usize];
                    for c in 0..3 {
                        lv[c] += hv * v[c];
                    }
                }
                if lv == [0.0; 3] {
                    continue;
                }
                if self.scene.accel.occluded(x, yv, [pq.prim, p.prim]) {
                    continue;
                }
                let f = brdf.eval(fy.to_local(-dir), wo);
                let g = cx * cy / r2 * pq.support.jacobian(xs.x, xs.y) * cell;
                for c in 0..3 {
                    out[c] += lv[c] * f[c] * g;
                }
            }
        }
        out
    }

    /// A small image of the importance camera (direct evaluation with exact emission),
    /// `WATCH_SIZE²` pixels; `None` without a camera.
    fn watch_image(&self) -> Option<Vec<[f64; 3]>> {
        let ImportanceSource::Camera { camera, aspect } = &self.config.importance else {
            return None;
        };
        Some(self.image(camera, *aspect, WATCH_SIZE, WATCH_SIZE, None))
    }

    /// An image of the solution from a pinhole `camera` (`aspect` if the camera has
    /// none): one ray per pixel centre; pixels show [`Self::radiance_exact_emission`],
    /// or with `gather = Some((mode, rays, seed))` the final gather. Row-major, top
    /// row first.
    #[must_use]
    pub fn image(
        &self,
        camera: &wavelux_scene::Camera,
        aspect: f64,
        width: usize,
        height: usize,
        gather: Option<(GatherMode, usize, u64)>,
    ) -> Vec<[f64; 3]> {
        let (yfov, aspect) = match camera.projection {
            wavelux_scene::Projection::Perspective { yfov, aspect: a } => {
                (yfov, a.unwrap_or(aspect))
            }
            _ => (std::f64::consts::FRAC_PI_3, aspect),
        };
        let f = camera.forward.normalize();
        let up = (camera.up - f * f.dot(camera.up)).normalize();
        let right = f.cross(up);
        let ty = (0.5 * yfov).tan();
        let tx = ty * aspect;
        (0..width * height)
            .into_par_iter()
            .map(|i| {
                let (px, py) = (i % width, i / width);
                let sx = (2.0 * (px as f64 + 0.5) / width as f64 - 1.0) * tx;
                let sy = (1.0 - 2.0 * (py as f64 + 0.5) / height as f64) * ty;
                let dir = (f + sx * right + sy * up).normalize();
                let ray = Ray {
                    origin: camera.position,
                    dir,
                };
                let Some(hit) = self.scene.accel.closest_hit(&ray, 0.0, f64::INFINITY) else {
                    return [0.0; 3];
                };
                let Some((p, st)) = self.scene.resolve(&hit) else {
                    return [0.0; 3];
                };
                match gather {
                    None => self.radiance_exact_emission(p, st, -dir),
                    Some((mode, rays, seed)) => {
                        let mut rng = Pcg64::seed_from_u64(mix(seed ^ mix(i as u64)));
                        self.gather(p, st, -dir, mode, rays, &mut rng, true)
                    }
                }
            })
            .collect()
    }
}

/// A field of the solution, for [`GlossySolution::pairing`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Field {
    /// The projected emitted radiance `L_e`.
    EmittedRadiance,
    /// The radiance expansion `L`.
    Radiance,
    /// The projected emitted importance `Γ_e`.
    EmittedImportance,
    /// The importance expansion `Γ`.
    Importance,
}

impl GlossySolution {
    fn field_values(&self, f: Field) -> (&[[f64; BANDS]], std::ops::Range<usize>) {
        match f {
            Field::EmittedRadiance => (&self.funcs.emit, RADIANCE),
            Field::Radiance => (&self.funcs.value, RADIANCE),
            Field::EmittedImportance => (&self.funcs.emit, IMPORTANCE),
            Field::Importance => (&self.funcs.value, IMPORTANCE),
        }
    }

    fn field_at(&self, f: Field, patch: usize, st: DVec2, w: DVec3) -> [f64; 3] {
        let (vals, bands) = self.field_values(f);
        self.coordinates(patch, st, w).map_or([0.0; 3], |u| {
            self.funcs.eval(&self.haar, patch, u, bands, vals)
        })
    }

    /// `M(A, B) = ∫_y ∫_x A(y, ω_yx) G(x, y) B(x, ω_xy) dx dy` over all pairs of
    /// patches (RGB), by an `order × order` Gauss rule on each patch with a shadow ray
    /// per pair. `M` is symmetric and, by reciprocity, `M(Γ_e, L) = M(Γ, L_e)` for the
    /// exact solution (Glossy §4.2): the image measured by the eye equals the
    /// importance arriving at the lights.
    ///
    /// # Errors
    /// [`GlossyError::Dependency`] for an order outside the quadrature crate's range.
    pub fn pairing(&self, a: Field, b: Field, order: usize) -> Result<[f64; 3], GlossyError> {
        let g = wavelux_quadrature::GaussLegendre::new(order)
            .map_err(crate::error::dep("quadrature"))?;
        let (x, wts) = g.unit();
        let pts: Vec<(DVec2, f64)> = (0..order * order)
            .map(|k| {
                (
                    DVec2::new(x[k % order], x[k / order]),
                    wts[k % order] * wts[k / order],
                )
            })
            .collect();
        let nonzero = |f: Field, p: usize| {
            let (vals, bands) = self.field_values(f);
            self.funcs.trees[p]
                .ids()
                .any(|id| bands.clone().any(|bb| vals[id as usize][bb] != 0.0))
        };
        let n = self.scene.patches.len();
        let pairs: Vec<(usize, usize)> = (0..n)
            .filter(|&p| nonzero(a, p))
            .flat_map(|p| (0..n).filter(move |&q| q != p).map(move |q| (p, q)))
            .filter(|&(_, q)| nonzero(b, q))
            .collect();
        let parts: Vec<[f64; 3]> = pairs
            .par_iter()
            .map(|&(p, q)| {
                let (pp, pq) = (&self.scene.patches[p], &self.scene.patches[q]);
                let mut s = [0.0; 3];
                for (ys, wy) in &pts {
                    if !pp.support.is_real(ys.x, ys.y) {
                        continue;
                    }
                    let (y, ny) = pp.support.point_normal(ys.x, ys.y);
                    for (xs, wx) in &pts {
                        if !pq.support.is_real(xs.x, xs.y) {
                            continue;
                        }
                        let (xx, nx) = pq.support.point_normal(xs.x, xs.y);
                        let d = y - xx;
                        let r2 = d.length_squared();
                        if !crate::positive(r2) {
                            continue;
                        }
                        let dir = d / r2.sqrt();
                        let (cx, cy) = (nx.dot(dir), -ny.dot(dir));
                        if !(cx > 0.0 && cy > 0.0) {
                            continue;
                        }
                        let av = self.field_at(a, p, *ys, -dir);
                        let bv = self.field_at(b, q, *xs, dir);
                        if av == [0.0; 3] || bv == [0.0; 3] {
                            continue;
                        }
                        if self.scene.accel.occluded(xx, y, [pq.prim, pp.prim]) {
                            continue;
                        }
                        let gw = cx * cy / r2
                            * wx
                            * wy
                            * pp.support.jacobian(ys.x, ys.y)
                            * pq.support.jacobian(xs.x, xs.y);
                        for c in 0..3 {
                            s[c] += av[c] * bv[c] * gw;
                        }
                    }
                }
                s
            })
            .collect();
        let mut out = [0.0; 3];
        for s in parts {
            for c in 0..3 {
                out[c] += s[c];
            }
        }
        Ok(out)
    }
}

/// Number of wavelet types (re-exported for callers sizing per-node data).
pub const NODE_TYPES: usize = TYPES;
