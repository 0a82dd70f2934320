//! `qm_mesh._native`: the Python module of qm (PyO3, numpy), a skin over the
//! facade crate [`qm`].
//!
//! It converts and nothing else: numpy arrays to [`qm::PolyMesh`] and back,
//! keyword arguments to [`qm::Options`] and [`qm::DecodeOptions`], the
//! facade's [`qm::Error`] to the exception classes of `qm_mesh/_errors.py`
//! ([`errors`]), and threads: encoding, decoding and distances run with the
//! GIL released. The Python package around it (`python/qm_mesh`) checks
//! dtypes and shapes, registers the trimesh loader and exporter, and
//! carries the documentation.

mod errors;

use std::sync::{Mutex, MutexGuard};

use numpy::ndarray::{Array2, Array3};
use numpy::{IntoPyArray, PyArray2, PyArray3, PyArrayMethods, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict, PyString};

use errors::{ParameterError, to_py};
use qm::io::glam::DVec3;
use qm::{DecodeOptions, LevelChoice, Limits, PolyMesh};

/// A numpy `(n, 3)` array of positions and an `(m, k)` array of corner
/// indices as a [`PolyMesh`]; `what` names the mesh in messages.
fn poly_mesh(
    vertices: &PyReadonlyArray2<'_, f64>,
    faces: &PyReadonlyArray2<'_, i64>,
    what: &str,
) -> PyResult<PolyMesh> {
    let v = vertices.as_array();
    let f = faces.as_array();
    let (n, k) = (v.nrows(), f.ncols());
    if v.ncols() != 3 {
        return Err(ParameterError::new_err(format!(
            "{what}vertices must have shape (n, 3), not {:?}",
            v.shape()
        )));
    }
    if k < 3 {
        return Err(ParameterError::new_err(format!(
            "{what}faces must have shape (m, 3) or (m, 4), not {:?}",
            f.shape()
        )));
    }
    // Indices and offsets are 32-bit in qm (`qm::io::Problem::TooMany`).
    let max = u64::from(u32::MAX);
    if n as u64 > max || (f.nrows() as u64).saturating_mul(k as u64) > max {
        return Err(errors::LimitError::new_err(format!(
            "{what}{n} vertices and {} face corners: at most {max} each are supported",
            f.len()
        )));
    }
    let positions = v
        .rows()
        .into_iter()
        .map(|r| DVec3::new(r[0], r[1], r[2]))
        .collect();
    let mut mesh = PolyMesh::new();
    mesh.positions = positions;
    let mut corners = Vec::with_capacity(k);
    for (i, row) in f.rows().into_iter().enumerate() {
        corners.clear();
        for &c in row {
            match u32::try_from(c) {
                Ok(c) if (c as usize) < n => corners.push(c),
                _ => {
                    return Err(ParameterError::new_err(format!(
                        "{what}face {i} refers to vertex {c}, but there are {n} vertices"
                    )));
                }
            }
        }
        mesh.push_face(&corners);
    }
    Ok(mesh)
}

/// Positions as a numpy `(n, 3)` float64 array, without a second copy.
fn positions_array<'py>(py: Python<'py>, positions: &[DVec3]) -> Bound<'py, PyArray2<f64>> {
    let flat: Vec<f64> = positions.iter().flat_map(|p| p.to_array()).collect();
    rows(py, flat, 3)
}

/// A flat vector as a numpy array of rows of `k`, without a copy.
fn rows<'py, T: numpy::Element>(
    py: Python<'py>,
    flat: Vec<T>,
    k: usize,
) -> Bound<'py, PyArray2<T>> {
    let n = flat.len() / k;
    Array2::from_shape_vec((n, k), flat)
        .expect("a whole number of rows")
        .into_pyarray(py)
}

/// A texture atlas and its quads' corner coordinates as numpy arrays:
/// `(h, w, 3)` uint8 and `(m, 4, 2)` float32.
type TextureArrays = (Py<PyArray3<u8>>, Py<PyArray3<f32>>);

