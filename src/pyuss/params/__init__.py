"""Parameter knowledge on the master side: what a parameter is and how its values read.

- `ParamInfo` (`pyuss.params.info`, also imported from `pyuss.params.model` beside `Reading`,
  a value read): one parameter - number, name, unit, data type, scaling, array size, access,
  limits, default, value and bit texts, access level, when changeable.
- `ParamBook` (`pyuss.params.book`): what is known of one drive's parameters, from (highest
  trust first) the user's parameter file, the drive's own descriptions read live (C 6; cached
  per drive and in an optional cache file), the profile's shipped parameter file.
- `pyuss.params.values`: words <-> typed values (float, signed/unsigned 8/16/32, scaled,
  texts), parsing a user's text with refusals before anything is sent (`ValueRefused`), and
  formatting (``10.00 s``).
- `pyuss.params.names`: parameter numbers as the family's documents write them (``r0021``,
  ``P1120``, ``P947.0``) and read in any spelling (``r21``, ``P0021``, ``21[0]``).

`pyuss.master.Drive.read` / ``write`` convert through the drive's book (``Drive.params``);
``read_raw`` / ``write_raw`` give the words. See docs/master.md ("Values") and
docs/commissioning.md.
"""

from pyuss.params.book import Describe, ParamBook
from pyuss.params.model import Access, ParamInfo, Source, from_description, from_parameter
from pyuss.params.values import (
    ValueRefused,
    decode,
    encode,
    format_value,
    json_value,
    parse,
    words_text,
)

__all__ = [
    "Access",
    "Describe",
    "ParamBook",
    "ParamInfo",
    "Source",
    "ValueRefused",
    "decode",
    "encode",
    "format_value",
    "from_description",
    "from_parameter",
    "json_value",
    "parse",
    "words_text",
]
