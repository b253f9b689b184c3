"""Pixel mappings between frames (tensor clustering paper, Sec. 4.4 and 5): exact identity on a static
scene, a single-light column carried across a camera move, CPU and GPU gathers, chains, bad input."""
from __future__ import annotations

import math

import numpy as np
import pytest

import manylights as ml
from manylights.scenes import animation_frames, scene_path

W = 40
FOV = 40.0
WALL_DISTANCE = 5.0
# Pixel footprint on the wall (camera at z = 4, wall at z = -1, fov 40 degrees along x).
FOOTPRINT = 2 * WALL_DISTANCE * math.tan(math.radians(FOV / 2)) / W

# A fronto-parallel wall, a floor and a box in front, one point light fixed in the world; the camera
# translates sideways (target moving with it: a pure translation) by `cx`.
RIG = f"""<scene version="3.0.0">
    <default name="res" value="{W}"/>
    <default name="cx" value="0"/>
    <sensor type="perspective">
        <float name="fov" value="{FOV}"/>
        <transform name="to_world"> <lookat origin="$cx, 0.5, 4" target="$cx, 0.5, -1" up="0, 1, 0"/> </transform>
        <film type="hdrfilm"> <integer name="width" value="$res"/> <integer name="height" value="$res"/> </film>
    </sensor>
    <bsdf type="diffuse" id="white"> <rgb name="reflectance" value="0.7, 0.7, 0.7"/> </bsdf>
    <bsdf type="diffuse" id="grey"> <rgb name="reflectance" value="0.4, 0.45, 0.5"/> </bsdf>
    <bsdf type="diffuse" id="yellow"> <rgb name="reflectance" value="0.8, 0.6, 0.1"/> </bsdf>
    <shape type="rectangle" id="wall"> <transform name="to_world"> <scale value="4"/> <translate z="-1"/> </transform> <ref id="white"/> </shape>
    <shape type="rectangle" id="floor"> <transform name="to_world"> <scale value="4"/> <rotate x="1" angle="-90"/> <translate y="-1" z="2"/> </transform> <ref id="grey"/> </shape>
    <shape type="cube" id="box"> <transform name="to_world"> <scale value="0.5"/> <rotate y="1" angle="25"/> <translate x="0.3" y="-0.5" z="0.5"/> </transform> <ref id="yellow"/> </shape>
    <emitter type="point"> <point name="position" x="1" y="2" z="3"/> <rgb name="intensity" value="10, 10, 10"/> </emitter>
</scene>
"""

# A pixel "matches" when every channel is within 1e-3 of the reference pixel's largest channel (the
# acceptance criterion), plus 1e-7 absolute for pixels in shadow (0 in both).
MATCH_RTOL = 1e-3
# A destination pixel is disoccluded when the surface point its mapping found lies farther than this many
# pixel footprints (on its surface) from its own point: more than half a pixel diagonal (0.707), so the
# point was not seen in the source frame. Measured on the rig: wall pixels lie at < 1e-4 footprints
# (aligned) or >= 0.75 (the two columns entering the view), floor and box pixels below 0.7.
DISOCCLUSION_FOOTPRINTS = 0.75


@pytest.fixture(scope="module")
def rig(tmp_path_factory):
    path = tmp_path_factory.mktemp("rig") / "rig.xml"
    path.write_text(RIG)
    return path


def _column(scene):
    """The single point light's column (exact CPU rays): (H, W, 3)."""
    return ml.LightMatrix(scene, ml.scene_lights(scene), device="cpu").columns([0])[0]


def test_static_scene_maps_every_surface_pixel_to_itself(rig):
    anim = ml.load_animation(rig, frames=[{"cx": 0.25}] * 3)
    sid = anim[0].gbuffer()["shape_index"]
    ident = np.arange(W * W).reshape(W, W)
    want = np.where(sid >= 0, ident, -1)
    for k, l in [(0, 1), (1, 0), (0, 2), (2, 0)]:
        np.testing.assert_array_equal(anim.mapping(k, l), want)
    np.testing.assert_array_equal(anim.mapping(1, 1), ident)
    col = _column(anim[0])
    np.testing.assert_array_equal(ml.apply_mapping(col, anim.mapping(0, 2), device="cpu"), col)
    np.testing.assert_array_equal(ml.apply_mapping(col, anim.mapping(0, 2), device="gpu"), col)


