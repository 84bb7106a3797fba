"""Any engine as a command: `[realtime] renderer = "command"` (docs/contract.md, "External engines").

    render(scene) -> Render        export the scene, run the engine's command, read its image and timings

The scene is exported once per render (scenes/exchange/export.py: scene.gltf, environment.hdr and the sidecar
iblcheck-export.json) into a temporary folder; the command is the `[realtime.command]` template, or a builtin
bridge's (BUILTIN_TEMPLATES), with its placeholders filled:

    {folder} {gltf} {environment} {sidecar}   the exported files
    {output}     the image the engine writes: OpenEXR, linear radiance, width x height, row 0 at the top
                 (an alpha channel, when written, is the engine's coverage: a pixel is covered at alpha >= 0.5)
    {timings}    a JSON file the engine may write (engine_timings.py): its frame times, name and version
    {width} {height}
    {frames} {warmup}  realtime.timing_frames and realtime.warmup_frames: how many frames to time, after how many
    {python} {repo}

The template is split like a shell line (shlex) and run without a shell, each placeholder replaced inside
its word, so a path with spaces stays one argument. How it ends:

    exit 0 and an image          the Render (rgb, mask, timings in ms, meta naming the engine and command)
    command not found, exit 127  MissingCapability (CLI exit 3): the engine is not installed
    exit 3                       MissingCapability: the bridge says its engine is missing (its stderr line)
    any other exit status        EngineRejected (exit 2): the engine refused the scene, with stderr's tail
    past timeout_s               EngineRejected naming realtime.command.timeout_s
    a wrong image                EngineRejected naming the file: missing, unreadable, wrong size, NaN or negative
"""

from __future__ import annotations

import os
import shlex
import signal
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from engines import engine_timings, linear_image
from scenes import InputError, MissingCapability
from scenes.exchange.export import export_scene
from scenes.model.render import Render

#: the repository root (the builtin bridges live under it)
REPO = Path(__file__).resolve().parents[1]
#: the builtin bridges' command lines (engines/web/render.mjs, engines/cycles/render.py)
BUILTIN_TEMPLATES = {
    "threejs": "node {repo}/engines/web/render.mjs --engine threejs --sidecar {sidecar} --output {output} "
               "--timings {timings} --frames {frames} --warmup {warmup}",
    "babylon": "node {repo}/engines/web/render.mjs --engine babylon --sidecar {sidecar} --output {output} "
               "--timings {timings} --frames {frames} --warmup {warmup}",
    # Cycles runs in its own virtual environment: bpy pins numpy < 2 (see the Makefile)
    "cycles": "{repo}/.venv-cycles/bin/python -m engines.cycles.render --sidecar {sidecar} --output {output} "
              "--timings {timings}",
}
PLACEHOLDERS = ("folder", "gltf", "environment", "sidecar", "output", "timings", "width", "height", "frames", "warmup",
                "python", "repo")
#: how much of the engine's stderr an error line quotes (its end, where the reason usually is)
STDERR_TAIL = 600
#: the exit status a bridge uses to say its engine is missing, and the shell's "command not found"
EXIT_MISSING, EXIT_NOT_FOUND = 3, 127


class EngineRejected(InputError):
    """The engine refused the scene or returned no usable image (CLI exit 2)."""


def template_of(command) -> tuple[str, str]:
    """(the template, its origin for messages) of a [realtime.command] table."""
    if command.engine:
        return BUILTIN_TEMPLATES[command.engine], f"realtime.command.engine = {command.engine!r}"
    return command.template, "realtime.command.template"


def command_line(template: str, values: dict[str, str], origin: str) -> list[str]:
    """The template split into words (shlex), each placeholder replaced; an unknown one is an InputError."""
    try:
        words = shlex.split(template)
    except ValueError as exc:
        raise InputError(f"{origin}: {template!r} is no command line ({exc})") from None
    if not words:
        raise InputError(f"{origin}: the command is empty")
    out = []
    for word in words:
        try:
            out.append(word.format_map(values))
        except KeyError as exc:
            raise InputError(f"{origin}: unknown placeholder {{{exc.args[0]}}} in {template!r}; the placeholders "
                             f"are {', '.join('{' + p + '}' for p in PLACEHOLDERS)}") from None
        except (ValueError, IndexError) as exc:
            raise InputError(f"{origin}: {word!r} is no valid template word ({exc}); write a literal brace "
                             "as {{ or }}") from None
    return out


def _tail(data: bytes) -> str:
    text = data.decode("utf-8", errors="replace").strip()
    return text if len(text) <= STDERR_TAIL else "..." + text[-STDERR_TAIL:]


def engine_environment() -> dict[str, str]:
    """This process's environment with the repository first on PYTHONPATH: a bridge run by another Python
    (Cycles' own venv) imports its package from the repository, whatever the working directory."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(REPO), env.get("PYTHONPATH", "")) if p)
    return env


def _stop(proc: subprocess.Popen) -> None:
    """Kill the engine's whole process group (its browser or renderer children included)."""
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except ProcessLookupError:
        pass


