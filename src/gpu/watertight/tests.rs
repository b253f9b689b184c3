use super::*;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg32;
use std::collections::HashMap;

struct Mesh {
    name: &'static str,
    v: Vec<[f32; 3]>,
    t: Vec<[usize; 3]>,
    /// Ray origins from which every ray through an interior edge or vertex crosses the surface there
    /// (inside a star-shaped closed mesh, or above a planar fan or a gentle height field).
    origins: Vec<[f32; 3]>,
}

/// A closed fan of `n` triangles around a centre, in a random plane.
fn fan(n: usize, rng: &mut Pcg32) -> Mesh {
    let e1 = glam::Vec3::new(rng.random::<f32>() - 0.5, rng.random::<f32>() - 0.5, rng.random::<f32>() - 0.5).normalize();
    let e2 = e1.any_orthonormal_vector();
    let nrm = e1.cross(e2);
    let c = glam::Vec3::new(0.3, -0.2, 0.1);
    let mut v = vec![c.to_array()];
    for k in 0..n {
        let a = (k as f32 + 0.3 * rng.random::<f32>()) / n as f32 * std::f32::consts::TAU;
        let r = 0.5 + rng.random::<f32>();
        v.push((c + r * (a.cos() * e1 + a.sin() * e2)).to_array());
    }
    let t = (0..n).map(|k| [0, 1 + k, 1 + (k + 1) % n]).collect();
    let origins =
        (0..8).map(|_| (c + 3.0 * nrm + 0.4 * (rng.random::<f32>() - 0.5) * e1 + 0.4 * rng.random::<f32>() * e2).to_array()).collect();
    Mesh { name: "fan", v, t, origins }
}

/// An n x n height field of gentle random heights, quads split along alternating diagonals.
fn grid(n: usize, rng: &mut Pcg32) -> Mesh {
    let v = (0..=n).flat_map(|j| (0..=n).map(move |i| (i, j))).map(|(i, j)| [i as f32, j as f32, 0.0]).collect::<Vec<_>>();
    let v: Vec<[f32; 3]> = v.into_iter().map(|p| [p[0], p[1], 0.3 * rng.random::<f32>()]).collect();
    let id = |i: usize, j: usize| j * (n + 1) + i;
    let mut t = Vec::new();
    for j in 0..n {
        for i in 0..n {
            let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
            if (i + j) % 2 == 0 {
                t.extend([[a, b, c], [a, c, d]]);
            } else {
                t.extend([[a, b, d], [b, c, d]]);
            }
        }
    }
    let h = n as f32 * 1.5;
    let origins = (0..8).map(|_| [rng.random::<f32>() * n as f32, rng.random::<f32>() * n as f32, h]).collect();
    Mesh { name: "grid", v, t, origins }
}

/// The unit cube, 12 triangles, seen from inside.
fn cube(rng: &mut Pcg32) -> Mesh {
    let v = (0..8).map(|k| [(k & 1) as f32, ((k >> 1) & 1) as f32, ((k >> 2) & 1) as f32]).collect();
    let quads = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]];
    let t = quads.iter().flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]).collect();
    let origins =
        (0..8).map(|_| [0.1 + 0.8 * rng.random::<f32>(), 0.1 + 0.8 * rng.random::<f32>(), 0.1 + 0.8 * rng.random::<f32>()]).collect();
    Mesh { name: "cube", v, t, origins }
}

/// A random closed mesh: a latitude-longitude sphere with random radii (star-shaped about the origin),
/// seen from its centre.
fn lumpy_sphere(rings: usize, segments: usize, rng: &mut Pcg32) -> Mesh {
    let mut v = vec![[0.0, 0.0, 0.7 + 0.6 * rng.random::<f32>()], [0.0, 0.0, -(0.7 + 0.6 * rng.random::<f32>())]];
    for i in 1..rings {
        let th = i as f32 / rings as f32 * std::f32::consts::PI;
        for k in 0..segments {
            let ph = k as f32 / segments as f32 * std::f32::consts::TAU;
            let r = 0.7 + 0.6 * rng.random::<f32>();
            v.push([r * th.sin() * ph.cos(), r * th.sin() * ph.sin(), r * th.cos()]);
        }
    }
    let id = |i: usize, k: usize| 2 + (i - 1) * segments + k % segments;
    let mut t = Vec::new();
    for k in 0..segments {
        t.push([0, id(1, k), id(1, k + 1)]);
        t.push([1, id(rings - 1, k + 1), id(rings - 1, k)]);
        for i in 1..rings - 1 {
            t.extend([[id(i, k), id(i + 1, k), id(i + 1, k + 1)], [id(i, k), id(i + 1, k + 1), id(i, k + 1)]]);
        }
    }
    Mesh { name: "lumpy sphere", v, t, origins: vec![[0.0; 3], [1e-3, -2e-3, 5e-4]] }
}

