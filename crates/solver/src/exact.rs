//! Exact unoccluded transfer of planar pieces (issue 11 §1): what a link block's
//! energy-carrying entries must be, computed without the error of a tensor Gauss rule
//! on the `1/r²` kernel.
//!
//! - A node of a planar support is a [`Piece`]: signed planar polygons (parallelogram
//!   and triangle supports; the real part of a node of a virtual polygon support, its
//!   trim loops clipped to the node's parallelogram when they are straight) or a planar
//!   region with curved edges (a node of a disk support: the images of the four edges
//!   of its parameter square under the concentric map), or a node of an unmasked
//!   curved support on an equal-area map (sphere, cylinder, ... patch:
//!   [`Piece::Mapped`]). The contour forms
//!   below hold for curved surfaces too (Stokes' theorem needs no plane: the
//!   projected-solid-angle form and `ln r`'s gradient are defined on all of space
//!   minus the point), provided the two sides face each other at every point, which
//!   [`FACING_GRID`] checks; elsewhere there is no exact form and the quadrature stays.
//! - The point-to-piece form factor `F(x → P) = ∫_P G dA_y` (unoccluded) is exact:
//!   Lambert's formula `F = (1/2π) Σ β_i n·ĝ_i` on polygons (after clipping to the
//!   tangent plane of `x`, `wavelux-geometry`), and its contour form
//!   `F = (1/2π) |∮ n_x · (r × dr)/|r|²|` on curved edges, integrated by Gauss–Legendre
//!   panels bisected where `x` comes closer to a panel than its length (the integrand is
//!   analytic elsewhere).
//! - Moments `∫_g ψ_a(x) F(x → P) dA_x` over a node `g` (its unit-square basis `ψ_a`)
//!   come from the node's 4×4 Gauss rule, which integrates every basis function
//!   exactly, so in a closed enclosure (where `Σ_P F(x → P) = 1` at every point) the
//!   moments of a node against all the pieces it sees add up to exactly those of the
//!   constant function whatever the rule's error on each piece.
//! - `∫_R ∫_E G` is the contour integral `(1/2π) ∮∮ ln r dx·dy` ([`constant`]):
//!   closed-form edge pairs of `wavelux-geometry` between polygons (exact and symmetric
//!   for any relative position: shared edges, vertices, T-junctions), adaptive Gauss
//!   panels when a boundary is curved.

use glam::{DVec2, DVec3};
use wavelux_geometry::Edge2;
use wavelux_geometry::formfactor::{
    area_form_factor, newell, point_segment_distance, point_to_polygon, segment_distance,
    segment_pair_log_integral,
};
use wavelux_quadrature::GaussLegendre;

use crate::basis::TreeBasis;
use crate::mask::{Coverage, Mask};
use crate::support::{Patch, SupportMap};
use crate::transfer::Region;

/// Quadrature rules of the exact parts, built once per transfer context.
#[derive(Debug, Clone)]
pub struct Rules {
    g4: (Vec<f64>, Vec<f64>),
    g8: (Vec<f64>, Vec<f64>),
}

impl Rules {
    /// The 4- and 8-point Gauss–Legendre rules on `[0, 1]`.
    pub fn new() -> Option<Self> {
        let g = |n| GaussLegendre::new(n).ok().map(|g| g.unit());
        Some(Self {
            g4: g(4)?,
            g8: g(8)?,
        })
    }
}

/// The exactly integrable image of a node (see the module docs).
#[derive(Debug, Clone)]
pub enum Piece {
    /// Planar polygons with signs (`+1` for outer loops, `−1` for holes), each
    /// counter-clockwise about `normal`, the front normal of the piece's plane.
    Polygons {
        /// `(vertices, sign)`.
        loops: Vec<(Vec<DVec3>, f64)>,
        /// Front normal.
        normal: DVec3,
        /// A point of the plane.
        origin: DVec3,
    },
    /// A node of a disk support: the region bounded by the images of its square's
    /// edges.
    Curved {
        /// The node.
        region: Region,
        /// Front normal.
        normal: DVec3,
        /// A point of the plane.
        origin: DVec3,
    },
    /// A node of an unmasked curved support on an equal-area map (sphere, cylinder,
    /// cone, ... patch, VirtualMesh §3.1): a smooth surface bounded by the images of its square's edges. Its contour forms
    /// hold where it is wholly in front of the other side and faces it at every point
    /// ([`FACING_GRID`] checks both).
    Mapped {
        /// The node.
        region: Region,
    },
}

impl Piece {
    /// The plane of a planar piece (front normal, a point); `None` for a curved one.
    fn plane(&self) -> Option<(DVec3, DVec3)> {
        match self {
            Piece::Polygons { normal, origin, .. } | Piece::Curved { normal, origin, .. } => {
                Some((*normal, *origin))
            }
            Piece::Mapped { .. } => None,
        }
    }

    /// Sample points and front normals over the piece: its vertices (polygons), or a
    /// [`FACING_GRID`]² grid of its node's square, boundary included (curved edges,
    /// curved surfaces).
    fn samples(&self, patches: &[Patch]) -> Vec<(DVec3, DVec3)> {
        match self {
            Piece::Polygons { loops, normal, .. } => loops
                .iter()
                .flat_map(|(l, _)| l.iter().map(|v| (*v, *normal)))
                .collect(),
            Piece::Curved { region, .. } | Piece::Mapped { region } => {
                let sup = &patches[region.patch].support;
                let k = FACING_GRID - 1;
                (0..FACING_GRID * FACING_GRID)
                    .map(|i| {
                        let (a, b) = ((i % FACING_GRID) as f64, (i / FACING_GRID) as f64);
                        sup.point_normal(
                            region.s0 + region.h * a / k as f64,
                            region.t0 + region.h * b / k as f64,
                        )
                    })
                    .collect()
            }
        }
    }
}

/// Points per side of the grid on which a curved node's facing is checked: a node of
/// a curved support counts as wholly in front of a point (or of another piece), and
/// facing it, when every point of this grid on its square (boundary included) is, to
/// `1e-9` of the distance. Cells of quadric patches at the levels the solver reaches
/// bend by less than the grid spacing resolves; a node straddling a horizon is caught
/// at its sampled points or, on its boundary, by the contour rule's own check.
pub const FACING_GRID: usize = 5;