/// [`TextureArrays`] of `atlas` and `corners` (four a quad).
fn texture_arrays(
    py: Python<'_>,
    atlas: &qm::codec::Atlas,
    corners: Vec<[f32; 2]>,
) -> TextureArrays {
    let (w, h) = (atlas.width as usize, atlas.height as usize);
    let image = Array3::from_shape_vec((h, w, 3), atlas.texels.as_flattened().to_vec())
        .expect("width x height texels");
    let quads = corners.len() / 4;
    let uv = Array3::from_shape_vec((quads, 4, 2), corners.as_flattened().to_vec())
        .expect("four corners a quad");
    (
        image.into_pyarray(py).unbind(),
        uv.into_pyarray(py).unbind(),
    )
}

/// The faces of a mesh as a numpy array: `(m, k)` when every face has `k`
/// corners, else fanned into triangles (`a b c`, `a c d`, ...).
fn faces_array<'py>(py: Python<'py>, mesh: &PolyMesh) -> Bound<'py, PyArray2<u32>> {
    let k = mesh.faces().next().map_or(3, <[u32]>::len);
    let mut flat = Vec::new();
    if mesh.all_faces_have(k) {
        flat.reserve(k * mesh.face_count());
        mesh.faces().for_each(|f| flat.extend_from_slice(f));
        return rows(py, flat, k);
    }
    for f in mesh.faces() {
        for pair in f[1..].windows(2) {
            flat.extend_from_slice(&[f[0], pair[0], pair[1]]);
        }
    }
    rows(py, flat, 3)
}

/// A numpy `(n, 4)` float32 array of RGBA colours (sRGB, 0..1, as
/// `qm_mesh.encode` makes it) for a mesh of `n` vertices.
fn vertex_colours(colours: &PyReadonlyArray2<'_, f32>, n: usize) -> PyResult<Vec<[f32; 4]>> {
    let c = colours.as_array();
    if c.shape() != [n, 4] {
        return Err(ParameterError::new_err(format!(
            "colors must have shape ({n}, 4), one RGBA colour per vertex, not {:?}",
            c.shape()
        )));
    }
    Ok(c.rows()
        .into_iter()
        .map(|r| [r[0], r[1], r[2], r[3]])
        .collect())
}

/// `None` or `"auto"`, `"finest"`, or a level number.
fn level_choice(level: Option<&Bound<'_, PyAny>>) -> PyResult<LevelChoice> {
    let Some(level) = level.filter(|l| !l.is_none()) else {
        return Ok(LevelChoice::Auto);
    };
    if let Ok(text) = level.cast::<PyString>() {
        return match text.to_cow()?.as_ref() {
            "auto" => Ok(LevelChoice::Auto),
            "finest" => Ok(LevelChoice::Finest),
            other => Err(ParameterError::new_err(format!(
                "level must be 'auto', 'finest' or a level number, not {other:?}"
            ))),
        };
    }
    match level.extract::<i64>() {
        Ok(l) if (0..=i64::from(qm::lift::MAX_LEVEL)).contains(&l) => {
            Ok(LevelChoice::Fixed(l as u32))
        }
        _ => Err(ParameterError::new_err(format!(
            "level must be 'auto', 'finest' or a level from 0 to {}, not {}",
            qm::lift::MAX_LEVEL,
            level.repr()?
        ))),
    }
}

/// A value that must be finite and at least 0.
fn non_negative(what: &str, value: f64) -> PyResult<f64> {
    if value.is_finite() && value >= 0.0 {
        Ok(value)
    } else {
        Err(ParameterError::new_err(format!(
            "{what} must be a finite number, 0 or more, not {value}"
        )))
    }
}

/// The decoder options of `decode` and `StreamDecoder`, made once by
/// `qm_mesh._decode_options` from their keyword arguments.
#[pyclass(frozen, name = "DecodeOptions", module = "qm_mesh")]
struct Decoding(DecodeOptions);

