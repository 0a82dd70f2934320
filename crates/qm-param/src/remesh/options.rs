//! The remesher's settings and what it reports.
//!
//! [`RemeshOptions`] says how many samples to aim for, at which level, how
//! the base domain is made ([`BaseDomain`]) and within which limits (memory,
//! folds, the PSNR floor). A remesh comes back as [`Remeshed`]: the
//! semi-regular mesh and its [`RemeshReport`], with a [`ComponentReport`] per
//! part and the [`NormalReport`] of normal placement.

use qm_lift::SemiRegularMesh;

use crate::clean::CleanReport;

/// Remesher settings.
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub struct RemeshOptions {
    /// Subdivision level `L`; `None` picks it from [`Self::samples_per_vertex`].
    pub level: Option<u32>,
    /// Samples to aim for per input vertex when choosing the level.
    pub samples_per_vertex: f64,
    /// Most samples to aim for (dense scans need far fewer samples per
    /// vertex than coarse models), unless the input has more vertices:
    /// then [`DENSE_SAMPLES_PER_VERTEX`](super::budget::DENSE_SAMPLES_PER_VERTEX)
    /// a vertex, so that the ceiling follows the input, not this count.
    pub max_samples: usize,
    /// Stretch-reweighting iterations of the parameterization.
    pub stretch_iterations: usize,
    /// Most extra cuts towards points of high stretch, per component.
    pub extra_cuts: usize,
    /// Rounds of least-squares fitting of the samples to the surface (0:
    /// samples lie on the surface, interpolating it).
    pub fit_rounds: usize,
    /// Place the samples again, coarse to fine, so that the codec's details
    /// point along its frame normals where that is safe (a normal mesh;
    /// module `normal`).
    pub normal: bool,
    /// Most bytes remeshing and encoding may take
    /// ([`encode_memory`](super::encode_memory)):
    /// checked on the input before any work and on the level's samples
    /// before they are made.
    pub max_memory: u64,
    /// Bytes the caller holds beside the work until it is encoded (an
    /// asset's decoded images), counted against
    /// [`max_memory`](Self::max_memory) with the estimate.
    pub held: u64,
    /// Remesh even where a chart's map onto its base domain folds (the remesh
    /// then overlaps itself there); by default that is an error
    /// ([`RemeshFailure::Folds`](crate::RemeshFailure::Folds)), before any
    /// sample is made.
    pub accept_folds: bool,
    /// How the base domain is made.
    pub domain: BaseDomain,
    /// The lowest PSNR (against the input's bounding box diagonal) a remesh
    /// through a simplified base domain may have: the remesher measures
    /// it, and below this fails with
    /// [`RemeshFailure::TooFar`](crate::RemeshFailure::TooFar). 0 accepts
    /// any.
    pub min_psnr: f64,
}

/// How the remesher makes its base domain.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
#[non_exhaustive]
pub enum BaseDomain {
    /// Both, measured: one square per component, unless that fails (a part
    /// that does not map, glue or lay out on a square, or whose map folds)
    /// or the simplified base domain measures clearly better.
    #[default]
    Auto,
    /// One square per component: a cut to a disk, mapped onto a square of
    /// base quads (modules `cut`, `square`).
    Square,
    /// A simplified base domain of many charts, every input vertex mapped
    /// onto it (modules `simplify`, `charts`; MAPS).
    Charts,
    /// The input's own triangles, three quads each, at level 0 (module
    /// `exact`): the input exactly, but no finer levels to stream.
    Input,
}

impl RemeshOptions {
    /// Defaults: level for about 30 samples per input vertex but at most
    /// about a million samples, 7 stretch
    /// iterations, up to 2 extra cuts per component, 3 fitting rounds,
    /// normal placement.
    pub const DEFAULT: RemeshOptions = RemeshOptions {
        level: None,
        samples_per_vertex: 30.0,
        max_samples: 1 << 20,
        stretch_iterations: 7,
        extra_cuts: 2,
        fit_rounds: 3,
        normal: true,
        max_memory: DEFAULT_MAX_MEMORY,
        held: 0,
        accept_folds: false,
        domain: BaseDomain::Auto,
        min_psnr: DEFAULT_MIN_PSNR,
    };

    /// Sets the level.
    pub const fn with_level(mut self, level: Option<u32>) -> Self {
        self.level = level;
        self
    }

    /// Sets the sample density target.
    pub const fn with_samples_per_vertex(mut self, ratio: f64) -> Self {
        self.samples_per_vertex = ratio;
        self
    }

