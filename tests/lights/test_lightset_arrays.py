"""Light sets made by researchers: ``LightSet.from_arrays``, indexing / masks / slices,
``LightSet.concat``, with shape and value checks.

The round trip rebuilds a generated set holding all five kinds (point, spot, directional, oriented
point, VPL) from its arrays and must render the same image bit for bit; subsets and concatenations
must give the same columns as the full set; a point light built from arrays must equal the scene's
own XML point light (whose columns are checked against Mitsuba in test_lights.py).
"""
from __future__ import annotations

import numpy as np
import pytest

import manylights as ml
from conftest import SCENE_CONFIGS

KINDS = {0: "point", 1: "spot", 2: "directional", 3: "oriented point", 4: "VPL"}


@pytest.fixture(scope="module")
def scene():
    xml, params, _ = SCENE_CONFIGS["cbox-lights"]
    return ml.load_scene(xml, size=(24, 24), **params)


@pytest.fixture(scope="module")
def lights(scene):
    s = ml.generate_lights(scene, area=24, environment=8, indirect=24, seed=3)
    assert set(np.unique(s.kind)) == set(KINDS), f"the set must hold every kind, got {np.unique(s.kind)}"
    return s


def _arrays(s):
    return dict(kind=s.kind, position=s.position, direction=s.direction, normal=s.normal,
                geo_normal=s.geo_normal, incident=s.incident, intensity=s.intensity,
                cutoff_angle=s.cutoff_angle, beam_width=s.beam_width, bsdf=s.bsdf, vpl_clamp=s.vpl_clamp,
                patch=s.patch, vsl_radius=s.vsl_radius, vpl_depth=s.vpl_depth)


def _bits(a):
    return np.ascontiguousarray(a).view(np.uint32)


def test_from_arrays_round_trip_is_bit_identical(scene, lights):
    t = ml.LightSet.from_arrays(scene, **_arrays(lights))
    assert len(t) == len(lights)
    for name in ["kind", "position", "direction", "normal", "geo_normal", "incident", "intensity",
                 "cutoff_angle", "beam_width", "bsdf", "power", "vpl_depth"]:
        a, b = getattr(lights, name), getattr(t, name)
        assert a.shape == b.shape and np.array_equal(_bits(a), _bits(b)), name
    assert t.vpl_clamp == lights.vpl_clamp and t.scene_sphere == lights.scene_sphere
    img_a = ml.LightMatrix(scene, lights).column_sum(progress=False)
    img_b = ml.LightMatrix(scene, t).column_sum(progress=False)
    assert img_a.max() > 0
    assert np.array_equal(_bits(img_a), _bits(img_b))


def test_masks_indices_slices_concat_give_the_same_columns(scene, lights):
    A = ml.LightMatrix(scene, lights)
    n = len(lights)
    vpl = lights.kind == 4
    cases = {
        "mask": (lights[vpl], np.flatnonzero(vpl)),
        "indices": (lights[np.array([5, 2, 2, -1])], np.array([5, 2, 2, n - 1])),
        "slice": (lights[3:n:7], np.arange(3, n, 7)),
        "int": (lights[4], np.array([4])),
        "concat": (ml.LightSet.concat([lights[n - 2:], lights[:3]]), np.r_[n - 2, n - 1, 0, 1, 2]),
    }
    for name, (sub, idx) in cases.items():
        assert len(sub) == len(idx), name
        assert np.array_equal(sub.position, lights.position[idx]), name
        assert np.array_equal(sub.kind, lights.kind[idx]), name
        cols_full = A.columns(idx)
        cols_sub = ml.LightMatrix(scene, sub).columns(range(len(idx)))
        assert cols_full.max() > 0, name
        np.testing.assert_array_equal(cols_sub, cols_full, err_msg=name)
    whole = ml.LightSet.concat([lights[:10], lights[10:]])
    assert np.array_equal(_bits(whole.bsdf), _bits(lights.bsdf)) and whole.vpl_clamp == lights.vpl_clamp


def test_point_light_from_arrays_equals_the_scene_xml_light(scene):
    xml_lights = ml.scene_lights(scene)
    j = int(np.flatnonzero(xml_lights.kind == 0)[0])
    p, i = xml_lights.position[j], xml_lights.intensity[j]
    # Given by power: P = 4 pi I for a point light.
    built = ml.LightSet.from_arrays(scene, kind=0, position=p[None].astype(np.float64),
                                    power=(4 * np.pi * i.astype(np.float64))[None])
    np.testing.assert_allclose(built.intensity[0], i, rtol=1e-6)
    np.testing.assert_allclose(built.power[0], 4 * np.pi * i, rtol=1e-6)
    exact = ml.LightSet.from_arrays(scene, kind=[0], position=[p], intensity=[i])
    col_xml = ml.LightMatrix(scene, xml_lights).columns([j])
    col_new = ml.LightMatrix(scene, exact).columns([0])
    assert col_xml.max() > 0
    np.testing.assert_array_equal(col_new, col_xml)
    # A grey (n,) intensity and a diffuse-albedo VPL.
    v = ml.LightSet.from_arrays(scene, kind=4, position=[[0.1, 0.0, 0.2]], normal=[[0, 1, 0]],
                                geo_normal=[[0, 1, 0]], incident=[[0, 1, 0]], intensity=[2.0], albedo=[0.5])
    # power of a diffuse VPL: flux * albedo.
    np.testing.assert_allclose(v.power[0], [1.0, 1.0, 1.0], rtol=1e-6)
    assert v.bsdf.shape == (1, 20)


