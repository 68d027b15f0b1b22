"""shearzone from Python: PIV, profiles, r_c, fits, LAOS and the simulator on numpy
arrays and files, with the same numbers as the ``shearzone`` command.

Every keyword option is the command's flag of the same name, with ``_`` for ``-``
(``min_peak_relative=0.3`` is ``--min-peak-relative 0.3``, ``f_hz=1`` is ``--f-hz 1``,
``N=4`` is ``--N 4``), in the flag's unit, and is checked as the command checks it:
``shearzone <command> --help`` lists them with their units and ranges, and
docs/python.md shows the calls. A list or tuple is the flag's comma-separated values
(``windows=(64, 32, 16)``, ``centre=(320, 240)``); a dict is a repeated KEY=VALUE flag
(``attr={"m_per_px": 1e-4}``); ``True`` gives a flag, ``False`` or ``None`` leaves it out.

Errors are exceptions carrying the command's one-line message: ``InputError`` (bad
data; ``MissingFileError`` for a file that is not there, also a FileNotFoundError),
``ConfigError`` (bad options; both are ValueErrors), ``NoResultError``. Long work
releases the GIL, reports to ``progress(label, done, total)`` when given, and stops at
Ctrl-C (KeyboardInterrupt) leaving no output file behind.
"""
from __future__ import annotations

import math
import os
import tempfile
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterable, Mapping, Optional, Sequence, Union

import numpy as np

from . import _native
from ._errors import (ConfigError, InputError, InternalError, MissingFileError, NoResultError,
                      NoResultWarning, ShearzoneError)

__version__ = _native.version
__all__ = [
    "piv", "piv_video", "read_image", "read_fields", "Fields", "profile", "width", "fit_erf", "fit_power",
    "collapse_erf", "laos", "laos_logs", "read_log", "read_table", "Table", "Scene", "simulate",
    "read_checkpoint", "sim_render", "synth", "synth_beads", "synth_particles", "run", "InputError", "MissingFileError", "ConfigError",
    "NoResultError", "NoResultWarning", "InternalError", "ShearzoneError",
]

Progress = Optional[Callable[[str, int, int], None]]
PathLike = Union[str, os.PathLike]


def _number(v: Any) -> str:
    if isinstance(v, (bool, np.bool_)):
        raise ConfigError(f"{v!r}: a flag takes True or False, a value option a number or text")
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, (float, np.floating)):
        return repr(float(v))  # the shortest text that reads back as the same double
    return str(v)


def _words(options: Mapping[str, Any]) -> list:
    """Keywords as the command's words: name -> --name-with-hyphens."""
    words = []
    for key, value in options.items():
        flag = "--" + key.replace("_", "-")
        if value is None or value is False:
            continue
        if value is True:
            words.append(flag)
        elif isinstance(value, Mapping):
            for k, v in value.items():
                words += [flag, f"{k}={_number(v)}"]
        elif isinstance(value, (list, tuple, np.ndarray)):
            words += [flag, ",".join(_number(v) for v in value)]
        else:
            words += [flag, _number(value)]
    return words


def _run(command: str, args: Sequence[Any], progress: Progress, options: Mapping[str, Any]) -> int:
    words = command.split() + [os.fspath(a) if isinstance(a, os.PathLike) else str(a) for a in args]
    return _native.run(words + _words(options), progress)


def run(command: str, *args: Any, progress: Progress = None, **options: Any) -> None:
    """Runs ``shearzone COMMAND ARGS --OPTIONS`` in this process, exactly as the command
    line does (quiet): e.g. ``run("sim check", "run/", output="check/", size=(640, 360))``.
    Raises the command's error as an exception; returns nothing (the outputs are files)."""
    code = _run(command, args, progress, options)
    if code == 3:
        raise NoResultError(f"shearzone {command}: no usable result (exit code 3)")
    if code != 0:
        raise InternalError(f"shearzone {command}: exit code {code}")


# ---------------------------------------------------------------------------- tables


