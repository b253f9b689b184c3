//! A host model of the GPU's watertight ray-triangle test (`hit_triangle` in `shaders/common/bvh.wgsl`),
//! line for line, with every `a*b +- c` and `a*b +- c*d` of the WGSL evaluated as the chosen
//! [`Contraction`]: as written (two roundings), or fused into `mul_add` in either grouping, as drivers
//! may do (WGSL has no way to forbid it). The tests fire rays exactly through shared edges and vertices
//! of meshes and count the rays that miss every triangle, for the shader's formulation and for the one
//! it replaced (`hit_triangle_unfiltered`: edge functions as plain differences of products, Dekker's
//! exact products only when one rounds to exactly 0), which misses under contraction.
//!
//! Test-only: the CPU tracer (`crate::raytrace`) is the reference renderer and is not modelled here.

/// How a driver evaluates `a*b - c*d` (and `x*y + z`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Fma {
    /// Each product rounded, then the sum (the WGSL as written).
    Separate,
    /// `fma(a, b, -(c*d))`: the first product fused.
    First,
    /// `fma(-c, d, a*b)`: the second product fused.
    Second,
}

/// The grouping at each site: the three edge functions may be fused differently (a compiler decides per
/// expression); `other` covers the projection and the t sum.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Contraction {
    pub edges: [Fma; 3],
    pub other: Fma,
}

impl Contraction {
    pub const fn uniform(f: Fma) -> Contraction {
        Contraction { edges: [f, f, f], other: f }
    }

    /// The variants the tests run: none, each grouping everywhere, and mixed groupings per edge.
    pub const ALL: [Contraction; 5] = [
        Contraction::uniform(Fma::Separate),
        Contraction::uniform(Fma::First),
        Contraction::uniform(Fma::Second),
        Contraction { edges: [Fma::First, Fma::Second, Fma::Separate], other: Fma::First },
        Contraction { edges: [Fma::Second, Fma::Separate, Fma::First], other: Fma::Second },
    ];
}

/// `a*b - c*d` as `f` evaluates it.
pub fn dop(a: f32, b: f32, c: f32, d: f32, f: Fma) -> f32 {
    match f {
        Fma::Separate => a * b - c * d,
        Fma::First => a.mul_add(b, -(c * d)),
        Fma::Second => (-c).mul_add(d, a * b),
    }
}

/// `a*b + c` (`c` not a product) as `f` evaluates it.
pub fn mad(a: f32, b: f32, c: f32, f: Fma) -> f32 {
    match f {
        Fma::Separate => a * b + c,
        _ => a.mul_add(b, c),
    }
}

/// `a*b + c*d` as `f` evaluates it.
pub fn sop(a: f32, b: f32, c: f32, d: f32, f: Fma) -> f32 {
    match f {
        Fma::Separate => a * b + c * d,
        Fma::First => a.mul_add(b, c * d),
        Fma::Second => c.mul_add(d, a * b),
    }
}

/// WGSL `WatertightRay`.
#[derive(Debug, Clone, Copy)]
pub struct WatertightRay {
    pub o: [f32; 3],
    pub kx: usize,
    pub ky: usize,
    pub kz: usize,
    pub sx: f32,
    pub sy: f32,
    pub sz: f32,
    pub t_min: f32,
}

/// WGSL `watertight_ray`.
pub fn watertight_ray(o: [f32; 3], d: [f32; 3]) -> WatertightRay {
    let a = d.map(f32::abs);
    let mut kz = 2;
    if a[0] >= a[1] && a[0] >= a[2] {
        kz = 0;
    } else if a[1] >= a[2] {
        kz = 1;
    }
    let mut kx = (kz + 1) % 3;
    let mut ky = (kx + 1) % 3;
    if d[kz] < 0.0 {
        std::mem::swap(&mut kx, &mut ky);
    }
    let ao = o.map(f32::abs);
    WatertightRay {
        o,
        kx,
        ky,
        kz,
        sx: d[kx] / d[kz],
        sy: d[ky] / d[kz],
        sz: 1.0 / d[kz],
        t_min: (1.0 + ao[0].max(ao[1]).max(ao[2])) * 9.536_743e-7,
    }
}

