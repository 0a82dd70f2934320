//! Subdivision-connectivity detection: undoing quad subdivision.
//!
//! One step of quad subdivision (the connectivity of Catmull-Clark) splits
//! every quad into four: a new point on each edge (E), one in each face (F),
//! and the old vertices (V) stay. Each new quad reads V, E, F, E around its
//! corners, with V opposite F. Undoing one step therefore means labelling
//! every vertex V, E or F so that all quads read that way; the coarse quad of
//! a face point is the four V corners of the four quads around it.
//!
//! The labelling is forced almost everywhere: once one quad's labels are
//! known, each neighbour across an edge shares a V or an F with it (every edge
//! is V-E or E-F), which fixes the neighbour. A face point must be an interior
//! vertex with four quads and an edge point an interior vertex with four quads
//! or a boundary vertex with two, so any other ("extraordinary") vertex is a
//! coarse vertex. That seeds each connected component; a component with no
//! extraordinary vertex at all (a torus, a cylinder) has up to four candidate
//! labellings, one per parity class of its grid, and the first consistent one
//! is used: on a regular grid the candidates are translates of one another.
//!
//! Repeating the step while it succeeds gives the base mesh and, for each
//! coarse face, its four children; walking those down from every base face
//! places each input vertex at its `(i, j)` on the base face grids.
//! Everything is linear in the mesh size (a million scattered-id quads take
//! about a second).

use qm_io::PolyMesh;
use qm_lift::{BaseMesh, Layout, MAX_LEVEL, MAX_SAMPLES, SemiRegularMesh};

use crate::quads::{QuadMesh, Valence};
use crate::{Error, Result};

/// A quad mesh recognised as a base mesh refined `level` times.
#[derive(Clone, Debug)]
pub struct Detected {
    /// The semi-regular mesh; its finest level has exactly the input's
    /// vertices and quads.
    pub mesh: SemiRegularMesh,
    /// For each sample, the input vertex it came from (a bijection).
    pub source: Vec<u32>,
    /// Number of quad subdivision steps undone (at least 1).
    pub level: u32,
}

/// Finds the coarsest base mesh of which `mesh` is a repeated quad
/// subdivision and returns `mesh` as a semi-regular mesh over it.
///
/// Fails when `mesh` is not a consistently oriented, edge-manifold mesh of
/// quads with every vertex used, or when not even one step of subdivision can
/// be undone (such a mesh needs remeshing instead). Stops at
/// [`MAX_LEVEL`] levels.
pub fn detect_subdivision(mesh: &PolyMesh) -> Result<Detected> {
    let fine = fine_mesh(mesh)?;
    let mut steps: Vec<Step> = Vec::new();
    let mut base: Option<QuadMesh> = None;
    while (steps.len() as u32) < MAX_LEVEL {
        match coarsen(base.as_ref().unwrap_or(&fine)) {
            Some((coarse, step)) => {
                steps.push(step);
                base = Some(coarse);
            }
            None => break,
        }
    }
    let Some(base) = base else {
        return Err(Error::NoSubdivisionConnectivity);
    };
    let level = steps.len() as u32;
    let grids = face_grids(&fine, &base, &steps)?;
    drop(steps);
    let base = BaseMesh::new(base.vertex_count(), base.into_faces())?;
    let layout = Layout::new(base, level)?;
    let (semi, source) = SemiRegularMesh::from_face_grids(layout, &grids, &mesh.positions)?;

    // Every step was checked to be an exact split, so the samples and the
    // input vertices must correspond one to one.
    if source.len() != mesh.positions.len() {
        return Err(Error::Internal("sample count differs from vertex count"));
    }
    let mut seen = vec![false; source.len()];
    for &v in &source {
        if std::mem::replace(&mut seen[v as usize], true) {
            return Err(Error::Internal("an input vertex is two samples"));
        }
    }
    Ok(Detected {
        mesh: semi,
        source,
        level,
    })
}

