"""Where mse writes output files (reading is :mod:`mse.input_files`'s).

Writing (:func:`write_atomic`, :func:`staged_folder`), by kind of target (docs/security.md):

- a regular file (or a missing one): written to a temporary file in the same folder, then
  renamed over the target, so a reader never sees half a file; an existing file keeps its
  permission bits (and owner, where allowed);
- a character device or a FIFO (``/dev/null``, ``/dev/stdout``, a named pipe): written
  through, never replaced;
- a symbolic link: followed to its target, which is then treated as above, unless the link
  sits in a sticky world-writable folder (``/tmp``) and belongs to someone else (the kernel's
  ``protected_symlinks`` rule) or dangles: refused;
- a directory, a block device, a socket, a read-only file, or any path that is also an input
  of the command: refused.

Every failure is an :class:`~mse.diagnostics.MseError` (``path: E105 message``); the
temporary file is removed on any error, on Ctrl-C and on SIGTERM (see
:func:`install_termination_handler`).
"""

from __future__ import annotations

import contextlib
import os
import signal
import stat
from collections.abc import Iterable, Iterator, Sequence
from pathlib import Path

from mse.diagnostics import MseError
from mse.input_files import PathLike, file_kind, located_error, was_read

_SIGNALS = tuple(s for s in (signal.SIGTERM, signal.SIGINT, getattr(signal, "SIGHUP", None)) if s is not None)


class Terminated(BaseException):
    """SIGTERM (or SIGHUP) arrived; raised so that clean-up code runs before exiting."""

    def __init__(self, signum: int) -> None:
        super().__init__(signum)
        self.signum = signum


def _terminate(signum: int, _frame: object) -> None:
    raise Terminated(signum)


def install_termination_handler() -> None:
    """Make SIGTERM and SIGHUP raise :class:`Terminated` (command-line use only), so that
    temporary files are removed before the process exits."""
    for signum in (signal.SIGTERM, getattr(signal, "SIGHUP", None)):
        if signum is not None:
            signal.signal(signum, _terminate)


@contextlib.contextmanager
def _signals_blocked() -> Iterator[None]:
    """Hold back termination signals while a temporary file is created and registered for
    clean-up (they are delivered right after, inside the ``try`` that removes it)."""
    if not hasattr(signal, "pthread_sigmask"):  # pragma: no cover - not on Linux
        yield
        return
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, _SIGNALS)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)


# -- writing --------------------------------------------------------------------------------
def _write_error(path: str, message: str) -> MseError:
    return located_error("E105", message, path)


def _same_file(a: os.stat_result, b: os.stat_result) -> bool:
    return (a.st_dev, a.st_ino) == (b.st_dev, b.st_ino)


def refuse_inputs(path: PathLike, inputs: Iterable[PathLike]) -> None:
    """E105 when ``path`` names the same file as one of ``inputs`` (for writers that do
    not go through :func:`write_atomic` with ``inputs``, check first)."""
    name = os.fspath(path)
    try:
        target = os.stat(name)
    except OSError:
        return
    _refuse_inputs(name, target, inputs)


def _refuse_inputs(name: str, target: os.stat_result | None, inputs: Iterable[PathLike]) -> None:
    if target is None:
        return
    if was_read(target):
        raise _write_error(name, "refusing to overwrite a file this command reads")
    for source in inputs:
        source_name = os.fspath(source)
        if source_name == "-":
            continue
        with contextlib.suppress(OSError):
            if _same_file(os.stat(source_name), target):
                raise _write_error(name, f"refusing to overwrite an input of this command ({source_name})")


def _may_follow(link: str, link_info: os.stat_result) -> bool:
    """The kernel's ``protected_symlinks`` rule: in a sticky world-writable folder (``/tmp``)
    follow only links of our own or of the folder's owner."""
    try:
        folder = os.stat(os.path.dirname(os.path.abspath(link)))
    except OSError:
        return False
    shared = bool(folder.st_mode & stat.S_ISVTX) and bool(folder.st_mode & stat.S_IWOTH)
    return not shared or link_info.st_uid in (os.geteuid(), folder.st_uid)


