"""Turning-error decomposition (003 §3) and the synthetic turning model."""

import numpy as np
import pandas as pd
import pytest
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler

from skthermal.fuzzy import ANFISRegressor
from skthermal.turning import (
    TURNING_TEST_CONDITIONS,
    decompose_turning_error,
    fit_error_lines,
    make_turning_errors,
)


def test_decomposition_by_hand():
    out = decompose_turning_error(
        [30.0, 40.0],
        D_omw=[30.010, 39.998],
        D_omc=[30.004, 40.003],
        D_pp=[30.007, 40.001],
    )
    expected = pd.DataFrame(
        {
            "d_tot": [7.0, 1.0],
            "d_g": [3.0, -2.0],
            "d_g_th": [-3.0, 3.0],
            "d_th": [-6.0, 5.0],
            "d_f_other": [10.0, -2.0],
            "d_agg": [4.0, 3.0],
        }
    )
    pd.testing.assert_frame_equal(out, expected, atol=1e-9)
    # The identities of 003 eq. (1)-(7).
    np.testing.assert_allclose(out.d_tot, out.d_g + out.d_th + out.d_f_other)
    np.testing.assert_allclose(out.d_agg, out.d_th + out.d_f_other)
    np.testing.assert_allclose(out.d_g_th, out.d_g + out.d_th)


def test_decomposition_with_fewer_measurements_and_units():
    only_cold = decompose_turning_error(40.0, D_omc=40.0025)
    assert list(only_cold.columns) == ["d_agg"]
    np.testing.assert_allclose(only_cold.d_agg, [2.5])
    um = decompose_turning_error(40000.0, D_pp=40004.0, D_omc=40001.0, unit="um")
    assert list(um.columns) == ["d_tot", "d_g", "d_agg"]
    np.testing.assert_allclose(um.iloc[0], [4.0, 3.0, 1.0])
    idx = pd.Index(["p1", "p2"], name="part")
    series = decompose_turning_error(
        pd.Series([10.0, 10.0], index=idx), D_omc=[10.001, 9.999]
    )
    assert series.index.equals(idx)
    np.testing.assert_allclose(series.d_agg, [1.0, -1.0])


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({}, "at least one"),
        ({"D_omc": [40.0, np.nan]}, "D_omc is NaN or infinite at position 1"),
        ({"D_omc": [40.0, 40.0, 40.0]}, "different lengths"),
        # A sequence of one is one part, not a number for all parts.
        ({"D_pp": [40.012]}, r"different lengths: \{'D_des': 2, 'D_pp': 1\}"),
        ({"D_pp": -1.0}, "positive"),
        ({"D_omc": "x"}, "numeric"),
        ({"D_omc": 40.0, "unit": "inch"}, "unit"),
        ({"D_omc": 40.0, "unit": ["mm"]}, "unit must be 'mm' or 'um'"),
        ({"D_omc": [[40.0]]}, "1-D"),
    ],
)
def test_decomposition_errors(kwargs, message):
    with pytest.raises(ValueError, match=message):
        decompose_turning_error([40.0, 40.0], **kwargs)


def test_decomposition_matches_pandas_inputs_by_their_index():
    des = pd.Series([40.0, 41.0], index=["a", "b"])
    pp = pd.Series([41.001, 40.001], index=["b", "a"])  # same parts, other order
    with pytest.raises(ValueError, match="different indexes"):
        decompose_turning_error(des, D_pp=pp)
    out = decompose_turning_error(des, D_pp=pp.reindex(des.index))
    np.testing.assert_allclose(out["d_tot"], [1.0, 1.0])
    with pytest.raises(ValueError, match=r"different lengths: \{'D_des': 1, 'D_pp': 2"):
        decompose_turning_error(des.iloc[:1], D_pp=[40.001, 40.002])
    with pytest.raises(ValueError, match="D_des is empty"):
        decompose_turning_error([], D_pp=[])


def test_pandas_inputs_of_other_lengths_or_order_are_refused():
    # Series paired by position: the same labels in another order gave
    # slopes [0.0, -0.1] instead of [0.1, 0.0]; two lengths were called
    # "different indexes" over two identical heads.
    L = pd.Series([10.0, 20.0, 30.0, 10.0, 20.0])
    d = pd.Series([1.0, 2.0, 3.0, 5.0, 5.0])
    parts = [1, 1, 1, 2, 2]
    with pytest.raises(ValueError, match="L_mm and d_um are pandas objects with dif"):
        fit_error_lines(L, d.iloc[::-1], parts)
    lines = fit_error_lines(L, d, parts)
    np.testing.assert_allclose(lines["a_um_per_mm"], [0.1, 0.0], atol=1e-12)
    des = pd.Series([40.0, 41.0, 42.0])
    with pytest.raises(ValueError, match=r"D_des and D_pp have 3 and 2 parts"):
        decompose_turning_error(des, D_pp=pd.Series([40.001, 41.001]))


