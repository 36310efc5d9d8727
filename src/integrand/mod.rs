//! Integrands with their exact integrals (math.md §1): `cos^k θ` here, the rendering-like
//! families (lobe, cap, Gaussian about a tilted axis) in [`family`], and [`Integrand`], the one
//! type experiments use; render-scene pixels in [`pixel`]; real light (a map seen from a surface)
//! in [`envmap`]; functions given from outside (a Python callable) in [`external`].

pub mod envmap;
pub mod external;
pub mod family;
pub mod lit;
pub mod pixel;

use crate::util::geometry::Vec3;
use envmap::EnvmapIntegrand;
use external::ExternalIntegrand;
use family::AxisIntegrand;
use pixel::PixelIntegrand;
use std::f64::consts::TAU;

/// An integrand of an experiment, with a name (a file name: `<name>.svg`) and its truth.
#[derive(Clone, Debug, PartialEq)]
pub enum Integrand {
    /// `cos^k θ`, named `cos<k>`.
    Cos(CosPower),
    /// A family integrand with its name.
    Axis { name: String, f: AxisIntegrand },
    /// A render-scene pixel's integrand in one channel, with its name.
    Pixel { name: String, f: Box<PixelIntegrand> },
    /// A map seen from an unoccluded surface, one channel, with its name.
    Envmap { name: String, f: Box<EnvmapIntegrand> },
    /// A batch function given from outside (a Python callable), with its name and truth.
    External(Box<ExternalIntegrand>),
}

impl Integrand {
    /// The name in files and tables.
    pub fn name(&self) -> String {
        match self {
            Integrand::Cos(c) => c.name(),
            Integrand::Axis { name, .. } | Integrand::Pixel { name, .. } | Integrand::Envmap { name, .. } => {
                name.clone()
            }
            Integrand::External(f) => f.name.clone(),
        }
    }

    /// What the integrand is, for titles and legends: `cos³θ`, `Phong lobe e = 8, tilt 30°`.
    pub fn display_name(&self) -> String {
        match self {
            Integrand::Cos(c) => c.display_name(),
            Integrand::Axis { f, .. } => f.display_name(),
            Integrand::Pixel { f, .. } => f.display_name(),
            Integrand::Envmap { f, .. } => f.display_name(),
            Integrand::External(f) => f.display_name.clone(),
        }
    }

    /// `f(ω)`; an external integrand's one-point batch (NaN when it fails: use
    /// [`Integrand::values`], which says why).
    #[inline]
    pub fn value(&self, w: &Vec3) -> f64 {
        match self {
            Integrand::Cos(c) => c.value(w),
            Integrand::Axis { f, .. } => f.value(w),
            Integrand::Pixel { f, .. } => f.value(w),
            Integrand::Envmap { f, .. } => f.value(w),
            Integrand::External(f) => f.values(std::slice::from_ref(w)).map_or(f64::NAN, |v| v[0]),
        }
    }

    /// `f` at every point, in one batch: an external integrand is called once (its errors,
    /// wrong lengths and non-finite values are the message); the others cannot fail.
    pub fn values(&self, points: &[Vec3]) -> Result<Vec<f64>, String> {
        match self {
            Integrand::External(f) => f.values(points),
            _ => Ok(points.iter().map(|w| self.value(w)).collect()),
        }
    }

    /// [`Integrand::values`] for trial `trial` at `n` of a run: a failure is an
    /// [`crate::Error::Integrand`] naming the integrand, the trial and N (`what` says which set
    /// when it is not the trial's N points).
    pub fn trial_values(
        &self,
        points: &[Vec3],
        trial: usize,
        n: usize,
        what: &str,
    ) -> crate::Result<Vec<f64>> {
        self.values(points).map_err(|m| {
            crate::Error::Integrand(format!(
                "integrand {:?}, trial {trial}, N = {n}: {what}{m}",
                self.name()
            ))
        })
    }

    /// The integrand's factors and techniques ([`lit::Lit`]) for the light-aware estimators, or
    /// why it has none (a sentence naming the integrand).
    pub fn lit(&self) -> Result<&dyn lit::Lit, String> {
        match self {
            Integrand::Envmap { f, .. } => Ok(f.as_ref()),
            Integrand::Cos(_) | Integrand::Axis { .. } | Integrand::External(_) => Err(format!(
                "integrand {:?} has no light (only envmap integrands expose their light and BRDF)",
                self.name()
            )),
            Integrand::Pixel { .. } => Err(format!(
                "integrand {:?} is a scene pixel, whose light and visibility the light-aware estimators \
                 do not sample yet (only envmap integrands)",
                self.name()
            )),
        }
    }

    /// `I = ∫_H f dω`.
    pub fn integral(&self) -> f64 {
        match self {
            Integrand::Cos(c) => c.integral(),
            Integrand::Axis { f, .. } => f.integral(),
            Integrand::Pixel { f, .. } => f.integral(),
            Integrand::Envmap { f, .. } => f.integral(),
            Integrand::External(f) => f.integral(),
        }
    }

