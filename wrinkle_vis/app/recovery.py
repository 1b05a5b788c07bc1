"""Crash recovery: the layout autosaved while the user works, offered back after a crash.

Each running app writes ``recovery-<pid>.json`` in the recovery folder (atomically, through
:func:`~wrinkle_vis.core.files.atomic_output`, so a kill or a full disk mid-write leaves the
previous copy) and removes it on a clean exit. A file whose process
is gone is an orphan: the next start offers each one to restore, discard or keep. No file
is deleted that the user was not asked about: not the other orphans, and not one that a dead
process with this process's pid left (a pid comes back, in containers often): that one is
an orphan too, and set aside before this process writes its own. No Qt here.
"""

from __future__ import annotations

import json
import os
import time
from dataclasses import dataclass
from pathlib import Path

from ..core.files import atomic_write_text
from ..core.layout import Layout, LayoutError, read_json

__all__ = ["Recovered", "Recovery", "default_directory"]

VERSION = 1
_STARTED = time.time()  # a file of our pid older than this was not written by us


def default_directory() -> Path:
    """``$WRINKLE_VIS_RECOVERY_DIR``, else ``$XDG_STATE_HOME/wrinkle-vis/recovery`` (default
    ``~/.local/state``).
    """
    env = os.environ.get("WRINKLE_VIS_RECOVERY_DIR")
    if env:
        return Path(env)
    state = os.environ.get("XDG_STATE_HOME") or Path.home() / ".local" / "state"
    return Path(state) / "wrinkle-vis" / "recovery"


@dataclass(frozen=True)
class Recovered:
    """What a recovery file holds."""

    path: Path
    layout: Layout
    source: Path | None  # the layout file the user had open, if any
    n_triangles: int
    saved_at: float  # seconds since the epoch


class Recovery:
    """The recovery file of this process, and the orphans of processes that did not exit cleanly.

    Parameters
    ----------
    directory : path, optional
        Where recovery files live (default :func:`default_directory`).
    """

    def __init__(self, directory: str | Path | None = None):
        self.directory = Path(directory) if directory else default_directory()
        self.path = self.directory / f"recovery-{os.getpid()}.json"

    def save(self, layout: Layout, source: str | Path | None, n_triangles: int) -> Path:
        """Write the layout to this process's recovery file (atomically); an orphan of a
        dead process that had this pid is renamed aside first (and offered later).
        """
        self.directory.mkdir(mode=0o700, parents=True, exist_ok=True)  # private: layouts
        if _stale(self.path):
            self.path.replace(self.path.with_name(
                f"recovery-{os.getpid()}-{self.path.stat().st_mtime_ns}.json"))
        data = {"wrinkle_vis_recovery": VERSION, "pid": os.getpid(), "saved_at": time.time(),
                "source": str(source) if source else None, "n_triangles": int(n_triangles),
                "layout": layout.to_dict()}
        atomic_write_text(self.path, json.dumps(data, indent=1), mode=0o600)
        return self.path

    def discard(self) -> None:
        """Remove this process's recovery file (a clean exit, or nothing left to recover);
        an orphan of a dead process that had this pid stays.
        """
        if not _stale(self.path):
            self.path.unlink(missing_ok=True)

    def orphans(self) -> list[Path]:
        """Recovery files of processes that are gone, newest first."""
        if not self.directory.is_dir():
            return []
        found = []
        for path in self.directory.glob("recovery-*.json"):
            pid = path.stem.removeprefix("recovery-")
            if pid == str(os.getpid()):  # ours, or a dead process's with our pid
                if _stale(path):
                    found.append(path)
            elif not (pid.isdigit() and _alive(int(pid))):
                found.append(path)
        return sorted(found, key=_mtime, reverse=True)

    @staticmethod
    def load(path: str | Path) -> Recovered:
        """Read a recovery file.

        Raises
        ------
        LayoutError
            If the file is not a wrinkle-vis recovery file or its layout is malformed (the
            message names the file, where, and what was expected).
        """
        path = Path(path)
        data = read_json(path)
        if not isinstance(data, dict) or data.get("wrinkle_vis_recovery") != VERSION:
            raise LayoutError(str(path), "$.wrinkle_vis_recovery",
                              f"a wrinkle-vis recovery file of version {VERSION}",
                              data.get("wrinkle_vis_recovery") if isinstance(data, dict)
                              else type(data).__name__)
        layout = Layout.from_dict(data.get("layout"), source=f"{path}: $.layout")
        return Recovered(path, layout, _source(path, data), _n_triangles(path, data),
                         _saved_at(path, data))


def _source(path: Path, data: dict) -> Path | None:
    """``$.source``: the layout file the user had open (a path), or null."""
    source = data.get("source")
    if source is None or source == "":
        return None
    if not isinstance(source, str) or "\0" in source:
        raise LayoutError(str(path), "$.source", "the path of a layout file or null", source)
    return Path(source)


def _n_triangles(path: Path, data: dict) -> int:
    """``$.n_triangles``: a positive whole number (default 4500)."""
    n = data.get("n_triangles", 4500)
    if isinstance(n, bool) or not isinstance(n, int) or not 0 < n < 2**31:
        raise LayoutError(str(path), "$.n_triangles", "a positive whole number of triangles",
                          n)
    return n


def _saved_at(path: Path, data: dict) -> float:
    """``$.saved_at``: seconds since the epoch (default 0), a time :func:`time.ctime` shows."""
    value = data.get("saved_at", 0)
    try:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise TypeError
        seconds = float(value)
        time.ctime(seconds)  # finite, and a date (raises beyond the year 9999 or so)
    except (TypeError, ValueError, OverflowError, OSError):
        raise LayoutError(str(path), "$.saved_at", "seconds since 1970 (a number)",
                          value) from None
    return seconds


def _mtime(path: Path) -> float:
    try:
        return path.stat().st_mtime
    except OSError:  # gone meanwhile
        return 0.0


def _stale(path: Path) -> bool:
    """Whether ``path`` exists and is older than this process (so not this process's)."""
    try:
        return path.stat().st_mtime < _STARTED
    except OSError:
        return False


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # someone else's process: alive
        pass
    return True
