"""Broadcast telegrams a master sends (A 3: ADR bit 5, address bits not evaluated, no answer).

Two forms exist and a profile says which its drives understand (reading 9,
`pyuss.profiles.BroadcastForm`):

- `enable_array_data`: the appendix's mechanism (C 5.2.3) - the 4-word PKW area carries a
  Broadcast Enable Array that selects the PZD words and the single bits of PZD words 1, 4 and 5
  the drives take; everything else keeps the value of their last individual telegram.
- `masked_control_data`: Baumueller's (Baumueller manual 2.2) - PZD1 is merged into each drive's
  control word through the mask in PWE1 (request ID 0; PKW 3 or 4, PZD 2 or 3); setpoints are
  not taken. With ``addresses`` the broadcast coding selects the drives that react: PZD2 (high
  word) and PZD3 (low word) hold a 32-bit mask, bit n = address n (the drives must have the
  coding switched on, P181 bit 1). With PKW 0 the control word is taken whole.

Both return the net data; `pyuss.master.Master.broadcast` puts them on the line.

In cyclic operation every individual telegram carries the master's own process data again, so
what a broadcast set stays only where the individual telegrams carry the same (for example the
ramp-enable bit that the next cycle's control words also set) - the appendix's "the signals of
the last non-broadcast telegram remain effective" works the other way round as well.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

from pyuss.errors import ConfigError
from pyuss.profiles.baumueller import address_mask, masked_control_pkw
from pyuss.protocol.broadcast import BroadcastEnableArray
from pyuss.protocol.layout import Layout

__all__ = ["enable_array_data", "masked_control_data"]


def enable_array_data(
    pzd: Sequence[int], enable: BroadcastEnableArray, layout: Layout | None = None
) -> bytes:
    """Net data of a broadcast with a Broadcast Enable Array (appendix): PKW 4 and the PZD
    words given (``layout`` default: PKW 4 and ``len(pzd)`` PZD words)."""
    layout = layout or Layout(4, len(pzd))
    if layout.pkw != 4:
        raise ConfigError(
            f"a Broadcast Enable Array needs a 4-word PKW area (C 5.2.3), not layout {layout}"
        )
    return layout.pack(enable.to_pkw(), list(pzd))


def masked_control_data(
    control: int,
    mask: int = 0xFFFF,
    *,
    layout: Layout,
    addresses: Iterable[int] | None = None,
) -> bytes:
    """Net data of Baumueller's masked control-word broadcast (Baumueller manual 2.2, reading 9)."""
    for name, word in (("control word", control), ("mask", mask)):
        if isinstance(word, bool) or not isinstance(word, int) or not 0 <= word <= 0xFFFF:
            raise ConfigError(f"{name} must be 0..FFFFh, got {word!r}")
    if layout.variable:
        raise ConfigError(
            "the masked control-word broadcast needs a fixed layout (Baumueller manual 2)"
        )
    pzd = [0] * layout.pzd
    if not pzd:
        raise ConfigError(f"layout {layout} has no PZD area for the control word")
    pzd[0] = control
    if layout.pkw == 0:
        if addresses is not None or mask != 0xFFFF:
            raise ConfigError("with PKW 0 the control word is taken whole: no mask, no addresses")
        return layout.pack(None, pzd)
    if layout.pzd < 2:
        raise ConfigError("the masked broadcast needs at least 2 PZD words (Baumueller manual 2.2)")
    if addresses is not None:
        if layout.pzd < 3:
            raise ConfigError("broadcast address coding needs 3 PZD words (Baumueller manual 2.2)")
        pzd[1], pzd[2] = address_mask(addresses)
    return layout.pack(masked_control_pkw(mask, layout.pkw), pzd)
