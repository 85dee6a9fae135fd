//! Scenes meet geometry: built-in scenes, a hand-written GLB of the Cornell box and a
//! native file with a polygon hole and a trimmed sphere are turned into
//! `wavelux-geometry` primitives and ray-cast; orientation, exact hit distances,
//! holes and trims, and glTF round trips are checked against closed forms.

use proptest::prelude::*;
use wavelux::geometry::{Accel, Ray};
use wavelux::param::glam;
use wavelux::scene::{self, GltfOptions, MeshElement, Scene, Shape, builtin};

fn accel(s: &Scene) -> (Accel, Vec<usize>) {
    let prims = s.primitives("<test>").expect("primitives");
    let owners = prims.iter().map(|(i, _)| *i).collect();
    (
        Accel::build(prims.into_iter().map(|(_, p)| p).collect()).expect("accel"),
        owners,
    )
}

/// A GLB (one node + mesh per surface, one material each) of a scene's mesh and
/// parallelogram surfaces, written by hand.
fn to_glb(s: &Scene) -> Vec<u8> {
    let mut bin: Vec<u8> = Vec::new();
    let (mut nodes, mut meshes, mut mats, mut views, mut accs) =
        (vec![], vec![], vec![], vec![], vec![]);
    for surf in &s.surfaces {
        let elements: Vec<MeshElement> = match &surf.shape {
            Shape::Mesh(m) => m.elements().collect(),
            Shape::Parallelogram {
                origin,
                edge_u,
                edge_v,
            } => vec![MeshElement::Parallelogram {
                origin: *origin,
                edge_u: *edge_u,
                edge_v: *edge_v,
            }],
            _ => continue,
        };
        let mut pts: Vec<[f32; 3]> = Vec::new();
        for e in elements {
            let tri = |a: glam::DVec3, b: glam::DVec3, c: glam::DVec3| {
                [a, b, c].map(|p| p.as_vec3().to_array())
            };
            match e {
                MeshElement::Triangle([a, b, c]) => pts.extend(tri(a, b, c)),
                MeshElement::Parallelogram {
                    origin: o,
                    edge_u: u,
                    edge_v: v,
                } => {
                    pts.extend(tri(o, o + u, o + u + v));
                    pts.extend(tri(o, o + u + v, o + v));
                }
            }
        }
        let off = bin.len();
        let (mut lo, mut hi) = ([f32::MAX; 3], [f32::MIN; 3]);
        for p in &pts {
            for c in 0..3 {
                lo[c] = lo[c].min(p[c]);
                hi[c] = hi[c].max(p[c]);
                bin.extend_from_slice(&p[c].to_le_bytes());
            }
        }
        views.push(format!(
            r#"{{"buffer":0,"byteOffset":{off},"byteLength":{}}}"#,
            bin.len() - off
        ));
        accs.push(format!(
            r#"{{"bufferView":{v},"componentType":5126,"count":{n},"type":"VEC3","min":[{},{},{}],"max":[{},{},{}]}}"#,
            lo[0],
            lo[1],
            lo[2],
            hi[0],
            hi[1],
            hi[2],
            v = views.len() - 1,
            n = pts.len()
        ));
        let m = &s.materials[surf.material];
        let l = m.emission.scale(1.0 / std::f64::consts::PI);
        let strength = l.max_channel().max(1.0);
        let r = m.reflectance.0;
        mats.push(format!(
            r#"{{"name":"{}","pbrMetallicRoughness":{{"baseColorFactor":[{},{},{},1]}},"emissiveFactor":[{},{},{}],"extensions":{{"KHR_materials_emissive_strength":{{"emissiveStrength":{}}}}}}}"#,
            m.name,
            r[0] as f32,
            r[1] as f32,
            r[2] as f32,
            (l.0[0] / strength) as f32,
            (l.0[1] / strength) as f32,
            (l.0[2] / strength) as f32,
            strength as f32
        ));
        meshes.push(format!(
            r#"{{"primitives":[{{"attributes":{{"POSITION":{}}},"material":{}}}]}}"#,
            accs.len() - 1,
            mats.len() - 1
        ));
        nodes.push(format!(
            r#"{{"name":"{}","mesh":{}}}"#,
            surf.name,
            meshes.len() - 1
        ));
    }
    let json = format!(
        r#"{{"asset":{{"version":"2.0"}},"extensionsUsed":["KHR_materials_emissive_strength"],"scene":0,"scenes":[{{"nodes":[{}]}}],"nodes":[{}],"meshes":[{}],"materials":[{}],"buffers":[{{"byteLength":{}}}],"bufferViews":[{}],"accessors":[{}]}}"#,
        (0..nodes.len())
            .map(|i| i.to_string())
            .collect::<Vec<_>>()
            .join(","),
        nodes.join(","),
        meshes.join(","),
        mats.join(","),
        bin.len(),
        views.join(","),
        accs.join(",")
    );
    let mut json = json.into_bytes();
    while !json.len().is_multiple_of(4) {
        json.push(b' ');
    }
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut out = b"glTF".to_vec();
    for w in [2u32, total as u32, json.len() as u32] {
        out.extend_from_slice(&w.to_le_bytes());
    }
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&json);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&bin);
    out
}

