//! The model errors drawn anew in every realisation, each from its own stream: gusts (a
//! wind that is another day's in every realisation) and a random force calibration
//! (another sensor's in every realisation). Each realises as a steady entry of `steady.rs`
//! or as [`RunGusts`], a [`WindSeries`] per run (docs/model.md#model-errors).

use std::cell::RefCell;
use std::sync::Arc;

use super::steady::ForceScale;
use super::{Drawn, MODEL_ERROR_COUNT, ModelError, ModelErrorEntry, TruthSample, entry_index};
use crate::noise::NormalSequence;

/// A random wind component along the direction of travel: a stationary AR(1) process in time
/// with standard deviation σ_w \[m/s\] and correlation time τ \[s\], drawn per realisation at
/// the cycle's sample times (w₀ = σ_w z₀, wᵢ = φᵢ wᵢ₋₁ + σ_w √(1 − φᵢ²) zᵢ,
/// φᵢ = exp(−(tᵢ − tᵢ₋₁)/τ)) and linear between them; in a drive of several runs (a
/// coast-down) each run's series is drawn on its own, from the next normals of the stream.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gust {
    /// σ_w \[m/s\].
    pub sd_m_s: f64,
    /// τ \[s\].
    pub time_s: f64,
}

impl Gust {
    /// A stationary AR(1) series of the gust at `times_s` from the next normals of `normals`.
    fn series(&self, normals: &mut NormalSequence, times_s: &Arc<[f64]>) -> WindSeries {
        let mut w = SPARE_WINDS.with_borrow_mut(Vec::pop).unwrap_or_default();
        w.resize(times_s.len(), 0.0);
        normals.fill(&mut w);
        let steps = self.steps(times_s);
        let mut previous = 0.0;
        for (i, z) in w.iter_mut().enumerate() {
            *z = match i {
                0 => self.sd_m_s * *z,
                _ => {
                    let [phi, scale] = steps[i - 1];
                    phi * previous + scale * *z
                }
            };
            previous = *z;
        }
        WindSeries::new(times_s.clone(), w)
    }

    /// φᵢ and σ_w √(1 − φᵢ²) of each step of `times_s` (i ≥ 1). The same in every
    /// realisation, so each thread keeps those of the last [`KEPT_STEPS`] runs it drew
    /// gusts on (a coast-down's runs each have their own times).
    fn steps(&self, times_s: &Arc<[f64]>) -> Arc<[[f64; 2]]> {
        type Kept = Vec<(Arc<[f64]>, [u64; 2], Arc<[[f64; 2]]>)>;
        thread_local! {
            static KEPT: RefCell<Kept> = const { RefCell::new(Vec::new()) };
        }
        let key = [self.sd_m_s.to_bits(), self.time_s.to_bits()];
        let make = || -> Arc<[[f64; 2]]> {
            times_s
                .windows(2)
                .map(|t| {
                    let phi = (-(t[1] - t[0]) / self.time_s).exp();
                    [phi, self.sd_m_s * (1.0 - phi * phi).sqrt()]
                })
                .collect()
        };
        KEPT.try_with(|kept| {
            let mut kept = kept.try_borrow_mut().ok()?;
            // The times are held here, so a pointer that matches is these times.
            if let Some((_, _, steps)) = kept
                .iter()
                .find(|(times, k, _)| Arc::ptr_eq(times, times_s) && *k == key)
            {
                return Some(steps.clone());
            }
            let steps = make();
            if kept.len() == KEPT_STEPS {
                kept.remove(0);
            }
            kept.push((times_s.clone(), key, steps.clone()));
            Some(steps)
        })
        .ok()
        .flatten()
        .unwrap_or_else(make)
    }
}

/// The runs whose gusts' steps a thread keeps ([`Gust::steps`]).
const KEPT_STEPS: usize = 32;

/// Spare wind columns a thread keeps at most (those of a group of realisations side by
/// side and the next).
const SPARE_WIND_COLUMNS: usize = 16;
/// The most values the spare wind columns hold together (32 MiB).
const SPARE_WIND_VALUES: usize = 4 << 20;

thread_local! {
    /// The wind columns of the thread's dropped series ([`WindSeries`]'s `Drop`), whose
    /// memory the next series writes into.
    static SPARE_WINDS: RefCell<Vec<Vec<f64>>> = const { RefCell::new(Vec::new()) };
}

impl ModelError for Gust {
    fn drawn(&self) -> Option<Drawn> {
        Some(Drawn {
            stream: crate::noise::Stream::Gusts,
            moves_the_vehicle: true,
        })
    }

    fn realise(
        &self,
        normals: &mut NormalSequence,
        run_times_s: &[Arc<[f64]>],
    ) -> Arc<dyn ModelError> {
        // Each run's series from the next normals of the stream: the runs' gusts are
        // independent, each starting stationary.
        let runs = run_times_s
            .iter()
            .map(|times_s| self.series(normals, times_s))
            .collect();
        Arc::new(RunGusts { runs })
    }
}

