//! Per-realisation costs on the thesis cycle (N = 60 001 samples), single thread:
//! raw ChaCha8 words (rand_chacha, one word at a time and in bulk; and chassis-mc's own
//! vectorised ChaCha8, the same stream), the ziggurat normal generator, rand_distr's StandardNormal, the
//! moment kernel (draw + accumulate), a whole realisation (kernel + solves + bounds), and
//! eight realisations computed side by side as a run computes them.
//!
//! Also what an entry of `[truth]` drawn per realisation costs (`drawn_cost`).
//!
//! Run: `cargo bench --bench kernel`. The targets are ratios measured in one run:
//! kernel ≤ 2 × raw words, and ≤ 0.25 ms per realisation; and the kernel's cost per sample
//! on a day-long speed trace (80 000 samples) within 20 % of the thesis cycle's; and a
//! realisation running OLS and `wbcls` (or `rls`) at most twice one running OLS alone.

use std::hint::black_box;
use std::path::Path;

use chassis_mc::estimate::channels::Channel;
use chassis_mc::model::Model;
use chassis_mc::model::vehicle::VehicleModel;
use chassis_mc::noise::{self, BLOCK, NormalStream};
use chassis_mc::study::Study;
use criterion::{Criterion, criterion_group, criterion_main};
use rand::Rng;
use rand_distr::{Distribution, StandardNormal};

const N: usize = 60_001;

fn thesis_model() -> VehicleModel {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("studies/thesis.toml");
    let study = Study::load(&path).unwrap();
    VehicleModel::new(&study).unwrap()
}

fn benches(c: &mut Criterion) {
    let mut g = c.benchmark_group("per_realisation");
    g.sample_size(60);
    let mut r = 0u64;
    g.bench_function("raw_chacha8_words", |b| {
        b.iter(|| {
            r += 1;
            let mut rng = noise::stream(2018, 0, Channel::Velocity.stream(), r);
            let mut acc = 0u64;
            for _ in 0..N {
                acc ^= rng.next_u64();
            }
            black_box(acc)
        })
    });
    g.bench_function("raw_chacha8_words_bulk", |b| {
        let mut bytes = [0u8; 8 * BLOCK];
        b.iter(|| {
            r += 1;
            let mut rng = noise::stream(2018, 0, Channel::Velocity.stream(), r);
            let mut acc = 0u64;
            for start in (0..N).step_by(BLOCK) {
                let len = BLOCK.min(N - start);
                rng.fill_bytes(&mut bytes[..8 * len]);
                for w in bytes[..8 * len].chunks_exact(8) {
                    acc ^= u64::from_le_bytes(w.try_into().unwrap());
                }
            }
            black_box(acc)
        })
    });
    g.bench_function("chassis_mc_chacha8_words", |b| {
        let mut words = [0u64; BLOCK];
        b.iter(|| {
            r += 1;
            let mut w =
                noise::ChaCha8Words::new(noise::key(2018, 0, Channel::Velocity.stream()), r);
            let mut acc = 0u64;
            for start in (0..N).step_by(BLOCK) {
                let len = BLOCK.min(N - start);
                w.fill(&mut words[..len]);
                acc ^= words[0];
            }
            black_box(acc)
        })
    });
    g.bench_function("ziggurat_normals", |b| {
        let mut buf = [0.0; BLOCK];
        b.iter(|| {
            r += 1;
            let mut s = NormalStream::for_realisation(2018, 0, Channel::Velocity.stream(), r);
            let mut acc = 0.0;
            for start in (0..N).step_by(BLOCK) {
                let len = BLOCK.min(N - start);
                s.fill_block(&mut buf[..len]);
                acc += buf[0];
            }
            black_box(acc)
        })
    });
    g.bench_function("rand_distr_standard_normal", |b| {
        b.iter(|| {
            r += 1;
            let mut rng = noise::stream(2018, 0, Channel::Velocity.stream(), r);
            let mut acc = 0.0;
            for _ in 0..N {
                let z: f64 = StandardNormal.sample(&mut rng);
                acc += z;
            }
            black_box(acc)
        })
    });
    let model = thesis_model();
    g.bench_function("kernel_moments", |b| {
        b.iter(|| {
            r += 1;
            black_box(model.moments(2018, 0, r))
        })
    });
    let mut slots = vec![0.0; model.layout().realisation_stride()];
    g.bench_function("realisation", |b| {
        b.iter(|| {
            r += 1;
            model.realise(2018, 0, r, &mut slots);
            black_box(slots[1])
        })
    });
    // As a run computes them: eight realisations of a condition side by side (each block of
    // its data read once for the eight); the time is per batch of eight.
    let mut batch = vec![0.0; 8 * model.layout().realisation_stride()];
    g.bench_function("eight_realisations_side_by_side", |b| {
        b.iter(|| {
            r += 8;
            model.realise_group(2018, &[0], r, 8, &mut batch);
            black_box(batch[1])
        })
    });
    g.finish();
}

