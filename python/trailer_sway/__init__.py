"""trailer_sway: the nonlinear dynamics of trailer sway from Python.

The functions wrap the Rust crates of this repository (the same code and the same
numbers as ``cargo xtask <task>``) and return numpy arrays:

- :class:`Vehicle` — the car–trailer parameters (paper Table I), validated;
- :func:`critical_speed` — V_crit of straight running (open loop or with the delayed
  yaw-rate feedback), or the speed up to which it stays stable; over an array of one
  vehicle field's values in parallel (:class:`CriticalSpeeds`);
- :func:`roots` — the rightmost characteristic roots of eq. (13);
- :func:`simulate` — one scenario (a dict in the TOML's shape, or a TOML file);
- :func:`bifurcation_diagram` — equilibria, cycles, Hopf and fold points over V;
- :func:`stability_chart` — the linear (V, D) charts of Fig. 4(a);
- :func:`nonlinear_chart` — Hopf and fold-of-cycles curves, codimension-two points;
- :func:`sweep` — a parallel study, returned as a :class:`Table` of numpy columns;
- :func:`lateral_stability` — the pulse-steer test (ISO 9815) on the model, and what it
  misses in the bistable range; :func:`analyse_recording` — the same reading of a
  recorded run;
- :func:`detect` — recorded signals of the towing car replayed through the sway
  detectors (:class:`Detection`).

Units are SI throughout (speeds in m/s, gains D and delays τ in s, angles in rad unless a
name says ``_deg``). Long calls release the GIL, run on rayon's threads and stop with
Ctrl-C: ``KeyboardInterrupt`` within a fraction of a second, once every thread of the call
has stopped (nothing is returned or written, nothing keeps computing). They show their
progress (``progress=``: a tqdm bar when tqdm is installed, or your callback
``progress(stage, done, total)``; see ``trailer_sway._progress``). Bad input raises
``ValueError`` (a value of the wrong type ``TypeError``) with the problem ``cargo xtask``
states for the same value, naming the Python argument or dict key. Results print as a
one-line summary, and have ``plot(ax=None)`` when matplotlib is installed (and
``to_pandas()`` where they are tables, with pandas). The keys of a scenario are typed in
:class:`Scenario`.
"""

from __future__ import annotations

import json
import math
import os
import re
from dataclasses import dataclass, field
from typing import Any, Mapping, Optional, Sequence, Union

import numpy as np

from . import _native, _plot, _progress
from ._progress import Progress
from ._native import Vehicle, get_num_threads, set_num_threads, to_toml
from ._scenario import Controller, InitialState, Scenario, SpeedProfile

__version__: str = _native.__version__

__all__ = [
    "__version__",
    "Vehicle",
    "Progress",
    "CriticalSpeed",
    "CriticalSpeeds",
    "critical_speed",
    "roots",
    "Simulation",
    "simulate",
    "Scenario",
    "SpeedProfile",
    "Controller",
    "InitialState",
    "BifurcationDiagram",
    "bifurcation_diagram",
    "StabilityChart",
    "StabilityCharts",
    "stability_chart",
    "NonlinearChart",
    "NonlinearCharts",
    "nonlinear_chart",
    "Table",
    "sweep",
    "LateralStability",
    "lateral_stability",
    "RecordedDecay",
    "analyse_recording",
    "Detection",
    "DetectorTrace",
    "detect",
    "DETECTORS",
    "DETECTION_SIGNALS",
    "set_num_threads",
    "get_num_threads",
    "to_toml",
]

PathLike = Union[str, "os.PathLike[str]"]


def _vehicle_from_dict(fields: Mapping[str, float]) -> Vehicle:
    """Rebuilds a pickled :class:`Vehicle`."""
    return Vehicle(**fields)


def _vehicle(v: Optional[Vehicle]) -> Vehicle:
    if v is None:
        return Vehicle.table1()
    if not isinstance(v, Vehicle):
        raise TypeError(f"vehicle: expected a trailer_sway.Vehicle or None (Table I), got {_kind(v)}")
    return v


# ---------------------------------------------------------------------------------------
# arguments: numbers where numbers are expected, each named as the caller wrote it


def _kind(x: Any) -> str:
    """The type of ``x`` as a message names it."""
    return "None" if x is None else type(x).__name__


def _is_number(x: Any) -> bool:
    return isinstance(x, (int, float, np.integer, np.floating)) and not isinstance(x, (bool, np.bool_))


def _number(x: Any, name: str, unit: str) -> float:
    """``x`` as a float; ``TypeError`` naming ``name`` for anything but a real number (a
    str, a bool, None, a sequence). NaN and inf pass: the checks that follow name them."""
    if not _is_number(x):
        raise TypeError(f"{name}: expected a number [{unit}], got {_kind(x)}")
    return float(x)


def _optional_number(x: Any, name: str, unit: str) -> Optional[float]:
    return None if x is None else _number(x, name, unit)


def _int(x: Any, name: str) -> int:
    """``x`` as an int (a Python or numpy integer, not a bool or a float)."""
    if isinstance(x, (bool, np.bool_)) or not isinstance(x, (int, np.integer)):
        raise TypeError(f"{name}: expected an int, got {_kind(x)}")
    return int(x)


def _numbers(x: Any, name: str, unit: str) -> list:
    """A number or a sequence of numbers (list, tuple, 1-d array) as a list of floats; a
    str is not a sequence of numbers (``TypeError``), each entry is checked as
    ``name[i]``."""
    if _is_number(x):
        return [float(x)]
    wrong = TypeError(f"{name}: expected a number or a sequence of numbers [{unit}], got {_kind(x)}")
    if isinstance(x, (str, bytes, Mapping)) or x is None:
        raise wrong
    if isinstance(x, np.ndarray) and x.ndim != 1:
        raise ValueError(f"{name}: expected a 1-d sequence, got an array of shape {x.shape}")
    try:
        items = list(x)
    except TypeError:
        raise wrong from None
    return [_number(v, f"{name}[{i}]", unit) for i, v in enumerate(items)]


def _bool(x: Any, name: str) -> bool:
    if not isinstance(x, (bool, np.bool_)):
        raise TypeError(f"{name}: expected True or False, got {_kind(x)}")
    return bool(x)


def _mapping(x: Any, name: str, example: str) -> dict:
    if not isinstance(x, Mapping):
        raise TypeError(f"{name}: expected a dict like {example}, got {_kind(x)}")
    return dict(x)


def _renamed(e: Exception, keys: Mapping[str, str]) -> Exception:
    """``e`` with the config key its message names (```speed.cells```) replaced by the
    keyword argument that set it (```speed_cells```); an entry's index or sub-key is
    kept (```delays_s[1]``` → ```delays[1]```)."""

    def python(m: "re.Match[str]") -> str:
        key = m.group(1)
        for old, new in keys.items():
            if key == old or key.startswith((old + "[", old + ".")):
                return f"`{new}{key[len(old):]}`"
        return m.group(0)

    return type(e)(re.sub(r"`([^`]*)`", python, str(e), count=1))


# ---------------------------------------------------------------------------------------
# critical speed


@dataclass(frozen=True)
class CriticalSpeed:
    """Where straight running loses stability.

    Attributes:
        v_crit_mps: V_crit [m/s], or None when straight running is stable on the whole
            scanned range (then ``stable_up_to_mps`` is its end) or already unstable at
            its start.
        hopf_frequency_hz: frequency of the critical pair Im λ / 2π at V_crit [Hz]
            (0 for a static crossing; None without a crossing).
        hopf_omega_rad_s: its angular frequency ω [rad/s].
        stable_up_to_mps: the speed up to which straight running is stable [m/s]:
            V_crit, or the end of the scanned range; None if unstable at its start.
        reason: ``"crossing"`` (a Hopf point, or a static one when ω = 0),
            ``"stable_up_to_max"`` or ``"unstable_at_min"``: outcomes, not errors.
        loss_of_stability: at a crossing, ``"hopf"`` (a complex pair: sway starts) or
            ``"divergence"`` (a real root, ω = 0: a static divergence), as the ``linear``
            task's summary; None without a crossing.
        message: the outcome in words (``"straight running is stable at every speed up
            to 100 m/s …"``); None at a crossing.
    """

    v_crit_mps: Optional[float]
    hopf_frequency_hz: Optional[float]
    hopf_omega_rad_s: Optional[float]
    stable_up_to_mps: Optional[float]
    reason: str
    loss_of_stability: Optional[str] = None
    message: Optional[str] = None

    @staticmethod
    def _of(raw: Mapping[str, Any]) -> "CriticalSpeed":
        """The outcome the native search returns (``reason`` and its numbers)."""
        reason = raw["reason"]
        if reason == "crossing":
            v = raw["v_crit_mps"]
            w = raw["hopf_omega_rad_s"]
            kind = "divergence" if w == 0.0 else "hopf"
            return CriticalSpeed(v, raw["hopf_frequency_hz"], w, v, reason, kind)
        if reason == "stable_up_to_max":
            up = raw["stable_up_to_mps"]
            return CriticalSpeed(
                None, None, None, up, reason, None,
                f"straight running is stable at every speed up to {up:g} m/s (the maximum speed, v_max_mps)",
            )
        return CriticalSpeed(
            None, None, None, None, reason, None,
            f"straight running is already unstable at the lowest speed, {raw['v_min_mps']:g} m/s (v_min_mps)",
        )


