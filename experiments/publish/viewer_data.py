"""The report viewer's data: one small JavaScript file per row and per reference, loaded on demand.

    write(out_dir, rows, labels) -> {row id: "viewer/rows/RID.js"}   # the rows that have data
    copy_assets(out_dir)                              # experiments/publish/viewer/* -> DIR/viewer/

A page opened from disk (file://) cannot fetch() files beside it, but it can load a script. So each
data file is exactly one statement, `window.iblcheckViewer.add(JSON);`, that viewer/viewer.js loads by
inserting a `<script src>` when a row is opened (the Content-Security-Policy allows scripts from the
report's origin over HTTP and from file: URLs on disk; the page names only files inside the report folder).
JSON is `json.dumps(..., ensure_ascii=True)`: every character outside ASCII
(U+2028 and U+2029 included) is a \\u escape, and `<`, `>`, `&` are escaped as well, so no name in it
can end the string, the statement or a `<script>` element.

The arrays (docs/contract.md: images are H x W x C, row 0 at the top) are stored as

    {"channels": 3|1, "dtype": "f16"|"u8", "codec": "deflate", "data": BASE64, "clamped": n (f16 only)}

where BASE64 is base64 of zlib.compress (RFC 1950, what the browser's DecompressionStream("deflate")
reads) of the little-endian array bytes, row-major. Linear radiance (the real-time image, the reference
and its second seed) is float16: magnitudes above 65504 are stored as 65504 and counted in `clamped`;
the error map (|difference| of display values, mean over RGB) and the FLIP map are float16 in [0, 1];
the mask is u8 0/1.

A row file: {"id", "label", "width", "height", "tonemap": {"key", "white", "exposure", "adapt_lum"} or
null, "psnr", "reference": REFID or null, "images": {"test", "error", "flip", "mask"}} (images a row
did not keep are left out), and "display": "srgb" for a tone-mapped PNG/JPEG engine image, whose "test"
holds display values (sRGB-decoded code values), not radiance. A reference file: {"id": "ref-REFID", "width",
"height", "images":
{"reference", "reference2"}}.

Rebuilding a report rewrites only what changed: each file's content key (a hash of the format version,
the row's fields and the bytes of the files it is made from) is kept in viewer/data.json, and a file
whose key is unchanged is neither encoded nor written again. Files of rows no longer in the report are
removed.
"""

from __future__ import annotations

import base64
import hashlib
import json
import re
import zlib
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import numpy as np

from experiments.measure.results import ResultRow
from experiments.publish import images
from experiments.publish.outputs import write_bytes, write_text
from experiments.publish.text import one_line
from scenes import InputError

#: bump when the files' format changes (part of every content key, so a rebuild rewrites them all)
FORMAT_VERSION = 1
#: the folder of the viewer in a report, its data and the index of content keys
VIEWER, ROWS, REFS, INDEX = "viewer", "rows", "refs", "data.json"
#: the call each data file makes (viewer/viewer.js defines it)
CALL = "window.iblcheckViewer.add("
#: an id usable as a file name and in a URL as it is
_PLAIN = re.compile(r"[A-Za-z0-9_-]{1,64}")


def encode(values: np.ndarray, dtype: str) -> dict:
    """One image as the viewer reads it (module docstring): float16 ("f16", clamped and counted) or
    uint8 ("u8"), little-endian, row-major, deflated and base64-encoded."""
    clamped = None
    if dtype == "f16":
        half, clamped = images.to_float16(values)
        data = half.astype("<f2")
    elif dtype == "u8":
        data = np.asarray(values).astype(np.uint8)
    else:
        raise ValueError(f"dtype {dtype!r}: 'f16' or 'u8'")
    out = {"channels": 1 if data.ndim == 2 else int(data.shape[2]), "dtype": dtype, "codec": "deflate",
           "data": base64.b64encode(zlib.compress(np.ascontiguousarray(data).tobytes(), 6)).decode("ascii")}
    return out if clamped is None else {**out, "clamped": clamped}


