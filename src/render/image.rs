//! Linear images, the RMSE (math.md §6) and the files written for them: OpenEXR (linear float
//! RGB), tone-mapped PNG and error images (thesis Fig. 3.14). Encoders are pure (`-> Vec<u8>`);
//! the caller writes with [`crate::io::write_atomic`].

use super::scene::Rgb;
use crate::error::InputError;
use ::image::{ImageFormat, Rgb32FImage, RgbImage};
use std::io::Cursor;
use std::path::Path;

/// A linear RGB image, row-major, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    pub width: usize,
    pub height: usize,
    pub data: Vec<Rgb>,
}

/// How an error image scales the per-pixel error norm to `[0, 1]`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ErrorScale {
    /// Divide by the largest error of the image.
    Normalised,
    /// Divide by a fixed maximum (`--error-max`), so that images can be compared.
    Absolute,
}

/// How an error image shows the scaled error.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ColourMap {
    /// Black (0) to white (1).
    Grey,
    /// matplotlib's perceptually uniform `viridis`.
    Viridis,
}

impl Image {
    /// `sqrt(mean((a − b)²))` over all pixels and the three channels of the linear images.
    ///
    /// Panics if the sizes differ (callers check with [`Image::check_same_size`]).
    pub fn rmse(&self, reference: &Image) -> f64 {
        assert_eq!((self.width, self.height), (reference.width, reference.height));
        let sum: f64 = self
            .data
            .iter()
            .zip(&reference.data)
            .map(|(a, b)| (0..3).map(|c| (a[c] - b[c]).powi(2)).sum::<f64>())
            .sum();
        (sum / (3 * self.data.len()) as f64).sqrt()
    }

    /// An [`InputError`] unless `other` (read from `what`) has this image's size.
    pub fn check_same_size(&self, other: &Image, what: &str) -> Result<(), InputError> {
        if (self.width, self.height) == (other.width, other.height) {
            Ok(())
        } else {
            Err(InputError::new(format!(
                "{what}: the reference is {}×{}, the render is {}×{}; render at the reference's size",
                other.width, other.height, self.width, self.height
            )))
        }
    }

    /// The linear image as OpenEXR, 32-bit float RGB.
    pub fn to_exr(&self) -> crate::Result<Vec<u8>> {
        let buf = Rgb32FImage::from_fn(self.width as u32, self.height as u32, |x, y| {
            let p = self.data[y as usize * self.width + x as usize];
            ::image::Rgb(p.map(|v| v as f32))
        });
        let mut out = Cursor::new(Vec::new());
        ::image::DynamicImage::ImageRgb32F(buf)
            .write_to(&mut out, ImageFormat::OpenExr)
            .map_err(|e| crate::Error::Encode(format!("encoding OpenEXR: {e}")))?;
        Ok(out.into_inner())
    }

    /// Reads an OpenEXR (or Radiance .hdr) image; errors name `what` and the file.
    pub fn read(path: &Path, what: &str) -> Result<Image, InputError> {
        let name = path.display();
        let bytes =
            std::fs::read(path).map_err(|e| InputError::new(format!("{what} {name}: cannot read: {e}")))?;
        // Recognised by content: an 8-bit PNG is not linear radiance, whatever its name.
        let img = crate::render::env::decode_hdr_image(&bytes)
            .map_err(|m| InputError::new(format!("{what} {name}: {m}")))?;
        // A NaN or infinite pixel would turn every RMSE against this image into NaN/inf; a
        // damaged reference must be an error (or, for the reference cache, a reason to render
        // again), not a silently meaningless table.
        if let Some(bad) = first_non_finite(img.width() as usize, img.as_raw()) {
            return Err(InputError::new(format!(
                "{what} {name}: {bad}; an image must hold finite values"
            )));
        }
        Ok(Image {
            width: img.width() as usize,
            height: img.height() as usize,
            data: img.pixels().map(|p| p.0.map(f64::from)).collect(),
        })
    }

    /// The picture for people: exposure 1, clamp to `[0, 1]`, sRGB transfer curve, 8-bit PNG.
    pub fn to_png(&self) -> crate::Result<Vec<u8>> {
        let buf = RgbImage::from_fn(self.width as u32, self.height as u32, |x, y| {
            let p = self.data[y as usize * self.width + x as usize];
            ::image::Rgb(p.map(|v| to_u8(srgb(v.clamp(0.0, 1.0)))))
        });
        encode_png(buf)
    }

    /// Per-pixel error norms `e = ‖a − b‖₂` of the RGB difference (thesis §3.2.7).
    pub fn error_norms(&self, reference: &Image) -> Vec<f64> {
        self.data
            .iter()
            .zip(&reference.data)
            .map(|(a, b)| (0..3).map(|c| (a[c] - b[c]).powi(2)).sum::<f64>().sqrt())
            .collect()
    }

