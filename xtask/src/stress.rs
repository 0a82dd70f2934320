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

use std::collections::HashMap;
use std::f64::consts::{PI, TAU};
use std::path::{Path, PathBuf};

use qm::PolyMesh;
use qm::io::SplitMix64;
use qm::lift::glam::{DQuat, DVec3};
use qm::param::TriMesh;
use qm::param::clean;

/// Grid step of the genus-12 plate's marching tetrahedra (~60k vertices).
const PLATE_STEP: f64 = 0.052;
/// Subdivisions of the holed sphere's icosahedron (40,962 vertices).
const SPHERE_LEVEL: u32 = 6;
/// Vertices per side of the height field's grid.
const FIELD_SIDE: usize = 300;
/// Subdivisions of the pocked sphere's icosahedron (10,242 vertices).
const POCKED_LEVEL: u32 = 5;
/// Share of the pocked sphere's triangles missing.
const POCKED_SHARE: f64 = 0.02;

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

/// A triangle mesh under construction.
#[derive(Clone, Debug, Default)]
pub struct Tris {
    pub positions: Vec<DVec3>,
    pub faces: Vec<[u32; 3]>,
}

impl Tris {
    fn push(&mut self, p: DVec3) -> u32 {
        self.positions.push(p);
        (self.positions.len() - 1) as u32
    }

    /// Appends another mesh, renumbering its vertices.
    fn append(&mut self, other: &Tris) {
        let base = self.positions.len() as u32;
        self.positions.extend_from_slice(&other.positions);
        (self.faces).extend(other.faces.iter().map(|f| f.map(|v| v + base)));
    }

    /// Drops the vertices no face uses, keeping the others' order.
    fn compact(&mut self) {
        let mut map = vec![u32::MAX; self.positions.len()];
        let mut positions = Vec::new();
        for f in &mut self.faces {
            for v in f.iter_mut() {
                if map[*v as usize] == u32::MAX {
                    map[*v as usize] = positions.len() as u32;
                    positions.push(self.positions[*v as usize]);
                }
                *v = map[*v as usize];
            }
        }
        self.positions = positions;
    }

    /// Turns every face so its normal points along `outward(centroid)`.
    fn orient(&mut self, outward: impl Fn(DVec3) -> DVec3) {
        for f in &mut self.faces {
            let [a, b, c] = f.map(|v| self.positions[v as usize]);
            if (b - a).cross(c - a).dot(outward((a + b + c) / 3.0)) < 0.0 {
                f.swap(1, 2);
            }
        }
    }
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

// ---------------------------------------------------------------------------
// Randomness: SplitMix64 of a seed, as a function, so each draw is named.

/// A uniform number in `[0, 1)` from a stream and an index in it.
pub(crate) fn unit(stream: u64, i: u64) -> f64 {
    let h = SplitMix64::mix(SplitMix64::mix(stream) ^ i.wrapping_mul(0xd6e8_feb8_6659_fd93));
    (h >> 11) as f64 / (1u64 << 53) as f64
}

/// A uniform number in `[lo, hi)`.
fn between(stream: u64, i: u64, lo: f64, hi: f64) -> f64 {
    lo + (hi - lo) * unit(stream, i)
}

// ---------------------------------------------------------------------------
// Topology, as the remesher sees it.

/// A generated mesh's topology: the whole mesh's (`qm::param::clean::topology`,
/// which also checks that it is a consistently oriented manifold), and each
/// connected component's after the remesher's clean-up.
pub struct Topology {
    pub whole: clean::Topology,
    pub parts: Vec<clean::Topology>,
}

impl Topology {
    pub fn of(tris: &Tris) -> Topology {
        let whole = clean::topology(&TriMesh {
            positions: tris.positions.clone(),
            triangles: tris.faces.clone(),
        });
        let mesh = PolyMesh::from_faces(tris.positions.clone(), &tris.faces);
        let parts = clean::clean(&mesh)
            .map(|c| clean::components_topology(&c.components))
            .unwrap_or_default();
        Topology { whole, parts }
    }

    /// The genus of a single closed or bounded part.
    pub fn genus(&self) -> Option<i64> {
        (self.whole.manifold && self.parts.len() == 1).then_some(self.whole.genus)
    }
}

impl std::fmt::Display for Topology {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let w = &self.whole;
        write!(
            f,
            "{} vertices, {} faces, {} edges, Euler {}, {} components, \
             {} boundary loops ({} edges), {}",
            w.vertices,
            w.faces,
            w.edges,
            w.euler,
            self.parts.len(),
            w.boundary_loops,
            w.boundary_edges,
            if w.manifold {
                "manifold"
            } else {
                "NOT manifold"
            }
        )?;
        if let Some(g) = self.genus() {
            write!(f, ", genus {g}")?;
        }
        Ok(())
    }
}

