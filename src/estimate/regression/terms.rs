//! The terms of a regression's sums that are not plain products of two columns, read in
//! lanes, and the grade's columns of a set of rows.

use super::Column;
use crate::numeric::simd::Lanes;
use crate::numeric::sum::Terms;

/// Σ aᵢ·xᵢ with x = −k V² column 2 (each xᵢ = (−k·Vᵢ)·Vᵢ rounded as the column holds it).
pub(super) struct DragDot<'a> {
    pub a: &'a [f64],
    pub v: &'a [f64],
    pub k: f64,
}

impl Terms for DragDot<'_> {
    fn len(&self) -> usize {
        assert_eq!(self.a.len(), self.v.len(), "a column per row");
        self.a.len()
    }
    #[inline(always)]
    fn at<L: Lanes>(&self, l: L, i: usize) -> L::F64 {
        let v = l.load(self.v, i);
        l.load(self.a, i) * (l.splat(-self.k) * v * v)
    }
}

/// Σ xᵢ² of column 2 (x as in [`DragDot`]).
pub(super) struct DragSquare<'a> {
    pub v: &'a [f64],
    pub k: f64,
}

impl Terms for DragSquare<'_> {
    fn len(&self) -> usize {
        self.v.len()
    }
    #[inline(always)]
    fn at<L: Lanes>(&self, l: L, i: usize) -> L::F64 {
        let v = l.load(self.v, i);
        let x = l.splat(-self.k) * v * v;
        x * x
    }
}

/// Column 3 c = −g cos θ, the grade term g sin θ and the output y = dV/dt + g sin θ of
/// rows with acceleration `accel` and grade of sine `sin` and cosine `cos`.
pub(super) fn grade_columns(
    g: f64,
    accel: &[f64],
    sin: &[f64],
    cos: &[f64],
) -> (Column, Column, Column) {
    let c = Column::collected(cos.iter().map(|cs| -g * cs));
    let g_sin = Column::collected(sin.iter().map(|s| g * s));
    let y = Column::collected(accel.iter().zip(g_sin.iter()).map(|(a, gs)| a + gs));
    (c, g_sin, y)
}
