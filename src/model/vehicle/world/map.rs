//! The elevation map's error drawn in every realisation: its forward differences along the
//! grid, the measured grade's tangent, sine and cosine at a regression's rows
//! (docs/model.md#grade-map).

use crate::dynamics::DriveCycle;
use crate::estimate::regression::Column;
use crate::noise::NormalSequence;
#[cfg(target_arch = "x86_64")]
use crate::numeric::simd::Avx2;
use crate::terrain::GRID_STEP_M;

/// The elevation map's error: a stationary AR(1) process along the distance on the terrain
/// grid (σ_h \[m\], correlation length L \[m\]); the measured grade is the forward
/// difference of the erroneous elevation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(in crate::model::vehicle) struct GradeMap {
    /// σ_h \[m\].
    pub sd_m: f64,
    /// L \[m\].
    pub length_m: f64,
}

impl GradeMap {
    /// How many forward differences [`GradeMap::differences`] draws to cover `end_m`: those
    /// of the grid points 0 ..= ⌊end_m⌋ + 2.
    pub(super) fn differences_to_cover(end_m: f64) -> usize {
        (end_m.max(0.0) / GRID_STEP_M).floor() as usize + 2
    }

    /// The forward differences dⱼ = eⱼ₊₁ − eⱼ of one realisation's map error e on the
    /// grid x = 0, 1, … m, far enough to cover `end_m`, from `normals`: in a buffer of the
    /// calling thread's, kept from one realisation to the next (a fresh one each time was
    /// page faults), which `read` is given.
    pub(super) fn differences<T>(
        &self,
        normals: &mut NormalSequence,
        end_m: f64,
        read: impl FnOnce(&[f64]) -> T,
    ) -> T {
        thread_local! {
            static BUFFER: std::cell::Cell<Vec<f64>> = const { std::cell::Cell::new(Vec::new()) };
        }
        let mut e = BUFFER.take();
        let points = Self::differences_to_cover(end_m) + 1;
        e.resize(points, 0.0);
        normals.fill(&mut e);
        let phi = (-GRID_STEP_M / self.length_m).exp();
        let innovation = self.sd_m * (1.0 - phi * phi).sqrt();
        e[0] *= self.sd_m;
        for j in 1..points {
            e[j] = phi * e[j - 1] + innovation * e[j];
        }
        // In place: dⱼ is written after eⱼ₊₁ and eⱼ are read.
        for j in 0..points - 1 {
            e[j] = e[j + 1] - e[j];
        }
        let out = read(&e[..points - 1]);
        BUFFER.set(e);
        out
    }
}

/// The grade \[rad\] measured from the map at `x_m` where the true grade is `grade_rad`,
/// driving with `heading` (+1 forwards, −1 backwards, where the vehicle sees the route's
/// grade negated, and the map's error too): atan(tan θ + heading·d(x)), d the map's forward
/// differences `d` per grid step, linear between grid points (as the terrain's grade is).
#[cfg(test)]
fn mapped_grade(grade_rad: f64, x_m: f64, heading: f64, d: &[f64]) -> f64 {
    mapped_tangent(grade_rad.tan(), x_m, heading, d).atan()
}

/// The tangent of the grade measured from the map ([`mapped_grade`]) where the true grade's
/// tangent is `tan_grade`: tan θ + heading·d(x).
pub(super) fn mapped_tangent(tan_grade: f64, x_m: f64, heading: f64, d: &[f64]) -> f64 {
    tangent_in_cell(tan_grade, heading, d, grid_cell(x_m, d.len()))
}

/// Where `x_m` falls on the grid of `len` forward differences: the index j of the cell
/// (at most `len` − 2) and the fraction u − j of the way through it, u = x / grid step.
#[inline(always)]
fn grid_cell(x_m: f64, len: usize) -> (usize, f64) {
    let u = (x_m / GRID_STEP_M).max(0.0);
    // u ≥ 0 (or NaN): truncation is its floor.
    let j = (u as usize).min(len - 2);
    (j, u - j as f64)
}

