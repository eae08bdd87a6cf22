//! The sweep's figure, as PNG and SVG (plotters): two log-log panels, error against bake time
//! and error against frame time. Every row is a marker in its method's colour (f32 filled, f16
//! hollow; circles for the main fine mesh, triangles for the others); each method's main curve (main fine mesh and samples, f32, by increasing `k`) is a
//! line; the Pareto front over the main fine mesh's rows is a black step line with ringed
//! markers.
//!
//! Text needs a TrueType font, read at run time (plotters' `ab_glyph` text, no system font
//! libraries): `LRR_FONT` if set, else the first of [`FONT_PATHS`] that exists. Without one
//! the plot is refused with an error that says what to install; the CSV and the markdown do
//! not depend on it. CI installs `fonts-dejavu-core` (`.ci/run`).

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use plotters::coord::Shift;
use plotters::prelude::*;

use super::analysis;
use super::report::user_error;
use super::row::Row;
use lrr_precompute::error::{Error, Result};

/// Where fonts are looked for when `LRR_FONT` is not set.
pub const FONT_PATHS: [&str; 6] = [
    "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/TTF/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/truetype/liberation/LiberationSans-Regular.ttf",
    "/System/Library/Fonts/Supplemental/Arial.ttf",
    "C:\\Windows\\Fonts\\arial.ttf",
];

const WIDTH: u32 = 1400;
const HEIGHT: u32 = 560;
const MF_COLOUR: RGBColor = RGBColor(31, 119, 180);
const MSC_COLOUR: RGBColor = RGBColor(214, 39, 40);
const SPLIT_COLOUR: RGBColor = RGBColor(44, 160, 44);

/// Writes `PREFIX.png` and `PREFIX.svg`; returns their paths.
pub fn write(prefix: &Path, title: &str, rows: &[Row]) -> Result<[PathBuf; 2]> {
    if rows.is_empty() {
        return Err(Error::Settings("no rows to plot".into()));
    }
    register_font()?;
    let png = with_extension(prefix, "png");
    let svg = with_extension(prefix, "svg");
    let fail = |path: &Path, e: String| {
        Error::Settings(format!("cannot draw the plot {}: {e}", path.display()))
    };
    {
        let root = BitMapBackend::new(&png, (WIDTH, HEIGHT)).into_drawing_area();
        draw(&root, title, rows).map_err(|e| fail(&png, e))?;
    }
    {
        let root = SVGBackend::new(&svg, (WIDTH, HEIGHT)).into_drawing_area();
        draw(&root, title, rows).map_err(|e| fail(&svg, e))?;
    }
    Ok([png, svg])
}

fn with_extension(prefix: &Path, ext: &str) -> PathBuf {
    let mut s = prefix.as_os_str().to_owned();
    s.push(".");
    s.push(ext);
    PathBuf::from(s)
}

/// Registers the font as plotters' "sans-serif" once per process.
fn register_font() -> Result<()> {
    static DONE: OnceLock<std::result::Result<(), String>> = OnceLock::new();
    DONE.get_or_init(|| {
        let path = find_font()?;
        let bytes = std::fs::read(&path)
            .map_err(|e| format!("cannot read the font {}: {e}", path.display()))?;
        // plotters keeps fonts for the whole process ('static); one font, read once.
        let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
        plotters::style::register_font("sans-serif", FontStyle::Normal, bytes).map_err(|_| {
            format!(
                "{} is not a TrueType/OpenType font; set LRR_FONT to a .ttf file",
                path.display()
            )
        })
    })
    .clone()
    .map_err(Error::Settings)
}

fn find_font() -> std::result::Result<PathBuf, String> {
    if let Some(p) = std::env::var_os("LRR_FONT") {
        let p = PathBuf::from(p);
        return if p.is_file() {
            Ok(p)
        } else {
            Err(format!(
                "LRR_FONT names {}, which is not a file; point it at a .ttf font",
                p.display()
            ))
        };
    }
    FONT_PATHS
        .iter()
        .map(PathBuf::from)
        .find(|p| p.is_file())
        .ok_or_else(|| {
            format!(
                "the plot needs a TrueType font and none was found (looked at {}); install one \
                 (Debian/Ubuntu: apt-get install fonts-dejavu-core) or set LRR_FONT=/path/to/font.ttf, \
                 or leave out --plot",
                FONT_PATHS.join(", ")
            )
        })
}

type Cost = fn(&Row) -> f64;

fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    rows: &[Row],
) -> std::result::Result<(), String> {
    let text = |e: &dyn std::fmt::Display| e.to_string();
    root.fill(&WHITE).map_err(|e| text(&e))?;
    let root = root
        .titled(title, ("sans-serif", 22))
        .map_err(|e| text(&e))?;
    let (left, right) = root.split_horizontally(WIDTH / 2);
    let ylabel = if rows.iter().any(|r| r.rel_error_ref.is_some()) {
        let s = rows.iter().find_map(|r| r.ref_samples).unwrap_or(0);
        format!("relative L2 error (vs exact, {s} samples/pair)")
    } else {
        "relative L2 error (vs exact, same samples)".to_string()
    };
    panel(&left, rows, "bake time (s)", &ylabel, |r| r.bake_s)?;
    panel(&right, rows, "frame time (s)", &ylabel, |r| r.frame_s)?;
    root.present().map_err(|e| text(&e))
}

