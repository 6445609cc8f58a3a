//! Post-processing of an estimate: M̂ and Ĉd, and the thesis's conversions of its bound into
//! errors of M and Cd (see docs/model.md#post-processing); each a per-row extra column, one
//! entry of [`EXTRAS`].

use nalgebra::Vector3;

/// M̂ = 1/θ̂₁ \[kg\] and Ĉd = M̂ θ̂₂ \[-\] (thesis eqs. 38–39).
pub fn mass_and_drag(theta: &Vector3<f64>) -> (f64, f64) {
    let m = 1.0 / theta[0];
    (m, m * theta[1])
}

/// The thesis's error conversions of the 1/M and Cd/M bounds σ₁, σ₂ into errors of M \[kg\]
/// and Cd \[-\] (thesis eqs. 41–42):
///
/// ```text
/// σ_M  = 1 / (θ̂₁ − σ₁) − M̂                      (41)
/// σ_Cd = (θ̂₂ + σ₂) (θ̂₁ + σ₁)⁻¹ − Ĉd             (42)
/// ```
///
/// How the garbled equations were read: the extracted eq. 41 is a fraction `1 / (θ̂(1) −
/// σ_{1/M})` followed by `− M̂`, unambiguous. Eq. 42 prints as `(θ̂(2) + σ_{Cd/M})
/// (θ̂(1) + σ_{1/M}) − Ĉd` with the subscripts `M` of σ_{Cd/M} and σ_{1/M} on the line
/// below. Taken literally it multiplies two quantities in 1/kg and subtracts a
/// dimensionless Ĉd, so the exponent −1 on the second factor was lost in extraction:
/// Ĉd = θ̂₂/θ̂₁ (eq. 39), and the perturbed value (θ̂₂ + σ₂)/(θ̂₁ + σ₁) is dimensionless. The
/// signs are kept as printed (+σ₁ in eq. 42, −σ₁ in eq. 41), although they make the two
/// conversions lean in different directions. These are the thesis's heuristics, reported
/// for fidelity, not propagated standard errors (the delta method would give
/// σ_M ≈ σ₁/θ̂₁²).
pub fn thesis_error_conversions(theta: &Vector3<f64>, bound: &[f64; 3]) -> (f64, f64) {
    let (m, cd) = mass_and_drag(theta);
    let sigma_m = 1.0 / (theta[0] - bound[0]) - m;
    let sigma_cd = (theta[1] + bound[1]) / (theta[0] + bound[0]) - cd;
    (sigma_m, sigma_cd)
}

/// What a per-row derived quantity is computed from.
#[derive(Debug, Clone, Copy)]
pub struct ExtraInputs<'a> {
    /// The row's estimate θ̂ (NaN when the estimator failed).
    pub theta: &'a Vector3<f64>,
    /// 2-norm condition number of the realisation's noisy X̃ᵀX̃.
    pub fisher_condition: f64,
    /// The realisation's thesis bound, where it applies.
    pub thesis_bound: Option<&'a [f64; 3]>,
}

/// A derived quantity stored next to every estimate: one entry of [`EXTRAS`].
#[derive(Debug, Clone, Copy)]
pub struct Extra {
    /// Column name.
    pub name: &'static str,
    /// Unit.
    pub unit: &'static str,
    /// One-line description.
    pub description: &'static str,
    /// Its value for one row.
    pub value: fn(&ExtraInputs<'_>) -> f64,
}

/// Every per-row extra of the vehicle model that every estimate has, in column order (an
/// estimator's own columns follow: `Estimator::columns`).
pub static EXTRAS: [Extra; 5] = [
    Extra {
        name: "mass_hat",
        unit: "kg",
        description: "M̂ = 1/θ̂₁ (thesis eq. 38)",
        value: |x| mass_and_drag(x.theta).0,
    },
    Extra {
        name: "cd_hat",
        unit: "1",
        description: "Ĉd = M̂ θ̂₂ (thesis eq. 39)",
        value: |x| mass_and_drag(x.theta).1,
    },
    Extra {
        name: "fisher_condition",
        unit: "1",
        description: "2-norm condition number of the noisy X̃ᵀX̃ (the thesis's cond(FI))",
        value: |x| x.fisher_condition,
    },
    Extra {
        name: "mass_sd_thesis",
        unit: "kg",
        description: "σ_M = 1/(θ̂₁ − σ₁) − M̂ from the thesis bound (thesis eq. 41)",
        value: |x| {
            x.thesis_bound
                .map_or(f64::NAN, |b| thesis_error_conversions(x.theta, b).0)
        },
    },
    Extra {
        name: "cd_sd_thesis",
        unit: "1",
        description: "σ_Cd = (θ̂₂ + σ₂)/(θ̂₁ + σ₁) − Ĉd from the thesis bound (thesis eq. 42)",
        value: |x| {
            x.thesis_bound
                .map_or(f64::NAN, |b| thesis_error_conversions(x.theta, b).1)
        },
    },
];
