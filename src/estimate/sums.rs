//! The sums of the normal equations, one typed list: each [`Sum`] is a product of measured
//! columns ([`Column`]), and [`Moments`] (a field per sum), the kernel's per-row
//! accumulation, the control variates (`controls.rs`) and their count are generated from
//! the one table of the `sums!` macro below (docs/model.md#control-variates).
//!
//! With x̃₁ = F̃, w = Ṽ², x̃₃ = −g cos θ̃ and ỹ the noisy output, column 2 of the regression
//! is −k w, so XᵀX and Xᵀy need only sums of products of (x̃₁, w, x̃₃, ỹ).

use std::ops::{Index, IndexMut};

/// A measured column of the regression whose products the sums are.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Column {
    /// x̃₁ = F̃ \[N\].
    F,
    /// w = Ṽ² \[m²/s²\] (column 2 of the regression is −k w).
    W,
    /// x̃₃ = −g cos θ̃ \[m/s²\].
    C,
    /// ỹ, the noisy output \[m/s²\].
    Y,
}

impl Column {
    /// Every column, in the order of a measured row `[x̃₁, w, x̃₃, ỹ]`.
    pub const ALL: [Column; 4] = [Column::F, Column::W, Column::C, Column::Y];

    /// Position in a measured row (and in [`Column::ALL`]).
    pub const fn index(self) -> usize {
        self as usize
    }
}

/// The table of sums: `Variant field [factor (* factor)] control-column unit "Σ …"`, in the
/// order of [`Sum::ALL`] and of the control-variate columns. Adding a line here adds the
/// field of [`Moments`], its sum row by row (`Moments::add_row`, the definition the
/// kernel's sums are tested against), its control variate (whose expectation and whether
/// it varies follow from its factors, `controls.rs`) and its column. Written by hand, each
/// checked: its BCLS correction (`Moments::compensate`, which
/// `every_compensated_sum_has_its_noise_free_expectation` checks), the hand-vectorised
/// sums of the fast path (`MomentAccumulator::finish` over `moments/lane_sums.rs`) and of the general
/// path and the segments (`moments/segment_sums.rs`), and the regression's noise-free sums
/// (`moments::noise_free_moments`): each builds [`Moments`] with every field named (a new
/// sum fails to compile there), and `fast_and_general_paths_build_the_same_moments`,
/// `the_vectorised_general_path_keeps_the_row_by_row_sums_within_rounding` and
/// `every_hand_written_list_sums_each_sum_by_its_factors` check the values against
/// [`Sum::factors`]. The noise-free segment sums (`wbcls::WeightSegments`) are derived from
/// [`Sum::regressors_only`].
macro_rules! sums {
    ($( $variant:ident $field:ident [$first:ident $(* $second:ident)?]
        $control:literal $unit:literal $what:literal; )*) => {
        /// One sum of a realisation's normal equations (a field of [`Moments`]).
        #[derive(Debug, Clone, Copy, PartialEq, Eq)]
        pub enum Sum {
            $( #[doc = concat!($what, ".")] $variant, )*
        }

        /// Number of sums (N and the grade term's sums apart).
        pub const SUM_COUNT: usize = [$(Sum::$variant),*].len();

        impl Sum {
            /// Every sum, in the order of [`Moments::sums`] and of the control variates.
            pub const ALL: [Sum; SUM_COUNT] = [$(Sum::$variant),*];

            /// Position in [`Sum::ALL`].
            pub const fn index(self) -> usize {
                self as usize
            }

            /// The columns whose product it sums (one column: the column's own sum).
            pub const fn factors(self) -> &'static [Column] {
                match self {
                    $( Sum::$variant => &[Column::$first $(, Column::$second)?], )*
                }
            }

            /// True when its factors are x̃₁ and x̃₃ alone (no w, no ỹ): a sum that is
            /// constant where those columns are noise-free.
            pub const fn regressors_only(self) -> bool {
                let f = self.factors();
                let mut i = 0;
                while i < f.len() {
                    if !matches!(f[i], Column::F | Column::C) {
                        return false;
                    }
                    i += 1;
                }
                true
            }

            /// Name of its control variate's column.
            pub const fn control_name(self) -> &'static str {
                match self {
                    $( Sum::$variant => $control, )*
                }
            }

            /// Unit of the sum.
            pub const fn unit(self) -> &'static str {
                match self {
                    $( Sum::$variant => $unit, )*
                }
            }

            /// Its control variate, in symbols: the sum minus its expectation.
            pub const fn control_description(self) -> &'static str {
                match self {
                    $( Sum::$variant => concat!($what, " − E"), )*
                }
            }

            /// The sum, in symbols.
            pub const fn symbol(self) -> &'static str {
                match self {
                    $( Sum::$variant => $what, )*
                }
            }
        }

        /// The sums of one realisation from which every estimator's normal equations are
        /// built: a field per [`Sum`], N, and the grade term's sums where they are summed.
        ///
        /// With x̃₁ = F̃, w = Ṽ², x̃₃ = −g cos θ̃ and ỹ the noisy output (column 2 is −k w).
        #[derive(Debug, Clone, Copy, Default, PartialEq)]
        pub struct Moments {
            $( #[doc = concat!($what, ".")] pub $field: f64, )*
            /// N.
            pub n: f64,
            /// The sums of the grade term s̃ = g sin θ̃ of ỹ (`None` where they are not
            /// summed: the fast path, which has no grade noise; only the grade noise's
            /// compensation reads them).
            pub grade: Option<GradeSums>,
        }

        impl Moments {
            /// The sums in the order of [`Sum::ALL`].
            pub fn sums(&self) -> [f64; SUM_COUNT] {
                [$(self.$field),*]
            }

            /// Add the products of one measured row `[x̃₁, w, x̃₃, ỹ]` (indexed by
            /// [`Column`]) to the sums, not to N: the definition, row by row, that the
            /// kernel's sums in lanes are checked against.
            #[cfg(test)]
            pub(crate) fn add_row(&mut self, row: &[f64; 4]) {
                $( self.$field += row[Column::$first.index()]
                    $(* row[Column::$second.index()])?; )*
            }

            /// Add every sum of `b` (not N, not the grade term's), each with one addition.
            #[inline(always)]
            fn add_sums(&mut self, b: &Moments) {
                $( self.$field += b.$field; )*
            }

            /// Add `q` times every sum of `b` (not N, not the grade term's).
            #[cfg(test)]
            fn add_scaled_sums(&mut self, b: &Moments, q: f64) {
                $( self.$field += q * b.$field; )*
            }
        }

        impl Index<Sum> for Moments {
            type Output = f64;
            fn index(&self, s: Sum) -> &f64 {
                match s {
                    $( Sum::$variant => &self.$field, )*
                }
            }
        }

        impl IndexMut<Sum> for Moments {
            fn index_mut(&mut self, s: Sum) -> &mut f64 {
                match s {
                    $( Sum::$variant => &mut self.$field, )*
                }
            }
        }
    };
}