def statement(payload: dict) -> str:
    """The whole data file: one call whose argument is ASCII-only JSON with <, > and & escaped too."""
    text = json.dumps(payload, ensure_ascii=True, allow_nan=False, separators=(",", ":"))
    # JSON allows these escapes inside strings and they never occur outside one in json.dumps' output
    text = text.replace("<", "\\u003c").replace(">", "\\u003e").replace("&", "\\u0026")
    return f"{CALL}{text});\n"


def file_id(text: str) -> str:
    """`text` when it is a plain id (letters, digits, '_' and '-', at most 64), else a hash of it:
    a name safe in a file name, a URL and an HTML attribute, the same for the same text."""
    return text if _PLAIN.fullmatch(text) else _hashed(text)


def _hashed(text: str) -> str:
    return "h" + hashlib.sha256(text.encode("utf-8", "surrogatepass")).hexdigest()[:16]


def reference_id(rel: str) -> str:
    """The viewer's id of a reference folder (the path of its reference.npz relative to the results
    folder): its folders below images/ joined by '.', which plain ids never hold (or a hash of it)."""
    parts = Path(rel).parent.parts
    parts = parts[1:] if parts[:1] == ("images",) else parts
    joined = ".".join(parts)
    return joined if parts and all(_PLAIN.fullmatch(p) for p in parts) and len(joined) <= 128 else _hashed(rel)


def _digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _key(*parts: object) -> str:
    return hashlib.sha256(json.dumps([FORMAT_VERSION, *parts], sort_keys=True, default=str).encode()).hexdigest()


@dataclass
class Written:
    """What `write` did: the data file of each row that has one, why the others have none, and how
    many files it wrote and left as they were."""

    rows: dict[str, str]
    missing: dict[str, str]
    written: int = 0
    kept: int = 0


