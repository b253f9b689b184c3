"""Gather cloud and its cluster hierarchy: `ml.gather_cloud`, `GatherCloud.on`,
`GatherCloud.hierarchy`. Areas, surface points, normals, uvs and diffuse reflectances are checked against
Mitsuba 3.9.1's own values (`shape.surface_area()`, `scene.ray_intersect`, `bsdf.eval_diffuse_reflectance`)."""
from __future__ import annotations

import numpy as np
import pytest

import manylights as ml
from conftest import SCENES, TEST_SCENES

CBOX_LIGHTS = SCENES / "cbox-lights" / "scene.xml"
MATPREVIEW = TEST_SCENES / "matpreview" / "scene.xml"


@pytest.fixture(scope="module")
def cbox_lights():
    return ml.load_scene(CBOX_LIGHTS, res=32)


def _mitsuba_hits(mitsuba_ref, mi_scene, origins, directions, bsdf_of=None):
    """Mitsuba's ray_intersect of rays (o, d) with t_max 1e-3: p, n (geometric), sh_n, uv, shape id, prim index
    and, when `bsdf_of` (a Mitsuba shape) is given, its bsdf's eval_diffuse_reflectance at each hit."""
    mi = mitsuba_ref.mitsuba()
    shapes = mi_scene.shapes()
    n = len(origins)
    out = {k: np.zeros((n, 3), np.float32) for k in ("p", "n", "sh_n", "kd")}
    out["uv"] = np.zeros((n, 2), np.float32)
    out["shape"] = [None] * n
    out["prim"] = np.full(n, -1, np.int64)
    if mi.variant().startswith("scalar"):
        for k in range(n):
            ray = mi.Ray3f(mi.Point3f(*map(float, origins[k])), mi.Vector3f(*map(float, directions[k])))
            ray.maxt = 1e-3
            si = mi_scene.ray_intersect(ray)
            if not si.is_valid():
                continue
            for key, v in [("p", si.p), ("n", si.n), ("sh_n", si.sh_frame.n), ("uv", si.uv)]:
                out[key][k] = np.array(v)
            out["shape"][k] = si.shape.id()
            out["prim"][k] = si.prim_index
            if bsdf_of is not None:
                out["kd"][k] = np.array(bsdf_of.bsdf().eval_diffuse_reflectance(si))
        return out
    import drjit as dr  # noqa: F401

    o = mi.Point3f(*(mi.Float(origins[:, c].astype(np.float32)) for c in range(3)))
    d = mi.Vector3f(*(mi.Float(directions[:, c].astype(np.float32)) for c in range(3)))
    ray = mi.Ray3f(o, d)
    ray.maxt = mi.Float(np.full(n, 1e-3, np.float32))
    si = mi_scene.ray_intersect(ray)
    valid = np.array(si.is_valid())

    def arr(v, c):
        a = np.array(v, dtype=np.float32)
        return a.T if a.shape == (c, n) else a.reshape(n, c)

    out["p"], out["n"], out["sh_n"], out["uv"] = arr(si.p, 3), arr(si.n, 3), arr(si.sh_frame.n, 3), arr(si.uv, 2)
    for s in shapes:
        hit = valid & np.array(si.shape == mi.ShapePtr(s))
        for k in np.nonzero(hit)[0]:
            out["shape"][k] = s.id()
    out["prim"] = np.where(valid, np.array(si.prim_index, dtype=np.int64), -1)
    if bsdf_of is not None:
        kd = np.array(bsdf_of.bsdf().eval_diffuse_reflectance(si), dtype=np.float32)
        # A constant reflectance comes back with width 1.
        out["kd"] = np.tile(kd.ravel(), (n, 1)) if kd.size == 3 else arr(kd, 3)
    return out


