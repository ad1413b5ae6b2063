"""The DP slave state machine of the simulated KS VARIO, pure (time is passed in).

`DpSlave.handle(frame, now)` takes one FDL request addressed to the station and returns the
bytes to send back (or None). The services a DP master uses at start-up and in operation:

* FDL status (FC 49h)             -> SD1 with FC 00h (slave, ready);
* Slave_Diag (DSAP 60)            -> the diagnosis of `pyuss.ksvario.diag` (6 or 15 bytes);
* Set_Prm (DSAP 61)               -> E5; checks ident number 1030h and the 4 user parameter
                                     bytes (interface description 6); a fault is reported in the
                                     diagnosis;
* Chk_Cfg (DSAP 62)               -> E5; validates the modules by the interface description's rules
  (3.1);
* Get_Cfg (DSAP 59)               -> the configuration bytes;
* Global_Control (DSAP 58, SDN)   -> no answer; Clear_Data applies the fail-safe, freeze and
                                     sync are reflected in the diagnosis;
* Rd_Inp / Rd_Outp (DSAP 56 / 57) -> the current input / output image;
* Data_Exchange (no SAP)          -> the input image with FC DL, or DH while the diagnosis
                                     differs from what the master last read (new diagnosis
                                     waits); a configuration without input bytes is answered
                                     with the short acknowledgement E5 (SD1 with DH when new
                                     diagnosis waits).

States follow the DP slave: WAIT_PRM -> WAIT_CFG -> DATA_EXCH. Data_Exchange outside
DATA_EXCH is answered RS (service not activated). With FCV set, a request whose FCB equals
the previous one from the same master is a repetition: the stored answer is sent again without
acting twice. A repetition repeats the telegram, so a request with the same FCB but other
content is taken as new (some masters, pyprofibus among them, do not toggle FCB after a short
acknowledgement). The watchdog (Set_Prm WD_On, 10 ms x factor 1 x factor 2) drops a slave that
hears nothing from its master back to WAIT_PRM and applies the fail-safe (interface description
2.4).
"""

from __future__ import annotations

import enum
import logging

from pyuss.errors import ConfigError
from pyuss.ksvario.coupler import Coupler
from pyuss.ksvario.diag import IDENT_NUMBER, NO_MASTER, Diagnosis, Status1, Status2
from pyuss.ksvario.dp.fdl import BROADCAST, FC, SAP, SC, Frame
from pyuss.ksvario.modules import Configuration, chk_cfg_bytes
from pyuss.ksvario.userprm import DiagnosisFormat, UserParameters

log = logging.getLogger("pyuss.ksvario.dp")

_ACK = bytes((SC,))
_STA_WD = 0x08
_STA_FREEZE = 0x10
_STA_SYNC = 0x20
_GC_CLEAR = 0x02
_GC_UNFREEZE = 0x04
_GC_FREEZE = 0x08
_GC_UNSYNC = 0x10
_GC_SYNC = 0x20


class State(enum.Enum):
    WAIT_PRM = "wait for parameters"
    WAIT_CFG = "wait for configuration"
    DATA_EXCH = "data exchange"


