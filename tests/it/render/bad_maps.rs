//! Bad environment maps and unreadable input files through the binary (issue 27 "Bad input",
//! issue 30 item 2): each is exit 2 with one line naming the file (and the kind and limit where
//! there is one), before any work, nothing written — and nothing hangs or grows without bound
//! (a FIFO, `/dev/zero`).

use crate::common::*;
use image::{ImageFormat, Rgb, Rgb32FImage};
use std::path::Path;
use std::time::{Duration, Instant};

/// A 16×8 map of constant radiance 1 as Radiance `.hdr`.
fn write_hdr(path: &Path) {
    Rgb32FImage::from_pixel(16, 8, Rgb([1.0, 1.0, 1.0]))
        .save_with_format(path, ImageFormat::Hdr)
        .unwrap();
}

/// A 16×8 OpenEXR map with `v` at texel (3, 2), channel g.
fn write_exr_with(path: &Path, v: f32) {
    let mut buf = Rgb32FImage::from_pixel(16, 8, Rgb([1.0, 1.0, 1.0]));
    buf.get_pixel_mut(3, 2).0[1] = v;
    image::DynamicImage::ImageRgb32F(buf)
        .save_with_format(path, ImageFormat::OpenExr)
        .unwrap();
}

fn mkfifo(path: &Path) {
    let ok = std::process::Command::new("mkfifo")
        .arg(path)
        .status()
        .unwrap()
        .success();
    assert!(ok, "mkfifo {}", path.display());
}

/// Runs `workbench args` in `dir` (with `env` set) and checks: exit 2 within a few seconds,
/// one line on stderr holding every needle, no new file in `dir`.
fn refused(dir: &Path, env: &[(&str, &str)], args: &[&str], needles: &[&str]) {
    let before = std::fs::read_dir(dir).unwrap().count();
    let start = Instant::now();
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_workbench"))
        .args(args)
        .env_remove("WORKBENCH_DATA")
        .envs(env.iter().copied())
        .current_dir(dir)
        .output()
        .unwrap();
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
    assert!(
        start.elapsed() < Duration::from_secs(20),
        "{args:?} took {:?}",
        start.elapsed()
    );
    assert_eq!(err.trim_end().lines().count(), 1, "{args:?}: not one line: {err}");
    for n in needles {
        assert!(err.contains(n), "{args:?}: `{n}` not in: {err}");
    }
    assert_eq!(
        std::fs::read_dir(dir).unwrap().count(),
        before,
        "{args:?} wrote files"
    );
}

fn render_with(env: &str) -> Vec<&str> {
    vec![
        "render", "-q", "--env", env, "--width", "8", "--height", "8", "--spp", "2", "--out", "a.exr",
    ]
}

#[test]
fn bad_maps_are_refused_in_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write_hdr(&d.join("good.hdr"));
    let good = std::fs::read(d.join("good.hdr")).unwrap();
    std::fs::write(d.join("truncated.hdr"), &good[..good.len() / 2]).unwrap();
    std::fs::write(d.join("text.hdr"), b"not an image at all\n").unwrap();
    std::fs::write(d.join("png.hdr"), b"\x89PNG\r\n\x1a\n\0\0\0\rIHDR").unwrap();
    mkfifo(&d.join("fifo.hdr"));
    // Sparse: the size, not a gigabyte of disk.
    std::fs::File::create(d.join("huge.hdr"))
        .unwrap()
        .set_len((1 << 30) + 1)
        .unwrap();
    write_exr_with(&d.join("negative.exr"), -0.5);
    write_exr_with(&d.join("nan.exr"), f32::NAN);
    // A header declaring 10⁶ × 10⁶ texels: refused by the decoder's limits, not allocated.
    std::fs::write(
        d.join("giant.hdr"),
        b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 1000000 +X 1000000\n\0\0\0\0",
    )
    .unwrap();
    let cases: &[(&str, &[&str])] = &[
        ("missing.hdr", &["--env missing.hdr: cannot read"]),
        (
            "truncated.hdr",
            &["--env truncated.hdr: not a valid Radiance .hdr image"],
        ),
        (
            "text.hdr",
            &["--env text.hdr: the file is text, not a Radiance .hdr or OpenEXR image"],
        ),
        ("png.hdr", &["--env png.hdr: the file is a PNG image"]),
        (
            "fifo.hdr",
            &[
                "--env fifo.hdr: is a named pipe (FIFO), not a regular file; environment maps are read from regular files only",
            ],
        ),
        (
            "/dev/zero",
            &[
                "--env /dev/zero: is a character device, not a regular file; environment maps are read from regular files only",
            ],
        ),
        (
            "huge.hdr",
            &["--env huge.hdr: the file is 1073741825 bytes; environment maps are limited to 1.0 GiB"],
        ),
        (
            "negative.exr",
            &["--env negative.exr: texel (3, 2) = [1.0, -0.5, 1.0] is not a finite radiance >= 0"],
        ),
        (
            "nan.exr",
            &["--env nan.exr: texel (3, 2) = [1.0, NaN, 1.0] is not a finite radiance >= 0"],
        ),
        (
            "giant.hdr",
            &[
                "--env giant.hdr: not a valid Radiance .hdr image: it declares more than the decoder's limits (32768 texels a side, 2.0 GiB decoded)",
            ],
        ),
        // A word that is neither a file nor a catalogue map: the catalogue's maps are listed.
        (
            "pisaa",
            &[
                "--env pisaa: cannot read: no such file, and not the name of a catalogue map (pisa, pisa-256, grace, archi",
            ],
        ),
        (
            "thesis-mc3000",
            &["--env thesis-mc3000: `thesis-mc3000` is the catalogue's image, not a map"],
        ),
    ];
    for (env, needles) in cases {
        refused(d, &[], &render_with(env), needles);
    }
    // The same map through a render table and an experiment's pixel integrand.
    std::fs::write(
        d.join("table.json"),
        r#"{"name": "t", "env": "fifo.hdr", "spp": [2], "variants": [{"label": "mc", "integrator": "mc"}]}"#,
    )
    .unwrap();
    refused(
        d,
        &[],
        &["validate", "table.json"],
        &["table.json: env: fifo.hdr: is a named pipe (FIFO)"],
    );
    std::fs::write(
        d.join("exp.json"),
        r#"{"name": "e", "integrands": [{"type": "pixel", "pixel": [128, 186], "width": 256, "height": 256, "env": "/dev/zero", "channel": "g"}],
            "estimators": [{"label": "MC", "method": "mc"}], "samples": [4], "trials": 2, "seed": 1}"#,
    )
    .unwrap();
    refused(
        d,
        &[],
        &["validate", "exp.json"],
        &["integrands[0].env: /dev/zero: is a character device"],
    );
}

