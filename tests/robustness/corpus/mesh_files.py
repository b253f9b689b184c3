"""Bad-input cases: mesh files (OBJ, PLY) through load_scene."""
from __future__ import annotations

from .common import FILE_ERRORS, JUNK, OBJ, cases_for, ply_binary

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
