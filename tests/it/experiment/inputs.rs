//! Issue 8, "Nothing lost, nothing silently wrong": inputs that were accepted and misread, or
//! refused with an unclear message. One module per class of the issue, named after it; each
//! bad input must give exit code 2 and one line naming the file, where in it, and the value.

use crate::common::*;
use std::path::Path;

/// A minimal valid experiment; `{extra}` is spliced in before the closing brace.
fn experiment(extra: &str) -> String {
    format!(
        "{{\"name\": \"t\", \"integrands\": [\"cos\"], \"estimators\": [{{\"label\": \"MC\", \"method\": \"mc\"}}], \
         \"samples\": [4], \"trials\": 2{extra}}}"
    )
}

/// Runs `args` in `dir` and returns stderr, which must be one line, with exit code 2.
fn input_error(dir: &Path, args: &[&str]) -> String {
    let o = workbench(dir, args);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
    assert_eq!(err.lines().count(), 1, "{args:?}: not one line: {err}");
    err.trim_end().to_string()
}

/// `workbench validate NAME` on `text` written to `NAME`: the one-line error.
fn validate_error(name: &str, text: impl AsRef<[u8]>) -> String {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join(name), text).unwrap();
    input_error(dir.path(), &["validate", name])
}

/// `workbench validate NAME` on `text` succeeds.
fn validates(name: &str, text: impl AsRef<[u8]>) {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join(name), text).unwrap();
    let o = workbench(dir.path(), &["validate", name]);
    assert!(o.status.success(), "{name}: {}", stderr(&o));
}

fn encode(image: &::image::DynamicImage, format: ::image::ImageFormat) -> Vec<u8> {
    let mut out = std::io::Cursor::new(Vec::new());
    image.write_to(&mut out, format).unwrap();
    out.into_inner()
}

/// A 4×2 map of constant radiance `v` as `format`.
fn constant_map(v: f32, format: ::image::ImageFormat) -> Vec<u8> {
    encode(
        &::image::DynamicImage::ImageRgb32F(::image::Rgb32FImage::from_pixel(4, 2, ::image::Rgb([v; 3]))),
        format,
    )
}

/// Issue 8, item 5: an 8-bit picture given as an environment map was used as linear radiance.
mod a_file_type_the_tool_does_not_support_is_accepted {
    use super::*;
    use workbench::render::env::{HdrFormat, decode_hdr_image, sniff_hdr_format};

    const RENDER: [&str; 9] = [
        "render",
        "--integrator",
        "mc",
        "--spp",
        "1",
        "--width",
        "4",
        "--height",
        "4",
    ];

    fn png() -> Vec<u8> {
        encode(
            &::image::DynamicImage::ImageRgb8(::image::RgbImage::from_pixel(4, 2, ::image::Rgb([128; 3]))),
            ::image::ImageFormat::Png,
        )
    }

    /// Named `.png` or disguised as `.hdr`, a PNG is refused with what it is and what is accepted.
    #[test]
    fn a_png_environment_map_is_refused_naming_its_format() {
        for name in ["picture.png", "picture.hdr"] {
            let dir = tempfile::tempdir().unwrap();
            std::fs::write(dir.path().join(name), png()).unwrap();
            let err = input_error(
                dir.path(),
                &[&RENDER[..], &["--env", name, "--out", "a.exr"]].concat(),
            );
            assert_eq!(
                err,
                format!(
                    "Error: --env {name}: the file is a PNG image, not a Radiance .hdr or OpenEXR image \
                     (recognised by content, not by name); use `sky`, `white` or an equirectangular .hdr/.exr file"
                )
            );
            assert_eq!(
                std::fs::read_dir(dir.path()).unwrap().count(),
                1,
                "files were written"
            );
        }
    }

