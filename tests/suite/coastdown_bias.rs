//! What a coast-down's estimators recover noise-free: exactly, on a flat road in calm air;
//! the documented shifts of a steady wind and of a hill, derived for the pooled runs
//! (docs/model.md#coastdown-bias).

use super::common::*;
use chassis_mc::study::Study;
use nalgebra::{DMatrix, DVector};

/// studies/coastdown.toml (M = 1500 kg, Cd = 0.30, A_f = 2.2 m², Cr = 0.010, 8 runs),
/// noise-free, R = 2, with `directions`, a steady `wind` \[m/s\] (0: calm) and, when
/// `hill`, the thesis's cos² hill (scale 1) from 20 km along it.
fn coastdown(directions: &str, wind: f64, hill: bool) -> Study {
    let mut text = set_key(&study_text("coastdown.toml"), "velocity_sd", "[0.0]");
    text = text.replace(
        "# directions = \"alternate\"",
        &format!("directions = \"{directions}\"\n#"),
    );
    if hill {
        text = text.replace("# start_distance = 0.0", "start_distance = 20000.0\n#");
        text.push_str(
            "\n[terrain]\nprofile = \"cos2\"\nheight = 25.0\nperiod = 300.0\nlength = 50000\n\
             scales = [1.0]\nscale_applies_to = \"grade\"\n",
        );
    }
    if wind != 0.0 {
        text.push_str(&format!("\n[truth]\nwind_speed = [{wind}]\n"));
    }
    Study::from_toml(&text, "coastdown")
        .unwrap()
        .with_overrides(Some(2), None)
        .unwrap()
}

const M: f64 = 1500.0;
const G: f64 = 9.81;
const K: f64 = 0.5 * 1.2 * 2.2;
const CD: f64 = 0.30;
const CR: f64 = 0.010;

/// What a noise-free run gives: per estimator, θ̂ of [Cd/M, Cr] (`bias_model` + truth), and
/// road_load's A, B, C; and the used rows of the cycle: speed, grade and run.
struct Outcome {
    theta: Vec<(String, [f64; 2])>,
    abc: [f64; 3],
    v: Vec<f64>,
    grade: Vec<f64>,
    run: Vec<i32>,
}

fn outcome(study: &Study) -> Outcome {
    let (dir, _) = run(study, None);
    let summary = read_table(&dir.path().join("summary.parquet"));
    let (est, par) = (
        str_col(&summary, "estimator"),
        str_col(&summary, "parameter"),
    );
    let (truth, bias) = (f64_col(&summary, "truth"), f64_col(&summary, "bias_model"));
    let mut theta: Vec<(String, [f64; 2])> = Vec::new();
    for i in 0..summary.num_rows() {
        let p = usize::from(par[i] == "rolling_resistance");
        if theta.last().is_none_or(|(e, _)| *e != est[i]) {
            theta.push((est[i].clone(), [f64::NAN; 2]));
        }
        theta.last_mut().unwrap().1[p] = truth[i] + bias[i];
    }
    let rows = read_table(&dir.path().join("realisations.parquet"));
    let i = str_col(&rows, "estimator")
        .iter()
        .position(|e| e == "road_load")
        .unwrap();
    let abc = ["a", "b", "c"].map(|x| f64_col(&rows, &format!("road_load_{x}"))[i]);
    let cycles = read_table(&dir.path().join("cycles.parquet"));
    let used = bool_col(&cycles, "used");
    fn keep<T>(x: Vec<T>, used: &[bool]) -> Vec<T> {
        x.into_iter()
            .zip(used)
            .filter(|(_, u)| **u)
            .map(|(v, _)| v)
            .collect()
    }
    let run = keep(i32_col(&cycles, "run"), &used);
    Outcome {
        theta,
        abc,
        v: keep(f64_col(&cycles, "v"), &used),
        grade: keep(f64_col(&cycles, "grade"), &used),
        run,
    }
}

/// The least-squares coefficients of `y` on the columns `x` (normal equations, LU).
fn project(x: &[Vec<f64>], y: &[f64]) -> Vec<f64> {
    let n = y.len();
    let a = DMatrix::from_fn(n, x.len(), |i, j| x[j][i]);
    let b = DVector::from_column_slice(y);
    let lhs = a.transpose() * &a;
    let rhs = a.transpose() * b;
    lhs.lu().solve(&rhs).unwrap().iter().copied().collect()
}

fn rel(got: f64, want: f64) -> f64 {
    ((got - want) / want).abs()
}

