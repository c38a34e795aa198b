"""Long calls release the GIL and stop on Ctrl-C with KeyboardInterrupt."""

import subprocess
import sys
import textwrap
import threading
import time

import pytest

import trailer_sway as ts

LONG = {
    "name": "long",
    "axes": [
        {"parameter": "speed_mps", "min": 30.0, "max": 38.0, "points": 200},
        {"parameter": "theta0_deg", "min": 2.0, "max": 12.0, "points": 50},
    ],
    "base": {
        "horizon_s": 200.0,
        "speed": {"kind": "constant", "speed_mps": 33.0},
        "initial": {"kind": "state", "theta0_deg": 0.0},
    },
}


def test_ctrl_c_raises_keyboard_interrupt_promptly(tmp_path):
    # a 10 000-point study (minutes) interrupted by SIGINT after 1 s: KeyboardInterrupt
    # within 2 s of the signal, and the interpreter lives on
    script = tmp_path / "interrupt.py"
    script.write_text(
        textwrap.dedent(
            f"""
            import os, signal, threading, time
            import trailer_sway as ts
            # a process started in the background by a non-interactive shell inherits
            # SIGINT ignored, and Python then keeps it ignored: install Python's handler
            signal.signal(signal.SIGINT, signal.default_int_handler)
            threading.Timer(1.0, lambda: os.kill(os.getpid(), signal.SIGINT)).start()
            t0 = time.monotonic()
            try:
                ts.sweep({LONG!r})
                print("finished")
            except KeyboardInterrupt:
                print("interrupted", time.monotonic() - t0)
            print("alive", ts.critical_speed().v_crit_mps > 0)
            """
        )
    )
    r = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=120)
    out = r.stdout.split()
    assert r.returncode == 0, r.stderr
    assert out[0] == "interrupted", r.stdout
    assert float(out[1]) < 3.0, r.stdout
    assert out[2:] == ["alive", "True"]


def test_long_calls_release_the_gil():
    # while a sweep runs on another thread, this thread keeps executing Python code
    small = dict(LONG, axes=[dict(LONG["axes"][0], points=20), dict(LONG["axes"][1], points=10)])
    done = threading.Event()
    th = threading.Thread(target=lambda: (ts.sweep(small), done.set()))
    t0 = time.monotonic()
    th.start()
    ticks = 0
    while not done.is_set() and time.monotonic() - t0 < 60:
        ticks += 1
        time.sleep(0.001)
    th.join()
    elapsed = time.monotonic() - t0
    assert done.is_set()
    # about one tick per ms of the call (at least a quarter, on a loaded machine)
    assert ticks > 0.25 * elapsed * 1000 / 1.1, (ticks, elapsed)


def test_set_num_threads_takes_effect_at_any_time(table1):
    # reference: get_num_threads and the same numbers on 1 and 2 threads (a computation
    # before and between the changes: the pool is replaced, not refused)
    import trailer_sway as ts

    before = ts.critical_speed(table1).v_crit_mps
    ts.set_num_threads(1)
    assert ts.get_num_threads() == 1
    one = ts.lateral_stability(table1, speeds=[25.0, 30.0], amplitudes_deg=[1.0, 2.0]).summary
    ts.set_num_threads(2)
    assert ts.get_num_threads() == 2
    two = ts.lateral_stability(table1, speeds=[25.0, 30.0], amplitudes_deg=[1.0, 2.0]).summary
    assert one == two
    assert ts.critical_speed(table1).v_crit_mps == before


@pytest.mark.parametrize(
    "n, error, text",
    [(-1, ValueError, "expected 1 to 1024 threads, got -1"), (0, ValueError, "got 0"),
     (10**30, ValueError, "expected 1 to 1024"), ("2", TypeError, "expected an int, got str"),
     (True, TypeError, "got bool"), (2.0, TypeError, "got float")],
)
def test_set_num_threads_refuses_what_is_not_a_thread_count(n, error, text):
    import trailer_sway as ts

    with pytest.raises(error) as e:
        ts.set_num_threads(n)
    assert text in str(e.value), str(e.value)
