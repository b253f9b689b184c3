"""Animation output: EXR sequences read back bit-exact, MP4 and GIF decoded back to the
frames' sRGB codes (within the codec's loss), side-by-side strips, and files that appear complete or not at
all."""
from __future__ import annotations

import numpy as np
import pytest

import manylights as ml
from manylights.io import video

iio = pytest.importorskip("imageio.v3")


def _animation(f=6, h=32, w=48, seed=0):
    """Frames with a moving bright square over a smooth gradient (linear radiance in [0, 1])."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:h, 0:w].astype(np.float32)
    frames = np.empty((f, h, w, 3), np.float32)
    for k in range(f):
        frames[k] = np.stack([x / w, y / h, np.full_like(x, 0.2)], -1) * 0.5
        frames[k, 8:16, 4 + 5 * k:12 + 5 * k] = [0.9, 0.8, 0.1]
    return frames + rng.uniform(0, 1e-3, frames.shape).astype(np.float32)


def test_exr_sequence_is_bit_exact(tmp_path):
    frames = _animation()
    paths = ml.write_exr_sequence(frames, tmp_path / "seq", prefix="shot")
    assert [p.name for p in paths] == [f"shot_{k:04d}.exr" for k in range(len(frames))]
    back = np.stack([ml.read_exr(p) for p in paths])
    assert back.dtype == np.float32 and np.array_equal(back, frames)
    # Nothing else (no temporary files) in the folder.
    assert sorted(p.name for p in (tmp_path / "seq").iterdir()) == [p.name for p in paths]


def test_srgb8_matches_png(tmp_path):
    frames = _animation(f=1)
    ml.write_png(tmp_path / "a.png", frames[0], exposure=0.5)
    png = iio.imread(tmp_path / "a.png")
    assert np.array_equal(video.to_srgb8(frames[0], exposure=0.5), png)
    # The value of a known code: linear 0.5 -> sRGB 0.7354 -> 188.
    assert video.to_srgb8(np.full((1, 1, 3), 0.5, np.float32))[0, 0, 0] == 188


@pytest.mark.parametrize("suffix, tolerance", [(".mp4", 6.0), (".gif", 12.0)])
def test_video_round_trip(tmp_path, suffix, tolerance):
    frames = _animation(h=31, w=47)  # odd sizes: MP4 pads to even
    path = ml.write_video(frames, tmp_path / f"a{suffix}", fps=10)
    assert path.is_file() and [p.name for p in tmp_path.iterdir()] == [f"a{suffix}"]
    back = iio.imread(path)[..., :3].astype(np.float64)
    assert back.shape[0] == len(frames)
    back = back[:, :31, :47]
    want = video.to_srgb8(frames).astype(np.float64)
    # Mean absolute difference of the 8-bit codes: lossy H.264 (crf 18) / GIF palette quantisation.
    mad = np.abs(back - want).mean()
    assert mad < tolerance, mad
    # Frames differ where the square moved: the decoded sequence is not one repeated frame.
    assert np.abs(back[0] - back[-1]).mean() > 1.0


def test_failed_write_leaves_nothing(tmp_path, monkeypatch):
    frames = _animation()

    def boom(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(iio, "imwrite", boom)
    with pytest.raises(KeyboardInterrupt):
        ml.write_video(frames, tmp_path / "a.gif")
    assert list(tmp_path.iterdir()) == []
    # MP4: Ctrl-C while ffmpeg runs kills ffmpeg, waits for it and removes its temporary file.
    import subprocess

    started = []
    real = subprocess.Popen.communicate

    def interrupted(self, *a, **k):
        started.append(self)
        raise KeyboardInterrupt

    monkeypatch.setattr(subprocess.Popen, "communicate", interrupted)
    with pytest.raises(KeyboardInterrupt):
        ml.write_video(frames, tmp_path / "a.mp4")
    monkeypatch.setattr(subprocess.Popen, "communicate", real)
    assert len(started) == 1 and started[0].returncode is not None  # ffmpeg was waited for
    assert list(tmp_path.iterdir()) == []


def test_side_by_side_layout():
    a, b = _animation(seed=1), _animation(seed=2)
    strip = ml.side_by_side([a, b, video.error_panel(a, b)], labels=["tensor", "mrcs", "error"], gap=3)
    f, h, w, _ = a.shape
    assert strip.shape == (f, h + video.LABEL_HEIGHT, 3 * w + 2 * 3, 3)
    body = strip[:, video.LABEL_HEIGHT:]
    assert np.array_equal(body[:, :, :w], a) and np.array_equal(body[:, :, w + 3:2 * w + 3], b)
    assert np.all(body[:, :, w:w + 3] == 0)
    # Labels are drawn (some white pixels above each panel) and nothing outside the header changed.
    header = strip[0, :video.LABEL_HEIGHT, :, 0]
    for k in range(3):
        assert header[:, k * (w + 3):k * (w + 3) + w].max() > 0.5
    # Error panel: 4 |a - b| averaged over channels.
    want = 4 * np.abs(a - b).mean(-1)
    assert np.allclose(body[..., 2 * w + 6:, 0], want, rtol=1e-6)
    single = ml.side_by_side([a[0], b[0]])
    assert single.shape == (h, 2 * w + 2, 3)


@pytest.mark.parametrize("call, match", [
    (lambda p: ml.write_video(np.zeros((2, 4, 4, 3), np.float32), p / "a.avi"), "mp4 or .gif"),
    (lambda p: ml.write_video(np.zeros((2, 4, 4, 3), np.float32), p / "a.mp4", fps=0), "fps"),
    (lambda p: ml.write_video(np.zeros((0, 4, 4, 3), np.float32), p / "a.mp4"), "empty"),
    (lambda p: ml.write_video(np.zeros((4, 4, 3), np.float32), p / "a.mp4"), r"\(f, H, W, 3\)"),
    (lambda p: ml.write_video(np.full((2, 4, 4, 3), np.nan, np.float32), p / "a.gif"), "frame 0 pixel"),
    (lambda p: ml.write_exr_sequence(np.zeros((2, 4, 4, 3), np.float32), p, prefix="a/b"), "prefix"),
    (lambda p: ml.side_by_side([np.zeros((2, 4, 4, 3)), np.zeros((2, 4, 5, 3))]), "all must match"),
    (lambda p: ml.side_by_side([np.zeros((2, 4, 4, 3))], labels=["a", "b"]), "2 labels for 1 panels"),
    (lambda p: ml.side_by_side([]), "at least one"),
])
def test_bad_input(tmp_path, call, match):
    with pytest.raises(ValueError, match=match):
        call(tmp_path)
    assert list(tmp_path.iterdir()) == []


def test_missing_folder(tmp_path):
    with pytest.raises(FileNotFoundError, match="does not exist"):
        ml.write_video(_animation(), tmp_path / "nope" / "a.gif")
