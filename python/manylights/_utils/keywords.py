"""Unknown keyword arguments of the public functions: refused before the function body runs (so before any
native work), with a TypeError naming the closest valid keyword (``difflib``) and listing the valid ones.

``@checked_keywords()`` on a function whose keywords are all named in its signature; for one that passes
``**options`` on, ``@checked_keywords(target)`` adds the keyword-only parameters of ``target`` to the valid
names. The wrapper calls ``wrapper.__wrapped__``, so a test can replace the body and count its calls.
"""
from __future__ import annotations

import difflib
import functools
import importlib
import inspect
from typing import Callable, Iterable


def keyword_names(fn) -> list[str]:
    """Names ``fn`` (function, or class: its ``__init__``) accepts as keywords (``self`` excluded)."""
    target = fn.__init__ if inspect.isclass(fn) else fn
    params = inspect.signature(target).parameters.values()
    return [p.name for p in params
            if p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY) and p.name not in ("self", "cls")]


def unknown_keyword_error(func: str, given: str, valid: Iterable[str], what: str = "keyword argument") -> TypeError:
    """``TypeError: func() got an unexpected keyword argument 'given'; did you mean 'x'? (valid: ...)``."""
    valid = sorted(set(valid))
    close = difflib.get_close_matches(given, valid, n=1, cutoff=0.6)
    if not close:  # a prefix or a case slip ("color" for "color_averaging", "Seed")
        close = [v for v in valid if v.lower().startswith(given.lower()) or given.lower().startswith(v.lower())][:1]
    hint = f"; did you mean {close[0]!r}?" if close else ""
    return TypeError(f"{func}() got an unexpected {what} {given!r}{hint} (valid: {', '.join(valid)})")


def checked_keywords(forward=None, exclude: Iterable[str] = ()) -> Callable:
    """Decorator: refuse keywords that neither the function nor ``forward``'s keyword-only parameters
    (minus ``exclude``, the ones the function sets itself) accept. ``forward``: the function or class the
    ``**options`` go to, or a ``"module:name"`` string resolved at the first call (for a target that would
    make an import cycle)."""

    def decorate(fn):
        own = keyword_names(fn)
        name = fn.__qualname__.replace(".__init__", "")
        cache: list = []

        def valid_names() -> frozenset:
            if not cache:
                names = set(own)
                if forward is not None:
                    target = forward
                    if isinstance(target, str):
                        module, attr = target.split(":")
                        target = getattr(importlib.import_module(module), attr)
                    init = target.__init__ if inspect.isclass(target) else target
                    names.update(p.name for p in inspect.signature(init).parameters.values()
                                 if p.kind == p.KEYWORD_ONLY and p.name not in exclude)
                cache.append(frozenset(names))
            return cache[0]

        @functools.wraps(fn)
        def wrapper(*args, **kwargs):
            if kwargs:
                names = valid_names()
                for k in kwargs:
                    if k not in names:
                        raise unknown_keyword_error(name, k, names)
            return wrapper.__wrapped__(*args, **kwargs)

        return wrapper

    return decorate
