"""The diagnostic parameters of a USS slave interface (A 5.2.3), readable through the PKW channel.

A 5.2.3 proposes that a slave show its receive diagnostics as parameters: 16 diagnostic
parameters of 16 bits each, and an indexed parameter in which the received telegram can be
looked at character by character. The engine offers them as 18 read-only parameters from a
first number ``base`` that each profile chooses (`pyuss.profiles.Profile.diagnostic_pnu`) so
that they do not collide with the drive's own:

===========  =================  ==========================================================
PNU          name               value
===========  =================  ==========================================================
base + 0     USS HW version     1. hardware version of the interface (0: simulated)
base + 1     USS SW version     2. software version: pyuss major/minor/patch as 0xMmp
base + 2     USS reserve        3. reserved, 0
base + 3     USS error status   4. error status word (V2, bits 0..7 of A 5.2.3, latched)
base + 4     USS good/min       5. telegrams received without error in the last minute
base + 5     USS discard/min    6. telegrams discarded in the last minute
base + 6     USS good tlg       7. counter: telegrams received without error
base + 7     USS discarded      8. counter: telegrams discarded
base + 8     USS framing err    9. counter: framing errors
base + 9     USS overrun err    10. counter: overrun errors
base + 10    USS parity err     11. counter: parity errors
base + 11    USS no STX         12. counter: telegram start not recognised
base + 12    USS resid. time    13. counter: residual telegram time exceeded
base + 13    USS BCC error      14. counter: wrong BCC
base + 14    USS length err     15. counter: wrong telegram length
base + 15    USS timeout        16. counter: telegram failure time expired
base + 16    USS last tlg       the last telegram received for this slave, two characters per
                                element (first character in the high byte), 128 elements
base + 17    USS last tlg len   its length in characters
===========  =================  ==========================================================

Counters are shown modulo 65536. The values are refreshed whenever the master reads one of
these parameters, so they are the interface's state at that moment. The error status word has
bit texts (request ID 15). The parameters follow the drive's profile settings (index base,
description layout), so they read like any other parameter of the device.
"""

from __future__ import annotations

from dataclasses import replace

from pyuss import __version__
from pyuss.drive.database import Access, DisplayFormat, Parameter, ParameterDatabase
from pyuss.drive.datatypes import DataType
from pyuss.drive.faults import ParameterFault
from pyuss.drive.memory import ParameterMemory
from pyuss.errors import ConfigError
from pyuss.protocol.diagnostics import Diagnostics
from pyuss.protocol.telegram import Telegram

__all__ = ["COUNT", "TELEGRAM_WORDS", "DiagnosticParameters", "software_version"]

COUNT = 18
"""Number of diagnostic parameters."""
TELEGRAM_WORDS = 128
"""Elements of the telegram parameter: 256 characters, two per element."""

_NAMES = (
    "USS HW version",
    "USS SW version",
    "USS reserve",
    "USS error status",
    "USS good/min",
    "USS discard/min",
    "USS good tlg",
    "USS discarded",
    "USS framing err",
    "USS overrun err",
    "USS parity err",
    "USS no STX",
    "USS resid. time",
    "USS BCC error",
    "USS length err",
    "USS timeout",
)

_STATUS_TEXTS = {
    0: ("NO FRAMING ERR", "FRAMING ERROR"),
    1: ("NO OVERRUN", "BUFFER OVERRUN"),
    2: ("NO PARITY ERR", "PARITY ERROR"),
    3: ("START OK", "NO STX"),
    4: ("BCC OK", "BCC ERROR"),
    5: ("RESIDUAL OK", "RESIDUAL TIME"),
    6: ("LGE OK", "WRONG LGE"),
    7: ("MONITORING OK", "TIMEOUT"),
}


def software_version() -> int:
    """The pyuss version as one word: major in bits 8..15, minor 4..7, patch 0..3."""
    parts = [int(p) if p.isdigit() else 0 for p in __version__.split(".")[:3]]
    major, minor, patch = [*parts, 0, 0, 0][:3]
    return (major & 0xFF) << 8 | (minor & 0xF) << 4 | (patch & 0xF)


