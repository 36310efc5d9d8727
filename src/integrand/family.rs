//! Rendering-like integrands about a tilted axis (math.md §1, "Rendering-like integrands"):
//!
//! | family | `f(ω)` on `H` | parameter |
//! |---|---|---|
//! | lobe (Phong) | `max(0, ω·a)^e · (ω·n)^m` | exponent `e ≥ 0` |
//! | cap (a disc light; `α = 90°`: an occluded cosine) | `1[ω·a ≥ cos α] · (ω·n)^m` | half-angle `α ∈ (0°, 180°]` |
//! | gaussian (spherical Gaussian) | `exp(λ (ω·a − 1)) · (ω·n)^m` | sharpness `λ > 0` |
//!
//! with `a` a unit axis at polar angle `θa` from the normal `n = +z` and `m ∈ {0, 1}`.
//!
//! **Truth.** Each is `g(ω·a) (ω·n)^m`, so with `t = ω·a` and the circle `{ω·a = t}`
//! parametrised by its azimuth about `a` (`dω = dt dφ`),
//! `I = ∫_{−1}^{1} g(t) A_m(t) dt`, `A_0 = Φ`, `A_1 = t cos θa Φ + 2 √(1 − t²) sin θa sin(Φ/2)`,
//! where `Φ(t) = 2 arccos(clamp(−t cos θa / (sin θa √(1 − t²)), −1, 1))` is the measure of the
//! part of the circle in `H` (the arc function of math.md §4). We integrate in the angle
//! `γ = arccos t`, where `√(1 − t²) = sin γ` and `Φ` comes without cancellation:
//! with `h∓ = (1 ∓ r)/2`, `r` the clamped ratio, `h− = cos(γ − θa) / (2 sin θa sin γ)` and
//! `h+ = −cos(γ + θa) / (2 sin θa sin γ)`, `Φ = 4 asin √h−` (or `2π − 4 asin √h+`) and
//! `sin(Φ/2) = 2 √(h− h+)`. The integral is split where `Φ` has its square-root kinks
//! (`cos(γ ∓ θa) = 0`) and where `g` jumps (the cap's edge `γ = α`) or has a kink or power
//! singularity (the lobe at `γ = π/2`); each piece is mapped by `γ = c + h sin(πv/2)`, which
//! makes square-root ends smooth, and integrated by adaptive Gauss–Legendre (bisection until
//! the disagreements of two levels add up to 1e-14 of the integral of `|integrand|`). Tested against closed forms to
//! 1e-12 relative and against an independent 2-D quadrature in `(θ, φ)` about the normal.
//!
//! **In experiment files.** [`FamilySpec`] is an integrand object as written (`{"type": "lobe",
//! …}`, the render scene's `pixel` and a map's `envmap`); [`FamilySpec::resolve`] turns it into an [`Integrand`]
//! with its default name ([`AxisIntegrand::default_name`]), and [`Profile::parameter`] is the
//! manifest's parameter column. A new axis profile touches this file only.

use super::Integrand;
use super::envmap::{BrdfSpec, EnvmapIntegrand};
use super::pixel::PixelIntegrand;
use crate::util::geometry::Vec3;
use crate::util::quadrature::GaussLegendre;
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use std::f64::consts::{FRAC_PI_2, PI, TAU};
use std::sync::LazyLock;

/// The profile `g(t)` of a family, `t = ω·a`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Profile {
    /// `max(0, t)^e` (with `0^0 = 1`, so `e = 0` is the constant 1).
    Lobe { exponent: f64 },
    /// `1[t ≥ cos α]`, `α` in degrees.
    Cap { half_angle: f64 },
    /// `exp(λ (t − 1))`.
    Gaussian { sharpness: f64 },
}

