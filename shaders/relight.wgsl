// Relighting with a precomputed direct-to-indirect transfer (src/gpu/relight.rs; Hasan, Pellacini, Bala,
// SIGGRAPH 2006, Sec. 3.3, 3.5, 5). The direct light at the gather and view samples comes from the column
// pass (columns.wgsl); these kernels do the rest on GPU-resident buffers:
// - haar_level: one pass of the non-standard orthonormal 2D Haar transform (src/relight/haar.rs, same
//   arithmetic): the current size x size average image `src` -> averages in `dst`, details in `coeffs`
//   (Mallat layout, final positions), and the last average in coeffs[0];
// - cull: transport-weighted on-the-fly culling of wavelet lights (3.5): light j is zeroed when
//   |coeffs[j]| * norms[j] < epsilon; counts non-zero and culled lights;
// - product: per row, sum over a chunk of its sparse coefficients of value * light[index] (CSR rows,
//   one thread per row: a gather, no atomics; <= params.count iterations per invocation, far below Mesa
//   22.3's 65,535-iteration limit);
// - product_rgb: the same over RGB rows (three values per coefficient, row_value[3k .. 3k + 3], each
//   multiplying its channel of the light: the photon-mapped multiple-bounce rows M_E^w);
// - finish_bounce: B_{k+1} = k_d / pi * partial, total += B_{k+1} (the multi-bounce passes);
// - combine: radiance = albedo / pi * partial + direct (a pixel's delta-chain samples summed in), RGB f32;
//   with masks (params.count > num_rows: every view sample has a row, its albedo uploaded times its
//   throughput) the indirect light of the pixel's extra samples is summed in too;
// - combine_glossy: the same plus the glossy final gather, albedo / pi * partial + k_g * partial_glossy +
//   direct (the CPU's order of additions: relight::indirect, glossy::add_glossy).

const WORKGROUP_SIZE: u32 = 64u;
const RELIGHT_INV_PI: f32 = 0.318309886183791;

// Keep in sync with `RelightParams` in src/gpu/relight.rs (32 bytes).
struct RelightParams {
    // Gather image side (haar_level), or wavelet lights (cull), or rows (product, finish_bounce, combine).
    side: u32,
    // haar_level: the current average image's side (a power of 2, >= 2).
    size: u32,
    // Rows of this dispatch (product, finish_bounce, combine) or threads (haar_level, cull).
    num_rows: u32,
    // product: row r of this part is output row row_offset + r.
    row_offset: u32,
    // product: coefficients [first, first + count) of each row are summed by this dispatch.
    first: u32,
    // product: see first; combine: the rows of the sparse products (num_rows, or more with masks: the
    // extra view samples' rows follow the pixels').
    count: u32,
    // Threads per dispatch row (groups_x * WORKGROUP_SIZE); thread t = gid.y * dispatch_width + gid.x.
    dispatch_width: u32,
    // cull: epsilon (>= 0).
    epsilon: f32,
}

@group(0) @binding(0) var<uniform> params: RelightParams;
@group(0) @binding(1) var<storage, read> src: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> dst: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read_write> coeffs: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read> norms: array<f32>;
@group(0) @binding(5) var<storage, read_write> wavelet_lights: array<vec4<f32>>;
// Non-zero wavelet lights, culled ones.
@group(0) @binding(6) var<storage, read_write> counters: array<atomic<u32>, 2>;
@group(0) @binding(7) var<storage, read> row_start: array<u32>;
@group(0) @binding(8) var<storage, read> row_index: array<u32>;
@group(0) @binding(9) var<storage, read> row_value: array<f32>;
@group(0) @binding(10) var<storage, read_write> partial: array<vec4<f32>>;
// Per-row RGB scale before 1 / pi: k_d of the gather image's pixels, or the pixels' diffuse albedo.
@group(0) @binding(11) var<storage, read> albedo: array<vec4<f32>>;
@group(0) @binding(12) var<storage, read_write> total: array<vec4<f32>>;
// Direct light of every view sample (pixels, then delta-chain samples).
@group(0) @binding(13) var<storage, read> direct: array<vec4<f32>>;
// Pixel p's delta-chain samples are width * height + [extra_start[p], extra_start[p + 1]).
@group(0) @binding(14) var<storage, read> extra_start: array<u32>;
@group(0) @binding(15) var<storage, read_write> image: array<f32>;
// The glossy product sum_j F_g^w(i, j) b^w_j per pixel (combine_glossy).
@group(0) @binding(16) var<storage, read> partial_glossy: array<vec4<f32>>;
// k_g per pixel (RGB; 0 for pixels that are not glossy).
@group(0) @binding(17) var<storage, read> glossy_color: array<vec4<f32>>;

