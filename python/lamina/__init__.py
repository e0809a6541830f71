"""Lamina from Python: layered materials (Hanrahan and Krueger 1993), their BRDFs, fits and
renders, with numpy in and out.

Every function calls the C++ function the ``lamina`` command calls, so a result equals the
command line's bit for bit (docs/python.md). Long calls release the GIL, report progress
through a callback and stop cleanly on Ctrl-C (KeyboardInterrupt, nothing written).
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
import sys
import threading
import time
from dataclasses import dataclass, field
from typing import Any, Callable, Dict, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from . import _lamina
from ._lamina import Cancelled, DenoiseError, FitError, ImageIoError, StackFileError

__version__: str = _lamina.__version__

StackFileError.__doc__ = "A material file (or dict) is invalid: the command line's one-line message, naming the file and JSON path."
FitError.__doc__ = "A fit's input is invalid (a parameter path, bounds, the measurements): the command line's message."
ImageIoError.__doc__ = "An image file cannot be read or written: one line naming the file."
DenoiseError.__doc__ = "Open Image Denoise cannot be loaded or reports an error."

__all__ = [
    "__version__", "Stack", "Layer", "BrdfResult", "FitResult", "Image", "brdf", "fit", "render", "compare",
    "denoise", "relative_difference", "plot_brdf", "plot_compare", "StackFileError", "FitError", "ImageIoError", "DenoiseError",
]

PathLike = Union[str, "os.PathLike[str]"]
Progress = Union[None, bool, Callable[[int, int], None]]
Layer = _lamina.Layer


def _path(value: Any, what: str) -> str:
    if not isinstance(value, (str, os.PathLike)):
        raise TypeError(f"{what}: expected a path (str or os.PathLike), got {type(value).__name__}")
    return os.fspath(value)


def _number(value: Any, what: str, lo: float = -math.inf, hi: float = math.inf, hi_open: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise TypeError(f"{what}: expected a number, got {type(value).__name__}")
    v = float(value)
    if not math.isfinite(v):
        raise ValueError(f"{what}: must be a finite number (got {value})")
    if v < lo or v > hi or (hi_open and v == hi):
        raise ValueError(f"{what}: must be in [{lo:g}, {hi:g}{')' if hi_open else ']'} (got {value})")
    return v


def _integer(value: Any, what: str, lo: int, hi: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"{what}: expected an integer, got {type(value).__name__}")
    if not lo <= int(value) <= hi:
        raise ValueError(f"{what}: must be an integer between {lo} and {hi} (got {value})")
    return int(value)


# ---------------------------------------------------------------------------------------------
# Progress and Ctrl-C

def _in_notebook() -> bool:
    return "ipykernel" in sys.modules


class _TerminalBar:
    """A one-line bar on stderr: label, percentage, elapsed and remaining time."""

    def __init__(self, label: str) -> None:
        self.label, self.start, self.last = label, time.monotonic(), 0.0

    def __call__(self, done: int, total: int) -> None:
        now = time.monotonic()
        if now - self.last < 0.2 and done < total:
            return
        self.last = now
        fraction = min(done / total, 1.0) if total else 0.0
        elapsed = now - self.start
        eta = elapsed * (1 - fraction) / fraction if fraction > 0 else 0.0
        bar = "#" * int(30 * fraction)
        sys.stderr.write(f"\r{self.label} {100 * fraction:5.1f}% |{bar:<30}| {elapsed:.1f} s, {eta:.1f} s left")
        sys.stderr.flush()

    def close(self) -> None:
        sys.stderr.write("\n")


def _reporter(progress: Progress, label: str):
    if progress is None:
        progress = sys.stderr.isatty() and not _in_notebook()
    if progress is True:
        return _TerminalBar(label)
    if progress is False:
        return None
    if not callable(progress):
        raise TypeError("progress: expected None, a bool or a callable(done, total)")
    return progress


def _run(work: Callable[[Any], Any], progress: Progress, label: str) -> Any:
    """Runs work(state) in a thread (it releases the GIL) while this thread reports its progress;
    Ctrl-C (or an exception in the callback) asks it to stop and is raised once it has.

    The end is signalled by an Event, not Thread.join: a KeyboardInterrupt inside join() can mark
    a running thread as stopped (CPython's _wait_for_tstate_lock releases the lock the running
    thread holds), and the work would then outlive the call."""
    report = _reporter(progress, label)
    state = _lamina.JobState()
    outcome: Dict[str, Any] = {}
    done = threading.Event()

    def target() -> None:
        try:
            outcome["value"] = work(state)
        except Cancelled:  # asked by the calling thread, which raises its own exception
            pass
        except BaseException as e:  # handed to the calling thread
            outcome["error"] = e
        finally:
            done.set()

    threading.Thread(target=target, name=f"lamina {label}", daemon=True).start()
    try:
        while not done.wait(0.05):
            if report is not None and state.total:
                report(state.done, state.total)
    except BaseException:
        state.cancel()
        while True:  # the work stops at its next progress report; a second Ctrl-C waits too
            try:
                if done.wait(0.1):
                    break
            except KeyboardInterrupt:
                pass
        raise
    finally:
        if isinstance(report, _TerminalBar):
            report.close()
    if "error" in outcome:
        raise outcome.pop("error")
    return outcome["value"]


# ---------------------------------------------------------------------------------------------
# Stacks

class Stack:
    """A layered material (docs/contracts.md, "Material file"). Read-only: ``name``,
    ``above_ior``, ``top_roughness``, ``layers`` (each with ``name``, ``ior``, ``thickness`` in mm,
    ``sigma_a``, ``sigma_s``, ``albedo`` as RGB tuples), ``transmits``; ``to_dict()`` gives the
    file's JSON. Invalid input raises StackFileError (a ValueError) with the command line's
    one-line message, e.g. ``skin.json: layers[1].thickness: must be > 0``."""

    def __init__(self, native: "_lamina.Stack") -> None:
        self._native = native

    @classmethod
    def load(cls, path: PathLike) -> "Stack":
        """Reads a material file (as ``lamina brdf STACK.json``)."""
        return cls(_lamina.Stack.load(_path(path, "path")))

    @classmethod
    def from_dict(cls, d: Mapping[str, Any], source: str = "<dict>") -> "Stack":
        """A stack from the material file's JSON as a dict; errors are prefixed with ``source``."""
        if not isinstance(d, Mapping):
            raise TypeError(f"from_dict: expected a dict, got {type(d).__name__}")
        try:
            text = json.dumps(d, allow_nan=False)
        except ValueError as e:  # NaN or infinity: not a JSON number
            raise StackFileError(f"{source}: {e}") from None
        except TypeError as e:
            raise TypeError(f"{source}: {e}") from None
        return cls(_lamina.Stack.parse(text, source))

    @classmethod
    def from_json(cls, text: str, source: str = "<json>") -> "Stack":
        """A stack from the material file's text."""
        if not isinstance(text, str):
            raise TypeError(f"from_json: expected a str, got {type(text).__name__}")
        return cls(_lamina.Stack.parse(text, source))

    def to_dict(self) -> Dict[str, Any]:
        """The material file's JSON."""
        return json.loads(self._native.json)

    name = property(lambda self: self._native.name)
    above_ior = property(lambda self: self._native.above_ior)
    top_roughness = property(lambda self: self._native.top_roughness)
    layers = property(lambda self: self._native.layers)
    transmits = property(lambda self: self._native.transmits)
    source = property(lambda self: self._native.source)

    def __repr__(self) -> str:
        return f"Stack({self.source!r}, {len(self.layers)} layer(s))"


