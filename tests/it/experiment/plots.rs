//! The figures through the binary: the SVGs are well-formed and say what they show (display
//! names, the fitting range, exact series as exact, the guide's anchor, what the reference is)
//! with their prose in a caption file beside them, and the error image carries a titled colour
//! bar on a common scale.

use crate::common::*;
use std::path::Path;

/// A text node of an SVG with the attributes of the element that holds it.
#[derive(Debug)]
struct TextNode {
    attrs: Vec<(String, String)>,
    text: String,
}

impl TextNode {
    fn attr(&self, name: &str) -> Option<f64> {
        self.attrs
            .iter()
            .find(|a| a.0 == name)
            .and_then(|a| a.1.parse().ok())
    }
}

fn unescape(s: &str) -> Result<String, String> {
    let mut out = String::new();
    let mut rest = s;
    while let Some(i) = rest.find('&') {
        out.push_str(&rest[..i]);
        let end = rest[i..].find(';').ok_or(format!("bare & in {s:?}"))? + i;
        out.push_str(match &rest[i + 1..end] {
            "amp" => "&",
            "lt" => "<",
            "gt" => ">",
            "quot" => "\"",
            "apos" => "'",
            e => return Err(format!("unknown entity &{e}; in {s:?}")),
        });
        rest = &rest[end + 1..];
    }
    out.push_str(rest);
    Ok(out)
}

/// Parses `svg` as XML far enough to know it is well-formed — one `svg` root, every element
/// closed in order, attributes quoted, entities valid — and returns its non-blank text nodes.
fn parse_svg(svg: &str) -> Result<Vec<TextNode>, String> {
    let mut stack: Vec<(String, Vec<(String, String)>)> = Vec::new();
    let mut roots = 0;
    let mut texts = Vec::new();
    let mut rest = svg;
    loop {
        let (text, after) = match rest.find('<') {
            Some(i) => (&rest[..i], Some(&rest[i + 1..])),
            None => (rest, None),
        };
        if !text.trim().is_empty() {
            let (_, attrs) = stack.last().ok_or(format!("text outside the root: {text:?}"))?;
            texts.push(TextNode {
                attrs: attrs.clone(),
                text: unescape(text.trim())?,
            });
        }
        let Some(after) = after else { break };
        let end = after.find('>').ok_or("unclosed tag")?;
        let tag = &after[..end];
        rest = &after[end + 1..];
        if tag.starts_with('?') || tag.starts_with('!') {
            continue;
        }
        if let Some(name) = tag.strip_prefix('/') {
            let (open, _) = stack.pop().ok_or(format!("</{name}> closes nothing"))?;
            if open != name.trim() {
                return Err(format!("<{open}> closed by </{name}>"));
            }
            continue;
        }
        let self_closing = tag.ends_with('/');
        let body = tag.trim_end_matches('/');
        let name_end = body.find(char::is_whitespace).unwrap_or(body.len());
        let name = &body[..name_end];
        if name.is_empty()
            || !name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == ':')
        {
            return Err(format!("bad element name in <{tag}>"));
        }
        let mut attrs = Vec::new();
        let mut a = body[name_end..].trim_start();
        while !a.is_empty() {
            let eq = a.find('=').ok_or(format!("attribute without value in <{tag}>"))?;
            let key = a[..eq].trim();
            let q = a[eq + 1..].chars().next().ok_or("missing value")?;
            if q != '"' && q != '\'' {
                return Err(format!("unquoted attribute {key} in <{tag}>"));
            }
            let v_start = eq + 2;
            let v_end = a[v_start..].find(q).ok_or(format!("unterminated {key}"))? + v_start;
            attrs.push((key.to_string(), unescape(&a[v_start..v_end])?));
            a = a[v_end + 1..].trim_start();
        }
        if stack.is_empty() {
            roots += 1;
            if name != "svg" {
                return Err(format!("root element <{name}>"));
            }
        }
        if !self_closing {
            stack.push((name.to_string(), attrs));
        }
    }
    if !stack.is_empty() {
        return Err(format!("unclosed <{}>", stack.last().unwrap().0));
    }
    if roots != 1 {
        return Err(format!("{roots} root elements"));
    }
    Ok(texts)
}