/// Whether every sample of `a` and every sample of `b` face each other (each in front
/// of the other's tangent plane, to `1e-9` of their distance or of the smaller set's
/// extent, whichever is larger). The extent's floor lets the samples of two pieces
/// that share a boundary meet: a tube's rim sample and a disk's rim sample are one
/// point computed by two maps, a few ulps apart in any direction, and the distance
/// alone gave no tolerance there (the tube–disk pairs of a closed cylinder lost their
/// exact form at random, and their quadrature blocks left rows 0.9 % off).
fn mutually_facing(a: &[(DVec3, DVec3)], b: &[(DVec3, DVec3)]) -> bool {
    let extent = |s: &[(DVec3, DVec3)]| {
        let (lo, hi) = s.iter().fold(
            (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
            |(lo, hi), (p, _)| (lo.min(*p), hi.max(*p)),
        );
        (hi - lo).length()
    };
    let floor = extent(a).min(extent(b));
    a.iter().all(|(x, nx)| {
        b.iter().all(|(y, ny)| {
            let d = *y - *x;
            let tol = 1e-9 * d.length().max(floor);
            nx.dot(d) >= -tol && ny.dot(-d) >= -tol
        })
    })
}

/// Whether two nodes of the same patch overlap (one contains the other): their
/// contour integrals would run along coincident curves of the same surface.
fn same_surface_overlap(a: &Region, b: &Region) -> bool {
    a.patch == b.patch
        && a.s0 < b.s0 + b.h
        && b.s0 < a.s0 + a.h
        && a.t0 < b.t0 + b.h
        && b.t0 < a.t0 + a.h
}

/// The exact polygon of a node of a parallelogram or triangle support,
/// counter-clockwise about the support's normal, collapsed corners removed
/// ([`wavelux_support::Support::cell_polygon`], which the glossy transport and the
/// shafts use too).
pub fn node_polygon(p: &Patch, r: &Region) -> Option<Vec<DVec3>> {
    p.support.cell_polygon(r.s0, r.t0, r.h)
}

/// The piece of node `g` of patch `p`. As an emitter (`real_only`) a node of a virtual
/// support is its real part; as a receiver the whole square (virtual points receive,
/// VirtualMesh §4.2). A node of an unmasked curved support on an equal-area map is
/// [`Piece::Mapped`]. `None` where no exact form exists (masked or natural-coordinate
/// curved supports, trims with arcs crossing the node, empty nodes).
pub fn piece(p: &Patch, g: &Region, real_only: bool) -> Option<Piece> {
    let sup = &p.support;
    if !sup.is_planar() {
        // Equal-area maps only: the node rules below weigh every point by the
        // support's constant area element.
        return (sup.mask.is_none() && sup.is_equal_area()).then_some(Piece::Mapped { region: *g });
    }
    let normal = sup.normal;
    match (&sup.map, &sup.mask) {
        (SupportMap::Disk { .. }, None) => Some(Piece::Curved {
            region: *g,
            normal,
            origin: sup.point(g.s0, g.t0),
        }),
        (SupportMap::Parallelogram { .. } | SupportMap::Triangle { .. }, mask) => {
            let cov = match mask {
                Some(_) if real_only => sup.coverage(g.s0, g.t0, g.h),
                _ => Coverage::Full,
            };
            match cov {
                Coverage::Empty => None,
                Coverage::Full => {
                    let poly = node_polygon(p, g)?;
                    Some(Piece::Polygons {
                        origin: poly[0],
                        loops: vec![(poly, 1.0)],
                        normal,
                    })
                }
                Coverage::Partial => {
                    let m = mask.as_ref()?;
                    let mut loops = Vec::new();
                    for clipped in real_loops(m, g)? {
                        let sign = signed_area(&clipped).signum();
                        let mut poly: Vec<DVec3> = clipped
                            .iter()
                            .map(|q| {
                                let (s, t) = m.from_plane(*q);
                                sup.point(s, t)
                            })
                            .collect();
                        if newell(&poly).dot(normal) < 0.0 {
                            poly.reverse();
                        }
                        loops.push((poly, sign));
                    }
                    let origin = sup.point(g.s0, g.t0);
                    Some(Piece::Polygons {
                        loops,
                        normal,
                        origin,
                    })
                }
            }
        }
        _ => None,
    }
}

/// The real part of node `g` of a masked support, in the mask's plane: each trim loop
/// clipped to the node's window (outer loops counter-clockwise, holes clockwise; loops
/// that miss the window dropped). `None` where a loop has an arc.
fn real_loops(m: &Mask, g: &Region) -> Option<Vec<Vec<DVec2>>> {
    let w = [
        m.to_plane(g.s0, g.t0),
        m.to_plane(g.s0 + g.h, g.t0),
        m.to_plane(g.s0 + g.h, g.t0 + g.h),
        m.to_plane(g.s0, g.t0 + g.h),
    ];
    let mut out = Vec::new();
    for lp in &m.region().loops {
        let mut pts = Vec::with_capacity(lp.edges.len());
        for e in &lp.edges {
            match e {
                Edge2::Segment { a, .. } => pts.push(*a),
                Edge2::Arc { .. } => return None,
            }
        }
        let clipped = clip_convex(&pts, &w);
        if clipped.len() >= 3 {
            out.push(clipped);
        }
    }
    Some(out)
}

fn signed_area(p: &[DVec2]) -> f64 {
    let mut a = 0.0;
    for i in 0..p.len() {
        a += p[i].perp_dot(p[(i + 1) % p.len()]);
    }
    0.5 * a
}

/// Sutherland–Hodgman clip of a closed polygon (either orientation) against the convex
/// quadrilateral `w` (either orientation). A concave subject may come back with
/// zero-width bridges along `w`'s border; they cancel in every contour integral.
fn clip_convex(subject: &[DVec2], w: &[DVec2; 4]) -> Vec<DVec2> {
    let orient = signed_area(w).signum();
    let mut out = subject.to_vec();
    for i in 0..4 {
        let (a, b) = (w[i], w[(i + 1) % 4]);
        let side = |p: DVec2| orient * (b - a).perp_dot(p - a);
        let input = std::mem::take(&mut out);
        for j in 0..input.len() {
            let (p, q) = (input[j], input[(j + 1) % input.len()]);
            let (sp, sq) = (side(p), side(q));
            if sp >= 0.0 {
                out.push(p);
            }
            if (sp > 0.0 && sq < 0.0) || (sp < 0.0 && sq > 0.0) {
                out.push(p + (q - p) * (sp / (sp - sq)));
            }
        }
        if out.is_empty() {
            break;
        }
    }
    out
}

/// `F(x → P)` for a receiver point `x` with unit normal `nx` (see the module docs):
/// zero where `x` is not in front of `P`; `None` where the curved contour form does not
/// apply (a curved piece crossing the tangent plane of `x`, a curved surface not facing
/// `x` at every point).
pub fn point_form_factor(
    patches: &[Patch],
    rules: &Rules,
    piece: &Piece,
    x: DVec3,
    nx: DVec3,
) -> Option<f64> {
    point_form_factor_at(patches, rules, piece, x, nx, false)
}

/// [`point_form_factor`] for a point `x` that lies on the piece itself when `inside`
/// (a point of a [`Piece::Mapped`] node's own square): on a concave node, `F(x → P) =
/// 1 − (1/2π)|∮_{∂P} n_x · (r × dr)/|r|²|`, the hemisphere less the cone of the
/// node's boundary (see [`nested_constant`]); `None` where the node is not concave
/// about `x` (a sample of it not facing `x`, or `x` not facing the sample).
fn point_form_factor_at(
    patches: &[Patch],
    rules: &Rules,
    piece: &Piece,
    x: DVec3,
    nx: DVec3,
    inside: bool,
) -> Option<f64> {
    if inside {
        let faces = |(y, ny): &(DVec3, DVec3)| {
            let d = *y - x;
            let tol = 1e-9 * d.length();
            nx.dot(d) >= -tol && ny.dot(-d) >= -tol
        };
        if !matches!(piece, Piece::Mapped { .. }) || !piece.samples(patches).iter().all(faces) {
            return None;
        }
        let mut total = 0.0;
        for c in curves(patches, piece) {
            total += curve_integral(&c, rules, x, nx, (0.0, 1.0), 0)?;
        }
        return Some((1.0 - (total / (2.0 * std::f64::consts::PI)).abs()).max(0.0));
    }
    if let Some((n, o)) = piece.plane() {
        if n.dot(x - o) <= 0.0 {
            return Some(0.0);
        }
    } else {
        let pts = piece.samples(patches);
        let facing = |(y, ny): &(DVec3, DVec3)| {
            let d = *y - x;
            let tol = 1e-9 * d.length();
            (
                nx.dot(d) >= -tol && ny.dot(-d) >= -tol,
                nx.dot(d) > tol && ny.dot(-d) > tol,
            )
        };
        if pts.iter().all(|p| !facing(p).1) {
            // No sample sees x: the unoccluded kernel vanishes on the node.
            return Some(0.0);
        }
        if !pts.iter().all(|p| facing(p).0) {
            return None;
        }
    }
    match piece {
        Piece::Polygons { loops, .. } => Some(
            loops
                .iter()
                .map(|(p, s)| s * point_to_polygon(x, nx, p).unwrap_or(0.0))
                .sum::<f64>()
                .max(0.0),
        ),
        Piece::Curved { .. } | Piece::Mapped { .. } => {
            let mut total = 0.0;
            for c in curves(patches, piece) {
                total += curve_integral(&c, rules, x, nx, (0.0, 1.0), 0)?;
            }
            Some((total / (2.0 * std::f64::consts::PI)).abs())
        }
    }
}

/// The four edges of a node's square, counter-clockwise in `(s, t)`.
fn square_edges(g: &Region) -> [(DVec2, DVec2); 4] {
    let c = [
        DVec2::new(g.s0, g.t0),
        DVec2::new(g.s0 + g.h, g.t0),
        DVec2::new(g.s0 + g.h, g.t0 + g.h),
        DVec2::new(g.s0, g.t0 + g.h),
    ];
    std::array::from_fn(|i| (c[i], c[(i + 1) % 4]))
}

/// Parameters in `(0, 1)` where the segment `a → b` of the unit square crosses a
/// diagonal, where the concentric map has a kink.
fn disk_kinks(a: DVec2, b: DVec2) -> Vec<f64> {
    let mut v = Vec::new();
    // Diagonals s = t and s + t = 1.
    let diagonals: [fn(DVec2) -> f64; 2] = [|p| p.x - p.y, |p| p.x + p.y - 1.0];
    for f in diagonals {
        let (fa, fb) = (f(a), f(b));
        if fa * fb < 0.0 {
            v.push(fa / (fa - fb));
        }
    }
    v
}

/// `∫ n_x · (r × dr)/|r|²` along the panel `u ∈ [u0, u1]` of a boundary curve
/// (8-point Gauss per panel; a panel closer to `x` than its length is bisected, at
/// most 40 times). `None` if a point of the curve lies behind the tangent plane of `x`.
fn curve_integral(
    c: &Curve<'_>,
    rules: &Rules,
    x: DVec3,
    nx: DVec3,
    (u0, u1): (f64, f64),
    depth: u32,
) -> Option<f64> {
    let (pa, pb) = (c.at(u0), c.at(u1));
    let um = 0.5 * (u0 + u1);
    let mid = c.at(um);
    // Length through the midpoint (a closed edge, a tube's rim, has no chord).
    let chord = (mid - pa).length() + (pb - mid).length();
    let dist = point_segment_distance(x, pa, pb).min((mid - x).length());
    if dist < chord && depth < 40 {
        return Some(
            curve_integral(c, rules, x, nx, (u0, um), depth + 1)?
                + curve_integral(c, rules, x, nx, (um, u1), depth + 1)?,
        );
    }
    let (gx, gw) = &rules.g8;
    let d = u1 - u0;
    let mut sum = 0.0;
    for (u, w) in gx.iter().zip(gw) {
        let u = u0 + d * u;
        let r = c.at(u) - x;
        if nx.dot(r) < -1e-12 * r.length() {
            return None;
        }
        sum += w * nx.dot(r.cross(c.tangent(u))) / r.length_squared();
    }
    for p in [pa, pb] {
        if nx.dot(p - x) < -1e-12 * (p - x).length() {
            return None;
        }
    }
    Some(sum * d)
}

/// `∫_g ψ_a(x) F(x → P) dA_x`, `a = 0..n` (the unit-square basis of `g`), by the
/// node's 4×4 Gauss rule (see the module docs). The price of one rule for every
/// piece: it is not bisected, so a moment against a piece touching or close to the
/// node is only as good as 16 points on `F`'s peak (measured on the Cornell faces:
/// 2–9 % off for floor nodes touching a block's foot, and a link's flux from a
/// 0.55 m wall triangle into a small face ~0.3 m away +2.4 % through its higher
/// moments; the block's constant entry is exact regardless, [`constant`]). `None` where a point form factor does not exist.
pub fn moments(
    patches: &[Patch],
    basis: &TreeBasis,
    rules: &Rules,
    g: &Region,
    piece: &Piece,
    evals: &mut u64,
) -> Option<Vec<f64>> {
    let mut out = vec![0.0; basis.n()];
    rule_on(
        patches, basis, rules, &rules.g4, g, g, piece, evals, &mut out,
    )?;
    Some(out)
}

/// `∫_{g ∩ real} ψ_a(y) F(y → P) dA_y`, `a = 0..n`: the moments of a node `g` of a
/// masked (virtual) support over its real part only, the part that emits
/// (VirtualMesh §4.2). The real part is the mask's loops clipped to the node's window
/// ([`real_loops`]), pulled back to parameter space, where it is a straight polygon
/// with holes for every planar map. It is cut into trapezoids by vertical lines
/// through its vertices (in each slab, the edges crossing it sorted upwards; the
/// trapezoids between consecutive edges where the winding number is not zero), each
/// integrated by a 4×4 Gauss rule, exact for the basis functions times any cubic.
/// Only real points are sampled: `F(y → P)` jumps where `P`'s plane meets the node
/// (a block standing on the rim of a floor's hole), so a rule may not straddle the
/// real region's boundary. Unlike [`moments`], the panels are bisected towards each
/// piece `P` (up to `REAL_DEPTH` times), so different pieces are integrated on
/// different points: in a closed enclosure the moments against all pieces sum to
/// `∫_{g ∩ real} ψ_a` to the rules' accuracy (8e-7 relative on one piece next to a
/// touching edge in the tests), not to rounding. `None` where the support has no
/// mask, a loop crossing the node has an arc, or a point form factor does not exist.
pub fn real_moments(
    patches: &[Patch],
    basis: &TreeBasis,
    rules: &Rules,
    g: &Region,
    piece: &Piece,
    evals: &mut u64,
) -> Option<Vec<f64>> {
    let sup = &patches[g.patch].support;
    let m = sup.mask.as_ref()?;
    // Edges (start, end) of the real part in parameter space.
    let mut edges: Vec<(DVec2, DVec2)> = Vec::new();
    for lp in real_loops(m, g)? {
        let st: Vec<DVec2> = lp
            .iter()
            .map(|q| {
                let (s, t) = m.from_plane(*q);
                DVec2::new(s, t)
            })
            .collect();
        for (k, &p) in st.iter().enumerate() {
            edges.push((p, st[(k + 1) % st.len()]));
        }
    }
    let mut xs: Vec<f64> = edges.iter().map(|e| e.0.x).collect();
    xs.sort_by(f64::total_cmp);
    xs.dedup();
    let mut out = vec![0.0; basis.n()];
    let at = |(p, q): (DVec2, DVec2), s: f64| p.y + (q.y - p.y) * ((s - p.x) / (q.x - p.x));
    for slab in xs.windows(2) {
        let (s0, s1) = (slab[0], slab[1]);
        let sm = 0.5 * (s0 + s1);
        // Every edge spans whole slabs (its end points are among `xs`).
        let mut cross: Vec<(f64, f64, f64, i32)> = edges
            .iter()
            .filter(|(p, q)| p.x.min(q.x) <= s0 && p.x.max(q.x) >= s1)
            .map(|&e| {
                let up = if e.1.x > e.0.x { 1 } else { -1 };
                (at(e, sm), at(e, s0), at(e, s1), up)
            })
            .collect();
        cross.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut winding = 0;
        for k in 0..cross.len().saturating_sub(1) {
            winding += cross[k].3;
            if winding == 0 {
                continue;
            }
            let (lo, hi) = (cross[k], cross[k + 1]);
            let trap = Trapezoid {
                s: (s0, s1),
                lo: (lo.1, lo.2),
                hi: (hi.1, hi.2),
            };
            trap.integrate(
                patches,
                basis,
                rules,
                g,
                piece,
                [0.0, 1.0, 0.0, 1.0],
                0,
                evals,
                &mut out,
            )?;
        }
    }
    Some(out)
}

/// Bisections of a panel of [`real_moments`] towards the piece it sees: a panel closer
/// to the piece's boundary than its own diameter is split in four, down to
/// `2^-REAL_DEPTH` of its trapezoid (`F(y → P)` has a logarithmic derivative where
/// `P` touches the node, e.g. a block's face standing on a floor).
const REAL_DEPTH: u32 = 6;

/// A trapezoid of parameter space with vertical sides: `s ∈ [s.0, s.1]`, between the
/// lines through `(s.0, lo.0)`–`(s.1, lo.1)` and `(s.0, hi.0)`–`(s.1, hi.1)`.
struct Trapezoid {
    s: (f64, f64),
    lo: (f64, f64),
    hi: (f64, f64),
}

impl Trapezoid {
    /// `(s, t)` and the parameter area element at `(u, v) ∈ [0, 1]²`.
    fn map(&self, u: f64, v: f64) -> (f64, f64, f64) {
        let s = self.s.0 + u * (self.s.1 - self.s.0);
        let t0 = self.lo.0 + u * (self.lo.1 - self.lo.0);
        let t1 = self.hi.0 + u * (self.hi.1 - self.hi.0);
        (s, t0 + v * (t1 - t0), (self.s.1 - self.s.0) * (t1 - t0))
    }

    /// Adds `∫ ψ_a F(y → P) dA_y` over the panel `[u0, u1] × [v0, v1]` of the
    /// trapezoid into `out` (4×4 Gauss, bisected near the piece, see [`REAL_DEPTH`]).
    #[allow(clippy::too_many_arguments)]
    fn integrate(
        &self,
        patches: &[Patch],
        basis: &TreeBasis,
        rules: &Rules,
        g: &Region,
        piece: &Piece,
        [u0, u1, v0, v1]: [f64; 4],
        depth: u32,
        evals: &mut u64,
        out: &mut [f64],
    ) -> Option<()> {
        let sup = &patches[g.patch].support;
        if depth < REAL_DEPTH {
            let corner = |u, v| {
                let (s, t, _) = self.map(u, v);
                sup.point(s, t)
            };
            let size = (corner(u0, v0) - corner(u1, v1))
                .length()
                .max((corner(u1, v0) - corner(u0, v1)).length());
            let (um, vm) = (0.5 * (u0 + u1), 0.5 * (v0 + v1));
            if size > 0.0 && piece_distance(patches, piece, corner(um, vm)) < size {
                for q in [
                    [u0, um, v0, vm],
                    [um, u1, v0, vm],
                    [u0, um, vm, v1],
                    [um, u1, vm, v1],
                ] {
                    self.integrate(patches, basis, rules, g, piece, q, depth + 1, evals, out)?;
                }
                return Some(());
            }
        }
        let (x, w) = &rules.g4;
        let n = basis.n();
        let mut psi = [0.0; 16];
        for (xu, wu) in x.iter().zip(w) {
            for (xv, wv) in x.iter().zip(w) {
                let (s, t, jac) = self.map(u0 + (u1 - u0) * xu, v0 + (v1 - v0) * xv);
                if jac <= 0.0 {
                    continue;
                }
                let (yp, ny) = sup.point_normal(s, t);
                *evals += 1;
                let f = point_form_factor(patches, rules, piece, yp, ny)?;
                if f == 0.0 {
                    continue;
                }
                basis.eval((s - g.s0) / g.h, (t - g.t0) / g.h, &mut psi[..n]);
                let c = wu * wv * (u1 - u0) * (v1 - v0) * jac * sup.jacobian(s, t) * f;
                for (o, p) in out.iter_mut().zip(&psi[..n]) {
                    *o += c * p;
                }
            }
        }
        Some(())
    }
}

/// Distance from `x` to the boundary of a piece (its loops' edges; for a curved piece,
/// to its node's bounding sphere).
fn piece_distance(patches: &[Patch], piece: &Piece, x: DVec3) -> f64 {
    match piece {
        Piece::Polygons { loops, .. } => loops
            .iter()
            .flat_map(|(l, _)| {
                (0..l.len()).map(move |k| point_segment_distance(x, l[k], l[(k + 1) % l.len()]))
            })
            .fold(f64::INFINITY, f64::min),
        Piece::Curved { region, .. } | Piece::Mapped { region } => {
            let (c, r) = patches[region.patch]
                .support
                .bounding_sphere(region.s0, region.t0, region.h);
            ((x - c).length() - r).max(0.0)
        }
    }
}

/// Gauss `(x, w)` rule on the sub-square `sub` of node `g`: adds `Σ w F ψ` into `acc`.
#[allow(clippy::too_many_arguments)]
fn rule_on(
    patches: &[Patch],
    basis: &TreeBasis,
    rules: &Rules,
    rule: &(Vec<f64>, Vec<f64>),
    g: &Region,
    sub: &Region,
    piece: &Piece,
    evals: &mut u64,
    acc: &mut [f64],
) -> Option<()> {
    let p = &patches[g.patch];
    let (x, w) = rule;
    let area = p.support.area * sub.h * sub.h;
    let n = basis.n();
    let mut psi = [0.0; 16];
    // Points of `g` on the piece's own node (a curved node's self pair or a nested
    // pair; Gauss points are never on a square's edge).
    let on_piece = |s: f64, t: f64| match piece {
        Piece::Mapped { region: q } => {
            q.patch == g.patch
                && (q.s0..=q.s0 + q.h).contains(&s)
                && (q.t0..=q.t0 + q.h).contains(&t)
        }
        _ => false,
    };
    for (jt, wt) in x.iter().zip(w) {
        for (js, ws) in x.iter().zip(w) {
            let (s, t) = (sub.s0 + sub.h * js, sub.t0 + sub.h * jt);
            let (xp, nx) = p.support.point_normal(s, t);
            *evals += 1;
            let f = point_form_factor_at(patches, rules, piece, xp, nx, on_piece(s, t))?;
            if f == 0.0 {
                continue;
            }
            basis.eval((s - g.s0) / g.h, (t - g.t0) / g.h, &mut psi[..n]);
            let c = ws * wt * area * f;
            for (a, v) in acc.iter_mut().zip(&psi[..n]) {
                *a += c * v;
            }
        }
    }
    Some(())
}

/// `∫_R ∫_E G` of two pieces by the contour form `A_R F_RE = (1/2π) ∮∮ ln r dx·dy`
/// (Schröder & Hanrahan 1993): `wavelux-geometry`'s closed-form edge pairs when both
/// are polygons (signed loops, each counter-clockwise about its front normal; clipped
/// to each other's half-spaces, so any relative position is exact); with a curved
/// piece, tensor Gauss panels on the two boundaries, bisected while two panels are
/// closer than their length (the integrand is analytic elsewhere). `None` where a curved
/// piece crosses the other's plane (the contour form needs each piece entirely in
/// front of the other).
pub fn constant(patches: &[Patch], rules: &Rules, r: &Piece, e: &Piece) -> Option<f64> {
    if let (Piece::Polygons { loops: lr, .. }, Piece::Polygons { loops: le, .. }) = (r, e) {
        let mut sum = 0.0;
        for (pr, sr) in lr {
            for (pe, se) in le {
                sum += sr * se * area_form_factor(pr, pe).ok()?;
            }
        }
        return Some(sum.max(0.0));
    }
    let cr = curves(patches, r);
    let ce = curves(patches, e);
    let behind = |cs: &[Curve<'_>], n: DVec3, o: DVec3| {
        cs.iter().any(|c| {
            (0..=8).any(|i| {
                let p = c.at(i as f64 / 8.0);
                n.dot(p - o) < -1e-9 * (p - o).length()
            })
        })
    };
    match (r.plane(), e.plane()) {
        (Some((nr, or)), Some((ne, oe))) => {
            if behind(&cr, ne, oe) || behind(&ce, nr, or) {
                return None;
            }
        }
        _ => {
            // A curved surface: every sample pair must face each other, and the
            // nodes may not overlap on one surface.
            if let (
                Piece::Curved { region: a, .. } | Piece::Mapped { region: a },
                Piece::Curved { region: b, .. } | Piece::Mapped { region: b },
            ) = (r, e)
                && same_surface_overlap(a, b)
            {
                return match (r, e) {
                    (Piece::Mapped { .. }, Piece::Mapped { .. }) => {
                        nested_constant(patches, rules, a, b)
                    }
                    _ => None,
                };
            }
            if !mutually_facing(&r.samples(patches), &e.samples(patches)) {
                return None;
            }
        }
    }
    let mut sum = 0.0;
    for a in &cr {
        for b in &ce {
            sum += a.sign
                * b.sign
                * panel_pair(
                    rules,
                    a,
                    (0.0, 1.0),
                    b,
                    (0.0, 1.0),
                    0,
                    (FLAT, f64::INFINITY),
                );
        }
    }
    Some((sum / (2.0 * std::f64::consts::PI)).abs())
}

/// `∫_R ∫_E G` of two nested nodes `a`, `b` of one curved support (a node's self pair,
/// or a node and a descendant) whose larger node is concave: every sample pair of it
/// ([`FACING_GRID`]) faces each other, as on the inside of a sphere or a cylinder.
/// `None` elsewhere (a convex side sees none of itself; the quadrature's zero stays).
///
/// From a point `x` inside a concave node `N`, the node covers the part of the
/// hemisphere below its boundary's cone, so `F(x → N) = 1 − (1/2π)|∮_{∂N} n_x · (r ×
/// dr)/|r|²|` (a flat piece gives `1 − 1 = 0`); integrating over the smaller node `S`
/// and applying Stokes' theorem to the second term as for two separate pieces,
/// `∫_S ∫_N G = |S| − (1/2π)|∮_{∂S} ∮_{∂N} ln r dx·dy|` (a closed sphere: no boundary,
/// `F = 1`; a hemisphere: `|S| − π R² = π R²`, `F = ½`). The second term is nearly
/// `|S|` when the node sees little of itself, so the chords of [`panel_pair`]'s close
/// panels would be amplified by `1/F`: close panels are capped at [`NESTED_PANEL`] of
/// the node's side, the double contour is taken at two chord lengths (the caps and
/// [`FLAT`], then both halved) and extrapolated (Richardson for the chords' `O(l²)`
/// error; measured without extrapolation: 1.8e-2, 1.1e-3, 6.5e-5 at FLAT, FLAT/4,
/// FLAT/16 on level-3 sphere cells). Sphere cells against `|S||N|/(4πR²)`: worst
/// 1.6e-6 over levels 0–3, 3.1e-5 at level 6 (without the cap 2.5e-2 at level 6: an
/// absolute chord length leaves the small nodes' error amplified by `1/F`).
fn nested_constant(patches: &[Patch], rules: &Rules, a: &Region, b: &Region) -> Option<f64> {
    let (small, big) = if a.h <= b.h { (a, b) } else { (b, a) };
    let grid = Piece::Mapped { region: *big }.samples(patches);
    if !mutually_facing(&grid, &grid) {
        return None;
    }
    let (pa, pb) = (Piece::Mapped { region: *a }, Piece::Mapped { region: *b });
    let (ca, cb) = (curves(patches, &pa), curves(patches, &pb));
    let area = patches[small.patch].support.area * small.h * small.h;
    // Close panels also no longer than NESTED_PANEL of the node's side, so that the
    // chords' error relative to F (which shrinks with the node) does not grow with the
    // level.
    let (fl, cap) = (1.0, NESTED_PANEL * area.sqrt());
    let double = |k: f64| {
        let mut sum = 0.0;
        for x in &ca {
            for y in &cb {
                sum += x.sign
                    * y.sign
                    * panel_pair(
                        rules,
                        x,
                        (0.0, 1.0),
                        y,
                        (0.0, 1.0),
                        0,
                        (k * fl * FLAT, k * cap),
                    );
            }
        }
        sum
    };
    let (coarse, fine) = (double(1.0), double(0.5));
    let ex = (4.0 * fine - coarse) / 3.0;
    let contour = ex.abs() / (2.0 * std::f64::consts::PI);
    let v = area - contour;
    (v.is_finite()).then_some(v.max(0.0))
}

/// A boundary curve of a piece: a straight segment, or the image of a parameter
/// segment `a → b` under a planar support's map (smooth between its ends).
struct Curve<'a> {
    kind: CurveKind<'a>,
    sign: f64,
}

