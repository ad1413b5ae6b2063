"""Interop with the PROFIBUS-DP master of the pyprofibus package (a test-only dependency).

pyprofibus's DP master, on its own serial PHY (which opens a serial device), opens the pty of
the simulated KS VARIO, brings it through FDL status, Slave_Diag, Set_Prm, Chk_Cfg into
Data_Exchange, and the parameter channel of module A.1 moves data through it; pyprofibus's GSD
parser reads the emitted GSD.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import pyprofibus
import pyprofibus.gsd.interp as gsd_interp
import pytest
from ksvario_sim import SlaveThread

from pyuss.ksvario.address import Address
from pyuss.ksvario.channel import ChannelClient, DataFormat
from pyuss.ksvario.coupler import CacheSelection, Coupler
from pyuss.ksvario.gsd import emit_gsd
from pyuss.ksvario.modules import Configuration

STATION = 8


def _write_conf(
    tmp: Path,
    device: str,
    gsd: Path,
    modules: tuple[str, ...] = (
        "A.1: General-Parameter channel",
        "B.1: I/O - 1 word IN",
        "B.6: I/O - 1 word OUT",
    ),
    sizes: tuple[int, int] = (10, 10),
) -> Path:
    """A pyprofibus configuration: ``sizes`` are (input_size, output_size) as pyprofibus
    counts them, from the slave's side (input = master -> slave)."""
    conf = tmp / "ksvario.conf"
    conf.write_text(
        "\n".join(
            [
                "[PROFIBUS]",
                "debug=0",
                "[PHY]",
                "type=serial",
                f"dev={device}",
                "baud=19200",
                "[DP]",
                "master_class=1",
                "master_addr=2",
                "[SLAVE_0]",
                "name=ksvario",
                f"addr={STATION}",
                f"gsd={gsd}",
                "sync_mode=0",
                "freeze_mode=0",
                "group_mask=1",
                "watchdog_ms=2000",
                *(f"module_{i}={name}" for i, name in enumerate(modules)),
                f"input_size={sizes[0]}",
                f"output_size={sizes[1]}",
                "",
            ]
        ),
        encoding="utf-8",
    )
    return conf


def test_pyprofibus_gsd_parser_reads_the_emitted_gsd(tmp_path: Path) -> None:
    path = tmp_path / "PMA_1030.gsd"
    path.write_text(emit_gsd(), encoding="ascii", newline="")
    gsd: Any = gsd_interp.GsdInterp.fromFile(str(path))
    assert gsd.getIdentNumber() == 0x1030
    assert gsd.isModular()
    assert len(gsd.getField("Module")) == 17
    gsd.setConfiguredModule("A.1: General-Parameter channel")
    gsd.setConfiguredModule("B.10: I/O - 16 words OUT")
    assert [e.getDU() for e in gsd.getCfgDataElements()] == [b"\xf3", b"\x6f"]
    assert gsd.getUserPrmData() == bytes(4)


@pytest.mark.pty
def test_pyprofibus_master_reaches_data_exchange_and_moves_channel_data(tmp_path: Path) -> None:
    gsd_path = tmp_path / "PMA_1030.gsd"
    gsd_path.write_text(emit_gsd(), encoding="ascii", newline="")
    coupler = Coupler(selection=CacheSelection(free_read=((1, 0x01),), free_write=((1, 0x10),)))
    coupler.set(Address.channel(1, 0x96), 123.4)  # Pb1 of channel 1, example 4.5.1
    coupler.set(Address.channel(1, 0x01), 21.5)  # read cache entry 1 -> module B.1
    with SlaveThread(coupler, STATION) as sim:
        conf = pyprofibus.PbConf.fromFile(str(_write_conf(tmp_path, sim.device, gsd_path)))
        master = conf.makeDPM()
        try:
            desc = conf.slaveConfs[0].makeDpSlaveDesc()
            master.addSlave(desc)
            master.initialize()
            jobs = [
                ("read", DataFormat.INTEGER, 0x4496, 1),
                ("write", DataFormat.REAL, 0xFD09, [1.5, 2.5, 3.5]),
                ("read", DataFormat.REAL, 0xFD09, 3),
            ]
            client = ChannelClient(timeout=20.0)
            results: list[list[Any]] = []
            b1_word: int | None = None
            out_word = bytes.fromhex("0064")  # 10.0 to write cache entry 1 via B.6
            started = False
            deadline = time.monotonic() + 60
            while time.monotonic() < deadline:
                if not started or (client.status.done and jobs):
                    if started:
                        assert client.result == 0, client.status.describe()
                        results.append(client.values)
                    kind, fmt, addr, arg = jobs.pop(0)
                    if kind == "read":
                        client.start_read(fmt, addr, arg, time.monotonic())
                    else:
                        client.start_write(fmt, addr, arg, time.monotonic())
                    started = True
                if client.status.done and not jobs:
                    results.append(client.values)
                    break
                desc.setMasterOutData(bytearray(client.request() + out_word))
                handled = master.run()
                if handled is not None:
                    data = handled.getMasterInData()
                    if data is not None:
                        client.feed(bytes(data[:8]), time.monotonic())
                        b1_word = int.from_bytes(data[8:10], "big")
            else:
                pytest.fail(f"not finished: {client.status.describe()}")
        finally:
            master.destroy()
    assert sim.error is None
    assert results[0] == [1234]
    assert results[2] == [1.5, 2.5, 3.5]
    assert coupler.get(Address.channel(30, 0x85)) == 2.5
    assert b1_word == 215
    assert coupler.get(Address.channel(1, 0x10)) == 10.0


class CountingCoupler(Coupler):
    """The simulated coupler, counting the configurations (Chk_Cfg) it takes."""

    configured = 0

    def configure(self, configuration: Configuration) -> None:
        self.configured += 1
        super().configure(configuration)


@pytest.mark.pty
def test_pyprofibus_master_drives_an_output_only_configuration(tmp_path: Path) -> None:
    """With output modules only the coupler has no input bytes: it acknowledges Data_Exchange
    with the short acknowledgement E5, which is what pyprofibus's master waits for. Twenty
    output words reach the coupler in one data exchange phase (a master that missed its
    answers would give up on the slave and parameterise it again)."""
    gsd_path = tmp_path / "PMA_1030.gsd"
    gsd_path.write_text(emit_gsd(), encoding="ascii", newline="")
    coupler = CountingCoupler(selection=CacheSelection(free_write=((1, 0x10),)))
    modules = ("B.6: I/O - 1 word OUT",)
    with SlaveThread(coupler, STATION) as sim:
        path = _write_conf(tmp_path, sim.device, gsd_path, modules, (2, 0))
        conf = pyprofibus.PbConf.fromFile(str(path))
        master = conf.makeDPM()
        try:
            desc = conf.slaveConfs[0].makeDpSlaveDesc()
            master.addSlave(desc)
            master.initialize()
            deadline = time.monotonic() + 60
            for word in range(1, 21):
                while coupler.get(Address.channel(1, 0x10)) != word / 10:
                    assert time.monotonic() < deadline, f"word {word} never reached the coupler"
                    desc.setMasterOutData(bytearray(word.to_bytes(2, "big")))
                    master.run()
        finally:
            master.destroy()
    assert sim.error is None
    assert coupler.configured == 1
