//! Sums over a realisation's measured rows for the estimators that read them: the moments
//! of consecutive segments (`wbcls`) and the running normal equations of `rls`. Both written
//! once over the four lanes of `numeric::simd` (portable, or AVX2 where the CPU has it: the
//! same operations in the same order, so the same bits).

use std::sync::Arc;

use nalgebra::{Matrix3, Vector3};

use super::moments::{GradeSums, Moments, RowsView};
use super::regression::Regression;
use super::wbcls::SEGMENT_S;
#[cfg(target_arch = "x86_64")]
use crate::numeric::simd::Avx2;
use crate::numeric::simd::{Lanes4, Quad, Real};

const LANES: usize = 4;

#[inline(always)]
fn reduce(l: [f64; LANES]) -> f64 {
    (l[0] + l[1]) + (l[2] + l[3])
}

/// Least time between two checks of the running `rls` estimate \[s\]: the settle time is
/// resolved to this or to four rows, whichever is longer.
pub const RLS_CHECK_S: f64 = 0.25;

/// The moments of rows `start..end` (N = the row count). With `constant`, the sums of
/// x̃₁ and x̃₃ alone (Σx̃₁², Σx̃₁x̃₃, Σx̃₃², Σx̃₁, Σx̃₃) are taken from it instead of being
/// summed: the caller passes them where those columns are noise-free (the segment's of
/// `Regression::segments`); where `rows.noise_free_y` says ỹ is noise-free too, so are
/// Σx̃₁ỹ, Σx̃₃ỹ and Σỹ. With `grade`, the
/// sums of the grade term ([`GradeSums`]) as well (`None` without).
pub fn segment_moments(
    rows: RowsView<'_>,
    start: usize,
    end: usize,
    constant: Option<&Moments>,
    grade: bool,
) -> Moments {
    #[cfg(target_arch = "x86_64")]
    if let Some(avx2) = Avx2::detect() {
        // SAFETY: the token proves the CPU has AVX2.
        return unsafe { segment_moments_avx2(avx2, rows, start, end, constant, grade) };
    }
    segment_moments_lanes(Quad, rows, start, end, constant, grade)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn segment_moments_avx2(
    avx2: Avx2,
    rows: RowsView<'_>,
    start: usize,
    end: usize,
    constant: Option<&Moments>,
    grade: bool,
) -> Moments {
    segment_moments_lanes(avx2, rows, start, end, constant, grade)
}

/// A product of columns summed in lanes: columns `.0` and `.1` of the four given, or column
/// `.0` alone when `.1` is [`ALONE`].
type Term = (usize, usize);

/// The second factor of a [`Term`] that is one column alone.
const ALONE: usize = usize::MAX;

/// Each term summed over rows `0..whole` (a multiple of four) of `cols`, row i into lane
/// i mod 4, in the lanes of `l` (portable, or one AVX2 register: the same bits). Always
/// inlined, so that the terms are constants of the loop.
#[inline(always)]
fn lane_sums<L: Lanes4, const K: usize>(
    l: L,
    cols: [&[f64]; 4],
    terms: [Term; K],
    whole: usize,
) -> [[f64; LANES]; K] {
    let used = |c: usize| terms.iter().any(|&(x, z)| x == c || z == c);
    for (c, col) in cols.iter().enumerate() {
        assert!(!used(c) || col.len() >= whole);
    }
    let mut acc = [l.splat(0.0); K];
    for i in (0..whole).step_by(LANES) {
        for (a, &(x, z)) in acc.iter_mut().zip(&terms) {
            let t = if z == ALONE {
                l.load(cols[x], i)
            } else {
                l.load(cols[x], i) * l.load(cols[z], i)
            };
            *a = *a + t;
        }
    }
    acc.map(|a| l.lanes(a))
}

/// Each term summed over all rows of `cols` (`n` rows): [`lane_sums`] of the groups of
/// four, the rows after them into lane 0, then each sum (l₀ + l₁) + (l₂ + l₃). The sums
/// below are this with their lists of terms; a term's lanes are summed apart from the
/// others', so a term has the same bits in any list.
#[inline(always)]
fn sums<L: Lanes4, const K: usize>(
    l: L,
    cols: [&[f64]; 4],
    terms: [Term; K],
    n: usize,
) -> [f64; K] {
    let whole = n - n % LANES;
    let mut acc = lane_sums(l, cols, terms, whole);
    #[allow(clippy::needless_range_loop)] // row i of each of the columns a term names
    for i in whole..n {
        for (a, &(x, z)) in acc.iter_mut().zip(&terms) {
            a[0] += if z == ALONE {
                cols[x][i]
            } else {
                cols[x][i] * cols[z][i]
            };
        }
    }
    acc.map(reduce)
}

/// The sums that involve w or ỹ: [Σx̃₁ỹ, Σx̃₃ỹ, Σx̃₁w, Σx̃₃w, Σw², Σwỹ, Σw, Σỹ].
#[inline(always)]
fn noisy_sums<L: Lanes4>(l: L, f: &[f64], w: &[f64], c: &[f64], y: &[f64]) -> [f64; 8] {
    // Columns 0..4: x̃₁, w, x̃₃, ỹ.
    let terms = [
        (0, 3),
        (2, 3),
        (0, 1),
        (2, 1),
        (1, 1),
        (1, 3),
        (1, ALONE),
        (3, ALONE),
    ];
    sums(l, [f, w, c, y], terms, f.len())
}

/// The sums that involve w: [Σx̃₁w, Σx̃₃w, Σw², Σwỹ, Σw] (those of [`noisy_sums`]).
#[inline(always)]
fn w_sums<L: Lanes4>(l: L, f: &[f64], w: &[f64], c: &[f64], y: &[f64]) -> [f64; 5] {
    // Columns 0..4: x̃₁, w, x̃₃, ỹ.
    let terms = [(0, 1), (2, 1), (1, 1), (1, 3), (1, ALONE)];
    sums(l, [f, w, c, y], terms, f.len())
}

/// The sums of ỹ without w: [Σx̃₁ỹ, Σx̃₃ỹ, Σỹ] of rows `f`, `c`, `y`, the same bits as
/// [`segment_moments`] sums them (the portable build; the AVX2 build agrees bit for bit).
/// For the regression's noise-free sums over each segment (`Regression::segments`).
pub(crate) fn output_sums(f: &[f64], c: &[f64], y: &[f64]) -> [f64; 3] {
    // Columns 0..4: x₁, (none), x₃, y.
    sums(Quad, [f, &[], c, y], [(0, 3), (2, 3), (3, ALONE)], f.len())
}

/// The sums of x̃₁ and x̃₃ alone: [Σx̃₁², Σx̃₁x̃₃, Σx̃₃², Σx̃₁, Σx̃₃].
#[inline(always)]
fn regressor_sums<L: Lanes4>(l: L, f: &[f64], c: &[f64]) -> [f64; 5] {
    let terms = [(0, 0), (0, 2), (2, 2), (0, ALONE), (2, ALONE)];
    sums(l, [f, &[], c, &[]], terms, f.len())
}

/// The sums of the grade term s̃: [Σs̃, Σx̃₁s̃, Σx̃₃s̃, Σws̃].
#[inline(always)]
fn grade_sums<L: Lanes4>(l: L, f: &[f64], w: &[f64], c: &[f64], s: &[f64]) -> GradeSums {
    // Columns 0..4: x̃₁, w, x̃₃, s̃.
    let terms = [(3, ALONE), (0, 3), (2, 3), (1, 3)];
    let [s_s, s_1s, s_3s, s_ws] = sums(l, [f, w, c, s], terms, f.len());
    GradeSums {
        s_s,
        s_1s,
        s_3s,
        s_ws,
    }
}

#[inline(always)]
pub(crate) fn segment_moments_lanes<L: Lanes4>(
    l: L,
    rows: RowsView<'_>,
    start: usize,
    end: usize,
    constant: Option<&Moments>,
    grade: bool,
) -> Moments {
    let (f, w, c, y) = (
        &rows.f[start..end],
        &rows.w[start..end],
        &rows.c[start..end],
        &rows.y[start..end],
    );
    // An `if`, not a closure: a closure is not inlined into the AVX2 functions with it.
    let grade = if grade {
        Some(grade_sums(l, f, w, c, &rows.s[start..end]))
    } else {
        None
    };
    let [s_1y, s_3y, s_1w, s_3w, s_ww, s_wy, s_w, s_y] = match constant {
        // ỹ the regression's: its sums without w are the segment's noise-free ones.
        Some(m) if rows.noise_free_y => {
            let [s_1w, s_3w, s_ww, s_wy, s_w] = w_sums(l, f, w, c, y);
            [m.s_1y, m.s_3y, s_1w, s_3w, s_ww, s_wy, s_w, m.s_y]
        }
        _ => noisy_sums(l, f, w, c, y),
    };
    let [s_11, s_13, s_33, s_1, s_3] = match constant {
        Some(m) => [m.s_11, m.s_13, m.s_33, m.s_1, m.s_3],
        None => regressor_sums(l, f, c),
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
        n: (end - start) as f64,
        grade,
    }
}

/// What an estimator reads from the measured rows beyond their sums
/// ([`Estimator::reads`](super::estimators::Estimator::reads)).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RowRead {
    /// Nothing: the moments suffice.
    Nothing,
    /// The moments of each weight segment of `wbcls` ([`SegmentScan`]).
    Segments,
    /// The running normal equations of `rls` ([`RlsScan`]).
    Rls,
    /// The rows themselves.
    Rows,
}

