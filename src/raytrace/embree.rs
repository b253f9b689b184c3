//! Packets of shadow rays through Embree 3 (Wald, Woop, Benthin, Johnson, Ernst, "Embree: A Kernel
//! Framework for Efficient CPU Ray Tracing", SIGGRAPH 2014), the kernel library under Mitsuba 3's
//! `ray_test`, through the `embree` crate's FFI (`embree::sys`) and the system's `libembree3` (Debian's
//! `libembree-dev`; `embree` cargo feature).
//!
//! Why: a packet of 16 rays traverses the BVH together, each box and triangle test vectorised across the
//! rays. The library's own traversal (`occlusion.rs`) vectorises across the 8 children of a node for one
//! ray at a time, and runs as fast as Embree's own single-ray query (`rtcOccluded1`); Embree's 16-wide
//! packets (`rtcOccluded16`) ran 1.6-3.0x faster on the same rays (`python -m manylights.bench backends
//! --peer mitsuba`, docs/validation/backends.md). Columns (one light, consecutive pixels) and rows (one
//! view sample, consecutive lights) are the coherent ray sets packets need.
//!
//! Exactness: the scene is built `RTC_SCENE_FLAG_ROBUST` (watertight triangle tests, conservative box
//! tests; Mitsuba builds without it, 17-38% more rays per second on the benchmark's batches, and then 376
//! of 20,000 rays aimed at a closed cube's edges leave it: docs/validation/backends.md), the rays are the
//! library's own (Mitsuba's offsets, `t_max` shortened by `SHADOW_EPSILON`) with the library's floor on t
//! (`bvh::t_floor`, as `tnear`: a shading point exactly on an edge, whose offset origin lies in the plane
//! of the other face, is not blocked by that face at t = 0). Embree's triangle test is not the library's
//! (Woop et al.'s watertight test, `intersect.rs`): the two may differ on rays that end within rounding of
//! a surface or pass exactly through an edge or a vertex. Measured on the light matrix's column and row
//! batches of cbox, veach-ajar and the bunny (`bench backends --peer mitsuba`, 11.2M rays) and on the
//! tracer's 46,000 random and surface-to-surface test rays no ray differs; rays aimed exactly at an edge or
//! a vertex, or ending within 1e-6 of a hit, may (4.5% of those test rays), and none leaves a closed cube
//! through its edges (`raytrace::tests::packets::packets_answer_as_single_rays`).
//!
//! Only triangles: a scene with analytic spheres gets no Embree scene (its packets take the library's own
//! traversal, one ray at a time). The scene is built from the tracer's own triangles on its first packet
//! (`RayTracer::occluded_packet`), so a tracer used only for closest hits, or beside the GPU backend, never
//! pays for it (2M triangles: about 1 s and 0.22 GB). Masked surfaces are ordinary triangles here, as for
//! the library's own binary query; transmittance through masks never comes here (`mask.rs`).
//!
//! | here | meaning |
//! |---|---|
//! | `o`, `d`, `t_max` | ray origin, direction (any length), far end in units of `d` (the near end is the library's floor on t, `bvh::t_floor`) |
//! | `lanes` | lanes of the packet that carry a ray Embree can take (-1) or none (0) |
use super::PACKET;
use embree::sys::*;
use glam::Vec3;
use std::sync::OnceLock;

// `rtcOccluded16` takes exactly 16 lanes.
const _: () = assert!(PACKET == 16);

/// A packet goes to Embree as coherent when every ray's direction is within this cosine of its first ray's
/// (`EmbreeScene::occluded16`; the threshold measured in docs/validation/backends.md).
pub const COHERENT_COS: f32 = 0.8;

/// Scenes of more triangles trace every packet as incoherent: coherent (frustum) traversal gained 9-13% on
/// cbox's columns, 15-26% on veach-ajar's and 18% on the bunny's rows (69,451 triangles), and lost
/// 17-29% on the 2,097,152-triangle room, whose rays start on a floor of tiny triangles
/// (docs/validation/backends.md). Between the two sizes it is not measured.
pub const COHERENT_MAX_TRIANGLES: usize = 1 << 20;

