//! Test helpers: each channel's standard normals for a realisation, and a block's share of
//! them as the kernel hands them to the pass.

use crate::estimate::channels::{BlockNoise, Channel, NoiseLevels};
use crate::noise::NormalStream;

/// The draws of rows `start .. start + len` of each channel `noise` has on.
pub(crate) fn block_draws<'a>(
    draws: &'a [Vec<f64>],
    noise: &NoiseLevels,
    start: usize,
    len: usize,
) -> BlockNoise<'a> {
    BlockNoise::from_fn(|c| {
        noise
            .is_on(c)
            .then(|| &draws[c.index()][start..start + len])
    })
}

/// `n` standard normals of every channel, from realisation `r` of seed `seed`.
pub(crate) fn channel_draws(n: usize, seed: u64, r: u64) -> Vec<Vec<f64>> {
    Channel::ALL
        .iter()
        .map(|c| {
            let mut z = vec![0.0; n];
            NormalStream::for_realisation(seed, 0, c.stream(), r).fill(&mut z);
            z
        })
        .collect()
}
