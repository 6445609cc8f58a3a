//! Chart primitives: series, colours, axes, legends, and one chart drawn into an SVG file.

use std::path::Path;

use plotters::prelude::*;

use super::axis::{Ticked, linear_ticks, log_ticks, padded, shared_exponent, with_exponent};
use super::{FigureError, LEGEND_WIDTH, SIZE, draw_error};

/// A series of a chart: one legend entry.
#[derive(Clone)]
pub(super) struct Series {
    pub(super) label: String,
    pub(super) color: RGBColor,
    /// (x, y, half-width of the error bar)
    pub(super) points: Vec<(f64, f64, f64)>,
    /// Drawn as circles with error bars (estimates) or as a line with crosses (bounds).
    pub(super) markers: bool,
}

/// A horizontal reference line.
pub(super) struct Reference {
    pub(super) y: f64,
    pub(super) label: String,
}

/// Distinct colours readable on white: Okabe & Ito (2008, colour-blind safe) first, then
/// darker tones; repeats after 16.
pub(super) fn color(i: usize) -> RGBColor {
    const PALETTE: [(u8, u8, u8); 16] = [
        (0, 114, 178),
        (213, 94, 0),
        (0, 158, 115),
        (204, 121, 167),
        (230, 159, 0),
        (86, 180, 233),
        (0, 0, 0),
        (153, 153, 51),
        (136, 34, 85),
        (68, 119, 170),
        (17, 119, 51),
        (170, 68, 153),
        (102, 51, 0),
        (51, 34, 136),
        (136, 136, 136),
        (204, 51, 17),
    ];
    let (r, g, b) = PALETTE[i % PALETTE.len()];
    RGBColor(r, g, b)
}

/// A colour from dark blue to orange for position `k` of `n` (ordered things: scales).
pub(super) fn ramp(k: usize, n: usize) -> RGBColor {
    let t = if n > 1 {
        k as f64 / (n - 1) as f64
    } else {
        0.0
    };
    let lerp = |a: f64, b: f64| (a + t * (b - a)).round() as u8;
    RGBColor(lerp(20.0, 230.0), lerp(40.0, 120.0), lerp(140.0, 10.0))
}

pub(super) struct Axes<'a> {
    pub(super) title: &'a str,
    pub(super) x_label: &'a str,
    pub(super) y_label: &'a str,
    pub(super) log_y: bool,
}

/// Draw one chart of `series` into `path`.
pub(super) fn chart(
    path: &Path,
    axes: &Axes<'_>,
    series: &[Series],
    references: &[Reference],
) -> Result<(), FigureError> {
    chart_with_note(path, axes, series, references, None)
}

