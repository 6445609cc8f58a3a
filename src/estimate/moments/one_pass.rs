//! The general path's block measured in one pass: every channel's perturbation of a sample,
//! the grade's small-angle sine and cosine and the angle addition, and the columns w, x̃₃,
//! s̃, ỹ (and x̃₁ under force noise), four samples at a time in registers. The same IEEE
//! operations in the same order as the channels' [`perturb`](crate::estimate::channels::Channel::perturb)
//! column by column followed by the column passes of `MeasuredBlock::measure_by_channels`,
//! so the same bits (docs/model.md#sufficient-statistics); only the memory traffic between
//! the passes is gone.

use super::MeasuredBlock;
use crate::estimate::channels::{BlockNoise, Channel, NoiseLevels, Quantity};
use crate::estimate::regression::Regression;
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
        #[allow(unused_mut)] // written on x86-64 only
        let mut done = 0;
        #[cfg(target_arch = "x86_64")]
        if AVX2 {
            // SAFETY: `AVX2` is set only inside functions compiled for AVX2, which are called
            // only where the CPU has it.
            done = unsafe { simd::groups(&x, &mut out, len) };
        }
        let [f, w, c, s, y] = out;
        for j in done..len {
            let r = row(&x, j);
            (f[j], w[j], c[j], s[j], y[j]) = (r[0], r[1], r[2], r[3], r[4]);
        }
    }
}

#[cfg(target_arch = "x86_64")]
mod simd {
    //! The pass in 256-bit registers, four samples per group.

    use std::arch::x86_64::*;

    use super::{Inputs, row};
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

    /// The groups of four samples of `0..len` into the columns `[x̃₁, w, x̃₃, s̃, ỹ]`
    /// (x̃₁ written under force noise only, x̃₃ and s̃ under grade noise only); returns
    /// the first sample not done (a multiple of four). A group with a grade angle outside
    /// the polynomials' range is measured by the scalar [`row`] instead, as
    /// `sin_cos_slice` hands such an angle to `f64::sin_cos`.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub(super) fn groups(x: &Inputs<'_>, out: &mut [&mut [f64]; 5], len: usize) -> usize {
        let [f_out, w_out, c_out, s_out, y_out] = out;
        let whole = len - len % 4;
        let (add, mul) = (_mm256_add_pd, _mm256_mul_pd);
        let set = _mm256_set1_pd;
        let minus_g = set(-x.g);
        let g = set(x.g);
        let mut i = 0;
        while i < whole {
            let v = match x.speed {
                Some(d) => add(load(x.v, i), mul(set(d.sd), load(d.e, i))),
                None => load(x.v, i),
            };
            store(w_out, i, mul(v, v));
            if let Some(d) = x.force {
                store(f_out, i, add(load(x.f, i), mul(set(d.sd), load(d.e, i))));
            }
            let s = match x.grade {
                Some(d) => {
                    let (sin_d, cos_d, outside) = kernel4(mul(set(d.sd), load(d.e, i)));
                    if outside != 0 {
                        for j in i..i + 4 {
                            let r = row(x, j);
                            (f_out[j], w_out[j], c_out[j], s_out[j], y_out[j]) =
                                (r[0], r[1], r[2], r[3], r[4]);
                        }
                        i += 4;
                        continue;
                    }
                    let (sin0, cos0) = (load(x.sin, i), load(x.cos, i));
                    let sin = add(mul(sin0, cos_d), mul(cos0, sin_d));
                    let cos = _mm256_sub_pd(mul(cos0, cos_d), mul(sin0, sin_d));
                    store(c_out, i, mul(minus_g, cos));
                    let s = mul(g, sin);
                    store(s_out, i, s);
                    s
                }
                None => load(x.g_sin, i),
            };
            let mut y = add(load(x.accel, i), s);
            if let Some(d) = x.output {
                y = add(y, mul(set(d.sd), load(d.e, i)));
            }
            if let Some(d) = x.derivative {
                y = add(y, load(d, i));
            }
            store(y_out, i, y);
            i += 4;
        }
        whole
    }
}
