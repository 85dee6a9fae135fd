// The meshless relighting product i = S·e (wavelux_meshless::backend, Meshless §3.3)
// on the f32 row-block CSC layout of PackedTransfer: one workgroup per block of
// receivers; the workgroup walks the active senders in increasing order and its 64
// invocations split each sender's column (entries of one column have distinct rows,
// so no two invocations touch the same accumulator before the barrier that ends the
// column). Each accumulator is a TwoSum pair (sum, compensation) in f32: the order of
// every addition is fixed, so the same input gives bitwise the same output.

struct Params {
    // Blocks in this chunk.
    blocks: u32,
    // Receivers per block.
    block_rows: u32,
    // Receivers in this chunk.
    rows: u32,
    // Senders (columns).
    cols: u32,
    // Active senders (entries of `active`).
    nactive: u32,
    // Workgroups along x of the dispatch.
    groups_x: u32,
    pad0: u32,
    pad1: u32,
}

@group(0) @binding(0) var<uniform> p: Params;
// Per block of the chunk, cols + 1 offsets into `row`/`val` (relative to the chunk).
@group(0) @binding(1) var<storage, read> col_ptr: array<u32>;
// Receiver of each entry, relative to the chunk's first receiver.
@group(0) @binding(2) var<storage, read> row: array<u32>;
// Nine scaled values per entry, channel-major [r.xyz, g.xyz, b.xyz].
@group(0) @binding(3) var<storage, read> val: array<f32>;
// Three scaled values per sender (RGB).
@group(0) @binding(4) var<storage, read> e: array<f32>;
// The active senders, increasing.
@group(0) @binding(5) var<storage, read> senders: array<u32>;
// Eighteen words per receiver of the chunk: nine sums, then nine compensations.
@group(0) @binding(6) var<storage, read_write> acc: array<f32>;

const WG: u32 = 64u;

@compute @workgroup_size(64)
fn main(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let b = wid.x + wid.y * p.groups_x;
    if (b >= p.blocks) {
        return;
    }
    let lo = b * p.block_rows;
    let n = min(p.block_rows, p.rows - lo);
    for (var q = lid; q < n * 18u; q += WG) {
        acc[lo * 18u + q] = 0.0;
    }
    storageBarrier();
    let base = b * (p.cols + 1u);
    for (var k = 0u; k < p.nactive; k++) {
        let j = senders[k];
        let s = col_ptr[base + j];
        let t = col_ptr[base + j + 1u];
        let ej = vec3<f32>(e[3u * j], e[3u * j + 1u], e[3u * j + 2u]);
        for (var q = s + lid; q < t; q += WG) {
            let r = row[q] * 18u;
            for (var c = 0u; c < 3u; c++) {
                for (var a = 0u; a < 3u; a++) {
                    let i = r + c * 3u + a;
                    let term = val[q * 9u + c * 3u + a] * ej[c];
                    // TwoSum (Knuth): sum + err == acc + term exactly.
                    let s0 = acc[i];
                    let sum = s0 + term;
                    let bv = sum - s0;
                    let err = (s0 - (sum - bv)) + (term - bv);
                    acc[i] = sum;
                    acc[i + 9u] = acc[i + 9u] + err;
                }
            }
        }
        storageBarrier();
    }
}
