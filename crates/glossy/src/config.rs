//! The knobs of the glossy method, with their defaults and ranges.

use crate::directions::DirectionKind;
use crate::error::{GlossyError, invalid};
use crate::nonstandard::Decomposition;
use crate::patch::ImportanceSource;
use crate::solve::LinearSolver;
use crate::transport::TransportOptions;
use crate::ward::WardVariant;

/// Which senders the final gather (Glossy §5.5) integrates.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub enum GatherMode {
    /// Every basis function of every patch ("complete").
    All,
    /// Senders linked to a function supporting `(y, ω_ye)` ("faster").
    Linked,
    /// Senders linked to the root `φ` of `y`'s patch ("fastest"; the paper saw no loss).
    #[default]
    Root,
}

impl GatherMode {
    /// Lower-case name.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::All => "all",
            Self::Linked => "linked",
            Self::Root => "root",
        }
    }
}

/// Everything [`crate::GlossySolution`] needs besides the scene.
#[derive(Debug, Clone, PartialEq)]
pub struct GlossyConfig {
    /// Ward normalisation (default [`WardVariant::Bounded`]).
    pub variant: WardVariant,
    /// Hemisphere ↔ square map (default the cosine-weighted [`DirectionKind::Cosine`],
    /// ours; the paper's is [`DirectionKind::Glossy`]).
    pub directions: DirectionKind,
    /// Linear solver (default Gauss–Seidel; standard decomposition only).
    pub solver: LinearSolver,
    /// Operator decomposition (default the paper's standard one; the non-standard one
    /// iterates push–gather–pull Picard sweeps whatever `solver` says, and needs
    /// importance off).
    pub decomposition: Decomposition,
    /// Relative change (or GMRES residual) that ends a solve (default `1e-6`).
    pub tolerance: f64,
    /// Iteration cap per solve (default 500).
    pub max_iterations: usize,
    /// Refinement rounds (default 4; 0: the `V⁰` solution only).
    pub rounds: usize,
    /// A round computes every candidate whose value is at least this fraction of the
    /// round's largest (Glossy §5.3: 10 %); in `(0, 1]`.
    pub fraction: f64,
    /// Importance source (default off).
    pub importance: ImportanceSource,
    /// Refinement stops adding links at this count (the run continues).
    pub max_links: usize,
    /// Refinement stops adding links past this memory (bytes, links + coefficients).
    pub max_bytes: usize,
    /// Deepest node level (`≤` [`crate::basis::MAX_LEVEL`]; default 5).
    pub max_level: u8,
    /// Samples of every transport coefficient.
    pub transport: TransportOptions,
    /// Directional rays per receiving node for the reflected importance (and
    /// radiance) arriving at it, and as many samples (a shadow ray each) of the
    /// emitted part per band set with sources (default 16; see [`crate::refine`]).
    pub importance_rays: usize,
    /// Level of the up-front decomposition of directional / textured emitters and of
    /// the eye's pyramid (default 4).
    pub emitter_level: u8,
    /// Relative cut-off of kept emitter coefficients (default `1e-4`).
    pub emitter_tolerance: f64,
    /// Stop refining when a `watch`-sized eye image changes by less than this relative
    /// L² amount between rounds (`None`: off; needs a camera).
    pub image_tolerance: Option<f64>,
    /// Seed of all jitter.
    pub seed: u64,
}

impl Default for GlossyConfig {
    fn default() -> Self {
        Self {
            variant: WardVariant::Bounded,
            directions: DirectionKind::Cosine,
            solver: LinearSolver::GaussSeidel,
            decomposition: Decomposition::Standard,
            tolerance: 1e-6,
            max_iterations: 500,
            rounds: 4,
            fraction: 0.1,
            importance: ImportanceSource::Off,
            max_links: 2_000_000,
            max_bytes: 4 << 30,
            max_level: 5,
            transport: TransportOptions::default(),
            importance_rays: 16,
            emitter_level: 4,
            emitter_tolerance: 1e-4,
            image_tolerance: None,
            seed: 0,
        }
    }
}

impl GlossyConfig {
    /// Checks every range.
    ///
    /// # Errors
    /// [`GlossyError::Invalid`] naming the first bad knob.
    pub fn validate(&self) -> Result<(), GlossyError> {
        self.transport.validate()?;
        if !(self.tolerance.is_finite() && self.tolerance >= 0.0) {
            return Err(invalid(
                "tolerance",
                format!("{} must be finite and >= 0", self.tolerance),
            ));
        }
        if self.decomposition == Decomposition::NonStandard
            && !matches!(self.importance, ImportanceSource::Off)
        {
            return Err(invalid(
                "decomposition",
                "the non-standard decomposition supports importance off only",
            ));
        }
        if self.max_iterations == 0 {
            return Err(invalid("max iterations", "must be >= 1"));
        }
        if !(self.fraction > 0.0 && self.fraction <= 1.0) {
            return Err(invalid(
                "fraction",
                format!("{} not in (0, 1]", self.fraction),
            ));
        }
        if self.max_level > crate::basis::MAX_LEVEL {
            return Err(invalid(
                "max level",
                format!("{} > {}", self.max_level, crate::basis::MAX_LEVEL),
            ));
        }
        if !(1..=1024).contains(&self.importance_rays) {
            return Err(invalid(
                "importance rays",
                format!("{} not in 1..=1024", self.importance_rays),
            ));
        }
        if self.emitter_level > 7 {
            return Err(invalid(
                "emitter level",
                format!("{} > 7", self.emitter_level),
            ));
        }
        if !(self.emitter_tolerance.is_finite() && (0.0..1.0).contains(&self.emitter_tolerance)) {
            return Err(invalid(
                "emitter tolerance",
                format!("{} not in [0, 1)", self.emitter_tolerance),
            ));
        }
        if let Some(t) = self.image_tolerance
            && !(t.is_finite() && t >= 0.0)
        {
            return Err(invalid(
                "image tolerance",
                format!("{t} must be finite and >= 0"),
            ));
        }
        Ok(())
    }
}