enum CurveKind<'a> {
    Segment(DVec3, DVec3),
    /// The image of the parameter segment `a → b`, with the ends where the map is
    /// singular ([`singular_end`]) smoothed.
    Mapped(&'a crate::support::Support, DVec2, DVec2, Ends),
}

/// Which ends of a mapped curve have a square-root singularity.
#[derive(Debug, Clone, Copy)]
struct Ends {
    start: bool,
    end: bool,
}

impl Ends {
    /// The curve's parameter as a function of the panel variable `u ∈ [0, 1]`:
    /// `u²` towards a singular start, `1 − (1 − u)²` towards a singular end,
    /// `u²(3 − 2u)` for both, flat at each singular end so that the curve is analytic
    /// there in `u`.
    fn map(self, u: f64) -> f64 {
        match (self.start, self.end) {
            (false, false) => u,
            (true, false) => u * u,
            (false, true) => 1.0 - (1.0 - u) * (1.0 - u),
            (true, true) => u * u * (3.0 - 2.0 * u),
        }
    }
}

/// Whether the image of the segment `p → q` (parameter space) leaves `p` like a
/// square root: an equal-area map is singular where its Jacobian's factors degenerate
/// (a sphere's pole: the radius is `√(1 − w²)` with `w` linear in `t`; a cone's apex),
/// which falls on the ends of the node edges touching it. Detected by the distances
/// `d₁, d₂` from `p` of the points at `δ` and `2δ` of the way (`δ = 1e-4`): `d₂/d₁ ≈ 2`
/// on a smooth curve, `√2` at a square-root end (threshold 1.7). Without the
/// substitution of [`Ends::map`] the 8-point Gauss panels of a pole cell's meridians
/// were 7 % off (level-2 sphere cell seen from a floor point).
fn singular_end(sup: &crate::support::Support, p: DVec2, q: DVec2) -> bool {
    let delta = 1e-4;
    let y0 = sup.point(p.x, p.y);
    let at = |f: f64| {
        let r = p + (q - p) * f;
        (sup.point(r.x, r.y) - y0).length()
    };
    let (d1, d2) = (at(delta), at(2.0 * delta));
    d1 > 0.0 && d2 < 1.7 * d1
}

