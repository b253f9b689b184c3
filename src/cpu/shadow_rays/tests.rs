//! The batch's rays are the ones `shade` casts: traced alone they give the matrix's own visibility.
use super::*;
use crate::cpu::shade;

#[test]
fn traced_rays_reproduce_the_matrix_visibility_element_by_element() {
    let p = crate::testing::backend_pair(16);
    let a = &p.cpu;
    let (m, n) = a.shape();
    let views: Vec<usize> = (0..m).step_by(3).collect();
    let lights: Vec<usize> = crate::testing::lights_of_every_kind(&a.lights, 3);
    let tracer = a.tracer().unwrap();
    for order in [Order::Columns, Order::Rows] {
        let rays = shadow_rays(&a.view, &a.lights, &views, &lights, order).unwrap();
        assert_eq!(rays.elements, (views.len() * lights.len()) as u64);
        let (blocked, _) = trace(&tracer, &rays.origin, &rays.direction, &rays.t_max).unwrap();
        let mut cast = 0;
        for k in 0..rays.view.len() {
            let (i, j) = (rays.view[k] as usize, rays.light[k] as usize);
            let s = shade(&tracer, &a.view, &a.lights, &ShadingPoint::new(&a.view, i), i, j);
            assert!(s.tested, "a ray for ({i}, {j}) that shade does not cast");
            assert_eq!(blocked[k], !s.lit, "element ({i}, {j})");
            cast += 1;
        }
        // Every element that shade tests has its ray in the batch, and some are blocked, some lit.
        let tested = views
            .iter()
            .flat_map(|&i| lights.iter().map(move |&j| (i, j)))
            .filter(|&(i, j)| shade(&tracer, &a.view, &a.lights, &ShadingPoint::new(&a.view, i), i, j).tested)
            .count();
        assert_eq!(cast, tested);
        assert!(blocked.iter().any(|&b| b) && blocked.iter().any(|&b| !b));
        if order == Order::Columns {
            // light by light, in the order asked for
            let first: Vec<u32> = rays.light.iter().fold(Vec::new(), |mut v, &j| {
                if v.last() != Some(&j) {
                    v.push(j);
                }
                v
            });
            assert!(first
                .windows(2)
                .all(|w| lights.iter().position(|&l| l as u32 == w[0]) < lights.iter().position(|&l| l as u32 == w[1])));
        }
    }
    assert!(shadow_rays(&a.view, &a.lights, &[m], &lights, Order::Rows).is_err());
    assert!(shadow_rays(&a.view, &a.lights, &views, &[n], Order::Rows).is_err());
    assert!(trace(&tracer, &[Vec3::ZERO], &[], &[1.0]).is_err());
}