def _stack(value: Any) -> Stack:
    if isinstance(value, Stack):
        return value
    if isinstance(value, Mapping):
        return Stack.from_dict(value)
    if isinstance(value, (str, os.PathLike)):
        return Stack.load(value)
    raise TypeError(f"stack: expected a Stack, a dict or a path, got {type(value).__name__}")


# ---------------------------------------------------------------------------------------------
# lamina brdf

@dataclass
class BrdfResult:
    """What ``lamina brdf`` computes. ``totals[key]`` for R_specular, R_diffuse, T_ballistic,
    T_diffuse, absorbed (and adding-doubling's R/T/absorbed_hemispherical): a dict with
    ``value`` and ``stderr`` (RGB numpy arrays; adding-doubling also ``discretisation_error``).
    The bins (``value``, ``stderr``, ``single``, ``multiple``: arrays of shape (2, bins_theta,
    bins_phi, 3), side 0 reflect, 1 transmit; 1/sr) exist unless ``table=False``;
    ``theta_o_deg`` and ``phi_o_deg`` are the bin centres."""

    method: str
    theta_i: float
    phi_i: float
    totals: Dict[str, Dict[str, np.ndarray]]
    value: Optional[np.ndarray] = None
    stderr: Optional[np.ndarray] = None
    single: Optional[np.ndarray] = None
    multiple: Optional[np.ndarray] = None
    theta_o_deg: Optional[np.ndarray] = None
    phi_o_deg: Optional[np.ndarray] = None
    projected_solid_angle: Optional[np.ndarray] = None
    extra: Dict[str, Any] = field(default_factory=dict)
    notes: List[str] = field(default_factory=list)

    def total(self, key: str) -> np.ndarray:
        """The RGB value of a total, e.g. ``result.total("R_diffuse")``."""
        return self.totals[key]["value"]


