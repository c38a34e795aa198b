"""The keys of a scenario — :func:`trailer_sway.simulate`'s ``scenario`` dict, the shape of
``configs/scenario_example.toml`` — as typed dicts, each key with its unit: for type
checkers, editors' completion and ``help(trailer_sway.Scenario)``. The TOML reader checks
the same keys (an unknown key or a wrong type is refused, naming it); keys marked optional
take the default given here when left out (None is not a value).

A speed is a number [m/s] or relative to the vehicle: ``{"of_v_crit": f}`` is f·V_crit
of the open loop, ``{"in_bistable": f}`` is V_fold + f·(V_crit − V_fold).
"""

from __future__ import annotations

from typing import Literal, Sequence, TypedDict, Union


class RelativeSpeed(TypedDict, total=False):
    """A speed relative to the vehicle (exactly one key)."""

    of_v_crit: float  # f: the speed f·V_crit of the open loop
    in_bistable: float  # f: V_fold + f·(V_crit − V_fold) (0: the fold of cycles, 1: V_crit)


Speed = Union[float, RelativeSpeed]
"""A speed [m/s], or relative to the vehicle."""


class ConstantSpeed(TypedDict):
    """``speed = {"kind": "constant", "speed_mps": V}``."""

    kind: Literal["constant"]
    speed_mps: Speed  # V [m/s]


class _Ramp(TypedDict):
    kind: Literal["ramp"]
    initial_mps: Speed  # V(0) [m/s]
    change_mps: Speed  # ΔV [m/s] (negative: braking); a number or {"of_v_crit": f}
    start_s: float  # start of the ramp [s]
    duration_s: float  # T [s]


class RampSpeed(_Ramp, total=False):
    """``speed = {"kind": "ramp", …}``: V(0) until ``start_s``, then V(0) + ΔV after T."""

    shape: Literal["linear", "s_curve", "exponential"]  # default "linear"


class TableSpeed(TypedDict):
    """``speed = {"kind": "table", "points": [[t, V], …]}``: V(t) interpolated linearly."""

    kind: Literal["table"]
    points: Sequence[Sequence[float]]  # [[t s, V m/s], …], t increasing


SpeedProfile = Union[ConstantSpeed, RampSpeed, TableSpeed]
"""V(t): constant, a ramp, or a table."""


class SteeringLimits(TypedDict, total=False):
    """The steering actuator of a ``yaw_rate_feedback`` controller (default: ideal)."""

    max_angle_deg: float  # saturation |δ| ≤ δ_max [deg]
    max_rate_deg_s: float  # rate limit |dδ/dt| ≤ δ̇_max [deg/s] (δ a first-order actuator state)
    time_constant_s: float  # t_a of that actuator [s], default 0.05


class NoController(TypedDict):
    """``controller = {"kind": "none"}``: δ ≡ 0 (the default)."""

    kind: Literal["none"]


class _YawRateFeedback(TypedDict):
    kind: Literal["yaw_rate_feedback"]
    gain_s: float  # D [s]
    delay_s: float  # τ [s]


class YawRateFeedback(_YawRateFeedback, total=False):
    """The paper's δ(t) = −D·ψ̇(t − τ) for on_s ≤ t < off_s (eq. 8)."""

    on_s: float  # switched on [s], default 0
    off_s: float  # switched off [s], default never
    actuator: SteeringLimits


class Gains(TypedDict, total=False):
    """Gains of u = −(D·ψ̇ + K_θ·θ + D_θ·θ̇)(t − τ); steering: δ [rad] per ψ̇ [rad/s],
    θ [rad], θ̇ [rad/s]; differential braking: M_z [N m] per the same."""

    yaw_rate: float  # D
    hitch_angle: float  # K_θ
    hitch_rate: float  # D_θ


class _Sensed(TypedDict):
    kind: Literal["yaw_rate_hitch", "predictor"]
    gains: Gains
    delay_s: float  # τ [s]


class SensedController(_Sensed, total=False):
    """``yaw_rate_hitch`` (a yaw-rate and a hitch-angle sensor) or ``predictor`` (ψ̇
    predicted τ ahead through a model of the vehicle; only ``gains["yaw_rate"]``)."""

    actuator: Literal["steering", "differential_braking"]  # default "steering"
    on_s: float  # [s], default 0
    off_s: float  # [s], default never
    limit: dict  # the braking limit (ignored for steering)
    prediction_vehicle: str  # predictor: a vehicle file of its own (default: the vehicle)
    model_error: dict  # predictor: factors on its model, e.g. {"trailer_mass_factor": 1.1}


Controller = Union[NoController, YawRateFeedback, SensedController]
"""δ(t): none, the paper's yaw-rate feedback, or a controller beyond the paper's."""


class StateInitial(TypedDict, total=False):
    """``initial = {"kind": "state", …}``: a given state; components left out are 0."""

    kind: Literal["state"]  # required
    theta0_deg: float  # hitch angle θ(0) [deg]
    psi0_deg: float  # yaw angle ψ(0) [deg]
    sigma1_mps: float  # σ1(0) [m/s]
    sigma2_per_s: float  # σ2(0) [1/s]
    sigma3_per_s: float  # σ3(0) [1/s]


class SwayCycleInitial(TypedDict):
    """``initial = {"kind": "sway_cycle", …}``: the state reached after ``settle_s`` at
    ``speed_mps`` from θ(0) = ``theta0_rad`` (open loop): "on the sway cycle"."""

    kind: Literal["sway_cycle"]
    speed_mps: Speed  # V0 while settling [m/s]
    settle_s: float  # settling time [s]
    theta0_rad: float  # the small initial perturbation θ(0) [rad]


InitialState = Union[StateInitial, SwayCycleInitial]
"""x(0): a given state, or on the sway cycle."""


class Solver(TypedDict, total=False):
    """``solver``: the integrator's error control."""

    rtol: float  # relative tolerance, default 1e-8
    atol: float  # absolute tolerance, default 1e-10
    max_steps: int  # step budget of one run, default 2 000 000
    method: Literal["auto", "dop853", "dopri5"]  # default "auto"
    kink_landing: str  # how steps land on the switching points, default "auto"


class Metrics(TypedDict, total=False):
    """``metrics``: how a run is measured and classified."""

    final_window_s: float  # final_amplitude_deg = max |θ| over the last this many s, default 5
    settle_threshold_deg: float  # settled: |θ| stays below this [deg], default 1
    min_crossings: int  # oscillating: θ − mean crosses 0 this often in the window, default 2
    decay_tolerance: float  # decaying: amplitude shrinks by more than this per window, default 1e-3


class _Scenario(TypedDict):
    speed: SpeedProfile
    initial: InitialState


class Scenario(_Scenario, total=False):
    """One scenario: ``simulate(vehicle, scenario)`` or ``simulate(vehicle, **keys)``.
    Required: ``speed`` and ``initial``."""

    name: str  # letters, digits, '_' and '-'; default "python"
    horizon_s: float  # end time [s], default 40
    output_step_s: float  # trajectory sampling [s], default 0.01
    action_s: float  # start of the metrics "after action" [s]; default the earliest action
    guard: Literal["stop", "off"]  # validity guard: stop at loss of control (default) or off
    controller: Controller  # default {"kind": "none"}
    solver: Solver
    metrics: Metrics