@dataclass(frozen=True, repr=False)
class CriticalSpeeds:
    """:func:`critical_speed` over the values of one vehicle field (``critical_speed(v,
    trailer_mass=np.linspace(900, 1500, 13))``), each value's search that of the scalar
    call on ``vehicle.replace(field=value)``, bit for bit.

    ``field`` (e.g. ``"trailer_mass"``) and its ``unit``; ``values`` the field's values;
    float64 arrays ``v_crit_mps``, ``hopf_frequency_hz``, ``hopf_omega_rad_s`` (NaN where
    there is no crossing) and ``stable_up_to_mps`` (NaN where already unstable at
    v_min_mps); ``reason`` per value (``"crossing"``, ``"stable_up_to_max"``,
    ``"unstable_at_min"``). ``cs[i]`` is value i's :class:`CriticalSpeed`; ``len(cs)``,
    ``to_pandas()``, ``plot(ax=None)``.
    """

    field: str
    unit: str
    values: np.ndarray
    v_crit_mps: np.ndarray
    hopf_frequency_hz: np.ndarray
    hopf_omega_rad_s: np.ndarray
    stable_up_to_mps: np.ndarray
    reason: np.ndarray
    v_min_mps: float

    def __len__(self) -> int:
        return len(self.values)

    def __getitem__(self, i: int) -> CriticalSpeed:
        raw = {
            "reason": str(self.reason[i]),
            "v_crit_mps": float(self.v_crit_mps[i]),
            "hopf_frequency_hz": float(self.hopf_frequency_hz[i]),
            "hopf_omega_rad_s": float(self.hopf_omega_rad_s[i]),
            "stable_up_to_mps": float(self.stable_up_to_mps[i]),
            "v_min_mps": self.v_min_mps,
        }
        return CriticalSpeed._of(raw)

    def __repr__(self) -> str:
        found = np.isfinite(self.v_crit_mps)
        span = (
            f"V_crit {np.nanmin(self.v_crit_mps):.2f} to {np.nanmax(self.v_crit_mps):.2f} m/s"
            if found.any()
            else "no crossing"
        )
        return (
            f"CriticalSpeeds({self.field}: {len(self)} values, {span}, "
            f"{int((self.reason == 'stable_up_to_max').sum())} stable up to the maximum speed)"
        )

    def to_pandas(self):
        """A DataFrame: the field's values and the arrays above, one row per value."""
        return _dataframe(
            {self.field: self.values, "v_crit_mps": self.v_crit_mps,
             "hopf_frequency_hz": self.hopf_frequency_hz, "hopf_omega_rad_s": self.hopf_omega_rad_s,
             "stable_up_to_mps": self.stable_up_to_mps, "reason": self.reason},
            "CriticalSpeeds",
        )

    def plot(self, ax: Any = None) -> Any:
        """V_crit [m/s] over the field's values (matplotlib); returns the axes."""
        return _plot.critical_speeds(self, ax)


def _dataframe(columns: Mapping[str, Any], what: str):
    try:
        import pandas as pd
    except ImportError as e:
        raise ImportError(f"{what}.to_pandas() needs pandas, which is not installed: pip install pandas") from e
    return pd.DataFrame(dict(columns))


def _field_unit(name: str) -> str:
    """The unit of a vehicle field, from its attribute's documentation (``[kg]``)."""
    m = re.search(r"\[([^\]]*)\]", getattr(Vehicle, name).__doc__ or "")
    return m.group(1) if m else "-"


def _controller_gain_delay(controller: Any) -> tuple[Optional[float], Optional[float]]:
    if controller is None:
        return None, None
    if not isinstance(controller, Mapping):
        raise TypeError(
            "controller: expected None or a dict like "
            "{'kind': 'yaw_rate_feedback', 'gain_s': 0.1, 'delay_s': 0.2}, "
            f"got {_kind(controller)}"
        )
    unknown = [k for k in controller if k not in ("kind", "gain_s", "delay_s", "on_s", "off_s", "actuator")]
    if unknown:
        raise ValueError(
            f"controller: unknown key `{unknown[0]}`; the linear analysis takes `kind`, `gain_s` and `delay_s`"
        )
    kind = controller.get("kind", "yaw_rate_feedback")
    if kind == "none":
        return None, None
    if kind != "yaw_rate_feedback":
        raise ValueError(
            f"controller: `kind`: unknown variant `{kind}`, expected `none` or `yaw_rate_feedback`"
        )
    missing = [k for k in ("gain_s", "delay_s") if k not in controller]
    if missing:
        raise ValueError(f"controller: missing field `{missing[0]}`")
    return (
        _number(controller["gain_s"], "controller: `gain_s`", "s"),
        _number(controller["delay_s"], "controller: `delay_s`", "s"),
    )


def critical_speed(
    vehicle: Optional[Vehicle] = None,
    controller: Optional[Mapping[str, Any]] = None,
    *,
    v_min_mps: float = 1.0,
    v_max_mps: float = 100.0,
    scan_step_mps: float = 0.5,
    tolerance_mps: Optional[float] = None,
    progress: Progress = None,
    **field: Any,
) -> Union[CriticalSpeed, CriticalSpeeds]:
    """V_crit of straight running, or the "stable up to" outcome.

    Open loop (``controller=None``): the lowest speed where the spectral abscissa of
    Ã(V) (eq. 9–11) changes sign, by a scan every ``scan_step_mps`` from ``v_min_mps``
    to ``v_max_mps`` and bisection to ``tolerance_mps`` (default, None: 1e-11 m/s) — the
    ``linear`` task's search (``configs/linear.toml``).

    Closed loop (``controller={"kind": "yaw_rate_feedback", "gain_s": D, "delay_s": τ}``,
    the TOML's shape; only D [s] and τ [s] enter the linear analysis): the lowest speed
    at which eq. (13) has a root with Re λ > 0, by the exact unstable-root count at
    speeds at most ``scan_step_mps`` apart and bisection to ``tolerance_mps`` (default
    1e-9 m/s) — the ``fig4a`` task's ``v_crit_at_d``.

    Over one vehicle field: a keyword naming a field of :class:`Vehicle` with a sequence
    or 1-d array of values (``trailer_mass=np.linspace(900.0, 1500.0, 13)``) searches on
    ``vehicle.replace(trailer_mass=value)`` for each value, in parallel, and returns
    :class:`CriticalSpeeds` (NaN and a reason where there is no crossing); a single number
    is that one vehicle's :class:`CriticalSpeed`. ``progress`` reports the searches done.
    """
    v = _vehicle(vehicle)
    gain, delay = _controller_gain_delay(controller)
    if tolerance_mps is None:
        tolerance_mps = 1e-11 if gain is None else 1e-9
    search = (
        gain,
        delay,
        _number(v_min_mps, "v_min_mps", "m/s"),
        _number(v_max_mps, "v_max_mps", "m/s"),
        _number(scan_step_mps, "scan_step_mps", "m/s"),
        _number(tolerance_mps, "tolerance_mps", "m/s"),
    )
    if not field:
        return CriticalSpeed._of(json.loads(_native.critical_speed(v, *search)))
    if len(field) > 1:
        raise TypeError(f"critical_speed(): one vehicle field at a time, got {', '.join(field)}")
    (name, values), = field.items()
    if name not in Vehicle.fields():
        raise TypeError(
            f"critical_speed(): unexpected keyword `{name}`: neither a search setting (v_min_mps, "
            f"v_max_mps, scan_step_mps, tolerance_mps) nor a vehicle field ({', '.join(Vehicle.fields())})"
        )
    if _is_number(values):
        return critical_speed(v.replace(**{name: values}), controller, v_min_mps=v_min_mps,
                              v_max_mps=v_max_mps, scan_step_mps=scan_step_mps, tolerance_mps=tolerance_mps)
    x = np.ascontiguousarray(_numbers(values, name, _field_unit(name)), dtype=np.float64)
    arrays, reasons = _progress.run(
        progress, lambda p: _native.critical_speeds(v, name, x, *search, p)
    )
    return CriticalSpeeds(
        field=name,
        unit=_field_unit(name),
        values=x,
        reason=np.array(reasons, dtype=str) if reasons else np.empty(0, dtype=str),
        v_min_mps=search[2],
        **arrays,
    )


