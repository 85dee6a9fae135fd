//! The JSON result (schema `wavelux-result`, version 1; documented in `docs/cli.md`).

use serde::{Deserialize, Serialize};

/// Name of the schema.
pub const SCHEMA: &str = "wavelux-result";
/// Version of the schema.
pub const VERSION: u32 = 1;

/// A complete result file.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Result {
    /// Always [`SCHEMA`].
    pub schema: String,
    /// Always [`VERSION`].
    pub version: u32,
    /// The scene.
    pub scene: SceneInfo,
    /// Method and every knob that was used.
    pub method: MethodInfo,
    /// Per surface results.
    pub surfaces: Vec<SurfaceResult>,
    /// Error estimate against a quick Monte Carlo check (null when skipped).
    pub error_estimate: Option<ErrorEstimate>,
    /// Why `error_estimate` is null (`--samples 0`, or why the check could not run);
    /// null when there is an estimate, and for the reference (whose surfaces carry
    /// their own standard errors).
    #[serde(default)]
    pub error_estimate_skipped: Option<String>,
    /// Every warning of the run, as printed on stderr: what the loader dropped or
    /// changed, scene features the method does not model, a skipped error check.
    /// `--strict` turns them into errors.
    #[serde(default)]
    pub warnings: Vec<WarningInfo>,
    /// Run statistics.
    pub statistics: Statistics,
    /// Files written (null entries were not written).
    pub outputs: Outputs,
}

/// One warning.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WarningInfo {
    /// A stable tag: a loader warning's kind (`degenerate-triangles-dropped`,
    /// `grouping-fallback`, `reflectance-clamped`, ...), `not-modelled` for a scene
    /// feature the method does not model, `error-check-skipped`.
    pub kind: String,
    /// The scene file (null for warnings that are not about a file).
    pub file: Option<String>,
    /// The element: a glTF primitive, a surface, a material, a medium, ...
    pub element: String,
    /// The whole warning in words (what stderr shows after `wavelux: warning: `).
    pub message: String,
    /// For `not-modelled`: the method that models the feature, when this build has it.
    #[serde(default)]
    pub use_method: Option<String>,
}

/// The scene.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct SceneInfo {
    /// As given on the command line.
    pub source: String,
    /// Scene name.
    pub name: String,
    /// Number of surfaces.
    pub surfaces: usize,
    /// Total area of the surfaces (scene units², one side each).
    pub total_area: f64,
    /// Emitted power Σ area·E (W per channel).
    pub emitted_power: [f64; 3],
}

/// Method and knobs.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct MethodInfo {
    /// `gather`, `shoot` or `reference`.
    pub name: String,
    /// Basis (`Haar`, `M2`, `M3`, `CDV`), null for the reference.
    pub basis: Option<String>,
    /// Refinement threshold.
    pub eps: Option<f64>,
    /// Oracle (`kernel`, `brightness`).
    pub oracle: Option<String>,
    /// Deepest level.
    pub max_level: Option<u8>,
    /// Smallest element area.
    pub min_area: Option<f64>,
    /// Linear solver.
    pub solver: Option<String>,
    /// Iteration cap.
    pub max_iterations: Option<usize>,
    /// Relative residual tolerance.
    pub tolerance: Option<f64>,
    /// Visibility mode.
    pub visibility: Option<String>,
    /// Gauss points per axis.
    pub quad: Option<usize>,
    /// `--cluster`: the clustering tolerance of the initial links (null: every root
    /// pair linked).
    #[serde(default)]
    pub cluster: Option<f64>,
    /// Shooting: target convergence rate `(E_i − E_r)/E_i` (null otherwise).
    #[serde(default)]
    pub convergence: Option<f64>,
    /// Shooting: shot limit (null otherwise).
    #[serde(default)]
    pub max_shots: Option<usize>,
    /// `--method meshless`: its whole configuration (null otherwise).
    #[serde(default)]
    pub meshless: Option<wavelux::meshless::MeshlessConfig>,
    /// `--method glossy`: its knobs (null otherwise).
    #[serde(default)]
    pub glossy: Option<serde_json::Value>,
    /// `--method global-cube`: its whole configuration (`wavelux_volume::GlobalCubeConfig`;
    /// null otherwise).
    #[serde(default)]
    pub global_cube: Option<serde_json::Value>,
    /// `--device`: what was requested, what ran, the adapter and why the CPU ran
    /// (null in results written before the option existed).
    #[serde(default)]
    pub device: Option<DeviceInfo>,
    /// Monte Carlo samples per surface (reference or error check).
    pub samples: u64,
    /// Worker threads.
    pub threads: usize,
    /// Seed.
    pub seed: u64,
}

