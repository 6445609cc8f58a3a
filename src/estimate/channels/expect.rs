//! The expectations of the measured columns at a noise-free row, which the control variates
//! centre the sums with (docs/model.md#control-variates): noise-free here, then moved by
//! each channel's [`ChannelTerms::expect`](super::ChannelTerms::expect).

/// A noise-free row as the expectations of its measured columns read it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrueRow {
    /// Propulsion force F \[N\].
    pub f: f64,
    /// Speed V \[m/s\].
    pub v: f64,
    /// The acceleration in the output \[m/s²\] (without the grade term).
    pub accel: f64,
    /// sin of the grade.
    pub sin_grade: f64,
    /// cos of the grade.
    pub cos_grade: f64,
    /// Gravity g \[m/s²\].
    pub g: f64,
    /// 1/Δt of the central difference a differentiated acceleration takes \[1/s\] (0 when
    /// the acceleration is the model's).
    pub inv_dt: f64,
}

/// The expectations at one row of the measured columns and of the products of two
/// columns that the same channel moves (docs/model.md#control-variates): noise-free from
/// [`ColumnMoments::noise_free`], then moved by each channel that is on
/// ([`Channel::expect`](super::Channel::expect)).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ColumnMoments {
    /// E\[x̃₁\], E\[w\], E\[x̃₃\], E\[ỹ\], indexed by [`Column`](crate::estimate::sums::Column).
    pub mean: [f64; 4],
    /// E\[x̃₁²\].
    pub ff: f64,
    /// E\[w²\].
    pub ww: f64,
    /// E\[x̃₃²\].
    pub cc: f64,
    /// E\[x̃₃ỹ\] (both carry the grade noise).
    pub cy: f64,
    /// Cov(w, ỹ), through a differentiated acceleration with correlated speed noise (0
    /// otherwise; set by [`Channel::expect_shared`](super::Channel::expect_shared)).
    pub wy_neighbours: f64,
}

impl ColumnMoments {
    /// The values of a row without noise (w = V², x̃₃ = −g cos θ, ỹ = a + g sin θ).
    pub fn noise_free(r: &TrueRow) -> Self {
        let (g, a, sin, cos) = (r.g, r.accel, r.sin_grade, r.cos_grade);
        let v2 = r.v * r.v;
        ColumnMoments {
            mean: [r.f, v2, -g * cos, a + g * sin],
            ff: r.f * r.f,
            ww: v2 * v2,
            cc: g * g * (cos * cos),
            cy: -g * a * cos - g * g * (sin * cos),
            wy_neighbours: 0.0,
        }
    }
}
