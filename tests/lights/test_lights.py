"""Many lights (CI-sized): GPU columns against the exact CPU oracle, direct light
against stored Mitsuba references, full global illumination as the number of VPLs grows, power
conservation, determinism and bad input.

The full-size figures (cbox 128x128 and veach-ajar with 100k lights) are in ``python -m manylights.bench
lights``; the direct-light references are compared at their full size here, but through the exact CPU
oracle on a fixed random subset of pixels (it is ~50x faster than the software GPU on this machine), and
the GPU images are tied to the oracle column by column (``test_gpu_columns_match_exact``) and by one
full GPU brute-force image (``test_brute_force_gpu_image_cbox_lights``).
"""
from __future__ import annotations

import json
import textwrap

import numpy as np
import pytest

import manylights as ml
from conftest import REPO, SCENE_CONFIGS, save_failure_images

REFS = REPO / "tests" / "references"

# --- GPU columns vs the exact oracle -------------------------------------------------------------------
# Acceptance: >= 99% of pixels within 2% relative or 1e-3 absolute. A single light of a 4096-light set
# carries 1/4096 of the power, so the absolute floor is taken relative to the column's maximum.
PIXEL_REL = 0.02
PIXEL_ABS_OF_MAX = 1e-3
MIN_PIXELS_OK = 0.99
# Mismatches must sit at shadow boundaries: within this many pixels of an exact lit/unlit transition.
BOUNDARY_RADIUS = 2
# ... except for this fraction of all pixels (float rounding in a spot's falloff, grazing receivers).
MAX_OFF_BOUNDARY = 1e-3
LIGHTS_PER_KIND = 20
KIND_NAMES = ["point", "spot", "directional", "oriented_point", "vpl"]


def _load(name, size):
    xml, params, _ = SCENE_CONFIGS[name]
    return ml.load_scene(xml, size=size, **params)


def _near_boundary(lit: np.ndarray, r: int) -> np.ndarray:
    """Pixels within r of a pixel whose lit state differs (exact visibility)."""
    out = np.zeros_like(lit)
    h, w = lit.shape
    for dy in range(-r, r + 1):
        for dx in range(-r, r + 1):
            sy = slice(max(dy, 0), h + min(dy, 0))
            ty = slice(max(-dy, 0), h + min(-dy, 0))
            sx = slice(max(dx, 0), w + min(dx, 0))
            tx = slice(max(-dx, 0), w + min(-dx, 0))
            out[ty, tx] |= lit[sy, sx] != lit[ty, tx]
    return out


@pytest.mark.parametrize("name,size", [("cbox-lights", (64, 64)), ("veach-ajar", (96, 54))])
def test_gpu_columns_match_exact(name, size):
    scene = _load(name, size)
    lights = ml.generate_lights(scene, area=512, environment=512, indirect=4000, max_depth=-1, seed=5)
    # The GPU backend's default hybrid visibility against the exact oracle (the CPU backend IS the oracle).
    A = ml.LightMatrix(scene, lights, device="gpu")
    rng = np.random.default_rng(1)
    js = []
    for k in range(5):
        idx = np.flatnonzero(lights.kind == k)
        js += [int(j) for j in rng.choice(idx, min(LIGHTS_PER_KIND, len(idx)), replace=False)]
    gpu = A.columns(js)
    worst, off_boundary, report = 1.0, 0, []
    for k, j in enumerate(js):
        exact = A.column_exact(j)
        bad = ~(np.abs(gpu[k] - exact) <= np.maximum(PIXEL_REL * np.abs(exact), PIXEL_ABS_OF_MAX * exact.max())).all(-1)
        lit = exact.max(-1) > 0
        off = bad & ~_near_boundary(lit, BOUNDARY_RADIUS)
        off_boundary += int(off.sum())
        ok = 1.0 - bad.mean()
        worst = min(worst, ok)
        if bad.any():
            ys, xs = np.nonzero(bad)
            report.append(f"light {j} ({KIND_NAMES[lights.kind[j]]}): {bad.sum()} px, {off.sum()} off boundary, "
                          f"e.g. (x, y) = {list(zip(xs[:3].tolist(), ys[:3].tolist()))}")
        if ok < MIN_PIXELS_OK:
            save_failure_images(f"columns-{name}-{j}", gpu=gpu[k], exact=exact, bad=bad.astype(np.float32))
    kinds = np.bincount(lights.kind[js], minlength=5)
    print(f"\n{name}: {len(js)} lights {dict(zip(KIND_NAMES, kinds.tolist()))}; worst column {worst:.4%} of "
          f"pixels within tolerance; {off_boundary} mismatching pixels off shadow boundaries\n  " + "\n  ".join(report))
    assert worst >= MIN_PIXELS_OK, "\n".join(report)
    assert off_boundary <= MAX_OFF_BOUNDARY * len(js) * A.shape[0], "\n".join(report)
    assert np.isfinite(gpu).all()


