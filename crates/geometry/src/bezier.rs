//! Bicubic Bézier patches: evaluation with first derivatives and de Casteljau subdivision.

use glam::{DVec2, DVec3};

fn bernstein(t: f64) -> ([f64; 4], [f64; 4]) {
    let s = 1.0 - t;
    let b = [s * s * s, 3.0 * t * s * s, 3.0 * t * t * s, t * t * t];
    let d = [
        -3.0 * s * s,
        3.0 * s * s - 6.0 * t * s,
        6.0 * t * s - 3.0 * t * t,
        3.0 * t * t,
    ];
    (b, d)
}

/// Point, `∂/∂u` and `∂/∂v` of the bicubic patch with control net `p[i][j]` (`i` along `u`).
pub fn eval(p: &[[DVec3; 4]; 4], uv: DVec2) -> (DVec3, DVec3, DVec3) {
    let (bu, du) = bernstein(uv.x);
    let (bv, dv) = bernstein(uv.y);
    let mut x = DVec3::ZERO;
    let mut xu = DVec3::ZERO;
    let mut xv = DVec3::ZERO;
    for i in 0..4 {
        for j in 0..4 {
            x += bu[i] * bv[j] * p[i][j];
            xu += du[i] * bv[j] * p[i][j];
            xv += bu[i] * dv[j] * p[i][j];
        }
    }
    (x, xu, xv)
}

fn split_curve(c: [DVec3; 4]) -> ([DVec3; 4], [DVec3; 4]) {
    let m01 = 0.5 * (c[0] + c[1]);
    let m12 = 0.5 * (c[1] + c[2]);
    let m23 = 0.5 * (c[2] + c[3]);
    let a = 0.5 * (m01 + m12);
    let b = 0.5 * (m12 + m23);
    let m = 0.5 * (a + b);
    ([c[0], m01, a, m], [m, b, m23, c[3]])
}

/// Splits the patch at `u = 1/2` into the `(u ∈ [0,½], u ∈ [½,1])` halves.
pub fn split_u(p: &[[DVec3; 4]; 4]) -> ([[DVec3; 4]; 4], [[DVec3; 4]; 4]) {
    let mut l = [[DVec3::ZERO; 4]; 4];
    let mut r = [[DVec3::ZERO; 4]; 4];
    for j in 0..4 {
        let (a, b) = split_curve([p[0][j], p[1][j], p[2][j], p[3][j]]);
        for i in 0..4 {
            l[i][j] = a[i];
            r[i][j] = b[i];
        }
    }
    (l, r)
}

/// Splits the patch at `v = 1/2`.
pub fn split_v(p: &[[DVec3; 4]; 4]) -> ([[DVec3; 4]; 4], [[DVec3; 4]; 4]) {
    let mut l = [[DVec3::ZERO; 4]; 4];
    let mut r = [[DVec3::ZERO; 4]; 4];
    for i in 0..4 {
        let (a, b) = split_curve(p[i]);
        l[i] = a;
        r[i] = b;
    }
    (l, r)
}
