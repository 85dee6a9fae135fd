//! Linear RGB images: EXR (exr crate) and tone-mapped sRGB PNG (png crate) input and
//! output, error metrics between two images and false-colour error maps.
//!
//! Every file is written to a temporary file in the destination directory and then
//! renamed over the destination ([`write_atomic`]), so an interrupted run never leaves
//! a half-written file in place of an older output.

use std::io::{BufReader, BufWriter, Write};
use std::path::Path;

use serde::Serialize;

use crate::{RenderError, invalid};

fn io_err(path: &Path, e: impl std::fmt::Display) -> RenderError {
    RenderError::Io {
        path: path.display().to_string(),
        message: e.to_string(),
    }
}

/// Writes a file atomically: `write` fills a temporary file next to `path`, which is
/// then renamed onto `path`. On error the temporary file is removed and `path` is
/// untouched.
///
/// # Errors
/// [`RenderError::Io`] if the directory is not writable or `write` fails.
pub fn write_atomic(
    path: &Path,
    write: impl FnOnce(&Path) -> Result<(), RenderError>,
) -> Result<(), RenderError> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => std::path::PathBuf::from("."),
    };
    let name = path
        .file_name()
        .ok_or_else(|| io_err(path, "not a file path"))?
        .to_string_lossy()
        .into_owned();
    // Keep the extension last: the exr crate picks nothing from it, but tools might.
    let tmp = dir.join(format!(".{name}.tmp-{}", std::process::id()));
    let r = write(&tmp).and_then(|()| std::fs::rename(&tmp, path).map_err(|e| io_err(path, e)));
    if r.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    r
}

/// Writes bytes atomically (see [`write_atomic`]).
///
/// # Errors
/// [`RenderError::Io`] on I/O failure.
pub fn write_bytes_atomic(path: &Path, bytes: &[u8]) -> Result<(), RenderError> {
    write_atomic(path, |tmp| {
        let mut f = std::fs::File::create(tmp).map_err(|e| io_err(tmp, e))?;
        f.write_all(bytes).map_err(|e| io_err(tmp, e))?;
        f.sync_all().map_err(|e| io_err(tmp, e))
    })
}

/// Tone mapping of linear radiance to 8-bit sRGB.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ToneMap {
    /// Multiply by a fixed exposure, clamp to `[0, 1]`, sRGB-encode.
    Exposure(f64),
    /// Choose the exposure that maps the 95th percentile of the luminance of non-black
    /// pixels to 0.75, then as [`ToneMap::Exposure`] (light sources saturate).
    Auto,
}

/// A linear RGB image (row-major, top row first), pixel values in W/(m²·sr).
#[derive(Debug, Clone, PartialEq)]
pub struct Image {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Pixels, `width × height`.
    pub pixels: Vec<[f64; 3]>,
}

/// Error metrics between an image and a reference (per channel values pooled).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ErrorMetrics {
    /// Mean absolute difference.
    pub l1: f64,
    /// Mean absolute difference divided by the reference's mean absolute value.
    pub relative_l1: f64,
    /// Root mean square difference.
    pub rmse: f64,
    /// Largest absolute difference.
    pub max_abs: f64,
    /// Mean of the reference (for scale).
    pub reference_mean: f64,
}

/// Relative luminance (Rec. 709 weights).
pub fn luminance(c: [f64; 3]) -> f64 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