/// The input as a validated quad mesh, the finest level of the hierarchy.
fn fine_mesh(mesh: &PolyMesh) -> Result<QuadMesh> {
    if mesh.face_count() == 0 {
        return Err(Error::NoFaces { mesh: None });
    }
    if mesh.positions.len() as u64 > MAX_SAMPLES {
        return Err(Error::TooManyVertices {
            vertices: mesh.positions.len(),
            max: MAX_SAMPLES,
        });
    }
    let quads = mesh
        .faces()
        .enumerate()
        .map(|(face, corners)| {
            <[u32; 4]>::try_from(corners).map_err(|_| Error::NotQuads {
                face,
                corners: corners.len(),
            })
        })
        .collect::<Result<Vec<_>>>()?;
    let count = mesh.positions.len() as u32;
    // Only a broken mesh pays for the slower check that names the problem.
    QuadMesh::new(count, quads).map_err(|quads| match BaseMesh::new(count, quads) {
        Err(qm_lift::Error::UnusedVertex { vertex }) => Error::UnusedVertex { vertex },
        Err(e) => Error::InvalidMesh(e),
        Ok(_) => Error::Internal("quad mesh validity checks disagree"),
    })
}

/// One undone subdivision step: for each coarse face and each of its corners
/// `k`, the finer face at that corner and which of its own corners lies there.
struct Step {
    children: Vec<[(u32, u8); 4]>,
}

/// What a vertex becomes when one subdivision step is undone.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Role {
    /// A vertex of the coarse mesh.
    Vertex,
    /// The point added on a coarse edge.
    Edge,
    /// The point added in a coarse face.
    Face,
}

/// Roles of a quad's corners, starting at its coarse vertex.
const ROLES: [Role; 4] = [Role::Vertex, Role::Edge, Role::Face, Role::Edge];

/// Whether a vertex with these surroundings can take `role`: a face point
/// needs four quads around it, an edge point four or two on the boundary.
fn allows(valence: Valence, role: Role) -> bool {
    match role {
        Role::Vertex => true,
        Role::Edge => valence != Valence::Extraordinary,
        Role::Face => valence == Valence::Interior4,
    }
}

/// Marks a face whose labelling is not known yet.
const NO_PHASE: u8 = u8::MAX;

/// Labels vertices by propagating through quads. A face's *phase* is the index
/// of its coarse-vertex corner, which fixes the roles of all four corners.
struct Labeller<'a> {
    mesh: &'a QuadMesh,
    phase: Vec<u8>,
    role: Vec<Option<Role>>,
    /// Vertices labelled by the current attempt, to undo it if it fails.
    touched: Vec<u32>,
    stack: Vec<u32>,
}

impl<'a> Labeller<'a> {
    fn new(mesh: &'a QuadMesh) -> Self {
        Labeller {
            mesh,
            phase: vec![NO_PHASE; mesh.faces().len()],
            role: vec![None; mesh.vertex_count() as usize],
            touched: Vec::new(),
            stack: Vec::new(),
        }
    }

    /// Labels every component; `None` if some component has no consistent
    /// labelling.
    fn label_all(mut self) -> Option<(Vec<u8>, Vec<Option<Role>>)> {
        let mesh = self.mesh;
        let faces = mesh.faces();
        let mut seen = vec![false; faces.len()];
        let mut component: Vec<u32> = Vec::new();
        for start in 0..faces.len() as u32 {
            if seen[start as usize] {
                continue;
            }
            component.clear();
            component.push(start);
            seen[start as usize] = true;
            let mut next = 0;
            while let Some(&f) = component.get(next) {
                next += 1;
                for s in 0..4 {
                    if let Some((g, _)) = mesh.across(f, s) {
                        if !seen[g as usize] {
                            seen[g as usize] = true;
                            component.push(g);
                        }
                    }
                }
            }
            let extraordinary = component.iter().find_map(|&f| {
                let corners = faces[f as usize];
                (0..4u8)
                    .find(|&c| mesh.valence(corners[c as usize]) == Valence::Extraordinary)
                    .map(|c| (f, c))
            });
            let labelled = match extraordinary {
                // An extraordinary vertex can only be a coarse vertex.
                Some((f, c)) => self.propagate(f, c, &component),
                // No anchor: try the seed vertex as each of the four parity
                // classes (vertex, either edge direction, face).
                None => (0..4).any(|p| self.propagate(start, p, &component)),
            };
            if !labelled {
                return None;
            }
        }
        Some((self.phase, self.role))
    }

