//! The meshless method's command line (issue 15): `relight` is linear in the lights
//! across frames, and each warning of a meshless run is printed once.

use std::path::Path;

use anyhow::{Context, Result};
use serde_json::Value;

mod common;
use common::{MESHLESS_SMALL as SMALL, run, succeeds};

/// Runs `wavelux ARGS` in `cwd`, which must succeed; returns its stderr (its warnings).
fn ok(args: &[&str], cwd: &Path) -> Result<String> {
    Ok(String::from_utf8_lossy(&succeeds(args, cwd)?.stderr).into_owned())
}

/// Per-surface `key` (RGB) of every frame of a relight JSON.
fn per_frame(v: &Value, key: &str) -> Result<Vec<Vec<[f64; 3]>>> {
    v["frames"]
        .as_array()
        .context("frames")?
        .iter()
        .map(|f| {
            f["surfaces"]
                .as_array()
                .context("surfaces")?
                .iter()
                .map(|s| {
                    let c = |k: usize| s[key][k].as_f64().context("component");
                    Ok([c(0)?, c(1)?, c(2)?])
                })
                .collect()
        })
        .collect()
}

/// One transfer relights four frames of the Cornell box (its area light stays in every
/// frame): a spot `A`, a point light `B`, both, and none. With no sender skipped
/// (`--skip 0`) the indirect and the full per-surface means are linear in the punctual
/// lights: `f(A+B) + f(∅) = f(A) + f(B)` to f32 rounding, and the lights add light.
#[test]
fn relight_is_linear_in_the_lights_across_frames() -> Result<()> {
    let dir = tempfile::tempdir()?;
    let d = dir.path();
    let a = "\"spot:pos=0.278,0.5,0.27,dir=0,-1,0,angle=40,rgb=1,0.8,0.6\"";
    let b = "\"point:pos=0.1,0.3,0.2,rgb=0.5,0.4,0.3\"";
    std::fs::write(
        d.join("frames.json"),
        format!(
            r#"[{{"lights": [{a}]}}, {{"lights": [{b}]}}, {{"lights": [{a}, {b}]}}, {{"lights": []}}]"#
        ),
    )?;
    let mut args = vec!["relight", "builtin:cornell-box", "--path", "frames.json"];
    args.extend_from_slice(SMALL);
    args.extend_from_slice(&["--skip", "0", "--json", "r.json"]);
    ok(&args, d)?;
    let v: Value = serde_json::from_str(&std::fs::read_to_string(d.join("r.json"))?)?;
    for key in ["indirect", "radiosity"] {
        let f = per_frame(&v, key)?;
        assert_eq!(f.len(), 4);
        let scale = f
            .iter()
            .flatten()
            .flatten()
            .fold(0.0f64, |m, x| m.max(x.abs()));
        assert!(scale > 0.0);
        for (s, name) in v["frames"][0]["surfaces"]
            .as_array()
            .context("surfaces")?
            .iter()
            .enumerate()
        {
            for c in 0..3 {
                let (fa, fb, fab, f0) = (f[0][s][c], f[1][s][c], f[2][s][c], f[3][s][c]);
                let gap = (fab + f0 - fa - fb).abs();
                assert!(
                    gap <= 1e-5 * scale,
                    "{key} of {}: f(A+B) + f(∅) − f(A) − f(B) = {gap:e} (scale {scale:e})",
                    name["name"]
                );
            }
        }
        // The punctual lights add light somewhere: frame A+B differs from frame ∅.
        let added: f64 = f[2]
            .iter()
            .zip(&f[3])
            .map(|(p, q)| (0..3).map(|c| p[c] - q[c]).sum::<f64>())
            .sum();
        assert!(added > 1e-3 * scale, "{key}: the lights add {added:e}");
    }
    Ok(())
}

/// The first value under `key` anywhere in `v` (depth first).
fn find_key<'a>(v: &'a Value, key: &str) -> Option<&'a Value> {
    match v {
        Value::Object(m) => m
            .get(key)
            .or_else(|| m.values().find_map(|x| find_key(x, key))),
        Value::Array(a) => a.iter().find_map(|x| find_key(x, key)),
        _ => None,
    }
}

