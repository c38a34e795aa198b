"""critical_speed and roots against the CLI (`linear`, `fig4a` summaries; `roots`)."""

import math

import numpy as np
import pytest

import trailer_sway as ts
from conftest import cli_error, committed, xtask


def test_open_loop_critical_speed_is_the_linear_tasks(table1):
    # reference: results/linear/summary.json (configs/linear.toml: the same search
    # settings as the defaults); deterministic, so exact
    s = committed("linear")
    c = ts.critical_speed(table1)
    assert c.reason == "crossing"
    assert c.v_crit_mps == s["v_crit_mps"]
    assert c.hopf_frequency_hz == s["hopf_frequency_hz"]
    assert c.hopf_omega_rad_s == s["hopf_omega_rad_s"]
    assert c.stable_up_to_mps == c.v_crit_mps


def test_closed_loop_critical_speed_is_fig4as(table1):
    # reference: results/fig4a/summary.json, "v_crit_at_d_<D>_mps" per τ, searched from
    # the chart's first cell centre to the axis' top at as many speeds as cells, with
    # tolerance 1e-9 m/s (the ranges the task derived are in the summary); exact
    s = committed("fig4a")
    axis, gain = s["ranges"]["speed_mps"], s["ranges"]["gain_for_critical_speed_s"]
    v_lo = axis["min"] + 0.5 * (axis["max"] - axis["min"]) / axis["cells"]
    step = (axis["max"] - v_lo) / (axis["cells"] - 1)
    for entry in s["per_tau"]:
        c = ts.critical_speed(
            table1,
            {"kind": "yaw_rate_feedback", "gain_s": gain, "delay_s": entry["tau_s"]},
            v_min_mps=v_lo,
            v_max_mps=axis["max"],
            scan_step_mps=step,
            tolerance_mps=1e-9,
        )
        expected = entry[f"v_crit_at_d_{gain:g}_mps"]
        if expected is None:
            assert c.v_crit_mps is None and c.reason == "stable_up_to_max"
            assert c.stable_up_to_mps == axis["max"]
        else:
            assert c.v_crit_mps == expected, entry["tau_s"]
            # the crossing root is on the imaginary axis (independent: the roots there)
            r = ts.roots(table1, c.v_crit_mps, gain, entry["tau_s"], count=2)
            assert abs(r[0].real) < 1e-6
            assert math.isclose(c.hopf_omega_rad_s, abs(r[0].imag), rel_tol=1e-9)


def test_stable_up_to_the_maximum(table1):
    # below V_crit (34.75 m/s) straight running is stable: the outcome says so, and the
    # open-loop eigenvalues (the roots of eq. 13 at D = 0) have Re λ < 0 on the range
    c = ts.critical_speed(table1, v_max_mps=30.0)
    assert c.v_crit_mps is None and c.hopf_frequency_hz is None
    assert c.stable_up_to_mps == 30.0 and c.reason == "stable_up_to_max"
    for v in np.linspace(1.0, 30.0, 12):
        assert ts.roots(table1, v, 0.0, 0.0, count=4).real.max() < 0
    # a light trailer is stable up to the default maximum of 100 m/s
    light = table1.replace(trailer_mass=100.0, trailer_yaw_inertia=50.0)
    lc = ts.critical_speed(light)
    if lc.v_crit_mps is None:
        assert lc.stable_up_to_mps == 100.0
    else:  # then its V_crit lies above Table I's
        assert lc.v_crit_mps > 34.7
    # unstable at the lowest speed
    u = ts.critical_speed(table1, v_min_mps=40.0, v_max_mps=50.0)
    assert u.reason == "unstable_at_min" and u.stable_up_to_mps is None


def test_critical_speed_bad_input(table1):
    with pytest.raises(ValueError, match="v_min_mps"):
        ts.critical_speed(table1, v_min_mps=-1.0)
    with pytest.raises(ValueError, match="scan_step_mps"):
        ts.critical_speed(table1, scan_step_mps=1e-9)
    with pytest.raises(ValueError, match="delay"):
        ts.critical_speed(table1, {"kind": "yaw_rate_feedback", "gain_s": 0.1, "delay_s": -0.2})
    with pytest.raises(TypeError):
        ts.critical_speed(table1, {"kind": "yaw_rate_feedback", "gain_s": "x", "delay_s": 0.2})
    with pytest.raises(TypeError):
        ts.critical_speed("table1")


def _cli_roots(*args):
    out = xtask("roots", *args).stdout
    rows = [l.split() for l in out.splitlines() if l.strip() and not l.startswith("[")]
    return np.array([complex(float(a), float(b)) for a, b in rows])


@pytest.mark.parametrize("speed,gain,delay,count", [(35.0, 0.1, 0.2, 6), (35.0, 0.1, 0.2, 5), (20.0, -0.3, 0.4, 12)])
def test_roots_are_the_clis(table1, speed, gain, delay, count):
    # reference: `cargo xtask roots` stdout (shortest round-trip numbers): exact
    r = ts.roots(table1, speed, gain, delay, count=count)
    assert r.dtype == np.complex128
    cli = _cli_roots("--speed", speed, "--gain", gain, "--delay", delay, "--count", count)
    np.testing.assert_array_equal(r, cli)


def test_roots_bad_input_has_the_clis_problem_in_pythons_terms(table1):
    # reference: the message `cargo xtask roots … --check` prints, its option (`--speed`)
    # named as the Python argument (`speed`) and the call (`roots()`) as the source
    for flags, kwargs, argument in [
        (("--speed", "0", "--gain", "0.1", "--delay", "0.2"), dict(speed=0.0, gain=0.1, delay=0.2), "speed"),
        (("--speed", "35", "--gain", "0.1", "--delay=-0.2"), dict(speed=35.0, gain=0.1, delay=-0.2), "delay"),
        (("--speed", "35", "--gain", "0.1", "--delay", "0.2", "--count", "201"), dict(speed=35.0, gain=0.1, delay=0.2, count=201), "count"),
    ]:
        expected = cli_error("roots", *flags, "--check")
        assert expected.startswith(f"command line: `--{argument}`: ")
        with pytest.raises(ValueError) as e:
            ts.roots(table1, **kwargs)
        assert str(e.value) == expected.replace(f"command line: `--{argument}`", f"roots(): `{argument}`")
    with pytest.raises(ValueError, match="roots\\(\\): `gain`: expected a finite gain"):
        ts.roots(table1, 35.0, math.nan, 0.2)
    with pytest.raises(TypeError):
        ts.roots(table1, 35.0, 0.1, 0.2, count=2.5)
