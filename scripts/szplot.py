"""Shared figure style for the shearzone plot scripts (matplotlib and numpy only).

    import szplot
    szplot.setup()                       # rcParams: fonts, ticks, colours, markers
    fig, ax = plt.subplots(figsize=szplot.SINGLE)
    ax.errorbar(x, y, yerr=e, **szplot.series(i))
    szplot.legend_outside(ax)
    szplot.save(fig, "out.png")          # readable log ticks on every log axis, PNG at DPI

Every log axis gets at least three labelled ticks: decades when the data span several,
1-2-5 (or finer) steps when they span one or less, plain numbers (0.02, 5, 200) in the
range 1e-3..1e4 and a x 10^n beyond.
"""
import argparse
import math
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.ticker import FixedLocator, FuncFormatter, MaxNLocator, NullFormatter  # noqa: E402

DPI = 200
SINGLE = (3.4, 2.8)  # one journal column (8.6 cm), plus the room a legend outside takes
WIDE = (7.0, 2.9)  # two columns

# Okabe-Ito colours (colour-blind safe), distinct markers and line styles per series.
COLORS = ["#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9", "#000000", "#999999"]
MARKERS = ["o", "s", "^", "D", "v", "P", "X", "h"]
LINESTYLES = ["-", "--", "-.", ":", (0, (5, 1, 1, 1)), (0, (3, 1, 1, 1, 1, 1)), (0, (1, 1)), (0, (8, 2))]


def panel_parser(doc):
    """A parser whose first argument names the panel to draw: (parser, its subparsers)."""
    ap = argparse.ArgumentParser(description=doc, formatter_class=argparse.RawDescriptionHelpFormatter)
    return ap, ap.add_subparsers(dest="panel", required=True)


def setup():
    plt.rcParams.update({
        "font.size": 8,
        "axes.titlesize": 8.5,
        "axes.labelsize": 8.5,
        "legend.fontsize": 7,
        "xtick.labelsize": 7.5,
        "ytick.labelsize": 7.5,
        "figure.titlesize": 9,
        "axes.linewidth": 0.7,
        "lines.linewidth": 1.1,
        "lines.markersize": 4,
        "errorbar.capsize": 1.8,
        "xtick.direction": "in",
        "ytick.direction": "in",
        "xtick.top": True,
        "ytick.right": True,
        "xtick.major.size": 3.5,
        "ytick.major.size": 3.5,
        "xtick.minor.size": 2,
        "ytick.minor.size": 2,
        "legend.frameon": False,
        "legend.handlelength": 1.8,
        "axes.prop_cycle": matplotlib.cycler(color=COLORS),
        "mathtext.fontset": "dejavusans",
        "savefig.dpi": DPI,
        "figure.dpi": 100,
        "image.cmap": "viridis",
    })


def series(i, line=False, open_marker=False):
    """Colour and marker of series i (and a line style when line=True)."""
    s = {"color": COLORS[i % len(COLORS)], "marker": MARKERS[i % len(MARKERS)]}
    if open_marker:
        s["markerfacecolor"] = "white"
    s["linestyle"] = LINESTYLES[i % len(LINESTYLES)] if line else "none"
    return s


def fmt_num(v, _pos=None):
    """0.02, 5, 200 in 1e-3..1e4; 10^n or m x 10^n beyond."""
    if v == 0 or not math.isfinite(v):
        return "0"
    e = math.floor(math.log10(abs(v)) + 1e-9)
    if -3 <= e <= 4:
        return f"{v:.6g}"
    m = v / 10 ** e
    if abs(m - 1) < 1e-6:
        return rf"$10^{{{e}}}$"
    return rf"${m:.3g}\times10^{{{e}}}$"


