"""Overhead of `trailer_sway.simulate` over the Rust call: the run of the criterion bench
`S1_open_loop_V33_60s` (crates/sway/benches/simulation.rs: Table I, V = 33 m/s,
θ(0) = 0.1 rad (given in deg), 60 s, rtol 1e-8 / atol 1e-10, 7 states, nothing recorded) from Python.

    python python/bench/simulate_overhead.py [repeats]

Prints the median, 10th and 90th percentile of the wall time per call [ms]; compare the
median with criterion's (`cargo bench -p sway --bench simulation -- S1_open_loop`) built
with the same profile as the package.
"""

import statistics
import sys
import time

import trailer_sway as ts

S1 = {
    "name": "S1",
    "horizon_s": 60.0,
    "guard": "stop",
    "speed": {"kind": "constant", "speed_mps": 33.0},
    "initial": {"kind": "state", "theta0_deg": 5.729577951308232},  # 0.1 rad
    "solver": {"rtol": 1e-8, "atol": 1e-10},
}

repeats = int(sys.argv[1]) if len(sys.argv) > 1 else 2000
v = ts.Vehicle.table1()
r = ts.simulate(v, S1, trajectory=False)
print("S1:", r.sway_class, r.accepted_steps, "accepted,", r.rejected_steps, "rejected steps")


def timed(scenario, n):
    for _ in range(50):
        ts.simulate(v, scenario, trajectory=False)
    times = []
    for _ in range(n):
        t0 = time.perf_counter()
        ts.simulate(v, scenario, trajectory=False)
        times.append(time.perf_counter() - t0)
    return times


times = timed(S1, repeats)
q = statistics.quantiles(times, n=10)
print(f"simulate from Python: median {statistics.median(times) * 1e3:.4f} ms "
      f"(min {min(times) * 1e3:.4f}, p10 {q[0] * 1e3:.4f}, p90 {q[-1] * 1e3:.4f}; {repeats} calls)")
# the same call on a 1 ms horizon (two solver steps): what the call costs besides the
# integration (config reading and checks, the summary, the Python objects)
tiny = dict(S1, horizon_s=1e-3, output_step_s=1e-3)
t = timed(tiny, repeats)
print(f"the call alone (1 ms horizon): median {statistics.median(t) * 1e6:.1f} µs (min {min(t) * 1e6:.1f} µs)")
