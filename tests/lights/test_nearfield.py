"""Area-light samples that know their area: oriented points carry their patch, and
receivers within 8 patch radii get the patch's projected solid angle instead of the point's 1 / d^2.

Against a converged Mitsuba 3.9.1 pixel-centre reference (``tests/references/nearfield-panel-direct``,
``path`` max_depth=2) of ``tests/data/nearfield_panel.xml``: a 10 x 6 cm panel 5 mm above a diffuse floor.
The error is measured on the floor (pixels that see no emitter; the panel's own radiance is exact in both).
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import manylights as ml

HERE = Path(__file__).resolve().parents[1]
XML = HERE / "data" / "nearfield_panel.xml"
REF = HERE / "references" / "nearfield-panel-direct"
SIZE = (64, 64)
# Relative L2 on the floor that the patch formula must reach at every area-point count (measured
# 0.46-0.52% against a reference whose floor noise is ~0.3%). The point formula fails while the
# panel's pieces are large against their 5 mm gap to the floor (measured 11.3% / 3.5% / 1.1% at
# 64 / 256 / 1024 compact pieces: at 1024 a piece is 2.4 mm across and the points alone nearly do).
TOL = 0.015
COUNTS = (64, 256, 1024)
POINT_SPIKE_COUNTS = (64, 256)
# The reference's floor noise must be this much below TOL (>= 3x).
NOISE_MARGIN = 3.0


@pytest.fixture(scope="module")
def scene():
    return ml.load_scene(XML, size=SIZE)


@pytest.fixture(scope="module")
def reference():
    meta = json.loads(REF.with_suffix(".json").read_text())
    return ml.read_exr(REF.with_suffix(".exr")), ml.read_exr(REF.with_suffix(".var.exr")), meta


def without_patches(scene, lights):
    """The same oriented points as ``lights`` without their patches: today's point formula everywhere."""
    return ml.LightSet.from_arrays(scene, kind=lights.kind, position=lights.position, normal=lights.normal,
                                   intensity=lights.intensity)


def floor_error(A, ref, var):
    """(relative L2 on the floor pixels, the reference's relative noise there)."""
    em = A.emitted()
    floor = (em.sum(-1) == 0) & (ref.sum(-1) > 0)
    img = np.asarray(A.column_sum()).reshape(ref.shape) + em
    denom = (ref[floor] ** 2).sum()
    return float(np.sqrt(((img - ref)[floor] ** 2).sum() / denom)), float(np.sqrt(var[floor].sum() / denom))


def test_near_field_converges_to_mitsuba_where_points_spike(scene, reference):
    ref, var, meta = reference
    assert tuple(meta["size"]) == SIZE and meta["integrator"]["max_depth"] == 2
    for n in COUNTS:
        lights = ml.generate_lights(scene, area=n, environment=0, indirect=0, seed=0)
        assert len(lights) == n
        errs = {}
        for name, ls in (("point", without_patches(scene, lights)), ("patch", lights)):
            A = ml.LightMatrix(scene, ls, visibility="ray_traced", max_depth=2, device="cpu")
            errs[name], noise = floor_error(A, ref, var)
        print(f"\n{n} area points: relative L2 on the floor, point {errs['point']:.2%} -> patch {errs['patch']:.2%}"
              f" (reference floor noise {noise:.2%}, tolerance {TOL:.1%})")
        assert noise * NOISE_MARGIN <= TOL, f"reference floor noise {noise:.3%} is not {NOISE_MARGIN}x below {TOL}"
        assert errs["patch"] <= TOL
        if n in POINT_SPIKE_COUNTS:
            assert errs["point"] > 2 * TOL, "the scene no longer shows the point formula's near-field spike"


STAIRCASE = HERE / "data" / "staircase_recessed.xml"
STAIRCASE_REF = HERE / "references" / "staircase-direct"
# Acceptance: 13 small recessed area lights, direct light, <= 2% relative L2 at <= 16k area points.
STAIRCASE_TOL = 0.02