# ---------------------------------------------------------------------------------------
# roots


def roots(
    vehicle: Optional[Vehicle],
    speed: float,
    gain: float,
    delay: float,
    count: int = 6,
) -> np.ndarray:
    """The ``count`` rightmost characteristic roots λ [1/s] of eq. (13) at speed V [m/s],
    gain D [s] and delay τ [s], as ``cargo xtask roots`` prints them: a complex128
    array sorted by decreasing real part, conjugates listed separately (a pair is never
    split, so ``count + 1`` roots may come back), Newton-polished (relative accuracy
    ~1e-14). ``count`` ≤ 200."""
    return _native.roots(
        _vehicle(vehicle),
        _number(speed, "speed", "m/s"),
        _number(gain, "gain", "s"),
        _number(delay, "delay", "s"),
        _int(count, "count"),
    )


# ---------------------------------------------------------------------------------------
# simulate


@dataclass(frozen=True, repr=False)
class Simulation:
    """One simulated scenario (the 7-state model, paper eq. 5–7).

    Arrays are sampled every ``output_step_s`` (empty with ``trajectory=False``):
    ``t`` [s], ``states`` (n × 7, the columns named by ``state_names``: σ1 [m/s],
    σ2 [1/s], σ3 [1/s], θ [rad], ψ [rad], x_H [m], y_H [m]), ``theta`` [rad] (a view of
    ``states[:, 3]``), ``speed`` V [m/s], ``delta`` δ [rad]. Each array is the Rust result
    handed over without a copy. ``to_pandas()`` is the task's ``trajectory.csv`` as a
    DataFrame; ``plot(ax=None)`` draws θ and δ over time.

    ``metrics`` are the run's metrics as ``summary.json`` names them
    (``peak_theta_deg_after_action``, ``final_amplitude_deg``, ``settle_time_s``,
    ``outcome``, ``loss_of_control_time_s``, ``loss_of_control_condition``, ``class``,
    ``decay_rate_per_s``); ``sway_class`` is ``metrics["class"]``.
    """

    t: np.ndarray
    states: np.ndarray
    theta: np.ndarray
    speed: np.ndarray
    delta: np.ndarray
    metrics: dict
    sway_class: str
    action_s: float
    t_end_s: float
    accepted_steps: int
    rejected_steps: int
    name: str

    state_names = (
        "sigma1_mps",
        "sigma2_per_s",
        "sigma3_per_s",
        "theta_rad",
        "psi_rad",
        "x_h_m",
        "y_h_m",
    )
    """The columns of ``states`` with their units, as ``trajectory.csv`` names them."""

    @property
    def theta_deg(self) -> np.ndarray:
        """θ [deg]."""
        return np.degrees(self.theta)

    def __repr__(self) -> str:
        peak = self.metrics.get("peak_theta_deg_after_action")
        return (
            f"Simulation({self.name!r}: {self.sway_class}, {len(self.t)} samples to "
            f"{self.t_end_s:g} s, peak |θ| after action "
            f"{'None' if peak is None else f'{peak:.3g} deg'})"
        )

    def to_pandas(self):
        """The trajectory as a DataFrame with the columns of the task's ``trajectory.csv``
        (``t_s``, the states by ``state_names``, ``v_mps``, ``delta_rad``); needs pandas."""
        columns = {"t_s": self.t}
        columns.update({n: self.states[:, i] for i, n in enumerate(self.state_names)})
        columns.update({"v_mps": self.speed, "delta_rad": self.delta})
        return _dataframe(columns, "Simulation")

    def plot(self, ax: Any = None) -> Any:
        """θ and δ [deg] over time [s], the action time marked (matplotlib); returns the axes."""
        return _plot.simulation(self, ax)


_METRIC_KEYS = (
    "peak_theta_deg_after_action",
    "final_amplitude_deg",
    "settle_time_s",
    "outcome",
    "loss_of_control_time_s",
    "loss_of_control_condition",
    "class",
    "decay_rate_per_s",
)


def _config(config: Any, keys: Mapping[str, Any], what: str, shape: str) -> Any:
    """A config from a file or dict (``config``) and keyword arguments that set its
    top-level keys (a dict's keys replaced; not with a file)."""
    if not keys:
        return config
    if config is None:
        return dict(keys)
    if not isinstance(config, Mapping):
        raise TypeError(f"{what}: keyword arguments set the keys of a dict {shape}, not of a file; read the file into a dict first")
    return {**config, **keys}


def simulate(
    vehicle: Optional[Vehicle] = None,
    scenario: Union[Scenario, Mapping[str, Any], PathLike, None] = None,
    *,
    trajectory: bool = True,
    progress: Progress = None,
    **keys: Any,
) -> Simulation:
    """Simulates a scenario as ``cargo xtask simulate FILE.toml`` does.

    ``scenario`` is a TOML file path or a dict of the file's shape (:class:`Scenario`
    types every key with its unit; ``configs/scenario_example.toml`` is an example), and
    keyword arguments set its top-level keys, e.g.::

        simulate(v, horizon_s=60.0,
                 speed={"kind": "constant", "speed_mps": 33.0},
                 initial={"kind": "state", "theta0_deg": 5.0})

    ``name`` may be omitted in a dict. With ``trajectory=False`` only the metrics are
    computed (no samples are recorded).
    """
    scenario = _config(scenario, keys, "simulate()", "scenario")
    if scenario is None:
        raise TypeError(
            "simulate(): scenario: expected a dict of the scenario's keys (see trailer_sway.Scenario), "
            "a path to a scenario file, or the keys as keyword arguments (speed=…, initial=…)"
        )
    if isinstance(scenario, Mapping) and "name" not in scenario:
        scenario = {"name": "python", **scenario}
    v = _vehicle(vehicle)
    trajectory = _bool(trajectory, "trajectory")
    arrays, summary = _progress.run(
        progress, lambda p: _native.simulate(v, scenario, trajectory, p)
    )
    s = json.loads(summary)
    states = arrays["states"]
    return Simulation(
        t=arrays["t"],
        states=states,
        theta=states[:, 3],
        speed=arrays["speed"],
        delta=arrays["delta"],
        metrics={k: s[k] for k in _METRIC_KEYS},
        sway_class=s["class"],
        action_s=s["action_s"],
        t_end_s=s["t_end_s"],
        accepted_steps=s["accepted_steps"],
        rejected_steps=s["rejected_steps"],
        name=s["name"],
    )


# ---------------------------------------------------------------------------------------
# bifurcation diagram

@dataclass(frozen=True)
class BifurcationDiagram:
    """Straight running and the sway cycles over the speed V (paper Fig. 3a / 4b).

    ``equilibria``: ``v_mps`` [m/s], ``stable`` (bool), ``max_re_lambda_per_s`` (the
    rightmost characteristic root's real part [1/s]) along straight running, as the task's
    ``equilibria.csv``. ``cycles``: ``v_mps``, ``amplitude_deg`` (max |θ| [deg]),
    ``period_s`` [s], ``stable`` (bool), ``max_multiplier`` (largest nontrivial Floquet
    multiplier modulus), as ``cycles.csv``. Both are empty without a Hopf point.

    ``hopf_v_mps`` (V_crit [m/s]), ``hopf_omega_rad_s``, ``criticality``
    (``"subcritical"``/``"supercritical"``), ``fold_v_mps``, ``fold_amplitude_deg``,
    ``fold_period_s``, ``bistable_range_mps`` (fold → Hopf [m/s]), ``cycle_points``: the
    Hopf point and the fold of cycles corrected on their defining systems, as the task
    reports them; None where the vehicle has none, with ``reason`` saying why (e.g.
    ``"straight running is stable …"``: no Hopf point; a supercritical Hopf point: no
    fold). ``stable_up_to_mps``: without a Hopf point, the speed up to which straight
    running is stable. ``summary``: the task's numbers as they are in its
    ``summary.json`` (open loop: ``cargo xtask fig3a``'s diagram fields, with the cycle
    amplitudes at the configured speeds; closed loop: the ``pairs`` entry of
    ``cargo xtask fig4b``). ``plot(ax=None)`` draws the diagram (paper Fig. 3a).
    """

    equilibria: dict[str, np.ndarray]
    cycles: dict[str, np.ndarray]
    hopf_v_mps: Optional[float]
    hopf_omega_rad_s: Optional[float]
    criticality: Optional[str]
    fold_v_mps: Optional[float]
    fold_amplitude_deg: Optional[float]
    fold_period_s: Optional[float]
    bistable_range_mps: Optional[tuple]
    cycle_points: int
    stable_up_to_mps: Optional[float]
    reason: Optional[str]
    summary: dict

    def __repr__(self) -> str:
        if self.hopf_v_mps is None:
            return f"BifurcationDiagram(no Hopf point: {self.reason})"
        fold = "no fold" if self.fold_v_mps is None else f"fold of cycles at {self.fold_v_mps:.3f} m/s"
        return (
            f"BifurcationDiagram({self.criticality} Hopf point at {self.hopf_v_mps:.3f} m/s, "
            f"{fold}, {self.cycle_points} cycle points)"
        )

    def plot(self, ax: Any = None) -> Any:
        """Sway amplitude max |θ| [deg] over speed V [m/s]: straight running and the cycles,
        stable solid, unstable dashed, Hopf and fold marked (matplotlib); returns the axes."""
        return _plot.bifurcation_diagram(self, ax)


