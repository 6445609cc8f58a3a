//! The accumulator that builds the per-realisation sums of the vehicle regression
//! ([`Moments`], defined with the typed list of sums in `sums.rs`) block by block from the
//! noise draws (the kernel).
//!
//! A realisation is summarised by the [`Moments`] of its noisy columns: with w = Ṽ² the
//! middle column is −k w, so XᵀX and Xᵀy need only sums of products of (x₁, w, x₃, y). The
//! kernel never forms the N×3 matrix.

use super::channels::{BlockNoise, Channel, NoiseLevels, Sample};
use super::kernels::{Columns, ZEROS, output_sums, speed_sums};
use super::regression::Regression;
pub use super::sums::{GradeSums, Moments};

/// Row `i` of the measured regression, (x̃₁, w = Ṽ², x̃₃, ỹ, s̃ = g sin θ̃), with each
/// channel's standard-normal draw `draw(channel)` (0 when it is off), and the noise of a
/// differentiated acceleration \[m/s²\] where there is one.
#[inline]
fn measured_row(
    reg: &Regression,
    levels: &NoiseLevels,
    i: usize,
    draw: impl Fn(Channel) -> f64,
    derivative: Option<f64>,
) -> [f64; 5] {
    let mut s = Sample {
        f: reg.f[i],
        v: reg.v[i],
        sin_grade: reg.sin_grade[i],
        cos_grade: reg.cos_grade[i],
        output_noise: 0.0,
    };
    for (c, sd) in levels.iter() {
        c.perturb(&mut s, *sd, draw(c));
    }
    let x1 = s.f;
    let w = s.v * s.v;
    let x3 = -reg.g * s.cos_grade;
    let grade = reg.g * s.sin_grade;
    let mut y = reg.accel[i] + grade + s.output_noise;
    if let Some(d) = derivative {
        y += d;
    }
    [x1, w, x3, y, grade]
}

/// The measured rows of one realisation, for estimators that need more than the sums
/// (weighted and recursive ones). A column the noise does not touch is not copied: the
/// regression's own column stands in for it (see [`Rows::view`]).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Rows {
    /// w = Ṽ² \[m²/s²\] (column 2 is −k w).
    w: Vec<f64>,
    /// x̃₁ = F̃ \[N\] (`None`: noise-free).
    f: Option<Vec<f64>>,
    /// x̃₃ = −g cos θ̃ \[m/s²\] (`None`: noise-free).
    c: Option<Vec<f64>>,
    /// ỹ \[m/s²\] (`None`: noise-free).
    y: Option<Vec<f64>>,
    /// s̃ = g sin θ̃ \[m/s²\] (`None`: noise-free).
    s: Option<Vec<f64>>,
    /// Whether f, c, y and s are copied in this realisation (else the regression's stand in).
    copies: [bool; 4],
}

/// The measured rows as columns: x̃₁ = F̃, w = Ṽ², x̃₃ = −g cos θ̃, ỹ, s̃ = g sin θ̃.
#[derive(Debug, Clone, Copy)]
pub struct RowsView<'a> {
    /// x̃₁ = F̃ \[N\].
    pub f: &'a [f64],
    /// w = Ṽ² \[m²/s²\].
    pub w: &'a [f64],
    /// x̃₃ = −g cos θ̃ \[m/s²\].
    pub c: &'a [f64],
    /// ỹ \[m/s²\].
    pub y: &'a [f64],
    /// s̃ = g sin θ̃, the grade term of ỹ \[m/s²\].
    pub s: &'a [f64],
    /// True when x̃₁ and x̃₃ are the regression's noise-free columns.
    pub noise_free_f_c: bool,
}

impl RowsView<'_> {
    /// Number of rows.
    pub fn len(&self) -> usize {
        self.w.len()
    }

    /// True when there are none.
    pub fn is_empty(&self) -> bool {
        self.w.is_empty()
    }
}

impl Rows {
    /// Empty rows of `reg` under `noise`, with room for all of them.
    pub fn new(reg: &Regression, noise: &NoiseLevels) -> Self {
        let mut rows = Rows::default();
        rows.reset(reg, noise);
        rows
    }