    /// The error image (thesis Fig. 3.14): `e / max e` (normalised) or `e / max_error`
    /// (absolute), clamped to `[0, 1]`, in grey or through viridis.
    pub fn error_png(
        &self,
        reference: &Image,
        scale: ErrorScale,
        max_error: f64,
        map: ColourMap,
    ) -> crate::Result<Vec<u8>> {
        let e = self.error_norms(reference);
        let top = match scale {
            ErrorScale::Normalised => e.iter().copied().fold(0.0, f64::max),
            ErrorScale::Absolute => max_error,
        };
        let buf = RgbImage::from_fn(self.width as u32, self.height as u32, |x, y| {
            let v = e[y as usize * self.width + x as usize];
            let t = if top > 0.0 { (v / top).clamp(0.0, 1.0) } else { 0.0 };
            ::image::Rgb(match map {
                ColourMap::Grey => [to_u8(t); 3],
                ColourMap::Viridis => viridis(t),
            })
        });
        encode_png(buf)
    }
}

fn encode_png(buf: RgbImage) -> crate::Result<Vec<u8>> {
    let mut out = Cursor::new(Vec::new());
    buf.write_to(&mut out, ImageFormat::Png)
        .map_err(|e| crate::Error::Encode(format!("encoding PNG: {e}")))?;
    Ok(out.into_inner())
}

/// The first non-finite value of row-major RGB samples (`width` pixels a row), described as
/// `pixel (x, y) channel g is NaN` (x from the left, y from the top, as image viewers count).
fn first_non_finite(width: usize, samples: &[f32]) -> Option<String> {
    let k = samples.iter().position(|v| !v.is_finite())?;
    let (pixel, channel) = (k / 3, ["r", "g", "b"][k % 3]);
    let (x, y) = (pixel % width, pixel / width);
    Some(format!("pixel ({x}, {y}) channel {channel} is {}", samples[k]))
}

/// The sRGB transfer curve: `12.92 v` for `v ≤ 0.0031308`, else `1.055 v^(1/2.4) − 0.055`.
#[inline]
pub fn srgb(v: f64) -> f64 {
    if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

#[inline]
fn to_u8(v: f64) -> u8 {
    (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8
}

/// matplotlib's viridis at `t ∈ [0, 1]`, linear interpolation between nine of its stops.
pub fn viridis(t: f64) -> [u8; 3] {
    const STOPS: [[f64; 3]; 9] = [
        [68.0, 1.0, 84.0],
        [71.0, 44.0, 122.0],
        [59.0, 81.0, 139.0],
        [44.0, 113.0, 142.0],
        [33.0, 144.0, 141.0],
        [39.0, 173.0, 129.0],
        [92.0, 200.0, 99.0],
        [170.0, 220.0, 50.0],
        [253.0, 231.0, 37.0],
    ];
    let x = t.clamp(0.0, 1.0) * (STOPS.len() - 1) as f64;
    let k = (x as usize).min(STOPS.len() - 2);
    let f = x - k as f64;
    [0, 1, 2].map(|c| (STOPS[k][c] * (1.0 - f) + STOPS[k + 1][c] * f + 0.5) as u8)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn img(data: Vec<Rgb>) -> Image {
        Image {
            width: data.len(),
            height: 1,
            data,
        }
    }

    #[test]
    fn rmse_is_over_pixels_and_channels() {
        let a = img(vec![[0.0; 3], [0.0; 3]]);
        let b = img(vec![[1.0, 0.0, 0.0], [0.0; 3]]);
        assert!((a.rmse(&b) - (1.0f64 / 6.0).sqrt()).abs() < 1e-15);
        assert_eq!(a.rmse(&a), 0.0);
    }

    #[test]
    fn exr_round_trips_at_f32_precision() {
        let a = img(vec![[0.1, 2.5, 1e-3], [7.0, 0.0, 0.333]]);
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.exr");
        std::fs::write(&path, a.to_exr().unwrap()).unwrap();
        let b = Image::read(&path, "--reference").unwrap();
        assert_eq!((b.width, b.height), (2, 1));
        assert!(a.rmse(&b) < 1e-7);
    }

    #[test]
    fn srgb_and_viridis_end_points() {
        assert_eq!(to_u8(srgb(1.0)), 255);
        assert_eq!(to_u8(srgb(0.0)), 0);
        assert_eq!(to_u8(srgb(0.5)), 188);
        assert_eq!(viridis(0.0), [68, 1, 84]);
        assert_eq!(viridis(1.0), [253, 231, 37]);
    }
}
