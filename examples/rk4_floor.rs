//! The least a realisation whose truth moves the vehicle (gusts) can cost beside a steady
//! realisation of the same study: its cycle integrated again by RK4 at the sample step
//! (docs/model.md#model-errors), here stripped to the arithmetic alone, against the study's
//! own steady realisation, timed alternately in this process on one thread.
//!
//! ```text
//! cargo build --release --example rk4_floor
//! target/release/examples/rk4_floor studies/bias_compensation.toml [ROUNDS]
//! ```
//!
//! The study's first condition (a `torque` drive on a terrain profile) gives the steady
//! realisation (`Model::realise_group`, eight side by side, as `path_ratio` times it) and
//! the cycle. The floor integrates the same equation on the same grade table over the same
//! number of steps, [`SIDE`] realisations side by side in `f64` arrays that the compiler
//! turns into SIMD (AVX2 here; AVX-512 measured the same within a few per cent), each with
//! a wind series of its own. Everything a gusty realisation does beyond it makes that
//! realisation dearer, never cheaper:
//! - no draws (the gusts' normals, the sensor noise) and no sums or estimates: those are the
//!   steady realisation itself, which a gusty one does on top;
//! - the propulsion force and the wind taken at the stage's sample index, no time search;
//! - sine and cosine by the fdlibm kernels without range reduction or its check
//!   (`numeric::trig::kernel_lanes`, exact to an ulp for the grades of a road);
//! - the equation's forces alone: no model-error entries (their calls per stage, the
//!   aerodynamic force made again of the wind and air density, the added inertia's ratio
//!   M / (M + Σ m)), no sample state built for them;
//! - no stall or off-road check, no error path; only position, speed and acceleration
//!   stored, not the six columns a cycle records (nor the logged force).
//!
//! Prints the milliseconds per realisation of each (the best of the rounds, after one
//! round unmeasured that touches every buffer) and their ratio: the floor's ratio plus one
//! (the steady realisation's own work) bounds from below what a gusty realisation costs in
//! units of a steady one.

#![cfg_attr(not(target_arch = "x86_64"), allow(dead_code, unused_imports))]

use std::hint::black_box;
use std::path::Path;
use std::time::Instant;

use chassis_mc::dynamics::{Road, Truth};
use chassis_mc::model::Model;
use chassis_mc::model::vehicle::VehicleModel;
use chassis_mc::numeric::simd::{F64x4Portable, Quad};
use chassis_mc::numeric::trig::kernel_lanes;
use chassis_mc::study::Study;
use chassis_mc::terrain::GradeTable;

/// Realisations integrated side by side (two AVX2 registers, or one AVX-512).
const SIDE: usize = 8;
/// Steady realisations computed side by side, as the executor's batches.
const BATCH: usize = 8;

type Lanes = [f64; SIDE];

#[inline(always)]
fn each(f: impl Fn(usize) -> f64) -> Lanes {
    std::array::from_fn(f)
}

/// The equation's inputs: M, g, Cr, ½ρCdA, the grade table, and per step the force at the
/// sample and half a step on.
struct Equation<'a> {
    m: f64,
    g: f64,
    cr: f64,
    drag: f64,
    grade: &'a [f64],
    force: &'a [f64],
}

impl Equation<'_> {
    /// dV/dt of each lane at positions `x`, speeds `v`, force `f` and wind `w`, written lane
    /// array by lane array so that each line is one vector operation.
    #[inline(always)]
    fn accel(&self, x: Lanes, v: Lanes, f: f64, w: Lanes) -> Lanes {
        let last = self.grade.len() - 2;
        let theta = each(|k| {
            let i = (x[k] as usize).min(last);
            let u = x[k] - i as f64;
            self.grade[i] + u * (self.grade[i + 1] - self.grade[i])
        });
        // The sines and cosines four lanes at a time, as the engine's lanes compute them.
        let (mut sin, mut cos) = ([0.0; SIDE], [0.0; SIDE]);
        for q in 0..SIDE / 4 {
            let t = F64x4Portable(std::array::from_fn(|k| theta[4 * q + k]));
            let (s, c) = kernel_lanes(Quad, t);
            sin[4 * q..4 * q + 4].copy_from_slice(&s.0);
            cos[4 * q..4 * q + 4].copy_from_slice(&c.0);
        }
        let air = each(|k| v[k] + w[k]);
        let (m, g, cr, c) = (self.m, self.g, self.cr, self.drag);
        each(|k| (f - c * air[k] * air[k].abs() - m * g * (cr * cos[k] + sin[k])) / m)
    }

    /// [`SIDE`] cycles of `n` samples at step `h` with the winds `winds`; the last speeds.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn integrate(&self, n: usize, h: f64, winds: &[Vec<f64>; SIDE], out: &mut [Lanes]) {
        let (mut x, mut v) = ([0.0; SIDE], [0.0; SIDE]);
        for i in 0..n - 1 {
            let w0 = each(|k| winds[k][i]);
            let w1 = each(|k| winds[k][i + 1]);
            let wm = each(|k| 0.5 * (w0[k] + w1[k]));
            let (f0, fm, f1) = (
                self.force[2 * i],
                self.force[2 * i + 1],
                self.force[2 * i + 2],
            );
            let a1 = self.accel(x, v, f0, w0);
            let x2 = each(|k| x[k] + 0.5 * h * v[k]);
            let v2 = each(|k| v[k] + 0.5 * h * a1[k]);
            let a2 = self.accel(x2, v2, fm, wm);
            let x3 = each(|k| x[k] + 0.5 * h * v2[k]);
            let v3 = each(|k| v[k] + 0.5 * h * a2[k]);
            let a3 = self.accel(x3, v3, fm, wm);
            let x4 = each(|k| x[k] + h * v3[k]);
            let v4 = each(|k| v[k] + h * a3[k]);
            let a4 = self.accel(x4, v4, f1, w1);
            out[3 * i] = x;
            out[3 * i + 1] = v;
            out[3 * i + 2] = a1;
            x = each(|k| x[k] + h / 6.0 * (v[k] + 2.0 * v2[k] + 2.0 * v3[k] + v4[k]));
            v = each(|k| v[k] + h / 6.0 * (a1[k] + 2.0 * a2[k] + 2.0 * a3[k] + a4[k]));
        }
    }
}

