#!/usr/bin/python3
"""scripts/report.py: one self-contained HTML page of a run's results (`shearzone report`).

    report.py OUT [-o OUT/report.html] [--frames 6] [--version V] [--quiet]

OUT is a study's output folder (`shearzone study run ... -o OUT`: it holds study.json),
a closed loop's folder (`shearzone sim check ... -o OUT`: closed_loop.csv; its rows, the
chart, and the video's vectors beside the camera's truth per branch and setting) or one
clip's folder holding fields.h5 and, where made, profile.csv and width.csv. The
page holds, in order: warnings (widths without a usable r_c, clips with many invalid or
replaced vectors, fits and collapses refused, logs skipped or with a failed amplitude,
scales given by hand, the final window smaller than the beads), the counts, the result
tables and the study's figures (SVG), a section per clip (its frames with the vectors
drawn over them and a slider over the pairs, v(r) with the noise floor and r_c, the
valid fraction per pair, the PIV settings and the drive phase), a section per torque
log (Lissajous curves, harmonics, the instrument's own G' and G'') and the provenance
(versions, command lines, input sizes and SHA-256). A folder or file that is not as
shearzone wrote it: one line naming it on stderr, exit code 2, no page. Everything is embedded (frames as
JPEG, plots as SVG, a few lines of JavaScript): no network, no other file. The page
prints to a tidy PDF (the sliders' frames become a row of stills).

Debian's python3 with numpy, h5py and OpenCV (video frames); no plotting library: the
plots are drawn as SVG here, so the page is made in about a second per dozen clips.
"""
import argparse
import base64
import csv
import glob
import hashlib
import html
import json
import math
import os
import re
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))

# A clip is flagged when more than this fraction of its unmasked vectors is not valid
# (replaced or invalid): beyond it the profile leans on interpolated or missing vectors.
BAD_VECTOR_FRACTION = 0.10
# piv's window rule: a final window of at least 2.5 texture half-widths, 2/3 of a bead.
FINAL_WINDOW_PER_BEAD = 2.0 / 3.0


def esc(s):
    return html.escape(str(s), quote=True)


class Refusal(Exception):
    """An input the page cannot be made from: one line, exit code 2."""


# The file being read, for the one line that names it when a file is not what a
# shearzone output holds (a hand-edited CSV, a truncated HDF5 file).
CURRENT = {"file": None}


def open_h5(path):
    import h5py
    CURRENT["file"] = path
    try:
        return h5py.File(path, "r")
    except OSError as e:
        raise Refusal(f"{path}: not a readable HDF5 file ({str(e).split(' (')[0]}); expected piv's fields")


def read_csv(path):
    """(header dict, column names, rows as lists) of a shearzone CSV; None if absent."""
    if not os.path.isfile(path):
        return None
    CURRENT["file"] = path
    header, names, rows = {}, None, []
    with open(path, newline="", encoding="utf-8") as f:
        lines = f.read().splitlines()
    body = []
    for line in lines:
        if names is None and line.startswith("#"):
            k, _, v = line[1:].partition(":")
            header[k.strip()] = v.strip()
        else:
            body.append(line)
    reader = list(csv.reader(body))
    if reader:
        names, rows = reader[0], [r for r in reader[1:] if r]
    return header, names or [], rows


def refused(path):
    """The `# refused: ...` line a study writes in place of a fit it could not make."""
    p = os.path.join(path, "refused.txt") if os.path.isdir(path) else path
    if not os.path.isfile(p):
        return None
    with open(p, encoding="utf-8", errors="replace") as f:
        first = f.readline(4096).strip()
    return first[len("# refused:"):].strip() if first.startswith("# refused:") else None


def num(x):
    try:
        return float(x)
    except (TypeError, ValueError):
        return float("nan")


def fmt(v, digits=4):
    x = num(v)
    if math.isnan(x):
        return esc(v) if v not in (None, "") else ""
    if x == 0 or 1e-3 <= abs(x) < 1e5:
        return f"{x:.{digits}g}"
    return f"{x:.{digits - 1}e}"


def table(names, rows, keep=None, limit=None):
    """An HTML table of CSV rows (numbers to 4 digits); `keep`: the columns shown."""
    idx = [i for i, n in enumerate(names) if keep is None or n in keep]
    out = ["<table><thead><tr>", "".join(f"<th>{esc(names[i])}</th>" for i in idx), "</tr></thead><tbody>"]
    for r in rows[:limit]:
        cells = []
        for i in idx:
            v = r[i] if i < len(r) else ""
            cls = ' class="bad"' if names[i].endswith("status") and v not in ("ok", "") else ""
            cells.append(f"<td{cls}>{fmt(v)}</td>")
        out.append("<tr>" + "".join(cells) + "</tr>")
    out.append("</tbody></table>")
    if limit is not None and len(rows) > limit:
        out.append(f"<p class='note'>{len(rows) - limit} more rows in the CSV.</p>")
    return "".join(out)


# ---------------------------------------------------------------------------- SVG plots


def nice_ticks(lo, hi, n=5):
    if not (math.isfinite(lo) and math.isfinite(hi)) or hi <= lo:
        return [lo]
    step = 10 ** math.floor(math.log10((hi - lo) / n))
    for m in (1, 2, 5, 10):
        if (hi - lo) / (step * m) <= n:
            step *= m
            break
    start = math.ceil(lo / step) * step
    return [start + k * step for k in range(int((hi - start) / step + 1e-9) + 1)]


