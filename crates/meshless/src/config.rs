//! The knobs of the meshless precomputation and relighting, with the seed's defaults
//! (Meshless §2.3, §3.2, §4.2) and the choices marked "ours".

use serde::{Deserialize, Serialize};

use crate::MeshlessError;

/// Configuration of [`crate::Precomputed::build`] and the relighter.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MeshlessConfig {
    /// Receiver levels `L_r` (§4.2: 6), `1..=16`.
    pub receiver_levels: usize,
    /// Sender levels `L_s`, the first levels of the same basis (§4.2: 3), `1..=L_r`.
    pub sender_levels: usize,
    /// Poisson-disk spacing `R_coarse` of level 0 in scene units (§2.3: a user
    /// constant); `R_l = R_coarse / 2^l`. `None`: [`DEFAULT_R_FRACTION`] of the diagonal
    /// of the scene's bounding box (ours; a convenience that, unlike an explicit value,
    /// changes when a rotation changes the box).
    pub r_coarse: Option<f64>,
    /// Support factor `C` of level 0, `r = C·R` (§2.3: 1.5).
    pub c_coarse: f64,
    /// Support factor `C` of the finest level (§2.3: 2.5); linear in between.
    pub c_fine: f64,
    /// Consecutive dart-throwing failures that close a level (§2.3: 2000).
    pub max_failures: usize,
    /// Bounces of an importance particle (§2.3: 30).
    pub particle_bounces: usize,
    /// Leading bounces whose hits are not deposited as candidates (§2.3: 3).
    pub skip_bounces: usize,
    /// Rays of the free-distance test (ours: 32; 0 disables the test).
    pub free_rays: usize,
    /// Candidates whose harmonic-mean free distance over rays of length `3R` is below
    /// `free_reject · R` are rejected (§2.3: 1/6).
    pub free_reject: f64,
    /// Gather rays `N_g` per receiver in eq. (16) (ours: 256).
    pub gather_rays: usize,
    /// Link threshold `ε` (§4.2: 0.025; dimensionless), `>= 0`.
    pub epsilon: f64,
    /// How `ε` applies to a sender's level ([`LinkThreshold`]; files written before
    /// this field existed were built with [`LinkThreshold::Uniform`]).
    #[serde(default = "LinkThreshold::legacy")]
    pub threshold: LinkThreshold,
    /// Largest share of a level-0 receiver's gathered link mass that the Fig. 5
    /// criteria may drop (ours; default [`DEFAULT_MAX_DROPPED_SHARE`]; `None`, or
    /// `Some(1.0)`, which never keeps a link back: the seed's criteria alone). The mass of
    /// receiver `i` is `M_i = Σ_j ‖T'_ij‖` over its gathered row (eq. (16)); when the
    /// links the criteria drop sum to more than `share · M_i`, the largest of them are
    /// kept back until the dropped rest is at most `share · M_i`. A uniform `ε` drops
    /// the many small links of a fine level 0 (each `∝ R_coarse²`), which together
    /// carry much of the irradiance, and a dropped level-0 link is never refined; this
    /// bound is scale-free. Finer receivers keep the seed's criteria (applied to them
    /// too, the bound keeps eq. (17)'s small differences and gather noise: 5× the
    /// links on the Cornell box). In `[0, 1]`. Files written before this field existed
    /// were built with the seed's criteria and read back as `None`.
    #[serde(default)]
    pub max_dropped_share: Option<f64>,
    /// Threshold of the bounce products: links with `‖S_ij‖ < bounce_epsilon` are
    /// dropped after each product `S_{b+1} = T₀·Q·S_b` (ours; `None`: `ε/10`). The seed
    /// drops at `ε`; with `ε = 0.005` that loses ~25 % of the Cornell box's indirect
    /// energy (its second-bounce links are spread over every sender), `ε/10` about 1 %.
    pub bounce_epsilon: Option<f64>,
    /// Bounces `B` of the Neumann series `S = Σ_{b ≤ B} S_b` (§4.2: 4), `>= 1`.
    pub bounces: usize,
    /// Seed of every random stream (particles, gather strata).
    pub seed: u64,
    /// Viewpoint of point placement (default: the scene's first camera, else the
    /// centre of its bounding box).
    pub viewpoint: Option<[f64; 3]>,
    /// Largest number of points on all levels (an error, not an allocation failure,
    /// when reached).
    pub max_points: usize,
    /// Largest number of links in `T` or `S`.
    pub max_links: usize,
    /// At runtime, senders with `|e_j| <= skip · max |e|` are skipped (ours: 1e-3).
    pub skip: f64,
}

