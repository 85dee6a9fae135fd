//! The linear system on one active set (GlobalCube §3): unknowns `Chi[p][side]`
//! (§3.2's pseudocode), the transport operator `K` (gather through the projector,
//! scatter with the albedo, route to faces with Γ, eq. (32)), and the relaxations of
//! §2.2/§3 — Jacobi (eq. (28); the pseudocode's `Chi += …` read as `=`), a blocked
//! Gauss–Seidel, and GMRES on `(I − K) Chi = Chi_source` through
//! `wavelux_linear::FnOperator`.
//!
//! Sources: a cell of source `χᵗ` (W/m³) and volume `V` puts `χᵗ V / 6` on each face;
//! an opaque cell puts it on its exposed faces only (those not touching another opaque
//! cell: a hidden face can neither receive nor emit, so its share would be lost).
//! Emission: a cell `q` of side `E` (m) and collision weight `Ĝ_q` emits from face `s`
//! the coefficient `e_s = 6 Chi_s / (Ĝ_q E²)` (W/(m²·sr)), so that over all directions
//! it emits exactly `Σ_s Chi_s` (the projected-area mean of the faces a direction
//! leaves by averages `e` to `Σ e_s/6` over the sphere); an empty-opacity cell emits
//! its source as a thin emitter, `e_s = 6 Chi_s/(4π V)` per unit length.
//! Scattering: receiver `p` collides `C_p[i]` through entry face `i` from the other
//! cells (backend docs); its routing ([`crate::flight::routing`], per channel) turns
//! that into `m C_p[i]` collisions in total (re-collisions in the cell included) and
//! `Chi_p[j] = χᵗV/6 + Σ_i R_p[i][j] m C_p[i]` (default: `Γ_ii = σ`, `Γ_ij = (1 − σ)
//! F_ij`, scattered light re-colliding with the probability `π_p` of light born
//! uniformly in the cell; energy is conserved: absorbed + scattered out = collided
//! from outside).
//!
//! Recorded transport: the gather is linear in the emission coefficients while the
//! active set (so every opacity) stays fixed. After one full sweep through the
//! projector, the system asks it to record that map ([`Projector::record`],
//! [`crate::backend::Transport`]) within [`SystemSettings::transport_memory`] bytes;
//! every later gather of the set is then a sparse product instead of a new projection.
//! A set that is applied once (a refinement step with one relaxation) never records.
//! With adaptive supersampling (the CPU projector's default) the pixels supersampled
//! are those of the emission of the set's first Jacobi iterate `sources + K chi₀`
//! (`chi₀` the face powers of the set's first full [`System::apply`]; the emission
//! Jacobi's second sweep gathers, so Jacobi and GMRES record the same map), kept for
//! the set's later sweeps: the replayed solve differs from the re-projected one, whose
//! supersampled pixels follow each sweep's radiance, where a pixel's contrast crosses
//! the threshold after the recording (measured in docs/performance.md,
//! "wavelux-volume"). Before, the choice was made for the vector of the application
//! that records, which for GMRES is its initial guess: at the lowpass solve the bare
//! sources, where only the emitters shine. Supersampling chosen on an emitter alone
//! corrects the views in which a centre ray hits a sub-pixel emitter but not those in
//! which every centre ray misses it, so it loses the emitter's power: the voxelised
//! Cornell box at 16³, `N = 4`, absorbed 0.78 of the emitted power under GMRES against
//! 0.94 under Jacobi (crate docs, "Energy conservation"; `tests/supersampling.rs`).

use std::time::Instant;

use crate::active::{ActiveSet, LeafData, Traversal, WeightCache};
use crate::backend::{
    Emission, FaceRgb, GatherStats, ProjectionScene, Projector, Receiver, Transport,
};
use crate::cell::{Collision, GammaMode, SelfInteraction};
use crate::error::VolumeError;
use crate::flight::{Routing, routing};
use crate::hierarchy::Hierarchy;

/// Settings of the system (not of the solve loop).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SystemSettings {
    /// Collision weights.
    pub collision: Collision,
    /// Γ convention.
    pub gamma: GammaMode,
    /// Largest framebuffer side; a level-`l` receiver uses `min(cap, side >> l)`
    /// (GlobalCube §5: 16², 32², 64² for the 16³, 32³, 64³ levels of a 64³ scene).
    pub framebuffer: usize,
    /// Framebuffer of the boundary (escape) measurement.
    pub escape_framebuffer: usize,
    /// Self-interaction of scattered light.
    pub self_interaction: SelfInteraction,
    /// Largest recorded transport (bytes; 0: never record, every gather projects).
    pub transport_memory: usize,
}