def _write_through(name: str, payload: bytes) -> None:
    """Write into an existing character device or FIFO without replacing it."""
    try:
        fd = os.open(name, os.O_WRONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0))
    except OSError as error:
        import errno

        reason = "nothing reads this FIFO" if error.errno == errno.ENXIO else (error.strerror or str(error))
        raise _write_error(name, f"cannot write output: {reason}") from None
    try:
        os.set_blocking(fd, True)
        view = memoryview(payload)
        while view:
            written = os.write(fd, view)
            view = view[written:]
    except OSError as error:
        raise _write_error(name, f"cannot write output: {error.strerror or error}") from None
    finally:
        os.close(fd)


def _resolve_target(name: str) -> tuple[str, os.stat_result | None]:
    """The path to write and what is there now (None: nothing); refuses what must not be
    replaced or written."""
    try:
        info = os.lstat(name)
    except FileNotFoundError:
        return name, None
    except OSError as error:
        raise _write_error(name, f"cannot write output: {error.strerror or error}") from None
    except ValueError:  # a NUL character in the name
        raise _write_error(repr(name), "cannot write output: the name holds a NUL character") from None
    if stat.S_ISLNK(info.st_mode):
        if not _may_follow(name, info):
            raise _write_error(name, "refusing to follow a symbolic link owned by another user in a shared folder")
        try:
            info = os.stat(name)
        except OSError:
            raise _write_error(name, "refusing to write through a dangling symbolic link") from None
        if stat.S_ISREG(info.st_mode):
            name = os.path.realpath(name)
    mode = info.st_mode
    if stat.S_ISREG(mode):
        if not os.access(name, os.W_OK):
            raise _write_error(name, "cannot write output: the file is read-only")
        return name, info
    if stat.S_ISCHR(mode) or stat.S_ISFIFO(mode):
        return name, info
    raise _write_error(name, f"cannot write output: is {file_kind(mode)}")


def write_atomic(path: PathLike, data: str | bytes, *, inputs: Iterable[PathLike] = (), durable: bool = True) -> None:
    """Write ``data`` to ``path`` (see the module docstring for each kind of target).

    ``inputs`` are the files the command read: writing over one of them is refused.
    ``durable``: flush the data to disk before the rename (off for caches)."""
    payload = data.encode("utf-8", errors="surrogateescape") if isinstance(data, str) else data
    with atomic_path(path, inputs=inputs) as temporary:
        try:
            with open(temporary, "wb") as handle:
                handle.write(payload)
                handle.flush()
                if durable:
                    os.fsync(handle.fileno())
        except OSError as error:
            raise _write_error(os.fspath(path), f"cannot write output: {error.strerror or error}") from None


@contextlib.contextmanager
def atomic_path(path: PathLike, *, inputs: Iterable[PathLike] = (), suffix: str = ".tmp") -> Iterator[Path]:
    """A temporary file for writers that need a path (encoders, image libraries): write
    ``path``'s content into the yielded file; when the body succeeds it takes ``path``'s place
    by the rules of :func:`write_atomic` (renamed over a regular file with its mode kept,
    streamed into a device or FIFO, refused for what must not be written); on any error or
    signal it is removed and ``path`` is untouched."""
    name = os.fspath(path)
    target, existing = _resolve_target(name)
    _refuse_inputs(name, existing, inputs)
    through = existing is not None and not stat.S_ISREG(existing.st_mode)
    import tempfile  # only when writing (keeps the start of every command light)

    # Beside the target (one rename, same file system); a device's folder is no place for it.
    folder = tempfile.gettempdir() if through else os.path.dirname(os.path.abspath(target))
    try:
        os.makedirs(folder, exist_ok=True)
    except OSError as error:
        raise _write_error(name, f"cannot create the output folder: {error.strerror or error}") from None
    base = os.path.basename(target)
    tmp_name = ""
    try:
        with _signals_blocked():
            try:
                fd, tmp_name = tempfile.mkstemp(prefix=f".{base[:100]}.", suffix=suffix, dir=folder)
            except OSError as error:
                reason = error.strerror or str(error)
                raise _write_error(name, f"cannot write output: cannot create a file in {folder}: {reason}") from None
        os.close(fd)
        yield Path(tmp_name)
        if through:
            with open(tmp_name, "rb") as handle:
                _write_through(target, handle.read())
            return
        if existing is not None:
            os.chmod(tmp_name, stat.S_IMODE(existing.st_mode) & 0o777)
            if (existing.st_uid, existing.st_gid) != (os.geteuid(), os.getegid()):
                with contextlib.suppress(OSError):
                    os.chown(tmp_name, existing.st_uid, existing.st_gid)
        else:  # mkstemp makes 0600; a new file gets what a plain open() would give
            os.chmod(tmp_name, 0o666 & ~_umask())
        os.replace(tmp_name, target)
        tmp_name = ""
    except OSError as error:
        raise _write_error(name, f"cannot write output: {error.strerror or error}") from None
    finally:
        if tmp_name:
            with contextlib.suppress(OSError):
                os.unlink(tmp_name)


