"""Unknown keyword arguments: every public function and class in ``__all__`` refuses them before its body
runs (so before any native work), with a TypeError naming the closest valid keyword."""
from __future__ import annotations

import inspect
from unittest import mock

import pytest

import manylights as ml
from conftest import SCENES

# A misspelling per function: (function, keyword given, keyword the message must suggest).
MISSPELLED = [
    (ml.mrcs, "colums", "columns"),
    (ml.mrcs, "projection_dims", "projection_dim"),  # forwarded to cluster_reduced_columns
    (ml.render, "target_eror", "target_error"),
    (ml.generate_lights, "aera", "area"),
    (ml.LightMatrix, "devise", "device"),
    (ml.power_sampling, "colums", "columns"),
    (ml.instant_radiosity, "shadow_map", "shadow_map_size"),  # forwarded to LightMatrix
    (ml.render_brute_force, "visibilty", "visibility"),
    (ml.mrcs_progressive, "round", "rounds"),
    (ml.DirectToIndirect, "gathers", "gather"),
    (ml.kmeans, "iteration", "iterations"),
    (ml.write_png, "exposur", "exposure"),
]


def _public_callables():
    for name in ml.__all__:
        obj = getattr(ml, name)
        if inspect.isfunction(obj):
            yield name, obj, obj
        elif inspect.isclass(obj) and inspect.isfunction(obj.__init__) and "__wrapped__" in vars(obj.__init__):
            yield name, obj, obj.__init__


@pytest.mark.parametrize("fn,given,suggested", MISSPELLED, ids=[f"{f.__name__}-{g}" for f, g, _ in MISSPELLED])
def test_misspelled_keyword_names_the_closest(fn, given, suggested):
    # Real-looking positional arguments are not needed: the keyword is refused first.
    with pytest.raises(TypeError, match=rf"unexpected keyword argument '{given}'; did you mean '{suggested}'\?"):
        fn(None, None, **{given: 1})


def test_every_public_function_checks_keywords_before_its_body():
    """Each public Python function (and class constructor) is wrapped: with its body replaced by a counting
    mock, an unknown keyword raises TypeError and the body never ran; a valid call reaches the body once."""
    checked = []
    for name, obj, fn in _public_callables():
        if name in ("load_scene", "load_animation"):
            continue  # scene parameters: the next test and tests/animation/test_animation.py
        assert hasattr(fn, "__wrapped__"), f"{name} does not check its keywords"
        body = mock.Mock(return_value="ran")
        with mock.patch.object(fn, "__wrapped__", body):
            with pytest.raises(TypeError, match="unexpected keyword argument 'no_such_option'"):
                obj(None, no_such_option=1)
            assert body.call_count == 0, name
            if inspect.isfunction(obj):
                assert obj(None) == "ran" and body.call_count == 1, name
        checked.append(name)
    assert len(checked) >= 35, checked
    for must in ["mrcs", "render", "generate_lights", "LightMatrix", "power_sampling", "DirectToIndirect"]:
        assert must in checked


def test_load_scene_refuses_unknown_parameter_before_loading():
    """``load_scene(path, rez=64)``: no ``$rez`` in the file, so TypeError suggesting ``res``, and the native
    loader is never called; a valid parameter still loads."""
    from manylights import scene as scene_module

    xml = SCENES / "cbox" / "scene.xml"
    with mock.patch.object(scene_module._native, "load_scene", side_effect=AssertionError("loader ran")) as native:
        with pytest.raises(TypeError, match=r"unexpected scene parameter 'rez'; did you mean 'res'\?"):
            ml.load_scene(xml, rez=64)
        assert native.call_count == 0
    assert ml.load_scene(xml, res=8).width == 8
    # a parameter that only an included file refers to is valid (cbox-rgb.xml: $res in fragments/base.xml)
    assert ml.load_scene(SCENES / "cbox" / "cbox-rgb.xml", res=8).width == 8
    with pytest.raises(TypeError, match=r"'spd'; did you mean 'spp'\?"):
        ml.load_scene(SCENES / "cbox" / "cbox-rgb.xml", spd=8)
