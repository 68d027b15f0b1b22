#!/usr/bin/python3
"""Collects a study's per-branch tables into one table per dataset (a step of scripts/study/Snakefile).

    collect.py widths OUT.csv WIDTH.csv [WIDTH.csv ...]   # r_c(phi0) rows of `shearzone width`
    collect.py laos OUT.csv LAOSDIR [LAOSDIR ...]         # summary.csv rows of `shearzone laos`

widths: one row per input, in the order given, the width file's columns plus `item` (its
        folder: the clip or the group/branch) and `rc_se_m`, the standard error the fits
        weigh with: (rc_ci_high_m - rc_ci_low_m) / (2 z), z the normal quantile of the
        width's `confidence` (1.96 at 0.95); empty where the interval is. A width that
        holds only `# refused:` (a clip piv refused) is named in a `# skipped:` line.
laos:   the rows of every summary.csv, with `item` (the LAOS folder); a folder that LAOS
        refused (refused.txt) is named in a `# skipped:` line (exit 2 when all were).
Columns must agree between inputs (else exit 2, one line naming the first column that
differs: e.g. a stress/strain log among torque/angle logs). Written atomically.
"""
import csv
import io
import os
import statistics
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
from szcsv import header  # noqa: E402


def rows_of(path):
    with open(path, newline="", encoding="utf-8") as f:
        lines = [ln for ln in f if not ln.startswith("#")]
    r = csv.reader(lines)
    cols = next(r, None)
    if cols is None:
        fail(f"{path}: no column row")
    return cols, [row for row in r if row]


def fail(msg):
    print(f"collect.py: error: {msg}", file=sys.stderr)
    sys.exit(2)


def main():
    if len(sys.argv) < 4 or sys.argv[1] not in ("widths", "laos"):
        print(__doc__, file=sys.stderr)
        return 1
    kind, out, inputs = sys.argv[1], sys.argv[2], sys.argv[3:]
    cols0, table = None, []
    meta_lines = ["# tool: shearzone study (scripts/study/collect.py)\n",
                  f"# collected: {kind} of {len(inputs)} input(s), in the study's order\n"]
    for path in inputs:
        src = os.path.join(path, "summary.csv") if kind == "laos" else path
        refused = os.path.join(path, "refused.txt")
        if kind == "laos" and os.path.exists(refused):
            with open(refused, encoding="utf-8") as f:
                meta_lines.append(f"# skipped: {path}: {f.read().strip().lstrip('# ')}\n")
            continue
        if kind == "widths":
            with open(src, encoding="utf-8") as f:
                first = f.readline().strip()
            if first.startswith("# refused:"):  # a clip piv refused: its width holds the reason
                meta_lines.append(f"# skipped: {src}: {first.lstrip('# ')}\n")
                continue
        cols, rows = rows_of(src)
        if cols0 is None:
            cols0, first = cols, src
        elif cols != cols0:
            k = next((i for i, (a, b) in enumerate(zip(cols, cols0)) if a != b), min(len(cols), len(cols0)))
            here = cols[k] if k < len(cols) else "(none)"
            there = cols0[k] if k < len(cols0) else "(none)"
            mode = (" (one dataset's logs must all be torque/angle or all stress/strain)"
                    if kind == "laos" else "")
            fail(f"{src}: column {k + 1} is {here}, but {there} in {first}: the tables cannot be "
                 f"collected into one{mode}")
        # item: the clip (lab/clips/NAME) or group/branch (sim/G/phi0_X) the file belongs to
        parts = os.path.normpath(src).split(os.sep)
        item = "/".join(parts[:-1])
        if kind == "widths":
            conf = float(header(src).get("confidence", "nan"))
            z = statistics.NormalDist().inv_cdf(0.5 + conf / 2) if 0 < conf < 1 else float("nan")
            ilo, ihi = cols.index("rc_ci_low_m"), cols.index("rc_ci_high_m")
            for r in rows:
                se = ""
                if r[ilo] and r[ihi] and z == z:
                    v = (float(r[ihi]) - float(r[ilo])) / (2 * z)
                    se = repr(v) if v > 0 else ""
                table.append(r + [item, se])
            meta_lines.append(f"# source: {src} (confidence {conf:g}, z = {z:.6g})\n")
        else:
            for r in rows:
                table.append(r + [item])
            meta_lines.append(f"# source: {src}\n")
    if cols0 is None:
        first = next((m[len("# skipped: "):].strip() for m in meta_lines if m.startswith("# skipped: ")), "")
        fail(f"{out}: every input was refused; the first: {first}")
    extra = ["item", "rc_se_m"] if kind == "widths" else ["item"]
    if kind == "widths":
        meta_lines.append("# rc_se_m: (rc_ci_high_m - rc_ci_low_m) / (2 z): the interval's half-width as a "
                          "standard error (empty without an interval)\n")
    buf = io.StringIO()
    buf.writelines(meta_lines)
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(cols0 + extra)
    w.writerows(table)
    tmp = out + ".tmp"
    os.makedirs(os.path.dirname(out) or ".", exist_ok=True)
    with open(tmp, "w", encoding="utf-8") as f:
        f.write(buf.getvalue())
    os.replace(tmp, out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
