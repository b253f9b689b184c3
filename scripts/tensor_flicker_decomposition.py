"""Where tensor clustering's flicker comes from with a moving camera.

Runs the CI configuration of ``tests/test_tensor_animation.py`` (``bounce``, 8 consecutive frames of its
40-frame path at 48x48, 3,032 lights, moving camera), renders the whole light tensor A once (every light's
column in every frame, ~0.7 GB), and re-does the final reconstruction (Hašan et al. 2008, Sec. 4.5) of the
same clusterings with one part replaced at a time, so each variant isolates one candidate cause:

  chain     the renderer itself: each representative column rendered in its frame k0, carried through the
            chain of nearest-neighbour mappings M(k0 -> k0+1) ... M(k-1 -> k) (the paper);
  direct    one nearest-neighbour mapping from frame k0 straight to frame k (no random walk of chains);
  bilinear  the direct mapping's nearest pixel refined to a bilinear interpolation of its 2x2 source pixels
            on the same surface (normal and albedo agree), weights from the destination point's position
            in the source pixel grid;
  centre    the representative re-chosen (same centroid rule) among the pairs of the cluster's centre frame;
  rec-mapped  Rec(t, k) from the representative column *as mapped* into frame k, read at frame k's rows
            (a ratio estimator with numerator and denominator on the same rows);
  oracle-rec  Rec from the true column norms (all pixels; not available to a renderer);
  exact     every representative rendered in every frame it serves (not a renderer at 300 maps per frame:
            the bound that any better pixel mapping can reach);
  exact+same-rec  that, with Rec(t, k) = sum_J |R(:, j, k)| / |R(:, rep light, k)| (same frame's rows);

and splits the flicker that the mappings add (chain - exact) by the span in frames of the clusters.
Per-frame MRCS at 600 shadow maps (100 rows + 500 columns) is the baseline. Usage:

    python scripts/tensor_flicker_decomposition.py [--seeds 8] [--cache bounce-A.npy] [--still-box] [--frames 8 --res 48]
"""
from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

import manylights as ml
import manylights.scenes
from manylights import _native  # the direct (non-adjacent) mapping is not public API

ROWS, TENSOR_COLUMNS, MRCS_COLUMNS = 100, 200, 500


def animation_tensor(frames=8, res=48, still_box=False):
    """The ``_tensor(still=False)`` setup of tests/test_tensor_animation.py (``still_box``: the box keeps
    its frame-0 pose, only the camera moves)."""
    fr = ml.scenes.animation_frames("bounce", count=40)[:frames]
    if still_box:
        fr = [{**x, **{k: v for k, v in fr[0].items() if k.startswith("box_")}} for x in fr]
    anim = ml.load_animation(ml.scenes.scene_path("bounce"), frames=fr, res=res)
    L = ml.generate_animation_lights(anim, seed=0, area=1024, environment=1024, indirect=1000, photons=20000)
    return ml.LightTensor(anim, L, device="cpu")


def gather(img, src):
    """out[i] = img[src[i]], 0 where src[i] < 0 (a mapping as an index array)."""
    out = np.zeros_like(img)
    ok = src >= 0
    out[ok] = img[src[ok]]
    return out