    /// The same through a render table's `env`.
    #[test]
    fn a_png_environment_map_in_a_render_table_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("sky.png"), png()).unwrap();
        let spec = r#"{"name": "t", "env": "sky.png", "variants": [{"integrator": "mc"}]}"#;
        std::fs::write(dir.path().join("table.json"), spec).unwrap();
        let err = input_error(dir.path(), &["validate", "table.json"]);
        assert!(
            err.starts_with("Error: table.json: env: sky.png: the file is a PNG image, not a Radiance"),
            "{err}"
        );
    }

    /// Radiance and OpenEXR maps are recognised by content: misnamed, they light the scene
    /// exactly as correctly named ones do.
    #[test]
    fn supported_maps_are_recognised_by_content_not_name() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        std::fs::write(d.join("map.hdr"), constant_map(0.5, ::image::ImageFormat::Hdr)).unwrap();
        std::fs::write(
            d.join("map-hdr.png"),
            constant_map(0.5, ::image::ImageFormat::Hdr),
        )
        .unwrap();
        std::fs::write(
            d.join("map-exr.dat"),
            constant_map(0.5, ::image::ImageFormat::OpenExr),
        )
        .unwrap();
        let mut images = Vec::new();
        for map in ["map.hdr", "map-hdr.png", "map-exr.dat"] {
            let out = format!("{map}.exr");
            let o = workbench(d, &[&RENDER[..], &["--env", map, "--out", &out, "-q"]].concat());
            assert!(o.status.success(), "{map}: {}", stderr(&o));
            images.push(std::fs::read(d.join(out)).unwrap());
        }
        assert_eq!(images[0], images[1]);
        assert_eq!(images[0], images[2]);
    }

    /// `#?RGBE` is the other Radiance signature; the image crate checks for `#?RADIANCE` only.
    #[test]
    fn the_rgbe_signature_is_read_like_radiance() {
        let radiance = constant_map(2.0, ::image::ImageFormat::Hdr);
        assert!(radiance.starts_with(b"#?RADIANCE"));
        let mut rgbe = b"#?RGBE".to_vec();
        rgbe.extend_from_slice(&radiance[b"#?RADIANCE".len()..]);
        assert_eq!(sniff_hdr_format(&rgbe), Ok(HdrFormat::Radiance));
        let a = decode_hdr_image(&radiance).unwrap();
        let b = decode_hdr_image(&rgbe).unwrap();
        assert_eq!(a, b);
        assert_eq!(a.get_pixel(0, 0).0, [2.0; 3]);
    }

    /// What `--reference` will say once `Image::read` decodes with `decode_hdr_image`.
    #[test]
    fn decode_errors_say_what_the_file_is() {
        assert_eq!(
            decode_hdr_image(&png()).unwrap_err(),
            "the file is a PNG image, not a Radiance .hdr or OpenEXR image (recognised by content, not by name)"
        );
        let e = decode_hdr_image(b"#?RADIANCE\nFORMAT=nonsense\n\n-Y 2 +X 2\nxx").unwrap_err();
        assert!(e.starts_with("not a valid Radiance .hdr image ("), "{e}");
        let e = decode_hdr_image(&[0x76, 0x2f, 0x31, 0x01, 0, 0]).unwrap_err();
        assert!(e.starts_with("not a valid OpenEXR image ("), "{e}");
    }
}

/// Issue 8, item 9: smaller inconsistencies and understatements.
mod smaller_inconsistencies {
    use super::*;

    /// A UTF-8 byte-order mark was refused in experiment files but accepted in points files;
    /// now every input file accepts it.
    #[test]
    fn a_byte_order_mark_is_accepted_in_every_input_file() {
        let bom = |text: &str| [&b"\xef\xbb\xbf"[..], text.as_bytes()].concat();
        validates("experiment.json", bom(&experiment(", \"seed\": 1")));
        validates(
            "table.json",
            bom(r#"{"name": "t", "variants": [{"integrator": "mc"}]}"#),
        );
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("points.csv"), bom("x,y,z\n0,0,1\n1,0,0\n")).unwrap();
        let o = workbench(dir.path(), &["rule", "--points", "points.csv"]);
        assert!(o.status.success(), "{}", stderr(&o));
        assert_eq!(stdout(&o).lines().count(), 3, "{}", stdout(&o));
    }

