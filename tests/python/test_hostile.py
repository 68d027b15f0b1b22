"""The hostile-input replay (scripts/hostile.py) through Python: every case run in this
process by the module, against the command on the same input. Each refused case raises
the exception class of its exit code (1 and 2: ConfigError or InputError, both
ValueErrors; 3: NoResultError) with exactly the command's one-line message, and leaves
no output; the accepted damaged video raises nothing. Then the classes of bad input
only Python has: arrays of the wrong shape, type, layout or values, mismatched lengths,
scene values of the wrong type."""
import importlib.util
import os
import re
import shutil
import subprocess
import sys

import numpy as np
import pytest

import shearzone as sz

CLI = os.environ["SHEARZONE_CLI"]
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
spec = importlib.util.spec_from_file_location("hostile", os.path.join(ROOT, "scripts", "hostile.py"))
hostile = importlib.util.module_from_spec(spec)
spec.loader.exec_module(hostile)

WORK = None


@pytest.fixture(scope="module")
def work(tmp_path_factory):
    d = tmp_path_factory.mktemp("hostile")
    hostile.make_inputs(CLI, str(d))
    return d


CASES = hostile.cases("WORK")
EXCEPTION_OF_CODE = {1: (sz.ConfigError,), 2: (sz.ConfigError, sz.InputError), 3: (sz.NoResultError,)}
OUTPUTS = ("o", "run", "lo", "co", "so", "f.h5", "v.csv", "p.csv", "fits.csv", "w.csv", "ff.csv")


def clean(work):
    for p in OUTPUTS:
        path = work / p
        if path.is_dir():
            shutil.rmtree(path)
        elif path.exists():
            path.unlink()
    for p in os.listdir(work):
        if p.startswith(("p_", "fits_", "ff_")):
            os.remove(work / p)


@pytest.mark.parametrize("name,argv,want,absent,pattern", CASES, ids=[c[0] for c in CASES])
def test_hostile_case_in_python(work, monkeypatch, name, argv, want, absent, pattern):
    argv = [a.replace("WORK", str(work)) for a in argv]
    monkeypatch.chdir(work)
    clean(work)
    r = subprocess.run([CLI, *argv], capture_output=True, text=True, cwd=work, timeout=120)
    assert r.returncode == want, r.stderr
    clean(work)
    if want == 0:
        assert sz._native.run(argv, None) == 0
        return
    with pytest.raises(EXCEPTION_OF_CODE[want]) as e:
        code = sz._native.run(argv, None)
        if code == 3:  # (no exception class reached the binding: the code alone)
            raise sz.NoResultError(f"exit {code}")
    assert isinstance(e.value, ValueError) == (want in (1, 2))
    message = str(e.value)
    assert "\n" not in message
    # (a flag the parser refuses: the command adds where its usage is; Python has help())
    usage = " (run with --help for usage)" if want == 1 else ""
    assert r.stderr.strip() == "shearzone: error: " + message + usage
    if pattern:
        assert re.search(pattern, r.stderr)
    for p in absent or []:
        assert not (work / p).exists(), f"{p} left behind"


def frames(n=64):
    return sz.synth.beads(width=n, height=n, diameter=12, u=1, v=0, seed=1)["frames"]


def test_arrays_python_alone_can_give_are_refused(tmp_path, monkeypatch):
    """Ten classes of bad arrays and values, each one exception naming the argument and
    what was expected; no file is written anywhere."""
    monkeypatch.chdir(tmp_path)
    a, b = frames()
    cases = [
        (lambda: sz.piv(a[None], b), sz.InputError, r"3-D array; expected a 2-D grey image"),
        (lambda: sz.piv(a, b[:, :32]), sz.InputError, r"frames must match"),
        (lambda: sz.piv(a.astype(np.int32), b.astype(np.int32)), sz.InputError,
         r"dtype int32; expected uint8, uint16 or float32"),
        (lambda: sz.piv(np.full(a.shape, np.nan, np.float32), b.astype(np.float32) / 255), sz.InputError,
         r"NaN|not finite|0\.\.1"),
        (lambda: sz.piv(a.astype(np.float32) * 2, b.astype(np.float32)), sz.InputError, r"0\.\.1"),
        (lambda: sz.piv(np.zeros((0, 0), np.uint8), np.zeros((0, 0), np.uint8)), sz.InputError, r"empty|0 x 0|size"),
        (lambda: sz.piv(a, b, windows="abc"), sz.ConfigError, r"windows"),
        (lambda: sz.piv(a, b, overlap=True), sz.ConfigError, r"--overlap: 1 required FLOAT missing"),
        (lambda: sz.fit_erf([0.1, 0.2, 0.3], [1, 2], sigma=None), sz.InputError,
         r"^x and y: 3 and 2 values; expected as many of each$"),
        (lambda: sz.fit_erf([0.1, np.nan, 0.3, 0.4, 0.5], [1, 2, 3, 4, 5]), sz.InputError,
         r"^x\[1\] = nan: not a finite number$"),
        (lambda: sz.fit_power([1, 2, 3], [1, 2, 3], [0.1, 0.0, 0.1]), sz.InputError,
         r"^sigma\[1\] = 0: not a positive uncertainty$"),
        (lambda: sz.laos(None, np.zeros(10), np.full(10, np.inf), f_hz=1), sz.InputError,
         r"^torque\[0\] = inf: not a finite number$"),
        (lambda: sz.laos(np.arange(10.0), np.zeros(9), np.zeros(10), f_hz=1), sz.InputError,
         r"^t, angle and torque: 10, 9 and 10 values; expected as many of each$"),
        (lambda: sz.Scene(sim={"duration_s": "0.1"}).check(), sz.ConfigError, r'"sim.duration_s": \'0.1\': expected a finite number'),
        (lambda: sz.Scene(sim={"threads": 1.5}).check(), sz.ConfigError, r'"sim.threads": 1.5: expected a whole number'),
        (lambda: sz.Scene(boxes={}).check(), sz.ConfigError, r'unknown section "boxes"'),
        (lambda: sz.read_checkpoint(tmp_path / "none.h5"), sz.MissingFileError, r"no such file"),
        (lambda: sz.read_fields(tmp_path / "none.h5"), sz.MissingFileError, r"no such file"),
    ]
    for call, cls, pattern in cases:
        with pytest.raises(cls) as e:
            call()
        assert re.search(pattern, str(e.value)), (pattern, str(e.value))
        assert "\n" not in str(e.value)
    assert os.listdir(tmp_path) == []


def test_crops_and_float64_frames_are_copied_not_refused():
    """A crop (a strided view) and float64 frames give the numbers of their C-order
    uint8 and float32 copies."""
    a, b = sz.synth.beads(width=160, height=128, diameter=14, u=1.2, v=0.4, seed=6)["frames"]
    view = (slice(8, 120), slice(16, 144))
    r = sz.piv(a[view], b[view])
    ref = sz.piv(a[view].copy(), b[view].copy())
    np.testing.assert_array_equal(r.u_px, ref.u_px)
    np.testing.assert_array_equal(r.v_px, ref.v_px)
    f64 = sz.piv(a / 255.0, b / 255.0)
    f32 = sz.piv((a / 255.0).astype(np.float32), (b / 255.0).astype(np.float32))
    np.testing.assert_array_equal(f64.u_px, f32.u_px)
