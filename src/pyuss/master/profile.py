"""The master's use of a device profile (`pyuss.profiles.Profile`, shared with the slave side).

A profile tells the master:

- how a parameter number travels: `Profile.encode_pnu` / `Profile.decode_pnu` (PKE bits 0..10
  and, for MICROMASTER 4, a page number in IND bits 12..15; reading 8);
- which answer belongs to which job: `answers` - `Pkw.is_answer_to` (C 4.2.1.1: response ID of
  C Table 4.3, PNU, IND for indexed jobs), the same page, and no IND comparison for drives
  that answer IND 0 always (6SE21, SIMOVERT P 6SE21 manual 7.5);
- how long to wait for an answer: `response_limit` - the latest answer the profile allows,
  with the device's response-delay mode counted in (Baumueller answers within 2 ms, or within
  20 ms in that mode, Baumueller manual 2.5), never below the start pause (A 5.2.1.1);
- the start pause it needs (`Profile.start_pause_chars`, reading 2), its layouts
  (`Profile.check_layout`, `Profile.default_layout`), its error numbers
  (`Profile.error_meaning`) and broadcast form (`Profile.broadcast`, reading 9);
- from its parameter file: where arrays start counting (`index_base`) and the layout of its
  parameter descriptions (`description_style`).
"""

from __future__ import annotations

from pyuss.drive.database import DescriptionStyle
from pyuss.errors import ConfigError
from pyuss.profiles import Profile, get_profile
from pyuss.protocol.pkw import Pkw
from pyuss.protocol.timing import response_delay_limit

__all__ = [
    "Profile",
    "answers",
    "description_style",
    "index_base",
    "resolve_profile",
    "response_limit",
]


def resolve_profile(profile: Profile | str | None) -> Profile:
    """The profile named ``profile`` (None: ``generic``, the specification's drive profile)."""
    if profile is None:
        return get_profile("generic")
    if isinstance(profile, Profile):
        return profile
    if isinstance(profile, str):
        return get_profile(profile)
    raise ConfigError(f"profile must be a name or a pyuss.profiles.Profile, not {profile!r}")


def answers(profile: Profile, answer: Pkw, request: Pkw) -> bool:
    """True when ``answer`` belongs to ``request`` (see the module docstring)."""
    if profile.answer_index_zero:
        answer = Pkw(answer.id, answer.pnu, request.index, answer.spm_toggle, answer.values)
    if not answer.is_answer_to(request):
        return False
    return profile.page(answer.index) == profile.page(request.index)


def response_limit(profile: Profile, baud: int, limit: float | None = None) -> float:
    """How long the master waits for the start of an answer: ``limit`` if given, else the
    latest answer ``profile`` allows (its response-delay mode included); never below the start
    pause (A 5.2.1.1) - the profile's, where it asks for a longer one (Baumueller: 3 character
    times, reading 2), since the slave keeps it before its answer too."""
    if limit is None:
        limit = max(profile.response_delay(baud, delayed=True)[1], profile.response_delay(baud)[1])
    return max(response_delay_limit(baud, limit), profile.start_pause(baud))


def index_base(profile: Profile) -> int:
    """The first array index of the profile's drives (C 3.2 counts from 1; MICROMASTER 4 from 0)."""
    return profile.database().profile.index_base


def description_style(profile: Profile) -> DescriptionStyle:
    """The parameter description layout of the profile's drives (C 6; Baumueller manual 2.2.1)."""
    return profile.database().profile.description