def _speeds(x: Any, name: str) -> list:
    """Speeds: numbers [m/s] or relative ones (``{"of_v_crit": f}``), as a list."""
    if isinstance(x, (str, bytes, Mapping)) or not hasattr(x, "__iter__"):
        raise TypeError(f"{name}: expected a sequence of speeds (numbers [m/s] or {{'of_v_crit': f}}), got {_kind(x)}")
    return [v if isinstance(v, Mapping) else _number(v, f"{name}[{i}]", "m/s") for i, v in enumerate(x)]


def _empty_branches() -> tuple[dict, dict]:
    f, b = np.empty(0), np.empty(0, dtype=bool)
    eq = {"v_mps": f, "stable": b, "max_re_lambda_per_s": f}
    cy = {"v_mps": f, "amplitude_deg": f, "period_s": f, "max_multiplier": f, "stable": b}
    return eq, cy


def bifurcation_diagram(
    vehicle: Optional[Vehicle] = None,
    controller: Optional[Mapping[str, Any]] = None,
    *,
    continuation: Optional[Mapping[str, Any]] = None,
    stable_speeds_mps: Optional[Sequence[Any]] = None,
    unstable_speeds_mps: Optional[Sequence[Any]] = None,
    progress: Progress = None,
) -> BifurcationDiagram:
    """The bifurcation diagram over V for the open loop (``controller=None``: the diagram
    of ``cargo xtask fig3a``) or the delayed yaw-rate feedback (``{"kind":
    "yaw_rate_feedback", "gain_s": D, "delay_s": τ}``: one pair of ``cargo xtask fig4b``),
    on the vehicle's model (any vehicle file, model variants included).

    ``continuation`` takes the keys of ``[diagram.continuation]`` in
    ``configs/fig3a.toml`` (open loop) or ``[continuation]`` in ``configs/fig4b.toml``
    (closed loop): ``v_min_mps``, ``v_max_mps`` (omitted: derived from the vehicle),
    ``beyond_hopf``, ``intervals``, ``degree``, ``hopf_amplitude``, ``initial_step``,
    ``max_step``, ``max_cycle_points``, ``root_degree``, ``cycle_branch_points``; absent
    keys take that file's defaults. Open loop only: ``stable_speeds_mps`` and
    ``unstable_speeds_mps`` (numbers [m/s] or ``{"of_v_crit": f}`` / ``{"in_bistable":
    f}``), the speeds at which ``summary`` reports the cycle amplitudes (default: fig3a's).

    A vehicle without a Hopf point is a result, not an error: ``hopf_v_mps`` None,
    ``reason`` and ``stable_up_to_mps`` set, empty branches.
    """
    v = _vehicle(vehicle)
    gain, delay = _controller_gain_delay(controller)
    cont = {} if continuation is None else _mapping(continuation, "continuation", "{'intervals': 40}")
    settings: dict = {"continuation": cont}
    if gain is None:
        if stable_speeds_mps is not None:
            settings["stable_speeds_mps"] = _speeds(stable_speeds_mps, "stable_speeds_mps")
        if unstable_speeds_mps is not None:
            settings["unstable_speeds_mps"] = _speeds(unstable_speeds_mps, "unstable_speeds_mps")
    elif stable_speeds_mps is not None or unstable_speeds_mps is not None:
        raise TypeError(
            "stable_speeds_mps / unstable_speeds_mps: only for the open loop (fig3a's diagram)"
        )
    raw, arrays = _progress.run(
        progress, lambda p: _native.bifurcation_diagram(v, gain, delay, settings, p)
    )
    s = json.loads(raw)
    eq, cy = (arrays["equilibria"], arrays["cycles"]) if arrays is not None else _empty_branches()
    reason = s.get("reason") or s.get("hopf_reason") or s.get("fold_reason")
    br = s.get("bistable_range_mps")
    return BifurcationDiagram(
        equilibria=eq,
        cycles=cy,
        hopf_v_mps=s.get("hopf_v_mps"),
        hopf_omega_rad_s=s.get("hopf_omega_rad_s"),
        criticality=s.get("criticality"),
        fold_v_mps=s.get("fold_v_mps"),
        fold_amplitude_deg=s.get("fold_amplitude_deg"),
        fold_period_s=s.get("fold_period_s"),
        bistable_range_mps=None if br is None else tuple(br),
        cycle_points=s.get("cycle_points", 0),
        stable_up_to_mps=s.get("stable_up_to_mps"),
        reason=reason,
        summary=s,
    )


# ---------------------------------------------------------------------------------------
# stability charts


@dataclass(frozen=True, repr=False)
class StabilityChart:
    """The linear stability chart of one delay τ in the (V, D) plane (paper Fig. 4a).

    ``v_mps`` [m/s] and ``d_s`` [s] are the cell centres; ``unstable_roots`` (nv × nd,
    int; -1 where a count failed) is the exact number of characteristic roots of eq. (13)
    with Re λ > 0, ``spectral_abscissa_per_s`` (nv × nd) max Re λ [1/s];
    ``static_boundary`` and ``dynamic_boundary`` are the D-subdivision curves (λ = 0 and
    λ = ±iω) as rows (branch, V [m/s], D [s], ω [rad/s]); ``summary`` is this delay's
    ``per_tau`` entry of ``cargo xtask fig4a``'s ``summary.json``; ``failures`` the cells
    whose count failed (speed index, gain index, message). ``plot(ax=None)`` shades the
    stable region.
    """

    tau_s: float
    v_mps: np.ndarray
    d_s: np.ndarray
    unstable_roots: np.ndarray
    spectral_abscissa_per_s: np.ndarray
    static_boundary: np.ndarray
    dynamic_boundary: np.ndarray
    summary: dict
    failures: list[tuple[int, int, str]]

    @property
    def stable(self) -> np.ndarray:
        """nv × nd booleans: straight running is asymptotically stable."""
        return self.unstable_roots == 0

    def __repr__(self) -> str:
        return (
            f"StabilityChart(τ = {self.tau_s:g} s, {len(self.v_mps)} × {len(self.d_s)} cells, "
            f"{int(self.stable.sum())} stable, {len(self.failures)} failed)"
        )

    def plot(self, ax: Any = None) -> Any:
        """The stable region over speed V [m/s] × gain D [s] and its boundaries
        (matplotlib); returns the axes."""
        return _plot.stability_chart(self, ax)


class _PerDelay:
    """One chart per delay in ``charts``: indexing, ``len``, iteration, and ``plot`` with
    one panel per delay."""

    charts: list

    def __getitem__(self, i: int) -> Any:
        return self.charts[i]

    def __len__(self) -> int:
        return len(self.charts)

    def __iter__(self):
        return iter(self.charts)

    def plot(self, ax: Any = None) -> list:
        """One panel per delay (``ax``: as many axes, or None for a new figure); returns
        the axes."""
        return _plot.each(self.charts, ax)