impl Curve<'_> {
    fn at(&self, u: f64) -> DVec3 {
        match &self.kind {
            CurveKind::Segment(a, b) => *a + (*b - *a) * u,
            CurveKind::Mapped(sup, a, b, ends) => {
                let u = ends.map(u);
                let p = *a + (*b - *a) * u;
                sup.point(p.x, p.y)
            }
        }
    }

    fn tangent(&self, u: f64) -> DVec3 {
        match &self.kind {
            CurveKind::Segment(a, b) => *b - *a,
            CurveKind::Mapped(..) => {
                let step = 1e-6;
                let (u0, u1) = ((u - step).max(0.0), (u + step).min(1.0));
                (self.at(u1) - self.at(u0)) / (u1 - u0)
            }
        }
    }
}

/// The mapped curve `a → b` of `sup`: curved supports' ends checked for square-root
/// singularities ([`singular_end`]), planar ones (disks: kinks are split off) kept.
fn mapped(sup: &crate::support::Support, a: DVec2, b: DVec2) -> CurveKind<'_> {
    let ends = if sup.is_planar() {
        Ends {
            start: false,
            end: false,
        }
    } else {
        Ends {
            start: singular_end(sup, a, b),
            end: singular_end(sup, b, a),
        }
    };
    CurveKind::Mapped(sup, a, b, ends)
}

