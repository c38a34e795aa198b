"""lateral_stability and analyse_recording against the CLI (`cargo xtask
lateral_stability`, with and without `--recording`) on the same inputs."""

import json

import numpy as np
import pytest

import trailer_sway as ts
from conftest import committed, run_task, xtask

SMALL = dict(speeds=[20.0, 25.0, 30.0], amplitudes_deg=[1.0, 3.0], horizon_s=20.0)


def test_lateral_stability_is_the_tasks(table1, tmp_path):
    # reference: `cargo xtask lateral_stability --config <the same keys>`: summary.json,
    # deterministic, so exact
    r = ts.lateral_stability(table1, **SMALL)
    results = run_task("lateral_stability", ts.to_toml(SMALL), tmp_path)
    s = json.loads((results / "lateral_stability" / "summary.json").read_text())
    assert r.summary["speeds"] == s["speeds"]
    for k in ("test_critical_speed_mps", "v_crit_mps", "v_fold_mps", "overestimate_mps", "fit"):
        assert r.summary[k] == s[k], k
    np.testing.assert_array_equal(r.speed_mps, [row["speed_mps"] for row in s["speeds"]])
    np.testing.assert_array_equal(r.damping_ratio, [row["damping_ratio"] for row in s["speeds"]])
    # below V_fold the amplitudes are null in the task and NaN here, with the reason
    assert r.zero_damping_amplitude_deg.dtype == np.float64
    assert np.isnan(r.zero_damping_amplitude_deg).all()
    assert all("below V_fold" in why for why in r.reasons)
    assert len(r.local_damping) == 3 and r.local_damping[0].shape[1] == 2
    assert r.trace is not None and r.trace["values"].shape[1] == 2
    assert "test critical speed" in repr(r) and len(repr(r)) < 200


def test_lateral_stability_of_the_shipped_config_is_the_committed_one(table1):
    # reference: results/lateral_stability/summary.json as committed (the default config)
    r = ts.lateral_stability(table1)
    c = committed("lateral_stability")
    assert r.test_critical_speed_mps == c["test_critical_speed_mps"]
    assert r.summary["speeds"] == c["speeds"]


def _pulse_run(d, speed=25.0, step=0.02, seconds=30.0):
    """A recorded run whose sway after a 0.4 s impulse is e^{σt} sin(ωt) with damping
    ratio d exactly (ω = 2π·0.6 rad/s)."""
    t = np.arange(0.0, seconds, step)
    omega = 2 * np.pi * 0.6
    sigma = -d * omega / np.sqrt(1 - d * d)
    steering = np.where((t > 1.0) & (t < 1.4), np.sin(np.pi * (t - 1.0) / 0.4), 0.0)
    s = t - 1.4
    theta = np.where(s > 0, 0.02 * np.exp(sigma * s) * np.sin(omega * np.maximum(s, 0)), 0.0)
    return t, {"steering_angle": steering, "hitch_angle": theta, "speed": np.full_like(t, speed)}


def test_analyse_recording_reads_a_known_damping_and_matches_the_cli(tmp_path):
    # reference: the damping ratio the synthetic run was made with (1e-3), and the CLI's
    # --recording analysis of the same samples written as CSV (same numbers to 1e-12:
    # the CSV's decimal text rounds the samples)
    t, signals = _pulse_run(0.08)
    r = ts.analyse_recording(t, signals)
    assert abs(r.damping_ratio - 0.08) < 1e-3
    assert abs(r.frequency_hz - 0.6) < 0.006
    assert r.signal == "hitch_angle" and r.speed_mps == pytest.approx(25.0)
    assert r.peaks_used.shape == (5, 2)
    csv = tmp_path / "run.csv"
    rows = np.column_stack([t, signals["speed"], np.degrees(signals["steering_angle"]), np.degrees(signals["hitch_angle"])])
    np.savetxt(csv, rows, delimiter=",", header="time [s],speed [m/s],steering_angle [deg],hitch_angle [deg]", comments="", fmt="%.17g")
    out = tmp_path / "out"
    xtask("lateral_stability", "--results", out, "--recording", csv)
    s = json.loads((out / "lateral_stability_recordings" / "summary.json").read_text())
    row = s["recordings"][0]
    assert row["damping_ratio"] == pytest.approx(r.damping_ratio, abs=1e-12)
    assert row["frequency_hz"] == pytest.approx(r.frequency_hz, rel=1e-12)


def test_analyse_recording_reads_the_rearmost_articulation_of_a_combination():
    # reference: the damping ratio the synthetic run was made with; the rearmost coupling's
    # column (the CLI's `rearmost_articulation_angle`) reads like the hitch angle, and is
    # picked by name when both are given
    t, signals = _pulse_run(0.08)
    rear = {"steering_angle": signals["steering_angle"], "rearmost_articulation_angle": signals["hitch_angle"]}
    r = ts.analyse_recording(t, rear)
    assert r.signal == "rearmost_articulation_angle"
    assert abs(r.damping_ratio - 0.08) < 1e-3
    _, faster = _pulse_run(0.1)
    both = {**signals, "rearmost_articulation_angle": faster["hitch_angle"]}
    assert ts.analyse_recording(t, both).signal == "hitch_angle"
    r = ts.analyse_recording(t, both, signal="rearmost_articulation_angle")
    assert abs(r.damping_ratio - 0.1) < 1e-3


@pytest.mark.parametrize(
    "mutate, error, text",
    [
        (lambda t, s: (t, {**s, "hitch_angle": np.where(np.arange(len(t)) == 7, np.nan, s["hitch_angle"])}), ValueError, "row 7: signals['hitch_angle'] is not a finite number"),
        (lambda t, s: (np.where(np.arange(len(t)) == 9, 0.0, t), s), ValueError, "row 9: t does not increase"),
        (lambda t, s: (t, {k: v for k, v in s.items() if k != "steering_angle"}), ValueError, "missing 'steering_angle'"),
        (lambda t, s: (t, {"steering_angle": s["steering_angle"]}), ValueError, "at least one of"),
        (lambda t, s: (t, {**s, "theta": s["hitch_angle"]}), ValueError, "unknown key"),
        (lambda t, s: (t, {**s, "steering_angle": np.zeros_like(t)}), ValueError, "no steering impulse"),
        (lambda t, s: (t[::5], {k: v[::5] for k, v in s.items()}), ValueError, "20 Hz"),
        (lambda t, s: (t[:200], {k: v[:200] for k, v in s.items()}), ValueError, "too few peaks"),
        (lambda t, s: (t, {**s, "hitch_angle": s["hitch_angle"][:-1]}), ValueError, "samples, t has"),
        (lambda t, s: ("0.1, 0.2", s), TypeError, "got a string"),
        (lambda t, s: (t, list(s.values())), TypeError, "expected a dict"),
    ],
)
def test_bad_recordings_raise_in_pythons_terms(mutate, error, text):
    t, s = mutate(*_pulse_run(0.08))
    with pytest.raises(error, match=None) as e:
        ts.analyse_recording(t, s)
    assert text in str(e.value), str(e.value)
