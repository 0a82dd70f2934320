"""trimesh integration: a loader and an exporter for ``.qm`` in trimesh's
registries (``trimesh.exchange.load.mesh_loaders`` and
``trimesh.exchange.export._mesh_exporters``), so that ``trimesh.load`` and
``Trimesh.export`` know the extension. trimesh stays optional."""

from __future__ import annotations

import importlib.util
import sys
from typing import Any

# What `trimesh.load(path, **kwargs)` passes on to the decoder.
_DECODE_KEYS = ("max_bytes", "max_error", "level", "max_triangles", "passes", "tolerance_db", "max_memory")


def load_qm(file_obj: Any, file_type: Any = None, resolver: Any = None, **kwargs: Any) -> dict:
    """trimesh loader: the ``.qm`` file's mesh, at the level its bytes
    support, as the keyword arguments of a ``Trimesh`` (the quads split
    into triangles; a file's colours as ``vertex_colors``). ``trimesh.load("x.qm", max_error=..., level=...)``
    passes the decoder's options through."""
    from . import decode

    options = {k: kwargs[k] for k in _DECODE_KEYS if k in kwargs}
    decoded = decode(file_obj.read(), **options)
    metadata = dict(kwargs.get("metadata") or {})
    metadata["qm"] = {
        "level": decoded.level,
        "finest_level": decoded.finest_level,
        "passes": decoded.passes,
        "truncated": decoded.truncated,
        "error": decoded.error,
        "psnr_db": decoded.psnr_db,
    }
    mesh = {"vertices": decoded.vertices, "faces": decoded.triangles, "metadata": metadata}
    if decoded.colors is not None:
        mesh["vertex_colors"] = decoded.colors
    return mesh


def export_qm(mesh: Any, **kwargs: Any) -> bytes:
    """trimesh exporter: ``mesh.export("x.qm", bits=14, ...)`` encodes the
    mesh with :func:`qm_mesh.encode` and its keyword arguments, with the
    mesh's vertex colours if it has some."""
    from . import encode

    kwargs.pop("resolver", None)
    if getattr(mesh.visual, "kind", None) == "vertex" and "colors" not in kwargs:
        kwargs["colors"] = mesh.visual.vertex_colors
    return encode(mesh.vertices, mesh.faces, **kwargs)


def register(only_if_imported: bool = False) -> bool:
    """Adds the ``qm`` loader and exporter to trimesh's registries; imports
    trimesh if it is installed (unless ``only_if_imported``). Returns whether
    trimesh is there. Importing qm_mesh calls it once."""
    if "trimesh" not in sys.modules:
        if only_if_imported or importlib.util.find_spec("trimesh") is None:
            return False
    try:
        from trimesh.exchange import export, load
    except ImportError:
        return False
    load.mesh_loaders["qm"] = load_qm
    export._mesh_exporters["qm"] = export_qm
    return True
