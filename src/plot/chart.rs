//! The frame every workbench chart shares, so that a plot states only what is its own (data,
//! ranges, titles, axis descriptions, tick labels): the SVG figure (title block, chart, legend
//! below), the chart's margins and label areas, the mesh's fonts and lines, log axes with their
//! labelled key points and minor ticks, and the recurring marks (series line with markers,
//! dashed guide, binomial band around a level, interval bars).

use super::{
    AXIS_FONT, FONT, Figure, GUIDE, HEADER_HEIGHT, LegendEntry, SeriesStyle, TICK_FONT, Ticks, WIDTH,
    caption_text, chart_minor_ticks, colour, draw_header, draw_legend, draw_styled_marker, format_count,
    format_tick, layout, legend_height,
};
use plotters::coord::Shift;
use plotters::coord::combinators::{LogCoord, WithKeyPoints};
use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
use plotters::prelude::*;

/// Left margin of a chart in its area, in pixels.
pub const MARGIN_LEFT: u32 = 16;
/// Right margin of a chart (room for the last x label), in pixels.
pub const MARGIN_RIGHT: u32 = 28;
const MARGIN_TOP: u32 = 8;
/// Height of the x label area (tick labels and the axis description).
const X_LABEL_AREA: u32 = 52;
/// Width of the y label area; the plotting area's width follows from it.
pub const Y_LABEL_AREA: u32 = 84;
/// Width in pixels of a chart's plotting area (what [`super::count_ticks`] spaces labels over).
pub const PLOT_WIDTH: f64 = (WIDTH - MARGIN_LEFT - MARGIN_RIGHT - Y_LABEL_AREA) as f64;

/// The plotting area's height in a chart area `chart_height` pixels high: the room for the y
/// axis's description.
pub fn plot_height(chart_height: u32) -> f64 {
    chart_height.saturating_sub(MARGIN_TOP + X_LABEL_AREA) as f64
}

/// The error of a drawing: plotters' own, or a caller's.
pub type FigureResult<T> = Result<T, Box<dyn std::error::Error>>;

/// A drawing area of an SVG figure.
pub type SvgArea<'s> = DrawingArea<SVGBackend<'s>, Shift>;

/// Whether a value can stand on a log axis (positive and finite).
pub fn on_log_axis(v: f64) -> bool {
    v.is_finite() && v > 0.0
}

/// How an axis's tick labels read.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Labels {
    /// A count (N, spp): the integer ([`format_count`]).
    Count,
    /// A log tick `m·10^k`: decimals (`0.05`) when `decimal`, else `5×10⁻²` ([`format_tick`]).
    Log { decimal: bool },
    /// A fixed number of decimals (a share: `0.95`).
    Fixed(usize),
}

impl Labels {
    /// The label of the tick at `v`.
    pub fn format(self, v: f64) -> String {
        match self {
            Labels::Count => format_count(v),
            Labels::Log { decimal } => format_tick(v, decimal),
            Labels::Fixed(decimals) => format!("{v:.decimals$}"),
        }
    }
}

/// One axis of a chart: its range, its ticks (labelled ones with grid lines, minor ones as short
/// marks; unused on a linear axis, which plotters ticks itself), what it shows, how labels read.
#[derive(Clone, Debug, PartialEq)]
pub struct Axis {
    pub range: (f64, f64),
    pub ticks: Ticks,
    pub desc: String,
    pub labels: Labels,
}

/// A log axis with grid lines and labels at chosen values only.
pub type LogAxis = WithKeyPoints<LogCoord<f64>>;

/// A chart over coordinates `X` × `Y`.
pub type Chart<'a, DB, X, Y> = ChartContext<'a, DB, Cartesian2d<X, Y>>;
/// A chart with log axes both ways.
pub type LogLogChart<'a, DB> = Chart<'a, DB, LogAxis, LogAxis>;

