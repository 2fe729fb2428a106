#!/usr/bin/env python3
"""Slowdown against the page cache's budget, from `scripts/ooc_render.sh` logs.

Usage: plot_budget_sweep.py SWEEP_LOG OUT_PNG [--title TEXT]

SWEEP_LOG holds, for each budget, a line "=== round R fraction 1/F budget B"
(F = 0 for unlimited) followed by what `ooc_render.sh` printed with
WARM=N ("warm render ... X s daemon CPU" lines and the "cache ..." line
with the hit rate). Each budget's slowdown is the median warm daemon CPU
over the median of the same round's unlimited run; one line per round,
the hit rate printed under each point of the first round, the 1.5x goal
dashed. Where the cache line gives the peak of pages pinned beyond the
budget ("at most X MiB", pbgi status since 2026-11-28), each round also
gets the same slowdowns against the cache's budget plus that peak (hollow
markers): the views the render held at most. Prints the table it plots
(markdown). Exits 3 without matplotlib.
"""
import re
import statistics
import sys

NO_MATPLOTLIB = 3


def parse(path):
    runs = {}  # (round, fraction) -> {"cpu": [...], "hit": float}
    current = None
    for line in open(path, encoding="utf-8"):
        m = re.match(r"=== round (\d+) fraction 1/(\d+) budget (\d+)", line)
        if m:
            current = (int(m[1]), int(m[2]))
            runs[current] = {"cpu": [], "hit": None, "budget": int(m[3]), "pinned": None}
            continue
        if current is None:
            continue
        m = re.search(r"([\d.]+) s daemon CPU", line)
        if m:
            runs[current]["cpu"].append(float(m[1]))
        m = re.match(r"cache .*\(([\d.]+)% hits\)", line)
        if m:
            runs[current]["hit"] = float(m[1])
            pinned = re.search(r"at most ([\d.]+) MiB", line)
            if pinned:
                runs[current]["pinned"] = float(pinned[1]) * 2**20
    return runs


def main(argv):
    if len(argv) < 3:
        print(__doc__, file=sys.stderr)
        return 1
    title = argv[argv.index("--title") + 1] if "--title" in argv else "slowdown against the page cache's budget"
    runs = parse(argv[1])
    rounds = sorted({r for r, _ in runs})
    table = {}
    for r in rounds:
        base = runs.get((r, 0))
        if not base or not base["cpu"]:
            print(f"round {r} has no unlimited run", file=sys.stderr)
            return 1
        unlimited = statistics.median(base["cpu"])
        for (rr, f), v in runs.items():
            if rr == r and f != 0 and v["cpu"]:
                # The views held at most, as a fraction of the set: budget + pinned peak.
                total = None if v["pinned"] is None else (v["budget"] + v["pinned"]) / (v["budget"] * f)
                table.setdefault(f, {})[r] = (statistics.median(v["cpu"]), statistics.median(v["cpu"]) / unlimited,
                                              v["hit"], total)
        table.setdefault(0, {})[r] = (unlimited, 1.0, base["hit"], None)
    fractions = sorted((f for f in table if f != 0), reverse=True)
    print("| budget | " + " | ".join(f"round {r}: CPU s, ratio, hit rate, cache + pinned peak" for r in rounds) + " |")
    print("| --- |" + " --- |" * len(rounds))
    for f in fractions + [0]:
        cells = []
        for r in rounds:
            cpu, ratio, hit, total = table[f].get(r, (None, None, None, None))
            held = "" if total is None else f", {total:.3f} of the set"
            cells.append("-" if cpu is None else f"{cpu:.2f} s, {ratio:.2f}x, {hit:.1f}%{held}")
        print(f"| {'unlimited' if f == 0 else '1/' + str(f)} | " + " | ".join(cells) + " |")
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("no matplotlib: no plot", file=sys.stderr)
        return NO_MATPLOTLIB
    fig, ax = plt.subplots(figsize=(6.4, 4.0))
    xs = [1.0 / f for f in fractions]
    for r in rounds:
        ys = [table[f][r][1] if r in table[f] else float("nan") for f in fractions]
        line = ax.plot(xs, ys, marker="o", label=f"round {r}")[0]
        totals = [table[f][r][3] if r in table[f] else None for f in fractions]
        if all(t is not None for t in totals):
            ax.plot(totals, ys, marker="o", fillstyle="none", linestyle=":", color=line.get_color(),
                    label=f"round {r}, against cache + pinned peak")
    for x, f in zip(xs, fractions):
        hit = table[f][rounds[0]][2]
        if hit is not None:
            ax.annotate(f"{hit:.0f}%", (x, table[f][rounds[0]][1]), textcoords="offset points", xytext=(0, -14),
                        ha="center", fontsize=7)
    ax.axhline(1.5, linestyle="--", color="grey", linewidth=1, label="goal at 1/8: 1.5x")
    ax.axvline(1 / 8, linestyle=":", color="grey", linewidth=1)
    ax.set_xscale("log", base=2)
    ax.set_xticks(xs)
    ax.set_xticklabels([f"1/{f}" if f != 1 else "1" for f in fractions])
    ax.set_xlabel("page cache budget (filled), with the pinned peak (hollow): fraction of the set on disk")
    ax.set_ylabel("warm render CPU / unlimited")
    ax.set_title(title, fontsize=10)
    ax.legend(fontsize=8)
    ax.grid(True, alpha=0.3)
    fig.tight_layout()
    fig.savefig(argv[2], dpi=110)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
