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

3. `--drawn`, on a study whose realisations each draw their own truth (`[truth]
   speed_process_sd`, `mass_from_prior`; torque drive, cos2 terrain, one condition): the
   condition's averaged PCRLB (summary.parquet's pcrlb_inv_mass, pcrlb_grade and their _60s,
   _120s, _300s), the Tichavsky recursion with each expectation the mean over 100 truths.
   Our truths are stepped from cycles.parquet's first speed and position with its force f_prop
   by the filters' Euler step plus s N(0,1), the grade the terrain's table interpolated at the
   truth's distance; the recursion is written as the joint information of (d_k, d_k+1, th),
   d = [V, phi], marginalised on d_k, vectorised over groups of truths. Checks (replacing 1-2):
   (D0) the recursion on one truth's own path equals the covariance Riccati of check 1 on it
   (relative 1e-6); (D1) the engine's values against the mean over K independent sets of 100
   truths (own seeds): z = (engine - mean) / SD across the sets, |z| <= 4 (where that SD is
   below 1e-6 of the mean the bound barely depends on the draw and the test is relative,
   1e-5); (D2, reported) the averaged bound against the bounds along single truths' paths
   (cycles.parquet's, ours, the engine's path_bound_* per realisation), the size of the effect
   of averaging.

    python3 tools/filters_check.py --write-drawn-study /tmp/pcheck/study.toml  # [truth] added
    chassis-mc run /tmp/pcheck/study.toml --out /tmp/pcheck/out
    python3 tools/filters_check.py --drawn /tmp/pcheck/study.toml /tmp/pcheck/out [--K 10]
        [--truths 100] [--seed 1]

Exit status 0 when every check passes, 1 otherwise.
"""

import argparse
import pathlib
import re
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


# --- the averaged PCRLB over drawn truths (--drawn) -------------------------------------------

CHECKPOINTS = (60.0, 120.0, 300.0)  # s after the first row, as the engine's _60s, _120s, _300s


def grade_table(study):
    """The terrain's grade on the 1 m grid, theta_i for x = i = 0 ... L-1 (docs/model.md sec. 2).
    Profile cos2 and one scale only."""
    tr = tomllib.loads(pathlib.Path(study).read_text())["terrain"]
    if tr["profile"] != "cos2" or len(tr["scales"]) != 1:
        sys.exit("--drawn: only terrain.profile = \"cos2\" with one scale is implemented")
    x = np.arange(tr["length"] + 1, dtype=float)
    rise = np.diff(tr["height"] * np.cos(x / tr["period"]) ** 2)
    a = tr["scales"][0]
    if tr["scale_applies_to"] == "grade":
        return a * np.arctan(rise)
    if tr["scale_applies_to"] == "elevation":
        return np.arctan(a * rise)
    sys.exit(f"--drawn: unknown terrain.scale_applies_to {tr['scale_applies_to']!r}")


def truth_keys(study):
    """(speed_process_sd, mass_from_prior) of the study's [truth] table."""
    tr = tomllib.loads(pathlib.Path(study).read_text()).get("truth", {})
    return float(tr.get("speed_process_sd", 0.0)), bool(tr.get("mass_from_prior", False))


def draw_truths(p, t, F, v0, x0, table, s_u, from_prior, n, rng):
    """n truths stepped with the filters' Euler step (docs/model.md#filter-truth): from V0 = v0,
    X0 = x0, V+ = V + dt*(th*(F - c V^2) - g*(Cr cos phi + sin phi)) + s_u N(0,1), X+ = X + dt*V,
    phi = the table linearly interpolated at X. th = 1/M, or drawn from the filters' prior.
    Returns V and phi of shape (N, n) and th of shape (n,)."""
    c, g, Cr = p["c"], p["g"], p["Cr"]
    N = len(t)
    if from_prior:
        th = 1.0 / p["M0"] + (p["sdM"] / p["M0"] ** 2) * rng.standard_normal(n)
    else:
        th = np.full(n, 1.0 / p["M"])
    grid = np.arange(len(table), dtype=float)
    u = s_u * rng.standard_normal((N - 1, n))
    V, PHI = np.empty((N, n)), np.empty((N, n))
    Vk, Xk = np.full(n, float(v0)), np.full(n, float(x0))
    for k, dt in enumerate(np.diff(t).tolist()):
        if Vk.min() <= 0.0 or Xk.max() > grid[-1]:
            sys.exit("--drawn: a truth stalled or left the terrain's table (not handled)")
        phi = np.interp(Xk, grid, table)
        V[k], PHI[k] = Vk, phi
        Vk, Xk = (Vk + dt * (th * (F[k] - c * Vk * Vk) - g * (Cr * np.cos(phi) + np.sin(phi)))
                  + u[k], Xk + dt * Vk)
    V[-1], PHI[-1] = Vk, np.interp(Xk, grid, table)
    return V, PHI, th