/// How many fans (face sets connected through edges at the vertex) meet at
/// each vertex: 1 on a manifold, 0 for an unused vertex.
fn fans(tris: &Tris) -> Vec<usize> {
    let n = tris.positions.len();
    // Each face's "link edge" seen from each of its corners.
    let mut start = vec![0usize; n + 1];
    for f in &tris.faces {
        for &v in f {
            start[v as usize + 1] += 1;
        }
    }
    for v in 0..n {
        start[v + 1] += start[v];
    }
    let mut fill = start.clone();
    let mut link = vec![(0u32, 0u32); 3 * tris.faces.len()];
    for f in &tris.faces {
        for k in 0..3 {
            let v = f[k] as usize;
            link[fill[v]] = (f[(k + 1) % 3], f[(k + 2) % 3]);
            fill[v] += 1;
        }
    }
    let mut out = vec![0; n];
    let mut local: Vec<u32> = Vec::new();
    for v in 0..n {
        let edges = &link[start[v]..start[v + 1]];
        if edges.is_empty() {
            continue;
        }
        local.clear();
        local.extend(edges.iter().flat_map(|&(a, b)| [a, b]));
        local.sort_unstable();
        local.dedup();
        let at = |x: u32| local.binary_search(&x).unwrap() as u32;
        let mut uf = UnionFind::new(local.len());
        for &(a, b) in edges {
            uf.union(at(a), at(b));
        }
        let mut roots: Vec<u32> = (0..local.len() as u32).map(|i| uf.find(i)).collect();
        roots.sort_unstable();
        roots.dedup();
        out[v] = roots.len();
    }
    out
}

struct UnionFind(Vec<u32>);

impl UnionFind {
    fn new(n: usize) -> Self {
        UnionFind((0..n as u32).collect())
    }

    fn find(&mut self, mut x: u32) -> u32 {
        while self.0[x as usize] != x {
            let up = self.0[self.0[x as usize] as usize];
            self.0[x as usize] = up;
            x = up;
        }
        x
    }

    fn union(&mut self, a: u32, b: u32) {
        let (a, b) = (self.find(a), self.find(b));
        if a != b {
            self.0[a.max(b) as usize] = a.min(b);
        }
    }
}

// ---------------------------------------------------------------------------
// genus12: a plate with 12 holes by marching tetrahedra.

/// Polynomial smooth minimum with blend width `k`.
fn smin(a: f64, b: f64, k: f64) -> f64 {
    let h = (0.5 + 0.5 * (b - a) / k).clamp(0.0, 1.0);
    b + (a - b) * h - k * h * (1.0 - h)
}

fn smax(a: f64, b: f64, k: f64) -> f64 {
    -smin(-a, -b, k)
}

/// Half extents of the plate (before the wave).
const PLATE: DVec3 = DVec3::new(2.3, 1.8, 0.2);

/// The plate's hole centres and radii: a 4 x 3 grid, radii varied.
fn plate_holes() -> Vec<(f64, f64, f64)> {
    let mut holes = Vec::new();
    for j in 0..3 {
        for i in 0..4 {
            let k = (j * 4 + i) as u64;
            let x = -1.5 + i as f64 + between(11, k, -0.08, 0.08);
            let y = -1.1 + 1.1 * j as f64 + between(12, k, -0.08, 0.08);
            holes.push((x, y, between(13, k, 0.22, 0.36)));
        }
    }
    holes
}

/// Signed distance (roughly) to the wavy plate: negative inside.
fn plate_sdf(p: DVec3, holes: &[(f64, f64, f64)]) -> f64 {
    let p = DVec3::new(
        p.x,
        p.y,
        p.z - 0.18 * (1.3 * p.x).sin() * (1.1 * p.y + 0.4).cos(),
    );
    let r = 0.15;
    let q = p.abs() - (PLATE - r);
    let slab = q.max(DVec3::ZERO).length() + q.max_element().min(0.0) - r;
    let hole = holes
        .iter()
        .map(|&(x, y, radius)| (p.truncate() - qm::lift::glam::DVec2::new(x, y)).length() - radius)
        .fold(f64::INFINITY, f64::min);
    smax(slab, -hole, 0.08)
}