fn curves<'a>(patches: &'a [Patch], p: &Piece) -> Vec<Curve<'a>> {
    match p {
        Piece::Polygons { loops, .. } => loops
            .iter()
            .flat_map(|(poly, sign)| {
                (0..poly.len()).map(move |i| Curve {
                    kind: CurveKind::Segment(poly[i], poly[(i + 1) % poly.len()]),
                    sign: *sign,
                })
            })
            .collect(),
        Piece::Curved { region, .. } | Piece::Mapped { region } => {
            let sup = &patches[region.patch].support;
            let mut v = Vec::new();
            for (a, b) in square_edges(region) {
                let mut ts = vec![0.0, 1.0];
                ts.extend(disk_kinks(a, b));
                ts.sort_by(f64::total_cmp);
                for w in ts.windows(2) {
                    v.push(Curve {
                        kind: mapped(sup, a + (b - a) * w[0], a + (b - a) * w[1]),
                        sign: 1.0,
                    });
                }
            }
            v
        }
    }
}

/// The longest close panel of a nested pair's double contour ([`nested_constant`]), as
/// a fraction of the node's side (`√area`): measured on sphere cells, levels 1–6, worst
/// relative error 1.1e-6 / 1.0e-6 / 1.6e-6 / 5.2e-6 / 6.8e-6 / 3.1e-5 (0.03: up to
/// 2.9e-4 at level 6; with FLAT/4 alone and no cap, 2.5e-2 at level 6).
const NESTED_PANEL: f64 = 0.015;

