"""Writing files safely: every writer of the package goes through :func:`atomic_output`.

A file is written to a temporary file beside its target (same folder, so the rename cannot
cross a file system), flushed to disk, checked (not empty; a caller may re-read it), given
the permissions of the file it replaces (or the umask's for a new file) and renamed over the
target with :func:`os.replace`. On any failure the temporary file is removed and the old
target is left as it was. A target that is a symbolic link is written through (the link's
target is replaced and the link kept) only if the link belongs to the current user or to
the owner of the folder it lies in; any other link on the way is refused
(:func:`check_output`), so a link planted in a shared folder cannot redirect a write.

Temporary files and folders are named ``.NAME.<pid>-<host>.<random>.tmp...``; those of
processes that are gone (killed) are removed by the next write into the same folder
(:func:`clean_stale`), and a folder moved aside (``.NAME.old.<pid>-<host>.<random>``) by a
killed :func:`replace_folder` is put back if its place is empty. Outputs of several files are
replaced as a whole: a folder by one exchange of two names (:func:`replace_folder`), an index
and its folder of pieces by renaming a new version folder in and then the index over the
old one (:func:`replace_indexed`); a kill at any point leaves the old output or the new
one, never a mix.

Errors are one line each, naming the problem and the way out: :class:`OutputPathError` for
a target that cannot be written at all (a folder, a missing or read-only folder, an
unsupported extension), checked before any work with :func:`check_output`, and
:class:`WriteError` for a write that failed (a full disk, an I/O error, a file that does not
read back).
"""

from __future__ import annotations

import ctypes
import errno
import hashlib
import os
import re
import secrets
import shutil
import signal
import socket
import stat
import tempfile
import time
from collections.abc import Callable, Iterator, Sequence, Set
from contextlib import contextmanager
from pathlib import Path

__all__ = ["Interrupted", "OutputPathError", "WriteError", "atomic_output", "atomic_write_bytes",
           "atomic_write_text", "check_output", "clean_stale", "commits", "deferred_signals",
           "exchange", "indexed_entries", "input_problem", "interrupt_exception", "new_version",
           "note_interrupt",
           "replace_folder", "replace_indexed", "replace_permissions", "resolve_output",
           "temp_folder", "temp_prefix", "tidy_versions", "write_error"]


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
        its target written). A link owned neither by the current user nor by the owner
        of the folder holding it is not followed (:func:`resolve_output`).

    Raises
    ------
    OutputPathError
        For an unsupported or missing extension, a path that is a folder, a folder that does
        not exist, is not a folder or is not writable, or a symbolic link on the way that
        another user planted.
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
    real = resolve_output(given)
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


_MAX_LINKS = 40  # as the kernel's limit on links followed in one path


def resolve_output(path: str | os.PathLike) -> Path:
    """``path`` made absolute with its symbolic links resolved, as the kernel would, except
    that a link is followed only if it belongs to the current user or to the owner of the
    folder it lies in.

    That is the kernel's ``fs.protected_symlinks`` rule for sticky world-writable folders
    (``/tmp``), applied to every folder: a writer renames its temporary file onto the
    resolved path, which the kernel's rule never sees, so the rule is applied here. A link
    that someone else planted in a shared folder would otherwise redirect the write onto a
    file of theirs choosing (as root: any file).

    Raises
    ------
    OutputPathError
        For such a link (naming it, its owner and the way out), or a loop of links.
    """
    full = os.fspath(path)
    if not os.path.isabs(full):  # not abspath: ".." after a link is the link target's parent
        full = os.path.join(os.getcwd(), full)
    pending = list(reversed(full.split(os.sep)))
    done, hops = os.sep, 0
    while pending:
        part = pending.pop()
        if part in ("", "."):
            continue
        if part == "..":
            done = os.path.dirname(done)
            continue
        here = os.path.join(done, part)
        try:
            st = os.lstat(here)
        except OSError:  # missing (the new file), or not a folder: the caller says which
            done = here
            continue
        if not stat.S_ISLNK(st.st_mode):
            done = here
            continue
        hops += 1
        if hops > _MAX_LINKS:
            raise OutputPathError(f"{os.fspath(path)!r}: too many symbolic links (a loop?); "
                                  "write somewhere else")
        _check_link_owner(here, st, done, path)
        target = os.readlink(here)
        if os.path.isabs(target):
            done = os.sep
        pending += reversed(target.split(os.sep))
    return Path(done)


