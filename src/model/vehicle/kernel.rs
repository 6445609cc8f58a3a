//! The kernel of one realisation: each noise channel's draws, the normal-equation sums
//! accumulated block by block (one condition, or a draw group side by side), and the
//! estimates, bounds, extras and control variates concluded from them.

use nalgebra::Vector3;

use super::VehicleModel;
use super::draws::{
    Draws, OwnRegression, SPAN_NOISE, ar1_step, central_differences, filter_side_by_side,
};
use super::world::MovedCycle;
use crate::estimate::bounds::{BOUNDS, BoundValue, thesis_bound};
use crate::estimate::channels::{BlockNoise, CHANNEL_COUNT, Channel, PerChannel, Signal};
use crate::estimate::conversions::ExtraInputs;
use crate::estimate::estimator::{RowScans, ScanStart};
use crate::estimate::estimators::Realisation;
use crate::estimate::moments::{MomentAccumulator, Moments, Rows};
use crate::estimate::regression::Regression;
use crate::model::Status;
use crate::noise::{BLOCK, NormalStream};

/// The speed sensor's channel: its noise is drawn by the kernel itself where it is
/// differentiated into the output (correlated noise in w is drawn likewise, whichever
/// channel's: `NoiseLevels::speed_channel`).
pub(super) const SPEED: Channel = Channel::of(Signal::Speed);

impl VehicleModel {
    /// The standard normal draws of `channel` in realisation `r` of condition `c`, in the
    /// blocks the kernel reads them (its keys, shared or not): `out.len()` values.
    pub fn standard_draws(&self, seed: u64, c: usize, channel: Channel, r: u64, out: &mut [f64]) {
        let key = self.stream_key(c);
        let mut draws = Draws::new(self.shared, seed, key, channel, r);
        for chunk in out.chunks_mut(BLOCK) {
            draws.fill(chunk);
        }
    }

    /// The moments of realisation `r` of condition `c`: the kernel. Draws each active
    /// channel's normals block by block and accumulates the normal-equation sums (N is NaN,
    /// the sums zero, when the realisation's truth cannot be simulated).
    pub fn moments(&self, seed: u64, c: usize, r: u64) -> Moments {
        match self.regression_of(seed, c, r, None) {
            Ok(world) => {
                let (reg, ar1, _) = self.rows_of(c, &world);
                self.measure(seed, c, r, reg, ar1, None, None)
            }
            Err(_) => Moments {
                n: f64::NAN,
                ..Moments::default()
            },
        }
    }

    /// The regression of realisation `r` of condition `c` and the AR(1) coefficients of its
    /// correlated speed noise, when the realisation has its own (a condition with a
    /// [`World`](super::world::World); `None`: the condition's); an error says why its truth
    /// cannot be simulated.
    fn regression_of(
        &self,
        seed: u64,
        c: usize,
        r: u64,
        moved: Option<Result<MovedCycle, String>>,
    ) -> Result<Option<OwnRegression>, String> {
        let cond = &self.conditions[c];
        let Some(world) = &cond.world else {
            return Ok(None);
        };
        let ids = (seed, self.stream_key(c), r);
        let (reg, inv_mass) = world.regression_given(&self.study, &cond.regression, ids, moved)?;
        let ar1 = cond
            .noise
            .velocity_correlated()
            .then(|| reg.ar1_coefficients(cond.noise.velocity_correlation_s));
        // A drawn mass moves 1/M and Cd/M; Cd and Cr stay the vehicle's.
        let truth = match inv_mass {
            Some(inv_mass) => [
                inv_mass,
                self.study.vehicle.drag_coefficient * inv_mass,
                self.truth[2],
            ],
            None => self.truth,
        };
        Ok(Some((reg, ar1, truth)))
    }

