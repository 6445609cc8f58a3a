//! Which columns the pinned hashes leave out: results newer than the hashes, each with a
//! hash or a check of its own.

/// The control variates and the summary's control-variate measures: new results, not
/// something the older engine implied. The hashes of the old columns skip them; they have
/// their own pinned hash (`control_hash`).
pub(super) fn control_column(name: &str) -> bool {
    (name.starts_with("cv_")
        || name.ends_with("_cv")
        || name.ends_with("_cv_mcse")
        || name == "n_controls")
        && !spread_column(name)
}

/// The summary's control-variate measures of the spread (EmpSE, MSE, RMSE, EmpSE / bound
/// and the variance-ratio test by control variates): newer still, with their own pinned
/// hash (`spread_hash`).
pub(super) fn spread_column(name: &str) -> bool {
    let base = name.strip_suffix("_mcse").unwrap_or(name);
    matches!(base, "emp_se_cv" | "mse_cv" | "rmse_cv")
        || (base.starts_with("emp_over_") && base.ends_with("_cv"))
        || name.ends_with("_p_cv")
}

/// The summary's metrics of why a cycle identifies (VIFs, correlations, the condition
/// number): new results of the condition's noise-free rows, checked against independent
/// implementations in `tests/suite/identification.rs` and analysis/identification.py.
pub(super) fn identification_column(name: &str) -> bool {
    chassis_mc::model::vehicle::is_identification_metric(name)
}
