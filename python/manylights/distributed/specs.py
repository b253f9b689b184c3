"""What a sweep is made of: scenes, methods, budgets, seeds, light models and options, checked and expanded
into one task per render (``sweep``'s arguments; its doc)."""
from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Optional

from .._utils import validate as _v
from ..scenes import SCENES_DIR
from .worker import ANIMATION_METHODS, METHODS


def scene_specs(scenes, local: bool) -> list[dict]:
    if isinstance(scenes, (str, os.PathLike)) or (isinstance(scenes, tuple) and len(scenes) == 2
                                                  and isinstance(scenes[1], dict)):
        scenes = [scenes]
    try:
        scenes = list(scenes)
    except TypeError:
        raise TypeError(f"scenes must be a list of paths or (path, parameters) pairs, got {type(scenes).__name__}") \
            from None
    if not scenes:
        raise ValueError("scenes is empty: give at least one scene path or (path, parameters) pair")
    out = []
    for i, s in enumerate(scenes):
        params = {}
        if isinstance(s, (tuple, list)):
            if len(s) != 2 or not isinstance(s[1], dict):
                raise ValueError(f"scenes[{i}] must be a path or a (path, parameters dict) pair, got {s!r}")
            s, params = s
        if not isinstance(s, (str, os.PathLike)):
            raise TypeError(f"scenes[{i}]: a scene is a path (str or os.PathLike), got {type(s).__name__}")
        given = os.fspath(s)
        path = Path(given)
        if not path.is_file() and Path(given).name == given and (SCENES_DIR / given / "scene.xml").is_file():
            path = SCENES_DIR / given / "scene.xml"  # a bundled scene's name
        elif local and not path.is_file():
            raise FileNotFoundError(f"scenes[{i}]: scene file not found: {given}")
        clean = {}
        for k, v in params.items():
            if not isinstance(k, str):
                raise ValueError(f"scenes[{i}]: parameter names must be strings, got {k!r}")
            if k == "frames":
                if not isinstance(v, (list, tuple)) or not v or not all(isinstance(f, dict) for f in v):
                    raise ValueError(f"scenes[{i}]: frames must be a non-empty list of parameter dicts (one per "
                                     f"frame of the animation), got {v!r}")
                for k_, f in enumerate(v):
                    for name, x in f.items():
                        if not isinstance(name, str) or not isinstance(x, (str, int, float, bool)):
                            raise ValueError(f"scenes[{i}]: frame {k_}: parameter {name!r} must be a string "
                                             f"name with a string, number or bool value, got {x!r}")
                v = [dict(f) for f in v]
            elif k == "size":
                if not isinstance(v, (tuple, list)) or len(v) != 2:
                    raise ValueError(f"scenes[{i}]: size must be (width, height), got {v!r}")
                v = [_v.integer(f"scenes[{i}] size[{j}]", x, 1, 2**32 - 1) for j, x in enumerate(v)]
            elif not isinstance(v, (str, int, float, bool)):
                raise ValueError(f"scenes[{i}]: parameter {k!r} must be a string, number or bool, got {v!r}")
            clean[k] = v
        out.append({"path": str(path.resolve()) if path.is_file() else str(path), "display": given,
                    "params": clean})
    return out


def parse_methods(methods) -> list[str]:
    if isinstance(methods, str):
        methods = [methods]
    methods = list(methods)
    if not methods:
        raise ValueError(f"methods is empty: give one or more of {', '.join(METHODS)}")
    for m in methods:
        if m not in METHODS:
            raise ValueError(f"unknown method {m!r}; methods: {', '.join(METHODS)}")
    if len(set(methods)) != len(methods):
        raise ValueError(f"methods lists a method twice: {methods}")
    return methods


def parse_budgets(budgets) -> list[tuple[int, int]]:
    try:
        budgets = list(budgets)
    except TypeError:
        raise ValueError(f"budgets must be a list of (rows, columns) pairs, got {budgets!r}") from None
    if not budgets:
        raise ValueError("budgets is empty: give at least one (rows, columns) pair")
    out = []
    for i, b in enumerate(budgets):
        if not isinstance(b, (tuple, list)) or len(b) != 2:
            raise ValueError(f"budgets[{i}] must be a (rows, columns) pair of integers >= 1, got {b!r}")
        out.append((_v.integer(f"budgets[{i}] rows", b[0], 1, 2**31 - 1),
                    _v.integer(f"budgets[{i}] columns", b[1], 1, 2**31 - 1)))
    if len(set(out)) != len(out):
        raise ValueError(f"budgets lists a (rows, columns) pair twice: {out}")
    return out


