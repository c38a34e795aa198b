"""What a notebook user discovers: vehicle fields as attributes, the scenario's keys typed,
every result type exported and typed, short reprs, float64 columns, ``__version__``,
``to_pandas()`` and ``plot()``; and ``critical_speed`` over an array of one field's values,
equal to the scalar call bit for bit."""

from __future__ import annotations

import inspect
import json
import math
import pydoc
import re
import sys
import typing

import numpy as np
import pytest

import trailer_sway as ts
from conftest import CONFIGS, REPO, RESULTS

SMALL_SWEEP = {
    "axes": [{"parameter": "speed_mps", "min": 25.0, "max": 33.0, "points": 3}],
    "base": {
        "horizon_s": 20.0,
        "speed": {"kind": "constant", "speed_mps": 30.0},
        "initial": {"kind": "state", "theta0_deg": 2.0},
    },
}
SCENARIO = {
    "horizon_s": 20.0,
    "speed": {"kind": "constant", "speed_mps": 33.0},
    "initial": {"kind": "state", "theta0_deg": 5.0},
}
SMALL_NONLINEAR = dict(
    delays=[0.0],
    summary_gains_s=[0.0],
    bistable_gain_s=0.0,
    chart={"hopf_max_points": 40, "fold_max_points": 20, "criticality_samples": 2,
           "criticality_cycle_points": 2, "seed_gains_s": [0.1]},
    regions={"speed_cells": 6, "gain_cells": 4},
)


@pytest.fixture(scope="module")
def results():
    """One small result of every kind (module-scoped: computed once)."""
    v = ts.Vehicle.table1()
    return {
        "critical_speed": ts.critical_speed(v),
        "critical_speeds": ts.critical_speed(v, trailer_mass=[100.0, 985.0, 1400.0]),
        "simulate": ts.simulate(v, SCENARIO),
        "bifurcation_diagram": ts.bifurcation_diagram(v, continuation={"intervals": 12, "max_cycle_points": 40}),
        "stability_chart": ts.stability_chart(v, delays=[0.0, 0.2], speed_cells=30, gain_cells=20),
        "nonlinear_chart": ts.nonlinear_chart(v, **SMALL_NONLINEAR),
        "sweep": ts.sweep(SMALL_SWEEP, v),
        "lateral_stability": ts.lateral_stability(v, speeds=[25.0, 30.0], amplitudes_deg=[]),
    }


# ---------------------------------------------------------------------------------------
# inputs


def test_version_is_the_packages():
    # reference: the version pip installs (python/pyproject.toml)
    text = (REPO / "python" / "pyproject.toml").read_text()
    assert ts.__version__ == re.search(r'^version = "([^"]+)"', text, re.M).group(1)
    assert "__version__" in ts.__all__


def test_vehicle_fields_are_read_only_attributes_with_units(table1):
    # reference: Vehicle.fields() (paper Table I's 15 keys) and to_dict()
    d = table1.to_dict()
    for name in ts.Vehicle.fields():
        assert name in dir(table1), name
        assert getattr(table1, name) == d[name]
        doc = getattr(ts.Vehicle, name).__doc__
        assert re.search(r"\[[^\]]+\]", doc), (name, doc)  # its unit
        with pytest.raises(AttributeError):
            setattr(table1, name, 1.0)
    text = pydoc.render_doc(ts.Vehicle, renderer=pydoc.plaintext)
    assert "trailer_mass" in text and "m2: the trailer's mass [kg]" in text
    stub = (REPO / "python" / "trailer_sway" / "_native.pyi").read_text()
    for name in ts.Vehicle.fields():
        assert re.search(rf"@property\n    def {name}\(self\) -> float:", stub), name
    with pytest.raises(AttributeError, match="trailer_weight"):
        table1.trailer_weight


def _annotations(td) -> dict:
    return typing.get_type_hints(td)


def _resolves(td, path: list) -> bool:
    """Whether the key path is a key of the typed dict `td` (through nested typed dicts
    and unions of them)."""
    options = typing.get_args(td) if typing.get_origin(td) is typing.Union else (td,)
    for option in options:
        if not typing.is_typeddict(option):
            continue
        hints = _annotations(option)
        if path[0] in hints and (len(path) == 1 or _resolves(hints[path[0]], path[1:])):
            return True
    return False