@dataclass
class Table:
    """A CSV output of the toolkit: ``columns`` (name -> numpy array: float where every
    cell is a number or empty, NaN for empty; else str), ``header`` (the ``# key: value``
    lines, in order) and ``path``. ``table["rc_m"]`` is a column; ``to_pandas()`` a
    DataFrame when pandas is installed."""

    columns: dict
    header: dict
    path: Optional[str] = None

    def __getitem__(self, name: str) -> np.ndarray:
        return self.columns[name]

    def __len__(self) -> int:
        return len(next(iter(self.columns.values()))) if self.columns else 0

    def keys(self):
        return self.columns.keys()

    def to_pandas(self):
        import pandas  # optional: only this method needs it
        return pandas.DataFrame(self.columns)


def _column(cells: list) -> np.ndarray:
    try:
        return np.array([float(c) if c != "" else math.nan for c in cells], dtype=float)
    except ValueError:
        return np.array(cells, dtype=object)


def read_table(path: PathLike) -> Table:
    """Reads a CSV written by the toolkit (``#`` header lines, then one header row)."""
    import csv
    header, rows, names = {}, [], None
    with open(path, newline="", encoding="utf-8") as f:
        for line in f:
            if names is None and line.startswith("#"):
                key, _, value = line[1:].strip().partition(":")
                header[key.strip()] = value.strip()
                continue
            if names is None:
                names = next(csv.reader([line]))
                continue
            if line.strip():
                rows.append(next(csv.reader([line])))
    if names is None:
        raise InputError(f"{os.fspath(path)}: no header row; expected a CSV table")
    cols = {n: _column([r[i] if i < len(r) else "" for r in rows]) for i, n in enumerate(names)}
    return Table(cols, header, os.fspath(path))


class _Output:
    """The output path given, or one in a temporary folder removed afterwards."""

    def __init__(self, output: Optional[PathLike], name: str):
        self._tmp = None if output is not None else tempfile.TemporaryDirectory(prefix="shearzone-")
        self.path = os.fspath(output) if output is not None else os.path.join(self._tmp.name, name)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        if self._tmp is not None:
            self._tmp.cleanup()


# ---------------------------------------------------------------------------- PIV


@dataclass
class PivResult:
    """One pair's vectors on the grid, arrays of shape (rows, columns): x_px, y_px (grid
    coordinates, px, image convention: x right, y down), u_px, v_px (displacement from
    frame a to frame b, px per pair), flag (0 valid, 1 replaced, 2 masked, 3 invalid),
    peak, peak_ratio; dt_s, the header the command writes (options, windows and
    conventions, in order) and the windows used."""

    x_px: np.ndarray
    y_px: np.ndarray
    u_px: np.ndarray
    v_px: np.ndarray
    flag: np.ndarray
    peak: np.ndarray
    peak_ratio: np.ndarray
    dt_s: float
    header: dict
    windows_px: list = field(default_factory=list)
    texture_size_px: float = math.nan

    FLAGS = {0: "valid", 1: "replaced", 2: "masked", 3: "invalid"}

    @property
    def valid(self) -> np.ndarray:
        """True where the vector is measured and passed validation."""
        return self.flag == 0


def _frame(a: Any) -> Any:
    """A frame as the native side takes it: float64 as float32, C order (no copy when it is)."""
    if isinstance(a, np.ndarray):
        if a.dtype == np.float64:
            a = a.astype(np.float32)
        return np.ascontiguousarray(a)
    return a


def piv(frame_a: np.ndarray, frame_b: np.ndarray, *, progress: Progress = None, **options: Any) -> PivResult:
    """PIV (or ``method="track"``) of one pair of grey frames held as 2-D arrays:
    uint8, uint16, or float (grey levels 0..1). C-contiguous uint8, uint16 and float32
    arrays are used without a copy; a crop or other strided view, and float64, are
    copied first (to C order, float32). Options are those of ``shearzone piv`` (windows,
    overlap, preset, centre, annulus, vane, f_hz, phi0_rad, mask_image, method,
    bead_diameter_px, ...; docs/piv.md); ``fps`` (Hz) times the pair (dt = 1/fps). The
    numbers equal the command's on the same images."""
    out = _native.piv_frames([_frame(frame_a), _frame(frame_b)], _words(options), progress)
    p = out["pairs"][0]
    return PivResult(p["x_px"], p["y_px"], p["u_px"], p["v_px"], p["flag"], p["peak"], p["peak_ratio"],
                     p["dt_s"], dict(out["header"]), list(out["windows_px"]), out["texture_size_px"])


