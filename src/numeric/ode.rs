//! The classical fixed-step Runge–Kutta method (RK4), the one stepper every drive mode and
//! the fit's bootstrap integrate with (docs/model.md#vehicle).

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
    mut derivative: impl FnMut(Stage, [f64; N]) -> Result<[f64; N], E>,
) -> Result<[f64; N], E> {
    let at =
        |k: &[f64; N], c: f64| -> [f64; N] { std::array::from_fn(|j| state[j] + c * h * k[j]) };
    let k2 = derivative(Stage::Half, at(&k1, 0.5))?;
    let k3 = derivative(Stage::Half, at(&k2, 0.5))?;
    let k4 = derivative(Stage::Full, std::array::from_fn(|j| state[j] + h * k3[j]))?;
    Ok(std::array::from_fn(|j| {
        state[j] + h / 6.0 * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j])
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