def _log_ticks(lo, hi):
    lo, hi = min(lo, hi), max(lo, hi)
    if not (lo > 0 and math.isfinite(lo) and math.isfinite(hi)):
        return None
    e0, e1 = math.floor(math.log10(lo)) - 1, math.ceil(math.log10(hi)) + 1
    eps = 1e-9
    for subs in ((1,), (1, 3), (1, 2, 5), (1, 1.5, 2, 3, 5, 7), tuple(range(1, 10))):
        ticks = [m * 10.0 ** e for e in range(e0, e1 + 1) for m in subs]
        ticks = [t for t in ticks if lo * (1 - eps) <= t <= hi * (1 + eps)]
        if len(ticks) >= (4 if len(subs) < 3 else 3):
            break
    if len(ticks) > 7:  # many decades: every k-th one
        k = math.ceil(len(ticks) / 6)
        ticks = [t for t in ticks if round(math.log10(t)) % k == 0]
    if len(ticks) < 3:  # less than a factor ~1.3: linear steps
        ticks = [t for t in MaxNLocator(4).tick_values(lo, hi) if lo * (1 - eps) <= t <= hi * (1 + eps)]
    return ticks


def log_ticks(ax, which):
    """Readable labelled ticks on a log axis of ax ('x' or 'y'); keeps the limits."""
    axis = ax.xaxis if which == "x" else ax.yaxis
    lim = ax.get_xlim() if which == "x" else ax.get_ylim()
    ticks = _log_ticks(*lim)
    if not ticks:
        return
    axis.set_major_locator(FixedLocator(ticks))
    axis.set_major_formatter(FuncFormatter(fmt_num))
    lo, hi = min(lim), max(lim)
    minor = [m * 10.0 ** e for e in range(math.floor(math.log10(lo)), math.ceil(math.log10(hi)) + 1)
             for m in range(1, 10)]
    minor = [t for t in minor if lo <= t <= hi and all(abs(t / s - 1) > 1e-6 for s in ticks)]
    if len(ticks) > 6 and math.log10(hi / lo) > 6:  # very wide: decades only as minor ticks
        minor = [t for t in minor if abs(math.log10(t) - round(math.log10(t))) < 1e-9]
    axis.set_minor_locator(FixedLocator(minor))
    axis.set_minor_formatter(NullFormatter())
    (ax.set_xlim if which == "x" else ax.set_ylim)(lim)


def data_ticks(ax, which, values):
    """Label exactly these values on a (log) axis, e.g. the few settings a benchmark ran."""
    axis = ax.xaxis if which == "x" else ax.yaxis
    vals = sorted({float(v) for v in values if math.isfinite(float(v))})
    axis.set_major_locator(FixedLocator(vals))
    axis.set_major_formatter(FuncFormatter(fmt_num))
    axis.set_minor_locator(FixedLocator([]))
    axis._sz_fixed = True


def legend_outside(ax, title=None, **kw):
    """Legend to the right of the axes, off the data."""
    kw.setdefault("alignment", "left")
    return ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0, title=title,
                     title_fontsize=7, **kw)


def fix_log_axes(fig):
    """Readable ticks on every log axis of the figure (not those set by data_ticks)."""
    for ax in fig.axes:
        for which, axis in (("x", ax.xaxis), ("y", ax.yaxis)):
            if axis.get_scale() == "log" and not getattr(axis, "_sz_fixed", False):
                log_ticks(ax, which)


def tight(fig, **kw):
    """tight_layout after the log ticks are fixed (their labels set the margins)."""
    fix_log_axes(fig)
    fig.tight_layout(**kw)


