"""Compare the G-buffers of the hand-built test scenes (src/testing/view_scenes.rs) with Mitsuba
3.9.1's aov integrator at pixel centres. Dump them first:
  MANYLIGHTS_GBUFFER_DUMP=/tmp/gbuffer_dump cargo test --release -- --ignored dump_scenes_for_mitsuba
then: python tests/mitsuba_check_gbuffer.py /tmp/gbuffer_dump
"""
import os
import sys
import tempfile

import mitsuba as mi
import numpy as np

mi.set_variant("scalar_rgb")


def check(folder):
    cam = open(os.path.join(folder, "camera.txt")).read().split()
    to_world = np.array(cam[:16], dtype=np.float64).reshape(4, 4)
    fov, near, far, W, H = float(cam[16]), float(cam[17]), float(cam[18]), int(cam[19]), int(cam[20])
    d = {
        "type": "scene",
        "integrator": {"type": "aov", "aovs": "p:position,n:sh_normal,g:geo_normal,uv:uv"},
        "sensor": {
            "type": "perspective", "fov": fov, "fov_axis": "x", "near_clip": near, "far_clip": far,
            "to_world": mi.ScalarTransform4f(to_world.tolist()),
            "sampler": {"type": "stratified", "sample_count": 1, "jitter": False},
            "film": {"type": "hdrfilm", "width": W, "height": H, "rfilter": {"type": "box"}},
        },
    }
    files = sorted(f for f in os.listdir(folder) if f.endswith((".obj", ".sphere")))
    for f in files:
        k = int(f.split(".")[0])
        if f.endswith(".sphere"):
            c = [float(x) for x in open(os.path.join(folder, f)).read().split()]
            d[f"shape_{k:03d}"] = {"type": "sphere", "center": c[:3], "radius": c[3]}
        else:
            has_vn = "\nvn " in open(os.path.join(folder, f)).read()
            d[f"shape_{k:03d}"] = {"type": "obj", "filename": os.path.join(folder, f), "face_normals": not has_vn}
    img = np.array(mi.render(mi.load_dict(d), spp=1))
    k = img.shape[-1] - 11  # the 11 aov channels come last
    ref_p, ref_n, ref_g, ref_uv = (img[..., k:k + 3], img[..., k + 3:k + 6], img[..., k + 6:k + 9],
                                   img[..., k + 9:k + 11])
    ours = np.fromfile(os.path.join(folder, "view.bin"), dtype="<f4").reshape(H, W, 12)
    p, n, g, uv, shape = ours[..., 0:3], ours[..., 3:6], ours[..., 6:9], ours[..., 9:11], ours[..., 11]
    ref_hit = np.abs(ref_p).sum(-1) > 0
    hit = shape >= 0
    both = ref_hit & hit
    lo, hi = p[hit].min(0), p[hit].max(0)
    diag = np.linalg.norm(hi - lo)
    err = np.linalg.norm(p - ref_p, axis=-1) / diag
    print(f"{os.path.basename(folder)} {W}x{H}: coverage mismatches {int((ref_hit != hit).sum())} of {W * H}; "
          f"position error / diag: max {err[both].max():.2e}, pixels > 1e-5: {int((err[both] > 1e-5).sum())}")
    same = both & (err < 1e-5)
    du = np.abs(uv - ref_uv)
    du[..., 0] = np.minimum(du[..., 0], 1 - du[..., 0])  # sphere u wraps at phi = 0
    print(f"  on the same surface ({int(same.sum())} px): max |n - n_ref| {np.abs(n - ref_n)[same].max():.2e}, "
          f"max |g - g_ref| {np.abs(g - ref_g)[same].max():.2e}, max |uv - uv_ref| {du[same].max():.2e}")


root = sys.argv[1] if len(sys.argv) > 1 else os.path.join(tempfile.gettempdir(), "gbuffer_dump")
for name in sorted(os.listdir(root)):
    check(os.path.join(root, name))
