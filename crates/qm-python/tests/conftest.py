"""Fixtures: meshes from the repository's assets/, encoded once per session,
and a coloured file from the qm-wasm example `coloured`."""

import os
import subprocess
from pathlib import Path

import numpy as np
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


@pytest.fixture(scope="session")
def coloured_qm(tmp_path_factory):
    """A bumpy sphere with a colour per vertex, ``(data, rgb)``: the bytes of
    the ``.qm`` file the qm-wasm example ``coloured`` writes ($QM_COLOURED,
    else a build in target/; `.ci/python` builds it), and the colours the
    whole file decodes to at its finest level, uint8 (n, 3). Skips without
    the example: qm_mesh cannot encode colours yet."""
    candidates = [os.environ.get("QM_COLOURED")]
    candidates += [str(ROOT / "target" / p / "examples" / "coloured") for p in ("release", "debug")]
    example = next((c for c in candidates if c and os.access(c, os.X_OK) and Path(c).is_file()), None)
    if example is None:
        pytest.skip("no coloured example: cargo build --release -p qm-wasm --example coloured")
    path = tmp_path_factory.mktemp("coloured") / "coloured.qm"
    subprocess.run([example, str(path)], check=True)
    rgb = np.frombuffer(path.with_suffix(".rgb").read_bytes(), dtype=np.uint8).reshape(-1, 3)
    return path.read_bytes(), rgb