fn svg_texts(path: &Path) -> Vec<TextNode> {
    let svg = std::fs::read_to_string(path).unwrap();
    parse_svg(&svg).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// Whether the texts, joined by spaces (a wrapped legend line is several nodes), contain `needle`.
fn has(texts: &[TextNode], needle: &str) -> bool {
    let all: Vec<&str> = texts.iter().map(|t| t.text.as_str()).collect();
    all.join(" ").contains(needle)
}

#[test]
fn the_checker_rejects_broken_svg() {
    assert!(parse_svg("<svg a=\"1\"><text x='2'>a &amp; b</text><path d=\"M0\"/></svg>").is_ok());
    for bad in [
        "<svg><text>a</svg>",
        "<svg><g></text></svg>",
        "<svg a=1></svg>",
        "<svg>a & b</svg>",
        "<svg></svg><svg></svg>",
        "<g></g>",
    ] {
        assert!(parse_svg(bad).is_err(), "{bad}");
    }
}

/// cos θ: cosine-weighted MC is exact (f/p = π). cos0 (the constant 1): uniform MC is exact
/// (f/p = 2π) and so is BMCP with the analytic prior c = 1 (Y − c = 0). cos³θ: nothing is.
const EXACT: &str = r#"{
  "name": "p", "title": "plot test", "integrands": ["cos", "cos0", "cos3"],
  "estimators": [
    { "label": "MC", "method": "mc" },
    { "label": "MC-cos", "method": "mc", "design": "cosine" },
    { "label": "BMCP", "method": "bmcp" }
  ],
  "samples": [4, 8, 16, 32, 64], "trials": 6, "seed": 3
}"#;

