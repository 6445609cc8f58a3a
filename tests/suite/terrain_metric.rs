//! terrain_ms_grid at scale 1 equals the closed-form mean of
//! (atan Δy)² to 1e-12 relative.
//!
//! Closed form of the forward difference of y = h cos²(x/P) on the 1 m grid:
//! Δy_i = h [cos²((i+1)/P) − cos²(i/P)] = −h sin((2i+1)/P) sin(1/P), an independent way of
//! computing each grade without the subtraction of nearly equal elevations. Both sides sum
//! 50 000 squares; the engine's sum is exactly rounded and the reference below uses
//! Neumaier compensation, so their difference is dominated by the ~1e-14 relative rounding
//! of individual Δy values — 100× inside the 1e-12 tolerance.

use super::common::*;

fn neumaier(values: impl Iterator<Item = f64>) -> f64 {
    let (mut sum, mut comp) = (0.0f64, 0.0f64);
    for v in values {
        let t = sum + v;
        comp += if sum.abs() >= v.abs() {
            (sum - t) + v
        } else {
            (v - t) + sum
        };
        sum = t;
    }
    sum + comp
}

#[test]
fn grid_metric_matches_the_closed_form_at_scale_one() {
    let (h, p, l) = (25.0f64, 300.0f64, 50_000usize);
    let closed = neumaier((0..l).map(|i| {
        let dy = -h * ((2 * i + 1) as f64 / p).sin() * (1.0 / p).sin();
        dy.atan().powi(2)
    })) / l as f64;

    let study = study("thesis.toml", 1);
    let infos = chassis_mc::model::prepare(&study).unwrap().infos();
    let grid = infos[0].metrics[0];
    let rel = ((grid - closed) / closed).abs();
    assert!(
        rel <= 1e-12,
        "terrain_ms_grid {grid} vs closed form {closed}: {rel:e}"
    );
    // docs/model.md#terrain: at a = 1 they are about 0.00346 and 0.00340 rad².
    assert!((grid - 0.00346).abs() < 5e-6, "{grid}");
    let cycle = infos[0].metrics[1];
    assert!((cycle - 0.00340).abs() < 5e-6, "{cycle}");
    // Scaling the grade by a multiplies ς by a² exactly (up to rounding).
    let last = infos[10].metrics[0];
    assert!((last / grid - 4.0).abs() < 1e-12, "{last} / {grid}");
}
