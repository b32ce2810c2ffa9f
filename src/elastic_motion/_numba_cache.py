"""Loading the package's numba kernels from numba's cache without numba's compiler set-up.

Every kernel of the package is compiled with ``cache=True``: a process loads its machine code
from the ``__pycache__`` folder beside the source in a few milliseconds. But numba's cache
loader (``numba.core.caching.Cache.load_overload``) first calls ``target_context.refresh()``,
which imports and installs every typing and lowering registry numba has (array math, linear
algebra, strings, random numbers, typed containers, cffi, ...): about 0.7 s on a busy 2-core
machine, as much as half of ``import numpy, scipy.linalg, numba``, paid by the first kernel
call of every process (``elastic-motion blend`` spent 23 % of its time there, issue 34).
Running machine code that is already compiled needs none of those registries; it needs
numba's runtime (NRT: the allocator of the arrays a kernel creates), which
``rtsys.initialize`` sets up, and which the refresh would have initialised first.

:func:`load_kernels_lightly` replaces the loader with one that initialises the runtime and
loads, nothing more. Nothing else changes: numba refreshes its contexts itself whenever it
compiles (``CompilerBase.__init__``: a cache miss, a new type signature, a user's own
``@njit``) and whenever lowering looks up an implementation it lacks
(``BaseContext.get_function``), so the registries are there whenever something needs them.
It is installed by :mod:`elastic_motion.groups`, the bottom layer every module with a kernel
imports, so it is in place before the first kernel runs. If numba lacks a piece it uses
(another numba than the tested 0.59-0.68), numba's own loader stays.

Likewise the first call of any dispatcher runs numba's extension set-up
(``numba.core.entrypoints.init_all``: the ``numba_extensions`` entry points, found by reading
the metadata of every installed distribution, 7-13 ms), which lets third-party packages teach
the compiler their types. The package's own kernels take numpy arrays and numbers only, so
their calls skip it; the first call of any other function (a user's ``@njit``) runs it as
before, and so does every compile (numba's context refresh sets the extensions up too).

And ``@njit(cache=True)`` sets a kernel's cache up when the module defining it is imported:
it finds the ``__pycache__`` folder and proves it writable by creating a temporary file
there, 0.2 ms per kernel, 10 ms for the 48 kernels of a blend's modules, most of which a
given command never calls. The package's kernels get a cache that does this on its first
use (a call, or a ``compile``): the same cache, files and statistics, set up when needed.
"""

from __future__ import annotations

from typing import Any

__all__ = ["load_kernels_lightly"]


def load_kernels_lightly() -> bool:
    """Make numba's cache loader skip the registry refresh (module docstring); idempotent.

    Returns
    -------
    bool
        Whether the light loader is in place.
    """
    try:
        from numba.core.caching import Cache
        from numba.core.dispatcher import Dispatcher
        from numba.core.runtime import rtsys
    except ImportError:  # pragma: no cover - another numba layout: keep its loader
        return False
    _skip_extensions_for_own_kernels(Dispatcher)
    _set_caches_up_when_used(Dispatcher)
    original = Cache.load_overload
    if getattr(original, "_elastic_motion_light", False):
        return True
    if not all(hasattr(Cache, name) for name in ("_load_overload", "_guard_against_spurious_io_errors")):
        return False  # pragma: no cover - another numba: keep its loader

    def load_overload(self: Any, sig: Any, target_context: Any) -> Any:
        # numba's loader without target_context.refresh(): the runtime is all a loaded kernel needs
        rtsys.initialize(target_context)
        with self._guard_against_spurious_io_errors():
            return self._load_overload(sig, target_context)

    load_overload._elastic_motion_light = True  # type: ignore[attr-defined]
    load_overload.__doc__ = original.__doc__
    Cache.load_overload = load_overload
    return True


def _skip_extensions_for_own_kernels(dispatcher: Any) -> None:
    """Skip numba's extension set-up on calls of the package's own kernels (module
    docstring); idempotent, and nothing when numba has no such hook."""
    hook = getattr(dispatcher, "_compilation_chain_init_hook", None)
    if hook is None or getattr(hook, "_elastic_motion_light", False):
        return

    def init_hook(self: Any) -> None:
        if _own(getattr(self, "py_func", None)):
            return  # numpy arrays and numbers only: no third-party types to learn
        hook(self)

    init_hook._elastic_motion_light = True  # type: ignore[attr-defined]
    init_hook.__doc__ = hook.__doc__
    dispatcher._compilation_chain_init_hook = init_hook


def _own(py_func: Any) -> bool:
    """Whether a dispatcher's function is one of the package's kernels."""
    return getattr(py_func, "__module__", "").startswith("elastic_motion.")


class _CacheOnFirstUse:
    """numba's ``FunctionCache`` of a kernel, created on the first use of any of its
    attributes (module docstring)."""

    # class-level defaults: a copy made without __init__ (copy, pickle) then fails with an
    # AttributeError naming the attribute instead of recursing through __getattr__
    _py_func: Any = None
    _cache_class: Any = None
    _cache: Any = None

    def __init__(self, py_func: Any, cache_class: Any) -> None:
        self._py_func = py_func
        self._cache_class = cache_class

    def __getattr__(self, name: str) -> Any:
        if self._cache_class is None:
            raise AttributeError(name)
        if self._cache is None:
            self._cache = self._cache_class(self._py_func)
        return getattr(self._cache, name)


def _set_caches_up_when_used(dispatcher: Any) -> None:
    """Give the package's kernels caches set up on first use (module docstring); idempotent,
    and nothing when numba's dispatcher has no ``enable_caching``."""
    from numba.core.caching import FunctionCache

    original = getattr(dispatcher, "enable_caching", None)
    if original is None or getattr(original, "_elastic_motion_light", False):
        return

    def enable_caching(self: Any) -> None:
        if _own(self.py_func):
            self._cache = _CacheOnFirstUse(self.py_func, FunctionCache)
        else:
            original(self)

    enable_caching._elastic_motion_light = True  # type: ignore[attr-defined]
    enable_caching.__doc__ = original.__doc__
    dispatcher.enable_caching = enable_caching
