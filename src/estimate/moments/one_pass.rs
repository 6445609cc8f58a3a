//! The general path's block measured in one pass: every channel's perturbation of a sample,
//! the grade's small-angle sine and cosine and the angle addition, and the columns w, x̃₃,
//! s̃, ỹ (and x̃₁ under force noise), four samples at a time in registers; with AVX2 the
//! block's sums are added in the same pass, in the lanes `segment_moments` (`row_sums.rs`)
//! uses. The same IEEE operations in the same order as the channels'
//! [`perturb`](crate::estimate::channels::Channel::perturb) column by column, the column
//! passes of `MeasuredBlock::measure_by_channels` and `segment_moments` over the rows, so
//! the same bits (docs/model.md#sufficient-statistics); only the memory traffic between
//! the passes is gone.

use super::{GradeSums, MeasuredBlock, Moments};
use crate::estimate::channels::{BlockNoise, Channel, NoiseLevels, Quantity};
use crate::estimate::regression::Regression;
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
    fn new(
        reg: &'a Regression,
        levels: &NoiseLevels,
        start: usize,
        len: usize,
        draws: BlockNoise<'a>,
        derivative: Option<&'a [f64]>,
    ) -> Self {
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

impl MeasuredBlock {
    /// [`measure`](Self::measure) in one pass over the samples; with `AVX2` (true only
    /// inside a function compiled for AVX2, called where the CPU has it) four samples per
    /// 256-bit register, lane for lane the portable operations.
    #[inline(always)]
    pub(super) fn measure_one_pass<const AVX2: bool>(
        &mut self,
        reg: &Regression,
        levels: &NoiseLevels,
        start: usize,
        len: usize,
        draws: BlockNoise<'_>,
        derivative: Option<&[f64]>,
    ) {
        self.pass::<AVX2, false, false, false>(reg, levels, start, len, draws, derivative);
    }

    /// The block measured as by [`measure`](Self::measure) and its moments as
    /// `segment_moments` (`row_sums.rs`) takes them from the measured rows, bit for bit:
    /// without `regressors` the sums of x̃₁ and x̃₃ alone are zero, without `grade` there
    /// are no grade sums. On x86-64 with AVX2 the sums are added in the pass, in the
    /// registers the samples are measured in.
    #[allow(clippy::too_many_arguments)]
    pub fn measure_and_sum(
        &mut self,
        reg: &Regression,
        levels: &NoiseLevels,
        start: usize,
        len: usize,
        draws: BlockNoise<'_>,
        derivative: Option<&[f64]>,
        regressors: bool,
        grade: bool,
    ) -> Moments {
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx2") {
                // SAFETY: the CPU supports AVX2, checked just above.
                return unsafe {
                    self.measure_and_sum_avx2(
                        reg, levels, start, len, draws, derivative, regressors, grade,
                    )
                };
            }
        }
        self.measure_and_sum_portable(
            reg, levels, start, len, draws, derivative, regressors, grade,
        )
    }

    /// [`measure_and_sum`](Self::measure_and_sum) as two steps: the block measured
    /// ([`measure`](Self::measure)'s portable pass), then `segment_moments` of its rows.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub(super) fn measure_and_sum_portable(
        &mut self,
        reg: &Regression,
        levels: &NoiseLevels,
        start: usize,
        len: usize,
        draws: BlockNoise<'_>,
        derivative: Option<&[f64]>,
        regressors: bool,
        grade: bool,
    ) -> Moments {
        self.measure_one_pass::<false>(reg, levels, start, len, draws, derivative);
        let none = Moments::default();
        segment_moments(
            self.view(reg),
            0,
            len,
            (!regressors).then_some(&none),
            grade,
        )
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    #[allow(clippy::too_many_arguments)]
    fn measure_and_sum_avx2(
        &mut self,
        reg: &Regression,
        levels: &NoiseLevels,
        start: usize,
        len: usize,
        draws: BlockNoise<'_>,
        derivative: Option<&[f64]>,
        regressors: bool,
        grade: bool,
    ) -> Moments {
        let (r, d) = (reg, derivative);
        let lanes = match (regressors, grade) {
            (true, true) => self.pass::<true, true, true, true>(r, levels, start, len, draws, d),
            (true, false) => self.pass::<true, true, true, false>(r, levels, start, len, draws, d),
            (false, true) => self.pass::<true, true, false, true>(r, levels, start, len, draws, d),
            (false, false) => {
                self.pass::<true, true, false, false>(r, levels, start, len, draws, d)
            }
        };
        moments(&lanes, len, regressors, grade)
    }

    /// The pass: the block measured, and with `SUMS` (AVX2 only) the lanes of its sums of
    /// the terms that `REGRESSORS` and `GRADE` ask for (the others stay zero).
    #[inline(always)]
    fn pass<const AVX2: bool, const SUMS: bool, const REGRESSORS: bool, const GRADE: bool>(
        &mut self,
        reg: &Regression,
        levels: &NoiseLevels,
        start: usize,
        len: usize,
        draws: BlockNoise<'_>,
        derivative: Option<&[f64]>,
    ) -> Lanes {
        let x = Inputs::new(reg, levels, start, len, draws, derivative);
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
            (done, lanes) = unsafe { simd::groups::<SUMS, REGRESSORS, GRADE>(&x, &mut out, len) };
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

    use std::arch::x86_64::*;

    use super::{Inputs, Lanes, TERMS, row};
    use crate::numeric::trig::simd::kernel4;

    #[inline]
    #[target_feature(enable = "avx2")]
    fn load(x: &[f64], i: usize) -> __m256d {
        assert!(i + 4 <= x.len());
        // SAFETY: bounds checked just above.
        unsafe { _mm256_loadu_pd(x.as_ptr().add(i)) }
    }

    #[inline]
    #[target_feature(enable = "avx2")]
    fn store(x: &mut [f64], i: usize, v: __m256d) {
        assert!(i + 4 <= x.len());
        // SAFETY: bounds checked just above.
        unsafe { _mm256_storeu_pd(x.as_mut_ptr().add(i), v) }
    }

    /// The measured values `[x̃₁, w, x̃₃, s̃, ỹ]` of the group of samples `i..i + 4`, and
    /// the mask of its grade angles outside the polynomials' range (whose values the
    /// caller replaces).
    ///
    /// # Safety
    /// The CPU supports AVX2 (called only from [`groups`]).
    #[inline(always)]
    unsafe fn measure4(x: &Inputs<'_>, i: usize) -> ([__m256d; 5], i32) {
        // SAFETY: the CPU supports AVX2.
        unsafe {
            let (add, mul, set) = (_mm256_add_pd, _mm256_mul_pd, _mm256_set1_pd);
            let v = match x.speed {
                Some(d) => add(load(x.v, i), mul(set(d.sd), load(d.e, i))),
                None => load(x.v, i),
            };
            let w = mul(v, v);
            let f = match x.force {
                Some(d) => add(load(x.f, i), mul(set(d.sd), load(d.e, i))),
                None => load(x.f, i),
            };
            let (c, s, outside) = match x.grade {
                Some(d) => {
                    let (sin_d, cos_d, outside) = kernel4(mul(set(d.sd), load(d.e, i)));
                    let (sin0, cos0) = (load(x.sin, i), load(x.cos, i));
                    let sin = add(mul(sin0, cos_d), mul(cos0, sin_d));
                    let cos = _mm256_sub_pd(mul(cos0, cos_d), mul(sin0, sin_d));
                    (mul(set(-x.g), cos), mul(set(x.g), sin), outside)
                }
                None => (load(x.c, i), load(x.g_sin, i), 0),
            };
            let mut y = add(load(x.accel, i), s);
            if let Some(d) = x.output {
                y = add(y, mul(set(d.sd), load(d.e, i)));
            }
            if let Some(d) = x.derivative {
                y = add(y, load(d, i));
            }
            ([f, w, c, s, y], outside)
        }
    }

    /// Write the group `i..i + 4` measured as `values` (with `outside` the mask of
    /// [`measure4`]: such a group is measured again by the scalar [`row`]) into the columns
    /// and, with `SUMS`, add its terms to the lanes.
    ///
    /// # Safety
    /// The CPU supports AVX2 (called only from [`groups`]).
    #[inline(always)]
    unsafe fn finish4<const SUMS: bool, const REGRESSORS: bool, const GRADE: bool>(
        x: &Inputs<'_>,
        out: &mut [&mut [f64]; 5],
        acc: &mut [__m256d; TERMS],
        i: usize,
        values: [__m256d; 5],
        outside: i32,
    ) {
        // SAFETY: the CPU supports AVX2.
        unsafe {
            let [mut f, mut w, mut c, mut s, mut y] = values;
            let [f_out, w_out, c_out, s_out, y_out] = out;
            if x.force.is_some() {
                store(f_out, i, f);
            }
            if x.grade.is_some() {
                store(c_out, i, c);
                store(s_out, i, s);
            }
            store(w_out, i, w);
            store(y_out, i, y);
            if outside != 0 {
                for j in i..i + 4 {
                    let r = row(x, j);
                    (f_out[j], w_out[j], c_out[j], s_out[j], y_out[j]) =
                        (r[0], r[1], r[2], r[3], r[4]);
                }
                // The scalar rows' values (x̃₁, x̃₃, s̃ written there whether moved or not).
                (f, w, c, s, y) = (
                    load(f_out, i),
                    load(w_out, i),
                    load(c_out, i),
                    load(s_out, i),
                    load(y_out, i),
                );
            }
            if SUMS {
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

    /// The groups of four samples of `0..len` into the columns `[x̃₁, w, x̃₃, s̃, ỹ]`
    /// (x̃₁ written under force noise only, x̃₃ and s̃ under grade noise only) and, with
    /// `SUMS`, their terms into the lanes (those `REGRESSORS` and `GRADE` ask for); returns
    /// the first sample not done (a multiple of four) and the lanes. A group with a grade
    /// angle outside the polynomials' range is measured by the scalar [`row`] instead, as
    /// `sin_cos_slice` hands such an angle to `f64::sin_cos`.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub(super) fn groups<const SUMS: bool, const REGRESSORS: bool, const GRADE: bool>(
        x: &Inputs<'_>,
        out: &mut [&mut [f64]; 5],
        len: usize,
    ) -> (usize, Lanes) {
        let whole = len - len % 4;
        let mut acc = [_mm256_setzero_pd(); TERMS];
        for i in (0..whole).step_by(4) {
            // SAFETY: this function is compiled for AVX2 and called where the CPU has it.
            unsafe {
                let (values, outside) = measure4(x, i);
                finish4::<SUMS, REGRESSORS, GRADE>(x, out, &mut acc, i, values, outside);
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
}
