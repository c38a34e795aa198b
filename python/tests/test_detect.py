"""detect: recorded signals replayed through the sway detectors of `sway-detect`."""

import numpy as np
import pytest

import trailer_sway as ts


def damped_sine(t, amplitude, frequency_hz, zeta):
    """amplitude · e^{σt} sin(ω_d t): the response of one mode of damping ratio ζ."""
    w = 2 * np.pi * frequency_hz
    sigma = -zeta * w / np.sqrt(1 - zeta * zeta)
    return amplitude * np.exp(sigma * t) * np.sin(w * t)


def test_the_estimator_recovers_the_damping_of_a_clean_damped_sine():
    # reference: a damped sinusoid satisfies the estimator's autoregressive model exactly,
    # so once the start is forgotten (25 s ≫ its 4 s memory) the estimate is exact to 1e-3
    # (the crate's own test `noise_free_estimates_converge_to_the_exact_damping`)
    t = np.arange(0, 25.0, 0.01)
    for zeta in (0.05, -0.03):
        r = ts.detect(
            t,
            {"yaw_rate": damped_sine(t, 0.05, 0.6, zeta)},
            detectors=["damping_estimator"],
            options={"damping_estimator": {"amplitude_floor": 0.0}},
        )
        d = r.detectors["damping_estimator"]
        assert abs(d.damping_ratio[-1] - zeta) < 1e-3, (zeta, d.damping_ratio[-1])
        assert abs(d.frequency_hz[-1] - 0.6) < 1e-3
        assert d.status == ["ok"] * len(t)
        assert d.damping_ratio.dtype == np.float64


def test_growing_sway_is_flagged_and_a_decaying_disturbance_is_not():
    # reference: the counter's rule. A sine at 0.7 Hz of 0.05 rad/s (2.5 × its threshold)
    # from t = 0: a half-oscillation counts once its peak passes the threshold, so the
    # third counts early in the third half-wave, which starts at 1.0 period; with the
    # band-pass's lag (< half a period) the first flag lies in [1.0, 1.5] periods. A
    # ζ = 0.3 decay from 0.03 rad/s falls below 0.02 rad/s within its first
    # period: never three half-oscillations, and strongly damped for the estimator.
    t = np.arange(0, 30.0, 0.01)
    period = 1 / 0.7
    growing = ts.detect(t, {"yaw_rate": damped_sine(t, 0.05, 0.7, 0.0)})
    first = growing.detectors["oscillation_counter"].first_flag_s
    assert first is not None and 1.0 * period <= first <= 1.5 * period, first
    decaying = ts.detect(t, {"yaw_rate": damped_sine(t, 0.03, 0.7, 0.3)})
    for name, d in decaying.detectors.items():
        assert d.first_flag_s is None, (name, d.first_flag_s)
        assert not d.flag.any()
    # every detector runs, in DETECTORS' order, and flags exactly where score ≥ threshold
    assert list(growing.detectors) == list(ts.DETECTORS)
    for d in growing.detectors.values():
        np.testing.assert_array_equal(d.flag, d.score >= d.threshold)
    assert "first flags" in repr(growing) and len(repr(growing)) < 200


def test_the_sample_rate_is_the_recordings():
    # reference: the same signal at 50 Hz and at 100 Hz is the same sway: the counter's
    # first flag agrees to a few samples (the band-pass is designed for each rate)
    for step in (0.01, 0.02):
        t = np.arange(0, 20.0, step)
        r = ts.detect(t, {"yaw_rate": damped_sine(t, 0.05, 0.7, 0.0)}, detectors=["oscillation_counter"])
        d = r.detectors["oscillation_counter"]
        assert d.options["sample_rate_hz"] == pytest.approx(1 / step)
        if step == 0.01:
            at_100 = d.first_flag_s
        else:
            assert abs(d.first_flag_s - at_100) <= 0.1, (d.first_flag_s, at_100)


def test_nan_samples_and_gaps_are_reported_and_survived():
    # reference: the crate's input rules: a NaN sample is ignored ("invalid"), a step of
    # more than 1.5 periods since the last used sample restarts the detector ("gap"); the
    # sway is still flagged after
    t = np.arange(0, 30.0, 0.01)
    y = damped_sine(t, 0.05, 0.7, 0.0)
    y[100] = np.nan
    keep = np.ones(len(t), dtype=bool)
    keep[200:210] = False  # ten lost frames
    r = ts.detect(t[keep], {"yaw_rate": y[keep]}, detectors=["oscillation_counter", "damping_estimator"])
    for d in r.detectors.values():
        assert d.status[100] == "invalid"
        # the invalid sample is a lost frame for the next (a step of 2 periods)
        assert d.status[101] == "gap" and d.status[200] == "gap"
        assert d.status.count("ok") == keep.sum() - 3
        assert d.first_flag_s is not None


def test_without_the_signal_it_reads_a_detector_never_flags():
    # the detectors read the yaw rate by default: a recording with only the lateral
    # acceleration is "not measured" for them, every sample invalid
    t = np.arange(0, 5.0, 0.01)
    r = ts.detect(t, {"lateral_acceleration": np.sin(t)})
    for d in r.detectors.values():
        assert set(d.status) == {"invalid"} and not d.flag.any()
    # ... unless its options say which signal to read
    r = ts.detect(
        t, {"lateral_acceleration": np.sin(t)},
        options={"oscillation_counter": {"signal": "lateral_acceleration"}},
        detectors=["oscillation_counter"],
    )
    assert r.detectors["oscillation_counter"].status[-1] == "ok"