def test_camera_move_carries_a_single_light_column(rig):
    """Rigid move: the camera translates by 2 wall pixels; the light and the scene stay. Mapped frame-0
    column against frame 1's own column, outside disocclusions."""
    anim = ml.load_animation(rig, frames=[{"cx": 0.0}, {"cx": repr(2 * FOOTPRINT)}])
    col0, col1 = _column(anim[0]), _column(anim[1])
    M = anim.mapping(0, 1)
    mapped = ml.apply_mapping(col0, M)
    g = anim.gbuffers()
    sid = g["shape_index"][1]
    src = M.reshape(-1)
    p0 = g["position"][0].reshape(-1, 3)
    p1 = g["position"][1].reshape(-1, 3)
    dist = np.where(src >= 0, np.linalg.norm(p1 - p0[np.maximum(src, 0)], axis=1), np.inf).reshape(W, W)
    camera = np.array([2 * FOOTPRINT, 0.5, 4.0])
    # A pixel's footprint on its surface: depth x pixel angle, stretched by 1 / cos at grazing angles.
    cos = np.abs((g["normal"][1] * g["wi"][1]).sum(-1))
    footprint = (np.linalg.norm(g["position"][1] - camera, axis=-1) * 2 * math.tan(math.radians(FOV / 2)) / W
                 / np.maximum(cos, 0.1))
    seen = (sid >= 0) & (dist <= DISOCCLUSION_FOOTPRINTS * footprint)

    def matches(img):
        return np.abs(img - col1).max(-1) <= MATCH_RTOL * np.abs(col1).max(-1) + 1e-7

    fraction = matches(mapped)[seen].mean()
    unmapped = matches(col0)[seen].mean()
    wall = seen & (sid == 0)
    print(f"rigid camera move: {seen.sum()} of {(sid >= 0).sum()} surface pixels outside disocclusions; "
          f"{fraction:.3f} match to {MATCH_RTOL} (wall {matches(mapped)[wall].mean():.3f}, floor "
          f"{matches(mapped)[seen & (sid == 1)].mean():.3f}, box {matches(mapped)[seen & (sid == 2)].mean():.3f}); "
          f"without the mapping {unmapped:.3f}")
    # The wall's pixels are the same world points in both frames (the move is a whole number of its
    # pixels): the mapping finds them and the shading is identical.
    assert matches(mapped)[wall].all()
    # Floor and box samples do not line up (other depths): their nearest neighbours lie up to half a pixel
    # away, and the shading gradient over that exceeds 1e-3. Measured (CPU deep framebuffers): 0.843 of
    # the 1519 pixels outside disocclusions (wall 1.0, floor 0.395, box 0.283), 0.038 without the mapping.
    assert fraction >= 0.80
    assert unmapped <= 0.05
    # Disocclusions: the two wall columns entering the view (frame border), 2 x 40 pixels.
    assert 70 <= ((sid >= 0) & ~seen).sum() <= 90
    rel_mapped = np.linalg.norm((mapped - col1)[seen]) / np.linalg.norm(col1[seen])
    rel_unmapped = np.linalg.norm((col0 - col1)[seen]) / np.linalg.norm(col1[seen])
    print(f"relative L2 outside disocclusions: mapped {rel_mapped:.4f}, unmapped {rel_unmapped:.4f}")
    # Measured: 0.0103 mapped, 0.239 unmapped (ratio 0.043).
    assert rel_mapped < 0.1 * rel_unmapped


@pytest.fixture(scope="module")
def bounce():
    return ml.load_animation(scene_path("bounce"), frames=animation_frames("bounce", count=4), res=32)


