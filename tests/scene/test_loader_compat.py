"""Scene-loader compatibility with Mitsuba 3.9.1 on inputs published scenes use:
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
    from manylights.testing import mitsuba as reference

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


# ---- item 3: spectral values ----

CBOX_WHITE = ("400:0.343, 404:0.445, 408:0.551, 412:0.624, 416:0.665, 420:0.687, 424:0.708, 428:0.723, "
              "432:0.715, 436:0.71, 440:0.745, 500:0.747, 560:0.733, 600:0.74, 650:0.72, 700:0.737")
SPECTRA = {
    "uniform": "0.5",
    "uniform_bright": "3",
    "irregular_list": CBOX_WHITE,
    "red_irregular": "400:0.04, 500:0.058, 560:0.067, 580:0.099, 600:0.287, 620:0.513, 660:0.638, 700:0.642",
    "narrow_band": "520:0, 530:1, 540:0",
    "beyond_cie_range": "300:0.2, 900:0.9",
    "out_of_gamut": "440:0, 450:1.5, 460:0",
}


def _area_scene(spectrum_value):
    return f"""
  <shape type="rectangle" id="lamp"><bsdf type="diffuse" id="mat">
      <spectrum name="reflectance" value="{spectrum_value}"/></bsdf>
    <emitter type="area"><spectrum name="radiance" value="{spectrum_value}"/></emitter></shape>
  <emitter type="point" id="pt"><point name="position" value="0, 0, 2"/>
    <spectrum name="intensity" value="{spectrum_value}"/></emitter>
  <emitter type="directional" id="sun"><vector name="direction" value="0, 0, -1"/>
    <spectrum name="irradiance" value="{spectrum_value}"/></emitter>
  <emitter type="constant" id="sky"><spectrum name="radiance" value="{spectrum_value}"/></emitter>
  <shape type="rectangle"><bsdf type="roughconductor" id="metal">
      <spectrum name="eta" value="{spectrum_value}"/><spectrum name="k" value="{spectrum_value}"/>
      <spectrum name="specular_reflectance" value="{spectrum_value}"/></bsdf></shape>"""


@pytest.mark.parametrize("case", list(SPECTRA))
def test_spectrum_to_rgb_matches_mitsuba(case, tmp_path):
    """Reflectance (D65-weighted, clamped to [0, 1]), unbounded (eta, k) and emission (no D65: radiance,
    intensity, irradiance) conversions against Mitsuba's scalar_rgb values (mi.traverse)."""
    mi = _mi()
    xml = _scene(tmp_path, _area_scene(SPECTRA[case]))
    p = mi.traverse(mi.load_file(str(xml), optimize=False))
    def mi_val(suffix):
        (key,) = [k for k in p.keys() if k.endswith(suffix + ".value")]
        return np.array(p[key], dtype=np.float64).ravel()

    s = ml.load_scene(xml)
    diffuse = next(b for b in s.bsdfs if b["type"] == "diffuse")
    metal = next(b for b in s.bsdfs if b["type"] == "roughconductor")
    em = {e["type"]: e for e in s.emitters}
    pairs = [
        (diffuse["reflectance"], mi_val("lamp.bsdf.reflectance")),
        (metal["specular_reflectance"], mi_val(".specular_reflectance")),
        (metal["eta"], mi_val(".eta")),
        (metal["k"], mi_val(".k")),
        (em["area"]["radiance"], mi_val("lamp.emitter.radiance")),
        (em["point"]["intensity"], mi_val("pt.intensity")),
        (em["directional"]["irradiance"], mi_val("sun.irradiance")),
        (em["constant"]["radiance"], mi_val("sky.radiance")),
    ]
    for k, (ours, theirs) in enumerate(pairs):
        theirs = np.broadcast_to(theirs, (3,))
        np.testing.assert_allclose(np.asarray(ours, np.float64), theirs, rtol=2e-6, atol=1e-7, err_msg=f"pair {k}")