/// A wind known at sample times (one realisation's gusts), linear between them and held
/// beyond the ends.
#[derive(Debug, Clone, PartialEq)]
pub struct WindSeries {
    /// Times from the cycle's start \[s\], increasing (shared by every realisation's
    /// series of a run).
    times_s: Arc<[f64]>,
    /// The wind at each \[m/s\], positive a headwind.
    wind_m_s: Vec<f64>,
    /// (n − 1) / (tₙ₋₁ − t₀), which turns a time into the guess of its index for evenly
    /// spaced times ([`WindSeries::first_after`]).
    per_step: f64,
}

impl WindSeries {
    /// The wind `wind_m_s` \[m/s\] at the increasing times `times_s` \[s\] (as many).
    pub fn new(times_s: Arc<[f64]>, wind_m_s: Vec<f64>) -> WindSeries {
        assert_eq!(times_s.len(), wind_m_s.len(), "a wind at each time");
        let n = times_s.len();
        let per_step = match n {
            0 | 1 => 0.0,
            _ => (n - 1) as f64 / (times_s[n - 1] - times_s[0]),
        };
        WindSeries {
            times_s,
            wind_m_s,
            per_step,
        }
    }

    /// The times \[s\].
    pub fn times_s(&self) -> &[f64] {
        &self.times_s
    }

    /// The wind at each time \[m/s\].
    pub fn wind_m_s(&self) -> &[f64] {
        &self.wind_m_s
    }

    /// The wind \[m/s\] at time `t_s` from the cycle's start: exactly the sample's value at
    /// a sample time.
    pub fn at(&self, t_s: f64) -> f64 {
        let (t, w) = (&self.times_s, &self.wind_m_s);
        let j = self.first_after(t_s);
        match j {
            0 => w[0],
            j if j == t.len() => w[j - 1],
            j => {
                let u = (t_s - t[j - 1]) / (t[j] - t[j - 1]);
                w[j - 1] + u * (w[j] - w[j - 1])
            }
        }
    }
}

impl Drop for WindSeries {
    /// Its wind column becomes the thread's spare, for the next series drawn (unless the
    /// spares are full).
    fn drop(&mut self) {
        let wind = std::mem::take(&mut self.wind_m_s);
        let _ = SPARE_WINDS.try_with(|spare| {
            if let Ok(mut spare) = spare.try_borrow_mut()
                && spare.len() < SPARE_WIND_COLUMNS
                && spare.iter().map(Vec::capacity).sum::<usize>() + wind.capacity()
                    <= SPARE_WIND_VALUES
            {
                spare.push(wind);
            }
        });
    }
}

impl WindSeries {
    /// The index of the first sample time after `t_s` (`t.partition_point(|x| x <= t_s)`),
    /// found from the guess of evenly spaced times and corrected, so that an RK4 stage
    /// does not search the whole series.
    fn first_after(&self, t_s: f64) -> usize {
        let t = &self.times_s;
        let n = t.len();
        if n < 2 || t_s.is_nan() {
            return t.partition_point(|&x| x <= t_s);
        }
        // Truncated, not floored (the same for a guess ≥ 0; a guess only starts the search,
        // so its rounding moves no index).
        let guess = (t_s - t[0]) * self.per_step;
        let mut j = if guess.is_finite() && guess >= 0.0 {
            (guess as usize).saturating_add(1).min(n)
        } else {
            0
        };
        while j > 0 && t[j - 1] > t_s {
            j -= 1;
        }
        while j < n && t[j] <= t_s {
            j += 1;
        }
        j
    }
}

/// A realisation's gusts: one series per run, each read at the time since its run's first
/// sample (a drive of one run has one, read at the time since the cycle's start).
#[derive(Debug, Clone, PartialEq)]
pub struct RunGusts {
    /// Per run, its gust series.
    pub runs: Vec<WindSeries>,
}

impl ModelError for RunGusts {
    fn wind_m_s(&self, s: &TruthSample) -> f64 {
        self.runs[s.run].at(s.run_time_s)
    }
}

/// A random calibration error of the force signal: the log records (1 + ε)·F with
/// ε ~ N(0, s²) drawn once per realisation. The truth's motion is unchanged.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ForceScaleDrawn {
    /// s \[-\].
    pub sd: f64,
}

impl ModelError for ForceScaleDrawn {
    fn drawn(&self) -> Option<Drawn> {
        Some(Drawn {
            stream: crate::noise::Stream::ForceCalibration,
            moves_the_vehicle: false,
        })
    }

    fn realise(
        &self,
        normals: &mut NormalSequence,
        _run_times_s: &[Arc<[f64]>],
    ) -> Arc<dyn ModelError> {
        let mut z = [0.0];
        normals.fill(&mut z);
        Arc::new(ForceScale {
            scale: self.sd * z[0],
        })
    }
}

/// The value of `truth.wind_gust_time` among every entry's `values`.
fn gust_time(values: &[f64; MODEL_ERROR_COUNT]) -> f64 {
    values[entry_index(GUST_TIME.key).expect("the gust time is an entry")]
}

