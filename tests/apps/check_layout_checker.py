#!/usr/bin/python3
"""The figures' layout check (scripts/szplot.py, layout_problems) finds what it is for:
overprinting labels, a label cut by the saved area, text cut by its axes; and nothing
in a clean figure. Run by CTest ("figures: the layout check finds cut and overprinting
text"); the figure tests rely on it.

    check_layout_checker.py REPO_ROOT
"""
import os
import sys

sys.path.insert(0, os.path.join(sys.argv[1], "scripts"))
import szplot  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402

szplot.setup()
failures = []


def expect(name, fig, needle):
    problems = szplot.layout_problems(fig)
    plt.close(fig)
    found = [p for p in problems if needle is not None and needle in p]
    if needle is None and problems:
        failures.append(f"{name}: a clean figure reported {problems}")
    if needle is not None and not found:
        failures.append(f"{name}: expected a problem with {needle!r}, got {problems}")


fig, ax = plt.subplots(figsize=(3.4, 2.8))
ax.plot([0, 1], [0, 1], label="a line")
ax.set_xlabel("x (m)")
ax.set_ylabel("y (m)")
ax.set_title("clean")
ax.legend()
expect("clean", fig, None)

fig, (a1, a2) = plt.subplots(1, 2, figsize=(3.4, 2.8))
a1.set_title("a very long title that runs into its neighbour's")
a2.set_title("the neighbour's own long title")
expect("titles", fig, "overprints")

fig, ax = plt.subplots(figsize=(3.4, 2.8))
ax.set_ylabel("a y label far too long for the height of this small figure (dimensionless)")
expect("long y label", fig, "y-label is cut by the saved area")

fig, ax = plt.subplots(figsize=(3.4, 2.8))
ax.text(0.9, 0.5, "text running out of its axes", transform=ax.transAxes, clip_on=True)
expect("clipped text", fig, "is cut by its axes")

fig, ax = plt.subplots(figsize=(3.4, 2.8))
ax.text(0.5, 0.5, "one label", transform=ax.transAxes)
ax.text(0.52, 0.5, "another label", transform=ax.transAxes)
expect("overprinting texts", fig, "overprints")

# a point label centred under a point at the axes' left edge runs over the y tick labels
# (the bench's speed chart on a slower machine); labels_inside moves it back inside
def edge_label():
    fig, ax = plt.subplots(figsize=(3.4, 2.8))
    ax.plot([2.5, 8.5], [0.032, 0.06], "o")
    ax.set_yscale("log")
    ax.set_yticks([0.03, 0.05])
    ax.set_yticklabels(["0.03", "0.05"])
    ax.annotate("--preset profile", (2.5, 0.032), xytext=(0, -9), textcoords="offset points",
                fontsize=7, ha="center", va="top")
    return fig


expect("label at the axes' edge", edge_label(), "overprints")
fig = edge_label()
szplot.labels_inside(fig)
expect("label at the axes' edge, moved inside", fig, None)

for f in failures:
    print(f"check_layout_checker: {f}", file=sys.stderr)
sys.exit(1 if failures else 0)