def test_recessed_staircase_lights_converge_to_mitsuba():
    """The issue's case: 13 recessed 8 x 8 cm lights beside a staircase (``tests/data/staircase_recessed.xml``),
    direct light, against a converged Mitsuba pixel-centre reference (140k spp), on the 1,327 lit pixels that
    see no emitter (the recess sides touch the emitters).

    Measured: patches 0.68% / 0.73% / 0.43% at 1k / 4k / 16k area points (the reference's own noise there is
    0.40%, so these are at its floor); the point formula 21.7% / 31.8% / 21.5%, 99.98% of its squared error in
    1% of the pixels (the recess sides)."""
    meta = json.loads(STAIRCASE_REF.with_suffix(".json").read_text())
    ref, var = ml.read_exr(STAIRCASE_REF.with_suffix(".exr")), ml.read_exr(STAIRCASE_REF.with_suffix(".var.exr"))
    assert tuple(meta["size"]) == (64, 64) and meta["integrator"]["max_depth"] == 2
    scene = ml.load_scene(STAIRCASE, res=64)
    errs = {}
    for name, n in (("patch", 1024), ("patch", 4096), ("point", 4096)):
        lights = ml.generate_lights(scene, area=n, environment=0, indirect=0, seed=0)
        ls = without_patches(scene, lights) if name == "point" else lights
        A = ml.LightMatrix(scene, ls, visibility="ray_traced", max_depth=2, device="cpu")
        errs[name, n], noise = floor_error(A, ref, var)
    print("\nstaircase, relative L2 on lit non-emitter pixels: " +
          ", ".join(f"{k[0]}@{k[1]} {v:.2%}" for k, v in errs.items()) + f" (reference noise {noise:.2%})")
    assert noise * NOISE_MARGIN <= STAIRCASE_TOL
    assert errs["patch", 1024] <= STAIRCASE_TOL and errs["patch", 4096] <= STAIRCASE_TOL
    # The scene still shows the point formula's near-field spike that the patches remove.
    assert errs["point", 4096] > 5 * STAIRCASE_TOL


def test_patches_partition_the_emitter_and_survive_arrays(scene):
    lights = ml.generate_lights(scene, area=100, environment=0, indirect=0, seed=3)
    p = lights.patch
    assert p.shape == (100, 4, 3) and p.dtype == np.float32
    # Each patch is the part of its stratum in one triangle; 100 strata over the panel's two equal triangles
    # straddle none, so together they tile the 0.1 x 0.06 m panel.
    area = 0.5 * np.linalg.norm(np.cross(p[:, 2] - p[:, 0], p[:, 3] - p[:, 1]), axis=-1)
    assert area.sum() == pytest.approx(0.1 * 0.06, rel=1e-5)
    assert (area > 0).all()
    # Corners lie in the panel's plane z = 0, within its extent.
    assert np.abs(p[..., 2]).max() < 1e-7
    assert np.abs(p[..., 0]).max() <= 0.05 + 1e-7 and p[..., 1].min() >= 0.005 - 1e-7 and p[..., 1].max() <= 0.065 + 1e-7
    # Indexing, concat and from_arrays keep the patches (and so the matrix, bit for bit).
    np.testing.assert_array_equal(lights[::3].patch, p[::3])
    np.testing.assert_array_equal(ml.LightSet.concat([lights[:10], lights[10:]]).patch, p)
    again = ml.LightSet.from_arrays(scene, kind=lights.kind, position=lights.position, normal=lights.normal,
                                    intensity=lights.intensity, patch=p)
    np.testing.assert_array_equal(again.patch, p)
    js = [0, 37, 99]
    a = ml.LightMatrix(scene, lights, visibility="ray_traced", device="cpu").columns(js)
    b = ml.LightMatrix(scene, again, visibility="ray_traced", device="cpu").columns(js)
    np.testing.assert_array_equal(a, b)
    # Without patches the near field differs (the spike), far away it is the same formula.
    c = ml.LightMatrix(scene, without_patches(scene, lights), visibility="ray_traced", device="cpu").columns(js)
    assert not np.array_equal(a, c)
    # User-made oriented points default to no patch; other kinds have none.
    assert not without_patches(scene, lights).patch.any()


