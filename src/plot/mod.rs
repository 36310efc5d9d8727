//! The look shared by the workbench's SVG plots (`run`'s error plots and the render table's RMSE
//! plot): colours, markers, log-axis ticks that do not crowd, a title block and a legend drawn
//! below the chart, where it cannot cover data.

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

mod chart;
pub mod faces;
pub use chart::*;

/// Width of every plot in pixels.
pub const WIDTH: u32 = 960;
/// Height of the title block (title and one line of subtitle).
pub const HEADER_HEIGHT: u32 = 62;
/// Font size of tick labels (plotters' sizes are points: an SVG text of `size / 1.24` px).
pub const TICK_FONT: u32 = 17;
/// Font size of axis descriptions.
pub const AXIS_FONT: u32 = 19;
/// Font size of the legend.
pub const LEGEND_FONT: u32 = 18;
/// Font family (DejaVu Sans or whatever the viewer maps `sans-serif` to).
pub const FONT: &str = "sans-serif";
/// The colour of reference lines (guides) and of generic legend samples.
pub const GUIDE: RGBColor = RGBColor(90, 90, 90);

/// Okabe–Ito colours, distinguishable with colour-vision deficiencies (their yellow, unreadable
/// on white, left out), in the order series get them, then Paul Tol's wine and olive for an
/// eighth and ninth series (`cos3-designs` has nine), so that no two of nine share a colour.
pub const PALETTE: [RGBColor; 9] = [
    RGBColor(213, 94, 0),
    RGBColor(0, 114, 178),
    RGBColor(0, 158, 115),
    RGBColor(204, 121, 167),
    RGBColor(230, 159, 0),
    RGBColor(86, 180, 233),
    RGBColor(0, 0, 0),
    RGBColor(136, 34, 85),
    RGBColor(153, 153, 51),
];

/// The colour of series `i`.
pub fn colour(i: usize) -> RGBColor {
    PALETTE[i % PALETTE.len()]
}

/// Number of distinct marker shapes. Series `i` gets shape `(i + ⌊i/9⌋) mod 7` and colour
/// `i mod 9`, so two series share both only 63 apart (nine apart they share the colour, and the
/// shape moves by three).
pub const MARKERS: usize = 7;

/// The marker shape of series `i` (see [`MARKERS`]).
fn marker_shape(i: usize) -> usize {
    (i + i / PALETTE.len()) % MARKERS
}

/// Draws the marker of series `i` centred on pixel `at` of `area`: filled circle, filled
/// triangle, ×, open circle, filled square, filled diamond, open square. Shapes differ as well
/// as colours, so series stay apart in grey print and where colours blend. (Drawn in pixels
/// on a plain drawing area, so that a chart's points, mapped with `backend_coord`, and the
/// legend share it.)
pub fn draw_marker<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    i: usize,
    at: (i32, i32),
    colour: RGBColor,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    draw_marker_scaled(area, i, at, colour, 1.0)
}

/// The marker of a series in `style` at pixel `at`: its shape and colour, enlarged by
/// [`SeriesStyle::marker_scale`] when later series lie on it, so that theirs, drawn over it,
/// leave its outline showing.
pub fn draw_styled_marker<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    style: SeriesStyle,
    at: (i32, i32),
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    draw_marker_scaled(area, style.marker, at, colour(style.colour), style.marker_scale())
}

/// [`draw_marker`] with every size multiplied by `scale`.
fn draw_marker_scaled<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    i: usize,
    at: (i32, i32),
    colour: RGBColor,
    scale: f64,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let (x, y) = at;
    let px = |v: f64| (v * scale).round() as i32;
    let (r, t) = (px(4.0), px(6.0));
    let fill = colour.filled();
    let stroke = colour.stroke_width(2);
    // Open shapes get a white inside so that a band or line behind them does not show through.
    let white = WHITE.filled();
    match marker_shape(i) {
        0 => area.draw(&Circle::new(at, r, fill)),
        1 => area.draw(&TriangleMarker::new(at, t, fill)),
        2 => area.draw(&Cross::new(at, r, stroke)),
        3 => {
            area.draw(&Circle::new(at, r, white))?;
            area.draw(&Circle::new(at, r, stroke))
        }
        4 => area.draw(&Rectangle::new([(x - r, y - r), (x + r, y + r)], fill)),
        5 => area.draw(&Polygon::new(
            vec![(x, y - t), (x + px(5.0), y), (x, y + t), (x - px(5.0), y)],
            fill,
        )),
        _ => {
            area.draw(&Rectangle::new([(x - r, y - r), (x + r, y + r)], white))?;
            area.draw(&Rectangle::new([(x - r, y - r), (x + r, y + r)], stroke))
        }
    }
}

/// The tick values of one axis: labelled ones (with tick marks and grid lines) and unlabelled
/// minor ones (short tick marks only).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Ticks {
    /// Values with a label, a tick mark and a faint grid line.
    pub labelled: Vec<f64>,
    /// Values with a short tick mark only.
    pub minor: Vec<f64>,
}

/// `m·10^k` as the nearest `f64` (so that `0.02` prints as `0.02`, not `0.020000000000000004`).
fn decade_multiple(m: u32, k: i32) -> f64 {
    format!("{m}e{k}").parse().expect("a number")
}

