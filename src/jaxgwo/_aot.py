"""Traced programs kept across processes, so that a warm ``jaxgwo`` run skips tracing.

JAX's persistent compilation cache lets a second process skip XLA *compilation*, but
not the Python tracing and the lowering to StableHLO that come before it.  For the
optimiser, the L-BFGS polish and the simulation those two steps take longer than the
compiled programs run: about 1.5 s of a warm ``jaxgwo identify``.

:func:`cached_jit` wraps an already jitted function.  While :func:`enable` has named a
directory (the CLI does, beside the compilation cache), each call looks up the program
lowered for these arguments with :mod:`jax.export` and stored there, and lowers and
stores it if there is none; the stored program is then compiled (from the persistent
compilation cache, when it holds it) and run.  It is the very program a plain call
would compile, so the results are bit-identical.  The key is everything the trace
depends on: the jaxgwo sources, the versions of JAX, jaxlib, equinox and optax, the JAX
settings that change a trace, the static arguments (configuration fields, functions by
name) and the shape and dtype of every array argument.  Arguments it cannot key (an
object without a stable description, a closure) take the plain path.  A file is about
0.1-0.2 MB; what another version of the sources stored more than a day ago is deleted
when this version stores its own, and deleting the folder is always safe.

Without :func:`enable` (the library's default, and the test suite's) every call is the
plain jitted call.
"""

from __future__ import annotations

import functools
import hashlib
import os
import re
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import equinox as eqx
import jax
import numpy as np

__all__ = ["cached_jit", "enable", "enabled_directory"]

_directory: str | None = None
_programs: dict[str, Callable] = {}  # key -> jitted call of the stored program, this process

# JAX settings that change what a trace produces
_TRACE_SETTINGS = (
    "jax_enable_x64",
    "jax_numpy_dtype_promotion",
    "jax_numpy_rank_promotion",
    "jax_default_matmul_precision",
    "jax_default_prng_impl",
    "jax_threefry_partitionable",
)
_PACKAGES = ("jax", "jaxlib", "equinox", "optax", "numpy")


def enable(directory: str | None) -> None:
    """Store and reuse lowered programs in ``directory`` (None: stop)."""
    global _directory
    if directory is not None:
        os.makedirs(directory, exist_ok=True)
    _directory = directory
    _programs.clear()


def enabled_directory() -> str | None:
    return _directory


@functools.cache
def _fingerprint() -> str:
    """The jaxgwo sources and the versions of the libraries that trace them."""
    from importlib import metadata  # about 30 ms to import: only when keying a call

    h = hashlib.sha256()
    root = Path(__file__).parent
    for path in sorted(root.rglob("*.py")):
        h.update(str(path.relative_to(root)).encode() + b"\0" + path.read_bytes() + b"\0")
    for name in _PACKAGES:
        try:
            h.update(f"{name}={metadata.version(name)}\0".encode())
        except metadata.PackageNotFoundError:
            h.update(f"{name}=?\0".encode())
    return h.hexdigest()


def _describe_static(value) -> str | None:
    """A description of a static argument that is the same in every process, or None."""
    if value is None or isinstance(value, (bool, int, float, complex, str, bytes)):
        return f"{type(value).__name__}:{value!r}"
    if callable(value) and hasattr(value, "__qualname__") and hasattr(value, "__module__"):
        if "<locals>" in value.__qualname__ or "<lambda>" in value.__qualname__:
            return None  # a closure: its captured values are not in the description
        return f"function:{value.__module__}.{value.__qualname__}"
    return None


_FUNCTION_REPR = re.compile(r"<function (\S+) at 0x[0-9a-f]+>")


def _describe_tree(treedef) -> str | None:
    """``repr(treedef)`` with functions (static fields, such as a bound method's) by name
    instead of address; None if another object is described by its address."""
    text = _FUNCTION_REPR.sub(lambda m: f"function:{m.group(1)}", repr(treedef))
    if "<locals>" in text or "<lambda>" in text or " at 0x" in text:
        return None
    return text


def _key(name: str, leaves, treedef, static_leaves, static_def, options) -> str | None:
    statics = [_describe_static(v) for v in static_leaves]
    trees = [_describe_tree(treedef), _describe_tree(static_def)]
    if any(s is None for s in statics + trees):
        return None
    parts = [
        name,
        _fingerprint(),
        *trees,
        *statics,
        *(f"{x.shape}:{x.dtype}:{getattr(x, 'weak_type', False)}" for x in leaves),
        *(f"{s}={getattr(jax.config, s, None)!r}" for s in _TRACE_SETTINGS),
        jax.default_backend(),
        repr(options),
        f"python {sys.version_info[:2]}",
    ]
    return hashlib.sha256("\n".join(parts).encode()).hexdigest()


