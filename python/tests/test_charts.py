"""stability_chart, nonlinear_chart and bifurcation_diagram against the CLI tasks
(`fig4a`, `chart_nonlinear`, `fig3a`, `fig4b`) on the same inputs."""

import csv
import json

import numpy as np
import pytest

import trailer_sway as ts
from conftest import cli_error, committed, run_task


def _csv(path):
    with open(path) as f:
        rows = list(csv.reader(f))
    return rows[0], np.array([[float(x) if x else np.nan for x in r] for r in rows[1:]]).reshape(-1, len(rows[0]))


def _summary(results, task):
    s = json.loads((results / task / "summary.json").read_text())
    return s


SMALL_CHART = dict(
    delays=[0.0, 0.2],
    speed_range=(0.0, 60.0),
    gain_range=(-0.5, 0.5),
    speed_cells=30,
    gain_cells=20,
)


def _fig4a_config(delays, speed_range, gain_range, speed_cells, gain_cells):
    return ts.to_toml(
        {
            "speed": {"min_mps": speed_range[0], "max_mps": speed_range[1], "cells": speed_cells},
            "gain": {"min_s": gain_range[0], "max_s": gain_range[1], "cells": gain_cells},
            "delays_s": delays,
        }
    )


def test_stability_chart_is_fig4as(table1, tmp_path):
    # reference: `cargo xtask fig4a --config <the same grid>`: summary.json and the grid
    # and boundary CSVs; deterministic, so exact
    charts = ts.stability_chart(table1, **SMALL_CHART)
    results = run_task("fig4a", _fig4a_config(**SMALL_CHART), tmp_path)
    s = _summary(results, "fig4a")
    for k in ("open_loop_v_crit_mps", "per_tau", "grid_cells_per_tau"):
        assert charts.summary[k] == s[k], k
    assert len(charts) == 2
    for ch in charts:
        header, grid = _csv(results / "fig4a" / f"grid_tau_{ch.tau_s:g}.csv")
        assert header == ["v_mps", "d_s", "spectral_abscissa_per_s", "unstable_roots"]
        nv, nd = len(ch.v_mps), len(ch.d_s)
        assert ch.unstable_roots.shape == (nv, nd) == (30, 20)
        np.testing.assert_array_equal(grid[:, 0].reshape(nv, nd)[:, 0], ch.v_mps)
        np.testing.assert_array_equal(grid[:, 1].reshape(nv, nd)[0], ch.d_s)
        np.testing.assert_array_equal(grid[:, 2].reshape(nv, nd), ch.spectral_abscissa_per_s)
        np.testing.assert_array_equal(grid[:, 3].reshape(nv, nd), ch.unstable_roots)
        for kind, arr in (("dynamic", ch.dynamic_boundary), ("static", ch.static_boundary)):
            _, b = _csv(results / "fig4a" / f"{kind}_boundary_tau_{ch.tau_s:g}.csv")
            np.testing.assert_array_equal(b.reshape(-1, 4), arr)
        # independent of the CLI: the stable cells have no root with Re λ > 0
        st = ch.stable
        assert np.all(ch.spectral_abscissa_per_s[st & np.isfinite(ch.spectral_abscissa_per_s)] < 1e-9)


def test_stability_chart_limits_are_the_clis(table1, tmp_path):
    # reference: `cargo xtask fig4a --config FILE --check` on the same oversized grid
    big = dict(SMALL_CHART, speed_cells=200_000)
    f = tmp_path / "big.toml"
    f.write_text(_fig4a_config(**big))
    expected = cli_error("fig4a", "--config", f, "--check")
    with pytest.raises(ValueError) as e:
        ts.stability_chart(table1, **big)
    # the same problem, under the keyword argument that set the file's `speed.cells`
    assert str(e.value).split(": ", 2)[2] == expected.split(": ", 2)[2]
    assert "`speed.cells`" in expected and "`speed_cells`" in str(e.value)
    with pytest.raises(ValueError, match="`speed_cells`"):
        ts.stability_chart(table1, speed_cells=1)
    with pytest.raises(ValueError, match=r"`delays\[1\]`"):
        ts.stability_chart(table1, delays=[0.0, float("nan")], speed_cells=4, gain_cells=4)


SMALL_NONLINEAR = {
    "delays_s": [0.0],
    "summary_gains_s": [0.0, 0.1],
    "bistable_gain_s": 0.1,
    "chart": {
        "hopf_max_points": 60,
        "fold_max_points": 40,
        "criticality_samples": 2,
        "criticality_cycle_points": 2,
        "seed_gains_s": [0.1],
    },
    "regions": {"speed_cells": 10, "gain_cells": 6},
}


