"""Saving and loading a direct-to-indirect precomputation (save/load and bad input):
``rel.save(path)`` / ``ml.DirectToIndirect.load(path, scene)``. A loaded object relights bit-identically;
a scene whose geometry, materials, camera or film changed is refused; a scene whose lights changed loads;
damaged, truncated and foreign files are refused; a failed save leaves no file behind."""
from __future__ import annotations

import json
import re
import zipfile
from pathlib import Path

import numpy as np
import pytest

import manylights as ml
from manylights.relight import store as relight_store

BOX = Path(__file__).parents[1] / "data" / "relight_box.xml"


@pytest.fixture(scope="module")
def box():
    return ml.load_scene(BOX)


@pytest.fixture(scope="module")
def rel(box):
    return ml.DirectToIndirect(box, gather=4**4, final_gather_coefficients=40, bounces=2, multibounce_coefficients=20)


@pytest.fixture(scope="module")
def saved(rel, tmp_path_factory):
    return rel.save(tmp_path_factory.mktemp("store") / "box.npz")


def _other_lights(scene):
    return ml.LightSet.from_arrays(scene, kind=[1, 0], position=[[-0.5, 0.8, 0.2], [0.4, 0.5, 0.5]],
                                   direction=[np.array([0.3, -1.0, -0.2]) / np.linalg.norm([0.3, -1.0, -0.2]), [0, 0, 0]], intensity=[[2, 2, 1.5], [0.4, 0.5, 0.6]],
                                   cutoff_angle=[np.radians(35), 0], beam_width=[np.radians(25), 0])


def _variant(tmp_path, name, old, new):
    text = BOX.read_text()
    assert old in text, old
    p = tmp_path / f"{name}.xml"
    p.write_text(text.replace(old, new))
    return p


def test_loaded_transfer_relights_bit_identically(box, rel, saved):
    loaded = ml.DirectToIndirect.load(saved, box)
    for lights in [ml.scene_lights(box), _other_lights(box)]:
        for eps in [0.0, 1e-3]:
            a, b = rel.relight(lights, epsilon=eps), loaded.relight(lights, epsilon=eps)
            assert a.dtype == b.dtype == np.float32 and a.shape == b.shape == (32, 32, 3)
            assert np.array_equal(a, b)
            assert a.max() > 0.01
    assert np.array_equal(rel.gather_positions, loaded.gather_positions)
    assert np.array_equal(rel.gather_irradiance(ml.scene_lights(box)), loaded.gather_irradiance(ml.scene_lights(box)))
    # Stats and the precomputation's timings come back.
    for k in ["gather", "pixels", "coefficients_per_row", "coefficients_kept", "bounces",
              "multibounce_coefficients_kept", "bytes", "shadow_rays", "links", "threshold", "near_field"]:
        assert loaded.stats[k] == rel.stats[k], k
    for k in ["gather_cloud", "hierarchy", "final_gather", "multibounce"]:
        assert loaded.timings[k] == rel.timings[k], k
    assert rel.stats["multibounce_coefficients_kept"] > 0
    assert repr(loaded) == repr(rel)


def test_file_holds_format_version_hash_and_info(box, rel, saved):
    with np.load(saved, allow_pickle=False) as z:
        assert str(z["format"]) == "manylights.DirectToIndirect" and int(z["version"]) == relight_store.VERSION
        assert json.loads(str(z["scene_hash"])) == relight_store.scene_hash(box)
        info = json.loads(str(z["info"]))
        assert info["options"]["gather"] == 256 and info["options"]["coefficients"] == 40
        assert info["options"]["bounces"] == 2 and info["options"]["multibounce_coefficients"] == 20
        assert info["stats"]["coefficients_kept"] == rel.stats["coefficients_kept"]
        assert info["timings"]["final_gather"] == rel.timings["final_gather"]
        # The sparse rows as stored: 1024 pixels, at most 40 coefficients each, indices < 256.
        off, idx = z["final_gather.offsets"], z["final_gather.index"]
        assert off.shape == (1025,) and off[-1] == len(idx) == rel.stats["coefficients_kept"]
        assert np.diff(off).max() <= 40 and idx.max() < 256
    names = zipfile.ZipFile(saved).namelist()
    assert "final_gather.value.npy" in names and "multibounce.index.npy" in names
    assert not [p for p in saved.parent.iterdir() if p.name.endswith(".tmp")]