/// Whether every direction of `d` lies within [`COHERENT_COS`] of the first one (then `occluded16` traces
/// the packet as coherent). Directions may have any length; a zero direction is never within.
#[inline]
pub fn coherent(d: &[Vec3]) -> bool {
    let axis = d.first().copied().unwrap_or(Vec3::ZERO);
    let axis_len2 = axis.length_squared();
    d.iter().all(|dk| {
        let c = dk.dot(axis);
        c > 0.0 && c * c >= COHERENT_COS * COHERENT_COS * dk.length_squared() * axis_len2
    })
}

/// Embree's `FLT_LARGE`: a packet ray whose origin or direction has a component beyond it fails Embree's
/// validity check, an assertion that aborts the process in Debian's build (`RayK::valid`).
const LARGE: f32 = 1.844e18;

/// Whether Embree accepts the ray (`LARGE`; `t_max` not NaN); others must be traced another way.
#[inline]
pub fn in_range(o: Vec3, d: Vec3, t_max: f32) -> bool {
    o.abs().max_element() <= LARGE && d.abs().max_element() <= LARGE && !t_max.is_nan()
}

/// The process's Embree device (its thread pool builds the scenes); null where Embree cannot start.
struct Device(RTCDevice);
// An Embree device is thread safe (Embree's API documentation, "Thread safety").
unsafe impl Send for Device {}
unsafe impl Sync for Device {}

fn device() -> Option<RTCDevice> {
    static DEVICE: OnceLock<Device> = OnceLock::new();
    let d = DEVICE.get_or_init(|| Device(unsafe { rtcNewDevice(std::ptr::null()) })).0;
    (!d.is_null()).then_some(d)
}

/// One committed Embree scene of a set of triangles, queried from any number of threads.
pub struct EmbreeScene {
    scene: RTCScene,
    /// Whether packets in a narrow cone are traced as coherent: scenes of at most
    /// [`COHERENT_MAX_TRIANGLES`].
    coherent_packets: bool,
}

// Committed Embree scenes may be queried from several threads at once (Embree's API documentation).
unsafe impl Send for EmbreeScene {}
unsafe impl Sync for EmbreeScene {}

impl EmbreeScene {
    /// `triangles` (world-space vertices) as one robust Embree scene; None where Embree cannot start or its
    /// build reports an error (the caller then traces its own way).
    pub fn new(triangles: &[[Vec3; 3]]) -> Option<Self> {
        let device = device()?;
        // SAFETY: every pointer comes from Embree and is checked before use; the buffers are written within
        // the sizes asked for; the geometry is released once attached (the scene keeps its reference).
        unsafe {
            let rscene = rtcNewScene(device);
            rtcSetSceneFlags(rscene, RTCSceneFlags::ROBUST);
            rtcSetSceneBuildQuality(rscene, RTCBuildQuality::HIGH);
            if !triangles.is_empty() {
                let g = rtcNewGeometry(device, RTCGeometryType::TRIANGLE);
                let n = triangles.len();
                let v = rtcSetNewGeometryBuffer(g, RTCBufferType::VERTEX, 0, RTCFormat::FLOAT3, 12, 3 * n) as *mut f32;
                let ix = rtcSetNewGeometryBuffer(g, RTCBufferType::INDEX, 0, RTCFormat::UINT3, 12, n) as *mut u32;
                if v.is_null() || ix.is_null() || 3 * n > u32::MAX as usize {
                    rtcReleaseGeometry(g);
                    rtcReleaseScene(rscene);
                    return None;
                }
                let vs = std::slice::from_raw_parts_mut(v, 9 * n);
                for (dst, t) in vs.chunks_exact_mut(9).zip(triangles) {
                    for (k, p) in t.iter().enumerate() {
                        dst[3 * k..3 * k + 3].copy_from_slice(&p.to_array());
                    }
                }
                let is = std::slice::from_raw_parts_mut(ix, 3 * n);
                for (k, dst) in is.chunks_exact_mut(3).enumerate() {
                    let first = 3 * k as u32;
                    dst.copy_from_slice(&[first, first + 1, first + 2]);
                }
                rtcCommitGeometry(g);
                rtcAttachGeometry(rscene, g);
                rtcReleaseGeometry(g);
            }
            rtcCommitScene(rscene);
            if rtcGetDeviceError(device) != RTCError::NONE {
                rtcReleaseScene(rscene);
                return None;
            }
            Some(EmbreeScene { scene: rscene, coherent_packets: triangles.len() <= COHERENT_MAX_TRIANGLES })
        }
    }

