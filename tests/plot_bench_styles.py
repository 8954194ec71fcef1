#!/usr/bin/python3
# SPDX-License-Identifier: MIT
"""scripts/plot-bench on a stored bench run (docs/results/kinds-idle/flat:
13 measured systems, 8 model columns, 12 projections): every plotted series
has its own colour + point + dash, a system keeps its style across the two
plots, the per-cell-size model columns are grouped into "AE best" / "MO
best", and gnuplot draws both plots from it.

usage: plot_bench_styles.py SOURCE_DIR WORK_DIR"""
import pathlib
import re
import shutil
import subprocess
import sys

src, work = pathlib.Path(sys.argv[1]), pathlib.Path(sys.argv[2])
fixture = src / "docs" / "results" / "kinds-idle" / "flat"
script = src / "scripts" / "plot-bench"

printed = subprocess.run([str(script), "--print", str(fixture)], check=True, capture_output=True, text=True).stdout
CLAUSE = re.compile(r"\$(\w+) using 1:(\d+) with linespoints lc rgb '(#[0-9a-f]{6})' pt (\d+) ps [\d.]+ dt (\d+) "
                    r"lw [\d.]+ (?:title '([^']*)'|notitle)")
plots = {}
for line in printed.splitlines():
    if line.startswith("plot "):
        series = CLAUSE.findall(line)
        assert len(series) == line.count(" using 1:"), f"a clause the test cannot read: {line}"
        plots[series[0][0]] = series
assert set(plots) == {"times", "accel"}, plots.keys()

styles = {}  # title -> style, across both plots
for name, series in plots.items():
    triples = [(colour, pt, dt) for _, _, colour, pt, dt, _ in series]
    assert len(set(triples)) == len(triples), f"{name}: two series share colour, point and dash: {series}"
    titles = [t for *_, t in series if t]
    assert len(set(titles)) == len(titles), f"{name}: a title twice"
    for t in titles:
        assert not re.match(r"^(AE|MO) (none|\d+) ", t), f"{name}: per-cell-size model column {t!r} plotted"
    assert "AE best (model)" in titles and "MO best (model)" in titles, (name, titles)
    assert "hybrid sw (m)" in titles, titles
    for _, _, colour, pt, dt, t in series:
        if t:
            assert styles.setdefault(t, (colour, pt, dt)) == (colour, pt, dt), f"{t!r} changes style between plots"

times = plots["times"]
measured = [t for *_, t in times if t.endswith("(m)")]
assert len(measured) == 13, measured
assert sum(1 for s in times if not s[5]) == 12, "the 12 projections of measured systems (no model projections)"
colour_of = {t: c for _, _, c, _, _, t in times if t}
assert colour_of["hybrid sw (m)"] != colour_of["FCL DynamicAABBTree (m)"]
plotted = [t for t in colour_of if not t.startswith("paper")]
assert len({colour_of[t] for t in plotted}) == len(plotted), "systems and models: one colour each"

# The grouped model columns are the per-row minimum of the family's columns.
dat = (fixture / "times.dat").read_text().splitlines()
head = re.findall(r'"([^"]*)"', dat[0])
row = dat[2].split()  # n = 10000
ae = [float(row[i + 1]) for i, h in enumerate(head) if re.match(r"^AE (none|\d+) \(model\)$", h) and row[i + 1] != "?"]
block = printed.split("$times << EOD\n", 1)[1].split("\nEOD", 1)[0].splitlines()
block_head = re.findall(r'"([^"]*)"', block[0])
block_row = block[2].split()
assert float(block_row[block_head.index("AE best (model)") + 1]) == min(ae), (block_row, ae)

# gnuplot draws both plots.
shutil.rmtree(work, ignore_errors=True)
shutil.copytree(fixture, work)
for f in ("accel.png", "accel.svg", "times.png", "times.svg"):
    (work / f).unlink(missing_ok=True)
subprocess.run([str(script), str(work)], check=True)
for f in ("accel.png", "accel.svg", "times.png", "times.svg"):
    assert (work / f).stat().st_size > 10000, f
print(f"plot-bench: {len(plots['times'])} series in times, {len(plots['accel'])} in accel, all styles distinct")