/// A log axis's range around the values drawn: `[min / pad, max · pad]`, or `pad²` either side
/// when all values are equal, or the decade range `[1e-3, 1]` when nothing is drawn (a plot of
/// exact series; its legend says why).
pub fn padded_log_range(values: &[f64], pad: f64) -> (f64, f64) {
    if values.is_empty() {
        return (1e-3, 1.0);
    }
    let lo = values.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = values.iter().copied().fold(0.0, f64::max);
    if lo < hi {
        (lo / pad, hi * pad)
    } else {
        (lo / (pad * pad), hi * pad * pad)
    }
}

/// Ticks of a logarithmic error axis over `[lo, hi]` (`0 < lo < hi`): the decades are labelled
/// and 2…9 × 10^k are minor ticks. When fewer than two decades fall inside the range, 2 and 5 ×
/// 10^k are labelled too, and if that still gives fewer than two labels, every m × 10^k.
pub fn log_ticks(lo: f64, hi: f64) -> Ticks {
    let all: Vec<(u32, f64)> = {
        let mut v = Vec::new();
        for k in lo.log10().floor() as i32..=hi.log10().ceil() as i32 {
            for m in 1u32..=9 {
                let t = decade_multiple(m, k);
                if t >= lo && t <= hi {
                    v.push((m, t));
                }
            }
        }
        v
    };
    let pick = |labelled: &[u32]| -> Ticks {
        let values = |keep: bool| {
            all.iter()
                .filter(|(m, _)| labelled.contains(m) == keep)
                .map(|p| p.1)
                .collect()
        };
        Ticks {
            labelled: values(true),
            minor: values(false),
        }
    };
    for labelled in [&[1][..], &[1, 2, 5], &[1, 2, 3, 4, 5, 6, 7, 8, 9]] {
        let t = pick(labelled);
        if t.labelled.len() >= 2 {
            return t;
        }
    }
    pick(&[1, 2, 3, 4, 5, 6, 7, 8, 9])
}

/// Whether an axis over `[lo, hi]` reads better in decimals (`0.05`) than in `1e-2` notation:
/// when it spans less than three decades of moderate numbers.
pub fn decimal_axis(lo: f64, hi: f64) -> bool {
    lo >= 1e-3 && hi < 1e4 && hi / lo < 1e3
}

/// A tick label: the shortest decimal when `decimal`, else `10⁻²`, `5×10⁻³`, … (one
/// significant digit is all a log tick at `m·10^k` has), the exponent in Unicode superscript
/// digits and minus, which every SVG viewer and `rsvg-convert` draw as plain text.
pub fn format_tick(v: f64, decimal: bool) -> String {
    if decimal {
        // Rust's shortest round-trip form: `0.05`, `0.2`, `3`.
        return format!("{v}");
    }
    // `{:e}` is the shortest round-trip form `m e k`: `1e-2`, `5e-3`, `2.5e-3`.
    let s = format!("{v:e}");
    let (mantissa, exponent) = s.split_once('e').expect("{:e} has an exponent");
    let power = format!("10{}", superscript(exponent));
    if mantissa == "1" {
        power
    } else {
        format!("{mantissa}×{power}")
    }
}

/// `text` (digits and `-`) in Unicode superscript: `-12` → `⁻¹²`.
fn superscript(text: &str) -> String {
    text.chars()
        .map(|c| match c {
            '-' => '⁻',
            '0' => '⁰',
            '1' => '¹',
            '2' => '²',
            '3' => '³',
            '4' => '⁴',
            '5' => '⁵',
            '6' => '⁶',
            '7' => '⁷',
            '8' => '⁸',
            '9' => '⁹',
            other => other,
        })
        .collect()
}

/// The value of a tick label written by [`format_tick`] (`0.05`, `10⁻²`, `5×10⁻³`), or `None`
/// for other text: for checks that read a figure's ticks back.
pub fn parse_tick(label: &str) -> Option<f64> {
    if let Ok(v) = label.parse::<f64>() {
        return Some(v);
    }
    let (mantissa, power) = match label.split_once('×') {
        Some((m, p)) => (m.parse::<f64>().ok()?, p),
        None => (1.0, label),
    };
    let exponent: String = power
        .strip_prefix("10")?
        .chars()
        .map(|c| match c {
            '⁻' => Some('-'),
            '⁰' => Some('0'),
            '¹' => Some('1'),
            '²' => Some('2'),
            '³' => Some('3'),
            '⁴'..='⁹' => char::from_digit(c as u32 - '⁴' as u32 + 4, 10),
            _ => None,
        })
        .collect::<Option<String>>()?;
    format!("{mantissa}e{exponent}").parse().ok()
}

/// Pixels per em of a plotters font size (plotters writes `size / 1.24` into the SVG).
fn em(font: u32) -> f64 {
    font as f64 / 1.24
}

/// DejaVu Sans advance widths, in em, of ASCII ' ' … '~' (read from the font's `hmtx` table;
/// DejaVu Sans is what `sans-serif` resolves to on this machine and most Linux systems, and is
/// wider than Helvetica or Arial, so other viewers have room to spare).
// 0.318 em (a period, a comma) is a font width, not 1/π.
#[allow(clippy::approx_constant)]
const ASCII_EM: [f64; 95] = [
    0.318, 0.401, 0.460, 0.838, 0.636, 0.950, 0.780, 0.275, 0.390, 0.390, 0.500, 0.838, 0.318, 0.361, 0.318,
    0.337, 0.636, 0.636, 0.636, 0.636, 0.636, 0.636, 0.636, 0.636, 0.636, 0.636, 0.337, 0.337, 0.838, 0.838,
    0.838, 0.531, 1.000, 0.684, 0.686, 0.698, 0.770, 0.632, 0.575, 0.775, 0.752, 0.295, 0.295, 0.656, 0.557,
    0.863, 0.748, 0.787, 0.603, 0.787, 0.695, 0.635, 0.611, 0.732, 0.684, 0.989, 0.685, 0.611, 0.685, 0.390,
    0.337, 0.390, 0.838, 0.500, 0.500, 0.613, 0.635, 0.550, 0.635, 0.615, 0.352, 0.635, 0.634, 0.278, 0.278,
    0.579, 0.278, 0.974, 0.634, 0.612, 0.635, 0.635, 0.411, 0.521, 0.392, 0.634, 0.592, 0.818, 0.592, 0.592,
    0.525, 0.636, 0.337, 0.636, 0.838,
];