fn genus_plate(step: f64) -> Tris {
    let holes = plate_holes();
    let lo = -(PLATE + DVec3::new(0.1, 0.1, 0.35));
    let hi = -lo;
    marching_tetrahedra(lo, hi, step, |p| plate_sdf(p, &holes))
}

/// The zero set of `f` (negative inside) on a grid of cubes of side `step`
/// over the box `lo..hi`, each cube cut into six tetrahedra around its
/// main diagonal (the same cut in every cube, so neighbours agree on the
/// shared faces). A vertex is made once per grid edge the surface crosses,
/// so the result is closed wherever `f > 0` on the box's border.
pub fn marching_tetrahedra(lo: DVec3, hi: DVec3, step: f64, f: impl Fn(DVec3) -> f64) -> Tris {
    let n = ((hi - lo) / step).ceil().as_uvec3() + 1;
    let (nx, ny, nz) = (n.x as usize, n.y as usize, n.z as usize);
    let id = |i: usize, j: usize, k: usize| (k * ny + j) * nx + i;
    let point = |i: usize, j: usize, k: usize| lo + DVec3::new(i as f64, j as f64, k as f64) * step;
    let mut value = vec![0.0; nx * ny * nz];
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let v = f(point(i, j, k));
                // Keep values off zero so every crossing lies inside an edge.
                value[id(i, j, k)] = if v.abs() < 1e-12 { 1e-12 } else { v };
            }
        }
    }
    let mut tris = Tris::default();
    let mut on_edge: HashMap<(usize, usize), u32> = HashMap::new();
    let mut cross = |tris: &mut Tris, a: usize, b: usize, pa: DVec3, pb: DVec3| -> u32 {
        let key = (a.min(b), a.max(b));
        *on_edge.entry(key).or_insert_with(|| {
            let (fa, fb) = (value[a], value[b]);
            // Kept off the ends so no two vertices nearly coincide.
            let t = (fa / (fa - fb)).clamp(0.01, 0.99);
            tris.push(pa + (pb - pa) * t)
        })
    };
    // The six tetrahedra: paths from corner 0 to corner 7 along the axes.
    const PATHS: [[usize; 3]; 6] = [
        [0, 1, 2],
        [0, 2, 1],
        [1, 0, 2],
        [1, 2, 0],
        [2, 0, 1],
        [2, 1, 0],
    ];
    for k in 0..nz - 1 {
        for j in 0..ny - 1 {
            for i in 0..nx - 1 {
                for path in PATHS {
                    let mut c = [i, j, k];
                    let mut corners = [(0usize, DVec3::ZERO); 4];
                    corners[0] = (id(c[0], c[1], c[2]), point(c[0], c[1], c[2]));
                    for (s, &axis) in path.iter().enumerate() {
                        c[axis] += 1;
                        corners[s + 1] = (id(c[0], c[1], c[2]), point(c[0], c[1], c[2]));
                    }
                    let (inside, outside): (Vec<_>, Vec<_>) =
                        corners.iter().partition(|&&(v, _)| value[v] < 0.0);
                    let before = tris.faces.len();
                    match inside.len() {
                        1 | 3 => {
                            let (one, three) = if inside.len() == 1 {
                                (inside[0], &outside)
                            } else {
                                (outside[0], &inside)
                            };
                            let v: Vec<u32> = (three.iter())
                                .map(|&&(w, pw)| cross(&mut tris, one.0, w, one.1, pw))
                                .collect();
                            tris.faces.push([v[0], v[1], v[2]]);
                        }
                        2 => {
                            let (a, b, c, d) = (inside[0], inside[1], outside[0], outside[1]);
                            let ac = cross(&mut tris, a.0, c.0, a.1, c.1);
                            let ad = cross(&mut tris, a.0, d.0, a.1, d.1);
                            let bd = cross(&mut tris, b.0, d.0, b.1, d.1);
                            let bc = cross(&mut tris, b.0, c.0, b.1, c.1);
                            tris.faces.push([ac, ad, bd]);
                            tris.faces.push([ac, bd, bc]);
                        }
                        _ => {}
                    }
                    // Outward is from the inside corners to the outside ones.
                    let centre = |s: &[&(usize, DVec3)]| {
                        s.iter().map(|c| c.1).sum::<DVec3>() / s.len().max(1) as f64
                    };
                    let out = centre(&outside) - centre(&inside);
                    for f in &mut tris.faces[before..] {
                        let [a, b, c] = f.map(|v| tris.positions[v as usize]);
                        if (b - a).cross(c - a).dot(out) < 0.0 {
                            f.swap(1, 2);
                        }
                    }
                }
            }
        }
    }
    tris
}

