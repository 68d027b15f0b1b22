"""The Python module against the command: the same numbers bit for bit on the same
input, the command's messages as exceptions, nothing left behind on failure.

Run by ctest ("python: ..."): PYTHONPATH holds the build's python/ folder and
SHEARZONE_CLI the command built beside it."""
import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

import shearzone as sz

CLI = os.environ["SHEARZONE_CLI"]
ROOT = Path(__file__).resolve().parents[2]


def cli(*args, code=0):
    r = subprocess.run([CLI, *map(str, args)], capture_output=True, text=True)
    assert r.returncode == code, r.stderr
    return r


@pytest.fixture(scope="module")
def beads(tmp_path_factory):
    """A rendered clip of 24 px beads in uniform shift (4 frames) and its first pair."""
    d = tmp_path_factory.mktemp("beads")
    cli("synth", "beads", "-o", d / "clip", "--width", 256, "--height", 192, "--diameter", 24, "--u", 1.3,
        "--v", -0.6, "--frames", 4, "--seed", 3)
    cli("synth", "beads", "-o", d / "pair", "--width", 256, "--height", 192, "--diameter", 24, "--u", 1.3,
        "--v", -0.6, "--seed", 3)
    return d


def test_piv_on_arrays_equals_the_command(beads, tmp_path):
    cli("piv", beads / "pair" / "A.png", beads / "pair" / "B.png", "-o", tmp_path / "cli.csv", "--overlap", 0.5)
    table = sz.read_table(tmp_path / "cli.csv")
    a = sz.synth_beads(width=256, height=192, diameter=24, u=1.3, v=-0.6, seed=3)["frames"]
    r = sz.piv(a[0], a[1], overlap=0.5)
    assert r.u_px.dtype == np.float32 and r.u_px.ndim == 2
    np.testing.assert_array_equal(r.x_px.ravel(), table["x_px"])
    np.testing.assert_array_equal(r.y_px.ravel(), table["y_px"])
    for name in ("u_px", "v_px", "peak", "peak_ratio"):
        np.testing.assert_array_equal(getattr(r, name).ravel(), table[name].astype(np.float32), err_msg=name)
    flags = {v: k for k, v in sz.PivResult.FLAGS.items()}
    np.testing.assert_array_equal(r.flag.ravel(), [flags[f] for f in table["flag"]])
    assert r.header["piv_overlap"] == table.header["piv_overlap"]
    # The frames rendered by Python and read from the command's PNGs are the same.
    np.testing.assert_array_equal(a[0], sz._native.read_image(str(beads / "pair" / "A.png")))


def test_piv_of_a_clip_equals_the_command_and_reports_progress(beads, tmp_path):
    frames = str(beads / "clip" / "frame_*.png")
    cli("piv", frames, "-o", tmp_path / "cli.h5")
    seen = []
    fields = sz.piv_video(frames, tmp_path / "py.h5", progress=lambda label, k, n: seen.append((label, k, n)))
    ref = sz.read_fields(tmp_path / "cli.h5")
    assert len(fields) == len(ref) == 3
    for k in range(3):
        for name in ("u_px", "v_px", "flag", "peak", "peak_ratio", "t_a_s", "dt_s"):
            np.testing.assert_array_equal(fields[k][name], ref[k][name], err_msg=name)
    assert seen and seen[-1][1] == 3 and seen[-1][0] == "piv: pairs"
    assert fields.attr("fps") == 25.0 and fields.header["grey_conversion"] == "luma"


