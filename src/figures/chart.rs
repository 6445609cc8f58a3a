//! Chart primitives: series, colours, axes, legends, and one chart drawn into an SVG file.

use std::path::Path;

use plotters::coord::ranged1d::{AsRangedCoord, DefaultFormatting, KeyPointHint};
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

/// Tick positions of an axis: labelled grid lines (`major`) and the lighter ones between
/// them (`minor`), with how their labels are written.
pub(super) struct Ticks {
    pub(super) major: Vec<f64>,
    pub(super) minor: Vec<f64>,
    /// Linear: the shared power of ten and the decimals; log: `None`.
    linear: Option<(i32, usize)>,
}

impl Ticks {
    /// The label of the tick at `v`.
    pub(super) fn label(&self, v: f64) -> String {
        match self.linear {
            Some((exp, decimals)) => {
                let s = format!("{:.decimals$}", v / 10f64.powi(exp));
                if s.trim_start_matches('-')
                    .trim_matches(['0', '.'])
                    .is_empty()
                {
                    "0".into()
                } else {
                    s
                }
            }
            None => log_label(v),
        }
    }
}

/// A coordinate with the grid lines of [`Ticks`] (plotters' own log axis labels every
/// minor tick and repeats the decade where its light ticks reach it).
pub(super) struct Ticked<R> {
    inner: R,
    major: Vec<f64>,
    minor: Vec<f64>,
}

impl<R: Ranged<ValueType = f64>> Ticked<R> {
    pub(super) fn new<T>(range: T, ticks: &Ticks) -> Self
    where
        T: AsRangedCoord<CoordDescType = R>,
        R: From<T>,
    {
        Ticked {
            inner: R::from(range),
            major: ticks.major.clone(),
            minor: ticks.minor.clone(),
        }
    }
}

impl<R: Ranged<ValueType = f64>> Ranged for Ticked<R> {
    type ValueType = f64;
    // Labels come from the chart's formatter, [`Ticks::label`].
    type FormatOption = DefaultFormatting;

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        self.inner.map(value, limit)
    }

    fn key_points<H: KeyPointHint>(&self, hint: H) -> Vec<f64> {
        if hint.weight().allow_light_points() {
            self.minor.clone()
        } else {
            self.major.clone()
        }
    }

    fn range(&self) -> std::ops::Range<f64> {
        self.inner.range()
    }

    fn axis_pixel_range(&self, limit: (i32, i32)) -> std::ops::Range<i32> {
        self.inner.axis_pixel_range(limit)
    }
}

