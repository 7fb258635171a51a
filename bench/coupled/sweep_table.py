"""Reading `coupler sweep` tables (DIR/sweep.csv) for the bench scripts' printed tables."""
import csv


def rows(path):
    """The sweep's runs, one dict per CSV row, in run order."""
    with open(path) as f:
        return list(csv.DictReader(f))


def cell(row, key, fmt="{:.4g}"):
    """The row's value under key formatted as a number, or '-' when the run left it empty."""
    v = row.get(key, "")
    return fmt.format(float(v)) if v not in ("", None) else "-"
