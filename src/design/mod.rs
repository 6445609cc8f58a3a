//! `design`: the smallest drive duration or terrain scale (or the largest speed-noise level
//! or model error) at which a target on one parameter's relative RMSE, relative EmpSE or
//! relative bias holds for one estimator (see docs/model.md#design).
//!
//! The first-order predictions (the bound's SE and the first-order bias of
//! [`VehicleModel::first_order`](crate::model::vehicle::VehicleModel::first_order)) on a
//! grid of the key bracket the answer in milliseconds; Monte Carlo runs of the study at the
//! bracket's ends and by bisection then decide it. A value *holds* when the Monte Carlo
//! estimate of the measure is at most the target; the answer is the smallest value that
//! holds (the largest, for a noise level or a model error) within the search's resolution
//! of one that does not, with the measure's MCSE there. For a model error the answer is the
//! end of the run of values that hold from `--from` on (the largest headwind up to which the
//! target holds), not a value beyond a failing one where two biases happen to cancel.
//!
//! `search.rs` brackets and bisects the answer on typed variants of the study
//! ([`Study::varied`](crate::study::Study::varied)), `target.rs` reads the target,
//! `output.rs` writes `design.parquet`, `figures/design.svg` and `report.html`.

pub mod campaign;
pub(crate) mod output;
mod search;
mod target;

use std::path::PathBuf;

use thiserror::Error;

use crate::figures::FigureError;
use crate::output::OutputError;
use crate::run::RunError;
use crate::study::StudyError;

pub use output::answer_sentence;
pub use search::design;
pub use target::{DesignMeasure, DesignTarget};

/// A study key `design` can vary: a setting [`Study::varied`](crate::study::Study::varied)
/// gives one value.
pub use crate::study::VariedKey as DesignKey;

/// The output file of `design`.
pub const DESIGN_FILE: &str = "design.parquet";

/// The footer key holding the answer (empty when there is none in the range).
pub const ANSWER_KEY: &str = "chassis_mc.design.answer";

/// True when the answer for `key` is the largest value that holds (a noise level, a model
/// error's size), false when it is the smallest.
fn largest(key: DesignKey) -> bool {
    matches!(key, DesignKey::VelocitySd | DesignKey::Truth(_))
}

/// True when the answer for `key` is the end of the run of values that hold starting at
/// `--from`, the measure being the one without the error there and growing from it though
/// not necessarily monotonically (a model error: a bias may pass through zero and change
/// sign further out, where the errors cancel by chance); false when it is the value that
/// holds nearest the range's other end, the measure being monotone in the key.
fn from_the_good_end(key: DesignKey) -> bool {
    matches!(key, DesignKey::Truth(_))
}

/// What to search.
#[derive(Debug, Clone)]
pub struct DesignRequest {
    /// The key varied.
    pub key: DesignKey,
    /// The range searched.
    pub from: f64,
    /// The range searched.
    pub to: f64,
    /// The target.
    pub target: DesignTarget,
    /// The estimator (a name in the study's list; `None`: its first).
    pub estimator: Option<String>,
    /// Output directory.
    pub out: PathBuf,
}

/// One evaluated value of the key.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DesignPoint {
    /// The key's value.
    pub value: f64,
    /// The first-order prediction of the measure.
    pub predicted: f64,
    /// The Monte Carlo estimate and its MCSE, where one was run.
    pub simulated: Option<(f64, f64)>,
}

/// What `design` found.
#[derive(Debug, Clone)]
pub struct DesignResult {
    /// Every evaluated value, in increasing order.
    pub points: Vec<DesignPoint>,
    /// The answer (`None`: the target holds nowhere in the range).
    pub answer: Option<DesignPoint>,
    /// The nearest evaluated value on the other side of the answer, which does not hold
    /// (`None`: the answer is the end of the range).
    pub neighbour: Option<f64>,
    /// How far the answer could move with the Monte Carlo error of the measure there: its
    /// MCSE divided by the slope of the predicted measure against the key (`None` where
    /// that slope is not defined).
    pub answer_sd: Option<f64>,
    /// The estimator's name.
    pub estimator: String,
    /// Realisations per Monte Carlo evaluation.
    pub realisations: u64,
    /// Files written.
    pub files: Vec<PathBuf>,
}

/// Why `design` cannot search.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum DesignError {
    /// The study, or the study with the key set, is invalid.
    #[error(transparent)]
    Study(#[from] StudyError),
    /// A Monte Carlo evaluation failed.
    #[error(transparent)]
    Run(#[from] RunError),
    /// Writing the output failed.
    #[error(transparent)]
    Output(#[from] OutputError),
    /// Drawing the figure failed.
    #[error(transparent)]
    Figure(#[from] FigureError),
    /// The request does not fit the study.
    #[error("{0}")]
    Request(String),
}

impl DesignError {
    /// Whether the cause is the user's input (exit status 2 at the command line): an invalid
    /// study or request, or an output directory that cannot be used as it is
    /// ([`OutputError::is_bad_input`]). A Monte Carlo evaluation that fails is a failure
    /// while running (exit status 1), whatever its cause.
    pub fn is_bad_input(&self) -> bool {
        match self {
            DesignError::Study(_) | DesignError::Request(_) => true,
            DesignError::Output(e) => e.is_bad_input(),
            DesignError::Figure(e) => e.is_bad_input(),
            DesignError::Run(_) => false,
        }
    }
}
