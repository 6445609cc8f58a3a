//! One block of a realisation's measured rows: what it is measured from ([`Block`]), the
//! general path's measured columns ([`MeasuredBlock`], measured and summed in one pass in
//! `one_pass.rs`) and the view of measured rows as columns ([`RowsView`]).

use crate::estimate::channels::{BlockNoise, Channel, NoiseLevels, Signal};
use crate::estimate::regression::Regression;
use crate::noise::BLOCK;
#[cfg(target_arch = "x86_64")]
use crate::numeric::simd::Avx2;
use crate::numeric::simd::Quad;

mod one_pass;

pub use one_pass::ChunkLanes;
pub(crate) use one_pass::chunk_moments;

/// The output's channel, which the fast path carries beside the noise in w.
pub(super) const OUTPUT: Channel = Channel::of(Signal::Acceleration);

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
    /// Whether the last pass wrote its rows into a [`RowsOut`] rather than these columns.
    rows_elsewhere: bool,
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
            rows_elsewhere: false,
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

    /// Whether the last pass's channels moved x̃₁ and whether they moved x̃₃ and s̃ (where
    /// they did not, the block's rows take the regression's).
    pub fn moved(&self) -> [bool; 2] {
        [self.force_moved, self.grade_moved]
    }

    /// The block's rows on `reg` (the regression it was measured on).
    pub fn view<'a>(&'a self, reg: &'a Regression) -> RowsView<'a> {
        assert!(
            !self.rows_elsewhere,
            "the block's rows were written into the kept rows"
        );
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
            chunks: RowChunks::NONE,
        }
    }
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
    /// The lane sums the pass took of the last block's whole chunks ([`RowChunks`]).
    pub chunks: RowChunks<'a>,
}

/// The lane sums of the whole chunks of [`CHUNK_ROWS`] rows of the last block measured,
/// as the pass took them ([`RowsOut::chunks`]); chunk j holds rows [`CHUNK_ROWS`]·j ..
/// [`CHUNK_ROWS`]·(j + 1).
#[derive(Debug, Clone, Copy)]
pub struct RowChunks<'a> {
    /// The chunks' lane sums (empty: none taken).
    pub lanes: &'a [ChunkLanes],
    /// The index of the first of them among the rows' chunks.
    pub from: usize,
    /// Whether they hold the grade term's sums.
    pub grade: bool,
    /// Whether the rows inside whole chunks are written (else only the rows after each
    /// block's last whole chunk are, and a reader takes the chunks' lane sums).
    pub rows: bool,
}

impl RowChunks<'_> {
    /// No chunks taken, every row written.
    pub const NONE: RowChunks<'static> = RowChunks {
        lanes: &[],
        from: 0,
        grade: false,
        rows: true,
    };

    /// The lane sums of chunk `j` of the rows, where taken.
    pub fn get(&self, j: usize) -> Option<&ChunkLanes> {
        self.lanes.get(j.checked_sub(self.from)?)
    }

    /// The first row after the taken chunks.
    pub fn end(&self) -> usize {
        CHUNK_ROWS * (self.from + self.lanes.len())
    }
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

/// What [`MeasuredBlock::measure_and_sum`] gives besides the sums that involve w or ỹ.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Wanted {
    /// The sums of x̃₁ and x̃₃ alone (zero without: `MomentAccumulator::finish` takes the
    /// regression's where those columns are noise-free). Σx̃₁² and Σx̃₁ are zero as well
    /// wherever no source moved x̃₁: `finish` takes the regression's.
    pub regressors: bool,
    /// The grade term's sums ([`GradeSums`](crate::estimate::sums::GradeSums)).
    pub grade: bool,
    /// The measured rows, for [`MeasuredBlock::view`]: without, the vectorised pass writes
    /// no columns and the block's rows are not to be read.
    pub rows: bool,
}

/// Where a pass of the general path writes its measured rows instead of the block's own
/// columns: the kept rows' columns at the block's place ([`Rows`](super::rows::Rows)), so
/// that they are not copied there afterwards. A column given as `None` (one the rows take
/// from the regression) is written into the block's own, as without.
#[derive(Debug)]
pub struct RowsOut<'a> {
    /// x̃₁ = F̃ \[N\].
    pub f: Option<&'a mut [f64]>,
    /// w = Ṽ² \[m²/s²\].
    pub w: &'a mut [f64],
    /// x̃₃ = −g cos θ̃ \[m/s²\].
    pub c: Option<&'a mut [f64]>,
    /// s̃ = g sin θ̃ \[m/s²\].
    pub s: Option<&'a mut [f64]>,
    /// ỹ \[m/s²\].
    pub y: &'a mut [f64],
    /// Where given (room for the block's whole chunks of [`CHUNK_ROWS`] rows; the block
    /// starts at a multiple of it), the pass takes the block's sums chunk by chunk: each
    /// whole chunk's terms summed in lanes of their own, written here (the lanes
    /// `segment_moments` in `moments/segment_sums.rs` sums those rows in, so the same
    /// bits), and the block's lanes the chunks' added in order, then the rows after them
    /// (the same sums in another order than without: docs/model.md#wbcls).
    pub chunks: Option<&'a mut [ChunkLanes]>,
    /// With chunks, whether the rows inside them are written as well (else only the
    /// rows after the last whole chunk).
    pub chunk_rows: bool,
}

/// The rows of a chunk of the pass's sums ([`RowsOut::chunks`]): `wbcls`'s least number of
/// rows in a weight segment, which every segment but the last holds where the samples are
/// at least 1/30 s apart (a real log's 1 or 10 Hz; docs/model.md#wbcls).
pub const CHUNK_ROWS: usize = 16;
