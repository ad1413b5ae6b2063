"""The records of parameter knowledge: `ParamInfo`, what is known of one parameter
(`pyuss.params.info`), and `Reading`, one value read from a drive, which prints itself through
`pyuss.params.values`.

Both are imported from here; `ParamInfo` and its builders live in `pyuss.params.info`, below
the values they convert, so that a `Reading` can format its value with them.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from pyuss.drive.database import Access
from pyuss.drive.datatypes import DataType, Value
from pyuss.errors import UssError
from pyuss.params.info import DescriptionLike, ParamInfo, Source, from_description, from_parameter
from pyuss.params.names import param_name
from pyuss.params.values import decode, format_value, json_value, words_text

__all__ = [
    "Access",
    "DescriptionLike",
    "ParamInfo",
    "Reading",
    "Source",
    "from_description",
    "from_parameter",
    "param_label",
]


def param_label(pnu: int, index: int | None = None, info: ParamInfo | None = None) -> str:
    """``P1120``, ``P947.3``, ``P2010.1``, ``r0021``: the parameter number as the drive's
    documents write it, by what ``info`` says of it (its family's style and access; without
    it ``P21``); a number from 2000 on as the number itself, whatever IND page carries it."""
    return info.label(index) if info is not None else param_name(pnu, index)


@dataclass(frozen=True, slots=True)
class Reading:
    """One value read from a drive: the words it sent and what they mean.

    ``index`` is None for a simple parameter and for a whole array (then ``value`` and
    ``words`` hold every element, ``value`` as a list). ``sent``: for the answer to a write,
    the words written (None for a read).
    """

    pnu: int
    index: int | None
    info: ParamInfo | None
    words: tuple[int, ...]
    value: Value | list[Value]
    sent: tuple[int, ...] | None = None

    @property
    def differs(self) -> bool:
        """The answer to a write carries other words than were written: the drive holds
        another value than the one asked for (it limits or rounds). A text is compared
        without the blanks that pad it."""
        if self.sent is None or tuple(self.sent) == tuple(self.words):
            return False
        if self.info is not None and self.info.dtype is DataType.VISIBLE_STRING:
            return self.written_text() != self.text_value()
        return True

    def text_value(self) -> str:
        """The value as printed."""
        return format_value(self.info, self.value)

    def written_text(self) -> str:
        """The value written, as printed (``""`` for a read)."""
        if self.sent is None:
            return ""
        if self.info is None:
            if len(self.sent) > 2:
                return words_text(self.sent)
            number = self.sent[0] if len(self.sent) == 1 else self.sent[0] << 16 | self.sent[1]
            return format_value(None, number)
        try:
            return format_value(self.info, decode(self.info, self.sent, self.index))
        except UssError:
            return words_text(self.sent)

    @property
    def label(self) -> str:
        return param_label(self.pnu, self.index, self.info)

    def text(self) -> str:
        """``P1120 = 10.00 s (Ramp-up time)``."""
        name = f" ({self.info.name})" if self.info is not None and self.info.name else ""
        return f"{self.label} = {format_value(self.info, self.value)}{name}"

    def to_dict(self) -> dict[str, Any]:
        """``pnu``, ``index``, ``label``, ``name``, ``unit``, ``type``, ``value`` (typed; a list
        for a whole array), ``raw`` (the words) and ``text`` (the value as printed)."""
        info = self.info
        data: dict[str, Any] = {
            "pnu": self.pnu,
            "index": self.index,
            "label": self.label,
            "name": info.name if info is not None else None,
            "unit": info.unit if info is not None else "",
            "type": info.type_name if info is not None else None,
            "value": json_value(self.value),
            "raw": list(self.words),
            "text": format_value(info, self.value),
        }
        if info is not None and info.texts and isinstance(self.value, int):
            data["value_text"] = info.texts.get(self.value)
        return data