def test_official_cbox_spectral_loads_as_mitsuba(mitsuba_ref):
    """The official spectral Cornell box (scenes/cbox/cbox.xml) loads; reflectances and the light's
    radiance equal Mitsuba's."""
    from conftest import SCENES

    xml = SCENES / "cbox" / "cbox.xml"
    p = mitsuba_ref.mitsuba().traverse(mitsuba_ref.load(xml))
    s = ml.load_scene(xml)
    ours = {tuple(np.round(b["reflectance"], 5)) for b in s.bsdfs if b["type"] == "diffuse"}
    for k in ("white", "red", "green", "light"):
        v = tuple(np.round(np.array(p[f"{k}.reflectance.value"], np.float64).ravel(), 5))
        assert v in ours, (k, v, ours)
    lamp = next(e for e in s.emitters if e["type"] == "area")
    theirs = next(np.array(p[k]).ravel() for k in p.keys() if k.endswith("emitter.radiance.value"))
    np.testing.assert_allclose(lamp["radiance"], theirs, rtol=2e-6)


@pytest.mark.parametrize("value, words", [
    ("700:1, 400:2", ["strictly increasing", "700:1, 400:2"]),
    ("400:1", ["at least two"]),
    ("400:1, 500", ["wavelength:value"]),
    ("400:1, 5x0:2", ["\"5x0\""]),
])
def test_bad_spectrum_names_file_line_and_value(value, words, tmp_path):
    xml = _scene(tmp_path, f"""<shape type="rectangle"><bsdf type="diffuse">
      <spectrum name="reflectance" value="{value}"/></bsdf></shape>""")
    with pytest.raises(ml.SceneError) as e:
        ml.load_scene(xml)
    msg = str(e.value)
    assert "scene.xml:" in msg and all(w in msg for w in words), msg


def test_blackbody_is_refused_as_in_mitsuba_rgb(tmp_path):
    """Mitsuba's RGB variants load a blackbody but cannot evaluate it ("Not implemented for non-spectral
    modes"): a clear error here."""
    xml = _scene(tmp_path, """<shape type="rectangle"><emitter type="area">
      <spectrum type="blackbody" name="radiance"><float name="temperature" value="3000"/></spectrum>
      </emitter></shape>""")
    with pytest.raises(ml.SceneError) as e:
        ml.load_scene(xml)
    assert "scene.xml:9" in str(e.value) and 'type="blackbody"' in str(e.value) and "non-spectral" in str(e.value)


# ---- item 4: scenes of version < 2.0 ----

LEGACY = """<scene version="{version}">
  <sensor type="perspective"><float name="fov" value="40"/><string name="{fovAxis}" value="y"/>
    <float name="{nearClip}" value="0.05"/>
    <transform name="{toWorld}"><lookat origin="0, 1, 8" target="0, 0, 0" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="32"/><integer name="height" value="24"/></film></sensor>
  <bsdf type="diffuse" id="d"><rgb name="{diffuseReflectance}" value="0.2, 0.4, 0.6"/></bsdf>
  <bsdf type="roughplastic" id="p"><float name="{intIOR}" value="1.6"/><float name="{extIOR}" value="1.1"/>
    <rgb name="{diffuseReflectance}" value="0.3, 0.3, 0.1"/><rgb name="{specularReflectance}" value="0.9"/></bsdf>
  <shape type="rectangle" id="r"><transform name="{toWorld}"><rotate x="1" angle="30"/></transform>
    <ref id="d"/></shape>
  <shape type="cube" id="c"><transform name="{toWorld}"><scale value="0.3"/><translate x="1"/></transform>
    <ref name="bsdf" id="p"/><emitter type="area"><rgb name="radiance" value="1, 2, 3"/></emitter></shape>
  <shape type="sphere" id="s"><point name="center" x="-1" y="0" z="0"/><float name="radius" value="0.5"/>
    <bsdf type="diffuse"><texture type="checkerboard" name="{diffuseReflectance}">
      <rgb name="color0" value="0.1"/><rgb name="color1" value="0.7"/>{uvopts}</texture></bsdf></shape>
  <emitter type="spot" id="spot"><float name="{cutoffAngle}" value="30"/><float name="{beamWidth}" value="20"/>
    <rgb name="intensity" value="5"/>
    <transform name="{toWorld}"><lookat origin="0, 3, 3" target="0, 0, 0"/></transform></emitter>
</scene>
"""
OLD_NAMES = {k: k for k in ("fovAxis", "nearClip", "toWorld", "diffuseReflectance", "intIOR", "extIOR",
                            "specularReflectance", "cutoffAngle", "beamWidth")}
