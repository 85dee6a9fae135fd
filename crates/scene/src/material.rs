//! Materials: Lambertian reflectance and emission (RGB, optionally textured), with room
//! for Ward glossy parameters (Glossy §6, [Ward 1992]) and directional emitters
//! (Glossy §6's "spotlights").
//!
//! # Radiometric conventions (one convention for every loader)
//!
//! - Surfaces are Lambertian unless [`Material::ward`] is set; the radiosity
//!   equation is `B = E + ρ·H` per RGB channel, with `B` radiosity (W/m²), `H`
//!   irradiance (W/m²) and `ρ` the diffuse reflectance, `0 <= ρ < 1`.
//! - [`Material::emission`] is the emitted **radiant exitance** `E` (W/m² per
//!   channel); a Lambertian emitter with exitance `E` has radiance `E/π`.
//! - glTF's `emissiveFactor × KHR_materials_emissive_strength` (times the emissive
//!   texture) is an emitted *radiance* in glTF's relative units; the glTF loader stores
//!   `E = π × emissive`. See `docs/scene-format.md`.

use crate::error::SceneError;

/// An RGB triple of linear (not sRGB-encoded) values.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Rgb(pub [f64; 3]);

impl Rgb {
    /// Black, `(0, 0, 0)`.
    pub const BLACK: Self = Self([0.0; 3]);

    /// Builds a triple.
    pub const fn new(r: f64, g: f64, b: f64) -> Self {
        Self([r, g, b])
    }

    /// The same value in all three channels.
    pub const fn grey(v: f64) -> Self {
        Self([v; 3])
    }

    /// Channel-wise product.
    pub fn times(self, o: Self) -> Self {
        Self([self.0[0] * o.0[0], self.0[1] * o.0[1], self.0[2] * o.0[2]])
    }

    /// Multiplies every channel by `s`.
    pub fn scale(self, s: f64) -> Self {
        Self(self.0.map(|c| c * s))
    }

    /// Largest channel.
    pub fn max_channel(self) -> f64 {
        self.0[0].max(self.0[1]).max(self.0[2])
    }

    /// Whether every channel is exactly zero.
    pub fn is_black(self) -> bool {
        self.0 == [0.0; 3]
    }

    /// Mean of the three channels.
    pub fn mean(self) -> f64 {
        (self.0[0] + self.0[1] + self.0[2]) / 3.0
    }
}

/// Converts an sRGB-encoded value in `[0, 1]` to linear (IEC 61966-2-1).
pub fn srgb_to_linear(c: f64) -> f64 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// A decoded RGB texture with linear values, row-major from the top-left texel
/// (glTF's convention: `uv = (0, 0)` is the top-left corner of the image).
#[derive(Debug, Clone, PartialEq)]
pub struct Texture {
    /// Name (glTF image name or URI, or a generated `image{i}`).
    pub name: String,
    /// Width in texels (`>= 1`).
    pub width: usize,
    /// Height in texels (`>= 1`).
    pub height: usize,
    /// `width × height` linear RGB texels, row-major, top row first.
    pub texels: Vec<Rgb>,
}

impl Texture {
    /// Nearest-texel lookup with repeat wrapping (glTF's default sampler wrap mode);
    /// black for non-finite coordinates or an inconsistent texture.
    pub fn sample_nearest(&self, u: f64, v: f64) -> Rgb {
        let wrap = |t: f64, n: usize| -> usize {
            let f = t - t.floor();
            let i = (f * n as f64) as usize;
            i.min(n - 1)
        };
        if !(u.is_finite() && v.is_finite())
            || self.width == 0
            || self.height == 0
            || self.texels.len() < self.width * self.height
        {
            return Rgb::BLACK;
        }
        let x = wrap(u, self.width);
        let y = wrap(v, self.height);
        self.texels[y * self.width + x]
    }

    /// Mean texel value (a box-filtered average over the whole image).
    pub fn mean(&self) -> Rgb {
        let n = self.texels.len().max(1) as f64;
        let mut s = [0.0; 3];
        for t in &self.texels {
            for c in 0..3 {
                s[c] += t.0[c];
            }
        }
        Rgb(s.map(|x| x / n))
    }
}

/// A reference from a material to a texture of the scene.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TextureRef {
    /// Index into [`crate::Scene::textures`].
    pub texture: usize,
    /// Which texture-coordinate set of the mesh to use (glTF `TEXCOORD_n`).
    pub uv_set: u32,
}