def test_chains_compose_and_gpu_equals_cpu(bounce):
    M01, M12, M23 = bounce.mapping(0, 1), bounce.mapping(1, 2), bounce.mapping(2, 3)
    M03 = bounce.mapping(0, 3)
    flat01, flat12, flat23 = M01.reshape(-1), M12.reshape(-1), M23.reshape(-1)
    # M(0 -> 3)[i] = M01[M12[M23[i]]], -1 propagating.
    want = np.full(flat23.shape, -1)
    ok = flat23 >= 0
    mid = np.where(ok, flat12[np.maximum(flat23, 0)], -1)
    ok2 = mid >= 0
    want[ok2] = flat01[mid[ok2]]
    np.testing.assert_array_equal(M03.reshape(-1), want)
    # Backward mappings are computed (not the forward ones inverted) and compose the same way.
    M30 = bounce.mapping(3, 0)
    np.testing.assert_array_equal(M30, ml._native.compose_mappings([bounce.mapping(3, 2), bounce.mapping(2, 1), bounce.mapping(1, 0)]))
    rng = np.random.default_rng(0)
    imgs = rng.random((2, 32, 32, 3), dtype=np.float32)
    cpu_chain = ml.apply_mapping(imgs, [M01, M12, M23], device="cpu")
    gpu_chain = ml.apply_mapping(imgs, [M01, M12, M23], device="gpu")
    np.testing.assert_array_equal(cpu_chain, gpu_chain)
    np.testing.assert_array_equal(ml.apply_mapping(imgs, M03, device="gpu"), cpu_chain)
    # The gather itself: out[i] = image[M[i]], 0 where M[i] = -1.
    flat = imgs[0].reshape(-1, 3)
    want_img = np.where((M03.reshape(-1) >= 0)[:, None], flat[np.maximum(M03.reshape(-1), 0)], 0.0).reshape(32, 32, 3)
    np.testing.assert_array_equal(cpu_chain[0], want_img)
    # Each frame's background pixels map to -1; surface pixels to surface pixels of the source frame.
    sid = bounce.gbuffers()["shape_index"]
    assert np.array_equal(M01 < 0, sid[1] < 0)
    assert (sid[0].reshape(-1)[M01[M01 >= 0]] >= 0).all()


def test_apply_mapping_bad_input(bounce):
    M = bounce.mapping(0, 1)
    img = np.zeros((32, 32, 3), np.float32)
    bad = M.copy()
    bad[3, 5] = 32 * 32
    with pytest.raises(ValueError, match=r"mapping\[3, 5\] = 1024 is not a pixel index in \[0, 1024\)"):
        ml.apply_mapping(img, bad)
    bad[3, 5] = -2
    with pytest.raises(ValueError, match=r"mapping\[3, 5\] = -2"):
        ml.apply_mapping(img, bad)
    with pytest.raises(TypeError, match="integer array"):
        ml.apply_mapping(img, M.astype(np.float32))
    with pytest.raises(ValueError, match=r"images must have shape \(K, 32, 32, 3\)"):
        ml.apply_mapping(np.zeros((16, 32, 3), np.float32), M)
    with pytest.raises(ValueError, match=r"\(H, W, 3\) or \(K, H, W, 3\)"):
        ml.apply_mapping(np.zeros((32, 32), np.float32), M)
    with pytest.raises(ValueError, match="empty"):
        ml.apply_mapping(img, [])
    with pytest.raises(ValueError, match=r"mapping\[1\] is 16x32"):
        ml.apply_mapping(img, [M, M[:16]])
    with pytest.raises(ValueError, match="must be an \\(H, W\\) integer array"):
        ml.apply_mapping(img, M.reshape(-1))
    with pytest.raises(ValueError, match="device must be"):
        ml.apply_mapping(img, M, device="tpu")
    with pytest.raises(TypeError, match="real numeric"):
        ml.apply_mapping(np.full((32, 32, 3), "x"), M)
    with pytest.raises(IndexError, match="frame 4 out of range"):
        bounce.mapping(0, 4)
    with pytest.raises(TypeError):
        bounce.mapping(0.5, 1)
