"""Reading shearzone CSV files in the plotting scripts (standard library only).

A shearzone CSV opens with `# key: value` header lines, then one row of column names
(with units), then data.
"""
import csv


def read_csv(path):
    """Rows of a shearzone CSV as dicts (the '#' header block skipped)."""
    with open(path, newline="", encoding="utf-8") as f:
        lines = [ln for ln in f if not ln.startswith("#")]
    return list(csv.DictReader(lines))


def header(path):
    """The `# key: value` header block as a dict."""
    meta = {}
    with open(path, encoding="utf-8") as f:
        for ln in f:
            if not ln.startswith("#"):
                break
            k, _, v = ln[1:].partition(":")
            meta[k.strip()] = v.strip()
    return meta


def num(x):
    """float(x), NaN for an empty or non-numeric cell."""
    try:
        return float(x)
    except (TypeError, ValueError):
        return float("nan")


def param(row, name, se=False):
    """A parameter of a `fit erf|power` wide table (one row per group): the column `name`
    (or its standard error, `name_se`) with or without its unit suffix (rcinf_m,
    W_se_rad). None when the row has no such column."""
    key = name + "_se" if se else name
    if key in row:
        return row[key]
    for k, v in row.items():
        if k.startswith(key + "_") and (se or not k.startswith(name + "_se")):
            return v
    return None