sums! {
    FF s_11 [F * F] "cv_f_f" "N^2" "Σ x̃₁²";
    FC s_13 [F * C] "cv_f_c" "N m/s^2" "Σ x̃₁ x̃₃";
    CC s_33 [C * C] "cv_c_c" "m^2/s^4" "Σ x̃₃²";
    FY s_1y [F * Y] "cv_f_y" "N m/s^2" "Σ x̃₁ ỹ";
    CY s_3y [C * Y] "cv_c_y" "m^2/s^4" "Σ x̃₃ ỹ";
    FW s_1w [F * W] "cv_f_w" "N m^2/s^2" "Σ x̃₁ w";
    CW s_3w [C * W] "cv_c_w" "m^3/s^4" "Σ x̃₃ w";
    WW s_ww [W * W] "cv_w_w" "m^4/s^4" "Σ w²";
    WY s_wy [W * Y] "cv_w_y" "m^3/s^4" "Σ w ỹ";
    W s_w [W] "cv_w" "m^2/s^2" "Σ w";
    F s_1 [F] "cv_f" "N" "Σ x̃₁";
    C s_3 [C] "cv_c" "m/s^2" "Σ x̃₃";
    Y s_y [Y] "cv_y" "m/s^2" "Σ ỹ";
}

/// The sums of a realisation that involve the measured grade term s̃ = g sin θ̃ of ỹ on its
/// own: BCLS's correction of grade noise needs them (docs/model.md#bcls), because ỹ's grade
/// term and the rest of ỹ are scaled differently by the noise.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct GradeSums {
    /// Σ s̃.
    pub s_s: f64,
    /// Σ x̃₁ s̃.
    pub s_1s: f64,
    /// Σ x̃₃ s̃.
    pub s_3s: f64,
    /// Σ w s̃.
    pub s_ws: f64,
}

impl GradeSums {
    /// Add the grade term's products of one measured row `[x̃₁, w, x̃₃, ỹ]` with s̃ = `s`
    /// (the definition the kernel's sums are checked against).
    #[cfg(test)]
    pub(crate) fn add_row(&mut self, row: &[f64; 4], s: f64) {
        self.s_s += s;
        self.s_1s += row[Column::F.index()] * s;
        self.s_3s += row[Column::C.index()] * s;
        self.s_ws += row[Column::W.index()] * s;
    }

