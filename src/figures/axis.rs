//! An axis's ticks, labels and range: plain tick labels sharing one power of ten, decades or 1–2–5 on log axes, a light line between labels.

use plotters::coord::ranged1d::{AsRangedCoord, DefaultFormatting, KeyPointHint};
use plotters::prelude::*;

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
