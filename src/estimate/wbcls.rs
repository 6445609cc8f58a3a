//! `wbcls`: weighted bias-compensated least squares (see docs/model.md#wbcls).
//!
//! BCLS, then the equation-error variance Ω̂ from that estimate, then BCLS with weights
//! 1/Ω̂, twice. The rows are cut into consecutive segments of [`SEGMENT_S`] (and at least
//! [`MIN_SEGMENT_ROWS`] rows); a segment's
//! weight takes the speed inside Ω̂ from the measured speed of its neighbouring segments
//! (not its own), so each weight is independent of the noise of the rows it weights (for
//! AR(1) speed noise the neighbours are taken three correlation times away, where the
//! correlation has fallen below 5 %) and the compensated weighted sums stay unbiased up to
//! the O(1/N) effect of the weights' dependence on the realisation's BCLS estimate. The
//! moments of each segment are summed once per realisation; each iteration only reweights
//! them.

use std::sync::Arc;

use super::bounds::{Bound, BoundKind};
use super::channels::{Channel, GradeLoading, NoiseLevels, OmegaAt, Signal};
use super::estimator::{
    Estimate, Estimator, EstimatorSettings, FirstOrder, Realisation, RowScan, ScanStart,
    compensated_bias,
};
use super::moments::Moments;
use super::moments::RowsView;
use super::regression::Regression;
use super::moments::{CHUNK_ROWS, chunk_moments};
use super::moments::segment_sums::{output_sums, segment_moments_lanes, with_constants};
use super::sums::{Column as Factor, Sum, WeightedSums};
#[cfg(target_arch = "x86_64")]
use crate::numeric::simd::Avx2;
use crate::numeric::simd::{Lanes4, Quad};

/// The least length of the segments that share one weight \[s\] (but the last; a segment
/// holds at least one row).
pub const SEGMENT_S: f64 = 0.5;

/// The fewest rows of a segment (but the last): at the thesis's 100 Hz a 0.5 s segment
/// holds 50, at a real log's 1 Hz one row would make a segment, its moments and its weight
/// cost as much as the rest of the row's work together (docs/model.md#wbcls).
pub const MIN_SEGMENT_ROWS: usize = 16;

/// How many times the weights are recomputed from the latest estimate.
pub const ITERATIONS: usize = 2;

/// How many correlation times of AR(1) speed noise lie between a segment and the
/// neighbours its weight is taken from.
pub const CORRELATION_TIMES_LEFT_OUT: f64 = 3.0;

/// Weighted bias-compensated least squares.
#[derive(Debug, Clone, Copy)]
pub struct Wbcls;

impl Estimator for Wbcls {
    fn name(&self) -> &'static str {
        "wbcls"
    }

    fn description(&self) -> &'static str {
        "weighted BCLS: BCLS, then weights 1/Ω̂ from that estimate and the locally averaged measured speed, then BCLS with the weights (twice)"
    }

    fn scan(&self) -> Option<Box<dyn RowScan>> {
        Some(Box::new(SegmentScan::default()))
    }

    fn reads_grade_sums(&self) -> bool {
        true
    }

    fn needs_even_differentiation(&self) -> bool {
        true
    }

    fn first_order_bias(&self, at: &FirstOrder<'_>) -> [f64; 3] {
        compensated_bias(at)
    }

    fn estimate(&self, r: &Realisation<'_>) -> Estimate {
        let (k, g) = (r.regression.k, r.regression.g);
        let sd = r.noise.speed_sd();
        let mut theta = match r.settings.solve(&r.moments.bcls_system(k, g, r.noise)) {
            Ok(theta) => theta,
            failed => return Estimate::theta(failed),
        };
        let weight_segments = WeightSegments::of(r.regression);
        let segments = &weight_segments.ranges[..];
        let moments = &r.scan::<SegmentScan>().done[..];
        let skip = segments_left_out(r.noise, weight_segments.shortest_s);
        let local = neighbour_means(moments, sd * sd, skip);
        let derivative = derivative_variance(r, segments);
        for _ in 0..ITERATIONS {
            let weighting = Weighting {
                moments,
                local: &local,
                derivative: derivative.as_deref(),
                theta: [theta[0], theta[1], theta[2]],
                k,
                noise: r.noise,
            };
            let Some(total) = weighting.total() else {
                // No noise, or a variance model that breaks down: stay with the last
                // estimate.
                return Estimate::theta(Ok(theta));
            };
            theta = match r.settings.solve(&total.bcls_system(k, g, r.noise)) {
                Ok(theta) => theta,
                failed => return Estimate::theta(failed),
            };
        }
        Estimate::theta(Ok(theta))
    }

    fn reports(&self, bound: &Bound, _settings: &EstimatorSettings) -> bool {
        // The sandwich is the spread of the unweighted estimators.
        bound.kind != BoundKind::EivSandwich
    }
}

