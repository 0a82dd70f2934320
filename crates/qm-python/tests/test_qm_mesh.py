"""qm_mesh against the library: round trips, prefixes, streaming, errors,
trimesh, and the GIL released while decoding."""

import json
import subprocess
import threading
import time
from pathlib import Path

import numpy as np
import pytest

import qm_mesh
from qm_mesh import DataError, FileError, LimitError, ParameterError, QmError, TruncatedError

ROOT = Path(__file__).resolve().parents[3]


def same(a, b):
    """Two decoded meshes are the same, bit for bit."""
    assert a.vertices.dtype == np.float64 and a.faces.dtype == np.uint32
    assert np.array_equal(a.vertices, b.vertices)
    assert np.array_equal(a.faces, b.faces)
    assert (a.colors is None) == (b.colors is None)
    if a.colors is not None:
        assert a.colors.dtype == np.uint8 and np.array_equal(a.colors, b.colors)
    assert (a.level, a.passes, a.truncated, a.bytes_used) == (b.level, b.passes, b.truncated, b.bytes_used)
    assert a.error == b.error or (np.isnan(a.error) and np.isnan(b.error))


def cuts(data, stream_start, count=40):
    """Cuts from the end of the base mesh to the whole file."""
    return sorted({int(n) for n in np.linspace(stream_start, len(data), count)})


# Round trips


def test_a_quad_mesh_round_trips_to_its_quantized_self(cube, cube_qm):
    vertices, faces = cube
    assert faces.shape[1] == 4
    d = qm_mesh.decode(cube_qm)
    assert (d.level, d.finest_level, d.truncated, d.passes) == (5, 5, False, d.total_passes)
    assert d.vertices.shape == vertices.shape and d.faces.shape == faces.shape
    assert d.bytes_used == len(cube_qm)
    assert d.error == 0.0
    # Quantized to 16 bits of the bounding box: every vertex within a step
    # of an input vertex.
    step = np.ptp(vertices, axis=0).max() / 2**16
    nearest = max(np.sqrt(((vertices[None, :, :] - c[:, None, :]) ** 2).sum(-1).min(1).max()) for c in np.array_split(d.vertices, 16))
    assert nearest < step
    assert qm_mesh.distance(cube, d, samples=20_000).psnr_db > 90


def test_float32_and_int32_inputs_encode_as_their_float64_values(cube):
    vertices, faces = cube
    small = vertices.astype(np.float32)
    a = qm_mesh.encode(small, faces.astype(np.int32), holds=False)
    b = qm_mesh.encode(small.astype(np.float64), faces.astype(np.int64), holds=False)
    assert a == b
    assert isinstance(a, bytes)


def test_a_triangle_mesh_is_remeshed_and_decodes_close_to_it(spot, spot_qm):
    d = qm_mesh.decode(spot_qm)
    assert d.level == d.finest_level >= 3
    assert d.triangles.shape == (2 * len(d.faces), 3)
    assert np.array_equal(d.triangles[0::2], d.faces[:, [0, 1, 2]])
    assert np.array_equal(d.triangles[1::2], d.faces[:, [0, 2, 3]])
    r = qm_mesh.distance(spot, d, samples=50_000)
    assert r.psnr_db > 70, r