def piv_video(inputs: Union[PathLike, Sequence[PathLike]], output: PathLike, *, progress: Progress = None,
              **options: Any) -> "Fields":
    """``shearzone piv INPUTS -o OUTPUT``: a video, an image glob or a list of images to
    fields.h5 (or one pair to .csv), streamed; returns the fields read back lazily.
    ``progress(label, done, total)`` is called as pairs finish."""
    ins = [inputs] if isinstance(inputs, (str, os.PathLike)) else list(inputs)
    run("piv", *ins, progress=progress, output=os.fspath(output), **options)
    return read_fields(output, **({"dt_s": 1.0 / options["fps"]} if "fps" in options else {}))


class Fields:
    """The fields of ``piv`` read pair by pair (nothing loaded until asked):
    ``len(fields)`` pairs, ``fields[k]`` a dict of arrays (as PivResult's, plus t_a_s and
    dt_s in s, and ``masked``: True where the mask (vane, cup, mask image) hid the node), ``fields.attr(name)`` a root attribute (number, text or None), ``fields.header``
    the options the fields were made with."""

    def __init__(self, path: PathLike, dt_s: float = 0.04):
        self.path = os.fspath(path)
        self._f = _native.Fields(self.path, float(dt_s))

    def __len__(self) -> int:
        return len(self._f)

    def __getitem__(self, k: int) -> dict:
        if k < 0:
            k += len(self)
        d = self._f.pair(k)
        d["masked"] = d["flag"] == 2  # the vane, the cup wall, a mask image: no vector there
        return d

    def __iter__(self):
        for k in range(len(self)):
            yield self[k]

    def attr(self, name: str):
        return self._f.attribute(name)

    @property
    def header(self) -> dict:
        text = self.attr("options") or ""
        return dict(line.split(": ", 1) for line in str(text).splitlines() if ": " in line)


def read_image(path: PathLike, grey: str = "luma") -> np.ndarray:
    """An image file as the command reads it: a 2-D grey array (uint8, or uint16 for a
    16-bit file); ``grey`` is piv's ``--grey`` conversion of colour (luma, mean, green, ...)."""
    return _native.read_image(os.fspath(path), grey)


def read_fields(path: PathLike, dt_s: float = 0.04) -> Fields:
    """Opens fields.h5 (or a one-pair CSV, timed ``dt_s``) for reading pair by pair."""
    return Fields(path, dt_s)


# ---------------------------------------------------------------------------- profiles


def profile(fields: PathLike, output: Optional[PathLike] = None, *, progress: Progress = None,
            **options: Any) -> Table:
    """``shearzone profile FIELDS -o OUTPUT``: v(r) about the cup axis (mean |v|,
    lock-in, phase bins; docs/profile-width.md). Options as the command's (centre,
    radii_px, m_per_px, bead_diameter_m, f_hz, groups, noise_ref, ...). Without
    ``output`` the CSVs go to a temporary folder. Returns the profile table (its
    columns carry their units: r_m, v_m_per_s, ...)."""
    with _Output(output, "profile.csv") as out:
        run("profile", os.fspath(fields), progress=progress, output=out.path, **options)
        return read_table(out.path)


def width(profiles: Union[PathLike, Sequence[PathLike]], output: Optional[PathLike] = None, **options: Any) -> Table:
    """``shearzone width PROFILES -o OUTPUT``: r_c of each profile at ``vc`` (m/s), its
    bootstrap interval and status. Returns the widths table (rc_m, ci_low_m, ...,
    status). Where no profile gives a usable r_c (the command's exit code 3) the table
    still comes back, r_c empty (NaN) and the status saying why, with a NoResultWarning."""
    ins = [profiles] if isinstance(profiles, (str, os.PathLike)) else list(profiles)
    with _Output(output, "widths.csv") as out:
        try:
            _run("width", ins, None, dict(options, output=out.path))
        except NoResultError as e:  # the command's exit 3: the table is written, each row's status says why
            if not os.path.exists(out.path):
                raise
            warnings.warn(str(e), NoResultWarning, stacklevel=2)
        return read_table(out.path)


