#!/usr/bin/env python3
"""Regenerates BENCHMARKS.md's "Simulated scenarios (generated)" sections from the code as it is.

Every figure comes from an `atrium` command printed next to it, with the machine it ran on, so a
stale figure is one command away from being caught:

  python3 scripts/benchmark_figures.py --write               # everything (about 40 min on 2 cores)
  python3 scripts/benchmark_figures.py --only speed --write  # real-time factors, one run at a time
  python3 scripts/benchmark_figures.py --only seeds --scenario wifi_atrium   # print, do not write

With `--write` each generated part replaces the text between its markers in BENCHMARKS.md
(`<!-- figures:speed:begin -->` ... `<!-- figures:speed:end -->`, likewise `experiments` and
`seeds`); without it the sections are printed. `--scenario` limits the seed checks and is
never written (a partial table would replace the whole one).

Real-time factors run one scenario at a time (one core busy, `timing` of `atrium run --json`,
the drive only). Seed spreads come from `atrium check SCENARIO --seeds 1..10 --json`, which
runs the seeds in parallel. Build first: `cargo build --release -p atrium-cli`.
"""

import argparse
import json
import os
import platform
import subprocess
import sys
import time

ROOT = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))

# The node and appearance experiments have their own commands and tests (`atrium nodes`,
# `atrium appearance`); every other bundled scenario with expectations is checked on seeds.


def atrium():
    exe = os.path.join(ROOT, "target", "release", "atrium")
    if not os.path.exists(exe):
        sys.exit(f"{exe} not found: run `cargo build --release -p atrium-cli` first")
    return exe


def run_json(args):
    out = subprocess.run(
        [atrium(), *args], cwd=ROOT, capture_output=True, text=True, check=False
    )
    try:
        return json.loads(out.stdout)
    except json.JSONDecodeError:
        sys.exit(f"atrium {' '.join(args)} gave no JSON (exit {out.returncode}):\n{out.stderr}")


def bundled_scenarios():
    d = os.path.join(ROOT, "scenarios")
    names = sorted(f[:-5] for f in os.listdir(d) if f.endswith(".toml"))
    return [n for n in names if not n.startswith("tmp_")]


def scenarios_with_expectations():
    def has_expect(name):
        with open(os.path.join(ROOT, "scenarios", name + ".toml")) as f:
            return any(line.startswith("[expect") for line in f)

    return [n for n in bundled_scenarios() if has_expect(n)]


def fmt(v):
    if v is None:
        return "never"
    a = abs(v)
    if a != 0 and (a < 0.01 or a >= 1000):
        return f"{v:.3g}"
    return f"{v:.3f}".rstrip("0").rstrip(".")


def cpu_model():
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown CPU"


def write_section(name, lines):
    """Replaces BENCHMARKS.md's text between the `name` markers with `lines`."""
    path = os.path.join(ROOT, "BENCHMARKS.md")
    text = open(path, encoding="utf-8").read()
    begin, end = f"<!-- figures:{name}:begin -->", f"<!-- figures:{name}:end -->"
    a, b = text.index(begin) + len(begin), text.index(end)
    body = "\n".join(lines).strip("\n")
    with open(path, "w", encoding="utf-8") as f:
        f.write(text[:a] + "\n" + body + "\n" + text[b:])


def speed_section():
    lines = [
        "### Real-time factors (one run each, the scenario's own seed, drive only)",
        "",
        f"Machine: {cpu_model()}, {platform.machine()}, {os.cpu_count()} cores, "
        f"{platform.platform()}; measured {time.strftime('%Y-%m-%d')}.",
        "",
        "| scenario | real time × | simulator s | localizers s (heaviest) | command |",
        "|---|---|---|---|---|",
    ]
    for name in bundled_scenarios():
        path = f"scenarios/{name}.toml"
        out = subprocess.run(
            [atrium(), "run", path, "--json"], cwd=ROOT, capture_output=True, text=True
        )
        try:
            d = json.loads(out.stdout)
        except json.JSONDecodeError:
            continue  # not a driving scenario (experiments have their own commands)
        t = d.get("timing") or {}
        if not t:
            continue
        locs = t.get("localizers_s", {})
        heavy = sorted(locs.items(), key=lambda kv: -kv[1])[:2]
        heavy = ", ".join(f"{k} {v:.2f}" for k, v in heavy)
        lines.append(
            f"| {name} | {t['real_time_factor']:.0f} | {t['sim_s']:.2f} | {heavy} "
            f"| `atrium run {path} --json` |"
        )
        print(lines[-1], file=sys.stderr)
    return lines


