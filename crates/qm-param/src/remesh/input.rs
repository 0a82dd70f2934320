//! The input's own triangles as the base domain ([`BaseDomain::Input`]):
//! the clean-up with zero-thickness sheets kept, each triangle three quads
//! at level 0 (module `exact`), and the result measured against the input.
//! The input exactly, but no finer levels to stream.

use super::exact;
use super::finish::measure;
#[cfg(doc)]
use super::options::BaseDomain;
use super::options::Remeshed;
use crate::clean::clean_keeping_sheets;
use crate::{Error, PolyMesh, RemeshFailure, Result};

/// [`BaseDomain::Input`] asked for: refused with a `level` other than 0.
pub(super) fn remesh_as_asked(mesh: &PolyMesh, level: Option<u32>) -> Result<Remeshed> {
    if let Some(level) = level.filter(|&l| l != 0) {
        return Err(Error::remesh(RemeshFailure::Step(format!(
            "the input's own triangles are a base of level 0, not {level}"
        ))));
    }
    remesh_input(mesh)
}

/// [`BaseDomain::Input`]: the input's own triangles, zero-thickness sheets
/// kept, measured.
pub(super) fn remesh_input(mesh: &PolyMesh) -> Result<Remeshed> {
    let mut exact = exact::remesh_exact(clean_keeping_sheets(mesh)?)?;
    exact.report.psnr = Some(measure(mesh, &exact.mesh)?);
    Ok(exact)
}