SUFFIX = ".jaxexport"
"""Stored programs are :meth:`jax.export.Exported.serialize` bytes (JAX's own versioned
format, no pickle), one file each."""


def _read(path: str):
    from jax import export as jax_export

    try:
        with open(path, "rb") as f:
            return jax_export.deserialize(bytearray(f.read()))
    except Exception:  # noqa: BLE001  (missing, truncated, or from another JAX: lower again)
        return None


def _write(path: str, exported) -> None:
    data = exported.serialize()
    try:
        fd, tmp = tempfile.mkstemp(dir=os.path.dirname(path), suffix=".tmp")
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        os.replace(tmp, path)  # atomic: a concurrent reader sees all of it or nothing
    except OSError:
        return  # a read-only or full cache: this process still runs the program
    _remove_stale(path)


STALE_AFTER_S = 86400.0
"""Programs another version of the sources stored are deleted once they are this old."""


def _remove_stale(path: str) -> None:
    """Delete what other versions of the sources (or of JAX) stored for the same function
    a day or more ago, so that the folder does not grow with every upgrade or edit (two
    versions in use side by side keep their own)."""
    directory, name = os.path.split(path)
    current = name.rsplit("-", 1)[0]  # label-fingerprint
    label = current.rsplit("-", 1)[0]
    now = time.time()
    for other in os.listdir(directory):
        if not (other.endswith(SUFFIX) and other.rsplit("-", 2)[0] == label
                and other.rsplit("-", 1)[0] != current):
            continue
        other = os.path.join(directory, other)
        try:
            if now - os.path.getmtime(other) > STALE_AFTER_S:
                os.remove(other)
        except OSError:
            pass  # another process removed it first


def _uncommitted(a):
    if jax.dtypes.issubdtype(a.dtype, jax.dtypes.prng_key):
        return a  # no host form; keys are not computed on
    return jax.device_put(np.asarray(a))


def cached_jit(fn: Callable | None = None, *, name: str | None = None,
               compiler_options: Callable[[], tuple] | None = None):
    """Wrap a jitted ``fn`` (``jax.jit`` or ``equinox.filter_jit``) whose array arguments
    are traced and whose other arguments are static, and whose result is an array or a
    tuple of arrays: see the module docstring.  ``compiler_options()`` gives the XLA
    options the stored program is compiled with (those ``fn`` itself uses)."""
    if fn is None:
        return functools.partial(cached_jit, name=name, compiler_options=compiler_options)
    label = name or f"{fn.__module__}.{getattr(fn, '__qualname__', repr(fn))}"

    @functools.wraps(fn)
    def wrapper(*args):
        if _directory is None:
            return fn(*args)
        dynamic, static = eqx.partition(args, eqx.is_array)
        leaves, treedef = jax.tree.flatten(dynamic)
        if any(isinstance(x, jax.core.Tracer) for x in leaves):
            # inside a transformation (vmap, grad, an outer jit): a stored program has
            # no batching or differentiation rules, and the outer trace is not cached
            return fn(*args)
        static_leaves, static_def = jax.tree.flatten(static)
        options = tuple(compiler_options()) if compiler_options is not None else ()
        key = _key(label, leaves, treedef, static_leaves, static_def, options)
        if key is None:
            return fn(*args)
        program = _programs.get(key)
        if program is None:
            # the sources' fingerprint in the name lets a new version clear out the old
            path = os.path.join(_directory, f"{label}-{_fingerprint()[:12]}-{key[:32]}{SUFFIX}")
            exported = _read(path)
            if exported is not None:
                program = jax.jit(exported.call, compiler_options=dict(options) or None)
                try:
                    out = program(*leaves)
                except Exception:  # noqa: BLE001  (a stored program this JAX cannot run)
                    exported = None
                else:
                    _programs[key] = program
                    return jax.tree.map(_uncommitted, out)
            if exported is None:

                def flat(*xs):
                    return fn(*eqx.combine(jax.tree.unflatten(treedef, xs), static))

                from jax import export as jax_export

                exported = jax_export.export(jax.jit(flat))(*leaves)
                _write(path, exported)
            program = jax.jit(exported.call, compiler_options=dict(options) or None)
            _programs[key] = program
        # A stored program returns arrays committed to its device, where a plain jitted
        # call returns uncommitted ones; JAX compiles each later operation separately for
        # the two, so hand back uncommitted copies (a host round trip of small results).
        return jax.tree.map(_uncommitted, program(*leaves))

    wrapper.uncached = fn
    return wrapper
