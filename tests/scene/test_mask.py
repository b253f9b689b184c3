"""Mitsuba's ``mask`` BSDF (opacity cut-outs) on the CPU and GPU backends (``src/raytrace/mask.rs``,
``src/view/chains.rs``, ``src/gpu/mask.rs``, ``shaders/common/mask.wgsl``).

- Pixel-centre renders of ``tests/data/mask_leaves.xml`` (two masked quads, opacity 0.5 and a 0.1 / 0.85
  checkerboard, over a floor under a small area light, 64 x 48) against converged Mitsuba 3.9.1 references
  (``tests/references/mask-leaves*``, ``llvm_ad_rgb``) at max_depth -1, 3 and 2: relative L2 of the brute-force
  image (``column_sum() + emitted()``, 4096 area-light samples) within 1.5x the reference's noise. Each depth
  checks one rule: -1 the (1 - opacity) transmittance of camera rays and shadow rays; 3 that a shadow ray may
  cross a mask only with depth to spare (the floor seen through a mask gets no light through a mask); 2 that
  nothing is seen or lit through a mask, and Mitsuba's ``valid_ray`` factor. Measured: 0.402% / 0.398% / 0.218%
  against noise 0.400% / 0.399% / 0.200%. The same scene with opaque quads (the masks' nested BSDFs alone), and
  our render at another depth, are >= 10x the noise away from each reference.
- The probe path tracer (``probe_pixels``, Mitsuba's ``path`` with masks) at 130 pixels against the same
  references: mean squared z-score near 1, and far from 1 against the reference of another depth.
- Masks around delta BSDFs (``tests/data/mask_delta.xml``: a gold mirror of opacity 0.5 and a checkerboard-masked
  smooth plastic; reference ``mask-delta``): brute force within 1.5x the reference's noise (measured 0.389% against
  0.400%), the masks replaced by their nested BSDFs or the nested BSDFs made black >= 10x the noise away; probes;
  the GPU; VPL particles through a masked mirror; a masked glass sphere (``tests/data/mask_glass.xml``) within the
  delta chains' own deviation on the glass alone plus the noise.
- VPL tracing: the flux a masked quad passes and reflects, the depth a null event consumes, and no light from a
  point light through a mask; the same for the gather samples of animation lights (equal to the still scene's
  VPL power), and their brute-force image of a masked box against the still scene's VPLs' (relative L2 within the
  noise of both seed means).
- Glossy MIS on a glossy floor under the masks against pure light columns (light through a mask reaches
  Mitsuba only by BSDF sampling, weight 1, and is carried whole by the light columns).
- RIS (with and without spatial reuse) and clustered visibility (both backends) against the brute force; bias
  compensation runs on a masked box (its
  unbiasedness through masks is measured in ``src/matrix/bias_compensation/tests.rs``). Direct-to-indirect
  relighting through masks: ``tests/relight/test_relight_masks.py``.
- The GPU backend's brute-force image against the CPU's (relative L2 within the project's GPU-vs-CPU tolerance)
  and against the same Mitsuba references (within the CPU's tolerance) at max_depth -1, 3 and 2; a mask around a
  rough dielectric runs on the GPU too (``device_info`` gives no reason to refuse it).
- Loading (exact values) and the refusals with file, line and value.
"""
from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

import manylights as ml

HERE = Path(__file__).resolve().parents[1]
DATA = HERE / "data"
REFS = HERE / "references"
# Relative L2 against a reference may exceed the reference's own noise by this factor (our image is exact up to
# the area light's discretisation into 4096 samples).
TOL_NOISE = 1.5
# Opaque quads must miss the reference by at least this many noise levels (the test can fail).
OFF_NOISE = 10.0
AREA_SAMPLES = 4096


def _render(scene, max_depth):
    A = ml.LightMatrix(scene, ml.generate_lights(scene, area=AREA_SAMPLES), device="cpu", max_depth=max_depth)
    return np.asarray(A.column_sum(progress=False)) + A.emitted()


def _opaque(text):
    """The XML with each mask replaced by its nested BSDF (the opacity dropped)."""
    text = re.sub(r'<float name="opacity" value="[\d.]+"/>', "", text)
    text = re.sub(r'<texture type="checkerboard" name="opacity">.*?</texture>', "", text, flags=re.S)
    text = re.sub(r'<bsdf type="mask">\s*(<bsdf type="diffuse">.*?</bsdf>)\s*</bsdf>', r"\1", text, flags=re.S)
    assert "mask" not in text.split("-->", 1)[1]
    return text


@pytest.mark.parametrize("name, max_depth, other_depth", [("mask-leaves", -1, 3), ("mask-leaves-depth3", 3, -1),
                                                         ("mask-leaves-depth2", 2, 3)])
