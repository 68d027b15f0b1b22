#!/usr/bin/env python3
"""Open a `shearzone sim` snapshot index with ParaView's XDMF 2 reader (optional check).

    pvbatch scripts/check_xdmf_paraview.py run/snapshots.xdmf

Needs ParaView's Python (Debian: paraview + python3-paraview; `pvbatch3.11`), which is
not a build or test dependency. Prints the time steps, the point count and bounds of the
last snapshot, and every point array with its component ranges; exits non-zero if the
reader finds no time steps or no points.
"""
import sys

from paraview.simple import XDMFReader


def main():
    if len(sys.argv) != 2:
        sys.exit("usage: pvbatch check_xdmf_paraview.py run/snapshots.xdmf")
    r = XDMFReader(FileNames=[sys.argv[1]])
    r.UpdatePipelineInformation()
    times = list(r.TimestepValues) if r.TimestepValues else []
    print("time steps:", len(times), "from", times[:1], "to", times[-1:])
    r.UpdatePipeline(times[-1] if times else 0.0)
    info = r.GetDataInformation()
    print("points", info.GetNumberOfPoints(), "bounds", info.GetBounds())
    for k in r.PointData.keys():
        a = r.PointData[k]
        ranges = [a.GetRange(c) for c in range(a.GetNumberOfComponents())]
        print("array", k, "components", a.GetNumberOfComponents(), "range", ranges)
    if not times or info.GetNumberOfPoints() == 0:
        sys.exit("no time steps or no points")


main()
