"""A paper strip wetted on its top face curls, then uncurls as the moisture crosses the sheet
(data/scenes/moisture_curl.toml). Plots the strip's curvature against time with matplotlib.

    python moisture_curl.py [--steps N] [--out curvature.png]

The curvature is that of the circular arc through the clamped end and the tip of the strip's
centre line: a clamped strip of length L curled to curvature k has its tip at
(sin(kL)/k, (1 - cos(kL))/k), so k = 2 z / (x^2 + z^2) with (x, z) the tip relative to the clamp.
The scene says the natural curvature peaks near c*dm/h = 20 1/m.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

import thinshell

SCENE = Path(__file__).resolve().parents[2] / "data" / "scenes" / "moisture_curl.toml"


def curvature(x: np.ndarray, x0: np.ndarray) -> float:
    """Curvature (1/m) of the arc through the clamp and the tip of the centre line."""
    y_mid = 0.5 * (x0[:, 1].min() + x0[:, 1].max())
    line = np.abs(x0[:, 1] - y_mid) < 1e-9
    clamp = line & (x0[:, 0] == x0[:, 0].min())
    tip = line & (x0[:, 0] == x0[:, 0].max())
    d = x[tip][0] - x[clamp][0]
    return 2.0 * d[2] / (d[0] ** 2 + d[2] ** 2)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=40, help="quasi-static steps of 0.5 s (default 40)")
    ap.add_argument("--out", default="curvature.png", help="the plot (PNG)")
    args = ap.parse_args()

    sim = thinshell.Simulation(thinshell.Scene.from_file(SCENE, [f"integrator.steps={args.steps}"]))
    x0 = sim.reference_positions
    t, k = [0.0], [curvature(sim.positions, x0)]

    def record(s: thinshell.Simulation, r: dict) -> None:
        t.append(r["time"])
        k.append(curvature(s.positions, x0))

    summary = sim.run(callback=record)
    # The peak is the largest magnitude: the strip curls towards -z, so its curvatures are negative.
    peak = int(np.argmax(np.abs(k)))
    print(f"{summary['steps']} steps, peak curvature {k[peak]:.2f} 1/m at t = {t[peak]:.1f} s")

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 3.5))
    ax.plot(t, k, "o-", ms=3)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("curvature (1/m)")
    ax.set_title("moisture-curling paper strip")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(args.out, dpi=120)
    np.savetxt(Path(args.out).with_suffix(".csv"), np.column_stack([t, k]), delimiter=",", header="time_s,curvature_per_m", comments="")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
