//! The measured rows of one realisation, kept for the estimators that read rows ([`Rows`]):
//! the columns the noise moves, block by block, the regression's standing in for the rest.

use super::block::{
    Block, CHUNK_ROWS, ChunkLanes, MeasuredBlock, OUTPUT, RowChunks, RowsOut, RowsView,
};
use super::lane_sums::ZEROS;
use crate::estimate::channels::{BlockNoise, Channel, NoiseLevels, measured_speed};
use crate::estimate::regression::Regression;
use crate::estimate::sums::Column;
use crate::noise::BLOCK;
use crate::numeric::simd::Scalar;

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
    /// x̃₁ = F̃ \[N\] (`None`: noise-free). Like w, each copied column is as long as the
    /// regression and holds the first `len` rows.
    f: Option<Vec<f64>>,
    /// x̃₃ = −g cos θ̃ \[m/s²\] (`None`: noise-free).
    c: Option<Vec<f64>>,
    /// ỹ \[m/s²\] (`None`: noise-free).
    y: Option<Vec<f64>>,
    /// s̃ = g sin θ̃ \[m/s²\] (`None`: noise-free).
    s: Option<Vec<f64>>,
    /// Whether f, c, y and s are copied in this realisation (else the regression's stand in).
    copies: [bool; 4],
    /// On the fast path (only Ṽ and ỹ carry noise), the channel whose noise is in w
    /// ([`NoiseLevels::speed_channel`]); `None`: the general path.
    fast: Option<Channel>,
    /// What the general path's pass takes of the rows' chunks in this realisation
    /// ([`Rows::take_chunks`]); `None`: no chunks, every row written.
    chunking: Option<Chunking>,
    /// The lane sums of the last block's whole chunks ([`RowsView::chunks`]), room for a
    /// block's: a scan reads them before the next block is measured.
    chunks: Vec<ChunkLanes>,
}

