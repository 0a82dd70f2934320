"""qm_mesh: progressive mesh compression with qm, in numpy terms.

A mesh goes in; an *embedded* ``.qm`` stream comes out, and any prefix of
it past the base mesh decodes to a crack-free mesh whose error falls as
more bytes arrive::

    import qm_mesh
    data = qm_mesh.encode(vertices, faces)            # float (n, 3), int (m, 3) or (m, 4)
    coarse = qm_mesh.decode(data[: len(data) // 8])   # any prefix past the base mesh
    print(coarse.level, coarse.psnr_db, coarse.vertices.shape, coarse.faces.shape)

The work is done by qm's Rust library, with the GIL released. Errors are
subclasses of :class:`QmError`. With trimesh installed, importing this
module lets ``trimesh.load("x.qm")`` and ``mesh.export("x.qm")`` work.

The import name is ``qm_mesh``, not ``qm``: the PyPI distribution
``qm-qua`` (Quantum Machines) already installs a top-level ``qm`` package.
"""

from __future__ import annotations

import os
from typing import Any, Optional, Tuple, Union

import numpy as np

from . import _native
from ._errors import (
    DataError,
    FileError,
    LimitError,
    ParameterError,
    QmError,
    TruncatedError,
)
from ._native import Decoded, Distance

__all__ = [
    "encode",
    "decode",
    "info",
    "read",
    "write",
    "distance",
    "StreamDecoder",
    "Decoded",
    "Distance",
    "QmError",
    "DataError",
    "TruncatedError",
    "LimitError",
    "ParameterError",
    "FileError",
    "register_trimesh",
    "DEFAULT_BITS",
    "DEFAULT_SAMPLES",
    "DEFAULT_SEED",
    "DEFAULT_TOLERANCE_DB",
]

#: Quantization bits per coordinate of :func:`encode` by default.
DEFAULT_BITS: int = _native.DEFAULT_BITS
#: Samples per direction of :func:`distance` by default.
DEFAULT_SAMPLES: int = _native.DEFAULT_SAMPLES
#: Sampling seed of :func:`distance` by default.
DEFAULT_SEED: int = _native.DEFAULT_SEED
#: How much worse, in dB, the automatic level may be than the finest.
DEFAULT_TOLERANCE_DB: float = _native.DEFAULT_TOLERANCE_DB
_DEFAULT_MIN_REMESH_PSNR: float = _native.DEFAULT_MIN_REMESH_PSNR

Level = Union[int, str, None]
BytesLike = Union[bytes, bytearray, memoryview]
PathLike = Union[str, "os.PathLike[str]"]
#: A mesh for :func:`distance`: ``(vertices, faces)`` or any object with
#: ``vertices`` and ``faces`` attributes (a ``trimesh.Trimesh``, a
#: :class:`Decoded`).
MeshLike = Any


def _vertices(vertices: Any, what: str = "") -> np.ndarray:
    a = np.asarray(vertices)
    if a.dtype.kind not in "fiu":
        raise ParameterError(f"{what}vertices must be real numbers, not dtype {a.dtype}")
    if a.ndim != 2 or a.shape[1] != 3:
        raise ParameterError(f"{what}vertices must have shape (n, 3), not {a.shape}")
    return np.ascontiguousarray(a, dtype=np.float64)


def _faces(faces: Any, what: str = "") -> np.ndarray:
    a = np.asarray(faces)
    if a.size == 0 and a.dtype.kind == "f":
        a = a.astype(np.int64)
    if a.dtype.kind not in "iu":
        raise ParameterError(f"{what}faces must be integers, not dtype {a.dtype}")
    if a.ndim != 2 or a.shape[1] < 3:
        raise ParameterError(f"{what}faces must have shape (m, 3) or (m, 4), not {a.shape}")
    if a.dtype == np.uint64 and a.size and int(a.max()) > np.iinfo(np.int64).max:
        raise ParameterError(f"{what}faces refer to vertex {int(a.max())}, beyond any mesh")
    return np.ascontiguousarray(a, dtype=np.int64)