/// A day-long 1 Hz drive log of `TRACE_SAMPLES` samples as a speed-trace study (speed
/// 10–20 m/s, grade ±2 %, σ_v = 1 m/s), written into `dir`.
fn trace_model(dir: &Path) -> VehicleModel {
    let mut csv = String::from("t,v,grade\n");
    for i in 0..TRACE_SAMPLES {
        let t = i as f64;
        let v = 15.0 + 5.0 * (t / 50.0).sin();
        let g = 0.02 * (t / 300.0).sin();
        csv.push_str(&format!("{t},{v},{g}\n"));
    }
    std::fs::write(dir.join("day.csv"), csv).unwrap();
    let thesis =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("studies/thesis.toml"))
            .unwrap();
    let mut text = String::new();
    let mut skip = false;
    for line in thesis.lines() {
        if line.starts_with('[') {
            skip = line == "[drive]" || line == "[terrain]";
            if line == "[drive]" {
                text.push_str("[drive]\nmode = \"speed_trace\"\ntrace = \"day.csv\"\ntime_column = \"t\"\nspeed_column = \"v\"\nspeed_unit = \"m/s\"\ngrade_column = \"grade\"\ngrade_unit = \"rad\"\n");
            }
        }
        if !skip {
            text.push_str(line);
            text.push('\n');
        }
    }
    let path = dir.join("day.toml");
    std::fs::write(&path, text).unwrap();
    VehicleModel::new(&Study::load(&path).unwrap()).unwrap()
}

/// Samples of the day-long trace (a 1 Hz log of 22 h).
const TRACE_SAMPLES: usize = 80_000;

/// The kernel's cost per sample on a day-long speed trace against the thesis cycle: criterion
/// times each (throughput in samples), and a ratio measured in this run is printed (median
/// of 15 interleaved rounds of 20 realisations each).
fn per_sample(c: &mut Criterion) {
    let dir = tempfile::tempdir().unwrap();
    let thesis = thesis_model();
    let trace = trace_model(dir.path());
    let mut g = c.benchmark_group("kernel_per_sample");
    let mut r = 0u64;
    for (name, model, n) in [
        ("thesis_cycle", &thesis, N),
        ("speed_trace_80k", &trace, TRACE_SAMPLES),
    ] {
        g.throughput(criterion::Throughput::Elements(n as u64));
        g.bench_function(name, |b| {
            b.iter(|| {
                r += 1;
                black_box(model.moments(2018, 0, r))
            })
        });
    }
    g.finish();
    let per_sample = |model: &VehicleModel, n: usize, r0: u64| {
        let start = std::time::Instant::now();
        for r in r0..r0 + 20 {
            black_box(model.moments(2018, 0, r));
        }
        start.elapsed().as_secs_f64() / (20 * n) as f64
    };
    let mut ratios: Vec<f64> = (0..15u64)
        .map(|k| per_sample(&trace, TRACE_SAMPLES, 100 * k) / per_sample(&thesis, N, 100 * k))
        .collect();
    ratios.sort_by(f64::total_cmp);
    println!(
        "kernel cost per sample, speed trace (80 000 samples) / thesis cycle (60 001): {:.3} (median of 15; range {:.3}–{:.3})",
        ratios[7], ratios[0], ratios[14]
    );
}

/// The thesis study (velocity noise σ_v = 1 m/s, scale 1) running `estimators`.
fn thesis_with(dir: &Path, estimators: &str) -> VehicleModel {
    let thesis =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("studies/thesis.toml"))
            .unwrap();
    let text: String = thesis
        .lines()
        .map(|line| {
            if line.starts_with("estimators") {
                format!("estimators = {estimators}\n")
            } else {
                format!("{line}\n")
            }
        })
        .collect();
    let path = dir.join("estimators.toml");
    std::fs::write(&path, text).unwrap();
    VehicleModel::new(&Study::load(&path).unwrap()).unwrap()
}