@pytest.mark.parametrize(
    "call, exception, message",
    [
        (lambda t: ts.detect(t, {"yaw_rat": t}), ValueError, r"signals: unknown key\(s\) \['yaw_rat'\]"),
        (lambda t: ts.detect(t, {"yaw_rate": t[:-1]}), ValueError, r"signals\['yaw_rate'\]: 99 samples, t has 100"),
        (lambda t: ts.detect(t, {}), ValueError, r"signals: expected at least one of"),
        (lambda t: ts.detect(t, [t]), TypeError, r"signals: expected a dict of sequences, got list"),
        (lambda t: ts.detect("0.1", {"yaw_rate": t}), TypeError, r"t: expected a sequence of numbers, got a string"),
        (lambda t: ts.detect(t, {"yaw_rate": ["a"] * 100}), TypeError, r"signals\['yaw_rate'\]: expected a sequence of numbers"),
        (lambda t: ts.detect(t[:1], {"yaw_rate": t[:1]}), ValueError, r"t: expected at least 2 samples"),
        (lambda t: ts.detect(t[::-1], {"yaw_rate": t}), ValueError, r"t: expected finite times increasing"),
        (lambda t: ts.detect(t, {"yaw_rate": t}, detectors="oscillation_counter"), TypeError, r"detectors: expected a list of names"),
        (lambda t: ts.detect(t, {"yaw_rate": t}, detectors=["kalman"]), ValueError, r"detectors: unknown detector 'kalman'"),
        (lambda t: ts.detect(t, {"yaw_rate": t}, options=[1]), TypeError, r"options: expected a dict of option dicts"),
        (lambda t: ts.detect(t, {"yaw_rate": t}, detectors=["damping_estimator"], options={"oscillation_counter": {}}), ValueError, r"options: 'oscillation_counter' is not among the detectors run"),
        (lambda t: ts.detect(t, {"yaw_rate": t}, options={"oscillation_counter": 3}), TypeError, r"options\['oscillation_counter'\]: expected a dict, got int"),
        (lambda t: ts.detect(t, {"yaw_rate": t}, options={"oscillation_counter": {"amplitude_threshold": "big"}}), TypeError, r"amplitude_threshold"),
        (lambda t: ts.detect(t, {"yaw_rate": t}, options={"oscillation_counter": {"treshold": 1.0}}), ValueError, r"treshold"),
        (lambda t: ts.detect(t, {"yaw_rate": t}, options={"oscillation_counter": {"amplitude_threshold": -1.0}}), ValueError, r"detect\(options\['oscillation_counter'\]\): .*amplitude_threshold"),
        (lambda t: ts.detect(t, {"yaw_rate": t}, options={"damping_estimator": {"band": {"low_hz": 2.0, "high_hz": 1.0}}}), ValueError, r"sway band"),
    ],
)
def test_bad_input_is_named_in_python_terms(call, exception, message):
    t = np.arange(0, 1.0, 0.01)
    with pytest.raises(exception, match=message):
        call(t)


def test_the_detection_plots():
    mpl = pytest.importorskip("matplotlib")
    mpl.use("Agg")
    t = np.arange(0, 20.0, 0.01)
    r = ts.detect(t, {"yaw_rate": damped_sine(t, 0.05, 0.7, 0.0)})
    ax = r.plot()
    assert ax.get_xlabel() == "time t [s]" and "rad/s" in ax.get_ylabel()
    labels = [l.get_label() for l in ax.get_legend().get_lines()]
    assert any(l.startswith("oscillation_counter: first flag") for l in labels), labels


def test_the_observer_estimates_the_hitch_angle_of_the_recording():
    # reference: a recording of the Rust sensors on the observer's own model is not at hand
    # here; what Python can check is the wiring: the observer runs on the four signals it
    # reads, its per-sample estimates come back as float64 arrays of t's length, and with
    # no excitation (straight running at 25 m/s, zero signals) the hitch angle stays at 0
    # within its standard deviation and V_crit is estimated (NaN before the first search)
    t = np.arange(0, 10.0, 0.01)
    zero = np.zeros(len(t))
    r = ts.detect(
        t,
        {"yaw_rate": zero, "lateral_acceleration": zero, "steering_wheel_angle": zero, "speed": np.full(len(t), 25.0)},
        detectors=["model_observer"],
    )
    d = r.detectors["model_observer"]
    assert d.status.count("ok") == len(t)
    e = d.estimates
    for k in ("hitch_angle", "hitch_angle_sd", "trailer_mass", "v_crit_estimate_mps"):
        assert e[k].dtype == np.float64 and len(e[k]) == len(t), k
    assert np.all(np.abs(e["hitch_angle"]) <= 3 * e["hitch_angle_sd"] + 1e-12)
    assert np.isfinite(e["v_crit_estimate_mps"][-1]) and e["v_crit_estimate_mps"][-1] > 0
    # nothing drives it: the prior's mass stays within its prior sd (1300 ± 600 kg)
    assert abs(e["trailer_mass"][-1] - 1300.0) < 600.0
    assert not d.flag.any()