#[test]
fn error_plots_say_what_they_show() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("p.json"), EXACT).unwrap();
    let o = workbench(dir.path(), &["run", "p.json", "-q", "--out", "p"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = dir.path().join("p");

    // The claims below rest on these series really being exact.
    let (_, trials) = read_csv(&out.join("trials.csv"));
    let exact = |f: &str, e: &str| {
        trials
            .iter()
            .filter(|t| t[0] == f && t[1] == e)
            .all(|t| t[8].parse::<f64>().unwrap() <= 1e-12 * t[7].parse::<f64>().unwrap())
    };
    assert!(exact("cos", "MC-cos") && exact("cos0", "MC") && exact("cos0", "BMCP"));
    assert!(!exact("cos3", "MC") && !exact("cos0", "MC-cos"));

    // File names stay ASCII; the figures use display names.
    let cos = svg_texts(&out.join("cos.svg"));
    let cos0 = svg_texts(&out.join("cos0.svg"));
    let cos3 = svg_texts(&out.join("cos3.svg"));
    let caption = |name: &str| std::fs::read_to_string(out.join(format!("{name}.caption.txt"))).unwrap();
    assert!(has(&cos, "∫ cos θ dω") && has(&cos0, "∫ 1 dω") && has(&cos3, "∫ cos³θ dω"));
    for (name, texts) in [("cos", &cos), ("cos0", &cos0), ("cos3", &cos3)] {
        assert!(!has(texts, "cos3") && !has(texts, "cos0"));
        // Never a fitted zero slope; the range is stated: N ≥ the median of 4 … 64.
        assert!(!has(texts, "slope 0.00") && !has(texts, "slope −0.00"));
        // (With 6 trials some slopes are `n/a (wide interval, N ≥ 16)`: still the range.)
        assert!(has(texts, "N ≥ 16)"), "{texts:#?}");
        // The band has one legend entry; what it is, is said in the caption, as is the fit.
        assert_eq!(texts.iter().filter(|t| t.text.contains("10–90%")).count(), 1);
        let caption = caption(name);
        assert!(
            caption.contains("over N ≥ 16") && caption.contains("10–90% quantiles"),
            "{caption}"
        );
        // The prose is in the caption file, not in the figure.
        assert!(!has(texts, "least-squares") && caption.contains("least-squares"));
        // No tick label at a fake floor: exact points are left out, not clamped.
        let ticks: Vec<f64> = texts
            .iter()
            .filter_map(|t| workbench::plot::parse_tick(&t.text))
            .collect();
        assert!(ticks.len() >= 2 + 5, "error and N ticks: {texts:#?}");
        assert!(ticks.iter().all(|&v| v > 1e-10), "a tick at the floor");
        // Ticks read as powers of ten, never in e-notation.
        assert!(texts.iter().all(|t| !t.text.contains("e-")), "{texts:#?}");
    }
    assert!(has(&cos, "MC-cos: exact at every N") && has(&cos, "MC: slope"));
    assert!(has(&cos0, "MC: exact at every N") && has(&cos0, "BMCP: exact at every N"));
    assert!(has(&cos0, "MC-cos: slope") && caption("cos0").contains("exact: error 0 up to rounding"));
    assert!(!has(&cos3, "exact"));
    // The guide goes through uniform MC, and is left out when MC has no error to go through.
    // Its exponent is typeset: a raised <tspan> (a text node of its own), never a caret.
    assert!(has(&cos, "∝ N −1/2 through MC") && has(&cos3, "∝ N −1/2 through MC"));
    assert!(!has(&cos0, "−1/2") && !has(&cos, "^("));
    // One axis and subtitle style: the integrand is named once, in the subtitle's integral.
    for texts in [&cos, &cos0, &cos3] {
        assert!(has(texts, "absolute error |Î − I|  [sr]"));
        assert!(!has(texts, "integrand "), "{texts:#?}");
    }
}

/// Issue 22 item 1, issue 32: bands are drawn by default where they overlap no other, for those
/// `plot.bands` names otherwise, and `validate` shows which.
#[test]
fn bands_follow_plot_bands_and_default_to_those_that_overlap_no_other() {
    let dir = tempfile::tempdir().unwrap();
    let spec = |plot: &str| {
        format!(
            r#"{{ "name": "b", "integrands": ["cos3"], "samples": [4, 8, 16], "trials": 5, "seed": 1,
                 "estimators": [ {{"label": "MC", "method": "mc"}}, {{"label": "BMC", "method": "bmc"}},
                                 {{"label": "BMCP", "method": "bmcp"}}, {{"label": "BSQ", "method": "bsq"}} ]{plot} }}"#
        )
    };
    let bands = |plot: &str| -> (usize, String, String) {
        std::fs::write(dir.path().join("b.json"), spec(plot)).unwrap();
        let o = workbench(dir.path(), &["run", "b.json", "-q", "--out", "b"]);
        assert!(o.status.success(), "{}", stderr(&o));
        let svg = std::fs::read_to_string(dir.path().join("b/cos3.svg")).unwrap();
        let caption = std::fs::read_to_string(dir.path().join("b/cos3.caption.txt")).unwrap();
        let v = workbench(dir.path(), &["validate", "b.json"]);
        // A band is a polygon filled at 6% opacity.
        (
            svg.matches("<polygon opacity=\"0.06\"").count(),
            caption,
            String::from_utf8_lossy(&v.stdout).into(),
        )
    };
    // By default a band is drawn where it overlaps no earlier band: MC's first, never all four
    // here (BMC, BMCP and BSQ lie close together at every N).
    let (n, caption, validate) = bands("");
    assert!((1..4).contains(&n), "{n} bands by default");
    assert!(
        caption.contains("by default a band is drawn only where it overlaps no band drawn before it"),
        "{caption}"
    );
    assert!(caption.contains("drawn for MC"), "{caption}");
    assert!(validate.contains("\"bands\": \"auto\""), "{validate}");
    let (n, caption, validate) = bands(r#", "plot": {"bands": ["MC", "BMC"]}"#);
    assert_eq!(n, 2);
    assert!(caption.contains("drawn for MC, BMC"), "{caption}");
    assert!(validate.contains("\"MC\",\n      \"BMC\""), "{validate}");
    assert_eq!(bands(r#", "plot": {"bands": "all"}"#).0, 4);
    std::fs::write(dir.path().join("b.json"), spec(r#", "plot": {"bands": ["XY"]}"#)).unwrap();
    let o = workbench(dir.path(), &["validate", "b.json"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("plot.bands") && stderr(&o).contains("\"XY\""),
        "{}",
        stderr(&o)
    );
}

#[test]
fn the_rmse_plot_names_its_reference_and_keeps_the_legend_off_the_data() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(
        d.join("t.json"),
        r#"{ "name": "t", "seed": 1, "width": 8, "height": 6, "spp": [4, 8, 16], "repetitions": 2,
             "reference": {"spp": 32},
             "variants": [ {"label": "MC", "integrator": "mc"}, {"label": "MC cos", "integrator": "mc-cos"},
                           {"label": "BMC", "integrator": "bmc", "gps": 1} ] }"#,
    )
    .unwrap();
    let o = workbench(d, &["render", "t.json", "--results-dir", "r", "-q"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let texts = svg_texts(&d.join("r/t/rmse_vs_spp.svg"));
    assert!(has(&texts, "reference rendered with uniform MC at 32 spp"));
    assert!(has(&texts, "∝ spp −1/2 through MC") && !has(&texts, "^("));
    let svg = std::fs::read_to_string(d.join("r/t/rmse_vs_spp.svg")).unwrap();
    assert!(
        svg.contains("spp<tspan baseline-shift=\"super\""),
        "the exponent is not raised"
    );
    let caption = std::fs::read_to_string(d.join("r/t/rmse_vs_spp.caption.txt")).unwrap();
    assert!(caption.contains("95% Student-t interval") && !has(&texts, "Student-t"));
    // No title given: the plot is titled with the table's name (render-table files set `title`).
    assert!(has(&texts, "t: mean RMSE against samples per pixel"));
    // The legend is below the plotting area: every label sits lower than every tick label.
    let lowest_tick = texts
        .iter()
        .filter(|t| workbench::plot::parse_tick(&t.text).is_some())
        .filter_map(|t| t.attr("y"))
        .fold(0.0, f64::max);
    for label in ["MC", "MC cos", "BMC"] {
        let t = texts.iter().find(|t| t.text == label).expect(label);
        assert!(t.attr("y").unwrap() > lowest_tick, "{label} inside the chart");
    }
}

#[test]
fn error_images_have_a_colour_bar_and_report_their_scale() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let size = ["--width", "40", "--height", "30"];
    let mut args = vec![
        "render",
        "-q",
        "--integrator",
        "mc",
        "--spp",
        "64",
        "--out",
        "ref.exr",
    ];
    args.extend(size);
    assert!(workbench(d, &args).status.success());
    let mut args = vec![
        "render",
        "-q",
        "--integrator",
        "mc",
        "--spp",
        "2",
        "--reference",
        "ref.exr",
        "--out",
        "a.exr",
    ];
    args.extend(size);
    let o = workbench(d, &args);
    assert!(o.status.success(), "{}", stderr(&o));
    // The default is the common absolute scale, and the image's own maximum is reported.
    let err = stderr(&o);
    assert!(err.contains("max error ") && err.contains(" at pixel ("), "{err}");
    assert!(err.contains("scale 0–0.25"), "{err}");
    let png = image::open(d.join("a-error.png")).unwrap().into_rgb8();
    assert!(
        png.width() > 40 && png.height() == 30,
        "{}×{}",
        png.width(),
        png.height()
    );

    args.extend(["--error-scale", "normalised"]);
    *args.iter_mut().find(|a| **a == "a.exr").unwrap() = "b.exr";
    let o = workbench(d, &args);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("the image's own maximum"), "{}", stderr(&o));
}

/// Issue 43 item 5: beside fixed-N estimators, a tolerance estimator is drawn at the mean N its
/// stopping rule used (stopping_summary.csv), not at its first stage: the N axis reaches those
/// N, the legend gives it no slope, and both captions say where its points stand.
#[test]
fn tolerance_estimators_stand_at_the_n_they_used() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("t.json"),
        r#"{ "name": "t", "integrands": ["cos3"],
             "estimators": [ { "label": "MC", "method": "mc" },
                             { "label": "MC tol", "method": "mc", "tolerance": { "abs": 0.05, "max_n": 4096, "min_n": 16 } } ],
             "samples": [16, 64], "trials": 20, "seed": 5 }"#,
    )
    .unwrap();
    let o = workbench(dir.path(), &["run", "t.json", "-q", "--out", "t"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = dir.path().join("t");
    let (head, rows) = read_csv(&out.join("stopping_summary.csv"));
    let col = head.iter().position(|h| h == "mean_n_used").unwrap();
    let used: Vec<f64> = rows.iter().map(|r| r[col].parse().unwrap()).collect();
    // The claim rests on the rule spending far more than the first stages 16 and 64.
    assert!(used.iter().all(|&n| n >= 512.0), "{used:?}");
    for name in ["t.svg", "t-coverage.svg"] {
        let name = name.replacen('t', "cos3", 1);
        let texts = svg_texts(&out.join(&name));
        let ticks: Vec<f64> = texts
            .iter()
            .filter_map(|t| t.text.parse::<u64>().ok())
            .map(|n| n as f64)
            .collect();
        let top = ticks.iter().copied().fold(0.0, f64::max);
        let far = used.iter().copied().fold(0.0, f64::max);
        assert!(2.0 * top > far, "{name}: N ticks {ticks:?} stop short of {far}");
        let caption = std::fs::read_to_string(out.join(name.replace(".svg", ".caption.txt"))).unwrap();
        assert!(
            caption.contains("MC tol stops at a tolerance: each point stands at the mean N"),
            "{caption}"
        );
    }
    let texts = svg_texts(&out.join("cos3.svg"));
    assert!(has(&texts, "MC tol: at the mean N used") && !has(&texts, "MC tol: slope"));
}