def test_scenario_keys_are_typed_with_their_units():
    # reference: the key tables of the simulate task's guide page (every key a scenario
    # file takes, docs/src/tasks/simulate.md) and the keys of configs/scenario_example.toml
    page = (REPO / "docs" / "src" / "tasks" / "simulate.md").read_text()
    keys = re.findall(r"^\| `([a-z_.0-9]+)` \|", page, re.M)
    assert len(keys) > 25
    missing = [k for k in keys if not _resolves(ts.Scenario, k.split("."))]
    assert not missing, missing
    import tomllib

    def paths(d, prefix=()):
        for k, v in d.items():
            if isinstance(v, dict) and not set(v) <= {"of_v_crit", "in_bistable"}:
                yield from paths(v, prefix + (k,))
            else:
                yield list(prefix + (k,))

    example = tomllib.loads((CONFIGS / "scenario_example.toml").read_text())
    assert all(_resolves(ts.Scenario, p) for p in paths(example))
    # every key's comment in the stub names a unit or a default
    source = (REPO / "python" / "trailer_sway" / "_scenario.py").read_text()
    assert "horizon_s: float  # end time [s]" in source


def test_scenario_keys_as_keyword_arguments(table1):
    # the same run as the dict, bit for bit
    a = ts.simulate(table1, SCENARIO, trajectory=False)
    b = ts.simulate(table1, trajectory=False, **SCENARIO)
    assert a.metrics == b.metrics and a.accepted_steps == b.accepted_steps
    c = ts.simulate(table1, {**SCENARIO, "horizon_s": 10.0}, trajectory=False, horizon_s=20.0)
    assert c.metrics == a.metrics


def test_every_result_type_is_exported_and_typed():
    # reference: the return annotation of every public function
    for name in ts.__all__:
        obj = getattr(ts, name)
        if not inspect.isfunction(obj):  # classes, type aliases; the native functions
            continue
        hints = typing.get_type_hints(obj)
        assert "return" in hints, name
        ret = hints["return"]
        kinds = typing.get_args(ret) if typing.get_origin(ret) is typing.Union else (ret,)
        for k in kinds:
            if k is np.ndarray:
                continue
            assert k.__module__ == "trailer_sway" and k.__name__ in ts.__all__, (name, k)
    assert ts.stability_chart.__annotations__["return"] in ("StabilityCharts", ts.StabilityCharts)
    assert ts.nonlinear_chart.__annotations__["return"] in ("NonlinearCharts", ts.NonlinearCharts)


# ---------------------------------------------------------------------------------------
# results


def test_reprs_are_short(results, table1):
    for name, r in results.items():
        text = repr(r)
        assert len(text) < 300 and text.count("\n") <= 2, (name, text)
        assert type(r).__name__ in text, (name, text)
    long = ts.simulate(table1, {**SCENARIO, "horizon_s": 200.0})
    assert len(repr(long)) < 300


def test_an_all_none_column_is_float64_nan(results):
    # reference: Table's docstring (numeric columns float64, NaN where absent); no run of
    # this sweep loses control, so `loss_of_control_time_s` is absent in every row
    t = results["sweep"]
    col = t["loss_of_control_time_s"]
    assert col.dtype == np.float64 and np.isnan(col).all()
    assert t["class"].dtype == object and t["loss_of_control_condition"].dtype == object
    for name in t.columns:
        assert t[name].dtype in (np.float64, np.int64, object), name


def test_simulation_states_are_named_as_the_trajectory_csv(results, table1):
    # reference: results/scenario_example/trajectory.csv's header
    header = (RESULTS / "scenario_example" / "trajectory.csv").read_text().splitlines()[0].split(",")
    assert list(ts.Simulation.state_names) == header[1:8]
    pd = pytest.importorskip("pandas")
    r = ts.simulate(table1, CONFIGS / "scenario_example.toml")
    df = r.to_pandas()
    assert isinstance(df, pd.DataFrame) and list(df.columns) == header
    np.testing.assert_array_equal(df["theta_rad"].to_numpy(), r.theta)
    np.testing.assert_array_equal(df[list(r.state_names)].to_numpy(), r.states)
    np.testing.assert_array_equal(df["delta_rad"].to_numpy(), r.delta)