/// The advance width of `c` in em: [`ASCII_EM`], the symbols the plots use, and a wide default.
#[allow(clippy::approx_constant)]
fn char_em(c: char) -> f64 {
    match c {
        ' '..='~' => ASCII_EM[c as usize - ' ' as usize],
        '·' | 'Î' => 0.318,
        '²' | '³' | '₀' | '₁' | '⁰' | '¹' | '⁴'..='⁹' | '⁻' => 0.401,
        '°' | '–' => 0.5,
        '∫' => 0.521,
        'λ' | 'σ' => 0.592,
        'θ' => 0.612,
        '∝' => 0.714,
        '±' | '×' | '−' | '≤' | '≥' | 'ω' => 0.838,
        '—' => 1.0,
        _ => 0.9,
    }
}

/// Estimated width in pixels of `text` drawn at `font` px: its DejaVu Sans advance widths
/// ([`char_em`]) plus 3% (kerning, hinting). Decides whether a header line or an axis
/// description fits; the legend keeps its own rougher rule.
pub fn estimated_width(text: &str, font: f64) -> f64 {
    1.03 * text.chars().map(char_em).sum::<f64>() * font / 1.24
}

/// `full` if it is estimated to fit in `px` pixels at `font` px, else `short`: for axis
/// descriptions that name the integrand, which can be long (a render-scene pixel).
pub fn fitting_label(full: String, short: &str, font: u32, px: f64) -> String {
    if estimated_width(&full, font as f64) <= px {
        full
    } else {
        short.to_string()
    }
}

/// The largest font size up to `font` px at which `text` is estimated to fit in `px` pixels,
/// but at least `min` (below that the text is clipped rather than made unreadable).
pub fn fitted_font(text: &str, font: f64, min: f64, px: f64) -> f64 {
    let width = estimated_width(text, font);
    if width <= px {
        font
    } else {
        // Rounded down to a tenth of a pixel, so that the text stays inside `px`.
        ((font * px / width * 10.0).floor() / 10.0).max(min)
    }
}

/// Estimated width in pixels of a number drawn at `font` (DejaVu Sans, the usual `sans-serif`,
/// has digits 0.64 em wide).
pub fn text_width(text: &str, font: u32) -> f64 {
    text.chars().count() as f64 * 0.64 * em(font)
}

/// Ticks of a logarithmic count axis (N, spp) over `[lo, hi]` drawn `px` pixels wide: the
/// `grid` values — all powers of two between its ends when the grid is made of powers of two —
/// labelled with every s-th value for the smallest step s at which no two labels come closer than
/// 12 px, the rest as minor ticks.
pub fn count_ticks(grid: &[usize], lo: f64, hi: f64, px: f64) -> Ticks {
    let mut g: Vec<usize> = grid.to_vec();
    g.sort_unstable();
    g.dedup();
    let candidates: Vec<f64> = match (g.first(), g.last()) {
        (Some(&a), Some(&b)) if g.iter().all(|n| n.is_power_of_two()) => {
            let (ka, kb) = (a.trailing_zeros(), b.trailing_zeros());
            (ka..=kb).map(|k| (1u64 << k) as f64).collect()
        }
        _ => g.iter().map(|&n| n as f64).collect(),
    };
    let pos = |v: f64| (v.ln() - lo.ln()) / (hi.ln() - lo.ln()) * px;
    let width = |v: f64| text_width(&format_count(v), TICK_FONT);
    for step in 1..=candidates.len().max(1) {
        let chosen: Vec<f64> = candidates.iter().copied().step_by(step).collect();
        let fits = chosen
            .windows(2)
            .all(|w| pos(w[1]) - pos(w[0]) >= 0.5 * (width(w[0]) + width(w[1])) + 12.0);
        if fits {
            let minor = candidates
                .iter()
                .copied()
                .filter(|c| !chosen.contains(c))
                .collect();
            return Ticks {
                labelled: chosen,
                minor,
            };
        }
    }
    Ticks::default()
}

/// A count-axis label: the integer.
pub fn format_count(v: f64) -> String {
    format!("{}", v.round())
}

/// A figure's white page split into its title block, its chart (`chart_height` pixels) and the
/// legend below.
#[allow(clippy::type_complexity)]
pub fn layout<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    chart_height: u32,
) -> Result<
    (
        DrawingArea<DB, Shift>,
        DrawingArea<DB, Shift>,
        DrawingArea<DB, Shift>,
    ),
    DrawingAreaErrorKind<DB::ErrorType>,
> {
    root.fill(&WHITE)?;
    let (header, rest) = root.split_vertically(HEADER_HEIGHT);
    let (chart, legend) = rest.split_vertically(chart_height);
    Ok((header, chart, legend))
}