// ---------------------------------------------------------------------------
// holes100: a sphere with holes.

/// A unit icosahedron subdivided `level` times, projected to the sphere.
fn icosphere(level: u32) -> Tris {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let mut tris = Tris::default();
    for p in [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ] {
        tris.push(DVec3::from(p).normalize());
    }
    tris.faces = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..level {
        let mut mid: HashMap<(u32, u32), u32> = HashMap::new();
        let mut faces = Vec::with_capacity(4 * tris.faces.len());
        for f in std::mem::take(&mut tris.faces) {
            let mut m = [0u32; 3];
            for k in 0..3 {
                let (a, b) = (f[k], f[(k + 1) % 3]);
                m[k] = *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                    let p = (tris.positions[a as usize] + tris.positions[b as usize]).normalize();
                    tris.push(p)
                });
            }
            faces.push([f[0], m[0], m[2]]);
            faces.push([f[1], m[1], m[0]]);
            faces.push([f[2], m[2], m[1]]);
            faces.push(m);
        }
        tris.faces = faces;
    }
    tris.orient(|c| c);
    tris
}

/// `n` well-spread unit vectors (a Fibonacci spiral).
fn fibonacci(n: usize) -> Vec<DVec3> {
    let golden = PI * (3.0 - 5f64.sqrt());
    (0..n)
        .map(|i| {
            let z = 1.0 - (2.0 * i as f64 + 1.0) / n as f64;
            let r = (1.0 - z * z).sqrt();
            let a = golden * i as f64;
            DVec3::new(r * a.cos(), r * a.sin(), z)
        })
        .collect()
}

fn holed_sphere(level: u32, holes: usize) -> Tris {
    let mut tris = icosphere(level);
    let centres = fibonacci(holes);
    // Fibonacci points lie at least ~0.3 apart for 100 points; radii up to
    // 0.1 leave a band of faces between any two holes.
    let radii: Vec<f64> = (0..holes as u64)
        .map(|i| between(21, i, 0.06, 0.1))
        .collect();
    let pos = &tris.positions;
    tris.faces.retain(|f| {
        let c = (pos[f[0] as usize] + pos[f[1] as usize] + pos[f[2] as usize]).normalize();
        !centres
            .iter()
            .zip(&radii)
            .any(|(h, &r)| c.distance_squared(*h) < r * r)
    });
    prune_pinches(&mut tris);
    for p in &mut tris.positions {
        let bump = broad_bump(*p) + 0.006 * (23.0 * p.x).sin() * (19.0 * p.z + 1.0).sin();
        *p *= 1.0 + bump;
    }
    tris.compact();
    tris
}

/// The holed and pocked spheres' broad bumps, a share of the radius at `p`.
fn broad_bump(p: DVec3) -> f64 {
    0.02 * (5.0 * p.x + 1.0).sin() * (4.0 * p.y).cos() * (6.0 * p.z + 2.0).sin()
}

/// A scan with many small holes: `icosphere(level)` with the holed
/// sphere's broad bumps, its vertices moved by up to 0.3% of the radius
/// along the normal, and a `share` of its triangles dropped (then pinches
/// pruned).
fn pocked_sphere(level: u32, share: f64) -> Tris {
    let mut tris = icosphere(level);
    let mut i = 0u64;
    tris.faces.retain(|_| {
        i += 1;
        unit(41, i) >= share
    });
    prune_pinches(&mut tris);
    for (i, p) in tris.positions.iter_mut().enumerate() {
        *p *= 1.0 + broad_bump(*p) + between(42, i as u64, -0.003, 0.003);
    }
    tris.compact();
    tris
}

