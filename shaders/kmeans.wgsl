// GPU K-means with the orientation-thresholded distance of Eq. 7 and the distance-based fuzzy membership
// of Sec. 3.2.2 / Alg. 2 (src/gpu/kmeans.rs drives it; src/cluster/kmeans/ documents the method and is
// its CPU twin). One module, one bind group, several entry points:
//
//   grid_count   one thread per centroid: count the centroids of each grid cell (atomics)
//   grid_scan    one workgroup: exclusive prefix sum of the counts -> cell_start
//   grid_fill    one thread per centroid: write its index into its cell's slice of cell_items
//   assign       one thread per data point: the F nearest centroids by expanding shells of grid cells
//   assign_chunk one thread per data point: exhaustive merge of centroids [chunk_start, + CHUNK)
//   accumulate   one thread per data point: atomic fixed-point sums per cluster, objective partials
//   update       one thread per centroid: centroid = mean of its points, normal = normalised mean
//   fuzzy_weights one thread per data point: Eq. 10 weights of its F clusters
//
// Order of candidates: the key (inadmissible, d^2, index) compared lexicographically, where
// "inadmissible" is Eq. 7's infinite distance (normals differ by more than the threshold). The result
// never depends on the order in which atomics or cells are visited.
//
// Loops per invocation stay far below Mesa 22.3's silent cut at 65,535 iterations: `assign` counts
// every loop iteration and gives up after `params.budget` (<= 24,576), marking the point unresolved so
// that `assign_chunk` (at most CHUNK * (1 + F) = 34,816 iterations per dispatch) finishes it exactly;
// grid_scan loops at most 2 * 1024 + 8 times (<= 2^18 cells).

const WORKGROUP_SIZE: u32 = 256u;
// Largest fuzziness F (mirrors MAX_FUZZY in src/cluster/kmeans/mod.rs).
const MAX_F: u32 = 16u;
// Centroids per assign_chunk dispatch (mirrors CHUNK in src/gpu/kmeans.rs).
const CHUNK: u32 = 2048u;
// Bit of a candidate index marking an inadmissible candidate (Eq. 7: infinite distance).
const INADMISSIBLE: u32 = 0x80000000u;
const INDEX_MASK: u32 = 0x7fffffffu;
// Words per cluster in `sums`: count, then (lo, hi) 64-bit sums of 3 position and 3 normal components.
const SUM_WORDS: u32 = 13u;
// Fixed-point scale of the sums: 2^24 steps over the quantisation range.
const FIXED_SCALE: f32 = 16777216.0;

// Keep in sync with `GpuKMeansParams` in src/gpu/kmeans.rs (112 bytes).
struct Params {
    // Grid origin (xyz) and cubic cell size h (w).
    grid_lo: vec4<f32>,
    // Cells per axis (xyz) and their product (w).
    grid_dims: vec4<u32>,
    // Quantisation origin (xyz): the data's bounding-box minimum.
    quant_lo: vec4<f32>,
    // Quantisation extent (xyz): bounding-box size; an axis of size 0 quantises to 0.
    quant_extent: vec4<f32>,
    // Data points, centroids, fuzziness F, 1 = accelerated by the grid.
    n: u32,
    k: u32,
    f: u32,
    use_grid: u32,
    // 1 = Eq. 7's orientation threshold is on; its cosine.
    has_threshold: u32,
    cos_threshold: f32,
    // First centroid of this assign_chunk dispatch.
    chunk_start: u32,
    // 1 = accumulate adds the fixed-point sums (0: objective only).
    accumulate_sums: u32,
    // Loop-iteration budget of `assign`; shells beyond which no cell exists.
    budget: u32,
    max_shell: u32,
    // Absolute slack of the shell stopping test (float rounding of cell coordinates).
    slack: f32,
    // First point (or centroid) of this dispatch: a kernel over n items runs as several dispatches
    // within the work budget (src/gpu/dispatch.rs), each a whole number of workgroups but the last.
    first_item: u32,
}

