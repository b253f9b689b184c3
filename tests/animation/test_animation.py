"""Animations as input and the bundled animated scene "bounce": frames from
per-frame <default> parameters or from one file per frame, checked against Mitsuba 3.9.1's own loading
and rendering of the same frames; topology checks and bad input."""
from __future__ import annotations

from unittest import mock

import numpy as np
import pytest

import manylights as ml
from manylights.animation import frames as frames_module
from manylights.scenes import animation_frames, scene_path

BOUNCE = scene_path("bounce")

# Mitsuba's pixel-centre direct-light render (256 spp) against our brute force of 2048 area + 2048
# environment lights, on 4x4 pixel blocks of a 24x24 film: measured relative L2 0.013 (frame 0) and 0.015
# (frame 5), about the reference's own noise on blocks (per-pixel noise 0.052-0.064 / 4); 0.04 leaves
# room for the noise and fails on any real difference (our frame 4 or 6 against Mitsuba's frame 5 of 8: 0.21, 0.11).
BLOCK_RTOL = 0.04


def _tiny_xml(tmp_path, name, body, width=8, height=6):
    p = tmp_path / name
    p.write_text(f"""<scene version="3.0.0">
        <default name="x" value="0"/>
        <sensor type="perspective"><float name="fov" value="40"/>
          <transform name="to_world"><lookat origin="0,0,5" target="0,0,0" up="0,1,0"/></transform>
          <film type="hdrfilm"><integer name="width" value="{width}"/><integer name="height" value="{height}"/></film>
        </sensor>
        <emitter type="point"><point name="position" x="$x" y="1" z="2"/></emitter>
        {body}
    </scene>""")
    return p


def test_frames_follow_their_parameters():
    frames = animation_frames("bounce", count=5)
    anim = ml.load_animation(BOUNCE, frames=frames, res=32)
    assert len(anim) == 5 and (anim.width, anim.height) == (32, 32)
    assert anim[-1] is anim[4] and list(anim) == anim.frames
    assert anim.params[2] == {"res": 32, **frames[2]}
    for k, scene in enumerate(anim):
        f = frames[k]
        np.testing.assert_allclose(scene.camera["origin"], [f["cam_x"], f["cam_y"], f["cam_z"]], atol=1e-5)
        box = next(s for s in scene.shapes if s["id"] == "box")
        # bbox of a cube scaled (sxz, sy, sxz), spun about y by box_spin, centred at (box_x, box_y, box_z).
        assert box["bbox_min"][1] == pytest.approx(f["box_y"] - f["box_sy"], abs=1e-5)
        assert box["bbox_max"][1] == pytest.approx(f["box_y"] + f["box_sy"], abs=1e-5)
        centre = (np.array(box["bbox_min"]) + np.array(box["bbox_max"])) / 2
        np.testing.assert_allclose(centre, [f["box_x"], f["box_y"], f["box_z"]], atol=1e-5)
    # The box really moves and squashes; the floor stays.
    assert anim[0].shapes[3]["bbox_max"] != anim[1].shapes[3]["bbox_max"]
    assert anim[0].shapes[0]["bbox_max"] == anim[1].shapes[0]["bbox_max"]
    g = anim.gbuffers()
    assert g["position"].shape == (5, 32, 32, 3) and g["shape_index"].shape == (5, 32, 32)
    np.testing.assert_array_equal(g["albedo"][2], anim[2].gbuffer()["albedo"])
    # The helper spans the same motion whatever the count: its ends are the same.
    assert animation_frames("bounce", count=40)[-1] == frames[-1] and animation_frames("bounce", 1) == frames[:1]


def test_one_file_per_frame(tmp_path):
    a = _tiny_xml(tmp_path, "a.xml", '<shape type="cube" id="box"/>')
    b = _tiny_xml(tmp_path, "b.xml", '<shape type="cube" id="box"><transform name="to_world"><translate x="0.5"/></transform></shape>')
    anim = ml.load_animation([a, b])
    assert len(anim) == 2 and anim.paths == [a, b]
    assert anim[1].shapes[0]["bbox_min"][0] == pytest.approx(-0.5)
    anim = ml.load_animation([a, a], frames=[{"x": 1}, {"x": 2}], size=(4, 4))
    assert [s.emitters[0]["position"][0] for s in anim] == [1.0, 2.0] and anim[0].width == 4


def test_deforming_mesh_per_frame(tmp_path):
    """Mesh vertices may move between frames (one OBJ per frame); connectivity may not."""
    quad = [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)]
    xmls = []
    for k, (lift, faces) in enumerate([(0.0, "f 1 2 3\nf 1 3 4"), (0.4, "f 1 2 3\nf 1 3 4"), (0.4, "f 1 2 4\nf 2 3 4")]):
        obj = tmp_path / f"sheet{k}.obj"
        verts = "\n".join(f"v {x} {y} {z + (lift if x > 0 else 0.0)}" for x, y, z in quad)
        obj.write_text(verts + "\n" + faces + "\n")
        xmls.append(_tiny_xml(tmp_path, f"f{k}.xml", f'<shape type="obj" id="sheet"><string name="filename" value="{obj.name}"/></shape>'))
    anim = ml.load_animation(xmls[:2])
    z = [a.mesh(0)["positions"][:, 2] for a in anim]
    assert z[0].max() == 0.0 and z[1].max() == pytest.approx(0.4)
    with pytest.raises(ml.SceneError, match=r"f2.xml:\d+: frame 2: shape 0 'sheet': triangle \d+ has vertices .* different connectivity"):
        ml.load_animation(xmls)


