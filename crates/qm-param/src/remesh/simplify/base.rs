//! What a simplification makes: the base mesh of a part and the map of
//! every input vertex onto it ([`Base`], [`Location`]), and the bases passed
//! through on the way ([`Simplified`]).

/// Where an input vertex lies on the base mesh.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Location {
    /// It is a base vertex.
    Vertex,
    /// In base triangle `.0` (an index of [`Base::triangles`]) at
    /// barycentric coordinates `.1` of its corners.
    Face(u32, [f64; 3]),
}

/// A base triangle mesh of a component and the map onto it.
#[derive(Clone, Debug)]
pub struct Base {
    /// Counter-clockwise base triangles on the component's vertex ids.
    pub triangles: Vec<[u32; 3]>,
    /// Per component vertex.
    pub location: Vec<Location>,
    /// Per component vertex: whether it lies on a feature line (a boundary
    /// or a crease), where the map keeps it.
    pub feature: Vec<bool>,
    /// Whether crease lines were ended at their sharp turns, as scanner
    /// noise (see [`simplify_part`](super::simplify_part)).
    pub noisy_creases: bool,
}

/// What [`simplify_part`](super::simplify_part) made: the base, and the
/// bases passed through at the checkpoints asked for (count asked, base),
/// largest first.
pub struct Simplified {
    pub base: Base,
    pub passed: Vec<(usize, Base)>,
}