/// One pass of the reweighting: the segments' `moments`, each weighted by 1/Ω̂ at the
/// estimate `theta` (its local speed and grade loading from `local`, plus the variance
/// `derivative` adds).
struct Weighting<'a> {
    moments: &'a [Moments],
    local: &'a [(f64, f64)],
    derivative: Option<&'a [f64]>,
    theta: [f64; 3],
    k: f64,
    noise: &'a NoiseLevels,
}

impl Weighting<'_> {
    /// The weighted moments summed in order; `None` where a variance is not positive and
    /// finite. Compiled for AVX2 where the CPU has it (the same operations: only the
    /// instructions differ).
    fn total(&self) -> Option<Moments> {
        #[cfg(target_arch = "x86_64")]
        {
            if crate::numeric::simd::avx2() {
                // SAFETY: the CPU supports AVX2, checked just above.
                return unsafe { self.total_avx2() };
            }
        }
        self.total_body()
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn total_avx2(&self) -> Option<Moments> {
        self.total_body()
    }

    #[inline(always)]
    fn total_body(&self) -> Option<Moments> {
        let mut total = WeightedSums::default();
        for (b, (m, &(v2, c2))) in self.moments.iter().zip(self.local).enumerate() {
            let variance = row_variance(&self.theta, self.k, v2, c2, self.noise)
                + self.derivative.map_or(0.0, |d| d[b]);
            if !(variance > 0.0 && variance.is_finite()) {
                return None;
            }
            total.add(m, 1.0 / variance);
        }
        Some(total.finish())
    }
}

/// How many segments on each side of a segment are skipped before its neighbours, the
/// most any channel needs: none for noise independent between rows,
/// [`CORRELATION_TIMES_LEFT_OUT`] correlation times for noise correlated in time (counted
/// in segments of the shortest span `shortest_s`, so that the skipped ones span at least
/// that), and at least one for noise that enters neighbouring rows (a segment's edge rows
/// read the neighbours' samples).
fn segments_left_out(noise: &NoiseLevels, shortest_s: f64) -> usize {
    Channel::ALL
        .iter()
        .map(|c| {
            let tau = c.correlation_time_s(noise);
            let correlated = if tau > 0.0 {
                (CORRELATION_TIMES_LEFT_OUT * tau / shortest_s).ceil() as usize
            } else {
                0
            };
            if c.enters_neighbours(noise) {
                correlated.max(1)
            } else {
                correlated
            }
        })
        .max()
        .unwrap_or(0)
}

/// Per segment, the variance the channels add to ỹ beyond their Ω terms
/// ([`Channel::derivative_variance`]), in [`Channel::ALL`] order (`None`: none does).
fn derivative_variance(r: &Realisation<'_>, segments: &[(usize, usize)]) -> Option<Vec<f64>> {
    let mut terms = Channel::ALL
        .iter()
        .filter_map(|c| c.derivative_variance(r.regression, r.noise, segments));
    let first = terms.next()?;
    Some(terms.fold(first, |mut total, t| {
        for (a, b) in total.iter_mut().zip(t) {
            *a += b;
        }
        total
    }))
}

/// Per segment b, from the segments `skip + 1` before and after it (those that exist):
/// the mean of Ṽ² − σ² (an unbiased local V², at least 0) and of x̃₃²; the means over all
/// segments where it has no neighbour.
fn neighbour_means(moments: &[Moments], s2: f64, skip: usize) -> Vec<(f64, f64)> {
    // [ΣṼ², Σx̃₃², N] of segments, each added in turn, and their means (`None`: no row).
    let add = |[w, c2, n]: [f64; 3], m: &Moments| [w + m.s_w, c2 + m.s_33, n + m.n];
    let mean = |[w, c2, n]: [f64; 3]| (n > 0.0).then(|| ((w / n - s2).max(0.0), c2 / n));
    let overall = mean(moments.iter().fold([0.0; 3], add)).unwrap_or((0.0, 0.0));
    (0..moments.len())
        .map(|b| {
            let before = b.checked_sub(skip + 1).map(|i| &moments[i]);
            let near = before.into_iter().chain(moments.get(b + skip + 1));
            mean(near.fold([0.0; 3], add)).unwrap_or(overall)
        })
        .collect()
}

