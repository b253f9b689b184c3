"""Public Mitsuba scenes (not written for this project) against Mitsuba 3.9.1: direct light, pixel-centre.

The scenes are not bundled (too large, or no licence file), except a smaller copy of the living room that the
tests render (``bundle``, ``tests/scene/test_public_living_room.py``): fetch the two repositories at the commits
below into one folder, as ``<root>/<owner>+<name>/`` working trees, then

    .venv/bin/python tests/public_scenes.py --root <root> edit         # scene_edited.xml next to each scene
    .venv/bin/python tests/public_scenes.py --root <root> reference    # Mitsuba references under <root>/refs
    .venv/bin/python tests/public_scenes.py --root <root> compare      # manylights against them, one JSON line each
    .venv/bin/python tests/public_scenes.py --root <root> bundle       # the small copies in tests/data/scenes

Edits (the same edited XML goes to both renderers): shapes whose mesh file the repository lacks (Git LFS
objects that are not in it) are removed, a missing bitmap becomes a constant 0.5 reflectance, and the film's
``high_quality_edges`` is dropped (Mitsuba 3.9.1 refuses it as an unreferenced property, and so do we).
References follow ``tests/make_references.py``: ``path`` with max_depth 2, camera rays through pixel centres,
batches of independent seeds until the time limit, variance of the mean per pixel. The film size is given to
both renderers (``size=``); the XML's own film keeps its aspect ratio.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

import manylights as ml

BITTERLI = ("jgarciapueyo+mitsuba2-transient-scenes", "ab67c4caa9228aa9d4115aeb90c3d3bab0aaf7b5")
MITSUBA_DATA = ("mitsuba-renderer+mitsuba-data", "01100fa9b0b154492061a92404f26dcd7b784dbb")

# name -> (repository, scene path in it, film size (W, H), generate_lights arguments, reference seconds)
SCENES = {
    "bitterli-living-room": (BITTERLI, "living-room/scene.xml", (96, 54), {"area": 0, "environment": 131072}, 240),
    "bitterli-bathroom2": (BITTERLI, "bathroom2/scene.xml", (96, 54), {"area": 4096}, 240),
    "bitterli-bathroom": (BITTERLI, "bathroom/scene.xml", (96, 54), {"area": 4096}, 240),
    "mitsuba-data-mask": (MITSUBA_DATA, "docs/scenes/bsdf_mask_after.xml", (96, 72),
                          {"area": 0, "environment": 16384}, 200),
    "mitsuba-data-bumpmap": (MITSUBA_DATA, "docs/scenes/bsdf_bumpmap_with.xml", (96, 72),
                             {"area": 0, "environment": 16384}, 200),
    "mitsuba-data-normalmap": (MITSUBA_DATA, "docs/scenes/bsdf_normalmap_with.xml", (96, 72),
                               {"area": 0, "environment": 16384}, 200),
    "mitsuba-data-roughdielectric": (MITSUBA_DATA, "docs/scenes/bsdf_roughdielectric_rough.xml", (96, 72),
                                     {"area": 0, "environment": 16384}, 200),
}
# Glossy MIS BSDF samples per view sample (LightMatrix's bsdf_samples) where the default 256 is too few: the
# living room's rough plastics (GGX alpha 0.05-0.2) reflect the sky through its windows.
BSDF_SAMPLES = {"bitterli-living-room": 4096}
MAX_DEPTH = 2


def scene_xml(root: Path, name: str) -> Path:
    (repo, _), rel, *_ = SCENES[name]
    return root / repo / rel


def edited_xml(root: Path, name: str) -> Path:
    xml = scene_xml(root, name)
    return xml.with_name(xml.stem + "_edited.xml")


def edit(root: Path, name: str) -> dict:
    """Write ``<scene>_edited.xml``; returns what was changed."""
    xml = scene_xml(root, name)
    tree = ET.parse(xml)
    top = tree.getroot()
    removed, constant, dropped = [], [], []

    def resolve(value):
        return any((d / value).exists() for d in [xml.parent, xml.parent / "../../common"])

    for shape in list(top.iter("shape")):
        for s in shape.findall("string"):
            if s.get("name") == "filename" and not resolve(s.get("value")):
                top.remove(shape)
                removed.append(s.get("value"))
    for parent in top.iter():
        for i, t in enumerate(list(parent)):
            if t.tag == "texture" and t.get("type") == "bitmap":
                fn = [s.get("value") for s in t.findall("string") if s.get("name") == "filename"][0]
                if not resolve(fn):
                    parent.remove(t)
                    parent.insert(i, ET.Element("rgb", {"name": t.get("name"), "value": "0.5, 0.5, 0.5"}))
                    constant.append(fn)
    for film in top.iter("film"):
        for b in list(film):
            if b.get("name") in ("highQualityEdges", "high_quality_edges"):
                film.remove(b)
                dropped.append(b.get("name"))
    tree.write(edited_xml(root, name))
    return {"scene": name, "removed_shapes": removed, "constant_textures": constant, "dropped": dropped}


BUNDLED = {"bitterli-living-room": "living-room"}
# Texture downsampling of the bundled copy: the environment map by 8 (block means keep its integral), the
# colour textures by 4.
ENV_DOWNSAMPLE, TEXTURE_DOWNSAMPLE = 8, 4


def _write_ply(path: Path, positions, normals, uvs, faces) -> None:
    """Binary little-endian PLY: float32 x y z (nx ny nz) (u v) per vertex, uchar + 3 uint32 per face."""
    props = ["x", "y", "z"] + (["nx", "ny", "nz"] if normals is not None else []) + (["u", "v"] if uvs is not None else [])
    vert = np.concatenate([a for a in (positions, normals, uvs) if a is not None], axis=1).astype("<f4")
    face = np.zeros(len(faces), dtype=[("n", "u1"), ("i", "<u4", 3)])
    face["n"], face["i"] = 3, faces
    head = ["ply", "format binary_little_endian 1.0", f"element vertex {len(vert)}",
            *[f"property float {p}" for p in props], f"element face {len(faces)}",
            "property list uchar uint vertex_indices", "end_header"]
    path.write_bytes(("\n".join(head) + "\n").encode() + vert.tobytes() + face.tobytes())


def bundle(root: Path, name: str, dest: Path) -> dict:
    """A small copy of a public scene for ``tests/data/scenes/<dest>``: the edited XML; every OBJ mesh as the
    binary PLY of the mesh Mitsuba loads from it (the same vertices, normals, and texture coordinates where its
    BSDF has a bitmap; Mitsuba's OBJ reader flips v, so the PLY stores the flipped value); the environment map
    and colour textures block-averaged; opacity (mask) textures as they are; and the scene's licence with a
    note of the changes. Needs Mitsuba."""
    import imageio.v3 as iio

    from manylights.testing import mitsuba as mitsuba_ref

    mi = mitsuba_ref.mitsuba()
    src = edited_xml(root, name)
    tree = ET.parse(src)
    top = tree.getroot()
    (dest / "models").mkdir(parents=True, exist_ok=True)
    (dest / "textures").mkdir(exist_ok=True)
    textured = {b.get("id") for b in top.findall("bsdf") if any(t.get("type") == "bitmap" for t in b.iter("texture"))}
    opacity = {s.get("value") for t in top.iter("texture") if t.get("name") == "opacity" for s in t.findall("string")}
    meshes = 0
    for shape in top.iter("shape"):
        if shape.get("type") != "obj":
            continue
        fn = [s for s in shape.findall("string") if s.get("name") == "filename"][0]
        out = Path(fn.get("value")).with_suffix(".ply")
        params = mi.traverse(mi.load_dict({"type": "obj", "filename": str(src.parent / fn.get("value"))}))
        keep_uv = any(r.get("id") in textured for r in shape.findall("ref"))
        arr = {k: np.asarray(params[f"vertex_{k}"]) for k in ("positions", "normals", "texcoords")}
        _write_ply(dest / out, arr["positions"].reshape(-1, 3),
                   arr["normals"].reshape(-1, 3) if arr["normals"].size else None,
                   arr["texcoords"].reshape(-1, 2) if keep_uv and arr["texcoords"].size else None,
                   np.asarray(params["faces"]).reshape(-1, 3))
        shape.set("type", "ply")
        fn.set("value", out.as_posix())
        meshes += 1
    textures = {}
    for s in top.iter("string"):
        value = s.get("value", "")
        if s.get("name") != "filename" or not value.startswith("textures/") or value in textures:
            continue
        target = dest / value
        if value in opacity:
            target.write_bytes((src.parent / value).read_bytes())
        elif value.endswith(".exr"):
            a = ml.read_exr(src.parent / value)[..., :3]
            k = ENV_DOWNSAMPLE
            a = a[: a.shape[0] // k * k, : a.shape[1] // k * k].reshape(a.shape[0] // k, k, a.shape[1] // k, k, 3)
            ml.write_exr(target, a.mean(axis=(1, 3)))
        else:
            img = iio.imread(src.parent / value).astype(np.float64)
            k = TEXTURE_DOWNSAMPLE
            h, w = img.shape[0] // k * k, img.shape[1] // k * k
            img = img[:h, :w].reshape(h // k, k, w // k, k, -1).mean(axis=(1, 3))
            iio.imwrite(target, np.clip(img + 0.5, 0, 255).astype(np.uint8), quality=90)
        textures[value] = target.stat().st_size
    tree.write(dest / "scene.xml")
    licence = (src.parent / "LICENSE.txt").read_text()
    (dest / "LICENSE.txt").write_text(
        licence.rstrip() + "\n\nChanges in this copy (made by tests/public_scenes.py, `bundle`, from the Mitsuba "
        "conversion at https://github.com/jgarciapueyo/mitsuba2-transient-scenes): the meshes are stored as binary "
        "PLY (texture coordinates kept only where the material has a texture); the environment map is block-"
        f"averaged by {ENV_DOWNSAMPLE} and the colour textures by {TEXTURE_DOWNSAMPLE} in each direction; the "
        "film's high-quality-edges flag is dropped.\n")
    (repo, commit), rel, *_ = SCENES[name]
    (dest / "SOURCE.txt").write_text(
        f"Source: github.com/{repo.replace('+', '/')} @ {commit}: {rel} and the meshes and textures it names, made\n"
        "smaller by tests/public_scenes.py (`bundle`; the changes are listed in LICENSE.txt). Licence: as the\n"
        "original scene's, in LICENSE.txt here. Test data only, not part of the package.\n")
    return {"scene": name, "dest": str(dest), "meshes": meshes, "textures": textures,
            "bytes": sum(f.stat().st_size for f in dest.rglob("*") if f.is_file())}


def reference(root: Path, name: str, out: Path, seconds: float) -> dict:
    from manylights.testing import mitsuba as mitsuba_ref

    mi = mitsuba_ref.mitsuba()
    size = SCENES[name][2]
    total = np.zeros((size[1], size[0], 3))
    total2 = np.zeros_like(total)
    spp, batch, t0 = 0, 64, time.perf_counter()
    while time.perf_counter() - t0 < seconds:
        mean, var = mitsuba_ref.mitsuba_render(edited_xml(root, name), size, max_depth=MAX_DEPTH, spp=batch,
                                               seed=spp, batch=16)
        total += mean.astype(np.float64) * batch
        total2 += (var.astype(np.float64) * max(batch - 1, 1) + mean.astype(np.float64) ** 2) * batch
        spp += batch
        batch = min(batch * 2, 1024)
    m = total / spp
    v = np.maximum(total2 / spp - m * m, 0) / max(spp - 1, 1)
    out.mkdir(parents=True, exist_ok=True)
    ml.write_exr(out / f"{name}.exr", m.astype(np.float32))
    ml.write_exr(out / f"{name}.var.exr", v.astype(np.float32))
    meta = {"scene": name, "size": list(size), "spp": spp, "max_depth": MAX_DEPTH,
            "relative_noise": float(np.sqrt(v.sum()) / np.linalg.norm(m)), "mitsuba": mi.__version__,
            "variant": mi.variant(), "seconds": round(time.perf_counter() - t0, 1)}
    (out / f"{name}.json").write_text(json.dumps(meta) + "\n")
    return meta


def compare(root: Path, name: str, out: Path, bsdf_samples=None, **overrides) -> dict:
    """Brute force (``column_sum() + emitted()``, CPU, max_depth 2) against the stored reference: relative L2
    and the reference's relative noise over the whole image and over the pixels whose reference has variance
    (``sampled``: lit by sampled light; the others see only emitters, exact in both), and the share of the
    squared error in the 20 worst pixels."""
    ref, var = ml.read_exr(out / f"{name}.exr"), ml.read_exr(out / f"{name}.var.exr")
    size, kw = SCENES[name][2], dict(SCENES[name][3], **overrides)
    bsdf_samples = bsdf_samples or BSDF_SAMPLES.get(name, 256)
    t0 = time.perf_counter()
    scene = ml.load_scene(edited_xml(root, name), size=size)
    lights = ml.generate_lights(scene, seed=0, **kw)
    A = ml.LightMatrix(scene, lights, device="cpu", max_depth=MAX_DEPTH, bsdf_samples=bsdf_samples)
    em = np.asarray(A.emitted())
    img = np.asarray(A.column_sum(progress=False)) + em
    res = {"scene": name, "lights": kw, "bsdf_samples": bsdf_samples, "bsdfs": sorted({b["type"] for b in scene.bsdfs}),
           "seconds": round(time.perf_counter() - t0, 1)}
    np.save(out / f"{name}.manylights.npy", img)
    sq = ((img - ref) ** 2).sum(axis=2)
    res["worst20_share"] = float(np.sort(sq.ravel())[-20:].sum() / sq.sum())
    for key, sel in [("image", np.ones(ref.shape[:2], bool)), ("sampled", var.max(axis=2) > 0)]:
        den = (ref[sel] ** 2).sum()
        err = float(np.sqrt(((img[sel] - ref[sel]) ** 2).sum() / den))
        noise = float(np.sqrt(var[sel].sum() / den))
        res[key] = {"pixels": int(sel.sum()), "relative_l2": err, "noise": noise, "ratio": err / noise}
    return res


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("step", choices=["edit", "reference", "compare", "bundle"])
    ap.add_argument("names", nargs="*", help=f"subset of {list(SCENES)}")
    ap.add_argument("--root", type=Path, required=True, help="folder holding the fetched repositories")
    ap.add_argument("--out", type=Path, help="references folder (default <root>/refs)")
    ap.add_argument("--environment", type=int, help="override the environment light count")
    ap.add_argument("--bsdf-samples", type=int, help="glossy MIS BSDF samples per view sample")
    ap.add_argument("--env-visibility", action="store_true",
                    help="environment strata allocated by visibility (generate_lights(env_visibility=True))")
    a = ap.parse_args(argv)
    out = a.out or a.root / "refs"
    for name in a.names or list(BUNDLED if a.step == "bundle" else SCENES):
        if a.step == "bundle":
            res = bundle(a.root, name, Path(__file__).resolve().parent / "data" / "scenes" / BUNDLED[name])
        elif a.step == "edit":
            res = edit(a.root, name)
        elif a.step == "reference":
            res = reference(a.root, name, out, SCENES[name][4])
        else:
            over = {} if a.environment is None else {"environment": a.environment}
            if a.env_visibility:
                over["env_visibility"] = True
            res = compare(a.root, name, out, a.bsdf_samples, **over)
        print(json.dumps(res), flush=True)


if __name__ == "__main__":
    sys.exit(main())