/// Default [`SystemSettings::transport_memory`]: 1 GiB.
pub const DEFAULT_TRANSPORT_MEMORY: usize = 1 << 30;

impl Default for SystemSettings {
    fn default() -> Self {
        Self {
            collision: Collision::Exact,
            gamma: GammaMode::Normalized,
            framebuffer: 32,
            escape_framebuffer: 8,
            self_interaction: SelfInteraction::Uniform,
            transport_memory: DEFAULT_TRANSPORT_MEMORY,
        }
    }
}

/// Per-channel energy account of a state (W).
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
pub struct Energy {
    /// Source power `Σ χᵗ V`.
    pub emitted: [f64; 3],
    /// Power absorbed: `Σ_p (1 − ω_p) Σ_i C_p[i]`.
    pub absorbed: [f64; 3],
    /// Power leaving through the grid's boundary (the projector's escape measurement).
    pub escaped: [f64; 3],
    /// Collided power `Σ_p Σ_i C_p[i]`.
    pub collided: [f64; 3],
}

impl Energy {
    /// `(emitted − absorbed − escaped) / emitted` per channel (0 where nothing is
    /// emitted): the discrete transport's non-conservation.
    #[must_use]
    pub fn balance_error(&self) -> [f64; 3] {
        [0, 1, 2].map(|c| {
            if self.emitted[c] > 0.0 {
                (self.emitted[c] - self.absorbed[c] - self.escaped[c]) / self.emitted[c]
            } else {
                0.0
            }
        })
    }
}

/// The system on one active set.
pub struct System<'a> {
    projector: &'a dyn Projector,
    settings: SystemSettings,
    /// Voxels per axis.
    pub side: usize,
    /// Voxel edge (m).
    pub voxel: f64,
    /// Active leaves.
    pub set: ActiveSet,
    /// Per-leaf medium values.
    pub data: LeafData,
    /// Traversal cells and map.
    pub traversal: Traversal,
    /// Receivers (leaves with σ > 0), in leaf order.
    pub receivers: Vec<Receiver>,
    /// Per leaf: its receiver index, if it receives.
    pub receiver_of: Vec<Option<usize>>,
    /// Per leaf: source power per face and channel.
    pub sources: Vec<FaceRgb>,
    /// Per leaf and channel: how it turns collided power into collisions and face
    /// powers ([`crate::flight::routing`]).
    pub routing: Vec<[Routing; 3]>,
    /// The recorded transport, once asked for (`None` inside: the projector declined).
    transport: std::sync::OnceLock<Option<Transport>>,
    /// Receivers gathered through the projector so far.
    gathered: std::sync::atomic::AtomicUsize,
    /// The set's first Jacobi iterate `sources + K chi₀` (`chi₀` the face powers of
    /// the first full [`System::apply`]), whose emission makes the recording's
    /// adaptive choices (module docs).
    first_iterate: std::sync::OnceLock<Vec<FaceRgb>>,
}

/// Work and time of applications of `K`.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct Work {
    /// Projector work.
    pub gather: GatherStats,
    /// Applications of `K` (full sweeps).
    pub applications: u64,
    /// Seconds spent in the projector (recording included).
    pub projector_seconds: f64,
    /// Transports recorded ([`crate::backend::Transport`], one per active set at most).
    pub recorded: u64,
    /// Entries of the transports recorded.
    pub transport_entries: u64,
    /// Receiver gathers answered by a recorded transport instead of the projector.
    pub replayed: u64,
}

