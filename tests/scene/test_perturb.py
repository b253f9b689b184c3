"""Mitsuba 3.9.1's ``bumpmap`` and ``normalmap`` (``src/shading/perturb.rs``, ``src/scene/xml/perturb.rs``).

- The perturbed BSDF (Rust reference and WGSL twin) against Mitsuba's ``bsdf.eval`` of a ``normalmap`` whose
  texture is one constant normal, for several nested BSDFs and random (wi, wo), live. (The bump gradient, the
  uv tangents and the normal map lookup at texture points are checked against Mitsuba's values in
  ``src/shading/perturb/tests.rs``.)
- Pixel-centre direct-light renders against converged Mitsuba references (``tests/references/bumpmap-direct``,
  ``normalmap-direct``, 64 x 48, two point lights; ``tests/data/bumpmap_ripples.xml``, ``normalmap_waves.xml``):
  relative L2 within 1.5x the reference's noise (measured 0.195% and 0.196% against 0.200%: 122k and 132k spp), CPU
  (and GPU for the normal map); without the perturbation 26% and 30%.
- Loading: wrappers declared at the top level (used by reference, or by no shape at all, as in Bitterli's
  staircase) and the refusals with file, line and value (more in ``tests/robustness/corpus/scene_files.py``).
"""
from __future__ import annotations

import json
import zlib
from pathlib import Path

import mitsuba as mi  # a test dependency: missing it must fail, not skip
import numpy as np
import pytest

import manylights as ml
import manylights._native as native

HERE = Path(__file__).resolve().parents[1]
DATA = HERE / "data"
REFS = HERE / "references"
RTOL, FLOOR = 1e-3, 1e-4
TOL_NOISE = 1.5

NESTED = {
    "diffuse": {"type": "diffuse", "reflectance": [0.7, 0.6, 0.5]},
    "roughplastic_ggx": {"type": "roughplastic", "distribution": "ggx", "alpha": 0.2, "int_ior": 1.5,
                         "diffuse_reflectance": [0.3, 0.5, 0.2]},
    "roughconductor_beckmann": {"type": "roughconductor", "distribution": "beckmann", "alpha": 0.3,
                                "eta": [1.65746, 0.880369, 0.521229], "k": [9.22387, 6.26952, 4.837]},
    "principled": {"type": "principled", "base_color": [0.6, 0.4, 0.3], "roughness": 0.4, "metallic": 0.3},
    "twosided_diffuse": {"type": "diffuse", "reflectance": [0.4, 0.5, 0.6], "twosided": True},
}
# Normals of the constant normal maps (unit, local frame): tilted 25 and 50 degrees.
NORMALS = [(0.3, -0.3, 0.905538513813742), (0.55, 0.55, 0.628490254499)]


def _mi_dict(spec):
    d = {k: v for k, v in spec.items() if k != "twosided"}
    for key in ("reflectance", "diffuse_reflectance", "eta", "k", "base_color"):
        if key in d and isinstance(d[key], list):
            d[key] = {"type": "rgb", "value": d[key]}
    return d


def _mitsuba_eval(spec, n, wi, wo, outer_twosided):
    mi.set_variant("scalar_rgb")
    texel = (np.asarray(n, np.float32) + 1) / 2
    nested = _mi_dict(spec)
    if spec.get("twosided") and not outer_twosided:
        nested = {"type": "twosided", "inner": nested}
    d = {"type": "normalmap", "normalmap": {"type": "bitmap", "raw": True,
                                            "bitmap": mi.Bitmap(np.tile(texel, (2, 2, 1)))},
         "inner": nested}
    if outer_twosided:
        d = {"type": "twosided", "inner": d}
    bsdf = mi.load_dict(d)
    si = mi.SurfaceInteraction3f()
    si.sh_frame = mi.Frame3f(mi.Vector3f(0, 0, 1))
    si.n = mi.Normal3f(0, 0, 1)
    si.uv = mi.Point2f(0.4, 0.6)
    si.dp_du, si.dp_dv = mi.Vector3f(1, 0, 0), mi.Vector3f(0, 1, 0)
    ctx = mi.BSDFContext()
    out = np.empty_like(wi)
    for j in range(len(wi)):
        si.wi = mi.Vector3f(*map(float, wi[j]))
        out[j] = np.array(bsdf.eval(ctx, si, mi.Vector3f(*map(float, wo[j]))))
    return out


