//! Command-line arguments (clap).

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand, ValueEnum};

/// Hierarchical and wavelet global illumination.
///
/// With no command: solve and render the built-in Cornell box with good defaults and
/// write out/cornell.exr, out/cornell.png and out/cornell.json.
#[derive(Parser)]
#[command(name = "wavelux", version, about, args_override_self = true)]
pub struct Cli {
    /// What to do (default: `solve builtin:cornell-box`).
    #[command(subcommand)]
    pub command: Option<Command>,
}

/// Used to get the defaults of `solve` when no command is given.
#[derive(Parser)]
#[command(args_override_self = true)]
pub struct SolveOnly {
    /// The arguments.
    #[command(flatten)]
    pub args: SolveArgs,
}

/// The commands.
#[derive(Subcommand)]
pub enum Command {
    /// Solve a scene, write its JSON result and an image from the scene's camera.
    #[command(args_override_self = true)]
    Solve(SolveArgs),
    /// Like `solve`, with the camera chosen by name or given by flags.
    #[command(args_override_self = true)]
    Render(RenderArgs),
    /// List the built-in scenes.
    Scenes,
    /// Error metrics between two results (JSON) or two images (EXR/PNG).
    Compare(CompareArgs),
    /// List the crates this build is made of.
    Crates,
    /// Relight a scene with precomputed meshless direct-to-indirect transfer
    /// (Meshless §3.3): per frame full and indirect images, optional bakes, and JSON.
    #[command(args_override_self = true)]
    Relight(RelightArgs),
}

/// Global illumination method.
#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum MethodArg {
    /// Wavelet radiosity with links (gathering; Ziegler ch. 2-4).
    Gather,
    /// Linkless hierarchical shooting on the Virtual Mesh (VirtualMesh §5, Southwell
    /// order: the patch with the most unshot power shoots next).
    Shoot,
    /// The Monte Carlo path tracer (reference / ground truth).
    Reference,
    /// Meshless hierarchical basis with precomputed direct-to-indirect transfer
    /// (Meshless §2-§3): one frame lit by the scene's lights and emitters.
    Meshless,
    /// Glossy global illumination with 4D Haar radiance, Ward BRDFs and importance
    /// (Glossy §3-§5).
    Glossy,
    /// Volume radiosity of a participating medium with the hierarchical Global Cube
    /// (GlobalCube §2-§5); surfaces only through --voxelize.
    GlobalCube,
}

/// Basis of the wavelet solver.
#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum BasisArg {
    /// Piecewise constants.
    Haar,
    /// Alpert multiwavelets, 2 functions per cell and axis.
    M2,
    /// Alpert multiwavelets, 3 functions per cell and axis.
    M3,
    /// Cohen-Daubechies-Vial D4 on the interval.
    Cdv,
}

/// Linear solver.
#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum SolverArg {
    /// Picard (Jacobi) iteration.
    Picard,
    /// Alias of picard.
    Jacobi,
    /// Hierarchical Gauss-Seidel.
    GaussSeidel,
    /// Southwell iteration: runs the linkless shooting solver (`--method shoot`),
    /// which relaxes the patch with the largest unshot power at each step.
    Southwell,
    /// Restarted GMRES(30).
    Gmres,
    /// CG on the normal equations.
    Cgnr,
}

/// Visibility in transfer blocks.
#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum VisibilityArg {
    /// One shadow ray per quadrature sample pair.
    Quadrature,
    /// Unoccluded block times a 4x4-ray visible fraction.
    Fractional,
    /// No visibility (every pair mutually visible; for testing).
    Off,
}

/// Refinement oracle.
#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum OracleArg {
    /// Kernel smoothness (eps dimensionless; gather's default).
    Kernel,
    /// Kernel smoothness times brightness (eps in W/m2).
    Brightness,
    /// Global cube: details of the source or opacity (GlobalCube §4.2).
    Static,
    /// Global cube: differences of a cell's face powers.
    Dynamic,
    /// Global cube: static first, then dynamic (the paper; global-cube's default).
    Both,
    /// Global cube: no oracle, every cell refined (the standard global cube).
    None,
}

