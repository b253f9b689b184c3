"""Known sources of bias of a light matrix's image: what no error estimate of this package covers.

Every estimate a renderer reports (``error_estimate``: the halves or held-out rows of MRCS, the halving of the
light counts in ``light_budget``) measures VARIANCE: the spread of the sampled rows, columns or lights around
their expectation. The expectation itself can differ from the converged image of the scene (what Mitsuba's
``path`` integrator converges to) where the light model is biased, and then no number of rows, columns or
lights removes the difference. ``bias_sources(A)`` lists the ones this package knows of, each a dict
``{"source", "reason", ...}`` with the figures behind it; results carry them as ``RenderResult.bias_sources``
and ``render("scene.xml", target_error=e)`` does not claim a target while any is active.

| source | what | why it is a bias |
|---|---|---|
| ``vpl_clamp`` | VPLs whose geometry term cos cos / d^2 is clamped (``generate_lights``' ``clamp``) | the clamp removes energy near corners and contacts deterministically (Kollig and Keller 2004); ``LightMatrix.bias_compensation`` adds it back |
| ``vsl_radius`` | virtual spherical lights (``indirect_kind="vsl"``) | each VPL's light is spread over a sphere: a blurred expectation that converges only as the radius goes to 0 (Hašan et al. 2009) |
| ``anisotropic_frame`` | shapes with an anisotropic BSDF (``roughconductor`` / ``roughdielectric`` with ``alpha_u`` != ``alpha_v``, ``principled`` with ``anisotropic`` > 0) whose shading frame differs from Mitsuba's (``src/shading/frame.rs``: spheres, cubes, disks, most meshes) | the lobe is evaluated rotated about the normal: its highlight turns. The probes' path tracer shades in the same frame, so unlike the others no probe sees it (``PROBES_BLIND``) |
| ``glossy_lobe_without_mis`` | view samples on a lobe narrower than ``glossy_roughness`` that the matrix's glossy MIS does not sample (``principled``'s clearcoat; rough plastic, rough conductor and principled's specular lobe are sampled, alone or in a ``blendbsdf``) | a few point lights on a sharp lobe: highlights of area and environment lights are missed by every draw but a rare one, a heavy tail that the estimates (a few draws) do not see |

Symbols: alpha, the lobe's GGX / Beckmann roughness (principled's clearcoat: lerp(0.1, 0.001, gloss)); ``glossy_roughness``, the
LightMatrix's threshold below which a lobe gets BSDF samples.
"""
from __future__ import annotations

import numpy as np

#: Light kinds (``LightSet.kind``): virtual point lights (and VSLs, with ``vsl_radius`` > 0).
VPL_KIND = 4
#: Sources that the probes' path tracer shares, so that no probe estimate covers them either.
PROBES_BLIND = frozenset({"anisotropic_frame"})


def probes_blind(sources: list[dict]) -> list[dict]:
    """The sources in ``sources`` that no probe estimate covers (``PROBES_BLIND``)."""
    return [s for s in sources if s["source"] in PROBES_BLIND]


def _value(v):
    """A BSDF parameter as the scene reports it (a number, a list of numbers, or ``"texture[i]"``): its smallest
    value, or ``"texture"``."""
    if isinstance(v, str):
        return "texture"
    return float(np.min(v))


def _clearcoat_alpha(bsdf: dict):
    """A ``principled`` BSDF's clearcoat lobe roughness (Mitsuba: lerp(0.1, 0.001, clearcoat_gloss)), None
    without a clearcoat, ``"texture"`` where it is textured."""
    cc = _value(bsdf.get("clearcoat", 0.0))
    if cc == "texture":
        return "texture"
    if cc <= 0.0:
        return None
    gloss = _value(bsdf.get("clearcoat_gloss", 1.0))
    return gloss if gloss == "texture" else 0.1 * (1.0 - gloss) + 0.001 * gloss


def skipped_lobes(bsdfs: list[dict], index: int, threshold: float, depth: int = 0) -> list[str]:
    """The narrow lobes of BSDF ``index`` (resolved through ``twosided``, ``blendbsdf``, ``bumpmap`` and
    ``normalmap``) that glossy MIS
    does not sample: rough plastic, rough conductor and principled's specular lobe are sampled (alone or in a
    blend, ``src/matrix/glossy.rs``); principled's clearcoat lobe is not. A description of each (e.g.
    ``"principled 3 clearcoat alpha 0.001"``)."""
    if depth > 16 or not 0 <= index < len(bsdfs):
        return []
    b = bsdfs[index]
    t = b["type"]
    if t == "twosided":
        return skipped_lobes(bsdfs, int(b["front"]), threshold, depth + 1)
    if t in ("bumpmap", "normalmap"):
        return skipped_lobes(bsdfs, int(b["bsdf"]), threshold, depth + 1)
    if t == "blendbsdf":
        return [f"{s} inside blendbsdf {index}" for k in ("bsdf_0", "bsdf_1")
                for s in skipped_lobes(bsdfs, int(b[k]), threshold, depth + 1)]
    if t != "principled":
        return []
    a = _clearcoat_alpha(b)
    if a is None:
        return []
    if a == "texture":
        return [f"principled {index} clearcoat with a textured clearcoat or gloss"]
    return [f"principled {index} clearcoat alpha {a:.3g}"] if a < threshold else []


