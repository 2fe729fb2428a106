#!/usr/bin/env python3
"""Speed-vs-error plot of a `pbgi bench` run.

Usage: plot_bench.py BENCH_JSON OUT_PNG [--time wall|cpu]

Two log-log panels (MSE of the indirect AOV, MSE of the beauty) against
render time in seconds. One line per series of the sweep (the path tracer
over spp; PBGI and factorized PBGI per surfel budget and microbuffer
resolution over the cut threshold; each further payload codec per gather
method over the microbuffer resolution), coloured by method (PBGI blues,
FPBGI greens). Pareto-optimal configurations are ringed
and joined by a dashed staircase; PBGI's default configuration is a star,
its time including the build a hollow star; the path tracer's
interpolated point at the default's MSE is a cross. `--time cpu` puts the
process CPU seconds on the x axis instead of wall-clock seconds (fairer
when other processes shared the machine during the run).

Exits 3 if matplotlib is missing (the bench then reports "no plot"),
1 on any other error.
"""
import json
import sys

NO_MATPLOTLIB = 3

try:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
except ImportError as e:  # pragma: no cover - depends on the environment
    print(f"plot_bench.py: matplotlib unavailable ({e})", file=sys.stderr)
    sys.exit(NO_MATPLOTLIB)

# Each method has a family of colours; its series take them in turn, so
# PBGI's surfel budgets and microbuffers are told apart and the path tracer
# stays red.
METHOD_PALETTES = {
    "path": ["tab:red"],
    "pbgi": ["tab:blue", "tab:cyan", "navy", "tab:purple", "steelblue", "darkturquoise"],
    "fpbgi": ["tab:green", "olive", "darkgreen", "limegreen", "teal", "yellowgreen"],
}
EXTRA_PALETTES = [["tab:orange", "tab:brown", "gold"], ["tab:pink", "tab:gray", "black"]]
LINESTYLES = ["-", "--", ":", "-."]
MARKERS = ["o", "s", "^", "D", "v", "P"]


