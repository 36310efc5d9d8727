//! Linear images, the RMSE (math.md §6) and the files written for them: OpenEXR (linear float
//! RGB), tone-mapped PNG and error images (thesis Fig. 3.14). Encoders are pure (`-> Vec<u8>`);
//! the caller writes with [`crate::files::atomic::write_atomic`].

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
    /// Divide by the largest error of the image: shows where one image's error is, but the same
    /// colour means different errors in different images.
    Normalised,
    /// Divide by a fixed maximum (`--error-max`, default [`DEFAULT_ERROR_MAX`]), clamping larger
    /// errors: the same error has the same colour in every image, so images can be compared.
    Absolute,
}

/// The error norm `‖a − b‖₂` (RGB, linear) at the top of the colour bar by default.
///
/// Chosen from the errors of the renders the workbench compares (256×256, `sky`, against a
/// 3000-spp MC reference): at 40 spp — thesis Fig. 4.3 — 9.2% of MC's pixels and 5.4% of
/// BMC's have errors above 0.25, at 80 spp 3.3% and 0.1%, at 20 spp 17% and 14%. So 0.25
/// keeps the bulk of every such image inside the scale, where differences show, and clamps
/// only the bright ground's worst pixels. 0.1 (about the per-channel RMSE) would clamp 30% and
/// 24% at 40 spp and paint the whole ground plane in the top colour. A fixed default is what
/// makes two images comparable: the same error has the same colour in both.
pub const DEFAULT_ERROR_MAX: f64 = 0.25;

/// An encoded error image and the numbers behind it, for the caller to report.
#[derive(Clone, Debug, PartialEq)]
pub struct ErrorImage {
    /// The PNG: the error map with a colour bar on its right.
    pub png: Vec<u8>,
    /// The largest per-pixel error norm.
    pub max_error: f64,
    /// Its pixel `(x, y)` (the first in row order; row 0 at the top).
    pub max_at: (usize, usize),
    /// The error at the top of the colour bar (the image's own maximum when normalised).
    pub scale_max: f64,
    /// Pixels whose error exceeds `scale_max`, drawn in the top colour.
    pub clamped: usize,
}

