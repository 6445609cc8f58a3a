//! The exact covariances of a realisation's sums over the noise, which the spread's control
//! variates centre the products of the controls with (docs/model.md#spread-control-variates).
//!
//! A row's measured columns are x̃₁ = F̃, w = Ṽ², x̃₃ = −g cos θ̃ and ỹ = a + s̃ + o + d, with
//! s̃ = g sin θ̃ the grade term, o the output noise and d the noise a differentiated
//! acceleration carries: six [`Part`]s, each moved by one channel at a time
//! ([`ChannelTerms::PARTS`]; w by the speed sensor's or the air-speed sensor's).
//! The channels are independent, so the expectation of a product of parts at a row is the
//! product of each channel's joint moment of its own parts ([`Channel::raw_moment`]), and
//! the covariance of two sums' terms at a row is E\[ab\] − E\[a\]E\[b\] of column monomials
//! of degree ≤ 4 (ỹ expanded into its parts). Rows that share a channel's noise add that
//! channel's terms across rows ([`Channel::covariance_across_rows`]).
//!
//! [`ChannelTerms::PARTS`]: super::ChannelTerms::PARTS

use super::{CHANNEL_COUNT, Channel, NoiseLevels, TrueRow};
use crate::estimate::regression::Regression;
use crate::estimate::sums::{Column, Sum};
use crate::numeric::sum::ExactSum;

mod gaussian;

use gaussian::factorial;
pub use gaussian::{gaussian_moment, hermite_coefficients};

/// A random part of a row's measured columns, each moved by one channel at a time.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Part {
    /// x̃₁ = F̃ \[N\].
    F,
    /// w = Ṽ² \[m²/s²\].
    W,
    /// x̃₃ = −g cos θ̃ \[m/s²\].
    C,
    /// s̃ = g sin θ̃, the grade term of ỹ \[m/s²\].
    S,
    /// o, the output noise of ỹ \[m/s²\].
    O,
    /// d, the speed noise in ỹ through a differentiated acceleration \[m/s²\].
    D,
}

/// Number of parts.
pub const PART_COUNT: usize = 6;

impl Part {
    /// Every part.
    pub const ALL: [Part; PART_COUNT] = [Part::F, Part::W, Part::C, Part::S, Part::O, Part::D];

    /// The highest power a product of two sums' terms raises it to (x̃₁, w, x̃₃ appear twice
    /// in a sum like Σw², ỹ once in a sum).
    pub const fn max_power(self) -> u8 {
        match self {
            Part::F | Part::W | Part::C => 4,
            Part::S | Part::O | Part::D => 2,
        }
    }

    /// Its value without noise at row `r`.
    pub fn noise_free(self, r: &TrueRow) -> f64 {
        match self {
            Part::F => r.f,
            Part::W => r.v * r.v,
            Part::C => -r.g * r.cos_grade,
            Part::S => r.g * r.sin_grade,
            Part::O | Part::D => 0.0,
        }
    }
}

/// Powers of the parts, indexed by [`Part`] order.
pub type Powers = [u8; PART_COUNT];

/// Largest table a channel's parts need: (4 + 1) × (2 + 1).
const TABLE: usize = 15;

/// One channel's joint moments of its parts at one row, for every power up to
/// [`Part::max_power`].
#[derive(Debug, Clone, Copy)]
struct ChannelTable {
    parts: &'static [Part],
    values: [f64; TABLE],
}

impl ChannelTable {
    /// Index of the powers of `parts` in the table (mixed radix, first part fastest).
    fn index(parts: &[Part], p: &Powers) -> usize {
        let mut index = 0;
        let mut stride = 1;
        for &part in parts {
            index += p[part as usize] as usize * stride;
            stride *= part.max_power() as usize + 1;
        }
        index
    }

    /// The entries of `channel`'s table with their parts' powers: those `only` lists, or
    /// all.
    fn entries(channel: Channel, only: Option<&[usize]>) -> Vec<(usize, Powers)> {
        let parts = channel.parts();
        let size: usize = parts.iter().map(|p| p.max_power() as usize + 1).product();
        assert!(size <= TABLE, "{channel:?} has parts beyond the table");
        let decompose = |i: usize| {
            let mut p = [0u8; PART_COUNT];
            let mut rest = i;
            for &part in parts {
                let radix = part.max_power() as usize + 1;
                p[part as usize] = (rest % radix) as u8;
                rest /= radix;
            }
            (i, p)
        };
        match only {
            Some(list) => list.iter().map(|&i| decompose(i)).collect(),
            None => (0..size).map(decompose).collect(),
        }
    }

