"""Preset machines: Machine-B-like (77 sensors) and Machine-A-like (26 sensors).

The structures follow the sensor layouts of the thesis (001 Table 4-4 and
Table 6-1); the numbers are plausible lumped values for small vertical milling
centres, tuned so the simulated tests land near the magnitudes the papers
report (METHODS §14). They are a starting point for
:meth:`ThermalMachine.calibrate`, not a model of any particular machine.
"""

import dataclasses

import numpy as np

from skthermal.simulate._spec import MachineSpec, SensorSpec

N_CARRIER = 6
N_SCREW = 4


def _carrier_point(u, extra=None):
    """Weights of a point at fraction ``u`` along the carrier (0 = spindle end)."""
    x = u * (N_CARRIER - 1)
    i = min(int(np.floor(x)), N_CARRIER - 2)
    f = x - i
    w = {f"carrier{i + 1}": 1.0 - f, f"carrier{i + 2}": f}
    if extra:
        scale = 1.0 - sum(extra.values())
        w = {k: v * scale for k, v in w.items()}
        for k, v in extra.items():
            w[k] = w.get(k, 0.0) + v
    return {k: v for k, v in w.items() if v > 0}


def _common_structure():
    carrier = [f"carrier{i + 1}" for i in range(N_CARRIER)]
    screw = [f"screw{i + 1}" for i in range(N_SCREW)]
    nodes = (
        "bearings",
        "boss",
        *carrier,
        "motor",
        "column_surface",
        "column_core",
        "base",
        *screw,
        "nut",
        "axis_motor",
        "tool",
        "enclosure",
    )
    edges = [("bearings", "boss"), ("boss", "carrier1")]
    edges += [(carrier[i], carrier[i + 1]) for i in range(N_CARRIER - 1)]
    edges += [
        ("motor", "carrier2"),
        (carrier[-1], "column_surface"),
        ("column_surface", "column_core"),
        ("column_core", "base"),
        ("base", "screw1"),
    ]
    edges += [(screw[i], screw[i + 1]) for i in range(N_SCREW - 1)]
    edges += [
        (screw[-1], "base"),
        ("nut", "base"),
        ("nut", "screw2"),
        ("axis_motor", "base"),
        ("boss", "tool"),
    ]
    return nodes, tuple(edges), carrier, screw


def _structure_roles(nodes, edges, carrier, screw):
    """MachineSpec fields shared by both presets: the network and node roles."""
    return {
        "nodes": nodes,
        "edges": edges,
        "head_nodes": ("bearings", "boss", *carrier, "motor"),
        "exposed_nodes": ("boss", *carrier, "motor", "column_surface", "base", "tool"),
        "screw_nodes": tuple(screw),
        "nut": "nut",
        "axis_motor": "axis_motor",
    }


def _sensor(number, weights, kind, location):
    """A temperature sensor ``T<nn>_C``."""
    return SensorSpec(f"T{number:02d}_C", weights, kind, location)


def _common_params(carrier, screw):
    p = {
        "C.bearings": 1500.0,
        "C.boss": 12000.0,
        "C.motor": 10000.0,
        "C.column_surface": 60000.0,
        "C.column_core": 600000.0,
        "C.base": 900000.0,
        "C.nut": 1500.0,
        "C.axis_motor": 8000.0,
        "C.tool": 700.0,
        "C.enclosure": 200000.0,
        "G.bearings-boss": 12.0,
        "G.boss-carrier1": 10.0,
        "G.motor-carrier2": 3.0,
        f"G.{carrier[-1]}-column_surface": 6.0,
        "G.column_surface-column_core": 25.0,
        "G.column_core-base": 15.0,
        "G.base-screw1": 1.5,
        f"G.{screw[-1]}-base": 1.5,
        "G.nut-base": 2.0,
        "G.nut-screw2": 1.0,
        "G.axis_motor-base": 2.0,
        "G.boss-tool": 1.2,
        "hA.bearings": 0.3,
        "hA.boss": 1.2,
        "hA.motor": 2.0,
        "hA.column_surface": 8.0,
        "hA.column_core": 0.0,
        "hA.base": 10.0,
        "hA.nut": 0.2,
        "hA.axis_motor": 1.0,
        "hA.tool": 0.25,
        "hA.enclosure": 30.0,
        "q.bearing_W": 8.0,
        "q.alpha": 1.5,
        "q.motor_idle_W": 10.0,
        "q.motor_W_per_krpm": 4.0,
        "q.belt_W_per_krpm": 2.0,
        "q.cutting_W": 0.0,
        "sensor.noise_C": 0.03,
        "sensor.quantization_C": 0.125,
        "sensor.offset_C": 0.15,
        "disp.noise_um": 0.3,
    }
    for c in carrier:
        p[f"C.{c}"] = 9000.0
        p[f"hA.{c}"] = 0.8
    for a, b in zip(carrier[:-1], carrier[1:], strict=True):
        p[f"G.{a}-{b}"] = 8.0
    for s in screw:
        p[f"C.{s}"] = 2500.0
        p[f"hA.{s}"] = 0.3
    for a, b in zip(screw[:-1], screw[1:], strict=True):
        p[f"G.{a}-{b}"] = 2.0
    return p