impl Default for MeshlessConfig {
    fn default() -> Self {
        Self {
            receiver_levels: 6,
            sender_levels: 3,
            r_coarse: None,
            c_coarse: 1.5,
            c_fine: 2.5,
            max_failures: 2000,
            particle_bounces: 30,
            skip_bounces: 3,
            free_rays: 32,
            free_reject: 1.0 / 6.0,
            gather_rays: 256,
            epsilon: 0.025,
            threshold: LinkThreshold::Uniform,
            max_dropped_share: Some(DEFAULT_MAX_DROPPED_SHARE),
            bounce_epsilon: None,
            bounces: 4,
            seed: 0,
            viewpoint: None,
            max_points: 4_000_000,
            max_links: 200_000_000,
            skip: 1e-3,
        }
    }
}

/// How the link threshold `ε` applies to the senders of each level.
///
/// A link `T_ij` is the vector irradiance at `x_i` per unit coefficient of sender `j`,
/// so it scales with the integral of `B_j`: with Shepard normalisation (eq. (2)) that
/// is the area per point of the sender's level, `∝ R_l²`. A level-`l` sender's links
/// are then `4^l` times smaller than a level-0 sender's for the same irradiance per
/// unit area, and a uniform `ε` drops proportionally more of the finer levels.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[non_exhaustive]
pub enum LinkThreshold {
    /// `ε` for every link (the seed, Fig. 5; the default).
    Uniform,
    /// `ε·(R_l/R_coarse)² = ε/4^l` for a sender on level `l` (ours): the
    /// threshold follows the sender's support area, so `ε` bounds the dropped
    /// irradiance per unit sender area alike on every level. Level-0 links are tested
    /// as in the seed; finer senders keep more links.
    SenderArea,
}

impl LinkThreshold {
    /// The threshold of files written before the field existed.
    fn legacy() -> Self {
        Self::Uniform
    }

    /// The factor of `ε` for a sender on level `l`.
    pub fn factor(self, l: usize) -> f64 {
        match self {
            Self::Uniform => 1.0,
            Self::SenderArea => 0.25f64.powi(l as i32),
        }
    }
}

fn check_finite(what: &'static str, v: f64) -> Result<(), MeshlessError> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(MeshlessError::config(what, format!("{v} is not finite")))
    }
}

/// The default [`MeshlessConfig::max_dropped_share`] (ours, session 29): each level-0
/// receiver's dropped links carry at most 5 % of its gathered link mass.
///
/// Chosen from measurements on the Cornell box at `ε = 0.005`, `R_coarse` 0.068 m, 3/2
/// levels, 8 bounces and the default 256 gather rays (docs/performance.md,
/// meshless-scaling), against a path-traced reference (noise floor 1.13 %): the
/// seed's criteria alone keep 0.737 of the indirect energy (26.3 % relative L1), a
/// share of 0.1 keeps 0.965 (5.16 %), 0.05 keeps 0.990 (3.80 %, 193k links in `T`
/// against 154k with the seed's criteria); only 0.1 and 0.05 were tried at 256 rays,
/// and at 128 rays, where the gather noise already keeps links, 0.05 overshoots
/// (energy 1.045). Not measured at the seed's `ε = 0.025`, the default [`MeshlessConfig::epsilon`].
pub const DEFAULT_MAX_DROPPED_SHARE: f64 = 0.05;

/// `R_coarse` as a fraction of the scene's bounding-box diagonal when
/// [`MeshlessConfig::r_coarse`] is `None`.
pub const DEFAULT_R_FRACTION: f64 = 0.05;

