#!/usr/bin/python3
"""Check that the demo's figures exist and are real pictures.

    /usr/bin/python3 scripts/check_figures.py DIR [REL.png ...]

DIR is a demo output folder (scripts/demo.sh: demo-output/; scripts/test_figures.sh: its
WORKDIR). Without REL.png arguments the demo's figure list (FIGURES below) is checked.
Each file must be a valid PNG (signature, IHDR, IEND), at least 400 x 300 pixels and
10 kB, saved at >= 150 dpi when the file records its resolution (pHYs), and not blank
(decoded with matplotlib: some spread of pixel values). Exits 1 and names every failure.
"""
import os
import struct
import sys
import zlib

FIGURES = [
    "sand_piv.png",                      # PIV of the PIVlab sand pair over frame A
    "beads_vane/piv_field.png",          # PIV of the bead clip over its video frame
    "beads_vane/truth.png",              # ground truth of the bead clip
    "pair_rotation/truth.png",           # ground truth of the rotating pair
    "beads_vane/fig2a_profile.png",      # Fig 2A
    "fits/fig2c_rc.png",                 # Fig 2C
    "fits/fig2d_W.png",                  # Fig 2D
    "fits/fig2e_collapse.png",           # Fig 2E
    "laos/fig3a_tau_max.png",            # Fig 3A
    "laos/fig3d_tau_N.png",              # Fig 3D
    "laos/fig5_lissajous_N45.png",       # Fig 5
    "laos/fig6_tan_delta.png",           # Fig 6
    "laos/fig_spp_N45.png",              # within the cycle (laos --spp)
    "sim_cup/check/closed_loop.png",     # the closed loop: video r_c and PIV error against truth
]
MIN_W, MIN_H, MIN_BYTES, MIN_DPI = 400, 300, 10_000, 150


def check_png(path):
    """A list of problems with the PNG at path (empty when it is fine)."""
    if not os.path.isfile(path):
        return ["missing"]
    size = os.path.getsize(path)
    with open(path, "rb") as f:
        data = f.read()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        return ["not a PNG (bad signature)"]
    problems = []
    pos, chunks, w, h = 8, {}, 0, 0
    while pos + 8 <= len(data):
        n, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + n]
        crc = data[pos + 8 + n:pos + 12 + n]
        if len(body) != n or len(crc) != 4 or zlib.crc32(kind + body) != struct.unpack(">I", crc)[0]:
            return problems + [f"corrupt chunk {kind!r}"]
        chunks.setdefault(kind, body)
        pos += 12 + n
        if kind == b"IEND":
            break
    if b"IHDR" not in chunks or b"IEND" not in chunks or b"IDAT" not in chunks:
        return problems + ["truncated (IHDR, IDAT or IEND missing)"]
    w, h = struct.unpack(">II", chunks[b"IHDR"][:8])
    if w < MIN_W or h < MIN_H:
        problems.append(f"{w}x{h} px, below {MIN_W}x{MIN_H}")
    if size < MIN_BYTES:
        problems.append(f"{size} bytes, below {MIN_BYTES}")
    if b"pHYs" in chunks:
        px, py, unit = struct.unpack(">IIB", chunks[b"pHYs"][:9])
        if unit == 1 and min(px, py) * 0.0254 < MIN_DPI - 0.5:
            problems.append(f"{min(px, py) * 0.0254:.0f} dpi, below {MIN_DPI}")
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.image as mpimg

        img = mpimg.imread(path)
        if float(img[..., :3].std()) < 0.01:
            problems.append("blank (no spread of pixel values)")
    except ImportError:
        pass
    except Exception as e:  # noqa: BLE001 - any decoding error is a bad PNG
        problems.append(f"cannot decode: {e}")
    return problems


def main():
    if len(sys.argv) < 2 or sys.argv[1] in ("-h", "--help"):
        sys.exit(__doc__)
    root = sys.argv[1]
    names = sys.argv[2:] or FIGURES
    bad = 0
    for rel in names:
        problems = check_png(os.path.join(root, rel))
        if problems:
            bad += 1
            print(f"check_figures: FAIL {rel}: {'; '.join(problems)}")
    print(f"check_figures: {len(names) - bad} of {len(names)} figures OK in {root}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
