"""Dimensional error decomposition in cylindrical turning, and synthetic
turning data from a stated model.

Li, Venuvinod, Djorjevich and Liu (003 §3) decompose the diametral error of a
turned part with three measurements besides the designed diameter: on the
machine while it is still warm (``D_omw``), on the machine after it has cooled
(``D_omc``) and post-process on a CMM (``D_pp``). The aggregate of the
thermal, force-induced and other errors, ``d_agg = D_omc - D_des``, needs only
the cold on-machine measurement; an ANFIS with the cutting forces as inputs
then predicts the slope and offset of ``d_agg = a L + b`` along the part
(003 §7, Table 2).
"""

from numbers import Integral, Real

import numpy as np
import pandas as pd
from sklearn.utils import check_random_state
from sklearn.utils._param_validation import Interval, validate_params

from skthermal._naming import plain, shown
from skthermal.utils._aligned import common_index
from skthermal.utils._runs import check_labels, label_array

_UNITS = {"mm": 1000.0, "um": 1.0}
# A measured diameter further than this share from the designed one is not a
# machining error (µm on mm) but a unit slip, a radius or another part.
_MAX_RELATIVE_ERROR = 0.05
# Designed diameters above this (µm) are micrometres given with unit="mm":
# the largest vertical lathes turn about 10 m.
_MAX_DIAMETER_UM = 10e6

#: Cutting conditions of the six test cases of 003 Table 1.
TURNING_TEST_CONDITIONS = pd.DataFrame(
    {
        "V_m_s": [2.5, 4.0, 4.0, 4.0, 2.5, 4.0],
        "f_mm_rev": [0.10, 0.20, 0.15, 0.15, 0.15, 0.10],
        "d_mm": [1.0, 1.0, 1.0, 0.5, 1.0, 0.5],
        "D_mm": [45.0, 35.0, 45.0, 35.0, 45.0, 35.0],
        "nose_mm": [0.4, 0.8, 0.8, 0.4, 0.4, 0.8],
        "coolant": [True, False, True, False, True, False],
        "material": ["steel", "steel", "steel", "aluminium", "aluminium", "aluminium"],
    },
    index=pd.RangeIndex(1, 7, name="case"),
)


def _series(value, name, scale):
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be numeric diameters.") from None
    if arr.ndim > 1:
        raise ValueError(f"{name} must be a number or 1-D, got shape {arr.shape}.")
    if arr.size == 0:
        raise ValueError(f"{name} is empty: give one diameter per part.")
    bad = ~np.isfinite(arr)
    if bad.any():
        where = "" if arr.ndim == 0 else f" at position {int(np.flatnonzero(bad)[0])}"
        raise ValueError(f"{name} is NaN or infinite{where}.")
    if np.any(arr <= 0):
        raise ValueError(f"{name} must be positive diameters.")
    return arr * scale


