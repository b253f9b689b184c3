use super::*;

/// int_P cos_r cos_l / r^2 dA by a fine midpoint rule over the quad (bilinear map), clipped by sign.
fn brute(c: &[Vec3; 4], p: Vec3, n: Vec3, res: usize) -> (f64, f64) {
    let nl = (c[1] - c[0]).cross(c[3] - c[0]).normalize();
    let (mut s, mut a) = (0.0f64, 0.0f64);
    for iu in 0..res {
        for iv in 0..res {
            let (u, w) = ((iu as f32 + 0.5) / res as f32, (iv as f32 + 0.5) / res as f32);
            let q = |u: f32, w: f32| (c[0] * (1.0 - u) + c[1] * u) * (1.0 - w) + (c[3] * (1.0 - u) + c[2] * u) * w;
            let x = q(u, w);
            let du = (q(u + 0.5 / res as f32, w) - q(u - 0.5 / res as f32, w)) as Vec3;
            let dw = q(u, w + 0.5 / res as f32) - q(u, w - 0.5 / res as f32);
            let da = du.cross(dw).length() as f64;
            let d = x - p;
            let r2 = d.length_squared() as f64;
            let cr = n.dot(d) as f64 / r2.sqrt();
            if cr <= 0.0 {
                continue;
            }
            let cl = (nl.dot(-d) as f64 / r2.sqrt()).abs();
            s += cr * cl / r2 * da;
            a += da;
        }
    }
    (s, a)
}

#[test]
fn projected_solid_angle_matches_quadrature_and_disc_formula() {
    // A trapezoid 1 cm above a receiver facing it, one tilted and crossing the receiver's plane.
    let trap = [Vec3::new(-0.1, -0.05, 0.01), Vec3::new(0.1, -0.05, 0.01), Vec3::new(0.05, 0.05, 0.01), Vec3::new(-0.05, 0.05, 0.01)];
    for (c, p, n) in [
        (trap, Vec3::new(0.02, 0.01, 0.0), Vec3::Z),
        (trap, Vec3::new(0.3, 0.0, 0.0), Vec3::new(-1.0, 0.0, 1.0).normalize()),
        (trap, Vec3::new(0.0, 0.0, 0.01 - 0.002), Vec3::new(0.3, 0.1, 1.0).normalize()),
    ] {
        let (psa, area) = clipped_projected_solid_angle(&c, p, n);
        let (s, a) = brute(&c, p, n, 2000);
        assert!(((psa as f64) - s).abs() < 2e-3 * s, "psa {psa} vs quadrature {s}");
        assert!(((area as f64) - a).abs() < 2e-3 * a.max(1e-6), "area {area} vs {a}");
    }
    // A receiver on the axis of a square: exact 4 * (x / sqrt(1+x^2) atan(x / sqrt(1+x^2)) ...):
    // compare with the closed form of a unit square at height h above a corner, times 4.
    let h = 0.5f64;
    let ff_corner = {
        // Form factor (times pi = PSA) from a point below the corner of an a x b rectangle at height h.
        let (x, y) = (1.0 / h, 1.0 / h);
        let t1 = x / (1.0 + x * x).sqrt() * (y / (1.0 + x * x).sqrt()).atan();
        let t2 = y / (1.0 + y * y).sqrt() * (x / (1.0 + y * y).sqrt()).atan();
        (t1 + t2) / 2.0
    };
    let sq = [Vec3::new(-1.0, -1.0, 0.5), Vec3::new(1.0, -1.0, 0.5), Vec3::new(1.0, 1.0, 0.5), Vec3::new(-1.0, 1.0, 0.5)];
    let (psa, area) = clipped_projected_solid_angle(&sq, Vec3::ZERO, Vec3::Z);
    assert!((psa as f64 - 4.0 * ff_corner).abs() < 1e-6 * 4.0 * ff_corner * 10.0, "{psa} vs {}", 4.0 * ff_corner);
    assert!((area - 4.0).abs() < 1e-6);
    // Entirely below the plane: nothing.
    assert_eq!(clipped_projected_solid_angle(&sq, Vec3::new(0.0, 0.0, 1.0), Vec3::Z), (0.0, 0.0));
}