NEW_NAMES = {"fovAxis": "fov_axis", "nearClip": "near_clip", "toWorld": "to_world", "diffuseReflectance":
             "diffuse_reflectance", "intIOR": "int_ior", "extIOR": "ext_ior", "specularReflectance":
             "specular_reflectance", "cutoffAngle": "cutoff_angle", "beamWidth": "beam_width"}
OLD_UV = '<float name="uoffset" value="0.25"/><float name="vscale" value="3"/><float name="uscale" value="2"/>'
NEW_UV = '<transform name="to_uv"><translate x="0.25"/><scale x="2" y="3"/></transform>'


def _summary(s):
    meshes = [s.mesh(k) for k in range(len(s.shapes))]
    return s.camera, s.bsdfs, s.emitters, [(m["positions"], m["normals"]) for m in meshes]


@pytest.mark.parametrize("version", ["0.6.0", "0.5.0"])
def test_legacy_scene_loads_like_its_v3_twin_and_mitsuba(version, tmp_path):
    mi = _mi()
    old = tmp_path / "old.xml"
    old.write_text(LEGACY.format(version=version, uvopts=OLD_UV, **OLD_NAMES))
    new = tmp_path / "new.xml"
    # The 3.0 twin: snake_case names, `reflectance` for diffuse, to_uv for the uv options.
    names = dict(NEW_NAMES)
    new.write_text(LEGACY.format(version="3.0.0", uvopts=NEW_UV, **names)
                   .replace('type="diffuse" id="d"><rgb name="diffuse_reflectance"',
                            'type="diffuse" id="d"><rgb name="reflectance"')
                   .replace('name="diffuse_reflectance">\n      <rgb name="color0"',
                            'name="reflectance">\n      <rgb name="color0"'))
    a, b = ml.load_scene(old), ml.load_scene(new)
    ca, ba, ea, ma = _summary(a)
    cb, bb, eb, mb = _summary(b)
    assert ca.keys() == cb.keys() and all(np.allclose(ca[k], cb[k]) for k in ca)
    assert ca["near_clip"] == pytest.approx(0.05)
    assert repr(ba) == repr(bb) and repr(ea) == repr(eb)
    for (pa, na), (pb, nb) in zip(ma, mb):
        np.testing.assert_array_equal(pa, pb)
        np.testing.assert_array_equal(na, nb)
    # Mitsuba upgrades the old file to the same values.
    mi_scene = mi.load_file(str(old), optimize=False)
    p = mi.traverse(mi_scene)
    mi_pos = {sh.id(): np.array(sh.vertex_positions_buffer()).reshape(-1, 3) for sh in mi_scene.shapes() if sh.id() in "rc"}
    diffuse = next(x for x in ba if x["type"] == "diffuse" and not isinstance(x["reflectance"], dict))
    np.testing.assert_allclose(diffuse["reflectance"], np.array(p["d.reflectance.value"]).ravel(), rtol=1e-6)
    plastic = next(x for x in ba if x["type"] == "roughplastic")
    np.testing.assert_allclose(plastic["diffuse_reflectance"], np.array(p["p.diffuse_reflectance.value"]).ravel())
    assert float(np.array(p["p.eta"]).ravel()[0]) == pytest.approx(1.6 / 1.1, rel=1e-6)
    np.testing.assert_allclose(ma[1][0], mi_pos["c"], atol=1e-6)
    np.testing.assert_allclose(ma[0][0], mi_pos["r"], atol=1e-6)
    spot = next(e for e in ea if e["type"] == "spot")
    assert spot["cutoff_angle"] == pytest.approx(np.radians(30)) and spot["beam_width"] == pytest.approx(np.radians(20))
    tex_key = next(k for k in p.keys() if k.endswith("reflectance.to_uv"))
    np.testing.assert_allclose(np.array(p[tex_key].matrix).reshape(3, 3),
                               [[2, 0, 0.5], [0, 3, 0], [0, 0, 1]], atol=1e-6)


