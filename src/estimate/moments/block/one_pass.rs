//! The general path's block measured in one pass: each sample built from the regression's
//! noise-free quantities and moved by every channel that is on (each channel's
//! [`measure`](crate::estimate::channels::Channel::measure), the one definition of its
//! arithmetic), its w and ỹ formed, and, when asked, its terms added to the block's sums in
//! the lanes `segment_moments` (`moments/segment_sums.rs`) uses, so the same bits
//! (docs/model.md#sufficient-statistics). Written once over the number types of
//! `numeric::simd`: four samples at a time in the portable lanes or in an AVX2 register, the
//! samples after the last group one at a time.

use super::{Block, CHUNK_ROWS, MeasuredBlock, RowsOut, Wanted};
use crate::estimate::sums::Column;
use crate::estimate::sums::{GradeSums, Moments};
#[cfg(target_arch = "x86_64")]
use crate::numeric::simd::Avx2;
use crate::numeric::simd::{Lanes4, Quad, Real, Scalar};

mod flat;
mod passes;

use flat::{DERIVATIVE, Flat, RUNTIME, bit, moves};

use passes::{MAX_PASSES, PASSES};

// `pass` names each entry of PASSES, 0 .. 32.
const _: () = assert!(MAX_PASSES == 32, "list each entry of PASSES in `pass`");

/// The block's lane sums, accumulator k of the terms of [`terms`]: sample i into lane
/// i mod 4 (the lanes of `moments/segment_sums.rs`).
type LaneSums = [[f64; LANES]; TERMS];

/// A chunk's lane sums ([`RowsOut::chunks`]), as a block's ([`LaneSums`]).
pub type ChunkLanes = LaneSums;

/// The moments of a chunk from its lane sums, each reduced as `segment_moments` reduces a
/// segment's (so the same bits); with the grade term's sums where `grade`.
#[inline(always)]
pub(crate) fn chunk_moments<L: Lanes4>(l: L, lanes: &ChunkLanes, grade: bool) -> Moments {
    moments(l.reduce_each(l.load_each(lanes)), CHUNK_ROWS, true, grade)
}

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

/// The terms of x̃₁ alone in [`terms`], x̃₁² and x̃₁: constant where no source moves x̃₁, so
/// a block's are not summed there (the realisation takes the regression's,
/// `MomentAccumulator::finish`).
const FORCE_TERMS: [usize; 2] = [8, 11];

/// The moments of `len` rows from their sums of [`terms`], each reduced from its lanes as
/// `segment_moments` reduces them, (l₀ + l₁) + (l₂ + l₃); without `regressors` the sums of
/// x̃₁ and x̃₃ alone are zero (left to `MomentAccumulator::finish`), without `grade` there
/// are no grade sums.
#[inline(always)]
fn moments(sums: [f64; TERMS], len: usize, regressors: bool, grade: bool) -> Moments {
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
    /// `segment_moments` (`moments/segment_sums.rs`) takes them from the measured rows, bit for bit,
    /// but Σx̃₁² and Σx̃₁, zero where no source moved x̃₁ (left to the realisation);
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
        let sums = lanes.map(|l| (l[0] + l[1]) + (l[2] + l[3]));
        let mut m = moments(sums, b.len, wanted.regressors, wanted.grade);
        if !self.force_moved {
            // Left to the realisation (FORCE_TERMS): zero, as without `regressors`.
            (m.s_11, m.s_1) = (0.0, 0.0);
        }
        m
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
        let ([f_out, w_out, c_out, s_out, y_out], chunks, chunk_rows) = match out {
            None => (own, None, true),
            Some(o) => {
                let [f, _, c, s, _] = own;
                let columns = [
                    o.f.unwrap_or(f),
                    o.w,
                    o.c.unwrap_or(c),
                    o.s.unwrap_or(s),
                    o.y,
                ];
                (columns, o.chunks, o.chunk_rows)
            }
        };
        for column in [&f_out, &w_out, &c_out, &s_out, &y_out] {
            assert_eq!(column.len(), len, "a column of the block's rows");
        }
        let wanted = |k: usize| {
            k < REGRESSOR_TERMS || (REGRESSORS && k < GRADE_TERMS) || (GRADE && k >= GRADE_TERMS)
        };
        // The block's sums: not those of x̃₁ alone where the loop's sources leave it
        // noise-free (FORCE_TERMS; a loop that reads its sources at run time sums them, and
        // `measure_and_sum_in` drops them alike). The chunks keep every wanted sum.
        let block_sum =
            |k: usize| wanted(k) && (const { moves(CH, Column::F) } || !FORCE_TERMS.contains(&k));
        let whole = len - len % LANES;
        // Group i (rows i .. i + 4) measured, its rows written where kept, its terms added
        // to the lanes `$acc`. A macro, not a closure: a closure's body is not compiled
        // with the caller's target features.
        macro_rules! group {
            ($i:expr, $acc:expr, $rows:expr, $summed:expr) => {{
                let (i, rows) = ($i, $rows);
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
                        if $summed(k) {
                            $acc[k] = $acc[k] + t;
                        }
                    }
                }
            }};
        }
        let mut acc = [l.splat(0.0); TERMS];
        let mut first = 0;
        if let Some(chunks) = chunks {
            // Chunk by chunk: each chunk's sums in lanes of their own, kept in `chunks`;
            // then the chunks' lanes added to the block's in order.
            assert!(
                SUMS && self.start.is_multiple_of(CHUNK_ROWS),
                "chunks of the pass's sums"
            );
            let count = len / CHUNK_ROWS;
            assert_eq!(chunks.len(), count, "room for the block's whole chunks");
            let mut part = [l.splat(0.0); TERMS];
            for i in (0..count * CHUNK_ROWS).step_by(LANES) {
                group!(i, part, rows && chunk_rows, wanted);
                if (i + LANES).is_multiple_of(CHUNK_ROWS) {
                    for (kept, p) in chunks[i / CHUNK_ROWS].iter_mut().zip(part) {
                        l.store(p, kept, 0);
                    }
                    part = [l.splat(0.0); TERMS];
                }
            }
            for kept in chunks.iter() {
                let part = l.load_each(kept);
                for (k, (a, p)) in acc.iter_mut().zip(part).enumerate() {
                    if block_sum(k) {
                        *a = *a + p;
                    }
                }
            }
            first = count * CHUNK_ROWS;
        }
        for i in (first..whole).step_by(LANES) {
            group!(i, acc, rows, block_sum);
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
                    if block_sum(k) {
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
