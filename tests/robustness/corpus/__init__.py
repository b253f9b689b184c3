"""The bad-input corpus (run by ``tests/robustness/bad_input_corpus.py``), one module per domain.

Importing a module registers its cases in ``CASES``, so the imports below are in the corpus's order (the
order of ``CASES`` and of the test ids); ``selftest`` comes last, as it replaces them when asked to.
"""
from __future__ import annotations

# isort: off
from . import scene_files  # noqa: F401
from . import mesh_files  # noqa: F401
from . import textures  # noqa: F401
from . import images  # noqa: F401
from . import metrics  # noqa: F401
from . import scenes_lights  # noqa: F401
from . import light_matrix  # noqa: F401
from . import clustering  # noqa: F401
from . import gather  # noqa: F401
from . import renderers  # noqa: F401
from . import native_only  # noqa: F401
from . import animations  # noqa: F401
from . import tensor  # noqa: F401
from . import sweep  # noqa: F401
from . import subprocess_env  # noqa: F401
from . import not_covered  # noqa: F401
from . import selftest  # noqa: F401
# isort: on
from .common import CASES, REPO, Case, Ctx, case, cases_for
from .not_covered import NOT_COVERED
from .subprocess_env import SUBPROCESS_ENV

__all__ = ["CASES", "NOT_COVERED", "REPO", "SUBPROCESS_ENV", "Case", "Ctx", "case", "cases_for"]