    /// Labels `component` starting from face `seed` with phase `phase`; on a
    /// conflict, undoes this attempt and returns false.
    fn propagate(&mut self, seed: u32, phase: u8, component: &[u32]) -> bool {
        self.touched.clear();
        self.stack.clear();
        self.phase[seed as usize] = phase;
        self.stack.push(seed);
        let ok = self.run();
        if !ok {
            for &v in &self.touched {
                self.role[v as usize] = None;
            }
            for &f in component {
                self.phase[f as usize] = NO_PHASE;
            }
        }
        ok
    }

    fn run(&mut self) -> bool {
        let mesh = self.mesh;
        let faces = mesh.faces();
        while let Some(f) = self.stack.pop() {
            let phase = self.phase[f as usize];
            let corners = faces[f as usize];
            for (k, &role) in ROLES.iter().enumerate() {
                let v = corners[(phase as usize + k) & 3];
                match self.role[v as usize] {
                    Some(old) if old != role => return false,
                    Some(_) => {}
                    None => {
                        if !allows(mesh.valence(v), role) {
                            return false;
                        }
                        self.role[v as usize] = Some(role);
                        self.touched.push(v);
                    }
                }
            }
            for s in 0..4u8 {
                let Some((g, side)) = mesh.across(f, s) else {
                    continue;
                };
                if self.phase[g as usize] != NO_PHASE {
                    continue;
                }
                // The neighbour runs along this side backwards: its corner
                // `side` is our corner `s + 1`, its corner `side + 1` our
                // corner `s`. One of the two is a coarse vertex or face point,
                // which fixes the neighbour's phase.
                let role_at = |c: u8| ROLES[(c.wrapping_sub(phase) & 3) as usize];
                let offset = match (role_at(s.wrapping_add(1)), role_at(s)) {
                    (Role::Vertex, _) => 0,
                    (Role::Face, _) => 2,
                    (_, Role::Vertex) => 1,
                    _ => 3,
                };
                self.phase[g as usize] = (side + offset) & 3;
                self.stack.push(g);
            }
        }
        true
    }
}

