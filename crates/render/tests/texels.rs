//! Function metrics: texel grids cover every lit side with its exact area, fields are
//! read at the texels consistently with the solver's own integrals, the noise floor is
//! the expected score of an exact answer, and the image metrics (reflected relative L1,
//! flat-region noise, downsampling) have their closed forms.

use glam::{DVec2, DVec3};
use wavelux_render::{Image, PathTracer, ReferenceOptions, SolutionField, TexelGrid, View};
use wavelux_scene::{
    AnalyticPatch, AnalyticSurface, Loop, Material, Placement, PlaneFrame, PolygonShape, Rgb,
    Scene, Shape, Sidedness, Surface, builtin,
};
use wavelux_solver::{BasisKind, LinearMethod, SolverConfig, solve};

fn opts(seed: u64) -> ReferenceOptions {
    ReferenceOptions {
        seed,
        ..ReferenceOptions::default()
    }
}

/// A sphere lamp over a two-sided floor with a round hole and a curved, trimmed
/// cylinder wall: every support kind the texels must resolve (parallelogram, masked
/// polygon with an arc, curved patch).
fn curved_scene() -> Scene {
    let mut s = Scene::new("curved");
    let floor = s.add_material(Material::lambertian("floor", Rgb::grey(0.6), Rgb::BLACK));
    let under = s.add_material(Material::lambertian("under", Rgb::grey(0.3), Rgb::BLACK));
    let wall = s.add_material(Material::lambertian(
        "wall",
        Rgb::new(0.5, 0.4, 0.3),
        Rgb::BLACK,
    ));
    let lamp = s.add_material(Material::lambertian("lamp", Rgb::BLACK, Rgb::grey(20.0)));
    s.add_surface(Surface {
        name: "floor".into(),
        shape: Shape::Polygon(PolygonShape {
            frame: PlaneFrame {
                origin: DVec3::ZERO,
                u: DVec3::X,
                v: DVec3::Y,
            },
            outer: Loop::polygon(&[
                DVec2::new(-1.0, -1.0),
                DVec2::new(1.0, -1.0),
                DVec2::new(1.0, 1.0),
                DVec2::new(-1.0, 1.0),
            ]),
            holes: vec![Loop::circle(DVec2::new(0.4, 0.3), 0.2)],
        }),
        material: floor,
        sides: Sidedness::TwoSided { back: under },
    });
    let pl = |o: DVec3| Placement {
        origin: o,
        axis: DVec3::Z,
        reference: DVec3::X,
    };
    s.add_surface(Surface {
        name: "wall".into(),
        shape: Shape::Patch(AnalyticPatch {
            surface: AnalyticSurface::Cylinder {
                placement: pl(DVec3::new(-0.3, -0.2, 0.0)),
                radius: 0.4,
                azimuth: (0.5, 3.5),
                height: (0.0, 0.6),
            },
            trim: None,
        }),
        material: wall,
        sides: Sidedness::OneSided,
    });
    s.add_surface(Surface {
        name: "lamp".into(),
        shape: Shape::Patch(AnalyticPatch {
            surface: AnalyticSurface::Sphere {
                placement: pl(DVec3::new(0.2, 0.1, 1.2)),
                radius: 0.15,
                azimuth: (0.0, std::f64::consts::TAU),
                latitude: (-1.5, 1.5),
            },
            trim: None,
        }),
        material: lamp,
        sides: Sidedness::OneSided,
    });
    s
}