    /// serde_json keeps the last of duplicate keys: the file said one thing and ran another.
    #[test]
    fn duplicate_json_keys_are_rejected_with_their_path() {
        let text = experiment(", \"seed\": 1").replace(
            "{\"label\": \"MC\", \"method\": \"mc\"}",
            "{\"label\": \"MC\", \"method\": \"mc\"},\n  {\"label\": \"BMC\", \"method\": \"bmc\", \"noise\": 0.1,\n   \"noise\": 0.5}",
        );
        assert_eq!(
            validate_error("dup.json", text),
            "Error: dup.json: estimators[1].noise: duplicate key \"noise\" at line 3 column 10"
        );
        // The column is that of the duplicate key's closing quote.
        let text = experiment(", \"seed\": 1, \"seed\": 2");
        let column = text.rfind("\"seed\"").unwrap() + "\"seed\"".len();
        assert_eq!(
            validate_error("dup.json", &text),
            format!("Error: dup.json: seed: duplicate key \"seed\" at line 1 column {column}")
        );
        let table = r#"{"name": "t", "variants": [{"integrator": "mc", "integrator": "bmc"}]}"#;
        assert_eq!(
            validate_error("table.json", table),
            "Error: table.json: variants[0].integrator: duplicate key \"integrator\" at line 1 column 60"
        );
    }

    /// docs/guide/rule.md promises that a bad points file names the line; a non-UTF-8 byte did not.
    #[test]
    fn a_non_utf8_byte_in_a_points_file_names_the_line() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("points.csv"), b"x,y,z\n0,0,1\n1,\xe9,0\n").unwrap();
        assert_eq!(
            input_error(dir.path(), &["rule", "--points", "points.csv"]),
            "Error: points.csv: line 3, column 3: byte 0xE9 is not UTF-8 text; save the file as UTF-8"
        );
    }

    /// Names over 100 characters were refused as "not a safe folder name" without the limit.
    #[test]
    fn an_over_long_experiment_name_states_the_limit() {
        let named = |name: &str| {
            experiment(", \"seed\": 1").replace("\"name\": \"t\"", &format!("\"name\": \"{name}\""))
        };
        assert_eq!(
            validate_error("long.json", named(&"a".repeat(101))),
            format!(
                "Error: long.json: name: \"{}…\" is 101 characters long; names are limited to 100 characters",
                "a".repeat(20)
            )
        );
        validates("long.json", named(&"a".repeat(100)));
    }

    /// MC at N = 10⁷ with two designs took twice the documented memory per thread: the limit
    /// now counts the points of every design drawn in a unit, and the message says the bytes.
    #[test]
    fn the_memory_limit_counts_the_points_of_every_design() {
        let two_designs = |n: u64| {
            experiment(", \"seed\": 1")
                .replace(
                    "{\"label\": \"MC\", \"method\": \"mc\"}",
                    "{\"label\": \"MC\", \"method\": \"mc\"}, {\"label\": \"QMC\", \"method\": \"mc\", \"design\": \"fibonacci\"}",
                )
                .replace("\"samples\": [4]", &format!("\"samples\": [4, {n}]"))
        };
        assert_eq!(
            validate_error("mem.json", two_designs(10_000_000)),
            "Error: mem.json: samples[1]: N = 10000000 with 2 designs would need 0.6 GiB per worker thread \
             for the sample sets and their values (32 bytes per point per design); the limit is 10000000 points \
             per trial across designs, so N ≤ 5000000 here"
        );
        validates("mem.json", two_designs(5_000_000));
        // One design may still use the whole budget.
        validates(
            "mem.json",
            experiment(", \"seed\": 1").replace("\"samples\": [4]", "\"samples\": [10000000]"),
        );
        let e = validate_error(
            "mem.json",
            experiment(", \"seed\": 1").replace("\"samples\": [4]", "\"samples\": [10000001]"),
        );
        assert!(
            e.starts_with("Error: mem.json: samples[0]: N = 10000001 with 1 design would need 0.3 GiB"),
            "{e}"
        );
    }
}

/// Issue 8: the JSON a hostile user tries, each a one-line error naming file, path and value.
mod hostile_json {
    use super::*;

