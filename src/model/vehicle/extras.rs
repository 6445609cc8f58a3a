//! The per-row extra columns of the vehicle model's tables: those every estimate has, and
//! the estimators' own, one column per name.

use crate::estimate::campaign::{CAMPAIGN_PASS, Verdict};
use crate::estimate::conversions::{EXTRAS, ExtraInputs};
use crate::estimate::estimators::{ESTIMATORS, Estimate, EstimateColumn, EstimatorRef};
use crate::model::ExtraInfo;
use crate::study::VehicleStudy;

/// A per-row extra column of the tables: one that every estimate has (an index into
/// [`EXTRAS`]) or estimators' own (an entry of their [`Estimator::columns`](crate::estimate::estimator::Estimator::columns),
/// one column for every estimator that has an entry of its name, NaN in the other
/// estimators' rows).
#[derive(Debug, Clone, Copy)]
pub(super) enum ExtraColumn {
    Every(usize),
    Own(&'static EstimateColumn),
    /// The campaign's verdict on the realisation's runs (docs/model.md#campaign), the same
    /// in every estimator's row.
    Campaign(CampaignColumn),
}

/// A column of a campaign's verdict.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum CampaignColumn {
    /// `campaign_pass`: 1 when the realisation's campaign passes, 0 when it fails.
    Pass,
    /// `campaign_precision`: the worst interval's statistical accuracy p.
    Precision,
}

impl ExtraColumn {
    /// Its entry in the layout.
    pub(super) fn info(self) -> ExtraInfo {
        match self {
            ExtraColumn::Every(j) => ExtraInfo::from(&EXTRAS[j]),
            ExtraColumn::Own(column) => ExtraInfo {
                name: column.name,
                unit: column.unit,
                description: column.description,
            },
            ExtraColumn::Campaign(CampaignColumn::Pass) => ExtraInfo {
                name: CAMPAIGN_PASS,
                unit: "",
                description: "1 when the realisation's campaign of runs passes the study's \
                              criterion, 0 when it fails (docs/model.md#campaign)",
            },
            ExtraColumn::Campaign(CampaignColumn::Precision) => ExtraInfo {
                name: "campaign_precision",
                unit: "",
                description: "the statistical accuracy p = t·s/(√n·T̄) of the campaign's worst \
                              speed interval, a fraction of its mean coast-down time (NaN for \
                              a criterion without one, or a run that misses an interval)",
            },
        }
    }

    /// Its value in the row of `estimator`, whose estimate is `estimate`, in a realisation
    /// whose campaign got `verdict`.
    pub(super) fn value(
        self,
        inputs: &ExtraInputs<'_>,
        estimator: EstimatorRef,
        estimate: &Estimate,
        verdict: Option<Verdict>,
    ) -> f64 {
        match self {
            ExtraColumn::Campaign(column) => verdict.map_or(f64::NAN, |v| match column {
                CampaignColumn::Pass => f64::from(u8::from(v.passes)),
                CampaignColumn::Precision => v.precision,
            }),
            ExtraColumn::Every(j) => (EXTRAS[j].value)(inputs),
            ExtraColumn::Own(column) => estimator
                .columns()
                .iter()
                .position(|c| c.name == column.name)
                .map_or(f64::NAN, |k| estimate.columns[k]),
        }
    }
}

/// The per-row extras the tables of `study` carry: those of every estimate, then each
/// registered estimator's own (in the order of [`ESTIMATORS`], a name once, where it first
/// appears) that are in every study or whose estimator the study lists.
pub(super) fn study_extras(study: &VehicleStudy) -> Vec<ExtraColumn> {
    let mut extras: Vec<ExtraColumn> = (0..EXTRAS.len()).map(ExtraColumn::Every).collect();
    for &e in ESTIMATORS.iter() {
        let e = EstimatorRef(e);
        let listed = study.estimators.contains(&e);
        for column in e.columns().iter().filter(|c| c.in_every_study || listed) {
            let known = extras
                .iter()
                .any(|x| matches!(x, ExtraColumn::Own(c) if c.name == column.name));
            if !known {
                extras.push(ExtraColumn::Own(column));
            }
        }
    }
    if study.campaign.is_some() {
        extras.extend([
            ExtraColumn::Campaign(CampaignColumn::Pass),
            ExtraColumn::Campaign(CampaignColumn::Precision),
        ]);
    }
    extras
}