/// Device of a method's GPU kernels (`--device`; issue 17, "Device selection").
#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum DeviceArg {
    /// The CPU (the reference for every kernel).
    Cpu,
    /// Any wgpu adapter, software ones (Mesa lavapipe) included; exits with status 2
    /// when there is none or the command was built without the `gpu` feature. A method
    /// with no GPU kernel for the chosen settings runs on the CPU with a warning.
    Gpu,
    /// A discrete or integrated GPU when the method has a kernel for the chosen
    /// settings, else the CPU; the reason is recorded in `method.device.fallback`.
    Auto,
}

/// Mesh grouping of the loaders (`wavelux_scene::MeshGrouping`).
#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum MeshGroupingArg {
    /// Connected coplanar triangles become complex polygons.
    Surfaces,
    /// Every triangle stays a triangle (exact parallelogram pairs merged).
    Triangles,
}

/// Options of `solve` (and `render`).
#[derive(Args, Clone, Debug)]
pub struct SolveArgs {
    /// Scene: a glTF file (.gltf/.glb), a native file (.toml) or builtin:NAME.
    #[arg(default_value = "builtin:cornell-box")]
    pub scene: String,
    /// Global illumination method.
    #[arg(long, value_enum, default_value_t = MethodArg::Gather)]
    pub method: MethodArg,
    /// Wavelet basis [default: m3 for gather, haar for shoot].
    #[arg(long, value_enum)]
    pub basis: Option<BasisArg>,
    /// Solve to this relative L1 error of the radiosity function (`0.01` or `1%`):
    /// refine-solve-estimate rounds until the a-posteriori estimate is below it; the
    /// basis (unless --basis), thresholds and depth are chosen by the solver and
    /// recorded in the JSON (`statistics.target`); --max-level is then only a safety
    /// limit [default: 10]. Without it, `gather` solves to 2 % unless --eps, --oracle,
    /// --max-level or --basis cdv ask for one fixed-threshold refinement.
    #[arg(long, value_parser = parse_fraction, conflicts_with_all = ["eps", "oracle"])]
    pub target_error: Option<f64>,
    /// With a target error (given or the default): every face side's own estimated
    /// relative L1 error must reach this as well (`0.03` or `3%`; `off`: the
    /// scene-wide target alone) [default: the target error]. A looser face goal is
    /// cheaper: the built-in Cornell box at 2 % reaches texel error 1.45 % with every
    /// face at 3 % in about a third of the CPU of every face at 2 % (1.10 %).
    #[arg(long, value_parser = parse_face_target)]
    pub face_target: Option<f64>,
    /// With a target error (given or the default): judge each face's goal by its worst
    /// channel, as the `cornell-faces` reproduction judges a face's mean, instead of
    /// with its three channels summed (the default), where a coloured face's dim
    /// channel weighs little
    #[arg(long)]
    pub face_channels: bool,
    /// With a target error (given or the default): the visibility of the error
    /// estimate's fine gather on partly visible links: `N` (1..=8) shoots, per
    /// residual point, one ray to the centre of each of N × N cells of the link's
    /// emitter, shared by the emitter samples in that cell; `traced` one ray per
    /// point and emitter sample (the rule before session 27). On the built-in Cornell
    /// box `3` traces half the estimate's rays of `traced` at a slightly lower texel
    /// error (docs/performance.md) [default: 3].
    #[arg(long, value_parser = parse_estimate_visibility)]
    pub estimate_visibility: Option<usize>,
    /// Cluster the initial links of `gather` (hierarchical radiosity with clustering,
    /// Smits, Arvo & Greenberg 1994): two groups of surfaces whose conservative
    /// transport bound is at most this fraction of the scene's predicted mean reflected
    /// radiosity (`0.01` or `1%`) get one cluster link instead of a link per pair of
    /// surfaces. Only with one fixed-threshold refinement (--eps, --oracle or
    /// --max-level) [default: off: every pair of surfaces is linked].
    #[arg(long, value_parser = parse_fraction)]
    pub cluster: Option<f64>,
    /// Refinement threshold (see --oracle for its unit); with `gather`, selects one
    /// fixed-threshold refinement instead of the default target error [default: 0.01;
    /// meshless: the dimensionless link threshold, 0.005].
    #[arg(long)]
    pub eps: Option<f64>,
    /// Deepest element level (0..=20); with `gather` and no --target-error, selects one
    /// fixed-threshold refinement [default: 2 for gather, 3 for shoot; the target
    /// error's safety limit: 10].
    #[arg(long)]
    pub max_level: Option<u8>,
    /// Smallest element area (scene units squared).
    #[arg(long, default_value_t = 0.0)]
    pub min_area: f64,
    /// Refinement oracle; with `gather`, selects one fixed-threshold refinement
    /// [default: kernel; global-cube: both].
    #[arg(long, value_enum)]
    pub oracle: Option<OracleArg>,
    /// Linear solver of `gather` [default: gmres]; `southwell` selects `--method shoot`.
    #[arg(long, value_enum)]
    pub solver: Option<SolverArg>,
    /// Shooting: stop once this fraction of the emitted power has been propagated,
    /// `(E_i − E_r)/E_i` in (0, 1].
    #[arg(long, default_value_t = 0.999)]
    pub convergence: f64,
    /// Shooting: at most this many shots.
    #[arg(long, default_value_t = 10_000)]
    pub max_shots: usize,
    /// Maximum iterations (sweeps) per channel.
    #[arg(long, default_value_t = 100)]
    pub max_iterations: usize,
    /// Relative residual tolerance of the linear solve [default: 1e-6; global-cube:
    /// the largest relative update, 1e-4].
    #[arg(long)]
    pub tolerance: Option<f64>,
    /// Visibility in transfer blocks.
    #[arg(long, value_enum, default_value_t = VisibilityArg::Quadrature)]
    pub visibility: VisibilityArg,
    /// Gauss points per axis of the transfer quadrature (1..=16).
    #[arg(long = "quad", default_value_t = 3)]
    pub quad: usize,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Device of the method's GPU kernels (the global cube's projection, the meshless
    /// transfer product); the JSON's
    /// `method.device` records what was requested, what ran and why.
    #[arg(long, value_enum, default_value_t = DeviceArg::Cpu)]
    pub device: DeviceArg,
    /// Seed of every random choice (image jitter, final gather, Monte Carlo).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Output directory of the image and JSON files.
    #[arg(long, default_value = "out")]
    pub out: PathBuf,
    /// Path of the JSON result (default: OUT/NAME.json).
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Print nothing but warnings and errors (no progress, no summary).
    #[arg(long, short)]
    pub quiet: bool,
    /// Turn every warning (what the loader dropped or changed, a scene feature the
    /// method does not model, a skipped error check) into an error.
    #[arg(long)]
    pub strict: bool,
    /// How triangle meshes of glTF and native files become surfaces: `surfaces`
    /// groups connected coplanar triangles into the polygons they tile (one support
    /// each); `triangles` keeps every triangle (the behaviour before grouping).
    #[arg(long, value_enum, default_value_t = MeshGroupingArg::Surfaces)]
    pub mesh_grouping: MeshGroupingArg,
    /// Image width in pixels.
    #[arg(long, default_value_t = 512)]
    pub width: usize,
    /// Image height in pixels.
    #[arg(long, default_value_t = 512)]
    pub height: usize,
    /// Samples per pixel along each axis (spp x spp per pixel).
    #[arg(long, default_value_t = 2)]
    pub spp: usize,
    /// Final-gather rays per pixel sample (0: no final gather). With --direct, they
    /// gather the solution's reflected light instead of showing its indirect part.
    #[arg(long, default_value_t = 0)]
    pub gather: usize,
    /// Exact direct light in the image: shadow rays per emitter and pixel sample
    /// (stratified; fully lit and fully shadowed points are exact whatever the count),
    /// plus the solution's indirect part (0: show the solution's radiosity itself).
    #[arg(long, default_value_t = 4)]
    pub direct: usize,
    /// Also export a glTF (+ .bin) with the radiosity baked into vertex colours here.
    #[arg(long)]
    pub gltf: Option<PathBuf>,
    /// Also write per-patch lightmap EXRs of this resolution into OUT/NAME-lightmaps/.
    #[arg(long)]
    pub lightmaps: Option<usize>,
    /// Write no image (JSON only).
    #[arg(long)]
    pub no_image: bool,
    /// Also write the radiosity at a lightmap-like texel grid of this density (texels
    /// per scene unit², every lit side) to OUT/NAME.texels.json, for `compare`.
    #[arg(long)]
    pub texels: Option<f64>,
    /// Path-traced walks per texel of --texels with --method reference.
    #[arg(long, default_value_t = 1024)]
    pub texel_paths: u64,
    /// Monte Carlo samples per surface for the error estimate (0: skip the estimate).
    /// With --method reference: samples per surface of the reference itself.
    #[arg(long, default_value_t = 65536)]
    pub samples: u64,
    /// Options of `--method meshless`.
    #[command(flatten)]
    pub meshless: MeshlessArgs,
    /// Options of `--method glossy`.
    #[command(flatten)]
    pub glossy: GlossyArgs,
    /// Options of `--method global-cube`.
    #[command(flatten)]
    pub volume: VolumeArgs,
}

