//! A realisation's own regression made from its condition's where only part of its rows is
//! drawn anew (a calibration of the force, the elevation map's error in the grade): the
//! columns that stay are shared, the new ones written into the thread's spare storage, and
//! only the sums that hold a new column taken again. Each sum is exactly rounded from the
//! same products, so the result is bit for bit the regression built whole from those rows
//! (docs/model.md#model-errors).

use nalgebra::Vector3;

use super::derived::Derived;
use super::{Column, DragDot, Regression};
use crate::estimate::sums::GradeSums;
#[cfg(target_arch = "x86_64")]
use crate::numeric::simd::Avx2;
use crate::numeric::simd::{Lanes4, Quad, Real};
use crate::numeric::sum::{Dot, LaneSums, Plain, SquareDot, exact_sum_of};

impl Regression {
    /// This regression with its force column F logged through `log` (a calibration drawn
    /// per realisation, which replaces each force of the column it is given by the logged
    /// one): bit for bit the regression built from the logged force.
    pub fn with_force(&self, log: impl FnOnce(&mut [f64])) -> Regression {
        let f = Column::filled(self.len(), |f| {
            f.copy_from_slice(&self.f);
            log(f);
        });
        let dot = |a: &[f64], b: &[f64]| exact_sum_of(&Dot(a, b));
        let mut reg = self.clone();
        reg.xtx[(0, 0)] = dot(&f, &f);
        reg.xtx[(0, 1)] = exact_sum_of(&DragDot {
            a: &f,
            v: &self.v,
            k: self.k,
        });
        reg.xtx[(0, 2)] = dot(&f, &self.c);
        reg.xtx[(1, 0)] = reg.xtx[(0, 1)];
        reg.xtx[(2, 0)] = reg.xtx[(0, 2)];
        reg.xty[0] = dot(&f, &self.y);
        reg.grade_sums_noise_free.s_1s = dot(&f, &self.g_sin);
        reg.sum_f = exact_sum_of(&Plain(&f));
        reg.f = f;
        reg.derived = Derived::default();
        reg
    }

    /// This regression with the grade of each row replaced by the one whose sine and cosine
    /// are given (an elevation map's error drawn per realisation): the force, speed and
    /// acceleration stay, the sums that hold only them are kept and the rest taken again,
    /// so the result is bit for bit [`Regression::with_sin_cos`] of the rows with that
    /// grade.
    pub fn with_grade(&self, sin_grade: Column, cos_grade: Column) -> Regression {
        assert!(
            sin_grade.len() == self.len() && cos_grade.len() == self.len(),
            "a grade per row"
        );
        assert!(
            self.differentiation.is_none(),
            "a model acceleration's regression"
        );
        let n = self.len();
        let mut fast = [None; GRADE_SUMS];
        let [c, g_sin, y] = Column::filled_together(n, |out| {
            fast = grade_pass(self, &sin_grade, &cos_grade, out);
        });
        // Each sum the bound could not decide, exactly from its terms.
        let dot = |a: &[f64], b: &[f64]| exact_sum_of(&Dot(a, b));
        let drag = |a: &[f64]| {
            exact_sum_of(&DragDot {
                a,
                v: &self.v,
                k: self.k,
            })
        };
        let f = &self.f;
        let exact: [&dyn Fn() -> f64; GRADE_SUMS] = [
            &|| dot(f, &c),
            &|| drag(&c),
            &|| dot(&c, &c),
            &|| dot(f, &y),
            &|| drag(&y),
            &|| dot(&c, &y),
            &|| exact_sum_of(&Plain(&g_sin)),
            &|| dot(f, &g_sin),
            &|| dot(&c, &g_sin),
            &|| exact_sum_of(&SquareDot(&self.v, &g_sin)),
            &|| exact_sum_of(&Plain(&c)),
            &|| exact_sum_of(&Plain(&y)),
        ];
        let [f_c, w_c, c_c, f_y, w_y, c_y, s, f_s, c_s, ws, sum_c, sum_y] =
            std::array::from_fn(|i| fast[i].unwrap_or_else(exact[i]));
        let mut reg = self.clone();
        reg.xtx[(0, 2)] = f_c;
        reg.xtx[(1, 2)] = w_c;
        reg.xtx[(2, 2)] = c_c;
        reg.xtx[(2, 0)] = f_c;
        reg.xtx[(2, 1)] = w_c;
        reg.xty = Vector3::new(f_y, w_y, c_y);
        reg.grade_sums_noise_free = GradeSums {
            s_s: s,
            s_1s: f_s,
            s_3s: c_s,
            s_ws: ws,
        };
        reg.sum_c = sum_c;
        reg.sum_y = sum_y;
        reg.c = c;
        reg.y = y;
        reg.g_sin = g_sin;
        reg.sin_grade = sin_grade;
        reg.cos_grade = cos_grade;
        reg.derived = Derived::default();
        reg
    }
}

