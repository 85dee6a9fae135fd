//! Gauss–Seidel-like relaxation methods on the fixed-point form `(I − K) x = b`.
//!
//! All methods follow Ziegler's generic update, Alg. 2.3.3: choose an index `i`,
//! choose a step `Δ`, set `x_i += Δ` and update the maintained residual
//! `r = b − (I − K) x` with one column of `K`: `r_j += K_ji Δ` for all `j`,
//! `r_i −= Δ`. The initial residual is `b` when no initial guess is given.
//!
//! | method | index `i` | step `Δ` |
//! | --- | --- | --- |
//! | Gauss–Seidel (Alg. 2.3.1) | cyclic `0, 1, …, n−1, 0, …` | `r_i / m_ii` |
//! | SOR | cyclic | `ω r_i / m_ii`, `0 < ω < 2` |
//! | Southwell (§2.3.2) | `argmax A_i |r_i|` | `r_i / m_ii` |
//! | progressive refinement (Alg. 2.3.2) | `argmax A_i |r_i|` | `r_i / m_ii` |
//! | Shao (Table 2.1) | `argmax A_i |r_i|` | `r_i + (K r)_i` |
//! | Gortler (Table 2.1) | `argmax A_i |r_i|` | `(r_i + Σ_{l≠i} K_il r_l) / (1 − Σ_{l≠i} K_il K_li)` |
//! | Feda (Table 2.1) | `argmax |(D_A (I − F̂)⁻¹ r)_k|` (see below) | `r_i + ρ_i/(1 − ρ̄) · Σ_l A_l r_l / |S|` |
//! | Xu (Table 2.1) | `argmax |(D_A (I − F̂)⁻¹ r)_k|` (see below) | `r_i + (K r)_i + ρ̄/(1 − ρ̄) · ρ_i Σ_l A_l r_l / |S|` |
//!
//! Here `m_ii = 1 − K_ii` (Ziegler assumes `m_ii = 1`, true for planar patches), `A`
//! are the area weights (default 1), `|S| = Σ A_l`, `ρ` the reflectances and
//! `F̂ = R 𝟏 D_A / |S|` (Ziegler §2.3.2, `𝟏` the all-ones matrix), i.e.
//! `F̂_kl = ρ_k A_l / |S|`.
//!
//! # How Table 2.1 is read (and where it is ambiguous)
//!
//! Ziegler writes the ideal step as `Δ = e_iᵀ M⁻¹ r` and approximates `M⁻¹` by `M̄`
//! from the table, so every step above is `Δ = (M̄ r)_i`:
//!
//! * Shao: `M̄ = I + F` (two Neumann terms).
//! * Gortler: `M̄ = Σ_j F̃_iʲ = (I − F̃_i)⁻¹` where `F̃_i` keeps only row `i` and
//!   column `i` of `F` (off-diagonal). Solving `(I − F̃_i) y = r` for `y_i` by
//!   eliminating the other unknowns (`y_k = r_k + F_ki y_i`) gives the closed form in
//!   the table above: `O(n)` work with one row and one column. *Ambiguity*: Ziegler
//!   writes the entries of `F̃_i` as `ρ_k f_kl` although his `F` already contains
//!   `R` (`F = R G`, eq. (2.16)); we read them as `K_kl`, which is what makes
//!   `Σ_j F̃_iʲ ≈ I + F` in the table hold.
//! * Feda: `M̄ = Σ_i F̂ⁱ`. Because `F̂² = ρ̄ F̂` with `ρ̄ = Σ_l A_l ρ_l / |S|`, this is
//!   `I + F̂ / (1 − ρ̄)`, the table's closed form. *Ambiguity*: Ziegler defines
//!   `ρ_avg = Σ ρ_i / n`, which makes the closed form exact only for equal areas; we
//!   use the area-weighted mean so that the printed identity holds exactly (they
//!   agree for unit area weights).
//! * Xu: `M̄ = I + F + Σ_{i≥2} F̂ⁱ = I + F + ρ̄/(1 − ρ̄) F̂`.
//! * Selection: the text conversion of the table's selection column reads `D_A r`
//!   for PR/Shao/Gortler and `(I − F̂) D_A r` for Feda/Xu ("the index i is selected
//!   such that the absolute value of the i-th component of the given matrix is
//!   maximized"). *Ambiguity, and a deviation*: taken literally, `(I − F̂) D_A r`
//!   stalls. After shooting `i` with the Feda step its residual becomes
//!   `r_i = −ρ_i u/(1 − ρ̄)` (`u = Σ A_l r_l/|S|`), whose literal selection value is
//!   then often the largest in magnitude while its step `Δ_i = r_i + ρ_i u/(1 − ρ̄)`
//!   is zero, so the same index is chosen forever (observed while testing: relative
//!   residual frozen at ≈ 0.16 on 40-patch systems, for Feda and Xu alike). Reading
//!   it as `(I − F̂)⁻¹ D_A r` (a lost superscript) still stalls for non-uniform
//!   areas (frozen at ≈ 1.7e-2 on a closed 3-patch scene). We select by
//!   `D_A (I − F̂)⁻¹ r`, i.e. `s_k = A_k (r_k + ρ_k u/(1 − ρ̄)) = A_k Δ_k^Feda`: the
//!   largest area-weighted Feda step, consistent with PR's `D_A r = D_A M̄ r`. All
//!   three readings coincide for unit areas up to the placement of the inverse.
//! * *Safeguards (a deviation)*: selection by the largest residual and the step
//!   `(M̄ r)_i` do not match, and the literal methods can stall or cycle. Gortler's
//!   step is idempotent: re-selecting the index just updated, which often still
//!   has the largest residual (`r_i` becomes `−(back·r_i + g)/(1 − back)` with
//!   `g = Σ_{l≠i} K_il r_l`, `back = Σ_{l≠i} K_il K_li`), gives `Δ = 0` exactly.
//!   Shao's repeated step decays geometrically towards a state with
//!   `r_i + (K r)_i = 0` while `r_i ≠ 0` (residuals frozen at ≈ 3e-5 on a closed
//!   3-patch scene in our tests), and Xu can alternate `+δ, −δ` on one index. Two
//!   rules, applied to the four Table 2.1 methods only:
//!   1. the index updated last is excluded from the next selection;
//!   2. a step whose effective relaxation factor `Δ m_ii / r_i` is below 1/2
//!      (including zero or the wrong sign, or any non-zero step on an index with
//!      `r_i = 0`) is replaced by a plain Southwell update: index
//!      `argmax A_j |r_j|`, step `r_j / m_jj` (one more column fetch when the
//!      index differs). Such updates are counted in
//!      [`crate::Convergence::safeguarded_updates`].
//!
//!   Overshooting (factor > 1, the point of these methods) is never limited:
//!   clamping it at 1.9 made Feda and Xu no faster than PR at ρ = 0.999 (9602
//!   sweeps against 197 and 105 on the n = 400 scene of `docs/performance.md`).
//!   With both rules and correct area weights, 6000 random closed scenes (n ≤ 14)
//!   converged to `1e-13` for all four methods. Earlier variants failed: without
//!   rule 1, Xu failed on 16 of 2000; with rule 2 taking the plain step at the same
//!   index instead of a Southwell update, Feda cycled on 1 of 6000.
//! * *Open scenes*: Feda and Xu assume a closed scene (`F̂` replaces `F` in the
//!   ambient part). In open scenes, or with area weights that do not match the
//!   form factors, the overshoot can exceed a factor of 2 and the literal step
//!   diverges. For example, take two patches that do not see each other, with
//!   `A = (1.77, 0.5)` and `ρ₀ = 0.89`. A Feda step on patch 0, while patch 1 has
//!   no unshot light, multiplies patch 0's residual by
//!   `−ρ₀ A₀ / (|S| (1 − ρ̄)) ≈ −2.3`. Rule 2 catches that case, but not every one:
//!   on 3000 random open scenes (n ≤ 14, correct areas), Feda failed to reach
//!   `1e-13` within 3000 sweeps 11 times and Xu 2 times. Feda also failed once on
//!   3000 closed scenes given unit instead of true area weights.
//! * The formulas are as printed, derived for `m_ii = 1`; Shao and Xu include
//!   `K_ii r_i` in `(K r)_i`, Gortler excludes the diagonal as `F̃_i` does.
//!
//! Feda and Xu need reflectances ([`SolverOptions::reflectance`]). Xu et al. prove
//! convergence for modified versions of Feda and Xu only (Ziegler §2.3.2); here the
//! unmodified steps are used, and the tests check convergence on diagonally dominant
//! radiosity-like systems.
//!
//! Progressive refinement returns `x̂ = x + r` (Ziegler's iteration variable) and,
//! when reflectances are given, the display solution with the ambient term of Cohen
//! et al. 1988: `x̂_i + ρ_i · ambient`, `ambient = (Σ_l A_l r_l / |S|) / (1 − ρ̄)`.
//! The ambient term is not part of the iteration (Ziegler §2.3.2, "Comparison").
//!
//! One record is written every [`SolverOptions::updates_per_record`] updates
//! (default `n`, one sweep); convergence is tested at records on the maintained
//! residual. Work counts one column per update, plus one row for Shao, Gortler and Xu.

