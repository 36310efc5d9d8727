//! Real light as an integrand (math.md §1 "Scene integrands", §10): a lat-long map seen from an
//! unoccluded surface with world normal `n`, one channel, in the local frame the estimators
//! sample (`+z` the normal):
//!
//! `f(ω) = L_c(d) · f_r(ω) · ω_z`, `d = t ω_x + b ω_y + n ω_z`,
//!
//! `(t, b, n)` the renderer's frame about `n` ([`Frame::from_normal`]: Duff et al. 2017), `L_c` the
//! map under its lookup (`mitsuba` by default, or `thesis`) in channel `c` (`r`, `g`, `b`, or
//! `luminance` = `0.2126 r + 0.7152 g + 0.0722 b`, Rec. 709: linear, so the texel sum applies),
//! and the BRDF
//!
//! - `lambert`: `f_r = 1/π` (albedo 1), so `I = E(n) = (1/π) ∫ L max(0, n·d) dω`, the irradiance
//!   of math.md §10 (a constant map `L` gives `I = L`);
//! - `{"phong": e, "axis": a}`: `f_r = ((e + 1)/(2π)) max(0, ω·a)^e`, `a` in the local frame like
//!   the lobe family's axis (normalised; `e > 0`): the lobe integrates to 1 over the sphere.
//!
//! **Truth.** The texel sum of [`crate::render::texel`]: for `lambert` [`texel::irradiance`]
//! (exact in azimuth, adaptive Gauss–Kronrod in the polar angle), for Phong [`texel::lobe::phong`]
//! (the same outer rule, Chebyshev panels of the lobe in azimuth integrated against the map's
//! cells in closed form); both per channel, combined with the
//! channel's weights, to the absolute tolerance [`TRUTH_TOLERANCE`] times the map's mean texel
//! value, with the quadrature's error estimate kept beside the truth (the manifest's
//! `truth_error_estimate`). A map is read once per process and per lookup (its cell table, the
//! prefix sums, is built once and shared by every integrand under it).

use super::lit::Lit;
use crate::render::env::{Environment, Lookup};
use crate::render::texel;
use crate::sampling::bsdf::BsdfSampler;
use crate::sampling::light::LightDistribution;
use crate::util::geometry::{Frame, Vec3};
use crate::util::shown::shown;
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use std::collections::HashMap;
use std::f64::consts::{FRAC_1_PI, TAU};
use std::sync::{Arc, LazyLock, Mutex};

/// The truth's absolute tolerance per channel, in units of the map's mean texel value (a map of
/// mean 1 gives truths to 1e-9).
pub const TRUTH_TOLERANCE: f64 = 1e-9;

/// Largest Phong exponent accepted, the lobe family's own limit. The certified truth
/// ([`texel::lobe::phong`]) stays under a second per normal up to it (about 0.02 s on Pisa
/// 1024×512 at e = 10⁴ … 10⁶, at most about 0.6 s for lobes broader than a cosine, e < 1:
/// `cargo bench --bench exact -- phong`, docs/guide/real-light.md); past about 10⁴ its stated
/// error carries the weights' own rounding, `(a·d)^e` evaluated to a relative `~(e + 1) ε_mach`
/// (10⁻⁹ of the truth at e = 10⁶).
pub const MAX_EXPONENT: f64 = 1e6;

/// The channels, as files spell them.
pub const CHANNELS: [&str; 4] = ["r", "g", "b", "luminance"];

/// Rec. 709 luminance weights of linear RGB.
pub const LUMINANCE: [f64; 3] = crate::sampling::light::LUMINANCE;

/// The BRDF of an `envmap` integrand.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Brdf {
    /// `1/π`.
    Lambert,
    /// `((e + 1)/(2π)) max(0, ω·a)^e`, `a` a unit vector in the local frame.
    Phong { exponent: f64, axis: Vec3 },
}

/// One channel's weights of linear RGB: `r`, `g`, `b` or Rec. 709 `luminance`.
pub fn channel_weights(channel: &str) -> Option<[f64; 3]> {
    match channel {
        "r" => Some([1.0, 0.0, 0.0]),
        "g" => Some([0.0, 1.0, 0.0]),
        "b" => Some([0.0, 0.0, 1.0]),
        "luminance" => Some(LUMINANCE),
        _ => None,
    }
}

