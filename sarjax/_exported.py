"""Compiled simulation programs kept on disk between processes.

XLA's persistent cache (:mod:`sarjax._compilation_cache`) skips the compilation of a
program a later process lowers again, but not the Python work before it: tracing the
simulator to a jaxpr and lowering it (2–3 s for a Fourier-domain method). Here the whole
compiled program of a jitted call is kept (the simulation, ``_simulate._run``, and the
eager programs of the budget checks decorated with :func:`cached`): the first call
traces, lowers and compiles it as usual, then serialises the executable under a key of
everything that determines it; a later process with the same key loads it and runs it
without tracing.

**Key** (a SHA-256 of a canonical text): the function's module and name; the sarjax
source (a digest of every ``.py`` and ``.cc`` file of the package, so an edited checkout never loads
an older program); the versions of Python, jax, jaxlib, equinox and NumPy; the backend,
its platform version, the devices, the CPU model and flags and ``$XLA_FLAGS``; the jax
options that change a trace (x64, rank and dtype promotion, matmul precision, the
default device); and the call's static arguments by value (the simulator and its
options, the plan, the call plan with its devices, the dtype, the method name: every
field that is not an array, recursively, NumPy arrays by their bytes) with the shape,
dtype, weak type and placement of each array argument. The array values themselves are
not part of the key: they are the program's inputs. A static argument the key cannot
spell out (an object with no canonical form, e.g. a lambda) is not cached: that call
runs the ordinary ``jit`` path.

**Entries** are files ``<folder>/<function>-<key>.bin``: a header naming the key and the
SHA-256 of the body, the serialised executable and the output's static part. A file is
written to a temporary name and renamed into place (:func:`sarjax._files.atomic_write`),
so processes writing the same entry at once leave one whole file; one that does not
match its key or checksum, or fails to load, is ignored and written anew. A cached
entry is trusted as the folder is: it holds compiled code, like XLA's own cache.
"""

from __future__ import annotations

import collections
import dataclasses
import enum
import functools
import hashlib
import importlib
import json
import logging
import os
import pickle
import platform
import sys
import threading
import types
from pathlib import Path

import equinox as eqx
import jax
import numpy as np

from ._files import atomic_write

logger = logging.getLogger(__name__)

FORMAT = b"sarjax-program 1\n"  # the first line of every entry
SUFFIX = ".bin"
_MEMORY_ENTRIES = 32  # programs kept loaded in this process (least recently used dropped)
# jax options read while tracing: a program traced under other values is another program
_CONFIG = ("jax_enable_x64", "jax_numpy_rank_promotion", "jax_numpy_dtype_promotion",
           "jax_default_matmul_precision", "jax_default_device", "jax_threefry_partitionable",
           "jax_enable_checks", "jax_debug_nans", "jax_debug_infs", "jax_disable_jit")

# what writing an entry may raise (the disk, pickling the output's static part, XLA), and
# what reading a damaged or foreign one may (its header, its pickle, XLA)
_NOT_KEPT = (OSError, RuntimeError, ValueError, TypeError, AttributeError, pickle.PicklingError)
_DAMAGED = (OSError, RuntimeError, ValueError, TypeError, KeyError, IndexError, EOFError,
            AttributeError, ImportError, pickle.UnpicklingError)

_folder: Path | None = None
_loaded: collections.OrderedDict = collections.OrderedDict()
_loaded_lock = threading.Lock()
_compile_lock = threading.RLock()  # re-entered where a program traced under it calls another


def set_folder(folder) -> Path | None:
    """Keep programs in ``folder`` (created when needed); None turns the cache off."""
    global _folder
    _folder = None if folder is None else Path(folder)
    _loaded.clear()
    return _folder


def folder() -> Path | None:
    """The folder in use, or None when programs are not kept."""
    return _folder


def persistent(fn):
    """``fn`` (an ``eqx.filter_jit`` function), its compiled programs kept in
    :func:`folder`; ``fn`` itself when no folder is set."""
    if _folder is None:
        return fn
    return functools.partial(_call, fn)


def cached(fn):
    """Decorator: ``fn`` (an ``eqx.filter_jit`` function) through :func:`persistent` on
    each call, so its programs are kept while a folder is set (positional calls)."""

    @functools.wraps(fn, updated=())
    def call(*args, **kwargs):
        return persistent(fn)(*args) if not kwargs else fn(*args, **kwargs)

    return call


class Unkeyable(TypeError):
    """A static argument without a canonical form: the call is not cached."""


@dataclasses.dataclass(frozen=True)
class _Slot:
    """Position of an output array in the pickled output template."""

    index: int


