//! `workbench schema`: the committed schemas are what the binary prints, every shipped file
//! validates against its schema (checked by an independent validator, the `jsonschema` crate),
//! and bad files fail both the schema and `workbench validate`.

use crate::common::{stderr, stdout, workbench};
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use workbench::schema::SchemaKind;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn read_json(path: &Path) -> Value {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn validator(kind: SchemaKind) -> jsonschema::Validator {
    let schema = read_json(&root().join(kind.shipped_path()));
    jsonschema::draft202012::new(&schema).expect("the schema compiles")
}

/// The kind of a shipped file: render tables have `variants`.
fn kind_of(file: &Value) -> SchemaKind {
    if file.get("variants").is_some() {
        SchemaKind::RenderTable
    } else if file.get("kind").and_then(|k| k.as_str()) == Some("irradiance") {
        SchemaKind::Irradiance
    } else {
        SchemaKind::Experiment
    }
}

fn shipped_files() -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(root().join("experiments"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "json"))
        .collect();
    files.sort();
    files
}

#[test]
fn committed_schemas_are_what_the_binary_prints() {
    for kind in SchemaKind::ALL {
        let out = workbench(&root(), &["schema", kind.name()]);
        assert!(out.status.success(), "{}", stderr(&out));
        let committed = std::fs::read_to_string(root().join(kind.shipped_path())).unwrap();
        assert!(
            stdout(&out) == committed,
            "{} is out of date: run `workbench schema {} --out {}`",
            kind.shipped_path(),
            kind.name(),
            kind.shipped_path()
        );
    }
}

#[test]
fn every_shipped_file_names_and_follows_its_schema() {
    let files = shipped_files();
    assert!(files.len() >= 10, "found only {} shipped files", files.len());
    for path in files {
        let file = read_json(&path);
        let kind = kind_of(&file);
        let expected = format!("../{}", kind.shipped_path());
        assert_eq!(
            file["$schema"],
            json!(expected),
            "{}: \"$schema\"",
            path.display()
        );
        // The relative path resolves from the file's folder.
        assert!(path.parent().unwrap().join(&expected).is_file(), "{expected}");
        let errors: Vec<String> = validator(kind)
            .iter_errors(&file)
            .map(|e| e.to_string())
            .collect();
        assert!(errors.is_empty(), "{}: {errors:?}", path.display());
    }
}

/// What a bad-file case does to a good file.
type Breaks = Box<dyn Fn(&mut Value)>;

/// A valid file to break one field at a time.
fn good_experiment() -> Value {
    json!({
        "$schema": "../schema/experiment.schema.json",
        "name": "schema-test",
        "integrands": ["cos3", {"type": "lobe", "axis": [0, 0, 1], "exponent": 8}],
        "estimators": [
            {"label": "MC", "method": "mc"},
            {"label": "BMC", "method": "bmc", "design": "sobol", "scale": "ml",
             "kernel": {"type": "sobolev", "s": 1.4}}
        ],
        "samples": [8, 16],
        "trials": 3,
        "seed": 1
    })
}

fn good_table() -> Value {
    json!({
        "name": "schema-test",
        "spp": [8],
        "repetitions": [2],
        "reference": {"method": "mc", "spp": 16},
        "variants": [{"integrator": "bmc", "gps": 2}, {"integrator": "mc-cos"}]
    })
}

/// Both the schema and `workbench validate` refuse `file`.
fn assert_refused(kind: SchemaKind, file: &Value, what: &str) {
    assert!(!validator(kind).is_valid(file), "the schema accepts {what}");
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.json");
    std::fs::write(&path, serde_json::to_vec_pretty(file).unwrap()).unwrap();
    let out = workbench(dir.path(), &["validate", "bad.json"]);
    assert_eq!(
        out.status.code(),
        Some(2),
        "validate accepts {what}: {}",
        stdout(&out)
    );
}

#[test]
fn good_files_pass_both_the_schema_and_validate() {
    for (kind, file) in [
        (SchemaKind::Experiment, good_experiment()),
        (SchemaKind::RenderTable, good_table()),
    ] {
        let errors: Vec<String> = validator(kind)
            .iter_errors(&file)
            .map(|e| e.to_string())
            .collect();
        assert!(errors.is_empty(), "{errors:?}");
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("good.json"), serde_json::to_vec(&file).unwrap()).unwrap();
        let out = workbench(dir.path(), &["validate", "good.json"]);
        assert!(out.status.success(), "{}", stderr(&out));
    }
}

#[test]
fn bad_experiments_fail_the_schema() {
    let cases: Vec<(&str, Breaks)> = vec![
        (
            "an unknown top-level field",
            Box::new(|f| f["sample"] = json!([8])),
        ),
        (
            "an unknown estimator field",
            Box::new(|f| f["estimators"][0]["nosie"] = json!(0.1)),
        ),
        (
            "an unknown method",
            Box::new(|f| f["estimators"][0]["method"] = json!("qmc")),
        ),
        (
            "an unknown design",
            Box::new(|f| f["estimators"][1]["design"] = json!("halton")),
        ),
        (
            "an unknown scale",
            Box::new(|f| f["estimators"][1]["scale"] = json!("mle")),
        ),
        ("samples as a string", Box::new(|f| f["samples"] = json!("8,16"))),
        ("N = 0", Box::new(|f| f["samples"] = json!([0, 16]))),
        ("no samples", Box::new(|f| f["samples"] = json!([]))),
        ("trials = 0", Box::new(|f| f["trials"] = json!(0))),
        ("a negative seed", Box::new(|f| f["seed"] = json!(-1))),
        (
            "a lobe without an axis",
            Box::new(|f| f["integrands"][1] = json!({"type": "lobe", "exponent": 8})),
        ),
        (
            "an unknown family",
            Box::new(|f| f["integrands"][1] = json!({"type": "disc", "axis": [0, 0, 1]})),
        ),
        (
            "an unknown kernel",
            Box::new(|f| f["estimators"][1]["kernel"] = json!({"type": "matern"})),
        ),
        (
            "a folder name with a slash",
            Box::new(|f| f["name"] = json!("../elsewhere")),
        ),
    ];
    for (what, breaks) in cases {
        let mut file = good_experiment();
        breaks(&mut file);
        assert_refused(SchemaKind::Experiment, &file, what);
    }
}

#[test]
fn bad_render_tables_fail_the_schema() {
    let cases: Vec<(&str, Breaks)> = vec![
        ("an unknown field", Box::new(|f| f["resolution"] = json!(64))),
        (
            "an unknown integrator",
            Box::new(|f| f["variants"][0]["integrator"] = json!("path")),
        ),
        (
            "an unknown reference method",
            Box::new(|f| f["reference"]["method"] = json!("bdpt")),
        ),
        (
            "repetitions as a string",
            Box::new(|f| f["repetitions"] = json!("ten")),
        ),
        (
            "no variants",
            Box::new(|f| f.as_object_mut().unwrap().remove("variants").map(drop).unwrap()),
        ),
    ];
    for (what, breaks) in cases {
        let mut file = good_table();
        breaks(&mut file);
        assert_refused(SchemaKind::RenderTable, &file, what);
    }
}

#[test]
fn an_experiment_is_not_a_render_table() {
    assert!(!validator(SchemaKind::RenderTable).is_valid(&good_experiment()));
    assert!(!validator(SchemaKind::Experiment).is_valid(&good_table()));
}