    /// Empty these rows for a realisation of `reg` under `noise`, keeping their memory
    /// (a thread reuses one `Rows` for all its realisations).
    pub fn reset(&mut self, reg: &Regression, noise: &NoiseLevels) {
        let n = reg.len();
        let general = !noise.fast_path();
        let column = |v: &mut Option<Vec<f64>>, copied: bool| {
            if copied {
                let v = v.get_or_insert_with(Vec::new);
                v.clear();
                v.reserve(n);
            } else if let Some(v) = v {
                // Keep the memory for a later condition that copies it.
                v.clear();
            }
        };
        self.w.clear();
        self.w.reserve(n);
        column(&mut self.f, general);
        column(&mut self.c, general);
        let output = general || noise.is_on(Channel::Output);
        let grade = general && noise.is_on(Channel::Grade);
        column(&mut self.y, output);
        column(&mut self.s, grade);
        self.copies = [general, general, output, grade];
    }

    /// The columns, with `reg`'s (the regression the rows were measured on) where the noise
    /// left one untouched.
    pub fn view<'a>(&'a self, reg: &'a Regression) -> RowsView<'a> {
        let pick = |own: &'a Option<Vec<f64>>, copied: bool, theirs: &'a [f64]| match own {
            Some(v) if copied => v.as_slice(),
            _ => theirs,
        };
        RowsView {
            f: pick(&self.f, self.copies[0], &reg.f),
            w: &self.w,
            c: pick(&self.c, self.copies[1], &reg.c),
            y: pick(&self.y, self.copies[2], &reg.y),
            s: pick(&self.s, self.copies[3], &reg.g_sin),
            noise_free_f_c: !self.copies[0],
        }
    }

    /// Append the measured rows `start .. start + len` of `reg` with the block's draws and
    /// derivative noise (the same the moments of the block are summed from, with the same
    /// arithmetic).
    pub fn push_block(
        &mut self,
        reg: &Regression,
        levels: &NoiseLevels,
        start: usize,
        len: usize,
        draws: BlockNoise<'_>,
        derivative: Option<&[f64]>,
    ) {
        let range = start..start + len;
        if !self.copies[0] {
            // Fast path: only Ṽ and ỹ carry noise.
            let sd_v = levels[Channel::Velocity];
            let e = draws[Channel::Velocity].unwrap_or(&ZEROS[..len]);
            self.w
                .extend(reg.v[range.clone()].iter().zip(e).map(|(v, e)| {
                    let vt = v + sd_v * e;
                    vt * vt
                }));
            if let (Some(y), Some(eta), true) =
                (&mut self.y, draws[Channel::Output], self.copies[2])
            {
                let sd_y = levels[Channel::Output];
                y.extend(reg.y[range].iter().zip(eta).map(|(y, eta)| y + sd_y * eta));
            }
            return;
        }
        let (Some(f), Some(c), Some(y)) = (&mut self.f, &mut self.c, &mut self.y) else {
            unreachable!("the general path copies every column");
        };
        for (j, i) in range.enumerate() {
            let [x1, w, x3, yi, si] = measured_row(
                reg,
                levels,
                i,
                |ch| draws[ch].map_or(0.0, |d| d[j]),
                derivative.map(|d| d[j]),
            );
            f.push(x1);
            self.w.push(w);
            c.push(x3);
            y.push(yi);
            if let (Some(s), true) = (&mut self.s, self.copies[3]) {
                s.push(si);
            }
        }
    }
}

/// Partial sums of the fast path (speed and output noise only): everything that the noise
/// touches, accumulated per block.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
struct SpeedOutputSums {
    s_w: f64,
    s_wf: f64,
    s_wc: f64,
    s_ww: f64,
    s_wy: f64,
    s_eta: f64,
    s_f_eta: f64,
    s_c_eta: f64,
    s_w_eta: f64,
}

/// Accumulates one realisation's [`Moments`] block by block.
#[derive(Debug, Clone)]
pub struct MomentAccumulator<'r> {
    reg: &'r Regression,
    noise: NoiseLevels,
    /// Only speed and output noise: the constant columns stay noise-free and five sums per
    /// sample suffice.
    use_fast_path: bool,
    /// Whether the general path sums the grade term ([`GradeSums`]): only the compensation
    /// of grade noise reads it.
    sum_grade: bool,
    fast: SpeedOutputSums,
    general: Moments,
}