/// A plotters coordinate of `f64` values (linear, or log with or without key points).
pub trait F64Coord: Ranged<ValueType = f64> {}
impl<T: Ranged<ValueType = f64>> F64Coord for T {}

impl Axis {
    /// A log axis of values (errors, seconds, tolerances) over `range`: [`super::log_ticks`],
    /// labelled in decimals or as powers of ten (`10⁻²`) as [`super::decimal_axis`] says.
    pub fn log_values(range: (f64, f64), desc: impl Into<String>) -> Self {
        Axis {
            range,
            ticks: super::log_ticks(range.0, range.1),
            desc: desc.into(),
            labels: Labels::Log {
                decimal: super::decimal_axis(range.0, range.1),
            },
        }
    }

    /// A log axis of counts (N, spp) over `range`, ticked at the values of `grid`
    /// ([`super::count_ticks`] over the plotting area's width).
    pub fn counts(grid: &[usize], range: (f64, f64), desc: impl Into<String>) -> Self {
        Axis {
            range,
            ticks: super::count_ticks(grid, range.0, range.1, PLOT_WIDTH),
            desc: desc.into(),
            labels: Labels::Count,
        }
    }

    /// A linear axis of shares (coverage, share within a tolerance) over `range`, its ticks
    /// plotters' own, labelled with two decimals.
    pub fn shares(range: (f64, f64), desc: impl Into<String>) -> Self {
        Axis {
            range,
            ticks: Ticks::default(),
            desc: desc.into(),
            labels: Labels::Fixed(2),
        }
    }

    /// The axis as a log coordinate labelled at its `ticks.labelled`.
    pub fn log_coord(&self) -> LogAxis {
        let (lo, hi) = self.range;
        (lo..hi).log_scale().with_key_points(self.ticks.labelled.clone())
    }

    /// The axis as a linear coordinate.
    pub fn linear_coord(&self) -> std::ops::Range<f64> {
        self.range.0..self.range.1
    }
}

/// A chart on `area` with the shared margins and label areas, over coordinates `x` × `y`.
#[allow(clippy::type_complexity)]
pub fn chart_on<'a, DB: DrawingBackend, X: AsRangedCoord, Y: AsRangedCoord>(
    area: &'a DrawingArea<DB, Shift>,
    x: X,
    y: Y,
) -> Result<
    ChartContext<'a, DB, Cartesian2d<X::CoordDescType, Y::CoordDescType>>,
    DrawingAreaErrorKind<DB::ErrorType>,
> {
    ChartBuilder::on(area)
        .margin_left(MARGIN_LEFT)
        .margin_right(MARGIN_RIGHT)
        .margin_top(MARGIN_TOP)
        .x_label_area_size(X_LABEL_AREA)
        .y_label_area_size(Y_LABEL_AREA)
        .build_cartesian_2d(x, y)
}

/// Draws the chart's axes in the shared style: descriptions and tick labels from `x` and `y`,
/// faint grid lines at the labelled ticks only, 6 px tick marks.
pub fn draw_mesh<DB, X, Y>(
    chart: &mut Chart<'_, DB, X, Y>,
    x: &Axis,
    y: &Axis,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>>
where
    DB: DrawingBackend,
    X: F64Coord + ValueFormatter<f64>,
    Y: F64Coord + ValueFormatter<f64>,
{
    let x_format = |v: &f64| x.labels.format(*v);
    let y_format = |v: &f64| y.labels.format(*v);
    chart
        .configure_mesh()
        .x_desc(x.desc.as_str())
        .y_desc(y.desc.as_str())
        .x_label_formatter(&x_format)
        .y_label_formatter(&y_format)
        .axis_desc_style((FONT, AXIS_FONT))
        .label_style((FONT, TICK_FONT))
        .bold_line_style(BLACK.mix(0.08))
        .light_line_style(TRANSPARENT)
        .set_all_tick_mark_size(6)
        .draw()
}

/// The log–log chart on `area`: [`chart_on`] over `x.log_coord()` × `y.log_coord()`, [`draw_mesh`], and
/// the minor ticks of both axes drawn on `root`.
pub fn log_log_chart<'a, DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    area: &'a DrawingArea<DB, Shift>,
    x: &Axis,
    y: &Axis,
) -> Result<LogLogChart<'a, DB>, DrawingAreaErrorKind<DB::ErrorType>> {
    let mut chart = chart_on(area, x.log_coord(), y.log_coord())?;
    draw_mesh(&mut chart, x, y)?;
    chart_minor_ticks(
        root,
        &chart,
        &x.ticks.minor,
        &y.ticks.minor,
        (x.range.0, y.range.0),
    )?;
    Ok(chart)
}