/// [`mapped_tangent`] at the grid cell `(j, fraction)` of [`grid_cell`].
#[inline(always)]
fn tangent_in_cell(tan_grade: f64, heading: f64, d: &[f64], (j, fraction): (usize, f64)) -> f64 {
    let error = d[j] + fraction * (d[j + 1] - d[j]);
    tan_grade + heading * error / GRID_STEP_M
}

/// The sine and cosine of the grade whose tangent is `t` (|θ| < π/2): t/√(1 + t²) and
/// 1/√(1 + t²), without the angle (docs/model.md#grade-map).
#[inline]
fn sin_cos_of_tangent(t: f64) -> (f64, f64) {
    let r = 1.0 / (1.0 + t * t).sqrt();
    (t * r, r)
}

/// The rows of a regression as the map reads them: each used sample's heading, true grade's
/// tangent and grid cell, and the farthest position. Where the map's error is the only thing
/// a realisation draws, they are the condition's, made once (a realisation draws only the
/// map's error); where the truth is drawn too, each realisation makes its own. The cells
/// are found here, for the forward differences drawn to cover `end_m`.
#[derive(Debug)]
pub(super) struct MapRows {
    heading: Vec<f64>,
    tan_grade: Vec<f64>,
    /// Each row's grid cell j and its fraction through it ([`grid_cell`]).
    cell: Vec<usize>,
    fraction: Vec<f64>,
    /// The number of forward differences [`GradeMap::differences`] draws to cover `end_m`,
    /// which the cells are found for.
    differences: usize,
    pub(super) end_m: f64,
}

impl MapRows {
    pub(super) fn new(cycle: &DriveCycle, used: &[bool]) -> MapRows {
        let rows: Vec<usize> = (0..cycle.len()).filter(|&i| used[i]).collect();
        let x_m: Vec<f64> = rows.iter().map(|&i| cycle.x_m[i]).collect();
        let end_m = x_m.iter().fold(0.0, |end, &x| f64::max(end, x));
        let differences = GradeMap::differences_to_cover(end_m);
        let (cell, fraction) = x_m.iter().map(|&x| grid_cell(x, differences)).unzip();
        MapRows {
            end_m,
            heading: rows.iter().map(|&i| cycle.heading(i)).collect(),
            tan_grade: rows.iter().map(|&i| cycle.grade_rad[i].tan()).collect(),
            cell,
            fraction,
            differences,
        }
    }

    /// The sine and cosine of the measured grade at each row under the map's forward
    /// differences `d` (drawn to cover `end_m`).
    pub(super) fn sin_cos(&self, d: &[f64]) -> (Column, Column) {
        assert_eq!(
            d.len(),
            self.differences,
            "the map's differences cover the rows"
        );
        let n = self.tan_grade.len();
        let [sin, cos] = Column::filled_together(n, |[sin, cos]| {
            #[cfg(target_arch = "x86_64")]
            if let Some(avx2) = Avx2::detect() {
                // SAFETY: the token proves the CPU has AVX2.
                return unsafe { self.sin_cos_avx2(avx2, d, sin, cos) };
            }
            self.sin_cos_into(d, sin, cos);
        });
        (sin, cos)
    }

