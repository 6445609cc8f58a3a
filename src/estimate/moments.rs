//! The accumulator that builds the per-realisation sums of the vehicle regression
//! ([`Moments`], defined with the typed list of sums in `sums.rs`) block by block from the
//! noise draws (the kernel).
//!
//! A realisation is summarised by the [`Moments`] of its noisy columns: with w = Ṽ² the
//! middle column is −k w, so XᵀX and Xᵀy need only sums of products of (x₁, w, x₃, y). The
//! kernel never forms the N×3 matrix.

use super::channels::{BlockNoise, Channel, NoiseLevels};
use super::regression::Regression;
use super::sums::Column;
pub use super::sums::{GradeSums, Moments};
use crate::noise::BLOCK;
use block::OUTPUT;
use lane_sums::{Columns, ZEROS, output_sums, speed_sums, speed_sums_writing_w};

mod block;
mod lane_sums;
mod rows;
pub mod segment_sums;
pub(crate) use block::chunk_moments;
pub use block::{
    Block, CHUNK_ROWS, ChunkLanes, MeasuredBlock, RowChunks, RowsOut, RowsView, Wanted,
};
pub use rows::Rows;

/// The sums of w = V² without speed noise — Σw, ΣwF, Σwc, Σw², Σwy — block by block in
/// the lanes of the fast path, exactly as a realisation without speed noise would sum them:
/// such a realisation starts from these instead of recomputing them. Made once per
/// regression ([`Regression::derived`]).
#[derive(Debug)]
struct NoiseFreeSpeedSums([f64; 5]);

impl NoiseFreeSpeedSums {
    fn of(reg: &Regression) -> std::sync::Arc<NoiseFreeSpeedSums> {
        reg.derived(|reg| {
            let mut sums = [0.0; 5];
            for start in (0..reg.len()).step_by(BLOCK) {
                let range = start..(start + BLOCK).min(reg.len());
                let cols = Columns {
                    v: &reg.v[range.clone()],
                    f: &reg.f[range.clone()],
                    c: &reg.c[range.clone()],
                    y: &reg.y[range.clone()],
                };
                let block = speed_sums(&cols, &ZEROS[..range.len()], 0.0);
                for (total, b) in sums.iter_mut().zip(block) {
                    *total += b;
                }
            }
            NoiseFreeSpeedSums(sums)
        })
    }
}