/// A closed box with a Ward floor, a participating medium, a sphere emitter (which the
/// meshless direct lighting cannot sample) beside a parallelogram one and a point light: `solve --method meshless`
/// and `relight` each print every warning once (the precomputation's own notes on
/// media and Ward lobes are not repeated), list the same warnings in the JSON, and
/// `--strict` refuses the scene.
#[test]
fn meshless_warnings_are_printed_once() -> Result<()> {
    let dir = tempfile::tempdir()?;
    let d = dir.path();
    let wall = |name: &str, o: [i32; 3], u: [i32; 3], v: [i32; 3], m: &str| {
        format!(
            "[[surface]]\nname = \"{name}\"\nmaterial = \"{m}\"\nshape = {{ type = \"parallelogram\", \
             origin = {o:?}, edge_u = {u:?}, edge_v = {v:?} }}\n"
        )
    };
    let mut toml = String::from(
        r#"name = "warned-box"
[[material]]
name = "gloss"
reflectance = 0.5
ward = { specular = 0.2, alpha_x = 0.1 }
[[material]]
name = "white"
reflectance = 0.7
[[material]]
name = "bulb"
reflectance = 0.0
emission = 5.0
[[light]]
name = "lamp"
type = "point"
position = [0.5, 0.5, 0.6]
intensity = 1.0
[[medium]]
name = "fog"
min = [0, 0, 0]
max = [1, 1, 1]
resolution = [2, 2, 2]
source = 0.0
opacity = 0.1
albedo = 0.5
[[surface]]
name = "ball"
material = "bulb"
shape = { type = "sphere", center = [0.5, 0.5, 0.85], radius = 0.05 }
[[surface]]
name = "panel"
material = "bulb"
shape = { type = "parallelogram", origin = [0.4, 0.4, 0.99], edge_u = [0, 0.2, 0], edge_v = [0.2, 0, 0] }
"#,
    );
    // Six inward-facing walls of the unit cube.
    toml += &wall("floor", [0, 0, 0], [1, 0, 0], [0, 1, 0], "gloss");
    toml += &wall("ceiling", [0, 0, 1], [0, 1, 0], [1, 0, 0], "white");
    toml += &wall("x0", [0, 0, 0], [0, 1, 0], [0, 0, 1], "white");
    toml += &wall("x1", [1, 0, 0], [0, 0, 1], [0, 1, 0], "white");
    toml += &wall("y0", [0, 0, 0], [0, 0, 1], [1, 0, 0], "white");
    toml += &wall("y1", [0, 1, 0], [1, 0, 0], [0, 0, 1], "white");
    std::fs::write(d.join("box.toml"), toml)?;

    let mut solve = vec![
        "solve",
        "box.toml",
        "--method",
        "meshless",
        "--samples",
        "0",
    ];
    solve.extend_from_slice(SMALL);
    let mut relight = vec!["relight", "box.toml"];
    relight.extend_from_slice(SMALL);
    for (args, json) in [(&solve, "s.json"), (&relight, "r.json")] {
        let mut args = args.clone();
        args.extend_from_slice(&["--json", json]);
        let err = ok(&args, d)?;
        let v: Value = serde_json::from_str(&std::fs::read_to_string(d.join(json))?)?;
        let warned = v["warnings"].as_array().context("warnings")?;
        // The precomputation's statistics do not repeat them.
        let pre = find_key(&v, "precompute").context("precompute statistics")?;
        assert!(pre.is_object(), "{args:?}: {pre}");
        assert!(pre.get("warnings").is_none(), "{args:?}: {pre}");
        let elements: Vec<&str> = warned
            .iter()
            .map(|w| w["element"].as_str().unwrap_or("?"))
            .collect();
        for want in [
            "material \"gloss\" (surfaces \"floor\")",
            "medium \"fog\"",
            "emitter \"ball\"",
        ] {
            assert_eq!(
                elements.iter().filter(|e| **e == want).count(),
                1,
                "{args:?}: {elements:?}"
            );
        }
        let lines: Vec<&str> = err
            .lines()
            .filter(|l| l.starts_with("wavelux: warning:"))
            .collect();
        assert_eq!(lines.len(), warned.len(), "{args:?}: {err}");
        for w in warned {
            let msg = w["message"].as_str().context("message")?;
            let n = lines.iter().filter(|l| l.ends_with(msg)).count();
            assert_eq!(n, 1, "{args:?}: {msg:?} printed {n} times: {err}");
        }
        let mut strict = args.clone();
        strict.push("--strict");
        let out = run(&strict, d);
        assert!(!out.status.success(), "{strict:?} should fail");
        assert!(String::from_utf8_lossy(&out.stderr).contains("--strict"));
    }
    Ok(())
}
