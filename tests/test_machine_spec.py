"""The machine description: validation, dict and TOML, presets, response API."""

import ast
import json
import re
import tomllib
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from skthermal.simulate import (
    EFFECTS,
    DutyCycle,
    Effect,
    MachineSpec,
    SensorSpec,
    ThermalMachine,
)
from skthermal.simulate._spec import dumps_toml

DUTY = DutyCycle([(1800, 4000, 2000), (900, 0, 0), (900, 6000, 500)])


def _small():
    """A three-node machine as a dict (the file layout)."""
    return {
        "name": "small",
        "axes": ["z"],
        "roles": {"enclosure": "air", "tool": "spindle", "head": ["spindle"]},
        "nodes": {
            "spindle": {"capacity_J_per_K": 2000.0, "convection_W_per_K": 0.5},
            "housing": {"capacity_J_per_K": 20000.0, "convection_W_per_K": 3.0},
            "air": {"capacity_J_per_K": 50000.0, "convection_W_per_K": 40.0},
        },
        "links": [{"between": ["spindle", "housing"], "conductance_W_per_K": 5.0}],
        "heat": {"bearing": {"node": "spindle", "W_at_1000_rpm": 4.0, "alpha": 1.5}},
        "sensors": {"T1_C": {"weights": {"housing": 0.8, "room": 0.2}}},
        "displacement": {"z": {"spindle": 2.0, "housing": 1.0}},
    }


@pytest.mark.parametrize("name", ["vmc-b", "vmc-a", "spindle-rig"])
def test_presets_round_trip_through_dict_and_toml(name, tmp_path):
    machine = ThermalMachine.from_preset(name)
    spec = machine.spec
    assert MachineSpec.from_dict(spec.to_dict()) == spec
    path = tmp_path / "machine.toml"
    spec.to_toml(path)
    assert MachineSpec.from_toml(path) == spec
    again = ThermalMachine.from_spec(path)
    a = machine.simulate(DUTY, 20.0, random_state=0)
    b = again.simulate(DUTY, 20.0, random_state=0)
    pd.testing.assert_frame_equal(a, b, check_exact=True)


def test_a_sensor_on_one_node_is_a_node_name():
    data = _small()
    data["sensors"]["T1_C"] = {"node": "spindle"}
    spec = MachineSpec.from_dict(data)
    assert spec.sensors[0].weights == {"spindle": 1.0}
    assert MachineSpec.from_dict(spec.to_dict()) == spec


def test_a_custom_source_may_heat_the_enclosure_air():
    # Roles of solid bodies may not sit on the enclosure; a custom source
    # may (a cabinet or hydraulic unit warming the air inside).
    data = _small()
    data["heat"]["custom"] = {"cabinet": {"node": "air", "W_constant": 50.0}}
    machine = ThermalMachine.from_spec(data, effects=[])
    run = machine.simulate(DutyCycle([(3600, 0, 0)]), 20.0, noise=False)
    assert run["T1_C"].iloc[-1] > 20.1


def test_a_small_machine_from_a_dict_simulates():
    machine = ThermalMachine.from_spec(_small(), effects=[])
    run = machine.simulate(DUTY, 20.0, noise=False)
    assert list(run.columns[-2:]) == ["T1_C", "disp_z_um"]
    assert np.all(np.isfinite(run.iloc[:, 2:].to_numpy(float)))
    assert run["disp_z_um"].iloc[60] > 1.0  # the spindle heats and grows
    assert machine.params["q.motor_idle_W"] == 0.0  # absent sources are off