def brdf(stack: Union[Stack, Mapping[str, Any], PathLike], theta_i: float, *, table: bool = True,
         progress: Progress = None, **options: Any) -> BrdfResult:
    """The BRDF/BTDF table and energy totals of a stack for light from (theta_i, phi_i) degrees,
    as ``lamina brdf STACK --theta-i THETA_I --method METHOD --samples N --seed S --out T.csv``.
    The options are those of ``lamina brdf`` by keyword (the flag without dashes, ``-`` as
    ``_``), with its defaults and ranges: one table declares both (renderer/batch/brdf_job.h).
    table: adding-doubling's bins too (the other methods always have them). progress: None (a
    bar on a terminal, nothing in a notebook), True, False or a callable(done, total)."""
    s = _stack(stack)
    # numpy scalars as Python numbers; the module checks types and ranges against the table.
    given = {k: (v.item() if isinstance(v, np.generic) else v) for k, v in {"theta_i": theta_i, **options}.items()}
    d = _run(lambda state: _lamina.brdf(s._native, given, bool(table), state), progress, "brdf")
    used = d["options"]
    totals = {k: {kk: np.asarray(vv) for kk, vv in v.items()} for k, v in d["totals"].items()}
    r = BrdfResult(method=used["method"], theta_i=used["theta_i"], phi_i=used["phi_i"], totals=totals,
                   notes=list(d["notes"]))
    for key in ("value", "stderr", "single", "multiple", "theta_o_deg", "phi_o_deg", "projected_solid_angle"):
        if key in d:
            setattr(r, key, d[key])
    for key in ("walk_ends", "unresolved_walks", "R_forward_peak", "T_forward_peak"):
        if key in d:
            r.extra[key] = d[key]
    if r.method == "monte-carlo":
        r.extra.update(samples=used["samples"], seed=used["seed"])
    return r


def _brdf_signature() -> None:
    """brdf's signature and the list of its options in its docstring, from the module's table."""
    import inspect
    rows = _lamina.brdf_options()
    kw = inspect.Parameter.KEYWORD_ONLY
    params = [inspect.Parameter("stack", inspect.Parameter.POSITIONAL_OR_KEYWORD, annotation="Union[Stack, Mapping[str, Any], PathLike]"),
              inspect.Parameter("theta_i", inspect.Parameter.POSITIONAL_OR_KEYWORD, annotation=float)]
    params += [inspect.Parameter(name, kw, default=default, annotation=type(default))
               for name, default, _, required in rows if not required]
    params += [inspect.Parameter("table", kw, default=True, annotation=bool),
               inspect.Parameter("progress", kw, default=None, annotation="Progress")]
    brdf.__signature__ = inspect.Signature(params, return_annotation="BrdfResult")  # type: ignore[attr-defined]
    brdf.__doc__ = (brdf.__doc__ or "") + "\n\n    Options: " + "; ".join(
        f"``{name}`` ({help})" for name, _, help, _ in rows) + "."


