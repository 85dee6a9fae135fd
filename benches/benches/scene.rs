//! Scene loading benches: glTF (GLB) load time for a generated 1M-triangle mesh, flat
//! (every triangle pair merges into a parallelogram; grouped, the whole grid is one
//! rectangle) and wavy (nothing merges or groups), with mesh grouping off
//! (`MeshGrouping::Triangles`) and on (the default), against reading the same file into
//! memory and decoding its vertex floats (the I/O + parse floor a loader cannot beat),
//! plus the built-in scenes.
#![allow(missing_docs)] // reason: criterion's macros generate undocumented items

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use std::hint::black_box;
use std::path::{Path, PathBuf};
use wavelux::scene::{GltfOptions, MeshGrouping, builtin, load_gltf};

/// Quads along x and z: 1000 × 500 quads = 1 000 000 triangles.
const NX: usize = 1000;
const NZ: usize = 500;

/// Writes a GLB with one indexed triangle mesh over a `NX × NZ` grid of unit quads;
/// `wavy` displaces the vertices vertically so that no quad is planar.
fn write_grid_glb(path: &Path, wavy: bool) {
    let (vx, vz) = (NX + 1, NZ + 1);
    let mut bin: Vec<u8> = Vec::with_capacity(vx * vz * 12 + NX * NZ * 24);
    let (mut lo, mut hi) = ([f32::MAX; 3], [f32::MIN; 3]);
    for k in 0..vz {
        for i in 0..vx {
            let (x, z) = (i as f32, k as f32);
            let y = if wavy {
                0.25 * (0.37 * x).sin() * (0.53 * z).cos() + 0.01 * ((i * 7 + k * 13) % 5) as f32
            } else {
                0.0
            };
            for (c, v) in [x, y, z].into_iter().enumerate() {
                lo[c] = lo[c].min(v);
                hi[c] = hi[c].max(v);
                bin.extend_from_slice(&v.to_le_bytes());
            }
        }
    }
    let pos_len = bin.len();
    for k in 0..NZ {
        for i in 0..NX {
            let a = (k * vx + i) as u32;
            let (b, c, d) = (a + 1, a + 1 + vx as u32, a + vx as u32);
            // Counter-clockwise seen from +y.
            for idx in [a, d, c, a, c, b] {
                bin.extend_from_slice(&idx.to_le_bytes());
            }
        }
    }
    let idx_len = bin.len() - pos_len;
    let json = format!(
        concat!(
            r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],"#,
            r#""nodes":[{{"name":"grid","mesh":0}}],"#,
            r#""meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"indices":1,"material":0}}]}}],"#,
            r#""materials":[{{"name":"grey","pbrMetallicRoughness":{{"baseColorFactor":[0.5,0.5,0.5,1]}}}}],"#,
            r#""buffers":[{{"byteLength":{total}}}],"#,
            r#""bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":{pos_len}}},{{"buffer":0,"byteOffset":{pos_len},"byteLength":{idx_len}}}],"#,
            r#""accessors":[{{"bufferView":0,"componentType":5126,"count":{nv},"type":"VEC3","min":[{l0},{l1},{l2}],"max":[{h0},{h1},{h2}]}},"#,
            r#"{{"bufferView":1,"componentType":5125,"count":{ni},"type":"SCALAR"}}]}}"#
        ),
        total = bin.len(),
        pos_len = pos_len,
        idx_len = idx_len,
        nv = vx * vz,
        ni = NX * NZ * 6,
        l0 = lo[0],
        l1 = lo[1],
        l2 = lo[2],
        h0 = hi[0],
        h1 = hi[1],
        h2 = hi[2],
    );
    let mut json = json.into_bytes();
    while !json.len().is_multiple_of(4) {
        json.push(b' ');
    }
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&json);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&bin);
    std::fs::write(path, out).expect("write bench GLB");
}

/// The floor: read the file and decode every vertex float to f64 (sum, so the work
/// is not optimised away).
fn read_and_decode(path: &Path) -> f64 {
    let bytes = std::fs::read(path).expect("read");
    let json_len = u32::from_le_bytes([bytes[12], bytes[13], bytes[14], bytes[15]]) as usize;
    let bin = &bytes[20 + json_len + 8..];
    let nv = (NX + 1) * (NZ + 1) * 3;
    bin[..nv * 4]
        .chunks_exact(4)
        .map(|c| f64::from(f32::from_le_bytes([c[0], c[1], c[2], c[3]])))
        .sum()
}

fn gltf_load(c: &mut Criterion) {
    let dir: PathBuf =
        std::env::temp_dir().join(format!("wavelux-scene-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let flat = dir.join("grid-flat.glb");
    let wavy = dir.join("grid-wavy.glb");
    write_grid_glb(&flat, false);
    write_grid_glb(&wavy, true);
    // Triangles kept (the merging alone), and the default mesh grouping.
    let tri = GltfOptions {
        grouping: MeshGrouping::Triangles,
        ..GltfOptions::default()
    };
    let grouped = GltfOptions::default();
    // Sanity: the loads are what we think they are.
    let s = load_gltf(&flat, &tri).expect("load flat");
    let wavelux::scene::Shape::Mesh(m) = &s.surfaces[0].shape else {
        panic!("mesh expected")
    };
    assert_eq!((m.parallelograms.len(), m.triangles.len()), (NX * NZ, 0));
    let s = load_gltf(&wavy, &tri).expect("load wavy");
    let wavelux::scene::Shape::Mesh(m) = &s.surfaces[0].shape else {
        panic!("mesh expected")
    };
    assert_eq!(m.triangle_count(), 2 * NX * NZ);
    // Grouped, the flat grid is one rectangle; the wavy one stays triangles.
    let s = load_gltf(&flat, &grouped).expect("load flat");
    assert!(matches!(
        s.surfaces[..],
        [wavelux::scene::Surface {
            shape: wavelux::scene::Shape::Parallelogram { .. },
            ..
        }]
    ));
    let s = load_gltf(&wavy, &grouped).expect("load wavy");
    assert_eq!(s.surfaces[0].shape.element_count(), 2 * NX * NZ);

    let mut g = c.benchmark_group("gltf_load_1m_triangles");
    g.sample_size(10);
    g.throughput(Throughput::Elements((2 * NX * NZ) as u64));
    g.bench_function("read_and_decode_floor", |b| {
        b.iter(|| black_box(read_and_decode(black_box(&flat))))
    });
    g.bench_function("flat_merged", |b| {
        b.iter(|| load_gltf(black_box(&flat), &tri).expect("load"))
    });
    g.bench_function("wavy_unmerged", |b| {
        b.iter(|| load_gltf(black_box(&wavy), &tri).expect("load"))
    });
    g.bench_function("flat_grouped", |b| {
        b.iter(|| load_gltf(black_box(&flat), &grouped).expect("load"))
    });
    g.bench_function("wavy_grouped", |b| {
        b.iter(|| load_gltf(black_box(&wavy), &grouped).expect("load"))
    });
    g.finish();
    let _ = std::fs::remove_dir_all(&dir);
}

fn builtins(c: &mut Criterion) {
    c.bench_function("builtin/cornell_box", |b| b.iter(builtin::cornell_box));
    c.bench_function("builtin/cornell_box_primitives", |b| {
        let s = builtin::cornell_box();
        b.iter(|| s.primitives("<built-in>").expect("primitives"))
    });
}

criterion_group!(benches, gltf_load, builtins);
criterion_main!(benches);
