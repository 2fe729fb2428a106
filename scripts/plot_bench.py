#!/usr/bin/env python3
"""Speed-vs-error plot of a `pbgi bench` run.

Usage: plot_bench.py BENCH_JSON OUT_PNG

Two log-log panels (MSE of the indirect AOV, MSE of the beauty) against
render time in seconds. One line per series of the sweep (the path tracer
over spp; PBGI per surfel budget and microbuffer resolution over the cut
threshold), coloured by method. Pareto-optimal configurations are ringed
and joined by a dashed staircase; PBGI's default configuration is a star,
its time including the build a hollow star; the path tracer's
interpolated point at the default's MSE is a cross.

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

METHOD_COLOURS = {"path": "tab:red", "pbgi": "tab:blue"}
EXTRA_COLOURS = ["tab:green", "tab:purple", "tab:orange", "tab:brown", "tab:olive"]
LINESTYLES = ["-", "--", ":", "-."]
MARKERS = ["o", "s", "^", "D", "v", "P"]


def method_colour(method, seen):
    if method in METHOD_COLOURS:
        return METHOD_COLOURS[method]
    if method not in seen:
        seen[method] = EXTRA_COLOURS[len(seen) % len(EXTRA_COLOURS)]
    return seen[method]


def series_styles(rows):
    """A (linestyle, marker) per series, distinct within each method."""
    styles, count = {}, {}
    for r in rows:
        s = r["series"]
        if s in styles:
            continue
        i = count.get(r["method"], 0)
        count[r["method"]] = i + 1
        styles[s] = (LINESTYLES[i % len(LINESTYLES)], MARKERS[(i // len(LINESTYLES)) % len(MARKERS)])
    return styles


def panel(ax, bench, aov):
    rows = [r for r in bench["rows"] if r[aov]["mse"] is not None and r[aov]["mse"] > 0]
    extra = {}
    styles = series_styles(rows)
    # 1. One line per series, in sweep order.
    series = []
    for r in rows:
        if r["series"] not in series:
            series.append(r["series"])
    for s in series:
        pts = [r for r in rows if r["series"] == s]
        pts.sort(key=lambda r: r["render_seconds"])
        ls, marker = styles[s]
        ax.plot([r["render_seconds"] for r in pts], [r[aov]["mse"] for r in pts],
                linestyle=ls, marker=marker, markersize=4, linewidth=1.2,
                color=method_colour(pts[0]["method"], extra), label=s, alpha=0.85)
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
        ax.set_title(f"{aov}: speed-up {eq['speedup']:.1f}x render, "
                     f"{eq['speedup_including_build']:.1f}x incl. build", fontsize=10)
    else:
        ax.set_title(aov, fontsize=10)
    noise = bench["reference"].get(f"noise_mse_{aov}")
    if noise:
        ax.axhline(noise, color="tab:gray", linewidth=0.8, linestyle="-.",
                   label=f"reference noise ~{noise:.2g}")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("render time (s)")
    ax.set_ylabel(f"MSE of {aov} vs reference")
    ax.grid(True, which="both", alpha=0.25)


def main(argv):
    if len(argv) != 3:
        print(__doc__, file=sys.stderr)
        return 1
    with open(argv[1]) as f:
        bench = json.load(f)
    fig, axes = plt.subplots(1, 2, figsize=(15, 6.5))
    panel(axes[0], bench, "indirect")
    panel(axes[1], bench, "beauty")
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="center right", fontsize=7, frameon=False)
    ref = bench["reference"]
    fig.suptitle(f"{bench['scene']}  {bench['camera']}  {bench['width']}x{bench['height']}  "
                 f"max depth {bench['max_depth']}  reference {ref['spp']} spp  "
                 f"{bench['threads']} threads", fontsize=10)
    fig.tight_layout(rect=(0, 0, 0.8, 0.95))
    fig.savefig(argv[2], dpi=110)
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main(sys.argv))
    except (OSError, KeyError, ValueError) as e:
        print(f"plot_bench.py: {e}", file=sys.stderr)
        sys.exit(1)