    /// Add every sum of `b` (destructured, so that a new field fails to compile here).
    fn add(&mut self, b: &GradeSums) {
        let GradeSums {
            s_s,
            s_1s,
            s_3s,
            s_ws,
        } = *b;
        self.s_s += s_s;
        self.s_1s += s_1s;
        self.s_3s += s_3s;
        self.s_ws += s_ws;
    }

    /// Add `q` times every sum of `b` (destructured, so that a new field fails to compile
    /// here).
    #[cfg(test)]
    fn add_scaled(&mut self, b: &GradeSums, q: f64) {
        let GradeSums {
            s_s,
            s_1s,
            s_3s,
            s_ws,
        } = *b;
        self.s_s += q * s_s;
        self.s_1s += q * s_1s;
        self.s_3s += q * s_3s;
        self.s_ws += q * s_ws;
    }
}

impl Moments {
    /// Add the sums of `b` (not its N), each with one addition: a block's sums to a
    /// realisation's.
    #[inline(always)]
    pub(crate) fn add(&mut self, b: &Moments) {
        self.add_sums(b);
        if let Some(g) = &b.grade {
            self.grade.get_or_insert_with(GradeSums::default).add(g);
        }
    }

    /// Add `q` times every sum of `b`, N included, field by field: the definition
    /// [`WeightedSums`] is checked against.
    #[cfg(test)]
    pub(crate) fn add_scaled(&mut self, b: &Moments, q: f64) {
        self.add_scaled_sums(b, q);
        self.n += q * b.n;
        if let Some(g) = &b.grade {
            self.grade
                .get_or_insert_with(GradeSums::default)
                .add_scaled(g, q);
        }
    }
}

/// Σ q·m over several [`Moments`] m, each sum with the additions of
/// [`Moments::add_scaled`] in the same order (so the same bits), held in arrays: the
/// compiler then takes four sums per instruction where [`Moments::add_scaled`] takes one
/// (the reweighting of many segments).
#[derive(Debug, Clone, Default)]
pub(crate) struct WeightedSums {
    sums: [f64; SUM_COUNT],
    n: f64,
    /// The grade term's sums (`None` until a moment that has them is added).
    grade: Option<[f64; 4]>,
}

impl WeightedSums {
    /// Add `q` times every sum of `b`, N included.
    #[inline(always)]
    pub(crate) fn add(&mut self, b: &Moments, q: f64) {
        for (a, s) in self.sums.iter_mut().zip(b.sums()) {
            *a += q * s;
        }
        self.n += q * b.n;
        if let Some(g) = &b.grade {
            let GradeSums {
                s_s,
                s_1s,
                s_3s,
                s_ws,
            } = *g;
            let grade = self.grade.get_or_insert([0.0; 4]);
            for (a, s) in grade.iter_mut().zip([s_s, s_1s, s_3s, s_ws]) {
                *a += q * s;
            }
        }
    }