def test_render_matches_mitsuba(name, max_depth, other_depth, tmp_path):
    meta = json.loads((REFS / f"{name}.json").read_text())
    assert meta["integrator"] == {"type": "path", "max_depth": max_depth} and meta["mitsuba"] == "3.9.1"
    ref, var = ml.read_exr(REFS / f"{name}.exr"), ml.read_exr(REFS / f"{name}.var.exr")
    den = (ref ** 2).sum()
    noise = float(np.sqrt(var.sum() / den))
    img = _render(ml.load_scene(DATA / "mask_leaves.xml"), max_depth)
    err = float(np.sqrt(((img - ref) ** 2).sum() / den))
    flat = tmp_path / "opaque.xml"
    flat.write_text(_opaque((DATA / "mask_leaves.xml").read_text()))
    off = float(np.sqrt(((_render(ml.load_scene(flat), max_depth) - ref) ** 2).sum() / den))
    # The render at another depth (measured 24x, 24x and 265x the noise).
    other = float(np.sqrt(((_render(ml.load_scene(DATA / "mask_leaves.xml"), other_depth) - ref) ** 2).sum() / den))
    print(f"\n{name}: relative L2 {err:.3%} (reference noise {noise:.3%}; opaque quads {off:.2%}; "
          f"max_depth {other_depth} {other:.2%})")
    assert err <= TOL_NOISE * noise
    assert off >= OFF_NOISE * noise
    assert other >= OFF_NOISE * noise


# Mean squared z-score of probes against a reference: about 1 when both estimate the same image (390 values,
# 130 pixels x RGB, correlated across channels: its spread is about 0.12).
PROBE_CHI2 = 1.5
# Against the reference of another max_depth it must be far above (the test can fail).
PROBE_CHI2_WRONG = 10.0


def _probe_chi2(scene, name, max_depth):
    ref, var = ml.read_exr(REFS / f"{name}.exr"), ml.read_exr(REFS / f"{name}.var.exr")
    rows, cols = np.meshgrid(np.arange(2, 48, 5), np.arange(2, 64, 5), indexing="ij")
    px = np.stack([rows.ravel(), cols.ravel()], 1).astype(np.int64)
    mean, pvar = ml.probe_pixels(scene, px, spp=1024, max_depth=max_depth, seed=1)
    r, c = px[:, 0], px[:, 1]
    z = (np.asarray(mean) - ref[r, c]) / np.sqrt(np.asarray(pvar) + var[r, c] + 1e-12)
    return float((z ** 2).mean())


@pytest.mark.parametrize("name, max_depth, wrong", [("mask-leaves", -1, "mask-leaves-depth2"),
                                                    ("mask-leaves-depth3", 3, "mask-leaves-depth2"),
                                                    ("mask-leaves-depth2", 2, "mask-leaves")])
def test_probes_match_mitsuba(name, max_depth, wrong):
    scene = ml.load_scene(DATA / "mask_leaves.xml")
    chi2, chi2_wrong = _probe_chi2(scene, name, max_depth), _probe_chi2(scene, wrong, max_depth)
    print(f"\n{name}: probes' mean z^2 {chi2:.2f} (against {wrong}: {chi2_wrong:.1f})")
    assert chi2 < PROBE_CHI2
    assert chi2_wrong > PROBE_CHI2_WRONG


def test_load_values_and_view_samples():
    scene = ml.load_scene(DATA / "mask_leaves.xml")
    b = scene.bsdfs
    assert b[3] == {"type": "mask", "opacity": 0.5, "bsdf": 2}
    assert b[5] == {"type": "mask", "opacity": "texture[0]", "bsdf": 4}
    assert b[2]["type"] == b[4]["type"] == "diffuse"
    assert np.allclose(b[2]["reflectance"], [0.8, 0.3, 0.2])
    # Every pixel on a quad gets one extra view sample (the floor behind, with throughput 1 - opacity);
    # at max_depth 2 the floor behind is not a view sample (it would not sample emitters).
    A = ml.LightMatrix(scene, ml.generate_lights(scene, area=16), device="cpu", max_depth=-1)
    vs = A.view_samples()
    m = 64 * 48
    assert A.shape[0] == m
    extra = vs["pixel"][m:]
    assert len(extra) > 100 and len(np.unique(extra)) == len(extra)
    A2 = ml.LightMatrix(scene, ml.generate_lights(scene, area=16), device="cpu", max_depth=2)
    assert len(A2.view_samples()["pixel"]) == m


