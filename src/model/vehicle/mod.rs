//! The thesis's vehicle study as a [`Model`]: one drive cycle per terrain scale; noise on
//! the measured speed, output, grade and force; OLS and BCLS on the same draw of each
//! realisation (common random numbers); and every bound that applies.

use std::cell::RefCell;
use std::sync::Arc;

use nalgebra::Vector3;
use rayon::prelude::*;

use arrow::array::RecordBatch;
use arrow::error::ArrowError;

mod axes;
mod cycles_table;
mod prepare;
mod replayed;

pub use axes::{Point, VehicleAxis, axes, grid};
pub use cycles_table::{cycles_batch, cycles_schema};

use super::{
    BoundInfo, ConditionInfo, ExtraInfo, ExtraTable, FigureX, Layout, Model, ParameterInfo, Status,
    realise_one_by_one,
};
use crate::estimate::bounds::{BOUNDS, BoundValue, thesis_bound};
use crate::estimate::channels::{BlockNoise, CHANNEL_COUNT, Channel, NoiseLevels, PerChannel};
use crate::estimate::controls::{CONTROLS, Expectations, varies};
use crate::estimate::conversions::{EXTRAS, ExtraInputs};
use crate::estimate::estimators::Realisation;
use crate::estimate::moments::{MomentAccumulator, Moments, Rows};
use crate::estimate::regression::Regression;
use crate::noise::{BLOCK, NormalSequence, NormalStream};
use crate::numeric::linalg::condition_number;
use crate::study::{Study, StudyError, VehicleStudy};
use crate::vehicle::DriveCycle;
use prepare::{ScaleCycle, duration_count, scale_cycles, segments, used_samples};

/// Parameter names of θ = [1/M, Cd/M, Cr] as used in every output column.
pub const PARAMETERS: [&str; 3] = ["inv_mass", "drag_over_mass", "rolling_resistance"];

/// One prepared condition: its noise and the regression of its rows.
#[derive(Debug)]
struct Condition {
    info: ConditionInfo,
    scale_index: usize,
    noise: NoiseLevels,
    regression: Arc<Regression>,
    /// AR(1) coefficients of correlated speed noise (`None` when white).
    ar1: Option<Vec<[f64; 2]>>,
    /// Per entry of [`BOUNDS`]: its standard errors where they are constant over the
    /// realisations and the bound applies (NaN otherwise).
    constant_bounds: Vec<[f64; 3]>,
    /// Its draw group ([`Model::draw_group`]): its own index unless the draws are shared.
    group: usize,
    /// The expected moments: what the control variates are centred on.
    expected: Expectations,
}

/// An error about key `key` (dotted) of the study a model is prepared from, for `reason`.
type ErrorAt<'a> = dyn Fn(&str, String) -> StudyError + Sync + 'a;

/// The bit that marks a draw group's key, so that a shared stream is never some condition's
/// own.
const SHARED_GROUP: u64 = 1 << 63;

/// The vehicle model with all its conditions prepared (drive cycles simulated).
#[derive(Debug)]
pub struct VehicleModel {
    study: VehicleStudy,
    layout: Layout,
    conditions: Vec<Condition>,
    /// One cycle per terrain scale (kept for cycles.parquet and figures).
    cycles: Vec<ScaleCycle>,
    /// Whether an estimator of the study reads the measured rows.
    needs_rows: bool,
    /// The sums whose control variates the layout carries (indices into [`CONTROLS`]).
    controls: Vec<usize>,
    /// `noise.share_across_scales`: conditions differing only in scale and duration read
    /// the same draws, as prefixes of one normal sequence per channel.
    shared: bool,
    /// The true θ.
    truth: [f64; 3],
}

impl VehicleModel {
    /// Prepare every condition of `study`: one drive cycle per terrain scale, the regression
    /// of each (scale, duration). A scale at which the vehicle stalls or runs off the
    /// terrain is an error naming that scale.
    pub fn new(study: &Study) -> Result<Self, StudyError> {
        let vs = study
            .vehicle()
            .ok_or_else(|| study.error_at("model", "is not a vehicle study"))?
            .clone();
        Self::prepare(vs, &|key: &str, reason: String| study.error_at(key, reason))
    }