/// Relative sagitta below which a close panel of [`panel_pair`] is taken as its chord
/// (a circular arc of length `l` and radius `R` has sagitta `l²/(8R)`: panels shorter
/// than `0.08 R`). The chord's `ln r` differs from the arc's by about this fraction on
/// a panel pair whose share of the integral is of the order of its length squared:
/// measured on a closed cylinder's tube and end disk, whose rims coincide, 2.1e-5 of
/// their form factor (1e-3: 2e-7 at ten times the cost).
const FLAT: f64 = 1e-2;

/// `∫_{ua}∫_{vb} ln|A(u) − B(v)| A'(u)·B'(v) du dv` over the panels `ua` of `a` and `vb`
/// of `b`: 8×8 Gauss when the panels are farther apart than their chords, else the
/// longer one is bisected (at most 30 times); close panels straight to `flat_to` of
/// their length ([`FLAT`]) are taken as their chords.
fn panel_pair(
    rules: &Rules,
    a: &Curve<'_>,
    ua: (f64, f64),
    b: &Curve<'_>,
    vb: (f64, f64),
    depth: u32,
    flat_to: (f64, f64),
) -> f64 {
    let (a0, a1) = (a.at(ua.0), a.at(ua.1));
    let (b0, b1) = (b.at(vb.0), b.at(vb.1));
    let am = a.at(0.5 * (ua.0 + ua.1));
    let bm = b.at(0.5 * (vb.0 + vb.1));
    // Lengths through the midpoints (a closed edge, a tube's rim, has no chord).
    let la = (am - a0).length() + (a1 - am).length();
    let lb = (bm - b0).length() + (b1 - bm).length();
    let dist = segment_distance(a0, a1, b0, b1).min((am - bm).length());
    if dist < la.max(lb) && depth < 30 {
        // Close panels that are straight to FLAT of their length (segments at once,
        // arcs after a few bisections): the closed form on their chords. Coincident
        // curves (a tube's rim on its end disk) would otherwise bisect to the depth
        // limit along their whole length.
        let flat = |m: DVec3, p: DVec3, q: DVec3, l: f64| {
            (m - 0.5 * (p + q)).length() <= flat_to.0 * l && l <= flat_to.1
        };
        if flat(am, a0, a1, la)
            && flat(bm, b0, b1, lb)
            && let Ok(v) = segment_pair_log_integral(a0, a1, b0, b1)
        {
            return v;
        }
        if la >= lb {
            let m = 0.5 * (ua.0 + ua.1);
            return panel_pair(rules, a, (ua.0, m), b, vb, depth + 1, flat_to)
                + panel_pair(rules, a, (m, ua.1), b, vb, depth + 1, flat_to);
        }
        let m = 0.5 * (vb.0 + vb.1);
        return panel_pair(rules, a, ua, b, (vb.0, m), depth + 1, flat_to)
            + panel_pair(rules, a, ua, b, (m, vb.1), depth + 1, flat_to);
    }
    let (gx, gw) = &rules.g8;
    let (da, db) = (ua.1 - ua.0, vb.1 - vb.0);
    let pts_b: Vec<(DVec3, DVec3)> = gx
        .iter()
        .map(|v| {
            let v = vb.0 + db * v;
            (b.at(v), b.tangent(v))
        })
        .collect();
    let mut sum = 0.0;
    for (u, wu) in gx.iter().zip(gw) {
        let u = ua.0 + da * u;
        let (p, tp) = (a.at(u), a.tangent(u));
        for ((q, tq), wv) in pts_b.iter().zip(gw) {
            let r = (p - *q).length();
            if r > 0.0 {
                sum += wu * wv * r.ln() * tp.dot(*tq);
            }
        }
    }
    sum * da * db
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::support::{Side, Support};
    use wavelux_geometry::formfactor::{coaxial_disks, point_to_parallel_disk};

    fn patch(support: Support) -> Patch {
        Patch {
            surface: 0,
            piece: 0,
            side: Side::Front,
            support,
            reflectance: [0.5; 3],
            emission: [0.0; 3],
            prim: 0,
        }
    }

    fn root(patch: usize) -> Region {
        Region {
            patch,
            s0: 0.0,
            t0: 0.0,
            h: 1.0,
        }
    }

    #[test]
    fn disk_pieces_reproduce_the_catalogue() {
        // Emitter: a disk of radius 1 at height h facing down; receivers: points and a
        // coaxial disk of radius 0.6 facing up.
        let rules = Rules::new().unwrap();
        for h in [0.05, 1.0, 20.0] {
            let patches = vec![
                patch(Support::disk(
                    DVec3::new(0.0, 0.0, h),
                    DVec3::Y,
                    DVec3::X,
                    1.0,
                )),
                patch(Support::disk(DVec3::ZERO, DVec3::X, DVec3::Y, 0.6)),
            ];
            let e = piece(&patches[0], &root(0), true).unwrap();
            for a in [0.0, 0.3, 0.99, 1.7] {
                let f = point_form_factor(&patches, &rules, &e, DVec3::new(a, 0.0, 0.0), DVec3::Z)
                    .unwrap();
                let exact = point_to_parallel_disk(1.0, h, a).unwrap();
                // The contour's tangent is a central difference (step 1e-6): ~1e-9.
                assert!(
                    (f - exact).abs() < 1e-8 * exact,
                    "h {h} a {a}: {f} vs {exact}"
                );
            }
            let r = piece(&patches[1], &root(1), false).unwrap();
            let c = constant(&patches, &rules, &r, &e).unwrap();
            let exact = coaxial_disks(0.6, 1.0, h).unwrap() * std::f64::consts::PI * 0.36;
            assert!((c - exact).abs() < 1e-8 * exact, "h {h}: {c} vs {exact}");
            // Reciprocity of the contour form.
            let c2 = constant(&patches, &rules, &e, &r).unwrap();
            assert!((c - c2).abs() < 1e-10 * c, "{c} vs {c2}");
            // Sub-squares of the concentric map partition the disk: their point form
            // factors add up.
            let x = DVec3::new(0.2, -0.1, 0.0);
            let whole = point_form_factor(&patches, &rules, &e, x, DVec3::Z).unwrap();
            let mut parts = 0.0;
            for c in 0..16 {
                let g = Region {
                    patch: 0,
                    s0: 0.25 * (c % 4) as f64,
                    t0: 0.25 * (c / 4) as f64,
                    h: 0.25,
                };
                let p = piece(&patches[0], &g, true).unwrap();
                parts += point_form_factor(&patches, &rules, &p, x, DVec3::Z).unwrap();
            }
            assert!((parts - whole).abs() < 1e-10 * whole, "{parts} vs {whole}");
        }
    }

    #[test]
    fn moments_of_a_closed_box_sum_to_those_of_the_constant() {
        // The six inward faces of the unit cube: from every point of a face, the form
        // factors to the other five sum to one, so the Gauss moments do too.
        let basis = TreeBasis::new(crate::BasisKind::Multiwavelet(3)).unwrap();
        let rules = Rules::new().unwrap();
        let (x, y, z) = (DVec3::X, DVec3::Y, DVec3::Z);
        let faces = [
            (DVec3::ZERO, y, z),
            (x, z, y),
            (DVec3::ZERO, z, x),
            (y, x, z),
            (DVec3::ZERO, x, y),
            (z, y, x),
        ];
        let patches: Vec<Patch> = faces
            .iter()
            .map(|&(o, u, v)| patch(Support::parallelogram(o, u, v)))
            .collect();
        let g = Region {
            patch: 4,
            s0: 0.25,
            t0: 0.5,
            h: 0.25,
        };
        let mut sum = vec![0.0; basis.n()];
        let mut evals = 0;
        for q in [0, 1, 2, 3, 5] {
            for c in 0..4 {
                let e = Region {
                    patch: q,
                    s0: 0.5 * (c % 2) as f64,
                    t0: 0.5 * (c / 2) as f64,
                    h: 0.5,
                };
                let p = piece(&patches[q], &e, true).unwrap();
                let m = moments(&patches, &basis, &rules, &g, &p, &mut evals).unwrap();
                for (s, v) in sum.iter_mut().zip(&m) {
                    *s += v;
                }
            }
        }
        let area = 1.0 / 16.0;
        assert!((sum[0] - area).abs() < 1e-14, "{}", sum[0]);
        for v in &sum[1..] {
            assert!(v.abs() < 1e-14, "{sum:?}");
        }
    }

    #[test]
    fn real_moments_of_a_partial_node_match_the_constant_and_a_fine_rule() {
        // A unit floor with a hole under a block; the block's face at x = 0.25 (facing
        // −x) touches the floor along the hole's edge. The floor node
        // [0, 0.5] × [0.25, 0.75] is partly over the hole.
        use crate::mask::Mask;
        use wavelux_geometry::{TrimLoop, TrimRegion};
        let sq = |a: f64, b: f64, c: f64, d: f64| {
            vec![
                DVec2::new(a, c),
                DVec2::new(b, c),
                DVec2::new(b, d),
                DVec2::new(a, d),
            ]
        };
        let mut hole = sq(0.25, 0.75, 0.375, 0.625);
        hole.reverse();
        let region = TrimRegion::new(vec![
            TrimLoop::polygon(&sq(0.0, 1.0, 0.0, 1.0)).unwrap(),
            TrimLoop::polygon(&hole).unwrap(),
        ])
        .unwrap();
        let basis = TreeBasis::new(crate::BasisKind::Multiwavelet(3)).unwrap();
        let rules = Rules::new().unwrap();
        // Both orientations of Λ (the mask plane mirrored against (s, t)).
        for mirrored in [false, true] {
            let (mask, floor) = if mirrored {
                (
                    Mask::new(region.clone(), DVec2::ZERO, DVec2::Y, DVec2::X).unwrap(),
                    Support::parallelogram(DVec3::ZERO, DVec3::Y, DVec3::X).flipped(),
                )
            } else {
                (
                    Mask::new(region.clone(), DVec2::ZERO, DVec2::X, DVec2::Y).unwrap(),
                    Support::parallelogram(DVec3::ZERO, DVec3::X, DVec3::Y),
                )
            };
            let patches = vec![
                patch(floor.with_mask(mask)),
                patch(Support::parallelogram(
                    DVec3::new(0.25, 0.375, 0.0),
                    0.25 * DVec3::Z,
                    0.25 * DVec3::Y,
                )),
            ];
            assert!(patches[0].support.normal.z > 0.0);
            let g = if mirrored {
                Region {
                    patch: 0,
                    s0: 0.25,
                    t0: 0.0,
                    h: 0.5,
                }
            } else {
                Region {
                    patch: 0,
                    s0: 0.0,
                    t0: 0.25,
                    h: 0.5,
                }
            };
            assert_eq!(
                patches[0].support.coverage(g.s0, g.t0, g.h),
                Coverage::Partial
            );
            let r = piece(&patches[1], &root(1), false).unwrap();
            let e = piece(&patches[0], &g, true).unwrap();
            let mut evals = 0;
            let m = real_moments(&patches, &basis, &rules, &g, &r, &mut evals).unwrap();
            // ψ₀ = 1: the constant moment is ∫_E ∫_R G, the closed-form contour integral.
            let c = constant(&patches, &rules, &r, &e).unwrap();
            // (Measured: 8e-7 relative, from the bisections towards the touching edge.)
            assert!(
                (m[0] - c).abs() < 1e-5 * c,
                "mirrored {mirrored}: {} vs {c}",
                m[0]
            );
            // Every moment against an 8×8 Gauss rule on each real 1/16-square of the
            // node (the hole's edges lie on that grid).
            let mut fine = vec![0.0; basis.n()];
            for k in 0..64 {
                let sub = Region {
                    patch: 0,
                    s0: g.s0 + 0.0625 * (k % 8) as f64,
                    t0: g.t0 + 0.0625 * (k / 8) as f64,
                    h: 0.0625,
                };
                if patches[0].support.coverage(sub.s0, sub.t0, sub.h) == Coverage::Full {
                    rule_on(
                        &patches, &basis, &rules, &rules.g8, &g, &sub, &r, &mut evals, &mut fine,
                    )
                    .unwrap();
                }
            }
            for (a, (v, f)) in m.iter().zip(&fine).enumerate() {
                assert!(
                    (v - f).abs() < 1e-5 * c,
                    "mirrored {mirrored} ψ{a}: {v} vs {f}"
                );
            }
        }
    }

    #[test]
    fn convex_clip_keeps_the_inside() {
        let w = [
            DVec2::new(0.0, 0.0),
            DVec2::new(1.0, 0.0),
            DVec2::new(1.0, 1.0),
            DVec2::new(0.0, 1.0),
        ];
        // An L-shaped (concave) loop half outside the window, clockwise (a hole).
        let l = [
            DVec2::new(0.5, 0.5),
            DVec2::new(0.5, 2.0),
            DVec2::new(2.0, 2.0),
            DVec2::new(2.0, -1.0),
            DVec2::new(-1.0, -1.0),
            DVec2::new(-1.0, 0.5),
        ];
        let c = clip_convex(&l, &w);
        // Window ∩ L = the unit square minus [0, 0.5] × [0.5, 1], clockwise.
        assert!(
            (signed_area(&c) + 0.75).abs() < 1e-14,
            "{}",
            signed_area(&c)
        );
    }
}
