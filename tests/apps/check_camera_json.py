#!/usr/bin/python3
"""camera.json is valid JSON whatever the run folder is called: a tiny filmed cup run into
a folder whose name holds `"` and `\\`, rendered, and its camera.json read back with
Python's json module (the folder name intact). Run by CTest.

    check_camera_json.py SHEARZONE WORKDIR
"""
import json
import os
import shutil
import subprocess
import sys

sz, work = sys.argv[1], sys.argv[2]
shutil.rmtree(work, ignore_errors=True)
os.makedirs(work)
scene = ("[sim]\nduration_s = 0.1\ntime_step_s = 1e-3\nfriction = 0.3\ntolerance = 1e-3\nmax_iterations = 100\n"
         "[output]\nsnapshot_every = 0\n[cylinder]\nradius_m = 0.024\nheight_m = 0.02\nbead_diameter_m = 0.004\n"
         "sectors = 4\n[beads]\ndiameter_m = 0.004\ndensity_kg_per_m3 = 7800\n[vane]\nradius_m = 0.01\n"
         "height_m = 0.02\nphi0_rad = 0.0628\nf_Hz = 2.0\n[fill]\ncount = 40\nsettle = true\n[camera]\nspacing_px = 4\n")
with open(os.path.join(work, "cam.toml"), "w") as f:
    f.write(scene)
run = 'run "quoted" \\ back'
subprocess.run([sz, "sim", "cam.toml", "-q", "-o", run], cwd=work, check=True)
subprocess.run([sz, "sim", "render", run, "-o", "video", "--size", "64,64", "-q"], cwd=work, check=True)
with open(os.path.join(work, "video", "camera.json"), encoding="utf-8") as f:
    cam = json.load(f)  # raises on invalid JSON
if cam["run"] != run:
    sys.exit(f"check_camera_json: camera.json names the run {cam['run']!r}, expected {run!r}")
print("check_camera_json: camera.json is valid JSON for a run folder named " + run)