#[pymethods]
impl Decoding {
    #[new]
    #[pyo3(signature = (max_bytes, max_error, level, max_triangles, passes, tolerance_db,
        max_memory))]
    fn new(
        max_bytes: Option<usize>,
        max_error: Option<f64>,
        level: Option<&Bound<'_, PyAny>>,
        max_triangles: Option<u64>,
        passes: Option<u32>,
        tolerance_db: f64,
        max_memory: Option<u64>,
    ) -> PyResult<Self> {
        let limits = max_memory.map_or(Limits::DEFAULT, |m| Limits::DEFAULT.with_max_memory(m));
        let max_error = max_error
            .map(|e| non_negative("max_error", e))
            .transpose()?;
        Ok(Decoding(
            DecodeOptions::default()
                .with_max_bytes(max_bytes)
                .with_max_error(max_error)
                .with_level(level_choice(level)?)
                .with_max_triangles(max_triangles)
                .with_passes(passes)
                .with_tolerance_db(non_negative("tolerance_db", tolerance_db)?)
                .with_limits(limits),
        ))
    }
}

/// A decoded mesh: numpy arrays and what the decoder says of them.
#[pyclass(frozen, get_all, module = "qm_mesh")]
struct Decoded {
    /// Vertex positions, float64, shape (n, 3).
    vertices: Py<PyArray2<f64>>,
    /// Quads as vertex indices, counter-clockwise, uint32, shape (m, 4).
    faces: Py<PyArray2<u32>>,
    /// For a file with colours: one 8-bit sRGB colour per vertex, uint8,
    /// shape (n, 3); None for a file without.
    colors: Option<Py<PyArray2<u8>>>,
    /// For a file whose colours reached a finer level than the mesh: those
    /// colours as a texture atlas, 8-bit sRGB, uint8, shape (h, w, 3), rows
    /// from the top; else None.
    texture: Option<Py<PyArray3<u8>>>,
    /// With a texture: each quad corner's texture coordinates, (0, 0) at
    /// the image's top-left corner, float32, shape (m, 4, 2); else None.
    face_uvs: Option<Py<PyArray3<f32>>>,
    /// The subdivision level of the mesh (0 is the base mesh).
    level: u32,
    /// The file's finest level.
    finest_level: u32,
    /// Bit-plane passes decoded completely.
    passes: u32,
    /// Bit-plane passes in the complete file.
    total_passes: u32,
    /// Whether the bytes ended inside a pass (more bytes would refine it).
    truncated: bool,
    /// Bytes of the input the mesh used.
    bytes_used: usize,
    /// The decoder's estimate of the RMS distance, in model units, from
    /// the complete file's finest mesh.
    error: f64,
    /// The same as PSNR against the bounding-box diagonal, in dB.
    psnr_db: f64,
}

#[pymethods]
impl Decoded {
    /// The quads split into triangles along their first diagonal (`a b c`,
    /// `a c d`), uint32, shape (2m, 3).
    #[getter]
    fn triangles<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<u32>>> {
        let quads = self.faces.bind(py).readonly();
        let flat = quads
            .as_array()
            .rows()
            .into_iter()
            .flat_map(|q| [q[0], q[1], q[2], q[0], q[2], q[3]])
            .collect();
        Ok(rows(py, flat, 3))
    }

    fn __repr__(&self, py: Python<'_>) -> String {
        format!(
            "Decoded(level={} of {}, {} vertices, {} quads, passes={} of {}, truncated={}, \
             bytes_used={}, error={:.3e}, psnr_db={:.2})",
            self.level,
            self.finest_level,
            self.vertices.bind(py).len().unwrap_or(0),
            self.faces.bind(py).len().unwrap_or(0),
            self.passes,
            self.total_passes,
            if self.truncated { "True" } else { "False" },
            self.bytes_used,
            self.error,
            self.psnr_db
        )
    }
}

