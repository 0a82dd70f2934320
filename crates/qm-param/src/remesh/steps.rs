//! The steps of a remesh, announced as they start ([`Step`]), so that a
//! caller can show where the time goes ([`remesh_reporting`](super::remesh_reporting)).

use std::fmt;

/// A step of remeshing. Under [`BaseDomain::Auto`](super::BaseDomain::Auto)
/// both base domains are made at once, so their steps interleave.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum Step {
    /// Merging duplicate vertices, pairing non-manifold edges, orienting
    /// and splitting the input into parts.
    Cleaning,
    /// One square per part: cutting each part open into a disk and mapping
    /// it onto a square (sparse solves).
    MappingSquares,
    /// One square per part: sampling each square's grid on the surface.
    SamplingSquares,
    /// The simplified base domain: simplifying each part to its base.
    Simplifying,
    /// The simplified base domain: charting the input over the base,
    /// untangling and relaxing the map, and sampling it.
    MappingCharts,
    /// Measuring a remesh against the input (the symmetric surface
    /// distance), to choose between base domains.
    Measuring,
}

impl fmt::Display for Step {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Step::Cleaning => "cleaning up the input",
            Step::MappingSquares => "one square per part: mapping",
            Step::SamplingSquares => "one square per part: sampling",
            Step::Simplifying => "simplified base: simplifying",
            Step::MappingCharts => "simplified base: charting, relaxing and sampling",
            Step::Measuring => "measuring a remesh against the input",
        })
    }
}

/// Where [`Step`]s are announced: called from the remesher's threads.
pub type Reporter<'a> = &'a (dyn Fn(Step) + Sync);