/// Misses and false hits of rays through interior edges and vertices.
#[derive(Debug, Default, Clone, Copy)]
struct Count {
    rays: usize,
    misses: usize,
    false_hits: usize,
}

/// Fires rays from every origin of `mesh` (scaled by `scale`, moved by `offset` scales) through points
/// of its interior edges and through its interior vertices; a ray misses when none of the triangles at
/// its target (those of the edge and around its ends; those around the vertex) passes the edge test
/// with t > 0. A false hit: a triangle that touches neither the target
/// edge nor the target vertex passes (only checked on closed meshes from inside, where the ray crosses
/// the surface once).
fn fire(mesh: &Mesh, scale: f32, offset: f32, c: Contraction, unfiltered: bool, rng: &mut Pcg32) -> Count {
    let v: Vec<[f32; 3]> = mesh.v.iter().map(|p| p.map(|x| (x + offset) * scale)).collect();
    let mut edges: HashMap<(usize, usize), Vec<usize>> = HashMap::new();
    let mut at_vertex: HashMap<usize, Vec<usize>> = HashMap::new();
    for (k, t) in mesh.t.iter().enumerate() {
        for e in 0..3 {
            let (a, b) = (t[e], t[(e + 1) % 3]);
            edges.entry((a.min(b), a.max(b))).or_default().push(k);
            at_vertex.entry(a).or_default().push(k);
        }
    }
    let interior: Vec<((usize, usize), &Vec<usize>)> = edges.iter().filter(|(_, ts)| ts.len() == 2).map(|(e, ts)| (*e, ts)).collect();
    let closed = interior.len() == edges.len();
    let mut interior = interior;
    interior.sort();
    // A vertex is interior when all its edges are.
    let inner_vertex = |i: usize| edges.iter().filter(|((a, b), _)| *a == i || *b == i).all(|(_, ts)| ts.len() == 2);
    let mut targets: Vec<([f32; 3], Vec<usize>)> = Vec::new();
    for ((a, b), ts) in &interior {
        // The two triangles of the edge, and those around its ends (a point computed on the edge may
        // round onto an end vertex).
        let mut around = ts.to_vec();
        around.extend(at_vertex[a].iter().chain(&at_vertex[b]).filter(|k| !ts.contains(k)));
        around.sort();
        around.dedup();
        for _ in 0..4 {
            let s: f32 = rng.random::<f32>();
            let p = [0, 1, 2].map(|k| v[*a][k] + s * (v[*b][k] - v[*a][k]));
            targets.push((p, around.clone()));
        }
        targets.push(([0, 1, 2].map(|k| 0.5 * (v[*a][k] + v[*b][k])), around.clone()));
    }
    let mut verts: Vec<usize> = at_vertex.keys().copied().filter(|&i| inner_vertex(i)).collect();
    verts.sort();
    for i in verts {
        targets.push((v[i], at_vertex[&i].clone()));
    }
    let mut n = Count::default();
    for o in &mesh.origins {
        let o = o.map(|x| (x + offset) * scale);
        for (p, ts) in &targets {
            let d = glam::Vec3::from(*p) - glam::Vec3::from(o);
            let d = (d / d.length()).to_array();
            let r = watertight_ray(o, d);
            n.rays += 1;
            let tri = |k: usize| (v[mesh.t[k][0]], v[mesh.t[k][1]], v[mesh.t[k][2]]);
            let hit = ts.iter().any(|&k| {
                let (p0, p1, p2) = tri(k);
                triangle_t(&r, p0, p1, p2, c, unfiltered).is_some_and(|t| t > 0.0)
            });
            n.misses += !hit as usize;
            if closed {
                let far =
                    (0..mesh.t.len()).filter(|k| !ts.contains(k) && !ts.iter().any(|&j| mesh.t[j].iter().any(|x| mesh.t[*k].contains(x))));
                for k in far.take(3) {
                    let (p0, p1, p2) = tri(k);
                    n.false_hits += triangle_t(&r, p0, p1, p2, c, unfiltered).is_some_and(|t| t > 0.0) as usize;
                }
            }
        }
    }
    n
}