def test_read_and_write_keep_the_mesh_exactly(tmp_path, spot_qm):
    d = qm_mesh.decode(spot_qm, max_bytes=len(spot_qm) // 3)
    for name in ("m.ply", "m.obj"):
        qm_mesh.write(tmp_path / name, d.vertices, d.faces)
        vertices, faces = qm_mesh.read(str(tmp_path / name))
        assert np.array_equal(faces, d.faces)
        if name.endswith("ply"):  # binary float64: exact
            assert np.array_equal(vertices, d.vertices)
        else:
            assert np.allclose(vertices, d.vertices, rtol=1e-12, atol=0)


# Prefixes


def test_every_prefix_decodes_and_the_levels_table_says_what_to(spot_qm):
    table = qm_mesh.info(spot_qm)
    start = table["stream_start"]
    assert table["bytes"] == len(spot_qm)
    rows = table["levels"]
    assert rows[0]["bytes"] == start and rows[-1]["bytes"] == len(spot_qm)
    assert [r["bytes"] for r in rows] == sorted({r["bytes"] for r in rows})
    for r in rows:
        d = qm_mesh.decode(spot_qm[: r["bytes"]])
        assert (d.level, d.passes, d.error) == (r["level"], r["passes"], r["error"])
        assert len(d.vertices) == r["vertices"] and 2 * len(d.faces) == r["triangles"]
    last_error = np.inf
    for n in cuts(spot_qm, start):
        d = qm_mesh.decode(spot_qm[:n])
        same(d, qm_mesh.decode(spot_qm, max_bytes=n))
        assert d.bytes_used <= n
        assert d.truncated == (n < len(spot_qm) and d.passes < d.total_passes) or d.truncated
        assert d.error <= last_error * 1.0001 or d.level != d.finest_level
        last_error = min(last_error, d.error)
    with pytest.raises(TruncatedError):
        qm_mesh.decode(spot_qm[: start - 1])


def test_options_choose_the_level_the_goal_and_the_size(spot_qm):
    finest = qm_mesh.decode(spot_qm, level="finest", max_bytes=len(spot_qm) // 10)
    assert finest.level == finest.finest_level
    for level in range(finest.finest_level + 1):
        d = qm_mesh.decode(spot_qm, level=level)
        assert d.level == level
    auto = qm_mesh.decode(spot_qm, max_bytes=len(spot_qm) // 10)
    assert auto.level <= finest.level
    goal = qm_mesh.decode(spot_qm, max_error=1e-3)
    assert goal.error <= 1e-3 and goal.bytes_used < len(spot_qm)
    capped = qm_mesh.decode(spot_qm, max_triangles=5000)
    assert 2 * len(capped.faces) <= 5000


def test_prefixes_match_the_native_decoder_bit_for_bit(spot_qm, qm_cli, tmp_path):
    if qm_cli is None:
        pytest.skip("no qm command-line build to compare with (set QM_CLI)")
    path = tmp_path / "spot.qm"
    path.write_bytes(spot_qm)
    start = qm_mesh.info(spot_qm)["stream_start"]
    for n in cuts(spot_qm, start, 6):
        out = tmp_path / f"{n}.ply"
        subprocess.run([qm_cli, "decompress", str(path), "--bytes", str(n), "-o", str(out), "--quiet"], check=True)
        vertices, faces = qm_mesh.read(out)
        d = qm_mesh.decode(spot_qm, max_bytes=n)
        assert np.array_equal(vertices, d.vertices), n
        assert np.array_equal(faces, d.faces), n


def test_distance_is_the_command_lines(spot, spot_qm, qm_cli, tmp_path):
    d = qm_mesh.decode(spot_qm, max_bytes=len(spot_qm) // 4)
    r = qm_mesh.distance(spot, d, samples=30_000)
    assert 0 < r.rms <= r.hausdorff and r.mean <= r.rms
    assert r.psnr_db == pytest.approx(20 * np.log10(r.diag / r.rms))
    assert r.samples[0] > 29_000
    zero = qm_mesh.distance(spot, spot, samples=1000)
    assert zero.rms == 0 and zero.psnr_db == np.inf
    if qm_cli is None:
        pytest.skip("no qm command-line build to compare with (set QM_CLI)")
    qm_mesh.write(tmp_path / "d.ply", d.vertices, d.faces)
    qm_mesh.write(tmp_path / "spot.ply", *spot)
    out = subprocess.run(
        [qm_cli, "distance", str(tmp_path / "spot.ply"), str(tmp_path / "d.ply"), "--json", "--samples", "30000"],
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    native = json.loads(out)
    assert (r.rms, r.hausdorff, r.psnr_db) == (native["rms"], native["hausdorff"], native["psnr_db"])


# Streaming


def test_streaming_matches_decoding_each_prefix(spot_qm):
    decoder = qm_mesh.StreamDecoder()
    assert decoder.mesh() is None and not decoder.ready and np.isnan(decoder.error)
    shown = 0
    for i in range(0, len(spot_qm), 997):
        changed = decoder.feed(spot_qm[i : i + 997])
        n = decoder.bytes_received
        assert n == min(i + 997, len(spot_qm))
        if not decoder.ready:
            assert not changed and decoder.mesh() is None
            assert decoder.bytes_needed > n
            continue
        m = decoder.mesh()
        same(m, qm_mesh.decode(spot_qm[:n]))
        assert decoder.error == m.error and decoder.level == m.level
        shown += changed
    assert shown > 10
    assert not decoder.mesh().truncated and not decoder.wants_more


def test_colours_come_with_every_prefix_and_exactly_at_the_end(coloured_qm, cube_qm):
    data, rgb = coloured_qm
    whole = qm_mesh.decode(data, level="finest")
    assert not whole.truncated
    assert whole.colors.dtype == np.uint8 and whole.colors.shape == whole.vertices.shape
    assert np.array_equal(whole.colors, rgb)
    start = qm_mesh.info(data)["stream_start"]
    decoder = qm_mesh.StreamDecoder()
    errors = []
    for i in range(0, len(data), 401):
        if not decoder.feed(data[i : i + 401]):
            continue
        m = decoder.mesh()
        assert m.colors.shape == m.vertices.shape, f"one colour per vertex at {m.bytes_used} bytes"
        same(m, qm_mesh.decode(data[: decoder.bytes_received]))
        finest = qm_mesh.decode(data[: decoder.bytes_received], level="finest")
        errors.append(np.abs(finest.colors.astype(int) - rgb).mean())
    assert len(errors) > 5 and decoder.bytes_received > start
    assert errors[0] > 1 and errors[-1] == 0, f"mean colour error by prefix: {errors}"
    # A file without colours has none.
    assert qm_mesh.decode(cube_qm).colors is None


def test_a_texture_finer_than_the_mesh_comes_with_its_coordinates(cube_qm):
    # A textured cube: its texture's colours five levels finer than its
    # level-0 geometry (`qm compress` of a cube OBJ under a wave texture).
    data = (ROOT / "tests" / "data" / "textured_cube.qm").read_bytes()
    d = qm_mesh.decode(data)
    h, w, c = d.texture.shape
    assert d.texture.dtype == np.uint8 and c == 3
    assert d.face_uvs.dtype == np.float32 and d.face_uvs.shape == (len(d.faces), 4, 2)
    # Every corner sits on a texel centre inside the image, and each quad's
    # corners on distinct texels.
    texel = d.face_uvs * np.array([w, h], dtype=np.float32) - 0.5
    assert np.allclose(texel, np.round(texel), atol=1e-2)
    assert (texel > 0).all() and (texel < [w - 1, h - 1]).all()
    assert all(len({tuple(p) for p in np.round(q)}) == 4 for q in texel)
    # The streaming decoder gives the same; a prefix the same atlas, less refined.
    stream = qm_mesh.StreamDecoder()
    stream.feed(data)
    m = stream.mesh()
    assert np.array_equal(m.texture, d.texture) and np.array_equal(m.face_uvs, d.face_uvs)
    # A prefix: what decode() gives is what the streaming decoder shows
    # after the same bytes: the atlas of the whole file (its size is the
    # header's), with colours not yet refined.
    prefix = data[: len(data) // 3]
    cut = qm_mesh.decode(prefix)
    partial = qm_mesh.StreamDecoder()
    partial.feed(prefix)
    shown = partial.mesh()
    assert cut.texture is not None and shown.texture is not None
    assert np.array_equal(cut.texture, shown.texture)
    assert np.array_equal(cut.face_uvs, shown.face_uvs)
    assert cut.texture.shape == d.texture.shape
    assert not np.array_equal(cut.texture, d.texture)
    # Fed in pieces, the texture's version changes whenever the texture or
    # its coordinates do.
    pieces = qm_mesh.StreamDecoder()
    last = None
    versions = set()
    for i in range(0, len(data), 499):
        if not pieces.feed(data[i : i + 499]) or pieces.mesh().texture is None:
            continue
        m = pieces.mesh()
        now = (pieces.texture_version, m.texture.tobytes(), m.face_uvs.tobytes())
        if last is not None and now[0] == last[0]:
            assert now[1:] == last[1:], f"at {m.bytes_used} bytes"
        versions.add(now[0])
        last = now
    assert len(versions) > 3
    # A file without finer colours has none.
    assert qm_mesh.decode(cube_qm).texture is None and qm_mesh.decode(cube_qm).face_uvs is None


def test_a_streaming_goal_stops_wanting_bytes(spot_qm):
    decoder = qm_mesh.StreamDecoder(max_error=1e-3, level="finest")
    for i in range(0, len(spot_qm), 4096):
        decoder.feed(spot_qm[i : i + 4096])
        if decoder.ready and not decoder.wants_more:
            break
    m = decoder.mesh()
    assert m.error <= 1e-3 and m.level == m.finest_level
    assert decoder.bytes_received < len(spot_qm)


def test_a_corrupt_stream_fails_as_soon_as_it_shows(spot_qm):
    start = qm_mesh.info(spot_qm)["stream_start"]
    bad = bytearray(spot_qm)
    bad[start - 6] ^= 0x55  # inside the base section: its checksum fails
    decoder = qm_mesh.StreamDecoder()
    with pytest.raises(DataError, match="checksum"):
        decoder.feed(bytes(bad[:start]))
    with pytest.raises(DataError, match="not a .qm"):
        qm_mesh.StreamDecoder().feed(b"PK\x03\x04 not a qm file at all")


# Errors


@pytest.mark.parametrize(
    "call, kind, words",
    [
        (lambda q: qm_mesh.decode(b"solid cube\nfacet normal 0 0 1\n"), DataError, "not a .qm"),
        (lambda q: qm_mesh.decode(q[:20]), TruncatedError, "truncated"),
        (lambda q: qm_mesh.decode(q, max_memory=10_000), LimitError, "max_memory"),
        (lambda q: qm_mesh.decode(q, level="coarse"), ParameterError, "level"),
        (lambda q: qm_mesh.decode(q, level=-1), ParameterError, "level"),
        (lambda q: qm_mesh.decode(q, max_error=float("nan")), ParameterError, "max_error"),
        (lambda q: qm_mesh.decode(q, max_bytes=-1), ParameterError, "max_bytes"),
        (lambda q: qm_mesh.StreamDecoder(passes=1.5), ParameterError, "passes"),
        (lambda q: qm_mesh.info(b"\x89QM"), TruncatedError, "truncated"),
        (lambda q: qm_mesh.encode(np.zeros((4, 2)), [[0, 1, 2]]), ParameterError, "shape (n, 3)"),
        (lambda q: qm_mesh.encode(np.zeros((4, 3)), [[0, 1]]), ParameterError, "shape (m, 3)"),
        (lambda q: qm_mesh.encode(np.zeros((4, 3)), [[0.0, 1, 2]]), ParameterError, "integers"),
        (lambda q: qm_mesh.encode(np.zeros((4, 3)), [[0, 1, 9]]), ParameterError, "vertex 9"),
        (lambda q: qm_mesh.encode(np.zeros((4, 3)), [[0, 1, -1]]), ParameterError, "vertex -1"),
        (lambda q: qm_mesh.encode([["a", "b", "c"]], [[0, 0, 0]]), ParameterError, "real numbers"),
        (lambda q: qm_mesh.encode(np.zeros((3, 3)), [[0, 1, 2]]), DataError, ""),
        (lambda q: qm_mesh.encode(np.eye(3), [[0, 1, 2]], bits=40), ParameterError, "bits"),
        (lambda q: qm_mesh.encode(np.eye(3), [[0, 1, 2]], base_domain="round"), ParameterError, "base_domain"),
        (lambda q: qm_mesh.encode(np.eye(3), [[0, 1, 2]], max_memory=1000), LimitError, "max_memory"),
        (lambda q: qm_mesh.read("no such file.obj"), FileError, "no such file.obj"),
        (lambda q: qm_mesh.write("m.stl", np.eye(3), [[0, 1, 2]]), ParameterError, "unsupported output"),
        (lambda q: qm_mesh.distance((np.eye(3), [[0, 1, 2]]), "mesh"), ParameterError, "mesh b"),
        (lambda q: qm_mesh.distance((np.eye(3), [[0, 1, 2]]), (np.eye(3), [[0, 1, 2]]), samples=0), ParameterError, "sample"),
        (lambda q: qm_mesh.decode(12345), TypeError, "bytes-like"),
    ],
)
def test_bad_input_raises_typed_errors_that_say_what_was_wrong(spot_qm, call, kind, words):
    with pytest.raises(kind) as caught:
        call(spot_qm)
    if issubclass(kind, QmError):
        assert isinstance(caught.value, QmError)
    assert words.lower() in str(caught.value).lower()


def test_error_classes_are_also_the_builtin_ones():
    assert issubclass(DataError, ValueError) and issubclass(ParameterError, ValueError)
    assert issubclass(TruncatedError, DataError)
    assert issubclass(FileError, OSError)
    assert not issubclass(LimitError, ValueError)


def test_a_garbage_mesh_file_is_a_data_error(tmp_path):
    path = tmp_path / "bad.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nf 1 2 7\n")
    with pytest.raises(DataError, match="line 3"):
        qm_mesh.read(path)


# trimesh


def test_trimesh_loads_and_exports_qm(tmp_path, spot, spot_qm):
    trimesh = pytest.importorskip("trimesh")
    path = tmp_path / "spot.qm"
    path.write_bytes(spot_qm)
    mesh = trimesh.load_mesh(path, process=False)
    assert isinstance(mesh, trimesh.Trimesh)
    # The legacy `trimesh.load` returns a bare Trimesh only for the formats
    # in a list of its own; for others, a Scene of the one mesh, or the mesh
    # with force="mesh".
    assert isinstance(trimesh.load(path, force="mesh", process=False), trimesh.Trimesh)
    scene = trimesh.load(path, process=False)
    assert np.array_equal(list(scene.geometry.values())[0].vertices, mesh.vertices)
    d = qm_mesh.decode(spot_qm)
    assert np.array_equal(mesh.vertices, d.vertices)
    assert np.array_equal(mesh.faces, d.triangles)
    assert mesh.metadata["qm"]["level"] == d.level
    coarse = trimesh.load_mesh(str(path), max_error=1e-3, process=False)
    assert len(coarse.vertices) < len(mesh.vertices) or coarse.metadata["qm"]["error"] <= 1e-3
    # Exporting re-encodes: the triangles of the decoded quads remesh again.
    source = trimesh.Trimesh(*spot, process=False)
    out = tmp_path / "again.qm"
    source.export(out, bits=14)
    again = trimesh.load_mesh(out)
    assert qm_mesh.info(out.read_bytes())["bits"] == 14
    assert qm_mesh.distance(source, again, samples=20_000).psnr_db > 65


def field(vertices):
    """A smooth sRGB colour field over a mesh, uint8 (n, 3)."""
    waves = np.sin(vertices @ np.array([[3.0, 0.0, -2.0], [0.0, -2.5, 2.0], [1.0, 2.0, -3.0]]))
    return np.round(127.5 + 110 * waves).astype(np.uint8)


def test_colors_encode_with_the_geometry_and_decode_at_every_prefix(cube, cube_qm):
    vertices, faces = cube
    rgb = field(vertices)
    data = qm_mesh.encode(vertices, faces, colors=rgb)
    assert data != cube_qm and len(data) > len(cube_qm)
    assert qm_mesh.encode(vertices, faces, colors=rgb.astype(np.float32) / 255) == data
    assert qm_mesh.encode(vertices, faces, colors=np.c_[rgb, np.full(len(rgb), 7, np.uint8)]) == data
    d = qm_mesh.decode(data, level="finest")
    assert not d.truncated and d.colors.shape == d.vertices.shape
    # The surface's colour at each sample: the field at the decoded
    # vertex, within the rounding of a colour sampled near the vertex.
    error = np.abs(d.colors.astype(int) - field(d.vertices).astype(int))
    assert error.mean() < 1.0 and error.max() <= 8, (error.mean(), error.max())
    start = qm_mesh.info(data)["stream_start"]
    for n in cuts(data, start, 8):
        p = qm_mesh.decode(data[:n])
        assert p.colors.shape == p.vertices.shape
    for bad in (rgb[1:], rgb[:, :2], rgb.astype(np.int32), rgb / 100.0):
        with pytest.raises(ParameterError, match="colors"):
            qm_mesh.encode(vertices, faces, colors=bad)


def test_trimesh_exports_vertex_colours(tmp_path, cube):
    trimesh = pytest.importorskip("trimesh")
    vertices, faces = cube
    mesh = trimesh.Trimesh(vertices, faces, vertex_colors=field(vertices), process=False)
    path = tmp_path / "coloured-cube.qm"
    mesh.export(path)
    back = trimesh.load_mesh(path, level="finest", process=False)
    error = np.abs(back.visual.vertex_colors[:, :3].astype(int) - field(back.vertices).astype(int))
    assert error.mean() < 1.0


def test_trimesh_loads_colours_as_vertex_colours(tmp_path, coloured_qm, spot_qm):
    trimesh = pytest.importorskip("trimesh")
    data, rgb = coloured_qm
    path = tmp_path / "coloured.qm"
    path.write_bytes(data)
    mesh = trimesh.load_mesh(path, level="finest", process=False)
    assert mesh.visual.kind == "vertex"
    assert np.array_equal(mesh.visual.vertex_colors[:, :3], rgb)
    plain = tmp_path / "spot.qm"
    plain.write_bytes(spot_qm)
    assert trimesh.load_mesh(plain, process=False).visual.kind is None


# Threads


def test_two_threads_decode_at_once(spot_qm):
    """With the GIL released, two decodes run at the same time: the calls
    of the two threads overlap for most of their duration. Were the GIL
    held, a call could start only once the other thread's call ended."""
    qm_mesh.decode(spot_qm)
    spans = [[], []]
    barrier = threading.Barrier(2)

    def work(i):
        barrier.wait()
        for _ in range(4):
            t0 = time.perf_counter()
            qm_mesh.decode(spot_qm, level="finest")
            spans[i].append((t0, time.perf_counter()))

    threads = [threading.Thread(target=work, args=(i,)) for i in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    overlap = sum(max(0.0, min(a1, b1) - max(a0, b0)) for a0, a1 in spans[0] for b0, b1 in spans[1])
    busy = min(sum(t1 - t0 for t0, t1 in s) for s in spans)
    assert overlap > 0.5 * busy, (overlap, busy, spans)
