"""The layering of docs/architecture.md holds: the protocol layer is pure and stands alone,
and no lower layer reaches up into a higher one."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "pyuss"

# What each package may import from pyuss (besides itself and the shared root modules
# errors, log, atomicfile, userfile, tomlwrite, _lazy and _callbacks, and loop and system for
# all but the protocol layer). Every package of pyuss has its entry
# (`test_every_package_has_its_rule`).
ALLOWED: dict[str, set[str]] = {
    "protocol": set(),
    # where Windows, macOS and Linux differ: below everything that does I/O
    "system": set(),
    "transport": {"protocol", "bus"},  # bus:// URLs open the virtual bus client (lazily)
    "bus": {"protocol", "transport"},
    "drive": {"protocol"},
    "profiles": {"protocol", "drive"},
    "slave": {"protocol", "transport", "bus", "drive", "profiles"},
    "monitor": {"protocol", "transport", "bus"},
    # parameter knowledge sits below the master, which converts values through it
    "params": {"protocol", "drive", "profiles"},
    # the master; its testing module assembles simulated drives (slave) on a virtual bus
    "master": {"protocol", "transport", "bus", "drive", "profiles", "params", "slave"},
    # the companions: BASS serves a drive model of pyuss.drive; KS VARIO stands alone
    "bass": {"protocol", "transport", "drive"},
    "ksvario": {"protocol", "transport"},
    # commissioning (backup, compare, restore, status) builds on the master
    "commission": {"protocol", "drive", "profiles", "params", "master"},
    # the live-drive model: the one place where a face's wish becomes process data or a
    # parameter job, on the master
    "points": {"protocol", "transport", "bus", "drive", "profiles", "params", "master"},
    # the faces: the drive model, commission and the monitor, never the master
    # (the web page and the data logger know nothing of each other)
    "web": {"protocol", "transport", "bus", "profiles", "params"}
    | {"points", "commission", "monitor", "plant"},
    # the plant over the broker: the gateways' topics (their contract), read and commanded
    # as an MQTT client; the drive model's checks and values, never the master
    "plant": {"protocol", "drive", "profiles", "params", "points", "gateway"},
    # the data logger: a drive's process data and parameters through the drive model
    "datalog": {"protocol", "drive", "params", "points"},
    # the gateway's faces over the drive model
    "gateway": {"protocol", "transport", "bus", "drive", "profiles", "params", "points"},
    # the uss command wires every part to the command line; pyuss.lines (the module of the
    # configuration file of lines and drives, over pyuss.points.config) serves it alone
    "cli": {
        "protocol", "transport", "bus", "drive", "profiles", "slave", "monitor", "params",
        "master", "bass", "ksvario", "commission", "points", "web", "datalog", "gateway",
        "lines", "plant",
    },
}  # fmt: skip
FACES = ("web", "datalog", "gateway", "plant")
# Each gateway face imports its own library only; the pure modules none of them.
FACE_LIBRARIES = {"pymodbus", "aiomqtt", "paho", "asyncua"}
FACE_OWN = {"modbus.py": set(), "mqtt.py": {"aiomqtt", "paho"}, "opcua.py": {"asyncua"}}
# Pure means no I/O and no clock: none of these in the protocol layer.
IMPURE = {"asyncio", "socket", "serial", "time", "os", "threading", "subprocess", "select"}


def test_every_package_has_its_rule() -> None:
    packages = {p.name for p in SRC.iterdir() if (p / "__init__.py").is_file()}
    assert packages == set(ALLOWED), f"without a rule: {sorted(packages - set(ALLOWED))}"


DOC = SRC.parents[1] / "docs" / "architecture.md"
# The one pair of the same level that import each other: a bus:// URL opens the virtual bus's
# client (lazily), and the bus is a transport provider.
SAME_LEVEL = {("transport", "bus"), ("bus", "transport")}


def _levels() -> dict[str, int]:
    """The level of each package in the table of docs/architecture.md, "The layers"."""
    text = DOC.read_text(encoding="utf-8")
    section = text.split("\n## The layers\n", 1)[1].split("\n## ", 1)[0]
    levels: dict[str, int] = {}
    for level, packages in re.findall(r"^\| (\d+) \| ([^|]+) \|", section, flags=re.MULTILINE):
        for package in re.findall(r"`(\w+)`", packages):
            assert package not in levels, f"{package} twice in docs/architecture.md"
            levels[package] = int(level)
    return levels


def test_the_drawing_of_the_layers_is_the_rules() -> None:
    levels = _levels()
    assert set(levels) == set(ALLOWED), f"docs/architecture.md: {set(levels) ^ set(ALLOWED)}"
    above = [
        f"{package} (level {levels[package]}) imports {used} (level {levels[used]})"
        for package, allowed in ALLOWED.items()
        for used in allowed
        if used in levels and levels[used] >= levels[package] and (package, used) not in SAME_LEVEL
    ]
    assert not above, f"docs/architecture.md draws these the other way: {above}"


def _imports(package: str) -> set[str]:
    found: set[str] = set()
    for path in (SRC / package).rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom) and node.module:
                found.add(node.module)
            elif isinstance(node, ast.Import):
                found.update(alias.name for alias in node.names)
    return found


@pytest.mark.parametrize("package", sorted(ALLOWED))
def test_no_layer_reaches_up(package: str) -> None:
    used = {
        name.split(".")[1]
        for name in _imports(package)
        if name.startswith("pyuss.") and name.count(".") >= 1
    }
    used -= {package, "errors", "log", "atomicfile", "userfile", "tomlwrite", "_lazy", "_callbacks"}
    if package != "protocol":  # the event loop and platform helpers: every layer doing I/O
        used -= {"loop", "system"}
    assert used <= ALLOWED[package], f"pyuss.{package} imports {sorted(used - ALLOWED[package])}"


@pytest.mark.parametrize("face", FACES)
def test_faces_go_through_the_drive_model_not_the_master(face: str) -> None:
    used = {
        name
        for name in _imports(face)
        if name == "pyuss.master" or name.startswith("pyuss.master.")
    }
    assert not used, f"pyuss.{face} imports {sorted(used)}: use pyuss.points"
    assert "master" not in ALLOWED[face]


@pytest.mark.parametrize("module", sorted(p.name for p in (SRC / "gateway").glob("*.py")))
def test_gateway_faces_import_only_their_own_library(module: str) -> None:
    tree = ast.parse((SRC / "gateway" / module).read_text(encoding="utf-8"))
    roots = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            roots.add(node.module.split(".")[0])
        elif isinstance(node, ast.Import):
            roots.update(alias.name.split(".")[0] for alias in node.names)
    assert roots & FACE_LIBRARIES <= FACE_OWN.get(module, set()), f"pyuss.gateway.{module}"


def test_points_import_no_face_library() -> None:
    roots = {name.split(".")[0] for name in _imports("points")}
    assert not roots & FACE_LIBRARIES


# A module is read whole: at most this many lines. The ones below are still longer (to be
# split by what they are); no other module may grow past it.
MOST_LINES = 700
LONGER_STILL = {
    "bus/core.py",
    "cli/simulate.py",
    "drive/database.py",
    "gateway/mqtt.py",
    "gateway/opcua.py",
    "gateway/topics.py",
    "master/drive.py",
    "master/scheduler.py",
    "monitor/core.py",
    "web/backend.py",
    "web/server.py",
}


def test_no_module_grows_past_the_lines_one_reads_whole() -> None:
    longer = {
        path.relative_to(SRC).as_posix()
        for path in SRC.rglob("*.py")
        if path.read_text(encoding="utf-8").count("\n") > MOST_LINES
    }
    assert longer <= LONGER_STILL, f"over {MOST_LINES} lines: {sorted(longer - LONGER_STILL)}"


def test_protocol_layer_does_no_io_and_reads_no_clock() -> None:
    roots = {name.split(".")[0] for name in _imports("protocol")}
    assert not roots & IMPURE, f"pyuss.protocol imports {sorted(roots & IMPURE)}"


def test_waits_with_a_time_limit_use_asyncio_timeout() -> None:
    # asyncio.wait_for (Python 3.11) returns a result that arrives together with a
    # cancellation of the waiting task and drops the cancellation: the task runs on.
    users = [
        str(path.relative_to(SRC))
        for path in SRC.rglob("*.py")
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8")))
        if isinstance(node, ast.Attribute) and node.attr == "wait_for"
    ]
    assert not users, f"asyncio.wait_for in {sorted(set(users))}: use asyncio.timeout"


# Where the platforms differ is decided in pyuss.system alone (docs/platforms.md): no other
# module looks at the platform or calls what exists on some platforms only.
PLATFORM_NAMES = {"fcntl", "termios", "msvcrt", "tty", "pty", "winreg", "_winapi", "resource"}
PLATFORM_CALLS = {
    ("sys", "platform"): "sys.platform",
    ("os", "name"): "os.name",
    ("os", "major"): "os.major",
    ("os", "openpty"): "os.openpty",
    ("os", "replace"): "os.replace (system.replace, atomicfile)",
    ("os", "fchmod"): "os.fchmod",
    ("os", "O_NOFOLLOW"): "os.O_NOFOLLOW",
    ("os", "ttyname"): "os.ttyname",
    ("selectors", "EpollSelector"): "selectors.EpollSelector",
    ("selectors", "KqueueSelector"): "selectors.KqueueSelector",
    ("signal", "SIGTERM"): "signal.SIGTERM",
    ("signal", "SIGBREAK"): "signal.SIGBREAK",
}
PLATFORM_METHODS = {"add_signal_handler", "remove_signal_handler"}


def _platform_uses(path: Path) -> list[str]:
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            found += [a.name for a in node.names if a.name.split(".")[0] in PLATFORM_NAMES]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            if node.module.split(".")[0] in PLATFORM_NAMES:
                found.append(node.module)
        elif isinstance(node, ast.Attribute):
            if isinstance(node.value, ast.Name) and (node.value.id, node.attr) in PLATFORM_CALLS:
                found.append(PLATFORM_CALLS[node.value.id, node.attr])
            elif node.attr in PLATFORM_METHODS:
                found.append(node.attr)
    return found


@pytest.mark.parametrize(
    "module",
    sorted(
        str(p.relative_to(SRC))
        for p in SRC.rglob("*.py")
        if p.relative_to(SRC).parts[0] != "system"
    ),
)
def test_platform_choices_live_in_pyuss_system(module: str) -> None:
    found = _platform_uses(SRC / module)
    assert not found, f"pyuss/{module} uses {sorted(set(found))}: ask pyuss.system instead"


def test_the_platform_rule_sees_what_it_forbids() -> None:
    found = _platform_uses(SRC / "system" / "_posix.py") + _platform_uses(
        SRC / "system" / "_windows.py"
    )
    assert {"fcntl", "termios", "msvcrt", "sys.platform", "add_signal_handler"} <= set(found)