/// [`draw_minor_ticks`] at the chart's own coordinates: `x_minor` along the bottom axis,
/// `y_minor` along the left one, `corner` the chart's lower-left data corner.
pub fn chart_minor_ticks<'a, DB: DrawingBackend, X: Ranged<ValueType = f64>, Y: Ranged<ValueType = f64>>(
    root: &DrawingArea<DB, Shift>,
    chart: &ChartContext<'a, DB, Cartesian2d<X, Y>>,
    x_minor: &[f64],
    y_minor: &[f64],
    corner: (f64, f64),
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let plot = chart.plotting_area().get_pixel_range();
    let xs: Vec<i32> = x_minor
        .iter()
        .map(|&x| chart.backend_coord(&(x, corner.1)).0)
        .collect();
    let ys: Vec<i32> = y_minor
        .iter()
        .map(|&y| chart.backend_coord(&(corner.0, y)).1)
        .collect();
    draw_minor_ticks(root, &plot, &xs, &ys)
}

/// Draws short unlabelled tick marks outside the plotting area `plot` (its pixel ranges, as
/// from `ChartContext::plotting_area().get_pixel_range()`): at pixel columns `xs` under the x
/// axis and pixel rows `ys` left of the y axis.
pub fn draw_minor_ticks<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    plot: &(std::ops::Range<i32>, std::ops::Range<i32>),
    xs: &[i32],
    ys: &[i32],
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let style = BLACK.mix(0.7).stroke_width(1);
    let (xr, yr) = plot;
    for &x in xs.iter().filter(|x| xr.contains(x)) {
        root.draw(&PathElement::new(vec![(x, yr.end), (x, yr.end + 3)], style))?;
    }
    for &y in ys.iter().filter(|y| yr.contains(y)) {
        root.draw(&PathElement::new(vec![(xr.start - 3, y), (xr.start, y)], style))?;
    }
    Ok(())
}

/// Room for a header line: the figure's width less 20 px on each side.
const HEADER_TEXT_WIDTH: f64 = (WIDTH - 40) as f64;

/// Draws the title (25 px) and a subtitle (18 px), centred, in the top `HEADER_HEIGHT` pixels of
/// `area`. A line too wide for the figure is drawn smaller, down to 60% of its size
/// ([`fitted_font`]), rather than clipped at both ends.
pub fn draw_header<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    title: &str,
    subtitle: &str,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let centre = (WIDTH / 2) as i32;
    let top = Pos::new(HPos::Center, VPos::Top);
    let title_font = fitted_font(title, 25.0, 15.0, HEADER_TEXT_WIDTH);
    area.draw(&Text::new(
        title.to_string(),
        (centre, 10),
        (FONT, title_font).into_font().color(&BLACK).pos(top),
    ))?;
    let subtitle_font = fitted_font(subtitle, 18.0, 10.8, HEADER_TEXT_WIDTH);
    area.draw(&Text::new(
        subtitle.to_string(),
        (centre, 38),
        (FONT, subtitle_font)
            .into_font()
            .color(&RGBColor(70, 70, 70))
            .pos(top),
    ))?;
    Ok(())
}

/// How a series is drawn: its colour (an index into [`PALETTE`]), its marker shape (an index
/// for [`draw_marker`]) and whether its line is dashed. Series `i` is by default
/// [`SeriesStyle::of`]`(i)`; figures that group series (by method, by first stage) or draw one
/// series over another (coincident series) choose the parts apart.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SeriesStyle {
    /// The colour: [`colour`]`(colour)`.
    pub colour: usize,
    /// The marker: [`draw_marker`]'s shape `marker`.
    pub marker: usize,
    /// A dashed line (dashes of 8 px, gaps of 5 px) rather than a solid one.
    pub dashed: bool,
    /// How many later series lie on this one ([`coincidences`]): its markers grow with it.
    pub grow: usize,
}

impl SeriesStyle {
    /// Series `i`'s default: colour `i`, marker `i`, a solid line.
    pub fn of(i: usize) -> Self {
        SeriesStyle {
            colour: i,
            marker: i,
            dashed: false,
            grow: 0,
        }
    }

    /// The markers' size factor: 1, and 1.5 or 2 for a series one or more later series lie on,
    /// so that the markers of a coincident group nest, the first largest.
    pub fn marker_scale(self) -> f64 {
        1.0 + 0.5 * self.grow.min(2) as f64
    }

    /// The line's width in pixels: 2, and 5 or 8 for a series one or more later series lie on,
    /// so that a later line drawn over it leaves it showing on both sides, in its own style.
    pub fn line_width(self) -> u32 {
        2 + 3 * self.grow.min(2) as u32
    }
}

/// The sample drawn before a legend entry's text.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Swatch {
    /// Series `i`: a line in [`colour`]`(i)` with [`draw_marker`]'s shape `i`.
    Series(usize),
    /// A series in its own style ([`SeriesStyle`]).
    Styled(SeriesStyle),
    /// A dashed grey reference line.
    Guide,
    /// A light grey band with dashed edges (what a quantile band is).
    Band,
    /// A vertical grey bar with caps (what an interval bar is).
    Bar,
}

/// One legend entry: a sample and a short text. What the entry means at length goes in the
/// figure's caption file, not in the figure.
#[derive(Clone, Debug, PartialEq)]
pub struct LegendEntry {
    /// The sample drawn before the text.
    pub swatch: Swatch,
    /// The text, one line.
    pub text: String,
}

impl LegendEntry {
    /// Series `i`'s entry.
    pub fn series(i: usize, text: impl Into<String>) -> Self {
        LegendEntry {
            swatch: Swatch::Series(i),
            text: text.into(),
        }
    }

