//! Shading: BSDF evaluation (Rust reference, twin of `shaders/common/bsdf.wgsl`).
pub mod bsdf;
pub mod bsdf_tables;
pub mod frame;
pub mod hemisphere;
pub mod perturb;
pub mod principled;

/// A BSDF resolved at one surface point (textures already evaluated), packed for the GPU.
/// Keep in sync with `struct Bsdf` in `shaders/common/bsdf.wgsl` (80 bytes, 16-byte aligned rows).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GpuBsdf {
    /// Diffuse reflectance (diffuse, plastic, roughplastic).
    pub diffuse: [f32; 3],
    /// One of the `KIND_*` constants in `bsdf`.
    pub kind: u32,
    /// Specular reflectance (plastics, conductors).
    pub specular: [f32; 3],
    /// `FLAG_*` bits in `bsdf` (two-sided, nonlinear, GGX vs Beckmann).
    pub flags: u32,
    /// Conductor: eta (RGB). Plastics: relative IOR in `eta[0]`.
    pub eta: [f32; 3],
    pub alpha_u: f32,
    /// Conductor: k (RGB).
    pub k: [f32; 3],
    pub alpha_v: f32,
    /// Kind-specific precomputed values (documented in `bsdf`).
    pub extra: [f32; 4],
}
