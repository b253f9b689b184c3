"""The bad-input corpus: malformed arguments for every public function of manylights
and truncated / foreign files for every file reader. Each case must raise a Python ``Exception`` of the
listed kinds whose message names the problem; a pyo3 ``PanicException`` (a ``BaseException``), an
abort, a hang or a return counts as a failure.

Run by ``tests/robustness/test_bad_input.py`` in a child process (``python tests/robustness/bad_input_corpus.py OUT_DIR``)
that reports one JSON line per case as it goes, so that an abort or a hang is pinned to its case and
the remaining cases run in a fresh child.
"""
from __future__ import annotations

import json
import os
import struct
import sys
import traceback
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

REPO = Path(__file__).resolve().parents[2]


@dataclass
class Case:
    id: str
    target: str                      # the public function it covers, e.g. "load_scene", "LightMatrix.rows"
    fn: Callable                     # fn(ctx) -> anything; must raise
    raises: tuple = ("ValueError",)  # accepted exception class names (subclasses count)
    match: tuple = ()                # each must appear (case-insensitively) in the message
    subprocess: bool = False         # run alone in its own child (environment-changing cases)


CASES: list[Case] = []


def case(id, target, raises=("ValueError",), match=(), subprocess=False):
    def deco(fn):
        CASES.append(Case(id, target, fn, tuple(raises), tuple(match), subprocess))
        return fn
    return deco


def cases_for(target, items, raises=("ValueError",), subprocess=False):
    """Register one case per (id suffix, callable, match) item for ``target``."""
    for suffix, fn, match in items:
        CASES.append(Case(f"{target}:{suffix}", target, fn, tuple(raises), tuple(match), subprocess))


# --------------------------------------------------------------------------------------------------
# Context: a tiny scene, its lights and light matrix, and a folder of good and bad files.

class Ctx:
    def __init__(self, tmp: Path):
        self.tmp = tmp
        self._cache = {}

    def _get(self, name, make):
        if name not in self._cache:
            self._cache[name] = make()
        return self._cache[name]

    @property
    def ml(self):
        import manylights
        return manylights

    @property
    def native(self):
        from manylights import _native
        return _native

    @property
    def scene(self):
        return self._get("scene", lambda: self.ml.load_scene(REPO / "scenes" / "demo" / "scene.xml", res=8))

    @property
    def lights(self):
        return self._get("lights", lambda: self.ml.generate_lights(self.scene, area=4, seed=0))

    @property
    def A(self):
        return self._get("A", lambda: self.ml.LightMatrix(self.scene, self.lights, shadow_map_size=16))

    @property
    def n(self):
        return self.A.shape[1]

    @property
    def m(self):
        return self.A.shape[0]

    def file(self, name: str, data: bytes) -> Path:
        p = self.tmp / name
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_bytes(data)
        return p

    # good files to truncate or rename
    @property
    def png_bytes(self) -> bytes:
        def make():
            p = self.tmp / "good.png"
            self.ml.write_png(p, np.full((4, 4, 3), 0.5, np.float32))
            return p.read_bytes()
        return self._get("png", make)

    @property
    def exr_bytes(self) -> bytes:
        def make():
            p = self.tmp / "good.exr"
            self.ml.write_exr(p, np.full((4, 8, 3), 0.5, np.float32))
            return p.read_bytes()
        return self._get("exr", make)

    @property
    def jpg_bytes(self) -> bytes:
        return (REPO / "scenes" / "veach-ajar" / "textures" / "landscape-with-a-lake.jpg").read_bytes()

    def scene_with(self, name: str, body: str, files: dict[str, bytes] | None = None) -> Path:
        """A tiny scene XML (8x8 film, a point light) with ``body`` inside <scene>, beside ``files``."""
        d = self.tmp / name
        d.mkdir(parents=True, exist_ok=True)
        for fname, data in (files or {}).items():
            (d / fname).write_bytes(data)
        xml = f"""<scene version="3.0.0">
    <sensor type="perspective">
        <float name="fov" value="45"/>
        <transform name="to_world"> <lookat origin="0, 0, 4" target="0, 0, 0" up="0, 1, 0"/> </transform>
        <film type="hdrfilm"> <integer name="width" value="8"/> <integer name="height" value="8"/> </film>
    </sensor>
    <emitter type="point"> <point name="position" x="0" y="0" z="3"/> <rgb name="intensity" value="1"/> </emitter>
    {body}
</scene>
"""
        p = d / "scene.xml"
        p.write_text(xml)
        return p


JUNK = bytes(range(256)) * 8 + b"\x00\xff" * 100
OBJ = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\n"


def ply_binary(nv_header: int, nf_header: int, nv_data: int, nf_data: int, face_index: int = 2) -> bytes:
    head = (f"ply\nformat binary_little_endian 1.0\nelement vertex {nv_header}\nproperty float x\nproperty float y\n"
            f"property float z\nelement face {nf_header}\nproperty list uchar int vertex_indices\nend_header\n").encode()
    verts = b"".join(struct.pack("<3f", float(i), float(i % 2), 0.0) for i in range(nv_data))
    faces = b"".join(struct.pack("<B3i", 3, 0, 1, face_index) for _ in range(nf_data))
    return head + verts + faces


def exr_window(exr: bytes, window: tuple[int, int, int, int]) -> bytes:
    """A valid EXR whose header's dataWindow (xmin, ymin, xmax, ymax) is replaced (the pixels stay 8x4)."""
    attr = b"dataWindow\x00box2i\x00"
    i = exr.index(attr) + len(attr) + 4
    return exr[:i] + struct.pack("<4i", *window) + exr[i + 16:]


def png_header_only(width: int, height: int) -> bytes:
    """A PNG signature + IHDR claiming width x height, and no image data."""
    ihdr = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    chunk = struct.pack(">I", len(ihdr)) + b"IHDR" + ihdr + struct.pack(">I", zlib.crc32(b"IHDR" + ihdr))
    return b"\x89PNG\r\n\x1a\n" + chunk


def bmp_declaring(width: int, height: int) -> bytes:
    """A 24-bit uncompressed BMP header declaring width x height, followed by 4 bytes of pixels."""
    return (b"BM" + struct.pack("<IHHI", 58, 0, 0, 54) + struct.pack("<IiiHHIIiiII", 40, width, height, 1, 24, 0, 0, 0, 0, 0, 0)
            + b"\x01\x02\x03\x00")


def tga_declaring(width: int, height: int) -> bytes:
    """An uncompressed 24-bit TGA header declaring width x height, followed by one pixel."""
    return bytes([0, 0, 2, 0, 0, 0, 0, 0]) + struct.pack("<HHHHBB", 0, 0, width, height, 24, 0x20) + b"\x01\x02\x03"


def jpeg_declaring(jpeg: bytes, width: int, height: int) -> bytes:
    """A JPEG whose frame header (the first SOFn segment) is changed to declare width x height."""
    i = 2
    while jpeg[i] == 0xFF and jpeg[i + 1] not in (0xC0, 0xC1, 0xC2):
        i += 2 + struct.unpack(">H", jpeg[i + 2:i + 4])[0]
    assert jpeg[i] == 0xFF, "no frame header"
    return jpeg[:i + 5] + struct.pack(">HH", height, width) + jpeg[i + 9:]


# --------------------------------------------------------------------------------------------------
# Scene files: the XML itself.

FILE_ERRORS = ("SceneError", "OSError", "ValueError")


cases_for("load_scene", [
    ("missing file", lambda c: c.ml.load_scene(c.tmp / "nope.xml"), ["nope.xml"]),
    ("a directory", lambda c: c.ml.load_scene(c.tmp), ["tmp"]),
    ("empty file", lambda c: c.ml.load_scene(c.file("empty/scene.xml", b"")), ["scene.xml"]),
    ("binary junk", lambda c: c.ml.load_scene(c.file("junk/scene.xml", JUNK)), ["scene.xml"]),
    ("PNG renamed .xml", lambda c: c.ml.load_scene(c.file("png/scene.xml", c.png_bytes)), ["scene.xml"]),
    ("XML cut in half", lambda c: c.ml.load_scene(c.file(
        "half/scene.xml", c.scene_with("full", "").read_bytes()[:300])), ["scene.xml"]),
    ("not a scene root", lambda c: c.ml.load_scene(c.file("root/scene.xml", b"<shape type='obj'/>")),
     ["scene.xml", "scene"]),
    ("UTF-16 text", lambda c: c.ml.load_scene(c.file("u16/scene.xml", c.scene_with("u8", "").read_text()
                                                          .encode("utf-16"))), ["scene.xml"]),
    ("bad parameter value", lambda c: c.ml.load_scene(REPO / "scenes" / "demo" / "scene.xml", res="abc"),
     ["abc", "scene.xml:15"]),
    ("negative resolution", lambda c: c.ml.load_scene(REPO / "scenes" / "demo" / "scene.xml", res=-8), ["-8"]),
    ("NaN parameter", lambda c: c.ml.load_scene(REPO / "scenes" / "demo" / "scene.xml", res=float("nan")),
     ["nan"]),
    ("size of zero", lambda c: c.ml.load_scene(REPO / "scenes" / "demo" / "scene.xml", size=(0, 8)), ["size"]),
    ("size of three", lambda c: c.ml.load_scene(REPO / "scenes" / "demo" / "scene.xml", size=(8, 8, 8)),
     ["size"]),
    ("fractional size", lambda c: c.ml.load_scene(REPO / "scenes" / "demo" / "scene.xml", size=(8.5, 8)),
     ["size"]),
    ("NaN size", lambda c: c.ml.load_scene(REPO / "scenes" / "demo" / "scene.xml", size=(float("nan"), 8)),
     ["size"]),
    # Mitsuba loads any film size; the G-buffer refuses sides over the device's limit (a GPU texture's
    # side, or 65536 for the CPU backend's ray-cast G-buffer).
    ("huge film", lambda c: c.ml.load_scene(REPO / "scenes" / "demo" / "scene.xml", size=(10**6, 10**6)).gbuffer(),
     ["1000000x1000000", "each side must be in 1..="]),
    ("huge film parameter", lambda c: c.ml.load_scene(REPO / "scenes" / "demo" / "scene.xml", res=10**7).gbuffer(),
     ["10000000", "each side must be in 1..="]),
    ("film width over u32", lambda c: c.ml.load_scene(REPO / "scenes" / "demo" / "scene.xml", res=2**40),
     ["1099511627776"]),
    ("include of a junk file", lambda c: c.ml.load_scene(c.scene_with(
        "inc", '<include filename="part.xml"/>', {"part.xml": JUNK})), ["part.xml"]),
    ("include of itself", lambda c: c.ml.load_scene(c.file(
        "self/scene.xml", b'<scene version="3.0.0"><include filename="scene.xml"/></scene>')), ["scene.xml"]),
    ("NaN in a transform", lambda c: c.ml.load_scene(c.scene_with(
        "nant", '<shape type="sphere"><transform name="to_world"><translate x="nan"/></transform></shape>')),
     ["nan"]),
    ("NaN sphere radius", lambda c: c.ml.load_scene(c.scene_with(
        "nanr", '<shape type="sphere"><float name="radius" value="nan"/></shape>')), ["nan", "scene.xml:8"]),
], raises=FILE_ERRORS + ("FileNotFoundError",))
_GLASS = '<shape type="sphere"><bsdf type="dielectric"/>{}</shape>'
cases_for("load_scene[medium]", [
    ("RGB sigma_t above 1", lambda c: c.ml.load_scene(c.scene_with("med-rgb", _GLASS.format(
        '<medium type="homogeneous" name="interior"><rgb name="sigma_t" value="0.5, 2, 0.5"/></medium>'))),
     ["scene.xml:8", "sigma_t", "in [0, 1]"]),
    ("NaN scale", lambda c: c.ml.load_scene(c.scene_with("med-nan", _GLASS.format(
        '<medium type="homogeneous" name="interior"><float name="scale" value="nan"/></medium>'))),
     ["scene.xml:8", "scale"]),
    ("unnamed medium", lambda c: c.ml.load_scene(c.scene_with("med-name", _GLASS.format(
        '<medium type="homogeneous"/>'))), ["scene.xml:8", "interior"]),
    ("heterogeneous medium", lambda c: c.ml.load_scene(c.scene_with("med-het", _GLASS.format(
        '<medium type="heterogeneous" name="interior"/>'))), ["scene.xml:8", "heterogeneous"]),
    ("medium refused on request", lambda c: c.ml.load_scene(c.scene_with("med-err", _GLASS.format(
        '<medium type="homogeneous" name="interior"/>')), media="error"), ["scene.xml:8", "medium"]),
    ("film gamma", lambda c: c.ml.load_scene(c.file("gamma/scene.xml", c.scene_with("gamma0", "<shape type='sphere'/>")
                                                    .read_text().replace('<film type="hdrfilm">',
                                                                         '<film type="hdrfilm"><float name="gamma" value="2.2"/>')
                                                    .encode())), ["scene.xml:5", "gamma"]),
    ("crop window outside the film", lambda c: c.ml.load_scene(c.file(
        "crop/scene.xml", c.scene_with("crop0", "<shape type='sphere'/>").read_text().replace(
            '<film type="hdrfilm">', '<film type="hdrfilm"><integer name="crop_width" value="9"/>').encode())),
     ["scene.xml:5", "invalid crop window"]),
], raises=("SceneError",))
_BUMP_TEX = '<texture type="bitmap"><string name="filename" value="h.png"/></texture>'
_NORMAL_TEX = '<texture name="normalmap" type="bitmap"><string name="filename" value="n.png"/>{}</texture>'
cases_for("load_scene[bumpmap]", [
    ("bumpmap without a texture", lambda c: c.ml.load_scene(c.scene_with("bump-notex", _GLASS.replace(
        '<bsdf type="dielectric"/>', '<bsdf type="bumpmap"><bsdf type="diffuse"/></bsdf>').format(""))),
     ["scene.xml:8", "bumpmap", "texture", "got none"]),
    ("bumpmap without a nested BSDF", lambda c: c.ml.load_scene(c.scene_with("bump-nobsdf", _GLASS.replace(
        '<bsdf type="dielectric"/>', f'<bsdf type="bumpmap">{_BUMP_TEX}</bsdf>').format(""), {"h.png": c.png_bytes})),
     ["scene.xml:8", "bumpmap", "nested BSDF", "got none"]),
    ("bumpmap over a checkerboard", lambda c: c.ml.load_scene(c.scene_with("bump-checker", _GLASS.replace(
        '<bsdf type="dielectric"/>', '<bsdf type="bumpmap"><texture type="checkerboard"/><bsdf type="diffuse"/></bsdf>')
        .format(""))), ["scene.xml:8", "bitmap", "checkerboard"]),
    ("bumpmap with a truncated texture", lambda c: c.ml.load_scene(c.scene_with("bump-trunc", _GLASS.replace(
        '<bsdf type="dielectric"/>', f'<bsdf type="bumpmap">{_BUMP_TEX}<bsdf type="diffuse"/></bsdf>').format(""),
        {"h.png": c.png_bytes[:40]})), ["h.png"]),
    ("normalmap not raw", lambda c: c.ml.load_scene(c.scene_with("normal-raw", _GLASS.replace(
        '<bsdf type="dielectric"/>', '<bsdf type="normalmap">' + _NORMAL_TEX.format('<boolean name="raw" value="false"/>')
        + '<bsdf type="diffuse"/></bsdf>').format(""), {"n.png": c.png_bytes})), ["scene.xml:8", "raw", "false"]),
    ("normalmap of a grey image", lambda c: c.ml.load_scene(c.scene_with("normal-grey", _GLASS.replace(
        '<bsdf type="dielectric"/>', '<bsdf type="normalmap">' + _NORMAL_TEX.format('<boolean name="raw" value="true"/>')
        + '<bsdf type="diffuse"/></bsdf>').format(""),
        {"n.png": (REPO / "tests" / "data" / "textures" / "bump_ripples.png").read_bytes()})),
     ["scene.xml:8", "n.png", "1 channel"]),
], raises=FILE_ERRORS + ("FileNotFoundError",))
_MASK_TEX = '<texture name="opacity" type="bitmap"><string name="filename" value="a.png"/></texture>'
cases_for("load_scene[mask]", [
    ("mask without a nested BSDF", lambda c: c.ml.load_scene(c.scene_with("mask-nobsdf", _GLASS.replace(
        '<bsdf type="dielectric"/>', f'<bsdf type="mask">{_MASK_TEX}</bsdf>').format(""), {"a.png": c.png_bytes})),
     ["scene.xml:8", "mask", "nested BSDF", "got none"]),
    ("mask whose opacity texture is missing", lambda c: c.ml.load_scene(c.scene_with("mask-notex", _GLASS.replace(
        '<bsdf type="dielectric"/>', f'<bsdf type="mask">{_MASK_TEX}<bsdf type="diffuse"/></bsdf>').format(""))),
     ["a.png"]),
    ("mask opacity above 1", lambda c: c.ml.load_scene(c.scene_with("mask-big", _GLASS.replace(
        '<bsdf type="dielectric"/>', '<bsdf type="mask"><float name="opacity" value="1.5"/><bsdf type="diffuse"/>'
        '</bsdf>').format(""))), ["scene.xml:8", "opacity", "[0, 1]", "1.5"]),
], raises=FILE_ERRORS + ("FileNotFoundError",))
_DIEL = '<shape type="sphere"><bsdf type="{}">{}</bsdf></shape>'


def _diel(c, tag, kind, props):
    return c.ml.load_scene(c.scene_with(tag, _DIEL.format(kind, props)))


