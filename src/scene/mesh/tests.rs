use super::*;
use crate::testing::scene_file;

fn loc() -> Location {
    Location::new("test.obj", 0)
}

fn quad() -> MeshData {
    MeshData {
        positions: vec![Vec3::new(0., 0., 0.), Vec3::new(1., 0., 0.), Vec3::new(1., 1., 0.), Vec3::new(0., 1., 0.)],
        normals: vec![],
        uvs: vec![],
        indices: vec![[0, 1, 2], [0, 2, 3]],
    }
}

/// Per shared mesh, from mitsuba 3.9.1 (scalar_rgb, identity to_world, `mi.load_dict`): path, vertex
/// count, face count (minus the zero-area faces we drop), index k, position 0, position k, normal 0,
/// normal k, last normal, uv 0, first face, last face.
#[rustfmt::skip]
#[allow(clippy::type_complexity)]
const MITSUBA: &[(&str, usize, usize, usize, [f32; 3], [f32; 3], [f32; 3], [f32; 3], [f32; 3], Option<[f32; 2]>, [u32; 3], [u32; 3])] = &[
    ("cbox/meshes/cbox_back.obj", 4, 2, 3, [549.5999755859375, 0.0, 559.2000122070312], [556.0, 548.7999877929688, 559.2000122070312], [0.0, 0.0, -1.0], [0.0, 0.0, -1.0], [0.0, 0.0, -1.0], None, [0, 1, 2], [0, 2, 3]),
    ("cbox/meshes/cbox_ceiling.obj", 8, 4, 7, [556.0, 548.7999877929688, 0.0], [343.0, 548.7999877929688, 227.0], [0.0, -1.0, 0.0], [0.0, 0.9999999403953552, 0.0], [0.0, 0.9999999403953552, 0.0], None, [0, 1, 2], [4, 6, 7]),
    ("cbox/meshes/cbox_floor.obj", 4, 2, 3, [552.7999877929688, 0.0, 0.0], [549.5999755859375, 0.0, 559.2000122070312], [0.0, 1.0, 0.0], [0.0, 1.0, 0.0], [0.0, 1.0, 0.0], None, [0, 1, 2], [0, 2, 3]),
    ("cbox/meshes/cbox_greenwall.obj", 4, 2, 3, [0.0, 0.0, 559.2000122070312], [0.0, 548.7999877929688, 559.2000122070312], [1.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 0.0, 0.0], None, [0, 1, 2], [0, 2, 3]),
    ("cbox/meshes/cbox_largebox.obj", 24, 12, 7, [423.0, 330.0, 247.0], [472.0, 0.0, 406.0], [0.0, 1.0, 0.0], [0.9556490182876587, 0.0, -0.2945080101490021], [0.0, -1.0, 0.0], None, [0, 1, 2], [20, 22, 23]),
    ("cbox/meshes/cbox_luminaire.obj", 4, 2, 3, [343.0, 548.7999877929688, 227.0], [213.0, 548.7999877929688, 227.0], [0.0, -1.0, 0.0], [0.0, -0.9999999403953552, 0.0], [0.0, -0.9999999403953552, 0.0], None, [0, 1, 2], [0, 2, 3]),
    ("cbox/meshes/cbox_redwall.obj", 4, 2, 3, [552.7999877929688, 0.0, 0.0], [556.0, 548.7999877929688, 0.0], [-0.9999581575393677, 0.008711210452020168, -0.0028269558679312468], [-0.999983012676239, 0.005830827169120312, 1.1137239741554339e-10], [-0.999983012676239, 0.005830827169120312, 1.1137239741554339e-10], None, [0, 1, 2], [0, 2, 3]),
    ("cbox/meshes/cbox_smallbox.obj", 24, 12, 7, [130.0, 165.0, 65.0], [240.0, 0.0, 272.0], [0.0, 1.0, 0.0], [0.9534001350402832, 0.0, 0.30170902609825134], [0.0, -1.0, 0.0], None, [0, 1, 2], [20, 22, 23]),
    ("cbox-lights/shortbox.obj", 8, 12, 7, [-1.0, -1.0, -1.0], [-1.0, 1.0, 1.0], [-0.5773503184318542, -0.5773503184318542, -0.5773503184318542], [-0.5773502588272095, 0.5773503184318542, 0.5773503184318542], [-0.5773502588272095, 0.5773503184318542, 0.5773503184318542], None, [0, 1, 2], [3, 6, 5]),
    ("matpreview/matpreview_0.ply", 289, 512, 7, [-0.5048662424087524, 0.5747208595275879, 0.7843790054321289], [-0.37986624240875244, 0.5747208595275879, 0.7843790054321289], [-0.0005493488279171288, -0.9891029000282288, 0.1472255140542984], [0.0, -0.9891532063484192, 0.14688821136951447], [0.0, 0.0, 1.0], Some([0.6446580290794373, 0.8092356324195862]), [0, 1, 2], [285, 288, 286]),
    ("matpreview/matpreview_1.ply", 2078, 3936, 7, [0.667028546333313, 0.27629226446151733, 0.06282293796539307], [0.49155735969543457, 0.491557240486145, 0.06282293796539307], [0.0708649680018425, 0.02935922145843506, 0.9970538020133972], [0.0, 0.0, 1.0], [0.5554186105728149, 0.8312205076217651, 0.024140652269124985], Some([0.15914541482925415, 0.3169771432876587]), [0, 1, 2], [1861, 2077, 1865]),
    ("matpreview/matpreview_2.ply", 29439, 57152, 7, [0.047490596771240234, -0.44950318336486816, -0.9026844501495361], [-5.064810102339834e-05, -0.4499431848526001, -0.9037290811538696], [0.0468159019947052, -0.3872535526752472, -0.9207839369773865], [0.0, -0.38783320784568787, -0.921729564666748], [0.48666131496429443, 0.520568311214447, 0.7015479207038879], Some([0.9039270281791687, 0.8643703460693359]), [0, 1, 2], [29438, 29380, 29428]),
    ("bunny/meshes/bunny.ply", 35947, 69451, 7, [-0.037829700857400894, 0.12793999910354614, 0.0044746701605618], [0.03321300074458122, 0.11269199848175049, 0.02768610045313835], [0.19486819207668304, 0.9727270603179932, -0.1258106231689453], [0.7254139184951782, 0.5106182098388672, 0.46156662702560425], [-0.0912192165851593, -0.5985832214355469, -0.7958499193191528], None, [21216, 21215, 20399], [17277, 17346, 17345]),
    ("bunny/meshes/plane.ply", 289, 512, 7, [-0.5048662424087524, 0.5747208595275879, 0.7843790054321289], [-0.37986624240875244, 0.5747208595275879, 0.7843790054321289], [-0.0005493488279171288, -0.9891029000282288, 0.1472255140542984], [0.0, -0.9891532063484192, 0.14688821136951447], [0.0, 0.0, 1.0], Some([0.6446580290794373, 0.8092356324195862]), [0, 1, 2], [285, 288, 286]),
    ("veach-ajar/models/Mesh001.obj", 24, 12, 7, [-1.0009119510650635, 0.6195629835128784, -3.9853079319000244], [-1.0009119510650635, -0.006744000129401684, -4.1053080558776855], [-1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0], Some([0.0, 1.0]), [0, 1, 2], [20, 22, 23]),
    ("veach-ajar/models/Mesh002.obj", 24, 12, 7, [-1.0009119510650635, 0.6195629835128784, -1.147596001625061], [-1.0009119510650635, -0.006744000129401684, -1.2675960063934326], [-1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0], Some([0.0, 1.0]), [0, 1, 2], [20, 22, 23]),
    ("veach-ajar/models/Mesh003.obj", 24, 12, 7, [-2.6203060150146484, 0.6195629835128784, -1.147596001625061], [-2.6203060150146484, -0.006744000129401684, -1.2675960063934326], [-1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0], Some([0.0, 1.0]), [0, 1, 2], [20, 22, 23]),
    ("veach-ajar/models/Mesh004.obj", 24, 12, 7, [-2.758241891860962, 0.6506209969520569, -1.0371359586715698], [-2.758241891860962, 0.5906209945678711, -4.237135887145996], [-1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0], Some([0.08055199682712555, 0.5125789642333984]), [0, 1, 2], [20, 22, 23]),
    ("veach-ajar/models/Mesh005.obj", 64, 44, 7, [-3.021946907043457, 2.760469913482666, -6.240964889526367], [-3.021946907043457, -0.016759999096393585, -6.44536018371582], [-1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 0.0, 1.0], Some([0.0, 1.0]), [0, 1, 2], [60, 62, 63]),
    ("veach-ajar/models/Mesh006.obj", 24, 12, 7, [-2.818228006362915, 2.7690250873565674, -4.689565181732178], [-2.3621859550476074, -0.012129999697208405, -6.182384967803955], [-0.9563608765602112, 0.0, -0.29218804836273193], [0.29218804836273193, 0.0, -0.9563608765602112], [0.0, 1.0, 0.0], Some([0.39680999517440796, 0.012881994247436523]), [0, 1, 2], [20, 22, 23]),
    ("veach-ajar/models/Mesh007.obj", 24, 12, 7, [-2.6203060150146484, 0.6195629835128784, -3.9853079319000244], [-2.6203060150146484, -0.006744000129401684, -4.1053080558776855], [-1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0], Some([0.0, 1.0]), [0, 1, 2], [20, 22, 23]),
    ("veach-ajar/models/Mesh008.obj", 4, 2, 3, [-2.798419952392578, 2.6736199855804443, -3.573873996734619], [-2.798419952392578, 1.8219469785690308, -3.573873996734619], [1.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 0.0, 0.0], Some([0.9911019802093506, 0.052024006843566895]), [0, 1, 2], [0, 2, 3]),
    ("veach-ajar/models/Mesh010.obj", 576, 372, 7, [-2.7981679439544678, 2.4348180294036865, -4.690145015716553], [-2.7905139923095703, 2.4348180294036865, -4.688621997833252], [0.09799867868423462, 0.0, -0.9951865673065186], [0.29030993580818176, 0.0, -0.9569327235221863], [0.0, -1.0, 0.0], Some([0.0, 1.0]), [0, 1, 2], [544, 574, 575]),
    ("veach-ajar/models/Mesh011.obj", 4, 2, 3, [-2.8499999046325684, 0.0, -7.599999904632568], [2.8499999046325684, 0.0, -7.599999904632568], [0.0, 1.0, 0.0], [0.0, 1.0, 0.0], [0.0, 1.0, 0.0], Some([0.9505890011787415, 0.011583983898162842]), [0, 1, 2], [0, 2, 3]),
    ("veach-ajar/models/Mesh012.obj", 960, 620, 7, [-2.7981679439544678, 0.2628839910030365, -4.690145015716553], [-2.7905139923095703, 0.2628839910030365, -4.688621997833252], [0.09799867868423462, 0.0, -0.9951865673065186], [0.29030993580818176, 0.0, -0.9569327235221863], [0.0, -1.0, 0.0], Some([0.0, 1.0]), [0, 1, 2], [928, 958, 959]),
    ("veach-ajar/models/Mesh013.obj", 24, 12, 7, [-2.9295430183410645, 2.747783899307251, -1.6618479490280151], [-2.9295430183410645, 1.7477840185165405, -3.6618480682373047], [-1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0], Some([0.0, 1.0]), [0, 1, 2], [20, 22, 23]),
    ("veach-ajar/models/Mesh014.obj", 112, 104, 7, [-2.8499999046325684, 0.0, -4.627807140350342], [2.8499999046325684, 2.9260001182556152, -7.599999904632568], [0.0, 0.0, 1.0], [0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], Some([0.0, 1.0]), [0, 1, 2], [107, 110, 111]),
    ("veach-ajar/models/Mesh015.obj", 1536, 2882, 7, [-2.3558850288391113, 1.2125630378723145, -6.029265880584717], [-2.3562839031219482, 1.2040159702301025, -6.028061866760254], [0.3248254656791687, 0.0, -0.9457740783691406], [0.31120565533638, -0.29030531644821167, -0.904916524887085], [0.9586110711097717, 0.0030000347178429365, 0.2847032845020294], Some([0.0, 1.0]), [0, 1, 2], [1471, 1472, 1408]),
    ("veach-ajar/models/Mesh016.obj", 576, 372, 7, [-2.7981679439544678, 1.3192919492721558, -4.690145015716553], [-2.7905139923095703, 1.3192919492721558, -4.688621997833252], [0.09799867868423462, 0.0, -0.9951865673065186], [0.29030993580818176, 0.0, -0.9569327235221863], [0.0, -1.0, 0.0], Some([0.0, 1.0]), [0, 1, 2], [544, 574, 575]),
];