#[test]
fn texels_cover_every_lit_side_with_its_area() {
    for scene in [builtin::cornell_box(), curved_scene(), builtin::occluded()] {
        for density in [50.0, 2000.0] {
            let g = TexelGrid::new(&scene, density).unwrap();
            for (i, surf) in scene.surfaces.iter().enumerate() {
                let sides: &[bool] = match surf.sides {
                    Sidedness::TwoSided { .. } => &[false, true],
                    _ => &[false],
                };
                for &back in [false, true].iter() {
                    let a: f64 = g
                        .texels
                        .iter()
                        .filter(|t| t.surface == i && t.back == back)
                        .map(|t| t.area)
                        .sum();
                    let want = if sides.contains(&back) {
                        surf.shape.area()
                    } else {
                        0.0
                    };
                    assert!(
                        (a - want).abs() <= 1e-9 * want.max(1.0),
                        "{} {} back {back}: {a} vs {want}",
                        scene.name,
                        surf.name
                    );
                }
            }
            let lit: f64 = scene
                .surfaces
                .iter()
                .map(|s| {
                    s.shape.area()
                        * if matches!(s.sides, Sidedness::TwoSided { .. }) {
                            2.0
                        } else {
                            1.0
                        }
                })
                .sum();
            // At least one texel per primitive, else about the density.
            assert!(g.len() as f64 >= 0.5 * density * lit, "{}", scene.name);
            assert!(
                g.len() as f64 <= 2.0 * density * lit + 400.0,
                "{}",
                scene.name
            );
            for t in &g.texels {
                assert!((DVec3::from_array(t.normal).length() - 1.0).abs() < 1e-9);
            }
        }
    }
    assert!(TexelGrid::new(&builtin::cornell_box(), f64::NAN).is_err());
    assert!(TexelGrid::new(&builtin::cornell_box(), -1.0).is_err());
    assert!(TexelGrid::new(&builtin::cornell_box(), 1e12).is_err());
}

/// Read at the texels, a solution's area-weighted mean over a surface side equals the
/// solver's own real-area average of that side (an independent quadrature of the same
/// function), and every texel resolves to its own surface and side.
#[test]
fn texel_values_integrate_to_the_solvers_side_averages() {
    for (scene, basis) in [
        (builtin::cornell_box(), BasisKind::Multiwavelet(3)),
        (curved_scene(), BasisKind::Haar),
    ] {
        let sol = solve(
            &scene,
            &SolverConfig {
                basis,
                eps: 0.1,
                max_level: 2,
                linear_method: LinearMethod::Gmres { restart: 30 },
                ..SolverConfig::default()
            },
        )
        .unwrap();
        let field = SolutionField::new(&sol).unwrap();
        let g = TexelGrid::new(&scene, 40_000.0 / scene.total_area()).unwrap();
        let v = g.evaluate(&field);
        assert_eq!(v.unresolved, 0, "{}", scene.name);
        for (i, surf) in scene.surfaces.iter().enumerate() {
            for (back, side) in [
                (false, wavelux_solver::Side::Front),
                (true, wavelux_solver::Side::Back),
            ] {
                let Some(want) = wavelux_render::side_average(&sol, i, side) else {
                    continue;
                };
                let (mut acc, mut a) = ([0.0; 3], 0.0);
                for (t, val) in g.texels.iter().zip(&v.values) {
                    if t.surface == i && t.back == back {
                        for c in 0..3 {
                            acc[c] += t.area * val[c];
                        }
                        a += t.area;
                    }
                }
                for c in 0..3 {
                    let got = acc[c] / a;
                    assert!(
                        (got - want[c]).abs() <= 0.01 * want[c].abs() + 1e-9,
                        "{} {} back {back} channel {c}: texels {got} vs solver {}",
                        scene.name,
                        surf.name,
                        want[c]
                    );
                }
            }
        }
    }
}

/// The white furnace's exact answer `E/(1 − ρ)` scores the noise floor against a
/// path-traced texel reference: `E|N(0, σ²)| = σ√(2/π)` (the mean over 864 texel
/// channels has a relative spread of about 4 %), and every texel agrees with the
/// closed form within 5 standard errors.
#[test]
fn an_exact_answer_scores_the_noise_floor() {
    let (e, rho) = (1.0, 0.5);
    let scene = builtin::white_furnace(e, rho).unwrap();
    let pt = PathTracer::new(&scene).unwrap();
    let g = TexelGrid::new(&scene, 48.0).unwrap();
    assert_eq!(g.len(), 6 * 49);
    let est = pt.texels(&g, 200, &opts(4)).unwrap();
    let exact = e / (1.0 - rho);
    for x in &est {
        for c in 0..3 {
            assert!((x.mean[c] - exact).abs() <= 5.0 * x.std_error[c], "{x:?}");
        }
    }
    let m = g
        .compare_estimates(&vec![[exact; 3]; g.len()], &est)
        .unwrap();
    let floor = m.noise_floor.unwrap();
    assert!(
        (m.relative_l1 / floor - 1.0).abs() < 0.2,
        "{} vs floor {floor}",
        m.relative_l1
    );
    // Thread-count independence of the texel reference.
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(|| pt.texels(&g, 50, &opts(4)).unwrap());
    assert_eq!(one, pt.texels(&g, 50, &opts(4)).unwrap());
}