def _pairs(n, seed):
    v = np.random.default_rng(seed).normal(size=(2, n, 3))
    v /= np.linalg.norm(v, axis=2, keepdims=True)
    return np.ascontiguousarray(v[0], np.float32), np.ascontiguousarray(v[1], np.float32)


def _max_rel(a, ref):
    return float(np.max(np.abs(a - ref) / np.maximum(np.abs(ref), FLOOR)))


@pytest.mark.parametrize("name", list(NESTED))
@pytest.mark.parametrize("k", range(len(NORMALS)))
def test_perturbed_bsdf_matches_mitsuba(name, k):
    spec, n = NESTED[name], NORMALS[k]
    wi, wo = _pairs(600, seed=zlib.crc32(f"{name}{k}".encode()))
    # A twosided around the normalmap (diffuse, second normal), or inside it (twosided_diffuse).
    outer = name == "diffuse" and k == 1
    ref = _mitsuba_eval(spec, n, wi, wo, outer)
    ours = dict(spec, perturbed_normal=list(n), twosided=spec.get("twosided", False) or outer,
                twosided_inside=bool(spec.get("twosided")))
    cpu = native.bsdf_eval(ours, wi, wo, "cpu")
    gpu = native.bsdf_eval(ours, wi, wo, "gpu")
    plain = native.bsdf_eval(spec, wi, wo, "cpu")
    print(f"{name} n{k}: Rust-Mitsuba {_max_rel(cpu, ref):.2e}, WGSL-Mitsuba {_max_rel(gpu, ref):.2e}, "
          f"unperturbed-Mitsuba {_max_rel(plain, ref):.2e}, nonzero {int(np.sum(ref.max(1) > 0))}")
    assert np.sum(ref.max(1) > 0) > 60
    assert _max_rel(cpu, ref) < RTOL
    assert _max_rel(gpu, ref) < RTOL
    assert _max_rel(plain, ref) > 0.1  # the perturbation matters at these normals


def _render(scene, device="cpu"):
    A = ml.LightMatrix(scene, ml.generate_lights(scene, area=0), device=device, max_depth=2)
    return np.asarray(A.column_sum(progress=False)) + A.emitted()


@pytest.mark.parametrize("name, xml, wrapper", [
    ("bumpmap-direct", "bumpmap_ripples.xml", "bumpmap"),
    ("normalmap-direct", "normalmap_waves.xml", "normalmap"),
])
def test_render_matches_mitsuba(name, xml, wrapper, tmp_path):
    meta = json.loads((REFS / f"{name}.json").read_text())
    assert meta["integrator"] == {"type": "path", "max_depth": 2} and meta["mitsuba"] == "3.9.1"
    ref, var = ml.read_exr(REFS / f"{name}.exr"), ml.read_exr(REFS / f"{name}.var.exr")
    scene = ml.load_scene(DATA / xml)
    img = _render(scene)
    den = (ref ** 2).sum()
    if wrapper == "normalmap":  # the WGSL twin on the G-buffer's records (measured 4e-8; bumpmap 2e-8)
        gpu = _render(scene, "gpu")
        assert float(np.sqrt(((gpu - img) ** 2).sum() / den)) < 1e-5
    err = float(np.sqrt(((img - ref) ** 2).sum() / den))
    noise = float(np.sqrt(var.sum() / den))
    # The same scene with the wrappers' nested BSDFs alone.
    text = (DATA / xml).read_text()
    flat = tmp_path / xml
    flat.write_text(_unwrap(text, wrapper))
    (tmp_path / "textures").symlink_to(DATA / "textures")
    off = float(np.sqrt(((_render(ml.load_scene(flat)) - ref) ** 2).sum() / den))
    print(f"\n{name}: relative L2 {err:.3%} (reference noise {noise:.3%}; without the {wrapper}s {off:.2%})")
    assert err <= TOL_NOISE * noise
    assert off >= 10 * noise


