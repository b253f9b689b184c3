// Visibility modes and the hybrid shadow-map test's tolerances, shared by columns.wgsl and rows.wgsl
// (rows measure texels of the cube face at the light end, columns of the light's map at the receiver).
// Keep in sync with `Visibility` in src/matrix/mod.rs.
const VISIBILITY_SHADOW_MAP: u32 = 0u;
const VISIBILITY_HYBRID: u32 = 1u;
const VISIBILITY_RAY_TRACED: u32 = 2u;
// Outcome of the hybrid shadow-map test.
const SM_SHADOW: u32 = 0u;
const SM_LIT: u32 = 1u;
const SM_UNSURE: u32 = 2u;
// Hybrid tolerances, in texels of the layer's world-space texel size at p (see `shadow_map_decide`).
// A tap matches the receiver's plane within LIT_TOL + LIT_SLOPE_TOL * (plane's depth change per texel).
const LIT_TOL: f32 = 0.05;
const LIT_SLOPE_TOL: f32 = 0.01;
// An occluder is certain when it lies at least OCCLUDER_GAP in front of p (and of p's plane at every tap).
const OCCLUDER_GAP: f32 = 0.25;
// The four taps count as one plane when their bilinear twist is below PLANAR_TOL.
const PLANAR_TOL: f32 = 0.02;
// Depth-buffer rounding allowance: this many ulps of 1.0 in NDC depth (Depth32Float).
const DEPTH_ULPS: f32 = 16.0;
// Receiver planes seen more grazing than this (texel-area ratio of the plane's projection) are unsure.
const MIN_PROJECTED_AREA: f32 = 0.02;