# ---------------------------------------------------------------------------- fits


@dataclass
class Fit:
    """A least-squares fit: ``params`` (name -> value), ``std_errors``, ``ci`` (name ->
    (low, high) at ``confidence``), ``bootstrap_ci`` (NaN without bootstrap), ``status``
    ("ok" or why not), ``message`` and the rest of the solver's report in ``report``
    (chi2, reduced_chi2, aic, bic, covariance, correlation, fitted, residuals, ...)."""

    status: str
    message: str
    params: dict
    std_errors: dict
    ci: dict
    bootstrap_ci: dict
    report: dict

    @property
    def ok(self) -> bool:
        return self.status == "ok"


def _fit(d: dict) -> Fit:
    names = d["names"]
    return Fit(d["status"], d["message"], dict(zip(names, d["values"])), dict(zip(names, d["std_errors"])),
               {n: (lo, hi) for n, lo, hi in zip(names, d["ci_low"], d["ci_high"])},
               {n: (lo, hi) for n, lo, hi in zip(names, d["boot_low"], d["boot_high"])}, d)


def _arrays(x, y, sigma):
    x = np.asarray(x, dtype=float).ravel()
    y = np.asarray(y, dtype=float).ravel()
    s = np.asarray(sigma, dtype=float).ravel() if sigma is not None else np.empty(0)
    return x, y, s


def fit_erf(x, y, sigma=None, **options: Any) -> Fit:
    """The erf transition r(x) = rc0 + (rcinf - rc0) (1 + erf((x - phi_c)/W))/2 fitted
    to arrays (``shearzone fit erf``: options loss, loss_scale, bootstrap, seed,
    confidence, absolute_sigma). Parameters rc0, rcinf, phi_c, W in the data's units."""
    return _fit(_native.fit_arrays("erf", *_arrays(x, y, sigma), _words(options)))


def fit_power(x, y, sigma=None, **options: Any) -> Fit:
    """The power law y = A x^k fitted to arrays (``shearzone fit power``: space="linear"
    or "log", subtract_at, and the options of fit_erf). Parameters A, k."""
    d = _native.fit_arrays("power", *_arrays(x, y, sigma), _words(options))
    f = _fit(d)
    if "y0" in d:
        f.report["y0"] = d["y0"]
    return f


def collapse_erf(table: Any = None, *, phi0=None, rc=None, N=None, sigma=None, output: Optional[PathLike] = None,
                 **options: Any) -> dict:
    """``shearzone collapse erf TABLE -o OUTPUT``: each N's r_c(phi0) rescaled by its own
    erf fit, then all N fitted at once with W = W0 (N/N_ref)^-alpha (docs/fit.md).
    Either a CSV ``table`` with the columns named by ``x``, ``y``, ``group`` and
    ``sigma`` (the command's options: column names), or arrays: ``phi0`` (rad), ``rc`` (m), ``N`` and
    optionally ``sigma`` (m), written exactly (shortest round-trip text) to a table the
    command reads. Other options: group_rtol, absolute_sigma, loss, loss_scale,
    bootstrap, seed. Returns ``{"parameters", "collapsed", "master"}``, the three tables
    of the output folder (a temporary one unless ``output`` is given)."""
    with _Output(output, "collapse") as out, tempfile.TemporaryDirectory(prefix="shearzone-") as tmp:
        if table is None:
            if phi0 is None or rc is None or N is None:
                raise ConfigError("collapse_erf: give a table, or the arrays phi0, rc and N (and sigma)")
            cols = {"phi0_rad": phi0, "rc_m": rc, "N": N}
            if sigma is not None:
                cols["rc_se_m"] = sigma
            cols = {k: np.asarray(v, dtype=float).ravel() for k, v in cols.items()}
            if len({len(v) for v in cols.values()}) != 1:
                raise InputError("collapse_erf: phi0, rc, N" + (", sigma" if sigma is not None else "") +
                                 f" have {', '.join(str(len(v)) for v in cols.values())} values; expected the same count")
            table = os.path.join(tmp, "rc_phi0.csv")
            with open(table, "w", encoding="utf-8") as f:
                f.write(",".join(cols) + "\n")
                for row in zip(*cols.values()):
                    f.write(",".join(repr(float(v)) for v in row) + "\n")
            options = dict(options, x="phi0_rad", y="rc_m", group="N", sigma="rc_se_m" if sigma is not None else None)
        elif sigma is not None:  # a table's sigma column, by name
            options = dict(options, sigma=sigma)
        run("collapse erf", os.fspath(table), output=out.path, **options)
        return {name: read_table(os.path.join(out.path, name + ".csv")) for name in ("parameters", "collapsed", "master")}


