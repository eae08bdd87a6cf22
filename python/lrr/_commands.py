"""The commands of the ``lrr`` command line from Python: ``bake`` (in a child process, with a
progress bar, Ctrl-C cancelling it), ``export`` and ``command`` (in-process)."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import tempfile
import threading
from typing import Any

from ._errors import CommandError, InputError
from . import _lrr

# The keyword arguments of bake(): the flags of `lrr bake` (README, `lrr bake --help`).
BAKE_SETTINGS = frozenset(
    {
        "element_size",
        "patch_size",
        "method",
        "threshold",
        "min_patch_area",
        "samples",
        "visibility",
        "threads",
        "max_memory",
        "precision",
        "layout",
        "refine",
        "resume",
        "checkpoint_rows",
        "report",
        "verbose",
    }
)

# The plain progress lines of a bake whose stderr is a pipe (precompute/src/progress.rs).
_STARTED = re.compile(r"^lrr: (?P<stage>[^:]+): started$")
_COUNTED = re.compile(r"^lrr: (?P<stage>[^:]+): (?P<done>\d+)/(?P<total>\d+) \(")
_UNCOUNTED = re.compile(r"^lrr: (?P<stage>[^:]+): (?P<done>\d+) done, ")
_RUNNING = re.compile(r"^lrr: (?P<stage>[^:]+): still running, ")
_DONE = re.compile(r"^lrr: (?P<stage>[^:]+): done in (?P<seconds>[0-9.]+) s$")
_ERROR = "lrr: error: "


def flag(key: str, value: Any) -> list[str]:
    """``key=value`` as command-line words: ``--key-name value``; True: the bare flag; False
    or None: nothing; a sequence: comma-separated (``eye=(1, 2, 3)`` → ``--eye 1,2,3``)."""
    name = "--" + key.replace("_", "-")
    if value is None or value is False:
        return []
    if value is True:
        return [name]
    if isinstance(value, (list, tuple)):
        return [name, ",".join(str(v) for v in value)]
    return [name, os.fspath(value) if isinstance(value, os.PathLike) else str(value)]


def command(*args: Any) -> str:
    """Runs ``lrr ARGS...`` in this process (e.g. ``lrr.command("info", "cornell.lrr")``) and
    returns what it printed; a failure raises ``lrr.CommandError`` with its message."""
    return _lrr.run([os.fspath(a) if isinstance(a, os.PathLike) else str(a) for a in args])


class _Progress:
    """Shows the child's progress lines: a tqdm bar per stage when tqdm is installed, else the
    lines themselves; other lines (warnings, notes) are passed on to stderr."""

    def __init__(self, enabled: bool) -> None:
        self.enabled = enabled
        self.bar = None
        try:
            from tqdm.auto import tqdm

            self.tqdm = tqdm if enabled else None
        except ImportError:
            self.tqdm = None

    def line(self, text: str) -> None:
        progress = [p.match(text) for p in (_STARTED, _COUNTED, _UNCOUNTED, _RUNNING, _DONE)]
        if not any(progress):
            if not text.startswith(_ERROR):
                print(text, file=sys.stderr)
            return
        if not self.enabled:
            return
        if self.tqdm is None:
            print(text, file=sys.stderr)
            return
        started, counted, uncounted, _, done = progress
        if started:
            self.close()
            self.bar = self.tqdm(desc=started["stage"], unit=" items", leave=False)
        elif self.bar is not None and (counted or uncounted):
            m = counted or uncounted
            if counted:
                self.bar.total = int(m["total"])
            self.bar.n = int(m["done"])
            self.bar.refresh()
        elif done:
            self.close()

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
            self.bar = None


def _stop(proc: subprocess.Popen) -> None:
    """Ends the child (it may already have died of the same SIGINT) and reaps it."""
    if proc.poll() is None:
        proc.terminate()
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


def bake(
    scene: str | os.PathLike,
    output: str | os.PathLike | None = None,
    *,
    progress: bool = True,
    **settings: Any,
):
    """Bakes ``scene`` (OBJ, glTF 2.0, or an lrr scene description ``.toml``) into an operator
    file and returns it loaded as an :class:`lrr.Operator`.

    The bake is ``lrr bake SCENE -o OUTPUT`` with ``settings`` as its flags
    (``element_size=0.05`` → ``--element-size 0.05``, ``method="2mf"``, ``samples=4``,
    ``refine=0``, ``precision="f16"``, ``threads=2``, ``resume=True``, ...; the scene
    description's ``[bake]`` table supplies what they leave out, but not the output), run in a
    child process of this Python (``python -m lrr``), so its bytes are ``lrr bake``'s.
    ``output=None`` bakes into a temporary file that is removed once loaded.

    Progress: a tqdm bar per stage when tqdm is installed (else the plain progress lines) on
    stderr, with the import's warnings; ``progress=False`` shows warnings only. Ctrl-C
    (``KeyboardInterrupt``) ends the bake: the output file is untouched (written atomically) and
    the checkpoint ``OUTPUT.ckpt`` survives, so ``resume=True`` continues it. A failure raises
    ``lrr.CommandError`` with the command's message.
    """
    unknown = sorted(set(settings) - BAKE_SETTINGS)
    if unknown:
        raise TypeError(
            f"bake() got unexpected keyword arguments {unknown}; "
            f"the settings are {sorted(BAKE_SETTINGS)}"
        )
    tmp = tempfile.TemporaryDirectory(prefix="lrr-bake-") if output is None else None
    path = os.path.join(tmp.name, "operator.lrr") if tmp else os.fspath(output)
    argv = ["bake", os.fspath(scene), "-o", path]
    for key, value in settings.items():
        argv += flag(key, value)
    try:
        _run_child(argv, _Progress(progress))
        from ._lrr import Operator

        if tmp is None:
            return Operator.load(path)
        with open(path, "rb") as f:
            return Operator.from_bytes(f.read())
    finally:
        if tmp is not None:
            tmp.cleanup()


def _run_child(argv: list[str], progress: _Progress) -> str:
    """``python -m lrr ARGV`` with its stderr shown through ``progress``; its stdout returned."""
    env = dict(os.environ)
    # The child must find this very package (a wheel, or a source checkout on sys.path).
    package_root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [package_root, env.get("PYTHONPATH")]))
    proc = subprocess.Popen(
        [sys.executable, "-m", "lrr", *argv],
        stdin=subprocess.DEVNULL,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        errors="replace",
        env=env,
    )
    stdout: list[str] = []
    reader = threading.Thread(target=lambda: stdout.append(proc.stdout.read()), daemon=True)
    reader.start()
    errors: list[str] = []
    try:
        for raw in proc.stderr:
            text = raw.rstrip("\n")
            if text.startswith(_ERROR):
                errors.append(text[len(_ERROR) :])
            progress.line(text)
        status = proc.wait()
    except BaseException:
        _stop(proc)
        raise
    finally:
        progress.close()
        reader.join(timeout=10)
    if status != 0:
        message = errors[-1] if errors else f"lrr {argv[0]} exited with status {status}"
        raise CommandError(message)
    return "".join(stdout)


def export(op, output: str | os.PathLike, *, groups=None, emission=None, **flags: Any) -> str:
    """``Operator.export``: ``lrr export`` of ``op`` in this process (see its docstring)."""
    with tempfile.TemporaryDirectory(prefix="lrr-export-") as tmp:
        source = op.path
        if source is None:
            source = os.path.join(tmp, "operator.lrr")
            with open(source, "wb") as f:
                f.write(op.to_bytes())
        argv: list[Any] = ["export", source, "-o", output]
        if groups is not None:
            if not isinstance(groups, dict):
                raise InputError("groups: a dict {light group name: intensity}")
            for name, a in groups.items():
                argv += ["--group", f"{name}={float(a)!r}"]
        if emission is not None:
            import numpy as np

            e = np.asarray(emission, dtype=np.float64)
            if e.shape == (3, op.n) and op.n != 3:
                e = e.T
            if e.shape != (op.n, 3):
                raise InputError(
                    f"emission: expected shape ({op.n}, 3) or (3, {op.n}), got {e.shape}"
                )
            path = os.path.join(tmp, "emission.json")
            with open(path, "w") as f:
                json.dump(e.tolist(), f)
            argv += ["--emission", path]
        for key, value in flags.items():
            argv += flag(key, value)
        return command(*argv)
