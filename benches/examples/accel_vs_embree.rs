//! `Accel` against Embree 4 on the same triangles and shadow segments, one thread each,
//! side by side in one run (issue 12 §3).
//!
//! Scene: the geometry bench's `room_100k` (99 840 triangles); queries: segments
//! between points drawn uniformly on two random triangles (seed 7, as the bench). The
//! Rust side times `Accel::occluded_queries` in a one-thread rayon pool (f64 watertight
//! tests, `ignore` = the two end-point triangles, end epsilon `1e-9·D`); the Embree side
//! (`embree_occlusion.py`, through the pip package `embreex`) times `rtcOccluded1` per
//! segment on one thread, with f32 vertices and the segment shortened by `1e-4·|q−p|`
//! at both ends (Embree has no `ignore`: without the margin the end-point triangles
//! block their own rays). The runs alternate `--repeats` times; the report gives each
//! side's best and median rate and the fraction of segments on which the answers agree.
//!
//! Usage: `cargo run --release -p wavelux-benches --example accel_vs_embree --
//! [--rays N] [--repeats K] [--python PYTHON] [--preset fast|medium|slow|very-slow]
//! [--leaf PRIMS]` (needs `pip install embreex numpy`; `--preset` and `--leaf` set
//! `Accel::build_with`'s obvhs parameters, default `Accel::build`'s).

use std::io::Write;
use std::path::Path;
use std::process::Command;
use std::time::Instant;

use anyhow::{Context, bail};
use obvhs::BvhBuildParams;
use rand::SeedableRng;
use rand_pcg::Pcg64;
use wavelux_benches::{queries, room_100k};
use wavelux_geometry::{Accel, Primitive, Triangle};

fn write_f32(path: &Path, data: impl Iterator<Item = f64>) -> anyhow::Result<()> {
    let mut buf = Vec::new();
    for x in data {
        buf.extend_from_slice(&(x as f32).to_le_bytes());
    }
    std::fs::File::create(path)
        .with_context(|| format!("creating {}", path.display()))?
        .write_all(&buf)?;
    Ok(())
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() -> anyhow::Result<()> {
    let mut rays = 1_000_000usize;
    let mut repeats = 3usize;
    let mut python = "python3".to_string();
    let mut preset = "medium".to_string();
    let mut leaf: Option<u32> = None;
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        let mut val = || args.next().with_context(|| format!("{a} needs a value"));
        match a.as_str() {
            "--rays" => rays = val()?.parse()?,
            "--repeats" => repeats = val()?.parse()?,
            "--python" => python = val()?,
            "--preset" => preset = val()?,
            "--leaf" => leaf = Some(val()?.parse()?),
            _ => bail!(
                "unknown option {a} (--rays N, --repeats K, --python PYTHON, --preset \
fast|medium|slow|very-slow, --leaf PRIMS)"
            ),
        }
    }
    if rays == 0 || repeats == 0 {
        bail!("--rays and --repeats must be positive");
    }
    let tris = room_100k();
    let qs = queries(&tris, rays, &mut Pcg64::seed_from_u64(7));
    let t = Instant::now();
    let mut params = match preset.as_str() {
        "fast" => BvhBuildParams::fast_build(),
        "medium" => BvhBuildParams::medium_build(),
        "slow" => BvhBuildParams::slow_build(),
        "very-slow" => BvhBuildParams::very_slow_build(),
        _ => bail!("--preset {preset}: fast, medium, slow or very-slow"),
    };
    if let Some(n) = leaf {
        params.max_prims_per_leaf = n;
    }
    let acc = Accel::build_with(
        tris.iter()
            .map(|t| Primitive::Triangle(Triangle { v: *t }))
            .collect(),
        params,
    )?;
    let accel_build = t.elapsed().as_secs_f64();

    let dir = tempfile::tempdir()?;
    let d = dir.path();
    write_f32(
        &d.join("tris.f32"),
        tris.iter().flatten().flat_map(|v| v.to_array()),
    )?;
    let mut org = Vec::with_capacity(3 * rays);
    let mut dirs = Vec::with_capacity(3 * rays);
    let mut dist = Vec::with_capacity(rays);
    for q in &qs {
        let len = (q.q - q.p).length();
        let u = (q.q - q.p) / len;
        let e = 1e-4 * len;
        org.extend((q.p + u * e).to_array());
        dirs.extend(u.to_array());
        dist.push(len - 2.0 * e);
    }
    write_f32(&d.join("org.f32"), org.into_iter())?;
    write_f32(&d.join("dir.f32"), dirs.into_iter())?;
    write_f32(&d.join("dist.f32"), dist.into_iter())?;
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/embree_occlusion.py");

    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build()?;
    let mut out = vec![false; rays];
    let (mut ours, mut theirs) = (Vec::new(), Vec::new());
    let mut embree_build = 0.0;
    let mut embree_ans = Vec::new();
    for _ in 0..repeats {
        let t = Instant::now();
        pool.install(|| acc.occluded_queries(&qs, &mut out))?;
        ours.push(t.elapsed().as_secs_f64());
        let st = Command::new(&python)
            .arg(&script)
            .arg(d)
            .status()
            .with_context(|| format!("running {python} {}", script.display()))?;
        if !st.success() {
            bail!("{} failed ({st}); is embreex installed?", script.display());
        }
        let j: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(d.join("embree.json"))?)?;
        theirs.push(j["trace_s"].as_f64().context("trace_s")?);
        embree_build = j["build_s"].as_f64().context("build_s")?;
        embree_ans = std::fs::read(d.join("embree.u8"))?;
    }
    if embree_ans.len() != rays {
        bail!("Embree answered {} of {rays} segments", embree_ans.len());
    }
    let agree = out
        .iter()
        .zip(&embree_ans)
        .filter(|(a, b)| **a == (**b != 0))
        .count();
    let blocked = out.iter().filter(|&&b| b).count();
    let rate = |s: f64| rays as f64 / s / 1e6;
    let (bo, bt) = (
        ours.iter().copied().fold(f64::INFINITY, f64::min),
        theirs.iter().copied().fold(f64::INFINITY, f64::min),
    );
    let (mo, mt) = (median(&mut ours.clone()), median(&mut theirs.clone()));
    println!(
        "room_100k: {} triangles, {rays} segments ({blocked} blocked for Accel), one thread, \
{repeats} alternating runs; Accel built with obvhs preset {preset}{}",
        tris.len(),
        leaf.map_or(String::new(), |n| format!(
            ", at most {n} triangles per leaf"
        ))
    );
    println!("build: Accel {accel_build:.3} s, Embree {embree_build:.3} s (incl. scene setup)");
    println!(
        "Accel:  best {:.3} M rays/s, median {:.3} (runs {:?} s)",
        rate(bo),
        rate(mo),
        ours.iter().map(|x| format!("{x:.3}")).collect::<Vec<_>>()
    );
    println!(
        "Embree: best {:.3} M rays/s, median {:.3} (runs {:?} s)",
        rate(bt),
        rate(mt),
        theirs.iter().map(|x| format!("{x:.3}")).collect::<Vec<_>>()
    );
    println!(
        "Accel / Embree throughput: best {:.3}x, median {:.3}x; answers agree on {:.3} % of segments",
        bt / bo,
        mt / mo,
        100.0 * agree as f64 / rays as f64
    );
    Ok(())
}
