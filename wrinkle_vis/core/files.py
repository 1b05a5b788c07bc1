"""Writing files safely: every writer of the package goes through :func:`atomic_output`.

A file is written to a temporary file beside its target (same folder, so the rename cannot
cross a file system), flushed to disk, checked (not empty; a caller may re-read it), given
the permissions of the file it replaces (or the umask's for a new file) and renamed over the
target with :func:`os.replace`. On any failure the temporary file is removed and the old
target is left as it was. A target that is a symbolic link is written through: the link's
target is replaced and the link kept.

Errors are one line each, naming the problem and the way out: :class:`OutputPathError` for
a target that cannot be written at all (a folder, a missing or read-only folder, an
unsupported extension), checked before any work with :func:`check_output`, and
:class:`WriteError` for a write that failed (a full disk, an I/O error, a file that does not
read back).
"""

from __future__ import annotations

import errno
import os
import stat
import tempfile
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

__all__ = ["OutputPathError", "WriteError", "atomic_output", "atomic_write_bytes",
           "atomic_write_text", "check_output", "input_problem", "replace_permissions",
           "write_error"]


class OutputPathError(ValueError):
    """A target that cannot be written: its message names the problem and the way out."""


class WriteError(OSError):
    """A write that failed; the old file, if any, is intact and no temporary file is left."""


def _extension_list(suffixes: Sequence[str]) -> str:
    return ", ".join(suffixes[:-1]) + f" or {suffixes[-1]}" if len(suffixes) > 1 else \
        suffixes[0]


def check_output(path: str | os.PathLike, suffixes: Sequence[str] | None = None) -> Path:
    """Check that ``path`` can be written, before any work is done; return the real target.

    Parameters
    ----------
    path : path
        Where the caller means to write.
    suffixes : sequence of str, optional
        The extensions the writer supports (lower case, with the dot); ``path``'s extension
        must be one of them (case-insensitive).

    Returns
    -------
    Path
        The file to replace: ``path`` with symbolic links resolved (the link is kept and
        its target written).

    Raises
    ------
    OutputPathError
        For an unsupported or missing extension, a path that is a folder, a folder that does
        not exist, is not a folder or is not writable.
    """
    given = Path(path).expanduser()
    if given.is_dir():
        example = given / f"out{suffixes[0] if suffixes else ''}"
        raise OutputPathError(f"{str(given)!r} is a folder; give a file name inside it, "
                              f"e.g. {str(example)!r}")
    if suffixes:
        suffixes = tuple(s.lower() for s in suffixes)
        if given.suffix.lower() not in suffixes:
            what = (f"has the unsupported extension {given.suffix!r}" if given.suffix
                    else "has no extension")
            raise OutputPathError(
                f"{str(given)!r} {what}; name it with {_extension_list(suffixes)}, e.g. "
                f"{str(given.with_suffix(suffixes[0]))!r}")
    if str(given) in ("", "."):
        raise OutputPathError("no output file given; name one, e.g. 'out"
                              f"{suffixes[0] if suffixes else '.txt'}'")
    real = Path(os.path.realpath(given))
    if real.is_dir():
        example = real / f"out{suffixes[0] if suffixes else ''}"
        raise OutputPathError(f"{str(given)!r} is a folder; give a file name inside it, "
                              f"e.g. {str(example)!r}")
    folder = real.parent
    if not folder.exists():
        raise OutputPathError(f"folder {str(folder)!r} does not exist; create it first "
                              f"(mkdir -p {folder}) or write somewhere else")
    if not folder.is_dir():
        raise OutputPathError(f"{str(folder)!r} is not a folder; write somewhere else")
    if not os.access(folder, os.W_OK | os.X_OK):
        why = "is on a read-only file system" if _read_only_fs(folder) else "is not writable"
        raise OutputPathError(f"folder {str(folder)!r} {why}; write somewhere else or make "
                              "it writable")
    return real


def _read_only_fs(folder: Path) -> bool:
    try:
        return bool(os.statvfs(folder).f_flag & os.ST_RDONLY)
    except (OSError, AttributeError):
        return False


def umask() -> int:
    """The process's umask (read without changing it for long)."""
    mask = os.umask(0)
    os.umask(mask)
    return mask


def replace_permissions(tmp: str | os.PathLike, target: str | os.PathLike) -> None:
    """Give ``tmp`` the mode (and, as root, the owner) of ``target``, or for a new file the
    mode an ordinary ``open`` would give (``0o666`` less the umask).
    """
    try:
        st = os.stat(target)
    except FileNotFoundError:
        os.chmod(tmp, 0o666 & ~umask())
        return
    os.chmod(tmp, stat.S_IMODE(st.st_mode))
    if hasattr(os, "geteuid") and os.geteuid() == 0:
        try:
            os.chown(tmp, st.st_uid, st.st_gid)
        except OSError:
            pass


_WAY_OUT = {
    errno.ENOSPC: "no space left on the device; free some space or write to another disk",
    errno.EDQUOT: "disk quota exceeded; free some space or write to another disk",
    errno.EROFS: "the file system is read-only; write somewhere else",
    errno.EACCES: "permission denied; write somewhere else or change the permissions",
    errno.EPERM: "operation not permitted; write somewhere else or change the permissions",
    errno.EFBIG: "the file is too large for this file system; write to another disk",
    errno.EIO: "input/output error; check the disk",
}