def test_arrays_and_area_per_shape_match_mitsuba(cbox_lights, mitsuba_ref):
    """Each shape holds n * (its Mitsuba surface_area / total) samples within the stratification error (at most
    4 samples; measured <= 2 on this scene and seed, Rust test); the total area equals the sum of Mitsuba's
    surface areas (sphere analytic); every sample stands for total / n."""
    n = 4**6
    c = ml.gather_cloud(cbox_lights, n=n, seed=3)
    assert len(c) == n and c.side == 64
    for name, shape, dtype in [("positions", (n, 3), np.float32), ("normals", (n, 3), np.float32),
                               ("geo_normals", (n, 3), np.float32), ("uv", (n, 2), np.float32),
                               ("areas", (n,), np.float32), ("shape", (n,), np.int64), ("triangle", (n,), np.int64),
                               ("barycentrics", (n, 2), np.float32), ("k_d", (n, 3), np.float32),
                               ("k_g", (n, 3), np.float32), ("roughness", (n,), np.float32)]:
        a = getattr(c, name)
        assert a.shape == shape and a.dtype == dtype, name
    assert c.bsdf.shape == (n, 20) and c.bsdf.dtype == np.uint32
    mi_scene = mitsuba_ref.load(CBOX_LIGHTS, res=32)
    mi_area = {s.id(): float(np.asarray(s.surface_area()).ravel()[0]) for s in mi_scene.shapes()}
    ids = [s["id"] for s in cbox_lights.shapes]
    assert set(ids) == set(mi_area)
    total = sum(mi_area.values())
    assert c.total_area == pytest.approx(total, rel=1e-5)
    np.testing.assert_allclose(c.areas, total / n, rtol=1e-5)
    counts = np.bincount(c.shape, minlength=len(ids))
    expected = np.array([n * mi_area[i] / total for i in ids])
    assert np.abs(counts - expected).max() <= 4.0, (counts, expected)
    ball = ids.index("ball")
    assert (c.triangle[c.shape == ball] == -1).all() and (c.triangle[c.shape != ball] >= 0).all()


def test_samples_are_mitsuba_surface_points(cbox_lights, mitsuba_ref):
    """A ray shot at each sample from 1e-4 above it hits, in Mitsuba, the same shape and (away from edges and
    the box bottoms lying on the floor) the same triangle, at the sample's position with its geometric and
    shading normals and uv. Measured (4^5 samples): 98.2% same triangle; position 2.5e-7, normals 1.8e-7,
    uv 2.4e-7 at most (the scene is ~2 units across); bound 2e-6."""
    c = ml.gather_cloud(cbox_lights, n=4**4, seed=1)
    p, ng = c.positions.astype(np.float64), c.geo_normals.astype(np.float64)
    hits = _mitsuba_hits(mitsuba_ref, mitsuba_ref.load(CBOX_LIGHTS, res=32), p + 1e-4 * ng, -ng)
    ids = [s["id"] for s in cbox_lights.shapes]
    same = np.array([hits["shape"][k] == ids[c.shape[k]] and (c.triangle[k] == -1 or hits["prim"][k] == c.triangle[k])
                     for k in range(len(c))])
    assert same.mean() >= 0.95, same.mean()
    assert np.linalg.norm(hits["p"] - c.positions, axis=1).max() < 2e-6
    np.testing.assert_allclose(hits["n"][same], c.geo_normals[same], atol=2e-6)
    np.testing.assert_allclose(hits["sh_n"][same], c.normals[same], atol=2e-6)
    np.testing.assert_allclose(hits["uv"][same], c.uv[same], atol=2e-6)


def test_diffuse_reflectance_matches_mitsuba(mitsuba_ref):
    """k_d at every sample on matpreview's checkerboard plane (diffuse, textured) and its plastic object equals
    Mitsuba's eval_diffuse_reflectance at the same surface point (the checkerboard's edges excepted: a uv
    rounding can flip a square, 1% of the samples at most; measured: all 825 plane and 149 object samples equal
    exactly)."""
    scene = ml.load_scene(MATPREVIEW, width=32, height=24)
    c = ml.gather_cloud(scene, n=4**5, seed=0)
    mi_scene = mitsuba_ref.load(MATPREVIEW, width=32, height=24)
    ids = [s["id"] for s in scene.shapes]
    for shape_id, textured in [("shape-plane", True), ("shape-matpreview-exterior", False)]:
        on = np.nonzero(c.shape == ids.index(shape_id))[0]
        assert len(on) > 10, shape_id
        mi_shape = next(s for s in mi_scene.shapes() if s.id() == shape_id)
        p, ng = c.positions[on].astype(np.float64), c.geo_normals[on].astype(np.float64)
        hits = _mitsuba_hits(mitsuba_ref, mi_scene, p + 1e-4 * ng, -ng, bsdf_of=mi_shape)
        hit = np.array([h == shape_id for h in hits["shape"]])
        assert hit.mean() > 0.95
        agree = np.abs(hits["kd"][hit] - c.k_d[on][hit]).max(axis=1) < 1e-5
        assert agree.mean() >= (0.99 if textured else 1.0), (shape_id, agree.mean())
        if textured:
            assert len(np.unique(c.k_d[on][:, 0])) == 2  # both colours of the checkerboard are sampled
        else:
            np.testing.assert_allclose(c.k_d[on], np.tile([0.940, 0.271, 0.361], (len(on), 1)), atol=1e-6)


