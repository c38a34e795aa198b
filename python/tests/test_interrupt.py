"""Ctrl-C stops every long call: `KeyboardInterrupt` within 0.5 s of the signal, no thread
left computing (the process's CPU time stands still afterwards), and the next small call
runs at its normal speed.

Reference: the same small call timed before the interrupted one, in the same process;
the CPU time over a quiet half second after the interrupt (a busy core would add 0.5 s).
Each long call is sized to run for well over the 1 s after which the signal comes (a call
that finishes first fails the test: it would test nothing).
"""

import json
import subprocess
import sys
import textwrap

import pytest

# the long calls, as Python source on the Table I vehicle `v`; each runs for many seconds
LONG_CALLS = {
    "stability_chart": "ts.stability_chart(v, delays=(0.2, 0.4), speed_cells=2500, gain_cells=2500)",
    "nonlinear_chart": "ts.nonlinear_chart(v)",
    "bifurcation_diagram": (
        "ts.bifurcation_diagram(v, {'kind': 'yaw_rate_feedback', 'gain_s': 0.1, 'delay_s': 0.2},"
        " continuation={'intervals': 400, 'max_cycle_points': 5000, 'initial_step': 0.005, 'max_step': 0.01})"
    ),
    "sweep": (
        "ts.sweep({'name': 'long', 'axes': ["
        "{'parameter': 'speed_mps', 'min': 30.0, 'max': 38.0, 'points': 200},"
        "{'parameter': 'theta0_deg', 'min': 2.0, 'max': 12.0, 'points': 50}],"
        " 'base': {'horizon_s': 200.0, 'speed': {'kind': 'constant', 'speed_mps': 33.0},"
        " 'initial': {'kind': 'state', 'theta0_deg': 0.0}}})"
    ),
    "lateral_stability": (
        "ts.lateral_stability(v, speeds=[20.0 + 0.25 * k for k in range(60)],"
        " amplitudes_deg=[0.5 * k for k in range(1, 20)])"
    ),
    "simulate": (
        "ts.simulate(v, {'horizon_s': 90000.0, 'output_step_s': 0.1, 'speed': {'kind': 'constant', 'speed_mps': 36.0},"
        " 'initial': {'kind': 'state', 'theta0_deg': 5.0}}, trajectory=False)"
    ),
}

SCRIPT = textwrap.dedent(
    """
    import json, os, signal, sys, threading, time
    import trailer_sway as ts

    # a process started in the background by a non-interactive shell inherits SIGINT
    # ignored, and Python then keeps it ignored: install Python's handler
    signal.signal(signal.SIGINT, signal.default_int_handler)
    v = ts.Vehicle.table1()

    def small():
        t0 = time.perf_counter()
        ts.stability_chart(v, delays=(0.2,), speed_cells=50, gain_cells=50)
        return time.perf_counter() - t0

    small()  # warm up
    before = min(small() for _ in range(3))
    sent = []
    def interrupt():
        sent.append(time.monotonic())
        os.kill(os.getpid(), signal.SIGINT)
    threading.Timer(1.0, interrupt).start()
    try:
        CALL
        print(json.dumps({"finished": True}))
        sys.exit(0)
    except KeyboardInterrupt:
        latency = time.monotonic() - sent[0]
    cpu0 = time.process_time()
    time.sleep(0.5)
    idle_cpu = time.process_time() - cpu0
    after = small()
    print(json.dumps({"finished": False, "latency_s": latency, "idle_cpu_s": idle_cpu,
                      "small_before_s": before, "small_after_s": after,
                      "threads": threading.active_count()}))
    """
)


@pytest.mark.parametrize("name", sorted(LONG_CALLS))
def test_ctrl_c_stops_the_call_and_its_threads(name, tmp_path):
    script = tmp_path / "interrupt.py"
    script.write_text(SCRIPT.replace("CALL", LONG_CALLS[name]))
    r = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    got = json.loads(r.stdout.strip().splitlines()[-1])
    print(name, got)
    assert not got["finished"], f"{name} finished within 1 s: it tests nothing"
    # the bound: stopped within 0.5 s of the signal
    assert got["latency_s"] < 0.5, got
    # nothing computing in the background (one busy core would add ≈ 0.5 s)
    assert got["idle_cpu_s"] < 0.1, got
    # the next small call at its normal speed (3× and 50 ms of slack for a loaded machine)
    assert got["small_after_s"] < 3.0 * got["small_before_s"] + 0.05, got


SWEEP = {
    "name": "progress",
    "axes": [{"parameter": "speed_mps", "min": 30.0, "max": 38.0, "points": 400}],
    "base": {
        "horizon_s": 200.0,
        "speed": {"kind": "constant", "speed_mps": 33.0},
        "initial": {"kind": "state", "theta0_deg": 8.0},
    },
}


def test_progress_callback_sees_the_points_of_a_sweep():
    # reference: the sweep's own point count; reports are monotone and end at the total
    import trailer_sway as ts

    seen = []
    table = ts.sweep(SWEEP, progress=lambda stage, done, total: seen.append((stage, done, total)))
    assert len(table) == 400
    assert seen, "a call of more than a quarter of a second reports its progress"
    assert {s for s, _, _ in seen} == {"sweep points"}
    assert all(total == 400 for _, _, total in seen)
    done = [d for _, d, _ in seen]
    assert done == sorted(done) and done[-1] == 400


def test_an_exception_in_the_progress_callback_stops_the_call():
    import trailer_sway as ts

    class Stop(Exception):
        pass

    def stop(stage, done, total):
        raise Stop(stage)

    with pytest.raises(Stop, match="sweep points"):
        ts.sweep(SWEEP, progress=stop)
    with pytest.raises(TypeError, match="progress: expected None, True, False or a callable"):
        ts.sweep(SWEEP, progress="yes")


def test_progress_none_draws_a_tqdm_bar_when_tqdm_is_installed(monkeypatch):
    # reference: a stand-in tqdm module that records its bars; every bar is closed after
    import types

    import trailer_sway as ts

    bars = []

    class Bar:
        def __init__(self, total=None, desc=None, leave=True):
            self.total, self.desc, self.n, self.closed = total, desc, 0, False
            bars.append(self)

        def refresh(self):
            pass

        def close(self):
            self.closed = True

    auto = types.ModuleType("tqdm.auto")
    auto.tqdm = Bar
    monkeypatch.setitem(sys.modules, "tqdm", types.ModuleType("tqdm"))
    monkeypatch.setitem(sys.modules, "tqdm.auto", auto)
    ts.sweep(SWEEP)
    assert [(b.desc, b.total, b.n, b.closed) for b in bars] == [("sweep points", 400, 400, True)]
    bars.clear()
    ts.sweep(SWEEP, progress=False)
    assert bars == []