/// The result of the `rls` scan: the exponentially weighted normal equations (A, b) of
/// all rows, and the settle row (see [`rls_scan`]).
pub type RlsResult = ((Matrix3<f64>, Vector3<f64>), Option<usize>);

/// The union of what a study's estimators read from the rows.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RowReads {
    /// Some estimator reads the segments' moments.
    pub segments: bool,
    /// Some estimator reads the running normal equations.
    pub rls: bool,
    /// Some estimator reads the rows themselves.
    pub rows: bool,
}

impl RowReads {
    /// What `reads` ask for together.
    pub fn of(reads: impl IntoIterator<Item = RowRead>) -> Self {
        let mut all = RowReads::default();
        for read in reads {
            match read {
                RowRead::Nothing => {}
                RowRead::Segments => all.segments = true,
                RowRead::Rls => all.rls = true,
                RowRead::Rows => all.rows = true,
            }
        }
        all
    }

    /// Whether the measured rows are kept at all (every scan reads them).
    pub fn any(&self) -> bool {
        self.segments || self.rls || self.rows
    }
}

/// The sums over the rows that the estimators read, taken by the kernel as it measures the
/// rows (block by block, while they are in cache): the same values, bit for bit, as one
/// pass over all rows after the last.
#[derive(Debug, Clone, Default)]
pub struct RowScans {
    segments: Option<SegmentScan>,
    rls: Option<RlsScan>,
}