/// Labels powers of ten only (the other grid lines stay unlabelled).
fn decade_label(v: &f64) -> String {
    let e = v.log10().round();
    if (v.log10() - e).abs() < 1e-6 {
        format!("1e{e}")
    } else {
        String::new()
    }
}

/// Log range around the values, padded by a quarter of a decade on each side.
fn log_range(values: impl Iterator<Item = f64>) -> std::ops::Range<f64> {
    let (lo, hi) = values
        .filter(|v| v.is_finite() && *v > 0.0)
        .fold((f64::INFINITY, 0.0f64), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    if !(lo.is_finite() && hi > 0.0) {
        return 1e-6..1.0;
    }
    let pad = 10f64.powf(0.25);
    (lo / pad)..(hi * pad)
}

fn panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    rows: &[Row],
    xlabel: &str,
    ylabel: &str,
    cost: Cost,
) -> std::result::Result<(), String> {
    let text = |e: &dyn std::fmt::Display| e.to_string();
    let xr = log_range(rows.iter().map(cost));
    let yr = log_range(rows.iter().map(user_error));
    let mut chart = ChartBuilder::on(area)
        .margin(16)
        .x_label_area_size(48)
        .y_label_area_size(72)
        .build_cartesian_2d(xr.log_scale(), yr.log_scale())
        .map_err(|e| text(&e))?;
    chart
        .configure_mesh()
        .x_desc(xlabel)
        .y_desc(ylabel)
        .x_label_formatter(&decade_label)
        .y_label_formatter(&decade_label)
        .label_style(("sans-serif", 14))
        .axis_desc_style(("sans-serif", 16))
        .light_line_style(WHITE.mix(0.0))
        .draw()
        .map_err(|e| text(&e))?;
    let pos = |r: &Row| (cost(r), user_error(r));
    for (method, colour, label) in [
        ("2mf", MF_COLOUR, "2MF"),
        ("2msc", MSC_COLOUR, "2MSC"),
        ("2msc-split", SPLIT_COLOUR, "2MSC (split)"),
    ] {
        let Some(key) = analysis::main_key(rows, method) else {
            continue;
        };
        let mut main: Vec<&Row> = rows
            .iter()
            .filter(|r| {
                r.method == method
                    && r.n == key.n
                    && r.samples == key.samples
                    && r.precision == "f32"
            })
            .collect();
        if main.is_empty() {
            continue;
        }
        main.sort_by_key(|r| r.k);
        let first = main[0];
        let caption = format!(
            "{label}: n = {}, {} samples, f32, by k",
            first.n, first.samples
        );
        chart
            .draw_series(LineSeries::new(
                main.iter().map(|r| pos(r)),
                colour.stroke_width(2),
            ))
            .map_err(|e| text(&e))?
            .label(caption)
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2))
            });
        let style = |r: &Row| {
            if r.precision == "f32" {
                colour.filled()
            } else {
                colour.stroke_width(1)
            }
        };
        // Rows of the main fine mesh as circles, of other fine meshes as triangles.
        let mine = |main: bool| {
            rows.iter()
                .filter(move |r| r.method == method && (r.n == key.n) == main)
        };
        chart
            .draw_series(mine(true).map(|r| Circle::new(pos(r), 4, style(r))))
            .map_err(|e| text(&e))?;
        chart
            .draw_series(mine(false).map(|r| TriangleMarker::new(pos(r), 5, style(r))))
            .map_err(|e| text(&e))?;
    }
    pareto(&mut chart, rows, cost)?;
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .label_font(("sans-serif", 14))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(|e| text(&e))
}

type Chart<'a, DB> = ChartContext<
    'a,
    DB,
    Cartesian2d<
        plotters::coord::combinators::LogCoord<f64>,
        plotters::coord::combinators::LogCoord<f64>,
    >,
>;

/// The Pareto front over the main fine mesh's rows ([`analysis::main_front`]): a step line (error holds until a costlier point improves
/// it) and a ring around each of its points.
fn pareto<DB: DrawingBackend>(
    chart: &mut Chart<'_, DB>,
    rows: &[Row],
    cost: Cost,
) -> std::result::Result<(), String> {
    let text = |e: &dyn std::fmt::Display| e.to_string();
    let front: Vec<(f64, f64)> = analysis::main_front(rows, cost, user_error)
        .into_iter()
        .map(|i| (cost(&rows[i]), user_error(&rows[i])))
        .collect();
    let mut steps = Vec::new();
    for (i, &(x, y)) in front.iter().enumerate() {
        if i > 0 {
            steps.push((x, front[i - 1].1));
        }
        steps.push((x, y));
    }
    chart
        .draw_series(LineSeries::new(steps, BLACK.stroke_width(1)))
        .map_err(|e| text(&e))?
        .label(format!("Pareto front, n = {} (ringed)", rows[0].n))
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK));
    chart
        .draw_series(
            front
                .iter()
                .map(|&p| Circle::new(p, 8, BLACK.stroke_width(1))),
        )
        .map_err(|e| text(&e))?;
    Ok(())
}
