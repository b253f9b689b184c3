"""Bad-input cases: scenes, lights, rows."""
from __future__ import annotations

import numpy as np

from .common import cases_for

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