impl Profile {
    /// The family's name in files: `lobe`, `cap` or `gaussian`.
    pub fn family(&self) -> &'static str {
        match self {
            Profile::Lobe { .. } => "lobe",
            Profile::Cap { .. } => "cap",
            Profile::Gaussian { .. } => "gaussian",
        }
    }

    /// The parameter's JSON field and value: `("exponent", e)`, `("half_angle", α)`,
    /// `("sharpness", λ)` (the manifest's parameter column).
    pub fn parameter(&self) -> (&'static str, f64) {
        match *self {
            Profile::Lobe { exponent } => ("exponent", exponent),
            Profile::Cap { half_angle } => ("half_angle", half_angle),
            Profile::Gaussian { sharpness } => ("sharpness", sharpness),
        }
    }

    /// Checks the parameter (finite, in range); the message names the JSON field.
    pub fn validate(&self) -> Result<(), String> {
        match *self {
            Profile::Lobe { exponent } if !(exponent.is_finite() && (0.0..=1e6).contains(&exponent)) => {
                Err(format!(
                    "exponent: must be in [0, 1e6], got {}",
                    crate::util::shown::shown(exponent)
                ))
            }
            Profile::Cap { half_angle } if !(half_angle > 0.0 && half_angle <= 180.0) => Err(format!(
                "half_angle: must be in (0, 180] degrees, got {}",
                crate::util::shown::shown(half_angle)
            )),
            Profile::Gaussian { sharpness } if !(sharpness > 0.0 && sharpness <= 1e6) => Err(format!(
                "sharpness: must be in (0, 1e6], got {}",
                crate::util::shown::shown(sharpness)
            )),
            _ => Ok(()),
        }
    }

    /// `g(t)`.
    #[inline]
    pub fn g(&self, t: f64) -> f64 {
        match *self {
            Profile::Lobe { exponent } => {
                if exponent == 0.0 {
                    1.0
                } else if t <= 0.0 {
                    0.0
                } else {
                    t.powf(exponent)
                }
            }
            Profile::Cap { half_angle } => {
                if half_angle >= 180.0 || t >= half_angle.to_radians().cos() {
                    1.0
                } else {
                    0.0
                }
            }
            Profile::Gaussian { sharpness } => (sharpness * (t - 1.0)).exp(),
        }
    }

    /// Angles `γ = arccos t` in `(0, π)` where `g` jumps or is not smooth.
    fn breaks(&self) -> Vec<f64> {
        match *self {
            Profile::Lobe { exponent } if exponent != 0.0 => vec![FRAC_PI_2],
            Profile::Cap { half_angle } if half_angle < 180.0 => vec![half_angle.to_radians()],
            _ => Vec::new(),
        }
    }
}

/// A family integrand: profile, unit axis, whether it carries the cosine `ω·n`, and its truth.
#[derive(Clone, Debug, PartialEq)]
pub struct AxisIntegrand {
    pub profile: Profile,
    /// The unit axis `a` (normalised from the JSON).
    pub axis: Vec3,
    /// `m = 1`: the integrand also carries `ω·n`.
    pub cosine: bool,
    truth: f64,
}

impl AxisIntegrand {
    /// Validates the parameters, normalises the axis and computes the truth.
    pub fn new(profile: Profile, axis: [f64; 3], cosine: bool) -> Result<Self, String> {
        profile.validate()?;
        let v = Vec3::new(axis[0], axis[1], axis[2]);
        let norm = v.norm();
        if !(norm.is_finite() && norm > 1e-12) {
            return Err(format!(
                "axis: must be a non-zero finite vector, got [{}, {}, {}]",
                axis[0], axis[1], axis[2]
            ));
        }
        let axis = v * (1.0 / norm);
        let truth = axis_integral(&profile, axis.z.clamp(-1.0, 1.0), cosine);
        Ok(AxisIntegrand {
            profile,
            axis,
            cosine,
            truth,
        })
    }

    /// `f(ω) = g(ω·a) (ω·n)^m`.
    #[inline]
    pub fn value(&self, w: &Vec3) -> f64 {
        let g = self.profile.g(w.dot(&self.axis));
        if self.cosine { g * w.z } else { g }
    }

    /// `I = ∫_H f dω` (see the module docs).
    pub fn integral(&self) -> f64 {
        self.truth
    }

    /// `Phong lobe e = 8, tilt 30°`, `disc light 15°, tilt 45° × cos θ`, `spherical Gaussian
    /// λ = 20, tilt 0°`.
    pub fn display_name(&self) -> String {
        let tilt = format!("{:.1}", self.tilt_degrees());
        let tilt = tilt.strip_suffix(".0").unwrap_or(&tilt);
        let what = match self.profile {
            Profile::Lobe { exponent } => format!("Phong lobe e = {exponent}"),
            Profile::Cap { half_angle } => format!("disc light {half_angle}°"),
            Profile::Gaussian { sharpness } => format!("spherical Gaussian λ = {sharpness}"),
        };
        format!(
            "{what}, tilt {tilt}°{}",
            if self.cosine { " × cos θ" } else { "" }
        )
    }

