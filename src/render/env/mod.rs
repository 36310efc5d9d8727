//! Environment lighting (render-scene.md, "The sky" and "Environment maps from files"):
//! the procedural sky, a constant white environment, or an equirectangular map.

use super::scene::Rgb;
use crate::error::InputError;
use crate::files::read::FileKind;
use crate::sampling::light::{self, LightDistribution};
use crate::util::geometry::Vec3;
use cells::CellTable;
use std::f64::consts::{PI, TAU};
use std::path::Path;
use std::sync::{Arc, LazyLock, OnceLock};

pub mod cells;

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
    /// `sky`, `white`, a catalogue map's name (`pisa`, read from the data folder and checked
    /// against its sha256; [`crate::data`]), or the path of a Radiance `.hdr` / OpenEXR map
    /// (whatever its name; a path is anything with a `/` or an existing file). Errors start with
    /// `ARG: `; the caller puts the setting's name before it (the CLI's `--env`, a spec's `env:`).
    pub fn from_arg(arg: &str) -> Result<Self, InputError> {
        match arg {
            "sky" => Ok(Environment::Sky),
            "white" => Ok(Environment::White),
            _ => {
                let failed = |e: crate::data::DataError| InputError::new(format!("{arg}: {}", e.reason()));
                let bytes = crate::data::resolve(arg, crate::data::Kind::Map)
                    .and_then(|source| source.read(FileKind::Map))
                    .map_err(failed)?;
                EnvMap::decode(arg, &bytes).map(Environment::Map)
            }
        }
    }

    /// What determines the lighting, for cache keys: `sky`, `white` or `map:<hash of the texels>`
    /// (with `:thesis` appended under the thesis lookup).
    pub fn key(&self) -> String {
        match self {
            Environment::Sky => "sky".into(),
            Environment::White => "white".into(),
            Environment::Map(m) => {
                let key = format!("map:{}x{}:{:016x}", m.width, m.height, m.hash);
                match m.lookup {
                    Lookup::Mitsuba => key,
                    Lookup::Thesis => key + ":thesis",
                }
            }
        }
    }

    /// The same environment with a map looked up by `lookup` (`what` names the option or field
    /// in the error): only maps have lookups, so `thesis` for `sky` or `white` is refused.
    pub fn with_lookup(self, lookup: Lookup, what: &str) -> Result<Self, InputError> {
        match self {
            Environment::Map(m) => Ok(Environment::Map(m.with_lookup(lookup))),
            other if lookup == Lookup::Mitsuba => Ok(other),
            other => Err(InputError::new(format!(
                "{what}: the {} lookup applies to environment map files, not to `{}`",
                lookup.name(),
                other.key()
            ))),
        }
    }

    /// The light's luminance distribution for light sampling (math.md §11), built once: a map's
    /// ([`EnvMap::light`]), the sky's tabulated on a 512×256 lat-long grid (positive everywhere),
    /// the uniform one for `white`.
    pub fn light(&self) -> &LightDistribution {
        static SKY: LazyLock<LightDistribution> = LazyLock::new(|| {
            let grid = light::Grid {
                rows: 256,
                cols: 512,
                psi_start: -PI,
            };
            LightDistribution::tabulate(grid, |d| light::luminance(sky(d)))
        });
        static WHITE: LazyLock<LightDistribution> = LazyLock::new(LightDistribution::uniform);
        match self {
            Environment::Sky => &SKY,
            Environment::White => &WHITE,
            Environment::Map(m) => m.light(),
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

/// How a direction finds its radiance in a lat-long map (math.md §10, "Lookups").
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum Lookup {
    /// Mitsuba 3's `envmap`: bilinear between texel centres (render-scene.md).
    #[default]
    Mitsuba,
    /// The thesis code's: `u = (1 + atan2(d.x, −d.z)/π)/2`, `v = arccos(d.y)/π`, the nearest
    /// texel `(⌊v(H − 1)⌋, ⌊u(W − 1)⌋)`, no interpolation.
    Thesis,
}

impl Lookup {
    pub const ALL: [Lookup; 2] = [Lookup::Mitsuba, Lookup::Thesis];

    /// `mitsuba` or `thesis`.
    pub fn name(self) -> &'static str {
        match self {
            Lookup::Mitsuba => "mitsuba",
            Lookup::Thesis => "thesis",
        }
    }

    /// Parses [`Lookup::name`]; `what` names the option or field in the error.
    pub fn from_name(name: &str, what: &str) -> Result<Self, InputError> {
        Self::ALL.into_iter().find(|l| l.name() == name).ok_or_else(|| {
            InputError::new(format!(
                "{what}: unknown map lookup {name:?}; the lookups are mitsuba, thesis"
            ))
        })
    }
}

/// What identifies a map's texels in cache keys: a splitmix64 chain over the size and every
/// channel's bits.
fn texel_hash(width: usize, height: usize, texels: &[[f32; 3]]) -> u64 {
    texels.iter().flatten().fold(
        crate::util::rng::label_id(&format!("{width}x{height}")),
        |h, v| crate::util::rng::splitmix64(h ^ v.to_bits() as u64),
    )
}

/// An equirectangular map of `W × H` texels (linear RGB), looked up by [`Lookup`].
#[derive(Clone, Debug)]
pub struct EnvMap {
    pub width: usize,
    pub height: usize,
    texels: Vec<[f32; 3]>,
    hash: u64,
    /// How directions find texels ([`Lookup::Mitsuba`] unless chosen).
    lookup: Lookup,
    /// The map's cells under `lookup`, built on first use by the texel sum.
    cells: OnceLock<Arc<CellTable>>,
    /// The map's luminance distribution under `lookup`, built on first use by light sampling.
    light: OnceLock<Arc<LightDistribution>>,
}

impl EnvMap {
    /// Reads a Radiance `.hdr` or OpenEXR map, recognised by content ([`sniff_hdr_format`]);
    /// other formats, unreadable and malformed files are [`InputError`]s naming the file.
    pub fn load(path: &Path) -> Result<Self, InputError> {
        let name = path.display();
        let bytes = crate::files::read::read(path, FileKind::Map)
            .map_err(|e| InputError::new(format!("{name}: {}", e.reason())))?;
        Self::decode(&name.to_string(), &bytes)
    }

    /// [`EnvMap::load`] from the file's bytes; `name` is the map as the user named it.
    pub fn decode(name: &str, bytes: &[u8]) -> Result<Self, InputError> {
        let img = decode_hdr_image(bytes).map_err(|m| {
            InputError::new(format!(
                "{name}: {m}; use `sky`, `white` or an equirectangular .hdr/.exr file"
            ))
        })?;
        let (w, h) = (img.width() as usize, img.height() as usize);
        if w < 1 || h < 2 {
            return Err(InputError::new(format!(
                "{name}: the map is {w}×{h} texels; it needs at least 1×2"
            )));
        }
        let texels: Vec<[f32; 3]> = img.pixels().map(|p| p.0).collect();
        if let Some(k) = texels
            .iter()
            .position(|t| t.iter().any(|v| !v.is_finite() || *v < 0.0))
        {
            return Err(InputError::new(format!(
                "{name}: texel ({}, {}) = {:?} is not a finite radiance >= 0",
                k % w,
                k / w,
                texels[k]
            )));
        }
        Ok(EnvMap {
            width: w,
            height: h,
            hash: texel_hash(w, h, &texels),
            texels,
            lookup: Lookup::Mitsuba,
            cells: OnceLock::new(),
            light: OnceLock::new(),
        })
    }

    /// [`EnvMap::from_texels`] with the hash a decoded file of these texels would have.
    #[cfg(test)]
    fn decode_test(width: usize, height: usize, texels: Vec<[f32; 3]>) -> Self {
        EnvMap {
            hash: texel_hash(width, height, &texels),
            ..Self::from_texels(width, height, texels)
        }
    }

    /// A map from texels in row-major order (row 0 at the zenith).
    pub fn from_texels(width: usize, height: usize, texels: Vec<[f32; 3]>) -> Self {
        assert!(width >= 1 && height >= 2 && texels.len() == width * height);
        EnvMap {
            width,
            height,
            texels,
            hash: 0,
            lookup: Lookup::Mitsuba,
            cells: OnceLock::new(),
            light: OnceLock::new(),
        }
    }

    /// The same map looked up by `lookup`.
    pub fn with_lookup(self, lookup: Lookup) -> Self {
        EnvMap {
            lookup,
            cells: OnceLock::new(),
            light: OnceLock::new(),
            ..self
        }
    }

    /// The same map with every texel channel clamped to at most `max` (finite, > 0): what a
    /// renderer that stores light in a low dynamic range does to a sun (the thesis's Archi map
    /// is clamped at 1.0). The texels change, so does the hash, and with it every cache key.
    pub fn clamped(self, max: f32) -> Self {
        assert!(max.is_finite() && max > 0.0, "a clamp is finite and > 0");
        let texels: Vec<[f32; 3]> = self.texels.iter().map(|t| t.map(|v| v.min(max))).collect();
        EnvMap {
            hash: texel_hash(self.width, self.height, &texels),
            texels,
            cells: OnceLock::new(),
            light: OnceLock::new(),
            ..self
        }
    }

    /// The largest texel channel (the peak radiance, e.g. a sun's).
    pub fn peak(&self) -> f32 {
        self.texels.iter().flatten().fold(0.0, |m, &v| m.max(v))
    }

    /// The FNV-1a hash of the texels and their size (what a decoded file's cache keys carry),
    /// computed afresh: also for a map built from texels, whose stored hash is 0.
    pub fn content_hash(&self) -> u64 {
        texel_hash(self.width, self.height, &self.texels)
    }

    /// How directions find texels.
    pub fn lookup_kind(&self) -> Lookup {
        self.lookup
    }

    /// The map's cells under its lookup (math.md §10), built once and shared by clones made
    /// after that.
    pub fn cells(&self) -> &CellTable {
        self.cells.get_or_init(|| {
            let texel = |r: usize, c: usize| self.texel(r, c);
            Arc::new(match self.lookup {
                Lookup::Mitsuba => CellTable::bilinear(self.width, self.height, texel),
                Lookup::Thesis => CellTable::constant(self.width, self.height, texel),
            })
        })
    }

    /// The map's luminance distribution for light sampling (math.md §11) on the cells of its
    /// lookup (§10): under `thesis` the `(H − 1) × (W − 1)` constant cells with their texel's
    /// luminance (so `p_L ∝ Y` exactly); under `mitsuba` the `(H − 1) × W` bilinear cells with
    /// the mean luminance of their four corner texels (positive wherever the bilinear radiance
    /// is). Built once and shared by clones made after that.
    pub fn light(&self) -> &LightDistribution {
        self.light.get_or_init(|| {
            let y = |r: usize, c: usize| light::luminance(self.texel(r, c).map(f64::from));
            let (w, h) = (self.width, self.height);
            Arc::new(match self.lookup {
                Lookup::Thesis => {
                    let cols = (w - 1).max(1);
                    let values = (0..h - 1)
                        .flat_map(|r| (0..cols).map(move |c| (r, c)))
                        .map(|(r, c)| y(r, c))
                        .collect();
                    let grid = light::Grid {
                        rows: h - 1,
                        cols,
                        psi_start: -PI,
                    };
                    LightDistribution::new(grid, values)
                }
                Lookup::Mitsuba => {
                    let values = (0..h - 1)
                        .flat_map(|r| (0..w).map(move |c| (r, c)))
                        .map(|(r, c)| {
                            let c1 = (c + 1) % w;
                            0.25 * (y(r, c) + y(r, c1) + y(r + 1, c) + y(r + 1, c1))
                        })
                        .collect();
                    let grid = light::Grid {
                        rows: h - 1,
                        cols: w,
                        psi_start: PI / w as f64,
                    };
                    LightDistribution::new(grid, values)
                }
            })
        })
    }

    /// The texel in row `row` (0 at the zenith) and column `col`.
    #[inline]
    pub fn texel(&self, row: usize, col: usize) -> [f32; 3] {
        self.texels[row * self.width + col]
    }

    /// `env(ω)` by the map's [`Lookup`].
    #[inline]
    pub fn lookup(&self, w: &Vec3) -> Rgb {
        match self.lookup {
            Lookup::Mitsuba => self.bilinear(w),
            Lookup::Thesis => self.nearest(w),
        }
    }

    /// The thesis code's lookup: `u = (1 + atan2(ω.x, −ω.z)/π)/2`, `v = arccos(ω.y)/π`, texel
    /// `(⌊v(H − 1)⌋, ⌊u(W − 1)⌋)`.
    pub fn nearest(&self, w: &Vec3) -> Rgb {
        let u = (1.0 + w.x.atan2(-w.z) / PI) / 2.0;
        let v = w.y.clamp(-1.0, 1.0).acos() / PI;
        let col = ((u * (self.width - 1) as f64).floor() as usize).min(self.width - 1);
        let row = ((v * (self.height - 1) as f64).floor() as usize).min(self.height - 1);
        self.texel(row, col).map(f64::from)
    }

    /// Bilinear lookup at `u = frac(atan2(ω.x, −ω.z)/(2π))`, `v = arccos(ω.y)/π`; column
    /// coordinate `u·W − ½` (texel centres, wrapping), row coordinate `v·(H − 1)` (row 0 on the
    /// zenith, row `H − 1` on the nadir).
    pub fn bilinear(&self, w: &Vec3) -> Rgb {
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

/// A file format that holds linear radiance: the formats accepted for environment maps and
/// `--reference` images.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HdrFormat {
    /// Radiance RGBE (`.hdr`, `.pic`), starting with `#?RADIANCE` or `#?RGBE`.
    Radiance,
    /// OpenEXR, starting with the magic number `76 2f 31 01`.
    OpenExr,
}

impl HdrFormat {
    /// `Radiance .hdr` or `OpenEXR`, for messages.
    pub fn name(self) -> &'static str {
        match self {
            HdrFormat::Radiance => "Radiance .hdr",
            HdrFormat::OpenExr => "OpenEXR",
        }
    }
}

/// A file in none of the [`HdrFormat`]s. `found` says what it is instead: `a PNG image`,
/// `empty`, `of an unknown format (starting with bytes 00 01 02 03)`, ….
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct UnsupportedFormat {
    pub found: String,
}

impl std::fmt::Display for UnsupportedFormat {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "the file is {}, not a Radiance .hdr or OpenEXR image (recognised by content, not by name)",
            self.found
        )
    }
}

