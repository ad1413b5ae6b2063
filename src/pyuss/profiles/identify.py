"""Which drive family a drive is, from what it shows in its parameters.

A profile's `pyuss.profiles.base.IdentityRule`s say what a drive of the family answers: the
Siemens families show the manufacturer (42) and the product type in r0964 (1 = MICROMASTER 420,
2 = MICROMASTER 440), the V20 has P2023 (RS-485 protocol selection), a NORD SK 500E has P743
(inverter type) and P707 (software version) and no r0964. `identify` reads the parameters the
rules name through a function the caller gives (the master's parameter read, or a simulated
drive's), in a fixed order, each at most once, and returns the first family all of whose rules
hold. A Siemens drive of the MICROMASTER 4 kind that no family rule names (G110, G120: the
project knows no product type numbers for them) is reported as such, with ``micromaster4`` as
the profile to talk to it with.

Nothing here does I/O itself: ``read(pnu, index)`` returns the value, or None when the drive
refuses the job (error 0, illegal parameter number, and every other refusal).
"""

from __future__ import annotations

from collections.abc import Awaitable, Callable, Iterable
from dataclasses import dataclass

from pyuss.profiles.base import IdentityRule, Profile

__all__ = ["Identity", "Reader", "identify", "identity_parameters"]

Reader = Callable[[int, int | None], Awaitable[float | None]]
"""``read(pnu, index)``: the value of a parameter (element ``index``), None if refused."""

_SIEMENS_KIND = IdentityRule(964, 0, frozenset({42}))
"""r0964[0] = 42: a Siemens drive of the MICROMASTER 4 kind (parameter pages in IND)."""


@dataclass(frozen=True, slots=True)
class Identity:
    """What `identify` found out."""

    family: str | None
    """The profile name of the family (``sinamics-v20`` ...), None when not known."""
    profile: str | None
    """The profile to talk to the drive with: the family's, or ``micromaster4`` for a Siemens
    drive of that kind whose family is not known; None when nothing is known."""
    evidence: tuple[tuple[int, int | None, float | None], ...]
    """The parameters read: (PNU, index, value or None if refused)."""

    @property
    def text(self) -> str:
        """A short description for people ("SINAMICS V20", "Siemens, MICROMASTER 4 kind")."""
        if self.family is not None:
            from pyuss.profiles import get_profile

            return get_profile(self.family).title
        if self.profile is not None:
            product = next((v for p, i, v in self.evidence if (p, i) == (964, 1)), None)
            what = "" if product is None else f", product type {int(product)}"
            return f"Siemens, MICROMASTER 4 kind{what}"
        return "unknown"


def identity_parameters(profiles: Iterable[Profile]) -> list[tuple[int, int | None]]:
    """The parameters `identify` may read for ``profiles``, in reading order."""
    seen: list[tuple[int, int | None]] = []
    for profile in profiles:
        for rule in profile.identity:
            key = (rule.pnu, rule.index)
            if key not in seen:
                seen.append(key)
    return seen


async def identify(read: Reader, profiles: Iterable[Profile] | None = None) -> Identity:
    """The family of the drive behind ``read`` among ``profiles`` (default: every built-in
    profile that has identity rules), see the module docstring."""
    if profiles is None:
        from pyuss.profiles import PROFILES

        profiles = PROFILES.values()
    candidates = [p for p in profiles if p.identity]
    cache: dict[tuple[int, int | None], float | None] = {}

    async def value(rule: IdentityRule) -> float | None:
        key = (rule.pnu, rule.index)
        if key not in cache:
            cache[key] = await read(rule.pnu, rule.index)
        return cache[key]

    found: str | None = None
    for profile in candidates:
        for rule in profile.identity:
            if not rule.matches(await value(rule)):
                break
        else:
            found = profile.name
            break
    kind = None
    if found is None and _SIEMENS_KIND.matches(await value(_SIEMENS_KIND)):
        kind = "micromaster4"
    evidence = tuple((pnu, index, v) for (pnu, index), v in cache.items())
    return Identity(found, found or kind, evidence)
