"""Vehicles with model variants (configs/vehicles/*.toml: tyre relaxation, axle lists, tyre
laws, hitch torque): every function that takes any model against the CLI run with
`--vehicle FILE` on the same inputs (small resolutions), and what a variant vehicle's
fields do."""

import csv
import json
import math
import pickle

import numpy as np
import pytest

import trailer_sway as ts
from conftest import CONFIGS, cli_error, run_task, xtask

RELAXATION = CONFIGS / "vehicles" / "relaxation.toml"
TANDEM = CONFIGS / "vehicles" / "tandem.toml"


@pytest.fixture(scope="module")
def relaxed():
    return ts.Vehicle.from_toml(RELAXATION)


def _summary(results, task):
    return json.loads((results / task / "summary.json").read_text())


def _csv(path):
    with open(path) as f:
        rows = list(csv.reader(f))
    return rows[0], np.array([[float(x) if x else np.nan for x in r] for r in rows[1:]]).reshape(-1, len(rows[0]))


def test_variant_vehicle_fields(relaxed, tmp_path):
    assert not relaxed.is_paper_form and relaxed.states == 7
    assert relaxed.variant_key == "tractor.front_relaxation_length_m"
    assert ts.Vehicle.table1().is_paper_form and ts.Vehicle.table1().states == 4
    # the paper's keys its file has read and change as in the file
    assert relaxed.trailer_mass == 985.0 and relaxed.tractor_front_axle == 5.15
    heavy = relaxed.replace(trailer_mass=1400.0)
    assert heavy.trailer_mass == 1400.0 and heavy.variant_key == relaxed.variant_key
    assert heavy != relaxed and relaxed.replace(trailer_mass=985.0) == relaxed
    # the file round-trips (to_toml, from_toml_str, pickle)
    assert ts.Vehicle.from_toml_str(relaxed.to_toml()) == relaxed
    assert pickle.loads(pickle.dumps(relaxed)) == relaxed
    with pytest.raises(ValueError, match="model variants"):
        relaxed.to_dict()
    with pytest.raises(ValueError, match=r"`trailer.mass`: -1 is invalid"):
        relaxed.replace(trailer_mass=-1.0)
    # an axle key of a unit whose axles are a list is the group's: its mean position
    # (reference: VehicleSpec::with_parameter, the sweeps' reading of the same key)
    tandem = ts.Vehicle.from_toml(TANDEM)
    assert tandem.trailer_axle == pytest.approx(2.8, abs=1e-12)  # axles at 2.4 and 3.2 m
    moved = tandem.replace(trailer_axle=3.2)
    assert moved.trailer_axle == pytest.approx(3.2, abs=1e-12) and moved != tandem
    assert moved.variant_key == tandem.variant_key


def test_invalid_variant_file_raises_the_cli_message(tmp_path):
    # reference: `cargo xtask linear --vehicle FILE --check` on the same file
    f = tmp_path / "bad.toml"
    f.write_text(RELAXATION.read_text().replace("relaxation_length_m = 0.3 ", "relaxation_length_m = -0.3 ", 1))
    expected = cli_error("linear", "--vehicle", f, "--check")
    with pytest.raises(ValueError) as e:
        ts.Vehicle.from_toml(f)
    assert str(e.value) == expected


def test_critical_speed_and_roots(relaxed, tmp_path):
    # reference: `cargo xtask linear --vehicle relaxation.toml` (summary.json) and
    # `cargo xtask roots --vehicle …` (stdout); exact
    results = run_task("linear", None, tmp_path, "--vehicle", RELAXATION)
    s = _summary(results, "linear")
    c = ts.critical_speed(relaxed)
    assert c.reason == "crossing" and c.v_crit_mps == s["v_crit_mps"]
    assert c.hopf_omega_rad_s == s["hopf_omega_rad_s"]
    # relaxation lowers V_crit (32.58 m/s, the file's comment; independent of the CLI)
    assert abs(c.v_crit_mps - 32.58) < 0.01
    out = xtask("roots", "--vehicle", RELAXATION, "--speed", 30, "--gain", 0.1, "--delay", 0.2, "--count", 5).stdout
    rows = [l.split() for l in out.splitlines() if l.strip() and not l.startswith("[")]
    cli = np.array([complex(float(a), float(b)) for a, b in rows])
    np.testing.assert_array_equal(ts.roots(relaxed, 30.0, 0.1, 0.2, count=5), cli)
    # the closed loop at D = 0 is the open loop: its crossing root is V_crit's (1e-6 m/s)
    cl = ts.critical_speed(relaxed, {"kind": "yaw_rate_feedback", "gain_s": 0.0, "delay_s": 0.1})
    assert abs(cl.v_crit_mps - c.v_crit_mps) < 1e-6