def test_profile_and_width_equal_the_command(tmp_path):
    """A shear zone of known width: v = U0 exp(-(r - r0)/w), U0 = 3 px per frame, r0 = w =
    20 px (0.1 mm per px, 25 fps), so v = 2 mm/s at r = 46.4 px = 4.64 mm."""
    cli("synth", "beads", "-o", tmp_path / "clip", "--width", 256, "--height", 192, "--diameter", 16, "--field",
        "shear-zone", "--r0", 20, "--w", 20, "--U0", 3, "--frames", 6, "--seed", 3)
    cli("piv", tmp_path / "clip" / "frame_*.png", "-o", tmp_path / "f.h5")
    opts = ["--centre", "128,96", "--radii-px", "10,90", "--m-per-px", "1e-4", "--bin-px", "8"]
    cli("profile", tmp_path / "f.h5", "-o", tmp_path / "cli.csv", *opts)
    p = sz.profile(tmp_path / "f.h5", tmp_path / "py.csv", centre=(128, 96), radii_px=(10, 90), m_per_px=1e-4,
                   bin_px=8)
    ref = sz.read_table(tmp_path / "cli.csv")
    assert set(p.keys()) == set(ref.keys())
    # The header is the command's; its command line is the one that gives the same table.
    assert {k: v for k, v in p.header.items() if k != "command_line"} == \
        {k: v for k, v in ref.header.items() if k != "command_line"}
    assert p.header["command_line"].startswith("shearzone profile ")
    for name in ref.keys():
        np.testing.assert_array_equal(p[name], ref[name], err_msg=name)
    columns = ("rc_m", "rc_ci_low_m", "rc_ci_high_m", "rc_status", "v_noise_m_per_s")
    cli("width", tmp_path / "cli.csv", "-o", tmp_path / "w_cli.csv", "--vc", 2e-3)
    w = sz.width(tmp_path / "py.csv", vc=2e-3)
    ref = sz.read_table(tmp_path / "w_cli.csv")
    for name in columns:
        np.testing.assert_array_equal(w[name], ref[name], err_msg=name)
    assert w["rc_status"][0] == "ok" and abs(w["rc_m"][0] - 4.64e-3) < 0.3e-3  # 3 px: a bin and a half
    # Below the noise floor the command exits 3 and writes the row with its status; Python
    # returns the same table and warns.
    cli("width", tmp_path / "cli.csv", "-o", tmp_path / "w3_cli.csv", "--vc", 1e-5, code=3)
    with pytest.warns(sz.NoResultWarning, match="noise floor"):
        w = sz.width(tmp_path / "py.csv", vc=1e-5)
    ref = sz.read_table(tmp_path / "w3_cli.csv")
    for name in columns:
        np.testing.assert_array_equal(w[name], ref[name], err_msg=name)
    assert w["rc_status"][0] == "noise_limited" and np.isnan(w["rc_m"][0])


def test_fits_on_arrays_equal_the_command(tmp_path):
    rng = np.random.default_rng(5)
    x = np.linspace(0.05, 0.5, 12)
    y = 2 + 3 * 0.5 * (1 + np.vectorize(__import__("math").erf)((x - 0.25) / 0.08)) + rng.normal(0, 0.05, x.size)
    s = np.full(x.size, 0.05)
    with open(tmp_path / "t.csv", "w") as f:
        f.write("phi0_rad,rc_m,se_m\n")
        for a, b, c in zip(x, y, s):
            f.write(f"{a!r},{b!r},{c!r}\n")
    cli("fit", "erf", tmp_path / "t.csv", "-o", tmp_path / "erf.csv", "--x", "phi0_rad", "--y", "rc_m", "--sigma",
        "se_m", "--bootstrap", 50)
    ref = sz.read_table(tmp_path / "erf.csv")
    f = sz.fit_erf(x, y, s, bootstrap=50)
    assert f.ok
    for i, name in enumerate(ref["parameter"]):
        assert f.params[name] == ref["value"][i]
        assert f.std_errors[name] == ref["std_error"][i]
        assert f.ci[name] == (ref["ci_low"][i], ref["ci_high"][i])
        assert f.bootstrap_ci[name] == (ref["boot_low"][i], ref["boot_high"][i])
    yp = 0.7 * x ** 1.5 * (1 + rng.normal(0, 0.02, x.size))
    with open(tmp_path / "p.csv", "w") as f:
        f.write("N,v\n")
        for a, b in zip(x, yp):
            f.write(f"{a!r},{b!r}\n")
    cli("fit", "power", tmp_path / "p.csv", "-o", tmp_path / "pow.csv", "--x", "N", "--y", "v", "--space", "log")
    ref = sz.read_table(tmp_path / "pow.csv")
    f = sz.fit_power(x, yp, space="log")
    for i, name in enumerate(ref["parameter"]):
        assert f.params[name] == ref["value"][i] and f.std_errors[name] == ref["std_error"][i]


