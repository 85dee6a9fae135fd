//! wavelux-volume: volume radiosity with the hierarchical Global Cube (Hubeli,
//! Lippert, Gross; "GlobalCube" §2–§5).
//!
//! # The model
//! The paper states its model loosely; this crate implements the following, and every
//! test and reproduction refers to it.
//!
//! * **Cells.** A cell is a homogeneous cube of side `h`: opacity `σ = 1 − e^{−A}`
//!   across one side (optical depth `A`, extinction `A/h`), scattering albedo `ω`
//!   (RGB), source `χᵗ` (W/m³, RGB: power leaving the cell per unit volume). A cell
//!   does not interact with itself (`m_pp = 1`, §3.1). `σ = 1` is an opaque
//!   Lambertian box of reflectance `ω` (§2.1: surfaces as thin volumes). Outside the
//!   grid is a black boundary.
//! * **Unknowns.** Per active cell, face and channel the outgoing power `Chi[p][side]`
//!   (§3.2's pseudocode); a source puts `χᵗ h³/6` on every face.
//! * **Gathering** (§3.1, Fig. 3). A receiver gathers through a cube map at its centre:
//!   six 90° frusta of `N × N` pixels ([`cubemap`]). Each pixel's ray composites the
//!   cells it crosses front to back (the paper's back-to-front slices give the same
//!   sum), exactly chord by chord: a chord `ℓ` has opacity `1 − (1 − σ)^{ℓ/h}`. The
//!   tables of §3.2: each pixel's exact solid angle (the distance correction, eq.
//!   (29)), and the receiver's collision weights per entry face (the directional and
//!   positional corrections, eq. (30), Fig. 6) — see below.
//! * **Senders.** A sender contributes `S(ω) · α(ω)` (colour × opacity): `α` is the
//!   chord's opacity, `S` the coefficient `e_s = 6 Chi_s / (Ĝ h²)` of the face `s` the
//!   ray enters the sender through (the face the light leaves it by; over the cell's
//!   cross-section this is the projected-area mean of the faces `ω` leaves by, and a
//!   face hidden behind a touching opaque cell is never seen), normalised so that the cell emits
//!   exactly `Σ Chi` over all directions. So opaque cells are non-leaking Lambertian
//!   boxes (intensity `P Σ|ω_i| / 6π`: `P/6π` on an axis), thin cells isotropic
//!   emitters (`P/4π`), and a uniform radiance field is reproduced exactly.
//! * **Receivers** collide what the same opacities remove (eq. (31)), credited to
//!   their entry faces: the exact opacity-weighted projected area of a homogeneous
//!   cube per entry face, `G_i(ω)` ([`cell`]), integrated to `Ĝ` over all directions;
//!   the pixel weights are scaled so that they sum to `Ĝ` exactly. The paper's plain
//!   `σ` weight is [`cell::Collision::Plain`].
//! * **Routing** (Γ, eq. (32); [`flight`]). The scattered power `ω C_i` collided
//!   through face `i` leaves through face `j` with `Γ_ij = (1 − σ) F_ij` (`F`: the
//!   cube's interior face form factors, opposite 0.19982, adjacent 0.20004) and
//!   `Γ_ii = σ`. As printed, `Γ_ii = 1`, so a row sums to `2 − σ` and creates energy,
//!   against the paper's own claim that the form factors guarantee no energy is
//!   introduced; the default `Γ_ii = σ` makes rows sum to 1 (an opaque cell reflects
//!   through the face it was lit on, a clear one passes light to the other faces).
//!   The printed form is [`cell::GammaMode::Printed`]. The alternative
//!   [`cell::GammaMode::FirstFlight`] is the exact first-flight routing of a
//!   homogeneous cube: of light entering face `i` under uniform radiance and
//!   scattered once, the fraction `Γ_ij = ∫_V E_i E_j dV / (4π ∫_V E_i dV)` leaves by
//!   face `j` (`E_j(x)`: face `j`'s attenuated solid angle from `x`); the rest
//!   collides in the cell again and is then treated as born uniformly in it. Thin
//!   cells send 24 % of what they scatter back through the entry face, 16 % through
//!   each side face and 12 % through the opposite one (`Γ_ii = σ`: 0 and 20 %); an
//!   `A = 1.25` cell returns 34 % of what leaves it by the entry face (`Γ_ii = σ`:
//!   71 %). Both conserve energy; which is closer to the Monte Carlo tracer depends
//!   on the depth ("Thick, bright media" below), so the paper's form with `Γ_ii = σ`
//!   stays the default.
//! * **Self-interaction.** Sources leave their cell without colliding in it (`m_pp =
//!   1`, §3.1). Scattered light does collide in its own cell again with the
//!   probability `π = 1 − Ĝ/(4πA)` of light born uniformly in a cube (a geometric
//!   series per cell, energy-conserving; [`cell::SelfInteraction`]): without it an
//!   optically thick, bright cell (A = 1.25, ω = 0.99) collides a third too little
//!   against the Monte Carlo reference. `SelfInteraction::None` is the paper.
//!
//! # Energy conservation and the receiver's samples
//! Γ conserves energy inside a cell, and a uniform field is gathered exactly; but the
//! transport between cells is a gather at one point per receiver (its centre, or its
//! faces' centres when it is opaque or touches an opaque cell), so it is not
//! reciprocal, and near a sender that point is not the receiver's mean: an opaque
//! cell next to a source cell collides 27 % too little from its centre (+24 % from
//! the shared face's centre), two opaque faces across a one-voxel gap see each other
//! with the point form factor 0.239 instead of the mean 0.1998. The bias is a few per
//! cent per bounce on real scenes and multiple scattering multiplies it by about
//! `1/(1 − ρ)`: on `gc-lounge-8` (levels 0, N = 8, supersampling on) absorbed +
//! escaped exceeds emitted by 8.0 % (2.9 % with every albedo 0), on the Cornell box
//! voxelised at 8³ by 6.3 % (3.2 % single bounce). It is a discretisation error: it
//! falls with the receiver's size relative to its neighbours. The knob is
//! [`backend::cpu::CpuProjector::receiver_samples`] `k`: `k³` ray origins per cell
//! (`k²` per face of an opaque cell, and per boundary square of the escape
//! measurement) integrate the receiver by the midpoint rule, error `O(1/k²)`
//! (`tests/receiver_samples.rs`: the closed-form case above, −27 % → +9.7 % → +1.3 %
//! for `k` = 1, 2, 4), at `k²`–`k³` times the projection cost. `k = 1` is the paper
//! ([`backend::cpu::CpuProjector::new`]); the default
//! ([`backend::cpu::CpuProjector::default`], the command's `--receiver-samples`) is
//! [`backend::cpu::DEFAULT_RECEIVER_SAMPLES`] `= 2`, the conservative operator.
//!
//! **Adaptive supersampling and sub-pixel emitters.** The CPU projector supersamples
//! a pixel whose centre ray's radiance contrasts with a neighbour's
//! ([`backend::cpu::AntiAlias`]). An emitter smaller than the pixel spacing is then
//! corrected to its true coverage in the views where a centre ray hits it (point
//! sampling over-counts it there) and stays missed in those where every centre ray
//! passes beside it (point sampling under-counts it there): point sampling alone is
//! right on average over positions, the correction of the hits alone is a one-sided
//! loss. It is the largest when the pixels are chosen on the emitters alone, and it
//! falls as the emitter covers more pixels. Measured on the Cornell box voxelised at
//! 16³ (closed, so absorbed = emitted is exact; `tests/supersampling.rs`): at
//! `N = 4` point sampling absorbs 0.995 of the emitted power; supersampling chosen on
//! the bare sources 0.783 (the light's faces' column sums, weighted by their power,
//! 0.783: the whole loss is the light's first flight), chosen on the first Jacobi
//! iterate (what a recorded solve does, [`system`] docs) 0.941; at `N = 8` 0.992
//! (point sampling 1.022). Session 28's 0.78 at `N = 4` was GMRES recording on its
//! initial guess, the bare sources; GMRES and Jacobi now record the same map.
//!
//! **Thick, bright media** (the open defect of issue 14: a uniformly emitting cube of
//! optical depth 10 across `8³` voxels, `A = 1.25` per voxel, `ω = 0.99`, `N = 8`:
//! with the paper's one-point escape the account loses 10.8 % with `k = 1`, and the
//! particle tracer escapes 0.915 of the emitted power against the model's 0.80).
//! Measured mechanism, two parts:
//! 1. *Point sampling at the grid's boundary.* One face of one cell emitting 1 W,
//!    collided plus escaped power: inside the medium 0.998–1.001 (the point-sampling
//!    biases cancel by translation symmetry); at the boundary they do not. The
//!    paper's escape looks from each boundary square's centre, the point with the
//!    longest chord through the thick boundary cell: it counts the cell's own outer
//!    face 1.24 times and light from its neighbours' side faces too little (a side
//!    face 0.92, along an edge 0.86). The faces' powers differ strongly in such a
//!    medium (an outer face is never lit), and about nine collisions per emitted
//!    watt multiply the per-bounce deficit. The *conserving escape* (`k ≥ 2`,
//!    [`backend`] docs) counts the boundary cells' own outer faces exactly (1.0000,
//!    `tests/conservation.rs`) and moves the sample points from pixel to pixel.
//! 2. *Routing.* `Γ_ii = σ` sends 71 % of what an `A = 1.25` cell scatters back
//!    through its entry face, first flights 34 % of what leaves (the rest leaves 6.7 %
//!    by the opposite face, 14.7 % by each side face, [`flight`]), so the model keeps
//!    light inside thick media: it collides 9.4 times per emitted watt (`k = 2`)
//!    against the tracer's 8.6. With the first-flight routing it collides 7.6 times:
//!    the model's faces emit uniformly over their area, so light that left a cell by
//!    a side face near its entry face is moved to the middle of that face, deeper
//!    into the medium, and re-collided light is treated as born uniformly in the cell.
//!
//! Measured at `k = 2` with the conserving escape (`8³`, `N = 8`, GMRES 1e-8; the
//! tracer: absorbed 0.086 / escaped 0.915 at `ω = 0.99`, 0.705 / 0.294 at `ω = 0.5`):
//! `Γ_ii = σ`: `ω = 0.99` absorbed 0.094, escaped 0.868, balance +3.8 % (+5.2 % with
//! the one-point escape); `ω = 0.5` 0.704 / 0.286, +1.0 %. First flight: `ω = 0.99`
//! 0.076 / 0.892, +3.3 %; `ω = 0.5` 0.693 / 0.297, +1.0 %. Against the tracer's
//! collided power per `2³` block (`k = 1`, `render/tests/volume_model.rs`) the first
//! flight is closer at `τ = 1` (L1 0.043 against 0.047 at `ω = 0.5`, 0.042 against
//! 0.057 at `ω = 0.99`) and further at `τ = 10` (0.030 against 0.020; the slab 0.065
//! against 0.035). What is left is the face-level model's spatial resolution inside a
//! cell, a discretisation error that falls with refinement at moderate depths.
//!
//! # Hierarchy
//! The non-standard 3D Haar decomposition (seven wavelet types, eqs. (25)–(27)) of
//! `χᵗ` and σ by `wavelux_mra::tensor`, with `M = m0 + L` ([`hierarchy`]; thresholds
//! in the paper's averaging units); active cells are octree leaves of mixed level
//! ([`active`]); the framebuffer side follows the level (the paper's 16², 32², 64² for
//! the 16³, 32³, 64³ levels), capped. The solve loop with the static and dynamic
//! oracles and eqs. (33)–(34) is [`mod@solve`]; the relaxations (Jacobi eq. (28),
//! Gauss–Seidel, GMRES) are in [`system`].
//!
//! # Surfaces
//! [`voxelize()`] rasterises a surface scene into opaque cells (GlobalCube §2.1's
//! surfaces as thin volumes) inside a black opaque shell, so one scene can be solved by
//! both the surface methods and the global cube.
//!
//! # Backends
//! The projection is the [`backend::Projector`] trait with the CPU implementation
//! [`backend::cpu::CpuProjector`] (modes `exact` and `pyramid`) and a conformance
//! suite ([`backend::conformance`]) for every backend (wgpu comes later). While an
//! active set is relaxed, the gather is linear in the emission, so the system has the
//! projector record it once ([`backend::Projector::record`], [`backend::Transport`])
//! and replays it instead of re-projecting at every relaxation ([`system`] docs); with
//! adaptive supersampling the recording keeps the pixels supersampled at the sweep
//! that records.
//!
//! # Deviations from the paper (see also `docs/architecture.md`)
//! Exact chords instead of point-sampled slices; exact collision weights instead of
//! the plain `σ` weight (optional); `Γ_ii = σ` instead of 1 (optional; or the
//! first-flight routing); the conserving escape with `k ≥ 2`; eq. (33)'s
//! undefined `χ^f` read as `χᵗ`; the pseudocode's `Chi += …` read as `=`; optional
//! receiver samples (two per axis by default; one point is the paper's).

pub mod active;
pub mod backend;
pub mod cell;
pub mod cubemap;
pub mod error;
pub mod flight;
pub mod grid;
pub mod hierarchy;
pub mod solution;
pub mod solve;
pub mod system;
pub mod voxelize;

pub use backend::cpu::{CpuProjector, Projection};
pub use backend::{Projector, TraversalCell};
pub use cell::{Collision, GammaMode, SelfInteraction};
pub use error::VolumeError;
pub use grid::VolumeGrid;
pub use hierarchy::CoarseOpacity;
pub use solution::{VolumeSolution, q_square, rms};
pub use solve::{
    GlobalCubeConfig, Oracle, Refined, Relaxation, StepRecord, Threshold, solve,
    solve_with_snapshots,
};
pub use system::Energy;
pub use voxelize::voxelize;