use crate::error::{LinearError, Unsupported};
use crate::history::{Method, Solve, SolverOptions, StopReason};
use crate::operator::Operator;
use crate::util::{Recorder, check_inputs, fixed_point_residual_norm, norm};

/// The overrelaxation choices of Ziegler Table 2.1 (besides PR itself, see
/// [`progressive_refinement`]). Formulas in the [module documentation](self).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[non_exhaustive]
pub enum OverrelaxationKind {
    /// Shao & Badler 1993: `M̄ = I + F`.
    Shao,
    /// Gortler et al. 1994: `M̄ = (I − F̃_i)⁻¹` (row and column `i` of `F`).
    Gortler,
    /// Feda & Purgathofer 1992 in the form of Xu et al. 1994: `M̄ = Σ F̂ⁱ`.
    Feda,
    /// Xu et al. 1994: `M̄ = I + F + Σ_{i≥2} F̂ⁱ`.
    Xu,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Rule {
    Cyclic { omega: f64 },
    Greedy,
    Over(OverrelaxationKind),
}

/// Result of [`progressive_refinement`].
#[derive(Debug, Clone, PartialEq)]
pub struct ProgressiveSolve {
    /// The solve; `solve.x` is Ziegler's iteration variable `x̂ = x + r`.
    pub solve: Solve,
    /// The unshot residual `r` (residual of `x̂ − r`).
    pub unshot: Vec<f64>,
    /// The final ambient value `(Σ A_l r_l / |S|) / (1 − ρ̄)` (needs reflectances).
    pub ambient: Option<f64>,
    /// The display solution `x̂ + ρ · ambient` (needs reflectances).
    pub displayed: Option<Vec<f64>>,
    /// Per record: relative error of the display solution against the reference
    /// (needs reflectances and a reference).
    pub displayed_errors: Vec<Option<f64>>,
}

/// Gauss–Seidel (Ziegler Alg. 2.3.1, "gathering" written as residual updates) for
/// `(I − K) x = b`. Needs [`Operator::column`] of `K`. Converges for strictly
/// diagonally dominant `I − K` (e.g. radiosity with `ρ < 1`).
pub fn gauss_seidel<K: Operator + ?Sized>(
    k: &K,
    b: &[f64],
    opts: &SolverOptions,
) -> Result<Solve, LinearError> {
    let run = relax(
        k,
        b,
        Rule::Cyclic { omega: 1.0 },
        Method::GaussSeidel,
        false,
        opts,
    )?;
    Ok(run.solve)
}

/// Successive overrelaxation with `ω =` [`SolverOptions::omega`] (Ziegler §2.3.2,
/// `Δ = ω r_i`). Needs [`Operator::column`] of `K`.
pub fn sor<K: Operator + ?Sized>(
    k: &K,
    b: &[f64],
    opts: &SolverOptions,
) -> Result<Solve, LinearError> {
    let run = relax(
        k,
        b,
        Rule::Cyclic { omega: opts.omega },
        Method::Sor,
        false,
        opts,
    )?;
    Ok(run.solve)
}

/// Southwell relaxation: update the unknown with the largest area-weighted residual
/// `A_i |r_i|` (Ziegler §2.3.2 uses `|r_i|`, i.e. unit weights, the default).
/// Needs [`Operator::column`] of `K`.
pub fn southwell<K: Operator + ?Sized>(
    k: &K,
    b: &[f64],
    opts: &SolverOptions,
) -> Result<Solve, LinearError> {
    let run = relax(k, b, Rule::Greedy, Method::Southwell, false, opts)?;
    Ok(run.solve)
}

/// Progressive refinement (Ziegler Alg. 2.3.2, Cohen et al. 1988): Southwell
/// shooting with the displayed iterate `x̂ = x + r` and the ambient term. Needs
/// [`Operator::column`] of `K`; the ambient term needs reflectances.
pub fn progressive_refinement<K: Operator + ?Sized>(
    k: &K,
    b: &[f64],
    opts: &SolverOptions,
) -> Result<ProgressiveSolve, LinearError> {
    relax(
        k,
        b,
        Rule::Greedy,
        Method::ProgressiveRefinement,
        true,
        opts,
    )
}

/// One of the Table 2.1 overrelaxation methods. Needs [`Operator::column`] of `K`,
/// and [`Operator::row`] for Shao, Gortler and Xu; Feda and Xu need
/// [`SolverOptions::reflectance`].
pub fn overrelaxation<K: Operator + ?Sized>(
    k: &K,
    b: &[f64],
    kind: OverrelaxationKind,
    opts: &SolverOptions,
) -> Result<Solve, LinearError> {
    let run = relax(
        k,
        b,
        Rule::Over(kind),
        Method::Overrelaxation(kind),
        false,
        opts,
    )?;
    Ok(run.solve)
}

/// Smallest effective relaxation factor `Δ m_ii / r_i` accepted from a Table 2.1
/// step before the safeguard substitutes a Southwell update.
const MIN_FACTOR: f64 = 0.5;

/// Like [`argmax_abs`] but never returns `skip` (unless it is the only index).
fn argmax_abs_except(v: impl Iterator<Item = f64>, skip: Option<usize>) -> usize {
    argmax_abs(
        v.enumerate()
            .map(|(k, x)| if Some(k) == skip { 0.0 } else { x }),
    )
}

fn argmax_abs(v: impl Iterator<Item = f64>) -> usize {
    let mut best = 0;
    let mut best_v = -1.0;
    for (i, x) in v.enumerate() {
        if x.abs() > best_v {
            best_v = x.abs();
            best = i;
        }
    }
    best
}

/// The area weights `A` (default 1), `|S| = Σ A_l`, reflectances `ρ` and their area
/// mean `ρ̄` of a relaxation (module docs), and what is derived from them.
struct Weights<'a> {
    areas: Vec<f64>,
    total_area: f64,
    rho: Option<&'a [f64]>,
    rho_bar: Option<f64>,
}