    /// Prepare every condition of the validated `vs`; `error_at` names a key of the study
    /// it came from in an error.
    fn prepare(vs: VehicleStudy, error_at: &ErrorAt<'_>) -> Result<Self, StudyError> {
        let truth = vs.vehicle.theta();
        let cycles = scale_cycles(&vs, error_at)?;
        let segments = segments(&vs, &cycles, error_at)?;
        let durations = duration_count(&vs);
        let layout = layout(&vs);
        if let Some(e) = vs.estimators.iter().find(|e| e.compensates_speed_noise()) {
            uneven_differentiation(&vs, &segments, e.name(), error_at)?;
        }
        let points = grid(&vs);
        let controls = study_controls(&vs);
        // Scale and duration are the outermost axes: the conditions of one draw group are
        // `inner` apart.
        let inner = points.len() / (vs.scales.len() * durations);
        let conditions: Vec<Condition> = points
            .par_iter()
            .enumerate()
            .map(|(c, point)| {
                let group = if vs.share_across_scales { c % inner } else { c };
                let noise = point.noise;
                let k = point.scale_index * durations + point.duration_index;
                let segment = &segments[k];
                let source = vs
                    .acceleration
                    .iter()
                    .position(|&a| a == noise.acceleration)
                    .expect("the grid takes the source from the study's list");
                let regression = segment.regressions[source][point.grade_bias_index].clone();
                let constant_bounds = BOUNDS
                    .iter()
                    .map(|bound| {
                        match bound.value {
                            BoundValue::Constant(se) if (bound.applies)(&noise) => {
                                se(&regression, &truth, &noise)
                            }
                            _ => None,
                        }
                        .unwrap_or([f64::NAN; 3])
                    })
                    .collect();
                let applies = vs
                    .estimators
                    .iter()
                    .map(|e| {
                        BOUNDS
                            .iter()
                            .map(|b| (b.applies)(&noise) && e.reports(b, &vs.settings))
                            .collect()
                    })
                    .collect();
                let ar1 = noise
                    .velocity_correlated()
                    .then(|| regression.ar1_coefficients(noise.velocity_correlation_s));
                let expected = Expectations::new(&regression, &noise, ar1.as_deref());
                Condition {
                    info: ConditionInfo {
                        axes: axes()
                            .map(|a| a.value(&vs, point, segment.duration_s))
                            .collect(),
                        metrics: segment.metrics.clone(),
                        truth: truth.to_vec(),
                        applies,
                        controls: controls.iter().map(|&j| expected.applies()[j]).collect(),
                    },
                    scale_index: point.scale_index,
                    noise,
                    ar1,
                    regression,
                    constant_bounds,
                    group,
                    expected,
                }
            })
            .collect();
        // Members of a draw group read one set of draws: they must agree on everything but
        // the cycle (the group's first member is condition `group`).
        assert!(
            conditions
                .iter()
                .all(|c: &Condition| conditions[c.group].noise == c.noise),
            "a draw group mixes noise levels: the scale and duration axes must be outermost"
        );
        Ok(VehicleModel {
            layout,
            conditions,
            cycles,
            needs_rows: vs.estimators.iter().any(|e| e.needs_rows()),
            controls,
            shared: vs.share_across_scales,
            truth,
            study: vs,
        })
    }

    /// Every condition's drive cycle (conditions with the same terrain scale share one).
    pub fn cycles(&self) -> Vec<Arc<DriveCycle>> {
        self.conditions
            .iter()
            .map(|c| self.cycles[c.scale_index].cycle.clone())
            .collect()
    }

