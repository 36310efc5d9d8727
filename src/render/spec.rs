//! The table spec (`workbench render SPEC.json`): the JSON, validated field by field into a
//! [`TablePlan`] with every default filled in, before any work.
//!
//! Fields (all but `name` and `variants` optional):
//!
//! ```json
//! { "name": "render-table", "seed": 0, "width": 256, "height": 256, "env": "sky",
//!   "spp": [20, 40, 60, 80], "repetitions": 10,
//!   "reference": { "spp": 3000, "seed": 1 },
//!   "model": { "kernel": "sobolev", "s": 1.4, "noise": 0.01, "kernel_mean": "exact" },
//!   "variants": [ { "label": "MC", "integrator": "mc" },
//!                 { "label": "BMC 4 GP", "integrator": "bmc", "gps": 4, "rotate": true } ] }
//! ```
//!
//! Unknown fields are errors; every message names the file, the JSON path and the value.

use super::env::Environment;
use super::integrator::IntegratorKind;
use super::renderer::check_size;
use crate::bmc::{BmcModel, DEFAULT_NOISE, validate_noise};
use crate::io::InputError;
use crate::kernel::{Kernel, Sobolev, SquaredExponential};
use crate::kernel_mean::KernelMeanMode;
use serde_json::{Map, Value};
use std::path::{Path, PathBuf};

/// One row of the table.
#[derive(Clone, Debug, PartialEq)]
pub struct VariantPlan {
    pub label: String,
    pub kind: IntegratorKind,
    /// Sample sets (BMC/BMCP only; 0 for MC).
    pub gps: usize,
    /// Random azimuth rotation (BMC/BMCP only; false for MC).
    pub rotate: bool,
}

/// The MC reference image.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReferencePlan {
    pub spp: usize,
    pub seed: u64,
}

/// A validated table: everything the run needs, defaults filled in.
#[derive(Clone, Debug)]
pub struct TablePlan {
    pub file: PathBuf,
    pub name: String,
    pub seed: u64,
    pub width: usize,
    pub height: usize,
    pub env: Environment,
    pub env_arg: String,
    pub spp: Vec<usize>,
    /// Repetitions per entry of `spp`.
    pub repetitions: Vec<usize>,
    pub reference: ReferencePlan,
    /// The BMC model, built only when a variant needs it.
    pub model: Option<BmcModel>,
    /// The model's parameters, for the manifest.
    pub model_json: Value,
    pub variants: Vec<VariantPlan>,
}

/// Default spp list (thesis Table 4.1, Fig. 4.1b).
pub const DEFAULT_SPP: [usize; 4] = [20, 40, 60, 80];
/// Most repetitions per spp (a table of more would run for days).
pub const MAX_REPETITIONS: usize = 10_000;

/// Default repetitions per spp.
pub const DEFAULT_REPETITIONS: usize = 10;
/// Default spp of the MC reference (thesis §3.2.7).
pub const DEFAULT_REFERENCE_SPP: usize = 3000;
/// The reference's default seed is `mix(seed, [REFERENCE_SEED])`.
const REFERENCE_SEED: u64 = 0x2ef;

/// Reads and validates `path`.
pub fn load(path: &Path) -> Result<TablePlan, InputError> {
    let name = path.display().to_string();
    let text =
        std::fs::read_to_string(path).map_err(|e| InputError::new(format!("{name}: cannot read: {e}")))?;
    parse(&text, path)
}