/// The sums of a regression that hold its grade: XᵀX's (0, 2), (1, 2), (2, 2), Xᵀy, the
/// grade term's four, Σc and Σy.
const GRADE_SUMS: usize = 12;

/// One pass over the rows of `reg` with the grade of sine `sin` and cosine `cos`: writes
/// c = −g cos θ, g sin θ and y = dV/dt + g sin θ into `out` (as `grade_columns` makes them)
/// and sums the [`GRADE_SUMS`] terms of each row, each as its exactly rounded sum takes it
/// (`None` where the bound cannot decide). Compiled for AVX2 where the CPU has it.
fn grade_pass(
    reg: &Regression,
    sin: &[f64],
    cos: &[f64],
    out: [&mut [f64]; 3],
) -> [Option<f64>; GRADE_SUMS] {
    #[cfg(target_arch = "x86_64")]
    if let Some(avx2) = Avx2::detect() {
        // SAFETY: the token proves AVX2; the CPU has AVX-512F and VL where asked.
        return unsafe {
            match crate::numeric::simd::avx512vl() {
                true => grade_pass_avx512(avx2, reg, sin, cos, out),
                false => grade_pass_avx2(avx2, reg, sin, cos, out),
            }
        };
    }
    grade_pass_lanes(Quad, reg, sin, cos, out)
}

/// [`grade_pass_avx2`] compiled with AVX-512VL as well: the same 256-bit operations (no
/// FMA: Rust contracts nothing), so the same bits, with 32 registers for the twelve sums'
/// running values, errors and magnitudes instead of 16.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,avx512f,avx512vl")]
fn grade_pass_avx512(
    avx2: Avx2,
    reg: &Regression,
    sin: &[f64],
    cos: &[f64],
    out: [&mut [f64]; 3],
) -> [Option<f64>; GRADE_SUMS] {
    grade_pass_lanes(avx2, reg, sin, cos, out)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn grade_pass_avx2(
    avx2: Avx2,
    reg: &Regression,
    sin: &[f64],
    cos: &[f64],
    out: [&mut [f64]; 3],
) -> [Option<f64>; GRADE_SUMS] {
    grade_pass_lanes(avx2, reg, sin, cos, out)
}

/// [`grade_pass`] in the lanes of `l`, the rows beyond the last whole block one by one.
#[inline(always)]
fn grade_pass_lanes<L: Lanes4>(
    l: L,
    reg: &Regression,
    sin: &[f64],
    cos: &[f64],
    [c_out, s_out, y_out]: [&mut [f64]; 3],
) -> [Option<f64>; GRADE_SUMS] {
    let n = reg.len();
    let (f, v, accel) = (&reg.f[..], &reg.v[..], &reg.accel[..]);
    assert!(sin.len() == n && cos.len() == n && c_out.len() == n);
    assert!(s_out.len() == n && y_out.len() == n);
    let mut sums = LaneSums::<L, GRADE_SUMS>::new(l);
    let whole = n - n % L::WIDTH;
    let (minus_g, g, minus_k) = (l.splat(-reg.g), l.splat(reg.g), l.splat(-reg.k));
    for i in (0..whole).step_by(L::WIDTH) {
        let (fi, vi) = (l.load(f, i), l.load(v, i));
        let c = minus_g * l.load(cos, i);
        let s = g * l.load(sin, i);
        let y = l.load(accel, i) + s;
        let w = minus_k * vi * vi;
        l.store(c, c_out, i);
        l.store(s, s_out, i);
        l.store(y, y_out, i);
        sums.add(grade_terms(fi, vi, w, c, s, y));
    }
    for i in whole..n {
        let c = -reg.g * cos[i];
        let s = reg.g * sin[i];
        let y = accel[i] + s;
        let w = -reg.k * v[i] * v[i];
        (c_out[i], s_out[i], y_out[i]) = (c, s, y);
        sums.add_row(grade_terms(f[i], v[i], w, c, s, y));
    }
    sums.finish(l, n)
}

/// The [`GRADE_SUMS`] terms of a row with force `f`, speed `v`, column 2 `w`, column 3 `c`,
/// grade term `s` and output `y`, each product rounded as its sum's [`Terms`](crate::numeric::sum::Terms) rounds it.
#[inline(always)]
fn grade_terms<R: Real>(f: R, v: R, w: R, c: R, s: R, y: R) -> [R; GRADE_SUMS] {
    [
        f * c,
        c * w,
        c * c,
        f * y,
        y * w,
        c * y,
        s,
        f * s,
        c * s,
        v * v * s,
        c,
        y,
    ]
}

impl Drop for Regression {
    /// Its columns that nothing else holds become the thread's spare storage.
    fn drop(&mut self) {
        for column in [
            &self.t,
            &self.f,
            &self.c,
            &self.v,
            &self.y,
            &self.accel,
            &self.g_sin,
            &self.sin_grade,
            &self.cos_grade,
        ] {
            column.recycle();
        }
    }
}
