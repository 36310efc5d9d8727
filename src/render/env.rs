//! Environment lighting (render-scene.md, "The sky" and "Environment maps from files"):
//! the procedural sky, a constant white environment, or an equirectangular map.

use super::scene::Rgb;
use crate::error::InputError;
use crate::geometry::Vec3;
use std::f64::consts::{PI, TAU};
use std::path::Path;

/// The radiance `env(ω)` arriving from direction `ω` (unit) when nothing is in the way.
#[derive(Clone, Debug)]
pub enum Environment {
    /// The procedural sky with a sun lobe.
    Sky,
    /// `env(ω) = 1` in every channel: then a Lambertian pixel with an unoccluded hemisphere
    /// is `∫ (albedo/π) cos θ dω = albedo` (thesis §3.2.6, Test 1).
    White,
    /// An equirectangular map read from a file.
    Map(EnvMap),
}

impl Environment {
    /// `sky`, `white`, or the path of a Radiance `.hdr` / OpenEXR `.exr` map.
    pub fn from_arg(arg: &str) -> Result<Self, InputError> {
        match arg {
            "sky" => Ok(Environment::Sky),
            "white" => Ok(Environment::White),
            path => EnvMap::load(Path::new(path)).map(Environment::Map),
        }
    }

    /// What determines the lighting, for cache keys: `sky`, `white` or `map:<hash of the texels>`.
    pub fn key(&self) -> String {
        match self {
            Environment::Sky => "sky".into(),
            Environment::White => "white".into(),
            Environment::Map(m) => format!("map:{}x{}:{:016x}", m.width, m.height, m.hash),
        }
    }

    /// `env(ω)`.
    #[inline]
    pub fn radiance(&self, w: &Vec3) -> Rgb {
        match self {
            Environment::Sky => sky(w),
            Environment::White => [1.0; 3],
            Environment::Map(m) => m.lookup(w),
        }
    }
}

/// The procedural sky: with `h = ω.y`,
/// `sky = (0.90, 0.90, 0.85)(1 − h) + (0.30, 0.50, 0.90) h` above the horizon,
/// `(0.40, 0.38, 0.35)` below, plus the sun `(6.0, 5.6, 4.8)·max(0, ω·s)^32`,
/// `s = normalize(−1, 1, 0.5)`.
#[inline]
pub fn sky(w: &Vec3) -> Rgb {
    const HORIZON: Rgb = [0.90, 0.90, 0.85];
    const ZENITH: Rgb = [0.30, 0.50, 0.90];
    const GROUND: Rgb = [0.40, 0.38, 0.35];
    const SUN: Rgb = [6.0, 5.6, 4.8];
    // normalize(−1, 1, 0.5) = (−1, 1, 0.5)/1.5.
    const S: [f64; 3] = [-1.0 / 1.5, 1.0 / 1.5, 0.5 / 1.5];
    let h = w.y;
    let base = if h >= 0.0 {
        [0, 1, 2].map(|c| HORIZON[c] * (1.0 - h) + ZENITH[c] * h)
    } else {
        GROUND
    };
    let cos_sun = (w.x * S[0] + w.y * S[1] + w.z * S[2]).max(0.0);
    let lobe = cos_sun.powi(32);
    [0, 1, 2].map(|c| base[c] + SUN[c] * lobe)
}

/// An equirectangular map of `W × H` texels (linear RGB), looked up like Mitsuba 3's `envmap`.
#[derive(Clone, Debug)]
pub struct EnvMap {
    pub width: usize,
    pub height: usize,
    texels: Vec<[f32; 3]>,
    hash: u64,
}

impl EnvMap {
    /// Reads a Radiance `.hdr` or OpenEXR map; unreadable or malformed files are [`InputError`]s
    /// naming the file.
    pub fn load(path: &Path) -> Result<Self, InputError> {
        let name = path.display();
        let bytes = std::fs::read(path)
            .map_err(|e| InputError::new(format!("--env {name}: cannot read the environment map: {e}")))?;
        let img = ::image::ImageReader::new(std::io::Cursor::new(&bytes))
            .with_guessed_format()
            .map_err(|e| InputError::new(format!("--env {name}: {e}")))?
            .decode()
            .map_err(|e| {
                InputError::new(format!(
                    "--env {name}: not a valid Radiance .hdr or OpenEXR image ({e}); \
                     use `sky`, `white` or an equirectangular .hdr/.exr file"
                ))
            })?
            .into_rgb32f();
        let (w, h) = (img.width() as usize, img.height() as usize);
        if w < 1 || h < 2 {
            return Err(InputError::new(format!(
                "--env {name}: the map is {w}×{h} texels; it needs at least 1×2"
            )));
        }
        let texels: Vec<[f32; 3]> = img.pixels().map(|p| p.0).collect();
        if let Some(k) = texels
            .iter()
            .position(|t| t.iter().any(|v| !v.is_finite() || *v < 0.0))
        {
            return Err(InputError::new(format!(
                "--env {name}: texel ({}, {}) = {:?} is not a finite radiance >= 0",
                k % w,
                k / w,
                texels[k]
            )));
        }
        let hash = texels
            .iter()
            .flatten()
            .fold(crate::rng::label_id(&format!("{w}x{h}")), |h, v| {
                crate::rng::splitmix64(h ^ v.to_bits() as u64)
            });
        Ok(EnvMap {
            width: w,
            height: h,
            texels,
            hash,
        })
    }

