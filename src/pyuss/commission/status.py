"""`uss status`: one look at a drive - state, status word, actual values with units, faults.

`look` sends one telegram for the process data (the status word in PZD1 and the main actual
value in PZD2, C 5; a layout without PZD reads the status word parameter the profile names
instead) and reads the parameters the profile's file names for the purpose (``[drive]``:
state, actual, setpoint, fault, warning, and the reference that is 100 % of setpoints and
actual values, 4000h). The main actual value is shown in percent and, where the profile names
the reference parameter, in its unit (Hz, rpm). Fault and warning numbers come with the text
the profile gives them where it has one. Where the family's file names the command and setpoint
sources (``[sources]``: P0700, P1000) one line says whether the drive follows USS or what it
ignores and what to set (`pyuss.commission.sources`). A reference parameter the drive
refuses (a drive looked at with another family's profile) leaves the actual value in
percent, and a note says why (`Look.notes`). A drive of unknown kind (no profile named) shows
what its telegram says - state, status word, the bits' meanings by the USS specification (C Table
5.5; bits 11..15 are the device's own), the actual value in percent - and `Look.unknown_kind`
says that its parameters, texts and reference are not known: no family's are put in their
place.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from pyuss.commission.backup import Entry, read_parameters
from pyuss.commission.sources import Sources, check
from pyuss.errors import DriveRefusal
from pyuss.master.drive import Drive
from pyuss.master.process import DriveStatus, state_of
from pyuss.params.words import WordKind, WordText, describe_word
from pyuss.profiles.base import Profile
from pyuss.protocol.pzd import STATUS_BITS, describe_bits, raw16_to_percent

__all__ = ["UNKNOWN_KIND_NOTE", "Look", "fault_texts", "look", "reference_value", "warning_texts"]

ROLES = ("state", "actual", "setpoint", "fault", "warning")

UNKNOWN_KIND_NOTE = (
    "drive of unknown kind (no --profile): its parameters for state, setpoint, fault and "
    "warning, their texts and the reference of the actual value are not known; give --profile "
    "NAME (or auto) for them"
)


def fault_texts(drive: Drive) -> dict[int, str]:
    """Fault numbers the profile knows, with their texts (the family's own list first); none
    for a drive of unknown kind."""
    return dict(drive.profile.fault_names) if drive.profile_named else {}


def warning_texts(drive: Drive) -> dict[int, str]:
    """Warning numbers the profile knows, with their texts (none for a drive of unknown
    kind)."""
    return dict(drive.profile.warnings) if drive.profile_named else {}


async def reference_value(drive: Drive) -> tuple[float, str] | None:
    """The value and unit of the reference parameter (100 % = 4000h), where the profile names
    one whose unit is not percent (None for a drive of unknown kind: no profile names one)."""
    if not drive.profile_named:
        return None
    ref = drive.profile.database().roles.get("reference")
    if ref is None:
        return None
    reading = await drive.read_param(ref.pnu, ref.index)
    info = reading.info
    if info is None or not info.unit or info.unit == "%":
        return None
    if isinstance(reading.value, bool) or not isinstance(reading.value, int | float):
        return None
    return float(reading.value), info.unit


@dataclass(slots=True)
class Look:
    """What `look` saw."""

    address: int
    word: int
    actual_percent: float | None = None
    actual: float | None = None
    """The main actual value in the reference's unit (None without a reference)."""
    unit: str = ""
    parameters: list[Entry] = field(default_factory=list)
    shown: dict[str, str] = field(default_factory=dict)
    """Each parameter's value as printed (by label), with its unit and value text."""
    texts: dict[int, str] = field(default_factory=dict)
    """Fault texts by number, for the parameter labelled `fault_label`."""
    fault_label: str = ""
    warnings: dict[int, str] = field(default_factory=dict)
    """Warning texts by number, for the parameter labelled `warning_label`."""
    warning_label: str = ""
    family_bits: dict[int, str] = field(default_factory=dict)
    """What the device-specific status bits 11..15 show on this family (its profile)."""
    family: Profile | None = None
    """The drive's family (None: of unknown kind), that names the status bits 11..15 in
    `status_text`."""
    unknown_kind: bool = False
    """No profile was named: the drive's parameters, fault texts and reference are unknown."""
    notes: list[str] = field(default_factory=list)
    """What could not be seen, and why (a reference parameter the drive refused)."""
    sources: Sources | None = None
    """Whether the drive follows the control word and setpoint of USS (None: not looked)."""

    def _text_of(self, entry: Entry) -> str | None:
        if not entry.ok or not isinstance(entry.value, int) or entry.value == 0:
            return None
        if entry.label == self.fault_label:
            return self.texts.get(entry.value)
        if entry.label == self.warning_label:
            return self.warnings.get(entry.value)
        return None

    @property
    def state(self) -> str:
        return state_of(self.word)

    @property
    def status_text(self) -> WordText:
        """The status word and its set bits named (`pyuss.params.words`)."""
        return describe_word(self.word, WordKind.STATUS, self.family)

    def bits(self) -> list[tuple[int, bool, str]]:
        return [
            (bit, on, self.family_bits.get(bit, text) if bit >= 11 else text)
            for bit, on, text in describe_bits(self.word, STATUS_BITS)
        ]

    def lines(self) -> list[str]:
        out = [f"drive {self.address}: {self.state}", f"status word {self.status_text}"]
        out += [f"  bit {bit:2}  {int(on)}  {text}" for bit, on, text in self.bits()]
        if self.actual_percent is not None:
            physical = f" = {self.actual:.2f} {self.unit}" if self.actual is not None else ""
            out.append(f"actual value (PZD2) {self.actual_percent:.2f} %{physical}")
        for entry in self.parameters:
            text = self.shown.get(entry.label) or entry.text()
            meaning = self._text_of(entry)
            if meaning:
                text += f" ({meaning})"
            name = f" ({entry.name})" if entry.name else ""
            out.append(f"{entry.label}{name} = {text}")
        if self.sources is not None and self.sources.known:
            out.append(f"sources: {self.sources.line()}")
        out += self.notes
        if self.unknown_kind:
            out.append(UNKNOWN_KIND_NOTE)
        return out

    def to_dict(self) -> dict[str, Any]:
        return {
            "address": self.address,
            "state": self.state,
            "status": self.word,
            "status_hex": f"{self.word:04X}",
            "status_text": self.status_text.text(),
            "bits": [{"bit": b, "set": on, "meaning": t} for b, on, t in self.bits()],
            "actual_percent": self.actual_percent,
            "actual": self.actual,
            "unit": self.unit,
            "unknown_kind": self.unknown_kind,
            "notes": self.notes,
            "sources": None if self.sources is None else self.sources.to_dict(),
            "parameters": [
                {
                    **e.to_dict(),
                    "text": self.shown.get(e.label, ""),
                    "fault_text": self._text_of(e),
                }
                for e in self.parameters
            ],
        }


async def look(drive: Drive, *, timeout: float | None = None) -> Look:
    """One look at ``drive`` (see the module docstring)."""
    db = drive.profile.database() if drive.profile_named else None
    status: DriveStatus | None = None
    if drive.layout.pzd >= 1:
        status = await drive.next_update(timeout=timeout)
        word = status.word
    else:
        ref = None if db is None else db.roles.get("status_word")
        if ref is None:
            from pyuss.errors import ConfigError

            whose = (
                f"profile {drive.profile.name} names"
                if db is not None
                else "the drive is of unknown kind (no --profile): nothing names"
            )
            raise ConfigError(
                f"layout {drive.layout} carries no status word (PZD 0) and {whose} its status "
                "word parameter: give --layout with PZD"
            )
        value = await drive.read(ref.pnu, ref.index, timeout=timeout)
        assert isinstance(value, int)
        word = value
    roles = {} if db is None else db.roles
    fault, warning = roles.get("fault"), roles.get("warning")
    result = Look(
        drive.address,
        word,
        texts=fault_texts(drive),
        fault_label=drive.params.label(fault.pnu, fault.index) if fault else "",
        warnings=warning_texts(drive),
        warning_label=drive.params.label(warning.pnu, warning.index) if warning else "",
        family_bits={
            bit: text
            for bit, text in drive.profile.status_bits.items()
            if bit >= 11 and drive.profile_named
        },
        family=drive.profile if drive.profile_named else None,
        unknown_kind=db is None,
    )
    if status is not None and status.actual:
        result.actual_percent = raw16_to_percent(status.actual[0])
        try:
            reference = await reference_value(drive)
        except DriveRefusal as exc:  # the rest of the look is still worth having
            reference = None
            where = "" if exc.pnu is None else f" {drive.params.label(exc.pnu, exc.index)}"
            result.notes.append(
                f"the reference parameter{where} (100 % of the actual value) could not be "
                f"read: error {exc.number}: {exc.meaning}; is --profile {drive.profile.name} "
                "this drive's family?"
            )
        if reference is not None:
            result.actual = result.actual_percent / 100 * reference[0]
            result.unit = reference[1]
    wanted = []
    for role in ROLES:
        ref = roles.get(role)
        if ref is not None and (ref.pnu, ref.index) not in wanted:
            wanted.append((ref.pnu, ref.index))
    result.parameters = await read_parameters(drive, wanted)
    result.shown = {e.label: e.text(drive.params.get(e.pnu)) for e in result.parameters}
    result.sources = await check(drive, timeout=timeout)
    return result
