// Two-point occlusion: CWBVH traversal (Ylitie et al. 2017) of obvhs' nodes with a
// conservative slab test, and f32 leaf tests that only answer when their margin beats
// a forward error bound (occlusion.rs derives it). Output per query:
// 0 = clear, 1 = blocked, 2 = unsure (the host re-traces it in f64).

struct Params {
    n: u32,
    pad0: u32,
    pad1: u32,
    pad2: u32,
}

@group(0) @binding(0) var<uniform> P: Params;
// 20 words per node (obvhs CwBvhNode, 80 bytes).
@group(0) @binding(1) var<storage, read> nodes: array<u32>;
// 16 words per slot: kind, prim, planar, size, 4 points x 3 floats.
@group(0) @binding(2) var<storage, read> slots: array<u32>;
// 12 words per query: a.xyz, eps_s, b.xyz, pad, ignore0, ignore1, pad, pad.
@group(0) @binding(3) var<storage, read> queries: array<u32>;
@group(0) @binding(4) var<storage, read_write> answers: array<u32>;

const U: f32 = 5.9604645e-8; // 2^-24
const MISS: u32 = 0u;
const HIT: u32 = 1u;
const UNSURE: u32 = 2u;

fn f(w: u32) -> f32 {
    return bitcast<f32>(w);
}

fn cabs(p: vec3<f32>, q: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(p.y * q.z + p.z * q.y, p.z * q.x + p.x * q.z, p.x * q.y + p.y * q.x);
}

// |det(x, y, z) − det(x̃, ỹ, z̃)| bound for inputs within componentwise errors ex, ey,
// ez of the exact ones, including the f32 evaluation of det (occlusion.rs).
fn det_bound(x: vec3<f32>, y: vec3<f32>, z: vec3<f32>, ex: vec3<f32>, ey: vec3<f32>, ez: vec3<f32>) -> f32 {
    let ax = abs(x);
    let ay = abs(y);
    let az = abs(z);
    let p0 = dot(ax, cabs(ay, az));
    let p1 = dot(ax + ex, cabs(ay + ey, az + ez));
    return (p1 - p0) + 16.0 * U * p1 + 1e-36;
}

fn det(x: vec3<f32>, y: vec3<f32>, z: vec3<f32>) -> f32 {
    return dot(cross(x, y), z);
}

// Rounding error of a difference of two rounded f32 inputs (componentwise).
fn diff_err(p: vec3<f32>, q: vec3<f32>) -> vec3<f32> {
    return 2.0 * U * (abs(p) + abs(q));
}

fn point(s: u32, i: u32) -> vec3<f32> {
    let b = s * 16u + 4u + i * 3u;
    return vec3<f32>(f(slots[b]), f(slots[b + 1u]), f(slots[b + 2u]));
}

// Plane crossing of the segment a→b inside s ∈ [eps, 1 − eps]: MISS (surely not),
// HIT (surely, and not edge-on), UNSURE.
fn plane_test(v0: vec3<f32>, e1: vec3<f32>, e2: vec3<f32>, ee1: vec3<f32>, ee2: vec3<f32>,
              a: vec3<f32>, b: vec3<f32>, eps: f32, dil: f32) -> u32 {
    let za = a - v0;
    let zb = b - v0;
    let fa = det(e1, e2, za);
    let fb = det(e1, e2, zb);
    let ba = det_bound(e1, e2, za, ee1, ee2, diff_err(a, v0) + vec3<f32>(dil));
    let bb = det_bound(e1, e2, zb, ee1, ee2, diff_err(b, v0) + vec3<f32>(dil));
    let sa = abs(fa) > ba;
    let sb = abs(fb) > bb;
    if (sa && sb && (fa > 0.0) == (fb > 0.0)) {
        return MISS;
    }
    if (!(sa && sb)) {
        return UNSURE;
    }
    // Opposite signs for sure: the crossing s* = |fa| / (|fa| + |fb|).
    let lo_den = abs(fa) + abs(fb) - ba - bb;
    let hi_den = abs(fa) + abs(fb) + ba + bb;
    let sa_lo = (abs(fa) - ba) / hi_den;
    let sa_hi = (abs(fa) + ba) / lo_den;
    let sb_lo = (abs(fb) - bb) / hi_den;
    let sb_hi = (abs(fb) + bb) / lo_den;
    let lo_eps = eps * (1.0 - 1e-5) - 1e-8;
    let hi_eps = eps * (1.0 + 1e-5) + 1e-8;
    if (sa_hi * (1.0 + 1e-5) < lo_eps || sb_hi * (1.0 + 1e-5) < lo_eps) {
        return MISS;
    }
    if (sa_lo * (1.0 - 1e-5) > hi_eps && sb_lo * (1.0 - 1e-5) > hi_eps) {
        return HIT;
    }
    return UNSURE;
}