@pytest.mark.parametrize(
    "edit, message",
    [
        (
            lambda d: d["links"][0].update(between=["spindle", "housng"]),
            r"link 'spindle-housng': unknown node 'housng' \(did you mean 'housing'",
        ),
        (
            lambda d: d["links"][0].update(between=["spindle", "room"]),
            r"link 'spindle-room': 'room' \(the workshop air\) is not a node.*"
            r"roles: exposed",
        ),
        (
            # A node named so had its displacement coefficient counted twice
            # (once more as the ball screw's growth), silently.
            lambda d: d["nodes"].update(screw={"capacity_J_per_K": 100.0}),
            r"node 'screw': the name is reserved for the ball screw's growth",
        ),
        (
            lambda d: d["nodes"]["housing"].update(capacity_J_per_K=-5.0),
            r"node 'housing': capacity_J_per_K must be positive, got -5",
        ),
        (
            lambda d: d["sensors"]["T1_C"].update(weights={"spindel": 1.0}),
            r"sensor 'T1_C': unknown node 'spindel' \(did you mean 'spindle'",
        ),
        (
            lambda d: d["nodes"]["spindle"].update(capacity_J_per_k=1.0),
            r"node 'spindle': unknown field 'capacity_J_per_k' "
            r"\(did you mean 'capacity_J_per_K'",
        ),
        (
            lambda d: d["nodes"].update(lost={"capacity_J_per_K": 10.0}),
            r"\['lost'\] are not connected to the air",
        ),
        (
            lambda d: d["roles"].update(tool="nose"),
            r"role 'tool': unknown node 'nose'",
        ),
        (
            lambda d: d["displacement"].update(x={"spindle": 1.0}),
            r"displacement: the table 'x' names no axis of the machine",
        ),
        (
            lambda d: d["displacement"].update(typo_um=0.2),
            r"displacement: unknown field 'typo_um'",
        ),
        (
            lambda d: d["displacement"][d["axes"][0]].update(noise_um=0.2),
            r"noise_um is a field of \[displacement\] itself",
        ),
        (
            lambda d: d["heat"]["bearing"].update(W_at_1000rpm=3.0),
            r"heat source 'bearing': unknown field 'W_at_1000rpm' "
            r"\(did you mean 'W_at_1000_rpm'",
        ),
        (
            lambda d: d["sensors"]["T1_C"].update(kind="surfce"),
            r"kind 'surfce' \(did you mean 'surface'",
        ),
        (
            lambda d: d.update(groups={"g": ["T2_C"]}),
            r"group 'g': unknown sensor 'T2_C'",
        ),
        (
            lambda d: d["nodes"]["spindle"].update(capacity_J_per_K="2 kJ/K"),
            r"node 'spindle': capacity_J_per_K must be a number",
        ),
        (
            lambda d: d.update(nodes=3),
            r"nodes must be a table with one entry per node",
        ),
        (
            lambda d: d.update(links={"between": ["spindle", "housing"]}),
            r"links must be a list of tables",
        ),
        (
            lambda d: d.update(axes="z"),
            r"axes must be a list of names",
        ),
        (
            lambda d: d["heat"].update(custom={"pump": {"node": "bse", "W": 5.0}}),
            r"heat source 'pump': unknown node 'bse'",
        ),
        (
            lambda d: d["heat"].update(custom={"pump": {"node": "air", "Watts": 5.0}}),
            r"heat source 'pump': unknown field 'Watts'",
        ),
        (
            lambda d: d["heat"].update(custom={"bearing": {"node": "air"}}),
            r"heat source 'bearing': the name is taken by a built-in source",
        ),
        (
            lambda d: d["sensors"]["T1_C"].update(noise_C=-0.1),
            r"sensor 'T1_C': noise_C must not be negative",
        ),
        (
            lambda d: d["sensors"]["T1_C"].update(noise_c=0.1),
            r"sensor 'T1_C': unknown field 'noise_c' \(did you mean 'noise_C'",
        ),
        (
            lambda d: d["sensors"]["T1_C"].update(node="spindle"),
            r"sensor 'T1_C': give either node .* or weights",
        ),
        (
            lambda d: d["sensors"].update(T2_C={"node": "spindel"}),
            r"sensor 'T2_C': unknown node 'spindel' \(did you mean 'spindle'",
        ),
        (
            lambda d: d["sensors"].update(T2_C={"node": ["spindle"]}),
            r"sensor 'T2_C': node must be a node name",
        ),
        (
            lambda d: d["sensors"]["T1_C"].update(
                weights={"housing": -0.8, "room": 0.2}
            ),
            r"sensor 'T1_C': weight of 'housing' must not be negative, got -0.8",
        ),
        (
            lambda d: d["sensors"]["T1_C"].update(weights={"housing": 0.0}),
            r"sensor 'T1_C': the weights must sum to 1 .*, got 0\.$",
        ),
        (
            lambda d: d["sensors"]["T1_C"].update(weights={"housing": 5.0}),
            r"sensor 'T1_C': the weights must sum to 1 .*, got 5\.$",
        ),
        (
            lambda d: d["sensors"]["T1_C"].update(
                weights={"housing": 0.5, "room": 0.2}
            ),
            r"sensor 'T1_C': the weights must sum to 1 .*got 0.5 \+ 0.2 = 0.7",
        ),
        (
            lambda d: d["sensors"].update(T3={"node": "housing"}),
            r"sensor 'T3': .* named T<name>_C .*\(did you mean 'T3_C'\?\)",
        ),
        (
            # An independent check: no hint, where a run-table column of the
            # same name got one.
            lambda d: d["sensors"].update(T_fb_C={"node": "housing"}),
            r"sensor 'T_fb_C': .* named T<name>_C .*\(did you mean 'Tfb_C'\?\)",
        ),
        (
            lambda d: d["sensors"].update(disp_q_um={"node": "housing"}),
            r"sensor 'disp_q_um': .*'disp_q_um' is a displacement column",
        ),
        (
            lambda d: d.update(axes=["z-1"], displacement={}),
            r"axis 'z-1': a displacement channel name is letters and digits",
        ),
        (
            lambda d: d["heat"].update(drive={"node": "spindel"}),
            r"^heat source 'drive': unknown node 'spindel' \(did you mean 'spindle'",
        ),
        (
            lambda d: d["heat"].update(
                feed={"screw": ["housing"], "nut": "nutt", "axis": "z"}
            ),
            r"^heat source 'feed': nut: unknown node 'nutt'",
        ),
        (
            lambda d: d["heat"].update(feed={"screw": ["housing"], "axis": "y"}),
            r"^heat source 'feed': axis: unknown axis 'y'",
        ),
        (
            lambda d: d["roles"].update(head=["spindel"]),
            r"^roles: head: unknown node 'spindel'",
        ),
        (
            lambda d: d["roles"].pop("enclosure"),
            r"^roles: enclosure is required .*; nodes: \['spindle', 'housing', 'air'\]",
        ),
        (
            lambda d: d["heat"]["bearing"].update(alpha=9.0),
            r"^heat source 'bearing', field 'alpha': parameter 'q.alpha' .*must "
            r"lie in \[0.5, 3\], got 9.0",
        ),
        (
            lambda d: d["heat"]["bearing"].update(W_at_1000_rpm=-1.0),
            r"^heat source 'bearing', field 'W_at_1000_rpm': parameter "
            r"'q.bearing_W' is a heat input and must not be negative",
        ),
        (
            lambda d: d.update(effects={"sensor_lag": {"on": "yes"}}),
            r"effect 'sensor_lag': on must be true or false, got 'yes'",
        ),
        (
            lambda d: d.update(effects={"sensor_lag": {"tau_s": 0.0}}),
            r"effect 'sensor_lag'.*'sensor_lag.tau_s' must lie in \(0, 86400\] s",
        ),
        (
            # Milliseconds for seconds: a lag of 2.8 h would pass, 2.8e3 h not.
            lambda d: d.update(effects={"sensor_lag": {"tau_s": 1e7}}),
            r"'sensor_lag.tau_s' must lie in \(0, 86400\] s \(up to a day\), got "
            r"10000000.0; a sensor lags its part by seconds to minutes\.$",
        ),
        (
            lambda d: d.update(effects={"speed_convection": {"exponent": 8.0}}),
            r"'speed_convection.exponent' must lie in \[0, 2\], got 8.0; forced",
        ),
        (
            lambda d: d["roles"].update(tool="air"),
            r"^role 'tool' \(the tool or test bar\) is the enclosure 'air', the "
            r"air node around the machine; give it a solid node\.$",
        ),
        (
            lambda d: d["heat"]["bearing"].update(node="air"),
            r"^role 'bearing' \(the node the spindle bearings heat\) is the "
            r"enclosure 'air'",
        ),
        (
            lambda d: d["roles"].update(head=["spindle", "air"]),
            r"^roles: head \(nodes whose convection grows with speed\) lists the "
            r"enclosure 'air'",
        ),
        (
            lambda d: d["roles"].update(exposed=["air"]),
            r"^roles: exposed .* lists the enclosure 'air'",
        ),
        (
            # A unit typo in a link is named by the link's nodes.
            lambda d: d["links"][0].update(
                conductance_W_per_m_K=d["links"][0].pop("conductance_W_per_K")
            ),
            r"^link 'spindle-housing': unknown field 'conductance_W_per_m_K' "
            r"\(did you mean 'conductance_W_per_K'\?\)",
        ),
        (
            lambda d: d.update(params={"q.bearng_W": 3.0}),
            r"Unknown parameter\(s\) 'q.bearng_W' \(did you mean 'q.bearing_W'\?\)",
        ),
        (
            lambda d: d["displacement"]["z"].update(housng=1.0),
            r"displacement 'z': unknown node 'housng' \(did you mean 'housing'",
        ),
        (
            lambda d: d["displacement"]["z"].update(screw=1.0),
            r"^displacement 'z': screw: the ball screw's growth counts only on a "
            r"machine with a ball screw \(\[heat.feed\] screw = \[...\]\), "
            "which this machine has not",
        ),
        (
            # Without a ball screw, 'screw' is not offered among the nodes.
            lambda d: d["displacement"]["z"].update(scerw=1.0),
            r"unknown node 'scerw'; known: \['air', 'housing', 'spindle'\]\.$",
        ),
        (
            # Left out, the bearings' heat went to the tool node silently.
            lambda d: d["heat"]["bearing"].pop("node"),
            r"^heat source 'bearing': node is required \(the node it heats\)",
        ),
        (
            lambda d: d["heat"].update(hydraulic={"node": "housing"}),
            r"heat: unknown field 'hydraulic'.*Another heat source \(a pump, a "
            r"hydraulic unit\) is \[heat.custom.hydraulic\]",
        ),
        (
            # Column names for axes blamed the feed axis ("unknown axis 'z'").
            lambda d: (
                d.update(axes=["disp_z_um"])
                or d["heat"].update(feed={"screw": ["housing"], "axis": "z"})
            ),
            r"^axis 'disp_z_um': .* 'disp_z_um' is a column: give 'z'\.$",
        ),
        (
            # A node named twice in a role list loaded silently.
            lambda d: d["roles"].update(head=["spindle", "spindle"]),
            r"^roles: head lists 'spindle' twice\.$",
        ),
        (
            lambda d: d["heat"].update(
                feed={"screw": ["housing"], "axis": "z", "W_per_m_min": 5.0}
            ),
            r"^heat source 'feed': unknown field 'W_per_m_min'.*"
            r"\[effects.feed_heating\] W_per_m_min",
        ),
    ],
)
def test_bad_specs_name_the_entry(edit, message):
    data = _small()
    edit(data)
    with pytest.raises(ValueError, match=message):
        MachineSpec.from_dict(data)


