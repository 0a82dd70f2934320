//! Base vertices' stars laid flat: each base vertex's *chart*.
//!
//! Main items: [`Star`] (a star's base triangles with their corners' 2D
//! places, then the triangles across its outer edges, unfolded), [`Stars`]
//! and [`Domain`], what sampling and untangling share of a component and
//! its base domain.
//!
//! A star keeps its edge lengths at its centre `a`, and the angles at `a`
//! are scaled to a full turn, `2 pi / sum(angles)` (on a boundary only as
//! far as needed to stay under `1.8 pi`); [`flatten_star`] spreads them
//! evenly where a scaled angle would open beyond `0.9 pi`. A triangle
//! across an outer edge `w0 w1` keeps its own shape there: its third
//! corner at the same place along and off the edge, relative to its length.

use std::collections::HashMap;

use qm_lift::glam::{DVec2, DVec3};

use super::drawn::barycentric;
use crate::remesh::simplify::{Base, Location, Ring, ring};
use crate::{Error, RemeshFailure, Result, TriMesh};

/// The 2D places of `a`'s ring vertices: each star triangle keeps its edge
/// lengths at `a`, and the angles at `a` are scaled to a full turn (on a
/// boundary, only as far as needed to stay under one). So a base triangle
/// and its neighbour across an edge sit almost as in 3D in the charts of
/// both ends of that edge, and the two charts agree where their quads meet.
/// Where a scaled angle would open beyond `0.9 pi`, the angles are spread
/// evenly instead.
fn flatten_star(a: DVec3, ring: &[DVec3], closed: bool, triangles: usize) -> Vec<DVec2> {
    let k = ring.len();
    let spokes: Vec<DVec3> = ring.iter().map(|&p| p - a).collect();
    let lengths: Vec<f64> = spokes.iter().map(|s| s.length()).collect();
    let angles: Vec<f64> = (0..triangles)
        .map(|i| spokes[i].angle_between(spokes[(i + 1) % k]))
        .collect();
    let total: f64 = angles.iter().sum();
    let scale = if closed {
        std::f64::consts::TAU / total
    } else {
        (1.8 * std::f64::consts::PI / total).min(1.0)
    };
    let turn = if closed {
        std::f64::consts::TAU
    } else {
        std::f64::consts::PI
    };
    let kept = total > 0.0
        && lengths.iter().all(|&l| l > 0.0)
        && angles
            .iter()
            .all(|&t| t > 0.0 && t * scale < 0.9 * std::f64::consts::PI);
    let step: Vec<f64> = if kept {
        angles.iter().map(|&t| t * scale).collect()
    } else {
        let even = (turn / triangles as f64).min(2.0 * std::f64::consts::FRAC_PI_3);
        vec![even; triangles]
    };
    let mean = lengths.iter().sum::<f64>() / k as f64;
    let mut phi = 0.0f64;
    (0..k)
        .map(|i| {
            let r = if lengths[i] > 0.0 {
                lengths[i]
            } else {
                mean.max(1e-300)
            };
            let p = DVec2::new(r * phi.cos(), r * phi.sin());
            if i < step.len() {
                phi += step[i];
            }
            p
        })
        .collect()
}

/// One base vertex's star: its triangles, each with its corners' 2D places
/// in the vertex's chart (the vertex at the origin), then the triangles
/// across its outer edges, unfolded.
pub(super) struct Star {
    pub(super) places: Vec<(u32, [DVec2; 3])>,
    /// How many of `places` are the star's own.
    pub(super) proper: usize,
}

impl Star {
    /// The star's own triangles' places, and (`wide`) the unfolded ones.
    pub(super) fn drawn(&self, wide: bool) -> &[(u32, [DVec2; 3])] {
        &self.places[..if wide { self.places.len() } else { self.proper }]
    }

    /// The map's location of chart point `x`: the base triangle (among
    /// [`Star::drawn`]) that holds it, and its barycentric coordinates.
    pub(super) fn locate(&self, x: DVec2, wide: bool) -> Option<Location> {
        self.drawn(wide).iter().find_map(|(t, place)| {
            let l = barycentric(place, x);
            l.iter().all(|&v| v >= 0.0).then_some(Location::Face(*t, l))
        })
    }
}

