#!/usr/bin/python3
"""scripts/hostile.py: replay hostile and broken inputs through the CLI and check the
promises of README "Exit codes" and "Limits on inputs" for each: the expected exit code,
exactly one stderr line (none for the accepted damaged video), no output left after a
failure, and bounded cost (wall time <= --max-seconds, peak resident memory <= --max-mb
per run, measured with wait4).

    scripts/hostile.py [BIN] [--max-seconds 10] [--max-mb 1024] [--csv out.csv]

BIN defaults to build/ci/apps/shearzone. Prints one row per case (code, lines, s, MB)
and exits 1 when any case breaks a promise. Inputs are made in a temporary folder;
tests/data/regressions holds the files that cannot be made on the fly.
"""
import argparse
import csv
import re
import os
import shutil
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
REG = os.path.join(ROOT, "tests", "data", "regressions")


def run(cmd, cwd, timeout):
    """Runs cmd; returns (exit code, stdout, stderr, seconds, peak RSS in MiB)."""
    out_path = os.path.join(cwd, ".stdout")
    err_path = os.path.join(cwd, ".stderr")
    with open(out_path, "wb") as out, open(err_path, "wb") as err:
        t0 = time.monotonic()
        p = subprocess.Popen(cmd, cwd=cwd, stdout=out, stderr=err, stdin=subprocess.DEVNULL)
        deadline = t0 + timeout
        while True:
            pid, status, ru = os.wait4(p.pid, os.WNOHANG)
            if pid:
                break
            if time.monotonic() > deadline:
                p.kill()
                pid, status, ru = os.wait4(p.pid, 0)
                break
            time.sleep(0.005)
        secs = time.monotonic() - t0
    code = os.waitstatus_to_exitcode(status)
    if code < 0:
        code = 128 - code
    with open(out_path, "rb") as f:
        stdout = f.read().decode("utf-8", "replace")
    with open(err_path, "rb") as f:
        stderr = f.read().decode("utf-8", "replace")
    os.remove(out_path)
    os.remove(err_path)
    return code, stdout, stderr, secs, ru.ru_maxrss / 1024.0


def nested_toml(kind, depth=10000):
    if kind == "array":
        return "a = " + "[" * depth + "]" * depth + "\n"
    return "a = " + "{b=" * depth + "1" + "}" * depth + "\n"


SIM_BOX = "[box]\nmin_m = [-0.02, -0.02, 0]\nmax_m = [0.02, 0.02, 0.1]\n"


def sim_scene(sim="duration_s = 0.01\ntime_step_s = 1e-3\n", beads="diameter_m = 0.01\n"
              "positions_m = [0, 0, 0.005]\n", extra=""):
    return "[sim]\n" + sim + SIM_BOX + "[beads]\n" + beads + extra


