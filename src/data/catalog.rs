//! The catalogue of external files (`data/catalog.json`, embedded at build time): every file the
//! workbench can read from a data folder, by short name, with its path relative to the folder,
//! size, sha256, source and terms. Nothing it lists is in the repository.

use serde::Deserialize;
use std::sync::OnceLock;

/// What a catalogue file is; `map`s can be named wherever an environment map is expected.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Kind {
    /// A lat-long environment map (`.hdr`/`.exr`).
    Map,
    /// A rendered image (a reference or someone's render).
    Image,
    /// A CSV table.
    Table,
    /// A scene description (Mitsuba XML).
    Scene,
    /// A mesh a scene loads.
    Mesh,
    /// A texture a scene loads.
    Texture,
}

impl Kind {
    /// `map`, `image`, … as in the catalogue.
    pub fn name(self) -> &'static str {
        match self {
            Kind::Map => "map",
            Kind::Image => "image",
            Kind::Table => "table",
            Kind::Scene => "scene",
            Kind::Mesh => "mesh",
            Kind::Texture => "texture",
        }
    }
}

/// One external file.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Entry {
    /// Short name: `pisa`, `thesis-mc3000`, ….
    pub name: String,
    pub kind: Kind,
    /// Relative to the data folder, `/`-separated.
    pub path: String,
    /// Size in bytes.
    pub bytes: u64,
    /// The full sha256, lower-case hex.
    pub sha256: String,
    /// What the file is, in a few words.
    pub what: String,
    /// Where it comes from (and so where to obtain it).
    pub source: String,
    /// The terms it is used under.
    pub terms: String,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CatalogFile {
    #[allow(dead_code)]
    about: String,
    files: Vec<Entry>,
}

/// The catalogue's text, as committed.
pub const CATALOG_JSON: &str = include_str!("../../data/catalog.json");

/// Every entry, in the catalogue's order (parsed once; the tests check it parses).
pub fn entries() -> &'static [Entry] {
    static ENTRIES: OnceLock<Vec<Entry>> = OnceLock::new();
    ENTRIES.get_or_init(|| {
        let file: CatalogFile =
            serde_json::from_str(CATALOG_JSON).expect("data/catalog.json is valid (tested)");
        file.files
    })
}

/// The entry called `name`.
pub fn find(name: &str) -> Option<&'static Entry> {
    entries().iter().find(|e| e.name == name)
}

/// The names of the entries of `kind`, in the catalogue's order.
pub fn names(kind: Kind) -> Vec<&'static str> {
    entries()
        .iter()
        .filter(|e| e.kind == kind)
        .map(|e| e.name.as_str())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashSet;

    /// Names and paths are unique, paths are relative and clean, checksums are full sha256.
    #[test]
    fn the_catalogue_is_well_formed() {
        let all = entries();
        assert!(all.len() >= 30, "{}", all.len());
        let unique_names: HashSet<_> = all.iter().map(|e| &e.name).collect();
        let paths: HashSet<_> = all.iter().map(|e| &e.path).collect();
        assert_eq!((unique_names.len(), paths.len()), (all.len(), all.len()));
        for e in all {
            assert!(
                e.name
                    .bytes()
                    .all(|b| b.is_ascii_lowercase() || b.is_ascii_digit() || b == b'-'),
                "{}",
                e.name
            );
            assert!(
                !e.path.starts_with('/') && !e.path.split('/').any(|p| p.is_empty() || p == "." || p == ".."),
                "{}",
                e.path
            );
            assert!(
                e.sha256.len() == 64
                    && e.sha256
                        .bytes()
                        .all(|b| b.is_ascii_digit() || (b'a'..=b'f').contains(&b)),
                "{}",
                e.name
            );
            assert!(e.bytes > 0 && !e.source.is_empty() && !e.terms.is_empty());
        }
        // The words `sky` and `white` are the procedural environments, never a file.
        assert!(find("sky").is_none() && find("white").is_none());
        assert_eq!(find("pisa").unwrap().path, "envmaps/debevec/pisa_1024x512.hdr");
        assert!(names(Kind::Map).starts_with(&["pisa", "pisa-256", "grace", "archi"]));
    }
}
