"""Looking at results: ``print(result)`` is a short summary, ``repr`` stays under 1,000 characters,
``_repr_png_`` is the PNG ``write_png`` writes, and ``ml.show`` displays inline in Jupyter or writes a PNG."""
from __future__ import annotations

import sys
import types
from unittest import mock

import numpy as np
import pytest

import manylights as ml
from conftest import SCENES
from manylights.io import display as show_module

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def matrix():
    scene = ml.load_scene(SCENES / "cbox" / "scene.xml", res=16)
    return ml.LightMatrix(scene, ml.generate_lights(scene, area=200, seed=1), device="cpu")


def _png_pixels(data: bytes, tmp_path) -> np.ndarray:
    import imageio.v3 as iio

    return np.asarray(iio.imread(data, extension=".png"))


def test_render_result_summary_repr_and_png(matrix, tmp_path):
    res = ml.render(matrix, target_error=0.05, progress=False)
    text = str(res)
    lines = text.splitlines()
    assert lines[0].startswith("RenderResult: mrcs_progressive (seed 0) on cpu") and "16x16 image" in lines[0]
    assert any(line.startswith("  budget: rows ") for line in lines), text
    assert any(line.startswith("  error estimate: ") and "% relative L2" in line for line in lines), text
    time_line = next(line for line in lines if line.startswith("  time: "))
    assert f"{res.seconds:.3g} s = " in time_line and "clustering" in time_line
    assert "shadow" not in text  # a CPU matrix: no shadow-map stages
    assert len(lines) <= 8
    r = repr(res)
    assert r.startswith("<RenderResult: mrcs_progressive") and len(r) < 1000 and "\n" not in r
    # Even with many stages, big arrays and long budgets the repr stays short.
    big = ml.RenderResult(image=np.zeros((512, 512, 3), np.float32), method="x" * 500, seed=1,
                          timings={f"stage{k}": 0.1 * k for k in range(1, 40)},
                          budget={f"key{k}": np.arange(1000) for k in range(30)}, error_estimate=0.5,
                          bias_sources=[{"source": "s" * 300, "reason": "r"}] * 20)
    assert len(repr(big)) < 1000 and len(str(big).splitlines()) <= 8
    # _repr_png_: the same bytes as write_png writes
    png = res._repr_png_()
    assert png.startswith(PNG_MAGIC)
    ml.write_png(tmp_path / "ref.png", res.image)
    assert png == (tmp_path / "ref.png").read_bytes()
    assert _png_pixels(png, tmp_path).shape == (16, 16, 3)


def test_animation_result_summary_and_png():
    frames = np.random.default_rng(0).random((5, 6, 4, 3)).astype(np.float32)
    res = ml.AnimationResult(frames=frames, method="tensor_clustering", seed=3,
                             shadow_maps_per_frame=np.array([10, 12, 8, 9, 11]),
                             timings={"slices": 1.5, "clustering": 0.25}, budget={"rows": 10, "columns": 30},
                             device={"kind": "cpu", "name": "test"})
    text = str(res)
    assert text.splitlines()[0] == "AnimationResult: tensor_clustering (seed 3) on cpu (test), 5 frames of 4x6"
    assert "time: 1.75 s = slices 1.5 + clustering 0.25" in text
    assert len(repr(res)) < 1000
    png = res._repr_png_()
    # the frames side by side: 5 frames of width 4
    assert _png_pixels(png, None).shape == (6, 20, 3)


def test_show_writes_png_outside_a_notebook(tmp_path, capsys):
    img = np.zeros((8, 10, 3), np.float32)
    img[:, :5] = 1.0
    out = ml.show(img, path=tmp_path / "a.png")
    assert out == tmp_path / "a.png"
    px = _png_pixels(out.read_bytes(), tmp_path)
    assert px.shape == (8, 10, 3) and px[0, 0].tolist() == [255, 255, 255] and px[0, 9].tolist() == [0, 0, 0]
    # without a path: a new file in the temporary folder, its name printed
    out2 = ml.show(img[..., 0])  # grey (H, W) works too
    try:
        assert out2.suffix == ".png" and out2.name.startswith("manylights-")
        assert f"wrote {out2}" in capsys.readouterr().out
        assert _png_pixels(out2.read_bytes(), tmp_path).shape == (8, 10, 3)
    finally:
        out2.unlink()
    with pytest.raises(ValueError, match="shape"):
        ml.show(np.zeros((2, 3, 5)))
    with pytest.raises(TypeError, match="unexpected keyword argument 'exposre'; did you mean 'exposure'"):
        ml.show(img, exposre=1)


def test_show_displays_inline_in_a_notebook():
    """In a Jupyter kernel ``show`` hands IPython.display one PNG and returns None (IPython stubbed)."""
    shown = []
    display_mod = types.SimpleNamespace(Image=lambda data, format: ("Image", data, format),
                                        display=lambda obj: shown.append(obj))
    ipython = types.ModuleType("IPython")
    ipython.display = display_mod
    ipython.get_ipython = lambda: types.SimpleNamespace(config={"IPKernelApp": {}})
    with mock.patch.dict(sys.modules, {"IPython": ipython, "IPython.display": display_mod}):
        assert show_module.in_notebook()
        assert ml.show(np.ones((4, 4, 3), np.float32)) is None
    assert len(shown) == 1 and shown[0][0] == "Image" and shown[0][2] == "png"
    assert shown[0][1].startswith(PNG_MAGIC)