_brdf_signature()


# ---------------------------------------------------------------------------------------------
# lamina fit

@dataclass
class FitResult:
    """What ``lamina fit`` reports: ``values`` and ``sigmas`` by unknown name ("PATH" or
    "PATH[r]"; sigma inf where not identified), the fitted ``stack``, chi2, dof, per measurement
    the model value and residual, and the warnings."""

    values: Dict[str, float]
    sigmas: Dict[str, float]
    stack: Stack
    chi2: float
    dof: int
    parameters: List[Dict[str, Any]]
    model: np.ndarray
    residual: np.ndarray
    warnings: List[str]
    evaluations: int


def _measurements_csv(data: Any) -> Tuple[str, str]:
    if isinstance(data, (str, os.PathLike)):
        path = os.fspath(data)
        try:
            with open(path, encoding="utf-8") as f:
                return f.read(), path
        except OSError as e:
            raise FitError(f"{path}: cannot open ({e.strerror})") from None
    if not isinstance(data, Sequence):
        raise TypeError(f"data: expected a CSV path or a list of dicts, got {type(data).__name__}")
    out = io.StringIO()
    columns = ["quantity", "channel", "theta_i_deg", "value", "sigma"]
    w = csv.writer(out, lineterminator="\n")
    w.writerow(columns)
    for i, row in enumerate(data):
        if not isinstance(row, Mapping) or set(row) != set(columns):
            raise ValueError(f"data[{i}]: expected a dict with the keys {', '.join(columns)}")
        w.writerow([repr(float(row[c])) if isinstance(row[c], float) else row[c] for c in columns])
    return out.getvalue(), "<data>"


def fit(stack: Union[Stack, Mapping[str, Any], PathLike], data: Any,
        params: Mapping[str, Tuple[float, float]], *, quadrature_points: int = 16,
        coarse_quadrature_points: int = 4) -> FitResult:
    """Fits parameters of a stack to measured totals, as ``lamina fit STACK --data DATA.csv
    --param PATH=LO:HI ...``. data: the CSV's path or a list of dicts with quantity (R,
    R_diffuse, T, T_diffuse, T_unscattered), channel (r, g, b), theta_i_deg (degrees or
    "diffuse"), value and sigma. params: {"layers[0].sigma_s": (0, 100), ...}."""
    s = _stack(stack)
    text, source = _measurements_csv(data)
    if not isinstance(params, Mapping) or not params:
        raise ValueError("params: expected a non-empty dict {PATH: (LO, HI)}")
    specs = []
    for path, bounds in params.items():
        if not isinstance(path, str) or not isinstance(bounds, Sequence) or len(bounds) != 2:
            raise ValueError(f"params[{path!r}]: expected PATH: (LO, HI)")
        specs.append((path, _number(bounds[0], f"params[{path!r}] lower"), _number(bounds[1], f"params[{path!r}] upper")))
    q = _integer(quadrature_points, "quadrature_points", 4, 64)
    cq = _integer(coarse_quadrature_points, "coarse_quadrature_points", 0, 64)
    d = _run(lambda state: _lamina.fit(s._native, text, source, specs, q, cq), False, "fit")
    ps = d["parameters"]
    return FitResult(values={p["name"]: p["value"] for p in ps}, sigmas={p["name"]: p["sigma"] for p in ps},
                     stack=Stack.from_json(d["fitted_json"], f"{s.source} (fitted)"), chi2=d["chi2"], dof=d["dof"],
                     parameters=ps, model=np.asarray(d["model"]), residual=np.asarray(d["residual"]),
                     warnings=list(d["warnings"]), evaluations=d["evaluations"])