/// Flat road, calm air, noise-free, alternating runs: the road load is exactly
/// k Cd V² + Cr M g, so OLS and BCLS (of y − F/M on [−kV², −g]) and `road_load` (of
/// A + B·V + C·V²) recover Cd/M and Cr to 1e-9 relative, and road_load's B is 0 to 1e-9 of A
/// (rounding in sums of ~10⁴ rows and a 3×3 solve of equilibrated condition ≈ 10⁵).
#[test]
fn a_calm_flat_coast_down_is_recovered_exactly() {
    let out = outcome(&coastdown("alternate", 0.0, false));
    assert_eq!(out.theta.len(), 3);
    for (est, [cd_m, cr]) in &out.theta {
        assert!(rel(*cd_m, CD / M) <= 1e-9, "{est}: Cd/M {cd_m}");
        assert!(rel(*cr, CR) <= 1e-9, "{est}: Cr {cr}");
    }
    let [a, b, c] = out.abc;
    assert!(
        rel(a, CR * M * G) <= 1e-9 && rel(c, K * CD) <= 1e-9,
        "A {a}, C {c}"
    );
    assert!(b.abs() <= 1e-9 * a, "B {b} of A {a}");
}

/// A steady wind w = 3 m/s (headwind on the even runs), noise-free. The truth's drag is
/// k Cd (V + h w)², h = ±1 the run's heading, so with the pooled rows' least-squares
/// projections (docs/model.md#coastdown-bias):
/// - OLS/BCLS with the mass known, hV ≈ a V² + b on [V², 1]: ΔCd/M = 2 w a · Cd/M,
///   ΔCr = (Cd/M) k (2 w b + w²)/g;
/// - road_load, hV ≈ c₀ + c₁V + c₂V² on [1, V, V²]: A = Cr M g + k Cd (w² + 2 w c₀),
///   B = 2 k Cd w c₁, C = k Cd (1 + 2 w c₂).
///
/// One way (h = 1): a, b are V's projection (OLS has no V column: Cd/M is off by 2wa,
/// 15 % here), c = (0, 1, 0) (road_load's B takes 2kCd w V, its C is exact, its A takes kCd w²).
/// Alternating: hV is not zero on average, since a headwind run spends less time at every
/// speed than its tailwind return, so the wind's terms shrink but do not cancel. Each
/// estimate matches its prediction to 1e-9 relative (both exact in real arithmetic: the
/// estimators are linear in the output; what differs is rounding).
#[test]
fn a_steady_wind_moves_each_estimator_as_derived_for_the_pooled_runs() {
    let w = 3.0;
    let mut shifts = Vec::new();
    for directions in ["one_way", "alternate"] {
        let out = outcome(&coastdown(directions, w, false));
        let h: Vec<f64> = out
            .run
            .iter()
            .map(|&r| match directions {
                "alternate" if r % 2 == 1 => -1.0,
                _ => 1.0,
            })
            .collect();
        let hv: Vec<f64> = out.v.iter().zip(&h).map(|(v, h)| h * v).collect();
        let v2: Vec<f64> = out.v.iter().map(|v| v * v).collect();
        let ones = vec![1.0; out.v.len()];
        let ab = project(&[v2.clone(), ones.clone()], &hv);
        let c = project(&[ones, out.v.clone(), v2], &hv);
        let theta2 = CD / M;
        let ols = [
            theta2 * (1.0 + 2.0 * w * ab[0]),
            CR + theta2 * K * (2.0 * w * ab[1] + w * w) / G,
        ];
        for (est, got) in &out.theta {
            let want = match est.as_str() {
                "ols" | "bcls" => ols,
                _ => [
                    theta2 * (1.0 + 2.0 * w * c[2]),
                    CR + theta2 * K * (w * w + 2.0 * w * c[0]) / G,
                ],
            };
            for p in 0..2 {
                assert!(
                    rel(got[p], want[p]) <= 1e-9,
                    "{directions} {est} parameter {p}: {} vs predicted {}",
                    got[p],
                    want[p]
                );
            }
            if est == "ols" || est == "road_load" {
                shifts.push((
                    directions,
                    est.clone(),
                    got[0] / theta2 - 1.0,
                    got[1] / CR - 1.0,
                ));
            }
        }
        let abc = [
            CR * M * G + K * CD * (w * w + 2.0 * w * c[0]),
            2.0 * K * CD * w * c[1],
            K * CD * (1.0 + 2.0 * w * c[2]),
        ];
        for (p, (got, want)) in out.abc.iter().zip(abc).enumerate() {
            assert!(
                rel(*got, want) <= 1e-9,
                "{directions} road_load coefficient {p}: {got} vs predicted {want}"
            );
        }
        if directions == "one_way" {
            assert!(c[0].abs() < 1e-9 && (c[1] - 1.0).abs() < 1e-9 && c[2].abs() < 1e-9);
        }
    }
    for (d, e, cd, cr) in &shifts {
        eprintln!(
            "{d:9} {e:9}: Cd {:+.3} %, Cr {:+.3} %",
            100.0 * cd,
            100.0 * cr
        );
    }
    // Which analysis the alternation protects (measured, noise-free, printed above): OLS's
    // errors shrink (Cd 14.8 % → −2.2 %, Cr 16.7 % → 0.38 %), the pooled road_load's grow
    // (Cd 0 → 2.1 %, Cr 2.4 % → 4.5 %): one way its B absorbs the wind exactly, pooled
    // the flipped wind's hV is outside [1, V, V²]. Asserted with margins: OLS's Cd error
    // shrinks > 5×, its Cr error > 10×; road_load's Cd and Cr errors grow.
    let find = |d: &str, e: &str| shifts.iter().find(|s| s.0 == d && s.1 == e).unwrap();
    let (ols_one, ols_alt) = (find("one_way", "ols"), find("alternate", "ols"));
    assert!(
        ols_alt.2.abs() * 5.0 < ols_one.2.abs(),
        "{ols_one:?} {ols_alt:?}"
    );
    assert!(
        ols_alt.3.abs() * 10.0 < ols_one.3.abs(),
        "{ols_one:?} {ols_alt:?}"
    );
    let (rl_one, rl_alt) = (find("one_way", "road_load"), find("alternate", "road_load"));
    assert!(rl_alt.2.abs() > rl_one.2.abs() && rl_alt.3.abs() > rl_one.3.abs());
}

