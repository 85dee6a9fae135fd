//! The glossy scene: one patch per lit side of every `wavelux-support` support, with
//! its Ward BRDF, emitter, shading frame and texture look-ups (Glossy §6.1–§6.3), the
//! eye patch that emits importance (§4.2), and one BVH over the real surfaces.
//!
//! - **Frames.** Ward's `α_x` follows the surface's `tangent` (from the scene,
//!   projected onto the tangent plane) or else the support's `∂/∂s`: a parallelogram's
//!   `edge_u`, a triangle's `b − a`, a disk's `u` axis, a curved map's `∂Ψ∘Λ/∂s` (central
//!   differences, projected). The direction square `(u₃, u₄)` is laid out in the same
//!   frame.
//! - **Textures** are looked up per sample (§6.2): reflectance and emission textures
//!   at the sample's texture coordinates (a mesh element's interpolated `TEXCOORD_n`,
//!   else the support's `(s, t)`).
//! - **Emitters**: Lambertian (`E/π`) or cosine-power spotlights
//!   (`E (n + 2) cosⁿθ/(2π)`, §6.3), times the emission texture.
//! - **The eye** (§4.2) is a square of side `1e-3 ×` the scene diagonal centred on the
//!   camera, facing along its view direction, transparent (not in the BVH) and black;
//!   it emits importance `Γ_e = 1` for directions inside the camera's viewing pyramid.
//!   Named patches can emit `Γ_e = 1` in every direction instead (Fig. 15's patch 3).

use glam::{DVec2, DVec3};
use wavelux_geometry::{Accel, Hit, Primitive};
use wavelux_scene::{Camera, EmissionProfile, Projection, Rgb, Scene, Shape, TextureRef};
use wavelux_support::{ParamKind, Side, Support, SupportMap, build_supports};

use crate::error::{GlossyError, invalid};
use crate::ward::{Brdf, Frame, MIN_ALPHA, WardLobe, WardVariant, cosine_power_radiance};

/// Side of the eye patch relative to the scene diagonal.
pub const EYE_SIZE_REL: f64 = 1e-3;

/// What emits importance (Glossy §4.2).
#[derive(Debug, Clone, PartialEq, Default)]
pub enum ImportanceSource {
    /// No importance: the oracle weighs every receiver by 1 (view-independent).
    #[default]
    Off,
    /// An eye patch at this camera emitting `Γ_e = 1` inside its viewing pyramid
    /// (`aspect`: width/height used when the camera has none).
    Camera {
        /// The camera.
        camera: Camera,
        /// Width / height of the image when the camera does not fix it.
        aspect: f64,
    },
    /// These surfaces (by name) emit `Γ_e = 1` in every direction.
    Surfaces(Vec<String>),
}

/// The viewing pyramid of the eye patch.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frustum {
    /// Unit view direction.
    pub forward: DVec3,
    /// Unit right direction.
    pub right: DVec3,
    /// Unit up direction.
    pub up: DVec3,
    /// `tan(xfov/2)`.
    pub tan_x: f64,
    /// `tan(yfov/2)`.
    pub tan_y: f64,
}

impl Frustum {
    /// Whether the world direction `w` lies inside the pyramid.
    #[must_use]
    pub fn contains(&self, w: DVec3) -> bool {
        let z = w.dot(self.forward);
        z > 0.0
            && w.dot(self.right).abs() <= self.tan_x * z
            && w.dot(self.up).abs() <= self.tan_y * z
    }
}

/// One patch: a lit side of a support (or the eye).
#[derive(Debug, Clone)]
pub struct Patch {
    /// Readable name: `surface[piece]` plus `/back` for back sides, or `eye`.
    pub name: String,
    /// Index of the scene surface (`usize::MAX` for the eye).
    pub surface: usize,
    /// Piece of the surface.
    pub piece: usize,
    /// Which side.
    pub side: Side,
    /// Primitive id in [`GlossyScene::accel`] (`None`: the transparent eye).
    pub prim: Option<u32>,
    /// The support (with this side's normal).
    pub support: Support,
    /// BRDF before textures.
    pub brdf: Brdf,
    /// Reflectance texture (multiplies `brdf.diffuse`).
    pub reflectance_texture: Option<TextureRef>,
    /// Emitted exitance `E` (W/m²) before textures.
    pub emission: [f64; 3],
    /// Cosine-power exponent of a spotlight (`None`: Lambertian).
    pub emission_exponent: Option<f64>,
    /// Emission texture (multiplies `emission`).
    pub emission_texture: Option<TextureRef>,
    /// Tangent hint of the shading frame (the surface's `tangent`).
    pub tangent: Option<DVec3>,
    /// Emits importance `Γ_e = 1` in every direction.
    pub importance: bool,
    /// The eye's viewing pyramid (only on the eye patch).
    pub frustum: Option<Frustum>,
    /// A curved side that sees itself (no self-link is made; its self-transfer is
    /// reported as lost).
    pub sees_itself: bool,
    /// `±1`: this side's normal over the curved map's own normal (`1` for planar maps).
    orientation: f64,
}