#[test]
fn angle_between_is_accurate() {
    for t in [1e-6f32, 1e-3, 0.3, 1.0, 1.5707, 2.5, 3.1] {
        let a = Vec3::X;
        let b = Vec3::new(t.cos(), t.sin(), 0.0);
        assert!((angle_between(a, b) - t).abs() <= 3e-7 * t.max(1.0), "{t}: {}", angle_between(a, b));
    }
}

#[test]
fn checks_reject_nan_and_zero_area() {
    assert!(check(0, &[Vec3::ZERO; 4]).is_ok());
    let e = check(3, &[Vec3::X, Vec3::X * 2.0, Vec3::X * 3.0, Vec3::X * 4.0]).unwrap_err();
    assert!(e.to_string().contains("patch[3] has zero area"), "{e}");
    let e = check(1, &[Vec3::new(f32::NAN, 0.0, 0.0), Vec3::X, Vec3::Y, Vec3::ONE]).unwrap_err();
    assert!(e.to_string().contains("patch[1] must have finite corners"), "{e}");
}

/// The near field of a receiver lit from below its shading normal (a `twosided` wall whose triangles
/// face away from the light and the camera) clips the patch to the side the light is on. It used to
/// clip to the upper side only and return None: 0 for every near-field point of such a wall.
#[test]
fn near_field_clips_to_the_side_the_light_is_on() {
    // A 2 x 2 square 0.5 above p: PSA = 4 x the form factor (times pi) from below a corner of a unit
    // square at height 0.5 (closed form in f64), area 4.
    let sq = [Vec3::new(-1.0, -1.0, 0.5), Vec3::new(1.0, -1.0, 0.5), Vec3::new(1.0, 1.0, 0.5), Vec3::new(-1.0, 1.0, 0.5)];
    let (x, y) = (2.0f64, 2.0f64);
    let t1 = x / (1.0 + x * x).sqrt() * (y / (1.0 + x * x).sqrt()).atan();
    let t2 = y / (1.0 + y * y).sqrt() * (x / (1.0 + y * y).sqrt()).atan();
    let psa = 4.0 * (t1 + t2) / 2.0;
    let intensity = Vec3::new(1.0, 2.0, 3.0);
    let wo = Vec3::new(0.2, -0.1, 0.5).normalize();
    let expect = |c: f32| (psa / (4.0 * wo.z as f64)) * c as f64;
    let front = near_field(&sq, intensity, Vec3::ZERO, Vec3::Z, wo).unwrap();
    let back = near_field(&sq, intensity, Vec3::ZERO, -Vec3::Z, wo).expect("a receiver facing away is lit from its back");
    assert_eq!(front, back, "the same half-space, bit for bit");
    for (got, c) in [(back.x, 1.0), (back.y, 2.0), (back.z, 3.0)] {
        assert!((got as f64 / expect(c) - 1.0).abs() < 2e-6, "{got} vs {}", expect(c));
    }
    assert_eq!(receiver_side(-Vec3::Z, wo), Some((Vec3::Z, wo.z)));
    assert_eq!(receiver_side(Vec3::Z, wo), Some((Vec3::Z, wo.z)));
    // wo in the receiver's plane: nothing (the BSDF's cosine is 0 there).
    assert_eq!(receiver_side(Vec3::X, Vec3::Y), None);
    assert!(near_field(&sq, intensity, Vec3::ZERO, Vec3::X, Vec3::Y).is_none());
    // A patch straddling the receiver's plane: each side gets its own part, and the two parts' areas
    // add up to the patch's.
    let tilted = [Vec3::new(-0.5, 0.3, -0.4), Vec3::new(0.5, 0.3, -0.4), Vec3::new(0.5, 0.3, 0.6), Vec3::new(-0.5, 0.3, 0.6)];
    let (_, up) = clipped_projected_solid_angle(&tilted, Vec3::ZERO, Vec3::Z);
    let (_, down) = clipped_projected_solid_angle(&tilted, Vec3::ZERO, -Vec3::Z);
    assert!((up - 0.6).abs() < 1e-6 && (down - 0.4).abs() < 1e-6, "{up} {down}");
}