/// An SVG figure [`WIDTH`] wide and its caption: the title block (`title`, `subtitle`), a chart
/// area `chart_height` pixels high that `draw_chart` fills (given the whole page, for markers
/// drawn in pixels, and the chart area), and `legend` below; `caption` (one paragraph each)
/// goes into the caption after the title and subtitle ([`caption_text`]), not into the SVG.
pub fn svg_figure(
    title: &str,
    subtitle: &str,
    chart_height: u32,
    legend: &[LegendEntry],
    caption: &[String],
    draw_chart: impl for<'s> FnOnce(&SvgArea<'s>, &SvgArea<'s>) -> FigureResult<()>,
) -> FigureResult<Figure> {
    let height = HEADER_HEIGHT + chart_height + legend_height(legend);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (WIDTH, height)).into_drawing_area();
        let (header, chart_area, legend_area) = layout(&root, chart_height)?;
        draw_header(&header, title, subtitle)?;
        draw_chart(&root, &chart_area)?;
        draw_legend(&legend_area, legend)?;
        root.present()?;
    }
    Ok(Figure {
        svg: superscripts(&svg),
        caption: caption_text(title, subtitle, caption),
    })
}

/// Text written `x^(e)` (a legend's `N^(−1/2)`) typeset with `e` raised and smaller: an SVG
/// `<tspan>` with `baseline-shift="super"`, which plotters' text cannot make. Only inside text
/// (no markup between the parentheses); the caption files keep the plain `^(…)`.
pub fn superscripts(svg: &str) -> String {
    let mut out = String::with_capacity(svg.len());
    let mut rest = svg;
    while let Some(i) = rest.find("^(") {
        let after = &rest[i + 2..];
        match after.find(')') {
            Some(j) if !after[..j].contains(['<', '>', '(']) => {
                out.push_str(&rest[..i]);
                out.push_str("<tspan baseline-shift=\"super\" font-size=\"72%\">");
                out.push_str(&after[..j]);
                out.push_str("</tspan>");
                rest = &after[j + 1..];
            }
            _ => {
                out.push_str(&rest[..i + 2]);
                rest = after;
            }
        }
    }
    out.push_str(rest);
    out
}

/// Series `i`'s line through `points` in its colour, then its marker at each point.
pub fn draw_line_with_markers<DB: DrawingBackend, X: F64Coord, Y: F64Coord>(
    chart: &mut Chart<'_, DB, X, Y>,
    root: &DrawingArea<DB, Shift>,
    i: usize,
    points: &[(f64, f64)],
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    draw_styled_line(chart, root, SeriesStyle::of(i), points)
}

/// A series' line through `points` in `style` (solid or dashed), then its marker at each point.
pub fn draw_styled_line<DB: DrawingBackend, X: F64Coord, Y: F64Coord>(
    chart: &mut Chart<'_, DB, X, Y>,
    root: &DrawingArea<DB, Shift>,
    style: SeriesStyle,
    points: &[(f64, f64)],
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let c = colour(style.colour).stroke_width(style.line_width());
    if style.dashed {
        chart.draw_series(DashedLineSeries::new(points.to_vec(), 8, 5, c))?;
    } else {
        chart.draw_series(LineSeries::new(points.to_vec(), c))?;
    }
    for p in points {
        draw_styled_marker(root, style, chart.backend_coord(p))?;
    }
    Ok(())
}

