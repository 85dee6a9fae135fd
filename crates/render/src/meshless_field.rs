//! [`MeshlessField`]: a `wavelux-meshless` relighting result as a [`RadiosityField`]
//! (Meshless §3.3: "the indirect vector irradiance ... turned to irradiance by dotting
//! with the surface normal, and composited with direct illumination ... Finally, the
//! result is modulated by the surface albedo").
//!
//! At a hit `x` with normal `n` on a side of reflectance `ρ` and exitance `E`, the
//! field shows `B = E + ρ·(E_dir(x) + n·i(x))`: the direct irradiance `E_dir` is
//! evaluated per point by the frame's [`DirectLighting`] (punctual lights with shadow
//! rays, area emitters by next-event estimation with a stream keyed by the point's
//! position), the indirect part `n·i` from the hierarchical expansion or its flattened
//! one-level resampling (§4.1). [`Component`] selects the full exitance, the
//! indirect part `ρ n·i` or the direct part `E + ρ E_dir` alone.

use wavelux_geometry::{Accel, Hit};
use wavelux_meshless::{DirectLighting, Flat, Indirect, SceneSurfaces};

use crate::field::{RadiosityField, SurfacePoint};

/// Which part of the exitance a [`MeshlessField`] shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum Component {
    /// `E + ρ(E_dir + n·i)`.
    Full,
    /// `ρ n·i` (no emission, no direct light).
    Indirect,
    /// `E + ρ E_dir`.
    Direct,
}

/// Where the indirect irradiance comes from.
#[derive(Debug, Clone, Copy)]
pub enum IndirectSource<'a> {
    /// The hierarchical expansion (eq. (6), all receiver levels).
    Hierarchical(&'a Indirect<'a>),
    /// Its one-level flattening (§4.1).
    Flat(&'a Flat<'a>),
}

/// A relit meshless solution seen by the renderer (module docs).
#[derive(Debug)]
pub struct MeshlessField<'a> {
    surfaces: &'a SceneSurfaces,
    indirect: IndirectSource<'a>,
    direct: DirectLighting,
    component: Component,
}

impl<'a> MeshlessField<'a> {
    /// A field over the scene's surfaces (`surfaces` must be built from the scene the
    /// transfer was precomputed for). `direct` must be valid for `surfaces`
    /// ([`DirectLighting::validate`]); invalid lights contribute nothing.
    pub fn new(
        surfaces: &'a SceneSurfaces,
        indirect: IndirectSource<'a>,
        direct: DirectLighting,
        component: Component,
    ) -> Self {
        Self {
            surfaces,
            indirect,
            direct,
            component,
        }
    }

    /// The same field showing another component.
    pub fn with_component(&self, component: Component) -> Self {
        Self {
            surfaces: self.surfaces,
            indirect: self.indirect,
            direct: self.direct.clone(),
            component,
        }
    }

    /// Indirect irradiance `n·i` at a resolved point (W/m², RGB).
    pub fn indirect_irradiance(&self, p: &SurfacePoint) -> [f64; 3] {
        match self.indirect {
            IndirectSource::Hierarchical(i) => i.irradiance_at(p.point, p.normal),
            IndirectSource::Flat(f) => f.irradiance_at(p.point, p.normal),
        }
    }

    /// Direct irradiance at a resolved point (W/m², RGB).
    pub fn direct_irradiance(&self, p: &SurfacePoint) -> [f64; 3] {
        let key = p
            .point
            .to_array()
            .iter()
            .fold(0x243f_6a88_85a3_08d3u64, |a, v| {
                (a ^ v.to_bits())
                    .rotate_left(23)
                    .wrapping_mul(0x9E37_79B9_7F4A_7C15)
            });
        self.direct
            .irradiance_at(self.surfaces, p.point, p.normal, key)
    }

    fn side(&self, p: &SurfacePoint) -> (usize, bool) {
        (p.side_index / 2, p.side_index % 2 == 1)
    }
}

impl RadiosityField for MeshlessField<'_> {
    fn accel(&self) -> &Accel {
        self.surfaces.accel()
    }

    fn resolve(&self, hit: &Hit) -> Option<SurfacePoint> {
        let surface = self.surfaces.surface_of(hit.prim)?;
        let back = !hit.front;
        self.surfaces.reflectance(surface, back)?;
        Some(SurfacePoint {
            surface,
            side_index: 2 * surface + usize::from(back),
            st: hit.uv,
            point: hit.point,
            normal: if back { -hit.normal } else { hit.normal },
        })
    }

    fn radiosity(&self, p: &SurfacePoint) -> [f64; 3] {
        let e = self.emission(p);
        let rho = self.reflectance(p);
        let irr = match self.component {
            Component::Full => {
                let (d, i) = (self.direct_irradiance(p), self.indirect_irradiance(p));
                std::array::from_fn(|c| d[c] + i[c])
            }
            Component::Indirect => self.indirect_irradiance(p),
            Component::Direct => self.direct_irradiance(p),
        };
        std::array::from_fn(|c| e[c] + rho[c] * irr[c])
    }

    fn emission(&self, p: &SurfacePoint) -> [f64; 3] {
        if self.component == Component::Indirect {
            return [0.0; 3];
        }
        let (s, back) = self.side(p);
        self.surfaces.exitance(s, back).unwrap_or([0.0; 3])
    }

    fn reflectance(&self, p: &SurfacePoint) -> [f64; 3] {
        let (s, back) = self.side(p);
        self.surfaces.reflectance(s, back).unwrap_or([0.0; 3])
    }
}
