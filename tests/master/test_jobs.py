"""Parameter jobs (C 4.2.1.1, C 4.2.1.2): one job at a time, repeated until its own answer,
old answers not taken for new ones, spontaneous messages, refusals, concurrency."""

from __future__ import annotations

import asyncio
import contextlib

import pytest

from pyuss.errors import ConfigError, DriveRefusal
from pyuss.master import JobTimeout, NoWriteAuthority, SpontaneousMessage
from pyuss.master.jobs import Job, ParameterChannel
from pyuss.master.process import OPERATE
from pyuss.profiles import get_profile
from pyuss.protocol.layout import Layout
from pyuss.protocol.pkw import Pkw, RequestId, ResponseId, pwe_float
from pyuss.protocol.pzd import ControlWord
from support.buses import scripted_bus

GENERIC = get_profile("generic")


def _job(request: Pkw, results: list[Job], timeout: float = 1.0) -> Job:
    return Job(request, request.pnu, None, timeout, results.append)


# -- the channel alone (pure) ---------------------------------------------------------------


def test_a_job_is_repeated_until_its_own_answer_arrives() -> None:
    channel = ParameterChannel(5, GENERIC)
    done: list[Job] = []
    channel.answer(Pkw(ResponseId.NO_RESPONSE), 0.0)
    channel.submit(_job(Pkw(RequestId.READ_VALUE, 52), done))
    assert channel.request(0.1) == Pkw(RequestId.READ_VALUE, 52)
    channel.answer(Pkw(ResponseId.NO_RESPONSE), 0.1)  # not processed yet
    assert channel.request(0.2) == Pkw(RequestId.READ_VALUE, 52)
    channel.answer(Pkw(ResponseId.VALUE_WORD, 53, values=(1,)), 0.2)  # another parameter
    assert not done
    assert channel.request(0.3) == Pkw(RequestId.READ_VALUE, 52)
    channel.answer(Pkw(ResponseId.VALUE_WORD, 52, values=(7,)), 0.3)
    assert done and done[0].answer == Pkw(ResponseId.VALUE_WORD, 52, values=(7,))
    assert done[0].sent == 3
    assert channel.request(0.4) == Pkw(RequestId.NO_JOB)


def test_no_job_is_sent_between_jobs_whose_answers_could_be_confused() -> None:
    channel = ParameterChannel(5, GENERIC)
    done: list[Job] = []
    channel.answer(Pkw(ResponseId.NO_RESPONSE), 0.0)
    channel.submit(_job(Pkw(RequestId.WRITE_WORD, 52, values=(5,)), done))
    channel.submit(_job(Pkw(RequestId.READ_VALUE, 52), done))
    channel.submit(_job(Pkw(RequestId.READ_VALUE, 53), done))
    assert channel.request(0.0).id == RequestId.WRITE_WORD
    channel.answer(Pkw(ResponseId.VALUE_WORD, 52, values=(5,)), 0.0)
    # "read P52" would accept the answer (ID 1, PNU 52) still being repeated: no job first.
    assert channel.request(0.1) == Pkw(RequestId.NO_JOB)
    channel.answer(Pkw(ResponseId.VALUE_WORD, 52, values=(5,)), 0.1)  # old answer again
    assert channel.request(0.2) == Pkw(RequestId.NO_JOB)
    channel.answer(Pkw(ResponseId.NO_RESPONSE), 0.2)
    assert channel.request(0.3) == Pkw(RequestId.READ_VALUE, 52)
    channel.answer(Pkw(ResponseId.VALUE_WORD, 52, values=(5,)), 0.3)
    # "read P53" cannot take "ID 1 PNU 52" for its answer: it follows at once.
    assert channel.request(0.4) == Pkw(RequestId.READ_VALUE, 53)
    assert channel.stats().guard_telegrams == 2


def test_the_first_job_waits_for_a_known_answer() -> None:
    channel = ParameterChannel(5, GENERIC)
    done: list[Job] = []
    channel.submit(_job(Pkw(RequestId.READ_VALUE, 52), done))
    assert channel.request(0.0) == Pkw(RequestId.NO_JOB)  # nothing known of the slave yet