def _check_link_owner(link: str, st: os.stat_result, folder: str,
                      given: str | os.PathLike) -> None:
    """Refuse ``link`` (lstat ``st``, in ``folder``) unless it belongs to the current user or
    to the folder's owner.
    """
    if not hasattr(os, "geteuid"):
        return
    try:
        owner = os.stat(folder).st_uid
    except OSError:
        return
    if st.st_uid in (os.geteuid(), owner):
        return
    what = f"{link!r} is a symbolic link that" if os.path.abspath(given) == link else \
        f"{os.fspath(given)!r} passes through the symbolic link {link!r}, which"
    raise OutputPathError(
        f"{what} belongs to another user (uid {st.st_uid}), not to you or to the owner of "
        f"the folder {folder!r}, so it is not written through; remove the link or write "
        "somewhere else")


# ---------------------------------------------------------------------- temporaries
def _host_tag() -> str:
    """6 hex digits naming this machine and pid namespace (a container): a pid is only
    looked up where it means the same process.
    """
    try:
        space = os.stat("/proc/self/ns/pid").st_ino
    except OSError:
        space = 0
    return hashlib.sha1(f"{socket.gethostname()}:{space}".encode()).hexdigest()[:6]


#: This machine and pid namespace, in the names of temporaries (``<pid>-<HOST_TAG>``).
HOST_TAG = _host_tag()
_WRITER = r"(?P<pid>\d+)-(?P<host>[0-9a-f]{6})"
_TEMP = re.compile(r"\.(?P<name>.+)\." + _WRITER + r"\.[a-z0-9_]{8}\.tmp(\..*)?")
_OLD = re.compile(r"\.(?P<name>.+)\.old\." + _WRITER + r"\.[a-z0-9_]{8}")
# names of versions before the pid was in them: stale once they are this old (seconds)
_LEGACY = (re.compile(r"\.(?P<name>.+)\.[a-z0-9_]{8}\.tmp(\..*)?"),
           re.compile(r"\.(?P<name>.+)\.old\.[a-z0-9_]{8}"))
LEGACY_AGE_S = 600.0
#: Temporaries of another machine or container (whose pids mean nothing here) are stale
#: once they are this old (seconds).
FOREIGN_AGE_S = 86400.0


def _writer_tag() -> str:
    return f"{os.getpid()}-{HOST_TAG}"


def _alive(pid: int) -> bool:
    """Whether process ``pid`` exists (this process counts)."""
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError, ValueError):  # someone else's, or not a pid
        return True
    return True


def _older(entry: os.DirEntry, now: float, seconds: float) -> bool:
    try:
        return now - entry.stat(follow_symlinks=False).st_mtime > seconds
    except OSError:
        return False


def _gone(m: re.Match, entry: os.DirEntry, now: float) -> bool:
    """Whether the writer named in ``m`` (pid and host tag) is gone: here, a pid that no
    process has; of another machine or container, a name older than a day.
    """
    if m.group("host") == HOST_TAG:
        return not _alive(int(m.group("pid")))
    return _older(entry, now, FOREIGN_AGE_S)


def _stale_match(entry: os.DirEntry, now: float) -> re.Match | None:
    """The name's match if ``entry`` is a temporary of a process that is gone."""
    for pattern in (_TEMP, _OLD):
        m = pattern.fullmatch(entry.name)
        if m:
            return m if _gone(m, entry, now) else None
    for pattern in _LEGACY:
        m = pattern.fullmatch(entry.name)
        if m:
            return m if _older(entry, now, LEGACY_AGE_S) else None
    return None


def _remove_any(path: str | os.PathLike) -> None:
    """Remove a file, link or folder (a link itself, never what it points to)."""
    try:
        if os.path.isdir(path) and not os.path.islink(path):
            shutil.rmtree(path, ignore_errors=True)
        else:
            os.unlink(path)
    except OSError:
        pass


