//! Speed noise through time: where a differentiated acceleration takes its speeds
//! ([`Differentiation`], and the regression built with one) and the AR(1) coefficients of
//! noise correlated in time (docs/model.md#noise-channels).

use std::sync::OnceLock;

use super::{Column, Regression, Segments};
use crate::dynamics::{DriveCycle, VehicleParams};

/// Where a differentiated acceleration takes its speeds: the logged samples from the one
/// before the first row to the one after the last (the *span*; rows left out of the
/// regression in between are logged too), and each row's place in it. Row i's output is
/// (Ṽ_{s+1} − Ṽ_{s−1}) / (t_{s+1} − t_{s−1}) + g sin θ̃ with s = `sample[i]`.
#[derive(Debug, Clone)]
pub struct Differentiation {
    /// Times of the span's samples \[s\].
    pub span_t: Column,
    /// The run of each of the span's samples.
    pub span_run: Column<u32>,
    /// Each row's sample in the span (its neighbours are the samples before and after).
    pub sample: Column<usize>,
    /// 1 / (t_{s+1} − t_{s−1}) of each row \[1/s\].
    pub inv_dt: Column,
    /// [`Differentiation::mean_spans`] of the segments first asked for.
    spans: OnceLock<Segments<f64>>,
}

impl PartialEq for Differentiation {
    /// The same samples (the kept spans are derived from them).
    fn eq(&self, other: &Self) -> bool {
        self.span_t == other.span_t
            && self.span_run == other.span_run
            && self.sample == other.sample
            && self.inv_dt == other.inv_dt
    }
}

impl Differentiation {
    /// Where the first `n` rows take their speeds (the regression's
    /// [`prefix`](Regression::prefix)): the span runs to the sample after the last row.
    pub fn prefix(&self, n: usize) -> Differentiation {
        let span = self.sample[n - 1] + 2;
        Differentiation {
            span_t: self.span_t.prefix(span),
            span_run: self.span_run.prefix(span),
            sample: self.sample.prefix(n),
            inv_dt: self.inv_dt.prefix(n),
            spans: OnceLock::new(),
        }
    }

    /// The mean central-difference span t_{s+1} − t_{s−1} of the rows of each of
    /// `segments` \[s\] (rows a..b), summed in row order; kept for the segments first asked
    /// for (`wbcls` asks for the same ones in every realisation).
    pub fn mean_spans(&self, segments: &[(usize, usize)]) -> std::borrow::Cow<'_, [f64]> {
        let compute = || -> Vec<f64> {
            segments
                .iter()
                .map(|&(a, b)| {
                    let span: f64 = (a..b)
                        .map(|i| self.span_t[self.sample[i] + 1] - self.span_t[self.sample[i] - 1])
                        .sum();
                    span / (b - a) as f64
                })
                .collect()
        };
        let (kept, spans) = self.spans.get_or_init(|| (segments.to_vec(), compute()));
        match kept.as_slice() == segments {
            true => std::borrow::Cow::Borrowed(spans),
            false => std::borrow::Cow::Owned(compute()),
        }
    }
}

impl Regression {
    /// The regression of the samples of `cycle` marked in `used` (none of them the first or
    /// last sample of its run: a speed is differenced within a run, never across two) with
    /// the acceleration differentiated from the speed: the noise-free output is the central
    /// difference of the true speed, and [`Differentiation`] tells the kernel where each
    /// row's speed noise comes from.
    pub fn differentiated(
        cycle: &DriveCycle,
        used: &[bool],
        grade_offset: f64,
        vehicle: &VehicleParams,
    ) -> Regression {
        let (t, v) = (&cycle.t_s, &cycle.v_m_s);
        let rows: Vec<usize> = (0..used.len()).filter(|&i| used[i]).collect();
        assert!(
            !rows.is_empty() && rows.iter().all(|&i| !cycle.at_run_edge(i)),
            "a differentiated row needs a sample of its run on each side"
        );
        let inv_dt: Vec<f64> = rows.iter().map(|&i| 1.0 / (t[i + 1] - t[i - 1])).collect();
        let mut selected = cycle.select(used);
        selected.accel_m_s2 = rows
            .iter()
            .zip(&inv_dt)
            .map(|(&i, q)| (v[i + 1] - v[i - 1]) * q)
            .collect();
        selected
            .grade_rad
            .iter_mut()
            .for_each(|g| *g += grade_offset);
        let start = rows[0] - 1;
        let end = rows[rows.len() - 1] + 1;
        let mut reg = Regression::new(&selected, vehicle);
        reg.differentiation = Some(Differentiation {
            span_t: t[start..=end].into(),
            span_run: cycle.run[start..=end].into(),
            sample: rows.iter().map(|&i| i - start).collect::<Vec<_>>().into(),
            inv_dt: inv_dt.into(),
            spans: OnceLock::new(),
        });
        reg
    }

    /// The times of the samples that carry speed noise: the span for a differentiated
    /// acceleration, else the rows.
    pub fn noise_times(&self) -> &[f64] {
        self.differentiation.as_ref().map_or(&self.t, |d| &d.span_t)
    }
}

/// The AR(1) coefficients of noise with correlation time `tau_s` \[s\] at samples `t` of
/// runs `run`: φ_i = exp(−(t_i − t_{i−1})/τ) and √(1 − φ_i²), so that
/// e_i = φ_i e_{i−1} + √(1 − φ_i²) z_i is stationary with unit variance for any steps. At the
/// first sample and at each run's first sample the process restarts, \[0, 1\] (e_i = z_i):
/// runs are independent (docs/model.md#coastdown).
pub fn ar1_coefficients(t: &[f64], run: &[u32], tau_s: f64) -> Vec<[f64; 2]> {
    assert_eq!(t.len(), run.len(), "a run per sample");
    (0..t.len())
        .map(|i| match i > 0 && run[i] == run[i - 1] {
            true => {
                let phi = (-(t[i] - t[i - 1]) / tau_s).exp();
                [phi, (1.0 - phi * phi).sqrt()]
            }
            false => [0.0, 1.0],
        })
        .collect()
}
