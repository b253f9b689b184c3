//! Compact equal-area strata of a triangle mesh emitter: the stratum of each area light.
//!
//! An emitter with T triangles of positive area and n >= T lights gives each triangle one light, the
//! rest in proportion to its area (largest remainder), and cuts a triangle with m lights into m
//! triangles of equal area by recursive bisection of the longest edge: a piece with m > 1 is cut on
//! its longest edge at the fraction floor(m/2) / m, the two parts getting floor(m/2) and m - floor(m/2)
//! lights. Cutting the longest edge keeps the pieces as compact as their triangle (measured on a square's
//! halves: longest edge^2 / (2 area) at most 4.35 at any m, against 2 for the halves; a sliver triangle's
//! pieces stay as thin as it is), so a piece's near field (`lights::patch`, a few piece radii) stays
//! close to it; the
//! stratification along the cumulative area that emitters with fewer lights than triangles keep makes
//! strips (measured median aspect 1,886:1 for 4,000 lights on a quad). Light k of the emitter stands
//! for piece k: a uniform point in it, weighted by the piece's area (A_t / m_t).
//!
//! Symbols: T triangles, n lights of the emitter, m_t lights of triangle t, A_t its area.
use glam::Vec3;

/// One stratum: a triangle of the mesh, the piece's corners as barycentric weights (w0, w1, w2) of that
/// triangle's vertices (the triangle's winding kept), and the piece's area (m^2).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Piece {
    pub triangle: usize,
    pub bary: [Vec3; 3],
    pub area: f64,
}

/// The compact strata (module docs) of `n` lights over `triangles` (corner positions) with the
/// cumulative areas `cdf`; None when n is below the number of triangles of positive area (then every
/// triangle cannot have a light of its own) or there is none.
pub fn compact_strata(triangles: &[[Vec3; 3]], cdf: &[f64], n: usize) -> Option<Vec<Piece>> {
    let areas: Vec<f64> = cdf.iter().enumerate().map(|(t, &c)| c - if t == 0 { 0.0 } else { cdf[t - 1] }).collect();
    let positive = areas.iter().filter(|&&a| a > 0.0).count();
    if positive == 0 || n < positive {
        return None;
    }
    let extra = super::area::split_counts(&areas, n - positive);
    let mut out = Vec::with_capacity(n);
    for (t, (&a, &x)) in areas.iter().zip(&extra).enumerate() {
        if a > 0.0 {
            let m = 1 + x;
            bisect(&triangles[t], t, [Vec3::X, Vec3::Y, Vec3::Z], m, a / m as f64, &mut out);
        }
    }
    Some(out)
}

/// Cut the piece with barycentric corners `b` of triangle `t` (positions `tri`) into `m` equal parts.
fn bisect(tri: &[Vec3; 3], t: usize, b: [Vec3; 3], m: usize, area: f64, out: &mut Vec<Piece>) {
    if m <= 1 {
        out.push(Piece { triangle: t, bary: b, area });
        return;
    }
    let pos = b.map(|w| tri[0] * w.x + tri[1] * w.y + tri[2] * w.z);
    // Edge (i, i + 1) with the opposite corner i + 2: cyclic, so both parts keep the winding.
    let i = (0..3)
        .max_by(|&x, &y| (pos[(x + 1) % 3] - pos[x]).length_squared().total_cmp(&(pos[(y + 1) % 3] - pos[y]).length_squared()))
        .unwrap_or(0);
    let (j, k) = ((i + 1) % 3, (i + 2) % 3);
    let m1 = m / 2;
    let f = m1 as f32 / m as f32;
    let q = b[i] + (b[j] - b[i]) * f;
    bisect(tri, t, [b[i], q, b[k]], m1, area, out);
    bisect(tri, t, [q, b[j], b[k]], m - m1, area, out);
}

#[cfg(test)]
mod tests;
