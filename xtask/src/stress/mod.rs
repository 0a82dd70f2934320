//! `stress DIR`: generated meshes whose topology or facets are hard on a
//! codec: five large ones,
//!
//! - `genus12.obj`: a closed, wavy plate with a 4 x 3 grid of holes, genus
//!   12, the zero set of a signed distance function extracted by marching
//!   tetrahedra on a grid (vertices welded on shared edges, so the surface
//!   is closed and manifold).
//! - `holes100.obj`: a bumpy subdivided icosahedron with 100 roughly round
//!   holes around Fibonacci points; 100 boundary loops.
//! - `parts300.obj`: 300 separate closed parts (UV spheres, subdivided
//!   boxes, tori) of 50 to 500 vertices each, rotated and placed on a
//!   jittered 3D grid without overlaps.
//! - `heightfield.obj`: an open height field like a range scan: a regular
//!   grid of a sum of sines inside a ragged outline with a few missing
//!   patches and per-vertex noise; one connected manifold surface with
//!   boundary.
//! - `pocked.obj`: a scan with hundreds of small holes: a bumpy subdivided
//!   icosahedron (10,242 vertices) with per-vertex noise and 2% of its
//!   triangles missing, one or two at each hole.
//!
//!
//! And six small faceted shapes, every edge a crease (the remesher sends
//! them as their own triangles): `cube.obj` (12 triangles),
//! `tetrahedron.obj`, `lprism.obj` (an L-shaped prism of 12 vertices),
//! `cylinder.obj` (32 segments, capped), `torus24x12.obj` and
//! `uvsphere8x16.obj`.
//!
//! Everything is deterministic: the randomness is a hash of fixed seeds.
//! Each mesh's topology (Euler characteristic, components, boundary loops,
//! whether it is manifold) is measured with the remesher's own clean-up and
//! `topology`, and printed.

//!
//! The modules, one per family: `plate` (genus12), `spheres` (holes100,
//! pocked), `parts` (parts300), `field` (heightfield) and `faceted` (the
//! small faceted shapes); `tris` builds the meshes and draws the seeded
//! randomness, `topology` measures them.

mod faceted;
mod field;
mod parts;
mod plate;
mod spheres;
mod topology;
mod tris;

use std::path::{Path, PathBuf};

use qm::PolyMesh;
use qm::lift::glam::DVec3;

pub(crate) use faceted::cylinder;
use faceted::{grid_box, l_prism, tetrahedron, torus, uv_sphere};
use field::{FIELD_SIDE, height_field};
use parts::parts;
use plate::{PLATE_STEP, genus_plate};
use spheres::{POCKED_LEVEL, POCKED_SHARE, SPHERE_LEVEL, holed_sphere, pocked_sphere};
use topology::Topology;
use tris::Tris;
pub(crate) use tris::unit;

pub fn run(args: &[String]) -> Result<(), String> {
    let [dir] = args else {
        return Err("usage: cargo xtask stress DIR".into());
    };
    let dir = PathBuf::from(dir);
    std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let meshes = [
        ("genus12.obj", genus_plate(PLATE_STEP)),
        ("holes100.obj", holed_sphere(SPHERE_LEVEL, 100)),
        ("parts300.obj", parts(300)),
        ("heightfield.obj", height_field(FIELD_SIDE)),
        ("pocked.obj", pocked_sphere(POCKED_LEVEL, POCKED_SHARE)),
        ("cube.obj", grid_box(1, DVec3::splat(0.5))),
        ("tetrahedron.obj", tetrahedron()),
        ("lprism.obj", l_prism()),
        ("cylinder.obj", cylinder(32)),
        ("torus24x12.obj", torus(24, 12, 0.3)),
        ("uvsphere8x16.obj", uv_sphere(8, 16)),
    ];
    for (name, tris) in meshes {
        let t = Topology::of(&tris);
        write(&dir.join(name), &tris)?;
        println!("{name}: {t}");
    }
    Ok(())
}

fn write(path: &Path, tris: &Tris) -> Result<(), String> {
    // Micrometre-scale rounding keeps the text short; every mesh here spans
    // a few units and no two vertices are that close.
    let round = |x: f64| (x * 1e6).round() / 1e6;
    let positions = tris
        .positions
        .iter()
        .map(|p| DVec3::new(round(p.x), round(p.y), round(p.z)))
        .collect();
    let mesh = PolyMesh::from_faces(positions, &tris.faces);
    qm::write_mesh(path, &mesh).map_err(|e| format!("{}: {e}", path.display()))
}