    /// Set the `entries` of `channel`'s table at row `r` under `noise`: its raw moments when
    /// it is on, the noise-free products when off (a part that another channel holds,
    /// `holders[part]` by [`holder`], is a factor of 1 here); `None` where it does not
    /// derive one.
    fn fill(
        &mut self,
        channel: Channel,
        noise: &NoiseLevels,
        r: &TrueRow,
        entries: &[(usize, Powers)],
        holders: &[Channel; PART_COUNT],
    ) -> Option<()> {
        let on = noise.is_on(channel);
        for (i, p) in entries {
            self.values[*i] = if on {
                channel.raw_moment(noise, r, p)?
            } else {
                self.parts
                    .iter()
                    .filter(|&&part| holders[part as usize] == channel)
                    .map(|&part| part.noise_free(r).powi(i32::from(p[part as usize])))
                    .product()
            };
        }
        Some(())
    }

    fn get(&self, p: &Powers) -> f64 {
        self.values[Self::index(self.parts, p)]
    }
}

/// The powers of the columns of a monomial x̃₁^f w^w x̃₃^c ỹ^y, indexed by [`Column`].
pub type ColumnPowers = [u8; 4];

/// The channel whose table holds `part`'s factor under `noise`: the first that lists it and
/// is on, else the first that lists it (with its noise-free value). Two channels list w,
/// the speed sensor's and the air-speed sensor's, never on together; the other's table
/// gives it the factor 1.
pub(super) fn holder(part: Part, noise: &NoiseLevels) -> Channel {
    let listing = || {
        Channel::ALL
            .into_iter()
            .filter(|c| c.parts().contains(&part))
    };
    listing()
        .find(|&c| noise.is_on(c))
        .or_else(|| listing().next())
        .expect("every part is a channel's")
}

/// The column powers of a sum's term.
pub fn powers_of(sum: Sum) -> ColumnPowers {
    let mut p = [0u8; 4];
    for c in sum.factors() {
        p[c.index()] += 1;
    }
    p
}

/// The column powers of the product of two sums' terms.
pub fn powers_of_pair(a: Sum, b: Sum) -> ColumnPowers {
    let (pa, pb) = (powers_of(a), powers_of(b));
    std::array::from_fn(|i| pa[i] + pb[i])
}

/// A column monomial expanded into parts: ỹ^y = Σ y!/(ka! ks! ko! kd!) a^ka s̃^ks o^ko d^kd,
/// each term (its coefficient, ka, the parts' powers).
#[derive(Debug, Clone)]
struct Expansion {
    terms: Vec<(f64, u8, Powers)>,
}

impl Expansion {
    /// The expansion of x̃₁^f w^w x̃₃^c ỹ^y, without the parts of `skip`.
    fn new(p: ColumnPowers, skip: Option<Channel>) -> Self {
        let skipped = |part: Part| skip.is_some_and(|c| c.parts().contains(&part));
        let y = p[Column::Y.index()];
        let mut terms = Vec::new();
        for ks in 0..=y {
            for ko in 0..=y - ks {
                for kd in 0..=y - ks - ko {
                    if (ks > 0 && skipped(Part::S))
                        || (ko > 0 && skipped(Part::O))
                        || (kd > 0 && skipped(Part::D))
                    {
                        continue;
                    }
                    let ka = y - ks - ko - kd;
                    let coefficient = factorial(y)
                        / (factorial(ka) * factorial(ks) * factorial(ko) * factorial(kd));
                    let mut powers = [0u8; PART_COUNT];
                    powers[Part::F as usize] = p[Column::F.index()];
                    powers[Part::W as usize] = p[Column::W.index()];
                    powers[Part::C as usize] = p[Column::C.index()];
                    powers[Part::S as usize] = ks;
                    powers[Part::O as usize] = ko;
                    powers[Part::D as usize] = kd;
                    terms.push((coefficient, ka, powers));
                }
            }
        }
        Expansion { terms }
    }
}

/// A term of an [`Expansion`] with its place in each channel's table: (coefficient, ka,
/// index per channel).
type Compiled = (f64, u8, [usize; CHANNEL_COUNT]);

/// The terms of `e` that can be non-zero under `noise` (a part that is 0 without noise, o or
/// d, vanishes where its channel leaves it so), each with its table indices.
fn compile(e: &Expansion, noise: &NoiseLevels) -> Vec<Compiled> {
    let zero = |part: Part| match part {
        Part::O => !noise.is_on(Channel::Output),
        Part::D => !noise.speed_noise_differentiated(),
        _ => false,
    };
    e.terms
        .iter()
        .filter(|(_, _, p)| {
            !Part::ALL
                .iter()
                .any(|&part| p[part as usize] > 0 && zero(part))
        })
        .map(|&(coefficient, ka, p)| {
            let index = Channel::ALL.map(|c| ChannelTable::index(c.parts(), &p));
            (coefficient, ka, index)
        })
        .collect()
}