def test_oracle_element_row_column_agree():
    scene = _load("cbox-lights", (32, 32))
    lights = ml.generate_lights(scene, area=64, environment=64, indirect=300, seed=2)
    A = ml.LightMatrix(scene, lights, visibility="ray_traced")
    m, n = A.shape
    i = 20 * 32 + 11
    row = A.row_exact(i)
    assert row.shape == (n, 3) and row.dtype == np.float32
    for j in [0, 1, 2, 100, n - 1]:
        np.testing.assert_array_equal(A.element(i, j), row[j])
        np.testing.assert_array_equal(A.column_exact(j)[20, 11], row[j])
    assert (row > 0).any()
    for bad in [lambda: A.element(m, 0), lambda: A.element(0, n), lambda: A.element(-1, 0),
                lambda: A.row_exact(m), lambda: A.column_exact(n), lambda: A.column_exact(1.5)]:
        with pytest.raises(ValueError):
            bad()


# --- Direct light against stored Mitsuba references ------------------------------------------------------
# Tolerances (relative L2 of the direct image): cbox and cbox-lights 3%, the env-map scenes 4%.
DIRECT = {
    # name: (reference, generate_lights arguments, max relative L2)
    "cbox": ("cbox-direct", dict(area=4096), 0.03),
    "cbox-lights": ("cbox-lights-direct", dict(area=4096, environment=4096), 0.03),
    # matpreview's reference has specular_reflectance = 0 on its smooth plastic (make_references.py):
    # our lights reach only the diffuse part of a smooth plastic, so both render the same BSDF.
    "matpreview": ("matpreview-direct", dict(area=0, environment=4096), 0.04),
    "bunny": ("bunny-direct", dict(area=0, environment=4096), 0.04),
}
# Pixels evaluated by the oracle per scene (a fixed random subset: the relative L2 over 4096 of
# 12-16k pixels estimates the full image's within ~5% of its value).
DIRECT_PIXELS = 4096
# A reference's own relative noise must be this much below the tolerance.
NOISE_MARGIN = 4.0


def oracle_image(A: ml.LightMatrix, pixels: np.ndarray) -> np.ndarray:
    """(k, 3): brute force (row sums by exact ray casting) plus emitted radiance at the given pixels."""
    rows = np.stack([A.row_exact(int(i)).sum(0) for i in pixels])
    return rows + A.emitted().reshape(-1, 3)[pixels]


def _reference(name):
    meta = json.loads((REFS / f"{name}.json").read_text())
    return ml.read_exr(REFS / f"{name}.exr"), ml.read_exr(REFS / f"{name}.var.exr"), meta