def _colors(colors: Any, n: int) -> Optional[np.ndarray]:
    """Vertex colours as the library takes them: float32 RGBA, sRGB, 0..1."""
    if colors is None:
        return None
    a = np.asarray(colors)
    if a.ndim != 2 or a.shape[0] != n or a.shape[1] not in (3, 4):
        raise ParameterError(f"colors must have shape ({n}, 3) or ({n}, 4), one per vertex, not {a.shape}")
    if a.dtype == np.uint8:
        a = a.astype(np.float32) / 255
    elif a.dtype.kind == "f":
        if not (np.isfinite(a).all() and a.min(initial=0) >= 0 and a.max(initial=0) <= 1):
            raise ParameterError("colors as floats must be finite and within 0..1")
    else:
        raise ParameterError(f"colors must be uint8 (0..255) or floats (0..1), not dtype {a.dtype}")
    if a.shape[1] == 3:
        a = np.concatenate([a, np.ones((n, 1), dtype=a.dtype)], axis=1)
    return np.ascontiguousarray(a, dtype=np.float32)


def _count(name: str, value: Optional[int]) -> Optional[int]:
    """An optional whole number, 0 or more, as the library takes it."""
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 0:
        raise ParameterError(f"{name} must be a whole number, 0 or more, not {value!r}")
    return int(value)


def _bytes(data: BytesLike) -> bytes:
    if isinstance(data, bytes):
        return data
    try:
        return bytes(memoryview(data))
    except TypeError:
        raise TypeError(f"data must be bytes-like, not {type(data).__name__}") from None


def encode(
    vertices: Any,
    faces: Any,
    *,
    bits: int = DEFAULT_BITS,
    passes: Optional[int] = None,
    max_bytes: Optional[int] = None,
    holds: bool = True,
    frames: bool = True,
    remesh_level: Optional[int] = None,
    normal_remesh: bool = True,
    base_domain: str = "auto",
    accept_folds: bool = False,
    min_remesh_psnr: float = _DEFAULT_MIN_REMESH_PSNR,
    max_memory: Optional[int] = None,
    colors: Any = None,
) -> bytes:
    """Compresses a mesh into the bytes of a ``.qm`` file.

    ``vertices`` is an ``(n, 3)`` array of real numbers (float32 or float64),
    ``faces`` an ``(m, 3)`` or ``(m, 4)`` integer array of vertex indices.
    A quad mesh with subdivision connectivity is coded as it is; anything
    else is remeshed into a semi-regular quad mesh first (seconds for a
    100,000-vertex scan). The GIL is released meanwhile.

    Keyword arguments, as ``qm compress`` takes them:

    - ``bits``: quantization bits per coordinate (default 16).
    - ``passes``: code only this many bit planes; ``max_bytes``: cut the
      file to this many bytes.
    - ``holds``: measure cuts and write holds (default on).
    - ``frames``: code details in local frames (default on).
    - ``remesh_level``: the remesher's subdivision level (default: about
      30 samples per input vertex, at most about a million).
    - ``normal_remesh``, ``base_domain`` (``"auto"``, ``"square"``,
      ``"charts"``, ``"input"``), ``accept_folds``, ``min_remesh_psnr``:
      the remesher's settings.
    - ``max_memory``: most bytes remeshing and encoding may take (default
      4 GiB), estimated before the work starts.
    - ``colors``: vertex colours, sRGB, one per vertex: uint8 ``(n, 3)``
      or ``(n, 4)`` (0..255) or floats (0..1); alpha is not carried. The
      colour of the surface at each sample is coded with the geometry, so
      that every prefix gives both (:attr:`Decoded.colors`).

    Raises :class:`DataError` for a mesh that cannot be remeshed,
    :class:`LimitError` past ``max_memory``, :class:`ParameterError` for
    bad arrays or settings.
    """
    v = _vertices(vertices)
    return _native.encode(
        v,
        _faces(faces),
        _count("bits", bits),
        _count("passes", passes),
        _count("max_bytes", max_bytes),
        bool(holds),
        bool(frames),
        _count("remesh_level", remesh_level),
        bool(normal_remesh),
        base_domain,
        bool(accept_folds),
        float(min_remesh_psnr),
        _count("max_memory", max_memory),
        _colors(colors, len(v)),
    )


def _decode_options(
    max_bytes: Optional[int],
    max_error: Optional[float],
    level: Level,
    max_triangles: Optional[int],
    passes: Optional[int],
    tolerance_db: float,
    max_memory: Optional[int],
) -> "_native.DecodeOptions":
    return _native.DecodeOptions(
        _count("max_bytes", max_bytes),
        max_error,
        level,
        _count("max_triangles", max_triangles),
        _count("passes", passes),
        tolerance_db,
        _count("max_memory", max_memory),
    )


