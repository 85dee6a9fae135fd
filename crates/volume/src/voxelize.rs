//! Surfaces as thin volumes (GlobalCube §2.1): a surface scene rasterised into an `N³`
//! grid, so that one scene can be solved by the surface methods and by the global cube
//! (`wavelux solve --voxelize N`).
//!
//! * The scene is tessellated (`wavelux_scene::tessellated`) and every triangle or
//!   parallelogram is sampled at the centres of a uniform subdivision whose pieces have
//!   edges of at most `h/4` (`h` the voxel edge); a sample marks the voxel containing it.
//! * A marked voxel is opaque (`σ = 1`); its albedo is the area-weighted mean of the
//!   front reflectance of the samples in it (texture means applied), at most
//!   [`MAX_ALBEDO`]. Emitters put their power `E · A` (per channel) into the voxels of
//!   their samples as a source (`χᵗ = P / h³`).
//! * The scene's bounding box, made a cube, fills the inner `(N − 2)³` voxels; the
//!   outermost layer is an opaque black shell (`ω = 0`). Without it, a wall or an
//!   emitter on the lattice's boundary would radiate half its power out of the grid
//!   through its outer face; with it, the outer faces touch an opaque cell and are
//!   hidden (a hidden face neither emits nor receives), so a one-sided emitter on a wall
//!   emits into the room only. The shell absorbs what an open scene lets out, like the
//!   black boundary.
//!
//! Discretisation (what a voxelised scene cannot say): a surface becomes a layer one to
//! two voxels thick; a voxel's faces are axis-aligned, so a tilted surface reflects as a
//! staircase; emitters emit from every exposed face of their voxels (a Lambertian box,
//! not a one-sided Lambertian surface); two-sided materials use their front side.

use glam::DVec3;
use ndarray::Array3;
use wavelux_scene::tessellated::{TessellateOptions, tessellated};
use wavelux_scene::{MeshElement, Scene, Shape};

use crate::error::{VolumeError, config};
use crate::grid::VolumeGrid;

/// Largest albedo of a voxelised surface (the grid's albedo must be `< 1`).
pub const MAX_ALBEDO: f64 = 0.999;

/// Largest `N` of [`voxelize`].
pub const MAX_VOXELIZE: usize = 256;

/// Rasterises `scene`'s surfaces into an `n³` grid (`n` a power of two in
/// `4..=`[`MAX_VOXELIZE`]); see the module documentation.
///
/// # Errors
/// [`VolumeError::Config`] for a bad `n`, a scene without surfaces, or a surface that
/// cannot be tessellated.
pub fn voxelize(scene: &Scene, n: usize) -> Result<VolumeGrid, VolumeError> {
    if !(4..=MAX_VOXELIZE).contains(&n) || !n.is_power_of_two() {
        return Err(config(
            "voxelize",
            format!("{n} must be a power of two in 4..={MAX_VOXELIZE}"),
        ));
    }
    if scene.surfaces.is_empty() {
        return Err(config("voxelize", "the scene has no surfaces"));
    }
    let tess = tessellated(scene, &TessellateOptions::default())
        .map_err(|e| config("voxelize", format!("tessellation failed: {e}")))?;
    let mut elements: Vec<(usize, MeshElement)> = Vec::new();
    let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    for (i, s) in tess.surfaces.iter().enumerate() {
        let els: Vec<MeshElement> = match &s.shape {
            Shape::Mesh(m) => m.elements().collect(),
            Shape::Triangle(t) => vec![MeshElement::Triangle(*t)],
            Shape::Parallelogram {
                origin,
                edge_u,
                edge_v,
            } => vec![MeshElement::Parallelogram {
                origin: *origin,
                edge_u: *edge_u,
                edge_v: *edge_v,
            }],
            _ => {
                return Err(config(
                    "voxelize",
                    format!("surface {:?} was not tessellated", s.name),
                ));
            }
        };
        for e in els {
            for p in corners(&e) {
                lo = lo.min(p);
                hi = hi.max(p);
            }
            elements.push((i, e));
        }
    }
    let extent = (hi - lo).max_element();
    if !(extent.is_finite() && extent > 0.0) {
        return Err(config("voxelize", "the surfaces span no volume"));
    }
    let inner = (n - 2) as f64;
    let h = extent / inner * (1.0 + 1e-9);
    let centre = 0.5 * (lo + hi);
    let min = centre - DVec3::splat(0.5 * n as f64 * h);

    let mut area = Array3::<f64>::zeros((n, n, n));
    let mut refl = [0, 1, 2].map(|_| Array3::<f64>::zeros((n, n, n)));
    let mut power = [0, 1, 2].map(|_| Array3::<f64>::zeros((n, n, n)));
    for (i, e) in &elements {
        let surf = &tess.surfaces[*i];
        let m = &tess.materials[surf.material];
        let mut rho = m.reflectance.0;
        if let Some(t) = m
            .reflectance_texture
            .and_then(|t| tess.textures.get(t.texture))
        {
            let t = t.mean().0;
            rho = std::array::from_fn(|c| rho[c] * t[c]);
        }
        let mut emit = m.emission.0;
        if let Some(t) = m
            .emission_texture
            .and_then(|t| tess.textures.get(t.texture))
        {
            let t = t.mean().0;
            emit = std::array::from_fn(|c| emit[c] * t[c]);
        }
        sample(e, 0.25 * h, &mut |p, a| {
            let idx = ((p - min) / h).floor();
            let at = [idx.z, idx.y, idx.x].map(|v| (v.max(1.0) as usize).min(n - 2));
            let at = (at[0], at[1], at[2]);
            area[at] += a;
            for c in 0..3 {
                refl[c][at] += a * rho[c];
                power[c][at] += a * emit[c];
            }
        });
    }
    let v = h * h * h;
    let mut opacity = Array3::<f64>::zeros((n, n, n));
    let mut source = [0, 1, 2].map(|_| Array3::<f64>::zeros((n, n, n)));
    let mut albedo = [0, 1, 2].map(|_| Array3::<f64>::zeros((n, n, n)));
    for ((z, y, x), o) in opacity.indexed_iter_mut() {
        let shell = [x, y, z].iter().any(|&k| k == 0 || k == n - 1);
        let a = area[(z, y, x)];
        if shell {
            *o = 1.0;
        } else if a > 0.0 {
            *o = 1.0;
            for c in 0..3 {
                albedo[c][(z, y, x)] = (refl[c][(z, y, x)] / a).clamp(0.0, MAX_ALBEDO);
                source[c][(z, y, x)] = power[c][(z, y, x)] / v;
            }
        }
    }
    VolumeGrid::new(
        &format!("{} (voxelised {n}³)", scene.name),
        h,
        min,
        opacity,
        source,
        albedo,
    )
}