/// Validates the text of a spec read from `path`.
pub fn parse(text: &str, path: &Path) -> Result<TablePlan, InputError> {
    let file = path.display().to_string();
    let root: Value = serde_json::from_str(text).map_err(|e| {
        InputError::new(format!(
            "{file}: invalid JSON at line {}, column {}: {e}",
            e.line(),
            e.column()
        ))
    })?;
    let cx = Cx { file: &file };
    let top = cx.object(&root, "$")?;
    cx.known(
        top,
        "$",
        &[
            "name",
            "seed",
            "width",
            "height",
            "env",
            "spp",
            "repetitions",
            "reference",
            "model",
            "variants",
        ],
    )?;

    let name = cx.string(cx.required(top, "$", "name")?, "$.name")?;
    if name.is_empty()
        || !name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
    {
        return Err(cx.err(
            "$.name",
            &Value::String(name),
            "must be non-empty and use only A–Z, a–z, 0–9, - and _ (it names the output folder)",
        ));
    }
    let seed = cx.opt(top, "seed", |v| cx.uint(v, "$.seed"))?.unwrap_or(0);
    let width = cx.opt(top, "width", |v| cx.uint(v, "$.width"))?.unwrap_or(256) as usize;
    let height = cx.opt(top, "height", |v| cx.uint(v, "$.height"))?.unwrap_or(256) as usize;
    check_size(width, height).map_err(|e| {
        InputError::new(format!(
            "{file}: $.width/$.height: {}",
            e.0.trim_start_matches("--width/--height: ")
        ))
    })?;
    let env_arg = cx
        .opt(top, "env", |v| cx.string(v, "$.env"))?
        .unwrap_or_else(|| "sky".into());
    let env =
        Environment::from_arg(&env_arg).map_err(|e| InputError::new(format!("{file}: $.env: {}", e.0)))?;

    let spp: Vec<usize> = match top.get("spp") {
        None => DEFAULT_SPP.to_vec(),
        Some(v) => {
            let items = cx.array(v, "$.spp")?;
            if items.is_empty() {
                return Err(cx.err("$.spp", v, "must list at least one sample count"));
            }
            let mut out = Vec::new();
            for (k, item) in items.iter().enumerate() {
                let p = format!("$.spp[{k}]");
                let n = cx.uint(item, &p)? as usize;
                if n == 0 {
                    return Err(cx.err(&p, item, "must be at least 1"));
                }
                if out.contains(&n) {
                    return Err(cx.err(&p, item, "appears twice"));
                }
                out.push(n);
            }
            out
        }
    };
    let repetitions: Vec<usize> = match top.get("repetitions") {
        None => vec![DEFAULT_REPETITIONS; spp.len()],
        Some(v @ Value::Array(items)) => {
            if items.len() != spp.len() {
                return Err(cx.err(
                    "$.repetitions",
                    v,
                    &format!(
                        "needs one count per entry of $.spp ({}), or one number",
                        spp.len()
                    ),
                ));
            }
            items
                .iter()
                .enumerate()
                .map(|(k, item)| cx.positive(item, &format!("$.repetitions[{k}]")))
                .collect::<Result<_, _>>()?
        }
        Some(v) => vec![cx.positive(v, "$.repetitions")?; spp.len()],
    };
    if let Some(k) = repetitions.iter().position(|&r| r > MAX_REPETITIONS) {
        let path = match top.get("repetitions") {
            Some(Value::Array(_)) => format!("$.repetitions[{k}]"),
            _ => "$.repetitions".to_string(),
        };
        return Err(cx.err(
            &path,
            &(repetitions[k] as u64).into(),
            &format!("at most {MAX_REPETITIONS} renders per spp"),
        ));
    }

    let reference = match top.get("reference") {
        None => ReferencePlan {
            spp: DEFAULT_REFERENCE_SPP,
            seed: crate::rng::mix(seed, &[REFERENCE_SEED]),
        },
        Some(v) => {
            let obj = cx.object(v, "$.reference")?;
            cx.known(obj, "$.reference", &["spp", "seed"])?;
            ReferencePlan {
                spp: cx
                    .opt(obj, "spp", |v| {
                        let n = cx.positive(v, "$.reference.spp")?;
                        if n > super::cli::MAX_MC_SPP {
                            let msg = format!("at most {} samples per pixel", super::cli::MAX_MC_SPP);
                            return Err(cx.err("$.reference.spp", v, &msg));
                        }
                        Ok(n)
                    })?
                    .unwrap_or(DEFAULT_REFERENCE_SPP),
                seed: cx
                    .opt(obj, "seed", |v| cx.uint(v, "$.reference.seed"))?
                    .unwrap_or_else(|| crate::rng::mix(seed, &[REFERENCE_SEED])),
            }
        }
    };

    let variants_value = cx.required(top, "$", "variants")?;
    let items = cx.array(variants_value, "$.variants")?;
    if items.is_empty() {
        return Err(cx.err("$.variants", variants_value, "must list at least one variant"));
    }
    let mut variants: Vec<VariantPlan> = Vec::new();
    for (k, item) in items.iter().enumerate() {
        let p = format!("$.variants[{k}]");
        let obj = cx.object(item, &p)?;
        cx.known(obj, &p, &["label", "integrator", "gps", "rotate"])?;
        let kind_value = cx.required(obj, &p, "integrator")?;
        let kind_path = format!("{p}.integrator");
        let kind_name = cx.string(kind_value, &kind_path)?;
        let kind = IntegratorKind::from_name(&kind_name).ok_or_else(|| {
            cx.err(
                &kind_path,
                kind_value,
                "unknown integrator; expected one of mc, mc-cos, bmc, bmcp",
            )
        })?;
        let label = match obj.get("label") {
            Some(v) => cx.string(v, &format!("{p}.label"))?,
            None => kind_name.clone(),
        };
        if label.is_empty() || variants.iter().any(|v| v.label == label) {
            return Err(cx.err(
                &format!("{p}.label"),
                &Value::String(label),
                "labels must be non-empty and unique",
            ));
        }
        // Labels name the PNG files: two that give the same file name would overwrite each other.
        let slug = super::table::png_name(&label, 0);
        if slug == "-0spp.png"
            || variants
                .iter()
                .any(|v| super::table::png_name(&v.label, 0) == slug)
        {
            return Err(cx.err(
                &format!("{p}.label"),
                &Value::String(label),
                "needs an ASCII letter or digit, and a file name (ASCII letters and digits, lower-cased) no other label has",
            ));
        }
        for key in ["gps", "rotate"] {
            if !kind.uses_sets()
                && let Some(v) = obj.get(key)
            {
                return Err(cx.err(
                    &format!("{p}.{key}"),
                    v,
                    &format!("applies only to bmc and bmcp, not {kind}"),
                ));
            }
        }
        let gps = if kind.uses_sets() {
            let gp = format!("{p}.gps");
            let n = cx.opt(obj, "gps", |v| cx.positive(v, &gp))?.unwrap_or(4);
            super::cli::check_gps(n, "gps").map_err(|e| InputError::new(format!("{file}: {gp}: {}", e.0)))?;
            n
        } else {
            0
        };
        let rotate = kind.uses_sets()
            && cx
                .opt(obj, "rotate", |v| cx.bool(v, &format!("{p}.rotate")))?
                .unwrap_or(true);
        for &n in &spp {
            super::cli::check_spp(kind, n, "spp")
                .map_err(|e| InputError::new(format!("{file}: $.spp with {p} ({kind}): {}", e.0)))?;
        }
        variants.push(VariantPlan {
            label,
            kind,
            gps,
            rotate,
        });
    }

    let (model, model_json) = model(&cx, top.get("model"), variants.iter().any(|v| v.kind.uses_sets()))?;
    Ok(TablePlan {
        file: path.to_path_buf(),
        name,
        seed,
        width,
        height,
        env,
        env_arg,
        spp,
        repetitions,
        reference,
        model,
        model_json,
        variants,
    })
}

