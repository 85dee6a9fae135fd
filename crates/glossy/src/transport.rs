//! Transport coefficients by eq. (5) of Glossy §5.2:
//! `T_{r←s} = ∫_{x,y} [∫_ω b̄_r(y, ω) f_r(ω_xy, y, ω) dω] G(x, y) b_s(x, ω_xy) dy dx`.
//!
//! With the parameter-measure duals (see [`crate::basis`]) this is
//! `∫ du_r b_r(u_r) ∫ ds_s A_s G f_r b_s(s_s, D⁻¹(ω_xy))`: the sender's direction
//! coordinates are not integrated — they are the direction from `x` to `y`. Both
//! functions are constant on the 16 children of their nodes, so every coefficient
//! between the two nodes follows from the 16 × 16 child-pair integrals
//! `Q[k_r][k_s] = ∫_{k_r} du_r ∫_{spatial(k_s)} ds_s A_s G f_r 1[D⁻¹(ω_xy) ∈ ang(k_s)]`
//! by one Haar step on each side: `T_{τ_r←τ_s} = 4^{j_r+1} 4^{j_s+1} Σ H[τ_r][k_r]
//! H[τ_s][k_s] Q[k_r][k_s]`, which gives the link's 15 wavelet coefficients (or the
//! root `φ`) and its `φ→φ` coefficient from the same samples.
//!
//! Sampling, stratified per child cell of both nodes with jitter seeded per link:
//! - `(x, y)`: `n × n` jittered points in each of the sender's and the receiver's 4
//!   spatial child cells, all pairs (`16 n⁴` pairs), each with one shadow ray; child
//!   cells whose images touch (a shared edge or vertex) use wavelux-quadrature's
//!   Sauter–Schwab rules for the `1/r²` singularity instead. Pairs whose direction
//!   `ω_xy` lies outside the sender's direction cell are skipped (no ray): `b_s` is 0
//!   there.
//! - `ω` (inner, per pair): the diffuse part `ρ_d/π` is integrated exactly over each of
//!   the receiver's 4 direction child cells (so a diffuse receiver's angular wavelets
//!   are zero to rounding); the Ward lobe by multiple importance sampling (balance
//!   heuristic) of `m` stratified uniform points per child cell and `l` lobe samples
//!   (half-vector sampling, exact pdf) per pair — the lobe samples keep sharp lobes
//!   (α = 0.01) accurate on coarse cells, the uniform ones cover the rest.
//!
//! Virtual points of masked supports: a sender point that is not real sends nothing; a
//! receiver point that is not real receives with the visibility of its nearest real
//! point (VirtualMesh §4.1's extended radiosity).

use glam::{DVec2, DVec3};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;
use wavelux_geometry::Ray;
use wavelux_geometry::formfactor::area_form_factor;
use wavelux_quadrature::{Corner, RuleNd, SquarePair, singular::square_pair_rule};
use wavelux_support::{Coverage, SupportMap};

use crate::basis::{CHILDREN, HaarStep, NodeKey, TYPES};
use crate::directions::DirectionKind;
use crate::error::{GlossyError, dep, invalid};
use crate::patch::GlossyScene;

/// Sample counts of one link computation.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct TransportOptions {
    /// `n`: an `n × n` jittered grid of points per spatial child cell, per side.
    pub spatial: usize,
    /// `m`: uniform direction samples per receiving direction child cell and pair.
    pub angular: usize,
    /// `l`: lobe samples per pair (glossy receivers only).
    pub lobe: usize,
    /// Gauss order of the singular rules for touching cells (`6n⁴`/`4n⁴` points).
    pub singular_order: usize,
    /// Receiver-side lobe samples per receiving direction child and receiver point,
    /// used instead of the sender-side lobe integral when the lobe is sharper than
    /// the sender points' spacing (one ray each; 0: never).
    pub reverse: usize,
}

impl Default for TransportOptions {
    /// `n = 2`, `m = 2`, `l = 4`, singular order 2, 4 receiver-side samples.
    fn default() -> Self {
        Self {
            spatial: 2,
            angular: 2,
            lobe: 4,
            singular_order: 2,
            reverse: 4,
        }
    }
}