/// Compresses a mesh (see `qm_mesh.encode`).
#[pyfunction]
#[pyo3(signature = (vertices, faces, bits, passes, max_bytes, holds, frames, remesh_level,
    normal_remesh, base_domain, accept_folds, min_remesh_psnr, max_memory, colors))]
#[allow(clippy::too_many_arguments)]
fn encode<'py>(
    py: Python<'py>,
    vertices: PyReadonlyArray2<'py, f64>,
    faces: PyReadonlyArray2<'py, i64>,
    bits: u32,
    passes: Option<u32>,
    max_bytes: Option<usize>,
    holds: bool,
    frames: bool,
    remesh_level: Option<u32>,
    normal_remesh: bool,
    base_domain: &str,
    accept_folds: bool,
    min_remesh_psnr: f64,
    max_memory: Option<u64>,
    colors: Option<PyReadonlyArray2<'py, f32>>,
) -> PyResult<Bound<'py, PyBytes>> {
    let mut asset = qm::Asset::default();
    asset.mesh = poly_mesh(&vertices, &faces, "")?;
    let n = asset.mesh.positions.len();
    asset.colors = colors.map(|c| vertex_colours(&c, n)).transpose()?;
    let domain = match base_domain {
        "auto" => qm::param::BaseDomain::Auto,
        "square" => qm::param::BaseDomain::Square,
        "charts" => qm::param::BaseDomain::Charts,
        "input" => qm::param::BaseDomain::Input,
        other => {
            return Err(ParameterError::new_err(format!(
                "base_domain must be 'auto', 'square', 'charts' or 'input', not {other:?}"
            )));
        }
    };
    let defaults = qm::RemeshOptions::DEFAULT;
    let remesh = defaults
        .with_level(remesh_level)
        .with_normal(normal_remesh)
        .with_max_memory(max_memory.unwrap_or(defaults.max_memory))
        .with_accept_folds(accept_folds)
        .with_domain(domain)
        .with_min_psnr(non_negative("min_remesh_psnr", min_remesh_psnr)?);
    let mut code = qm::EncodeOptions::DEFAULT
        .with_bits(bits)
        .with_passes(passes)
        .with_max_bytes(max_bytes)
        .with_holds(holds);
    if !frames {
        // As `qm compress --no-frames`: world axes, no extra normal weight.
        code = code
            .with_frames(false)
            .with_weighting(qm::Weighting::LEVELS);
    }
    let options = qm::Options::default().with_remesh(remesh).with_encode(code);
    let encoded = py
        .detach(|| qm::encode_asset(&asset, &options))
        .map_err(to_py)?;
    Ok(PyBytes::new(py, &encoded.bytes))
}

/// Decompresses `.qm` bytes or a prefix of them (see `qm_mesh.decode`).
#[pyfunction]
fn decode(py: Python<'_>, data: &[u8], options: &Decoding) -> PyResult<Decoded> {
    let options = options.0;
    let (decoded, flat, quads, colours, corners) = py
        .detach(|| {
            let d = qm::decode(data, &options)?;
            // The arrays' contents are made here too, without the GIL.
            let flat: Vec<f64> = d.mesh.positions.iter().flat_map(|p| p.to_array()).collect();
            let quads: Vec<u32> = d.mesh.faces().flatten().copied().collect();
            let colours = d.colours().map(|c| c.as_flattened().to_vec());
            let corners = d.corner_texcoords();
            Ok::<_, qm::Error>((d, flat, quads, colours, corners))
        })
        .map_err(to_py)?;
    let texture =
        (decoded.texture().zip(corners)).map(|(atlas, corners)| texture_arrays(py, atlas, corners));
    let (texture, face_uvs) = texture.unzip();
    Ok(Decoded {
        vertices: rows(py, flat, 3).unbind(),
        faces: rows(py, quads, 4).unbind(),
        colors: colours.map(|c| rows(py, c, 3).unbind()),
        texture,
        face_uvs,
        level: decoded.level(),
        finest_level: u32::from(decoded.raw.header.level),
        passes: decoded.passes(),
        total_passes: u32::from(decoded.raw.header.passes),
        truncated: decoded.truncated(),
        bytes_used: decoded.bytes_used(),
        error: decoded.error_estimate(),
        psnr_db: decoded.psnr_estimate(),
    })
}