#[test]
fn texel_metric_closed_forms() {
    let scene = builtin::cornell_box();
    let g = TexelGrid::new(&scene, 300.0).unwrap();
    // Reference: E + (1, 2, 3) everywhere; values off by 10 % of the reflected part.
    let r: Vec<[f64; 3]> = g
        .texels
        .iter()
        .map(|t| {
            [
                t.emission[0] + 1.0,
                t.emission[1] + 2.0,
                t.emission[2] + 3.0,
            ]
        })
        .collect();
    let v: Vec<[f64; 3]> = g
        .texels
        .iter()
        .zip(&r)
        .map(|(t, x)| std::array::from_fn(|c| x[c] + 0.1 * (x[c] - t.emission[c])))
        .collect();
    let m = g.compare(&v, &r, None).unwrap();
    assert!((m.relative_l1 - 0.1).abs() < 1e-12, "{}", m.relative_l1);
    assert!((m.max_relative - 0.1).abs() < 1e-12);
    assert_eq!(m.noise_floor, None);
    assert!(g.compare(&v[1..], &r, None).is_err());
    let dark: Vec<[f64; 3]> = g.texels.iter().map(|t| t.emission).collect();
    assert!(g.compare(&v, &dark, None).is_err());
}

fn image(w: usize, h: usize, mut f: impl FnMut(usize, usize) -> [f64; 3]) -> Image {
    let mut img = Image::new(w, h);
    for y in 0..h {
        for x in 0..w {
            img.pixels[y * w + x] = f(x, y);
        }
    }
    img
}

#[test]
fn image_metric_closed_forms() {
    let (w, h) = (20, 12);
    let reference = image(w, h, |x, y| [1.0 + x as f64, 2.0, 0.5 + y as f64]);
    // A 2×2 light at (5..7, 4..6): it and its one-pixel ring (4×4 = 16 pixels) are left
    // out, so the light's wrong values do not count.
    let emitters = image(w, h, |x, y| {
        if (5..7).contains(&x) && (4..6).contains(&y) {
            [9.0; 3]
        } else {
            [0.0; 3]
        }
    });
    let a = image(w, h, |x, y| {
        let r = reference.pixels[y * w + x];
        if emitters.pixels[y * w + x][0] > 0.0 {
            [100.0; 3]
        } else {
            r.map(|v| 1.03 * v)
        }
    });
    let (e, kept) = a.reflected_relative_l1(&reference, &emitters).unwrap();
    assert_eq!(kept, w * h - 16);
    assert!((e - 0.03).abs() < 1e-12, "{e}");
    assert!(
        a.reflected_relative_l1(&Image::new(3, 3), &emitters)
            .is_err()
    );
    // Downsampling keeps the mean and averages blocks.
    let d = reference.downsample(4).unwrap();
    assert_eq!((d.width, d.height), (5, 3));
    assert!((d.pixels[0][0] - 2.5).abs() < 1e-12 && (d.pixels[0][2] - 2.0).abs() < 1e-12);
    assert!(reference.downsample(3).is_err() && reference.downsample(0).is_err());
    // Flat noise: zero on a linear ramp, σ on independent noise of relative σ.
    let flat = vec![true; 200 * 200];
    let ramp = image(200, 200, |x, y| {
        [1.0 + 0.01 * x as f64 + 0.02 * y as f64; 3]
    });
    assert!(ramp.flat_noise(&flat).unwrap() < 1e-9);
    let mut state = 12345u64;
    let mut unif = move || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    // Uniform noise of half-width 0.01·√3 has standard deviation 0.01.
    let noisy = image(200, 200, |_, _| {
        [1.0 + 0.01 * 3f64.sqrt() * (2.0 * unif() - 1.0); 3]
    });
    let n = noisy.flat_noise(&flat).unwrap();
    assert!((n - 0.01).abs() < 0.0005, "{n}");
    assert_eq!(noisy.flat_noise(&vec![false; 200 * 200]), None);
    // Brighter and darker halves with the same relative noise (the step between them
    // left out of the mask, as the flat mask leaves out edges): still σ.
    let halves = image(200, 200, |x, _| {
        let base = if x < 100 { 1.0 } else { 0.05 };
        [base * (1.0 + 0.01 * 3f64.sqrt() * (2.0 * unif() - 1.0)); 3]
    });
    let off_step: Vec<bool> = (0..200 * 200)
        .map(|i| !(99..=100).contains(&(i % 200)))
        .collect();
    let n = halves.flat_noise(&off_step).unwrap();
    assert!((n - 0.01).abs() < 0.0005, "{n}");
    // A near-black square with a large relative deviation (a checkerboard of 1e-6 and
    // 2e-6, invisible on a display), its rim left out of the mask as the flat mask
    // leaves out edges, does not dominate: the noise stays the bright part's 1 % (a
    // mean of per-pixel ratios gives about 6 % here).
    let inside = |x: usize, y: usize| (90..110).contains(&x) && (90..110).contains(&y);
    let dark = image(200, 200, |x, y| {
        if inside(x, y) {
            [1e-6 * (1.0 + ((x + y) % 2) as f64); 3]
        } else {
            [1.0 + 0.01 * 3f64.sqrt() * (2.0 * unif() - 1.0); 3]
        }
    });
    let rim: Vec<bool> = (0..200 * 200)
        .map(|i| {
            let (x, y) = (i % 200, i / 200);
            let c = inside(x, y);
            (x.saturating_sub(1)..=(x + 1).min(199))
                .all(|u| (y.saturating_sub(1)..=(y + 1).min(199)).all(|v| inside(u, v) == c))
        })
        .collect();
    let n = dark.flat_noise(&rim).unwrap();
    assert!((n - 0.01).abs() < 0.0005, "{n}");
}