/// The format of an image file from its first bytes, never from its name: an 8-bit picture
/// (PNG, JPEG) renamed `.hdr`, or decoded because the decoder accepts it, would be taken as
/// linear radiance and silently give wrong results.
pub fn sniff_hdr_format(bytes: &[u8]) -> Result<HdrFormat, UnsupportedFormat> {
    if bytes.starts_with(b"#?RADIANCE") || bytes.starts_with(b"#?RGBE") {
        return Ok(HdrFormat::Radiance);
    }
    if bytes.starts_with(&[0x76, 0x2f, 0x31, 0x01]) {
        return Ok(HdrFormat::OpenExr);
    }
    let found = |s: &str| Err(UnsupportedFormat { found: s.into() });
    let known: &[(&[u8], &str)] = &[
        (b"\x89PNG\r\n\x1a\n", "a PNG image"),
        (b"\xff\xd8\xff", "a JPEG image"),
        (b"GIF87a", "a GIF image"),
        (b"GIF89a", "a GIF image"),
        (b"II*\0", "a TIFF image"),
        (b"MM\0*", "a TIFF image"),
        (b"\xff\x0a", "a JPEG XL image"),
        (b"\0\0\0\x0cJXL \r\n\x87\n", "a JPEG XL image"),
        (b"qoif", "a QOI image"),
        (b"farbfeld", "a farbfeld image"),
        (b"DDS ", "a DDS texture"),
        (b"8BPS", "a Photoshop image"),
        (b"PF\n", "a PFM image"),
        (b"Pf\n", "a PFM image"),
        (b"\0\0\x01\0", "an ICO image"),
        (b"%PDF", "a PDF document"),
        (b"PK\x03\x04", "a ZIP archive"),
        (b"\x1f\x8b", "a gzip archive"),
        (b"BM", "a BMP image"),
    ];
    if let Some((_, name)) = known.iter().find(|(magic, _)| bytes.starts_with(magic)) {
        return found(name);
    }
    if bytes.len() >= 12 && &bytes[..4] == b"RIFF" && &bytes[8..12] == b"WEBP" {
        return found("a WebP image");
    }
    if bytes.len() >= 12 && &bytes[4..8] == b"ftyp" {
        return found(match &bytes[8..12] {
            b"avif" | b"avis" => "an AVIF image",
            b"heic" | b"heix" | b"mif1" | b"msf1" => "a HEIF image",
            _ => "an ISO media file (MP4, MOV, …)",
        });
    }
    // Netpbm: `P1` … `P7` and a whitespace byte.
    if bytes.len() >= 3
        && bytes[0] == b'P'
        && (b'1'..=b'7').contains(&bytes[1])
        && bytes[2].is_ascii_whitespace()
    {
        return found("a Netpbm (PBM/PGM/PPM/PAM) image");
    }
    if bytes.is_empty() {
        return found("empty");
    }
    let head = &bytes[..bytes.len().min(64)];
    if head
        .iter()
        .all(|&b| b.is_ascii_graphic() || b.is_ascii_whitespace())
    {
        return found("text");
    }
    let first: Vec<String> = bytes.iter().take(4).map(|b| format!("{b:02x}")).collect();
    Err(UnsupportedFormat {
        found: format!("of an unknown format (starting with bytes {})", first.join(" ")),
    })
}