/// The arguments of the `rls` scan of one realisation (see [`rls_scan`]).
#[derive(Debug, Clone, Copy)]
pub struct RlsTarget {
    /// Forgetting factor λ.
    pub lambda: f64,
    /// The true 1/M the settle time is scored against, and the band around it.
    pub target: f64,
    /// Half-width of the band.
    pub band: f64,
}

impl RowScans {
    /// Empty scans of `reg`'s rows for what `reads` asks (`grade`: the segments sum the
    /// grade term too), keeping the memory of earlier realisations. `shared`: `reg` serves
    /// many realisations (a condition's), so RLS takes what they share from its plan
    /// ([`Regression::rls_plan`], made once); otherwise (a realisation's own regression)
    /// RLS sums every term itself, the same bits without a plan to make per realisation.
    pub fn reset(
        &mut self,
        reads: RowReads,
        reg: &Regression,
        grade: bool,
        rls: RlsTarget,
        shared: bool,
    ) {
        self.segments = match (reads.segments, self.segments.take()) {
            (true, Some(mut scan)) => {
                scan.reset(grade);
                Some(scan)
            }
            (true, None) => Some(SegmentScan::new(grade)),
            (false, _) => None,
        };
        self.rls = reads.rls.then(|| {
            let plan = match shared {
                true => reg.rls_plan(rls.lambda),
                false => Arc::new(RlsPlan::new(&reg.t, None, rls.lambda)),
            };
            RlsScan::new(reg.k, plan, rls.target, rls.band, reg.len())
        });
    }

    /// Take the measured rows up to `end` (exclusive; a multiple of four or the row count).
    pub fn advance(&mut self, rows: RowsView<'_>, reg: &Regression, end: usize) {
        if let Some(scan) = &mut self.segments {
            scan.advance(rows, reg, end);
        }
        if let Some(scan) = &mut self.rls {
            scan.advance(rows, end);
        }
    }

    /// The moments of each weight segment of [`SEGMENT_S`] (`None`: not asked for).
    pub fn segments(&self) -> Option<&[Moments]> {
        self.segments.as_ref().map(|s| s.done.as_slice())
    }

    /// The running normal equations' result (`None`: not asked for).
    pub fn rls(&self) -> Option<RlsResult> {
        self.rls.as_ref().map(RlsScan::finish)
    }
}

/// The moments of each weight segment of `wbcls` ([`SEGMENT_S`] long,
/// [`Regression::segments`]), each taken by [`segment_moments`] once the rows have reached
/// its end.
#[derive(Debug, Clone, Default)]
struct SegmentScan {
    grade: bool,
    done: Vec<Moments>,
}

impl SegmentScan {
    fn new(grade: bool) -> Self {
        SegmentScan {
            grade,
            done: Vec::new(),
        }
    }

    fn reset(&mut self, grade: bool) {
        self.grade = grade;
        self.done.clear();
    }

