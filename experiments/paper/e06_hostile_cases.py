"""Hostile inputs: names, files and values that once ran script in a report, wrote outside
the folder asked for, crashed with a traceback or were silently misread.

One list of each, shared by tests/hard/ (which asserts them one by one) and E6 of the paper suite
(experiments/paper/e06_stability.py, which lists what happened to each), so the table shows what the tests try.
"""

from __future__ import annotations

import os
import socket
import struct
from collections.abc import Callable
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import OpenEXR

from experiments.measure.results import ResultRow
from scenes import MeshError
from scenes.geometry import meshes


def error_of(fn: Callable[[], object]) -> str:
    """'Type: message' of the exception `fn` raises, or 'no error': the outcome an E6 case reports."""
    try:
        fn()
    except Exception as exc:  # the message is the outcome being reported
        return f"{type(exc).__name__}: {exc}"
    return "no error"


#: marks a script that ran: every payload sets this attribute on <body> (the browser test looks for it)
PWNED = "data-pwned"
#: text that hostile names carry into every field: markup, script URLs, template syntax, terminal
#: escapes, control characters, bidirectional overrides, Markdown and rich markup
HOSTILE_NAMES = (
    f'<img src=x onerror="document.body.setAttribute(\'{PWNED}\', \'1\')">',
    f"<script>document.body.setAttribute('{PWNED}', '1')</script>",
    f'"><svg onload="document.body.setAttribute(\'{PWNED}\', \'1\')">',
    f"' onmouseover='document.body.setAttribute(\"{PWNED}\", \"1\")' x='",
    f"javascript:document.body.setAttribute('{PWNED}','1')",
    "{{ 7 * 7 }} {% if true %}jinja{% endif %}",
    "\x1b[31mred\x1b[0m\x1b]0;title\x07",
    "tab\tnew\nline\rreturn",
    "nul\x00byte and \x7f del and \x9b csi",
    "rtl \u202eexe.txt",
    "| cell | split |",
    "[bold]rich[/bold] [link=http://example.com]x[/link]",
    "&amp; &lt;b&gt; ]]><!-- -->",
    r"$\undefinedcommand{$ mathtext $\frac{1}{$",
)
#: what Python says in its own words: never part of an `error:` line
PYTHON_PHRASES = (
    "Traceback", "list index out of range", "buffer is smaller than requested size", "object has no attribute",
    "unsupported operand", "invalid literal for int()", "could not convert string to float", "is not in list",
    "not subscriptable", "NoneType", "codec can't decode", "out of bounds for axis", "cannot reshape array",
    "setting an array element with a sequence", "StopIteration", "KeyError", "IndexError", "ValueError",
    "TypeError", "RecursionError", "maximum recursion depth", "[Errno", "struct.error", "unpack requires",
)


def file_safe(name: str) -> str:
    """A hostile name as a file name: only '/' and NUL (which no file name can hold) replaced."""
    return name.replace("/", "_").replace("\x00", "_")[:200]


def python_text(message: str) -> list[str]:
    """The Python phrases found in an error message (none is the goal)."""
    return [p for p in PYTHON_PHRASES if p in message]


# --------------------------------------------------------------------------- meshes

