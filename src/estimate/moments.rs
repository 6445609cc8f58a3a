//! The accumulator that builds the per-realisation sums of the vehicle regression
//! ([`Moments`], defined with the typed list of sums in `sums.rs`) block by block from the
//! noise draws (the kernel).
//!
//! A realisation is summarised by the [`Moments`] of its noisy columns: with w = Ṽ² the
//! middle column is −k w, so XᵀX and Xᵀy need only sums of products of (x₁, w, x₃, y). The
//! kernel never forms the N×3 matrix.

use super::channels::{BlockNoise, Channel, NoiseLevels};
use super::kernels::{Columns, ZEROS, output_sums, speed_sums, speed_sums_writing_w};
use super::regression::Regression;
pub use super::sums::{GradeSums, Moments};
use crate::noise::BLOCK;
#[cfg(target_arch = "x86_64")]
use crate::numeric::simd::Avx2;
use crate::numeric::simd::Quad;

mod one_pass;
pub use one_pass::Wanted;

/// What a block is measured from: samples `start .. start + len` of the regression `reg`,
/// the noise levels, each channel's standard-normal draws of the block (a channel that is
/// off has none) and the noise of a differentiated acceleration \[m/s²\] where there is one.
#[derive(Clone, Copy)]
pub struct Block<'a> {
    /// The regression measured.
    pub reg: &'a Regression,
    /// The channels' standard deviations.
    pub levels: &'a NoiseLevels,
    /// The block's first sample.
    pub start: usize,
    /// The block's number of samples (at most [`BLOCK`]).
    pub len: usize,
    /// Each channel's draws of the block.
    pub draws: BlockNoise<'a>,
    /// A differentiated acceleration's noise of each sample \[m/s²\].
    pub derivative: Option<&'a [f64]>,
}

/// One block of measured rows as columns — x̃₁ = F̃, w = Ṽ², x̃₃ = −g cos θ̃, ỹ and
/// s̃ = g sin θ̃ — built from the block's draws by each channel's
/// [`measure`](Channel::measure) (the general path; docs/model.md#sufficient-statistics).
/// A column no channel moved is the regression's own (see [`MeasuredBlock::view`]).
#[derive(Debug, Clone)]
pub struct MeasuredBlock {
    start: usize,
    len: usize,
    force_moved: bool,
    grade_moved: bool,
    f: [f64; BLOCK],
    w: [f64; BLOCK],
    c: [f64; BLOCK],
    y: [f64; BLOCK],
    s: [f64; BLOCK],
}

impl MeasuredBlock {
    /// An empty block (on the heap: a dozen columns of [`BLOCK`]).
    pub fn new() -> Box<Self> {
        Box::new(MeasuredBlock {
            start: 0,
            len: 0,
            force_moved: false,
            grade_moved: false,
            f: [0.0; BLOCK],
            w: [0.0; BLOCK],
            c: [0.0; BLOCK],
            y: [0.0; BLOCK],
            s: [0.0; BLOCK],
        })
    }