class DpSlave:
    """A PROFIBUS-DP slave in front of a `Coupler` (see module docstring)."""

    def __init__(self, coupler: Coupler, address: int, *, ident: int = IDENT_NUMBER) -> None:
        if not 0 <= address <= 125:
            raise ConfigError(f"station address {address} is out of range 0..125")
        self.coupler = coupler
        self.address = address
        self.ident = ident
        self.state = State.WAIT_PRM
        self.master: int | None = None
        self.status1 = Status1.STATION_NOT_READY
        self.prm_req = True
        self.watchdog: float | None = None
        self.freeze = False
        self.sync = False
        self.group = 0
        self._diag_read = b""
        self.outputs = b""
        self.inputs = b""
        self.last_seen = 0.0
        self.exchanges = 0
        self._last_fcb: dict[int, int] = {}
        self._last_request: dict[int, Frame] = {}
        self._last_answer: dict[int, bytes] = {}
        self._expected_cfg: Configuration | None = None

    # ------------------------------------------------------------------ diagnosis
    def diagnosis(self) -> Diagnosis:
        status1 = self.status1
        device = None
        if self.coupler.user.diagnosis is DiagnosisFormat.EXTENDED:
            device = self.coupler.device_diagnosis()
            if device.any_fault:
                status1 |= Status1.EXT_DIAG
        status2 = Status2.ALWAYS_ONE
        if self.prm_req:
            status2 |= Status2.PRM_REQ
        if self.watchdog is not None and self.state is not State.WAIT_PRM:
            status2 |= Status2.WD_ON
        if self.freeze:
            status2 |= Status2.FREEZE_MODE
        if self.sync:
            status2 |= Status2.SYNC_MODE
        master = self.master if self.master is not None else NO_MASTER
        return Diagnosis(
            status1, status2, master_address=master, ident_number=self.ident, device=device
        )

    # ------------------------------------------------------------------ time
    def tick(self, now: float) -> None:
        """Check the watchdog; call it regularly."""
        if (
            self.state is State.DATA_EXCH
            and self.watchdog is not None
            and now - self.last_seen > self.watchdog
        ):
            log.info("watchdog expired: fail-safe, waiting for parameters")
            self._lose_master()

    def _lose_master(self) -> None:
        self.coupler.bus_failure()
        self.state = State.WAIT_PRM
        self.status1 = Status1.STATION_NOT_READY
        self.prm_req = True
        self.master = None

    # ------------------------------------------------------------------ requests
    def handle(self, frame: Frame, now: float) -> bytes | None:
        """Answer one received frame; None when nothing is to be sent."""
        if not frame.is_request or frame.sd not in (0x10, 0x68, 0xA2):
            return None
        if frame.da == BROADCAST:
            if frame.dsap == SAP.GLOBAL_CONTROL:
                self._global_control(frame)
            return None
        if frame.da != self.address:
            return None
        self.tick(now)
        if frame.function == FC.FDL_STATUS:
            return Frame(0x10, frame.sa, self.address, FC.OK).encode()
        if frame.function not in (FC.SRD_HI, FC.SRD_LO, FC.SDN_HI, FC.SDN_LO):
            return self._reply(frame, FC.RS)
        if self.master is not None and frame.sa == self.master:
            self.last_seen = now
        fcb = frame.fc & FC.FCB
        if frame.fc & FC.FCV:
            if (
                self._last_fcb.get(frame.sa) == fcb
                and self._last_request.get(frame.sa) == frame
                and frame.sa in self._last_answer
            ):
                return self._last_answer[frame.sa]  # a repetition: answer again, act once
            self._last_fcb[frame.sa] = fcb
        else:
            self._last_fcb.pop(frame.sa, None)
        self._last_request[frame.sa] = frame
        answer = self._dispatch(frame, now)
        if frame.function in (FC.SDN_HI, FC.SDN_LO):
            return None
        if answer is not None:
            self._last_answer[frame.sa] = answer
        return answer

    def _reply(self, frame: Frame, fc: int, du: bytes = b"", sap: int | None = None) -> bytes:
        if sap is None or frame.ssap is None:
            return Frame(0x10, frame.sa, self.address, fc, du).encode()
        return Frame(0x68, frame.sa, self.address, fc, du, dsap=frame.ssap, ssap=sap).encode()

    def _dispatch(self, frame: Frame, now: float) -> bytes | None:
        sap = frame.dsap
        if sap is None:
            return self._data_exchange(frame, now)
        if sap == SAP.SLAVE_DIAG:
            self._diag_read = self.diagnosis().encode()
            return self._reply(frame, FC.DL, self._diag_read, SAP.SLAVE_DIAG)
        if sap == SAP.SET_PRM:
            self._set_prm(frame, now)
            return _ACK
        if sap == SAP.CHK_CFG:
            self._chk_cfg(frame)
            return _ACK
        if sap == SAP.GET_CFG:
            conf = self.coupler.configuration
            data = chk_cfg_bytes(conf.modules) if conf is not None else b""
            return self._reply(frame, FC.DL, data, SAP.GET_CFG)
        if sap == SAP.GLOBAL_CONTROL:
            self._global_control(frame)
            return None
        if sap == SAP.READ_INPUTS:
            return self._reply(frame, FC.DL, self.inputs, SAP.READ_INPUTS)
        if sap == SAP.READ_OUTPUTS:
            return self._reply(frame, FC.DL, self.outputs, SAP.READ_OUTPUTS)
        return self._reply(frame, FC.RS)

    def _set_prm(self, frame: Frame, now: float) -> None:
        du = frame.du
        self.status1 = Status1.STATION_NOT_READY
        if len(du) < 7:
            self._prm_fault(f"Set_Prm with {len(du)} bytes, at least 7 needed")
            return
        ident = (du[4] << 8) | du[5]
        if ident != self.ident:
            self._prm_fault(f"Set_Prm for ident {ident:04X}h, this is {self.ident:04X}h")
            return
        try:
            user = UserParameters.decode(du[7:])
        except ConfigError as exc:
            self._prm_fault(str(exc))
            return
        self.coupler.set_user_parameters(user)
        status = du[0]
        self.watchdog = (du[1] * du[2] * 0.01) if status & _STA_WD else None
        self.group = du[6]
        self.master = frame.sa
        self.last_seen = now
        self.prm_req = False
        self.state = State.WAIT_CFG
        log.info("parameterised by master %d: %s", frame.sa, user.describe())

    def _prm_fault(self, why: str) -> None:
        log.warning("parameterisation refused: %s", why)
        self.status1 = Status1.STATION_NOT_READY | Status1.PRM_FAULT
        self.prm_req = True
        self.state = State.WAIT_PRM

    def _chk_cfg(self, frame: Frame) -> None:
        if self.state is State.WAIT_PRM:
            return
        try:
            conf = Configuration.from_chk_cfg(frame.du)
        except ConfigError as exc:
            log.warning("configuration refused: %s", exc)
            self.status1 = Status1.STATION_NOT_READY | Status1.CFG_FAULT
            self.prm_req = True
            self.state = State.WAIT_PRM
            return
        self.coupler.configure(conf)
        self.outputs = bytes(conf.output_bytes)
        self.inputs = self.coupler.exchange(self.outputs, self.last_seen)
        self.status1 = Status1.NONE
        self.state = State.DATA_EXCH
        log.info("configured: %s", ", ".join(m.key for m in conf.modules))

    def _global_control(self, frame: Frame) -> None:
        if len(frame.du) < 2:
            return
        command, groups = frame.du[0], frame.du[1]
        if groups and not groups & self.group:
            return
        if command & _GC_CLEAR and self.state is State.DATA_EXCH:
            self.coupler.bus_failure()
        if command & _GC_FREEZE:
            self.freeze = True
        if command & _GC_UNFREEZE:
            self.freeze = False
        if command & _GC_SYNC:
            self.sync = True
        if command & _GC_UNSYNC:
            self.sync = False

    def _data_exchange(self, frame: Frame, now: float) -> bytes:
        if self.state is not State.DATA_EXCH:
            return self._reply(frame, FC.RS)
        conf = self.coupler.configuration
        assert conf is not None
        if len(frame.du) != conf.output_bytes:
            log.warning(
                "Data_Exchange with %d output bytes, %d configured",
                len(frame.du),
                conf.output_bytes,
            )
            return self._reply(frame, FC.UE)
        self.outputs = frame.du
        self.inputs = self.coupler.exchange(frame.du, now)
        self.exchanges += 1
        if self.diag_pending:
            return self._reply(frame, FC.DH, self.inputs)
        if not self.inputs:
            return _ACK
        return self._reply(frame, FC.DL, self.inputs)

    @property
    def diag_pending(self) -> bool:
        """New diagnosis waits: it differs from what the master last read with Slave_Diag."""
        return self.diagnosis().encode() != self._diag_read
