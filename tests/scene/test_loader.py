"""Scene loading: the shared scenes against Mitsuba's own loader, and bad input."""
import math

import numpy as np
import pytest

import manylights as ml
from conftest import SCENE_CONFIGS, TEST_SCENES


def _triangles(pos, idx):
    """(T, 9) corner positions in triangle order (both loaders keep file order and corner order)."""
    return np.asarray(pos, dtype=np.float64)[np.asarray(idx)].reshape(len(idx), 9)


def _nondegenerate(tri):
    """Mitsuba keeps zero-area triangles; we drop them (documented in src/scene/mesh.rs)."""
    t = tri.reshape(-1, 3, 3).astype(np.float32)
    cross = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
    return tri[(cross.astype(np.float32) ** 2).sum(-1) > 0]


@pytest.mark.parametrize("name", list(SCENE_CONFIGS))
def test_meshes_match_mitsuba(name, mitsuba_ref):
    xml, params, size = SCENE_CONFIGS[name]
    scene = ml.load_scene(xml, size=size, **params)
    mi_scene = mitsuba_ref.load(xml, **params)
    mi_shapes = mi_scene.shapes()
    assert len(scene.shapes) == len(mi_shapes)
    lo, hi = scene.bounds
    diag = math.dist(lo, hi)
    for k, (ours, theirs) in enumerate(zip(scene.shapes, mi_shapes)):
        if ours["type"] == "sphere":
            bb = theirs.bbox()
            assert np.allclose(ours["bbox_min"], np.array(bb.min), atol=1e-5 * diag)
            assert np.allclose(ours["bbox_max"], np.array(bb.max), atol=1e-5 * diag)
            continue
        m = scene.mesh(k)
        pos = np.array(theirs.vertex_positions_buffer(), dtype=np.float64).reshape(-1, 3)
        faces = np.array(theirs.faces_buffer(), dtype=np.int64).reshape(-1, 3)
        a = _triangles(m["positions"], m["indices"])
        b = _nondegenerate(_triangles(pos, faces))
        assert a.shape == b.shape, f"{name} shape {k}: {a.shape[0]} triangles, Mitsuba {b.shape[0]} (non-degenerate)"
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-5 * diag, err_msg=f"{name} shape {k} ({ours['id']})")


def test_cbox_lights_introspection():
    xml, params, size = SCENE_CONFIGS["cbox-lights"]
    s = ml.load_scene(xml, **params)
    assert (s.width, s.height) == (128, 128)
    assert [sh["type"] for sh in s.shapes] == ["rectangle"] * 6 + ["cube", "obj", "sphere"]
    assert [sh["id"] for sh in s.shapes][:3] == ["floor", "ceiling", "back"]
    kinds = sorted(e["type"] for e in s.emitters)
    assert kinds == ["area", "directional", "envmap", "point", "spot"]
    point = next(e for e in s.emitters if e["type"] == "point")
    assert point["position"] == pytest.approx([0.5, 0.8, 0.6])
    spot = next(e for e in s.emitters if e["type"] == "spot")
    assert spot["cutoff_angle"] == pytest.approx(math.radians(25))
    assert spot["beam_width"] == pytest.approx(math.radians(15))
    cam = s.camera
    assert cam["fov_x"] == pytest.approx(45.0)
    assert cam["origin"] == pytest.approx([0, 0, 3.9])
    assert cam["forward"] == pytest.approx([0, 0, -1])
    ball = s.shapes[8]
    assert ball["center"] == pytest.approx([0.45, -0.25, 0.25]) and ball["radius"] == pytest.approx(0.2)


def test_params_and_size_override():
    xml, _, _ = SCENE_CONFIGS["cbox-lights"]
    assert ml.load_scene(xml, res=32).width == 32
    s = ml.load_scene(TEST_SCENES / "bunny" / "scene.xml", size=(64, 48))
    assert (s.width, s.height) == (64, 48)
    # fov_axis "smaller" on a landscape film: the vertical fov is the given one.
    assert s.camera["fov_y"] == pytest.approx(28.8415, abs=1e-3)


def _write(tmp_path, body, name="scene.xml"):
    p = tmp_path / name
    p.write_text(body)
    return p


CAMERA = """<sensor type="perspective"><float name="fov" value="45"/>
<film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film></sensor>
"""