/// The step of about `count` ticks over `span`: 1, 2 or 5 × a power of ten.
fn nice_step(span: f64, count: f64) -> f64 {
    let raw = span / count;
    let mag = 10f64.powf(raw.log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .map(|m| m * mag)
        .find(|&s| s >= raw * (1.0 - 1e-9))
        .unwrap_or(10.0 * mag)
}

/// The multiples of `step` in [lo, hi], computed as k·step (no accumulated error).
fn multiples(lo: f64, hi: f64, step: f64, offset: f64) -> Vec<f64> {
    let (first, last) = ((lo / step - offset).ceil(), (hi / step - offset).floor());
    if !(first.is_finite() && last.is_finite()) || last - first > 1000.0 {
        return Vec::new();
    }
    (first as i64..=last as i64)
        .map(|k| (k as f64 + offset) * step)
        .collect()
}

/// Ticks of a linear axis over [lo, hi]: about eight labelled at 1, 2 or 5 × a power of
/// ten, a light line half-way between them, labels in units of 10^`exp` with as many
/// decimals as the step needs (so no two labels are equal).
pub(super) fn linear_ticks(lo: f64, hi: f64, exp: i32) -> Ticks {
    if hi <= lo || hi.is_nan() || lo.is_nan() {
        return Ticks {
            major: vec![lo],
            minor: Vec::new(),
            linear: Some((exp, 4)),
        };
    }
    let step = nice_step(hi - lo, 8.0);
    let decimals = (-(step / 10f64.powi(exp)).log10().floor()).max(0.0) as usize;
    Ticks {
        major: multiples(lo, hi, step, 0.0),
        minor: multiples(lo, hi, step, 0.5),
        linear: Some((exp, decimals)),
    }
}

/// Ticks of a log axis over [lo, hi] (0 < lo < hi): labelled decades (every second, third
/// … beyond eight), or 1, 2 and 5 × 10^k where fewer than three decades show, or plain
/// 1-2-5 steps on a range narrower than that; light lines at the other integer multiples of
/// the decades where the range spans at most four decades.
pub(super) fn log_ticks(lo: f64, hi: f64) -> Ticks {
    let (k_lo, k_hi) = (lo.log10().ceil() as i32, hi.log10().floor() as i32);
    let decades: Vec<i32> = (k_lo..=k_hi).collect();
    // The integer multiples m·10^k (m = 1 … 9) in range, by their mantissa.
    let multiples_of = |mantissas: &[f64]| -> Vec<f64> {
        let mut v: Vec<f64> = (k_lo - 1..=k_hi)
            .flat_map(|k| mantissas.iter().map(move |m| m * 10f64.powi(k)))
            .filter(|v| (lo..=hi).contains(v))
            .collect();
        v.sort_by(f64::total_cmp);
        v
    };
    let all: Vec<f64> = (1..=9).map(f64::from).collect();
    let minor_except = |major: &[f64]| {
        if (hi / lo).log10() > 4.0 {
            return Vec::new();
        }
        multiples_of(&all)
            .into_iter()
            .filter(|v| !major.iter().any(|m| (m / v - 1.0).abs() < 1e-9))
            .collect()
    };
    if decades.len() >= 3 {
        let stride = decades.len().div_ceil(8);
        let major: Vec<f64> = decades
            .iter()
            .filter(|k| k.rem_euclid(stride as i32) == 0)
            .map(|&k| 10f64.powi(k))
            .collect();
        let minor = if stride == 1 {
            minor_except(&major)
        } else {
            decades
                .iter()
                .map(|&k| 10f64.powi(k))
                .filter(|v| !major.contains(v))
                .collect()
        };
        return Ticks {
            major,
            minor,
            linear: None,
        };
    }
    let one_two_five = multiples_of(&[1.0, 2.0, 5.0]);
    if one_two_five.len() >= 3 {
        let minor = minor_except(&one_two_five);
        return Ticks {
            major: one_two_five,
            minor,
            linear: None,
        };
    }
    // Less than a factor of about 5: evenly stepped values, labelled like the decades.
    let step = nice_step(hi - lo, 5.0);
    Ticks {
        major: multiples(lo, hi, step, 0.0),
        minor: Vec::new(),
        linear: None,
    }
}

/// A tick label of a log axis: plain from 0.001 to 9999 ("0.05", "1", "200"), else
/// m·10ⁿ ("2·10⁻⁵", and "10⁻⁵" for m = 1); m to at most three decimals.
pub(super) fn log_label(v: f64) -> String {
    if !(v.is_finite() && v > 0.0) {
        return String::new();
    }
    let mut e = v.log10().floor() as i32;
    let mut m = format!("{:.3}", v / 10f64.powi(e));
    if m.starts_with("10") {
        e += 1;
        m = format!("{:.3}", v / 10f64.powi(e));
    }
    let m = m.trim_end_matches('0').trim_end_matches('.');
    if (-3..4).contains(&e) {
        let mantissa_decimals = m.split('.').nth(1).map_or(0, str::len) as i32;
        let decimals = (mantissa_decimals - e).max(0) as usize;
        return format!("{v:.decimals$}");
    }
    let power = format!("10{}", superscript(e));
    if m == "1" {
        power
    } else {
        format!("{m}·{power}")
    }
}

/// `n` in superscript digits, e.g. ⁻⁵.
fn superscript(n: i32) -> String {
    n.to_string()
        .chars()
        .map(|c| match c {
            '-' => '⁻',
            d => ['⁰', '¹', '²', '³', '⁴', '⁵', '⁶', '⁷', '⁸', '⁹']
                [d.to_digit(10).unwrap_or(0) as usize],
        })
        .collect()
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

/// An axis description with its shared power of ten, e.g. `bias [1/kg] (×10⁻⁷)`.
pub(super) fn with_exponent(label: &str, exp: i32) -> String {
    if exp == 0 {
        return label.to_string();
    }
    format!("{label} (×10{})", superscript(exp))
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

    fn labels(t: &Ticks) -> Vec<String> {
        t.major.iter().map(|&v| t.label(v)).collect()
    }

    #[test]
    fn tick_labels_share_one_power_of_ten() {
        assert_eq!(shared_exponent(0.0, 4.2e-3), -3);
        assert_eq!(shared_exponent(1.0, 2.0), 0);
        assert_eq!(shared_exponent(-2e5, 1e5), 5);
        assert_eq!(with_exponent("bias", -7), "bias (×10⁻⁷)");
        assert_eq!(with_exponent("scale", 0), "scale");
        // Steps of 1, 2 or 5 in the shared unit, with the decimals the step needs.
        assert_eq!(
            labels(&linear_ticks(-0.3e-3, 4.2e-3, -3)),
            ["0", "1", "2", "3", "4"]
        );
        assert_eq!(
            labels(&linear_ticks(-5.6, 0.2, 0)),
            ["-5", "-4", "-3", "-2", "-1", "0"]
        );
        // Close values keep distinct labels (no rounding to four decimals).
        let close = labels(&linear_ticks(1.000_01, 1.000_05, 0));
        assert!(close.windows(2).all(|w| w[0] != w[1]), "{close:?}");
    }

    #[test]
    fn log_axes_label_decades_or_one_two_five_never_every_minor_tick() {
        // Four decades: the decades only, "1" for 10⁰, light lines at 2 … 9.
        let t = log_ticks(0.03, 1.3e2);
        assert_eq!(labels(&t), ["0.1", "1", "10", "100"]);
        // 0.03 … 0.09, then 2 … 9 × 0.1, 1 and 10.
        assert_eq!(t.minor.len(), 7 + 3 * 8);
        // 9·10⁻⁷ … 3.6·10⁻⁵ (two decades): 1, 2, 5 × 10ⁿ, each once.
        assert_eq!(
            labels(&log_ticks(0.9e-6, 3.6e-5)),
            ["10⁻⁶", "2·10⁻⁶", "5·10⁻⁶", "10⁻⁵", "2·10⁻⁵"]
        );
        // A factor of two: evenly stepped mantissas.
        assert_eq!(
            labels(&log_ticks(0.9e-6, 1.8e-6)),
            ["10⁻⁶", "1.2·10⁻⁶", "1.4·10⁻⁶", "1.6·10⁻⁶", "1.8·10⁻⁶"]
        );
        // Twenty decades: every third decade labelled, the others light.
        let wide = log_ticks(1e-12, 1e8);
        assert_eq!(wide.major.len(), 7);
        assert_eq!(wide.minor.len(), 14);
        assert_eq!(log_label(1.0), "1");
        assert_eq!(log_label(0.05), "0.05");
        assert_eq!(log_label(2.5e-5), "2.5·10⁻⁵");
        assert_eq!(log_label(9.9999e-6), "10⁻⁵");
    }
}