def test_a_job_times_out_and_leaves_the_answer_unknown() -> None:
    channel = ParameterChannel(5, GENERIC)
    done: list[Job] = []
    channel.answer(Pkw(ResponseId.NO_RESPONSE), 0.0)
    channel.submit(_job(Pkw(RequestId.READ_VALUE, 52), done, timeout=0.5))
    channel.request(0.0)
    channel.request(0.4)
    channel.expire(0.6)
    assert isinstance(done[0].error, JobTimeout)
    assert "2 telegrams sent" in str(done[0].error)
    assert channel.last_answer is None


def test_a_timeout_names_the_parameter_as_the_family_writes_it_and_what_to_do() -> None:
    from pyuss.profiles import get_profile

    channel = ParameterChannel(5, get_profile("sinamics-v20"))
    done: list[Job] = []
    channel.answer(Pkw(ResponseId.NO_RESPONSE), 0.0)
    channel.submit(_job(Pkw(RequestId.READ_VALUE, 52), done, timeout=0.5))
    channel.request(0.0)
    channel.expire(0.6)
    assert str(done[0].error) == (
        "slave 5: no answer to read parameter value r0052 within 0.5 s (1 telegrams sent; "
        "C 4.2.1.1): the drive answers, but not this job: allow it more time, or repeat it"
    )


def test_spontaneous_messages_are_new_only_when_the_toggle_changes() -> None:
    channel = ParameterChannel(5, GENERIC)
    assert channel.answer(Pkw(ResponseId.NO_RESPONSE), 0.0) is None
    assert channel.toggle is False
    message = channel.answer(
        Pkw(ResponseId.SPONTANEOUS_WORD, 52, spm_toggle=True, values=(9,)), 0.1
    )
    assert message is not None and message.pnu == 52 and message.value == 9
    assert channel.toggle is True  # acknowledged in the next request
    assert channel.request(0.2).spm_toggle is True
    assert (
        channel.answer(Pkw(ResponseId.SPONTANEOUS_WORD, 52, spm_toggle=True, values=(9,)), 0.2)
        is None
    )
    second = channel.answer(
        Pkw(ResponseId.SPONTANEOUS_DWORD, 60, spm_toggle=False, values=(1, 2)), 0.3
    )
    assert second is not None and second.value == 0x0001_0002
    assert channel.toggle is False


def test_the_toggle_starts_from_the_slave_and_a_first_message_is_delivered() -> None:
    channel = ParameterChannel(5, GENERIC)
    channel.answer(Pkw(ResponseId.NO_RESPONSE, spm_toggle=True), 0.0)
    assert channel.toggle is True
    fresh = ParameterChannel(5, GENERIC)
    message = fresh.answer(Pkw(ResponseId.SPONTANEOUS_WORD, 52, spm_toggle=False, values=(1,)), 0.0)
    assert message is not None and fresh.toggle is False


def test_a_spontaneous_message_does_not_count_as_the_slaves_latest_answer() -> None:
    channel = ParameterChannel(5, GENERIC)
    done: list[Job] = []
    channel.answer(Pkw(ResponseId.NO_RESPONSE), 0.0)
    channel.submit(_job(Pkw(RequestId.WRITE_WORD, 52, values=(5,)), done))
    channel.request(0.0)
    channel.answer(Pkw(ResponseId.VALUE_WORD, 52, values=(5,)), 0.0)
    channel.answer(Pkw(ResponseId.SPONTANEOUS_WORD, 18, spm_toggle=True, values=(1,)), 0.1)
    channel.submit(_job(Pkw(RequestId.READ_VALUE, 52), done))
    # After the message the slave goes back to repeating "ID 1 PNU 52": still guarded.
    assert channel.request(0.2).id == RequestId.NO_JOB


# -- over the virtual bus -------------------------------------------------------------------


async def test_read_and_write_words_double_words_and_floats() -> None:
    async with scripted_bus((5,), layout=Layout(4, 2)) as env:
        drive = env.master.drive(5)
        assert await drive.read(52) == 0x4000
        assert await drive.write(18, 0x7000) == 0x7000
        assert env.slaves[5].params[18] == 0x7000
        assert await drive.write(60, 0x1234_5678) == 0x1234_5678
        assert await drive.read(60) == 0x1234_5678
        assert await drive.write(60, 50.0) == 50.0
        assert await drive.read_raw(60) == pwe_float(50.0)
        assert await drive.write_raw(60, (0, 7)) == (0, 7)  # a small value as a double word
        assert env.slaves[5].dwords[60] == 7
        assert await drive.write(18, -2) == -2
        assert await drive.read(18) == 0xFFFE  # nothing known of P18: the word as sent
        assert await drive.read_raw(18) == (0xFFFE,)