def _call(fn, *args):
    if jax.process_count() > 1 or jax.config.jax_disable_jit:
        return fn(*args)
    dynamic, static = eqx.partition(args, eqx.is_array)
    leaves, in_tree = jax.tree_util.tree_flatten(dynamic)
    if any(isinstance(x, jax.core.Tracer) for x in leaves):  # inside jit, grad, vmap
        return fn(*args)
    try:
        key = _key(fn, static, leaves, in_tree)
    except Unkeyable as err:
        logger.debug("not cached: %s", err)
        return fn(*args)
    entry = _loaded.get(key)
    if entry is None:
        entry = _load(fn, key, len(leaves))
        if entry is not None:
            outputs = _first_run(entry[0], leaves, fn, key)
            if outputs is not None:
                return _remember(key, entry, outputs)
            entry = None
    if entry is None:
        # one thread compiles at a time: the test for an executable from XLA's cache
        # counts the cache's hits, and compiling past the cache turns it off for the
        # process meanwhile (a call's checks compile their own programs in a worker
        # thread beside the simulation's: interleaved, one thread's compile could take
        # the other's hit for its own, or find the cache turned back on half-way, and
        # keep a program that misses functions); a call from another thread may have
        # compiled it meanwhile
        with _compile_lock:
            entry = _loaded.get(key)
            if entry is None:
                entry = _compile(fn, static, leaves, in_tree)
                if entry[0] is None:  # cannot be kept
                    return fn(*args)
                _store(fn, key, entry)
                _keep(key, entry)
    return _remember(key, entry, entry[0](*leaves))


def _keep(key, entry):
    """Keep ``entry`` loaded (the least recently used beyond a few dropped)."""
    with _loaded_lock:  # calls from several threads (a simulation and its checks)
        _loaded[key] = entry
        _loaded.move_to_end(key)
        while len(_loaded) > _MEMORY_ENTRIES:
            _loaded.popitem(last=False)


def _remember(key, entry, outputs):
    """Keep ``entry`` loaded (:func:`_keep`); the call's result from the program's
    ``outputs``."""
    _keep(key, entry)
    return jax.tree_util.tree_map(lambda slot: outputs[slot.index], entry[1],
                                  is_leaf=lambda x: isinstance(x, _Slot))


def _first_run(compiled, leaves, fn, key):
    """The outputs of a program read from disk, waited for: None, and the entry removed,
    when it fails to run (a program that loads but does not run is not trusted)."""
    try:
        return jax.block_until_ready(compiled(*leaves))
    except (RuntimeError, ValueError) as err:  # jax.errors.JaxRuntimeError: a missing function
        logger.warning("ignoring cache entry %s: it does not run: %s", _path(fn, key), err)
        _path(fn, key).unlink(missing_ok=True)
        return None


def _compile(fn, static, leaves, in_tree):
    """Trace, lower and compile ``fn`` on the flat array arguments (XLA's persistent
    cache applies); the executable and the output template. Under ``_compile_lock``
    (:func:`_call`)."""
    body = getattr(fn, "__wrapped__", fn)  # the Python function under eqx.filter_jit
    template = []

    def flat(*arrays):
        out = body(*eqx.combine(jax.tree_util.tree_unflatten(in_tree, arrays), static))
        out_dynamic, out_static = eqx.partition(out, eqx.is_array)
        out_leaves, out_tree = jax.tree_util.tree_flatten(out_dynamic)
        slots = jax.tree_util.tree_unflatten(out_tree, map(_Slot, range(len(out_leaves))))
        template.append(eqx.combine(slots, out_static))
        return out_leaves

    flat.__name__ = flat.__qualname__ = getattr(body, "__name__", "program")
    lowered = jax.jit(flat).lower(*leaves)
    hits = _xla_cache_hits()
    compiled = lowered.compile()
    if _xla_cache_hits() > hits:
        # XLA's cache held it: an executable loaded from there does not serialise whole
        # (run after a reload, it misses its functions), so compile it afresh to keep it
        # (a new function: jax would return the same executable for the same one)
        again = functools.wraps(flat)(lambda *arrays: flat(*arrays))
        compiled = _compile_afresh(lambda: jax.jit(again).lower(*leaves))
    return compiled, template[0]


_hits = [0]


def _count_hits(event, **_):
    if event == "/jax/compilation_cache/cache_hits":
        _hits[0] += 1


@functools.cache
def _listen():
    jax.monitoring.register_event_listener(_count_hits)


def _xla_cache_hits() -> int:
    """Executables loaded from XLA's persistent cache in this process so far."""
    _listen()
    return _hits[0]