    /// An entry with any sample: a guide, a band, bars, a styled series.
    pub fn key(swatch: Swatch, text: impl Into<String>) -> Self {
        LegendEntry {
            swatch,
            text: text.into(),
        }
    }
}

/// A drawn figure: the SVG, and its caption — what the figure's marks mean at length, written
/// beside it as `<plot>.caption.txt` ([`caption_name`]), so that the figure keeps only its
/// title, axes and legend.
#[derive(Clone, Debug, PartialEq)]
pub struct Figure {
    /// The SVG document.
    pub svg: String,
    /// The caption: the title and subtitle on the first two lines, then one paragraph per
    /// line, paragraphs separated by blank lines; ends with a newline.
    pub caption: String,
}

/// The caption file of the figure `svg_name`: `cos3.svg` → `cos3.caption.txt`.
pub fn caption_name(svg_name: &str) -> String {
    format!(
        "{}.caption.txt",
        svg_name.strip_suffix(".svg").unwrap_or(svg_name)
    )
}

/// The caption text of a figure titled `title` (subtitle `subtitle`) with paragraphs `prose`.
pub fn caption_text(title: &str, subtitle: &str, prose: &[String]) -> String {
    let mut s = format!("{title}\n{subtitle}\n");
    for p in prose {
        s.push('\n');
        s.push_str(p);
        s.push('\n');
    }
    s
}

/// Writes `figure` into `folder`: the SVG as `name` and its caption as [`caption_name`]`(name)`,
/// both listed in the manifest.
pub fn write_figure(
    folder: &mut crate::files::result_folder::ResultFolder,
    name: &str,
    description: &str,
    figure: &Figure,
) -> crate::Result<()> {
    folder.write(name, description, figure.svg.as_bytes())?;
    folder.write(
        &caption_name(name),
        &format!("the caption of {name}: what its marks mean, and series drawn over one another"),
        figure.caption.as_bytes(),
    )
}

/// [`write_figure`] for a machine-dependent figure (listed in `timings.json`, not committed).
pub fn write_figure_local(
    folder: &mut crate::files::result_folder::ResultFolder,
    name: &str,
    description: &str,
    figure: &Figure,
) -> crate::Result<()> {
    folder.write_local(name, description, figure.svg.as_bytes())?;
    folder.write_local(
        &caption_name(name),
        &format!("the caption of {name} (machine-dependent; not committed)"),
        figure.caption.as_bytes(),
    )
}

/// Where two series drawn on the same axes would hide each other: the x values at which both
/// have a point and their points lie within `px` pixels, given `to_px` (a y value to its pixel
/// row). For the caption's note on coincident series and to draw the later one distinguishably.
pub fn coincident_at(a: &[(f64, f64)], b: &[(f64, f64)], to_px: impl Fn(f64) -> f64, px: f64) -> Vec<f64> {
    a.iter()
        .filter_map(|&(x, ya)| {
            let &(_, yb) = b.iter().find(|p| p.0 == x)?;
            ((to_px(ya) - to_px(yb)).abs() <= px).then_some(x)
        })
        .collect()
}

/// The caption's note when an `x^(−1/2)` guide line hides `series` (named `name`): the x values
/// (`axis`: `N`, `spp`) at which the guide's value `on_guide(x)` lies within [`COINCIDENT_PX`]
/// of the series' point, or None where it hides nothing.
pub fn guide_note(
    series: &[(f64, f64)],
    on_guide: impl Fn(f64) -> f64,
    to_px: impl Fn(f64) -> f64,
    name: &str,
    axis: &str,
) -> Option<String> {
    let guide: Vec<(f64, f64)> = series.iter().map(|&(x, _)| (x, on_guide(x))).collect();
    let at = coincident_at(series, &guide, to_px, COINCIDENT_PX);
    (!at.is_empty()).then(|| {
        format!(
            "The {axis}^(−1/2) guide lies on {name} at {axis} = {} (within {COINCIDENT_PX} px): it is \
             drawn over that line, grey and dashed.",
            list_values(&at)
        )
    })
}

/// The pixel row of `y` on a log axis over `range` drawn `height` pixels high (0 at the bottom).
pub fn log_px(range: (f64, f64), height: f64) -> impl Fn(f64) -> f64 {
    move |y: f64| (y.ln() - range.0.ln()) / (range.1.ln() - range.0.ln()) * height
}

/// Markers closer than this (in pixels) hide each other: a marker is 8–12 px wide.
pub const COINCIDENT_PX: f64 = 4.0;

/// `xs` as a short list for a caption: `N = 32, 64, 128`.
pub fn list_values(xs: &[f64]) -> String {
    xs.iter().map(|x| format!("{x}")).collect::<Vec<_>>().join(", ")
}

/// Whether the x values `at` include two neighbours of `series` (its points in x order): then
/// the two series share a line segment there and one hides the other. Lines that merely cross
/// (one shared point) stay apart by their markers' shapes.
fn shares_a_segment(series: &[(f64, f64)], at: &[f64]) -> bool {
    series
        .windows(2)
        .any(|w| at.contains(&w[0].0) && at.contains(&w[1].0))
}

/// Which series of a figure lie on one another, and what the caption says about it.
#[derive(Clone, Debug, PartialEq)]
pub struct Coincidences {
    /// Per series, whether it lies on an earlier one (drawn over it).
    pub over: Vec<bool>,
    /// Per series, how many later series lie on it (its line and markers grow).
    pub under: Vec<usize>,
    /// The caption's sentences, one per pair.
    pub notes: Vec<String>,
}