def _parameter(
    pnu: int,
    name: str,
    dtype: DataType,
    doc: str,
    *,
    array: int | None = None,
    bit_texts: dict[int, tuple[str, str]] | None = None,
) -> Parameter:
    return Parameter(
        pnu=pnu,
        name=name,
        dtype=dtype,
        default=(0,) * (1 if array is None else array),
        array=array,
        access=Access.RO,
        store=False,
        display=DisplayFormat.HEX if dtype is DataType.V2 else DisplayFormat.DEC,
        bit_texts=bit_texts or {},
        doc=doc,
        follows="USS specification A 5.2.3",
    )


class DiagnosticParameters:
    """The 18 diagnostic parameters from ``base`` of one slave, backed by ``diagnostics``.

    ``drive_db`` is the drive's database: its profile settings are reused, and a collision of
    the numbers with its parameters is refused with `ConfigError`.
    """

    def __init__(self, base: int, diagnostics: Diagnostics, drive_db: ParameterDatabase) -> None:
        last = base + COUNT - 1
        limit = drive_db.profile.max_pnu
        if base < 0 or last > limit:
            raise ConfigError(
                f"diagnostic parameters P{base}..P{last} do not fit the parameter numbers "
                f"0..{limit} of profile {drive_db.profile.name!r}"
            )
        taken = [p.pnu for p in drive_db if base <= p.pnu <= last]
        if taken:
            raise ConfigError(
                f"diagnostic parameters P{base}..P{last} collide with P{taken[0]} of the "
                "parameter file; choose another first number for them"
            )
        self.base = base
        self.diagnostics = diagnostics
        self._last: Telegram | bytes = b""
        params = {}
        for offset, name in enumerate(_NAMES):
            if offset == 3:
                param = _parameter(
                    base + offset,
                    name,
                    DataType.V2,
                    "A 5.2.3 error status word",
                    bit_texts=_STATUS_TEXTS,
                )
            else:
                param = _parameter(
                    base + offset, name, DataType.UINT16, f"A 5.2.3 no. {offset + 1}"
                )
            params[param.pnu] = param
        telegram = _parameter(
            base + 16,
            "USS last tlg",
            DataType.UINT16,
            "last telegram received, two characters per element",
            array=TELEGRAM_WORDS,
        )
        params[telegram.pnu] = telegram
        length = _parameter(base + 17, "USS last tlg len", DataType.UINT16, "its length")
        params[length.pnu] = length
        # read-only displays: the keyword and write-enable parameters of the drive are not
        # theirs (write authority is the drive's, checked by the parameter channel)
        profile = replace(drive_db.profile, access_level=None, write_enable=None)
        self.memory = ParameterMemory(ParameterDatabase(profile, params))

    def __contains__(self, pnu: object) -> bool:
        return isinstance(pnu, int) and self.base <= pnu < self.base + COUNT

    def note_telegram(self, telegram: Telegram | bytes) -> None:
        """Remember the last telegram received for this slave (its bytes are built only when
        they are read)."""
        self._last = telegram if isinstance(telegram, Telegram) else bytes(telegram)

    @property
    def telegram(self) -> bytes:
        """The bytes of the last telegram received for this slave (empty before the first)."""
        last = self._last
        return last.encode() if isinstance(last, Telegram) else last

    def refresh(self, now: float) -> ParameterMemory:
        """Bring the values up to date (time ``now`` for the per-minute rates); the memory."""
        words = self.diagnostics.snapshot(now).words()
        update = self.memory.update
        for offset, word in enumerate(words):
            update(self.base + offset, word)
        telegram = self.telegram
        data = telegram.ljust(2 * TELEGRAM_WORDS, b"\0")[: 2 * TELEGRAM_WORDS]
        index_base = self.memory.db.profile.index_base
        for i in range(TELEGRAM_WORDS):
            try:
                update(self.base + 16, data[2 * i] << 8 | data[2 * i + 1], index_base + i)
            except ParameterFault:  # pragma: no cover - the array covers exactly these
                break
        update(self.base + 17, len(telegram))
        return self.memory
