"""The I/O-validation layer: every file or folder path a user gives is checked here first.

The command line (``shells.cli``) calls these checks for every path argument (mesh and parameter
files read, ``-o`` files and folders, ``--png``) before any work starts, so a bad path is one
``InputError`` (one line on stderr, exit status 2), never a traceback after minutes of computing.

Two kinds of check:

* **Shared with the host.** ``scripts/in-env`` runs commands in a chroot whose OS tree (``/usr``,
  ``/etc``, ``/var``, ``/opt``, ...) is the environment's own; only some host directories are
  bound into it at the same path (the host's ``/tmp``, ``$HOME``, the current directory, the
  repository, non-system top-level directories such as ``/home`` or ``/work``). It lists them,
  colon-separated, in the environment variable ``SHELLS_HOST_PATHS`` (the Docker image's
  entrypoint does the same from its mounts). A path that resolves outside all of them is inside
  the environment's private root: a file written there never appears on the host and a file read
  there is not the host's, so it is refused. Without ``SHELLS_HOST_PATHS`` (a native install)
  this check does nothing; set but empty means nothing is shared.
* **Usable** (checked second, so nothing is probed in the private root). An output folder must
  be a writable folder or creatable (its nearest existing ancestor is a folder in which a folder
  can be made); an output file must not be a folder and its folder must be usable likewise. The
  probe is a temporary entry removed at once: nothing the command would write is created here.

The functions are plain (no MPI): the CLI runs them on rank 0 and broadcasts the verdict.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Mapping
from pathlib import Path

from shells.errors import InputError

__all__ = ["HOST_PATHS_VAR", "host_prefixes", "check_shared", "check_input_file",
           "check_output_file", "check_output_dir"]

#: Environment variable listing the directories shared with the host (colon-separated).
HOST_PATHS_VAR = "SHELLS_HOST_PATHS"


def _text(path: str | os.PathLike[str], what: str) -> str:
    """The path as a string a file system call accepts, or an InputError."""
    p = os.fspath(path)
    if not isinstance(p, str) or p == "":
        raise InputError(f"{what} must be a non-empty path, got {p!r}")
    if "\0" in p:
        raise InputError(f"{what} {p!r} is not a valid path (it contains a NUL character)")
    try:
        os.fsencode(p)
    except UnicodeError:
        raise InputError(f"{what} {p!r} is not a valid path (not encodable)") from None
    return p


def host_prefixes(environ: Mapping[str, str] | None = None) -> tuple[str, ...] | None:
    """The resolved directories shared with the host (see the module docstring).

    Args:
        environ: the environment to read the list from (default ``os.environ``).

    Returns:
        The resolved prefixes, or None when no list is set (no check).
    """
    env = os.environ if environ is None else environ
    value = env.get(HOST_PATHS_VAR)
    if value is None:
        return None
    out: list[str] = []
    for item in value.split(":"):
        if item.startswith("/"):
            real = os.path.realpath(item)
            if real not in out:
                out.append(real)
    return tuple(out)


def _under(path: str, prefix: str) -> bool:
    return prefix == "/" or path == prefix or path.startswith(prefix.rstrip("/") + "/")


def check_shared(path: str | os.PathLike[str], what: str,
                 environ: Mapping[str, str] | None = None) -> Path:
    """Refuse a path that resolves inside the environment's private root (module docstring).

    Args:
        path: the path (relative paths are taken from the current folder).
        what: what it is, for messages (e.g. "--output").
        environ: as for ``host_prefixes``.

    Returns:
        The path as given.

    Raises:
        InputError: if it is not shared with the host, or not a valid path.
    """
    p = _text(path, what)
    prefixes = host_prefixes(environ)
    if prefixes is None:
        return Path(p)
    real = os.path.realpath(os.path.abspath(p))
    if any(_under(real, q) for q in prefixes):
        return Path(p)
    shown = repr(p) if real == p else f"{p!r} (= {real})"
    where = (f"use a path under {', '.join(prefixes)}" if prefixes else
             "no host folder is shared (Docker: docker run -v \"$PWD:$PWD\" -w \"$PWD\" ...)")
    raise InputError(f"{what} {shown} is inside the environment's private root, not on the host; "
                     f"{where}")


def check_input_file(path: str | os.PathLike[str], what: str) -> Path:
    """Check an input file: shared with the host.

    Existence and format are checked by its reader, which says what is wrong with it.

    Args:
        path: the file.
        what: what it is, for messages.

    Returns:
        The path.

    Raises:
        InputError: as ``check_shared``.
    """
    return check_shared(path, what)


def _nearest_existing(p: Path) -> Path:
    q = p.absolute()
    while not q.exists() and q != q.parent:
        q = q.parent
    return q


def _probe(folder: Path, what: str, shown: str, make_dir: bool) -> None:
    """Create and remove a temporary file (or folder) in ``folder``: proves it is writable."""
    try:
        if make_dir:
            os.rmdir(tempfile.mkdtemp(prefix=".shells-write-test-", dir=folder))
        else:
            fd, name = tempfile.mkstemp(prefix=".shells-write-test-", dir=folder)
            os.close(fd)
            os.unlink(name)
    except OSError as e:
        made = "a folder" if make_dir else "a file"
        raise InputError(f"{what} {shown} cannot be written: {made} cannot be made in "
                         f"{str(folder)!r} ({e.strerror or e})") from None


def _usable_folder(folder: Path, what: str, shown: str) -> None:
    """``folder`` is a writable folder, or can be created (its nearest existing ancestor is a
    folder in which a folder can be made)."""
    try:
        if folder.exists():
            if not folder.is_dir():
                raise InputError(f"{what} {shown}: {str(folder)!r} exists and is not a folder")
            _probe(folder, what, shown, make_dir=False)
        else:
            anc = _nearest_existing(folder)
            if not anc.is_dir():
                raise InputError(f"{what} {shown} cannot be created: {str(anc)!r} is not a folder")
            _probe(anc, what, shown, make_dir=True)
    except OSError as e:  # e.g. a name too long for the file system
        raise InputError(f"{what} {shown} is not usable: {e.strerror or e}") from None


def check_output_dir(path: str | os.PathLike[str], what: str) -> Path:
    """Check an output folder: an existing writable folder, or creatable; shared with the host.

    Args:
        path: the folder.
        what: what it is, for messages.

    Returns:
        The path.

    Raises:
        InputError: if it cannot be used.
    """
    p = check_shared(path, what)
    _usable_folder(p, what, repr(str(path)))
    return p


def check_output_file(path: str | os.PathLike[str], what: str,
                      suffixes: tuple[str, ...] | None = None) -> Path:
    """Check an output file: not a folder, in a usable folder, shared with the host.

    Args:
        path: the file.
        what: what it is, for messages.
        suffixes: the allowed suffixes (case-insensitive); None: any.

    Returns:
        The path.

    Raises:
        InputError: if it cannot be used or has another suffix.
    """
    p = Path(_text(path, what))
    shown = repr(str(path))
    if suffixes and p.suffix.lower() not in suffixes:
        raise InputError(f"{what} must name a {' or '.join(suffixes)} file, got {shown}")
    check_shared(p, what)
    try:
        if p.is_dir():
            raise InputError(f"{what} {shown} is a folder, not a file")
        if p.exists() and not os.access(p, os.W_OK):
            raise InputError(f"{what} {shown} exists and is not writable")
    except OSError as e:
        raise InputError(f"{what} {shown} is not usable: {e.strerror or e}") from None
    _usable_folder(p.parent, what, shown)
    return p