#[test]
fn scene_meshes_match_mitsuba() {
    const NORMAL_TOL: f32 = 2e-6; // Mitsuba normalises with rsqrt, we divide by the length
    for &(file, nv, nf, k, p0, pk, n0, nk, nlast, uv0, f0, flast) in MITSUBA {
        let path = scene_file(file);
        let l = Location::new(&path, 0);
        let data = if file.ends_with(".obj") { load_obj(&path, &l) } else { load_ply(&path, &l) }.unwrap();
        let (p, n, uv, idx) = finalize(data, Mat4::IDENTITY, false, false, &l).unwrap();
        assert_eq!((p.len(), idx.len()), (nv, nf), "{file}");
        assert_eq!(p[0], Vec3::from_array(p0), "{file}");
        assert_eq!(p[k], Vec3::from_array(pk), "{file}");
        for (got, want) in [(n[0], n0), (n[k], nk), (n[nv - 1], nlast)] {
            assert!((got - Vec3::from_array(want)).abs().max_element() < NORMAL_TOL, "{file}: {got} vs {want:?}");
        }
        match uv0 {
            Some(u) => assert_eq!((uv.len(), uv[0]), (nv, Vec2::from_array(u)), "{file}"),
            None => assert!(uv.is_empty(), "{file}"),
        }
        assert_eq!((idx[0], idx[nf - 1]), (f0, flast), "{file}");
    }
}