@dataclass(frozen=True, repr=False)
class StabilityCharts(_PerDelay):
    """One :class:`StabilityChart` per delay (``charts``, in the given order; also
    ``charts[i]``, ``len``, iteration) and the summary of ``cargo xtask fig4a``
    (``summary``: ``open_loop_v_crit_mps``, ``per_tau``, ``grid_cells_per_tau``).
    ``plot(ax=None)`` draws one panel per delay."""

    charts: list[StabilityChart]
    summary: dict

    def __repr__(self) -> str:
        taus = ", ".join(f"{c.tau_s:g}" for c in self.charts)
        return f"StabilityCharts(τ = {taus} s; open-loop V_crit {self.summary.get('open_loop_v_crit_mps')} m/s)"


def _pair(x: Any, what: str, unit: str) -> tuple[Optional[float], Optional[float]]:
    if isinstance(x, (str, bytes, Mapping)):
        raise TypeError(f"{what}: expected a pair (min, max) [{unit}], got {_kind(x)}")
    try:
        a, b = x
    except (TypeError, ValueError):
        raise TypeError(f"{what}: expected a pair (min, max) [{unit}], got {x!r}") from None
    return _optional_number(a, f"{what}[0]", unit), _optional_number(b, f"{what}[1]", unit)


def _without_none(d: Mapping[str, Any]) -> dict:
    """The entries of ``d`` that are not None: the keys an optional argument leaves to the
    task's default (None is refused in a config dict)."""
    return {k: v for k, v in d.items() if v is not None}


# the config keys of fig4a and chart_nonlinear that a keyword argument sets
_STABILITY_CHART_KEYS = {
    "delays_s": "delays",
    "speed.min_mps": "speed_range[0]",
    "speed.max_mps": "speed_range[1]",
    "speed.cells": "speed_cells",
    "speed": "speed_range",
    "gain.min_s": "gain_range[0]",
    "gain.max_s": "gain_range[1]",
    "gain.cells": "gain_cells",
    "gain": "gain_range",
    "summary.gain_for_critical_speed_s": "gain_for_critical_speed_s",
    "summary.speed_for_gain_interval_mps": "speed_for_gain_interval_mps",
    "summary.speed_tolerance_mps": "speed_tolerance_mps",
    "numerics.reseed_interval": "reseed_interval",
    "numerics.tracked_roots": "tracked_roots",
}
_NONLINEAR_CHART_KEYS = {"delays_s": "delays"}


def stability_chart(
    vehicle: Optional[Vehicle] = None,
    delays: Union[float, Sequence[float]] = (0.0, 0.1, 0.2, 0.4),
    speed_range: Optional[tuple[Optional[float], Optional[float]]] = None,
    gain_range: Optional[tuple[Optional[float], Optional[float]]] = None,
    *,
    speed_cells: int = 300,
    gain_cells: int = 200,
    gain_for_critical_speed_s: Optional[float] = None,
    speed_for_gain_interval_mps: Optional[float] = None,
    speed_tolerance_mps: float = 1e-9,
    reseed_interval: int = 8,
    tracked_roots: int = 8,
    progress: Progress = None,
) -> StabilityCharts:
    """Stability charts of the delayed yaw-rate feedback δ(t) = −D·ψ̇(t − τ) in the
    (V, D) plane, one per delay τ [s] in ``delays``, over ``speed_range`` [m/s] ×
    ``gain_range`` [s] in ``speed_cells`` × ``gain_cells`` cells — ``cargo xtask fig4a``
    with these values as its config (the defaults are ``configs/fig4a.toml``'s). A range
    (or one end of it) given as None is derived from the vehicle as the task derives it
    (speeds from 0 to above the largest critical speed, gains ±5·D₁);
    ``gain_for_critical_speed_s`` (None: D₁) and ``speed_for_gain_interval_mps``
    (None: the first whole m/s above the open-loop V_crit) place the summary's
    headline numbers."""
    v = _vehicle(vehicle)
    v0, v1 = (None, None) if speed_range is None else _pair(speed_range, "speed_range", "m/s")
    d0, d1 = (None, None) if gain_range is None else _pair(gain_range, "gain_range", "s")
    config = {
        "speed": _without_none({"min_mps": v0, "max_mps": v1, "cells": _int(speed_cells, "speed_cells")}),
        "gain": _without_none({"min_s": d0, "max_s": d1, "cells": _int(gain_cells, "gain_cells")}),
        "delays_s": _numbers(delays, "delays", "s"),
        "summary": _without_none({
            "gain_for_critical_speed_s": _optional_number(gain_for_critical_speed_s, "gain_for_critical_speed_s", "s"),
            "speed_for_gain_interval_mps": _optional_number(speed_for_gain_interval_mps, "speed_for_gain_interval_mps", "m/s"),
            "speed_tolerance_mps": _number(speed_tolerance_mps, "speed_tolerance_mps", "m/s"),
        }),
        "numerics": {
            "reseed_interval": _int(reseed_interval, "reseed_interval"),
            "tracked_roots": _int(tracked_roots, "tracked_roots"),
        },
    }
    try:
        raw, charts = _progress.run(progress, lambda p: _native.stability_chart(v, config, p))
    except (TypeError, ValueError) as e:
        raise _renamed(e, _STABILITY_CHART_KEYS) from None
    summary = json.loads(raw)
    out = [
        StabilityChart(
            tau_s=c["tau_s"],
            v_mps=c["v_mps"],
            d_s=c["d_s"],
            unstable_roots=c["unstable_roots"],
            spectral_abscissa_per_s=c["spectral_abscissa_per_s"],
            static_boundary=c["static_boundary"],
            dynamic_boundary=c["dynamic_boundary"],
            summary=entry,
            failures=c["failures"],
        )
        for c, entry in zip(charts, summary["per_tau"])
    ]
    return StabilityCharts(out, summary)


@dataclass(frozen=True, repr=False)
class NonlinearChart:
    """The nonlinear stability chart of one delay τ: ``hopf_curves`` (each a dict of
    arrays ``d_s`` [s], ``v_mps`` [m/s], ``omega_rad_s`` [rad/s], ``subcritical`` (1, 0,
    NaN unknown), and its ``seed_d_s``), ``fold_curves`` (``d_s``, ``v_mps``,
    ``period_s`` [s], ``amplitude_deg`` (max |θ| [deg])), ``codim2_points`` (kind, D, V,
    ω) and ``summary``: this delay's ``per_tau`` entry of ``cargo xtask
    chart_nonlinear``'s ``summary.json`` (``curves``, ``codim2_points``,
    ``bistable_width_mps``, ``notes``).

    Nothing to show is a result, not an error: ``hopf_reason`` says why there is no Hopf
    curve (e.g. straight running stable in the whole box), ``fold_reason`` why there is
    no fold-of-cycles curve, ``bistable_reason`` why ``bistable_width_mps`` (V_hopf −
    V_fold at the bistable gain [m/s]) is None, ``safe_reason`` that the chart is all
    safe; each None when it does not apply. ``plot(ax=None)`` draws the curves."""

    tau_s: float
    hopf_curves: list[dict[str, Any]]
    fold_curves: list[dict[str, Any]]
    codim2_points: list[dict[str, Any]]
    summary: dict
    bistable_width_mps: Optional[float] = None
    hopf_reason: Optional[str] = None
    fold_reason: Optional[str] = None
    bistable_reason: Optional[str] = None
    safe_reason: Optional[str] = None

    def __repr__(self) -> str:
        width = "None" if self.bistable_width_mps is None else f"{self.bistable_width_mps:.3f} m/s"
        return (
            f"NonlinearChart(τ = {self.tau_s:g} s, {len(self.hopf_curves)} Hopf and "
            f"{len(self.fold_curves)} fold-of-cycles curves, {len(self.codim2_points)} "
            f"codimension-two points, bistable width {width})"
        )

    def plot(self, ax: Any = None) -> Any:
        """The Hopf and fold-of-cycles curves over speed V [m/s] × gain D [s]
        (matplotlib); returns the axes."""
        return _plot.nonlinear_chart(self, ax)


@dataclass(frozen=True, repr=False)
class NonlinearCharts(_PerDelay):
    """One :class:`NonlinearChart` per delay (``charts``, in the given order; also
    ``charts[i]``, ``len``, iteration) and the ranges ``cargo xtask chart_nonlinear``
    derived (``ranges``). ``plot(ax=None)`` draws one panel per delay."""

    charts: list[NonlinearChart]
    ranges: dict

    def __repr__(self) -> str:
        taus = ", ".join(f"{c.tau_s:g}" for c in self.charts)
        return f"NonlinearCharts(τ = {taus} s)"


