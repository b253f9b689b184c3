"""Writes the seed inputs of the fuzz targets into fuzz/corpus-raw/<target>/ (small valid files).

Run: .venv/bin/python fuzz/seeds.py [FOLDER]. Needs numpy, Pillow and OpenEXR (requirements-dev.txt).
The committed corpus (fuzz/corpus/) is these seeds plus what fuzzing found, minimised with `cargo fuzz cmin`
(`make fuzz-cmin`). FOLDER (default: the repository) adds the small XML and OBJ files of its scenes/.
"""
import io
import struct
import sys
from pathlib import Path

import numpy as np
import OpenEXR
from PIL import Image

FUZZ = Path(__file__).resolve().parent
OUT = FUZZ / "corpus-raw"
MARK = "\n--8<-- "


def put(target, name, data):
    d = OUT / target
    d.mkdir(parents=True, exist_ok=True)
    (d / name).write_bytes(data.encode() if isinstance(data, str) else data)


# ---------------------------------------------------------------- images
rng = np.random.default_rng(1)


def pil_bytes(img, fmt, **kw):
    b = io.BytesIO()
    img.save(b, fmt, **kw)
    return b.getvalue()


rgb = Image.fromarray(rng.integers(0, 256, (3, 2, 3), dtype=np.uint8), "RGB")
grey = Image.fromarray(rng.integers(0, 256, (2, 5), dtype=np.uint8), "L")
rgba = Image.fromarray(rng.integers(0, 256, (2, 2, 4), dtype=np.uint8), "RGBA")
put("png", "rgb_2x3.png", pil_bytes(rgb, "PNG"))
put("png", "grey_5x2.png", pil_bytes(grey, "PNG"))
put("png", "rgba_2x2.png", pil_bytes(rgba, "PNG"))
put("png", "la_1x1.png", pil_bytes(Image.new("LA", (1, 1), (7, 9)), "PNG"))
put("png", "palette_3x1.png", pil_bytes(rgb.convert("P"), "PNG"))
put("png", "grey16_2x2.png", pil_bytes(Image.fromarray(np.array([[0, 300], [40000, 65535]], np.uint16)), "PNG"))
put("png", "bilevel_4x2.png", pil_bytes(Image.new("1", (4, 2), 1), "PNG"))
put("jpg", "rgb_8x8.jpg", pil_bytes(rgb.resize((8, 8)), "JPEG", quality=90))
put("jpg", "grey_3x2.jpg", pil_bytes(grey.resize((3, 2)), "JPEG"))
put("jpg", "progressive_9x7.jpg", pil_bytes(rgb.resize((9, 7)), "JPEG", progressive=True))
put("jpg", "sub420_17x3.jpg", pil_bytes(rgb.resize((17, 3)), "JPEG", subsampling=2, quality=50))
put("jpg", "cmyk_2x2.jpg", pil_bytes(rgb.resize((2, 2)).convert("CMYK"), "JPEG"))


# Radiance RGBE (.hdr): flat and run-length encoded scanlines, Mitsuba's and Radiance's signatures.
def rgbe(rgb):
    """float RGB (h, w, 3) -> RGBE bytes (h, w, 4), Radiance's float2rgbe."""
    m = rgb.max(axis=2)
    mant, e = np.frexp(m)
    scale = np.where(m > 1e-32, mant * 256.0 / np.where(m > 0, m, 1), 0)
    out = np.zeros(rgb.shape[:2] + (4,), np.uint8)
    out[..., :3] = (rgb * scale[..., None]).astype(np.uint8)
    out[..., 3] = np.where(m > 1e-32, e + 128, 0)
    return out


def hdr_rle_row(row):
    """One new-style RLE scanline: 2 2 w_hi w_lo, then each channel as runs/literals."""
    w = len(row)
    out = bytearray([2, 2, w >> 8, w & 255])
    for c in range(4):
        ch = row[:, c]
        i = 0
        while i < w:
            j = i
            while j < w and j - i < 127 and ch[j] == ch[i]:
                j += 1
            if j - i >= 3:
                out += bytes([128 + j - i, ch[i]])
                i = j
            else:
                k = min(w, i + 128)
                j = i + 1
                while j < k and not (j + 2 < w and ch[j] == ch[j + 1] == ch[j + 2]):
                    j += 1
                out += bytes([j - i]) + bytes(ch[i:j])
                i = j
    return bytes(out)


