"""The ``plot(ax=None)`` methods of the results: matplotlib figures with labelled axes
(units in brackets) and a legend, drawn as the tasks' own figures draw them. matplotlib is
imported when a plot is drawn, not with the package (it stays optional)."""

from __future__ import annotations

from typing import Any, Optional, Sequence

import numpy as np


def _pyplot() -> Any:
    try:
        import matplotlib.pyplot as plt
    except ImportError as e:
        raise ImportError(
            "plot() needs matplotlib, which is not installed: pip install matplotlib "
            "(or pass the data to your own plotting code; every result holds numpy arrays)"
        ) from e
    return plt


def axes(ax: Any = None) -> Any:
    """``ax``, or the axes of a new figure (``matplotlib.pyplot.subplots()``)."""
    return ax if ax is not None else _pyplot().subplots()[1]


def each(items: Sequence[Any], ax: Any = None) -> list:
    """Each item's ``plot`` on its own axes: ``ax`` a sequence of as many axes, or None
    for a new figure with one row of panels; returns the axes."""
    if ax is None:
        n = max(len(items), 1)
        ax = list(_pyplot().subplots(1, n, figsize=(4.5 * n, 4), squeeze=False)[1][0])
    if len(ax) != len(items):
        raise ValueError(f"ax: expected {len(items)} axes, one per delay, got {len(ax)}")
    return [item.plot(a) for item, a in zip(items, ax)]


def _part(ax: Any, x: np.ndarray, y: np.ndarray, mask: np.ndarray, style: str, label: Optional[str]) -> None:
    """The line ``(x, y)`` where ``mask`` holds (gaps elsewhere); nothing, and no legend
    entry, where it never does."""
    if np.any(mask):
        ax.plot(x, np.where(mask, y, np.nan), style, label=label)


def bifurcation_diagram(d: Any, ax: Any = None) -> Any:
    """Straight running (amplitude 0) and the cycle branch over V; stable solid, unstable
    dashed; the Hopf point and the fold of cycles marked (paper Fig. 3a)."""
    ax = axes(ax)
    eq, cy = d.equilibria, d.cycles
    zero = np.zeros_like(eq["v_mps"])
    _part(ax, eq["v_mps"], zero, eq["stable"], "k-", "straight running, stable")
    _part(ax, eq["v_mps"], zero, ~eq["stable"], "k--", "straight running, unstable")
    _part(ax, cy["v_mps"], cy["amplitude_deg"], cy["stable"], "C0-", "sway cycles, stable")
    _part(ax, cy["v_mps"], cy["amplitude_deg"], ~cy["stable"], "C0--", "sway cycles, unstable")
    if d.hopf_v_mps is not None:
        ax.plot([d.hopf_v_mps], [0.0], "C3o", label=f"Hopf point V_crit = {d.hopf_v_mps:.2f} m/s")
    if d.fold_v_mps is not None:
        ax.plot([d.fold_v_mps], [d.fold_amplitude_deg], "C1s", label=f"fold of cycles {d.fold_v_mps:.2f} m/s")
    ax.set_xlabel("speed V [m/s]")
    ax.set_ylabel("sway amplitude max |θ| [deg]")
    ax.set_title("bifurcation diagram" if d.reason is None else d.reason, fontsize="medium")
    ax.legend(fontsize="small")
    return ax


def stability_chart(c: Any, ax: Any = None) -> Any:
    """The stable region of the (V, D) plane at one delay, shaded, and its D-subdivision
    boundaries (λ = 0 and λ = ±iω; paper Fig. 4a)."""
    ax = axes(ax)
    from matplotlib.patches import Patch

    ax.contourf(c.v_mps, c.d_s, c.stable.T.astype(float), levels=[0.5, 1.5], colors=["#cfe3f3"])
    for rows, style, label in (
        (c.static_boundary, "C1-", "boundary λ = 0"),
        (c.dynamic_boundary, "C0-", "boundary λ = ±iω"),
    ):
        for k, branch in enumerate(np.unique(rows[:, 0]) if len(rows) else []):
            r = rows[rows[:, 0] == branch]
            ax.plot(r[:, 1], r[:, 2], style, lw=1, label=label if k == 0 else None)
    handles, _ = ax.get_legend_handles_labels()
    ax.legend(
        handles=[Patch(color="#cfe3f3", label="stable (no root with Re λ > 0)"), *handles],
        fontsize="small",
    )
    ax.set_xlabel("speed V [m/s]")
    ax.set_ylabel("gain D [s]")
    ax.set_title(f"τ = {c.tau_s:g} s", fontsize="medium")
    return ax