    /// The regression a realisation of condition `c` is drawn on, its AR(1) coefficients
    /// and its true θ: its own (`world`, from [`Self::regression_of`]) or the condition's.
    fn rows_of<'a>(
        &'a self,
        c: usize,
        world: &'a Option<OwnRegression>,
    ) -> (&'a Regression, Option<&'a [[f64; 2]]>, &'a [f64; 3]) {
        let cond = &self.conditions[c];
        world.as_ref().map_or_else(
            || (&*cond.regression, cond.ar1.as_deref(), &self.truth),
            |(reg, ar1, truth)| (reg, ar1.as_deref(), truth),
        )
    }

    /// The moments of realisation `r` of condition `c` on the regression `reg` (with AR(1)
    /// coefficients `ar1` of correlated speed noise), and, into `rows` when given, its
    /// measured rows (from the same draws). `span`: the speed noise of a differentiated
    /// acceleration's span, drawn and filtered already ([`Self::filter_spans`]).
    #[inline]
    #[allow(clippy::too_many_arguments)]
    fn measure(
        &self,
        seed: u64,
        c: usize,
        r: u64,
        reg: &Regression,
        ar1: Option<&[[f64; 2]]>,
        mut rows: Option<(&mut Rows, &mut RowScans)>,
        span: Option<&[f64]>,
    ) -> Moments {
        let cond = &self.conditions[c];
        let noise = cond.noise;
        let mut streams = PerChannel::from_fn(|channel| {
            noise
                .is_on(channel)
                .then(|| Draws::new(self.shared, seed, self.stream_key(c), channel, r))
        });
        let mut buffers = PerChannel([[0.0; BLOCK]; CHANNEL_COUNT]);
        let mut acc = MomentAccumulator::new(reg, noise)
            .grade_sums(self.grade_sums)
            .keep_rows(rows.is_some());
        let n = reg.len();
        if let Some((rows, scans)) = &mut rows {
            // The rows themselves are read whole by an estimator that reads rows, or a
            // campaign's verdict.
            let whole = self.study.estimators.iter().any(|e| e.reads_rows())
                || self.study.campaign.is_some();
            let [reads, only] = scans.reads_chunks(acc.sums_grade());
            rows.take_chunks([reads, only && !whole], acc.sums_grade());
        }
        // A differentiated acceleration: the speed noise of every logged sample of the span
        // (AR(1)-filtered where correlated), drawn before the rows that read it, into this
        // thread's buffer (kept from one realisation to the next).
        let mut span_buffer = SPAN_NOISE.take();
        let velocity = &mut streams[SPEED];
        let span_noise = match (&reg.differentiation, velocity, span) {
            (Some(d), Some(_), Some(span)) if noise.speed_noise_differentiated() => Some((d, span)),
            (Some(d), Some(stream), None) if noise.speed_noise_differentiated() => {
                let e = &mut span_buffer;
                e.resize(d.span_t.len(), 0.0);
                stream.fill(e);
                if let Some(ar1) = ar1 {
                    let mut previous = 0.0;
                    for (z, step) in e.iter_mut().zip(ar1) {
                        ar1_step(&mut previous, z, *step);
                    }
                }
                Some((d, &span_buffer[..]))
            }
            _ => None,
        };
        let mut derivative = [0.0; BLOCK];
        // The previous sample's correlated noise in w (AR(1) on the rows only).
        let mut previous = 0.0;
        let in_w = noise.speed_channel();
        for start in (0..n).step_by(BLOCK) {
            let len = BLOCK.min(n - start);
            // The speed noise of the block's rows where they are consecutive samples of the
            // span: read where it is, not copied into the block's buffer.
            let mut span_rows = None;
            if let Some((d, e)) = &span_noise {
                // Each row's own sample's noise, and σ_v (e_{s+1} − e_{s−1}) / Δt in ỹ.
                let sd = noise[SPEED];
                let buffer = &mut buffers[SPEED][..len];
                let (first, last) = (d.sample[start], d.sample[start + len - 1]);
                let inv_dt = &d.inv_dt[start..start + len];
                if last - first == len - 1 {
                    // Consecutive samples (the rows are increasing): slices, which vectorise.
                    span_rows = Some(&e[first..=last]);
                    let (before, after) = (&e[first - 1..last], &e[first + 1..last + 2]);
                    central_differences(sd, after, before, inv_dt, &mut derivative[..len]);
                } else {
                    for (j, i) in (start..start + len).enumerate() {
                        let s = d.sample[i];
                        buffer[j] = e[s];
                        derivative[j] = sd * (e[s + 1] - e[s - 1]) * inv_dt[j];
                    }
                }
            } else if let (Some(ar1), Some(stream)) = (ar1, &mut streams[in_w]) {
                let buffer = &mut buffers[in_w][..len];
                stream.fill(buffer);
                for (z, step) in buffer.iter_mut().zip(&ar1[start..start + len]) {
                    ar1_step(&mut previous, z, *step);
                }
            }
            // The noise in w is drawn above when it is correlated or differentiated.
            let speed_drawn = ar1.is_some() || span_noise.is_some();
            let mut draws = BlockNoise::default();
            for (channel, ((stream, buffer), draw)) in Channel::ALL
                .into_iter()
                .zip(streams.0.iter_mut().zip(&mut buffers.0).zip(&mut draws.0))
            {
                *draw = stream.as_mut().map(|s| {
                    if !(channel == in_w && speed_drawn) {
                        s.fill(&mut buffer[..len]);
                    }
                    match span_rows {
                        Some(rows) if channel == SPEED && channel == in_w => rows,
                        _ => &buffer[..len],
                    }
                });
            }
            let derivative = span_noise.as_ref().map(|_| &derivative[..len]);
            // On the fast path with the rows kept, the sums write w into the rows as they
            // take it (one computation of it for both).
            // On the general path the pass writes the rows where they are kept.
            match &mut rows {
                Some((rows, _)) if acc.measures_rows() => {
                    let moved = acc.add_block_into(start, len, draws, derivative, rows.room(len));
                    rows.take_room(len, moved);
                }
                Some((rows, _)) => {
                    match acc.writes_w() {
                        true => {
                            let w = rows.w_room(len);
                            acc.add_block_writing_w(start, len, draws, derivative, w);
                        }
                        false => acc.add_block(start, len, draws, derivative),
                    }
                    rows.push_block(reg, &noise, start, len, draws, derivative);
                }
                None => acc.add_block(start, len, draws, derivative),
            }
            if let Some((rows, scans)) = &mut rows {
                // The sums the estimators read over the rows, while the block is in cache.
                scans.advance(rows.view(reg), start + len);
            }
        }
        SPAN_NOISE.set(span_buffer);
        acc.finish()
    }
}

