"""Type stubs of the compiled module qm_mesh._native (see qm_mesh for the documented API)."""

import os
from typing import Any, Dict, Optional, Tuple, Union

import numpy as np
import numpy.typing as npt

DEFAULT_BITS: int
DEFAULT_SAMPLES: int
DEFAULT_SEED: int
DEFAULT_TOLERANCE_DB: float
DEFAULT_MIN_REMESH_PSNR: float

_Path = Union[str, "os.PathLike[str]"]
_Level = Union[int, str, None]

class Decoded:
    """A decoded mesh: numpy arrays and what the decoder says of them."""

    @property
    def vertices(self) -> npt.NDArray[np.float64]:
        """Vertex positions, float64, shape (n, 3)."""
    @property
    def faces(self) -> npt.NDArray[np.uint32]:
        """Quads as vertex indices, counter-clockwise, uint32, shape (m, 4)."""
    @property
    def colors(self) -> Optional[npt.NDArray[np.uint8]]:
        """For a file with colours: 8-bit sRGB per vertex, uint8, shape (n, 3); else None."""
    @property
    def texture(self) -> Optional[npt.NDArray[np.uint8]]:
        """For a file whose colours reached a finer level than the mesh: those colours as a
        texture atlas, 8-bit sRGB, uint8, shape (h, w, 3), rows from the top; else None."""
    @property
    def face_uvs(self) -> Optional[npt.NDArray[np.float32]]:
        """With a texture: each quad corner's texture coordinates, (0, 0) at the image's
        top-left corner, float32, shape (m, 4, 2); else None."""
    @property
    def triangles(self) -> npt.NDArray[np.uint32]:
        """The quads split along their first diagonal, uint32, shape (2m, 3)."""
    @property
    def level(self) -> int:
        """The subdivision level of the mesh (0 is the base mesh)."""
    @property
    def finest_level(self) -> int:
        """The file's finest level."""
    @property
    def passes(self) -> int:
        """Bit-plane passes decoded completely."""
    @property
    def total_passes(self) -> int:
        """Bit-plane passes in the complete file."""
    @property
    def truncated(self) -> bool:
        """Whether the bytes ended inside a pass (more bytes would refine it)."""
    @property
    def bytes_used(self) -> int:
        """Bytes of the input the mesh used."""
    @property
    def error(self) -> float:
        """Estimated RMS distance, in model units, from the complete file's finest mesh."""
    @property
    def psnr_db(self) -> float:
        """The same as PSNR against the bounding-box diagonal, in dB."""

class Distance:
    """The symmetric surface distance between two meshes."""

    @property
    def rms(self) -> float: ...
    @property
    def mean(self) -> float: ...
    @property
    def hausdorff(self) -> float: ...
    @property
    def psnr_db(self) -> float: ...
    @property
    def diag(self) -> float: ...
    @property
    def samples(self) -> Tuple[int, int]: ...

class DecodeOptions:
    """The decoder's options (qm_mesh.decode's keyword arguments)."""

    def __init__(
        self,
        max_bytes: Optional[int],
        max_error: Optional[float],
        level: _Level,
        max_triangles: Optional[int],
        passes: Optional[int],
        tolerance_db: float,
        max_memory: Optional[int],
    ) -> None: ...

class StreamDecoder:
    """An incremental decoder: feed it the bytes of a .qm file as they arrive."""

    def __init__(self, options: DecodeOptions) -> None: ...
    def feed(self, chunk: bytes) -> bool:
        """Appends bytes and decodes; returns whether the mesh changed."""
    def mesh(self) -> Optional[Decoded]:
        """The current mesh, or None before the header and base mesh are complete."""
    @property
    def ready(self) -> bool: ...
    @property
    def wants_more(self) -> bool: ...
    @property
    def bytes_received(self) -> int: ...
    @property
    def bytes_needed(self) -> int: ...
    @property
    def error(self) -> float: ...
    @property
    def psnr_db(self) -> float: ...
    @property
    def level(self) -> Optional[int]: ...
    @property
    def texture_version(self) -> int: ...

def encode(
    vertices: npt.NDArray[np.float64],
    faces: npt.NDArray[np.int64],
    bits: int,
    passes: Optional[int],
    max_bytes: Optional[int],
    holds: bool,
    frames: bool,
    remesh_level: Optional[int],
    normal_remesh: bool,
    base_domain: str,
    accept_folds: bool,
    min_remesh_psnr: float,
    max_memory: Optional[int],
    colors: Optional[npt.NDArray[np.float32]],
) -> bytes: ...
def decode(data: bytes, options: DecodeOptions) -> Decoded: ...
def info(data: bytes, max_memory: Optional[int]) -> Dict[str, Any]: ...
def read(path: _Path) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.uint32]]: ...
def write(path: _Path, vertices: npt.NDArray[np.float64], faces: npt.NDArray[np.int64]) -> None: ...
def distance(
    vertices_a: npt.NDArray[np.float64],
    faces_a: npt.NDArray[np.int64],
    vertices_b: npt.NDArray[np.float64],
    faces_b: npt.NDArray[np.int64],
    samples: int,
    seed: int,
) -> Distance: ...
