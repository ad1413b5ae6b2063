"""Device profiles: a parameter file (``data/<name>.toml``) plus the telegram-level facts of a
device family, shared by the slave and the master.

=================  =====================================================  ===================
name               device                                                 follows
=================  =====================================================  ===================
``generic``        the drive profile of the USS specification             USS specification A, C,
app.
``6se21``          SIMOVERT P 6SE21 / early MICROMASTER                   SIMOVERT P 6SE21 manual
7.5
``baumueller``     Baumueller drives (fixed length, masked broadcast)     Baumueller manual part 2
``nord``           NORD frequency inverters                               NORD BU 0050 1.3.5/1.3.6
``micromaster4``   MICROMASTER 4 / SINAMICS (P2000 and up via IND page)   public MM4 manuals
``micromaster420`` MICROMASTER 420                                        its manuals
``micromaster440`` MICROMASTER 440                                        its manuals
``sinamics-g110``  SINAMICS G110                                          its manuals
``sinamics-g120``  SINAMICS G120 with CU240S control unit                 its manuals
``sinamics-v20``   SINAMICS V20                                           its manuals
``nord-sk500e``    NORD SK 500E series                                    NORD BU 0050, BU 0050/0500
=================  =====================================================  ===================

The family profiles (`pyuss.profiles.siemens`, `pyuss.profiles.nord_sk500e`) add what the
family's manuals say: baud rate codes, address range, control and status word bits, fault and
warning numbers, the reference parameter, and how a drive shows its identity
(`pyuss.profiles.identify`). ``micromaster4`` and ``nord`` stay as they were.

`get_profile` returns one; `Profile` (in `pyuss.profiles.base`) documents what it holds.
`pyuss.profiles.coverage` says how much of a commissioning each family's parameter file covers
(the checklist ``commissioning.toml`` beside this module).
"""

from __future__ import annotations

from dataclasses import replace
from functools import cache

from pyuss.drive.loader import load_profile, split_edition
from pyuss.errors import ConfigError
from pyuss.profiles import (
    baumueller,
    generic,
    micromaster4,
    nord,
    nord_sk500e,
    siemens,
    six_se21,
)
from pyuss.profiles.base import BitRef, BroadcastForm, IdentityRule, Profile

__all__ = [
    "PROFILES",
    "UNKNOWN_KIND",
    "BitRef",
    "BroadcastForm",
    "IdentityRule",
    "Profile",
    "get_profile",
    "profile_names",
]

UNKNOWN_KIND = "unknown"
"""What stands for the profile of a drive no profile is named for, where a name is shown or
kept (a backup's header, the page, the gateway's state): a drive of unknown kind, no family's
facts applied. No profile has this name."""

PROFILES: dict[str, Profile] = {
    p.name: p
    for p in (
        generic.PROFILE,
        six_se21.PROFILE,
        baumueller.PROFILE,
        nord.PROFILE,
        micromaster4.PROFILE,
        *siemens.PROFILES,
        nord_sk500e.PROFILE,
    )
}
"""The built-in profiles by name."""


def profile_names() -> tuple[str, ...]:
    """Names of the built-in profiles."""
    return tuple(PROFILES)


def get_profile(name: str) -> Profile:
    """The built-in profile ``name``; ``NAME@EDITION`` is the profile with the values of
    that edition of its manual (its file's ``[editions]``, docs/drive.md). `ConfigError`
    naming the known profiles or editions otherwise."""
    try:
        return PROFILES[name]
    except (KeyError, TypeError):
        if isinstance(name, str) and "@" in name:
            return _edition_profile(name)
        known = ", ".join(PROFILES)
        raise ConfigError(f"unknown profile {name!r} (known: {known})") from None


@cache
def _edition_profile(name: str) -> Profile:
    base, _edition = split_edition(name)
    profile = get_profile(base)
    load_profile(f"{profile.data or profile.name}@{_edition}")  # an unknown edition: refused
    return replace(profile, name=name, data=f"{profile.data or profile.name}@{_edition}")
