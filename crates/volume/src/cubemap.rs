//! The global cube's framebuffer (GlobalCube §3.1, Fig. 3): six 90° frusta of `N × N`
//! pixels around a receiver's centre, with the tables of §3.2 — each pixel's exact
//! solid angle (the distance correction, eq. (29), integrated over the pixel), its
//! direction, and the receiver's entry faces for it (the positional correction of
//! Fig. 6: a face receives through its own frustum and the parts of the four
//! neighbouring frusta it sees).
//!
//! Faces and frusta are ordered `+x, −x, +y, −y, +z, −z` (index `2·axis + (sign < 0)`).
//! Pixel `(i, j)` of frustum `f` spans the tangent square
//! `[−1 + 2i/N, −1 + 2(i+1)/N] × [−1 + 2j/N, −1 + 2(j+1)/N]` of the plane at distance 1
//! along the frustum's axis (first tangent axis = the next axis cyclically).

use std::sync::{Arc, Mutex, OnceLock};

/// Largest framebuffer side accepted.
pub const MAX_FRAMEBUFFER: usize = 1024;

/// One pixel of the cube map.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pixel {
    /// Unit direction from the receiver's centre through the pixel's centre.
    pub dir: [f64; 3],
    /// Exact solid angle of the pixel (sr); the pixels of one map sum to `4π`.
    pub solid_angle: f64,
    /// `|dir|` per axis (the projected areas of the faces perpendicular to each axis).
    pub abs: [f64; 3],
    /// For each axis, the receiver's entry face on that axis (the face whose outward
    /// normal has a positive dot product with `dir`).
    pub entry: [u8; 3],
}

/// A cube map of side `N`: `6 N²` pixels, frustum by frustum, row `j` major.
#[derive(Debug, Clone, PartialEq)]
pub struct CubeMap {
    /// Pixels per side.
    pub side: usize,
    /// The pixels.
    pub pixels: Vec<Pixel>,
}

/// `atan(uv / √(1 + u² + v²))`: the solid angle of the rectangle `[0,u]×[0,v]` at
/// distance 1 (signed).
fn corner(u: f64, v: f64) -> f64 {
    (u * v / (1.0 + u * u + v * v).sqrt()).atan()
}

/// Face index of `axis` with sign (`true` = negative).
#[must_use]
pub fn face_index(axis: usize, negative: bool) -> usize {
    2 * axis + usize::from(negative)
}

impl CubeMap {
    /// Builds the map of side `n` (`1 ≤ n ≤` [`MAX_FRAMEBUFFER`]; larger or zero sides
    /// give an empty map, which the callers reject earlier with a typed error).
    #[must_use]
    pub fn new(n: usize) -> Self {
        if n == 0 || n > MAX_FRAMEBUFFER {
            return Self {
                side: n,
                pixels: Vec::new(),
            };
        }
        let mut pixels = Vec::with_capacity(6 * n * n);
        let edge = |i: usize| -1.0 + 2.0 * i as f64 / n as f64;
        for f in 0..6 {
            let axis = f / 2;
            let sign = if f % 2 == 0 { 1.0 } else { -1.0 };
            let (ta, tb) = ((axis + 1) % 3, (axis + 2) % 3);
            for j in 0..n {
                for i in 0..n {
                    let (u0, u1, v0, v1) = (edge(i), edge(i + 1), edge(j), edge(j + 1));
                    let solid_angle =
                        corner(u1, v1) - corner(u0, v1) - corner(u1, v0) + corner(u0, v0);
                    // Pixel centres as `(2i + 1 − N)/N`: exact zero on the axes of odd
                    // sides (the midpoint of the rounded edges is ±1e-17 there, and such a
                    // stray component decides which voxel column a ray along a voxel
                    // plane runs in, by rounding).
                    let centre = |i: usize| (2.0 * i as f64 + 1.0 - n as f64) / n as f64;
                    let (u, v) = (centre(i), centre(j));
                    let r = (1.0 + u * u + v * v).sqrt();
                    let mut dir = [0.0; 3];
                    dir[axis] = sign / r;
                    dir[ta] = u / r;
                    dir[tb] = v / r;
                    let abs = dir.map(f64::abs);
                    let entry = [0, 1, 2].map(|a| face_index(a, dir[a] < 0.0) as u8);
                    pixels.push(Pixel {
                        dir,
                        solid_angle,
                        abs,
                        entry,
                    });
                }
            }
        }
        Self { side: n, pixels }
    }

    /// A shared map of side `n`, built once per process.
    #[must_use]
    pub fn shared(n: usize) -> Arc<CubeMap> {
        static CACHE: OnceLock<Mutex<Vec<Arc<CubeMap>>>> = OnceLock::new();
        let cache = CACHE.get_or_init(|| Mutex::new(Vec::new()));
        let mut guard = match cache.lock() {
            Ok(g) => g,
            Err(p) => p.into_inner(),
        };
        if let Some(m) = guard.iter().find(|m| m.side == n) {
            return m.clone();
        }
        let m = Arc::new(CubeMap::new(n));
        guard.push(m.clone());
        m
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solid_angles_sum_to_four_pi_and_directions_are_unit() {
        for n in [1, 2, 3, 16, 64] {
            let m = CubeMap::new(n);
            assert_eq!(m.pixels.len(), 6 * n * n);
            let s: f64 = m.pixels.iter().map(|p| p.solid_angle).sum();
            assert!((s - 4.0 * std::f64::consts::PI).abs() < 1e-12, "{n}: {s}");
            for p in &m.pixels {
                let l = p.dir.iter().map(|x| x * x).sum::<f64>();
                assert!((l - 1.0).abs() < 1e-14);
                for a in 0..3 {
                    assert_eq!(p.entry[a] as usize / 2, a);
                    assert_eq!(p.entry[a] % 2 == 1, p.dir[a] < 0.0);
                }
            }
        }
    }

    #[test]
    fn frustum_solid_angle_is_two_pi_over_three() {
        let m = CubeMap::new(8);
        let s: f64 = m.pixels[..64].iter().map(|p| p.solid_angle).sum();
        assert!((s - 4.0 * std::f64::consts::PI / 6.0).abs() < 1e-13);
    }
}