/// Decodes a Radiance `.hdr` or OpenEXR image (recognised by [`sniff_hdr_format`]) to linear
/// RGB. Errors (without the file name, which the caller adds) say what the file is instead, or
/// why it is not a valid image of its format.
pub fn decode_hdr_image(bytes: &[u8]) -> Result<::image::Rgb32FImage, String> {
    let format = sniff_hdr_format(bytes).map_err(|e| e.to_string())?;
    let decoded = match format {
        // The decoder checks for `#?RADIANCE`; `#?RGBE` files (the other signature writers
        // use) are the same format, so they are decoded with the signature replaced.
        HdrFormat::Radiance if bytes.starts_with(b"#?RGBE") => {
            let mut renamed = b"#?RADIANCE".to_vec();
            renamed.extend_from_slice(&bytes[b"#?RGBE".len()..]);
            decode_as(&renamed, ::image::ImageFormat::Hdr)
        }
        HdrFormat::Radiance => decode_as(bytes, ::image::ImageFormat::Hdr),
        HdrFormat::OpenExr => decode_as(bytes, ::image::ImageFormat::OpenExr),
    };
    decoded.map_err(|e| match e {
        ::image::ImageError::Limits(_) => format!(
            "not a valid {} image: it declares more than the decoder's limits ({MAX_IMAGE_SIDE} texels a side, {} decoded)",
            format.name(),
            crate::files::read::bytes(MAX_DECODE_BYTES)
        ),
        e => format!("not a valid {} image ({e})", format.name()),
    })
}

