//! Native (TOML) format: the showcase file parses into the intended scene (areas
//! against closed forms), includes of glTF and native files with prefix and
//! transform, include cycles, and typed errors; arbitrary text never panics.

mod common;

use std::f64::consts::PI;

use common::{MatSpec, MeshSpec, gltf_embedded, unit_square};
use proptest::prelude::*;
use wavelux_scene::{
    DefaultValue, EmissionProfile, SceneError, Shape, Sidedness, WarningKind, load, load_native,
    parse_native,
};

const SHOWCASE: &str = include_str!("data/showcase.toml");

#[test]
fn showcase_parses_with_closed_form_areas() {
    let s = parse_native(SHOWCASE, "showcase.toml", None).unwrap();
    assert_eq!(s.name, "showcase");
    assert!(s.warnings.is_empty());
    assert_eq!(
        s.defaults["basis"],
        DefaultValue::Str("multiwavelet".into())
    );
    assert_eq!(s.defaults["order"], DefaultValue::Int(2));
    assert_eq!(s.defaults["epsilon"], DefaultValue::Float(1e-4));
    let area = |n: &str| s.surface(n).unwrap().shape.area();
    let close = |a: f64, b: f64, tol: f64| (a - b).abs() <= tol * b.abs().max(1.0);
    assert!(close(area("floor"), 16.0, 1e-15));
    assert!(close(area("ceiling-light"), 1.0, 1e-15));
    assert!(close(area("wedge"), 0.5, 1e-15));
    assert!(close(area("prism"), 1.0, 1e-15));
    assert!(close(area("panel"), 12.0 - PI * 0.25 - 0.25, 1e-14));
    // Upper hemisphere 2πr² minus a disk of radius 0.1 of the equal-area square.
    assert!(close(
        area("dome"),
        2.0 * PI * 0.25 * (1.0 - PI * 0.01),
        1e-12
    ));
    assert!(close(area("pipe"), PI * 0.2 * 2.0, 1e-12));
    // Cone frustum between φ = 0.5 and 1: π a s (φ1² − φ0²), slant s = √(a² + b²).
    assert!(close(area("lampshade"), PI * 0.3 * 0.5 * 0.75, 1e-12));
    assert!(close(area("ring"), 4.0 * PI * PI * 0.6 * 0.1, 1e-9));
    // Prolate spheroid a = 0.2, c = 0.3: 2πa² (1 + c/(a e) asin e), e = √(1 − a²/c²).
    let (a, c) = (0.2f64, 0.3f64);
    let e = (1.0 - a * a / (c * c)).sqrt();
    assert!(close(
        area("egg"),
        2.0 * PI * a * a * (1.0 + c / (a * e) * e.asin()),
        1e-9
    ));
    // Bézier (u, (u − ½)²... ) strip: P(u, v) = (u, v, 3 + u(1 − u)); area = ∫ √(1 + (1 − 2u)²) du.
    let want = (2f64.sqrt() + 1f64.asinh()) / 2.0;
    assert!(close(area("patch"), want, 1e-9));
    // Materials.
    let m = |n: &str| &s.materials[s.material_id(n).unwrap()];
    assert_eq!(m("white").reflectance.0, [0.7; 3]);
    assert_eq!(m("lamp").emission.0, [100.0, 90.0, 80.0]);
    assert_eq!(
        m("spot").emission_profile,
        EmissionProfile::CosinePower { exponent: 8.0 }
    );
    let w = m("glossy").ward.unwrap();
    assert_eq!((w.alpha_x, w.alpha_y, w.specular.0), (0.2, 0.5, [0.1; 3]));
    assert_eq!(
        s.surface("wedge").unwrap().sides,
        Sidedness::TwoSided {
            back: s.material_id("white").unwrap()
        }
    );
    // Front sides: floor up (+y), panel +x, light down? (corners ccw seen from below.)
    let floor = &s.surface("floor").unwrap().shape;
    let Shape::Parallelogram { edge_u, edge_v, .. } = floor else {
        panic!()
    };
    assert!(edge_u.cross(*edge_v).y > 0.0);
    // Medium and camera.
    let h = &s.media[0];
    assert_eq!((h.voxel_count(), h.is_dyadic()), (8, true));
    assert_eq!(h.opacity[h.index(1, 1, 0)], 0.2);
    assert_eq!(s.cameras[0].forward, glam::DVec3::Z);
    // Everything converts to exact geometry.
    let prims = s.primitives("showcase.toml").unwrap();
    assert_eq!(
        prims.len(),
        s.surfaces
            .iter()
            .map(|x| x.shape.element_count())
            .sum::<usize>()
    );
}