GOOD_OBJ = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nvn 0 0 1\nf 1//1 3//1 2//1\nf 1//1 2//1 4//1\nf 1 4 3\nf 2 3 4\n"
#: (label, OBJ text): each must be refused with a MeshError naming the file (and the line)
BAD_OBJS = (
    ("vertex with 2 numbers", "v 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"),
    ("vertex with a word", "v 0 zero 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"),
    ("normal with 1 number", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 1\nf 1 2 3\n"),
    ("face with 1 corner", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1\n"),
    ("face with a word", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 two 3\n"),
    ("face index 0", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n"),
    ("face index past the end", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n"),
    ("negative index past the start", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -7\n"),
    ("normal index missing", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1//4 2//4 3//4\n"),
    ("normal index a word", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//x 2//1 3//1\n"),
    ("no faces", "v 0 0 0\n"),
    ("only degenerate faces", "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n"),
    ("NaN vertex", "v nan 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"),
    ("huge coordinates", "v 1e30 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"),
    ("binary garbage", "\x00\xff\xfe garbage \x01\x02"),
)

_PLY_HEAD = ("ply\nformat {fmt} 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
             "element face 2\nproperty list uchar int vertex_indices\nend_header\n")
_VERTS = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=np.float32)


def good_ply(binary: bool) -> bytes:
    if binary:
        faces = b"".join(bytes([3]) + np.array(f, "<i4").tobytes() for f in ([0, 1, 2], [0, 2, 3]))
        return _PLY_HEAD.format(fmt="binary_little_endian").encode() + _VERTS.astype("<f4").tobytes() + faces
    body = "".join(f"{a} {b} {c}\n" for a, b, c in _VERTS) + "3 0 1 2\n3 0 2 3\n"
    return (_PLY_HEAD.format(fmt="ascii") + body).encode()


def _ply(head_from: str, head_to: str, binary: bool = False) -> bytes:
    return good_ply(binary).replace(head_from.encode(), head_to.encode(), 1)


#: (label, PLY bytes): each must be refused with a MeshError naming the file
BAD_PLYS = (
    ("no format line", _ply("format ascii 1.0\n", "")),
    ("unknown format", _ply("format ascii", "format binary_middle_endian")),
    ("unknown property type", _ply("property float x", "property float128 x")),
    ("property before any element", b"ply\nformat ascii 1.0\nproperty float x\nend_header\n"),
    ("element without a count", _ply("element face 2", "element face")),
    ("no x property", _ply("property float x", "property float u")),
    ("face without a list", _ply("property list uchar int vertex_indices", "property int vertex_indices")),
    ("face with 2 corners", good_ply(False).replace(b"3 0 1 2\n", b"2 0 1\n")),
    ("face index past the end", good_ply(False).replace(b"3 0 1 2\n", b"3 0 1 9\n")),
    ("a word in the body", good_ply(False).replace(b"3 0 2 3\n", b"3 0 two 3\n")),
    ("fractional index", good_ply(False).replace(b"3 0 2 3\n", b"3 0 2.5 3\n")),
    ("ascii body cut short", good_ply(False)[:-12]),
    ("binary body cut short", good_ply(True)[:-5]),
    ("binary vertex block cut", good_ply(True)[: len(_PLY_HEAD.format(fmt="binary_little_endian")) + 20]),
    ("header not finished", b"ply\nformat ascii 1.0\nelement vertex 4\n"),
    ("no ply signature", b"PLY?\n" + good_ply(False)),
)


def mesh_cases() -> list[tuple[str, str, bytes]]:
    """(label, "obj" or "ply", file bytes): every bad mesh above and truncations of good ones."""
    cases = [(label, "obj", text.encode("latin-1")) for label, text in BAD_OBJS]
    cases += [(label, "ply", data) for label, data in BAD_PLYS]
    for kind, data in (("obj", GOOD_OBJ.encode()), ("ply", good_ply(False)), ("ply", good_ply(True))):
        cases += [(f"{kind} cut at byte {len(d)}", kind, d) for d in truncations(data)]
    return cases


def mesh_outcome(path: Path) -> str:
    """"loaded", "refused" (a MeshError naming the file, in iblcheck's words), "raw Python text" or
    "crashed: <exception type>"."""
    try:
        meshes.load_file(path)
    except MeshError as exc:
        return "refused" if str(exc).startswith(str(path)) and not python_text(str(exc)) else "raw Python text"
    except Exception as exc:  # the outcome being reported
        return f"crashed: {type(exc).__name__}"
    return "loaded"


def truncations(data: bytes, count: int = 24) -> list[bytes]:
    """`data` cut at `count` offsets spread over its length (never empty, never whole)."""
    cuts = np.unique(np.linspace(1, len(data) - 1, count).astype(int))
    return [data[:c] for c in cuts]


# --------------------------------------------------------------------------- environment maps


def _exr(path: Path, channels: dict, header: dict | None = None) -> Path:
    head = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage, **(header or {})}
    with OpenEXR.File(head, channels) as f:
        f.write(str(path))
    return path


def _plane(value: float = 1.0, dtype=np.float32) -> np.ndarray:
    return np.full((8, 16), value, dtype=dtype)


def misread_maps(folder: Path) -> list[tuple[str, Path, str]]:
    """(label, map file, a word the refusal must contain): files that hold no usable colour radiance
    or that a reader could take for something else."""
    f = Path(folder)
    rgb = {c: _plane() for c in "RGB"}
    two_parts = [OpenEXR.Part({"type": OpenEXR.scanlineimage}, rgb, name="beauty"),
                 OpenEXR.Part({"type": OpenEXR.scanlineimage}, {c: _plane(0.0) for c in "RGB"}, name="albedo")]
    with OpenEXR.File(two_parts) as exr:
        exr.write(str(f / "parts.exr"))
    crop = {"displayWindow": (np.array([0, 0], np.int32), np.array([31, 15], np.int32)),
            "dataWindow": (np.array([0, 0], np.int32), np.array([15, 7], np.int32))}
    return [
        ("EXR with only alpha", _exr(f / "alpha.exr", {"A": _plane()}), "alpha"),
        ("EXR with only depth", _exr(f / "depth.exr", {"Z": _plane(3.0)}), "depth"),
        ("EXR with R only", _exr(f / "red.exr", {"R": _plane()}), "no colour"),
        ("EXR with R and G", _exr(f / "rg.exr", {"R": _plane(), "G": _plane()}), "no colour"),
        ("EXR luminance/chroma", _exr(f / "yc.exr", {"Y": _plane(), "RY": _plane(0.1), "BY": _plane(0.1)}), "chroma"),
        ("EXR with two RGB layers", _exr(f / "layers.exr", {f"{layer}.{c}": _plane() for layer in ("diffuse", "spec")
                                                           for c in "RGB"}), "layers"),
        ("EXR with integer channels", _exr(f / "uint.exr", {c: _plane(1, np.uint32) for c in "RGB"}), "integers"),
        ("EXR with two parts", f / "parts.exr", "multi-part"),
        ("EXR cropped from its display window", _exr(f / "crop.exr", rgb, crop), "display window"),
        ("PFM scale 0", _pfm(f / "zero.pfm", b"0.0"), "scale"),
        ("PFM scale -0", _pfm(f / "negzero.pfm", b"-0"), "scale"),
        ("PFM scale nan", _pfm(f / "nan.pfm", b"nan"), "scale"),
        ("PFM scale inf", _pfm(f / "inf.pfm", b"-inf"), "scale"),
        ("PFM scale a word", _pfm(f / "word.pfm", b"minus"), "header"),
    ]


def _pfm(path: Path, scale: bytes) -> Path:
    body = struct.pack("<" + "f" * 3 * 16 * 8, *([1.0] * 3 * 16 * 8))
    path.write_bytes(b"PF\n16 8\n" + scale + b"\n" + body)
    return path


def special_paths(folder: Path, suffix: str = ".exr") -> list[tuple[str, Path, str]]:
    """(label, path, the word the refusal must contain): paths with `suffix` that are no readable
    regular file (a symbolic link loop first)."""
    f = Path(folder)
    loop, broken, fifo, sock, device = (f / f"{n}{suffix}" for n in ("loop", "broken", "pipe", "socket", "device"))
    if not loop.is_symlink():
        os.symlink(loop, loop)
    if not device.is_symlink():
        os.symlink("/dev/null", device)
    if not broken.is_symlink():
        os.symlink(f / f"nowhere{suffix}", broken)
    (f / f"folder{suffix}").mkdir(exist_ok=True)
    if not fifo.exists():
        os.mkfifo(fifo)
    if not sock.exists():
        s = socket.socket(socket.AF_UNIX)
        s.bind(str(sock))
        s.close()
    return [("a symbolic link loop", loop, "loop"), ("a broken symbolic link", broken, "broken"),
            ("a folder", f / f"folder{suffix}", "folder"), ("a named pipe", fifo, "pipe"),
            ("a socket", sock, "socket"), ("a device (through a link)", device, "device"),
            ("a missing file", f / f"missing{suffix}", "not found")]


# --------------------------------------------------------------------------- geometry for back faces


def cube_obj(shared: bool, half: float = 0.5) -> str:
    """A cube as OBJ: 8 shared vertices and no normals (smooth normals: at its silhouette the
    interpolated normal faces away while the face faces the viewer), or 24 vertices with per-face normals."""
    corners = [(x, y, z) for x in (-half, half) for y in (-half, half) for z in (-half, half)]
    quads = []
    for axis in range(3):
        for sign in (-1.0, 1.0):
            quad = [i for i, c in enumerate(corners) if c[axis] == sign * half]
            u, w = [(axis + 1) % 3, (axis + 2) % 3]
            centre = np.mean([corners[i] for i in quad], axis=0)
            ang = [np.arctan2(corners[i][w] - centre[w], corners[i][u] - centre[u]) for i in quad]
            quad = [quad[k] for k in np.argsort(ang)]
            quads.append(quad if sign > 0 else quad[::-1])
    if shared:
        lines = [f"v {x:g} {y:g} {z:g}" for x, y, z in corners]
        lines += [f"f {q[0] + 1} {q[1] + 1} {q[2] + 1}\nf {q[0] + 1} {q[2] + 1} {q[3] + 1}" for q in quads]
        return "\n".join(lines) + "\n"
    lines = []
    for k, q in enumerate(quads):
        normal = np.zeros(3)
        normal[k // 2] = -1.0 if k % 2 == 0 else 1.0
        lines += [f"v {corners[i][0]:g} {corners[i][1]:g} {corners[i][2]:g}" for i in q]
        lines.append(f"vn {normal[0]:g} {normal[1]:g} {normal[2]:g}")
        a, n = 4 * k + 1, k + 1
        lines.append(f"f {a}//{n} {a + 1}//{n} {a + 2}//{n}\nf {a}//{n} {a + 2}//{n} {a + 3}//{n}")
    return "\n".join(lines) + "\n"


# --------------------------------------------------------------------------- what escaped


def hostile_rows(names=HOSTILE_NAMES) -> list:
    """Result rows carrying each hostile name in every text field a row has (scene name, map file
    name, technique and material values, overrides), for report and summary checks without rendering."""
    rows = []
    for k, (i, name) in enumerate((i, name) for i, name in enumerate(names) for _ in range(2)):
        rows.append(ResultRow(  # two LOD biases per name: the bias plot draws a panel titled with it
            id=f"hostile{k:02d}", spec=f"/tmp/{file_safe(name)}.toml", overrides={"name": name, name: name},
            scene=name, techniques={"diffuse": name, "glossy": "box", "lod_bias": float(k % 2), "sh_order": 2,
                                    "lod_mapping": "paper", "sh_window": name},
            materials=[{"type": name, "exponent": 1.0, "f0": 0.5}],
            env=f"/tmp/{file_safe(name)}.exr", effects=["diffuse", "glossy"], unsimulated_effects=[name],
            width=8, height=8, face_size=8, psnr=30.0 + i, ssim=0.9, flip=0.1, rel_mse=0.01, noise_floor_psnr=40.0,
            at_noise_floor=False, pixels=64, realtime_ms={"filter": 1.0, "draw": 1.0, "total": 2.0},
            images={"realtime": f"javascript:{name}", "reference": f"https://example.com/{i}.png",
                    "error": f"../../{i}.png", "flip": f"images/{i}/flip.png"}))
    return rows


def page_problems(html: str) -> list[str]:
    """What in a report page could run script or reach the network: an element or attribute that a
    hostile name smuggled in, an inline script, a script, style sheet or data file from outside the
    report folder, a missing Content-Security-Policy or one that lets inline script or eval run."""
    allowed = {"html", "head", "meta", "title", "style", "link", "body", "h1", "h2", "p", "section", "table",
               "thead", "tbody", "tr", "th", "td", "div", "figure", "figcaption", "img", "a", "details", "summary",
               "ul", "li", "pre", "code", "script", "span"}
    problems: list[str] = []

    class Scan(HTMLParser):
        scripts, policies, in_script = 0, [], False

        def handle_starttag(self, tag, attrs):
            if tag not in allowed:
                problems.append(f"element <{tag}>")
            values = {key: value or "" for key, value in attrs}
            for key, value in values.items():
                if key.startswith("on"):
                    problems.append(f"attribute {key} on <{tag}>")
                # data-data: a file the viewer loads as a script (experiments/publish/viewer_data.py)
                if key in ("src", "href", "data-data") and value and not (
                        value.startswith("data:image/png;base64,") and tag == "img" or _local(value)):
                    problems.append(f"{key}={value[:40]!r} on <{tag}>")
                if key == "http-equiv" and value.lower() == "content-security-policy":
                    Scan.policies.append(values.get("content", ""))
            if tag == "script":
                Scan.scripts += 1
                Scan.in_script = True
                if not values.get("src"):
                    problems.append("an inline script (a <script> without src)")
            if tag == "link" and values.get("rel", "").lower() != "stylesheet":
                problems.append(f"<link rel={values.get('rel', '')[:40]!r}>")

        def handle_endtag(self, tag):
            if tag == "script":
                Scan.in_script = False

        def handle_data(self, data):
            if Scan.in_script and data.strip():
                problems.append("script text inside a <script> element")

    scan = Scan()
    scan.feed(html)
    if Scan.scripts == 0:
        problems.append("no script element (the page loads viewer/viewer.js)")
    if len(Scan.policies) != 1:
        problems.append(f"{len(Scan.policies)} Content-Security-Policy elements (one expected)")
    problems += [p for policy in Scan.policies for p in csp_problems(policy)]
    if PWNED + '="' in html:
        problems.append("a hostile attribute in the markup")
    return problems


def csp_problems(policy: str) -> list[str]:
    """What lets a page's Content-Security-Policy run more than the report's own script files: no
    default-src 'none', a script-src missing or allowing inline script, eval, hashes, nonces or any
    source but 'self' and file:, or a base-uri other than 'none'."""
    directives = {}
    for part in policy.split(";"):
        words = part.split()
        if words:
            directives.setdefault(words[0].lower(), [w.lower() for w in words[1:]])
    problems = []
    if directives.get("default-src") != ["'none'"]:
        problems.append("CSP: default-src is not 'none'")
    scripts = directives.get("script-src")
    if scripts is None:
        problems.append("CSP: no script-src")
    else:
        problems += [f"CSP: script-src allows {w}" for w in scripts if w not in ("'self'", "file:")]
    if directives.get("base-uri") != ["'none'"]:
        problems.append("CSP: base-uri is not 'none'")
    return problems


def _local(value: str) -> bool:
    """A relative path inside the report folder: no scheme, not absolute, no '..', no backslash."""
    return ":" not in value and not value.startswith("/") and ".." not in value and "\\" not in value


def markdown_problems(md: str) -> list[str]:
    """Raw HTML, control characters or broken table rows in a Markdown summary."""
    problems = []
    if any(c in md for c in "<>"):
        problems.append("raw < or > (HTML) in the Markdown")
    if any(ord(c) < 32 and c != "\n" for c in md):
        problems.append("control characters")
    for table in md.split("\n\n"):
        rows = [r for r in table.splitlines() if r.startswith("|")]
        widths = {len(r.replace("\\|", "").split("|")) for r in rows}
        if len(widths) > 1:
            problems.append(f"a table whose rows have {sorted(widths)} cells")
    return problems


def terminal_problems(text: str) -> list[str]:
    """Characters a terminal would interpret (anything but newline below U+0020, DEL, C1, bidi controls)."""
    bad = sorted({f"U+{ord(c):04X}" for c in text if (ord(c) < 32 and c != "\n") or 0x7F <= ord(c) <= 0x9F
                  or 0x202A <= ord(c) <= 0x202E or 0x2066 <= ord(c) <= 0x2069})
    return [f"control characters {', '.join(bad)}"] if bad else []