    /// The axis's angle from the normal, in degrees.
    pub fn tilt_degrees(&self) -> f64 {
        self.axis.z.clamp(-1.0, 1.0).acos().to_degrees()
    }

    /// `lobe8-tilt30`, `cap15-tilt45-cos`, `gaussian20-tilt0`: the family, its parameter, the
    /// axis's tilt from the normal in degrees (the azimuth does not change the integral) and
    /// `-cos` for `m = 1`.
    pub fn default_name(&self) -> String {
        let (_, param) = self.profile.parameter();
        // To a tenth of a degree, without a trailing ".0" ([0.5, 0, 0.866] is 30.0007°: "30").
        let tilt = format!("{:.1}", self.tilt_degrees());
        let tilt = tilt.strip_suffix(".0").unwrap_or(&tilt);
        format!(
            "{}{param}-tilt{tilt}{}",
            self.profile.family(),
            if self.cosine { "-cos" } else { "" }
        )
    }
}

/// A rendering-like integrand about a tilted axis (math.md §1, "Rendering-like integrands").
// Read by `FamilyFields`, so that errors name the field inside (`normal[0]`); a doc line here
// would go into the committed JSON Schema.
#[derive(Debug, Clone, PartialEq, Serialize, JsonSchema)]
#[serde(tag = "type", rename_all = "lowercase", deny_unknown_fields)]
pub enum FamilySpec {
    /// `max(0, ω·a)^e · (ω·n)^m`.
    Lobe {
        #[serde(default, skip_serializing_if = "Option::is_none")]
        name: Option<String>,
        axis: [f64; 3],
        exponent: f64,
        #[serde(default)]
        cosine: bool,
    },
    /// `1[ω·a ≥ cos α] · (ω·n)^m`, `α = half_angle` in degrees.
    Cap {
        #[serde(default, skip_serializing_if = "Option::is_none")]
        name: Option<String>,
        axis: [f64; 3],
        half_angle: f64,
        #[serde(default)]
        cosine: bool,
    },
    /// `exp(λ (ω·a − 1)) · (ω·n)^m`, `λ = sharpness`.
    Gaussian {
        #[serde(default, skip_serializing_if = "Option::is_none")]
        name: Option<String>,
        axis: [f64; 3],
        sharpness: f64,
        #[serde(default)]
        cosine: bool,
    },
    /// The render scene's integrand at pixel `[i, j]` (column, row from the top left) of a
    /// `width × height` image under `env` (`sky`, `white`, a catalogue map by name or a map
    /// file), one `channel` (`r`,
    /// `g`, `b`): math.md §1 "Scene integrands".
    Pixel {
        #[serde(default, skip_serializing_if = "Option::is_none")]
        name: Option<String>,
        pixel: [usize; 2],
        #[serde(default = "default_size")]
        width: usize,
        #[serde(default = "default_size")]
        height: usize,
        #[serde(default = "default_env")]
        env: String,
        channel: String,
    },
    /// A lat-long map seen from an unoccluded surface with world normal `normal`
    /// ([`super::envmap`]): `L_c(d) · f_r · (ω·n)`, `brdf` `"lambert"` (`f_r = 1/π`: the truth is
    /// the irradiance `E(n)`) or `{"phong": e, "axis": [x, y, z]}` (`f_r = ((e + 1)/2π)
    /// max(0, ω·a)^e`, axis in the local frame), `lookup` `mitsuba` (default) or `thesis`,
    /// `channel` `r`, `g`, `b` or `luminance` (Rec. 709, default).
    Envmap {
        #[serde(default, skip_serializing_if = "Option::is_none")]
        name: Option<String>,
        env: String,
        normal: [f64; 3],
        #[serde(default)]
        brdf: BrdfSpec,
        #[serde(default = "default_lookup")]
        lookup: String,
        #[serde(default = "default_channel")]
        channel: String,
    },
}