SCENARIO = {
    "name": "py_variant",
    "horizon_s": 10.0,
    "output_step_s": 0.05,
    "speed": {"kind": "constant", "speed_mps": 30.0},
    "initial": {"kind": "state", "theta0_deg": 4.0},
}


def test_simulate(relaxed, tmp_path):
    # reference: `cargo xtask simulate FILE --vehicle relaxation.toml`: summary.json and
    # trajectory.csv; exact
    f = tmp_path / "s.toml"
    f.write_text(ts.to_toml(SCENARIO))
    xtask("simulate", f, "--vehicle", RELAXATION, "--results", tmp_path / "results")
    out = tmp_path / "results" / "py_variant"
    s = json.loads((out / "summary.json").read_text())
    r = ts.simulate(relaxed, SCENARIO)
    for k, v in r.metrics.items():
        assert v == s[k], k
    assert (r.accepted_steps, r.rejected_steps) == (s["accepted_steps"], s["rejected_steps"])
    _, rows = _csv(out / "trajectory.csv")
    np.testing.assert_array_equal(r.t, rows[:, 0])
    np.testing.assert_array_equal(r.states, rows[:, 1:8])
    # a different model from Table I's (independent: the paper's model on the same scenario)
    p = ts.simulate(ts.Vehicle.table1(), SCENARIO)
    assert not np.array_equal(p.theta, r.theta)


SMALL_CONTINUATION = {"intervals": 12, "degree": 3, "max_cycle_points": 40, "max_step": 0.5, "beyond_hopf": 0.1}


def test_bifurcation_diagram(relaxed, tmp_path):
    # reference: `cargo xtask fig3a` (the diagram) with `--vehicle relaxation.toml` on the
    # same small settings; exact (the closed loop goes through fig4b's one function for any
    # plant: test_charts.py compares it on Table I)
    fig3a = {
        "panels": {"speed_mps": 30.0, "theta0_deg": [2.0], "horizon_s": 2.0},
        "diagram": {"continuation": SMALL_CONTINUATION, "stable_speeds_mps": [34.0], "unstable_speeds_mps": []},
    }
    s = _summary(run_task("fig3a", ts.to_toml(fig3a), tmp_path, "--vehicle", RELAXATION), "fig3a")
    d = ts.bifurcation_diagram(relaxed, continuation=SMALL_CONTINUATION, stable_speeds_mps=[34.0], unstable_speeds_mps=[])
    for k, v in d.summary.items():
        assert s[k] == v, k
    assert d.hopf_v_mps == s["hopf_v_mps"] and len(d.cycles["v_mps"]) == s["cycle_points"]
    _, eq = _csv(tmp_path / "results" / "fig3a" / "equilibria.csv")
    np.testing.assert_array_equal(eq[:, 0], d.equilibria["v_mps"])
    np.testing.assert_array_equal(eq[:, 2], d.equilibria["max_re_lambda_per_s"])
    # the Hopf point is the linear V_crit (independent: eigenvalues; 1e-6 m/s)
    assert abs(d.hopf_v_mps - ts.critical_speed(relaxed).v_crit_mps) < 1e-6



def test_stability_chart(relaxed, tmp_path):
    # reference: `cargo xtask fig4a --vehicle relaxation.toml` on the same small grid; exact
    grid = dict(delays=[0.1], speed_range=(0.0, 60.0), gain_range=(-0.5, 0.5), speed_cells=12, gain_cells=8)
    cfg = {
        "speed": {"min_mps": 0.0, "max_mps": 60.0, "cells": 12},
        "gain": {"min_s": -0.5, "max_s": 0.5, "cells": 8},
        "delays_s": [0.1],
    }
    s = _summary(run_task("fig4a", ts.to_toml(cfg), tmp_path, "--vehicle", RELAXATION), "fig4a")
    charts = ts.stability_chart(relaxed, **grid)
    for k in ("open_loop_v_crit_mps", "per_tau", "grid_cells_per_tau"):
        assert charts.summary[k] == s[k], k
    _, g = _csv(tmp_path / "results" / "fig4a" / "grid_tau_0.1.csv")
    np.testing.assert_array_equal(g[:, 3].reshape(12, 8), charts[0].unstable_roots)


def test_nonlinear_chart(relaxed, tmp_path):
    # reference: `cargo xtask chart_nonlinear --vehicle relaxation.toml`, small; exact
    cycles = {k: v for k, v in SMALL_CONTINUATION.items() if k != "beyond_hopf"}
    c = {
        "delays_s": [0.0],
        "summary_gains_s": [0.0],
        "bistable_gain_s": 0.0,
        "chart": {
            "hopf_max_points": 12,
            "fold_max_points": 6,
            "criticality_samples": 2,
            "criticality_cycle_points": 2,
            "seed_gains_s": [0.0],
            "cycles": cycles,
        },
        "regions": {"speed_cells": 4, "gain_cells": 3},
    }
    s = _summary(run_task("chart_nonlinear", ts.to_toml(c), tmp_path, "--vehicle", RELAXATION), "chart_nonlinear")
    charts = ts.nonlinear_chart(
        relaxed, c["delays_s"], summary_gains_s=c["summary_gains_s"], bistable_gain_s=c["bistable_gain_s"], chart=c["chart"], regions=c["regions"]
    )
    assert [ch.summary for ch in charts] == s["per_tau"]