/// `truth.wind_gust_sd`.
pub(super) const GUST: ModelErrorEntry = ModelErrorEntry {
    name: "gusts",
    key: "wind_gust_sd",
    unit: "m/s",
    axis: true,
    drawn: true,
    neutral: 0.0,
    check: |s| super::steady::within(s, 0.0, 20.0, "must be a finite number in [0, 20] m/s"),
    build: |s, values| {
        Some(Arc::new(Gust {
            sd_m_s: s,
            time_s: gust_time(values),
        }))
    },
};

/// `truth.wind_gust_time`: the correlation time of the gusts (a parameter of
/// `wind_gust_sd`, which it builds nothing without).
pub(super) const GUST_TIME: ModelErrorEntry = ModelErrorEntry {
    name: "gusts' correlation time",
    key: "wind_gust_time",
    unit: "s",
    axis: false,
    drawn: true,
    neutral: 10.0,
    // Up to about 100 days: a correlation time far beyond a run's length makes each run's
    // gust one steady draw.
    check: |t| {
        (!(t.is_finite() && t > 0.0 && t <= 1e7))
            .then_some("must be a finite number > 0 and at most 1e7 s")
    },
    build: |_, _| None,
};

/// `truth.force_scale_sd`.
pub(super) const FORCE_SCALE_SD: ModelErrorEntry = ModelErrorEntry {
    name: "random force calibration",
    key: "force_scale_sd",
    unit: "",
    axis: true,
    drawn: true,
    neutral: 0.0,
    check: |s| super::steady::within(s, 0.0, 0.5, "must be a finite number in [0, 0.5]"),
    build: |s, _| Some(Arc::new(ForceScaleDrawn { sd: s })),
};

#[cfg(test)]
mod tests {
    use super::*;

    /// A drive of several runs draws each run's gusts from the next normals of the stream,
    /// each series starting stationary (w₀ = σ z₀, not carried over from the run before),
    /// and a sample reads its own run's series at the time since its run's start; a drive of
    /// one run draws exactly what the series alone draws.
    #[test]
    fn each_run_draws_its_own_gusts() {
        let gust = Gust {
            sd_m_s: 1.5,
            time_s: 1e6,
        };
        let times: Arc<[f64]> = (0..50).map(|i| i as f64 * 0.1).collect();
        let realised = |runs: &[Arc<[f64]>]| {
            let mut normals = NormalSequence::for_realisation(3, 1, crate::noise::Stream::Gusts, 9);
            gust.realise(&mut normals, runs)
        };
        let two = realised(&[times.clone(), times.clone()]);
        let mut normals = NormalSequence::for_realisation(3, 1, crate::noise::Stream::Gusts, 9);
        let first = gust.series(&mut normals, &times);
        let second = gust.series(&mut normals, &times);
        let sample = |run: usize, t: f64| TruthSample {
            time_s: 100.0 + t,
            distance_m: 0.0,
            speed_m_s: 20.0,
            grade_rad: 0.0,
            heading: 1.0,
            run,
            run_time_s: t,
        };
        for (j, &t) in times.iter().enumerate() {
            assert_eq!(two.wind_m_s(&sample(0, t)), first.wind_m_s[j]);
            assert_eq!(two.wind_m_s(&sample(1, t)), second.wind_m_s[j]);
        }
        // With τ = 10⁶ s a carried-over series would start run 1 where run 0 ended.
        assert_ne!(second.wind_m_s[0], first.wind_m_s[49]);
        assert_eq!(second.wind_m_s[0] / 1.5, {
            let mut n = NormalSequence::for_realisation(3, 1, crate::noise::Stream::Gusts, 9);
            let mut z = [0.0; 51];
            n.fill(&mut z);
            z[50]
        });
        let one = realised(std::slice::from_ref(&times));
        for (j, &t) in times.iter().enumerate() {
            assert_eq!(one.wind_m_s(&sample(0, t)), first.wind_m_s[j]);
        }
    }

    #[test]
    fn the_gusts_lookup_finds_what_a_search_of_the_times_finds() {
        // Even steps with rounding (i · 0.01), and uneven ones: every probe, at, between
        // and beyond the sample times, lands where partition_point lands.
        let even: Vec<f64> = (0..1001).map(|i| i as f64 * 0.01).collect();
        let uneven: Vec<f64> = (0..300).map(|i| (i as f64).powf(1.3) * 0.1).collect();
        for times in [even, uneven] {
            let series = WindSeries::new(times.clone().into(), vec![0.0; times.len()]);
            let last = *times.last().unwrap();
            let mut probes: Vec<f64> = times.clone();
            probes.extend(times.windows(2).map(|w| 0.5 * (w[0] + w[1])));
            probes.extend([-1.0, last + 1.0, f64::INFINITY, -f64::INFINITY]);
            for p in probes {
                assert_eq!(
                    series.first_after(p),
                    times.partition_point(|&x| x <= p),
                    "at {p}"
                );
            }
        }
    }
}