/// The header of `.qm` bytes and what each pass's prefix decodes to (see
/// `qm_mesh.info`).
#[pyfunction]
#[pyo3(signature = (data, max_memory))]
fn info<'py>(
    py: Python<'py>,
    data: &[u8],
    max_memory: Option<u64>,
) -> PyResult<Bound<'py, PyDict>> {
    let limits = max_memory.map_or(Limits::DEFAULT, |m| Limits::DEFAULT.with_max_memory(m));
    let options = DecodeOptions::DEFAULT.with_limits(limits);
    let (decoder, table) = py
        .detach(|| {
            let decoder = qm::Decoder::new(data, &limits)?;
            let table = qm::prefix_table(data, &options)?;
            Ok::<_, qm::codec::Error>((decoder, table))
        })
        .map_err(|e| to_py(e.into()))?;
    let h = decoder.header();
    let out = PyDict::new(py);
    out.set_item("bytes", data.len())?;
    out.set_item("stream_start", decoder.stream_start())?;
    out.set_item("bits", h.bits)?;
    out.set_item("level", h.level)?;
    out.set_item("passes", h.passes)?;
    out.set_item("planes", h.planes)?;
    out.set_item("holds", h.holds.len())?;
    out.set_item("base_vertices", h.base_vertices)?;
    out.set_item("base_faces", h.base_faces)?;
    out.set_item("vertices", decoder.vertices_at(decoder.finest_level()))?;
    out.set_item("triangles", decoder.triangles_at(decoder.finest_level()))?;
    out.set_item("bbox_min", h.origin)?;
    out.set_item("step", h.step)?;
    let levels = table
        .iter()
        .map(|r| {
            let row = PyDict::new(py);
            row.set_item("bytes", r.bytes)?;
            row.set_item("passes", r.passes)?;
            row.set_item("level", r.level)?;
            row.set_item("vertices", r.vertices)?;
            row.set_item("triangles", r.triangles)?;
            row.set_item("error", r.error)?;
            row.set_item("psnr_db", r.psnr_db)?;
            Ok(row)
        })
        .collect::<PyResult<Vec<_>>>()?;
    out.set_item("levels", levels)?;
    Ok(out)
}

/// Vertices and faces as numpy arrays.
type Arrays<'py> = (Bound<'py, PyArray2<f64>>, Bound<'py, PyArray2<u32>>);

/// Reads a mesh file (see `qm_mesh.read`).
#[pyfunction]
fn read<'py>(py: Python<'py>, path: std::path::PathBuf) -> PyResult<Arrays<'py>> {
    let mesh = py.detach(|| qm::read_mesh(&path)).map_err(to_py)?;
    Ok((positions_array(py, &mesh.positions), faces_array(py, &mesh)))
}

/// Writes a mesh file (see `qm_mesh.write`).
#[pyfunction]
fn write<'py>(
    py: Python<'py>,
    path: std::path::PathBuf,
    vertices: PyReadonlyArray2<'py, f64>,
    faces: PyReadonlyArray2<'py, i64>,
) -> PyResult<()> {
    let mesh = poly_mesh(&vertices, &faces, "")?;
    py.detach(|| qm::write_mesh(&path, &mesh)).map_err(to_py)
}

/// The symmetric surface distance between two meshes.
#[pyclass(frozen, get_all, module = "qm_mesh")]
struct Distance {
    /// The larger of the two one-sided RMS distances.
    rms: f64,
    /// The larger of the two one-sided mean distances.
    mean: f64,
    /// The larger of the two one-sided largest distances found: the
    /// sampled Hausdorff distance.
    hausdorff: f64,
    /// `20 log10(diag / rms)`, in dB (infinite for coinciding surfaces).
    psnr_db: f64,
    /// The bounding-box diagonal of the first mesh.
    diag: f64,
    /// Samples taken on each surface.
    samples: (usize, usize),
}

