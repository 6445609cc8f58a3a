//! A realisation's own regression made from its condition's where only part of its rows is
//! drawn anew (a calibration of the force, the elevation map's error in the grade): the
//! columns that stay are shared, the new ones written into the thread's spare storage, and
//! only the sums that hold a new column taken again. Each sum is exactly rounded from the
//! same products, so the result is bit for bit the regression built whole from those rows
//! (docs/model.md#model-errors).

use nalgebra::Vector3;

use super::derived::Derived;
use super::{Column, DragDot, Regression, grade_columns};
use crate::estimate::sums::GradeSums;
use crate::numeric::sum::{Dot, Plain, SquareDot, exact_sum_of};

impl Regression {
    /// This regression with its force column F logged through `logged` (a calibration
    /// drawn per realisation): bit for bit the regression built from the logged force.
    pub fn with_force(&self, logged: impl Fn(f64) -> f64) -> Regression {
        let f = Column::collected(self.f.iter().map(|&f| logged(f)));
        let dot = |a: &[f64], b: &[f64]| exact_sum_of(&Dot(a, b));
        let mut reg = self.clone();
        reg.xtx[(0, 0)] = dot(&f, &f);
        reg.xtx[(0, 1)] = exact_sum_of(&DragDot {
            a: &f,
            v: &self.v,
            k: self.k,
        });
        reg.xtx[(0, 2)] = dot(&f, &self.c);
        reg.xtx[(1, 0)] = reg.xtx[(0, 1)];
        reg.xtx[(2, 0)] = reg.xtx[(0, 2)];
        reg.xty[0] = dot(&f, &self.y);
        reg.grade_sums_noise_free.s_1s = dot(&f, &self.g_sin);
        reg.sum_f = exact_sum_of(&Plain(&f));
        reg.f = f;
        reg.derived = Derived::default();
        reg
    }

    /// This regression with the grade of each row replaced by the one whose sine and cosine
    /// are given (an elevation map's error drawn per realisation): the force, speed and
    /// acceleration stay, the sums that hold only them are kept and the rest taken again,
    /// so the result is bit for bit [`Regression::with_sin_cos`] of the rows with that
    /// grade.
    pub fn with_grade(&self, sin_grade: Column, cos_grade: Column) -> Regression {
        assert!(
            sin_grade.len() == self.len() && cos_grade.len() == self.len(),
            "a grade per row"
        );
        assert!(
            self.differentiation.is_none(),
            "a model acceleration's regression"
        );
        let (c, g_sin, y) = grade_columns(self.g, &self.accel, &sin_grade, &cos_grade);
        let dot = |a: &[f64], b: &[f64]| exact_sum_of(&Dot(a, b));
        let drag = |a: &[f64]| {
            exact_sum_of(&DragDot {
                a,
                v: &self.v,
                k: self.k,
            })
        };
        let f = &self.f;
        let mut reg = self.clone();
        reg.xtx[(0, 2)] = dot(f, &c);
        reg.xtx[(1, 2)] = drag(&c);
        reg.xtx[(2, 2)] = dot(&c, &c);
        reg.xtx[(2, 0)] = reg.xtx[(0, 2)];
        reg.xtx[(2, 1)] = reg.xtx[(1, 2)];
        reg.xty = Vector3::new(dot(f, &y), drag(&y), dot(&c, &y));
        reg.grade_sums_noise_free = GradeSums {
            s_s: exact_sum_of(&Plain(&g_sin)),
            s_1s: dot(f, &g_sin),
            s_3s: dot(&c, &g_sin),
            s_ws: exact_sum_of(&SquareDot(&self.v, &g_sin)),
        };
        reg.sum_c = exact_sum_of(&Plain(&c));
        reg.sum_y = exact_sum_of(&Plain(&y));
        reg.c = c;
        reg.y = y;
        reg.g_sin = g_sin;
        reg.sin_grade = sin_grade;
        reg.cos_grade = cos_grade;
        reg.derived = Derived::default();
        reg
    }
}

impl Drop for Regression {
    /// Its columns that nothing else holds become the thread's spare storage.
    fn drop(&mut self) {
        for column in [
            &self.t,
            &self.f,
            &self.c,
            &self.v,
            &self.y,
            &self.accel,
            &self.g_sin,
            &self.sin_grade,
            &self.cos_grade,
        ] {
            column.recycle();
        }
    }
}