def test_error_lines_by_hand():
    L = np.tile([10.0, 20.0, 30.0, 40.0], 2)
    d = np.r_[0.5 * L[:4] + 2.0, -0.1 * L[4:] + 1.0]
    lines = fit_error_lines(L, d, groups=["b"] * 4 + ["a"] * 4)
    assert lines.index.tolist() == ["a", "b"]
    np.testing.assert_allclose(lines.to_numpy(), [[-0.1, 1.0], [0.5, 2.0]])
    with pytest.raises(ValueError, match=r"^Part 0 has its points at a single"):
        fit_error_lines([10.0, 10.0], [1.0, 2.0])
    with pytest.raises(ValueError, match="same length"):
        fit_error_lines([10.0, 20.0], [1.0])
    with pytest.raises(ValueError, match=r"L_mm is inf at point 1 \(part 0;"):
        fit_error_lines([10.0, np.inf], [1.0, 2.0])
    with pytest.raises(ValueError, match=r"d_um is nan at point 2 \(part 'b';"):
        fit_error_lines([1.0, 2.0, 1.0, 2.0], [1.0, 2.0, np.nan, 3.0], list("aabb"))
    for labels in (["a", "a", None, None], [1.0, 1.0, np.nan, np.nan]):
        with pytest.raises(ValueError, match="Point 2 has no part label"):
            fit_error_lines([10.0, 20.0, 10.0, 20.0], [1.0, 2.0, 3.0, 4.0], labels)
    with pytest.raises(ValueError, match="empty"):
        fit_error_lines([], [])


def test_generator_follows_its_stated_model():
    cases, prof = make_turning_errors(
        conditions=TURNING_TEST_CONDITIONS,
        noise_um=0.0,
        force_noise=0.0,
        part_noise_um=0.0,
        random_state=0,
    )
    # Case 1: steel, V 2.5, f 0.1, d 1.0, D 45, r_n 0.4, coolant.
    c1 = cases.loc[1]
    Ft = 2000 * 0.1 * 1.0
    assert c1.F_t_N == pytest.approx(Ft)
    assert c1.F_r_N == pytest.approx(Ft * (0.25 + 0.25 * 0.4))
    assert c1.F_a_N == pytest.approx(Ft * (0.50 - 0.15 * 0.4))
    assert c1.torque_Nm == pytest.approx(Ft * 45 / 2000)
    p1 = prof[prof.case == 1]
    L = p1.L_mm.to_numpy()
    np.testing.assert_allclose(L, np.arange(10, 101, 10))
    Fr = c1.F_r_N
    d_th = -0.004 * Ft * 2.5 * 0.5 * (0.5 + 0.5 * (100 - L) / 100)
    d_f = 2 * Fr * (0.01 + 0.0002 * L) + 2000 * Fr * L**3 / (
        3 * 210000 * np.pi * 45**4 / 64
    )
    np.testing.assert_allclose(p1.d_th_um, d_th)
    np.testing.assert_allclose(p1.d_f_um, d_f)
    np.testing.assert_allclose(p1.d_other_um, 0.6 * 2.5 * 0.7)
    # Noise-free diameters decompose back into the true components.
    dec = decompose_turning_error(
        prof.D_des_mm, D_omw=prof.D_omw_mm, D_omc=prof.D_omc_mm, D_pp=prof.D_pp_mm
    )
    np.testing.assert_allclose(dec.d_agg, prof.d_agg_um, atol=1e-8)
    np.testing.assert_allclose(dec.d_th, prof.d_th_um, atol=1e-8)
    np.testing.assert_allclose(dec.d_g, prof.d_g_um, atol=1e-8)
    np.testing.assert_allclose(dec.d_f_other, prof.d_f_um + prof.d_other_um, atol=1e-8)
    lines = fit_error_lines(prof.L_mm, prof.d_agg_um, prof.case)
    np.testing.assert_allclose(cases[["a_um_per_mm", "b_um"]], lines, atol=1e-8)


