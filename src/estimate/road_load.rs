//! `road_load`: the coast-down analysis of SAE J2263 / J1263 (docs/model.md#road-load).
//!
//! Every measured row gives the road-load force the analyst infers from the weighed mass M,
//! the assumed rotating-mass factor δ̂ (`estimation.effective_mass_factor`) and the measured
//! grade:
//!
//! ```text
//! F_RL,i = F̃_i − M (1 + δ̂) ã_i − M g sin θ̃_i,    ã_i = ỹ_i − g sin θ̃_i
//!        = F̃_i − M ỹ_i − M δ̂ ã_i
//! ```
//!
//! (in a coast-down F̃ = 0), fitted by least squares over all rows as A + B·V + C·V² with V
//! the measured speed (√w of the row: the speed's magnitude). Then Cd/M = C/(k M) with
//! k = ½ ρ A_f, and Cr = A/(M g), for comparison with the other estimators; A \[N\],
//! B \[N·s/m\] and C \[N·s²/m²\] are the extra columns `road_load_a`, `_b`, `_c`.

use nalgebra::{Matrix3, Vector3};

use super::bounds::{Bound, BoundKind};
use super::estimator::{
    Estimate, EstimateColumn, Estimator, EstimatorSettings, FirstOrder, Realisation,
};
use super::parameters::Parameters;
use crate::numeric::linalg::solve_spd;

/// Its own columns: the fitted A, B, C (NaN where the fit failed).
static COLUMNS: [EstimateColumn; 3] = [
    EstimateColumn {
        name: "road_load_a",
        unit: "N",
        description: "road_load only: A of the fitted road-load force A + B·V + C·V²",
        in_every_study: false,
    },
    EstimateColumn {
        name: "road_load_b",
        unit: "N·s/m",
        description: "road_load only: B of the fitted road-load force A + B·V + C·V²",
        in_every_study: false,
    },
    EstimateColumn {
        name: "road_load_c",
        unit: "N·s²/m²",
        description: "road_load only: C of the fitted road-load force A + B·V + C·V²",
        in_every_study: false,
    },
];

/// The coast-down's road-load fit A + B·V + C·V².
#[derive(Debug, Clone, Copy)]
pub struct RoadLoad;

impl Estimator for RoadLoad {
    fn name(&self) -> &'static str {
        "road_load"
    }

    fn description(&self) -> &'static str {
        "the coast-down analysis (SAE J2263): the road-load force F − M(1 + δ̂)a − M g sin θ fitted as A + B·V + C·V² over all rows (known mass), reported as Cd/M = C/(kM) and Cr = A/(Mg)"
    }

    fn reads_rows(&self) -> bool {
        true
    }

    fn columns(&self) -> &'static [EstimateColumn] {
        &COLUMNS
    }

    fn needs_known_mass(&self) -> bool {
        true
    }

    fn reads_effective_mass_factor(&self) -> bool {
        true
    }

    /// Its estimate on the noise-free rows: what the model errors and the deterministic
    /// measurement effects (a hill's cos θ in its A) make it estimate; what the noise adds
    /// is not predicted.
    fn first_order_bias(&self, at: &FirstOrder<'_>) -> [f64; 3] {
        at.noise_free_bias
    }

    fn estimate(&self, r: &Realisation<'_>) -> Estimate {
        let Parameters::KnownMass { inv_mass } = r.settings.parameters else {
            unreachable!("road_load is validated to run with the mass known")
        };
        let rows = r.rows();
        let mass = 1.0 / inv_mass;
        let delta = r.settings.effective_mass_factor;
        let (mut a, mut b) = (Matrix3::zeros(), Vector3::zeros());
        let mut sums = [0.0; 8];
        for i in 0..rows.len() {
            let w = rows.w[i];
            let v = w.sqrt();
            let accel = rows.y[i] - rows.s[i];
            let force = rows.f[i] - mass * rows.y[i] - mass * delta * accel;
            for (s, x) in
                sums.iter_mut()
                    .zip([1.0, v, w, v * w, w * w, force, v * force, w * force])
            {
                *s += x;
            }
        }
        let [n, s_v, s_w, s_vw, s_ww, s_f, s_vf, s_wf] = sums;
        a.copy_from_slice(&[n, s_v, s_w, s_v, s_w, s_vw, s_w, s_vw, s_ww]);
        b.copy_from_slice(&[s_f, s_vf, s_wf]);
        let fit = solve_spd(&a, &b);
        let theta = fit.map(|abc| {
            Vector3::new(
                inv_mass,
                abc[2] / (r.regression.k * mass),
                abc[0] / (mass * r.regression.g),
            )
        });
        let abc = fit.map_or([f64::NAN; 3], |abc| [abc[0], abc[1], abc[2]]);
        Estimate::with_columns(theta, &abc)
    }

    fn reports(&self, bound: &Bound, _settings: &EstimatorSettings) -> bool {
        // The sandwich is OLS's spread on [x₂, x₃], not this fit's on [1, V, V²]. The
        // Cramér–Rao spreads of the two-parameter model are a reference: a bound where it is
        // unbiased (a flat road, output noise), not under speed noise, where it is biased
        // (docs/model.md#road-load).
        bound.kind != BoundKind::EivSandwich
    }
}
