"""``python -m manylights.bench relight`` on a tiny configuration: cbox with a spot at
24x24, 4^4 gather samples, a 256-spp full-GI reference in a temporary cache. No timing is compared with a
constant: the checks are on the errors against the reference (the same numbers recomputed here), the
culling table, the frame-rate rows, the cache and the files written."""
from __future__ import annotations

import argparse
import json

import pytest

import manylights as ml
from manylights.bench import relight as br

pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")


def _args(*argv):
    ap = argparse.ArgumentParser()
    br.add_parser(ap.add_subparsers(dest="cmd"))
    return ap.parse_args(["relight", *map(str, argv)])


def _base(tmp):
    return ["--res", 24, "--gather", 256, "--bounces", 2, "--ref-spp", 256, "--cache", tmp / "cache",
            "--out", tmp / "out", "--relights", 2]


@pytest.fixture(scope="module")
def result(tmp_path_factory, mitsuba_ref):
    tmp = tmp_path_factory.mktemp("relight")
    assert br.run(_args(*_base(tmp), "--coefficients", 4, 64, 256, "--default-coefficients", 64,
                        "--cull", 1e-3, 1e-1, "--sizes", "20x16")) == 0
    return tmp, json.loads((tmp / "out" / "relight-cbox.json").read_text())


def test_errors_are_those_of_the_relit_images(result, mitsuba_ref):
    tmp, r = result
    assert [row["coefficients"] for row in r["coefficients"]] == [4, 64, 256]
    # Recompute the 64-coefficient row: the same precomputation relit by the same spot against the cached
    # reference gives the stored error.
    path = br.spot_scene("cbox", br.SPOT_SEEN, tmp / "scenes", "check")
    scene = ml.load_scene(path, size=(24, 24), res=24)
    rel = ml.DirectToIndirect(scene, gather=256, final_gather_coefficients=64, bounces=2, multibounce_coefficients=40)
    ref_exr = [p for p in (tmp / "cache").glob("ref-cbox-spot-seen-*.exr") if not p.name.endswith(".var.exr")]
    assert len(ref_exr) == 1
    err = ml.relative_l2(rel.relight(ml.scene_lights(scene)), ml.read_exr(ref_exr[0]))
    row = r["coefficients"][1]
    assert row["relative_l2"] == pytest.approx(err, rel=1e-5)
    # Every coefficient count keeps the energy of the one bounce roughly right at this size: the error is
    # bounded by the indirect share (~45% in cbox) and well above 0.
    for row in r["coefficients"]:
        assert 0.01 < row["relative_l2"] < 0.45 and row["relative_l2_no_edges"] <= row["relative_l2"] + 0.05
        assert row["bytes"] > 0 and row["precompute_seconds"] > 0
    assert r["coefficients"][0]["bytes"] < r["coefficients"][2]["bytes"]
    assert 0.01 < r["unseen"]["relative_l2"] < 0.45
    assert 0 < r["edge_fraction"]["seen"] < 0.5


def test_culling_and_frame_rate_rows(result):
    _, r = result
    cull = r["culling"]
    assert [c["epsilon_fraction"] for c in cull] == [0.0, 1e-3, 1e-1]
    assert cull[0]["wavelet_lights_culled"] == 0
    # A larger epsilon culls more wavelet lights and changes the image more; at 10% of the image's norm
    # it still changes it by less than the bound's worst case (every culled light at epsilon).
    assert cull[1]["wavelet_lights_culled"] <= cull[2]["wavelet_lights_culled"] < cull[2]["wavelet_lights"]
    assert 0 < cull[2]["change"] and cull[1]["change"] <= cull[2]["change"]
    fr = r["frame_rate"]
    assert len(fr) == 1 and fr[0]["size"] == [20, 16]
    assert fr[0]["relights_per_second"] == pytest.approx(1 / fr[0]["relight_seconds_median"])
    assert set(fr[0]["stages_median_seconds"]) >= {"gather_direct", "transfer", "view_direct"}


def test_files_and_reference_cache(result):
    tmp, r = result
    assert (tmp / "out" / "relight-cbox.png").stat().st_size > 0
    assert (tmp / "out" / "relight-cbox-strip.png").stat().st_size > 0
    assert len(list((tmp / "cache").glob("ref-*.json"))) == 2
    assert not list((tmp / "out").glob("*.tmp*"))


@pytest.mark.parametrize("argv, needle", [
    (["--gather", 32], "power of 4"),
    (["--coefficients", 0], "coefficient"),
    (["--gather", 16, "--coefficients", 17], "coefficient"),
    (["--sizes", "320by240"], "320by240"),
    (["--sizes", "0x10"], "0x10"),
    (["--cull", -1], "--cull"),
    (["--relights", 0], "--relights"),
    (["--max-depth", 1], "--max-depth"),
])
def test_bad_arguments(argv, needle, tmp_path):
    with pytest.raises(ValueError, match=needle):
        br.run(_args("--out", tmp_path, "--cache", tmp_path, *argv))
    assert not list(tmp_path.iterdir())