#[test]
fn includes_gltf_and_native_with_prefix_and_transform() {
    let dir = tempfile::tempdir().unwrap();
    let (p, i) = unit_square(1.0);
    let text = gltf_embedded(
        &[MeshSpec::new("tile", p, i, 0)],
        &[MatSpec::grey("grey", 0.5)],
        &[],
    );
    std::fs::write(dir.path().join("tile.gltf"), text).unwrap();
    std::fs::write(
        dir.path().join("inner.toml"),
        "[[material]]\nname = \"m\"\nreflectance = 0.3\n[[surface]]\nname = \"s\"\nmaterial = \"m\"\nshape = { type = \"parallelogram\", origin = [0,0,0], edge_u = [1,0,0], edge_v = [0,1,0] }\n",
    )
    .unwrap();
    std::fs::create_dir(dir.path().join("sub")).unwrap();
    std::fs::write(
        dir.path().join("sub/main.toml"),
        r#"
[[include]]
path = "../tile.gltf"
prefix = "a/"
scale = 2.0
translate = [0, 0, 5]

[[include]]
path = "../tile.gltf"
prefix = "b/"

[[include]]
path = "../inner.toml"

[[surface]]
name = "own"
material = "a/grey"
shape = { type = "triangle", vertices = [[0,0,0],[1,0,0],[0,1,0]] }
"#,
    )
    .unwrap();
    let s = load(dir.path().join("sub/main.toml")).unwrap();
    assert_eq!(s.name, "main");
    let names: Vec<_> = s.surfaces.iter().map(|x| x.name.as_str()).collect();
    assert_eq!(names, ["a/tile", "b/tile", "s", "own"]);
    assert!((s.surface("a/tile").unwrap().shape.area() - 4.0).abs() < 1e-12);
    let Shape::Mesh(m) = &s.surface("a/tile").unwrap().shape else {
        panic!()
    };
    assert!(m.positions.iter().all(|p| p.z == 5.0));
    assert_eq!(s.materials.len(), 3);
}

#[test]
fn include_cycles_are_typed_errors() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("a.toml"),
        "[[include]]\npath = \"b.toml\"\n",
    )
    .unwrap();
    std::fs::write(
        dir.path().join("b.toml"),
        "[[include]]\npath = \"a.toml\"\n",
    )
    .unwrap();
    assert!(matches!(
        load_native(dir.path().join("a.toml")),
        Err(SceneError::IncludeCycle { .. })
    ));
    // Self-include.
    std::fs::write(
        dir.path().join("c.toml"),
        "[[include]]\npath = \"c.toml\"\n",
    )
    .unwrap();
    assert!(matches!(
        load_native(dir.path().join("c.toml")),
        Err(SceneError::IncludeCycle { .. })
    ));
    // Missing include and no base.
    std::fs::write(
        dir.path().join("d.toml"),
        "[[include]]\npath = \"nope.toml\"\n",
    )
    .unwrap();
    assert!(matches!(
        load_native(dir.path().join("d.toml")),
        Err(SceneError::Io { .. })
    ));
    assert!(matches!(
        parse_native("[[include]]\npath = \"x.toml\"\n", "m", None),
        Err(SceneError::Unsupported { .. })
    ));
}

fn err(text: &str) -> SceneError {
    parse_native(text, "bad.toml", None).expect_err(text)
}

const PARA: &str =
    "shape = { type = \"parallelogram\", origin = [0,0,0], edge_u = [1,0,0], edge_v = [0,1,0] }";