def test_gpu_equals_cpu_in_the_near_field(scene):
    lights = ml.generate_lights(scene, area=48, environment=0, indirect=0, seed=1)
    js = list(range(0, 48, 3))
    cpu = ml.LightMatrix(scene, lights, device="cpu", visibility="ray_traced")
    gpu = ml.LightMatrix(scene, lights, device="gpu", visibility="ray_traced")
    c, g = np.asarray(cpu.columns(js)), np.asarray(gpu.columns(js))
    near = np.asarray(ml.LightMatrix(scene, without_patches(scene, lights), device="cpu",
                                     visibility="ray_traced").columns(js)) != c
    assert near.sum() > 1000, "too few near-field elements to compare"
    diff = np.abs(g - c) > 1e-5 * np.abs(c) + 1e-6 * np.abs(c).max()
    print(f"\n{near.sum()} near-field values, {diff.sum()} of {c.size} differ between GPU and CPU")
    assert diff.mean() <= 1e-3
    # Rows (the GPU row pass) use the same formula.
    rows = np.asarray(gpu.rows([64 * 40 + 30, 64 * 50 + 20]))
    exact = np.stack([cpu.row_exact(64 * 40 + 30), cpu.row_exact(64 * 50 + 20)])
    np.testing.assert_allclose(rows, exact, rtol=2e-5, atol=1e-6 * exact.max())


def test_bad_patches_are_refused(scene):
    lights = ml.generate_lights(scene, area=4, environment=0, indirect=0, seed=0)
    base = dict(kind=lights.kind, position=lights.position, normal=lights.normal, intensity=lights.intensity)
    p = lights.patch.copy()
    p[2, 1, 0] = np.nan
    with pytest.raises(ValueError, match=r"patch\[2\] must have finite corners"):
        ml.LightSet.from_arrays(scene, **base, patch=p)
    p = lights.patch.copy()
    p[1] = [[0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0]]  # collinear: zero area
    with pytest.raises(ValueError, match=r"patch\[1\] has zero area"):
        ml.LightSet.from_arrays(scene, **base, patch=p)
    with pytest.raises(ValueError, match=r"patch must have shape \(n, 4, 3\) = \(4, 4, 3\), got \(4, 3\)"):
        ml.LightSet.from_arrays(scene, **base, patch=np.zeros((4, 3)))


def test_zero_area_emitter_is_a_scene_error(tmp_path):
    """An area light of zero area is refused when the scene loads (SceneError naming file, line and
    shape), so no oriented point (and no patch) of zero area can be generated from a scene."""
    xml = tmp_path / "flat.xml"
    xml.write_text(XML.read_text().replace('<scale x="0.05" y="0.03" z="1"/>', '<scale x="0.05" y="0" z="1"/>'))
    with pytest.raises(ml.SceneError, match=r'flat.xml:\d+: area emitter on a degenerate shape "panel".*zero area'):
        ml.load_scene(xml, size=(16, 16))


def test_textured_emitters_keep_the_point_formula(tmp_path):
    """The patch formula assumes L constant over the patch: points of a textured emitter carry none."""
    xml = tmp_path / "textured.xml"
    xml.write_text(XML.read_text().replace(
        '<rgb name="radiance" value="10, 10, 10"/>',
        '<texture type="checkerboard" name="radiance"><rgb name="color0" value="10, 1, 1"/>'
        '<rgb name="color1" value="1, 1, 10"/></texture>'))
    scene = ml.load_scene(xml, size=(16, 16))
    lights = ml.generate_lights(scene, area=64, environment=0, indirect=0, seed=0)
    assert len(lights) == 64 and not lights.patch.any()