/// Rays from the Cornell camera through a grid of image points all hit the inside
/// (front side) of the box, and the same rays hit the same surfaces at the same
/// distances after a GLB round trip (which turns the ceiling polygon into a gap, so
/// rays that reach the ceiling are excluded from the comparison).
#[test]
fn cornell_camera_sees_only_front_sides_and_survives_glb() {
    let s = builtin::cornell_box();
    let (acc, owner) = accel(&s);
    let cam = &s.cameras[0];
    let scene::Projection::Perspective { yfov, .. } = cam.projection else {
        panic!("perspective expected")
    };
    let h = (0.5 * yfov).tan();
    let glb = to_glb(&s);
    let loaded = scene::load_gltf_slice(&glb, "cornell.glb", None, &GltfOptions::default())
        .expect("load GLB");
    let (acc2, owner2) = accel(&loaded);
    let n = 24;
    let mut compared = 0;
    for j in 0..n {
        for i in 0..n {
            // Stay inside the box's silhouette: 90% of the field of view.
            let x = 0.9 * h * (2.0 * (i as f64 + 0.5) / n as f64 - 1.0);
            let y = 0.9 * h * (2.0 * (j as f64 + 0.5) / n as f64 - 1.0);
            let d = cam.forward + x * cam.right() + y * cam.up;
            let ray = Ray::new(cam.position, d).expect("ray");
            let hit = acc
                .closest_hit(&ray, 0.0, f64::INFINITY)
                .expect("camera ray must hit");
            assert!(
                hit.front,
                "ray {i},{j} hit a back side of {}",
                s.surfaces[owner[hit.prim as usize]].name
            );
            let name = &s.surfaces[owner[hit.prim as usize]].name;
            if name == "ceiling" {
                continue;
            }
            let hit2 = acc2
                .closest_hit(&ray, 0.0, f64::INFINITY)
                .expect("hit after round trip");
            assert_eq!(&loaded.surfaces[owner2[hit2.prim as usize]].name, name);
            assert!(
                (hit.t - hit2.t).abs() < 1e-6 * hit.t,
                "{} vs {}",
                hit.t,
                hit2.t
            );
            assert!(hit2.front);
            compared += 1;
        }
    }
    assert!(compared > n * n / 2);
    // Materials and emission survive the round trip: E = π × emissive × strength.
    let light = &loaded.materials[loaded.surface("light").unwrap().material];
    let want = &s.materials[s.surface("light").unwrap().material];
    for c in 0..3 {
        assert!((light.emission.0[c] - want.emission.0[c]).abs() < 1e-5 * want.emission.0[c]);
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Inside the white-furnace cube every ray hits an inward (front) face at the exact
    /// distance to the cube's boundary.
    #[test]
    fn furnace_rays_hit_front_faces_at_exact_distance(
        p in (0.05..0.95f64, 0.05..0.95f64, 0.05..0.95f64),
        d in (-1.0..1.0f64, -1.0..1.0f64, -1.0..1.0f64),
    ) {
        let s = builtin::white_furnace(1.0, 0.5).unwrap();
        let (acc, _) = accel(&s);
        let o = glam::DVec3::new(p.0, p.1, p.2);
        let dir = glam::DVec3::new(d.0, d.1, d.2);
        prop_assume!(dir.length() > 0.1);
        let dir = dir.normalize();
        let t_exact = (0..3)
            .filter(|&k| dir[k] != 0.0)
            .map(|k| if dir[k] > 0.0 { (1.0 - o[k]) / dir[k] } else { -o[k] / dir[k] })
            .fold(f64::INFINITY, f64::min);
        let hit = acc.closest_hit(&Ray::new(o, dir).unwrap(), 0.0, f64::INFINITY).unwrap();
        prop_assert!(hit.front);
        prop_assert!((hit.t - t_exact).abs() < 1e-12);
    }
}

/// A native file with a polygon hole and a trimmed sphere: rays through the hole and
/// the trimmed-away cap miss, rays through the solid parts hit.
#[test]
fn native_holes_and_trims_are_respected_by_ray_casting() {
    let text = r#"
[[material]]
name = "m"
reflectance = 0.5

[[surface]]
name = "plate"
material = "m"
[surface.shape]
type = "polygon"
origin = [0, 0, 0]
u = [1, 0, 0]
v = [0, 1, 0]
outer = [{ start = [-2, -2] }, { start = [2, -2] }, { start = [2, 2] }, { start = [-2, 2] }]
holes = [[{ start = [1.5, 0], center = [0, 0] }]]

[[surface]]
name = "ball"
material = "m"
[surface.shape]
type = "sphere"
center = [0, 0, 5]
radius = 1
trim = { outer = [{ start = [0, 0] }, { start = [1, 0] }, { start = [1, 0.5] }, { start = [0, 0.5] }] }
"#;
    let s = scene::parse_native(text, "holes.toml", None).expect("parse");
    let plate = s.surface("plate").unwrap().shape.area();
    assert!((plate - (16.0 - 2.25 * std::f64::consts::PI)).abs() < 1e-12);
    // Lower half of the sphere's equal-area square is the southern hemisphere (z ≤ 5).
    let ball = s.surface("ball").unwrap().shape.area();
    assert!((ball - 2.0 * std::f64::consts::PI).abs() < 1e-9);
    let (acc, owner) = accel(&s);
    let down = glam::DVec3::NEG_Z;
    let cast = |x: f64, y: f64, z: f64, d: glam::DVec3| {
        acc.closest_hit(
            &Ray::new(glam::DVec3::new(x, y, z), d).unwrap(),
            0.0,
            f64::INFINITY,
        )
        .map(|h| (s.surfaces[owner[h.prim as usize]].name.clone(), h))
    };
    // Through the circular hole (and below the sphere's equator): nothing from above
    // the sphere's centre hits the missing northern cap; the southern cap is hit.
    let (name, h) = cast(0.2, 0.1, 10.0, down).expect("hits the southern hemisphere");
    assert_eq!(name, "ball");
    assert!(h.point.z < 5.0);
    // From below, through the hole: hits the southern cap from outside (front).
    let (name, h) = cast(0.2, 0.1, -1.0, glam::DVec3::Z).expect("hit");
    assert_eq!(name, "ball");
    assert!(h.front && h.point.z < 5.0);
    // Outside the hole: the plate.
    let (name, h) = cast(1.5, 1.5, 10.0, down).expect("hit");
    assert_eq!(name, "plate");
    assert!((h.t - 10.0).abs() < 1e-12 && h.front);
    // Beside the sphere, inside the hole: nothing at all.
    assert!(cast(1.2, 0.0, 10.0, down).is_none());
    assert!(cast(0.0, -1.3, -3.0, glam::DVec3::Z).is_none());
}
