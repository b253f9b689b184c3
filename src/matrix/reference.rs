//! CPU reference for light-matrix elements: the same shading as `columns.wgsl` with exact visibility by
//! brute-force ray casting against every scene triangle (Möller-Trumbore). O(triangles) per element:
//! for tiny hand-made scenes and tests only.
use crate::lights::LightSet;
use crate::scene::Scene;
use crate::view::ViewSamples;
use glam::Vec3;

/// Mitsuba's `coordinate_system(n)` (Duff et al. 2017): (s, t) completing n to a right-handed frame.
pub fn coordinate_system(n: Vec3) -> (Vec3, Vec3) {
    let sign = 1.0f32.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x), Vec3::new(b, sign + n.y * n.y * a, -n.y))
}

/// All scene triangles, for ray casting.
pub struct CpuReference {
    triangles: Vec<[Vec3; 3]>,
    /// Ray offset (relative to the scene diagonal) for shadow rays.
    epsilon: f32,
}

impl CpuReference {
    pub fn new(scene: &Scene) -> CpuReference {
        let triangles = scene.meshes.iter().flat_map(|m| m.indices.iter().map(move |t| t.map(|v| m.positions[v as usize]))).collect();
        CpuReference { triangles, epsilon: 1e-5 * scene.diagonal().max(1e-6) }
    }

    /// Nearest hit distance along (o, d) in (0, t_max), with its triangle index.
    pub fn intersect(&self, o: Vec3, d: Vec3, t_max: f32) -> Option<(f32, usize)> {
        let mut best: Option<(f32, usize)> = None;
        for (k, [p0, p1, p2]) in self.triangles.iter().enumerate() {
            let (e1, e2) = (*p1 - *p0, *p2 - *p0);
            let pv = d.cross(e2);
            let det = e1.dot(pv);
            if det.abs() < 1e-12 {
                continue;
            }
            let inv = 1.0 / det;
            let tv = o - *p0;
            let u = tv.dot(pv) * inv;
            if !(0.0..=1.0).contains(&u) {
                continue;
            }
            let qv = tv.cross(e1);
            let v = d.dot(qv) * inv;
            if v < 0.0 || u + v > 1.0 {
                continue;
            }
            let t = e2.dot(qv) * inv;
            if t > 0.0 && t < best.map_or(t_max, |b| b.0) {
                best = Some((t, k));
            }
        }
        best
    }

    /// True when nothing blocks the segment from p (offset along the geometric normal toward the light)
    /// to the light at distance `dist` along `wo`.
    pub fn visible(&self, p: Vec3, geo_normal: Vec3, wo: Vec3, dist: f32) -> bool {
        let side = if geo_normal.dot(wo) >= 0.0 { geo_normal } else { -geo_normal };
        let o = p + side * self.epsilon;
        let t_max = if dist.is_finite() { (o - (p + wo * dist)).length() * (1.0 - 1e-5) } else { f32::INFINITY };
        let d = if dist.is_finite() { ((p + wo * dist) - o).normalize() } else { wo };
        self.intersect(o, d, t_max).is_none()
    }

    /// A(i, j): light j's contribution to view sample i (RGB), with ray-cast visibility.
    pub fn element(&self, view: &ViewSamples, lights: &LightSet, i: usize, j: usize) -> Vec3 {
        self.element_with_visibility(view, lights, i, j).0
    }

    /// A(i, j) and whether the light is visible from sample i (false when it sends nothing).
    pub fn element_with_visibility(&self, view: &ViewSamples, lights: &LightSet, i: usize, j: usize) -> (Vec3, bool) {
        if view.shape_index[i] < 0 {
            return (Vec3::ZERO, false);
        }
        let p = view.position[i];
        let Some((wo, radiance, dist)) = lights.emitted(j, p, view.normal[i]) else {
            return (Vec3::ZERO, false);
        };
        let n = view.normal[i];
        let (s, t) = coordinate_system(n);
        let local = |v: Vec3| Vec3::new(v.dot(s), v.dot(t), v.dot(n));
        let f =
            lights.shade_receiver(j, p, wo, radiance, |w| crate::shading::bsdf::eval_records(&view.bsdf, i, local(view.wi[i]), local(w)));
        let vis = self.visible(p, view.geo_normal[i], wo, dist);
        (if vis { f } else { Vec3::ZERO }, vis)
    }

    /// Column j as H * W * 3 floats.
    pub fn column(&self, view: &ViewSamples, lights: &LightSet, j: usize) -> Vec<f32> {
        (0..view.len()).flat_map(|i| self.element(view, lights, i, j).to_array()).collect()
    }
}

#[cfg(test)]
mod tests;
