"""Simulated test campaigns of the papers' machines, as run tables.

Tests I-VI of Machine B (001 Table 5-3), the environmental (ETVE) test and the
multi-part test of Machine A (001 §6.2-6.3), generated with the physics-based
simulator. Every generator returns a run table whose ``attrs["metadata"]``
holds one record (dict) per run: machine, effects, description;
``pandas.DataFrame(runs.attrs["metadata"])`` makes it a table and
``write_runs(runs, path, metadata=runs.attrs["metadata"])`` saves it beside the
file.
"""

from sklearn.utils import check_random_state

from skthermal.datasets._combine import concat_runs

MACHINE_B_TESTS = {
    # name: (hours/speed steps, ambient settings, description, paper's max Y µm)
    "I": (
        [(1, 4000), (1, 0)],
        {"mean_C": 20.5, "trend_C_per_h": 0.2},
        "4000 rpm, 1 h heating / 1 h cooling",
        25.0,
    ),
    "II": (
        [(3, 4000), (2, 0)],
        {"mean_C": 19.0, "trend_C_per_h": -0.1},
        "4000 rpm, 3 h heating / 2 h cooling",
        35.0,
    ),
    "III": (
        [(3, 4000), (2, 0)],
        {"mean_C": 21.5, "trend_C_per_h": 0.15},
        "4000 rpm, 3 h heating / 2 h cooling, warmer rising ambient",
        40.0,
    ),
    "IV": (
        [(2, 4000), (1, 0), (2, 4000), (3, 0)],
        {"mean_C": 20.0, "day_amplitude_C": 0.4, "start_hour": 8.0},
        "4000 rpm, 2 h heating / 1 h stop / 2 h heating / 3 h stop",
        39.0,
    ),
    "V": (
        [(1, 8000), (1, 0)],
        {"mean_C": 20.0, "trend_C_per_h": 0.0},
        "8000 rpm, 1 h heating / 1 h cooling",
        64.0,
    ),
    "VI": (
        [(1, 8000), (1, 0)],
        {"mean_C": 23.0, "trend_C_per_h": 1.1},
        "8000 rpm, 1 h heating / 1 h cooling, warmer rising ambient",
        79.0,
    ),
}


def _concat(frames, metas):
    """Join simulated runs, each with its own metadata record."""
    for frame in frames:
        frame.attrs.clear()
    return concat_runs(frames, metadata=list(metas), validate=False)


def make_machine_b_tests(
    tests=None, *, machine=None, sample_period_s=30.0, noise=True, random_state=None
):
    """Tests I-VI of Machine B (001 Table 5-3), simulated.

    Parameters
    ----------
    tests : str or sequence of {"I", "II", "III", "IV", "V", "VI"}, optional
        Which tests (default all six, in order); a single string is one
        test.
    machine : ThermalMachine, optional
        Default: the ``"vmc-b"`` preset with its default effects.
    sample_period_s : float, default=30.0
    noise : bool, default=True
        Sensor and displacement noise (see ``ThermalMachine.simulate``).
    random_state : int, RandomState instance or None

    Returns
    -------
    runs : DataFrame
        Run table with runs ``"I"`` .. ``"VI"``, 77 temperatures ``T01_C`` ..
        ``T77_C`` and ``disp_x_um``, ``disp_y_um``, ``disp_z_um``.
        ``runs.attrs["metadata"]`` has one row per run, including the test
        description and the paper's maximum Y error.

    Examples
    --------
    >>> from skthermal.datasets import make_machine_b_tests
    >>> runs = make_machine_b_tests(["I", "V"], random_state=0)
    >>> runs.groupby("run", sort=False).size().to_dict()
    {'I': 241, 'V': 241}
    """
    from skthermal.simulate import AmbientProfile, DutyCycle, ThermalMachine

    machine = ThermalMachine.from_preset("vmc-b") if machine is None else machine
    if tests is None:
        names = list(MACHINE_B_TESTS)
    elif isinstance(tests, str):
        names = [tests]  # one test: "IV" is not "I" and "V"
    else:
        names = list(tests)
    unknown = [t for t in names if t not in MACHINE_B_TESTS]
    if unknown:
        raise ValueError(
            f"Unknown test(s) {unknown}; Machine B has {list(MACHINE_B_TESTS)}."
        )
    rng = check_random_state(random_state)
    seeds = dict(zip(MACHINE_B_TESTS, rng.randint(0, 2**31 - 1, 6)))
    frames, metas = [], []
    for name in names:
        steps, air, description, paper_y = MACHINE_B_TESTS[name]
        ambient = AmbientProfile(noise_C=0.05, **air)
        frame = machine.simulate(
            DutyCycle.from_hours(steps),
            ambient,
            sample_period_s=sample_period_s,
            run=name,
            noise=noise,
            random_state=seeds[name],
        )
        frames.append(frame)
        metas.append(
            {
                **machine.run_metadata(name),
                "description": description,
                "paper_max_disp_y_um": paper_y,
            }
        )
    return _concat(frames, metas)


