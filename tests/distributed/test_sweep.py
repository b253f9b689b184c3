"""Sweeps on Dask: a 2-process LocalCluster gives the serial DataFrame, references are rendered
once per content, a killed worker loses no row, an interrupted sweep resumes with only the missing renders,
a task that raises is a row with its error, and bad input is refused before anything is written."""
from __future__ import annotations

import json
import os
import signal
import time

import numpy as np
import pandas as pd
import pytest

import manylights as ml
from manylights.distributed import worker as sweep_worker
from manylights.scenes import scene_path

# The acceptance sweep: 2 scenes x 2 methods x 2 budgets x 2 seeds (tiny scenes, a few hundred lights).
SCENES = [("demo", {"res": 16}), ("cbox", {"res": 16})]
METHODS = ["mrcs", "power_sampling"]
BUDGETS = [(8, 16), (16, 48)]
SEEDS = [0, 1]
LIGHTS = 300
SWEEP = dict(scenes=SCENES, methods=METHODS, budgets=BUDGETS, seeds=SEEDS, lights=LIGHTS, device="cpu",
             progress=False)
# Columns that must not depend on where or when a row was computed.
SAME = ["task", "scene", "params", "scene_hash", "lights", "method", "rows", "columns", "clusters", "seed", "status",
        "rel_l2", "reference_key", "device", "adapter"]


@pytest.fixture(scope="module")
def client():
    from dask.distributed import Client, LocalCluster

    cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0",
                           env={"RAYON_NUM_THREADS": "1"})
    c = Client(cluster)
    yield c
    c.close()
    cluster.close()


@pytest.fixture(scope="module")
def serial(tmp_path_factory):
    refs = tmp_path_factory.mktemp("refs")
    return ml.sweep(workers=0, reference_dir=refs, **SWEEP), refs