fn thread_index(gid: vec3<u32>) -> u32 {
    return gid.y * params.dispatch_width + gid.x;
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn haar_level(@builtin(global_invocation_id) gid: vec3<u32>) {
    let t = thread_index(gid);
    let h = params.size / 2u;
    if t >= h * h {
        return;
    }
    let side = params.side;
    let r = t / h;
    let c = t % h;
    let a = src[(2u * r) * side + 2u * c];
    let b = src[(2u * r) * side + 2u * c + 1u];
    let cl = src[(2u * r + 1u) * side + 2u * c];
    let d = src[(2u * r + 1u) * side + 2u * c + 1u];
    let average = 0.5 * ((a + b) + (cl + d));
    dst[r * side + c] = average;
    coeffs[r * side + c + h] = 0.5 * ((a - b) + (cl - d));
    coeffs[(r + h) * side + c] = 0.5 * ((a + b) - (cl + d));
    coeffs[(r + h) * side + c + h] = 0.5 * ((a - b) - (cl - d));
    if h == 1u {
        coeffs[0] = average;
    }
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn cull(@builtin(global_invocation_id) gid: vec3<u32>) {
    let j = thread_index(gid);
    if j >= params.num_rows {
        return;
    }
    let c = coeffs[j].xyz;
    let keep = sqrt(dot(c, c)) * norms[j] >= params.epsilon;
    wavelet_lights[j] = vec4<f32>(select(vec3<f32>(0.0), c, keep), 0.0);
    if any(c != vec3<f32>(0.0)) {
        atomicAdd(&counters[0], 1u);
        if !keep {
            atomicAdd(&counters[1], 1u);
        }
    }
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn product(@builtin(global_invocation_id) gid: vec3<u32>) {
    let r = thread_index(gid);
    if r >= params.num_rows {
        return;
    }
    let out = params.row_offset + r;
    var s = vec3<f32>(0.0);
    if params.first != 0u {
        s = partial[out].xyz;
    }
    let start = row_start[r] + params.first;
    let end = min(row_start[r + 1u], start + params.count);
    for (var k = start; k < end; k = k + 1u) {
        s = s + row_value[k] * wavelet_lights[row_index[k]].xyz;
    }
    partial[out] = vec4<f32>(s, 0.0);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn product_rgb(@builtin(global_invocation_id) gid: vec3<u32>) {
    let r = thread_index(gid);
    if r >= params.num_rows {
        return;
    }
    let out = params.row_offset + r;
    var s = vec3<f32>(0.0);
    if params.first != 0u {
        s = partial[out].xyz;
    }
    let start = row_start[r] + params.first;
    let end = min(row_start[r + 1u], start + params.count);
    for (var k = start; k < end; k = k + 1u) {
        let v = vec3<f32>(row_value[3u * k], row_value[3u * k + 1u], row_value[3u * k + 2u]);
        s = s + v * wavelet_lights[row_index[k]].xyz;
    }
    partial[out] = vec4<f32>(s, 0.0);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn finish_bounce(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = thread_index(gid);
    if p >= params.num_rows {
        return;
    }
    let b = (albedo[p].xyz * RELIGHT_INV_PI) * partial[p].xyz;
    dst[p] = vec4<f32>(b, 0.0);
    total[p] = vec4<f32>(total[p].xyz + b, 0.0);
}

// Direct light of pixel p: its own view sample plus its delta-chain samples.
fn pixel_direct(p: u32) -> vec3<f32> {
    var d = direct[p].xyz;
    for (var k = extra_start[p]; k < extra_start[p + 1u]; k = k + 1u) {
        d = d + direct[params.num_rows + k].xyz;
    }
    return d;
}

fn write_pixel(p: u32, v: vec3<f32>) {
    image[3u * p] = v.x;
    image[3u * p + 1u] = v.y;
    image[3u * p + 2u] = v.z;
}

// Indirect light of row r (a pixel, or with masks any view sample).
fn row_indirect(r: u32) -> vec3<f32> {
    return (albedo[r].xyz * RELIGHT_INV_PI) * partial[r].xyz;
}

fn row_indirect_glossy(r: u32) -> vec3<f32> {
    return row_indirect(r) + glossy_color[r].xyz * partial_glossy[r].xyz;
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn combine(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = thread_index(gid);
    if p >= params.num_rows {
        return;
    }
    var indirect = row_indirect(p);
    if params.count > params.num_rows {
        for (var k = extra_start[p]; k < extra_start[p + 1u]; k = k + 1u) {
            indirect = indirect + row_indirect(params.num_rows + k);
        }
    }
    write_pixel(p, indirect + pixel_direct(p));
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn combine_glossy(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = thread_index(gid);
    if p >= params.num_rows {
        return;
    }
    var indirect = row_indirect_glossy(p);
    if params.count > params.num_rows {
        for (var k = extra_start[p]; k < extra_start[p + 1u]; k = k + 1u) {
            indirect = indirect + row_indirect_glossy(params.num_rows + k);
        }
    }
    write_pixel(p, indirect + pixel_direct(p));
}