impl VehicleModel {
    /// [`Model::realise`](crate::model::Model::realise) with a thread's row buffer (and the
    /// span's speed noise filtered already, see [`Self::measure`]; the realisation's truth
    /// and cycle made already, `moved`, see [`World::moved_cycles`]).
    ///
    /// [`World::moved_cycles`]: super::world::World::moved_cycles
    #[allow(clippy::too_many_arguments)]
    pub(super) fn realise_with(
        &self,
        seed: u64,
        c: usize,
        r: u64,
        rows: &mut Rows,
        scans: &mut RowScans,
        slots: &mut [f64],
        span: Option<&[f64]>,
        moved: Option<Result<MovedCycle, String>>,
    ) {
        let cond = &self.conditions[c];
        let world = match self.regression_of(seed, c, r, moved) {
            Ok(world) => world,
            Err(_) => return self.unsimulated(slots),
        };
        let (reg, ar1, truth) = self.rows_of(c, &world);
        if self.reads_rows {
            rows.reset(reg, &cond.noise);
            let start = ScanStart {
                noise: &cond.noise,
                settings: &cond.settings,
                truth,
                // A realisation's own regression (drawn entries) serves it alone.
                shared: world.is_none(),
            };
            scans.reset(&self.study.estimators, reg, &start);
            let kept = Some((&mut *rows, &mut *scans));
            let moments = self.measure(seed, c, r, reg, ar1, kept, span);
            self.conclude(c, reg, truth, &moments, Some((rows, scans)), slots);
        } else {
            let moments = self.measure(seed, c, r, reg, ar1, None, span);
            self.conclude(c, reg, truth, &moments, None, slots)
        }
    }