// A data point or centroid: position (xyz) then unit normal (xyz) (zero normal when normals are absent).
struct Point {
    p: vec4<f32>,
    n: vec4<f32>,
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> points: array<Point>;
@group(0) @binding(2) var<storage, read_write> centroids: array<Point>;
@group(0) @binding(3) var<storage, read_write> cell_count: array<atomic<u32>>;
@group(0) @binding(4) var<storage, read_write> cell_start: array<u32>;
@group(0) @binding(5) var<storage, read_write> cell_items: array<u32>;
// n * F nearest centroids per point (index | INADMISSIBLE), nearest first, and their squared distances.
@group(0) @binding(6) var<storage, read_write> best_idx: array<u32>;
@group(0) @binding(7) var<storage, read_write> best_d2: array<f32>;
// 1 = `assign` ran out of budget before its shell test proved the list exact.
@group(0) @binding(8) var<storage, read_write> status: array<u32>;
@group(0) @binding(9) var<storage, read_write> sums: array<atomic<u32>>;
// One objective partial sum (f32, workgroup tree reduction) per accumulate workgroup.
@group(0) @binding(10) var<storage, read_write> partials: array<f32>;
@group(0) @binding(11) var<storage, read_write> weights: array<f32>;

var<workgroup> wg_sum: array<f32, WORKGROUP_SIZE>;
var<workgroup> wg_scan: array<u32, WORKGROUP_SIZE>;

fn km_is_nan(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7fffffffu) > 0x7f800000u;
}

fn linear_id(gid: vec3<u32>, nwg: vec3<u32>) -> u32 {
    return params.first_item + gid.x + gid.y * nwg.x * WORKGROUP_SIZE;
}

fn cell_coord(x: vec3<f32>) -> vec3<u32> {
    let h = params.grid_lo.w;
    let c = floor((x - params.grid_lo.xyz) / h);
    let hi = vec3<f32>(params.grid_dims.xyz) - vec3<f32>(1.0);
    return vec3<u32>(clamp(c, vec3<f32>(0.0), hi));
}

fn cell_index(c: vec3<u32>) -> u32 {
    return c.x + params.grid_dims.x * (c.y + params.grid_dims.y * c.z);
}

// Candidate key of centroid c for a point (p, np): index with the INADMISSIBLE bit, squared distance.
fn candidate(c: u32, p: vec3<f32>, np: vec3<f32>) -> vec2<u32> {
    let q = centroids[c];
    let d = p - q.p.xyz;
    var idx = c;
    // A NaN cosine (a degenerate normal) is inadmissible: tested on the bits, since a compiler that
    // assumes no NaN may fold `!(cos > threshold)` into `cos <= threshold`.
    let cos_pq = dot(np, q.n.xyz);
    if params.has_threshold != 0u && (km_is_nan(cos_pq) || cos_pq <= params.cos_threshold) {
        idx = c | INADMISSIBLE;
    }
    return vec2<u32>(idx, bitcast<u32>(dot(d, d)));
}

// a < b in the order (inadmissible, d^2, index).
fn key_less(a: vec2<u32>, b: vec2<u32>) -> bool {
    let fa = a.x >> 31u;
    let fb = b.x >> 31u;
    if fa != fb {
        return fa < fb;
    }
    let da = bitcast<f32>(a.y);
    let db = bitcast<f32>(b.y);
    if da != db {
        return da < db;
    }
    return (a.x & INDEX_MASK) < (b.x & INDEX_MASK);
}

// The sorted list of a point's F best candidates (invocation-private). F = 1 (K-means) keeps its one
// candidate in `best0`, a register: a dynamically indexed private array lives in memory on CPU adapters
// and made the assignment several times slower.
var<private> list: array<vec2<u32>, MAX_F>;
var<private> best0: vec2<u32>;
var<private> found: u32;
var<private> steps: u32;

// Insert a candidate into the list (Alg. 2, lines 9-17); counts its shifts in `steps`.
fn insert(cand: vec2<u32>) {
    let f = params.f;
    if f == 1u {
        if found == 0u || key_less(cand, best0) {
            best0 = cand;
            found = 1u;
        }
        return;
    }
    if found == f && !key_less(cand, list[f - 1u]) {
        return;
    }
    if found < f {
        found = found + 1u;
    }
    var j = found - 1u;
    loop {
        if j == 0u || !key_less(cand, list[j - 1u]) {
            break;
        }
        list[j] = list[j - 1u];
        j = j - 1u;
        steps = steps + 1u;
    }
    list[j] = cand;
}

