//! A coast-down campaign's verdict on each realisation (docs/model.md#campaign): the
//! criterion of `[campaign]` on the coast-down times read from the realisation's measured
//! speeds, the rows the estimators read.

use super::{ErrorAt, VehicleModel};
use crate::dynamics::Prefix;
use crate::estimate::campaign::Verdict;
use crate::estimate::moments::Rows;
use crate::estimate::regression::Regression;
use crate::study::{StudyError, VehicleStudy};

/// The number of runs of a condition that uses `prefix` of its cycle, whose regression is
/// `reg`: the prefix's runs, or every run of the rows.
pub(super) fn runs_of(prefix: Prefix, reg: &Regression) -> usize {
    match prefix {
        Prefix::Runs(k) => k,
        _ => reg.run.last().map_or(0, |&r| r as usize + 1),
    }
}

/// Check that every run of the noise-free rows `reg` (a condition of `runs` runs at scale
/// `scale`) crosses both edges of every interval of the study's campaign: an interval the
/// runs do not span is an error naming it.
pub(super) fn check_noise_free(
    vs: &VehicleStudy,
    reg: &Regression,
    runs: usize,
    scale: f64,
    error_at: &ErrorAt<'_>,
) -> Result<(), StudyError> {
    let Some(campaign) = &vs.campaign else {
        return Ok(());
    };
    if !campaign.criterion.reads_times() {
        return Ok(());
    }
    let times = crate::estimate::campaign::CoastTimes::measure(
        &reg.t,
        &reg.run,
        |k| reg.v[k],
        runs,
        &campaign.intervals,
    );
    for i in 0..runs {
        for (j, interval) in campaign.intervals.iter().enumerate() {
            if times.times[i * times.intervals + j].is_nan() {
                let speeds: Vec<f64> = (0..reg.len())
                    .filter(|&k| reg.run[k] as usize == i)
                    .map(|k| reg.v[k])
                    .collect();
                let (high, low) = (speeds.first().copied(), speeds.last().copied());
                return Err(error_at(
                    &format!("campaign.speeds[{j}]"),
                    format!(
                        "the interval {} ± {} m/s is not crossed by run {i} of the noise-free \
                         coast-down at scale {scale}, whose rows go from {} to {} m/s; a run \
                         must start above v + Δv and end below v − Δv (drive.speed_high, \
                         drive.speed_low and drive.min_speed select its rows)",
                        interval.speed_m_s,
                        interval.half_width_m_s,
                        high.map_or(f64::NAN, |v| v),
                        low.map_or(f64::NAN, |v| v),
                    ),
                ));
            }
        }
    }
    Ok(())
}

impl VehicleModel {
    /// The campaign's verdict on a realisation of condition `c` whose measured rows on `reg`
    /// are `rows` (`None`: the study has no campaign). The measured speed is √w, w = Ṽ² the
    /// rows' drag column (a coast-down's speeds stay far above the sensor's noise, so Ṽ > 0).
    pub(super) fn verdict(
        &self,
        c: usize,
        reg: &Regression,
        rows: Option<&Rows>,
    ) -> Option<Verdict> {
        let campaign = self.study.campaign.as_ref()?;
        let rows = rows.expect("a study with a campaign keeps the measured rows");
        let w = rows.view(reg).w;
        Some(campaign.judge(
            &reg.t,
            &reg.run,
            |k| w[k].sqrt(),
            self.conditions[c].campaign_runs,
        ))
    }
}
