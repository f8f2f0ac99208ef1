"""sism from Python: soft shadows on a modelled 16-wide SIMD many-core machine.

The functions bind the Rust library the ``sism`` command line is built on; figures are the same
as the command line's. Images follow the project's contract (docs/CONTRACTS.md): visibility ``V``
in [0, 1] per pixel, ``NaN`` where the eye ray misses, ``-1`` on receivers facing away from the
light; rows top to bottom, float32.

Errors are raised with the library's message: ``OSError`` when a file cannot be read or written,
``ValueError`` for bad input (a malformed scene, an unknown algorithm or parameter, images of
different sizes). The GIL is released while Rust works.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any, Dict, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from . import _sism
from ._sism import Scene

__all__ = [
    "Scene",
    "Render",
    "algorithms",
    "load_scene",
    "render",
    "read_visibility",
    "compare",
    "study",
    "simd_backend",
]
__version__ = _sism.__version__

PathLike = Union[str, "os.PathLike[str]"]


def algorithms() -> List[Dict[str, Any]]:
    """Every algorithm of the registry.

    Each is a dict: ``name``, ``family``, ``summary`` (one line), ``machine`` (True when
    ``render(..., machine=...)`` can time it) and ``params``: a list of dicts with ``key``,
    ``default`` (as written on the command line), ``range`` and ``description``.
    """
    return _sism.algorithms()


def load_scene(path: PathLike, width: Optional[int] = None, height: Optional[int] = None) -> Scene:
    """Loads a scene file (TOML, with its OBJ meshes), optionally at another image size (pixels).

    Raises ``OSError`` when a file is missing or unreadable, ``ValueError`` when it is malformed
    or the size is out of range.
    """
    return _sism.load_scene(os.fspath(path), width, height)


def _to_array(data: bytes, width: int, height: int) -> np.ndarray:
    # Little-endian float32 from the library; a writable copy the caller owns.
    return np.frombuffer(data, dtype="<f4").reshape(height, width).astype(np.float32, copy=True)


class Render(dict):
    """One rendered frame: a dict with

    * ``visibility``: ``numpy.ndarray`` float32, shape (height, width), rows top to bottom;
    * ``stats``: counter name → ``(value, unit)``, as ``stats.json`` has them;
    * ``facts``: run facts (algorithm, parameters, SIMD backend, ...);
    * ``machine``: ``None`` natively; with ``machine=`` the simulated frame: ``frame``, ``phases``
      and ``steps`` (each with ``ms``, ``cycles``, ``tasks`` and a cycle ``stack`` of ``issue``,
      ``memory``, ``atomics_sync`` and ``imbalance_idle``), the machine's ``name``, ``cores``,
      ``threads_per_core`` and ``clock_ghz``;
    * ``algorithm``, ``params`` (the resolved parameters, ``key=value`` joined by spaces).

    Attribute access works too: ``r.visibility``, ``r.stats``.
    """

    def __getattr__(self, name: str) -> Any:
        try:
            return self[name]
        except KeyError:
            raise AttributeError(name) from None

    @property
    def phase_ms(self) -> Dict[str, float]:
        """Simulated milliseconds per phase (empty without ``machine=``)."""
        m = self.get("machine")
        return {} if m is None else {p["phase"]: p["ms"] for p in m["phases"]}


def render(
    scene: Scene,
    algo: str,
    params: Optional[Mapping[str, Union[str, int, float, bool]]] = None,
    machine: Optional[PathLike] = None,
    progress: bool = False,
) -> Render:
    """Renders one frame of ``scene`` with algorithm ``algo`` (see :func:`algorithms`).

    ``params`` sets the algorithm's parameters by key (values as the command line's
    ``--param key=value``). ``machine`` — a preset (``larrabee-8`` … ``larrabee-64``, ``host``) or
    a machine TOML file — counts the frame and times it on that modelled chip (the image is the
    same, bit for bit). ``progress`` shows progress bars on stderr.
    """
    r = _sism.render(
        scene,
        algo,
        None if params is None else dict(params),
        None if machine is None else os.fspath(machine),
        progress,
    )
    r["visibility"] = _to_array(r["visibility"], r["width"], r["height"])
    return Render(r)


def read_visibility(path: PathLike) -> np.ndarray:
    """Reads a visibility image, PFM or OpenEXR (told apart by content), as float32 (height, width)."""
    data, width, height = _sism.read_visibility(os.fspath(path))
    return _to_array(data, width, height)


ImageLike = Union[PathLike, np.ndarray, Render]


def _image(x: ImageLike, which: str) -> Tuple[Tuple[bytes, int, int], Optional[Path]]:
    """The image as (bytes, width, height), and the shaded.png beside it if it is a file."""
    if isinstance(x, Render):
        x = x["visibility"]
    if isinstance(x, np.ndarray):
        if x.ndim != 2:
            raise ValueError(f"{which}: a visibility image is 2-D (height, width), got shape {x.shape}")
        a = np.ascontiguousarray(x, dtype="<f4")
        return (a.tobytes(), int(a.shape[1]), int(a.shape[0])), None
    path = Path(os.fspath(x))
    data, width, height = _sism.read_visibility(str(path))
    beside = path.parent / "shaded.png"
    return (data, width, height), (beside if beside.is_file() else None)


def compare(reference: ImageLike, test: ImageLike, scene: Optional[Scene] = None) -> Dict[str, Any]:
    """Error of ``test`` against ``reference``: the figures of ``sism compare``.

    Each image is a file (PFM or OpenEXR), a NumPy array (height, width) or a :class:`Render`.
    Returns ``compared`` (pixels holding a visibility in both), ``mae``, ``rmse``, ``p99``, ``max``,
    ``share_over_0_1``, ``penumbra_pixels``, ``penumbra_mae`` and ``flip``: mean LDR-ꟻLIP between
    the two frames' shaded views. ꟻLIP needs the shading: from ``scene`` when given (the scene both
    images are frames of), else from the ``shaded.png`` a render wrote beside each file; otherwise
    ``flip`` is ``None``.
    """
    (r, r_png), (t, t_png) = _image(reference, "reference"), _image(test, "test")
    pngs = (str(r_png), str(t_png)) if scene is None and r_png and t_png else None
    return _sism.compare(r, t, scene, pngs)


def study(
    scene: Scene,
    machine: PathLike = "larrabee-24",
    algo: str = "sism",
    cores: Optional[Sequence[int]] = None,
    threads: Optional[Sequence[int]] = None,
    l2_kb: Optional[Sequence[int]] = None,
    params: Optional[Mapping[str, Union[str, int, float, bool]]] = None,
    progress: bool = False,
) -> List[Dict[str, Any]]:
    """An architecture study: one frame of ``algo`` counted once, re-timed on every machine of the
    sweep ``cores`` × ``threads`` (per core) × ``l2_kb`` (L2 per core, KB) around ``machine``
    (an axis left out keeps the base machine's value).

    Returns one dict per point and row — ``level`` is ``frame``, ``phase`` or ``step`` — with the
    point's ``cores``, ``threads``, ``l2_kb``, ``clock_ghz`` and ``machine`` name, the row's
    ``phase``, ``tasks``, ``cycles``, ``ms``, cycle stack (``issue``, ``memory``,
    ``atomics_sync``, ``imbalance_idle``), ``lane_utilisation``, miss rates, ``bytes_dram``, and
    the point's ``frame_speedup`` over the fewest cores. ``pandas.DataFrame(rows)`` takes it as is.
    """
    as_list = lambda v: None if v is None else [int(x) for x in v]  # noqa: E731
    return _sism.study(
        scene,
        os.fspath(machine),
        algo,
        as_list(cores),
        as_list(threads),
        as_list(l2_kb),
        None if params is None else dict(params),
        progress,
    )


def simd_backend() -> str:
    """The SIMD backend the kernels run on: ``avx512`` where the CPU has it, else ``portable``
    (``SISM_SIMD=portable`` forces it)."""
    return _sism.simd_backend()