#[test]
fn scene_meshes_all_normals_match_mitsuba() {
    // All normals of meshes with recomputed (shortbox, bunny: 1113 unreferenced vertices get (1,0,0))
    // and file normals, through a weighted sum sum_i (i % 13 + 1) n_i that catches sign, order and
    // weighting errors. Reference sums from mitsuba 3.9.1's vertex_normals_buffer().
    #[rustfmt::skip]
    const NORMAL_SUMS: &[(&str, [f64; 3])] = &[
    ("cbox-lights/shortbox.obj", [2.309401512145996, 2.309401512145996, 9.237604975700378]),
    ("bunny/meshes/bunny.ply", [8257.638581313704, 7728.777708779569, 5003.95210958067]),
    ("matpreview/matpreview_2.ply", [18908.16432808786, 1202.579982693489, -4250.681805809676]),
    ("veach-ajar/models/Mesh015.obj", [-352.08555649849586, -2.196886327350512, -91.07796416338533]),
    ("veach-ajar/models/Mesh012.obj", [1.8755085095763206, -4.0, 15.106586217880249]),
    ];
    for (file, sum) in NORMAL_SUMS {
        let path = scene_file(file);
        let l = Location::new(&path, 0);
        let data = if file.ends_with(".obj") { load_obj(&path, &l) } else { load_ply(&path, &l) }.unwrap();
        let (_, n, _, _) = finalize(data, Mat4::IDENTITY, false, false, &l).unwrap();
        let s = n.iter().enumerate().fold(glam::DVec3::ZERO, |a, (i, v)| a + v.as_dvec3() * (i % 13 + 1) as f64);
        assert!((s - glam::DVec3::from_array(*sum)).abs().max_element() < 1e-3, "{file}: {s}");
    }
}