def test_generator_draws_and_validates():
    cases, prof = make_turning_errors(8, n_positions=5, spacing_mm=20.0, random_state=3)
    assert cases.shape == (8, 13) and prof.shape == (40, 11)
    assert set(cases.material) <= {"steel", "aluminium"}
    again, _ = make_turning_errors(8, n_positions=5, spacing_mm=20.0, random_state=3)
    pd.testing.assert_frame_equal(cases, again)
    with pytest.raises(ValueError, match="n_cases"):
        make_turning_errors(0)
    with pytest.raises(ValueError, match="n_positions"):
        make_turning_errors(3, n_positions=1)
    with pytest.raises(ValueError, match="noise_um"):
        make_turning_errors(3, noise_um=-1.0)
    with pytest.raises(ValueError, match="no column"):
        make_turning_errors(conditions=TURNING_TEST_CONDITIONS.drop(columns="d_mm"))
    with pytest.raises(ValueError, match="Unknown material"):
        make_turning_errors(conditions=TURNING_TEST_CONDITIONS.assign(material="brass"))
    # "False" or "no" would read as True with astype(bool).
    for flag in ("False", np.nan):
        with pytest.raises(ValueError, match=r"conditions\['coolant'\] is .* case 1"):
            make_turning_errors(conditions=TURNING_TEST_CONDITIONS.assign(coolant=flag))
    ones = TURNING_TEST_CONDITIONS.assign(
        coolant=TURNING_TEST_CONDITIONS["coolant"].astype(int)
    )
    pd.testing.assert_frame_equal(
        make_turning_errors(conditions=ones, random_state=0)[0],
        make_turning_errors(conditions=TURNING_TEST_CONDITIONS, random_state=0)[0],
    )
    speeds = TURNING_TEST_CONDITIONS["V_m_s"].to_numpy().copy()
    speeds[1] = np.nan
    with pytest.raises(ValueError, match=r"conditions\['V_m_s'\] is nan for case 2"):
        make_turning_errors(conditions=TURNING_TEST_CONDITIONS.assign(V_m_s=speeds))


def test_anfis_predicts_aggregate_error_lines():
    """003 §7: ANFIS on (torque, F_r, F_a) -> (a, b), 6 test cases (Table 1)."""
    train, _ = make_turning_errors(20, random_state=0)
    test, prof = make_turning_errors(conditions=TURNING_TEST_CONDITIONS, random_state=1)
    inputs = ["torque_Nm", "F_r_N", "F_a_N"]
    model = make_pipeline(
        StandardScaler(), ANFISRegressor(n_clusters=3, epochs=100, random_state=0)
    ).fit(train[inputs], train[["a_um_per_mm", "b_um"]])
    ab = pd.DataFrame(model.predict(test[inputs]), index=test.index)
    ab = ab.loc[prof.case].to_numpy()
    predicted = ab[:, 0] * prof.L_mm + ab[:, 1]
    measured = 1000 * (prof.D_omc_mm - prof.D_des_mm)
    mean_error = (predicted - measured).abs().groupby(prof.case).mean()
    # 003 Table 2 reports mean errors of 1.2-3.4 µm on its six cases.
    assert mean_error.max() < 3.5


def test_fit_error_lines_names_text():
    with pytest.raises(ValueError, match=r"L_mm must hold numbers, got \['x'"):
        fit_error_lines(["x", 20, 30], [1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match="d_um must hold numbers"):
        fit_error_lines([10.0, 20.0, 30.0], [1.0, "n/a", 3.0])


@pytest.mark.parametrize(
    "args, kwargs, message",
    [
        ((40.0,), {"D_omc": 40.002, "D_pp": 40005.0}, r"D_pp of part 0 is 40005 mm"),
        ((20.0,), {"D_omc": 40.002}, r"D_omc of part 0 .* designed 20 mm.*radii"),
        ((40000.0,), {"D_omc": 40002.0}, r"D_des reaches 40000 mm.*unit='um'"),
    ],
)
def test_unit_slips_are_refused(args, kwargs, message):
    # Micrometres typed as mm, or a radius for a diameter, gave errors of
    # 2000 µm to 4e7 µm without a word.
    with pytest.raises(ValueError, match=message):
        decompose_turning_error(*args, **kwargs)
    ok = decompose_turning_error(40000.0, D_omc=40002.0, unit="um")
    assert ok["d_agg"].tolist() == [2.0]


def test_error_lines_keep_parts_of_two_label_kinds_apart():
    with pytest.raises(ValueError, match=r"Part labels mix kinds: point 0 has 1"):
        fit_error_lines([10, 20, 10, 20], [1, 2, 3, 4], groups=[1, 1, "1", "1"])