/// A dashed grey reference line through `points` (a rate guide, a nominal level).
pub fn draw_guide<DB: DrawingBackend, X: F64Coord, Y: F64Coord>(
    chart: &mut Chart<'_, DB, X, Y>,
    points: Vec<(f64, f64)>,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    chart.draw_series(DashedLineSeries::new(points, 8, 5, GUIDE.stroke_width(2)))?;
    Ok(())
}

/// The light grey band `band` (clipped to the chart's `y` range) across the `x` range, and the
/// dashed line at `level` inside it: where a calibrated share falls (math.md §7).
pub fn draw_level_band<DB: DrawingBackend, X: F64Coord, Y: F64Coord>(
    chart: &mut Chart<'_, DB, X, Y>,
    x: (f64, f64),
    y: (f64, f64),
    band: (f64, f64),
    level: f64,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    chart.draw_series(std::iter::once(Rectangle::new(
        [(x.0, band.0.max(y.0)), (x.1, band.1.min(y.1))],
        GUIDE.mix(0.15).filled(),
    )))?;
    draw_guide(chart, vec![(x.0, level), (x.1, level)])
}

/// Vertical interval bars `(x, lo, hi)` in series `i`'s colour.
pub fn draw_bars<DB: DrawingBackend, X: F64Coord, Y: F64Coord>(
    chart: &mut Chart<'_, DB, X, Y>,
    i: usize,
    bars: impl Iterator<Item = (f64, f64, f64)>,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let c = colour(i);
    chart.draw_series(bars.map(|(x, lo, hi)| PathElement::new(vec![(x, lo), (x, hi)], c.stroke_width(2))))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `N^(−1/2)` becomes a raised exponent; text without one, and markup, are left alone.
    #[test]
    fn exponents_are_typeset() {
        assert_eq!(
            superscripts("<text>∝ N^(−1/2) through MC</text>"),
            "<text>∝ N<tspan baseline-shift=\"super\" font-size=\"72%\">−1/2</tspan> through MC</text>"
        );
        for plain in ["<text>N = 4</text>", "a^(b<c>)", "x^(", "^(a(b))"] {
            assert_eq!(superscripts(plain), plain);
        }
    }

    #[test]
    fn labels_read_as_counts_log_ticks_or_fixed_decimals() {
        assert_eq!(Labels::Count.format(64.0), "64");
        assert_eq!(Labels::Log { decimal: false }.format(1e-3), "10⁻³");
        assert_eq!(Labels::Log { decimal: true }.format(0.05), "0.05");
        assert_eq!(Labels::Fixed(2).format(0.954), "0.95");
        assert_eq!(Labels::Fixed(2).format(1.0), "1.00");
    }

    /// The figure is the header, the chart area and the legend stacked: the SVG's height is
    /// their sum, and the chart closure gets an area of exactly `chart_height` pixels.
    #[test]
    fn figures_stack_header_chart_and_legend() {
        let legend = [LegendEntry::series(0, "MC")];
        let mut seen = (0, 0);
        let figure = svg_figure("t", "s", 300, &legend, &["what it means".into()], |_, area| {
            seen = area.dim_in_pixel();
            Ok(())
        })
        .unwrap();
        let svg = figure.svg;
        // The caption is beside the figure, not in it.
        assert_eq!(figure.caption, "t\ns\n\nwhat it means\n");
        assert!(!svg.contains("what it means"));
        assert_eq!(seen, (WIDTH, 300));
        let height = HEADER_HEIGHT + 300 + legend_height(&legend);
        assert!(svg.contains(&format!("height=\"{height}\"")), "{svg}");
    }
}