impl Patch {
    /// Whether this is the eye.
    #[must_use]
    pub fn is_eye(&self) -> bool {
        self.frustum.is_some()
    }

    /// Whether it emits light.
    #[must_use]
    pub fn is_emitter(&self) -> bool {
        self.emission.iter().any(|&e| e > 0.0)
    }

    /// Whether it reflects anything.
    #[must_use]
    pub fn reflects(&self) -> bool {
        !self.brdf.is_black()
    }

    /// The support's `∂/∂s` and `∂/∂t` directions at `(s, t)` of a planar map (see
    /// the module docs; curved maps go through [`Self::point_frame`]).
    fn planar_derivatives(&self, s: f64) -> (DVec3, DVec3) {
        match self.support.map {
            SupportMap::Parallelogram { edge_u, edge_v, .. } => (edge_u, edge_v),
            SupportMap::Triangle { a, b, c } => {
                // a + √s((1−t)(b−a) + t(c−a)).
                let r = s.max(1e-12).sqrt();
                (b - a, r * (c - b))
            }
            SupportMap::Disk { u, v, .. } => (u, v),
            SupportMap::Mapped { .. } => (DVec3::ZERO, DVec3::ZERO),
        }
    }

    /// The shading frame at `(s, t)`: normal of this side, tangent from the surface's
    /// tangent or `∂/∂s` (then `∂/∂t`, then any) projected onto the tangent plane.
    #[must_use]
    pub fn frame(&self, s: f64, t: f64) -> Frame {
        self.point_frame(s, t).2
    }

    /// Position, unit normal of this side and shading frame ([`Self::frame`]) at
    /// `(s, t)`, from a single evaluation of a curved map (`∂Ψ∘Λ/∂s` by the chain rule
    /// through the support's affine `Λ`; an equal-area Bézier evaluation costs
    /// thousands of area-element evaluations, so the transport asks once per point).
    #[must_use]
    pub fn point_frame(&self, s: f64, t: f64) -> (DVec3, DVec3, Frame) {
        let (p, n, d_ds, d_dt) = match (&self.support.map, &self.support.param) {
            (SupportMap::Mapped { origin, e1, e2 }, Some(psi)) => {
                let e = psi.eval(*origin + s * *e1 + t * *e2);
                let d_ds = e.dp_du * e1.x + e.dp_dv * e1.y;
                let d_dt = e.dp_du * e2.x + e.dp_dv * e2.y;
                (e.position, self.orientation * e.normal, d_ds, d_dt)
            }
            _ => {
                let (p, n) = self.support.point_normal(s, t);
                let (d_ds, d_dt) = self.planar_derivatives(s);
                (p, n, d_ds, d_dt)
            }
        };
        let hint = self.tangent.unwrap_or(d_ds);
        let frame = Frame::new(n, hint)
            .or_else(|| Frame::new(n, d_ds))
            .or_else(|| Frame::new(n, d_dt))
            .unwrap_or_else(|| Frame::any(n));
        (p, n, frame)
    }
}

/// The prepared scene.
#[derive(Debug)]
pub struct GlossyScene {
    /// Scene (file) name used in errors.
    pub file: String,
    /// Patches; the eye (if any) is last.
    pub patches: Vec<Patch>,
    /// BVH over the real surfaces (one primitive per support piece).
    pub accel: Accel,
    /// `[front patch, back patch]` per primitive.
    prim_sides: Vec<[Option<usize>; 2]>,
    /// Texture-coordinate lookup per patch (`None`: the support's `(s, t)`).
    texcoords: Vec<Option<TexMap>>,
    /// The scene's textures.
    pub textures: Vec<wavelux_scene::Texture>,
    /// Scene diagonal (m).
    pub diagonal: f64,
    /// Warnings (roughness below [`MIN_ALPHA`], albedo above 1, self-seeing patches).
    pub warnings: Vec<String>,
}