    fn advance(&mut self, rows: RowsView<'_>, reg: &Regression, end: usize) {
        let (segments, constants) = reg.segments(SEGMENT_S);
        #[cfg(target_arch = "x86_64")]
        if let Some(avx2) = Avx2::detect() {
            // SAFETY: the token proves the CPU has AVX2.
            return unsafe { self.advance_avx2(avx2, rows, segments, constants, end) };
        }
        self.advance_lanes(Quad, rows, segments, constants, end);
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn advance_avx2(
        &mut self,
        avx2: Avx2,
        rows: RowsView<'_>,
        segments: &[(usize, usize)],
        constants: &[Moments],
        end: usize,
    ) {
        self.advance_lanes(avx2, rows, segments, constants, end);
    }

    /// The segments that end by `end`, each [`segment_moments`] of its rows, written into
    /// `done` by the function that sums them (compiled for AVX2, the copy of a segment's
    /// moments is a few register stores rather than a call of `memcpy`).
    #[inline(always)]
    fn advance_lanes<L: Lanes4>(
        &mut self,
        l: L,
        rows: RowsView<'_>,
        segments: &[(usize, usize)],
        constants: &[Moments],
        end: usize,
    ) {
        while let Some(&(a, b)) = segments.get(self.done.len()) {
            if b > end {
                break;
            }
            let constant = rows.noise_free_f_c.then_some(&constants[self.done.len()]);
            self.done
                .push(segment_moments_lanes(l, rows, a, b, constant, self.grade));
        }
    }
}

/// The exponentially weighted normal equations A = Σ λ^(N−1−i) x̃_i x̃_iᵀ, b likewise, of
/// all rows (k = ½ρA for column 2, `t` the row times), and the first checked row from which
/// on θ̂₁ of the rows so far stays within `target ± band` at every check (`None`: outside
/// or undefined at the last). Checks fall on the last row of a group of four at least
/// [`RLS_CHECK_S`] after the previous check, the last row of the last group, and every
/// row after it. [`RlsScan`] in one step.
pub fn rls_scan(
    rows: RowsView<'_>,
    t: &[f64],
    k: f64,
    lambda: f64,
    target: f64,
    band: f64,
) -> RlsResult {
    let plan = Arc::new(RlsPlan::new(t, None, lambda));
    let mut scan = RlsScan::new(k, plan, target, band, rows.len());
    scan.advance(rows, rows.len());
    scan.finish()
}

/// The terms of the running sums that involve no w, in the order of [`RlsPlan`]'s states:
/// x₁², x₁x₃, x₃², x₁y, x₃y (indices into [`products`]).
const PLANNED: [usize; 5] = [0, 2, 5, 6, 8];

/// What the `rls` scans of one regression's realisations share: the checked rows (a
/// function of the rows' times alone) and, over the regression's own x₁, x₃ and y, the
/// state at each check of the [`PLANNED`] terms. A realisation whose x̃₁ and x̃₃ (and ỹ)
/// are those columns would sum those terms to the same bits, so it takes their states from
/// here and sums only the others (those of w, and with a noisy ỹ those of ỹ).
#[derive(Debug, Clone)]
pub struct RlsPlan {
    lambda: f64,
    /// The last row of each group of four checked, increasing (the rows after the last
    /// group, each checked, are not listed).
    checks: Vec<usize>,
    /// The state of each [`PLANNED`] term at each check, then [`PLAN_PADDING`] copies of
    /// the last (so that any check's state and the next three's are one slice); empty:
    /// not computed.
    fixed: [Vec<f64>; 5],
}

/// The copies of the last check's states after [`RlsPlan`]'s.
const PLAN_PADDING: usize = LANES - 1;

impl RlsPlan {
    /// The checks of rows at times `t` (see [`rls_scan`]) and, with `columns` (x₁, x₃, y of
    /// the regression), the states of the [`PLANNED`] terms at each under forgetting factor
    /// `lambda`.
    pub fn new(t: &[f64], columns: Option<[&[f64]; 3]>, lambda: f64) -> Self {
        let n = t.len();
        let whole = n - n % LANES;
        let mut checks = Vec::new();
        let mut last_check = f64::NEG_INFINITY;
        for last in (LANES - 1..whole).step_by(LANES) {
            if t[last] - last_check >= RLS_CHECK_S || last + 1 == whole {
                last_check = t[last];
                checks.push(last);
            }
        }
        let mut plan = RlsPlan {
            lambda,
            checks,
            fixed: Default::default(),
        };
        if let Some([f, c, y]) = columns {
            // Their scan with every term summed and each check's state recorded (the terms
            // of w read some column of the right length and go unread).
            let mut scan = RlsScan::new(0.0, Arc::new(plan.clone()), 0.0, 0.0, n);
            scan.run.record = Some(Vec::with_capacity(plan.checks.len()));
            let rows = RowsView {
                f,
                w: f,
                c,
                y,
                s: y,
                noise_free_f_c: false,
                noise_free_y: false,
            };
            scan.advance(rows, whole);
            let states = scan.run.record.take().unwrap_or_default();
            if let Some(last) = states.last() {
                let padded = states.iter().chain(std::iter::repeat_n(last, PLAN_PADDING));
                for (slot, fixed) in plan.fixed.iter_mut().enumerate() {
                    *fixed = padded.clone().map(|state| state[slot]).collect();
                }
            }
        }
        plan
    }

