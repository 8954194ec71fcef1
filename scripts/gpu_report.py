#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""gpu-report.json and gpu-report.md from the raw results of scripts/gpu-check.

Inputs (in OUT/logs): env.txt, tests.log, engine-tests.log, python-build.json
(scripts/gpu_python_module.py), python-tests.log (pytest), bench-NAME.json
(hbp-gpu-bench), bench-NAME.rc, power-NAME.csv (nvidia-smi samples),
cpu-NAME.json (`hbp run --json` of the carried main build). Standard library
only: the device machine has no Debian packages.

Energy per frame is board power sampled during the back-to-back device
frames of `hbp-gpu-bench --sustain` (only samples inside that window) times
the wall time per frame of that loop: the board's whole draw, idle gaps
between kernels included.
"""
import argparse
import csv
import datetime
import json
import os
import re
import statistics
import time

# Table 4 of the paper at 1,024,000 objects (ms per frame), and Table 5's
# GPU rows (published figures, their own machines and scenes).
PAPER_ACCELERATOR_MS = 12.18
PAPER_GPU_SAP_MS = 1958.9
PAPER_CPU_DBVT_MS = 9897.0
TABLE5 = [("Liu et al. (GPU SAP)", 960_000, 161.0), ("Avril et al. (GPU)", 1_000_000, 245.95)]


def read_json(path):
    try:
        with open(path) as f:
            return json.load(f)
    except (OSError, ValueError) as e:
        return {"error": f"{os.path.basename(path)}: {e}"}


def read_rc(path):
    """(exit code, cut) of a step's NAME.rc as scripts/gpu-check records it:
    "cut" when the deadline shortened the step's limit and it ran out of it
    (listed, not a failure); a missing or unreadable file is exit code 1."""
    try:
        rc = open(path).read().strip()
        return (None, True) if rc == "cut" else (int(rc), False)
    except (OSError, ValueError):
        return 1, False


def power_samples(path):
    """[(unix seconds, watts)] from nvidia-smi's csv (local-time stamps)."""
    samples = []
    if not os.path.exists(path):
        return samples
    with open(path) as f:
        for row in csv.reader(f):
            try:
                stamp = datetime.datetime.strptime(row[0].strip(), "%Y/%m/%d %H:%M:%S.%f")
                samples.append((time.mktime(stamp.timetuple()) + stamp.microsecond / 1e6, float(row[1])))
            except (ValueError, IndexError):
                pass
    return samples