cases_for("load_scene[dielectric]", [
    ("roughdielectric unknown distribution", lambda c: _diel(c, "rd-dist", "roughdielectric",
     '<string name="distribution" value="phong"/>'), ["scene.xml:8", "phong", "beckmann"]),
    ("roughdielectric negative alpha", lambda c: _diel(c, "rd-alpha", "roughdielectric",
     '<float name="alpha" value="-0.2"/>'), ["scene.xml:8", "alpha", "-0.2"]),
    ("roughdielectric NaN alpha_u", lambda c: _diel(c, "rd-nan", "roughdielectric",
     '<float name="alpha_u" value="nan"/><float name="alpha_v" value="0.1"/>'), ["scene.xml:8", "alpha_u", "nan"]),
    ("roughdielectric alpha_u without alpha_v", lambda c: _diel(c, "rd-uv", "roughdielectric",
     '<float name="alpha_u" value="0.1"/>'), ["scene.xml:8", "alpha_v"]),
    ("roughdielectric zero int_ior", lambda c: _diel(c, "rd-ior0", "roughdielectric",
     '<float name="int_ior" value="0"/>'), ["scene.xml:8", "int_ior", "got 0"]),
    ("roughdielectric equal IORs", lambda c: _diel(c, "rd-eq", "roughdielectric",
     '<float name="int_ior" value="1.5"/><float name="ext_ior" value="1.5"/>'), ["scene.xml:8", "differ", "1.5"]),
    ("roughdielectric unknown IOR name", lambda c: _diel(c, "rd-name", "roughdielectric",
     '<string name="int_ior" value="glas"/>'), ["scene.xml:8", "glas", "bk7"]),
    ("thindielectric negative ext_ior", lambda c: _diel(c, "td-neg", "thindielectric",
     '<float name="ext_ior" value="-1"/>'), ["scene.xml:8", "ext_ior", "-1"]),
    ("thindielectric reflectance above 1", lambda c: _diel(c, "td-rgb", "thindielectric",
     '<rgb name="specular_reflectance" value="2, 0.5, 0.5"/>'), ["scene.xml:8", "specular_reflectance", "[0, 1]"]),
    ("twosided around roughdielectric", lambda c: _diel(c, "rd-two", "twosided",
     '<bsdf type="roughdielectric"/>'), ["scene.xml:8", "twosided", "transmission"]),
], raises=FILE_ERRORS)
cases_for("load_scene[medium]", [
    ("bad media option", lambda c: c.ml.load_scene(REPO / "scenes" / "demo" / "scene.xml", media="ignore"), ["media"]),
], raises=("ValueError",))
cases_for("load_scene", [
    # refused before loading, naming the closest parameter the file has
    ("unused parameter", lambda c: c.ml.load_scene(REPO / "scenes" / "demo" / "scene.xml", nope=1), ["nope"]),
    ("misspelled parameter", lambda c: c.ml.load_scene(REPO / "scenes" / "demo" / "scene.xml", rez=8),
     ["rez", "did you mean 'res'"]),
], raises=("TypeError",))

# --------------------------------------------------------------------------------------------------
# Mesh files (OBJ, PLY) through load_scene.


def _mesh_scene(ctx, tag, kind, data):
    p = ctx.scene_with(tag, f'<shape type="{kind}"><string name="filename" value="mesh.{kind}"/></shape>',
                       {f"mesh.{kind}": data})
    return ctx.ml.load_scene(p)


cases_for("load_scene[obj]", [
    ("PNG renamed .obj", lambda c: _mesh_scene(c, "obj-png", "obj", c.png_bytes), ["mesh.obj"]),
    ("binary junk", lambda c: _mesh_scene(c, "obj-junk", "obj", JUNK), ["mesh.obj"]),
    ("empty file", lambda c: _mesh_scene(c, "obj-empty", "obj", b""), ["mesh.obj"]),
    ("face index out of range", lambda c: _mesh_scene(c, "obj-oob", "obj", OBJ + b"f 1 2 99\n"), ["mesh.obj", "99"]),
    ("face index zero", lambda c: _mesh_scene(c, "obj-zero", "obj", OBJ + b"f 0 1 2\n"), ["mesh.obj"]),
    ("huge face index", lambda c: _mesh_scene(c, "obj-huge", "obj", OBJ + b"f 1 2 99999999999999999999\n"),
     ["mesh.obj"]),
    ("vertex with two coordinates", lambda c: _mesh_scene(c, "obj-v2", "obj", b"v 0 0\n" + OBJ), ["mesh.obj"]),
    ("NaN vertex", lambda c: _mesh_scene(c, "obj-nan", "obj", OBJ.replace(b"v 1 0 0", b"v nan 0 0")),
     ["mesh.obj", "nan"]),
    ("inf vertex", lambda c: _mesh_scene(c, "obj-inf", "obj", OBJ.replace(b"v 1 0 0", b"v inf 0 0")),
     ["mesh.obj", "inf"]),
], raises=FILE_ERRORS)

cases_for("load_scene[ply]", [
    ("PNG renamed .ply", lambda c: _mesh_scene(c, "ply-png", "ply", c.png_bytes), ["mesh.ply"]),
    ("binary junk", lambda c: _mesh_scene(c, "ply-junk", "ply", JUNK), ["mesh.ply"]),
    ("empty file", lambda c: _mesh_scene(c, "ply-empty", "ply", b""), ["mesh.ply"]),
    ("header only", lambda c: _mesh_scene(c, "ply-head", "ply", ply_binary(3, 1, 0, 0)), ["mesh.ply"]),
    ("truncated vertices", lambda c: _mesh_scene(c, "ply-trv", "ply", ply_binary(3, 1, 3, 1)[:-20]), ["mesh.ply"]),
    ("truncated faces", lambda c: _mesh_scene(c, "ply-trf", "ply", ply_binary(3, 2, 3, 1)), ["mesh.ply"]),
    ("face index out of range", lambda c: _mesh_scene(c, "ply-oob", "ply", ply_binary(3, 1, 3, 1, face_index=7)),
     ["vertex 7", "scene.xml:8"]),
    ("negative face index", lambda c: _mesh_scene(c, "ply-neg", "ply", ply_binary(3, 1, 3, 1, face_index=-1)),
     ["mesh.ply"]),
    ("huge vertex count", lambda c: _mesh_scene(c, "ply-huge", "ply", ply_binary(10**12, 1, 3, 1)), ["mesh.ply"]),
    ("header cut", lambda c: _mesh_scene(c, "ply-hcut", "ply", ply_binary(3, 1, 3, 1)[:40]), ["mesh.ply"]),
], raises=FILE_ERRORS)

# --------------------------------------------------------------------------------------------------
# Textures (bitmap) and environment maps through load_scene.


def _tex_scene(ctx, tag, fname, data):
    body = (f'<shape type="rectangle"><bsdf type="diffuse"><texture name="reflectance" type="bitmap">'
            f'<string name="filename" value="{fname}"/></texture></bsdf></shape>')
    return ctx.ml.load_scene(ctx.scene_with(tag, body, {fname: data}))


def _env_scene(ctx, tag, fname, data):
    body = f'<shape type="rectangle"/><emitter type="envmap"><string name="filename" value="{fname}"/></emitter>'
    return ctx.ml.load_scene(ctx.scene_with(tag, body, {fname: data}))


# A 4x4 Radiance RGBE image (flat, not run-length encoded) and a 4x4 little-endian colour PFM.
HDR_BYTES = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 4 +X 4\n" + bytes([128, 64, 32, 129]) * 16
PFM_BYTES = b"PF\n4 4\n-1.0\n" + struct.pack("<48f", *([0.5] * 48))


def _exr_with(texel):
    import tempfile

    import manylights as ml
    img = np.full((4, 8, 3), 0.5, np.float32)
    img[1, 2] = texel
    img[3, 5] = texel
    with tempfile.TemporaryDirectory() as d:
        ml.write_exr(Path(d) / "t.exr", img)
        return (Path(d) / "t.exr").read_bytes()


cases_for("load_scene[envmap]", [
    (f"{what} texels", lambda c, t=t, w=what: _env_scene(c, f"env-{w}", f"{w}.exr", _exr_with(t)),
     [f"{what}.exr", "2 of 32 texels", "texel 10", "finite and >= 0"])
    for what, t in (("nan", [np.nan, 0.5, 0.5]), ("inf", [0.5, np.inf, 0.5]), ("negative", [0.5, 0.5, -1.0]))
], raises=("SceneError", "ValueError"))


def _area_tex_scene(ctx, tag, fname, data):
    body = (f'<shape type="rectangle"><emitter type="area"><texture name="radiance" type="bitmap">'
            f'<string name="filename" value="{fname}"/></texture></emitter></shape>')
    return ctx.ml.load_scene(ctx.scene_with(tag, body, {fname: data}))


cases_for("load_scene[area emitter texture]", [
    (f"{what} texels", lambda c, t=t, w=what: _area_tex_scene(c, f"area-{w}", f"{w}.exr", _exr_with(t)),
     [f"{what}.exr", "area emitter radiance texture", "2 of 32 texels", "finite and >= 0"])
    for what, t in (("nan", [np.nan, 0.5, 0.5]), ("negative", [0.5, 0.5, -1.0]))
], raises=("SceneError", "ValueError"))

for _kind, _load_fn in [("bitmap", _tex_scene), ("envmap", _env_scene)]:
    cases_for(f"load_scene[{_kind}]", [
        ("truncated PNG", lambda c, f=_load_fn, k=_kind: f(c, f"{k}-png", "t.png", c.png_bytes[:40]), ["t.png"]),
        ("JPEG cut in its header", lambda c, f=_load_fn, k=_kind: f(c, f"{k}-jpg", "t.jpg", c.jpg_bytes[:100]),
         ["t.jpg"]),
        ("truncated EXR", lambda c, f=_load_fn, k=_kind: f(c, f"{k}-exr", "t.exr", c.exr_bytes[:200]), ["t.exr"]),
        ("empty PNG", lambda c, f=_load_fn, k=_kind: f(c, f"{k}-e", "e.png", b""), ["e.png"]),
        ("empty EXR", lambda c, f=_load_fn, k=_kind: f(c, f"{k}-ee", "e.exr", b""), ["e.exr"]),
        ("junk as .exr", lambda c, f=_load_fn, k=_kind: f(c, f"{k}-j", "j.exr", JUNK), ["j.exr"]),
        ("text as .png", lambda c, f=_load_fn, k=_kind: f(c, f"{k}-txt", "x.png", b"hello\n" * 20), ["x.png"]),
        # (A PNG renamed .exr loads: images are recognised by their first bytes, as Mitsuba does.)
        ("truncated HDR", lambda c, f=_load_fn, k=_kind: f(c, f"{k}-hdr", "t.hdr", HDR_BYTES[:60]), ["t.hdr"]),
        ("HDR header only", lambda c, f=_load_fn, k=_kind: f(c, f"{k}-hdrh", "h.hdr", HDR_BYTES[:40]), ["h.hdr"]),
        ("junk as .hdr", lambda c, f=_load_fn, k=_kind: f(c, f"{k}-jh", "j.hdr", b"#?" + JUNK), ["j.hdr"]),
        ("truncated PFM", lambda c, f=_load_fn, k=_kind: f(c, f"{k}-pfm", "t.pfm", PFM_BYTES[:30]), ["t.pfm"]),
        ("PFM with a zero scale", lambda c, f=_load_fn, k=_kind: f(
            c, f"{k}-pfm0", "z.pfm", PFM_BYTES.replace(b"-1.0", b"0.0")), ["z.pfm"]),
        ("PFM claiming 10^5 x 10^5", lambda c, f=_load_fn, k=_kind: f(
            c, f"{k}-pfmbig", "b.pfm", b"PF\n100000 100000\n-1.0\n" + PFM_BYTES[13:]), ["b.pfm"]),
        ("EXR header claiming 10^5 x 10^5", lambda c, f=_load_fn, k=_kind: f(
            c, f"{k}-bigexr", "big.exr", exr_window(c.exr_bytes, (0, 0, 99999, 99999))), ["big.exr"]),
        ("PNG header claiming 10^5 x 10^5", lambda c, f=_load_fn, k=_kind: f(
            c, f"{k}-big", "big.png", png_header_only(100000, 100000)), ["big.png"]),
        # Texture size policy: at most 16384^2 pixels, declared in any format's header.
        ("JPEG header claiming 60000 x 60000", lambda c, f=_load_fn, k=_kind: f(
            c, f"{k}-bigjpg", "big.jpg", jpeg_declaring(c.jpg_bytes, 60000, 60000)),
         ["big.jpg", "JPEG image of 60000x60000 pixels is larger than supported", "16384x16384"]),
        ("HDR header claiming 60000 x 60000", lambda c, f=_load_fn, k=_kind: f(
            c, f"{k}-bighdr", "big.hdr", HDR_BYTES.replace(b"-Y 4 +X 4", b"-Y 60000 +X 60000")),
         ["big.hdr", "60000x60000 pixels is larger than supported", "16384x16384"]),
        ("BMP header claiming 60000 x 60000", lambda c, f=_load_fn, k=_kind: f(
            c, f"{k}-bigbmp", "big.bmp", bmp_declaring(60000, 60000)),
         ["big.bmp", "BMP image of 60000x60000 pixels is larger than supported", "16384x16384"]),
        ("TGA header claiming 60000 x 60000", lambda c, f=_load_fn, k=_kind: f(
            c, f"{k}-bigtga", "big.tga", tga_declaring(60000, 60000)),
         ["big.tga", "TGA image of 60000x60000 pixels is larger than supported", "16384x16384"]),
        ("PPM header claiming 60000 x 60000", lambda c, f=_load_fn, k=_kind: f(
            c, f"{k}-bigppm", "big.ppm", b"P6\n60000 60000\n255\n\x01\x02\x03"),
         ["big.ppm", "PNM image of 60000x60000 pixels is larger than supported", "16384x16384"]),
        ("truncated BMP", lambda c, f=_load_fn, k=_kind: f(c, f"{k}-bmp", "t.bmp", bmp_declaring(4, 4)), ["t.bmp"]),
        ("BMP of zero width", lambda c, f=_load_fn, k=_kind: f(c, f"{k}-bmp0", "z.bmp", bmp_declaring(0, 4)), ["z.bmp"]),
        ("truncated TGA", lambda c, f=_load_fn, k=_kind: f(c, f"{k}-tga", "t.tga", tga_declaring(4, 4)), ["t.tga"]),
        ("PPM with a bad maximum", lambda c, f=_load_fn, k=_kind: f(
            c, f"{k}-ppmmax", "m.ppm", b"P6\n1 1\n0\n\x01\x02\x03"), ["m.ppm"]),
        ("junk as .tga", lambda c, f=_load_fn, k=_kind: f(c, f"{k}-jtga", "j.tga", JUNK), ["j.tga"]),
        ("junk, unknown extension", lambda c, f=_load_fn, k=_kind: f(c, f"{k}-ext", "t.xyz", JUNK), ["t.xyz"]),
    ], raises=FILE_ERRORS)
    # A JPEG declaring 4000 x 4000 pixels (400 MB to decode) while MANYLIGHTS_MEMORY_LIMIT=64M: MemoryError.
    cases_for(f"load_scene[{_kind}]", [
        ("JPEG larger than MANYLIGHTS_MEMORY_LIMIT", lambda c, f=_load_fn, k=_kind: f(
            c, f"{k}-memjpg", "mem.jpg", jpeg_declaring(c.jpg_bytes, 4000, 4000)),
         ["mem.jpg", "JPEG image of 4000x4000 pixels", "MANYLIGHTS_MEMORY_LIMIT", "67.1 MB is available"]),
    ], raises=("MemoryError",), subprocess=True)

# --------------------------------------------------------------------------------------------------
# Image files and arrays: read_exr, write_exr, write_png.

