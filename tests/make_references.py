"""Render the stored Mitsuba references under tests/references/ (run once; the tests read the results).

Each reference is a pixel-centre render (camera rays through pixel centres, everything after them random)
with Mitsuba 3.9.1's ``path`` integrator (``volpath`` for those in ``INTEGRATORS``), accumulated until the
estimated relative L2 noise of the mean, sqrt(sum var) / ||mean||, is below the target -- at least 4x below
the tolerance the tests apply to it.
Next to each ``<name>.exr`` go ``<name>.var.exr`` (variance of the mean per pixel) and ``<name>.json``
(Mitsuba version, variant, spp, seed, noise, scene hash, parameters, edits).

    .venv/bin/python tests/make_references.py            # all missing references
    .venv/bin/python tests/make_references.py --force cbox-direct
"""
from __future__ import annotations

import argparse
import hashlib
import json
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import manylights as ml  # noqa: E402
from conftest import REPO, SCENES, TEST_SCENES  # noqa: E402
from manylights.testing import mitsuba as reference  # noqa: E402

OUT = HERE / "references"

# name -> (scene xml, loader params, film size (W, H), max_depth, target relative noise, scene edit)
# Edits: "no-smooth-specular" sets specular_reflectance=0 on smooth plastics (our lights cannot reach a
# delta lobe; the remaining diffuse part is exactly what both renderers compute). "blend-object" makes the
# matpreview object a blendbsdf, weight 0.5, of roughplastic (GGX alpha 0.15, the object's colour) and
# roughconductor (GGX alpha 0.02, Au).
REFERENCES = {
    "cbox-direct": (SCENES / "cbox" / "scene.xml", {"res": 128}, (128, 128), 2, 0.0075, None),
    "cbox-lights-direct": (SCENES / "cbox-lights" / "scene.xml", {"res": 128}, (128, 128), 2, 0.0075, None),
    "matpreview-direct": (TEST_SCENES / "matpreview" / "scene.xml", {"width": 128, "height": 96}, (128, 96), 2, 0.01,
                          "no-smooth-specular"),
    "bunny-direct": (TEST_SCENES / "bunny" / "scene.xml", {}, (128, 96), 2, 0.01, None),
    "cbox-gi": (SCENES / "cbox" / "scene.xml", {"res": 128}, (128, 128), -1, 0.02, None),
    "veach-ajar-gi": (SCENES / "veach-ajar" / "scene.xml", {"resx": 64, "resy": 36}, (64, 36), -1, 0.05, None),
    # VSLs and bias compensation: veach-ajar full GI at 32x18, its noise 3x below 5%.
    "veach-ajar-gi-32": (SCENES / "veach-ajar" / "scene.xml", {"resx": 32, "resy": 18}, (32, 18), -1, 0.0167, None),
    # CI-sized full GI (tests/lights/test_lights.py: error vs indirect light count).
    "cbox-gi-64": (SCENES / "cbox" / "scene.xml", {"res": 64}, (64, 64), -1, 0.002, None),
    # Near field (tests/lights/test_nearfield.py): an emitting panel 5 mm above a floor, direct light. The
    # target is over the whole image (the panel itself is exact and bright); the floor's own noise, which
    # the test checks against its tolerance, is ~8x the whole image's.
    "nearfield-panel-direct": (HERE / "data" / "nearfield_panel.xml", {"res": 64}, (64, 64), 2, 0.0004, None),
    # tests/lights/test_twosided.py: the same panel 1 mm above a twosided diffuse floor whose triangles face away from
    # the camera and the light (lit and seen from its back). The target is over the whole image (the panel
    # dominates its norm); the floor's own noise, which the test checks, is ~7x the whole image's.
    "twosided-wall-direct": (HERE / "data" / "twosided_wall.xml", {"res": 64}, (64, 64), 2, 0.0003, None),
    # Near field, acceptance (tests/lights/test_nearfield.py): 13 small recessed area lights beside a staircase, direct
    # light. The emitters seen directly (radiance 40, exact) dominate the image's norm; the target makes the
    # noise on the lit surfaces, which the test checks, ~0.5%.
    "staircase-direct": (HERE / "data" / "staircase_recessed.xml", {"res": 64}, (64, 64), 2, 0.00002, None),
    # Glossy highlights (tests/lights/test_glossy.py): Veach's plates, sphere lights on rough plastic (alpha 0.005-0.1),
    # direct light. The spheres seen directly (exact) dominate the norm; the target makes the plates' own
    # noise, which the test checks, about 0.3%.
    "veach-plates-direct": (HERE / "data" / "veach_plates.xml", {"width": 64, "height": 48}, (64, 48), 2, 0.0003,
                            None),
    # The same plates under an environment map with a bright band (glossy MIS against environment strata).
    "veach-plates-env-direct": (HERE / "data" / "veach_plates_env.xml", {"width": 64, "height": 48}, (64, 48), 2, 0.002,
                                None),
    # Glossy MIS on blended BSDFs (tests/lights/test_glossy.py): the env-lit plates as blends of a rough lobe and a
    # near-specular rough conductor (alpha 0.02-0.05).
    "glossy-blend-direct": (HERE / "data" / "glossy_blend.xml", {"width": 64, "height": 48}, (64, 48), 2, 0.003, None),
    # The same plates as principled BSDFs (glossy MIS on principled's specular lobe).
    "glossy-principled-direct": (HERE / "data" / "glossy_principled.xml", {"width": 64, "height": 48}, (64, 48), 2, 0.003,
                                 None),
    # matpreview's object as a blend of rough plastic and a near-specular gold (glossy MIS on blends).
    "matpreview-blend-direct": (TEST_SCENES / "matpreview" / "scene.xml", {"width": 64, "height": 48}, (64, 48), 2, 0.004,
                                "blend-object"),
    # Area-light strata (for the strata tests to come), direct light: a 6.5 x 5.1 m emitting wall whose top edge
    # meets the ceiling at a right angle (the emitter's pixels, exact in both, are part of the norm), and two
    # 1:50 strips, one touching the floor, one 2 cm above it.
    "wall-corner-direct": (HERE / "data" / "wall_emitter_corner.xml", {"res": 64}, (64, 64), 2, 0.0008, None),
    "strip-lights-direct": (HERE / "data" / "strip_lights.xml", {"res": 64}, (64, 64), 2, 0.0015, None),
    # A disk light in a ceiling recess (tests/lights/test_nearfield.py): the recess walls in its near field,
    # the room lit through the opening. The emitter (radiance 30, exact) dominates the norm: the target makes
    # the lit surfaces' own noise ~0.5%.
    "disk-recess-direct": (HERE / "data" / "disk_recess.xml", {"res": 64}, (64, 64), 2, 0.00015, None),
    # Calibration of ``render(target_error=e)`` (``python -m manylights.bench targets``): the case at >= 256^2,
    # the 13-light staircase with its indirect light, and a room lit through a window by an environment map
    # (256 x 144, direct light, most of it from a small bright region of the sky).
    "cbox-gi-256": (SCENES / "cbox" / "scene.xml", {"res": 256}, (256, 256), -1, 0.004, None),
    "staircase-gi-64": (HERE / "data" / "staircase_recessed.xml", {"res": 64}, (64, 64), -1, 0.002, None),
    "window-room-direct": (SCENES / "window-room" / "scene.xml", {"resx": 256, "resy": 144}, (256, 144), 2, 0.01,
                           None),
    # matpreview with its full smooth plastic (specular coat reached by delta chains), small.
    "matpreview-full-direct": (TEST_SCENES / "matpreview" / "scene.xml", {"width": 64, "height": 48}, (64, 48), 2, 0.005,
                               None),
    # A glass sphere with an absorbing coloured interior (homogeneous medium, albedo 0) over a floor, point light,
    # under volpath with max_depth 4: the floor seen through the glass gets direct light (tests/scene/test_media.py).
    "glass-medium-direct": (HERE / "data" / "glass_medium.xml", {"width": 64, "height": 48}, (64, 48), 4, 0.002, None),
    # Bump and normal maps (tests/scene/test_perturb.py), direct light: a floor and a sphere under two point
    # lights, with Mitsuba's ``bumpmap`` (height textures/bump_ripples.png; the floor's wrapper declared at the top
    # level and referenced) and ``normalmap`` (textures/normal_waves.png; the floor's inside a twosided), 64 x 48.
    # Point lights at pixel centres: Mitsuba's estimate is deterministic (noise 0 after the first batch).
    "bumpmap-direct": (HERE / "data" / "bumpmap_ripples.xml", {"width": 64, "height": 48}, (64, 48), 2, 0.002, None),
    "normalmap-direct": (HERE / "data" / "normalmap_waves.xml", {"width": 64, "height": 48}, (64, 48), 2, 0.002, None),
    # roughdielectric and thindielectric (tests/scene/test_dielectric.py), direct light: rough glass panes lit
    # through reflection and transmission by two point lights, an area light seen only through a thin pane.
    "rough-glass-direct": (HERE / "data" / "rough_glass.xml", {"width": 64, "height": 48}, (64, 48), 2, 0.004, None),
    # Masked surfaces (tests/scene/test_mask.py): two `mask` quads (opacity 0.5 and a checkerboard 0.1 / 0.85)
    # over a floor under a small area light, 64 x 48. max_depth -1: the floor through the quads and their
    # shadows at (1 - opacity) (no indirect light exists in this scene); max_depth 2 and 3: Mitsuba's depth
    # accounting of null events and its `valid_ray` rule.
    "mask-leaves": (HERE / "data" / "mask_leaves.xml", {"width": 64, "height": 48}, (64, 48), -1, 0.004, None),
    "mask-leaves-depth2": (HERE / "data" / "mask_leaves.xml", {"width": 64, "height": 48}, (64, 48), 2, 0.002, None),
    "mask-leaves-depth3": (HERE / "data" / "mask_leaves.xml", {"width": 64, "height": 48}, (64, 48), 3, 0.004, None),
    # A public interior (tests/scene/test_public_living_room.py): Bitterli's "The Grey & White Room" (CC-BY,
    # tests/data/scenes/living-room/LICENSE.txt), lit only through its windows by an environment map, with
    # masked leaves, glass, rough plastics and conductors; a version 0.5 file. Direct light at 96 x 54.
    "living-room-direct": (TEST_SCENES / "living-room" / "scene.xml", {}, (96, 54), 2, 0.0012, None),
    # A mask around delta BSDFs (tests/scene/test_mask.py): a half-opaque gold mirror facing the camera (the lit floor
    # seen in it and through it; the light behind its plane, so no caustic) and a checkerboard-masked smooth plastic
    # quad over the floor, 64 x 48, max_depth -1.
    "mask-delta": (HERE / "data" / "mask_delta.xml", {"width": 64, "height": 48}, (64, 48), -1, 0.004, None),
    # A mask around a smooth glass sphere over a floor under a point light (no caustic), 48 x 36, max_depth -1;
    # with opacity 1 (the glass alone) for the delta chains' own deviation on it.
    "mask-glass": (HERE / "data" / "mask_glass.xml", {"width": 48, "height": 36}, (48, 36), -1, 0.002, None),
    "mask-glass-opaque": (HERE / "data" / "mask_glass.xml", {"width": 48, "height": 36, "opacity": 1.0}, (48, 36), -1,
                          0.002, None),
}