def expectations(p, t, F, V, PHI, th):
    """The means over the truths (columns of V, PHI) of the ten products the recursion needs,
    at each step k = 0 ... N-2, shape (N-1, 10): with the step's Jacobians at the truth,
    A = [[a, d], [0, 1]], B = [b, 0], W = diag(1/qv, w2), w2 = 1/(q |V| dt):
    E a^2, E ad, E d^2, E w2, E a, E d, E ab, E db, E b, E b^2."""
    dt = np.diff(t)[:, None]
    a, b, d = jac(p, V[:-1], th[None, :], PHI[:-1], F[:-1, None], dt)
    w2 = 1.0 / (p["q"] * np.abs(V[:-1]) * dt)
    return np.stack([x.mean(axis=1) for x in
                     (a * a, a * d, d * d, w2, a, d, a * b, d * b, b, b * b)], axis=1)


def sd_from_information(J):
    """SDs of th and phi, the diagonal of J^-1 for J of shape (..., 3, 3) in the order
    (V, phi, th); J is equilibrated (scaled to a unit diagonal) before it is inverted."""
    s = 1.0 / np.sqrt(np.diagonal(J, axis1=-2, axis2=-1))
    C = np.linalg.inv(J * s[..., :, None] * s[..., None, :])
    var = np.diagonal(C, axis1=-2, axis2=-1) * s * s
    return np.sqrt(var[..., 2]), np.sqrt(var[..., 1])


def averaged_pcrlb(p, E, rows):
    """The Tichavsky recursion in information form with the parameter th static, one per group.
    E: (N-1, G, 10) from `expectations` (each group's means over its truths). The information
    of (d_k, d_{k+1}, th) given J_k, the information of (d_k = [V_k, phi_k], th), is

        M = [[J_dd + E[A'WA], -E[A'W],        J_dp + E[A'WB]],
             [.,              E[W] + H'H/sv^2, -E[WB]        ],
             [.,              .,               J_pp + E[B'WB]]]     (5 x 5, symmetric)

    and J_{k+1} its Schur complement on d_k (written here as the joint matrix marginalised
    with a batched solve). J_0 = diag(1/sv^2, 1/sd0^2, 1/Var(1/M)) in the order (V, phi, th).
    Returns the SDs of th and phi at the given row indices, each of shape (G, len(rows))."""
    w1, G = 1.0 / p["qv"], E.shape[1]
    J = np.zeros((G, 3, 3))
    J[:, 0, 0], J[:, 1, 1] = 1.0 / p["sv"] ** 2, 1.0 / p["sd0"] ** 2
    J[:, 2, 2] = (p["M0"] ** 2 / p["sdM"]) ** 2
    keep = {}
    if 0 in rows:
        keep[0] = J.copy()
    M = np.zeros((G, 5, 5))
    for k in range(E.shape[0]):
        ea2, ead, ed2, ew2, ea, ed, eab, edb, eb, eb2 = E[k].T
        M[:] = 0.0
        M[:, :2, :2] = J[:, :2, :2]
        M[:, :2, 4] = M[:, 4, :2] = J[:, :2, 2]
        M[:, 4, 4] = J[:, 2, 2] + w1 * eb2
        M[:, 0, 0] += w1 * ea2
        M[:, 0, 1] += w1 * ead
        M[:, 1, 0] += w1 * ead
        M[:, 1, 1] += w1 * ed2 + ew2
        M[:, 0, 2] = M[:, 2, 0] = -w1 * ea      # -E[A'W]: rows d_k, columns d_{k+1}
        M[:, 1, 2] = M[:, 2, 1] = -w1 * ed
        M[:, 1, 3] = M[:, 3, 1] = -ew2
        M[:, 0, 4] += w1 * eab                  # E[A'WB]
        M[:, 4, 0] += w1 * eab
        M[:, 1, 4] += w1 * edb
        M[:, 4, 1] += w1 * edb
        M[:, 2, 2] = w1 + 1.0 / p["sv"] ** 2    # E[W] + H'H/sv^2
        M[:, 3, 3] = ew2
        M[:, 2, 4] = M[:, 4, 2] = -w1 * eb      # -E[WB]
        C = M[:, :2, 2:]
        J = M[:, 2:, 2:] - np.swapaxes(C, 1, 2) @ np.linalg.solve(M[:, :2, :2], C)
        J = 0.5 * (J + np.swapaxes(J, 1, 2))
        if k + 1 in rows:
            keep[k + 1] = J.copy()
    sd_th, sd_phi = sd_from_information(np.stack([keep[r] for r in rows], axis=1))
    return sd_th, sd_phi


