//! The cost of the filters of mass and grade and of their bound on one path of the thesis
//! cycle's length (60 001 samples at 0.01 s), against a thesis realisation (OLS, the kernel
//! and its solve), measured alternately in this process on one thread (README
//! "Performance").
//!
//! ```text
//! cargo build --release --example filter_costs && target/release/examples/filter_costs [ROUNDS]
//! ```
//!
//! Prints, per item, the best over `ROUNDS` (default 8) of the mean wall time of 16 runs,
//! in ms, and its ratio to the thesis realisation's: `ekf` (the filter alone, from the
//! measured speeds and forces), `rls_mf`, and the bound along one path (`path_bound`; the
//! condition's PCRLB over n truths costs n of these steps).

use std::hint::black_box;
use std::path::Path;
use std::time::Instant;

use chassis_mc::estimate::filters::rls_mf::{self, RlsMfSettings};
use chassis_mc::estimate::filters::{FilterModel, TruePath, ekf, pcrlb};
use chassis_mc::model::Model;
use chassis_mc::model::vehicle::VehicleModel;
use chassis_mc::study::Study;

const RUNS: usize = 16;

/// A named item to time.
type Item<'a> = (&'static str, Box<dyn FnMut() + 'a>);
const N: usize = 60_001;

fn main() -> anyhow::Result<()> {
    let rounds: usize = match std::env::args().nth(1) {
        None => 8,
        Some(a) => a.parse()?,
    };
    // The thesis realisation: studies/thesis.toml's first condition, OLS.
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("studies/thesis.toml");
    let study = Study::load(&path).map_err(|e| anyhow::anyhow!("{e}"))?;
    let model = VehicleModel::new(&study).map_err(|e| anyhow::anyhow!("{e}"))?;
    let mut slots = vec![0.0; 8 * model.layout().realisation_stride()];

    // A path of the filters' model: the thesis vehicle from 10 m/s under the thesis torque's
    // force on a gentle sinusoidal grade, speeds measured with a fixed pattern of noise.
    let filter = FilterModel {
        drag: 0.5 * 1.2 * 5.5 * 0.35,
        rolling: 0.0125,
        g: 9.81,
        speed_process_var: 1e-6,
        grade_walk: 1e-7,
        speed_noise_var: 0.01,
    };
    let prior = ekf::Prior {
        mass_kg: 1500.0,
        mass_sd_kg: 250.0,
        grade_sd_rad: 0.01,
    };
    let dt = 0.01;
    let (mut t, mut v, mut grade, mut f, mut z) = (vec![], vec![], vec![], vec![], vec![]);
    let mut x = [10.0, 1.0 / 1800.0, 0.0];
    for k in 0..N {
        let tk = k as f64 * dt;
        x[2] = 0.05 * (0.01 * tk).sin();
        let force = 2025.0 * (1.0 + 0.1 * (0.1 * tk).sin());
        t.push(tk);
        v.push(x[0]);
        grade.push(x[2]);
        f.push(force);
        z.push(x[0] + 0.1 * ((k * 7919 % 1000) as f64 / 500.0 - 1.0));
        x = filter.step(&x, force, dt);
    }
    let truth = TruePath {
        t: &t,
        v: &v,
        grade: &grade,
        force: &f,
        inv_mass: 1.0 / 1800.0,
    };
    let settings = RlsMfSettings {
        forgetting_mass: 1.0,
        forgetting_grade: 0.999,
        half_window: rls_mf::half_window(0.5, dt),
    };

    let mut first = 0u64;
    let mut items: Vec<Item<'_>> = vec![
        (
            "thesis realisation (OLS)",
            Box::new(|| {
                model.realise_group(2018, &[0], first, 8, &mut slots);
                first += 8;
                black_box(&slots);
            }),
        ),
        (
            "ekf",
            Box::new(|| {
                black_box(ekf::run(&filter, &prior, &t, &z, &f, |_, _| {}));
            }),
        ),
        (
            "rls_mf",
            Box::new(|| {
                black_box(rls_mf::run(
                    &filter,
                    &prior,
                    &settings,
                    &t,
                    &z,
                    &f,
                    |_, _| {},
                ));
            }),
        ),
        (
            "path_bound (PCRLB along one path)",
            Box::new(|| {
                black_box(pcrlb::bound(&filter, &prior, &[truth]).ok());
            }),
        ),
    ];
    let mut best = vec![f64::INFINITY; items.len()];
    for _ in 0..rounds {
        for ((name, run), best) in items.iter_mut().zip(&mut best) {
            // The thesis item computes 8 realisations per call.
            let per_call = if name.starts_with("thesis") { 8.0 } else { 1.0 };
            let started = Instant::now();
            for _ in 0..RUNS {
                run();
            }
            let ms = started.elapsed().as_secs_f64() * 1e3 / (RUNS as f64 * per_call);
            *best = best.min(ms);
        }
    }
    println!("{:<36} {:>10} {:>10}", "item", "ms", "× thesis");
    for ((name, _), ms) in items.iter().zip(&best) {
        println!("{name:<36} {ms:>10.3} {:>10.2}", ms / best[0]);
    }
    Ok(())
}
