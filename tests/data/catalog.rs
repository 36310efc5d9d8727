//! The catalogue against the real data folder: every file present with its size and sha256,
//! every map loads (with the facts `../shared/data/README.md` states about it), maps named by
//! catalogue name render exactly as by path, `workbench data` is content.

use crate::{Data, Test};
use sha2::{Digest, Sha256};
use workbench::data::{Kind, catalog};
use workbench::render::env::{EnvMap, decode_hdr_image};

pub const TESTS: &[Test] = &[
    (
        "every_file_is_present_with_its_size_and_sha256",
        every_file_is_present_with_its_size_and_sha256,
    ),
    (
        "every_file_of_the_folder_is_catalogued",
        every_file_of_the_folder_is_catalogued,
    ),
    ("every_map_loads", every_map_loads),
    (
        "workbench_data_exits_0_on_the_folder",
        workbench_data_exits_0_on_the_folder,
    ),
    (
        "a_map_by_name_renders_as_by_path",
        a_map_by_name_renders_as_by_path,
    ),
    (
        "an_altered_copy_is_refused_by_checksum",
        an_altered_copy_is_refused_by_checksum,
    ),
];

/// Computed here with `std::fs::read` and `sha2` directly, not through the module under test.
fn every_file_is_present_with_its_size_and_sha256(data: &Data) {
    for e in catalog::entries() {
        let bytes = std::fs::read(data.dir.join(&e.path)).unwrap_or_else(|err| panic!("{}: {err}", e.path));
        assert_eq!(bytes.len() as u64, e.bytes, "{}", e.path);
        let sha: String = Sha256::digest(&bytes)
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect();
        assert_eq!(sha, e.sha256, "{}", e.path);
    }
}

/// Nothing in the folder (but its README) is left out of the catalogue.
fn every_file_of_the_folder_is_catalogued(data: &Data) {
    fn walk(dir: &std::path::Path, out: &mut Vec<std::path::PathBuf>) {
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                walk(&path, out);
            } else {
                out.push(path);
            }
        }
    }
    let mut files = Vec::new();
    walk(&data.dir, &mut files);
    let missing: Vec<String> = files
        .iter()
        .map(|p| {
            p.strip_prefix(&data.dir)
                .unwrap()
                .to_string_lossy()
                .replace('\\', "/")
        })
        .filter(|p| p != "README.md" && !catalog::entries().iter().any(|e| &e.path == p))
        .collect();
    assert!(missing.is_empty(), "not in data/catalog.json: {missing:?}");
}

/// Every map decodes and is accepted (finite, non-negative texels); the facts the data
/// folder's README states are checked: sizes, Pisa's peak and black nadir, Archi's clamp, the
/// test map's two values, the suns. Prints each map's size and peak texel.
fn every_map_loads(data: &Data) {
    for name in catalog::names(Kind::Map) {
        let bytes = workbench::data::read(data.entry(name)).unwrap_or_else(|e| panic!("{e}"));
        EnvMap::decode(name, &bytes).unwrap_or_else(|e| panic!("{e}"));
        let img = decode_hdr_image(&bytes).unwrap();
        let texels = img.as_raw();
        let peak = texels.iter().copied().fold(0f32, f32::max);
        let zeros =
            img.pixels().filter(|p| p.0 == [0.0; 3]).count() as f64 / (img.width() * img.height()) as f64;
        println!(
            "{name}: {}×{}, peak texel {peak:.4e}, {:.1}% black",
            img.width(),
            img.height(),
            100.0 * zeros
        );
        let size = (img.width(), img.height());
        match name {
            "pisa" => {
                assert_eq!(size, (1024, 512));
                assert!((peak - 6.81).abs() < 0.005, "pisa peak {peak}");
                assert!((zeros - 0.107).abs() < 0.0005, "pisa zeros {zeros}");
            }
            "pisa-256" | "grace" => assert_eq!(size, (256, 128)),
            "archi" => {
                assert_eq!(size, (1024, 512));
                // "nozero": no black texel, and clipped at 1. (The folder's README says "clamped to
                // [0.011, 1.0]"; the file has texels whose largest channel is 3.05e-5, so only
                // the top and the absence of black are checked.)
                let low = img
                    .pixels()
                    .map(|p| p.0.into_iter().fold(0f32, f32::max))
                    .fold(f32::INFINITY, f32::min);
                assert!(low > 0.0 && peak <= 1.0 + 1e-6, "archi range [{low}, {peak}]");
            }
            "black-and-white" => {
                assert_eq!(size, (256, 256));
                let (black, two) = (
                    texels.iter().filter(|&&v| v == 0.0).count(),
                    texels.iter().filter(|&&v| v == 2.0).count(),
                );
                // Half and half, to a row: the boundary row falls on the black side (129 rows
                // against 127).
                assert_eq!(black + two, texels.len(), "values other than 0 and 2");
                assert!(
                    black.abs_diff(two) <= 2 * 256 * 3,
                    "{black} black against {two} at 2"
                );
            }
            "park" | "polyhaven-sky" => {
                assert_eq!(size, (1024, 512));
                assert!((6e4..=2.1e5).contains(&peak), "{name} peak {peak}");
            }
            _ => {}
        }
    }
}

fn workbench_data_exits_0_on_the_folder(data: &Data) {
    let dir = tempfile::tempdir().unwrap();
    let o = data.workbench(dir.path(), &["data"]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{out}{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let n = catalog::entries().len();
    assert!(out.contains(&format!("{n} files: {n} intact, 0 not")), "{out}");
}

/// `--env pisa-256` and `--env <its path>` give the same bytes: naming a map changes nothing
/// but how it is found (the map's cache key is its texels').
fn a_map_by_name_renders_as_by_path(data: &Data) {
    let dir = tempfile::tempdir().unwrap();
    let path = data.path("pisa-256");
    let render = |env: &str, out: &str| {
        let o = data.workbench(
            dir.path(),
            &[
                "render", "-q", "--env", env, "--width", "16", "--height", "12", "--spp", "4", "--out", out,
            ],
        );
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        std::fs::read(dir.path().join(out)).unwrap()
    };
    assert_eq!(
        render("pisa-256", "a.exr"),
        render(path.to_str().unwrap(), "b.exr")
    );
}

/// A copy of a catalogue map with one byte changed, in a data folder of its own: refused by
/// checksum, naming the file, the expected sha256 and the source.
fn an_altered_copy_is_refused_by_checksum(data: &Data) {
    let dir = tempfile::tempdir().unwrap();
    let entry = data.entry("pisa-256");
    let copy = dir.path().join("data").join(&entry.path);
    std::fs::create_dir_all(copy.parent().unwrap()).unwrap();
    let mut bytes = std::fs::read(data.path("pisa-256")).unwrap();
    let last = bytes.len() - 1;
    bytes[last] ^= 1;
    std::fs::write(&copy, &bytes).unwrap();
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_workbench"))
        .args(["render", "--data", "data", "--env", "pisa-256", "--out", "a.exr"])
        .current_dir(dir.path())
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("altered") && err.contains(&entry.sha256) && err.contains(&entry.source),
        "{err}"
    );
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    assert!(!dir.path().join("a.exr").exists());
}