/// The moments of one row's measured columns: each channel's table of its parts.
#[derive(Debug, Clone)]
pub struct RowMoments {
    tables: [ChannelTable; CHANNEL_COUNT],
    accel: f64,
    /// Under the noise the moments are of, the channel that holds each part ([`holder`]).
    holders: [Channel; PART_COUNT],
    /// The channels off that hold no part: their entries are all 1, set once.
    ones: [bool; CHANNEL_COUNT],
}

impl RowMoments {
    /// The moments of row `r` under `noise` (`None`: a channel that is on does not derive
    /// them).
    pub fn new(noise: &NoiseLevels, r: &TrueRow) -> Option<Self> {
        let entries = Channel::ALL.map(|c| ChannelTable::entries(c, None));
        let mut row = RowMoments::empty(noise);
        row.fill(noise, r, &entries)?;
        Some(row)
    }

    /// Moments under `noise` with every entry unset (NaN).
    fn empty(noise: &NoiseLevels) -> Self {
        let holders = Part::ALL.map(|part| holder(part, noise));
        let ones = Channel::ALL.map(|c| !noise.is_on(c) && !holders.contains(&c));
        RowMoments {
            tables: Channel::ALL.map(|c| ChannelTable {
                parts: c.parts(),
                values: [if ones[c.index()] { 1.0 } else { f64::NAN }; TABLE],
            }),
            accel: f64::NAN,
            holders,
            ones,
        }
    }

    /// Set the table entries `entries` of each channel to row `r`'s.
    fn fill(
        &mut self,
        noise: &NoiseLevels,
        r: &TrueRow,
        entries: &[Vec<(usize, Powers)>; CHANNEL_COUNT],
    ) -> Option<()> {
        for ((c, table), e) in Channel::ALL.iter().zip(&mut self.tables).zip(entries) {
            if !self.ones[c.index()] {
                table.fill(*c, noise, r, e, &self.holders)?;
            }
        }
        self.accel = r.accel;
        Some(())
    }

    /// E\[x̃₁^f w^w x̃₃^c ỹ^y\] over every channel but `skip` (whose factor is taken as 1:
    /// its parts' powers must be 0, and ỹ is expanded without them).
    pub fn moment_without(&self, p: ColumnPowers, skip: Option<Channel>) -> f64 {
        self.expanded(&Expansion::new(p, skip), skip)
    }

    /// The moment whose expansion into parts is `e`, over every channel but `skip`.
    fn expanded(&self, e: &Expansion, skip: Option<Channel>) -> f64 {
        let mut total = 0.0;
        for (coefficient, ka, powers) in &e.terms {
            let mut term = coefficient * self.accel.powi(i32::from(*ka));
            for (c, table) in Channel::ALL.iter().zip(&self.tables) {
                if Some(*c) != skip {
                    term *= table.get(powers);
                }
            }
            total += term;
        }
        total
    }

    /// The moment of the compiled terms `terms` ([`compile`]).
    fn compiled(&self, terms: &[Compiled]) -> f64 {
        let mut total = 0.0;
        for (coefficient, ka, index) in terms {
            let mut term = coefficient * self.accel.powi(i32::from(*ka));
            for (table, &i) in self.tables.iter().zip(index) {
                term *= table.values[i];
            }
            total += term;
        }
        total
    }

    /// E\[x̃₁^f w^w x̃₃^c ỹ^y\] over every channel.
    pub fn moment(&self, p: ColumnPowers) -> f64 {
        self.moment_without(p, None)
    }
}

impl TrueRow {
    /// Row `i` of `reg` without noise.
    pub fn of(reg: &Regression, i: usize) -> Self {
        TrueRow {
            f: reg.f[i],
            v: reg.v[i],
            accel: reg.accel[i],
            sin_grade: reg.sin_grade[i],
            cos_grade: reg.cos_grade[i],
            g: reg.g,
            inv_dt: reg.differentiation.as_ref().map_or(0.0, |d| d.inv_dt[i]),
        }
    }
}