@pytest.mark.parametrize("name", list(DIRECT))
def test_direct_light_vs_mitsuba(name, tmp_path):
    ref_name, gen, tol = DIRECT[name]
    ref, var, meta = _reference(ref_name)
    if meta.get("edit"):
        # The reference's scene edit (matpreview: no smooth specular) applies to ours too: delta chains
        # would otherwise show the environment in the plastic's specular layer.
        from make_references import edited

        xml, params, _ = SCENE_CONFIGS[name]
        scene = ml.load_scene(edited(xml, meta["edit"], tmp_path), size=tuple(meta["size"]), **params)
    else:
        scene = _load(name, tuple(meta["size"]))
    lights = ml.generate_lights(scene, **gen)
    A = ml.LightMatrix(scene, lights, visibility="ray_traced", max_depth=2)  # the references' depth
    m = A.shape[0]
    pixels = np.sort(np.random.default_rng(0).choice(m, min(DIRECT_PIXELS, m), replace=False))
    ours = oracle_image(A, pixels)
    r = ref.reshape(-1, 3)[pixels]
    err = float(np.sqrt(((ours - r) ** 2).sum() / (r ** 2).sum()))
    print(f"\n{name}: {len(lights)} lights, relative L2 {err:.4%} on {len(pixels)} pixels (tolerance {tol:.0%}); "
          f"reference noise {meta['relative_noise']:.4%} ({meta['spp']} spp) = tolerance / "
          f"{tol / meta['relative_noise']:.1f}")
    if meta["relative_noise"] * NOISE_MARGIN > tol:
        print(f"  WARNING: {ref_name}'s noise is not {NOISE_MARGIN}x below the tolerance")
    assert np.isfinite(ours).all()
    if err > tol:
        full = np.zeros((m, 3), np.float32)
        full[pixels] = ours
        save_failure_images(f"direct-{name}", ours=full.reshape(ref.shape), ref=ref)
    assert err <= tol


# The brute-force image (column_sum + emitted) against a stored reference; fewer lights than the acceptance
# count (CI time), which the 3% tolerance still holds with (measured 2.2%, of which ~2% are ~200 pixels on the
# floor/wall corner edges where the G-buffer's tie goes to the wall, Mitsuba's to the floor).
IMAGE_TOL = 0.03
# The GPU's image of the same lights equals the CPU's exact rays up to f32 arithmetic (measured: relative L2
# 3.8e-4, against 2.2% for the image's distance to Mitsuba). A quarter of the lights (software GPU time);
# area and environment lights both still take part.
GPU_VS_CPU_TOL = 1.5e-3


@pytest.fixture(scope="module")
def cbox_lights_scene():
    ref, _, meta = _reference("cbox-lights-direct")
    return _load("cbox-lights", tuple(meta["size"])), ref


def test_brute_force_image_cbox_lights(cbox_lights_scene):
    scene, ref = cbox_lights_scene
    lights = ml.generate_lights(scene, area=1024, environment=1024)
    img = ml.render_brute_force(scene, lights, visibility="ray_traced", progress=False, device="cpu")
    err = ml.relative_l2(img, ref)
    print(f"\ncbox-lights brute force, {len(lights)} lights: relative L2 {err:.4%}")
    if err > IMAGE_TOL:
        save_failure_images("brute-force-cbox-lights", ours=img, ref=ref)
    assert np.isfinite(img).all()
    assert err <= IMAGE_TOL


def test_brute_force_gpu_image_cbox_lights(cbox_lights_scene):
    scene, ref = cbox_lights_scene
    lights = ml.generate_lights(scene, area=256, environment=256)
    imgs = {d: ml.render_brute_force(scene, lights, visibility="ray_traced", progress=False, device=d)
            for d in ("cpu", "gpu")}
    err = ml.relative_l2(imgs["gpu"], imgs["cpu"])
    print(f"\ncbox-lights brute force, {len(lights)} lights: GPU vs CPU relative L2 {err:.2e}, "
          f"vs Mitsuba {ml.relative_l2(imgs['gpu'], ref):.3%}")
    assert np.isfinite(imgs["gpu"]).all()
    assert err <= GPU_VS_CPU_TOL


def test_emitted_area_and_environment():
    # cbox-lights: the area light seen from below shows its radiance; background pixels show the env map.
    scene = _load("cbox-lights", (64, 64))
    A = ml.LightMatrix(scene, ml.scene_lights(scene), visibility="ray_traced")
    e = A.emitted()
    g = scene.gbuffer()
    light_shape = [k for k, s in enumerate(scene.shapes) if s["emitter"] is not None][0]
    on_light = g["shape_index"] == light_shape
    assert on_light.any()
    np.testing.assert_array_equal(e[on_light], np.broadcast_to(np.float32([8, 7, 5]), e[on_light].shape))
    background = g["shape_index"] < 0
    assert background.any() and (e[background] > 0).all()
    assert (e[~background & ~on_light] == 0).all()
    # Seen from behind (camera above the light, looking down at its back): nothing.
    assert np.isfinite(e).all()