/// Ω̂: the first-order equation-error variance of docs/model.md#bounds at the estimate
/// `theta`, with a local V̂² for V² and a local mean of x̃₃² = g² cos² θ̃ for the grade term
/// (its θ₃ sin θ part, below 0.3 % of it, is left out).
fn row_variance(theta: &[f64; 3], k: f64, v2: f64, c2: f64, noise: &NoiseLevels) -> f64 {
    noise.omega(&OmegaAt {
        theta: *theta,
        k,
        v2,
        grade: GradeLoading::MeanSquare(c2),
    })
}

/// The weight segments of `wbcls`: consecutive row ranges of at least [`SEGMENT_S`] and
/// [`MIN_SEGMENT_ROWS`] rows each (the last may be shorter; a range holds at least one
/// row), and over each the noise-free
/// sums of the terms without w: those of x₁ and x₃ alone (Σx₁², Σx₁x₃, Σx₃², Σx₁, Σx₃), and
/// Σx₁y, Σx₃y, Σy in four lanes as [`segment_moments`](super::moments::segment_sums::segment_moments) sums a segment (so a segment whose ỹ
/// is y takes them to the same bits); the rest zero. Made once per regression
/// ([`Regression::derived`]).
#[derive(Debug)]
pub(crate) struct WeightSegments {
    /// Row ranges a..b.
    pub(crate) ranges: Vec<(usize, usize)>,
    /// The noise-free sums without w over each.
    pub(crate) sums: Vec<Moments>,
    /// The shortest time from a segment's first row to the next segment's (at least
    /// [`SEGMENT_S`]; [`SEGMENT_S`] with one segment) \[s\].
    pub(crate) shortest_s: f64,
    /// Whether every segment but the last is the chunk of [`CHUNK_ROWS`] rows at its
    /// place (rows 16·j .. 16·(j + 1)), as where the samples are at least 1/30 s apart:
    /// then the kernel's pass takes their moments ([`RowsView::chunks`]).
    pub(crate) chunks: bool,
}

impl WeightSegments {
    /// `reg`'s weight segments.
    pub(crate) fn of(reg: &Regression) -> Arc<WeightSegments> {
        reg.derived(|reg| {
            let t = &reg.t;
            let mut ranges = Vec::new();
            let mut start = 0;
            for i in 1..t.len() {
                if t[i] - t[start] >= SEGMENT_S && i - start >= MIN_SEGMENT_ROWS {
                    ranges.push((start, i));
                    start = i;
                }
            }
            // the full segments' spans (each at least SEGMENT_S by the rule above)
            let shortest_s = ranges
                .iter()
                .map(|&(a, b)| t[b] - t[a])
                .reduce(f64::min)
                .unwrap_or(SEGMENT_S);
            if !t.is_empty() {
                ranges.push((start, t.len()));
            }
            let sums = ranges
                .iter()
                .map(|&(a, b)| {
                    let mut m = Moments::default();
                    for s in Sum::ALL.into_iter().filter(|s| s.regressors_only()) {
                        let column = |c: &Factor| match c {
                            Factor::F => &reg.f[a..b],
                            _ => &reg.c[a..b],
                        };
                        m[s] = match s.factors() {
                            [x] => column(x).iter().sum(),
                            [x, z] => column(x).iter().zip(column(z)).map(|(x, z)| x * z).sum(),
                            _ => unreachable!("a sum has one or two factors"),
                        };
                    }
                    [m.s_1y, m.s_3y, m.s_y] = output_sums(&reg.f[a..b], &reg.c[a..b], &reg.y[a..b]);
                    m
                })
                .collect();
            let full = &ranges[..ranges.len().saturating_sub(1)];
            let chunks = full
                .iter()
                .enumerate()
                .all(|(j, &range)| range == (CHUNK_ROWS * j, CHUNK_ROWS * (j + 1)));
            WeightSegments {
                ranges,
                sums,
                shortest_s,
                chunks,
            }
        })
    }
}