impl TransportOptions {
    /// Checks the ranges (`1..=8`, `0..=64`, `0..=64`, `1..=8`; `m + l > 0`).
    ///
    /// # Errors
    /// [`GlossyError::Invalid`] naming the first bad value.
    pub fn validate(&self) -> Result<(), GlossyError> {
        if !(1..=8).contains(&self.spatial) {
            return Err(invalid(
                "spatial samples",
                format!("{} not in 1..=8", self.spatial),
            ));
        }
        if self.reverse > 1024 {
            return Err(invalid(
                "reverse samples",
                format!("{} > 1024", self.reverse),
            ));
        }
        if self.angular > 64 || self.lobe > 64 || self.angular + self.lobe == 0 {
            return Err(invalid(
                "angular/lobe samples",
                format!("{} / {} (each ≤ 64, not both 0)", self.angular, self.lobe),
            ));
        }
        if !(1..=8).contains(&self.singular_order) {
            return Err(invalid(
                "singular order",
                format!("{} not in 1..=8", self.singular_order),
            ));
        }
        Ok(())
    }
}

/// One end of a link: patch, node and (sender only) type; `phi` marks a root-`φ`
/// receiver.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct End {
    /// Patch index.
    pub patch: usize,
    /// Node.
    pub key: NodeKey,
    /// Type `τ` of the sending function (0 = root `φ`); for a receiver, 0 means the
    /// root `φ` and anything else the node's 15 wavelets.
    pub tau: usize,
}

/// The result of one link computation (f64; the link stores f32).
#[derive(Debug, Clone, PartialEq)]
pub struct LinkValues {
    /// `T[c][τ − 1]` into the receiving node's wavelets, or `[c][0]` into the root `φ`.
    pub coef: [[f64; TYPES]; 3],
    /// `T_{φ_R ← φ_S}` per channel.
    pub phiphi: [f64; 3],
    /// Max − min of the kernel `A_s·G·V·f_r` (largest channel) over the samples.
    pub variation: f64,
    /// Receiver / sender children with non-zero samples.
    pub masks: [u16; 2],
    /// Kernel evaluations (pairs × direction samples).
    pub samples: u64,
    /// Shadow rays traced.
    pub rays: u64,
    /// Whether any sample was non-zero.
    pub nonzero: bool,
}

/// Computes transport coefficients over a prepared scene.
#[derive(Debug)]
pub struct Transport<'a> {
    scene: &'a GlossyScene,
    dirs: DirectionKind,
    haar: HaarStep,
    opts: TransportOptions,
    /// Sauter–Schwab rules: 32 common-edge (receiver edge × sender edge × flip) and 16
    /// common-vertex rules.
    edge_rules: Vec<RuleNd>,
    vertex_rules: Vec<RuleNd>,
    /// Distance under which two corners coincide.
    tol: f64,
    /// Bounding sphere of every patch (whole support): pairs of patches whose spheres
    /// are far apart cannot touch, so their cell corners are never computed.
    spheres: Vec<(DVec3, f64)>,
    /// Gauss–Legendre nodes and weights on `[0,1]` of the spatial rule.
    gx: Vec<f64>,
    gw: Vec<f64>,
}

/// A lobe counts as sharp when the sender points' angular spacing exceeds this many
/// roughnesses: Gauss points then resolve the lobe's mirror image poorly, while the
/// receiver-side estimate (whose only noise is which sender its rays hit) is good
/// when the lobe fits inside few senders. Measured on the white furnace (level-2
/// cells, n = 3): α = 0.2 is better sender-side, α = 0.01 receiver-side.
pub const SHARP: f64 = 3.0;

const EDGES: [(usize, usize); 4] = [(0, 1), (1, 2), (2, 3), (3, 0)];

/// Accumulator of the 16 × 16 child-pair integrals per channel.
type Q = [[[f64; 3]; CHILDREN]; CHILDREN];

/// Geometry of a sender point, shared by every receiver point of a link.
struct SendPoint {
    x: DVec3,
    nx: DVec3,
    frame: crate::ward::Frame,
    real: bool,
    /// Area density of the point (world area⁻¹): the inverse of its parameter weight
    /// times the support's area element `J(s, t)`, evaluated once per point.
    dens: f64,
    /// `J(s, t)` (world area per unit parameter area).
    jac: f64,
}

impl SendPoint {
    /// The point at parameter `st` whose weight per unit parameter area is `w`.
    fn new(p: &crate::patch::Patch, st: DVec2, w: f64) -> Self {
        let real = p.support.is_real(st.x, st.y);
        let (x, nx, frame) = if real {
            p.point_frame(st.x, st.y)
        } else {
            (DVec3::ZERO, DVec3::Z, crate::ward::Frame::any(DVec3::Z))
        };
        let jac = p.support.jacobian(st.x, st.y);
        Self {
            x,
            nx,
            frame,
            real,
            dens: 1.0 / (w * jac),
            jac,
        }
    }
}

/// A receiver sample point with its frame and BRDF.
struct RecvPoint {
    #[allow(dead_code)]
    st: DVec2,
    y: DVec3,
    ny: DVec3,
    yv: DVec3,
    frame: crate::ward::Frame,
    brdf: crate::ward::Brdf,
}

