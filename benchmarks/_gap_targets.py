"""The confusion table and target rates of issue-13's truth-machine protocol,
shared by ``bench_gap_truth.py`` (ThermalMachine mode) and
``bench_gap_external.py`` (run-table mode)."""

import pandas as pd
from truth import CASES

NOT_IN_VOCABULARY = ("null", "coolant")


def summarise(df):
    """Confusion table (truth x named) and target rates of a results table.

    ``df`` has one row per case and seed with ``case``, ``named``,
    ``ranked_first``, ``true_shrink`` and, when the mode reports it,
    ``true_share`` (share of the explainable gap).
    """
    vocabulary = [c for c in CASES if c not in NOT_IN_VOCABULARY]
    confusion = pd.crosstab(df["case"], df["named"]).reindex(
        index=[c for c in CASES if c in set(df["case"])],
        columns=[*vocabulary, "none"],
        fill_value=0,
    )
    eff = df[~df["case"].isin(NOT_IN_VOCABULARY)]
    null = df[df["case"] == "null"]
    oov = df[df["case"] == "coolant"]
    rates = {}
    if len(eff):
        rates["withheld effect ranked first (>= 90%)"] = (
            eff["ranked_first"] == eff["case"]
        ).mean()
        rates["withheld effect named"] = (eff["named"] == eff["case"]).mean()
        rates["mean held-out shrink of the withheld effect (>= 0.70)"] = eff[
            "true_shrink"
        ].mean()
        if "true_share" in eff:
            rates["mean share of the explainable gap, withheld effect"] = eff[
                "true_share"
            ].mean()
    if len(null):
        rates["null called none (>= 90%)"] = (null["named"] == "none").mean()
    if len(oov):
        rates["out-of-vocabulary not blamed on an effect (100%)"] = (
            oov["named"] == "none"
        ).mean()
    return confusion, rates