MOVING = """<scene version="3.0.0">
    <default name="dx" value="0"/>
    <default name="s" value="1"/>
    <sensor type="perspective"><film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="16"/></film>
        <transform name="to_world"><lookat origin="0, 1, 4" target="0, 0, 0" up="0, 1, 0"/></transform></sensor>
    <bsdf type="diffuse" id="grey"><rgb name="reflectance" value="0.5, 0.4, 0.3"/></bsdf>
    <shape type="rectangle" id="floor"><transform name="to_world"><rotate x="1" angle="-90"/><scale value="2"/></transform><ref id="grey"/></shape>
    <shape type="cube" id="box"><transform name="to_world"><scale value="0.3"/><scale x="$s"/><translate x="$dx" y="0.3"/></transform><ref id="grey"/></shape>
    EXTRA
</scene>
"""


def _moving(tmp_path, extra="", **params):
    path = tmp_path / f"moving{len(extra)}.xml"
    path.write_text(MOVING.replace("EXTRA", extra))
    return ml.load_scene(path, **params)


def test_on_follows_an_animation_frame(tmp_path):
    """The cloud of frame 0 evaluated on frame 1 (the box moved by dx = 0.5 and stretched 2x along x): floor
    samples stay, box samples move with their barycentrics (same triangle, same barycentrics), and the areas of
    samples on the box's faces scale by their triangle's change of area (x 2 for faces spanning x, x 1 for the
    two faces normal to x)."""
    f0, f1 = _moving(tmp_path), _moving(tmp_path, dx=0.5, s=2)
    c0 = ml.gather_cloud(f0, n=4**5, seed=2)
    c1 = c0.on(f1)
    np.testing.assert_array_equal(c1.shape, c0.shape)
    np.testing.assert_array_equal(c1.barycentrics, c0.barycentrics)
    floor, box = c0.shape == 0, c0.shape == 1
    np.testing.assert_array_equal(c1.positions[floor], c0.positions[floor])
    expect = c0.positions[box] * [2.0, 1.0, 1.0] + [0.5, 0.0, 0.0]
    np.testing.assert_allclose(c1.positions[box], expect, atol=1e-5)
    ratio = c1.areas[box] / c0.areas[box]
    x_faces = np.abs(c0.normals[box][:, 0]) > 0.5
    np.testing.assert_allclose(ratio[x_faces], 1.0, rtol=1e-4)
    np.testing.assert_allclose(ratio[~x_faces], 2.0, rtol=1e-4)
    np.testing.assert_allclose(c1.k_d, c0.k_d)
    assert c1.total_area == pytest.approx(c1.areas.astype(np.float64).sum(), rel=1e-6)
    # Re-evaluating on its own scene changes nothing.
    same = c0.on(f0)
    np.testing.assert_array_equal(same.positions, c0.positions)
    np.testing.assert_array_equal(same.areas, c0.areas)


def test_on_refuses_another_topology(tmp_path):
    c0 = ml.gather_cloud(_moving(tmp_path), n=16)
    extra = _moving(tmp_path, extra='<shape type="sphere" id="ball"><ref id="grey"/></shape>')
    with pytest.raises(ValueError, match="3 shapes.*same topology|same topology"):
        c0.on(extra)
    with pytest.raises(TypeError):
        c0.on("scene.xml")