impl<'r> MomentAccumulator<'r> {
    /// Start a realisation of `reg` with noise levels `noise`.
    pub fn new(reg: &'r Regression, noise: NoiseLevels) -> Self {
        let mut fast = SpeedOutputSums::default();
        if !noise.is_on(Channel::Velocity) {
            [fast.s_w, fast.s_wf, fast.s_wc, fast.s_ww, fast.s_wy] = reg.speed_sums_noise_free;
        }
        MomentAccumulator {
            reg,
            noise,
            use_fast_path: noise.fast_path(),
            sum_grade: noise.is_on(Channel::Grade),
            fast,
            general: Moments::default(),
        }
    }

    /// Like [`new`](Self::new) but always on the general path, summing the grade term
    /// whatever the noise (for cross-checks).
    #[cfg(test)]
    pub(crate) fn new_general(reg: &'r Regression, noise: NoiseLevels) -> Self {
        MomentAccumulator {
            use_fast_path: false,
            sum_grade: true,
            ..Self::new(reg, noise)
        }
    }

    /// Add samples `start .. start + len` with the block's standard-normal draws and, for
    /// a differentiated acceleration, the noise it adds to each output \[m/s²\]. Each block
    /// is summed separately and then added, so rounding grows like the number of blocks,
    /// not of samples.
    #[inline]
    pub fn add_block(
        &mut self,
        start: usize,
        len: usize,
        draws: BlockNoise<'_>,
        derivative: Option<&[f64]>,
    ) {
        if self.use_fast_path {
            debug_assert!(
                derivative.is_none(),
                "the fast path has no derivative noise"
            );
            self.add_fast(start, len, draws);
        } else {
            self.add_general(start, len, draws, derivative);
        }
    }

    #[inline]
    fn add_fast(&mut self, start: usize, len: usize, draws: BlockNoise<'_>) {
        let reg = self.reg;
        let range = start..start + len;
        let cols = Columns {
            v: &reg.v[range.clone()],
            f: &reg.f[range.clone()],
            c: &reg.c[range.clone()],
            y: &reg.y[range],
        };
        let sd_v = self.noise[Channel::Velocity];
        let s = &mut self.fast;
        let e = draws[Channel::Velocity].unwrap_or(&ZEROS[..len]);
        // Speed noise off: Ṽ = V exactly, and `new` set the speed sums already.
        if sd_v != 0.0 {
            let [s_w, s_wf, s_wc, s_ww, s_wy] = speed_sums(&cols, e, sd_v);
            s.s_w += s_w;
            s.s_wf += s_wf;
            s.s_wc += s_wc;
            s.s_ww += s_ww;
            s.s_wy += s_wy;
        }
        if let Some(eta) = draws[Channel::Output] {
            let [s_eta, s_f_eta, s_c_eta, s_w_eta] = output_sums(&cols, e, sd_v, eta);
            s.s_eta += s_eta;
            s.s_f_eta += s_f_eta;
            s.s_c_eta += s_c_eta;
            s.s_w_eta += s_w_eta;
        }
    }

    fn add_general(
        &mut self,
        start: usize,
        len: usize,
        draws: BlockNoise<'_>,
        derivative: Option<&[f64]>,
    ) {
        if self.sum_grade {
            self.add_general_rows::<true>(start, len, draws, derivative);
        } else {
            self.add_general_rows::<false>(start, len, draws, derivative);
        }
    }

    /// The general path's sums of one block, with the grade term's when `GRADE` (a constant,
    /// so that the loop without it has no trace of it).
    #[inline(always)]
    fn add_general_rows<const GRADE: bool>(
        &mut self,
        start: usize,
        len: usize,
        draws: BlockNoise<'_>,
        derivative: Option<&[f64]>,
    ) {
        let reg = self.reg;
        let levels = self.noise;
        let mut b = Moments::default();
        let mut grade = GradeSums::default();
        // A channel that is off draws zeros.
        let zeros = &ZEROS[..len];
        let draws = draws.0.map(|d| d.unwrap_or(zeros));
        for (j, i) in (start..start + len).enumerate() {
            let [x1, w, x3, y, s] = measured_row(
                reg,
                &levels,
                i,
                |c| draws[c.index()][j],
                derivative.map(|d| d[j]),
            );
            let row = [x1, w, x3, y];
            b.add_row(&row);
            if GRADE {
                grade.add_row(&row, s);
            }
        }
        if GRADE {
            b.grade = Some(grade);
        }
        self.general.add(&b);
    }

