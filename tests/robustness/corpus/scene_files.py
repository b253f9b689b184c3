"""Bad-input cases: scene files (the XML itself) through load_scene."""
from __future__ import annotations

from .common import FILE_ERRORS, JUNK, REPO, cases_for

# --------------------------------------------------------------------------------------------------
# Scene files: the XML itself.


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
    ("zero sphere radius", lambda c: c.ml.load_scene(c.scene_with(
        "zeror", '<shape type="sphere"><float name="radius" value="0"/></shape>')), ["radius", "scene.xml:8"]),
    # Emitted values that are NaN, negative or overflow float32: refused where they are written (they had
    # dropped area and constant emitters silently).
    ("NaN area radiance", lambda c: c.ml.load_scene(c.scene_with(
        "nanarea", '<shape type="rectangle"><emitter type="area"><rgb name="radiance" value="nan, 1, 1"/>'
        '</emitter></shape>')), ["radiance", "nan", "scene.xml:8"]),
    ("negative constant radiance", lambda c: c.ml.load_scene(c.scene_with(
        "negconst", '<emitter type="constant"><rgb name="radiance" value="-0.5"/></emitter>')),
     ["radiance", "-0.5", "scene.xml:8"]),
    ("area radiance overflowing float32", lambda c: c.ml.load_scene(c.scene_with(
        "hugearea", '<shape type="rectangle"><emitter type="area"><rgb name="radiance" value="1e40"/>'
        '</emitter></shape>')), ["radiance", "inf", "scene.xml:8"]),
    # Mitsuba's camera rays would pass through area emitters: refused, not rendered with the emitters.
    ("integrator hiding emitters", lambda c: c.ml.load_scene(c.scene_with(
        "hide", '<integrator type="path"><boolean name="hide_emitters" value="true"/></integrator>')),
     ["hide_emitters", "scene.xml:8"]),
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