# ---------------------------------------------------------------------------------------------
# Images

_AOV_LAYERS = {"albedo": ("albedo.R", "albedo.G", "albedo.B"), "normal": ("N.X", "N.Y", "N.Z"),
               "variance": ("variance.R", "variance.G", "variance.B")}


class Image:
    """A linear RGB image with its extra channels and EXR header. ``rgb``: float32 array of shape
    (height, width, 3); ``channels``: {name: (height, width) float32} as in the EXR ("spp",
    "albedo.R", "N.X", "Z", ...); ``aovs``: the same grouped ("albedo", "normal", "variance" of
    shape (h, w, 3), "depth" and "spp" of shape (h, w)); ``metadata``: the header's attributes;
    ``window``: (x, y, full_width, full_height) of a crop, full_width 0 for the whole image."""

    def __init__(self, rgb: np.ndarray, channels: Optional[Mapping[str, np.ndarray]] = None,
                 metadata: Optional[Mapping[str, str]] = None, window: Tuple[int, int, int, int] = (0, 0, 0, 0),
                 info: Optional[Dict[str, Any]] = None) -> None:
        rgb = np.ascontiguousarray(rgb, dtype=np.float32)
        if rgb.ndim != 3 or rgb.shape[2] != 3:
            raise ValueError(f"rgb: expected shape (height, width, 3), got {rgb.shape}")
        self.rgb = rgb
        self.channels = {k: np.ascontiguousarray(v, dtype=np.float32) for k, v in (channels or {}).items()}
        self.metadata = dict(metadata or {})
        self.window = tuple(window)
        self.info = info or {}

    width = property(lambda self: self.rgb.shape[1])
    height = property(lambda self: self.rgb.shape[0])

    @property
    def aovs(self) -> Dict[str, np.ndarray]:
        out = {}
        for name, keys in _AOV_LAYERS.items():
            if all(k in self.channels for k in keys):
                out[name] = np.stack([self.channels[k] for k in keys], axis=-1)
        if "Z" in self.channels:
            out["depth"] = self.channels["Z"]
        if "spp" in self.channels:
            out["spp"] = self.channels["spp"]
        return out

    def write(self, path: PathLike) -> None:
        """Writes a float EXR (atomically) with the channels and header, as ``lamina render``."""
        _lamina.write_exr(_path(path, "path"), self.rgb, list(self.metadata.items()), list(self.channels.items()),
                           self.window)

    @classmethod
    def read(cls, path: PathLike) -> "Image":
        """Reads an image: an EXR with every channel and its header, or HDR, PNG, JPEG (linear RGB)."""
        p = _path(path, "path")
        if p.lower().endswith(".exr"):
            d = _lamina.read_exr(p)
            names, values = d["names"], d["values"]
            planes = {n: values[:, :, i] for i, n in enumerate(names)}
            for c in "RGB":
                if c not in planes:
                    raise ImageIoError(f"{p}: no channel {c}")
            rgb = np.stack([planes.pop(c) for c in "RGB"], axis=-1)
            return cls(rgb, planes, dict(d["metadata"]))
        rgb, _ = _lamina.read_image(p)
        return cls(rgb)

    def __repr__(self) -> str:
        return f"Image({self.width}x{self.height}, channels={list(self.channels)})"


def _image(value: Any, what: str) -> Image:
    if isinstance(value, Image):
        return value
    if isinstance(value, np.ndarray):
        return Image(value)
    if isinstance(value, (str, os.PathLike)):
        return Image.read(value)
    raise TypeError(f"{what}: expected an Image, a numpy array or a path, got {type(value).__name__}")


# ---------------------------------------------------------------------------------------------
# lamina render