def _texts(fig):
    """(description, Text) of every visible, non-empty text of the figure: titles, axis
    labels, tick labels, legend entries, annotations, figure texts."""
    out, seen = [], set()

    def add(what, t):
        if t is not None and id(t) not in seen and t.get_visible() and t.get_text().strip():
            seen.add(id(t))
            out.append((what, t))

    for i, ax in enumerate(fig.axes):
        if not ax.get_visible():
            continue
        name = f"axes {i}" + (f" ({ax.get_title()!r})" if ax.get_title() else "")
        for loc in ("title", "_left_title", "_right_title"):
            add(f"{name} title", getattr(ax, loc, None))
        for axis, which in ((ax.xaxis, "x"), (ax.yaxis, "y")):
            if not axis.get_visible():
                continue
            add(f"{name} {which}-label", axis.label)
            add(f"{name} {which} offset", axis.get_offset_text())
            # the ticks matplotlib draws: those inside the view (private, matplotlib 3.6)
            for tick in axis._update_ticks():
                if tick.get_visible():
                    for lab in (tick.label1, tick.label2):
                        add(f"{name} {which} tick {lab.get_text()!r}", lab)
        legend = ax.get_legend()
        if legend is not None and legend.get_visible():
            for t in legend.get_texts():
                add(f"{name} legend {t.get_text()!r}", t)
            add(f"{name} legend title", legend.get_title())
        for t in ax.texts:
            add(f"{name} text {t.get_text()!r}", t)
    if getattr(fig, "_suptitle", None) is not None:
        add("suptitle", fig._suptitle)
    for t in fig.texts:
        add(f"figure text {t.get_text()!r}", t)
    for legend in fig.legends:
        for t in legend.get_texts():
            add(f"figure legend {t.get_text()!r}", t)
    return out


def layout_problems(fig):
    """Text that is cut (by the saved area or by the axes that clip it) or that overprints
    other text, as a list of sentences (empty when the figure reads cleanly). Bounding
    boxes come from matplotlib's renderer, in display pixels; a pair of texts overprints
    when their boxes overlap by more than 1 px both ways."""
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    saved = fig.get_tightbbox(renderer).transformed(fig.dpi_scale_trans)  # inches -> px
    items = []
    for what, t in _texts(fig):
        bb = t.get_window_extent(renderer)
        if bb.width <= 0 or bb.height <= 0:
            continue
        items.append((what, t, bb))
    problems = []
    pad = 1.0
    for what, t, bb in items:
        if bb.x0 < saved.x0 - pad or bb.y0 < saved.y0 - pad or bb.x1 > saved.x1 + pad or bb.y1 > saved.y1 + pad:
            problems.append(f"{what} is cut by the saved area")
        clip = t.get_clip_box() if t.get_clip_on() else None
        if clip is not None and (bb.x0 < clip.x0 - pad or bb.x1 > clip.x1 + pad or bb.y0 < clip.y0 - pad
                                 or bb.y1 > clip.y1 + pad):
            problems.append(f"{what} is cut by its axes")
    for i in range(len(items)):
        for j in range(i + 1, len(items)):
            if _overprint(items[i][2], items[j][2], pad):
                problems.append(f"{items[i][0]} overprints {items[j][0]}")
    return problems


def _overprint(a, b, pad=1.0):
    """Two display boxes overlap by more than `pad` px both ways."""
    return min(a.x1, b.x1) - max(a.x0, b.x0) > pad and min(a.y1, b.y1) - max(a.y0, b.y0) > pad