/// Texture coordinates of a mesh element: `uv(s, t)` from the vertices' coordinates.
#[derive(Debug, Clone, Copy)]
enum TexMap {
    /// `o + s (a − o) + t (b − o)`.
    Parallelogram([DVec2; 3]),
    /// `a + √s((1−t)(b−a) + t(c−a))`.
    Triangle([DVec2; 3]),
}

impl TexMap {
    fn at(&self, s: f64, t: f64) -> DVec2 {
        match *self {
            TexMap::Parallelogram([o, a, b]) => o + s * (a - o) + t * (b - o),
            TexMap::Triangle([a, b, c]) => {
                let r = s.max(0.0).sqrt();
                a + r * ((1.0 - t) * (b - a) + t * (c - a))
            }
        }
    }
}

fn texmap(scene: &Scene, surface: usize, piece: usize, set: u32) -> Option<TexMap> {
    let Shape::Mesh(m) = &scene.surfaces.get(surface)?.shape else {
        return None;
    };
    let uv = m.uv_sets.get(set as usize)?;
    let np = m.parallelograms.len();
    if piece < np {
        let q = m.parallelograms[piece];
        Some(TexMap::Parallelogram([
            uv[q[0] as usize],
            uv[q[1] as usize],
            uv[q[3] as usize],
        ]))
    } else {
        let t = m.triangles.get(piece - np)?;
        Some(TexMap::Triangle(t.map(|i| uv[i as usize])))
    }
}

/// `±1`: a curved support's side normal over its map's own normal (`1` for planar
/// maps), so that [`Patch::point_frame`] needs one evaluation of the map.
fn orientation_of(support: &Support) -> f64 {
    match (&support.map, &support.param) {
        (SupportMap::Mapped { origin, e1, e2 }, Some(psi)) => {
            let n = psi.normal(*origin + 0.5 * (*e1 + *e2));
            if support.normal_at(0.5, 0.5).dot(n) < 0.0 {
                -1.0
            } else {
                1.0
            }
        }
        _ => 1.0,
    }
}

fn scene_err(file: &str, element: impl Into<String>, reason: impl Into<String>) -> GlossyError {
    GlossyError::Scene {
        file: file.into(),
        element: element.into(),
        reason: reason.into(),
    }
}