    /// The slots of a realisation whose truth cannot be simulated: every estimator's
    /// status [`Status::Unsimulated`], every number NaN.
    fn unsimulated(&self, slots: &mut [f64]) {
        slots.fill(f64::NAN);
        for ei in 0..self.study.estimators.len() {
            slots[self.layout.status_at(ei)] = Status::Unsimulated as u8 as f64;
        }
    }

    /// Whether [`VehicleModel::measure_group`] computes `conditions` (one draw group, or one
    /// condition's consecutive realisations): white noise (or, for one condition, AR(1)
    /// speed noise, filtered for the realisations side by side), an acceleration not
    /// differentiated from the noisy speed, and no estimator that reads the rows. Otherwise
    /// each realisation of each condition is computed on its own (from the same draws).
    pub(super) fn one_draw_serves(&self, conditions: &[usize]) -> bool {
        (self.shared || conditions.len() == 1)
            && !self.reads_rows
            && conditions.iter().all(|&c| {
                let cond = &self.conditions[c];
                (cond.ar1.is_none() || conditions.len() == 1)
                    && cond.world.is_none()
                    && !(cond.regression.differentiation.is_some()
                        && cond.noise.speed_noise_differentiated())
            })
    }

    /// The moments of realisations `first .. first + count` of each of `conditions` (one
    /// draw group, see [`VehicleModel::one_draw_serves`]), per realisation in the order of
    /// `conditions`. Each block of every channel's shared sequence is drawn once and
    /// accumulated into every condition whose rows reach it, the realisations side by side
    /// so that a condition's block of data is read once for all of them. Bit for bit the
    /// moments [`VehicleModel::measure`] gives each condition alone.
    pub(super) fn measure_group(
        &self,
        seed: u64,
        conditions: &[usize],
        first: u64,
        count: usize,
    ) -> Vec<Vec<Moments>> {
        let key = self.stream_key(conditions[0]);
        let noise = self.conditions[conditions[0]].noise;
        let lengths: Vec<usize> = conditions
            .iter()
            .map(|&c| self.conditions[c].regression.len())
            .collect();
        let mut streams: Vec<PerChannel<Option<NormalStream>>> = (first..first + count as u64)
            .map(|r| {
                PerChannel::from_fn(|channel| {
                    noise
                        .is_on(channel)
                        .then(|| NormalStream::for_realisation(seed, key, channel.stream(), r))
                })
            })
            .collect();
        let mut buffers = vec![PerChannel([[0.0; BLOCK]; CHANNEL_COUNT]); count];
        // accs[i][k]: realisation first + i, condition conditions[k]
        let mut accs: Vec<Vec<MomentAccumulator>> = (0..count)
            .map(|_| {
                conditions
                    .iter()
                    .map(|&c| {
                        // No estimator reads the rows here (`one_draw_serves`).
                        MomentAccumulator::new(&self.conditions[c].regression, noise)
                            .grade_sums(self.grade_sums)
                            .keep_rows(false)
                    })
                    .collect()
            })
            .collect();
        let longest = lengths.iter().copied().max().unwrap_or(0);
        // AR(1) speed noise (one condition): each realisation's previous sample's noise.
        let ar1 = match conditions {
            [c] => self.conditions[*c].ar1.as_deref(),
            _ => None,
        };
        let mut previous = vec![0.0; count];
        let in_w = noise.speed_channel();
        for start in (0..longest).step_by(BLOCK) {
            // Shared: whole blocks, the sequence each condition reads a prefix of. Alone (one
            // condition, its own streams): the blocks `measure` requests.
            let drawn = match self.shared {
                true => BLOCK,
                false => BLOCK.min(longest - start),
            };
            for (streams, buffers) in streams.iter_mut().zip(&mut buffers) {
                for (stream, buffer) in streams.0.iter_mut().zip(&mut buffers.0) {
                    if let Some(s) = stream {
                        s.fill_block(&mut buffer[..drawn]);
                    }
                }
            }
            if let Some(ar1) = ar1 {
                // The filter `measure` applies, for the realisations side by side: their
                // recursions are independent, so the processor overlaps them.
                let rows = &ar1[start..(start + drawn).min(ar1.len())];
                filter_side_by_side(&mut buffers, |b| &mut b[in_w][..], &mut previous, rows);
            }
            for (k, &n) in lengths.iter().enumerate().filter(|(_, n)| **n > start) {
                let len = BLOCK.min(n - start);
                for (accs, buffers) in accs.iter_mut().zip(&buffers) {
                    let mut draws = BlockNoise::default();
                    for ((stream, buffer), draw) in
                        streams[0].0.iter().zip(&buffers.0).zip(&mut draws.0)
                    {
                        *draw = stream.as_ref().map(|_| &buffer[..len]);
                    }
                    accs[k].add_block(start, len, draws, None);
                }
            }
        }
        accs.into_iter()
            .map(|accs| accs.iter().map(MomentAccumulator::finish).collect())
            .collect()
    }

