//! JSON Schemas (draft 2020-12) of the two input files, generated from the spec types that
//! parse them, so that the schema cannot drift from what `run`, `render` and `validate` accept.
//!
//! The schema checks structure: field names, types and the names of methods, designs and
//! integrators. What depends on several fields at once (a check naming an existing label, an
//! N too large for memory, a prior only on BMCP) is left to `workbench validate`. The shipped
//! files name their schema in `"$schema"` (a path relative to the file), which editors use for
//! completion and inline errors; the tool ignores that field.

use crate::experiment::spec::ExperimentSpec;
use crate::render::integrator::IntegratorKind;
use crate::sampling::Design;
use crate::table::spec::TableSpec;
use schemars::{JsonSchema, Schema, SchemaGenerator, json_schema};
use std::borrow::Cow;

/// The files a schema is generated for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SchemaKind {
    /// Experiment files (`workbench run`).
    Experiment,
    /// Render tables (`workbench render SPEC.json`).
    RenderTable,
    /// Irradiance protocol files (`workbench run`, `"kind": "irradiance"`).
    Irradiance,
}

impl SchemaKind {
    /// Every kind, in the order of the docs.
    pub const ALL: [SchemaKind; 3] = [
        SchemaKind::Experiment,
        SchemaKind::RenderTable,
        SchemaKind::Irradiance,
    ];

    /// The name on the command line (`workbench schema <name>`).
    pub fn name(self) -> &'static str {
        match self {
            SchemaKind::Experiment => "experiment",
            SchemaKind::RenderTable => "render-table",
            SchemaKind::Irradiance => "irradiance",
        }
    }

    /// Parses [`SchemaKind::name`].
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.name() == name)
    }

    /// Where the project keeps this schema, relative to the repository root; the shipped
    /// files' `"$schema"` points here.
    pub fn shipped_path(self) -> &'static str {
        match self {
            SchemaKind::Experiment => "schema/experiment.schema.json",
            SchemaKind::RenderTable => "schema/render-table.schema.json",
            SchemaKind::Irradiance => "schema/irradiance.schema.json",
        }
    }

    /// The schema as a JSON value.
    pub fn schema(self) -> serde_json::Value {
        let schema = match self {
            SchemaKind::Experiment => schemars::schema_for!(ExperimentSpec),
            SchemaKind::RenderTable => schemars::schema_for!(TableSpec),
            SchemaKind::Irradiance => schemars::schema_for!(crate::irradiance::IrradianceSpec),
        };
        schema.to_value()
    }

    /// The schema as written to files and stdout: pretty-printed, with a final newline.
    pub fn text(self) -> String {
        let mut text = serde_json::to_string_pretty(&self.schema()).expect("a schema serialises");
        text.push('\n');
        text
    }
}

/// A string that must be one of `names`.
fn one_of_names(description: &str, names: Vec<String>) -> Schema {
    json_schema!({
        "type": "string",
        "enum": names,
        "description": description,
    })
}

/// By name, as [`Design`]'s hand-written serde does; the names come from [`Design::ALL`].
impl JsonSchema for Design {
    fn schema_name() -> Cow<'static, str> {
        "Design".into()
    }

    fn json_schema(_: &mut SchemaGenerator) -> Schema {
        one_of_names(
            "How a sample set is drawn (math.md §2).",
            Design::ALL.iter().map(|d| d.name().to_string()).collect(),
        )
    }
}

/// By name, as [`IntegratorKind`]'s hand-written serde does; the names come from
/// [`IntegratorKind::all`].
impl JsonSchema for IntegratorKind {
    fn schema_name() -> Cow<'static, str> {
        "IntegratorKind".into()
    }

    fn json_schema(_: &mut SchemaGenerator) -> Schema {
        one_of_names(
            "The renderer's per-pixel estimator.",
            IntegratorKind::all().iter().map(|k| k.name()).collect(),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn schemas_are_draft_2020_12_and_name_the_closed_sets() {
        for kind in SchemaKind::ALL {
            let schema = kind.schema();
            assert_eq!(schema["$schema"], "https://json-schema.org/draft/2020-12/schema");
            assert_eq!(SchemaKind::from_name(kind.name()), Some(kind));
        }
        let text = SchemaKind::Experiment.text();
        for design in Design::ALL {
            assert!(
                text.contains(&format!("\"{}\"", design.name())),
                "{design} missing"
            );
        }
        let table = SchemaKind::RenderTable.text();
        for kind in IntegratorKind::all() {
            assert!(table.contains(&format!("\"{}\"", kind.name())), "{kind} missing");
        }
    }
}
