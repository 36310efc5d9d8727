//! What a render says about its own error: the per-pixel sd its estimator states, how often
//! the interval `Î ± q·sd` holds the reference (coverage, math.md §7), and the pictures of both.
//!
//! `render --sd-out sd.exr` writes [`PixelSds::sd`] (linear, one sd per channel) with a PNG of
//! its norm `‖sd‖₂` on the error image's scale; with `--reference` also the coverage map
//! ([`coverage_map_png`]) and the image-wide figures ([`Coverage`]). Render tables report
//! coverage95 per render and cell.

use super::image::{Image, legend_png};
use crate::bq::estimator::Uncertainty;

/// The sd each pixel's estimator states per channel, and the law of its intervals.
#[derive(Clone, Debug, PartialEq)]
pub struct PixelSds {
    /// The sd per pixel and channel, linear; 0 for background pixels (no estimate).
    pub sd: Image,
    /// Whether the pixel has an estimate (its primary ray hit the scene).
    pub hit: Vec<bool>,
    /// Student-t degrees of freedom of the intervals (None: normal). One estimator at one spp
    /// states the same law at every pixel.
    pub dof: Option<usize>,
    /// Pixel-channels whose fitted amplitude is exactly 0 (every residual 0, e.g. every sample
    /// occluded): their interval is a point, absence of evidence rather than certainty (math.md
    /// §7); they stay in the coverage.
    pub zero_amplitude: usize,
}

impl PixelSds {
    /// From each pixel's stated uncertainty (None for background pixels), row-major.
    ///
    /// # Panics
    /// If pixels state different interval laws.
    pub fn new(width: usize, height: usize, pixels: &[Option<[Uncertainty; 3]>]) -> Self {
        assert_eq!(pixels.len(), width * height, "one entry per pixel");
        let dof = pixels.iter().flatten().next().map(|u| u[0].dof).unwrap_or(None);
        let data = pixels
            .iter()
            .map(|p| match p {
                Some(u) => {
                    assert!(u.iter().all(|c| c.dof == dof), "one interval law per image");
                    u.map(|c| c.sd)
                }
                None => [0.0; 3],
            })
            .collect();
        let zero_amplitude = pixels
            .iter()
            .flatten()
            .flat_map(|u| u.iter())
            .filter(|c| c.amplitude == Some(0.0))
            .count();
        PixelSds {
            sd: Image { width, height, data },
            hit: pixels.iter().map(Option::is_some).collect(),
            dof,
            zero_amplitude,
        }
    }

    /// The two-sided quantile `q` of the intervals `Î ± q·sd` at `level`.
    pub fn quantile(&self, level: f64) -> f64 {
        crate::util::stats::interval_quantile(self.dof, level)
    }

    /// `‖sd‖₂` over the three channels per pixel: the root of the expected squared error norm
    /// `E‖Î − I‖²` if the sds are right, so comparable with the error image's `‖render − ref‖₂`.
    pub fn norms(&self) -> Vec<f64> {
        self.sd
            .data
            .iter()
            .map(|s| s.iter().map(|v| v * v).sum::<f64>().sqrt())
            .collect()
    }

    /// How many of pixel `k`'s channels hold the reference within `q · sd`: `|Î − I| ≤ q·sd`
    /// (so an exact estimate with sd 0 is covered); None for background pixels.
    pub fn channels_covered(&self, image: &Image, reference: &Image, q: f64, k: usize) -> Option<u8> {
        self.hit[k].then(|| {
            (0..3)
                .filter(|&c| (image.data[k][c] - reference.data[k][c]).abs() <= q * self.sd.data[k][c])
                .count() as u8
        })
    }
}

/// Image-wide calibration of a render against its reference, over the hit pixels' channels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Coverage {
    /// Pixel-channels counted (3 per hit pixel, or per pixel of the mask).
    pub pixel_channels: usize,
    /// Shares of them whose interval at 50%, 80% and 95% holds the reference.
    pub coverage50: f64,
    pub coverage80: f64,
    pub coverage95: f64,
    /// Median of `|Î − I| / sd` (`0/0` counts as 0, `x/0` as ∞): 0.674 for calibrated normal
    /// intervals.
    pub median_error_over_sd: f64,
}

/// Coverage of `image`'s intervals (sds `sds`) against `reference`, over the hit pixels where
/// `mask` (row-major; None: everywhere) is true. NaN shares when no pixel counts.
pub fn coverage(image: &Image, reference: &Image, sds: &PixelSds, mask: Option<&[bool]>) -> Coverage {
    assert_eq!((image.width, image.height), (reference.width, reference.height));
    let (q50, q80, q95) = (sds.quantile(0.5), sds.quantile(0.8), sds.quantile(0.95));
    let mut counts = [0usize; 3];
    let mut ratios = Vec::new();
    for k in 0..image.data.len() {
        if !sds.hit[k] || mask.is_some_and(|m| !m[k]) {
            continue;
        }
        for c in 0..3 {
            let e = (image.data[k][c] - reference.data[k][c]).abs();
            let sd = sds.sd.data[k][c];
            for (n, q) in counts.iter_mut().zip([q50, q80, q95]) {
                *n += usize::from(e <= q * sd);
            }
            ratios.push(if e == 0.0 { 0.0 } else { e / sd });
        }
    }
    let n = ratios.len();
    ratios.sort_by(f64::total_cmp);
    let share = |k: usize| k as f64 / n as f64;
    Coverage {
        pixel_channels: n,
        coverage50: share(counts[0]),
        coverage80: share(counts[1]),
        coverage95: share(counts[2]),
        median_error_over_sd: if n == 0 {
            f64::NAN
        } else {
            crate::util::stats::quantile_sorted(&ratios, 0.5)
        },
    }
}