def test_point_near_field_round_trips(box, tmp_path):
    rel = ml.DirectToIndirect(box, gather=4**3, final_gather_coefficients=16, near_field="point")
    rel.save(tmp_path / "point.npz")
    loaded = ml.DirectToIndirect.load(tmp_path / "point.npz", box)
    assert loaded.stats["near_field"] == "point" and rel.stats["near_field"] == "point"
    lights = ml.scene_lights(box)
    assert np.array_equal(loaded.relight(lights), rel.relight(lights))
    # The disc form differs (it is darker next to corners), so the option really travels with the file.
    disc = ml.DirectToIndirect(box, gather=4**3, final_gather_coefficients=16)
    assert not np.array_equal(disc.relight(lights), rel.relight(lights))


def test_changed_lights_still_load(box, rel, saved, tmp_path):
    """Emitters are not part of the scene hash: a moved, brighter spot light and an added point light load,
    and relight as the original transfer does with the same lights."""
    p = _variant(tmp_path, "lights", '<rgb name="intensity" value="3, 3, 2.5"/>', '<rgb name="intensity" value="9, 1, 1"/>')
    text = p.read_text().replace('origin="0.3, 0.9, 0.4"', 'origin="-0.3, 0.9, 0.2"')
    text = text.replace("</scene>", '<emitter type="point"><point name="position" x="0" y="0.5" z="0"/>'
                                    '<rgb name="intensity" value="1, 1, 1"/></emitter></scene>')
    p.write_text(text)
    scene2 = ml.load_scene(p)
    loaded = ml.DirectToIndirect.load(saved, scene2)
    lights2 = ml.scene_lights(scene2)
    assert len(lights2) == 2
    same = ml.LightSet.from_arrays(box, kind=lights2.kind, position=lights2.position, direction=lights2.direction,
                                   intensity=lights2.intensity, cutoff_angle=lights2.cutoff_angle,
                                   beam_width=lights2.beam_width)
    assert np.array_equal(loaded.relight(lights2), rel.relight(same))


@pytest.mark.parametrize("what,old,new,section", [
    ("geometry moved", '<translate x="-0.35" y="-0.4" z="-0.3"/>', '<translate x="-0.3" y="-0.4" z="-0.3"/>', "geometry"),
    ("material changed", '<rgb name="reflectance" value="0.63, 0.065, 0.05"/>', '<rgb name="reflectance" value="0.6, 0.065, 0.05"/>', "materials"),
    ("camera moved", '<lookat origin="0, 0, 3.9"', '<lookat origin="0, 0.1, 3.9"', "camera"),
    ("film size", '<default name="res" value="32"/>', '<default name="res" value="24"/>', "film"),
])
def test_changed_scene_is_refused(saved, tmp_path, what, old, new, section):
    p = _variant(tmp_path, section, old, new)
    with pytest.raises(ValueError) as e:
        ml.DirectToIndirect.load(saved, ml.load_scene(p))
    msg = str(e.value)
    assert str(saved) in msg and f"({section} changed" in msg and "precompute again" in msg, msg
    # Only the changed section is named.
    others = {"geometry", "materials", "camera", "film"} - {section}
    assert not any(re.search(rf"\b{o}\b", msg.split("changed")[0].split("(")[-1]) for o in others), msg