/// The JSON's `method.device` (`--device`, docs/cli.md).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct DeviceInfo {
    /// `--device`: `cpu`, `gpu` or `auto`.
    pub requested: String,
    /// What ran the method's GPU-capable kernels: `cpu`, `gpu`, or `gpu+cpu` when a
    /// device failure moved the rest of the run to the CPU.
    pub used: String,
    /// The adapter's name (null when none was opened).
    pub adapter: Option<String>,
    /// `discrete`, `integrated`, `virtual`, `cpu` (software, e.g. lavapipe) or `other`.
    pub device_type: Option<String>,
    /// The graphics API (`vulkan`).
    pub backend: Option<String>,
    /// Driver name and version.
    pub driver: Option<String>,
    /// Why the CPU ran instead of the requested or available GPU (null when it did not).
    pub fallback: Option<String>,
}

/// `"front"`: [`SurfaceResult::side`] of reports written before it existed.
fn front_side() -> String {
    "front".into()
}

/// One surface.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct SurfaceResult {
    /// Surface name (glTF node name, else mesh name, else a stable generated name).
    pub name: String,
    /// Area of one side (scene units²).
    pub area: f64,
    /// The side reported: `"front"`, or `"back"` for a two-sided surface whose front
    /// neither reflects nor emits and whose back does (an inward surface written as a
    /// black front, e.g. a sphere fitted to a mesh facing its centre).
    #[serde(default = "front_side")]
    pub side: String,
    /// Emitted exitance E of the reported side (W/m²).
    pub emission: [f64; 3],
    /// Diffuse reflectance ρ of the reported side.
    pub reflectance: [f64; 3],
    /// Area-averaged exitant radiosity B of the reported side (W/m², same units as E).
    pub radiosity: [f64; 3],
    /// Standard error of `radiosity` (Monte Carlo reference only, else null).
    pub std_error: Option<[f64; 3]>,
}

/// Error estimate against the Monte Carlo check.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ErrorEstimate {
    /// `Σ_s A_s Σ_c |B_sc − B̂_sc| / Σ_s A_s Σ_c |B̂_sc − E_sc|` against the check's
    /// averages (relative to the reflected radiosity: emitters' `E` is exact).
    pub relative_l1: f64,
    /// The same with the check's standard errors in place of the difference: the noise
    /// floor of `relative_l1`.
    pub check_noise: f64,
    /// Largest |B − B̂| / (standard error) over surfaces and channels.
    pub max_z: f64,
    /// Monte Carlo samples per surface.
    pub samples: u64,
}

/// Wall time per phase (seconds).
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct Times {
    /// Loading and validating the scene.
    pub load: f64,
    /// Supports, accelerator, rule setup.
    pub setup: f64,
    /// Refinement and link computation.
    pub refine: f64,
    /// Linear solves.
    pub solve: f64,
    /// A-posteriori error estimates (`--target-error`; 0 otherwise).
    #[serde(default)]
    pub estimate: f64,
    /// Monte Carlo (reference or error check).
    pub monte_carlo: f64,
    /// Rendering.
    pub render: f64,
    /// Writing files.
    pub write: f64,
    /// Whole run.
    pub total: f64,
}