#[test]
fn bad_input_gives_typed_errors_naming_file_and_element() {
    // Syntax error and unknown key: the TOML parser's message with position.
    assert!(matches!(err("name = "), SceneError::Native { file, .. } if file == "bad.toml"));
    assert!(
        matches!(err("colour = 1"), SceneError::Native { message, .. } if message.contains("colour"))
    );
    // Reflectance >= 1, negative, NaN.
    for v in ["1.0", "-0.1", "nan", "[0.5, 1.5, 0.5]"] {
        match err(&format!("[[material]]\nname = \"m\"\nreflectance = {v}\n")) {
            SceneError::InvalidReflectance { file, element, .. } => {
                assert_eq!(
                    (file.as_str(), element.as_str()),
                    ("bad.toml", "material \"m\"")
                );
            }
            other => panic!("{v}: {other:?}"),
        }
    }
    // Negative or infinite emission.
    for v in ["-1", "inf"] {
        assert!(matches!(
            err(&format!(
                "[[material]]\nname = \"m\"\nreflectance = 0.5\nemission = {v}\n"
            )),
            SceneError::InvalidEmission { .. }
        ));
    }
    // Ward total ≥ 1.
    assert!(matches!(
        err(
            "[[material]]\nname = \"m\"\nreflectance = 0.6\nward = { specular = 0.5, alpha_x = 0.1 }\n"
        ),
        SceneError::InvalidReflectance { .. }
    ));
    let mat = "[[material]]\nname = \"m\"\nreflectance = 0.5\n";
    // Unknown material, duplicate names.
    assert!(matches!(
        err(&format!("[[surface]]\nname = \"s\"\nmaterial = \"x\"\n{PARA}\n")),
        SceneError::UnknownReference { name, .. } if name == "x"
    ));
    assert!(matches!(
        err(&format!(
            "{mat}[[surface]]\nname = \"s\"\nmaterial = \"m\"\n{PARA}\n[[surface]]\nname = \"s\"\nmaterial = \"m\"\n{PARA}\n"
        )),
        SceneError::DuplicateName { .. }
    ));
    assert!(matches!(
        err(&format!("{mat}{mat}")),
        SceneError::DuplicateName { .. }
    ));
    // Non-finite coordinates.
    match err(&format!(
        "{mat}[[surface]]\nname = \"t\"\nmaterial = \"m\"\nshape = {{ type = \"triangle\", vertices = [[0,0,0],[1,0,nan],[0,1,0]] }}\n"
    )) {
        SceneError::NonFinite { element, .. } => assert_eq!(element, "surface \"t\""),
        other => panic!("{other:?}"),
    }
    // Non-planar quad; open arc; unsupported Bézier degree; bad sphere radius.
    let shape_err = |shape: &str| {
        err(&format!(
            "{mat}[[surface]]\nname = \"t\"\nmaterial = \"m\"\nshape = {shape}\n"
        ))
    };
    assert!(matches!(
        shape_err("{ type = \"quad\", corners = [[0,0,0],[1,0,0],[1,1,1],[0,1,0]] }"),
        SceneError::Malformed { .. }
    ));
    assert!(matches!(
        shape_err(
            "{ type = \"polygon\", origin = [0,0,0], u = [1,0,0], v = [0,1,0], outer = [{ start = [0,0] }, { start = [2,0], center = [0.5, 0] }] }"
        ),
        SceneError::Malformed { .. }
    ));
    assert!(matches!(
        shape_err("{ type = \"bezier\", degree = [5, 1], control = [] }"),
        SceneError::Unsupported { .. }
    ));
    assert!(matches!(
        shape_err("{ type = \"sphere\", center = [0,0,0], radius = -1 }"),
        SceneError::Malformed { .. }
    ));
    // Media out of range or wrong size.
    let medium = |extra: &str| {
        err(&format!(
            "[[medium]]\nname = \"f\"\nmin = [0,0,0]\nmax = [1,1,1]\nresolution = [2,1,1]\n{extra}\n"
        ))
    };
    assert!(matches!(
        medium("source = 0\nopacity = 1.5\nalbedo = 0.5"),
        SceneError::InvalidMedium { what, .. } if what == "opacity"
    ));
    assert!(matches!(
        medium("source = 0\nopacity = [0.5]\nalbedo = 0.5"),
        SceneError::Malformed { .. }
    ));
    assert!(matches!(
        medium("source = -1\nopacity = 0.5\nalbedo = 0.5"),
        SceneError::InvalidMedium { .. }
    ));
    // Degenerate camera.
    assert!(matches!(
        err("[[camera]]\nname = \"c\"\nposition = [0,0,0]\ntarget = [0,0,0]\nyfov_deg = 40\n"),
        SceneError::Malformed { .. }
    ));
}

