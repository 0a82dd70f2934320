//! qm: progressive compression of meshes.
//!
//! A mesh goes in; an *embedded* bitstream comes out, and any prefix of that
//! stream decodes to a crack-free mesh whose error falls as more bytes
//! arrive. The pipeline is a ladder of crates, each usable alone:
//!
//! | module | crate | owns |
//! |---|---|---|
//! | [`lift`] | `qm-lift` | base quad meshes, sample layouts, quantization, the integer lifting transform |
//! | [`tree`] | `qm-tree` | zerotrees over edge and face coefficients |
//! | [`ezw`] | `qm-ezw` | bit-plane zerotree coding, the arithmetic coder |
//! | [`io`] | `qm-io` | the `.qm` container, the codec driver, mesh files |
//! | [`param`] | `qm-param` | input mesh to semi-regular mesh |
//!
//! ```no_run
//! # fn main() -> qm::Result<()> {
//! let mesh = qm::read_mesh("model.obj".as_ref())?;
//! let prepared = qm::prepare(&mesh, &qm::RemeshOptions::DEFAULT)?;
//! let compressed = qm::compress_against(&prepared.mesh, &mesh, &qm::EncodeOptions::DEFAULT)?;
//! // Any prefix after the base mesh decodes.
//! let cut = &compressed.bytes[..compressed.bytes.len() / 2];
//! let decoded = qm::decompress(cut, &qm::DecodeOptions::default())?;
//! qm::write_mesh("coarse.obj".as_ref(), &decoded.to_polymesh())?;
//! # Ok(()) }
//! ```

mod error;

pub use error::{Error, Result};
pub use qm_ezw as ezw;
pub use qm_io as io;
pub use qm_lift as lift;
pub use qm_param as param;
pub use qm_tree as tree;

pub use qm_io::{
    BasePlacement, Compressed, Contexts, DecodeOptions, DecodeStatus, Decoder, Decompressed,
    EncodeOptions, Frames, Limits, PolyMesh, UpdateRule, Weighting,
};
pub use qm_lift::SemiRegularMesh;
pub use qm_param::{Detected, RemeshOptions, RemeshReport, Remeshed};

/// Reads a mesh file (OBJ, PLY, OFF or STL).
pub fn read_mesh(path: &std::path::Path) -> Result<PolyMesh> {
    Ok(qm_io::mesh::read_mesh(path)?)
}

/// Writes a mesh file (OBJ or PLY, by extension), atomically.
pub fn write_mesh(path: &std::path::Path, mesh: &PolyMesh) -> Result<()> {
    Ok(qm_io::mesh::write_mesh(path, mesh)?)
}

/// Finds subdivision connectivity in a quad mesh (no remeshing).
pub fn detect(mesh: &PolyMesh) -> Result<Detected> {
    Ok(qm_param::detect_subdivision(mesh)?)
}

/// Remeshes any mesh into a semi-regular quad mesh.
pub fn remesh(mesh: &PolyMesh, options: &RemeshOptions) -> Result<Remeshed> {
    Ok(qm_param::remesh(mesh, options)?)
}

/// An input mesh made semi-regular.
#[derive(Clone, Debug)]
pub struct Prepared {
    /// The semi-regular mesh to compress.
    pub mesh: SemiRegularMesh,
    /// For a quad mesh taken as it is: the input vertex of each sample.
    pub source: Option<Vec<u32>>,
    /// For a remeshed input: what the remesher did.
    pub remeshed: Option<RemeshReport>,
}

/// Turns any input mesh into a semi-regular quad mesh: a quad mesh with
/// subdivision connectivity is taken as it is, anything else is remeshed.
pub fn prepare(mesh: &PolyMesh, options: &RemeshOptions) -> Result<Prepared> {
    if mesh.all_faces_have(4) {
        match qm_param::detect_subdivision(mesh) {
            Ok(d) => {
                return Ok(Prepared {
                    mesh: d.mesh,
                    source: Some(d.source),
                    remeshed: None,
                });
            }
            Err(qm_param::Error::NoSubdivisionConnectivity | qm_param::Error::InvalidMesh(_)) => {}
            Err(e) => return Err(e.into()),
        }
    }
    let r = qm_param::remesh(mesh, options)?;
    Ok(Prepared {
        mesh: r.mesh,
        source: None,
        remeshed: Some(r.report),
    })
}

/// Compresses a semi-regular mesh.
pub fn compress(mesh: &SemiRegularMesh, options: &EncodeOptions) -> Result<Compressed> {
    Ok(qm_io::compress(mesh, options)?)
}

/// [`compress`] for a semi-regular mesh made from `input` (by [`prepare`]):
/// the encoder's holds are measured against `input`'s surface, the way
/// `qm distance` measures, rather than against `mesh` (see
/// [`io::holds`]).
pub fn compress_against(
    mesh: &SemiRegularMesh,
    input: &PolyMesh,
    options: &EncodeOptions,
) -> Result<Compressed> {
    if !options.holds {
        return compress(mesh, options);
    }
    let surface = qm_param::distance::Surface::new(input)?;
    let probes = qm_io::Probes::new(mesh, |p| surface.closest(p));
    Ok(qm_io::compress_probed(mesh, options, Some(&probes))?)
}

/// Decompresses `.qm` bytes; any cut after the base mesh is fine.
pub fn decompress(bytes: &[u8], options: &DecodeOptions) -> Result<Decompressed> {
    Ok(qm_io::decompress(bytes, options)?)
}