/// Run statistics.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct Statistics {
    /// Wall times.
    pub time_s: Times,
    /// Quadtree nodes over all patches.
    pub elements: usize,
    /// Leaf elements (unknown blocks).
    pub leaves: usize,
    /// Links stored.
    pub links: usize,
    /// Cluster links (`--cluster`; not counted in `links`).
    #[serde(default)]
    pub cluster_links: usize,
    /// Links split during refinement.
    pub refined_links: u64,
    /// Oracle evaluations.
    pub oracle_evaluations: u64,
    /// Kernel evaluations.
    pub kernel_evaluations: u64,
    /// Shadow rays of the solver.
    pub solver_rays: u64,
    /// Rays traced on the GPU (`--device gpu|auto`; the global cube's pixel rays;
    /// null when no GPU kernel ran).
    #[serde(default)]
    pub device_rays: Option<u64>,
    /// Rays of GPU-capable kernels the CPU traced instead after a device failure (null
    /// when no GPU kernel ran).
    #[serde(default)]
    pub deferred_rays: Option<u64>,
    /// Primary rays of the image.
    pub primary_rays: u64,
    /// Final-gather rays.
    pub gather_rays: u64,
    /// Shadow rays of the image's exact direct light (`--direct`).
    pub direct_rays: u64,
    /// Bytes held by the solver's hierarchy, links and vectors.
    pub solver_bytes: usize,
    /// Peak resident memory of the process (bytes; null where unknown).
    pub peak_memory_bytes: Option<u64>,
    /// Iterations per channel solve.
    pub iterations: Vec<usize>,
    /// Relative residual after each iteration, per channel solve.
    pub residual_history: Vec<Vec<f64>>,
    /// Energy balance: emitted, absorbed, escaped and unshot power (W per channel).
    pub energy: Option<Energy>,
    /// Shooting: number of shots (null otherwise).
    #[serde(default)]
    pub shots: Option<usize>,
    /// Shooting: input primitives that shot at least once (VirtualMesh Table 1's
    /// "# shooting surfaces"; null otherwise).
    #[serde(default)]
    pub shooting_surfaces: Option<usize>,
    /// Shooting: convergence rate `(E_i − E_r)/E_i` after each shot (empty otherwise).
    #[serde(default)]
    pub convergence_history: Vec<f64>,
    /// `--target-error`: the a-posteriori estimate, what the solver chose and why,
    /// and every refine-solve-estimate round (null otherwise).
    #[serde(default)]
    pub target: Option<TargetReport>,
    /// `--method meshless`: precomputation and frame statistics (null otherwise).
    #[serde(default)]
    pub meshless: Option<MeshlessStats>,
    /// `--method glossy`: the solver's counts, bytes, phase times and rounds
    /// (`wavelux_glossy::GlossyStats`; null otherwise).
    #[serde(default)]
    pub glossy: Option<serde_json::Value>,
    /// `--method global-cube`: the medium, energy account, solve steps and timings
    /// (null otherwise).
    #[serde(default)]
    pub volume: Option<VolumeStats>,
}

/// Statistics of `--method global-cube` (GlobalCube Table 1's quantities and the
/// energy account).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct VolumeStats {
    /// The medium's name.
    pub medium: String,
    /// `--voxelize N` (null for a medium of the scene).
    pub voxelized: Option<usize>,
    /// Voxels per axis of the padded cubic lattice.
    pub side: usize,
    /// The medium's voxel counts `[nx, ny, nz]` before padding.
    pub extent: [usize; 3],
    /// Voxel edge (scene units).
    pub voxel: f64,
    /// Active cells of the final solution.
    pub elements: usize,
    /// The projection backend.
    pub projector: String,
    /// Source power per channel (W).
    pub emitted: [f64; 3],
    /// Absorbed power per channel (W).
    pub absorbed: [f64; 3],
    /// Power escaped through the lattice's boundary per channel (W).
    pub escaped: [f64; 3],
    /// Collided power per channel (W).
    pub collided: [f64; 3],
    /// `(emitted − absorbed − escaped) / emitted` per channel.
    pub balance_error: [f64; 3],
    /// Every step of the solve loop (`wavelux_volume::StepRecord`: level, step, kind,
    /// elements, static and dynamic refinements, relaxations, largest update, seconds,
    /// energy).
    pub steps: serde_json::Value,
    /// Projector work (`wavelux_volume::system::Work`).
    pub work: serde_json::Value,
    /// Wall seconds of the solve.
    pub solve_seconds: f64,
}

