"""Image formats Mitsuba reads (EXR, Radiance RGBE, PFM; tiny env maps
padded as Mitsuba pads them), `serialized` meshes, `cylinder`, and `shapegroup` + `instance`, each
checked against mitsuba 3.9.1 (written files, `mi.load_dict` vertex buffers, pixel-centre renders and
G-buffers by Mitsuba's own ray intersection)."""
import struct
import zlib

import numpy as np
import pytest

import manylights as ml

SENSOR = """<sensor type="perspective"><float name="fov" value="{fov}"/>
  <transform name="to_world"><lookat origin="{origin}" target="{target}" up="0, 1, 0"/></transform>
  <film type="hdrfilm"><integer name="width" value="{w}"/><integer name="height" value="{h}"/>
  <rfilter type="box"/></film></sensor>"""


def _scene(body: str, *, w=32, h=32, fov=40, origin="0, 0, 5", target="0, 0, 0") -> str:
    return f'<scene version="3.0.0">\n{SENSOR.format(w=w, h=h, fov=fov, origin=origin, target=target)}\n{body}\n</scene>\n'


# ---- item 5: image formats and tiny environment maps ----

# Env radiance along pixel-centre rays: texels identical to Mitsuba's own reading of the same file; the
# f32 camera rays and lookups of the two renderers differ slightly (measured: 1.1e-5 relative at most).
ENV_RTOL = 5e-5


@pytest.mark.parametrize("size", [(1, 1), (7, 1), (7, 2), (13, 5)])
@pytest.mark.parametrize("ext", ["exr", "hdr", "pfm"])
def test_envmap_formats_match_mitsuba_at_pixel_centres(tmp_path, mitsuba_ref, size, ext):
    mi = mitsuba_ref.mitsuba()
    w, h = size
    rng = np.random.default_rng(w * 100 + h)
    texels = rng.uniform(0.01, 4.0, (h, w, 3)).astype(np.float32)
    mi.Bitmap(texels).write(str(tmp_path / f"env.{ext}"))  # Mitsuba writes the file
    # A wide camera sees mostly sky; the one shape (required here) sits behind it.
    xml = tmp_path / "scene.xml"
    xml.write_text(_scene(f"""<emitter type="envmap"><string name="filename" value="env.{ext}"/>
  <float name="scale" value="1.5"/><transform name="to_world"><rotate y="1" angle="30"/></transform></emitter>
<shape type="rectangle"><transform name="to_world"><translate z="9"/></transform></shape>""", fov=150,
                          origin="0, 0, 0", target="0.3, 0.4, -1"))
    ref, _ = mitsuba_ref.mitsuba_render(xml, (32, 32), max_depth=1)
    scene = ml.load_scene(xml)
    env = [e for e in scene.emitters if e["type"] == "envmap"][0]
    # Mitsuba pads env maps to at least 2 x 3 texels (mi.traverse data is (H, W + 2, 3)).
    data = np.array(mi.traverse(mi.load_dict({"type": "envmap", "filename": str(tmp_path / f"env.{ext}")}))["data"])
    assert (env["height"], env["width"] + 2) == data.shape[:2]
    A = ml.LightMatrix(scene, ml.generate_lights(scene, area=0, environment=4))
    ours = A.emitted()
    assert ref.max() > 0.0
    np.testing.assert_allclose(ours, ref, rtol=ENV_RTOL, atol=1e-6)


