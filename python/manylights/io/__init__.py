"""Files people look at: images (``images``: EXR, PNG), animations (``video``: EXR sequences, MP4/GIF,
side-by-side strips, error panels, 8-bit sRGB) and a quick look (``show``: inline in Jupyter, else a PNG)."""
from .display import png_bytes, show
from .images import read_exr, write_exr, write_png
from .video import error_panel, side_by_side, to_srgb8, write_exr_sequence, write_video

__all__ = ["read_exr", "write_exr", "write_png", "show", "png_bytes", "error_panel", "side_by_side", "to_srgb8", "write_exr_sequence",
           "write_video"]