impl<'a> System<'a> {
    /// Builds the system for `set`.
    #[must_use]
    pub fn new(
        projector: &'a dyn Projector,
        settings: SystemSettings,
        hierarchy: &Hierarchy,
        voxel: f64,
        set: ActiveSet,
        cache: &mut WeightCache,
    ) -> Self {
        let data = LeafData::new(&set, hierarchy);
        let traversal = Traversal::new(&set, &data, settings.collision, cache);
        let side = set.side;
        let mut receivers = Vec::new();
        let mut receiver_of = vec![None; set.leaves.len()];
        let mut sources = Vec::with_capacity(set.leaves.len());
        for (i, l) in set.leaves.iter().enumerate() {
            if data.opacity[i] > 0.0 {
                receiver_of[i] = Some(receivers.len());
                let n = settings.framebuffer.min(side >> l.level).max(1);
                receivers.push(Receiver {
                    cell: i as u32,
                    framebuffer: n as u32,
                });
            }
            let v = (f64::from(l.size()) * voxel).powi(3);
            let power = data.source[i].map(|x| x * v);
            let mut f = [[0.0; 3]; 6];
            let exposed = if data.opacity[i] >= 1.0 {
                exposed_faces(&traversal, side, l)
            } else {
                [true; 6]
            };
            let k = exposed.iter().filter(|&&e| e).count();
            for s in 0..6 {
                if k == 0 || exposed[s] {
                    f[s] = power.map(|p| p / if k == 0 { 6.0 } else { k as f64 });
                }
            }
            sources.push(f);
        }
        let routing = data
            .opacity
            .iter()
            .zip(&data.albedo)
            .map(|(&o, alb)| alb.map(|w| routing(o, w, settings.gamma, settings.self_interaction)))
            .collect();
        Self {
            projector,
            settings,
            side,
            voxel,
            set,
            data,
            traversal,
            receivers,
            receiver_of,
            sources,
            routing,
            transport: std::sync::OnceLock::new(),
            gathered: std::sync::atomic::AtomicUsize::new(0),
            first_iterate: std::sync::OnceLock::new(),
        }
    }

    /// The recorded transport, recording it when one full sweep has gone through the
    /// projector already (module docs); `None` while it has not, or when the
    /// projector declines. `emission` (the gather's) makes the projector's adaptive
    /// choices for the recording ([`Projector::record`]).
    fn transport(
        &self,
        emission: &Emission<'_>,
        work: &mut Work,
    ) -> Result<Option<&Transport>, VolumeError> {
        use std::sync::atomic::Ordering;
        if let Some(t) = self.transport.get() {
            return Ok(t.as_ref());
        }
        if self.settings.transport_memory == 0
            || self.gathered.load(Ordering::Relaxed) < self.receivers.len()
        {
            return Ok(None);
        }
        let t0 = Instant::now();
        // The adaptive choices are made for the first Jacobi iterate's emission when
        // there is one (module docs), else for the gather's own.
        let first = self.first_iterate.get().map(|x| self.emission(x));
        let first = first.as_ref().map(|(e, p)| Emission {
            coefficients: e,
            power: p,
        });
        let t = self.projector.record(
            &self.scene(),
            first.as_ref().unwrap_or(emission),
            self.settings.collision,
            &self.receivers,
            self.settings.transport_memory,
        )?;
        work.projector_seconds += t0.elapsed().as_secs_f64();
        if let Some(t) = &t {
            work.recorded += 1;
            work.transport_entries += t.entries() as u64;
        }
        Ok(self.transport.get_or_init(|| t).as_ref())
    }

    /// Number of leaves.
    #[must_use]
    pub fn len(&self) -> usize {
        self.set.leaves.len()
    }