/// Ward's anisotropic glossy BRDF parameters (Glossy §6, [Ward 1992]): specular
/// reflectance `ρ_s` and roughnesses `α_x`, `α_y` along the surface's tangent
/// directions (`α_n`, `α_r` in Glossy §6). Stored for glossy methods; the diffuse
/// solvers use only [`Material::reflectance`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WardParams {
    /// Specular reflectance `ρ_s` per channel; `ρ_d + ρ_s < 1` channel-wise.
    pub specular: Rgb,
    /// Roughness along the surface's first tangent (`> 0`, radians-like slope).
    pub alpha_x: f64,
    /// Roughness along the second tangent (`> 0`); equal to `alpha_x` when isotropic.
    pub alpha_y: f64,
}

/// The angular distribution of emitted light.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[non_exhaustive]
pub enum EmissionProfile {
    /// Lambertian: radiance `E/π` in every direction of the front hemisphere.
    #[default]
    Lambertian,
    /// A directional emitter (Glossy §6's spotlights): radiance proportional to
    /// `cos^n θ`, normalised so that the exitance is still [`Material::emission`],
    /// i.e. radiance `E (n + 2) cos^n θ / (2π)` (`∫ L cos θ dω = E`).
    CosinePower {
        /// Exponent `n >= 0` (`n = 0` is Lambertian).
        exponent: f64,
    },
}

/// A material: what a surface side reflects and emits.
#[derive(Debug, Clone, PartialEq)]
pub struct Material {
    /// Unique name within the scene.
    pub name: String,
    /// Diffuse reflectance `ρ` per channel, `0 <= ρ < 1`. Multiplied by
    /// [`Material::reflectance_texture`] when present.
    pub reflectance: Rgb,
    /// Optional reflectance texture (values in `[0, 1]`, multiplied by
    /// [`Material::reflectance`]).
    pub reflectance_texture: Option<TextureRef>,
    /// Emitted radiant exitance `E` (W/m² per channel, `>= 0`). Multiplied by
    /// [`Material::emission_texture`] when present.
    pub emission: Rgb,
    /// Optional emission texture (multiplies [`Material::emission`]).
    pub emission_texture: Option<TextureRef>,
    /// Angular profile of the emission.
    pub emission_profile: EmissionProfile,
    /// Optional Ward glossy lobe (Glossy §6); `None` for purely Lambertian surfaces.
    pub ward: Option<WardParams>,
}

impl Material {
    /// A Lambertian material with constant reflectance and emission.
    pub fn lambertian(name: impl Into<String>, reflectance: Rgb, emission: Rgb) -> Self {
        Self {
            name: name.into(),
            reflectance,
            reflectance_texture: None,
            emission,
            emission_texture: None,
            emission_profile: EmissionProfile::Lambertian,
            ward: None,
        }
    }

    /// Whether the material emits (non-black emission).
    pub fn is_emitter(&self) -> bool {
        !self.emission.is_black()
    }

    /// The diffuse reflectance and emitted exitance (W/m²) the diffuse methods and the
    /// diffuse reference use: each texture replaced by its mean over the image, one
    /// constant over the whole surface. A texture index outside `textures` is ignored
    /// (loaders validate the indices).
    pub fn diffuse_means(&self, textures: &[Texture]) -> (Rgb, Rgb) {
        let mean =
            |t: Option<TextureRef>| t.and_then(|t| textures.get(t.texture)).map(Texture::mean);
        let rho =
            mean(self.reflectance_texture).map_or(self.reflectance, |t| self.reflectance.times(t));
        let e = mean(self.emission_texture).map_or(self.emission, |t| self.emission.times(t));
        (rho, e)
    }

    /// [`Material::diffuse_means`], checked: every reflectance channel finite and in
    /// `[0, 1)`, every emission channel finite and `>= 0`.
    ///
    /// # Errors
    /// A message naming the first bad value (`reflectance 1.2 outside [0, 1)`,
    /// `emission NaN not finite and >= 0`); callers prefix the material or surface.
    pub fn checked_diffuse_means(
        &self,
        textures: &[Texture],
    ) -> Result<([f64; 3], [f64; 3]), String> {
        let (rho, e) = self.diffuse_means(textures);
        let (rho, e) = (rho.0, e.0);
        for c in 0..3 {
            if !(rho[c].is_finite() && (0.0..1.0).contains(&rho[c])) {
                return Err(format!("reflectance {} outside [0, 1)", rho[c]));
            }
            if !(e[c].is_finite() && e[c] >= 0.0) {
                return Err(format!("emission {} not finite and >= 0", e[c]));
            }
        }
        Ok((rho, e))
    }