def parse_seeds(seeds) -> list[int]:
    if isinstance(seeds, int) and not isinstance(seeds, bool):
        seeds = [seeds]
    seeds = [_v.seed(s, f"seeds[{i}]") for i, s in enumerate(seeds)]
    if not seeds:
        raise ValueError("seeds is empty: give at least one seed")
    if len(set(seeds)) != len(seeds):
        raise ValueError(f"seeds lists a seed twice: {seeds}")
    return seeds


def parse_lights(lights) -> dict:
    if isinstance(lights, dict):
        allowed = {"total", "area", "environment", "indirect", "max_depth", "clamp", "seed", "env_importance",
                   "photons", "indirect_kind", "vsl_radius_scale", "vsl_neighbours", "vpl_importance",
                   "vpl_view_samples", "vpl_accept_min"}
        if bad := sorted(set(lights) - allowed):
            raise ValueError(f"lights: unknown keys {bad}; allowed: {sorted(allowed)}")
        spec = dict(lights)
    else:
        spec = {"total": lights}
    for k in ("total", "area", "environment", "indirect"):
        if k in spec:
            spec[k] = _v.integer(f"lights[{k!r}]", spec[k], 1 if k == "total" else 0, 2**40)
    spec.setdefault("seed", 0)
    spec["seed"] = _v.seed(spec["seed"], "lights['seed']")
    return spec


def parse_options(options, methods) -> dict:
    if options is None:
        return {}
    if not isinstance(options, dict):
        raise ValueError(f"options must be a dict of method -> keyword arguments, got {options!r}")
    out = {}
    for m, kw in options.items():
        if m not in methods:
            raise ValueError(f"options for {m!r}, which is not one of the sweep's methods {methods}")
        if not isinstance(kw, dict) or not all(isinstance(k, str) for k in kw):
            raise ValueError(f"options[{m!r}] must be a dict of keyword arguments, got {kw!r}")
        try:
            json.dumps(kw)
        except TypeError as e:
            raise ValueError(f"options[{m!r}]: values must be plain numbers, strings, lists or dicts ({e})") from None
        out[m] = dict(kw)
    return out


#: What a light model may change: ``generate_lights`` arguments, ``LightMatrix`` settings, and the bias
#: compensation image added to every render (``LightMatrix.bias_compensation`` arguments but the seed).
MODEL_LIGHTS = {"indirect_kind", "vsl_radius_scale", "vsl_neighbours", "clamp", "max_depth", "vpl_importance",
                "vpl_view_samples", "vpl_accept_min"}
MODEL_MATRIX = {"glossy_roughness", "bsdf_samples", "glossy_seed", "max_depth"}
MODEL_BIAS = {"spp", "light_samples", "max_depth"}


def parse_light_models(light_models) -> Optional[list[dict]]:
    """``{name: {"lights": {...}, "matrix": {...}, "bias_compensation": {...} or None}}`` -> a list of
    ``{"name", "lights", "matrix", "bias_compensation"}`` (None: no light-model axis)."""
    if light_models is None:
        return None
    if not isinstance(light_models, dict) or not light_models:
        raise ValueError(f"light_models must be a non-empty dict of name -> settings, got {light_models!r}")
    out = []
    for name, spec in light_models.items():
        if not isinstance(name, str) or not name:
            raise ValueError(f"light_models: names must be non-empty strings, got {name!r}")
        spec = {} if spec is None else spec
        if not isinstance(spec, dict) or set(spec) - {"lights", "matrix", "bias_compensation"}:
            raise ValueError(f"light_models[{name!r}] must be a dict with keys lights, matrix, bias_compensation, "
                             f"got {spec!r}")
        model = {"name": name}
        for key, allowed in (("lights", MODEL_LIGHTS), ("matrix", MODEL_MATRIX), ("bias_compensation", MODEL_BIAS)):
            kw = spec.get(key)
            if kw is None:
                model[key] = None if key == "bias_compensation" else {}
                continue
            if not isinstance(kw, dict) or set(kw) - allowed:
                raise ValueError(f"light_models[{name!r}][{key!r}] must be a dict of {sorted(allowed)}, got {kw!r}")
            try:
                json.dumps(kw)
            except TypeError as e:
                raise ValueError(f"light_models[{name!r}][{key!r}]: values must be plain numbers or strings ({e})") \
                    from None
            model[key] = dict(kw)
        if model["lights"].get("indirect_kind", "vpl") not in ("vpl", "vsl"):
            raise ValueError(f"light_models[{name!r}]: indirect_kind must be 'vpl' or 'vsl', got "
                             f"{model['lights']['indirect_kind']!r}")
        if model["bias_compensation"] is not None and model["lights"].get("indirect_kind") == "vsl":
            raise ValueError(f"light_models[{name!r}]: bias compensation applies to clamped VPLs, not to VSLs")
        out.append(model)
    return out