def series_styles(rows):
    """A (colour, linestyle, marker) per series, distinct within each method."""
    styles, count, palettes = {}, {}, dict(METHOD_PALETTES)
    for r in rows:
        s, m = r["series"], r["method"]
        if s in styles:
            continue
        if m not in palettes:
            palettes[m] = EXTRA_PALETTES[(len(palettes) - len(METHOD_PALETTES)) % len(EXTRA_PALETTES)]
        i = count.get(m, 0)
        count[m] = i + 1
        colours = palettes[m]
        styles[s] = (colours[i % len(colours)], LINESTYLES[(i // len(colours)) % len(LINESTYLES)],
                     MARKERS[i % len(MARKERS)])
    return styles


def with_time(bench, kind):
    """A copy of the rows whose *_seconds fields are the chosen clock's."""
    if kind == "wall":
        return bench
    out = dict(bench)
    out["rows"] = []
    for r in bench["rows"]:
        r = dict(r)
        r["render_seconds"] = r["render_cpu_seconds"]
        r["total_seconds"] = r["total_cpu_seconds"]
        out["rows"].append(r)
    # Pareto flags of bench.json are for wall time: recompute for CPU time.
    for aov in ("indirect", "beauty"):
        pts = [(r["render_seconds"], r[aov]["mse"]) for r in out["rows"]]
        for r, (t, e) in zip(out["rows"], pts):
            r["pareto_" + aov] = t is not None and e is not None and not any(
                t2 is not None and e2 is not None and t2 <= t and e2 <= e and (t2 < t or e2 < e)
                for t2, e2 in pts)
    eq = {}
    for aov, e in bench.get("equal_error", {}).items():
        e = dict(e)
        e["path_seconds"] = e["path_cpu_seconds"]
        eq[aov] = e
    out["equal_error"] = eq
    return out


def panel(ax, bench, aov, time_label):
    rows = [r for r in bench["rows"] if r[aov]["mse"] is not None and r[aov]["mse"] > 0]
    styles = series_styles(rows)
    # 1. One line per series, in sweep order.
    series = []
    for r in rows:
        if r["series"] not in series:
            series.append(r["series"])
    for s in series:
        pts = [r for r in rows if r["series"] == s]
        pts.sort(key=lambda r: r["render_seconds"])
        colour, ls, marker = styles[s]
        ax.plot([r["render_seconds"] for r in pts], [r[aov]["mse"] for r in pts],
                linestyle=ls, marker=marker, markersize=4, linewidth=1.2,
                color=colour, label=s, alpha=0.85)
    # 2. The Pareto front: ringed points joined by a staircase.
    front = sorted((r for r in rows if r["pareto_" + aov]), key=lambda r: r["render_seconds"])
    if front:
        ax.scatter([r["render_seconds"] for r in front], [r[aov]["mse"] for r in front],
                   s=90, facecolors="none", edgecolors="black", linewidths=1.2, zorder=5,
                   label="Pareto-optimal")
        ax.step([r["render_seconds"] for r in front], [r[aov]["mse"] for r in front],
                where="post", color="black", linestyle="--", linewidth=0.8, zorder=4)
    # 3. PBGI's default, with and without its build, and the path tracer at
    # equal error.
    for r in rows:
        if not r["is_default"]:
            continue
        ax.scatter([r["render_seconds"]], [r[aov]["mse"]], marker="*", s=220,
                   color="gold", edgecolors="black", zorder=6, label=f"default {r['name']}")
        ax.scatter([r["total_seconds"]], [r[aov]["mse"]], marker="*", s=160,
                   facecolors="none", edgecolors="black", zorder=6, label="default incl. build")
    eq = bench.get("equal_error", {}).get(aov, {})
    if eq.get("valid"):
        kind = "extrapolated" if eq["extrapolated"] else "interpolated"
        ax.scatter([eq["path_seconds"]], [eq["pbgi_mse"]], marker="X", s=110, color="tab:red",
                   edgecolors="black", zorder=6,
                   label=f"path at equal MSE: {eq['path_spp']:.1f} spp ({kind})")
        ax.axhline(eq["pbgi_mse"], color="grey", linewidth=0.6, linestyle=":")
        if eq["extrapolated"]:
            # The Monte Carlo rate from the nearest sweep point to the cross.
            path = sorted((r for r in rows if r["method"] == "path"), key=lambda r: r["spp"])
            end = path[-1] if eq["path_spp"] > path[-1]["spp"] else path[0]
            ax.plot([end["render_seconds"], eq["path_seconds"]], [end[aov]["mse"], eq["pbgi_mse"]],
                    color="tab:red", linestyle="--", linewidth=0.8, alpha=0.7)
        ax.set_title(f"{aov}: PBGI speed-up at equal MSE {eq['speedup']:.2g}x "
                     f"({eq['speedup_including_build']:.2g}x incl. build, "
                     f"{eq['speedup_cpu']:.2g}x in CPU time)", fontsize=10)
    else:
        ax.set_title(aov, fontsize=10)
    noise = bench["reference"].get(f"noise_mse_{aov}")
    if noise:
        ax.axhline(noise, color="tab:gray", linewidth=0.8, linestyle="-.",
                   label=f"reference noise ~{noise:.2g}")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel(time_label)
    ax.set_ylabel(f"MSE of {aov} vs reference")
    ax.grid(True, which="both", alpha=0.25)


def main(argv):
    args = argv[1:]
    kind = "wall"
    if len(args) == 4 and args[2] == "--time" and args[3] in ("wall", "cpu"):
        kind = args[3]
        args = args[:2]
    if len(args) != 2:
        print(__doc__, file=sys.stderr)
        return 1
    with open(args[0]) as f:
        bench = with_time(json.load(f), kind)
    label = "render time, wall clock (s)" if kind == "wall" else "render time, process CPU (s)"
    fig, axes = plt.subplots(1, 2, figsize=(15, 6.5))
    panel(axes[0], bench, "indirect", label)
    panel(axes[1], bench, "beauty", label)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="center right", fontsize=7, frameon=False)
    ref = bench["reference"]
    fig.suptitle(f"{bench['scene']}  {bench['camera']}  {bench['width']}x{bench['height']}  "
                 f"max depth {bench['max_depth']}  reference {ref['spp']} spp  "
                 f"{bench['threads']} threads", fontsize=10)
    fig.tight_layout(rect=(0, 0, 0.8, 0.95))
    fig.savefig(args[1], dpi=110)
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main(sys.argv))
    except (OSError, KeyError, ValueError) as e:
        print(f"plot_bench.py: {e}", file=sys.stderr)
        sys.exit(1)