# Integrator of the references that do not use ``path`` (with the max_depth above).
INTEGRATORS = {"glass-medium-direct": "volpath"}


def scene_hash(xml: Path) -> str:
    """sha256 over the XML and every file in its folder (meshes, textures), in sorted order."""
    h = hashlib.sha256()
    for f in sorted(p for p in xml.parent.rglob("*") if p.is_file()):
        h.update(f.relative_to(xml.parent).as_posix().encode())
        h.update(f.read_bytes())
    return h.hexdigest()


def edited(xml: Path, edit, tmp: Path) -> Path:
    if edit is None:
        return xml
    if edit == "no-smooth-specular":
        import xml.etree.ElementTree as ET

        out = reference.scene_variant(xml, tmp, remove_area_emitters=False)
        tree = ET.parse(out)
        for b in tree.getroot().iter("bsdf"):
            if b.get("type") == "plastic":
                for c in [c for c in b if c.get("name") == "specular_reflectance"]:
                    b.remove(c)
                ET.SubElement(b, "float", {"name": "specular_reflectance", "value": "0"})
        tree.write(out)
        return out
    if edit == "blend-object":
        import xml.etree.ElementTree as ET

        out = reference.scene_variant(xml, tmp, remove_area_emitters=False)
        tree = ET.parse(out)
        for b in tree.getroot().iter("bsdf"):
            if b.get("id") == "bsdf-matpreview":
                b.clear()
                b.attrib.update({"type": "blendbsdf", "id": "bsdf-matpreview"})
                ET.SubElement(b, "float", {"name": "weight", "value": "0.5"})
                rp = ET.SubElement(b, "bsdf", {"type": "roughplastic"})
                ET.SubElement(rp, "string", {"name": "distribution", "value": "ggx"})
                ET.SubElement(rp, "float", {"name": "alpha", "value": "0.15"})
                ET.SubElement(rp, "rgb", {"name": "diffuse_reflectance", "value": "0.940, 0.271, 0.361"})
                rc = ET.SubElement(b, "bsdf", {"type": "roughconductor"})
                ET.SubElement(rc, "string", {"name": "distribution", "value": "ggx"})
                ET.SubElement(rc, "float", {"name": "alpha", "value": "0.02"})
                ET.SubElement(rc, "string", {"name": "material", "value": "Au"})
        tree.write(out)
        return out
    raise ValueError(edit)