# ---------------------------------------------------------------------------- LAOS


def laos(t, angle, torque, **options: Any) -> dict:
    """LAOS of one record held as arrays: time (s; ``None`` for an angle-sampled record),
    drive (angle in rad, or strain) and response (torque in N m, or stress in Pa).
    Options are those of ``shearzone laos`` (f_hz, inertia_kg_m2, stress_constant and
    strain_constant, max_harmonic, cycles, no_drift, no_split, ...). Returns
    ``{"amplitudes": [...], "skipped_blocks": n}``: per amplitude x0, K1p, K1pp,
    tan_delta, I3_over_I1, the Chebyshev e and v, S, T, the harmonics Kp/Kpp with
    their SEs, the cycles and the Lissajous samples of the cycles used; with
    ``spp=True`` also ``"spp"``: M, the cage modulus and the static and dynamic yield
    (value, unchecked, noise_sd, truncation_change, status), the same per used cycle,
    and per sample theta, x, rate, r, Gp, Gp_se, Gpp, Gpp_se, delta, dGp_dtheta,
    dGpp_dtheta, r_d, x_eq (docs/laos.md, "Within the cycle")."""
    ts = np.asarray(t, dtype=float).ravel() if t is not None else np.empty(0)
    return _native.laos_arrays(ts, np.asarray(angle, dtype=float).ravel(), np.asarray(torque, dtype=float).ravel(),
                               _words(options))


def laos_logs(logs: Union[PathLike, Sequence[PathLike]], output: PathLike, **options: Any) -> Table:
    """``shearzone laos LOGS -o OUTPUT``: every log (any supported vendor export) to the
    folder's summary.csv, cycles.csv, harmonics.csv and lissajous_NN.csv; returns the
    summary table."""
    ins = [logs] if isinstance(logs, (str, os.PathLike)) else list(logs)
    run("laos", *ins, output=os.fspath(output), **options)
    return read_table(os.path.join(os.fspath(output), "summary.csv"))


def read_log(path: PathLike, **options: Any) -> dict:
    """Reads a rheometer export as ``laos`` reads it (what ``laos --inspect`` shows, as
    data): format, quantity, parameters, its segments (time_s, drive, response arrays in
    s, rad or strain, N m or Pa; the instrument's own values) and the skipped blocks.
    Options: format, time_col, angle_col, torque_col, interval_col, the units."""
    return _native.read_log(os.fspath(path), _words(options))


# ---------------------------------------------------------------------------- synth, sim


def _synth(kind: str, output: Optional[PathLike], options: Mapping[str, Any]) -> dict:
    with _Output(output, "synth") as out:
        run("synth " + kind, output=out.path, **options)
        d = Path(out.path)
        names = sorted(p for p in d.iterdir() if p.suffix in (".png", ".tif", ".tiff"))
        result = {"frames": [_native.read_image(os.fspath(p)) for p in names],
                  "truth": read_table(d / "truth.csv"), "times": read_table(d / "frames.csv")}
        videos = [p for p in d.iterdir() if p.suffix in (".mp4", ".avi")]
        if videos and output is not None:
            result["video"] = os.fspath(videos[0])
        return result


def synth_beads(output: Optional[PathLike] = None, **options: Any) -> dict:
    """``shearzone synth beads``: shaded beads moved by a known field (options width,
    height, diameter, u, v, field, omega, frames, seed, ...). Returns ``frames`` (arrays
    as the command's images), ``truth`` (the exact displacement table) and ``times``."""
    return _synth("beads", output, options)


def synth_particles(output: Optional[PathLike] = None, **options: Any) -> dict:
    """``shearzone synth particles``: Gaussian tracer particles (as synth_beads)."""
    return _synth("particles", output, options)