    /// The first-order prediction of estimator `e`'s (index in the study's list) bias and
    /// standard error in condition `c`, per parameter: the bias of the ratio of expectations
    /// (the normal equations' expected sums under the condition's speed noise, solved;
    /// zero for an estimator that compensates the noise, every channel's; other channels'
    /// biases of OLS are not predicted), and the SE of the first bound the estimator reports among `crlb_output`,
    /// `eiv_sandwich` and `eiv_crlb_linearized` (NaN where none applies).
    pub fn first_order(&self, c: usize, e: usize) -> ([f64; 3], [f64; 3]) {
        let cond = &self.conditions[c];
        let est = &self.study.estimators[e];
        let se = ["crlb_output", "eiv_sandwich", "eiv_crlb_linearized"]
            .iter()
            .filter_map(|name| BOUNDS.iter().position(|b| b.name == *name))
            .find(|&b| cond.info.applies[e][b] && cond.constant_bounds[b][0].is_finite())
            .map_or([f64::NAN; 3], |b| cond.constant_bounds[b]);
        if est.compensates_speed_noise() {
            return ([0.0; 3], se);
        }
        let reg = &*cond.regression;
        let s2 = cond.noise[Channel::Velocity].powi(2);
        let m = reg.noise_free_moments();
        // E[Ṽ²] = V² + σ², E[Ṽ⁴] = V⁴ + 6σ²V² + 3σ⁴ (docs/model.md#bcls, read backwards).
        let expected = Moments {
            s_1w: m.s_1w + s2 * m.s_1,
            s_3w: m.s_3w + s2 * m.s_3,
            s_ww: m.s_ww + 6.0 * s2 * m.s_w + 3.0 * s2 * s2 * m.n,
            s_wy: m.s_wy + s2 * m.s_y,
            s_w: m.s_w + s2 * m.n,
            ..m
        };
        let bias = match crate::estimate::estimators::solve(&expected.ols_system(reg.k)) {
            Ok(theta) => [0, 1, 2].map(|p| theta[p] - self.truth[p]),
            Err(_) => [f64::NAN; 3],
        };
        (bias, se)
    }

    /// The number condition `c`'s random streams are keyed by: its index, or, with
    /// `noise.share_across_scales`, its draw group's, marked (docs/model.md#shared-noise).
    fn stream_key(&self, c: usize) -> u64 {
        let group = self.conditions[c].group as u64;
        if self.shared {
            SHARED_GROUP | group
        } else {
            group
        }
    }

    /// The standard normal draws of `channel` in realisation `r` of condition `c`, in the
    /// blocks the kernel reads them (its keys, shared or not): `out.len()` values.
    pub fn standard_draws(&self, seed: u64, c: usize, channel: Channel, r: u64, out: &mut [f64]) {
        let key = self.stream_key(c);
        let mut draws = Draws::new(self.shared, seed, key, channel, r);
        for chunk in out.chunks_mut(BLOCK) {
            draws.fill(chunk);
        }
    }

    /// The noise levels of condition `c`.
    pub fn noise_levels(&self, c: usize) -> NoiseLevels {
        self.conditions[c].noise
    }

    /// The validated study settings.
    pub fn study(&self) -> &VehicleStudy {
        &self.study
    }

    /// The moments of realisation `r` of condition `c`: the kernel. Draws each active
    /// channel's normals block by block and accumulates the normal-equation sums.
    pub fn moments(&self, seed: u64, c: usize, r: u64) -> Moments {
        self.measure(seed, c, r, None)
    }