impl<'a> Weights<'a> {
    fn new(opts: &'a SolverOptions, n: usize) -> Self {
        let areas: Vec<f64> = opts.areas.clone().unwrap_or_else(|| vec![1.0; n]);
        let total_area: f64 = areas.iter().sum();
        let rho = opts.reflectance.as_deref();
        let rho_bar = rho.map(|rho| {
            rho.iter().zip(&areas).map(|(r, a)| r * a).sum::<f64>()
                / total_area.max(f64::MIN_POSITIVE)
        });
        Self {
            areas,
            total_area,
            rho,
            rho_bar,
        }
    }

    /// `A_k |r_k|`-style weighted values `A_k r_k`.
    fn weighted<'r>(&'r self, r: &'r [f64]) -> impl Iterator<Item = f64> + 'r {
        r.iter().zip(&self.areas).map(|(ri, a)| ri * a)
    }

    /// `u = Σ_l A_l r_l / |S|`.
    fn mean(&self, r: &[f64]) -> f64 {
        self.weighted(r).sum::<f64>() / self.total_area
    }

    /// The ambient value `u / (1 − ρ̄)` (needs reflectances).
    fn ambient(&self, r: &[f64]) -> Option<f64> {
        self.rho_bar.map(|rb| self.mean(r) / (1.0 - rb))
    }