# The GPU's image equals the CPU's exact rays up to f32 arithmetic (the project's GPU-vs-CPU tolerance,
# tests/lights/test_lights.py).
GPU_VS_CPU_TOL = 1.5e-3


@pytest.mark.parametrize("name, max_depth", [("mask-leaves", -1), ("mask-leaves-depth3", 3), ("mask-leaves-depth2", 2),
                                             ("mask-delta", -1)])
def test_gpu_matches_cpu_and_mitsuba(name, max_depth):
    ref, var = ml.read_exr(REFS / f"{name}.exr"), ml.read_exr(REFS / f"{name}.var.exr")
    den = (ref ** 2).sum()
    noise = float(np.sqrt(var.sum() / den))
    scene = ml.load_scene(DATA / ("mask_delta.xml" if name == "mask-delta" else "mask_leaves.xml"))
    assert ml.device_info("gpu", scene=scene)["reason"] is None
    lights = ml.generate_lights(scene, area=AREA_SAMPLES)
    imgs = {}
    for device in ("cpu", "gpu"):
        A = ml.LightMatrix(scene, lights, device=device, max_depth=max_depth, visibility="ray_traced")
        assert A.device["kind"] == device
        imgs[device] = np.asarray(A.column_sum(progress=False)) + A.emitted()
    err = ml.relative_l2(imgs["gpu"], imgs["cpu"])
    err_ref = float(np.sqrt(((imgs["gpu"] - ref) ** 2).sum() / den))
    print(f"\n{name}: GPU vs CPU relative L2 {err:.2e}; GPU vs Mitsuba {err_ref:.3%} (reference noise {noise:.3%})")
    assert np.isfinite(imgs["gpu"]).all()
    assert err <= GPU_VS_CPU_TOL
    assert err_ref <= TOL_NOISE * noise


def test_gpu_takes_a_mask_around_a_rough_dielectric(tmp_path):
    """Every nested BSDF a loaded mask can hold has a WGSL twin of its sampling density (the MIS weight of a
    masked surface's direct light): "gpu" gives no reason to refuse, and its image equals the CPU's."""
    p = tmp_path / "s.xml"
    p.write_text('<scene version="3.0.0">\n<sensor type="perspective"><transform name="to_world"><lookat origin="0, 0, 4" '
                 'target="0, 0, 0" up="0, 1, 0"/></transform><film type="hdrfilm"><integer name="width" value="16"/>'
                 '<integer name="height" value="12"/></film></sensor>\n<shape type="sphere"><bsdf type="mask">'
                 '<float name="opacity" value="0.5"/><bsdf type="roughdielectric"/></bsdf></shape>\n'
                 '<emitter type="point"><point name="position" x="1" y="3" z="3"/></emitter>\n</scene>')
    scene = ml.load_scene(p)
    assert ml.device_info("gpu", scene=scene)["reason"] is None
    lights = ml.scene_lights(scene)
    imgs = [np.asarray(ml.LightMatrix(scene, lights, device=d, visibility="ray_traced").column_sum(progress=False))
            for d in ("cpu", "gpu")]
    assert imgs[0].sum() > 0
    assert ml.relative_l2(imgs[1], imgs[0]) <= GPU_VS_CPU_TOL


def _delta_variant(tmp_path, kind):
    """mask_delta.xml with its masks replaced by their nested BSDFs (``opaque``), or with the nested BSDFs black
    (``black``: only the null lobe left)."""
    text = (DATA / "mask_delta.xml").read_text()
    if kind == "opaque":
        text = re.sub(r'<bsdf type="mask">\s*(?:<float name="opacity" value="[\d.]+"/>|<texture type="checkerboard" '
                      r'name="opacity">.*?</texture>)\s*(<bsdf type="(?:conductor|plastic)">.*?</bsdf>)\s*</bsdf>', r"\1",
                      text, flags=re.S)
    else:
        text = re.sub(r'<bsdf type="(conductor|plastic)">.*?</bsdf>',
                      '<bsdf type="diffuse"><rgb name="reflectance" value="0"/></bsdf>', text, flags=re.S)
    assert text.count('type="mask"') == (0 if kind == "opaque" else 2)
    p = tmp_path / f"delta_{kind}.xml"
    p.write_text(text)
    return ml.load_scene(p)