def nonlinear_chart(
    vehicle: Optional[Vehicle] = None,
    delays: Union[float, Sequence[float]] = (0.0, 0.1, 0.2, 0.4),
    *,
    summary_gains_s: Optional[Sequence[float]] = None,
    bistable_gain_s: Optional[float] = None,
    chart: Optional[Mapping[str, Any]] = None,
    regions: Optional[Mapping[str, Any]] = None,
    progress: Progress = None,
) -> NonlinearCharts:
    """Hopf and fold-of-cycles curves in the (V, D) plane and their codimension-two
    points, one :class:`NonlinearChart` per delay τ [s] — ``cargo xtask chart_nonlinear``
    with these values as its config. ``chart`` takes the keys of ``[chart]`` in
    ``configs/chart_nonlinear.toml`` (box, seeds, steps, ``cycles`` mesh), ``regions`` its
    ``speed_cells``/``gain_cells``; keys left out take the file's defaults (the box and
    the seeds derived from the vehicle), and ``summary_gains_s`` and ``bistable_gain_s``
    None are derived from the vehicle as the task derives them. Expensive: about 15 s per
    delay on 2 cores with the defaults."""
    v = _vehicle(vehicle)
    config: dict = {"delays_s": _numbers(delays, "delays", "s")}
    if summary_gains_s is not None:
        config["summary_gains_s"] = _numbers(summary_gains_s, "summary_gains_s", "s")
    if bistable_gain_s is not None:
        config["bistable_gain_s"] = _number(bistable_gain_s, "bistable_gain_s", "s")
    if chart is not None:
        config["chart"] = _mapping(chart, "chart", "{'hopf_max_points': 200}")
    if regions is not None:
        config["regions"] = _mapping(regions, "regions", "{'speed_cells': 40, 'gain_cells': 30}")
    try:
        raw, charts = _progress.run(progress, lambda p: _native.nonlinear_chart(v, config, p))
    except (TypeError, ValueError) as e:
        raise _renamed(e, _NONLINEAR_CHART_KEYS) from None
    summary = json.loads(raw)
    return NonlinearCharts(
        [
            NonlinearChart(
                tau_s=c["tau_s"],
                hopf_curves=c["hopf_curves"],
                fold_curves=c["fold_curves"],
                codim2_points=entry["codim2_points"],
                summary=entry,
                bistable_width_mps=entry.get("bistable_width_mps"),
                hopf_reason=entry.get("hopf_reason"),
                fold_reason=entry.get("fold_reason"),
                bistable_reason=entry.get("bistable_reason"),
                safe_reason=entry.get("safe_reason"),
            )
            for c, entry in zip(charts, summary["per_tau"])
        ],
        summary.get("ranges", {}),
    )


# ---------------------------------------------------------------------------------------
# sweeps


class Table:
    """A result table without pandas: ordered columns of equal length, numeric ones as
    float64/int64 numpy arrays (NaN where a value is absent), text ones as numpy object
    arrays (None where absent). ``table["v_crit_mps"]``, ``table.columns``,
    ``len(table)``, ``table.to_dict()``, ``table.to_pandas()`` (if pandas is installed).
    """

    def __init__(self, columns: Mapping[str, Any], order: Sequence[str], name: str = "", kind: str = ""):
        self._cols = {}
        for k in order:
            c = columns[k]
            self._cols[k] = c if isinstance(c, np.ndarray) else np.array(c, dtype=object)
        self.name = name
        self.kind = kind

    @property
    def columns(self) -> list:
        """The column names, in ``sweep.csv``'s order."""
        return list(self._cols)

    def __getitem__(self, key: str) -> np.ndarray:
        return self._cols[key]

    def __contains__(self, key: str) -> bool:
        return key in self._cols

    def __len__(self) -> int:
        return len(next(iter(self._cols.values()))) if self._cols else 0

    def __repr__(self) -> str:
        return f"Table({self.name!r}, kind={self.kind!r}, {len(self)} rows, columns={self.columns})"

    def to_dict(self) -> dict:
        """{column: numpy array}."""
        return dict(self._cols)

    def to_pandas(self):
        """A pandas DataFrame of the columns (requires pandas)."""
        return _dataframe(self._cols, "Table")

    def counts(self, column: str = "class") -> dict:
        """{value: rows} of a text column (e.g. the simulation classes)."""
        values, n = np.unique(np.array([str(x) for x in self._cols[column]]), return_counts=True)
        return {str(v): int(k) for v, k in zip(values, n)}


def sweep(
    config: Union[Mapping[str, Any], PathLike],
    vehicle: Optional[Vehicle] = None,
    *,
    progress: Progress = None,
) -> Table:
    """A parallel study, as ``cargo xtask sweep FILE.toml``: ``config`` is a sweep file
    or a dict of its shape (``configs/sweep_threshold.toml``); ``vehicle`` (default
    Table I) is ``--vehicle``. Returns one row per grid point (× uncertainty sample), the
    columns of the task's ``sweep.csv``: the axis values (named by parameter), sampled
    fields, the kind's results (a simulation's metrics and class; V_crit and the Hopf
    frequency; the Hopf and fold speeds), ``accepted_steps`` and ``error`` (None for a
    point that succeeded). Runs on rayon's threads; the θ(0) threshold bisection and the
    figures of the task are not computed. ``name`` may be omitted in a dict."""
    if isinstance(config, Mapping) and "name" not in config:
        config = {"name": "python", **config}
    v = _vehicle(vehicle)
    name, kind, columns, order = _progress.run(progress, lambda p: _native.sweep(v, config, p))
    return Table(columns, order, name, kind)


# ---------------------------------------------------------------------------------------
# the lateral stability test


def _column(rows: Sequence[Mapping[str, Any]], key: str) -> np.ndarray:
    """A float64 column of the rows, NaN where a value is null."""
    return np.array([np.nan if r.get(key) is None else float(r[key]) for r in rows], dtype=float)


@dataclass(frozen=True)
class LateralStability:
    """The lateral stability test (ISO 9815 pulse steer) on the model, as
    ``cargo xtask lateral_stability`` computes it.

    Per test speed (float64 arrays, NaN where the task writes null): ``speed_mps``,
    ``steering_amplitude_deg`` and ``peak_lateral_acceleration_mps2`` (the impulse),
    ``damping_ratio`` D and ``frequency_hz`` of the decay of ``signal``'s peaks,
    ``peaks_used``, ``zero_damping_amplitude_deg`` (where the impulses' local damping
    D(A) crosses zero), ``unstable_cycle_amplitude_deg`` / ``stable_cycle_amplitude_deg``
    (the sway cycles' max |θ| from continuation), ``triggering_impulse_deg`` (the smallest
    impulse that triggers sway) and ``reasons`` (why a value is NaN; None where none is).
    ``local_damping``: per speed an n × 2 array of (amplitude [deg], D).

    ``test_critical_speed_mps`` (the fit of D(V) over the decaying runs extrapolated to
    D = 0; ``fit_coefficients`` constant first), ``v_crit_mps``, ``v_fold_mps``,
    ``overestimate_mps`` (test speed − V_fold), ``reason`` and ``stable_up_to_mps`` where
    V_crit or V_fold is None. ``trace``: one run (``values``, ``steering_deg``,
    ``peaks_used`` as n × 2 arrays of (t [s], value)). ``summary``: the task's
    ``summary.json`` fields. ``plot(ax=None)`` draws the damping over speed.
    """

    speed_mps: np.ndarray
    steering_amplitude_deg: np.ndarray
    peak_lateral_acceleration_mps2: np.ndarray
    damping_ratio: np.ndarray
    frequency_hz: np.ndarray
    peaks_used: np.ndarray
    zero_damping_amplitude_deg: np.ndarray
    unstable_cycle_amplitude_deg: np.ndarray
    stable_cycle_amplitude_deg: np.ndarray
    triggering_impulse_deg: np.ndarray
    reasons: list
    local_damping: list
    signal: str
    test_critical_speed_mps: Optional[float]
    fit_coefficients: np.ndarray
    v_crit_mps: Optional[float]
    v_fold_mps: Optional[float]
    overestimate_mps: Optional[float]
    reason: Optional[str]
    stable_up_to_mps: Optional[float]
    trace: Optional[dict]
    summary: dict = field(repr=False)

    def plot(self, ax: Any = None) -> Any:
        """The damping ratio D [-] over speed V [m/s], its fit extrapolated to D = 0, and
        V_crit and V_fold (matplotlib); returns the axes."""
        return _plot.lateral_stability(self, ax)

    def __repr__(self) -> str:
        def f(v: Optional[float]) -> str:
            return "None" if v is None else f"{v:.3f}"

        return (
            f"LateralStability({len(self.speed_mps)} speeds, test critical speed "
            f"{f(self.test_critical_speed_mps)} m/s, V_crit {f(self.v_crit_mps)} m/s, "
            f"V_fold {f(self.v_fold_mps)} m/s, overestimate {f(self.overestimate_mps)} m/s)"
        )


