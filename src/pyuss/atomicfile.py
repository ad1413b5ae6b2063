"""Files written atomically: the one way pyuss writes a file a user keeps.

Recordings of the virtual bus, monitor captures, the simulated drives' EEPROM stores, the GSD
file and the installed Wireshark dissector are all written the same way: under a temporary name
in the target's folder, flushed and fsynced, renamed over the target, then the folder is
fsynced. A crash leaves either the old file or the new one, never half of one.

`AtomicWriter` checks the target when it is created, before any work is done: a target that is
a folder, a device, a pipe or a socket (the rename would put a file in its place, even
``/dev/null`` for root), or a folder that does not exist or cannot be written, is a
`ConfigError` naming the file (bad input, exit code 2 in the commands), so a long recording
is never made for nothing.
Should finishing still fail (the disk is full, the target turned into a folder meanwhile, ...),
a streamed file (a recording, a capture) keeps its temporary file and the error names it: no
data lost. `write_atomically`, whose caller still holds the data, removes it instead.

The file gets the permissions any newly created file gets (0666 less the umask), not the 0600
of a bare temporary file, so a GSD file or a capture can be shared like any other file.

On Windows, which renames no open file, the file is closed before the rename, and a rename
that an antivirus or an indexer holds up for a moment is tried again for a second
(`pyuss.system.replace_closing`).

A writer killed outright (``kill -9``, a power cut) leaves its temporary file
(``.NAME.XXXXXXXX.tmp`` beside NAME) behind. Every writer holds an exclusive lock
(``flock``; a lock of its first byte on Windows) on its temporary file while it lives;
`remove_stale` removes the temporary files of a target whose lock nobody holds, i.e. whose
writer is gone, and leaves those of a live writer alone. The EEPROM store calls it when a
drive starts.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from pathlib import Path
from typing import IO, Any

from pyuss import system
from pyuss.errors import ConfigError

_ATTEMPTS = 5
"""Temporary files tried when a sweep of another process removes one as it is created."""


def _umask() -> int:
    """The process's umask, read without changing it where the system tells it."""
    with (
        contextlib.suppress(OSError, ValueError),
        open("/proc/self/status", encoding="ascii", errors="replace") as status,
    ):
        for line in status:
            if line.startswith("Umask:"):
                return int(line.split()[1], 8)
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def check_target(path: str | os.PathLike[str], what: str) -> Path:
    """``path`` as a `Path` if a file can be created there; `ConfigError` naming it if not."""
    target = Path(path)
    folder = target.parent
    if target.is_dir():
        raise ConfigError(f"cannot write {what} to {target}: it is a folder")
    if not folder.is_dir():
        raise ConfigError(f"cannot write {what} to {target}: folder {folder} does not exist")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise ConfigError(f"cannot write {what} to {target}: folder {folder} is not writable")
    return target


def check_regular(target: Path, advice: str) -> None:
    """`ConfigError` naming ``target`` if it is there and is no regular file (a device, a
    pipe or a socket): a file written there would take its place (``advice``: what to give
    instead)."""
    if target.exists() and not target.is_file():
        raise ConfigError(f"{target} is no regular file (a device, a pipe or a socket): {advice}")