def test_mask_around_delta_bsdfs_matches_mitsuba(tmp_path):
    """A mask around a gold mirror (opacity 0.5) and around a smooth plastic (checkerboard opacity): the camera's delta
    chains follow the nested delta lobes times the opacity and the null lobe times 1 - opacity, shadow rays cross with
    (1 - opacity). Brute force against the pixel-centre Mitsuba reference (max_depth -1) within 1.5x its noise; the
    masks replaced by their nested BSDFs, and the nested BSDFs made black, >= 10x the noise away."""
    meta = json.loads((REFS / "mask-delta.json").read_text())
    assert meta["integrator"] == {"type": "path", "max_depth": -1} and meta["mitsuba"] == "3.9.1"
    ref, var = ml.read_exr(REFS / "mask-delta.exr"), ml.read_exr(REFS / "mask-delta.var.exr")
    den = (ref ** 2).sum()
    noise = float(np.sqrt(var.sum() / den))
    scene = ml.load_scene(DATA / "mask_delta.xml")
    assert sorted(b["type"] for b in scene.bsdfs) == ["conductor", "diffuse", "diffuse", "mask", "mask", "plastic"]
    err = float(np.sqrt(((_render(scene, -1) - ref) ** 2).sum() / den))
    offs = {k: float(np.sqrt(((_render(_delta_variant(tmp_path, k), -1) - ref) ** 2).sum() / den))
            for k in ("opaque", "black")}
    print(f"\nmask-delta: relative L2 {err:.3%} (reference noise {noise:.3%}); opaque masks {offs['opaque']:.2%}, "
          f"black nested BSDFs {offs['black']:.2%}")
    assert err <= TOL_NOISE * noise
    assert min(offs.values()) >= OFF_NOISE * noise


def test_mask_around_glass_matches_mitsuba():
    """A mask around a smooth glass sphere (refraction: the radiance scaling of a refracted chain times the opacity)
    over a floor under a point light, against pixel-centre Mitsuba references of the masked sphere and of the glass
    alone (opacity 1). The delta chains' own deviation on this glass (measured 0.558% against noise 0.173%, the glass
    alone) bounds the masked render's, plus the masked reference's noise (measured 0.568%, noise 0.195%); the glass
    alone is >= 10x the noise from the masked reference (measured 7.1%)."""
    def render(**params):
        scene = ml.load_scene(DATA / "mask_glass.xml", **params)
        A = ml.LightMatrix(scene, ml.scene_lights(scene), device="cpu", max_depth=-1)
        return np.asarray(A.column_sum(progress=False)) + A.emitted()

    def rel(img, name):
        ref, var = ml.read_exr(REFS / f"{name}.exr"), ml.read_exr(REFS / f"{name}.var.exr")
        den = (ref ** 2).sum()
        return float(np.sqrt(((img - ref) ** 2).sum() / den)), float(np.sqrt(var.sum() / den))

    masked, glass = render(), render(opacity=1.0)
    err, noise = rel(masked, "mask-glass")
    err_glass, _ = rel(glass, "mask-glass-opaque")
    off, _ = rel(glass, "mask-glass")
    print(f"\nmask-glass: relative L2 {err:.3%} (noise {noise:.3%}); the glass alone against its own reference "
          f"{err_glass:.3%}, against the masked one {off:.2%}")
    assert err <= err_glass + TOL_NOISE * noise
    assert off >= OFF_NOISE * noise


def test_probes_match_mitsuba_through_delta_masks():
    """The probe path tracer samples a masked delta BSDF's null lobe and its nested delta lobes."""
    scene = ml.load_scene(DATA / "mask_delta.xml")
    chi2, chi2_wrong = _probe_chi2(scene, "mask-delta", -1), _probe_chi2(scene, "mask-leaves", -1)
    print(f"\nmask-delta: probes' mean z^2 {chi2:.2f} (against mask-leaves: {chi2_wrong:.1f})")
    assert chi2 < PROBE_CHI2
    assert chi2_wrong > PROBE_CHI2_WRONG


@pytest.mark.parametrize("body, match", [
    ('<bsdf type="mask"><float name="opacity" value="0.3"/></bsdf>', r"s\.xml:3: .*mask.*exactly one nested BSDF is required, got none"),
    ('<bsdf type="mask">\n<float name="opacity" value="1.5"/><bsdf type="diffuse"/></bsdf>', r"s\.xml:4: .*mask.*opacity must be in \[0, 1\], got 1\.5"),
    ('<bsdf type="mask"><float name="opacity" value="-0.25"/><bsdf type="diffuse"/></bsdf>', r"s\.xml:3: .*opacity must be in \[0, 1\], got -0\.25"),
    ('<bsdf type="mask"><bsdf type="diffuse"/>\n<bsdf type="diffuse"/></bsdf>', r"s\.xml:4: .*mask.*only a single nested BSDF"),
    ('<bsdf type="mask"><bsdf type="mask"><bsdf type="diffuse"/></bsdf></bsdf>', r"s\.xml:3: .*a mask inside a mask"),
    ('<bsdf type="blendbsdf"><float name="weight" value="0.5"/><bsdf type="diffuse"/>\n<bsdf type="mask"><bsdf type="diffuse"/>'
     '</bsdf></bsdf>', r"s\.xml:4: .*blendbsdf.*a mask inside it is not supported"),
])
def test_bad_masks_name_file_line_and_value(tmp_path, body, match):
    p = tmp_path / "s.xml"
    p.write_text('<scene version="3.0.0">\n<sensor type="perspective"/>\n<shape type="sphere">' + body + "</shape>\n</scene>")
    with pytest.raises(ml.SceneError, match=match):
        ml.load_scene(p)