class _Index:
    """viewer/data.json: {file: content key} of the files as last written."""

    def __init__(self, folder: Path) -> None:
        self.path = folder / INDEX
        try:
            old = json.loads(self.path.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            old = {}
        self.old = old if isinstance(old, dict) else {}
        self.new: dict[str, str] = {}

    def fresh(self, folder: Path, rel: str, key: str) -> bool:
        self.new[rel] = key
        return self.old.get(rel) == key and (folder / rel).is_file()

    def save(self) -> None:
        if self.new != self.old:
            write_text(self.path, json.dumps(self.new, indent=0, sort_keys=True) + "\n")


def write(out_dir: Path, rows: list[ResultRow], labels: dict[str, str]) -> Written:
    """The data files of `rows` under out_dir/viewer (module docstring); `labels`: each row's label
    by row id. A row whose measured arrays are absent or unreadable gets no file, with the reason."""
    out_dir = Path(out_dir)
    folder = out_dir / VIEWER
    for sub in (ROWS, REFS):
        (folder / sub).mkdir(parents=True, exist_ok=True)
    index = _Index(folder)
    done = Written({}, {})
    refs: dict[str, str] = {}  # reference.npz path -> its id, each written once
    for row in rows:
        why = _write_row(out_dir, folder, row, labels.get(row.id, row.scene), index, refs, done)
        if why:
            done.missing[row.id] = why
    for sub in (ROWS, REFS):  # the files of rows and references no longer in the report
        for old in sorted((folder / sub).glob("*.js")):
            if f"{sub}/{old.name}" not in index.new:
                old.unlink()
    index.save()
    return done


def _write_row(out_dir: Path, folder: Path, row: ResultRow, label: str, index: _Index, refs: dict[str, str],
               done: Written) -> str | None:
    """Write (or keep) `row`'s file and its reference's; None, or why the row has no data."""
    rel = row.images.get(images.ARRAYS)
    if row.error:
        return "the row failed: nothing was measured"
    if not rel:
        return "written before rows kept their arrays: run it again to view it"
    arrays = out_dir / rel
    if not arrays.resolve().is_relative_to(out_dir.resolve()):
        return f"its arrays {one_line(rel, 80)!r} lie outside the report folder"
    if not arrays.is_file():
        return f"its arrays {one_line(rel, 80)} are gone"
    ref_rel = images.reference_file(row)
    ref_path = out_dir / ref_rel if ref_rel else None
    ref_id = None
    if ref_path is not None and ref_path.resolve().is_relative_to(out_dir.resolve()) and ref_path.is_file():
        if ref_rel not in refs:
            try:
                refs[ref_rel] = _write_reference(out_dir, folder, row, ref_rel, reference_id(ref_rel), index, done)
            except InputError:
                refs[ref_rel] = ""  # unreadable: its rows are shown without their reference
        ref_id = refs[ref_rel] or None
    fields = {"id": row.id, "label": label, "width": row.width, "height": row.height, "psnr": row.psnr,
              "reference": ref_id}
    name = f"{ROWS}/{file_id(row.id)}.js"
    if index.fresh(folder, name, _key(fields, _digest(arrays))):
        done.rows[row.id], done.kept = f"{VIEWER}/{name}", done.kept + 1
        return None
    try:
        kept = images.load_measured(out_dir, row)
    except InputError as exc:
        index.new.pop(name)
        return one_line(str(exc), 200)
    if kept is None:
        index.new.pop(name)
        return "its arrays are gone"
    pictures = {"test": encode(kept.test.rgb, "f16"), "error": encode(kept.error, "f16")}
    if kept.flip is not None:
        pictures["flip"] = encode(kept.flip, "f16")
    pictures["mask"] = encode(kept.mask, "u8")
    payload = {**fields, "tonemap": kept.tonemap, "images": pictures}
    if kept.test.meta.get("encoding") == "srgb":  # a tone-mapped PNG/JPEG engine image: display values, no radiance
        payload["display"] = "srgb"
    write_text(folder / name, statement(payload))
    done.rows[row.id], done.written = f"{VIEWER}/{name}", done.written + 1
    return None


def _write_reference(out_dir: Path, folder: Path, row: ResultRow, ref_rel: str, ref_id: str, index: _Index,
                     done: Written) -> str:
    """Write (or keep) the file of the reference at `ref_rel`; returns its id."""
    name = f"{REFS}/{ref_id}.js"
    if index.fresh(folder, name, _key(ref_id, row.width, row.height, _digest(out_dir / ref_rel))):
        done.kept += 1
        return ref_id
    try:
        ref = images.load_reference(out_dir, row)
    except InputError:
        index.new.pop(name)
        raise
    if ref is None:
        index.new.pop(name)
        raise InputError(f"{ref_rel}: gone")
    pictures = {}
    for kind, values in (("reference", ref.reference), ("reference2", ref.reference2)):
        if values is not None:  # already float16: what was clamped is the count save_reference kept
            pictures[kind] = {**encode(values, "f16"), "clamped": ref.clamped.get(kind, 0)}
    write_text(folder / name, statement({"id": f"ref-{ref_id}", "width": row.width, "height": row.height,
                                         "images": pictures}))
    done.written += 1
    return ref_id


def copy_assets(out_dir: Path) -> list[str]:
    """Copy the viewer's own files (experiments/publish/viewer/, package data) into out_dir/viewer/,
    each only when its bytes differ; returns the names copied."""
    source = resources.files("experiments.publish") / VIEWER
    copied = []
    for item in sorted(source.iterdir(), key=lambda p: p.name) if source.is_dir() else []:
        if not item.is_file() or item.name.startswith(".") or item.name.endswith((".pyc", ".py")):
            continue
        data = item.read_bytes()
        target = Path(out_dir) / VIEWER / item.name
        if not target.is_file() or target.read_bytes() != data:
            target.parent.mkdir(parents=True, exist_ok=True)
            write_bytes(target, data)
            copied.append(item.name)
    return copied