@pytest.mark.parametrize("k", [0, 5])
def test_bounce_frames_match_mitsuba(mitsuba_ref, k):
    """Frame k of the bundled animation as Mitsuba loads it (mi.load_file(path, **params), mi.traverse)
    and renders it (pixel-centre direct light)."""
    mi = mitsuba_ref.mitsuba()
    params = dict(animation_frames("bounce", count=8)[k], res=24)
    scene = ml.load_scene(BOUNCE, **params)
    ms = mitsuba_ref.load(BOUNCE, **params)
    p = mi.traverse(ms)
    sensor_key = next(key for key in p.keys() if key.endswith(".to_world") and key.startswith("object_"))
    cam = np.array(p[sensor_key].matrix, dtype=np.float64).reshape(4, 4)
    for col, name in enumerate(["left", "up", "forward", "origin"]):
        np.testing.assert_allclose(scene.camera[name], cam[:3, col], atol=1e-5, err_msg=name)
    # The animated box: Mitsuba's world-space vertices, in its own order.
    names = [s["id"] for s in scene.shapes]
    mesh = scene.mesh(names.index("box"))
    np.testing.assert_allclose(mesh["positions"], np.array(p["box.vertex_positions"]).reshape(-1, 3), atol=1e-5)
    # The area light: its rectangle's corners are to_world applied to (+-1, +-1, 0); its radiance.
    light = np.array(p["area-light.to_world"].matrix, dtype=np.float64).reshape(4, 4)
    corners = np.array([[x, y, 0, 1] for x in (-1, 1) for y in (-1, 1)]) @ light.T
    ours = scene.mesh(names.index("area-light"))["positions"]
    ours = ours[np.lexsort(np.round(ours, 4).T)]
    theirs = corners[np.lexsort(np.round(corners[:, :3], 4).T), :3]
    np.testing.assert_allclose(ours, theirs, atol=1e-5)
    area = next(e for e in scene.emitters if e["type"] == "area")
    np.testing.assert_allclose(area["radiance"], np.array(p["area-light.emitter.radiance.value"]).reshape(3))
    env = next(e for e in scene.emitters if e["type"] == "envmap")
    assert env["scale"] == pytest.approx(float(np.array(p["sky.scale"]).reshape(-1)[0]))
    # Render: Mitsuba's pixel-centre path max_depth=2 against our brute force of area + environment lights.
    mean, _ = mitsuba_ref.mitsuba_render(BOUNCE, (24, 24), max_depth=2, spp=256, **params)
    ours = ml.render_brute_force(scene, ml.generate_lights(scene, area=2048, environment=2048, seed=0),
                                 device="cpu", progress=False)

    def blocks(a):
        return a.reshape(6, 4, 6, 4, 3).mean(axis=(1, 3))

    rel = np.linalg.norm(blocks(ours) - blocks(mean)) / np.linalg.norm(blocks(mean))
    print(f"bounce frame {k}: block relative L2 against Mitsuba {rel:.4f}")
    assert rel < BLOCK_RTOL


def test_bad_input(tmp_path):
    with pytest.raises(ValueError, match="frame list is empty"):
        ml.load_animation(BOUNCE, frames=[])
    with pytest.raises(ValueError, match="frames is required"):
        ml.load_animation(BOUNCE)
    # A parameter the XML neither declares nor uses (Mitsuba refuses it too): refused before any frame loads.
    frames = animation_frames("bounce", count=3)
    frames[2] = dict(frames[2], wobble=1)
    with mock.patch.object(frames_module, "load_scene", side_effect=AssertionError("a frame loaded")):
        with pytest.raises(TypeError, match=r"frame 2 .*unexpected scene parameter 'wobble'"):
            ml.load_animation(BOUNCE, frames=frames, res=16)
    with pytest.raises(TypeError, match="frame 1 must be a dict"):
        ml.load_animation(BOUNCE, frames=[{}, 3])
    with pytest.raises(TypeError, match="frame 0: parameter names must be strings"):
        ml.load_animation(BOUNCE, frames=[{1: 2}])
    with pytest.raises(FileNotFoundError, match="frame 1"):
        ml.load_animation([BOUNCE, tmp_path / "missing.xml"])
    with pytest.raises(ValueError, match="2 scene files but 3 frame parameter dicts"):
        ml.load_animation([BOUNCE, BOUNCE], frames=[{}, {}, {}])
    with pytest.raises(ValueError, match="size"):
        ml.load_animation(BOUNCE, frames=[{}], size=(0, 4))
    with pytest.raises(TypeError, match="scene file or a list"):
        ml.load_animation(3, frames=[{}])
    # Different topology: named frame, shape, counts, file and line.
    a = _tiny_xml(tmp_path, "a.xml", '<shape type="cube" id="box"/>')
    b = _tiny_xml(tmp_path, "b.xml", '<shape type="rectangle" id="box"/>')
    with pytest.raises(ml.SceneError, match=r"b\.xml:\d+: frame 2: shape 0 'box' has 2 triangles but 12 in frame 0"):
        ml.load_animation([a, a, b])
    c = _tiny_xml(tmp_path, "c.xml", '<shape type="cube" id="box"/><shape type="cube" id="other"/>')
    with pytest.raises(ml.SceneError, match="frame 1: the scene has 2 shapes but frame 0 has 1"):
        ml.load_animation([a, c])
    d = _tiny_xml(tmp_path, "d.xml", '<shape type="cube" id="box"/>', width=8, height=8)
    with pytest.raises(ValueError, match=r"frame 1 .*film is 8x8 but frame 0's is 8x6"):
        ml.load_animation([a, d])
    # ... which a common size resolves.
    assert len(ml.load_animation([a, d], size=(8, 8))) == 2
    anim = ml.load_animation([a, a])
    with pytest.raises(IndexError, match="frame 2 out of range"):
        anim[2]
    with pytest.raises(TypeError, match="frame index must be an integer"):
        anim["0"]
