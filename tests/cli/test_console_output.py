"""What a user running ``python script.py`` sees on the console.

Progress in logs and CI. With stderr going to a pipe or a file a call with the default ``progress=None``
writes nothing, and one with ``progress=True`` a few plain lines per progress display (start and end), not
tqdm's carriage-return redraws; in a terminal (a pty here) the default is a live tqdm bar.

Item 11: with ``XDG_RUNTIME_DIR`` unset, importing manylights and starting the GPU prints nothing on
stderr (Mesa's device-select layer used to make libwayland print "error: XDG_RUNTIME_DIR is invalid or
not set in the environment." twice), and the GPU gives the same column as in this process.
"""
from __future__ import annotations

import fcntl
import json
import os
import pty
import struct
import subprocess
import sys
import termios
import textwrap

import numpy as np

import manylights as ml
from conftest import REPO, SCENE_CONFIGS

SCRIPT = textwrap.dedent(r"""
    import json, sys
    import numpy as np
    import manylights as ml
    xml, params = sys.argv[1], json.loads(sys.argv[2])
    scene = ml.load_scene(xml, size=(16, 16), **params)
    lights = ml.generate_lights(scene, area=int(sys.argv[3]), seed=0)
    A = ml.LightMatrix(scene, lights, shadow_map_size=64)
    progress = json.loads(sys.argv[5]) if len(sys.argv) > 5 else None
    img = A.column_sum(progress=progress)     # progress=None by default: a bar in a terminal, quiet in logs
    R = A.rows(np.arange(40), progress=progress)
    np.save(sys.argv[4], img)
""")


def _cbox():
    xml, params, _ = SCENE_CONFIGS["cbox"]
    return str(xml), json.dumps(params)


def test_progress_in_a_pipe_is_a_few_lines(tmp_path):
    xml, params = _cbox()
    env = {k: v for k, v in os.environ.items() if k != "MANYLIGHTS_PROGRESS"}
    # 1500 lights = 6 column batches of 256, 40 rows; tqdm redrew once per batch before.
    # The default in a pipe: nothing at all.
    quiet = subprocess.run([sys.executable, "-c", SCRIPT, xml, params, "300", str(tmp_path / "q.npy")],
                           capture_output=True, text=True, cwd=REPO, env=env, timeout=600)
    assert quiet.returncode == 0 and quiet.stderr == "", quiet.stderr[-3000:]
    # progress=True in a pipe: a few plain lines.
    out = subprocess.run([sys.executable, "-c", SCRIPT, xml, params, "1500", str(tmp_path / "img.npy"), "true"],
                         capture_output=True, text=True, cwd=REPO, env=env, timeout=600)
    assert out.returncode == 0, out.stderr[-3000:]
    lines = out.stderr.splitlines()
    assert "\r" not in out.stderr, repr(out.stderr[:500])
    progress = [line for line in lines if line.startswith("manylights: ")]
    assert len(progress) == len(lines), lines          # nothing else on stderr
    # Start and end of each call (an intermediate line only past LOG_INTERVAL = 60 s).
    cols = [line for line in progress if line.startswith("manylights: columns: ")]
    rows = [line for line in progress if line.startswith("manylights: rows: ")]
    assert 2 <= len(cols) <= 3 and 2 <= len(rows) <= 3, lines
    assert cols[0] == "manylights: columns: 1500 lights ..." and cols[-1].startswith("manylights: columns: done, 1500 lights in")
    assert rows[-1].startswith("manylights: rows: done, 40 rows in")
    # The image is the same as without progress display.
    scene = ml.load_scene(SCENE_CONFIGS["cbox"][0], size=(16, 16), **SCENE_CONFIGS["cbox"][1])
    ref = ml.LightMatrix(scene, ml.generate_lights(scene, area=1500, seed=0),
                          shadow_map_size=64).column_sum(progress=False)
    np.testing.assert_array_equal(np.load(tmp_path / "img.npy"), ref)


def test_progress_in_a_terminal_is_a_bar(tmp_path):
    xml, params = _cbox()
    env = {k: v for k, v in os.environ.items() if k != "MANYLIGHTS_PROGRESS"}
    master, slave = pty.openpty()
    # A terminal of 80 columns (a new pty has 0, which tqdm would fill with an empty bar).
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 80, 0, 0))
    proc = subprocess.Popen([sys.executable, "-c", SCRIPT, xml, params, "600", str(tmp_path / "img.npy")],
                            stdout=subprocess.DEVNULL, stderr=slave, cwd=REPO, env=env)
    os.close(slave)
    chunks = []
    while True:
        try:
            data = os.read(master, 65536)
        except OSError:
            break
        if not data:
            break
        chunks.append(data)
    proc.wait(timeout=600)
    os.close(master)
    text = b"".join(chunks).decode(errors="replace")
    assert proc.returncode == 0, text[-3000:]
    assert "columns:" in text and "%|" in text and "\r" in text, text[:1000]   # tqdm's live bar
    assert "manylights: columns" not in text                                   # not the log lines


def test_no_xdg_runtime_dir_error_lines(tmp_path):
    xml, params = _cbox()
    env = {k: v for k, v in os.environ.items()
           if k not in ("XDG_RUNTIME_DIR", "WAYLAND_DISPLAY", "NODEVICE_SELECT", "MANYLIGHTS_PROGRESS")}
    script = textwrap.dedent(r"""
        import json, os, sys
        import numpy as np
        import manylights as ml
        print(ml.device_info()["name"])
        scene = ml.load_scene(sys.argv[1], size=(16, 16), **json.loads(sys.argv[2]))
        col = ml.LightMatrix(scene, ml.generate_lights(scene, area=16, seed=0)).columns([3])
        np.save(sys.argv[3], col)
    """)
    out = subprocess.run([sys.executable, "-c", script, xml, params, str(tmp_path / "col.npy")],
                         capture_output=True, text=True, cwd=REPO, env=env, timeout=600)
    assert out.returncode == 0, out.stderr[-3000:]
    assert "XDG_RUNTIME_DIR" not in out.stderr and "error" not in out.stderr.lower(), out.stderr
    assert out.stderr.strip() == "", out.stderr
    scene = ml.load_scene(SCENE_CONFIGS["cbox"][0], size=(16, 16), **SCENE_CONFIGS["cbox"][1])
    ref = ml.LightMatrix(scene, ml.generate_lights(scene, area=16, seed=0)).columns([3])
    assert ref.max() > 0
    np.testing.assert_array_equal(np.load(tmp_path / "col.npy"), ref)