def _compile_afresh(lower):
    """``lower().compile()`` past XLA's persistent cache; None where this jax offers no way
    (the program is then run, not kept)."""
    try:
        from jax._src import compilation_cache as xla_cache

        lock, state = xla_cache._cache_initialized_mutex, ("_cache_checked", "_cache_used")
        with lock:
            kept = [getattr(xla_cache, name) for name in state]
            xla_cache._cache_checked, xla_cache._cache_used = True, False
    except (ImportError, AttributeError):
        return None
    try:
        return lower().compile()
    finally:
        with lock:
            xla_cache._cache_checked, xla_cache._cache_used = kept


def _path(fn, key) -> Path:
    return _folder / f"{getattr(fn, '__name__', 'program').lstrip('_')}-{key}{SUFFIX}"


def _store(fn, key, entry):
    """Write an entry (temporary name, then renamed); a failure only loses the entry."""
    from jax.experimental.serialize_executable import serialize

    compiled, template = entry
    try:
        program, _, _ = serialize(compiled)
        outputs = pickle.dumps(template, protocol=pickle.HIGHEST_PROTOCOL)
        header = json.dumps({"key": key, "sha256": hashlib.sha256(program + outputs).hexdigest(),
                             "program": len(program), "outputs": len(outputs)})
        _folder.mkdir(parents=True, exist_ok=True)
        atomic_write(_path(fn, key),
                     lambda tmp: tmp.write_bytes(FORMAT + header.encode() + b"\n" + program
                                                 + outputs), overwrite=True)
    except _NOT_KEPT as err:  # a full disk, a read-only folder, a program XLA cannot save
        logger.warning("compiled program not kept in %s: %s", _folder, err)


def _load(fn, key, num_inputs):
    """The entry of ``key`` (executable, output template), or None when there is none or it
    is not whole: a wrong format, key, length or checksum, or an executable that does not
    load."""
    from jax.experimental.serialize_executable import deserialize_and_load

    path = _path(fn, key)
    try:
        blob = path.read_bytes()
    except OSError:
        return None
    try:
        if not blob.startswith(FORMAT):
            raise ValueError("not a program file")
        line_end = blob.index(b"\n", len(FORMAT))
        header = json.loads(blob[len(FORMAT):line_end])
        body = blob[line_end + 1:]
        if header["key"] != key or len(body) != header["program"] + header["outputs"]:
            raise ValueError("another key or a truncated file")
        if hashlib.sha256(body).hexdigest() != header["sha256"]:
            raise ValueError("checksum mismatch")
        program, outputs = body[:header["program"]], body[header["program"]:]
        template = pickle.loads(outputs)
        in_tree = jax.tree_util.tree_structure(((0,) * num_inputs, {}))
        num_outputs = len(jax.tree_util.tree_leaves(
            template, is_leaf=lambda x: isinstance(x, _Slot)))
        out_tree = jax.tree_util.tree_structure([0] * num_outputs)
        compiled = deserialize_and_load(program, in_tree, out_tree)
    except _DAMAGED as err:  # anything unexpected in the file: compile afresh
        logger.warning("ignoring cache entry %s: %s", path, err)
        return None
    return compiled, template


# ---- the key ---------------------------------------------------------------------------


def _key(fn, static, leaves, in_tree) -> str:
    parts = [
        FORMAT.decode().strip(),
        f"function {_name(getattr(fn, '__wrapped__', fn))}",
        f"environment {_environment()}",
        f"config {_encode({name: getattr(jax.config, name) for name in _CONFIG})}",
        f"inputs {_encode_tree(in_tree)}",
        f"arrays {_encode([_array(x) for x in leaves])}",
        f"static {_encode_tree(jax.tree_util.tree_structure(static))}",
        f"static values {_encode(jax.tree_util.tree_leaves(static))}",
    ]
    return hashlib.sha256("\n".join(parts).encode()).hexdigest()


@functools.cache
def _environment() -> str:
    """Versions, backend, devices, CPU and the sarjax source: fixed for a process."""
    from importlib.metadata import version

    return _encode({
        "python": sys.version,
        "versions": {name: version(name) for name in ("jax", "jaxlib", "equinox", "numpy")},
        "backend": jax.default_backend(),
        "platform_version": jax.devices()[0].client.platform_version,
        "devices": [_device(d) for d in jax.devices()],
        "machine": (platform.machine(), platform.processor(), _cpu()),
        "xla_flags": os.environ.get("XLA_FLAGS", ""),
        "sarjax": _source_digest(),
    })