    /// Estimates, bounds and extras of condition `c` from its realisation's moments on the
    /// regression `reg` (and rows, when an estimator reads them) into `slots`.
    pub(super) fn conclude(
        &self,
        c: usize,
        reg: &Regression,
        truth: &[f64; 3],
        moments: &Moments,
        rows: Option<(&Rows, &RowScans)>,
        slots: &mut [f64],
    ) {
        let cond = &self.conditions[c];
        let k = reg.k;
        let noisy_xtx = moments.ols_system(k).0;
        let parameters = self.study.settings.parameters;
        let fisher_condition = parameters.condition_number(&noisy_xtx);
        let thesis_bound = thesis_bound(&noisy_xtx, &cond.noise, parameters);
        // Every bound's standard errors in this realisation: those computed per realisation
        // the same for every estimator, the constant ones those of the estimator's spread.
        let per_realisation: Vec<Option<[f64; 3]>> = BOUNDS
            .iter()
            .map(|bound| match bound.value {
                BoundValue::PerRealisation(se) if (bound.applies)(&cond.noise) => {
                    Some(se(&noisy_xtx, &cond.noise, parameters).unwrap_or([f64::NAN; 3]))
                }
                _ => None,
            })
            .collect();
        let layout = &self.layout;
        let verdict = self.verdict(c, reg, rows.map(|(rows, _)| rows));
        for (ei, est) in self.study.estimators.iter().enumerate() {
            let estimate = est.estimate(&Realisation {
                moments,
                rows: rows.map(|(rows, _)| rows),
                scans: rows.map(|(_, scans)| scans),
                regression: reg,
                noise: &cond.noise,
                settings: &cond.settings,
                truth,
            });
            let status = if estimate.theta.is_ok() {
                Status::Ok
            } else {
                Status::Singular
            };
            let theta = estimate.theta.unwrap_or_else(|_| Vector3::repeat(f64::NAN));
            slots[layout.status_at(ei)] = status as u8 as f64;
            // The layout's parameters are the fitted ones, in θ's order.
            for (p, &i) in parameters.free().iter().enumerate() {
                slots[layout.theta_at(ei, p)] = theta[i];
                for (b, own) in per_realisation.iter().enumerate() {
                    let values = own.unwrap_or(cond.constant_bounds[ei][b]);
                    slots[layout.bound_at(ei, b, p)] = if cond.info.applies[ei][b] {
                        values[i]
                    } else {
                        f64::NAN
                    };
                }
            }
            let inputs = ExtraInputs {
                theta: &theta,
                fisher_condition,
                thesis_bound: thesis_bound.as_ref(),
            };
            for (x, extra) in self.extras.iter().enumerate() {
                slots[layout.extra_at(ei, x)] = extra.value(&inputs, *est, &estimate, verdict);
            }
        }
        let centred = cond.expected.centre(moments);
        for (k, &j) in self.controls.iter().enumerate() {
            // Null where the control does not apply (its expectation is not this
            // realisation's: a condition whose realisations have their own regressions).
            slots[layout.control_at(k)] = match cond.info.controls[k] {
                true => centred[j],
                false => f64::NAN,
            };
        }
    }
}