    /// Whether there are no leaves.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.set.leaves.is_empty()
    }

    /// The settings.
    #[must_use]
    pub fn settings(&self) -> SystemSettings {
        self.settings
    }

    fn scene(&self) -> ProjectionScene<'_> {
        ProjectionScene {
            side: self.side,
            voxel: self.voxel,
            cells: &self.traversal.cells,
            cell_map: &self.traversal.map,
        }
    }

    /// Emission coefficient and power of leaf `i` with face powers `chi`.
    fn leaf_emission(&self, i: usize, chi: &FaceRgb) -> (FaceRgb, [f64; 3]) {
        let leaf = &self.set.leaves[i];
        let edge = f64::from(leaf.size()) * self.voxel;
        let g = self.traversal.cells[i].total_weight;
        let scale = if self.data.opacity[i] > 0.0 {
            if g > 0.0 {
                6.0 / (g * edge * edge)
            } else {
                0.0
            }
        } else {
            6.0 / (4.0 * std::f64::consts::PI * edge * edge * edge)
        };
        let mut e = [[0.0; 3]; 6];
        let mut p = [0.0; 3];
        for s in 0..6 {
            for c in 0..3 {
                e[s][c] = scale * chi[s][c];
                p[c] += chi[s][c];
            }
        }
        (e, p)
    }

    /// Emission arrays for all traversal cells (empty nodes emit nothing).
    #[must_use]
    pub fn emission(&self, chi: &[FaceRgb]) -> (Vec<FaceRgb>, Vec<[f64; 3]>) {
        let nc = self.traversal.cells.len();
        let mut e = vec![[[0.0; 3]; 6]; nc];
        let mut p = vec![[0.0; 3]; nc];
        for i in 0..self.len() {
            let (ei, pi) = self.leaf_emission(i, &chi[i]);
            e[i] = ei;
            p[i] = pi;
        }
        (e, p)
    }

    /// Collided power per receiver for the receivers `range`.
    fn gather(
        &self,
        e: &[FaceRgb],
        p: &[[f64; 3]],
        range: std::ops::Range<usize>,
        work: &mut Work,
    ) -> Result<Vec<FaceRgb>, VolumeError> {
        let mut out = vec![[[0.0; 3]; 6]; range.len()];
        let first = range.start;
        let emission = Emission {
            coefficients: e,
            power: p,
        };
        if let Some(tr) = self.transport(&emission, work)? {
            let t = Instant::now();
            tr.apply(e, range.clone(), &mut out)?;
            work.replayed += range.len() as u64;
            work.projector_seconds += t.elapsed().as_secs_f64();
        } else {
            let t = Instant::now();
            let stats = self.projector.gather(
                &self.scene(),
                &emission,
                self.settings.collision,
                &self.receivers[range.clone()],
                &mut out,
            )?;
            self.gathered
                .fetch_add(range.len(), std::sync::atomic::Ordering::Relaxed);
            work.gather += stats;
            work.projector_seconds += t.elapsed().as_secs_f64();
        }
        for (k, c) in out.iter_mut().enumerate() {
            self.to_total(self.receivers[first + k].cell as usize, c);
        }
        Ok(out)
    }

    /// Turns the power collided from other cells into the total the cell collides,
    /// its own re-collisions included ([`Routing::multiplier`]).
    fn to_total(&self, leaf: usize, c: &mut FaceRgb) {
        let r = &self.routing[leaf];
        for f in c.iter_mut() {
            for ch in 0..3 {
                f[ch] *= r[ch].multiplier;
            }
        }
    }

    /// Collided power (W per entry face and channel) of the given leaves with face
    /// powers `chi` (leaves that do not receive get zeros).
    ///
    /// # Errors
    /// Backend errors.
    pub fn collide(
        &self,
        chi: &[FaceRgb],
        leaves: &[usize],
        work: &mut Work,
    ) -> Result<Vec<FaceRgb>, VolumeError> {
        let (e, p) = self.emission(chi);
        let recv: Vec<Receiver> = leaves
            .iter()
            .filter_map(|&i| {
                self.receiver_of
                    .get(i)
                    .copied()
                    .flatten()
                    .map(|r| self.receivers[r])
            })
            .collect();
        let mut out = vec![[[0.0; 3]; 6]; recv.len()];
        let t = Instant::now();
        let stats = self.projector.gather(
            &self.scene(),
            &Emission {
                coefficients: &e,
                power: &p,
            },
            self.settings.collision,
            &recv,
            &mut out,
        )?;
        work.gather += stats;
        work.projector_seconds += t.elapsed().as_secs_f64();
        for (c, r) in out.iter_mut().zip(&recv) {
            self.to_total(r.cell as usize, c);
        }
        let mut it = out.into_iter();
        Ok(leaves
            .iter()
            .map(|&i| {
                if self.receiver_of.get(i).copied().flatten().is_some() {
                    it.next().unwrap_or_default()
                } else {
                    [[0.0; 3]; 6]
                }
            })
            .collect())
    }

    /// Routes receiver `r`'s (total) collided power to its faces
    /// ([`Routing::matrix`] per channel: what is scattered and not re-collided).
    fn scatter(&self, r: usize, collided: &FaceRgb) -> FaceRgb {
        let i = self.receivers[r].cell as usize;
        let mut out = [[0.0; 3]; 6];
        for (c, rt) in self.routing[i].iter().enumerate() {
            let g = rt.matrix();
            for (fi, row) in g.iter().enumerate() {
                for (fj, &gij) in row.iter().enumerate() {
                    out[fj][c] += gij * collided[fi][c];
                }
            }
        }
        out
    }

    /// `y = K chi` for every leaf (non-receivers get 0) and the collided powers.
    ///
    /// # Errors
    /// Backend errors.
    pub fn apply(
        &self,
        chi: &[FaceRgb],
        work: &mut Work,
    ) -> Result<(Vec<FaceRgb>, Vec<FaceRgb>), VolumeError> {
        let (e, p) = self.emission(chi);
        let projected = self.transport.get().is_none();
        let collided = self.gather(&e, &p, 0..self.receivers.len(), work)?;
        work.applications += 1;
        let mut y = vec![[[0.0; 3]; 6]; self.len()];
        for (r, c) in collided.iter().enumerate() {
            y[self.receivers[r].cell as usize] = self.scatter(r, c);
        }
        if projected && self.settings.transport_memory > 0 && self.first_iterate.get().is_none() {
            // The first full sweep: keep `sources + K chi` (bitwise Jacobi's next
            // iterate) for the recording.
            let mut x = self.sources.clone();
            for (a, b) in x.iter_mut().zip(&y) {
                add(a, b);
            }
            let _ = self.first_iterate.set(x);
        }
        Ok((y, collided))
    }

    /// One Jacobi sweep: `chi ← sources + K chi`. Returns the largest update relative
    /// to the largest face power, and the collided powers of the sweep.
    ///
    /// # Errors
    /// Backend errors.
    pub fn jacobi(
        &self,
        chi: &mut [FaceRgb],
        work: &mut Work,
    ) -> Result<(f64, Vec<FaceRgb>), VolumeError> {
        let (y, collided) = self.apply(chi, work)?;
        let mut new = self.sources.clone();
        for (n, k) in new.iter_mut().zip(&y) {
            add(n, k);
        }
        let d = max_update(chi, &new);
        chi.copy_from_slice(&new);
        Ok((d, collided))
    }

    /// One blocked Gauss–Seidel sweep: receivers in blocks of
    /// [`GAUSS_SEIDEL_BLOCK`] in leaf order; each block gathers with the faces updated
    /// by the blocks before it (deterministic: the blocks do not depend on the thread
    /// count).
    ///
    /// # Errors
    /// Backend errors.
    pub fn gauss_seidel(
        &self,
        chi: &mut [FaceRgb],
        work: &mut Work,
    ) -> Result<(f64, Vec<FaceRgb>), VolumeError> {
        let before = chi.to_vec();
        let (mut e, mut p) = self.emission(chi);
        let mut collided = vec![[[0.0; 3]; 6]; self.receivers.len()];
        let nr = self.receivers.len();
        let mut start = 0;
        while start < nr {
            let end = (start + GAUSS_SEIDEL_BLOCK).min(nr);
            let c = self.gather(&e, &p, start..end, work)?;
            for (k, cr) in c.iter().enumerate() {
                let r = start + k;
                let i = self.receivers[r].cell as usize;
                let mut v = self.sources[i];
                add(&mut v, &self.scatter(r, cr));
                chi[i] = v;
                let (ei, pi) = self.leaf_emission(i, &v);
                e[i] = ei;
                p[i] = pi;
                collided[r] = *cr;
            }
            start = end;
        }
        work.applications += 1;
        Ok((max_update(&before, chi), collided))
    }

    /// GMRES on `(I − K) chi = sources` from the initial guess `chi` (all three
    /// channels in one vector of `18 ×` leaves unknowns). Stops at relative residual
    /// `tolerance` or after `max_iterations` operator applications.
    ///
    /// # Errors
    /// Backend errors and GMRES breakdowns.
    pub fn gmres(
        &self,
        chi: &mut [FaceRgb],
        tolerance: f64,
        max_iterations: usize,
        work: &mut Work,
    ) -> Result<(f64, usize), VolumeError> {
        use wavelux_linear::{FnOperator, SolverOptions, gmres};
        let n = 18 * self.len();
        if n == 0 {
            return Ok((0.0, 0));
        }
        // Validate once so that the operator below cannot fail.
        let _ = self.apply(chi, work)?;
        let cell = std::cell::RefCell::new(Work::default());
        let op = FnOperator::new(n, |x: &[f64], y: &mut [f64]| {
            let xs = unflatten(x);
            let mut w = cell.borrow_mut();
            match self.apply(&xs, &mut w) {
                Ok((k, _)) => {
                    let kf = flatten(&k);
                    for i in 0..n {
                        y[i] = x[i] - kf[i];
                    }
                }
                Err(_) => y.fill(f64::NAN),
            }
        });
        let b = flatten(&self.sources);
        let opts = SolverOptions::default()
            .with_tolerance(tolerance)
            .with_max_iterations(max_iterations.max(1))
            .with_restart(30)
            .with_initial_guess(flatten(chi));
        let sol = gmres(&op, &b, &opts).map_err(|e| VolumeError::Solver(e.to_string()))?;
        let inner = cell.into_inner();
        work.gather += inner.gather;
        work.applications += inner.applications;
        work.projector_seconds += inner.projector_seconds;
        work.recorded += inner.recorded;
        work.transport_entries += inner.transport_entries;
        work.replayed += inner.replayed;
        let new = unflatten(&sol.x);
        chi.copy_from_slice(&new);
        let rel = sol.history.final_relative_residual;
        Ok((rel, sol.history.iterations.len().saturating_sub(1)))
    }

    /// Energy account of the state `chi` with its collided powers.
    ///
    /// # Errors
    /// Backend errors of the escape measurement.
    pub fn energy(&self, chi: &[FaceRgb], collided: &[FaceRgb]) -> Result<Energy, VolumeError> {
        let mut en = Energy::default();
        for s in &self.sources {
            for f in s {
                for c in 0..3 {
                    en.emitted[c] += f[c];
                }
            }
        }
        for (r, col) in collided.iter().enumerate() {
            let i = self.receivers[r].cell as usize;
            for f in col {
                for c in 0..3 {
                    en.collided[c] += f[c];
                    en.absorbed[c] += (1.0 - self.data.albedo[i][c]) * f[c];
                }
            }
        }
        let (e, p) = self.emission(chi);
        en.escaped = self.projector.escape(
            &self.scene(),
            &Emission {
                coefficients: &e,
                power: &p,
            },
            self.settings.escape_framebuffer as u32,
        )?;
        Ok(en)
    }
}

