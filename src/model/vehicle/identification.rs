//! Why a cycle identifies θ (docs/model.md#identification): the condition metrics of the
//! noise-free information J = XᵀX of its regression over the fitted parameters — J scaled
//! to unit diagonal (the regressors' uncentred correlations), each parameter's variance
//! inflation factor, and the scaled matrix's condition number.

use nalgebra::DMatrix;

use crate::estimate::parameters::Parameters;
use crate::estimate::regression::Regression;

/// The metrics' names with every parameter fitted: the VIFs in θ's order, the correlations
/// of the pairs (1/M, Cd/M), (1/M, Cr), (Cd/M, Cr), and the condition number.
const ALL: [&str; 7] = [
    "vif_inv_mass",
    "vif_drag_over_mass",
    "vif_rolling_resistance",
    "corr_inv_mass_drag_over_mass",
    "corr_inv_mass_rolling_resistance",
    "corr_drag_over_mass_rolling_resistance",
    "condition_number",
];

/// The same with the mass weighed (\[Cd/M, Cr\] fitted).
const KNOWN_MASS: [&str; 4] = [
    "vif_drag_over_mass",
    "vif_rolling_resistance",
    "corr_drag_over_mass_rolling_resistance",
    "condition_number",
];

/// Whether `name` is one of these metrics (of any study).
pub fn is_metric(name: &str) -> bool {
    ALL.contains(&name)
}

/// The names of the metrics of a study fitting `parameters`, in the order of [`metrics`].
pub(super) fn names(parameters: Parameters) -> &'static [&'static str] {
    match parameters {
        Parameters::All => &ALL,
        Parameters::KnownMass { .. } => &KNOWN_MASS,
    }
}

/// The metrics of `reg`'s noise-free J over the free parameters of `parameters`: with
/// S = D J D, D = diag(J_jj^(−1/2)) (S_ij = J_ij/√(J_ii J_jj)), each VIF_j = J_jj (J⁻¹)_jj = (S⁻¹)_jj (uncentred: the
/// model has no intercept), each correlation S_ij (i < j, row-major), and the condition
/// number λ_max(S)/λ_min(S). NaN where J is singular or not positive definite.
pub(super) fn metrics(reg: &Regression, parameters: Parameters) -> Vec<f64> {
    let free = parameters.free();
    let p = free.len();
    let j = DMatrix::from_fn(p, p, |a, b| reg.xtx[(free[a], free[b])]);
    let s = DMatrix::from_fn(p, p, |a, b| j[(a, b)] / (j[(a, a)] * j[(b, b)]).sqrt());
    let pairs = (0..p).flat_map(|a| (a + 1..p).map(move |b| (a, b)));
    let mut out = vec![f64::NAN; p];
    out.extend(pairs.map(|(a, b)| s[(a, b)]));
    let eigen = s.clone().symmetric_eigenvalues();
    let (low, high) = (eigen.min(), eigen.max());
    out.push(match low > 0.0 {
        true => high / low,
        false => f64::NAN,
    });
    if let Some(inverse) = s.cholesky().map(|c| c.inverse()) {
        for a in 0..p {
            out[a] = inverse[(a, a)];
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dynamics::{DriveCycle, VehicleParams};

    /// A regression of rows whose columns are exactly orthogonal after scaling, and one
    /// with two proportional columns.
    #[test]
    fn orthogonal_columns_have_unit_vifs_and_proportional_ones_none() {
        let vehicle = VehicleParams {
            mass_kg: 1.0,
            drag_coefficient: 0.0,
            rolling_resistance: 0.0,
            frontal_area_m2: 2.0,
            air_density_kg_m3: 1.0,
            gravity_m_s2: 1.0,
            drivetrain: None,
        };
        // k = 1, g = 1: columns F, −V², −cos θ. With V = 1 and θ = 0 the last two are −1:
        // F = ±1 alternating is orthogonal to both, which are proportional.
        let n = 8;
        let cycle = DriveCycle {
            t_s: (0..n).map(|i| i as f64).collect(),
            x_m: (0..n).map(|i| i as f64).collect(),
            v_m_s: vec![1.0; n],
            grade_rad: vec![0.0; n],
            f_prop_n: (0..n)
                .map(|i| if i % 2 == 0 { 1.0 } else { -1.0 })
                .collect(),
            accel_m_s2: vec![0.0; n],
            run: vec![0; n],
            run_heading: vec![1.0],
        };
        let reg = Regression::new(&cycle, &vehicle);
        let all = metrics(&reg, Parameters::All);
        assert_eq!(all.len(), ALL.len());
        // Singular: no VIF, and no finite condition number (λ_min is 0 to rounding).
        assert!(
            all[0..3].iter().all(|v| v.is_nan() || *v >= 1e12),
            "{all:?}"
        );
        assert_eq!(all[3], 0.0);
        assert_eq!(all[5], 1.0);
        assert!(all[6].is_nan() || all[6] >= 1e12, "singular: {all:?}");
        // Without the mass the two proportional columns remain: still singular; with V
        // varying they are not.
        let mut varied = cycle.clone();
        varied.v_m_s = (0..n).map(|i| 1.0 + 0.5 * (i / 2) as f64).collect();
        let reg = Regression::new(&varied, &vehicle);
        let two = metrics(&reg, Parameters::KnownMass { inv_mass: 1.0 });
        assert_eq!(two.len(), KNOWN_MASS.len());
        // Two columns with correlation ρ: VIF 1/(1 − ρ²), condition number (1 + ρ)/(1 − ρ).
        let rho = two[2];
        assert!((two[0] * (1.0 - rho * rho) - 1.0).abs() < 1e-12);
        assert!((two[1] - two[0]).abs() < 1e-12 * two[0]);
        assert!((two[3] * (1.0 - rho) / (1.0 + rho) - 1.0).abs() < 1e-12);
    }
}