def vmc_b():
    """Machine-B-like small VMC: 77 sensors laid out as 001 Table 4-4."""
    nodes, edges, carrier, screw = _common_structure()
    S = []

    def add(*args):
        S.append(_sensor(*args))

    for i, n in enumerate(range(1, 8)):  # outside the column, bottom to top
        h = i / 6
        add(
            n,
            {
                "column_surface": 0.85 - 0.1 * h,
                "column_core": 0.15,
                "carrier6": 0.1 * h,
            },
            "surface",
            "outside the column",
        )
    for i, n in enumerate(range(8, 34)):  # carrier strip 1
        add(n, _carrier_point(i / 25), "surface", "carrier strip 1")
    for i, n in enumerate(range(34, 63)):  # carrier strip 2, beside the motor
        u = i / 28
        extra = {"motor": 0.12 * np.exp(-(((u - 0.3) / 0.15) ** 2))}
        add(n, _carrier_point(u, extra), "surface", "carrier strip 2")
    add(63, {"boss": 0.85, "bearings": 0.15}, "surface", "spindle boss")
    add(64, {"boss": 0.9, "carrier1": 0.1}, "surface", "spindle boss")
    add(65, {"boss": 0.8, "bearings": 0.2}, "surface", "spindle boss")
    add(66, {"enclosure": 0.8, "base": 0.2}, "air", "Y scale air")
    add(67, {"enclosure": 0.75, "screw2": 0.25}, "air", "Y scale air")
    add(68, {"base": 0.7, "screw1": 0.3}, "surface", "Y bed")
    add(69, {"base": 0.6, "screw3": 0.4}, "surface", "Y bed")
    add(
        70,
        {"room": 0.5, "enclosure": 0.4, "column_surface": 0.1},
        "air",
        "ambient at the top of the column",
    )
    add(
        71, {"column_core": 0.8, "column_surface": 0.2}, "embedded", "inside the column"
    )
    add(
        72, {"column_core": 0.9, "column_surface": 0.1}, "embedded", "inside the column"
    )
    add(73, {"enclosure": 0.6, "carrier3": 0.4}, "air", "carrier air")
    add(74, {"base": 0.8, "nut": 0.2}, "surface", "table")
    add(75, {"enclosure": 0.6, "boss": 0.4}, "air", "spindle air")
    add(76, {"room": 0.5, "enclosure": 0.5}, "air", "base air")
    add(77, {"enclosure": 0.6, "tool": 0.4}, "air", "tool air")

    spec = MachineSpec(
        name="vmc-b",
        description=(
            "Small vertical milling centre like Machine B (000, 001 §5.3): "
            "spindle carrier on a column, belt-driven spindle, 77 temperature "
            "sensors (001 Table 4-4), test bar measured in X, Y and Z."
        ),
        sensors=tuple(S),
        **_structure_roles(nodes, edges, carrier, screw),
        feed_axis="y",
        groups={
            "column": [f"T{n:02d}_C" for n in (*range(1, 8), 70, 71, 72)],
            "carrier strip 1": [f"T{n:02d}_C" for n in range(8, 34)],
            "carrier strip 2": [f"T{n:02d}_C" for n in range(34, 63)],
            "spindle boss": [f"T{n:02d}_C" for n in range(63, 66)],
            "other": [f"T{n:02d}_C" for n in (66, 67, 68, 69, 73, 74, 75, 76, 77)],
        },
    )
    p = _common_params(carrier, screw)
    p.update(
        {
            "q.bearing_W": 10.0,
            "q.alpha": 1.65,
            "hA.boss": 2.0,
            "k.y.motor": 1.0,
            "k.y.column_surface": 1.0,
            "k.y.column_core": -1.0,
            "k.y.base": -4.0,
            "k.y.screw": 4.0,
            "k.z.bearings": 0.15,
            "k.z.boss": 0.35,
            "k.z.tool": 0.6,
            "k.z.column_surface": 0.3,
            "k.z.column_core": 0.6,
            "k.x.boss": 0.03,
            "k.x.carrier3": 0.02,
            "k.x.motor": 0.02,
        }
    )
    for c in carrier:
        p[f"C.{c}"] = 9000.0
        p[f"hA.{c}"] = 1.6
        p[f"k.y.{c}"] = 1.8
    return spec, p