def make_etve(
    *,
    machine=None,
    hours=160.0,
    sample_period_s=60.0,
    door_events=((0.5,), (122.0,), (134.0,)),
    day_amplitude_C=2.5,
    noise=True,
    random_state=None,
):
    """Environmental temperature variation error test (ETVE), simulated.

    The spindle stays still while the workshop air follows the day/night
    cycle (about ±2.5 °C) and workshop doors open for 30 minutes (a drop of
    about 9 °C, recovering over 45 minutes), as in the 160-hour test of
    Machine A (001 §6.2, 002).

    Parameters
    ----------
    machine : ThermalMachine, optional
        Default: the ``"vmc-a"`` preset.
    hours : float, default=160.0
    sample_period_s : float, default=60.0
    door_events : sequence of tuples, default=((0.5,), (122.0,), (134.0,))
        ``DoorEvent`` arguments: (start_h[, drop_C, duration_min, recovery_min]).
    day_amplitude_C : float, default=2.5
    noise : bool, default=True
    random_state : int, RandomState instance or None

    Returns
    -------
    runs : DataFrame
        One run ``"ETVE"``.
    """
    from skthermal.simulate import AmbientProfile, DoorEvent, DutyCycle, ThermalMachine

    machine = ThermalMachine.from_preset("vmc-a") if machine is None else machine
    events = [DoorEvent(*e) if not isinstance(e, DoorEvent) else e for e in door_events]
    ambient = AmbientProfile(
        mean_C=19.0,
        day_amplitude_C=day_amplitude_C,
        start_hour=0.0,
        door_events=events,
        noise_C=0.1,
        noise_tau_min=30.0,
    )
    frame = machine.simulate(
        DutyCycle([(hours * 3600.0, 0.0)]),
        ambient,
        sample_period_s=sample_period_s,
        run="ETVE",
        initial="ambient",
        noise=noise,
        random_state=random_state,
    )
    meta = {
        **machine.run_metadata("ETVE"),
        "description": f"{hours:g} h environmental test, {len(events)} door events",
    }
    return _concat([frame], [meta])


def make_multipart_test(
    *, machine=None, n_parts=6, sample_period_s=10.0, noise=True, random_state=None
):
    """Multi-part machining test of Machine A (001 §6.3), simulated.

    Parts are machined one after another: each part runs the spindle at a
    different speed with axis feed, separated by short probing pauses, while
    the air of the temperature-controlled room is warmed and then cooled.

    Returns
    -------
    runs : DataFrame
        One run ``"multipart"`` with 26 temperatures and X, Y, Z displacements.
    """
    from skthermal.simulate import AmbientProfile, DutyCycle, ThermalMachine

    machine = ThermalMachine.from_preset("vmc-a") if machine is None else machine
    rng = check_random_state(random_state)
    speeds = rng.choice([3000, 4500, 6000, 7500, 9000], size=n_parts)
    feeds = rng.choice([1000, 2000, 3000, 4000], size=n_parts)
    steps = []
    for n, f in zip(speeds, feeds, strict=True):
        steps += [(40 * 60.0, float(n), float(f)), (5 * 60.0, 0.0, 0.0)]
    steps.append((90 * 60.0, 0.0, 0.0))
    duty = DutyCycle(steps)
    hours = duty.duration_s / 3600.0
    ambient = AmbientProfile(
        mean_C=20.0,
        day_amplitude_C=5.0,
        start_hour=14.0 - hours / 2,
        peak_h=14.0,
        noise_C=0.05,
    )
    frame = machine.simulate(
        duty,
        ambient,
        sample_period_s=sample_period_s,
        run="multipart",
        noise=noise,
        random_state=rng,
    )
    meta = {
        **machine.run_metadata("multipart"),
        "description": f"{n_parts} parts, speeds {list(map(int, speeds))} rpm",
    }
    return _concat([frame], [meta])