class Scene:
    """A simulator scene as values: ``sections`` maps each section of the scene file
    (sim, output, box, cylinder, beads, chains, fill, vane, camera, protocol;
    docs/sim.md) to its keys, in the keys' units (``duration_s`` in s, ``diameter_m``
    in m, ``max_angle_deg`` in degrees, positions as flat lists x0, y0, z0, x1, ...).
    ``Scene(sim={"duration_s": 0.1, "time_step_s": 5e-4}, box={...})`` builds one,
    ``Scene.from_toml(path)`` reads a file (what the file sets, nothing more).
    ``check()`` applies the rules ``shearzone sim`` applies (ConfigError naming the key),
    ``to_toml()`` gives the file the command reads back to the same values."""

    def __init__(self, **sections: Mapping[str, Any]):
        self.sections = {name: dict(keys) for name, keys in sections.items()}

    @classmethod
    def from_toml(cls, path: PathLike) -> "Scene":
        return cls(**_native.scene_from_toml(os.fspath(path)))

    def __getitem__(self, section: str) -> dict:
        return self.sections.setdefault(section, {})

    def __repr__(self) -> str:
        return f"Scene({', '.join(f'{k}={v!r}' for k, v in self.sections.items())})"

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Scene) and self.sections == other.sections

    def to_toml(self, path: Optional[PathLike] = None, comment: str = "") -> str:
        """The scene file's text (numbers in their shortest exact form); written to
        ``path`` when given."""
        text = _native.scene_to_toml(self.sections, comment)
        if path is not None:
            Path(path).write_text(text, encoding="utf-8")
        return text

    def check(self) -> "Scene":
        """Every key and every rule between sections, as the command checks them
        (nothing placed or run); returns the scene."""
        _native.scene_check(self.sections)
        return self


def simulate(scene: Union[Scene, PathLike], output: PathLike, *, progress: Progress = None,
             scene_file: Optional[PathLike] = None, **options: Any) -> str:
    """``shearzone sim SCENE -o OUTPUT``: the contact-dynamics simulation of a scene (a
    ``Scene`` or a scene TOML; docs/sim.md); options as the command's (restart, phi0,
    f_hz, cycles, threads, force). A Scene is written to ``scene_file`` (else a
    temporary file, which the outputs' ``scene`` header then names) and run from it.
    Returns the run folder; ``read_checkpoint(folder + "/checkpoint.h5")`` reads its end
    state, ``read_fields(folder + "/surface.h5")`` its surface field."""
    if isinstance(scene, Scene):
        scene.check()
        with tempfile.TemporaryDirectory(prefix="shearzone-") as tmp:
            path = os.fspath(scene_file) if scene_file is not None else os.path.join(tmp, "scene.toml")
            scene.to_toml(path)
            run("sim", path, progress=progress, output=os.fspath(output), **options)
    else:
        run("sim", os.fspath(scene), progress=progress, output=os.fspath(output), **options)
    return os.fspath(output)


def read_checkpoint(path: PathLike) -> dict:
    """A simulator checkpoint as arrays: ``position_m``, ``velocity_m_per_s``,
    ``angular_velocity_rad_per_s`` (n, 3), ``orientation`` (n, 4; unit quaternions w, x,
    y, z), ``diameter_m``, ``mass_kg``, ``kind`` (0 mobile, 1 fixed, 2 kinematic),
    ``chain_id`` (n), ``ropes`` (r, 2 body indices), ``step``, ``time_s``,
    ``time_step_s``, ``n_walls``, ``n_contacts`` and ``state_hash`` (hex, the ``state
    hash`` that ``shearzone sim`` prints for the run that wrote it)."""
    return _native.read_checkpoint(os.fspath(path))


def sim_render(run_dir: PathLike, output: PathLike, *, progress: Progress = None, **options: Any) -> str:
    """``shearzone sim render RUN -o OUTPUT``: the virtual camera's video of a run."""
    run("sim render", os.fspath(run_dir), progress=progress, output=os.fspath(output), **options)
    return os.fspath(output)


class synth:
    """``synth.beads(...)`` and ``synth.particles(...)``: synth_beads and synth_particles."""
    beads = staticmethod(synth_beads)
    particles = staticmethod(synth_particles)