/// Undoes one subdivision step of `mesh`, if it is an exact quad split of a
/// valid coarser mesh.
fn coarsen(mesh: &QuadMesh) -> Option<(QuadMesh, Step)> {
    let (phase, role) = Labeller::new(mesh).label_all()?;
    let faces = mesh.faces();

    let mut coarse_id = vec![u32::MAX; role.len()];
    let mut coarse_vertices = 0u32;
    for (v, r) in role.iter().enumerate() {
        if *r == Some(Role::Vertex) {
            coarse_id[v] = coarse_vertices;
            coarse_vertices += 1;
        }
    }

    let mut done = vec![false; faces.len()];
    let mut coarse_faces = Vec::with_capacity(faces.len() / 4);
    let mut children = Vec::with_capacity(faces.len() / 4);
    // The edge point on each side of each coarse face.
    let mut midpoints: Vec<[u32; 4]> = Vec::with_capacity(faces.len() / 4);
    for start in 0..faces.len() as u32 {
        if done[start as usize] {
            continue;
        }
        // Walk the four quads around the face point, counter-clockwise: the
        // next one lies across the side from the edge point to the face point.
        let mut corners = [0u32; 4];
        let mut kids = [(0u32, 0u8); 4];
        let mut mids = [0u32; 4];
        let mut q = start;
        for k in 0..4 {
            if std::mem::replace(&mut done[q as usize], true) {
                return None;
            }
            let p = phase[q as usize];
            let quad = faces[q as usize];
            corners[k] = coarse_id[quad[p as usize] as usize];
            kids[k] = (q, p);
            mids[k] = quad[(p as usize + 1) & 3];
            q = mesh.across(q, (p + 1) & 3)?.0;
        }
        if q != start {
            return None;
        }
        coarse_faces.push(corners);
        children.push(kids);
        midpoints.push(mids);
    }

    // A 4x6 torus would coarsen to a 2x3 one whose edges come in pairs: not
    // a valid base mesh, so the hierarchy ends one level finer.
    let coarse = QuadMesh::new(coarse_vertices, coarse_faces).ok()?;
    // Both faces of a coarse edge must have split it at the same point, or
    // the finer mesh has a slit (a 2-around cylinder coarsens that way)...
    for (f, mids) in midpoints.iter().enumerate() {
        for (k, &mid) in mids.iter().enumerate() {
            if let Some((g, side)) = coarse.across(f as u32, k as u8) {
                if midpoints[g as usize][side as usize] != mid {
                    return None;
                }
            }
        }
    }
    // ... and then each finer vertex is exactly one coarse vertex, edge or face.
    let split_count = coarse.vertex_count() as usize + coarse.edge_count() + coarse.faces().len();
    if split_count != role.len() {
        return None;
    }
    Some((coarse, Step { children }))
}

/// Corners of a square, counter-clockwise from its origin.
const SQUARE: [(usize, usize); 4] = [(0, 0), (1, 0), (1, 1), (0, 1)];

/// A face of some level placed on a base face grid: its corner `rot + t`
/// lies at corner `t` of the square of side `2^level` at `(i, j)`.
struct Placement {
    level: usize,
    face: u32,
    rot: u8,
    i: usize,
    j: usize,
}

/// The input vertex at every grid point of every base face, in the layout
/// expected by [`SemiRegularMesh::from_face_grids`].
fn face_grids(fine: &QuadMesh, base: &QuadMesh, steps: &[Step]) -> Result<Vec<u32>> {
    let level = steps.len();
    let side = (1usize << level) + 1;
    let mut grids = vec![u32::MAX; base.faces().len() * side * side];
    let mut stack = Vec::new();
    for (b, grid) in grids.chunks_exact_mut(side * side).enumerate() {
        stack.push(Placement {
            level,
            face: b as u32,
            rot: 0,
            i: 0,
            j: 0,
        });
        while let Some(at) = stack.pop() {
            if at.level == 0 {
                let quad = fine.faces()[at.face as usize];
                for (t, (di, dj)) in SQUARE.iter().enumerate() {
                    let v = quad[(at.rot as usize + t) & 3];
                    let slot = &mut grid[(at.j + dj) * side + at.i + di];
                    if *slot != u32::MAX && *slot != v {
                        return Err(Error::Internal("two quads disagree on a grid point"));
                    }
                    *slot = v;
                }
                continue;
            }
            let half = 1usize << (at.level - 1);
            let kids = &steps[at.level - 1].children[at.face as usize];
            for (t, (di, dj)) in SQUARE.iter().enumerate() {
                // The child at this square corner holds the coarse corner
                // there; turn it so that corner lands on the same spot.
                let (child, corner) = kids[(at.rot as usize + t) & 3];
                stack.push(Placement {
                    level: at.level - 1,
                    face: child,
                    rot: (corner + 4 - t as u8) & 3,
                    i: at.i + di * half,
                    j: at.j + dj * half,
                });
            }
        }
    }
    Ok(grids)
}

#[cfg(test)]
mod tests;