/// Removes faces until no vertex is pinched: at a vertex where several fans
/// meet, all but the largest fan go.
fn prune_pinches(tris: &mut Tris) {
    loop {
        let counts = fans(tris);
        let pinched: Vec<u32> = (0..counts.len() as u32)
            .filter(|&v| counts[v as usize] > 1)
            .collect();
        if pinched.is_empty() {
            return;
        }
        let mut drop = vec![false; tris.faces.len()];
        for v in pinched {
            let around: Vec<usize> = (0..tris.faces.len())
                .filter(|&f| !drop[f] && tris.faces[f].contains(&v))
                .collect();
            // Group the faces at `v` into fans by shared edges through `v`.
            let mut uf = UnionFind::new(around.len());
            for (x, &fx) in around.iter().enumerate() {
                for (y, &fy) in around.iter().enumerate().skip(x + 1) {
                    let shared = tris.faces[fx]
                        .iter()
                        .filter(|&&w| w != v && tris.faces[fy].contains(&w))
                        .count();
                    if shared > 0 {
                        uf.union(x as u32, y as u32);
                    }
                }
            }
            let roots: Vec<u32> = (0..around.len() as u32).map(|x| uf.find(x)).collect();
            let size = |r: u32| roots.iter().filter(|&&s| s == r).count();
            let keep = *roots.iter().max_by_key(|&&r| (size(r), r)).unwrap();
            for (x, &f) in around.iter().enumerate() {
                if roots[x] != keep {
                    drop[f] = true;
                }
            }
        }
        let mut k = 0;
        tris.faces.retain(|_| {
            k += 1;
            !drop[k - 1]
        });
    }
}

// ---------------------------------------------------------------------------
// parts300: many small closed parts.

fn uv_sphere(rings: u32, segments: u32) -> Tris {
    let mut t = Tris::default();
    let north = t.push(DVec3::Z);
    for r in 1..rings {
        let theta = PI * r as f64 / rings as f64;
        for s in 0..segments {
            let phi = TAU * s as f64 / segments as f64;
            t.push(DVec3::new(
                theta.sin() * phi.cos(),
                theta.sin() * phi.sin(),
                theta.cos(),
            ));
        }
    }
    let south = t.push(-DVec3::Z);
    let at = |r: u32, s: u32| 1 + (r - 1) * segments + s % segments;
    for s in 0..segments {
        t.faces.push([north, at(1, s), at(1, s + 1)]);
        t.faces
            .push([south, at(rings - 1, s + 1), at(rings - 1, s)]);
        for r in 1..rings - 1 {
            t.faces.push([at(r, s), at(r + 1, s), at(r + 1, s + 1)]);
            t.faces.push([at(r, s), at(r + 1, s + 1), at(r, s + 1)]);
        }
    }
    t.orient(|c| c);
    t
}

/// The surface of a box of half extents `half` with `n` segments an edge.
fn grid_box(n: u32, half: DVec3) -> Tris {
    let mut t = Tris::default();
    let mut index: HashMap<[u32; 3], u32> = HashMap::new();
    let mut vertex = |t: &mut Tris, c: [u32; 3]| -> u32 {
        *index.entry(c).or_insert_with(|| {
            let p = DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64) / n as f64 * 2.0 - 1.0;
            t.push(p * half)
        })
    };
    for axis in 0..3 {
        for side in [0, n] {
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            for a in 0..n {
                for b in 0..n {
                    let corner = |da: u32, db: u32| {
                        let mut c = [0u32; 3];
                        c[axis] = side;
                        c[u] = a + da;
                        c[v] = b + db;
                        c
                    };
                    let q = [corner(0, 0), corner(1, 0), corner(1, 1), corner(0, 1)]
                        .map(|c| vertex(&mut t, c));
                    t.faces.push([q[0], q[1], q[2]]);
                    t.faces.push([q[0], q[2], q[3]]);
                }
            }
        }
    }
    t.orient(|c| c);
    t
}

fn tetrahedron() -> Tris {
    let mut t = Tris::default();
    for p in [[1., 1., 1.], [1., -1., -1.], [-1., 1., -1.], [-1., -1., 1.]] {
        t.push(DVec3::from_array(p));
    }
    t.faces = vec![[0, 1, 2], [0, 3, 1], [0, 2, 3], [1, 3, 2]];
    t.orient(|c| c);
    t
}

/// An L-shaped prism: an outline of six corners, extruded, its caps in
/// four triangles each.
fn l_prism() -> Tris {
    let outline = [(0., 0.), (2., 0.), (2., 1.), (1., 1.), (1., 2.), (0., 2.)];
    let mut t = Tris::default();
    for z in [0., 1.] {
        for &(x, y) in &outline {
            t.push(DVec3::new(x, y, z));
        }
    }
    for i in 0..6 {
        let j = (i + 1) % 6;
        t.faces.push([i, j, j + 6]);
        t.faces.push([i, j + 6, i + 6]);
    }
    for [a, b, c] in [[0, 2, 1], [0, 3, 2], [0, 5, 3], [3, 5, 4]] {
        t.faces.push([a, b, c]);
        t.faces.push([a + 6, c + 6, b + 6]);
    }
    t
}