/// Options of the glossy method (`--method glossy`; `--solver`, `--max-level`,
/// `--max-iterations`, `--tolerance`, `--gather` and `--seed` apply as well).
#[derive(Args, Clone, Debug)]
pub struct GlossyArgs {
    /// Glossy: Ward normalisation.
    #[arg(long, value_enum, default_value_t = crate::pipeline::glossy::WardVariantArg::Bounded)]
    pub ward_variant: crate::pipeline::glossy::WardVariantArg,
    /// Glossy: hemisphere-to-square map of the directions (default the cosine-weighted
    /// map, whose coarse nodes keep a glossy lobe's energy; `glossy` is the paper's).
    #[arg(long, value_enum, default_value_t = crate::pipeline::glossy::DirectionsArg::Cosine)]
    pub directions: crate::pipeline::glossy::DirectionsArg,
    /// Glossy: refinement rounds (0: the V⁰ solution only).
    #[arg(long, default_value_t = 4)]
    pub rounds: usize,
    /// Glossy: a round adds every candidate link whose oracle value is at least this
    /// fraction of the round's largest, in (0, 1] (Glossy §5.3: 0.1).
    #[arg(long, default_value_t = 0.1)]
    pub fraction: f64,
    /// Glossy: what emits importance (`camera`: an eye patch at the image's camera).
    #[arg(long, value_enum, default_value_t = crate::pipeline::glossy::ImportanceArg::Off)]
    pub importance: crate::pipeline::glossy::ImportanceArg,
    /// Glossy: these surfaces (comma-separated names) emit importance in every
    /// direction instead of a camera.
    #[arg(long, value_delimiter = ',')]
    pub importance_surfaces: Option<Vec<String>>,
    /// Glossy: stop refining when the camera's 24 × 24 watch image changes by less
    /// than this relative L² amount between rounds (needs --importance camera).
    #[arg(long)]
    pub image_tolerance: Option<f64>,
    /// Glossy: senders of the final gather (with --gather N: N rays per sending node).
    #[arg(long, value_enum, default_value_t = crate::pipeline::glossy::GatherModeArg::Root)]
    pub gather_mode: crate::pipeline::glossy::GatherModeArg,
    /// Glossy: refinement stops adding links at this count (the run continues).
    #[arg(long, default_value_t = 2_000_000)]
    pub glossy_max_links: usize,
    /// Glossy: refinement stops adding links past this memory (bytes).
    #[arg(long, default_value_t = 4 << 30)]
    pub max_bytes: usize,
    /// Glossy: n × n jittered points per spatial child cell and side of a link.
    #[arg(long, default_value_t = 2)]
    pub spatial_samples: usize,
    /// Glossy: direction samples per receiving direction child cell and point pair.
    #[arg(long, default_value_t = 2)]
    pub angular_samples: usize,
    /// Glossy: Ward-lobe samples per point pair (glossy receivers).
    #[arg(long, default_value_t = 4)]
    pub lobe_samples: usize,
    /// Glossy: operator decomposition (§3.5; non-standard: scaling links with
    /// push/pull, importance off).
    #[arg(long, value_enum, default_value_t = crate::pipeline::glossy::DecompositionArg::Standard)]
    pub decomposition: crate::pipeline::glossy::DecompositionArg,
}