/// On the thesis's hill (cos², 25 m high, 300 m period), alternating runs, calm, noise-free.
/// The estimators read the measured grade, so its g sin θ leaves y exactly: OLS and BCLS
/// (whose model has −g cos θ) recover Cd/M and Cr to 1e-9. road_load's A fits Cr M g cos θ,
/// not Cr M g: its shift is the projection of Cr M g (cos θ − 1) on [1, V, V²] over the
/// pooled rows (exact, to 1e-9 of the estimate).
///
/// What does not cancel: an analysis that left the grade out (a flat-track assumption)
/// would put the rows' mean g sin θ into A. A return run sees −θ(x) at every place, but the
/// rows are samples in time and every run, either way, ends on the climb that brings it down
/// to speed_low (from its last speed maximum on, a third of the rows average +0.54 m/s²):
/// the pooled mean is positive and the alternation removes only ≈ 12 % of it (measured:
/// 0.102 m/s² alternating, 0.116 one way; asserted: alternating > 0.5 × one way).
#[test]
fn on_a_hill_the_measured_grade_is_removed_and_its_time_weighted_mean_does_not_cancel() {
    let alternate = outcome(&coastdown("alternate", 0.0, true));
    let mut road_load = None;
    for (est, got) in &alternate.theta {
        match est.as_str() {
            "ols" | "bcls" => {
                assert!(rel(got[0], CD / M) <= 1e-9, "{est} Cd/M {}", got[0]);
                assert!(rel(got[1], CR) <= 1e-9, "{est} Cr {}", got[1]);
            }
            _ => road_load = Some(*got),
        }
    }
    let road_load = road_load.unwrap();
    let v2: Vec<f64> = alternate.v.iter().map(|v| v * v).collect();
    let ones = vec![1.0; v2.len()];
    let cos: Vec<f64> = alternate
        .grade
        .iter()
        .map(|g| CR * M * G * (g.cos() - 1.0))
        .collect();
    let c = project(&[ones, alternate.v.clone(), v2], &cos);
    let want = [CD / M + c[2] / (K * M), CR + c[0] / (M * G)];
    for p in 0..2 {
        assert!(
            rel(road_load[p], want[p]) <= 1e-9,
            "road_load parameter {p}: {} vs predicted {}",
            road_load[p],
            want[p]
        );
    }
    let one_way = outcome(&coastdown("one_way", 0.0, true));
    let mean_sin =
        |o: &Outcome| o.grade.iter().map(|g| G * g.sin()).sum::<f64>() / o.grade.len() as f64;
    let (alt, one) = (mean_sin(&alternate), mean_sin(&one_way));
    eprintln!(
        "mean g sin θ over the pooled rows: {alt:.4} m/s² alternating, {one:.4} one way; \
         road_load Cr shift {:+.3} %",
        100.0 * (road_load[1] / CR - 1.0)
    );
    assert!(
        one > 0.0 && alt > 0.5 * one,
        "{alt} alternating, {one} one way"
    );
}
