"""The linearised covariance of OLS θ̂ under a differentiated acceleration, in the real world
of studies/fit_log.toml and in `fit`'s bootstrap worlds (docs/model.md#fit).

For white speed noise e (σ = 0.1 m/s) the regression's error is, to first order,
(XᵀX)⁻¹ Σⱼ eⱼ wⱼ with wⱼ the weight of sample j in Σᵢ xᵢ (eᵢ₊₁ − eᵢ₋₁)/(tᵢ₊₁ − tᵢ₋₁) and in the
V² column's own noise. Prints, per log, the SEs of each bootstrap world over the real one:
"smoothed" (force from the central differences of the smoothed measured speed, rows from
that speed ≥ min_speed: the old world), "simulated, own rows" (the fitted vehicle simulated
under the logged force, rows from its speed) and "simulated, log's rows" (what `fit` does).

    chassis-mc simulate-log studies/fit_log.toml --out DIR/log0.csv --realisation 0   # … r
    sed 's/velocity_sd = \\[0.1\\]/velocity_sd = [0.0]/' studies/fit_log.toml > clean.toml
    chassis-mc simulate-log clean.toml --out DIR/clean.csv
    python3 analysis/fit_bootstrap_world.py DIR/clean.csv DIR/log*.csv
"""

import argparse

import numpy as np

K, G, SD, MIN_SPEED = 0.5 * 1.2 * 5.5, 9.81, 0.1, 0.5
THETA = np.array([1 / 1800, 0.35 / 1800, 0.0125])  # the truth stands in for θ̂


def load(path):
    d = np.genfromtxt(path, delimiter=",", names=True)
    return d["time_s"], d["speed_m_s"], d["force_n"], d["grade_rad"]


def central(t, v):
    i = np.arange(len(t))
    a, b = np.maximum(i - 1, 0), np.minimum(i + 1, len(t) - 1)
    return (v[b] - v[a]) / (t[b] - t[a])


def smoothed(t, v, half=0.5):
    return np.array([max(v[np.abs(t - ti) <= half + 1e-12].mean(), 0.0) for ti in t])


def rows(v):
    used = v >= MIN_SPEED
    used[0] = used[-1] = False
    return used


def se(t, v, f, grade, used):
    r = np.nonzero(used)[0]
    x = np.column_stack([f[r], -K * v[r] ** 2, -G * np.cos(grade[r])])
    q = 1 / (t[r + 1] - t[r - 1])
    w = np.zeros((len(t), 3))
    np.add.at(w, r + 1, x * q[:, None])
    np.add.at(w, r - 1, -x * q[:, None])
    np.add.at(w, r, x * (THETA[1] * 2 * K * v[r])[:, None])
    bread = np.linalg.inv(x.T @ x)
    return np.sqrt(np.diag(bread @ (w.T @ w) @ bread)) * SD


def simulated(t, s, f, grade, used, tau=None):
    """RK4 over each stretch that used rows read, from s at its start (as src/fit.rs)."""
    n = len(t)
    read = used | np.r_[False, used[:-1]] | np.r_[used[1:], False]

    def accel(v, fi, gi, si):
        a = THETA[0] * fi - THETA[1] * K * v * abs(v) - THETA[2] * G * np.cos(gi) - G * np.sin(gi)
        return a + ((si - v) / tau if tau else 0.0)

    v = s.copy()
    for i in range(n - 1):
        if not (read[i] and read[i + 1]):
            continue
        h = t[i + 1] - t[i]
        fm, gm, sm = (f[i] + f[i + 1]) / 2, (grade[i] + grade[i + 1]) / 2, (s[i] + s[i + 1]) / 2
        k1 = accel(v[i], f[i], grade[i], s[i])
        k2 = accel(v[i] + h / 2 * k1, fm, gm, sm)
        k3 = accel(v[i] + h / 2 * k2, fm, gm, sm)
        k4 = accel(v[i] + h * k3, f[i + 1], grade[i + 1], s[i + 1])
        v[i + 1] = v[i] + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return v


def world_force(t, v, grade):
    resistance = THETA[1] * K * v * v + THETA[2] * G * np.cos(grade) + G * np.sin(grade)
    return (central(t, v) + resistance) / THETA[0]


def main(clean, logs):
    _, v_true, f_true, _ = load(clean)
    print("log: SE ratio [1/M, Cd/M, Cr] of each world to the real one")
    for path in logs:
        t, v, f, grade = load(path)
        used = rows(v)
        real = se(t, v_true, f_true, grade, used)
        s = smoothed(t, v)
        worlds = {"smoothed": (s, rows(s))}
        for tau in (None, 30.0, 10.0):
            w = simulated(t, s, f, grade, used, tau)
            name = "simulated, log's rows" + (f", pull τ = {tau:g} s" if tau else "")
            worlds[name] = (w, used)
            if tau is None:
                worlds["simulated, own rows"] = (w, rows(w))
        for name, (w, u) in worlds.items():
            fw = world_force(t, w, grade)
            rough = np.std(np.diff(fw[used], 2))  # over the rows the log uses
            ratio = se(t, w, fw, grade, u) / real
            print(f"{path} {name:32} {np.round(ratio, 3)}  rms 2nd diff of F {rough:.3g} N")
        print(f"{path} log's force: rms 2nd diff {np.std(np.diff(f_true[used], 2)):.3g} N")


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("clean", help="the noise-free log (simulate-log of velocity_sd = [0.0])")
    ap.add_argument("logs", nargs="+", help="noisy logs of the same study (simulate-log)")
    args = ap.parse_args()
    main(args.clean, args.logs)