def test_truncated_damaged_and_foreign_files_are_refused(box, saved, tmp_path):
    data = saved.read_bytes()
    cases = {
        "truncated.npz": data[: len(data) // 2],
        "truncated-end.npz": data[:-10],
        "empty.npz": b"",
        "random.npz": np.random.default_rng(0).bytes(4096),
        "image.npz": _png_bytes(tmp_path),
    }
    for name, blob in cases.items():
        p = tmp_path / name
        p.write_bytes(blob)
        with pytest.raises(ValueError) as e:
            ml.DirectToIndirect.load(p, box)
        assert str(p) in str(e.value) and ("not a manylights relighting file" in str(e.value)
                                           or "truncated" in str(e.value)), (name, str(e.value))
    # One flipped byte inside the largest array: the zip's CRC-32 catches it.
    with zipfile.ZipFile(saved) as z:
        info = max(z.infolist(), key=lambda i: i.file_size)
    flipped = bytearray(data)
    at = info.header_offset + 30 + len(info.filename) + info.file_size // 2
    flipped[at] ^= 0x40
    p = tmp_path / "flipped.npz"
    p.write_bytes(bytes(flipped))
    with pytest.raises(ValueError, match="damaged"):
        ml.DirectToIndirect.load(p, box)
    # A foreign npz: no format entry.
    p = tmp_path / "foreign.npz"
    np.savez(p, x=np.zeros(3))
    with pytest.raises(ValueError, match="not a manylights relighting file"):
        ml.DirectToIndirect.load(p, box)
    with pytest.raises(FileNotFoundError):
        ml.DirectToIndirect.load(tmp_path / "missing.npz", box)
    with pytest.raises(TypeError, match="Scene"):
        ml.DirectToIndirect.load(saved, str(BOX))


def _png_bytes(tmp_path):
    p = tmp_path / "x.png"
    ml.write_png(p, np.full((4, 4, 3), 0.5, np.float32))
    return p.read_bytes()


def _rewrite(src, dst, **changes):
    with np.load(src, allow_pickle=False) as z:
        arrays = {k: z[k] for k in z.files}
    for k, v in changes.items():
        if v is None:
            del arrays[k]
        else:
            arrays[k] = v
    np.savez(dst, **arrays)
    return dst


def test_wrong_version_and_inconsistent_arrays_are_refused(box, saved, tmp_path):
    p = _rewrite(saved, tmp_path / "v2.npz", version=np.array(2, np.uint32))
    with pytest.raises(ValueError, match="version 2.*reads version 1"):
        ml.DirectToIndirect.load(p, box)
    p = _rewrite(saved, tmp_path / "fmt.npz", format=np.array("something.else"))
    with pytest.raises(ValueError, match="something.else"):
        ml.DirectToIndirect.load(p, box)
    with np.load(saved) as z:
        idx = z["final_gather.index"].copy()
        order = z["hierarchy.order"].copy()
    idx[7] = 256
    p = _rewrite(saved, tmp_path / "index.npz", **{"final_gather.index": idx})
    with pytest.raises(ValueError, match=r"final_gather.*256 >= gather \(256\)"):
        ml.DirectToIndirect.load(p, box)
    order[3] = order[4]
    p = _rewrite(saved, tmp_path / "order.npz", **{"hierarchy.order": order})
    with pytest.raises(ValueError, match="permutation"):
        ml.DirectToIndirect.load(p, box)
    p = _rewrite(saved, tmp_path / "gather.npz", **{"options.gather": np.array(128, np.uint64)})
    with pytest.raises(ValueError, match="power of 4"):
        ml.DirectToIndirect.load(p, box)
    p = _rewrite(saved, tmp_path / "coef.npz", **{"options.coefficients": np.array(257, np.uint64)})
    with pytest.raises(ValueError, match=r"257.*gather \(256\)"):
        ml.DirectToIndirect.load(p, box)
    p = _rewrite(saved, tmp_path / "missing.npz", **{"multibounce.value": None})
    with pytest.raises(ValueError, match="multibounce.value"):
        ml.DirectToIndirect.load(p, box)
    p = _rewrite(saved, tmp_path / "dtype.npz", **{"final_gather.value": np.zeros(3, np.int8)})
    with pytest.raises(TypeError, match="final_gather.value.*int8"):
        ml.DirectToIndirect.load(p, box)


def test_failed_save_leaves_no_file(rel, saved, tmp_path, monkeypatch):
    with pytest.raises(FileNotFoundError):
        rel.save(tmp_path / "no-such-folder" / "x.npz")
    blocker = tmp_path / "a-file"
    blocker.write_text("x")
    with pytest.raises(OSError):
        rel.save(blocker / "x.npz")
    # An interruption in the middle of writing: the destination keeps its old content, no temporary remains.
    dest = tmp_path / "dest.npz"
    dest.write_bytes(b"old")
    real = np.savez

    def interrupted(f, **arrays):
        real(f, **dict(list(arrays.items())[:5]))
        raise KeyboardInterrupt

    monkeypatch.setattr(relight_store.np, "savez", interrupted)
    with pytest.raises(KeyboardInterrupt):
        rel.save(dest)
    assert dest.read_bytes() == b"old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a-file", "dest.npz"]
    # A failing rename (e.g. the destination is a folder) too.
    monkeypatch.setattr(relight_store.np, "savez", real)
    (tmp_path / "folder.npz").mkdir()
    with pytest.raises(OSError):
        rel.save(tmp_path / "folder.npz")
    assert not [p for p in tmp_path.iterdir() if p.name.endswith(".tmp")]
    # And a good save over an existing file replaces it whole.
    rel.save(dest)
    assert zipfile.is_zipfile(dest) and ml.DirectToIndirect.load(dest, rel.scene).stats["links"] == rel.stats["links"]
    with pytest.raises(TypeError):
        rel.save(3)