def hdr_bytes(img, sig=b"#?RADIANCE", rle=False, extra=b""):
    h, w = img.shape[:2]
    px = rgbe(img)
    head = sig + b"\nFORMAT=32-bit_rle_rgbe\n" + extra + b"\n-Y %d +X %d\n" % (h, w)
    body = b"".join(hdr_rle_row(r) for r in px) if rle else px.tobytes()
    return head + body


hdr_img = rng.random((3, 2, 3)) * 4
put("hdr", "flat_2x3.hdr", hdr_bytes(hdr_img))
put("hdr", "mitsuba_sig_1x1.hdr", b"#?RGBE\nFORMAT=32-bit_rle_rgbe\n\n-Y 1 +X 1\n\x80\x80\x80\x81")
ramp = np.repeat(np.linspace(0, 8, 20)[None, :, None], 3, axis=2) * np.ones((2, 20, 3))
ramp[:, 10:] = 5.0  # a run
put("hdr", "rle_20x2.hdr", hdr_bytes(ramp, rle=True))
put("hdr", "exposure_2x3.hdr", hdr_bytes(hdr_img, extra=b"EXPOSURE=2.0\n# comment\nGAMMA=1\n"))
put("hdr", "truncated_rle.hdr", hdr_bytes(ramp, rle=True)[:-7])
put("hdr", "xyze.hdr", b"#?RADIANCE\nFORMAT=32-bit_rle_xyze\n\n-Y 1 +X 1\n\x80\x80\x80\x81")
put("hdr", "flipped.hdr", b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n+Y 1 -X 2\n\x80\x80\x80\x81\x80\x80\x80\x81")
put("hdr", "header_only.hdr", b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 40000 +X 40000\n")

# PFM: colour/grey, little/big-endian, scaled; bottom row first in the file.


def pfm_bytes(img, little=True, scale=1.0, sep=b"\n"):
    grey = img.ndim == 2
    h, w = img.shape[:2]
    data = np.ascontiguousarray(img[::-1], dtype="<f4" if little else ">f4").tobytes()
    return (b"Pf" if grey else b"PF") + sep + b"%d %d" % (w, h) + sep + b"%g" % (-scale if little else scale) + b"\n" + data


pfm_img = (rng.random((3, 2, 3)) * 10 - 2).astype(np.float32)
put("pfm", "rgb_le_2x3.pfm", pfm_bytes(pfm_img))
put("pfm", "rgb_be_2x3.pfm", pfm_bytes(pfm_img, little=False))
put("pfm", "grey_le_5x2.pfm", pfm_bytes(pfm_img[:2, :, 0].repeat(3, axis=1)[:, :5]))
put("pfm", "grey_be_scaled_1x1.pfm", pfm_bytes(np.array([[0.25]]), little=False, scale=2.5, sep=b" "))
put("pfm", "special_values.pfm", pfm_bytes(np.array([[[np.inf, -np.inf, np.nan], [0.0, -0.0, 1e-45]]])))
put("pfm", "truncated.pfm", pfm_bytes(pfm_img)[:-5])
put("pfm", "header_only.pfm", b"PF\n65536 65536\n-1\n")

# BMP, PPM (PNM) and TGA: Pillow's encoders (uncompressed and RLE), and headers declaring large sizes.
put("bmp", "rgb_2x3.bmp", pil_bytes(rgb, "BMP"))
put("bmp", "grey_5x2.bmp", pil_bytes(grey, "BMP"))
put("bmp", "palette_3x1.bmp", pil_bytes(rgb.convert("P"), "BMP"))
put("bmp", "rgba_2x2.bmp", pil_bytes(rgba, "BMP"))
put("bmp", "bilevel_4x2.bmp", pil_bytes(Image.new("1", (4, 2), 1), "BMP"))
put("bmp", "rle8_9x7.bmp", pil_bytes(rgb.resize((9, 7)).convert("P"), "BMP", compression="bmp_rle"))
put("bmp", "header_60000.bmp", b"BM" + struct.pack("<IHHI", 58, 0, 0, 54)
    + struct.pack("<IiiHHIIiiII", 40, 60000, 60000, 1, 24, 0, 0, 0, 0, 0, 0) + b"\x01\x02\x03\x00")
put("ppm", "rgb_2x3.ppm", pil_bytes(rgb, "PPM"))
put("ppm", "grey_5x2.pgm.ppm", pil_bytes(grey, "PPM"))
put("ppm", "rgb16_1x1.ppm", b"P6\n1 1\n65535\n\x01\x02\x03\x04\x05\x06")
put("ppm", "ascii_2x1.ppm", b"P3\n# comment\n2 1\n255\n1 2 3 4 5 6\n")
put("ppm", "pam_1x1.ppm", b"P7\nWIDTH 1\nHEIGHT 1\nDEPTH 3\nMAXVAL 255\nTUPLTYPE RGB\nENDHDR\n\x01\x02\x03")
put("ppm", "header_60000.ppm", b"P6\n60000 60000\n255\n\x01\x02\x03")
put("tga", "rgb_2x3.tga", pil_bytes(rgb, "TGA"))
put("tga", "rgb_rle_2x3.tga", pil_bytes(rgb.resize((7, 3)), "TGA", compression="tga_rle"))
put("tga", "grey_5x2.tga", pil_bytes(grey, "TGA"))
put("tga", "rgba_2x2.tga", pil_bytes(rgba, "TGA"))
put("tga", "palette_3x1.tga", pil_bytes(rgb.convert("P"), "TGA"))
put("tga", "header_60000.tga", bytes([0, 0, 2, 0, 0, 0, 0, 0]) + struct.pack("<HHHHBB", 0, 0, 60000, 60000, 24, 0x20)
    + b"\x01\x02\x03")


def exr_bytes(name, channels, compression, tiled=False):
    hdr = {"compression": compression, "type": OpenEXR.tiledimage if tiled else OpenEXR.scanlineimage}
    if tiled:
        hdr["tiles"] = OpenEXR.TileDescription()
    p = OUT / "exr" / name
    p.parent.mkdir(parents=True, exist_ok=True)
    OpenEXR.File(hdr, channels).write(str(p))


exr_bytes("half_rgb_piz.exr", {"RGB": rng.random((3, 2, 3)).astype("float16")}, OpenEXR.PIZ_COMPRESSION)
exr_bytes("float_rgba_zip.exr", {"RGBA": rng.random((2, 2, 4)).astype("float32")}, OpenEXR.ZIP_COMPRESSION)
exr_bytes("y_none.exr", {"Y": rng.random((2, 3)).astype("float32")}, OpenEXR.NO_COMPRESSION)
exr_bytes("rgb_rle.exr", {"RGB": rng.random((1, 4, 3)).astype("float16")}, OpenEXR.RLE_COMPRESSION)
exr_bytes("rgb_zips.exr", {"RGB": rng.random((2, 1, 3)).astype("float32")}, OpenEXR.ZIPS_COMPRESSION)
exr_bytes("rgb_pxr24.exr", {"RGB": rng.random((2, 2, 3)).astype("float32")}, OpenEXR.PXR24_COMPRESSION)
exr_bytes("rgb_b44.exr", {"RGB": rng.random((4, 4, 3)).astype("float16")}, OpenEXR.B44_COMPRESSION)
exr_bytes("y_tiled_zip.exr", {"Y": rng.random((3, 5)).astype("float32")}, OpenEXR.ZIP_COMPRESSION, tiled=True)
exr_bytes("uint_rgb.exr", {"R": np.arange(4, dtype=np.uint32).reshape(2, 2), "G": np.ones((2, 2), np.uint32),
                            "B": np.zeros((2, 2), np.uint32)}, OpenEXR.NO_COMPRESSION)

# ---------------------------------------------------------------- meshes
put("obj", "tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
put("obj", "quad_vt_vn.obj", "# c\no a\ng b\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0.25\nvn 0 0 1\n"
    "usemtl m\ns 1\nf 1/1/1 2/2/1 3/2/1\nf 1/1/1 3/2/1 4/1/1\n")
put("obj", "forms.obj", "v 0 0 0 1\r\nv\t1 0 0\r\nv 1 1 0\nv 0 1 0\nv -1 0 0\nvt 0.5 0.5 0\nvn 0 1 0\n"
    "f 1//1 2//1 3//1 4//1 5//1\nf 2/1 3/1 4/1 # c\nf -3 -2 -1\nf 1 2\n")
put("obj", "missing_vt.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\nf 1/1/1 2 3//1\n")
put("obj", "degenerate.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 4\nv 5 5 5\n")


def ply_ascii(extra=""):
    return ("ply\nformat ascii 1.0\ncomment hi\nelement vertex 4\nproperty float x\nproperty float y\n"
            "property float z\nproperty float s\nproperty float t\nproperty uchar red\n" + extra +
            "element face 1\nproperty list uchar int vertex_index\nend_header\n"
            "0 0 0 0 0 255\n1 0 0 1 0 0\n1 1 0 1 1 0\n0 1 0 0 0.25 7\n4 0 1 2 3\n")


def ply_binary(big):
    enc = "binary_big_endian" if big else "binary_little_endian"
    e = ">" if big else "<"
    b = (f"ply\nformat {enc} 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
         "property float nx\nproperty float ny\nproperty float nz\nproperty float texture_u\n"
         "property float texture_v\nproperty double quality\nelement face 1\n"
         "property list uchar uint vertex_indices\nelement extra 1\nproperty int k\nend_header\n").encode()
    for i, p in enumerate([(0, 0, 0), (2, 0, 0), (0, 3, 0)]):
        b += struct.pack(e + "8fd", *p, 0, 0, 1, i * 0.5, 0.125, 9.0)
    b += struct.pack(e + "B3I", 3, 0, 1, 2) + struct.pack(e + "i", 5)
    return b


put("ply", "ascii_quad.ply", ply_ascii())
put("ply", "le.ply", ply_binary(False))
put("ply", "be.ply", ply_binary(True))
put("ply", "uv_double.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty double x\nproperty double y\n"
    "property double z\nproperty double u\nproperty double v\nproperty short nx\nproperty short ny\n"
    "property short nz\nelement face 1\nproperty list uint8 uint32 vertex_indices\nend_header\n"
    "0 0 0 0 0 0 0 1\n1 0 0 1 0 0 0 1\n0 1 0 0 1 0 0 1\n3 0 1 2\n")

# ---------------------------------------------------------------- scenes
SENSOR = """<sensor type="perspective">
    <string name="fov_axis" value="$axis"/><float name="fov" value="45"/><float name="near_clip" value="0.01"/>
    <float name="far_clip" value="100"/>
    <transform name="to_world"><lookat origin="0, 0, 4" target="0, 0, 0" up="0, 1, 0"/></transform>
    <sampler type="independent"><integer name="sample_count" value="4"/></sampler>
    <film type="hdrfilm"><integer name="width" value="$res"/><integer name="height" value="$res"/>
        <rfilter type="box"/></film>
</sensor>"""

ALL = f"""@params res=8
<scene version="3.0.0">
    <default name="res" value="16"/>
    <default name="axis" value="x"/>
    <path value="meshes"/>
    <include filename="inc.xml"/>
    {SENSOR}
    <integrator type="path"><integer name="max_depth" value="3"/></integrator>
    <bsdf type="twosided" id="two"><bsdf type="diffuse"><texture type="bitmap" name="reflectance">
        <string name="filename" value="t.png"/><string name="filter_type" value="nearest"/>
        <string name="wrap_mode" value="mirror"/><boolean name="raw" value="false"/>
        <transform name="to_uv"><scale x="2" y="3"/></transform></texture></bsdf></bsdf>
    <bsdf type="plastic" id="pl"><rgb name="diffuse_reflectance" value="0.1, 0.2, 0.3"/>
        <float name="int_ior" value="1.9"/></bsdf>
    <bsdf type="roughplastic" id="rp"><string name="distribution" value="beckmann"/><float name="alpha" value="0.2"/></bsdf>
    <bsdf type="conductor" id="co"><string name="material" value="Au"/></bsdf>
    <bsdf type="roughconductor" id="rc"><float name="alpha_u" value="0.1"/><float name="alpha_v" value="0.3"/>
        <rgb name="eta" value="0.2, 0.9, 1.1"/><rgb name="k" value="3, 2.9, 2.8"/></bsdf>
    <bsdf type="dielectric" id="de"><string name="int_ior" value="bk7"/><string name="ext_ior" value="air"/></bsdf>
    <texture type="checkerboard" id="ch"><rgb name="color0" value="0.2"/><rgb name="color1" value="0.8"/></texture>
    <bsdf type="diffuse" id="dch"><ref name="reflectance" id="ch"/></bsdf>
    <alias id="dch" as="dch2"/>
    <shape type="obj"><string name="filename" value="m.obj"/><boolean name="face_normals" value="true"/>
        <transform name="to_world"><rotate x="0" y="1" z="1" angle="15"/><scale value="2"/>
        <translate x="1" y="0" z="-1"/></transform><ref id="two"/></shape>
    <shape type="ply"><string name="filename" value="m.ply"/><boolean name="flip_normals" value="true"/>
        <transform name="to_world"><matrix value="1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1"/></transform><ref id="pl"/></shape>
    <shape type="rectangle"><ref id="rp"/><emitter type="area"><rgb name="radiance" value="1, 2, 3"/></emitter></shape>
    <shape type="cube"><ref id="co"/><transform name="to_world"><scale x="1" y="2" z="-1"/></transform></shape>
    <shape type="sphere"><point name="center" x="0" y="1" z="0"/><float name="radius" value="0.5"/><ref id="de"/></shape>
    <shape type="disk"><ref id="dch2"/></shape>
    <shape type="rectangle"><ref id="rc"/></shape>
    <emitter type="point"><point name="position" value="0, 3, 0"/><rgb name="intensity" value="5"/></emitter>
    <emitter type="spot"><transform name="to_world"><lookat origin="1, 1, 1" target="0, 0, 0"/></transform>
        <float name="cutoff_angle" value="30"/><float name="beam_width" value="20"/><spectrum name="intensity" value="4"/></emitter>
    <emitter type="directional"><vector name="direction" value="0, -1, 0"/><rgb name="irradiance" value="1"/></emitter>
    <emitter type="envmap"><string name="filename" value="e.exr"/><float name="scale" value="2"/></emitter>
    <emitter type="constant"><rgb name="radiance" value="0.1"/></emitter>
</scene>{MARK}inc.xml
<scene version="3.0.0"><default name="axis" value="smaller"/>
    <bsdf type="diffuse" id="unused"><rgb name="reflectance" value="\\$"/></bsdf></scene>{MARK}meshes/m.obj
v 0 0 0
v 1 0 0
v 0 1 0
vt 0 0
vt 1 0
vt 0 1
f 1/1 2/2 3/3
{MARK}m.ply
{ply_ascii()}"""
# Binary files go last in a bundle (their bytes may not contain the mark).
png = pil_bytes(rgb, "PNG")
exr = (OUT / "exr" / "half_rgb_piz.exr").read_bytes()
assert MARK.encode() not in png + exr
put("xml", "all_plugins.xml", ALL.encode() + MARK.encode() + b"t.png\n" + png + MARK.encode() + b"e.exr\n" + exr)

# Bump and normal maps: a top-level bumpmap used by reference, one no shape uses, a normalmap in a twosided.
PERTURB = f"""<scene version="3.0.0"><default name="res" value="4"/><default name="axis" value="x"/>{SENSOR}
    <bsdf type="bumpmap" id="b"><texture type="bitmap"><string name="filename" value="h.png"/>
        <transform name="to_uv"><scale x="2" y="3"/></transform></texture><float name="scale" value="0.5"/>
        <bsdf type="roughplastic"><float name="alpha" value="0.2"/></bsdf></bsdf>
    <bsdf type="bumpmap" id="unused"><texture type="bitmap"><string name="filename" value="h.png"/></texture>
        <bsdf type="diffuse" id="inner"/></bsdf>
    <shape type="rectangle"><ref id="b"/></shape>
    <shape type="sphere"><ref id="inner"/></shape>
    <shape type="cube"><bsdf type="twosided"><bsdf type="normalmap"><texture name="normalmap" type="bitmap">
        <boolean name="raw" value="true"/><string name="filename" value="n.png"/></texture>
        <bsdf type="diffuse"/></bsdf></bsdf></shape>
    <emitter type="point"><point name="position" value="0, 3, 0"/><rgb name="intensity" value="5"/></emitter>
</scene>"""
put("xml", "perturb.xml", PERTURB.encode() + MARK.encode() + b"h.png\n" + pil_bytes(grey, "PNG") + MARK.encode()
    + b"n.png\n" + png)

# Masks: a bitmap opacity around a twosided diffuse (leaves), a constant one, a mask inside a twosided.
MASKED = f"""<scene version="3.0.0"><default name="res" value="4"/><default name="axis" value="y"/>{SENSOR}
    <shape type="rectangle"><bsdf type="mask"><texture name="opacity" type="bitmap">
        <string name="filename" value="a.png"/></texture>
        <bsdf type="twosided"><bsdf type="diffuse"/></bsdf></bsdf></shape>
    <shape type="sphere"><bsdf type="mask"><float name="opacity" value="0.25"/><bsdf type="roughplastic"/></bsdf></shape>
    <shape type="cube"><bsdf type="twosided"><bsdf type="mask"><float name="opacity" value="0.5"/>
        <bsdf type="diffuse"/></bsdf></bsdf></shape>
    <emitter type="constant"><rgb name="radiance" value="1"/></emitter>
</scene>"""
put("xml", "mask.xml", MASKED.encode() + MARK.encode() + b"a.png\n" + pil_bytes(grey, "PNG"))

put("xml", "minimal.xml", f"""<scene version="3.0.0"><default name="res" value="4"/><default name="axis" value="y"/>
{SENSOR}<shape type="sphere"/></scene>""")
put("xml", "include_chain.xml", f"""<scene version="3.0.0"><include filename="a.xml"/></scene>{MARK}a.xml
<scene version="3.0.0"><default name="res" value="3"/><include filename="sub/b.xml"/></scene>{MARK}sub/b.xml
<scene version="3.0.0"><default name="axis" value="x"/>{SENSOR}<shape type="cube" id="c"/></scene>""")
put("xml", "errors.xml", """@params unused=1
<scene version="3.0.0"><shape type="obj"><string name="filename" value="nope.obj"/></shape>
<float name="x" value="1e400"/><transform name="to_world"><lookat origin="0,0,0" target="0,0,0"/></transform>
<spectrum name="s" value="400:1, 500:2"/><rgb name="c" value="1, 2"/><ref id="missing"/></scene>""")

# Extra seeds from the repository's scenes (or the scenes/ of a folder given).
scenes = (Path(sys.argv[1]) if len(sys.argv) > 1 else FUZZ.parent) / "scenes"
if scenes.is_dir():
    for xml in sorted(scenes.rglob("*.xml")):
        if xml.stat().st_size < 16000:
            put("xml", "shared_" + "_".join(xml.relative_to(scenes).parts), xml.read_bytes())
    for obj in sorted(scenes.rglob("*.obj")):
        if obj.stat().st_size < 8000:
            put("obj", "shared_" + obj.name, obj.read_bytes())
    cbox = scenes / "cbox" / "scene.xml"
    if cbox.is_file():
        text = cbox.read_text()
        for name in ["luminaire", "floor", "smallbox"]:
            text += f"{MARK}meshes/cbox_{name}.obj\n" + (scenes / "cbox" / "meshes" / f"cbox_{name}.obj").read_text()
        put("xml", "shared_cbox_with_meshes.xml", text)
print("seeds in", OUT)
