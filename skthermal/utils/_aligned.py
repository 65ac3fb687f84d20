"""Inputs matched by position: pandas objects must share their index."""

import pandas as pd


def common_index(values, item="rows"):
    """The index shared by the pandas inputs among ``values`` (a dict of
    name -> input; None without any). Inputs are matched by position, so
    pandas inputs indexed differently (other ``item``, or the same in another
    order) are an error naming both, not a silent mismatch."""
    indexed = {
        k: v.index for k, v in values.items() if isinstance(v, pd.Series | pd.DataFrame)
    }
    if not indexed:
        return None
    (first, index), *others = indexed.items()
    for name, other in others:
        if len(other) != len(index):
            raise ValueError(
                f"{first} and {name} have {len(index)} and {len(other)} {item}: "
                f"they are matched by position; give the same {item} to both."
            )
        if not index.equals(other):
            raise ValueError(
                f"{first} and {name} are pandas objects with different indexes "
                f"({list(index[:3])}... and {list(other[:3])}...): the {item} are "
                f"matched by position; reindex them to the same {item} in the "
                f"same order (e.g. {name}.reindex({first}.index))."
            )
    return index
