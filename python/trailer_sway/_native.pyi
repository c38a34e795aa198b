"""Type hints of the extension module (the Rust layer; use the functions of
``trailer_sway`` rather than these)."""

from os import PathLike
from typing import Any, Callable, Mapping, Optional, Union

import numpy as np

# `progress`: None or a callable (stage, done, total), called from the calling thread
ProgressCallback = Optional[Callable[[str, int, int], None]]

class Vehicle:
    """A car–trailer combination, validated: positive masses, inertias and stiffnesses,
    0 < c < f, 0 < d < f, 0 < μ ≤ μ0, g > 0 (``ValueError`` with the CLI's message
    otherwise). Lengths in m, masses in kg, inertias in kg m², cornering stiffnesses in
    N/rad, g in m/s². Either the paper's form (Table I's 15 fields) or a vehicle file with
    model variants (tyre relaxation, axle lists, tyre laws, hitch torque:
    ``configs/vehicles/*.toml``), read with ``from_toml``; on such a vehicle a paper
    field that its file lacks (an axle key of a unit whose axles are a list) raises
    ``ValueError``, and ``to_dict`` raises ``ValueError``."""

    # the fields of Table I, read-only attributes (a vehicle with model variants raises
    # ValueError for a key its file lacks)
    @property
    def tractor_mass(self) -> float:
        """m1: the tractor's mass [kg]"""
    @property
    def tractor_yaw_inertia(self) -> float:
        """J1: the tractor's yaw moment of inertia about its centre of gravity [kg m²]"""
    @property
    def tractor_front_axle(self) -> float:
        """f: hitch to the tractor's front axle [m]"""
    @property
    def tractor_cog(self) -> float:
        """d: hitch to the tractor's centre of gravity [m]"""
    @property
    def tractor_rear_axle(self) -> float:
        """c: hitch to the tractor's rear axle [m]"""
    @property
    def tractor_front_cornering_stiffness(self) -> float:
        """C_F: cornering stiffness of the tractor's front axle [N/rad]"""
    @property
    def tractor_rear_cornering_stiffness(self) -> float:
        """C_R: cornering stiffness of the tractor's rear axle [N/rad]"""
    @property
    def trailer_mass(self) -> float:
        """m2: the trailer's mass [kg]"""
    @property
    def trailer_yaw_inertia(self) -> float:
        """J2: the trailer's yaw moment of inertia about its centre of gravity [kg m²]"""
    @property
    def trailer_cog(self) -> float:
        """h: hitch to the trailer's centre of gravity [m]"""
    @property
    def trailer_axle(self) -> float:
        """l: hitch to the trailer's axle [m]"""
    @property
    def trailer_cornering_stiffness(self) -> float:
        """C_T: cornering stiffness of the trailer's axle [N/rad]"""
    @property
    def friction_mu_static(self) -> float:
        """μ0: static friction coefficient of the tyres [-]"""
    @property
    def friction_mu_dynamic(self) -> float:
        """μ: sliding friction coefficient of the tyres [-]"""
    @property
    def gravity(self) -> float:
        """g: gravitational acceleration [m/s²]"""
    def __init__(
        self,
        *,
        tractor_mass: float,
        tractor_yaw_inertia: float,
        tractor_front_axle: float,
        tractor_cog: float,
        tractor_rear_axle: float,
        tractor_front_cornering_stiffness: float,
        tractor_rear_cornering_stiffness: float,
        trailer_mass: float,
        trailer_yaw_inertia: float,
        trailer_cog: float,
        trailer_axle: float,
        trailer_cornering_stiffness: float,
        friction_mu_static: float,
        friction_mu_dynamic: float,
        gravity: float = 9.81,
    ) -> None: ...
    @staticmethod
    def table1() -> Vehicle:
        """Paper Table I (μ0 = 0.9, μ = 0.6, g = 9.81 m/s²)."""
    @staticmethod
    def from_toml(path: Union[str, PathLike[str]]) -> Vehicle:
        """A vehicle file (``configs/vehicle.toml``'s form, or with model variants); TOML
        text instead of a path is a ``ValueError`` pointing to ``from_toml_str``."""
    @staticmethod
    def from_toml_str(text: str) -> Vehicle:
        """A vehicle file's text."""
    def replace(self, **changes: float) -> Vehicle:
        """A copy with some fields changed, validated (on a vehicle with model variants:
        the paper's keys its file has)."""
    @staticmethod
    def fields() -> list[str]: ...
    @property
    def is_paper_form(self) -> bool: ...
    @property
    def variant_key(self) -> Optional[str]:
        """The first key that makes the vehicle differ from the paper's model."""
    @property
    def states(self) -> int:
        """Number of states of the model (4 + one per relaxing axle)."""
    def to_dict(self) -> dict[str, float]:
        """{field: value}; ``ValueError`` on a vehicle with model variants."""
    def to_toml(self) -> str:
        """The vehicle file's text."""
    def __eq__(self, other: object) -> bool: ...