/// A catalogue map by name: without a data folder the message says how to set one; in a data
/// folder whose copy differs from the catalogue (here: any other bytes at its path) it is
/// refused by checksum, naming the file, the expected sha256 and where to obtain it.
#[test]
fn catalogue_maps_need_an_intact_data_folder() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let entry = workbench::data::catalog::find("pisa-256").unwrap();
    refused(
        d,
        &[],
        &render_with("pisa-256"),
        &[
            "--env pisa-256: `pisa-256` is the catalogue's map envmaps/debevec/pisa_256x128.hdr and no data folder is set: pass --data DIR or set WORKBENCH_DATA=DIR",
        ],
    );
    refused(
        d,
        &[("WORKBENCH_DATA", "nowhere")],
        &render_with("pisa-256"),
        &["WORKBENCH_DATA=nowhere: cannot be read"],
    );
    let data = d.join("data");
    refused(
        d,
        &[],
        &[&["--data", "data"][..], &render_with("pisa-256")].concat(),
        &["--data data: cannot be read"],
    );
    let copy = data.join(&entry.path);
    std::fs::create_dir_all(copy.parent().unwrap()).unwrap();
    refused(
        d,
        &[("WORKBENCH_DATA", "data")],
        &render_with("pisa-256"),
        &[
            "data/envmaps/debevec/pisa_256x128.hdr: missing; the catalogue's `pisa-256` is 93420 bytes with sha256 884b223a294bbd30",
            &entry.source,
        ],
    );
    write_hdr(&copy);
    let altered = format!(
        "the catalogue's `pisa-256` is {} bytes with sha256 {}; obtain it from {}",
        entry.bytes, entry.sha256, entry.source
    );
    refused(
        d,
        &[("WORKBENCH_DATA", "data")],
        &render_with("pisa-256"),
        &["pisa_256x128.hdr: altered (it is ", &altered],
    );
    // --data wins over WORKBENCH_DATA.
    refused(
        d,
        &[("WORKBENCH_DATA", "nowhere")],
        &[&["--data", "data"][..], &render_with("pisa-256")].concat(),
        &["pisa_256x128.hdr: altered"],
    );
    std::fs::remove_file(&copy).unwrap();
    mkfifo(&copy);
    refused(
        d,
        &[("WORKBENCH_DATA", "data")],
        &render_with("pisa-256"),
        &["pisa_256x128.hdr: is a named pipe (FIFO)", &entry.sha256],
    );
    // `workbench data` reports the same, one line per file not intact, after the listing.
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_workbench"))
        .args(["data", "--data", "data"])
        .current_dir(d)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    let n = workbench::data::catalog::entries().len();
    assert_eq!(stderr(&o).lines().count(), n, "{}", stderr(&o));
    assert!(
        stdout(&o).contains(&format!("{n} files: 0 intact, {n} not")),
        "{}",
        stdout(&o)
    );
    // A file that exists by the name of a map is a path, not the catalogue's.
    write_hdr(&d.join("pisa-256"));
    let o = workbench(d, &render_with("pisa-256"));
    assert!(o.status.success(), "{}", stderr(&o));
}

/// Other inputs: an experiment file, a render table, a points CSV that is a FIFO are refused by
/// type at once instead of blocking.
#[test]
fn inputs_that_are_fifos_are_refused_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    mkfifo(&d.join("exp.json"));
    mkfifo(&d.join("points.csv"));
    refused(
        d,
        &[],
        &["run", "exp.json", "--out", "out"],
        &[
            "exp.json: is a named pipe (FIFO), not a regular file; spec files are read from regular files only",
        ],
    );
    refused(
        d,
        &[],
        &["validate", "exp.json"],
        &["exp.json: is a named pipe (FIFO)"],
    );
    refused(
        d,
        &[],
        &["render", "exp.json"],
        &["exp.json: is a named pipe (FIFO)"],
    );
    refused(
        d,
        &[],
        &["rule", "--points", "points.csv", "--out", "r.csv"],
        &[
            "points.csv: is a named pipe (FIFO), not a regular file; points files are read from regular files only",
        ],
    );
    refused(
        d,
        &[],
        &[&render_with("sky")[..], &["--reference", "/dev/zero"]].concat(),
        &[
            "--reference /dev/zero: is a character device, not a regular file; images are read from regular files only",
        ],
    );
}