DISK_RECESS = HERE / "data" / "disk_recess.xml"
DISK_RECESS_REF = HERE / "references" / "disk-recess-direct"


def _psa(p, n, corners):
    """Lambert's formula: the projected solid angle of a planar polygon (corners (K, 3), in order) from p on
    a plane of normal n: 1/2 |sum over edges of theta_k (n . g_k) / |g_k||, g_k = a_k x a_{k+1}."""
    a = np.asarray(corners, dtype=np.float64) - p
    b = np.roll(a, -1, axis=0)
    g = np.cross(a, b)
    gl = np.linalg.norm(g, axis=1)
    cos = np.einsum("ij,ij->i", a, b) / (np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1))
    theta = np.arccos(np.clip(cos, -1.0, 1.0))
    ok = gl > 0
    return 0.5 * abs(float(np.sum(theta[ok] * (g[ok] @ n) / gl[ok])))


def test_disk_light_in_a_ceiling_recess_converges():
    """A disk light (radius 12 cm) 1 cm below the top of a 15 cm ceiling recess (``tests/data/disk_recess.xml``),
    direct light, both places it lights:

    - the room's walls, lit through the opening (the recess hides part of many lights), against a converged
      Mitsuba pixel-centre reference (516k spp; its noise there 0.30%): the acceptance rule, 4x the lights give
      <= 0.6x the error (until within 1.5x of that noise). Measured, mean of 2 seeds: 3.0% / 0.93% / 0.41% at
      1k / 4k / 16k (x0.31, x0.44). With the lights offset_p off the disk (0.33 mm) as they were, the walls
      stayed 1.4% too bright: their visibility rays ended off the surface and saw more of the disk through
      the opening;
    - the recess walls, in the disk's near field, against the exact irradiance at each pixel's own point
      (Lambert's formula over the disk as a 4,096-gon): there the irradiance changes steeply and Mitsuba's
      pixel-centre points are not exactly ours (its values differ from the exact ones at our points by 0.16%,
      within its noise). Measured: 0.09% at 16k points (4 seeds)."""
    meta = json.loads(DISK_RECESS_REF.with_suffix(".json").read_text())
    ref = ml.read_exr(DISK_RECESS_REF.with_suffix(".exr"))[..., :3].astype(np.float64)
    var = ml.read_exr(DISK_RECESS_REF.with_suffix(".var.exr"))[..., :3].astype(np.float64)
    assert tuple(meta["size"]) == (64, 64) and meta["integrator"]["max_depth"] == 2
    scene = ml.load_scene(DISK_RECESS, res=64)
    g = scene.gbuffer(device="cpu")
    ids = np.array([scene.shapes[k]["id"] if k >= 0 else "" for k in np.asarray(g["shape_index"]).ravel()])
    room = (np.isin(ids, ["wall-back", "wall-left"]) & (ref.reshape(-1, 3).sum(-1) > 0)).reshape(64, 64)
    noise = float(np.sqrt(var[room].sum() / (ref[room] ** 2).sum()))
    errs, images = [], {}
    for n in (1024, 4096, 16384):
        e = []
        for seed in (0, 1):
            lights = ml.generate_lights(scene, area=n, environment=0, indirect=0, seed=seed)
            A = ml.LightMatrix(scene, lights, visibility="ray_traced", max_depth=2, device="cpu")
            images[n, seed] = img = A.column_sum(progress=False) + A.emitted()
            e.append(float(np.sqrt(((img - ref)[room] ** 2).sum() / (ref[room] ** 2).sum())))
        errs.append(float(np.mean(e)))
    print("\ndisk recess, room walls at 1k / 4k / 16k: " + " / ".join(f"{e:.2%}" for e in errs)
          + f" (reference noise {noise:.2%})")
    for a, b in zip(errs, errs[1:]):
        assert b <= 0.6 * a or b <= 1.5 * noise, (errs, noise)
    pos = np.asarray(g["position"], dtype=np.float64).reshape(-1, 3)
    nrm = np.asarray(g["normal"], dtype=np.float64).reshape(-1, 3)
    albedo = np.asarray(g["albedo"], dtype=np.float64).reshape(-1, 3)
    recess = np.flatnonzero(np.isin(ids, ["recess-left", "recess-back"]) & (pos[:, 1] < 2.64))
    assert len(recess) >= 60
    angle = 2 * np.pi * np.arange(4096) / 4096
    disk = np.stack([0.12 * np.cos(angle), np.full_like(angle, 2.64), 0.12 * np.sin(angle)], axis=1)
    radiance = np.array([30.0, 28.0, 25.0])
    exact = np.array([albedo[i] / np.pi * radiance * _psa(pos[i], nrm[i], disk) for i in recess])
    got = np.mean([images[16384, s].reshape(-1, 3)[recess] for s in (0, 1)], axis=0)
    assert np.linalg.norm(got - exact) / np.linalg.norm(exact) < 0.003


