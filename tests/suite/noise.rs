//! The normal generator: goodness of fit against the standard normal, and value stability
//! (a fixed key gives fixed first values, so an upgrade cannot silently change every study).

use chassis_mc::numeric::sum::exact_sum;
use chassis_mc::{estimate::channels::Channel, noise::NormalStream};
use statrs::distribution::{ContinuousCDF, Normal};

/// 10⁶ draws over 100 realisation streams of the thesis cycle's length.
fn draws() -> Vec<f64> {
    let mut all = Vec::with_capacity(1_000_000);
    for r in 0..100 {
        let mut s = NormalStream::for_realisation(99, 3, Channel::Velocity.stream(), r);
        let mut buf = vec![0.0; 10_000];
        s.fill(&mut buf);
        all.extend(buf);
    }
    all
}

#[test]
fn normals_pass_kolmogorov_smirnov_and_tail_checks() {
    let mut x = draws();
    let n = x.len() as f64;
    x.sort_by(|a, b| a.partial_cmp(b).unwrap());
    let phi = Normal::standard();
    let d = x
        .iter()
        .enumerate()
        .map(|(i, &v)| {
            let f = phi.cdf(v);
            (f - i as f64 / n).abs().max(((i + 1) as f64 / n - f).abs())
        })
        .fold(0.0, f64::max);
    // Kolmogorov distribution: P(√n D > 1.949) = 0.001.
    assert!(d * n.sqrt() < 1.949, "KS statistic √n·D = {}", d * n.sqrt());

    // The tail beyond r = 3.6541528853610088 is sampled by a separate path (Marsaglia's
    // tail method): P(|Z| > r) = 2.5806e-4 (scipy.stats.norm.sf(r) * 2), so the count is
    // binomial with mean 258.1 and SD 16.1; allow 5 SD.
    let r = 3.654152885361009;
    let tail = x.iter().filter(|v| v.abs() > r).count() as f64;
    let expected = 2.0 * phi.sf(r) * n;
    assert!(
        (tail - expected).abs() < 5.0 * expected.sqrt(),
        "{tail} vs {expected}"
    );

    // Wedge region checks by equiprobable bins: χ² with 99 df; P(χ²₉₉ > 148.2) = 0.001.
    let bins = 100usize;
    let mut counts = vec![0f64; bins];
    for v in &x {
        let b = ((phi.cdf(*v) * bins as f64) as usize).min(bins - 1);
        counts[b] += 1.0;
    }
    let e = n / bins as f64;
    let chi2: f64 = counts.iter().map(|c| (c - e) * (c - e) / e).sum();
    assert!(chi2 < 148.2, "χ² = {chi2}");
}

#[test]
fn a_fixed_key_gives_fixed_values() {
    let mut s = NormalStream::for_realisation(2018, 0, Channel::Velocity.stream(), 0);
    let mut first = [0.0; 8];
    s.fill(&mut first);
    // Pinned when the generator was written (chassis-mc 0.1.0); a change here changes the
    // numbers of every study ever run and must be a deliberate, documented decision.
    let pinned: [f64; 8] = PINNED_FIRST;
    assert_eq!(first, pinned);
    // The whole thesis-length stream, slow paths included, through its exactly rounded sum.
    let mut s = NormalStream::for_realisation(2018, 0, Channel::Velocity.stream(), 0);
    let mut all = vec![0.0; 60_001];
    s.fill(&mut all);
    let sum = exact_sum(all.iter().copied());
    assert_eq!(sum.to_bits(), PINNED_SUM.to_bits());
}

const PINNED_FIRST: [f64; 8] = [
    0.6127096534416318,
    -1.7342395529195487,
    0.1393885303076129,
    -1.7882004588428106,
    0.609242630136679,
    0.7230724537897589,
    1.2070212136225333,
    0.810996425282554,
];
const PINNED_SUM: f64 = -333.1264259478608;