/// The colour bar's title on an error image: the per-pixel error norm, in radiance units.
pub const ERROR_TITLE: &str = "|error| (radiance)";
/// The colour bar's title on an sd image: the per-pixel posterior sd norm, in radiance units.
pub const SD_TITLE: &str = "sd (radiance)";
/// The colour bar's title on an adaptive render's spp map.
pub const SPP_TITLE: &str = "samples per pixel";

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

    /// The mean over pixels of the per-pixel RGB L2 norm `‖a − b‖₂` (the thesis code's error
    /// measure, `error.csv` of `../shared/data/thesis/mc30`).
    pub fn mean_l2(&self, reference: &Image) -> f64 {
        assert_eq!((self.width, self.height), (reference.width, reference.height));
        let sum: f64 = self
            .data
            .iter()
            .zip(&reference.data)
            .map(|(a, b)| (0..3).map(|c| (a[c] - b[c]).powi(2)).sum::<f64>().sqrt())
            .sum();
        sum / self.data.len() as f64
    }

    /// The RMSE over the pixels where `mask` (row-major) is true: `sqrt(mean((a − b)²))` over
    /// their three channels; NaN for an empty mask.
    pub fn rmse_masked(&self, reference: &Image, mask: &[bool]) -> f64 {
        assert_eq!((self.width, self.height), (reference.width, reference.height));
        assert_eq!(mask.len(), self.data.len(), "one mask entry per pixel");
        let (mut sum, mut n) = (0.0, 0usize);
        for ((a, b), _) in self
            .data
            .iter()
            .zip(&reference.data)
            .zip(mask)
            .filter(|(_, m)| **m)
        {
            sum += (0..3).map(|c| (a[c] - b[c]).powi(2)).sum::<f64>();
            n += 3;
        }
        (sum / n as f64).sqrt()
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

    /// Reads the reference a `width × height` render is compared with ([`Image::read`]), and
    /// refuses one of another size ([`Image::check_same_size`]) before anything is rendered.
    pub fn read_reference(path: &Path, what: &str, width: usize, height: usize) -> Result<Image, InputError> {
        let reference = Image::read(path, what)?;
        let probe = Image {
            width,
            height,
            data: Vec::new(),
        };
        probe.check_same_size(&reference, what)?;
        Ok(reference)
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
        let bytes = crate::files::read::read(path, crate::files::read::FileKind::Image)
            .map_err(|e| InputError::new(format!("{what} {name}: {}", e.reason())))?;
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

    /// The error image (thesis Fig. 3.14): each pixel's error norm `e` as `e / max e`
    /// (normalised) or `e / max_error` (absolute), clamped to `[0, 1]`, in grey or through
    /// viridis, with a colour bar on the right labelled 0 and the top of the scale (followed by
    /// `+` when pixels are clamped there), so that the colours can be read without the command
    /// line that made them, and titled [`ERROR_TITLE`] along its right edge.
    pub fn error_png(
        &self,
        reference: &Image,
        scale: ErrorScale,
        max_error: f64,
        map: ColourMap,
    ) -> crate::Result<ErrorImage> {
        scalar_png(
            &self.error_norms(reference),
            self.width,
            self.height,
            scale,
            max_error,
            map,
            ERROR_TITLE,
        )
    }
}

/// A non-negative per-pixel quantity `e` (row-major, `width × height`) as a picture with a
/// colour bar, scaled like [`Image::error_png`] (which draws error norms with it; the sd image
/// draws sd norms on the same scale, so the two can be compared colour for colour). `title`
/// (what the values are, with their unit) runs up the bar's right edge.
pub fn scalar_png(
    e: &[f64],
    width: usize,
    height: usize,
    scale: ErrorScale,
    max_error: f64,
    map: ColourMap,
    title: &str,
) -> crate::Result<ErrorImage> {
    assert_eq!(e.len(), width * height, "one value per pixel");
    let (max_i, max) = e
        .iter()
        .copied()
        .enumerate()
        .fold((0, 0.0), |best, (i, v)| if v > best.1 { (i, v) } else { best });
    let top = match scale {
        ErrorScale::Normalised => max,
        ErrorScale::Absolute => max_error,
    };
    let clamped = e.iter().filter(|&&v| v > top).count();
    let colour = |t: f64| match map {
        ColourMap::Grey => [to_u8(t); 3],
        ColourMap::Viridis => viridis(t),
    };
    let mut label = short_number(top);
    if clamped > 0 {
        label.push('+');
    }
    let bar = ColourBar::new(height, &label, title);
    let buf = RgbImage::from_fn((width + bar.width) as u32, height as u32, |x, y| {
        let (x, y) = (x as usize, y as usize);
        if x < width {
            let v = e[y * width + x];
            let t = if top > 0.0 { (v / top).clamp(0.0, 1.0) } else { 0.0 };
            ::image::Rgb(colour(t))
        } else {
            ::image::Rgb(bar.pixel(x - width, y, &colour))
        }
    });
    Ok(ErrorImage {
        png: encode_png(buf)?,
        max_error: max,
        max_at: (max_i % width.max(1), max_i / width.max(1)),
        scale_max: top,
        clamped,
    })
}

/// An 8-bit RGB picture (row-major `width × height` colours) with, on its right, a legend of
/// colour swatches, each labelled (digits, `.`, `e`, `-`, `+` only: the bitmap font has no
/// letters), top to bottom: for categorical maps such as the coverage map.
pub fn legend_png(
    colours: &[[u8; 3]],
    width: usize,
    height: usize,
    legend: &[([u8; 3], &str)],
) -> crate::Result<Vec<u8>> {
    assert_eq!(colours.len(), width * height, "one colour per pixel");
    let s = (height / 96).clamp(1, 3);
    let chars = legend.iter().map(|(_, l)| l.chars().count()).max().unwrap_or(0);
    let gap = 4 * s;
    let swatch = GLYPH_H * s;
    let strip = gap + swatch + 3 * s + chars * GLYPH_ADVANCE * s + 2 * s;
    let row = swatch + 3 * s;
    let buf = RgbImage::from_fn((width + strip) as u32, height as u32, |x, y| {
        let (x, y) = (x as usize, y as usize);
        if x < width {
            return ::image::Rgb(colours[y * width + x]);
        }
        let x = x - width;
        let (entry, dy) = ((y.saturating_sub(gap)) / row, (y.saturating_sub(gap)) % row);
        if y >= gap
            && let Some((colour, label)) = legend.get(entry)
        {
            if (gap..gap + swatch).contains(&x) && dy < swatch {
                return ::image::Rgb(*colour);
            }
            if glyph_pixel(label, x, dy, gap + swatch + 3 * s, 0, s) {
                return ::image::Rgb([0, 0, 0]);
            }
        }
        ::image::Rgb([255, 255, 255])
    });
    encode_png(buf)
}

/// `v` with three significant digits and no trailing zeros (`0.1`, `0.213`, `0.0015`,
/// `2.5e-5`): for the colour bar's label and the CLI's messages.
pub fn short_number(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let trim = |s: String| {
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        }
    };
    let magnitude = v.abs().log10().floor() as i32;
    if (-4..6).contains(&magnitude) {
        let decimals = (2 - magnitude).max(0) as usize;
        trim(format!("{v:.decimals$}"))
    } else {
        let s = format!("{v:.2e}");
        let (mantissa, exponent) = s.split_once('e').expect("{:e} has an exponent");
        format!("{}e{exponent}", trim(mantissa.to_string()))
    }
}

