#!/usr/bin/python3
"""Plots of a `coupler sweep` table (sweep.csv), written next to it.

  error_vs_walltime.png      the scene's error metric against wall time, one
                             marker per run annotated with its swept values,
                             one series per value of the first swept key;
                             log-log when every value is positive
  walltime_vs_<key>.png      wall time against the first swept key
  <figure>_vs_<key>.png      every figure column against the first swept key

Usage: plot_sweep.py DIR/sweep.csv. Prints the path of every PNG it writes.
Exit codes: 0 written, 2 unusable table, 3 matplotlib missing.
"""
import csv
import math
import os
import re
import sys

FIXED_AFTER_KEYS = ["status", "exit_code", "wall_s", "exchange_loop_s", "coupling_overhead_share",
                    "error_name", "error_value"]


def fail(message, code=2):
    sys.stderr.write("plot_sweep.py: " + message + "\n")
    sys.exit(code)


def number(text):
    try:
        value = float(text)
    except (TypeError, ValueError):
        return None
    return value if math.isfinite(value) else None


def read_table(path):
    try:
        with open(path, newline="") as f:
            rows = list(csv.reader(f))
    except OSError as e:
        fail("cannot read %s: %s" % (path, e.strerror))
    if not rows:
        fail("%s is empty" % path)
    header, body = rows[0], rows[1:]
    missing = [c for c in ["index"] + FIXED_AFTER_KEYS + ["run_dir"] if c not in header]
    if missing:
        fail("%s is not a sweep table (no column %s)" % (path, ", ".join(missing)))
    keys = header[1:header.index("status")]
    figures = header[header.index("error_value") + 1:header.index("run_dir")]
    records = [dict(zip(header, row)) for row in body if len(row) == len(header)]
    return keys, figures, records


def file_name(text):
    return re.sub(r"[^A-Za-z0-9._=+-]", "_", text)


def ordered(values):
    seen = []
    for v in values:
        if v not in seen:
            seen.append(v)
    return seen


def axis_values(records, key):
    """Numeric positions for the key's values when all are numbers, else category positions."""
    values = ordered(r[key] for r in records)
    numeric = [number(v) for v in values]
    if all(v is not None for v in numeric):
        return {v: n for v, n in zip(values, numeric)}, None
    return {v: i for i, v in enumerate(values)}, values


def use_log(values):
    positive = [v for v in values if v is not None]
    return bool(positive) and all(v > 0 for v in positive)


def plot_error_vs_walltime(plt, out_dir, keys, records):
    fig, ax = plt.subplots(figsize=(7, 5))
    points = [r for r in records if number(r["wall_s"]) is not None and number(r["error_value"]) is not None]
    if not points:
        ax.text(0.5, 0.5, "no run reported an error metric\n(the scene names no reference)",
                ha="center", va="center", transform=ax.transAxes)
    first = keys[0] if keys else None
    for value in ordered(r[first] for r in points) if first else [None]:
        series = [r for r in points if first is None or r[first] == value]
        xs = [number(r["wall_s"]) for r in series]
        ys = [number(r["error_value"]) for r in series]
        ax.plot(xs, ys, "o-", label=("%s=%s" % (first, value)) if first else None)
        for r, x, y in zip(series, xs, ys):
            note = ", ".join("%s=%s" % (k, r[k]) for k in keys)
            ax.annotate(note, (x, y), textcoords="offset points", xytext=(4, 4), fontsize=7)
    if points and use_log([number(r["wall_s"]) for r in points] + [number(r["error_value"]) for r in points]):
        ax.set_xscale("log")
        ax.set_yscale("log")
    names = ordered(r["error_name"] for r in points if r["error_name"])
    ax.set_xlabel("wall time [s]")
    ax.set_ylabel(" / ".join(names) if names else "error")
    ax.set_title("error against wall time")
    if points and first:
        ax.legend(fontsize=8)
    ax.grid(True, which="both", alpha=0.3)
    return save(plt, fig, os.path.join(out_dir, "error_vs_walltime.png"))


def plot_column(plt, out_dir, keys, records, column, label, stem=None):
    first = keys[0]
    positions, categories = axis_values(records, first)
    others = keys[1:]
    fig, ax = plt.subplots(figsize=(7, 5))
    groups = ordered(tuple(r[k] for k in others) for r in records)
    for group in groups:
        series = [r for r in records if tuple(r[k] for k in others) == group and number(r[column]) is not None]
        if not series:
            continue
        name = ", ".join("%s=%s" % (k, v) for k, v in zip(others, group))
        ax.plot([positions[r[first]] for r in series], [number(r[column]) for r in series], "o-",
                label=name or None)
    if categories is not None:
        ax.set_xticks(range(len(categories)))
        ax.set_xticklabels(categories, rotation=30, ha="right", fontsize=8)
    elif use_log(positions.values()) and max(positions.values()) >= 10 * min(positions.values()):
        ax.set_xscale("log")
    ax.set_xlabel(first)
    ax.set_ylabel(label)
    ax.set_title("%s against %s" % (label, first))
    if others:
        ax.legend(fontsize=8)
    ax.grid(True, which="both", alpha=0.3)
    return save(plt, fig, os.path.join(out_dir, file_name("%s_vs_%s" % (stem or column, first)) + ".png"))


def save(plt, fig, path):
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def main(argv):
    if len(argv) != 2:
        fail("usage: plot_sweep.py DIR/sweep.csv")
    keys, figures, records = read_table(argv[1])
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        fail("matplotlib is not available to %s (Debian: apt-get install python3-matplotlib)" % sys.executable, 3)
    out_dir = os.path.dirname(os.path.abspath(argv[1]))
    written = [plot_error_vs_walltime(plt, out_dir, keys, records)]
    if keys:
        written.append(plot_column(plt, out_dir, keys, records, "wall_s", "wall time [s]", "walltime"))
        for column in figures:
            written.append(plot_column(plt, out_dir, keys, records, column, column))
    for path in written:
        print(path)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
