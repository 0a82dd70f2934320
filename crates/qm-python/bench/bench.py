"""Benchmark of qm_mesh.decode: against the native decoder, and against
DracoPy at equal PSNR.

    python crates/qm-python/bench/bench.py [MESH] [--runs N] [--samples N]

MESH defaults to the Stanford bunny of the development models
(../shared/models/stanford-bunny.obj beside the checkout). Needs qm_mesh
installed (pip install ./crates/qm-python), DracoPy for the second table
(pip install DracoPy), and cargo for the native timing (`cargo xtask
decode-time`, a release build). Prints Markdown tables; times are medians.

1. Python ``qm_mesh.decode`` against the facade's ``qm::decode`` timed in
   Rust, on the whole file and on prefixes, with default options (the level
   the bytes support). The Python figure includes making the numpy arrays.
2. For each Draco quantization (``-qp`` 8 to 14, compression level 10),
   the bytes, PSNR and decode time of Draco, and of the shortest ``.qm``
   prefix ending at a pass whose PSNR is at least Draco's. PSNR is
   20 log10(bbox diagonal / RMS), RMS the symmetric surface distance to the
   input (``qm_mesh.distance``, as ``qm distance`` measures).
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

import qm_mesh

ROOT = Path(__file__).resolve().parents[3]


def median_ms(f, runs: int) -> float:
    f()
    times = []
    for _ in range(runs):
        t = time.perf_counter()
        f()
        times.append((time.perf_counter() - t) * 1e3)
    return statistics.median(times)


def native_ms(path: Path, cuts: list[int], runs: int) -> dict[int, float]:
    args = ["cargo", "xtask", "decode-time", str(path), "--runs", str(runs)]
    for c in cuts:
        args += ["--bytes", str(c)]
    out = subprocess.run(args, cwd=ROOT, check=True, capture_output=True, text=True).stdout
    rows = [json.loads(line) for line in out.splitlines() if line.startswith("{")]
    return {r["bytes"]: r["ms"] for r in rows}


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("mesh", nargs="?", default=str(ROOT.parent / "shared" / "models" / "stanford-bunny.obj"))
    p.add_argument("--runs", type=int, default=21)
    p.add_argument("--samples", type=int, default=300_000, help="distance samples per direction")
    p.add_argument("--no-draco", action="store_true")
    a = p.parse_args()

    mesh = Path(a.mesh)
    vertices, faces = qm_mesh.read(mesh)
    cache = ROOT / "target" / "bench" / (mesh.stem + ".qm")
    cache.parent.mkdir(parents=True, exist_ok=True)
    if not cache.exists():
        t = time.perf_counter()
        cache.write_bytes(qm_mesh.encode(vertices, faces))
        print(f"encoded {mesh.name} in {time.perf_counter() - t:.1f} s", file=sys.stderr)
    data = cache.read_bytes()
    table = qm_mesh.info(data)
    rows = table["levels"]

    # 1. Python against native.
    cuts = [len(data) // 16, len(data) // 4, len(data)]
    native = native_ms(cache, cuts, a.runs)
    print(f"\n{mesh.name}: {len(vertices)} vertices in, {len(data)} bytes, level {table['level']}\n")
    print("| prefix | bytes | level | vertices | native qm::decode ms | Python decode ms | Python / native |")
    print("|---|---|---|---|---|---|---|")
    for c in cuts:
        d = qm_mesh.decode(data[:c])
        ms = median_ms(lambda: qm_mesh.decode(data[:c]), a.runs)
        print(
            f"| {c / len(data):.3g} | {c} | {d.level} | {len(d.vertices)} | {native[c]:.2f} | {ms:.2f} "
            f"| {ms / native[c]:.3f} |"
        )
    if a.no_draco:
        return

    # 2. Against DracoPy at equal PSNR.
    import DracoPy

    def psnr(v, f) -> float:
        return qm_mesh.distance((vertices, faces), (v, f), samples=a.samples).psnr_db

    measured = []  # (bytes, psnr) of each pass end
    for r in rows:
        d = qm_mesh.decode(data[: r["bytes"]])
        measured.append((r["bytes"], psnr(d.vertices, d.faces)))
    print("\n| Draco -qp | Draco bytes | Draco dB | Draco decode ms | qm bytes | qm dB | qm decode ms | qm / Draco bytes |")
    print("|---|---|---|---|---|---|---|---|")
    points = np.ascontiguousarray(vertices, dtype=np.float32)
    for q in range(8, 15):
        buf = DracoPy.encode(points, faces.astype(np.uint32), quantization_bits=q, compression_level=10)
        dm = DracoPy.decode(buf)
        draco_db = psnr(np.asarray(dm.points, dtype=np.float64), np.asarray(dm.faces).reshape(-1, 3))
        draco_ms = median_ms(lambda: DracoPy.decode(buf), a.runs)
        hit = next(((b, db) for b, db in measured if db >= draco_db), None)
        if hit is None:
            print(f"| {q} | {len(buf)} | {draco_db:.1f} | {draco_ms:.2f} | - | below | - | - |")
            continue
        b, db = hit
        qm_ms = median_ms(lambda: qm_mesh.decode(data[:b]), a.runs)
        print(
            f"| {q} | {len(buf)} | {draco_db:.1f} | {draco_ms:.2f} | {b} | {db:.1f} | {qm_ms:.2f} "
            f"| {b / len(buf):.2f} |"
        )


if __name__ == "__main__":
    main()