def test_serial_rows_are_the_methods_own_errors(serial):
    """Each row's relative L2 is that of the method run directly on the same matrix against brute force."""
    df, _ = serial
    # power_sampling takes each distinct column count once: 2 scenes x (2 mrcs budgets + 2 column counts) x 2 seeds
    assert len(df) == 16 and df["task"].is_unique and (df["status"] == "ok").all()
    assert sorted(df["method"].unique()) == METHODS
    assert (df.loc[df.method == "power_sampling", "rows"] == 0).all()
    for name, params in SCENES:
        scene = ml.load_scene(scene_path(name), **params)
        lights = ml.generate_lights(scene, area=LIGHTS // 4, indirect=LIGHTS - LIGHTS // 4, seed=0)
        A = ml.LightMatrix(scene, lights, device="cpu")
        ref = A.column_sum(progress=False) + A.emitted()
        rows = df[df.scene == name]
        assert (rows["lights"] == len(lights)).all()
        for r in rows.itertuples():
            res = (ml.mrcs(A, rows=r.rows, columns=r.columns, seed=r.seed) if r.method == "mrcs"
                   else ml.power_sampling(A, columns=r.columns, seed=r.seed))
            assert r.rel_l2 == pytest.approx(ml.relative_l2(res.image, ref), rel=1e-6, abs=0)
            assert r.clusters == len(res.representatives)
    assert (df["seconds"] > 0).all() and (df["adapter"] == A.device["name"]).all()
    mrcs_rows = df[df.method == "mrcs"]
    assert (mrcs_rows["seconds_clustering"] > 0).all() and df.loc[df.method == "power_sampling",
                                                                  "seconds_clustering"].isna().all()


def test_local_cluster_equals_serial(client, serial, tmp_path):
    """The acceptance test: 2 worker processes give the serial DataFrame (same seeds -> same errors)."""
    want, _ = serial
    got = ml.sweep(client=client, reference_dir=tmp_path / "refs", **SWEEP)
    assert len(got) == len(want) == 16
    pd.testing.assert_frame_equal(got[SAME].drop(columns="rel_l2"), want[SAME].drop(columns="rel_l2"))
    np.testing.assert_allclose(got["rel_l2"].to_numpy(), want["rel_l2"].to_numpy(), rtol=1e-6, atol=0)
    # Both worker processes took part (one thread each, 18 tasks).
    assert len(client.scheduler_info()["workers"]) == 2


def test_reference_rendered_once_per_content(serial, tmp_path):
    """One reference file per (scene content, parameters, lights, backend); a second sweep reads them."""
    df, refs = serial
    files = sorted(refs.glob("*.npz"))
    assert len(files) == 2 and {f.stem for f in files} == set(df["reference_key"])
    assert not df["reference_cached"].any()
    stamps = {f: f.stat().st_mtime_ns for f in files}
    # The stored image is the brute-force image of the scene's matrix.
    scene = ml.load_scene(scene_path("demo"), res=16)
    A = ml.LightMatrix(scene, ml.generate_lights(scene, area=LIGHTS // 4, indirect=LIGHTS - LIGHTS // 4, seed=0),
                       device="cpu")
    key = df.loc[df.scene == "demo", "reference_key"].iloc[0]
    with np.load(refs / f"{key}.npz") as z:
        np.testing.assert_array_equal(z["image"], A.column_sum(progress=False) + A.emitted())
    again = ml.sweep(workers=0, reference_dir=refs, **{**SWEEP, "seeds": [5]})
    assert again["reference_cached"].all() and set(again["reference_key"]) == set(df["reference_key"])
    assert {f: f.stat().st_mtime_ns for f in refs.glob("*.npz")} == stamps
    # Another resolution is another content: a third file.
    ml.sweep(workers=0, reference_dir=refs, **{**SWEEP, "scenes": [("demo", {"res": 8})], "seeds": [0]})
    assert len(list(refs.glob("*.npz"))) == 3


def test_resume_renders_only_missing_rows(client, serial, tmp_path):
    """Interrupted after k rows (Ctrl-C), the Parquet file holds those k rows; the restart renders the rest."""
    want, _ = serial
    out = tmp_path / "sweep.parquet"
    k = 5
    seen = []

    def stop_after_k(row):
        seen.append(row["task"])
        if len(seen) == k:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        ml.sweep(client=client, out=out, reference_dir=tmp_path / "refs", on_row=stop_after_k, **SWEEP)
    first = pd.read_parquet(out)
    assert len(first) == k and sorted(first["task"]) == sorted(seen)
    rendered = []
    df = ml.sweep(client=client, out=out, reference_dir=tmp_path / "refs", on_row=lambda r: rendered.append(r["task"]),
                  **SWEEP)
    assert len(rendered) == len(want) - k and not set(rendered) & set(seen)
    assert len(df) == len(want) and df["task"].is_unique and list(df["task"]) == list(want["task"])
    np.testing.assert_allclose(df["rel_l2"].to_numpy(), want["rel_l2"].to_numpy(), rtol=1e-6, atol=0)
    # The k stored rows were kept as they were (their timings are those of the first run).
    kept = df.set_index("task").loc[first["task"], ["seconds", "host"]]
    np.testing.assert_array_equal(kept["seconds"].to_numpy(), first["seconds"].to_numpy())
    pd.testing.assert_frame_equal(pd.read_parquet(out), df)
    # A third run finds everything done and renders nothing.
    rendered.clear()
    ml.sweep(client=client, out=out, reference_dir=tmp_path / "refs", on_row=lambda r: rendered.append(r), **SWEEP)
    assert rendered == []


def test_killed_worker_loses_no_row(serial, tmp_path):
    """A worker process killed (SIGKILL) while it renders: its task runs again elsewhere; every row once."""
    from dask.distributed import Client, LocalCluster

    want, _ = serial
    cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0",
                           env={"RAYON_NUM_THREADS": "1"})
    c = Client(cluster)
    try:
        pids = c.run(os.getpid)
        killed = {}

        def kill_once(row):
            if killed:
                return
            processing = c.processing()
            busy = [w for w in pids if processing.get(w)]
            if busy:
                killed[busy[0]] = list(processing[busy[0]])
                os.kill(pids[busy[0]], signal.SIGKILL)

        df = ml.sweep(client=c, reference_dir=tmp_path / "refs", on_row=kill_once, **SWEEP)
        assert killed, "no worker was busy when the first row came back"
        (addr, in_flight), = killed.items()
        assert in_flight  # the killed worker had tasks
        assert len(df) == len(want) and df["task"].is_unique and (df["status"] == "ok").all()
        np.testing.assert_allclose(df["rel_l2"].to_numpy(), want["rel_l2"].to_numpy(), rtol=1e-6, atol=0)
        # The nanny started a new process in place of the killed one.
        deadline = time.monotonic() + 30
        while len(c.scheduler_info()["workers"]) < 2 and time.monotonic() < deadline:
            time.sleep(0.2)
        assert pids[addr] not in c.run(os.getpid).values()
    finally:
        c.close()
        cluster.close()


def test_failing_tasks_are_rows_with_their_error(client, tmp_path):
    """A task that raises (rows > view samples) and a scene missing on the workers are error rows naming
    the problem; the other rows are rendered."""
    df = ml.sweep(client=client, reference_dir=tmp_path / "refs",
                  **{**SWEEP, "scenes": [("demo", {"res": 8}), str(tmp_path / "gone" / "scene.xml")],
                     "budgets": [(8, 16), (100, 16)], "seeds": [0]})
    assert len(df) == 6 and df["task"].is_unique
    demo = df[df.scene == "demo"].set_index(["method", "rows"])
    assert demo.loc[("mrcs", 100), "status"] == "error" and "r must be in [1, 64]" in demo.loc[("mrcs", 100), "error"]
    assert (demo.drop(index=("mrcs", 100))["status"] == "ok").all()
    gone = df[df.scene != "demo"]
    assert len(gone) == 3 and (gone["status"] == "error").all()
    assert gone["error"].str.contains("FileNotFoundError").all() and gone["error"].str.contains("gone").all()
    assert gone["rel_l2"].isna().all()


def test_other_sweep_file_is_refused_and_kept(tmp_path):
    out = tmp_path / "s.parquet"
    ml.sweep(workers=0, out=out, reference_dir=tmp_path / "refs",
             **{**SWEEP, "scenes": [("demo", {"res": 8})], "seeds": [0], "methods": ["power_sampling"]})
    before = out.read_bytes()
    with pytest.raises(ValueError, match="another definition.*seeds"):
        ml.sweep(workers=0, out=out, reference_dir=tmp_path / "refs",
                 **{**SWEEP, "scenes": [("demo", {"res": 8})], "seeds": [1], "methods": ["power_sampling"]})
    assert out.read_bytes() == before
    foreign = tmp_path / "foreign.parquet"
    pd.DataFrame({"a": [1]}).to_parquet(foreign)
    before = foreign.read_bytes()
    with pytest.raises(ValueError, match="not written by manylights.sweep"):
        ml.sweep(workers=0, out=foreign, reference_dir=tmp_path / "refs", **SWEEP)
    assert foreign.read_bytes() == before
    meta = json.loads(__import__("pyarrow.parquet", fromlist=["x"]).read_schema(out).metadata[b"manylights.sweep"])
    assert meta["seeds"] == [0] and meta["methods"] == ["power_sampling"]


def test_light_counts_split():
    scene = ml.load_scene(scene_path("cbox"), res=8)
    assert sweep_worker.light_counts(scene, {"total": 1000, "seed": 0}) == {"area": 250, "environment": 0,
                                                                           "indirect": 750, "seed": 0}


def test_bench_mrcs_on_two_workers_equals_in_process(tmp_path):
    """`python -m manylights.bench mrcs --workers 2` runs its renders on ml.sweep's LocalCluster and records
    the errors the in-process run (--workers 0) records; the rows are in the Parquet file beside the JSON."""
    from manylights.bench import __main__ as bench

    argv = ["mrcs", "--scene", "demo", "--lights", "200", "--res", "16", "--columns", "8", "24", "--ratios", "1:1",
            "1:3", "--seeds", "2", "--device", "cpu", "--reference-dir", str(tmp_path / "refs")]
    assert bench.main([*argv, "--out", str(tmp_path / "w0"), "--workers", "0"]) == 0
    assert bench.main([*argv, "--out", str(tmp_path / "w2"), "--workers", "2"]) == 0
    s0 = json.loads((tmp_path / "w0" / "mrcs-demo.json").read_text())
    s2 = json.loads((tmp_path / "w2" / "mrcs-demo.json").read_text())
    assert [(r["method"], r["budget"]) for r in s2["records"]] == [(r["method"], r["budget"]) for r in s0["records"]]
    assert len(s2["records"]) == 2 * 4 and s2["workers"] == 2 and s0["workers"] == 0
    np.testing.assert_allclose([r["rel_l2_mean"] for r in s2["records"]], [r["rel_l2_mean"] for r in s0["records"]],
                               rtol=1e-6)
    (pq,) = (tmp_path / "w2").glob("mrcs-demo-*.parquet")
    df = pd.read_parquet(pq)
    # 2 budgets x (power sampling + instant radiosity + 2 MRCS ratios) x 2 seeds, each once
    assert len(df) == 16 and df["task"].is_unique and (df["status"] == "ok").all()
    mrcs_1_3 = df[(df["method"] == "mrcs") & (df["columns"] == 24) & (df["rows"] == 8)]
    rec = next(r for r in s2["records"] if r["method"] == "mrcs 1:3" and r["budget"]["columns"] == 24)
    assert rec["rel_l2_mean"] == pytest.approx(mrcs_1_3["rel_l2"].mean(), rel=1e-12)


def test_tensor_clustering_chunks_on_workers(client):
    """tensor_clustering(T, ..., client=): one task per chunk of frames, each clustered with its chunk index
    (``first_chunk``), so the result equals the serial call's, and the joined clustering indexes the whole
    animation."""
    import manylights.scenes as sc

    path = sc.resolve("bounce")
    frames = sc.animation_frames("bounce", count=4)
    anim = ml.load_animation(path, frames=frames, res=16)
    lights = ml.generate_animation_lights(anim, area=32, environment=32, indirect=64, photons=0, seed=0)
    T = ml.LightTensor(anim, lights, device="cpu")
    kw = dict(rows=16, columns=20, seed=1, chunk=2)
    serial = ml.tensor_clustering(T, **kw)
    dist = ml.tensor_clustering(T, client=client, **kw)
    assert dist.frames.shape == serial.frames.shape == (4, 16, 16, 3)
    np.testing.assert_array_equal(dist.rows, serial.rows)
    np.testing.assert_allclose(dist.frames, serial.frames, rtol=1e-6, atol=1e-7)
    np.testing.assert_array_equal(dist.clustering.representatives, serial.clustering.representatives)
    T1 = ml.LightTensor(ml.load_animation(path, frames=frames[2:], res=16), [lights[2], lights[3]], device="cpu")
    alone = ml.tensor_clustering(T1, row_indices=serial.rows, first_chunk=1, **{**kw, "rows": None})
    np.testing.assert_allclose(dist.frames[2:], alone.frames, rtol=1e-6, atol=1e-7)
    np.testing.assert_array_equal(dist.shadow_maps_per_frame[2:], alone.shadow_maps_per_frame)
    cl = dist.clustering
    c0 = len(cl.representatives) - alone.clustering.num_clusters  # clusters of chunk 0
    assert cl.assignment.shape == (T.shape[1], 4) and cl.rec.shape == (len(cl.representatives), 4, 3)
    assert (cl.representatives[c0:, 1] >= 2).all() and (cl.representatives[:c0, 1] < 2).all()
    assert (cl.frames[c0:] == alone.clustering.frames + 2).all()
    assert dist.budget["chunks"] == 2 and dist.budget["columns"] == int(cl.rendered.sum())
    # Its error against brute force is that of a tensor clustering (both runs alike).
    B = T.brute_force(progress=False)
    e_dist = ml.relative_l2_per_frame(dist.frames, B).mean()
    e_serial = ml.relative_l2_per_frame(serial.frames, B).mean()
    assert 0 < e_dist < 3 * e_serial and 0 < e_serial < 0.5


def test_animation_sweep_on_workers(client, tmp_path):
    """Animations in a sweep: tensor clustering and per-frame MRCS rows on 2 workers hold the mean per-frame
    error and the flicker of the method run directly, against the tensor's brute force."""
    import manylights.scenes as sc
    from manylights.metrics import flicker, relative_l2_per_frame

    path = sc.resolve("bounce")
    frames = sc.animation_frames("bounce", count=3)
    light_spec = {"area": 32, "environment": 32, "indirect": 64, "photons": 0}
    df = ml.sweep([(str(path), {"frames": frames, "res": 16})], methods=["tensor_clustering", "mrcs_per_frame"],
                  budgets=[(16, 20)], seeds=[0, 1], lights=light_spec, client=client, device="cpu", progress=False,
                  options={"tensor_clustering": {"chunk": 2}}, reference_dir=tmp_path / "refs")
    assert len(df) == 4 and (df["status"] == "ok").all() and (df["frames"] == 3).all()
    anim = ml.load_animation(path, frames=frames, res=16)
    T = ml.LightTensor(anim, ml.generate_animation_lights(anim, **light_spec, seed=0), device="cpu")
    B = T.brute_force()
    for r in df.itertuples():
        res = (ml.tensor_clustering(T, rows=16, columns=20, seed=r.seed, chunk=2) if r.method == "tensor_clustering"
               else ml.mrcs_per_frame(T, rows=16, columns=20, seed=r.seed))
        assert r.rel_l2 == pytest.approx(relative_l2_per_frame(res.frames, B).mean(), rel=1e-6)
        assert r.flicker == pytest.approx(flicker(res.frames, B), rel=1e-6)
        assert r.shadow_maps_per_frame == pytest.approx(np.mean(res.shadow_maps_per_frame))
    with pytest.raises(ValueError, match="animation"):
        ml.sweep([(str(path), {"frames": frames, "res": 16})], methods=["mrcs"], workers=0)


def test_error_estimate_column_is_the_methods_own(tmp_path):
    """MRCS with halves=True estimates its own error; the sweep keeps it per row (NaN for the others)."""
    df = ml.sweep([("cbox", {"res": 16})], methods=["mrcs", "power_sampling"], budgets=[(8, 32)], seeds=[0],
                  lights=LIGHTS, device="cpu", progress=False, workers=0, reference_dir=tmp_path / "refs",
                  options={"mrcs": {"halves": True}})
    mrcs = df[df.method == "mrcs"].iloc[0]
    scene = ml.load_scene(scene_path("cbox"), res=16)
    lights = ml.generate_lights(scene, area=LIGHTS // 4, indirect=LIGHTS - LIGHTS // 4, seed=0)
    res = ml.mrcs(ml.LightMatrix(scene, lights, device="cpu"), rows=8, columns=32, seed=0, halves=True)
    assert mrcs.error_estimate == pytest.approx(res.error_estimate, rel=1e-6) and mrcs.error_estimate > 0
    assert np.isnan(df[df.method == "power_sampling"].iloc[0].error_estimate)


def _sweep_cbox16(tmp_path, methods, budget):
    """A serial sweep of ``methods`` on cbox 16^2 at one budget, seed 0, with the same matrix and its brute
    force (the sweep's truth) rebuilt here: (DataFrame, LightMatrix, brute force image)."""
    df = ml.sweep([("cbox", {"res": 16})], methods=methods, budgets=[budget], seeds=[0], lights=LIGHTS, device="cpu",
                  progress=False, workers=0, reference_dir=tmp_path / "refs")
    assert (df.status == "ok").all(), df.error.tolist()
    scene = ml.load_scene(scene_path("cbox"), res=16)
    lights = ml.generate_lights(scene, area=LIGHTS // 4, indirect=LIGHTS - LIGHTS // 4, seed=0)
    A = ml.LightMatrix(scene, lights, device="cpu")
    return df, A, A.column_sum(progress=False) + A.emitted()


def test_sweep_reports_relmse_and_smape_and_the_light_tree_samplers(tmp_path):
    df, A, ref = _sweep_cbox16(tmp_path, ["light_bvh_sampling", "ris_sampling"], (1, 4))
    img = ml.light_bvh_sampling(A, samples=4, seed=0).image
    row = df[df.method == "light_bvh_sampling"].iloc[0]
    assert row.clusters == 4 and row.relmse == pytest.approx(ml.relmse(img, ref), rel=1e-5)
    assert row.smape == pytest.approx(ml.smape(img, ref), rel=1e-5) and row.smape > 0
    assert row.flip == pytest.approx(ml.metrics.flip(img, ref), rel=1e-5) and 0 < row.flip < 1


def test_sweep_runs_stochastic_lightcuts_and_lightslice(tmp_path):
    df, A, ref = _sweep_cbox16(tmp_path, ["stochastic_lightcuts", "lightslice"], (8, 16))
    slc = df[df.method == "stochastic_lightcuts"].iloc[0]
    assert slc.rows == 0 and slc.clusters == 16
    img = ml.stochastic_lightcuts(A, cut_size=16, seed=0).image
    assert slc.rel_l2 == pytest.approx(ml.relative_l2(img, ref), rel=1e-5) and slc.seconds_sampling > 0
    ls = df[df.method == "lightslice"].iloc[0]
    assert ls.rows == 8 and ls.clusters == 16
    img = ml.lightslice(A, slices=8, columns=16, seed=0).image
    assert ls.rel_l2 == pytest.approx(ml.relative_l2(img, ref), rel=1e-5) and 0 < ls.rel_l2 < 0.5
    assert ls.seconds_refinement > 0