#[test]
fn transformed_shapes_match_mitsuba() {
    // to_world = translate(1,2,3) * rotate(axis (1,1,0), 30 deg) * scale(1, 2, 0.5), as Mitsuba builds it
    // (row-major matrix printed by mitsuba 3.9.1); positions, first/last normals and the weighted
    // normal sum sum_i (i % 13 + 1) n_i from Mitsuba's buffers.
    #[rustfmt::skip]
    let m = Mat4::from_cols_array_2d(&[
        [1.0, 0.1339746117591858, -0.5, 0.0], [0.2679492235183716, 2.0, 1.0, 0.0],
        [0.25, -0.25, 0.4330126941204071, 0.0], [1.0, 2.0, 3.0, 1.0],
    ]);
    let shortbox = scene_file("cbox-lights/shortbox.obj");
    #[rustfmt::skip]
    let cases: [(&str, MeshData, [[f32; 3]; 2], [[f32; 3]; 2], [f64; 3]); 3] = [
        ("obj", load_obj(&shortbox, &loc()).unwrap(),
         [[-0.5179492235183716, 0.11602544784545898, 2.0669872760772705], [0.5179492235183716, 3.616025447845459, 4.93301248550415]],
         [[-0.8355879187583923, -0.31985265016555786, -0.4466398358345032], [-0.1883901059627533, 0.1883900910615921, 0.9638559818267822]],
         [6.442088961601257, -1.8203276097774506, 7.155463233590126]),
        ("cube", cube(),
         [[1.4820507764816284, 0.383974552154541, 1.0669872760772705], [0.017949223518371582, 4.116025447845459, 4.06698751449585]],
         [[-0.11897933483123779, -0.8880738019943237, -0.44403690099716187], [-0.44721361994743347, 0.44721361994743347, -0.7745966911315918]],
         [11.168086618185043, 25.08582630753517, -16.49348473548889]),
        ("rectangle", rectangle(),
         [[-0.2679492235183716, -0.13397455215454102, 2.5], [2.267949104309082, 4.133974552154541, 3.5]],
         [[0.44721361994743347, -0.44721361994743347, 0.7745966911315918]; 2],
         [4.472136199474335, -4.472136199474335, 7.745966911315918]),
    ];
    // The same transform built as the XML loader does: Mitsuba's normal matrix for a rotation about the
    // non-unit axis (1, 1, 0) is the rotation matrix itself, not the inverse transpose.
    let attrs = |v: &[(&str, &str)]| v.iter().map(|(k, x)| (k.to_string(), x.to_string())).collect::<Vec<_>>();
    let mut t = crate::scene::transform::Affine::IDENTITY;
    for (tag, a) in [
        ("scale", attrs(&[("x", "1"), ("y", "2"), ("z", "0.5")])),
        ("rotate", attrs(&[("x", "1"), ("y", "1"), ("angle", "30")])),
        ("translate", attrs(&[("value", "1 2 3")])),
    ] {
        t = crate::scene::transform::apply_op(t, tag, &a, &loc()).unwrap();
    }
    assert!((t.matrix.as_mat4() - m).abs().to_cols_array().iter().all(|d| *d < 1e-6), "{}", t.matrix);
    let nm = glam::DMat3::from_mat4(t.inverse_transpose).as_mat3();
    for (name, data, p_ends, n_ends, n_sum) in cases {
        let (p, n, _, _) = finalize_with_normal_matrix(data, m, nm, false, false, &loc()).unwrap();
        let last = p.len() - 1;
        for (got, want) in [(p[0], p_ends[0]), (p[last], p_ends[1])] {
            assert!((got - Vec3::from_array(want)).abs().max_element() < 1e-6, "{name}: {got} vs {want:?}");
        }
        for (got, want) in [(n[0], n_ends[0]), (n[last], n_ends[1])] {
            assert!((got - Vec3::from_array(want)).abs().max_element() < 2e-6, "{name}: {got} vs {want:?}");
        }
        let s = n.iter().enumerate().fold(glam::DVec3::ZERO, |a, (i, v)| a + v.as_dvec3() * (i % 13 + 1) as f64);
        assert!((s - glam::DVec3::from_array(n_sum)).abs().max_element() < 1e-4, "{name}: {s}");
    }
}

