"""`pip install --no-build-isolation .` into a fresh venv, offline (--no-index): the
module builds from the repository with CMake and Debian's packages, imports from the
venv and gives the command's numbers. Slow (a Release build of the library): ctest label
`slow` (`scripts/test.sh --all`)."""
import os
import shutil
import subprocess
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
CLI = os.environ["SHEARZONE_CLI"]


def copy_sources(dst: Path) -> None:
    """The repository's tracked files (a checkout) or its tree less build outputs."""
    if (ROOT / ".git").exists():
        files = subprocess.run(["git", "-C", ROOT, "ls-files", "-z"], check=True, capture_output=True).stdout
        for name in filter(None, files.decode().split("\0")):
            (dst / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(ROOT / name, dst / name)
    else:
        shutil.copytree(ROOT, dst, ignore=shutil.ignore_patterns("build", "demo-output", "out"), dirs_exist_ok=True)


def test_pip_install_into_a_fresh_venv_offline(tmp_path):
    src, venv = tmp_path / "src", tmp_path / "venv"
    copy_sources(src)
    # numpy comes from Debian (python3-numpy): the venv sees the system's packages.
    subprocess.run(["/usr/bin/python3", "-m", "venv", "--system-site-packages", venv], check=True)
    env = dict(os.environ, PIP_NO_INDEX="1", PIP_DISABLE_PIP_VERSION_CHECK="1", CMAKE_BUILD_PARALLEL_LEVEL="2")
    env.pop("PYTHONPATH", None)
    r = subprocess.run([venv / "bin" / "pip", "install", "--no-build-isolation", "--no-index", src],
                       capture_output=True, text=True, env=env, cwd=tmp_path)
    assert r.returncode == 0, r.stdout[-4000:] + r.stderr[-4000:]
    script = ("import shearzone as sz, numpy as np, sys\n"
              "c = sz.synth.beads(width=128, height=128, diameter=16, u=1.5, v=0.5, seed=4)\n"
              "r = sz.piv(*c['frames'])\n"
              "np.save(sys.argv[1], np.stack([r.u_px, r.v_px]))\n"
              "print(sz.__file__)\n")
    r = subprocess.run([venv / "bin" / "python", "-c", script, tmp_path / "uv.npy"], capture_output=True, text=True,
                       env=env, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip().startswith(str(venv)), r.stdout
    # The same numbers as the command on the same frames.
    subprocess.run([CLI, "synth", "beads", "-o", tmp_path / "pair", "--width", "128", "--height", "128",
                    "--diameter", "16", "--u", "1.5", "--v", "0.5", "--seed", "4"], check=True, capture_output=True)
    subprocess.run([CLI, "piv", tmp_path / "pair" / "A.png", tmp_path / "pair" / "B.png", "-o", tmp_path / "v.csv"],
                   check=True, capture_output=True)
    rows = [line.split(",") for line in (tmp_path / "v.csv").read_text().splitlines() if not line.startswith("#")]
    names = rows[0]
    u = np.array([float(r[names.index("u_px")]) for r in rows[1:]], dtype=np.float32)
    v = np.array([float(r[names.index("v_px")]) for r in rows[1:]], dtype=np.float32)
    uv = np.load(tmp_path / "uv.npy")
    np.testing.assert_array_equal(uv[0].ravel(), u)
    np.testing.assert_array_equal(uv[1].ravel(), v)
