//! Which sets of sources the general path's pass is compiled for ([`PASSES`]), derived
//! from the channel registry.

use super::{DERIVATIVE, RUNTIME, bit};
use crate::estimate::channels::{CHANNEL_COUNT, Channel, Signal};
use crate::estimate::sums::Column;

/// The most sets of sources a loop is compiled for.
pub(super) const MAX_PASSES: usize = 32;

/// The sets of sources `CH` the general path's pass is compiled for with every sum, from
/// the registry: a channel off the fast path (why a block takes the general path) and any
/// of the others, at most one channel of w on, and a differentiated acceleration only with
/// the speed sensor's channel; the first [`MAX_PASSES`] of them, those of the channels
/// registered first before those of a later one (a set beyond them takes the loop that reads
/// the sources at run time: the same bits, slower); then [`RUNTIME`] (a set no block has) to
/// fill the array.
pub(super) const PASSES: [u32; MAX_PASSES] = {
    let speed = Channel::of(Signal::Speed);
    let mut out = [RUNTIME; MAX_PASSES];
    let mut n = 0;
    // Bit 0 of `m` the differentiated acceleration's, bit i + 1 channel i's.
    let mut m: u32 = 0;
    while m < 2 * DERIVATIVE && n < MAX_PASSES {
        let set = (m >> 1) | if m & 1 != 0 { DERIVATIVE } else { 0 };
        let (mut general, mut in_w, mut speed_on) = (false, 0, false);
        let mut i = 0;
        while i < CHANNEL_COUNT {
            let c = Channel::ALL[i];
            if set & bit(c) != 0 {
                general |= !c.on_fast_path();
                let columns = c.columns();
                let mut k = 0;
                while k < columns.len() {
                    in_w += (columns[k] as usize == Column::W as usize) as usize;
                    k += 1;
                }
                speed_on |= c.index() == speed.index();
            }
            i += 1;
        }
        if general && in_w <= 1 && (set & DERIVATIVE == 0 || speed_on) {
            out[n] = set;
            n += 1;
        }
        m += 1;
    }
    out
};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_passes_compiled_are_the_sets_of_sources_a_block_of_the_general_path_meets() {
        let bits = |signals: &[Signal]| -> u32 {
            signals.iter().map(|&s| bit(Channel::of(s))).sum::<u32>()
        };
        use Signal::{Acceleration as Output, AirSpeed, Force, Grade, Speed};
        let compiled: Vec<u32> = PASSES.into_iter().filter(|&p| p != RUNTIME).collect();
        // Each set once: grade and/or force noise, with speed noise, output noise and a
        // differentiated acceleration (speed noise's) or an air speed, each on or off.
        let mut sorted = compiled.clone();
        sorted.dedup();
        assert_eq!(sorted.len(), compiled.len());
        for set in [
            bits(&[Grade]),
            bits(&[Force]),
            bits(&[Speed, Output, Grade, Force]) | DERIVATIVE,
            bits(&[Speed, Grade]) | DERIVATIVE,
            bits(&[AirSpeed, Grade]),
            bits(&[AirSpeed, Output, Force]),
        ] {
            assert!(compiled.contains(&set), "{set:#b}");
        }
        for set in [
            bits(&[Speed]),
            bits(&[Speed, Output]),
            bits(&[Grade]) | DERIVATIVE,
            bits(&[Speed, AirSpeed, Grade]),
            bits(&[AirSpeed, Grade]) | DERIVATIVE,
        ] {
            assert!(!compiled.contains(&set), "{set:#b}");
        }
    }
}