    /// The display solution `x̂ + ρ · ambient` (needs reflectances).
    fn displayed(&self, xh: &[f64], amb: Option<f64>) -> Option<Vec<f64>> {
        match (self.rho, amb) {
            (Some(rho), Some(amb)) => Some(xh.iter().zip(rho).map(|(v, p)| v + p * amb).collect()),
            _ => None,
        }
    }
}

/// Maps an operator's missing capability to the error naming `method`.
fn unsupported(method: Method) -> impl Fn(Unsupported) -> LinearError {
    move |source| LinearError::Unsupported { method, source }
}

/// Rejects a rule whose inputs are missing (Feda and Xu need reflectances).
fn check_rule(rule: Rule, method: Method, opts: &SolverOptions) -> Result<(), LinearError> {
    let needs_rho = matches!(
        rule,
        Rule::Over(OverrelaxationKind::Feda | OverrelaxationKind::Xu)
    );
    if needs_rho && opts.reflectance.is_none() {
        return Err(LinearError::MissingInput {
            method,
            what: "reflectances (SolverOptions::reflectance)",
        });
    }
    Ok(())
}

/// The state of one run of Ziegler's generic update (Alg. 2.3.3): iterate, maintained
/// residual, the fetched column (and row) of `K`, and the bookkeeping of the
/// selection rules and safeguards (module docs).
struct Relaxation<'a, K: ?Sized> {
    k: &'a K,
    rule: Rule,
    method: Method,
    w: Weights<'a>,
    needs_row: bool,
    x: Vec<f64>,
    r: Vec<f64>,
    col: Vec<(usize, f64)>,
    row: Vec<(usize, f64)>,
    scratch: Vec<f64>,
    next_cyclic: usize,
    /// Table 2.1 methods never update the same index twice in a row (module docs).
    last: Option<usize>,
    safeguarded: u64,
}