/// Per-computation state.
struct Acc {
    q: Box<Q>,
    kmin: f64,
    kmax: f64,
    samples: u64,
    rays: u64,
}

impl Acc {
    fn new() -> Self {
        Self {
            q: Box::new([[[0.0; 3]; CHILDREN]; CHILDREN]),
            kmin: f64::INFINITY,
            kmax: f64::NEG_INFINITY,
            samples: 0,
            rays: 0,
        }
    }

    /// Adds `k ×` the integrals of `o` (its kernel range and counts unscaled).
    fn merge_scaled(&mut self, o: &Acc, k: f64) {
        for (a, b) in self.q.iter_mut().zip(o.q.iter()) {
            for (x, y) in a.iter_mut().zip(b) {
                for c in 0..3 {
                    x[c] += k * y[c];
                }
            }
        }
        self.kmin = self.kmin.min(o.kmin);
        self.kmax = self.kmax.max(o.kmax);
        self.samples += o.samples;
        self.rays += o.rays;
    }
}

/// Child-cell pairs whose centres are closer than this many times the sum of their
/// bounding radii are near: the Gauss rule on the `1/r²` kernel is rescaled there
/// (see [`Transport::near_scale`]).
pub const NEAR_FIELD: f64 = 1.0;

impl<'a> Transport<'a> {
    /// A transport context.
    ///
    /// # Errors
    /// [`GlossyError::Invalid`] for bad options; [`GlossyError::Dependency`] if a rule
    /// cannot be built.
    pub fn new(
        scene: &'a GlossyScene,
        dirs: DirectionKind,
        opts: TransportOptions,
    ) -> Result<Self, GlossyError> {
        opts.validate()?;
        let mut edge_rules = Vec::with_capacity(32);
        for (r0, r1) in EDGES {
            for (e0, e1) in EDGES {
                for flip in 0..2 {
                    let (f0, f1) = if flip == 0 { (e0, e1) } else { (e1, e0) };
                    let pair = SquarePair::common_edge(
                        Corner::ALL[r0],
                        Corner::ALL[r1],
                        Corner::ALL[f0],
                        Corner::ALL[f1],
                    )
                    .map_err(dep("quadrature"))?;
                    edge_rules.push(
                        square_pair_rule(pair, opts.singular_order).map_err(dep("quadrature"))?,
                    );
                }
            }
        }
        let mut vertex_rules = Vec::with_capacity(16);
        for rc in Corner::ALL {
            for ec in Corner::ALL {
                let pair = SquarePair::CommonVertex {
                    receiver: rc,
                    emitter: ec,
                };
                vertex_rules
                    .push(square_pair_rule(pair, opts.singular_order).map_err(dep("quadrature"))?);
            }
        }
        let (gx, gw) = {
            let g =
                wavelux_quadrature::GaussLegendre::new(opts.spatial).map_err(dep("quadrature"))?;
            let (x, w) = g.unit();
            (x.to_vec(), w.to_vec())
        };
        Ok(Self {
            gx,
            gw,
            scene,
            dirs,
            haar: HaarStep::new(),
            opts,
            edge_rules,
            vertex_rules,
            tol: 1e-9 * scene.diagonal,
            spheres: scene
                .patches
                .iter()
                .map(|p| p.support.bounding_sphere(0.0, 0.0, 1.0))
                .collect(),
        })
    }

    /// The options.
    #[must_use]
    pub fn options(&self) -> TransportOptions {
        self.opts
    }

    /// The direction map.
    #[must_use]
    pub fn directions(&self) -> DirectionKind {
        self.dirs
    }