def svg_plot(series, xlabel, ylabel, title="", hlines=(), vlines=(), width=420, height=260, xlim=None, ylim=None):
    """A small line/point plot as inline SVG. series: dicts with x, y, optional err,
    label, colour, style ("line" or "points")."""
    xs = np.concatenate([np.asarray(s["x"], float) for s in series] + [np.asarray([v for v, _, _ in vlines], float)])
    ys = np.concatenate([np.asarray(s["y"], float) for s in series] + [np.asarray([v for v, _, _ in hlines], float)])
    xs, ys = xs[np.isfinite(xs)], ys[np.isfinite(ys)]
    if xs.size == 0 or ys.size == 0:
        return "<p class='note'>(no finite values to plot)</p>"
    x0, x1 = xlim or (float(xs.min()), float(xs.max()))
    y0, y1 = ylim or (min(0.0, float(ys.min())), float(ys.max()))
    if x1 <= x0:
        x0, x1 = x0 - 1, x1 + 1
    if y1 <= y0:
        y0, y1 = y0 - 1, y1 + 1
    pad = 0.05 * (y1 - y0)
    y0, y1 = (y0 - pad if y0 < 0 else y0), y1 + pad
    L, R, T, B = 62, 12, 24 if title else 10, 40
    W, H = width - L - R, height - T - B

    def px(x):
        return L + (x - x0) / (x1 - x0) * W

    def py(y):
        return T + (1 - (y - y0) / (y1 - y0)) * H

    o = [f'<svg xmlns="http://www.w3.org/2000/svg" class="plot" width="{width}" height="{height}" '
         f'viewBox="0 0 {width} {height}" role="img" font-family="sans-serif" font-size="11">']
    if title:
        o.append(f'<text x="{width / 2:.1f}" y="15" text-anchor="middle" class="t">{esc(title)}</text>')
    o.append(f'<rect x="{L}" y="{T}" width="{W}" height="{H}" fill="none" stroke="#999"/>')
    for t in nice_ticks(x0, x1):
        o.append(f'<line x1="{px(t):.1f}" y1="{T + H}" x2="{px(t):.1f}" y2="{T + H + 4}" stroke="#999"/>'
                 f'<text x="{px(t):.1f}" y="{T + H + 15}" text-anchor="middle">{fmt(t, 3)}</text>')
    for t in nice_ticks(y0, y1):
        o.append(f'<line x1="{L - 4}" y1="{py(t):.1f}" x2="{L}" y2="{py(t):.1f}" stroke="#999"/>'
                 f'<text x="{L - 6}" y="{py(t) + 4:.1f}" text-anchor="end">{fmt(t, 3)}</text>')
    o.append(f'<text x="{L + W / 2:.1f}" y="{height - 6}" text-anchor="middle">{esc(xlabel)}</text>')
    o.append(f'<text x="14" y="{T + H / 2:.1f}" text-anchor="middle" transform="rotate(-90 14 {T + H / 2:.1f})">'
             f'{esc(ylabel)}</text>')
    for v, label, colour in hlines:
        if math.isfinite(v) and y0 <= v <= y1:
            o.append(f'<line x1="{L}" y1="{py(v):.1f}" x2="{L + W}" y2="{py(v):.1f}" stroke="{colour}" '
                     f'stroke-dasharray="4 3"/><text x="{L + W - 4}" y="{py(v) - 4:.1f}" text-anchor="end" '
                     f'fill="{colour}">{esc(label)}</text>')
    for v, label, colour in vlines:
        if math.isfinite(v) and x0 <= v <= x1:
            o.append(f'<line x1="{px(v):.1f}" y1="{T}" x2="{px(v):.1f}" y2="{T + H}" stroke="{colour}"/>'
                     f'<text x="{px(v) + 4:.1f}" y="{T + H - 6}" fill="{colour}">{esc(label)}</text>')
    legend = []
    for k, s in enumerate(series):
        c = s.get("colour", ["#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b"][k % 6])
        x, y = np.asarray(s["x"], float), np.asarray(s["y"], float)
        ok = np.isfinite(x) & np.isfinite(y)
        if s.get("style", "line") == "line":
            pts = " ".join(f"{px(a):.1f},{py(b):.1f}" for a, b in zip(x[ok], y[ok]))
            o.append(f'<polyline points="{pts}" fill="none" stroke="{c}" stroke-width="1.4"/>')
        else:
            err = np.asarray(s.get("err", np.zeros_like(y)), float)
            for a, b, e in zip(x[ok], y[ok], err[ok]):
                if math.isfinite(e) and e > 0:
                    o.append(f'<line x1="{px(a):.1f}" y1="{py(b - e):.1f}" x2="{px(a):.1f}" y2="{py(b + e):.1f}" '
                             f'stroke="{c}"/>')
                o.append(f'<circle cx="{px(a):.1f}" cy="{py(b):.1f}" r="2.6" fill="{c}"/>')
        if s.get("label"):
            legend.append((s["label"], c))
    for k, (label, c) in enumerate(legend):
        o.append(f'<text x="{L + 8}" y="{T + 14 + 13 * k}" fill="{c}">{esc(label)}</text>')
    o.append("</svg>")
    return "".join(o)


# ---------------------------------------------------------------------------- frames


def frame_source(source_attr):
    """What piv read, from its `source` attribute: a video's path ("clip.mp4 (640x480,
    ...)"), or the list of images ("4 images (first ... last), 25 fps": the files of
    the first one's folder and extension from first to last, in order)."""
    m = re.match(r"^\d+ images \((.+) \.\.\. (.+)\), ", source_attr)
    if m:
        first, last = m.group(1), m.group(2)
        ext = os.path.splitext(first)[1]
        names = sorted(glob.glob(os.path.join(glob.escape(os.path.dirname(first)), "*" + ext)))
        return [n for n in names if first <= n <= last]
    return source_attr.split(" (")[0]


def video_frames(source, indices):
    """Frames (grey uint8) of a video, an image list or a glob at the given indices."""
    import cv2
    out = {}
    if not isinstance(source, list) and not (os.path.isfile(source) and
                                             source.lower().endswith((".mp4", ".avi", ".mov", ".mkv"))):
        # a glob or one image: the same as a list of images
        source = sorted(glob.glob(source)) if any(ch in source for ch in "*?[") else [source]
    if isinstance(source, list):
        for k in indices:
            if k < len(source):
                img = cv2.imread(source[k], cv2.IMREAD_GRAYSCALE)
                if img is not None:
                    out[k] = img if img.dtype == np.uint8 else (img // 257).astype(np.uint8)
    else:
        cap = cv2.VideoCapture(source)
        k, want = 0, set(indices)
        while want and k <= max(indices):
            ok, img = cap.read()
            if not ok:
                break
            if k in want:
                out[k] = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY) if img.ndim == 3 else img
                want.discard(k)
            k += 1
        cap.release()
    return out