def render(scene: PathLike, *, width: int = 640, height: int = 480, spp: int = 16, seed: int = 0, threads: int = 0,
           subsurface: str = "random-walk", tolerance: Optional[float] = None, camera: str = "",
           materials: Union[None, PathLike, Mapping[str, Union[Stack, PathLike]]] = None, env: Union[str, float] = "",
           max_depth: int = 64, aovs: Union[str, Sequence[str]] = "none", cache: Optional[PathLike] = None,
           table_method: Optional[str] = None, noise_threshold: float = 0.0, pilot_spp: Optional[int] = None,
           clamp: float = 0.0, time_limit: float = 0.0, crop: Optional[Sequence[int]] = None,
           walk: Optional[Mapping[str, Any]] = None, out: Optional[PathLike] = None, png: Optional[PathLike] = None,
           exposure: Optional[float] = None, tone_curve: Optional[str] = None, spectral: bool = False,
           progress: Progress = None) -> Image:
    """Renders a glTF scene, as ``lamina render SCENE --width W --height H --spp N --seed S ...``:
    the same image bit for bit. materials: a material map file, or {glTF material name: Stack or
    path}. aovs: "albedo,normal" or a list. walk: the walk's options by flag without dashes,
    e.g. {"guiding": "on"}. out/png: also written (all or none, as the CLI). An option left at
    None takes the command line's default; one given where it would not act (exposure without
    png, walk options with a mode that runs no walk, ...) raises ValueError with the command
    line's message. Ctrl-C stops the render within a path and raises KeyboardInterrupt; nothing
    is written."""
    s = _path(scene, "scene")
    w = _integer(width, "width", 1, 16384)
    h = _integer(height, "height", 1, 16384)
    n = _integer(spp, "spp", 1, 1 << 20)
    sd = _integer(seed, "seed", 0, 2**64 - 1)
    th = _integer(threads, "threads", 0, 4096)
    depth = _integer(max_depth, "max_depth", 0, 100000)
    tol = 0.0 if tolerance is None else _number(tolerance, "tolerance", 0.0, 1.0)
    nt = _number(noise_threshold, "noise_threshold", 0.0, 1.0, hi_open=True)
    ps = 16 if pilot_spp is None else _integer(pilot_spp, "pilot_spp", 1, 1 << 20)
    cl = _number(clamp, "clamp", 0.0, 1e30)
    tl = _number(time_limit, "time_limit", 0.0, 1e9)
    ex = 0.0 if exposure is None else _number(exposure, "exposure", -20.0, 20.0)
    region = [] if crop is None else [_integer(v, "crop", 0, 16384) for v in crop]
    if not isinstance(spectral, bool):
        raise TypeError(f"spectral: expected a bool, got {type(spectral).__name__}")
    # The options set, by their command-line flags: the library refuses those that would not act.
    given = [flag for flag, value in (("--tolerance", tolerance), ("--pilot-spp", pilot_spp), ("--crop", crop),
                                      ("--exposure", exposure), ("--tone-curve", tone_curve),
                                      ("--table-method", table_method)) if value is not None]
    aov_list = aovs if isinstance(aovs, str) else ",".join(aovs)
    env_text = env if isinstance(env, str) else repr(_number(env, "env", 0.0))
    map_path, inline = "", []
    if isinstance(materials, Mapping):
        for name, value in materials.items():
            st = _stack(value)
            inline.append((name, st._native.json, st.source))
    elif materials is not None:
        map_path = _path(materials, "materials")
    walk_options = [("--" + k.replace("_", "-"), str(v)) for k, v in (walk or {}).items()]
    given += [flag for flag, _ in walk_options]
    out_path = "" if out is None else _path(out, "out")
    png_path = "" if png is None else _path(png, "png")
    if png_path and not out_path:
        raise ValueError("png: only with out (the EXR and the PNG are written together)")
    command = (f"lamina.render({s!r}, width={w}, height={h}, spp={n}, seed={sd}, subsurface={subsurface!r}"
               f"{', materials=...' if materials else ''}{', spectral=True' if spectral else ''})")
    cache_dir = "" if cache is None else _path(cache, "cache")
    d = _run(lambda state: _lamina.render(s, out_path, png_path, w, h, n, sd, th, subsurface, tol, camera, map_path,
                                           env_text, depth, aov_list, cache_dir, table_method or "adding-doubling",
                                           nt, ps, cl, tl, region, ex, tone_curve or "filmic", walk_options, inline,
                                           spectral, command, given, state),
             progress, "render")
    for line in d["warnings"]:
        import warnings
        warnings.warn(line, RuntimeWarning, stacklevel=2)
    info = {k: d[k] for k in ("seconds", "camera", "invalid_samples", "clamped_samples", "layered_materials", "info")}
    return Image(d["rgb"], dict(d["channels"]), dict(d["metadata"]), d["window"], info)