/// A closed cylinder of radius 1 and height 2, `n` segments, each cap a fan
/// around its centre.
pub(crate) fn cylinder(n: u32) -> Tris {
    let mut t = Tris::default();
    for i in 0..n {
        let a = TAU * i as f64 / n as f64;
        t.push(DVec3::new(a.cos(), a.sin(), 0.0));
        t.push(DVec3::new(a.cos(), a.sin(), 2.0));
    }
    let (low, high) = (t.push(DVec3::ZERO), t.push(DVec3::new(0.0, 0.0, 2.0)));
    for i in 0..n {
        let j = (i + 1) % n;
        t.faces.push([2 * i, 2 * j, 2 * j + 1]);
        t.faces.push([2 * i, 2 * j + 1, 2 * i + 1]);
        t.faces.push([low, 2 * j, 2 * i]);
        t.faces.push([high, 2 * i + 1, 2 * j + 1]);
    }
    t
}

fn torus(major: u32, minor: u32, r: f64) -> Tris {
    let mut t = Tris::default();
    for i in 0..major {
        let u = TAU * i as f64 / major as f64;
        for j in 0..minor {
            let v = TAU * j as f64 / minor as f64;
            let ring = 1.0 + r * v.cos();
            t.push(DVec3::new(ring * u.cos(), ring * u.sin(), r * v.sin()));
        }
    }
    let at = |i: u32, j: u32| (i % major) * minor + j % minor;
    for i in 0..major {
        for j in 0..minor {
            t.faces.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
            t.faces.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
        }
    }
    t.orient(|c| c - DVec3::new(c.x, c.y, 0.0).normalize());
    t
}

/// `count` parts in cells of side 1 of a cubic grid: each fits in a ball of
/// radius 0.36 around its cell's centre, jittered by at most 0.1, so parts
/// are at least 0.08 apart.
fn parts(count: usize) -> Tris {
    let side = (count as f64).cbrt().ceil() as usize;
    let mut all = Tris::default();
    for i in 0..count as u64 {
        let k = i as usize;
        let cell = DVec3::new(
            (k % side) as f64,
            (k / side % side) as f64,
            (k / side / side) as f64,
        );
        let size = between(31, i, 0.14, 0.36);
        let draw = |s: u64, lo: f64, hi: f64| between(32 + s, i, lo, hi);
        let mut part = match i % 3 {
            0 => uv_sphere(draw(0, 6.0, 17.0) as u32, draw(1, 10.0, 31.0) as u32),
            1 => {
                // Half extents up to 1/sqrt(3) keep the box inside the ball.
                let half = DVec3::new(draw(2, 0.3, 0.577), draw(3, 0.3, 0.577), 0.577);
                grid_box(draw(4, 3.0, 9.99) as u32, half)
            }
            _ => {
                let r = draw(5, 0.2, 0.45);
                // Scaled so the outer radius 1 + r is 1.
                let mut t = torus(draw(6, 9.0, 29.0) as u32, draw(7, 6.0, 17.0) as u32, r);
                t.positions.iter_mut().for_each(|p| *p /= 1.0 + r);
                t
            }
        };
        let axis = DVec3::new(draw(8, -1.0, 1.0), draw(9, -1.0, 1.0), draw(10, -1.0, 1.0));
        let turn =
            DQuat::from_axis_angle(axis.try_normalize().unwrap_or(DVec3::Z), draw(11, 0.0, TAU));
        let jitter = DVec3::new(
            draw(12, -0.1, 0.1),
            draw(13, -0.1, 0.1),
            draw(14, -0.1, 0.1),
        );
        for p in &mut part.positions {
            *p = cell + jitter + turn * (*p * size);
        }
        all.append(&part);
    }
    all
}

// ---------------------------------------------------------------------------
// heightfield: an open scan.

/// The height field's surface over `[-1, 1]^2`.
fn height(x: f64, y: f64) -> f64 {
    0.12 * (2.1 * x + 0.3).sin() * (1.7 * y).cos()
        + 0.05 * (5.3 * x - 3.1 * y).sin()
        + 0.025 * (11.0 * x + 0.5).cos() * (9.0 * y + 1.0).sin()
        + 0.008 * (31.0 * x + 17.0 * y).sin()
}