#[test]
fn finalize_transforms_positions_and_normals() {
    let mut d = quad();
    d.normals = vec![Vec3::new(1., 0., 1.); 4];
    let m = Mat4::from_translation(Vec3::new(1., 2., 3.)) * Mat4::from_scale(Vec3::new(2., 1., 1.));
    let (p, n, uv, idx) = finalize(d, m, false, false, &loc()).unwrap();
    assert_eq!(p[2], Vec3::new(3., 3., 3.));
    // Inverse transpose of diag(2,1,1) maps (1,0,1) to (0.5,0,1).
    let expect = Vec3::new(0.5, 0., 1.).normalize();
    assert!((n[0] - expect).abs().max_element() < 1e-7, "{}", n[0]);
    assert!(uv.is_empty());
    assert_eq!(idx, vec![[0, 1, 2], [0, 2, 3]]);
}

#[test]
fn recomputed_normals_are_angle_weighted() {
    // Vertex 0 of a "tent": face A (in z=0, angle 90 deg at v0) and face B (in x=0, angle 45 deg at v0).
    let positions = vec![Vec3::ZERO, Vec3::new(1., 0., 0.), Vec3::new(0., 1., 0.), Vec3::new(0., 1., 1.)];
    // A: (0,1,2) normal +z, angle pi/2 at v0. B: (0,2,3) normal cross((0,1,0),(0,1,1)) = (1,0,0), angle pi/4.
    let n = angle_weighted_normals(&positions, &[[0, 1, 2], [0, 2, 3]]);
    let pi = std::f32::consts::PI;
    let expect = (Vec3::Z * (pi / 2.) + Vec3::X * (pi / 4.)).normalize();
    assert!((n[0] - expect).abs().max_element() < 1e-6, "{} vs {}", n[0], expect);
    // Both faces have area 1/2, so area weighting would give normalize(x + z): must differ.
    assert!((n[0] - Vec3::new(1., 0., 1.).normalize()).length() > 0.1);
    // Vertex 1 is only in A.
    assert_eq!(n[1], Vec3::Z);
}