    /// A map from texels in row-major order (row 0 at the zenith).
    pub fn from_texels(width: usize, height: usize, texels: Vec<[f32; 3]>) -> Self {
        assert!(width >= 1 && height >= 2 && texels.len() == width * height);
        EnvMap {
            width,
            height,
            texels,
            hash: 0,
        }
    }

    /// Bilinear lookup at `u = frac(atan2(ω.x, −ω.z)/(2π))`, `v = arccos(ω.y)/π`; column
    /// coordinate `u·W − ½` (texel centres, wrapping), row coordinate `v·(H − 1)` (row 0 on the
    /// zenith, row `H − 1` on the nadir).
    pub fn lookup(&self, w: &Vec3) -> Rgb {
        let u = (w.x.atan2(-w.z) / TAU).rem_euclid(1.0);
        let v = w.y.clamp(-1.0, 1.0).acos() / PI;
        let x = u * self.width as f64 - 0.5;
        let y = v * (self.height - 1) as f64;
        let x0 = x.floor();
        let fx = x - x0;
        let wi = self.width as i64;
        let c0 = (x0 as i64).rem_euclid(wi) as usize;
        let c1 = (c0 + 1) % self.width;
        let r0 = (y.floor() as usize).min(self.height - 2);
        let fy = y - r0 as f64;
        let t = |r: usize, c: usize| self.texels[r * self.width + c];
        let (a, b, c, d) = (t(r0, c0), t(r0, c1), t(r0 + 1, c0), t(r0 + 1, c1));
        [0, 1, 2].map(|k| {
            let top = a[k] as f64 * (1.0 - fx) + b[k] as f64 * fx;
            let bottom = c[k] as f64 * (1.0 - fx) + d[k] as f64 * fx;
            top * (1.0 - fy) + bottom * fy
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sky_matches_the_definition() {
        assert_eq!(sky(&Vec3::new(0.0, -1.0, 0.0)), [0.40, 0.38, 0.35]);
        let zenith = sky(&Vec3::y());
        let lobe = (1.0f64 / 1.5).powi(32);
        assert!((zenith[2] - (0.90 + 4.8 * lobe)).abs() < 1e-15);
        let sun = sky(&Vec3::new(-1.0, 1.0, 0.5).normalize());
        let h = 1.0 / 1.5;
        assert!((sun[0] - (0.90 * (1.0 - h) + 0.30 * h + 6.0)).abs() < 1e-12);
    }

    /// Texel centres and the pole rows are hit exactly; columns wrap.
    #[test]
    fn map_lookup_follows_mitsuba_conventions() {
        let (w, h) = (4, 3);
        let texels = (0..w * h).map(|k| [k as f32, 0.0, 0.0]).collect();
        let m = EnvMap::from_texels(w, h, texels);
        // Zenith: v = 0, row 0; u from atan2(0, −0) = 0 → column coordinate −½, halfway
        // between column 3 (wrapped) and column 0.
        assert!((m.lookup(&Vec3::y())[0] - 1.5).abs() < 1e-9);
        // Horizon (v = ½ → row 1) at u = (c + ½)/W is the centre of column c.
        for c in 0..w {
            let phi = TAU * (c as f64 + 0.5) / w as f64;
            // atan2(x, −z) = phi ⇔ x = sin phi, −z = cos phi.
            let dir = Vec3::new(phi.sin(), 0.0, -phi.cos());
            assert!((m.lookup(&dir)[0] - (w + c) as f64).abs() < 1e-9, "column {c}");
        }
        // Nadir: row 2.
        let nadir = m.lookup(&Vec3::new(0.0, -1.0, 0.0))[0];
        assert!((nadir - 9.5).abs() < 1e-9, "{nadir}");
    }
}