    /// Sets the number of extra cuts.
    pub const fn with_extra_cuts(mut self, cuts: usize) -> Self {
        self.extra_cuts = cuts;
        self
    }

    /// Sets the rounds of least-squares fitting.
    pub const fn with_fit_rounds(mut self, rounds: usize) -> Self {
        self.fit_rounds = rounds;
        self
    }

    /// Sets whether the samples are placed for normal details.
    pub const fn with_normal(mut self, normal: bool) -> Self {
        self.normal = normal;
        self
    }

    /// Sets the memory limit, in bytes.
    pub const fn with_max_memory(mut self, bytes: u64) -> Self {
        self.max_memory = bytes;
        self
    }

    /// Sets the bytes held beside the work ([`Self::held`]).
    pub const fn with_held(mut self, bytes: u64) -> Self {
        self.held = bytes;
        self
    }

    /// Whether work that needs `bytes`, beside what is [`held`](Self::held),
    /// fits [`max_memory`](Self::max_memory).
    pub const fn admits(&self, bytes: u64) -> bool {
        bytes.saturating_add(self.held) <= self.max_memory
    }

    /// Sets whether folded maps are remeshed anyway.
    pub const fn with_accept_folds(mut self, accept: bool) -> Self {
        self.accept_folds = accept;
        self
    }

    /// Sets how the base domain is made.
    pub const fn with_domain(mut self, domain: BaseDomain) -> Self {
        self.domain = domain;
        self
    }

    /// Sets the floor of a simplified base domain's remesh, in dB.
    pub const fn with_min_psnr(mut self, db: f64) -> Self {
        self.min_psnr = db;
        self
    }

    /// Sets the stretch iterations.
    pub const fn with_stretch_iterations(mut self, iterations: usize) -> Self {
        self.stretch_iterations = iterations;
        self
    }
}

impl Default for RemeshOptions {
    fn default() -> Self {
        RemeshOptions::DEFAULT
    }
}

/// What the remesher did to one component.
#[derive(Clone, Debug, serde::Serialize)]
pub struct ComponentReport {
    pub vertices: usize,
    pub triangles: usize,
    pub base_quads: usize,
    pub extra_cuts: usize,
    pub stretch: f64,
    pub flipped: usize,
    pub uncovered: usize,
}

/// A remeshed mesh.
#[derive(Clone, Debug)]
pub struct Remeshed {
    /// The semi-regular mesh.
    pub mesh: SemiRegularMesh,
    /// What the remesher did.
    pub report: RemeshReport,
}

/// What the remesher did: clean-up and each component's chart.
#[derive(Clone, Debug)]
pub struct RemeshReport {
    /// The clean-up summary.
    pub clean: CleanReport,
    /// Per component.
    pub components: Vec<ComponentReport>,
    /// The subdivision level chosen.
    pub level: u32,
    /// With [`RemeshOptions::normal`]: how many samples were placed on
    /// their normal ray.
    pub normal: Option<NormalReport>,
    /// The base domain made: `"square"` or `"charts"`.
    pub domain: &'static str,
    /// Why [`BaseDomain::Auto`] took the domain it did, where it was not
    /// its first choice: one square per part failed, measured worse or was
    /// not tried ([`MOST_CUT_LOOPS`](super::auto::MOST_CUT_LOOPS)), or
    /// charts failed.
    pub fallback: Option<String>,
    /// The remesh's PSNR against the input, as the remesher measured it
    /// (through charts always, [`RemeshOptions::min_psnr`]; through one
    /// square with [`BaseDomain::Auto`]).
    pub psnr: Option<f64>,
    /// The memory estimate ([`encode_memory`](super::encode_memory)) of
    /// remeshing and encoding this input into this remesh; where
    /// [`BaseDomain::Auto`] made both remeshes at once, of both.
    pub memory: u64,
}

/// What normal placement did ([`RemeshOptions::normal`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub struct NormalReport {
    /// Samples moved onto the ray from their prediction along the normal.
    pub moved: usize,
    /// Samples left where the fit put them (no plausible hit of the
    /// surface near them).
    pub kept: usize,
}

/// The default floor of a remesh through a simplified base domain
/// ([`RemeshOptions::min_psnr`]), in dB: a remesh below it is visibly not
/// the input.
pub const DEFAULT_MIN_PSNR: f64 = 50.0;

/// The default memory limit of remeshing and encoding: 4 GiB. Higher than
/// a decoder's (which takes files from strangers): the input is the user's
/// own mesh.
pub const DEFAULT_MAX_MEMORY: u64 = 4 << 30;