def clean_stale(folder: str | os.PathLike) -> list[str]:
    """Remove from ``folder`` the temporaries of writers that were killed; return their names.

    A temporary is stale when the process named in it
    (``.NAME.<pid>-<host>.<random>.tmp...``) is gone: ``host`` is :data:`HOST_TAG`, and no
    process has the pid; a name of another machine or container, when older than
    :data:`FOREIGN_AGE_S`; names written before the pid was in them, when older than
    :data:`LEGACY_AGE_S`. A folder moved aside by a killed :func:`replace_folder`
    (``.NAME.old.<pid>-<host>.<random>/NAME``) is put back first if ``NAME`` is missing. Only hidden
    names of these shapes are touched; errors are ignored (a folder that cannot be listed
    or written is left as it is).
    """
    folder = os.fspath(folder)
    removed: list[str] = []
    now = time.time()
    try:
        entries = [e for e in os.scandir(folder) if e.name.startswith(".")]
    except OSError:
        return removed
    for entry in entries:
        m = _stale_match(entry, now)
        if m is None:
            continue
        if m.re in (_OLD, _LEGACY[1]) and entry.is_dir(follow_symlinks=False):
            name = m.group("name")
            kept, place = os.path.join(entry.path, name), os.path.join(folder, name)
            if os.path.isdir(kept) and not os.path.lexists(place):
                try:
                    os.rename(kept, place)  # the old output, put back
                except OSError:
                    continue
        _remove_any(entry.path)
        removed.append(entry.name)
    return removed


def temp_prefix(name: str) -> str:
    """The start of a temporary's name for the output ``name``: ``.NAME.<pid>-<host>.``."""
    return f".{name}.{_writer_tag()}."


def temp_folder(parent: str | os.PathLike, name: str) -> Path:
    """A new hidden temporary folder in ``parent`` for the output ``name``, after removing
    what killed writers left there (:func:`clean_stale`).
    """
    clean_stale(parent)
    return Path(tempfile.mkdtemp(prefix=temp_prefix(name), suffix=".tmp", dir=parent))


# ---------------------------------------------------------------------- commits
class Interrupted(BaseException):
    """A SIGTERM or SIGHUP, raised where the program is (as Ctrl-C raises
    KeyboardInterrupt), so that the writers' clean-ups run.
    """

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = signum


def interrupt_exception(signum: int) -> BaseException:
    """The exception for signal ``signum``: KeyboardInterrupt for SIGINT, else
    :class:`Interrupted`.
    """
    return KeyboardInterrupt() if signum == getattr(signal, "SIGINT", None) else \
        Interrupted(signum)


_PENDING: list[int] = []


def note_interrupt(signum: int | None) -> None:
    """Record that signal ``signum`` asked the program to stop (a signal handler calls
    this before raising): from then on no output is put in place, in case the exception
    was swallowed on its way (inside VTK). ``None`` forgets it.
    """
    _PENDING[:] = [] if signum is None else [signum]


_COMMITS = 0
_DEFERRED = (getattr(signal, "SIGINT", None), getattr(signal, "SIGTERM", None),
             getattr(signal, "SIGHUP", None))


def commits() -> int:
    """How many outputs this process has put in place (a count that only grows): a signal
    handler tells by it whether an interrupted command had changed anything.
    """
    return _COMMITS


def _committed() -> None:
    global _COMMITS
    _COMMITS += 1


@contextmanager
def deferred_signals() -> Iterator[None]:
    """Hold SIGINT, SIGTERM and SIGHUP back during the block (the renames that put an
    output in place), so a handler runs before or after them, not between (POSIX only);
    after an interrupt (:func:`note_interrupt`) raise its exception instead.
    """
    if _PENDING:  # an interrupt came and its exception was lost: put nothing in place
        raise interrupt_exception(_PENDING[0])
    sigs = {s for s in _DEFERRED if s is not None}
    if not sigs or not hasattr(signal, "pthread_sigmask"):
        yield
        return
    old = signal.pthread_sigmask(signal.SIG_BLOCK, sigs)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


_AT_FDCWD, _RENAME_EXCHANGE = -100, 2
_UNSUPPORTED = {errno.ENOSYS, errno.EINVAL, errno.ENOTSUP, errno.EOPNOTSUPP, errno.EPERM}


def _renameat2():
    try:
        fn = ctypes.CDLL(None, use_errno=True).renameat2
    except (OSError, AttributeError):
        return None
    fn.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p,
                   ctypes.c_uint]
    fn.restype = ctypes.c_int
    return fn


_RENAMEAT2 = _renameat2() if os.name == "posix" else None