/// [`FamilySpec`]'s variants read externally tagged (`{"envmap": {…}}`): serde reads an
/// internally tagged enum (`"type"` beside the fields) through a buffer that loses the path, so an
/// error inside said `integrands[0]` where it meant `integrands[0].normal[0]` (issue 42).
/// `remote` makes serde build [`FamilySpec`] itself, so a field missing here does not compile.
#[derive(Deserialize)]
#[serde(remote = "FamilySpec", rename_all = "lowercase", deny_unknown_fields)]
enum FamilyFields {
    Lobe {
        #[serde(default)]
        name: Option<String>,
        axis: [f64; 3],
        exponent: f64,
        #[serde(default)]
        cosine: bool,
    },
    Cap {
        #[serde(default)]
        name: Option<String>,
        axis: [f64; 3],
        half_angle: f64,
        #[serde(default)]
        cosine: bool,
    },
    Gaussian {
        #[serde(default)]
        name: Option<String>,
        axis: [f64; 3],
        sharpness: f64,
        #[serde(default)]
        cosine: bool,
    },
    Pixel {
        #[serde(default)]
        name: Option<String>,
        pixel: [usize; 2],
        #[serde(default = "default_size")]
        width: usize,
        #[serde(default = "default_size")]
        height: usize,
        #[serde(default = "default_env")]
        env: String,
        channel: String,
    },
    Envmap {
        #[serde(default)]
        name: Option<String>,
        env: String,
        normal: [f64; 3],
        #[serde(default)]
        brdf: BrdfSpec,
        #[serde(default = "default_lookup")]
        lookup: String,
        #[serde(default = "default_channel")]
        channel: String,
    },
}

impl<'de> Deserialize<'de> for FamilySpec {
    /// `{"type": t, fields…}` as `{t: {fields…}}` through [`FamilyFields`], with the path of the
    /// field that failed ([`crate::files::spec_json::from_value`]) minus the variant's name.
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        use serde::de::Error;
        use serde_json::Value;
        struct Tagged(FamilySpec);
        impl<'de> Deserialize<'de> for Tagged {
            fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
                FamilyFields::deserialize(d).map(Tagged)
            }
        }
        let mut object = match Value::deserialize(d)? {
            Value::Object(o) => o,
            other => {
                return Err(D::Error::custom(format!(
                    "expected an object with a \"type\" ({}), got {}",
                    FamilySpec::types_or(),
                    crate::files::spec_json::kind(&other)
                )));
            }
        };
        let kind = match object.remove("type") {
            Some(Value::String(t)) => t,
            Some(other) => {
                return Err(D::Error::custom(format!(
                    "type: expected one of {}, got {other}",
                    FamilySpec::types_or()
                )));
            }
            None => return Err(D::Error::custom("missing field `type`")),
        };
        let tagged = Value::Object(serde_json::Map::from_iter([(
            kind.clone(),
            Value::Object(object),
        )]));
        crate::files::spec_json::from_value::<Tagged>(tagged)
            .map(|t| t.0)
            .map_err(|m| {
                // The variant's name leads the path (`envmap.normal[0]: …`); the file has `type`.
                let m = m
                    .strip_prefix(&format!("{kind}."))
                    .or_else(|| m.strip_prefix(&format!("{kind}: ")))
                    .map_or(m.clone(), str::to_owned);
                D::Error::custom(if m.starts_with("unknown variant") {
                    format!("type: {m}")
                } else {
                    m
                })
            })
    }
}

fn default_lookup() -> String {
    "mitsuba".into()
}

fn default_channel() -> String {
    "luminance".into()
}

/// The renderer's default image size.
fn default_size() -> usize {
    256
}

fn default_env() -> String {
    "sky".into()
}

