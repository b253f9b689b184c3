"""A generated many-emitter scene: a 10 m hall lit by thousands of small area emitters (a generator, no data).

Light-BVH sampling, RIS and Stochastic Lightcuts were built for scenes like this one (Conty Estevez and Kulla
2018; Bitterli et al. 2020; Yuksel 2019): many emitters of very different power, most of them far from any
given point and many hidden from it. ``python -m manylights.bench vs-mitsuba --scene many-emitters:5000
--samplers light_bvh_sampling ris_sampling stochastic_lightcuts`` writes it (``write_scene``) and charts those
samplers and MRCS against Mitsuba's path tracer on the same XML.

The hall (seeded, so the same ``emitters`` and ``seed`` give the same file byte for byte):

- a 10 x 3 x 10 m box (white floor and ceiling, grey walls; the wall behind the camera is open) with twelve
  grey boxes on the floor (pillars and crates: shadows at every scale);
- 70% of the emitters face down from the ceiling on a jittered grid, 6 to 12 cm squares; the rest face into
  the room from the left and right walls, 4 to 8 cm squares between 0.5 and 2.8 m up, also on jittered grids
  (each square inside its own cell, smaller where the cells are small: no two emitters overlap);
- radiance log-normal (sigma 1.5: a few emitters carry most of the power), colours drawn from five tints;
- Mitsuba's ``path`` integrator with ``max_depth`` 2 (direct light), a 4:3 ``hdrfilm`` with a box filter.

Symbols: N emitters (``emitters``), L_e an emitter's radiance.
"""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from .._utils.files import atomic_write_text

#: ``many-emitters:N`` names the generated hall with N emitters.
PREFIX = "many-emitters"
#: Tints (linear RGB) the emitters' colours are drawn from: warm white, cool white, amber, teal, pink.
TINTS = np.array([[1.0, 0.85, 0.7], [0.8, 0.9, 1.0], [1.0, 0.6, 0.2], [0.3, 0.9, 0.8], [1.0, 0.5, 0.7]])
#: Bounds of the emitter count.
MIN_EMITTERS, MAX_EMITTERS = 10, 200_000


def parse_name(name: str) -> int | None:
    """``"many-emitters:5000"`` -> 5000; None for any other name.

    Raises:
        ValueError: the prefix with a count that is not an integer in [MIN_EMITTERS, MAX_EMITTERS]."""
    m = re.fullmatch(rf"{PREFIX}:(.*)", str(name))
    if m is None:
        return None
    try:
        n = int(m.group(1))
    except ValueError:
        n = -1
    if not MIN_EMITTERS <= n <= MAX_EMITTERS:
        raise ValueError(f"{name!r}: expected {PREFIX}:N with N an integer in [{MIN_EMITTERS}, {MAX_EMITTERS}]")
    return n


def _rect(transform: str, bsdf: str, emitter: str = "") -> str:
    return f'    <shape type="rectangle"><transform name="to_world">{transform}</transform><ref id="{bsdf}"/>{emitter}</shape>\n'


def _box(cx: float, cz: float, sx: float, sy: float, sz: float) -> str:
    return (f'    <shape type="cube"><transform name="to_world"><scale x="{sx / 2:.4f}" y="{sy / 2:.4f}" '
            f'z="{sz / 2:.4f}"/><translate x="{cx:.4f}" y="{sy / 2:.4f}" z="{cz:.4f}"/></transform>'
            '<ref id="grey"/></shape>\n')