def seeds_section(names, seeds):
    lines = [
        f"### Expectations over seeds {seeds}",
        "",
        "Each row: the metric's min / median / max over the seeds and on how many the bound "
        "held; `claims also met by B` counts the claims a baseline B meets on the same run "
        "(it must fail at least one).",
        "",
    ]
    for name in names:
        path = f"scenarios/{name}.toml"
        cmd = f"atrium check {path} --seeds {seeds}"
        d = run_json(["check", path, "--seeds", seeds, "--json"])
        n = len(d["seeds"])
        lines += [
            f"**{name}**: passed on {d['passed_seeds']} of {n} seeds — `{cmd}`",
            "",
            "| localizer | metric | bound | held | min | median | max |",
            "|---|---|---|---|---|---|---|",
        ]
        for e in d["expectations"]:
            bound = ("<= " if e["bound"] == "max" else ">= ") + fmt(e["limit"])
            lines.append(
                f"| {e['localizer']} | {e['metric']} | {bound} | {e['held']}/{n} "
                f"| {fmt(e['min'])} | {fmt(e['median'])} | {fmt(e['max'])} |"
            )
        lines.append("")
        print(f"{name}: {d['passed_seeds']}/{n}", file=sys.stderr)
    return lines


def experiments_section():
    lines = ["### Experiments with their own commands", ""]
    for name in ["wheelchair_nodes", "wheelchair_nodes_paper"]:
        path = f"scenarios/{name}.toml"
        d = run_json(["nodes", path, "--json"])
        lines += [
            f"**{name}** (002 Table II), seeds {d['seeds']} — `atrium nodes {path}`",
            "",
            "| claim | value | limit | held |",
            "|---|---|---|---|",
        ]
        for c in d["checks"]:
            lines.append(
                f"| {c['what']} | {fmt(c['value'])} | {fmt(c['limit'])} "
                f"| {'yes' if c['passed'] else 'NO'} |"
            )
        lines.append("")
        print(f"{name}: nodes", file=sys.stderr)
    path = "scenarios/appearance_lab.toml"
    d = run_json(["appearance", path, "--json"])
    r = d["report"]
    lines += [
        f"**appearance_lab** (000 §VII), {d['image'][0]} × {d['image'][1]} px, "
        f"{r['training_images']} training images — `atrium appearance {path}`",
        "",
        f"Missing disparity {100 * r['disparity_missing']:.1f} %, "
        f"{100 * r['disparity_within_1px']:.1f} % of valid disparities within 1 px; "
        f"EM-PCA {r['empca_iterations']} iterations "
        f"({'converged' if r['empca_converged'] else 'NOT converged'}).",
        "",
        f"| lighting | mean e: intensity (J = {d['j_intensity']}) "
        f"| intensity + disparity ({d['j_each']} + {d['j_each']}) "
        f"| disparity (J = {d['j_intensity']}) | disparity (J = {d['j_each']}) | random poses |",
        "|---|---|---|---|---|---|",
    ]
    for c in r["conditions"]:
        lines.append(
            f"| {c['lighting']} | {fmt(c['intensity']['mean'])} "
            f"| {fmt(c['intensity_disparity']['mean'])} | {fmt(c['disparity']['mean'])} "
            f"| {fmt(c['disparity_each']['mean'])} | {fmt(c['random']['mean'])} |"
        )
    lines += ["", "| claim | measured | held |", "|---|---|---|"]
    for c in d["checks"]:
        lines.append(f"| {c['claim']} | {c['detail']} | {'yes' if c['passed'] else 'NO'} |")
    lines.append("")
    print("appearance_lab", file=sys.stderr)
    return lines


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--only", choices=["speed", "seeds", "experiments"])
    ap.add_argument("--seeds", default="1..10")
    ap.add_argument("--scenario", action="append", help="limit the seed checks to these")
    ap.add_argument("--write", action="store_true", help="rewrite BENCHMARKS.md's sections")
    a = ap.parse_args()
    if a.write and a.scenario:
        ap.error("--scenario gives a partial seed table: print it, do not --write it")
    parts = []
    if a.only in (None, "speed"):
        parts.append(("speed", speed_section()))
    if a.only in (None, "experiments"):
        parts.append(("experiments", experiments_section()))
    if a.only in (None, "seeds"):
        parts.append(("seeds", seeds_section(a.scenario or scenarios_with_expectations(), a.seeds)))
    for name, lines in parts:
        if a.write:
            write_section(name, lines)
        else:
            print("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