impl FamilySpec {
    /// The accepted `"type"`s, as the JSON spells them (the enum's variants, in order).
    pub const TYPES: [&'static str; 5] = ["lobe", "cap", "gaussian", "pixel", "envmap"];

    /// [`FamilySpec::TYPES`] for a sentence: `lobe, cap, gaussian or pixel`.
    pub fn types_or() -> String {
        let (last, rest) = Self::TYPES.split_last().expect("at least one type");
        format!("{} or {last}", rest.join(", "))
    }

    /// The `"name"` given in the file, if any.
    pub fn name(&self) -> Option<&str> {
        match self {
            FamilySpec::Lobe { name, .. }
            | FamilySpec::Cap { name, .. }
            | FamilySpec::Gaussian { name, .. }
            | FamilySpec::Pixel { name, .. }
            | FamilySpec::Envmap { name, .. } => name.as_deref(),
        }
    }

    /// The integrand, validated, with its truth computed, named as given (the caller checks
    /// the name: [`FamilySpec::name`]) or by default. Errors name the JSON field.
    pub fn resolve(&self) -> Result<Integrand, String> {
        let (profile, name, axis, cosine) = match self {
            FamilySpec::Lobe {
                name,
                axis,
                exponent,
                cosine,
            } => (Profile::Lobe { exponent: *exponent }, name, axis, *cosine),
            FamilySpec::Cap {
                name,
                axis,
                half_angle,
                cosine,
            } => (
                Profile::Cap {
                    half_angle: *half_angle,
                },
                name,
                axis,
                *cosine,
            ),
            FamilySpec::Gaussian {
                name,
                axis,
                sharpness,
                cosine,
            } => (
                Profile::Gaussian {
                    sharpness: *sharpness,
                },
                name,
                axis,
                *cosine,
            ),
            FamilySpec::Pixel {
                name,
                pixel,
                width,
                height,
                env,
                channel,
            } => {
                let f = PixelIntegrand::from_env_arg(*pixel, *width, *height, env, channel)?;
                let name = name.clone().unwrap_or_else(|| f.default_name());
                return Ok(Integrand::Pixel { name, f: Box::new(f) });
            }
            FamilySpec::Envmap {
                name,
                env,
                normal,
                brdf,
                lookup,
                channel,
            } => {
                let f = EnvmapIntegrand::new(env, *normal, brdf.resolve()?, lookup, channel)?;
                let name = name.clone().unwrap_or_else(|| f.default_name());
                return Ok(Integrand::Envmap { name, f: Box::new(f) });
            }
        };
        let f = AxisIntegrand::new(profile, *axis, cosine)?;
        let name = name.clone().unwrap_or_else(|| f.default_name());
        Ok(Integrand::Axis { name, f })
    }
}

/// Gauss–Legendre points per panel of the adaptive rule.
const POINTS: usize = 20;
static RULE: LazyLock<GaussLegendre> = LazyLock::new(|| GaussLegendre::new(POINTS));
/// Relative tolerance of the adaptive rule (against the integral of `|integrand|`).
const TOLERANCE: f64 = 1e-14;

/// `∫_{−1}^{1} g(t) A_m(t) dt` for an axis with `cos θa = mu`.
pub fn axis_integral(profile: &Profile, mu: f64, cosine: bool) -> f64 {
    let theta_a = mu.acos();
    let sin_a = theta_a.sin();
    let integrand = |gamma: f64| {
        let t = gamma.cos();
        let g = profile.g(t);
        if g == 0.0 {
            return 0.0;
        }
        let (phi, half_sin) = arc(gamma, theta_a, mu, sin_a);
        let a = if cosine {
            t * mu * phi + 2.0 * gamma.sin() * sin_a * half_sin
        } else {
            phi
        };
        g * a * gamma.sin()
    };
    let mut breaks: Vec<f64> = vec![0.0, PI];
    for b in [
        FRAC_PI_2 - theta_a,
        FRAC_PI_2 + theta_a,
        theta_a - FRAC_PI_2,
        1.5 * PI - theta_a,
    ]
    .into_iter()
    .chain(profile.breaks())
    {
        if b > 0.0 && b < PI {
            breaks.push(b);
        }
    }
    breaks.sort_by(f64::total_cmp);
    breaks.dedup_by(|a, b| (*a - *b).abs() <= 1e-15);
    // A first pass sets the scale of the absolute tolerance.
    let pieces: Vec<(f64, f64)> = breaks.windows(2).map(|w| (w[0], w[1])).collect();
    let scale: f64 = pieces
        .iter()
        .map(|&(lo, hi)| mapped(lo, hi, &|g| integrand(g).abs(), -1.0, 1.0))
        .sum();
    let tol = TOLERANCE * scale.max(f64::MIN_POSITIVE);
    adaptive(&pieces, &integrand, tol)
}

/// `(Φ, sin(Φ/2))` of the circle `{ω·a = cos γ}` (see the module docs).
fn arc(gamma: f64, theta_a: f64, mu: f64, sin_a: f64) -> (f64, f64) {
    let sin_g = gamma.sin();
    if sin_a == 0.0 || sin_g == 0.0 {
        // The axis is ±n, or the circle is the point ±a: all of it in H or none.
        let above = gamma.cos() * mu >= 0.0;
        return (if above { TAU } else { 0.0 }, 0.0);
    }
    let denom = 2.0 * sin_a * sin_g;
    let h_minus = (gamma - theta_a).cos() / denom;
    let h_plus = -(gamma + theta_a).cos() / denom;
    if h_minus <= 0.0 {
        (0.0, 0.0)
    } else if h_plus <= 0.0 {
        (TAU, 0.0)
    } else {
        let (hm, hp) = (h_minus.min(1.0), h_plus.min(1.0));
        let phi = if hm < hp {
            4.0 * hm.sqrt().asin()
        } else {
            TAU - 4.0 * hp.sqrt().asin()
        };
        (phi, 2.0 * (hm * hp).sqrt())
    }
}

/// `∫_{v0}^{v1}` of `f(γ(v)) γ'(v)` with `γ = c + h sin(πv/2)` mapping `[−1, 1]` onto `[lo, hi]`
/// (square-root behaviour at either end becomes smooth in `v`).
fn mapped(lo: f64, hi: f64, f: &dyn Fn(f64) -> f64, v0: f64, v1: f64) -> f64 {
    let (c, h) = (0.5 * (lo + hi), 0.5 * (hi - lo));
    RULE.integrate(v0, v1, |v| {
        let x = FRAC_PI_2 * v;
        f(c + h * x.sin()) * h * FRAC_PI_2 * x.cos()
    })
}

/// Most panels of the adaptive rule (a budget: smooth pieces need a few dozen).
const MAX_PANELS: usize = 20_000;

/// Globally adaptive Gauss–Legendre over the pieces: the panel whose value disagrees most with
/// the sum of its two halves is bisected (in `v`) until the disagreements add up to at most
/// `tol`, or the panel budget is spent. Returns the sum of the halves.
fn adaptive(pieces: &[(f64, f64)], f: &dyn Fn(f64) -> f64, tol: f64) -> f64 {
    struct Panel {
        piece: (f64, f64),
        v: (f64, f64),
        halves: f64,
        error: f64,
    }
    let panel = |piece: (f64, f64), v0: f64, v1: f64| {
        let whole = mapped(piece.0, piece.1, f, v0, v1);
        let mid = 0.5 * (v0 + v1);
        let halves = mapped(piece.0, piece.1, f, v0, mid) + mapped(piece.0, piece.1, f, mid, v1);
        Panel {
            piece,
            v: (v0, v1),
            halves,
            error: (whole - halves).abs(),
        }
    };
    let mut panels: Vec<Panel> = pieces.iter().map(|&p| panel(p, -1.0, 1.0)).collect();
    while panels.len() < MAX_PANELS {
        let total: f64 = panels.iter().map(|p| p.error).sum();
        if total <= tol {
            break;
        }
        let worst = (0..panels.len())
            .max_by(|&a, &b| panels[a].error.total_cmp(&panels[b].error))
            .expect("at least one panel");
        let p = panels.swap_remove(worst);
        let mid = 0.5 * (p.v.0 + p.v.1);
        panels.push(panel(p.piece, p.v.0, mid));
        panels.push(panel(p.piece, mid, p.v.1));
    }
    // Summed in a fixed order (by piece, then v), so the truth does not depend on the order of
    // refinement's ties.
    panels.sort_by(|a, b| a.piece.0.total_cmp(&b.piece.0).then(a.v.0.total_cmp(&b.v.0)));
    panels.iter().map(|p| p.halves).sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// [`FamilySpec::TYPES`] lists exactly the variants serde accepts, in order.
    #[test]
    fn family_types_are_the_spec_variants() {
        let e = serde_json::from_value::<FamilySpec>(serde_json::json!({"type": "nope"}))
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("type: unknown variant `nope`"), "{e}");
        let expected: Vec<String> = FamilySpec::TYPES.iter().map(|t| format!("`{t}`")).collect();
        assert!(
            e.contains(&format!("expected one of {}", expected.join(", "))),
            "{e}"
        );
        assert_eq!(FamilySpec::types_or(), "lobe, cap, gaussian, pixel or envmap");
        for p in [
            Profile::Lobe { exponent: 1.0 },
            Profile::Cap { half_angle: 1.0 },
            Profile::Gaussian { sharpness: 1.0 },
        ] {
            assert!(FamilySpec::TYPES.contains(&p.family()));
        }
    }