/// What a channel adds to the covariances of the sums through rows that share its noise.
#[derive(Debug, Clone, PartialEq)]
pub enum AcrossRows {
    /// Nothing: its draws enter one row each, independently.
    Nothing,
    /// Σ_{i≠j} Cov(aᵢ, bⱼ) per pair of the sums asked for (packed, a ≤ b).
    Covariance(Vec<f64>),
    /// Not derived for these levels.
    NotDerived,
}

/// Index of the pair (a, b), a ≤ b, of `q` items packed row by row.
pub fn packed(a: usize, b: usize, q: usize) -> usize {
    let (a, b) = (a.min(b), a.max(b));
    a * q - a * (a + 1) / 2 + b
}

/// The exact covariances of a condition's sums (packed, a ≤ b), with the resolution of each:
/// 2⁻⁵² Σᵢ (|E\[aᵢbᵢ\]| + |E\[aᵢ\]E\[bᵢ\]|) bounds the rounding of the per-row
/// subtractions, the largest error in them (docs/model.md#spread-control-variates).
#[derive(Debug, Clone, PartialEq)]
pub struct SumCovariances {
    /// Cov(a, b).
    pub value: Vec<f64>,
    /// The rounding error each may carry (absolute).
    pub resolution: Vec<f64>,
}

/// The exact covariance matrix of `sums` (packed, a ≤ b, in the order given) over the noise
/// `noise` of regression `reg`, with `ar1` the AR(1) coefficients of correlated speed noise
/// over [`Regression::noise_times`] (`None`: white); `None` where a channel that is on
/// does not derive its terms (docs/model.md#spread-control-variates lists the covered
/// combinations).
pub fn sum_covariances(
    reg: &Regression,
    noise: &NoiseLevels,
    ar1: Option<&[[f64; 2]]>,
    sums: &[Sum],
) -> Option<SumCovariances> {
    let q = sums.len();
    // The distinct monomials of the sums and their pairs, each expanded once.
    let mut monomials: Vec<ColumnPowers> = Vec::new();
    let mut index = |p: ColumnPowers| match monomials.iter().position(|&m| m == p) {
        Some(i) => i,
        None => {
            monomials.push(p);
            monomials.len() - 1
        }
    };
    let single: Vec<usize> = sums.iter().map(|&a| index(powers_of(a))).collect();
    let mut pairs = Vec::with_capacity(q * (q + 1) / 2);
    for a in 0..q {
        for b in a..q {
            pairs.push((
                index(powers_of_pair(sums[a], sums[b])),
                single[a],
                single[b],
            ));
        }
    }
    let expansions: Vec<Vec<Compiled>> = monomials
        .iter()
        .map(|&p| compile(&Expansion::new(p, None), noise))
        .collect();
    // The table entries the terms read, per channel.
    let mut used: [Vec<usize>; CHANNEL_COUNT] = Default::default();
    for (_, _, index) in expansions.iter().flatten() {
        for (u, &i) in used.iter_mut().zip(index) {
            if !u.contains(&i) {
                u.push(i);
            }
        }
    }
    let entries = Channel::ALL.map(|c| ChannelTable::entries(c, Some(&used[c.index()])));
    let mut total = vec![ExactSum::new(); pairs.len()];
    let mut magnitude = vec![0.0; pairs.len()];
    let mut values = vec![0.0; expansions.len()];
    let mut row = RowMoments::empty(noise);
    for i in 0..reg.len() {
        row.fill(noise, &TrueRow::of(reg, i), &entries)?;
        for (v, e) in values.iter_mut().zip(&expansions) {
            *v = row.compiled(e);
        }
        for ((t, m), &(ab, a, b)) in total.iter_mut().zip(&mut magnitude).zip(&pairs) {
            let product = values[a] * values[b];
            t.add(values[ab] - product);
            *m += values[ab].abs() + product.abs();
        }
    }
    // Every row's moments exist (checked above), so the channels' terms across rows may
    // build them again as they go.
    let row =
        |i: usize| RowMoments::new(noise, &TrueRow::of(reg, i)).expect("every row's moments exist");
    for c in Channel::ALL {
        if !noise.is_on(c) {
            continue;
        }
        match c.covariance_across_rows(reg, noise, ar1, &row, sums) {
            AcrossRows::Nothing => {}
            AcrossRows::Covariance(v) => {
                for (t, x) in total.iter_mut().zip(v) {
                    t.add(x);
                }
            }
            AcrossRows::NotDerived => return None,
        }
    }
    Some(SumCovariances {
        value: total.iter().map(ExactSum::value).collect(),
        resolution: magnitude.iter().map(|m| 2.0 * f64::EPSILON * m).collect(),
    })
}

#[cfg(test)]
mod tests;
