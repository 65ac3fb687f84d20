"""Simulator speed and memory: 160 h at 10 s sampling with the vmc-b preset.

Times ``ThermalMachine.simulate`` (77 sensors, noise, lag, quantisation) and,
side by side in the same run, a straightforward simulation of the same
network: the discrete system from ``scipy.linalg.expm`` stepped one sample at a
time in a Python loop (node temperatures only, no sensors). Prints both, their
ratio, the agreement of the node temperatures, and the peak memory of runs of
two lengths (it should grow linearly).

Run:  python benchmarks/bench_simulate.py [--check]
``--check`` exits 1 unless the full simulation takes at most 0.5 s.
"""

import argparse
import sys
import time
import tracemalloc

import numpy as np
from scipy.linalg import expm

from skthermal.simulate import AmbientProfile, DoorEvent, DutyCycle, ThermalMachine


def _naive(machine, rpm, air, dt, T0):
    """Per-step loop with the exact ZOH/FOH discrete matrices from expm."""
    nodes = machine.spec.nodes
    C = np.array([machine.params[f"C.{n}"] for n in nodes])
    T = np.empty((rpm.size, len(nodes)))
    T[0] = T0
    cache = {}
    heat = machine.heat_inputs(rpm[:-1])
    Q = heat.to_numpy()
    cols = [machine.node_index[n] for n in heat.columns]
    for k in range(rpm.size - 1):
        if rpm[k] not in cache:
            _, K, to_room = machine.network(rpm[k])
            n = len(nodes)
            A = -K / C[:, None]
            # Augmented matrix: state, heat (held), air value and air slope.
            M = np.zeros((n + 3, n + 3))
            M[:n, :n] = A
            M[:n, n] = 1.0  # heat input column (per-node heat via B below)
            M[:n, n + 1] = to_room / C
            M[n + 1, n + 2] = 1.0 / dt
            E = expm(M * dt)
            Bq = np.zeros((n, len(cols)))
            # Heat enters node i as Q_i / C_i: integrate it per heated node.
            for j, c in enumerate(cols):
                Mq = np.zeros((n + 1, n + 1))
                Mq[:n, :n] = A
                Mq[c, n] = 1.0 / C[c]
                Bq[:, j] = expm(Mq * dt)[:n, n]
            cache[rpm[k]] = (E[:n, :n], Bq, E[:n, n + 1], E[:n, n + 2])
        Ad, Bq, Ba, Bs = cache[rpm[k]]
        T[k + 1] = Ad @ T[k] + Bq @ Q[k] + Ba * air[k] + Bs * (air[k + 1] - air[k])
    return T


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--check", action="store_true")
    args = parser.parse_args(argv)

    machine = ThermalMachine.from_preset("vmc-b")
    duty = DutyCycle.from_hours([(4, 4000), (4, 0), (4, 8000), (4, 0)] * 10)
    air = AmbientProfile(
        day_amplitude_C=2.5, door_events=[DoorEvent(30.0)], noise_C=0.1
    )
    dt = 10.0

    t0 = time.perf_counter()
    machine.simulate(duty, air, sample_period_s=dt, random_state=0)
    first = time.perf_counter() - t0
    times = []
    for _ in range(args.repeats):
        t0 = time.perf_counter()
        runs, states = machine.simulate(
            duty, air, sample_period_s=dt, random_state=0, return_states=True
        )
        times.append(time.perf_counter() - t0)
    best = min(times)

    t = runs["time_s"].to_numpy()
    rpm = runs["spindle_rpm"].to_numpy()
    # Both integrate the same noiseless air profile.
    plain = AmbientProfile(day_amplitude_C=2.5, door_events=[DoorEvent(30.0)])
    air_true = plain.sample(t)
    ref_states = machine.simulate_drivers(
        t, rpm, air_true, noise=False, return_states=True
    )[1].to_numpy()
    t0 = time.perf_counter()
    naive = _naive(
        machine, rpm, air_true, dt, np.full(len(machine.spec.nodes), air_true[0])
    )
    t_naive = time.perf_counter() - t0
    t_states = np.inf
    for _ in range(args.repeats):
        t0 = time.perf_counter()
        machine.response(t, rpm, air_true)
        t_states = min(t_states, time.perf_counter() - t0)

    print(
        f"vmc-b, 160 h at {dt:g} s = {runs.shape[0] - 1} steps, "
        f"{len(machine.spec.nodes)} nodes, {len(machine.sensors)} sensors"
    )
    print(
        f"  simulate (run table with sensors, noise): best {best:.3f} s "
        f"(first call {first:.3f} s)"
    )
    print(f"  node temperatures only, modal scan      : {t_states:.3f} s")
    print(f"  node temperatures only, per-step loop   : {t_naive:.3f} s")
    print(f"  ratio loop / modal scan                 : {t_naive / t_states:.1f} x")
    print(
        f"  max |difference| of node temperatures   : "
        f"{np.abs(naive - ref_states).max():.2e} °C"
    )

    peaks = {}
    for hours in (40, 160):
        d = DutyCycle.from_hours([(4, 4000), (4, 0)] * (hours // 8))
        tracemalloc.start()
        machine.simulate(d, air, sample_period_s=dt, random_state=0)
        peaks[hours] = tracemalloc.get_traced_memory()[1] / 2**20
        tracemalloc.stop()
    print(
        f"  peak memory: 40 h {peaks[40]:.0f} MiB, 160 h {peaks[160]:.0f} MiB "
        f"(ratio {peaks[160] / peaks[40]:.2f} for 4x the length)"
    )
    if args.check and best > 0.5:
        print("FAILED: slower than 0.5 s")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