/// Largest width or height of a decoded image (a 32768 × 16384 lat-long map).
pub const MAX_IMAGE_SIDE: u32 = 32768;
/// Most the image decoder may allocate: a 16384 × 8192 RGBA float image is 2 GiB. A header
/// that declares more (10⁶ × 10⁶ texels in a few bytes) is refused before anything is allocated.
pub const MAX_DECODE_BYTES: u64 = 2 << 30;

fn decode_as(bytes: &[u8], format: ::image::ImageFormat) -> ::image::ImageResult<::image::Rgb32FImage> {
    let mut limits = ::image::Limits::default();
    limits.max_image_width = Some(MAX_IMAGE_SIDE);
    limits.max_image_height = Some(MAX_IMAGE_SIDE);
    limits.max_alloc = Some(MAX_DECODE_BYTES);
    let mut reader = ::image::ImageReader::with_format(std::io::Cursor::new(bytes), format);
    reader.limits(limits);
    reader.decode().map(|img| img.into_rgb32f())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A clamp caps every channel (a sun) and leaves the rest; the texels change, so does the
    /// cache key; a clamp above the peak changes nothing, key included.
    #[test]
    fn a_clamp_caps_the_peak_and_changes_the_key_only_when_it_bites() {
        let texels = vec![
            [0.5, 2.0, 1e5],
            [0.25, 0.25, 0.25],
            [3.0, 0.1, 0.2],
            [1.0, 1.0, 1.0],
        ];
        let map = EnvMap::decode_test(2, 2, texels.clone());
        let clamped = map.clone().clamped(1.0);
        assert_eq!(clamped.texel(0, 0), [0.5, 1.0, 1.0]);
        assert_eq!(clamped.texel(0, 1), [0.25, 0.25, 0.25]);
        assert_eq!(clamped.texel(1, 0), [1.0, 0.1, 0.2]);
        assert_eq!(clamped.peak(), 1.0);
        assert_eq!(map.peak(), 1e5);
        let key = |m: &EnvMap| Environment::Map(m.clone()).key();
        assert_ne!(key(&map), key(&clamped));
        assert_eq!(key(&map), key(&map.clone().clamped(1e6)));
    }

    /// Formats are told apart by their first bytes, whatever the file is called.
    #[test]
    fn formats_are_sniffed_from_content() {
        assert_eq!(sniff_hdr_format(b"#?RADIANCE\n"), Ok(HdrFormat::Radiance));
        assert_eq!(sniff_hdr_format(b"#?RGBE\n"), Ok(HdrFormat::Radiance));
        assert_eq!(
            sniff_hdr_format(&[0x76, 0x2f, 0x31, 0x01, 2]),
            Ok(HdrFormat::OpenExr)
        );
        let found = |bytes: &[u8]| sniff_hdr_format(bytes).unwrap_err().found;
        assert_eq!(found(b"\x89PNG\r\n\x1a\n\0\0"), "a PNG image");
        assert_eq!(found(b"\xff\xd8\xff\xe0\0\x10JFIF"), "a JPEG image");
        assert_eq!(found(b"RIFF\0\0\0\0WEBPVP8 "), "a WebP image");
        assert_eq!(found(b"P6\n4 4\n255\n"), "a Netpbm (PBM/PGM/PPM/PAM) image");
        assert_eq!(found(b"PF\n4 4\n-1\n"), "a PFM image");
        assert_eq!(found(b"{\"name\": \"x\"}"), "text");
        assert_eq!(found(b""), "empty");
        // `#?` alone is not enough: only the two Radiance signatures are.
        assert_eq!(found(b"#?XYZE\n"), "text");
        assert_eq!(
            found(&[0, 1, 2, 3, 0xfe]),
            "of an unknown format (starting with bytes 00 01 02 03)"
        );
        assert_eq!(
            UnsupportedFormat {
                found: "a PNG image".into()
            }
            .to_string(),
            "the file is a PNG image, not a Radiance .hdr or OpenEXR image (recognised by content, not by name)"
        );
    }

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

    /// The thesis lookup takes texel `(⌊v(H − 1)⌋, ⌊u(W − 1)⌋)`: cell centres of the
    /// `(H − 1) × (W − 1)` grid give their own texel, with no interpolation.
    #[test]
    fn thesis_lookup_takes_the_nearest_texel_below() {
        let (w, h) = (5, 4);
        let texels = (0..w * h).map(|k| [k as f32, 0.0, 0.0]).collect();
        let m = EnvMap::from_texels(w, h, texels).with_lookup(Lookup::Thesis);
        for row in 0..h - 1 {
            for col in 0..w - 1 {
                // Cell centre: θ = (row + ½)π/(H − 1), ψ = −π + 2π(col + ½)/(W − 1), where
                // ψ = atan2(d.x, −d.z): d = (sin θ sin ψ, cos θ, −sin θ cos ψ).
                let theta = (row as f64 + 0.5) * PI / (h - 1) as f64;
                let psi = -PI + TAU * (col as f64 + 0.5) / (w - 1) as f64;
                let d = Vec3::new(theta.sin() * psi.sin(), theta.cos(), -theta.sin() * psi.cos());
                assert_eq!(m.lookup(&d)[0], (row * w + col) as f64, "cell ({row}, {col})");
            }
        }
        // Row H − 1 and column W − 1 are reached on the boundary only: behind the camera
        // (ψ = atan2(0, −1) = π, u = 1) at the horizon (v = ½, row ⌊1.5⌋ = 1) is texel (1, 4);
        // the nadir (v = 1; ψ = atan2(0, −0) = π) is texel (3, 4).
        assert_eq!(m.lookup(&Vec3::new(0.0, 0.0, 1.0))[0], 9.0);
        assert_eq!(m.lookup(&Vec3::new(0.0, -1.0, 0.0))[0], 19.0);
    }
}