def scene_of(name):
    """('paper', 1024000) from 'paper-1024000', 'axis-sweep-paper-1024000', 'lbvh-paper-1024000',
    'paper-1024000-frame-order'."""
    parts = name.split("-")
    for i, p in enumerate(parts):
        if p.isdigit():
            return parts[i - 1], int(p)
    return None, None


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("dry")
    ap.add_argument("build_ok")
    ap.add_argument("build_s", type=int)
    ap.add_argument("tests_rc", type=int)
    ap.add_argument("engine_tests_rc")
    ap.add_argument("--python-tests-rc", default="none")
    ap.add_argument("--runs", nargs="*", default=[])
    ap.add_argument("--cpu-runs", nargs="*", default=[])
    a = ap.parse_args()
    out, logs = a.out, os.path.join(a.out, "logs")
    dry, build_ok = a.dry == "1", a.build_ok == "1"

    env = open(os.path.join(logs, "env.txt")).read()
    gpu = ""
    for line in env.splitlines():
        if "," in line and not line.startswith("name,") and ("NVIDIA" in line or "H100" in line or "H200" in line):
            gpu = line.split(",")[0].strip()
    cores = ""
    for line in env.splitlines():
        if line.startswith("host:"):
            cores = line

    def test_summary(name):
        p = os.path.join(logs, name)
        if not os.path.exists(p):
            return "not run"
        text = open(p).read().splitlines()
        totals = [l.strip() for l in text if re.match(r"^\[  (PASSED|FAILED|SKIPPED) +\] \d+ tests?", l)]
        failed = [l.split("]")[1].strip() for l in text if re.match(r"^\[  FAILED  \] \w+\.\w+", l)]
        return "; ".join(totals + (["failed: " + ", ".join(sorted(set(failed)))] if failed else [])) or "no summary"

    # The Python module built there and its pytest run (python-build.json
    # from scripts/gpu_python_module.py, python-tests.log).
    python = {"built": False, "reason": "no python-build.json: the build did not finish (see python-build.log)"}
    python.update(read_json(os.path.join(logs, "python-build.json")))
    python.pop("error", None)
    if not python["built"] and os.path.exists(os.path.join(logs, "python-build.log")):
        python["build_log_tail"] = open(os.path.join(logs, "python-build.log")).read().splitlines()[-5:]
    python["tests_exit_code"] = None if a.python_tests_rc == "none" else int(a.python_tests_rc)
    python["tests_summary"], python["tests_not_passed"] = "not run", []
    if os.path.exists(os.path.join(logs, "python-tests.log")):
        text = open(os.path.join(logs, "python-tests.log")).read().splitlines()
        summary = [l.strip("= ") for l in text if re.search(r"\d+ (passed|failed|skipped|errors?)\b.* in [\d.]+s", l)]
        python["tests_summary"] = summary[-1] if summary else "no summary"
        python["tests_not_passed"] = [l for l in text if re.match(r"^(FAILED|ERROR|SKIPPED) ", l)]
    # Counted like the other tests once carried: not built or failing is not OK.
    python["ok"] = (None if python.get("carried") is False
                    else python["built"] and python["tests_exit_code"] == 0)

    runs = []
    for name in a.runs:
        r = {"name": name}
        r.update(read_json(os.path.join(logs, f"bench-{name}.json")))
        r["exit_code"], r["cut"] = read_rc(os.path.join(logs, f"bench-{name}.rc"))
        samples = power_samples(os.path.join(logs, f"power-{name}.csv"))
        if samples:
            watts = [w for _, w in samples]
            r["power_samples"] = len(watts)
            r["board_power_mean_w"] = statistics.mean(watts)
            r["board_power_max_w"] = max(watts)
        if "sustained_start_unix" in r and samples:
            inside = [w for t, w in samples if r["sustained_start_unix"] + 0.3 <= t <= r["sustained_end_unix"]]
            if inside:
                r["sustained_power_samples"] = len(inside)
                r["sustained_power_mean_w"] = statistics.mean(inside)
                r["energy_per_frame_j"] = r["sustained_power_mean_w"] * r["sustained_wall_ms_per_frame"] / 1000
        runs.append(r)

    cpu_runs = []
    for name in a.cpu_runs:
        d = read_json(os.path.join(logs, f"cpu-{name}.json"))
        c = {"name": name}
        if "summary" in d:
            frames = d.get("frames", [])
            c.update({
                "engine": d["params"]["engine"], "objects": d["params"]["n"], "threads": d["params"]["threads"],
                "frames": len(frames), "first_frame_ms": d["summary"]["first_wall_ms"],
                "median_frame_ms": d["summary"]["median_wall_ms"], "p99_frame_ms": d["summary"]["p99_wall_ms"],
                "worst_frame_ms": d["summary"]["max_wall_ms"],
                "median_engine_ms": d["summary"]["median_engine_ms"],
                "pairs_per_frame": [f["pairs"] for f in frames],
            })
        else:
            c["error"] = d.get("error", "no summary")
        cpu_runs.append(c)

    # The same scene's frames on the GPU and on the CPU: equal pair counts on
    # every frame both ran, and the speed ratio of their medians.
    comparisons = []
    for c in cpu_runs:
        if c.get("engine") != "sw":
            continue
        kind, n = scene_of(c["name"])
        # The scene's own run (its name is the scene's: default options).
        g = next((r for r in runs if r["name"] == f"{kind}-{n}" and r.get("system") == "frame"), None)
        if not g or not g.get("median_frame_ms"):
            continue
        common = min(len(c["pairs_per_frame"]), len(g.get("pairs_per_frame", [])))
        comparisons.append({
            "scene": kind, "objects": n,
            "gpu_median_ms": g["median_frame_ms"], "cpu_median_ms": c["median_frame_ms"],
            "cpu_over_gpu": c["median_frame_ms"] / g["median_frame_ms"],
            "frames_compared": common,
            "pair_counts_equal": common > 0 and c["pairs_per_frame"][:common] == g["pairs_per_frame"][:common],
        })
    paper = next((r for r in runs if r["name"] == "paper-1024000"), None)
    peer = next((r for r in runs if r["name"] == "axis-sweep-paper-1024000"), None)
    lbvh = next((r for r in runs if r["name"] == "lbvh-paper-1024000"), None)
    cells = next((c for c in cpu_runs if c["name"] == "paper-1024000-cuda-cells"), None)
    blocks = next((r for r in runs if r["name"] == "paper-1024000-block-per-cell"), None)
    cubes = next((r for r in runs if r["name"] == "paper-1024000-cubes"), None)

    report = {
        "date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "dry_run": dry,
        "gpu": "" if dry else gpu,
        "host": cores,
        "environment": env,
        "build_ok": build_ok,
        "build_seconds": a.build_s,
        "gpu_tests": {"exit_code": a.tests_rc, "summary": test_summary("tests.log"),
                      "peers_summary": test_summary("tests-peers.log"), "required_device": not dry},
        "engine_tests": ({"exit_code": int(a.engine_tests_rc), "summary": test_summary("engine-tests.log")}
                         if a.engine_tests_rc != "none" else {"exit_code": None, "summary": "not run"}),
        "python_module": python,
        "runs": runs,
        "cpu_runs": cpu_runs,
        "comparisons": comparisons,
    }
    # hbp bench gpu of the carried main build, when it ran.
    if os.path.exists(os.path.join(logs, "hbp-bench-gpu.rc")):
        exit_code, cut = read_rc(os.path.join(logs, "hbp-bench-gpu.rc"))
        hbp_bench = read_json(os.path.join(logs, "hbp-bench-gpu.json"))
        if cut:
            report["hbp_bench_gpu"] = {"cut": True}
        elif "error" not in hbp_bench:
            report["hbp_bench_gpu"] = {k: hbp_bench.get(k) for k in ("device", "objects", "frames", "frame_ms",
                                                                     "cpu", "cpu_over_gpu", "frames_mismatched",
                                                                     "exact")}
        else:
            text = open(os.path.join(logs, "hbp-bench-gpu.log")).read().strip()
            report["hbp_bench_gpu"] = {"error": f"exit {exit_code}: {text[-500:]}"}
    ok = build_ok and a.tests_rc == 0 and bool(runs)
    hbp_bench_gpu = report.get("hbp_bench_gpu", {"exact": True})
    ok = ok and (hbp_bench_gpu.get("exact") is True or hbp_bench_gpu.get("cut") is True)
    ok = ok and all((r.get("exit_code") == 0 and r.get("exact")) or r["cut"] for r in runs)
    # hbp bench kind with the GPU systems (the carried main build), when it ran.
    if os.path.exists(os.path.join(logs, "hbp-bench-kind.rc")):
        exit_code, cut = read_rc(os.path.join(logs, "hbp-bench-kind.rc"))
        text = open(os.path.join(logs, "hbp-bench-kind.log")).read()
        # All four systems ran (sw and the three GPU ones): a GPU system that
        # could not start would be left out of the tables, not fail the run.
        all_ran = dry or "4 system(s)" in text
        report["hbp_bench_kind"] = {"exit_code": exit_code, "cut": cut, "all_systems_ran": all_ran,
                                    "log_tail": text.strip().splitlines()[-4:]}
        ok = ok and (cut or (exit_code == 0 and all_ran))
    ok = ok and report["engine_tests"]["exit_code"] in (None, 0)
    ok = ok and all(c["pair_counts_equal"] for c in comparisons)
    ok = ok and python["ok"] in (None, True)
    report["ok"] = ok
    if not dry and paper and paper.get("exact") and paper.get("median_frame_ms"):
        block = {"frame_ms": paper["median_frame_ms"], "first_frame_ms": paper["first_frame_ms"],
                 "first_frame": paper.get("first_frame"), "reserve_ms": paper.get("reserve_ms"),
                 "first_over_median": paper["first_frame_ms"] / paper["median_frame_ms"],
                 "with_transfers_ms": paper["median_frame_ms"] + paper["median_upload_ms"] + paper["median_download_ms"],
                 "over_paper_accelerator": PAPER_ACCELERATOR_MS / paper["median_frame_ms"],
                 "over_paper_gpu_sap": PAPER_GPU_SAP_MS / paper["median_frame_ms"],
                 "over_paper_cpu_dbvt": PAPER_CPU_DBVT_MS / paper["median_frame_ms"]}
        if paper.get("energy_per_frame_j"):
            block["energy_per_frame_j"] = paper["energy_per_frame_j"]
            block["energy_basis"] = ("mean board power (nvidia-smi) during back-to-back device frames "
                                     "x wall time per frame of that loop")
        if peer and peer.get("median_frame_ms"):
            block["axis_sweep_ms"] = peer["median_frame_ms"]
            block["axis_sweep_over_frame"] = peer["median_frame_ms"] / paper["median_frame_ms"]
        if lbvh and lbvh.get("median_frame_ms"):
            block["lbvh_ms"] = lbvh["median_frame_ms"]
            block["lbvh_over_frame"] = lbvh["median_frame_ms"] / paper["median_frame_ms"]
        if blocks and blocks.get("median_frame_ms"):
            block["block_per_cell_ms"] = blocks["median_frame_ms"]
            block["block_per_cell_over_frame"] = blocks["median_frame_ms"] / paper["median_frame_ms"]
        if cubes and cubes.get("median_frame_ms"):
            block["cubic_cells_ms"] = cubes["median_frame_ms"]
            block["cubic_cells_over_frame"] = cubes["median_frame_ms"] / paper["median_frame_ms"]
        cpu = next((c for c in comparisons if c["scene"] == "paper" and c["objects"] == 1024000), None)
        if cpu:
            block["cpu_sw_ms"] = cpu["cpu_median_ms"]
            block["cpu_over_gpu"] = cpu["cpu_over_gpu"]
        if cells and cells.get("median_engine_ms") is not None:
            block["cpu_cells_gpu_accelerator_engine_ms"] = cells["median_engine_ms"]
        report["paper_1024000"] = block
    with open(os.path.join(out, "gpu-report.json"), "w") as f:
        json.dump(report, f, indent=2)

    def fmt(v, f="{:.3f}"):
        return "—" if v is None else (f.format(v) if isinstance(v, (int, float)) and not isinstance(v, bool) else str(v))

    md = ["# GPU check", ""]
    md += (["**Dry run, no GPU:** the figures below are the CPU launcher's on the build machine, not a device's.", ""]
           if dry else [f"GPU: **{gpu or 'unknown'}**, {report['date']}; {cores}.", ""])
    md += ["```", env.strip(), "```", "",
           f"- build: {'ok' if build_ok else 'FAILED'} ({a.build_s} s from the start)",
           f"- gpu-labelled tests (tools/gpu build): exit {a.tests_rc}; frame: {report['gpu_tests']['summary']}; "
           f"peers: {report['gpu_tests']['peers_summary']}",
           f"- device tests of the main build (the `cuda` cell engine too): {report['engine_tests']['summary']}"]
    if python["built"]:
        p11 = python.get("pybind11", {})
        md.append(f"- Python module (python {python.get('python')}, pybind11 {p11.get('version')} from "
                  f"{p11.get('from')}; built in {python.get('seconds')} s): test_cuda_arrays.py, test_find_pairs.py: "
                  f"exit {fmt(python['tests_exit_code'], '{}')}; {python['tests_summary']}"
                  + ("" if python["ok"] else " — **NOT OK**"))
        md += [f"  - `{l}`" for l in python["tests_not_passed"]]
        md += [f"  - first tried, did not compile: {f}" for f in python.get("pybind11_failures", [])]
    else:
        md.append(f"- Python module: not built (python {python.get('python', '?')}): {python.get('reason')}"
                  + ("" if python["ok"] is None else " — **NOT OK**"))
        if python["ok"] is not None:
            md += [f"  - `{l}`" for l in python.get("build_log_tail", []) if l.strip()]
    md.append("")
    cols = [("objects", "objects", "{:.0f}"), ("order", "order", "{}"), ("pair order", "pair_order", "{}"), ("pair write", "pair_write", "{}"),
            ("sweep", "sweep", "{}"), ("cells", "cell_shape", "{}"), ("grid", "grid", "{}"),
            ("references", "references", "{:.0f}"), ("reserve", "reserve_ms", "{:.1f}"),
            ("first frame", "first_frame", "{}"), ("first", "first_frame_ms", "{:.3f}"),
            ("median", "median_frame_ms", "{:.3f}"), ("p99", "p99_frame_ms", "{:.3f}"),
            ("worst", "worst_frame_ms", "{:.3f}"), ("upload", "median_upload_ms", "{:.3f}"),
            ("download", "median_download_ms", "{:.3f}"), ("pairs", "mean_pairs", "{:.0f}"),
            ("pairs/s", "pairs_per_second", "{:.3g}"), ("MiB", "buffer_mib", "{:.0f}"),
            ("steady allocs", "steady_allocations", "{:.0f}"), ("W (sustained)", "sustained_power_mean_w", "{:.0f}"),
            ("mJ/frame", "energy_per_frame_mj", "{:.3f}"), ("CPU launcher ms", "reference_median_ms", "{:.1f}"),
            ("exact", "exact", "{}")]
    for r in runs:
        if r.get("grid_x") is not None:
            r["grid"] = f"{r['grid_x']:.0f}x{r['grid_y']:.0f}x{r['grid_z']:.0f}"
        if r.get("buffer_bytes") is not None:
            r["buffer_mib"] = r["buffer_bytes"] / 2**20
        if r.get("energy_per_frame_j") is not None:
            r["energy_per_frame_mj"] = r["energy_per_frame_j"] * 1000
    md += [("Frame times in ms (dry run: the CPU launcher's wall time)." if dry else
            "GPU frame, ms of device time (CUDA events, bounds to order; upload and download are the host "
            "transfers, apart). Every checked frame equal to the CPU launcher's list, and sampled objects "
            "against brute force."), "",
           "| run | " + " | ".join(c[0] for c in cols) + " |", "|---" * (len(cols) + 1) + "|"]
    for r in runs:
        md.append(f"| {r['name']} | " + " | ".join(fmt(r.get(k), f) for _, k, f in cols) + " |")
    stages = ["bounds", "refs", "sort", "count", "fill", "order"]
    md += ["", "Median device time per stage (ms):", "", "| run | " + " | ".join(stages) + " |",
           "|---" * 7 + "|"]
    for r in runs:
        md.append(f"| {r['name']} | " + " | ".join(fmt(r.get(f"median_{s}_ms")) for s in stages) + " |")
    if cpu_runs:
        md += ["", f"Our CPU engine (`hbp run`, wall ms per frame, all {cores.split(',')[1].strip() if ',' in cores else ''}):",
               "", "| run | engine | objects | threads | first | median | p99 | worst | engine ms |",
               "|---|---|---|---|---|---|---|---|---|"]
        for c in cpu_runs:
            md.append(f"| {c['name']} | {c.get('engine', '—')} | {fmt(c.get('objects'), '{}')} | "
                      f"{fmt(c.get('threads'), '{}')} | {fmt(c.get('first_frame_ms'))} | {fmt(c.get('median_frame_ms'))} | "
                      f"{fmt(c.get('p99_frame_ms'))} | {fmt(c.get('worst_frame_ms'))} | {fmt(c.get('median_engine_ms'))} |"
                      + (f" {c['error']}" if "error" in c else ""))
    if comparisons:
        md += ["", "The same scenes, GPU frame against our CPU engine in the same run (medians):", "",
               "| scene | objects | GPU ms | CPU ms | CPU / GPU | frames compared | pair counts equal |",
               "|---|---|---|---|---|---|---|"]
        for c in sorted(comparisons, key=lambda c: (c["scene"], c["objects"])):
            md.append(f"| {c['scene']} | {c['objects']} | {c['gpu_median_ms']:.3f} | {c['cpu_median_ms']:.3f} | "
                      f"{c['cpu_over_gpu']:.1f} | {c['frames_compared']} | {c['pair_counts_equal']} |")
    if "paper_1024000" in report:
        p = report["paper_1024000"]
        md += ["", "Paper scene, 1,024,000 objects, against the paper's Tables 4 and 5 (their figures, their "
               "machines; the accelerator's is modelled):", "",
               "| system | ms per frame | / our GPU frame |", "|---|---|---|",
               f"| our GPU frame ({gpu}, device time) | {p['frame_ms']:.3f} | 1 |",
               f"| our GPU frame with host transfers | {p['with_transfers_ms']:.3f} | "
               f"{p['with_transfers_ms'] / p['frame_ms']:.2f} |"]
        if "block_per_cell_ms" in p:
            md.append(f"| our GPU frame, the paper's block per cell (same run) | {p['block_per_cell_ms']:.3f} | "
                      f"{p['block_per_cell_over_frame']:.2f} |")
        if "cubic_cells_ms" in p:
            md.append(f"| our GPU frame, cubic cells (same run) | {p['cubic_cells_ms']:.3f} | "
                      f"{p['cubic_cells_over_frame']:.2f} |")
        if "axis_sweep_ms" in p:
            md.append(f"| our GPU one-axis sort and sweep (same run) | {p['axis_sweep_ms']:.3f} | "
                      f"{p['axis_sweep_over_frame']:.1f} |")
        if "lbvh_ms" in p:
            md.append(f"| our GPU LBVH (same run) | {p['lbvh_ms']:.3f} | {p['lbvh_over_frame']:.1f} |")
        if "cpu_sw_ms" in p:
            md.append(f"| our CPU engine, same machine (same run) | {p['cpu_sw_ms']:.3f} | {p['cpu_over_gpu']:.1f} |")
        md += [f"| paper: accelerator (modelled) | {PAPER_ACCELERATOR_MS} | {p['over_paper_accelerator']:.1f} |",
               f"| paper: Bullet3 GPU sort and sweep | {PAPER_GPU_SAP_MS} | {p['over_paper_gpu_sap']:.0f} |",
               f"| paper: Bullet DBVT (CPU) | {PAPER_CPU_DBVT_MS} | {p['over_paper_cpu_dbvt']:.0f} |"]
        for name, n, ms in TABLE5:
            md.append(f"| Table 5: {name}, {n:,} objects | {ms} | {ms / p['frame_ms']:.0f} |")
        if "energy_per_frame_j" in p:
            md += ["", f"Energy per steady frame: {p['energy_per_frame_j'] * 1000:.3f} mJ ({p['energy_basis']})."]
    if "hbp_bench_gpu" in report:
        h = report["hbp_bench_gpu"]
        if "error" in h:
            md += ["", f"`hbp bench gpu` (main build): failed: {h['error']}"]
        elif h.get("cut"):
            md += ["", "`hbp bench gpu` (main build): cut by the script's deadline."]
        else:
            md += ["", f"`hbp bench gpu --kind paper --n 1024000` (main build, {h.get('device')}): GPU frame median "
                   f"{fmt((h.get('frame_ms') or {}).get('median'))} ms, our CPU engine "
                   f"{fmt(((h.get('cpu') or {}).get('frame_ms') or {}).get('median'))} ms (x{fmt(h.get('cpu_over_gpu'), '{:.1f}')}); "
                   f"frames mismatched {h.get('frames_mismatched')}; exact {h.get('exact')}."]
    if "hbp_bench_kind" in report:
        k = report["hbp_bench_kind"]
        state = "cut by the script's deadline" if k["cut"] else f"exit {k['exit_code']}"
        md += ["", f"`hbp bench kind paper --n 100000 --systems sw,cuda,cuda-axis-sweep,cuda-lbvh` (main build): "
               f"{state}" + ("" if k["cut"] or (k["exit_code"] == 0 and k["all_systems_ran"])
                             else " — **NOT OK**" + ("" if k["all_systems_ran"] else " (not every system ran)"))]
        md += [f"  - `{l}`" for l in k["log_tail"]]
    cut = [r["name"] for r in runs if r["cut"]]
    if cut:
        md += ["", "Cut by the script's deadline (listed, not failures): " + ", ".join(cut) + "."]
    md += ["", f"Overall: {'OK' if ok else 'NOT OK'}", ""]
    with open(os.path.join(out, "gpu-report.md"), "w") as f:
        f.write("\n".join(md))
    print("\n".join(md))
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
