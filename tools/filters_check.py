#!/usr/bin/env python3
"""Independent NumPy check of chassis-mc's `ekf` and `rls_mf` estimators and its path bound.

Written from the model's specification only (not from src/estimate/filters). The state is
x = [V, th = 1/M, phi]; with c = rho*Cd*A/2 and dt = t[k+1] - t[k]:

    V+   = V + dt*(th*(F - c V^2) - g*(Cr cos phi + sin phi)) + u,  u ~ N(0, qv)
    phi+ = phi + w,  w ~ N(0, q |V| dt);  th constant;  z = V + e,  e ~ N(0, sv^2)

Checks, against a `chassis-mc run` of a study with estimators ["ekf", "rls_mf"]:

1. The posterior Cramér-Rao bound along the true path of cycles.parquet (the covariance
   Riccati recursion of the Kalman filter linearised about the true states, from P0): its
   SDs of th and phi at the last sample against the engine's path_bound_inv_mass and
   path_bound_grade. Tolerance: 1 % relative.
2. An EKF and the two-forgetting-factor RLS (Vahidi et al. 2005) run on R simulated
   measurement sets z = v + sv N(0,1) (own RNG, all R vectorised): the mean and the
   empirical SD of th-hat at the end against the engine's realisations.parquet.
   Tolerance: 4 combined Monte Carlo standard errors (mean: SD/sqrt(R); SD: SD/sqrt(2(R-1));
   the two runs' MCSEs combined in quadrature).

    chassis-mc run tools/filters_check.toml --out /tmp/fcheck
    python3 tools/filters_check.py tools/filters_check.toml /tmp/fcheck [--R 200] [--seed 1]

Exit status 0 when every check passes, 1 otherwise.
"""

import argparse
import pathlib
import sys
import tomllib

import numpy as np
import pandas as pd

# The engine's filter defaults (not set in the study file).
FORGETTING_MASS, FORGETTING_GRADE, DIFFERENCE_WINDOW = 1.0, 0.999, 0.5


def params(study):
    s = tomllib.loads(pathlib.Path(study).read_text())
    v, e = s["vehicle"], s["estimation"]
    return dict(
        c=0.5 * v["air_density"] * v["drag_coefficient"] * v["frontal_area"],
        Cr=v["rolling_resistance"], g=v["gravity"], M=v["mass"],
        M0=e["prior_mass"], sdM=e["prior_mass_sd"], sd0=e["grade_sd0"],
        q=e["grade_walk"], qv=e["speed_process_sd"] ** 2, sv=s["noise"]["velocity_sd"][0],
        lam1=e.get("forgetting_mass", FORGETTING_MASS),
        lam2=e.get("forgetting_grade", FORGETTING_GRADE),
        window=e.get("difference_window", DIFFERENCE_WINDOW),
    )


def p0(p):
    """P0 = diag(sv^2, (sdM/M0^2)^2, sd0^2) as the six entries p00 p01 p02 p11 p12 p22."""
    return [p["sv"] ** 2, 0.0, 0.0, (p["sdM"] / p["M0"] ** 2) ** 2, 0.0, p["sd0"] ** 2]


def predict_update(P, a, b, d, qphi, qv, r):
    """One Riccati step: P- = J P J^T + diag(qv, 0, qphi) with J = [[a, b, d], [0,1,0], [0,0,1]],
    then the update by H = [1, 0, 0], R = r. Works on scalars or arrays. Returns (P, P-, S)."""
    p00, p01, p02, p11, p12, p22 = P
    m01 = a * p01 + b * p11 + d * p12
    m02 = a * p02 + b * p12 + d * p22
    m00 = a * (a * p00 + b * p01 + d * p02) + b * m01 + d * m02 + qv
    m22 = p22 + qphi
    S = m00 + r
    Pm = (m00, m01, m02, p11, p12, m22)
    Pn = (m00 - m00 * m00 / S, m01 - m00 * m01 / S, m02 - m00 * m02 / S,
          p11 - m01 * m01 / S, p12 - m01 * m02 / S, m22 - m02 * m02 / S)
    return Pn, Pm, S


def jac(p, V, th, phi, F, dt):
    """The entries (a, b, d) of dV+/d(V, th, phi) and the drift dt*(...) of V."""
    c, g, Cr = p["c"], p["g"], p["Cr"]
    a = 1.0 - 2.0 * dt * th * c * V
    b = dt * (F - c * V * V)
    d = -dt * g * (np.cos(phi) - Cr * np.sin(phi))
    return a, b, d


def path_bound(p, t, v, phi, F):
    """SDs of th and phi at the last sample from the Riccati recursion along the true path."""
    th = 1.0 / p["M"]
    dt = np.diff(t)
    a, b, d = jac(p, v[:-1], th, phi[:-1], F[:-1], dt)
    qphi = p["q"] * np.abs(v[:-1]) * dt
    P = p0(p)
    for ak, bk, dk, qk in zip(a.tolist(), b.tolist(), d.tolist(), qphi.tolist()):
        P, _, _ = predict_update(P, ak, bk, dk, qk, p["qv"], p["sv"] ** 2)
    return np.sqrt(P[3]), np.sqrt(P[5])