#[test]
fn rays_through_shared_edges_and_vertices_never_miss_under_any_contraction() {
    let mut rng = Pcg32::seed_from_u64(7);
    let meshes = [fan(12, &mut rng), grid(8, &mut rng), cube(&mut rng), lumpy_sphere(8, 12, &mut rng), lumpy_sphere(5, 7, &mut rng)];
    let mut old_misses = [0usize; 5];
    let mut total_rays = 0;
    for mesh in &meshes {
        for scale in [1e-12f32, 1e-6, 1.0, 1e6, 1e12] {
            for offset in [0.0f32, 250.0] {
                for (ci, c) in Contraction::ALL.iter().enumerate() {
                    let seed = rng.random::<u64>();
                    let new = fire(mesh, scale, offset, *c, false, &mut Pcg32::seed_from_u64(seed));
                    assert_eq!(new.misses, 0, "{} scale {scale} offset {offset} {c:?}: {new:?}", mesh.name);
                    assert_eq!(new.false_hits, 0, "{} scale {scale} offset {offset} {c:?}: {new:?}", mesh.name);
                    let old = fire(mesh, scale, offset, *c, true, &mut Pcg32::seed_from_u64(seed));
                    old_misses[ci] += old.misses;
                    total_rays += new.rays;
                }
            }
        }
    }
    eprintln!("{total_rays} rays per formulation; misses of the replaced formulation per contraction {old_misses:?}");
    // Without contraction the replaced formulation was watertight too; with it, it is not.
    assert_eq!(old_misses[0], 0);
    assert!(old_misses[1] > 0 && old_misses[2] > 0, "{old_misses:?}");
}

#[test]
fn exact_diff_of_products_has_the_exact_sign() {
    // Against f64 (exact for products of f32): random operands, near-cancelling ones, exact ties, and
    // values the 12-bit split leaves odd (subnormal halves are avoided: the edge test works in normals).
    let mut rng = Pcg32::seed_from_u64(3);
    let mut near = 0;
    for k in 0..200_000 {
        let e = (rng.random::<f32>() - 0.5) * 60.0;
        let (a, b) = ((rng.random::<f32>() - 0.5) * e.exp2(), (rng.random::<f32>() - 0.5) * e.exp2());
        let (c, d) = match k % 4 {
            0 => ((rng.random::<f32>() - 0.5) * e.exp2(), (rng.random::<f32>() - 0.5) * e.exp2()),
            // c d as close to a b as f32 allows: the same product, or one ulp off in one factor.
            1 => (b, a),
            2 => (f32::from_bits(a.to_bits() + 1), b),
            _ => {
                let c = (rng.random::<f32>() - 0.5) * e.exp2();
                (c, (a as f64 * b as f64 / c as f64) as f32)
            }
        };
        let exact = a as f64 * b as f64 - c as f64 * d as f64;
        for fuse in [false, true] {
            let got = exact_diff_of_products(a, b, c, d, fuse);
            assert_eq!(got.partial_cmp(&0.0), exact.partial_cmp(&0.0), "{a} {b} {c} {d}: {got} vs {exact}");
            assert!((got as f64 - exact).abs() <= 1e-6 * exact.abs(), "{a} {b} {c} {d}: {got} vs {exact}");
            for f in [Fma::Separate, Fma::First, Fma::Second] {
                let e = edge_function(a, b, c, d, f);
                assert_eq!(e.partial_cmp(&0.0), exact.partial_cmp(&0.0), "{f:?} {a} {b} {c} {d}");
            }
        }
        near += (dop(a, b, c, d, Fma::First).partial_cmp(&0.0) != exact.partial_cmp(&0.0)) as usize;
    }
    // Fused, the plain difference gets the sign wrong on near-cancelling operands.
    assert!(near > 1000, "{near}");
}

#[test]
fn the_model_mirrors_the_wgsl() {
    let wgsl = crate::gpu::shaders::OCCLUDED;
    for line in [
        "let u = edge_function(cx, by, cy, bx);",
        "let v = edge_function(ax, cy, ay, cx);",
        "let w = edge_function(bx, ay, by, ax);",
        "const EDGE_FILTER: f32 = 4.76837158203125e-7;",
        "let hi = bitcast<f32>(bitcast<u32>(a) & 0xfffff000u);",
        "if abs(e) <= EDGE_FILTER * (abs(a * b) + abs(c * d)) {",
        "let t_scaled = u * (r.sz * a[r.kz]) + v * (r.sz * b[r.kz]) + w * (r.sz * c[r.kz]);",
        "return select(top, sum, sign(sum) == sign(top));",
    ] {
        assert!(wgsl.contains(line), "bvh.wgsl no longer has `{line}`: update src/gpu/watertight.rs");
    }
    assert_eq!(EDGE_FILTER, 2f32.powi(-21));
    assert!(!wgsl.contains("4097.0"), "Dekker's multiplicative split does not survive contraction");
}
