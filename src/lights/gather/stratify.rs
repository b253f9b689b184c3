//! The divide-and-conquer area sampler of the gather cloud (Hašan, Pellacini, Bala 2006, Sec. 4.1; the
//! algorithm is described in `lights::gather`'s module docs): surface regions (triangles, sub-triangles,
//! sphere patches), their equal-area bisection, and the recursive split of a region set and its budget.
use super::{surface_point, triangle_vertices, SPHERE_TRIANGLE};
use crate::error::Result;
use crate::lights::generate::sampling::{uniform, uniform_triangle};
use crate::scene::{Scene, ShapeKind};
use glam::{Vec2, Vec3};
use rand_pcg::Pcg32;
use std::f32::consts::PI;

/// A region of surface the sampler divides (module docs).
#[derive(Debug, Clone, Copy)]
pub(super) enum Region {
    /// A sub-triangle of triangle `tri` of `shape`: its corners as barycentrics (b1, b2) and in world space.
    Triangle { shape: u32, tri: u32, corners: [Vec2; 3], world: [Vec3; 3], area: f64 },
    /// A rectangle z in [z0, z1], phi in [phi0, phi1] of a sphere (area r^2 (z1 - z0)(phi1 - phi0)).
    Sphere { shape: u32, center: Vec3, radius: f32, z: [f32; 2], phi: [f32; 2], area: f64 },
}

impl Region {
    pub(super) fn area(&self) -> f64 {
        match self {
            Region::Triangle { area, .. } | Region::Sphere { area, .. } => *area,
        }
    }

    fn centroid(&self) -> Vec3 {
        match self {
            Region::Triangle { world, .. } => (world[0] + world[1] + world[2]) / 3.0,
            Region::Sphere { center, .. } => *center,
        }
    }

    /// Two halves of equal area.
    fn bisect(&self) -> (Region, Region) {
        match *self {
            Region::Triangle { shape, tri, corners, world, area } => {
                // Longest edge (i, j), opposite vertex k; split at the edge's midpoint.
                let edges = [(0usize, 1usize, 2usize), (1, 2, 0), (2, 0, 1)];
                let &(i, j, k) = edges
                    .iter()
                    .max_by(|a, b| {
                        let la = world[a.0].distance_squared(world[a.1]);
                        let lb = world[b.0].distance_squared(world[b.1]);
                        la.total_cmp(&lb).then(b.0.cmp(&a.0))
                    })
                    .unwrap_or(&(0, 1, 2));
                let (mc, mw) = ((corners[i] + corners[j]) * 0.5, (world[i] + world[j]) * 0.5);
                let half = area * 0.5;
                (
                    Region::Triangle { shape, tri, corners: [corners[k], corners[i], mc], world: [world[k], world[i], mw], area: half },
                    Region::Triangle { shape, tri, corners: [corners[k], mc, corners[j]], world: [world[k], mw, world[j]], area: half },
                )
            }
            Region::Sphere { shape, center, radius, z, phi, area } => {
                let zm = 0.5 * (z[0] + z[1]);
                // Surface lengths: along theta (arc between the z bounds) and along phi at mid height.
                let theta_len = z[0].clamp(-1.0, 1.0).acos() - z[1].clamp(-1.0, 1.0).acos();
                let phi_len = (phi[1] - phi[0]) * (1.0 - zm * zm).max(0.0).sqrt();
                let half = area * 0.5;
                if theta_len >= phi_len {
                    (
                        Region::Sphere { shape, center, radius, z: [z[0], zm], phi, area: half },
                        Region::Sphere { shape, center, radius, z: [zm, z[1]], phi, area: half },
                    )
                } else {
                    let pm = 0.5 * (phi[0] + phi[1]);
                    (
                        Region::Sphere { shape, center, radius, z, phi: [phi[0], pm], area: half },
                        Region::Sphere { shape, center, radius, z, phi: [pm, phi[1]], area: half },
                    )
                }
            }
        }
    }

    /// A uniform point of the region: (shape, triangle, coords).
    fn sample(&self, rng: &mut Pcg32) -> (u32, u32, Vec2) {
        let (u1, u2) = (uniform(rng), uniform(rng));
        match *self {
            Region::Triangle { shape, tri, corners, .. } => {
                let b = uniform_triangle(u1, u2);
                let c = corners[0] * (1.0 - b.x - b.y) + corners[1] * b.x + corners[2] * b.y;
                (shape, tri, c.clamp(Vec2::ZERO, Vec2::ONE))
            }
            Region::Sphere { shape, z, phi, .. } => {
                let zz = (z[0] + (z[1] - z[0]) * u1).clamp(-1.0, 1.0);
                let ph = phi[0] + (phi[1] - phi[0]) * u2;
                (shape, SPHERE_TRIANGLE, Vec2::new(ph / (2.0 * PI), zz.acos() / PI))
            }
        }
    }
}