    fn close(got: f64, want: f64, rel: f64) -> bool {
        (got - want).abs() <= rel * want.abs().max(1e-300)
    }

    /// Closed forms with the axis along the normal, for the half-space and for the whole sphere.
    #[test]
    fn closed_forms_to_1e_12() {
        let n = [0.0, 0.0, 1.0];
        for e in [0.0, 1.0, 2.5, 8.0, 100.0] {
            let f = AxisIntegrand::new(Profile::Lobe { exponent: e }, n, false).unwrap();
            assert!(
                close(f.integral(), TAU / (e + 1.0), 1e-12),
                "lobe {e}: {}",
                f.integral()
            );
            let f = AxisIntegrand::new(Profile::Lobe { exponent: e }, n, true).unwrap();
            assert!(close(f.integral(), TAU / (e + 2.0), 1e-12), "lobe {e} cos");
        }
        for alpha in [1.0f64, 15.0, 45.0, 89.0, 90.0] {
            let c = alpha.to_radians().cos();
            let f = AxisIntegrand::new(Profile::Cap { half_angle: alpha }, n, false).unwrap();
            assert!(close(f.integral(), TAU * (1.0 - c), 1e-12), "cap {alpha}");
            let f = AxisIntegrand::new(Profile::Cap { half_angle: alpha }, n, true).unwrap();
            let s = alpha.to_radians().sin();
            assert!(close(f.integral(), PI * s * s, 1e-12), "cap {alpha} cos");
        }
        for lambda in [0.5, 20.0, 1000.0] {
            let f = AxisIntegrand::new(Profile::Gaussian { sharpness: lambda }, n, false).unwrap();
            let want = TAU * -(-lambda).exp_m1() / lambda;
            assert!(close(f.integral(), want, 1e-12), "gaussian {lambda}");
        }
        // A narrow lobe tilted 20°: its part below the horizon is below 1e-40, so it integrates
        // as over the whole sphere, 2π/(e + 1).
        let t = 20f64.to_radians();
        let f =
            AxisIntegrand::new(Profile::Lobe { exponent: 100.0 }, [t.sin(), 0.0, t.cos()], false).unwrap();
        assert!(
            close(f.integral(), TAU / 101.0, 1e-12),
            "tilted lobe: {}",
            f.integral()
        );
        // A tilted half-space: the lune between two hemispheres has area 2(π − θa).
        for tilt in [0.0f64, 10.0, 45.0, 90.0, 135.0, 179.0] {
            let t = tilt.to_radians();
            let f = AxisIntegrand::new(Profile::Cap { half_angle: 90.0 }, [t.sin(), 0.0, t.cos()], false)
                .unwrap();
            assert!(
                close(f.integral(), 2.0 * (PI - t), 1e-12),
                "half-space tilt {tilt}: {}",
                f.integral()
            );
            // The whole sphere: the hemisphere, whatever the axis.
            let f = AxisIntegrand::new(Profile::Cap { half_angle: 180.0 }, [t.sin(), 0.3, t.cos()], true)
                .unwrap();
            assert!(close(f.integral(), PI, 1e-12), "sphere cap, tilt {tilt}");
        }
    }

    #[test]
    fn bad_parameters_name_the_field() {
        let n = [0.0, 0.0, 1.0];
        assert!(
            AxisIntegrand::new(Profile::Lobe { exponent: -1.0 }, n, false)
                .unwrap_err()
                .starts_with("exponent")
        );
        assert!(
            AxisIntegrand::new(Profile::Cap { half_angle: 0.0 }, n, false)
                .unwrap_err()
                .starts_with("half_angle")
        );
        assert!(
            AxisIntegrand::new(Profile::Cap { half_angle: 181.0 }, n, false)
                .unwrap_err()
                .starts_with("half_angle")
        );
        assert!(
            AxisIntegrand::new(Profile::Gaussian { sharpness: 0.0 }, n, false)
                .unwrap_err()
                .starts_with("sharpness")
        );
        assert!(
            AxisIntegrand::new(Profile::Gaussian { sharpness: 1.0 }, [0.0; 3], false)
                .unwrap_err()
                .starts_with("axis")
        );
    }
}