# The spectral keyword is lamina render's --spectral, declared once in C++ (SPECTRAL_OPTION).
_keyword, _flag, _help = _lamina.SPECTRAL_OPTION
render.__doc__ = (render.__doc__ or "") + f"\n\n    ``{_keyword}``: {_help} (``lamina render {_flag}``)."


# ---------------------------------------------------------------------------------------------
# lamina compare, lamina denoise

def compare(reference: Union[Image, np.ndarray, PathLike], test: Union[Image, np.ndarray, PathLike], *,
            epsilon: float = _lamina.DEFAULT_GUARD_EPSILON) -> Dict[str, float]:
    """The metrics of ``lamina compare REF TEST --json``: guard_floor, mean_relative,
    rms_relative, max_abs_relative, mae, mse, rmse, ssim (relative difference (TEST - REF) /
    max(REF, epsilon * mean(REF)))."""
    a, b = _image(reference, "reference"), _image(test, "test")
    eps = _number(epsilon, "epsilon", 0.0)
    if eps <= 0:
        raise ValueError(f"epsilon: must be > 0 (got {epsilon})")
    if a.rgb.shape != b.rgb.shape:
        raise ValueError(f"reference is {a.width}x{a.height} but test is {b.width}x{b.height}")
    for name, im in (("reference", a), ("test", b)):
        if not np.isfinite(im.rgb).all():
            raise ValueError(f"{name}: has non-finite pixels")
    return dict(_lamina.compare(a.rgb, b.rgb, eps))


def relative_difference(reference: Union[Image, np.ndarray, PathLike], test: Union[Image, np.ndarray, PathLike], *,
                        epsilon: float = _lamina.DEFAULT_GUARD_EPSILON) -> np.ndarray:
    """The relative difference of luminance per pixel, (height, width), as ``lamina compare --png`` shows it."""
    a, b = _image(reference, "reference"), _image(test, "test")
    return _lamina.relative_luminance_difference(a.rgb, b.rgb, _number(epsilon, "epsilon", 0.0))


def denoise(image: Union[Image, PathLike], *, use_aovs: bool = True, threads: int = 0) -> Image:
    """Intel Open Image Denoise on a render, guided by its albedo and normal AOVs if it has them
    (``lamina denoise``); the metadata is kept. Raises DenoiseError if the library is missing."""
    im = _image(image, "image")
    a = im.aovs
    albedo = a.get("albedo") if use_aovs else None
    normal = a.get("normal") if albedo is not None else None
    rgb, library, version = _lamina.denoise(im.rgb, albedo, normal, _integer(threads, "threads", 0, 4096))
    return Image(rgb, {}, im.metadata, im.window, {"oidn_library": library, "oidn_version": version})


def plot_brdf(result: BrdfResult, path: Optional[PathLike] = None, **kwargs: Any):
    """Polar plots of the BRDF and BTDF in the plane of incidence and hemispherical maps, with the
    totals in the legend and the Lambert lobe of the same albedo (lamina.plot.brdf)."""
    from .plot import brdf as _plot
    return _plot(result, path, **kwargs)


def plot_compare(reference: Union[Image, np.ndarray, PathLike], test: Union[Image, np.ndarray, PathLike],
                 path: Optional[PathLike] = None, **kwargs: Any):
    """A histogram of relative differences beside the false-colour image (lamina.plot.compare)."""
    from .plot import compare as _plot
    return _plot(reference, test, path, **kwargs)