fn height_field(side: usize) -> Tris {
    let cells = side - 1;
    let coord = |i: usize| -1.0 + 2.0 * i as f64 / cells as f64;
    // The outline: radius modulated by angle at several frequencies.
    let phase: Vec<f64> = (0..5).map(|k| between(41, k, 0.0, TAU)).collect();
    let outline = |a: f64| {
        0.78 + 0.07 * (3.0 * a + phase[0]).sin()
            + 0.04 * (7.0 * a + phase[1]).sin()
            + 0.025 * (13.0 * a + phase[2]).sin()
            + 0.012 * (29.0 * a + phase[3]).sin()
            + 0.006 * (61.0 * a + phase[4]).sin()
    };
    // Missing patches inside: (centre, radii of an ellipse).
    let patches: Vec<(f64, f64, f64, f64)> = (0..6u64)
        .map(|k| {
            let a = TAU * (k as f64 + between(42, k, 0.0, 0.5)) / 6.0;
            let r = between(43, k, 0.15, 0.5);
            let s = between(44, k, 0.03, 0.07);
            (r * a.cos(), r * a.sin(), s, s * between(45, k, 0.5, 1.5))
        })
        .collect();
    let mut keep = vec![false; cells * cells];
    let mut patch = vec![false; cells * cells];
    for j in 0..cells {
        for i in 0..cells {
            let (x, y) = (
                (coord(i) + coord(i + 1)) / 2.0,
                (coord(j) + coord(j + 1)) / 2.0,
            );
            let (r, a) = (x.hypot(y), y.atan2(x));
            let margin = outline(a) - r;
            let c = (j * cells + i) as u64;
            // Near the border some cells drop out, as on a real scan.
            let ragged = margin < 0.03 && unit(46, c) < 0.35;
            let hole = patches
                .iter()
                .any(|&(px, py, rx, ry)| ((x - px) / rx).powi(2) + ((y - py) / ry).powi(2) < 1.0);
            keep[j * cells + i] = margin > 0.0 && !ragged && !hole;
            patch[j * cells + i] = hole;
        }
    }
    // Dropped cells the outside does not reach are filled again: the
    // border is ragged, and the only holes inside are the patches.
    let outside = reach_from_border(&keep, cells);
    for c in 0..cells * cells {
        keep[c] |= !outside[c] && !patch[c];
    }
    clean_cells(&mut keep, cells);
    let mut tris = Tris::default();
    for j in 0..side {
        for i in 0..side {
            let (x, y) = (coord(i), coord(j));
            let noise = between(47, (j * side + i) as u64, -0.0015, 0.0015);
            tris.push(DVec3::new(x, y, height(x, y) + noise));
        }
    }
    let v = |i: usize, j: usize| (j * side + i) as u32;
    for j in 0..cells {
        for i in 0..cells {
            if keep[j * cells + i] {
                let q = [v(i, j), v(i + 1, j), v(i + 1, j + 1), v(i, j + 1)];
                tris.faces.push([q[0], q[1], q[2]]);
                tris.faces.push([q[0], q[2], q[3]]);
            }
        }
    }
    tris.compact();
    tris
}

/// The edge neighbours of cell `c` of an `n x n` grid.
fn neighbours(c: usize, n: usize) -> impl Iterator<Item = usize> {
    let (i, j) = (c % n, c / n);
    [
        (i > 0).then(|| c - 1),
        (i + 1 < n).then(|| c + 1),
        (j > 0).then(|| c - n),
        (j + 1 < n).then(|| c + n),
    ]
    .into_iter()
    .flatten()
}

/// The cells not kept that the grid's border reaches through cells not kept.
fn reach_from_border(keep: &[bool], n: usize) -> Vec<bool> {
    let mut seen = vec![false; n * n];
    let mut stack: Vec<usize> = (0..n * n)
        .filter(|&c| {
            let (i, j) = (c % n, c / n);
            !keep[c] && (i == 0 || j == 0 || i + 1 == n || j + 1 == n)
        })
        .collect();
    for &c in &stack {
        seen[c] = true;
    }
    while let Some(c) = stack.pop() {
        for d in neighbours(c, n) {
            if !keep[d] && !seen[d] {
                seen[d] = true;
                stack.push(d);
            }
        }
    }
    seen
}