/// A map under a surface with one normal, one BRDF and one channel, with its truth.
#[derive(Clone, Debug)]
pub struct EnvmapIntegrand {
    /// The map as given (`pisa`, or a path).
    pub env_name: String,
    /// The unit world normal.
    pub normal: Vec3,
    pub brdf: Brdf,
    pub lookup: Lookup,
    /// `r`, `g`, `b` or `luminance`.
    pub channel: String,
    weights: [f64; 3],
    frame: Frame,
    env: Arc<Environment>,
    truth: f64,
    truth_error: f64,
}

impl PartialEq for EnvmapIntegrand {
    /// Equal when defined alike (the map by its texels and lookup).
    fn eq(&self, other: &Self) -> bool {
        self.env.key() == other.env.key()
            && self.normal == other.normal
            && self.brdf == other.brdf
            && self.channel == other.channel
    }
}

/// Maps read in this process, by `(name as given, lookup)`.
type MapCache = HashMap<(String, Lookup), Arc<Environment>>;
static MAPS: LazyLock<Mutex<MapCache>> = LazyLock::new(|| Mutex::new(HashMap::new()));

/// The map named `env` (a catalogue name, checked against its sha256, or a `.hdr`/`.exr` path)
/// under `lookup`, read once per process. Errors name the field `env`.
pub fn load_map(env: &str, lookup: Lookup) -> Result<Arc<Environment>, String> {
    let key = (env.to_string(), lookup);
    if let Some(e) = MAPS.lock().expect("map cache").get(&key) {
        return Ok(e.clone());
    }
    let environment = Environment::from_arg(env).map_err(|e| format!("env: {}", e.0))?;
    if !matches!(environment, Environment::Map(_)) {
        return Err(format!(
            "env: the envmap family needs a map (a catalogue name such as \"pisa\" or a .hdr/.exr file), got {env:?}"
        ));
    }
    let environment = Arc::new(
        environment
            .with_lookup(lookup, "lookup")
            .map_err(|e| e.0.to_string())?,
    );
    if let Environment::Map(m) = environment.as_ref() {
        // Built here, once, rather than inside the first truth.
        m.cells();
    }
    MAPS.lock().expect("map cache").insert(key, environment.clone());
    Ok(environment)
}

/// `[x, y, z]` normalised, or an error naming `field`.
fn unit(field: &str, v: [f64; 3]) -> Result<Vec3, String> {
    let w = Vec3::new(v[0], v[1], v[2]);
    let norm = w.norm();
    if !(norm.is_finite() && norm > 1e-12) {
        return Err(format!(
            "{field}: must be a non-zero finite vector, got [{}, {}, {}]",
            shown(v[0]),
            shown(v[1]),
            shown(v[2])
        ));
    }
    Ok(w / norm)
}

impl EnvmapIntegrand {
    /// Validates everything (errors name the JSON field: `normal`, `brdf`, `lookup`, `channel`,
    /// `env`), reads the map (once per process) and computes the truth.
    pub fn new(env: &str, normal: [f64; 3], brdf: Brdf, lookup: &str, channel: &str) -> Result<Self, String> {
        let normal = unit("normal", normal)?;
        let brdf = match brdf {
            Brdf::Lambert => Brdf::Lambert,
            Brdf::Phong { exponent, axis } => {
                if !(exponent.is_finite() && exponent > 0.0 && exponent <= MAX_EXPONENT) {
                    return Err(format!(
                        "brdf.phong: the exponent must be in (0, 1e6], got {}",
                        shown(exponent)
                    ));
                }
                let axis = unit("brdf.axis", [axis.x, axis.y, axis.z])?;
                Brdf::Phong { exponent, axis }
            }
        };
        let lookup = Lookup::from_name(lookup, "lookup").map_err(|e| e.0.to_string())?;
        let weights = channel_weights(channel).ok_or_else(|| {
            format!("channel: must be \"r\", \"g\", \"b\" or \"luminance\", got {channel:?}")
        })?;
        let env_arc = load_map(env, lookup)?;
        let frame = Frame::from_normal(normal);
        let (truth, truth_error) = {
            let Environment::Map(m) = env_arc.as_ref() else {
                unreachable!("load_map returns maps only")
            };
            let tol = TRUTH_TOLERANCE * mean_texel(m).max(f64::MIN_POSITIVE);
            let q = match brdf {
                Brdf::Lambert => texel::irradiance(normal, &env_arc, m, tol),
                Brdf::Phong { exponent, axis } => {
                    texel::lobe::phong(normal, frame.to_world(&axis), exponent, m, tol)
                }
            };
            if q.work_limited {
                return Err(format!(
                    "env: the truth's quadrature stopped at its work limit ({} nodes) with error estimate {} \
                     (tolerance {}); a map this extreme needs a larger tolerance than the family's",
                    texel::MAX_NODES,
                    shown(q.error),
                    shown(tol)
                ));
            }
            let truth: f64 = (0..3).map(|c| weights[c] * q.value[c]).sum();
            // The error is per channel; the weights of a channel add up to ≤ 1.
            (truth, q.error * weights.iter().sum::<f64>())
        };
        Ok(EnvmapIntegrand {
            env_name: env.to_string(),
            normal,
            brdf,
            lookup,
            channel: channel.to_string(),
            weights,
            frame,
            env: env_arc,
            truth,
            truth_error,
        })
    }

