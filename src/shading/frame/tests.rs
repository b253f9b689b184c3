use super::*;

/// A scene of one `shape` (XML, without its BSDF) with `bsdf` (XML), loaded from a temporary file.
fn one_shape(tag: &str, shape: &str, bsdf: &str) -> Scene {
    let xml = format!(
        r#"<scene version="3.0.0">
        <sensor type="perspective"><film type="hdrfilm"><integer name="width" value="4"/><integer name="height" value="4"/></film></sensor>
        <shape type="{shape}">{bsdf}</shape></scene>"#
    );
    let dir = std::env::temp_dir().join(format!("ml-frame-{}-{tag}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("scene.xml");
    std::fs::write(&path, xml).unwrap();
    crate::scene::load_scene(&path, &Default::default()).unwrap()
}

const ANISO: &str = r#"<bsdf type="roughconductor"><float name="alpha_u" value="0.05"/><float name="alpha_v" value="0.3"/></bsdf>"#;
const ISO: &str = r#"<bsdf type="roughconductor"><float name="alpha" value="0.1"/></bsdf>"#;

#[test]
fn anisotropic_lobes_are_found_through_wrappers() {
    let s = one_shape("aniso", "rectangle", ANISO);
    assert!(anisotropic(&s, s.meshes[0].bsdf));
    let s = one_shape("iso", "rectangle", ISO);
    assert!(!anisotropic(&s, s.meshes[0].bsdf));
    let wrapped = format!(r#"<bsdf type="twosided"><bsdf type="blendbsdf"><float name="weight" value="0.5"/>{ISO}{ANISO}</bsdf></bsdf>"#);
    let s = one_shape("wrapped", "rectangle", &wrapped);
    assert!(anisotropic(&s, s.meshes[0].bsdf));
    let p = r#"<bsdf type="principled"><float name="anisotropic" value="0.9"/></bsdf>"#;
    let s = one_shape("principled", "rectangle", p);
    assert!(anisotropic(&s, s.meshes[0].bsdf));
    let p = r#"<bsdf type="principled"><float name="roughness" value="0.2"/></bsdf>"#;
    let s = one_shape("principled-iso", "rectangle", p);
    assert!(!anisotropic(&s, s.meshes[0].bsdf));
}

#[test]
fn frames_differ_on_spheres_cubes_and_disks_not_on_a_rectangle() {
    // The untransformed rectangle: dp_du = (2, 0, 0) and coordinate_system((0, 0, 1)).0 = (1, 0, 0), the
    // same frame (the helper's anisotropic rectangle matched Mitsuba to 3e-6).
    let s = one_shape("rect", "rectangle", ANISO);
    assert!(!anisotropic_frame_differs(&s, 0));
    // A sphere's azimuthal dp_du, a cube's faces (uvs per face) and a disk (tessellated) differ.
    for shape in ["sphere", "cube", "disk"] {
        let s = one_shape(shape, shape, ANISO);
        assert!(anisotropic_frame_differs(&s, 0), "{shape}");
        // An isotropic BSDF on the same shape does not see the frame.
        let s = one_shape(&format!("{shape}-iso"), shape, ISO);
        assert!(!anisotropic_frame_differs(&s, 0), "{shape} isotropic");
    }
}
