// The global cube's projection (GlobalCube §3.1) on the GPU: see src/projector.rs for
// the method, the data layout and the error bound. One workgroup per job (a receiving
// cell, or a boundary voxel for the escape sum); its invocations stride over the
// 6 N² pixels of the cube map, trace each pixel's ray cell by cell exactly as the CPU
// projector does (in f32), accumulate per entry face and channel with TwoSum, and
// reduce the workgroup in a fixed tree order (deterministic, no atomics).

struct Params {
    jobs: u32,
    side: i32,
    voxel: f32,
    min_trans: f32,
    // 0: gather, 1: escape.
    mode: u32,
    // Receiver samples per axis (a power of two; 1 for the escape).
    samples: u32,
    p1: u32,
    p2: u32,
}

struct Cell {
    o: vec3<u32>,
    size: u32,
    // Extinction per voxel edge; negative: opaque.
    ext: f32,
    q0: u32,
    q1: u32,
    q2: u32,
}

struct Pixel {
    dir: vec3<f32>,
    solid_angle: f32,
    // Entry faces of the three axes, 8 bits each.
    entry: u32,
    // The CPU's f64 |1/dir| per axis: high and low words of its bits.
    ih0: u32,
    ih1: u32,
    ih2: u32,
    il0: u32,
    il1: u32,
    il2: u32,
    // The CPU's f64 |dir| per axis: high and low words of its bits.
    dh0: u32,
    dh1: u32,
    dh2: u32,
    dl0: u32,
    dl1: u32,
    dl2: u32,
    q0: u32,
    q1: u32,
    q2: u32,
}