    /// `f(ω)` at the local direction `w` (normal `+z`): `L_c f_r ω_z` ([`Lit::integrand`]).
    #[inline]
    pub fn value(&self, w: &Vec3) -> f64 {
        self.integrand(w)
    }

    /// `I = ∫_H f dω` by the texel sum.
    pub fn integral(&self) -> f64 {
        self.truth
    }

    /// The texel sum's estimated absolute error of [`EnvmapIntegrand::integral`].
    pub fn integral_error(&self) -> f64 {
        self.truth_error
    }

    /// The map's name for file names: a catalogue name as is, a path's file stem, with any
    /// character outside `[A-Za-z0-9_.-]` replaced by `_`.
    fn env_stem(&self) -> String {
        let stem = std::path::Path::new(&self.env_name)
            .file_stem()
            .map(|s| s.to_string_lossy().to_string())
            .unwrap_or_else(|| self.env_name.clone());
        stem.chars()
            .map(|c| {
                if c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.') {
                    c
                } else {
                    '_'
                }
            })
            .collect()
    }

    /// The normal's polar angle from the map's `+y` and its azimuth `ψ = atan2(n.x, −n.z)`,
    /// in degrees to a tenth.
    fn angles(&self) -> (String, String) {
        let t = self.normal.y.clamp(-1.0, 1.0).acos().to_degrees();
        let p = self.normal.x.atan2(-self.normal.z).to_degrees();
        let fmt = |x: f64| {
            let s = format!("{x:.1}");
            let s = s.strip_suffix(".0").map(str::to_string).unwrap_or(s);
            if s == "-0" { "0".to_string() } else { s }
        };
        (fmt(t), fmt(p))
    }

    fn brdf_name(&self) -> String {
        match self.brdf {
            Brdf::Lambert => "lambert".into(),
            // Short, as in messages: `phong1e-300`, not 300 digits in a file name (issue 42).
            Brdf::Phong { exponent, .. } => format!("phong{}", shown(exponent)),
        }
    }

    /// `envmap-pisa-lambert-theta30-psi45-luminance`: the map, the BRDF, the normal's angles in
    /// the map (polar from `+y`, azimuth `ψ`), the channel (`-thesis` appended under that lookup).
    pub fn default_name(&self) -> String {
        let (t, p) = self.angles();
        format!(
            "envmap-{}-{}-theta{t}-psi{p}-{}{}",
            self.env_stem(),
            self.brdf_name(),
            self.channel,
            if self.lookup == Lookup::Thesis {
                "-thesis"
            } else {
                ""
            }
        )
    }

    /// `pisa seen by a Lambertian surface, normal θ 30°, ψ 45°, luminance`.
    pub fn display_name(&self) -> String {
        let (t, p) = self.angles();
        let brdf = match self.brdf {
            Brdf::Lambert => "a Lambertian surface".to_string(),
            Brdf::Phong { exponent, axis } => format!(
                "a Phong lobe e = {}, tilt {:.0}°",
                shown(exponent),
                axis.z.clamp(-1.0, 1.0).acos().to_degrees()
            ),
        };
        format!(
            "{} seen by {brdf}, normal θ {t}°, ψ {p}°, {}",
            self.env_name, self.channel
        )
    }
}