def lateral_stability(
    vehicle: Optional[Vehicle] = None,
    config: Union[Mapping[str, Any], PathLike, None] = None,
    *,
    progress: Progress = None,
    **keys: Any,
) -> LateralStability:
    """The lateral stability test on ``vehicle`` (default Table I; any model variant), as
    ``cargo xtask lateral_stability``: ``config`` is a TOML file or a dict of
    ``configs/lateral_stability.toml``'s shape; keyword arguments set its top-level keys
    (``speeds``, ``signal``, ``skip_peaks``, ``periods``, ``fit``, ``amplitudes_deg``,
    ``horizon_s``, ``sample_step_s``, ``pulse``, ``controller``, ``diagram``), e.g.
    ``lateral_stability(speeds=[20.0, 30.0], amplitudes_deg=[])``. Absent keys take the
    file's defaults."""
    config = _config(config, keys, "lateral_stability()", "config")
    v = _vehicle(vehicle)
    config = {} if config is None else config
    raw, arrays = _progress.run(progress, lambda p: _native.lateral_stability(v, config, p))
    s = json.loads(raw)
    rows = s["speeds"]
    fit = s.get("fit") or {}
    return LateralStability(
        speed_mps=_column(rows, "speed_mps"),
        steering_amplitude_deg=_column(rows, "steering_amplitude_deg"),
        peak_lateral_acceleration_mps2=_column(rows, "peak_lateral_acceleration_mps2"),
        damping_ratio=_column(rows, "damping_ratio"),
        frequency_hz=_column(rows, "frequency_hz"),
        peaks_used=np.array([int(r["peaks_used"]) for r in rows], dtype=np.int64),
        zero_damping_amplitude_deg=_column(rows, "zero_damping_amplitude_deg"),
        unstable_cycle_amplitude_deg=_column(rows, "unstable_cycle_amplitude_deg"),
        stable_cycle_amplitude_deg=_column(rows, "stable_cycle_amplitude_deg"),
        triggering_impulse_deg=_column(rows, "triggering_impulse_deg"),
        reasons=[r.get("reason") for r in rows],
        local_damping=list(arrays["local_damping"]),
        signal=s["signal"],
        test_critical_speed_mps=s.get("test_critical_speed_mps"),
        fit_coefficients=np.array(fit.get("coefficients", []), dtype=float),
        v_crit_mps=s.get("v_crit_mps"),
        v_fold_mps=s.get("v_fold_mps"),
        overestimate_mps=s.get("overestimate_mps"),
        reason=s.get("reason"),
        stable_up_to_mps=s.get("stable_up_to_mps"),
        trace=arrays.get("trace"),
        summary=s,
    )


@dataclass(frozen=True, repr=False)
class RecordedDecay:
    """One recorded pulse-steer run, read as ``cargo xtask lateral_stability
    --recording`` reads it: ``damping_ratio`` D, ``log_decrement`` δ, ``frequency_hz``,
    ``periods_used``, ``impulse_s`` (start, end [s]), ``peaks_used`` (n × 2: t [s], value
    of the filtered signal), ``filtered`` (the zero-phase low-passed signal), ``signal``
    (which one was read) and ``speed_mps`` (the mean speed from the impulse's end to the
    last peak used; None without a speed)."""

    damping_ratio: float
    log_decrement: float
    frequency_hz: float
    periods_used: int
    impulse_s: tuple
    peaks_used: np.ndarray
    filtered: np.ndarray
    signal: str
    speed_mps: Optional[float]

    def __repr__(self) -> str:
        speed = "" if self.speed_mps is None else f" at {self.speed_mps:.2f} m/s"
        return (
            f"RecordedDecay({self.signal}{speed}: damping ratio {self.damping_ratio:.4f}, "
            f"{self.frequency_hz:.3f} Hz over {self.periods_used} periods)"
        )


_SIGNALS = ("hitch_angle", "trailer_yaw_rate", "car_yaw_rate", "rearmost_articulation_angle")


def _samples(values: Any, name: str) -> np.ndarray:
    """A 1-d float64 array of numbers (not of strings, bools or None)."""
    if isinstance(values, (str, bytes)):
        raise TypeError(f"{name}: expected a sequence of numbers, got a string")
    if values is None or isinstance(values, Mapping):
        raise TypeError(f"{name}: expected a sequence of numbers, got {_kind(values)}")
    try:
        a = np.asarray(values)
    except ValueError as e:  # ragged
        raise ValueError(f"{name}: expected a 1-d sequence of numbers ({e})") from None
    if a.dtype.kind not in "iuf":
        raise TypeError(f"{name}: expected a sequence of numbers, got entries of type {a.dtype}")
    if a.ndim != 1:
        raise ValueError(f"{name}: expected a 1-d sequence, got shape {a.shape}")
    return np.ascontiguousarray(a, dtype=np.float64)


def analyse_recording(
    t: Any,
    signals: Mapping[str, Any],
    *,
    signal: Optional[str] = None,
    skip_peaks: int = 2,
    periods: int = 3,
    impulse_fraction: float = 0.05,
    low_pass_hz: float = 3.0,
    prominence_fraction: float = 0.05,
) -> RecordedDecay:
    """Reads the damping of one recorded pulse-steer run: ``t`` [s] increasing (≥ 20 Hz)
    and ``signals``, a dict of sequences sampled at ``t``: ``"steering_angle"`` (any unit)
    and at least one of ``"hitch_angle"``, ``"trailer_yaw_rate"``, ``"car_yaw_rate"``,
    ``"rearmost_articulation_angle"`` (a combination's last coupling; any unit), optionally
    ``"speed"`` [m/s]. ``signal`` picks the one to read (default: the
    first present in that order). The impulse is found from the steering, the signal is
    low-passed forwards and backwards (zero phase) and its prominent peaks after the
    impulse give D. Raises ``ValueError`` naming the problem (a key and row, counted from
    0, or too few peaks)."""
    if not isinstance(signals, Mapping):
        raise TypeError(f"signals: expected a dict of sequences, got {_kind(signals)}")
    unknown = [k for k in signals if k not in ("steering_angle", "speed", *_SIGNALS)]
    if unknown:
        raise ValueError(
            f"signals: unknown key(s) {unknown}; expected steering_angle, speed and one of {list(_SIGNALS)}"
        )
    if "steering_angle" not in signals:
        raise ValueError("signals: missing 'steering_angle'")
    present = [k for k in _SIGNALS if k in signals]
    if signal is None:
        if not present:
            raise ValueError(f"signals: expected at least one of {list(_SIGNALS)}")
        signal = present[0]
    elif not isinstance(signal, str):
        raise TypeError(f"signal: expected one of {list(_SIGNALS)}, got {_kind(signal)}")
    elif signal not in _SIGNALS:
        raise ValueError(f"signal: expected one of {list(_SIGNALS)}, got {signal!r}")
    elif signal not in signals:
        raise ValueError(f"signal: {signal!r} is not among the signals given ({present})")
    for name, v in (("skip_peaks", skip_peaks), ("periods", periods)):
        if _int(v, name) < (1 if name == "periods" else 0):
            raise ValueError(f"{name}: expected {'≥ 1' if name == 'periods' else '≥ 0'}, got {v}")
    for name, v in (
        ("impulse_fraction", impulse_fraction),
        ("prominence_fraction", prominence_fraction),
    ):
        if not 0.0 < _number(v, name, "-") < 1.0:
            raise ValueError(f"{name}: expected a fraction in (0, 1), got {v!r}")
    low_pass_hz = _number(low_pass_hz, "low_pass_hz", "Hz")
    if not (math.isfinite(low_pass_hz) and low_pass_hz > 0):
        raise ValueError(f"low_pass_hz: expected a cut-off > 0 Hz, got {low_pass_hz!r}")
    tt = _samples(t, "t")
    steering = _samples(signals["steering_angle"], "signals['steering_angle']")
    y = _samples(signals[signal], f"signals[{signal!r}]")
    for name, a in (("signals['steering_angle']", steering), (f"signals[{signal!r}]", y)):
        if len(a) != len(tt):
            raise ValueError(f"{name}: {len(a)} samples, t has {len(tt)}")
    r = _native.analyse_recording(
        tt, steering, y, f"signals[{signal!r}]", int(skip_peaks), int(periods),
        float(impulse_fraction), float(low_pass_hz), float(prominence_fraction),
    )
    speed = None
    if "speed" in signals:
        v = _samples(signals["speed"], "signals['speed']")
        end = r["peaks_used"][-1, 0] if len(r["peaks_used"]) else r["impulse_s"][1]
        window = (tt >= r["impulse_s"][1]) & (tt <= end)
        speed = float(v[window].mean()) if window.any() else None
    return RecordedDecay(
        damping_ratio=r["damping_ratio"],
        log_decrement=r["log_decrement"],
        frequency_hz=r["frequency_hz"],
        periods_used=r["periods_used"],
        impulse_s=tuple(r["impulse_s"]),
        peaks_used=r["peaks_used"],
        filtered=r["filtered"],
        signal=signal,
        speed_mps=speed,
    )


