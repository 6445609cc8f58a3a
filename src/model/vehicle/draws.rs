//! A realisation's noise as the kernel draws it: each channel's normals ([`Draws`]), the
//! AR(1) filter of correlated speed noise, one realisation alone or several side by side
//! (the same bits either way), and the thread's buffer of a differentiated acceleration's
//! span (docs/model.md#noise-channels).

use crate::estimate::channels::Channel;
use crate::estimate::regression::Regression;
use crate::model::SINGLE_BATCH;
use crate::noise::{NormalSequence, NormalStream};

/// One step of the AR(1) filter of correlated speed noise (docs/model.md#noise-channels):
/// z ← φ·previous + scale·z with `[φ, scale]` the row's coefficients, then previous ← z.
/// Every filter of the kernel takes this step, one realisation alone or several side by
/// side, so a realisation's noise has the same bits however it is batched.
#[inline(always)]
pub(super) fn ar1_step(previous: &mut f64, z: &mut f64, [phi, scale]: [f64; 2]) {
    *z = phi * *previous + scale * *z;
    *previous = *z;
}

/// The AR(1) filter ([`ar1_step`] with the rows' coefficients `ar1`) of the noise of
/// realisations side by side (realisation i's noise `pick(&mut noise[i])`): sample j of
/// every one, then j + 1, each from its `previous` value (left at its last). A batch of the
/// executor's size keeps each realisation's previous value in a register (in a list in
/// memory, each step waits for the store of the step before).
pub(super) fn filter_side_by_side<T>(
    noise: &mut [T],
    pick: impl Fn(&mut T) -> &mut [f64],
    previous: &mut [f64],
    ar1: &[[f64; 2]],
) {
    assert_eq!(
        noise.len(),
        previous.len(),
        "a previous value per realisation"
    );
    if let Ok(previous) = <&mut [f64; SINGLE_BATCH]>::try_from(&mut *previous) {
        let mut each = noise.iter_mut().map(&pick);
        let mut noise: [&mut [f64]; SINGLE_BATCH] =
            std::array::from_fn(|_| each.next().expect("a noise per previous value"));
        let mut last = *previous;
        for (j, step) in ar1.iter().enumerate() {
            for (e, last) in noise.iter_mut().zip(&mut last) {
                ar1_step(last, &mut e[j], *step);
            }
        }
        *previous = last;
        return;
    }
    for (j, step) in ar1.iter().enumerate() {
        for (e, previous) in noise.iter_mut().zip(previous.iter_mut()) {
            ar1_step(previous, &mut pick(e)[j], *step);
        }
    }
}

thread_local! {
    /// The speed noise of a differentiated acceleration's span (memory reused by the
    /// thread's next realisation).
    pub(super) static SPAN_NOISE: std::cell::Cell<Vec<f64>> = const { std::cell::Cell::new(Vec::new()) };
}

/// A realisation's own regression, the AR(1) coefficients of its correlated speed noise,
/// and its own true θ.
pub(super) type OwnRegression = (Regression, Option<Vec<[f64; 2]>>, [f64; 3]);

/// One channel's normals in a realisation: read straight from its stream in the blocks the
/// kernel asks for, or, shared between conditions, as a [`NormalSequence`] whose values do
/// not depend on the lengths read.
#[allow(clippy::large_enum_variant)] // on the stack for one realisation; a box would allocate
pub(super) enum Draws {
    Blocks(NormalStream),
    Sequence(NormalSequence),
}

impl Draws {
    pub(super) fn new(shared: bool, seed: u64, key: u64, channel: Channel, r: u64) -> Self {
        match shared {
            false => Draws::Blocks(NormalStream::for_realisation(
                seed,
                key,
                channel.stream(),
                r,
            )),
            true => Draws::Sequence(NormalSequence::for_realisation(
                seed,
                key,
                channel.stream(),
                r,
            )),
        }
    }

    #[inline]
    pub(super) fn fill(&mut self, out: &mut [f64]) {
        match self {
            Draws::Blocks(s) => s.fill(out),
            Draws::Sequence(s) => s.fill(out),
        }
    }
}

/// `out[j] = sd (after[j] − before[j]) inv_dt[j]`: a differentiated acceleration's noise
/// at consecutive rows from the speed noise of the samples after and before each
/// (docs/model.md#sensors). Compiled for AVX2 where the CPU has it
/// (four rows per instruction; the same operations lane by lane, so the same bits).
///
/// # Panics
/// If the slices are shorter than `out`.
pub(super) fn central_differences(
    sd: f64,
    after: &[f64],
    before: &[f64],
    inv_dt: &[f64],
    out: &mut [f64],
) {
    #[cfg(target_arch = "x86_64")]
    if crate::numeric::simd::avx2() {
        // SAFETY: the CPU supports AVX2, checked just above.
        return unsafe { central_differences_avx2(sd, after, before, inv_dt, out) };
    }
    central_differences_body(sd, after, before, inv_dt, out);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn central_differences_avx2(
    sd: f64,
    after: &[f64],
    before: &[f64],
    inv_dt: &[f64],
    out: &mut [f64],
) {
    central_differences_body(sd, after, before, inv_dt, out);
}

#[inline(always)]
fn central_differences_body(
    sd: f64,
    after: &[f64],
    before: &[f64],
    inv_dt: &[f64],
    out: &mut [f64],
) {
    let n = out.len();
    let (after, before, inv_dt) = (&after[..n], &before[..n], &inv_dt[..n]);
    for j in 0..n {
        out[j] = sd * (after[j] - before[j]) * inv_dt[j];
    }
}