/// On the Cornell box the flat pixels see no light source, and the flat noise of
/// path-traced images falls like `1/√spp` (it measures Monte Carlo noise, not
/// shading).
#[test]
fn flat_noise_of_path_traced_images_falls_with_the_samples() {
    let scene = builtin::cornell_box();
    let pt = PathTracer::new(&scene).unwrap();
    let view = View::new(&scene.cameras[0], 64, 64).unwrap();
    let flat = pt.flat_pixels(&view);
    let em = pt.emission_image(&view, 4).unwrap();
    let nflat = flat.iter().filter(|&&f| f).count();
    assert!(nflat > 300, "{nflat} flat pixels");
    for (f, e) in flat.iter().zip(&em.pixels) {
        assert!(!(*f && e[0] > 0.0));
    }
    assert!(em.pixels.iter().any(|p| p[0] > 0.0));
    let n1 = pt
        .render(&view, 2, &opts(1), &|_| {})
        .unwrap()
        .flat_noise(&flat)
        .unwrap();
    let n2 = pt
        .render(&view, 8, &opts(1), &|_| {})
        .unwrap()
        .flat_noise(&flat)
        .unwrap();
    // 16× the samples: a quarter of the noise (within 25 %).
    assert!((n1 / n2 / 4.0 - 1.0).abs() < 0.25, "{n1} vs {n2}");
}

/// The flat mask leaves out every pixel whose neighbours' footprints reach another
/// face: an image that is exactly constant on each side of each primitive, drawn with
/// 3×3 jittered samples per pixel that straddle every edge of the box, its blocks and
/// its light, has zero flat noise (the former mask, 3×3 neighbourhoods on one
/// surface, measured the edges: 4.8 % on this image).
#[test]
fn flat_noise_of_a_piecewise_constant_image_is_zero() {
    use rand::RngExt;
    let scene = builtin::cornell_box();
    let pt = PathTracer::new(&scene).unwrap();
    let view = View::new(&scene.cameras[0], 96, 96).unwrap();
    let flat = pt.flat_pixels(&view);
    assert!(flat.iter().filter(|&&f| f).count() > 2000);
    let mut rng = rand_pcg::Pcg64::new(7, 0xa02b_dbf7_bb3c_0a7a_c28f_a16a_64ab_f96b);
    let img = image(96, 96, |x, y| {
        let mut acc = 0.0;
        for k in 0..9 {
            let (sx, sy) = ((k % 3) as f64, (k / 3) as f64);
            let ray = view.ray(
                x as f64 + (sx + rng.random::<f64>()) / 3.0,
                y as f64 + (sy + rng.random::<f64>()) / 3.0,
            );
            if let Some(h) = pt.accel().closest_hit(&ray, 0.0, f64::INFINITY) {
                acc += 1.0 + f64::from(h.prim) + if h.front { 0.0 } else { 100.0 };
            }
        }
        [acc / 9.0; 3]
    });
    let n = img.flat_noise(&flat).unwrap();
    assert!(n < 1e-12, "flat noise {n} of a piecewise constant image");
}
