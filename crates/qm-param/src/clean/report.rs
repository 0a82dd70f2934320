//! What the clean-up changed, counted ([`CleanReport`]), and its one-line
//! summary.

use std::fmt;

/// Counts of what [`clean`](super::clean) changed. Face counts after step 1 are in
/// triangles.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[non_exhaustive]
pub struct CleanReport {
    /// Vertices of the input.
    pub input_vertices: usize,
    /// Faces (polygons) of the input.
    pub input_faces: usize,
    /// Triangles after fan triangulation.
    pub triangles: usize,
    /// Vertices merged into an earlier one with a bit-identical position.
    pub merged_vertices: usize,
    /// Faces with fewer than three corners, and triangles with a repeated
    /// vertex or zero area.
    pub dropped_degenerate: usize,
    /// Triangles dropped for sharing their vertex set with a triangle that
    /// is kept (step 3); those in [`Self::cancelled_faces`] are not counted.
    pub dropped_duplicate: usize,
    /// Faces of opposite pairs (the same vertex set, run the other way)
    /// dropped both, in sheets that meet other faces.
    pub cancelled_faces: usize,
    /// Edges shared by faces that were not joined across them: more than
    /// two faces left unpaired, an orientation conflict, or a cut to
    /// separate a fan.
    pub split_edges: usize,
    /// Edges with more than two faces whose faces were paired into
    /// manifold sheets (step 4).
    pub paired_edges: usize,
    /// Vertices given more than one copy (split edges' ends and bow ties).
    pub split_vertices: usize,
    /// Vertex copies added by splitting.
    pub added_vertices: usize,
    /// Output triangles whose orientation is the reverse of the input's.
    pub flipped_faces: usize,
    /// Vertices (after merging) used by no remaining triangle.
    pub dropped_unused_vertices: usize,
    /// Connected components.
    pub components: usize,
    /// Vertices of all components together.
    pub output_vertices: usize,
    /// Triangles of all components together.
    pub output_faces: usize,
}

impl fmt::Display for CleanReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "clean-up: {} -> {} vertices ({} duplicates merged, {} unused dropped, {} added by splits), \
             {} faces -> {} triangles ({} degenerate and {} duplicate dropped, {} cancelled in opposite pairs), \
             {} non-manifold edges paired, {} edges and {} vertices split, {} faces flipped, {} component{}",
            Thousands(self.input_vertices),
            Thousands(self.output_vertices),
            Thousands(self.merged_vertices),
            Thousands(self.dropped_unused_vertices),
            Thousands(self.added_vertices),
            Thousands(self.input_faces),
            Thousands(self.output_faces),
            Thousands(self.dropped_degenerate),
            Thousands(self.dropped_duplicate),
            Thousands(self.cancelled_faces),
            Thousands(self.paired_edges),
            Thousands(self.split_edges),
            Thousands(self.split_vertices),
            Thousands(self.flipped_faces),
            Thousands(self.components),
            if self.components == 1 { "" } else { "s" },
        )
    }
}

/// A count with thousands separators: `3,225`.
pub(super) struct Thousands(pub(super) usize);

impl fmt::Display for Thousands {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let digits = self.0.to_string();
        for (i, d) in digits.chars().enumerate() {
            if i > 0 && (digits.len() - i) % 3 == 0 {
                f.write_str(",")?;
            }
            write!(f, "{d}")?;
        }
        Ok(())
    }
}