def bias_sources(A) -> list[dict]:
    """The known bias sources of ``A``'s column sum (module doc), in the order vpl_clamp, vsl_radius,
    anisotropic_frame, glossy_lobe_without_mis; empty when the light model is unbiased as far as this package knows.

    Args:
        A: a ``LightMatrix``.

    Returns:
        list of dicts with ``source`` and ``reason`` (a sentence), and per source: ``lights`` and ``clamp``
        (1/m^2, scene units) for ``vpl_clamp``; ``lights`` and ``max_radius`` for ``vsl_radius``; ``shapes``
        (their ids) for ``anisotropic_frame``;
        ``view_samples`` (pixels on such a lobe) and ``lobes`` for ``glossy_lobe_without_mis``."""
    out = []
    lights = A.lights
    kind = np.asarray(lights.kind)
    vpl = kind == VPL_KIND
    radius = np.asarray(lights.vsl_radius) if vpl.any() else np.zeros(0)
    vsl = vpl & (radius > 0) if radius.size else np.zeros_like(vpl)
    point_vpls = int(np.count_nonzero(vpl & ~vsl))
    clamp = float(lights.vpl_clamp)
    if point_vpls and np.isfinite(clamp):
        out.append({"source": "vpl_clamp", "lights": point_vpls, "clamp": clamp, "reason": (
            f"{point_vpls} VPLs with the geometry term clamped at {clamp:.4g}: the energy removed near corners "
            "and contacts is in no estimate (LightMatrix.bias_compensation adds it back)")})
    if vsl.any():
        out.append({"source": "vsl_radius", "lights": int(np.count_nonzero(vsl)), "max_radius": float(radius[vsl].max()),
                    "reason": f"{int(np.count_nonzero(vsl))} virtual spherical lights spread each VPL over a sphere "
                              f"(radius up to {float(radius[vsl].max()):.4g}): a blurred expectation"})
    scene = A.scene
    turned = [(i, s) for i, s in enumerate(scene.shapes) if s.get("anisotropic_frame")]
    if turned:
        names = [str(s.get("id") or f"shape {i}") for i, s in turned]
        out.append({"source": "anisotropic_frame", "shapes": names, "reason": (
            f"{len(names)} shapes with an anisotropic BSDF are shaded in a frame rotated about the normal from "
            f"Mitsuba's ({', '.join(names[:4])}{', ...' if len(names) > 4 else ''}): their highlights turn, and "
            "the probes' path tracer shares the frame, so no estimate covers it")})
    threshold = A.glossy_roughness
    per_bsdf = {i: skipped_lobes(scene.bsdfs, i, threshold) for i in range(len(scene.bsdfs))}
    if any(per_bsdf.values()):
        shape_bsdf = np.array([-1 if s.get("bsdf") is None else int(s["bsdf"]) for s in scene.shapes] + [-1])
        shape = np.asarray(scene.gbuffer(device=A.device["kind"])["shape_index"]).reshape(-1).astype(np.int64)
        shape = np.where((shape >= 0) & (shape < len(scene.shapes)), shape, len(scene.shapes))
        seen = shape_bsdf[shape]
        hit = [i for i, lobes in per_bsdf.items() if lobes and np.any(seen == i)]
        if hit:
            count = int(np.isin(seen, hit).sum())
            lobes = [s for i in hit for s in per_bsdf[i]]
            out.append({"source": "glossy_lobe_without_mis", "view_samples": count, "lobes": lobes, "reason": (
                f"{count} pixels see a lobe narrower than glossy_roughness {threshold:g} that glossy MIS does not "
                f"sample ({'; '.join(lobes[:4])}{'; ...' if len(lobes) > 4 else ''}): their highlights are missed "
                "by all but rare draws of the lights")})
    return out


def describe(sources: list[dict]) -> str:
    """One sentence naming the sources (``"VPL clamp: ...; ..."``), or ``""`` for none."""
    return "; ".join(f"{s['source']}: {s['reason']}" for s in sources)