async def test_array_elements_and_length_counting_from_the_profile_base() -> None:
    async with scripted_bus((5,)) as env:
        drive = env.master.drive(5)
        assert await drive.array_length(4) == 3
        assert await drive.read(4, 2) == 2
        assert await drive.write(4, 9, 3) == 9
        assert env.slaves[5].arrays[4] == [1, 2, 9]
        assert await drive.read_array(4) == [1, 2, 9]


async def test_whole_array_in_one_telegram_with_the_variable_layout() -> None:
    async with scripted_bus((5,), layout=Layout(127, 2)) as env:
        drive = env.master.drive(5)
        count = len(env.slaves[5].log.requests)
        assert await drive.read_array(4) == [1, 2, 3]
        # the guard's "no job" and the job itself, no element-by-element reads
        assert len(env.slaves[5].log.requests) - count <= 4


async def test_refusals_are_typed_with_number_and_meaning() -> None:
    async with scripted_bus((5,)) as env:
        drive = env.master.drive(5)
        with pytest.raises(DriveRefusal) as info:
            await drive.read(999)
        assert info.value.number == 0
        assert info.value.meaning == "illegal parameter number"
        assert info.value.pnu == 999
        with pytest.raises(DriveRefusal, match="parameter cannot be changed"):
            await drive.write(53, 1)
        env.slaves[5].no_authority = True
        with pytest.raises(NoWriteAuthority, match="no parameter change rights for P52"):
            await drive.write(52, 1)
        assert await drive.read(52) == 0x4000  # reading still works


async def test_a_new_answer_is_not_mistaken_for_the_old_one_of_a_slow_slave() -> None:
    async with scripted_bus((5,)) as env:
        env.slaves[5].lag = 4  # a new job is answered after the 5th telegram carrying it
        drive = env.master.drive(5)
        seen: list[int] = []

        async def write(value: int) -> None:
            seen.append(await drive.write(52, value))
            seen.append(env.slaves[5].params[52])  # what the slave really holds at that moment

        await asyncio.gather(write(5), write(6))
        assert seen == [5, 5, 6, 6]
        assert await drive.read(52) == 6
        assert drive.diagnostics().jobs.guard_telegrams >= 2


async def test_spontaneous_messages_are_handed_on_once_and_acknowledged() -> None:
    async with scripted_bus((5,)) as env:
        drive = env.master.drive(5)
        messages: list[SpontaneousMessage] = []
        everywhere: list[SpontaneousMessage] = []
        drive.on_spontaneous(messages.append)
        env.master.on_spontaneous(everywhere.append)
        await drive.read(52)
        env.slaves[5].lag = 3
        env.slaves[5].push_spontaneous(52, 0x0123)
        env.slaves[5].push_spontaneous(18, 0x0456)
        assert await drive.read(53) == 7  # the job goes on after the messages
        for _ in range(5):
            await drive.next_update()
        assert [(m.pnu, m.value) for m in messages] == [(52, 0x0123), (18, 0x0456)]
        assert everywhere == messages
        assert not env.slaves[5].spontaneous and env.slaves[5]._pending is None  # both acknowledged
        assert drive.diagnostics().jobs.spontaneous == 2


async def test_concurrent_jobs_from_many_tasks_queue_and_do_not_interleave() -> None:
    async with scripted_bus((1, 2), layout=Layout(4, 2)) as env:
        one, two = env.master.drive(1), env.master.drive(2)
        for slave in env.slaves.values():
            slave.params.update({100 + i: i for i in range(10)})
            slave.lag = 1

        async def work(drive, base: int) -> list[int]:  # type: ignore[no-untyped-def]
            out = []
            for i in range(3):
                out.append(await drive.write(100 + (base + i) % 10, base * 10 + i))
                out.append(await drive.read(100 + (base + i) % 10))
            return out

        results = await asyncio.gather(*(work(one if k % 2 else two, k) for k in range(6)))
        for k, values in enumerate(results):
            assert values == [k * 10, k * 10, k * 10 + 1, k * 10 + 1, k * 10 + 2, k * 10 + 2]
        # every telegram carried at most one job, and each job was repeated until answered
        for slave in env.slaves.values():
            assert slave.log.requests


