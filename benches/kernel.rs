//! Per-realisation costs on the thesis cycle (N = 60 001 samples), single thread:
//! raw ChaCha8 words (rand_chacha, one word at a time and in bulk; and chassis-mc's own
//! vectorised ChaCha8, the same stream), the ziggurat normal generator, rand_distr's StandardNormal, the
//! moment kernel (draw + accumulate) and a whole realisation (kernel + solves + bounds).
//!
//! Run: `cargo bench --bench kernel`. The targets are ratios measured in one run:
//! kernel ≤ 2 × raw words, and ≤ 0.25 ms per realisation.

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
    g.finish();
}

criterion_group!(kernel, benches);
criterion_main!(kernel);