/// The [`Moments`] of `reg`'s rows as they are (no noise added): what a realisation without
/// noise sums, and the sums of a measured log taken as it is.
pub fn noise_free_moments(reg: &Regression) -> Moments {
    let [s_w, s_1w, s_3w, s_ww, s_wy] = NoiseFreeSpeedSums::of(reg).0;
    Moments {
        s_11: reg.xtx[(0, 0)],
        s_13: reg.xtx[(0, 2)],
        s_33: reg.xtx[(2, 2)],
        s_1y: reg.xty[0],
        s_3y: reg.xty[2],
        s_1w,
        s_3w,
        s_ww,
        s_wy,
        s_w,
        s_1: reg.sum_f,
        s_3: reg.sum_c,
        s_y: reg.sum_y,
        n: reg.len() as f64,
        grade: Some(reg.grade_sums_noise_free),
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
    /// The channel whose noise is in w ([`NoiseLevels::speed_channel`]).
    speed: Channel,
    /// Only speed and output noise: the constant columns stay noise-free and five sums per
    /// sample suffice.
    use_fast_path: bool,
    /// Whether the general path sums the grade term ([`GradeSums`]): only the compensation
    /// of grade noise reads it.
    sum_grade: bool,
    /// Whether the general path keeps each block's measured rows ([`Self::add_block_into`]).
    keep_rows: bool,
    /// No force noise: x̃₁ is noise-free, and the sums of it alone (x̃₁², x̃₁) are the
    /// regression's (the general path's pass leaves them).
    noise_free_f: bool,
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
        let speed = noise.speed_channel();
        if !noise.is_on(speed) {
            [fast.s_w, fast.s_wf, fast.s_wc, fast.s_ww, fast.s_wy] = NoiseFreeSpeedSums::of(reg).0;
        }
        MomentAccumulator {
            reg,
            noise,
            speed,
            use_fast_path: noise.fast_path(),
            sum_grade: noise.moves(Column::C),
            keep_rows: true,
            noise_free_f: !noise.moves(Column::F),
            noise_free_f_c: !noise.moves(Column::F) && !noise.moves(Column::C),
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

    /// Keep each block's measured rows ([`add_block_into`](Self::add_block_into) on the
    /// general path) only where `needed` (an estimator reads the rows); without, the
    /// general path's vectorised pass writes no columns (the sums keep their bits).
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
        self.use_fast_path && self.noise[self.speed] != 0.0
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
        let sd_v = self.noise[self.speed];
        let s = &mut self.fast;
        let e = draws[self.speed].unwrap_or(&ZEROS[..len]);
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
        if let Some(eta) = draws[OUTPUT] {
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
    /// [`segment_moments`](super::moments::segment_sums::segment_moments)); the sums
    /// of x̃₁ and x̃₃ alone are left to [`finish`](Self::finish) where those columns are
    /// noise-free.
    fn add_general(
        &mut self,
        start: usize,
        len: usize,
        draws: BlockNoise<'_>,
        derivative: Option<&[f64]>,
    ) {
        self.add_general_into(start, len, draws, derivative, None);
    }

    /// Whether the general path sums the grade term ([`GradeSums`]).
    pub fn sums_grade(&self) -> bool {
        self.sum_grade
    }

    /// Whether the blocks are measured on the general path with their rows kept: then
    /// [`add_block_into`](Self::add_block_into) writes a block's rows where they are kept.
    pub fn measures_rows(&self) -> bool {
        !self.use_fast_path && self.keep_rows
    }

    /// [`add_block`](Self::add_block) on the general path with the rows kept
    /// ([`measures_rows`](Self::measures_rows)), the block's measured rows written into
    /// `out` rather than the block's own columns: whether its channels moved x̃₁ and
    /// whether they moved x̃₃ and s̃ ([`MeasuredBlock::moved`]) are returned.
    #[inline]
    pub fn add_block_into(
        &mut self,
        start: usize,
        len: usize,
        draws: BlockNoise<'_>,
        derivative: Option<&[f64]>,
        out: RowsOut<'_>,
    ) -> [bool; 2] {
        assert!(
            self.measures_rows(),
            "rows written on the general path only"
        );
        self.add_general_into(start, len, draws, derivative, Some(out));
        self.block
            .as_ref()
            .expect("the block just measured")
            .moved()
    }

    /// The general path's block, its rows written into `out` when given.
    fn add_general_into(
        &mut self,
        start: usize,
        len: usize,
        draws: BlockNoise<'_>,
        derivative: Option<&[f64]>,
        out: Option<RowsOut<'_>>,
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
        let m = block.measure_and_sum(b, wanted, out);
        // The pass leaves x̃₁'s sums alone exactly where `finish` takes the regression's.
        assert_eq!(block.moved()[0], !self.noise_free_f, "x̃₁ moved");
        self.general.add(&m);
    }

    /// The realisation's moments.
    pub fn finish(&self) -> Moments {
        let reg = self.reg;
        let n = reg.len() as f64;
        if !self.use_fast_path {
            let mut m = Moments { n, ..self.general };
            if self.noise_free_f {
                m.s_11 = reg.xtx[(0, 0)];
                m.s_1 = reg.sum_f;
            }
            if self.noise_free_f_c {
                m.s_13 = reg.xtx[(0, 2)];
                m.s_33 = reg.xtx[(2, 2)];
                m.s_3 = reg.sum_c;
            }
            return m;
        }
        let s = &self.fast;
        let sd_y = self.noise[OUTPUT];
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

#[cfg(test)]
pub(crate) mod test_draws;