def vmc_a():
    """Machine-A-like VMC: 26 sensors laid out as 001 Table 6-1."""
    nodes, edges, carrier, screw = _common_structure()
    S = []

    def add(*args):
        S.append(_sensor(*args))

    for i, n in enumerate(range(1, 8)):
        add(n, _carrier_point(i / 6), "surface", f"carrier strip 1 (B{i + 1})")
    for i, n in enumerate(range(8, 15)):
        add(
            n,
            _carrier_point(i / 6, {"motor": 0.08}),
            "surface",
            f"carrier strip 2 (T{i + 1})",
        )
    add(
        15,
        {"room": 0.6, "enclosure": 0.2, "column_surface": 0.2},
        "air",
        "column ambient, outside the column",
    )
    add(
        16,
        {"column_surface": 0.6, "base": 0.4},
        "surface",
        "column bolt bottom, Z scale",
    )
    add(
        17,
        {"column_surface": 0.8, "carrier6": 0.2},
        "surface",
        "column bolt top, Z scale",
    )
    add(18, {"boss": 0.85, "bearings": 0.15}, "surface", "spindle front bottom")
    add(19, {"boss": 0.9, "carrier1": 0.1}, "surface", "spindle front top")
    add(20, {"motor": 1.0}, "surface", "spindle motor surface")
    add(21, {"nut": 1.0}, "surface", "X ball nut, X scale")
    add(22, {"base": 0.8, "screw2": 0.2}, "surface", "Y ball nut, Y scale")
    add(23, {"column_surface": 0.7, "carrier6": 0.3}, "surface", "Z ball nut, Z scale")
    add(24, {"axis_motor": 1.0}, "surface", "Z axis motor surface")
    add(25, {"screw1": 0.8, "base": 0.2}, "surface", "X axis bearing cap")
    add(26, {"base": 0.7, "axis_motor": 0.3}, "surface", "Y axis motor bolt")
    spec = MachineSpec(
        name="vmc-a",
        description=(
            "Vertical milling centre like Machine A (001 §6): 26 temperature "
            "sensors (001 Table 6-1), ball-screw feed on X, test bar measured "
            "in X, Y and Z."
        ),
        sensors=tuple(S),
        **_structure_roles(nodes, edges, carrier, screw),
        feed_axis="x",
        groups={
            "carrier": [f"T{n:02d}_C" for n in range(1, 15)],
            "column": ["T15_C", "T16_C", "T17_C", "T23_C"],
            "spindle": ["T18_C", "T19_C", "T20_C"],
            "axes": ["T21_C", "T22_C", "T24_C", "T25_C", "T26_C"],
        },
    )
    p = _common_params(carrier, screw)
    p.update(
        {
            "C.column_surface": 15000.0,
            "hA.column_surface": 8.0,
            "G.column_surface-column_core": 4.0,
            "k.y.column_surface": 4.0,
            "k.y.column_core": -2.0,
            "k.y.motor": 0.3,
            "k.z.bearings": 0.3,
            "k.z.boss": 1.0,
            "k.z.tool": 1.0,
            "k.z.column_surface": 7.0,
            "k.z.column_core": 2.0,
            "k.x.screw": 8.0,
            "k.x.boss": 0.1,
            "feed_heating.W_per_m_min": 15.0,
        }
    )
    for c in carrier:
        p[f"k.y.{c}"] = 0.5
    return spec, p


def _with_all_coefficients(build):
    """Every ``k.<axis>.<node>`` is a parameter (zero unless the preset sets it),
    so any of them can be changed or calibrated by name."""

    def preset():
        spec, p = build()
        for axis in spec.axes:
            for node in spec.nodes:
                p.setdefault(f"k.{axis}.{node}", 0.0)
        return dataclasses.replace(spec, params=p)

    preset.__doc__ = build.__doc__
    return preset


PRESETS = {
    "vmc-b": _with_all_coefficients(vmc_b),
    "vmc-a": _with_all_coefficients(vmc_a),
}