/// The map is the light, the BRDF the integrand's, and nothing occludes (`V = 1`).
impl Lit for EnvmapIntegrand {
    #[inline]
    fn radiance(&self, w: &Vec3) -> f64 {
        let l = self.env.radiance(&self.frame.to_world(w));
        self.weights[0] * l[0] + self.weights[1] * l[1] + self.weights[2] * l[2]
    }

    #[inline]
    fn brdf(&self, w: &Vec3) -> f64 {
        match self.brdf {
            Brdf::Lambert => FRAC_1_PI,
            Brdf::Phong { exponent, axis } => {
                let c = w.dot(&axis);
                if c <= 0.0 {
                    return 0.0;
                }
                (exponent + 1.0) / TAU * c.powf(exponent)
            }
        }
    }

    #[inline]
    fn visibility(&self, _: &Vec3) -> f64 {
        1.0
    }

    fn light(&self) -> &LightDistribution {
        self.env.light()
    }

    fn frame(&self) -> &Frame {
        &self.frame
    }

    /// Cosine for Lambert, the lobe itself for Phong.
    fn bsdf_sampler(&self) -> BsdfSampler {
        match self.brdf {
            Brdf::Lambert => BsdfSampler::Cosine,
            Brdf::Phong { exponent, axis } => BsdfSampler::Phong { exponent, axis },
        }
    }
}

/// The mean of all texel values over the three channels.
fn mean_texel(m: &crate::render::env::EnvMap) -> f64 {
    let mut sum = 0.0;
    for r in 0..m.height {
        for c in 0..m.width {
            sum += m.texel(r, c).iter().map(|&v| v as f64).sum::<f64>();
        }
    }
    sum / (3 * m.width * m.height) as f64
}

/// The `"brdf"` of an `envmap` integrand as written: `"lambert"` or `{"phong": e, "axis": [x, y, z]}`.
#[derive(Debug, Clone, PartialEq, Serialize, JsonSchema)]
#[serde(untagged)]
pub enum BrdfSpec {
    /// `"lambert"`.
    Named(String),
    /// A normalised Phong lobe about `axis` (local frame, normal `+z`).
    Phong(PhongSpec),
}

/// `{"phong": e, "axis": [x, y, z]}`.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct PhongSpec {
    /// The exponent `e > 0`.
    pub phong: f64,
    /// The lobe's axis in the local frame (normal `+z`).
    pub axis: [f64; 3],
}

impl Default for BrdfSpec {
    fn default() -> Self {
        BrdfSpec::Named("lambert".into())
    }
}

impl<'de> Deserialize<'de> for BrdfSpec {
    /// By hand rather than `untagged`, whose error hides what is accepted.
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        use serde::de::Error;
        match serde_json::Value::deserialize(d)? {
            serde_json::Value::String(name) => Ok(BrdfSpec::Named(name)),
            // The path inside (`axis[1]`) continues the field's own (`brdf`), which the reader
            // of the integrand adds.
            v @ serde_json::Value::Object(_) => crate::files::spec_json::from_value(v)
                .map(BrdfSpec::Phong)
                .map_err(D::Error::custom),
            other => Err(D::Error::custom(format!(
                "expected \"lambert\" or {{\"phong\": e, \"axis\": [x, y, z]}}, got {other}"
            ))),
        }
    }
}