// Triangle (n = 3) or parallelogram (n = 4) against the segment a→b.
fn convex_test(s: u32, n: u32, a: vec3<f32>, b: vec3<f32>, eps: f32) -> u32 {
    let size = f(slots[s * 16u + 3u]);
    let dil = 1e-8 * size;
    let d = b - a;
    let ed = diff_err(b, a);
    var pos = 0u;
    var neg = 0u;
    var sum = 0.0;
    var sum_b = 0.0;
    for (var i = 0u; i < n; i++) {
        let p = point(s, i);
        let q = point(s, (i + 1u) % n);
        let x = p - a;
        let y = q - a;
        let w = det(x, y, d);
        let bw = det_bound(x, y, d, diff_err(p, a) + vec3<f32>(dil), diff_err(q, a) + vec3<f32>(dil), ed);
        if (w > bw) {
            pos += 1u;
        } else if (w < -bw) {
            neg += 1u;
        }
        sum += w;
        sum_b += bw;
    }
    if (pos > 0u && neg > 0u) {
        return MISS;
    }
    let v0 = point(s, 0u);
    let v1 = point(s, 1u);
    let vl = point(s, n - 1u);
    let e1 = v1 - v0;
    let e2 = vl - v0;
    let ee1 = diff_err(v1, v0) + vec3<f32>(2.0 * dil);
    let ee2 = diff_err(vl, v0) + vec3<f32>(2.0 * dil);
    let pt = plane_test(v0, e1, e2, ee1, ee2, a, b, eps, dil);
    if (pt == MISS) {
        return MISS;
    }
    if (pos != n && neg != n) {
        return UNSURE;
    }
    // Through the interior for sure; not edge-on for sure (the CPU skips rays within
    // ~1e-10 rad of the plane): |N·D| ≥ |Σw| − Σbounds > 1e-9·(|N| + err N)·|D|.
    let nn = cross(e1, e2);
    let nerr = 8.0 * U * (length(abs(v1) + abs(v0)) * length(abs(vl) + abs(v0))) + 4.0 * dil * (length(e1) + length(e2));
    let scale_n = select(1.0, 2.0, n == 4u);
    if (abs(sum) - sum_b <= 1e-9 * scale_n * (length(nn) + 2.0 * nerr) * length(d) * 1.01 + 1e-36) {
        return UNSURE;
    }
    return pt;
}

fn leaf_test(s: u32, a: vec3<f32>, b: vec3<f32>, eps: f32, ig0: u32, ig1: u32) -> u32 {
    let kind = slots[s * 16u];
    let prim = slots[s * 16u + 1u];
    let planar = slots[s * 16u + 2u] != 0u;
    let ignored = prim == ig0 || prim == ig1;
    if (ignored && planar) {
        return MISS;
    }
    if (kind == 0u) {
        return convex_test(s, 3u, a, b, eps);
    }
    if (kind == 1u) {
        return convex_test(s, 4u, a, b, eps);
    }
    if (kind == 2u) {
        // Planar region: only a sure miss of its plane is decided here.
        let v0 = point(s, 0u);
        let v1 = point(s, 1u);
        let v2 = point(s, 2u);
        let dil = 1e-8 * f(slots[s * 16u + 3u]);
        let pt = plane_test(v0, v1 - v0, v2 - v0, diff_err(v1, v0) + vec3<f32>(2.0 * dil),
                            diff_err(v2, v0) + vec3<f32>(2.0 * dil), a, b, eps, dil);
        return select(UNSURE, MISS, pt == MISS);
    }
    // Curved: only the CPU decides.
    return UNSURE;
}

fn nbyte(w: u32, k: u32) -> u32 {
    return (w >> (k * 8u)) & 0xffu;
}

// Byte k (0..8) of the 8-byte field starting at word `word` of node `n`.
fn field(n: u32, word: u32, k: u32) -> u32 {
    return nbyte(nodes[n * 20u + word + k / 4u], k % 4u);
}

var<private> state_unsure: bool;
var<private> state_hit: bool;