    /// The forgetting factor the plan was made for.
    pub fn lambda(&self) -> f64 {
        self.lambda
    }
}

/// [`RlsRun`]'s `FREE`: which of x̃₁, x̃₃, ỹ are the regression's own columns, so that the
/// plan holds the states of the terms they alone make.
const FREE_NONE: u8 = 0;
/// x̃₁ and x̃₃ the regression's: x₁², x₁x₃, x₃² planned.
const FREE_F_C: u8 = 1;
/// x̃₁, x̃₃ and ỹ the regression's: every [`PLANNED`] term.
const FREE_F_C_Y: u8 = 2;

/// Whether a realisation sums term `k` of [`products`] under `free` (the plan holds the
/// others' states).
#[inline(always)]
const fn summed(free: u8, k: usize) -> bool {
    match free {
        FREE_F_C_Y => matches!(k, 1 | 3 | 4 | 7),
        FREE_F_C => !matches!(k, 0 | 2 | 5),
        _ => true,
    }
}

/// [`rls_scan`] run along the rows as they are measured: [`RlsScan::advance`] takes the
/// rows up to a point (the kernel calls it after each block), [`RlsScan::finish`] gives the
/// result. The same operations in the same order as one pass, so the same bits however the
/// rows are split (at multiples of four) and whether a term is summed or its states taken
/// from the [`RlsPlan`].
#[derive(Debug, Clone)]
pub struct RlsScan {
    plan: Arc<RlsPlan>,
    run: RlsRun,
}

/// An [`RlsScan`] but its plan, which the scan's steps read as they change this.
#[derive(Debug, Clone)]
struct RlsRun {
    k: f64,
    lambda: f64,
    target: f64,
    band: f64,
    /// Lane j holds the rows ≡ j (mod 4), each weighted so that the sum of the lanes after
    /// a group of four rows is the state after its last row: a new row of lane j enters
    /// with λ^(3−j) (`entry`), and every group ages all lanes by λ⁴ (`age`).
    entry: [f64; LANES],
    age: f64,
    lanes: [[f64; LANES]; 9],
    state: [f64; 9],
    /// The first checked row of the current run of checks inside the band.
    settle: Option<usize>,
    /// The next of the plan's checks.
    next_check: usize,
    /// Each check's states of the [`PLANNED`] terms, while the plan is made.
    record: Option<Vec<[f64; 5]>>,
    /// The next row to take, and the row count.
    next: usize,
    n: usize,
    /// The lanes of the summed terms at the checks not yet taken (taken several at a
    /// time).
    pending: [[[f64; LANES]; 9]; PENDING],
}

/// The checks [`RlsScan`] puts aside before it takes them side by side.
const PENDING: usize = 4;

impl RlsScan {
    /// A scan of `n` rows with the plan of their regression (see [`rls_scan`] for the
    /// arguments).
    pub fn new(k: f64, plan: Arc<RlsPlan>, target: f64, band: f64, n: usize) -> Self {
        let lambda = plan.lambda;
        let run = RlsRun {
            k,
            lambda,
            target,
            band,
            // The products `powi` makes at run time (λ³ = λ·λ², λ⁴ = λ²·λ²), written out so
            // that a λ known at compile time folds to the same bits.
            entry: [lambda * (lambda * lambda), lambda * lambda, lambda, 1.0],
            age: (lambda * lambda) * (lambda * lambda),
            lanes: [[0.0; LANES]; 9],
            state: [0.0; 9],
            settle: None,
            next_check: 0,
            record: None,
            next: 0,
            n,
            pending: [[[0.0; LANES]; 9]; PENDING],
        };
        RlsScan { plan, run }
    }

    /// Take rows up to `end` (exclusive; a multiple of four, or the row count).
    pub fn advance(&mut self, rows: RowsView<'_>, end: usize) {
        assert!(
            end.is_multiple_of(LANES) || end == self.run.n,
            "rows split at {end}"
        );
        let RlsScan { plan, run } = self;
        #[cfg(target_arch = "x86_64")]
        if let Some(avx2) = Avx2::detect() {
            // SAFETY: the token proves the CPU has AVX2.
            return unsafe { run.advance_avx2(avx2, plan, rows, end) };
        }
        run.advance_by(Quad, plan, rows, end);
    }

    /// The normal equations of all rows and the settle row (all rows taken).
    pub fn finish(&self) -> RlsResult {
        self.run.finish()
    }
}

impl RlsRun {
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn advance_avx2(&mut self, avx2: Avx2, plan: &RlsPlan, rows: RowsView<'_>, end: usize) {
        self.advance_by(avx2, plan, rows, end);
    }

    /// [`RlsScan::advance`] by the loop compiled for λ = 1 or not and for the columns of
    /// the regression's own the rows read.
    #[inline(always)]
    fn advance_by<L: Lanes4>(&mut self, l: L, plan: &RlsPlan, rows: RowsView<'_>, end: usize) {
        let planned = !plan.fixed[0].is_empty();
        let free = match (planned, rows.noise_free_f_c, rows.noise_free_y) {
            (true, true, true) => FREE_F_C_Y,
            (true, true, false) => FREE_F_C,
            _ => FREE_NONE,
        };
        match (self.lambda == 1.0, free) {
            (true, FREE_F_C_Y) => self.advance_body::<_, false, FREE_F_C_Y>(l, plan, rows, end),
            (true, FREE_F_C) => self.advance_body::<_, false, FREE_F_C>(l, plan, rows, end),
            (true, _) => self.advance_body::<_, false, FREE_NONE>(l, plan, rows, end),
            (false, FREE_F_C_Y) => self.advance_body::<_, true, FREE_F_C_Y>(l, plan, rows, end),
            (false, FREE_F_C) => self.advance_body::<_, true, FREE_F_C>(l, plan, rows, end),
            (false, _) => self.advance_body::<_, true, FREE_NONE>(l, plan, rows, end),
        }
    }

    /// The check of the estimate at `row`.
    #[inline(always)]
    fn check(&mut self, row: usize) {
        self.settle_at(settled(&self.state, self.target, self.band), row);
    }

    /// The check at `row` whose estimate is (`true`) or is not within the band.
    #[inline(always)]
    fn settle_at(&mut self, within: bool, row: usize) {
        if !within {
            self.settle = None;
        } else if self.settle.is_none() {
            self.settle = Some(row);
        }
    }

    #[inline(always)]
    fn advance_body<L: Lanes4, const FORGET: bool, const FREE: u8>(
        &mut self,
        l: L,
        plan: &RlsPlan,
        rows: RowsView<'_>,
        end: usize,
    ) {
        let n = self.n;
        let whole = n - n % LANES;
        let k = self.k;
        let (f, w, c, y) = (rows.f, rows.w, rows.c, rows.y);
        self.groups::<_, FORGET, FREE>(l, plan, [f, w, c, y], self.next, end.min(whole));
        self.next = self.next.max(end.min(whole));
        if end == n {
            for i in whole.max(self.next)..n {
                let x = products(f[i], -k * w[i], c[i], y[i]);
                for (s, x) in self.state.iter_mut().zip(x) {
                    *s = self.lambda * *s + x;
                }
                self.check(i);
            }
            self.next = n;
        }
    }

