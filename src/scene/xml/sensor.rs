//! Stage 2 of loading, the sensor: a `<sensor type="perspective">` node and its film -> `Camera`, with the
//! defaults of Mitsuba 3.9.1 (`src/sensors/perspective.cpp`, `src/render/sensor.cpp`).
use super::plugins::{unknown_plugin, Builder, DEFAULT_FILM_SIZE};
use super::props::Props;
use crate::error::{Error, Location, Result};
use crate::scene::transform;
use crate::scene::types::*;
use glam::DMat4;

impl Builder<'_> {
    /// The camera of a `<sensor type="perspective">` node.
    pub fn sensor(&mut self, node: usize) -> Result<Camera> {
        let mut p = Props::new(self.doc, node);
        let loc = p.loc().clone();
        if p.node.plugin != "perspective" {
            return Err(unknown_plugin(&p));
        }
        let mut film = None;
        for r in p.objects()? {
            let n = &self.doc.nodes[r.node];
            match n.class.as_str() {
                "film" if film.is_none() => film = Some(r.node),
                "film" => return Err(Error::scene(&r.loc, "only a single film can be given per sensor")),
                "sampler" => {}
                other => return Err(Error::scene(&r.loc, format!("unsupported <{other} type=\"{}\"> inside a sensor", n.plugin))),
            }
        }
        let f = self.film(film, &loc)?;
        let aspect = f.full.0 as f64 / f.full.1 as f64;
        let mut fov_x = parse_fov(&mut p, aspect)?;
        let near_clip = p.float("near_clip", 1e-2)?;
        let far_clip = p.float("far_clip", 1e4)?;
        if near_clip <= 0.0 || near_clip >= far_clip {
            return Err(Error::scene(&loc, format!("near_clip ({near_clip}) must be > 0 and < far_clip ({far_clip})")));
        }
        let mut offset = glam::DVec2::new(p.float("principal_point_offset_x", 0.0)?, p.float("principal_point_offset_y", 0.0)?);
        if !offset.is_finite() {
            return Err(Error::scene(&loc, format!("principal_point_offset {offset} must be finite")));
        }
        if let Some((ox, oy, cw, ch)) = f.crop {
            // The crop window as a camera of its own: the ray through crop position (px, py) is the full
            // film's ray through (px + ox, py + oy) (Mitsuba's `sample_ray` with a crop window). A film of
            // cw/W the width (tan(fov/2) scaled by it) whose principal point is shifted to match.
            let (w, h) = (f.full.0 as f64, f.full.1 as f64);
            let (cw, ch) = (cw as f64, ch as f64);
            fov_x = 2.0 * ((fov_x.to_radians() * 0.5).tan() * cw / w).atan().to_degrees();
            offset = glam::DVec2::new(
                0.5 * (1.0 - w / cw * (1.0 - 2.0 * (ox as f64 / w + offset.x))),
                0.5 * (1.0 - h / ch * (1.0 - 2.0 * (oy as f64 / h + offset.y))),
            );
        }
        let principal_point_offset = offset.as_vec2();
        let (width, height) = f.size;
        let to_world = p.transform("to_world")?.unwrap_or(DMat4::IDENTITY);
        if transform::has_scale(&to_world) {
            return Err(Error::scene(&loc, "scale factors in the camera to_world transformation are not allowed"));
        }
        p.finish()?;
        Ok(Camera {
            world_from_camera: transform::to_f32(&to_world),
            fov_x: (fov_x as f32).to_radians(),
            near_clip: near_clip as f32,
            far_clip: far_clip as f32,
            width,
            height,
            principal_point_offset,
            loc,
        })
    }

    /// Film of a sensor: `hdrfilm` width/height (default 768x576) and its crop window
    /// (`crop_offset_x/y`, `crop_width/height`, as Mitsuba's `Film`: the image is the window); the image
    /// size is replaced by `size_override` (the window then keeps its share of the film).
    /// `banner` (Mitsuba 0.x's logo switch, any type) is accepted and ignored, as Mitsuba 3.9.1 does;
    /// `gamma` (an `ldrfilm` property of Mitsuba 0.x) is refused, as Mitsuba 3.9.1 refuses it.
    fn film(&mut self, film: Option<usize>, sensor_loc: &Location) -> Result<Film> {
        let (mut w, mut h, mut loc) = (DEFAULT_FILM_SIZE.0, DEFAULT_FILM_SIZE.1, sensor_loc.clone());
        let mut crop = None;
        if let Some(node) = film {
            let mut p = Props::new(self.doc, node);
            if p.node.plugin != "hdrfilm" {
                return Err(unknown_plugin(&p));
            }
            loc = p.loc().clone();
            (w, _) = p.int("width", w)?;
            (h, _) = p.int("height", h)?;
            if ["crop_offset_x", "crop_offset_y", "crop_width", "crop_height"].iter().any(|n| p.has(n)) {
                let (ox, _) = p.int("crop_offset_x", 0)?;
                let (oy, _) = p.int("crop_offset_y", 0)?;
                let (cw, _) = p.int("crop_width", w)?;
                let (ch, _) = p.int("crop_height", h)?;
                let inside = |o: i64, c: i64, n: i64| o >= 0 && c > 0 && n > 0 && o.checked_add(c).is_some_and(|e| e <= n);
                if !inside(ox, cw, w) || !inside(oy, ch, h) || w > u32::MAX as i64 || h > u32::MAX as i64 {
                    return Err(Error::scene(
                        &loc,
                        format!(
                            "invalid crop window: offset ({ox}, {oy}), size {cw}x{ch} must lie inside the {w}x{h} film \
                             (offsets >= 0, sizes > 0)"
                        ),
                    ));
                }
                if (ox, oy, cw, ch) != (0, 0, w, h) {
                    crop = Some((ox as u32, oy as u32, cw as u32, ch as u32));
                }
            }
            if let Some(g) = p.node.props.iter().find(|q| q.name == "gamma") {
                return Err(Error::scene(
                    &g.loc,
                    "property \"gamma\" of the film is not supported: it belongs to Mitsuba 0.x's ldrfilm \
                     (Mitsuba 3.9.1 refuses it in an hdrfilm too); remove it, the renders are linear",
                ));
            }
            p.ignore(&["banner"]);
            for r in p.objects()? {
                let n = &self.doc.nodes[r.node];
                if n.class != "rfilter" {
                    return Err(Error::scene(&r.loc, format!("unsupported <{} type=\"{}\"> inside a film", n.class, n.plugin)));
                }
            }
            p.finish()?;
        }
        let (mut iw, mut ih) = crop.map(|(_, _, cw, ch)| (cw as i64, ch as i64)).unwrap_or((w, h));
        if let Some((ow, oh)) = self.size_override {
            (iw, ih) = (ow as i64, oh as i64);
        }
        if iw <= 0 || ih <= 0 || iw > u32::MAX as i64 || ih > u32::MAX as i64 {
            return Err(Error::scene(&loc, format!("film size {iw}x{ih}: width and height must be positive")));
        }
        let size = (iw as u32, ih as u32);
        // A crop window is a share of the file's film (whose aspect sets fov_axis); else the image is the film.
        let full = if crop.is_some() { (w as u32, h as u32) } else { size };
        Ok(Film { full, crop, size })
    }
}