    /// The oracle prior `c = I / (2π)` (math.md §1): the constant with the true integral.
    pub fn constant_prior(&self) -> f64 {
        match self {
            Integrand::Cos(c) => c.constant_prior(),
            Integrand::Axis { f, .. } => f.integral() / TAU,
            Integrand::Pixel { f, .. } => f.integral() / TAU,
            Integrand::Envmap { f, .. } => f.integral() / TAU,
            Integrand::External(f) => f.integral() / TAU,
        }
    }
}

/// `f(ω) = cos^k θ = ω_z^k` over the hemisphere around `+z`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CosPower {
    pub k: u32,
}

impl CosPower {
    /// `cos^k θ`, any `k ≥ 0`.
    pub fn new(k: u32) -> Self {
        CosPower { k }
    }

    /// Parses `cos` (k = 1), `cos2`, `cos3`, … and `cos0` (the constant 1).
    pub fn parse(name: &str) -> Option<Self> {
        let rest = name.strip_prefix("cos")?;
        if rest.is_empty() {
            return Some(CosPower::new(1));
        }
        if rest.starts_with('+') || rest.len() > 1 && rest.starts_with('0') {
            return None;
        }
        // Any k that `powi` takes (k ≤ 2³¹ − 1).
        rest.parse::<u32>()
            .ok()
            .filter(|&k| k <= i32::MAX as u32)
            .map(CosPower::new)
    }

    /// `cos` for k = 1, `cos<k>` otherwise.
    pub fn name(&self) -> String {
        if self.k == 1 {
            "cos".into()
        } else {
            format!("cos{}", self.k)
        }
    }

    /// The name for people, as the formula: `1` (k = 0), `cos θ`, `cos²θ`, `cos³θ`, … with the
    /// exponent in Unicode superscript digits for any k. File names keep [`CosPower::name`]
    /// (`cos3.svg`), which is ASCII and what experiment files say.
    pub fn display_name(&self) -> String {
        const SUPERSCRIPT: [char; 10] = ['⁰', '¹', '²', '³', '⁴', '⁵', '⁶', '⁷', '⁸', '⁹'];
        match self.k {
            0 => "1".into(),
            1 => "cos θ".into(),
            k => {
                let exponent: String = k
                    .to_string()
                    .bytes()
                    .map(|d| SUPERSCRIPT[(d - b'0') as usize])
                    .collect();
                format!("cos{exponent}θ")
            }
        }
    }

    /// `f(ω) = ω_z^k`.
    #[inline]
    pub fn value(&self, w: &Vec3) -> f64 {
        w.z.powi(self.k as i32)
    }

    /// `I_k = ∫_H cos^k θ dω = 2π / (k + 1)`.
    pub fn integral(&self) -> f64 {
        TAU / (self.k as f64 + 1.0)
    }

    /// The constant with the same integral, `c = I / (2π) = 1 / (k + 1)` (math.md §1;
    /// the thesis's 1/2 for cos³θ is an erratum).
    pub fn constant_prior(&self) -> f64 {
        1.0 / (self.k as f64 + 1.0)
    }

    /// Variance of one uniform-sampling MC term: `σ² = 4π² (1/(2k+1) − 1/(k+1)²)` (math.md §3).
    pub fn uniform_mc_variance(&self) -> f64 {
        let k = self.k as f64;
        TAU * TAU * (1.0 / (2.0 * k + 1.0) - 1.0 / ((k + 1.0) * (k + 1.0)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip() {
        assert_eq!(CosPower::parse("cos"), Some(CosPower::new(1)));
        assert_eq!(CosPower::parse("cos3"), Some(CosPower::new(3)));
        assert_eq!(CosPower::parse("cos0"), Some(CosPower::new(0)));
        assert_eq!(CosPower::parse("cos100"), Some(CosPower::new(100)));
        assert_eq!(
            CosPower::parse("cos2147483647"),
            Some(CosPower::new(i32::MAX as u32))
        );
        for bad in ["cos1x", "sin", "cos-1", "cos+2", "cos02", "", "cos2147483648"] {
            assert_eq!(CosPower::parse(bad), None, "{bad}");
        }
        for k in 0..6 {
            assert_eq!(CosPower::parse(&CosPower::new(k).name()), Some(CosPower::new(k)));
        }
    }

    #[test]
    fn display_names_use_superscripts() {
        let names: Vec<String> = [0, 1, 2, 3, 4, 10, 1024]
            .into_iter()
            .map(|k| CosPower::new(k).display_name())
            .collect();
        assert_eq!(
            names,
            ["1", "cos θ", "cos²θ", "cos³θ", "cos⁴θ", "cos¹⁰θ", "cos¹⁰²⁴θ"]
        );
    }

    /// The closed form against a midpoint rule in μ = cos θ (∫_H f dω = 2π ∫_0^1 μ^k dμ).
    #[test]
    fn integral_matches_quadrature() {
        for k in 0..5 {
            let f = CosPower::new(k);
            let m = 100_000;
            let q: f64 = (0..m)
                .map(|i| ((i as f64 + 0.5) / m as f64).powi(k as i32))
                .sum::<f64>()
                * TAU
                / m as f64;
            assert!((q - f.integral()).abs() < 1e-8, "k={k}");
            assert!((f.constant_prior() * TAU - f.integral()).abs() < 1e-15);
        }
    }
}
