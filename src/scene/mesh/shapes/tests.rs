use super::*;

fn cross(d: &MeshData, t: &[u32; 3]) -> Vec3 {
    let p = |k: usize| d.positions[t[k] as usize];
    (p(1) - p(0)).cross(p(2) - p(0))
}

#[test]
fn rectangle_matches_mitsuba() {
    let d = rectangle();
    assert_eq!(d.positions[0], Vec3::new(-1., -1., 0.));
    assert_eq!(d.positions[3], Vec3::new(1., 1., 0.));
    assert_eq!(d.uvs[0], Vec2::ZERO);
    assert_eq!(d.uvs[1], Vec2::new(1., 0.));
    assert_eq!(d.indices, vec![[1, 2, 0], [1, 3, 2]]);
    for t in &d.indices {
        assert!(cross(&d, t).normalize() == Vec3::Z);
    }
}

#[test]
fn cube_matches_mitsuba() {
    let d = cube();
    assert_eq!((d.positions.len(), d.indices.len()), (24, 12));
    assert_eq!(d.indices[1], [3, 0, 2]);
    assert_eq!(d.indices[11], [23, 20, 22]);
    assert_eq!(d.uvs[6], Vec2::new(1., 0.));
    for (k, t) in d.indices.iter().enumerate() {
        let n = cross(&d, t).normalize();
        assert_eq!(n, d.normals[t[0] as usize], "triangle {k}: winding agrees with the normal");
        for &i in t {
            assert_eq!(d.positions[i as usize].dot(n), 1.0); // on the face plane, outward
        }
    }
}

#[test]
fn disk_is_an_upward_fan() {
    let d = disk();
    let n = DISK_SEGMENTS as usize;
    assert_eq!((d.positions.len(), d.indices.len()), (2 * n + 1, n));
    assert_eq!(d.positions[n], d.positions[0]);
    let area: f32 = d.indices.iter().map(|t| 0.5 * cross(&d, t).z).sum();
    let expect = 0.5 * n as f32 * (2.0 * PI / n as f32).sin();
    assert!((area - expect).abs() < 1e-5 && (area - PI).abs() < 4e-4, "{area}");
    assert!(d.indices.iter().all(|t| cross(&d, t).z > 0.0));
    // uv (r, phi/2pi): the rim point at phi = pi/2 has v = 1/4.
    assert_eq!(d.uvs[n / 4], Vec2::new(1.0, 0.25));
    assert!((d.positions[n / 4] - Vec3::Y).length() < 1e-6);
}

#[test]
fn sphere_is_closed_and_outward() {
    let d = sphere();
    let (np, nt) = (SPHERE_PHI_SEGMENTS as usize, SPHERE_THETA_SEGMENTS as usize);
    assert_eq!(d.positions.len(), (np + 1) * (nt + 1));
    assert_eq!(d.indices.len(), np * (2 * nt - 2));
    let mut volume = 0.0f64;
    for t in &d.indices {
        let c = cross(&d, t);
        assert!(c.length() > 0.0);
        let centroid = (d.positions[t[0] as usize] + d.positions[t[1] as usize] + d.positions[t[2] as usize]) / 3.0;
        assert!(c.dot(centroid) > 0.0, "outward");
        volume += (c.dot(d.positions[t[0] as usize]) / 6.0) as f64;
    }
    // Inscribed: slightly less than 4/3 pi (4.18879), by about 2 (1 - cos(pi/128)) relative.
    let exact = 4.0 / 3.0 * std::f64::consts::PI;
    assert!(volume < exact && exact - volume < 5e-3, "{volume}");
    for (p, (n, uv)) in d.positions.iter().zip(d.normals.iter().zip(&d.uvs)) {
        assert!((p.length() - 1.0).abs() < 1e-6 && p == n);
        // Mitsuba's uv: theta = acos(z) / pi, phi = atan2(y, x) / 2pi in [0, 1).
        assert!((uv.y - p.z.clamp(-1., 1.).acos() / PI).abs() < 1e-6);
        if p.z.abs() < 0.999 {
            let mut phi = p.y.atan2(p.x) / (2.0 * PI);
            if phi < 0.0 {
                phi += 1.0;
            }
            assert!((uv.x - phi).abs() < 1e-5 || (uv.x - 1.0).abs() < 1e-6 && phi < 1e-6, "{uv} {phi}");
        }
    }
}