def exchange(a: str | os.PathLike, b: str | os.PathLike) -> bool:
    """Swap the names ``a`` and ``b`` (both must exist) in one step: Linux's
    ``renameat2(RENAME_EXCHANGE)``. Returns False where that is not supported (another
    system, an old kernel or C library, a file system without it), and the caller falls
    back.

    Raises
    ------
    OSError
        If the swap is supported but failed.
    """
    if _RENAMEAT2 is None:
        return False
    if _RENAMEAT2(_AT_FDCWD, os.fsencode(a), _AT_FDCWD, os.fsencode(b),
                  _RENAME_EXCHANGE) == 0:
        return True
    err = ctypes.get_errno()
    if err in _UNSUPPORTED:
        return False
    raise OSError(err, os.strerror(err), os.fspath(b))


def replace_folder(new: Path, folder: Path, then: Callable[[], None] | None = None) -> None:
    """Put the folder ``new`` in the place of ``folder``, replacing an old ``folder`` whole,
    then run ``then()``.

    ``new`` gets the old folder's permissions (or the umask's for a new one) and must lie on
    the same file system, in a temporary folder (:func:`temp_folder`) that the caller
    removes: after an exchange it holds the old folder. An old folder is swapped with the
    new in one step (:func:`exchange`), so a kill leaves one or the other. Where that is not
    supported, the old folder is first moved aside to ``.NAME.old.<pid>-<host>.<random>``, which
    the next write into the same folder puts back if the kill came before the new one was
    in place (:func:`clean_stale`). If ``then()`` fails, the old folder is put back.

    Raises
    ------
    OSError
        If a rename failed; ``folder`` is then as it was.
    """
    old_dir = None
    is_old = folder.is_dir() and not folder.is_symlink()
    os.chmod(new, folder.stat().st_mode & 0o7777 if is_old else 0o777 & ~umask())
    with deferred_signals():
        if is_old and exchange(new, folder):
            try:
                if then is not None:
                    then()
            except BaseException:
                exchange(new, folder)
                raise
            _committed()
            return
        try:
            if is_old:
                old_dir = Path(tempfile.mkdtemp(prefix=f".{folder.name}.old.{_writer_tag()}.",
                                                dir=folder.parent))
                os.rename(folder, old_dir / folder.name)
            os.rename(new, folder)
            if then is not None:
                then()
            _committed()
        except BaseException:
            if old_dir is not None and (old_dir / folder.name).exists():  # put it back
                if folder.exists():
                    os.rename(folder, new)
                os.rename(old_dir / folder.name, folder)
            raise
        finally:
            if old_dir is not None:
                shutil.rmtree(old_dir, ignore_errors=True)


_VERSION = re.compile(r"v" + _WRITER + r"-[0-9a-f]{8}")
_FILE_ATTR = re.compile(r"""\sfile=(["'])(.*?)\1""")


_WRITING: set[str] = set()  # this process's versions not yet committed or given up


def new_version() -> str:
    """A fresh name for a version folder of :func:`replace_indexed`:
    ``v<pid>-<host>-<8 hex>``.
    """
    name = f"v{_writer_tag()}-{secrets.token_hex(4)}"
    _WRITING.add(name)
    return name


def indexed_entries(index: Path, folder_name: str) -> set[str]:
    """The names in the folder ``folder_name`` that the XML index ``index`` refers to (the
    first part after ``folder_name/`` of each ``file="..."``); empty if it cannot be read.
    """
    from xml.sax.saxutils import unescape

    try:
        text = index.read_text(encoding="utf-8", errors="replace")
    except OSError:
        return set()
    names = set()
    for _, value in _FILE_ATTR.findall(text):
        parts = unescape(value, {"&quot;": '"', "&apos;": "'"}).split("/")
        if len(parts) >= 2 and parts[0] == folder_name:
            names.add(parts[1])
    return names


def replace_indexed(version: Path, folder: Path, index_tmp: Path, index: Path) -> None:
    """Put a new version of an index file and the pieces it refers to in place as a whole.

    ``version`` (a folder named by :func:`new_version`, holding the pieces) is renamed into
    ``folder`` (made if missing), then ``index_tmp``, which refers to the pieces as
    ``FOLDER/VERSION/...``, over ``index``: that rename is the commit. Only then are the old
    version (or, written before versions, the old pieces) and the versions of killed
    writers removed. A kill before the commit leaves the old index over its own pieces,
    after it the new one; leftovers go at the next write (:func:`tidy_versions`).

    Raises
    ------
    OSError
        If a rename failed; the index and its pieces are then as they were.
    """
    old = indexed_entries(index, folder.name)
    placed = folder / version.name
    try:
        with deferred_signals():
            if not folder.is_dir():
                folder.mkdir()
            os.rename(version, placed)
            try:
                replace_permissions(index_tmp, index)
                os.replace(index_tmp, index)
            except BaseException:
                shutil.rmtree(placed, ignore_errors=True)
                raise
            _committed()
    finally:
        _WRITING.discard(version.name)
    tidy_versions(folder, index, old - {version.name})