def test_laos_on_arrays_equals_the_command(tmp_path):
    t = np.arange(0, 8, 0.004)
    phi = 0.1 * np.sin(2 * np.pi * 1.0 * t)
    tau = 2e-3 * np.sin(2 * np.pi * t + 0.4) + 3e-4 * np.sin(3 * (2 * np.pi * t) + 0.2)
    with open(tmp_path / "log.csv", "w") as f:
        f.write("time_s,angle_rad,torque_N_m\n")
        for a, b, c in zip(t, phi, tau):
            f.write(f"{a!r},{b!r},{c!r}\n")
    cli("laos", tmp_path / "log.csv", "-o", tmp_path / "out", "--f-hz", 1)
    ref = sz.read_table(tmp_path / "out" / "summary.csv")
    r = sz.laos(t, phi, tau, f_hz=1)
    assert len(r["amplitudes"]) == len(ref) == 1
    a = r["amplitudes"][0]
    for name, col in (("x0", "phi0_rad"), ("K1p", "K1_prime_N_m_per_rad"), ("K1pp", "K1_dprime_N_m_per_rad"),
                      ("tan_delta", "tan_delta_1"), ("I3_over_I1", "I3_over_I1"), ("S", "S"), ("T", "T")):
        assert a[name] == ref[col][0], name
    # --spp: the same cycle measures and transient moduli as the command's files
    cli("laos", tmp_path / "log.csv", "-o", tmp_path / "spp", "--f-hz", 1, "--spp")
    s = sz.laos(t, phi, tau, f_hz=1, spp=True)["amplitudes"][0]["spp"]
    ref = sz.read_table(tmp_path / "spp" / "spp_summary.csv")
    assert s["M"] == ref["M_spp"][0]
    assert s["cage_modulus"]["status"] == ref["cage_stiffness_status"][0]
    assert s["cage_modulus"]["unchecked"] == ref["cage_stiffness_unchecked_N_m_per_rad"][0]
    pts = sz.read_table(tmp_path / "spp" / "spp_01.csv")
    np.testing.assert_array_equal(s["points"]["Gp"], pts["Kt_prime_N_m_per_rad"])
    assert len(s["cycles"]) == len(sz.read_table(tmp_path / "spp" / "spp_cycles.csv"))
    log = sz.read_log(tmp_path / "log.csv")
    assert log["format"] == "csv" and len(log["segments"]) == 1
    np.testing.assert_array_equal(log["segments"][0]["drive"], phi)


def test_errors_are_the_commands_messages_and_leave_nothing(beads, tmp_path):
    r = cli("piv", tmp_path / "none.png", beads / "pair" / "B.png", "-o", tmp_path / "x.csv", code=2)
    with pytest.raises(sz.MissingFileError) as e:
        sz.piv_video([tmp_path / "none.png", beads / "pair" / "B.png"], tmp_path / "x.csv")
    assert isinstance(e.value, FileNotFoundError)
    assert r.stderr.strip() == "shearzone: error: " + str(e.value)
    r = cli("piv", beads / "pair" / "A.png", beads / "pair" / "B.png", "-o", tmp_path / "x.csv", "--overlap", 2,
            code=2)
    frames = sz.synth_beads(width=64, height=64, diameter=12, u=1, v=0, seed=1)["frames"]
    with pytest.raises(sz.ConfigError) as e:
        sz.piv(frames[0], frames[1], overlap=2)
    assert "overlap = 2" in str(e.value) and r.stderr.strip() == "shearzone: error: " + str(e.value)
    with pytest.raises(sz.ConfigError, match="not-an-option"):
        sz.piv(frames[0], frames[1], not_an_option=1)
    with pytest.raises(sz.InputError, match="expected a 2-D"):
        sz.piv(frames[0][None], frames[1])
    with pytest.raises(sz.InputError, match="frames must match"):
        sz.piv(frames[0], frames[1][:32])
    with pytest.raises(ValueError):
        sz.fit_erf([1, 2, 3], [1, 2], loss="nonsense")

    # A callback that raises stops the work: its exception, and no output file.
    def stop(label, k, n):
        raise RuntimeError("stop here")
    with pytest.raises(RuntimeError, match="stop here"):
        sz.piv_video(str(beads / "clip" / "frame_*.png"), tmp_path / "stopped.h5", progress=stop)
    assert sorted(os.listdir(tmp_path)) == []