# ---------------------------------------------------------------------------------------
# sway detection on recorded signals

#: The signals a detector can read, as :func:`detect` takes them (SI units).
DETECTION_SIGNALS = ("yaw_rate", "lateral_acceleration", "steering_wheel_angle", "speed", "hitch_angle")

#: The detectors :func:`detect` runs, in the order of its results.
DETECTORS: tuple = tuple(_native.DETECTORS)


@dataclass(frozen=True, repr=False)
class DetectorTrace:
    """One detector's verdict after every sample of a recording (``sway-detect``): ``flag``
    (bool: sway seen), ``score`` (what the flag thresholds: flag ⇔ score ≥ ``threshold``;
    sweep a threshold over it for an ROC curve), ``amplitude`` (band-passed signal unit),
    ``frequency_hz``, ``damping_ratio`` (float64, NaN where the detector has no estimate),
    ``status`` (per sample ``"ok"``, ``"invalid"`` for NaN or a fault, ``"out_of_order"``,
    ``"gap"`` where it restarted after lost samples), ``first_flag_s`` (the time of the
    first flag, None if it never flags), ``estimates`` (the model observer's per-sample
    arrays: ``hitch_angle`` [rad] and ``hitch_angle_sd``, ``hitch_rate`` [rad/s] and
    ``hitch_rate_sd``, ``trailer_mass`` [kg] and ``trailer_mass_sd``,
    ``trailer_yaw_inertia`` [kg m²], ``trailer_cog`` [m], ``v_crit_estimate_mps`` and
    ``v_crit_sd_mps`` (NaN where it has none), ``sway_frequency_hz``; empty for the other
    detectors) and ``options`` (the options it ran with)."""

    name: str
    threshold: float
    flag: np.ndarray
    score: np.ndarray
    amplitude: np.ndarray
    frequency_hz: np.ndarray
    damping_ratio: np.ndarray
    status: list
    first_flag_s: Optional[float]
    estimates: dict = field(repr=False)
    options: dict = field(repr=False)

    def __repr__(self) -> str:
        first = "never flags" if self.first_flag_s is None else f"first flag at {self.first_flag_s:.3f} s"
        return f"DetectorTrace({self.name}: {len(self.flag)} samples, {first})"


@dataclass(frozen=True, repr=False)
class Detection:
    """Recorded signals replayed through the sway detectors: ``t`` [s], the ``signals``
    given (float64 arrays) and ``detectors``, a dict of :class:`DetectorTrace` by name.
    ``plot(ax=None)`` draws the detectors' signal with every detector's flag on the time
    axis."""

    t: np.ndarray
    signals: dict
    detectors: dict

    def __repr__(self) -> str:
        flags = ", ".join(
            f"{n}: {'never' if d.first_flag_s is None else f'{d.first_flag_s:.2f} s'}"
            for n, d in self.detectors.items()
        )
        return f"Detection({len(self.t)} samples, first flags {flags})"

    def plot(self, ax: Any = None) -> Any:
        """The yaw rate (or the first signal given) over t [s] with each detector's flag
        shaded (matplotlib); returns the axes."""
        return _plot.detection(self, ax)


def _sample_rate_hz(t: np.ndarray) -> float:
    """The recording's sample rate [Hz]: 1 / the median step of ``t``."""
    if len(t) < 2:
        raise ValueError(f"t: expected at least 2 samples, got {len(t)}")
    steps = np.diff(t)
    if not np.all(np.isfinite(steps)) or np.median(steps) <= 0:
        raise ValueError("t: expected finite times increasing on the whole (the median step > 0 s)")
    return float(1.0 / np.median(steps))


def detect(
    t: Any,
    signals: Mapping[str, Any],
    *,
    detectors: Optional[Sequence[str]] = None,
    options: Optional[Mapping[str, Mapping[str, Any]]] = None,
) -> Detection:
    """Replays recorded signals through the sway detectors, sample by sample, as the
    controller of a towing car would run them (``sway-detect``; see the guide's
    ``sway_assist`` page for what each detector does).

    ``t`` [s]: the sample times (equally spaced up to jitter; a step beyond 1.5 periods is
    a gap, after which a detector restarts). ``signals``: a dict of sequences sampled at
    ``t`` with keys from ``DETECTION_SIGNALS`` — ``"yaw_rate"`` [rad/s] of the car (what
    the detectors read by default), ``"lateral_acceleration"`` [m/s²],
    ``"steering_wheel_angle"`` [rad], ``"speed"`` [m/s], ``"hitch_angle"`` [rad]; absent
    ones and NaN samples are not measured. ``detectors``: names from ``DETECTORS``
    (default all). ``options``: per detector name a dict in the shape of its TOML table
    (``sample_rate_hz``, ``band = {low_hz, high_hz}``, ``amplitude_threshold``,
    ``half_oscillations``, … for ``oscillation_counter``; ``damping_threshold``,
    ``memory_s``, … for ``damping_estimator``; ``car``, ``steering_ratio``,
    ``trailer_axle_m``, ``mass``, … for ``model_observer``, which reads the yaw rate, the
    lateral acceleration, the steering-wheel angle and the speed); ``sample_rate_hz``
    defaults to the recording's (1 / the median step of ``t``), every other key to the
    detector's default.

    Raises ``TypeError`` for a value of the wrong type, ``ValueError`` naming the key for
    a bad value or a signal of another length than ``t``."""
    tt = _samples(t, "t")
    if not isinstance(signals, Mapping):
        raise TypeError(f"signals: expected a dict of sequences, got {_kind(signals)}")
    unknown = [k for k in signals if k not in DETECTION_SIGNALS]
    if unknown:
        raise ValueError(f"signals: unknown key(s) {unknown}; expected some of {list(DETECTION_SIGNALS)}")
    arrays = {}
    for k, v in signals.items():
        a = _samples(v, f"signals[{k!r}]")
        if len(a) != len(tt):
            raise ValueError(f"signals[{k!r}]: {len(a)} samples, t has {len(tt)}")
        arrays[k] = a
    if not arrays:
        raise ValueError(f"signals: expected at least one of {list(DETECTION_SIGNALS)}")
    if detectors is None:
        names = list(DETECTORS)
    elif isinstance(detectors, str) or not isinstance(detectors, Sequence):
        raise TypeError(f"detectors: expected a list of names from {list(DETECTORS)}, got {_kind(detectors)}")
    else:
        names = list(detectors)
        for n in names:
            if n not in DETECTORS:
                raise ValueError(f"detectors: unknown detector {n!r}; expected some of {list(DETECTORS)}")
    options = {} if options is None else options
    if not isinstance(options, Mapping):
        raise TypeError(f"options: expected a dict of option dicts by detector name, got {_kind(options)}")
    for n in options:
        if n not in names:
            raise ValueError(f"options: {n!r} is not among the detectors run ({names})")
    rate = _sample_rate_hz(tt)
    nan = np.full(len(tt), np.nan)
    column = [arrays.get(k, nan) for k in DETECTION_SIGNALS[:4]]
    traces = {}
    for n in names:
        given = options.get(n, {})
        if not isinstance(given, Mapping):
            raise TypeError(f"options[{n!r}]: expected a dict, got {_kind(given)}")
        opts = {"sample_rate_hz": rate, **given}
        r = _native.detect(tt, *column, arrays.get("hitch_angle"), n, opts)
        flag = np.asarray(r["flag"], dtype=bool)
        first = float(tt[np.argmax(flag)]) if flag.any() else None
        traces[n] = DetectorTrace(
            name=r["name"],
            threshold=r["threshold"],
            flag=flag,
            score=r["score"],
            amplitude=r["amplitude"],
            frequency_hz=r["frequency_hz"],
            damping_ratio=r["damping_ratio"],
            status=r["status"],
            first_flag_s=first,
            estimates=dict(r["estimates"]),
            options=opts,
        )
    return Detection(t=tt, signals=arrays, detectors=traces)