# --- Full global illumination ----------------------------------------------------------------------------
GI_REF = "cbox-gi-64"
GI_AREA = 1024
GI_SWEEP = [1000, 4000, 16000]
GI_SEEDS = [0, 1]
# Without the clamp the VPL estimate is unbiased: its error falls with N_i (measured 1.1% -> 0.67% ->
# 0.38%); each step must fall by at least this factor (averaged over the seeds).
GI_MIN_DECREASE = 0.85
# With the clamp the error falls to the clamp's bias floor (measured 0.71% -> 0.49% -> 0.47%):
# non-increasing up to this absolute slack (seed noise at the floor).
GI_FLOOR_SLACK = 0.001
# The GPU brute-force image (4k VPLs, clamped) vs the reference: full GI within 2% at 64x64 (measured 0.5%);
# and equal to the oracle's image up to f32 summation order.
GI_GPU_TOL = 0.02
GI_GPU_VS_ORACLE = 1e-4


@pytest.fixture(scope="module")
def gi_scene():
    ref, var, meta = _reference(GI_REF)
    return _load("cbox", tuple(meta["size"])), ref, meta


def _gi_error(scene, ref, indirect, seed, clamp):
    lights = ml.generate_lights(scene, area=GI_AREA, indirect=indirect, max_depth=-1, clamp=clamp, seed=seed)
    # The CPU backend's column sum: exact rays, the oracle's arithmetic (src/cpu/tests.rs checks them equal).
    A = ml.LightMatrix(scene, lights, device="cpu")
    img = A.column_sum(progress=False) + A.emitted()
    assert np.isfinite(img).all()
    return ml.relative_l2(img, ref), float(img.mean() / ref.mean())


def test_gi_error_decreases_with_indirect_lights(gi_scene):
    scene, ref, meta = gi_scene
    table = {}
    for clamp in [None, float("inf")]:
        for n_i in GI_SWEEP:
            runs = [_gi_error(scene, ref, n_i, seed, clamp) for seed in GI_SEEDS]
            table[(clamp, n_i)] = (np.mean([r[0] for r in runs]), np.mean([r[1] for r in runs]))
    print(f"\ncbox {meta['size']} full GI vs {GI_REF} (noise {meta['relative_noise']:.3%}), area {GI_AREA}, "
          f"mean over seeds {GI_SEEDS}:")
    for (clamp, n_i), (err, ratio) in table.items():
        print(f"  clamp {'default' if clamp is None else 'off':7s} N_i {n_i:6d}: relative L2 {err:.4%}, "
              f"mean ours/ref {ratio:.4f}")
    off = [table[(float("inf"), n)][0] for n in GI_SWEEP]
    on = [table[(None, n)][0] for n in GI_SWEEP]
    for a, b in zip(off, off[1:]):
        assert b <= GI_MIN_DECREASE * a, f"clamp off: error must fall with N_i: {off}"
    for a, b in zip(on, on[1:]):
        assert b <= a + GI_FLOOR_SLACK, f"clamp on: error must not grow with N_i: {on}"
    # The clamp's bias: it removes energy (mean below the reference) that the unclamped estimate keeps.
    bias_on = 1.0 - table[(None, GI_SWEEP[-1])][1]
    bias_off = 1.0 - table[(float("inf"), GI_SWEEP[-1])][1]
    print(f"  energy lost at N_i {GI_SWEEP[-1]}: clamp on {bias_on:.3%}, clamp off {bias_off:.3%}")
    assert bias_on > bias_off