def cases(work):
    """(name, argv after BIN, expected code, outputs that must be absent, regex on stderr)."""
    pair = ["in/A.png", "in/B.png"]
    fit_table = "fit.csv"
    c = []
    # --- TOML nested 10 000 deep: sim and every --config reader.
    for kind in ("array", "table"):
        toml = f"nested_{kind}.toml"
        c.append((f"sim_toml_nested_{kind}", ["sim", toml, "-o", "run"], 2, ["run"], "nested deeper"))
        c.append((f"synth_config_nested_{kind}", ["synth", "particles", "--config", toml, "-o", "o"],
                  2, ["o"], "nested deeper"))
        c.append((f"piv_config_nested_{kind}", ["piv", *pair, "--config", toml, "-o", "v.csv"],
                  2, ["v.csv"], "nested deeper"))
        c.append((f"fit_config_nested_{kind}", ["fit", "erf", fit_table, "--x", "phi0_rad", "--y", "rc_m",
                  "--config", toml, "-o", "fits.csv"], 2, ["fits.csv"], "nested deeper"))
        c.append((f"laos_config_nested_{kind}", ["laos", "laos.csv", "--config", toml, "-o", "lo"],
                  2, ["lo"], "nested deeper"))
        c.append((f"profile_config_nested_{kind}", ["profile", "fields.h5", "--config", toml, "-o", "p.csv"],
                  2, ["p.csv"], "nested deeper"))
        c.append((f"width_config_nested_{kind}", ["width", "profile.csv", "--config", toml, "-o", "w.csv"],
                  2, ["w.csv"], "nested deeper"))
        c.append((f"collapse_config_nested_{kind}", ["collapse", "fss", "fss.csv", "--x", "x", "--y", "y",
                  "--dy", "dy", "--L", "L", "--start", "0.5", "1", "0", "--config", toml, "-o", "co"],
                  2, ["co"], "nested deeper"))
    # --- Values that were internal errors (exit 4).
    c += [
        ("synth_u_1e300", ["synth", "particles", "--u", "1e300", "-o", "o"], 2, ["o"], "--u"),
        ("synth_beads_v_-1e12", ["synth", "beads", "--v", "-1e12", "-o", "o"], 2, ["o"], "--v"),
        ("synth_u_1e5", ["synth", "particles", "--u", "1e5", "-o", "o"], 2, ["o"], "--u"),
        ("synth_config_u_2147483648", ["synth", "particles", "--config", "u_big.toml", "-o", "o"],
         2, ["o"], "u"),
        ("sim_fill_count_1e9", ["sim", "fill_1e9.toml", "-o", "run"], 2, ["run"], "fill.count"),
        ("sim_beads_per_chain_1e8", ["sim", "chain_1e8.toml", "-o", "run"], 2, ["run"], "beads_per_chain"),
        ("collapse_fss_bootstrap_2e9", ["collapse", "fss", "fss.csv", "--x", "x", "--y", "y", "--dy", "dy",
         "--L", "L", "--start", "0.5", "1", "0", "--bootstrap", "2000000000", "-o", "co"],
         2, ["co"], "bootstrap"),
    ]
    # --- Unbounded time or memory.
    c += [
        ("synth_v_1e18", ["synth", "particles", "--v", "1e18", "-o", "o"], 2, ["o"], "--v"),
        ("synth_u_30000_64px", ["synth", "particles", "--u", "30000", "--width", "64", "--height", "64",
         "-o", "o"], 2, ["o"], "--u"),
        ("synth_16384px", ["synth", "particles", "--width", "16384", "--height", "16384", "-o", "o"],
         2, ["o"], "width"),
        ("piv_highpass_1e6", ["piv", *pair, "--highpass", "1e6", "-o", "v.csv"], 2, ["v.csv"], "highpass"),
        ("piv_highpass_1e5", ["piv", *pair, "--highpass", "1e5", "-o", "v.csv"], 2, ["v.csv"], "highpass"),
        ("piv_highpass_1e4", ["piv", *pair, "--highpass", "1e4", "-o", "v.csv"], 2, ["v.csv"], "highpass"),
        ("fit_erf_bootstrap_2e9", ["fit", "erf", fit_table, "--x", "phi0_rad", "--y", "rc_m",
         "--bootstrap", "2000000000", "-o", "fits.csv"], 2, ["fits.csv"], "bootstrap"),
        ("profile_h5_grid_2e9", ["profile", f"{REG}/h5_grid_declares_2e9_points.h5", "--radii-px", "0,30",
         "-o", "p.csv"], 2, ["p.csv"], "declares"),
        ("profile_h5_pairs_1e7", ["profile", f"{REG}/h5_declares_1e7_pairs_unwritten.h5", "--radii-px", "0,30",
         "-o", "p.csv"], 2, ["p.csv"], "declares"),
        ("piv_png_bomb_30000", ["piv", f"{REG}/png_declares_30000x30000.png",
         f"{REG}/png_declares_30000x30000.png", "-o", "v.csv"], 2, ["v.csv"], "30000 x 30000"),
        ("piv_tiff_bomb_20000", ["piv", f"{REG}/tiff_declares_20000x20000.tif",
         f"{REG}/tiff_declares_20000x20000.tif", "-o", "v.csv"], 2, ["v.csv"], "20000 x 20000"),
        ("piv_pgm_huge_header", ["piv", f"{REG}/pgm_declares_huge_size.pgm",
         f"{REG}/pgm_declares_huge_size.pgm", "-o", "v.csv"], 2, ["v.csv"], "px"),
        ("profile_h5_superblock", ["profile", f"{REG}/h5_superblock_driver_address_inside.h5",
         "--radii-px", "0,30", "-o", "p.csv"], 2, ["p.csv"], "HDF5"),
        ("laos_slow_header", ["laos", f"{REG}/log_header_slow_to_match.csv", "-o", "lo"], 2, ["lo"], "csv"),
    ]
    # --- Third-party lines on stderr; echoed inputs.
    c += [
        ("piv_mp4_no_moov", ["piv", f"{REG}/truncated_no_moov.mp4", "-o", "f.h5"], 2, ["f.h5"], "video"),
        ("piv_png_bad_ihdr", ["piv", f"{REG}/png_bad_ihdr_crc.png", f"{REG}/png_bad_ihdr_crc.png",
         "-o", "v.csv"], 2, ["v.csv"], "decode"),
        ("synth_codec_XXXX", ["synth", "particles", "--width", "64", "--height", "64", "--format", "mp4",
         "--codec", "XXXX", "-o", "o"], 2, ["o"], "XXXX"),
        ("fit_erf_flat_no_glog", ["fit", "erf", "flat.csv", "--x", "phi0_rad", "--y", "rc_m", "-o", "ff.csv"],
         3, None, "flat"),
        ("laos_10MB_header", ["laos", "wide.csv", "-o", "lo"], 2, ["lo"], "."),
        ("fit_10MB_header", ["fit", "erf", "wide.csv", "--x", "phi0_rad", "--y", "rc_m", "-o", "fits.csv"],
         2, ["fits.csv"], "."),
        ("missing_output", ["synth", "particles"], 1, [], "^shearzone: error: --output is required"),
    ]
    # --- Silent wrong results.
    c += [
        ("profile_nan_vector", ["profile", "fields_nan.h5", "--radii-px", "0,40", "--m-per-px", "1e-4", "--noise-region-m", "0.0005,0.002", "-o", "p.csv"], 2,
         ["p.csv"], "not finite|non-finite|NaN|nan"),
        ("sim_duration_1e300", ["sim", "dur.toml", "-o", "run"], 2, ["run"], "duration_s"),
        ("sim_time_step_1e-300", ["sim", "dt.toml", "-o", "run"], 2, ["run"], "time_step_s"),
        ("sim_coincident_beads", ["sim", "coincident.toml", "-o", "run"], 2, ["run"], "overlap"),
        ("sim_overlap_half_d", ["sim", "half.toml", "-o", "run"], 2, ["run"], "overlap"),
        ("piv_mp4_bytes_flipped", ["piv", f"{REG}/mp4_bytes_flipped.mp4", "--windows", "32,16", "-o", "f.h5"],
         0, None, "damaged"),
        ("piv_annulus_negative", ["piv", *pair, "--centre", "64,48", "--annulus", "-100,-10", "-o", "v.csv"],
         2, ["v.csv"], "annulus"),
        # NaN is refused by name (a bad flag value: exit 1; in --config: exit 2).
        ("profile_centre_nan", ["profile", "fields.h5", "--centre", "nan,nan", "--radii-px", "0,40", "--m-per-px", "1e-4", "--noise-region-m", "0.0005,0.002",
         "-o", "p.csv"], 1, ["p.csv"], "--centre: NaN is not a value"),
        ("laos_amplitude_1e-300", ["laos", "tiny.csv", "-o", "lo"], 2, ["lo"], "amplitude"),
    ]
    # --- Second probe (issue 34): NaN as "not given", damaged vendor cells, instrument
    # values out of range, study tags and grids, outputs that are links to nothing.
    c += [
        ("piv_f_hz_nan", ["piv", *pair, "--f-hz", "nan", "-o", "v.csv"], 1, ["v.csv"], "--f-hz: NaN is not a value"),
        ("profile_cycles_nan", ["profile", "fields.h5", "--cycles", "NAN", "-o", "p.csv"], 1, ["p.csv"],
         "--cycles: NaN is not a value"),
        ("laos_f_hz_minus_nan", ["laos", "laos.csv", "--f-hz", "-nan", "-o", "lo"], 1, ["lo"], "--f-hz: NaN"),
        ("laos_spp_tolerance_nan", ["laos", "laos.csv", "--spp", "--spp-tolerance", "nan", "-o", "lo"], 1, ["lo"],
         "--spp-tolerance: NaN"),
        ("laos_spp_harmonics_huge", ["laos", "laos.csv", "--spp", "--spp-harmonics", "1000000", "-o", "lo"], 2, ["lo"],
         "--spp-harmonics 1000000: expected 3..999"),
        ("synth_config_phi0_nan", ["synth", "beads", "--config", "phi0_nan.toml", "-o", "o"], 2, ["o"],
         r"phi0_nan.toml:1: key \"phi0\": --phi0: NaN is not a value"),
    ]
    for bad_name, bad in (("text", "abc"), ("empty", ""), ("1E+400", "1E+400"), ("thousands", "1.234,5")):
        c.append((f"laos_ap_cell_{bad_name}", ["laos", f"ap_{bad_name}.txt", "-o", "lo"], 2, ["lo"],
                  re.escape(f"ap_{bad_name}.txt:10: column")))
        c.append((f"laos_trios_cell_{bad_name}", ["laos", f"trios_{bad_name}.txt", "-o", "lo"], 2, ["lo"],
                  re.escape(f"trios_{bad_name}.txt:16: column")))
    c += [
        ("laos_malvern_bom_row", ["laos", "malvern_bom.csv", "-o", "lo"], 2, ["lo"], "malvern_bom.csv:20: a byte-order mark"),
        ("laos_ap_frequency_negative", ["laos", "ap_f_negative.txt", "-o", "lo"], 2, ["lo"],
         r"ap_f_negative.txt:9: the instrument's frequency: -0,1; expected > 0"),
        ("laos_ap_frequency_zero", ["laos", "ap_f_zero.txt", "-o", "lo"], 2, ["lo"], "frequency: 0; expected > 0"),
        ("study_tag_1e999", ["study", "run", "study_tag.toml", "-o", "so"], 2, ["so"], "out of the range of numbers"),
        ("study_pattern_wildcards", ["study", "run", "study_wild.toml", "-o", "so"], 2, ["so"], "does not match"),
        ("study_grid_duplicate", ["study", "run", "study_dup.toml", "-o", "so"], 2, ["so"], "appears twice"),
        ("study_grid_1e5", ["study", "run", "study_big.toml", "--dry-run", "-o", "so"], 2, ["so"], "a line of [0-9]+ characters"),
        ("study_grid_2000", ["study", "run", "study_2000.toml", "--dry-run", "-o", "so"], 2, ["so"],
         r"sim.seeds\": a grid of 2000 points"),
        ("sim_drive_alias", ["sim", "cup_alias.toml", "-o", "run"], 2, ["run"],
         r"cup_alias.toml:44: key \"protocol.f_Hz\": 199 Hz with sim.time_step_s = 0.001 s"),
        ("sim_branch_steps_1e9", ["sim", "cup_cycles.toml", "-o", "run"], 2, ["run"],
         r"key \"protocol.cycles\": 1000000 cycles at 0.5 Hz"),
        ("sim_check_passes_9", ["sim", "check", "run_none", "-o", "co", "--passes", "9"], 2, ["co"],
         "--passes 9: expected 1..6"),
        ("sim_check_passes_alone", ["sim", "check", "run_none", "-o", "co", "--passes", "2"], 2, ["co"],
         "--passes: it sets the passes of the --final-windows grid"),
        ("sim_existing_output_before_fill", ["sim", os.path.join(ROOT, "data-samples", "sim", "filmed_cup.toml"),
         "-o", "simdone"], 2, [], "simdone/snapshots.h5: output exists"),
        ("sim_existing_surface_before_fill", ["sim", os.path.join(ROOT, "data-samples", "sim", "filmed_cup.toml"),
         "-o", "simdone_surface"], 2, [], "simdone_surface/surface.h5: output exists"),
        ("sim_check_no_surface", ["sim", "check", "branch_nosurf", "-o", "co"], 2, ["co"],
         "branch_nosurf/surface.h5: no such file"),
        ("sim_restart_other_scene", ["sim", "ck_other.toml", "--restart", "ck_run/checkpoint.h5", "-o", "run"], 2,
         ["run"], r"ck_run/checkpoint.h5: not a checkpoint of ck_other.toml: the scene has 2 beads"),
        ("sim_check_mixed_runs", ["sim", "check", "mix", "-o", "co"], 2, ["co"],
         r"mix/surface.h5: run_id [0-9a-f]{16} is not frames.h5's run_id [0-9a-f]{16}: the two files come from "
         "different runs"),
        ("piv_mp4_stalled_stamps", ["piv", "stalled.mp4", "--windows", "32,16", "-o", "st.h5"], 2, ["st.h5"],
         r"stalled.mp4: the container's clocks disagree: its time stamps give no rate \(20 frames in 0 s, 19 of them"),
        ("piv_mp4_tick_stamps", ["piv", "tick.mp4", "--windows", "32,16", "-o", "st.h5"], 2, ["st.h5"],
         r"tick.mp4: the container's clocks disagree: its time stamps give 12800 fps"),
        ("study_generated_scene_refused", ["study", "run", "study_n10.toml", "-o", "so"], 2, ["so"],
         r"the scene of group N10_l0.0004_a60_s1: key \"cylinder.sectors\": a periodic sector with chains of 10 beads"),
        ("render_size_1e8", ["sim", "render", "cam_a", "-o", "rv", "--size", "16384,16384", "--format", "png"], 2,
         ["rv"], r"--size 16384x16384: 2.68e\+08 pixels per frame; expected at most 1e\+08"),
        ("render_mp4v_too_wide", ["sim", "render", "cam_a", "-o", "rv", "--size", "9000,2000"], 2, ["rv"],
         r"--codec mp4v holds at most 8190 px each way"),
        ("output_dangling_link", ["width", "profile.csv", "-o", "dangling.csv"], 2, [],
         "output is a symbolic link to a missing"),
        ("width_footprint_negative", ["width", "profile_bad_footprint.csv", "-o", "w.csv"], 2, ["w.csv"],
         r"profile_bad_footprint.csv: header \"velocity_footprint_var_m2: -1e-08\": expected a variance >= 0 m\^2"),
        ("width_velocity_bias_inf", ["width", "profile_bad_bias.csv", "-o", "w.csv"], 2, ["w.csv"],
         r"profile_bad_bias.csv: header \"velocity_bias_bound_m_per_s: inf\": expected a speed >= 0 m/s"),
        ("width_vector_radii_negative_sd", ["width", "profile_bad_radii.csv", "-o", "w.csv"], 2, ["w.csv"],
         r"profile_bad_radii.csv:[0-9]+: column \"r_vectors_sd_m\": -0.001; expected a standard deviation >= 0"),
    ]
    # --- report: folders whose files are not what shearzone wrote (hand-edited, cut short).
    c += [
        ("report_study_json_garbage", ["report", "rep_json"], 2, ["rep_json/report.html"],
         r"rep_json/study.json: line 1: not valid JSON"),
        ("report_fields_not_hdf5", ["report", "rep_h5"], 2, ["rep_h5/report.html"],
         r"rep_h5/fields.h5: not a readable HDF5 file"),
        ("report_closed_loop_no_columns", ["report", "rep_loop"], 2, ["rep_loop/report.html"],
         r"rep_loop/closed_loop.csv: no column or key 'branch'"),
    ]
    return c