def test_hierarchy_is_a_balanced_quad_tree_over_the_gather_image(cbox_lights):
    """order / pixel / sample_at_pixel are permutations; every depth-j cluster (4^(k-j) consecutive entries of
    `order`) is one aligned 2^(k-j) block of the gather image; clusters are compact: the mean distance of the
    samples of a 4-sample leaf parent to its centroid is far below that of random groups of 4 (measured 0.121
    against 0.962)."""
    c = ml.gather_cloud(cbox_lights, n=4**5, seed=0)
    h = c.hierarchy(K=30)
    k, side = h["levels"], h["side"]
    assert (k, side, h["K"]) == (5, 32, 30.0)
    n = len(c)
    for key in ("order", "pixel", "sample_at_pixel"):
        assert h[key].dtype == np.int64 and np.array_equal(np.sort(h[key]), np.arange(n)), key
    np.testing.assert_array_equal(h["sample_at_pixel"][h["pixel"]], np.arange(n))
    rows, cols = h["pixel"] // side, h["pixel"] % side
    for depth in range(k + 1):
        size, block = 4 ** (k - depth), 2 ** (k - depth)
        for cl in range(0, 4**depth, max(1, 4**depth // 16)):
            members = h["order"][cl * size:(cl + 1) * size]
            assert len({(r, q) for r, q in zip(rows[members] // block, cols[members] // block)}) == 1
    image = c.positions[h["sample_at_pixel"]].reshape(side, side, 3)
    np.testing.assert_array_equal(image[rows[7], cols[7]], c.positions[7])
    leaves = c.positions[h["order"]].reshape(-1, 4, 3)
    spread = np.linalg.norm(leaves - leaves.mean(axis=1, keepdims=True), axis=2).mean()
    rnd = c.positions[np.random.default_rng(0).permutation(n)].reshape(-1, 4, 3)
    spread_random = np.linalg.norm(rnd - rnd.mean(axis=1, keepdims=True), axis=2).mean()
    assert spread < 0.2 * spread_random, (spread, spread_random)
    # Deterministic, and K changes the tree.
    np.testing.assert_array_equal(c.hierarchy(K=30)["order"], h["order"])
    assert not np.array_equal(c.hierarchy(K=0.5)["order"], h["order"])


def test_same_seed_same_cloud(cbox_lights):
    a, b, d = (ml.gather_cloud(cbox_lights, n=64, seed=s) for s in (4, 4, 5))
    np.testing.assert_array_equal(a.positions, b.positions)
    assert not np.array_equal(a.positions, d.positions)
    assert ml.gather_cloud(cbox_lights, n=64, seed=4, include_emitters=False).shape.tolist().count(
        [s["id"] for s in cbox_lights.shapes].index("light")) == 0


@pytest.mark.parametrize("n", [0, 2, 8, 32, 4**13, -4])
def test_n_must_be_a_power_of_4(cbox_lights, n):
    with pytest.raises(ValueError, match="power of 4" if n >= 0 else "n must be in 0"):
        ml.gather_cloud(cbox_lights, n=n)


@pytest.mark.parametrize("bad", [{"n": 4.5}, {"n": "16"}, {"n": True}, {"seed": -1}, {"seed": 0.5}])
def test_bad_arguments(cbox_lights, bad):
    with pytest.raises(ValueError):
        ml.gather_cloud(cbox_lights, **bad)


SENSOR = ('<sensor type="perspective"><film type="hdrfilm"><integer name="width" value="8"/>'
          '<integer name="height" value="8"/></film></sensor>')


def test_scene_without_surfaces(tmp_path):
    """A scene whose only mesh has zero area (loaded with a warning, as Mitsuba does), and a scene whose only
    shape is an emitter when emitters are left out, have no surface for gather samples."""
    (tmp_path / "flat.obj").write_text("v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n")
    path = tmp_path / "flat.xml"
    path.write_text(f'<scene version="3.0.0">{SENSOR}<shape type="obj"><string name="filename" value="flat.obj"/></shape>'
                    '<emitter type="point"><point name="position" x="0" y="1" z="0"/></emitter></scene>')
    with pytest.warns(UserWarning):
        scene = ml.load_scene(path)
    with pytest.raises(ValueError, match="no surface"):
        ml.gather_cloud(scene, n=16)
    path = tmp_path / "light.xml"
    path.write_text(f'<scene version="3.0.0">{SENSOR}<shape type="rectangle"><emitter type="area"><rgb name="radiance" '
                    'value="1"/></emitter></shape></scene>')
    scene = ml.load_scene(path)
    assert len(ml.gather_cloud(scene, n=16)) == 16
    with pytest.raises(ValueError, match="no surface.*emitters excluded"):
        ml.gather_cloud(scene, n=16, include_emitters=False)
    with pytest.raises(TypeError, match="Scene"):
        ml.gather_cloud(str(path), n=16)


@pytest.mark.parametrize("K", [0.0, -1.0, float("nan"), float("inf")])
def test_hierarchy_bad_K(cbox_lights, K):
    c = ml.gather_cloud(cbox_lights, n=16)
    with pytest.raises(ValueError, match="K"):
        c.hierarchy(K=K)