impl MeshlessConfig {
    /// The threshold of the bounce products ([`MeshlessConfig::bounce_epsilon`]).
    pub fn bounce_epsilon_value(&self) -> f64 {
        self.bounce_epsilon.unwrap_or(self.epsilon / 10.0)
    }

    /// The link threshold of each sender level `0..sender_levels`: `ε` (or the bounce
    /// threshold when `bounce` is set) times [`LinkThreshold::factor`].
    pub fn level_thresholds(&self, bounce: bool) -> Vec<f64> {
        let eps = if bounce {
            self.bounce_epsilon_value()
        } else {
            self.epsilon
        };
        (0..self.sender_levels)
            .map(|l| eps * self.threshold.factor(l))
            .collect()
    }

    /// `R_coarse` in scene units for a scene whose bounding box has diagonal `diag`.
    pub fn r_coarse_for(&self, diag: f64) -> f64 {
        self.r_coarse.unwrap_or(DEFAULT_R_FRACTION * diag)
    }

    /// Checks every range documented on the fields.
    ///
    /// # Errors
    /// [`MeshlessError::Config`] naming the first bad field.
    pub fn validate(&self) -> Result<(), MeshlessError> {
        let bad = |what: &'static str, reason: String| Err(MeshlessError::config(what, reason));
        if !(1..=crate::MAX_LEVELS).contains(&self.receiver_levels) {
            return bad(
                "receiver_levels",
                format!("{} not in 1..={}", self.receiver_levels, crate::MAX_LEVELS),
            );
        }
        if self.sender_levels == 0 || self.sender_levels > self.receiver_levels {
            return bad(
                "sender_levels",
                format!(
                    "{} not in 1..=receiver_levels ({})",
                    self.sender_levels, self.receiver_levels
                ),
            );
        }
        for (what, v) in [
            ("r_coarse", self.r_coarse.unwrap_or(1.0)),
            ("c_coarse", self.c_coarse),
            ("c_fine", self.c_fine),
            ("free_reject", self.free_reject),
            ("epsilon", self.epsilon),
            ("bounce_epsilon", self.bounce_epsilon.unwrap_or(0.0)),
            ("skip", self.skip),
        ] {
            check_finite(what, v)?;
        }
        if let Some(r) = self.r_coarse
            && !(r > 0.0)
        {
            return bad("r_coarse", format!("{r} must be > 0"));
        }
        if !(self.c_coarse >= 1.0 && self.c_fine >= 1.0) {
            return bad(
                "c_coarse/c_fine",
                format!(
                    "support factors {} and {} must be >= 1 (supports must cover the Poisson disks)",
                    self.c_coarse, self.c_fine
                ),
            );
        }
        if self.epsilon < 0.0 {
            return bad("epsilon", format!("{} must be >= 0", self.epsilon));
        }
        if let Some(d) = self.max_dropped_share
            && !(0.0..=1.0).contains(&d)
        {
            return bad("max_dropped_share", format!("{d} not in [0, 1]"));
        }
        if self.bounce_epsilon.is_some_and(|b| b < 0.0) {
            return bad("bounce_epsilon", "must be >= 0".into());
        }
        if !(0.0..1.0).contains(&self.skip) {
            return bad("skip", format!("{} not in [0, 1)", self.skip));
        }
        if self.free_reject < 0.0 {
            return bad("free_reject", format!("{} must be >= 0", self.free_reject));
        }
        if self.gather_rays == 0 {
            return bad("gather_rays", "N_g must be >= 1".into());
        }
        if self.bounces == 0 {
            return bad("bounces", "B must be >= 1".into());
        }
        if self.max_failures == 0 {
            return bad("max_failures", "must be >= 1".into());
        }
        if self.particle_bounces == 0 || self.skip_bounces >= self.particle_bounces {
            return bad(
                "particle_bounces/skip_bounces",
                format!(
                    "{} bounces with {} skipped deposit nothing",
                    self.particle_bounces, self.skip_bounces
                ),
            );
        }
        if let Some(v) = self.viewpoint
            && !v.iter().all(|c| c.is_finite())
        {
            return Err(MeshlessError::Viewpoint {
                viewpoint: v,
                reason: "not finite".into(),
            });
        }
        Ok(())
    }