def make_inputs(bin_, work):
    def w(name, text):
        with open(os.path.join(work, name), "w") as f:
            f.write(text)

    for kind in ("array", "table"):
        w(f"nested_{kind}.toml", nested_toml(kind))
    subprocess.run([bin_, "synth", "particles", "--width", "128", "--height", "96", "--u", "1.5",
                    "--v", "-0.5", "-q", "-o", "in"], cwd=work, check=True)
    subprocess.run([bin_, "synth", "particles", "--width", "128", "--height", "96", "--field", "rotation",
                    "--omega", "0.02", "--frames", "4", "-q", "-o", "clip"], cwd=work, check=True)
    subprocess.run([bin_, "piv", "clip/frame_*.png", "--windows", "32,16", "--centre", "64,48", "-q", "-o", "fields.h5"], cwd=work, check=True)
    subprocess.run([bin_, "profile", "fields.h5", "--radii-px", "0,40", "--m-per-px", "1e-4", "--noise-region-m", "0.0005,0.002", "-q", "-o", "profile.csv"],
                   cwd=work, check=True)
    # A profile whose vectors' spread in one bin is negative (a hand-edited file).
    lines = open(os.path.join(work, "profile.csv")).read().split("\n")
    header = next(i for i, l in enumerate(lines) if l.startswith("r_m,"))
    col = lines[header].split(",").index("r_vectors_sd_m")
    row = next(i for i in range(header + 1, len(lines)) if lines[i] and lines[i].split(",")[col])
    cells = lines[row].split(",")
    cells[col] = "-0.001"
    lines[row] = ",".join(cells)
    open(os.path.join(work, "profile_bad_radii.csv"), "w").write("\n".join(lines))
    # ... and profiles with one header value the width must refuse.
    for name, key, value in (("profile_bad_footprint.csv", "velocity_footprint_var_m2", "-1e-08"),
                             ("profile_bad_bias.csv", "velocity_bias_bound_m_per_s", "inf")):
        text = open(os.path.join(work, "profile.csv")).read()
        text = re.sub(rf"# {key}: [^\n]*", f"# {key}: {value}", text)
        open(os.path.join(work, name), "w").write(text)
    shutil.copy(os.path.join(work, "fields.h5"), os.path.join(work, "fields_nan.h5"))
    import h5py  # python3-h5py (scripts/setup.sh)
    with h5py.File(os.path.join(work, "fields_nan.h5"), "r+") as f:
        u = f["/pairs/u_px"]
        flat = u[...].reshape(-1)
        flat[len(flat) // 2] = float("nan")
        u[...] = flat.reshape(u.shape)
    w("fit.csv", "phi0_rad,rc_m\n" + "".join(f"{0.1 * i:.1f},{0.01 + 0.01 * (i > 6):.3f}\n"
                                             for i in range(1, 14)))
    w("flat.csv", "phi0_rad,rc_m\n" + "".join(f"{0.1 * i:.1f},0.01\n" for i in range(1, 14)))
    w("fss.csv", "L,x,y,dy\n" + "".join(f"{L},{0.4 + 0.02 * i:.2f},{0.1 * i / L ** 0.1:.4f},0.01\n"
                                        for L in (8, 16, 32) for i in range(10)))
    w("laos.csv", "time_s,angle_rad,torque_N_m\n" + "".join(
        f"{0.01 * i:.2f},{0.3:.2f},{0.001:.3f}\n" for i in range(10)))
    import math
    w("tiny.csv", "time_s,angle_rad,torque_N_m\n" + "".join(
        f"{0.01 * i:.3f},{1e-300 * math.sin(2 * math.pi * 0.01 * i):.6e},{math.sin(2 * math.pi * 0.01 * i):.6f}\n"
        for i in range(500)))
    with open(os.path.join(work, "wide.csv"), "w") as f:
        f.write("phi0_rad," + ",".join(f"column_with_a_long_name_{i}" for i in range(400000)) + "\n0.1,0.2\n")
    for d, name, text in (("rep_json", "study.json", '{"study_file": "s.toml", clips'),
                          ("rep_h5", "fields.h5", "not HDF5\n"),
                          ("rep_loop", "closed_loop.csv", "# tool: shearzone\nrun,setting\nr,w\n")):
        os.makedirs(os.path.join(work, d), exist_ok=True)
        w(os.path.join(d, name), text)
    w("u_big.toml", "u = 2147483648\n")
    w("fill_1e9.toml", "[sim]\nduration_s = 0.01\n" + SIM_BOX + "[beads]\ndiameter_m = 0.001\n"
      "[fill]\ncount = 1000000000\nmin_m = [-0.01, -0.01, 0.01]\nmax_m = [0.01, 0.01, 0.05]\n")
    w("chain_1e8.toml", "[sim]\nduration_s = 0.01\n" + SIM_BOX + "[beads]\ndiameter_m = 0.001\n"
      "[chains]\nbeads_per_chain = 100000000\ncount = 1\n")
    w("phi0_nan.toml", "phi0 = nan\n")
    logs = os.path.join(ROOT, "tests", "data", "logs")

    def corrupt(src, dst, lineno, col, bad, sep):
        raw = open(os.path.join(logs, src), "rb").read()
        enc = "utf-16" if raw[:2] in (b"\xff\xfe", b"\xfe\xff") else "utf-8-sig" if raw[:3] == b"\xef\xbb\xbf" else "utf-8"
        lines = raw.decode(enc).split("\n")
        cells = lines[lineno - 1].split(sep)
        if col < 0:
            cells[0] = bad + cells[0]
        else:
            cells[col] = bad
        lines[lineno - 1] = sep.join(cells)
        with open(os.path.join(work, dst), "wb") as f:
            f.write("\n".join(lines).encode("utf-8"))

    for bad_name, bad in (("text", "abc"), ("empty", ""), ("1E+400", "1E+400"), ("thousands", "1.234,5")):
        corrupt("anton_paar_fr.txt", f"ap_{bad_name}.txt", 10, 3, bad, "\t")
        corrupt("trios.txt", f"trios_{bad_name}.txt", 16, 1, bad.replace("1.234,5", "1,234.5"), "\t")
    corrupt("malvern_rspace.csv", "malvern_bom.csv", 20, -1, "\ufeff", ";")
    corrupt("anton_paar_de_points.txt", "ap_f_negative.txt", 9, 3, "-0,1", "\t")
    corrupt("anton_paar_de_points.txt", "ap_f_zero.txt", 9, 3, "0", "\t")
    os.makedirs(os.path.join(work, "tags"), exist_ok=True)
    w("tags/N1_phi1e999.mp4", "x")
    w("study_tag.toml", "[lab.clip_glob]\nfiles = \"tags/*.mp4\"\npattern = \"N{N}_phi{phi0_rad}\"\n")
    os.makedirs(os.path.join(work, "wild"), exist_ok=True)
    w("wild/" + "a" * 240 + ".mp4", "x")
    w("study_wild.toml", "[lab.clip_glob]\nfiles = \"wild/*.mp4\"\npattern = \"*a*a*a*a*a*a*a*N{N}*b\"\n")
    cup = open(os.path.join(ROOT, "data-samples", "sim", "vane_cup.toml")).read()
    w("cup.toml", cup)
    w("cup_alias.toml", cup.replace("f_Hz = 0.5 ", "f_Hz = 199 ", 1))
    w("cup_cycles.toml", cup.replace("cycles = 2", "cycles = 1e6", 1))
    w("cup_quarter.toml", cup.replace("[cylinder]\n", "[cylinder]\nsectors = 4\n", 1))
    w("study_n10.toml", "[sim]\nscene = \"cup_quarter.toml\"\nN = [10]\nl_max_m = [0.0004]\nmax_angle_deg = [60]\n")
    w("study_dup.toml", "[sim]\nscene = \"cup.toml\"\nl_max_m = [0.0004, 4e-4]\n")
    w("study_2000.toml", "[sim]\nscene = \"cup.toml\"\nseeds = [" + ", ".join(str(i) for i in range(2000)) + "]\n")
    w("study_big.toml", "[sim]\nscene = \"cup.toml\"\nseeds = [" + ", ".join(str(i) for i in range(100000)) + "]\n")
    os.symlink(os.path.join(work, "missing", "w.csv"), os.path.join(work, "dangling.csv"))
    os.makedirs(os.path.join(work, "branch_nosurf"), exist_ok=True)
    w("branch_nosurf/frames.h5", "frames of a branch whose surface.h5 is missing")
    os.makedirs(os.path.join(work, "simdone"), exist_ok=True)
    w("simdone/snapshots.h5", "a finished run's file")
    os.makedirs(os.path.join(work, "simdone_surface"), exist_ok=True)
    w("simdone_surface/surface.h5", "a finished run's surface field")
    w("ck.toml", sim_scene())
    subprocess.run([bin_, "sim", "ck.toml", "-q", "-o", "ck_run"], cwd=work, check=True)
    w("ck_other.toml", sim_scene(beads="diameter_m = 0.01\npositions_m = [0, 0, 0.005, 0.011, 0, 0.005]\n"))
    # Two tiny filmed cups (a periodic quarter, 40 beads, 0.1 s) and a branch folder
    # holding the frames of one and the surface field of the other.
    cam = ("[sim]\nduration_s = 0.1\ntime_step_s = 1e-3\nfriction = 0.3\ntolerance = 1e-3\n"
           "max_iterations = 100\n[output]\nsnapshot_every = 0\n[cylinder]\nradius_m = 0.024\nheight_m = 0.02\n"
           "bead_diameter_m = 0.004\nsectors = 4\n[beads]\ndiameter_m = 0.004\ndensity_kg_per_m3 = 7800\n"
           "[vane]\nradius_m = 0.01\nheight_m = 0.02\nphi0_rad = 0.0628\nf_Hz = 2.0\n[fill]\ncount = 40\n"
           "settle = true\n[camera]\nspacing_px = 4\n")
    for name, text in (("cam_a", cam), ("cam_b", cam.replace("f_Hz = 2.0", "f_Hz = 3.0"))):
        w(name + ".toml", text)
        subprocess.run([bin_, "sim", name + ".toml", "-q", "-o", name], cwd=work, check=True)
    os.makedirs(os.path.join(work, "mix"), exist_ok=True)
    shutil.copy(os.path.join(work, "cam_a", "frames.h5"), os.path.join(work, "mix", "frames.h5"))
    shutil.copy(os.path.join(work, "cam_b", "surface.h5"), os.path.join(work, "mix", "surface.h5"))
    # MP4s whose time stamps stall (every stts delta 0) or tick once per frame (1/12800 s).
    import cv2  # python3-opencv (scripts/setup.sh)
    import numpy as np
    import struct
    grain = (np.random.default_rng(1).random((96, 160)) * 255).astype(np.uint8)
    for name, delta in (("stalled.mp4", 0), ("tick.mp4", 1)):
        path = os.path.join(work, name)
        vw = cv2.VideoWriter(path, cv2.VideoWriter_fourcc(*"mp4v"), 25.0, (128, 96), False)
        for k in range(20):
            vw.write(np.ascontiguousarray(grain[:, k:k + 128]))
        vw.release()
        data = bytearray(open(path, "rb").read())
        at = data.find(b"stts")
        for e in range(struct.unpack(">I", data[at + 8:at + 12])[0]):
            data[at + 16 + 8 * e:at + 20 + 8 * e] = struct.pack(">I", delta)
        open(path, "wb").write(bytes(data))
    w("dur.toml", sim_scene(sim="duration_s = 1e300\ntime_step_s = 1e-3\n"))
    w("dt.toml", sim_scene(sim="duration_s = 0.01\ntime_step_s = 1e-300\n"))
    w("coincident.toml", sim_scene(beads="diameter_m = 0.01\npositions_m = [0, 0, 0.005, 0, 0, 0.005]\n"))
    w("half.toml", sim_scene(beads="diameter_m = 0.01\npositions_m = [0, 0, 0.005, 0.005, 0, 0.005]\n"))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("bin", nargs="?", default=os.path.join(ROOT, "build", "ci", "apps", "shearzone"))
    ap.add_argument("--max-seconds", type=float, default=10.0)
    ap.add_argument("--max-mb", type=float, default=1024.0)
    ap.add_argument("--csv", help="also write the table as CSV")
    ap.add_argument("-k", help="only cases whose name contains this")
    a = ap.parse_args()
    bin_ = os.path.abspath(a.bin)
    import re
    rows, failures = [], 0
    with tempfile.TemporaryDirectory(prefix="shearzone-hostile-") as work:
        make_inputs(bin_, work)
        for name, argv, want, absent, pattern in cases(work):
            if a.k and a.k not in name:
                continue
            code, out, err, secs, mb = run([bin_, *argv], work, timeout=max(a.max_seconds * 3, 30))
            lines = err.count("\n") + (1 if err and not err.endswith("\n") else 0)
            problems = []
            if code != want:
                problems.append(f"exit {code}, expected {want}")
            want_lines = 0 if want == 0 else 1
            if lines != want_lines:
                problems.append(f"{lines} stderr lines, expected {want_lines}")
            text = err if want != 0 else out
            if pattern and not re.search(pattern, text):
                problems.append(f"message does not match /{pattern}/")
            for p in absent or []:
                if os.path.exists(os.path.join(work, p)):
                    problems.append(f"{p} left behind")
            if secs > a.max_seconds:
                problems.append(f"{secs:.1f} s > {a.max_seconds:g} s")
            if mb > a.max_mb:
                problems.append(f"{mb:.0f} MB > {a.max_mb:g} MB")
            for p in ("o", "run", "lo", "co", "so", "f.h5", "v.csv", "p.csv", "fits.csv", "w.csv", "ff.csv"):
                path = os.path.join(work, p)
                if os.path.isdir(path):
                    shutil.rmtree(path)
                elif os.path.exists(path):
                    os.remove(path)
            for p in os.listdir(work):
                if p.startswith(("p_", "fits_", "ff_")):
                    os.remove(os.path.join(work, p))
            failures += bool(problems)
            msg = (err.strip().splitlines() or [out.strip()])[0][:150] if (err or out) else ""
            rows.append((name, code, lines, f"{secs:.3f}", f"{mb:.0f}", "; ".join(problems) or "ok", msg))
            print(f"{'FAIL' if problems else 'ok  '} {name:34s} exit {code:3d}  {lines} line(s)  "
                  f"{secs:6.2f} s  {mb:6.0f} MB  {'; '.join(problems)}")
            if problems:
                print(f"     stderr: {err.strip()[:300]}")
    if a.csv:
        with open(a.csv, "w", newline="") as f:
            wr = csv.writer(f)
            wr.writerow(["case", "exit_code", "stderr_lines", "wall_s", "peak_rss_MB", "verdict", "first_line"])
            wr.writerows(rows)
    print(f"hostile: {len(rows) - failures} of {len(rows)} cases keep every promise "
          f"(<= {a.max_seconds:g} s, <= {a.max_mb:g} MB)")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