def test_spot_and_directional_from_arrays(scene):
    s = ml.LightSet.from_arrays(scene, kind=[1, 2], position=[[0, 1.5, 0], [0, 0, 0]],
                                direction=[[0, -1, 0], [0, -0.6, -0.8]], intensity=[[1, 2, 3], [0.5, 0.5, 0.5]],
                                cutoff_angle=[0.5, 0.0], beam_width=[0.25, 0.0])
    assert list(s.kind) == [1, 2]
    np.testing.assert_array_equal(s.position[1], [0, 0, 0])
    np.testing.assert_allclose(s.cutoff_angle, [0.5, 0.0])
    # Spot power: I * 2 pi (1 - (sin c - sin b) / (c - b)).
    c, b = 0.5, 0.25
    np.testing.assert_allclose(s.power[0], np.array([1, 2, 3]) * 2 * np.pi * (1 - (np.sin(c) - np.sin(b)) / (c - b)),
                               rtol=1e-5)


BAD = [
    (dict(kind=[0, 0], position=[[0, 0, 0], [np.nan, 0, 0]], intensity=[[1, 1, 1]] * 2), "position[1]", "finite"),
    (dict(kind=[0], position=[[0, 0, 0]], intensity=[[1, -1, 1]]), "intensity[0]", ">= 0"),
    (dict(kind=[3], position=[[0, 0, 0]], normal=[[0, 0, 2]], intensity=[[1, 1, 1]]), "normal[0]", "unit"),
    (dict(kind=[0, 0, 0], position=np.zeros((3, 2)), intensity=np.ones((3, 3))), "position", "(3, 3)"),
    (dict(kind=[0, 0], position=np.zeros((2, 3)), intensity=np.ones((3, 3))), "intensity", "got (3, 3)"),
    (dict(kind=[9], position=[[0, 0, 0]], intensity=[[1, 1, 1]]), "kind[0] = 9", "light kind"),
    (dict(kind=[1], position=[[0, 0, 0]], direction=[[0, 0, 1]], intensity=[[1, 1, 1]]), "cutoff_angle", "required"),
    (dict(kind=[1], position=[[0, 0, 0]], direction=[[0, 0, 1]], intensity=[[1, 1, 1]], cutoff_angle=0.3,
          beam_width=0.4), "beam_width[0]", "cutoff_angle"),
    (dict(kind=[4], position=[[0, 0, 0]], normal=[[0, 0, 1]], geo_normal=[[0, 0, 1]], incident=[[0, 0, 1]],
          intensity=[[1, 1, 1]]), "bsdf", "required"),
    (dict(kind=[2], direction=[[0, 0, 0]], intensity=[[1, 1, 1]]), "direction[0]", "unit"),
    (dict(kind=[0], position=[["a", "b", "c"]], intensity=[[1, 1, 1]]), "position", "dtype"),
    (dict(kind=[0.5], position=[[0, 0, 0]], intensity=[[1, 1, 1]]), "kind", "integers"),
    (dict(kind=[0], position=[[0, 0, 0]], intensity=[[1, 1, 1]], colour=1), "unknown argument 'colour'", "kind"),
    (dict(kind=[0], position=[[0, 0, 0]]), "intensity=", "power="),
    (dict(kind=[0], position=[[0, 0, 0]], power=[[1, np.inf, 1]]), "power[0]", "finite"),
    (dict(kind=[4], position=[[0, 0, 0]], normal=[[0, 0, 1]], geo_normal=[[0, 0, 1]], incident=[[0, 0, 1]],
          intensity=[[1, 1, 1]], albedo=[[0.5, 1.5, 0.5]]), "albedo[0]", "[0, 1]"),
    (dict(kind=[4, 4], position=[[0, 0, 0]] * 2, normal=[[0, 0, 1]] * 2, geo_normal=[[0, 0, 1]] * 2,
          incident=[[0, 0, 1]] * 2, intensity=[[1, 1, 1]] * 2, albedo=[0.5, 0.5], vpl_depth=[2, 0]), "vpl_depth[1]", ">= 1"),
    (dict(kind=[4], position=[[0, 0, 0]], normal=[[0, 0, 1]], geo_normal=[[0, 0, 1]], incident=[[0, 0, 1]],
          intensity=[[1, 1, 1]], albedo=[0.5], vpl_depth=1.5), "vpl_depth[0]", "integer"),
]


@pytest.mark.parametrize("kwargs,what,why", BAD, ids=[b[1] for b in BAD])
def test_from_arrays_bad_input(scene, kwargs, what, why):
    with pytest.raises(ValueError) as e:
        ml.LightSet.from_arrays(scene, **kwargs)
    assert what in str(e.value) and why in str(e.value), str(e.value)


def test_indexing_and_concat_bad_input(scene, lights):
    n = len(lights)
    with pytest.raises(IndexError, match=f"shape \\({n},\\)"):
        lights[np.ones(n + 1, dtype=bool)]
    with pytest.raises(IndexError, match=f"light index {n} .* out of range for {n} lights"):
        lights[[0, n]]
    with pytest.raises(IndexError):
        lights[-n - 1]
    with pytest.raises(TypeError, match="dtype"):
        lights[np.array([0.5])]
    assert len(lights[np.zeros(n, dtype=bool)]) == 0 and len(lights[5:2]) == 0
    with pytest.raises(ValueError, match="at least one"):
        ml.LightSet.concat([])
    xml, params, _ = SCENE_CONFIGS["cbox"]
    other = ml.load_scene(xml, size=(8, 8), **params)
    o = ml.LightSet.from_arrays(other, kind=0, position=[[0, 0.5, 0]], intensity=[[1, 1, 1]])
    with pytest.raises(ValueError, match="another scene"):
        ml.LightSet.concat([lights, o])