def test_bad_image_files_are_clear_errors(tmp_path):
    (tmp_path / "cut.hdr").write_bytes(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 4 +X 4\n\x80\x80")
    (tmp_path / "cut.pfm").write_bytes(b"PF\n4 4\n-1\n\0\0\0\0")
    for name in ["cut.hdr", "cut.pfm"]:
        xml = tmp_path / f"{name}.xml"
        xml.write_text(_scene(f'<emitter type="envmap"><string name="filename" value="{name}"/></emitter>\n'
                              '<shape type="rectangle"/>'))
        with pytest.raises(ml.SceneError, match=rf"{name}.xml:6: .*{name}"):
            ml.load_scene(xml)


# ---- item 6: serialized meshes ----

def _write_serialized(path, meshes):
    """Mitsuba's .serialized format (version 4), written independently of manylights: per sub-mesh
    u16 0x041C, u16 4, zlib(flags, name, counts, arrays, u32 indices); then u64 offsets and a u32 count."""
    out, offsets = b"", []
    for m in meshes:
        offsets.append(len(out))
        dt = "<f8" if m["double"] else "<f4"
        flags = (0x2000 if m["double"] else 0x1000) | (1 if "n" in m else 0) | (2 if "uv" in m else 0) \
            | (8 if "rgb" in m else 0)
        body = struct.pack("<I", flags) + m["name"].encode() + b"\0"
        body += struct.pack("<QQ", len(m["p"]), len(m["f"]))
        for k in ["p", "n", "uv", "rgb"]:
            if k in m:
                body += np.asarray(m[k], dt).tobytes()
        body += np.asarray(m["f"], "<u4").tobytes()
        out += struct.pack("<HH", 0x041C, 4) + zlib.compress(body)
    out += np.asarray(offsets, "<u8").tobytes() + struct.pack("<I", len(meshes))
    path.write_bytes(out)


def test_serialized_matches_mitsuba_vertex_buffers(tmp_path, mitsuba_ref):
    mitsuba_ref.mitsuba()
    rng = np.random.default_rng(3)
    # A bumpy 6x6 grid: sub-mesh 0 single precision without normals (recomputed), sub-mesh 1 double
    # precision with normals, uvs and colours (skipped).
    g = np.stack(np.meshgrid(np.linspace(-1, 1, 6), np.linspace(-1, 1, 6)), -1).reshape(-1, 2)
    p = np.column_stack([g, 0.1 * rng.standard_normal(len(g))])
    f = np.array([[r * 6 + c, r * 6 + c + 1, r * 6 + c + 7] for r in range(5) for c in range(5)]
                 + [[r * 6 + c, r * 6 + c + 7, r * 6 + c + 6] for r in range(5) for c in range(5)])
    n = p / np.linalg.norm(p, axis=1, keepdims=True) + [0, 0, 2]
    _write_serialized(tmp_path / "m.serialized", [
        {"name": "a", "double": False, "p": p, "f": f},
        {"name": "b", "double": True, "p": p * 2 + 1, "n": n, "uv": g * 0.5 + 0.5, "rgb": np.ones_like(p), "f": f},
    ])
    tw = '<transform name="to_world"><rotate x="1" angle="40"/><rotate y="1" angle="25"/><scale value="1.5, 0.5, 2"/>' \
         '<translate x="0.2"/></transform>'
    for k in range(2):
        xml = tmp_path / f"s{k}.xml"
        xml.write_text(_scene(f'<shape type="serialized" id="s"><string name="filename" value="m.serialized"/>'
                              f'<integer name="shape_index" value="{k}"/>{tw}</shape>'))
        ours = ml.load_scene(xml).mesh(0)
        ref = mitsuba_ref.load(xml).shapes()[0]
        vp = np.array(ref.vertex_positions_buffer()).reshape(-1, 3)
        np.testing.assert_allclose(ours["positions"], vp, atol=2e-6)
        np.testing.assert_array_equal(ours["indices"], np.array(ref.faces_buffer()).reshape(-1, 3))
        vn = np.array(ref.vertex_normals_buffer()).reshape(-1, 3)
        # Normals: recomputed ones match exactly; file normals under this non-uniform scale: Mitsuba uses
        # the inverse transpose too (serialized.cpp multiplies a Normal3f), so they agree as well.
        np.testing.assert_allclose(ours["normals"], vn, atol=2e-6)
        if k == 1:
            np.testing.assert_allclose(ours["uvs"], np.array(ref.vertex_texcoords_buffer()).reshape(-1, 2), atol=1e-7)
    with pytest.raises(ml.SceneError, match="m.serialized.*out of range"):
        xml.write_text(_scene('<shape type="serialized"><string name="filename" value="m.serialized"/>'
                              '<integer name="shape_index" value="2"/></shape>'))
        ml.load_scene(xml)


# ---- item 6: cylinder and instancing, G-buffers against Mitsuba's ray intersection ----

def _mitsuba_hits(xml, mitsuba_ref, size):
    """Pixel-centre ray_intersect by Mitsuba: position, normal, geo_normal, uv and the index in
    ``scene.shapes()`` of the shape hit, or of its *instance* for instanced shapes (what the ``aov``
    integrator's shape_index reports), -1 for a miss. (H, W, c) arrays."""
    mi = mitsuba_ref.mitsuba()
    w, h = size
    scene = mitsuba_ref.load(xml)
    shapes = scene.shapes()
    sensor = scene.sensors()[0]
    out = {k: np.zeros((h * w, 3), np.float32) for k in ("position", "normal", "geo_normal")}
    out["uv"] = np.zeros((h * w, 2), np.float32)
    sid = np.full(h * w, -1, np.int32)
    prim = np.full(h * w, -1, np.int32)
    if mi.variant().startswith("scalar"):
        for k, ray in enumerate(mitsuba_ref._pixel_centre_rays_scalar(mi, sensor, w, h)):
            si = scene.ray_intersect(ray)
            if si.is_valid():
                for key, v in [("position", si.p), ("normal", si.sh_frame.n), ("geo_normal", si.n), ("uv", si.uv)]:
                    out[key][k] = np.array(v)
                target = si.instance if si.instance is not None else si.shape
                sid[k] = next(i for i, s in enumerate(shapes) if s == target)
                prim[k] = si.prim_index
    else:
        si = scene.ray_intersect(mitsuba_ref._pixel_centre_rays(mi, sensor, w, h))
        valid = np.array(si.is_valid())
        for key, v, c in [("position", si.p, 3), ("normal", si.sh_frame.n, 3), ("geo_normal", si.n, 3), ("uv", si.uv, 2)]:
            a = np.array(v, dtype=np.float32)
            out[key] = (a.T if a.shape == (c, h * w) else a.reshape(h * w, c)).copy()
            out[key][~valid] = 0.0
        for i, s in enumerate(shapes):
            ptr = mi.ShapePtr(s)
            sid[valid & (np.array(si.shape == ptr) | np.array(si.instance == ptr))] = i
        prim[valid] = np.array(si.prim_index, dtype=np.int64)[valid]
    res = {k: v.reshape(h, w, -1) for k, v in out.items()}
    res["shape_index"] = sid.reshape(h, w)
    res["prim_index"] = prim.reshape(h, w)
    return res, [s.id() for s in shapes]


def _gbuffer_errors(xml, mitsuba_ref, size=(32, 32)):
    scene = ml.load_scene(xml)
    gb = scene.gbuffer()
    ref, _ = _mitsuba_hits(xml, mitsuba_ref, size)
    hit = (gb["shape_index"] >= 0) & (ref["shape_index"] >= 0)
    both = (gb["shape_index"] >= 0) == (ref["shape_index"] >= 0)
    pos = np.linalg.norm(gb["position"] - ref["position"], axis=-1)[hit]
    ndot = (gb["normal"] * ref["normal"]).sum(-1)[hit]
    gdot = (gb["geo_normal"] * ref["geo_normal"]).sum(-1)[hit]
    uv = np.abs(gb["uv"] - ref["uv"]).max(-1)[hit]
    return scene, gb, ref, dict(coverage=both.mean(), hits=int(hit.sum()), pos=pos, ndot=ndot, gdot=gdot, uv=uv)


# Tessellation of the cylinder (512 strips): vertices on the surface, strips up to 1.9e-5 radius inside
# it; at grazing rays the hit slides along the ray (measured up to 1.2e-4 here). Shading normals are the
# exact radial direction of the hit; face normals are within pi/512 rad of the radial direction at
# the facet, and grazing hits may land on the neighbouring strip: within 2 pi / 512 of Mitsuba's.
CYL_POS_TOL = 2.5e-4
CYL_NDOT = 1 - 1e-6
CYL_GDOT = np.cos(2 * np.pi / 512)


def test_cylinder_gbuffer_matches_mitsuba(tmp_path, mitsuba_ref):
    xml = tmp_path / "cyl.xml"
    xml.write_text(_scene("""
<shape type="cylinder" id="a"><point name="p0" x="-1" y="-0.5" z="0"/><point name="p1" x="1" y="0.3" z="-0.5"/>
  <float name="radius" value="0.4"/></shape>
<shape type="cylinder" id="b"><transform name="to_world"><scale value="0.3"/><rotate x="1" angle="-60"/>
  <translate x="0.3" y="0.8" z="0.5"/></transform><boolean name="flip_normals" value="true"/></shape>
<shape type="cylinder" id="c"><transform name="to_world"><scale x="0.5" y="0.5" z="1.2"/><translate x="0.5" y="-1.4" z="-1"/></transform></shape>
<shape type="cylinder" id="d"><transform name="to_world"><scale x="-0.3" y="0.3" z="0.6"/><rotate y="1" angle="70"/><translate x="-1.2" y="0.6" z="-0.4"/></transform></shape>""",
                          origin="0.5, 1, 5"))
    scene, gb, ref, e = _gbuffer_errors(xml, mitsuba_ref)
    print(f"cylinder: coverage {e['coverage']:.4f}, {e['hits']} hits, position max {e['pos'].max():.2e}, "
          f"normal 1-dot max {(1 - e['ndot']).max():.2e}, geo 1-dot max {(1 - e['gdot']).max():.2e}, uv max {e['uv'].max():.2e}")
    assert e["hits"] > 150 and e["coverage"] >= 0.995
    assert [s["type"] for s in scene.shapes] == ["cylinder"] * 4
    ok = lambda m: m.mean() >= 0.995  # noqa: E731  silhouette pixels may hit the tessellation differently
    assert ok(e["pos"] <= CYL_POS_TOL), np.sort(e["pos"])[-10:]
    assert ok(e["ndot"] >= CYL_NDOT), np.sort(e["ndot"])[:10]
    assert ok(e["gdot"] >= CYL_GDOT), np.sort(e["gdot"])[:10]
    assert ok(e["uv"] <= 1e-3), np.sort(e["uv"])[-10:]


def test_instances_gbuffer_matches_mitsuba(tmp_path, mitsuba_ref):
    xml = tmp_path / "inst.xml"
    xml.write_text(_scene("""
<shape type="shapegroup" id="g">
  <shape type="cube" id="box"><transform name="to_world"><scale value="0.3"/></transform>
    <bsdf type="diffuse"/></shape>
  <shape type="sphere" id="ball"><point name="center" x="0" y="0.6" z="0"/><float name="radius" value="0.25"/></shape>
</shape>
<shape type="instance" id="i1"><ref id="g"/><transform name="to_world"><rotate y="1" angle="30"/><translate x="-0.8"/></transform></shape>
<shape type="instance" id="i2"><ref id="g"/><transform name="to_world"><scale value="1.5"/><translate x="0.8" y="-0.3"/></transform></shape>
<shape type="rectangle" id="floor"><transform name="to_world"><rotate x="1" angle="-90"/><scale value="3"/><translate y="-0.9"/></transform></shape>""",
                          origin="0, 1.5, 5"))
    scene, gb, ref, e = _gbuffer_errors(xml, mitsuba_ref)
    assert [s["id"] for s in scene.shapes] == ["i1/box", "i1/ball", "i2/box", "i2/ball", "floor"]
    assert e["hits"] > 300 and e["coverage"] >= 0.995
    print(f"instances: position max {e['pos'].max():.2e}, normal 1-dot max {(1 - e['ndot']).max():.2e}")
    assert (e["pos"] <= 1e-4).mean() >= 0.995
    assert (e["ndot"] >= 1 - 1e-5).mean() >= 0.995
    # Every instance is seen where Mitsuba sees it (Mitsuba's shape index is the instance's).
    names = _mitsuba_hits(xml, mitsuba_ref, (32, 32))[1]
    for inst in ["i1", "i2"]:
        ours = np.isin(gb["shape_index"], [k for k, s in enumerate(scene.shapes) if s["id"].startswith(inst + "/")])
        theirs = ref["shape_index"] == names.index(inst)
        assert (ours == theirs).mean() >= 0.995 and theirs.sum() > 50
        # Triangles of the instanced cube: Mitsuba's prim_index is the triangle of the group's shape, so is ours.
        box = (gb["shape_index"] == [s["id"] for s in scene.shapes].index(inst + "/box")) & theirs
        assert box.sum() > 20 and (gb["prim_index"][box] == ref["prim_index"][box]).mean() >= 0.99


def test_new_shape_errors(tmp_path):
    # 5 vertices announced, the stream ends after 1.
    cut = struct.pack("<I", 0x1000) + b"x\0" + struct.pack("<QQ", 5, 1) + b"\0" * 12
    (tmp_path / "cut.serialized").write_bytes(struct.pack("<HH", 0x041C, 4) + zlib.compress(cut))
    cases = [
        ('<shape type="serialized"><string name="filename" value="cut.serialized"/></shape>',
         "cut.serialized.*vertex positions need 60 bytes"),
        ('<shape type="cylinder"><float name="radius" value="0.5"/><point name="p1" value="0, 0, 0"/></shape>',
         "must differ"),
        ('<shape type="instance"/>', "needs a reference to a shapegroup"),
        ('<shape type="rectangle" id="r"/><shape type="instance"><ref id="r"/></shape>', "only a shapegroup"),
        ('<shape type="shapegroup" id="g"><shape type="rectangle"><emitter type="area"/></shape></shape>',
         "instancing of emitters"),
        ('<shape type="shapegroup" id="g"><shape type="shapegroup"/></shape>', "nested shapegroups"),
    ]
    for k, (body, msg) in enumerate(cases):
        xml = tmp_path / f"bad{k}.xml"
        xml.write_text(_scene('<shape type="cube" id="keep"/>' + body))
        with pytest.raises(ml.SceneError, match=msg):
            ml.load_scene(xml)