    #[test]
    fn nan_and_infinity_literals_are_named() {
        for literal in ["NaN", "Infinity", "-Infinity"] {
            let text = experiment(&format!(", \"seed\": {literal}"));
            let column = text.find(literal).unwrap() + 1 + usize::from(literal.starts_with('-'));
            assert_eq!(
                validate_error("x.json", text),
                format!(
                    "Error: x.json: malformed JSON in seed at line 1 column {column}: \
                     {}, found `{literal}` (JSON has no NaN or Infinity: numbers must be finite)",
                    if literal.starts_with('-') {
                        "invalid number"
                    } else {
                        "expected value"
                    }
                )
            );
        }
    }

    #[test]
    fn numbers_too_big_for_whole_number_fields_are_named() {
        let whole = "expected a whole number from 0 to 18446744073709551615, got";
        for (field, value, message) in [
            (
                "seed",
                "18446744073709551616",
                "seed: {whole} 1.8446744073709552e+19, which is too big",
            ),
            ("trials", "1e30", "trials: {whole} 1e+30, which is too big"),
            (
                "samples",
                "[4, 99999999999999999999]",
                "samples[1]: {whole} 1e+20, which is too big",
            ),
            ("seed", "-3", "seed: {whole} -3, which is negative"),
        ] {
            let text = experiment(", \"seed\": 1");
            let text = match field {
                "seed" => text.replace("\"seed\": 1", &format!("\"seed\": {value}")),
                "trials" => text.replace("\"trials\": 2", &format!("\"trials\": {value}")),
                _ => text.replace("\"samples\": [4]", &format!("\"samples\": {value}")),
            };
            assert_eq!(
                validate_error("x.json", text),
                format!("Error: x.json: {}", message.replace("{whole}", whole))
            );
        }
    }

    #[test]
    fn a_top_level_array_is_named() {
        assert_eq!(
            validate_error("x.json", format!("[{}]", experiment(", \"seed\": 1"))),
            "Error: x.json: the file must hold one JSON object (the experiment), got an array"
        );
    }

    #[test]
    fn an_empty_file_says_what_it_must_hold() {
        for text in ["", "\n  \n"] {
            assert_eq!(
                validate_error("x.json", text),
                "Error: x.json: the file is empty; it must hold one JSON object (the experiment)"
            );
        }
    }

    #[test]
    fn a_folder_is_refused_in_one_line() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir(dir.path().join("x.json")).unwrap();
        let err = input_error(dir.path(), &["validate", "x.json"]);
        assert!(err.starts_with("Error: x.json: "), "{err}");
        // What the spec reader says (the commands read spec files through it once wired).
        assert_eq!(
            workbench::files::spec_json::read_spec(&dir.path().join("x.json"))
                .unwrap_err()
                .to_string(),
            format!("{}: is a folder, not a file", dir.path().join("x.json").display())
        );
    }

    /// A gigabyte is refused from its size, without reading it (the file is sparse).
    #[test]
    fn a_huge_file_is_not_read() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("huge.json");
        let file = std::fs::File::create(&path).unwrap();
        file.set_len(1 << 30).unwrap();
        assert_eq!(
            workbench::files::spec_json::read_spec(&path)
                .unwrap_err()
                .to_string(),
            format!(
                "{}: the file is 1.0 GiB; spec files are limited to 16.0 MiB",
                path.display()
            )
        );
        // Just over the limit is refused too, just under is read.
        file.set_len(workbench::files::spec_json::MAX_SPEC_BYTES + 1)
            .unwrap();
        assert!(workbench::files::spec_json::read_spec(&path).is_err());
        file.set_len(workbench::files::spec_json::MAX_SPEC_BYTES).unwrap();
        assert_eq!(
            workbench::files::spec_json::read_spec(&path).unwrap().len() as u64,
            workbench::files::spec_json::MAX_SPEC_BYTES
        );
    }

    /// A spec with a byte that is not UTF-8: the line and the byte.
    #[test]
    fn a_non_utf8_spec_names_the_line() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x.json");
        std::fs::write(&path, b"{\n  \"name\": \"caf\xe9\"\n}").unwrap();
        assert_eq!(
            workbench::files::spec_json::read_spec(&path)
                .unwrap_err()
                .to_string(),
            format!(
                "{}: line 2, column 15: byte 0xE9 is not UTF-8 text; save the file as UTF-8",
                path.display()
            )
        );
    }

    #[test]
    fn deep_nesting_is_one_line() {
        let text = experiment(&format!(
            ", \"seed\": 1, \"title\": {}{}",
            "[".repeat(500),
            "]".repeat(500)
        ));
        let column = text.find("[[[").unwrap() + 127;
        assert_eq!(
            validate_error("x.json", text),
            format!(
                "Error: x.json: malformed JSON at line 1 column {column}: nested more than 127 arrays and objects deep"
            )
        );
    }
}