    /// The weighted sums as [`Moments`].
    pub(crate) fn finish(&self) -> Moments {
        let mut m = Moments {
            n: self.n,
            grade: self.grade.map(|[s_s, s_1s, s_3s, s_ws]| GradeSums {
                s_s,
                s_1s,
                s_3s,
                s_ws,
            }),
            ..Moments::default()
        };
        for (s, v) in Sum::ALL.into_iter().zip(self.sums) {
            m[s] = v;
        }
        m
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::estimate::moments::segment_sums::segment_moments;
    use crate::estimate::moments::{RowChunks, RowsView};
    use crate::estimate::regression::test_regression;
    use crate::estimate::wbcls::WeightSegments;

    /// The hand-written lists of sums against their definition: for every [`Sum`], the
    /// regression's noise-free moments, its noise-free segment sums (the sums without w,
    /// the rest zero) and the segment sums of `moments/segment_sums.rs` (summed, and with those
    /// without w taken from the segment sums) equal Σ of the product of the sum's
    /// factors over the rows (the noise-free rows; the kernel's paths are checked against
    /// the macro's own `add_row` in `moments.rs`). The lists sum in other orders (lanes, blocks,
    /// exact sums) than this plain loop; each order's rounding error is below
    /// (N − 1)u Σ|term| + u Σ|term| for the products (Higham, Accuracy and Stability of
    /// Numerical Algorithms, 2nd ed., §4.2; u = ε/2), so the two agree within
    /// N ε Σ|term|, while a wrong or missing sum is off by the size of the sum.
    #[test]
    fn every_hand_written_list_sums_each_sum_by_its_factors() {
        let reg = test_regression();
        let w: Vec<f64> = reg.v.iter().map(|v| v * v).collect();
        let row = |i: usize| [reg.f[i], w[i], reg.c[i], reg.y[i]];
        // `without_w`: only the sums without w are expected (the others zero).
        let check = |what: &str, m: &Moments, a: usize, b: usize, without_w: bool| {
            for s in Sum::ALL {
                let (mut sum, mut abs) = (0.0, 0.0);
                if !s.factors().contains(&Column::W) || !without_w {
                    for i in a..b {
                        let t: f64 = s.factors().iter().map(|c| row(i)[c.index()]).product();
                        sum += t;
                        abs += t.abs();
                    }
                }
                let tolerance = (b - a) as f64 * f64::EPSILON * abs;
                assert!(
                    (m[s] - sum).abs() <= tolerance,
                    "{what} {a}..{b} {s:?}: {} vs {sum}",
                    m[s]
                );
            }
        };
        check(
            "noise_free_moments",
            &crate::estimate::moments::noise_free_moments(&reg),
            0,
            reg.len(),
            false,
        );
        let view = RowsView {
            f: &reg.f,
            w: &w,
            c: &reg.c,
            y: &reg.y,
            s: &reg.g_sin,
            noise_free_f_c: true,
            noise_free_y: true,
            chunks: RowChunks::NONE,
        };
        let segments = WeightSegments::of(&reg);
        let (ranges, constant) = (&segments.ranges, &segments.sums);
        assert!(ranges.len() > 3);
        // Every seventh segment and the last (shorter).
        let last = ranges.len() - 1;
        let picked = ranges.iter().zip(constant).enumerate();
        for (_, (&(a, b), k)) in picked.filter(|&(i, _)| i % 7 == 0 || i == last) {
            check("segments", k, a, b, true);
            check(
                "segment_moments",
                &segment_moments(view, a, b, None, false),
                a,
                b,
                false,
            );
            let m = segment_moments(view, a, b, Some(k), false);
            check("segment_moments with constants", &m, a, b, false);
            // The constants of ỹ are the sums it would take of the rows, bit for bit.
            let summed = RowsView {
                noise_free_y: false,
                ..view
            };
            let bits = |m: &Moments| (m.sums().map(f64::to_bits), m.n.to_bits());
            assert_eq!(
                bits(&m),
                bits(&segment_moments(summed, a, b, Some(k), false))
            );
        }
    }

    #[test]
    fn every_sum_reads_its_own_field_and_lists_its_factors_once() {
        let mut m = Moments::default();
        // Row [2, 3, 5, 7]: a product of two factors is their product, a single factor itself.
        m.add_row(&[2.0, 3.0, 5.0, 7.0]);
        for s in Sum::ALL {
            let expected: f64 = s
                .factors()
                .iter()
                .map(|c| [2.0, 3.0, 5.0, 7.0][c.index()])
                .product();
            assert_eq!(m[s], expected, "{s:?}");
            assert_eq!(m.sums()[s.index()], m[s], "{s:?}");
            assert!((1..=2).contains(&s.factors().len()));
        }
        for (i, s) in Sum::ALL.iter().enumerate() {
            assert_eq!(s.index(), i);
            for t in &Sum::ALL[i + 1..] {
                assert_ne!(s.factors(), t.factors());
                assert_ne!(s.control_name(), t.control_name());
            }
        }
    }

    /// The array sums give the bits of [`Moments::add_scaled`] field by field, with and
    /// without the grade term's sums (and where only some moments have them), and without a
    /// moment that has them, none.
    #[test]
    fn weighted_sums_are_add_scaled_bit_for_bit() {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(31);
        // Which moments have the grade term's sums: none, every one, every third.
        for every in [0, 1, 3] {
            let grade = every > 0;
            let mut want = Moments::default();
            let mut got = WeightedSums::default();
            for k in 0..500 {
                let mut m = Moments {
                    n: rng.random_range(1.0..60.0),
                    ..Moments::default()
                };
                for s in Sum::ALL {
                    m[s] = rng.random_range(-1e4..1e4);
                }
                m.grade = (grade && k % every == 1 % every).then(|| GradeSums {
                    s_s: rng.random_range(-10.0..10.0),
                    s_1s: rng.random_range(-1e4..1e4),
                    s_3s: rng.random_range(-1e3..1e3),
                    s_ws: rng.random_range(-1e5..1e5),
                });
                let q = 1.0 / rng.random_range(1e-3..10.0);
                want.add_scaled(&m, q);
                got.add(&m, q);
            }
            let got = got.finish();
            assert_eq!(got.grade.is_some(), grade);
            let bits = |m: &Moments| {
                let g = m.grade.unwrap_or_default();
                m.sums()
                    .into_iter()
                    .chain([m.n, g.s_s, g.s_1s, g.s_3s, g.s_ws])
                    .map(f64::to_bits)
                    .collect::<Vec<_>>()
            };
            assert_eq!(bits(&got), bits(&want));
        }
    }
}