/// The moments of each weight segment of `wbcls` (at least [`SEGMENT_S`] and
/// [`MIN_SEGMENT_ROWS`] rows long, [`WeightSegments`]), each taken by [`segment_moments`](super::moments::segment_sums::segment_moments) once the rows have reached
/// its end.
#[derive(Debug, Clone, Default)]
pub(crate) struct SegmentScan {
    grade: bool,
    segments: Option<Arc<WeightSegments>>,
    pub(crate) done: Vec<Moments>,
}

impl RowScan for SegmentScan {
    fn reset(&mut self, reg: &Regression, start: &ScanStart<'_>) {
        self.grade = start.noise.measures_noisy(Signal::Grade);
        self.segments = Some(WeightSegments::of(reg));
        self.done.clear();
    }

    fn reads_chunks(&self, grade: bool) -> bool {
        self.segments.as_ref().is_some_and(|s| s.chunks) && self.serves(grade)
    }

    fn advance(&mut self, rows: RowsView<'_>, end: usize) {
        let shared = Arc::clone(
            self.segments
                .as_ref()
                .expect("a scan is reset with its regression"),
        );
        let (segments, constants) = (&shared.ranges[..], &shared.sums[..]);
        #[cfg(target_arch = "x86_64")]
        if let Some(avx2) = Avx2::detect() {
            // SAFETY: the token proves the CPU has AVX2.
            return unsafe { self.advance_avx2(avx2, rows, segments, constants, end) };
        }
        self.advance_lanes(Quad, rows, segments, constants, end);
    }
}

impl SegmentScan {
    /// Whether chunks' moments taken with the grade term's sums or without (`grade`) serve
    /// the scan: without them only where it does not read them.
    fn serves(&self, grade: bool) -> bool {
        grade || !self.grade
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn advance_avx2(
        &mut self,
        avx2: Avx2,
        rows: RowsView<'_>,
        segments: &[(usize, usize)],
        constants: &[Moments],
        end: usize,
    ) {
        self.advance_lanes(avx2, rows, segments, constants, end);
    }

    /// The segments that end by `end`, each [`segment_moments`](super::moments::segment_sums::segment_moments) of its rows, written into
    /// `done` by the function that sums them (compiled for AVX2, the copy of a segment's
    /// moments is a few register stores rather than a call of `memcpy`).
    #[inline(always)]
    fn advance_lanes<L: Lanes4>(
        &mut self,
        l: L,
        rows: RowsView<'_>,
        segments: &[(usize, usize)],
        constants: &[Moments],
        end: usize,
    ) {
        while let Some(&(a, b)) = segments.get(self.done.len()) {
            if b > end {
                break;
            }
            let j = self.done.len();
            let constant = rows.noise_free_f_c.then_some(&constants[j]);
            // The chunk's moments as the pass took them, where it took them (with the
            // grade term's sums where they are wanted): the bits summing the rows gives.
            let chunk = rows.chunks.get(j).filter(|_| {
                (a, b) == (CHUNK_ROWS * j, CHUNK_ROWS * (j + 1)) && self.serves(rows.chunks.grade)
            });
            self.done.push(match chunk {
                Some(lanes) => {
                    let m = chunk_moments(l, lanes, self.grade);
                    with_constants(m, constant, rows.noise_free_y)
                }
                None => {
                    assert!(
                        rows.chunks.rows || a >= rows.chunks.end(),
                        "a segment read from rows that were not written"
                    );
                    segment_moments_lanes(l, rows, a, b, constant, self.grade)
                }
            });
        }
    }
}

#[cfg(test)]
mod chunk_tests;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_segment_takes_its_speed_from_its_neighbours_not_itself() {
        let m = |w: f64| Moments {
            s_w: w,
            s_33: 96.0,
            n: 1.0,
            ..Moments::default()
        };
        let moments = [m(100.0), m(400.0), m(900.0), m(1600.0)];
        let local = neighbour_means(&moments, 1.0, 0);
        assert_eq!(local[1], ((100.0 + 900.0) / 2.0 - 1.0, 96.0));
        assert_eq!(local[0].0, 399.0);
        // Skipping one: segment 0 uses segment 2, segment 1 segment 3.
        let local = neighbour_means(&moments, 1.0, 1);
        assert_eq!(local[0].0, 899.0);
        assert_eq!(local[1].0, 1599.0);
    }
}
