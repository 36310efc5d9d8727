//! Images made elsewhere beside a table: another renderer's reference, against which every
//! render is also measured, and its own renders, measured against both references
//! (`"external"` in a render table; docs/guide/thesis-images.md).
//!
//! The measures are the RMSE over pixels × channels ([`Image::rmse`]) and the thesis code's
//! mean per-pixel RGB L2 norm ([`Image::mean_l2`]).

use super::spec::ExternalSpec;
use crate::render::image::Image;
use std::path::PathBuf;

/// The external images, read and checked against the table's size.
#[derive(Clone, Debug)]
pub struct ExternalPlan {
    /// The reference as the spec names it, and the file it resolved to.
    pub reference_arg: String,
    pub reference_path: PathBuf,
    pub reference: Image,
    pub images: Vec<ExternalImage>,
}

/// One render made elsewhere.
#[derive(Clone, Debug)]
pub struct ExternalImage {
    pub label: String,
    pub arg: String,
    pub path: PathBuf,
    pub image: Image,
}

/// A render's measures against the external reference, and its mean L2 against the table's.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ExternalMeasures {
    pub rmse_theirs: f64,
    pub mean_l2_theirs: f64,
    pub mean_l2_ours: f64,
}

impl ExternalMeasures {
    pub fn of(image: &Image, theirs: &Image, ours: &Image) -> Self {
        ExternalMeasures {
            rmse_theirs: image.rmse(theirs),
            mean_l2_theirs: image.mean_l2(theirs),
            mean_l2_ours: image.mean_l2(ours),
        }
    }
}

/// The file an `"external"` image names: a path, or a catalogue image (`thesis-mc3000`) in the
/// data folder, verified against its size and sha256 ([`crate::data`]).
pub fn image_file(arg: &str) -> Result<PathBuf, String> {
    use crate::data::{DataError, Kind, Source};
    match crate::data::resolve(arg, Kind::Image).map_err(|e| format!("{arg}: {}", e.reason()))? {
        Source::Path(path) => Ok(path),
        Source::Entry(entry) => crate::data::folder()
            .and_then(|folder| folder.ok_or(DataError::NoFolder { entry }))
            .and_then(|folder| crate::data::check(&folder, entry))
            .map_err(|e| format!("{arg}: {}", e.reason())),
    }
}

/// Reads the spec's images; `resolve` turns a name or path into a file (the data catalogue),
/// errors name the field.
pub fn resolve(
    spec: &ExternalSpec,
    width: usize,
    height: usize,
    resolve: &dyn Fn(&str) -> Result<PathBuf, String>,
) -> Result<ExternalPlan, String> {
    let read = |arg: &str, field: &str| -> Result<(PathBuf, Image), String> {
        let path = resolve(arg).map_err(|m| format!("{field}: {m}"))?;
        let image = Image::read_reference(&path, field, width, height).map_err(|e| e.0)?;
        Ok((path, image))
    };
    let (reference_path, reference) = read(&spec.reference, "external.reference")?;
    let mut images = Vec::new();
    for (k, i) in spec.images.iter().flatten().enumerate() {
        let field = format!("external.images[{k}].image");
        if i.label.trim().is_empty() {
            return Err(format!("external.images[{k}].label: must not be empty"));
        }
        if images.iter().any(|x: &ExternalImage| x.label == i.label) {
            return Err(format!("external.images[{k}].label: {:?} is used twice", i.label));
        }
        let (path, image) = read(&i.image, &field)?;
        images.push(ExternalImage {
            label: i.label.clone(),
            arg: i.image.clone(),
            path,
            image,
        });
    }
    Ok(ExternalPlan {
        reference_arg: spec.reference.clone(),
        reference_path,
        reference,
        images,
    })
}

/// `external.csv`: per external image, its label and name, RMSE and mean L2 against the
/// external reference and against the table's reference (the first line: the external
/// reference itself against the table's).
pub fn external_csv(plan: &ExternalPlan, ours: &Image) -> Vec<u8> {
    let mut w = csv::Writer::from_writer(Vec::new());
    w.write_record([
        "label",
        "image",
        "rmse_theirs",
        "mean_l2_theirs",
        "rmse_ours",
        "mean_l2_ours",
    ])
    .expect("writing CSV to memory");
    let mut row = |label: &str, arg: &str, image: &Image| {
        w.write_record([
            label.to_string(),
            arg.to_string(),
            format!("{:?}", image.rmse(&plan.reference)),
            format!("{:?}", image.mean_l2(&plan.reference)),
            format!("{:?}", image.rmse(ours)),
            format!("{:?}", image.mean_l2(ours)),
        ])
        .expect("writing CSV to memory");
    };
    row("their reference", &plan.reference_arg, &plan.reference);
    for i in &plan.images {
        row(&i.label, &i.arg, &i.image);
    }
    w.into_inner().expect("writing CSV to memory")
}

/// The Markdown section of `table.md` listing the external images' measures.
pub fn external_md(plan: &ExternalPlan, ours: &Image) -> String {
    let mut s = format!(
        "\nImages made elsewhere, against their reference ({}) and against this table's:\n\n\
         | Image | RMSE vs theirs | mean L2 vs theirs | RMSE vs ours | mean L2 vs ours |\n\
         |---|---:|---:|---:|---:|\n",
        plan.reference_arg
    );
    let mut row = |label: &str, image: &Image| {
        s.push_str(&format!(
            "| {label} | {:.5} | {:.5} | {:.5} | {:.5} |\n",
            image.rmse(&plan.reference),
            image.mean_l2(&plan.reference),
            image.rmse(ours),
            image.mean_l2(ours)
        ));
    };
    row("their reference", &plan.reference);
    for i in &plan.images {
        row(&i.label, &i.image);
    }
    s
}
