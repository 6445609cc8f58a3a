//! The classical fixed-step Runge–Kutta method (RK4), the one stepper every drive mode and
//! the fit's bootstrap integrate with (docs/model.md#vehicle).

use super::simd::{Lanes, Scalar};

/// Where a stage of an RK4 step evaluates the derivative: the half step (stages 2 and 3)
/// or the full step (stage 4). The caller knows its time and inputs there.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stage {
    /// t + h/2.
    Half,
    /// t + h.
    Full,
}

/// One classical RK4 step of size `h` from `state`, whose derivative at the step's start is
/// `k1`: `derivative(stage, s)` is ds/dt at the stage's time and state `s`. Each component
/// is computed as s + c·h·k for the stages and s + h/6·(k₁ + 2k₂ + 2k₃ + k₄) at the end, in
/// that order (the bits of every cycle depend on it).
#[inline]
pub fn rk4_step<const N: usize, E>(
    state: [f64; N],
    h: f64,
    k1: [f64; N],
    derivative: impl FnMut(Stage, [f64; N]) -> Result<[f64; N], E>,
) -> Result<[f64; N], E> {
    rk4_step_in(Scalar, state, h, k1, derivative)
}

/// [`rk4_step`] with each component in the lanes of `l`: several independent systems
/// stepped side by side, each lane's operations those of [`rk4_step`] in the same order
/// (so the same bits as stepping each alone).
#[inline(always)]
pub fn rk4_step_in<L: Lanes, const N: usize, E>(
    l: L,
    state: [L::F64; N],
    h: f64,
    k1: [L::F64; N],
    mut derivative: impl FnMut(Stage, [L::F64; N]) -> Result<[L::F64; N], E>,
) -> Result<[L::F64; N], E> {
    let at = |k: &[L::F64; N], c: f64| -> [L::F64; N] {
        std::array::from_fn(|j| state[j] + l.splat(c * h) * k[j])
    };
    let k2 = derivative(Stage::Half, at(&k1, 0.5))?;
    let k3 = derivative(Stage::Half, at(&k2, 0.5))?;
    let k4 = derivative(
        Stage::Full,
        std::array::from_fn(|j| state[j] + l.splat(h) * k3[j]),
    )?;
    let (sixth, two) = (l.splat(h / 6.0), l.splat(2.0));
    Ok(std::array::from_fn(|j| {
        state[j] + sixth * (k1[j] + two * k2[j] + two * k3[j] + k4[j])
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_step_of_exponential_growth_is_the_fourth_order_taylor_polynomial() {
        // dy/dt = y: one RK4 step multiplies y by 1 + h + h²/2 + h³/6 + h⁴/24 exactly (in
        // exact arithmetic; here to rounding).
        let h = 0.1;
        let [y] = rk4_step::<1, ()>([1.0], h, [1.0], |_, [y]| Ok([y])).unwrap();
        let taylor = 1.0 + h + h * h / 2.0 + h.powi(3) / 6.0 + h.powi(4) / 24.0;
        assert!((y - taylor).abs() < 1e-15, "{y} {taylor}");
    }

    #[test]
    fn an_error_of_a_stage_stops_the_step() {
        let r = rk4_step([1.0, 0.0], 0.1, [0.0, 1.0], |stage, _| match stage {
            Stage::Full => Err("full"),
            Stage::Half => Ok([0.0, 1.0]),
        });
        assert_eq!(r, Err("full"));
    }
}
