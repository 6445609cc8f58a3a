//! Chart primitives: series, colours, axes, legends, and one chart drawn into an SVG file.

use std::path::Path;

use plotters::prelude::*;

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
    // Tick labels in plain notation, the axis's power of ten once in its description.
    let x_exp = shared_exponent(x_lo, x_hi);
    let y_exp = if axes.log_y {
        0
    } else {
        shared_exponent(y_lo, y_hi)
    };
    let x_desc = with_exponent(axes.x_label, x_exp);
    let y_desc = with_exponent(axes.y_label, y_exp);
    // The two branches differ only in the y coordinate type (linear or logarithmic).
    macro_rules! draw_on {
        ($y_range:expr, $y_format:expr) => {{
            let mut c = builder
                .build_cartesian_2d(x_lo..x_hi, $y_range)
                .map_err(|e| draw_error(path, e))?;
            c.configure_mesh()
                .x_desc(x_desc.as_str())
                .y_desc(y_desc.as_str())
                .axis_desc_style(("sans-serif", 17))
                .label_style(("sans-serif", 14))
                .x_label_formatter(&|v| plain(*v, x_exp))
                .y_label_formatter(&$y_format)
                .draw()
                .map_err(|e| draw_error(path, e))?;
            plot_series(&mut c, series, references, (x_lo, x_hi), y_lo, path)?;
        }};
    }
    if axes.log_y {
        draw_on!((y_lo..y_hi).log_scale(), |v: &f64| format!("{v:.0e}"));
    } else {
        draw_on!(y_lo..y_hi, |v: &f64| plain(*v, y_exp));
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
    root.present().map_err(|e| draw_error(path, e))
}

pub(super) fn plot_series<'a, DB, Y>(
    c: &mut ChartContext<'a, DB, Cartesian2d<plotters::coord::types::RangedCoordf64, Y>>,
    series: &[Series],
    references: &[Reference],
    (x_lo, x_hi): (f64, f64),
    y_floor: f64,
    path: &Path,
) -> Result<(), FigureError>
where
    DB: DrawingBackend + 'a,
    Y: Ranged<ValueType = f64>,
{
    for r in references {
        let style = ShapeStyle::from(&BLACK.mix(0.6)).stroke_width(1);
        let y = r.y;
        c.draw_series(DashedLineSeries::new([(x_lo, y), (x_hi, y)], 6, 4, style))
            .map_err(|e| draw_error(path, e))?;
    }
    for s in series {
        let color = s.color;
        let pts: Vec<(f64, f64, f64)> = s
            .points
            .iter()
            .copied()
            .filter(|p| p.0.is_finite() && p.1.is_finite())
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
            (x + 28, y - 8),
            ("sans-serif", 14),
        ))
        .map_err(|e| draw_error(path, e))?;
    }
    Ok(())
}

/// The power of ten shared by the tick labels of an axis over [lo, hi]: 0 where plain
/// numbers read well (magnitudes 0.01 … 10 000), else that of the larger end.
pub(super) fn shared_exponent(lo: f64, hi: f64) -> i32 {
    let m = lo.abs().max(hi.abs());
    if !(m.is_finite() && m > 0.0) || (1e-2..1e4).contains(&m) {
        0
    } else {
        m.log10().floor() as i32
    }
}

/// `v` / 10^`exp` in plain notation, at most four decimals, trailing zeros dropped.
pub(super) fn plain(v: f64, exp: i32) -> String {
    let x = v / 10f64.powi(exp);
    let s = format!("{x:.4}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" { "0".into() } else { s.to_string() }
}

/// An axis description with its shared power of ten, e.g. `bias [1/kg] (×10⁻⁷)`.
pub(super) fn with_exponent(label: &str, exp: i32) -> String {
    if exp == 0 {
        return label.to_string();
    }
    let sup: String = exp
        .to_string()
        .chars()
        .map(|c| match c {
            '-' => '⁻',
            d => ['⁰', '¹', '²', '³', '⁴', '⁵', '⁶', '⁷', '⁸', '⁹']
                [d.to_digit(10).unwrap_or(0) as usize],
        })
        .collect();
    format!("{label} (×10{sup})")
}

/// A range around `values` with 5 % margins (a factor on log scales); a unit range when
/// there is nothing to show.
pub(super) fn padded(values: impl Iterator<Item = f64>, log: bool) -> (f64, f64) {
    let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
        (a.min(v), b.max(v))
    });
    if !(lo.is_finite() && hi.is_finite()) {
        return if log { (0.1, 10.0) } else { (0.0, 1.0) };
    }
    if log {
        let (lo, hi) = if lo == hi {
            (lo / 2.0, hi * 2.0)
        } else {
            (lo, hi)
        };
        (lo / 1.25, hi * 1.25)
    } else {
        let span = if hi > lo {
            hi - lo
        } else {
            hi.abs().max(1e-300)
        };
        (lo - 0.05 * span, hi + 0.05 * span)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tick_labels_share_one_power_of_ten() {
        assert_eq!(shared_exponent(0.0, 4.2e-3), -3);
        assert_eq!(shared_exponent(1.0, 2.0), 0);
        assert_eq!(shared_exponent(-2e5, 1e5), 5);
        assert_eq!(plain(4.0e-3, -3), "4");
        assert_eq!(plain(1.25e-7, -7), "1.25");
        assert_eq!(plain(-0.0, 0), "0");
        assert_eq!(with_exponent("bias", -7), "bias (×10⁻⁷)");
        assert_eq!(with_exponent("scale", 0), "scale");
    }
}
