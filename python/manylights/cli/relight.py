"""``python -m manylights relight SCENE``: precompute a scene's direct-to-indirect transfer once (or load it)
and write one relit image per light placement (Hašan, Pellacini, Bala, SIGGRAPH 2006; ``DirectToIndirect``).

Light placements: each ``--light SPEC`` is one image; ``--lights FILE.json`` adds a JSON list of
placements. With neither, the scene's own lights make one image. A SPEC is one or more lights joined by
``+``, each ``KIND:key=value;key=value...`` (vectors as ``x,y,z``, colours as one number or ``r,g,b``,
angles in degrees, world units as the scene's):

    spot:pos=0,0.9,0;target=0,-1,0;intensity=3;cutoff=25;beam=15
        pos (required), target or dir (required; dir need not be unit), intensity (W/sr, default 1),
        cutoff (default 20) and beam (default 3/4 of cutoff) as Mitsuba's spot defines them
    point:pos=0,0.5,0;intensity=1,0.8,0.6
    directional:dir=0,-1,0;irradiance=2          (``intensity`` is accepted for irradiance)

A JSON placement is such a string, or a list of light dicts (``{"type": "spot", "pos": [0, 0.9, 0],
"target": [0, -1, 0], "intensity": 3, "cutoff": 25}``, same keys), or one light dict.

Writes ``--out``/``light_000.exr`` (float32 linear radiance, ``DirectToIndirect.relight``: direct + indirect
light) and ``light_000.png`` (8-bit sRGB at ``--exposure``) per placement, in order; every file is written
under a temporary name and renamed, so it appears complete or not at all. ``--save FILE`` keeps the
precomputation, ``--load FILE`` reuses one (``DirectToIndirect.load``: same geometry, materials, camera and
film; the scene's lights may differ).

    python -m manylights relight cbox-lights --res 64 --gather 4096 \\
        --light "spot:pos=-0.6,0.9,0.6;target=-0.3,-1,-0.2;intensity=3;cutoff=25" \\
        --light "spot:pos=0.5,0.9,0.3;target=0.2,-1,0;intensity=3;cutoff=25" --save cbox.npz
"""
from __future__ import annotations

import json
import math
import time
from pathlib import Path

import numpy as np

from .._native import LightSet
from .._utils.progress import progress_bar
from ..io.images import write_exr, write_png
from ..lights.generate import scene_lights
from ..relight.direct_to_indirect import DirectToIndirect
from ..scene import load_scene
from ..scenes import resolve
from .common import add_output, add_scene_options, scene_options

KINDS = {"point": 0, "spot": 1, "directional": 2}
_KEYS = {"point": {"pos", "intensity"}, "spot": {"pos", "target", "dir", "intensity", "cutoff", "beam"},
         "directional": {"dir", "irradiance", "intensity"}}