impl<K: Operator + ?Sized> Relaxation<'_, K> {
    /// The index to update (the rule's selection column of the module docs).
    fn choose(&mut self) -> usize {
        let (r, w) = (&self.r, &self.w);
        match self.rule {
            Rule::Cyclic { .. } => {
                let i = self.next_cyclic;
                self.next_cyclic = (self.next_cyclic + 1) % r.len();
                i
            }
            Rule::Greedy => argmax_abs(w.weighted(r)),
            Rule::Over(OverrelaxationKind::Shao | OverrelaxationKind::Gortler) => {
                argmax_abs_except(w.weighted(r), self.last)
            }
            Rule::Over(OverrelaxationKind::Feda | OverrelaxationKind::Xu) => {
                let rho = w.rho.expect("checked by check_rule");
                let rb = w.rho_bar.expect("checked by check_rule");
                let c: f64 = r.iter().zip(&w.areas).map(|(ri, a)| a * ri).sum::<f64>()
                    / w.total_area
                    / (1.0 - rb);
                argmax_abs_except(
                    (0..r.len()).map(|k| w.areas[k] * (r[k] + rho[k] * c)),
                    self.last,
                )
            }
        }
    }

    /// Fetches column `i` (and row `i` where the rule needs it) of `K` and returns
    /// `K_ii` and the rule's step `Δ` (module docs).
    fn step(&mut self, i: usize, rec: &mut Recorder<'_>) -> Result<(f64, f64), LinearError> {
        self.k
            .column(i, &mut self.col)
            .map_err(unsupported(self.method))?;
        rec.work.columns += 1;
        if self.needs_row {
            self.k
                .row(i, &mut self.row)
                .map_err(unsupported(self.method))?;
            rec.work.rows += 1;
        }
        let (r, w) = (&self.r, &self.w);
        let kii: f64 = self
            .col
            .iter()
            .filter(|(j, _)| *j == i)
            .map(|(_, v)| *v)
            .sum();
        let row_dot_r = || self.row.iter().map(|(l, v)| v * r[*l]).sum::<f64>();
        let delta = match self.rule {
            Rule::Cyclic { omega } => omega * r[i] / (1.0 - kii),
            Rule::Greedy => r[i] / (1.0 - kii),
            Rule::Over(OverrelaxationKind::Shao) => r[i] + row_dot_r(),
            Rule::Over(OverrelaxationKind::Gortler) => {
                for &(l, v) in &self.col {
                    self.scratch[l] = v;
                }
                let mut num = r[i];
                let mut back = 0.0;
                for &(l, v) in &self.row {
                    if l != i {
                        num += v * r[l];
                        back += v * self.scratch[l];
                    }
                }
                for &(l, _) in &self.col {
                    self.scratch[l] = 0.0;
                }
                num / (1.0 - back)
            }
            Rule::Over(kind @ (OverrelaxationKind::Feda | OverrelaxationKind::Xu)) => {
                let rho = w.rho.expect("checked by check_rule");
                let rb = w.rho_bar.expect("checked by check_rule");
                let u = w.mean(r);
                if kind == OverrelaxationKind::Feda {
                    r[i] + rho[i] / (1.0 - rb) * u
                } else {
                    r[i] + row_dot_r() + rb / (1.0 - rb) * rho[i] * u
                }
            }
        };
        Ok((kii, delta))
    }

    /// Safeguard (module docs): a Table 2.1 step whose effective relaxation factor
    /// `Δ m_ii / r_i` is below 1/2 (or that moves an index with zero residual) is
    /// replaced by a plain Southwell update at the largest weighted residual. Returns
    /// the index and step to apply (the column of that index is in `self.col`).
    fn safeguard(
        &mut self,
        i: usize,
        kii: f64,
        delta: f64,
        rec: &mut Recorder<'_>,
    ) -> Result<(usize, f64), LinearError> {
        if !matches!(self.rule, Rule::Over(_)) {
            return Ok((i, delta));
        }
        let plain = self.r[i] / (1.0 - kii);
        let factor_ok = if plain != 0.0 {
            delta / plain >= MIN_FACTOR
        } else {
            delta == 0.0
        };
        if factor_ok {
            return Ok((i, delta));
        }
        self.safeguarded += 1;
        let j = argmax_abs(self.w.weighted(&self.r));
        if j != i {
            self.k
                .column(j, &mut self.col)
                .map_err(unsupported(self.method))?;
            rec.work.columns += 1;
        }
        let kjj: f64 = self
            .col
            .iter()
            .filter(|(l, _)| *l == j)
            .map(|(_, v)| *v)
            .sum();
        Ok((j, self.r[j] / (1.0 - kjj)))
    }

    /// `x_i += Δ`, `r_j += K_ji Δ`, `r_i −= Δ`.
    fn apply(&mut self, i: usize, delta: f64) {
        self.last = Some(i);
        self.x[i] += delta;
        for &(j, v) in &self.col {
            self.r[j] += v * delta;
        }
        self.r[i] -= delta;
    }

    /// One update (choose, step, safeguard, apply).
    fn update(&mut self, rec: &mut Recorder<'_>) -> Result<(), LinearError> {
        let i = self.choose();
        let (kii, delta) = self.step(i, rec)?;
        let (i, delta) = self.safeguard(i, kii, delta, rec)?;
        if !delta.is_finite() {
            return Err(LinearError::NonFiniteIterate {
                method: self.method,
                iteration: rec.next_iteration(),
            });
        }
        self.apply(i, delta);
        Ok(())
    }
}