// The F-th (last) entry of a full list.
fn worst() -> vec2<u32> {
    if params.f == 1u {
        return best0;
    }
    return list[params.f - 1u];
}

fn store_list(i: u32) {
    if params.f == 1u {
        best_idx[i] = best0.x;
        best_d2[i] = bitcast<f32>(best0.y);
        return;
    }
    for (var j = 0u; j < params.f; j = j + 1u) {
        best_idx[i * params.f + j] = list[j].x;
        best_d2[i * params.f + j] = bitcast<f32>(list[j].y);
    }
}

fn load_list(i: u32) {
    let f = params.f;
    found = f;
    if f == 1u {
        best0 = vec2<u32>(best_idx[i], bitcast<u32>(best_d2[i]));
        return;
    }
    for (var j = 0u; j < f; j = j + 1u) {
        list[j] = vec2<u32>(best_idx[i * f + j], bitcast<u32>(best_d2[i * f + j]));
    }
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn grid_count(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let c = linear_id(gid, nwg);
    if c >= params.k {
        return;
    }
    atomicAdd(&cell_count[cell_index(cell_coord(centroids[c].p.xyz))], 1u);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn grid_scan(@builtin(local_invocation_id) lid: vec3<u32>) {
    // Each of the 256 threads owns a run of ceil(G / 256) cells (<= 1024 for G <= 2^18).
    let g = params.grid_dims.w;
    let run = (g + WORKGROUP_SIZE - 1u) / WORKGROUP_SIZE;
    let first = lid.x * run;
    let last = min(first + run, g);
    var total = 0u;
    for (var c = first; c < last; c = c + 1u) {
        total = total + atomicLoad(&cell_count[c]);
    }
    wg_scan[lid.x] = total;
    workgroupBarrier();
    // Hillis-Steele inclusive scan of the run totals.
    for (var s = 1u; s < WORKGROUP_SIZE; s = s * 2u) {
        var v = wg_scan[lid.x];
        if lid.x >= s {
            v = v + wg_scan[lid.x - s];
        }
        workgroupBarrier();
        wg_scan[lid.x] = v;
        workgroupBarrier();
    }
    var offset = wg_scan[lid.x] - total;
    for (var c = first; c < last; c = c + 1u) {
        cell_start[c] = offset;
        offset = offset + atomicLoad(&cell_count[c]);
    }
    if lid.x == WORKGROUP_SIZE - 1u {
        cell_start[g] = wg_scan[lid.x];
    }
}

// Runs after `cell_count` is cleared again: the counts become per-cell cursors.
@compute @workgroup_size(WORKGROUP_SIZE)
fn grid_fill(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let c = linear_id(gid, nwg);
    if c >= params.k {
        return;
    }
    let cell = cell_index(cell_coord(centroids[c].p.xyz));
    let slot = atomicAdd(&cell_count[cell], 1u);
    cell_items[cell_start[cell] + slot] = c;
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn assign(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = linear_id(gid, nwg);
    if i >= params.n {
        return;
    }
    let p = points[i].p.xyz;
    let np = points[i].n.xyz;
    let c0 = vec3<i32>(cell_coord(p));
    let dims = vec3<i32>(params.grid_dims.xyz);
    let h = params.grid_lo.w;
    // Position of p inside its cell, in cells per axis.
    let frac = clamp((p - params.grid_lo.xyz) / h - vec3<f32>(c0), vec3<f32>(0.0), vec3<f32>(1.0));
    let f = params.f;
    let budget = params.budget;
    found = 0u;
    steps = 0u;
    var complete = false;
    // Shell r: the cells at Chebyshev distance r from the point's cell (r = 0, 1 is the paper's 27-cell
    // neighbourhood). Every centroid outside shells 0..r lies beyond a face of their (2r+1)^3 block, so
    // the list is exact once its F-th entry is admissible and closer than the nearest such face.
    var r = 0;
    loop {
        if r > i32(params.max_shell) {
            complete = true;
            break;
        }
        if steps >= budget {
            break;
        }
        steps = steps + 1u;
        let zlo = max(c0.z - r, 0);
        let zhi = min(c0.z + r, dims.z - 1);
        let ylo = max(c0.y - r, 0);
        let yhi = min(c0.y + r, dims.y - 1);
        for (var z = zlo; z <= zhi && steps < budget; z = z + 1) {
            steps = steps + 1u;
            for (var y = ylo; y <= yhi && steps < budget; y = y + 1) {
                steps = steps + 1u;
                let on_face = abs(z - c0.z) == r || abs(y - c0.y) == r;
                // On a face of the shell every x; inside it only x = c0.x - r and c0.x + r.
                var x = c0.x - r;
                var x_end = c0.x + r;
                var x_step = 2 * r;
                if on_face {
                    x = max(c0.x - r, 0);
                    x_end = min(c0.x + r, dims.x - 1);
                    x_step = 1;
                }
                loop {
                    if x > x_end || steps >= budget {
                        break;
                    }
                    steps = steps + 1u;
                    if x >= 0 && x < dims.x {
                        let cell = cell_index(vec3<u32>(u32(x), u32(y), u32(z)));
                        let end = cell_start[cell + 1u];
                        for (var s = cell_start[cell]; s < end && steps < budget; s = s + 1u) {
                            steps = steps + 1u;
                            insert(candidate(cell_items[s], p, np));
                        }
                    }
                    if x_step == 0 {
                        break;
                    }
                    x = x + x_step;
                }
            }
        }
        if steps >= budget {
            break;
        }
        // Distance from p to the nearest face of the block of shells 0..r behind which cells remain
        // (faces on the grid's border hide nothing).
        var bound = 3.0e38;
        for (var a = 0; a < 3; a = a + 1) {
            if c0[a] - r > 0 {
                bound = min(bound, (frac[a] + f32(r)) * h);
            }
            if c0[a] + r < dims[a] - 1 {
                bound = min(bound, (1.0 - frac[a] + f32(r)) * h);
            }
        }
        // The three iterations above count against the budget too.
        steps = steps + 3u;
        if bound == 3.0e38 {
            // Every cell visited: the list is exact.
            complete = true;
            break;
        }
        let last = worst();
        if found == f && (last.x & INADMISSIBLE) == 0u {
            let b = bound - params.slack;
            if b > 0.0 && bitcast<f32>(last.y) < b * b {
                complete = true;
                break;
            }
        }
        r = r + 1;
    }
    store_list(i);
    status[i] = select(1u, 0u, complete);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn assign_chunk(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = linear_id(gid, nwg);
    if i >= params.n {
        return;
    }
    if params.use_grid != 0u && status[i] == 0u {
        return;
    }
    let p = points[i].p.xyz;
    let np = points[i].n.xyz;
    let f = params.f;
    steps = 0u;
    found = 0u;
    if params.chunk_start > 0u {
        // The first chunk held >= F centroids (CHUNK >= MAX_F and F <= k), so the stored list is full.
        load_list(i);
    }
    let end = min(params.chunk_start + CHUNK, params.k);
    for (var c = params.chunk_start; c < end; c = c + 1u) {
        insert(candidate(c, p, np));
    }
    store_list(i);
}

fn add64(word: u32, v: u32) {
    // 64-bit sum in two u32 words: the carry of the low word is counted exactly once.
    let old = atomicAdd(&sums[word], v);
    if old > 0xffffffffu - v {
        atomicAdd(&sums[word + 1u], 1u);
    }
}

// Fixed-point value of x in [lo, lo + extent]: round(2^24 (x - lo) / extent), 0 on a flat axis.
fn quantise(x: vec3<f32>, lo: vec3<f32>, extent: vec3<f32>) -> vec3<u32> {
    var u = vec3<f32>(0.0);
    for (var a = 0; a < 3; a = a + 1) {
        if extent[a] > 0.0 {
            u[a] = clamp((x[a] - lo[a]) / extent[a], 0.0, 1.0);
        }
    }
    return vec3<u32>(floor(u * FIXED_SCALE + vec3<f32>(0.5)));
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn accumulate(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_id) lid: vec3<u32>,
    @builtin(workgroup_id) wid: vec3<u32>,
) {
    let i = linear_id(gid, nwg);
    var d2 = 0.0;
    if i < params.n {
        let a = best_idx[i * params.f] & INDEX_MASK;
        d2 = best_d2[i * params.f];
        if params.accumulate_sums != 0u {
            let base = a * SUM_WORDS;
            atomicAdd(&sums[base], 1u);
            let qp = quantise(points[i].p.xyz, params.quant_lo.xyz, params.quant_extent.xyz);
            let qn = quantise(points[i].n.xyz, vec3<f32>(-1.0), vec3<f32>(2.0));
            for (var a3 = 0u; a3 < 3u; a3 = a3 + 1u) {
                add64(base + 1u + 2u * a3, qp[a3]);
                add64(base + 7u + 2u * a3, qn[a3]);
            }
        }
    }
    // Objective: per-workgroup tree sum of d^2 (the host adds the partials in f64).
    wg_sum[lid.x] = d2;
    workgroupBarrier();
    for (var s = WORKGROUP_SIZE / 2u; s > 0u; s = s / 2u) {
        if lid.x < s {
            wg_sum[lid.x] = wg_sum[lid.x] + wg_sum[lid.x + s];
        }
        workgroupBarrier();
    }
    // The dispatches' workgroups tile the points in order: workgroup w of the whole pass owns slot w.
    if lid.x == 0u {
        partials[params.first_item / WORKGROUP_SIZE + wid.x + wid.y * nwg.x] = wg_sum[0];
    }
}

fn mean64(word: u32, count: f32) -> f32 {
    let lo = atomicLoad(&sums[word]);
    let hi = atomicLoad(&sums[word + 1u]);
    return (f32(hi) * 4294967296.0 + f32(lo)) / count / FIXED_SCALE;
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn update(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let c = linear_id(gid, nwg);
    if c >= params.k {
        return;
    }
    let base = c * SUM_WORDS;
    let count = atomicLoad(&sums[base]);
    // An empty cluster keeps its centroid.
    if count == 0u {
        return;
    }
    let fc = f32(count);
    var u = vec3<f32>(0.0);
    var m = vec3<f32>(0.0);
    for (var a = 0u; a < 3u; a = a + 1u) {
        u[a] = mean64(base + 1u + 2u * a, fc);
        m[a] = mean64(base + 7u + 2u * a, fc) * 2.0 - 1.0;
    }
    centroids[c].p = vec4<f32>(params.quant_lo.xyz + u * params.quant_extent.xyz, 0.0);
    // Mean normal, normalised; members whose normals cancel keep the previous centroid normal.
    let len = length(m);
    if len > 1e-6 {
        centroids[c].n = vec4<f32>(m / len, 0.0);
    }
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn fuzzy_weights(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = linear_id(gid, nwg);
    if i >= params.n {
        return;
    }
    let f = params.f;
    let b = i * f;
    // Eq. 10 over the admissible clusters (1/inf = 0 for the others); all of them when none is.
    let any_admissible = (best_idx[b] & INADMISSIBLE) == 0u;
    var zeros = 0u;
    var n_used = 0u;
    var total = 0.0;
    for (var j = 0u; j < f; j = j + 1u) {
        let used = !any_admissible || (best_idx[b + j] & INADMISSIBLE) == 0u;
        if used {
            n_used = n_used + 1u;
            let d2 = best_d2[b + j];
            if d2 == 0.0 {
                zeros = zeros + 1u;
            } else {
                total = total + 1.0 / sqrt(d2);
            }
        }
    }
    for (var j = 0u; j < f; j = j + 1u) {
        let used = !any_admissible || (best_idx[b + j] & INADMISSIBLE) == 0u;
        let d2 = best_d2[b + j];
        var w = 0.0;
        if used {
            if zeros > 0u {
                w = select(0.0, 1.0 / f32(zeros), d2 == 0.0);
            } else if n_used == 1u {
                // Exactly 1: hardware division and sqrt are approximate (WGSL allows 2.5 ULP), x / x need not be 1.
                w = 1.0;
            } else {
                w = (1.0 / sqrt(d2)) / total;
            }
        }
        weights[b + j] = w;
    }
}