/// WGSL `EDGE_FILTER` (2^-21).
pub const EDGE_FILTER: f32 = 4.768_371_6e-7;

/// WGSL `split_bits`.
pub fn split_bits(a: f32) -> (f32, f32) {
    let hi = f32::from_bits(a.to_bits() & 0xffff_f000);
    (hi, a - hi)
}

/// WGSL `two_sum`.
pub fn two_sum(a: f32, b: f32) -> (f32, f32) {
    let s = a + b;
    let bb = s - a;
    (s, (a - (s - bb)) + (b - bb))
}

/// WGSL `grow4`: (lo, top).
fn grow4(e: [f32; 4], b: f32) -> ([f32; 4], f32) {
    let q0 = two_sum(b, e[0]);
    let q1 = two_sum(q0.0, e[1]);
    let q2 = two_sum(q1.0, e[2]);
    let q3 = two_sum(q2.0, e[3]);
    ([q0.1, q1.1, q2.1, q3.1], q3.0)
}

/// WGSL `grow2`.
fn grow2(e: [f32; 2], b: f32) -> [f32; 3] {
    let q0 = two_sum(b, e[0]);
    let q1 = two_sum(q0.0, e[1]);
    [q0.1, q1.1, q1.0]
}

/// WGSL `sum22`.
fn sum22(e: [f32; 2], f: [f32; 2]) -> [f32; 4] {
    let g = grow2(e, f[0]);
    let h = grow2([g[1], g[2]], f[1]);
    [g[0], h[0], h[1], h[2]]
}

/// WGSL `exact_diff_of_products`. Its products are of 12-bit halves, exact, so a fused multiply-add
/// rounds like a multiply then an add: no contraction switch is needed (the tests check that fusing
/// them changes nothing).
pub fn exact_diff_of_products(a: f32, b: f32, c: f32, d: f32, fuse: bool) -> f32 {
    let (sa, sb, sc, sd) = (split_bits(a), split_bits(b), split_bits(c), split_bits(d));
    let ts = |x: (f32, f32), y: (f32, f32)| -> (f32, f32) {
        if fuse {
            // fma(x0, x1, -(y0 y1)) for the sum; the error term as written.
            let s = x.0.mul_add(x.1, -(y.0 * y.1));
            let (p, q) = (x.0 * x.1, -(y.0 * y.1));
            let bb = s - p;
            (s, (p - (s - bb)) + (q - bb))
        } else {
            two_sum(x.0 * x.1, -(y.0 * y.1))
        }
    };
    let e0 = ts((sa.0, sb.0), (sc.0, sd.0));
    let e1 = ts((sa.0, sb.1), (sc.0, sd.1));
    let e2 = ts((sa.1, sb.0), (sc.1, sd.0));
    let e3 = ts((sa.1, sb.1), (sc.1, sd.1));
    let f = sum22([e0.1, e0.0], [e1.1, e1.0]);
    let g = sum22([e2.1, e2.0], [e3.1, e3.0]);
    let h0 = grow4(f, g[0]);
    let h1 = grow4([h0.0[1], h0.0[2], h0.0[3], h0.1], g[1]);
    let h2 = grow4([h1.0[1], h1.0[2], h1.0[3], h1.1], g[2]);
    let h3 = grow4([h2.0[1], h2.0[2], h2.0[3], h2.1], g[3]);
    let low = [h0.0[0], h1.0[0], h2.0[0], h3.0[0]];
    let high = [h3.0[1], h3.0[2], h3.0[3], h3.1];
    let mut top = 0.0f32;
    for v in low.iter().chain(&high) {
        if *v != 0.0 {
            top = *v;
        }
    }
    let sum = (((low[0] + low[1]) + (low[2] + low[3])) + high[0] + high[1]) + high[2] + high[3];
    if wgsl_sign(sum) == wgsl_sign(top) {
        sum
    } else {
        top
    }
}

/// WGSL `sign`: -1, 0 or 1.
fn wgsl_sign(x: f32) -> f32 {
    if x > 0.0 {
        1.0
    } else if x < 0.0 {
        -1.0
    } else {
        0.0
    }
}