/// A sensor's film: the full film size (the image size when there is no crop window), its crop window (offset x, y, width, height) when it is not the
/// whole film, and the image size (the crop window's, or `size_override`).
struct Film {
    full: (u32, u32),
    crop: Option<(u32, u32, u32, u32)>,
    size: (u32, u32),
}

/// Horizontal field of view in degrees (Mitsuba's `parse_fov`, `src/render/sensor.cpp`).
fn parse_fov(p: &mut Props, aspect: f64) -> Result<f64> {
    let loc = p.loc().clone();
    let (fov, axis) = match p.opt_float("fov")? {
        Some(fov) => {
            if p.has("focal_length") {
                return Err(Error::scene(&loc, "give either fov or focal_length, not both"));
            }
            let axis = p.string("fov_axis")?.map(|(s, _)| s.to_lowercase()).unwrap_or_else(|| "x".into());
            let axis = match axis.as_str() {
                "smaller" => if aspect > 1.0 { "y" } else { "x" }.to_string(),
                "larger" => if aspect > 1.0 { "x" } else { "y" }.to_string(),
                _ => axis,
            };
            (fov, axis)
        }
        None => {
            let f = p.string("focal_length")?.map(|(s, _)| s).unwrap_or("50mm");
            let v = f.strip_suffix("mm").unwrap_or(f);
            let v: f64 = v
                .trim()
                .parse()
                .map_err(|_| Error::scene(&loc, format!("could not parse focal_length \"{f}\" (must be of the form <x>mm)")))?;
            (2.0 * ((36.0f64 * 36.0 + 24.0 * 24.0).sqrt() / (2.0 * v)).atan().to_degrees(), "diagonal".to_string())
        }
    };
    let fov_x = match axis.as_str() {
        "x" => fov,
        "y" => (2.0 * ((0.5 * fov).to_radians().tan() * aspect).atan()).to_degrees(),
        "diagonal" => {
            let diagonal = 2.0 * (0.5 * fov).to_radians().tan();
            let width = diagonal / (1.0 + 1.0 / (aspect * aspect)).sqrt();
            (2.0 * (width * 0.5).atan()).to_degrees()
        }
        other => {
            return Err(Error::scene(&loc, format!("fov_axis \"{other}\" must be one of smaller, larger, diagonal, x, y")));
        }
    };
    if !(fov_x > 0.0 && fov_x < 180.0) {
        return Err(Error::scene(&loc, format!("the horizontal field of view ({fov_x} degrees) must be in (0, 180)")));
    }
    Ok(fov_x)
}
