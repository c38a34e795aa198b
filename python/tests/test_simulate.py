"""simulate against `cargo xtask simulate` (the committed scenario_example results)."""

import csv
import math

import numpy as np
import pytest

import trailer_sway as ts
from conftest import CONFIGS, RESULTS, cli_error, committed

EXAMPLE = CONFIGS / "scenario_example.toml"


def _trajectory_csv():
    with open(RESULTS / "scenario_example" / "trajectory.csv") as f:
        rows = list(csv.reader(f))
    return rows[0], np.array([[float(x) for x in r] for r in rows[1:]])


def test_scenario_example_is_the_clis(table1):
    # reference: results/scenario_example/{summary.json, trajectory.csv} of
    # `cargo xtask simulate configs/scenario_example.toml`; deterministic, so exact
    s = committed("scenario_example")
    r = ts.simulate(table1, EXAMPLE)
    for k, v in r.metrics.items():
        assert v == s[k], k
    assert r.sway_class == s["class"]
    assert (r.action_s, r.t_end_s) == (s["action_s"], s["t_end_s"])
    assert (r.accepted_steps, r.rejected_steps) == (s["accepted_steps"], s["rejected_steps"])
    header, rows = _trajectory_csv()
    assert header[0] == "t_s" and header[4] == "theta_rad"
    np.testing.assert_array_equal(r.t, rows[:, 0])
    np.testing.assert_array_equal(r.states, rows[:, 1:8])
    np.testing.assert_array_equal(r.theta, rows[:, 4])
    np.testing.assert_array_equal(r.speed, rows[:, 8])
    np.testing.assert_array_equal(r.delta, rows[:, 9])
    assert r.states.shape == (len(r.t), 7)


def test_a_dict_is_the_file(table1):
    # the scenario file as a dict (the TOML's shape) gives the same run, bit for bit
    import tomllib

    cfg = tomllib.loads(EXAMPLE.read_text())
    a = ts.simulate(table1, EXAMPLE, trajectory=False)
    b = ts.simulate(table1, cfg, trajectory=False)
    assert a.metrics == b.metrics
    assert (a.t_end_s, a.accepted_steps, a.rejected_steps) == (b.t_end_s, b.accepted_steps, b.rejected_steps)
    assert len(b.t) == 0 and b.states.shape == (0, 7)


def test_open_loop_decay_and_sway(table1):
    # reference: the time panels of `cargo xtask fig3a` (results/fig3a/summary.json, the
    # bistable range): at ≈ 33 m/s a 2° perturbation dies out, an 8° one grows into sway;
    # same run at the panel's resolved speed (a fraction of the diagram's bistable range, so
    # it can sit an ulp off 33), so the metrics are equal exactly
    s = committed("fig3a")["time_panels"]
    for theta0 in (2.0, 8.0):
        entry = s[f"theta0_{theta0:g}deg"]
        r = ts.simulate(
            table1,
            {
                "horizon_s": 60.0,
                "output_step_s": 0.02,
                "speed": {"kind": "constant", "speed_mps": entry["speed_mps"]},
                "initial": {"kind": "state", "theta0_deg": theta0},
                "solver": {"rtol": 1e-8, "atol": 1e-10},
            },
        )
        for k in r.metrics:
            assert r.metrics[k] == entry[k], (theta0, k)
        assert math.isclose(np.degrees(r.theta[0]), theta0, rel_tol=1e-12)
    assert r.sway_class == "sustained_sway"


def _bad(tmp_path, text):
    f = tmp_path / "bad.toml"
    f.write_text(text)
    return f


@pytest.mark.parametrize(
    "replace",
    [
        ('theta0_rad = 0.1', 'theta0_rad = nan'),
        ('horizon_s = 40.0', 'horizon_s = 1e9'),
        ('output_step_s = 0.02', 'output_step_s = 1e-7'),
        ('rtol = 1e-8', 'rtol = -1.0'),
        ('final_window_s = 5.0', 'final_window_s = "long"'),
        ('guard = "stop"', 'guard = "stop"\nunknown_key = 1'),
    ],
)
def test_bad_scenarios_raise_the_cli_message(table1, tmp_path, replace):
    # reference: `cargo xtask simulate FILE` on the same file (a run: some checks need
    # the speeds resolved for the vehicle, which `--check` does not do)
    text = EXAMPLE.read_text()
    assert replace[0] in text
    f = _bad(tmp_path, text.replace(replace[0], replace[1], 1))
    expected = cli_error("simulate", f, "--results", tmp_path / "results")
    with pytest.raises(ValueError) as e:
        ts.simulate(table1, f)
    assert str(e.value) == expected


def test_bad_dicts(table1):
    base = {"speed": {"kind": "constant", "speed_mps": 33.0}, "initial": {"kind": "state", "theta0_deg": 2.0}}
    with pytest.raises(ValueError, match=r"simulate\(scenario\): `initial.theta0_deg`: expected \|θ\(0\)\| < 90 deg, got NaN"):
        ts.simulate(table1, {**base, "initial": {"kind": "state", "theta0_deg": math.nan}})
    with pytest.raises(ValueError, match="horizon_s"):
        ts.simulate(table1, {**base, "horizon_s": -1.0})
    with pytest.raises(ValueError, match="unknown field `speeed`"):
        ts.simulate(table1, {**base, "speeed": 1})
    with pytest.raises(TypeError, match="unsupported type"):
        ts.simulate(table1, {**base, "horizon_s": object()})
    with pytest.raises(TypeError):
        ts.simulate(table1, 42)
