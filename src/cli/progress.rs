//! Progress of a run on stderr: a bar on a terminal; under SLURM, `nohup` or any redirect
//! (stderr not a terminal), a plain line at most every [`LINE_INTERVAL`], so a log file
//! shows how far a long run is.

use std::io::IsTerminal;
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

use crate::montecarlo::Observer;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressState, ProgressStyle};

/// Least time between two progress lines when stderr is not a terminal.
pub const LINE_INTERVAL: Duration = Duration::from_secs(10);

/// A rate with three significant digits: `4.21k/s`, `123/s`, `0.512/s`.
pub fn human_rate(per_second: f64) -> String {
    if !per_second.is_finite() || per_second <= 0.0 {
        return "–/s".into();
    }
    let (value, suffix) = match per_second {
        r if r >= 1e9 => (r / 1e9, "G"),
        r if r >= 1e6 => (r / 1e6, "M"),
        r if r >= 1e3 => (r / 1e3, "k"),
        r => (r, ""),
    };
    let decimals = if value >= 100.0 {
        0
    } else if value >= 10.0 {
        1
    } else {
        2
    };
    format!("{value:.decimals$}{suffix}/s")
}

/// A duration rounded for people: `42 s`, `3 min 20 s`, `2 h 05 min`, `3.2 days`.
pub fn human_duration(d: Duration) -> String {
    /// A Julian year.
    const SECONDS_PER_YEAR: f64 = 365.25 * 86_400.0;
    let s = d.as_secs_f64();
    if !s.is_finite() {
        return "unknown".into();
    }
    let whole = s.round() as u64;
    match whole {
        0..60 => format!("{whole} s"),
        60..3600 => format!("{} min {:02} s", whole / 60, whole % 60),
        3600..172_800 => format!("{} h {:02} min", whole / 3600, (whole % 3600) / 60),
        172_800..63_115_200 => format!("{:.1} days", s / 86_400.0),
        _ => match s / SECONDS_PER_YEAR {
            years if years < 1e4 => format!("{years:.0} years"),
            years => format!("{years:.1e} years"),
        },
    }
}

/// The plain progress line: done/total, percentage, rate and time left.
pub fn line(done: u64, total: u64, computed: u64, elapsed: Duration) -> String {
    let rate = computed as f64 / elapsed.as_secs_f64().max(1e-9);
    let left = total.saturating_sub(done) as f64;
    let eta = if rate > 0.0 {
        human_duration(Duration::from_secs_f64((left / rate).min(1e12)))
    } else {
        "unknown".into()
    };
    format!(
        "progress: {done}/{total} realisations ({:.1} %), {}, {} elapsed, about {eta} left",
        100.0 * done as f64 / total.max(1) as f64,
        human_rate(rate),
        human_duration(elapsed),
    )
}

/// Plain lines for a log file.
#[derive(Debug)]
pub struct Lines {
    total: AtomicU64,
    done: AtomicU64,
    /// Realisations kept from an earlier run (not computed now: not in the rate).
    kept: AtomicU64,
    started: Instant,
    last: Mutex<Instant>,
    interval: Duration,
}

impl Lines {
    /// Lines at most every `interval`.
    pub fn new(interval: Duration) -> Self {
        let now = Instant::now();
        Lines {
            total: AtomicU64::new(0),
            done: AtomicU64::new(0),
            kept: AtomicU64::new(0),
            started: now,
            last: Mutex::new(now),
            interval,
        }
    }

    /// The line to print at `now`, if the interval has passed since the last one.
    pub fn due(&self, now: Instant) -> Option<String> {
        let mut last = self.last.lock().expect("progress lock");
        if now.duration_since(*last) < self.interval {
            return None;
        }
        *last = now;
        Some(self.current(now))
    }

    /// The line describing the state at `now`.
    pub fn current(&self, now: Instant) -> String {
        let done = self.done.load(Ordering::Relaxed);
        let kept = self.kept.load(Ordering::Relaxed);
        line(
            done,
            self.total.load(Ordering::Relaxed),
            done - kept.min(done),
            now.duration_since(self.started),
        )
    }
}

