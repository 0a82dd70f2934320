//! Making a planned removal: the ring's faces replaced by the fan (or the
//! retriangulation), and every input vertex located in the removed faces,
//! the removed vertex among them, located again in the new ones, in the
//! ring's flattening and on its side of a crease line. Composed over all
//! removals, each input vertex ends in one base triangle with barycentric
//! coordinates: the map of the input onto the base.

use qm_lift::glam::DVec2;

use super::base::Location;
use super::plan::Plan;
use super::ring::edge_key;
use super::simplifier::Simplifier;

impl Simplifier<'_> {
    /// Removes `v` as `plan` says; returns the vertices whose rings changed.
    pub(super) fn collapse(&mut self, v: u32, plan: &Plan) -> Vec<u32> {
        let u = plan.u;
        let ring = self.ring(v).expect("planned ring");
        let k = ring.verts.len();
        let ui = ring.verts.iter().position(|&w| w == u).expect("u in ring");
        let bi = if self.crease_degree[v as usize] == 2 {
            (0..k).find(|&i| i != ui && self.creases.contains(&edge_key(v, ring.verts[i])))
        } else {
            None
        };
        let line = bi.filter(|_| ring.closed).map(|bi| (ui, bi));
        let flat = self.flatten(v, &ring, line).expect("planned flattening");
        let corner2d = |w: u32| -> DVec2 {
            if w == v {
                DVec2::ZERO
            } else {
                flat[ring
                    .verts
                    .iter()
                    .position(|&x| x == w)
                    .expect("ring vertex")]
            }
        };
        // The points of the old faces, in the flattening, with their side.
        let mut moving: Vec<(u32, DVec2, u8)> = Vec::new();
        for (i, &f) in ring.faces.iter().enumerate() {
            let side = Self::side(&ring, ui, bi, i);
            let t = self.faces[f as usize];
            let c = t.map(corner2d);
            for &p in &self.points[f as usize] {
                let Location::Face(_, b) = self.location[p as usize] else {
                    unreachable!("a located point")
                };
                moving.push((p, c[0] * b[0] + c[1] * b[1] + c[2] * b[2], side));
            }
            self.points[f as usize] = Vec::new();
            self.alive[f as usize] = false;
        }
        moving.push((v, DVec2::ZERO, if bi.is_some() { 2 } else { 0 }));
        // The new fan, or the ring retriangulated (no crease: one side).
        let fan = match &plan.triangles {
            Some(triangles) => triangles.iter().map(|&t| (0, t)).collect(),
            None => Self::fan(&ring, ui),
        };
        let mut made: Vec<(u32, [DVec2; 3], u8)> = Vec::with_capacity(fan.len());
        for &(i, [a, b, c]) in &fan {
            let t = [ring.verts[a], ring.verts[b], ring.verts[c]];
            let f = self.faces.len() as u32;
            self.faces.push(t);
            self.alive.push(true);
            self.points.push(Vec::new());
            made.push((f, [flat[a], flat[b], flat[c]], Self::side(&ring, ui, bi, i)));
        }
        for &w in &ring.verts {
            let fs = &mut self.vfaces[w as usize];
            fs.retain(|&f| self.alive[f as usize]);
        }
        for &(f, _, _) in &made {
            for w in self.faces[f as usize] {
                self.vfaces[w as usize].push(f);
            }
        }
        // Locate every moving point in a fan triangle of its side (`v`
        // itself, on a crease, lies on the line: either side).
        for (p, x, side) in moving {
            // A side may have no fan triangle left (its one triangle was
            // `v, u, b`): its points go onto the line `u b`.
            let sided = side != 2 && made.iter().any(|m| m.2 == side);
            let mut best: Option<(f64, u32, [f64; 3])> = None;
            for &(f, [a, b, c], s) in &made {
                if sided && s != side {
                    continue;
                }
                let area = (b - a).perp_dot(c - a);
                let l = [
                    (b - x).perp_dot(c - x) / area,
                    (c - x).perp_dot(a - x) / area,
                    (a - x).perp_dot(b - x) / area,
                ];
                let worst = l[0].min(l[1]).min(l[2]);
                if best.is_none_or(|b| worst > b.0) {
                    best = Some((worst, f, l));
                }
            }
            let (worst, f, mut l) = best.expect("a fan triangle");
            if worst < 0.0 {
                for x in &mut l {
                    *x = x.max(0.0);
                }
                let s: f64 = l.iter().sum();
                for x in &mut l {
                    *x /= s;
                }
            }
            self.location[p as usize] = Location::Face(f, l);
            self.points[f as usize].push(p);
        }
        // Bookkeeping.
        let qv = self.quadric[v as usize];
        self.quadric[u as usize].add(&qv);
        if let Some(bi) = bi {
            let b = ring.verts[bi];
            self.creases.remove(&edge_key(v, u));
            self.creases.remove(&edge_key(v, b));
            self.creases.insert(edge_key(u, b));
        }
        self.vfaces[v as usize].clear();
        self.removed[v as usize] = true;
        self.alive_vertices -= 1;
        self.alive_faces = self.alive_faces + made.len() - ring.faces.len();
        ring.verts
    }
}
