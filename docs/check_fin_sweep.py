"""Cross-check of the describing-function peak table in docs/model.md by direct time integration.

A deliberately plain fixed-step RK4 of the reduced default fin (relative coordinates, from rest,
base load -M r a_g, linear up-sweep), all levels integrated together. It only checks the DF
estimate; the project's simulator is ``freeplayid.simulate``.

    python docs/check_fin_sweep.py [--start 30] [--rate 0.5] [--zeta 0.03]

Takes about a minute per 20 Hz of sweep at 0.5 Hz/s on one core.
"""

from __future__ import annotations

import argparse
import copy

import numpy as np
import yaml

from freeplayid.model import fin_config_path, fin_from_config, freeplay_force, modal_analysis

G = 9.80665  # m/s^2 per g
LEVELS_G = np.array([0.2, 0.4, 0.6, 0.8, 1.0, 1.2])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--start", type=float, default=30.0, help="sweep start [Hz]")
    ap.add_argument("--stop", type=float, default=50.0, help="sweep stop [Hz]")
    ap.add_argument("--rate", type=float, default=0.5, help="sweep rate [Hz/s]")
    ap.add_argument("--zeta", type=float, default=None, help="override the damping ratio [-]")
    args = ap.parse_args()

    mapping = yaml.safe_load(fin_config_path().read_text(encoding="utf-8"))
    if args.zeta is not None:
        mapping = copy.deepcopy(mapping)
        mapping["damping"]["zeta"] = args.zeta
    fin = fin_from_config(mapping)
    kn, delta = mapping["hinge"]["kn"], mapping["hinge"]["delta"]
    B = fin.hinge_matrix()
    f_max = modal_analysis(fin.M, fin.closed_stiffness(kn)).frequencies_hz[-1]
    dt = 2.5 / (2 * np.pi * f_max)  # RK4 stable for omega dt < 2.78
    Minv = np.linalg.inv(fin.M)
    AK, AC, AB = -(Minv @ fin.K).T, -(Minv @ fin.damping).T, -(Minv @ B).T
    r = fin.influence
    f0, rate = args.start, args.rate
    n_steps = int((args.stop - f0) / rate / dt)

    def acc(t, y, v):
        ag = LEVELS_G * G * np.sin(2 * np.pi * (f0 * t + 0.5 * rate * t * t))
        return y @ AK + v @ AC + freeplay_force(y @ B, kn, delta) @ AB - ag[:, None] * r

    y = np.zeros((LEVELS_G.size, fin.n_dof))
    v = np.zeros_like(y)
    every = max(1, int(1e-3 / dt))
    theta, x_tl = [], []
    for k in range(n_steps):
        t = k * dt
        a1 = acc(t, y, v)
        a2 = acc(t + dt / 2, y + dt / 2 * v, v + dt / 2 * a1)
        a3 = acc(t + dt / 2, y + dt / 2 * v + dt * dt / 4 * a1, v + dt / 2 * a2)
        a4 = acc(t + dt, y + dt * v + dt * dt / 2 * a2, v + dt * a3)
        y = y + dt * v + dt * dt / 6 * (a1 + a2 + a3)
        v = v + dt / 6 * (a1 + 2 * a2 + 2 * a3 + a4)
        if k % every == 0:
            theta.append(np.abs(y @ B).max(axis=1))
            x_tl.append(np.abs(y[:, 0]))
    theta, x_tl = np.array(theta), np.array(x_tl)
    w = int(round(0.2 / (every * dt)))  # 0.2 s envelope windows
    nw = theta.shape[0] // w
    env = theta[: nw * w].reshape(nw, w, -1).max(axis=1)
    env_x = x_tl[: nw * w].reshape(nw, w, -1).max(axis=1)
    f_c = f0 + rate * (np.arange(nw) + 0.5) * w * every * dt
    print(f"RK4 dt = {dt:.3e} s, {n_steps} steps; ", end="")
    print(f"sweep {f0:g} -> {args.stop:g} Hz at {rate:g} Hz/s")
    print("| level [g] | envelope peak f [Hz] | Theta/delta | X_tl [mm] | resonance in band |")
    print("|---|---|---|---|---|")
    for j, lev in enumerate(LEVELS_G):
        i = int(np.argmax(env[:, j]))
        resonant = i > 1  # a peak in the first window is the start transient, not a resonance
        print(
            f"| {lev:.1f} | {f_c[i]:.2f} | {env[i, j] / delta:.2f} | {1e3 * env_x[i, j]:.2f} | "
            f"{'yes' if resonant else 'no (stays near the gap)'} |"
        )


if __name__ == "__main__":
    main()
