//! Grade noise: white noise σ_θ on the measured grade signal, entering the regressor
//! x̃₃ = −g cos θ̃ and the output's grade term g sin θ̃ (docs/model.md#noise-channels).

use super::{
    Channel, ChannelTerms, ColumnMoments, GradeLoading, NoiseLevels, OmegaAt, Part, Powers, Sample,
    Signal, TrueRow,
};
use crate::estimate::sums::Column;
use crate::estimate::sums::{GradeSums, Moments};
use crate::numeric::simd::Lanes;
use crate::numeric::trig::turn;

/// The grade-noise channel.
#[derive(Debug, Clone, Copy)]
pub struct GradeNoise;

impl ChannelTerms for GradeNoise {
    const KEY: &'static str = "grade_sd";
    const UNIT: &'static str = "rad";
    const DESCRIPTION: &'static str = "grade-measurement noise σ_θ";
    const DEFAULT_LEVELS: Option<&'static [f64]> = Some(&[0.0]);
    const STREAM: crate::noise::Stream = crate::noise::Stream::Channel(3);
    const IN_REGRESSORS: bool = true;
    const COLUMNS: &'static [Column] = &[Column::C, Column::Y];
    const SIGNAL: Signal = Signal::Grade;
    const OMEGA_RANK: usize = 2;
    const PARTS: &'static [Part] = &[Part::C, Part::S];

    /// x̃₃ = −g cos θ̃ and s̃ = g sin θ̃ of θ̃ = θ + δ, δ = σe, from the noise-free ones in
    /// `x.c` and `x.s` (no other channel moves them):
    /// the point (−g cos θ, g sin θ) = g (cos(π − θ), sin(π − θ)) turned by −δ
    /// (`numeric::trig::turn`, the short series of the small angle,
    /// docs/model.md#noise-channels).
    #[inline(always)]
    fn measure<L: Lanes>(l: L, x: &mut Sample<L::F64>, sd: f64, e: L::F64) {
        (x.c, x.s) = turn(l, x.c, x.s, l.splat(-sd) * e);
    }

    /// σ_θ = 0 moves nothing: the regression's own x̃₃ and s̃ stand.
    fn moves_at(sd: f64) -> bool {
        sd > 0.0
    }

    /// d/dθ \[g sin θ + θ₃ g cos θ\] = g (cos θ − θ₃ sin θ).
    fn omega_term(sd: f64, at: &OmegaAt) -> f64 {
        match at.grade {
            GradeLoading::Row { g, slope } => (g * sd).powi(2) * slope * slope,
            GradeLoading::MeanSquare(c2) => sd.powi(2) * c2,
        }
    }

    fn expect(sd: f64, r: &TrueRow, e: &mut ColumnMoments) {
        let (g, a) = (r.g, r.accel);
        let [e_cos, e_cos2, e_sin, e_sin_cos] = grade_moments(r.sin_grade, r.cos_grade, sd);
        e.mean[Column::C.index()] = -g * e_cos;
        e.mean[Column::Y.index()] = a + g * e_sin;
        e.cc = g * g * e_cos2;
        e.cy = -g * a * e_cos - g * g * e_sin_cos;
    }

    /// With ρ = e^(−σ²/2): E\[cos θ̃\] = ρ cos θ, E\[sin θ̃\] = ρ sin θ,
    /// E\[cos 2θ̃\] = ρ⁴ cos 2θ, E\[sin 2θ̃\] = ρ⁴ sin 2θ: a sum linear in cos θ̃ or sin θ̃ is
    /// divided by ρ, the products x̃₃² and x̃₃s̃ (through cos 2θ̃, sin 2θ̃) by ρ⁴ after
    /// removing their constant part; ỹ = ã + s̃ is split, its grade term s̃ = g sin θ̃ scaled
    /// apart from the rest ã (which the grade noise leaves alone).
    fn compensate(m: &Moments, sd: f64, g: f64) -> Moments {
        let s2 = sd * sd;
        let gs = m
            .grade
            .expect("the kernel sums the grade term wherever grade noise is on");
        // 1/ρ − 1 and 1/ρ⁴ − 1, accurate for small σ.
        let r1 = (0.5 * s2).exp_m1();
        let r4 = (2.0 * s2).exp_m1();
        let q1 = 1.0 + r1;
        Moments {
            s_13: q1 * m.s_13,
            // g² cos² θ = g²(1 + cos 2θ)/2
            s_33: m.s_33 + r4 * (m.s_33 - 0.5 * g * g * m.n),
            s_1y: m.s_1y + r1 * gs.s_1s,
            // x̃₃ỹ = x̃₃ã + x̃₃s̃, x̃₃s̃ = −(g²/2) sin 2θ̃
            s_3y: q1 * (m.s_3y - gs.s_3s) + (1.0 + r4) * gs.s_3s,
            s_3w: q1 * m.s_3w,
            s_wy: m.s_wy + r1 * gs.s_ws,
            s_3: q1 * m.s_3,
            s_y: m.s_y + r1 * gs.s_s,
            grade: Some(GradeSums {
                s_s: q1 * gs.s_s,
                s_1s: q1 * gs.s_1s,
                s_3s: (1.0 + r4) * gs.s_3s,
                s_ws: q1 * gs.s_ws,
            }),
            ..*m
        }
    }