#[test]
fn unreferenced_vertex_gets_fallback_normal() {
    let mut d = quad();
    d.positions.push(Vec3::new(5., 5., 5.));
    let (_, n, _, _) = finalize(d, Mat4::IDENTITY, false, false, &loc()).unwrap();
    assert_eq!(n[4], Vec3::X);
    assert_eq!(n[0], Vec3::Z);
}

#[test]
fn face_normals_unshare_vertices() {
    let mut d = quad();
    d.uvs = vec![Vec2::new(0., 0.), Vec2::new(1., 0.), Vec2::new(1., 1.), Vec2::new(0., 1.)];
    let (p, n, uv, idx) = finalize(d, Mat4::IDENTITY, true, false, &loc()).unwrap();
    assert_eq!(p.len(), 6);
    assert_eq!(idx, vec![[0, 1, 2], [3, 4, 5]]);
    assert!(n.iter().all(|&v| v == Vec3::Z));
    assert_eq!(uv[5], Vec2::new(0., 1.));
    assert_eq!(p[4], Vec3::new(1., 1., 0.));
}

#[test]
fn flip_normals_negates_and_rewinds() {
    let (p, n, _, idx) = finalize(quad(), Mat4::IDENTITY, false, true, &loc()).unwrap();
    assert_eq!(n[0], -Vec3::Z);
    assert_eq!(idx[0], [0, 2, 1]);
    let c = face_cross(&p, &idx[0]).normalize();
    assert_eq!(c, -Vec3::Z);
}

#[test]
fn nan_vertex_is_an_error() {
    let mut d = quad();
    d.positions[2].y = f32::NAN;
    let e = finalize(d, Mat4::IDENTITY, false, false, &loc()).unwrap_err().to_string();
    assert!(e.contains("test.obj") && e.contains("vertex 2") && e.contains("NaN"), "{e}");
    let mut d = quad();
    d.positions[1].x = f32::INFINITY;
    let e = finalize(d, Mat4::IDENTITY, false, false, &loc()).unwrap_err().to_string();
    assert!(e.contains("vertex 1") && e.contains("inf"), "{e}");
}

#[test]
fn index_out_of_range_is_an_error() {
    let mut d = quad();
    d.indices.push([0, 3, 9]);
    let e = finalize(d, Mat4::IDENTITY, false, false, &loc()).unwrap_err().to_string();
    assert!(e.contains("triangle 2") && e.contains("vertex 9") && e.contains("4 vertices"), "{e}");
}

#[test]
fn zero_area_triangles_are_dropped() {
    let mut d = quad();
    d.positions.push(Vec3::new(2., 0., 0.));
    d.indices.insert(1, [0, 1, 4]); // collinear
    d.indices.push([1, 1, 2]); // repeated index
    let (_, n, _, idx) = finalize(d, Mat4::IDENTITY, false, false, &loc()).unwrap();
    assert_eq!(idx, vec![[0, 1, 2], [0, 2, 3]]);
    assert_eq!(n[4], Vec3::X); // now unreferenced
}

#[test]
fn all_zero_area_gives_an_empty_mesh() {
    let d = MeshData {
        positions: vec![Vec3::ZERO, Vec3::X, Vec3::X * 2.0, Vec3::Y],
        normals: vec![],
        uvs: vec![],
        indices: vec![[0, 1, 2], [0, 0, 3]],
    };
    let (p, n, uv, idx) = finalize(d, Mat4::IDENTITY, false, false, &loc()).unwrap();
    assert!(p.is_empty() && n.is_empty() && uv.is_empty() && idx.is_empty());
}

#[test]
fn bad_attribute_lengths_are_errors() {
    let mut d = quad();
    d.normals = vec![Vec3::Z; 3];
    assert!(finalize(d, Mat4::IDENTITY, false, false, &loc()).is_err());
    let mut d = quad();
    d.normals = vec![Vec3::ZERO; 4];
    let e = finalize(d, Mat4::IDENTITY, false, false, &loc()).unwrap_err().to_string();
    assert!(e.contains("vertex 0") && e.contains("invalid normal"), "{e}");
}