/// WGSL `edge_function`.
pub fn edge_function(a: f32, b: f32, c: f32, d: f32, f: Fma) -> f32 {
    let e = dop(a, b, c, d, f);
    let bound = match f {
        Fma::Separate => (a * b).abs() + (c * d).abs(),
        _ => a.abs().mul_add(b.abs(), (c * d).abs()),
    };
    if e.abs() <= EDGE_FILTER * bound {
        return exact_diff_of_products(a, b, c, d, f != Fma::Separate);
    }
    e
}

/// The edge test of a triangle: `Some(t)` when it passes (t before the range check), as WGSL
/// `hit_triangle` (`unfiltered`: the formulation it replaced).
pub fn triangle_t(r: &WatertightRay, p0: [f32; 3], p1: [f32; 3], p2: [f32; 3], c: Contraction, unfiltered: bool) -> Option<f32> {
    let sub = |p: [f32; 3]| [p[0] - r.o[0], p[1] - r.o[1], p[2] - r.o[2]];
    let (a, b, cc) = (sub(p0), sub(p1), sub(p2));
    let f = c.other;
    let proj = |v: [f32; 3], s: f32, k: usize| mad(-s, v[r.kz], v[k], f);
    let (ax, ay) = (proj(a, r.sx, r.kx), proj(a, r.sy, r.ky));
    let (bx, by) = (proj(b, r.sx, r.kx), proj(b, r.sy, r.ky));
    let (cx, cy) = (proj(cc, r.sx, r.kx), proj(cc, r.sy, r.ky));
    let (u, v, w) = if unfiltered {
        let mut u = dop(cx, by, cy, bx, c.edges[0]);
        let mut v = dop(ax, cy, ay, cx, c.edges[1]);
        let mut w = dop(bx, ay, by, ax, c.edges[2]);
        if u == 0.0 || v == 0.0 || w == 0.0 {
            u = dekker_diff_of_products(cx, by, cy, bx, c.edges[0]);
            v = dekker_diff_of_products(ax, cy, ay, cx, c.edges[1]);
            w = dekker_diff_of_products(bx, ay, by, ax, c.edges[2]);
        }
        (u, v, w)
    } else {
        (edge_function(cx, by, cy, bx, c.edges[0]), edge_function(ax, cy, ay, cx, c.edges[1]), edge_function(bx, ay, by, ax, c.edges[2]))
    };
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return None;
    }
    let det = u + v + w;
    if det == 0.0 {
        return None;
    }
    let (za, zb, zc) = (r.sz * a[r.kz], r.sz * b[r.kz], r.sz * cc[r.kz]);
    let t_scaled = mad(w, zc, sop(u, za, v, zb, f), f);
    Some(t_scaled * (1.0 / det))
}

/// WGSL `hit_triangle`.
pub fn hit_triangle(r: &WatertightRay, p0: [f32; 3], p1: [f32; 3], p2: [f32; 3], t_max: f32, c: Contraction) -> bool {
    triangle_t(r, p0, p1, p2, c, false).is_some_and(|t| t > r.t_min && t < t_max)
}

/// The Dekker split and exact product of the replaced formulation (`4097 a`, then `c - (c - a)`), with
/// its products contracted as `f`.
fn dekker_split(a: f32, f: Fma) -> (f32, f32) {
    let c = 4097.0 * a;
    let hi = match f {
        Fma::Separate => c - (c - a),
        _ => 4097f32.mul_add(a, -4097f32.mul_add(a, -a)),
    };
    (hi, a - hi)
}

/// The replaced `diff_of_products`: Dekker's two-product error terms, contracted as `f`.
fn dekker_diff_of_products(a: f32, b: f32, c: f32, d: f32, f: Fma) -> f32 {
    let (sa, sb, sc, sd) = (dekker_split(a, f), dekker_split(b, f), dekker_split(c, f), dekker_split(d, f));
    let ep = mad(sa.1, sb.1, mad(sa.1, sb.0, mad(sa.0, sb.1, dop(sa.0, sb.0, a, b, f), f), f), f);
    let eq = mad(sc.1, sd.1, mad(sc.1, sd.0, mad(sc.0, sd.1, dop(sc.0, sd.0, c, d, f), f), f), f);
    dop(a, b, c, d, f) + (ep - eq)
}

#[cfg(test)]
mod tests;
