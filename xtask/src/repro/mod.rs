//! The registry of reproductions: one module per reproduction, each exposing `run`.
//!
//! A registration quotes where in the seed papers the reproduced result lives; the
//! paper's numbers are quoted inside each module next to their source, and ours are
//! always computed by `run` in the same invocation.

pub mod ziegler_3_1_4;

use crate::report::Report;
use crate::reproduce::Ctx;

mod cornell_faces;
mod default_bias;
mod global_cube_fig10;
mod global_cube_fig13;
mod global_cube_fig9;
mod global_cube_mc;
mod global_cube_table1;
mod glossy_3_5;
mod glossy_fig13;
mod glossy_fig16;
mod glossy_ward;
mod meshless_common;
mod meshless_fig3;
mod meshless_fig7;
mod meshless_scaling;
mod meshless_table1;
mod release_binary;
mod speed_accuracy;
mod standard;
mod transfer_accuracy;
mod virtual_mesh_common;
mod virtual_mesh_fig4;
mod virtual_mesh_table1;
mod virtual_mesh_table2;
mod virtual_mesh_table3;
mod ziegler_4_1;
mod ziegler_4_2;

/// One registered reproduction.
pub struct Reproduction {
    /// Stable identifier used by `--only` and as the report file name.
    pub id: &'static str,
    /// Paper and section/table/figure reproduced, e.g. "Ziegler §3.1.4, Fig. 3.5".
    pub source: &'static str,
    /// Seed file under `../shared/seeds/`.
    pub seed_file: &'static str,
    /// One-line title.
    pub title: &'static str,
    /// Computes our numbers and the report.
    pub run: fn(&Ctx) -> anyhow::Result<Report>,
}