@pytest.mark.parametrize("nested", ["conductor", "dielectric", "thindielectric", "plastic"])
def test_mask_around_a_delta_bsdf_loads(tmp_path, nested):
    p = tmp_path / "s.xml"
    p.write_text('<scene version="3.0.0">\n<sensor type="perspective"/>\n<shape type="sphere"><bsdf type="mask">'
                 f'<float name="opacity" value="0.25"/><bsdf type="{nested}"/></bsdf></shape>\n</scene>')
    bsdfs = ml.load_scene(p).bsdfs
    assert sorted(b["type"] for b in bsdfs) == sorted(["mask", nested])


@pytest.mark.parametrize("body", [
    '<bsdf type="twosided"><bsdf type="mask"><float name="opacity" value="0.25"/><bsdf type="diffuse"/></bsdf></bsdf>',
    '<bsdf type="mask"><float name="opacity" value="0.25"/><bsdf type="twosided"><bsdf type="diffuse"/></bsdf></bsdf>',
])
def test_twosided_mask_loads(tmp_path, body):
    """The leaf idioms: a twosided around a mask, and a mask around a twosided."""
    p = tmp_path / "s.xml"
    p.write_text('<scene version="3.0.0">\n<sensor type="perspective"/>\n<shape type="sphere">' + body + "</shape>\n</scene>")
    bsdfs = ml.load_scene(p).bsdfs
    assert sorted(b["type"] for b in bsdfs) == ["diffuse", "mask", "twosided"]
    assert [b["opacity"] for b in bsdfs if b["type"] == "mask"] == [0.25]


def _vpl_scene(tmp_path, opacity, light, nested='<bsdf type="diffuse"><rgb name="reflectance" value="0.5"/></bsdf>'):
    """A light above a 20 x 20 masked quad (y = 1, nested ``nested``, diffuse 0.5 by default; none for opacity
    None) above a 20 x 20 floor (y = 0)."""
    emitter = ('<shape type="rectangle"><transform name="to_world"><scale value="0.5"/><rotate x="1" angle="90"/>'
               '<translate y="2"/></transform><bsdf type="diffuse"><rgb name="reflectance" value="0"/></bsdf>'
               '<emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>' if light == "area" else
               '<emitter type="point"><point name="position" x="0" y="2" z="0"/><rgb name="intensity" value="1"/></emitter>')
    p = tmp_path / f"vpl_{opacity}_{light}_{abs(hash(nested))}.xml"
    quad = "" if opacity is None else f"""<shape type="rectangle"><transform name="to_world"><scale value="10"/>
<rotate x="1" angle="-90"/><translate y="1"/></transform><bsdf type="mask"><float name="opacity" value="{opacity}"/>
{nested}</bsdf></shape>"""
    p.write_text(f"""<scene version="3.0.0">
<sensor type="perspective"><transform name="to_world"><lookat origin="0, 5, 5" target="0, 0, 0" up="0, 1, 0"/></transform>
<film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film></sensor>
{emitter}
{quad}
<shape type="rectangle"><transform name="to_world"><scale value="10"/><rotate x="1" angle="-90"/></transform>
<bsdf type="diffuse"><rgb name="reflectance" value="0.5"/></bsdf></shape>
</scene>""")
    return ml.load_scene(p)


def _vpl_power(scene, max_depth):
    """(floor, quad) summed VPL power (mean of RGB), 20000 VPLs."""
    s = ml.generate_lights(scene, area=0, indirect=20000, max_depth=max_depth, seed=3)
    power = np.asarray(s.power).mean(axis=1)
    floor = np.asarray(s.position)[:, 1] < 0.5
    return float(power[floor].sum()), float(power[~floor].sum())


# Relative tolerance of VPL power sums over 20000 VPLs (their relative noise is about 1%).
VPL_REL = 0.04


