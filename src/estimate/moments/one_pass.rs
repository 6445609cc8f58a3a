//! The general path's block measured in one pass: every channel's perturbation of a sample,
//! the grade's small-angle sine and cosine and the angle addition, and the columns w, x̃₃,
//! s̃, ỹ (and x̃₁ under force noise), four samples at a time in registers; with AVX2 the
//! block's sums are added in the same pass, in the lanes `segment_moments` (`row_sums.rs`)
//! uses. The same IEEE operations in the same order as the channels'
//! [`perturb`](crate::estimate::channels::Channel::perturb) column by column, the column
//! passes of `MeasuredBlock::measure_by_channels` and `segment_moments` over the rows, so
//! the same bits (docs/model.md#sufficient-statistics); only the memory traffic between
//! the passes is gone.

use super::{Block, GradeSums, MeasuredBlock, Moments};
use crate::estimate::channels::{Channel, Quantity};
use crate::estimate::row_sums::segment_moments;
use crate::numeric::trig::sin_cos;

/// One channel's draws of the block and its standard deviation.
#[derive(Clone, Copy)]
struct Draw<'a> {
    e: &'a [f64],
    sd: f64,
}

/// What a block is measured from: the regression's noise-free samples of the block and
/// each channel's draws (`None`: off).
#[derive(Clone, Copy)]
struct Inputs<'a> {
    f: &'a [f64],
    v: &'a [f64],
    sin: &'a [f64],
    cos: &'a [f64],
    c: &'a [f64],
    g_sin: &'a [f64],
    accel: &'a [f64],
    g: f64,
    force: Option<Draw<'a>>,
    speed: Option<Draw<'a>>,
    grade: Option<Draw<'a>>,
    output: Option<Draw<'a>>,
    derivative: Option<&'a [f64]>,
}

impl<'a> Inputs<'a> {
    fn new(b: Block<'a>) -> Self {
        let Block {
            reg,
            levels,
            start,
            len,
            draws,
            derivative,
        } = b;
        let range = start..start + len;
        let mut inputs = Inputs {
            f: &reg.f[range.clone()],
            v: &reg.v[range.clone()],
            sin: &reg.sin_grade[range.clone()],
            cos: &reg.cos_grade[range.clone()],
            c: &reg.c[range.clone()],
            g_sin: &reg.g_sin[range.clone()],
            accel: &reg.accel[range],
            g: reg.g,
            force: None,
            speed: None,
            grade: None,
            output: None,
            derivative: derivative.map(|d| &d[..len]),
        };
        for (channel, &sd) in levels.iter() {
            let Some(e) = draws[channel] else { continue };
            let draw = Some(Draw { e: &e[..len], sd });
            // Each channel's `perturb`, written out here: a new channel fails to compile
            // until its perturbation is added to the pass.
            match channel {
                Channel::Velocity => inputs.speed = draw,
                Channel::Output => inputs.output = draw,
                // σ_θ = 0 moves nothing (GradeNoise::perturb).
                Channel::Grade => inputs.grade = draw.filter(|_| sd > 0.0),
                Channel::Force => inputs.force = draw,
            }
        }
        inputs
    }
}

/// One measured sample: x̃₁, w, x̃₃, s̃, ỹ.
type Row = [f64; 5];

/// Sample `j` measured by the scalar operations (the portable pass, the rows after the
/// last group of four, and a group with a grade angle outside the polynomials' range).
#[inline(always)]
fn row(x: &Inputs<'_>, j: usize) -> Row {
    let f = match x.force {
        Some(d) => x.f[j] + d.sd * d.e[j],
        None => x.f[j],
    };
    let v = match x.speed {
        Some(d) => x.v[j] + d.sd * d.e[j],
        None => x.v[j],
    };
    let (c, s) = match x.grade {
        Some(d) => {
            let (sin_d, cos_d) = sin_cos(d.sd * d.e[j]);
            let (sin0, cos0) = (x.sin[j], x.cos[j]);
            let sin = sin0 * cos_d + cos0 * sin_d;
            let cos = cos0 * cos_d - sin0 * sin_d;
            (-x.g * cos, x.g * sin)
        }
        None => (x.c[j], x.g_sin[j]),
    };
    let mut y = x.accel[j] + s;
    if let Some(d) = x.output {
        y += d.sd * d.e[j];
    }
    if let Some(d) = x.derivative {
        y += d[j];
    }
    [f, v * v, c, s, y]
}

