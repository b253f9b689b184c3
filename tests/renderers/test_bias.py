"""Known bias sources (``manylights.renderers.bias``): every result lists the ones its light model has, and
``ml.render("scene.xml", target_error=e)`` claims no target while one is active."""
import numpy as np
import pytest

import manylights as ml
from conftest import REPO
from manylights.renderers.bias import bias_sources, skipped_lobes

CBOX = REPO / "scenes" / "cbox" / "scene.xml"
CBOX_LIGHTS = REPO / "scenes" / "cbox-lights" / "scene.xml"

# A floor of one BSDF under a small area light, seen from above: 16x16 pixels, the light hides 6x6 of them.
PLATE = """<scene version="3.0.0">
    <sensor type="perspective">
        <float name="fov" value="30"/>
        <transform name="to_world"><lookat origin="0, 3, 0.01" target="0, 0, 0" up="0, 0, 1"/></transform>
        <film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="16"/></film>
    </sensor>
    {bsdfs}
    <shape type="rectangle">
        <transform name="to_world"><scale value="4"/><rotate x="1" angle="-90"/></transform>
        <ref id="floor"/>
    </shape>
    <shape type="rectangle">
        <transform name="to_world"><scale value="0.2"/><rotate x="1" angle="90"/><translate y="1"/></transform>
        <emitter type="area"><rgb name="radiance" value="5, 5, 5"/></emitter>
    </shape>
</scene>
"""
ROUGH = '<bsdf type="roughconductor" id="{id}"><float name="alpha" value="{alpha}"/></bsdf>'
BLEND = ('<bsdf type="blendbsdf" id="floor"><float name="weight" value="0.5"/>'
         '<bsdf type="diffuse"/>' + ROUGH.format(id="inner", alpha="{alpha}") + '</bsdf>')


def plate(tmp_path, name, bsdfs):
    path = tmp_path / f"{name}.xml"
    path.write_text(PLATE.format(bsdfs=bsdfs))
    return ml.load_scene(path)


def matrix(scene, **gen):
    return ml.LightMatrix(scene, ml.generate_lights(scene, **gen), device="cpu")


def test_clamped_vpls_are_a_bias_source_and_compensated_or_unclamped_ones_are_not():
    scene = ml.load_scene(CBOX, res=16)
    A = matrix(scene, area=64, indirect=200, seed=1)
    src = bias_sources(A)
    assert [s["source"] for s in src] == ["vpl_clamp"]
    n_vpl = int(np.count_nonzero(np.asarray(A.lights.kind) == 4))
    assert src[0]["lights"] == n_vpl > 100 and src[0]["clamp"] == pytest.approx(float(A.lights.vpl_clamp))
    assert "bias_compensation" in src[0]["reason"]
    res = ml.mrcs(A, rows=16, columns=32)
    assert res.bias_sources == src
    assert ml.power_sampling(A, columns=32).bias_sources == src
    assert bias_sources(matrix(scene, area=64, indirect=200, clamp=float("inf"))) == []
    assert bias_sources(matrix(scene, area=64)) == []  # direct light only: no VPL


def test_virtual_spherical_lights_are_a_bias_source():
    scene = ml.load_scene(CBOX, res=16)
    A = matrix(scene, area=16, indirect=100, indirect_kind="vsl")
    src = bias_sources(A)
    assert [s["source"] for s in src] == ["vsl_radius"]
    radius = np.asarray(A.lights.vsl_radius)
    assert src[0]["lights"] == int(np.count_nonzero(radius > 0)) > 50
    assert src[0]["max_radius"] == pytest.approx(float(radius.max()))


CLEARCOAT = ('<bsdf type="blendbsdf" id="floor"><float name="weight" value="0.5"/><bsdf type="diffuse"/>'
             '<bsdf type="principled"><float name="roughness" value="0.5"/><float name="clearcoat" value="{cc}"/>'
             '<float name="clearcoat_gloss" value="0.9"/></bsdf></bsdf>')


@pytest.mark.parametrize("cc, flagged", [(1.0, True), (0.0, False)])
def test_a_clearcoat_is_a_bias_source_even_inside_a_blend(tmp_path, cc, flagged):
    scene = plate(tmp_path, "clearcoat", CLEARCOAT.format(cc=cc))
    A = matrix(scene, area=16)
    src = bias_sources(A)
    if not flagged:
        assert src == []
        return
    assert [s["source"] for s in src] == ["glossy_lobe_without_mis"]
    shape = np.asarray(scene.gbuffer(device="cpu")["shape_index"])
    # The floor's pixels: all 256 but the 36 where the light, between camera and floor, hides it.
    assert src[0]["view_samples"] == int(np.count_nonzero(shape == 0)) == 256 - 36
    # Nested BSDFs load first; clearcoat alpha = lerp(0.1, 0.001, 0.9) = 0.0109.
    assert src[0]["lobes"] == ["principled 1 clearcoat alpha 0.0109 inside blendbsdf 2"]
    assert ml.mrcs(A, rows=4, columns=8).bias_sources == src


@pytest.mark.parametrize("bsdfs", [BLEND.format(alpha=0.05), ROUGH.format(id="floor", alpha=0.05)])
def test_glossy_mis_covers_rough_lobes_alone_or_blended(tmp_path, bsdfs):
    scene = plate(tmp_path, "rough", bsdfs)
    A = matrix(scene, area=16)
    assert bias_sources(A) == []  # alpha 0.05 < 0.2: BSDF samples (A.glossy_work counts them)
    assert A.glossy_work[0] == 256 - 36