def _scene(body, camera=CAMERA):
    return f'<scene version="3.0.0">\n{camera}{body}\n</scene>\n'


def _raises(tmp_path, text, exc, *needles, name="scene.xml"):
    p = _write(tmp_path, text, name)
    with pytest.raises(exc) as e:
        ml.load_scene(p)
    msg = str(e.value)
    for n in needles:
        assert n in msg, f"{n!r} not in error message: {msg}"
    return msg


def test_malformed_xml(tmp_path):
    _raises(tmp_path, _scene('<shape type="rectangle">\n<bsdf type="diffuse"></shape>'), ml.SceneError, "scene.xml:")


def test_unknown_plugin_names_plugin_file_and_line(tmp_path):
    text = _scene('<shape type="rectangle"/>\n<bsdf type="hair" id="h"/>')
    _raises(tmp_path, text, ml.SceneError, "hair", "scene.xml:5")


def test_missing_mesh_file(tmp_path):
    text = _scene('<shape type="obj"><string name="filename" value="nope.obj"/></shape>')
    _raises(tmp_path, text, FileNotFoundError, "nope.obj", "scene.xml:4")


def test_missing_texture_file(tmp_path):
    text = _scene('<shape type="rectangle"><bsdf type="diffuse"><texture type="bitmap" name="reflectance">'
                  '<string name="filename" value="missing.png"/></texture></bsdf></shape>')
    _raises(tmp_path, text, FileNotFoundError, "missing.png")


def test_nan_vertex(tmp_path):
    (tmp_path / "bad.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 nan 0\nf 1 2 3\n")
    text = _scene('<shape type="obj"><string name="filename" value="bad.obj"/></shape>')
    _raises(tmp_path, text, ml.SceneError, "bad.obj", "nan")


def test_degenerate_triangle(tmp_path):
    (tmp_path / "flat.obj").write_text("v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n")
    text = _scene('<shape type="obj"><string name="filename" value="flat.obj"/></shape>')
    (tmp_path / "scene.xml").write_text(text)
    # Mitsuba loads it (the mesh adds nothing): a warning naming file and line, an empty shape.
    with pytest.warns(UserWarning, match="scene.xml:4.*zero area"):
        s = ml.load_scene(tmp_path / "scene.xml")
    assert s.shapes[0]["triangles"] == 0


def test_warnings_grouped_per_kind(tmp_path):
    """Seven zero-area shapes: one warning line (how many, the first five ids, the first location), not seven."""
    import warnings

    (tmp_path / "flat.obj").write_text("v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n")
    body = "".join(f'<shape type="obj" id="flat{k}"><string name="filename" value="flat.obj"/></shape>\n'
                   for k in range(7))
    (tmp_path / "scene.xml").write_text(_scene('<shape type="rectangle" id="floor"/>' + body))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        s = ml.load_scene(tmp_path / "scene.xml")
    assert len(s.shapes) == 8
    messages = [str(w.message) for w in caught]
    assert len(messages) == 1, messages
    assert messages[0].startswith(f"{tmp_path / 'scene.xml'}:4 (first of 7): shapes ")
    assert '"flat0", "flat1", "flat2", "flat3", "flat4" and 2 more: all triangles have zero area' in messages[0]
    assert caught[0].category is UserWarning and caught[0].filename == __file__  # reported at the caller


def test_no_shapes(tmp_path):
    _raises(tmp_path, _scene('<emitter type="point"><point name="position" x="0" y="0" z="0"/></emitter>'),
            ml.SceneError, "scene.xml", "no shapes")


def test_film_of_zero_pixels(tmp_path):
    cam = CAMERA.replace('name="width" value="8"', 'name="width" value="0"')
    _raises(tmp_path, _scene('<shape type="rectangle"/>', camera=cam), ml.SceneError, "scene.xml:3", "width")


def test_camera_with_scale(tmp_path):
    cam = CAMERA.replace('<film', '<transform name="to_world"><scale value="2"/></transform><film')
    _raises(tmp_path, _scene('<shape type="rectangle"/>', camera=cam), ml.SceneError, "scene.xml:", "scale")


def test_scene_file_missing(tmp_path):
    with pytest.raises(FileNotFoundError):
        ml.load_scene(tmp_path / "absent.xml")
