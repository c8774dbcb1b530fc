"""Compiled forms derived from a source form by symbolic work in Python, remembered on disk
(problem layer utility).

Some forms are not written by hand but derived from another: the 1D model's mode forms C_0..C_4
are the mode Hessian differentiated k times in m by ``ufl.derivative``, its derivatives expanded
and m replaced by 0 (``shells.axisym.modes``); both models' dR/dκ is R(κ=1) - R(κ=0), whose
``ufl.replace`` expands R's derivatives (``shells.problem.forms``). FFCx finds a compiled form in
its cache by the form's signature, but only after that UFL work is done: a noticeable share of
a short 1D run, paid again in every run of a phase diagram, for kernels that were compiled long
ago (docs/design-notes.md, "Form cache"). ``compiled_derived`` remembers, under a key made of
the source form's signature and a tag naming the derivation, which compiled modules the derived
forms were, and where their coefficients and constants sit among the source form's: a later
call with the same key loads those modules and binds the source's own coefficients, with no UFL
work at all.

The forms are the same compiled kernels bound to the same objects, so everything computed
with them is identical to the last bit (tests/test_formcache.py). The key holds everything
that decides the kernels: the source's UFL signature (its whole expression: elements,
quadrature degree, every number written into it), the caller's tag (the derivation's own
source code), the versions of UFL, FFCx, basix and dolfinx, and the compiler options. A record
whose modules cannot be loaded is ignored and written again. ``SHELLS_FORM_CACHE=0`` turns the
cache off (the forms are then derived every time). In parallel the forms come from the
records only where every rank of the mesh's communicator has them (compiling is collective).

Processes that run at once share these folders and FFCx's: a record is written whole (a
temporary file renamed into place), and a process that finds a form being compiled by another
waits for it up to ``JIT_TIMEOUT`` (``_wait_for_other_compiles``).
"""

from __future__ import annotations

import hashlib
import importlib.util
import json
import logging
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

from shells.files import write_atomic

__all__ = ["compiled_derived", "cache_folder", "cache_root", "file_tag"]


def _cmp_constant(a: Any, b: Any) -> int:
    """UFL's order of two Constants, as its ``_cmp_terminal_by_repr`` (repr(a) against
    repr(b)), but with their counts, the reprs' last numbers, compared as numbers. UFL sorts the
    operands of sums and products canonically, and compares Constants by their reprs as
    strings, so "..., 100)" sorts before "..., 99)": a form whose Constants' counts straddle a
    power of ten (they grow through a process) gets another operand order, another expression
    and so another signature than the same form built elsewhere, and its record is not found
    (docs/design-notes.md, "Form cache"). Counts of the same number of digits compare as in
    UFL's own order: only those orders change."""
    x, y = repr(a), repr(b)
    if x == y:
        return 0
    (px, cx), (py, cy) = x.rsplit(", ", 1), y.rsplit(", ", 1)
    if px == py and cx[:-1].isdigit() and cy[:-1].isdigit():
        nx, ny = int(cx[:-1]), int(cy[:-1])
        return -1 if nx < ny else (0 if nx == ny else 1)
    return -1 if x < y else 1


def _order_constants_by_count() -> None:
    """Install ``_cmp_constant`` as UFL's comparison of Constants (once, where UFL has none of
    its own for them)."""
    try:
        import ufl.sorting
        from ufl.constant import Constant
    except ImportError:  # pragma: no cover - UFL is a dependency
        return
    cmps = getattr(ufl.sorting, "_terminal_cmps", None)
    if isinstance(cmps, dict):
        cmps.setdefault(Constant._ufl_typecode_, _cmp_constant)


_order_constants_by_count()

#: seconds a process waits for a form that another process is compiling (FFCx's cache: the
#: module's .c file made, its .c.cached marker not yet): as long as the longest compile
JIT_TIMEOUT = 300


def _wait_for_other_compiles() -> None:
    """Raise dolfinx's default JIT timeout, where it is shorter, to ``JIT_TIMEOUT`` (a user's
    dolfinx_jit_options.json still takes precedence; forms compiled with their own
    ``jit_options`` keep theirs). dolfinx's 10 s is shorter than a surface model's form takes to
    compile: of two runs started at once with an empty cache, the one that waited for the
    other's compile failed with FFCx's TimeoutError."""
    try:
        from dolfinx import jit
    except ImportError:  # pragma: no cover - dolfinx is a dependency
        return
    defaults = getattr(jit, "DOLFINX_DEFAULT_JIT_OPTIONS", None)
    if isinstance(defaults, dict):
        value, doc = defaults.get("timeout", (None, ""))
        if isinstance(value, int | float) and value < JIT_TIMEOUT:
            defaults["timeout"] = (JIT_TIMEOUT, doc)


