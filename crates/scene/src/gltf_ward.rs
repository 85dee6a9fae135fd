//! Ward lobes from glTF materials (Glossy §6.2's anisotropic Ward BRDF; issue 16's
//! material mapping). A glTF material stays Lambertian — diffuse results unchanged —
//! unless it opts in, in one of two ways:
//!
//! - **exact**, `extras.ward = { specular, alpha_x, alpha_y }` (`specular` a number or
//!   an RGB triple; `alpha_y` defaults to `alpha_x`): the lobe of the native format's
//!   `ward = {…}`, with `baseColorFactor` as the diffuse reflectance `ρ_d`; it wins over
//!   the extensions below;
//! - **approximate**, `KHR_materials_specular` (optionally with
//!   `KHR_materials_anisotropy` and `KHR_materials_ior`): `α = roughness²` of
//!   `pbrMetallicRoughness.roughnessFactor`, clamped to `[0.01, 1]` (a warning when
//!   clamped); anisotropy strength `s` gives `α_x = α + (1 − α) s²`, `α_y = α`, along the
//!   surface's first tangent (the support's `∂/∂s` or the scene's `tangent`; a non-zero
//!   `anisotropyRotation` is ignored with a warning); `ρ_s = specularFactor ×
//!   specularColorFactor × F0(ior)` with `F0 = ((ior − 1)/(ior + 1))²` (0.04 at the
//!   default `ior = 1.5`); `ρ_d = baseColor × (1 − max ρ_s)`. This maps glTF's
//!   microfacet model with Fresnel onto a Ward lobe without Fresnel: an approximation,
//!   not a conversion. Specular and anisotropy textures are ignored with a warning.
//!
//! Malformed values (wrong JSON types, non-finite or negative numbers, `α ≤ 0`) are
//! [`SceneError::Malformed`] naming the file and the material; an exact lobe whose
//! `ρ_d + ρ_s` reaches 1 is [`SceneError::InvalidReflectance`].

use serde_json::Value;

use crate::error::{SceneError, WarningKind};
use crate::material::{Rgb, WardParams};

/// Smallest `α` the approximate mapping produces (sharper lobes are clamped).
pub const MIN_ALPHA: f64 = 0.01;

/// A material's Ward lobe and the factor its diffuse reflectance is scaled by.
#[derive(Debug, Clone, PartialEq)]
pub struct GltfWard {
    /// The lobe.
    pub ward: WardParams,
    /// Multiplies `baseColor` to give `ρ_d` (`1` for the exact `extras.ward`).
    pub diffuse_scale: f64,
}

struct Ctx<'a> {
    file: &'a str,
    element: &'a str,
}

impl Ctx<'_> {
    fn malformed(&self, what: impl Into<String>) -> SceneError {
        SceneError::Malformed {
            file: self.file.into(),
            element: self.element.into(),
            what: what.into(),
        }
    }

    /// A finite number `>= 0` at `obj[key]`, or `default` when absent.
    fn number(&self, obj: &Value, ext: &str, key: &str, default: f64) -> Result<f64, SceneError> {
        match obj.get(key) {
            None => Ok(default),
            Some(v) => {
                match v.as_f64() {
                    Some(x) if x.is_finite() && x >= 0.0 => Ok(x),
                    _ => Err(self
                        .malformed(format!("{ext}.{key} must be a finite number >= 0, got {v}"))),
                }
            }
        }
    }

    /// An RGB triple (or one number for all three) at `obj[key]`.
    fn rgb(&self, obj: &Value, ext: &str, key: &str, default: f64) -> Result<Rgb, SceneError> {
        let bad = |v: &Value| {
            self.malformed(format!(
                "{ext}.{key} must be a number or 3 finite numbers >= 0, got {v}"
            ))
        };
        match obj.get(key) {
            None => Ok(Rgb::grey(default)),
            Some(v @ Value::Array(a)) => {
                if a.len() != 3 {
                    return Err(bad(v));
                }
                let mut out = [0.0; 3];
                for (o, x) in out.iter_mut().zip(a) {
                    match x.as_f64() {
                        Some(x) if x.is_finite() && x >= 0.0 => *o = x,
                        _ => return Err(bad(v)),
                    }
                }
                Ok(Rgb(out))
            }
            Some(v) => match v.as_f64() {
                Some(x) if x.is_finite() && x >= 0.0 => Ok(Rgb::grey(x)),
                _ => Err(bad(v)),
            },
        }
    }

    fn object<'v>(&self, v: &'v Value, ext: &str) -> Result<&'v Value, SceneError> {
        if v.is_object() {
            Ok(v)
        } else {
            Err(self.malformed(format!("{ext} must be an object, got {v}")))
        }
    }
}