    /// The moments of realisation `r` of condition `c`, and, into `rows` when given, its
    /// measured rows (from the same draws).
    pub fn measure(&self, seed: u64, c: usize, r: u64, mut rows: Option<&mut Rows>) -> Moments {
        let cond = &self.conditions[c];
        let reg = &*cond.regression;
        let noise = cond.noise;
        let mut streams = PerChannel::from_fn(|channel| {
            noise
                .is_on(channel)
                .then(|| Draws::new(self.shared, seed, self.stream_key(c), channel, r))
        });
        let mut buffers = PerChannel([[0.0; BLOCK]; CHANNEL_COUNT]);
        let mut acc = MomentAccumulator::new(reg, noise);
        let n = reg.len();
        // A differentiated acceleration: the speed noise of every logged sample of the span
        // (AR(1)-filtered where correlated), drawn before the rows that read it.
        let span_noise = match (&reg.differentiation, &mut streams[Channel::Velocity]) {
            (Some(d), Some(stream)) if noise.speed_noise_differentiated() => {
                let mut e = vec![0.0; d.span_t.len()];
                stream.fill(&mut e);
                if let Some(ar1) = &cond.ar1 {
                    let mut previous = 0.0;
                    for (z, [phi, scale]) in e.iter_mut().zip(ar1) {
                        *z = phi * previous + scale * *z;
                        previous = *z;
                    }
                }
                Some((d, e))
            }
            _ => None,
        };
        let mut derivative = [0.0; BLOCK];
        // The previous sample's correlated speed noise (AR(1) on the rows only).
        let mut previous = 0.0;
        for start in (0..n).step_by(BLOCK) {
            let len = BLOCK.min(n - start);
            if let Some((d, e)) = &span_noise {
                // Each row's own sample's noise, and σ_v (e_{s+1} − e_{s−1}) / Δt in ỹ.
                let sd = noise[Channel::Velocity];
                let buffer = &mut buffers[Channel::Velocity][..len];
                for (j, i) in (start..start + len).enumerate() {
                    let s = d.sample[i];
                    buffer[j] = e[s];
                    derivative[j] = sd * (e[s + 1] - e[s - 1]) * d.inv_dt[i];
                }
            } else if let (Some(ar1), Some(stream)) = (&cond.ar1, &mut streams[Channel::Velocity]) {
                let buffer = &mut buffers[Channel::Velocity][..len];
                stream.fill(buffer);
                for (z, [phi, scale]) in buffer.iter_mut().zip(&ar1[start..start + len]) {
                    *z = phi * previous + scale * *z;
                    previous = *z;
                }
            }
            // The speed noise is drawn above when it is correlated or differentiated.
            let speed_drawn = cond.ar1.is_some() || span_noise.is_some();
            let mut draws = BlockNoise::default();
            for (channel, ((stream, buffer), draw)) in Channel::ALL
                .into_iter()
                .zip(streams.0.iter_mut().zip(&mut buffers.0).zip(&mut draws.0))
            {
                *draw = stream.as_mut().map(|s| {
                    if !(channel == Channel::Velocity && speed_drawn) {
                        s.fill(&mut buffer[..len]);
                    }
                    &buffer[..len]
                });
            }
            let derivative = span_noise.as_ref().map(|_| &derivative[..len]);
            if let Some(rows) = rows.as_deref_mut() {
                rows.push_block(reg, &noise, start, len, draws, derivative);
            }
            acc.add_block(start, len, draws, derivative);
        }
        acc.finish()
    }
}

/// One channel's normals in a realisation: read straight from its stream in the blocks the
/// kernel asks for, or, shared between conditions, as a [`NormalSequence`] whose values do
/// not depend on the lengths read.
#[allow(clippy::large_enum_variant)] // on the stack for one realisation; a box would allocate
enum Draws {
    Blocks(NormalStream),
    Sequence(NormalSequence),
}

impl Draws {
    fn new(shared: bool, seed: u64, key: u64, channel: Channel, r: u64) -> Self {
        match shared {
            false => Draws::Blocks(NormalStream::for_realisation(
                seed,
                key,
                channel.stream(),
                r,
            )),
            true => Draws::Sequence(NormalSequence::for_realisation(
                seed,
                key,
                channel.stream(),
                r,
            )),
        }
    }

    fn fill(&mut self, out: &mut [f64]) {
        match self {
            Draws::Blocks(s) => s.fill(out),
            Draws::Sequence(s) => s.fill(out),
        }
    }
}

/// A compensating estimator (`name`) under a differentiated acceleration with AR(1) speed
/// noise needs evenly spaced samples: on uneven ones the noise is more correlated with one
/// neighbour than the other, E[ỹ Ṽ²] gains a term the compensation does not remove, and
/// the combination is an error naming it.
fn uneven_differentiation(
    vs: &VehicleStudy,
    segments: &[prepare::Segment],
    name: &str,
    error_at: &ErrorAt<'_>,
) -> Result<(), StudyError> {
    let correlated = vs.velocity_correlation_s.iter().any(|&t| t > 0.0)
        && vs.noise.levels(Channel::Velocity).iter().any(|&s| s > 0.0);
    let uneven = segments
        .iter()
        .flat_map(|s| s.regressions.iter().flatten())
        .any(|r| r.differentiation.as_ref().is_some_and(|d| !d.uniform_steps));
    if correlated && uneven {
        return Err(error_at(
            "estimation.acceleration",
            format!(
                "\"differentiated\" with correlated speed noise (noise.velocity_correlation_time) \
                 and the estimator \"{name}\" needs evenly spaced samples, and this cycle's are not: \
                 no bias compensation is implemented for that combination"
            ),
        ));
    }
    Ok(())
}

