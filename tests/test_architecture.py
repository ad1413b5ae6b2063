"""The layering of docs/architecture.md holds: the protocol layer is pure and stands alone,
and no lower layer reaches up into a higher one."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "pyuss"

# What each package may import from pyuss (besides itself and the shared root modules
# errors, log, atomicfile, userfile, tomlwrite, _lazy, _callbacks and _tasks, and loop and
# system for all but the protocol layer). Every package of pyuss has its entry
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
FACE_OWN = {
    "modbus.py": set(),
    "mqtt.py": {"aiomqtt", "paho"},
    "mqtt_client.py": {"aiomqtt", "paho"},
    "opcua.py": {"asyncua"},
    "opcua_nodes.py": {"asyncua"},
    "opcua_sessions.py": {"asyncua"},
}
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
    used -= {
        package,
        "errors",
        "log",
        "atomicfile",
        "userfile",
        "tomlwrite",
        "_lazy",
        "_callbacks",
        "_tasks",
    }
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
LONGER_STILL: set[str] = set()
# One state machine read as a whole may be longer; it says so at its top.
STATE_MACHINES = {"master/core.py"}


def test_no_module_grows_past_the_lines_one_reads_whole() -> None:
    longer = {
        path.relative_to(SRC).as_posix()
        for path in SRC.rglob("*.py")
        if path.read_text(encoding="utf-8").count("\n") > MOST_LINES
    }
    allowed = LONGER_STILL | STATE_MACHINES
    assert longer <= allowed, f"over {MOST_LINES} lines: {sorted(longer - allowed)}"
    for name in STATE_MACHINES:
        opening = ast.get_docstring(ast.parse((SRC / name).read_text(encoding="utf-8"))) or ""
        assert "One state machine" in opening, f"{name} does not say why it is one module"


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


# No import circles between the modules of pyuss: every import counts, at module level and
# inside functions (a function-local import closes a circle as surely, only later), relative
# ones resolved; imports under `if TYPE_CHECKING:` never run and are left out (the type
# checker's own test below counts them). A name taken from a package that loads its modules on
# first use (`pyuss._lazy`) counts as an import of the module that defines it, found in the
# package's own `TYPE_CHECKING` imports. The package a module belongs to, which Python loads
# before the module, counts only where the module imports it by name.


def _module_name(path: Path, root: Path) -> str:
    parts = list(path.relative_to(root.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _is_type_checking(test: ast.expr) -> bool:
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


Imports = list[ast.Import | ast.ImportFrom]


def _split_imports(tree: ast.AST) -> tuple[Imports, Imports]:
    """The imports that run (anywhere in the module), and those under `if TYPE_CHECKING:`."""
    runs: Imports = []
    typing_only: Imports = []

    def visit(node: ast.AST, checking: bool) -> None:
        if isinstance(node, ast.If) and _is_type_checking(node.test):
            for child in node.body:
                visit(child, True)
            for child in node.orelse:
                visit(child, checking)
            return
        if isinstance(node, ast.Import | ast.ImportFrom):
            (typing_only if checking else runs).append(node)
        for child in ast.iter_child_nodes(node):
            visit(child, checking)

    visit(tree, False)
    return runs, typing_only


def _absolute(node: ast.ImportFrom, module: str, is_package: bool) -> str:
    if node.level == 0:
        return node.module or ""
    base = module.split(".")
    base = base if is_package else base[:-1]
    base = base[: len(base) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


def import_graph(root: Path, *, typing: bool = False) -> dict[str, set[str]]:
    """Module -> the modules of the package at ``root`` it imports when it runs (``typing``:
    and those it imports for the type checker only)."""
    files = {_module_name(p, root): p for p in sorted(root.rglob("*.py"))}
    parsed = {n: _split_imports(ast.parse(p.read_text("utf-8"))) for n, p in files.items()}
    lazy: dict[str, dict[str, str]] = {}  # package -> name -> the module that defines it
    for name, path in files.items():
        if path.name == "__init__.py":
            lazy[name] = {
                alias.asname or alias.name: _absolute(node, name, True)
                for node in parsed[name][1]
                if isinstance(node, ast.ImportFrom)
                for alias in node.names
            }
    graph: dict[str, set[str]] = {name: set() for name in files}
    for name, path in files.items():
        for node in parsed[name][0] + (parsed[name][1] if typing else []):
            if isinstance(node, ast.Import):
                for alias in node.names:
                    target = alias.name
                    while target and target not in files:
                        target = target.rpartition(".")[0]
                    if target:
                        graph[name].add(target)
                continue
            source = _absolute(node, name, path.name == "__init__.py")
            for alias in node.names:
                if f"{source}.{alias.name}" in files:
                    graph[name].add(f"{source}.{alias.name}")
                elif alias.name in lazy.get(source, {}) and lazy[source][alias.name] in files:
                    graph[name].add(lazy[source][alias.name])
                elif source in files:
                    graph[name].add(source)
        graph[name].discard(name)
    return graph


def strongly_connected(graph: dict[str, set[str]]) -> list[list[str]]:
    """Tarjan's strongly connected components of ``graph`` with more than one member."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for nxt in sorted(graph[node]):
            if nxt not in index:
                visit(nxt)
                low[node] = min(low[node], low[nxt])
            elif nxt in on_stack:
                low[node] = min(low[node], index[nxt])
        if low[node] == index[node]:
            component = []
            while True:
                member = stack.pop()
                on_stack.discard(member)
                component.append(member)
                if member == node:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for node in sorted(graph):
        if node not in index:
            visit(node)
    return sorted(found)