def draw_vectors(grey, f, k, centre, vane, rc_px, scale):
    """The frame with pair k's vectors over it: valid green, replaced orange, invalid
    red, masked nodes shaded; the cup axis, the vane radius and r_c as circles. Small
    frames are enlarged (up to 3x, to about 480 px) and a dense grid thinned to one
    vector per 8 px of the frame, so that the arrows stay readable."""
    import cv2
    z = max(1, min(3, int(480 // max(grey.shape[1], 1))))
    img = cv2.cvtColor(grey, cv2.COLOR_GRAY2BGR)
    if z > 1:
        img = cv2.resize(img, (grey.shape[1] * z, grey.shape[0] * z), interpolation=cv2.INTER_LINEAR)
    x, y = f["x"], f["y"]
    u, v, flag = f["u"][k], f["v"][k], f["flag"][k]
    step = float(x[1] - x[0]) if len(x) > 1 else 8.0
    thin = max(1, int(math.ceil(8.0 / step)))
    overlay = img.copy()
    colours = {0: (60, 200, 60), 1: (0, 150, 255), 3: (40, 40, 230)}
    for i, yy in enumerate(y):
        for j, xx in enumerate(x):
            if flag[i, j] == 2:
                cv2.rectangle(overlay, (int(z * (xx - step / 2)), int(z * (yy - step / 2))),
                              (int(z * (xx + step / 2)), int(z * (yy + step / 2))), (90, 90, 90), -1)
    img = cv2.addWeighted(overlay, 0.45, img, 0.55, 0)
    for i in range(0, len(y), thin):
        for j in range(0, len(x), thin):
            fl = int(flag[i, j])
            if fl == 2 or not (math.isfinite(u[i, j]) and math.isfinite(v[i, j])):
                continue
            a = (int(round(z * x[j])), int(round(z * y[i])))
            tip = (int(round(z * (x[j] + scale * thin * u[i, j]))), int(round(z * (y[i] + scale * thin * v[i, j]))))
            cv2.arrowedLine(img, a, tip, colours.get(fl, (40, 40, 230)), 1, cv2.LINE_AA, tipLength=0.3)
    if centre is not None:
        c = (int(round(z * centre[0])), int(round(z * centre[1])))
        cv2.drawMarker(img, c, (255, 255, 0), cv2.MARKER_CROSS, 10, 1)
        if vane:
            cv2.circle(img, c, int(round(z * vane)), (255, 255, 0), 1, cv2.LINE_AA)
        if rc_px and math.isfinite(rc_px):
            cv2.circle(img, c, int(round(z * rc_px)), (255, 0, 255), 1, cv2.LINE_AA)
    longest = max(img.shape[:2])
    if longest > 640:  # the page shows frames at most 640 px wide: fewer bytes
        sc = 640.0 / longest
        img = cv2.resize(img, (int(img.shape[1] * sc), int(img.shape[0] * sc)), interpolation=cv2.INTER_AREA)
    ok, jpg = cv2.imencode(".jpg", img, [cv2.IMWRITE_JPEG_QUALITY, 80])
    return "data:image/jpeg;base64," + base64.b64encode(jpg.tobytes()).decode("ascii")


def truth_frames(path, frames, frame_a, frame_b, picks, centre, vane, scale):
    """A closed loop's truth field (the same layout as fields.h5) drawn over the video's
    frame for each picked pair: {pair: (data URI, truth's frame a, frame b)}. The truth's
    pair is the one with the same frames, else the one from the same first frame."""
    import h5py
    out = {}
    with open_h5(path) as h:
        ta, tb = h["pairs/frame_a"][()], h["pairs/frame_b"][()]
        g = {"x": h["grid/x_px"][()], "y": h["grid/y_px"][()], "u": {}, "v": {}, "flag": {}}
        for k in picks:
            fa, fb = int(frame_a[k]), int(frame_b[k])
            same = np.flatnonzero((ta == fa) & (tb == fb))
            j = same if same.size else np.flatnonzero(ta == fa)
            if not j.size or fa not in frames:
                continue
            j = int(j[0])
            g["u"][k], g["v"][k], g["flag"][k] = h["pairs/u_px"][j], h["pairs/v_px"][j], h["pairs/flag"][j]
            out[k] = (draw_vectors(frames[fa], g, k, centre, vane, None, scale), int(ta[j]), int(tb[j]))
    return out


def drive_plot(fields_path, attrs, opts, centre, vane):
    """The drive's phase at a glance: per pair, the beads' mean angular velocity next
    to the vane (valid vectors in the inner third of the gap, v_theta / r) against the
    vane's own, dphi/dt = phi0 2 pi f cos(2 pi f t + phase) at the pair's middle, scaled
    by the beads' in-phase amplitude. Curves in step: the phase piv masked the vane with is the
    beads'. Empty without a sinusoidal drive, a centre or a vane."""
    import h5py
    f_hz, phi0 = num(attrs.get("f_Hz")), num(attrs.get("phi0_rad"))
    phase = num(opts.get("vane_phase_rad", attrs.get("vane_phase_rad")))
    if not (centre and vane and f_hz > 0 and phi0 > 0 and math.isfinite(phase)):
        return ""
    cup = num(attrs.get("cup_radius_px"))
    outer = vane + (cup - vane) / 3 if math.isfinite(cup) and cup > vane else 1.5 * vane
    with open_h5(fields_path) as h:
        x, y = h["grid/x_px"][()], h["grid/y_px"][()]
        t = h["pairs/t_a_s"][()] + 0.5 * h["pairs/dt_s"][()]
        dt = h["pairs/dt_s"][()]
        dx, dy = np.meshgrid(x - centre[0], y - centre[1])
        r = np.hypot(dx, dy)
        ring = (r > vane) & (r <= outer)
        rows, cols = np.nonzero(ring.any(axis=1))[0], np.nonzero(ring.any(axis=0))[0]
        if rows.size == 0:
            return ""
        box = np.s_[rows[0]:rows[-1] + 1, cols[0]:cols[-1] + 1]  # only the ring's rows and columns are read
        dx, dy, r, ring = dx[box], dy[box], r[box], ring[box]
        beads = np.full(t.size, np.nan)
        for k0 in range(0, t.size, 64):  # 64 pairs at a time: bounded memory on long 1080p clips
            sl = np.s_[k0:k0 + 64, rows[0]:rows[-1] + 1, cols[0]:cols[-1] + 1]
            u, v, flag = h["pairs/u_px"][sl], h["pairs/v_px"][sl], h["pairs/flag"][sl]
            # v_theta (docs/formats.md, convention_rotation): (u (y - yc) - v (x - xc)) / r
            omega = (u * dy - v * dx) / np.maximum(r, 1e-9) ** 2
            use = ring[None] & (flag == 0) & np.isfinite(omega)
            n = use.sum(axis=(1, 2))
            beads[k0:k0 + len(n)] = np.where(n > 0, np.where(use, omega, 0).sum(axis=(1, 2)) / np.maximum(n, 1),
                                             np.nan)
    beads /= dt
    drive = phi0 * 2 * math.pi * f_hz * np.cos(2 * math.pi * f_hz * t + phase)
    # the drive scaled by the beads' in-phase part (least squares): a negative factor or
    # a visible lag says the phase (or the sense of rotation) is not the beads'
    ok = np.isfinite(beads)
    if not ok.any():  # no valid vector next to the vane: nothing to set the drive against
        return ""
    k = float(beads[ok] @ drive[ok] / max(drive[ok] @ drive[ok], 1e-30))
    return svg_plot([{"x": t, "y": beads, "label": "beads next to the vane"},
                     {"x": t, "y": k * drive, "label": f"the vane's dφ/dt × {k:.2g}", "colour": "#888"}],
                    "t (s)", "angular velocity (rad/s)", f"drive phase {phase:.3g} rad")


# ---------------------------------------------------------------------------- a clip


class Report:
    def __init__(self, root, n_frames):
        self.root, self.n_frames = root, n_frames
        self.shearzone, self.version = None, ""
        self.warnings, self.sections, self.inputs, self.commands = [], [], {}, []
        self.counts = {}
        self.tally = {}  # what: [done, of]

    def count(self, what, done):
        t = self.tally.setdefault(what, [0, 0])
        t[0] += bool(done)
        t[1] += 1

    def warn(self, where, text, anchor=None, first=False):
        """A warning; `first`: what did not run at all (a clip refused or without fields,
        a log skipped, a fit refused), listed before the rest."""
        link = f'<a href="#{esc(anchor)}">{esc(where)}</a>' if anchor else esc(where)
        self.warnings.append((0 if first else 1, len(self.warnings), f"<li>{link}: {esc(text)}</li>"))

    def command(self, header):
        if header and header.get("command_line"):
            self.commands.append(header["command_line"])

    def clip(self, rel, title, video=None, truth=None, overlays=(), kind="clips", check_width=True,
             tally="clips through PIV"):
        """A clip's section: frames with vectors, v(r), valid fraction per pair. For a
        closed loop, `truth` = (label, fields path): the truth's vectors over the same
        frame beside the video's; `overlays`: (label, profile.csv, width.csv) drawn in
        v(r) beside the video's profile."""
        import h5py
        d = os.path.normpath(os.path.join(self.root, rel))
        anchor = "clip-" + rel.replace("/", "-")
        parts = [f'<section class="clip" id="{esc(anchor)}"><h3>{esc(title)}</h3>']
        fields_path = os.path.join(d, "fields.h5")
        width = read_csv(os.path.join(d, "width.csv"))
        prof = read_csv(os.path.join(d, "profile.csv"))
        rc_m = status = None
        if width and width[2] and not check_width:
            get = dict(zip(width[1], width[2][0]))
            rc_m = num(get.get("rc_m"))
        elif width and width[2]:
            names, row = width[1], width[2][0]
            self.command(width[0])
            get = dict(zip(names, row))
            rc_m, status = num(get.get("rc_m")), get.get("rc_status", "")
            self.count("widths with a usable r_c", status == "ok")
            if status != "ok":
                self.warn(title, f"r_c {status}" + (f" (a bound: {fmt(rc_m)} m)" if math.isfinite(rc_m) else
                                                    " (no r_c)"), anchor)
            parts.append(f"<p>r_c = <b>{fmt(rc_m)} m</b> [{fmt(get.get('rc_ci_low_m'))}, "
                         f"{fmt(get.get('rc_ci_high_m'))}] ({esc(status)}, {esc(get.get('estimator', ''))}, "
                         f"v_c = {fmt(width[0].get('v_c_m_per_s'))} m/s)</p>")
        m_per_px = num(prof[0].get("m_per_px")) if prof else float("nan")
        if prof:
            self.command(prof[0])
            src = prof[0].get("scale_source", "")
            if src.startswith("--m-per-px"):
                self.warn(title, f"scale given by hand ({src}), not from the cup's radius", anchor)
        why = refused(fields_path) if os.path.isfile(fields_path) else None
        if tally:
            self.count(tally, os.path.isfile(fields_path) and why is None)
        if why:
            parts.append(f"<p class='bad'>refused by piv: {esc(why)}</p>")
            self.warn(title, f"refused: {why}", anchor, first=True)
        elif os.path.isfile(fields_path):
            with open_h5(fields_path) as h:
                attrs = {k: (v.decode() if isinstance(v, bytes) else v) for k, v in h.attrs.items()}
                flag = h["pairs/flag"][()]
                f = {"x": h["grid/x_px"][()], "y": h["grid/y_px"][()], "flag": flag}
                n = flag.shape[0]
                picks = sorted(set(np.linspace(0, n - 1, min(self.n_frames, n)).round().astype(int).tolist()))
                f["u"] = {k: h["pairs/u_px"][k] for k in picks}
                f["v"] = {k: h["pairs/v_px"][k] for k in picks}
                frame_a = h["pairs/frame_a"][()]
                frame_b = h["pairs/frame_b"][()]
                t_a = h["pairs/t_a_s"][()]
            opts = dict(line.split(": ", 1) for line in str(attrs.get("options", "")).splitlines() if ": " in line)
            self.commands.append(opts.get("command_line", ""))
            src = frame_source(str(attrs.get("source", "")))
            for p in ([src] if isinstance(src, str) else src):
                if os.path.isfile(p):
                    self.inputs[p] = None
            unmasked = (flag != 2).sum(axis=(1, 2))
            bad = ((flag == 1) | (flag == 3)).sum(axis=(1, 2)) / np.maximum(unmasked, 1)
            if bad.mean() > BAD_VECTOR_FRACTION:
                self.warn(title, f"{bad.mean():.0%} of the unmasked vectors replaced or invalid "
                                 f"(worst pair {bad.max():.0%})", anchor)
            texture = num(attrs.get("texture_size_px"))
            final = num(attrs.get("piv_final_window_px"))
            # piv's own rule sizes the final window to at least 2/3 of a bead (docs/piv.md,
            # "Final windows inside one bead"); windows given by hand may fall below it.
            if math.isfinite(texture) and math.isfinite(final) and final < FINAL_WINDOW_PER_BEAD * texture:
                self.warn(title, f"final window {final:g} px is under 2/3 of the beads' {texture:.0f} px: such "
                                 "windows see smooth shading and fail or read low (docs/piv.md)", anchor)
            centre = (num(attrs.get("centre_x_px")), num(attrs.get("centre_y_px")))
            centre = centre if all(map(math.isfinite, centre)) else None
            # the vane as piv masked it (its header, whether from flags or --config)
            m = re.search(r"radius ([0-9.eE+-]+) px", opts.get("mask_vane", ""))
            vane = num(m.group(1)) if m else None
            rc_px = rc_m / m_per_px if rc_m is not None and math.isfinite(m_per_px) else None
            frames = video_frames(video or src, [int(frame_a[k]) for k in picks])
            typical = np.nanpercentile(np.hypot(f["u"][picks[-1]], f["v"][picks[-1]]), 95) if picks else 1.0
            scale = 0.8 * (f["x"][1] - f["x"][0] if len(f["x"]) > 1 else 8) / max(typical, 1e-3)
            images = [(k, draw_vectors(frames[int(frame_a[k])], f, k, centre, vane, rc_px, scale))
                      for k in picks if int(frame_a[k]) in frames]
            truth_images = {}
            if truth and os.path.isfile(truth[1]):
                truth_images = truth_frames(truth[1], frames, frame_a, frame_b, picks, centre, vane, scale)
            if images:
                parts.append(f'<div class="frames" data-n="{len(images)}">')
                for i, (k, uri) in enumerate(images):
                    fa, fb = int(frame_a[k]), int(frame_b[k])
                    pics = (f'<img src="{uri}" alt="pair {k}: vectors over frame {fa}">')
                    caption = f"pair {k} (frames {fa} → {fb}), t = {t_a[k]:.3g} s (vectors x {scale:.2g})"
                    if truth:
                        tk = truth_images.get(k)
                        pics = (f'<div class="side"><div><p>the video, {esc(truth[2])}</p>{pics}</div><div>'
                                f'<p>{esc(truth[0])}' + (f' (frames {tk[1]} → {tk[2]})</p><img src="{tk[0]}" '
                                                         f'alt="pair {k}: {esc(truth[0])}">' if tk else
                                                         ": no pair from this frame</p>") + "</div></div>")
                    parts.append(f'<figure class="frame{" shown" if i == 0 else ""}">{pics}<figcaption>'
                                 f'{caption}</figcaption></figure>')
                parts.append(f'<input type="range" min="0" max="{len(images) - 1}" value="0" class="slider" '
                             f'aria-label="pair"><button type="button" class="play" aria-label="play">play'
                             f'</button></div>')
                parts.append("<p class='note'>green: valid; orange: replaced; red: invalid; grey: masked; "
                             "cyan: cup axis and vane radius; magenta: r_c.</p>")
            else:
                parts.append(f"<p class='note'>(the frames of {esc(src)} are not readable from here)</p>")
            parts.append('<div class="plots">')
            if prof and prof[2]:
                names, rows = prof[1], prof[2]
                col = {n: np.array([num(r[i]) for r in rows]) for i, n in enumerate(names)}
                series = [{"x": col["r_m"] * 1e3, "y": col["v_abs_m_per_s"] * 1e3, "err": col.get(
                    "v_abs_sem_m_per_s", np.zeros(len(rows))) * 1e3, "style": "points", "label": "mean |v|"}]
                noise = np.nanmedian(col.get("v_noise_m_per_s", np.array([np.nan]))) * 1e3
                vc = num(width[0].get("v_c_m_per_s")) * 1e3 if width else float("nan")
                vlines = [(rc_m * 1e3 if rc_m is not None else float("nan"), "r_c" + (" video" if overlays else ""),
                           "#c0c")]
                for (label, p_path, w_path), c in zip(overlays, ("#2ca02c", "#ff7f0e", "#8c564b")):
                    op, ow = read_csv(p_path), read_csv(w_path)
                    if op and op[2]:
                        oc = {n: np.array([num(r[i]) for r in op[2]]) for i, n in enumerate(op[1])}
                        series.append({"x": oc["r_m"] * 1e3, "y": oc["v_abs_m_per_s"] * 1e3, "label": label,
                                       "colour": c})
                    if ow and ow[2]:
                        vlines.append((num(dict(zip(ow[1], ow[2][0])).get("rc_m")) * 1e3, "", c))
                parts.append(svg_plot(series, "r (mm)", "v (mm/s)", "v(r)",
                                      hlines=[(noise, "noise floor", "#888"), (vc, "v_c", "#d62728")],
                                      vlines=vlines))
            parts.append(svg_plot([{"x": t_a, "y": 1 - bad, "label": "valid fraction"}], "t (s)",
                                  "valid / unmasked", "vectors per pair", ylim=(0, 1)))
            parts.append(drive_plot(fields_path, attrs, opts, centre, vane))
            parts.append("</div>")
            keys = ("piv_windows_px", "piv_overlap", "preset", "grey_conversion", "piv_final_window_px",
                    "texture_size_px", "mask_vane", "vane_phase_rad", "phase_auto", "f_Hz", "phi0_rad", "N")
            rows = [(k, opts.get(k, attrs.get(k))) for k in keys if opts.get(k, attrs.get(k)) is not None]
            rows.append(("source", attrs.get("source", "")))
            parts.append("<details><summary>PIV settings and drive phase</summary><table>" +
                         "".join(f"<tr><th>{esc(k)}</th><td>{esc(v)}</td></tr>" for k, v in rows) +
                         "</table></details>")
        else:
            parts.append("<p class='bad'>no fields.h5: PIV did not run or was refused.</p>")
            self.warn(title, "no PIV fields", anchor, first=True)
        parts.append("</section>")
        self.sections.append((kind, "".join(parts)))

    def inspect(self, rel, fallback=None):
        """Starts `shearzone laos --inspect` on the log a LAOS folder was made from, with
        the options it was made with (the summary's command_line, less -o, -q and
        --force): what the log holds (format, segments, skipped blocks and why). None
        without the binary (--shearzone) or the command line."""
        import shlex
        import subprocess
        summary = read_csv(os.path.join(self.root, rel, "summary.csv"))
        cmd = summary[0].get("command_line") if summary else None
        # a log LAOS refused has no summary: the study's own words for it
        words = shlex.split(cmd)[1:] if cmd else fallback
        if not (self.shearzone and words):
            return None
        out, skip = [], False
        for w in words:
            if skip:
                skip = False
            elif w in ("-o", "--output"):
                skip = True
            elif w not in ("-q", "--quiet", "--force", "-v", "--verbose"):
                out.append(w)
        if "laos" not in out:
            return None
        return subprocess.Popen([self.shearzone, *out, "--inspect"], stdout=subprocess.PIPE,
                                stderr=subprocess.STDOUT, text=True, cwd=self.root)

    @staticmethod
    def inspected(proc):
        if proc is None:
            return ""
        text = proc.communicate()[0]
        return ("<details><summary>what the log holds (<code>laos --inspect</code>: format, segments, skipped "
                f"blocks)</summary><pre>{esc(text.strip())}</pre></details>")

    def log(self, rel, title, inspect=None):
        d = os.path.join(self.root, rel)
        anchor = "log-" + rel.replace("/", "-")
        parts = [f'<section class="log" id="{esc(anchor)}"><h3>{esc(title)}</h3>']
        why = refused(d)
        summary = read_csv(os.path.join(d, "summary.csv"))
        self.count("torque logs analysed", not (why or not summary))
        if why or not summary:
            self.warn(title, f"log skipped: {why or 'no summary.csv'}", anchor, first=True)
            parts.append(f"<p class='bad'>skipped: {esc(why or 'no summary')}</p>{self.inspected(inspect)}"
                         "</section>")
            self.sections.append(("logs", "".join(parts)))
            return
        header, names, rows = summary
        self.command(header)
        for r in rows:
            st = dict(zip(names, r)).get("status", "ok")
            if st != "ok":
                self.warn(title, f"amplitude {fmt(dict(zip(names, r)).get('phi0_rad'))} rad: {st}", anchor)
        keep = ("segment", "amplitude", "phi0_rad", "K1_prime_N_m_per_rad", "K1_dprime_N_m_per_rad", "tan_delta_1",
                "I3_over_I1", "e3_over_e1", "v3_over_v1", "S", "T", "status", "instrument_f_Hz",
                "instrument_G_prime_Pa", "instrument_G_dprime_Pa")
        parts.append(table(names, rows, keep=keep))
        series = []
        for path in sorted(glob.glob(os.path.join(d, "lissajous_*.csv"))):
            lj = read_csv(path)
            if lj and lj[2]:
                n = lj[1]
                xi = next((i for i, c in enumerate(n) if c.startswith(("angle", "strain", "drive"))), 1)
                yi = next((i for i, c in enumerate(n) if c.startswith(("torque", "stress", "response"))), 2)
                series.append({"x": [num(r[xi]) for r in lj[2]], "y": [num(r[yi]) for r in lj[2]],
                               "label": os.path.basename(path)[:-4], "xl": n[xi], "yl": n[yi]})
        if series:
            parts.append(svg_plot(series, series[0]["xl"], series[0]["yl"], "Lissajous curves", width=460,
                                  height=320, ylim=None))
        harm = read_csv(os.path.join(d, "harmonics.csv"))
        if harm:
            parts.append("<details><summary>harmonics</summary>" + table(harm[1], harm[2], limit=60) + "</details>")
        parts.append(self.inspected(inspect))
        parts.append("</section>")
        self.sections.append(("logs", "".join(parts)))


# ---------------------------------------------------------------------------- the page

CSS = """
body{font:14px/1.4 system-ui,sans-serif;margin:1.5em auto;max-width:1100px;color:#222;padding:0 1em}
h1{font-size:1.6em}h2{border-bottom:1px solid #ccc;margin-top:1.6em}h3{margin:1.2em 0 .4em}
table{border-collapse:collapse;margin:.5em 0;font-size:12px}td,th{border:1px solid #ddd;padding:2px 6px;
text-align:right}th{background:#f4f4f4}td.bad,.bad{color:#b00}.note{color:#666;font-size:12px}
ul.warnings li{color:#8a4b00}.plots{display:flex;flex-wrap:wrap;gap:12px}svg.plot text{font-size:11px}
svg.plot .t{font-weight:bold}
.frames figure{display:none;margin:0}.frames figure.shown{display:block}.frames img{max-width:100%}
.slider{width:320px}.side{display:flex;gap:8px}.side>div{flex:1}.side p{margin:0;font-size:12px}.figure svg{max-width:100%;height:auto}details{margin:.4em 0}
@media print{.frames figure{display:inline-block;width:32%}.slider,.play{display:none}section{break-inside:avoid}}
"""

JS = """
document.querySelectorAll('.frames').forEach(function (box) {
  var figs = box.querySelectorAll('figure');
  var s = box.querySelector('input.slider');
  if (!s) return;
  function show() {
    figs.forEach(function (f, i) { f.classList.toggle('shown', i === Number(s.value)); });
  }
  s.addEventListener('input', show);
  var play = box.querySelector('button.play'), timer = null;
  if (!play) return;
  play.addEventListener('click', function () {
    if (timer) { clearInterval(timer); timer = null; play.textContent = 'play'; return; }
    play.textContent = 'pause';
    timer = setInterval(function () {
      s.value = String((Number(s.value) + 1) % figs.length);
      show();
    }, 400);
  });
});
"""


def sha256(path):
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def inline_svg(path):
    with open(path, encoding="utf-8") as f:
        text = f.read()
    start = text.find("<svg")
    if start < 0:
        return ""
    # matplotlib's <metadata> block (RDF naming its vocabularies by URL) is not drawn
    return re.sub(r"<metadata>.*?</metadata>", "", text[start:], flags=re.S)


def study_report(root, rep):
    path = os.path.join(root, "study.json")
    CURRENT["file"] = path
    with open(path, encoding="utf-8") as f:
        try:
            study = json.load(f)
        except ValueError as e:
            raise Refusal(f"{path}: line {getattr(e, 'lineno', '?')}: not valid JSON ({getattr(e, 'msg', e)}); "
                          "expected the study.json that study run writes")
    if not isinstance(study, dict) or "study_file" not in study:
        raise Refusal(f"{path}: no \"study_file\" key; expected the study.json that study run writes")
    rep.title = f"Study {study.get('study_file', root)}"
    rep.inputs[study["study_file"]] = None
    clips, logs = study.get("clips", {}), study.get("logs", {})
    for name in sorted(clips):
        rep.clip(f"lab/clips/{name}", f"clip {name}", video=clips[name].get("video"))
        rep.inputs[clips[name].get("video")] = None
    lab_laos = study.get("args", {}).get("lab_laos", [])
    inspections = {name: rep.inspect(f"lab/logs/{name}", ["laos", logs[name]["file"], *lab_laos])
                   if isinstance(logs[name], dict) and logs[name].get("file") else rep.inspect(f"lab/logs/{name}")
                   for name in sorted(logs)}  # run side by side
    for name in sorted(logs):
        rep.log(f"lab/logs/{name}", f"log {name}", inspect=inspections[name])
        src = logs[name].get("file") if isinstance(logs[name], dict) else None
        if src:
            rep.inputs[src] = None
    branches = 0
    for g in sorted(study.get("groups", {})):
        for b in sorted(study.get("branches", {})):
            branches += 1
            rel = f"sim/{g}/{b}"
            rep.clip(rel, f"simulated {g} {b}", video=os.path.join(root, f"sim/{g}/video_{b}/video.mp4"),
                     tally="simulated branches through PIV")
            rep.log(f"{rel}/laos", f"torque of {g} {b}")
    rep.counts = {"clips": len(clips), "torque logs": len(logs), "simulated branches": branches}
    results = []
    for ds in sorted(study.get("datasets", {})):
        d = os.path.join(root, "results", ds)
        results.append(f"<h3>dataset {esc(ds)}</h3>")
        for name, what, keep in (
                ("rc_phi0.csv", "r_c(φ0) per clip", ("item", "N", "phi0_rad", "rc_m", "rc_ci_low_m", "rc_ci_high_m",
                                                     "rc_status", "estimator")),
                ("erf_wide.csv", "erf fit per N", None), ("W_power.csv", "W(N) power law", None),
                ("rcinf_power.csv", "r_c∞(N) − r_c∞(1) power law", None),
                ("laos_summary.csv", "LAOS per log and amplitude", ("source", "N", "phi0_rad", "K1_prime_N_m_per_rad",
                                                                    "tan_delta_1", "I3_over_I1", "status")),
                ("tau_power.csv", "τ_max(N) power law", None)):
            p = os.path.join(d, name)
            if not os.path.exists(p):
                continue
            why = refused(p)
            if name.endswith("power.csv") or name == "erf_wide.csv":
                rep.count("fits made", not why)
            if why:
                rep.warn(f"{ds}: {what}", f"refused: {why}", first=True)
                results.append(f"<p class='bad'>{esc(what)}: refused ({esc(why)})</p>")
                continue
            t = read_csv(p)
            rep.command(t[0])
            results.append(f"<h4>{esc(what)} <span class='note'>({esc(name)})</span></h4>" +
                           table(t[1], t[2], keep=keep))
            if name == "erf_wide.csv":
                for r in t[2]:
                    row = dict(zip(t[1], r))
                    if row.get("status", "ok") != "ok":
                        msg = row.get("message", "")
                        rep.warn(f"{ds}: erf fit N = {row.get('group', '?')}",
                                 row.get("status", "") + (f": {msg}" if msg else ""))
        c = os.path.join(d, "collapse_erf")
        if os.path.isdir(c):
            why = refused(c)
            rep.count("fits made", not why)
            if why:
                rep.warn(f"{ds}: collapse", f"refused: {why}", first=True)
            else:
                t = read_csv(os.path.join(c, "parameters.csv"))
                if t:
                    results.append("<h4>collapse erf <span class='note'>(collapse_erf/parameters.csv)</span></h4>" +
                                   table(t[1], t[2]))
    rep.results = "".join(results)
    figs = sorted(glob.glob(os.path.join(root, "figures", "*.svg")))
    rep.figures = "".join(f'<figure class="figure"><figcaption>{esc(os.path.basename(p))}</figcaption>'
                          f"{inline_svg(p)}</figure>" for p in figs)


def folder_report(root, rep):
    rep.title = f"Run {os.path.abspath(root)}"
    rep.clip(".", os.path.basename(os.path.abspath(root)) or root)
    rep.counts = {"clips": 1}
    rep.results, rep.figures = "", ""


# A closed loop's video r_c is flagged when it lies further than this from the camera's
# truth: the bound docs/sim.md measures the pipeline against (half a bead).
CHECK_RC_TOLERANCE_D = 0.5


def check_report(root, rep):
    """A `sim check` folder: closed_loop.csv's rows, the chart of r_c error and PIV
    error against PIV time, and per branch and setting the video's vectors beside the
    camera's truth over the same frames, with the video's v(r) against both truths'."""
    header, names, rows = read_csv(os.path.join(root, "closed_loop.csv"))
    rep.title = f"Closed loop {header.get('run', os.path.abspath(root))}"
    rep.command(header)
    get = [dict(zip(names, r)) for r in rows]
    branches = list(dict.fromkeys(g["branch"] for g in get))
    rep.counts = {"simulated branches": len(branches), "settings": len(dict.fromkeys(g["setting"] for g in get)),
                  "rows": len(rows)}
    for g in get:
        where = f"{g['branch']}, {g['setting']}"
        anchor = "clip-" + f"{g['branch']}/{g['setting']}".replace("/", "-")
        sv, sc = g.get("rc_video_status", ""), g.get("rc_centres_status", "")
        err = num(g.get("rc_error_centres_over_d"))
        same = sv == sc and (sv != "ok" or abs(err) <= CHECK_RC_TOLERANCE_D)
        rep.count(f"rows whose r_c is the camera truth's (same status, within {CHECK_RC_TOLERANCE_D:g} d)", same)
        if sv != sc:
            rep.warn(where, f"r_c of the video {sv}, of the camera's truth {sc}", anchor)
        elif sv == "ok" and abs(err) > CHECK_RC_TOLERANCE_D:
            rep.warn(where, f"r_c of the video {err:+.2f} d from the camera's truth", anchor)
    def rc(g, which):
        st = g.get(f"rc_{which}_status", "")
        lo, hi = g.get(f"rc_{which}_ci_low_m", ""), g.get(f"rc_{which}_ci_high_m", "")
        text = f"{fmt(g.get(f'rc_{which}_m'))}" + (f" [{fmt(lo)}, {fmt(hi)}]" if lo and hi else "")
        return f"<td{' class=bad' if st != 'ok' else ''}>{text} {esc(st)}</td>"

    cells = ["branch", "φ0 (rad)", "N", "setting", "pairs", "r_c video (m)", "r_c camera truth (m)",
             "r_c surface field (m)", "error vs camera (d)", "error vs surface (d)", "PIV RMS error (px)",
             "invalid", "PIV (s)"]
    out = ["<table><thead><tr>" + "".join(f"<th>{esc(c)}</th>" for c in cells) + "</tr></thead><tbody>"]
    for g in get:
        out.append("<tr>" + "".join(f"<td>{fmt(g.get(k))}</td>" for k in ("branch", "phi0_rad", "N")) +
                   f'<td><a href="#{esc("clip-" + g["branch"] + "-" + g["setting"])}">{esc(g["setting"])}</a></td>'
                   f"<td>{fmt(g.get('pairs'))}</td>" + rc(g, "video") + rc(g, "centres") + rc(g, "surface") +
                   "".join(f"<td>{fmt(g.get(k), 3)}</td>" for k in ("rc_error_centres_over_d", "rc_error_over_d",
                                                                     "piv_rms_error_px", "invalid_fraction",
                                                                     "piv_s")) + "</tr>")
    out.append("</tbody></table>")
    results = ["<h3>closed_loop.csv</h3>", "".join(out),
               "<p class='note'>The camera's truth: the beads' centre motion on the same camera (bead by bead for "
               "track settings); the surface field: the simulator's material points, spin included; errors in "
               "bead diameters d; r_c intervals in brackets.</p>"]
    col = {n: np.array([num(g.get(n)) for g in get]) for n in names}
    series = []
    for b in branches:
        m = np.array([g["branch"] == b for g in get])
        series.append({"x": col["piv_s"][m], "y": col["rc_error_centres_over_d"][m], "style": "points", "label": b})
    chart = [svg_plot(series, "PIV time (s)", "(r_c video − camera truth) / d", "r_c error against PIV time",
                      hlines=[(CHECK_RC_TOLERANCE_D, "+d/2", "#888"), (-CHECK_RC_TOLERANCE_D, "−d/2", "#888"),
                              (0.0, "", "#bbb")])]
    series = [{"x": s_["x"], "y": col["piv_rms_error_px"][np.array([g["branch"] == s_["label"] for g in get])],
               "style": "points", "label": s_["label"]} for s_ in series]
    chart.append(svg_plot(series, "PIV time (s)", "RMS error per vector (px)", "PIV error against PIV time"))
    results.append('<div class="plots">' + "".join(chart) + "</div>")
    rep.results = "".join(results)
    rep.figures = ""
    claimed = {(g["branch"], g["setting"]) for g in get}
    for g in get:
        b, setting = g["branch"], g["setting"]
        rel = f"{b}/{setting}"
        if not os.path.isdir(os.path.join(root, rel)):
            # windows sized to the beads: the row names the windows used, the folder the ones asked for
            k = "_" + setting.rsplit("_", 1)[-1]
            spare = [os.path.basename(p) for p in sorted(glob.glob(os.path.join(root, b, "*" + k)))
                     if (b, os.path.basename(p)) not in claimed and os.path.isfile(os.path.join(p, "fields.h5"))]
            if spare:
                rel = f"{b}/{spare[0]}"
                claimed.add((b, spare[0]))
        bdir = os.path.join(root, b)
        track = setting.startswith("track_")
        truth = (("the camera's truth bead by bead", os.path.join(root, rel, "truth_beads.h5"), "tracked") if track
                 else ("the camera's truth", os.path.join(bdir, "truth_centres.h5"), "PIV"))
        overlays = [("camera truth", os.path.join(root, rel, "truth_beads_profile.csv"),
                     os.path.join(root, rel, "truth_beads_width.csv")) if track else
                    ("camera truth", os.path.join(bdir, "truth_centres_profile.csv"),
                     os.path.join(bdir, "truth_centres_width.csv")),
                    ("surface field", os.path.join(bdir, "truth_surface_profile.csv"),
                     os.path.join(bdir, "truth_surface_width.csv"))]
        rep.clip(rel, f"{b}, {setting}", video=os.path.join(bdir, "video", "video.mp4"), truth=truth,
                 overlays=overlays, kind="branches", check_width=False, tally=None)
        rep.inputs[os.path.join(bdir, "video", "video.mp4")] = None


def write_page(rep, out_path):
    listed = "".join(w for _, _, w in sorted(rep.warnings))
    warnings = f"<ul class='warnings'>{listed}</ul>" if rep.warnings else \
        "<p>No warnings: every width usable, every fit made, every log read.</p>"
    one = {"clips": "clip", "torque logs": "torque log", "simulated branches": "simulated branch",
           "settings": "setting", "rows": "row"}
    counts = ", ".join(f"{v} {one.get(k, k) if v == 1 else k}" for k, v in rep.counts.items())
    if rep.tally:
        counts += "; " + ", ".join(f"{k}: {d} of {n}" for k, (d, n) in rep.tally.items())
    provenance = ["<table><tr><th>input</th><th>bytes</th><th>SHA-256</th></tr>"]
    for p in sorted(k for k in rep.inputs if k):
        if os.path.isfile(p):
            provenance.append(f"<tr><td>{esc(p)}</td><td>{os.path.getsize(p)}</td><td><code>{sha256(p)}</code></td></tr>")
    provenance.append("</table><details><summary>command lines</summary><pre>" +
                      esc("\n".join(dict.fromkeys(c for c in rep.commands if c))) + "</pre></details>")
    sections = {"clips": [], "logs": [], "branches": []}
    for kind, text in rep.sections:
        sections[kind].append(text)
    page = [f"<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'><title>{esc(rep.title)}</title>",
            f"<meta name='viewport' content='width=device-width'><style>{CSS}</style></head><body>",
            f"<h1>{esc(rep.title)}</h1><p>{esc(counts)}; shearzone {esc(rep.version)}</p>",
            f"<h2 id='warnings'>Warnings ({len(rep.warnings)})</h2>{warnings}"]
    if rep.results:
        page.append(f"<h2 id='results'>Results</h2>{rep.results}")
    if rep.figures:
        page.append(f"<h2 id='figures'>Figures</h2>{rep.figures}")
    if sections["clips"]:
        page.append("<h2 id='clips'>Clips</h2>" + "".join(sections["clips"]))
    if sections["branches"]:
        page.append("<h2 id='branches'>The video beside the truth, per branch and setting</h2>" +
                    "".join(sections["branches"]))
    if sections["logs"]:
        page.append("<h2 id='logs'>Torque logs</h2>" + "".join(sections["logs"]))
    page.append(f"<h2 id='provenance'>Provenance</h2>{''.join(provenance)}")
    page.append(f"<script>{JS}</script></body></html>\n")
    tmp = out_path + ".partial"
    try:
        with open(tmp, "w", encoding="utf-8") as f:
            f.write("".join(page))
        os.replace(tmp, out_path)
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("out", help="a study's output folder, a sim check folder, or a folder holding fields.h5")
    ap.add_argument("-o", "--output", help="the page (default: OUT/report.html)")
    ap.add_argument("--frames", type=int, default=6, help="frames per clip under the slider (1..50)")
    ap.add_argument("--version", default="", help="the shearzone version, for the page's header")
    ap.add_argument("--quiet", action="store_true", help="no summary line")
    ap.add_argument("--shearzone", help="the shearzone binary: each lab log's `laos --inspect` on the page")
    a = ap.parse_args()
    prog = "shearzone: error: "
    if not os.path.isdir(a.out):
        print(f"{prog}{a.out}: no such folder; expected a study's output folder, a sim check folder or a folder "
              "holding piv's fields.h5", file=sys.stderr)
        return 2
    if not 1 <= a.frames <= 50:
        print(f"{prog}--frames {a.frames}: expected 1..50", file=sys.stderr)
        return 2
    rep = Report(a.out, a.frames)
    rep.version = a.version
    rep.shearzone = a.shearzone
    out = a.output or os.path.join(a.out, "report.html")
    try:
        if os.path.isfile(os.path.join(a.out, "study.json")):
            study_report(a.out, rep)
        elif os.path.isfile(os.path.join(a.out, "closed_loop.csv")):
            check_report(a.out, rep)
        elif os.path.isfile(os.path.join(a.out, "fields.h5")):
            folder_report(a.out, rep)
        else:
            raise Refusal(f"{a.out}: none of study.json, closed_loop.csv or fields.h5; expected a study's output "
                          "folder, a sim check folder or a folder holding piv's fields.h5")
        write_page(rep, out)
    except Refusal as e:
        print(f"{prog}{e}", file=sys.stderr)
        return 2
    except (KeyError, ValueError, IndexError, TypeError, OSError, UnicodeDecodeError) as e:
        # a file shearzone wrote, then altered or cut short: name it rather than the line of code
        what = f"no column or key {e}" if isinstance(e, KeyError) else str(e).splitlines()[0] if str(e) else type(e).__name__
        print(f"{prog}{CURRENT['file'] or a.out}: {what}; expected the file as shearzone wrote it", file=sys.stderr)
        return 2
    if not a.quiet:
        print(f"report: {out} ({os.path.getsize(out) / 1e6:.1f} MB; {len(rep.warnings)} warnings)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
