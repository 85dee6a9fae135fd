//! Every surface behind `dyn Parametrization`: non-finite input never panics, inverses
//! of non-finite points are `None`, and the shape accessor names the right surface.

use glam::{DVec2, DVec3};
use std::f64::consts::PI;
use std::sync::Arc;
use wavelux_param::{
    BezierPatch, Cardioid, Cone, Cylinder, Frame, GeneralizedCylinder, Helix, Parallelogram,
    Parametrization, Revolution, Sphere, Spheroid, SurfaceShape, TangentDevelopable, Torus,
};

fn all() -> Vec<Box<dyn Parametrization>> {
    let f = Frame::canonical();
    let mut ctrl = [[DVec3::ZERO; 4]; 4];
    for i in 0..4 {
        for j in 0..4 {
            ctrl[i][j] = DVec3::new(i as f64, j as f64, 0.2 * (i * j) as f64);
        }
    }
    let prof =
        wavelux_param::BezierCurve::new(vec![DVec3::new(1.0, 0.0, 0.0), DVec3::new(0.5, 0.0, 1.0)])
            .unwrap();
    vec![
        Box::new(Parallelogram::new(DVec3::ZERO, DVec3::X, DVec3::Y).unwrap()),
        Box::new(Cylinder::new(f, 1.0, (0.0, 1.0), (0.0, 1.0)).unwrap()),
        Box::new(Cone::new(f, 1.0, 1.0, (0.0, 1.0), (0.0, 1.0)).unwrap()),
        Box::new(Sphere::full(f, 1.0).unwrap()),
        Box::new(Spheroid::oblate(f, 1.0, 0.3, (0.0, 1.0), (-1.0, 1.0)).unwrap()),
        Box::new(Torus::new(f, 2.0, 1.0, (0.0, PI), (0.0, PI)).unwrap()),
        Box::new(Revolution::new(f, Arc::new(prof), (0.0, 1.0), (0.0, 2.0)).unwrap()),
        Box::new(
            GeneralizedCylinder::new(
                f,
                Arc::new(Cardioid::new(1.0).unwrap()),
                DVec3::Z,
                (0.0, 2.0),
                (0.0, 1.0),
            )
            .unwrap(),
        ),
        Box::new(
            TangentDevelopable::new(
                f,
                Arc::new(Helix::new(1.0, 1.0).unwrap()),
                (0.0, 3.0),
                (0.1, 1.0),
            )
            .unwrap(),
        ),
        Box::new(BezierPatch::new(ctrl).unwrap()),
    ]
}

#[test]
fn non_finite_input_never_panics() {
    for s in all() {
        for uv in [
            DVec2::NAN,
            DVec2::new(f64::INFINITY, 0.5),
            DVec2::new(0.5, f64::NEG_INFINITY),
        ] {
            let _ = s.eval(uv);
            let _ = s.jacobian(uv);
        }
        for p in [DVec3::NAN, DVec3::new(0.0, f64::INFINITY, 0.0)] {
            assert_eq!(s.inverse(p), None, "{s:?}");
        }
    }
}

#[test]
fn shapes_and_bounds() {
    let names: Vec<&str> = all()
        .iter()
        .map(|s| match s.shape() {
            SurfaceShape::Parallelogram(_) => "parallelogram",
            SurfaceShape::Cylinder(_) => "cylinder",
            SurfaceShape::Cone(_) => "cone",
            SurfaceShape::Sphere(_) => "sphere",
            SurfaceShape::Spheroid(_) => "spheroid",
            SurfaceShape::Torus(_) => "torus",
            SurfaceShape::Revolution(_) => "revolution",
            SurfaceShape::GeneralizedCylinder(_) => "generalized cylinder",
            SurfaceShape::TangentDevelopable(_) => "tangent developable",
            SurfaceShape::BezierPatch(_) => "bezier",
            _ => "other",
        })
        .collect();
    assert_eq!(names.len(), 10);
    assert!(!names.contains(&"other"));
    // Bounds contain a dense sample of every patch.
    for s in all() {
        let b = s.bounds();
        for i in 0..=20 {
            for j in 0..=20 {
                let p = s.position(DVec2::new(i as f64 / 20.0, j as f64 / 20.0));
                assert!(
                    b.contains(p, 1e-12 * b.diagonal()),
                    "{s:?}: {p} outside {b:?}"
                );
            }
        }
    }
}