#[cfg(not(target_arch = "x86_64"))]
fn main() {
    eprintln!("rk4_floor is written for x86-64 with AVX2");
    std::process::exit(2)
}

#[cfg(target_arch = "x86_64")]
fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(file) = args.first() else {
        eprintln!("usage: rk4_floor STUDY.toml [ROUNDS]");
        std::process::exit(2)
    };
    let rounds: usize = args.get(1).map_or(Ok(8), |a| a.parse())?;
    anyhow::ensure!(
        std::arch::is_x86_feature_detected!("avx2"),
        "the floor is written for AVX2"
    );
    let study = Study::load(Path::new(file)).map_err(|e| anyhow::anyhow!("{e}"))?;
    let model = VehicleModel::new(&study).map_err(|e| anyhow::anyhow!("{file}: {e}"))?;
    let vs = study
        .vehicle()
        .ok_or_else(|| anyhow::anyhow!("{file}: not a vehicle study"))?;
    let terrain = vs
        .terrain
        .as_ref()
        .ok_or_else(|| anyhow::anyhow!("{file}: the floor needs a terrain profile"))?;
    let table: GradeTable = terrain.grade_table(vs.scales[0]);
    let road = Road {
        table: Some(&table),
        scale: vs.scales[0],
    };
    let cycle = vs
        .drive
        .cycle(&vs.vehicle, road, &Truth::default())
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    let n = cycle.len();
    anyhow::ensure!(n >= 2, "{file}: the cycle has {n} sample(s)");
    let h = cycle.t_s[1] - cycle.t_s[0];
    // The force at each sample and half a step on (the mean of its neighbours).
    let f = &cycle.f_prop_n;
    let force: Vec<f64> = (0..2 * n - 1)
        .map(|j| match j % 2 {
            0 => f[j / 2],
            _ => 0.5 * (f[j / 2] + f[j / 2 + 1]),
        })
        .collect();
    let p = &vs.vehicle;
    let equation = Equation {
        m: p.mass_kg,
        g: p.gravity_m_s2,
        cr: p.rolling_resistance,
        drag: p.drag_coefficient * p.drag_factor_kg_m(),
        grade: table.grades(),
        force: &force,
    };
    // A different wind in each lane: ±1 m/s steps.
    let winds: [Vec<f64>; SIDE] = std::array::from_fn(|k| {
        (0..n)
            .map(|i| ((i * 7 + k * 13) % 17) as f64 / 8.0 - 1.0)
            .collect()
    });
    let mut out = vec![[0.0; SIDE]; 3 * n];
    let mut slots = vec![0.0; BATCH * model.layout().realisation_stride()];

    let (mut steady, mut floor) = (f64::INFINITY, f64::INFINITY);
    // Round 0 only touches every buffer.
    for round in 0..=rounds {
        let started = Instant::now();
        for r in (0..4 * BATCH as u64).step_by(BATCH) {
            model.realise_group(2018, &[0], r + 64 * round as u64, BATCH, &mut slots);
            black_box(&slots);
        }
        let steady_now = started.elapsed().as_secs_f64() / (4 * BATCH) as f64;
        let started = Instant::now();
        // SAFETY: AVX2 was detected above.
        unsafe { equation.integrate(n, h, &winds, &mut out) };
        black_box(&out);
        let floor_now = started.elapsed().as_secs_f64() / SIDE as f64;
        if round > 0 {
            steady = steady.min(steady_now);
            floor = floor.min(floor_now);
        }
    }
    println!(
        "steady realisation {:.3} ms, RK4 floor {:.3} ms per realisation ({n} samples): \
         floor / steady = {:.2}, a gusty realisation at least {:.2} steady ones",
        1e3 * steady,
        1e3 * floor,
        floor / steady,
        (floor + steady) / steady
    );
    Ok(())
}