/// The sums (indices into [`CONTROLS`]) that are control variates in some condition of
/// `study`: the columns its realisation table carries.
fn study_controls(study: &VehicleStudy) -> Vec<usize> {
    let points = grid(study);
    (0..CONTROLS.len())
        .filter(|&j| points.iter().any(|p| varies(&p.noise)[j]))
        .collect()
}

/// The row layout of the vehicle model running `estimators`.
pub fn layout(study: &VehicleStudy) -> Layout {
    let terrain = match &study.terrain {
        Some(t) => format!(
            "{}, {} km",
            t.profile.describe(),
            t.length_m as f64 / 1000.0
        ),
        None => "the trace's grade".to_string(),
    };
    let estimators = &study.estimators;
    Layout {
        context: vec![format!(
            "route: {terrain}; drive: {}",
            study.drive.describe()
        )],
        axes: axes().map(VehicleAxis::column).collect(),
        condition_metrics: vec!["terrain_ms_grid", "terrain_ms_cycle"],
        figure_x: Some(FigureX {
            metric: "terrain_ms_grid",
            label: "terrain variability ς = mean θ² over the terrain table [rad²]",
            replaces: "scale",
        }),
        parameters: vec![
            ParameterInfo {
                name: PARAMETERS[0],
                unit: "1/kg",
                description: "1/M, inverse vehicle mass",
            },
            ParameterInfo {
                name: PARAMETERS[1],
                unit: "1/kg",
                description: "Cd/M, drag coefficient over mass",
            },
            ParameterInfo {
                name: PARAMETERS[2],
                unit: "1",
                description: "Cr, rolling-resistance coefficient",
            },
        ],
        estimators: estimators.iter().map(|e| e.name()).collect(),
        extras: EXTRAS.iter().map(ExtraInfo::from).collect(),
        bounds: BOUNDS
            .iter()
            .map(|b| BoundInfo {
                name: b.name,
                description: b.description,
                // The thesis's bound divides by σ_v² in (m/s)² an information matrix of
                // the noisy regressors: never a bound (README "What the numbers mean").
                valid: b.name != "thesis_bound",
            })
            .collect(),
        controls: study_controls(study)
            .into_iter()
            .map(|j| ExtraInfo::from(&CONTROLS[j]))
            .collect(),
    }
}

impl Model for VehicleModel {
    fn layout(&self) -> &Layout {
        &self.layout
    }

    fn extra_tables(&self) -> Vec<ExtraTable> {
        vec![ExtraTable {
            file: "cycles.parquet",
            table: "cycles",
            schema: cycles_schema(),
        }]
    }

    /// cycles.parquet: block `index` is the cycle of scale `index / sources` with
    /// acceleration source `index % sources` (study order), whatever the other axes.
    fn extra_batch(&self, table: usize, index: usize) -> Option<Result<RecordBatch, ArrowError>> {
        let sources = &self.study.acceleration;
        let scale = self
            .cycles
            .get(index / sources.len())
            .filter(|_| table == 0)?;
        let source = sources[index % sources.len()];
        let used = used_samples(&scale.cycle, &self.study, None, source);
        Some(cycles_batch(
            self.study.scales[index / sources.len()],
            source.name(),
            &scale.cycle,
            &used,
        ))
    }

    fn condition_count(&self) -> usize {
        self.conditions.len()
    }

    fn condition_info(&self, c: usize) -> &ConditionInfo {
        &self.conditions[c].info
    }

    fn realise(&self, seed: u64, c: usize, r: u64, slots: &mut [f64]) {
        thread_local! {
            /// The measured rows of this thread's current realisation (memory reused).
            static ROWS: RefCell<Rows> = RefCell::default();
        }
        ROWS.with_borrow_mut(|rows| self.realise_with(seed, c, r, rows, slots));
    }

    fn draw_group(&self, c: usize) -> usize {
        self.conditions[c].group
    }

