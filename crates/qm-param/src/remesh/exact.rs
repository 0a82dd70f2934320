//! The input's own triangles as the base domain, at level 0.
//!
//! A faceted model (a low-poly asset, a CAD part of few faces) is its own
//! best description: every face is flat and every edge a crease. A
//! remesh through a square or charts cuts across those creases, and
//! measured on such models it stays far from the input however many
//! samples it takes (docs/decisions/017-input-triangles.md). Here
//! every input triangle is split into three quads, through its centroid
//! and its edges' midpoints (`qm_lift::split_triangles`, the split the
//! charts make of their base, so the base coder sends the triangles
//! alone), and the mesh is taken at level 0: its samples are the input's
//! vertices, the edges' midpoints and the triangles' centroids, and it is
//! the input's surface exactly. The price: the file is its base section,
//! sent whole before anything shows, with no finer levels to stream.

use qm_lift::glam::DVec3;
use qm_lift::{BaseMesh, Layout, SemiRegularMesh};

use super::{ComponentReport, RemeshReport, Remeshed};
use crate::clean::Cleaned;
use crate::{Error, RemeshFailure, Result};

/// The cleaned components' triangles, each split into three quads, as one
/// semi-regular mesh of level 0.
pub(super) fn remesh_exact(cleaned: Cleaned) -> Result<Remeshed> {
    // All parts as one triangle mesh, split once: the base coder knows a
    // split base by its one numbering (corners, then midpoints, then
    // centres).
    let mut input: Vec<DVec3> = Vec::new();
    let mut triangles: Vec<[u32; 3]> = Vec::new();
    let mut reports = Vec::with_capacity(cleaned.components.len());
    for component in &cleaned.components {
        let first = input.len() as u32;
        input.extend_from_slice(&component.positions);
        triangles.extend(component.triangles.iter().map(|t| t.map(|v| v + first)));
        reports.push(ComponentReport {
            vertices: component.positions.len(),
            triangles: component.triangles.len(),
            base_quads: 3 * component.triangles.len(),
            extra_cuts: 0,
            stretch: 0.0,
            flipped: 0,
            uncovered: 0,
        });
    }
    // In the order the base coder sends them cheaply.
    let split = super::charts::quads(&triangles);
    let mut positions = vec![DVec3::ZERO; split.vertex_count as usize];
    let at = |v: u32| input[v as usize];
    for (&v, &i) in &split.compact {
        positions[i as usize] = at(v);
    }
    for (quad, &(t, c)) in split.faces.iter().zip(&split.owner) {
        // The quad at corner `c` of triangle `t`: the corner, the midpoint
        // of the edge to the next corner, the centre.
        let tri = triangles[t as usize];
        let c = c as usize;
        positions[quad[1] as usize] = 0.5 * (at(tri[c]) + at(tri[(c + 1) % 3]));
        positions[quad[2] as usize] = (at(tri[0]) + at(tri[1]) + at(tri[2])) / 3.0;
    }
    let faces = split.faces;
    let invalid = |e: qm_lift::Error| {
        Error::remesh(RemeshFailure::Step(format!(
            "the input's own triangles make no valid base mesh: {e}"
        )))
    };
    let base = BaseMesh::new(positions.len() as u32, faces).map_err(invalid)?;
    let layout = Layout::new(base, 0).map_err(invalid)?;
    let mesh = SemiRegularMesh::new(layout, positions)?;
    Ok(Remeshed {
        mesh,
        report: RemeshReport {
            clean: cleaned.report,
            components: reports,
            level: 0,
            normal: None,
            domain: "input",
            fallback: None,
            psnr: None,
            memory: 0,
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::PolyMesh;
    use crate::clean::clean;

    /// An L-shaped prism: 12 vertices, every edge a crease.
    fn prism() -> PolyMesh {
        qm_shapes::poly(qm_shapes::l_prism())
    }

    #[test]
    fn the_input_is_its_own_remesh() {
        let input = prism();
        let r = remesh_exact(clean(&input).unwrap()).unwrap();
        let layout = r.mesh.layout();
        assert_eq!(layout.level(), 0);
        // 20 triangles, 30 edges, 12 vertices.
        assert_eq!(layout.face_count(), 60);
        assert_eq!(layout.sample_count(), 12 + 30 + 20);
        let ours = PolyMesh::from_faces(r.mesh.positions().to_vec(), &layout.quads(0));
        let options = crate::DistanceOptions::default().with_samples(20_000);
        let d = crate::distance(&input, &ours, &options).unwrap();
        assert!(d.hausdorff < 1e-9, "Hausdorff {}", d.hausdorff);
        // Every input vertex is a sample.
        for p in &input.positions {
            assert!(r.mesh.positions().iter().any(|q| q.distance(*p) == 0.0));
        }
    }

    /// A box with a zero-thickness fin on one edge (a triangle stored once
    /// each way, as coarse reconstructions store thin parts): the clean-up
    /// for remeshing cancels the fin, the input's own triangles keep it.
    #[test]
    fn the_input_keeps_its_zero_thickness_fins() {
        let (mut positions, quads) = qm_shapes::cube();
        positions.push(DVec3::new(0.5, 0.0, 2.0));
        let mut faces: Vec<[u32; 3]> = Vec::new();
        for [a, b, c, d] in quads {
            faces.push([a, b, c]);
            faces.push([a, c, d]);
        }
        // The fin on the top edge from 4 to 5, both ways.
        faces.push([4, 5, 8]);
        faces.push([5, 4, 8]);
        let input = PolyMesh::from_faces(positions, &faces);
        assert_eq!(clean(&input).unwrap().report.cancelled_faces, 2);
        let kept = crate::clean::clean_keeping_sheets(&input).unwrap();
        assert_eq!(kept.report.cancelled_faces, 0);
        let r = remesh_exact(kept).unwrap();
        let layout = r.mesh.layout();
        let ours = PolyMesh::from_faces(r.mesh.positions().to_vec(), &layout.quads(0));
        let options = crate::DistanceOptions::default().with_samples(20_000);
        let d = crate::distance(&input, &ours, &options).unwrap();
        assert!(d.hausdorff < 1e-9, "Hausdorff {}", d.hausdorff);
    }

    /// `BaseDomain::Auto` takes the prism's own triangles: its remeshes
    /// measure far below them, or take them as their base anyway.
    #[test]
    fn auto_sends_a_faceted_input_as_itself() {
        let r = super::super::remesh(&prism(), &super::super::RemeshOptions::DEFAULT).unwrap();
        assert_eq!((r.report.domain, r.report.level), ("input", 0));
        assert!(r.report.psnr.unwrap() > 100.0);
        assert!(r.report.fallback.is_some());
        // A level asked for is a remesh asked for; the input's own
        // triangles are level 0 alone.
        let at = |level, domain| {
            let options = super::super::RemeshOptions::DEFAULT
                .with_level(Some(level))
                .with_domain(domain);
            super::super::remesh(&prism(), &options)
        };
        let r = at(2, super::super::BaseDomain::Auto).unwrap();
        assert_eq!(r.report.level, 2);
        let e = at(2, super::super::BaseDomain::Input).unwrap_err();
        assert!(e.to_string().contains("level 0, not 2"), "{e}");
        assert_eq!(
            at(0, super::super::BaseDomain::Input).unwrap().report.level,
            0
        );
    }
}
