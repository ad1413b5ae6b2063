"""Persistence of the values written with the EEPROM request IDs (C Table 4.1, IDs 11..14).

A simulated drive keeps its parameter values in RAM. Values written with "change and store in
EEPROM" also go to a store file, so they survive a restart (a power cycle); everything else falls
back to the factory value.

File format: one header line, then a JSON body::

    pyuss-drive-store 1 sha256=<64 hex digits> bytes=<length of the body>
    {"profile": "generic", "values": [{"pnu": 18, "index": null, "words": [28672]}, ...]}

Values are stored as their PKW words, so a float, a string or a 32-bit value comes back bit for
bit. The file is written atomically: a temporary file in the same folder, written, flushed and
fsynced, renamed over the old one, then the folder is fsynced. A file that is torn (shorter than
its header says), altered (checksum), not of this format, or written for another profile is
refused with a `StoreError` naming the file; it is never loaded in part.

A drive killed while it wrote its store (``kill -9``) leaves a temporary file
``.NAME.XXXXXXXX.tmp`` beside the store; the next start of that store removes such files of
writers that are gone (`pyuss.atomicfile.remove_stale`), never one a running drive is writing.
"""

from __future__ import annotations

import hashlib
import json
import logging
import re
from collections.abc import Mapping
from pathlib import Path

from pyuss.atomicfile import remove_stale, write_atomically
from pyuss.errors import ConfigError

MAGIC = "pyuss-drive-store"
VERSION = 1
log = logging.getLogger("pyuss.drive")

_HEADER = re.compile(rb"pyuss-drive-store (\d+) sha256=([0-9a-f]{64}) bytes=(\d+)\n")

Key = tuple[int, int | None]
"""(PNU, IND) of a stored value; IND is None for a scalar."""


class StoreError(ConfigError):
    """The store file cannot be used: unreadable, torn, corrupt or for another profile."""


def encode_store(profile: str, values: Mapping[Key, tuple[int, ...]]) -> bytes:
    """The complete file content for ``values``."""
    entries = [
        {"pnu": pnu, "index": index, "words": list(words)}
        for (pnu, index), words in sorted(values.items(), key=lambda kv: (kv[0][0], kv[0][1] or 0))
    ]
    body = json.dumps({"profile": profile, "values": entries}, separators=(",", ":")).encode()
    digest = hashlib.sha256(body).hexdigest()
    return f"{MAGIC} {VERSION} sha256={digest} bytes={len(body)}\n".encode() + body


def decode_store(data: bytes, profile: str, name: str) -> dict[Key, tuple[int, ...]]:
    """The values in a store file's content; `StoreError` for anything not intact."""

    def refuse(problem: str) -> StoreError:
        return StoreError(f"{name}: {problem}; the store is not loaded (restore or delete it)")

    end = data.find(b"\n")
    match = _HEADER.fullmatch(data[: end + 1]) if end >= 0 else None
    if match is None:
        raise refuse(f"not a {MAGIC} file (bad or missing header line)")
    if int(match.group(1)) != VERSION:
        raise refuse(f"store format version {int(match.group(1))} is not supported")
    body = data[end + 1 :]
    if len(body) != int(match.group(3)):
        raise refuse(f"torn file: {len(body)} bytes of data, the header announces {match[3]!r}")
    if hashlib.sha256(body).hexdigest() != match.group(2).decode():
        raise refuse("checksum mismatch, the file is corrupted")
    try:
        content = json.loads(body)
    except (UnicodeDecodeError, json.JSONDecodeError):
        raise refuse("body is not valid JSON") from None
    if not isinstance(content, dict) or not isinstance(content.get("values"), list):
        raise refuse("body has no value list")
    if content.get("profile") != profile:
        raise refuse(f"written for profile {content.get('profile')!r}, not {profile!r}")
    values: dict[Key, tuple[int, ...]] = {}
    for entry in content["values"]:
        if not isinstance(entry, dict):
            raise refuse("value entry is not an object")
        pnu, index, words = entry.get("pnu"), entry.get("index"), entry.get("words")
        if (
            not isinstance(pnu, int)
            or isinstance(pnu, bool)
            or not (index is None or (isinstance(index, int) and not isinstance(index, bool)))
            or not isinstance(words, list)
            or not all(_is_int(w) and 0 <= w <= 0xFFFF for w in words)
        ):
            raise refuse(f"malformed value entry {entry!r}")
        values[(pnu, index)] = tuple(words)
    return values


def _is_int(value: object) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


class ParameterStore:
    """The store file of one drive (the simulated EEPROM)."""

    def __init__(self, path: str | Path, profile: str) -> None:
        self.path = Path(path)
        self.profile = profile
        if not self.path.parent.is_dir():
            raise StoreError(f"{self.path}: folder {self.path.parent} does not exist")
        for stale in remove_stale(self.path):
            log.info("%s: removed %s, left by a write that was cut off", self.path, stale.name)

    def load(self) -> dict[Key, tuple[int, ...]]:
        """The stored values; empty for a drive that never stored anything (no file yet)."""
        try:
            data = self.path.read_bytes()
        except FileNotFoundError:
            return {}
        except OSError as exc:
            raise StoreError(f"{self.path}: cannot read the store: {exc.strerror or exc}") from None
        return decode_store(data, self.profile, str(self.path))

    def save(self, values: Mapping[Key, tuple[int, ...]]) -> None:
        """Write all stored values atomically."""
        try:
            write_atomically(self.path, encode_store(self.profile, values), "the store")
        except ConfigError as exc:
            raise StoreError(str(exc)) from None