    /// Add the groups of four rows `start .. to` into the lanes of `l` (the terms `FREE`
    /// leaves to be summed), the lanes kept in registers between checks. The lanes at each
    /// check the plan makes are put aside and the checks taken [`PENDING`] at a time by
    /// [`checks`](Self::checks) (in order, the same operations as one at a time).
    #[inline(always)]
    fn groups<L: Lanes4, const FORGET: bool, const FREE: u8>(
        &mut self,
        l: L,
        plan: &RlsPlan,
        cols: [&[f64]; 4],
        start: usize,
        to: usize,
    ) {
        let [f, w, c, y] = cols;
        let minus_k = l.splat(-self.k);
        let age = l.splat(self.age);
        let entry = l.load(&self.entry, 0);
        let mut acc = self.lanes.map(|a| l.load(&a, 0));
        let row_of = |check: usize| plan.checks.get(check).copied().unwrap_or(usize::MAX);
        let mut count = 0;
        let mut next_row = row_of(self.next_check);
        for start in (start..to).step_by(LANES) {
            let x1 = l.load(f, start);
            let x2 = minus_k * l.load(w, start);
            let x3 = l.load(c, start);
            let y = l.load(y, start);
            let terms = [
                x1 * x1,
                x1 * x2,
                x1 * x3,
                x2 * x2,
                x2 * x3,
                x3 * x3,
                x1 * y,
                x2 * y,
                x3 * y,
            ];
            for (k, (a, t)) in acc.iter_mut().zip(terms).enumerate() {
                if !summed(FREE, k) {
                    continue;
                }
                // λ = 1: the factors are exactly 1, so this is the same sum.
                *a = if FORGET { age * *a + entry * t } else { *a + t };
            }
            if start + LANES - 1 == next_row {
                for (k, a) in acc.iter().enumerate() {
                    if summed(FREE, k) {
                        l.store(*a, &mut self.pending[count][k], 0);
                    }
                }
                count += 1;
                if count == PENDING {
                    self.checks::<_, FREE>(l, plan, count);
                    count = 0;
                }
                next_row = row_of(self.next_check + count);
            }
        }
        if count > 0 {
            self.checks::<_, FREE>(l, plan, count);
        }
        for (lane, a) in self.lanes.iter_mut().zip(acc) {
            l.store(a, lane, 0);
        }
    }

    /// The plan's next `count` checks (at most [`PENDING`]), `pending` holding each one's
    /// lanes of the terms it sums under `FREE`: side by side, check c in lane c, each
    /// state (l₀ + l₁) + (l₂ + l₃) of its lanes or the plan's, then [`settled`]'s
    /// operations; then the checks in order.
    #[inline(always)]
    fn checks<L: Lanes4, const FREE: u8>(&mut self, l: L, plan: &RlsPlan, count: usize) {
        debug_assert!((1..=PENDING).contains(&count));
        let j = self.next_check;
        let mut states = [l.splat(0.0); 9];
        for (k, state) in states.iter_mut().enumerate() {
            *state = if summed(FREE, k) {
                // Lane c: check c's sum of its lanes (lanes past `count` go unread).
                l.reduce4([0, 1, 2, 3].map(|c| l.load(&self.pending[c][k], 0)))
            } else {
                // The plan's states of checks j .. j + 4 (past its last check, copies of
                // the last).
                let slot = PLANNED.iter().position(|&p| p == k);
                l.load(&plan.fixed[slot.expect("a planned term")], j)
            };
        }
        let [p, q, e, s, u, v, b1, b2, b3] = states;
        let c11 = s * v - u * u;
        let det = p * c11 - q * (q * v - u * e) + e * (q * u - s * e);
        let num = b1 * c11 - q * (b2 * v - u * b3) + e * (b2 * u - s * b3);
        let off = (num - l.splat(self.target) * det).abs();
        let within = l.le(off, l.splat(self.band) * det.abs());
        let nonzero = l.ne(det, l.splat(0.0));
        let settled = l.movemask(l.and(within, nonzero));
        let each = states.map(|state| l.lanes(state));
        if let Some(record) = &mut self.record {
            record.extend((0..count).map(|c| PLANNED.map(|k| each[k][c])));
        }
        for (state, each) in self.state.iter_mut().zip(&each) {
            *state = each[count - 1];
        }
        for c in 0..count {
            self.settle_at(settled & (1 << c) != 0, plan.checks[j + c]);
        }
        self.next_check += count;
    }