impl GlossyScene {
    /// Prepares a scene: supports of every lit side (equal-area maps), BRDFs with the
    /// Ward `variant`, emitters, the BVH, and the importance source.
    ///
    /// # Errors
    /// [`GlossyError::Scene`] naming the file and element for invalid materials or
    /// geometry, a surface `tangent` along the normal, an unknown importance surface,
    /// a non-perspective importance camera; [`GlossyError::NoImportanceSource`] for
    /// importance from an empty surface list.
    pub fn new(
        scene: &Scene,
        file: &str,
        variant: WardVariant,
        importance: &ImportanceSource,
    ) -> Result<Self, GlossyError> {
        scene
            .validate(file)
            .map_err(|e| scene_err(file, "scene", e.to_string()))?;
        let set = build_supports(scene, ParamKind::EqualArea)
            .map_err(|e| scene_err(file, "supports", e.to_string()))?;
        let mut warnings = Vec::new();
        let mut brdfs: Vec<Option<Brdf>> = vec![None; scene.materials.len()];
        for (i, m) in scene.materials.iter().enumerate() {
            let element = format!("material {:?}", m.name);
            let mut b = Brdf::lambertian(m.reflectance.0);
            if let Some(w) = &m.ward {
                let lobe = WardLobe::new(variant, w.alpha_x, w.alpha_y)
                    .map_err(|e| scene_err(file, &element, e.to_string()))?;
                if w.alpha_x.min(w.alpha_y) < MIN_ALPHA {
                    warnings.push(format!(
                        "{file}: {element}: Ward roughness {} below {MIN_ALPHA}: transport \
                         coefficients are not designed for such sharp lobes",
                        w.alpha_x.min(w.alpha_y)
                    ));
                }
                b.specular = w.specular.0;
                b.lobe = Some(lobe);
                if b.is_glossy() {
                    let a = lobe
                        .max_albedo()
                        .map_err(|e| scene_err(file, &element, e.to_string()))?;
                    let worst = (0..3)
                        .map(|c| b.diffuse[c] + b.specular[c] * a)
                        .fold(0.0, f64::max);
                    if worst >= 1.0 {
                        warnings.push(format!(
                            "{file}: {element}: albedo {worst:.4} >= 1 at some incidence \
                             under the {} Ward variant (the solution may not converge)",
                            variant.name()
                        ));
                    }
                }
            }
            for v in b.diffuse.iter().chain(b.specular.iter()) {
                if !v.is_finite() {
                    return Err(GlossyError::NonFinite {
                        what: "reflectance",
                        value: *v,
                    });
                }
            }
            brdfs[i] = Some(b);
        }
        let named: Vec<String> = match importance {
            ImportanceSource::Surfaces(v) => {
                if v.is_empty() {
                    return Err(GlossyError::NoImportanceSource(format!(
                        "{file}: empty list of importance surfaces"
                    )));
                }
                for n in v {
                    if scene.surface(n).is_none() {
                        return Err(scene_err(
                            file,
                            format!("surface {n:?}"),
                            "importance surface not found",
                        ));
                    }
                }
                v.clone()
            }
            _ => Vec::new(),
        };
        let mut patches = Vec::with_capacity(set.sides.len() + 1);
        let mut texcoords = Vec::with_capacity(set.sides.len() + 1);
        let mut prim_sides = vec![[None, None]; set.pieces.len()];
        for side in &set.sides {
            let surf = &scene.surfaces[side.surface];
            let m = &scene.materials[side.material];
            let element = format!("surface {:?}", surf.name);
            let brdf = brdfs[side.material].ok_or_else(|| scene_err(file, &element, "material"))?;
            let exponent = match m.emission_profile {
                EmissionProfile::CosinePower { exponent } if exponent > 0.0 => Some(exponent),
                _ => None,
            };
            let name = format!(
                "{}[{}]{}",
                surf.name,
                side.piece,
                if side.side == Side::Back { "/back" } else { "" }
            );
            let tangent = scene.tangent(side.surface);
            let p = Patch {
                name,
                surface: side.surface,
                piece: side.piece,
                side: side.side,
                prim: Some(side.prim),
                support: side.support.clone(),
                brdf,
                reflectance_texture: m.reflectance_texture,
                emission: m.emission.0,
                emission_exponent: exponent,
                emission_texture: m.emission_texture,
                tangent,
                importance: named.contains(&surf.name),
                frustum: None,
                sees_itself: side.support.sees_itself(),
                orientation: orientation_of(&side.support),
            };
            if let Some(t) = tangent {
                let n = p.support.normal_at(0.5, 0.5);
                if Frame::new(n, t).is_none() {
                    return Err(scene_err(
                        file,
                        &element,
                        format!("tangent {t} is along the surface normal {n}"),
                    ));
                }
            }
            if p.sees_itself {
                warnings.push(format!(
                    "{file}: {element}: the patch sees itself; the glossy method makes no \
                     self-link, so light it sends to itself is lost (reported in the stats)"
                ));
            }
            let set_index = m
                .reflectance_texture
                .or(m.emission_texture)
                .map_or(0, |t| t.uv_set);
            texcoords.push(texmap(scene, side.surface, side.piece, set_index));
            let k = usize::from(side.side == Side::Back);
            prim_sides[side.prim as usize][k] = Some(patches.len());
            patches.push(p);
        }
        let prims: Vec<Primitive> = set
            .pieces
            .iter()
            .map(|s| s.primitive())
            .collect::<Result<_, _>>()
            .map_err(|e| scene_err(file, "geometry", e.to_string()))?;
        if prims.is_empty() {
            return Err(scene_err(file, "scene", "no surfaces"));
        }
        let accel = Accel::build(prims).map_err(|e| scene_err(file, "geometry", e.to_string()))?;
        let diagonal = accel.bounds().diagonal().length();
        if !(diagonal.is_finite() && diagonal > 0.0) {
            return Err(scene_err(file, "scene", "degenerate bounds"));
        }
        if let ImportanceSource::Camera { camera, aspect } = importance {
            let eye = eye_patch(file, camera, *aspect, diagonal)?;
            patches.push(eye);
            texcoords.push(None);
        }
        Ok(Self {
            file: file.into(),
            patches,
            accel,
            prim_sides,
            texcoords,
            textures: scene.textures.clone(),
            diagonal,
            warnings,
        })
    }

