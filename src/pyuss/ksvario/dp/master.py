"""A small PROFIBUS-DP class 1 master for one KS VARIO, as a `CyclicLink`.

`DpMasterLink.connect()` runs the start-up a DP master does (FDL status, Slave_Diag, Set_Prm
with the KS VARIO user parameters, Chk_Cfg with the configured modules, Slave_Diag until the
slave is ready); `exchange()` then runs one Data_Exchange (SRD high) per call. Requests carry
FCB/FCV as the FDL layer demands (first request of a sequence FCB=1 FCV=0, then alternating
with FCV=1), a lost answer is repeated with the same FCB up to ``retries`` times.

It drives a single slave on a line and holds no token: enough for `uss ksvario read|write`
against a coupler (simulated or real) on a point-to-point line, not a bus scheduler.
"""

from __future__ import annotations

from pyuss.errors import ProtocolError, UssTimeout
from pyuss.ksvario.diag import IDENT_NUMBER, Diagnosis
from pyuss.ksvario.dp.fdl import FC, SAP, SD1, SD2, Frame, FrameReceiver
from pyuss.ksvario.modules import Configuration
from pyuss.ksvario.userprm import UserParameters
from pyuss.log import log_frame
from pyuss.transport.base import Transport

_MASTER_SAP = 62


class DpMasterLink:
    """One DP slave behind a `Transport` (see module docstring)."""

    def __init__(
        self,
        line: Transport,
        station: int,
        configuration: Configuration,
        *,
        user: UserParameters | None = None,
        master_address: int = 2,
        watchdog_ms: int = 0,
        timeout: float = 0.5,
        retries: int = 3,
    ) -> None:
        self.line = line
        self.station = station
        self.configuration = configuration
        self.user = user or UserParameters()
        self.address = master_address
        self.watchdog_ms = watchdog_ms
        self.timeout = timeout
        self.retries = retries
        self._rx = FrameReceiver()
        self._fcb = 1
        self._fcv = 0
        self.diagnosis: Diagnosis | None = None

    async def _transact(self, frame: Frame, *, fcb: bool = True) -> Frame:
        fc = frame.fc
        if fcb:
            fc |= FC.FCB if self._fcb else 0
            fc |= FC.FCV if self._fcv else 0
        raw = Frame(frame.sd, frame.da, frame.sa, fc, frame.du, frame.dsap, frame.ssap).encode()
        for _attempt in range(self.retries + 1):
            self.line.flush_input()
            self._rx.reset()
            await self.line.write(raw)
            log_frame("tx", raw, self.line.clock())
            deadline = self.line.clock() + self.timeout
            while (left := deadline - self.line.clock()) > 0:
                chunk = await self.line.read(timeout=left)
                if chunk is None:
                    break
                for answer in self._rx.feed(chunk.data):
                    log_frame("rx", answer.encode(), chunk.timestamp)
                    if answer.sd == 0xE5 or (
                        answer.da == self.address and answer.sa == self.station
                    ):
                        if fcb:
                            self._fcb ^= 1
                            self._fcv = 1
                        return answer
        raise UssTimeout(f"DP station {self.station} did not answer {self.retries + 1} times")

    def _request(self, du: bytes = b"", dsap: int | None = None) -> Frame:
        ssap = _MASTER_SAP if dsap is not None else None
        sd = SD2 if du or dsap is not None else SD1
        return Frame(sd, self.station, self.address, FC.REQ | FC.SRD_HI, du, dsap, ssap)

    async def read_diagnosis(self) -> Diagnosis:
        answer = await self._transact(self._request(dsap=SAP.SLAVE_DIAG))
        self.diagnosis = Diagnosis.decode(answer.du)
        return self.diagnosis

    async def connect(self) -> Diagnosis:
        """Bring the slave into data exchange; returns its diagnosis."""
        status = Frame(SD1, self.station, self.address, FC.REQ | FC.FDL_STATUS)
        await self._transact(status, fcb=False)
        self._fcb, self._fcv = 1, 0
        await self.read_diagnosis()
        wd = self.watchdog_ms // 10
        f1, f2 = (max(1, min(255, wd)), max(1, (wd + 254) // 255)) if wd else (1, 1)
        station_status = 0x80 | (0x08 if wd else 0)
        prm = bytes((station_status, f1, f2, 11, IDENT_NUMBER >> 8, IDENT_NUMBER & 0xFF, 0))
        prm += self.user.encode()
        ack = await self._transact(self._request(prm, SAP.SET_PRM))
        if ack.sd != 0xE5:
            raise ProtocolError(f"Set_Prm not acknowledged (FC {ack.fc:02X}h)")
        ack = await self._transact(self._request(self.configuration.chk_cfg(), SAP.CHK_CFG))
        if ack.sd != 0xE5:
            raise ProtocolError(f"Chk_Cfg not acknowledged (FC {ack.fc:02X}h)")
        diag = await self.read_diagnosis()
        if not diag.ready_for_data_exchange:
            raise ProtocolError(f"station {self.station} is not ready: {diag.describe()}")
        return diag

    async def exchange(self, outputs: bytes) -> bytes:
        """One Data_Exchange. A slave without input bytes may answer with the short
        acknowledgement; an answer with DH (new diagnosis) makes the link read the diagnosis
        (into `diagnosis`) before it returns the inputs."""
        answer = await self._transact(self._request(outputs))
        if answer.sd == 0xE5 and self.configuration.input_bytes == 0:
            return b""
        if answer.sd == 0xE5 or answer.fc & 0x0F not in (FC.DL, FC.DH):
            raise ProtocolError(
                f"Data_Exchange refused by station {self.station} (FC {answer.fc:02X}h)"
            )
        if answer.fc & 0x0F == FC.DH:
            await self.read_diagnosis()
        return answer.du
