//! Finishing a remesh: each part's patch checked, the patches joined into
//! one semi-regular mesh, its samples placed for normal details, and the
//! remesh measured against its input.
//!
//! [`check_patch`] refuses a part whose samples stray far outside its
//! bounding box (a folded map). [`finish`] joins the parts' patches (module
//! `resample`'s [`Patch`]) into one base mesh and layout, the bases of
//! charts numbered as one split of all their triangles
//! ([`split_numbering`]), and with [`RemeshOptions::normal`] moves the
//! samples, coarse to fine, onto the ray along the codec's frame normal
//! where that is safe (module `normal`). [`measure`] is the remesher's own
//! PSNR of a remesh against its input.

use qm_lift::glam::DVec3;
use qm_lift::{BaseMesh, Layout, SemiRegularMesh, split_triangles};

use super::normal;
use super::options::{ComponentReport, NormalReport, RemeshOptions, RemeshReport, Remeshed};
use super::resample::Patch;
use super::surface;
use crate::clean::Cleaned;
use crate::{Error, Part, PolyMesh, RemeshFailure, Result, TriMesh};

/// How far outside its component's bounding box a sample may lie, in
/// diagonals of that box: the fit moves samples by a fraction of their
/// spacing, a folded map (which the gluing does not catch) throws them
/// across the scene.
const STRAY: f64 = 0.25;

/// Fails, naming the component and its map, if any of its samples lie more
/// than [`STRAY`] outside its bounding box: a remesh that far off is no
/// remesh of the input, and would be decoded as if it were.
pub(super) fn check_patch(
    c: usize,
    component: &TriMesh,
    stretch: f64,
    folded: usize,
    samples: &[DVec3],
) -> Result<()> {
    let (lo, hi) = component.positions.iter().fold(
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |(lo, hi), &p| (lo.min(p), hi.max(p)),
    );
    let margin = STRAY * (hi - lo).length();
    let (lo, hi) = (lo - margin, hi + margin);
    let stray = samples
        .iter()
        .filter(|p| !(p.cmpge(lo).all() && p.cmple(hi).all()))
        .count();
    if stray == 0 {
        return Ok(());
    }
    Err(Error::remesh(RemeshFailure::DoesNotMap {
        stray,
        stretch,
        folded,
    })
    .in_part(|| part(c, component)))
}

/// What an error message says of component `c`.
pub(super) fn part(c: usize, component: &TriMesh) -> Part {
    let topo = crate::clean::topology(component);
    Part {
        index: c,
        vertices: component.positions.len(),
        genus: topo.genus,
        holes: topo.boundary_loops,
    }
}

/// Joins the components' patches into one semi-regular mesh and, with
/// [`RemeshOptions::normal`], places its samples for normal details.
pub(super) fn finish(
    cleaned: Cleaned,
    patches: Vec<(Patch, ComponentReport)>,
    level: u32,
    options: &RemeshOptions,
    split: bool,
) -> Result<Remeshed> {
    let join = || -> Result<_> {
        let mut faces = Vec::new();
        let mut grids = Vec::new();
        let mut positions: Vec<DVec3> = Vec::new();
        // The surface triangle each sample was sampled from (the components'
        // triangles one after the other, as in `surface::Surface`).
        let mut triangles: Vec<u32> = Vec::new();
        let mut pinned: Vec<bool> = Vec::new();
        let mut first_triangle = 0u32;
        let mut base_vertices = 0u32;
        let mut reports = Vec::new();
        for ((patch, report), component) in patches.into_iter().zip(&cleaned.components) {
            let (bo, so) = (base_vertices, positions.len() as u32);
            faces.extend(patch.faces.iter().map(|f| f.map(|v| v + bo)));
            grids.extend(patch.grids.iter().map(|&s| s + so));
            positions.extend_from_slice(&patch.positions);
            triangles.extend(patch.triangles.iter().map(|&t| t + first_triangle));
            pinned.extend_from_slice(&patch.pinned);
            first_triangle += component.triangles.len() as u32;
            base_vertices += patch.base_vertices;
            reports.push(report);
        }
        if split {
            faces = split_numbering(&faces, base_vertices);
        }
        let base = BaseMesh::new(base_vertices, faces).map_err(|e| {
            Error::remesh(RemeshFailure::Step(format!(
                "the glued base mesh is invalid: {e}"
            )))
        })?;
        let layout = Layout::new(base, level)?;
        let (mesh, source) = SemiRegularMesh::from_face_grids(layout, &grids, &positions)?;
        // Per sample of the layout.
        let triangles: Vec<u32> = source.iter().map(|&v| triangles[v as usize]).collect();
        let pinned: Vec<bool> = source.iter().map(|&v| pinned[v as usize]).collect();
        Ok((mesh, triangles, pinned, reports))
    };
    let (sampled, surface) = rayon::join(join, || {
        options
            .normal
            .then(|| surface::Surface::new(&cleaned.components))
    });
    let (mut mesh, triangles, pinned, reports) = sampled?;
    let mut normal_report = None;
    if let Some(surface) = surface {
        let surface = surface?;
        let (layout, mut positions) = mesh.into_parts();
        let placed = normal::place(
            &layout,
            &mut positions,
            &triangles,
            &pinned,
            &surface,
            options.fit_rounds,
        );
        normal_report = Some(NormalReport {
            moved: placed.moved,
            kept: placed.kept,
        });
        mesh = SemiRegularMesh::new(layout, positions)?;
    }
    Ok(Remeshed {
        mesh,
        report: RemeshReport {
            clean: cleaned.report,
            components: reports,
            level,
            normal: normal_report,
            domain: "square",
            fallback: None,
            psnr: None,
            memory: 0,
        },
    })
}

/// The faces of parts' split bases (`qm_lift::split_triangles`, each part
/// numbered on its own: corners, midpoints, centres), one after the other,
/// numbered as the split of all their triangles together (the same
/// function's): every part's corners, then every midpoint, then every
/// centre, each in order of first use. The base coder knows a split by that
/// numbering alone (`qm_lift::unsplit`), and sends it as triangles, not as
/// quads (docs/decisions/021-one-split-base.md).
fn split_numbering(faces: &[[u32; 4]], vertices: u32) -> Vec<[u32; 4]> {
    // Quad `c` of a triangle starts at its corner `c`.
    let triangles: Vec<[u32; 3]> = faces
        .chunks_exact(3)
        .map(|q| [q[0][0], q[1][0], q[2][0]])
        .collect();
    let split = split_triangles(&triangles);
    if split.vertex_count == vertices {
        split.faces
    } else {
        // Not splits after all: as they are.
        faces.to_vec()
    }
}

/// Samples each way of the remesher's own measure of its distance to the
/// input ([`RemeshReport::psnr`]).
const CHECK_SAMPLES: usize = 50_000;

/// The PSNR of `remesh` against `input` (Metro's symmetric RMS distance,
/// [`CHECK_SAMPLES`] each way, over the input's bounding box diagonal).
pub(super) fn measure(input: &PolyMesh, remesh: &SemiRegularMesh) -> Result<f64> {
    let layout = remesh.layout();
    let ours = PolyMesh::from_faces(remesh.positions().to_vec(), &layout.quads(layout.level()));
    let options = crate::distance::DistanceOptions::default().with_samples(CHECK_SAMPLES);
    let report = crate::distance::distance(input, &ours, &options)?;
    Ok(report.psnr_db)
}