/// The `model` object: kernel, its parameters, noise and kernel-mean mode (defaults: Sobolev
/// `s = 1.4`, noise 0.01, exact kernel means).
fn model(cx: &Cx, value: Option<&Value>, needed: bool) -> Result<(Option<BmcModel>, Value), InputError> {
    let empty = Map::new();
    let obj = match value {
        Some(v) => cx.object(v, "$.model")?,
        None => &empty,
    };
    cx.known(
        obj,
        "$.model",
        &[
            "kernel",
            "s",
            "sigma",
            "length",
            "noise",
            "kernel_mean",
            "kernel_mean_samples",
        ],
    )?;
    let kernel_name = cx
        .opt(obj, "kernel", |v| cx.string(v, "$.model.kernel"))?
        .unwrap_or_else(|| "sobolev".into());
    let num = |key: &str| cx.opt(obj, key, |v| cx.number(v, &format!("$.model.{key}")));
    let kernel = match kernel_name.as_str() {
        "sobolev" => {
            for key in ["sigma", "length"] {
                if let Some(v) = obj.get(key) {
                    return Err(cx.err(&format!("$.model.{key}"), v, "applies only to the se kernel"));
                }
            }
            let s = num("s")?.unwrap_or(Sobolev::DEFAULT_S);
            Sobolev::new(s)
                .map(Kernel::Sobolev)
                .map_err(|e| cx.err("$.model.s", &s.into(), &e.to_string()))?
        }
        "se" => {
            if let Some(v) = obj.get("s") {
                return Err(cx.err("$.model.s", v, "applies only to the sobolev kernel"));
            }
            let (sigma, length) = (num("sigma")?.unwrap_or(1.0), num("length")?.unwrap_or(0.5));
            SquaredExponential::new(sigma, length)
                .map(Kernel::SquaredExponential)
                .map_err(|e| {
                    cx.err(
                        "$.model",
                        &serde_json::json!({"sigma": sigma, "length": length}),
                        &e.to_string(),
                    )
                })?
        }
        _ => return Err(cx.err("$.model.kernel", &obj["kernel"], "expected sobolev or se")),
    };
    let noise = num("noise")?.unwrap_or(DEFAULT_NOISE);
    let noise = validate_noise(noise).map_err(|m| cx.err("$.model.noise", &noise.into(), &m))?;
    let mode_name = cx
        .opt(obj, "kernel_mean", |v| cx.string(v, "$.model.kernel_mean"))?
        .unwrap_or_else(|| "exact".into());
    let samples = cx.opt(obj, "kernel_mean_samples", |v| {
        cx.positive(v, "$.model.kernel_mean_samples")
    })?;
    let mode = match mode_name.as_str() {
        "exact" => {
            if let Some(v) = obj.get("kernel_mean_samples") {
                return Err(cx.err(
                    "$.model.kernel_mean_samples",
                    v,
                    "applies only to \"kernel_mean\": \"mc\"",
                ));
            }
            KernelMeanMode::Exact
        }
        "mc" => {
            let m = samples.unwrap_or(KernelMeanMode::THESIS_SAMPLES);
            KernelMeanMode::monte_carlo(m as u64)
                .map_err(|msg| cx.err("$.model.kernel_mean_samples", &(m as u64).into(), &msg))?
        }
        _ => return Err(cx.err("$.model.kernel_mean", &obj["kernel_mean"], "expected exact or mc")),
    };
    let mut json = serde_json::json!({"kernel": kernel.to_json(), "noise": noise, "kernel_mean": mode_name});
    if let KernelMeanMode::MonteCarlo { samples } = mode {
        json["kernel_mean_samples"] = samples.into();
    }
    let model = needed.then(|| BmcModel::new(kernel, noise, mode));
    if let Some(w) = model.as_ref().and_then(|m| m.accuracy_warning()) {
        crate::status!("warning: {w}");
    }
    Ok((model, json))
}