def test_the_docs_examples_run(tmp_path, monkeypatch):
    """docs/python.md's example blocks, as they stand, in order, in an empty folder with
    data-samples/ beside it."""
    text = (ROOT / "docs" / "python.md").read_text()
    blocks = [part.split("```", 1)[0] for part in text.split("```python\n")[1:]]
    assert len(blocks) == 2
    (tmp_path / "data-samples").symlink_to(ROOT / "data-samples")
    monkeypatch.chdir(tmp_path)
    for block in blocks:
        exec(compile(block, "docs/python.md", "exec"), {})
    assert (tmp_path / "fields.h5").exists() and (tmp_path / "profile.csv").exists()
    assert (tmp_path / "run" / "checkpoint.h5").exists() and (tmp_path / "scene.toml").exists()


def test_cmake_install_puts_it_where_python_finds_it(tmp_path):
    """`cmake --install BUILD --prefix P`: P/lib/python3.X/dist-packages/shearzone imports
    and runs (Debian's layout; /usr/local is on its path)."""
    build = os.environ["SHEARZONE_BUILD"]
    subprocess.run(["cmake", "--install", build, "--prefix", tmp_path], check=True, capture_output=True)
    found = list(tmp_path.glob("lib/python3.*/dist-packages/shearzone/_native*.so"))
    assert len(found) == 1
    env = dict(os.environ, PYTHONPATH=str(found[0].parent.parent))
    r = subprocess.run(["/usr/bin/python3", "-c", "import shearzone; print(shearzone.__file__, shearzone.__version__)"],
                       capture_output=True, text=True, env=env, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert r.stdout.startswith(str(tmp_path))


SCENE = {
    "sim": {"duration_s": 0.01, "time_step_s": 5e-4},
    "output": {"snapshot_every": 5, "checkpoint_every": 10},
    "box": {"min_m": [-0.03, -0.03, 0.0], "max_m": [0.03, 0.03, 0.1]},
    "beads": {"diameter_m": 0.01, "positions_m": [0, 0, 0.006, 0.0105, 0, 0.006, 0.021, 0, 0.006]},
    "chains": {"beads_per_chain": 3, "l_max_m": 0.001, "max_angle_deg": 60},
    "fill": {"count": 2, "min_m": [-0.025, -0.025, 0.03], "max_m": [0.025, 0.025, 0.09]},
}


def test_a_scene_built_in_python_runs_as_its_file(tmp_path):
    """Scene(...) writes the file the command reads back to the same keys; simulate() on
    it gives the command's state hash, and the checkpoint reads back as the same arrays."""
    scene = sz.Scene(**SCENE).check()
    scene.to_toml(tmp_path / "s.toml")
    assert sz.Scene.from_toml(tmp_path / "s.toml") == scene
    r = cli("sim", tmp_path / "s.toml", "-o", tmp_path / "cli")
    cli_hash = r.stdout.split("state hash ")[1].split()[0]
    sz.simulate(scene, tmp_path / "py")
    py, ref = sz.read_checkpoint(tmp_path / "py" / "checkpoint.h5"), sz.read_checkpoint(tmp_path / "cli" / "checkpoint.h5")
    assert py["state_hash"] == ref["state_hash"] == cli_hash
    assert py["position_m"].shape == (9, 3) and py["step"] == 20 and py["time_s"] == pytest.approx(0.01)
    for name in ("position_m", "velocity_m_per_s", "angular_velocity_rad_per_s", "orientation", "diameter_m",
                 "chain_id", "ropes", "kind"):
        np.testing.assert_array_equal(py[name], ref[name], err_msg=name)
    assert sorted(set(py["chain_id"])) == [0, 1, 2] and py["ropes"].shape == (6, 2)
    # The rules are the command's: a bad key is named, in the scene's terms.
    with pytest.raises(sz.ConfigError, match=r'unknown key "sim.time_stp_s"'):
        sz.Scene(sim={"time_stp_s": 1e-3}).check()
    with pytest.raises(sz.ConfigError, match=r'key "sim.duration_s": nan'):
        sz.Scene(sim={"duration_s": float("nan")}).check()
    with pytest.raises(sz.ConfigError, match=r'"sim.threads"'):
        sz.Scene(sim={"duration_s": 0.01, "threads": 0}).check()


def test_synth_namespace_and_field_masks(tmp_path):
    clip = sz.synth.beads(width=96, height=96, diameter=12, u=1, v=0, seed=2)
    assert len(clip["frames"]) == 2 and clip["frames"][0].shape == (96, 96)
    cli("synth", "beads", "-o", tmp_path / "c", "--width", 256, "--height", 256, "--diameter", 16, "--field",
        "rotation", "--frames", 3, "--vane", "4,6,60", "--seed", 1)
    fields = sz.piv_video(str(tmp_path / "c" / "frame_*.png"), tmp_path / "f.h5", vane=(4, 6, 60),
                          centre=(128, 128))
    f = fields[0]
    assert f["masked"].dtype == bool and f["masked"].shape == f["flag"].shape
    assert f["masked"].any() and not f["masked"].all()
    np.testing.assert_array_equal(f["masked"], f["flag"] == 2)


def test_the_notebook_runs_and_its_rc_is_the_commands(tmp_path, monkeypatch):
    """docs/notebooks/from_video_to_rc.ipynb top to bottom (Debian's nbclient and
    ipykernel), in an empty folder with data-samples/ beside it; its r_c equals the
    command's on the clip the notebook made."""
    import nbformat  # scripts/setup.sh installs python3-nbclient, python3-ipykernel
    from nbclient import NotebookClient
    nb = nbformat.read(ROOT / "docs" / "notebooks" / "from_video_to_rc.ipynb", as_version=4)
    (tmp_path / "data-samples").symlink_to(ROOT / "data-samples")
    monkeypatch.setenv("PYDEVD_DISABLE_FILE_VALIDATION", "1")  # the kernel's debugger note on stderr
    # The kernel imports the module this test imports, whatever the caller's PYTHONPATH.
    monkeypatch.setenv("PYTHONPATH", os.path.dirname(os.path.dirname(os.path.abspath(sz.__file__))))
    NotebookClient(nb, timeout=300, kernel_name="python3", resources={"metadata": {"path": str(tmp_path)}}).execute()
    outputs = [o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", [])]
    assert not [o for o in outputs if o.get("output_type") == "error"]
    assert sum(1 for o in outputs if "image/png" in o.get("data", {})) == 4  # the four figures, inline
    opts = ["--centre", "128,128", "--radii-px", "10,120", "--m-per-px", "1e-4", "--bin-px", "8"]
    cli("piv", tmp_path / "clip" / "frame_*.png", "-o", tmp_path / "cli.h5", "--centre", "128,128")
    cli("profile", tmp_path / "cli.h5", "-o", tmp_path / "cli.csv", *opts)
    cli("width", tmp_path / "cli.csv", "-o", tmp_path / "w_cli.csv", "--vc", 2e-3)
    ref, nb_w = sz.read_table(tmp_path / "w_cli.csv"), sz.read_table(tmp_path / "widths.csv")
    assert nb_w["rc_status"][0] == "ok"
    for name in ("rc_m", "rc_ci_low_m", "rc_ci_high_m"):
        assert nb_w[name][0] == ref[name][0], name
    text = "".join(o.get("text", "") for o in outputs)
    assert f"r_c = {ref['rc_m'][0] * 1e3:.3f} mm" in text


MEMORY_SCRIPT = """
import resource, sys
import numpy as np
import shearzone as sz

def rss_mb(key):
    for line in open("/proc/self/status"):
        if line.startswith(key):
            return int(line.split()[1]) / 1024.0

base = rss_mb("VmRSS:")
a, b = sz.read_image(sys.argv[1]), sz.read_image(sys.argv[2])
r = sz.piv(a, b)
print(base, rss_mb("VmHWM:"), (a.nbytes + b.nbytes) / 2**20, float(np.nanmean(r.u_px)))
"""


def test_piv_of_a_1080p_pair_from_arrays_costs_no_more_memory_than_the_command(tmp_path):
    """Peak resident memory of piv on two 1920x1080 arrays, above the interpreter with
    the module imported, is at most the command's own peak on the same pair plus the
    two arrays (both measured here: /proc's VmHWM and wait4's ru_maxrss)."""
    cli("synth", "beads", "-o", tmp_path / "hd", "--width", 1920, "--height", 1080, "--diameter", 30, "--u", 2.5,
        "--v", 1, "--seed", 9)
    a, b = tmp_path / "hd" / "A.png", tmp_path / "hd" / "B.png"
    p = subprocess.Popen([CLI, "piv", a, b, "-o", tmp_path / "v.csv"], stdout=subprocess.DEVNULL)
    _, status, usage = os.wait4(p.pid, 0)
    assert os.waitstatus_to_exitcode(status) == 0
    cli_mb = usage.ru_maxrss / 1024.0
    r = subprocess.run(["/usr/bin/python3", "-c", MEMORY_SCRIPT, a, b], capture_output=True, text=True, check=True)
    base, peak, arrays, u = map(float, r.stdout.split())
    assert abs(u - 2.5) < 0.1
    print(f"python: {peak - base:.0f} MB above {base:.0f} MB; the command: {cli_mb:.0f} MB; arrays {arrays:.1f} MB")
    assert peak - base <= cli_mb + arrays


def test_collapse_on_arrays_equals_the_command(tmp_path):
    table = ROOT / "data-samples" / "widths" / "rc_phi0_synthetic.csv"
    cli("collapse", "erf", table, "-o", tmp_path / "cli", "--x", "phi0_rad", "--y", "rc_m", "--sigma", "rc_se_m",
        "--group", "N")
    t = sz.read_table(table)
    arrays = sz.collapse_erf(phi0=t["phi0_rad"], rc=t["rc_m"], N=t["N"], sigma=t["rc_se_m"])
    from_table = sz.collapse_erf(table, x="phi0_rad", y="rc_m", sigma="rc_se_m", group="N")
    for name in ("parameters", "collapsed", "master"):
        ref = sz.read_table(tmp_path / "cli" / f"{name}.csv")
        for result in (arrays, from_table):
            assert set(result[name].keys()) == set(ref.keys())
            for col in ref.keys():
                np.testing.assert_array_equal(result[name][col], ref[col], err_msg=f"{name}.{col}")
    with pytest.raises(sz.InputError, match="expected the same count"):
        sz.collapse_erf(phi0=[0.1, 0.2], rc=[1.0], N=[1, 1])


def test_long_work_releases_the_gil():
    """Another Python thread runs while piv works on a 1080p pair (the GIL is released):
    it counts thousands of loops, where a held GIL would let it run only at the end."""
    import threading
    a, b = sz.synth.beads(width=1920, height=1080, diameter=30, u=2.5, v=1, seed=9)["frames"]
    done, count = threading.Event(), [0]

    def work():
        sz.piv(a, b)
        done.set()

    t = threading.Thread(target=work)
    t.start()
    while not done.is_set():
        count[0] += 1
    t.join()
    assert count[0] > 10000, count[0]


CTRL_C_SCRIPT = """
import os, sys
import shearzone as sz
out = sys.argv[2]
def progress(label, done, total):
    if done == 1:
        print("started", flush=True)
try:
    sz.piv_video(sys.argv[1], out, progress=progress)
    print("finished")
except KeyboardInterrupt:
    print("interrupted", os.path.exists(out), sorted(os.listdir(os.path.dirname(out))))
"""


def test_ctrl_c_stops_a_long_call_and_leaves_no_output(tmp_path):
    """SIGINT during piv_video: a KeyboardInterrupt in Python, no fields.h5 and no
    partial file left in its folder."""
    import signal
    cli("synth", "beads", "-o", tmp_path / "clip", "--width", 640, "--height", 480, "--diameter", 20, "--u", 1.5,
        "--frames", 60, "--seed", 2)
    (tmp_path / "out").mkdir()
    p = subprocess.Popen(["/usr/bin/python3", "-c", CTRL_C_SCRIPT, str(tmp_path / "clip" / "frame_*.png"),
                          str(tmp_path / "out" / "fields.h5")], stdout=subprocess.PIPE, text=True)
    assert p.stdout.readline().strip() == "started"
    p.send_signal(signal.SIGINT)
    rest, _ = p.communicate(timeout=60)
    assert rest.strip() == "interrupted False []", rest