_wait_for_other_compiles()

log = logging.getLogger("shells")

_MODULES: dict[str, Any] = {}  # the compiled modules loaded in this process, by file


def cache_root() -> Path:
    """The package's cache folder, ``$XDG_CACHE_HOME/shells`` (default ``~/.cache``): the
    compiled C loop and the 1D model's FFCx modules live there too."""
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "shells"


def cache_folder() -> Path:
    """Where the records go: ``cache_root() / "derived"``."""
    return cache_root() / "derived"


def file_tag(path: str | os.PathLike) -> str:
    """A tag naming a derivation by the source file that holds it (``compiled_derived``'s
    ``tag``): any change of the file derives the forms again.

    Args:
        path: the source file.

    Returns:
        A hash of the file's contents (16 hex digits).
    """
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()[:16]


def _enabled() -> bool:
    return os.environ.get("SHELLS_FORM_CACHE", "1") != "0"


def record_key(source: Any, tag: str, jit_options: dict[str, Any] | None,
               extra: tuple[Any, ...] = (), spaces: tuple[Any, ...] | None = None) -> str:
    """The record's key of a derivation: the source form's signature, the derivation's
    ``tag``, the versions of UFL, FFCx, basix and dolfinx, the JIT options and the extra
    coefficients' and spaces' descriptions, hashed."""
    import basix
    import dolfinx
    import ffcx
    import ufl

    parts = [source.signature(), tag, ufl.__version__, ffcx.__version__, basix.__version__,
             dolfinx.__version__, repr(sorted((jit_options or {}).items())),
             repr(dolfinx.default_scalar_type)]
    parts += [repr(c.ufl_element()) for c in extra]  # the extra coefficients' elements
    if spaces is not None:  # the derived forms' own argument spaces
        parts += ["spaces"] + [repr(V.ufl_element()) for V in spaces]
    return hashlib.sha256("\n".join(parts).encode()).hexdigest()[:24]


def _positions(items: list[Any], pool: list[Any]) -> list[int] | None:
    """Where each of ``items`` sits in ``pool`` (by identity); None if one is not there."""
    out = []
    for x in items:
        found = [i for i, y in enumerate(pool) if y is x]
        if not found:
            return None
        out.append(found[0])
    return out


def _record(forms: list[Any], ufl_forms: list[Any], source: Any,
            extra: tuple[Any, ...] = (), spaces: tuple[Any, ...] | None = None
            ) -> list[dict] | None:
    """What a later call needs to rebuild ``forms``; None where they cannot be rebuilt from
    the source's coefficients and ``extra`` alone (a coefficient of their own, an integral
    other than one cell integral over the whole mesh, arguments other than the source's
    first ones, or than arguments in ``spaces`` where given)."""
    from dolfinx.fem import IntegralType

    coefficients, constants = [*source.coefficients(), *extra], source.constants()
    sources = source.arguments()
    out = []
    for f, u in zip(forms, ufl_forms, strict=True):
        if set(f.integral_types) != {IntegralType.cell} or any(
                i.subdomain_data() is not None or i.subdomain_id() != "everywhere"
                for i in u.integrals()):
            return None
        args = u.arguments()
        if spaces is None and tuple(args) != tuple(sources[: len(args)]):
            return None
        if spaces is not None and (len(args) > len(spaces) or any(
                a.number() != i or a.ufl_function_space() is not spaces[i]
                for i, a in enumerate(args))):
            return None
        cpos, kpos = _positions(u.coefficients(), coefficients), \
            _positions(u.constants(), constants)
        module = getattr(f.module, "__file__", None)
        names = [n for n in dir(f.module.lib) if n.startswith("form_")]
        if cpos is None or kpos is None or module is None or len(names) != 1:
            return None
        out.append({"module": module, "name": f.module.__name__, "form": names[0],
                    "coefficients": cpos, "constants": kpos, "rank": len(args)})
    return out


def _load(entry: dict) -> Any:
    path = entry["module"]
    if path not in _MODULES:
        spec = importlib.util.spec_from_file_location(entry["name"], path)
        if spec is None or spec.loader is None:
            raise ImportError(path)
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        _MODULES[path] = module
    return _MODULES[path]


