use super::*;
use rand::{RngExt, SeedableRng};

/// Tolerance of f32 results against f64 closed forms (a few ulps of the largest coordinate).
const REL_TOL: f32 = 1e-5;

#[test]
fn triangle_hit_barycentrics_and_t() {
    let (p0, p1, p2) = (Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0));
    let o = Vec3::new(0.25, 0.5, 2.0);
    let d = Vec3::new(0.0, 0.0, -2.0);
    let hit = WatertightRay::new(o, d).intersect_triangle(p0, p1, p2, 0.0, f32::INFINITY).unwrap();
    assert_eq!(hit, TriangleHit { t: 1.0, b1: 0.25, b2: 0.5 });
    // Back side is hit too, from below.
    let hit = WatertightRay::new(Vec3::new(0.25, 0.5, -1.0), Vec3::Z).intersect_triangle(p0, p1, p2, 0.0, 5.0);
    assert_eq!(hit.map(|h| h.t), Some(1.0));
    // Interval is open and respected.
    assert!(WatertightRay::new(o, d).intersect_triangle(p0, p1, p2, 0.0, 1.0).is_none());
    assert!(WatertightRay::new(o, d).intersect_triangle(p0, p1, p2, 1.0, 2.0).is_none());
    // Outside.
    assert!(WatertightRay::new(Vec3::new(0.75, 0.5, 2.0), d).intersect_triangle(p0, p1, p2, 0.0, 9.0).is_none());
}

#[test]
fn shared_edge_is_watertight() {
    // A quad split along its diagonal; rays exactly through the diagonal must hit one of the halves.
    let q = [Vec3::new(0.0, 0.0, 0.3), Vec3::new(1.0, 0.0, 0.3), Vec3::new(1.0, 1.0, 0.3), Vec3::new(0.0, 1.0, 0.3)];
    let mut rng = rand_pcg::Pcg32::seed_from_u64(7);
    for _ in 0..10_000 {
        let s: f32 = rng.random();
        let target = q[0] + (q[2] - q[0]) * s;
        let o = Vec3::new(rng.random::<f32>() * 3.0 - 1.0, rng.random::<f32>() * 3.0 - 1.0, 2.0);
        let ray = WatertightRay::new(o, target - o);
        let h0 = ray.intersect_triangle(q[0], q[1], q[2], 0.0, 2.0);
        let h1 = ray.intersect_triangle(q[0], q[2], q[3], 0.0, 2.0);
        assert!(h0.is_some() || h1.is_some(), "ray through the shared edge leaked at s={s}");
    }
}

#[test]
fn sphere_matches_closed_form() {
    let mut rng = rand_pcg::Pcg32::seed_from_u64(11);
    let mut hits = 0;
    for _ in 0..20_000 {
        let center = Vec3::new(rng.random::<f32>() * 20.0 - 10.0, rng.random::<f32>() * 20.0 - 10.0, 3.0);
        let radius = 0.1 + rng.random::<f32>() * 3.0;
        let o = Vec3::new(rng.random::<f32>() * 40.0 - 20.0, rng.random::<f32>() * 40.0 - 20.0, rng.random::<f32>() * 40.0 - 20.0);
        // Aim near the sphere (about half the rays hit), with a non-unit direction.
        let aim = center + Vec3::new(rng.random::<f32>() - 0.5, rng.random::<f32>() - 0.5, rng.random::<f32>() - 0.5) * 3.0 * radius;
        let d = (aim - o) * (0.1 + rng.random::<f32>() * 3.0);
        // Closed form in f64: |o + t d - c|^2 = r^2.
        let (c64, o64, d64) = (center.as_dvec3(), o.as_dvec3(), d.as_dvec3());
        let l = o64 - c64;
        let (a, b, c) = (d64.dot(d64), 2.0 * l.dot(d64), l.dot(l) - (radius as f64).powi(2));
        let disc = b * b - 4.0 * a * c;
        let expected = if disc < 0.0 {
            None
        } else {
            let (t0, t1) = ((-b - disc.sqrt()) / (2.0 * a), (-b + disc.sqrt()) / (2.0 * a));
            if t0 > 0.0 {
                Some(t0)
            } else if t1 > 0.0 {
                Some(t1)
            } else {
                None
            }
        };
        let got = intersect_sphere(center, radius, o, d, 0.0, f32::INFINITY);
        match (expected, got) {
            (None, None) => {}
            (Some(e), Some(g)) => {
                hits += 1;
                let scale = (o64 - c64).length() / d64.length() + radius as f64;
                assert!(((g as f64) - e).abs() <= REL_TOL as f64 * scale, "t {g} vs {e}");
            }
            // Grazing rays may differ by rounding: allow only when the discriminant is tiny.
            (e, g) => assert!(disc.abs() < 1e-9 * b * b, "hit mismatch {e:?} vs {g:?}, disc {disc}"),
        }
    }
    assert!(hits > 5000, "too few hits ({hits}) for a meaningful test");
    // From inside, the far root is taken.
    let t = intersect_sphere(Vec3::ZERO, 2.0, Vec3::new(0.0, 0.0, 1.0), Vec3::Z, 0.0, f32::INFINITY);
    assert_eq!(t, Some(1.0));
    assert_eq!(intersect_sphere(Vec3::ZERO, 2.0, Vec3::new(0.0, 0.0, 1.0), Vec3::Z, 0.0, 1.0), None);
}