def _cpu() -> str:
    """SHA-256 of the CPU's model and instruction-set flags (Linux), else empty."""
    try:
        lines = Path("/proc/cpuinfo").read_text().splitlines()
    except OSError:
        return ""
    wanted = sorted({line for line in lines if line.startswith(("model name", "flags"))})
    return hashlib.sha256("\n".join(wanted).encode()).hexdigest()


def _source_digest(root=None) -> str:
    """SHA-256 of every ``.py`` file and native kernel source (``.cc``) of the package
    (or of the folder ``root``), by relative path."""
    root = Path(root) if root is not None else Path(__file__).resolve().parent
    digest = hashlib.sha256()
    for path in sorted([*root.rglob("*.py"), *root.rglob("*.cc")]):
        digest.update(str(path.relative_to(root)).encode() + b"\0" + path.read_bytes())
    return digest.hexdigest()


def _device(d) -> tuple:
    return ("device", d.platform, d.id, d.device_kind, d.process_index)


def _array(x) -> tuple:
    sharding = getattr(x, "sharding", None)
    placed = ((_encode(tuple(sorted(d.id for d in sharding.device_set))), str(sharding))
              if sharding is not None and getattr(x, "_committed", False) else None)
    return ("array", tuple(np.shape(x)), np.dtype(x.dtype).str,
            bool(getattr(x, "weak_type", False)), placed)


def _encode_tree(treedef) -> str:
    """A treedef with its node types and auxiliary data spelled out."""
    if treedef.num_nodes == 1 and treedef.num_leaves == 1:
        return "*"
    node_type, aux = treedef.node_data()
    children = ",".join(_encode_tree(child) for child in treedef.children())
    return f"{_name(node_type)}[{_encode(aux)}]({children})"


def _name(obj) -> str:
    """``module.qualname`` of a class or function importable under that name."""
    module, qualname = getattr(obj, "__module__", None), getattr(obj, "__qualname__", None)
    if not module or not qualname or "<" in qualname:
        raise Unkeyable(f"{obj!r} has no importable name")
    if module == "builtins":  # NoneType, int, ...: their names are enough
        return qualname
    found = sys.modules.get(module) or importlib.import_module(module)
    for part in qualname.split("."):
        found = getattr(found, part, None)
    while found is not obj and hasattr(found, "__wrapped__"):  # under decorators
        found = found.__wrapped__
    if found is not obj:
        raise Unkeyable(f"{module}.{qualname} is not {obj!r}")
    return f"{module}.{qualname}"


def _encode(value) -> str:
    """A canonical text of a static value: equal texts for equal values, in every process."""
    if value is None or isinstance(value, (bool, int, float, complex, str, bytes)):
        return f"{type(value).__name__}:{value!r}"
    if isinstance(value, np.dtype):
        return f"dtype:{value.str}"
    if isinstance(value, type):
        if issubclass(value, np.generic):
            return f"dtype:{np.dtype(value).str}"
        return f"type:{_name(value)}"
    if isinstance(value, enum.Enum):
        return f"enum:{_name(type(value))}.{value.name}"
    if isinstance(value, (np.ndarray, np.generic)):
        data = np.ascontiguousarray(value)
        if data.dtype.hasobject:
            raise Unkeyable("an object array")
        return (f"ndarray:{data.dtype.str}{data.shape}:"
                f"{hashlib.sha256(data.tobytes()).hexdigest()}")
    if isinstance(value, (tuple, list)):
        kind = type(value).__name__ if type(value) in (tuple, list) else _name(type(value))
        return f"{kind}(" + ",".join(_encode(v) for v in value) + ")"
    if isinstance(value, dict):
        return "dict(" + ",".join(sorted(f"{_encode(k)}={_encode(v)}"
                                         for k, v in value.items())) + ")"
    if isinstance(value, (set, frozenset)):
        return f"{type(value).__name__}(" + ",".join(sorted(map(_encode, value))) + ")"
    if isinstance(value, jax.Device):
        return _encode(_device(value))
    if isinstance(value, (types.FunctionType, types.BuiltinFunctionType)):
        return f"function:{_name(value)}"
    if dataclasses.is_dataclass(value):  # a frozen dataclass or an eqx.Module
        fields = {f.name: getattr(value, f.name) for f in dataclasses.fields(value)}
        return f"{_name(type(value))}{_encode(fields)}"
    if isinstance(value, functools.partial):
        return f"partial({_encode(value.func)},{_encode(value.args)},{_encode(value.keywords)})"
    if not getattr(value, "__dict__", None) and not getattr(type(value), "__slots__", ()):
        return f"object:{_name(type(value))}"  # a stateless marker (equinox's MISSING)
    raise Unkeyable(f"no canonical form for a {type(value).__name__}")
