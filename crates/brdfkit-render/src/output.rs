//! The rendered image and its files: EXR (linear radiance) and PNG (tone-mapped sRGB),
//! both written atomically by [`brdfkit_core::atomic`] (a temporary file in the
//! destination directory, then a rename), so a reader never sees a half-written image,
//! and with the permissions of every other output.
//!
//! # Tone mapping (PNG only)
//!
//! Each linear channel c becomes c' = clamp(c · 2^exposure, 0, 1), then the sRGB
//! transfer function of IEC 61966-2-1, V = 12.92 c' for c' ≤ 0.0031308 and
//! 1.055 c'^(1/2.4) − 0.055 above, then round(255 V). No other curve: a preview should
//! show the radiance, with `film.exposure` to bring it into range. The EXR holds the
//! radiance itself (float32, no exposure).

use crate::error::OutputError;
use crate::stats::RenderStats;
use brdfkit_core::Rgb;
use image::{ImageFormat, Rgb32FImage, RgbImage};
use std::io::Cursor;
use std::path::Path;

/// A rendered image.
#[derive(Clone, Debug)]
pub struct RenderOutput {
    /// Pixels per row.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// Samples per pixel actually taken: `film.spp`, or 1 with the `center` filter and
    /// no environment (every sample would repeat the same deterministic value).
    pub spp: usize,
    /// Linear radiance (W m⁻² sr⁻¹ per channel), row-major, row 0 at the top.
    pub radiance: Vec<Rgb>,
    /// Standard error of each pixel's mean (sample standard deviation / √spp); zero for
    /// spp = 1 or where every sample agrees.
    pub std_error: Vec<Rgb>,
    /// PNG exposure in stops (from `film.exposure`).
    pub exposure: f64,
    /// Per-effect cost.
    pub stats: RenderStats,
}

/// sRGB encoding of a linear value in [0, 1] (IEC 61966-2-1).
#[inline]
pub fn linear_to_srgb(c: f64) -> f64 {
    if c <= 0.003_130_8 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

/// One tone-mapped 8-bit sRGB channel (see the module documentation).
#[inline]
pub fn tonemap_channel(c: f64, exposure: f64) -> u8 {
    // Radiance above the display's white clips; NaN cannot occur (render rejects it)
    // but would map to 0 through the clamp's NaN-free max/min.
    let v = (c * exposure.exp2()).clamp(0.0, 1.0);
    (linear_to_srgb(v) * 255.0).round() as u8
}

/// Encodes in memory with `encode`, then writes through brdfkit's one writer
/// ([`brdfkit_core::atomic::write_bytes`]): an encoder failure leaves no file, and a new
/// image gets 0666 & ~umask like any other output, not a temporary file's 0600.
fn write_image(
    path: &Path,
    encode: impl FnOnce(&mut Cursor<Vec<u8>>) -> image::ImageResult<()>,
) -> Result<(), OutputError> {
    let mut buf = Cursor::new(Vec::new());
    encode(&mut buf).map_err(|source| OutputError::Encode {
        path: path.to_path_buf(),
        source,
    })?;
    brdfkit_core::atomic::write_bytes(path, buf.get_ref()).map_err(OutputError::Io)
}

impl RenderOutput {
    /// Radiance of pixel (x, y).
    pub fn pixel(&self, x: usize, y: usize) -> Rgb {
        self.radiance[y * self.width + x]
    }

    /// Standard error of pixel (x, y).
    pub fn pixel_std_error(&self, x: usize, y: usize) -> Rgb {
        self.std_error[y * self.width + x]
    }

    /// The tone-mapped 8-bit sRGB image (see the module documentation).
    pub fn to_srgb8(&self, exposure: f64) -> RgbImage {
        let mut img = RgbImage::new(self.width as u32, self.height as u32);
        for (p, c) in img.pixels_mut().zip(&self.radiance) {
            *p = image::Rgb([
                tonemap_channel(c[0], exposure),
                tonemap_channel(c[1], exposure),
                tonemap_channel(c[2], exposure),
            ]);
        }
        img
    }

    /// The linear radiance as a float32 image.
    pub fn to_rgb32f(&self) -> Rgb32FImage {
        let mut img = Rgb32FImage::new(self.width as u32, self.height as u32);
        for (p, c) in img.pixels_mut().zip(&self.radiance) {
            *p = image::Rgb([c[0] as f32, c[1] as f32, c[2] as f32]);
        }
        img
    }

    /// Writes the tone-mapped image (exposure `self.exposure`) as an 8-bit sRGB PNG.
    pub fn write_png(&self, path: impl AsRef<Path>) -> Result<(), OutputError> {
        write_image(path.as_ref(), |buf| {
            self.to_srgb8(self.exposure).write_to(buf, ImageFormat::Png)
        })
    }

    /// Writes the linear radiance as a float32 RGB OpenEXR file.
    pub fn write_exr(&self, path: impl AsRef<Path>) -> Result<(), OutputError> {
        write_image(path.as_ref(), |buf| {
            self.to_rgb32f().write_to(buf, ImageFormat::OpenExr)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_curve_matches_the_standard() {
        assert_eq!(tonemap_channel(0.0, 0.0), 0);
        assert_eq!(tonemap_channel(1.0, 0.0), 255);
        assert_eq!(tonemap_channel(7.0, 0.0), 255);
        assert_eq!(tonemap_channel(-1.0, 0.0), 0);
        // ((0.6 + 0.055)/1.055)^2.4 = 0.318547 linear is sRGB 0.6 → 153;
        // 0.5 linear → 0.7354 → 188.
        assert_eq!(tonemap_channel(0.318_547, 0.0), 153);
        assert_eq!(tonemap_channel(0.5, 0.0), 188);
        // One stop up doubles before the curve.
        assert_eq!(tonemap_channel(0.25, 1.0), 188);
        // Continuity at the knee.
        let a = 12.92 * 0.003_130_8;
        let b = 1.055 * 0.003_130_8f64.powf(1.0 / 2.4) - 0.055;
        assert!((a - b).abs() < 1e-6);
    }
}