    /// [`RlsScan::finish`].
    fn finish(&self) -> RlsResult {
        debug_assert_eq!(self.next, self.n, "rows left untaken");
        let [p, q, e, s, u, v, b1, b2, b3] = self.state;
        (
            (
                Matrix3::new(p, q, e, q, s, u, e, u, v),
                Vector3::new(b1, b2, b3),
            ),
            self.settle,
        )
    }
}

/// The nine running sums [p, q, e, s, u, v, b₁, b₂, b₃] of A = [[p, q, e], [q, s, u],
/// [e, u, v]] and b, from one row.
#[inline(always)]
fn products(x1: f64, x2: f64, x3: f64, y: f64) -> [f64; 9] {
    [
        x1 * x1,
        x1 * x2,
        x1 * x3,
        x2 * x2,
        x2 * x3,
        x3 * x3,
        x1 * y,
        x2 * y,
        x3 * y,
    ]
}
/// Whether θ̂₁ = (A⁻¹b)₁ lies within `target ± band`, by the first column's cofactors
/// (|num − target·det| ≤ band·|det|, no division); false when A is singular.
#[inline(always)]
fn settled(a: &[f64; 9], target: f64, band: f64) -> bool {
    let [p, q, e, s, u, v, b1, b2, b3] = *a;
    let c11 = s * v - u * u;
    let det = p * c11 - q * (q * v - u * e) + e * (q * u - s * e);
    let num = b1 * c11 - q * (b2 * v - u * b3) + e * (b2 * u - s * b3);
    det != 0.0 && (num - target * det).abs() <= band * det.abs()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Deterministic rows y = xθ + wiggle over `n` samples `dt` apart.
    fn rows_every(dt: f64, n: usize) -> (Vec<f64>, [Vec<f64>; 4]) {
        let t: Vec<f64> = (0..n).map(|i| dt * i as f64).collect();
        let f: Vec<f64> = t.iter().map(|t| 2000.0 + 200.0 * (0.3 * t).sin()).collect();
        let w: Vec<f64> = t
            .iter()
            .map(|t| (15.0 + 5.0 * (0.11 * t).cos()).powi(2))
            .collect();
        let c: Vec<f64> = t
            .iter()
            .map(|t| -9.81 * (0.05 * (0.07 * t).sin()).cos())
            .collect();
        let theta = [1.0 / 1800.0, 0.35 / 1800.0, 0.0125];
        let k = 3.3;
        let y: Vec<f64> = (0..n)
            .map(|i| {
                let wiggle = 0.05 * ((i * 7919 % 101) as f64 / 50.0 - 1.0);
                theta[0] * f[i] - theta[1] * k * w[i] + theta[2] * c[i] + wiggle
            })
            .collect();
        (t, [f, w, c, y])
    }

    /// The time steps of the tests: 0.1 s (every group checked) and 0.01 s (every seventh,
    /// as on the thesis cycle, so the checks put aside have unchecked groups between them).
    const STEPS: [f64; 2] = [0.1, 0.01];

    fn view(cols: &[Vec<f64>; 4]) -> RowsView<'_> {
        RowsView {
            f: &cols[0],
            w: &cols[1],
            c: &cols[2],
            y: &cols[3],
            s: &cols[3],
            noise_free_f_c: false,
            noise_free_y: false,
        }
    }

    /// The checks of `rls_scan` by their definition, on the state of the plain recursion
    /// A_t = λA_{t−1} + x_t x_tᵀ after every row.
    fn naive(
        t: &[f64],
        cols: &[Vec<f64>; 4],
        lambda: f64,
        target: f64,
        band: f64,
    ) -> ([f64; 9], Option<usize>) {
        let n = t.len();
        let whole = n - n % LANES;
        let mut state = [0.0; 9];
        let mut settle = None;
        let mut last_check = f64::NEG_INFINITY;
        for i in 0..n {
            let x = products(cols[0][i], -3.3 * cols[1][i], cols[2][i], cols[3][i]);
            for (s, x) in state.iter_mut().zip(x) {
                *s = lambda * *s + x;
            }
            let checked = if i < whole {
                (i + 1) % LANES == 0 && (t[i] - last_check >= RLS_CHECK_S || i + 1 == whole)
            } else {
                true
            };
            if checked {
                if i < whole {
                    last_check = t[i];
                }
                if !settled(&state, target, band) {
                    settle = None;
                } else if settle.is_none() {
                    settle = Some(i);
                }
            }
        }
        (state, settle)
    }

    #[test]
    fn the_lane_sums_are_the_plain_recursion_and_check_where_it_says() {
        // λ = 1 and λ < 1, with N a multiple of four, not one, and below four; bands of
        // 0.01–1 % around the final 1/M estimate, so the settle row falls at different
        // places (or nowhere). The lanes sum the same products in another order: agreement
        // to 1e-12 relative (rounding of ~1e3 terms).
        let cases = STEPS
            .into_iter()
            .flat_map(|dt| [3usize, 401, 1203, 1204].map(|n| (dt, n)));
        for (dt, n) in cases {
            let (t, cols) = rows_every(dt, n);
            for lambda in [1.0, 0.995] {
                let ((a, b), _) = rls_scan(view(&cols), &t, 3.3, lambda, 0.0, 0.0);
                let final_theta = crate::numeric::linalg::solve_spd(&a, &b).map_or(0.0, |v| v[0]);
                for band in [1e-4, 1e-3, 1e-2] {
                    let (_, got) = rls_scan(
                        view(&cols),
                        &t,
                        3.3,
                        lambda,
                        final_theta,
                        band * final_theta,
                    );
                    let (state, want) = naive(&t, &cols, lambda, final_theta, band * final_theta);
                    assert_eq!(got, want, "dt {dt} n {n} λ {lambda} band {band}");
                    let lanes = [
                        a[(0, 0)],
                        a[(0, 1)],
                        a[(0, 2)],
                        a[(1, 1)],
                        a[(1, 2)],
                        a[(2, 2)],
                        b[0],
                        b[1],
                        b[2],
                    ];
                    for (x, y) in lanes.iter().zip(state) {
                        assert!(
                            (x - y).abs() <= 1e-12 * y.abs().max(1e-300),
                            "dt {dt} n {n} λ {lambda}: {x} vs {y}"
                        );
                    }
                }
            }
        }
    }