def add_parser(sub) -> None:
    import argparse

    p = sub.add_parser("relight", help="direct-to-indirect relighting: one image per light placement",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("scene", help="a Mitsuba 3 XML file, or a bundled scene's name (cbox-lights, ...)")
    p.add_argument("--light", action="append", default=[], metavar="SPEC", help="one light placement (see above)")
    p.add_argument("--lights", default=None, metavar="FILE", help="JSON list of light placements")
    add_output(p, "out/relight", "output folder")
    add_scene_options(p)
    p.add_argument("--gather", type=int, default=4**7, help="gather samples n_g, a power of 4 (default 4^7)")
    p.add_argument("--coefficients", type=int, default=100, help="wavelet coefficients kept per pixel row")
    p.add_argument("--bounces", type=int, default=1, help="diffuse bounces of indirect light")
    p.add_argument("--multibounce-coefficients", type=int, default=40, help="coefficients per gather row")
    p.add_argument("--threshold", type=float, default=0.03, help="solid-angle threshold of the gather")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--epsilon", type=float, default=0.0, help="on-the-fly wavelet-light culling (0: none)")
    p.add_argument("--exposure", type=float, default=0.0, help="PNG exposure (2^exposure)")
    p.add_argument("--save", default=None, metavar="FILE", help="write the precomputation to FILE")
    p.add_argument("--load", default=None, metavar="FILE", help="load a saved precomputation instead")
    p.add_argument("--no-png", action="store_true")
    p.set_defaults(run=run)


def _numbers(kind, key, text, count):
    """``count`` floats from 'a,b,c' (count 3), or 1 or 3 for a colour (count -3)."""
    try:
        v = [float(x) for x in str(text).split(",")]
    except ValueError:
        raise ValueError(f"{kind} light: {key}={text!r} is not a number list") from None
    want = (1, 3) if count == -3 else (count,)
    if len(v) not in want:
        raise ValueError(f"{kind} light: {key} needs {' or '.join(map(str, want))} numbers, got {text!r}")
    if not all(math.isfinite(x) for x in v):
        raise ValueError(f"{kind} light: {key}={text!r} must be finite")
    return v * 3 if count == -3 and len(v) == 1 else v


def parse_light(spec) -> dict:
    """One light from ``KIND:key=value;...`` (module docs) or a dict with a ``type`` key, as a dict of
    LightSet arrays for that light: kind, position, direction (unit), intensity (RGB), cutoff_angle and
    beam_width (radians). Raises ValueError naming the light and the key."""
    if isinstance(spec, dict):
        d = dict(spec)
        kind = d.pop("type", None)
        fields = {k: ",".join(map(str, v)) if isinstance(v, (list, tuple)) else str(v) for k, v in d.items()}
    elif isinstance(spec, str):
        kind, sep, rest = spec.strip().partition(":")
        if not sep:
            raise ValueError(f"light {spec!r}: expected KIND:key=value;... with KIND one of {', '.join(KINDS)}")
        fields = {}
        for item in filter(None, (s.strip() for s in rest.split(";"))):
            k, eq, v = item.partition("=")
            if not eq:
                raise ValueError(f"light {spec!r}: {item!r} is not key=value")
            if k.strip() in fields:
                raise ValueError(f"light {spec!r}: {k.strip()} given twice")
            fields[k.strip()] = v.strip()
    else:
        raise ValueError(f"a light must be a string or a dict, got {type(spec).__name__}")
    kind = str(kind).strip().lower()
    if kind not in KINDS:
        raise ValueError(f"light {spec!r}: unknown kind {kind!r} (one of {', '.join(KINDS)})")
    unknown = sorted(set(fields) - _KEYS[kind])
    if unknown:
        raise ValueError(f"{kind} light {spec!r}: unknown key(s) {', '.join(unknown)} "
                         f"(known: {', '.join(sorted(_KEYS[kind]))})")
    out = {"kind": KINDS[kind], "position": [0.0, 0.0, 0.0], "direction": [0.0, 0.0, 0.0],
           "cutoff_angle": 0.0, "beam_width": 0.0}
    if kind in ("point", "spot"):
        if "pos" not in fields:
            raise ValueError(f"{kind} light {spec!r}: pos=x,y,z is required")
        out["position"] = _numbers(kind, "pos", fields["pos"], 3)
    if kind in ("spot", "directional"):
        if kind == "spot" and ("target" in fields) == ("dir" in fields):
            raise ValueError(f"spot light {spec!r}: give exactly one of target=x,y,z and dir=x,y,z")
        if "dir" not in fields and kind == "directional":
            raise ValueError(f"directional light {spec!r}: dir=x,y,z is required")
        d = (np.subtract(_numbers(kind, "target", fields["target"], 3), out["position"]) if "target" in fields
             else np.array(_numbers(kind, "dir", fields["dir"], 3)))
        n = float(np.linalg.norm(d))
        if not n > 0:
            raise ValueError(f"{kind} light {spec!r}: the direction has zero length")
        out["direction"] = list(d / n)
    if kind == "directional" and "irradiance" in fields and "intensity" in fields:
        raise ValueError(f"directional light {spec!r}: give irradiance or intensity, not both")
    value = fields.get("irradiance", fields.get("intensity", "1"))
    out["intensity"] = _numbers(kind, "intensity", value, -3)
    if min(out["intensity"]) < 0:
        raise ValueError(f"{kind} light {spec!r}: intensity must be >= 0, got {value!r}")
    if kind == "spot":
        cutoff = _numbers(kind, "cutoff", fields.get("cutoff", "20"), 1)[0]
        beam = _numbers(kind, "beam", fields["beam"], 1)[0] if "beam" in fields else 0.75 * cutoff
        if not 0 < cutoff <= 180:
            raise ValueError(f"spot light {spec!r}: cutoff must be in (0, 180] degrees, got {cutoff}")
        if not 0 <= beam <= cutoff:
            raise ValueError(f"spot light {spec!r}: beam must be in [0, cutoff = {cutoff}] degrees, got {beam}")
        out["cutoff_angle"], out["beam_width"] = math.radians(cutoff), math.radians(beam)
    return out


def placement(scene, spec):
    """A LightSet of ``scene`` from one placement: a SPEC string (lights joined by '+'), a list of light
    strings / dicts, or one light dict (module docs). Raises ValueError."""
    if isinstance(spec, str):
        items = [s for s in spec.split("+") if s.strip()]
    elif isinstance(spec, dict):
        items = [spec]
    elif isinstance(spec, list):
        items = spec
    else:
        raise ValueError(f"a light placement must be a string, a list or a dict, got {type(spec).__name__}")
    if not items:
        raise ValueError(f"light placement {spec!r} has no light")
    lights = [parse_light(s) for s in items]
    arrays = {k: [light[k] for light in lights] for k in lights[0]}
    return LightSet.from_arrays(scene, **arrays)


def placements(scene, light_specs, lights_file):
    """[(label, LightSet)] of the --light options then the --lights file's entries; the scene's own lights
    when neither is given."""
    specs = [(s, s) for s in light_specs]
    if lights_file is not None:
        try:
            data = json.loads(Path(lights_file).read_text())
        except json.JSONDecodeError as e:
            raise ValueError(f"{lights_file}: not JSON ({e})") from None
        if not isinstance(data, list) or not data:
            raise ValueError(f"{lights_file}: expected a non-empty JSON list of light placements")
        specs += [(f"{lights_file}[{i}]", s) for i, s in enumerate(data)]
    if not specs:
        return [("scene lights", scene_lights(scene))]
    out = []
    for label, s in specs:
        try:
            out.append((label, placement(scene, s)))
        except ValueError as e:
            raise ValueError(f"--light {label}: {e}" if label == s else f"{label}: {e}") from None
    return out


def run(args) -> list[Path]:
    """The command (module docs); returns the written paths."""
    if args.save and args.load:
        raise ValueError("give --save or --load, not both (a loaded precomputation is already saved)")
    size, params = scene_options(args)
    scene = load_scene(resolve(args.scene), size=size, **params)
    todo = placements(scene, args.light, args.lights)
    t = time.perf_counter()
    if args.load:
        rel = DirectToIndirect.load(args.load, scene)
        print(f"loaded {args.load} ({time.perf_counter() - t:.2f} s): {rel!r}")
    else:
        rel = DirectToIndirect(scene, gather=args.gather, final_gather_coefficients=args.coefficients,
                                  seed=args.seed, bounces=args.bounces,
                                  multibounce_coefficients=args.multibounce_coefficients, threshold=args.threshold,
                                  progress=True)
        print(f"precomputed {rel!r} in {time.perf_counter() - t:.2f} s")
        if args.save:
            print(f"saved {rel.save(args.save)}")
    out = Path(args.output)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    seconds = 0.0
    with progress_bar(len(todo), "relight", True, unit="image") as callback:
        for k, (label, lights) in enumerate(todo):
            t = time.perf_counter()
            img = rel.relight(lights, epsilon=args.epsilon)
            seconds += time.perf_counter() - t
            p = out / f"light_{k:03d}.exr"
            write_exr(p, img)
            written.append(p)
            if not args.no_png:
                q = p.with_suffix(".png")
                write_png(q, img, exposure=args.exposure)
                written.append(q)
            if callback is not None:
                callback(k + 1, len(todo))
    print(f"relit {len(todo)} light placements in {seconds:.2f} s ({len(todo) / max(seconds, 1e-9):.1f} per second)")
    for k, (label, _) in enumerate(todo):
        print(f"  light_{k:03d}: {label}")
    print(f"wrote {len(written)} files under {out}")
    return written