def run(argv: list[str], timeout_s: float, origin: str) -> subprocess.CompletedProcess:
    """Run the engine; map how it ended to the exceptions of the module docstring."""
    try:
        # a session of its own, so that a timeout stops the engine's children too (a browser, a renderer)
        proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, stdin=subprocess.DEVNULL,
                                env=engine_environment(), start_new_session=True)
    except FileNotFoundError:
        raise MissingCapability(f"{origin}: the engine's program {argv[0]!r} was not found",
                                hint="install it or fix the command (`make setup` installs the builtin bridges)") \
            from None
    except PermissionError:
        raise MissingCapability(f"{origin}: the engine's program {argv[0]!r} is not executable") from None
    try:
        stdout, stderr = proc.communicate(timeout=timeout_s)
    except subprocess.TimeoutExpired:
        _stop(proc)
        try:
            _, stderr = proc.communicate(timeout=5)
        except subprocess.TimeoutExpired:  # a child outside the group still holds the pipe: no stderr then
            stderr = b""
        raise EngineRejected(f"{origin}: the engine did not finish within realtime.command.timeout_s = {timeout_s:g} s "
                             f"({shlex.join(argv)[:200]}); its stderr: {_tail(stderr) or 'nothing'}") from None
    except BaseException:  # Ctrl-C: no engine left running behind the interrupted command
        _stop(proc)
        raise
    done = subprocess.CompletedProcess(argv, proc.returncode, stdout, stderr)
    if done.returncode in (EXIT_MISSING, EXIT_NOT_FOUND):
        raise MissingCapability(f"{origin}: the engine is missing (exit {done.returncode}): "
                                f"{_tail(done.stderr) or 'no message'}")
    if done.returncode != 0:
        raise EngineRejected(f"{origin}: the engine rejected the scene (exit {done.returncode}): "
                             f"{_tail(done.stderr) or 'no message on stderr'}")
    return done


def read_image(path: Path, width: int, height: int, origin: str) -> tuple[np.ndarray, np.ndarray]:
    """(rgb, mask) of the engine's image (engines/linear_image.py): linear radiance of the scene's size; the
    mask from its alpha (all True without one: the comparison then uses the reference's coverage)."""
    if not path.is_file():
        raise EngineRejected(f"{origin}: the engine exited 0 but wrote no image at {path}")
    try:
        image = linear_image.read(path)
    except InputError as exc:
        raise EngineRejected(f"{origin}: the engine's image: {exc}") from None
    if image.rgb.shape[:2] != (height, width):
        raise EngineRejected(f"{origin}: the engine's image {path.name} is {image.rgb.shape[1]}x{image.rgb.shape[0]}, "
                             f"the scene's camera is {width}x{height} (camera.width x camera.height)")
    mask = np.ones((height, width), bool) if image.coverage is None else image.coverage
    return image.rgb, mask


def render(scene, workdir: str | Path | None = None) -> Render:
    """Render `scene` with its [realtime.command] engine (module docstring). `workdir`: where the export and the
    image go (kept); a temporary folder, removed afterwards, when None."""
    if scene.realtime.renderer != "command":
        raise InputError(f"{scene.path or scene.name}: realtime.renderer = {scene.realtime.renderer!r}: not an "
                         "external engine")
    template, origin = template_of(scene.realtime.command)
    with tempfile.TemporaryDirectory(prefix="iblcheck-engine-") as tmp:
        folder = Path(workdir) if workdir is not None else Path(tmp)
        folder.mkdir(parents=True, exist_ok=True)
        exported = export_scene(scene, folder / "export")
        output, timings = folder / "image.exr", folder / "timings.json"
        for stale in (output, timings):
            stale.unlink(missing_ok=True)
        values = {"folder": str(exported.folder), "gltf": str(exported.gltf), "environment": str(exported.environment),
                  "sidecar": str(exported.sidecar), "output": str(output), "timings": str(timings),
                  "width": str(scene.camera.width), "height": str(scene.camera.height),
                  "frames": str(scene.realtime.timing_frames), "warmup": str(scene.realtime.warmup_frames),
                  "python": sys.executable,
                  "repo": str(REPO)}
        argv = command_line(template, values, origin)
        run(argv, scene.realtime.command.timeout_s, origin)
        rgb, mask = read_image(output, scene.camera.width, scene.camera.height, origin)
        reported = engine_timings.read(timings, origin) if timings.is_file() else engine_timings.EngineTimings()
    meta = {"renderer": "command", "engine": reported.engine or scene.realtime.command.engine or argv[0],
            "engine_version": reported.version, "command": shlex.join(argv), "timings_note": reported.notes}
    return Render(rgb=rgb, mask=mask, timings=reported.as_render_timings(), meta=meta)