# Two more near-field shapes, against converged Mitsuba pixel-centre references (``make_references.py``):
# a 6.5 x 5.1 m emitter whose top edge meets the ceiling at a right angle (``wall_emitter_corner.xml``) and
# rectangles of aspect 1:50, one touching the floor, one 2 cm above it (``strip_lights.xml``). The error is
# taken on the lit pixels that see no emitter, where the reference's own noise is 0.54% / 0.81%.
# Measured on the CPU at 1k / 4k / 16k area points: wall corner 0.57 / 0.53 / 0.52%, strips 0.95 / 0.95 /
# 0.95% (chi^2 per pixel against the reference's variance 1.04: at its noise from 1k points on).
CORNER_CASES = {"wall-corner": ("wall_emitter_corner.xml", "wall-corner-direct"),
                "strips-1-50": ("strip_lights.xml", "strip-lights-direct")}


@pytest.mark.parametrize("device", ["cpu", "gpu"])
@pytest.mark.parametrize("case", list(CORNER_CASES))
def test_right_angle_emitter_edges_and_thin_strips_converge(case, device):
    """The acceptance rule: 4x the lights give <= 0.6x the error until it is within 1.5x of the reference's
    noise; both backends (the GPU at 1k and 4k points)."""
    xml, ref_name = CORNER_CASES[case]
    meta = json.loads((HERE / "references" / f"{ref_name}.json").read_text())
    assert tuple(meta["size"]) == (64, 64) and meta["integrator"]["max_depth"] == 2
    ref = ml.read_exr(HERE / "references" / f"{ref_name}.exr")[..., :3].astype(np.float64)
    var = ml.read_exr(HERE / "references" / f"{ref_name}.var.exr")[..., :3].astype(np.float64)
    scene = ml.load_scene(HERE / "data" / xml, res=64)
    errs, noise = [], None
    for n in ((1024, 4096, 16384) if device == "cpu" else (1024, 4096)):
        lights = ml.generate_lights(scene, area=n, environment=0, indirect=0, seed=0)
        A = ml.LightMatrix(scene, lights, visibility="ray_traced", max_depth=2, device=device)
        em = A.emitted()
        img = A.column_sum(progress=False) + em
        lit = (em.sum(-1) == 0) & (ref.sum(-1) > 0)
        denom = (ref[lit] ** 2).sum()
        errs.append(float(np.sqrt(((img - ref)[lit] ** 2).sum() / denom)))
        noise = float(np.sqrt(var[lit].sum() / denom))
    print(f"\n{case} [{device}]: " + " / ".join(f"{e:.2%}" for e in errs) + f" (reference noise {noise:.2%})")
    for a, b in zip(errs, errs[1:]):
        assert b <= 0.6 * a or b <= 1.5 * noise, (errs, noise)
    assert errs[-1] <= 1.5 * noise, (errs, noise)