/// The colour bar strip right of an error image: white, with a vertical gradient from the
/// colour of 0 (bottom) to that of 1 (top) and the labels `0` and the scale's top beside its
/// ends, and its title running bottom to top along its right edge, in a 5×7 bitmap font (the
/// `image` crate draws no text).
struct ColourBar {
    /// Width of the whole strip in pixels.
    width: usize,
    height: usize,
    /// Pixel scale of the font (each font pixel is `s × s`).
    s: usize,
    /// Columns of the gradient within the strip.
    bar: std::ops::Range<usize>,
    /// Rows of the gradient: its top row shows 1, its bottom row 0.
    rows: std::ops::Range<usize>,
    /// The top label; `None` if the image is too low for labels.
    top_label: Option<String>,
    /// The title, its first column in the strip, its font scale and the row its text starts
    /// from (reading upwards); `None` if the image is too low for it.
    title: Option<(String, usize, usize, usize)>,
}

impl ColourBar {
    fn new(height: usize, top_label: &str, title: &str) -> ColourBar {
        // Font pixels grow with the image so the labels stay legible at a glance.
        let s = (height / 96).clamp(1, 3);
        let labelled = height >= 2 * (GLYPH_H * s + 2 * s) + 4;
        let gap = 4 * s;
        let bar = gap..gap + 10 * s;
        let chars = top_label.chars().count().max(1);
        let labels_end = if labelled {
            bar.end + 3 * s + chars * GLYPH_ADVANCE * s + 2 * s
        } else {
            bar.end + 2 * s
        };
        // The title at the labels' scale, or smaller if it is too long for the image's height.
        let length = |t: usize| (title.chars().count() * GLYPH_ADVANCE).saturating_sub(1) * t;
        let title_scale = (1..=s).rev().find(|&t| length(t) + 4 * t <= height);
        let (width, title) = match title_scale {
            Some(t) if !title.is_empty() => {
                let x0 = labels_end + 2 * s;
                let start = (height + length(t)) / 2;
                (x0 + GLYPH_H * t + 3 * s, Some((title.to_string(), x0, t, start)))
            }
            _ => (labels_end, None),
        };
        // The labels are centred on the ends of the gradient, so those sit half a glyph in.
        let inset = if labelled {
            (GLYPH_H * s).div_ceil(2) + s
        } else {
            0
        };
        ColourBar {
            width,
            height,
            s,
            bar,
            rows: inset..height - inset,
            top_label: labelled.then(|| top_label.to_string()),
            title,
        }
    }