def parse_truth(truth, specs) -> list[Optional[str]]:
    """One image file (EXR or .npy) per scene, or None (brute force)."""
    if truth is None or isinstance(truth, (str, os.PathLike)):
        truth = [truth] * len(specs)
    truth = list(truth)
    if len(truth) != len(specs):
        raise ValueError(f"truth must be one image path (or None) per scene: {len(specs)} scenes, {len(truth)} given")
    out = []
    for i, t in enumerate(truth):
        if t is not None:
            if not Path(t).is_file():
                raise FileNotFoundError(f"truth[{i}]: image file not found: {t}")
            t = str(Path(t).resolve())
        out.append(t)
    return out


def check_kinds(specs, methods) -> None:
    """Animation methods need animated scenes (``frames`` in their parameters), the others still scenes."""
    for i, s in enumerate(specs):
        animated = "frames" in s["params"]
        wrong = [m for m in methods if (m in ANIMATION_METHODS) != animated]
        if wrong:
            what = "an animation (its parameters hold frames)" if animated else "a still scene (no frames parameter)"
            raise ValueError(f"scenes[{i}] ({s['display']}) is {what}, which method(s) {wrong} do not render; "
                             f"animation methods: {sorted(ANIMATION_METHODS)}")


def make_tasks(scene_specs, methods, budgets, seeds, lights, matrix, options=None, models=None,
           truth=None) -> list[dict]:
    """Every render of the sweep, in a fixed order (scene, light model, method, budget, seed); methods without
    rows take each distinct column count once (rows = 0 in their rows). A light model's settings are merged
    into the task's lights / matrix specs; its name joins the task key only when there is a light-model axis."""
    tasks = []
    for i, s in enumerate(scene_specs):
        for model in models or [None]:
            t_lights = lights if model is None else parse_lights({**lights, **model["lights"]})
            t_matrix = matrix if model is None else {**matrix, **model["matrix"]}
            bias = None if model is None else model["bias_compensation"]
            if bias is not None:  # the compensation's paths use the lights' max_depth unless told
                bias = {"max_depth": t_lights.get("max_depth", 5), **bias}
            for m in methods:
                pairs = budgets if METHODS[m] else list(dict.fromkeys((0, c) for _, c in budgets))
                for rows, c in pairs:
                    for seed in seeds:
                        key = [s["display"], s["params"], m, rows, c, seed] + ([] if model is None else [model["name"]])
                        tasks.append({"task": json.dumps(key, sort_keys=True), "scene": s, "lights": t_lights,
                                      "matrix": t_matrix, "method": m, "rows": rows, "columns": c, "seed": seed,
                                      "options": (options or {}).get(m, {}),
                                      "light_model": None if model is None else model["name"],
                                      "bias_compensation": bias, "truth": None if truth is None else truth[i]})
    return tasks


def definition_of(scene_specs, methods, budgets, seeds, lights, matrix, options, models=None, truth=None) -> dict:
    d = {"version": 1, "scenes": [[s["display"], s["params"]] for s in scene_specs], "methods": methods,
         "budgets": [list(b) for b in budgets], "seeds": seeds, "lights": lights, "matrix": matrix,
         "options": options}
    if models is not None:
        d["light_models"] = models
    if truth is not None and any(t is not None for t in truth):
        d["truth"] = truth
    return d


# ------------------------------------------------------------------------------------------ Parquet