#[pymethods]
impl Distance {
    fn __repr__(&self) -> String {
        format!(
            "Distance(rms={:.6e}, mean={:.6e}, hausdorff={:.6e}, psnr_db={:.3}, diag={:.6e})",
            self.rms, self.mean, self.hausdorff, self.psnr_db, self.diag
        )
    }
}

/// Measures the symmetric surface distance (see `qm_mesh.distance`).
#[pyfunction]
#[pyo3(signature = (vertices_a, faces_a, vertices_b, faces_b, samples, seed))]
fn distance<'py>(
    py: Python<'py>,
    vertices_a: PyReadonlyArray2<'py, f64>,
    faces_a: PyReadonlyArray2<'py, i64>,
    vertices_b: PyReadonlyArray2<'py, f64>,
    faces_b: PyReadonlyArray2<'py, i64>,
    samples: usize,
    seed: u64,
) -> PyResult<Distance> {
    let a = poly_mesh(&vertices_a, &faces_a, "mesh a: ")?;
    let b = poly_mesh(&vertices_b, &faces_b, "mesh b: ")?;
    let options = qm::param::distance::DistanceOptions::DEFAULT
        .with_samples(samples)
        .with_seed(seed);
    let r = py
        .detach(|| qm::param::distance(&a, &b, &options))
        .map_err(|e| to_py(e.into()))?;
    Ok(Distance {
        rms: r.rms,
        mean: r.mean,
        hausdorff: r.hausdorff,
        psnr_db: r.psnr_db,
        diag: r.diag,
        samples: (r.a_to_b.samples, r.b_to_a.samples),
    })
}

/// An incremental decoder: feed it the bytes of a `.qm` file as they
/// arrive; after each chunk, `mesh()` is what those bytes decode to.
///
/// It wraps the library's `StreamDecoder`, the one the WebAssembly decoder
/// and the command line use: `feed` resumes the bit-plane decoder where
/// the last chunk left it. Decoding runs with the GIL released; one
/// decoder may be shared between threads (calls take turns).
#[pyclass(module = "qm_mesh")]
struct StreamDecoder {
    inner: Mutex<qm::StreamDecoder>,
}

impl StreamDecoder {
    fn lock(&self) -> MutexGuard<'_, qm::StreamDecoder> {
        // A panic cannot leave the decoder half-changed in a way that
        // matters more than the panic itself, which Python already saw.
        self.inner.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// A value of the last refinement's mesh, or `none` before one.
    fn with_mesh<T>(&self, none: T, f: impl FnOnce(&qm::LevelMesh<'_>) -> T) -> T {
        self.lock().mesh().map_or(none, |m| f(&m))
    }
}

#[pymethods]
impl StreamDecoder {
    #[new]
    fn new(options: &Decoding) -> Self {
        StreamDecoder {
            inner: Mutex::new(qm::StreamDecoder::new(options.0)),
        }
    }

    /// Appends the next bytes of the file and decodes everything received
    /// so far. Returns whether the mesh changed (False while the header and
    /// base mesh are incomplete, or when the bytes change nothing, e.g.
    /// after an error goal was met). Raises as soon as the bytes show that
    /// the file is not `.qm`, is corrupt or exceeds the limits.
    fn feed(&self, py: Python<'_>, chunk: &[u8]) -> PyResult<bool> {
        py.detach(|| {
            let mut decoder = self.lock();
            if decoder.push(chunk)? {
                decoder.refine()
            } else {
                Ok(false)
            }
        })
        .map_err(|e| to_py(e.into()))
    }