fn corners(e: &MeshElement) -> Vec<DVec3> {
    match *e {
        MeshElement::Triangle(t) => t.to_vec(),
        MeshElement::Parallelogram {
            origin,
            edge_u,
            edge_v,
        } => vec![
            origin,
            origin + edge_u,
            origin + edge_v,
            origin + edge_u + edge_v,
        ],
    }
}

/// Calls `f(point, area)` at the centres of a uniform subdivision of `e` whose pieces
/// have edges of at most `step`; the areas sum to the element's.
fn sample(e: &MeshElement, step: f64, f: &mut dyn FnMut(DVec3, f64)) {
    match *e {
        MeshElement::Triangle([a, b, c]) => {
            let longest = (b - a).length().max((c - b).length()).max((a - c).length());
            let k = ((longest / step).ceil() as usize).max(1);
            let area = 0.5 * (b - a).cross(c - a).length() / (k * k) as f64;
            let (u, w) = ((b - a) / k as f64, (c - a) / k as f64);
            // k² sub-triangles: k(k+1)/2 upright, k(k−1)/2 inverted.
            for i in 0..k {
                for j in 0..k - i {
                    let p = a + u * i as f64 + w * j as f64;
                    f(p + (u + w) / 3.0, area);
                    if j + 1 < k - i {
                        f(p + (u + w) * (2.0 / 3.0), area);
                    }
                }
            }
        }
        MeshElement::Parallelogram {
            origin,
            edge_u,
            edge_v,
        } => {
            let ku = ((edge_u.length() / step).ceil() as usize).max(1);
            let kv = ((edge_v.length() / step).ceil() as usize).max(1);
            let area = edge_u.cross(edge_v).length() / (ku * kv) as f64;
            for i in 0..ku {
                for j in 0..kv {
                    let s = (i as f64 + 0.5) / ku as f64;
                    let t = (j as f64 + 0.5) / kv as f64;
                    f(origin + edge_u * s + edge_v * t, area);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn samples_cover_the_area() {
        let t = MeshElement::Triangle([
            DVec3::ZERO,
            DVec3::new(3.0, 0.0, 0.0),
            DVec3::new(0.0, 2.0, 1.0),
        ]);
        let (mut sum, mut count) = (0.0, 0);
        sample(&t, 0.1, &mut |_, a| {
            sum += a;
            count += 1;
        });
        let want = 0.5
            * DVec3::new(3.0, 0.0, 0.0)
                .cross(DVec3::new(0.0, 2.0, 1.0))
                .length();
        assert!((sum - want).abs() < 1e-12 * want, "{sum} vs {want}");
        // Longest edge √14 over 0.1: 38 pieces per edge.
        assert_eq!(count, 38 * 38);
    }

    #[test]
    fn cornell_box_power_and_albedo() {
        let scene = wavelux_scene::builtin::builtin("cornell-box").unwrap();
        let g = voxelize(&scene, 16).unwrap();
        // The sources carry the emitted power exactly.
        let want = scene.emitted_power();
        let got = g.source_power();
        for c in 0..3 {
            assert!(
                (got[c] - want[c]).abs() <= 1e-9 * want[c],
                "{got:?} vs {want:?}"
            );
        }
        // The shell is opaque and black; inside, opaque cells have albedos of the
        // scene's reflectances and the middle of the box is empty.
        assert_eq!(g.opacity[(0, 5, 5)], 1.0);
        assert_eq!(g.albedo[0][(0, 5, 5)], 0.0);
        assert_eq!(g.opacity[(8, 12, 8)], 0.0);
        let max_rho = g.albedo[0].iter().fold(0.0f64, |m, &v| m.max(v));
        assert!(max_rho > 0.3 && max_rho < 1.0, "{max_rho}");
        assert!(voxelize(&scene, 12).is_err());
        assert!(voxelize(&scene, 512).is_err());
        assert!(voxelize(&wavelux_scene::Scene::new("empty"), 16).is_err());
    }
}