/// Colours of the coverage map: every channel covered, some (1 or 2), none; background.
pub const COVERED_ALL: [u8; 3] = [225, 225, 225];
pub const COVERED_SOME: [u8; 3] = [240, 170, 30];
pub const COVERED_NONE: [u8; 3] = [200, 30, 30];
pub const BACKGROUND: [u8; 3] = [40, 40, 40];

/// The coverage map at `level`: each hit pixel light grey when the interval of every channel
/// holds the reference, orange when one or two do, red when none does; background dark grey.
/// A legend on the right labels the colours with the number of channels covered (`3`, `1-2`,
/// `0`). Calibrated 95% intervals leave about 14% of pixels orange (1 − 0.95³) and almost none
/// red if the channels' errors were independent; they are strongly correlated here (one set of
/// directions serves all three), so fewer are orange and red marks where the model is wrong.
pub fn coverage_map_png(
    image: &Image,
    reference: &Image,
    sds: &PixelSds,
    level: f64,
) -> crate::Result<Vec<u8>> {
    let q = sds.quantile(level);
    let colours: Vec<[u8; 3]> = (0..image.data.len())
        .map(|k| match sds.channels_covered(image, reference, q, k) {
            None => BACKGROUND,
            Some(3) => COVERED_ALL,
            Some(0) => COVERED_NONE,
            Some(_) => COVERED_SOME,
        })
        .collect();
    legend_png(
        &colours,
        image.width,
        image.height,
        &[(COVERED_ALL, "3"), (COVERED_SOME, "1-2"), (COVERED_NONE, "0")],
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sds(sd: Vec<[f64; 3]>, hit: Vec<bool>, dof: Option<usize>) -> PixelSds {
        let n = sd.len();
        PixelSds {
            sd: Image {
                width: n,
                height: 1,
                data: sd,
            },
            hit,
            dof,
            zero_amplitude: 0,
        }
    }

    /// The covered-channel count and the image-wide shares follow `|Î − I| ≤ q·sd` with the
    /// normal (or Student-t) quantile; background pixels do not count; 0/0 is covered.
    #[test]
    fn coverage_counts_channels_inside_the_interval() {
        let reference = Image {
            width: 4,
            height: 1,
            data: vec![[0.0; 3]; 4],
        };
        // Errors 1.0 against sd 1: inside 95% (1.96) and 80% (1.28), outside 50% (0.674);
        // 2.5: outside all; 0 with sd 0: covered.
        let image = Image {
            data: vec![[1.0, 2.5, 0.0], [2.5, 2.5, 2.5], [9.0; 3], [0.5, 0.5, 0.5]],
            ..reference.clone()
        };
        let s = sds(
            vec![[1.0, 1.0, 0.0], [1.0; 3], [0.0; 3], [1.0; 3]],
            vec![true, true, false, true],
            None,
        );
        let q = s.quantile(0.95);
        assert!((q - 1.959964).abs() < 1e-6);
        assert_eq!(s.channels_covered(&image, &reference, q, 0), Some(2));
        assert_eq!(s.channels_covered(&image, &reference, q, 1), Some(0));
        assert_eq!(s.channels_covered(&image, &reference, q, 2), None);
        assert_eq!(s.channels_covered(&image, &reference, q, 3), Some(3));
        let c = coverage(&image, &reference, &s, None);
        assert_eq!(c.pixel_channels, 9);
        assert_eq!(c.coverage95, 5.0 / 9.0);
        assert_eq!(c.coverage80, 5.0 / 9.0);
        assert_eq!(c.coverage50, 4.0 / 9.0); // 0/0 and the three 0.5s
        // Ratios sorted: 0, 0.5 ×3, 1, 2.5 ×4: the median is 1.
        assert_eq!(c.median_error_over_sd, 1.0);
        let masked = coverage(&image, &reference, &s, Some(&[false, false, false, true]));
        assert_eq!((masked.pixel_channels, masked.coverage95), (3, 1.0));
        // With 4 degrees of freedom q95 = 2.776: the 2.5s are now inside too.
        let t = sds(s.sd.data.clone(), s.hit.clone(), Some(4));
        assert_eq!(coverage(&image, &reference, &t, None).coverage95, 1.0);
        let png = coverage_map_png(&image, &reference, &s, 0.95).unwrap();
        assert!(png.starts_with(b"\x89PNG"));
    }
}