/// Issue 10: the amplitude, Bayes–Sard and calibration checks refuse bad input in one line
/// naming the file, the JSON path and the value (exit 2).
mod calibration_inputs {
    use super::*;

    fn spec(estimators: &str, samples: &str, checks: &str) -> String {
        format!(
            "{{\"name\": \"t\", \"integrands\": [\"cos\"], \"estimators\": [{estimators}], \
             \"samples\": {samples}, \"trials\": 4, \"seed\": 1, \"checks\": [{checks}]}}"
        )
    }

    #[test]
    fn bad_scales_bsq_sizes_and_calibration_checks_are_named() {
        let mc = r#"{"label": "MC", "method": "mc"}"#;
        let bmc = r#"{"label": "BMC", "method": "bmc"}"#;
        let cases = [
            (
                spec(r#"{"label": "B", "method": "bmc", "scale": "mle"}"#, "[4]", ""),
                "Error: x.json: estimators[0].scale: unknown variant `mle`",
            ),
            (
                spec(r#"{"label": "M", "method": "mc", "scale": "ml"}"#, "[4]", ""),
                "Error: x.json: estimators[0].scale: \"ml\" is not used by method mc",
            ),
            (
                spec(r#"{"label": "S", "method": "bsq"}"#, "[4, 1]", ""),
                "Error: x.json: samples[1]: N = 1 is too few for estimators[0] (\"S\", method bsq), which needs at least 2 points",
            ),
            (
                spec(&format!("{mc}, {bmc}"), "[1, 8]", r#"{"calibrated": "MC"}"#),
                "Error: x.json: checks[0].calibrated: \"MC\" (method mc) has no interval at N = 1, so its calibration cannot be checked; raise from_n",
            ),
            (
                spec(bmc, "[8]", r#"{"calibrated": "BMC", "level": 1.5}"#),
                "Error: x.json: checks[0].level: must be in (0, 1), got 1.5",
            ),
            (
                spec(bmc, "[8]", r#"{"calibrated": "BMX"}"#),
                "Error: x.json: checks[0].calibrated: no estimator is labelled \"BMX\" (labels: BMC)",
            ),
            (
                spec(
                    &format!("{mc}, {bmc}"),
                    "[8]",
                    r#"{"calibrated": "BMC", "than": "MC"}"#,
                ),
                "Error: x.json: checks[0].than: is not used by a calibration check",
            ),
            (
                spec(bmc, "[8]", r#"{"from_n": 4}"#),
                "Error: x.json: checks[0]: give \"better\" and \"than\"",
            ),
            (
                spec(bmc, "[8]", r#"{"calibrated": "BMC", "side": "upper"}"#),
                "Error: x.json: checks[0].side: unknown variant `upper`, expected `two-sided` or `lower`",
            ),
            (
                spec(
                    &format!("{mc}, {bmc}"),
                    "[8]",
                    r#"{"better": "BMC", "than": "MC", "side": "lower"}"#,
                ),
                "Error: x.json: checks[0].side: is used only by a calibration check",
            ),
        ];
        for (text, want) in cases {
            let got = validate_error("x.json", &text);
            assert!(got.starts_with(want), "{text}\n got: {got}\nwant: {want}");
        }
        // The calibration check on MC from N = 2 on is fine.
        validates(
            "ok.json",
            spec(
                &format!("{mc}, {bmc}"),
                "[1, 8]",
                r#"{"calibrated": "MC", "from_n": 2}"#,
            ),
        );
    }
}