def _unwrap(text, wrapper):
    """The XML with each wrapper replaced by its nested BSDF (its texture and scale dropped)."""
    import re

    text = re.sub(r'<texture (name="\w+" )?type="bitmap"( name="\w+")?>.*?</texture>', "", text, flags=re.S)
    text = re.sub(r'<float name="scale" value="0\.\d+"/>', "", text)
    text = re.sub(rf'<bsdf type="{wrapper}"( id="[\w-]+")?>', lambda m: f'<bsdf type="twosided"{m.group(1) or ""}>', text)
    assert wrapper not in text.split("-->", 1)[1]
    return text


def test_unused_top_level_wrapper_loads(tmp_path):
    """Bitterli's staircase: shapes refer to the BSDF inside a top-level bumpmap, none to the bumpmap."""
    p = tmp_path / "s.xml"
    (tmp_path / "textures").symlink_to(DATA / "textures")
    p.write_text("""<scene version="3.0.0">
  <sensor type="perspective"><film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film></sensor>
  <bsdf type="bumpmap" id="bump">
    <texture type="bitmap"><string name="filename" value="textures/bump_ripples.png"/></texture>
    <bsdf type="diffuse" id="inner"><rgb name="reflectance" value="0.3"/></bsdf>
  </bsdf>
  <shape type="sphere"><ref id="inner"/></shape>
</scene>""")
    scene = ml.load_scene(p)
    assert [b["type"] for b in scene.bsdfs] == ["diffuse"]
    # A shape using the wrapper itself keeps it.
    p.write_text(p.read_text().replace('<ref id="inner"/>', '<ref id="bump"/>'))
    assert [b["type"] for b in ml.load_scene(p).bsdfs] == ["diffuse", "bumpmap"]


@pytest.mark.parametrize("body, match", [
    ('<bsdf type="bumpmap"><bsdf type="diffuse"/></bsdf>', r"s\.xml:3: .*bumpmap.*height <texture> .* is required, got none"),
    ('<bsdf type="bumpmap"><texture type="bitmap"><string name="filename" value="textures/bump_ripples.png"/>'
     '</texture></bsdf>', r"s\.xml:3: .*bumpmap.*exactly one nested BSDF is required, got none"),
    ('<bsdf type="normalmap"><texture name="normalmap" type="bitmap"><string name="filename" '
     'value="textures/normal_waves.png"/></texture><bsdf type="diffuse"/></bsdf>',
     r"s\.xml:3: .*normalmap.*raw.*no raw property"),
    ('<bsdf type="normalmap"><texture name="normalmap" type="bitmap"><boolean name="raw" value="true"/><string '
     'name="filename" value="textures/bump_ripples.png"/></texture><bsdf type="diffuse"/></bsdf>',
     r"s\.xml:3: .*bump_ripples\.png has 1 channel\(s\); it needs 3"),
    ('<bsdf type="bumpmap"><texture type="checkerboard"/><bsdf type="diffuse"/></bsdf>',
     r's\.xml:3: .*the texture must be a bitmap, got <texture type="checkerboard">'),
    ('<bsdf type="bumpmap"><texture type="bitmap"><string name="filename" value="textures/bump_ripples.png"/>'
     '</texture><bsdf type="dielectric"/></bsdf>', r"s\.xml:3: .*delta lobe"),
    ('<bsdf type="bumpmap"><texture type="bitmap"><string name="filename" value="textures/bump_ripples.png"/>'
     '</texture><float name="scale" value="nan"/><bsdf type="diffuse"/></bsdf>', r"s\.xml:3: .*scale = NaN must be finite"),
])
def test_bad_wrappers_name_file_line_and_value(tmp_path, body, match):
    p = tmp_path / "s.xml"
    (tmp_path / "textures").symlink_to(DATA / "textures")
    p.write_text('<scene version="3.0.0">\n<sensor type="perspective"/>\n<shape type="sphere">' + body + "</shape>\n</scene>")
    with pytest.raises(ml.SceneError, match=match):
        ml.load_scene(p)
