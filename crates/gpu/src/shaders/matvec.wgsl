// Matrix-vector products on power-of-two-scaled f32 values with compensated (TwoSum)
// sums in a fixed order (see matvec.rs for the contract and the error bound).

struct Params {
    // Block rows (bsr) in this chunk.
    nbr: u32,
    // Block size.
    r: u32,
    c: u32,
    // Interleaved right-hand sides (1..4).
    k: u32,
    // Rows and columns (dense) of this chunk.
    nrows: u32,
    ncols: u32,
    pad0: u32,
    pad1: u32,
}

@group(0) @binding(0) var<uniform> P: Params;
@group(0) @binding(1) var<storage, read> row_ptr: array<u32>;
@group(0) @binding(2) var<storage, read> col_idx: array<u32>;
@group(0) @binding(3) var<storage, read> vals: array<f32>;
@group(0) @binding(4) var<storage, read> x: array<f32>;
@group(0) @binding(5) var<storage, read_write> y: array<vec2<f32>>;

// Knuth's TwoSum: s + e == a + b exactly (no multiplication, so no FMA contraction).
fn two_sum(a: f32, b: f32) -> vec2<f32> {
    let s = a + b;
    let bp = s - a;
    let e = (a - (s - bp)) + (b - bp);
    return vec2<f32>(s, e);
}

// One workgroup per block row; invocation (i, l) sums row i of the block row for
// right-hand side l over the blocks in storage order, columns in order.
@compute @workgroup_size(64)
fn bsr(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) lane: u32) {
    let br = wg.x + wg.y * 65535u;
    if (br >= P.nbr) {
        return;
    }
    let i = lane / P.k;
    let l = lane % P.k;
    if (i >= P.r) {
        return;
    }
    var s = 0.0;
    var comp = 0.0;
    let rc = P.r * P.c;
    let end = row_ptr[br + 1u];
    for (var b = row_ptr[br]; b < end; b++) {
        let base = b * rc + i * P.c;
        let xb = col_idx[b] * P.c;
        for (var j = 0u; j < P.c; j++) {
            let p = vals[base + j] * x[(xb + j) * P.k + l];
            let t = two_sum(s, p);
            s = t.x;
            comp += t.y;
        }
    }
    y[(br * P.r + i) * P.k + l] = vec2<f32>(s, comp);
}

// One invocation per row, every right-hand side, columns in order.
@compute @workgroup_size(64)
fn dense(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) lane: u32) {
    let row = (wg.x + wg.y * 65535u) * 64u + lane;
    if (row >= P.nrows) {
        return;
    }
    var s = vec4<f32>(0.0);
    var comp = vec4<f32>(0.0);
    let base = row * P.ncols;
    for (var j = 0u; j < P.ncols; j++) {
        let a = vals[base + j];
        for (var l = 0u; l < P.k; l++) {
            let p = a * x[j * P.k + l];
            let t = two_sum(s[l], p);
            s[l] = t.x;
            comp[l] += t.y;
        }
    }
    for (var l = 0u; l < P.k; l++) {
        y[row * P.k + l] = vec2<f32>(s[l], comp[l]);
    }
}