def test_legacy_upgrade_is_per_file_and_bad_version_is_an_error(tmp_path):
    """An included 0.6 file is upgraded by its own version, the 3.0 main file is not; a malformed
    version names file and value."""
    (tmp_path / "part.xml").write_text('<scene version="0.6.0"><shape type="rectangle">'
                                       '<transform name="toWorld"><translate z="2"/></transform></shape></scene>')
    main = _scene(tmp_path, '<include filename="part.xml"/>')
    s = ml.load_scene(main)
    assert s.shapes[0]["bbox_min"][2] == pytest.approx(2.0)
    bad = _scene(tmp_path, '<shape type="rectangle"><transform name="toWorld"><translate z="2"/></transform></shape>',
                 name="new.xml")
    with pytest.raises(ml.SceneError) as e:
        ml.load_scene(bad)
    assert "toWorld" in str(e.value)
    with pytest.raises(ml.SceneError) as e:
        ml.load_scene(_scene(tmp_path, '<shape type="cube"/>', version="0.6", name="v.xml"))
    assert "v.xml:" in str(e.value) and '"0.6"' in str(e.value)


# ---- item 7: where Mitsuba goes on ----

def test_path_resolved_as_mitsuba(tmp_path, monkeypatch):
    """`<path>` naming a folder that is not beside the scene: Mitsuba 3.9.1 looks for it in its search
    path (earlier <path>s, the working directory) and goes on when found there; a folder that exists
    nowhere fails in Mitsuba too (FileNotFoundError here, naming file and line)."""
    mi = _mi()
    (tmp_path / "assets" / "meshes").mkdir(parents=True)
    (tmp_path / "cwd" / "objs").mkdir(parents=True)
    (tmp_path / "assets" / "meshes" / "a.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    (tmp_path / "cwd" / "objs" / "b.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\n")
    monkeypatch.chdir(tmp_path / "cwd")
    body = ('<path value="assets"/><path value="meshes"/><path value="objs"/>'
            '<shape type="obj"><string name="filename" value="a.obj"/></shape>'
            '<shape type="obj"><string name="filename" value="b.obj"/></shape>')
    xml = _scene(tmp_path, body)
    assert sorted(len(np.array(s.faces_buffer())) for s in mi.load_file(str(xml)).shapes()) == [3, 6]
    assert [s["triangles"] for s in ml.load_scene(xml).shapes] == [1, 2]
    missing = _scene(tmp_path, body.replace('value="objs"', 'value="no/such/dir"'), name="m.xml")
    with pytest.raises(RuntimeError, match="not found"):
        mi.load_file(str(missing))
    with pytest.raises(FileNotFoundError) as e:
        ml.load_scene(missing)
    assert "m.xml:" in str(e.value) and "no/such/dir" in str(e.value)


DEGENERATE_OBJ = "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 1 0\nf 1 2 3\nf 1 1 4\n"


def test_all_degenerate_mesh_warns_and_keeps_shape_indices(tmp_path, mitsuba_ref):
    """A mesh whose triangles all have zero area: Mitsuba loads the scene and the mesh adds nothing. Here:
    a UserWarning, an empty shape at the same index, and G-buffer, lights and the light matrix work."""
    (tmp_path / "deg.obj").write_text(DEGENERATE_OBJ)
    body = """
  <shape type="rectangle" id="floor"><transform name="to_world"><scale value="3"/></transform></shape>
  <shape type="obj" id="deg"><string name="filename" value="deg.obj"/></shape>
  <shape type="cube" id="box"><transform name="to_world"><scale value="0.5"/><translate z="0.5"/></transform>
  </shape>
  <shape type="rectangle" id="lamp"><transform name="to_world"><scale value="0.3"/><rotate x="1" angle="180"/>
    <translate x="1.5" y="1.5" z="3"/></transform><emitter type="area"><rgb name="radiance" value="4"/></emitter></shape>
  <emitter type="point"><point name="position" value="1, 1, 3"/><rgb name="intensity" value="5"/></emitter>"""
    xml = _scene(tmp_path, body)
    with pytest.warns(UserWarning, match="zero area"):
        scene = ml.load_scene(xml)
    assert [s["id"] for s in scene.shapes] == ["floor", "deg", "box", "lamp"]
    assert scene.shapes[1]["triangles"] == 0 and scene.mesh(1)["positions"].shape == (0, 3)
    gb = scene.gbuffer()
    ref = mitsuba_ref.mitsuba_gbuffer(xml, (32, 32))
    assert [s.id() for s in mitsuba_ref.load(xml).shapes()] == ["floor", "deg", "box", "lamp"]
    assert (gb["shape_index"] == ref["shape_index"]).mean() >= 0.998
    assert (gb["shape_index"] == 2).sum() > 20 and not (gb["shape_index"] == 1).any()
    lights = ml.generate_lights(scene, area=64, seed=1)
    img = ml.LightMatrix(scene, lights).column_sum()
    assert img.shape == (32, 32, 3) and np.isfinite(img).all() and img.max() > 0


def test_area_emitter_on_degenerate_mesh_is_an_error(tmp_path):
    """Mitsuba fails on this too ("DiscreteDistribution: no probability mass found")."""
    (tmp_path / "deg.obj").write_text(DEGENERATE_OBJ)
    xml = _scene(tmp_path, '<shape type="rectangle"/><shape type="obj"><string name="filename" value="deg.obj"/>\n'
                           '<emitter type="area"/></shape>')
    with pytest.raises(ml.SceneError) as e:
        ml.load_scene(xml)
    assert "scene.xml:" in str(e.value) and "zero area" in str(e.value)


PPO_SENSOR = """
  <sensor type="perspective"><float name="fov" value="45"/><string name="fov_axis" value="{axis}"/>
    <float name="principal_point_offset_x" value="{ox}"/><float name="principal_point_offset_y" value="{oy}"/>
    <transform name="to_world"><lookat origin="0.5, 1, 7" target="0, 0, 0" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="{w}"/><integer name="height" value="{h}"/></film>
  </sensor>"""
PPO_BODY = """
  <shape type="cube" id="box"><transform name="to_world"><rotate y="1" angle="30"/></transform></shape>
  <shape type="sphere" id="ball"><point name="center" value="-0.4, 1.3, 1.4"/><float name="radius" value="0.7"/></shape>
  <shape type="rectangle" id="floor"><transform name="to_world"><scale value="6"/><rotate x="1" angle="-90"/>
    <translate y="-1"/></transform></shape>"""


@pytest.mark.parametrize("ox, oy, axis, w, h", [
    (0.2, -0.15, "x", 48, 32),
    (-0.3, 0.25, "y", 32, 48),
    (0.0, 0.0, "x", 32, 32),
])
def test_principal_point_offset_matches_mitsuba(ox, oy, axis, w, h, tmp_path, mitsuba_ref):
    """Off-axis projection (the Blender exporter writes principal_point_offset_x/y): the pixel-centre
    G-buffer (GPU rasteriser's projection, incl. the analytic sphere's per-pixel rays, and the CPU resolve)
    agrees with Mitsuba's camera rays."""
    xml = tmp_path / "ppo.xml"
    xml.write_text(f'<scene version="3.0.0">{PPO_SENSOR.format(ox=ox, oy=oy, axis=axis, w=w, h=h)}{PPO_BODY}</scene>')
    scene = ml.load_scene(xml)
    assert scene.camera["principal_point_offset"] == pytest.approx((ox, oy))
    gb = scene.gbuffer()
    ref = mitsuba_ref.mitsuba_gbuffer(xml, (w, h))
    same = gb["shape_index"] == ref["shape_index"]
    hit = same & (ref["shape_index"] >= 0)
    assert same.mean() >= 0.998, f"shape index agrees on {same.mean():.4%}"
    pos_err = np.linalg.norm(gb["position"] - ref["position"], axis=-1)[hit]
    assert np.quantile(pos_err, 0.998) < 1e-4, np.quantile(pos_err, 0.998)
    assert ((gb["normal"] * ref["normal"]).sum(-1)[hit] > 0.9999).mean() >= 0.998
    assert set(np.unique(ref["shape_index"])) == {-1, 0, 1, 2}


def test_principal_point_offset_must_be_a_number(tmp_path):
    xml = tmp_path / "ppo.xml"
    xml.write_text('<scene version="3.0.0">' + PPO_SENSOR.format(ox="abc", oy=0, axis="x", w=8, h=8) + PPO_BODY
                   + "</scene>")
    with pytest.raises(ml.SceneError) as e:
        ml.load_scene(xml)
    assert "ppo.xml:3" in str(e.value) and '"abc"' in str(e.value)


@pytest.mark.parametrize("rotate", ['<rotate x="1" y="1" angle="70"/>', '<rotate y="1" angle="70"/>'])
def test_envmap_under_rotation_matches_mitsuba(rotate, tmp_path, mitsuba_ref):
    """Background radiance of an environment map whose to_world rotates about a unit or non-unit axis:
    Mitsuba looks up to_world.inverse() * d, whose 3x3 block is the transpose of its normal matrix
    (R^T for a non-unit axis); pixel-centre max_depth=1 renders are deterministic."""
    h, w = 8, 16
    v, u = np.meshgrid(np.linspace(0, 1, h), np.linspace(0, 1, w), indexing="ij")
    env = np.stack([u, v, 0.2 + 0.5 * u * v], -1).astype(np.float32)
    ml.write_exr(tmp_path / "env.exr", env)
    xml = _scene(tmp_path, f"""<shape type="sphere"><float name="radius" value="0.01"/>
      <point name="center" value="0, 0, -50"/></shape>
      <emitter type="envmap"><string name="filename" value="env.exr"/>
      <transform name="to_world">{rotate}</transform></emitter>""", w=24, h=24)
    scene = ml.load_scene(xml)
    lights = ml.generate_lights(scene, area=0, environment=16, seed=0)
    ours = ml.LightMatrix(scene, lights).emitted()
    ref, _ = mitsuba_ref.mitsuba_render(xml, (24, 24), max_depth=1, spp=1)
    bg = ref.sum(-1) > 0
    assert bg.mean() > 0.9
    rel = np.abs(ours - ref)[bg] / np.maximum(ref[bg], 1e-3)
    assert np.quantile(rel, 0.99) < 1e-3, np.quantile(rel, 0.99)


@pytest.mark.parametrize("version, name", [("3.0.0", "high_quality_edges"), ("0.5.0", "highQualityEdges")])
def test_film_high_quality_edges_refused_as_mitsuba(tmp_path, version, name):
    """Bitterli's Mitsuba exports set the film's ``high_quality_edges`` (Mitsuba 0.5's highQualityEdges), which
    Mitsuba 3.9.1 refuses as an unreferenced property; so do we, naming file and line."""
    p = _scene(tmp_path, '<shape type="sphere"/>', version=version)
    p.write_text(p.read_text().replace('</film>', f'<boolean name="{name}" value="true"/></film>'))
    mi = _mi()
    with pytest.raises(RuntimeError, match="unreferenced property"):
        mi.load_file(str(p))
    with pytest.raises(ml.SceneError, match=r"scene\.xml:\d+: unreferenced property .*high_quality_edges"):
        ml.load_scene(p)
