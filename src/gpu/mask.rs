//! Masked surfaces (Mitsuba's `mask` BSDF) on the GPU: the mask table that `shaders/common/mask.wgsl`
//! reads, and the per-light fields it needs. The semantics are `crate::raytrace::mask`'s (module docs
//! there); the WGSL is the twin of `RayTracer::mask_transmittance_crossed`, `cpu::mask_visibility_at`
//! and `raytrace::mask::direct_factor`.
//!
//! Table (one storage binding of u32 words; floats stored as their bits):
//! - one record per masked mesh, at the offset its BVH primitives carry (`GpuPrimitive::mask`,
//!   `NO_MASK` for the others): `[source, opacity, has_uvs, 0]`, then for a textured triangle mesh with
//!   uvs 6 words per triangle (the uvs of its 3 vertices). `source` is `CONSTANT` (then `opacity` is the
//!   constant, clipped to [0, 1]) or the offset of a texture record. A triangle mesh without uvs looks
//!   textures up at its barycentrics (b1, b2), a sphere at Mitsuba's spherical uv, as `RayTracer::intersect`.
//! - one record per texture the masks read (`TEXTURE_HEADER` words, then the texels):
//!   `[kind, width, height, wrap, filter, to_uv (9 floats, column-major), 0, 0]`, kind 0 a bitmap (wrap 0
//!   repeat, 1 mirror, 2 clamp; filter 0 bilinear, 1 nearest) followed by its RGB texels row-major, kind 1
//!   a checkerboard followed by Mitsuba's `eval_1` values where `eval` picks `color0` (the mean of
//!   `color1`'s channels) and elsewhere (the mean of `color0`'s): `scene::texture::eval_1`.
//!
//! Per light (`light_fields`, in the `GpuLight` patch corners' unused w): whether its shadow rays cross
//! masked surfaces (area light samples, VPLs, environment strata of a scene without a directional
//! emitter) and, for an area light sample, Mitsuba's area-emitter density of its mesh
//! (`ViewSamples::mask_emitter_pdf`). Per view sample (`gpu::columns::GpuViewSample`): the mask budget
//! in `flags`, P_valid and the opacity.
//!
//! Limits: a shadow ray crosses at most `MAX_CROSSINGS` masked surfaces (as the CPU's loop); the column
//! pass gives each mask ray `MASK_RAY_COST` rays' share of the BVH step budget (`gpu::bvh`), so a masked
//! view's dispatches shade fewer lights each. The BSDF-sampling density of `direct_factor` is ported for
//! every record a loaded mask can hold; a bump or normal map inside a mask (which the loader refuses, but
//! a scene built in code may hold) has no WGSL twin of its density (`unsupported` names it; the GPU
//! backend refuses such scenes).
use crate::lights::{LightKind, LightSet};
use crate::raytrace::mask::{eval_opacity, mask_opacity_param};
use crate::scene::types::{Bsdf, FilterType, Param, Texture, WrapMode};
use crate::scene::{Scene, ShapeKind};
use crate::view::ViewSamples;

/// `GpuPrimitive::mask` of a primitive whose mesh is not masked; mirrored in `mask.wgsl`.
pub const NO_MASK: u32 = u32::MAX;
/// A mesh record's `source` for a constant opacity; mirrored in `mask.wgsl`.
pub const CONSTANT: u32 = u32::MAX;
/// Words of a mesh record before its uvs; mirrored in `mask.wgsl`.
pub const MESH_HEADER: usize = 4;
/// Words of a texture record before its texels; mirrored in `mask.wgsl`.
pub const TEXTURE_HEADER: usize = 16;
/// Most masked surfaces one shadow ray crosses (then it counts as blocked), as
/// `RayTracer::mask_transmittance_crossed`; mirrored in `mask.wgsl`.
pub const MAX_CROSSINGS: u32 = 1024;
/// BVH rays of the step budget a column dispatch sets aside per mask ray (one closest-hit traversal per
/// masked surface crossed, and one more).
pub const MASK_RAY_COST: u32 = 4;

/// Whether the mesh's texture lookups need its per-triangle uvs stored.
fn stores_uvs(scene: &Scene, mesh: usize, opacity: &Param) -> bool {
    let m = &scene.meshes[mesh];
    matches!(opacity, Param::Texture(_)) && !matches!(m.kind, ShapeKind::Sphere { .. }) && !m.uvs.is_empty()
}

/// Each mesh's record offset in the mask table (`NO_MASK` for meshes that are not masked); the layout
/// `MaskTable::build` writes (module docs).
pub fn mesh_records(scene: &Scene) -> Vec<u32> {
    let mut next = 0usize;
    scene
        .meshes
        .iter()
        .enumerate()
        .map(|(k, m)| match mask_opacity_param(&scene.bsdfs, m.bsdf) {
            Some(p) => {
                let at = next;
                next += MESH_HEADER + if stores_uvs(scene, k, p) { 6 * m.indices.len() } else { 0 };
                at as u32
            }
            None => NO_MASK,
        })
        .collect()
}

/// The mask table of a scene (module docs).
#[derive(Debug, Clone, Default)]
pub struct MaskTable {
    pub words: Vec<u32>,
}