def nonlinear_chart(c: Any, ax: Any = None) -> Any:
    """The Hopf curves (subcritical and supercritical parts), the fold-of-cycles curves and
    the codimension-two points in the (V, D) plane at one delay."""
    ax = axes(ax)
    labelled = set()

    def once(label: str) -> Optional[str]:
        if label in labelled:
            return None
        labelled.add(label)
        return label

    for h in c.hopf_curves:
        sub = h["subcritical"]
        for mask, style, label in (
            (sub == 1, "C3-", "Hopf curve, subcritical"),
            (sub == 0, "C0-", "Hopf curve, supercritical"),
            (np.isnan(sub), "C7-", "Hopf curve, criticality unknown"),
        ):
            _part(ax, h["v_mps"], h["d_s"], mask, style, once(label) if mask.any() else None)
    for f in c.fold_curves:
        ax.plot(f["v_mps"], f["d_s"], "C1--", label=once("fold of cycles"))
    for p in c.codim2_points:
        ax.plot([p["v_mps"]], [p["d_s"]], "ko", label=once("codimension-two points"))
    ax.set_xlabel("speed V [m/s]")
    ax.set_ylabel("gain D [s]")
    ax.set_title(f"τ = {c.tau_s:g} s" + ("" if c.hopf_curves else f": {c.hopf_reason}"), fontsize="medium")
    if labelled:
        ax.legend(fontsize="small")
    return ax


def simulation(s: Any, ax: Any = None) -> Any:
    """The hitch angle θ and the steering angle δ over time [deg], the action time marked."""
    if len(s.t) == 0:
        raise ValueError("Simulation.plot(): no trajectory to plot; simulate(..., trajectory=True) records one")
    ax = axes(ax)
    ax.plot(s.t, s.theta_deg, "C0-", label="hitch angle θ")
    ax.plot(s.t, np.degrees(s.delta), "C1-", lw=1, label="steering angle δ")
    ax.axvline(s.action_s, color="k", ls=":", lw=1, label=f"action at {s.action_s:g} s")
    ax.set_xlabel("time t [s]")
    ax.set_ylabel("angle [deg]")
    ax.set_title(f"{s.name}: {s.sway_class}", fontsize="medium")
    ax.legend(fontsize="small")
    return ax


def lateral_stability(r: Any, ax: Any = None) -> Any:
    """The damping ratio of the pulse-steer test over speed, its fit extrapolated to D = 0,
    and V_crit and V_fold (what the test misses in the bistable range)."""
    ax = axes(ax)
    ax.plot(r.speed_mps, r.damping_ratio, "C0o", label="test runs: damping of the decay")
    if len(r.fit_coefficients) and np.isfinite(r.speed_mps).any():
        hi = max(np.nanmax(r.speed_mps), r.test_critical_speed_mps or 0.0)
        v = np.linspace(np.nanmin(r.speed_mps), hi, 100)
        ax.plot(v, np.polynomial.polynomial.polyval(v, r.fit_coefficients), "C0--", lw=1, label="fit D(V)")
    ax.axhline(0.0, color="k", lw=0.5)
    for speed, style, label in (
        (r.test_critical_speed_mps, "C0:", "test's critical speed"),
        (r.v_crit_mps, "C3-", "V_crit (Hopf)"),
        (r.v_fold_mps, "C1-", "V_fold (sway from a large impulse)"),
    ):
        if speed is not None:
            ax.axvline(speed, color=style[:2], ls=style[2:], lw=1, label=f"{label} {speed:.2f} m/s")
    ax.set_xlabel("speed V [m/s]")
    ax.set_ylabel("damping ratio D [-]")
    ax.set_title(f"pulse-steer test, signal {r.signal}", fontsize="medium")
    ax.legend(fontsize="small")
    return ax


def critical_speeds(c: Any, ax: Any = None) -> Any:
    """V_crit over the field's values; where straight running is stable up to the maximum
    speed, that speed marked instead."""
    ax = axes(ax)
    ax.plot(c.values, c.v_crit_mps, "C0.-", label="V_crit")
    stable = c.reason == "stable_up_to_max"
    if stable.any():
        ax.plot(c.values[stable], c.stable_up_to_mps[stable], "C2^", label="stable up to the maximum speed")
    ax.set_xlabel(f"{c.field} [{c.unit}]")
    ax.set_ylabel("critical speed V_crit [m/s]")
    ax.legend(fontsize="small")
    return ax


_UNITS = {
    "yaw_rate": "rad/s",
    "lateral_acceleration": "m/s²",
    "steering_wheel_angle": "rad",
    "speed": "m/s",
    "hitch_angle": "rad",
}


def detection(d: Any, ax: Any = None) -> Any:
    """The signal the detectors read (the yaw rate, else the first given) over time, each
    detector's flagged samples shaded in its own colour, its first flag marked."""
    ax = axes(ax)
    name = "yaw_rate" if "yaw_rate" in d.signals else next(iter(d.signals))
    ax.plot(d.t, d.signals[name], "k-", lw=1, label=name.replace("_", " "))
    for i, (n, tr) in enumerate(d.detectors.items()):
        colour = f"C{i}"
        ax.fill_between(
            d.t, 0, 1, where=tr.flag, transform=ax.get_xaxis_transform(),
            color=colour, alpha=0.15, lw=0,
        )
        label = f"{n}: {'never flags' if tr.first_flag_s is None else f'first flag {tr.first_flag_s:.2f} s'}"
        if tr.first_flag_s is not None:
            ax.axvline(tr.first_flag_s, color=colour, ls="--", lw=1, label=label)
        else:
            ax.plot([], [], color=colour, ls="--", label=label)
    ax.set_xlabel("time t [s]")
    ax.set_ylabel(f"{name.replace('_', ' ')} [{_UNITS[name]}]")
    ax.set_title("sway detectors on the recorded signals (shaded: flagged)", fontsize="medium")
    ax.legend(fontsize="small")
    return ax
