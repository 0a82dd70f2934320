"""Fixtures: meshes from the repository's assets/, encoded once per session."""

import os
from pathlib import Path

import pytest

import qm_mesh

ROOT = Path(__file__).resolve().parents[3]
ASSETS = ROOT / "assets"


@pytest.fixture(scope="session")
def cube():
    """A Catmull-Clark cube (6,146 vertices, 5 levels): a quad mesh with
    subdivision connectivity, coded as it is."""
    return qm_mesh.read(ASSETS / "quad" / "cc_cube.obj")


@pytest.fixture(scope="session")
def cube_qm(cube):
    return qm_mesh.encode(*cube)


@pytest.fixture(scope="session")
def spot():
    """Keenan Crane's spot (2,930 vertices, triangles): remeshed to encode."""
    return qm_mesh.read(ASSETS / "spot.obj")


@pytest.fixture(scope="session")
def spot_qm(spot):
    return qm_mesh.encode(*spot)


@pytest.fixture(scope="session")
def qm_cli():
    """The `qm` command-line tool, the native decoder to compare with: $QM_CLI,
    else a build in the repository's target/; None if there is none (not
    the PATH: Proxmox has a `qm` of its own)."""
    candidates = [os.environ.get("QM_CLI")]
    candidates += [str(ROOT / "target" / p / "qm") for p in ("release", "debug")]
    for c in candidates:
        if c and os.access(c, os.X_OK) and Path(c).is_file():
            return c
    return None