    /// The realisation's moments.
    pub fn finish(&self) -> Moments {
        let reg = self.reg;
        let n = reg.len() as f64;
        if !self.use_fast_path {
            return Moments { n, ..self.general };
        }
        let s = &self.fast;
        let sd_y = self.noise[Channel::Output];
        Moments {
            s_11: reg.xtx[(0, 0)],
            s_13: reg.xtx[(0, 2)],
            s_33: reg.xtx[(2, 2)],
            s_1y: reg.xty[0] + sd_y * s.s_f_eta,
            s_3y: reg.xty[2] + sd_y * s.s_c_eta,
            s_1w: s.s_wf,
            s_3w: s.s_wc,
            s_ww: s.s_ww,
            s_wy: s.s_wy + sd_y * s.s_w_eta,
            s_w: s.s_w,
            s_1: reg.sum_f,
            s_3: reg.sum_c,
            s_y: reg.sum_y + sd_y * s.s_eta,
            n,
            grade: None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::estimate::regression::test_regression as regression;
    use crate::estimate::sums::Sum;
    use crate::noise::{BLOCK, NormalStream};

    fn moments(reg: &Regression, noise: NoiseLevels, general: bool) -> Moments {
        let mut acc = if general {
            MomentAccumulator::new_general(reg, noise)
        } else {
            MomentAccumulator::new(reg, noise)
        };
        let mut speed = NormalStream::for_realisation(1, 0, Channel::Velocity.stream(), 0);
        let mut output = NormalStream::for_realisation(1, 0, Channel::Output.stream(), 0);
        let (mut e, mut eta) = ([0.0; BLOCK], [0.0; BLOCK]);
        for start in (0..reg.len()).step_by(BLOCK) {
            let len = BLOCK.min(reg.len() - start);
            speed.fill_block(&mut e[..len]);
            output.fill_block(&mut eta[..len]);
            acc.add_block(
                start,
                len,
                BlockNoise::from_fn(|c| match c {
                    Channel::Velocity => Some(&e[..len]),
                    Channel::Output => Some(&eta[..len]),
                    _ => None,
                }),
                None,
            );
        }
        acc.finish()
    }

    #[test]
    fn fast_and_general_paths_build_the_same_moments() {
        let reg = regression();
        let mut noise = NoiseLevels::default();
        noise[Channel::Velocity] = 0.7;
        noise[Channel::Output] = 0.3;
        let a = moments(&reg, noise, false);
        let b = moments(&reg, noise, true);
        // Same products summed in a different grouping: agreement to rounding (1e-12
        // relative is ~10^4 ulps of headroom for 6001 terms).
        for (s, (x, y)) in Sum::ALL.into_iter().zip(a.sums().into_iter().zip(b.sums())) {
            assert!(
                (x - y).abs() <= 1e-12 * x.abs().max(y.abs()),
                "{s:?}: {x} vs {y}"
            );
        }
        assert_eq!(a.n, b.n);
    }

    #[test]
    fn without_noise_the_moments_are_the_noise_free_normal_equations() {
        let reg = regression();
        let m = MomentAccumulator::new(&reg, NoiseLevels::default());
        let mut acc = m;
        for start in (0..reg.len()).step_by(BLOCK) {
            let len = BLOCK.min(reg.len() - start);
            let none = BlockNoise::default();
            acc.add_block(start, len, none, None);
        }
        let (a, b) = acc.finish().ols_system(reg.k);
        for i in 0..3 {
            assert!((b[i] - reg.xty[i]).abs() <= 1e-12 * reg.xty[i].abs());
            for j in 0..3 {
                assert!((a[(i, j)] - reg.xtx[(i, j)]).abs() <= 1e-12 * reg.xtx[(i, j)].abs());
            }
        }
        // BCLS with σ_v = 0 is OLS.
        assert_eq!(
            acc.finish()
                .bcls_system(reg.k, reg.g, &NoiseLevels::default()),
            (a, b)
        );
    }
}