/// b_1 of a budget b split between areas a1 and the rest of `total` (module docs).
fn split_budget(b: usize, a1: f64, total: f64, rng: &mut Pcg32) -> usize {
    let exact = if total > 0.0 { b as f64 * (a1 / total) } else { b as f64 * 0.5 };
    ((exact + uniform(rng) as f64).floor() as usize).min(b)
}

/// Divides one region among `budget` samples (module docs).
fn stratify_region(r: Region, budget: usize, rng: &mut Pcg32, out: &mut Vec<(u32, u32, Vec2)>) {
    if budget == 0 {
        return;
    }
    if budget == 1 {
        out.push(r.sample(rng));
        return;
    }
    let (a, b) = r.bisect();
    let b1 = split_budget(budget, a.area(), r.area(), rng);
    stratify_region(a, b1, rng, out);
    stratify_region(b, budget - b1, rng, out);
}

/// The divide-and-conquer sampler over `regions` (module docs); an explicit stack keeps the depth
/// bounded whatever the areas.
pub(super) fn stratify(regions: &mut [Region], n: usize, rng: &mut Pcg32) -> Vec<(u32, u32, Vec2)> {
    let mut out = Vec::with_capacity(n);
    let mut stack = vec![(0usize, regions.len(), n)];
    while let Some((lo, hi, budget)) = stack.pop() {
        let set = &mut regions[lo..hi];
        if budget == 0 || set.is_empty() {
            continue;
        }
        if set.len() == 1 {
            stratify_region(set[0], budget, rng, &mut out);
            continue;
        }
        let total: f64 = set.iter().map(Region::area).sum();
        if budget == 1 {
            let target = uniform(rng) as f64 * total;
            let mut acc = 0.0;
            let mut pick = set.len() - 1;
            for (k, r) in set.iter().enumerate() {
                acc += r.area();
                if acc > target {
                    pick = k;
                    break;
                }
            }
            out.push(set[pick].sample(rng));
            continue;
        }
        let (mut lo_c, mut hi_c) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for r in set.iter() {
            lo_c = lo_c.min(r.centroid());
            hi_c = hi_c.max(r.centroid());
        }
        let ext = hi_c - lo_c;
        let axis = if ext.x >= ext.y && ext.x >= ext.z {
            0
        } else if ext.y >= ext.z {
            1
        } else {
            2
        };
        // Stable sort: equal centroids keep their (deterministic) order.
        set.sort_by(|a, b| a.centroid()[axis].total_cmp(&b.centroid()[axis]));
        // Split where the cumulative area is closest to half (each side non-empty).
        let (mut acc, mut split, mut a1, mut best) = (0.0f64, 1usize, 0.0f64, f64::INFINITY);
        for (k, r) in set[..set.len() - 1].iter().enumerate() {
            acc += r.area();
            let d = (acc - 0.5 * total).abs();
            if d < best {
                (best, split, a1) = (d, k + 1, acc);
            }
        }
        let b1 = split_budget(budget, a1, total, rng);
        let mid = lo + split;
        stack.push((mid, hi, budget - b1));
        stack.push((lo, mid, b1));
    }
    out
}

/// The sampled regions of a scene: every triangle with positive finite area, one region per sphere.
pub(super) fn scene_regions(scene: &Scene, include_emitters: bool) -> Result<Vec<Region>> {
    let mut regions = Vec::new();
    for (s, m) in scene.meshes.iter().enumerate() {
        if !include_emitters && m.emitter.is_some() {
            continue;
        }
        if let ShapeKind::Sphere { center, radius, .. } = m.kind {
            surface_point(scene, s, SPHERE_TRIANGLE, Vec2::ZERO)?; // checks centre and radius
            regions.push(Region::Sphere {
                shape: s as u32,
                center,
                radius,
                z: [-1.0, 1.0],
                phi: [0.0, 2.0 * PI],
                area: 4.0 * std::f64::consts::PI * (radius as f64).powi(2),
            });
            continue;
        }
        for t in 0..m.indices.len() {
            let [i0, i1, i2] = triangle_vertices(m, s, t)?;
            let world = [m.positions[i0], m.positions[i1], m.positions[i2]];
            let area = 0.5 * (world[1] - world[0]).as_dvec3().cross((world[2] - world[0]).as_dvec3()).length();
            if area > 0.0 && area.is_finite() {
                regions.push(Region::Triangle { shape: s as u32, tri: t as u32, corners: [Vec2::ZERO, Vec2::X, Vec2::Y], world, area });
            }
        }
    }
    Ok(regions)
}
