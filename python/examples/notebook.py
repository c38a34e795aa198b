"""A notebook-style tour of trailer_sway (run it as a script, or cell by cell in Jupyter).

    pip install ./python          # from the repository root
    python python/examples/notebook.py

Loads the paper's vehicle (Table I), computes the open-loop critical speed, the linear
stability chart of the delayed yaw-rate feedback (drawn with matplotlib if it is
installed), V_crit over the trailer's mass, and a 100-point sweep of simulations over
speed and initial hitch angle.
"""

# %% the vehicle of Table I
from pathlib import Path

import numpy as np

import trailer_sway as ts

repo = Path(__file__).resolve().parents[2]
vehicle = ts.Vehicle.from_toml(repo / "configs" / "vehicle.toml")  # = ts.Vehicle.table1()
print(vehicle)

# %% V_crit of straight running, and with the feedback D = 0.1 s, τ = 0.2 s
vc = ts.critical_speed(vehicle)
print(f"open loop: V_crit = {vc.v_crit_mps:.4f} m/s, Hopf frequency {vc.hopf_frequency_hz:.4f} Hz")
fb = ts.critical_speed(vehicle, {"kind": "yaw_rate_feedback", "gain_s": 0.1, "delay_s": 0.2})
print(f"D = 0.1 s, τ = 0.2 s: {fb.reason}, stable up to {fb.stable_up_to_mps:.4f} m/s")
heavy = ts.critical_speed(vehicle.replace(trailer_mass=1400.0))
print(f"a 1400 kg trailer: V_crit = {heavy.v_crit_mps:.4f} m/s")

# %% the rightmost characteristic roots at one point of the chart
print("roots at V = 35 m/s:", np.round(ts.roots(vehicle, 35.0, 0.1, 0.2, count=4), 4))

# %% the linear stability chart in the (V, D) plane (Fig. 4a, a coarse grid)
charts = ts.stability_chart(vehicle, delays=[0.0, 0.2], speed_cells=60, gain_cells=40)
for ch in charts:
    print(f"τ = {ch.tau_s} s: {ch.stable.mean():.1%} of the cells stable")
try:
    import matplotlib

    matplotlib.use("Agg")
except ImportError:
    print("matplotlib is not installed: the chart is not drawn")
else:
    axes = charts.plot()  # one panel per delay: the stable region and its boundaries
    out = Path.cwd() / "stability_chart.png"
    axes[0].figure.savefig(out, dpi=80)
    print(f"chart drawn: {out}")

# %% V_crit over the trailer's mass, in parallel (NaN and a reason where stable)
by_mass = ts.critical_speed(vehicle, trailer_mass=np.linspace(700.0, 1500.0, 9))
print(by_mass)
print("V_crit [m/s]:", np.round(by_mass.v_crit_mps, 2))

# %% a 100-point sweep: which perturbations trigger sustained sway?
table = ts.sweep(
    {
        "axes": [
            {"parameter": "speed_mps", "min": 30.0, "max": 39.0, "points": 10},
            {"parameter": "theta0_deg", "min": 1.0, "max": 19.0, "points": 10},
        ],
        "base": {
            "horizon_s": 40.0,
            "speed": {"kind": "constant", "speed_mps": 33.0},
            "initial": {"kind": "state", "theta0_deg": 0.0},
        },
    },
    vehicle,
)
print(table)
print("classes:", table.counts("class"))
sway = table["class"] == "sustained_sway"
print(f"lowest speed with sustained sway: {table['speed_mps'][sway].min():.1f} m/s")