def decode(
    data: BytesLike,
    max_bytes: Optional[int] = None,
    max_error: Optional[float] = None,
    level: Level = None,
    *,
    max_triangles: Optional[int] = None,
    passes: Optional[int] = None,
    tolerance_db: float = DEFAULT_TOLERANCE_DB,
    max_memory: Optional[int] = None,
) -> Decoded:
    """Decompresses the bytes of a ``.qm`` file, or any prefix of them past
    the base mesh.

    - ``max_bytes``: use only the first this many bytes.
    - ``max_error``: stop at the first pass whose estimated RMS error, in
      model units, meets this goal (0: the whole file).
    - ``level``: ``None`` or ``"auto"`` (default) for the level the bytes
      support, ``"finest"``, or a level number (0 is the base mesh).
    - ``max_triangles``: output no level with more triangles.
    - ``passes``: decode at most this many bit planes; ``tolerance_db``:
      how much worse the automatic level may be than the finest.
    - ``max_memory``: refuse a file whose header asks for more (default
      1 GiB).

    Returns a :class:`Decoded`: ``vertices`` (float64, ``(n, 3)``),
    ``faces`` (uint32 quads, ``(m, 4)``), ``colors`` (for a file with
    colours, 8-bit sRGB per vertex, uint8 ``(n, 3)``; else None),
    ``texture`` and ``face_uvs`` (for a file whose colours reached a finer
    level than the mesh: the texture atlas, uint8 ``(h, w, 3)``, and each
    quad corner's coordinates, float32 ``(m, 4, 2)``, ``(0, 0)`` at the
    image's top-left; else None), ``triangles``, ``level``,
    ``passes``, ``truncated``, ``error`` and ``psnr_db`` (the decoder's
    estimate). Raises :class:`TruncatedError` for bytes that end inside the
    header or base mesh, :class:`DataError` for bytes that are not ``.qm``
    or are corrupt, :class:`LimitError` for a file that asks for too much.
    """
    options = _decode_options(max_bytes, max_error, level, max_triangles, passes, tolerance_db, max_memory)
    return _native.decode(_bytes(data), options)


def info(data: BytesLike, *, max_memory: Optional[int] = None) -> dict:
    """The header of a ``.qm`` file and its levels table.

    Returns a dict: ``bytes``, ``stream_start`` (bytes of header and base
    mesh), ``bits``, ``level`` (finest), ``passes``, ``planes``, ``holds``,
    ``base_vertices``, ``base_faces``, ``vertices`` and ``triangles`` of the
    finest level, ``bbox_min``, ``step``, and ``levels``: one dict per pass
    end (``bytes``, ``passes``, ``level``, ``vertices``, ``triangles``,
    ``error``, ``psnr_db``) saying what that prefix decodes to, as
    ``qm info --levels`` prints it. Decodes the whole file once.
    """
    return _native.info(_bytes(data), _count("max_memory", max_memory))


def read(path: PathLike) -> Tuple[np.ndarray, np.ndarray]:
    """Reads a mesh file (OBJ, PLY, OFF or STL, by extension or content).

    Returns ``(vertices, faces)``: float64 ``(n, 3)`` and uint32 ``(m, k)``
    when every face has ``k`` corners, else the polygons fanned into
    triangles. Raises :class:`FileError` or :class:`DataError`.
    """
    return _native.read(path)


def write(path: PathLike, vertices: Any, faces: Any) -> None:
    """Writes a mesh file (OBJ or PLY, by extension), atomically: a failure
    leaves no half-written file. PLY is binary with float64 coordinates
    (exact); quads stay quads."""
    _native.write(path, _vertices(vertices), _faces(faces))


def _mesh(mesh: MeshLike, what: str) -> Tuple[np.ndarray, np.ndarray]:
    if isinstance(mesh, (tuple, list)) and len(mesh) == 2:
        vertices, faces = mesh
    elif hasattr(mesh, "vertices") and hasattr(mesh, "faces"):
        vertices, faces = mesh.vertices, mesh.faces
    else:
        raise ParameterError(
            f"{what}must be (vertices, faces) or have .vertices and .faces, "
            f"not {type(mesh).__name__}"
        )
    return _vertices(vertices, what), _faces(faces, what)


