"""manylights: many-light rendering research (Rust core, wgpu)."""
from . import _native
from ._native import ManyLightsError, GpuUnavailableError, GpuError, SceneError

__version__ = _native.__version__