/// [`chart`], with `note` written under the legend (e.g. what the figure leaves out).
pub(super) fn chart_with_note(
    path: &Path,
    axes: &Axes<'_>,
    series: &[Series],
    references: &[Reference],
    note: Option<&str>,
) -> Result<(), FigureError> {
    let finite = |v: &f64| v.is_finite() && (!axes.log_y || *v > 0.0);
    let xs: Vec<f64> = series
        .iter()
        .flat_map(|s| s.points.iter().map(|p| p.0))
        .collect();
    let mut ys: Vec<f64> = Vec::new();
    for s in series {
        for &(_, y, e) in &s.points {
            ys.push(y);
            if e.is_finite() {
                ys.push(y - e);
                ys.push(y + e);
            }
        }
    }
    ys.extend(references.iter().map(|r| r.y));
    let (x_lo, x_hi) = padded(xs.iter().copied().filter(finite), false);
    let (y_lo, y_hi) = padded(ys.iter().copied().filter(finite), axes.log_y);
    let root = SVGBackend::new(path, SIZE).into_drawing_area();
    root.fill(&WHITE).map_err(|e| draw_error(path, e))?;
    let mut builder = ChartBuilder::on(&root);
    builder
        .caption(axes.title, ("sans-serif", 24))
        .margin(15)
        .margin_right(LEGEND_WIDTH)
        .x_label_area_size(60)
        .y_label_area_size(100);
    // Tick labels in plain notation, the axis's power of ten once in its description; a
    // log axis labels its decades (or 1-2-5 steps) in their own notation.
    let x_exp = shared_exponent(x_lo, x_hi);
    let x_ticks = linear_ticks(x_lo, x_hi, x_exp);
    let y_exp = if axes.log_y {
        0
    } else {
        shared_exponent(y_lo, y_hi)
    };
    let x_desc = with_exponent(axes.x_label, x_exp);
    let y_desc = with_exponent(axes.y_label, y_exp);
    let dodge = dodge_step(series, x_lo, x_hi);
    // The two branches differ only in the y coordinate type (linear or logarithmic).
    macro_rules! draw_on {
        ($y_range:expr, $y_format:expr) => {{
            let x_range = Ticked::new(x_lo..x_hi, &x_ticks);
            let mut c = builder
                .build_cartesian_2d(x_range, $y_range)
                .map_err(|e| draw_error(path, e))?;
            c.configure_mesh()
                .x_desc(x_desc.as_str())
                .y_desc(y_desc.as_str())
                .axis_desc_style(("sans-serif", 17))
                .label_style(("sans-serif", 14))
                .light_line_style(BLACK.mix(0.06))
                .x_label_formatter(&|v| x_ticks.label(*v))
                .y_label_formatter(&$y_format)
                .draw()
                .map_err(|e| draw_error(path, e))?;
            plot_series(&mut c, series, references, (x_lo, x_hi), y_lo, dodge, path)?;
        }};
    }
    if axes.log_y {
        let y_ticks = log_ticks(y_lo, y_hi);
        let y_range = Ticked::new((y_lo..y_hi).log_scale(), &y_ticks);
        draw_on!(y_range, |v: &f64| y_ticks.label(*v));
    } else {
        let y_ticks = linear_ticks(y_lo, y_hi, y_exp);
        let y_range = Ticked::new(y_lo..y_hi, &y_ticks);
        draw_on!(y_range, |v: &f64| y_ticks.label(*v));
    }
    let mut entries: Vec<(String, Key)> = references
        .iter()
        .map(|r| (r.label.clone(), Key::Dashed))
        .collect();
    entries.extend(series.iter().map(|s| {
        let key = if s.markers {
            Key::Marker(s.color)
        } else {
            Key::Line(s.color)
        };
        (s.label.clone(), key)
    }));
    legend(&root, &entries, 60, path)?;
    if let Some(note) = note {
        let top = 60 + 20 * entries.len() as i32 + 10;
        let x = (SIZE.0 - LEGEND_WIDTH + 20) as i32;
        for (k, line) in wrap(note, NOTE_CHARS).iter().enumerate() {
            root.draw(&Text::new(
                line.clone(),
                (x, top + 16 * k as i32),
                ("sans-serif", 13).into_font().color(&BLACK.mix(0.7)),
            ))
            .map_err(|e| draw_error(path, e))?;
        }
    }
    root.present().map_err(|e| draw_error(path, e))
}

/// Characters per line of a note under the legend.
const NOTE_CHARS: usize = 36;

/// `text` in lines of at most `width` characters, broken at spaces.
fn wrap(text: &str, width: usize) -> Vec<String> {
    let mut lines: Vec<String> = Vec::new();
    for word in text.split_whitespace() {
        match lines.last_mut() {
            Some(line) if line.chars().count() + 1 + word.chars().count() <= width => {
                line.push(' ');
                line.push_str(word);
            }
            _ => lines.push(word.to_string()),
        }
    }
    lines
}

/// Whether [`plot_series`] sets `s` beside the others: a series of estimates with error bars
/// (not iso-lines or predictions, whose x is exact).
fn dodged(s: &Series) -> bool {
    s.markers && s.points.iter().any(|p| p.2.is_finite())
}

