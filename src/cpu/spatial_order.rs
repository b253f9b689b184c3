//! The order in which the CPU backend's rows trace a row's lights: neighbours in space next to each other,
//! so the rays of one view sample's packet (16 consecutive lights of this order) leave it in similar
//! directions and Embree's packet traversal shares its way through the BVH (docs/validation/backends.md,
//! "Coherent packets"). The values of the row do not depend on it: each element is computed alone and
//! written at its own light's place.
//!
//! | here | meaning |
//! |---|---|
//! | n | lights |
//! | `lo`, `hi` | bounding box of the lights' positions (of the directional lights' directions) |
//! | key | group (0 at a position, 1 directional) above a 30-bit Morton code of the cell, 10 bits per axis |
use crate::lights::LightSet;
use glam::Vec3;
use rayon::prelude::*;

/// The light indices 0..n in Morton order of the lights' positions (10 bits per axis over their bounding
/// box), directional lights last in Morton order of their directions: neighbours in this order are
/// neighbours in space, so a view sample's rays to consecutive lights of it form coherent packets. `rows`
/// trace in this order: 1.3-2.6x the rays per second of the lights' own order on the benchmark's row
/// batches (docs/validation/backends.md); each element is computed alone, so the values do not change.
pub fn spatial_order(lights: &LightSet) -> Vec<u32> {
    let n = lights.len();
    let at_infinity = |j: usize| lights.kind[j] == crate::lights::LightKind::Directional;
    let point = |j: usize| if at_infinity(j) { lights.direction[j] } else { lights.position[j] };
    let (mut lo, mut hi) = ([Vec3::INFINITY; 2], [Vec3::NEG_INFINITY; 2]);
    for j in 0..n {
        let (p, g) = (point(j), at_infinity(j) as usize);
        if p.is_finite() {
            lo[g] = lo[g].min(p);
            hi[g] = hi[g].max(p);
        }
    }
    let key = |j: usize| -> u64 {
        let (p, g) = (point(j), at_infinity(j) as usize);
        let cell = ((p - lo[g]) / (hi[g] - lo[g]).max(Vec3::splat(1e-30)) * 1023.0).clamp(Vec3::ZERO, Vec3::splat(1023.0));
        let (x, y, z) = if p.is_finite() { (cell.x as u64, cell.y as u64, cell.z as u64) } else { (1023, 1023, 1023) };
        let mut m = 0u64;
        for b in 0..10 {
            m |= ((x >> b) & 1) << (3 * b) | ((y >> b) & 1) << (3 * b + 1) | ((z >> b) & 1) << (3 * b + 2);
        }
        (g as u64) << 32 | m
    };
    let mut keyed: Vec<(u64, u32)> = (0..n).map(|j| (key(j), j as u32)).collect();
    keyed.par_sort_unstable();
    keyed.into_iter().map(|(_, j)| j).collect()
}
