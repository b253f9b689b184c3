// Tensor clustering's reconstruction on the GPU (src/gpu/reconstruction.rs; Hašan, Velázquez, Pellacini,
// Bala, EGSR 2008, Sec. 4.5 and 5): the GPU twin of src/matrix/reconstruction.rs. A batch of
// representative columns, all rendered in frame k0 and still in the column pass's output buffer, is
// scaled by Rec(c, k) and carried to every target frame k by the chain of pixel mappings, then added to
// frame k's accumulator:
//
//   acc_k(i) += sum_c Rec(c, k) * col_c(pi_{k0 -> k}(i)),
//
// pi walking from frame k back to k0: forward[s] (pixel of frame s nearest to a pixel of frame s + 1) for
// k > k0, backward[s] (pixel of frame s + 1 nearest to a pixel of frame s) for k < k0. One invocation per
// (target frame, pixel); its loops are bounded by the frame distance (< 65,535: a chunk of frames) and
// the batch size (checked on the host), under Mesa's silent loop cut (docs/WGPU_HEADLESS.md).
//
// A column holds one RGB triple per view sample: the first P are the pixels, the rest the extra samples
// of delta chains, folded into their pixel here through a CSR list (extra_start / extra_index of frame k0).

struct Params {
    // Pixels per frame (P) and view samples per column of frame k0 (m >= P).
    num_pixels: u32,
    num_samples: u32,
    // Columns in the batch and their frame.
    num_columns: u32,
    source_frame: u32,
    // Frames are numbered within the uploaded stretch of frames (a chunk). Target frames of this
    // dispatch: first_frame .. first_frame + num_frames, written at acc[(k - window_start) * P + i].
    first_frame: u32,
    num_frames: u32,
    window_start: u32,
    // Frames of the Rec rows (the stretch's frame count).
    rec_frames: u32,
    // First (frame, pixel) item of this dispatch: one window's items run as several dispatches within
    // the work budget (src/gpu/dispatch.rs), each a whole number of workgroups but the last.
    first_item: u32,
    // Workgroups along x (the dispatch is 2D when it exceeds the per-dimension limit).
    dispatch_width: u32,
    _pad0: u32,
    _pad1: u32,
}

const NO_SOURCE: u32 = 0xffffffffu;
const WORKGROUP_SIZE: u32 = 64u;

@group(0) @binding(0) var<uniform> params: Params;
// Column c's sample s at columns[(c * m + s) * 3 + ch].
@group(0) @binding(1) var<storage, read> columns: array<f32>;
// Rec(c, k) in xyz.
@group(0) @binding(2) var<storage, read> rec: array<vec4<f32>>;
// (rec_frames - 1) mappings of P entries each.
@group(0) @binding(3) var<storage, read> forward_map: array<u32>;
@group(0) @binding(4) var<storage, read> backward_map: array<u32>;
// Frame k0's extra samples of pixel p: extra_index[extra_start[p] .. extra_start[p + 1]].
@group(0) @binding(5) var<storage, read> extra_start: array<u32>;
@group(0) @binding(6) var<storage, read> extra_index: array<u32>;
@group(0) @binding(7) var<storage, read_write> acc: array<vec4<f32>>;

fn sample_rgb(c: u32, s: u32) -> vec3<f32> {
    let o = (c * params.num_samples + s) * 3u;
    return vec3<f32>(columns[o], columns[o + 1u], columns[o + 2u]);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let t = params.first_item + gid.x + gid.y * params.dispatch_width * WORKGROUP_SIZE;
    let P = params.num_pixels;
    if t >= P * params.num_frames {
        return;
    }
    let k = params.first_frame + t / P;
    let i = t % P;
    let k0 = params.source_frame;
    // Walk the chain of mappings from frame k back to frame k0.
    var idx = i;
    var s = k;
    loop {
        if s <= k0 || idx == NO_SOURCE {
            break;
        }
        idx = forward_map[(s - 1u) * P + idx];
        s = s - 1u;
    }
    loop {
        if s >= k0 || idx == NO_SOURCE {
            break;
        }
        idx = backward_map[s * P + idx];
        s = s + 1u;
    }
    if idx == NO_SOURCE {
        return;
    }
    var sum = vec3<f32>(0.0);
    let e0 = extra_start[idx];
    let e1 = extra_start[idx + 1u];
    for (var c = 0u; c < params.num_columns; c = c + 1u) {
        let w = rec[c * params.rec_frames + k].xyz;
        if all(w == vec3<f32>(0.0)) {
            continue;
        }
        var v = sample_rgb(c, idx);
        for (var e = e0; e < e1; e = e + 1u) {
            v = v + sample_rgb(c, extra_index[e]);
        }
        sum = sum + w * v;
    }
    let a = (k - params.window_start) * P + i;
    acc[a] = acc[a] + vec4<f32>(sum, 0.0);
}