    /// Checks the physical ranges: every reflectance channel (plus the Ward specular
    /// channel, when present) in `[0, 1)`, emission finite and `>= 0`, Ward roughnesses
    /// finite and `> 0`, cosine-power exponent finite and `>= 0`.
    pub fn validate(&self, file: &str) -> Result<(), SceneError> {
        let element = format!("material {:?}", self.name);
        let total = match &self.ward {
            Some(w) => Rgb([0, 1, 2].map(|c| self.reflectance.0[c] + w.specular.0[c])),
            None => self.reflectance,
        };
        for v in self.reflectance.0.iter().chain(total.0.iter()) {
            if !(*v >= 0.0 && *v < 1.0) {
                return Err(SceneError::InvalidReflectance {
                    file: file.into(),
                    element,
                    value: *v,
                });
            }
        }
        if let Some(w) = &self.ward {
            for v in w.specular.0 {
                if !(v >= 0.0) {
                    return Err(SceneError::InvalidReflectance {
                        file: file.into(),
                        element,
                        value: v,
                    });
                }
            }
            for a in [w.alpha_x, w.alpha_y] {
                if !(a.is_finite() && a > 0.0) {
                    return Err(SceneError::Malformed {
                        file: file.into(),
                        element,
                        what: format!("Ward roughness {a} must be finite and > 0"),
                    });
                }
            }
        }
        for v in self.emission.0 {
            if !(v.is_finite() && v >= 0.0) {
                return Err(SceneError::InvalidEmission {
                    file: file.into(),
                    element,
                    value: v,
                });
            }
        }
        if let EmissionProfile::CosinePower { exponent } = self.emission_profile
            && !(exponent.is_finite() && exponent >= 0.0)
        {
            return Err(SceneError::Malformed {
                file: file.into(),
                element,
                what: format!("emission exponent {exponent} must be finite and >= 0"),
            });
        }
        Ok(())
    }
}

/// What a loader does with a reflectance component outside `[0, 1)`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum ReflectancePolicy {
    /// Return [`SceneError::InvalidReflectance`] (the default).
    #[default]
    Reject,
    /// Clamp into `[0, max]` and record a [`crate::WarningKind::ReflectanceClamped`]
    /// warning. `max` must be in `[0, 1)` (values outside are replaced by `0.999`).
    /// NaN is still rejected.
    Clamp {
        /// Largest allowed reflectance after clamping.
        max: f64,
    },
}

#[cfg(test)]
mod tests {
    use super::*;

    fn texture(texels: Vec<Rgb>) -> Texture {
        Texture {
            name: "t".into(),
            width: texels.len(),
            height: 1,
            texels,
        }
    }

    #[test]
    fn diffuse_means_apply_texture_means_and_check_ranges() {
        let textures = vec![
            texture(vec![Rgb::new(0.2, 0.4, 1.0), Rgb::new(0.6, 0.8, 0.0)]),
            texture(vec![Rgb::grey(3.0)]),
        ];
        let mut m = Material::lambertian("m", Rgb::new(0.5, 0.5, 0.9), Rgb::grey(2.0));
        assert_eq!(
            m.diffuse_means(&textures),
            (Rgb::new(0.5, 0.5, 0.9), Rgb::grey(2.0))
        );
        m.reflectance_texture = Some(TextureRef {
            texture: 0,
            uv_set: 0,
        });
        m.emission_texture = Some(TextureRef {
            texture: 1,
            uv_set: 0,
        });
        let (rho, e) = m.diffuse_means(&textures);
        // Texture means (0.4, 0.6, 0.5) and 3.
        for (got, want) in rho.0.iter().zip([0.2, 0.3, 0.45]) {
            assert!((got - want).abs() < 1e-15, "{got} vs {want}");
        }
        assert_eq!(e, Rgb::grey(6.0));
        assert_eq!(m.checked_diffuse_means(&textures), Ok((rho.0, e.0)));
        // An index outside the textures is ignored.
        m.emission_texture = Some(TextureRef {
            texture: 7,
            uv_set: 0,
        });
        assert_eq!(m.diffuse_means(&textures).1, Rgb::grey(2.0));
        // Ranges, after the texture is applied.
        let bright = vec![texture(vec![Rgb::grey(2.5)])];
        m.emission_texture = None;
        m.reflectance_texture = Some(TextureRef {
            texture: 0,
            uv_set: 0,
        });
        let err = m.checked_diffuse_means(&bright).unwrap_err();
        assert!(err.starts_with("reflectance 1.25"), "{err}");
        let nan = Material::lambertian("n", Rgb::grey(0.5), Rgb::new(1.0, f64::NAN, 0.0));
        let err = nan.checked_diffuse_means(&[]).unwrap_err();
        assert!(err.starts_with("emission NaN"), "{err}");
    }
}