def test_nonlinear_chart_is_chart_nonlinears(table1, tmp_path):
    # reference: `cargo xtask chart_nonlinear --config <the same settings>`: the per-τ
    # summary and the curve CSVs; deterministic, so exact
    c = SMALL_NONLINEAR
    charts = ts.nonlinear_chart(
        table1,
        c["delays_s"],
        summary_gains_s=c["summary_gains_s"],
        bistable_gain_s=c["bistable_gain_s"],
        chart=c["chart"],
        regions=c["regions"],
    )
    results = run_task("chart_nonlinear", ts.to_toml(c), tmp_path)
    s = _summary(results, "chart_nonlinear")
    assert [ch.summary for ch in charts] == s["per_tau"]
    ch = charts[0]
    assert ch.hopf_curves, "no Hopf curve"
    for k, h in enumerate(ch.hopf_curves):
        _, rows = _csv(results / "chart_nonlinear" / f"hopf_tau_0_{k}.csv")
        got = np.column_stack([h["d_s"], h["v_mps"], h["omega_rad_s"], h["subcritical"]])
        np.testing.assert_array_equal(rows, got)
    for k, f in enumerate(ch.fold_curves):
        _, rows = _csv(results / "chart_nonlinear" / f"fold_cycles_tau_0_{k}.csv")
        got = np.column_stack([f["d_s"], f["v_mps"], f["period_s"], f["amplitude_deg"]])
        np.testing.assert_array_equal(rows, got)
    # independent: at D = 0 the Hopf curve passes through the open-loop V_crit (1e-6 m/s)
    vc = ts.critical_speed(table1).v_crit_mps
    at0 = [e for e in ch.summary["curves"] if e["d_s"] == 0.0][0]
    assert abs(at0["v_hopf_mps"] - vc) < 1e-6


def test_open_loop_diagram_is_fig3as(table1):
    # reference: results/fig3a/summary.json (configs/fig3a.toml's [diagram] = the
    # defaults); deterministic, so exact: every diagram field of the summary
    s = committed("fig3a")
    d = ts.bifurcation_diagram(table1)
    assert d.summary and d.reason is None
    for k, v in d.summary.items():
        assert v == s[k], k
    for k in ("hopf_v_mps", "fold_v_mps", "fold_amplitude_deg", "criticality", "hopf_omega_rad_s",
              "fold_period_s", "cycle_points"):
        assert getattr(d, k) == s[k], k
    assert list(d.bistable_range_mps) == s["bistable_range_mps"]
    # the equilibria lose stability at the Hopf point, the cycle branch starts there
    eq = d.equilibria
    assert np.all(eq["stable"][eq["v_mps"] < d.hopf_v_mps - 1e-6])
    assert not np.any(eq["stable"][eq["v_mps"] > d.hopf_v_mps + 1e-6])
    assert abs(d.cycles["v_mps"][0] - d.hopf_v_mps) < 0.1
    assert len(d.cycles["v_mps"]) == d.cycle_points
    # the Hopf point is the linear V_crit (independent: eigenvalues, 1e-6 m/s)
    assert abs(d.hopf_v_mps - ts.critical_speed(table1).v_crit_mps) < 1e-6


def test_closed_loop_diagram_is_fig4bs(table1, tmp_path):
    # reference: `cargo xtask fig4b` on one pair, τ = 0.1 s, D = 0.1 s, with a small
    # continuation (the shipped one takes a minute); its "pairs" entry, exact
    cont = {"intervals": 12, "degree": 3, "max_cycle_points": 60}
    cfg = {"pairs": [{"delay_s": 0.1, "gain_s": 0.1}], "continuation": cont}
    pair = _summary(run_task("fig4b", ts.to_toml(cfg), tmp_path), "fig4b")["pairs"][0]
    d = ts.bifurcation_diagram(table1, {"kind": "yaw_rate_feedback", "gain_s": 0.1, "delay_s": 0.1}, continuation=cont)
    assert d.summary == pair
    assert d.cycle_points == pair["cycle_points"] == len(d.cycles["v_mps"])
    assert d.hopf_v_mps == pair["hopf_v_mps"] and d.criticality == pair["criticality"]
    # independent of the CLI: the Hopf point is the closed loop's linear critical speed
    # (the exact root count along V; 1e-6 m/s)
    c = ts.critical_speed(table1, {"kind": "yaw_rate_feedback", "gain_s": 0.1, "delay_s": 0.1})
    assert abs(d.hopf_v_mps - c.v_crit_mps) < 1e-6


def test_diagram_bad_options(table1):
    with pytest.raises(ValueError, match="continuation.intervals"):
        ts.bifurcation_diagram(table1, continuation={"intervals": 1})
    with pytest.raises(ValueError, match="unknown field `mesh`"):
        ts.bifurcation_diagram(table1, continuation={"mesh": 3})