    /// Measure the samples of `b` with its draws, in one pass over the samples, four at a
    /// time in the portable lanes or an AVX2 register (the same bits).
    pub fn measure(&mut self, b: Block<'_>) {
        #[cfg(target_arch = "x86_64")]
        if let Some(avx2) = Avx2::detect() {
            // SAFETY: the token proves the CPU has AVX2.
            return unsafe { self.measure_avx2(avx2, b) };
        }
        self.measure_one_pass(Quad, b);
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn measure_avx2(&mut self, avx2: Avx2, b: Block<'_>) {
        self.measure_one_pass(avx2, b);
    }

    /// The block's rows on `reg` (the regression it was measured on).
    pub fn view<'a>(&'a self, reg: &'a Regression) -> RowsView<'a> {
        let (len, range) = (self.len, self.start..self.start + self.len);
        let f = self.force_moved.then(|| &self.f[..len]);
        let (c, s) = match self.grade_moved {
            true => (&self.c[..len], &self.s[..len]),
            false => (&reg.c[range.clone()], &reg.g_sin[range.clone()]),
        };
        RowsView {
            f: f.unwrap_or(&reg.f[range]),
            w: &self.w[..len],
            c,
            y: &self.y[..len],
            s,
            noise_free_f_c: f.is_none() && !self.grade_moved,
            noise_free_y: false,
        }
    }
}

/// The measured rows of one realisation, for estimators that need more than the sums
/// (weighted and recursive ones). A column the noise does not touch is not copied: the
/// regression's own column stands in for it (see [`Rows::view`]).
#[derive(Debug, Clone, Default)]
pub struct Rows {
    /// w = Ṽ² \[m²/s²\] (column 2 is −k w) of the first `len` rows; as long as the
    /// regression, the values after `len` from an earlier realisation or zero (so that a
    /// block's w is written in place, without first zeroing or growing the column).
    w: Vec<f64>,
    /// The rows taken so far.
    len: usize,
    /// The length of the room for w handed out by [`Rows::w_room`] and not yet taken by
    /// [`Rows::push_block`].
    w_ahead: Option<usize>,
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
    /// Whether the rows are measured on the fast path (only Ṽ and ỹ carry noise).
    fast: bool,
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
    /// True when ỹ is the regression's noise-free column.
    pub noise_free_y: bool,
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
        self.fast = !general;
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
        self.len = 0;
        self.w_ahead = None;
        self.w.resize(n, 0.0);
        // Only force noise moves x̃₁, only grade noise x̃₃ and s̃ (the general path's).
        let force = general && noise.is_on(Channel::Force);
        let grade = general && noise.is_on(Channel::Grade);
        let output = general || noise.is_on(Channel::Output) || noise.speed_noise_differentiated();
        column(&mut self.f, force);
        column(&mut self.c, grade);
        column(&mut self.y, output);
        column(&mut self.s, grade);
        self.copies = [force, grade, output, grade];
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
            w: &self.w[..self.len],
            c: pick(&self.c, self.copies[1], &reg.c),
            y: pick(&self.y, self.copies[2], &reg.y),
            s: pick(&self.s, self.copies[3], &reg.g_sin),
            noise_free_f_c: !self.copies[0] && !self.copies[1],
            noise_free_y: !self.copies[2],
        }
    }

    /// On the fast path, room for the w of the next block's `len` rows, for the fast
    /// path's sums to write as they take them
    /// ([`MomentAccumulator::add_block_writing_w`]); that block's
    /// [`push_block`](Self::push_block) then takes w as written there.
    pub fn w_room(&mut self, len: usize) -> &mut [f64] {
        assert!(self.fast, "w is written ahead on the fast path only");
        assert!(self.w_ahead.is_none(), "room for w handed out twice");
        self.w_ahead = Some(len);
        &mut self.w[self.len..self.len + len]
    }

    /// Append the measured rows `start .. start + len` of `reg` with the block's draws and
    /// derivative noise (the same the moments of the block are summed from, with the same
    /// arithmetic); their w as written in the room [`Self::w_room`] handed out for them, if
    /// it did.
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
        let w_written = match self.w_ahead.take() {
            Some(room) => {
                assert_eq!(room, len, "the room for w is the block's");
                true
            }
            None => false,
        };
        if self.fast {
            // Fast path: only Ṽ and ỹ carry noise.
            let sd_v = levels[Channel::Velocity];
            let e = draws[Channel::Velocity].unwrap_or(&ZEROS[..len]);
            if !w_written {
                let room = &mut self.w[self.len..self.len + len];
                for ((w, v), e) in room.iter_mut().zip(&reg.v[range.clone()]).zip(e) {
                    let vt = v + sd_v * e;
                    *w = vt * vt;
                }
            }
            self.len += len;
            if let (Some(y), true) = (&mut self.y, self.copies[2]) {
                let from = y.len();
                match draws[Channel::Output] {
                    Some(eta) => {
                        let sd_y = levels[Channel::Output];
                        y.extend(reg.y[range].iter().zip(eta).map(|(y, eta)| y + sd_y * eta));
                    }
                    None => y.extend_from_slice(&reg.y[range]),
                }
                if let Some(d) = derivative {
                    for (y, d) in y[from..].iter_mut().zip(d) {
                        *y += d;
                    }
                }
            }
            return;
        }
        let mut block = MeasuredBlock::new();
        block.measure(Block {
            reg,
            levels,
            start,
            len,
            draws,
            derivative,
        });
        self.push_measured(reg, &block);
    }

    /// Append the rows of a block measured on the general path (the columns the noise
    /// moves; the regression's stand in for the others).
    pub fn push_measured(&mut self, reg: &Regression, block: &MeasuredBlock) {
        let rows = block.view(reg);
        let len = rows.w.len();
        self.w[self.len..self.len + len].copy_from_slice(rows.w);
        self.len += len;
        for (own, copied, theirs) in [
            (&mut self.f, self.copies[0], rows.f),
            (&mut self.c, self.copies[1], rows.c),
            (&mut self.y, self.copies[2], rows.y),
            (&mut self.s, self.copies[3], rows.s),
        ] {
            if let (Some(own), true) = (own, copied) {
                own.extend_from_slice(theirs);
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
    /// The same four sums of a differentiated acceleration's noise d in place of η.
    s_d: f64,
    s_f_d: f64,
    s_c_d: f64,
    s_w_d: f64,
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
    /// Whether the general path keeps each block's measured rows ([`Self::measured`]).
    keep_rows: bool,
    /// No force or grade noise: x̃₁ and x̃₃ are noise-free, and the sums of them alone are
    /// the regression's.
    noise_free_f_c: bool,
    fast: SpeedOutputSums,
    general: Moments,
    /// The general path's last measured block (allocated on its first).
    block: Option<Box<MeasuredBlock>>,
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
            keep_rows: true,
            noise_free_f_c: !noise.is_on(Channel::Force) && !noise.is_on(Channel::Grade),
            fast,
            general: Moments::default(),
            block: None,
        }
    }

    /// Sum the grade term ([`GradeSums`]) only where `needed` as well as under grade noise:
    /// the compensation of grade noise (BCLS and its kin) is their one reader, and without
    /// it the kernel need not take them (the other sums keep their bits).
    pub fn grade_sums(self, needed: bool) -> Self {
        MomentAccumulator {
            sum_grade: self.sum_grade && needed,
            ..self
        }
    }

    /// Keep each block's measured rows for [`measured`](Self::measured) only where
    /// `needed` (an estimator reads the rows); without, the general path's vectorised pass
    /// writes no columns (the sums keep their bits).
    pub fn keep_rows(self, needed: bool) -> Self {
        MomentAccumulator {
            keep_rows: needed,
            ..self
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
            self.add_fast(start, len, draws, derivative, None);
        } else {
            self.add_general(start, len, draws, derivative);
        }
    }

    /// Whether [`add_block_writing_w`](Self::add_block_writing_w) writes w: on the fast
    /// path with speed noise (elsewhere w is not computed there).
    pub fn writes_w(&self) -> bool {
        self.use_fast_path && self.noise[Channel::Velocity] != 0.0
    }

    /// [`add_block`](Self::add_block) that, where [`writes_w`](Self::writes_w), also writes
    /// each sample's w = Ṽ² into `w` (`len` values): the fast path's measured rows, the
    /// values its sums take, computed once for both.
    #[inline]
    pub fn add_block_writing_w(
        &mut self,
        start: usize,
        len: usize,
        draws: BlockNoise<'_>,
        derivative: Option<&[f64]>,
        w: &mut [f64],
    ) {
        assert!(
            self.writes_w(),
            "w is written on the fast path with speed noise only"
        );
        self.add_fast(start, len, draws, derivative, Some(w));
    }

    /// The fast path's block; with `w` (speed noise on), w written into it.
    #[inline]
    fn add_fast(
        &mut self,
        start: usize,
        len: usize,
        draws: BlockNoise<'_>,
        derivative: Option<&[f64]>,
        w: Option<&mut [f64]>,
    ) {
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
            let [s_w, s_wf, s_wc, s_ww, s_wy] = match w {
                Some(w) => speed_sums_writing_w(&cols, e, sd_v, w),
                None => speed_sums(&cols, e, sd_v),
            };
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
        if let Some(d) = derivative {
            // ỹ = y + σ_y η + d: the derivative's noise enters the sums like output noise
            // of SD 1.
            let [s_d, s_f_d, s_c_d, s_w_d] = output_sums(&cols, e, sd_v, d);
            s.s_d += s_d;
            s.s_f_d += s_f_d;
            s.s_c_d += s_c_d;
            s.s_w_d += s_w_d;
        }
    }

    /// The general path: the block measured and summed in four lanes in one pass
    /// ([`MeasuredBlock::measure_and_sum`], the sums those of
    /// [`segment_moments`](super::row_sums::segment_moments)); the sums
    /// of x̃₁ and x̃₃ alone are left to [`finish`](Self::finish) where those columns are
    /// noise-free.
    fn add_general(
        &mut self,
        start: usize,
        len: usize,
        draws: BlockNoise<'_>,
        derivative: Option<&[f64]>,
    ) {
        let block = self.block.get_or_insert_with(MeasuredBlock::new);
        let wanted = Wanted {
            regressors: !self.noise_free_f_c,
            grade: self.sum_grade,
            rows: self.keep_rows,
        };
        let b = Block {
            reg: self.reg,
            levels: &self.noise,
            start,
            len,
            draws,
            derivative,
        };
        let m = block.measure_and_sum(b, wanted);
        self.general.add(&m);
    }

    /// The rows of the block last added on the general path (`None` on the fast path, and
    /// where the rows are not kept), for the estimators that read rows: the same values the
    /// sums were taken of.
    pub fn measured(&self) -> Option<&MeasuredBlock> {
        self.block
            .as_deref()
            .filter(|_| !self.use_fast_path && self.keep_rows)
    }

    /// The realisation's moments.
    pub fn finish(&self) -> Moments {
        let reg = self.reg;
        let n = reg.len() as f64;
        if !self.use_fast_path {
            let mut m = Moments { n, ..self.general };
            if self.noise_free_f_c {
                m.s_11 = reg.xtx[(0, 0)];
                m.s_13 = reg.xtx[(0, 2)];
                m.s_33 = reg.xtx[(2, 2)];
                m.s_1 = reg.sum_f;
                m.s_3 = reg.sum_c;
            }
            return m;
        }
        let s = &self.fast;
        let sd_y = self.noise[Channel::Output];
        Moments {
            s_11: reg.xtx[(0, 0)],
            s_13: reg.xtx[(0, 2)],
            s_33: reg.xtx[(2, 2)],
            s_1y: reg.xty[0] + sd_y * s.s_f_eta + s.s_f_d,
            s_3y: reg.xty[2] + sd_y * s.s_c_eta + s.s_c_d,
            s_1w: s.s_wf,
            s_3w: s.s_wc,
            s_ww: s.s_ww,
            s_wy: s.s_wy + sd_y * s.s_w_eta + s.s_w_d,
            s_w: s.s_w,
            s_1: reg.sum_f,
            s_3: reg.sum_c,
            s_y: reg.sum_y + sd_y * s.s_eta + s.s_d,
            n,
            grade: None,
        }
    }
}

#[cfg(test)]
mod tests;