    /// E\[(−g cos θ̃)ᶜ (g sin θ̃)ˢ\] ([`trig_moment`]).
    fn raw_moment(noise: &NoiseLevels, r: &TrueRow, k: &Powers) -> Option<f64> {
        let (c, s) = (k[Part::C as usize], k[Part::S as usize]);
        let m = trig_moment(r.sin_grade, r.cos_grade, noise[Channel::Grade], c, s);
        Some((-r.g).powi(c as i32) * r.g.powi(s as i32) * m)
    }
}

/// E\[cosᶜ(θ + δ) sinˢ(θ + δ)\] for δ ~ N(0, σ²), c + s ≤ 8, from sin θ and cos θ: with
/// z = e^(i(θ+δ)), cos = (z + z⁻¹)/2 and sin = (z − z⁻¹)/2i, the product is a Laurent
/// polynomial Σ aₙ zⁿ, and E\[zⁿ\] = e^(inθ) e^(−n²σ²/2).
fn trig_moment(sin: f64, cos: f64, sd: f64, c: u8, s: u8) -> f64 {
    const W: usize = 17; // n = −8..=8
    let mid = 8;
    assert!(c + s <= 8, "trigonometric moments up to the eighth order");
    // (re, im) coefficients of zⁿ at index n + 8.
    let mut poly = [(0.0f64, 0.0f64); W];
    poly[mid] = (1.0, 0.0);
    let factors = std::iter::repeat_n([(0.5, 0.0), (0.5, 0.0)], c as usize)
        .chain(std::iter::repeat_n([(0.0, 0.5), (0.0, -0.5)], s as usize));
    // each factor: [coefficient of z⁻¹, coefficient of z]
    for [down, up] in factors {
        let mut next = [(0.0, 0.0); W];
        for n in 0..W {
            let (re, im) = poly[n];
            if re == 0.0 && im == 0.0 {
                continue;
            }
            let mul = |(a, b): (f64, f64), (x, y): (f64, f64)| (a * x - b * y, a * y + b * x);
            let (dr, di) = mul((re, im), down);
            let (ur, ui) = mul((re, im), up);
            next[n - 1].0 += dr;
            next[n - 1].1 += di;
            next[n + 1].0 += ur;
            next[n + 1].1 += ui;
        }
        poly = next;
    }
    // e^(inθ) by repeated multiplication of e^(iθ) = cos θ + i sin θ.
    let mut total = 0.0;
    let (mut pr, mut pi) = (1.0f64, 0.0f64);
    for n in 0..=mid {
        let damp = (-0.5 * (n * n) as f64 * sd * sd).exp();
        let (a, b) = poly[mid + n];
        total += damp * (a * pr - b * pi);
        if n > 0 {
            // z⁻ⁿ: e^(−inθ) = pr − i pi
            let (a, b) = poly[mid - n];
            total += damp * (a * pr + b * pi);
        }
        (pr, pi) = (pr * cos - pi * sin, pr * sin + pi * cos);
    }
    total
}

/// E\[cos(θ + δ)\], E\[cos²(θ + δ)\], E\[sin(θ + δ)\], E\[sin(θ + δ) cos(θ + δ)\] for
/// δ ~ N(0, σ²), from sin θ and cos θ: with ρ = E\[cos δ\] = e^(−σ²/2),
/// E\[sin δ\] = E\[sin δ cos δ\] = 0 and E\[cos 2δ\] = ρ⁴.
fn grade_moments(sin: f64, cos: f64, sd: f64) -> [f64; 4] {
    let rho = (-0.5 * sd * sd).exp();
    let rho4 = (-2.0 * sd * sd).exp();
    [
        rho * cos,
        0.5 * (cos * cos * (1.0 + rho4) + sin * sin * (1.0 - rho4)),
        rho * sin,
        rho4 * sin * cos,
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The grade moments against the integrals themselves: the trapezoid rule over
    /// δ ∈ [−12σ, 12σ] with 4001 points (spectrally accurate for these smooth, rapidly
    /// decaying integrands: agreement to 1e-12) at σ = 0.3 rad, where ρ = 0.956 and
    /// ρ⁴ = 0.835 differ clearly from 1, and at grades of either sign.
    #[test]
    fn grade_moments_are_the_gaussian_integrals() {
        let sd = 0.3;
        for theta in [-0.4f64, -0.05, 0.0, 0.1, 0.7] {
            let (n, half) = (4001, 12.0 * sd);
            let h = 2.0 * half / (n - 1) as f64;
            let mut q = [0.0; 4];
            for k in 0..n {
                let d = -half + k as f64 * h;
                let w = h * (-0.5 * (d / sd).powi(2)).exp()
                    / (sd * (2.0 * std::f64::consts::PI).sqrt());
                let (s, c) = (theta + d).sin_cos();
                for (q, v) in q.iter_mut().zip([c, c * c, s, s * c]) {
                    *q += w * v;
                }
            }
            let e = grade_moments(theta.sin(), theta.cos(), sd);
            for j in 0..4 {
                assert!(
                    (e[j] - q[j]).abs() <= 1e-12,
                    "θ = {theta}, moment {j}: {} vs {}",
                    e[j],
                    q[j]
                );
            }
        }
    }
}