def thin_ticks(fig):
    """Fewer ticks on a linear axis whose tick labels would overprint each other (labels
    with many digits, as timings that all lie within milliseconds give): halve the
    ticks until they fit, at most three times."""
    for _ in range(3):
        fig.canvas.draw()
        renderer = fig.canvas.get_renderer()
        changed = False
        for ax in fig.axes:
            for axis, scale in ((ax.xaxis, ax.get_xscale()), (ax.yaxis, ax.get_yscale())):
                if scale != "linear":
                    continue
                boxes = [lab.get_window_extent(renderer) for t in axis._update_ticks() for lab in (t.label1,)
                         if lab.get_visible() and lab.get_text().strip()]
                if any(_overprint(a, b) for a, b in zip(boxes, boxes[1:])):
                    axis.set_major_locator(MaxNLocator(max(2, len(boxes) // 2)))
                    changed = True
        if not changed:
            return


def labels_inside(fig):
    """Point labels (annotations placed by an offset in points) that reach past their axes
    move back inside by the excess, sideways and up or down: a label under a point at
    the axes' edge would otherwise print over the tick labels, and where the points lie
    depends on timings."""
    from matplotlib.text import Annotation

    anns = [(ax, t) for ax in fig.axes for t in ax.texts
            if isinstance(t, Annotation) and t.get_visible() and t.anncoords == "offset points"]
    if not anns:
        return
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    for ax, t in anns:
        bb, box = t.get_window_extent(renderer), ax.get_window_extent(renderer)
        dx = max(0.0, box.x0 + 2 - bb.x0) - max(0.0, bb.x1 - (box.x1 - 2))
        dy = max(0.0, box.y0 + 2 - bb.y0) - max(0.0, bb.y1 - (box.y1 - 2))
        if dx or dy:
            x, y = t.xyann
            t.xyann = (x + dx * 72.0 / fig.dpi, y + dy * 72.0 / fig.dpi)


def separate_labels(fig):
    """Point labels (annotations placed by an offset in points) that overprint each other
    move apart, the later one down by the overlap, until none overlaps (at most 20
    rounds): labels at data points whose positions depend on timings cannot be placed
    by hand."""
    from matplotlib.text import Annotation

    per_axes = [[t for t in ax.texts if isinstance(t, Annotation) and t.get_visible() and t.anncoords == "offset points"]
                for ax in fig.axes]
    per_axes = [anns for anns in per_axes if len(anns) > 1]
    for _ in range(20 if per_axes else 0):  # no drawing for figures without such labels
        fig.canvas.draw()
        renderer = fig.canvas.get_renderer()
        moved = False
        for anns in per_axes:
            boxes = [t.get_window_extent(renderer) for t in anns]
            for i in range(len(anns)):
                for j in range(i + 1, len(anns)):
                    a, b = boxes[i], boxes[j]
                    if _overprint(a, b):
                        x, y = anns[j].xyann
                        dy = min(a.y1, b.y1) - max(a.y0, b.y0)
                        anns[j].xyann = (x, y - (dy + 2) * 72.0 / fig.dpi)
                        moved = True
        if not moved:
            return


def save(fig, out):
    """Fix the ticks of every log axis, then write a PNG at DPI, cropped to its content.
    With SHEARZONE_CHECK_LAYOUT=1 (scripts/test_figures.sh) a figure whose text is cut
    or overprints (layout_problems) is still written, then named on stderr, and
    LayoutError is raised."""
    fix_log_axes(fig)
    thin_ticks(fig)
    labels_inside(fig)
    separate_labels(fig)
    problems = layout_problems(fig) if os.environ.get("SHEARZONE_CHECK_LAYOUT") == "1" else []
    fig.savefig(out, dpi=DPI, bbox_inches="tight", pad_inches=0.04)
    plt.close(fig)
    if problems:
        for p in problems[:20]:
            print(f"figure layout: {out}: {p}", file=sys.stderr)
        raise LayoutError(f"{out}: {len(problems)} text(s) cut or overprinting")


class LayoutError(RuntimeError):
    """A figure whose text is cut or overprints (save with SHEARZONE_CHECK_LAYOUT=1): not a
    panel the data cannot fill, so plot_study.py does not skip it."""


def finite(*cols):
    """Arrays of the rows where every column is finite (empty CSV cells are NaN)."""
    arr = [np.asarray(c, dtype=float) for c in cols]
    ok = np.ones(len(arr[0]), dtype=bool)
    for a in arr:
        ok &= np.isfinite(a)
    return [a[ok] for a in arr]


def read_image(path, frame=0):
    """A greyscale image in 0..1: PNG/JPEG/TIFF through matplotlib, video (mp4, avi, ...)
    frame `frame` through OpenCV (python3-opencv)."""
    low = path.lower()
    if low.endswith((".mp4", ".avi", ".mov", ".mkv")):
        import cv2  # python3-opencv

        cap = cv2.VideoCapture(path)
        if not cap.isOpened():
            raise SystemExit(f"cannot open video {path}")
        cap.set(cv2.CAP_PROP_POS_FRAMES, int(frame))
        ok, img = cap.read()
        cap.release()
        if not ok:
            raise SystemExit(f"cannot read frame {frame} of {path}")
        img = img.astype(float) @ np.array([0.114, 0.587, 0.299]) if img.ndim == 3 else img.astype(float)  # BGR
        return img / 255.0
    import matplotlib.image as mpimg

    img = np.asarray(mpimg.imread(path), dtype=float)
    if img.ndim == 3:
        img = img[..., :3] @ np.array([0.299, 0.587, 0.114])  # ITU-R BT.601 luma
    if img.max() > 1.0:
        img = img / (65535.0 if img.max() > 255 else 255.0)
    return img


FLAG_NAMES = {0: "valid", 1: "replaced", 2: "masked", 3: "invalid"}


def flag_codes(flags):
    """PIV flags as codes 0 valid, 1 replaced, 2 masked, 3 invalid (from codes or names)."""
    names = {v: k for k, v in FLAG_NAMES.items()}
    out = []
    for f in flags:
        s = str(f).strip()
        out.append(names[s] if s in names else int(num_or(s, 3)))
    return np.array(out, dtype=int)


def num_or(s, default):
    try:
        return float(s)
    except (TypeError, ValueError):
        return default


def nice_ref(x):
    """A round reference value (1, 2 or 5 x 10^n) near x."""
    if not (x > 0 and math.isfinite(x)):
        return 1.0
    e = math.floor(math.log10(x))
    m = x / 10 ** e
    return (1 if m < 1.5 else 2 if m < 3.5 else 5) * 10.0 ** e


ARROW_CMAP = matplotlib.colors.LinearSegmentedColormap.from_list(
    "plasma_dark", plt.get_cmap("plasma")(np.linspace(0.0, 0.82, 256)))


def nice_ceil(x):
    """The smallest of 1, 1.2, 1.5, 2, 2.5, 3, 4, 5, 6, 8 x 10^n that is >= x."""
    if not (x > 0 and math.isfinite(x)):
        return 1.0
    e = math.floor(math.log10(x))
    for m in (1, 1.2, 1.5, 2, 2.5, 3, 4, 5, 6, 8, 10):
        if m * 10.0 ** e >= x * (1 - 1e-9):
            return m * 10.0 ** e
    return 10.0 ** (e + 1)


def draw_field(ax, img, x, y, u, v, flag=None, every=1, unit="px", length=1.0, cmap=ARROW_CMAP,
               legend=True, key_label=None):
    """PIV or truth vectors over a greyscale image in image axes (x right, y down, pixel
    centre (j, i)). x, y: 1-D (scattered) or 2-D grids; every: keep every k-th grid point.
    Valid vectors: arrows coloured by magnitude; replaced: cyan arrows; invalid: red
    crosses (their values are interpolated); masked: not drawn, small dark squares.
    Arrows are magnified so that the 98th percentile spans `length` (drawn) grid steps.
    Returns the colour mappable (for a colour bar)."""
    x, y, u, v = (np.asarray(a, dtype=float) for a in (x, y, u, v))
    code = np.zeros(u.shape, dtype=int) if flag is None else np.asarray(flag, dtype=int)
    if img is not None:
        h, w = img.shape[:2]
        # the frame at reduced contrast, so that dark and light arrows both show
        ax.imshow(img, cmap="gray", vmin=0, vmax=1, extent=(-0.5, w - 0.5, h - 0.5, -0.5),
                  interpolation="antialiased", alpha=0.5, zorder=0)
        ax.set_xlim(-0.5, w - 0.5)
        ax.set_ylim(h - 0.5, -0.5)
    else:
        ax.set_xlim(x.min() - 8, x.max() + 8)
        ax.set_ylim(y.max() + 8, y.min() - 8)
    if x.ndim == 1 and u.ndim == 2:
        x, y = np.meshgrid(x, y)
    x, y, u, v, code = (a.ravel() for a in (x, y, u, v, code))
    mag = np.hypot(u, v)
    gx, gy = np.unique(x), np.unique(y)
    step = float(np.median(np.diff(gx))) * every if gx.size > 1 else 16.0
    # arrows on every k-th column and row; flags marked at every point
    sub = np.isin(x, gx[every // 2::every]) & np.isin(y, gy[every // 2::every]) if every > 1 else \
        np.ones(x.shape, dtype=bool)
    good = (code == 0) & np.isfinite(mag)
    ref_mag = np.percentile(mag[good], 98) if good.any() else 1.0
    ref_mag = ref_mag if ref_mag > 0 else 1.0
    scale = ref_mag / (length * step)  # data units per image px of arrow
    vmax = nice_ceil(ref_mag)
    kw = dict(angles="xy", scale_units="xy", scale=scale, width=0.0032, headwidth=3.5, headlength=4,
              headaxislength=3.5, zorder=3)
    g = good & sub
    q = ax.quiver(x[g], y[g], u[g], v[g], mag[g], cmap=cmap, clim=(0, vmax), **kw)
    handles = []
    from matplotlib.lines import Line2D

    rep = (code == 1) & np.isfinite(mag)
    if rep.any():
        ax.quiver(x[rep], y[rep], u[rep], v[rep], color="#00c8ff", edgecolor="k", linewidth=0.3, **kw)
        handles.append(Line2D([], [], color="#00c8ff", marker=r"$\rightarrow$", ls="none", ms=9,
                              markeredgecolor="k", markeredgewidth=0.2,
                              label=f"replaced (interpolated): {int(rep.sum())}"))
    inv = code == 3
    if inv.any():
        ax.plot(x[inv], y[inv], "x", color="#ff2020", ms=3.5, mew=0.9, zorder=4)
        handles.append(Line2D([], [], color="#ff2020", marker="x", ls="none", ms=4, mew=0.9,
                              label=f"invalid (no arrow): {int(inv.sum())}"))
    msk = code == 2
    if msk.any():
        ax.plot(x[msk], y[msk], "s", color="0.15", ms=1.6, mew=0, zorder=2)
        handles.append(Line2D([], [], color="0.15", marker="s", ls="none", ms=3, mew=0,
                              label=f"masked (not measured): {int(msk.sum())}"))
    ref = nice_ref(ref_mag)
    label = key_label or f"arrow: {ref:g} {unit}"
    ax.quiverkey(q, 0.99, -0.2, ref, label, labelpos="W", coordinates="axes", color="k",
                 fontproperties={"size": 7})
    # the key is not part of the tight bounding box: an invisible stand-in keeps it on the page
    ax.text(0.99, -0.2, label + " " * 14, transform=ax.transAxes, ha="right", va="center", fontsize=7, alpha=0)
    ax.set_aspect("equal")
    ax.set_xlabel("x (px, right)")
    ax.set_ylabel("y (px, down)")
    if legend and handles:
        ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(-0.02, -0.16), ncol=1,
                  fontsize=6.5, handletextpad=0.3, columnspacing=1.0, borderaxespad=0.0)
    return q, handles


def colorbar(fig, ax, mappable, label):
    """A colour bar as tall as the axes."""
    from mpl_toolkits.axes_grid1 import make_axes_locatable

    cax = make_axes_locatable(ax).append_axes("right", size="3.5%", pad=0.08)
    cb = fig.colorbar(mappable, cax=cax)
    cb.set_label(label)
    return cb