def path_bounds(p, t, F, V, PHI, th, rows):
    """The covariance-form Riccati (`path_bound`) along each truth's own path, vectorised over
    the columns of V and PHI. Returns the SDs of th and phi at the rows, each (n, len(rows))."""
    n = V.shape[1]
    P = [np.full(n, x) for x in p0(p)]
    out = {0: (P[3], P[5])}
    for k, dt in enumerate(np.diff(t).tolist()):
        a, b, d = jac(p, V[k], th, PHI[k], F[k], dt)
        P, _, _ = predict_update(P, a, b, d, p["q"] * np.abs(V[k]) * dt, p["qv"], p["sv"] ** 2)
        if k + 1 in rows:
            out[k + 1] = (P[3], P[5])
    return (np.sqrt(np.stack([out[r][0] for r in rows], axis=1)),
            np.sqrt(np.stack([out[r][1] for r in rows], axis=1)))


def write_drawn_study(base, path, sd):
    """The study `base` with a [truth] table speed_process_sd = sd appended, written to path."""
    text = pathlib.Path(base).read_text()
    if re.search(r"^\s*\[truth\]", text, re.M):
        sys.exit(f"{base} already has a [truth] table")
    path = pathlib.Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text.rstrip("\n") + f"\n[truth]\nspeed_process_sd = {sd!r}\n")
    print(f"wrote {path}; next:\n  chassis-mc run {path} --out OUT\n"
          f"  python3 tools/filters_check.py --drawn {path} OUT")