/// The stars of every base vertex of `base`, keyed by component vertex.
fn stars(mesh: &TriMesh, base: &Base) -> Result<Stars> {
    let mut around: HashMap<u32, Vec<u32>> = HashMap::new();
    for (t, tri) in base.triangles.iter().enumerate() {
        for &v in tri {
            around.entry(v).or_default().push(t as u32);
        }
    }
    let mut across: HashMap<(u32, u32), u32> = HashMap::new();
    for (t, tri) in base.triangles.iter().enumerate() {
        for i in 0..3 {
            across.insert((tri[i], tri[(i + 1) % 3]), t as u32);
        }
    }
    around
        .into_iter()
        .map(|(a, star)| {
            let Ring {
                verts: ring,
                faces: order,
                closed,
            } = ring(a, &star, &base.triangles).ok_or_else(|| {
                Error::remesh(RemeshFailure::Step(format!(
                    "the base domain's triangles around base vertex {a} are not one fan"
                )))
            })?;
            let ring_positions: Vec<DVec3> =
                ring.iter().map(|&w| mesh.positions[w as usize]).collect();
            let flat = flatten_star(
                mesh.positions[a as usize],
                &ring_positions,
                closed,
                order.len(),
            );
            let place_of = |w: u32| -> DVec2 {
                if w == a {
                    DVec2::ZERO
                } else {
                    ring.iter()
                        .position(|&x| x == w)
                        .map_or(DVec2::ZERO, |i| flat[i])
                }
            };
            let mut places: Vec<(u32, [DVec2; 3])> = order
                .iter()
                .map(|&t| (t, base.triangles[t as usize].map(place_of)))
                .collect();
            // The triangles across the star's outer edges, unfolded there
            // with their own shape: input triangles that reach out of the
            // star near its quads are drawn whole.
            for i in 0..order.len() {
                let (w0, w1) = (ring[i], ring[(i + 1) % ring.len()]);
                let Some(&t) = across.get(&(w1, w0)) else {
                    continue;
                };
                if places.iter().any(|(s, _)| *s == t) {
                    continue;
                }
                let tri = base.triangles[t as usize];
                let Some(x) = tri.iter().copied().find(|&v| v != w0 && v != w1) else {
                    continue;
                };
                let (p0, p1, px) = (
                    mesh.positions[w0 as usize],
                    mesh.positions[w1 as usize],
                    mesh.positions[x as usize],
                );
                let e = p1 - p0;
                let len2 = e.length_squared();
                if len2.is_nan() || len2 <= 0.0 {
                    continue;
                }
                let along = (px - p0).dot(e) / len2;
                let perp = ((px - p0) - e * along).length() / len2.sqrt();
                let (q0, q1) = (flat[i], flat[(i + 1) % flat.len()]);
                let d = q1 - q0;
                let right = DVec2::new(d.y, -d.x);
                let qx = q0 + d * along + right * perp;
                let place = tri.map(|v| {
                    if v == w0 {
                        q0
                    } else if v == w1 {
                        q1
                    } else {
                        qx
                    }
                });
                places.push((t, place));
            }
            let proper = order.len();
            Ok((a, Star { places, proper }))
        })
        .try_fold(
            Stars(
                std::iter::repeat_with(|| None)
                    .take(mesh.positions.len())
                    .collect(),
            ),
            |mut stars, star: Result<(u32, Star)>| {
                let (a, star) = star?;
                stars.0[a as usize] = Some(star);
                Ok(stars)
            },
        )
}

/// The stars of a component's base vertices, by component vertex.
pub(super) struct Stars(Vec<Option<Star>>);

impl Stars {
    /// The base vertices, in order.
    pub(super) fn keys(&self) -> impl Iterator<Item = u32> + '_ {
        (0..self.0.len() as u32).filter(|&v| self.0[v as usize].is_some())
    }
}

impl std::ops::Index<&u32> for Stars {
    type Output = Star;

    /// Base vertex `a`'s star; panics if `a` is not a base vertex.
    fn index(&self, a: &u32) -> &Star {
        self.0[*a as usize].as_ref().expect("a base vertex")
    }
}

/// What sampling and untangling share of a component and its base domain:
/// every base vertex's star (which only the base triangles decide, not the
/// map) and the input triangles at each input vertex.
pub(crate) struct Domain {
    pub(super) stars: Stars,
    pub(super) around: Vec<Vec<u32>>,
    /// Per input vertex: whether the map holds it on a feature line, or
    /// between such vertices and base vertices only.
    pub(super) held: Vec<bool>,
}

impl Domain {
    pub(crate) fn new(mesh: &TriMesh, base: &Base) -> Result<Domain> {
        let mut around: Vec<Vec<u32>> = vec![Vec::new(); mesh.positions.len()];
        for (t, tri) in mesh.triangles.iter().enumerate() {
            for &v in tri {
                around[v as usize].push(t as u32);
            }
        }
        let fixed =
            |v: u32| base.feature[v as usize] || base.location[v as usize] == Location::Vertex;
        let held = (0..mesh.positions.len() as u32)
            .map(|v| {
                base.feature[v as usize]
                    || around[v as usize].iter().all(|&t| {
                        mesh.triangles[t as usize]
                            .iter()
                            .all(|&w| w == v || fixed(w))
                    })
            })
            .collect();
        Ok(Domain {
            stars: stars(mesh, base)?,
            around,
            held,
        })
    }
}
