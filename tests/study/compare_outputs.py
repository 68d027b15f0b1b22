#!/usr/bin/python3
"""compare_outputs.py A B: are two study folders the same, file by file?

Every file but Snakemake's bookkeeping (.snakemake/, .snakemake_timestamp) must exist in
both and hold the same bytes, with one exception: the wall-clock times a simulation
records (a `# fill_wall_s:` header line, the `wall_s` column of cycles.csv, HDF5
attributes named *wall* and the wall_s lines of a header stored as an attribute), which no two runs share. HDF5 files are compared by content
(every dataset's dtype, shape and values; every other attribute). Exit 0 when the same,
1 (with the differences on stderr) when not.
"""
import hashlib
import os
import sys

import h5py
import numpy as np


def files(root):
    out = set()
    for d, dirs, names in os.walk(root):
        dirs[:] = [x for x in dirs if x != ".snakemake"]
        for n in names:
            if n != ".snakemake_timestamp":
                out.add(os.path.relpath(os.path.join(d, n), root))
    return out


def text_key(path):
    with open(path, "rb") as f:
        lines = f.read().split(b"\n")
    keep, wall_col = [], None
    for ln in lines:
        if ln.startswith(b"#") and b"wall_s" in ln:
            continue
        cells = ln.split(b",")
        if wall_col is None and b"wall_s" in cells:
            wall_col = cells.index(b"wall_s")
        if wall_col is not None and len(cells) > wall_col and not ln.startswith(b"#"):
            del cells[wall_col]
        keep.append(b",".join(cells))
    return hashlib.sha256(b"\n".join(keep)).hexdigest()


def h5_items(path):
    items = {}

    def attrs(name, obj):
        for k, v in obj.attrs.items():
            if "wall" in k:
                continue
            if isinstance(v, bytes):
                v = v.decode("utf-8", "replace")
            if isinstance(v, str):  # a header block as text: its wall-clock lines left out
                v = "\n".join(ln for ln in v.split("\n") if "wall_s" not in ln)
            items[f"{name}@{k}"] = repr(np.asarray(v).tolist())

    with h5py.File(path, "r") as f:
        attrs("/", f)

        def visit(name, obj):
            attrs(name, obj)
            if isinstance(obj, h5py.Dataset):
                a = obj[()]
                items[name] = (str(obj.dtype), obj.shape, hashlib.sha256(np.ascontiguousarray(a).tobytes()).hexdigest())
        f.visititems(visit)
    return items


def key(path):
    if path.endswith(".h5"):
        return h5_items(path)
    if path.endswith((".csv", ".txt", ".toml", ".json", ".xdmf", ".svg")):
        return text_key(path)
    with open(path, "rb") as f:
        return hashlib.sha256(f.read()).hexdigest()


def main():
    a, b = sys.argv[1], sys.argv[2]
    fa, fb = files(a), files(b)
    bad = [f"only in {a}: {p}" for p in sorted(fa - fb)] + [f"only in {b}: {p}" for p in sorted(fb - fa)]
    for p in sorted(fa & fb):
        ka, kb = key(os.path.join(a, p)), key(os.path.join(b, p))
        if ka != kb:
            detail = ""
            if isinstance(ka, dict):
                detail = ": " + ", ".join(sorted(k for k in set(ka) | set(kb) if ka.get(k) != kb.get(k)))[:300]
            bad.append(f"differs: {p}{detail}")
    for line in bad:
        print(f"compare_outputs.py: {line}", file=sys.stderr)
    print(f"compare_outputs.py: {len(fa & fb)} files compared, {len(bad)} differences")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