def bilinear_taps(g, k0, k, nn, H, W, normal_albedo_tol=0.01):
    """(m, 4) source pixels and weights: the nearest pixel nn[i] of frame k0 and the three neighbours
    towards the destination point (its coordinates in k0's pixel grid from the local position gradient),
    bilinear weights, neighbours on another surface (|dn|^2 + |dalbedo|^2 > tol) dropped, renormalised."""
    m = H * W
    P0 = g["position"][k0].reshape(H, W, 3).astype(np.float64)
    V0 = g["shape_index"][k0].reshape(H, W) >= 0
    NA0 = np.concatenate([g["normal"][k0], g["albedo"][k0]], -1).reshape(m, 6).astype(np.float64)
    P = g["position"][k].reshape(m, 3).astype(np.float64)
    taps, wts = np.full((m, 4), -1, np.int64), np.zeros((m, 4))
    idx = np.flatnonzero(nn >= 0)
    s = nn[idx]
    sy, sx = s // W, s % W
    d = P[idx] - P0[sy, sx]

    def neighbour(oy, ox):
        ty, tx = sy + oy, sx + ox
        inside = (ty >= 0) & (ty < H) & (tx >= 0) & (tx < W)
        ty, tx = np.clip(ty, 0, H - 1), np.clip(tx, 0, W - 1)
        return ty, tx, inside & V0[ty, tx]

    def same_surface(t):
        return ((NA0[t] - NA0[s]) ** 2).sum(1) < normal_albedo_tol

    def gradient(oy, ox):
        fy, fx, fok = neighbour(oy, ox)
        by, bx, bok = neighbour(-oy, -ox)
        fok &= same_surface(fy * W + fx)
        bok &= same_surface(by * W + bx)
        return np.where(fok[:, None], P0[fy, fx] - P0[sy, sx], np.where(bok[:, None], P0[sy, sx] - P0[by, bx], 0.0))

    gx, gy = gradient(0, 1), gradient(1, 0)
    a11, a12, a22 = (gx * gx).sum(1), (gx * gy).sum(1), (gy * gy).sum(1)
    b1, b2 = (gx * d).sum(1), (gy * d).sum(1)
    det = a11 * a22 - a12 ** 2
    good = det > 1e-12 * np.maximum(a11 * a22, 1e-30)
    safe = np.where(good, det, 1.0)
    a = np.clip(np.where(good, (a22 * b1 - a12 * b2) / safe, 0), -1, 1)
    b = np.clip(np.where(good, (a11 * b2 - a12 * b1) / safe, 0), -1, 1)
    ex, ey = np.where(a >= 0, 1, -1), np.where(b >= 0, 1, -1)
    footprint = np.maximum(np.linalg.norm(gx, axis=1), np.linalg.norm(gy, axis=1))
    fa, fb = np.abs(a), np.abs(b)
    for c, (oy, ox, w) in enumerate([(0, 0, (1 - fa) * (1 - fb)), (0, ex, fa * (1 - fb)),
                                     (ey, 0, (1 - fa) * fb), (ey, ex, fa * fb)]):
        ty, tx, ok = neighbour(oy, ox)
        t = ty * W + tx
        # same surface, and no farther from the destination point than 1.5 pixel footprints
        ok &= same_surface(t) & (np.linalg.norm(P0[ty, tx] - P[idx], axis=1) < 1.5 * footprint)
        if c == 0:
            ok[:] = True
        taps[idx, c] = np.where(ok, t, -1)
        wts[idx, c] = np.where(ok, w, 0)
    tot = wts.sum(1)
    lost = idx[tot[idx] <= 0]  # every tap with weight dropped: the nearest pixel alone
    wts[lost] = 0
    wts[lost, 0] = 1
    tot[lost] = 1
    return taps, np.where(tot[:, None] > 0, wts / np.where(tot > 0, tot, 1)[:, None], 0)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, default=8)
    ap.add_argument("--cache", default=None, help=".npy file for the full tensor (reused when present)")
    ap.add_argument("--still-box", action="store_true", help="the box keeps its frame-0 pose (camera moves)")
    ap.add_argument("--frames", type=int, default=8, help="consecutive frames of bounce's 40-frame path")
    ap.add_argument("--res", type=int, default=48, help="image width and height")
    args = ap.parse_args(argv)
    t0 = time.time()
    T = animation_tensor(args.frames, args.res, still_box=args.still_box)
    m, n, f = T.shape
    H, W = T.scenes[0].height, T.scenes[0].width
    if args.cache and os.path.exists(args.cache):
        A = np.load(args.cache)
    else:
        A = np.empty((f, n, H, W, 3), np.float32)
        for k in range(f):
            A[k] = T.frame(k).columns(np.arange(n))
        if args.cache:
            np.save(args.cache, A)
    A = A.reshape(f, n, m, 3)
    emitted = np.stack([T.frame(k).emitted().reshape(m, 3) for k in range(f)])
    B = A.sum(1, dtype=np.float64) + emitted
    TN = np.stack([np.sqrt((A[k].astype(np.float64) ** 2).sum(1)) for k in range(f)], axis=1)  # (n, f, 3) true norms
    g = T.animation.gbuffers()
    sc = T.scenes
    cache = {}

    def chain(k0, k):
        return np.asarray(T.mapping(k0, k)).reshape(-1)

    def direct(k0, k):
        if ("d", k0, k) not in cache:
            cache[("d", k0, k)] = _native.pixel_mapping(sc[k0], sc[k], sc[0], "cpu").reshape(-1)
        return cache[("d", k0, k)]

    def bilinear(img, k0, k):
        if ("b", k0, k) not in cache:
            cache[("b", k0, k)] = bilinear_taps(g, k0, k, direct(k0, k), H, W)
        taps, wts = cache[("b", k0, k)]
        out = np.zeros_like(img)
        for c in range(4):
            ok = taps[:, c] >= 0
            out[ok] += wts[ok, c][:, None] * img[taps[ok, c]]
        return out

    def reconstruct(reps, rec, how="chain"):
        """frame_k = sum_t rec[t, k] * (representative t's column carried into frame k) + emitted."""
        out = emitted.astype(np.float64).copy()
        for k in range(f):
            for k0 in range(f):
                sel = np.flatnonzero((reps[:, 1] == k0) & (np.abs(rec[:, k]).sum(1) > 0))
                if not len(sel):
                    continue
                if how == "exact":
                    out[k] += np.einsum("tc,tmc->mc", rec[sel, k], A[k, reps[sel, 0]])
                    continue
                img = np.einsum("tc,tmc->mc", rec[sel, k], A[k0, reps[sel, 0]])
                if k0 == k:
                    out[k] += img
                elif how == "chain":
                    out[k] += gather(img, chain(k0, k))
                elif how == "direct":
                    out[k] += gather(img, direct(k0, k))
                else:
                    out[k] += bilinear(img, k0, k)
        return out

    def score(X):
        X, R = X.reshape(f, H, W, 3), B.reshape(f, H, W, 3)
        return float(ml.relative_l2_per_frame(X, R).mean()), float(ml.flicker(X, R))

    def flicker_part(D):
        dd = np.diff(D, axis=0)
        return float(np.sqrt((dd ** 2).sum() / len(dd) / (2 * (B ** 2).sum() / len(B))))

    table, spans = {}, {}
    for s in range(args.seeds):
        res = ml.tensor_clustering(T, rows=ROWS, columns=TENSOR_COLUMNS, seed=s)
        cl, rows = res.clustering, np.asarray(res.rows)
        R = np.asarray(T.slices(rows), dtype=np.float64)
        CN = np.sqrt((R ** 2).sum(0))  # (n, f, 3) reduced channel norms
        WN = np.sqrt((R ** 2).sum((0, 3)))  # (n, f) weights
        reps, asg, fr = np.asarray(cl.representatives), np.asarray(cl.assignment), np.asarray(cl.frames)
        rec = np.asarray(cl.rec, np.float64)
        rec_same, rec_oracle, rec_mapped = rec.copy(), rec.copy(), rec.copy()
        reps_c, rec_c = reps.copy(), rec.copy()
        for t in range(len(reps)):
            a, b = fr[t]
            J = np.flatnonzero(asg[:, a] == t)
            j0, k0 = reps[t]
            col = A[k0, j0].astype(np.float64)
            for k in range(a, b):
                num = CN[J, k].sum(0)
                rec_same[t, k] = np.where(CN[j0, k] > 0, num / np.where(CN[j0, k] > 0, CN[j0, k], 1), rec[t, k])
                tn = TN[J, k].sum(0)
                rec_oracle[t, k] = np.where(TN[j0, k0] > 0, tn / np.where(TN[j0, k0] > 0, TN[j0, k0], 1), 0)
                if k != k0:
                    mc = gather(col, chain(k0, k))[rows]
                    den = np.sqrt((mc ** 2).sum(0))
                    ok = den > 0.25 * CN[j0, k0]
                    rec_mapped[t, k] = np.where(ok, num / np.where(den > 0, den, 1), rec[t, k])
            if b - a > 1:  # centre-frame representative, same centroid rule and weight floor
                Rs = np.sqrt((R[:, J, a:b] ** 2).sum(-1))
                P, w = Rs.sum((1, 2)), WN[J, a:b]
                floor = 0.5 * w[w > 0].mean() if (w > 0).any() else 0.0
                mid = (a + b - 1) // 2 - a
                best, bd = None, -np.inf
                for kk in [mid] + ([mid + 1] if (b - a) % 2 == 0 else []):
                    for ji in np.flatnonzero((w[:, kk] > 0) & (w[:, kk] >= floor)):
                        dval = (Rs[:, ji, kk] @ P) / w[ji, kk]
                        if dval > bd:
                            bd, best = dval, (J[ji], a + kk)
                if best is not None:
                    reps_c[t] = best
                    for k in range(a, b):
                        den = CN[best[0], best[1]]
                        rec_c[t, k] = np.where(den > 0, CN[J, k].sum(0) / np.where(den > 0, den, 1), 0)
        row = {
            "chain (the renderer)": score(res.frames),
            "direct": score(reconstruct(reps, rec, "direct")),
            "bilinear": score(reconstruct(reps, rec, "bilinear")),
            "centre": score(reconstruct(reps_c, rec_c)),
            "rec-mapped": score(reconstruct(reps, rec_mapped)),
            "oracle-rec": score(reconstruct(reps, rec_oracle)),
            "exact": score(reconstruct(reps, rec, "exact")),
            "exact+same-rec": score(reconstruct(reps, rec_same, "exact")),
            "per-frame MRCS 600": score(ml.mrcs_per_frame(T, rows=ROWS, columns=MRCS_COLUMNS, seed=s).frames),
        }
        span = fr[:, 1] - fr[:, 0]
        for lo, hi in [(2, 2), (3, 4), (5, f)]:
            sel = ((span >= lo) & (span <= hi))[:, None, None]
            r_sel = np.where(sel, rec, 0)
            spans.setdefault(f"{lo}-{hi}", []).append(
                (int(sel.sum()), flicker_part(reconstruct(reps, r_sel) - reconstruct(reps, r_sel, "exact"))))
        for key, v in row.items():
            table.setdefault(key, []).append(v)
        print(f"seed {s}: " + ", ".join(f"{k} {v[0] * 100:.2f}%/{v[1]:.4f}" for k, v in row.items()),
              f"({time.time() - t0:.0f} s)", flush=True)
    base = np.mean([v[1] for v in table["per-frame MRCS 600"]])
    print(f"\nmeans over {args.seeds} seeds (mean per-frame relative L2 / flicker / flicker against MRCS at 600):")
    for key, v in table.items():
        v = np.asarray(v)
        print(f"  {key:22s} {v[:, 0].mean() * 100:5.2f}%  {v[:, 1].mean():.4f}  {v[:, 1].mean() / base:.3f}x")
    print("flicker added by the mappings (chain - exact), by cluster span in frames:")
    for key, v in spans.items():
        v = np.asarray(v)
        print(f"  span {key}: {v[:, 0].mean():.0f} clusters, {v[:, 1].mean():.4f}")


if __name__ == "__main__":
    sys.exit(main())