def decompose_turning_error(D_des, *, D_omw=None, D_omc=None, D_pp=None, unit="mm"):
    """Split the diametral error of turned parts into its components.

    With ``d_tot = d_g + d_th + d_f + d_other`` (003 eq. 2) the measurements
    give (003 eq. 1, 4-7)::

        d_tot      = D_pp  - D_des            total error
        d_g        = D_pp  - D_omc            geometric (axis positioning)
        d_g_th     = D_pp  - D_omw            geometric + thermal
        d_th       = D_omc - D_omw            thermal
        d_f_other  = D_omw - D_des            force-induced + other (tool wear..)
        d_agg      = D_omc - D_des            thermal + force-induced + other

    so ``d_tot = d_g + d_agg = d_g + d_th + d_f_other``. Only the columns the
    given measurements determine are returned.

    Parameters
    ----------
    D_des : float or array-like of shape (n,)
        Designed (NC-programmed) diameters.
    D_omw : float or array-like of shape (n,), optional
        On-machine measurement right after machining, machine warm.
    D_omc : float or array-like of shape (n,), optional
        On-machine measurement after the machine has cooled down.
    D_pp : float or array-like of shape (n,), optional
        Post-process measurement (CMM).
    unit : {"mm", "um"}, default="mm"
        Unit of the diameters. The components are returned in µm.

    Returns
    -------
    DataFrame of shape (n, n_components)
        Error components (µm); the index of the first pandas input, if any.

    Notes
    -----
    003 prints eq. (5) as ``d_f = d_other = D_omw - D_des``; from eq. (1),
    (2) and (4) it is the sum ``d_f + d_other``. The decomposition assumes
    the on-machine probe reads the machine's positioning error at the time
    of measurement (003 eq. 3, Mou and Liu): warm, ``d_g + d_th``; cold,
    ``d_g``.

    Examples
    --------
    >>> from skthermal.turning import decompose_turning_error
    >>> decompose_turning_error(40.0, D_omw=40.006, D_omc=40.002, D_pp=40.005).round(3)
       d_tot  d_g  d_g_th  d_th  d_f_other  d_agg
    0    5.0  3.0    -1.0  -4.0        6.0    2.0
    """
    if not isinstance(unit, str) or unit not in _UNITS:
        raise ValueError(f"unit must be 'mm' or 'um', got {unit!r}.")
    scale = _UNITS[unit]
    given = {"D_omw": D_omw, "D_omc": D_omc, "D_pp": D_pp}
    if all(v is None for v in given.values()):
        raise ValueError("Give at least one measured diameter: D_omw, D_omc or D_pp.")
    index = common_index({"D_des": D_des, **given}, item="parts")
    arrays = {"D_des": _series(D_des, "D_des", scale)}
    arrays.update({k: _series(v, k, scale) for k, v in given.items() if v is not None})
    # A number applies to every part; sequences give one diameter per part
    # and must agree in length (a sequence of one is one part, not a number).
    lengths = {k: v.size for k, v in arrays.items() if v.ndim == 1}
    if len(set(lengths.values())) > 1:
        raise ValueError(
            f"The diameters have different lengths: {lengths}; give one "
            "diameter per part in each (or a number for all parts)."
        )
    b = np.broadcast_arrays(*arrays.values())
    a = {k: np.atleast_1d(v) for k, v in zip(arrays, b, strict=True)}
    des = a["D_des"]
    if des.max() > _MAX_DIAMETER_UM:
        raise ValueError(
            f"D_des reaches {des.max() / scale:.6g} {unit}, over "
            f"{_MAX_DIAMETER_UM / 1e6:g} m: micrometres given with "
            f"unit={unit!r}? Pass unit='um', or the diameters in mm."
        )
    for name in given:
        if name in a:
            _check_plausible(a[name], des, name, unit)
    out = {}
    if "D_pp" in a:
        out["d_tot"] = a["D_pp"] - des
        if "D_omc" in a:
            out["d_g"] = a["D_pp"] - a["D_omc"]
        if "D_omw" in a:
            out["d_g_th"] = a["D_pp"] - a["D_omw"]
    if "D_omw" in a:
        if "D_omc" in a:
            out["d_th"] = a["D_omc"] - a["D_omw"]
        out["d_f_other"] = a["D_omw"] - des
    if "D_omc" in a:
        out["d_agg"] = a["D_omc"] - des
    frame = pd.DataFrame(out)
    if index is not None:
        if len(index) != len(frame):
            raise ValueError(
                f"The diameters have {len(frame)} values but the pandas input's "
                f"index has {len(index)} labels; give every diameter per part."
            )
        frame.index = index
    return frame


def _check_plausible(measured, designed, name, unit):
    """A ValueError naming the first part whose measured diameter is further
    than :data:`_MAX_RELATIVE_ERROR` from the designed one."""
    far = np.abs(measured - designed) > _MAX_RELATIVE_ERROR * designed
    if not far.any():
        return
    k = int(np.flatnonzero(far)[0])
    scale = _UNITS[unit]
    raise ValueError(
        f"{name} of part {k} is {measured[k] / scale:.6g} {unit} against a designed "
        f"{designed[k] / scale:.6g} {unit} ({int(far.sum())} part(s) differ by more "
        f"than {_MAX_RELATIVE_ERROR:.0%}): diametral errors are micrometres on "
        f"a diameter. Give every diameter (D_des too) in unit={unit!r}, as "
        "diameters, not radii."
    )


def _coolant_flags(column):
    """The ``coolant`` column as booleans: True/False or 1/0 only (a string
    such as "False" or "no", or a missing value, is an error: ``astype(bool)``
    would read every one of them as coolant on)."""
    ok = column.map(
        lambda v: (
            isinstance(v, (bool, np.bool_))
            or (isinstance(v, (int, float, np.integer, np.floating)) and v in (0, 1))
        )
    )
    if not ok.all():
        case = column.index[np.flatnonzero(~ok.to_numpy())[0]]
        raise ValueError(
            f"conditions['coolant'] is {column[case]!r} for case {plain(case)!r}: "
            "use True/False (or 1/0)."
        )
    return column.astype(bool)