    /// The colour of strip pixel `(x, y)` given the colour map `colour` on `[0, 1]`.
    fn pixel(&self, x: usize, y: usize, colour: &dyn Fn(f64) -> [u8; 3]) -> [u8; 3] {
        if self.bar.contains(&x) && self.rows.contains(&y) {
            let span = (self.rows.len() - 1).max(1) as f64;
            return colour((self.rows.end - 1 - y) as f64 / span);
        }
        if let Some(top) = &self.top_label {
            let x0 = self.bar.end + 3 * self.s;
            let half = GLYPH_H * self.s / 2;
            let top_y = self.rows.start.saturating_sub(half);
            let bottom_y = (self.rows.end - 1).saturating_sub(half);
            if glyph_pixel(top, x, y, x0, top_y, self.s) || glyph_pixel("0", x, y, x0, bottom_y, self.s) {
                return [0, 0, 0];
            }
        }
        // The title turned a quarter counter-clockwise: its text runs up from row `start`, the
        // glyphs' tops facing the bar.
        if let Some((title, x0, t, start)) = &self.title
            && x >= *x0
            && y <= *start
            && glyph_pixel(title, start - y, x - x0, 0, 0, *t)
        {
            return [0, 0, 0];
        }
        debug_assert!(y < self.height);
        [255, 255, 255]
    }
}

const GLYPH_W: usize = 5;
const GLYPH_H: usize = 7;
const GLYPH_ADVANCE: usize = GLYPH_W + 1;

/// Whether pixel `(x, y)` is ink of `text` drawn with its top-left corner at `(x0, y0)` in
/// font pixels of `s × s`.
fn glyph_pixel(text: &str, x: usize, y: usize, x0: usize, y0: usize, s: usize) -> bool {
    if x < x0 || y < y0 || y >= y0 + GLYPH_H * s {
        return false;
    }
    let (cx, cy) = ((x - x0) / s, (y - y0) / s);
    let (index, col) = (cx / GLYPH_ADVANCE, cx % GLYPH_ADVANCE);
    match text.chars().nth(index) {
        Some(c) if col < GLYPH_W => glyph(c)[cy] >> (GLYPH_W - 1 - col) & 1 == 1,
        _ => false,
    }
}