/// sRGB encoding of a linear value in `[0, 1]`.
pub fn srgb_encode(v: f64) -> f64 {
    let v = v.clamp(0.0, 1.0);
    if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

/// sRGB decoding to linear.
pub fn srgb_decode(v: f64) -> f64 {
    if v <= 0.040_45 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

/// A perceptually ordered false-colour ramp (black → blue → cyan → yellow → red →
/// white) for `t ∈ [0, 1]`.
pub fn false_colour(t: f64) -> [f64; 3] {
    const STOPS: [[f64; 3]; 6] = [
        [0.0, 0.0, 0.0],
        [0.0, 0.0, 1.0],
        [0.0, 1.0, 1.0],
        [1.0, 1.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 1.0],
    ];
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        1.0
    };
    let x = t * (STOPS.len() - 1) as f64;
    let i = (x.floor() as usize).min(STOPS.len() - 2);
    let f = x - i as f64;
    std::array::from_fn(|c| STOPS[i][c] * (1.0 - f) + STOPS[i + 1][c] * f)
}

impl Image {
    /// A black image.
    pub fn new(width: usize, height: usize) -> Self {
        Self {
            width,
            height,
            pixels: vec![[0.0; 3]; width * height],
        }
    }

    /// Pixel at `(x, y)`.
    ///
    /// # Panics
    /// If out of range.
    pub fn get(&self, x: usize, y: usize) -> [f64; 3] {
        self.pixels[y * self.width + x]
    }

    /// Writes a linear f32 RGB EXR (atomically).
    ///
    /// # Errors
    /// [`RenderError::Io`] on failure.
    pub fn write_exr(&self, path: &Path) -> Result<(), RenderError> {
        if self.width == 0 || self.height == 0 {
            return Err(invalid("image", "empty image"));
        }
        write_atomic(path, |tmp| {
            exr::prelude::write_rgb_file(tmp, self.width, self.height, |x, y| {
                let p = self.get(x, y);
                (p[0] as f32, p[1] as f32, p[2] as f32)
            })
            .map_err(|e| io_err(tmp, e))
        })
    }

    /// Writes a linear f32 RGBA EXR (atomically) with `alpha[y·width + x]` as A.
    ///
    /// # Errors
    /// [`RenderError::Invalid`] for an empty image or an alpha of the wrong length,
    /// [`RenderError::Io`] on failure.
    pub fn write_exr_rgba(&self, alpha: &[f64], path: &Path) -> Result<(), RenderError> {
        if self.width == 0 || self.height == 0 || alpha.len() != self.pixels.len() {
            return Err(invalid("image", "empty image or alpha of the wrong size"));
        }
        write_atomic(path, |tmp| {
            exr::prelude::write_rgba_file(tmp, self.width, self.height, |x, y| {
                let p = self.get(x, y);
                let a = alpha[y * self.width + x];
                (p[0] as f32, p[1] as f32, p[2] as f32, a as f32)
            })
            .map_err(|e| io_err(tmp, e))
        })
    }

    /// Reads the alpha channel of an EXR's first RGBA layer (`1` where it has none).
    ///
    /// # Errors
    /// [`RenderError::Io`] if the file is missing or not an RGB EXR.
    pub fn read_exr_alpha(path: &Path) -> Result<Vec<f64>, RenderError> {
        let img = exr::prelude::read_first_rgba_layer_from_file(
            path,
            |res, _| (res.width(), vec![1.0; res.width() * res.height()]),
            |(w, a): &mut (usize, Vec<f64>), pos, (_r, _g, _b, alpha): (f32, f32, f32, f32)| {
                a[pos.y() * *w + pos.x()] = f64::from(alpha);
            },
        )
        .map_err(|e| io_err(path, e))?;
        Ok(img.layer_data.channel_data.pixels.1)
    }

    /// Reads the first RGB(A) layer of an EXR file.
    ///
    /// # Errors
    /// [`RenderError::Io`] if the file is missing or not an RGB EXR.
    pub fn read_exr(path: &Path) -> Result<Self, RenderError> {
        let img = exr::prelude::read_first_rgba_layer_from_file(
            path,
            |res, _| Image::new(res.width(), res.height()),
            |img: &mut Image, pos, (r, g, b, _a): (f32, f32, f32, f32)| {
                let w = img.width;
                img.pixels[pos.y() * w + pos.x()] = [r as f64, g as f64, b as f64];
            },
        )
        .map_err(|e| io_err(path, e))?;
        Ok(img.layer_data.channel_data.pixels)
    }

    /// The exposure [`ToneMap::Auto`] picks for this image.
    pub fn auto_exposure(&self) -> f64 {
        let mut l: Vec<f64> = self
            .pixels
            .iter()
            .map(|p| luminance(*p))
            .filter(|v| v.is_finite() && *v > 0.0)
            .collect();
        if l.is_empty() {
            return 1.0;
        }
        l.sort_by(f64::total_cmp);
        let v = l[((l.len() - 1) as f64 * 0.95) as usize];
        0.75 / v
    }

    /// 8-bit sRGB bytes (RGB, row-major) after tone mapping.
    pub fn to_srgb8(&self, tone: ToneMap) -> Vec<u8> {
        let k = match tone {
            ToneMap::Exposure(e) => e,
            ToneMap::Auto => self.auto_exposure(),
        };
        self.pixels
            .iter()
            .flat_map(|p| p.map(|v| (srgb_encode(v * k) * 255.0 + 0.5) as u8))
            .collect()
    }

    /// Writes a tone-mapped 8-bit sRGB PNG (atomically).
    ///
    /// # Errors
    /// [`RenderError::Io`] on failure.
    pub fn write_png(&self, path: &Path, tone: ToneMap) -> Result<(), RenderError> {
        if self.width == 0 || self.height == 0 {
            return Err(invalid("image", "empty image"));
        }
        let data = self.to_srgb8(tone);
        write_atomic(path, |tmp| {
            let f = std::fs::File::create(tmp).map_err(|e| io_err(tmp, e))?;
            let mut enc =
                png::Encoder::new(BufWriter::new(f), self.width as u32, self.height as u32);
            enc.set_color(png::ColorType::Rgb);
            enc.set_depth(png::BitDepth::Eight);
            enc.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
            let mut w = enc.write_header().map_err(|e| io_err(tmp, e))?;
            w.write_image_data(&data).map_err(|e| io_err(tmp, e))?;
            w.finish().map_err(|e| io_err(tmp, e))
        })
    }

    /// Reads an 8-bit RGB or RGBA PNG, decoding sRGB to linear `[0, 1]`.
    ///
    /// # Errors
    /// [`RenderError::Io`] if the file is missing or not an 8-bit RGB(A) PNG.
    pub fn read_png(path: &Path) -> Result<Self, RenderError> {
        let f = std::fs::File::open(path).map_err(|e| io_err(path, e))?;
        let dec = png::Decoder::new(BufReader::new(f));
        let mut reader = dec.read_info().map_err(|e| io_err(path, e))?;
        let size = reader
            .output_buffer_size()
            .ok_or_else(|| io_err(path, "image too large"))?;
        let mut buf = vec![0; size];
        let info = reader.next_frame(&mut buf).map_err(|e| io_err(path, e))?;
        let ch = match (info.color_type, info.bit_depth) {
            (png::ColorType::Rgb, png::BitDepth::Eight) => 3,
            (png::ColorType::Rgba, png::BitDepth::Eight) => 4,
            _ => return Err(io_err(path, "only 8-bit RGB/RGBA PNGs are supported")),
        };
        let (w, h) = (info.width as usize, info.height as usize);
        let mut img = Image::new(w, h);
        for y in 0..h {
            let row = &buf[y * info.line_size..];
            for x in 0..w {
                img.pixels[y * w + x] =
                    std::array::from_fn(|c| srgb_decode(row[x * ch + c] as f64 / 255.0));
            }
        }
        Ok(img)
    }

    /// Reads an `.exr` or `.png` by extension.
    ///
    /// # Errors
    /// [`RenderError::Io`] for other extensions or read failures.
    pub fn read(path: &Path) -> Result<Self, RenderError> {
        match path
            .extension()
            .and_then(|e| e.to_str())
            .map(|e| e.to_ascii_lowercase())
            .as_deref()
        {
            Some("exr") => Self::read_exr(path),
            Some("png") => Self::read_png(path),
            _ => Err(io_err(path, "unknown image format (expected .exr or .png)")),
        }
    }

    /// Error metrics of `self` against `reference`.
    ///
    /// # Errors
    /// [`RenderError::SizeMismatch`] if the sizes differ.
    pub fn metrics(&self, reference: &Image) -> Result<ErrorMetrics, RenderError> {
        self.check_size(reference)?;
        let n = (self.pixels.len() * 3).max(1) as f64;
        let (mut l1, mut l2, mut mx, mut rm) = (0.0, 0.0, 0.0f64, 0.0);
        for (a, b) in self.pixels.iter().zip(&reference.pixels) {
            for c in 0..3 {
                let d = (a[c] - b[c]).abs();
                l1 += d;
                l2 += d * d;
                mx = mx.max(d);
                rm += b[c].abs();
            }
        }
        let mean = rm / n;
        Ok(ErrorMetrics {
            l1: l1 / n,
            relative_l1: if mean > 0.0 { l1 / n / mean } else { l1 / n },
            rmse: (l2 / n).sqrt(),
            max_abs: mx,
            reference_mean: mean,
        })
    }

    /// Relative L1 error of the reflected radiance: `Σ |a − b| / Σ |b|` over pixels
    /// and channels, leaving out every pixel where `emitters` (an image of the emitted
    /// radiance at the primary hits, e.g. [`crate::PathTracer::emission_image`]) is
    /// non-zero in the pixel or one of its eight neighbours: light sources are exact
    /// for every method, and their anti-aliased edges would otherwise dominate the
    /// sum. Returns the error and the number of pixels kept.
    ///
    /// # Errors
    /// [`RenderError::SizeMismatch`] if the sizes differ; [`RenderError::Invalid`] if
    /// no kept pixel has any radiance.
    pub fn reflected_relative_l1(
        &self,
        reference: &Image,
        emitters: &Image,
    ) -> Result<(f64, usize), RenderError> {
        self.check_size(reference)?;
        self.check_size(emitters)?;
        let (w, h) = (self.width, self.height);
        let lit = |x: usize, y: usize| emitters.pixels[y * w + x].iter().any(|&v| v > 0.0);
        let near_light = |i: usize| {
            let (x, y) = (i % w, i / w);
            (y.saturating_sub(1)..(y + 2).min(h))
                .any(|yy| (x.saturating_sub(1)..(x + 2).min(w)).any(|xx| lit(xx, yy)))
        };
        let (mut num, mut den, mut kept) = (0.0, 0.0, 0usize);
        for (i, (a, b)) in self.pixels.iter().zip(&reference.pixels).enumerate() {
            if near_light(i) {
                continue;
            }
            kept += 1;
            for c in 0..3 {
                num += (a[c] - b[c]).abs();
                den += b[c].abs();
            }
        }
        if !(den > 0.0 && den.is_finite()) {
            return Err(invalid(
                "reference image",
                "no radiance outside the light sources",
            ));
        }
        Ok((num / den, kept))
    }

    /// The image box-filtered down by an integer `factor` (each output pixel the mean
    /// of `factor × factor` input pixels; sizes must divide).
    ///
    /// # Errors
    /// [`RenderError::Invalid`] if `factor` is 0 or does not divide both sizes.
    pub fn downsample(&self, factor: usize) -> Result<Image, RenderError> {
        if factor == 0 || !self.width.is_multiple_of(factor) || !self.height.is_multiple_of(factor)
        {
            return Err(invalid(
                "downsampling factor",
                format!("{factor} does not divide {}x{}", self.width, self.height),
            ));
        }
        let (w, h) = (self.width / factor, self.height / factor);
        let mut out = Image::new(w, h);
        let k = 1.0 / (factor * factor) as f64;
        for y in 0..self.height {
            for x in 0..self.width {
                let p = self.pixels[y * self.width + x];
                let o = &mut out.pixels[(y / factor) * w + x / factor];
                for c in 0..3 {
                    o[c] += k * p[c];
                }
            }
        }
        Ok(out)
    }

    /// Pixel-to-pixel noise in flat regions: over the pixels marked in `flat` (each
    /// with its four neighbours inside the image), the ratio of the power of the
    /// luminance's second differences to the power of the luminance,
    /// `√( Σ (|L(x−1) − 2L(x) + L(x+1)|² + |L(y−1) − 2L(y) + L(y+1)|²) / Σ 12 L(x)² )`.
    /// For independent per-pixel noise of relative standard deviation `σ` the
    /// numerator's expectation is `12 σ² Σ L²` (a second difference has variance
    /// `6σ²L²`), so the result is `σ` — a relative deviation — while a smooth image
    /// contributes only its curvature. The sums are taken before the division so that
    /// each pixel weighs by its brightness: a near-black pixel (whose relative
    /// deviation is invisible and, divided by its own `L²`, would dominate a mean of
    /// per-pixel ratios) adds almost nothing. `None` if no marked pixel qualifies
    /// (positive luminance).
    pub fn flat_noise(&self, flat: &[bool]) -> Option<f64> {
        let (w, h) = (self.width, self.height);
        let lum = |x: usize, y: usize| luminance(self.pixels[y * w + x]);
        let (mut noise, mut signal) = (0.0, 0.0);
        for y in 1..h.saturating_sub(1) {
            for x in 1..w.saturating_sub(1) {
                if !flat.get(y * w + x).copied().unwrap_or(false) {
                    continue;
                }
                let l = lum(x, y);
                // Not positive, or NaN.
                if l.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
                    continue;
                }
                let dx = lum(x - 1, y) - 2.0 * l + lum(x + 1, y);
                let dy = lum(x, y - 1) - 2.0 * l + lum(x, y + 1);
                noise += dx * dx + dy * dy;
                signal += 12.0 * l * l;
            }
        }
        (signal > 0.0).then(|| (noise / signal).sqrt())
    }

    fn check_size(&self, o: &Image) -> Result<(), RenderError> {
        if self.width != o.width || self.height != o.height {
            return Err(RenderError::SizeMismatch(
                self.width,
                self.height,
                o.width,
                o.height,
            ));
        }
        Ok(())
    }

    /// A false-colour map of the per-pixel relative error
    /// `|a − b|_lum / max(mean_lum(b), |b|_lum)`, scaled so that `full_scale` maps to
    /// the top of [`false_colour`]. The result is display-referred (write it with
    /// `ToneMap::Exposure(1.0)`).
    ///
    /// # Errors
    /// [`RenderError::SizeMismatch`] if the sizes differ.
    pub fn error_map(&self, reference: &Image, full_scale: f64) -> Result<Image, RenderError> {
        self.check_size(reference)?;
        let mean = reference.pixels.iter().map(|p| luminance(*p)).sum::<f64>()
            / reference.pixels.len().max(1) as f64;
        let mut out = Image::new(self.width, self.height);
        for (i, (a, b)) in self.pixels.iter().zip(&reference.pixels).enumerate() {
            let d = luminance([0, 1, 2].map(|c| (a[c] - b[c]).abs()));
            let denom = luminance(*b).abs().max(mean).max(f64::MIN_POSITIVE);
            // The ramp is display-referred: undo the sRGB encoding of the PNG writer.
            out.pixels[i] = false_colour(d / denom / full_scale).map(srgb_decode);
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn test_image() -> Image {
        let mut img = Image::new(7, 5);
        for y in 0..5 {
            for x in 0..7 {
                img.pixels[y * 7 + x] =
                    [x as f64 * 0.1, y as f64 * 0.2, 0.05 + 1e3 * (x * y) as f64];
            }
        }
        img
    }

    #[test]
    fn exr_round_trip_is_f32_exact() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.exr");
        let img = test_image();
        img.write_exr(&p).unwrap();
        let back = Image::read_exr(&p).unwrap();
        assert_eq!((back.width, back.height), (7, 5));
        for (a, b) in img.pixels.iter().zip(&back.pixels) {
            for c in 0..3 {
                assert_eq!(a[c] as f32 as f64, b[c]);
            }
        }
        // No temporary file is left behind.
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    #[test]
    fn png_round_trip_within_quantisation() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.png");
        let mut img = test_image();
        for px in &mut img.pixels {
            *px = px.map(|v| v.min(1.0));
        }
        img.write_png(&p, ToneMap::Exposure(1.0)).unwrap();
        let back = Image::read_png(&p).unwrap();
        for (a, b) in img.pixels.iter().zip(&back.pixels) {
            for c in 0..3 {
                // Half an 8-bit step in sRGB is at most ~0.0065 in linear.
                assert!((a[c] - b[c]).abs() < 7e-3, "{a:?} {b:?}");
            }
        }
    }

    #[test]
    fn metrics_and_error_map() {
        let a = test_image();
        let m = a.metrics(&a).unwrap();
        assert_eq!(m.l1, 0.0);
        assert_eq!(m.max_abs, 0.0);
        let mut b = a.clone();
        for p in &mut b.pixels {
            p[0] += 0.5;
        }
        let m = b.metrics(&a).unwrap();
        assert!((m.l1 - 0.5 / 3.0).abs() < 1e-12);
        assert!((m.max_abs - 0.5).abs() < 1e-12);
        assert!((m.rmse - (0.25f64 / 3.0).sqrt()).abs() < 1e-12);
        let e = a.error_map(&a, 0.1).unwrap();
        assert!(e.pixels.iter().all(|p| *p == [0.0; 3]));
        assert!(a.metrics(&Image::new(3, 3)).is_err());
    }

    #[test]
    fn failed_write_leaves_old_file() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("keep.bin");
        std::fs::write(&p, b"old").unwrap();
        let r = write_atomic(&p, |tmp| {
            std::fs::write(tmp, b"half").unwrap();
            Err(invalid("test", "interrupted"))
        });
        assert!(r.is_err());
        assert_eq!(std::fs::read(&p).unwrap(), b"old");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }
}
