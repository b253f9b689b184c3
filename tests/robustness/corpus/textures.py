"""Bad-input cases: textures (bitmap) and environment maps through load_scene."""
from __future__ import annotations

import struct
from pathlib import Path

import numpy as np

from .common import (
    FILE_ERRORS,
    JUNK,
    bmp_declaring,
    cases_for,
    exr_window,
    jpeg_declaring,
    png_header_only,
    tga_declaring,
)

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