def fit_error_lines(L_mm, d_um, groups=None):
    """Least-squares line ``d = a L + b`` of error profiles, one per part.

    003 §7 linearises every measured profile of ``d_agg`` along the part
    (eq. 12) and lets ANFIS predict ``a`` and ``b``.

    Parameters
    ----------
    L_mm : array-like of shape (n,)
        Axial distance of each measuring point from the chuck face (mm).
    d_um : array-like of shape (n,)
        Error at each point (µm).
    groups : array-like of shape (n,), optional
        Part (test case) of each point; None: one part.

    Returns
    -------
    DataFrame
        Index: the parts (sorted); columns ``a_um_per_mm``, ``b_um``.

    Examples
    --------
    >>> from skthermal.turning import fit_error_lines
    >>> lines = fit_error_lines([10, 20, 30, 10, 20], [1, 2, 3, 5, 5],
    ...                         groups=[1, 1, 1, 2, 2])
    >>> (lines.round(6) + 0.0).to_dict("list")
    {'a_um_per_mm': [0.1, 0.0], 'b_um': [0.0, 5.0]}
    """
    common_index({"L_mm": L_mm, "d_um": d_um, "groups": groups}, item="points")
    arrays = []
    for name, values in (("L_mm", L_mm), ("d_um", d_um)):
        try:
            arrays.append(np.asarray(values, dtype=float))
        except (TypeError, ValueError):
            msg = f"{name} must hold numbers, got {shown(values)}."
            raise ValueError(msg) from None
    L, d = arrays
    if L.ndim != 1 or d.shape != L.shape:
        raise ValueError(
            f"L_mm and d_um must be 1-D of the same length, got {L.shape} and "
            f"{d.shape}."
        )
    if groups is None:
        groups = np.zeros(L.shape[0], dtype=int)
    else:
        groups = label_array(groups, item="point", label="part", whole="part")
    if groups.shape != L.shape:
        raise ValueError(f"groups must hold one part label per point ({L.shape[0]}).")
    if L.shape[0] == 0:
        raise ValueError("L_mm and d_um are empty: give the measured points.")
    check_labels(groups, item="point", label="part", whole="part")
    for name, values in (("L_mm", L), ("d_um", d)):
        bad = np.flatnonzero(~np.isfinite(values))
        if bad.size:
            i = int(bad[0])
            raise ValueError(
                f"{name} is {values[i]} at point {i} (part "
                f"{plain(groups[i])!r}; {bad.size} non-finite value(s)): every "
                "point needs a finite position and error."
            )
    labels, codes = np.unique(groups, return_inverse=True)
    m = labels.shape[0]
    n = np.bincount(codes, minlength=m).astype(float)
    mL = np.bincount(codes, L, m) / n
    md = np.bincount(codes, d, m) / n
    Lc = L - mL[codes]
    sxx = np.bincount(codes, Lc * Lc, m)
    sxy = np.bincount(codes, Lc * (d - md[codes]), m)
    flat = sxx <= 0
    if flat.any():
        raise ValueError(
            f"Part {plain(labels[np.flatnonzero(flat)[0]])!r} has its points at "
            "a single "
            "position; a line needs two positions."
        )
    a = sxy / sxx
    return pd.DataFrame(
        {"a_um_per_mm": a, "b_um": md - a * mL},
        index=pd.Index(labels, name="part"),
    )


_LEVELS = {
    "V_m_s": [2.5, 4.0],
    "f_mm_rev": [0.10, 0.15, 0.20],
    "d_mm": [0.5, 1.0],
    "D_mm": [30.0, 35.0, 40.0, 45.0, 50.0],
    "nose_mm": [0.4, 0.8],
    "coolant": [False, True],
    "material": ["steel", "aluminium"],
}
_MATERIAL = {  # specific cutting force (N/mm^2), Young's modulus (N/mm^2)
    "steel": (2000.0, 210000.0),
    "aluminium": (800.0, 70000.0),
}