    /// The mesh of the last chunk that changed it, or None before the
    /// header and base mesh are complete.
    fn mesh(&self, py: Python<'_>) -> Option<Decoded> {
        let decoder = self.lock();
        let m = decoder.mesh()?;
        let total_passes = decoder
            .decoder()
            .map_or(0, |d| u32::from(d.header().passes));
        let flat: Vec<u32> = m.quads().iter().flatten().copied().collect();
        let faces = (decoder.decoder().expect("a mesh has its decoder"))
            .layout()
            .face_count();
        let (texture, face_uvs) = (decoder.texture())
            .map(|(atlas, _)| {
                let corners = atlas.corner_texcoords(faces, m.level());
                texture_arrays(py, atlas, corners)
            })
            .unzip();
        Some(Decoded {
            vertices: positions_array(py, &m.positions()).unbind(),
            faces: rows(py, flat, 4).unbind(),
            colors: m
                .colours()
                .map(|c| rows(py, c.as_flattened().to_vec(), 3).unbind()),
            texture,
            face_uvs,
            level: m.level(),
            finest_level: decoder.finest_level(),
            passes: m.passes(),
            total_passes,
            truncated: m.truncated(),
            bytes_used: m.bytes_used(),
            error: m.error(),
            psnr_db: m.psnr_db(),
        })
    }

    /// Whether the header and base mesh have arrived.
    #[getter]
    fn ready(&self) -> bool {
        self.lock().ready()
    }

    /// Whether more bytes could still change the mesh (False once the
    /// whole file, the byte budget or the error goal is reached).
    #[getter]
    fn wants_more(&self) -> bool {
        self.lock().wants_more()
    }

    /// Bytes kept so far.
    #[getter]
    fn bytes_received(&self) -> usize {
        self.lock().bytes_received()
    }

    /// Before `ready`: the least total bytes the header and base mesh
    /// need, as far as known (0 once ready).
    #[getter]
    fn bytes_needed(&self) -> usize {
        self.lock().bytes_needed()
    }

    /// The estimated RMS error of the current mesh, in model units (NaN
    /// before the first mesh).
    #[getter]
    fn error(&self) -> f64 {
        self.with_mesh(f64::NAN, |m| m.error())
    }

    /// The same as PSNR against the bounding-box diagonal, in dB.
    #[getter]
    fn psnr_db(&self) -> f64 {
        self.with_mesh(f64::NAN, |m| m.psnr_db())
    }

    /// The level of the current mesh (None before the first mesh).
    #[getter]
    fn level(&self) -> Option<u32> {
        self.with_mesh(None, |m| Some(m.level()))
    }

    /// Changes whenever a refinement makes the texture anew (a file whose
    /// colour is finer than its geometry); while it stays, so do the
    /// texture and its coordinates.
    #[getter]
    fn texture_version(&self) -> u32 {
        self.lock().texture_version()
    }
}

/// The compiled half of `qm_mesh`.
#[pymodule(name = "_native")]
fn native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(encode, m)?)?;
    m.add_function(wrap_pyfunction!(decode, m)?)?;
    m.add_function(wrap_pyfunction!(info, m)?)?;
    m.add_function(wrap_pyfunction!(read, m)?)?;
    m.add_function(wrap_pyfunction!(write, m)?)?;
    m.add_function(wrap_pyfunction!(distance, m)?)?;
    m.add_class::<Decoding>()?;
    m.add_class::<Decoded>()?;
    m.add_class::<Distance>()?;
    m.add_class::<StreamDecoder>()?;
    m.add("DEFAULT_SAMPLES", qm::param::distance::DEFAULT_SAMPLES)?;
    m.add("DEFAULT_SEED", qm::param::distance::DEFAULT_SEED)?;
    m.add("DEFAULT_BITS", qm::lift::DEFAULT_BITS)?;
    m.add("DEFAULT_TOLERANCE_DB", qm::codec::DEFAULT_TOLERANCE_DB)?;
    m.add(
        "DEFAULT_MIN_REMESH_PSNR",
        qm::RemeshOptions::DEFAULT.min_psnr,
    )?;
    Ok(())
}