def _rebuild(records: list[dict], source: Any, extra: tuple[Any, ...] = (),
             spaces: tuple[Any, ...] | None = None
             ) -> tuple[list[Any], list[tuple[list, list]]]:
    """The forms of ``records``, bound to the source's coefficients (and ``extra``) and
    constants, as ``dolfinx.fem.form`` binds them, on the source's argument spaces (or
    ``spaces``); with each form's (coefficients, constants)."""
    import dolfinx
    from dolfinx.fem import IntegralType
    from dolfinx.fem.forms import Form, form_cpp_class

    coefficients, constants = [*source.coefficients(), *extra], source.constants()
    spaces = [V._cpp_object for V in (spaces if spaces is not None else
                                      [a.ufl_function_space() for a in source.arguments()])]
    mesh = source.ufl_domain().ufl_cargo()
    ftype = form_cpp_class(dolfinx.default_scalar_type)
    forms, reads = [], []
    for entry in records:
        module = _load(entry)
        ufcx_form = getattr(module.lib, entry["form"])
        own = [coefficients[i] for i in entry["coefficients"]]
        consts = [constants[i] for i in entry["constants"]]
        rank = int(entry.get("rank", len(spaces)))
        if ufcx_form.num_coefficients > len(own) or ufcx_form.num_constants != len(consts) \
                or ufcx_form.rank != rank or rank > len(spaces):
            raise ValueError("a record that does not match its module")
        bound = [own[ufcx_form.original_coefficient_positions[i]]._cpp_object
                 for i in range(ufcx_form.num_coefficients)]
        f = ftype(module.ffi.cast("uintptr_t", module.ffi.addressof(ufcx_form)), spaces[:rank],
                  bound, [k._cpp_object for k in consts], {IntegralType.cell: []}, {}, mesh)
        forms.append(Form(f, ufcx_form, None, module))
        reads.append((own, consts))
    return forms, reads


def compiled_derived(source: Any, tag: str, derive: Callable[[], list[Any]],
                     jit_options: dict[str, Any] | None = None,
                     extra: tuple[Any, ...] = (), spaces: tuple[Any, ...] | None = None
                     ) -> tuple[list[Any], list[tuple[list, list]]]:
    """The compiled forms of ``derive()``, from the record of an earlier call where there is one.

    Otherwise they are derived, compiled (``dolfinx.fem.form``) and recorded. Collective on
    the mesh's communicator: the forms come from the records only where every rank has them.

    Args:
        source: the UFL form the others derive from.
        tag: names the derivation; it must change whenever the derivation does (the
            caller's source code, say): the record is found by the source's signature, the
            tag and the elements of ``extra`` alone.
        derive: returns the derived UFL forms: on the source's first arguments (all, or
            fewer: a functional ``action(action(a, f), f)``), or on arguments in ``spaces``,
            with coefficients among the source's own and ``extra``, constants among its own.
        jit_options: FFCx options of the compilation (part of the key).
        extra: coefficients the derived forms may read beyond the source's.
        spaces: the function spaces of the derived forms' arguments (of the same mesh: a
            form on a product of the source's spaces, say); None: the source's.

    Returns:
        (the compiled forms, each one's (coefficients, constants) that it reads).
    """
    from dolfinx import fem

    comm = source.ufl_domain().ufl_cargo().comm
    extra = tuple(extra)
    spaces = tuple(spaces) if spaces is not None else None
    path = (cache_folder() / f"{record_key(source, tag, jit_options, extra, spaces)}.json"
            if _enabled() else None)
    found = None
    if path is not None and path.is_file():
        try:
            found = _rebuild(json.loads(path.read_text()), source, extra, spaces)
        except (OSError, ValueError, KeyError, TypeError, AttributeError, ImportError) as e:
            log.debug("form cache record %s not usable (%s): derived again", path, e)
    if comm.size > 1:
        from mpi4py import MPI

        # every rank alike: compiling a form is collective (dolfinx's JIT waits for rank 0),
        # and one rank may find a record that another does not (yet)
        if not comm.allreduce(found is not None, op=MPI.LAND):
            found = None
    if found is not None:
        return found
    ufl_forms = derive()
    forms = [fem.form(u, jit_options=jit_options) for u in ufl_forms]
    reads = [(list(u.coefficients()), list(u.constants())) for u in ufl_forms]
    if path is not None and comm.rank == 0:
        records = _record(forms, ufl_forms, source, extra, spaces)
        if records is not None:
            try:
                path.parent.mkdir(parents=True, exist_ok=True)
                write_atomic(path, json.dumps(records))  # a reader sees all of it or nothing
            except OSError as e:
                log.debug("form cache record %s not written: %s", path, e)
    return forms, reads