/// Options of the global cube (`--method global-cube`, GlobalCube §3–§4). It shares
/// `--levels` (the coarse levels L, default 2), `--oracle`, `--solver` (jacobi,
/// gauss-seidel, gmres), `--tolerance` and `--max-iterations` with the other methods.
#[derive(Args, Clone, Debug)]
pub struct VolumeArgs {
    /// Global cube: framebuffer side N cap (1..=1024); a level-l receiver uses
    /// min(N, side >> l) (the paper's 16², 32², 64² for 16³, 32³, 64³).
    #[arg(long, default_value_t = 32)]
    pub framebuffer: usize,
    /// Global cube: every refinement threshold, in 8-bit units t/255 of the
    /// quantity's range (GlobalCube Fig. 10: 13 ... 93) [default: 33].
    #[arg(long)]
    pub threshold: Option<f64>,
    /// Global cube: static threshold on source details (8-bit units) [default: --threshold].
    #[arg(long)]
    pub threshold_source: Option<f64>,
    /// Global cube: static threshold on opacity details (8-bit units) [default: --threshold].
    #[arg(long)]
    pub threshold_opacity: Option<f64>,
    /// Global cube: dynamic threshold on face-power differences (8-bit units of the
    /// lowpass solution's largest face power) [default: --threshold].
    #[arg(long)]
    pub threshold_chi: Option<f64>,
    /// Global cube: relaxations per refinement step (the paper: 1).
    #[arg(long, default_value_t = 1)]
    pub relaxations: usize,
    /// Global cube: projection of the CPU backend.
    #[arg(long, value_enum, default_value_t = ProjectionArg::Exact)]
    pub projection: ProjectionArg,
    /// Global cube: ray origins per axis of a receiver (1..=8): k³ points of a
    /// cell, k² points of each face of an opaque cell; 1 is the paper's one point.
    /// More samples integrate the receiver and tighten energy conservation at k²–k³
    /// times the projection cost; the default 2 is the conservative operator.
    #[arg(long, default_value_t = wavelux::volume::backend::cpu::DEFAULT_RECEIVER_SAMPLES)]
    pub receiver_samples: u32,
    /// Global cube: sub-pixels per side of the adaptive supersampling (1..=16; 1: off,
    /// the paper's one ray per pixel): a pixel whose radiance differs from a
    /// neighbour's by more than 50 % is replaced by the mean of N² sub-pixel rays.
    #[arg(long, default_value_t = 8)]
    pub supersample: u32,
    /// Global cube: routing Γ (eq. 32): `normalized` (Γ_ii = σ, conserves energy),
    /// `first-flight` (the exact first-flight routing of a homogeneous cube; conserves
    /// energy) or `printed` (Γ_ii = 1 as printed; creates energy).
    #[arg(long, value_enum, default_value_t = GammaArg::Normalized)]
    pub gamma: GammaArg,
    /// Global cube: the medium to solve (required when the scene has several).
    #[arg(long)]
    pub medium: Option<String>,
    /// Global cube: rasterise the scene's surfaces into an N³ grid (N a power of two,
    /// 2..=256): surfaces become opaque cells with their reflectance as albedo,
    /// emitters sources.
    #[arg(long)]
    pub voxelize: Option<usize>,
    /// Global cube: solve the medium and ignore the scene's surfaces.
    #[arg(long, conflicts_with = "voxelize")]
    pub ignore_surfaces: bool,
}