def spindle_rig():
    """Spindle test rig: bearings, housings, motor, base, air; 5 nose channels."""
    nodes = (
        "front_bearing",
        "rear_bearing",
        "spindle",
        "nose",
        "front_housing",
        "rear_housing",
        "motor",
        "base",
        "air",
    )
    links = {
        ("front_bearing", "spindle"): 5.0,
        ("front_bearing", "front_housing"): 8.0,
        ("rear_bearing", "spindle"): 5.0,
        ("rear_bearing", "rear_housing"): 8.0,
        ("spindle", "nose"): 3.0,
        ("front_housing", "rear_housing"): 6.0,
        ("motor", "rear_housing"): 4.0,
        ("motor", "spindle"): 1.5,
        ("front_housing", "base"): 4.0,
        ("rear_housing", "base"): 4.0,
    }
    capacity = {
        "front_bearing": 800.0,
        "rear_bearing": 800.0,
        "spindle": 6000.0,
        "nose": 600.0,
        "front_housing": 15000.0,
        "rear_housing": 15000.0,
        "motor": 12000.0,
        "base": 300000.0,
        "air": 60000.0,
    }
    convection = {
        "front_bearing": 0.1,
        "rear_bearing": 0.1,
        "spindle": 0.5,
        "nose": 0.3,
        "front_housing": 3.0,
        "rear_housing": 3.0,
        "motor": 3.0,
        "base": 10.0,
        "air": 60.0,
    }
    layout = [
        (1, {"front_housing": 1.0}, "surface", "front housing"),
        (2, {"front_housing": 0.8, "front_bearing": 0.2}, "surface", "front cap"),
        (3, {"rear_housing": 1.0}, "surface", "rear housing"),
        (4, {"rear_housing": 0.7, "rear_bearing": 0.3}, "surface", "rear cap"),
        (5, {"motor": 1.0}, "surface", "motor casing"),
        (6, {"air": 1.0}, "air", "air beside the rig"),
        (7, {"air": 0.5, "room": 0.5}, "air", "air above the rig"),
        (8, {"spindle": 0.5, "front_housing": 0.5}, "surface", "front face"),
        (9, {"front_bearing": 0.6, "front_housing": 0.4}, "embedded", "front ring"),
        (10, {"room": 1.0}, "air", "workshop air"),
        (11, {"base": 1.0}, "surface", "base"),
        (12, {"base": 0.7, "front_housing": 0.3}, "surface", "front foot"),
        (13, {"base": 0.7, "rear_housing": 0.3}, "surface", "rear foot"),
        (14, {"base": 0.8, "motor": 0.2}, "surface", "motor mount"),
        (15, {"base": 0.6, "air": 0.4}, "surface", "base edge"),
        (16, {"nose": 0.5, "air": 0.5}, "air", "air at the spindle nose"),
    ]
    sensors = tuple(
        SensorSpec(f"T{n}_C", w, kind, where) for n, w, kind, where in layout
    )
    head = ("front_bearing", "rear_bearing", "spindle", "nose", "front_housing")
    spec = MachineSpec(
        name="spindle-rig",
        description=(
            "Spindle test rig: a motor-driven spindle in front and rear bearing "
            "housings on a base, 16 temperature sensors and 5 displacement "
            "channels of the spindle nose (ch1, ch2 radial, ch3, ch4 axial, ch5 "
            "tilt), laid out like the FL_THERMAL record (whose sensor "
            "locations are not documented: the layout is a plausible guess)."
        ),
        nodes=nodes,
        edges=tuple(links),
        sensors=sensors,
        head_nodes=(*head, "rear_housing", "motor"),
        exposed_nodes=("nose", "front_housing", "rear_housing", "motor", "base"),
        enclosure="air",
        tool="nose",
        bearing="front_bearing",
        motor="motor",
        belt="rear_bearing",
        cutting="nose",
        axes=("ch1", "ch2", "ch3", "ch4", "ch5"),
        groups={
            "spindle": ["T1_C", "T2_C", "T3_C", "T4_C", "T8_C", "T9_C", "T16_C"],
            "motor": ["T5_C", "T14_C"],
            "base": ["T11_C", "T12_C", "T13_C", "T15_C"],
            "air": ["T6_C", "T7_C", "T10_C"],
        },
    )
    p = {f"C.{n}": v for n, v in capacity.items()}
    p.update({f"hA.{n}": v for n, v in convection.items()})
    p.update({f"G.{a}-{b}": g for (a, b), g in links.items()})
    p.update(
        {
            "q.bearing_W": 3.0,
            "q.alpha": 1.5,
            "q.motor_idle_W": 5.0,
            "q.motor_W_per_krpm": 2.0,
            "q.belt_W_per_krpm": 1.5,
            "q.cutting_W": 0.0,
            "sensor.noise_C": 0.02,
            "sensor.quantization_C": 0.01,
            "sensor.offset_C": 0.1,
            "disp.noise_um": 0.3,
            "k.ch1.front_housing": 3.0,
            "k.ch1.spindle": 1.0,
            "k.ch2.front_housing": 2.5,
            "k.ch2.motor": 0.8,
            "k.ch3.spindle": -8.0,
            "k.ch3.nose": -4.0,
            "k.ch3.front_housing": -4.0,
            "k.ch4.spindle": -7.0,
            "k.ch4.rear_housing": -5.0,
            "k.ch5.front_housing": 5.0,
            "k.ch5.rear_housing": -2.0,
            "k.ch5.nose": 2.0,
        }
    )
    return spec, p


PRESETS["spindle-rig"] = _with_all_coefficients(spindle_rig)