def test_vpls_pass_masks_with_one_minus_opacity(tmp_path):
    # An area light: the floor receives (1 - a) of what it receives through a fully open mask, one bounce later
    # (so none at max_depth 3, where VPLs are stored at the first bounce only); the quad reflects a of it.
    open_floor, open_quad = _vpl_power(_vpl_scene(tmp_path, 0.0, "area"), 4)
    floor, quad = _vpl_power(_vpl_scene(tmp_path, 0.3, "area"), 4)
    assert open_quad == 0.0 and open_floor > 0.0
    assert floor / open_floor == pytest.approx(0.7, rel=VPL_REL)
    solid_quad = _vpl_power(_vpl_scene(tmp_path, 1.0, "area"), 4)[1]
    assert quad / solid_quad == pytest.approx(0.3, rel=VPL_REL)
    # At max_depth 3 only particles that miss the quad (grazing, ~1% of the power) light the floor.
    assert _vpl_power(_vpl_scene(tmp_path, 0.3, "area"), 3)[0] < 0.05 * open_floor
    # A point light is reached only by emitter sampling, whose shadow rays masks block: nothing it emits
    # crosses the mask (Mitsuba's `path`); only what misses the quad reaches the floor (against no quad at all).
    p_open = _vpl_power(_vpl_scene(tmp_path, None, "point"), 4)[0]
    p_floor = _vpl_power(_vpl_scene(tmp_path, 0.3, "point"), 4)[0]
    assert p_floor < 0.1 * p_open


def _gather_power(scene, max_depth, clamp=1e30, photons=0):
    """(floor, quad) summed power (mean of RGB) of the indirect lights of ``generate_animation_lights`` on the
    one frame ``scene`` (gather samples lit by the direct light, and by ``photons`` of multiple bounces)."""
    lights = ml.generate_animation_lights([scene], area=1024, indirect=8192, max_depth=max_depth, clamp=clamp,
                                          photons=photons, seed=3)
    s = lights[0]
    kind = np.asarray(s.kind)
    power = np.asarray(s.power).mean(axis=1)[kind == 4]
    floor = np.asarray(s.position)[kind == 4][:, 1] < 0.5
    return float(power[floor].sum()), float(power[~floor].sum())


def test_animation_lights_pass_masks_as_vpls_do(tmp_path):
    """The gather samples of animation lights see the direct light through masks as VPL particles do: the floor
    under a quad of opacity 0.3 gets (1 - 0.3) of the power it gets through a fully open mask, the quad reflects
    0.3 of a solid one's, each equal to the still scene's VPL power (``generate_lights``, max_depth 4: the first
    bounce after at most one null event); nothing through the mask at max_depth 3 nor from a point light, and
    photons of multiple bounces do not count the light through the mask again."""
    open_floor, open_quad = _gather_power(_vpl_scene(tmp_path, 0.0, "area"), 4)
    floor, quad = _gather_power(_vpl_scene(tmp_path, 0.3, "area"), 4)
    solid_quad = _gather_power(_vpl_scene(tmp_path, 1.0, "area"), 4)[1]
    still_floor, still_quad = _vpl_power(_vpl_scene(tmp_path, 0.3, "area"), 4)
    print(f"\nanimation lights: floor {floor:.4f} (open {open_floor:.4f}, still VPLs {still_floor:.4f}); "
          f"quad {quad:.4f} (solid {solid_quad:.4f}, still VPLs {still_quad:.4f})")
    assert open_quad == 0.0 and open_floor > 0.0
    assert floor / open_floor == pytest.approx(0.7, rel=GATHER_REL)
    assert quad / solid_quad == pytest.approx(0.3, rel=GATHER_REL)
    assert floor == pytest.approx(still_floor, rel=VPL_REL)
    assert quad == pytest.approx(still_quad, rel=VPL_REL)
    assert _gather_power(_vpl_scene(tmp_path, 0.3, "area"), 3)[0] < 0.05 * open_floor
    # Light that reaches the floor through the mask has met no BSDF: it is direct light, which the photons of
    # multiple bounces must not count again (nothing bounces onto the floor in this scene).
    assert _gather_power(_vpl_scene(tmp_path, 0.3, "area"), 6, photons=20000)[0] == pytest.approx(floor, rel=1e-6)
    p_open = _gather_power(_vpl_scene(tmp_path, None, "point"), 4)[0]
    assert p_open > 0.0 and _gather_power(_vpl_scene(tmp_path, 0.3, "point"), 4)[0] < 0.01 * p_open


# Power ratios of gather samples in the same scene with another opacity (the same stratified samples and area
# points: only the 1024-point discretisation of the light differs; measured within 0.1%).
GATHER_REL = 0.01