def tidy_versions(folder: Path, index: Path, old: Set[str] = frozenset()) -> None:
    """Remove from ``folder`` the entries ``old`` (an index's former pieces) unless the
    ``index`` now refers to them, and the version folders it does not refer to that no
    writer is working on (of processes that are gone, or of this one and not being written).
    """
    current = indexed_entries(index, folder.name)
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return
    now = time.time()
    for entry in entries:
        if entry.name in current:
            continue
        m = _VERSION.fullmatch(entry.name)
        if entry.name in old or (m and _abandoned(m, entry, now)):
            _remove_any(entry.path)


def _abandoned(m: re.Match, entry: os.DirEntry, now: float) -> bool:
    """Whether no writer works on the version folder ``entry`` (``m`` its name's match)."""
    if m.group("host") == HOST_TAG and int(m.group("pid")) == os.getpid():
        return entry.name not in _WRITING
    return _gone(m, entry, now)


def umask() -> int:
    """The process's umask (read without changing it for long)."""
    mask = os.umask(0)
    os.umask(mask)
    return mask


def replace_permissions(tmp: str | os.PathLike, target: str | os.PathLike,
                        mode: int | None = None) -> None:
    """Give ``tmp`` the mode (and, as root, the owner) of ``target``, or for a new file
    ``mode`` (default: what an ordinary ``open`` would give, ``0o666`` less the umask).
    """
    try:
        st = os.stat(target)
    except FileNotFoundError:
        os.chmod(tmp, (0o666 if mode is None else mode) & ~umask())
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
    if isinstance(exc, WriteError):  # one line naming the target already
        return exc
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
                  check: Callable[[Path], None] | None = None,
                  mode: int | None = None) -> Iterator[Path]:
    """Write a file atomically through a temporary path, for writers that take a file name.

    Use as ``with atomic_output("out.mp4") as tmp: writer(tmp)``. The temporary file lies
    beside the target and ends in the target's extension (writers that pick the format by
    extension still work). On leaving the block it is synced, checked (not empty, then
    ``check(tmp)``, which raises to reject it), given the target's permissions and renamed
    over the target. If the block or a check fails, the temporary file is removed and the
    target left as it was. A new file gets ``mode`` less the umask (default ``0o666``).
    Temporaries that killed writers left beside the target are removed first
    (:func:`clean_stale`).

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
    clean_stale(real.parent)
    try:
        fd, tmp = tempfile.mkstemp(prefix=temp_prefix(real.name), suffix=f".tmp{real.suffix}",
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
            _commit(tmp, real, check, mode)
        except WriteError:
            raise
        except OSError as exc:
            raise write_error(real, exc) from exc
    except BaseException:
        _remove(tmp)
        raise


def _commit(tmp: str, real: Path, check: Callable[[Path], None] | None,
            mode: int | None) -> None:
    """:func:`atomic_output`'s last step: sync the temporary file ``tmp``, check it (not
    empty, then ``check``), give it the target's permissions and rename it over ``real``.
    """
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
                             f"not read back ({why}); nothing was changed there") from exc
    replace_permissions(tmp, real, mode)
    with deferred_signals():
        os.replace(tmp, real)
        _committed()


def atomic_write_bytes(path: str | os.PathLike, data: bytes | Callable, *,
                       suffixes: Sequence[str] | None = None,
                       check: Callable[[Path], None] | None = None,
                       mode: int | None = None) -> Path:
    """Write ``data`` (bytes, or a function that writes into a binary file object) to
    ``path`` atomically (:func:`atomic_output`; ``mode`` for a new file); returns the file
    written (links resolved).
    """
    real = check_output(path, suffixes)
    with atomic_output(real, check=check, mode=mode) as tmp:
        with open(tmp, "wb") as fh:
            if callable(data):
                data(fh)
            else:
                fh.write(data)
    return real


def atomic_write_text(path: str | os.PathLike, text: str, *, mode: int | None = None) -> Path:
    """Write ``text`` as UTF-8 to ``path`` atomically (:func:`atomic_output`; ``mode`` for a
    new file).
    """
    return atomic_write_bytes(path, text.encode("utf-8"), mode=mode)


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