cases_for("read_exr", [
    ("missing file", lambda c: c.ml.read_exr(c.tmp / "nope.exr"), ["nope.exr"]),
    ("a directory", lambda c: c.ml.read_exr(c.tmp), ["tmp"]),
    ("empty file", lambda c: c.ml.read_exr(c.file("empty.exr", b"")), ["empty.exr"]),
    ("binary junk", lambda c: c.ml.read_exr(c.file("junk.exr", JUNK)), ["junk.exr"]),
    ("truncated", lambda c: c.ml.read_exr(c.file("trunc.exr", c.exr_bytes[: len(c.exr_bytes) // 2])),
     ["trunc.exr"]),
    ("header only", lambda c: c.ml.read_exr(c.file("head.exr", c.exr_bytes[:100])), ["head.exr"]),
    ("PNG renamed .exr", lambda c: c.ml.read_exr(c.file("png.exr", c.png_bytes)), ["png.exr"]),
    ("header claiming 10^5 x 10^5", lambda c: c.ml.read_exr(c.file(
        "big.exr", exr_window(c.exr_bytes, (0, 0, 99999, 99999)))), ["big.exr"]),
    ("negative window", lambda c: c.ml.read_exr(c.file("neg.exr", exr_window(c.exr_bytes, (0, 0, -5, -5)))), ["neg.exr"]),
    ("window over int32", lambda c: c.ml.read_exr(c.file(
        "huge.exr", exr_window(c.exr_bytes, (-2**31, -2**31, 2**31 - 1, 2**31 - 1)))), ["huge.exr"]),
    ("not a path", lambda c: c.ml.read_exr(3), ["path"]),
], raises=("OSError", "ValueError", "TypeError"))

IMG = lambda *shape: np.zeros(shape, np.float32)  # noqa: E731
for _w, _ext in [("write_exr", "exr"), ("write_png", "png")]:
    cases_for(_w, [
        ("2-D image", lambda c, w=_w, e=_ext: getattr(c.ml, w)(c.tmp / f"o.{e}", IMG(4, 4)), ["(H, W, 3)"]),
        ("4 channels", lambda c, w=_w, e=_ext: getattr(c.ml, w)(c.tmp / f"o.{e}", IMG(4, 4, 4)), ["(H, W, 3)"]),
        ("empty image", lambda c, w=_w, e=_ext: getattr(c.ml, w)(c.tmp / f"o.{e}", IMG(0, 4, 3)), ["empty"]),
        ("complex dtype", lambda c, w=_w, e=_ext: getattr(c.ml, w)(c.tmp / f"o.{e}", np.zeros((2, 2, 3), complex)),
         ["complex"]),
        ("strings", lambda c, w=_w, e=_ext: getattr(c.ml, w)(c.tmp / f"o.{e}", np.full((2, 2, 3), "a")), ["'a'"]),
        ("folder missing", lambda c, w=_w, e=_ext: getattr(c.ml, w)(c.tmp / "no" / "dir" / f"o.{e}", IMG(2, 2, 3)),
         [f"o.{_ext}"]),
        ("path is a directory", lambda c, w=_w: getattr(c.ml, w)(c.tmp, IMG(2, 2, 3)), ["tmp"]),
    ], raises=("ValueError", "TypeError", "OSError"))
cases_for("write_png", [
    ("NaN exposure", lambda c: c.ml.write_png(c.tmp / "o.png", IMG(2, 2, 3), exposure=float("nan")),
     ["exposure"]),
    ("inf exposure", lambda c: c.ml.write_png(c.tmp / "o.png", IMG(2, 2, 3), exposure=float("inf")),
     ["exposure"]),
])
cases_for("show", [
    ("five channels", lambda c: c.ml.show(IMG(2, 3, 5), path=c.tmp / "s.png"), ["(2, 3, 5)"]),
    ("empty image", lambda c: c.ml.show(IMG(0, 3, 3), path=c.tmp / "s.png"), ["empty"]),
    ("NaN exposure", lambda c: c.ml.show(IMG(2, 2, 3), exposure=float("nan"), path=c.tmp / "s.png"), ["exposure"]),
])
cases_for("show", [
    ("strings", lambda c: c.ml.show([["a", "b"]], path=c.tmp / "s.png"), ["dtype"]),
], raises=("TypeError",))

# --------------------------------------------------------------------------------------------------
# Metrics.

cases_for("relative_l2", [
    ("shapes differ", lambda c: c.ml.relative_l2(IMG(2, 2, 3), IMG(2, 3, 3) + 1), ["shape"]),
    ("zero reference", lambda c: c.ml.relative_l2(IMG(2, 2, 3), IMG(2, 2, 3)), ["zero"]),
    ("empty", lambda c: c.ml.relative_l2(IMG(0, 3), IMG(0, 3)), ["empty"]),
    ("NaN in image", lambda c: c.ml.relative_l2(np.full((2, 2, 3), np.nan, np.float32), IMG(2, 2, 3) + 1),
     ["nan", "image"]),
    ("inf in reference", lambda c: c.ml.relative_l2(IMG(2, 2, 3), np.full((2, 2, 3), np.inf, np.float32)),
     ["inf", "reference"]),
])
cases_for("relative_l2", [("strings", lambda c: c.ml.relative_l2(np.full((2,), "a"), np.full((2,), "b")), ["'a'"])],
          raises=("TypeError",))
cases_for("fraction_within", [
    ("shapes differ", lambda c: c.ml.fraction_within(IMG(2, 2, 3), IMG(2, 3, 3)), ["shape"]),
    ("empty", lambda c: c.ml.fraction_within(IMG(0, 3), IMG(0, 3)), ["empty"]),
    ("negative tolerance", lambda c: c.ml.fraction_within(IMG(2, 2, 3), IMG(2, 2, 3), rel=-1), ["rel"]),
    ("NaN tolerance", lambda c: c.ml.fraction_within(IMG(2, 2, 3), IMG(2, 2, 3), abs_=float("nan")), ["abs_"]),
    ("NaN reference", lambda c: c.ml.fraction_within(IMG(2, 2, 3), np.full((2, 2, 3), np.nan)), ["nan"]),
])
cases_for("metrics.error_map", [
    ("shapes differ (would broadcast)", lambda c: __import__("manylights.metrics").metrics.error_map(
        IMG(4, 4, 3), IMG(1, 1, 3)), ["shape"]),
    ("2-D image", lambda c: __import__("manylights.metrics").metrics.error_map(IMG(4, 4), IMG(4, 4)), ["(H, W"]),
])

# --------------------------------------------------------------------------------------------------
# Scenes, lights, rows.

cases_for("scene_lights", [
    ("not a scene", lambda c: c.ml.scene_lights(None), ["Scene"]),
], raises=("TypeError",))
cases_for("generate_lights", [
    ("not a scene", lambda c: c.ml.generate_lights("scene.xml"), ["Scene"]),
], raises=("TypeError",))
cases_for("generate_lights", [
    ("negative count", lambda c: c.ml.generate_lights(c.scene, area=-1), ["area"]),
    ("fractional count", lambda c: c.ml.generate_lights(c.scene, area=1.5), ["area"]),
    ("NaN count", lambda c: c.ml.generate_lights(c.scene, area=float("nan")), ["area"]),
    ("huge count", lambda c: c.ml.generate_lights(c.scene, area=10**12), ["area"]),
    ("huge indirect", lambda c: c.ml.generate_lights(c.scene, area=0, indirect=10**12), ["indirect"]),
    ("count over u64", lambda c: c.ml.generate_lights(c.scene, environment=2**70), ["environment"]),
    ("NaN clamp", lambda c: c.ml.generate_lights(c.scene, clamp=float("nan")), ["clamp"]),
    ("zero clamp", lambda c: c.ml.generate_lights(c.scene, clamp=0), ["clamp"]),
    ("max_depth 2 with VPLs", lambda c: c.ml.generate_lights(c.scene, indirect=10, max_depth=2), ["max_depth"]),
    ("negative seed", lambda c: c.ml.generate_lights(c.scene, area=4, seed=-1), ["seed"]),
    ("fractional seed", lambda c: c.ml.generate_lights(c.scene, area=4, seed=0.5), ["seed"]),
    ("unknown indirect_kind", lambda c: c.ml.generate_lights(c.scene, area=4, indirect_kind="spheres"), ["indirect_kind"]),
    ("zero VSL radius scale", lambda c: c.ml.generate_lights(c.scene, area=4, indirect=10, indirect_kind="vsl",
                                                             vsl_radius_scale=0.0), ["vsl_radius_scale"]),
    ("NaN VSL radius scale", lambda c: c.ml.generate_lights(c.scene, area=4, indirect=10, indirect_kind="vsl",
                                                            vsl_radius_scale=float("nan")), ["vsl_radius_scale"]),
    ("zero VSL neighbours", lambda c: c.ml.generate_lights(c.scene, area=4, indirect_kind="vsl", vsl_neighbours=0),
     ["vsl_neighbours"]),
    ("non-bool vpl_importance", lambda c: c.ml.generate_lights(c.scene, area=4, indirect=10, vpl_importance="yes"),
     ["vpl_importance"]),
    ("negative vpl_view_samples", lambda c: c.ml.generate_lights(c.scene, area=4, indirect=10, vpl_importance=True,
                                                                 vpl_view_samples=-1), ["vpl_view_samples"]),
    ("NaN vpl_accept_min", lambda c: c.ml.generate_lights(c.scene, area=4, indirect=10, vpl_importance=True,
                                                          vpl_accept_min=float("nan")), ["vpl_accept_min"]),
])
cases_for("stratified_rows", [
    ("zero rows", lambda c: c.ml.stratified_rows(c.scene, 0), ["r"]),
    ("more rows than pixels", lambda c: c.ml.stratified_rows(c.scene, 65), ["64"]),
    ("huge r", lambda c: c.ml.stratified_rows(c.scene, 10**20), ["r"]),
    ("fractional r", lambda c: c.ml.stratified_rows(c.scene, 2.5), ["r"]),
    ("NaN r", lambda c: c.ml.stratified_rows(c.scene, float("nan")), ["r"]),
    ("negative seed", lambda c: c.ml.stratified_rows(c.scene, 4, seed=-3), ["seed"]),
    ("not a scene", lambda c: c.ml.stratified_rows(None, 4), ["scene"]),
], raises=("ValueError", "TypeError"))
cases_for("Scene.mesh", [
    ("index out of range", lambda c: c.scene.mesh(999), ["999"]),
    ("negative index", lambda c: c.scene.mesh(-1), ["-1", "out of range"]),
    ("fractional index", lambda c: c.scene.mesh(0.5), ["integer"]),
], raises=("ValueError", "TypeError", "OverflowError"))
cases_for("Scene", [("no constructor", lambda c: c.ml.Scene(), ["cannot create"])], raises=("TypeError",))
cases_for("Scene.gbuffer", [
    ("arguments", lambda c: c.scene.gbuffer(1), ["argument"]),
    ("two arguments", lambda c: c.scene.gbuffer("cpu", 2), ["argument"]),
], raises=("TypeError",))
cases_for("Scene.gbuffer", [
    ("unknown device", lambda c: c.scene.gbuffer("fpga"), ["fpga", "'cpu'"]),
])
cases_for("LightSet", [
    ("no constructor", lambda c: c.ml.LightSet(), ["cannot create"]),
    ("len of a non-set", lambda c: c.ml.LightSet.__len__(None), ["LightSet"]),
], raises=("TypeError",))

cases_for("LightSet.from_arrays", [
    ("NaN position", lambda c: c.ml.LightSet.from_arrays(c.scene, kind=0, position=[[0, np.nan, 0]],
                                                          intensity=[[1, 1, 1]]), ["position[0]", "finite"]),
    ("wrong position shape", lambda c: c.ml.LightSet.from_arrays(c.scene, kind=[0, 0], position=np.zeros((2, 4)),
                                                                  intensity=np.ones((2, 3))), ["position", "(2, 3)"]),
    ("negative intensity", lambda c: c.ml.LightSet.from_arrays(c.scene, kind=0, position=[[0, 0, 0]],
                                                                intensity=[[1, -1, 1]]), ["intensity[0]", ">= 0"]),
    ("intensity overflowing float32", lambda c: c.ml.LightSet.from_arrays(c.scene, kind=0, position=[[0, 0, 0]],
                                                                           intensity=[[3e38] * 3]),
     ["intensity[0]", "1e30", "overflow"]),
    ("inf power", lambda c: c.ml.LightSet.from_arrays(c.scene, kind=0, position=[[0, 0, 0]],
                                                       power=[[1, np.inf, 1]]), ["power[0]", "finite"]),
    ("unknown kind", lambda c: c.ml.LightSet.from_arrays(c.scene, kind=7, position=[[0, 0, 0]],
                                                          intensity=[[1, 1, 1]]), ["kind", "7"]),
    ("string positions", lambda c: c.ml.LightSet.from_arrays(c.scene, kind=0, position=[["a", "b", "c"]],
                                                              intensity=[[1, 1, 1]]), ["position", "dtype"]),
])
cases_for("LightSet.from_arrays", [
    ("not a scene", lambda c: c.ml.LightSet.from_arrays(None, kind=0, position=[[0, 0, 0]], intensity=[[1, 1, 1]]),
     ["Scene"]),
], raises=("TypeError",))
cases_for("LightSet.concat", [
    ("no sets", lambda c: c.ml.LightSet.concat([]), ["at least one"]),
])
cases_for("LightSet.concat", [
    ("not light sets", lambda c: c.ml.LightSet.concat([c.lights, 3]), ["LightSet"]),
], raises=("TypeError",))

# --------------------------------------------------------------------------------------------------
# LightMatrix.

cases_for("LightMatrix", [
    ("not a scene", lambda c: c.ml.LightMatrix(None, c.lights), ["Scene"]),
    ("not lights", lambda c: c.ml.LightMatrix(c.scene, [1, 2, 3]), ["LightSet"]),
], raises=("TypeError",))
cases_for("LightMatrix", [
    ("unknown visibility", lambda c: c.ml.LightMatrix(c.scene, c.lights, visibility="magic"), ["magic"]),
    ("shadow map 0", lambda c: c.ml.LightMatrix(c.scene, c.lights, shadow_map_size=0), ["shadow_map_size"]),
    ("negative shadow map", lambda c: c.ml.LightMatrix(c.scene, c.lights, shadow_map_size=-512),
     ["shadow_map_size"]),
    ("huge shadow map", lambda c: c.ml.LightMatrix(c.scene, c.lights, shadow_map_size=2**40),
     ["shadow_map_size"]),
    ("fractional shadow map", lambda c: c.ml.LightMatrix(c.scene, c.lights, shadow_map_size=100.5),
     ["shadow_map_size"]),
    ("NaN shadow map", lambda c: c.ml.LightMatrix(c.scene, c.lights, shadow_map_size=float("nan")),
     ["shadow_map_size"]),
    ("native: NaN bias", lambda c: c.native.LightMatrix(c.scene, c.lights, 16, depth_bias=float("nan")),
     ["depth_bias"]),
    ("native: negative offset", lambda c: c.native.LightMatrix(c.scene, c.lights, 16, normal_offset=-1.0),
     ["normal_offset"]),
    ("unknown device", lambda c: c.ml.LightMatrix(c.scene, c.lights, device="tpu"), ["tpu", "'cpu'"]),
    ("device not a string", lambda c: c.ml.LightMatrix(c.scene, c.lights, device=0), ["device"]),
    ("shadow maps on the CPU", lambda c: c.ml.LightMatrix(c.scene, c.lights, device="cpu", visibility="hybrid"),
     ["only the GPU backend", "ray_traced"]),
])
cases_for("LightMatrix", [
    ("bad MANYLIGHTS_DEVICE", lambda c: c.ml.LightMatrix(c.scene, c.lights), ["MANYLIGHTS_DEVICE", "quantum"]),
], subprocess=True)
cases_for("device_info", [
    ("unknown device", lambda c: c.ml.device_info("npu"), ["npu", "'gpu'"]),
])
# No GPU adapter at all (Vulkan pointed at no driver, the only backend allowed): "gpu" says what to install.
cases_for("LightMatrix", [
    ("gpu without any adapter", lambda c: c.ml.LightMatrix(c.scene, c.lights, device="gpu"),
     ["mesa-vulkan-drivers"]),
], raises=("GpuUnavailableError",), subprocess=True)

_IDX_CASES = lambda call, size: [  # noqa: E731
    ("index = size", lambda c: call(c, size(c)), ["range"]),
    ("negative index", lambda c: call(c, -1), ["-1"]),
    ("huge index", lambda c: call(c, 2**70), ["range"]),
    ("fractional index", lambda c: call(c, 1.5), ["integer"]),
    ("NaN index", lambda c: call(c, float("nan")), ["integer"]),
    ("bool index", lambda c: call(c, True), ["integer"]),
]
cases_for("LightMatrix.columns", _IDX_CASES(lambda c, i: c.A.columns([0, i]), lambda c: c.n) + [
    ("2-D indices", lambda c: c.A.columns(np.zeros((2, 2), np.int64)), ["one-dimensional", "(2, 2)"]),
    ("strings", lambda c: c.A.columns(["a"]), ["a"]),
])
cases_for("LightMatrix.element", _IDX_CASES(lambda c, i: c.A.element(i, 0), lambda c: c.m)
          + [("column out of range", lambda c: c.A.element(0, c.n), ["range"])])
cases_for("LightMatrix.bias_compensation", [
    ("zero spp", lambda c: c.A.bias_compensation(spp=0), ["spp"]),
    ("fractional spp", lambda c: c.A.bias_compensation(spp=1.5), ["spp"]),
    ("negative light_samples", lambda c: c.A.bias_compensation(light_samples=-1), ["light_samples"]),
    ("max_depth below -1", lambda c: c.A.bias_compensation(max_depth=-2), ["max_depth"]),
    ("negative seed", lambda c: c.A.bias_compensation(seed=-1), ["seed"]),
])
cases_for("LightMatrix.row_exact", _IDX_CASES(lambda c, i: c.A.row_exact(i), lambda c: c.m))
cases_for("LightMatrix.column_exact", _IDX_CASES(lambda c, i: c.A.column_exact(i), lambda c: c.n))
cases_for("LightMatrix.shadow_rays", [
    ("view sample out of range", lambda c: c.A.shadow_rays([c.m], [0]), ["range"]),
    ("light out of range", lambda c: c.A.shadow_rays([0], [c.n]), ["range"]),
    ("negative light", lambda c: c.A.shadow_rays([0], [-1]), ["range"]),
    ("unknown order", lambda c: c.A.shadow_rays([0], [0], order="diagonal"), ["order"]),
    ("float indices", lambda c: c.A.shadow_rays([0.5], [0]), ["integer"]),
])
cases_for("LightMatrix.shadow_rays", [
    ("every_element a string", lambda c: c.A.shadow_rays([0], [0], every_element="False"), ["every_element"]),
    ("every_element None", lambda c: c.A.shadow_rays([0], [0], every_element=None), ["every_element"]),
], raises=("TypeError",))
cases_for("LightMatrix.trace_shadow_rays", [
    ("two columns", lambda c: c.A.trace_shadow_rays(np.zeros((2, 2)), np.zeros((2, 3)), np.ones(2)), ["shape"]),
    ("lengths differ", lambda c: c.A.trace_shadow_rays(np.zeros((2, 3)), np.zeros((3, 3)), np.ones(2)),
     ["one entry per ray"]),
    ("t_max 2-D", lambda c: c.A.trace_shadow_rays(np.zeros((2, 3)), np.zeros((2, 3)), np.ones((2, 1))), ["t_max"]),
    ("1-D origin", lambda c: c.A.trace_shadow_rays(np.zeros(3), np.zeros((1, 3)), np.ones(1)), ["origin", "shape"]),
    ("no rays, wrong shape", lambda c: c.A.trace_shadow_rays([], [], []), ["origin", "shape"]),
    ("NaN origin", lambda c: c.A.trace_shadow_rays(np.array([[0, 0, 0], [0, np.nan, 0]]), np.ones((2, 3)),
                                                   np.ones(2)), ["origin of ray 1"]),
    ("inf direction", lambda c: c.A.trace_shadow_rays(np.zeros((1, 3)), np.array([[np.inf, 0, 0]]), np.ones(1)),
     ["direction of ray 0"]),
    ("NaN t_max", lambda c: c.A.trace_shadow_rays(np.zeros((2, 3)), np.ones((2, 3)), np.array([1.0, np.nan])),
     ["t_max of ray 1"]),
])
cases_for("LightMatrix.rows", _IDX_CASES(lambda c, i: c.A.rows([0, i], progress=False), lambda c: c.m) + [
    ("no rows", lambda c: c.A.rows([], progress=False), ["at least one"]),
    ("bool mask", lambda c: c.A.rows(np.ones(4, bool), progress=False), ["integer"]),
    ("shadow map 8", lambda c: c.A.rows([0], progress=False, shadow_map_size=8), ["shadow_map_size"]),
    ("more rows than samples", lambda c: c.A.rows(np.zeros(c.m + 1, np.int64), progress=False), ["rows"]),
])
cases_for("LightMatrix.column_sum", [
    ("wrong length", lambda c: c.A.column_sum(np.ones(c.n + 1), progress=False), ["length"]),
    ("2-D weights", lambda c: c.A.column_sum(np.ones((c.n, 3)), progress=False), ["(n,)", "(7, 3)"]),
    ("NaN weight", lambda c: c.A.column_sum(np.r_[np.nan, np.ones(c.n - 1)], progress=False), ["nan"]),
    ("inf weight", lambda c: c.A.column_sum(np.r_[np.inf, np.ones(c.n - 1)], progress=False), ["inf"]),
    ("empty weights", lambda c: c.A.column_sum(np.ones(0), progress=False), ["length"]),
    ("native: wrong length", lambda c: c.A._m.column_sum(np.ones(c.n + 1, np.float32)), ["length"]),
])
def _overflowing_matrix(c):
    """Light 1 of 1e30 W/sr a millionth of a unit above a visible surface: its contribution overflows."""
    def make():
        vs = c.A.view_samples()
        p, n = vs["position"][vs["surface"]][10], vs["normal"][vs["surface"]][10]
        lights = c.ml.LightSet.from_arrays(c.scene, kind=[0, 0], position=[[0, 1, 0], (p + n * 1e-6).tolist()],
                                           intensity=[[1, 1, 1], [1e30] * 3])
        return c.ml.LightMatrix(c.scene, lights, device="cpu")
    return c._get("overflow", make)


cases_for("LightMatrix.column_sum", [
    ("a contribution overflowing float32", lambda c: _overflowing_matrix(c).column_sum(progress=False),
     ["view sample", "light 1", "inf"]),
    ("weights overflowing the sum", lambda c: c.ml.LightMatrix(c.scene, c.ml.LightSet.from_arrays(
        c.scene, kind=[0, 0], position=[[0, 1, 0], [0, 1.1, 0]], intensity=[[1e30] * 3] * 2), device="cpu").column_sum(
        [1e10, 1e10], progress=False),
     ["view sample", "weighted sum", "inf"]),
], raises=("FloatingPointError",))
cases_for("LightMatrix.columns", [
    ("a column overflowing float32", lambda c: _overflowing_matrix(c).columns([1]), ["light 1", "view sample", "inf"]),
], raises=("FloatingPointError",))
cases_for("LightMatrix.column_sum", [("strings", lambda c: c.A.column_sum(["a"] * c.n, progress=False), ["'a'"])],
          raises=("TypeError",))
cases_for("LightMatrix.weighted_sum", [
    ("length mismatch", lambda c: c.A.weighted_sum([0, 1], np.ones((3, 3))), ["shape"]),
    ("2 channels", lambda c: c.A.weighted_sum([0, 1], np.ones((2, 2))), ["shape"]),
    ("3-D weights", lambda c: c.A.weighted_sum([0, 1], np.ones((2, 3, 1))), ["shape"]),
    ("NaN weight", lambda c: c.A.weighted_sum([0, 1], np.array([[1, 1, 1], [np.nan, 1, 1]])), ["nan"]),
    ("inf weight", lambda c: c.A.weighted_sum([0], np.array([np.inf])), ["inf"]),
    ("index out of range", lambda c: c.A.weighted_sum([c.n], np.ones(1)), ["range"]),
    ("negative index", lambda c: c.A.weighted_sum([-1], np.ones(1)), ["-1"]),
    ("fractional index", lambda c: c.A.weighted_sum([0.5], np.ones(1)), ["integer"]),
    ("native: 2 channels", lambda c: c.A._m.weighted_sum([0, 1], np.ones((2, 2), np.float32)), ["shape"]),
])
cases_for("LightMatrix.emitted", [("arguments", lambda c: c.A.emitted(1), ["argument"])], raises=("TypeError",))
cases_for("LightMatrix.visibility_stats", [("arguments", lambda c: c.A.visibility_stats(1), ["argument"])],
          raises=("TypeError",))
cases_for("native.LightMatrix.reset_visibility_stats", [
    ("arguments", lambda c: c.A._m.reset_visibility_stats(1), ["argument"])], raises=("TypeError",))

# --------------------------------------------------------------------------------------------------
# Clustering.

R = lambda *shape: np.random.default_rng(0).random(shape, dtype=np.float32)  # noqa: E731


def _nan_at(a, idx, v=np.nan):
    a = a.copy()
    a[idx] = v
    return a


cases_for("cluster_reduced_columns", [
    ("4 channels", lambda c: c.ml.cluster_reduced_columns(R(4, 10, 4), 3), ["shape"]),
    ("1-D", lambda c: c.ml.cluster_reduced_columns(R(10), 3), ["shape"]),
    ("no rows", lambda c: c.ml.cluster_reduced_columns(R(0, 10, 3), 3), ["r"]),
    ("no columns", lambda c: c.ml.cluster_reduced_columns(R(4, 0, 3), 1), ["n"]),
    ("NaN (names row and column)", lambda c: c.ml.cluster_reduced_columns(_nan_at(R(4, 10, 3), (2, 7, 1)), 3),
     ["row 2", "column 7"]),
    ("inf", lambda c: c.ml.cluster_reduced_columns(_nan_at(R(4, 10), (1, 3), np.inf), 3), ["row 1", "column 3"]),
    ("c = 0", lambda c: c.ml.cluster_reduced_columns(R(4, 10, 3), 0), ["c"]),
    ("c > n", lambda c: c.ml.cluster_reduced_columns(R(4, 10, 3), 11), ["c"]),
    ("negative c", lambda c: c.ml.cluster_reduced_columns(R(4, 10, 3), -2), ["c"]),
    ("huge c", lambda c: c.ml.cluster_reduced_columns(R(4, 10, 3), 2**70), ["c"]),
    ("fractional c", lambda c: c.ml.cluster_reduced_columns(R(4, 10, 3), 2.5), ["c"]),
    ("power wrong length", lambda c: c.ml.cluster_reduced_columns(R(4, 10, 3), 3, power=np.ones(9)), ["power"]),
    ("NaN power", lambda c: c.ml.cluster_reduced_columns(R(4, 10, 3), 3, power=_nan_at(np.ones(10), 4)),
     ["power"]),
    ("negative power", lambda c: c.ml.cluster_reduced_columns(R(4, 10, 3), 3, power=-np.ones(10)), ["power"]),
    ("projection_dim 0", lambda c: c.ml.cluster_reduced_columns(R(4, 10, 3), 3, projection_dim=0),
     ["projection_dim"]),
    ("NaN sampling_fraction", lambda c: c.ml.cluster_reduced_columns(R(4, 10, 3), 3, sampling_fraction=np.nan),
     ["sampling_fraction"]),
    ("sampling_fraction 2", lambda c: c.ml.cluster_reduced_columns(R(4, 10, 3), 3, sampling_fraction=2.0),
     ["sampling_fraction"]),
    ("negative seed", lambda c: c.ml.cluster_reduced_columns(R(4, 10, 3), 3, seed=-1), ["seed"]),
    ("complex dtype", lambda c: c.ml.cluster_reduced_columns(np.zeros((4, 10), complex), 3), ["complex"]),
    ("strings", lambda c: c.ml.cluster_reduced_columns(np.full((4, 10), "x"), 3), ["x"]),
], raises=("ValueError", "TypeError"))
cases_for("clustering_cost", [
    ("assignment wrong length", lambda c: c.ml.clustering_cost(R(4, 10, 3), np.zeros(9, np.int64)), ["assignment"]),
    ("negative label", lambda c: c.ml.clustering_cost(R(4, 10, 3), -np.ones(10, np.int64)), ["label"]),
    ("fractional labels", lambda c: c.ml.clustering_cost(R(4, 10, 3), np.full(10, 0.5)), ["integer"]),
    ("huge label", lambda c: c.ml.clustering_cost(R(4, 10, 3), np.full(10, 2**40, np.int64)), ["label"]),
    ("NaN in R", lambda c: c.ml.clustering_cost(_nan_at(R(4, 10), (0, 0)), np.zeros(10, np.int64)), ["row 0"]),
    ("bad R shape", lambda c: c.ml.clustering_cost(R(4, 10, 2), np.zeros(10, np.int64)), ["shape"]),
])

# K-means and fuzzy membership.
KP = lambda n=20: np.random.default_rng(2).random((n, 3), dtype=np.float32)  # noqa: E731
KN = lambda n=20: np.tile(np.array([[0, 0, 1]], np.float32), (n, 1))  # noqa: E731
cases_for("kmeans", [
    ("k = 0", lambda c: c.ml.kmeans(KP(), KN(), 0), ["k", "got 0"]),
    ("k > N", lambda c: c.ml.kmeans(KP(), KN(), 21), ["k", "got 21"]),
    ("negative k", lambda c: c.ml.kmeans(KP(), KN(), -3), ["k", "-3"]),
    ("fractional k", lambda c: c.ml.kmeans(KP(), KN(), 2.5), ["k", "2.5"]),
    ("huge k", lambda c: c.ml.kmeans(KP(), KN(), 2**70), ["k"]),
    ("NaN point", lambda c: c.ml.kmeans(_nan_at(KP(), (4, 1)), KN(), 3), ["points", "(4, 1)"]),
    ("inf normal", lambda c: c.ml.kmeans(KP(), _nan_at(KN(), (2, 0), np.inf), 3), ["normals", "(2, 0)"]),
    ("zero normal", lambda c: c.ml.kmeans(KP(), _nan_at(KN(), (5, 2), 0.0), 3), ["normal 5", "zero"]),
    ("points (N, 2)", lambda c: c.ml.kmeans(KP()[:, :2], None, 3), ["points", "(N, 3)", "(20, 2)"]),
    ("normals rows differ", lambda c: c.ml.kmeans(KP(), KN(19), 3), ["normals", "(19, 3)"]),
    ("no points", lambda c: c.ml.kmeans(np.zeros((0, 3), np.float32), None, 1), ["at least one"]),
    ("negative iterations", lambda c: c.ml.kmeans(KP(), KN(), 3, iterations=-1), ["iterations", "-1"]),
    ("NaN tolerance", lambda c: c.ml.kmeans(KP(), KN(), 3, tolerance=np.nan), ["tolerance", "nan"]),
    ("negative tolerance", lambda c: c.ml.kmeans(KP(), KN(), 3, tolerance=-0.5), ["tolerance", "-0.5"]),
    ("threshold > 1", lambda c: c.ml.kmeans(KP(), KN(), 3, cos_threshold=1.5), ["cos_threshold", "1.5"]),
    ("threshold < -1", lambda c: c.ml.kmeans(KP(), KN(), 3, cos_threshold=-2), ["cos_threshold", "-2"]),
    ("bad device", lambda c: c.ml.kmeans(KP(), KN(), 3, device="tpu"), ["device", "tpu"]),
    ("negative seed", lambda c: c.ml.kmeans(KP(), KN(), 3, seed=-1), ["seed", "-1"]),
    ("complex points", lambda c: c.ml.kmeans(np.zeros((4, 3), complex), None, 1), ["complex"]),
], raises=("ValueError", "TypeError"))
cases_for("fuzzy_membership", [
    ("f = 0", lambda c: c.ml.fuzzy_membership(KP(), KN(), KP(5), KN(5), 0), ["f", "got 0"]),
    ("f > k", lambda c: c.ml.fuzzy_membership(KP(), KN(), KP(5), KN(5), 6), ["f", "got 6"]),
    ("f > 16", lambda c: c.ml.fuzzy_membership(KP(), KN(), KP(20), KN(20), 17), ["f", "got 17"]),
    ("NaN centroid", lambda c: c.ml.fuzzy_membership(KP(), KN(), _nan_at(KP(5), (3, 0)), KN(5), 2),
     ["centroids", "(3, 0)"]),
    ("one side's normals", lambda c: c.ml.fuzzy_membership(KP(), KN(), KP(5), None, 2), ["normals"]),
    ("centroid normals rows", lambda c: c.ml.fuzzy_membership(KP(), KN(), KP(5), KN(4), 2),
     ["centroid_normals", "(4, 3)"]),
    ("no centroids", lambda c: c.ml.fuzzy_membership(KP(), None, np.zeros((0, 3), np.float32), None, 1),
     ["0 centroids"]),
    ("threshold NaN", lambda c: c.ml.fuzzy_membership(KP(), KN(), KP(5), KN(5), 2, cos_threshold=np.nan),
     ["cos_threshold", "nan"]),
    ("bad device", lambda c: c.ml.fuzzy_membership(KP(), KN(), KP(5), KN(5), 2, device=3), ["device", "3"]),
], raises=("ValueError", "TypeError"))
# The native functions behind them (checks that hold without the Python wrapper).
cases_for("native.kmeans", [
    ("k = 0", lambda c: c.native.kmeans(KP(), KN(), 0), ["k", "got 0"]),
    ("k > N", lambda c: c.native.kmeans(KP(), KN(), 21), ["k", "got 21"]),
    ("negative iterations", lambda c: c.native.kmeans(KP(), KN(), 3, -4), ["iterations", "-4"]),
    ("NaN point", lambda c: c.native.kmeans(_nan_at(KP(), (6, 2)), KN(), 3), ["point 6"]),
    ("shape", lambda c: c.native.kmeans(np.zeros((5, 4), np.float32), None, 1), ["(N, 3)", "[5, 4]"]),
    ("normals rows", lambda c: c.native.kmeans(KP(), KN(3), 2), ["normals", "3 rows"]),
    ("threshold", lambda c: c.native.kmeans(KP(), KN(), 2, 10, 0.0, 3.0), ["cos_threshold", "3"]),
    ("negative tolerance", lambda c: c.native.kmeans(KP(), KN(), 2, 10, -1.0), ["tolerance", "-1"]),
    ("device", lambda c: c.native.kmeans(KP(), KN(), 2, device="quantum"), ["device", "quantum"]),
])
cases_for("native.fuzzy_membership", [
    ("f = 0", lambda c: c.native.fuzzy_membership(KP(), KN(), KP(5), KN(5), 0), ["F", "got 0"]),
    ("f > k", lambda c: c.native.fuzzy_membership(KP(), KN(), KP(5), KN(5), 9), ["F", "got 9"]),
    ("negative f", lambda c: c.native.fuzzy_membership(KP(), KN(), KP(5), KN(5), -1), ["f", "-1"]),
    ("one side's normals", lambda c: c.native.fuzzy_membership(KP(), None, KP(5), KN(5), 2), ["normals"]),
    ("NaN normal", lambda c: c.native.fuzzy_membership(KP(), _nan_at(KN(), (1, 1)), KP(5), KN(5), 2), ["normal 1"]),
])

# Tensor clustering and the animation metrics.
T4 = lambda *shape: np.random.default_rng(1).random(shape, dtype=np.float32)  # noqa: E731
cases_for("cluster_tensor", [
    ("columns below f", lambda c: c.ml.cluster_tensor(T4(4, 5, 3, 3), 2), ["columns", "[3, 15]"]),
    ("columns above n f", lambda c: c.ml.cluster_tensor(T4(4, 5, 3, 3), 16), ["columns", "[3, 15]"]),
    ("huge columns", lambda c: c.ml.cluster_tensor(T4(4, 5, 3, 3), 2**70), ["columns"]),
    ("fractional columns", lambda c: c.ml.cluster_tensor(T4(4, 5, 3, 3), 4.5), ["columns"]),
    ("chunk 0", lambda c: c.ml.cluster_tensor(T4(4, 5, 3, 3), 5, chunk=0), ["chunk"]),
    ("init_clusters 0", lambda c: c.ml.cluster_tensor(T4(4, 5, 3, 3), 5, init_clusters=0), ["init_clusters"]),
    ("projection_dim 0", lambda c: c.ml.cluster_tensor(T4(4, 5, 3, 3), 5, projection_dim=0), ["projection_dim"]),
    ("2 channels", lambda c: c.ml.cluster_tensor(T4(4, 5, 3, 2), 5), ["shape"]),
    ("2-D", lambda c: c.ml.cluster_tensor(T4(4, 5), 5), ["shape"]),
    ("no frames", lambda c: c.ml.cluster_tensor(T4(4, 5, 0, 3), 5), ["frame"]),
    ("NaN (names row, light, frame)", lambda c: c.ml.cluster_tensor(_nan_at(T4(4, 5, 3, 3), (3, 2, 1, 0)), 5),
     ["row 3", "light 2", "frame 1"]),
    ("unknown representative", lambda c: c.ml.cluster_tensor(T4(4, 5, 3, 3), 5, representative="min"),
     ["representative"]),
    ("negative seed", lambda c: c.ml.cluster_tensor(T4(4, 5, 3, 3), 5, seed=-1), ["seed"]),
    ("complex dtype", lambda c: c.ml.cluster_tensor(np.zeros((4, 5, 3, 3), complex), 5), ["complex"]),
], raises=("ValueError", "TypeError"))
cases_for("native.cluster_tensor", [
    ("native: columns below f", lambda c: c.native.cluster_tensor(T4(4, 5, 3, 3), 2), ["columns"]),
    ("native: columns above n f", lambda c: c.native.cluster_tensor(T4(4, 5, 3, 3), 16), ["columns"]),
    ("native: chunk 0", lambda c: c.native.cluster_tensor(T4(4, 5, 3, 3), 5, 0, 0), ["chunk"]),
    ("native: bad shape", lambda c: c.native.cluster_tensor(T4(4, 5, 3, 2), 5), ["shape"]),
    ("native: NaN", lambda c: c.native.cluster_tensor(_nan_at(T4(4, 5, 3, 3), (0, 4, 2, 2)), 5),
     ["light 4", "frame 2"]),
    ("native: unknown representative", lambda c: c.native.cluster_tensor(T4(4, 5, 3, 3), 5, 0, 40, 100, 50, "x"),
     ["representative"]),
    ("native: negative columns", lambda c: c.native.cluster_tensor(T4(4, 5, 3, 3), -1), []),
], raises=("ValueError", "TypeError", "OverflowError"))
def _cs(c, **kw):
    """Valid clustered_shading arguments for the corpus matrix (one light label, two view clusters, F = 1)
    with ``kw`` replaced."""
    args = dict(light_labels=np.zeros(c.n, np.int64), light_centroids=np.zeros((1, 3), np.float32),
                view_centroids=np.zeros((2, 3), np.float32), view_normals=np.tile([0, 0, 1], (2, 1)).astype(np.float32),
                membership_clusters=np.zeros((c.m, 1), np.uint32), membership_weights=np.ones((c.m, 1), np.float32))
    return {**args, **kw}


def _cs_native(c, **kw):
    a = _cs(c, **kw)
    return c.native.clustered_shading(c.A._m, a["light_labels"].astype(np.uint32), a["light_centroids"],
                                      a["view_centroids"], a["view_normals"], a["membership_clusters"],
                                      a["membership_weights"])


cases_for("native.cluster_view_samples", [
    ("k = 0", lambda c: c.native.cluster_view_samples(KP(), KN(), 0), ["k", "got 0"]),
    ("gamma = 0", lambda c: c.native.cluster_view_samples(KP(), KN(), 3, 0), ["gamma", "got 0"]),
    ("f = 0", lambda c: c.native.cluster_view_samples(KP(), KN(), 3, 2, 0), ["f"]),
    ("NaN point", lambda c: c.native.cluster_view_samples(_nan_at(KP(), (6, 2)), KN(), 3), ["point 6"]),
    ("normals rows", lambda c: c.native.cluster_view_samples(KP(), KN(3), 2), ["normals", "3 rows"]),
])
cases_for("clustered_visibility", [
    ("not a matrix", lambda c: c.ml.clustered_visibility("A"), ["LightMatrix"]),
    ("zero light clusters", lambda c: c.ml.clustered_visibility(c.A, light_clusters=0), ["light_clusters"]),
    ("zero view clusters", lambda c: c.ml.clustered_visibility(c.A, view_clusters=0), ["view_clusters"]),
    ("fuzzy 17", lambda c: c.ml.clustered_visibility(c.A, fuzzy=17), ["fuzzy", "17"]),
    ("downsample 0", lambda c: c.ml.clustered_visibility(c.A, downsample=0), ["downsample"]),
    ("negative iterations", lambda c: c.ml.clustered_visibility(c.A, iterations=-1), ["iterations"]),
    ("threshold 2", lambda c: c.ml.clustered_visibility(c.A, cos_threshold=2.0), ["cos_threshold"]),
    ("negative seed", lambda c: c.ml.clustered_visibility(c.A, seed=-1), ["seed"]),
], raises=("ValueError", "TypeError"))
cases_for("clustered_shading", [
    ("label out of range", lambda c: c.ml.clustered_shading(c.A, **_cs(c, light_labels=np.full(c.n, 5))),
     ["light label 5", "1 light centroids"]),
    ("negative label", lambda c: c.ml.clustered_shading(c.A, **_cs(c, light_labels=-np.ones(c.n, np.int64))),
     ["light label -1"]),
    ("float labels", lambda c: c.ml.clustered_shading(c.A, **_cs(c, light_labels=np.zeros(c.n))), ["integers"]),
    ("labels not one per light", lambda c: c.ml.clustered_shading(c.A, **_cs(c, light_labels=[0])),
     ["one label per light"]),
    ("NaN light centroid", lambda c: c.ml.clustered_shading(c.A, **_cs(c, light_centroids=np.full((1, 3), np.nan))),
     ["light_centroids", "nan"]),
    ("centroids (k, 2)", lambda c: c.ml.clustered_shading(c.A, **_cs(c, view_centroids=np.zeros((2, 2)))),
     ["view_centroids", "(k, 3)"]),
    ("no view centroids", lambda c: c.ml.clustered_shading(c.A, **_cs(c, view_centroids=np.zeros((0, 3)))),
     ["view_centroids", "k >= 1"]),
    ("inf view normal", lambda c: c.ml.clustered_shading(c.A, **_cs(c, view_normals=np.full((2, 3), np.inf))),
     ["view_normals", "inf"]),
    ("normals of another count", lambda c: c.ml.clustered_shading(c.A, **_cs(c, view_normals=np.ones((3, 3)))),
     ["view_normals", "shape"]),
    ("weights not summing to 1", lambda c: c.ml.clustered_shading(
        c.A, **_cs(c, membership_weights=np.full((c.m, 1), 0.5, np.float32))), ["sum to 1", "0.5"]),
    ("NaN weight", lambda c: c.ml.clustered_shading(
        c.A, **_cs(c, membership_weights=_nan_at(np.ones((c.m, 1), np.float32), (3, 0)))), ["membership_weights", "nan"]),
    ("negative weight", lambda c: c.ml.clustered_shading(c.A, **_cs(
        c, membership_clusters=np.zeros((c.m, 2), np.uint32),
        membership_weights=np.tile(np.float32([1.5, -0.5]), (c.m, 1)))), ["-0.5", ">= 0"]),
    ("cluster id out of range", lambda c: c.ml.clustered_shading(
        c.A, **_cs(c, membership_clusters=np.full((c.m, 1), 7))), ["membership cluster 7", "2 view centroids"]),
    ("membership rows != view samples", lambda c: c.ml.clustered_shading(c.A, **_cs(
        c, membership_clusters=np.zeros((3, 1), np.uint32), membership_weights=np.ones((3, 1), np.float32))),
     ["shape", "view sample"]),
    ("clusters and weights of other shapes", lambda c: c.ml.clustered_shading(
        c.A, **_cs(c, membership_weights=np.ones((c.m, 2), np.float32))), ["membership", "shape"]),
    ("F > view clusters", lambda c: c.ml.clustered_shading(c.A, **_cs(
        c, membership_clusters=np.zeros((c.m, 3), np.uint32),
        membership_weights=np.full((c.m, 3), 1 / 3, np.float32))), ["fuzziness", "got 3"]),
    ("A not a LightMatrix", lambda c: c.ml.clustered_shading("A", **_cs(c)), ["LightMatrix"]),
    ("string weights", lambda c: c.ml.clustered_shading(c.A, **_cs(c, membership_weights=np.full((c.m, 1), "x"))),
     ["membership_weights"]),
], raises=("ValueError", "TypeError"))
cases_for("native.clustered_shading", [
    ("native: label out of range", lambda c: _cs_native(c, light_labels=np.full(c.n, 9)), ["light label 9"]),
    ("native: cluster id out of range", lambda c: _cs_native(c, membership_clusters=np.full((c.m, 1), 2, np.uint32)),
     ["membership cluster 2"]),
    ("native: NaN view centroid", lambda c: _cs_native(c, view_centroids=np.full((2, 3), np.nan, np.float32)),
     ["view centroid 0", "NaN"]),
    ("native: centroids (k, 4)", lambda c: _cs_native(c, light_centroids=np.zeros((1, 4), np.float32)),
     ["light_centroids", "(k, 3)"]),
    ("native: weights of another shape", lambda c: _cs_native(c, membership_weights=np.ones((c.m, 2), np.float32)),
     ["membership_weights", "shape"]),
    ("native: F = 0", lambda c: _cs_native(c, membership_clusters=np.zeros((c.m, 0), np.uint32),
                                           membership_weights=np.ones((c.m, 0), np.float32)), ["got 0"]),
    ("native: float64 weights", lambda c: _cs_native(c, membership_weights=np.ones((c.m, 1))), []),
], raises=("ValueError", "TypeError"))

cases_for("TensorClustering.estimate", [
    ("other n", lambda c: c.ml.cluster_tensor(T4(4, 5, 3, 3), 5).estimate(T4(4, 6, 3, 3)), ["shape"]),
    ("other f", lambda c: c.ml.cluster_tensor(T4(4, 5, 3, 3), 5).estimate(T4(4, 5, 2, 3)), ["shape"]),
    ("NaN", lambda c: c.ml.cluster_tensor(T4(4, 5, 3, 3), 15).estimate(_nan_at(T4(4, 5, 3, 3), (1, 1, 1, 1))),
     ["non-finite"]),
    ("strings", lambda c: c.ml.cluster_tensor(T4(4, 5, 3, 3), 5).estimate(np.full((4, 5, 3, 3), "s")), ["'s'"]),
], raises=("ValueError", "TypeError"))
cases_for("TensorClustering.lights", [
    ("t out of range", lambda c: c.ml.cluster_tensor(T4(4, 5, 3, 3), 5).lights(5), ["t"]),
    ("negative t", lambda c: c.ml.cluster_tensor(T4(4, 5, 3, 3), 5).lights(-1), ["t"]),
])
cases_for("flicker", [
    ("one frame", lambda c: c.ml.flicker(IMG(1, 2, 2, 3) + 1, IMG(1, 2, 2, 3) + 1), ["2 frames"]),
    ("shapes differ", lambda c: c.ml.flicker(IMG(3, 2, 2, 3), IMG(3, 2, 3, 3) + 1), ["shape"]),
    ("not (f, H, W, 3)", lambda c: c.ml.flicker(IMG(2, 2, 3) + 1, IMG(2, 2, 3) + 1), ["(f, H, W, 3)"]),
    ("zero reference", lambda c: c.ml.flicker(IMG(3, 2, 2, 3), IMG(3, 2, 2, 3)), ["zero"]),
    ("NaN", lambda c: c.ml.flicker(np.full((3, 2, 2, 3), np.nan, np.float32), IMG(3, 2, 2, 3) + 1), ["non-finite"]),
    ("strings", lambda c: c.ml.flicker(np.full((2,), "a"), np.full((2,), "b")), ["'a'"]),
], raises=("ValueError", "TypeError"))
cases_for("relative_l2_per_frame", [
    ("zero reference frame", lambda c: c.ml.relative_l2_per_frame(IMG(2, 2, 2, 3) + 1,
                                                                   np.stack([IMG(2, 2, 3) + 1, IMG(2, 2, 3)])),
     ["frame 1"]),
    ("shapes differ", lambda c: c.ml.relative_l2_per_frame(IMG(3, 2, 2, 3), IMG(2, 2, 2, 3) + 1), ["shape"]),
    ("not (f, H, W, 3)", lambda c: c.ml.relative_l2_per_frame(IMG(2, 2, 3) + 1, IMG(2, 2, 3) + 1), ["(f, H, W, 3)"]),
    ("inf", lambda c: c.ml.relative_l2_per_frame(IMG(2, 2, 2, 3), np.full((2, 2, 2, 3), np.inf)), ["non-finite"]),
], raises=("ValueError", "TypeError"))

# --------------------------------------------------------------------------------------------------
# Gather cloud, cluster hierarchy, Haar wavelets.

_gather = lambda c: c._get("gather", lambda: c.ml.gather_cloud(c.scene, n=16))  # noqa: E731
F = lambda *shape: np.zeros(shape, np.float32)  # noqa: E731

cases_for("gather_cloud", [
    ("n = 0", lambda c: c.ml.gather_cloud(c.scene, n=0), ["power of 4", "got 0"]),
    ("n not a power of 4", lambda c: c.ml.gather_cloud(c.scene, n=8), ["power of 4", "got 8"]),
    ("n too large", lambda c: c.ml.gather_cloud(c.scene, n=4**13), ["power of 4"]),
    ("negative n", lambda c: c.ml.gather_cloud(c.scene, n=-4), ["n"]),
    ("fractional n", lambda c: c.ml.gather_cloud(c.scene, n=4.5), ["n"]),
    ("NaN n", lambda c: c.ml.gather_cloud(c.scene, n=float("nan")), ["n"]),
    ("negative seed", lambda c: c.ml.gather_cloud(c.scene, n=16, seed=-1), ["seed"]),
    ("not a scene", lambda c: c.ml.gather_cloud("scene.xml", n=16), ["Scene"]),
], raises=("ValueError", "TypeError"))
cases_for("native.gather_cloud", [
    ("n not a power of 4", lambda c: c.native.gather_cloud(c.scene, 32), ["power of 4", "got 32"]),
    ("negative n", lambda c: c.native.gather_cloud(c.scene, -16), ["power of 4", "-16"]),
])
cases_for("GatherCloud", [
    ("no constructor (made by gather_cloud)", lambda c: c.ml.GatherCloud(), ["cannot create"]),
], raises=("TypeError",))
cases_for("GatherCloud.on", [
    ("another topology", lambda c: _gather(c).on(c.ml.load_scene(REPO / "scenes" / "cbox" / "scene.xml", res=8)),
     ["shape", "topology"]),
], raises=("ValueError",))
cases_for("GatherCloud.on", [
    ("not a scene", lambda c: _gather(c).on(None), ["scene"]),
], raises=("TypeError",))
cases_for("GatherCloud.hierarchy", [
    ("K = 0", lambda c: _gather(c).hierarchy(K=0.0), ["K", "got 0"]),
    ("NaN K", lambda c: _gather(c).hierarchy(K=float("nan")), ["K", "NaN"]),
    ("inf K", lambda c: _gather(c).hierarchy(K=float("inf")), ["K", "inf"]),
])
cases_for("native.haar2d", [
    ("not square", lambda c: c.native.haar2d(F(4, 2)), ["shape"]),
    ("side 3", lambda c: c.native.haar2d(F(3, 3)), ["2^k"]),
    ("empty", lambda c: c.native.haar2d(F(0, 0)), ["2^k"]),
    ("4-D", lambda c: c.native.haar2d(F(2, 2, 3, 1)), ["shape"]),
    ("NaN (names the pixel)", lambda c: c.native.haar2d(_nan_at(F(4, 4, 3), (1, 2, 0))), ["image[1, 2, 0]"]),
])
cases_for("native.haar2d", [
    ("float64", lambda c: c.native.haar2d(np.zeros((4, 4))), ["float"]),
], raises=("TypeError",))
cases_for("native.ihaar2d", [
    ("side 6", lambda c: c.native.ihaar2d(F(6, 6)), ["2^k"]),
    ("inf", lambda c: c.native.ihaar2d(_nan_at(F(2, 2), (1, 1), np.inf)), ["coeffs[1, 1]"]),
])
cases_for("native.haar_support_area", [
    ("side 0", lambda c: c.native.haar_support_area(0), ["power of 2", "got 0"]),
    ("side 12", lambda c: c.native.haar_support_area(12), ["power of 2", "got 12"]),
    ("huge side", lambda c: c.native.haar_support_area(2**40), ["power of 2"]),
])
cases_for("native.haar_cull_area_weighted", [
    ("negative keep", lambda c: c.native.haar_cull_area_weighted(F(4, 4), -1), ["keep"]),
    ("not square", lambda c: c.native.haar_cull_area_weighted(F(4, 8), 3), ["shape"]),
    ("NaN", lambda c: c.native.haar_cull_area_weighted(_nan_at(F(2, 2), (0, 1)), 1), ["coeffs[0, 1]"]),
])
cases_for("native.cull_wavelet_lights", [
    ("negative epsilon", lambda c: c.native.cull_wavelet_lights(F(4, 3), F(4), -1.0), ["epsilon"]),
    ("NaN epsilon", lambda c: c.native.cull_wavelet_lights(F(4, 3), F(4), float("nan")), ["epsilon"]),
    ("length mismatch", lambda c: c.native.cull_wavelet_lights(F(4, 3), F(5), 0.0), ["image norms"]),
    ("2-D norms", lambda c: c.native.cull_wavelet_lights(F(4, 3), F(4, 1), 0.0), ["image_norms"]),
    ("3-D light", lambda c: c.native.cull_wavelet_lights(F(4, 3, 1), F(4), 0.0), ["light"]),
    ("negative norm", lambda c: c.native.cull_wavelet_lights(F(4, 3), -np.ones(4, np.float32), 0.0), ["norm 0"]),
    ("inf light", lambda c: c.native.cull_wavelet_lights(_nan_at(F(4, 3), (2, 1), np.inf), F(4), 0.0), ["light 2"]),
])
_d2i = lambda c: c._get("d2i", lambda: c.ml.DirectToIndirect(c.scene, gather=16, final_gather_coefficients=4))  # noqa: E731
cases_for("DirectToIndirect", [
    ("gather not a power of 4", lambda c: c.ml.DirectToIndirect(c.scene, gather=32, final_gather_coefficients=4), ["power of 4", "32"]),
    ("gather = 0", lambda c: c.ml.DirectToIndirect(c.scene, gather=0, final_gather_coefficients=4), ["gather"]),
    ("fractional gather", lambda c: c.ml.DirectToIndirect(c.scene, gather=16.5, final_gather_coefficients=4), ["gather"]),
    ("coefficients > gather", lambda c: c.ml.DirectToIndirect(c.scene, gather=16, final_gather_coefficients=17), ["at most", "17"]),
    ("coefficients = 0", lambda c: c.ml.DirectToIndirect(c.scene, gather=16, final_gather_coefficients=0), ["final_gather_coefficients"]),
    ("negative threshold", lambda c: c.ml.DirectToIndirect(c.scene, gather=16, final_gather_coefficients=4, threshold=-1), ["threshold"]),
    ("NaN threshold", lambda c: c.ml.DirectToIndirect(c.scene, gather=16, final_gather_coefficients=4, threshold=float("nan")), ["threshold"]),
    ("clamp 0", lambda c: c.ml.DirectToIndirect(c.scene, gather=16, final_gather_coefficients=4, clamp=0), ["clamp"]),
    ("K 0", lambda c: c.ml.DirectToIndirect(c.scene, gather=16, final_gather_coefficients=4, K=0), ["K"]),
    ("unknown near_field", lambda c: c.ml.DirectToIndirect(c.scene, gather=16, final_gather_coefficients=4, near_field="sphere"), ["near_field", "sphere"]),
    ("bounces 0", lambda c: c.ml.DirectToIndirect(c.scene, gather=16, final_gather_coefficients=4, bounces=0), ["bounces"]),
    ("multibounce_coefficients > gather", lambda c: c.ml.DirectToIndirect(c.scene, gather=16, final_gather_coefficients=4, bounces=2, multibounce_coefficients=17), ["multibounce_coefficients", "17"]),
    ("negative seed", lambda c: c.ml.DirectToIndirect(c.scene, gather=16, final_gather_coefficients=4, seed=-1), ["seed"]),
    ("not a scene", lambda c: c.ml.DirectToIndirect("scene.xml", gather=16, final_gather_coefficients=4), ["Scene"]),
], raises=("ValueError", "TypeError"))
cases_for("native.DirectToIndirect", [
    ("gather not a power of 4", lambda c: c.native.DirectToIndirect(c.scene, 32, 4, 0, 0.0, float("inf"), 30.0), ["power of 4", "32"]),
    ("coefficients > gather", lambda c: c.native.DirectToIndirect(c.scene, 16, 17, 0, 0.0, float("inf"), 30.0), ["17"]),
    ("negative threshold", lambda c: c.native.DirectToIndirect(c.scene, 16, 4, 0, -1.0, float("inf"), 30.0), ["threshold"]),
    ("clamp 0", lambda c: c.native.DirectToIndirect(c.scene, 16, 4, 0, 0.0, 0.0, 30.0), ["clamp"]),
    ("K NaN", lambda c: c.native.DirectToIndirect(c.scene, 16, 4, 0, 0.0, float("inf"), float("nan")), ["K"]),
    ("bounces 0", lambda c: c.native.DirectToIndirect(c.scene, 16, 4, 0, 0.0, float("inf"), 30.0, 0), ["bounces"]),
    ("unknown near_field", lambda c: c.native.DirectToIndirect(c.scene, 16, 4, 0, 0.0, float("inf"), 30.0, 1, 40, None, near_field="sphere"), ["near_field", "sphere"]),
    ("multibounce_coefficients 0", lambda c: c.native.DirectToIndirect(c.scene, 16, 4, 0, 0.0, float("inf"), 30.0, 2, 0), ["multibounce_coefficients"]),
])
cases_for("DirectToIndirect.relight", [
    ("empty LightSet", lambda c: _d2i(c).relight(c.lights[0:0]), ["empty"]),
    ("negative epsilon", lambda c: _d2i(c).relight(c.lights, epsilon=-1.0), ["epsilon"]),
    ("NaN epsilon", lambda c: _d2i(c).relight(c.lights, epsilon=float("nan")), ["epsilon"]),
    ("not a LightSet", lambda c: _d2i(c).relight(np.zeros((3, 3))), ["LightSet"]),
], raises=("ValueError", "TypeError"))
cases_for("DirectToIndirect.gather_irradiance", [
    ("empty LightSet", lambda c: _d2i(c).gather_irradiance(c.lights[0:0]), ["empty"]),
    ("not a LightSet", lambda c: _d2i(c).gather_irradiance(None), ["LightSet"]),
], raises=("ValueError", "TypeError"))

# Saving and loading a precomputation (tests/relight/test_relight_store.py has the scene-change cases).
_d2i_file = lambda c: c._get("d2i_file", lambda: _d2i(c).save(c.tmp / "d2i.npz"))  # noqa: E731


def _d2i_rewritten(c, name, **changes):
    with np.load(_d2i_file(c), allow_pickle=False) as z:
        arrays = {k: z[k] for k in z.files}
    arrays.update(changes)
    np.savez(c.tmp / name, **arrays)
    return c.tmp / name


cases_for("DirectToIndirect.save", [
    ("missing folder", lambda c: _d2i(c).save(c.tmp / "no-such-folder" / "x.npz"), ["no-such-folder"]),
    ("folder is a file", lambda c: _d2i(c).save(c.file("plain.txt", b"x") / "x.npz"), ["plain.txt"]),
], raises=("OSError",))
cases_for("DirectToIndirect.save", [
    ("path not a path", lambda c: _d2i(c).save(3.5), ["path"]),
], raises=("TypeError",))
cases_for("DirectToIndirect.load", [
    ("truncated", lambda c: c.ml.DirectToIndirect.load(c.file("d2i-half.npz", _d2i_file(c).read_bytes()[:2000]), c.scene), ["truncated"]),
    ("png renamed", lambda c: c.ml.DirectToIndirect.load(c.file("d2i-png.npz", c.png_bytes), c.scene), ["not a manylights relighting file"]),
    ("random bytes", lambda c: c.ml.DirectToIndirect.load(c.file("d2i-rand.npz", bytes(range(256)) * 8), c.scene), ["not a manylights relighting file"]),
    ("empty file", lambda c: c.ml.DirectToIndirect.load(c.file("d2i-empty.npz", b""), c.scene), ["d2i-empty.npz"]),
    ("wrong version", lambda c: c.ml.DirectToIndirect.load(_d2i_rewritten(c, "d2i-v9.npz", version=np.array(9, np.uint32)), c.scene), ["version 9"]),
    ("film changed", lambda c: c.ml.DirectToIndirect.load(_d2i_file(c), c.ml.load_scene(REPO / "scenes" / "demo" / "scene.xml", res=12)), ["film changed"]),
    ("gather not a power of 4", lambda c: c.ml.DirectToIndirect.load(_d2i_rewritten(c, "d2i-g.npz", **{"options.gather": np.array(32, np.uint64)}), c.scene), ["power of 4", "32"]),
], raises=("ValueError",))
cases_for("DirectToIndirect.load", [
    ("missing file", lambda c: c.ml.DirectToIndirect.load(c.tmp / "absent.npz", c.scene), ["absent.npz"]),
], raises=("OSError",))
cases_for("DirectToIndirect.load", [
    ("not a scene", lambda c: c.ml.DirectToIndirect.load(_d2i_file(c), "scene.xml"), ["Scene"]),
], raises=("TypeError",))
cases_for("native.transfer_arrays", [
    ("not a DirectToIndirect", lambda c: c.native.transfer_arrays(c.scene), ["DirectToIndirect"]),
], raises=("TypeError",))
cases_for("native.transfer_from_arrays", [
    ("no arrays", lambda c: c.native.transfer_from_arrays(c.scene, []), ["options.gather"]),
    ("wrong shape", lambda c: c.native.transfer_from_arrays(c.scene, [(n, a.reshape(1, -1) if n == "size" else a) for n, a in c.native.transfer_arrays(_d2i(c))]), ["size", "[1, 2]"]),
], raises=("ValueError",))
cases_for("native.transfer_from_arrays", [
    ("int8 array", lambda c: c.native.transfer_from_arrays(c.scene, [("options.gather", np.zeros(1, np.int8))]), ["options.gather", "int8"]),
    ("not a list", lambda c: c.native.transfer_from_arrays(c.scene, 3), ["int"]),
], raises=("TypeError",))
cases_for("native.transfer_scene_hash", [
    ("not a scene", lambda c: c.native.transfer_scene_hash("scene.xml"), ["Scene"]),
], raises=("TypeError",))

# --------------------------------------------------------------------------------------------------
# Renderers.

cases_for("mrcs", [
    ("not a matrix", lambda c: c.ml.mrcs("A"), ["LightMatrix"]),
], raises=("TypeError",))
cases_for("mrcs", [
    ("zero rows", lambda c: c.ml.mrcs(c.A, rows=0, columns=2), ["r"]),
    ("zero columns", lambda c: c.ml.mrcs(c.A, rows=4, columns=0), ["c"]),
    ("more columns than lights", lambda c: c.ml.mrcs(c.A, rows=4, columns=c.n + 1), ["c"]),
    ("row index out of range", lambda c: c.ml.mrcs(c.A, columns=2, row_indices=[c.m]), ["range"]),
    ("clustering without weights", lambda c: c.ml.mrcs(c.A, clustering={"representatives": [0]}), ["weights"]),
    ("clustering weights wrong shape", lambda c: c.ml.mrcs(
        c.A, clustering={"representatives": [0, 1], "weights": np.ones((3, 3))}), ["weights"]),
    ("clustering NaN weights", lambda c: c.ml.mrcs(
        c.A, clustering={"representatives": [0], "weights": np.full((1, 3), np.nan)}), ["nan"]),
    ("clustering representative out of range", lambda c: c.ml.mrcs(
        c.A, clustering={"representatives": [c.n], "weights": np.ones((1, 3))}), ["range"]),
])
cases_for("mrcs", [
    ("negative error_rows", lambda c: c.ml.mrcs(c.A, rows=4, columns=2, error_rows=-1), ["error_rows"]),
    ("error_rows past the pixels", lambda c: c.ml.mrcs(c.A, rows=4, columns=2, error_rows=c.m + 1), ["error_rows"]),
    ("halves with one column", lambda c: c.ml.mrcs(c.A, rows=4, columns=1, halves=True), ["columns"]),
    ("halves with one light", lambda c: c.ml.mrcs(c.ml.LightMatrix(c.scene, c.ml.LightSet.from_arrays(
        c.scene, kind=0, position=[[0, 1, 0]], intensity=[[1, 1, 1]]), device="cpu"), rows=4, columns=2, halves=True),
     ["halves=True needs >= 2 lights", "has 1"]),
    ("halves with a given clustering", lambda c: c.ml.mrcs(
        c.A, halves=True, clustering={"representatives": [0], "weights": np.ones((1, 3))}), ["halves"]),
])
cases_for("mrcs_progressive", [
    ("not a matrix", lambda c: c.ml.mrcs_progressive("A", rounds=2), ["LightMatrix"]),
], raises=("TypeError",))
cases_for("mrcs_progressive", [
    ("ints without rounds", lambda c: c.ml.mrcs_progressive(c.A, rows=4, columns=2), ["rounds"]),
    ("zero rounds", lambda c: c.ml.mrcs_progressive(c.A, rows=4, columns=2, rounds=0), ["rounds"]),
    ("NaN rounds", lambda c: c.ml.mrcs_progressive(c.A, rows=4, columns=2, rounds=float("nan")), ["rounds"]),
    ("one column per round", lambda c: c.ml.mrcs_progressive(c.A, rows=4, columns=1, rounds=2), ["2 new columns"]),
    ("decreasing columns", lambda c: c.ml.mrcs_progressive(c.A, rows=[4, 8], columns=[4, 2]), ["increasing"]),
    ("repeated columns", lambda c: c.ml.mrcs_progressive(c.A, rows=[4, 8], columns=[4, 4]), ["strictly increasing"]),
    ("decreasing rows", lambda c: c.ml.mrcs_progressive(c.A, rows=[8, 4], columns=[2, 4]), ["rows", "non-decreasing"]),
    ("empty columns", lambda c: c.ml.mrcs_progressive(c.A, rows=[], columns=[]), ["at least one"]),
    ("rounds do not match the list", lambda c: c.ml.mrcs_progressive(c.A, rows=[4, 8], columns=[2, 4], rounds=3),
     ["rounds"]),
    ("rows and columns rounds differ", lambda c: c.ml.mrcs_progressive(c.A, rows=[4, 8, 12], columns=[2, 4]),
     ["rounds"]),
    ("more columns than lights", lambda c: c.ml.mrcs_progressive(c.A, rows=4, columns=c.n, rounds=2), ["lights"]),
    ("more rows than pixels", lambda c: c.ml.mrcs_progressive(c.A, rows=c.m, columns=2, rounds=2), ["rows"]),
    ("negative seed", lambda c: c.ml.mrcs_progressive(c.A, rows=4, columns=2, rounds=2, seed=-1), ["seed"]),
])
cases_for("render", [
    ("not a matrix", lambda c: c.ml.render(None, target_error=0.1), ["LightMatrix"]),
], raises=("TypeError",))
cases_for("render", [
    ("no target and no budget", lambda c: c.ml.render(c.A), ["target_error"]),
    ("zero target", lambda c: c.ml.render(c.A, target_error=0.0), ["target_error"]),
    ("negative target", lambda c: c.ml.render(c.A, target_error=-0.02), ["target_error"]),
    ("NaN target", lambda c: c.ml.render(c.A, target_error=float("nan")), ["target_error"]),
    ("zero time budget", lambda c: c.ml.render(c.A, time_budget=0), ["time_budget"]),
    ("negative time budget", lambda c: c.ml.render(c.A, time_budget=-1.0), ["time_budget"]),
    ("inf time budget", lambda c: c.ml.render(c.A, time_budget=float("inf")), ["time_budget"]),
    ("one first column", lambda c: c.ml.render(c.A, target_error=0.1, first_columns=1), ["first_columns"]),
    ("zero max_rounds", lambda c: c.ml.render(c.A, target_error=0.1, max_rounds=0), ["max_rounds"]),
    ("negative seed", lambda c: c.ml.render(c.A, target_error=0.1, seed=-1), ["seed"]),
    ("zero rows_per_column", lambda c: c.ml.render(c.A, target_error=0.1, rows_per_column=0), ["rows_per_column"]),
    ("rows_per_column above 1", lambda c: c.ml.render(c.A, target_error=0.1, rows_per_column=2), ["rows_per_column"]),
])
DEMO_XML = REPO / "scenes" / "demo" / "scene.xml"
cases_for("render[scene path]", [
    ("zero target", lambda c: c.ml.render(DEMO_XML, target_error=0.0), ["target_error"]),
    ("NaN target", lambda c: c.ml.render(DEMO_XML, target_error=float("nan")), ["target_error"]),
    ("negative time budget", lambda c: c.ml.render(DEMO_XML, time_budget=-1.0), ["time_budget"]),
    ("no target and no budget", lambda c: c.ml.render(DEMO_XML), ["target_error"]),
    ("odd first_lights", lambda c: c.ml.render(DEMO_XML, target_error=0.1, first_lights=5), ["first_lights"]),
    ("max_lights below first_lights", lambda c: c.ml.render(DEMO_XML, target_error=0.1, max_lights=4),
     ["max_lights"]),
    ("generation_share 0", lambda c: c.ml.render(DEMO_XML, target_error=0.1, generation_share=0), ["generation_share"]),
    ("max_depth 1", lambda c: c.ml.render(DEMO_XML, target_error=0.1, max_depth=1), ["max_depth"]),
])
cases_for("render[scene path]", [
    ("missing scene file", lambda c: c.ml.render(c.tmp / "missing.xml", target_error=0.1), ["missing.xml"]),
], raises=("FileNotFoundError",))
cases_for("render[scene path]", [
    ("scene options with a matrix", lambda c: c.ml.render(c.A, target_error=0.1, first_lights=64), ["first_lights"]),
], raises=("TypeError",))
cases_for("native.mrcs_row_variance", [
    ("label out of range", lambda c: c.ml._native.mrcs_row_variance(
        np.ones((2, 3, 3), np.float32), np.array([0, 1, 5], np.int32), np.full(3, 0.5), 2), ["assignment[2]"]),
    ("negative label", lambda c: c.ml._native.mrcs_row_variance(
        np.ones((2, 3, 3), np.float32), np.array([0, -1, 0], np.int32), np.full(3, 0.5), 2), ["-1"]),
    ("probability above 1", lambda c: c.ml._native.mrcs_row_variance(
        np.ones((2, 3, 3), np.float32), np.zeros(3, np.int32), np.array([0.5, 2.0, 0.5]), 1), ["probability[1]"]),
    ("NaN probability", lambda c: c.ml._native.mrcs_row_variance(
        np.ones((2, 3, 3), np.float32), np.zeros(3, np.int32), np.array([0.5, np.nan, 0.5]), 1), ["probability[1]"]),
    ("wrong length", lambda c: c.ml._native.mrcs_row_variance(
        np.ones((2, 3, 3), np.float32), np.zeros(2, np.int32), np.full(3, 0.5), 1), ["n = 3"]),
    ("NaN row", lambda c: c.ml._native.mrcs_row_variance(
        np.full((2, 3, 3), np.nan, np.float32), np.zeros(3, np.int32), np.full(3, 0.5), 1), ["non-finite"]),
    ("bad shape", lambda c: c.ml._native.mrcs_row_variance(
        np.ones((2, 3, 2), np.float32), np.zeros(3, np.int32), np.full(3, 0.5), 1), ["shape"]),
])
cases_for("power_sampling", [
    ("zero columns", lambda c: c.ml.power_sampling(c.A, columns=0), ["columns"]),
    ("fractional columns", lambda c: c.ml.power_sampling(c.A, columns=2.5), ["columns"]),
    ("NaN columns", lambda c: c.ml.power_sampling(c.A, columns=float("nan")), ["columns"]),
    ("huge columns", lambda c: c.ml.power_sampling(c.A, columns=10**12), ["columns"]),
    ("negative seed", lambda c: c.ml.power_sampling(c.A, columns=2, seed=-1), ["seed"]),
    ("not a matrix", lambda c: c.ml.power_sampling(None, columns=2), ["LightMatrix"]),
], raises=("ValueError", "TypeError"))
cases_for("LightTree", [
    ("empty LightSet", lambda c: c.ml.LightTree(c.lights[np.zeros(len(c.lights), dtype=bool)]), ["empty"]),
    ("not a LightSet", lambda c: c.ml.LightTree(None), ["LightSet"]),
], raises=("ValueError", "TypeError"))
cases_for("LightTree.pdf", [
    ("sample out of range", lambda c: c.ml.LightTree(c.lights).pdf(c.A._m, 10**6), ["out of range"]),
    ("other LightSet", lambda c: c.ml.LightTree(c.lights[:1]).pdf(c.A._m, 0), ["another LightSet"]),
])
cases_for("light_bvh_sampling", [
    ("zero samples", lambda c: c.ml.light_bvh_sampling(c.A, samples=0), ["samples"]),
    ("fractional samples", lambda c: c.ml.light_bvh_sampling(c.A, samples=2.5), ["samples"]),
    ("negative seed", lambda c: c.ml.light_bvh_sampling(c.A, seed=-1), ["seed"]),
    ("not a matrix", lambda c: c.ml.light_bvh_sampling(None), ["LightMatrix"]),
    ("tree not a LightTree", lambda c: c.ml.light_bvh_sampling(c.A, tree=3), ["LightTree"]),
    ("tree over other lights", lambda c: c.ml.light_bvh_sampling(c.A, tree=c.ml.LightTree(c.lights[:1])),
     ["another LightSet"]),
], raises=("ValueError", "TypeError"))
cases_for("ris_sampling", [
    ("zero candidates", lambda c: c.ml.ris_sampling(c.A, candidates=0), ["candidates"]),
    ("zero samples", lambda c: c.ml.ris_sampling(c.A, samples=0), ["samples"]),
    ("negative neighbours", lambda c: c.ml.ris_sampling(c.A, neighbours=-1), ["neighbours"]),
    ("zero radius", lambda c: c.ml.ris_sampling(c.A, neighbours=2, radius=0), ["radius"]),
    ("not a matrix", lambda c: c.ml.ris_sampling(None), ["LightMatrix"]),
], raises=("ValueError", "TypeError"))
cases_for("lightcuts", [
    ("zero error", lambda c: c.ml.lightcuts(c.A, error=0), ["error"]),
    ("NaN error", lambda c: c.ml.lightcuts(c.A, error=float("nan")), ["error"]),
    ("zero max_cut", lambda c: c.ml.lightcuts(c.A, max_cut=0), ["max_cut"]),
    ("unknown criterion", lambda c: c.ml.lightcuts(c.A, criterion="sum"), ["criterion"]),
    ("not a matrix", lambda c: c.ml.lightcuts(None), ["LightMatrix"]),
    ("negative probes", lambda c: c.ml.lightcuts(c.A, error_probes=-1), ["error_probes"]),
], raises=("ValueError", "TypeError"))
cases_for("reconstruction_cuts", [
    ("zero block", lambda c: c.ml.reconstruction_cuts(c.A, block=0), ["block"]),
    ("negative error", lambda c: c.ml.reconstruction_cuts(c.A, error=-0.02), ["error"]),
    ("zero max_cut", lambda c: c.ml.reconstruction_cuts(c.A, max_cut=0), ["max_cut"]),
    ("negative probes", lambda c: c.ml.reconstruction_cuts(c.A, error_probes=-3), ["error_probes"]),
], raises=("ValueError", "TypeError"))
cases_for("native.lightcuts", [
    ("zero error", lambda c: c.native.lightcuts(c.A._m, 0.0, 10, 0), ["error"]),
    ("zero max_cut", lambda c: c.native.lightcuts(c.A._m, 0.02, 0, 0), ["max_cut"]),
    ("unknown criterion", lambda c: c.native.lightcuts(c.A._m, 0.02, 10, 0, 0, "sum"), ["criterion"]),
])
cases_for("stochastic_lightcuts", [
    ("zero cut size", lambda c: c.ml.stochastic_lightcuts(c.A, cut_size=0), ["cut_size"]),
    ("fractional cut size", lambda c: c.ml.stochastic_lightcuts(c.A, cut_size=2.5), ["cut_size"]),
    ("zero samples", lambda c: c.ml.stochastic_lightcuts(c.A, samples=0), ["samples"]),
    ("negative seed", lambda c: c.ml.stochastic_lightcuts(c.A, seed=-1), ["seed"]),
    ("not a matrix", lambda c: c.ml.stochastic_lightcuts(None), ["LightMatrix"]),
    ("tree over other lights", lambda c: c.ml.stochastic_lightcuts(c.A, tree=c.ml.LightTree(c.lights[:1])),
     ["another LightSet"]),
], raises=("ValueError", "TypeError"))
cases_for("lightslice", [
    ("zero slices", lambda c: c.ml.lightslice(c.A, slices=0), ["slices"]),
    ("zero columns", lambda c: c.ml.lightslice(c.A, columns=0), ["columns"]),
    ("global above columns", lambda c: c.ml.lightslice(c.A, columns=4, global_columns=5), ["global_columns"]),
    ("zero neighbours", lambda c: c.ml.lightslice(c.A, neighbours=0), ["neighbours"]),
    ("NaN normal weight", lambda c: c.ml.lightslice(c.A, normal_weight=np.nan), ["normal_weight"]),
    ("negative seed", lambda c: c.ml.lightslice(c.A, seed=-1), ["seed"]),
    ("not a matrix", lambda c: c.ml.lightslice(None), ["LightMatrix"]),
    ("probes not an integer", lambda c: c.ml.lightslice(c.A, error_probes=2.5), ["error_probes"]),
], raises=("ValueError", "TypeError"))
cases_for("native.stochastic_lightcuts", [
    ("zero cut size", lambda c: c.native.stochastic_lightcuts(c.A._m, 0, 1, 0), ["cut_size"]),
])
cases_for("native.lightslice", [
    ("global above columns", lambda c: c.native.lightslice(c.A._m, 4, 4, 5, 2, 0.25, 0), ["global_columns"]),
    ("NaN normal weight", lambda c: c.native.lightslice(c.A._m, 4, 4, 2, 2, float("nan"), 0), ["normal_weight"]),
])
cases_for("native.light_bvh_sampling", [
    ("zero samples", lambda c: c.native.light_bvh_sampling(c.A._m, 0, 0), ["samples"]),
])
cases_for("native.ris", [
    ("zero candidates", lambda c: c.native.ris(c.A._m, 1, 0, 0), ["candidates"]),
    ("zero radius", lambda c: c.native.ris(c.A._m, 1, 2, 0, None, 2, 0), ["radius"]),
])
for _metric in ("relmse", "smape"):
    cases_for(_metric, [
        ("zero eps", lambda c, f=_metric: getattr(c.ml, f)(IMG(2, 2, 3), IMG(2, 2, 3), eps=0.0), ["eps"]),
        ("NaN eps", lambda c, f=_metric: getattr(c.ml, f)(IMG(2, 2, 3), IMG(2, 2, 3), eps=np.nan), ["eps"]),
        ("shapes differ", lambda c, f=_metric: getattr(c.ml, f)(IMG(2, 2, 3), IMG(2, 3, 3)), ["shape"]),
        ("NaN image", lambda c, f=_metric: getattr(c.ml, f)(np.full((2, 2, 3), np.nan), IMG(2, 2, 3)),
         ["non-finite"]),
    ])
cases_for("metrics.flip", [
    ("negative radiance", lambda c: c.ml.metrics.flip(IMG(4, 4, 3) - 1, IMG(4, 4, 3)), ["negative"]),
    ("not (H, W, 3)", lambda c: c.ml.metrics.flip(IMG(4, 4), IMG(4, 4)), ["(H, W, 3)"]),
])
cases_for("instant_radiosity", [
    ("zero lights", lambda c: c.ml.instant_radiosity(c.scene, lights=0), ["lights"]),
    ("fractional lights", lambda c: c.ml.instant_radiosity(c.scene, lights=2.5), ["lights"]),
    ("area_fraction 2", lambda c: c.ml.instant_radiosity(c.scene, lights=8, area_fraction=2.0), ["area_fraction"]),
    ("NaN environment_fraction", lambda c: c.ml.instant_radiosity(c.scene, lights=8, environment_fraction=np.nan),
     ["environment_fraction"]),
    ("not a scene", lambda c: c.ml.instant_radiosity(None, lights=8), ["Scene"]),
], raises=("ValueError", "TypeError"))
cases_for("render_brute_force", [
    ("weights wrong length", lambda c: c.ml.render_brute_force(c.scene, c.lights, weights=[1.0], progress=False),
     ["length"]),
    ("unknown visibility", lambda c: c.ml.render_brute_force(c.scene, c.lights, visibility="x", progress=False),
     ["visibility"]),
    ("shadow map 1", lambda c: c.ml.render_brute_force(c.scene, c.lights, shadow_map_size=1, progress=False),
     ["shadow_map_size"]),
])

# --------------------------------------------------------------------------------------------------
# Native-only functions (documented in _native.pyi).

_D = lambda *v: np.array([v], np.float32)  # noqa: E731
UP = _D(0, 0, 1)
cases_for("native.bsdf_eval", [
    ("spec not a dict", lambda c: c.native.bsdf_eval("diffuse", UP, UP, "cpu"), ["dict"]),
    ("unknown type", lambda c: c.native.bsdf_eval({"type": "velvet"}, UP, UP, "cpu"), ["velvet"]),
    ("no type", lambda c: c.native.bsdf_eval({"alpha": 0.1}, UP, UP, "cpu"), ["type"]),
    ("wi (N, 2)", lambda c: c.native.bsdf_eval({"type": "diffuse"}, np.zeros((1, 2), np.float32), UP, "cpu"),
     ["shape"]),
    ("wi/wo lengths differ", lambda c: c.native.bsdf_eval({"type": "diffuse"}, np.repeat(UP, 2, 0), UP, "cpu"),
     ["wi", "wo"]),
    ("NaN direction", lambda c: c.native.bsdf_eval({"type": "diffuse"}, _D(np.nan, 0, 1), UP, "cpu"), ["nan"]),
    ("unknown device", lambda c: c.native.bsdf_eval({"type": "diffuse"}, UP, UP, "tpu"), ["tpu"]),
    ("NaN alpha", lambda c: c.native.bsdf_eval({"type": "roughplastic", "alpha": float("nan")}, UP, UP, "cpu"),
     ["alpha"]),
    ("reflectance of 2 values", lambda c: c.native.bsdf_eval(
        {"type": "diffuse", "reflectance": [0.5, 0.5]}, UP, UP, "cpu"), ["reflectance"]),
    ("string parameter", lambda c: c.native.bsdf_eval({"type": "roughplastic", "alpha": "x"}, UP, UP, "cpu"),
     ["alpha"]),
], raises=("ValueError", "TypeError"))
cases_for("native.load_scene", [
    ("params not pairs", lambda c: c.native.load_scene(str(REPO / "scenes" / "demo" / "scene.xml"), [("res",)]),
     ["tuple of length 2"]),
    ("size zero", lambda c: c.native.load_scene(str(REPO / "scenes" / "demo" / "scene.xml"), [], (0, 8)),
     ["0x8"]),
], raises=("ValueError", "TypeError", "SceneError"))
cases_for("native.scene_lights", [("not a scene", lambda c: c.native.scene_lights(3), ["Scene"])],
          raises=("TypeError",))
cases_for("native.encode_exr", [
    ("float64 image", lambda c: c.native.encode_exr(np.zeros((2, 2, 3))), ["float32"]),
    ("2-D image", lambda c: c.native.encode_exr(np.zeros((2, 2), np.float32)), ["(H, W, 3)"]),
], raises=("TypeError", "ValueError"))
cases_for("native.encode_png", [
    ("float64 image", lambda c: c.native.encode_png(np.zeros((2, 2, 3))), ["float32"]),
    ("NaN exposure", lambda c: c.native.encode_png(np.zeros((2, 2, 3), np.float32), float("nan")),
     ["exposure"]),
], raises=("TypeError", "ValueError"))
cases_for("scenes.scene_path", [
    ("unknown scene", lambda c: __import__("manylights.scenes").scenes.scene_path("nope"), ["nope", "cbox"]),
    ("path escape", lambda c: __import__("manylights.scenes").scenes.scene_path("../scenes/cbox"), ["bundled"]),
    ("not a string", lambda c: __import__("manylights.scenes").scenes.scene_path(3), ["string"]),
], raises=("FileNotFoundError", "TypeError"))
cases_for("scenes.resolve", [
    ("neither file nor scene", lambda c: __import__("manylights.scenes").scenes.resolve("x.xml"), ["x.xml"]),
], raises=("FileNotFoundError",))
cases_for("native.stratified_rows", [
    ("zero width", lambda c: c.native.stratified_rows(0, 8, 1), ["0x8"]),
    ("r > pixels", lambda c: c.native.stratified_rows(2, 2, 5), ["r"]),
    ("huge image", lambda c: c.native.stratified_rows(2**31, 2**31, 10**12), ["r"]),
], raises=("ValueError", "OverflowError"))
cases_for("native.generate_lights", [
    ("huge area count", lambda c: c.native.generate_lights(c.scene, 10**15, 0, 0, 5, None, False, 0), ["area"]),
])
cases_for("native.cluster_reduced_columns", [
    ("float64 R", lambda c: c.native.cluster_reduced_columns(np.zeros((2, 4)), 2), ["float64", "float32"]),
], raises=("TypeError", "ValueError"))
cases_for("native.clustering_cost", [
    ("float labels", lambda c: c.native.clustering_cost(R(2, 4), [0.5] * 4), ["integer"]),
], raises=("TypeError",))

# Animations, pixel mappings, anti-aliasing.
DEMO = REPO / "scenes" / "demo" / "scene.xml"


def _anim(c):
    return c._get("anim", lambda: c.ml.load_animation(DEMO, frames=[{}, {}], res=8))


def _tiny(c, name, shapes, size=8):
    return c.file(name, f"""<scene version="3.0.0"><sensor type="perspective">
        <film type="hdrfilm"><integer name="width" value="{size}"/><integer name="height" value="{size}"/></film>
        </sensor>{shapes}</scene>""".encode())


cases_for("load_animation", [
    ("empty frame list", lambda c: c.ml.load_animation(DEMO, frames=[]), ["empty"]),
    ("no frames for one file", lambda c: c.ml.load_animation(DEMO), ["frames is required"]),
    ("undeclared parameter", lambda c: c.ml.load_animation(DEMO, frames=[{}, {"wobble": 1}], res=8),
     ["frame 1", "wobble"]),
    ("different topology", lambda c: c.ml.load_animation(
        [_tiny(c, "t1.xml", '<shape type="cube" id="a"/>'), _tiny(c, "t2.xml", '<shape type="rectangle" id="a"/>')]),
     ["frame 1", "shape 0 'a'", "triangles"]),
    ("different film sizes", lambda c: c.ml.load_animation(
        [_tiny(c, "t1.xml", '<shape type="cube" id="a"/>'), _tiny(c, "t3.xml", '<shape type="cube" id="a"/>', 4)]),
     ["frame 1", "4x4"]),
    ("missing file", lambda c: c.ml.load_animation([DEMO, c.tmp / "nope.xml"], res=8), ["frame 1", "nope.xml"]),
    ("frame not a dict", lambda c: c.ml.load_animation(DEMO, frames=[{}, [1]]), ["frame 1", "dict"]),
    ("bad size", lambda c: c.ml.load_animation(DEMO, frames=[{}], size=(-1, 2)), ["size"]),
    ("paths and frames of different lengths", lambda c: c.ml.load_animation([DEMO], frames=[{}, {}]), ["1 scene files"]),
], raises=("ValueError", "TypeError", "SceneError", "FileNotFoundError"))
cases_for("Animation", [
    ("no frames", lambda c: c.ml.Animation([], [], []), ["at least one frame"]),
    ("not scenes", lambda c: c.ml.Animation(["a.xml"], ["a.xml"], [{}]), ["Scene"]),
    ("unknown device", lambda c: c.ml.Animation([c.scene], [DEMO], [{}], device="fpga"), ["fpga"]),
], raises=("ValueError", "TypeError"))
cases_for("Animation.mapping", [
    ("frame out of range", lambda c: _anim(c).mapping(0, 2), ["frame 2", "2 frames"]),
    ("negative out of range", lambda c: _anim(c).mapping(-3, 0), ["frame -3"]),
    ("fractional frame", lambda c: _anim(c).mapping(0.5, 1), ["integer"]),
], raises=("IndexError", "TypeError"))
cases_for("apply_mapping", [
    ("entry out of range", lambda c: c.ml.apply_mapping(np.zeros((8, 8, 3)), np.full((8, 8), 64)), ["64", "[0, 64)"]),
    ("float mapping", lambda c: c.ml.apply_mapping(np.zeros((8, 8, 3)), np.zeros((8, 8))), ["integer"]),
    ("image of another size", lambda c: c.ml.apply_mapping(np.zeros((4, 8, 3)), _anim(c).mapping(0, 1)), ["(K, 8, 8, 3)"]),
    ("empty chain", lambda c: c.ml.apply_mapping(np.zeros((8, 8, 3)), []), ["empty"]),
    ("unknown device", lambda c: c.ml.apply_mapping(np.zeros((8, 8, 3)), np.zeros((8, 8), int), device="fpga"), ["fpga"]),
], raises=("ValueError", "TypeError"))
cases_for("antialias", [
    ("image of another size", lambda c: c.ml.antialias(np.zeros((4, 8, 3)), c.scene), ["(8, 8, C)"]),
    ("zero factor", lambda c: c.ml.antialias(np.zeros((8, 8, 3)), c.scene, factor=0), ["factor"]),
    ("huge factor", lambda c: c.ml.antialias(np.zeros((8, 8, 3)), c.scene, factor=10**9), ["factor"]),
    ("not a scene", lambda c: c.ml.antialias(np.zeros((8, 8, 3)), "scene.xml"), ["Scene"]),
    ("unknown device", lambda c: c.ml.antialias(np.zeros((8, 8, 3)), c.scene, device="fpga"), ["fpga"]),
], raises=("ValueError", "TypeError"))
cases_for("probe_pixels", [
    ("pixel outside the film", lambda c: c.ml.probe_pixels(c.scene, [[10**6, 0]], spp=4, progress=False), ["outside"]),
    ("negative pixel", lambda c: c.ml.probe_pixels(c.scene, [[0, -1]], spp=4, progress=False), ["outside"]),
    ("wrong shape", lambda c: c.ml.probe_pixels(c.scene, [1, 2, 3], spp=4, progress=False), ["(k, 2)"]),
    ("float pixels", lambda c: c.ml.probe_pixels(c.scene, [[0.5, 1.0]], spp=4, progress=False), ["integers"]),
    ("string pixels", lambda c: c.ml.probe_pixels(c.scene, [["a", "b"]], spp=4, progress=False), ["integer"]),
    ("one spp", lambda c: c.ml.probe_pixels(c.scene, [[0, 0]], spp=1, progress=False), ["spp"]),
    ("NaN spp", lambda c: c.ml.probe_pixels(c.scene, [[0, 0]], spp=float("nan"), progress=False), ["spp"]),
    ("max_depth 0", lambda c: c.ml.probe_pixels(c.scene, [[0, 0]], spp=4, max_depth=0, progress=False),
     ["max_depth"]),
    ("max_depth -2", lambda c: c.ml.probe_pixels(c.scene, [[0, 0]], spp=4, max_depth=-2, progress=False),
     ["max_depth"]),
    ("negative seed", lambda c: c.ml.probe_pixels(c.scene, [[0, 0]], spp=4, seed=-1, progress=False), ["seed"]),
    ("not a scene", lambda c: c.ml.probe_pixels("scene.xml", [[0, 0]]), ["Scene"]),
], raises=("ValueError", "TypeError"))
cases_for("native.probe_pixels", [
    ("pixel outside the film", lambda c: c.native.probe_pixels(c.scene, np.array([[10**6, 0]]), 4, -1, 0),
     ["outside"]),
    ("wrong shape", lambda c: c.native.probe_pixels(c.scene, np.zeros((1, 3), np.int64), 4, -1, 0), ["(k, 2)"]),
    ("one spp", lambda c: c.native.probe_pixels(c.scene, np.zeros((1, 2), np.int64), 1, -1, 0), ["spp"]),
    ("max_depth 0", lambda c: c.native.probe_pixels(c.scene, np.zeros((1, 2), np.int64), 4, 0, 0), ["max_depth"]),
    ("float pixels", lambda c: c.native.probe_pixels(c.scene, np.zeros((1, 2)), 4, -1, 0), ["int64"]),
], raises=("ValueError", "TypeError"))
cases_for("native.check_animation_topology", [
    ("no frames", lambda c: c.native.check_animation_topology([]), ["at least one frame"]),
    ("not scenes", lambda c: c.native.check_animation_topology(["a"]), ["Scene"]),
], raises=("ValueError", "TypeError"))
cases_for("native.pixel_mapping", [
    ("frames of different sizes", lambda c: c.native.pixel_mapping(c.scene, c.ml.load_scene(DEMO, res=4), c.scene),
     ["differ in size"]),
    ("unknown device", lambda c: c.native.pixel_mapping(c.scene, c.scene, c.scene, "fpga"), ["fpga"]),
])
cases_for("native.compose_mappings", [
    ("no mappings", lambda c: c.native.compose_mappings([]), ["at least one"]),
    ("different sizes", lambda c: c.native.compose_mappings([np.zeros((2, 2), np.int64), np.zeros((2, 3), np.int64)]),
     ["2x3"]),
    ("negative entry", lambda c: c.native.compose_mappings([np.full((2, 2), -5, np.int64)]), ["-5"]),
])
cases_for("native.apply_mapping", [
    ("float64 images", lambda c: c.native.apply_mapping(np.zeros((1, 2, 2, 3)), [np.zeros((2, 2), np.int64)]),
     ["float32"]),
    ("int32 mapping", lambda c: c.native.apply_mapping(np.zeros((1, 2, 2, 3), np.float32), [np.zeros((2, 2), np.int32)]),
     ["int64"]),
], raises=("TypeError", "ValueError"))
cases_for("native.antialias", [
    ("float64 image", lambda c: c.native.antialias(np.zeros((8, 8, 3)), c.scene), ["float32"]),
    ("factor 17", lambda c: c.native.antialias(np.zeros((8, 8, 3), np.float32), c.scene, 17), ["factor"]),
], raises=("TypeError", "ValueError"))
cases_for("scenes.animation_frames", [
    ("unknown scene", lambda c: __import__("manylights.scenes").scenes.animation_frames("nope"), ["nope", "bounce"]),
    ("zero frames", lambda c: __import__("manylights.scenes").scenes.animation_frames("bounce", 0), ["count"]),
    ("fractional count", lambda c: __import__("manylights.scenes").scenes.animation_frames("bounce", 2.5), ["count"]),
])

# Animation lights, the lighting tensor, tensor clustering, animation output.
def _tensor(c):
    return c._get("tensor", lambda: c.ml.LightTensor(
        _anim(c), c.ml.generate_animation_lights(_anim(c), area=8, indirect=8, seed=0), device="cpu"))


cases_for("generate_animation_lights", [
    ("no frames", lambda c: c.ml.generate_animation_lights([], area=4), ["no frames"]),
    ("negative area", lambda c: c.ml.generate_animation_lights(_anim(c), area=-1), ["area"]),
    ("fractional indirect", lambda c: c.ml.generate_animation_lights(_anim(c), indirect=2.5), ["indirect"]),
    ("huge photons", lambda c: c.ml.generate_animation_lights(_anim(c), photons=2**40), ["photons"]),
    ("NaN clamp", lambda c: c.ml.generate_animation_lights(_anim(c), area=4, clamp=float("nan")), ["clamp"]),
    ("negative seed", lambda c: c.ml.generate_animation_lights(_anim(c), area=4, seed=-1), ["seed"]),
    ("frames of other scenes", lambda c: c.ml.generate_animation_lights(
        [c.scene, c.ml.load_scene(REPO / "scenes" / "cbox" / "scene.xml", res=8)], area=4, indirect=4), ["frame 1"]),
])
cases_for("native.generate_animation_lights", [
    ("not scenes", lambda c: c.native.generate_animation_lights(["a"]), ["Scene"]),
    ("negative count", lambda c: c.native.generate_animation_lights([c.scene], -3), ["area"]),
], raises=("ValueError", "TypeError", "OverflowError"))
cases_for("LightTensor", [
    ("no frames", lambda c: c.ml.LightTensor([], c.lights), ["no frames"]),
    ("light sets of different sizes", lambda c: c.ml.LightTensor([c.scene, c.scene], [c.lights, c.lights[:1]]),
     ["frame 1 has 1 lights"]),
    ("too few light sets", lambda c: c.ml.LightTensor([c.scene, c.scene], [c.lights]), ["1 light sets for 2 frames"]),
    ("not a light set", lambda c: c.ml.LightTensor([c.scene], ["lights"]), ["LightSet"]),
    ("not a scene", lambda c: c.ml.LightTensor(["scene.xml"], c.lights), ["Scene"]),
    ("unknown device", lambda c: c.ml.LightTensor([c.scene], c.lights, device="fpga"), ["fpga"]),
])
cases_for("LightTensor.frame", [
    ("out of range", lambda c: _tensor(c).frame(2), ["frame 2 out of range"]),
    ("fractional", lambda c: _tensor(c).frame(0.5), ["integer"]),
], raises=("IndexError", "ValueError"))
cases_for("LightTensor.slices", [
    ("no rows", lambda c: _tensor(c).slices([]), ["at least one"]),
    ("row out of range", lambda c: _tensor(c).slices([64]), ["row index"]),
    ("fractional rows", lambda c: _tensor(c).slices([0.5]), ["row index"]),
])
cases_for("LightTensor.mapping", [
    ("frame out of range", lambda c: _tensor(c).mapping(0, 5), ["frame 5"]),
], raises=("IndexError", "TypeError"))
cases_for("mrcs_per_frame", [
    ("not a tensor", lambda c: c.ml.mrcs_per_frame(c.A), ["LightTensor"]),
    ("zero rows", lambda c: c.ml.mrcs_per_frame(_tensor(c), rows=0, columns=2), ["rows"]),
    ("too many columns", lambda c: c.ml.mrcs_per_frame(_tensor(c), rows=4, columns=10**6), ["columns"]),
    ("negative seed", lambda c: c.ml.mrcs_per_frame(_tensor(c), rows=4, columns=2, seed=-1), ["seed"]),
], raises=("ValueError", "TypeError"))
cases_for("tensor_clustering", [
    ("not a tensor", lambda c: c.ml.tensor_clustering(c.A), ["LightTensor"]),
    ("zero columns", lambda c: c.ml.tensor_clustering(_tensor(c), rows=4, columns=0), ["columns"]),
    ("zero rows", lambda c: c.ml.tensor_clustering(_tensor(c), rows=0, columns=2), ["rows"]),
    ("chunk 0", lambda c: c.ml.tensor_clustering(_tensor(c), rows=4, columns=2, chunk=0), ["chunk"]),
    ("unknown representative", lambda c: c.ml.tensor_clustering(_tensor(c), rows=4, columns=2, representative="x"),
     ["representative"]),
    ("negative time_weight", lambda c: c.ml.tensor_clustering(_tensor(c), rows=4, columns=2, time_weight=-1),
     ["time_weight"]),
    ("row index out of range", lambda c: c.ml.tensor_clustering(_tensor(c), columns=2, row_indices=[64]),
     ["row index"]),
], raises=("ValueError", "TypeError"))
cases_for("tensor_clustering", [
    ("client with frames not from an Animation", lambda c: c.ml.tensor_clustering(
        c.ml.LightTensor([c.scene], [c.lights], device="cpu"), rows=4, columns=2, client="tcp://127.0.0.1:9"),
     ["Animation", "load_animation"]),
    ("client with an unknown representative", lambda c: c.ml.tensor_clustering(
        _tensor(c), rows=4, columns=2, representative="x", client="tcp://127.0.0.1:9"), ["representative"]),
])
cases_for("tensor_clustering", [
    ("unreachable scheduler", lambda c: c.ml.tensor_clustering(_tensor(c), rows=4, columns=2,
                                                                client="tcp://127.0.0.1:9", connect_timeout=1),
     ["scheduler", "127.0.0.1:9"]),
], raises=("OSError",))
cases_for("cluster_tensor", [
    ("negative first_chunk", lambda c: c.ml.cluster_tensor(np.ones((2, 3, 2, 3), np.float32), 4, first_chunk=-1),
     ["first_chunk"]),
])
cases_for("native.tensor_accumulate", [
    ("acc not 4-D", lambda c: c.native.tensor_accumulate(np.zeros((2, 3), np.float32), np.zeros((1, 1, 1, 3), np.float32),
                                                          np.zeros(1, np.uint32), np.zeros((1, 2, 3), np.float32),
                                                          np.zeros((1, 1), np.uint32), np.zeros((1, 1), np.uint32)),
     ["(f, H, W, 3)"]),
    ("source frame out of range", lambda c: c.native.tensor_accumulate(
        np.zeros((2, 1, 1, 3), np.float32), np.zeros((1, 1, 1, 3), np.float32), np.full(1, 7, np.uint32),
        np.zeros((1, 2, 3), np.float32), np.zeros((1, 1), np.uint32), np.zeros((1, 1), np.uint32)), ["frame 7"]),
    ("mapping entry out of range", lambda c: c.native.tensor_accumulate(
        np.zeros((2, 1, 1, 3), np.float32), np.zeros((1, 1, 1, 3), np.float32), np.zeros(1, np.uint32),
        np.zeros((1, 2, 3), np.float32), np.full((1, 1), 5, np.uint32), np.zeros((1, 1), np.uint32)), ["maps to 5"]),
    ("float64 columns", lambda c: c.native.tensor_accumulate(
        np.zeros((2, 1, 1, 3), np.float32), np.zeros((1, 1, 1, 3)), np.zeros(1, np.uint32),
        np.zeros((1, 2, 3), np.float32), np.zeros((1, 1), np.uint32), np.zeros((1, 1), np.uint32)), ["float32"]),
], raises=("ValueError", "TypeError"))
cases_for("native.tensor_reconstruct_gpu", [
    ("no frames", lambda c: c.native.tensor_reconstruct_gpu([], np.zeros((0, 2), np.uint32), np.zeros((0, 0, 3), np.float32),
                                                            np.zeros((0, 1), np.uint32), np.zeros((0, 1), np.uint32)),
     ["no frames"]),
    ("representatives not (c, 2)", lambda c: c.native.tensor_reconstruct_gpu(
        [c.A._m], np.zeros((1, 3), np.uint32), np.zeros((1, 1, 3), np.float32), np.zeros((0, 1), np.uint32),
        np.zeros((0, 1), np.uint32)), ["(c, 2)"]),
    ("matrix on the CPU", lambda c: c.native.tensor_reconstruct_gpu(
        [c.ml.LightMatrix(c.scene, c.lights, device="cpu")._m], np.zeros((1, 2), np.uint32),
        np.zeros((1, 1, 3), np.float32), np.zeros((0, 1), np.uint32), np.zeros((0, 1), np.uint32)), ["not on the GPU"]),
], raises=("ValueError", "TypeError"))
# ml.sweep: everything is refused before a cluster starts or a file is written.
def _sweep(c, **kw):
    args = {"methods": ["mrcs"], "budgets": [(4, 8)], "seeds": [0], "lights": 50, "device": "cpu", "progress": False,
            "workers": 0, "reference_dir": c.tmp / "sweep-refs", **kw}
    return c.ml.sweep(args.pop("scenes", [("demo", {"res": 8})]), **args)


def _sweep_other_definition(c):
    out = c.tmp / "sweep-other.parquet"
    _sweep(c, out=out, seeds=[0])
    return _sweep(c, out=out, seeds=[0, 1])


cases_for("sweep", [
    ("unknown method", lambda c: _sweep(c, methods=["mrcs", "raytrace"]), ["raytrace", "power_sampling"]),
    ("empty scenes", lambda c: _sweep(c, scenes=[]), ["scenes is empty"]),
    ("empty budget list", lambda c: _sweep(c, budgets=[]), ["budgets is empty"]),
    ("budget not a pair", lambda c: _sweep(c, budgets=[(8,)]), ["budgets[0]", "(8,)"]),
    ("budget of 0 rows", lambda c: _sweep(c, budgets=[(0, 8)]), ["budgets[0] rows", "0"]),
    ("budget of negative columns", lambda c: _sweep(c, budgets=[(4, -8)]), ["budgets[0] columns", "-8"]),
    ("budget not integers", lambda c: _sweep(c, budgets=[(4, "many")]), ["budgets[0] columns", "many"]),
    ("budget repeated", lambda c: _sweep(c, budgets=[(4, 8), (4, 8)]), ["twice"]),
    ("negative seed", lambda c: _sweep(c, seeds=[0, -1]), ["seeds[1]", "-1"]),
    ("empty seeds", lambda c: _sweep(c, seeds=[]), ["seeds is empty"]),
    ("zero lights", lambda c: _sweep(c, lights=0), ["lights", "0"]),
    ("unknown lights key", lambda c: _sweep(c, lights={"area": 4, "vpl": 9}), ["vpl"]),
    ("unknown device", lambda c: _sweep(c, device="tpu"), ["tpu"]),
    ("scene parameter of a bad type", lambda c: _sweep(c, scenes=[("demo", {"res": [8]})]), ["res"]),
    ("frames not a list of dicts", lambda c: _sweep(c, methods=["tensor_clustering"],
                                                    scenes=[("bounce", {"frames": [1, 2]})]), ["frames"]),
    ("animation method on a still scene", lambda c: _sweep(c, methods=["tensor_clustering"]),
     ["tensor_clustering", "still"]),
    ("options for a method not swept", lambda c: _sweep(c, options={"power_sampling": {}}), ["power_sampling"]),
    ("Parquet file of another sweep", _sweep_other_definition, ["another definition", "seeds"]),
    ("Parquet file not a sweep's", lambda c: _sweep(c, out=c.file("sweep-foreign.parquet", b"PAR1 not really")),
     ["sweep-foreign.parquet"]),
])
cases_for("sweep", [
    ("missing scene file", lambda c: _sweep(c, scenes=[str(c.tmp / "no-such-scene.xml")]), ["no-such-scene.xml"]),
    ("out in a missing directory", lambda c: _sweep(c, out=c.tmp / "no-such-dir" / "s.parquet"), ["no-such-dir"]),
], raises=("FileNotFoundError",))
cases_for("sweep", [
    ("unreachable scheduler", lambda c: _sweep(c, client="tcp://127.0.0.1:9", connect_timeout=1),
     ["scheduler", "127.0.0.1:9"]),
], raises=("OSError",))
cases_for("sweep", [
    ("scenes not a list", lambda c: _sweep(c, scenes=42), ["scenes"]),
], raises=("TypeError",))
cases_for("native.check_host_memory", [
    ("more than addressable", lambda c: c.native.check_host_memory("test request", 2**100), ["test request"]),
], raises=("MemoryError", "OverflowError"))
cases_for("native.encode_srgb8", [
    ("2-D image", lambda c: c.native.encode_srgb8(np.zeros((2, 2), np.float32)), ["(H, W, 3)"]),
    ("NaN exposure", lambda c: c.native.encode_srgb8(np.zeros((1, 1, 3), np.float32), float("nan")), ["exposure"]),
], raises=("ValueError", "TypeError"))
cases_for("write_exr_sequence", [
    ("3-D frames", lambda c: c.ml.write_exr_sequence(np.zeros((2, 2, 3)), c.tmp / "seq"), ["(f, H, W, 3)"]),
    ("no frames", lambda c: c.ml.write_exr_sequence(np.zeros((0, 2, 2, 3)), c.tmp / "seq"), ["empty"]),
    ("NaN pixel", lambda c: c.ml.write_exr_sequence(_nan_at(np.zeros((2, 2, 2, 3)), (1, 0, 1, 2)), c.tmp / "seq"),
     ["frame 1", "row 0", "column 1"]),
    ("prefix with a separator", lambda c: c.ml.write_exr_sequence(np.zeros((1, 2, 2, 3)), c.tmp / "seq", prefix="a/b"),
     ["prefix"]),
])
cases_for("write_video", [
    ("unknown format", lambda c: c.ml.write_video(np.zeros((2, 4, 4, 3)), c.tmp / "a.avi"), [".avi"]),
    ("zero fps", lambda c: c.ml.write_video(np.zeros((2, 4, 4, 3)), c.tmp / "a.gif", fps=0), ["fps"]),
    ("inf value", lambda c: c.ml.write_video(_nan_at(np.zeros((2, 4, 4, 3)), (0, 1, 1, 0), np.inf), c.tmp / "a.gif"),
     ["frame 0"]),
    ("missing folder", lambda c: c.ml.write_video(np.zeros((2, 4, 4, 3)), c.tmp / "no" / "a.gif"), ["does not exist"]),
], raises=("ValueError", "FileNotFoundError"))
cases_for("side_by_side", [
    ("no panels", lambda c: c.ml.side_by_side([]), ["at least one"]),
    ("shapes differ", lambda c: c.ml.side_by_side([np.zeros((2, 2, 3)), np.zeros((2, 3, 3))]), ["all must match"]),
    ("label count", lambda c: c.ml.side_by_side([np.zeros((2, 2, 3))], labels=[]), ["0 labels"]),
    ("negative gap", lambda c: c.ml.side_by_side([np.zeros((2, 2, 3))], gap=-1), ["gap"]),
])

# An adapter that does not exist: the GPU cannot start (a fresh process: the device is created once).
cases_for("device_info", [
    ("no such adapter", lambda c: c.ml.device_info(), ["MANYLIGHTS_ADAPTER", "no-such-gpu"]),
], raises=("GpuUnavailableError",), subprocess=True)

# Functions that are public but not entry points for data, with why they need no corpus entry.
NOT_COVERED: dict[str, str] = {
    "RenderResult": "a dataclass that only holds results (no validation of its own)",
    "TensorClustering": "a dataclass that only holds results; made by cluster_tensor (covered)",
    "KMeansResult": "a dataclass that only holds results; made by kmeans (covered)",
    "AnimationLights": "a container of the per-frame LightSets that generate_animation_lights makes (covered)",
    "scenes.available": "takes no arguments",
    "scenes.animated": "takes no arguments",
    "Animation.gbuffers": "takes no arguments (the device is the Animation's, checked when it is made)",
    "AnimationResult": "a dataclass that only holds results (no validation of its own)",
    "LightTensor.brute_force": "takes only a progress flag (None, True or False; any other value counts as True)",
    "LightMatrix.view_samples": "takes no arguments",
    "RenderResult.summary": "takes no arguments",
    "AnimationResult.summary": "takes no arguments",
}

# Case id -> environment of its own child process.
SUBPROCESS_ENV = {"device_info:no such adapter": {"MANYLIGHTS_ADAPTER": "no-such-gpu"},
                  "LightMatrix:bad MANYLIGHTS_DEVICE": {"MANYLIGHTS_DEVICE": "quantum"},
                  "LightMatrix:gpu without any adapter": {"WGPU_BACKEND": "vulkan",
                                                          "VK_ICD_FILENAMES": "/nonexistent/icd.json",
                                                          "VK_DRIVER_FILES": "/nonexistent/icd.json"},
                  **{f"load_scene[{k}]:JPEG larger than MANYLIGHTS_MEMORY_LIMIT": {"MANYLIGHTS_MEMORY_LIMIT": "64M"}
                     for k in ("bitmap", "envmap")}}


# Self-test cases of the runner (only with BAD_INPUT_SELFTEST=1): each must be reported as a failure.
if os.environ.get("BAD_INPUT_SELFTEST"):
    class PanicException(BaseException):  # the name pyo3 gives its panics (pyo3_runtime.PanicException)
        pass

    def _panic(c):
        raise PanicException("called `Option::unwrap()` on a `None` value")

    def _hang(c):
        import time
        time.sleep(3600)

    CASES[:] = [Case("selftest:panic", "selftest", _panic), Case("selftest:abort", "selftest", lambda c: os.abort()),
                Case("selftest:returns", "selftest", lambda c: 42),
                Case("selftest:vague", "selftest", lambda c: int("x"), match=("nothing like this",)),
                Case("selftest:hang", "selftest", _hang), Case("selftest:ok", "selftest", lambda c: int("x"))]

# --------------------------------------------------------------------------------------------------
# The runner (in the child process).

def _classify(exc: BaseException, c: Case) -> dict:
    names = [k.__name__ for k in type(exc).__mro__]
    msg = str(exc)
    out = {"type": type(exc).__name__, "mro": names, "msg": msg[:2000]}
    if not isinstance(exc, Exception):
        out["verdict"] = "panic" if "PanicException" in names else "base-exception"
    elif not any(r in names for r in c.raises):
        out["verdict"] = "wrong-type"
    elif missing := [m for m in c.match if m.lower() not in msg.lower()]:
        out["verdict"] = "unclear"
        out["missing"] = missing
    else:
        out["verdict"] = "ok"
    return out


def run(out_dir: Path, only: list[str] | None = None) -> None:
    """Run the cases (or those in ``only``), printing one JSON line per case: {"start": id} then the result."""
    out_dir.mkdir(parents=True, exist_ok=True)
    ctx = Ctx(out_dir)
    for c in CASES:
        if only is not None and c.id not in only:
            continue
        print(json.dumps({"start": c.id}), flush=True)
        try:
            r = c.fn(ctx)
        except BaseException as e:  # PanicException is a BaseException: that is the point
            res = _classify(e, c)
            if res["verdict"] != "ok":
                res["traceback"] = traceback.format_exc()[-3000:]
        else:
            res = {"verdict": "returned", "returned": repr(r)[:300]}
        res["id"] = c.id
        print(json.dumps(res), flush=True)


if __name__ == "__main__":
    only = json.loads(os.environ["BAD_INPUT_ONLY"]) if os.environ.get("BAD_INPUT_ONLY") else None
    run(Path(sys.argv[1]), only)