    /// Up to [`PACKET`] rays `o + t d`, `t_floor < t < t_max`, in one packet (`rtcOccluded16`): `out[k]` is
    /// whether ray k hits a triangle, with `t_floor` the library's floor on t (`bvh::t_floor`). Returns the
    /// lanes Embree cannot take (bit k: ray k beyond [`LARGE`] or with a NaN `t_max`); their `out` is left
    /// false for the caller to trace another way. A ray with a zero or non-finite direction or origin, or a
    /// `t_max` that is not positive, answers false (as `RayTracer::occluded_ray`).
    ///
    /// The packet is traced as coherent (`RTC_INTERSECT_CONTEXT_FLAG_COHERENT`: Embree's frustum traversal)
    /// when its directions lie within a cone of half-angle 37 degrees ([`coherent`]: a column's rays toward
    /// one light from neighbouring pixels, a row's toward neighbouring lights) in a scene of at most
    /// [`COHERENT_MAX_TRIANGLES`], as incoherent otherwise.
    pub fn occluded16(&self, o: &[Vec3], d: &[Vec3], t_max: &[f32], out: &mut [bool]) -> u32 {
        let n = o.len().min(PACKET);
        let mut lanes = [0i32; PACKET];
        // SAFETY: RTCRay16 is plain old data (floats and integers); all zero is a valid value.
        let mut ray: RTCRay16 = unsafe { std::mem::zeroed() };
        let mut outside = 0u32;
        for k in 0..n {
            let (ok, dk) = (o[k], d[k]);
            let in_range = in_range(ok, dk, t_max[k]);
            outside |= (!in_range as u32) << k;
            // Embree asserts on a NaN in any component (a partly NaN ray passes `in_range`'s maxima), and a
            // lane whose t_max is not positive would keep its -inf (the occluded mark): those answer false.
            lanes[k] = if in_range && super::ray_is_valid(ok, dk) && t_max[k] > 0.0 { -1 } else { 0 };
            ray.org_x[k] = ok.x;
            ray.org_y[k] = ok.y;
            ray.org_z[k] = ok.z;
            ray.dir_x[k] = dk.x;
            ray.dir_y[k] = dk.y;
            ray.dir_z[k] = dk.z;
            ray.tnear[k] = super::bvh::t_floor(ok, dk, 0.0);
            ray.tfar[k] = t_max[k];
            ray.mask[k] = u32::MAX;
        }
        let flags = if self.coherent_packets && coherent(&d[..n]) {
            RTCIntersectContextFlags::COHERENT
        } else {
            RTCIntersectContextFlags::INCOHERENT
        };
        let mut ctx = RTCIntersectContext { flags, filter: None, instID: [u32::MAX] };
        // SAFETY: the scene is committed and lives as long as self; lanes, ctx and ray are valid for the call.
        unsafe { rtcOccluded16(lanes.as_ptr(), self.scene, &mut ctx, &mut ray) };
        for k in 0..n {
            // Embree marks an occluded ray by setting its tfar to -inf.
            out[k] = lanes[k] != 0 && ray.tfar[k] == f32::NEG_INFINITY;
        }
        outside
    }
}

impl Drop for EmbreeScene {
    fn drop(&mut self) {
        // SAFETY: the scene was created by rtcNewScene and is released once.
        unsafe { rtcReleaseScene(self.scene) };
    }
}