def render(name: str, max_seconds: float, seed: int = 0) -> dict:
    import tempfile

    import mitsuba as mi

    xml, params, size, max_depth, target, edit = REFERENCES[name]
    tmp = Path(tempfile.mkdtemp(prefix="ml-ref-"))
    path = edited(xml, edit, tmp)
    total = np.zeros((size[1], size[0], 3), np.float64)
    total2 = np.zeros_like(total)
    spp, batch, t0 = 0, 64, time.perf_counter()
    noise = float("inf")
    while noise > target and time.perf_counter() - t0 < max_seconds:
        mean, var = reference.mitsuba_render(path, size, max_depth=max_depth, spp=batch, seed=seed * 7919 + spp,
                                             batch=16, integrator=INTEGRATORS.get(name, "path"), **params)
        # Merge batch statistics: sums of samples and of squares.
        total += mean.astype(np.float64) * batch
        total2 += (var.astype(np.float64) * max(batch - 1, 1) + mean.astype(np.float64) ** 2) * batch
        spp += batch
        m = total / spp
        v = np.maximum(total2 / spp - m * m, 0) / max(spp - 1, 1)
        noise = float(np.sqrt(v.sum()) / np.linalg.norm(m))
        print(f"{name}: {spp} spp, noise {noise:.4%} (target {target:.2%}), {time.perf_counter() - t0:.0f} s",
              flush=True)
        batch = min(batch * 2, 1024)
    OUT.mkdir(exist_ok=True)
    ml.write_exr(OUT / f"{name}.exr", m.astype(np.float32))
    ml.write_exr(OUT / f"{name}.var.exr", v.astype(np.float32))
    meta = {
        "scene": str(xml.relative_to(REPO)),
        "scene_sha256": scene_hash(xml),
        "params": params,
        "size": list(size),
        "integrator": {"type": INTEGRATORS.get(name, "path"), "max_depth": max_depth},
        "edit": edit,
        "footprint": "pixel centre (camera ray through the pixel centre, all else random)",
        "spp": spp,
        "seed": seed,
        "relative_noise": noise,
        "target_noise": target,
        "mitsuba": mi.__version__,
        "variant": mi.variant(),
        "seconds": round(time.perf_counter() - t0, 1),
    }
    (OUT / f"{name}.json").write_text(json.dumps(meta, indent=2) + "\n")
    return meta


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("names", nargs="*", help=f"subset of {list(REFERENCES)}")
    ap.add_argument("--force", action="store_true", help="re-render existing references")
    ap.add_argument("--max-seconds", type=float, default=900.0)
    a = ap.parse_args(argv)
    reference.mitsuba()
    for name in a.names or list(REFERENCES):
        if (OUT / f"{name}.json").exists() and not a.force:
            print(f"{name}: exists")
            continue
        meta = render(name, a.max_seconds)
        print(json.dumps(meta))


if __name__ == "__main__":
    main()
