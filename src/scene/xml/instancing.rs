//! `shapegroup` and `instance` (Mitsuba 3.9.1 `src/shapes/shapegroup.cpp`, `src/shapes/instance.cpp`).
//!
//! A `shapegroup` holds shapes and renders nothing itself; each `instance` that references it (one
//! `<ref>` to a shapegroup) places the group's shapes with its `to_world`: a shape's world transform is
//! `instance.to_world * shape.to_world`. Here instancing is flattened at load time: each (instance,
//! shape of its group) pair becomes one `Mesh` whose id is `"<instance id>/<shape id>"`, appended at the
//! instance's place in document order, built exactly as a top-level shape would be (so sphere, cylinder
//! and every mesh type work inside groups). Memory grows with the number of instances.
//!
//! Mitsuba's rules, reproduced as load errors: a group may hold only shapes; no nested shapegroup, no
//! instance inside a group, no shape with an area emitter inside a group ("Instancing of emitters is not
//! supported"); an instance needs exactly one shapegroup. Mitsuba's `aov` `shape_index` of an instanced
//! hit is the instance's index in `scene.shapes()` (the same for all shapes of the group) and
//! `prim_index` the triangle of the group's shape; here each flattened mesh has its own shape index.
use super::plugins::Builder;
use super::props::Props;
use crate::error::{Error, Result};

impl Builder<'_> {
    /// Checks a `<shape type="shapegroup">`: only plain shapes without emitters (built per instance).
    pub(super) fn shapegroup(&mut self, node: usize) -> Result<()> {
        let mut p = Props::new(self.doc, node);
        for r in p.objects()? {
            let n = &self.doc.nodes[r.node];
            if n.class != "shape" {
                return Err(Error::scene(&r.loc, format!("a shapegroup can only hold shapes, got <{} type=\"{}\">", n.class, n.plugin)));
            }
            match n.plugin.as_str() {
                "shapegroup" => return Err(Error::scene(&r.loc, "nested shapegroups are not permitted")),
                "instance" => return Err(Error::scene(&r.loc, "nested instancing is not permitted")),
                _ => {}
            }
            let mut sp = Props::new(self.doc, r.node);
            for c in sp.objects()? {
                if self.doc.nodes[c.node].class == "emitter" {
                    return Err(Error::scene(&c.loc, "instancing of emitters is not supported (an area emitter inside a shapegroup)"));
                }
            }
        }
        p.finish()
    }

    /// Builds the shapes of an `<shape type="instance">`'s shapegroup, placed by the instance.
    pub(super) fn instance(&mut self, node: usize) -> Result<()> {
        let mut p = Props::new(self.doc, node);
        let loc = p.loc().clone();
        let outer = p.affine("to_world")?.unwrap_or(crate::scene::transform::Affine::IDENTITY);
        let children = p.objects()?;
        let id = p.node.id.clone().unwrap_or_else(|| format!("instance_{}", self.meshes.len()));
        p.finish()?;
        let group = match children.as_slice() {
            [r] if self.doc.nodes[r.node].class == "shape" && self.doc.nodes[r.node].plugin == "shapegroup" => r.node,
            [r] => {
                let n = &self.doc.nodes[r.node];
                return Err(Error::scene(
                    &r.loc,
                    format!("only a shapegroup can be specified in an instance, got <{} type=\"{}\">", n.class, n.plugin),
                ));
            }
            [] => return Err(Error::scene(&loc, "an instance needs a reference to a shapegroup")),
            [_, r, ..] => return Err(Error::scene(&r.loc, "only a single shapegroup can be specified per instance")),
        };
        self.shapegroup(group)?;
        let mut gp = Props::new(self.doc, group);
        for r in gp.objects()? {
            self.shape_in(r.node, &outer, Some(&id))?;
        }
        Ok(())
    }
}