def test_to_pandas_of_tables(results):
    pytest.importorskip("pandas")
    t = results["sweep"]
    df = t.to_pandas()
    assert list(df.columns) == t.columns and len(df) == len(t)
    assert df["loss_of_control_time_s"].dtype == np.float64
    c = results["critical_speeds"].to_pandas()
    assert list(c.columns)[:2] == ["trailer_mass", "v_crit_mps"] and len(c) == 3


def test_to_pandas_without_pandas_says_what_to_install(results, monkeypatch):
    monkeypatch.setitem(sys.modules, "pandas", None)
    for r in (results["simulate"], results["sweep"], results["critical_speeds"]):
        with pytest.raises(ImportError, match="needs pandas, which is not installed: pip install pandas"):
            r.to_pandas()


# ---------------------------------------------------------------------------------------
# plot()


def _agg_axes():
    mpl = pytest.importorskip("matplotlib")
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure()
    FigureCanvasAgg(fig)
    return mpl, fig, fig.add_subplot()


@pytest.mark.parametrize(
    "name, xlabel, ylabel, min_lines",
    [
        ("bifurcation_diagram", "speed V [m/s]", "sway amplitude max |θ| [deg]", 4),
        ("simulate", "time t [s]", "angle [deg]", 2),
        ("lateral_stability", "speed V [m/s]", "damping ratio D [-]", 1),
        ("critical_speeds", "trailer_mass [kg]", "critical speed V_crit [m/s]", 1),
    ],
)
def test_plot_draws_labelled_axes_with_a_legend(results, name, xlabel, ylabel, min_lines):
    _, fig, ax = _agg_axes()
    assert results[name].plot(ax=ax) is ax
    fig.canvas.draw()
    assert (ax.get_xlabel(), ax.get_ylabel()) == (xlabel, ylabel)
    assert len(ax.get_lines()) >= min_lines
    drawn = [l for l in ax.get_lines() if np.isfinite(np.asarray(l.get_ydata(), dtype=float)).any()]
    assert drawn, name
    legend = ax.get_legend()
    assert legend is not None and len(legend.get_texts()) >= 1


def test_plot_of_the_charts_one_panel_per_delay(results):
    _, fig, _ = _agg_axes()
    charts = results["stability_chart"]
    axes = [fig.add_subplot(1, 2, i + 1) for i in range(2)]
    assert charts.plot(ax=axes) == axes
    fig.canvas.draw()
    for ax, ch in zip(axes, charts):
        assert (ax.get_xlabel(), ax.get_ylabel()) == ("speed V [m/s]", "gain D [s]")
        assert ax.get_title() == f"τ = {ch.tau_s:g} s"
        texts = [t.get_text() for t in ax.get_legend().get_texts()]
        assert texts[0] == "stable (no root with Re λ > 0)" and "boundary λ = ±iω" in texts
    nl = results["nonlinear_chart"][0]
    _, fig, ax = _agg_axes()
    nl.plot(ax=ax)
    fig.canvas.draw()
    assert (ax.get_xlabel(), ax.get_ylabel()) == ("speed V [m/s]", "gain D [s]")
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert any(l.startswith("Hopf curve") for l in labels)
    with pytest.raises(ValueError, match="ax: expected 2 axes, one per delay, got 1"):
        charts.plot(ax=[ax])


def test_plot_without_ax_makes_a_figure(results):
    mpl = pytest.importorskip("matplotlib")
    mpl.use("Agg")
    import matplotlib.pyplot as plt

    ax = results["bifurcation_diagram"].plot()
    assert ax.figure is not None and ax.get_xlabel() == "speed V [m/s]"
    axes = results["stability_chart"].plot()
    assert len(axes) == 2
    plt.close("all")


def test_plot_without_matplotlib_says_what_to_install(results, monkeypatch):
    monkeypatch.setitem(sys.modules, "matplotlib.pyplot", None)
    with pytest.raises(ImportError, match="plot\\(\\) needs matplotlib, which is not installed: pip install matplotlib"):
        results["simulate"].plot()


