//! The general path's block measured in one pass: each sample built from the regression's
//! noise-free quantities and moved by every channel that is on (each channel's
//! [`measure`](crate::estimate::channels::Channel::measure), the one definition of its
//! arithmetic), its w and ỹ formed, and, when asked, its terms added to the block's sums in
//! the lanes `segment_moments` (`moments/segment_sums.rs`) uses, so the same bits
//! (docs/model.md#sufficient-statistics). Written once over the number types of
//! `numeric::simd`: four samples at a time in the portable lanes or in an AVX2 register, the
//! samples after the last group one at a time.

use super::{Block, MeasuredBlock, RowsOut, Wanted};
use crate::estimate::channels::{CHANNEL_COUNT, Channel, Sample};
use crate::estimate::sums::Column;
use crate::estimate::sums::{GradeSums, Moments};
#[cfg(target_arch = "x86_64")]
use crate::numeric::simd::Avx2;
use crate::numeric::simd::{Lanes, Lanes4, Quad, Real, Scalar};

/// The bit of a channel in the set `CH` of those that move a block (`1 << index`); the
/// differentiated acceleration's noise has the bit after the channels'.
const fn bit(c: Channel) -> u32 {
    1 << c.index()
}

/// The bit of a differentiated acceleration's noise in `CH`.
const DERIVATIVE: u32 = 1 << CHANNEL_COUNT;

/// `CH` for a loop that reads which channels are on at run time.
const RUNTIME: u32 = u32::MAX;

mod passes;

use passes::{MAX_PASSES, PASSES};

// `pass` names each entry of PASSES, 0 .. 32.
const _: () = assert!(MAX_PASSES == 32, "list each entry of PASSES in `pass`");