/// Which faces of an opaque leaf are exposed: the voxel just outside the face's centre
/// is outside the grid or not opaque.
pub(crate) fn exposed_faces(t: &Traversal, n: usize, l: &crate::active::Leaf) -> [bool; 6] {
    let o = l.origin().map(i64::from);
    let s = i64::from(l.size());
    std::array::from_fn(|f| {
        let axis = f / 2;
        let mut v = o.map(|c| c + s / 2);
        v[axis] = if f % 2 == 1 { o[axis] - 1 } else { o[axis] + s };
        if v.iter().any(|&c| c < 0 || c >= n as i64) {
            return true;
        }
        let lin = v[0] as usize + n * (v[1] as usize + n * v[2] as usize);
        t.cells[t.map[lin] as usize].extinction != f64::INFINITY
    })
}

/// Receivers per Gauss–Seidel block.
pub const GAUSS_SEIDEL_BLOCK: usize = 256;

fn add(a: &mut FaceRgb, b: &FaceRgb) {
    for s in 0..6 {
        for c in 0..3 {
            a[s][c] += b[s][c];
        }
    }
}

/// `max |new − old| / max |new|` over all faces and channels.
#[must_use]
pub fn max_update(old: &[FaceRgb], new: &[FaceRgb]) -> f64 {
    let (mut d, mut m) = (0.0f64, 0.0f64);
    for (a, b) in old.iter().zip(new) {
        for s in 0..6 {
            for c in 0..3 {
                d = d.max((a[s][c] - b[s][c]).abs());
                m = m.max(b[s][c].abs());
            }
        }
    }
    if m > 0.0 { d / m } else { d }
}

/// Flattens face powers (18 per leaf).
#[must_use]
pub fn flatten(x: &[FaceRgb]) -> Vec<f64> {
    x.iter()
        .flat_map(|f| f.iter().flat_map(|c| c.iter().copied()))
        .collect()
}

/// Inverse of [`flatten`].
#[must_use]
pub fn unflatten(x: &[f64]) -> Vec<FaceRgb> {
    x.chunks_exact(18)
        .map(|c| std::array::from_fn(|s| [c[3 * s], c[3 * s + 1], c[3 * s + 2]]))
        .collect()
}