/// Lanes of the block's sums, accumulator k of the terms of [`terms`]: sample i into lane
/// i mod 4 (the lanes of `row_sums.rs`).
type Lanes = [[f64; LANES]; TERMS];

const LANES: usize = 4;

/// Number of summed terms.
const TERMS: usize = 17;

/// The terms a sample adds to the block's sums, in the order of `segment_moments`' lists
/// (`row_sums.rs`): those of w or ỹ [x̃₁ỹ, x̃₃ỹ, x̃₁w, x̃₃w, w², wỹ, w, ỹ], those of x̃₁ and
/// x̃₃ alone [x̃₁², x̃₁x̃₃, x̃₃², x̃₁, x̃₃], and the grade term's [s̃, x̃₁s̃, x̃₃s̃, ws̃].
#[inline(always)]
fn terms([f, w, c, s, y]: Row) -> [f64; TERMS] {
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
fn moments(lanes: &Lanes, len: usize, regressors: bool, grade: bool) -> Moments {
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

/// What [`MeasuredBlock::measure_and_sum`] gives besides the sums that involve w or ỹ.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Wanted {
    /// The sums of x̃₁ and x̃₃ alone (zero without: `MomentAccumulator::finish` takes the
    /// regression's where those columns are noise-free).
    pub regressors: bool,
    /// The grade term's sums ([`GradeSums`]).
    pub grade: bool,
    /// The measured rows, for [`MeasuredBlock::view`]: without, the vectorised pass writes
    /// no columns and the block's rows are not to be read.
    pub rows: bool,
}

impl MeasuredBlock {
    /// [`measure`](Self::measure) in one pass over the samples; with `AVX2` (true only
    /// inside a function compiled for AVX2, called where the CPU has it) four samples per
    /// 256-bit register, lane for lane the portable operations.
    #[inline(always)]
    pub(super) fn measure_one_pass<const AVX2: bool>(&mut self, b: Block<'_>) {
        self.pass::<AVX2, false, false, false>(b, true);
    }

    /// The block measured as by [`measure`](Self::measure) and its moments as
    /// `segment_moments` (`row_sums.rs`) takes them from the measured rows, bit for bit;
    /// `wanted` says which sums besides those of w and ỹ, and whether the rows are kept.
    /// On x86-64 with AVX2 the sums are added in the pass, in the registers the samples are
    /// measured in (with AVX-512VL where the CPU has it: the same operations, more
    /// registers).
    pub fn measure_and_sum(&mut self, b: Block<'_>, wanted: Wanted) -> Moments {
        #[cfg(target_arch = "x86_64")]
        {
            use crate::numeric::simd;
            if simd::avx512vl() {
                // SAFETY: the CPU supports AVX-512F and VL (so AVX2), checked just above.
                return unsafe { self.measure_and_sum_avx512(b, wanted) };
            }
            if simd::avx2() {
                // SAFETY: the CPU supports AVX2, checked just above.
                return unsafe { self.measure_and_sum_avx2(b, wanted) };
            }
        }
        self.measure_and_sum_portable(b, wanted)
    }

    /// [`measure_and_sum`](Self::measure_and_sum) as two steps: the block measured
    /// ([`measure`](Self::measure)'s portable pass), then `segment_moments` of its rows.
    #[inline(always)]
    pub(super) fn measure_and_sum_portable(&mut self, b: Block<'_>, wanted: Wanted) -> Moments {
        self.measure_one_pass::<false>(b);
        // Zero sums of x̃₁ and x̃₃ alone where they are not wanted; the block's view never
        // says ỹ is the regression's, so its sums are always summed.
        let none = Moments::default();
        segment_moments(
            self.view(b.reg),
            0,
            b.len,
            (!wanted.regressors).then_some(&none),
            wanted.grade,
        )
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    pub(super) fn measure_and_sum_avx2(&mut self, b: Block<'_>, wanted: Wanted) -> Moments {
        self.measure_and_sum_simd(b, wanted)
    }

    /// The AVX2 pass compiled with AVX-512VL as well: the same 256-bit operations (no FMA:
    /// Rust contracts nothing), so the same bits, with 32 registers instead of 16 for the
    /// seventeen lane sums and the constants of the pass (fewer of them on the stack).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,avx512f,avx512vl")]
    fn measure_and_sum_avx512(&mut self, b: Block<'_>, wanted: Wanted) -> Moments {
        self.measure_and_sum_simd(b, wanted)
    }

    /// The pass of the AVX2 builds (always inlined into a function compiled for AVX2).
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn measure_and_sum_simd(&mut self, b: Block<'_>, wanted: Wanted) -> Moments {
        let rows = wanted.rows;
        let lanes = match (wanted.regressors, wanted.grade) {
            (true, true) => self.pass::<true, true, true, true>(b, rows),
            (true, false) => self.pass::<true, true, true, false>(b, rows),
            (false, true) => self.pass::<true, true, false, true>(b, rows),
            (false, false) => self.pass::<true, true, false, false>(b, rows),
        };
        moments(&lanes, b.len, wanted.regressors, wanted.grade)
    }

    /// The pass: the block measured (without `rows`, the vectorised pass writes no
    /// columns), and with `SUMS` (AVX2 only) the lanes of its sums of the terms that
    /// `REGRESSORS` and `GRADE` ask for (the others stay zero).
    #[inline(always)]
    fn pass<const AVX2: bool, const SUMS: bool, const REGRESSORS: bool, const GRADE: bool>(
        &mut self,
        b: Block<'_>,
        rows: bool,
    ) -> Lanes {
        let (start, len) = (b.start, b.len);
        let x = Inputs::new(b);
        (self.start, self.len) = (start, len);
        self.grade_moved = x.grade.is_some();
        self.columns.clear();
        let force = x.force.is_some();
        let f = self.columns.write(Quantity::Force, force);
        let mut out = [
            &mut f[..len],
            &mut self.w[..len],
            &mut self.c[..len],
            &mut self.s[..len],
            &mut self.y[..len],
        ];
        let mut lanes = [[0.0; LANES]; TERMS];
        #[allow(unused_mut)] // written on x86-64 only
        let mut done = 0;
        #[cfg(target_arch = "x86_64")]
        if AVX2 {
            // SAFETY: `AVX2` is set only inside functions compiled for AVX2, which are called
            // only where the CPU has it.
            (done, lanes) = unsafe {
                match (SUMS, REGRESSORS) {
                    (true, true) => simd::summed_groups::<GRADE>(&x, &mut out, len, rows),
                    _ => simd::groups::<SUMS, REGRESSORS, GRADE, { simd::RUNTIME }>(
                        &x, &mut out, len, rows,
                    ),
                }
            };
        }
        let [f, w, c, s, y] = out;
        for j in done..len {
            let r = row(&x, j);
            (f[j], w[j], c[j], s[j], y[j]) = (r[0], r[1], r[2], r[3], r[4]);
            if SUMS {
                // The samples after the last group, into lane 0 as `segment_moments` adds them.
                for (k, t) in terms(r).into_iter().enumerate() {
                    let wanted = k < REGRESSOR_TERMS
                        || (REGRESSORS && k < GRADE_TERMS)
                        || (GRADE && k >= GRADE_TERMS);
                    if wanted {
                        lanes[k][0] += t;
                    }
                }
            }
        }
        lanes
    }
}

#[cfg(target_arch = "x86_64")]
mod simd {
    //! The pass in 256-bit registers, four samples per group.
    //!
    //! Which channels move the block is a constant of the loop ([`Inputs::channels`]), so
    //! each combination the general path meets is compiled on its own, without a test of a
    //! channel per group; the inputs are read through pointers checked once per block.

    use std::arch::x86_64::*;

    use super::{Inputs, Lanes, TERMS, row};
    use crate::numeric::trig::simd::kernel4;

    /// Bits of the channels that move a block (the `CH` parameter of [`groups`]).
    pub(super) const FORCE: u8 = 1;
    pub(super) const SPEED: u8 = 2;
    pub(super) const GRADE_NOISE: u8 = 4;
    pub(super) const OUTPUT: u8 = 8;
    pub(super) const DERIVATIVE: u8 = 16;
    /// `CH` for a loop that reads which channels are on at run time.
    pub(super) const RUNTIME: u8 = u8::MAX;

    impl Inputs<'_> {
        /// The bits of the channels that move the block.
        pub(super) fn channels(&self) -> u8 {
            [
                (self.force.is_some(), FORCE),
                (self.speed.is_some(), SPEED),
                (self.grade.is_some(), GRADE_NOISE),
                (self.output.is_some(), OUTPUT),
                (self.derivative.is_some(), DERIVATIVE),
            ]
            .into_iter()
            .filter(|(on, _)| *on)
            .fold(0, |bits, (_, bit)| bits | bit)
        }
    }

    /// Whether the channel `bit` is on: a constant of the loop, or, for [`RUNTIME`], read
    /// from the inputs (`present`).
    #[inline(always)]
    fn on<const CH: u8>(bit: u8, present: bool) -> bool {
        if CH == RUNTIME {
            present
        } else {
            CH & bit != 0
        }
    }

    /// The block's inputs as pointers to `len` values each (null: the channel is off) and
    /// the standard deviations, read once before the loop.
    #[derive(Clone, Copy)]
    struct Flat {
        f: *const f64,
        v: *const f64,
        sin: *const f64,
        cos: *const f64,
        c: *const f64,
        g_sin: *const f64,
        accel: *const f64,
        g: f64,
        e_f: *const f64,
        e_v: *const f64,
        e_g: *const f64,
        e_o: *const f64,
        d: *const f64,
        sd_f: f64,
        sd_v: f64,
        sd_g: f64,
        sd_o: f64,
    }

    impl Flat {
        /// The pointers of `x`, whose slices all hold `len` values (checked).
        fn new(x: &Inputs<'_>, len: usize) -> Self {
            let ptr = |s: &[f64]| {
                assert_eq!(s.len(), len, "a column of the block");
                s.as_ptr()
            };
            let draw = |d: Option<super::Draw<'_>>| match d {
                Some(d) => (ptr(d.e), d.sd),
                None => (std::ptr::null(), 0.0),
            };
            let ((e_f, sd_f), (e_v, sd_v), (e_g, sd_g), (e_o, sd_o)) =
                (draw(x.force), draw(x.speed), draw(x.grade), draw(x.output));
            Flat {
                f: ptr(x.f),
                v: ptr(x.v),
                sin: ptr(x.sin),
                cos: ptr(x.cos),
                c: ptr(x.c),
                g_sin: ptr(x.g_sin),
                accel: ptr(x.accel),
                g: x.g,
                e_f,
                e_v,
                e_g,
                e_o,
                d: x.derivative.map_or(std::ptr::null(), ptr),
                sd_f,
                sd_v,
                sd_g,
                sd_o,
            }
        }
    }

    /// Four values from `p + i`.
    ///
    /// # Safety
    /// `p` points at least at `i + 4` values; the CPU supports AVX2.
    #[inline(always)]
    unsafe fn load(p: *const f64, i: usize) -> __m256d {
        // SAFETY: as the caller promises.
        unsafe { _mm256_loadu_pd(p.add(i)) }
    }

    /// Four values to `p + i`.
    ///
    /// # Safety
    /// `p` points at least at `i + 4` values; the CPU supports AVX2.
    #[inline(always)]
    unsafe fn store(p: *mut f64, i: usize, v: __m256d) {
        // SAFETY: as the caller promises.
        unsafe { _mm256_storeu_pd(p.add(i), v) }
    }

    /// The measured values `[x̃₁, w, x̃₃, s̃, ỹ]` of the group of samples `i..i + 4`, and
    /// the mask of its grade angles outside the polynomials' range (whose values the
    /// caller replaces).
    ///
    /// # Safety
    /// The CPU supports AVX2, `i + 4 <= len` of [`Flat::new`], and a channel `CH` says is
    /// on has its pointer (called only from [`groups`]).
    #[inline(always)]
    unsafe fn measure4<const CH: u8>(x: &Flat, i: usize) -> ([__m256d; 5], i32) {
        // SAFETY: the CPU supports AVX2; every pointer read holds `i + 4` values.
        unsafe {
            let (add, mul, set) = (_mm256_add_pd, _mm256_mul_pd, _mm256_set1_pd);
            let v = match on::<CH>(SPEED, !x.e_v.is_null()) {
                true => add(load(x.v, i), mul(set(x.sd_v), load(x.e_v, i))),
                false => load(x.v, i),
            };
            let w = mul(v, v);
            let f = match on::<CH>(FORCE, !x.e_f.is_null()) {
                true => add(load(x.f, i), mul(set(x.sd_f), load(x.e_f, i))),
                false => load(x.f, i),
            };
            let (c, s, outside) = match on::<CH>(GRADE_NOISE, !x.e_g.is_null()) {
                true => {
                    let (sin_d, cos_d, outside) = kernel4(mul(set(x.sd_g), load(x.e_g, i)));
                    let (sin0, cos0) = (load(x.sin, i), load(x.cos, i));
                    let sin = add(mul(sin0, cos_d), mul(cos0, sin_d));
                    let cos = _mm256_sub_pd(mul(cos0, cos_d), mul(sin0, sin_d));
                    (mul(set(-x.g), cos), mul(set(x.g), sin), outside)
                }
                false => (load(x.c, i), load(x.g_sin, i), 0),
            };
            let mut y = add(load(x.accel, i), s);
            if on::<CH>(OUTPUT, !x.e_o.is_null()) {
                y = add(y, mul(set(x.sd_o), load(x.e_o, i)));
            }
            if on::<CH>(DERIVATIVE, !x.d.is_null()) {
                y = add(y, load(x.d, i));
            }
            ([f, w, c, s, y], outside)
        }
    }

    /// The group `i..i + 4` measured by the scalar [`row`] into the columns `out` (a group
    /// with a grade angle outside the polynomials' range), and its values.
    ///
    /// # Safety
    /// The CPU supports AVX2; each of `out` points at `i + 4` values.
    #[cold]
    #[inline(never)]
    #[target_feature(enable = "avx2")]
    unsafe fn scalar4(x: &Inputs<'_>, out: [*mut f64; 5], i: usize) -> [__m256d; 5] {
        // SAFETY: each column holds `i + 4` values.
        unsafe {
            for j in i..i + 4 {
                for (column, value) in out.iter().zip(row(x, j)) {
                    *column.add(j) = value;
                }
            }
            // The scalar rows' values (x̃₁, x̃₃, s̃ written there whether moved or not).
            out.map(|column| load(column, i))
        }
    }

    /// The groups of four samples of `0..len` into the columns `[x̃₁, w, x̃₃, s̃, ỹ]`
    /// (with `rows` only; x̃₁ written under force noise only, x̃₃ and s̃ under grade noise
    /// only) and, with
    /// `SUMS`, their terms into the lanes (those `REGRESSORS` and `GRADE` ask for); returns
    /// the first sample not done (a multiple of four) and the lanes. `CH` is
    /// [`Inputs::channels`] or [`RUNTIME`]. A group with a grade angle outside the
    /// polynomials' range is measured by the scalar [`row`] instead, as `sin_cos_slice`
    /// hands such an angle to `f64::sin_cos`.
    ///
    /// # Safety
    /// The CPU supports AVX2; always inlined into a function compiled for it (a function
    /// compiled for AVX2 cannot be forced inline), whose features the loop is compiled with.
    #[inline(always)]
    pub(super) unsafe fn groups<
        const SUMS: bool,
        const REGRESSORS: bool,
        const GRADE: bool,
        const CH: u8,
    >(
        x: &Inputs<'_>,
        out: &mut [&mut [f64]; 5],
        len: usize,
        rows: bool,
    ) -> (usize, Lanes) {
        assert!(CH == RUNTIME || CH == x.channels(), "the pass's channels");
        let p = Flat::new(x, len);
        let columns = out.each_mut().map(|column| {
            assert_eq!(column.len(), len, "a measured column");
            column.as_mut_ptr()
        });
        let [f_out, w_out, c_out, s_out, y_out] = columns;
        let (force, grade) = (
            on::<CH>(FORCE, !p.e_f.is_null()),
            on::<CH>(GRADE_NOISE, !p.e_g.is_null()),
        );
        let whole = len - len % 4;
        // SAFETY (here and below): the CPU supports AVX2, as the caller promises.
        let mut acc = [unsafe { _mm256_setzero_pd() }; TERMS];
        for i in (0..whole).step_by(4) {
            // SAFETY: i + 4 <= len, the length of every input (checked by `Flat::new`) and
            // column.
            unsafe {
                let (mut values, outside) = measure4::<CH>(&p, i);
                if rows {
                    if force {
                        store(f_out, i, values[0]);
                    }
                    if grade {
                        store(c_out, i, values[2]);
                        store(s_out, i, values[3]);
                    }
                    store(w_out, i, values[1]);
                    store(y_out, i, values[4]);
                }
                if outside != 0 {
                    values = scalar4(x, columns, i);
                }
                if SUMS {
                    let [f, w, c, s, y] = values;
                    let (add, mul) = (_mm256_add_pd, _mm256_mul_pd);
                    let mut term = |k: usize, t: __m256d| acc[k] = add(acc[k], t);
                    term(0, mul(f, y));
                    term(1, mul(c, y));
                    term(2, mul(f, w));
                    term(3, mul(c, w));
                    term(4, mul(w, w));
                    term(5, mul(w, y));
                    term(6, w);
                    term(7, y);
                    if REGRESSORS {
                        term(8, mul(f, f));
                        term(9, mul(f, c));
                        term(10, mul(c, c));
                        term(11, f);
                        term(12, c);
                    }
                    if GRADE {
                        term(13, s);
                        term(14, mul(f, s));
                        term(15, mul(c, s));
                        term(16, mul(w, s));
                    }
                }
            }
        }
        let mut lanes = [[0.0; 4]; TERMS];
        if SUMS {
            for (l, a) in lanes.iter_mut().zip(acc) {
                // SAFETY: writes four f64 into an array of four.
                unsafe { _mm256_storeu_pd(l.as_mut_ptr(), a) };
            }
        }
        (whole, lanes)
    }

    /// [`groups`] with the sums of the general path's kernel (`REGRESSORS` set), compiled
    /// for the block's channels: one loop per combination of force or grade noise (one is
    /// on on the general path) with speed noise, output noise and a differentiated
    /// acceleration, each on or off.
    ///
    /// # Safety
    /// As [`groups`].
    #[inline(always)]
    pub(super) unsafe fn summed_groups<const GRADE: bool>(
        x: &Inputs<'_>,
        out: &mut [&mut [f64]; 5],
        len: usize,
        rows: bool,
    ) -> (usize, Lanes) {
        macro_rules! by_channels {
            ($($ch:literal)*) => {
                // SAFETY: as the caller promises.
                unsafe {
                    match x.channels() {
                        $($ch => groups::<true, true, GRADE, $ch>(x, out, len, rows),)*
                        _ => groups::<true, true, GRADE, RUNTIME>(x, out, len, rows),
                    }
                }
            };
        }
        // Every value with FORCE (1) or GRADE_NOISE (4) set, below 32.
        by_channels!(1 3 4 5 6 7 9 11 12 13 14 15 17 19 20 21 22 23 25 27 28 29 30 31)
    }
}