    /// [`MapRows::sin_cos_into`] compiled for AVX2 (the same IEEE operations, four rows at
    /// a time where the compiler can).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn sin_cos_avx2(&self, _: Avx2, d: &[f64], sin: &mut [f64], cos: &mut [f64]) {
        self.sin_cos_into(d, sin, cos);
    }

    /// The sines and cosines of [`MapRows::sin_cos`] written into `sin` and `cos`.
    #[inline(always)]
    fn sin_cos_into(&self, d: &[f64], sin: &mut [f64], cos: &mut [f64]) {
        let cells = self.cell.iter().zip(&self.fraction);
        let rows = self.heading.iter().zip(&self.tan_grade).zip(cells);
        for (s, ((heading, tan), (j, fraction))) in sin.iter_mut().zip(rows) {
            *s = tangent_in_cell(*tan, *heading, d, (*j, *fraction));
        }
        // The tangents become sines as the cosines are written.
        for (s, c) in sin.iter_mut().zip(cos) {
            (*s, *c) = sin_cos_of_tangent(*s);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::estimate::regression::Regression;

    #[test]
    fn the_maps_grade_error_has_the_variance_of_its_forward_difference() {
        // Var(e_{j+1} − e_j) = 2σ²(1 − φ), φ = exp(−Δx/L), for the stationary AR(1) e.
        let map = GradeMap {
            sd_m: 0.5,
            length_m: 50.0,
        };
        let mut normals = NormalSequence::for_realisation(7, 0, crate::noise::Stream::GradeMap, 0);
        let d = map.differences(&mut normals, 400_000.0, <[f64]>::to_vec);
        let n = d.len() as f64;
        let var = d.iter().map(|x| x * x).sum::<f64>() / n;
        let expected = 2.0 * 0.25 * (1.0 - (-1.0f64 / 50.0).exp());
        // d is a moving difference of an AR(1) with L = 50 grid steps: its sample variance
        // over 4e5 steps has a relative SE of about sqrt(2/4e5) ≈ 0.22 % (d's autocorrelation
        // beyond lag 1 is tiny); 5 % is over 20 SE.
        assert!((var / expected - 1.0).abs() < 0.05, "{var} vs {expected}");
        // At a grid point on a flat road the measured grade is atan(d_j).
        assert_eq!(mapped_grade(0.0, 10.0, 1.0, &d), d[10].atan());
        // Driven backwards, the vehicle sees the map's grade negated.
        assert_eq!(mapped_grade(0.0, 10.0, -1.0, &d), -d[10].atan());
    }

    #[test]
    fn the_grade_by_its_tangent_agrees_with_the_angle_s_sine_and_cosine() {
        // The map's grade enters by t/√(1 + t²) and 1/√(1 + t²) where it entered as
        // sin(atan t) and cos(atan t): four roundings against libm's near-correct ones, so
        // within a few ulps (4 allowed) on the grades a road has.
        for k in -4000..=4000 {
            let t = f64::from(k) * 1.25e-4;
            let (s, c) = sin_cos_of_tangent(t);
            let a = t.atan();
            assert!(
                (s - a.sin()).abs() <= 4.0 * f64::EPSILON * a.sin().abs(),
                "{t}"
            );
            assert!((c - a.cos()).abs() <= 4.0 * f64::EPSILON, "{t}");
        }
        // The regression's constant sums, built from the two, agree to 1e-12 relative to
        // the sum of the terms' magnitudes (a few ulps per term; the sums are exactly
        // rounded).
        let vehicle = crate::dynamics::VehicleParams::thesis();
        let cycle = crate::estimate::regression::test_cycle();
        let tangents: Vec<f64> = (cycle.grade_rad.iter().enumerate())
            .map(|(i, g)| g.tan() + 0.003 * (i as f64 * 0.01).sin())
            .collect();
        let mut by_angle = cycle.clone();
        by_angle.grade_rad = tangents.iter().map(|t| t.atan()).collect();
        let old = Regression::new(&by_angle, &vehicle);
        let new = Regression::with_sin_cos(
            &cycle,
            Column::collected(tangents.iter().map(|&t| sin_cos_of_tangent(t).0)),
            Column::collected(tangents.iter().map(|&t| sin_cos_of_tangent(t).1)),
            &vehicle,
        );
        // Σ|terms| bounded by the sums of the rows' magnitudes.
        let mut magnitudes = cycle.clone();
        for column in [&mut magnitudes.f_prop_n, &mut magnitudes.accel_m_s2] {
            column.iter_mut().for_each(|x| *x = x.abs());
        }
        let scales = Regression::with_sin_cos(
            &magnitudes,
            Column::collected(tangents.iter().map(|&t| sin_cos_of_tangent(t).0.abs())),
            Column::collected(tangents.iter().map(|&t| sin_cos_of_tangent(t).1)),
            &vehicle,
        );
        let all =
            |r: &Regression| -> Vec<f64> { r.xtx.iter().chain(r.xty.iter()).copied().collect() };
        for ((a, b), scale) in all(&old).into_iter().zip(all(&new)).zip(all(&scales)) {
            let scale = scale.abs();
            assert!((a - b).abs() <= 1e-12 * scale, "{a} vs {b}");
        }
    }
}
