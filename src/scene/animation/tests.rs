use super::*;
use crate::scene::{load_scene, LoadOptions};
use std::path::PathBuf;

fn write(dir: &std::path::Path, name: &str, body: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(
        &p,
        format!(
            r#"<scene version="3.0.0">
                <default name="x" value="0"/>
                <sensor type="perspective"><float name="fov" value="40"/>
                  <transform name="to_world"><lookat origin="0,0,5" target="0,0,0" up="0,1,0"/></transform>
                  <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="6"/></film>
                </sensor>
                <emitter type="point"><point name="position" x="$x" y="1" z="2"/></emitter>
                {body}
            </scene>"#
        ),
    )
    .unwrap();
    p
}

fn load(p: &std::path::Path, x: &str) -> Scene {
    load_scene(p, &LoadOptions { params: vec![("x".into(), x.into())], size: None, ..Default::default() }).unwrap()
}

#[test]
fn moving_shapes_pass_and_topology_changes_fail() {
    let dir = tempdir();
    let cube = r#"<shape type="cube" id="box"><transform name="to_world"><translate x="$x"/></transform></shape>"#;
    let a = write(&dir, "a.xml", cube);
    let (f0, f1) = (load(&a, "0"), load(&a, "0.5"));
    assert_ne!(f0.meshes[0].positions, f1.meshes[0].positions);
    check_topology(&[&f0, &f1]).unwrap();

    // A rectangle (2 triangles) where frame 0 has a cube (12): named frame, shape, counts, file.
    let b = write(&dir, "b.xml", r#"<shape type="rectangle" id="box"><transform name="to_world"><translate x="$x"/></transform></shape>"#);
    let f2 = load(&b, "0");
    let e = check_topology(&[&f0, &f1, &f2]).unwrap_err().to_string();
    assert!(e.contains("frame 2: shape 0 'box' has 2 triangles but 12 in frame 0") && e.contains("b.xml"), "{e}");

    let c = write(&dir, "c.xml", &format!("{cube}<shape type=\"sphere\" id=\"s\"/>"));
    let e = check_topology(&[&f0, &load(&c, "0")]).unwrap_err().to_string();
    assert!(e.contains("frame 1: the scene has 2 shapes but frame 0 has 1"), "{e}");

    let d = write(&dir, "d.xml", r#"<shape type="sphere" id="box"/>"#);
    let e = check_topology(&[&f0, &load(&d, "0")]).unwrap_err().to_string();
    assert!(e.contains("frame 1: shape 0 'box' is a sphere but a mesh in frame 0"), "{e}");

    let e = check_topology(&[]).unwrap_err().to_string();
    assert!(e.contains("at least one frame"), "{e}");
}

#[test]
fn film_size_and_emitters_must_match() {
    let dir = tempdir();
    let a = write(&dir, "a.xml", r#"<shape type="cube" id="box"/>"#);
    let f0 = load(&a, "0");
    let small = load_scene(&a, &LoadOptions { params: vec![], size: Some((4, 4)), ..Default::default() }).unwrap();
    let e = check_topology(&[&f0, &small]).unwrap_err().to_string();
    assert!(e.contains("frame 1") && e.contains("film is 4x4 but frame 0's is 8x6"), "{e}");

    let b = dir.join("b.xml");
    std::fs::write(
        &b,
        std::fs::read_to_string(&a).unwrap().replace(
            r#"<emitter type="point"><point name="position" x="$x" y="1" z="2"/></emitter>"#,
            r#"<emitter type="directional"><vector name="direction" x="$x" y="-1" z="0"/></emitter>"#,
        ),
    )
    .unwrap();
    let e = check_topology(&[&f0, &f0, &load(&b, "0")]).unwrap_err().to_string();
    assert!(e.contains("frame 2: emitter 0 is a 'directional' but a 'point' in frame 0"), "{e}");
}

fn tempdir() -> PathBuf {
    crate::testing::scratch_dir("anim")
}