def main_drawn(args):
    """The --drawn check: the engine's averaged PCRLB (summary.parquet) against K of our own."""
    p = params(args.study)
    s_u, from_prior = truth_keys(args.study)
    if s_u == 0.0 and not from_prior:
        sys.exit(f"--drawn: {args.study} draws no truth (no truth.speed_process_sd or "
                 "mass_from_prior); write one with --write-drawn-study")
    table = grade_table(args.study)
    out = pathlib.Path(args.out)
    cyc = pd.read_parquet(out / "cycles.parquet")
    cyc = cyc[cyc["used"]]
    t, x, v, phi, F = (cyc[col].to_numpy(float) for col in ("t", "x", "v", "grade", "f_prop"))
    summ = pd.read_parquet(out / "summary.parquet")
    if summ["condition"].nunique() != 1:
        sys.exit("--drawn: the study must have one condition")
    summ = summ[summ["pcrlb_inv_mass"].notna()].iloc[0]
    eng = pd.read_parquet(out / "realisations.parquet")
    ekf_rows = eng[eng["estimator"] == "ekf"]

    if args.K < 2:
        sys.exit("--drawn: --K must be at least 2 (an SD across sets)")
    # the rows of the checkpoints (the first at least T after the first row) and the last
    marks = [(f"{T:g} s", f"_{T:g}s", int(np.argmax(t - t[0] >= T)))
             for T in CHECKPOINTS if t[-1] - t[0] >= T] + [("last", "", len(t) - 1)]
    labels, suffixes, rows = zip(*marks)

    # groups of the recursion: the K sets (each averaged over its truths), then the first m
    # truths of set 0 alone (the self-check); the path bounds along each of set 0's truths
    m = min(args.paths, args.truths)
    E_sets, E_single, own = [], [], None
    for j, sq in enumerate(np.random.SeedSequence(args.seed).spawn(args.K)):
        V, PHI, th = draw_truths(p, t, F, v[0], x[0], table, s_u, from_prior, args.truths,
                                 np.random.default_rng(sq))
        E_sets.append(expectations(p, t, F, V, PHI, th))
        if j == 0:
            E_single = [expectations(p, t, F, V[:, [i]], PHI[:, [i]], th[[i]]) for i in range(m)]
            own = path_bounds(p, t, F, V, PHI, th, rows)
        del V, PHI
    sd_th, sd_phi = averaged_pcrlb(p, np.stack(E_sets + E_single, axis=1), rows)
    sets, single = np.arange(args.K), np.arange(args.K, args.K + m)
    ok = True

    print(f"N = {len(t)} samples, sv = {p['sv']}, filter speed_process_sd = {np.sqrt(p['qv']):g}, "
          f"truth speed_process_sd = {s_u:g}, mass_from_prior = {from_prior}; "
          f"K = {args.K} sets of {args.truths} truths, seed {args.seed}")

    print(f"\n(D0) Self-check: the information recursion on one truth's path against the "
          f"covariance Riccati (path_bound) on it, {m} paths, rows {labels}")
    for name, mine, ric in (("SD(1/M)", sd_th[single], own[0][:m]),
                            ("SD(grade)", sd_phi[single], own[1][:m])):
        rel = np.abs(mine / ric - 1.0).max()
        flag = "" if rel <= 1e-6 else "  FAIL"
        ok &= not flag
        print(f"  {name:<10} max |rel diff| {rel:.2e} (tolerance 1e-6){flag}")

    print(f"\n(D1) The averaged PCRLB (E = mean over {args.truths} truths) against the engine's "
          f"(its realisations 0 ... 99): numpy mean and SD across the K = {args.K} sets, "
          f"z = (engine - mean)/SD, tolerance |z| <= 4")
    print(f"{'quantity':<16}{'row':>7}{'numpy mean':>14}{'numpy SD':>11}{'SD/mean':>10}"
          f"{'engine':>14}{'rel diff':>11}{'z':>8}")
    for name, sd, col in (("SD(1/M) [1/kg]", sd_th, "pcrlb_inv_mass"),
                          ("SD(grade) [rad]", sd_phi, "pcrlb_grade")):
        for i, (lab, suf) in enumerate(zip(labels, suffixes)):
            x_ = sd[sets, i]
            mu, s = x_.mean(), x_.std(ddof=1)
            theirs = float(summ[col + suf])
            rel, z = theirs / mu - 1.0, (theirs - mu) / s
            tiny = s <= 1e-6 * abs(mu)  # the bound barely depends on the draw: judge relatively
            flag = "" if (abs(rel) <= 1e-5 if tiny else abs(z) <= 4) else "  FAIL"
            ok &= not flag
            print(f"{name:<16}{lab:>7}{mu:>14.6e}{s:>11.3e}{s / mu:>10.2e}{theirs:>14.6e}"
                  f"{rel:>+11.2e}{z:>+8.2f}{flag}" + ("  (SD tiny: relative, 1e-5)" if tiny else ""))

    print("\n(D2) The effect of averaging: the averaged PCRLB against the bound along one "
          "truth's path (the Riccati of check (1)), at the last row")
    print(f"{'quantity':<16}{'bound':<44}{'value':>14}{'SD':>11}{'averaged/this':>15}")
    nom = path_bound(p, t, v, phi, F)
    for q_, name, sd, col in ((0, "SD(1/M) [1/kg]", sd_th, "path_bound_inv_mass"),
                              (1, "SD(grade) [rad]", sd_phi, "path_bound_grade")):
        avg = sd[sets, -1].mean()
        e_ = ekf_rows[col].to_numpy(float)
        for lab, val, spread in (
                ("averaged PCRLB, numpy (mean over sets)", avg, sd[sets, -1].std(ddof=1)),
                ("averaged PCRLB, engine", float(summ[col.replace("path_bound", "pcrlb")]),
                 np.nan),
                ("path, cycles.parquet's noise-free path", nom[q_], np.nan),
                ("path, numpy's truth 0 of set 0", own[q_][0, -1], np.nan),
                (f"path, numpy's {args.truths} truths of set 0 (mean)", own[q_][:, -1].mean(),
                 own[q_][:, -1].std(ddof=1)),
                (f"path, engine's {len(e_)} realisations (mean)", e_.mean(), e_.std(ddof=1))):
            spread = "-" if np.isnan(spread) else f"{spread:.3e}"
            print(f"{name:<16}{lab:<44}{val:>14.6e}{spread:>11}{avg / val:>15.5f}")
    # the truths' distribution: the mean path bound over ours and over the engine's realisations
    print("(info) mean path bound, numpy's truths vs the engine's realisations "
          "(difference / combined MCSE):")
    for q_, name, col in ((0, "SD(1/M)", "path_bound_inv_mass"), (1, "SD(grade)", "path_bound_grade")):
        mine, e_ = own[q_][:, -1], ekf_rows[col].to_numpy(float)
        mc = np.hypot(mine.std(ddof=1) / np.sqrt(len(mine)), e_.std(ddof=1) / np.sqrt(len(e_)))
        print(f"  {name:<10} {(mine.mean() - e_.mean()) / mc:+.2f}")
    print("\nPASS" if ok else "\nFAIL")
    return 0 if ok else 1


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("study", nargs="?", default="tools/filters_check.toml")
    ap.add_argument("out", nargs="?", default="/tmp/fcheck")
    ap.add_argument("--R", type=int, default=200, help="simulated measurement sets")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--drawn", action="store_true",
                    help="check the averaged PCRLB of a study whose truths are drawn")
    ap.add_argument("--K", type=int, default=10, help="--drawn: independent sets of truths")
    ap.add_argument("--truths", type=int, default=100, help="--drawn: truths per set")
    ap.add_argument("--paths", type=int, default=3,
                    help="--drawn: single paths of the information-vs-Riccati self-check")
    ap.add_argument("--write-drawn-study", metavar="PATH",
                    help="write the study with [truth] speed_process_sd = --truth-sd to PATH, "
                         "then exit")
    ap.add_argument("--truth-sd", type=float, default=0.001)
    args = ap.parse_args()
    if args.write_drawn_study:
        write_drawn_study(args.study, args.write_drawn_study, args.truth_sd)
        return 0
    if args.drawn:
        return main_drawn(args)

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
