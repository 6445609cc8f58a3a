//! The pass's chunks (`RowsOut::chunks`): WBCLS's segment moments taken from them are the
//! bits its scan sums from the measured rows, and the realisation's sums, added chunk by
//! chunk, agree with the plain pass's within their rounding.

use super::*;
use crate::dynamics::VehicleParams;
use crate::estimate::estimator::EstimatorSettings;
use crate::estimate::moments::test_draws::{block_draws, channel_draws};
use crate::estimate::moments::{MomentAccumulator, Rows};
use crate::estimate::sums::Sum;
use crate::noise::BLOCK;

/// The test cycle sampled every 0.5 s (1203 rows: four whole blocks and a partial one, 75
/// whole chunks and 3 rows after them): WBCLS's segments are then its chunks.
fn half_second_regression() -> Regression {
    use crate::dynamics::{TorqueDrive, simulate};
    use crate::terrain::GradeTable;
    let drive = TorqueDrive {
        duration_s: 601.0,
        time_step_s: 0.5,
        steps: 1202,
        initial_speed_m_s: 5.0,
        torque_mean_n_m: 225.0,
        torque_amplitude: 0.1,
        torque_frequency_rad_s: 0.1,
    };
    let grades = (0..40_000)
        .map(|i| 0.08 * (i as f64 / 150.0).sin())
        .collect();
    let vehicle = VehicleParams::thesis();
    let cycle = simulate(&vehicle, &drive, &GradeTable::from_grades(grades)).unwrap();
    Regression::new(&cycle, &vehicle)
}

/// A realisation's sums and WBCLS's segment moments, the kernel's way (each block measured
/// into the kept rows, then the scan advanced over it), with `chunks` as
/// [`Rows::take_chunks`] takes them.
fn realise(
    reg: &Regression,
    noise: NoiseLevels,
    draws: &[Vec<f64>],
    chunks: [bool; 2],
) -> (Moments, Vec<Moments>) {
    let n = reg.len();
    let settings = EstimatorSettings::default();
    let start = ScanStart {
        noise: &noise,
        settings: &settings,
        truth: &[0.0; 3],
        shared: false,
    };
    let mut scan = SegmentScan::default();
    scan.reset(reg, &start);
    let mut rows = Rows::new(reg, &noise);
    let mut acc = MomentAccumulator::new(reg, noise).grade_sums(true);
    rows.take_chunks(chunks, acc.sums_grade());
    for start in (0..n).step_by(BLOCK) {
        let len = BLOCK.min(n - start);
        let block = block_draws(draws, &noise, start, len);
        let moved = acc.add_block_into(start, len, block, None, rows.room(len));
        rows.take_room(len, moved);
        scan.advance(rows.view(reg), start + len);
    }
    (acc.finish(), scan.done.clone())
}

#[test]
fn chunks_give_wbcls_the_bits_of_its_rows_and_the_sums_agree_within_rounding() {
    let reg = half_second_regression();
    let n = reg.len();
    assert_eq!(n, 1203);
    assert!(
        WeightSegments::of(&reg).chunks,
        "the segments are the chunks"
    );
    let bits = |m: &Moments| {
        let g = m
            .grade
            .map(|g| [g.s_s, g.s_1s, g.s_3s, g.s_ws].map(f64::to_bits));
        (m.sums().map(f64::to_bits), m.n.to_bits(), g)
    };
    for (velocity, grade, force) in [(0.4, 0.01, 0.0), (0.4, 0.01, 30.0), (0.0, 0.0, 30.0)] {
        let mut noise = NoiseLevels::default();
        noise[Channel::Velocity] = velocity;
        noise[Channel::Grade] = grade;
        noise[Channel::Force] = force;
        let draws = channel_draws(n, 7, 3);
        let (plain, want) = realise(&reg, noise, &draws, [false, false]);
        assert_eq!(want.len(), 76, "75 chunks and the 3 rows after them");
        // Σ|term| of each sum, from the rows the plain run measured (every row written).
        let mut rows = Rows::new(&reg, &noise);
        let mut acc = MomentAccumulator::new(&reg, noise).grade_sums(true);
        for start in (0..n).step_by(BLOCK) {
            let len = BLOCK.min(n - start);
            let moved = acc.add_block_into(
                start,
                len,
                block_draws(&draws, &noise, start, len),
                None,
                rows.room(len),
            );
            rows.take_room(len, moved);
        }
        let v = rows.view(&reg);
        let mut size = Moments::default();
        for i in 0..n {
            size.add_row(&[v.f[i].abs(), v.w[i].abs(), v.c[i].abs(), v.y[i].abs()]);
        }
        for chunks in [[true, false], [true, true]] {
            let (sums, got) = realise(&reg, noise, &draws, chunks);
            let what = format!("σ = {velocity}, {grade}, {force}; chunks {chunks:?}");
            assert_eq!(got.len(), want.len(), "{what}");
            for (j, (g, w)) in got.iter().zip(&want).enumerate() {
                assert_eq!(bits(g), bits(w), "{what}: segment {j}");
            }
            // The same terms added in another order: each sum within the rounding bound
            // 2(n − 1)ε Σ|term| of either order (Higham, "Accuracy and Stability of
            // Numerical Algorithms", 2nd ed., §4.2), whatever its cancellation.
            for s in Sum::ALL {
                let bound = 2.0 * (n - 1) as f64 * f64::EPSILON * size[s];
                assert!(
                    (sums[s] - plain[s]).abs() <= bound,
                    "{what}: {s:?} {} {}",
                    sums[s],
                    plain[s]
                );
            }
            assert_eq!(sums.n, plain.n);
            assert_eq!(sums.grade.is_some(), plain.grade.is_some(), "{what}");
            if let (Some(g), Some(p)) = (sums.grade, plain.grade) {
                // The grade term's: Σs̃, Σx̃₁s̃, Σx̃₃s̃, Σws̃.
                let size = [0, 1, 2, 3].map(|k| {
                    (0..n)
                        .map(|i| v.s[i].abs() * [1.0, v.f[i].abs(), v.c[i].abs(), v.w[i].abs()][k])
                        .sum::<f64>()
                });
                let [g, p] = [g, p].map(|g| [g.s_s, g.s_1s, g.s_3s, g.s_ws]);
                for k in 0..4 {
                    let bound = 2.0 * (n - 1) as f64 * f64::EPSILON * size[k];
                    assert!((g[k] - p[k]).abs() <= bound, "{what}: grade sum {k}");
                }
            }
        }
    }
}