/// Whether the source `bit` is on: a constant of the loop, or, for [`RUNTIME`], read from
/// the inputs (`present`).
#[inline(always)]
fn on<const CH: u32>(bit: u32, present: bool) -> bool {
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
struct Flat {
    len: usize,
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
    fn new(b: Block<'_>) -> Self {
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
    fn channels(&self) -> u32 {
        let channels = Channel::ALL
            .into_iter()
            .filter(|c| !self.e[c.index()].is_null())
            .fold(0, |bits, c| bits | bit(c));
        channels | if self.d.is_null() { 0 } else { DERIVATIVE }
    }

    /// Whether a channel that is on moves the measured column `column`.
    fn moves(&self, column: Column) -> bool {
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
    unsafe fn measure<L: Lanes, const CH: u32>(&self, l: L, i: usize) -> [L::F64; 5] {
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

/// The block's lane sums, accumulator k of the terms of [`terms`]: sample i into lane
/// i mod 4 (the lanes of `moments/segment_sums.rs`).
type LaneSums = [[f64; LANES]; TERMS];

const LANES: usize = 4;

/// Number of summed terms.
const TERMS: usize = 17;

/// The terms a sample adds to the block's sums, in the order of `segment_moments`' lists
/// (`moments/segment_sums.rs`): those of w or ỹ [x̃₁ỹ, x̃₃ỹ, x̃₁w, x̃₃w, w², wỹ, w, ỹ], those of x̃₁ and
/// x̃₃ alone [x̃₁², x̃₁x̃₃, x̃₃², x̃₁, x̃₃], and the grade term's [s̃, x̃₁s̃, x̃₃s̃, ws̃].
#[inline(always)]
fn terms<R: Real>([f, w, c, s, y]: [R; 5]) -> [R; TERMS] {
    [
        f * y,
        c * y,
        f * w,
        c * w,
        w * w,
        w * y,
        w,
        y,
        f * f,
        f * c,
        c * c,
        f,
        c,
        s,
        f * s,
        c * s,
        w * s,
    ]
}

/// The first of the sums of x̃₁ and x̃₃ alone in [`terms`], and the first of the grade
/// term's.
const REGRESSOR_TERMS: usize = 8;
const GRADE_TERMS: usize = 13;

/// The moments of the lanes as `segment_moments` forms them: each sum (l₀ + l₁) + (l₂ + l₃);
/// without `regressors` the sums of x̃₁ and x̃₃ alone are zero (left to
/// `MomentAccumulator::finish`), without `grade` there are no grade sums.
fn moments(lanes: &LaneSums, len: usize, regressors: bool, grade: bool) -> Moments {
    let sums = lanes.map(|l| (l[0] + l[1]) + (l[2] + l[3]));
    let [
        s_1y,
        s_3y,
        s_1w,
        s_3w,
        s_ww,
        s_wy,
        s_w,
        s_y,
        s_11,
        s_13,
        s_33,
        s_1,
        s_3,
        s_s,
        s_1s,
        s_3s,
        s_ws,
    ] = sums;
    let [s_11, s_13, s_33, s_1, s_3] = match regressors {
        true => [s_11, s_13, s_33, s_1, s_3],
        false => [0.0; 5],
    };
    Moments {
        s_11,
        s_13,
        s_33,
        s_1y,
        s_3y,
        s_1w,
        s_3w,
        s_ww,
        s_wy,
        s_w,
        s_1,
        s_3,
        s_y,
        n: len as f64,
        grade: grade.then_some(GradeSums {
            s_s,
            s_1s,
            s_3s,
            s_ws,
        }),
    }
}

impl MeasuredBlock {
    /// [`measure`](Self::measure) in one pass over the samples in the lanes of `l`.
    #[inline(always)]
    pub(in crate::estimate::moments) fn measure_one_pass<L: Lanes4>(&mut self, l: L, b: Block<'_>) {
        self.pass::<L, false, false, false>(l, b, true, None);
    }

    /// The block measured as by [`measure`](Self::measure) and its moments as
    /// `segment_moments` (`moments/segment_sums.rs`) takes them from the measured rows, bit for bit;
    /// `wanted` says which sums besides those of w and ỹ, and whether the rows are kept.
    /// The sums are added in the pass, in the lanes the samples are measured in (on x86-64
    /// one AVX2 register, with AVX-512VL where the CPU has it: the same operations, more
    /// registers). With `out`, the rows are written there instead of into the block's own
    /// columns (`wanted.rows` must be set).
    pub fn measure_and_sum(
        &mut self,
        b: Block<'_>,
        wanted: Wanted,
        out: Option<RowsOut<'_>>,
    ) -> Moments {
        #[cfg(target_arch = "x86_64")]
        if let Some(avx2) = Avx2::detect() {
            // SAFETY: the token proves AVX2; the CPU has AVX-512F and VL where asked.
            return unsafe {
                match crate::numeric::simd::avx512vl() {
                    true => self.measure_and_sum_avx512(avx2, b, wanted, out),
                    false => self.measure_and_sum_avx2(avx2, b, wanted, out),
                }
            };
        }
        self.measure_and_sum_in(Quad, b, wanted, out)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    pub(in crate::estimate::moments) fn measure_and_sum_avx2(
        &mut self,
        avx2: Avx2,
        b: Block<'_>,
        wanted: Wanted,
        out: Option<RowsOut<'_>>,
    ) -> Moments {
        self.measure_and_sum_in(avx2, b, wanted, out)
    }

    /// The AVX2 pass compiled with AVX-512VL as well: the same 256-bit operations (no FMA:
    /// Rust contracts nothing), so the same bits, with 32 registers instead of 16 for the
    /// seventeen lane sums and the constants of the pass (fewer of them on the stack).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,avx512f,avx512vl")]
    fn measure_and_sum_avx512(
        &mut self,
        avx2: Avx2,
        b: Block<'_>,
        wanted: Wanted,
        out: Option<RowsOut<'_>>,
    ) -> Moments {
        self.measure_and_sum_in(avx2, b, wanted, out)
    }

    /// [`measure_and_sum`](Self::measure_and_sum) in the lanes of `l`.
    #[inline(always)]
    pub(in crate::estimate::moments) fn measure_and_sum_in<L: Lanes4>(
        &mut self,
        l: L,
        b: Block<'_>,
        wanted: Wanted,
        out: Option<RowsOut<'_>>,
    ) -> Moments {
        let rows = wanted.rows;
        assert!(rows || out.is_none(), "rows written elsewhere are wanted");
        let lanes = match (wanted.regressors, wanted.grade) {
            (true, true) => self.pass::<L, true, true, true>(l, b, rows, out),
            (true, false) => self.pass::<L, true, true, false>(l, b, rows, out),
            (false, true) => self.pass::<L, true, false, true>(l, b, rows, out),
            (false, false) => self.pass::<L, true, false, false>(l, b, rows, out),
        };
        moments(&lanes, b.len, wanted.regressors, wanted.grade)
    }

    /// The pass: the block measured (without `rows`, the groups write no columns), and
    /// with `SUMS` the lanes of its sums of the terms that `REGRESSORS` and `GRADE` ask for
    /// (the others stay zero). With every sum, a loop is compiled for each combination of
    /// the sources the general path meets (force or grade noise, with speed noise, output
    /// noise and a differentiated acceleration each on or off); otherwise one loop reads
    /// them at run time.
    #[inline(always)]
    fn pass<L: Lanes4, const SUMS: bool, const REGRESSORS: bool, const GRADE: bool>(
        &mut self,
        l: L,
        b: Block<'_>,
        rows: bool,
        out: Option<RowsOut<'_>>,
    ) -> LaneSums {
        let x = Flat::new(b);
        (self.start, self.len) = (b.start, b.len);
        self.grade_moved = x.moves(Column::C);
        self.force_moved = x.moves(Column::F);
        self.rows_elsewhere = out.is_some();
        if !(SUMS && REGRESSORS) {
            return self.groups::<L, SUMS, REGRESSORS, GRADE, RUNTIME>(l, &x, rows, out);
        }
        macro_rules! by_channels {
            ($($i:literal)*) => {
                match x.channels() {
                    $(ch if ch == PASSES[$i] => {
                        self.groups::<L, SUMS, REGRESSORS, GRADE, { PASSES[$i] }>(l, &x, rows, out)
                    })*
                    _ => self.groups::<L, SUMS, REGRESSORS, GRADE, RUNTIME>(l, &x, rows, out),
                }
            };
        }
        // Each entry of PASSES (0 .. MAX_PASSES).
        by_channels!(0 1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16 17 18 19 20 21 22 23 24 25 26 27 28 29 30 31)
    }

    /// [`pass`](Self::pass) with the sources `CH` ([`Flat::channels`] or [`RUNTIME`]):
    /// the groups of four samples, then the samples after them one at a time (into lane 0
    /// of the sums, as `segment_moments` adds them).
    #[inline(always)]
    fn groups<
        L: Lanes4,
        const SUMS: bool,
        const REGRESSORS: bool,
        const GRADE: bool,
        const CH: u32,
    >(
        &mut self,
        l: L,
        x: &Flat,
        rows: bool,
        out: Option<RowsOut<'_>>,
    ) -> LaneSums {
        assert!(CH == RUNTIME || CH == x.channels(), "the pass's channels");
        let len = x.len;
        let (force, grade) = (self.force_moved, self.grade_moved);
        let own = [
            &mut self.f[..len],
            &mut self.w[..len],
            &mut self.c[..len],
            &mut self.s[..len],
            &mut self.y[..len],
        ];
        let [f_out, w_out, c_out, s_out, y_out] = match out {
            None => own,
            Some(o) => {
                let [f, _, c, s, _] = own;
                [
                    o.f.unwrap_or(f),
                    o.w,
                    o.c.unwrap_or(c),
                    o.s.unwrap_or(s),
                    o.y,
                ]
            }
        };
        for column in [&f_out, &w_out, &c_out, &s_out, &y_out] {
            assert_eq!(column.len(), len, "a column of the block's rows");
        }
        let wanted = |k: usize| {
            k < REGRESSOR_TERMS || (REGRESSORS && k < GRADE_TERMS) || (GRADE && k >= GRADE_TERMS)
        };
        let whole = len - len % LANES;
        let mut acc = [l.splat(0.0); TERMS];
        for i in (0..whole).step_by(LANES) {
            // SAFETY: i + 4 <= len; `CH` is the inputs' channels or RUNTIME (checked).
            let values = unsafe { x.measure::<L, CH>(l, i) };
            let [f, w, c, s, y] = values;
            if rows {
                if force {
                    l.store(f, f_out, i);
                }
                if grade {
                    l.store(c, c_out, i);
                    l.store(s, s_out, i);
                }
                l.store(w, w_out, i);
                l.store(y, y_out, i);
            }
            if SUMS {
                for (k, t) in terms(values).into_iter().enumerate() {
                    if wanted(k) {
                        acc[k] = acc[k] + t;
                    }
                }
            }
        }
        let mut lanes = [[0.0; LANES]; TERMS];
        if SUMS {
            lanes = l.lanes_each(acc);
        }
        for j in whole..len {
            // SAFETY: j < len; `CH` as above.
            let r = unsafe { x.measure::<Scalar, CH>(Scalar, j) };
            (f_out[j], w_out[j], c_out[j], s_out[j], y_out[j]) = (r[0], r[1], r[2], r[3], r[4]);
            if SUMS {
                for (k, t) in terms(r).into_iter().enumerate() {
                    if wanted(k) {
                        lanes[k][0] += t;
                    }
                }
            }
        }
        lanes
    }

    /// The block measured one sample at a time ([`Scalar`]): what the lanes must agree with.
    #[cfg(test)]
    pub(in crate::estimate::moments) fn measure_by_samples(&mut self, b: Block<'_>) {
        let x = Flat::new(b);
        (self.start, self.len) = (b.start, b.len);
        self.grade_moved = x.moves(Column::C);
        self.force_moved = x.moves(Column::F);
        self.rows_elsewhere = false;
        for j in 0..x.len {
            // SAFETY: j < len.
            let r = unsafe { x.measure::<Scalar, RUNTIME>(Scalar, j) };
            (self.f[j], self.w[j], self.c[j], self.s[j], self.y[j]) =
                (r[0], r[1], r[2], r[3], r[4]);
        }
    }
}