def test_twosided_blends_and_textured_clearcoats_are_resolved():
    bsdfs = [{"type": "twosided", "front": 1, "back": 1},
             {"type": "principled", "roughness": 0.1, "clearcoat": 0.5, "clearcoat_gloss": 0.0},
             {"type": "principled", "roughness": 0.1, "clearcoat": 0.0, "clearcoat_gloss": 1.0},
             {"type": "principled", "clearcoat": "texture[0]"},
             {"type": "roughconductor", "alpha_u": "texture[1]", "alpha_v": 0.1}]
    assert skipped_lobes(bsdfs, 0, 0.2) == ["principled 1 clearcoat alpha 0.1"]
    assert skipped_lobes(bsdfs, 1, 0.05) == []  # wider than the threshold
    assert skipped_lobes(bsdfs, 2, 0.2) == []  # no clearcoat
    assert skipped_lobes(bsdfs, 3, 0.2) == ["principled 3 clearcoat with a textured clearcoat or gloss"]
    assert skipped_lobes(bsdfs, 4, 0.2) == []  # glossy MIS reads textured roughness per view sample
    assert skipped_lobes(bsdfs, 7, 0.2) == []  # out of range: nothing


def test_render_does_not_claim_a_target_while_a_bias_source_is_active():
    # Without probes the estimates cover variance only (with them: tests/renderers/test_probe_error.py).
    opts = dict(params={"res": 16}, rows_per_column=0.25, progress=False, first_lights=64, max_lights=256,
                error_probes=0)
    res = ml.render(str(CBOX_LIGHTS), target_error=0.2, seed=1, **opts)
    assert [s["source"] for s in res.bias_sources] == ["vpl_clamp"]
    assert res.budget["target_reached"] is False
    assert res.budget["target_reason"].startswith("not claimed") and "vpl_clamp" in res.budget["target_reason"]
    # Direct light only (max_depth 2): no VPL, no known bias; the estimate's verdict stands.
    direct = ml.render(str(CBOX_LIGHTS), target_error=0.2, seed=1, max_depth=2, **opts)
    assert direct.bias_sources == []
    assert direct.budget["target_reached"] is (direct.budget["estimated_total_error"] <= 0.2)
    assert direct.budget["target_reached"] is True, direct.budget["target_reason"]
    assert "no known bias source" in direct.budget["target_reason"]


def test_animation_results_list_the_bias_sources_of_their_light_model():
    from manylights.scenes import animation_frames, scene_path

    anim = ml.load_animation(scene_path("bounce"), frames=animation_frames("bounce", 2), size=(16, 16), device="cpu")
    lights = ml.generate_animation_lights(anim, area=64, environment=64, indirect=64, photons=0)
    T = ml.LightTensor(anim, lights, device="cpu")
    n_vpl = int((np.asarray(lights[0].kind) == 4).sum())
    for res in (ml.tensor_clustering(T, rows=16, columns=32), ml.mrcs_per_frame(T, rows=16, columns=32)):
        assert [s["source"] for s in res.bias_sources] == ["vpl_clamp"] and res.bias_sources[0]["lights"] == n_vpl > 0
    direct = ml.generate_animation_lights(anim, area=64, environment=64, indirect=0, photons=0)
    assert ml.tensor_clustering(ml.LightTensor(anim, direct, device="cpu"), rows=16, columns=32).bias_sources == []


ANISO = ('<bsdf type="roughconductor" id="floor"><float name="alpha_u" value="0.05"/>'
         '<float name="alpha_v" value="0.3"/></bsdf>')


def test_anisotropic_lobes_in_a_turned_frame_are_a_bias_source_no_probe_covers(tmp_path):
    # The plate's floor: its rectangle's dp_du (the x axis) is coordinate_system(n)'s first tangent, the frame
    # Mitsuba shades in: no source.
    scene = plate(tmp_path, "aniso-floor", ANISO)
    assert [s["anisotropic_frame"] for s in scene.shapes] == [False, False]
    assert bias_sources(matrix(scene, area=16)) == []
    # The same BSDF on a sphere, whose dp_du is its azimuth: the frames differ by a turn about n.
    path = tmp_path / "aniso-sphere.xml"
    path.write_text(PLATE.format(bsdfs=ANISO).replace(
        '<shape type="rectangle">\n        <transform name="to_world"><scale value="4"/><rotate x="1" angle="-90"/></transform>',
        '<shape type="sphere" id="ball"><float name="radius" value="0.5"/>', 1))
    scene = ml.load_scene(path)
    assert [s["type"] for s in scene.shapes] == ["sphere", "rectangle"]
    assert [s["anisotropic_frame"] for s in scene.shapes] == [True, False]
    src = bias_sources(matrix(scene, area=16))
    assert [s["source"] for s in src] == ["anisotropic_frame"] and src[0]["shapes"] == ["ball"]
    # The probes' path tracer shades in the same frame: their bound cannot cover it, so no claim.
    res = ml.render(path, target_error=0.5, seed=0, max_depth=2, progress=False, first_lights=64, max_lights=256,
                    error_probes=32, probe_spp=16)
    assert [s["source"] for s in res.bias_sources] == ["anisotropic_frame"]
    assert res.budget["target_reached"] is False
    assert "cannot cover" in res.budget["target_reason"] and "anisotropic_frame" in res.budget["target_reason"]