/// Projection of the global cube's CPU backend.
#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum ProjectionArg {
    /// Every cell at full resolution along every pixel ray.
    Exact,
    /// Sample the pyramid level matching the pixel footprint (for 256³).
    Pyramid,
}

/// Routing convention of the global cube (GlobalCube eq. 32).
#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum GammaArg {
    /// Γ_ii = σ: rows sum to 1 (energy-conserving; default).
    Normalized,
    /// The exact first-flight routing of a homogeneous cube (energy-conserving).
    FirstFlight,
    /// Γ_ii = 1 as printed: rows sum to 2 − σ (creates energy).
    Printed,
}

/// How the meshless link threshold applies to each sender level.
#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum LinkThresholdArg {
    /// eps for every link (the paper's Fig. 5).
    Uniform,
    /// eps/4^l for a level-l sender: scaled with the sender's support area (ours).
    SenderArea,
}

/// Options of the meshless method (`--method meshless`).
#[derive(Args, Clone, Debug)]
pub struct MeshlessArgs {
    /// Meshless: receiver levels L_r (1..=16) [default: 6]; global cube: coarse levels
    /// L (M = m0 + L, 0 = the standard global cube) [default: 2].
    #[arg(long)]
    pub levels: Option<usize>,
    /// Meshless: sender levels L_s (the first levels; 1..=levels).
    #[arg(long, default_value_t = 3)]
    pub sender_levels: usize,
    /// Meshless: Poisson-disk spacing R of level 0 in scene units [default: 5 % of the
    /// scene's bounding-box diagonal].
    #[arg(long)]
    pub r_coarse: Option<f64>,
    /// Meshless: gather rays per receiver (eq. 16).
    #[arg(long, default_value_t = 256)]
    pub gather_rays: usize,
    /// Meshless: bounces B of S = T + T₀QT + ...
    #[arg(long, default_value_t = 4)]
    pub bounces: usize,
    /// Meshless: threshold of the bounce products [default: eps/10].
    #[arg(long)]
    pub bounce_eps: Option<f64>,
    /// Meshless: how eps applies to a sender's level.
    #[arg(long, value_enum, default_value_t = LinkThresholdArg::Uniform)]
    pub link_threshold: LinkThresholdArg,
    /// Meshless: largest share of a level-0 receiver's gathered link mass that eps may
    /// drop (0..=1; ours; 1: the seed's criteria alone) [default: 0.05].
    #[arg(long)]
    pub max_dropped_share: Option<f64>,
    /// Meshless: viewpoint x,y,z of point placement [default: the scene's first camera,
    /// else the centre of its bounds].
    #[arg(long, value_delimiter = ',', allow_negative_numbers = true)]
    pub viewpoint: Option<Vec<f64>>,
    /// Meshless: read the precomputed transfer from this file when it exists (it must
    /// belong to the scene), else precompute and write it there.
    #[arg(long)]
    pub transfer: Option<PathBuf>,
    /// Meshless: area-emitter samples per point of the direct lighting.
    #[arg(long, default_value_t = 64)]
    pub emitter_samples: usize,
    /// Meshless: at runtime skip senders with |e_j| <= skip·max|e|.
    #[arg(long, default_value_t = 1e-3)]
    pub skip: f64,
    /// Meshless: largest number of points (an error when exceeded).
    #[arg(long, default_value_t = 4_000_000)]
    pub max_points: usize,
    /// Meshless: largest number of links in T or S (an error when exceeded).
    #[arg(long, default_value_t = 200_000_000)]
    pub max_links: usize,
}