    /// The scan of all rows in one portable pass, with the sum `FORGET` says, summing the
    /// terms `FREE` leaves to be summed (the others' states from the plan of the rows' own
    /// x₁, x₃, y).
    fn portable<const FORGET: bool, const FREE: u8>(
        cols: &[Vec<f64>; 4],
        t: &[f64],
        lambda: f64,
    ) -> RlsResult {
        let n = t.len();
        let own = Some([&cols[0][..], &cols[2][..], &cols[3][..]]);
        let plan = Arc::new(RlsPlan::new(t, own, lambda));
        let mut scan = RlsScan::new(3.3, Arc::clone(&plan), 5e-4, 1e-5, n);
        scan.run
            .advance_body::<_, FORGET, FREE>(Quad, &plan, view(cols), n);
        scan.finish()
    }

    #[test]
    fn the_dispatched_and_portable_builds_agree_bit_for_bit() {
        for dt in STEPS {
            dispatched_and_portable_agree(dt);
        }
    }

    fn dispatched_and_portable_agree(dt: f64) {
        let (t, cols) = rows_every(dt, 1203);
        for lambda in [1.0, 0.995] {
            let want = rls_scan(view(&cols), &t, 3.3, lambda, 5e-4, 1e-5);
            assert_eq!(want, portable::<true, FREE_NONE>(&cols, &t, lambda));
            // The planned terms' states taken from the plan: the same bits.
            assert_eq!(want, portable::<true, FREE_F_C>(&cols, &t, lambda));
            assert_eq!(want, portable::<true, FREE_F_C_Y>(&cols, &t, lambda));
        }
        // λ = 1: the specialised sum is the general one with factors of exactly 1.
        let want = portable::<true, FREE_NONE>(&cols, &t, 1.0);
        assert_eq!(want, portable::<false, FREE_NONE>(&cols, &t, 1.0));
        assert_eq!(want, portable::<false, FREE_F_C>(&cols, &t, 1.0));
        assert_eq!(want, portable::<false, FREE_F_C_Y>(&cols, &t, 1.0));
        for (a, b) in [(0, 1203), (5, 18), (100, 103)] {
            for grade in [false, true] {
                assert_eq!(
                    segment_moments(view(&cols), a, b, None, grade),
                    segment_moments_lanes(Quad, view(&cols), a, b, None, grade)
                );
            }
        }
    }

    #[test]
    fn a_scan_taken_in_pieces_is_the_scan_in_one_pass_bit_for_bit() {
        // The kernel advances the scan block by block (multiples of four rows) while it
        // measures them; the settle row needs a band that is met part of the way. The scan
        // of rows whose x̃₁, x̃₃ (and ỹ) are the regression's takes the states of the terms
        // of those columns from the regression's plan: the same bits as summing them, with
        // ỹ the regression's and with ỹ moved (output noise).
        let cases = STEPS
            .into_iter()
            .flat_map(|dt| [3usize, 401, 1203, 1204].map(|n| (dt, n)));
        for (dt, n) in cases {
            let (t, cols) = rows_every(dt, n);
            let mut moved = cols.clone();
            for (i, y) in moved[3].iter_mut().enumerate() {
                *y += 1e-3 * ((i * 31 % 17) as f64 - 8.0);
            }
            for lambda in [1.0, 0.995] {
                let own = [&cols[0][..], &cols[2][..], &cols[3][..]];
                let plan = Arc::new(RlsPlan::new(&t, Some(own), lambda));
                let unplanned = Arc::new(RlsPlan::new(&t, None, lambda));
                fn free(cols: &[Vec<f64>; 4], y_free: bool) -> RowsView<'_> {
                    RowsView {
                        noise_free_f_c: true,
                        noise_free_y: y_free,
                        ..view(cols)
                    }
                }
                let cases = [
                    (&unplanned, view(&cols), view(&cols)),
                    (&plan, free(&cols, true), view(&cols)),
                    (&plan, free(&moved, false), view(&moved)),
                ];
                for (plan, rows, plain) in cases {
                    let whole = rls_scan(plain, &t, 3.3, lambda, 5e-4, 5e-5);
                    for piece in [4, 256, 1000] {
                        let mut scan = RlsScan::new(3.3, Arc::clone(plan), 5e-4, 5e-5, n);
                        let mut end = 0;
                        while end < n {
                            end = (end + piece).min(n);
                            scan.advance(rows, end);
                        }
                        let what = format!(
                            "dt {dt} n {n} λ {lambda} pieces of {piece}, free {} {}",
                            rows.noise_free_f_c, rows.noise_free_y
                        );
                        assert_eq!(scan.finish(), whole, "{what}");
                    }
                }
            }
        }
    }
}
