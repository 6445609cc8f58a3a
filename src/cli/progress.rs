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

/// How long the realisations must have been computing before a time left is estimated
/// (unless [`SETTLED_FRACTION`] of them is done first): the first chunks include the
/// threads' start and the caches' warm-up, and a rate from them can be off by a factor of
/// hundreds.
pub const SETTLE_TIME: Duration = Duration::from_secs(20);

/// The fraction of the realisations to compute after which the time left is estimated
/// however short the run so far.
pub const SETTLED_FRACTION: f64 = 0.1;

/// What a progress line says of the computing so far: realisations `done` of `total`,
/// `computed` of them by this run (not kept from an earlier one), `elapsed` since the run
/// began; `computing` is the time since the first realisation was computed and
/// `since_first` the realisations computed after it (the rate), `None` before any.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pace {
    /// Realisations done (kept and computed).
    pub done: u64,
    /// Realisations in all.
    pub total: u64,
    /// Realisations computed by this run.
    pub computed: u64,
    /// Time since the run began.
    pub elapsed: Duration,
    /// Time since the first computed realisations, and how many were computed after them.
    pub computing: Option<(Duration, u64)>,
}

/// The plain progress line: done/total, percentage, rate and time left. The rate is that
/// since the first computed realisations, and the time left is estimated only once the
/// computing has run [`SETTLE_TIME`] or done [`SETTLED_FRACTION`] of the work to compute.
pub fn line(pace: Pace) -> String {
    let Pace {
        done,
        total,
        computed,
        elapsed,
        computing,
    } = pace;
    let to_compute = total.saturating_sub(done) + computed;
    let (rate, eta) = match computing {
        Some((time, count)) if count > 0 && time > Duration::ZERO => {
            let rate = count as f64 / time.as_secs_f64();
            let settled = time >= SETTLE_TIME
                || computed as f64 >= SETTLED_FRACTION * to_compute.max(1) as f64;
            let left = total.saturating_sub(done) as f64;
            let eta = match settled {
                true => format!(
                    "about {} left",
                    human_duration(Duration::from_secs_f64((left / rate).min(1e12)))
                ),
                false => "time left not yet known".to_string(),
            };
            (rate, eta)
        }
        _ => (0.0, "time left not yet known".to_string()),
    };
    format!(
        "progress: {done}/{total} realisations ({:.1} %), {}, {} elapsed, {eta}",
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
    /// When the first realisations were computed, and the count done then.
    first: Mutex<Option<(Instant, u64)>>,
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
            first: Mutex::new(None),
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

    /// `count` more realisations computed at `now`.
    pub fn record(&self, count: u64, now: Instant) {
        let done = self.done.fetch_add(count, Ordering::Relaxed) + count;
        let mut first = self.first.lock().expect("progress lock");
        if first.is_none() {
            *first = Some((now, done));
        }
    }

    /// The line describing the state at `now`.
    pub fn current(&self, now: Instant) -> String {
        let done = self.done.load(Ordering::Relaxed);
        let kept = self.kept.load(Ordering::Relaxed);
        let first = *self.first.lock().expect("progress lock");
        line(Pace {
            done,
            total: self.total.load(Ordering::Relaxed),
            computed: done - kept.min(done),
            elapsed: now.duration_since(self.started),
            computing: first.map(|(at, then)| (now.duration_since(at), done - then.min(done))),
        })
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
                let now = Instant::now();
                lines.record(count, now);
                if let Some(line) = lines.due(now) {
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
        let t0 = lines.started;
        lines.record(50, t0);
        lines.record(200, t0 + Duration::from_secs(8));
        assert_eq!(lines.due(t0 + Duration::from_secs(5)), None);
        let line = lines
            .due(t0 + Duration::from_secs(10))
            .expect("a line after 10 s");
        // 200 realisations in the 10 s after the first 50: 20/s; 25 % done (past the 10 %
        // that settles the estimate), 750 left: 37.5 s, shown rounded.
        assert_eq!(
            line,
            "progress: 250/1000 realisations (25.0 %), 20.0/s, 10 s elapsed, about 38 s left"
        );
        assert_eq!(lines.due(t0 + Duration::from_secs(15)), None);
        assert!(lines.due(t0 + Duration::from_secs(20)).is_some());
    }

    #[test]
    fn no_time_left_is_extrapolated_from_a_slow_start() {
        // An 18 s run whose first 9 s prepare the model: its first line, at 10 s, had
        // said "about 3 h 13 min left" from the few realisations done by then.
        let lines = Lines::new(Duration::from_secs(10));
        lines.total.store(100_000, Ordering::Relaxed);
        let t0 = lines.started;
        lines.record(8, t0 + Duration::from_secs(9));
        lines.record(800, t0 + Duration::from_secs(10));
        let line = lines.due(t0 + Duration::from_secs(10)).expect("a line");
        assert!(line.ends_with("time left not yet known"), "{line}");
        // Once 10 % is computed, the rate since the first results gives the time left:
        // 9 992 realisations in the 2 s after the first 8 (4 996/s), 90 000 left: 18 s.
        lines.record(9_192, t0 + Duration::from_secs(11));
        let line = lines.current(t0 + Duration::from_secs(11));
        assert!(line.ends_with("about 18 s left"), "{line}");
    }
}