struct Job {
    // Minimum corner (voxels) and edge of the receiving box.
    lo: vec3<i32>,
    size: i32,
    // Gather: first weight of the job's table (floats). Escape: the inward face.
    table: u32,
    // First pixel of the job's cube map and its pixel count.
    pix: u32,
    npix: u32,
    // Gather: 1 if every entry face sends its own ray.
    flags: u32,
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> cells: array<Cell>;
@group(0) @binding(2) var<storage, read> cmap: array<u32>;
@group(0) @binding(3) var<storage, read> emis: array<f32>;
@group(0) @binding(4) var<storage, read> pixels: array<Pixel>;
@group(0) @binding(5) var<storage, read> weights: array<f32>;
@group(0) @binding(6) var<storage, read> jobs: array<Job>;
@group(0) @binding(7) var<storage, read_write> outp: array<u32>;

const WG: u32 = 64u;
const BIG: f32 = 3.0e38;
// Per job: 18 sums, 18 compensations, the composited-cell count.
const OUT_STRIDE: u32 = 37u;

var<private> steps: u32;
// Receiver samples per axis k (a power of two) and log2(2k): ray origins are
// multiples of 1/(2k) voxel, so 2k·o is an integer.
var<private> samples: u32;
var<private> lk: u32;

// 1 − e^{−x} without cancellation for small x (Horner; degree 12 at x < 0.5 leaves a
// relative truncation error below 0.5¹²/13! ≈ 4e-14).
fn one_minus_exp(x: f32) -> f32 {
    if (x < 0.5) {
        var s = 1.0;
        for (var k = 12; k >= 2; k = k - 1) {
            s = 1.0 - x * s / f32(k);
        }
        return x * s;
    }
    return 1.0 - exp(-x);
}

struct Ray {
    o: vec3<f32>,
    d: vec3<f32>,
    t: f32,
    // The first voxel crossed (unused when `inside` is 1).
    idx: vec3<i32>,
    // Entry weight per axis (the CPU's `entry`): the ray enters a cell through the face
    // of axis a it meets moving along d with weight entry[a]; they sum to 1.
    entry: vec3<f32>,
    // 1: the ray starts inside the box (ilo, isize), which contributes nothing and is
    // left by the same crossing rule as every other cell.
    inside: u32,
    ilo: vec3<i32>,
    isize: i32,
    // The f64 |1/d| per axis (bits: high, low words), for `crossing_key`.
    ih: vec3<u32>,
    il: vec3<u32>,
    // The f64 |d| per axis (bits: high, low words), for `exit_voxel`.
    dh: vec3<u32>,
    dl: vec3<u32>,
}

// The CPU's crossing distance |b − o|·|1/d| rounded to f64 (round to nearest even), as
// an order-preserving key (exponent, significand bits 52..32, bits 31..0). `h2` is
// 2k|b − o|, an integer below 2¹⁶ (ray origins are multiples of 1/(2k) voxel; the host
// checks the bound); (ih, il) are the bits of the f64 |1/d|. The product of h2 and
// the 53-bit significand is formed exactly in 16-bit limbs (below 2⁶⁹, every limb
// product and carry below 2³²), then rounded to 53 bits; the common factor 1/(2k) and
// the exponent bias do not change the order.
fn crossing_key(h2: u32, ih: u32, il: u32) -> vec3<u32> {
    let e = (ih >> 20u) & 0x7FFu;
    let mh = (ih & 0xFFFFFu) | 0x100000u;
    let p0 = h2 * (il & 0xFFFFu);
    let p1 = h2 * (il >> 16u) + (p0 >> 16u);
    let p2 = h2 * (mh & 0xFFFFu) + (p1 >> 16u);
    let p3 = h2 * (mh >> 16u) + (p2 >> 16u);
    let lo = (p0 & 0xFFFFu) | (p1 << 16u);
    let mid = (p2 & 0xFFFFu) | (p3 << 16u);
    let top = p3 >> 16u;
    // Bits of the product (at least 53: h2 ≥ 1, the significand ≥ 2⁵²).
    var nb = 64u - countLeadingZeros(mid);
    if (top > 0u) {
        nb = 96u - countLeadingZeros(top);
    }
    var s = nb - 53u;
    if (s == 0u) {
        return vec3<u32>(e, mid, lo);
    }
    var qlo = (lo >> s) | (mid << (32u - s));
    var qhi = (mid >> s) | (top << (32u - s));
    let rem = lo & ((1u << s) - 1u);
    let half = 1u << (s - 1u);
    if (rem > half || (rem == half && (qlo & 1u) == 1u)) {
        qlo = qlo + 1u;
        if (qlo == 0u) {
            qhi = qhi + 1u;
        }
        if (qhi == 0x200000u) {
            qhi = 0x100000u;
            s = s + 1u;
        }
    }
    return vec3<u32>(e + s, qhi, qlo);
}

// 16-bit limbs of a 53-bit significand given as bits 52..32 and 31..0.
fn limbs4(hi: u32, lo: u32) -> array<u32, 4> {
    return array<u32, 4>(lo & 0xFFFFu, lo >> 16u, hi & 0xFFFFu, hi >> 16u);
}

// 32 bits of the 16-bit-limb number p starting at bit `start`.
fn bits32(p: array<u32, 8>, start: u32) -> u32 {
    var q = p;
    let i = start / 16u;
    let off = i32(start % 16u);
    var v = 0u;
    for (var k = 0u; k < 3u; k = k + 1u) {
        let li = i + k;
        if (li < 8u) {
            let sh = 16 * i32(k) - off;
            if (sh >= 0) {
                if (sh < 32) {
                    v = v | (q[li] << u32(sh));
                }
            } else {
                v = v | (q[li] >> u32(-sh));
            }
        }
    }
    return v;
}

// The voxel the CPU's exit point names along a non-tied axis: voxel_coordinate of the
// f64 value o + te·d, where te is the f64 crossing distance (`tk`, a crossing_key),
// (dh, dl) the bits of the f64 |d| (d ≠ 0, sign `dneg`), o2 = 2k·o (an integer) and xf
// the same value in f32. Away from integers (more than 1e-3, far above the f32 and
// f64 errors at coordinates ≤ 1024) the f32 value names the same voxel. Near an
// integer n the f64 value is formed exactly: te·|d| as a 106-bit integer product of
// the significands rounded to nearest even at 53 bits (the CPU's multiplication),
// then its difference z with n − o exactly in 64-bit integers; the CPU's sum rounds
// to n itself iff |z| is at most half the spacing of doubles at n (n has an even
// significand, so a tie goes to n).
fn exit_voxel(xf: f32, o2: i32, dneg: bool, tk: vec3<u32>, dh: u32, dl: u32) -> i32 {
    var dir = 1.0;
    if (dneg) {
        dir = -1.0;
    }
    let n = i32(round(xf));
    if (abs(xf - f32(n)) > 1.0e-3) {
        return voxel_coordinate(xf, dir);
    }
    var a = limbs4(tk.y, tk.z);
    var b = limbs4((dh & 0xFFFFFu) | 0x100000u, dl);
    var p: array<u32, 8>;
    var carry = 0u;
    for (var k = 0; k < 8; k = k + 1) {
        var slo = carry;
        var shi = 0u;
        for (var i = 0; i < 4; i = i + 1) {
            let j = k - i;
            if (j >= 0 && j < 4) {
                let m = a[i] * b[j];
                slo = slo + (m & 0xFFFFu);
                shi = shi + (m >> 16u);
            }
        }
        p[k] = slo & 0xFFFFu;
        carry = (slo >> 16u) + shi;
    }
    // Both significands lie in [2⁵², 2⁵³): the product has 105 or 106 bits.
    var s = 52u;
    if ((p[6] >> 9u) != 0u) {
        s = 53u;
    }
    var qlo = bits32(p, s);
    var qhi = bits32(p, s + 32u) & 0x1FFFFFu;
    let hb = s - 1u;
    let half = (p[hb / 16u] >> (hb % 16u)) & 1u;
    var sticky = (p[hb / 16u] & ((1u << (hb % 16u)) - 1u)) != 0u;
    for (var i = 0u; i < hb / 16u; i = i + 1u) {
        sticky = sticky || p[i] != 0u;
    }
    if (half == 1u && (sticky || (qlo & 1u) == 1u)) {
        qlo = qlo + 1u;
        if (qlo == 0u) {
            qhi = qhi + 1u;
        }
        if (qhi == 0x200000u) {
            qhi = 0x100000u;
            s = s + 1u;
        }
    }
    // te·|d| rounded = Q·2^x.
    let x = (i32(tk.x) - 1075 - i32(lk)) + (i32((dh >> 20u) & 0x7FFu) - 1075) + i32(s);
    // z = (o + sign·te|d|) − n = sign·Q·2^x − c with c = (2k·n − o2)/2k.
    let c2 = i32(2u * samples) * n - o2;
    var zpos: bool;
    var dhi: u32;
    var dlo: u32;
    if (c2 == 0) {
        zpos = !dneg;
        dhi = qhi;
        dlo = qlo;
    } else {
        if ((c2 > 0) == dneg) {
            return voxel_coordinate(xf, dir);
        }
        // |c| in units of 2^x (about 2⁵³: |c| ≈ te·|d|), as a 64-bit integer.
        let sh = -i32(lk) - x;
        let m = u32(abs(c2));
        if (sh < 0 || sh + 32 - i32(countLeadingZeros(m)) > 64) {
            return voxel_coordinate(xf, dir);
        }
        var chi = 0u;
        var clo = 0u;
        if (sh >= 32) {
            chi = m << u32(sh - 32);
        } else if (sh > 0) {
            clo = m << u32(sh);
            chi = m >> u32(32 - sh);
        } else {
            clo = m;
        }
        let q_ge = qhi > chi || (qhi == chi && qlo >= clo);
        if (q_ge) {
            dlo = qlo - clo;
            dhi = qhi - chi - select(0u, 1u, qlo < clo);
            zpos = !dneg;
        } else {
            dlo = clo - qlo;
            dhi = chi - qhi - select(0u, 1u, clo < qlo);
            zpos = dneg;
        }
    }
    var on_n = dhi == 0u && dlo == 0u;
    if (!on_n && n != 0) {
        let an = u32(abs(n));
        let kk = 31 - i32(countLeadingZeros(an));
        var t = kk - 53 - x;
        // Below a power of two (moving toward zero) the spacing halves.
        if ((an & (an - 1u)) == 0u && (zpos != (n > 0))) {
            t = t - 1;
        }
        if (t >= 64) {
            on_n = true;
        } else if (t >= 32) {
            let lim = 1u << u32(t - 32);
            on_n = dhi < lim || (dhi == lim && dlo == 0u);
        } else if (t >= 0) {
            let lim = 1u << u32(t);
            on_n = dhi == 0u && dlo <= lim;
        }
    }
    if (on_n) {
        if (dneg) {
            return n - 1;
        }
        return n;
    }
    if (zpos) {
        return n;
    }
    return n - 1;
}

fn key_less(a: vec3<u32>, b: vec3<u32>) -> bool {
    if (a.x != b.x) {
        return a.x < b.x;
    }
    if (a.y != b.y) {
        return a.y < b.y;
    }
    return a.z < b.z;
}

// The voxel coordinate of x for a ray moving with component d: a position on a voxel
// boundary goes to the side the ray moves to.
fn voxel_coordinate(x: f32, d: f32) -> i32 {
    let f = floor(x);
    if (x == f && d < 0.0) {
        return i32(f) - 1;
    }
    return i32(f);
}

fn start_voxel(o: vec3<f32>, d: vec3<f32>) -> vec3<i32> {
    return vec3<i32>(voxel_coordinate(o.x, d.x), voxel_coordinate(o.y, d.y),
                     voxel_coordinate(o.z, d.z));
}

fn unit_entry(a: i32) -> vec3<f32> {
    var e = vec3<f32>(0.0);
    e[a] = 1.0;
    return e;
}

fn inv_hi(px: Pixel) -> vec3<u32> {
    return vec3<u32>(px.ih0, px.ih1, px.ih2);
}

fn inv_lo(px: Pixel) -> vec3<u32> {
    return vec3<u32>(px.il0, px.il1, px.il2);
}

// The ray from the point of face `face` of the box [lo, lo + size) at fractions `at`
// of the side along the face's two tangent axes (the next axes cyclically), along d.
fn face_ray(lo: vec3<i32>, size: i32, face: u32, px: Pixel, at: vec2<f32>) -> Ray {
    let d = px.dir;
    let axis = i32(face / 2u);
    let negative = (face % 2u) == 1u;
    var o = vec3<f32>(lo);
    o[(axis + 1) % 3] = o[(axis + 1) % 3] + at.x * f32(size);
    o[(axis + 2) % 3] = o[(axis + 2) % 3] + at.y * f32(size);
    if (negative) {
        o[axis] = f32(lo[axis]);
    } else {
        o[axis] = f32(lo[axis] + size);
    }
    var idx = start_voxel(o, d);
    if (negative) {
        idx[axis] = lo[axis] - 1;
    } else {
        idx[axis] = lo[axis] + size;
    }
    return Ray(o, d, 0.0, idx, unit_entry(axis), 0u, lo, size, inv_hi(px), inv_lo(px), vec3<u32>(px.dh0, px.dh1, px.dh2),
               vec3<u32>(px.dl0, px.dl1, px.dl2));
}

// The ray from the point at fractions `at` of the box's side along d, started inside
// it.
fn box_ray(lo: vec3<i32>, size: i32, px: Pixel, at: vec3<f32>) -> Ray {
    let d = px.dir;
    let o = vec3<f32>(lo) + at * f32(size);
    return Ray(o, d, 0.0, lo, unit_entry(0), 1u, lo, size, inv_hi(px), inv_lo(px), vec3<u32>(px.dh0, px.dh1, px.dh2),
               vec3<u32>(px.dl0, px.dl1, px.dl2));
}

// The active cell containing voxel idx, or -1 outside the grid.
fn cell_at(idx: vec3<i32>) -> i32 {
    let n = params.side;
    if (any(idx < vec3<i32>(0)) || any(idx >= vec3<i32>(n))) {
        return -1;
    }
    return i32(cmap[u32(idx.x + n * (idx.y + n * idx.z))]);
}

// The emission a ray entering cell ci with entry weights `entry` along d sees.
fn emission_of(ci: u32, entry: vec3<f32>, d: vec3<f32>) -> vec3<f32> {
    var e = vec3<f32>(0.0);
    for (var a = 0; a < 3; a = a + 1) {
        if (entry[a] != 0.0) {
            var f = 2u * u32(a);
            if (d[a] > 0.0) {
                f = f + 1u;
            }
            let b = ci * 18u + f * 3u;
            e = e + entry[a] * vec3<f32>(emis[b], emis[b + 1u], emis[b + 2u]);
        }
    }
    return e;
}

// Front-to-back compositing along `ray` (the CPU projector's `trace`, exact cells),
// with its crossing rule: where a ray leaves a box across two or three faces at once
// (an exact edge or corner crossing), the crossing is the mean over every order of
// stepping across the tied axes; in each order an opaque cell beside the edge stops
// the ray (contributing its emission), the fraction of orders that pass multiplies
// the transmittance, and the ray enters the cell beyond through the mixture of faces
// the passing orders end on.
fn trace(ray: Ray) -> vec3<f32> {
    let o = ray.o;
    let d = ray.d;
    var t = ray.t;
    var idx = ray.idx;
    var entry = ray.entry;
    var inside = ray.inside;
    var inv = vec3<f32>(0.0);
    for (var a = 0; a < 3; a = a + 1) {
        if (d[a] != 0.0) {
            inv[a] = 1.0 / d[a];
        }
    }
    var rad = vec3<f32>(0.0);
    var trans = 1.0;
    loop {
        var lo: vec3<i32>;
        var size: i32;
        var ext = 0.0;
        var ci = 0u;
        let contributes = inside == 0u;
        if (inside == 1u) {
            lo = ray.ilo;
            size = ray.isize;
            inside = 0u;
        } else {
            let c = cell_at(idx);
            if (c < 0) {
                break;
            }
            ci = u32(c);
            let cell = cells[ci];
            lo = vec3<i32>(cell.o);
            size = i32(cell.size);
            ext = cell.ext;
        }
        let hi = lo + vec3<i32>(size);
        // Crossing distances: in f32 for the chord, and which planes the ray meets
        // first (and which at once) decided on the CPU's f64 values.
        var ta = vec3<f32>(BIG);
        var keys: array<vec3<u32>, 3>;
        var first = -1;
        for (var a = 0; a < 3; a = a + 1) {
            if (d[a] != 0.0) {
                var b = lo[a];
                if (d[a] > 0.0) {
                    b = hi[a];
                }
                ta[a] = (f32(b) - o[a]) * inv[a];
                let k2 = i32(2u * samples);
                let h = u32(abs(k2 * b - i32(round(f32(k2) * o[a]))));
                keys[a] = crossing_key(h, ray.ih[a], ray.il[a]);
                if (first < 0 || key_less(keys[a], keys[first])) {
                    first = a;
                }
            }
        }
        // The chord ends at the f32 distance of the nearest plane (the least of the
        // tied ones, so that it does not depend on how the axes are labelled).
        var te = BIG;
        for (var a = 0; a < 3; a = a + 1) {
            if (first >= 0 && d[a] != 0.0 && all(keys[a] == keys[first])) {
                te = min(te, ta[a]);
            }
        }
        if (contributes) {
            let len = max(te - t, 0.0);
            let e = emission_of(ci, entry, d);
            steps = steps + 1u;
            if (ext != 0.0) {
                var tr = 0.0;
                var alpha = 1.0;
                if (ext > 0.0) {
                    let x = ext * len;
                    alpha = one_minus_exp(x);
                    tr = exp(-x);
                }
                rad = rad + (trans * alpha) * e;
                trans = trans * tr;
                if (trans < params.min_trans) {
                    break;
                }
            } else {
                rad = rad + (trans * len * params.voxel) * e;
            }
        }
        if (te >= BIG) {
            break;
        }
        // The voxel beside the exit point inside the box, and the one across each
        // exit face.
        var base: vec3<i32>;
        var stepped = vec3<i32>(0);
        var tied = array<i32, 3>(0, 0, 0);
        var n_tied = 0;
        for (var a = 0; a < 3; a = a + 1) {
            var v = voxel_coordinate(o[a] + te * d[a], d[a]);
            if (d[a] != 0.0 && first >= 0) {
                v = exit_voxel(o[a] + te * d[a], i32(round(f32(2u * samples) * o[a])), d[a] < 0.0, keys[first],
                               ray.dh[a], ray.dl[a]);
            }
            base[a] = clamp(v, lo[a], hi[a] - 1);
            if (d[a] != 0.0 && all(keys[a] == keys[first])) {
                if (d[a] > 0.0) {
                    stepped[a] = hi[a];
                    base[a] = hi[a] - 1;
                } else {
                    stepped[a] = lo[a] - 1;
                    base[a] = lo[a];
                }
                tied[n_tied] = a;
                n_tied = n_tied + 1;
            }
        }
        idx = base;
        for (var k = 0; k < n_tied; k = k + 1) {
            idx[tied[k]] = stepped[tied[k]];
        }
        t = te;
        if (n_tied == 1) {
            entry = unit_entry(tied[0]);
            continue;
        }
        // An exact edge (2 axes) or corner (3 axes) crossing: average the orders, in
        // the CPU's order (edges: ascending, descending; corners: lexicographic).
        let beyond = cell_at(idx);
        var passed = 0;
        var mix = vec3<f32>(0.0);
        var stopped = vec3<f32>(0.0);
        var orders = 2;
        if (n_tied == 3) {
            orders = 6;
        }
        for (var oi = 0; oi < orders; oi = oi + 1) {
            var ord = array<i32, 3>(0, 0, 0);
            if (n_tied == 2) {
                if (oi == 0) {
                    ord[0] = tied[0];
                    ord[1] = tied[1];
                } else {
                    ord[0] = tied[1];
                    ord[1] = tied[0];
                }
            } else {
                // Permutation oi of (0, 1, 2) in lexicographic order.
                let first = oi / 2;
                let r0 = select(0, 1, first == 0);
                let r1 = select(2, 1, first == 2);
                ord[0] = first;
                if (oi % 2 == 0) {
                    ord[1] = r0;
                    ord[2] = r1;
                } else {
                    ord[1] = r1;
                    ord[2] = r0;
                }
            }
            var at = base;
            var last = ord[n_tied - 1];
            var blocked = false;
            for (var k = 0; k < n_tied - 1; k = k + 1) {
                let a = ord[k];
                at[a] = stepped[a];
                let side = cell_at(at);
                if (side < 0) {
                    continue;
                }
                if (beyond >= 0 && side == beyond) {
                    last = a;
                    break;
                }
                if (cells[u32(side)].ext < 0.0) {
                    stopped = stopped + emission_of(u32(side), unit_entry(a), d);
                    steps = steps + 1u;
                    blocked = true;
                    break;
                }
            }
            if (!blocked) {
                passed = passed + 1;
                mix[last] = mix[last] + 1.0;
            }
        }
        rad = rad + trans * stopped / f32(orders);
        trans = trans * f32(passed) / f32(orders);
        if (passed == 0 || trans < params.min_trans) {
            break;
        }
        entry = mix / f32(passed);
    }
    return rad;
}

var<private> acc_s: array<f32, 18>;
var<private> acc_c: array<f32, 18>;

// Knuth's TwoSum: acc += v with the rounding error kept in the compensation.
fn add(i: u32, v: f32) {
    let a = acc_s[i];
    let s = a + v;
    let bb = s - a;
    let err = (a - (s - bb)) + (v - bb);
    acc_s[i] = s;
    acc_c[i] = acc_c[i] + err;
}

var<workgroup> red_s: array<f32, 1152>;
var<workgroup> red_c: array<f32, 1152>;
var<workgroup> red_n: array<u32, 64>;

fn gather_pixel(job: Job, p: u32) {
    let px = pixels[job.pix + p];
    let wb = job.table + 3u * p;
    let w = vec3<f32>(weights[wb], weights[wb + 1u], weights[wb + 2u]);
    if (w.x <= 0.0 && w.y <= 0.0 && w.z <= 0.0) {
        return;
    }
    var ent = array<u32, 3>(px.entry & 255u, (px.entry >> 8u) & 255u, (px.entry >> 16u) & 255u);
    var rad: array<vec3<f32>, 3>;
    let ks = samples;
    let fk = f32(ks);
    if ((job.flags & 1u) == 1u) {
        // k × k points of each entry face (the midpoints of a k × k split).
        let inv = 1.0 / (fk * fk);
        for (var k = 0; k < 3; k = k + 1) {
            rad[k] = vec3<f32>(0.0);
            if (w[k] > 0.0) {
                for (var jb = 0u; jb < ks; jb = jb + 1u) {
                    for (var ja = 0u; ja < ks; ja = ja + 1u) {
                        let at = (vec2<f32>(f32(ja), f32(jb)) + 0.5) / fk;
                        rad[k] = rad[k] + inv * trace(face_ray(job.lo, job.size, ent[k], px, at));
                    }
                }
            }
        }
    } else {
        // k³ points of the cell (the midpoints of a k × k × k split).
        let inv = 1.0 / (fk * fk * fk);
        var r = vec3<f32>(0.0);
        for (var jz = 0u; jz < ks; jz = jz + 1u) {
            for (var jy = 0u; jy < ks; jy = jy + 1u) {
                for (var jx = 0u; jx < ks; jx = jx + 1u) {
                    let at = (vec3<f32>(f32(jx), f32(jy), f32(jz)) + 0.5) / fk;
                    r = r + inv * trace(box_ray(job.lo, job.size, px, at));
                }
            }
        }
        rad[0] = r;
        rad[1] = r;
        rad[2] = r;
    }
    for (var k = 0; k < 3; k = k + 1) {
        for (var ch = 0u; ch < 3u; ch = ch + 1u) {
            add(ent[k] * 3u + ch, w[k] * rad[k][ch]);
        }
    }
}

fn escape_pixel(job: Job, p: u32) {
    let px = pixels[job.pix + p];
    let face = job.table;
    let axis = i32(face / 2u);
    // The inward face of the outside voxel is negative when the boundary is at +side.
    var c = px.dir[axis];
    if ((face % 2u) == 1u) {
        c = -c;
    }
    if (c <= 0.0) {
        return;
    }
    let r = trace(face_ray(job.lo, 1, face, px, vec2<f32>(0.5)));
    for (var ch = 0u; ch < 3u; ch = ch + 1u) {
        add(ch, (px.solid_angle * c) * r[ch]);
    }
}

@compute @workgroup_size(64)
fn main(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
        @builtin(local_invocation_index) lid: u32) {
    let j = wid.x + wid.y * nwg.x;
    for (var i = 0u; i < 18u; i = i + 1u) {
        acc_s[i] = 0.0;
        acc_c[i] = 0.0;
    }
    steps = 0u;
    samples = max(params.samples, 1u);
    lk = 1u + firstTrailingBit(samples);
    if (j < params.jobs) {
        let job = jobs[j];
        for (var p = lid; p < job.npix; p = p + WG) {
            if (params.mode == 0u) {
                gather_pixel(job, p);
            } else {
                escape_pixel(job, p);
            }
        }
    }
    for (var i = 0u; i < 18u; i = i + 1u) {
        red_s[lid * 18u + i] = acc_s[i];
        red_c[lid * 18u + i] = acc_c[i];
    }
    red_n[lid] = steps;
    workgroupBarrier();
    for (var stride = WG / 2u; stride > 0u; stride = stride / 2u) {
        if (lid < stride) {
            let o = lid + stride;
            for (var i = 0u; i < 18u; i = i + 1u) {
                let a = red_s[lid * 18u + i];
                let v = red_s[o * 18u + i];
                let s = a + v;
                let bb = s - a;
                let err = (a - (s - bb)) + (v - bb);
                red_s[lid * 18u + i] = s;
                red_c[lid * 18u + i] = red_c[lid * 18u + i] + red_c[o * 18u + i] + err;
            }
            red_n[lid] = red_n[lid] + red_n[o];
        }
        workgroupBarrier();
    }
    if (lid == 0u && j < params.jobs) {
        for (var i = 0u; i < 18u; i = i + 1u) {
            outp[j * OUT_STRIDE + i] = bitcast<u32>(red_s[i]);
            outp[j * OUT_STRIDE + 18u + i] = bitcast<u32>(red_c[i]);
        }
        outp[j * OUT_STRIDE + 36u] = red_n[0];
    }
}