/// The chunks the pass takes in a realisation, and where the last block's are
/// ([`RowChunks`] is the view of them).
#[derive(Debug, Clone, Copy)]
struct Chunking {
    /// Whether the pass sums the grade term in them.
    grade: bool,
    /// Whether the rows inside whole chunks are written ([`RowChunks::rows`]).
    rows: bool,
    /// The index of the last block's first whole chunk among the realisation's chunks.
    from: usize,
    /// The number of the last block's whole chunks.
    count: usize,
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
        self.fast = (!general).then(|| noise.speed_channel());
        let column = |v: &mut Option<Vec<f64>>, copied: bool| {
            if copied {
                // The values from an earlier realisation are written over before read.
                v.get_or_insert_with(Vec::new).resize(n, 0.0);
            } else if let Some(v) = v {
                // Keep the memory for a later condition that copies it.
                v.clear();
            }
        };
        self.len = 0;
        self.w_ahead = None;
        self.chunking = None;
        self.w.resize(n, 0.0);
        // Only force noise moves x̃₁, only grade noise x̃₃ and s̃ (the general path's).
        let force = general && noise.moves(Column::F);
        let grade = general && noise.moves(Column::C);
        let output = general || noise.moves(Column::Y);
        column(&mut self.f, force);
        column(&mut self.c, grade);
        column(&mut self.y, output);
        column(&mut self.s, grade);
        self.copies = [force, grade, output, grade];
    }

    /// On the general path, have the pass take the lane sums of each chunk of
    /// [`CHUNK_ROWS`] rows as it measures them where a scan `reads` them, and write only the
    /// rows after each block's whole chunks where `only` the scans read the rows, all of
    /// them from the chunks ([`RowScans::reads_chunks`]); `grade`: whether the pass sums
    /// the grade term. The realisation's sums are then taken chunk by chunk
    /// ([`RowsOut::chunks`]). Set after [`reset`](Self::reset), before the first block.
    ///
    /// [`RowScans::reads_chunks`]: crate::estimate::estimator::RowScans::reads_chunks
    pub fn take_chunks(&mut self, [reads, only]: [bool; 2], grade: bool) {
        assert_eq!(self.len, 0, "chunks are chosen before the first block");
        self.chunking = (reads && self.fast.is_none()).then_some(Chunking {
            grade,
            rows: !only,
            from: 0,
            count: 0,
        });
        if self.chunking.is_some() {
            self.chunks.resize(BLOCK / CHUNK_ROWS, Default::default());
        }
    }

    /// The columns, with `reg`'s (the regression the rows were measured on) where the noise
    /// left one untouched.
    pub fn view<'a>(&'a self, reg: &'a Regression) -> RowsView<'a> {
        let pick = |own: &'a Option<Vec<f64>>, copied: bool, theirs: &'a [f64]| match own {
            Some(v) if copied => &v[..self.len],
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
            chunks: match self.chunking {
                Some(c) => RowChunks {
                    lanes: &self.chunks[..c.count],
                    from: c.from,
                    grade: c.grade,
                    rows: c.rows,
                },
                None => RowChunks::NONE,
            },
        }
    }

    /// On the fast path, room for the w of the next block's `len` rows, for the fast
    /// path's sums to write as they take them
    /// ([`MomentAccumulator::add_block_writing_w`](super::MomentAccumulator::add_block_writing_w)); that block's
    /// [`push_block`](Self::push_block) then takes w as written there.
    pub fn w_room(&mut self, len: usize) -> &mut [f64] {
        assert!(
            self.fast.is_some(),
            "w is written ahead on the fast path only"
        );
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
        if let Some(speed) = self.fast {
            // Fast path: only Ṽ and ỹ carry noise.
            let sd_v = levels[speed];
            let e = draws[speed].unwrap_or(&ZEROS[..len]);
            if !w_written {
                let room = &mut self.w[self.len..self.len + len];
                for ((w, &v), &e) in room.iter_mut().zip(&reg.v[range.clone()]).zip(e) {
                    let vt = measured_speed(Scalar, v, sd_v, e);
                    *w = vt * vt;
                }
            }
            if let (Some(y), true) = (&mut self.y, self.copies[2]) {
                let y = &mut y[self.len..self.len + len];
                match draws[OUTPUT] {
                    Some(eta) => {
                        let sd_y = levels[OUTPUT];
                        for ((y, noise_free), eta) in y.iter_mut().zip(&reg.y[range]).zip(eta) {
                            *y = noise_free + sd_y * eta;
                        }
                    }
                    None => y.copy_from_slice(&reg.y[range]),
                }
                if let Some(d) = derivative {
                    for (y, d) in y.iter_mut().zip(d) {
                        *y += d;
                    }
                }
            }
            self.len += len;
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
        let range = self.len..self.len + rows.w.len();
        self.w[range.clone()].copy_from_slice(rows.w);
        for (own, copied, theirs) in [
            (&mut self.f, self.copies[0], rows.f),
            (&mut self.c, self.copies[1], rows.c),
            (&mut self.y, self.copies[2], rows.y),
            (&mut self.s, self.copies[3], rows.s),
        ] {
            if let (Some(own), true) = (own, copied) {
                own[range.clone()].copy_from_slice(theirs);
            }
        }
        self.len = range.end;
    }

    /// On the general path, the room for the next block's `len` rows in these columns, for
    /// the pass to write them there ([`MomentAccumulator::add_block_into`]); the block is
    /// then taken by [`take_room`](Self::take_room).
    ///
    /// [`MomentAccumulator::add_block_into`]: super::MomentAccumulator::add_block_into
    pub fn room(&mut self, len: usize) -> RowsOut<'_> {
        assert!(self.fast.is_none(), "the general path's room");
        let range = self.len..self.len + len;
        let whole_chunks = range.start / CHUNK_ROWS..range.end / CHUNK_ROWS;
        if let Some(c) = &mut self.chunking {
            (c.from, c.count) = (whole_chunks.start, whole_chunks.len());
        }
        let [f, c, y, s] = [&mut self.f, &mut self.c, &mut self.y, &mut self.s];
        let [copy_f, copy_c, copy_y, copy_s] = self.copies;
        fn room(
            v: &mut Option<Vec<f64>>,
            copied: bool,
            range: std::ops::Range<usize>,
        ) -> Option<&mut [f64]> {
            v.as_mut().filter(|_| copied).map(|v| &mut v[range])
        }
        RowsOut {
            f: room(f, copy_f, range.clone()),
            w: &mut self.w[range.clone()],
            c: room(c, copy_c, range.clone()),
            s: room(s, copy_s, range.clone()),
            y: room(y, copy_y, range).expect("the general path copies ỹ"),
            chunks: self
                .chunking
                .is_some()
                .then(|| &mut self.chunks[..whole_chunks.len()]),
            chunk_rows: self.chunking.is_none_or(|c| c.rows),
        }
    }

    /// Take the `len` rows written into [`room`](Self::room), whose channels moved x̃₁ and
    /// x̃₃ as `moved` says: the columns these rows copy are exactly those. They agree
    /// because a channel that is on at a level that moves nothing has no draws (a channel's
    /// draws exist where its level is > 0, and every channel that moves x̃₁ or x̃₃ moves it
    /// at any level > 0); were they ever to differ, this stops the run before a scan reads
    /// the rows.
    pub fn take_room(&mut self, len: usize, moved: [bool; 2]) {
        let [force, grade] = moved;
        assert_eq!(
            [force, grade, grade],
            [self.copies[0], self.copies[1], self.copies[3]],
            "the rows copy the columns the block's channels move"
        );
        self.len += len;
    }
}