/// Makes the kept cells of an `n x n` grid one edge-connected set with no
/// vertex where only two diagonally opposite cells meet.
fn clean_cells(keep: &mut [bool], n: usize) {
    let at = |i: usize, j: usize| j * n + i;
    loop {
        let mut changed = false;
        for j in 0..n - 1 {
            for i in 0..n - 1 {
                let q = [at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)].map(|c| keep[c]);
                if q == [true, false, true, false] {
                    keep[at(i, j)] = false;
                    changed = true;
                } else if q == [false, true, false, true] {
                    keep[at(i + 1, j)] = false;
                    changed = true;
                }
            }
        }
        if !changed {
            break;
        }
    }
    // The largest edge-connected set of cells stays.
    let mut label = vec![usize::MAX; n * n];
    let mut best = (0, usize::MAX);
    for start in 0..n * n {
        if !keep[start] || label[start] != usize::MAX {
            continue;
        }
        let mut stack = vec![start];
        label[start] = start;
        let mut size = 0;
        while let Some(c) = stack.pop() {
            size += 1;
            for d in neighbours(c, n) {
                if keep[d] && label[d] == usize::MAX {
                    label[d] = start;
                    stack.push(d);
                }
            }
        }
        if size > best.0 {
            best = (size, start);
        }
    }
    for c in 0..n * n {
        keep[c] = keep[c] && label[c] == best.1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plate_has_genus_twelve() {
        let t = Topology::of(&genus_plate(0.07));
        assert!(t.whole.manifold, "{t}");
        assert_eq!((t.parts.len(), t.whole.boundary_edges), (1, 0), "{t}");
        assert_eq!(t.genus(), Some(12), "{t}");
    }

    #[test]
    fn marching_tetrahedra_makes_a_sphere() {
        let t = Topology::of(&marching_tetrahedra(
            DVec3::splat(-1.3),
            DVec3::splat(1.3),
            0.1,
            |p| p.length() - 1.0,
        ));
        assert!(t.whole.manifold, "{t}");
        assert_eq!((t.parts.len(), t.whole.boundary_edges), (1, 0), "{t}");
        assert_eq!(t.genus(), Some(0), "{t}");
    }

    #[test]
    fn sphere_has_a_hundred_holes() {
        let t = Topology::of(&holed_sphere(5, 100));
        assert!(t.whole.manifold, "{t}");
        assert_eq!(t.parts.len(), 1, "{t}");
        assert_eq!(t.whole.boundary_loops, 100, "{t}");
        assert_eq!(t.genus(), Some(0), "{t}");
    }

    #[test]
    fn pocked_sphere_has_hundreds_of_small_holes() {
        let tris = pocked_sphere(POCKED_LEVEL, POCKED_SHARE);
        let t = Topology::of(&tris);
        assert!(t.whole.manifold, "{t}");
        assert_eq!(t.parts.len(), 1, "{t}");
        assert!(t.whole.boundary_loops >= 300, "{t}");
        // Small holes: one or two missing triangles each, on average.
        assert!(t.whole.boundary_edges <= 5 * t.whole.boundary_loops, "{t}");
        assert_eq!(t.genus(), Some(0), "{t}");
    }

    /// The remesher's components of the 300 parts.
    fn components(all: &Tris) -> Vec<TriMesh> {
        clean::clean(&PolyMesh::from_faces(all.positions.clone(), &all.faces))
            .unwrap()
            .components
    }

    #[test]
    fn parts_are_separate_and_closed() {
        let all = parts(300);
        let t = Topology::of(&all);
        assert!(t.whole.manifold, "{t}");
        assert_eq!((t.parts.len(), t.whole.boundary_edges), (300, 0), "{t}");
        let mut tori = 0;
        for p in &t.parts {
            assert!((50..=500).contains(&p.vertices), "{p:?}");
            assert!(p.manifold && p.is_closed(), "{p:?}");
            match p.genus {
                0 => {}
                1 => tori += 1,
                _ => panic!("{p:?}"),
            }
        }
        assert_eq!(tori, 100);
    }

    #[test]
    fn parts_do_not_overlap() {
        // The parts' bounding balls (around their mean vertex) are disjoint.
        let balls: Vec<(DVec3, f64)> = components(&parts(300))
            .iter()
            .map(|part| {
                let ps = &part.positions;
                let c = ps.iter().sum::<DVec3>() / ps.len() as f64;
                (c, ps.iter().map(|p| p.distance(c)).fold(0.0, f64::max))
            })
            .collect();
        assert_eq!(balls.len(), 300);
        for (i, a) in balls.iter().enumerate() {
            for b in &balls[i + 1..] {
                assert!(a.0.distance(b.0) > a.1 + b.1, "{a:?} {b:?}");
            }
        }
    }

    #[test]
    fn height_field_is_one_open_sheet() {
        let t = Topology::of(&height_field(120));
        assert!(t.whole.manifold, "{t}");
        assert_eq!(t.parts.len(), 1, "{t}");
        assert!(
            t.whole.boundary_loops >= 1 && t.whole.boundary_edges > 0,
            "{t}"
        );
        assert_eq!(t.genus(), Some(0), "{t}");
    }
}