# ---------------------------------------------------------------------------------------
# critical_speed over one field's values


MASSES = np.linspace(100.0, 1600.0, 16)  # 100 kg: stable up to 100 m/s; the rest a crossing


def _assert_same(vector: ts.CriticalSpeeds, scalars: list) -> None:
    assert len(vector) == len(scalars)
    for i, s in enumerate(scalars):
        # bit for bit: every number of the scalar call, None as NaN
        assert vector[i] == s, i
        for k in ("v_crit_mps", "hopf_frequency_hz", "hopf_omega_rad_s", "stable_up_to_mps"):
            want = getattr(s, k)
            got = getattr(vector, k)[i]
            assert (math.isnan(got) and want is None) or got == want, (i, k, got, want)
        assert vector.reason[i] == s.reason


def test_over_an_array_is_the_scalar_call_bit_for_bit(table1):
    # reference: critical_speed(vehicle.replace(trailer_mass=m)) for each m
    c = ts.critical_speed(table1, trailer_mass=MASSES)
    assert isinstance(c, ts.CriticalSpeeds) and c.field == "trailer_mass" and c.unit == "kg"
    assert c.v_crit_mps.dtype == np.float64 and c.reason.dtype.kind == "U"
    _assert_same(c, [ts.critical_speed(table1.replace(trailer_mass=m)) for m in MASSES])
    assert c.reason[0] == "stable_up_to_max" and math.isnan(c.v_crit_mps[0])
    assert c.stable_up_to_mps[0] == 100.0
    # the values of Table I: the linear task's V_crit (results/linear/summary.json)
    i = int(np.argmin(abs(MASSES - 985.0)))
    at_table1 = ts.critical_speed(table1, trailer_mass=[985.0])
    assert at_table1.v_crit_mps[0] == json.loads((RESULTS / "linear" / "summary.json").read_text())["v_crit_mps"]
    assert c.v_crit_mps[i] > 0


def test_over_an_array_closed_loop_and_unstable_at_the_start(table1):
    fb = {"kind": "yaw_rate_feedback", "gain_s": 0.1, "delay_s": 0.2}
    cogs = [0.5, 1.0, 1.5]
    c = ts.critical_speed(table1, fb, trailer_cog=cogs)
    _assert_same(c, [ts.critical_speed(table1.replace(trailer_cog=x), fb) for x in cogs])
    u = ts.critical_speed(table1, v_min_mps=40.0, v_max_mps=50.0, trailer_mass=[1200.0, 1500.0])
    _assert_same(u, [ts.critical_speed(table1.replace(trailer_mass=m), v_min_mps=40.0, v_max_mps=50.0) for m in (1200.0, 1500.0)])
    assert list(u.reason) == ["unstable_at_min"] * 2 and np.isnan(u.stable_up_to_mps).all()


def test_over_an_array_is_the_same_on_any_number_of_threads(table1):
    before = ts.get_num_threads()
    try:
        ts.set_num_threads(1)
        one = ts.critical_speed(table1, trailer_mass=MASSES)
        ts.set_num_threads(2)
        two = ts.critical_speed(table1, trailer_mass=MASSES)
    finally:
        ts.set_num_threads(before)
    np.testing.assert_array_equal(one.v_crit_mps, two.v_crit_mps)
    np.testing.assert_array_equal(one.reason, two.reason)


def test_over_an_array_of_a_vehicle_with_variants():
    # a vehicle file with model variants: the field replaced as Vehicle.replace does
    v = ts.Vehicle.from_toml(CONFIGS / "vehicles" / "relaxation.toml")
    c = ts.critical_speed(v, trailer_mass=[900.0, 1100.0])
    _assert_same(c, [ts.critical_speed(v.replace(trailer_mass=m)) for m in (900.0, 1100.0)])


def test_one_value_and_no_values(table1):
    one = ts.critical_speed(table1, trailer_mass=1200.0)
    assert one == ts.critical_speed(table1.replace(trailer_mass=1200.0))
    empty = ts.critical_speed(table1, trailer_mass=np.array([]))
    assert len(empty) == 0 and empty.v_crit_mps.shape == (0,)