async def test_a_job_for_a_silent_slave_times_out() -> None:
    async with scripted_bus((5,)) as env:
        env.slaves[5].silent = True
        drive = env.master.drive(5)
        with pytest.raises(JobTimeout) as silence:
            await drive.read(52, timeout=0.3)
        assert str(silence.value) == (
            "slave 5 does not answer (no reply within 0.3 s): check address, baud rate and "
            "wiring (USS specification A 5.2.1.1: the slave does not send)"
        )
        env.slaves[5].silent = False
        assert await drive.read(52) == 0x4000
        env.slaves[5].silent = True  # it answered before: the job may be what it ignores
        with pytest.raises(JobTimeout) as silence:
            await drive.read(53, timeout=0.3)  # sent at once: no answer to take for its own
        assert str(silence.value).startswith(
            "slave 5 has stopped answering: no reply to read parameter value P53 within 0.3 s"
        )
        assert "check the wiring, and whether the drive knows this request" in str(silence.value)


async def test_reading_parameters_never_changes_the_control_word() -> None:
    async with scripted_bus((5,)) as env:
        drive = env.master.drive(5)
        await drive.on()
        await drive.setpoint(50.0)
        start = len(env.slaves[5].log.requests)
        for pnu in (52, 53, 999):
            with contextlib.suppress(DriveRefusal):
                await drive.read(pnu)
        layout = Layout(3, 2)
        words = {layout.unpack(t.data).pzd for t in env.slaves[5].log.requests[start:]}
        assert words == {(int(OPERATE | ControlWord.ON), 0x2000)}


async def test_process_data_commands_build_the_profile_control_words() -> None:
    async with scripted_bus((5,)) as env:
        drive = env.master.drive(5)
        sent: list[int] = []
        layout = Layout(3, 2)
        env.slaves[5].on_request = lambda t: sent.append(layout.unpack(t.data).pzd[0])
        assert drive.control == 0  # no control by the interface until told (C Table 5.4)
        status = await drive.on()
        assert status.control == 0x047F
        assert 0x047E in sent  # OFF1 first: leaves "switch-on inhibited"
        assert (await drive.off1()).control == 0x047E
        assert (await drive.off2()).control == 0x047C
        assert (await drive.off3()).control == 0x047A
        await drive.on()
        assert (await drive.enable(False)).control == 0x0477
        assert (await drive.enable()).control == 0x047F
        sent.clear()
        assert (await drive.acknowledge()).control == 0x047F
        assert 0x04FF in sent  # rising edge of bit 7
        assert (await drive.jog(1)).control == 0x057F
        assert (await drive.jog(None)).control == 0x047F
        status = await drive.setpoint(raw=0x1234)
        assert drive.setpoints == (0x1234,)
        assert status.word == 0x0231 and status.state == "ready to switch on"


async def test_requests_the_layout_cannot_carry_are_refused_before_sending() -> None:
    async with scripted_bus((5,)) as env:
        drive = env.master.drive(5)
        with pytest.raises(ConfigError, match="double words need PKW 4"):
            await drive.write(60, 0x12345)
        with pytest.raises(ConfigError, match="variable layout"):
            await drive.read_text(7, 3)
        with pytest.raises(ConfigError, match=r"0\.\.2047"):
            await drive.read(2048)
        with pytest.raises(ConfigError, match="PZD"):
            await drive.setpoint(10.0, pzd=3)


async def test_a_cancelled_job_leaves_the_channel_usable() -> None:
    async with scripted_bus((5,)) as env:
        env.slaves[5].lag = 3
        drive = env.master.drive(5)
        with pytest.raises(TimeoutError):
            await asyncio.wait_for(drive.write(52, 9), 0.005)
        assert not drive._link.channel.busy
        assert await drive.write(52, 10) == 10
        assert await drive.read(52) == 10
