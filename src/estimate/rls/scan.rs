//! The `rls` scan of a realisation's measured rows: the exponentially weighted normal
//! equations and the settle time, taken in four lanes as the kernel measures the rows
//! (docs/model.md#rls). Written once over the four lanes of `numeric::simd` (portable, or
//! AVX2 where the CPU has it: the same operations in the same order, so the same bits).

use std::sync::Arc;

use nalgebra::{Matrix3, Vector3};

use crate::estimate::moments::{RowChunks, RowsView};
use crate::estimate::regression::Regression;
#[cfg(target_arch = "x86_64")]
use crate::numeric::simd::Avx2;
use crate::numeric::simd::{Lanes4, Quad, Real};

const LANES: usize = 4;

/// Least time between two checks of the running `rls` estimate \[s\]: the settle time is
/// resolved to this or to four rows, whichever is longer.
pub const RLS_CHECK_S: f64 = 0.25;

/// The result of the `rls` scan: the exponentially weighted normal equations (A, b) of
/// all rows, and the settle row (see [`rls_scan`]).
pub type RlsResult = ((Matrix3<f64>, Vector3<f64>), Option<usize>);

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
    /// The plan of the `rls` scans of `reg`'s rows under forgetting factor `lambda`, made
    /// on first use and kept with the regression ([`Regression::derived`]); `lambda` must
    /// be the same at every call.
    pub fn shared(reg: &Regression, lambda: f64) -> Arc<RlsPlan> {
        let plan = reg.derived(|reg| {
            let columns = [&reg.f[..], &reg.c[..], &reg.y[..]];
            RlsPlan::new(&reg.t, Some(columns), lambda)
        });
        assert_eq!(
            plan.lambda().to_bits(),
            lambda.to_bits(),
            "one forgetting factor per regression"
        );
        plan
    }

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
                chunks: RowChunks::NONE,
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
        // The groups as arrays of four, their bounds checked here once, not at every load.
        let [f, w, c, y] = cols.map(|col| col[start..to.max(start)].as_chunks::<LANES>().0);
        let minus_k = l.splat(-self.k);
        let age = l.splat(self.age);
        let entry = l.load(&self.entry, 0);
        let mut acc = l.load_each(&self.lanes);
        let row_of = |check: usize| plan.checks.get(check).copied().unwrap_or(usize::MAX);
        let mut count = 0;
        let mut next_row = row_of(self.next_check);
        let groups = f.iter().zip(w).zip(c).zip(y).enumerate();
        for (g, (((f, w), c), y)) in groups {
            let start = start + g * LANES;
            let x1 = l.load(f, 0);
            let x2 = minus_k * l.load(w, 0);
            let x3 = l.load(c, 0);
            let y = l.load(y, 0);
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
                l.reduce4([
                    l.load(&self.pending[0][k], 0),
                    l.load(&self.pending[1][k], 0),
                    l.load(&self.pending[2][k], 0),
                    l.load(&self.pending[3][k], 0),
                ])
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
        let each = l.lanes_each(states);
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
mod tests;
