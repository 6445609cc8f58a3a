use super::*;
use crate::estimate::channels::BlockNoise;
use crate::estimate::channels::Channel;
use crate::estimate::moments::MomentAccumulator;
use crate::estimate::moments::Moments;
use crate::noise::{BLOCK, NormalStream};

/// A 60 s thesis-like cycle on a grade of 0.05 ± 0.04 rad: mostly uphill, so that the
/// sums of sin θ (Σ F sin θ, Σ V² sin θ, …), whose grade-noise corrections are in
/// proportion to them, are far from zero.
fn regression() -> Regression {
    use crate::terrain::GradeTable;
    use crate::dynamics::{TorqueDrive, VehicleParams, simulate};
    let vehicle = VehicleParams::thesis();
    let drive = TorqueDrive {
        duration_s: 60.0,
        time_step_s: 0.01,
        steps: 6000,
        initial_speed_m_s: 5.0,
        torque_mean_n_m: 225.0,
        torque_amplitude: 0.1,
        torque_frequency_rad_s: 0.1,
    };
    let grades = (0..3000)
        .map(|i| 0.05 + 0.04 * (i as f64 / 150.0).sin())
        .collect();
    let cycle = simulate(&vehicle, &drive, &GradeTable::from_grades(grades)).unwrap();
    Regression::new(&cycle, &vehicle)
}

/// The moments of realisation `r` under white `noise`, on the general path (which sums
/// the grade term whatever the noise).
fn moments(reg: &Regression, noise: NoiseLevels, r: u64) -> Moments {
    let mut acc = MomentAccumulator::new_general(reg, noise);
    let mut streams = Channel::ALL.map(|c| NormalStream::for_realisation(11, 0, c.stream(), r));
    let mut buffers = [[0.0; BLOCK]; 4];
    for start in (0..reg.len()).step_by(BLOCK) {
        let len = BLOCK.min(reg.len() - start);
        for (s, b) in streams.iter_mut().zip(&mut buffers) {
            s.fill_block(&mut b[..len]);
        }
        let draws = BlockNoise::from_fn(|c| noise.is_on(c).then(|| &buffers[c.index()][..len]));
        acc.add_block(start, len, draws, None);
    }
    acc.finish()
}

/// Every sum the compensation reads or writes: the thirteen of [`Moments::sums`], then
/// Σs̃, Σx̃₁s̃, Σx̃₃s̃, Σws̃.
fn all_sums(m: &Moments) -> [f64; 17] {
    let g = m.grade.expect("summed on the general path");
    let s = m.sums();
    std::array::from_fn(|j| match j {
        0..13 => s[j],
        13 => g.s_s,
        14 => g.s_1s,
        15 => g.s_3s,
        _ => g.s_ws,
    })
}

/// Each compensated sum is unbiased for its noise-free value: over R realisations of an
/// uphill test cycle (6001 rows), for each channel alone and all four together, the mean of
/// (compensated − noise-free) is within 4.5 of its standard errors of 0 for every sum (of
/// 85 comparisons, one outside by chance has probability ≈ 6e-4). The grade noise is
/// σ_θ = 0.6 rad, where ρ = e^(−σ²/2) = 0.835 and ρ⁴ = 0.487 are far from 1, so that
/// every grade term matters (the corrections are identities of the Gaussian moments,
/// exact at any σ). The test has the power to see a missing or wrong term:
/// wherever a channel's compensation changes a sum, it changes its mean by more than 10
/// of those standard errors (so dropping it would put that sum > 5.5 SE off; measured:
/// 18 SE at least). A sum no noise touches is compared to rounding (1e-12 relative:
/// the kernel's block sums against exactly rounded ones, over 6001 terms).
#[test]
fn every_compensated_sum_has_its_noise_free_expectation() {
    let reg = regression();
    let truth = all_sums(&crate::estimate::moments::noise_free_moments(&reg));
    let levels = [
        (Channel::Velocity, 0.8),
        (Channel::Output, 0.3),
        (Channel::Grade, 0.6),
        (Channel::Force, 40.0),
    ];
    let mut cases: Vec<NoiseLevels> = levels
        .iter()
        .map(|&(c, sd)| {
            let mut noise = NoiseLevels::default();
            noise[c] = sd;
            noise
        })
        .collect();
    let mut all = NoiseLevels::default();
    for (c, sd) in levels {
        all[c] = sd;
    }
    cases.push(all);
    let r = 600;
    let mut powered = 0;
    for noise in cases {
        let (mut error, mut shift) = (vec![], vec![]);
        for k in 0..r {
            let m = moments(&reg, noise, k);
            let raw = all_sums(&m);
            let fixed = all_sums(&m.compensated(reg.g, &noise));
            error.push(std::array::from_fn::<f64, 17, _>(|j| fixed[j] - truth[j]));
            shift.push(std::array::from_fn::<f64, 17, _>(|j| fixed[j] - raw[j]));
        }
        let mean_se = |x: &[[f64; 17]], j: usize| {
            let mean = x.iter().map(|s| s[j]).sum::<f64>() / r as f64;
            let var = x.iter().map(|s| (s[j] - mean).powi(2)).sum::<f64>() / (r - 1) as f64;
            (mean, (var / r as f64).sqrt())
        };
        for (j, t) in truth.iter().enumerate() {
            let (mean, se) = mean_se(&error, j);
            assert!(
                mean.abs() <= 4.5 * se.max(1e-12 * t.abs()),
                "sum {j} under {noise:?}: mean error {mean:e}, SE {se:e}"
            );
            let (moved, _) = mean_se(&shift, j);
            if moved != 0.0 {
                assert!(
                    moved.abs() > 10.0 * se,
                    "sum {j} under {noise:?}: the compensation moves it by {moved:e}, SE {se:e}"
                );
                powered += 1;
            }
        }
    }
    // Speed: Σx̃₁w, Σx̃₃w, Σw², Σwỹ, Σw, Σws̃; force: Σx̃₁²; grade: Σx̃₁x̃₃, Σx̃₃², Σx̃₁ỹ,
    // Σx̃₃ỹ, Σx̃₃w, Σwỹ, Σx̃₃, Σỹ and the four of s̃; all four: their union.
    assert_eq!(powered, 6 + 1 + 12 + 16);
}