def circles(graph: dict[str, set[str]]) -> list[str]:
    """Each circle as "a -> b -> a": per component, shortest circles until each member is on one."""
    named = []
    for component in strongly_connected(graph):
        members = set(component)
        uncovered = list(component)
        while uncovered:
            start = uncovered[0]
            # the shortest way from start back to start inside the component (breadth first)
            came: dict[str, str] = {}
            queue = [start]
            while queue and start not in came:
                node = queue.pop(0)
                for nxt in sorted(graph[node] & members):
                    if nxt not in came:
                        came[nxt] = node
                        queue.append(nxt)
            path = [start]
            while len(path) == 1 or path[-1] != start:
                path.append(came[path[-1]])
            path.reverse()
            named.append(" -> ".join(path))
            uncovered = [m for m in uncovered if m not in path]
    return named


def test_no_import_circles() -> None:
    found = circles(import_graph(SRC))
    assert not found, "import circles (move the shared code down, do not hide the import):\n" + (
        "\n".join(found)
    )


# Imports under `if TYPE_CHECKING:` close circles for the type checker only: none is left (a
# `Drive` is typed by the calls it makes of its master, `pyuss.master.drive.Bus`).
TYPE_ONLY_CIRCLES: list[str] = []


def test_no_other_circles_for_the_type_checker() -> None:
    assert circles(import_graph(SRC, typing=True)) == TYPE_ONLY_CIRCLES


def test_the_circle_rule_sees_what_it_forbids(tmp_path: Path) -> None:
    package = tmp_path / "pkg"
    (package / "sub").mkdir(parents=True)
    files = {
        "__init__.py": "import typing\nif typing.TYPE_CHECKING:\n    from pkg.a import A\n",
        "a.py": "A = 1\ndef f():\n    from . import b\n",  # function-level, relative
        "b.py": "from .sub.c import C\n",
        "sub/__init__.py": "",
        "sub/c.py": "import pkg\nfrom .. import A\n",  # a name the package loads lazily: pkg.a
        "d.py": "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from pkg import e\n",
        "e.py": "import pkg.d\n",  # d imports e only for the type checker: no circle
    }
    for name, text in files.items():
        (package / name).write_text(text, encoding="utf-8")
    assert circles(import_graph(package)) == ["pkg.a -> pkg.b -> pkg.sub.c -> pkg.a"]
    assert circles(import_graph(package, typing=True)) == [
        "pkg -> pkg.a -> pkg.b -> pkg.sub.c -> pkg",
        "pkg.d -> pkg.e -> pkg.d",
    ]