__version__: str

def critical_speed(
    vehicle: Vehicle,
    gain: Optional[float],
    delay: Optional[float],
    v_min_mps: float,
    v_max_mps: float,
    scan_step_mps: float,
    tolerance_mps: float,
) -> str: ...
def critical_speeds(
    vehicle: Vehicle,
    field: str,
    values: np.ndarray,
    gain: Optional[float],
    delay: Optional[float],
    v_min_mps: float,
    v_max_mps: float,
    scan_step_mps: float,
    tolerance_mps: float,
    progress: ProgressCallback = None,
) -> tuple[dict[str, np.ndarray], list[str]]:
    """critical_speed on ``vehicle.replace(field=x)`` for each x of ``values``, in
    parallel: float64 arrays (NaN without a crossing) and the reasons."""
def roots(
    vehicle: Vehicle, speed: float, gain: float, delay: float, count: int = 6
) -> np.ndarray: ...
def simulate(
    vehicle: Vehicle, scenario: Any, trajectory: bool = True, progress: ProgressCallback = None
) -> tuple[dict[str, np.ndarray], str]: ...
def stability_chart(
    vehicle: Vehicle, config: Mapping[str, Any], progress: ProgressCallback = None
) -> tuple[str, list[dict[str, Any]]]: ...
def nonlinear_chart(
    vehicle: Vehicle, config: Mapping[str, Any], progress: ProgressCallback = None
) -> tuple[str, list[dict[str, Any]]]: ...
def bifurcation_diagram(
    vehicle: Vehicle,
    gain: Optional[float],
    delay: Optional[float],
    settings: Mapping[str, Any],
    progress: ProgressCallback = None,
) -> tuple[str, Optional[dict[str, dict[str, np.ndarray]]]]:
    """``settings``: ``{"continuation": {…}}`` (and, open loop, the speeds of the cycle
    amplitudes)."""
def sweep(
    vehicle: Vehicle, config: Any, progress: ProgressCallback = None
) -> tuple[str, str, dict[str, Any], list[str]]: ...
def lateral_stability(
    vehicle: Vehicle, config: Any, progress: ProgressCallback = None
) -> tuple[str, dict[str, Any]]: ...
def analyse_recording(
    t: Any, steering: Any, signal: Any, signal_name: str, skip_peaks: int, periods: int,
    impulse_fraction: float, low_pass_hz: float, prominence_fraction: float,
) -> dict[str, Any]: ...
DETECTORS: list[str]
def detect(
    t: Any, yaw_rate: Any, lateral_acceleration: Any, steering_wheel_angle: Any, speed: Any,
    hitch_angle: Any, detector: str, options: Optional[Mapping[str, Any]] = None,
) -> dict[str, Any]: ...
def set_num_threads(n: int) -> None:
    """The number of threads (1 to 1024) of every later call, at any time."""
def get_num_threads() -> int:
    """The number of threads the next call will use."""
def to_toml(config: Mapping[str, Any]) -> str:
    """The TOML text of a config dict (a file ``cargo xtask`` reads)."""
