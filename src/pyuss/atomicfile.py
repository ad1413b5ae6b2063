"""Files written atomically: the one way pyuss writes a file a user keeps.

Recordings of the virtual bus, monitor captures, the simulated drives' EEPROM stores, the GSD
file and the installed Wireshark dissector are all written the same way: under a temporary name
in the target's folder, flushed and fsynced, renamed over the target, then the folder is
fsynced. A crash leaves either the old file or the new one, never half of one.

`AtomicWriter` checks the target when it is created, before any work is done: a target that is
a folder, or a folder that does not exist or cannot be written, is a `ConfigError` naming the
file (bad input, exit code 2 in the commands), so a long recording is never made for nothing.
Should finishing still fail (the disk is full, the target turned into a folder meanwhile, ...),
a streamed file (a recording, a capture) keeps its temporary file and the error names it: no
data lost. `write_atomically`, whose caller still holds the data, removes it instead.

The file gets the permissions any newly created file gets (0666 less the umask), not the 0600
of a bare temporary file, so a GSD file or a capture can be shared like any other file.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from pathlib import Path
from typing import IO, Any

from pyuss.errors import ConfigError


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
        self.what = what
        self.keep_on_failure = keep_on_failure
        try:
            fd, self.tmp = tempfile.mkstemp(
                prefix=f".{self.path.name}.", suffix=".tmp", dir=self.path.parent
            )
        except OSError as exc:
            raise ConfigError(f"cannot write {what} to {self.path}: {exc.strerror}") from None
        with contextlib.suppress(OSError):
            os.fchmod(fd, 0o666 & ~_umask())
        self.file: IO[Any] | None = (
            os.fdopen(fd, "w", encoding="utf-8") if text else os.fdopen(fd, "wb")
        )

    def write(self, data: Any) -> None:
        if self.file is None:
            raise ConfigError(f"{self.what} {self.path} is already closed")
        self.file.write(data)

    def close(self) -> None:
        """Flush, fsync, rename into place, fsync the folder."""
        file, self.file = self.file, None
        if file is None:
            return
        try:
            try:
                file.flush()
                os.fsync(file.fileno())
            finally:
                file.close()
            os.replace(self.tmp, self.path)
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