def scene_xml(emitters: int, seed: int = 0) -> str:
    """The hall's Mitsuba 3 XML with ``emitters`` area emitters (module docs).

    Raises:
        ValueError: ``emitters`` outside [MIN_EMITTERS, MAX_EMITTERS]."""
    if not MIN_EMITTERS <= int(emitters) <= MAX_EMITTERS:
        raise ValueError(f"emitters must be in [{MIN_EMITTERS}, {MAX_EMITTERS}], got {emitters}")
    n = int(emitters)
    rng = np.random.default_rng(seed)
    n_ceiling = int(round(0.7 * n))
    n_wall = n - n_ceiling
    parts = []

    def emitter() -> str:
        radiance = np.exp(rng.normal(1.0, 1.5)) * TINTS[rng.integers(len(TINTS))]
        return ('<emitter type="area"><rgb name="radiance" value="'
                + ", ".join(f"{v:.4g}" for v in radiance) + '"/></emitter>')

    # Every emitter lies inside its own cell of a grid, so no two overlap: coplanar overlapping emitters
    # would make which one a ray hits a matter of rounding (renderers then disagree on what the camera sees).
    def in_cell(lo: float, cell: float, half: float) -> float:
        return lo + rng.uniform(half, cell - half)

    # Ceiling: a k x k grid over 9.6 x 9.6 m, the first n_ceiling cells; rotate x 90 faces down.
    k = int(np.ceil(np.sqrt(n_ceiling)))
    cell = 9.6 / k
    for c in range(n_ceiling):
        i, j = divmod(c, k)
        half = min(rng.uniform(0.03, 0.06), 0.45 * cell)
        x, z = in_cell(-4.8 + i * cell, cell, half), in_cell(-4.8 + j * cell, cell, half)
        parts.append(_rect(f'<scale value="{half:.4f}"/><rotate x="1" angle="90"/>'
                           f'<translate x="{x:.4f}" y="2.995" z="{z:.4f}"/>', "black", emitter()))
    # Walls x = -5 (facing +x) and x = +5 (facing -x): per wall a grid over 0.5-2.8 m up and 9.6 m along,
    # its cells in random order.
    per_wall = [(n_wall + 1) // 2, n_wall // 2]
    for side, count in zip((-1.0, 1.0), per_wall):
        if count == 0:
            continue
        cols = int(np.ceil(np.sqrt(count * 9.6 / 2.3)))
        rows = int(np.ceil(count / cols))
        cw, ch = 9.6 / cols, 2.3 / rows
        for c in rng.permutation(rows * cols)[:count]:
            r, q = divmod(int(c), cols)
            half = min(rng.uniform(0.02, 0.04), 0.45 * min(cw, ch))
            y, z = in_cell(0.5 + r * ch, ch, half), in_cell(-4.8 + q * cw, cw, half)
            parts.append(_rect(f'<scale value="{half:.4f}"/><rotate y="1" angle="{-90 * side:.0f}"/>'
                               f'<translate x="{4.995 * side:.4f}" y="{y:.4f}" z="{z:.4f}"/>', "black", emitter()))
    boxes = []
    for _ in range(12):
        tall = rng.uniform() < 0.4
        boxes.append(_box(rng.uniform(-4.0, 4.0), rng.uniform(-4.0, 2.5), rng.uniform(0.3, 1.0),
                          rng.uniform(2.0, 2.9) if tall else rng.uniform(0.4, 1.2), rng.uniform(0.3, 1.0)))
    return ('<scene version="3.0.0">\n'
            f'    <!-- generated by manylights.bench.many_emitters: {n} emitters, seed {seed} -->\n'
            '    <integrator type="path"><integer name="max_depth" value="2"/></integrator>\n'
            '    <sensor type="perspective"><float name="fov" value="75"/>\n'
            '        <transform name="to_world"><lookat origin="0, 1.6, 7.5" target="0, 1.2, 0" up="0, 1, 0"/>'
            '</transform>\n'
            '        <film type="hdrfilm"><integer name="width" value="256"/><integer name="height" value="192"/>'
            '<rfilter type="box"/></film>\n    </sensor>\n'
            '    <bsdf type="diffuse" id="white"><rgb name="reflectance" value="0.75, 0.75, 0.75"/></bsdf>\n'
            '    <bsdf type="diffuse" id="grey"><rgb name="reflectance" value="0.4, 0.4, 0.4"/></bsdf>\n'
            '    <bsdf type="diffuse" id="black"><rgb name="reflectance" value="0.05, 0.05, 0.05"/></bsdf>\n'
            + _rect('<scale value="5"/><rotate x="1" angle="-90"/>', "white")  # floor, facing up
            + _rect('<scale value="5"/><rotate x="1" angle="90"/><translate y="3"/>', "white")  # ceiling
            + _rect('<scale x="5" y="1.5"/><translate y="1.5" z="-5"/>', "grey")  # back wall
            + _rect('<scale x="5" y="1.5"/><rotate y="1" angle="90"/><translate x="-5" y="1.5"/>', "grey")
            + _rect('<scale x="5" y="1.5"/><rotate y="1" angle="-90"/><translate x="5" y="1.5"/>', "grey")
            + "".join(boxes) + "".join(parts) + "</scene>\n")


def write_scene(folder: Path, emitters: int, seed: int = 0) -> Path:
    """Write the hall with ``emitters`` emitters to ``folder/scene.xml`` (atomically; unchanged content is
    not rewritten, so a cache keyed by the folder's content stays valid). Returns the XML's path.

    Raises:
        ValueError: ``emitters`` outside [MIN_EMITTERS, MAX_EMITTERS]."""
    xml = scene_xml(emitters, seed)
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "scene.xml"
    if not path.is_file() or path.read_text() != xml:
        atomic_write_text(path, xml)
    return path