_UMASK: int | None = None


def _umask() -> int:
    global _UMASK
    if _UMASK is None:  # os.umask can only be read by setting it: do it once per process
        _UMASK = os.umask(0o022)
        os.umask(_UMASK)
    return _UMASK


@contextlib.contextmanager
def staged_folder(out: PathLike, *, inputs: Sequence[PathLike] = (), empty: bool = False) -> Iterator[Path]:
    """A temporary folder beside ``out`` to write a set of files into; on success its files
    move into ``out`` (created if missing), on any error or signal it is removed and ``out``
    is left as it was.  ``out`` must not be a file nor an input of the command; with
    ``empty``, it must also be new or empty (a set of files that belong together, such as
    one timeline's motion clips, must not mix with another run's)."""
    name = os.fspath(out)
    target = Path(name)
    if target.exists() and not target.is_dir():
        raise _write_error(name, "cannot write output: exists and is not a folder")
    if empty and target.is_dir() and any(target.iterdir()):
        raise _write_error(name, "the output folder must be new or empty (its files would mix with this run's)")
    with contextlib.suppress(OSError):
        if target.exists() and was_read(os.stat(name)):
            raise _write_error(name, "refusing to write into a file this command reads")
    for source in inputs:
        source_name = os.fspath(source)
        with contextlib.suppress(OSError):
            if source_name != "-" and target.exists() and _same_file(os.stat(source_name), os.stat(name)):
                raise _write_error(name, f"refusing to write into an input of this command ({source_name})")
    parent = target.resolve().parent
    try:
        parent.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise _write_error(name, f"cannot create the output folder: {error.strerror or error}") from None
    import shutil
    import tempfile

    staging = ""
    try:
        with _signals_blocked():
            staging = tempfile.mkdtemp(prefix=f".{target.name[:100]}.", suffix=".tmp", dir=parent)
        yield Path(staging)
        _move_into(Path(staging), target, inputs)
    except OSError as error:
        raise _write_error(name, f"cannot write output: {error.strerror or error}") from None
    finally:
        if staging:
            shutil.rmtree(staging, ignore_errors=True)


def _move_into(staging: Path, target: Path, inputs: Iterable[PathLike]) -> None:
    os.chmod(staging, 0o777 & ~_umask())
    if not target.exists():
        os.rename(staging, target)  # one atomic step when the folder is new
        return
    for entry in sorted(staging.rglob("*")):
        destination = target / entry.relative_to(staging)
        if entry.is_dir():
            destination.mkdir(exist_ok=True)
        else:
            write_atomic(destination, entry.read_bytes(), inputs=inputs, durable=False)


def user_cache_dir(kind: str) -> Path:
    """The folder of one kind of cache: ``$MSE_CACHE_DIR/kind``, else the XDG cache folder
    (``$XDG_CACHE_HOME/mse/kind``, default ``~/.cache/mse/kind``)."""
    configured = os.environ.get("MSE_CACHE_DIR")
    if configured:
        return Path(configured) / kind
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "mse" / kind


def private_folder(folder: Path) -> bool:
    """True when ``folder`` exists (it is created 0700 if missing), belongs to this user,
    nobody else may write into it, and every folder above it belongs to this user or root
    and is not writable by others (or is sticky, like ``/tmp``): a cache that someone else
    could swap or edit is never trusted."""
    try:
        folder.mkdir(parents=True, exist_ok=True, mode=0o700)
        info = os.stat(folder)
        owner = os.geteuid()
        if not stat.S_ISDIR(info.st_mode) or info.st_uid != owner or info.st_mode & (stat.S_IWGRP | stat.S_IWOTH):
            return False
        for ancestor in folder.resolve().parents:
            above = os.stat(ancestor)
            if above.st_uid not in (owner, 0):
                return False
            if above.st_mode & (stat.S_IWGRP | stat.S_IWOTH) and not above.st_mode & stat.S_ISVTX:
                return False
    except OSError:
        return False
    return True