/// The target-error loop of a run (`--target-error`).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct TargetReport {
    /// The target relative L1 error of the radiosity function.
    pub target: f64,
    /// Whether the estimate reached it.
    pub reached: bool,
    /// Why the loop stopped.
    pub stop_reason: String,
    /// The a-posteriori estimate of the final solution's relative L1 error
    /// (`Σ_c ∫|e_c| / Σ_c ∫|B_c − E_c|` over real points).
    pub estimate: f64,
    /// The residual alone (the local part of the estimate), relative as above.
    pub residual: f64,
    /// The relative error every face side had to reach as well (the target unless
    /// set otherwise).
    pub face_target: f64,
    /// The face side with the largest estimated relative L1 error and that error
    /// (`surface` or `surface (back)`); faces darker than 1 % of the scene's mean
    /// reflected radiosity are judged relative to that 1 %.
    pub worst_face: String,
    /// See `worst_face`.
    pub worst_face_estimate: f64,
    /// The basis chosen (or given) and why.
    pub basis: String,
    /// Why that basis.
    pub basis_reason: String,
    /// Initial brightness threshold (W/m²) and why.
    pub eps: f64,
    /// Why that threshold.
    pub eps_reason: String,
    /// Relative residual tolerance of the linear solves.
    pub tolerance: f64,
    /// Every round.
    pub rounds: Vec<TargetRound>,
}

/// One refine-solve-estimate round.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct TargetRound {
    /// Links solved with.
    pub links: usize,
    /// Leaves (unknown blocks).
    pub leaves: usize,
    /// Links split before this round.
    pub refined: u64,
    /// Estimated relative L1 error after the round.
    pub estimate: f64,
    /// The largest estimated relative L1 error of a face side after the round.
    pub worst_face_estimate: f64,
    /// Wall times (s): refinement and link blocks, linear solves, the estimate.
    pub time_refine_s: f64,
    /// See `time_refine_s`.
    pub time_solve_s: f64,
    /// See `time_refine_s`.
    pub time_estimate_s: f64,
    /// Shadow rays of the estimate.
    pub estimate_rays: u64,
    /// Links whose fine transport the estimate reused from the previous round (no
    /// kernel samples or rays spent on them again).
    pub estimate_reused_links: u64,
}

/// Statistics of `--method meshless`.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct MeshlessStats {
    /// Whether the transfer was read from `--transfer` (its precomputation statistics
    /// are then those of the run that built it).
    pub transfer_loaded: bool,
    /// The transfer backend.
    pub backend: String,
    /// Hash of the scene the transfer belongs to (hex).
    pub scene_hash: String,
    /// Points, links, rays, bytes and phase times (ms) of the precomputation.
    pub precompute: wavelux::meshless::PrecomputeStats,
    /// Times (ms) of the frame: direct irradiance, pull-push, `S·e`.
    pub frame: wavelux::meshless::FrameTimes,
}

/// Energy accounting (W per channel).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Energy {
    /// Σ E·A.
    pub emitted: [f64; 3],
    /// Σ (1 − ρ) ∫H.
    pub absorbed: [f64; 3],
    /// Power leaving the modelled sides.
    pub escaped: [f64; 3],
    /// Power not yet propagated.
    pub unshot: [f64; 3],
}

/// Output files.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct Outputs {
    /// Linear EXR.
    pub exr: Option<String>,
    /// Tone-mapped PNG.
    pub png: Option<String>,
    /// This JSON.
    pub json: Option<String>,
    /// Baked glTF export (`--gltf`).
    #[serde(default)]
    pub gltf: Option<String>,
    /// Lightmap directory (`--lightmaps`).
    #[serde(default)]
    pub lightmaps: Option<String>,
    /// Texel file (`--texels`).
    #[serde(default)]
    pub texels: Option<String>,
    /// `--method global-cube`: the raw emission grid (`side³ × 3` little-endian f32, x
    /// fastest, RGB interleaved, W/m³).
    #[serde(default)]
    pub volume_emission: Option<String>,
    /// `--method global-cube`: slice PNGs of the emission density across x, y and z.
    #[serde(default)]
    pub volume_slices: Vec<String>,
}
