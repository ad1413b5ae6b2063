"""Run a command and stop it with Ctrl+C, as a Windows user in a console window does.

Runs under Windows Python (the Windows lane starts it through Wine, docs/windows-lane.md):

    python interrupt.py [--stop-after S] [--timeout S] -- PROGRAM ARGS...

PROGRAM runs on this process's console with its output on pipes; each line it prints is
passed on at once as ``out: LINE`` (stdout) or ``err: LINE`` (stderr), so that the caller can
read the address a server prints. The Ctrl+C goes when a line ``stop`` comes on this
process's stdin (or at its end, or after --stop-after seconds); it is the console's Ctrl+C
event sent to every process of the console (GenerateConsoleCtrlEvent(CTRL_C_EVENT, 0)),
which is what pressing Ctrl+C in the window does: the program (and the launcher of a
console script such as uss.exe) gets it, this process ignores it. Then the program has
--timeout seconds to end. The last line is ``result: {JSON}`` with its exit code, how
long it took to stop after the Ctrl+C, and whether it had to be killed.

Ctrl+Break (CTRL_BREAK_EVENT to a CREATE_NEW_PROCESS_GROUP child) is not what is sent:
Wine 8.0 delivers no console event but CTRL_C_EVENT (its server answers the other ones
with STATUS_NOT_IMPLEMENTED), docs/windows-lane.md.
"""

from __future__ import annotations

import sys

assert sys.platform == "win32"  # Windows only (the type checker reads it too)

# ruff: noqa: E402 - the imports follow the platform check
import argparse
import ctypes
import json
import os
import signal
import subprocess
import threading
import time


def _own_console() -> None:
    """Give this process a console of its own for the program to share.

    Under Wine, a program started from Linux with its standard streams on pipes is attached
    to no usable console: Ctrl events cannot be sent on it (ERROR_INVALID_HANDLE), and
    AllocConsole alone is refused (ERROR_ACCESS_DENIED) until FreeConsole. On Windows the
    two calls just give a new console."""
    kernel32 = ctypes.WinDLL("kernel32", use_last_error=True)
    kernel32.FreeConsole()
    if not kernel32.AllocConsole():
        raise OSError(ctypes.get_last_error(), "AllocConsole failed")


def _relay(stream: object, tag: str, lock: threading.Lock, first: threading.Event) -> None:
    for raw in iter(stream.readline, b""):  # type: ignore[attr-defined]
        line = raw.decode(errors="replace").rstrip("\r\n")
        with lock:
            print(f"{tag}: {line}", flush=True)
        if tag == "out":
            first.set()


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("--stop-after", type=float, default=None)
    parser.add_argument("--timeout", type=float, default=20.0)
    parser.add_argument("command", nargs=argparse.REMAINDER)
    args = parser.parse_args()
    command = args.command[1:] if args.command[:1] == ["--"] else args.command

    _own_console()
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the Ctrl+C is for the program
    started = time.monotonic()
    proc = subprocess.Popen(
        command, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.PIPE
    )
    lock = threading.Lock()
    first = threading.Event()
    relays = [
        threading.Thread(target=_relay, args=(proc.stdout, "out", lock, first), daemon=True),
        threading.Thread(
            target=_relay, args=(proc.stderr, "err", lock, threading.Event()), daemon=True
        ),
    ]
    for relay in relays:
        relay.start()

    stop = threading.Event()

    def wait_for_stop() -> None:
        for line in sys.stdin:
            if line.strip() == "stop":
                break
        stop.set()

    if args.stop_after is None:
        threading.Thread(target=wait_for_stop, daemon=True).start()
    else:
        threading.Timer(args.stop_after, stop.set).start()

    while not stop.is_set() and proc.poll() is None:
        stop.wait(0.1)
    result: dict[str, object] = {"exited_before_stop": proc.poll() is not None}
    sent = time.monotonic()
    if proc.poll() is None:
        os.kill(0, signal.CTRL_C_EVENT)  # GenerateConsoleCtrlEvent(CTRL_C_EVENT, 0)
    try:
        proc.wait(timeout=args.timeout)
        result["killed"] = False
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()
        result["killed"] = True
    for relay in relays:
        relay.join(timeout=5)
    result.update(
        returncode=proc.returncode,
        stop_seconds=round(time.monotonic() - sent, 2),
        run_seconds=round(sent - started, 2),
    )
    with lock:
        print("result: " + json.dumps(result), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