def test_sweep(relaxed, tmp_path):
    # reference: `cargo xtask sweep FILE --vehicle relaxation.toml`: sweep.csv; exact
    study = {
        "name": "py_variant_sweep",
        "axes": [{"parameter": "speed_mps", "min": 28.0, "max": 36.0, "points": 3}],
        "base": {"horizon_s": 5.0, "speed": {"kind": "constant", "speed_mps": 30.0},
                 "initial": {"kind": "state", "theta0_deg": 3.0}},
    }
    f = tmp_path / "s.toml"
    f.write_text(ts.to_toml(study))
    xtask("sweep", f, "--vehicle", RELAXATION, "--results", tmp_path / "results")
    t = ts.sweep(study, relaxed)
    with open(tmp_path / "results" / "py_variant_sweep" / "sweep.csv") as fh:
        rows = list(csv.reader(fh))
    assert t.columns == rows[0] and len(t) == len(rows) - 1
    for j, name in enumerate(rows[0]):
        col = t[name]
        cells = [r[j] for r in rows[1:]]
        if col.dtype == object:
            assert ["" if x is None else str(x) for x in col] == cells, name
        else:
            want = np.array([float(x) if x else np.nan for x in cells])
            np.testing.assert_array_equal(col.astype(float), want, err_msg=name)


# ---------------------------------------------------------------------------------------
# outcomes, not exceptions: a vehicle stable at every speed (the trailer's centre of gravity
# 1.3 m ahead of its axle: V_crit above the 100 m/s maximum)

@pytest.fixture(scope="module")
def stable_vehicle():
    return ts.Vehicle.table1().replace(trailer_cog=1.5)


def test_stable_vehicle_outcomes(stable_vehicle, tmp_path):
    # reference: `cargo xtask linear` and `cargo xtask fig3a` with `--vehicle` that file:
    # their summaries say "stable up to" with a reason instead of failing
    f = tmp_path / "stable.toml"
    f.write_text(stable_vehicle.to_toml())
    lin = _summary(run_task("linear", None, tmp_path, "--vehicle", f), "linear")
    c = ts.critical_speed(stable_vehicle)
    assert lin["v_crit_mps"] is None and c.v_crit_mps is None
    assert c.reason == "stable_up_to_max" and c.stable_up_to_mps == lin["stable_up_to_mps"] == 100.0
    assert c.message.startswith("straight running is stable at every speed up to 100 m/s")
    fig3a = {"panels": {"speed_mps": 30.0, "theta0_deg": [2.0], "horizon_s": 1.0}, "diagram": {}}
    s = _summary(run_task("fig3a", ts.to_toml(fig3a), tmp_path, "--vehicle", f), "fig3a")
    d = ts.bifurcation_diagram(stable_vehicle)
    assert s["hopf_v_mps"] is None and d.hopf_v_mps is None and d.fold_v_mps is None
    for k, v in d.summary.items():
        assert s[k] == v, k
    assert d.reason == s["hopf_reason"] and d.stable_up_to_mps == s["stable_up_to_mps"]
    assert len(d.equilibria["v_mps"]) == 0 and len(d.cycles["v_mps"]) == 0
    # the closed loop: fig4b's entry with its reason
    cl = ts.bifurcation_diagram(stable_vehicle, {"kind": "yaw_rate_feedback", "gain_s": 0.0, "delay_s": 0.0})
    assert cl.hopf_v_mps is None and cl.reason and cl.summary["stable_up_to_mps"] == cl.stable_up_to_mps


def test_stable_vehicle_nonlinear_chart(stable_vehicle, tmp_path):
    # reference: `cargo xtask chart_nonlinear --vehicle` that file: no Hopf curve, said in
    # the summary; Python returns the same entry with its reasons
    c = {"delays_s": [0.0], "chart": {"hopf_max_points": 10, "fold_max_points": 4}, "regions": {"speed_cells": 4, "gain_cells": 3}}
    f = tmp_path / "stable.toml"
    f.write_text(stable_vehicle.to_toml())
    s = _summary(run_task("chart_nonlinear", ts.to_toml(c), tmp_path, "--vehicle", f), "chart_nonlinear")
    charts = ts.nonlinear_chart(stable_vehicle, [0.0], chart=c["chart"], regions=c["regions"])
    assert [ch.summary for ch in charts] == s["per_tau"]
    ch = charts[0]
    assert not ch.hopf_curves and ch.hopf_reason and ch.hopf_reason == s["per_tau"][0].get("hopf_reason")