// Tests the children of node `n` against the segment; leaves are tested at once.
// Returns the mask of hit internal children (by child slot).
fn visit(n: u32, a: vec3<f32>, d: vec3<f32>, b: vec3<f32>, eps: f32, ig0: u32, ig1: u32) -> u32 {
    let base = n * 20u;
    let p = vec3<f32>(f(nodes[base]), f(nodes[base + 1u]), f(nodes[base + 2u]));
    let w3 = nodes[base + 3u];
    let ext = vec3<f32>(f(nbyte(w3, 0u) << 23u), f(nbyte(w3, 1u) << 23u), f(nbyte(w3, 2u) << 23u));
    let imask = nbyte(w3, 3u);
    let prim_base = nodes[base + 5u];
    var inner = 0u;
    for (var k = 0u; k < 8u; k++) {
        let cmeta = field(n, 6u, k);
        if (cmeta == 0u) {
            continue;
        }
        let qlo = vec3<f32>(f32(field(n, 8u, k)), f32(field(n, 12u, k)), f32(field(n, 16u, k)));
        let qhi = vec3<f32>(f32(field(n, 10u, k)), f32(field(n, 14u, k)), f32(field(n, 18u, k)));
        var lo = p + ext * qlo;
        var hi = p + ext * qhi;
        lo = lo - abs(lo) * (4.0 * U) - vec3<f32>(1e-30);
        hi = hi + abs(hi) * (4.0 * U) + vec3<f32>(1e-30);
        // Conservative slab test of the segment a + t d, t ∈ [0, 1].
        var t0 = 0.0;
        var t1 = 1.0;
        var hit = true;
        for (var ax = 0u; ax < 3u; ax++) {
            if (abs(d[ax]) < 1e-30) {
                if (a[ax] < lo[ax] - 1e-29 || a[ax] > hi[ax] + 1e-29) {
                    hit = false;
                }
            } else {
                let inv = 1.0 / d[ax];
                let ta = (lo[ax] - a[ax]) * inv;
                let tb = (hi[ax] - a[ax]) * inv;
                let tn = min(ta, tb);
                let tf = max(ta, tb);
                t0 = max(t0, tn - abs(tn) * 1e-6);
                t1 = min(t1, tf + abs(tf) * 1e-6);
            }
        }
        if (!hit || t0 > t1) {
            continue;
        }
        if ((imask & (1u << k)) != 0u) {
            inner |= 1u << k;
        } else {
            let start = prim_base + (cmeta & 31u);
            let count = countOneBits(cmeta >> 5u);
            for (var j = 0u; j < count; j++) {
                let r = leaf_test(start + j, a, b, eps, ig0, ig1);
                if (r == HIT) {
                    state_hit = true;
                    return 0u;
                }
                if (r == UNSURE) {
                    state_unsure = true;
                }
            }
        }
    }
    return inner;
}

fn child_index(n: u32, k: u32) -> u32 {
    let cmeta = field(n, 6u, k);
    let slot = (cmeta & 31u) - 24u;
    let imask = nbyte(nodes[n * 20u + 3u], 3u);
    return nodes[n * 20u + 4u] + countOneBits(imask & ((1u << slot) - 1u));
}

@compute @workgroup_size(64)
fn occlude(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nw: vec3<u32>) {
    let i = gid.x + gid.y * nw.x * 64u;
    if (i >= P.n) {
        return;
    }
    let qb = i * 12u;
    let a = vec3<f32>(f(queries[qb]), f(queries[qb + 1u]), f(queries[qb + 2u]));
    let eps = f(queries[qb + 3u]);
    let b = vec3<f32>(f(queries[qb + 4u]), f(queries[qb + 5u]), f(queries[qb + 6u]));
    let ig0 = queries[qb + 8u];
    let ig1 = queries[qb + 9u];
    let d = b - a;
    state_unsure = false;
    state_hit = false;
    var stack: array<vec2<u32>, 32>;
    var sp = 0u;
    let root = visit(0u, a, d, b, eps, ig0, ig1);
    if (state_hit) {
        answers[i] = HIT;
        return;
    }
    if (root != 0u) {
        stack[0] = vec2<u32>(0u, root);
        sp = 1u;
    }
    while (sp > 0u) {
        let top = stack[sp - 1u];
        let k = firstTrailingBit(top.y);
        let rest = top.y & (top.y - 1u);
        if (rest == 0u) {
            sp -= 1u;
        } else {
            stack[sp - 1u].y = rest;
        }
        let child = child_index(top.x, k);
        let m = visit(child, a, d, b, eps, ig0, ig1);
        if (state_hit) {
            answers[i] = HIT;
            return;
        }
        if (m != 0u) {
            if (sp == 32u) {
                // Stack full: this subtree is not traversed, so the answer is unsure.
                state_unsure = true;
            } else {
                stack[sp] = vec2<u32>(child, m);
                sp += 1u;
            }
        }
    }
    answers[i] = select(MISS, UNSURE, state_unsure);
}