#[test]
fn degenerate_triangles_are_dropped_with_a_warning_but_zero_area_surfaces_are_errors() {
    let mat = "[[material]]\nname = \"m\"\nreflectance = 0.5\n";
    let surf = |shape: &str| {
        parse_native(
            &format!("{mat}[[surface]]\nname = \"s\"\nmaterial = \"m\"\nshape = {shape}\n"),
            "w.toml",
            None,
        )
    };
    // One degenerate triangle of two: dropped, counted, reported.
    let s = surf("{ type = \"mesh\", positions = [[0,0,0],[1,0,0],[0,1,0],[2,0,0]], triangles = [[0,1,2],[0,1,3]] }").unwrap();
    assert_eq!(s.surfaces.len(), 1);
    assert_eq!(
        s.warnings
            .iter()
            .map(|w| (&w.file[..], &w.kind))
            .collect::<Vec<_>>(),
        [(
            "w.toml",
            &WarningKind::DegenerateTrianglesDropped { count: 1 }
        )]
    );
    // Whole surfaces of zero area are typed errors naming the file and the surface.
    for shape in [
        "{ type = \"parallelogram\", origin = [0,0,0], edge_u = [1,0,0], edge_v = [2,0,0] }",
        "{ type = \"mesh\", positions = [[0,0,0],[1,0,0],[2,0,0]], triangles = [[0,1,2]] }",
        "{ type = \"triangle\", vertices = [[0,0,0],[1,1,1],[2,2,2]] }",
    ] {
        match surf(shape) {
            Err(SceneError::Degenerate { file, element, .. }) => {
                assert_eq!(file, "w.toml");
                assert_eq!(element, "surface \"s\"");
            }
            other => panic!("{shape}: expected a zero-area error, got {other:?}"),
        }
    }
    // An emitter with 1e308 edges has an infinite area: an error, not a vanished light.
    match surf(
        "{ type = \"parallelogram\", origin = [0,0,0], edge_u = [1e308,0,0], edge_v = [0,1e308,0] }",
    ) {
        Err(SceneError::NonFinite {
            file,
            element,
            what,
            value,
        }) => {
            assert_eq!(
                (file.as_str(), element.as_str(), what.as_str()),
                ("w.toml", "surface \"s\"", "area")
            );
            assert!(value.is_infinite());
        }
        other => panic!("expected a non-finite area error, got {other:?}"),
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn arbitrary_text_never_panics(text in ".{0,300}") {
        let _ = parse_native(&text, "fuzz.toml", None);
    }

    /// Random line-level edits of the showcase never panic.
    #[test]
    fn corrupted_showcase_never_panics(edits in proptest::collection::vec((any::<usize>(), prop_oneof![
        Just(""), Just("radius = 0"), Just("radius = nan"), Just("resolution = [0, 1, 1]"),
        Just("resolution = [100000, 100000, 100000]"), Just("degree = [0, 0]"),
        Just("latitude_deg = [90, -90]"), Just("minor = 5"), Just("triangles = [[0, 1, 99]]"),
        Just("holes = [[{ start = [0, 0] }]]"), Just("yfov_deg = 180"), Just("generator = [-1, 1]"),
    ]), 1..4)) {
        let mut lines: Vec<String> = SHOWCASE.lines().map(str::to_string).collect();
        for (pos, rep) in edits {
            let n = lines.len();
            lines[pos % n] = rep.to_string();
        }
        let _ = parse_native(&lines.join("\n"), "fuzz.toml", None);
    }
}

#[test]
fn surface_tangents_are_read_validated_and_prefixed() {
    let text = r#"
[[material]]
name = "m"
reflectance = 0.5
ward = { specular = 0.2, alpha_x = 0.1, alpha_y = 0.4 }

[[surface]]
name = "brushed"
material = "m"
tangent = [1, 2, 0]
shape = { type = "parallelogram", origin = [0, 0, 0], edge_u = [1, 0, 0], edge_v = [0, 1, 0] }

[[surface]]
name = "plain"
material = "m"
shape = { type = "parallelogram", origin = [0, 0, 1], edge_u = [1, 0, 0], edge_v = [0, 1, 0] }
"#;
    let s = parse_native(text, "t.toml", None).unwrap();
    let i = s.surfaces.iter().position(|x| x.name == "brushed").unwrap();
    assert_eq!(s.tangent(i), Some(glam::DVec3::new(1.0, 2.0, 0.0)));
    let j = s.surfaces.iter().position(|x| x.name == "plain").unwrap();
    assert_eq!(s.tangent(j), None);
    // Merged under a prefix, the tangent follows its surface.
    let mut outer = wavelux_scene::Scene::new("outer");
    outer.merge(s, "in/");
    let k = outer
        .surfaces
        .iter()
        .position(|x| x.name == "in/brushed")
        .unwrap();
    assert_eq!(outer.tangent(k), Some(glam::DVec3::new(1.0, 2.0, 0.0)));
    outer.validate("outer").unwrap();
    // A zero tangent is a typed error naming the surface.
    let bad = text.replace("tangent = [1, 2, 0]", "tangent = [0, 0, 0]");
    match parse_native(&bad, "t.toml", None) {
        Err(SceneError::Malformed { file, element, .. }) => {
            assert_eq!(file, "t.toml");
            assert!(element.contains("brushed"), "{element}");
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn holes_outside_or_overlapping_are_typed_errors() {
    let poly = |holes: &str| {
        parse_native(
            &format!(
                "[[material]]\nname = \"m\"\nreflectance = 0.5\n\
                 [[surface]]\nname = \"floor\"\nmaterial = \"m\"\n\
                 shape = {{ type = \"polygon\", origin = [0,0,0], u = [1,0,0], v = [0,1,0], \
                 outer = [{{ start = [0,0] }}, {{ start = [1,0] }}, {{ start = [1,1] }}, {{ start = [0,1] }}], \
                 holes = {holes} }}\n"
            ),
            "h.toml",
            None,
        )
    };
    // Inside: area 1 − 0.25.
    let s = poly("[[{ start = [0.25,0.25] }, { start = [0.75,0.25] }, { start = [0.75,0.75] }, { start = [0.25,0.75] }]]").unwrap();
    assert!((s.total_area() - 0.75).abs() < 1e-12);
    // A hole outside the outer loop used to be accepted with area 1 − 0.5 = 0.5.
    for (holes, want) in [
        (
            "[[{ start = [2,0] }, { start = [3,0] }, { start = [3,0.5] }, { start = [2,0.5] }]]",
            "hole 0 is not inside the outer loop",
        ),
        (
            "[[{ start = [0.1,0.1] }, { start = [0.6,0.1] }, { start = [0.6,0.6] }, { start = [0.1,0.6] }], \
              [{ start = [0.4,0.4] }, { start = [0.9,0.4] }, { start = [0.9,0.9] }, { start = [0.4,0.9] }]]",
            "holes 0 and 1 overlap",
        ),
        (
            "[[{ start = [0.2,0.2] }, { start = [0.8,0.8] }, { start = [0.8,0.2] }, { start = [0.2,0.8] }]]",
            "hole 0 crosses or overlaps itself",
        ),
    ] {
        match poly(holes) {
            Err(SceneError::Malformed {
                file,
                element,
                what,
            }) => {
                assert_eq!(file, "h.toml");
                assert_eq!(element, "surface \"floor\"");
                assert!(what.contains(want), "{what}");
            }
            other => panic!("{holes}: expected a typed error, got {other:?}"),
        }
    }
}