/// Every registered reproduction, in report order.
pub fn all() -> Vec<Reproduction> {
    vec![
        Reproduction {
            id: "ziegler-3.1.4",
            source: "Ziegler §3.1.4, Figs. 3.5–3.6 and tables",
            seed_file: "004_cb5b08859768bf36.txt",
            title: "Haar vs multiwavelets vs CDV: projections, compression and L1 errors",
            run: ziegler_3_1_4::run,
        },
        Reproduction {
            id: "virtual-mesh-fig4",
            source: "VirtualMesh §3.1.3, Fig. 4",
            seed_file: "001_663a8814abd90f9c.txt",
            title: "Ring-torus patch flattened by a constant-Jacobian map vs natural coordinates",
            run: virtual_mesh_fig4::run,
        },
        Reproduction {
            id: "ziegler-4.1",
            source: "Ziegler §4.1, Figs. 4.3–4.5",
            seed_file: "004_cb5b08859768bf36.txt",
            title: "Haar vs multiwavelets on the Unoccluded and Occluded scenes; fractional visibility",
            run: ziegler_4_1::run,
        },
        Reproduction {
            id: "ziegler-4.2",
            source: "Ziegler §4.2, Figs. 4.12–4.15 and link table",
            seed_file: "004_cb5b08859768bf36.txt",
            title: "Picard vs GMRES vs CGNR on the box scenes (Haar, m = 5)",
            run: ziegler_4_2::run,
        },
        Reproduction {
            id: "virtual-mesh-table1",
            source: "VirtualMesh §6.1, Table 1 and Fig. 11",
            seed_file: "001_663a8814abd90f9c.txt",
            title: "Complex polygons through the virtual mesh vs triangulated (opera hall, Haar; paper 99 %, ours 90 %)",
            run: virtual_mesh_table1::run,
        },
        Reproduction {
            id: "virtual-mesh-table2",
            source: "VirtualMesh §6.2, Table 2",
            seed_file: "001_663a8814abd90f9c.txt",
            title: "Quadric teapot vs its 1,392-primitive tessellation (paper M1–M3 at 99 %; ours M3 at 90 %)",
            run: virtual_mesh_table2::run,
        },
        Reproduction {
            id: "virtual-mesh-table3",
            source: "VirtualMesh §6.3, Table 3",
            seed_file: "001_663a8814abd90f9c.txt",
            title: "Constant vs natural-coordinate Jacobian push/pull on the chess set (M2, 90 %)",
            run: virtual_mesh_table3::run,
        },
        Reproduction {
            id: "speed-accuracy",
            source: "issue: speed vs accuracy of every method against the path tracer",
            seed_file: "003_fdfe6675de3bf6ad.txt",
            title: "Error vs wall time: wavelet bases × ε × levels and the path tracer",
            run: speed_accuracy::run,
        },
        Reproduction {
            id: "default-bias",
            source: "issue 13 §2: the default command against the path tracer",
            seed_file: "004_cb5b08859768bf36.txt",
            title: "The default command's surface averages: no significant bias, an honest printed error",
            run: default_bias::run,
        },
        Reproduction {
            id: "ziegler-2.2.3-standard",
            source: "Ziegler §2.2.3 (standard vs non-standard realisation); Glossy §3.5",
            seed_file: "004_cb5b08859768bf36.txt",
            title: "Standard vs non-standard decomposition of the same links: sparsity, solve cost, agreement",
            run: standard::run,
        },
        Reproduction {
            id: "glossy-fig13",
            source: "Glossy §7.1, Figs. 12–15",
            seed_file: "003_fdfe6675de3bf6ad.txt",
            title: "Three patches: glossy radiance convergence; patch 3 without importance, with it, with gather",
            run: glossy_fig13::run,
        },
        Reproduction {
            id: "glossy-fig16",
            source: "Glossy §7.2, Fig. 16",
            seed_file: "003_fdfe6675de3bf6ad.txt",
            title: "Maze with a Bézier teapot, spotlights and a window: counts, importance at equal image error, final gathers",
            run: glossy_fig16::run,
        },
        Reproduction {
            id: "glossy-3.5",
            source: "Glossy §3.5 (standard vs non-standard operator decomposition)",
            seed_file: "003_fdfe6675de3bf6ad.txt",
            title: "Standard vs non-standard decomposition on the three-patch scene: links and samples at equal error",
            run: glossy_3_5::run,
        },
        Reproduction {
            id: "glossy-ward",
            source: "Glossy §6.2 (Ward BRDF); albedos registered in issue 16",
            seed_file: "003_fdfe6675de3bf6ad.txt",
            title: "Ward albedo of the Original, Product and Bounded normalisations",
            run: glossy_ward::run,
        },
        Reproduction {
            id: "transfer-accuracy",
            source: "issue 11 §5: Howell's catalogue and white furnaces",
            seed_file: "004_cb5b08859768bf36.txt",
            title: "Transfer accuracy at the geometric extremes: analytic catalogue and white furnaces",
            run: transfer_accuracy::run,
        },
        Reproduction {
            id: "cornell-faces",
            source: "issue 11 §2: the Cornell box glTF with one node per face",
            seed_file: "001_663a8814abd90f9c.txt",
            title: "Every face of the one-node-per-face Cornell glTF at default settings vs the path tracer",
            run: cornell_faces::run,
        },
        Reproduction {
            id: "meshless-table1",
            source: "Meshless §4.2, Table 1",
            seed_file: "002_d3831e6496376b14.txt",
            title: "Direct-to-indirect precomputation statistics on the atrium (level 0 tuned to 339)",
            run: meshless_table1::run,
        },
        Reproduction {
            id: "meshless-fig3",
            source: "Meshless §2.2, Fig. 3",
            seed_file: "002_d3831e6496376b14.txt",
            title: "Hierarchical meshless approximation F_0…F_L refining towards the function",
            run: meshless_fig3::run,
        },
        Reproduction {
            id: "meshless-fig7",
            source: "Meshless §4.2, Fig. 7 and frame times",
            seed_file: "002_d3831e6496376b14.txt",
            title: "Atrium relit at three spots vs the path tracer; direct, transport and flatten times",
            run: meshless_fig7::run,
        },
        Reproduction {
            id: "meshless-scaling",
            source: "Meshless §3.2, §4.2 (Comparisons); issue 15 error target",
            seed_file: "002_d3831e6496376b14.txt",
            title: "Links, time and error vs receivers and ε; dense one-level transfer vs hierarchy",
            run: meshless_scaling::run,
        },
        Reproduction {
            id: "global-cube-table1",
            source: "GlobalCube §5, Table 1 (Figs. 11, 13)",
            seed_file: "000_eb64a2a0d4770757.txt",
            title: "Hierarchical global cube on the lounge: elements and times per refinement step",
            run: global_cube_table1::run,
        },
        Reproduction {
            id: "global-cube-fig9",
            source: "GlobalCube §5, Fig. 9",
            seed_file: "000_eb64a2a0d4770757.txt",
            title: "Global cube convergence in the framebuffer side N (Q_square, eq. 35)",
            run: global_cube_fig9::run,
        },
        Reproduction {
            id: "global-cube-fig10",
            source: "GlobalCube §5, Fig. 10",
            seed_file: "000_eb64a2a0d4770757.txt",
            title: "Hierarchical vs standard global cube across oracle thresholds",
            run: global_cube_fig10::run,
        },
        Reproduction {
            id: "global-cube-fig13",
            source: "GlobalCube §5, Figs. 13–14",
            seed_file: "000_eb64a2a0d4770757.txt",
            title: "Progressive refinement of the lounge: snapshots, back-wall slices, static vs dynamic splits",
            run: global_cube_fig13::run,
        },
        Reproduction {
            id: "global-cube-mc",
            source: "issue 14 §6–§7 (GlobalCube has no Monte Carlo comparison)",
            seed_file: "000_eb64a2a0d4770757.txt",
            title: "Global cube vs the Monte Carlo volume tracer: collided-power error against CPU time",
            run: global_cube_mc::run,
        },
    ]
}