impl Coincidences {
    /// Series `i`'s style from `base` (its face, whose colour, marker and line style never
    /// change): its line and markers grown by the number of later series on it.
    pub fn style(&self, i: usize, base: SeriesStyle) -> SeriesStyle {
        SeriesStyle {
            grow: self.under.get(i).copied().unwrap_or(0),
            ..base
        }
    }
}

/// Which series (their points, in drawing order) lie on an earlier one along at least one
/// segment (two neighbouring points within [`COINCIDENT_PX`]): those are drawn over it, whose
/// line and markers grow, so that a wide line under a narrow one and nested markers of different
/// shapes show every series, each in its own face. The caption's sentence for each pair: `"BMCP lies on BMC at N = 32, 64 (markers
/// within 4 px): …"`.
pub fn coincidences(
    names: &[String],
    points: &[Vec<(f64, f64)>],
    to_px: impl Fn(f64) -> f64,
    x_name: &str,
) -> Coincidences {
    let mut c = Coincidences {
        over: vec![false; points.len()],
        under: vec![0; points.len()],
        notes: Vec::new(),
    };
    for j in 0..points.len() {
        for i in 0..j {
            let at = coincident_at(&points[i], &points[j], &to_px, COINCIDENT_PX);
            if !shares_a_segment(&points[i], &at) {
                continue;
            }
            c.over[j] = true;
            c.under[i] += 1;
            c.notes.push(format!(
                "{} lies on {} at {x_name} = {} (markers within {COINCIDENT_PX} px): it is drawn over it, \
                 and {}'s line and markers are drawn wider, so that both stay visible.",
                names[j],
                names[i],
                list_values(&at),
                names[i]
            ));
        }
    }
    c
}

const SWATCH_WIDTH: i32 = 34;
const ROW_HEIGHT: u32 = 24;
const LEGEND_PAD: u32 = 10;

/// Columns for the entries: as many as fit in the width, at most 3.
fn legend_columns(entries: &[LegendEntry]) -> usize {
    let widest = entries
        .iter()
        .map(|e| SWATCH_WIDTH as f64 + 8.0 + legend_text_width(&e.text))
        .fold(0.0, f64::max);
    let usable = (WIDTH - 2 * LEGEND_PAD) as f64;
    ((usable / (widest + 24.0)).floor() as usize).clamp(1, 3)
}

fn legend_rows(entries: &[LegendEntry]) -> (usize, usize) {
    let columns = legend_columns(entries);
    (entries.len().div_ceil(columns), columns)
}

/// Estimated width in pixels of legend text (DejaVu Sans letters, spaces and digits average
/// ~0.55 em; a little over, so that estimated lines never run past the frame).
fn legend_text_width(text: &str) -> f64 {
    text.chars().count() as f64 * 0.55 * em(LEGEND_FONT)
}

/// Height in pixels of the legend block for `entries`.
pub fn legend_height(entries: &[LegendEntry]) -> u32 {
    let (rows, _) = legend_rows(entries);
    rows as u32 * ROW_HEIGHT + 2 * LEGEND_PAD
}

/// Draws the legend block (below the chart, framed): the entries in columns, row by row.
pub fn draw_legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    entries: &[LegendEntry],
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let (_, columns) = legend_rows(entries);
    let height = legend_height(entries) as i32;
    let left = 16;
    area.draw(&Rectangle::new(
        [(left - 6, 2), (WIDTH as i32 - 10, height - 4)],
        BLACK.mix(0.35).stroke_width(1),
    ))?;
    let column_width = (WIDTH as i32 - 2 * left) / columns as i32;
    let font = (FONT, LEGEND_FONT)
        .into_font()
        .color(&BLACK)
        .pos(Pos::new(HPos::Left, VPos::Center));
    for (k, e) in entries.iter().enumerate() {
        let (row, col) = (k / columns, k % columns);
        let x = left + col as i32 * column_width;
        let y = LEGEND_PAD as i32 + row as i32 * ROW_HEIGHT as i32 + ROW_HEIGHT as i32 / 2;
        draw_swatch(area, e.swatch, x, y)?;
        area.draw(&Text::new(
            e.text.clone(),
            (x + SWATCH_WIDTH + 8, y),
            font.clone(),
        ))?;
    }
    Ok(())
}

fn draw_swatch<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    swatch: Swatch,
    x: i32,
    y: i32,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let w = SWATCH_WIDTH;
    match swatch {
        Swatch::Series(i) => draw_swatch(area, Swatch::Styled(SeriesStyle::of(i)), x, y)?,
        Swatch::Styled(style) => {
            // The face as the series is drawn (a wider line and larger markers included).
            let c = colour(style.colour);
            let stroke = c.stroke_width(style.line_width());
            if style.dashed {
                dashed(area, x, x + w, y, stroke)?;
            } else {
                area.draw(&PathElement::new(vec![(x, y), (x + w, y)], stroke))?;
            }
            draw_styled_marker(area, style, (x + w / 2, y))?;
        }
        Swatch::Guide => dashed(area, x, x + w, y, GUIDE.stroke_width(2))?,
        Swatch::Band => {
            area.draw(&Rectangle::new(
                [(x, y - 7), (x + w, y + 7)],
                GUIDE.mix(0.15).filled(),
            ))?;
            dashed(area, x, x + w, y - 7, GUIDE.stroke_width(1))?;
            dashed(area, x, x + w, y + 7, GUIDE.stroke_width(1))?;
        }
        Swatch::Bar => {
            let m = x + w / 2;
            let s = GUIDE.stroke_width(2);
            area.draw(&PathElement::new(vec![(m, y - 8), (m, y + 8)], s))?;
            area.draw(&PathElement::new(vec![(m - 4, y - 8), (m + 4, y - 8)], s))?;
            area.draw(&PathElement::new(vec![(m - 4, y + 8), (m + 4, y + 8)], s))?;
        }
    }
    Ok(())
}