class AtomicWriter:
    """A file written under a temporary name and renamed into place by `close`.

    ``what`` names the file in messages ("a capture", "the GSD file"); ``text`` opens it for
    UTF-8 text instead of bytes; ``keep_on_failure`` keeps the temporary file when `close`
    fails (and names it). `discard` drops it. Both are idempotent.
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        what: str,
        *,
        text: bool = False,
        keep_on_failure: bool = True,
    ) -> None:
        self.path = check_target(path, what)
        if self.path.exists() and not self.path.is_file():
            raise ConfigError(
                f"cannot write {what} to {self.path}: it is no regular file (a device, a pipe "
                "or a socket), and the file written would take its place: give a file"
            )
        self.what = what
        self.keep_on_failure = keep_on_failure
        try:
            fd, self.tmp = _locked_temporary(self.path)
        except OSError as exc:
            raise ConfigError(f"cannot write {what} to {self.path}: {exc.strerror}") from None
        with contextlib.suppress(OSError):
            system.set_mode(fd, 0o666 & ~_umask())
        self.file: IO[Any] | None = (
            os.fdopen(fd, "w", encoding="utf-8") if text else os.fdopen(fd, "wb")
        )

    def write(self, data: Any) -> None:
        """Write ``data``; a write the disk refuses (full, gone read-only, an I/O error) ends
        the file as a failing `close` does: `ConfigError` naming the file and the reason, the
        temporary file kept and named (``keep_on_failure``) or removed."""
        if self.file is None:
            raise ConfigError(f"{self.what} {self.path} is already closed")
        try:
            self.file.write(data)
        except OSError as exc:
            problem = f"cannot write {self.what} {self.path}: {exc.strerror or exc}"
            if self.keep_on_failure:
                file, self.file = self.file, None
                with contextlib.suppress(OSError):
                    file.close()
                raise ConfigError(f"{problem}; what was written is kept as {self.tmp}") from None
            self.discard()
            raise ConfigError(problem) from None

    def close(self) -> None:
        """Flush, fsync, rename into place, fsync the folder."""
        file, self.file = self.file, None
        if file is None:
            return
        try:
            try:
                file.flush()
                os.fsync(file.fileno())
            except BaseException:
                file.close()
                raise
            system.replace_closing(file, self.tmp, self.path)
        except OSError as exc:
            problem = f"cannot finish {self.what} {self.path}: {exc.strerror or exc}"
            if self.keep_on_failure:
                raise ConfigError(f"{problem}; what was written is kept as {self.tmp}") from None
            with contextlib.suppress(OSError):
                os.unlink(self.tmp)
            raise ConfigError(problem) from None
        _sync_folder(self.path.parent)

    def discard(self) -> None:
        """Drop the temporary file without writing the target."""
        file, self.file = self.file, None
        if file is not None:
            with contextlib.suppress(OSError):  # a full disk refuses the buffer's flush too
                file.close()
            with contextlib.suppress(OSError):
                os.unlink(self.tmp)

    def __enter__(self) -> AtomicWriter:
        return self

    def __exit__(self, exc_type: object, exc: object, tb: object) -> None:
        if exc_type is None:
            self.close()
        else:
            self.discard()


def _temporary_prefix(target: Path) -> str:
    return f".{target.name}."


def _locked_temporary(target: Path) -> tuple[int, str]:
    """A new temporary file beside ``target``, locked for as long as its descriptor is open.

    A sweep (`remove_stale`) in another process may find the file between its creation and
    the lock and remove it: then the descriptor no longer names the file at that path, and
    another one is made."""
    for _ in range(_ATTEMPTS):
        fd, tmp = tempfile.mkstemp(
            prefix=_temporary_prefix(target), suffix=".tmp", dir=target.parent
        )
        try:
            system.try_lock(fd)
            if os.path.samestat(os.fstat(fd), os.stat(tmp)):
                return fd, tmp
        except OSError:
            pass
        os.close(fd)
    raise OSError(0, "temporary files were removed as they were made")


def remove_stale(path: str | os.PathLike[str]) -> list[Path]:
    """Remove the temporary files a killed writer of ``path`` left behind (those whose lock
    no living writer holds); return what was removed. Errors are ignored: a file that cannot
    be removed stays, as it did before."""
    target = Path(path)
    removed: list[Path] = []
    prefix = _temporary_prefix(target)
    try:
        names = [
            n for n in os.listdir(target.parent) if n.startswith(prefix) and n.endswith(".tmp")
        ]
    except OSError:
        return removed
    for name in names:
        stale = target.parent / name
        try:
            fd = os.open(stale, os.O_RDONLY | system.NOFOLLOW)
        except OSError:
            continue
        try:
            if not os.path.samestat(os.fstat(fd), os.lstat(stale)):
                continue
            system.try_lock(fd)  # refused: a live writer's file
        except OSError:
            continue
        finally:
            os.close(fd)  # before the unlink: Windows removes no open file
        try:
            os.unlink(stale)
        except OSError:
            continue
        removed.append(stale)
    return removed


def write_atomically(path: str | os.PathLike[str], data: bytes, what: str = "a file") -> None:
    """Replace ``path`` by ``data`` so that a crash leaves either the old or the new file."""
    with AtomicWriter(path, what, keep_on_failure=False) as writer:
        writer.write(data)


def _sync_folder(folder: Path) -> None:
    """Make the rename durable; not every system can open a folder, which is no error."""
    with contextlib.suppress(OSError):
        dir_fd = os.open(folder, os.O_RDONLY)
        try:
            os.fsync(dir_fd)
        finally:
            os.close(dir_fd)
