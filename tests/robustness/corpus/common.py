"""The bad-input corpus's shared parts: the ``Case`` registry, the context the cases run in, byte
helpers for foreign and truncated files, and the names several sections use.
"""
from __future__ import annotations

import struct
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

REPO = Path(__file__).resolve().parents[3]


@dataclass
class Case:
    id: str
    target: str                      # the public function it covers, e.g. "load_scene", "LightMatrix.rows"
    fn: Callable                     # fn(ctx) -> anything; must raise
    raises: tuple = ("ValueError",)  # accepted exception class names (subclasses count)
    match: tuple = ()                # each must appear (case-insensitively) in the message
    subprocess: bool = False         # run alone in its own child (environment-changing cases)


CASES: list[Case] = []


def case(id, target, raises=("ValueError",), match=(), subprocess=False):
    def deco(fn):
        CASES.append(Case(id, target, fn, tuple(raises), tuple(match), subprocess))
        return fn
    return deco


def cases_for(target, items, raises=("ValueError",), subprocess=False):
    """Register one case per (id suffix, callable, match) item for ``target``."""
    for suffix, fn, match in items:
        CASES.append(Case(f"{target}:{suffix}", target, fn, tuple(raises), tuple(match), subprocess))


# --------------------------------------------------------------------------------------------------
# Context: a tiny scene, its lights and light matrix, and a folder of good and bad files.

class Ctx:
    def __init__(self, tmp: Path):
        self.tmp = tmp
        self._cache = {}

    def _get(self, name, make):
        if name not in self._cache:
            self._cache[name] = make()
        return self._cache[name]

    @property
    def ml(self):
        import manylights
        return manylights

    @property
    def native(self):
        from manylights import _native
        return _native

    @property
    def scene(self):
        return self._get("scene", lambda: self.ml.load_scene(REPO / "scenes" / "demo" / "scene.xml", res=8))

    @property
    def lights(self):
        return self._get("lights", lambda: self.ml.generate_lights(self.scene, area=4, seed=0))

    @property
    def A(self):
        return self._get("A", lambda: self.ml.LightMatrix(self.scene, self.lights, shadow_map_size=16))

    @property
    def n(self):
        return self.A.shape[1]

    @property
    def m(self):
        return self.A.shape[0]

    def file(self, name: str, data: bytes) -> Path:
        p = self.tmp / name
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_bytes(data)
        return p

    # good files to truncate or rename
    @property
    def png_bytes(self) -> bytes:
        def make():
            p = self.tmp / "good.png"
            self.ml.write_png(p, np.full((4, 4, 3), 0.5, np.float32))
            return p.read_bytes()
        return self._get("png", make)

    @property
    def exr_bytes(self) -> bytes:
        def make():
            p = self.tmp / "good.exr"
            self.ml.write_exr(p, np.full((4, 8, 3), 0.5, np.float32))
            return p.read_bytes()
        return self._get("exr", make)

    @property
    def jpg_bytes(self) -> bytes:
        return (REPO / "scenes" / "veach-ajar" / "textures" / "landscape-with-a-lake.jpg").read_bytes()

    def scene_with(self, name: str, body: str, files: dict[str, bytes] | None = None) -> Path:
        """A tiny scene XML (8x8 film, a point light) with ``body`` inside <scene>, beside ``files``."""
        d = self.tmp / name
        d.mkdir(parents=True, exist_ok=True)
        for fname, data in (files or {}).items():
            (d / fname).write_bytes(data)
        xml = f"""<scene version="3.0.0">
    <sensor type="perspective">
        <float name="fov" value="45"/>
        <transform name="to_world"> <lookat origin="0, 0, 4" target="0, 0, 0" up="0, 1, 0"/> </transform>
        <film type="hdrfilm"> <integer name="width" value="8"/> <integer name="height" value="8"/> </film>
    </sensor>
    <emitter type="point"> <point name="position" x="0" y="0" z="3"/> <rgb name="intensity" value="1"/> </emitter>
    {body}
</scene>
"""
        p = d / "scene.xml"
        p.write_text(xml)
        return p


JUNK = bytes(range(256)) * 8 + b"\x00\xff" * 100
OBJ = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\n"


def ply_binary(nv_header: int, nf_header: int, nv_data: int, nf_data: int, face_index: int = 2) -> bytes:
    head = (f"ply\nformat binary_little_endian 1.0\nelement vertex {nv_header}\nproperty float x\nproperty float y\n"
            f"property float z\nelement face {nf_header}\nproperty list uchar int vertex_indices\nend_header\n").encode()
    verts = b"".join(struct.pack("<3f", float(i), float(i % 2), 0.0) for i in range(nv_data))
    faces = b"".join(struct.pack("<B3i", 3, 0, 1, face_index) for _ in range(nf_data))
    return head + verts + faces


def exr_window(exr: bytes, window: tuple[int, int, int, int]) -> bytes:
    """A valid EXR whose header's dataWindow (xmin, ymin, xmax, ymax) is replaced (the pixels stay 8x4)."""
    attr = b"dataWindow\x00box2i\x00"
    i = exr.index(attr) + len(attr) + 4
    return exr[:i] + struct.pack("<4i", *window) + exr[i + 16:]


def png_header_only(width: int, height: int) -> bytes:
    """A PNG signature + IHDR claiming width x height, and no image data."""
    ihdr = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    chunk = struct.pack(">I", len(ihdr)) + b"IHDR" + ihdr + struct.pack(">I", zlib.crc32(b"IHDR" + ihdr))
    return b"\x89PNG\r\n\x1a\n" + chunk


def bmp_declaring(width: int, height: int) -> bytes:
    """A 24-bit uncompressed BMP header declaring width x height, followed by 4 bytes of pixels."""
    return (b"BM" + struct.pack("<IHHI", 58, 0, 0, 54) + struct.pack("<IiiHHIIiiII", 40, width, height, 1, 24, 0, 0, 0, 0, 0, 0)
            + b"\x01\x02\x03\x00")


def tga_declaring(width: int, height: int) -> bytes:
    """An uncompressed 24-bit TGA header declaring width x height, followed by one pixel."""
    return bytes([0, 0, 2, 0, 0, 0, 0, 0]) + struct.pack("<HHHHBB", 0, 0, width, height, 24, 0x20) + b"\x01\x02\x03"


def jpeg_declaring(jpeg: bytes, width: int, height: int) -> bytes:
    """A JPEG whose frame header (the first SOFn segment) is changed to declare width x height."""
    i = 2
    while jpeg[i] == 0xFF and jpeg[i + 1] not in (0xC0, 0xC1, 0xC2):
        i += 2 + struct.unpack(">H", jpeg[i + 2:i + 4])[0]
    assert jpeg[i] == 0xFF, "no frame header"
    return jpeg[:i + 5] + struct.pack(">HH", height, width) + jpeg[i + 9:]



# --------------------------------------------------------------------------------------------------
# Shared by several sections.

FILE_ERRORS = ("SceneError", "OSError", "ValueError")

IMG = lambda *shape: np.zeros(shape, np.float32)  # noqa: E731
R = lambda *shape: np.random.default_rng(0).random(shape, dtype=np.float32)  # noqa: E731


def _nan_at(a, idx, v=np.nan):
    a = a.copy()
    a[idx] = v
    return a


DEMO = REPO / "scenes" / "demo" / "scene.xml"


def _anim(c):
    return c._get("anim", lambda: c.ml.load_animation(DEMO, frames=[{}, {}], res=8))