    /// The scene.
    #[must_use]
    pub fn scene(&self) -> &'a GlossyScene {
        self.scene
    }

    /// The Haar step.
    #[must_use]
    pub fn haar(&self) -> &HaarStep {
        &self.haar
    }

    /// Which singular rule applies to a receiver child square and a sender child
    /// square whose images touch (`None`: they do not, or they coincide).
    fn touching(&self, rc: &[DVec3; 4], sc: &[DVec3; 4]) -> Option<&RuleNd> {
        let mut pairs = Vec::new();
        for (i, a) in rc.iter().enumerate() {
            for (j, b) in sc.iter().enumerate() {
                if (*a - *b).length() <= self.tol {
                    pairs.push((i, j));
                }
            }
        }
        match pairs.as_slice() {
            [(r, e)] => Some(&self.vertex_rules[r * 4 + e]),
            [(r0, e0), (r1, e1)] => {
                // Receiver edge (r0, r1) in EDGES order, sender edge in either direction.
                let (ri, rflip) = EDGES
                    .iter()
                    .position(|&(a, b)| (a, b) == (*r0, *r1))
                    .map(|i| (i, false))
                    .or_else(|| {
                        EDGES
                            .iter()
                            .position(|&(a, b)| (a, b) == (*r1, *r0))
                            .map(|i| (i, true))
                    })?;
                let (e_first, e_second) = if rflip { (*e1, *e0) } else { (*e0, *e1) };
                let ei = EDGES.iter().position(|&(a, b)| {
                    (a, b) == (e_first, e_second) || (a, b) == (e_second, e_first)
                })?;
                let flip = usize::from(EDGES[ei] != (e_first, e_second));
                Some(&self.edge_rules[(ri * 4 + ei) * 2 + flip])
            }
            _ => None,
        }
    }

    /// Computes the coefficients of the link `send → recv`; `stream` seeds the jitter.
    #[must_use]
    pub fn compute(&self, send: End, recv: End, stream: u64) -> LinkValues {
        let mut acc = Acc::new();
        let mut rng = Pcg64::seed_from_u64(stream);
        let ps = &self.scene.patches[send.patch];
        let pr = &self.scene.patches[recv.patch];
        let (hs, hr) = (send.key.size(), recv.key.size());
        let (ls, lr) = (send.key.lo(), recv.key.lo());
        let n = self.opts.spatial;
        let (hs2, hr2) = (0.5 * hs, 0.5 * hr);
        let s0s: [DVec2; 4] = std::array::from_fn(|cs| {
            DVec2::new(
                ls[0] + hs2 * (cs & 1) as f64,
                ls[1] + hs2 * (cs >> 1) as f64,
            )
        });
        // Cells of distinct patches touch only if the patches' spheres meet (a factor
        // 2 of margin over the sampled spheres of curved maps).
        let may_touch = send.patch != recv.patch && {
            let ((ca, ra), (cb, rb)) = (self.spheres[send.patch], self.spheres[recv.patch]);
            (ca - cb).length() <= 2.0 * (ra + rb) + self.tol
        };
        let scs: [[DVec3; 4]; 4] = std::array::from_fn(|cs| {
            if may_touch {
                corners(ps, s0s[cs], hs2)
            } else {
                [DVec3::ZERO; 4]
            }
        });
        // Gauss–Legendre points (n × n per child cell, weights per unit square).
        let gauss = |o: DVec2, h: f64| -> Vec<(DVec2, f64)> {
            (0..n * n)
                .map(|i| {
                    let (a, b) = (i % n, i / n);
                    (
                        o + h * DVec2::new(self.gx[a], self.gx[b]),
                        self.gw[a] * self.gw[b],
                    )
                })
                .collect()
        };
        // Sender points per sender child: reused by every receiver point.
        let xs_pts: [Vec<(DVec2, f64)>; 4] = std::array::from_fn(|cs| gauss(s0s[cs], hs2));
        let xs_geo: [Vec<SendPoint>; 4] = std::array::from_fn(|cs| {
            xs_pts[cs]
                .iter()
                .map(|(xs, wx)| SendPoint::new(ps, *xs, hs2 * hs2 * wx))
                .collect()
        });
        let reverse = self.sharp(send, recv);
        for cr in 0..4 {
            let r0 = DVec2::new(
                lr[0] + hr2 * (cr & 1) as f64,
                lr[1] + hr2 * (cr >> 1) as f64,
            );
            let rc = if may_touch {
                corners(pr, r0, hr2)
            } else {
                [DVec3::ZERO; 4]
            };
            let rules: [Option<&RuleNd>; 4] = std::array::from_fn(|cs| {
                if may_touch {
                    self.touching(&rc, &scs[cs])
                } else {
                    None
                }
            });
            let ys = gauss(r0, hr2);
            // Near, non-touching child pairs of planar pieces: their Gauss samples go to
            // a separate accumulator, rescaled to the exact form factor below.
            let scale: [Option<f64>; 4] = std::array::from_fn(|cs| {
                if rules[cs].is_some() {
                    return None;
                }
                self.near_scale(pr, r0, hr2, ps, s0s[cs], hs2, &ys, &xs_pts[cs])
            });
            let mut near: [Option<Acc>; 4] =
                std::array::from_fn(|cs| scale[cs].map(|_| Acc::new()));
            for &(yr, wy) in &ys {
                let w_y = hr2 * hr2 * wy;
                let Some(ry) = self.receiver_point(recv, yr) else {
                    continue;
                };
                for cs in 0..4 {
                    if rules[cs].is_some() {
                        continue;
                    }
                    let target = match near[cs].as_mut() {
                        Some(a) => a,
                        None => &mut acc,
                    };
                    for sp in &xs_geo[cs] {
                        self.pair(send, recv, &ry, sp, w_y, !reverse, cs, cr, &mut rng, target);
                    }
                }
                if reverse {
                    self.reverse(send, recv, &ry, w_y, &rules, cr, &mut rng, &mut acc);
                }
            }
            for (cs, a) in near.iter().enumerate() {
                if let (Some(a), Some(k)) = (a, scale[cs]) {
                    acc.merge_scaled(a, k);
                }
            }
            // Touching child pairs: Sauter–Schwab rules, x and y together.
            for cs in 0..4 {
                let Some(rule) = rules[cs] else { continue };
                let w_cells = hs2 * hs2 * hr2 * hr2;
                for (pt, w) in rule.iter() {
                    let yr = r0 + hr2 * DVec2::new(pt[0], pt[1]);
                    let xs = s0s[cs] + hs2 * DVec2::new(pt[2], pt[3]);
                    let Some(ry) = self.receiver_point(recv, yr) else {
                        continue;
                    };
                    // Area weight of x folded into w: w·A_s = 1/density.
                    let wx = w * w_cells / (hr2 * hr2);
                    self.pair(
                        send,
                        recv,
                        &ry,
                        &SendPoint::new(ps, xs, wx),
                        hr2 * hr2,
                        true,
                        cs,
                        cr,
                        &mut rng,
                        &mut acc,
                    );
                }
            }
        }
        self.finish(send, recv, &acc)
    }

    /// The correction of a near child pair (receiver cell `[r0, r0+hr]²` of `pr`,
    /// sender cell `[s0, s0+hs]²` of `ps`) that shares no full edge or single corner
    /// (those take the singular rules): the exact unoccluded `∫∫ cos θ_x cos θ_y / r²
    /// dA_x dA_y` of the two planar pieces (contour-integral form factor of
    /// `wavelux-geometry`, robust for shared partial edges: triangle supports of a
    /// mesh meet along edges with different parametrisations) over the same integral
    /// by the Gauss points `ys` × `xs` (unit-square weights). The pair's samples
    /// (visibility, BRDF, direction cells) are multiplied by it, as the diffuse
    /// solver does for near pairs at its splitting limit. `None` when the pair is far,
    /// a piece is not a planar polygon, or the sender cell is not all real.
    #[allow(clippy::too_many_arguments)]
    fn near_scale(
        &self,
        pr: &crate::patch::Patch,
        r0: DVec2,
        hr: f64,
        ps: &crate::patch::Patch,
        s0: DVec2,
        hs: f64,
        ys: &[(DVec2, f64)],
        xs: &[(DVec2, f64)],
    ) -> Option<f64> {
        // Only planar polygons have a contour form factor (`cell_polygon`): decide that
        // before the spheres, which cost curved maps nine evaluations each.
        let polygon = |p: &crate::patch::Patch| {
            matches!(
                p.support.map,
                SupportMap::Parallelogram { .. } | SupportMap::Triangle { .. }
            )
        };
        if !(polygon(pr) && polygon(ps)) {
            return None;
        }
        let (cr, rr) = pr.support.bounding_sphere(r0.x, r0.y, hr);
        let (cs, rs) = ps.support.bounding_sphere(s0.x, s0.y, hs);
        if (cr - cs).length() >= NEAR_FIELD * (rr + rs) {
            return None;
        }
        if ps.support.coverage(s0.x, s0.y, hs) != Coverage::Full {
            return None;
        }
        let a = pr.support.cell_polygon(r0.x, r0.y, hr)?;
        let b = ps.support.cell_polygon(s0.x, s0.y, hs)?;
        let exact = std::f64::consts::PI * area_form_factor(&a, &b).ok()?;
        let mut gauss = 0.0;
        for (y, wy) in ys {
            let (yp, ny) = pr.support.point_normal(y.x, y.y);
            let wy = wy * hr * hr * pr.support.jacobian(y.x, y.y);
            for (x, wx) in xs {
                let (xp, nx) = ps.support.point_normal(x.x, x.y);
                let d = yp - xp;
                let r2 = d.length_squared();
                let (cx, cy) = (nx.dot(d), -ny.dot(d));
                if crate::positive(r2) && cx > 0.0 && cy > 0.0 {
                    let wx = wx * hs * hs * ps.support.jacobian(x.x, x.y);
                    gauss += wy * wx * cx * cy / (r2 * r2);
                }
            }
        }
        (exact.is_finite() && exact >= 0.0 && gauss > 0.0).then(|| exact / gauss)
    }

    /// Geometry and material of a receiver point.
    fn receiver_point(&self, recv: End, yr: DVec2) -> Option<RecvPoint> {
        let pr = &self.scene.patches[recv.patch];
        let (y, ny, frame) = pr.point_frame(yr.x, yr.y);
        if !y.is_finite() {
            return None;
        }
        Some(RecvPoint {
            st: yr,
            y,
            ny,
            yv: if pr.support.is_real(yr.x, yr.y) {
                y
            } else {
                pr.support.visibility_point(yr.x, yr.y)
            },
            frame,
            brdf: self.scene.brdf_at(recv.patch, yr.x, yr.y),
        })
    }

    /// Receiver-side (lobe) samples of the specular integral at one receiver point:
    /// `ω_o` uniform in each receiving direction child, `ω_i` from the lobe about it, a
    /// ray from `y` along `ω_i`; weighted by the balance heuristic against the
    /// sender-side strategies of [`Transport::pair`].
    fn reverse(
        &self,
        send: End,
        recv: End,
        ry: &RecvPoint,
        w_y: f64,
        rules: &[Option<&RuleNd>; 4],
        cr: usize,
        rng: &mut Pcg64,
        acc: &mut Acc,
    ) {
        let mb = self.opts.reverse;
        let Some(lobe) = ry.brdf.lobe.filter(|_| ry.brdf.is_glossy()) else {
            return;
        };
        if mb == 0 {
            return;
        }
        let ps = &self.scene.patches[send.patch];
        let (hs, hr) = (send.key.size(), recv.key.size());
        let (ls, lr) = (send.key.lo(), recv.key.lo());
        let hc = 0.5 * hr;
        let vol = hc * hc;
        let eps = 1e-7 * self.scene.diagonal;
        for ca in 0..4 {
            let c0 = DVec2::new(lr[2] + hc * (ca & 1) as f64, lr[3] + hc * (ca >> 1) as f64);
            for i in 0..mb {
                let u = c0 + hc * stratified(i, mb, rng);
                let wo = self.dirs.direction(u);
                let Some((wi, pdf, f)) = lobe.sample_eval(wo, [rng.random(), rng.random()]) else {
                    continue;
                };
                acc.samples += 1;
                let dir = ry.frame.to_world(wi);
                acc.rays += 1;
                let ray = Ray {
                    origin: ry.yv + ry.ny * eps,
                    dir,
                };
                let Some(hit) = self.scene.accel.closest_hit(&ray, eps, f64::INFINITY) else {
                    continue;
                };
                let Some((q, xs)) = self.scene.resolve(&hit) else {
                    continue;
                };
                if q != send.patch {
                    continue;
                }
                let inside =
                    xs.x >= ls[0] && xs.x <= ls[0] + hs && xs.y >= ls[1] && xs.y <= ls[1] + hs;
                if !inside || !ps.support.is_real(xs.x, xs.y) {
                    continue;
                }
                let cs = usize::from(xs.x >= ls[0] + 0.5 * hs)
                    | (usize::from(xs.y >= ls[1] + 0.5 * hs) << 1);
                if rules[cs].is_some() {
                    continue;
                }
                let (x, nxv, fx) = ps.point_frame(xs.x, xs.y);
                let d = ry.y - x;
                let r2 = d.length_squared();
                if !crate::positive(r2) {
                    continue;
                }
                let wxy = d / r2.sqrt();
                let Some(ks_ang) = self.sender_cell(send, &fx, wxy) else {
                    continue;
                };
                let ks = cs | (ks_ang << 2);
                let cx = nxv.dot(wxy);
                let cy = -ry.ny.dot(wxy);
                if !(cx > 0.0 && cy > 0.0) {
                    continue;
                }
                if !(f > 0.0 && pdf > 0.0) {
                    continue;
                }
                // ∫_c du ∫ dω_i cos θ_y f ≈ (vol/m_b) Σ f cos θ_y / p(ω_i | ω_o).
                let val = vol / mb as f64 * f * cy / pdf;
                let kr = cr | (ca << 2);
                for c in 0..3 {
                    acc.q[kr][ks][c] += w_y * ry.brdf.specular[c] * val;
                }
            }
        }
    }

    /// Whether the receiver's lobe is sharp against the sender points' spacing: the
    /// angle between neighbouring sender points seen from the receiver,
    /// `h_s √A_s / (2n · r)`, exceeds [`SHARP`] times the lobe's smaller roughness. Sender-side points
    /// would then land isolated mirror spots in the receiving direction cells, so the
    /// specular part is sampled from the receiver instead ([`Transport::reverse`]).
    fn sharp(&self, send: End, recv: End) -> bool {
        let pr = &self.scene.patches[recv.patch];
        let ps = &self.scene.patches[send.patch];
        let Some(lobe) = pr.brdf.lobe.filter(|_| pr.brdf.is_glossy()) else {
            return false;
        };
        if self.opts.reverse == 0 {
            return false;
        }
        let (hs, hr) = (send.key.size(), recv.key.size());
        let (ls, lr) = (send.key.lo(), recv.key.lo());
        let cs = ps.support.point(ls[0] + 0.5 * hs, ls[1] + 0.5 * hs);
        let cr = pr.support.point(lr[0] + 0.5 * hr, lr[1] + 0.5 * hr);
        let r = (cs - cr).length().max(1e-300);
        let spacing = hs * ps.support.area.sqrt() / (2.0 * self.opts.spatial as f64 * r);
        spacing > SHARP * lobe.alpha_x.min(lobe.alpha_y)
    }

    /// The sender's direction child of `ω_xy` in the sender's `frame`, `None` outside its direction cell
    /// or behind it.
    fn sender_cell(&self, send: End, frame: &crate::ward::Frame, wxy: DVec3) -> Option<usize> {
        let ls = frame.to_local(wxy);
        if !crate::positive(ls.z) {
            return None;
        }
        let u = self.dirs.inverse(ls)?;
        let hs = send.key.size();
        let lo = send.key.lo();
        let inside = u.x >= lo[2] && u.x <= lo[2] + hs && u.y >= lo[3] && u.y <= lo[3] + hs;
        inside.then(|| {
            usize::from(u.x >= lo[2] + 0.5 * hs) | (usize::from(u.y >= lo[3] + 0.5 * hs) << 1)
        })
    }

    /// One sender-side `(x, y)` pair: shadow ray, sender direction cell, inner direction
    /// integral. `w_y`: parameter weight of `y`; the pair's weight for the area integral
    /// over `x` is `w_y / sp.dens`.
    fn pair(
        &self,
        send: End,
        recv: End,
        ry: &RecvPoint,
        sp: &SendPoint,
        w_y: f64,
        specular: bool,
        cs: usize,
        cr: usize,
        rng: &mut Pcg64,
        acc: &mut Acc,
    ) {
        let ps = &self.scene.patches[send.patch];
        let pr = &self.scene.patches[recv.patch];
        if !sp.real {
            return;
        }
        let (x, nx, dx) = (sp.x, sp.nx, sp.dens);
        let d = ry.y - x;
        let r2 = d.length_squared();
        if !crate::positive(r2) {
            return;
        }
        let wxy = d / r2.sqrt();
        let zero = |acc: &mut Acc| {
            acc.kmin = acc.kmin.min(0.0);
            acc.kmax = acc.kmax.max(0.0);
        };
        let Some(ks_ang) = self.sender_cell(send, &sp.frame, wxy) else {
            // Outside the sender's direction cell: b_s = 0 (skipped, no ray); behind
            // the sender: a zero kernel sample.
            if !crate::positive(sp.frame.to_local(wxy).z) {
                zero(acc);
            }
            return;
        };
        let ks = cs | (ks_ang << 2);
        let cx = nx.dot(wxy);
        let cy = -ry.ny.dot(wxy);
        if !(cx > 0.0 && cy > 0.0) {
            zero(acc);
            return;
        }
        acc.rays += 1;
        if self.scene.accel.occluded(x, ry.yv, [ps.prim, pr.prim]) {
            zero(acc);
            return;
        }
        let g = cx * cy / r2;
        let brdf = &ry.brdf;
        let wi = ry.frame.to_local(-wxy);
        let hr = recv.key.size();
        let lr = recv.key.lo();
        let hc = 0.5 * hr;
        let vol = hc * hc;
        // Specular integrals (already divided by the x density) over the 4 receiving
        // direction children.
        let mut spec = [0.0; 4];
        let lobe = brdf.lobe.filter(|_| brdf.is_glossy() && specular);
        if let Some(lobe) = lobe {
            let (m, l) = (self.opts.angular, self.opts.lobe);
            let d_a1 = dx * m as f64 / vol;
            let in_cell =
                |u: DVec2| u.x >= lr[2] && u.x <= lr[2] + hr && u.y >= lr[3] && u.y <= lr[3] + hr;
            let child =
                |u: DVec2| usize::from(u.x >= lr[2] + hc) | (usize::from(u.y >= lr[3] + hc) << 1);
            // The balance heuristic's other density; `j`: `J_ω` at the sample.
            let dens_other = |pdf: f64, j: f64| dx * l as f64 * pdf * j;
            for ca in 0..4 {
                let c0 = DVec2::new(lr[2] + hc * (ca & 1) as f64, lr[3] + hc * (ca >> 1) as f64);
                for i in 0..m {
                    let u = c0 + hc * stratified(i, m, rng);
                    let wo = self.dirs.direction(u);
                    let (f, pdf) = lobe.eval_pdf(wi, wo);
                    acc.samples += 1;
                    if f > 0.0 {
                        spec[ca] += f / (d_a1 + dens_other(pdf, self.dirs.jacobian_of(u, wo)));
                    }
                }
            }
            for _ in 0..l {
                let Some((wo, pdf, f)) = lobe.sample_eval(wi, [rng.random(), rng.random()]) else {
                    continue;
                };
                acc.samples += 1;
                let Some(u) = self.dirs.inverse(wo) else {
                    continue;
                };
                if !in_cell(u) {
                    continue;
                }
                let den = d_a1 + dens_other(pdf, self.dirs.jacobian(u));
                if f > 0.0 && den > 0.0 {
                    spec[child(u)] += f / den;
                }
            }
        } else {
            acc.samples += 4;
        }
        let inv_pi = std::f64::consts::FRAC_1_PI;
        let jac = sp.jac;
        for (ca, s) in spec.iter().enumerate() {
            let kr = cr | (ca << 2);
            let mut kmax: f64 = 0.0;
            for c in 0..3 {
                let v = brdf.diffuse[c] * inv_pi * vol / dx + brdf.specular[c] * s;
                acc.q[kr][ks][c] += w_y * g * v;
                kmax = kmax.max(g * v * dx / vol * jac);
            }
            acc.kmin = acc.kmin.min(kmax);
            acc.kmax = acc.kmax.max(kmax);
        }
    }

    fn finish(&self, send: End, recv: End, acc: &Acc) -> LinkValues {
        let h = &self.haar;
        let scale =
            4f64.powi(i32::from(recv.key.level) + 1) * 4f64.powi(i32::from(send.key.level) + 1);
        let mut v = [[0.0; 3]; CHILDREN];
        let mut w0 = [[0.0; 3]; CHILDREN];
        let mut masks = [0u16; 2];
        for kr in 0..CHILDREN {
            for ks in 0..CHILDREN {
                let q = acc.q[kr][ks];
                if q.iter().any(|&x| x != 0.0) {
                    masks[0] |= 1 << kr;
                    masks[1] |= 1 << ks;
                }
                for c in 0..3 {
                    v[kr][c] += h.at(send.tau, ks) * q[c];
                    w0[kr][c] += h.at(0, ks) * q[c];
                }
            }
        }
        let mut coef = [[0.0; TYPES]; 3];
        let mut phiphi = [0.0; 3];
        for c in 0..3 {
            if recv.tau == 0 {
                coef[c][0] = scale * (0..CHILDREN).map(|k| h.at(0, k) * v[k][c]).sum::<f64>();
            } else {
                for t in 1..CHILDREN {
                    coef[c][t - 1] =
                        scale * (0..CHILDREN).map(|k| h.at(t, k) * v[k][c]).sum::<f64>();
                }
            }
            phiphi[c] = scale * (0..CHILDREN).map(|k| h.at(0, k) * w0[k][c]).sum::<f64>();
        }
        let variation = if acc.kmax >= acc.kmin {
            acc.kmax - acc.kmin
        } else {
            0.0
        };
        LinkValues {
            coef,
            phiphi,
            variation,
            masks,
            samples: acc.samples,
            rays: acc.rays,
            nonzero: masks[0] != 0,
        }
    }
}

/// Point `i` of `m` stratified jittered points in the unit square: a jittered
/// `k × k` grid when `m = k²`, else `m` strata along the first axis with the second
/// coordinate uniform (every point uniform overall: unbiased for any `m`).
pub fn stratified(i: usize, m: usize, rng: &mut Pcg64) -> DVec2 {
    let k = (m as f64).sqrt().round() as usize;
    let (a, b) = (rng.random::<f64>(), rng.random::<f64>());
    if k * k == m {
        DVec2::new(
            ((i % k) as f64 + a) / k as f64,
            ((i / k) as f64 + b) / k as f64,
        )
    } else {
        DVec2::new((i as f64 + a) / m as f64, b)
    }
}

/// Images of the corners `(0,0), (1,0), (1,1), (0,1)` of the square `[o, o + h]²`.
fn corners(p: &crate::patch::Patch, o: DVec2, h: f64) -> [DVec3; 4] {
    p.support.corners(o.x, o.y, h)
}