def write_error(path: str | os.PathLike, exc: BaseException) -> WriteError:
    """The one-line :class:`WriteError` for a failure ``exc`` while writing ``path``."""
    if isinstance(exc, OSError) and exc.errno in _WAY_OUT:
        why = _WAY_OUT[exc.errno]
    elif isinstance(exc, OSError) and exc.strerror:
        why = exc.strerror
    else:
        why = " ".join(str(exc).split()) or type(exc).__name__
    err = WriteError(f"could not write {str(Path(path))!r}: {why} (nothing was changed "
                     "there)")
    err.errno = getattr(exc, "errno", None)
    return err


def _remove(path: str | os.PathLike) -> None:
    try:
        os.unlink(path)
    except FileNotFoundError:
        pass


@contextmanager
def atomic_output(path: str | os.PathLike, *, suffixes: Sequence[str] | None = None,
                  check: Callable[[Path], None] | None = None) -> Iterator[Path]:
    """Write a file atomically through a temporary path, for writers that take a file name.

    Use as ``with atomic_output("out.mp4") as tmp: writer(tmp)``. The temporary file lies
    beside the target and ends in the target's extension (writers that pick the format by
    extension still work). On leaving the block it is synced, checked (not empty, then
    ``check(tmp)``, which raises to reject it), given the target's permissions and renamed
    over the target. If the block or a check fails, the temporary file is removed and the
    target left as it was.

    Raises
    ------
    OutputPathError
        From :func:`check_output`, before the block runs.
    WriteError
        If writing, checking or renaming failed; one line naming the file and the way out.
        Errors that are not about the file (a ``KeyboardInterrupt``, a bug) pass through
        after the clean-up.
    """
    real = check_output(path, suffixes)
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{real.name}.", suffix=f".tmp{real.suffix}",
                                   dir=real.parent)
    except OSError as exc:
        raise write_error(real, exc) from exc
    os.close(fd)
    try:
        try:
            yield Path(tmp)
        except WriteError:
            raise
        except OSError as exc:
            raise write_error(real, exc) from exc
        try:
            with open(tmp, "rb+") as fh:
                os.fsync(fh.fileno())
            if os.path.getsize(tmp) == 0:
                raise WriteError(f"could not write {str(real)!r}: the writer wrote nothing "
                                 "(nothing was changed there)")
            if check is not None:
                try:
                    check(Path(tmp))
                except Exception as exc:  # any failure to read back rejects the file
                    why = " ".join(str(exc).split()) or type(exc).__name__
                    raise WriteError(f"could not write {str(real)!r}: the written file does "
                                     f"not read back ({why}); nothing was changed there"
                                     ) from exc
            replace_permissions(tmp, real)
            os.replace(tmp, real)
        except WriteError:
            raise
        except OSError as exc:
            raise write_error(real, exc) from exc
    except BaseException:
        _remove(tmp)
        raise


def atomic_write_bytes(path: str | os.PathLike, data: bytes | Callable, *,
                       suffixes: Sequence[str] | None = None,
                       check: Callable[[Path], None] | None = None) -> Path:
    """Write ``data`` (bytes, or a function that writes into a binary file object) to
    ``path`` atomically (:func:`atomic_output`); returns the file written (links resolved).
    """
    real = check_output(path, suffixes)
    with atomic_output(real, check=check) as tmp:
        with open(tmp, "wb") as fh:
            if callable(data):
                data(fh)
            else:
                fh.write(data)
    return real


def atomic_write_text(path: str | os.PathLike, text: str) -> Path:
    """Write ``text`` as UTF-8 to ``path`` atomically (:func:`atomic_output`)."""
    return atomic_write_bytes(path, text.encode("utf-8"))


def input_problem(path: str | os.PathLike) -> str | None:
    """What keeps ``path`` from being read as a regular file, in words; None if nothing.

    ``"no such file"`` for a missing one (``FileNotFoundError`` territory); otherwise what
    it is: a folder, a named pipe, a device (such as ``/dev/zero``), a socket, a symbolic
    link loop or a link to nowhere, or a file that cannot be opened (permission denied).
    """
    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        return ("is a symbolic link to a missing file" if os.path.islink(path)
                else "no such file")
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            return "is a symbolic link loop (a link that leads back to itself)"
        if exc.errno == errno.ENOTDIR:
            return "no such file (a part of the path is a file, not a folder)"
        return f"cannot be opened ({exc.strerror or exc})"
    kinds = ((stat.S_ISDIR, "is a folder, not a file"),
             (stat.S_ISFIFO, "is a named pipe (FIFO), not a file"),
             (stat.S_ISCHR, "is a character device (such as /dev/zero), not a file"),
             (stat.S_ISBLK, "is a block device, not a file"),
             (stat.S_ISSOCK, "is a socket, not a file"))
    for test, what in kinds:
        if test(mode):
            return what
    if not os.access(path, os.R_OK):
        return "cannot be read (permission denied)"
    return None
