"""Scene-loader compatibility with Mitsuba 3.9.1 on inputs published scenes use (issue 8 items 1, 3, 4, 7):
every transform form, spectral values, version < 2.0 scenes, and what Mitsuba accepts and goes on with.
Each test loads the same small scene with Mitsuba (scalar_rgb) and compares the values."""
import numpy as np
import pytest

import manylights as ml

SENSOR = """
  <sensor type="perspective">
    <float name="fov" value="40"/>
    <transform name="to_world"><lookat origin="0, 0, 8" target="0, 0, 0" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="{w}"/><integer name="height" value="{h}"/></film>
  </sensor>"""


def _scene(tmp_path, body, *, version="3.0.0", w=32, h=32, sensor=True, name="scene.xml"):
    p = tmp_path / name
    p.write_text(f'<scene version="{version}">\n{SENSOR.format(w=w, h=h) if sensor else ""}\n{body}\n</scene>\n')
    return p


def _mi():
    from manylights import reference

    return reference.mitsuba()


# ---- item 1: transforms ----

TRANSFORMS = {
    "rotate_unit_axis": '<rotate y="1" angle="30"/>',
    "rotate_non_unit_axis": '<rotate x="0" y="1" z="1" angle="15"/>',
    "rotate_value_negative_axis": '<rotate value="-1, 2, 0.5" angle="-33"/>',
    "rotate_z_only_scaled": '<rotate z="-2" angle="40"/>',
    "scale_one_value": '<scale value="2"/>',
    "scale_one_axis": '<scale x="2"/>',
    "scale_value_three": '<scale value="2, 3, 4"/>',
    "scale_negative": '<scale x="-1" y="2" z="0.5"/>',
    "translate_xyz": '<translate x="1" y="-2" z="0.5"/>',
    "translate_value": '<translate value="1 2 3"/>',
    "matrix_16": '<matrix value="1 0.2 0 1  0.1 2 0.3 -1  0 0 0.5 2  0 0 0 1"/>',
    "matrix_9": '<matrix value="0.5 -1 0  1 0.5 0.2  0 0.3 1.5"/>',
    "lookat_non_orthogonal_up": '<lookat origin="1, 2, 3" target="0, 0, 0" up="0, 0.5, 1"/>',
    "lookat_no_up": '<lookat origin="1, 2, 3" target="0, 0, 0"/>',
    "chain": ('<scale x="1" y="2" z="0.5"/><rotate x="1" y="1" angle="30"/><translate value="1, 2, 3"/>'
              '<matrix value="1 0 0.3  0 1 0  0 0 1"/><rotate value="0.2 0 -3" angle="70"/>'),
}


@pytest.mark.parametrize("form", list(TRANSFORMS))
def test_transform_matches_mitsuba(form, tmp_path):
    """A cube (24 vertices spanning all axes, normals along all axes) under each transform form: world
    positions and shading normals agree with Mitsuba's buffers (so both its matrix and the matrix it
    applies to normals are reproduced)."""
    mi = _mi()
    body = f'<shape type="cube" id="c"><transform name="to_world">{TRANSFORMS[form]}</transform></shape>'
    xml = _scene(tmp_path, body)
    ours = ml.load_scene(xml).mesh(0)
    theirs = mi.load_file(str(xml), optimize=False).shapes()[0]
    pos = np.array(theirs.vertex_positions_buffer(), dtype=np.float64).reshape(-1, 3)
    nrm = np.array(theirs.vertex_normals_buffer(), dtype=np.float64).reshape(-1, 3)
    faces = np.array(theirs.faces_buffer()).reshape(-1, 3)
    np.testing.assert_array_equal(ours["indices"], faces)
    scale = max(1.0, np.abs(pos).max())
    np.testing.assert_allclose(ours["positions"], pos, rtol=0, atol=1e-6 * scale)
    np.testing.assert_allclose(ours["normals"], nrm, rtol=0, atol=2e-6)