/// The exact `extras.ward` lobe, if the material's extras hold one.
fn exact(ctx: &Ctx<'_>, extras: Option<&str>) -> Result<Option<GltfWard>, SceneError> {
    let Some(raw) = extras else { return Ok(None) };
    let extras: Value = serde_json::from_str(raw)
        .map_err(|e| ctx.malformed(format!("extras are not valid JSON: {e}")))?;
    let Some(w) = extras.get("ward") else {
        return Ok(None);
    };
    let w = ctx.object(w, "extras.ward")?;
    let Some(ax) = w.get("alpha_x") else {
        return Err(ctx.malformed("extras.ward needs alpha_x"));
    };
    if w.get("specular").is_none() {
        return Err(ctx.malformed("extras.ward needs specular"));
    }
    let specular = ctx.rgb(w, "extras.ward", "specular", 0.0)?;
    let alpha_x = match ax.as_f64() {
        Some(a) if a.is_finite() && a > 0.0 => a,
        _ => {
            return Err(ctx.malformed(format!(
                "extras.ward.alpha_x must be finite and > 0, got {ax}"
            )));
        }
    };
    let alpha_y = match w.get("alpha_y") {
        None => alpha_x,
        Some(v) => match v.as_f64() {
            Some(a) if a.is_finite() && a > 0.0 => a,
            _ => {
                return Err(ctx.malformed(format!(
                    "extras.ward.alpha_y must be finite and > 0, got {v}"
                )));
            }
        },
    };
    Ok(Some(GltfWard {
        ward: WardParams {
            specular,
            alpha_x,
            alpha_y,
        },
        diffuse_scale: 1.0,
    }))
}

/// The approximate lobe from `KHR_materials_specular` (+ anisotropy, ior).
fn approximate(
    ctx: &Ctx<'_>,
    m: &gltf::Material<'_>,
    warn: &mut dyn FnMut(WarningKind),
) -> Result<Option<GltfWard>, SceneError> {
    const SPEC: &str = "KHR_materials_specular";
    const ANISO: &str = "KHR_materials_anisotropy";
    const IOR: &str = "KHR_materials_ior";
    let Some(spec) = m.extension_value(SPEC) else {
        return Ok(None);
    };
    let spec = ctx.object(spec, SPEC)?;
    let factor = ctx.number(spec, SPEC, "specularFactor", 1.0)?;
    let color = ctx.rgb(spec, SPEC, "specularColorFactor", 1.0)?;
    for t in ["specularTexture", "specularColorTexture"] {
        if spec.get(t).is_some() {
            warn(WarningKind::Ignored {
                what: format!("{SPEC}.{t} (the Ward lobe takes the factors)"),
            });
        }
    }
    let ior = match m.extension_value(IOR) {
        None => 1.5,
        Some(v) => ctx.number(ctx.object(v, IOR)?, IOR, "ior", 1.5)?,
    };
    // ior = 0 is glTF's "infinite" (F0 = 1).
    let f0 = if ior == 0.0 {
        1.0
    } else {
        ((ior - 1.0) / (ior + 1.0)).powi(2)
    };
    let roughness = f64::from(m.pbr_metallic_roughness().roughness_factor());
    if !(roughness.is_finite() && roughness > 0.0) {
        return Err(ctx.malformed(format!(
            "roughnessFactor {roughness} must be finite and > 0 for a Ward lobe ({SPEC})"
        )));
    }
    let raw = roughness * roughness;
    let alpha = raw.clamp(MIN_ALPHA, 1.0);
    if alpha != raw {
        warn(WarningKind::Ignored {
            what: format!("Ward roughness α = roughness² = {raw:e} below {MIN_ALPHA} (clamped)"),
        });
    }
    let mut alpha_x = alpha;
    if let Some(a) = m.extension_value(ANISO) {
        let a = ctx.object(a, ANISO)?;
        let s = ctx.number(a, ANISO, "anisotropyStrength", 0.0)?;
        if s > 1.0 {
            return Err(ctx.malformed(format!("{ANISO}.anisotropyStrength {s} must be in [0, 1]")));
        }
        alpha_x = alpha + (1.0 - alpha) * s * s;
        let rot = match a.get("anisotropyRotation") {
            None => 0.0,
            Some(v) => v.as_f64().filter(|x| x.is_finite()).ok_or_else(|| {
                ctx.malformed(format!(
                    "{ANISO}.anisotropyRotation must be finite, got {v}"
                ))
            })?,
        };
        if rot != 0.0 {
            warn(WarningKind::Ignored {
                what: format!(
                    "{ANISO}.anisotropyRotation {rot} (α_x follows the surface's first tangent)"
                ),
            });
        }
        if a.get("anisotropyTexture").is_some() {
            warn(WarningKind::Ignored {
                what: format!("{ANISO}.anisotropyTexture"),
            });
        }
    }
    let specular = Rgb(color.0.map(|c| (factor * c * f0).min(1.0)));
    let max = specular.0.iter().copied().fold(0.0, f64::max);
    Ok(Some(GltfWard {
        ward: WardParams {
            specular,
            alpha_x,
            alpha_y: alpha,
        },
        diffuse_scale: 1.0 - max,
    }))
}

/// The Ward lobe of glTF material `m` (see the module docs), `None` when it does not
/// opt in; `element` names the material in errors; `warn` receives what was ignored.
///
/// # Errors
/// [`SceneError::Malformed`] for wrong types or out-of-range values.
pub fn ward_of(
    m: &gltf::Material<'_>,
    file: &str,
    element: &str,
    warn: &mut dyn FnMut(WarningKind),
) -> Result<Option<GltfWard>, SceneError> {
    let ctx = Ctx { file, element };
    let extras = m.extras().as_ref().map(|r| r.get());
    if let Some(w) = exact(&ctx, extras)? {
        return Ok(Some(w));
    }
    approximate(&ctx, m, warn)
}