def test_scene_hash_ignores_file_location_and_ids(box, tmp_path):
    text = BOX.read_text().replace('id="tallbox"', 'id="box2"')
    p = tmp_path / "sub" / "moved.xml"
    p.parent.mkdir()
    p.write_text("<!-- moved -->\n" + text)
    assert relight_store.scene_hash(ml.load_scene(p)) == relight_store.scene_hash(box)
    assert set(relight_store.scene_hash(box)) == {"geometry", "materials", "camera", "film"}
    with pytest.raises(TypeError):
        relight_store.scene_hash("scene.xml")


def test_nan_lights_never_reach_relight(box, rel, tmp_path):
    """Lights with a NaN intensity are refused on every way in: the scene file, LightSet.from_arrays, the
    CLI's light specs (and relight checks again in Rust: relight::relight::tests)."""
    p = _variant(tmp_path, "nan", '<rgb name="intensity" value="3, 3, 2.5"/>', '<rgb name="intensity" value="nan, 3, 2.5"/>')
    with pytest.raises(ml.SceneError, match=r"nan\.xml:\d+: emitter \"spot\": intensity must be finite"):
        ml.scene_lights(ml.load_scene(p))
    with pytest.raises(ValueError, match="intensity"):
        ml.LightSet.from_arrays(box, kind=1, position=[[0, 0.9, 0]], direction=[[0, -1, 0]],
                                intensity=[[float("nan"), 1, 1]], cutoff_angle=0.5, beam_width=0.3)
    from manylights.cli import relight as relight_cli

    with pytest.raises(ValueError, match="finite"):
        relight_cli.placement(box, [{"type": "point", "pos": [0, 0, 0], "intensity": float("nan")}])
    with pytest.raises(ValueError, match="empty"):
        rel.relight(ml.scene_lights(box)[0:0])


def test_glossy_and_photon_matrices_round_trip(tmp_path):
    """The glossy F_g rows with their k_g and the photon-mapped M (3 channels) travel with the file."""
    scene = ml.load_scene(Path(__file__).parents[1] / "data" / "relight_glossy_box.xml", res=16)
    rel = ml.DirectToIndirect(scene, gather=4**4, final_gather_coefficients=32, bounces=3, multibounce="photons",
                              photons_per_sample=8, photon_neighbours=32)
    assert rel.stats["glossy_pixels"] > 0 and rel.stats["photons"] > 0
    rel.save(tmp_path / "glossy.npz")
    loaded = ml.DirectToIndirect.load(tmp_path / "glossy.npz", scene)
    lights = ml.scene_lights(scene)
    for eps in (0.0, 1e-3):
        assert np.array_equal(loaded.relight(lights, epsilon=eps), rel.relight(lights, epsilon=eps))
    for k in ("glossy_pixels", "glossy_coefficients_kept", "photons", "multibounce", "multibounce_coefficients_kept"):
        assert loaded.stats[k] == rel.stats[k], k
    # Without F_g the image differs: the glossy rows really are in the file.
    off = ml.DirectToIndirect(scene, gather=4**4, final_gather_coefficients=32, bounces=3, multibounce="photons",
                              photons_per_sample=8, photon_neighbours=32, glossy=False)
    assert ml.relative_l2(off.relight(lights), rel.relight(lights)) > 0.01