    /// The patch and `(s, t)` a ray hit (`None`: the black back of a one-sided
    /// surface, or an unknown primitive).
    #[must_use]
    pub fn resolve(&self, hit: &Hit) -> Option<(usize, DVec2)> {
        let sides = self.prim_sides.get(hit.prim as usize)?;
        let p = if hit.front { sides[0]? } else { sides[1]? };
        let st = self.patches[p].support.map.invert(hit.point, hit.uv);
        Some((p, st))
    }

    /// Index of the eye patch, if any.
    #[must_use]
    pub fn eye(&self) -> Option<usize> {
        self.patches.iter().position(Patch::is_eye)
    }

    fn tex(&self, patch: usize, t: Option<TextureRef>, s: f64, tt: f64) -> Option<Rgb> {
        let t = t?;
        let tex = self.textures.get(t.texture)?;
        let uv = match &self.texcoords[patch] {
            Some(m) => m.at(s, tt),
            None => DVec2::new(s, tt),
        };
        Some(tex.sample_nearest(uv.x, uv.y))
    }

    /// The BRDF of `patch` at `(s, t)` (reflectance texture applied).
    #[must_use]
    pub fn brdf_at(&self, patch: usize, s: f64, t: f64) -> Brdf {
        let p = &self.patches[patch];
        let mut b = p.brdf;
        if let Some(tx) = self.tex(patch, p.reflectance_texture, s, t) {
            b.diffuse = std::array::from_fn(|c| b.diffuse[c] * tx.0[c]);
        }
        b
    }

    /// Emitted exitance `E` of `patch` at `(s, t)` (texture applied; W/m²).
    #[must_use]
    pub fn exitance_at(&self, patch: usize, s: f64, t: f64) -> [f64; 3] {
        let p = &self.patches[patch];
        let mut e = p.emission;
        if let Some(tx) = self.tex(patch, p.emission_texture, s, t) {
            e = std::array::from_fn(|c| e[c] * tx.0[c]);
        }
        e
    }

    /// Emitted radiance of `patch` at `(s, t)` in the local direction `w` (z =
    /// normal), W/(m²·sr).
    #[must_use]
    pub fn emitted(&self, patch: usize, s: f64, t: f64, w: DVec3) -> [f64; 3] {
        let p = &self.patches[patch];
        if !p.is_emitter() || !crate::positive(w.z) {
            return [0.0; 3];
        }
        let e = self.exitance_at(patch, s, t);
        let n = p.emission_exponent.unwrap_or(0.0);
        let k = cosine_power_radiance(1.0, n, w.z);
        e.map(|v| v * k)
    }
}

/// The eye patch of a camera (see the module docs).
fn eye_patch(file: &str, cam: &Camera, aspect: f64, diag: f64) -> Result<Patch, GlossyError> {
    let element = format!("camera {:?}", cam.name);
    let yfov = match cam.projection {
        Projection::Perspective { yfov, aspect: a } => (yfov, a.unwrap_or(aspect)),
        _ => {
            return Err(scene_err(
                file,
                &element,
                "importance needs a perspective camera (an orthographic one has no eye point)",
            ));
        }
    };
    let (yfov, aspect) = yfov;
    let valid = yfov.is_finite()
        && yfov > 0.0
        && yfov < std::f64::consts::PI
        && aspect.is_finite()
        && aspect > 0.0
        && cam.position.is_finite();
    if !valid {
        return Err(invalid(
            "camera",
            format!("{element}: field of view {yfov}, aspect {aspect}"),
        ));
    }
    let f = cam.forward.normalize();
    let up = (cam.up - f * f.dot(cam.up)).normalize();
    let right = f.cross(up);
    let e = EYE_SIZE_REL * diag;
    let origin = cam.position - 0.5 * e * (right + up);
    // edge_u × edge_v = up × right = forward: the eye faces the scene.
    let support = Support::parallelogram(origin, e * up, e * right);
    let tan_y = (0.5 * yfov).tan();
    Ok(Patch {
        name: "eye".into(),
        surface: usize::MAX,
        piece: 0,
        side: Side::Front,
        prim: None,
        support,
        brdf: Brdf::lambertian([0.0; 3]),
        reflectance_texture: None,
        emission: [0.0; 3],
        emission_exponent: None,
        emission_texture: None,
        tangent: Some(right),
        importance: false,
        frustum: Some(Frustum {
            forward: f,
            right,
            up,
            tan_x: tan_y * aspect,
            tan_y,
        }),
        sees_itself: false,
        orientation: 1.0,
    })
}