    fn realise_group(
        &self,
        seed: u64,
        conditions: &[usize],
        first: u64,
        count: usize,
        slots: &mut [f64],
    ) {
        if !self.one_draw_serves(conditions) {
            return realise_one_by_one(self, seed, conditions, first, count, slots);
        }
        let mut slots = slots.chunks_exact_mut(self.layout.realisation_stride());
        for moments in self.measure_group(seed, conditions, first, count) {
            for (&c, (moments, slots)) in conditions.iter().zip(moments.iter().zip(&mut slots)) {
                self.conclude(c, moments, None, slots);
            }
        }
    }
}

impl VehicleModel {
    /// [`Model::realise`] with a thread's row buffer.
    fn realise_with(&self, seed: u64, c: usize, r: u64, rows: &mut Rows, slots: &mut [f64]) {
        let cond = &self.conditions[c];
        let rows = self.needs_rows.then(|| {
            rows.reset(&cond.regression, &cond.noise);
            rows
        });
        match rows {
            Some(rows) => {
                let moments = self.measure(seed, c, r, Some(&mut *rows));
                self.conclude(c, &moments, Some(rows), slots);
            }
            None => self.conclude(c, &self.measure(seed, c, r, None), None, slots),
        }
    }

    /// Whether [`VehicleModel::measure_group`] computes `conditions` (one draw group, or one
    /// condition's consecutive realisations): white noise, an acceleration not
    /// differentiated from the noisy speed, and no estimator that reads the rows. Otherwise
    /// each realisation of each condition is computed on its own (from the same draws).
    fn one_draw_serves(&self, conditions: &[usize]) -> bool {
        (self.shared || conditions.len() == 1)
            && !self.needs_rows
            && conditions.iter().all(|&c| {
                let cond = &self.conditions[c];
                cond.ar1.is_none()
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
    fn measure_group(
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
                    .map(|&c| MomentAccumulator::new(&self.conditions[c].regression, noise))
                    .collect()
            })
            .collect();
        let longest = lengths.iter().copied().max().unwrap_or(0);
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

    /// Estimates, bounds and extras of condition `c` from its realisation's moments (and
    /// rows, when an estimator reads them) into `slots`.
    fn conclude(&self, c: usize, moments: &Moments, rows: Option<&Rows>, slots: &mut [f64]) {
        let cond = &self.conditions[c];
        let k = cond.regression.k;
        let noisy_xtx = moments.ols_system(k).0;
        let fisher_condition = condition_number(&noisy_xtx);
        let thesis_bound = thesis_bound(&noisy_xtx, &cond.noise);
        // Every bound's standard errors in this realisation (the same for every estimator).
        let bounds: Vec<[f64; 3]> = BOUNDS
            .iter()
            .zip(&cond.constant_bounds)
            .map(|(bound, constant)| match bound.value {
                BoundValue::PerRealisation(se) if (bound.applies)(&cond.noise) => {
                    se(&noisy_xtx, &cond.noise).unwrap_or([f64::NAN; 3])
                }
                _ => *constant,
            })
            .collect();
        let layout = &self.layout;
        for (ei, est) in self.study.estimators.iter().enumerate() {
            let estimate = est.estimate(&Realisation {
                moments,
                rows,
                regression: &cond.regression,
                noise: &cond.noise,
                settings: &self.study.settings,
                truth: &self.truth,
            });
            let status = if estimate.theta.is_ok() {
                Status::Ok
            } else {
                Status::Singular
            };
            let theta = estimate.theta.unwrap_or_else(|_| Vector3::repeat(f64::NAN));
            slots[layout.status_at(ei)] = status as u8 as f64;
            for p in 0..3 {
                slots[layout.theta_at(ei, p)] = theta[p];
                for (b, values) in bounds.iter().enumerate() {
                    slots[layout.bound_at(ei, b, p)] = if cond.info.applies[ei][b] {
                        values[p]
                    } else {
                        f64::NAN
                    };
                }
            }
            let inputs = ExtraInputs {
                theta: &theta,
                fisher_condition,
                thesis_bound: thesis_bound.as_ref(),
                settle_time_s: estimate.settle_time_s,
            };
            for (x, extra) in EXTRAS.iter().enumerate() {
                slots[layout.extra_at(ei, x)] = (extra.value)(&inputs);
            }
        }
        let centred = cond.expected.centre(moments);
        for (k, &j) in self.controls.iter().enumerate() {
            slots[layout.control_at(k)] = centred[j];
        }
    }
}