/// Rows of a 5×7 glyph, most significant of the five bits on the left; unknown characters are
/// blank (labels draw digits, `.`, `e`, `-` and `+`; the colour bars' titles the letters of
/// [`ERROR_TITLE`], [`SD_TITLE`] and [`SPP_TITLE`], `|`, parentheses and spaces).
fn glyph(c: char) -> [u8; GLYPH_H] {
    match c {
        '0' => [0b01110, 0b10001, 0b10011, 0b10101, 0b11001, 0b10001, 0b01110],
        '1' => [0b00100, 0b01100, 0b00100, 0b00100, 0b00100, 0b00100, 0b01110],
        '2' => [0b01110, 0b10001, 0b00001, 0b00010, 0b00100, 0b01000, 0b11111],
        '3' => [0b11111, 0b00010, 0b00100, 0b00010, 0b00001, 0b10001, 0b01110],
        '4' => [0b00010, 0b00110, 0b01010, 0b10010, 0b11111, 0b00010, 0b00010],
        '5' => [0b11111, 0b10000, 0b11110, 0b00001, 0b00001, 0b10001, 0b01110],
        '6' => [0b00110, 0b01000, 0b10000, 0b11110, 0b10001, 0b10001, 0b01110],
        '7' => [0b11111, 0b00001, 0b00010, 0b00100, 0b01000, 0b01000, 0b01000],
        '8' => [0b01110, 0b10001, 0b10001, 0b01110, 0b10001, 0b10001, 0b01110],
        '9' => [0b01110, 0b10001, 0b10001, 0b01111, 0b00001, 0b00010, 0b01100],
        '.' => [0, 0, 0, 0, 0, 0b01100, 0b01100],
        'e' => [0, 0, 0b01110, 0b10001, 0b11111, 0b10000, 0b01110],
        '-' => [0, 0, 0, 0b11111, 0, 0, 0],
        '+' => [0, 0b00100, 0b00100, 0b11111, 0b00100, 0b00100, 0],
        'a' => [0, 0, 0b01110, 0b00001, 0b01111, 0b10001, 0b01111],
        'c' => [0, 0, 0b01110, 0b10000, 0b10000, 0b10001, 0b01110],
        'd' => [0b00001, 0b00001, 0b01101, 0b10011, 0b10001, 0b10001, 0b01111],
        'i' => [0b00100, 0, 0b01100, 0b00100, 0b00100, 0b00100, 0b01110],
        'l' => [0b01100, 0b00100, 0b00100, 0b00100, 0b00100, 0b00100, 0b01110],
        'm' => [0, 0, 0b11010, 0b10101, 0b10101, 0b10001, 0b10001],
        'n' => [0, 0, 0b10110, 0b11001, 0b10001, 0b10001, 0b10001],
        'o' => [0, 0, 0b01110, 0b10001, 0b10001, 0b10001, 0b01110],
        'p' => [0, 0, 0b11110, 0b10001, 0b11110, 0b10000, 0b10000],
        'r' => [0, 0, 0b10110, 0b11001, 0b10000, 0b10000, 0b10000],
        's' => [0, 0, 0b01110, 0b10000, 0b01110, 0b00001, 0b11110],
        'x' => [0, 0, 0b10001, 0b01010, 0b00100, 0b01010, 0b10001],
        '|' => [0b00100; GLYPH_H],
        '(' => [0b00010, 0b00100, 0b01000, 0b01000, 0b01000, 0b00100, 0b00010],
        ')' => [0b01000, 0b00100, 0b00010, 0b00010, 0b00010, 0b00100, 0b01000],
        _ => [0; GLYPH_H],
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

    fn decode(png: &[u8]) -> RgbImage {
        ::image::load_from_memory(png).unwrap().into_rgb8()
    }

    /// A 64×48 image whose error norm grows along x (row 0: 0 … 0.63), against black.
    fn ramp(gain: f64) -> (Image, Image) {
        let (w, h) = (64, 48);
        let data = (0..w * h)
            .map(|i| [gain * (i % w) as f64 / 100.0, 0.0, 0.0])
            .collect();
        (
            Image {
                width: w,
                height: h,
                data,
            },
            Image {
                width: w,
                height: h,
                data: vec![[0.0; 3]; w * h],
            },
        )
    }

    #[test]
    fn the_colour_bar_follows_the_map_and_is_labelled() {
        let (a, b) = ramp(1.0);
        for map in [ColourMap::Viridis, ColourMap::Grey] {
            let e = a.error_png(&b, ErrorScale::Absolute, 0.25, map).unwrap();
            let png = decode(&e.png);
            assert!(png.width() as usize > a.width, "no strip");
            assert_eq!(png.height() as usize, a.height);
            let bar = ColourBar::new(a.height, "0.25+", ERROR_TITLE);
            assert_eq!(png.width() as usize, a.width + bar.width);
            let colour = |t: f64| match map {
                ColourMap::Grey => [to_u8(t); 3],
                ColourMap::Viridis => viridis(t),
            };
            // Every row of the gradient shows its value, 1 at the top to 0 at the bottom.
            let x = (a.width + bar.bar.start + 1) as u32;
            let (top, bottom) = (bar.rows.start, bar.rows.end - 1);
            for y in top..=bottom {
                let t = (bottom - y) as f64 / (bottom - top) as f64;
                assert_eq!(png.get_pixel(x, y as u32).0, colour(t), "row {y}");
            }
            assert_eq!(png.get_pixel(x, top as u32).0, colour(1.0));
            assert_eq!(png.get_pixel(x, bottom as u32).0, colour(0.0));
            // Labels: black ink right of the bar, near its top and near its bottom.
            let ink = |ys: std::ops::Range<usize>| {
                ys.flat_map(|y| (a.width + bar.bar.end..png.width() as usize).map(move |x| (x, y)))
                    .any(|(x, y)| png.get_pixel(x as u32, y as u32).0 == [0, 0, 0])
            };
            assert!(ink(0..top + 5) && ink(bottom - 4..a.height));
            // Between the labels, ink only in the title's column, right of the labels.
            let title_x = bar.title.as_ref().map_or(bar.width, |t| t.1);
            let ink_before = |ys: std::ops::Range<usize>, end: usize| {
                ys.flat_map(|y| (a.width + bar.bar.end..a.width + end).map(move |x| (x, y)))
                    .any(|(x, y)| png.get_pixel(x as u32, y as u32).0 == [0, 0, 0])
            };
            assert!(
                !ink_before(top + 10..bottom - 10, title_x),
                "ink between the labels"
            );
        }
    }

    /// Issue 22 item 9: the colour bar has a title with its unit, running up its right edge in
    /// its own column; an image too low for the title at any scale goes without it.
    #[test]
    fn the_colour_bar_has_a_title_with_its_unit() {
        let bar = ColourBar::new(256, "0.25+", ERROR_TITLE);
        let (title, x0, t, start) = bar.title.clone().expect("room for a title");
        assert_eq!((title.as_str(), t), (ERROR_TITLE, 2));
        // Centred: as much room above the text as below.
        let length = (ERROR_TITLE.chars().count() * GLYPH_ADVANCE - 1) * t;
        assert!(start < 256 && start + 1 >= length && (256 - start).abs_diff(start + 1 - length) <= 1);
        let white = [255u8; 3];
        let ink: usize = (0..bar.width)
            .flat_map(|x| (0..256).map(move |y| (x, y)))
            .filter(|&(x, y)| x >= x0 && bar.pixel(x, y, &|_| white) == [0, 0, 0])
            .count();
        assert!(ink > 100, "{ink} ink pixels in the title column");
        // Every title's letters have glyphs.
        for c in [ERROR_TITLE, SD_TITLE, SPP_TITLE]
            .concat()
            .chars()
            .filter(|c| *c != ' ')
        {
            assert_ne!(glyph(c), [0; GLYPH_H], "{c:?} has no glyph");
        }
        assert!(ColourBar::new(30, "0.25", SPP_TITLE).title.is_none());
        let untitled = ColourBar::new(256, "0.25+", "");
        assert!(untitled.title.is_none() && untitled.width < bar.width);
    }

    #[test]
    fn the_error_image_reports_its_maximum_and_what_it_clamped() {
        let (a, b) = ramp(1.0);
        let e = a
            .error_png(&b, ErrorScale::Absolute, 0.25, ColourMap::Viridis)
            .unwrap();
        assert_eq!(e.max_at, (63, 0));
        assert!((e.max_error - 0.63).abs() < 1e-12);
        assert_eq!(e.scale_max, 0.25);
        // Columns 26 … 63 (errors 0.26 … 0.63) of all 48 rows are above the scale.
        assert_eq!(e.clamped, 38 * 48);
        let n = a
            .error_png(&b, ErrorScale::Normalised, 0.25, ColourMap::Viridis)
            .unwrap();
        assert_eq!((n.scale_max, n.clamped), (e.max_error, 0));
    }

    /// The point of the absolute default: the same error has the same colour in two images
    /// with different largest errors — and not when each is normalised by its own maximum.
    #[test]
    fn a_common_scale_gives_the_same_error_the_same_colour() {
        let (a1, b) = ramp(1.0);
        let (a2, _) = ramp(0.5);
        // Pixel x has error x/100 in the first image and x/200 in the second: error 0.1 is
        // pixel 10 in one and pixel 20 in the other.
        let colour_at = |img: &Image, x: u32, scale| {
            let e = img
                .error_png(&b, scale, DEFAULT_ERROR_MAX, ColourMap::Viridis)
                .unwrap();
            decode(&e.png).get_pixel(x, 5).0
        };
        assert_eq!(
            colour_at(&a1, 10, ErrorScale::Absolute),
            colour_at(&a2, 20, ErrorScale::Absolute)
        );
        assert_eq!(
            colour_at(&a1, 10, ErrorScale::Absolute),
            viridis(0.1 / DEFAULT_ERROR_MAX)
        );
        assert_ne!(
            colour_at(&a1, 10, ErrorScale::Normalised),
            colour_at(&a2, 20, ErrorScale::Normalised)
        );
    }

    #[test]
    fn short_numbers() {
        let cases = [
            (0.1, "0.1"),
            (0.25, "0.25"),
            (0.2134, "0.213"),
            (0.0015, "0.0015"),
            (1.67, "1.67"),
            (12.0, "12"),
            (2.5e-5, "2.5e-5"),
            (0.0, "0"),
        ];
        for (v, s) in cases {
            assert_eq!(short_number(v), s, "{v}");
        }
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