fn relax<K: Operator + ?Sized>(
    k: &K,
    b: &[f64],
    rule: Rule,
    method: Method,
    progressive: bool,
    opts: &SolverOptions,
) -> Result<ProgressiveSolve, LinearError> {
    let n = k.dim();
    check_inputs(b, n, opts)?;
    check_rule(rule, method, opts)?;
    let mut rec = Recorder::new(method, b, opts);
    let mut r = b.to_vec();
    let x = match &opts.initial_guess {
        Some(x0) => {
            let mut kx = vec![0.0; n];
            k.apply(x0, &mut kx);
            rec.work.applications += 1;
            for i in 0..n {
                r[i] = b[i] + kx[i] - x0[i];
            }
            x0.clone()
        }
        None => vec![0.0; n],
    };
    let mut run = Relaxation {
        k,
        rule,
        method,
        w: Weights::new(opts, n),
        needs_row: matches!(
            rule,
            Rule::Over(
                OverrelaxationKind::Shao | OverrelaxationKind::Gortler | OverrelaxationKind::Xu
            )
        ),
        x,
        r,
        col: Vec::new(),
        row: Vec::new(),
        scratch: vec![0.0; n],
        next_cyclic: 0,
        last: None,
        safeguarded: 0,
    };
    let per_record = opts.updates_per_record.unwrap_or(n.max(1));
    let mut displayed_errors = Vec::new();
    let x_hat =
        |x: &[f64], r: &[f64]| -> Vec<f64> { x.iter().zip(r).map(|(a, b)| a + b).collect() };

    let reason = 'outer: loop {
        // Record the current state.
        let converged = if progressive {
            let xh = x_hat(&run.x, &run.r);
            let d = run.w.displayed(&xh, run.w.ambient(&run.r));
            displayed_errors.push(d.as_deref().and_then(|d| rec.error_of(d)));
            rec.record(norm(&run.r), Some(&xh))?
        } else {
            rec.record(norm(&run.r), Some(&run.x))?
        };
        if converged {
            break StopReason::Converged;
        }
        if rec.next_iteration() > opts.max_iterations {
            break StopReason::MaxIterations;
        }
        for _ in 0..per_record {
            if n == 0 {
                break 'outer StopReason::Converged;
            }
            run.update(&mut rec)?;
        }
    };

    let (ambient, displayed, x) = if progressive {
        let ambient = run.w.ambient(&run.r);
        let xh = x_hat(&run.x, &run.r);
        (ambient, run.w.displayed(&xh, ambient), xh)
    } else {
        (None, None, std::mem::take(&mut run.x))
    };
    let fin = fixed_point_residual_norm(k, b, &x);
    let mut solve = rec.finish(x, reason, fin);
    solve.history.safeguarded_updates = run.safeguarded;
    Ok(ProgressiveSolve {
        solve,
        unshot: run.r,
        ambient,
        displayed,
        displayed_errors,
    })
}