@validate_params(
    {
        "n_cases": [Interval(Integral, 1, None, closed="left")],
        "conditions": [pd.DataFrame, None],
        "n_positions": [Interval(Integral, 2, None, closed="left")],
        "spacing_mm": [Interval(Real, 0, None, closed="neither")],
        "noise_um": [Interval(Real, 0, None, closed="left")],
        "force_noise": [Interval(Real, 0, None, closed="left")],
        "part_noise_um": [Interval(Real, 0, None, closed="left")],
        "random_state": ["random_state"],
    },
    prefer_skip_nested_validation=True,
)
def make_turning_errors(
    n_cases=20,
    *,
    conditions=None,
    n_positions=10,
    spacing_mm=10.0,
    noise_um=0.5,
    force_noise=0.03,
    part_noise_um=1.0,
    random_state=None,
):
    """Synthetic cylindrical-turning tests with a known error model.

    Cutting conditions are drawn from the levels of 003 §6 (or given).
    The model, per part, at axial distance ``L`` from the chuck face
    (``L = spacing, 2 spacing, .., n_positions spacing``; diametral errors in
    µm, forces in N, lengths in mm)::

        F_t = K_c f d (V / 2.5)^-0.1         tangential force, K_c = 2000
                                             (steel) or 800 (aluminium) N/mm^2
        F_r = F_t (0.25 + 0.25 r_n / d)      radial force (nose radius r_n)
        F_a = F_t (0.50 - 0.15 r_n / d)      axial force
        T   = F_t D / 2000                   spindle torque (N m)
        P   = F_t V                          cutting power (W)
        d_th(L)    = -0.004 P (1 - 0.5 c) (0.5 + 0.5 (L_max - L) / L_max)
                     part cut hot shrinks; cutting runs from the free end
                     towards the chuck, coolant c halves it
        d_f,mft(L) = 2 F_r (0.01 + 0.0002 L)  machine-fixture-tool compliance,
                     a rotation about a centre behind the chuck (linear in L)
        d_f,w(L)   = 2000 F_r L^3 / (3 E I), I = pi D^4 / 64
                     the part as a cantilever (cubic in L), E = 210000
                     (steel) or 70000 (aluminium) N/mm^2
        d_other    = 0.6 V (1 - 0.3 c) m + u tool wear, m = 1 steel, 0.5 Al,
                     plus u ~ N(0, part_noise_um) per part: clamping and
                     tool-wear scatter that the forces do not explain
        d_agg      = d_th + d_f,mft + d_f,w + d_other
        d_g(L)     = 2.0 + 0.01 L            the machine's geometric error

    The measured forces carry multiplicative noise ``N(1, force_noise)``
    (003 Fig. 4: force model slope 0.96-0.98). The diameters are
    ``D_omc = D_des + d_agg``, ``D_omw = D_omc - d_th``, ``D_pp = D_omc + d_g``,
    each read with independent ``N(0, noise_um)`` noise (the soft-touch
    probe repeats to about 1 µm, 003 §2). ``a`` and ``b`` are the
    least-squares line through the measured ``d_agg`` (003 eq. 12); the cubic
    workpiece deflection makes the true profile curve, so a line cannot fit
    it exactly, as in 003 Fig. 7.

    Parameters
    ----------
    n_cases : int, default=20
        Parts (test cases) to draw; ignored when ``conditions`` is given.
    conditions : DataFrame, optional
        Cutting conditions, one row per part, with columns ``V_m_s``,
        ``f_mm_rev``, ``d_mm``, ``D_mm``, ``nose_mm``, ``coolant`` and
        ``material`` (``"steel"``/``"aluminium"``), e.g.
        :data:`TURNING_TEST_CONDITIONS` (003 Table 1).
    n_positions : int, default=10
        Measuring points per part (003 §7: 10 points, 10 mm apart).
    spacing_mm : float, default=10.0
    noise_um : float, default=0.5
        Standard deviation of every diameter measurement (µm).
    force_noise : float, default=0.03
        Relative standard deviation of the measured forces.
    part_noise_um : float, default=1.0
        Standard deviation of the per-part error the forces do not explain
        (µm); it bounds how well any force-driven model can do.
    random_state : int, RandomState instance or None

    Returns
    -------
    cases : DataFrame
        One row per part (index ``case``): the conditions, measured forces
        ``F_t_N``, ``F_r_N``, ``F_a_N``, ``torque_Nm`` and the fitted line
        ``a_um_per_mm``, ``b_um`` of the measured ``d_agg``.
    profiles : DataFrame
        One row per part and position: ``case``, ``L_mm``, the diameters
        ``D_des_mm``, ``D_omw_mm``, ``D_omc_mm``, ``D_pp_mm`` (measured) and
        the true components ``d_g_um``, ``d_th_um``, ``d_f_um``,
        ``d_other_um``, ``d_agg_um``.

    Examples
    --------
    >>> from skthermal.turning import make_turning_errors
    >>> cases, profiles = make_turning_errors(6, random_state=0)
    >>> cases.shape, profiles.shape
    ((6, 13), (60, 11))
    >>> err = profiles["D_omc_mm"] - profiles["D_des_mm"]
    >>> bool(abs(1000 * err - profiles["d_agg_um"]).max() < 3)
    True
    """
    rng = check_random_state(random_state)
    if conditions is None:
        cond = pd.DataFrame(
            {
                k: np.asarray(v, dtype=object)[rng.randint(len(v), size=n_cases)]
                for k, v in _LEVELS.items()
            },
            index=pd.RangeIndex(1, n_cases + 1, name="case"),
        )
    else:
        if not isinstance(conditions, pd.DataFrame) or conditions.empty:
            raise ValueError("conditions must be a non-empty DataFrame.")
        missing = [k for k in _LEVELS if k not in conditions.columns]
        if missing:
            raise ValueError(f"conditions has no column(s) {missing}.")
        if not conditions.index.is_unique:
            raise ValueError("conditions needs a unique index (one label per part).")
        cond = conditions[list(_LEVELS)].copy()
        cond.index.name = "case"
    bad = sorted(set(cond["material"]) - set(_MATERIAL))
    if bad:
        raise ValueError(f"Unknown material(s) {bad}; use 'steel' or 'aluminium'.")
    numeric = [k for k in _LEVELS if k not in ("material", "coolant")]
    for k in numeric:
        values = pd.to_numeric(cond[k], errors="coerce").astype(float)
        bad = ~(np.isfinite(values) & (values > 0))
        if bad.any():
            case = cond.index[np.flatnonzero(bad.to_numpy())[0]]
            raise ValueError(
                f"conditions[{k!r}] is {plain(cond[k][case])!r} for case "
                f"{plain(case)!r}: "
                "cutting conditions must be positive numbers."
            )
        cond[k] = values
    cond["coolant"] = _coolant_flags(cond["coolant"])

    V, f, d = (cond[k].to_numpy(float) for k in ("V_m_s", "f_mm_rev", "d_mm"))
    D, rn = cond["D_mm"].to_numpy(float), cond["nose_mm"].to_numpy(float)
    cool = cond["coolant"].to_numpy(float)
    Kc = np.array([_MATERIAL[m][0] for m in cond["material"]])
    E = np.array([_MATERIAL[m][1] for m in cond["material"]])
    wear = np.where(cond["material"].to_numpy() == "steel", 1.0, 0.5)
    Ft = Kc * f * d * (V / 2.5) ** -0.1
    Fr = Ft * (0.25 + 0.25 * rn / d)
    Fa = Ft * (0.50 - 0.15 * rn / d)

    m = len(cond)
    L = spacing_mm * np.arange(1, n_positions + 1)
    Lmax = L[-1]
    P = Ft * V
    d_th = -0.004 * (P * (1 - 0.5 * cool))[:, None] * (0.5 + 0.5 * (Lmax - L) / Lmax)
    inertia = np.pi * D**4 / 64.0
    d_f = (
        2 * Fr[:, None] * (0.01 + 0.0002 * L)
        + 2000 * Fr[:, None] * L**3 / (3 * E * inertia)[:, None]
    )
    scatter = rng.normal(0.0, part_noise_um, m)
    d_other = np.repeat(
        (0.6 * V * (1 - 0.3 * cool) * wear + scatter)[:, None], L.size, axis=1
    )
    d_agg = d_th + d_f + d_other
    d_g = np.broadcast_to(2.0 + 0.01 * L, d_agg.shape)

    D_des = np.repeat(D[:, None], L.size, axis=1)
    noise = rng.normal(0.0, noise_um, (3, m, L.size)) / 1000.0
    D_omc_true = D_des + d_agg / 1000.0
    D_omc = D_omc_true + noise[0]
    D_omw = D_omc_true - d_th / 1000.0 + noise[1]
    D_pp = D_omc_true + d_g / 1000.0 + noise[2]

    forces = Ft, Fr, Fa
    meas = [F * rng.normal(1.0, force_noise, m) for F in forces]
    case = np.repeat(cond.index.to_numpy(), L.size)
    profiles = pd.DataFrame(
        {
            "case": case,
            "L_mm": np.tile(L, m),
            "D_des_mm": D_des.ravel(),
            "D_omw_mm": D_omw.ravel(),
            "D_omc_mm": D_omc.ravel(),
            "D_pp_mm": D_pp.ravel(),
            "d_g_um": d_g.ravel(),
            "d_th_um": d_th.ravel(),
            "d_f_um": d_f.ravel(),
            "d_other_um": d_other.ravel(),
            "d_agg_um": d_agg.ravel(),
        }
    )
    lines = fit_error_lines(
        profiles["L_mm"], 1000.0 * (D_omc - D_des).ravel(), groups=case
    )
    cases = cond.copy()
    cases["F_t_N"], cases["F_r_N"], cases["F_a_N"] = meas
    cases["torque_Nm"] = meas[0] * D / 2000.0
    lines = lines.reindex(cond.index)
    cases["a_um_per_mm"] = lines["a_um_per_mm"].to_numpy()
    cases["b_um"] = lines["b_um"].to_numpy()
    return cases, profiles