def ekf(p, t, F, z):
    """EKF on z of shape (N, R); returns th-hat at the last sample and its SD, each (R,)."""
    c, g, Cr = p["c"], p["g"], p["Cr"]
    R = z.shape[1]
    V, th, phi = z[0].copy(), np.full(R, 1.0 / p["M0"]), np.zeros(R)
    P = [np.full(R, x) for x in p0(p)]
    dts = np.diff(t).tolist()
    for k, dt in enumerate(dts):
        F_k = F[k]
        a, b, d = jac(p, V, th, phi, F_k, dt)
        Vm = V + dt * (th * (F_k - c * V * V) - g * (Cr * np.cos(phi) + np.sin(phi)))
        P, Pm, S = predict_update(P, a, b, d, p["q"] * np.abs(V) * dt, p["qv"], p["sv"] ** 2)
        innov = (z[k + 1] - Vm) / S
        V, th, phi = Vm + Pm[0] * innov, th + Pm[1] * innov, phi + Pm[2] * innov
    return th, np.sqrt(P[3])


def rls_mf(p, t, F, z):
    """Two-forgetting-factor RLS on z of shape (N, R); returns th-hat at the end, (R,)."""
    c, g, sv, lam1, lam2 = p["c"], p["g"], p["sv"], p["lam1"], p["lam2"]
    N, R = z.shape
    m = max(1, int(round(p["window"] / (t[1] - t[0]))))
    k = np.arange(m, N - m)
    y = (z[k + m] - z[k - m]) / (t[k + m] - t[k - m])[:, None]
    cs = np.vstack([np.zeros((1, R)), np.cumsum(z, axis=0)])
    Vbar = (cs[k + m + 1] - cs[k - m]) / (2 * m + 1)
    u = F[k][:, None] - c * Vbar * Vbar
    sy2 = 2.0 * sv ** 2 / (t[2 * m] - t[0]) ** 2
    th, beta = np.full(R, 1.0 / p["M0"]), np.full(R, p["Cr"])
    P1 = np.full(R, (p["sdM"] / p["M0"] ** 2) ** 2 / sy2)
    P2 = p["sd0"] ** 2 / sy2  # same in every realisation
    for yk, uk in zip(y, u):
        e = yk - (th * uk - g * beta)
        L1 = P1 * uk / (lam1 + uk * uk * P1)
        L2 = -g * P2 / (lam2 + g * g * P2)
        th = th + L1 * e
        beta = beta + L2 * e
        P1 = (1.0 - L1 * uk) * P1 / lam1
        P2 = (1.0 + g * L2) * P2 / lam2
    return th


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("study", nargs="?", default="tools/filters_check.toml")
    ap.add_argument("out", nargs="?", default="/tmp/fcheck")
    ap.add_argument("--R", type=int, default=200, help="simulated measurement sets")
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()

    p = params(args.study)
    out = pathlib.Path(args.out)
    cyc = pd.read_parquet(out / "cycles.parquet")
    cyc = cyc[cyc["used"]]
    t, v, phi, F = (cyc[col].to_numpy(float) for col in ("t", "v", "grade", "f_prop"))
    eng = pd.read_parquet(out / "realisations.parquet")
    ok = True

    print(f"N = {len(t)} samples, c = {p['c']:.6g} kg/m, sv = {p['sv']}, "
          f"lam1 = {p['lam1']}, lam2 = {p['lam2']}, window = {p['window']} s")
    print("\n(1) Bound along the true path (tolerance 1 %)")
    print(f"{'quantity':<22}{'numpy':>14}{'engine':>14}{'rel diff':>12}")
    b_th, b_phi = path_bound(p, t, v, phi, F)
    ekf_rows = eng[eng["estimator"] == "ekf"]
    for name, mine, col in (("SD(1/M) [1/kg]", b_th, "path_bound_inv_mass"),
                            ("SD(grade) [rad]", b_phi, "path_bound_grade")):
        theirs = ekf_rows[col].iloc[0]
        rel = mine / theirs - 1.0
        flag = "" if abs(rel) <= 0.01 else "  FAIL"
        ok &= not flag
        print(f"{name:<22}{mine:>14.6e}{theirs:>14.6e}{rel:>+12.3e}{flag}")

    rng = np.random.default_rng(args.seed)
    z = v[:, None] + p["sv"] * rng.standard_normal((len(v), args.R))
    th_ekf, sd_ekf = ekf(p, t, F, z)
    mine = {"ekf": th_ekf, "rls_mf": rls_mf(p, t, F, z)}

    print(f"\n(2) th-hat = 1/M-hat at the end, R = {args.R} (numpy) vs engine "
          f"(tolerance 4 combined MCSE); truth 1/M = {1 / p['M']:.6e}")
    print(f"{'estimator':<10}{'stat':<6}{'numpy':>14}{'engine':>14}{'diff':>12}"
          f"{'MCSE comb':>12}{'diff/MCSE':>11}")
    for est, th in mine.items():
        e = eng.loc[eng["estimator"] == est, "theta_inv_mass"].to_numpy(float)
        for stat, f, se in (("mean", np.mean, lambda x: np.std(x, ddof=1) / np.sqrt(len(x))),
                            ("SD", lambda x: np.std(x, ddof=1),
                             lambda x: np.std(x, ddof=1) / np.sqrt(2 * (len(x) - 1)))):
            diff, mc = f(th) - f(e), np.hypot(se(th), se(e))
            flag = "" if abs(diff) <= 4 * mc else "  FAIL"
            ok &= not flag
            print(f"{est:<10}{stat:<6}{f(th):>14.6e}{f(e):>14.6e}{diff:>+12.3e}"
                  f"{mc:>12.3e}{diff / mc:>+11.2f}{flag}")
    print(f"(info) ekf filter SD of 1/M at the end: numpy mean {sd_ekf.mean():.6e}, engine mean "
          f"{ekf_rows['filter_sd_inv_mass'].mean():.6e}")
    print("\nPASS" if ok else "\nFAIL")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
