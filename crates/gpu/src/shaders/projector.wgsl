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
    p0: u32,
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
    idx: vec3<i32>,
    entry: u32,
}

fn start_voxel(o: vec3<f32>, d: vec3<f32>) -> vec3<i32> {
    var idx: vec3<i32>;
    for (var a = 0; a < 3; a = a + 1) {
        let f = floor(o[a]);
        if (o[a] == f && d[a] < 0.0) {
            idx[a] = i32(f) - 1;
        } else {
            idx[a] = i32(f);
        }
    }
    return idx;
}

fn face_ray(lo: vec3<i32>, size: i32, face: u32, d: vec3<f32>) -> Ray {
    let axis = i32(face / 2u);
    let negative = (face % 2u) == 1u;
    var o = vec3<f32>(lo) + 0.5 * f32(size);
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
    return Ray(o, d, 0.0, idx, face ^ 1u);
}

fn centre_ray(lo: vec3<i32>, size: i32, d: vec3<f32>) -> Ray {
    let o = vec3<f32>(lo) + 0.5 * f32(size);
    let hi = lo + vec3<i32>(size);
    var ta = vec3<f32>(BIG);
    var te = BIG;
    for (var a = 0; a < 3; a = a + 1) {
        if (d[a] > 0.0) {
            ta[a] = (f32(hi[a]) - o[a]) / d[a];
        } else if (d[a] < 0.0) {
            ta[a] = (f32(lo[a]) - o[a]) / d[a];
        }
        te = min(te, ta[a]);
    }
    var step = 2;
    if (ta.x == te) {
        step = 0;
    } else if (ta.y == te) {
        step = 1;
    }
    var idx: vec3<i32>;
    for (var a = 0; a < 3; a = a + 1) {
        if (a == step) {
            if (d[a] > 0.0) {
                idx[a] = hi[a];
            } else {
                idx[a] = lo[a] - 1;
            }
        } else {
            idx[a] = clamp(i32(floor(o[a] + te * d[a])), lo[a], hi[a] - 1);
        }
    }
    // The ray enters the next cell through its face opposite to the direction.
    var entry = 2u * u32(step);
    if (d[step] > 0.0) {
        entry = entry + 1u;
    }
    return Ray(o, d, te, idx, entry);
}

// Front-to-back compositing along `ray` (the CPU projector's `trace`, exact cells).
fn trace(ray: Ray) -> vec3<f32> {
    let n = params.side;
    let o = ray.o;
    let d = ray.d;
    var t = ray.t;
    var idx = ray.idx;
    var entry = ray.entry;
    var inv = vec3<f32>(0.0);
    for (var a = 0; a < 3; a = a + 1) {
        if (d[a] != 0.0) {
            inv[a] = 1.0 / d[a];
        }
    }
    var rad = vec3<f32>(0.0);
    var trans = 1.0;
    loop {
        if (any(idx < vec3<i32>(0)) || any(idx >= vec3<i32>(n))) {
            break;
        }
        let lin = u32(idx.x + n * (idx.y + n * idx.z));
        let ci = cmap[lin];
        let c = cells[ci];
        let lo = vec3<i32>(c.o);
        let hi = lo + vec3<i32>(i32(c.size));
        var ta = vec3<f32>(BIG);
        var te = BIG;
        for (var a = 0; a < 3; a = a + 1) {
            if (d[a] > 0.0) {
                ta[a] = (f32(hi[a]) - o[a]) * inv[a];
            } else if (d[a] < 0.0) {
                ta[a] = (f32(lo[a]) - o[a]) * inv[a];
            }
            te = min(te, ta[a]);
        }
        let len = max(te - t, 0.0);
        let eb = ci * 18u + entry * 3u;
        let e = vec3<f32>(emis[eb], emis[eb + 1u], emis[eb + 2u]);
        steps = steps + 1u;
        if (c.ext != 0.0) {
            var tr = 0.0;
            var alpha = 1.0;
            if (c.ext > 0.0) {
                let x = c.ext * len;
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
        var step = 2;
        if (ta.x == te) {
            step = 0;
        } else if (ta.y == te) {
            step = 1;
        }
        for (var a = 0; a < 3; a = a + 1) {
            if (a == step) {
                if (d[a] > 0.0) {
                    idx[a] = hi[a];
                } else {
                    idx[a] = lo[a] - 1;
                }
            } else {
                idx[a] = clamp(i32(floor(o[a] + te * d[a])), lo[a], hi[a] - 1);
            }
        }
        entry = 2u * u32(step);
        if (d[step] > 0.0) {
            entry = entry + 1u;
        }
        t = te;
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
    if (job.flags == 1u) {
        for (var k = 0; k < 3; k = k + 1) {
            rad[k] = vec3<f32>(0.0);
            if (w[k] > 0.0) {
                rad[k] = trace(face_ray(job.lo, job.size, ent[k], px.dir));
            }
        }
    } else {
        let r = trace(centre_ray(job.lo, job.size, px.dir));
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
    let r = trace(face_ray(job.lo, 1, face, px.dir));
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