impl BrdfSpec {
    /// The BRDF, or an error naming the field `brdf`.
    pub fn resolve(&self) -> Result<Brdf, String> {
        match self {
            BrdfSpec::Named(n) if n == "lambert" => Ok(Brdf::Lambert),
            BrdfSpec::Named(n) => Err(format!(
                "brdf: unknown BRDF {n:?}; expected \"lambert\" or {{\"phong\": e, \"axis\": [x, y, z]}}"
            )),
            BrdfSpec::Phong(p) => Ok(Brdf::Phong {
                exponent: p.phong,
                axis: Vec3::new(p.axis[0], p.axis[1], p.axis[2]),
            }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::image::Image;
    use std::f64::consts::PI;

    /// Writes a `w × h` map (row 0 at the zenith) as OpenEXR in `dir`; returns its path.
    fn map_file(
        dir: &std::path::Path,
        name: &str,
        w: usize,
        h: usize,
        texel: impl Fn(usize, usize) -> [f64; 3],
    ) -> String {
        let data = (0..h)
            .flat_map(|r| (0..w).map(move |c| (r, c)))
            .map(|(r, c)| texel(r, c))
            .collect();
        let path = dir.join(format!("{name}.exr"));
        std::fs::write(
            &path,
            Image {
                width: w,
                height: h,
                data,
            }
            .to_exr()
            .unwrap(),
        )
        .unwrap();
        path.display().to_string()
    }

    fn unit3(v: [f64; 3]) -> [f64; 3] {
        let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        v.map(|x| x / n)
    }

    const NORMALS: [[f64; 3]; 5] = [
        [0.0, 1.0, 0.0],
        [0.0, -1.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.3, 0.5, -0.8],
        [-0.7, -0.2, 0.4],
    ];

    /// A constant map `L`: Lambert gives `E = L` (f_r = 1/π, albedo 1) for every normal, both
    /// lookups and every channel; a Phong lobe about the normal gives `L (e + 1)/(e + 2)`.
    #[test]
    fn constant_map_closed_forms() {
        let dir = tempfile::tempdir().unwrap();
        let l = [0.5, 1.0, 2.0];
        let path = map_file(dir.path(), "constant", 8, 5, |_, _| l);
        for lookup in ["mitsuba", "thesis"] {
            for (ch, weights) in CHANNELS.iter().map(|c| (c, channel_weights(c).unwrap())) {
                let want: f64 = (0..3).map(|k| weights[k] * l[k]).sum();
                for n in NORMALS {
                    let f = EnvmapIntegrand::new(&path, n, Brdf::Lambert, lookup, ch).unwrap();
                    assert!(
                        (f.integral() - want).abs() < 1e-9,
                        "{lookup} {ch} {n:?}: {}",
                        f.integral()
                    );
                    assert!(f.integral_error() < 1e-8);
                    for e in [1.0, 8.0, 100.0] {
                        let brdf = Brdf::Phong {
                            exponent: e,
                            axis: Vec3::z(),
                        };
                        let f = EnvmapIntegrand::new(&path, n, brdf, lookup, ch).unwrap();
                        let want = want * (e + 1.0) / (e + 2.0);
                        assert!(
                            (f.integral() - want).abs() < 1e-9,
                            "phong {e} {lookup} {ch} {n:?}: {} vs {want}",
                            f.integral()
                        );
                    }
                }
            }
        }
    }

    /// Half-black (thesis lookup, 2 above the horizon, 0 below): a surface tilted `α` from `+y`
    /// sees `E = 2 (1 + cos α)/2`.
    #[test]
    fn half_black_map_closed_form() {
        let dir = tempfile::tempdir().unwrap();
        // H = 5: cell rows θ ∈ [kπ/4, (k + 1)π/4); rows 0 and 1 lit.
        let path = map_file(
            dir.path(),
            "half",
            9,
            5,
            |r, _| if r < 2 { [2.0; 3] } else { [0.0; 3] },
        );
        for n in NORMALS {
            let n = unit3(n);
            let f = EnvmapIntegrand::new(&path, n, Brdf::Lambert, "thesis", "g").unwrap();
            let want = 2.0 * (1.0 + n[1]) / 2.0;
            assert!(
                (f.integral() - want).abs() < 1e-9,
                "{n:?}: {} vs {want}",
                f.integral()
            );
        }
    }

    /// One bright texel (thesis lookup: one cell `θ ∈ [θ₀, θ₁)`, `ψ ∈ [ψ₀, ψ₁)`) seen from `+y`:
    /// `E = (1/π) Δψ (sin²θ₁ − sin²θ₀)/2`; seen from a normal whose hemisphere misses it, 0.
    #[test]
    fn single_bright_texel_closed_form() {
        let dir = tempfile::tempdir().unwrap();
        let (w, h) = (9, 7);
        let (row, col) = (1, 3);
        let path = map_file(dir.path(), "texel", w, h, |r, c| {
            if (r, c) == (row, col) {
                [100.0; 3]
            } else {
                [0.0; 3]
            }
        });
        let (t0, t1) = (
            row as f64 * PI / (h - 1) as f64,
            (row + 1) as f64 * PI / (h - 1) as f64,
        );
        let dpsi = TAU / (w - 1) as f64;
        let want = 100.0 / PI * dpsi * (t1.sin().powi(2) - t0.sin().powi(2)) / 2.0;
        let f = EnvmapIntegrand::new(&path, [0.0, 1.0, 0.0], Brdf::Lambert, "thesis", "r").unwrap();
        assert!(
            (f.integral() - want).abs() < 1e-9 * want,
            "{} vs {want}",
            f.integral()
        );
        let f = EnvmapIntegrand::new(&path, [0.0, -1.0, 0.0], Brdf::Lambert, "thesis", "r").unwrap();
        assert_eq!(f.integral(), 0.0);
    }

    /// The truth against brute force on the integrand the estimators see: a midpoint rule in the
    /// local `(cos θ, φ)` (error O(h²) at the cells' kinks and jumps: 2·10⁻⁴ relative allowed), on
    /// a map of varied texels, both lookups, Lambert and Phong.
    #[test]
    fn truth_matches_brute_force_over_the_local_hemisphere() {
        let dir = tempfile::tempdir().unwrap();
        let path = map_file(dir.path(), "varied", 12, 6, |r, c| {
            [
                1.0 + ((r * 7 + c * 3) % 5) as f64,
                0.5 + (c % 4) as f64,
                (r + c) as f64 * 0.1,
            ]
        });
        let m = 1200;
        for lookup in ["mitsuba", "thesis"] {
            for brdf in [
                Brdf::Lambert,
                Brdf::Phong {
                    exponent: 6.0,
                    axis: Vec3::new(0.4, 0.1, 0.9),
                },
            ] {
                for n in [[0.3, 0.5, -0.8], [-0.7, -0.2, 0.4]] {
                    let f = EnvmapIntegrand::new(&path, n, brdf, lookup, "luminance").unwrap();
                    let mut sum = 0.0;
                    for i in 0..m {
                        let mu = (i as f64 + 0.5) / m as f64;
                        let s = (1.0 - mu * mu).sqrt();
                        for j in 0..2 * m {
                            let phi = (j as f64 + 0.5) * PI / m as f64;
                            sum += f.value(&Vec3::new(s * phi.cos(), s * phi.sin(), mu));
                        }
                    }
                    let brute = sum * (1.0 / m as f64) * (PI / m as f64);
                    assert!(
                        (brute - f.integral()).abs() < 2e-4 * f.integral(),
                        "{lookup} {brdf:?} {n:?}: brute {brute} vs {}",
                        f.integral()
                    );
                }
            }
        }
    }

    /// Bad input names the field: a zero normal, a Phong exponent ≤ 0 or not finite, a zero axis,
    /// an unknown lookup, channel or BRDF, a missing map, `sky` (not a map).
    #[test]
    fn bad_input_names_the_field() {
        let dir = tempfile::tempdir().unwrap();
        let path = map_file(dir.path(), "c", 4, 3, |_, _| [1.0; 3]);
        let err = |n: [f64; 3], brdf: Brdf, lookup: &str, ch: &str| {
            EnvmapIntegrand::new(&path, n, brdf, lookup, ch).unwrap_err()
        };
        let up = [0.0, 1.0, 0.0];
        assert!(err([0.0; 3], Brdf::Lambert, "mitsuba", "r").starts_with("normal: "));
        for e in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            let m = err(
                up,
                Brdf::Phong {
                    exponent: e,
                    axis: Vec3::z(),
                },
                "mitsuba",
                "r",
            );
            assert!(m.starts_with("brdf.phong: the exponent"), "{m}");
        }
        let m = err(
            up,
            Brdf::Phong {
                exponent: 2.0,
                axis: Vec3::zeros(),
            },
            "mitsuba",
            "r",
        );
        assert!(m.starts_with("brdf.axis: "), "{m}");
        assert!(err(up, Brdf::Lambert, "nearest", "r").starts_with("lookup: "));
        assert!(err(up, Brdf::Lambert, "mitsuba", "alpha").starts_with("channel: "));
        let m = BrdfSpec::Named("glass".into()).resolve().unwrap_err();
        assert!(m.starts_with("brdf: unknown BRDF \"glass\""), "{m}");
        let m = EnvmapIntegrand::new(
            &dir.path().join("none.exr").display().to_string(),
            up,
            Brdf::Lambert,
            "mitsuba",
            "r",
        )
        .unwrap_err();
        assert!(m.starts_with("env: "), "{m}");
        let m = EnvmapIntegrand::new("sky", up, Brdf::Lambert, "mitsuba", "r").unwrap_err();
        assert!(m.starts_with("env: the envmap family needs a map"), "{m}");
    }
}