def distance(
    a: MeshLike,
    b: MeshLike,
    *,
    samples: int = DEFAULT_SAMPLES,
    seed: int = DEFAULT_SEED,
) -> Distance:
    """The symmetric surface distance between two meshes, as Metro and
    MeshLab measure it and ``qm distance`` prints it: ``samples``
    area-uniform samples on each surface, each projected onto the other.

    Each mesh is ``(vertices, faces)`` or has ``.vertices`` and ``.faces``
    (a ``trimesh.Trimesh``, a :class:`Decoded`). Returns a
    :class:`Distance`: ``rms``, ``mean``, ``hausdorff`` (the larger of the
    two directions), ``psnr_db`` = 20 log10(``diag`` / ``rms``) with
    ``diag`` the bounding-box diagonal of ``a``. The GIL is released.
    """
    va, fa = _mesh(a, "mesh a: ")
    vb, fb = _mesh(b, "mesh b: ")
    return _native.distance(va, fa, vb, fb, _count("samples", samples), _count("seed", seed))


class StreamDecoder:
    """An incremental decoder: feed it the bytes of a ``.qm`` file as they
    arrive (from a socket, an HTTP response, a file read in pieces); after
    each chunk, :meth:`mesh` is what those bytes decode to, the same as
    :func:`decode` of the bytes so far.

    It wraps the library's ``StreamDecoder``, the one the WebAssembly
    decoder and the command line use: each chunk resumes the bit-plane
    decoder where the last one left it. The options are :func:`decode`'s;
    with ``max_error`` or ``max_bytes``, :attr:`wants_more` turns False once
    the goal is met. Decoding runs with the GIL released; calls on one
    decoder from several threads take turns.
    """

    __slots__ = ("_inner",)

    def __init__(
        self,
        *,
        max_bytes: Optional[int] = None,
        max_error: Optional[float] = None,
        level: Level = None,
        max_triangles: Optional[int] = None,
        passes: Optional[int] = None,
        tolerance_db: float = DEFAULT_TOLERANCE_DB,
        max_memory: Optional[int] = None,
    ) -> None:
        options = _decode_options(max_bytes, max_error, level, max_triangles, passes, tolerance_db, max_memory)
        self._inner = _native.StreamDecoder(options)

    def feed(self, chunk: BytesLike) -> bool:
        """Appends the next bytes and decodes everything received so far.
        Returns whether the mesh changed (False while the header and base
        mesh are incomplete, or when the bytes change nothing). Raises
        :class:`DataError` as soon as the bytes show that the file is not
        ``.qm`` or is corrupt, :class:`LimitError` when its header asks for
        too much."""
        return self._inner.feed(_bytes(chunk))

    def mesh(self) -> Optional[Decoded]:
        """The current mesh (a :class:`Decoded`, arrays copied), or None
        before the header and base mesh are complete."""
        return self._inner.mesh()

    @property
    def ready(self) -> bool:
        """Whether the header and base mesh have arrived."""
        return self._inner.ready

    @property
    def wants_more(self) -> bool:
        """Whether more bytes could still change the mesh."""
        return self._inner.wants_more

    @property
    def bytes_received(self) -> int:
        """Bytes kept so far (at most ``max_bytes``)."""
        return self._inner.bytes_received

    @property
    def bytes_needed(self) -> int:
        """Before :attr:`ready`: the least total bytes the header and base
        mesh need, as far as known (0 once ready)."""
        return self._inner.bytes_needed

    @property
    def error(self) -> float:
        """Estimated RMS error of the current mesh, in model units (NaN
        before the first mesh)."""
        return self._inner.error

    @property
    def psnr_db(self) -> float:
        """The same as PSNR against the bounding-box diagonal, in dB."""
        return self._inner.psnr_db

    @property
    def level(self) -> Optional[int]:
        """Level of the current mesh (None before the first mesh)."""
        return self._inner.level

    @property
    def texture_version(self) -> int:
        """Changes whenever a refinement makes the texture anew (a file
        whose colour is finer than its geometry): while it stays, so do the
        meshes' ``texture`` and ``face_uvs``, and a viewer need not upload
        them again."""
        return self._inner.texture_version


from ._trimesh import register as register_trimesh  # noqa: E402

register_trimesh(only_if_imported=False)
