//! `cad DIR`: faceted CAD meshes from OpenSCAD's bundled examples (CC0,
//! Debian's `openscad` package), rendered to STL by `openscad`, their
//! duplicate corners welded, written as OBJ into `DIR`: parts of spheres,
//! cylinders, extrusions, text and height maps, every edge a crease, as a
//! user's CAD export makes them (issue 44's set;
//! docs/decisions/035-chosen-parallelograms.md).

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::Command;

use qm::PolyMesh;

/// Where Debian's `openscad` package puts its examples.
const EXAMPLES: &str = "/usr/share/openscad/examples";

/// The examples rendered, under [`EXAMPLES`]: a spread of CSG, extrusion,
/// text and height maps, 853 to 7,778 vertices each.
const MODELS: [&str; 10] = [
    "Basics/CSG-modules",
    "Basics/CSG",
    "Advanced/GEB",
    "Parametric/candleStand",
    "Advanced/children",
    "Basics/logo_and_text",
    "Basics/rotate_extrude",
    "Parametric/sign",
    "Basics/linear_extrude",
    "Advanced/surface_image",
];

pub fn run(args: &[String]) -> Result<(), String> {
    let [dir] = args else {
        return Err("usage: cargo xtask cad DIR (needs `apt-get install -y openscad`)".into());
    };
    let dir = PathBuf::from(dir);
    std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    for model in MODELS {
        let scad = Path::new(EXAMPLES).join(format!("{model}.scad"));
        let name = model.rsplit('/').next().unwrap_or(model);
        let stl = std::env::temp_dir().join(format!("qm-cad-{}-{name}.stl", std::process::id()));
        // Examples that `use` others find them beside themselves.
        let status = Command::new("openscad")
            .arg("-o")
            .arg(&stl)
            .arg(&scad)
            .current_dir(scad.parent().unwrap_or(Path::new(".")))
            .output()
            .map_err(|e| format!("openscad: {e} (install with `apt-get install -y openscad`)"))?;
        if !status.status.success() {
            return Err(format!(
                "openscad {}: {}",
                scad.display(),
                String::from_utf8_lossy(&status.stderr).trim()
            ));
        }
        let soup = qm::read_mesh(&stl).map_err(|e| e.to_string());
        let _ = std::fs::remove_file(&stl);
        let mesh = welded(&soup?);
        let out = dir.join(format!("cad_{name}.obj"));
        qm::write_mesh(&out, &mesh).map_err(|e| e.to_string())?;
        println!(
            "{}: {} vertices, {} triangles",
            out.display(),
            mesh.positions.len(),
            mesh.face_count()
        );
    }
    Ok(())
}

/// `soup` (an STL's separate triangles) with the corners at the same
/// position made one vertex, and the triangles that collapse dropped.
fn welded(soup: &PolyMesh) -> PolyMesh {
    let mut index: HashMap<[u64; 3], u32> = HashMap::new();
    let mut positions = Vec::new();
    let mut faces = Vec::new();
    for face in soup.faces() {
        let corners: Vec<u32> = face
            .iter()
            .map(|&v| {
                let p = soup.positions[v as usize];
                *index
                    .entry(p.to_array().map(f64::to_bits))
                    .or_insert_with(|| {
                        positions.push(p);
                        positions.len() as u32 - 1
                    })
            })
            .collect();
        let mut distinct = corners.clone();
        distinct.sort_unstable();
        distinct.dedup();
        if distinct.len() == corners.len() {
            faces.push(corners);
        }
    }
    let mut mesh = PolyMesh::from_faces::<3>(positions, &[]);
    faces.iter().for_each(|f| mesh.push_face(f));
    mesh
}
