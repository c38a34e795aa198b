"""Bad inputs as a new user tries them, across every public function: each raises its
exception type with a message in Python's terms — it names the Python argument or the dict
key that is wrong (`speed`, `v_max_mps`, `continuation.intervals`, `trailer_mass[1]`), never
a command-line option (`--speed`) or the command line, and states a limit as every other
message states it ("N exceeds the limit L").

Reference: the signatures and docstrings of `trailer_sway` (what each argument is, in which
unit, which are Optional) and the limits of `docs/src/limits.md`. The first block holds the
inputs of the issue that asked for this (a NaN speed that named `--speed`,
`critical_speed(v_max_mps=inf)` that named `v_min_mps`, a str accepted for a number, a str
split into delays, `horizon_s=None` taken as 40 s, TOML text where a path goes, the sweep's
point limit stated two ways); the rest are more of the same kind.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

import trailer_sway as ts
from conftest import CONFIGS

V = ts.Vehicle.table1()
FB = {"kind": "yaw_rate_feedback", "gain_s": 0.1, "delay_s": 0.2}
SCENARIO = {"speed": {"kind": "constant", "speed_mps": 33.0}, "initial": {"kind": "state", "theta0_deg": 2.0}}
SWEEP = {
    "axes": [{"parameter": "speed_mps", "min": 30.0, "max": 38.0, "points": 5}],
    "base": {"horizon_s": 10.0, **SCENARIO},
}
TOML_TEXT = 'name = "s1"\nhorizon_s = 60.0\n[speed]\nkind = "constant"\nspeed_mps = 33.0\n'


def _t(n=400):
    return np.arange(n) * 0.02


def _signals(n=400, **changes):
    s = {"steering_angle": np.zeros(n), "hitch_angle": np.zeros(n)}
    s["steering_angle"][10:20] = 0.01
    s.update(changes)
    return s


def _sweep(**changes):
    return {**SWEEP, **changes}


def _axis(**changes):
    return _sweep(axes=[{**SWEEP["axes"][0], **changes}])


def _chart(**kwargs):
    """A stability chart small enough to be refused before any work, or to run at once."""
    return ts.stability_chart(V, **{"delays": [0.2], "speed_cells": 4, "gain_cells": 4, **kwargs})


# (call, exception, pattern the message must match)
ISSUE = [
    pytest.param(lambda: ts.roots(V, math.nan, 0.1, 0.2), ValueError, r"roots\(\): `speed`: expected a positive speed \[m/s\], got NaN", id="roots-nan-speed-names-speed-not---speed"),
    pytest.param(lambda: ts.critical_speed(V, v_max_mps=math.inf), ValueError, r"`v_max_mps`: expected a finite speed above v_min_mps = 1 m/s, got inf", id="critical_speed-v_max-inf-names-v_max_mps"),
    pytest.param(lambda: ts.roots(V, "35", 0.1, 0.2), TypeError, r"^speed: expected a number \[m/s\], got str$", id="roots-str-speed"),
    pytest.param(lambda: ts.nonlinear_chart(V, delays="0.2"), TypeError, r"^delays: expected a number or a sequence of numbers \[s\], got str$", id="nonlinear_chart-str-delays-not-split"),
    pytest.param(lambda: ts.stability_chart(V, delays="0.2"), TypeError, r"^delays: expected a number or a sequence of numbers", id="stability_chart-str-delays-not-split"),
    pytest.param(lambda: ts.simulate(V, {**SCENARIO, "horizon_s": None}), TypeError, r"`horizon_s`: expected a value, got None \(leave the key out for its default\)", id="simulate-horizon-None-is-not-the-default"),
    pytest.param(lambda: ts.simulate(V, horizon_s=None, **SCENARIO), TypeError, r"`horizon_s`: expected a value, got None", id="simulate-keyword-horizon-None"),
    pytest.param(lambda: ts.simulate(V, TOML_TEXT), ValueError, r"looks like TOML text, not a path: pass a dict of the file's shape \(tomllib\.loads\(text\)", id="simulate-toml-text-for-a-path"),
    pytest.param(lambda: ts.Vehicle.from_toml("[tractor]\nmass = 2400.0\n"), ValueError, r"looks like TOML text, not a path: Vehicle\.from_toml_str\(text\)", id="from_toml-toml-text-for-a-path"),
    pytest.param(lambda: ts.sweep(_axis(points=200_000)), ValueError, r"sweep\(config\): `axes\[0\]\.points`: 200000 exceeds the limit 100000 ", id="sweep-points-limit-above-the-plan"),
    pytest.param(lambda: ts.sweep(_axis(points=2_000_000)), ValueError, r"sweep\(config\): `axes\[0\]\.points`: 2000000 exceeds the limit 100000 ", id="sweep-points-limit-stated-the-same-way"),
]

VEHICLE = [
    pytest.param(lambda: ts.Vehicle(trailer_mass=900.0), TypeError, r"Vehicle\(\): missing field\(s\) tractor_mass, ", id="Vehicle-missing-fields"),
    pytest.param(lambda: ts.Vehicle(**{**V.to_dict(), "trailer_mass": "heavy"}), TypeError, r"Vehicle\(\): `trailer_mass`: expected a number \[kg\], got str", id="Vehicle-str-field"),
    pytest.param(lambda: V.replace(trailer_mass=-1.0), ValueError, r"Vehicle\.replace\(\): `trailer_mass`: -1 is invalid: expected a positive finite number", id="replace-negative-mass"),
    pytest.param(lambda: V.replace(trailer_mass="985"), TypeError, r"`trailer_mass`: expected a number \[kg\], got str", id="replace-str-mass"),
    pytest.param(lambda: V.replace(trailer_mass=True), TypeError, r"`trailer_mass`: expected a number \[kg\], got bool", id="replace-bool-mass"),
    pytest.param(lambda: V.replace(trailer_mass=None), TypeError, r"`trailer_mass`: expected a number \[kg\], got NoneType", id="replace-None-mass"),
    pytest.param(lambda: V.replace(trailer_mass=[985.0]), TypeError, r"`trailer_mass`: expected a number \[kg\], got list", id="replace-list-mass"),
    pytest.param(lambda: V.replace(trailer_cog=math.nan), ValueError, r"`trailer_cog`: NaN is invalid", id="replace-nan-cog"),
    pytest.param(lambda: V.replace(trailer_mass=math.inf), ValueError, r"`trailer_mass`: inf is invalid", id="replace-inf-mass"),
    pytest.param(lambda: V.replace(trailer_weight=1.0), TypeError, r"unknown field `trailer_weight`; fields: tractor_mass, ", id="replace-unknown-field"),
    pytest.param(lambda: V.replace(tractor_rear_axle=6.0), ValueError, r"`tractor_rear_axle`: 6 is invalid: expected 0 < c < f", id="replace-rear-axle-beyond-front"),
    pytest.param(lambda: V.replace(friction_mu_dynamic=0.95), ValueError, r"`friction_mu_dynamic`: 0\.95 is invalid", id="replace-mu-above-mu0"),
    pytest.param(lambda: V.replace(gravity=0.0), ValueError, r"`gravity`: 0 is invalid", id="replace-zero-gravity"),
    pytest.param(lambda: ts.Vehicle.from_toml(42), TypeError, r"Vehicle\.from_toml\(\): path: expected a str or os\.PathLike, got int", id="from_toml-int-path"),
    pytest.param(lambda: ts.Vehicle.from_toml("/nonexistent/my_car.toml"), OSError, r"/nonexistent/my_car\.toml: cannot read", id="from_toml-missing-file"),
    pytest.param(lambda: ts.Vehicle.from_toml_str("[tractor]\nmass = 'heavy'\n"), ValueError, r"`tractor\.mass`: invalid type: string \"heavy\"", id="from_toml_str-str-mass"),
    pytest.param(lambda: ts.Vehicle.from_toml(CONFIGS / "vehicles" / "tandem.toml").replace(trailer_axle=-3.0), ValueError, r"Vehicle\.replace\(\): `trailer\.axles\[0\]\.position_m`: -3\.4 is invalid: .* \(set by `trailer_axle` = -3, which moves the trailer's axle list\)", id="replace-axle-of-a-tandem-ahead-of-the-hitch"),
    pytest.param(lambda: V.trailer_weight, AttributeError, r"Vehicle' object has no attribute 'trailer_weight'", id="Vehicle-unknown-attribute"),
    pytest.param(lambda: setattr(V, "trailer_mass", 1.0), AttributeError, r"trailer_mass", id="Vehicle-fields-read-only"),
]

CRITICAL_SPEED = [
    pytest.param(lambda: ts.critical_speed("table1"), TypeError, r"^vehicle: expected a trailer_sway\.Vehicle or None \(Table I\), got str$", id="critical_speed-str-vehicle"),
    pytest.param(lambda: ts.critical_speed(V, v_min_mps=-1.0), ValueError, r"`v_min_mps`: expected a speed > 0 m/s, got -1", id="critical_speed-negative-v_min"),
    pytest.param(lambda: ts.critical_speed(V, v_min_mps=math.nan), ValueError, r"`v_min_mps`: expected a speed > 0 m/s, got NaN", id="critical_speed-nan-v_min"),
    pytest.param(lambda: ts.critical_speed(V, v_min_mps=50.0, v_max_mps=40.0), ValueError, r"`v_max_mps`: expected a finite speed above v_min_mps = 50 m/s, got 40", id="critical_speed-v_max-below-v_min"),
    pytest.param(lambda: ts.critical_speed(V, v_max_mps="100"), TypeError, r"^v_max_mps: expected a number \[m/s\], got str$", id="critical_speed-str-v_max"),
    pytest.param(lambda: ts.critical_speed(V, v_max_mps=None), TypeError, r"^v_max_mps: expected a number \[m/s\], got None$", id="critical_speed-None-v_max"),
    pytest.param(lambda: ts.critical_speed(V, scan_step_mps=0.0), ValueError, r"`scan_step_mps`: must be positive, got 0", id="critical_speed-zero-step"),
    pytest.param(lambda: ts.critical_speed(V, scan_step_mps=1e-9), ValueError, r"critical_speed\(\): `scan_step_mps`: 99000000000 exceeds the limit 100000 \(9\.900e10 scan points", id="critical_speed-step-over-the-limit"),
    pytest.param(lambda: ts.critical_speed(V, tolerance_mps=1.0), ValueError, r"`tolerance_mps`: expected 0 < tolerance < 0\.01 m/s, got 1", id="critical_speed-coarse-tolerance"),
    pytest.param(lambda: ts.critical_speed(V, "yaw_rate_feedback"), TypeError, r"^controller: expected None or a dict like", id="critical_speed-str-controller"),
    pytest.param(lambda: ts.critical_speed(V, {**FB, "kind": "pid"}), ValueError, r"controller: `kind`: unknown variant `pid`", id="critical_speed-unknown-controller-kind"),
    pytest.param(lambda: ts.critical_speed(V, {"kind": "yaw_rate_feedback", "gain_s": 0.1}), ValueError, r"controller: missing field `delay_s`", id="critical_speed-controller-without-delay"),
    pytest.param(lambda: ts.critical_speed(V, {**FB, "gain_s": "0.1"}), TypeError, r"controller: `gain_s`: expected a number \[s\], got str", id="critical_speed-str-gain"),
    pytest.param(lambda: ts.critical_speed(V, {**FB, "delay_s": -0.2}), ValueError, r"`controller\.delay_s`: expected a delay ≥ 0 s, got -0\.2", id="critical_speed-negative-delay"),
    pytest.param(lambda: ts.critical_speed(V, {**FB, "gain_s": math.inf}), ValueError, r"`controller\.gain_s`: expected a finite gain \[s\], got inf", id="critical_speed-inf-gain"),
    pytest.param(lambda: ts.critical_speed(V, {"kind": "yaw_rate_feedback", "gain": 0.1, "delay_s": 0.2}), ValueError, r"controller: unknown key `gain`", id="critical_speed-misspelt-controller-key"),
    pytest.param(lambda: ts.critical_speed(V, trailer_mass=[900.0, -1.0]), ValueError, r"critical_speed\(\): `trailer_mass\[1\]`: -1 is invalid", id="critical_speeds-negative-entry"),
    pytest.param(lambda: ts.critical_speed(V, trailer_mass=np.array([900.0, np.nan])), ValueError, r"`trailer_mass\[1\]`: NaN is invalid", id="critical_speeds-nan-entry"),
    pytest.param(lambda: ts.critical_speed(V, trailer_mass="900"), TypeError, r"^trailer_mass: expected a number or a sequence of numbers \[kg\], got str$", id="critical_speeds-str-values"),
    pytest.param(lambda: ts.critical_speed(V, trailer_mass=["900"]), TypeError, r"^trailer_mass\[0\]: expected a number \[kg\], got str$", id="critical_speeds-str-entry"),
    pytest.param(lambda: ts.critical_speed(V, trailer_mass=None), TypeError, r"^trailer_mass: expected a number or a sequence of numbers \[kg\], got None$", id="critical_speeds-None-values"),
    pytest.param(lambda: ts.critical_speed(V, trailer_mass=np.ones((2, 2))), ValueError, r"^trailer_mass: expected a 1-d sequence, got an array of shape \(2, 2\)$", id="critical_speeds-2d-array"),
    pytest.param(lambda: ts.critical_speed(V, trailer_mass=[900.0], trailer_cog=[1.0]), TypeError, r"one vehicle field at a time, got trailer_mass, trailer_cog", id="critical_speeds-two-fields"),
    pytest.param(lambda: ts.critical_speed(V, v_max=50.0), TypeError, r"unexpected keyword `v_max`: neither a search setting \(v_min_mps, v_max_mps", id="critical_speed-misspelt-keyword"),
]

ROOTS = [
    pytest.param(lambda: ts.roots(V, 35.0, 0.1, 0.2, count=2.5), TypeError, r"^count: expected an int, got float$", id="roots-float-count"),
    pytest.param(lambda: ts.roots(V, 35.0, 0.1, 0.2, count="6"), TypeError, r"^count: expected an int, got str$", id="roots-str-count"),
    pytest.param(lambda: ts.roots(V, 35.0, 0.1, 0.2, count=True), TypeError, r"^count: expected an int, got bool$", id="roots-bool-count"),
    pytest.param(lambda: ts.roots(V, 35.0, 0.1, 0.2, count=0), ValueError, r"roots\(\): `count`: expected at least 1, got 0", id="roots-zero-count"),
    pytest.param(lambda: ts.roots(V, 35.0, 0.1, 0.2, count=-1), ValueError, r"roots\(\): `count`: expected at least 1, got -1", id="roots-negative-count"),
    pytest.param(lambda: ts.roots(V, 35.0, 0.1, 0.2, count=201), ValueError, r"roots\(\): `count`: 201 exceeds the limit 200 ", id="roots-count-over-the-limit"),
    pytest.param(lambda: ts.roots(V, -35.0, 0.1, 0.2), ValueError, r"roots\(\): `speed`: expected a positive speed \[m/s\], got -35", id="roots-negative-speed"),
    pytest.param(lambda: ts.roots(V, 35.0, math.inf, 0.2), ValueError, r"roots\(\): `gain`: expected a finite gain \[s\], got inf", id="roots-inf-gain"),
    pytest.param(lambda: ts.roots(V, 35.0, 0.1, -0.2), ValueError, r"roots\(\): `delay`: expected a delay ≥ 0 s, got -0\.2", id="roots-negative-delay"),
    pytest.param(lambda: ts.roots(V, None, 0.1, 0.2), TypeError, r"^speed: expected a number \[m/s\], got None$", id="roots-None-speed"),
    pytest.param(lambda: ts.roots(V, 35.0, [0.1], 0.2), TypeError, r"^gain: expected a number \[s\], got list$", id="roots-list-gain"),
    pytest.param(lambda: ts.roots(V, 35.0, 0.1, "0.2"), TypeError, r"^delay: expected a number \[s\], got str$", id="roots-str-delay"),
    pytest.param(lambda: ts.roots("Table I", 35.0, 0.1, 0.2), TypeError, r"^vehicle: expected a trailer_sway\.Vehicle", id="roots-str-vehicle"),
]

SIMULATE = [
    pytest.param(lambda: ts.simulate(V, 42), TypeError, r"simulate\(scenario\): expected a dict in the TOML file's shape or a path to a TOML file, got int", id="simulate-int-scenario"),
    pytest.param(lambda: ts.simulate(V), TypeError, r"simulate\(\): scenario: expected a dict of the scenario's keys", id="simulate-no-scenario"),
    pytest.param(lambda: ts.simulate(V, {**SCENARIO, "speeed": 1}), ValueError, r"simulate\(scenario\): `speeed`: unknown field `speeed`", id="simulate-misspelt-key"),
    pytest.param(lambda: ts.simulate(V, {**SCENARIO, "horizon_s": -1.0}), ValueError, r"simulate\(scenario\): `horizon_s`: ", id="simulate-negative-horizon"),
    pytest.param(lambda: ts.simulate(V, {**SCENARIO, "horizon_s": "60"}), TypeError, r"simulate\(scenario\): `horizon_s`: invalid type: string \"60\", expected f64", id="simulate-str-horizon"),
    pytest.param(lambda: ts.simulate(V, {**SCENARIO, "horizon_s": object()}), TypeError, r"`horizon_s`: unsupported type object", id="simulate-object-horizon"),
    pytest.param(lambda: ts.simulate(V, {**SCENARIO, "horizon_s": 10**30}), ValueError, r"`horizon_s`: integer 1000000000000000000000000000000 out of range", id="simulate-huge-int-horizon"),
    pytest.param(lambda: ts.simulate(V, {**SCENARIO, "horizon_s": 1e9}), ValueError, r"`horizon_s`: 1000000000 exceeds the limit 100000 ", id="simulate-horizon-over-the-limit"),
    pytest.param(lambda: ts.simulate(V, {**SCENARIO, "output_step_s": 1e-9}), ValueError, r"`output_step_s`: 40000000000 exceeds the limit 5000000 ", id="simulate-output-step-over-the-sample-limit"),
    pytest.param(lambda: ts.simulate(V, {**SCENARIO, "initial": {"kind": "state", "theta0_deg": math.nan}}), ValueError, r"`initial\.theta0_deg`: expected \|θ\(0\)\| < 90 deg, got NaN", id="simulate-nan-theta0"),
    pytest.param(lambda: ts.simulate(V, {**SCENARIO, "speed": {"kind": "constnat", "speed_mps": 33.0}}), ValueError, r"simulate\(scenario\): `speed\.kind`: unknown variant `constnat`, expected one of `constant`, `ramp`, `table`", id="simulate-misspelt-speed-kind"),
    pytest.param(lambda: ts.simulate(V, {**SCENARIO, "speed": {"kind": "constant"}}), ValueError, r"`speed`: missing field `speed_mps`", id="simulate-speed-without-value"),
    pytest.param(lambda: ts.simulate(V, {**SCENARIO, "controller": {**FB, "gain_s": None}}), TypeError, r"`controller\.gain_s`: expected a value, got None", id="simulate-None-gain"),
    pytest.param(lambda: ts.simulate(V, {**SCENARIO, "speed": {"kind": "table", "points": "[[0, 35]]"}}), TypeError, r"`speed(\.points)?`: invalid type: string", id="simulate-str-table"),
    pytest.param(lambda: ts.simulate(V, {1: 2}), TypeError, r"simulate\(scenario\): `<root>`: dict keys must be str", id="simulate-int-key"),
    pytest.param(lambda: ts.simulate(V, SCENARIO, trajectory="yes"), TypeError, r"^trajectory: expected True or False, got str$", id="simulate-str-trajectory"),
    pytest.param(lambda: ts.simulate(V, "no_such_scenario.toml"), OSError, r"no_such_scenario\.toml: cannot read", id="simulate-missing-file"),
    pytest.param(lambda: ts.simulate(V, CONFIGS / "scenario_example.toml", horizon_s=10.0), TypeError, r"simulate\(\): keyword arguments set the keys of a dict scenario, not of a file", id="simulate-keywords-with-a-file"),
    pytest.param(lambda: ts.simulate(V, {**SCENARIO, "name": "my run"}), ValueError, r"`name`: expected ", id="simulate-name-with-a-space"),
]

DIAGRAM = [
    pytest.param(lambda: ts.bifurcation_diagram(V, continuation={"intervals": 1}), ValueError, r"bifurcation_diagram\(\): `continuation\.intervals`", id="diagram-too-few-intervals"),
    pytest.param(lambda: ts.bifurcation_diagram(V, continuation={"mesh": 3}), ValueError, r"bifurcation_diagram\(\): `continuation\.mesh`: unknown field `mesh`", id="diagram-unknown-key"),
    pytest.param(lambda: ts.bifurcation_diagram(V, FB, continuation={"mesh": 3}), ValueError, r"bifurcation_diagram\(\): `continuation\.mesh`: unknown field `mesh`", id="diagram-closed-loop-unknown-key-same-path"),
    pytest.param(lambda: ts.bifurcation_diagram(V, FB, continuation={"intervals": 1}), ValueError, r"`continuation\.intervals`", id="diagram-closed-loop-too-few-intervals"),
    pytest.param(lambda: ts.bifurcation_diagram(V, continuation="fast"), TypeError, r"^continuation: expected a dict like", id="diagram-str-continuation"),
    pytest.param(lambda: ts.bifurcation_diagram(V, continuation={"intervals": "40"}), TypeError, r"`continuation\.intervals`: invalid type: string \"40\"", id="diagram-str-intervals"),
    pytest.param(lambda: ts.bifurcation_diagram(V, continuation={"intervals": None}), TypeError, r"`continuation\.intervals`: expected a value, got None", id="diagram-None-intervals"),
    pytest.param(lambda: ts.bifurcation_diagram(V, continuation={"intervals": 2.5}), TypeError, r"`continuation\.intervals`: invalid type: floating point", id="diagram-float-intervals"),
    pytest.param(lambda: ts.bifurcation_diagram(V, stable_speeds_mps="30"), TypeError, r"^stable_speeds_mps: expected a sequence of speeds", id="diagram-str-speeds"),
    pytest.param(lambda: ts.bifurcation_diagram(V, stable_speeds_mps=[None]), TypeError, r"^stable_speeds_mps\[0\]: expected a number \[m/s\], got None$", id="diagram-None-speed"),
    pytest.param(lambda: ts.bifurcation_diagram(V, FB, stable_speeds_mps=[30.0]), TypeError, r"stable_speeds_mps / unstable_speeds_mps: only for the open loop", id="diagram-speeds-with-a-controller"),
    pytest.param(lambda: ts.bifurcation_diagram(V, {**FB, "gain_s": 10.0}), ValueError, r"`controller\.gain_s`: expected a finite gain \|D\| ≤ 5 s, got 10", id="diagram-gain-over-5"),
    pytest.param(lambda: ts.bifurcation_diagram(V, continuation={"max_cycle_points": 10**7}), ValueError, r"bifurcation_diagram\(\): `continuation\.max_cycle_points`: 10000000 exceeds the limit 100000 ", id="diagram-cycle-points-over-the-limit"),
]

STABILITY_CHART = [
    pytest.param(lambda: _chart(delays=[0.0, math.nan]), ValueError, r"stability_chart\(\): `delays\[1\]`", id="chart-nan-delay"),
    pytest.param(lambda: _chart(delays=[-0.1]), ValueError, r"stability_chart\(\): `delays\[0\]`", id="chart-negative-delay"),
    pytest.param(lambda: _chart(delays=[]), ValueError, r"stability_chart\(\): `delays`", id="chart-no-delays"),
    pytest.param(lambda: _chart(delays=[0.1, None]), TypeError, r"^delays\[1\]: expected a number \[s\], got None$", id="chart-None-delay"),
    pytest.param(lambda: _chart(delays={"tau": 0.2}), TypeError, r"^delays: expected a number or a sequence of numbers \[s\], got dict$", id="chart-dict-delays"),
    pytest.param(lambda: _chart(speed_cells=None), TypeError, r"^speed_cells: expected an int, got None$", id="chart-None-cells-is-not-the-default"),
    pytest.param(lambda: _chart(speed_cells=1), ValueError, r"stability_chart\(\): `speed_cells`: expected ≥ 2, got 1", id="chart-one-cell"),
    pytest.param(lambda: _chart(speed_cells=200_000), ValueError, r"stability_chart\(\): `speed_cells`: 200000 exceeds the limit 100000 ", id="chart-cells-over-the-limit"),
    pytest.param(lambda: _chart(speed_cells=30.0), TypeError, r"^speed_cells: expected an int, got float$", id="chart-float-cells"),
    pytest.param(lambda: _chart(gain_cells=-5), ValueError, r"stability_chart\(\): `gain_cells`", id="chart-negative-cells"),
    pytest.param(lambda: _chart(speed_cells=20_000, gain_cells=20_000), ValueError, r"exceeds the limit 20000000 ", id="chart-cells-product-over-the-limit"),
    pytest.param(lambda: _chart(speed_range=(60.0, 0.0)), ValueError, r"stability_chart\(\): `speed_range", id="chart-reversed-speed-range"),
    pytest.param(lambda: _chart(speed_range="0-60"), TypeError, r"^speed_range: expected a pair \(min, max\) \[m/s\], got str$", id="chart-str-range"),
    pytest.param(lambda: _chart(speed_range=(0.0, "60")), TypeError, r"^speed_range\[1\]: expected a number \[m/s\], got str$", id="chart-str-range-end"),
    pytest.param(lambda: _chart(gain_range=(-0.5, 0.0, 0.5)), TypeError, r"^gain_range: expected a pair \(min, max\) \[s\], got \(", id="chart-triple-range"),
    pytest.param(lambda: _chart(tracked_roots=0), ValueError, r"stability_chart\(\): `tracked_roots`", id="chart-no-tracked-roots"),
    pytest.param(lambda: _chart(speed_tolerance_mps=None), TypeError, r"^speed_tolerance_mps: expected a number \[m/s\], got None$", id="chart-None-tolerance"),
    pytest.param(lambda: _chart(gain_for_critical_speed_s="D1"), TypeError, r"^gain_for_critical_speed_s: expected a number \[s\], got str$", id="chart-str-gain-for-vcrit"),
]

NONLINEAR_CHART = [
    pytest.param(lambda: ts.nonlinear_chart(V, delays=[math.nan]), ValueError, r"nonlinear_chart\(\): `delays\[0\]`", id="nonlinear-nan-delay"),
    pytest.param(lambda: ts.nonlinear_chart(V, delays=[0.0] * 65), ValueError, r"nonlinear_chart\(\): `delays`: 65 exceeds the limit 64 ", id="nonlinear-delays-over-the-limit"),
    pytest.param(lambda: ts.nonlinear_chart(V, delays=[0.0], chart="big"), TypeError, r"^chart: expected a dict like", id="nonlinear-str-chart"),
    pytest.param(lambda: ts.nonlinear_chart(V, delays=[0.0], chart={"hopf_max_points": 10**6}), ValueError, r"`chart\.hopf_max_points`: 1000000 exceeds the limit 20000 ", id="nonlinear-points-over-the-limit"),
    pytest.param(lambda: ts.nonlinear_chart(V, delays=[0.0], chart={"hopf_points": 10}), ValueError, r"nonlinear_chart\(\): `chart\.hopf_points`: unknown field `hopf_points`", id="nonlinear-misspelt-chart-key"),
    pytest.param(lambda: ts.nonlinear_chart(V, delays=[0.0], regions={"speed_cells": "10"}), TypeError, r"`regions\.speed_cells`: invalid type: string", id="nonlinear-str-cells"),
    pytest.param(lambda: ts.nonlinear_chart(V, delays=[0.0], bistable_gain_s="0.1"), TypeError, r"^bistable_gain_s: expected a number \[s\], got str$", id="nonlinear-str-bistable-gain"),
    pytest.param(lambda: ts.nonlinear_chart(V, delays=[0.0], summary_gains_s="0.1"), TypeError, r"^summary_gains_s: expected a number or a sequence of numbers \[s\], got str$", id="nonlinear-str-summary-gains"),
    pytest.param(lambda: ts.nonlinear_chart(V, delays=[0.0], chart={"seed_gains_s": None}), TypeError, r"`chart\.seed_gains_s`: expected a value, got None", id="nonlinear-None-seeds"),
]

SWEEP_CASES = [
    pytest.param(lambda: ts.sweep(42), TypeError, r"sweep\(config\): expected a dict in the TOML file's shape or a path to a TOML file, got int", id="sweep-int-config"),
    pytest.param(lambda: ts.sweep(_sweep(axis=[])), ValueError, r"sweep\(config\): `axis`: unknown field `axis`", id="sweep-misspelt-key"),
    pytest.param(lambda: ts.sweep(_axis(points=0)), ValueError, r"`axes\[0\]\.points`: expected at least 1 point, got 0", id="sweep-zero-points"),
    pytest.param(lambda: ts.sweep(_axis(points=2.5)), TypeError, r"`axes\[0\]\.points`: invalid type: floating point `2\.5`", id="sweep-float-points"),
    pytest.param(lambda: ts.sweep(_axis(points=-3)), ValueError, r"`axes\[0\]\.points`", id="sweep-negative-points"),
    pytest.param(lambda: ts.sweep(_axis(parameter="speed")), ValueError, r"`axes\[0\]\.parameter`", id="sweep-unknown-parameter"),
    pytest.param(lambda: ts.sweep(_axis(min=38.0, max=30.0)), ValueError, r"`axes\[0\]`: expected finite min <= max, got 38 and 30", id="sweep-reversed-axis"),
    pytest.param(lambda: ts.sweep(_axis(min=math.nan)), ValueError, r"sweep\(config\): `axes\[0\]\.min`: NaN is invalid", id="sweep-nan-axis"),
    pytest.param(lambda: ts.sweep(TOML_TEXT), ValueError, r"sweep\(config\): .* looks like TOML text, not a path", id="sweep-toml-text"),
    pytest.param(lambda: ts.sweep(SWEEP, "Table I"), TypeError, r"^vehicle: expected a trailer_sway\.Vehicle", id="sweep-str-vehicle"),
    pytest.param(lambda: ts.sweep(_sweep(base={**SWEEP["base"], "horizon_s": None})), TypeError, r"`base\.horizon_s`: expected a value, got None", id="sweep-None-horizon"),
    pytest.param(lambda: ts.sweep(_sweep(axes=[SWEEP["axes"][0]] * 2)), ValueError, r"`axes\[1\]\.parameter`: each parameter may be swept once", id="sweep-axis-twice"),
]

LATERAL = [
    pytest.param(lambda: ts.lateral_stability(V, speeds="30"), TypeError, r"lateral_stability\(\): `speeds`: invalid type: string", id="lateral-str-speeds"),
    pytest.param(lambda: ts.lateral_stability(V, horizon_s=None), TypeError, r"lateral_stability\(\): `horizon_s`: expected a value, got None", id="lateral-None-horizon"),
    pytest.param(lambda: ts.lateral_stability(V, speedz=[30.0]), ValueError, r"lateral_stability\(\): `speedz`: unknown field `speedz`", id="lateral-misspelt-key"),
    pytest.param(lambda: ts.lateral_stability(V, TOML_TEXT), ValueError, r"lateral_stability\(\): .* looks like TOML text, not a path", id="lateral-toml-text"),
    pytest.param(lambda: ts.lateral_stability(V, 42), TypeError, r"lateral_stability\(\): expected a dict in the TOML file's shape or a path", id="lateral-int-config"),
    pytest.param(lambda: ts.lateral_stability(V, CONFIGS / "lateral_stability.toml", speeds=[30.0]), TypeError, r"lateral_stability\(\): keyword arguments set the keys of a dict config, not of a file", id="lateral-keywords-with-a-file"),
    pytest.param(lambda: ts.lateral_stability(V, amplitudes_deg=[1.0] * 10_001), ValueError, r"`amplitudes_deg`: 10001 exceeds the limit 10000 ", id="lateral-array-over-the-limit"),
]

RECORDING = [
    pytest.param(lambda: ts.analyse_recording("0.1, 0.2", _signals()), TypeError, r"^t: expected a sequence of numbers, got a string$", id="recording-str-t"),
    pytest.param(lambda: ts.analyse_recording(["0.1", "0.2"], _signals(2)), TypeError, r"^t: expected a sequence of numbers, got entries of type <U3$", id="recording-str-entries"),
    pytest.param(lambda: ts.analyse_recording(np.zeros((20, 2)), _signals(20)), ValueError, r"^t: expected a 1-d sequence, got shape \(20, 2\)$", id="recording-2d-t"),
    pytest.param(lambda: ts.analyse_recording([], {"steering_angle": [], "hitch_angle": []}), ValueError, r"expected at least 10 samples of t, signals\['steering_angle'\] and signals\['hitch_angle'\] of equal length, got 0, 0 and 0", id="recording-empty"),
    pytest.param(lambda: ts.analyse_recording(_t(), [1, 2]), TypeError, r"^signals: expected a dict of sequences, got list$", id="recording-list-signals"),
    pytest.param(lambda: ts.analyse_recording(_t(), _signals(), signal=3), TypeError, r"^signal: expected one of \['hitch_angle', 'trailer_yaw_rate', 'car_yaw_rate', 'rearmost_articulation_angle'\], got int$", id="recording-int-signal"),
    pytest.param(lambda: ts.analyse_recording(_t(), _signals(), signal="theta"), ValueError, r"^signal: expected one of .*got 'theta'$", id="recording-unknown-signal"),
    pytest.param(lambda: ts.analyse_recording(_t(), _signals(), skip_peaks=-1), ValueError, r"^skip_peaks: expected ≥ 0, got -1$", id="recording-negative-skip"),
    pytest.param(lambda: ts.analyse_recording(_t(), _signals(), periods=2.0), TypeError, r"^periods: expected an int, got float$", id="recording-float-periods"),
    pytest.param(lambda: ts.analyse_recording(_t(), _signals(), impulse_fraction=1.5), ValueError, r"^impulse_fraction: expected a fraction in \(0, 1\), got 1\.5$", id="recording-fraction-above-1"),
    pytest.param(lambda: ts.analyse_recording(_t(), _signals(), impulse_fraction="0.05"), TypeError, r"^impulse_fraction: expected a number \[-\], got str$", id="recording-str-fraction"),
    pytest.param(lambda: ts.analyse_recording(_t(), _signals(), low_pass_hz=math.nan), ValueError, r"^low_pass_hz: expected a cut-off > 0 Hz, got nan$", id="recording-nan-cut-off"),
    pytest.param(lambda: ts.analyse_recording(_t(), _signals(hitch_angle=[None] * 400)), TypeError, r"^signals\['hitch_angle'\]: expected a sequence of numbers, got entries of type object$", id="recording-None-samples"),
    pytest.param(lambda: ts.analyse_recording(_t(), _signals(hitch_angle=np.r_[np.zeros(399), np.inf])), ValueError, r"^row 399: signals\['hitch_angle'\] is not a finite number$", id="recording-inf-sample"),
]

RUNTIME = [
    pytest.param(lambda: ts.set_num_threads("2"), TypeError, r"set_num_threads: n: expected an int, got str", id="threads-str"),
    pytest.param(lambda: ts.set_num_threads(0), ValueError, r"set_num_threads: n: expected 1 to 1024 threads, got 0", id="threads-zero"),
    pytest.param(lambda: ts.to_toml([1, 2]), TypeError, r"^to_toml\(\): config: expected a dict, got list$", id="to_toml-list"),
    pytest.param(lambda: ts.to_toml({"horizon_s": None}), TypeError, r"^to_toml\(\): `horizon_s`: expected a value, got None", id="to_toml-None"),
]

CASES = ISSUE + VEHICLE + CRITICAL_SPEED + ROOTS + SIMULATE + DIAGRAM + STABILITY_CHART + NONLINEAR_CHART + SWEEP_CASES + LATERAL + RECORDING + RUNTIME

# what a message in Python's terms never contains
CLI_TERMS = re.compile(r"`--[a-z]|\bcommand line\b|<scenario>|<sweep>|cargo xtask")


@pytest.mark.parametrize("call, error, pattern", CASES)
def test_bad_input_raises_in_pythons_terms(call, error, pattern):
    with pytest.raises(error, match=pattern) as e:
        call()
    assert type(e.value) is error or error is OSError, type(e.value)
    assert not CLI_TERMS.search(str(e.value)), str(e.value)


def test_the_table_holds_the_issues_inputs_and_60_more():
    assert len(ISSUE) == 11 and len(CASES) - len(ISSUE) >= 60, len(CASES)
    # every public function is tried
    tried = " ".join(p.id for p in CASES)
    for name in ("Vehicle", "replace", "from_toml", "critical_speed", "roots", "simulate", "diagram",
                 "chart", "nonlinear", "sweep", "lateral", "recording", "threads", "to_toml"):
        assert name in tried, name
