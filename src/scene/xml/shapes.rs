//! Stage 2 of loading, shapes: a `<shape>` node -> `Mesh` (with its BSDF, its area emitter and its
//! `to_world`), with the defaults of Mitsuba 3.9.1's shape plugins (`src/shapes/*.cpp`); `shapegroup` and
//! `instance` are in `instancing.rs`.
use super::plugins::{unknown_plugin, Builder};
use super::props::{ObjectRef, Props};
use crate::error::{Error, Result};
use crate::scene::mesh;
use crate::scene::transform;
use crate::scene::types::*;
use glam::{DMat4, DVec3, Mat4, Vec3};

impl Builder<'_> {
    /// Builds one top-level `<shape>` into `meshes` (and its area emitter into `area_emitters`);
    /// `shapegroup` and `instance` are handled in `instancing.rs`.
    pub fn shape(&mut self, node: usize) -> Result<()> {
        match self.doc.nodes[node].plugin.as_str() {
            "shapegroup" => self.shapegroup(node),
            "instance" => self.instance(node),
            _ => self.shape_in(node, &transform::Affine::IDENTITY, None),
        }
    }

    /// Builds a shape placed by `outer * to_world`; `instance` names the instance it belongs to (its
    /// mesh id becomes `"<instance>/<shape id>"`).
    pub(super) fn shape_in(&mut self, node: usize, outer: &transform::Affine, instance: Option<&str>) -> Result<()> {
        let mut p = Props::new(self.doc, node);
        let loc = p.loc().clone();
        let k = self.meshes.len();
        let to_world_affine = *outer * p.affine("to_world")?.unwrap_or(transform::Affine::IDENTITY);
        let to_world = to_world_affine.matrix;
        let flip_normals = p.bool("flip_normals", false)?;
        let plugin = p.node.plugin.as_str();
        // Mitsuba 3.9.1 meshes (these read face_normals); sphere and disk are analytic there.
        let is_mesh = matches!(plugin, "obj" | "ply" | "cube" | "rectangle" | "serialized");
        let face_normals = if is_mesh { p.bool("face_normals", false)? } else { false };
        let (kind, data, world_from_local) = match plugin {
            "obj" | "ply" => {
                let (path, floc) = self.filename(&mut p, &format!("{plugin} shape"))?;
                let mut data = if plugin == "obj" { mesh::load_obj(&path, &floc)? } else { mesh::load_ply(&path, &floc)? };
                // `load_*` apply Mitsuba's default (OBJ: flip, PLY: no flip); undo/apply on request.
                let default_flip = plugin == "obj";
                if p.bool("flip_tex_coords", default_flip)? != default_flip {
                    data.uvs.iter_mut().for_each(|uv| uv.y = 1.0 - uv.y);
                }
                let kind = if plugin == "obj" { ShapeKind::Obj } else { ShapeKind::Ply };
                (kind, data, to_world)
            }
            "rectangle" => (ShapeKind::Rectangle, mesh::rectangle(), to_world),
            "cube" => (ShapeKind::Cube, mesh::cube(), to_world),
            "disk" => (ShapeKind::Disk, mesh::disk(), to_world),
            "sphere" => {
                let center = p.vector("center")?.unwrap_or(DVec3::ZERO);
                let radius = p.float("radius", 1.0)?;
                if radius == 0.0 || !radius.is_finite() {
                    return Err(Error::scene(&p.loc_of("radius"), format!("sphere: radius must be finite and non-zero, got {radius}")));
                }
                let m = to_world * DMat4::from_translation(center) * DMat4::from_scale(DVec3::splat(radius));
                let cols = [m.x_axis.truncate(), m.y_axis.truncate(), m.z_axis.truncate()];
                let l = cols.map(|c| c.length());
                let uniform = (l[1] - l[0]).abs() <= 1e-5 * l[0] && (l[2] - l[0]).abs() <= 1e-5 * l[0];
                let orthogonal = (0..3).all(|i| cols[i].dot(cols[(i + 1) % 3]).abs() <= 1e-5 * l[0] * l[0]);
                if !(uniform && orthogonal) || l[0] == 0.0 {
                    return Err(Error::scene(
                        &loc,
                        format!(
                            "sphere: to_world must be a similarity (uniform scale, no shear); axis lengths {:.6}, {:.6}, {:.6}",
                            l[0], l[1], l[2]
                        ),
                    ));
                }
                let mirrored = glam::DMat3::from_mat4(m).determinant() < 0.0;
                let kind = ShapeKind::Sphere {
                    center: m.w_axis.truncate().as_vec3(),
                    radius: l[0] as f32,
                    flip_normals: flip_normals != mirrored,
                };
                (kind, mesh::sphere(), m)
            }
            "serialized" => {
                let (path, floc) = self.filename(&mut p, "serialized shape")?;
                let (shape_index, _) = p.int("shape_index", 0)?;
                (ShapeKind::Serialized, mesh::load_serialized(&path, shape_index, &floc)?, to_world)
            }
            "cylinder" => {
                let radius = p.float("radius", 1.0)?;
                let p0 = p.vector("p0")?.unwrap_or(DVec3::ZERO);
                let p1 = p.vector("p1")?.unwrap_or(DVec3::Z);
                let m = mesh::cylinder_to_world(to_world, p0, p1, radius)
                    .ok_or_else(|| Error::scene(&loc, format!("cylinder: p0 {p0} and p1 {p1} must differ")))?;
                let mut data = mesh::cylinder();
                if glam::DMat3::from_mat4(m).determinant() < 0.0 {
                    // A mirroring to_world: Mitsuba flips its normals back outward (cylinder.cpp, `S[0][0] <= 0`).
                    data.indices.iter_mut().for_each(|t| t.swap(1, 2));
                }
                (ShapeKind::Cylinder, data, m)
            }
            _ => return Err(unknown_plugin(&p)),
        };
        // Children: one BSDF and at most one area emitter.
        let mut bsdf = None;
        let mut emitter_node = None;
        let (mut interior, mut exterior) = (None, None);
        for r in p.objects()? {
            let n = &self.doc.nodes[r.node];
            match n.class.as_str() {
                "medium" if self.media_policy == super::MediaPolicy::Follow => {
                    let slot = match r.name.as_deref() {
                        Some("interior") => &mut interior,
                        Some("exterior") => &mut exterior,
                        other => {
                            return Err(Error::scene(
                                &r.loc,
                                format!("a medium inside a shape must be named \"interior\" or \"exterior\", got {other:?}"),
                            ))
                        }
                    };
                    if slot.is_some() {
                        return Err(Error::scene(
                            &r.loc,
                            format!("only a single {} medium can be given per shape", r.name.as_deref().unwrap_or("")),
                        ));
                    }
                    *slot = Some(self.medium(r.node)?);
                }
                "bsdf" if bsdf.is_none() => bsdf = Some(self.bsdf(r.node)?),
                "bsdf" => return Err(Error::scene(&r.loc, "only a single BSDF can be given per shape")),
                "emitter" if emitter_node.is_none() => emitter_node = Some(r),
                "emitter" => return Err(Error::scene(&r.loc, "only a single emitter can be given per shape")),
                other => {
                    return Err(Error::scene(&r.loc, format!("unsupported <{other} type=\"{}\"> inside a shape", n.plugin)));
                }
            }
        }
        let id = p.node.id.clone().unwrap_or_else(|| format!("shape_{k}"));
        let id = match instance {
            Some(inst) => format!("{inst}/{id}"),
            None => id,
        };
        p.finish()?;
        let bsdf = match bsdf {
            Some(b) => b,
            None => *self.default_bsdf.get_or_insert_with(|| {
                self.bsdfs.push(Bsdf::Diffuse { reflectance: Param::Value(Vec3::splat(0.5)) });
                self.bsdfs.len() - 1
            }),
        };
        // Normals as Mitsuba transforms them (`transform::Affine`); the sphere's and the cylinder's
        // tessellations are ours, placed by their own matrix (radius, p0/p1 folded in): its inverse transpose.
        let normal_from_local = match kind {
            ShapeKind::Sphere { .. } | ShapeKind::Cylinder => glam::DMat3::from_mat4(world_from_local).inverse().transpose(),
            _ => glam::DMat3::from_mat4(to_world_affine.inverse_transpose),
        };
        let world_from_local: Mat4 = transform::to_f32(&world_from_local);
        let (positions, normals, uvs, indices) =
            mesh::finalize_with_normal_matrix(data, world_from_local, normal_from_local.as_mat3(), face_normals, flip_normals, &loc)?;
        if indices.is_empty() {
            if let Some(r) = &emitter_node {
                // Mitsuba fails too ("DiscreteDistribution: no probability mass found").
                return Err(Error::scene(
                    &r.loc,
                    format!("area emitter on a degenerate shape \"{id}\" ({loc}): all its triangles have zero area"),
                ));
            }
            self.warnings.push(format!("{loc}: shape \"{id}\": all triangles have zero area; the shape adds nothing (as in Mitsuba)"));
        }
        let emitter = match emitter_node {
            Some(r) => {
                let e = self.area_emitter(&r, k)?;
                self.area_emitters.push(e);
                Some(self.area_emitters.len() - 1)
            }
            None => None,
        };
        if interior.is_some() || exterior.is_some() {
            self.shape_media.push((self.meshes.len(), interior, exterior));
        }
        self.meshes.push(Mesh { id, kind, positions, normals, uvs, indices, face_normals, bsdf, emitter, loc });
        Ok(())
    }

    fn area_emitter(&mut self, r: &ObjectRef, mesh: usize) -> Result<Emitter> {
        let mut p = Props::new(self.doc, r.node);
        if p.node.plugin != "area" {
            return Err(Error::scene(&r.loc, format!("a shape's emitter must be type=\"area\", got \"{}\"", p.node.plugin)));
        }
        if let Some(prev) = self.attached.insert(r.node, r.loc.clone()) {
            return Err(Error::scene(&r.loc, format!("area emitter already attached to another shape at {prev}")));
        }
        if p.has("to_world") {
            return Err(Error::scene(p.loc(), "area emitter: a to_world transform is not allowed (the shape's applies)"));
        }
        let (radiance, texture) = match self.unbounded_param(&mut p, "radiance", 1.0)? {
            Param::Value(v) => (super::plugins::emitted_value(&mut p, "radiance", v)?, None),
            Param::Texture(t) => {
                self.check_emitter_texture(t, "area emitter radiance texture")?;
                (Vec3::ONE, Some(t))
            }
        };
        let loc = p.loc().clone();
        p.finish()?;
        Ok(Emitter::Area { mesh, radiance, texture, loc })
    }

    /// True if this top-level emitter node was attached to a shape.
    pub fn is_attached(&self, node: usize) -> bool {
        self.attached.contains_key(&node)
    }
}