/// What an estimator that reads the rows adds to a realisation: the whole realisation
/// (kernel, rows, every estimator, bounds) with OLS and one more estimator against OLS
/// alone. Criterion times each, and the ratios measured in this run are printed (median of
/// 15 interleaved rounds of 10 realisations each). The target: at most 2.
fn estimator_cost(c: &mut Criterion) {
    let dir = tempfile::tempdir().unwrap();
    let models: Vec<(&str, VehicleModel)> = [
        ("ols", r#"["ols"]"#),
        ("ols_bcls", r#"["ols", "bcls"]"#),
        ("ols_wbcls", r#"["ols", "wbcls"]"#),
        ("ols_rls", r#"["ols", "rls"]"#),
    ]
    .into_iter()
    .map(|(name, list)| (name, thesis_with(dir.path(), list)))
    .collect();
    bench_realisations(c, "estimator_cost", 30, &models);
    for (name, model) in &models[1..] {
        let rounds = interleaved(model, &models[0].1, 10);
        let ratio = |(t, base): (f64, f64)| t / base;
        println!(
            "realisation cost, {name} / ols alone: {:.3} (median of 15; range {:.3}–{:.3})",
            ratio(rounds[7]),
            ratio(rounds[0]),
            ratio(rounds[14])
        );
    }
}

/// Criterion's timing of a whole realisation (condition 0, a new realisation each
/// iteration) of each of `models`, in the group `group`.
fn bench_realisations(
    c: &mut Criterion,
    group: &str,
    sample_size: usize,
    models: &[(&str, VehicleModel)],
) {
    let mut g = c.benchmark_group(group);
    g.sample_size(sample_size);
    let mut r = 0u64;
    for (name, model) in models {
        let mut slots = vec![0.0; model.layout().realisation_stride()];
        g.bench_function(*name, |b| {
            b.iter(|| {
                r += 1;
                model.realise(2018, 0, r, &mut slots);
                black_box(slots[1])
            })
        });
    }
    g.finish();
}

/// The time per realisation \[s\] of `model` and of `baseline` in 15 interleaved rounds of
/// `per` realisations each, sorted by their ratio.
fn interleaved(model: &VehicleModel, baseline: &VehicleModel, per: u64) -> Vec<(f64, f64)> {
    let time = |model: &VehicleModel, r0: u64| {
        let mut slots = vec![0.0; model.layout().realisation_stride()];
        let start = std::time::Instant::now();
        for r in r0..r0 + per {
            model.realise(2018, 0, r, &mut slots);
            black_box(slots[1]);
        }
        start.elapsed().as_secs_f64() / per as f64
    };
    let mut rounds: Vec<(f64, f64)> = (0..15u64)
        .map(|k| (time(model, 100 * k), time(baseline, 100 * k)))
        .collect();
    rounds.sort_by(|a, b| (a.0 / a.1).total_cmp(&(b.0 / b.1)));
    rounds
}

/// The thesis study at one scale with `extra` appended (a `[truth]` table or `[noise]` keys
/// spliced after `velocity_sd`).
fn thesis_drawn(dir: &Path, name: &str, noise: &str, truth: &str) -> VehicleModel {
    let text: String =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("studies/thesis.toml"))
            .unwrap()
            .lines()
            .map(|line| match line {
                l if l.starts_with("scales") => "scales = [1.0]\n".to_string(),
                l if l.starts_with("velocity_sd") => format!("{l}\n{noise}\n"),
                l => format!("{l}\n"),
            })
            .collect();
    let path = dir.join(format!("{name}.toml"));
    std::fs::write(&path, format!("{text}\n[truth]\n{truth}\n")).unwrap();
    VehicleModel::new(&Study::load(&path).unwrap()).unwrap()
}

/// What an entry drawn anew in every realisation costs (docs/model.md#model-errors): the
/// whole realisation of the thesis cycle (σ_v = 1 m/s, OLS) with gusts (each realisation's
/// motion integrated again by RK4 and its regression rebuilt), with a random force
/// calibration (the log rescaled, the regression rebuilt), with the map's error (the grade
/// rebuilt), against the steady study. Criterion times each; the ratios measured in this run
/// are printed (median of 15 interleaved rounds of 5 realisations each).
fn drawn_cost(c: &mut Criterion) {
    let dir = tempfile::tempdir().unwrap();
    let models: Vec<(&str, VehicleModel)> = [
        ("steady", "", ""),
        ("gusts", "", "wind_gust_sd = [2.0]"),
        ("force_scale_sd", "", "force_scale_sd = [0.05]"),
        ("grade_map", "grade_map_sd = [0.05]", ""),
    ]
    .into_iter()
    .map(|(name, noise, truth)| (name, thesis_drawn(dir.path(), name, noise, truth)))
    .collect();
    bench_realisations(c, "drawn_cost", 20, &models);
    for (name, model) in &models[1..] {
        let rounds = interleaved(model, &models[0].1, 5);
        let (t, base) = rounds[7];
        println!(
            "realisation cost, {name}: {:.2} ms vs {:.3} ms steady = {:.1}x (median of 15; ratio range {:.1}-{:.1})",
            1e3 * t,
            1e3 * base,
            t / base,
            rounds[0].0 / rounds[0].1,
            rounds[14].0 / rounds[14].1
        );
    }
}

criterion_group!(kernel, benches, per_sample, estimator_cost, drawn_cost);
criterion_main!(kernel);