def _masked_box(tmp_path, opacity=0.4):
    """A closed diffuse box (albedo 0.7, normals inward) under a small area light, with a masked shelf (diffuse,
    facing up) across half of it: every pixel has indirect light, some seen through the mask; None for no shelf."""
    diffuse = '<bsdf type="diffuse"><rgb name="reflectance" value="0.7"/></bsdf>'
    wall = "" if opacity is None else f"""<shape type="rectangle"><transform name="to_world"><scale x="0.65" y="1"/>
<rotate x="1" angle="-90"/><translate x="-0.35" y="-0.3"/></transform><bsdf type="mask">
<float name="opacity" value="{opacity}"/>{diffuse}</bsdf></shape>"""
    p = tmp_path / f"masked_box_{opacity}.xml"
    p.write_text(f"""<scene version="3.0.0">
<sensor type="perspective"><float name="fov" value="80"/><transform name="to_world"><lookat origin="0, 0, 0.9" target="0, 0, 0"
up="0, 1, 0"/></transform><film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="16"/></film></sensor>
<shape type="cube"><boolean name="flip_normals" value="true"/>{diffuse}</shape>
<shape type="rectangle"><transform name="to_world"><scale value="0.3"/><rotate x="1" angle="90"/><translate y="0.8"/></transform>
<bsdf type="diffuse"><rgb name="reflectance" value="0"/></bsdf><emitter type="area"><rgb name="radiance" value="1, 2, 3"/></emitter>
</shape>
{wall}
</scene>""")
    return ml.load_scene(p)


# Relative L2 between two unbiased light sets' mean images may exceed the noise of that difference by this
# factor (the noise is estimated from the seeds themselves).
ANIM_NOISE_FACTOR = 1.5


def _mean_images(scene, make, seeds=6):
    imgs = np.array([np.asarray(ml.LightMatrix(scene, make(seed), device="cpu").column_sum(progress=False))
                     for seed in range(seeds)])
    return imgs.mean(0), imgs.var(0, ddof=1) / seeds


def test_animation_lights_render_masks_as_vpls_do(tmp_path):
    """Brute-force images of a masked box (camera rays and shadow rays through a shelf of opacity 0.4) lit by
    animation lights (one frame; gather samples, one bounce) and by the still scene's VPLs at max_depth 3 (one
    bounce) agree within the noise of their seed means (measured 0.45% against 0.47%); animation lights generated
    with the shelf opaque are far off."""
    scene = _masked_box(tmp_path, 0.4)

    def anim(s, seed):
        return ml.generate_animation_lights([s], area=256, indirect=4096, max_depth=3, clamp=1e30, seed=seed)[0]

    ma, va = _mean_images(scene, lambda seed: anim(scene, seed))
    ms, vs = _mean_images(scene, lambda seed: ml.generate_lights(scene, area=256, indirect=4096, max_depth=3,
                                                                  clamp=1e30, seed=seed))
    den = np.sqrt((ms ** 2).sum())
    err = float(np.sqrt(((ma - ms) ** 2).sum()) / den)
    noise = float(np.sqrt((va + vs).sum()) / den)
    # Lights generated as if the wall were opaque, rendered in the masked box.
    opaque = _masked_box(tmp_path, 1.0)
    mo, _ = _mean_images(scene, lambda seed: anim(opaque, seed), seeds=2)
    off = float(np.sqrt(((mo - ms) ** 2).sum()) / den)
    print(f"\nanimation lights vs still VPLs: relative L2 {err:.3%} (noise {noise:.3%}); lights of an opaque shelf "
          f"{off:.2%}")
    assert err <= ANIM_NOISE_FACTOR * noise
    assert off >= OFF_NOISE * noise


def test_bias_compensation_crosses_masks(tmp_path):
    """Bias compensation on a masked scene (its paths, shadow rays and null events as the light matrix's and
    the probes'; unbiasedness against the unclamped VPL image is measured in
    ``src/matrix/bias_compensation/tests.rs``): it runs, and adds energy where the clamp removed some."""
    scene = _masked_box(tmp_path)
    lights = ml.generate_lights(scene, area=16, indirect=200, max_depth=-1, clamp=1.0, seed=0)
    A = ml.LightMatrix(scene, lights, device="cpu")
    comp = np.asarray(A.bias_compensation(spp=4, light_samples=0, seed=1))
    assert comp.shape == (16, 16, 3) and np.isfinite(comp).all()
    assert comp.min() >= 0 and comp.sum() > 0
    px = np.arange(0, 256, 5)
    part = np.asarray(A.bias_compensation(spp=4, light_samples=0, seed=1, pixels=px)).reshape(-1, 3)
    np.testing.assert_array_equal(part[px], comp.reshape(-1, 3)[px])


