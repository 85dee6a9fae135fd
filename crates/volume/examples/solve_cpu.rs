//! Times one global cube solve of a built-in lounge on the CPU projector (issue 14 §8:
//! where the projector's time goes), in CPU seconds of this process, and optionally
//! writes the red channel's collided power per voxel (17 significant digits, one per
//! line) so that two builds can be compared bitwise with `cmp`.
//!
//! `cargo run --release -p wavelux-volume --example solve_cpu -- MODE SIDE N [OUT]`:
//! `MODE` `default` is the command's default solve and projector
//! (`GlobalCubeConfig::default()`, `CpuProjector::default()`) with the framebuffer cap
//! `N`; `reprojected` is the same with the transport re-projected at every sweep
//! (`transport_memory` 0: the projector's plain gather instead of its recording);
//! `standard` is the standard global cube of `global-cube-mc`
//! ([`GlobalCubeConfig::standard`]: levels 0, GMRES to 1e-6; no supersampling, one
//! receiver sample) at framebuffer `N`. `SIDE` picks
//! `gc-lounge-SIDE`. Run with `RAYON_NUM_THREADS=1` for timings.

use std::error::Error;
use wavelux_volume::backend::cpu::{AntiAlias, CpuProjector, Projection};
use wavelux_volume::{GlobalCubeConfig, VolumeGrid};

/// CPU seconds (user + system) of this process so far, from `/proc/self/stat` (Linux;
/// clock ticks of 1/100 s).
fn cpu_seconds() -> Result<f64, Box<dyn Error>> {
    let stat = std::fs::read_to_string("/proc/self/stat")?;
    let after = stat.rsplit(')').next().ok_or("no ')' in /proc/self/stat")?;
    let fields: Vec<&str> = after.split_whitespace().collect();
    let ticks = |i: usize| -> Result<f64, Box<dyn Error>> {
        Ok(fields
            .get(i)
            .ok_or("short /proc/self/stat")?
            .parse::<f64>()?)
    };
    // utime and stime are fields 14 and 15, the 12th and 13th after the name.
    Ok((ticks(11)? + ticks(12)?) / 100.0)
}

fn main() -> Result<(), Box<dyn Error>> {
    let args: Vec<String> = std::env::args().collect();
    let mode = args.get(1).map_or("default", String::as_str);
    let side: usize = args.get(2).map_or(Ok(16), |s| s.parse())?;
    let n: usize = args.get(3).map_or(Ok(4), |s| s.parse())?;
    let name = format!("gc-lounge-{side}");
    let scene = wavelux_scene::builtin::builtin(&name).ok_or(format!("no built-in {name}"))?;
    let medium = scene.media.first().ok_or("the scene has no medium")?;
    let grid = VolumeGrid::from_medium(medium)?;
    let (cfg, projector) = match mode {
        "default" => (
            GlobalCubeConfig {
                framebuffer: n,
                ..GlobalCubeConfig::default()
            },
            CpuProjector::default(),
        ),
        "reprojected" => (
            GlobalCubeConfig {
                framebuffer: n,
                transport_memory: 0,
                ..GlobalCubeConfig::default()
            },
            CpuProjector::default(),
        ),
        "standard" => (
            GlobalCubeConfig::standard(n),
            CpuProjector::new(Projection::Exact, AntiAlias::OFF),
        ),
        other => {
            return Err(format!("mode {other}: expected default, reprojected or standard").into());
        }
    };
    let start = cpu_seconds()?;
    let s = wavelux_volume::solve(&grid, &cfg, &projector, &mut |_| {})?;
    let cpu = cpu_seconds()? - start;
    let collided = s.collided_per_voxel();
    let red: f64 = collided[0].iter().sum();
    println!(
        "{mode} {name} N {n}: {cpu:.2} s CPU, {} elements, {} rays, {} gathers replayed, \
         collided (red) {red:.12e}, balance {:+.3e}",
        s.elements(),
        s.work.gather.rays,
        s.work.replayed,
        s.energy.balance_error()[0]
    );
    if let Some(path) = args.get(4) {
        let lines: Vec<String> = collided[0].iter().map(|v| format!("{v:.17e}")).collect();
        std::fs::write(path, lines.join("\n"))?;
    }
    Ok(())
}
