//! `workbench schema`: the JSON Schema of experiment files, render tables or irradiance files.

use super::output::{status, stdout};
use std::path::PathBuf;
use std::process::ExitCode;
use workbench::files::file_set::FileSet;
use workbench::schema::SchemaKind;

/// Options of `workbench schema`.
#[derive(clap::Args, Debug)]
#[command(after_help = "Examples:\n  \
    workbench schema experiment > experiment.schema.json\n  \
    workbench schema render-table --out schema/render-table.schema.json\n\n\
    The shipped files name their schema in \"$schema\" (schema/*.schema.json in the repository), which \
    editors use for completion and inline errors. The schema checks structure (field names, types, \
    method, design and integrator names); `workbench validate` checks the rest.\n\n\
    Exit codes: 0 success; 2 any error.")]
pub struct SchemaArgs {
    /// Which files: `experiment` (workbench run), `render-table` (workbench render SPEC.json) or
    /// `irradiance` (workbench run, `"kind": "irradiance"`).
    #[arg(value_parser = kind_names())]
    kind: String,
    /// Write the schema here (atomically) instead of to stdout.
    #[arg(long)]
    out: Option<PathBuf>,
}

fn kind_names() -> Vec<&'static str> {
    SchemaKind::ALL.iter().map(|k| k.name()).collect()
}

pub fn schema(args: SchemaArgs) -> anyhow::Result<ExitCode> {
    let kind = SchemaKind::from_name(&args.kind).expect("clap checked the name");
    let text = kind.text();
    match &args.out {
        Some(path) => {
            let mut files = FileSet::lock(&[("--out", path.as_path())], "use another --out")?;
            files.stage(path, text.as_bytes())?;
            files.commit()?;
            status!("schema: {} → {}", kind.name(), path.display());
        }
        None => stdout(&text)?,
    }
    Ok(ExitCode::SUCCESS)
}
