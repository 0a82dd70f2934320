//! Test meshes, built in one place for the tests of every crate and for the
//! xtask: tetrahedra, a cube, an octahedron and an L-shaped prism
//! ([`solids`]), UV spheres ([`spheres`]), tori ([`tori`]), cylinders
//! ([`cylinders`]) and flat meshes: grids, a plane, a square, a fan, an
//! n-gon ([`flat`]). Each returns a [`PolyMesh`], or positions with
//! triangles ([`Triangles`]) or quads ([`Quads`]) where its callers build
//! other types ([`poly`] makes those a `PolyMesh`). Tests assert exact
//! numbers of these meshes, so each generator keeps its vertex order, face
//! order and arithmetic; where tests built one shape in two ways, both are
//! here as named variants. Meshes of `qm-lift`'s own types (a `BaseMesh`, a
//! `SemiRegularMesh`) stay in `qm_lift::synthetic`: this crate is below
//! `qm-lift` (it uses only `qm-io`), so that every crate can take it as a
//! dev-dependency. Not published.

pub mod cylinders;
pub mod flat;
pub mod solids;
pub mod spheres;
pub mod tori;

pub use cylinders::{cylinder, cylinder_ring_by_ring, open_cylinder_quads};
pub use flat::{grid, grid_quads, grid_triangles, holed_grid, ngon, plane, quad_fan, square};
pub use solids::{cube, l_prism, octahedron, tetrahedron, tetrahedron_inward};
pub use spheres::{uv_sphere, uv_sphere_poles_first, uv_sphere_radial, uv_sphere_triangles};
pub use tori::{torus, torus_quads, torus_ring_by_ring};

use glam::DVec3;
use qm_io::PolyMesh;

/// Positions and triangles.
pub type Triangles = (Vec<DVec3>, Vec<[u32; 3]>);

/// Positions and quads.
pub type Quads = (Vec<DVec3>, Vec<[u32; 4]>);

/// Positions and faces of `K` corners as a [`PolyMesh`].
pub fn poly<const K: usize>((positions, faces): (Vec<DVec3>, Vec<[u32; K]>)) -> PolyMesh {
    PolyMesh::from_faces(positions, &faces)
}

/// The cells `(i, j)` of a `w` by `h` grid of cells, row by row (`j`
/// outer).
fn rows(w: u32, h: u32) -> impl Iterator<Item = (u32, u32)> {
    (0..h).flat_map(move |j| (0..w).map(move |i| (i, j)))
}

/// The quad of each cell `(i, j)` in turn: the corners `(i, j)`,
/// `(i + 1, j)`, `(i + 1, j + 1)`, `(i, j + 1)`, numbered by `id`.
fn cell_quads(
    cells: impl Iterator<Item = (u32, u32)>,
    id: impl Fn(u32, u32) -> u32,
) -> Vec<[u32; 4]> {
    cells
        .map(|(i, j)| [id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)])
        .collect()
}

/// Each of [`cell_quads`] `a b c d` split on its diagonal from `a` into the
/// triangles `a b c` and `a c d`.
fn cell_triangles(
    cells: impl Iterator<Item = (u32, u32)>,
    id: impl Fn(u32, u32) -> u32,
) -> Vec<[u32; 3]> {
    let quads = cell_quads(cells, id);
    quads
        .iter()
        .flat_map(|&[a, b, c, d]| [[a, b, c], [a, c, d]])
        .collect()
}

#[cfg(test)]
mod tests;
