//! The cost per realisation of two studies' first condition, computed alternately in this
//! process on one thread: for `benches/path_costs.py --in-process`, which compares each
//! sensor path with the thesis path by two timings taken moments apart, without the
//! process start, the study's preparation and the output that a whole run adds.
//!
//! ```text
//! cargo build --release --example path_ratio
//! target/release/examples/path_ratio BASE.toml PATH.toml [ROUNDS] [PER_ROUND]
//! ```
//!
//! Prints `BASE_MS PATH_MS`: for each study the best over `ROUNDS` (default 8) of the mean
//! wall time per realisation of `PER_ROUND` (default 40, rounded up to a multiple of eight)
//! realisations with seed 2018, computed eight side by side as a run computes them
//! (`Model::realise_group`), the two studies alternating round by round.

use std::hint::black_box;
use std::path::Path;
use std::time::Instant;

use chassis_mc::model::Model;
use chassis_mc::model::vehicle::VehicleModel;
use chassis_mc::study::Study;

/// Realisations computed side by side, as the executor's batches.
const BATCH: u64 = 8;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let usage = || -> ! {
        eprintln!("usage: path_ratio BASE.toml PATH.toml [ROUNDS] [PER_ROUND]");
        std::process::exit(2)
    };
    let (Some(base), Some(path)) = (args.first(), args.get(1)) else {
        usage()
    };
    let number = |i: usize, default: u64| match args.get(i).map(|a| a.parse::<u64>()) {
        None => default,
        Some(Ok(n)) if n > 0 => n,
        Some(_) => usage(),
    };
    // Whole batches: the loop below computes `per_round` realisations exactly.
    let (rounds, per_round) = (number(2, 8), number(3, 40).div_ceil(BATCH) * BATCH);
    let load = |file: &str| -> anyhow::Result<VehicleModel> {
        let study = Study::load(Path::new(file)).map_err(|e| anyhow::anyhow!("{e}"))?;
        VehicleModel::new(&study).map_err(|e| anyhow::anyhow!("{file}: {e}"))
    };
    let models = [load(base)?, load(path)?];
    // Seconds per realisation of `per_round` realisations of condition 0 from `first` on.
    let time = |model: &VehicleModel, first: u64| {
        let mut slots = vec![0.0; BATCH as usize * model.layout().realisation_stride()];
        let started = Instant::now();
        for r in (first..first + per_round).step_by(BATCH as usize) {
            model.realise_group(2018, &[0], r, BATCH as usize, &mut slots);
            black_box(&slots);
        }
        started.elapsed().as_secs_f64() / per_round as f64
    };
    let mut best = [f64::INFINITY; 2];
    for round in 0..rounds {
        for (model, best) in models.iter().zip(&mut best) {
            *best = best.min(time(model, round * per_round));
        }
    }
    println!("{:.6} {:.6}", best[0] * 1e3, best[1] * 1e3);
    Ok(())
}