/// Validation context: the file name for messages.
struct Cx<'a> {
    file: &'a str,
}

impl Cx<'_> {
    /// `file: path = value: message`, on one line.
    fn err(&self, path: &str, value: &Value, message: &str) -> InputError {
        let mut shown = value.to_string();
        if shown.len() > 60 {
            shown.truncate(57);
            shown.push_str("...");
        }
        InputError::new(format!("{}: {path} = {shown}: {message}", self.file))
    }

    fn object<'v>(&self, v: &'v Value, path: &str) -> Result<&'v Map<String, Value>, InputError> {
        v.as_object()
            .ok_or_else(|| self.err(path, v, "expected an object"))
    }

    fn array<'v>(&self, v: &'v Value, path: &str) -> Result<&'v Vec<Value>, InputError> {
        v.as_array().ok_or_else(|| self.err(path, v, "expected an array"))
    }

    fn known(&self, obj: &Map<String, Value>, path: &str, fields: &[&str]) -> Result<(), InputError> {
        match obj.iter().find(|(k, _)| !fields.contains(&k.as_str())) {
            Some((k, v)) => Err(self.err(
                &format!("{path}.{k}"),
                v,
                &format!("unknown field; expected one of {}", fields.join(", ")),
            )),
            None => Ok(()),
        }
    }

    fn required<'v>(
        &self,
        obj: &'v Map<String, Value>,
        path: &str,
        key: &str,
    ) -> Result<&'v Value, InputError> {
        obj.get(key)
            .ok_or_else(|| InputError::new(format!("{}: {path}.{key}: missing (required)", self.file)))
    }

    fn opt<T>(
        &self,
        obj: &Map<String, Value>,
        key: &str,
        f: impl FnOnce(&Value) -> Result<T, InputError>,
    ) -> Result<Option<T>, InputError> {
        obj.get(key).map(f).transpose()
    }

    fn string(&self, v: &Value, path: &str) -> Result<String, InputError> {
        v.as_str()
            .map(str::to_owned)
            .ok_or_else(|| self.err(path, v, "expected a string"))
    }

    fn bool(&self, v: &Value, path: &str) -> Result<bool, InputError> {
        v.as_bool()
            .ok_or_else(|| self.err(path, v, "expected true or false"))
    }

    fn number(&self, v: &Value, path: &str) -> Result<f64, InputError> {
        v.as_f64().ok_or_else(|| self.err(path, v, "expected a number"))
    }

    fn uint(&self, v: &Value, path: &str) -> Result<u64, InputError> {
        v.as_u64()
            .ok_or_else(|| self.err(path, v, "expected a non-negative integer"))
    }

    fn positive(&self, v: &Value, path: &str) -> Result<usize, InputError> {
        match v.as_u64() {
            Some(n) if n >= 1 => Ok(n as usize),
            _ => Err(self.err(path, v, "expected an integer >= 1")),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn err(text: &str) -> String {
        parse(text, Path::new("t.json")).unwrap_err().0
    }

    #[test]
    fn defaults_are_filled_in() {
        let p = parse(
            r#"{"name": "t", "variants": [{"integrator": "mc"}, {"integrator": "bmc"}]}"#,
            Path::new("t.json"),
        )
        .unwrap();
        assert_eq!(p.spp, DEFAULT_SPP);
        assert_eq!(p.repetitions, vec![DEFAULT_REPETITIONS; 4]);
        assert_eq!((p.width, p.height, p.reference.spp), (256, 256, 3000));
        assert_eq!(
            p.variants[0],
            VariantPlan {
                label: "mc".into(),
                kind: IntegratorKind::Mc,
                gps: 0,
                rotate: false
            }
        );
        assert_eq!(
            p.variants[1],
            VariantPlan {
                label: "bmc".into(),
                kind: IntegratorKind::Bmc,
                gps: 4,
                rotate: true
            }
        );
        assert!(p.model.is_some());
    }

    #[test]
    fn errors_name_file_path_and_value() {
        let base = r#""name": "t", "variants": [{"integrator": "mc"}]"#;
        assert_eq!(
            err(&format!("{{{base}, \"colour\": 1}}")),
            "t.json: $.colour = 1: unknown field; expected one of name, seed, width, height, env, spp, repetitions, reference, model, variants"
        );
        assert_eq!(
            err(r#"{"name": "t", "variants": [{"integrator": "bmx"}]}"#),
            "t.json: $.variants[0].integrator = \"bmx\": unknown integrator; expected one of mc, mc-cos, bmc, bmcp"
        );
        assert!(
            err(&format!("{{{base}, \"spp\": [20, 0]}}"))
                .starts_with("t.json: $.spp[1] = 0: must be at least 1")
        );
        assert!(
            err(&format!("{{{base}, \"repetitions\": [1, 2]}}"))
                .starts_with("t.json: $.repetitions = [1,2]: needs one count")
        );
        assert!(
            err(r#"{"name": "t", "variants": [{"integrator": "mc", "gps": 2}]}"#)
                .starts_with("t.json: $.variants[0].gps = 2: applies only")
        );
        assert!(
            err(&format!("{{{base}, \"model\": {{\"noise\": -1}}}}"))
                .starts_with("t.json: $.model.noise = -1.0: noise must be")
        );
        assert!(
            err(&format!("{{{base}, \"model\": {{\"s\": 3}}}}"))
                .starts_with("t.json: $.model.s = 3.0: sobolev kernel: s must be")
        );
        assert!(
            err(&format!("{{{base}, \"width\": 100000, \"height\": 100000}}")).contains("$.width/$.height")
        );
        assert!(
            err(&format!("{{{base}, \"env\": \"missing.hdr\"}}"))
                .starts_with("t.json: $.env: --env missing.hdr: cannot read")
        );
        assert!(
            err(&format!("{{{base}, \"reference\": {{\"spp\": 0}}}}"))
                .starts_with("t.json: $.reference.spp = 0:")
        );
        assert!(err(r#"{"variants": []}"#).starts_with("t.json: $.name: missing"));
        assert!(err(r#"{"name": "t", "variants": []}"#).starts_with("t.json: $.variants = []: must list"));
        assert!(err(r#"{"name": "a/b", "variants": []}"#).starts_with("t.json: $.name = \"a/b\""));
        assert!(err("{").starts_with("t.json: invalid JSON at line 1"));
        assert!(
            err(r#"{"name": "t", "variants": [{"integrator": "mc"}, {"integrator": "mc"}]}"#)
                .contains("unique")
        );
        assert!(err(r#"{"name": "t", "spp": [20000], "variants": [{"integrator": "bmc"}]}"#).contains("GiB"));
    }
}