# (device, area points, VPLs): the software GPU gets a quarter of the lights (CI time; 1000 VPLs measured
# 1.1% against the reference in the sweep above).
@pytest.mark.parametrize("device,area,vpls", [("cpu", GI_AREA, 4000), ("gpu", GI_AREA // 4, 1000)])
def test_gi_brute_force(gi_scene, device, area, vpls):
    scene, ref, _ = gi_scene
    lights = ml.generate_lights(scene, area=area, indirect=vpls, max_depth=-1, seed=0)
    A = ml.LightMatrix(scene, lights, visibility="ray_traced", device=device)
    img = A.column_sum(progress=False) + A.emitted()
    err = ml.relative_l2(img, ref)
    exact = oracle_image(A, np.arange(A.shape[0])).reshape(ref.shape)
    print(f"\ncbox-gi-64 {device} brute force ({len(lights)} lights): relative L2 {err:.4%}; "
          f"vs oracle {ml.relative_l2(img, exact):.2e}")
    assert err <= GI_GPU_TOL
    assert ml.relative_l2(img, exact) <= GI_GPU_VS_ORACLE


# --- Power conservation ---------------------------------------------------------------------------------
POWER_TOL = 0.005  # generated lights carry the emitters' power within 0.5%


def _mesh_area(scene, k):
    s = scene.shapes[k]
    if s["type"] == "sphere":
        return 4 * np.pi * s["radius"] ** 2
    m = scene.mesh(k)
    p = m["positions"].astype(np.float64)[m["indices"]]
    return 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1).sum()


@pytest.mark.parametrize("name", ["cbox", "cbox-lights"])
def test_area_power_is_conserved(name):
    scene = _load(name, (16, 16))
    expect = sum(np.pi * _mesh_area(scene, e["shape"]) * np.float64(e["radiance"])
                 for e in scene.emitters if e["type"] == "area")
    lights = ml.generate_lights(scene, area=1000)
    got = lights.power[lights.kind == 3].astype(np.float64).sum(0)
    np.testing.assert_allclose(got, expect, rtol=POWER_TOL)


def _envmap_integral(path, scale, rows_per_texel=4):
    """int L dw of a lat-long map by a midpoint rule on a grid 4x finer than the texels, with Mitsuba's
    bilinear lookup (column u W - 0.5 wrapping, row t (H - 1) clamped); independent of the Rust code."""
    data = ml.read_exr(path).astype(np.float64)
    h, w, _ = data.shape
    nt, nu = rows_per_texel * h, rows_per_texel * w
    t = (np.arange(nt) + 0.5) / nt
    u = (np.arange(nu) + 0.5) / nu
    y = np.clip(t * (h - 1), 0, h - 1)
    x = u * w - 0.5
    y0 = np.floor(y).astype(int)
    y1 = np.minimum(y0 + 1, h - 1)
    fy = (y - y0)[:, None, None]
    x0 = np.floor(x).astype(int)
    fx = (x - x0)[None, :, None]
    c0, c1 = x0 % w, (x0 + 1) % w
    top = data[y0][:, c0] * (1 - fx) + data[y0][:, c1] * fx
    bottom = data[y1][:, c0] * (1 - fx) + data[y1][:, c1] * fx
    L = top * (1 - fy) + bottom * fy
    dw = np.sin(np.pi * t)[:, None, None] * (np.pi / nt) * (2 * np.pi / nu)
    return scale * (L * dw).sum((0, 1))


@pytest.mark.parametrize("name,env_file", [("cbox-lights", "env.exr"), ("matpreview", None)])
def test_environment_power_is_conserved(name, env_file):
    import xml.etree.ElementTree as ET

    xml, _, _ = SCENE_CONFIGS[name]
    scene = _load(name, (16, 16))
    env = [e for e in scene.emitters if e["type"] == "envmap"][0]
    if env_file is None:
        node = [e for e in ET.parse(xml).getroot().iter("emitter") if e.get("type") == "envmap"][0]
        env_file = [c.get("value") for c in node if c.get("name") == "filename"][0]
    integral = _envmap_integral(xml.parent / env_file, env["scale"])
    lo, hi = (np.float64(b) for b in scene.bounds)
    r = 0.5 * np.linalg.norm(hi - lo)
    expect = np.pi * r * r * integral
    for importance in [False, True]:
        lights = ml.generate_lights(scene, area=0, environment=2048, env_importance=importance)
        env_lights = (lights.kind == 2) & (np.linalg.norm(lights.position, axis=1) == 0)
        got = lights.power[env_lights].astype(np.float64).sum(0)
        # The scene's own directional emitter (cbox-lights) is a delta light, not a stratum.
        got -= sum(np.pi * r * r * np.float64(e["irradiance"]) for e in scene.emitters if e["type"] == "directional")
        np.testing.assert_allclose(got, expect, rtol=POWER_TOL, err_msg=f"env_importance={importance}")


FURNACE_XML = """<scene version="3.0.0">
    <sensor type="perspective">
        <float name="fov" value="60"/>
        <transform name="to_world"><lookat origin="0, 0, 0.5" target="0, 0, -1" up="0, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="16"/></film>
    </sensor>
    <shape type="sphere">
        <float name="radius" value="1"/> <boolean name="flip_normals" value="true"/>
        <bsdf type="diffuse"><rgb name="reflectance" value="0.5, 0.25, 0.75"/></bsdf>
    </shape>
    <emitter type="point"><point name="position" x="0.1" y="-0.2" z="0.3"/>
        <rgb name="intensity" value="1, 2, 3"/></emitter>
</scene>
"""


def test_indirect_power_is_conserved(tmp_path):
    # Furnace: a point light inside a closed diffuse sphere of albedo rho. Every particle hits the sphere,
    # so the VPLs of bounce k carry Phi rho^(k-1) and reflect Phi rho^k: with max_depth = 6 (bounces 1..4,
    # below Mitsuba's rr_depth = 5, so no Russian roulette) their powers sum to Phi (rho + ... + rho^4).
    path = tmp_path / "furnace.xml"
    path.write_text(FURNACE_XML)
    scene = ml.load_scene(path)
    rho = np.array([0.5, 0.25, 0.75])
    phi = 4 * np.pi * np.array([1.0, 2.0, 3.0])
    expect = phi * sum(rho ** k for k in range(1, 5))
    lights = ml.generate_lights(scene, area=0, indirect=20000, max_depth=6, seed=3)
    got = lights.power[lights.kind == 4].astype(np.float64).sum(0)
    np.testing.assert_allclose(got, expect, rtol=POWER_TOL)


# --- Determinism -----------------------------------------------------------------------------------------
LIGHTSET_FIELDS = ["kind", "position", "direction", "normal", "geo_normal", "incident", "intensity", "power"]


def test_same_seed_is_bit_identical_and_seeds_differ():
    scene = _load("cbox-lights", (32, 32))
    gen = dict(area=64, environment=64, indirect=500, max_depth=-1)
    a, b, c = (ml.generate_lights(scene, seed=s, **gen) for s in (7, 7, 8))
    for f in LIGHTSET_FIELDS:
        np.testing.assert_array_equal(getattr(a, f), getattr(b, f), err_msg=f)
    assert len(a) != len(c) or not np.array_equal(a.position, c.position)
    img_a, img_b, img_c = (ml.render_brute_force(scene, s, visibility="ray_traced", progress=False)
                           for s in (a, b, c))
    np.testing.assert_array_equal(img_a, img_b)
    assert not np.array_equal(img_a, img_c)


# --- Bad input -------------------------------------------------------------------------------------------
SCENE_TEMPLATE = """<scene version="3.0.0">
    <sensor type="perspective">
        <float name="fov" value="60"/>
        <transform name="to_world"><lookat origin="0, 0, 3" target="0, 0, 0" up="0, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="16"/></film>
    </sensor>
    <shape type="rectangle" id="floor">
        <bsdf type="diffuse"><rgb name="reflectance" value="0.5"/></bsdf>
    </shape>
    {extra}
</scene>
"""


def _scene(tmp_path, extra, name="bad.xml"):
    p = tmp_path / name
    p.write_text(SCENE_TEMPLATE.format(extra=textwrap.dedent(extra)))
    return ml.load_scene(p)


def _finite_render(scene, **gen):
    lights = ml.generate_lights(scene, **gen)
    img = ml.render_brute_force(scene, lights, visibility="ray_traced", progress=False)
    assert np.isfinite(img).all()
    return lights, img


AREA_LIGHT = """<shape type="rectangle">
    <transform name="to_world"><scale value="0.3"/><rotate x="1" angle="180"/><translate z="1"/></transform>
    <emitter type="area"><rgb name="radiance" value="{radiance}"/></emitter>
</shape>"""


def test_no_emitters_is_a_clear_error(tmp_path):
    scene = _scene(tmp_path, "")
    with pytest.raises(ValueError, match="no emitters"):
        ml.generate_lights(scene)


def test_zero_counts_give_only_delta_lights(tmp_path):
    scene = _scene(tmp_path, AREA_LIGHT.format(radiance="1, 2, 3")
                   + '<emitter type="point"><point name="position" x="0" y="0" z="1"/></emitter>')
    lights, img = _finite_render(scene, area=0, environment=0, indirect=0)
    assert lights.kind.tolist() == [0]
    assert (img > 0).any()
    # No lights at all: an image of zeros plus what the camera sees directly.
    only_area = _scene(tmp_path, AREA_LIGHT.format(radiance="1, 2, 3"), "area.xml")
    lights, img = _finite_render(only_area, area=0)
    assert len(lights) == 0 and np.isfinite(img).all()


def test_zero_radiance_area_light_contributes_nothing(tmp_path):
    scene = _scene(tmp_path, AREA_LIGHT.format(radiance="0, 0, 0")
                   + '<emitter type="point"><point name="position" x="0" y="0" z="1"/></emitter>')
    lights, img = _finite_render(scene, area=256, indirect=200)
    assert (lights.kind == 3).sum() == 0


def test_zero_area_emitter(tmp_path):
    extra = """<shape type="rectangle">
        <transform name="to_world"><scale x="0" y="0.3"/><translate z="1"/></transform>
        <emitter type="area"><rgb name="radiance" value="1"/></emitter>
    </shape>"""
    # A zero-area shape is degenerate geometry: the loader refuses it, naming the shape.
    with pytest.raises(ml.SceneError, match="degenerate"):
        _scene(tmp_path, extra)


@pytest.mark.parametrize("radiance, shown", [("nan, 1, 1", "NaN, 1.0, 1.0"), ("inf, 1, 1", "inf, 1.0, 1.0"),
                                             ("-1, 1, 1", "-1.0, 1.0, 1.0")])
def test_non_finite_or_negative_area_radiance_is_refused_where_it_is_written(tmp_path, radiance, shown):
    # A NaN or negative radiance had dropped the emitter silently (the image without it, the target claimed);
    # an infinite one reached generate_lights' check without a file or line. All are refused on load, naming
    # the radiance element's line and the value.
    with pytest.raises(ml.SceneError, match=r"bad\.xml:\d+: emitter \"area\": radiance must be finite and >= 0") as e:
        _scene(tmp_path, AREA_LIGHT.format(radiance=radiance))
    assert f"[{shown}]" in str(e.value)


def _write_env(tmp_path, data, name="env.exr"):
    ml.write_exr(tmp_path / name, np.ascontiguousarray(data, np.float32))
    return name


ENV = '<emitter type="envmap"><string name="filename" value="{file}"/></emitter>'


def test_non_finite_and_negative_env_texels_are_refused(tmp_path):
    # Reading them as zero changed the lighting silently: the scene is refused, naming the file and count.
    data = np.ones((8, 16, 3), np.float32)
    data[2, 3] = [np.nan, 1, 1]
    data[5, 10] = [np.inf, 1, 1]
    data[7, 0] = [1, -0.5, 1]
    with pytest.raises(ml.SceneError, match=r"envmap .*env\.exr: 3 of 128 texels are NaN, infinite or negative "
                                            r"\(the first: texel 35 = \[NaN, 1\.0, 1\.0\]\)"):
        _scene(tmp_path, ENV.format(file=_write_env(tmp_path, data)))
    data[2, 3] = data[5, 10] = data[7, 0] = 1
    _scene(tmp_path, ENV.format(file=_write_env(tmp_path, data, "clean.exr")), "clean.xml")


def test_non_lat_long_env_map(tmp_path):
    # Mitsuba reads any W x H bitmap as lat-long (no aspect check); so do we. A square map is lat-long
    # with stretched texels, not an error; it renders finite and its lights carry its integral.
    scene = _scene(tmp_path, ENV.format(file=_write_env(tmp_path, np.full((16, 16, 3), 0.5))))
    lights, img = _finite_render(scene, environment=512)
    lo, hi = (np.float64(b) for b in scene.bounds)
    r = 0.5 * np.linalg.norm(hi - lo)
    np.testing.assert_allclose(lights.power.sum(0), np.pi * r * r * 4 * np.pi * 0.5, rtol=POWER_TOL)
    # A map a loader cannot read as lat-long at all (a single texel row) is a clear error or uniform.
    try:
        flat = _scene(tmp_path, ENV.format(file=_write_env(tmp_path, np.ones((1, 16, 3)), "row.exr")), "row.xml")
    except (ml.SceneError, ValueError):
        return
    _finite_render(flat, environment=64)
