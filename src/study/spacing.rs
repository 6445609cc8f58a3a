//! The one rule on sample spacing (docs/model.md#sensors): a compensating estimator under a
//! differentiated acceleration with AR(1) speed noise needs evenly spaced samples. On
//! uneven ones the noise is more correlated with one neighbour than the other, E[ỹ Ṽ²]
//! gains a term the compensation does not remove, and the combination is an error. The
//! vehicle model checks it on a study's cycles, `fit` on its log.

use crate::estimate::estimators::EstimatorRef;

/// Relative tolerance on the steps between sample times: steps that differ from the first
/// by at most this much are even (timestamps written with a few decimals pass).
pub const EVEN_STEPS_TOLERANCE: f64 = 1e-6;

/// Whether the steps between the times `t` all equal the first to
/// [`EVEN_STEPS_TOLERANCE`] relative.
pub fn evenly_spaced(t: &[f64]) -> bool {
    let Some(first) = t.get(1).map(|t1| t1 - t[0]) else {
        return true;
    };
    t.windows(2)
        .all(|w| ((w[1] - w[0]) / first - 1.0).abs() <= EVEN_STEPS_TOLERANCE)
}

/// The compensating estimator of `estimators` that the rule refuses, if any: when the speed
/// noise is `correlated` and some span of `spans` is not evenly spaced.
///
/// `spans` are the sample times whose speed noise enters differentiated regressions, one
/// slice per regression, each checked on its own (a step between two spans is no step of
/// either). The two callers pass different spans, as they always have: the vehicle model
/// each differentiated regression's span (its used rows and their neighbours, all that the
/// noise touches, per scale and duration), `fit` its whole log (stricter: samples outside
/// the used span are checked too; the fit's bootstrap world, a one-condition model, then
/// checks the span again).
pub fn uneven_differentiation<'a>(
    correlated: bool,
    estimators: &[EstimatorRef],
    spans: impl IntoIterator<Item = &'a [f64]>,
) -> Option<EstimatorRef> {
    let compensating = estimators.iter().find(|e| e.needs_even_differentiation())?;
    (correlated && spans.into_iter().any(|t| !evenly_spaced(t))).then_some(*compensating)
}

/// Why [`uneven_differentiation`] refuses `estimator`: the acceleration is differentiated
/// (`how`, in the caller's terms) and the samples of `what` are uneven.
pub fn uneven_reason(estimator: EstimatorRef, how: &str, what: &str) -> String {
    format!(
        "a differentiated acceleration ({how}) with correlated speed noise \
         (noise.velocity_correlation_time) and the compensating estimator \"{}\" needs evenly \
         spaced samples, and {what}'s are not: no bias compensation is implemented for that \
         combination",
        estimator.name()
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn steps_within_the_tolerance_are_even() {
        assert!(evenly_spaced(&[0.0, 0.1, 0.2, 0.30000001]));
        assert!(!evenly_spaced(&[0.0, 0.1, 0.2, 0.31]));
        assert!(evenly_spaced(&[1.0]));
    }
}
