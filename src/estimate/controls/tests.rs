use super::*;
use crate::estimate::channels::{Acceleration, BlockNoise};
use crate::estimate::moments::MomentAccumulator;
use crate::estimate::regression::test_regression as regression;
use crate::noise::{BLOCK, NormalStream};

/// The moments of realisation `r` with white noise on every channel that is on.
fn moments(reg: &Regression, noise: NoiseLevels, r: u64) -> Moments {
    let mut acc = MomentAccumulator::new(reg, noise);
    let mut streams = Channel::ALL
        .map(|c| NormalStream::for_realisation(9, 0, c.stream(), r))
        .to_vec();
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

/// Every control variate has mean zero: for each channel alone and all together, over
/// R realisations each control's mean is within 4.5 of its standard errors of 0 (one of
/// 35 comparisons outside by chance: probability ≈ 2.4e-4). This catches an error in the
/// speed, force and output terms (the σ² terms are ~N σ² while the SE is ~√N σ); the grade
/// terms, whose errors would be of order σ_θ² Σ sin θ here, are checked by quadrature
/// above.
#[test]
fn control_variates_have_mean_zero_on_every_channel() {
    let reg = regression();
    let mut cases = Vec::new();
    for (channel, sd) in [
        (Channel::Velocity, 0.8),
        (Channel::Output, 0.3),
        (Channel::Grade, 0.02),
        (Channel::Force, 40.0),
    ] {
        let mut noise = NoiseLevels::default();
        noise[channel] = sd;
        cases.push(noise);
    }
    let mut all = NoiseLevels::default();
    all[Channel::Velocity] = 0.8;
    all[Channel::Output] = 0.3;
    all[Channel::Grade] = 0.02;
    all[Channel::Force] = 40.0;
    cases.push(all);
    let r = 600;
    let mut compared = 0;
    for noise in cases {
        assert_eq!(noise.acceleration, Acceleration::Model);
        let e = Expectations::new(&reg, &noise, None);
        let samples: Vec<[f64; CONTROL_COUNT]> =
            (0..r).map(|k| e.centre(&moments(&reg, noise, k))).collect();
        for j in 0..CONTROL_COUNT {
            if e.0[j].is_none() {
                assert!(samples.iter().all(|s| s[j].is_nan()));
                continue;
            }
            let mean = samples.iter().map(|s| s[j]).sum::<f64>() / r as f64;
            let var = samples.iter().map(|s| (s[j] - mean).powi(2)).sum::<f64>() / (r - 1) as f64;
            let se = (var / r as f64).sqrt();
            assert!(
                se > 0.0,
                "{} does not vary under {noise:?}",
                CONTROLS[j].name
            );
            assert!(
                mean.abs() <= 4.5 * se,
                "{} under {noise:?}: mean {mean:e}, SE {se:e}",
                CONTROLS[j].name
            );
            compared += 1;
        }
    }
    assert_eq!(compared, 5 + 4 + 8 + 5 + 13);
}

/// A product of two columns that one channel moves is not the product of their means:
/// every such sum (a square, or a pair a channel's [`Channel::columns`] both list, or
/// w ỹ, which speed noise shares through a differentiated acceleration) reads a joint
/// moment. With every joint moment NaN, exactly those sums come out NaN, so a new
/// channel that moves two columns without a joint moment fails here.
#[test]
fn a_product_of_columns_one_channel_moves_reads_its_joint_moment() {
    let e = ColumnMoments {
        mean: [2.0, 3.0, 5.0, 7.0],
        ff: f64::NAN,
        ww: f64::NAN,
        cc: f64::NAN,
        cy: f64::NAN,
        wy_neighbours: f64::NAN,
    };
    for s in Sum::ALL {
        let shared = match *s.factors() {
            [a, b] => {
                a == b
                    || (a, b) == (Column::W, Column::Y)
                    || Channel::ALL
                        .iter()
                        .any(|c| c.columns().contains(&a) && c.columns().contains(&b))
            }
            _ => false,
        };
        assert_eq!(e.of(s).is_nan(), shared, "{s:?}");
    }
}

#[test]
fn without_noise_nothing_is_a_control() {
    let e = Expectations::new(&regression(), &NoiseLevels::default(), None);
    assert_eq!(e.applies(), [false; CONTROL_COUNT]);
}