def test_vpls_pass_a_masked_mirror(tmp_path):
    """A particle meets a mask around a mirror: straight through with probability 1 - opacity, else reflected (up, to
    the black emitter) with no VPL stored on the mirror."""
    mirror = '<bsdf type="conductor"/>'
    open_floor, _ = _vpl_power(_vpl_scene(tmp_path, 0.0, "area", mirror), 4)
    floor, quad = _vpl_power(_vpl_scene(tmp_path, 0.3, "area", mirror), 4)
    assert open_floor > 0.0 and quad == 0.0
    assert floor / open_floor == pytest.approx(0.7, rel=VPL_REL)


# Clustered visibility on the masked quads (1,024 area samples, 64 x 48) against the brute force: with one
# cluster per light and per view sample it is the brute force (measured 5e-7 on both backends); with 48 light x
# 300 view clusters and F = 4, measured 3.4% (CPU and GPU). Visibility bits in place of the transmittances
# (V = 1 wherever some light gets through) double the clustered error (src/cluster/visibility/tests.rs).
CLUSTERED_REL_L2 = 0.05


@pytest.mark.parametrize("device", ["cpu", "gpu"])
def test_clustered_visibility_crosses_masks(device):
    """Clustered visibility's entries are the masks' transmittances, on both backends."""
    scene = ml.load_scene(DATA / "mask_leaves.xml")
    A = ml.LightMatrix(scene, ml.generate_lights(scene, area=1024), device=device, visibility="ray_traced")
    bf = np.asarray(A.column_sum(progress=False)) + A.emitted()
    rel = lambda img: float(np.sqrt(((np.asarray(img) - bf) ** 2).sum() / (bf ** 2).sum()))  # noqa: E731
    # Every view sample its own cluster: the pixels and the surfaces seen through the masks behind them.
    samples = len(A.view_samples()["position"])
    assert samples > A.shape[0]
    every = ml.clustered_visibility(A, light_clusters=A.shape[1], view_clusters=samples, fuzzy=1, seed=0)
    assert rel(every.image) < 1e-5
    coarse = ml.clustered_visibility(A, light_clusters=48, view_clusters=300, fuzzy=4, seed=0)
    print(device, rel(every.image), rel(coarse.image))
    assert rel(coarse.image) < CLUSTERED_REL_L2


# RIS images (64 samples per view sample) against the brute force: relative L2 measured 2.9% (noise); one that
# treated masks as opaque to its shadow rays would lose the (1 - opacity) light in the quads' shadows.
RIS_REL_L2 = 0.05


@pytest.mark.parametrize("neighbours", [0, 4])
def test_ris_shadow_rays_cross_masks(neighbours):
    scene = ml.load_scene(DATA / "mask_leaves.xml")
    A = ml.LightMatrix(scene, ml.generate_lights(scene, area=1024), device="cpu")
    bf = np.asarray(A.column_sum(progress=False)) + A.emitted()
    img = np.asarray(ml.ris_sampling(A, samples=64, candidates=8, seed=1, neighbours=neighbours).image)
    assert float(np.sqrt(((img - bf) ** 2).sum() / (bf ** 2).sum())) < RIS_REL_L2
    assert img.sum() / bf.sum() == pytest.approx(1.0, abs=0.01)


# Glossy MIS (light columns weighted by w_L plus BSDF-sampled rays) against pure light columns on a glossy
# floor: measured 0.15% relative L2; weighting the light through a mask by w_L too (the BSDF rays stop at
# masks) was 8.8% off.
GLOSSY_REL_L2 = 0.01


def test_glossy_mis_keeps_the_light_through_masks(tmp_path):
    text = (DATA / "mask_leaves.xml").read_text()
    glossy = text.replace('<bsdf type="diffuse">\n            <rgb name="reflectance" value="0.6, 0.6, 0.55"/>\n        </bsdf>',
                          '<bsdf type="roughplastic"><string name="distribution" value="ggx"/><float name="alpha" '
                          'value="0.03"/><rgb name="diffuse_reflectance" value="0.3, 0.3, 0.25"/></bsdf>')
    assert glossy != text
    p = tmp_path / "glossy.xml"
    p.write_text(glossy)
    scene = ml.load_scene(p)
    lights = ml.generate_lights(scene, area=4096)
    images = []
    for opts in [{"glossy_roughness": 0.0}, {"bsdf_samples": 1024}]:
        A = ml.LightMatrix(scene, lights, device="cpu", **opts)
        images.append(np.asarray(A.column_sum(progress=False)) + A.emitted())
    assert A.glossy_work[0] > 0
    ref, img = images
    assert float(np.sqrt(((img - ref) ** 2).sum() / (ref ** 2).sum())) < GLOSSY_REL_L2