def test_rotate_non_unit_axis_is_not_normalised(tmp_path):
    """Mitsuba 3.9.1 builds Rodrigues' matrix from the axis as given: (0, 1, 1) at 15 degrees maps the
    vertex (1, 1, 1) of the cube to (0.965926, 1.292893, 0.775255), not to a rotated point."""
    xml = _scene(tmp_path, f'<shape type="cube"><transform name="to_world">{TRANSFORMS["rotate_non_unit_axis"]}'
                           '</transform></shape>')
    m = ml.load_scene(xml).mesh(0)
    k = int(np.argmin(np.abs(m["positions"] - [0.965926, 1.292893, 0.775255]).sum(1)))
    np.testing.assert_allclose(m["positions"][k], [0.9659258, 1.2928932, 0.7752551], atol=1e-6)


@pytest.mark.parametrize("lookat", [
    'origin="1, 2, 3" target="0, 0, 0" up="0, 0.5, 1"',
    'origin="1, 2, 3" target="0, 0, 0"',
    'origin="0, 4, 1" target="0.5, 0, 0" up="1, 1, 0"',
])
def test_sensor_lookat_matches_mitsuba(lookat, tmp_path):
    mi = _mi()
    xml = tmp_path / "s.xml"
    xml.write_text(f"""<scene version="3.0.0"><shape type="cube"/>
      <sensor type="perspective"><transform name="to_world"><lookat {lookat}/></transform></sensor></scene>""")
    cam = ml.load_scene(xml).camera
    m = np.array(mi.load_file(str(xml)).sensors()[0].world_transform().matrix, dtype=np.float64).reshape(4, 4)
    for key, col in (("left", 0), ("up", 1), ("forward", 2), ("origin", 3)):
        np.testing.assert_allclose(cam[key], m[:3, col], rtol=0, atol=1e-6, err_msg=key)


def test_gbuffer_under_non_unit_rotation_matches_mitsuba(tmp_path, mitsuba_ref):
    """Pixel-centre G-buffer of meshes rotated about (0, 1, 1) (the issue's case: was 94.8% of pixels)."""
    body = """
  <shape type="obj" id="box"><string name="filename" value="box.obj"/>
    <transform name="to_world"><scale value="0.8"/><rotate x="0" y="1" z="1" angle="15"/>
      <translate x="-1.2"/></transform></shape>
  <shape type="rectangle" id="rect"><transform name="to_world">
    <rotate x="0" y="1" z="1" angle="25"/><translate x="1.5" y="0.3"/></transform></shape>
  <shape type="cube" id="cube"><transform name="to_world"><scale value="0.5"/>
    <rotate value="1, -2, 0.5" angle="-40"/><translate y="-1.6" x="1"/></transform></shape>"""
    # An OBJ with its own normals (bent, so the normal matrix matters) and one without.
    (tmp_path / "box.obj").write_text(
        "v -1 -1 0\nv 1 -1 0\nv 1 1 0.3\nv -1 1 0.3\nvn 0.3 0 1\nvn -0.2 0.1 1\nvn 0 0.4 1\nvn 0.1 -0.3 1\n"
        "f 1//1 2//2 3//3\nf 1//1 3//3 4//4\n")
    xml = _scene(tmp_path, body, w=48, h=48)
    scene = ml.load_scene(xml)
    gb = scene.gbuffer()
    ref = mitsuba_ref.mitsuba_gbuffer(xml, (48, 48))
    sid = gb["shape_index"]
    same = sid == ref["shape_index"]
    hit = same & (sid >= 0)
    assert hit.sum() > 0.2 * sid.size
    n_dot = (gb["normal"] * ref["normal"]).sum(-1)[hit]
    g_dot = (gb["geo_normal"] * ref["geo_normal"]).sum(-1)[hit]
    assert same.mean() >= 0.998, f"shape index agrees on {same.mean():.4%}"
    assert (n_dot > 0.9999).mean() >= 0.998, f"normals agree on {(n_dot > 0.9999).mean():.4%}"
    assert (g_dot > 0.9999).mean() >= 0.998
    pos_err = np.linalg.norm(gb["position"] - ref["position"], axis=-1)[hit]
    assert np.quantile(pos_err, 0.998) < 1e-4