def test_bad_toml_file_names_the_file(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text('name = "x"\n[nodes.a]\ncapacity_J_per_K = 1.0\n[[links]]\n')
    with pytest.raises(ValueError, match=r"bad.toml: link 1: 'between'"):
        ThermalMachine.from_spec(path)
    path.write_text("name = ")
    with pytest.raises(ValueError, match=r"bad.toml: not a valid TOML"):
        ThermalMachine.from_spec(path)
    with pytest.raises(FileNotFoundError, match="missing.toml"):
        ThermalMachine.from_spec(tmp_path / "missing.toml")


def test_unreadable_machine_files_give_one_clear_error(tmp_path):
    path = tmp_path / "latin1.toml"
    path.write_bytes('name = "Fräse"\n'.encode("latin-1"))
    with pytest.raises(ValueError, match=r"latin1.toml: not a UTF-8 text file"):
        ThermalMachine.from_spec(path)
    with pytest.raises(IsADirectoryError, match=r"a directory, not a machine file"):
        ThermalMachine.from_spec(tmp_path)


def test_a_range_error_in_a_file_names_the_file_and_the_entry(tmp_path):
    path = tmp_path / "rig.toml"
    text = MachineSpec.from_dict(_small()).to_toml()
    path.write_text(text.replace("alpha = 1.5", "alpha = 9.0"), encoding="utf-8")
    with pytest.raises(
        ValueError,
        match=r"rig.toml: heat source 'bearing', field 'alpha': parameter 'q.alpha'",
    ):
        ThermalMachine.from_spec(path)


def test_sensor_noise_figures_are_checked_against_a_slip():
    # A noise of 20 °C (meant 0.02) was accepted; the readings carried it,
    # and the only word came later: the air "in Fahrenheit?".
    data = {**_small(), "sensor_noise": {"noise_C": 20.0}}
    with pytest.raises(ValueError, match=r"sensor_noise, field 'noise_C'.* \[0, 5\]"):
        MachineSpec.from_dict(data)
    data = {**_small(), "params": {"disp.noise_um": 500.0}}
    with pytest.raises(ValueError, match=r"'disp.noise_um' must lie in \[0, 100\]"):
        MachineSpec.from_dict(data)
    data = _small()
    data["sensors"]["T1_C"]["offset_C"] = 15.0
    with pytest.raises(ValueError, match=r"T1_C.*offset_C must lie in \[0, 5\] °C"):
        MachineSpec.from_dict(data)
    data["sensors"]["T1_C"]["offset_C"] = 0.2
    MachineSpec.from_dict(data)


def test_a_simulation_far_hotter_than_any_machine_warns():
    # A heat input in kW written as W: the part reached 453 °C without a word.
    data = _small()
    data["heat"]["bearing"]["W_at_1000_rpm"] = 4000.0
    machine = ThermalMachine.from_spec(MachineSpec.from_dict(data), effects=[])
    t = np.arange(0.0, 4 * 3600.0, 60.0)
    with pytest.warns(UserWarning, match=r"node 'spindle' rises \d+ K above the air"):
        machine.simulate_drivers(t, np.full(t.size, 8000.0), np.full(t.size, 20.0))
    ok = ThermalMachine.from_spec(MachineSpec.from_dict(_small()), effects=[])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ok.simulate_drivers(t, np.full(t.size, 8000.0), np.full(t.size, 20.0))


def test_numpy_numbers_in_a_dict_spec_are_numbers(tmp_path):
    data = _small()
    data["nodes"]["spindle"]["capacity_J_per_K"] = np.int64(2000)
    data["heat"]["bearing"]["W_at_1000_rpm"] = np.float32(4.0)
    data["sensors"]["T1_C"]["weights"] = {"housing": np.float64(0.8), "room": 0.2}
    spec = MachineSpec.from_dict(data)
    assert spec.params["C.spindle"] == 2000.0 and spec.params["q.bearing_W"] == 4.0
    path = tmp_path / "m.toml"
    spec.to_toml(path)
    assert MachineSpec.from_toml(path) == spec
    data["heat"]["bearing"]["alpha"] = np.bool_(True)
    with pytest.raises(
        ValueError, match="heat source 'bearing': alpha must be a number"
    ):
        MachineSpec.from_dict(data)


def test_toml_writer_reads_back_exactly():
    spec = ThermalMachine.from_preset("vmc-b").spec
    text = spec.to_toml()
    assert tomllib.loads(text) == spec.to_dict()


def test_spec_built_in_python_is_checked():
    with pytest.raises(ValueError, match="unknown node 'b'"):
        MachineSpec("m", "", ("a", "enclosure"), (("a", "b"),), ())
    with pytest.raises(ValueError, match="sensor 'T1_C': unknown node"):
        MachineSpec(
            "m",
            "",
            ("tool", "enclosure", "bearings", "motor", "carrier2"),
            (),
            (SensorSpec("T1_C", {"toll": 1.0}),),
        )


def test_spindle_rig_preset_matches_the_fl_thermal_layout():
    rig = ThermalMachine.from_preset("spindle-rig")
    assert rig.sensors == [f"T{i}_C" for i in range(1, 17)]
    assert rig.targets == [f"disp_ch{i}_um" for i in range(1, 6)]
    run = rig.simulate(DUTY, 20.0, random_state=0)
    values = run.iloc[:, 2:].to_numpy(float)
    assert np.all(np.isfinite(values))
    assert np.abs(run[rig.targets].to_numpy()).max() > 5.0  # µm, not nothing
    assert rig.node_time_constants()["base"] > rig.node_time_constants()["spindle"]


@pytest.mark.parametrize("name", ["vmc-b", "spindle-rig"])
def test_response_and_read_reproduce_the_noiseless_simulation(name):
    machine = ThermalMachine.from_preset(name, effects=list(EFFECTS))
    sim = machine.simulate(DUTY, 20.0, noise=False)
    drivers = (sim["time_s"], sim["spindle_rpm"], sim["ambient_C"], sim["feed_mm_min"])
    T = machine.response(*drivers)
    values = machine.read(T, sim["ambient_C"], sample_period_s=30.0)
    expected = sim[machine.sensors + machine.targets].to_numpy()
    np.testing.assert_allclose(values, expected, atol=1e-9)
    parts = machine.response(*drivers, by_source=True)
    np.testing.assert_allclose(sum(parts.values()), T, atol=1e-9)
    with pytest.raises(ValueError, match="does not predict"):
        machine.read(T, sim["ambient_C"], ["T99_C"], sample_period_s=30.0)
    holed = T.copy()
    holed[7, 2] = np.nan
    with pytest.raises(ValueError, match="node_T holds a value that is not finite"):
        machine.read(holed, sim["ambient_C"], sample_period_s=30.0)
    air = sim["ambient_C"].to_numpy(copy=True)
    air[4] = np.inf
    with pytest.raises(ValueError, match=r"ambient_C .* not finite .* row 4"):
        machine.read(T, air, sample_period_s=30.0)


def test_one_recursion_over_speed_steps_equals_one_per_step():
    """Without an effect that makes the network follow the speed, a run
    integrates in one recursion; with one whose convection does not change
    (speed_convection at gain 0) it integrates step by step: the same."""
    still = ThermalMachine.from_preset("vmc-b", effects=["feed_heating"])
    stepped = ThermalMachine.from_preset(
        "vmc-b", effects=["feed_heating", "speed_convection"]
    ).with_params({"speed_convection.gain": 0.0})
    sim = still.simulate(DUTY, 20.0, noise=False)
    drivers = (sim["time_s"], sim["spindle_rpm"], sim["ambient_C"], sim["feed_mm_min"])
    np.testing.assert_allclose(
        still.response(*drivers, initial="steady"),
        stepped.response(*drivers, initial="steady"),
        rtol=1e-9,
        atol=1e-9,
    )
    a = still.response(*drivers, initial="steady", by_source=True)
    b = stepped.response(*drivers, initial="steady", by_source=True)
    assert list(a) == list(b) == ["air", "bearing", "drive", "feed"]
    for source in a:
        np.testing.assert_allclose(a[source], b[source], rtol=1e-9, atol=1e-9)
    # With a gain the convection follows the speed, and the response changes.
    cooled = stepped.with_params({"speed_convection.gain": 0.5})
    assert np.abs(cooled.response(*drivers) - still.response(*drivers)).max() > 0.1


def test_with_params_is_the_machine_built_with_those_params():
    """with_params checks only the changed values, yet gives the machine the
    constructor builds, and still refuses bad values and joint rules."""
    machine = ThermalMachine.from_preset("spindle-rig", effects=list(EFFECTS))
    sim = machine.simulate(DUTY, 20.0, noise=False)  # fills the caches
    cap = next(k for k in machine.params if k.startswith("C."))
    change = {cap: 2.0 * machine.params[cap], "speed_convection.gain": 0.5}
    fast = machine.with_params(change)
    built = ThermalMachine(machine.spec, {**machine.params, **change}, machine.effects)
    assert fast.params == built.params
    pd.testing.assert_frame_equal(
        fast.simulate(DUTY, 20.0, noise=False), built.simulate(DUTY, 20.0, noise=False)
    )
    assert not sim.equals(fast.simulate(DUTY, 20.0, noise=False))
    with pytest.raises(ValueError, match="must be positive"):
        machine.with_params({cap: -1.0})
    with pytest.raises(ValueError, match="must not exceed 1"):
        machine.with_params(
            {"feed_heating.nut_share": 0.8, "feed_heating.motor_share": 0.7}
        )


def test_an_effect_is_one_class(monkeypatch):
    """A new effect needs only its class: parameters, checks and physics."""

    class Coolant(Effect):
        name = "coolant"
        summary = "Coolant takes heat out of the spindle while it turns."
        params = {"hA": 3.0}
        units = {"hA": "W/K"}
        diagnosis_parameter = "coolant.hA"

        def convection(self, machine, p, rpm, h):
            if rpm > 0:
                h[machine.node_index[machine.spec.bearing]] += p["coolant.hA"]
            return h

    monkeypatch.setitem(EFFECTS, "coolant", Coolant())
    base = ThermalMachine.from_preset("spindle-rig", effects=[])
    cooled = base.with_effects(add=["coolant"])
    hot = base.simulate(DUTY, 20.0, noise=False)
    cool = cooled.simulate(DUTY, 20.0, noise=False)
    assert cool["T9_C"].iloc[90] < hot["T9_C"].iloc[90] - 0.1
    with pytest.raises(ValueError, match="'coolant.hA' must not be negative"):
        cooled.with_params({"coolant.hA": -1.0})


def test_every_effect_declares_its_diagnosis_parameter():
    for name, effect in EFFECTS.items():
        assert isinstance(effect, Effect) and effect.name == name
        p = effect.diagnosis_parameter
        assert p is None or p.split(".", 1)[1] in effect.params


def test_gap_uses_only_the_public_simulator_api():
    root = Path(__file__).parents[1] / "skthermal" / "gap"
    private = {"_cache", "_integrate", "_displacement_array", "_on", "_heat", "_params"}
    for path in root.glob("*.py"):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            if isinstance(node, ast.Attribute):
                assert node.attr not in private, f"{path.name} uses .{node.attr}"
            if isinstance(node, ast.ImportFrom) and node.module:
                assert not node.module.startswith("skthermal.simulate."), path.name


def test_a_calibrated_machine_is_written_back(tmp_path):
    machine = ThermalMachine.from_preset("spindle-rig").with_params(
        {"q.bearing_W": 4.5, "sensor_lag.tau_s": 300.0}
    )
    path = tmp_path / "calibrated.toml"
    machine.to_spec().to_toml(path)
    again = ThermalMachine.from_spec(path, effects=machine.effects)
    assert again.params == machine.params


@pytest.mark.parametrize(
    "effects", [[], ["sensor_lag", "sensor_drift"], list(EFFECTS)], ids=repr
)
def test_a_machine_round_trips_with_its_effects(effects, tmp_path):
    machine = ThermalMachine.from_preset("spindle-rig", effects=effects).with_params(
        {
            "q.bearing_W": 4.5,
            "sensor_lag.tau_s": 300.0,
            "sensor_drift.rate_C_per_h": 0.2,
        }
    )
    spec = machine.to_spec()
    assert spec.effects == {e: e in effects for e in EFFECTS}
    path = tmp_path / "calibrated.toml"
    spec.to_toml(path)
    expected = machine.simulate(DUTY, 20.0, random_state=0)
    for again in (
        ThermalMachine.from_spec(spec),
        ThermalMachine.from_spec(spec.to_dict()),
        ThermalMachine.from_spec(path),
    ):
        assert again.effects == machine.effects
        assert again.params == machine.params
        run = again.simulate(DUTY, 20.0, random_state=0)
        pd.testing.assert_frame_equal(run, expected, check_exact=True)
        assert run.attrs["metadata"] == expected.attrs["metadata"]
    # Effects given explicitly still replace the recorded switches.
    assert ThermalMachine.from_spec(path, effects=["tool_growth"]).effects == (
        "tool_growth",
    )


def test_effect_switches_in_a_file_and_files_without_them():
    data = _small()
    # Every effect but sensor_drift, less those that cannot act on this
    # machine: it has no ball screw and no node washed by the workshop air.
    default = ("sensor_lag", "speed_convection", "tool_growth")
    assert ThermalMachine.from_spec(data).effects == default
    data["effects"] = {
        "sensor_drift": {"on": True},
        "sensor_lag": {"on": False, "tau_s": 100.0},
    }
    spec = MachineSpec.from_dict(data)
    assert spec.effects == {"sensor_drift": True, "sensor_lag": False}
    machine = ThermalMachine.from_spec(spec)
    # Recorded switches apply; the effects not recorded keep their default.
    assert machine.effects == (*default[1:], "sensor_drift")
    assert machine.params["sensor_lag.tau_s"] == 100.0
    assert MachineSpec.from_dict(spec.to_dict()) == spec
    assert tomllib.loads(spec.to_toml())["effects"]["sensor_lag"]["on"] is False


def test_an_effect_that_cannot_act_is_off_by_default_and_warns_when_asked():
    """The rig has no ball screw: feed_heating is not on by default, and
    switching it on (argument, file or with_effects) warns with the reason."""
    rig = ThermalMachine.from_preset("spindle-rig")
    assert "feed_heating" not in rig.effects
    assert rig.effect_status()["sensor_lag"]
    with pytest.warns(
        UserWarning,
        match="'feed_heating' is switched on but does nothing: the machine has "
        "no ball screw",
    ) as record:
        ThermalMachine.from_preset("spindle-rig", effects=["feed_heating"])
    assert record[0].filename == __file__  # the user's line
    with pytest.warns(UserWarning, match="'feed_heating'.*no ball screw"):
        on = rig.with_effects(add=["feed_heating"])
    assert "feed_heating" in on.effects
    with pytest.warns(UserWarning, match="'feed_heating'.*no ball screw"):
        ThermalMachine.from_spec(on.to_spec())
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        on.with_effects(remove=["sensor_lag"])  # nothing newly switched on
        ThermalMachine.from_spec(rig.to_spec())


def test_without_axes_the_axes_are_the_displacement_tables():
    # An independent check: a lathe's file with [displacement.z] and
    # [displacement.x] and no axes got x, y and z, a spurious disp_y_um
    # channel of noise alone (said by a warning only).
    data = _small()
    del data["axes"]
    data["displacement"] = {"z": {"spindle": 2.0}, "x": {"housing": 1.0}}
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        spec = MachineSpec.from_dict(data)
    assert spec.axes == ("z", "x")
    del data["displacement"]
    assert MachineSpec.from_dict(data).axes == ("x", "y", "z")


def test_an_axis_without_coefficients_or_a_machine_without_heat_warns():
    data = _small()
    data["axes"] = ["z", "w"]  # no [displacement.w]
    with pytest.warns(
        UserWarning,
        match=r"axis 'w' has no thermo-elastic coefficient .* disp_w_um would be "
        "sensor noise alone",
    ):
        ThermalMachine.from_spec(data)
    data = _small()
    del data["heat"]
    with pytest.warns(UserWarning, match=r"no heat source has any power") as record:
        ThermalMachine.from_spec(data)
    assert record[0].filename == __file__
    # A custom source is heat too.
    data["heat"] = {"custom": {"cabinet": {"node": "air", "W_constant": 50.0}}}
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ThermalMachine.from_spec(data)


def test_a_node_that_fills_in_a_blink_warns_of_a_unit_slip():
    # A capacity given in kJ/K where J/K is meant (1000 times too small)
    # simulated without a word; every preset's nodes take a minute or more.
    data = _small()
    data["nodes"]["spindle"]["capacity_J_per_K"] = 2.0
    with pytest.warns(
        UserWarning,
        match=r"node 'spindle' takes up heat in 0.36 s \(capacity 2 J/K against "
        r"5.5 W/K .*J/K, not kJ/K",
    ):
        ThermalMachine.from_spec(data, effects=[])
    # An independent check's motor of 12 kJ/K written as 12 J/K filled in
    # 1.3 s, past the warning (then at 1 s).
    data["nodes"]["spindle"]["capacity_J_per_K"] = 12.0
    with pytest.warns(UserWarning, match=r"node 'spindle' takes up heat in 2.2 s"):
        ThermalMachine.from_spec(data, effects=[])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ThermalMachine.from_spec(_small(), effects=[])
        for preset in ("vmc-b", "vmc-a", "spindle-rig"):
            ThermalMachine.from_preset(preset)


def test_unknown_parameter_names_are_rejected_on_every_path():
    machine = ThermalMachine.from_spec(_small(), effects=["sensor_lag"])
    runs = machine.simulate(DutyCycle([(600, 1000)]), noise=False)
    hint = r"'sensor_lag.tauu' \(did you mean 'sensor_lag.tau_s'\?\)"
    for call in (
        lambda: ThermalMachine.from_spec(_small(), params={"sensor_lag.tauu": 5.0}),
        lambda: ThermalMachine.from_preset("vmc-b", params={"sensor_lag.tauu": 5.0}),
        lambda: machine.with_params({"sensor_lag.tauu": 5.0}),
        lambda: machine.calibrate(runs, ["sensor_lag.tauu"]),
        lambda: MachineSpec.from_dict({**_small(), "params": {"sensor_lag.tauu": 5.0}}),
    ):
        with pytest.raises(ValueError, match=rf"Unknown parameter\(s\) {hint}"):
            call()
    # A name of the structure that the machine leaves at its default is known.
    data = _small()
    data["heat"]["custom"] = {"pump": {"node": "housing"}}
    pump = ThermalMachine.from_spec(data, effects=[]).with_params({"q.pump.W": 2.0})
    assert pump.params["q.pump.W"] == 2.0


def test_a_spec_built_in_python_needs_only_the_network_numbers():
    spec = MachineSpec(
        name="bare",
        description="",
        nodes=("tool", "housing", "enclosure"),
        edges=(("tool", "housing"), ("housing", "enclosure")),
        sensors=(SensorSpec("T1_C", {"tool": 1.0}),),
        bearing="tool",
        motor="tool",
        belt="tool",
        axes=("z",),
        params={
            "C.tool": 500.0,
            "C.housing": 5000.0,
            "C.enclosure": 5000.0,
            "hA.enclosure": 10.0,
            "G.tool-housing": 2.0,
            "G.housing-enclosure": 2.0,
            "q.bearing_W": 5.0,
            "k.z.housing": 1.0,
        },
    )
    run = ThermalMachine.from_spec(spec, effects=[]).simulate(DUTY, noise=False)
    assert run["T1_C"].iloc[60] > 20.5 and run["disp_z_um"].iloc[60] > 0.5


def test_network_and_heat_inputs_are_public():
    rig = ThermalMachine.from_preset("spindle-rig", effects=[])
    C, K, h_room = rig.network(3000.0)
    assert C.shape == (9,) and K.shape == (9, 9) and np.allclose(K, K.T)
    assert h_room[rig.node_index["air"]] == rig.params["hA.air"]
    heat = rig.heat_inputs([0.0, 1000.0])
    assert heat.loc[1, "front_bearing"] == pytest.approx(rig.params["q.bearing_W"])
    assert heat.loc[0].sum() == 0.0


def test_custom_heat_source_heats_its_node_and_round_trips(tmp_path):
    data = _small()
    data["heat"]["custom"] = {
        "pump": {"node": "housing", "W_constant": 6.0, "W_per_m_min": 2.0},
        "fan": {"node": "spindle", "W_at_1000_rpm": 1.0, "alpha": 2.0},
    }
    machine = ThermalMachine.from_spec(data, effects=[])
    heat = machine.heat_inputs([0.0, 2000.0], feed_mm_min=[3000.0, 0.0])
    # pump: 6 W always + 2 W per m/min of feed; fan: (n/1000)^2 W, plus the
    # bearing's 4 W (n/1000)^1.5 on the same node.
    np.testing.assert_allclose(heat["housing"], [6.0 + 6.0, 6.0])
    np.testing.assert_allclose(heat["spindle"], [0.0, 4.0 + 4 * 2**1.5])
    spec = machine.spec
    assert spec.custom_heat == {"pump": "housing", "fan": "spindle"}
    assert MachineSpec.from_dict(spec.to_dict()) == spec
    path = tmp_path / "m.toml"
    spec.to_toml(path)
    again = ThermalMachine.from_spec(path, effects=[])
    pd.testing.assert_frame_equal(
        again.simulate(DUTY, 20.0, noise=False),
        machine.simulate(DUTY, 20.0, noise=False),
    )
    # The source heats the machine even with the spindle off.
    idle = machine.simulate(DutyCycle([(7200, 0)]), 20.0, noise=False)
    assert idle["T1_C"].iloc[-1] > 20.05
    # Its |feed| term is part of the "feed" response, the rest of the
    # "drive" response (the gap diagnosis gives each part its own gains);
    # the parts still sum up.
    t = np.arange(61) * 60.0
    rpm, air = np.full(61, 2000.0), np.full(61, 20.0)
    feed = np.where(t < 1800, 3000.0, 0.0)
    parts = machine.response(t, rpm, air, feed, by_source=True)
    np.testing.assert_allclose(sum(parts.values()), machine.response(t, rpm, air, feed))
    without_pump_feed = machine.with_params({"q.pump.W_per_m_min": 0.0})
    np.testing.assert_allclose(
        parts["drive"], without_pump_feed.response(t, rpm, air, by_source=True)["drive"]
    )
    assert parts["feed"][-1, machine.node_index["housing"]] > 0.1
    assert "feed" not in machine.response(t, rpm, air, by_source=True)


def test_per_sensor_noise_overrides_the_machine_figures():
    data = _small()
    data["sensor_noise"] = {"noise_C": 0.0, "quantization_C": 0.0}
    data["sensors"]["T2_C"] = {
        "weights": {"housing": 1.0},
        "noise_C": 0.5,
        "quantization_C": 0.25,
    }
    machine = ThermalMachine.from_spec(data, effects=[])
    run = machine.simulate(DUTY, 20.0, random_state=0)
    quiet = machine.simulate(DUTY, 20.0, noise=False)
    # T1_C takes the machine's figures (no noise, no step): exact.
    np.testing.assert_allclose(run["T1_C"], quiet["T1_C"], atol=1e-12)
    # T2_C has its own noise and reads in steps of 0.25 °C.
    residual = run["T2_C"] - quiet["T2_C"]
    assert 0.3 < residual.std() < 0.7
    np.testing.assert_allclose(run["T2_C"] / 0.25, np.round(run["T2_C"] / 0.25))
    by_name = {s.name: s for s in machine.spec.sensors}
    assert by_name["T2_C"].noise_C == 0.5 and by_name["T1_C"].noise_C is None
    assert MachineSpec.from_dict(machine.spec.to_dict()) == machine.spec


def test_decimal_quantisation_steps_read_as_a_logger_writes_them():
    # Steps of 0.01 °C (the spindle rig) and 0.1 °C give readings with that
    # many decimals, as a logger's file has them (20.08, not
    # 20.080000000000002); a binary step (0.125) is unchanged, and so is a
    # step with no short decimal form.
    rig = ThermalMachine.from_preset("spindle-rig")
    run = rig.simulate(DUTY, 20.0, random_state=0)
    temps = run.filter(regex="_C$")
    decimals = temps.map(lambda v: len(repr(float(v)).split(".")[1]))
    assert temps.shape[1] > 10 and (decimals <= 2).all().all()
    data = _small()
    for step, decimals in [(0.1, 1), (0.125, 3), (0.005, 3)]:
        data["sensor_noise"] = {"noise_C": 0.3, "quantization_C": step}
        run = ThermalMachine.from_spec(data, effects=[]).simulate(
            DUTY, 20.0, random_state=1
        )
        values = run.filter(regex="_C$").to_numpy()
        np.testing.assert_array_equal(values, np.round(values, decimals))
        np.testing.assert_allclose(values / step, np.round(values / step), atol=1e-9)
    data["sensor_noise"] = {"noise_C": 0.3, "quantization_C": 1 / 3}
    machine = ThermalMachine.from_spec(data, effects=[])
    run = machine.simulate(DUTY, 20.0, random_state=1)
    values = run.filter(regex="_C$").to_numpy()
    np.testing.assert_allclose(values * 3, np.round(values * 3), atol=1e-9)


def test_parameters_that_cut_a_node_off_are_refused_at_construction():
    # As the spec itself would: a machine that cannot be saved or solved is
    # not made at all.
    from skthermal.simulate import ThermalMachine

    rig = ThermalMachine.from_preset("spindle-rig")
    with pytest.raises(ValueError, match=r"node\(s\) \['nose'\] are not connected"):
        rig.with_params({"G.spindle-nose": 0.0, "hA.nose": 0.0})
    with pytest.raises(ValueError, match="'air' .* needs a positive convection"):
        rig.with_params({"hA.air": 0.0})


# --- audit fixes: ranges, TOML text, names and types -----------------------------


@pytest.mark.parametrize("name", ["vmc-b", "vmc-a", "spindle-rig"])
def test_parameter_range_is_the_rule_check_parameters_applies(name):
    # One home for the ranges: every value at an edge passes the check, every
    # value just outside fails it, for every parameter (effects' included).
    from skthermal.simulate._spec import check_parameters, parameter_range

    machine = ThermalMachine.from_preset(name)
    spec, params = machine.spec, machine.params
    assert str(parameter_range("q.alpha")) == "[0.5, 3]"
    assert str(parameter_range("feed_heating.measure_at")) == "[0, 1]"
    assert str(parameter_range("C.x")) == "(0, inf)"
    for key in params:
        valid = parameter_range(key)
        inside = [valid.high] if np.isfinite(valid.high) else []
        outside = [valid.high + 1e-3] if np.isfinite(valid.high) else []
        if np.isfinite(valid.low):
            inside.append(valid.low + 1e-3 if valid.low_open else valid.low)
            outside.append(valid.low if valid.low_open else valid.low - 1e-3)
        if key in ("feed_heating.nut_share", "feed_heating.motor_share"):
            inside = [v for v in inside if v <= 0.5]  # their sum is at most 1
            others = {"feed_heating.nut_share": 0.0, "feed_heating.motor_share": 0.0}
        else:
            others = {}
        for value in inside:
            check_parameters(spec, {**params, **others, key: value})
        for value in outside:
            with pytest.raises(ValueError, match=re.escape(repr(key))):
                check_parameters(spec, {**params, **others, key: value})


@pytest.mark.parametrize(
    "edit",
    [
        lambda d: d.__setitem__("description", "line1\r\nline2\ttab\x1besc\x7fdel"),
        lambda d: d.__setitem__("name", 'a"b\\c\x00'),
        lambda d: d["sensors"]["T1_C"].__setitem__("location", "x\x7f\x08\x0c"),
        lambda d: d.__setitem__("groups", {"Spindelköpfe": ["T1_C"], "a.b c": []}),
        lambda d: d["heat"].__setitem__(
            "custom", {"kühlung": {"node": "air", "W": 1.0}}
        ),
    ],
)
def test_to_toml_writes_what_from_toml_reads_back(edit, tmp_path):
    data = _small()
    edit(data)
    spec = MachineSpec.from_dict(data)
    path = tmp_path / "m.toml"
    spec.to_toml(path)
    assert MachineSpec.from_toml(path) == spec
    assert tomllib.loads(spec.to_toml()) == spec.to_dict()


@pytest.mark.parametrize("node", ["gehäuse", "²", "front housing", "Ä-1"])
def test_non_ascii_and_spaced_node_names_are_written_quoted(node, tmp_path):
    data = json.loads(json.dumps(_small()).replace('"housing"', json.dumps(node)))
    spec = MachineSpec.from_dict(data)
    assert node in spec.nodes
    path = tmp_path / "m.toml"
    spec.to_toml(path)
    assert f'[nodes."{node}"]' in path.read_text(encoding="utf-8")
    assert MachineSpec.from_toml(path) == spec


def test_link_parameter_names_cannot_collide():
    data = _small()
    for n in ("a-b", "c", "a", "b-c"):
        data["nodes"][n] = {"capacity_J_per_K": 1000.0, "convection_W_per_K": 1.0}
    data["links"] += [
        {"between": ["a-b", "c"], "conductance_W_per_K": 1.0},
        {"between": ["a", "b-c"], "conductance_W_per_K": 100.0},
    ]
    with pytest.raises(
        ValueError,
        match=r"links \['a-b', 'c'\] and \['a', 'b-c'\] would share the "
        r"conductance parameter 'G.a-b-c'",
    ):
        MachineSpec.from_dict(data)
    data["links"].pop()  # one link with a '-' in a name is fine
    spec = MachineSpec.from_dict(data)
    assert spec.params["G.a-b-c"] == 1.0


@pytest.mark.parametrize(
    "edit, message",
    [
        (
            lambda d: d["roles"].__setitem__("tool", ["spindle"]),
            r"role 'tool' must be a node name, got \['spindle'\]",
        ),
        (
            lambda d: d["roles"].__setitem__("enclosure", {"air": 1}),
            r"role 'enclosure' must be a node name, got \{'air': 1\}",
        ),
        (
            lambda d: d["links"][0].__setitem__("between", [["spindle"], "housing"]),
            r"link 1: 'between' must list two node names, got \[\['spindle'\], "
            r"'housing'\]",
        ),
        (
            lambda d: d["heat"].__setitem__("feed", {"nut": "housing", "axis": "z"}),
            r"\[heat.feed\] needs screw = \[...\]",
        ),
        (
            lambda d: d["heat"].__setitem__("feed", {"screw": []}),
            r"\[heat.feed\] needs screw = \[...\]",
        ),
        (
            lambda d: d.__setitem__("name", {"a": 1}),
            r"name must be a string \(text\), got dict",
        ),
        (
            lambda d: d.__setitem__("description", ["a", "b"]),
            r"description must be a string \(text\), got list",
        ),
        (
            lambda d: d["sensors"]["T1_C"].__setitem__("location", 5),
            r"sensor 'T1_C': location must be a string",
        ),
    ],
)
def test_wrong_types_name_the_entry(edit, message):
    data = _small()
    edit(data)
    with pytest.raises(ValueError, match=message):
        MachineSpec.from_dict(data)


def test_spec_built_in_python_checks_types_and_the_screw():
    nodes = ("tool", "enclosure", "bearings", "motor", "carrier2")
    with pytest.raises(ValueError, match=r"link \[\['tool'\], 'motor'\]"):
        MachineSpec("m", "", nodes, ((["tool"], "motor"),), ())
    with pytest.raises(ValueError, match="role 'nut': feed heating needs the ball"):
        MachineSpec("m", "", nodes, (), (), nut="motor")


def test_a_spec_is_explicitly_unhashable():
    spec = MachineSpec.from_dict(_small())
    assert MachineSpec.__hash__ is None
    with pytest.raises(TypeError, match="unhashable type: 'MachineSpec'"):
        hash(spec)
    assert spec == MachineSpec.from_dict(_small())


def test_an_unquoted_dotted_parameter_name_gets_a_hint(tmp_path):
    spec = MachineSpec.from_dict(_small())
    path = tmp_path / "m.toml"
    path.write_text(
        spec.to_toml() + "\n[params]\nq.bearing_W = 6.0\n", encoding="utf-8"
    )
    with pytest.raises(
        ValueError, match=r"params: 'q' is a table.*write \"q.bearing_W\" = \.\.\."
    ):
        MachineSpec.from_toml(path)
    path.write_text(
        spec.to_toml() + '\n[params]\n"q.bearing_W" = 6.0\n', encoding="utf-8"
    )
    # The quoted name sets the parameter (and says it overrides the entry).
    with pytest.warns(UserWarning, match="overrides heat source 'bearing'"):
        assert MachineSpec.from_toml(path).params["q.bearing_W"] == 6.0


@pytest.mark.parametrize("value", ["5", True, np.True_, b"3"])
def test_parameters_are_numbers_in_python_as_in_files(value):
    # A machine file refuses text and bools for numbers; the Python API took
    # them ("5" as 5.0, True as a heat input of 1 W).
    machine = ThermalMachine.from_preset("vmc-b")
    for call in (
        lambda: machine.with_params({"q.bearing_W": value}),
        lambda: ThermalMachine.from_preset("vmc-b", params={"q.bearing_W": value}),
    ):
        with pytest.raises(ValueError, match="'q.bearing_W' must be a number"):
            call()
    assert machine.with_params({"q.bearing_W": np.array(5.0)}).params[
        "q.bearing_W"
    ] == pytest.approx(5.0)


# --- input-validation fixes: shares, steady state, huge numbers, [params] --------


def _feed_runs(W_per_m_min):
    """Noise-free runs of vmc-a whose nut and axis motor heat as if half of
    ``W_per_m_min`` went to each (the model below has 4 W per m/min)."""
    truth = ThermalMachine.from_preset(
        "vmc-a",
        effects=["feed_heating"],
        params={
            "feed_heating.nut_share": 0.5,
            "feed_heating.motor_share": 0.5,
            "feed_heating.W_per_m_min": W_per_m_min,
        },
    )
    duty = DutyCycle([(3600, 0, 8000), (1800, 0, 0)])
    return truth.simulate(duty, 20.0, noise=False, sample_period_s=60)


def test_a_joint_fit_of_the_feed_shares_gives_a_valid_machine():
    # The nut and the axis motor take fractions of one heat flow: their sum
    # may not exceed 1. Runs that ask for more (four times the model's feed
    # heat into the nut and the motor) drove the fit across that limit, where
    # the machine of the next step was refused mid-fit.
    runs = _feed_runs(16.0)
    model = ThermalMachine.from_preset(
        "vmc-a",
        effects=["feed_heating"],
        params={"feed_heating.nut_share": 0.3, "feed_heating.motor_share": 0.3},
    )
    shares = ["feed_heating.nut_share", "feed_heating.motor_share"]
    for bounds in (None, [(0.0, 1.0), (0.0, 1.0)]):
        fitted, result = model.calibrate(
            runs, shares, bounds, channels=["T21_C", "T24_C"]
        )
        total = sum(fitted.params[k] for k in shares)
        assert total <= 1.0
        assert total == pytest.approx(1.0, abs=1e-6)  # on the limit, as asked
        assert all(result.params[k] > 0.3 for k in shares)
        assert np.all(np.isfinite(result.std_error))
        assert (result.rmse_after < result.rmse_before).all()
        ThermalMachine.from_spec(fitted.to_spec().to_dict())  # written back
    # One share freed: the fixed one leaves it the rest.
    fitted, _ = model.calibrate(
        runs, ["feed_heating.nut_share"], [(0.0, 1.0)], channels=["T21_C"]
    )
    assert fitted.params["feed_heating.nut_share"] <= 0.7
    # Bounds that leave no valid machine are refused up front, naming them.
    with pytest.raises(
        ValueError,
        match=r"bounds of \['feed_heating.nut_share', 'feed_heating.motor_share'\]"
        r".*low bounds sum to 1.1",
    ):
        model.calibrate(runs, shares, [(0.5, 1.0), (0.6, 1.0)], channels=["T21_C"])
    with pytest.raises(ValueError, match=r"= 1.1 must not exceed 1"):
        model.with_params(
            {"feed_heating.nut_share": 0.6, "feed_heating.motor_share": 0.5}
        )


def test_a_joint_fit_of_the_feed_shares_reaches_an_inner_optimum():
    # Where the runs ask for less than the limit, the reparameterised fit
    # finds the same shares as any fit would (the truth, noise-free).
    truth = ThermalMachine.from_preset(
        "vmc-a",
        effects=["feed_heating"],
        params={"feed_heating.nut_share": 0.4, "feed_heating.motor_share": 0.2},
    )
    runs = truth.simulate(DutyCycle([(3600, 0, 8000), (1800, 0, 0)]), 20.0, noise=False)
    model = truth.with_params(
        {"feed_heating.nut_share": 0.25, "feed_heating.motor_share": 0.25}
    )
    shares = ["feed_heating.nut_share", "feed_heating.motor_share"]
    _, result = model.calibrate(runs, shares, channels=["T21_C", "T24_C"])
    assert result.params.to_numpy() == pytest.approx([0.4, 0.2], abs=1e-6)


@pytest.mark.filterwarnings("ignore::skthermal.simulate.ImplausibleDriverWarning")
@pytest.mark.parametrize("rpm", [1e50, 1e100])
def test_a_steady_start_at_an_absurd_speed_names_the_speed(rpm):
    # The steady state solved K T = h T_air + Q at the first speed: at an
    # absurd one the speed-driven convection made K numerically singular,
    # and the error was numpy's "Singular matrix" (or "no path to the air",
    # or "the network is too stiff", naming capacities and conductances).
    m = ThermalMachine.from_preset("spindle-rig")
    t = np.arange(5) * 60.0
    for initial in ("steady", "ambient"):
        with pytest.raises(ValueError) as info:
            m.response(t, np.full(5, rpm), np.full(5, 20.0), initial=initial, run="r7")
        message = str(info.value)
        assert f"spindle speed {rpm:g} rpm (spindle_rpm, run 'r7', row 0)" in message
        assert "plausible range (a spindle turns at up to some 1e+05 rpm)" in message
        assert "no path to the air" not in message
        assert "smallest capacity" not in message
    with pytest.raises(ValueError, match=r"initial='steady': .*spindle_rpm 1e\+50"):
        m.simulate(DutyCycle([(600, 1e50)]), initial="steady", noise=False)
    with pytest.raises(ValueError, match=r"heat input is not finite .*run 'r7', row 0"):
        m.response(t, np.full(5, 1e308), np.full(5, 20.0), initial="steady", run="r7")
    # Speeds a spindle reaches still start steady.
    run = m.simulate(DutyCycle([(3600, 30000)]), initial="steady", noise=False)
    assert np.all(np.isfinite(run.iloc[:, 2:].to_numpy(float)))
    assert np.ptp(run["disp_ch1_um"]) < 1e-6  # it stays put


@pytest.mark.parametrize(
    "edit, entry",
    [
        (
            lambda d: d["nodes"]["spindle"].update(capacity_J_per_K=10**400),
            "node 'spindle': capacity_J_per_K",
        ),
        (
            lambda d: d["nodes"]["housing"].update(convection_W_per_K=10**400),
            "node 'housing': convection_W_per_K",
        ),
        (
            lambda d: d["links"][0].update(conductance_W_per_K=10**400),
            "link 'spindle-housing': conductance_W_per_K",
        ),
        (
            lambda d: d.update(sensor_noise={"noise_C": 10**400}),
            "sensor_noise: noise_C",
        ),
        (
            lambda d: d["sensors"]["T1_C"].update(offset_C=10**400),
            "sensor 'T1_C': offset_C",
        ),
        (
            lambda d: d["sensors"]["T1_C"].update(weights={"housing": 10**400}),
            "sensor 'T1_C': weight of 'housing'",
        ),
        (
            lambda d: d["displacement"]["z"].update(spindle=-(10**400)),
            "displacement 'z': spindle",
        ),
        (
            lambda d: d["heat"]["bearing"].update(W_at_1000_rpm=10**400),
            "heat source 'bearing': W_at_1000_rpm",
        ),
        (
            lambda d: d.update(effects={"sensor_lag": {"tau_s": 10**400}}),
            "effect 'sensor_lag': tau_s",
        ),
        (
            lambda d: d.update(params={"q.cutting_W": 10**400}),
            "heat source 'cutting', field 'W': parameter 'q.cutting_W'",
        ),
    ],
)
def test_an_integer_beyond_a_float_names_the_entry(edit, entry, tmp_path):
    # TOML reads integers exactly: 10**400 reached float() deep inside and
    # raised a bare OverflowError ("int too large to convert to float").
    data = _small()
    edit(data)
    path = tmp_path / "m.toml"
    path.write_text(dumps_toml(data), encoding="utf-8")
    message = re.escape(entry) + r" must be a finite number .*an integer of 401 digits"
    with pytest.raises(ValueError, match=message):
        MachineSpec.from_dict(data)
    with pytest.raises(ValueError, match=re.escape(str(path)) + ": " + message):
        ThermalMachine.from_spec(path)


def test_huge_integers_in_the_python_api_name_the_argument():
    machine = ThermalMachine.from_spec(_small(), effects=[])
    with pytest.raises(ValueError, match=r"'C.spindle' must be a finite number"):
        machine.with_params({"C.spindle": 10**400})
    with pytest.raises(ValueError, match=r"bounds of 'C.spindle': high must be a fin"):
        machine.calibrate(pd.DataFrame({"run": [1]}), ["C.spindle"], [(1, 10**400)])
    with pytest.raises(ValueError, match=r"segment 0: every value must be a finite"):
        DutyCycle([(60, 10**400)])
    t = [0, 60, 120]
    with pytest.raises(ValueError, match=r"spindle_rpm holds an integer too large"):
        machine.simulate_drivers(t, [0, 10**400, 0], [20, 20, 20])
    with pytest.raises(ValueError, match=r"initial holds an integer too large"):
        machine.response(t, [0, 0, 0], [20, 20, 20], initial=[10**400, 20, 20])


@pytest.mark.parametrize(
    "node, value, named",
    [
        ("spindle", 1e-300, r"smallest capacity C.spindle = 1e-300 J/K"),
        ("spindle", 1e300, r"largest capacity C.spindle = 1e\+300 J/K"),
        ("air", 1e-20, r"smallest capacity C.air = 1e-20 J/K"),
    ],
)
def test_absurd_capacities_are_named_not_simulated_silently(node, value, named):
    # A spec holds any positive capacity (a plausibility limit is the
    # command line's, for drivers); the simulation names the one floating
    # point cannot carry. A capacity of 1e300 J/K simulated silently to
    # temperatures below the air with heat flowing in, and 1e-20 J/K on
    # the air node claimed "no path to the air".
    data = _small()
    data["nodes"][node]["capacity_J_per_K"] = value
    machine = ThermalMachine.from_spec(data, effects=[])
    assert machine.params[f"C.{node}"] == value
    for initial in ("ambient", "steady"):
        with pytest.raises(ValueError, match=named):
            machine.simulate(DUTY, 20.0, noise=False, initial=initial)
    data["links"][0]["conductance_W_per_K"] = 1e50
    data["nodes"][node]["capacity_J_per_K"] = 2000.0
    with pytest.raises(ValueError, match=r"largest conductance G.spindle-housing"):
        ThermalMachine.from_spec(data, effects=[]).simulate(DUTY, noise=False)


def test_params_that_repeat_an_entry_warn_naming_both_places(tmp_path):
    # A [params] number that an entry gives too silently won over the entry.
    data = _small()
    data["effects"] = {"sensor_lag": {"tau_s": 100.0}}
    data["params"] = {
        "C.spindle": 3000.0,
        "k.z.housing": 1.0,  # the same value: no override, no warning
        "sensor_lag.tau_s": 10.0,
        "q.cutting_W": 2.0,  # no entry gives it: no warning
    }
    with pytest.warns(UserWarning) as record:
        spec = MachineSpec.from_dict(data)
    messages = [str(w.message) for w in record]
    assert messages == [
        "params: 'C.spindle' = 3000.0 overrides node 'spindle', field "
        "'capacity_J_per_K' = 2000.0 (one parameter, given twice); the [params] "
        "value is used. Give each number in one place.",
        "params: 'sensor_lag.tau_s' = 10.0 overrides effect 'sensor_lag', field "
        "'tau_s' = 100.0 (one parameter, given twice); the [params] value is "
        "used. Give each number in one place.",
    ]
    assert spec.params["C.spindle"] == 3000.0
    assert spec.params["sensor_lag.tau_s"] == 10.0
    path = tmp_path / "m.toml"
    path.write_text(dumps_toml(data), encoding="utf-8")
    with pytest.warns(UserWarning) as record:
        ThermalMachine.from_spec(path)
    assert [str(w.message) for w in record] == [f"{path}: {m}" for m in messages]
    # A written spec gives every number once: it reads back silently.
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        spec.to_toml(path)
        assert MachineSpec.from_toml(path) == spec


def test_share_low_bounds_that_use_all_the_room_leave_nothing_to_fit():
    # Low bounds summing to exactly the room said "may sum to at most 1,
    # but their low bounds sum to 1; lower them": self-contradictory. The
    # only valid point is then the low bounds themselves.
    machine = ThermalMachine.from_preset("vmc-b")
    runs = machine.simulate(
        DutyCycle.heat_cool(3000, heat_h=0.1, cool_h=0.1, feed_mm_min=2000),
        noise=False,
    )
    shares = ["feed_heating.nut_share", "feed_heating.motor_share"]
    bounds = {shares[0]: (0.5, 0.9), shares[1]: (0.5, 0.8)}
    with pytest.raises(ValueError) as info:
        machine.calibrate(runs, shares, bounds=bounds, max_nfev=2)
    message = str(info.value)
    assert "their low bounds (sum 1) already use all of it" in message
    assert "the only valid point is the low bounds themselves" in message
    assert "nothing to fit. Lower a low bound." in message
    assert "but their low bounds sum to" not in message
    # Beyond the room it stays "lower them".
    bounds[shares[0]] = (0.6, 0.9)
    with pytest.raises(ValueError, match=r"but their low bounds sum to 1.1; lower"):
        machine.calibrate(runs, shares, bounds=bounds, max_nfev=2)


def test_a_numpy_number_in_params_is_shown_as_a_plain_number():
    # The [params] override warning printed "np.float64(3000.0)".
    data = _small()
    data["params"] = {"C.spindle": np.float64(3000.0)}
    with pytest.warns(UserWarning) as record:
        MachineSpec.from_dict(data)
    (message,) = [str(w.message) for w in record]
    assert message.startswith("params: 'C.spindle' = 3000.0 overrides")
    assert "np.float64" not in message


@pytest.mark.parametrize(
    "build, named",
    [
        (lambda: DutyCycle.heat_cool(3000, heat_h=10**400, cool_h=1), "heat_h"),
        (lambda: DutyCycle.heat_cool(3000, heat_h=1, cool_h=10**400), "cool_h"),
        (lambda: DutyCycle.heat_cool(3000, heat_h=1e306, cool_h=1), "heat_h"),
        (lambda: DutyCycle.from_hours([(1, 0), (10**400, 3000)]), "step 1: hours"),
        (lambda: DutyCycle.speed_spectrum([1000], step_h=10**400), "step_h"),
        (
            lambda: DutyCycle.speed_spectrum([1000], step_h=1, rest_h=10**400),
            "rest_h",
        ),
    ],
)
def test_duty_cycle_hours_beyond_a_float_name_the_argument(build, named):
    # heat_h=10**400 raised a bare OverflowError from heat_h * 3600.0.
    with pytest.raises(ValueError, match=rf"{named} must be a finite number"):
        build()


def test_a_stiff_network_names_its_fastest_and_slowest_nodes():
    # A 1 mJ/K bead on 1 W/K beside a 1e8 J/K base with 0.1 W/K convection:
    # the message named the largest conductance, the enclosure's 40 W/K,
    # which has nothing to do with it.
    data = {
        "name": "bead",
        "axes": ["z"],
        "roles": {"enclosure": "air", "tool": "base"},
        "nodes": {
            "bead": {"capacity_J_per_K": 1e-3, "convection_W_per_K": 0.0},
            "base": {"capacity_J_per_K": 1e8, "convection_W_per_K": 0.1},
            "air": {"capacity_J_per_K": 5e4, "convection_W_per_K": 40.0},
        },
        "links": [{"between": ["bead", "base"], "conductance_W_per_K": 1.0}],
        "heat": {"bearing": {"node": "base", "W_at_1000_rpm": 50.0, "alpha": 1.5}},
        "sensors": {"T1_C": {"node": "bead"}},
        "displacement": {"z": {"base": 1.0}},
    }
    machine = ThermalMachine.from_spec(data, effects=[])
    with pytest.raises(ValueError, match="too stiff") as info:
        machine.simulate(DutyCycle.heat_cool(3000, heat_h=1, cool_h=1), noise=False)
    message = str(info.value)
    assert (
        "fastest node 'bead': time constant 0.001 s = smallest capacity "
        "C.bead = 0.001 J/K over G.bead-base = 1 W/K;" in message
    )
    assert (
        "slowest node 'base': time constant 9.09e+07 s = largest capacity "
        "C.base = 1e+08 J/K over G.bead-base = 1 W/K + hA.base = 0.1 W/K)" in message
    )
    assert "hA.air" not in message


def test_a_screw_coefficient_off_the_feed_axis_names_the_feed_axis():
    from skthermal.simulate import ThermalMachine

    machine = ThermalMachine.from_preset("vmc-b", effects=[])
    with pytest.raises(ValueError, match=r"only on the feed axis 'y' \('k.y.screw'\)"):
        machine.with_params({"k.x.screw": 1.0})