/// Draw `series` and `references` on `c`. Series of estimates ([`dodged`]) are set side by
/// side: the k-th of n at x + (k − (n − 1)/2)·`dodge`, so that equal values stay visible.
pub(super) fn plot_series<'a, DB, X, Y>(
    c: &mut ChartContext<'a, DB, Cartesian2d<X, Y>>,
    series: &[Series],
    references: &[Reference],
    (x_lo, x_hi): (f64, f64),
    y_floor: f64,
    dodge: f64,
    path: &Path,
) -> Result<(), FigureError>
where
    DB: DrawingBackend + 'a,
    X: Ranged<ValueType = f64>,
    Y: Ranged<ValueType = f64>,
{
    let marker_series = series.iter().filter(|s| dodged(s)).count();
    let mut k = 0;
    for r in references {
        let style = ShapeStyle::from(&BLACK.mix(0.6)).stroke_width(1);
        let y = r.y;
        c.draw_series(DashedLineSeries::new([(x_lo, y), (x_hi, y)], 6, 4, style))
            .map_err(|e| draw_error(path, e))?;
    }
    for s in series {
        let color = s.color;
        let shift = if dodged(s) {
            k += 1;
            (k as f64 - 1.0 - (marker_series as f64 - 1.0) / 2.0) * dodge
        } else {
            0.0
        };
        let pts: Vec<(f64, f64, f64)> = s
            .points
            .iter()
            .filter(|p| p.0.is_finite() && p.1.is_finite())
            .map(|&(x, y, e)| (x + shift, y, e))
            .collect();
        if s.markers {
            c.draw_series(pts.iter().filter(|p| p.2.is_finite()).map(|&(x, y, e)| {
                ErrorBar::new_vertical(x, (y - e).max(y_floor), y, y + e, color.stroke_width(1), 6)
            }))
            .map_err(|e| draw_error(path, e))?;
            c.draw_series(LineSeries::new(
                pts.iter().map(|p| (p.0, p.1)),
                color.mix(0.35).stroke_width(1),
            ))
            .map_err(|e| draw_error(path, e))?;
            c.draw_series(
                pts.iter()
                    .map(|&(x, y, _)| Circle::new((x, y), 4, color.filled())),
            )
            .map_err(|e| draw_error(path, e))?;
        } else {
            c.draw_series(LineSeries::new(
                pts.iter().map(|p| (p.0, p.1)),
                color.stroke_width(2),
            ))
            .map_err(|e| draw_error(path, e))?;
            c.draw_series(
                pts.iter()
                    .map(|&(x, y, _)| Cross::new((x, y), 4, color.stroke_width(2))),
            )
            .map_err(|e| draw_error(path, e))?;
        }
    }
    Ok(())
}

/// What a legend entry shows next to its text.
#[derive(Clone, Copy)]
pub(super) enum Key {
    /// A filled circle (estimates with MCSE bars).
    Marker(RGBColor),
    /// A solid line with crosses (bounds).
    Line(RGBColor),
    /// A dashed grey line (references).
    Dashed,
}

/// Draw a legend in the right-hand margin of `root`, from pixel row `top`.
pub(super) fn legend<DB: DrawingBackend>(
    root: &DrawingArea<DB, plotters::coord::Shift>,
    entries: &[(String, Key)],
    top: i32,
    path: &Path,
) -> Result<(), FigureError> {
    let x = (SIZE.0 - LEGEND_WIDTH + 20) as i32;
    // 14 px, smaller where the longest label would run off the figure (a character of
    // sans-serif text is about 0.55 em wide), at least 10 px.
    let longest = entries
        .iter()
        .map(|(l, _)| l.chars().count())
        .max()
        .unwrap_or(0);
    let room = f64::from(LEGEND_WIDTH - 20 - 28 - 4);
    let font = (room / (0.55 * longest.max(1) as f64))
        .floor()
        .clamp(10.0, 14.0);
    for (k, (label, key)) in entries.iter().enumerate() {
        let y = top + 20 * k as i32;
        match *key {
            Key::Marker(c) => root.draw(&Circle::new((x + 10, y), 4, c.filled())),
            Key::Line(c) => root.draw(&PathElement::new(
                vec![(x, y), (x + 20, y)],
                c.stroke_width(2),
            )),
            Key::Dashed => root.draw(&PathElement::new(vec![(x, y), (x + 20, y)], BLACK.mix(0.6))),
        }
        .map_err(|e| draw_error(path, e))?;
        root.draw(&Text::new(
            label.clone(),
            (x + 28, y - (font * 8.0 / 14.0).round() as i32),
            ("sans-serif", font),
        ))
        .map_err(|e| draw_error(path, e))?;
    }
    Ok(())
}

/// How far apart [`plot_series`] sets the marker series of a chart [x units]: 6 px, or
/// less where the x values are closer than 6 px per series; 0 with one marker series.
pub(super) fn dodge_step(series: &[Series], x_lo: f64, x_hi: f64) -> f64 {
    let n = series.iter().filter(|s| dodged(s)).count();
    if n < 2 || x_hi <= x_lo || x_hi.is_nan() || x_lo.is_nan() {
        return 0.0;
    }
    let mut xs: Vec<f64> = series
        .iter()
        .filter(|s| dodged(s))
        .flat_map(|s| s.points.iter().map(|p| p.0))
        .filter(|x| x.is_finite())
        .collect();
    xs.sort_by(f64::total_cmp);
    xs.dedup();
    let px = (x_hi - x_lo) / f64::from(SIZE.0 - LEGEND_WIDTH - 130);
    let gap = xs
        .windows(2)
        .map(|w| w[1] - w[0])
        .fold(f64::INFINITY, f64::min);
    // The whole group of n markers within 70 % of the smallest gap.
    (6.0 * px).min(0.7 * gap / n as f64)
}
