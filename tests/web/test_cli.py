"""uss web on the command line: the first line is the page's address, a token off loopback,
bad input in one line."""

from __future__ import annotations

import signal
import subprocess
import sys
import urllib.error
import urllib.request
from pathlib import Path

import pytest

USS = [sys.executable, "-m", "pyuss.cli.main"]


@pytest.mark.posix("stops uss web with SIGINT and checks it ended cleanly")
def test_off_loopback_a_token_is_printed_and_needed() -> None:
    web = subprocess.Popen(
        [*USS, "web", "--demo", "--listen", "0.0.0.0:0"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert web.stdout is not None
        url = web.stdout.readline().strip()
        token_line = web.stdout.readline().strip()
        assert url.startswith("http://127.0.0.1:") and "/?token=" in url
        token = url.split("?token=")[1]
        assert len(token) >= 20 and token_line.startswith(f"token: {token}")
        bare = url.split("?")[0]
        with pytest.raises(urllib.error.HTTPError) as refused:
            urllib.request.urlopen(bare + "api/bus", timeout=30)
        assert refused.value.code == 401
        with urllib.request.urlopen(f"{bare}api/bus?token={token}", timeout=30) as reply:
            assert reply.status == 200
        web.send_signal(signal.SIGINT)
        web.communicate(timeout=30)
        assert web.returncode == 0
    finally:
        if web.poll() is None:
            web.kill()
            web.wait()


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (["--demo", "--listen", "nonsense"], "HOST:PORT"),
        (["--demo", "--listen", "127.0.0.1:99999"], "0..65535"),
        (["--demo", "--address", "5"], "--demo brings its own drives"),
        (["--port", "tcp://127.0.0.1:9", "--profile", "nosuch"], "--profile"),
        (
            ["--port", "tcp://127.0.0.1:9", "--profile", "sinamics-v20@1999"],
            "unknown edition '1999' (known: 2019, 2014, 2012)",
        ),
        (["--demo", "--token", " "], "--token"),
        (["--mqtt", "ftp://broker"], "--mqtt"),
        (["--mqtt", "mqtt://127.0.0.1:1883", "--address", "5"], "leave out --address"),
        (["--mqtt", "mqtt://127.0.0.1:1883", "--mqtt-password", "x"], "needs a username"),
        (["--mqtt", "--config", "/nonexistent.toml"], "nonexistent.toml"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(args: list[str], words: str) -> None:
    done = subprocess.run([*USS, "web", *args], capture_output=True, text=True, timeout=60)
    assert done.returncode == 2, done.stderr
    assert done.stderr.count("\n") == 1 and words in done.stderr
    assert done.stdout == ""


def test_a_port_that_cannot_be_opened_fails_in_one_line() -> None:
    done = subprocess.run(
        [*USS, "web", "--port", "/dev/nonexistent-port", "--address", "5", "--listen", ":0"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 1
    assert done.stderr.count("\n") == 1 and "nonexistent" in done.stderr


def test_a_plant_without_the_mqtt_extra_names_the_pip_install() -> None:
    code = (
        "import sys; sys.modules['aiomqtt'] = None\n"
        "from pyuss.cli.main import main\n"
        "sys.exit(main(['web', '--mqtt', 'mqtt://127.0.0.1:1883', '--listen', ':0']))\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert done.returncode == 2
    assert done.stderr.count("\n") == 1 and "pip install 'pyuss[mqtt]'" in done.stderr


def test_a_bad_web_table_is_named_in_one_line(tmp_path: Path) -> None:
    config = tmp_path / "uss.toml"
    config.write_text('[web]\nmqtt = "mqtt://127.0.0.1:1883"\nbroker = "x"\n', encoding="utf-8")
    done = subprocess.run(
        [*USS, "web", "--mqtt", "--config", str(config)], capture_output=True, text=True, timeout=60
    )
    assert done.returncode == 2
    assert done.stderr.strip() == (
        f"uss web: {config}: web.broker: unknown key (known: mqtt, username, password, ca, "
        "cert, key, insecure, prefix, keepalive)"
    )
