"""Markdown pipe tables, for the reports (no extra dependency)."""


def markdown_table(frame, *, cell=str, empty=None):
    """A DataFrame as a GitHub Markdown pipe table.

    Parameters
    ----------
    frame : DataFrame
        The table; its index is not written.
    cell : callable, default=str
        Formats one value as the text of its cell.
    empty : str or None, default=None
        Returned instead of a table when ``frame`` has no row; None writes
        the header alone.

    Returns
    -------
    str

    Examples
    --------
    >>> import pandas as pd
    >>> from skthermal._markdown import markdown_table
    >>> print(markdown_table(pd.DataFrame({"run": ["a"], "RMSE_um": [1.25]})))
    | run | RMSE_um |
    |---|---|
    | a | 1.25 |
    """
    if empty is not None and not len(frame):
        return empty
    header = "| " + " | ".join(map(str, frame.columns)) + " |"
    rule = "|" + "|".join("---" for _ in frame.columns) + "|"
    body = [
        "| " + " | ".join(cell(v) for v in row) + " |"
        for row in frame.itertuples(index=False, name=None)
    ]
    return "\n".join([header, rule, *body])
