//! Warnings of a run: what the loader dropped or changed (`Scene::warnings`), scene
//! features the chosen method does not model, and a skipped error check. They are
//! printed on stderr (also with `--quiet`, which silences progress and the summary,
//! not warnings), listed in the JSON under `warnings`, and turned into an error by
//! `--strict`.
//!
//! The [`Feature`] constants are the one table of which method models which scene
//! feature; a new method adds its name to the features it models, and a warning names a method only
//! when this build of the command has it (a `--method` value).

use clap::ValueEnum;
use wavelux::scene::{EmissionProfile, Material, Scene, Sidedness};

use crate::cli::MethodArg;
use crate::report::WarningInfo;

/// A scene feature that only some methods model.
pub struct Feature {
    /// What the feature is, in words ("a Ward glossy lobe").
    pub what: &'static str,
    /// What a method that does not model it does instead.
    pub instead: &'static str,
    /// The `--method` names of the methods that model it, the preferred one first.
    pub modelled_by: &'static [&'static str],
}

/// Ward glossy lobes (Glossy §6).
pub const WARD: Feature = Feature {
    what: "a Ward glossy lobe",
    instead: "only its diffuse reflectance is used",
    modelled_by: &["glossy"],
};
/// Directional (cosine-power) emitters (Glossy §6's spotlights).
pub const DIRECTIONAL: Feature = Feature {
    what: "a directional emitter (cosine-power exponent)",
    instead: "it emits as a Lambertian emitter of the same exitance",
    modelled_by: &["glossy"],
};
/// Participating media (GlobalCube §2–§3).
pub const MEDIUM: Feature = Feature {
    what: "a participating medium",
    instead: "it is ignored (no emission, absorption or scattering)",
    modelled_by: &["global-cube"],
};
/// Punctual (point and spot) lights.
pub const PUNCTUAL: Feature = Feature {
    what: "a punctual light",
    instead: "it is ignored (it emits nothing)",
    modelled_by: &["meshless"],
};
/// Reflectance and emission textures.
pub const TEXTURE: Feature = Feature {
    what: "a reflectance or emission texture",
    instead: "the texture's mean value is used over the whole surface",
    modelled_by: &["glossy"],
};

impl Feature {
    /// Whether `method` (a `--method` name) models the feature.
    pub fn modelled_by(&self, method: &str) -> bool {
        self.modelled_by.contains(&method)
    }

    /// The first method that models the feature and that this build has.
    pub fn available_method(&self) -> Option<&'static str> {
        self.modelled_by
            .iter()
            .copied()
            .find(|m| MethodArg::from_str(m, false).is_ok())
    }
}

/// The loader's warnings.
pub fn from_scene(scene: &Scene) -> Vec<WarningInfo> {
    scene
        .warnings
        .iter()
        .map(|w| WarningInfo {
            kind: w.kind.code().into(),
            file: Some(w.file.clone()),
            element: w.element.clone(),
            message: w.to_string(),
            use_method: None,
        })
        .collect()
}

/// Names of the surfaces using material `m` on some side, as `"a", "b" (+3 more)`.
fn surfaces_using(scene: &Scene, m: usize) -> String {
    let names: Vec<String> = scene
        .surfaces
        .iter()
        .filter(|s| s.material == m || matches!(s.sides, Sidedness::TwoSided { back } if back == m))
        .map(|s| format!("{:?}", s.name))
        .collect();
    let shown = names.iter().take(3).cloned().collect::<Vec<_>>().join(", ");
    match names.len() {
        0..=3 => shown,
        n => format!("{shown} (+{} more)", n - 3),
    }
}

/// One `not-modelled` warning.
fn not_modelled(feature: &Feature, method: &str, element: String, file: &str) -> WarningInfo {
    let use_method = feature.available_method();
    let hint = match use_method {
        Some(m) => format!("; --method {m} models it"),
        None => String::new(),
    };
    WarningInfo {
        kind: "not-modelled".into(),
        file: Some(file.into()),
        message: format!(
            "{file}: {element}: {} is not modelled by --method {method}: {}{hint}",
            feature.what, feature.instead
        ),
        element,
        use_method: use_method.map(str::to_string),
    }
}

/// The scene features (per material, light and medium) that `method` does not model.
/// Materials no surface uses are not reported.
pub fn unmodelled(scene: &Scene, method: &str, file: &str) -> Vec<WarningInfo> {
    let mut out = Vec::new();
    let features = |m: &Material| {
        let mut f: Vec<&'static Feature> = Vec::new();
        if m.ward.is_some() {
            f.push(&WARD);
        }
        if m.is_emitter()
            && matches!(m.emission_profile, EmissionProfile::CosinePower { exponent } if exponent != 0.0)
        {
            f.push(&DIRECTIONAL);
        }
        if m.reflectance_texture.is_some() || (m.is_emitter() && m.emission_texture.is_some()) {
            f.push(&TEXTURE);
        }
        f
    };
    for (i, m) in scene.materials.iter().enumerate() {
        let used = surfaces_using(scene, i);
        if used.is_empty() {
            continue;
        }
        for feature in features(m) {
            if !feature.modelled_by(method) {
                let element = format!("material {:?} (surfaces {used})", m.name);
                out.push(not_modelled(feature, method, element, file));
            }
        }
    }
    if !PUNCTUAL.modelled_by(method) {
        for l in &scene.lights {
            out.push(not_modelled(
                &PUNCTUAL,
                method,
                format!("light {:?}", l.name),
                file,
            ));
        }
    }
    if !MEDIUM.modelled_by(method) {
        for m in &scene.media {
            out.push(not_modelled(
                &MEDIUM,
                method,
                format!("medium {:?}", m.name),
                file,
            ));
        }
    }
    out
}

/// A skipped error check as a warning.
pub fn error_check_skipped(reason: &str) -> WarningInfo {
    WarningInfo {
        kind: "error-check-skipped".into(),
        file: None,
        element: "error check".into(),
        message: format!("the Monte Carlo error check was skipped: {reason}"),
        use_method: None,
    }
}

/// Prints warnings on stderr (whatever `--quiet` says).
pub fn print(ws: &[WarningInfo]) {
    for w in ws {
        eprintln!("wavelux: warning: {}", w.message);
    }
}

/// With `--strict`, warnings are an error listing them (call before [`print`], so
/// they are not printed twice).
pub fn strict(strict: bool, ws: &[WarningInfo]) -> anyhow::Result<()> {
    if strict && !ws.is_empty() {
        let list: Vec<&str> = ws.iter().map(|w| w.message.as_str()).collect();
        anyhow::bail!(
            "--strict: {} warning(s) are errors:\n  {}",
            ws.len(),
            list.join("\n  ")
        );
    }
    Ok(())
}