    /// Support factor `C_l` of level `l` (linear from `c_coarse` to `c_fine`; `c_coarse`
    /// for a single level).
    pub fn support_factor(&self, l: usize) -> f64 {
        let levels = self.receiver_levels;
        if levels <= 1 {
            return self.c_coarse;
        }
        let t = l as f64 / (levels - 1) as f64;
        self.c_coarse + (self.c_fine - self.c_coarse) * t
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_configs_are_typed_errors() {
        let cases: Vec<(&str, MeshlessConfig)> = vec![
            (
                "receiver_levels",
                MeshlessConfig {
                    receiver_levels: 0,
                    ..Default::default()
                },
            ),
            (
                "receiver_levels",
                MeshlessConfig {
                    receiver_levels: 17,
                    ..Default::default()
                },
            ),
            (
                "sender_levels",
                MeshlessConfig {
                    sender_levels: 7,
                    ..Default::default()
                },
            ),
            (
                "r_coarse",
                MeshlessConfig {
                    r_coarse: Some(0.0),
                    ..Default::default()
                },
            ),
            (
                "r_coarse",
                MeshlessConfig {
                    r_coarse: Some(-1.0),
                    ..Default::default()
                },
            ),
            (
                "r_coarse",
                MeshlessConfig {
                    r_coarse: Some(f64::NAN),
                    ..Default::default()
                },
            ),
            (
                "epsilon",
                MeshlessConfig {
                    epsilon: -1e-3,
                    ..Default::default()
                },
            ),
            (
                "epsilon",
                MeshlessConfig {
                    epsilon: f64::NAN,
                    ..Default::default()
                },
            ),
            (
                "max_dropped_share",
                MeshlessConfig {
                    max_dropped_share: Some(1.5),
                    ..Default::default()
                },
            ),
            (
                "max_dropped_share",
                MeshlessConfig {
                    max_dropped_share: Some(f64::NAN),
                    ..Default::default()
                },
            ),
            (
                "gather_rays",
                MeshlessConfig {
                    gather_rays: 0,
                    ..Default::default()
                },
            ),
            (
                "bounces",
                MeshlessConfig {
                    bounces: 0,
                    ..Default::default()
                },
            ),
            (
                "skip",
                MeshlessConfig {
                    skip: 1.0,
                    ..Default::default()
                },
            ),
        ];
        for (what, c) in cases {
            match c.validate() {
                Err(MeshlessError::Config { what: w, .. }) => assert_eq!(w, what),
                other => panic!("{what}: {other:?}"),
            }
        }
        let c = MeshlessConfig {
            viewpoint: Some([0.0, f64::INFINITY, 0.0]),
            ..Default::default()
        };
        assert!(matches!(c.validate(), Err(MeshlessError::Viewpoint { .. })));
        MeshlessConfig::default().validate().unwrap();
    }

    #[test]
    fn thresholds_per_sender_level() {
        let mut c = MeshlessConfig {
            epsilon: 0.02,
            bounce_epsilon: Some(1e-3),
            ..Default::default()
        };
        assert_eq!(c.level_thresholds(false), vec![0.02; 3]);
        c.threshold = LinkThreshold::SenderArea;
        assert_eq!(c.level_thresholds(false), vec![0.02, 0.005, 0.00125]);
        assert_eq!(c.level_thresholds(true), vec![1e-3, 2.5e-4, 6.25e-5]);
        // A configuration saved before the field existed reads as uniform.
        let mut v = serde_json::to_value(&c).unwrap();
        v.as_object_mut().unwrap().remove("threshold");
        let old: MeshlessConfig = serde_json::from_value(v).unwrap();
        assert_eq!(old.threshold, LinkThreshold::Uniform);
    }

    #[test]
    fn support_factor_is_linear() {
        let c = MeshlessConfig::default();
        assert_eq!(c.support_factor(0), 1.5);
        assert!((c.support_factor(5) - 2.5).abs() < 1e-15);
        assert!((c.support_factor(2) - 1.9).abs() < 1e-12);
    }
}