impl MaskTable {
    /// The table of `scene` (empty without masked meshes).
    pub fn build(scene: &Scene) -> MaskTable {
        let records = mesh_records(scene);
        let mut words: Vec<u32> = Vec::new();
        // Texture records follow every mesh record; each texture is stored once.
        let mut texture_at: Vec<Option<u32>> = vec![None; scene.textures.len()];
        let mut textures: Vec<u32> = Vec::new();
        let mesh_words: usize = scene
            .meshes
            .iter()
            .enumerate()
            .filter_map(|(k, m)| {
                mask_opacity_param(&scene.bsdfs, m.bsdf)
                    .map(|p| MESH_HEADER + if stores_uvs(scene, k, p) { 6 * m.indices.len() } else { 0 })
            })
            .sum();
        for (k, m) in scene.meshes.iter().enumerate() {
            let Some(p) = mask_opacity_param(&scene.bsdfs, m.bsdf) else { continue };
            debug_assert_eq!(words.len(), records[k] as usize);
            let (source, value) = match p {
                Param::Value(_) => (CONSTANT, eval_opacity(&scene.textures, p, glam::Vec2::ZERO)),
                Param::Texture(t) => {
                    let at = *texture_at[*t].get_or_insert_with(|| {
                        let at = (mesh_words + textures.len()) as u32;
                        push_texture(&mut textures, &scene.textures[*t]);
                        at
                    });
                    (at, 0.0)
                }
            };
            let uvs = stores_uvs(scene, k, p);
            words.extend_from_slice(&[source, value.to_bits(), uvs as u32, 0]);
            if uvs {
                for tri in &m.indices {
                    for &v in tri {
                        let uv = m.uvs[v as usize];
                        words.extend_from_slice(&[uv.x.to_bits(), uv.y.to_bits()]);
                    }
                }
            }
        }
        debug_assert_eq!(words.len(), mesh_words);
        words.extend_from_slice(&textures);
        MaskTable { words }
    }

    /// Bytes of the table.
    pub fn bytes(&self) -> u64 {
        self.words.len() as u64 * 4
    }
}

/// Appends the texture record of `tex` (module docs).
fn push_texture(out: &mut Vec<u32>, tex: &Texture) {
    let mut header = [0u32; TEXTURE_HEADER];
    let to_uv = match tex {
        Texture::Bitmap { width, height, filter, wrap, to_uv, .. } => {
            header[1] = *width;
            header[2] = *height;
            header[3] = match wrap {
                WrapMode::Repeat => 0,
                WrapMode::Mirror => 1,
                WrapMode::Clamp => 2,
            };
            header[4] = match filter {
                FilterType::Bilinear => 0,
                FilterType::Nearest => 1,
            };
            to_uv
        }
        Texture::Checkerboard { to_uv, .. } => {
            header[0] = 1;
            to_uv
        }
    };
    for (w, c) in header[5..14].iter_mut().zip(to_uv.to_cols_array()) {
        *w = c.to_bits();
    }
    out.extend_from_slice(&header);
    match tex {
        Texture::Bitmap { data, .. } => out.extend(data.iter().flat_map(|t| t.to_array().map(f32::to_bits))),
        Texture::Checkerboard { color0, color1, .. } => {
            let mean = |c: glam::Vec3| (c.x + c.y + c.z) / 3.0;
            out.extend_from_slice(&[mean(*color1).to_bits(), mean(*color0).to_bits()]);
        }
    }
}

/// Light j's mask fields (module docs): (Mitsuba's area-emitter density of its mesh, 0 for other kinds;
/// 1 when its shadow rays cross masked surfaces, 1 + d for a VPL of depth d >= 1, whose rays cross d fewer
/// than the view sample's budget (`cpu::mask_visibility_at`), 0 when masks block them).
/// `directional_passes`: whether the scene's directional lights are environment strata
/// (`raytrace::mask::Masks::directional_is_environment`).
pub fn light_fields(view: &ViewSamples, lights: &LightSet, j: usize, directional_passes: bool) -> [f32; 2] {
    let pdf = match lights.kind[j] {
        LightKind::OrientedPoint => {
            usize::try_from(lights.mis_mesh[j]).ok().and_then(|k| view.mask_emitter_pdf.get(k)).copied().unwrap_or(0.0)
        }
        _ => 0.0,
    };
    let passes = match lights.kind[j] {
        LightKind::OrientedPoint => 1.0,
        LightKind::Vpl => 1.0 + lights.vpl_depth[j].clamp(1, 1 << 16) as f32,
        LightKind::Directional => directional_passes as u8 as f32,
        LightKind::Point | LightKind::Spot => 0.0,
    };
    [pdf, passes]
}

/// Why the GPU cannot shade `scene`'s masks, or None: a mask around a BSDF whose sampling density
/// (`lights::generate::sampling::pdf_bsdf`, in `direct_factor`) has no WGSL twin (bump and normal maps,
/// `shading::perturb::pdf`; the XML loader refuses them inside a mask).
pub fn unsupported(scene: &Scene) -> Option<String> {
    fn needs_cpu(bsdfs: &[Bsdf], i: usize, depth: u32) -> Option<&'static str> {
        if depth > 8 {
            return None;
        }
        match bsdfs.get(i)? {
            Bsdf::BumpMap { .. } => Some("bumpmap"),
            Bsdf::NormalMap { .. } => Some("normalmap"),
            Bsdf::TwoSided { front, back } => {
                needs_cpu(bsdfs, *front, depth + 1).or_else(|| if back != front { needs_cpu(bsdfs, *back, depth + 1) } else { None })
            }
            Bsdf::Mask { nested, .. } => needs_cpu(bsdfs, *nested, depth + 1),
            _ => None,
        }
    }
    scene.bsdfs.iter().enumerate().filter(|(_, b)| matches!(b, Bsdf::Mask { .. })).find_map(|(i, _)| {
        needs_cpu(&scene.bsdfs, i, 0).map(|what| {
            format!(
                "a mask BSDF around a {what}: the GPU backend has no twin of its BSDF-sampling density (Mitsuba's \
                 MIS weight on the direct light of a masked surface)"
            )
        })
    })
}

#[cfg(test)]
mod tests;