/// Where progress goes.
#[derive(Debug)]
pub enum Progress {
    /// A bar redrawn in place on a terminal.
    Bar(ProgressBar),
    /// Plain lines, for a file or pipe.
    Lines(Lines),
    /// Nothing (`--quiet`), but notices still go to stderr.
    Quiet,
}

impl Progress {
    /// A bar when stderr is a terminal, lines otherwise; nothing but notices when `quiet`.
    pub fn new(quiet: bool) -> Self {
        if quiet {
            Progress::Quiet
        } else if std::io::stderr().is_terminal() {
            let bar = ProgressBar::with_draw_target(Some(0), ProgressDrawTarget::stderr());
            bar.set_style(
                ProgressStyle::with_template(
                    "{spinner} [{elapsed_precise}] {wide_bar} {human_pos}/{human_len} realisations ({rate}, eta {eta})",
                )
                .expect("valid progress template")
                .with_key("rate", |s: &ProgressState, w: &mut dyn std::fmt::Write| {
                    let _ = w.write_str(&human_rate(s.per_sec()));
                }),
            );
            Progress::Bar(bar)
        } else {
            Progress::Lines(Lines::new(LINE_INTERVAL))
        }
    }

    /// The run is over: clear the bar, or print the last line.
    pub fn finish(&self) {
        match self {
            Progress::Bar(bar) => bar.finish_and_clear(),
            Progress::Lines(lines) => eprintln!("{}", lines.current(Instant::now())),
            Progress::Quiet => {}
        }
    }
}

impl Observer for Progress {
    fn planned(&self, total: u64, done: u64) {
        match self {
            Progress::Bar(bar) => {
                bar.set_length(total);
                bar.set_position(done);
            }
            Progress::Lines(lines) => {
                lines.total.store(total, Ordering::Relaxed);
                lines.done.store(done, Ordering::Relaxed);
                lines.kept.store(done, Ordering::Relaxed);
            }
            Progress::Quiet => {}
        }
    }

    fn realisations_done(&self, count: u64) {
        match self {
            Progress::Bar(bar) => bar.inc(count),
            Progress::Lines(lines) => {
                lines.done.fetch_add(count, Ordering::Relaxed);
                if let Some(line) = lines.due(Instant::now()) {
                    eprintln!("{line}");
                }
            }
            Progress::Quiet => {}
        }
    }

    fn notice(&self, message: &str) {
        match self {
            Progress::Bar(bar) => bar.suspend(|| eprintln!("{message}")),
            _ => eprintln!("{message}"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rates_have_three_significant_digits() {
        assert_eq!(human_rate(4213.7), "4.21k/s");
        assert_eq!(human_rate(123.4), "123/s");
        assert_eq!(human_rate(12.34), "12.3/s");
        assert_eq!(human_rate(0.5123), "0.51/s");
        assert_eq!(human_rate(2.5e6), "2.50M/s");
        assert_eq!(human_rate(0.0), "–/s");
    }

    #[test]
    fn durations_are_rounded_for_people() {
        assert_eq!(human_duration(Duration::from_secs(42)), "42 s");
        assert_eq!(human_duration(Duration::from_secs(200)), "3 min 20 s");
        assert_eq!(human_duration(Duration::from_secs(7500)), "2 h 05 min");
        assert_eq!(human_duration(Duration::from_secs(864_000)), "10.0 days");
    }

    #[test]
    fn lines_come_at_most_once_per_interval_with_rate_and_eta() {
        let lines = Lines::new(Duration::from_secs(10));
        lines.total.store(1000, Ordering::Relaxed);
        lines.done.store(250, Ordering::Relaxed);
        let t0 = lines.started;
        assert_eq!(lines.due(t0 + Duration::from_secs(5)), None);
        let line = lines
            .due(t0 + Duration::from_secs(10))
            .expect("a line after 10 s");
        // 250 realisations in 10 s: 25/s, 750 left: 30 s.
        assert_eq!(
            line,
            "progress: 250/1000 realisations (25.0 %), 25.0/s, 10 s elapsed, about 30 s left"
        );
        assert_eq!(lines.due(t0 + Duration::from_secs(15)), None);
        assert!(lines.due(t0 + Duration::from_secs(20)).is_some());
    }
}
