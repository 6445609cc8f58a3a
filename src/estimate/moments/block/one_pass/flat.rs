//! What the general path's pass reads, as pointers checked once per block ([`Flat`]), and
//! which sources move a block: as a constant `CH` of a compiled loop, or read at run time.

use super::super::Block;
use crate::estimate::channels::{CHANNEL_COUNT, Channel, Sample};
use crate::estimate::sums::Column;
use crate::numeric::simd::Lanes;

/// The bit of a channel in the set `CH` of those that move a block (`1 << index`); the
/// differentiated acceleration's noise has the bit after the channels'.
pub(super) const fn bit(c: Channel) -> u32 {
    1 << c.index()
}

/// The bit of a differentiated acceleration's noise in `CH`.
pub(super) const DERIVATIVE: u32 = 1 << CHANNEL_COUNT;

/// Whether a source of the set `ch` moves the measured column `column` (a differentiated
/// acceleration's noise moves ỹ alone); [`RUNTIME`] counts as moving every column.
pub(super) const fn moves(ch: u32, column: Column) -> bool {
    if ch == RUNTIME || (ch & DERIVATIVE != 0 && column as usize == Column::Y as usize) {
        return true;
    }
    let mut i = 0;
    while i < CHANNEL_COUNT {
        let c = Channel::ALL[i];
        let columns = c.columns();
        let mut k = 0;
        while ch & bit(c) != 0 && k < columns.len() {
            if columns[k] as usize == column as usize {
                return true;
            }
            k += 1;
        }
        i += 1;
    }
    false
}

/// `CH` for a loop that reads which channels are on at run time.
pub(super) const RUNTIME: u32 = u32::MAX;

/// Whether the source `bit` is on: a constant of the loop, or, for [`RUNTIME`], read from
/// the inputs (`present`).
#[inline(always)]
pub(super) fn on<const CH: u32>(bit: u32, present: bool) -> bool {
    if CH == RUNTIME {
        present
    } else {
        CH & bit != 0
    }
}

/// What a block is measured from, as pointers to `len` values each, checked once per block:
/// the regression's noise-free samples of the block, each channel's draws (null: off, or
/// at a level that moves nothing) and standard deviation, and a differentiated
/// acceleration's noise (null: none).
#[derive(Clone, Copy)]
pub(super) struct Flat {
    pub(super) len: usize,
    f: *const f64,
    v: *const f64,
    c: *const f64,
    g_sin: *const f64,
    accel: *const f64,
    e: [*const f64; CHANNEL_COUNT],
    sd: [f64; CHANNEL_COUNT],
    d: *const f64,
}

// SAFETY: the pointers are read only, from slices that outlive the pass (a `Flat` lives in
// one call of `MeasuredBlock::pass`).
impl Flat {
    pub(super) fn new(b: Block<'_>) -> Self {
        let Block {
            reg,
            levels,
            start,
            len,
            draws,
            derivative,
        } = b;
        let range = start..start + len;
        let ptr = |s: &[f64]| {
            assert_eq!(s.len(), len, "a column of the block");
            s.as_ptr()
        };
        let mut flat = Flat {
            len,
            f: ptr(&reg.f[range.clone()]),
            v: ptr(&reg.v[range.clone()]),
            c: ptr(&reg.c[range.clone()]),
            g_sin: ptr(&reg.g_sin[range.clone()]),
            accel: ptr(&reg.accel[range]),
            e: [std::ptr::null(); CHANNEL_COUNT],
            sd: [0.0; CHANNEL_COUNT],
            d: derivative.map_or(std::ptr::null(), |d| ptr(&d[..len])),
        };
        for (channel, &sd) in levels.iter() {
            if let Some(e) = draws[channel].filter(|_| channel.moves_at(sd)) {
                flat.e[channel.index()] = ptr(&e[..len]);
                flat.sd[channel.index()] = sd;
            }
        }
        flat
    }

    /// The bits of the sources that move the block.
    pub(super) fn channels(&self) -> u32 {
        let channels = Channel::ALL
            .into_iter()
            .filter(|c| !self.e[c.index()].is_null())
            .fold(0, |bits, c| bits | bit(c));
        channels | if self.d.is_null() { 0 } else { DERIVATIVE }
    }

    /// Whether a channel that is on moves the measured column `column`.
    pub(super) fn moves(&self, column: Column) -> bool {
        Channel::ALL
            .into_iter()
            .any(|c| !self.e[c.index()].is_null() && c.columns().contains(&column))
    }

    /// Samples `i .. i + L::WIDTH` measured: `[x̃₁, w, x̃₃, s̃, ỹ]`. Each channel on (of
    /// `CH`, or of the inputs for [`RUNTIME`]) moves the sample, in the order of
    /// [`Channel::ALL`] ([`Channel::measure_each`]; each moves its own quantities, so the
    /// order changes no value).
    ///
    /// # Safety
    /// `i + L::WIDTH <= self.len`, and a channel `CH` says is on has its pointer.
    #[inline(always)]
    pub(super) unsafe fn measure<L: Lanes, const CH: u32>(&self, l: L, i: usize) -> [L::F64; 5] {
        // SAFETY: every pointer read holds `len` ≥ `i + L::WIDTH` values.
        unsafe {
            let mut x = Sample {
                force: l.load_ptr(self.f, i),
                speed: l.load_ptr(self.v, i),
                c: l.load_ptr(self.c, i),
                s: l.load_ptr(self.g_sin, i),
                output_noise: None,
            };
            Channel::measure_each(l, &mut x, |c| {
                let k = c.index();
                // A channel that is on has its pointer, of `len` values (the block above).
                on::<CH>(bit(c), !self.e[k].is_null())
                    .then(|| (self.sd[k], l.load_ptr(self.e[k], i)))
            });
            let w = x.speed * x.speed;
            let mut y = l.load_ptr(self.accel, i) + x.s;
            if let Some(noise) = x.output_noise {
                y = y + noise;
            }
            if on::<CH>(DERIVATIVE, !self.d.is_null()) {
                y = y + l.load_ptr(self.d, i);
            }
            [x.force, w, x.c, x.s, y]
        }
    }
}