/// A fraction written as `0.01` or `1%`; must be finite and in (0, 1).
fn parse_fraction(v: &str) -> Result<f64, String> {
    let t = v.trim();
    let x = match t.strip_suffix('%') {
        Some(p) => p.trim().parse::<f64>().map(|x| x / 100.0),
        None => t.parse::<f64>(),
    }
    .map_err(|e| format!("{v:?} is not a number or percentage: {e}"))?;
    if x.is_finite() && x > 0.0 && x < 1.0 {
        Ok(x)
    } else {
        Err(format!("{v:?} must be in (0, 1) (or (0 %, 100 %))"))
    }
}

/// `--face-target`: a fraction or percentage in (0, 1), or `off` (infinity: the
/// per-face goal switched off).
fn parse_face_target(v: &str) -> Result<f64, String> {
    if v.trim().eq_ignore_ascii_case("off") {
        Ok(f64::INFINITY)
    } else {
        parse_fraction(v)
    }
}

/// `--estimate-visibility`: `traced` (0: one ray per point pair) or a cell count per
/// axis in 1..=8.
fn parse_estimate_visibility(v: &str) -> Result<usize, String> {
    let v = v.trim();
    if v.eq_ignore_ascii_case("traced") {
        return Ok(0);
    }
    match v.parse::<usize>() {
        Ok(n) if (1..=8).contains(&n) => Ok(n),
        _ => Err(format!("{v:?} must be `traced` or a cell count in 1..=8")),
    }
}