/// A horizontal dashed line from `x0` to `x1` at `y`, dashes of 6 px with gaps of 4 px.
fn dashed<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    x0: i32,
    x1: i32,
    y: i32,
    style: ShapeStyle,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let mut x = x0;
    while x < x1 {
        area.draw(&PathElement::new(vec![(x, y), ((x + 6).min(x1), y)], style))?;
        x += 10;
    }
    Ok(())
}

/// `x` with `decimals` decimals and a typographic minus sign (−1.52); never a negative zero.
pub fn signed(x: f64, decimals: usize) -> String {
    let s = format!("{x:.decimals$}");
    // "-0.00" would read as a negative zero.
    let s = if s.trim_start_matches('-').chars().all(|c| c == '0' || c == '.') {
        s.trim_start_matches('-').to_string()
    } else {
        s
    };
    s.replace('-', "−")
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A title that fits keeps its size; one that does not is drawn smaller, so that it is
    /// estimated to fit, but never below the minimum (regression: two experiment titles were
    /// clipped at both ends of their plots).
    #[test]
    fn header_lines_shrink_to_fit_the_figure() {
        let room = HEADER_TEXT_WIDTH;
        let short = "MC vs BMC vs BMCP on cos³θ over the hemisphere";
        assert_eq!(fitted_font(short, 25.0, 15.0, room), 25.0);
        let long = "cos³θ and a tilted Gaussian: i.i.d. uniform points against symmetric rings \
                    (J rings of M azimuths)";
        let font = fitted_font(long, 25.0, 15.0, room);
        assert!((15.0..25.0).contains(&font), "{font}");
        assert!(estimated_width(long, font) <= room);
        assert_eq!(fitted_font(&"x".repeat(1000), 25.0, 15.0, room), 15.0);
        // In the SVG: plotters writes size / 1.24.
        let svg = svg_figure(long, "s", 100, &[], &[], |_, _| Ok(())).unwrap().svg;
        assert!(svg.contains(&format!("font-size=\"{}\"", font / 1.24)), "{svg}");
        assert!(!svg.contains(&format!("font-size=\"{}\"", 25.0 / 1.24)), "{svg}");
        let svg = svg_figure(short, "s", 100, &[], &[], |_, _| Ok(())).unwrap().svg;
        assert!(svg.contains(&format!("font-size=\"{}\"", 25.0 / 1.24)), "{svg}");
    }

    /// No two of the first 63 series share both colour and marker (the [`MARKERS`] claim).
    #[test]
    fn series_differ_in_colour_or_marker_for_63_series() {
        let style = |i: usize| (colour(i), marker_shape(i));
        for i in 0..63 {
            for j in i + 1..63 {
                assert_ne!(style(i), style(j), "series {i} and {j}");
            }
        }
        assert_eq!(style(0), style(63));
    }

    #[test]
    fn axis_labels_fall_back_to_the_short_form_when_too_long() {
        let full = "absolute error |Î − I| of ∫ cos³θ dω  [sr]".to_string();
        assert_eq!(fitting_label(full.clone(), "short", AXIS_FONT, 500.0), full);
        let long = format!(
            "absolute error |Î − I| of ∫ {} dω  [sr]",
            "pixel (128, 168) ".repeat(4)
        );
        assert_eq!(fitting_label(long, "short", AXIS_FONT, 500.0), "short");
    }

    #[test]
    fn error_axes_label_decades_and_keep_the_rest_minor() {
        let t = log_ticks(3e-5, 2.0);
        assert_eq!(t.labelled, [1e-4, 1e-3, 1e-2, 1e-1, 1.0]);
        assert!(t.minor.contains(&5e-5) && t.minor.contains(&2.0) && !t.minor.contains(&1e-3));
        assert_eq!(format_tick(1e-3, false), "10⁻³");
        // Less than two decades: 2 and 5 join in, in decimals.
        let t = log_ticks(0.018, 0.13);
        assert_eq!(t.labelled, [0.02, 0.05, 0.1]);
        assert!(decimal_axis(0.018, 0.13) && !decimal_axis(3e-5, 2.0));
        assert_eq!(format_tick(0.02, true), "0.02");
        // Narrower still: every multiple.
        assert_eq!(log_ticks(0.031, 0.048).labelled, [0.04]);
        assert_eq!(log_ticks(0.029, 0.048).labelled, [0.03, 0.04]);
    }

    /// 4 … 16384 at the experiment plot's width: every power of two, with room between labels;
    /// 1 … 10⁷ must be thinned.
    #[test]
    fn count_axes_do_not_crowd() {
        let grid: Vec<usize> = (2..=14).map(|k| 1 << k).collect();
        let px = 820.0;
        let (lo, hi) = (4.0 / 1.2, 16384.0 * 1.2);
        let t = count_ticks(&grid, lo, hi, px);
        assert_eq!(t.labelled.len(), 13);
        let wide: Vec<usize> = [1, 10, 100, 1000, 10_000, 100_000, 1_000_000, 10_000_000].to_vec();
        let all_pow2: Vec<usize> = (0..=23).map(|k| 1 << k).collect();
        for g in [&wide, &all_pow2] {
            let (lo, hi) = (g[0] as f64 / 1.2, *g.last().unwrap() as f64 * 1.2);
            let t = count_ticks(g, lo, hi, px);
            assert!(t.labelled.len() >= 4, "{t:?}");
            let pos = |v: f64| (v.ln() - lo.ln()) / (hi.ln() - lo.ln()) * px;
            for w in t.labelled.windows(2) {
                let need = 0.5
                    * (text_width(&format_count(w[0]), TICK_FONT)
                        + text_width(&format_count(w[1]), TICK_FONT));
                assert!(pos(w[1]) - pos(w[0]) > need, "{w:?} overlap");
            }
        }
        // A grid of non-powers of two is labelled at its own values.
        let t = count_ticks(&[20, 40, 60, 80], 18.0, 88.0, px);
        assert_eq!(t.labelled, [20.0, 40.0, 60.0, 80.0]);
    }

    /// Every marker draws a different shape: the SVG of each, in one colour, differs.
    #[test]
    fn markers_are_distinct() {
        let shapes: Vec<String> = (0..MARKERS)
            .map(|i| {
                let mut svg = String::new();
                {
                    let area = SVGBackend::with_string(&mut svg, (20, 20)).into_drawing_area();
                    draw_marker(&area, i, (10, 10), BLACK).unwrap();
                    area.present().unwrap();
                }
                svg
            })
            .collect();
        for i in 0..MARKERS {
            for j in 0..i {
                assert_ne!(shapes[i], shapes[j], "markers {i} and {j}");
            }
        }
    }

    /// Issue 22 item 4: powers of ten read `10⁻³`, other multiples `5×10⁻³`, positive
    /// exponents `10²`; [`parse_tick`] reads every form back.
    #[test]
    fn ticks_read_as_powers_of_ten_with_superscript_exponents() {
        assert_eq!(format_tick(1e-1, false), "10⁻¹");
        assert_eq!(format_tick(5e-3, false), "5×10⁻³");
        assert_eq!(format_tick(2.5e-12, false), "2.5×10⁻¹²");
        assert_eq!(format_tick(1.0, false), "10⁰");
        assert_eq!(format_tick(100.0, false), "10²");
        assert_eq!(format_tick(4e7, false), "4×10⁷");
        assert_eq!(format_tick(0.05, true), "0.05");
        for v in [1e-1, 5e-3, 2.5e-12, 1.0, 100.0, 4e7, 6e-9, 8e-10] {
            assert_eq!(parse_tick(&format_tick(v, false)), Some(v), "{v}");
        }
        assert_eq!(parse_tick("0.05"), Some(0.05));
        assert_eq!(parse_tick("MC"), None);
        assert_eq!(parse_tick("10x"), None);
    }

    /// Every legend entry takes one row slot; the block's height follows the rows.
    #[test]
    fn legend_entries_fill_columns_row_by_row() {
        let entries: Vec<LegendEntry> = (0..7).map(|i| LegendEntry::series(i, "short")).collect();
        let (rows, columns) = legend_rows(&entries);
        assert_eq!((rows, columns), (3, 3));
        assert_eq!(legend_height(&entries), 3 * ROW_HEIGHT + 2 * LEGEND_PAD);
    }

    /// Series whose points lie within [`COINCIDENT_PX`] of an earlier series' are found, named in
    /// a note with where, and marked to be drawn over it; apart, nothing is said.
    #[test]
    fn coincident_series_are_found_and_noted() {
        let to_px = log_px((1e-3, 1.0), 500.0);
        let a = vec![(16.0, 0.1), (32.0, 0.01), (64.0, 0.002)];
        let b = vec![(16.0, 0.2), (32.0, 0.0101), (64.0, 0.00201)];
        let c = vec![(16.0, 0.5), (32.0, 0.5), (64.0, 0.5)];
        assert_eq!(coincident_at(&a, &b, &to_px, COINCIDENT_PX), [32.0, 64.0]);
        let names = ["BMC".to_string(), "BMCP".into(), "MC".into(), "X".into()];
        // X crosses BMC at one point only: a crossing, not a coincidence.
        let crossing = vec![(16.0, 0.5), (32.0, 0.0101), (64.0, 0.5)];
        let found = coincidences(&names, &[a, b, c, crossing], &to_px, "N");
        assert_eq!(found.over, [false, true, false, false]);
        assert_eq!(found.under, [1, 0, 0, 0]);
        assert_eq!(found.notes.len(), 1);
        assert!(
            found.notes[0].starts_with("BMCP lies on BMC at N = 32, 64"),
            "{}",
            found.notes[0]
        );
        // BMC's line and markers grow, BMCP keeps its face (a face never changes its line).
        assert_eq!(found.style(0, SeriesStyle::of(0)).marker_scale(), 1.5);
        assert_eq!(found.style(0, SeriesStyle::of(0)).line_width(), 5);
        assert_eq!(found.style(1, SeriesStyle::of(1)), SeriesStyle::of(1));
        assert_eq!(found.style(2, SeriesStyle::of(2)), SeriesStyle::of(2));
        assert_eq!(caption_name("cos3.svg"), "cos3.caption.txt");
    }

    #[test]
    fn slopes_print_with_a_real_minus() {
        assert_eq!(signed(-1.524, 2), "−1.52");
        assert_eq!(signed(0.5, 2), "0.50");
        assert_eq!(signed(-0.001, 2), "0.00");
    }
}