/// Options of `relight`.
#[derive(Args, Clone, Debug)]
pub struct RelightArgs {
    /// Scene, image and meshless options (`--method` is ignored: always meshless).
    #[command(flatten)]
    pub solve: SolveArgs,
    /// Camera options.
    #[command(flatten)]
    pub camera: CameraArgs,
    /// A light of the (single) frame, repeatable (intensity in W/sr, cone half-angles
    /// in degrees): `spot:pos=x,y,z,dir=x,y,z,angle=DEG[,inner=DEG],rgb=R[,G,B]` or
    /// `point:pos=x,y,z,rgb=R[,G,B]` [default: the scene's own lights].
    #[arg(long = "light")]
    pub lights: Vec<String>,
    /// A JSON file of frames: `[{"lights": ["spot:pos=...", ...]}, ...]`.
    #[arg(long)]
    pub path: Option<PathBuf>,
}

/// Camera options of `render`.
#[derive(Args, Clone, Debug)]
pub struct CameraArgs {
    /// Use the scene camera with this name (default: the first one).
    #[arg(long, conflicts_with_all = ["eye", "target"])]
    pub camera: Option<String>,
    /// Eye position x,y,z (explicit look-at camera; needs --target).
    #[arg(
        long,
        value_delimiter = ',',
        requires = "target",
        allow_negative_numbers = true
    )]
    pub eye: Option<Vec<f64>>,
    /// Look-at target x,y,z.
    #[arg(
        long,
        value_delimiter = ',',
        requires = "eye",
        allow_negative_numbers = true
    )]
    pub target: Option<Vec<f64>>,
    /// Up direction x,y,z of the look-at camera.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "0,1,0",
        allow_negative_numbers = true
    )]
    pub up: Vec<f64>,
    /// Vertical field of view of the look-at camera in degrees.
    #[arg(long, default_value_t = 40.0)]
    pub fov: f64,
}

/// Options of `render`.
#[derive(Args, Clone, Debug)]
pub struct RenderArgs {
    /// Solve options.
    #[command(flatten)]
    pub solve: SolveArgs,
    /// Camera options.
    #[command(flatten)]
    pub camera: CameraArgs,
}

/// Options of `compare`.
#[derive(Args, Clone, Debug)]
pub struct CompareArgs {
    /// The result or image to judge.
    pub a: PathBuf,
    /// The reference result or image.
    pub b: PathBuf,
    /// Write a false-colour relative error map (PNG) of two images here.
    #[arg(long)]
    pub map: Option<PathBuf>,
    /// Relative error shown at the top of the error map's colour ramp.
    #[arg(long, default_value_t = 0.1)]
    pub scale: f64,
    /// Write the metrics as JSON here.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Print nothing but errors.
    #[arg(long, short)]
    pub quiet: bool,
}
