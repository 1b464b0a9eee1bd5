"""Bottom-layer file helpers: JSON serialisation of results and the one output layer.

Used by every layer that writes (io writers, model files, reports, the demo, the CLI); depends on
nothing of usvid but :mod:`usvid.errors`. Every file usvid writes goes through
:func:`write_atomic`; a command checks its outputs against its inputs first with
:func:`check_outputs`; a command that fills a folder claims it with :func:`claim_output_dir`.

- :func:`check_outputs` ``(outputs, inputs, patterns)``: a :class:`OutputError` when an output is
  one of the inputs (paths resolved, symlinks followed, hard links compared by device and inode),
  lies inside an input folder, would match a glob the command reads its inputs from, is a folder,
  or is a device node, FIFO or socket (never replaced: ``--out /dev/null`` is refused).
- :func:`check_input` ``(path, what)``: the one check of a file a command reads: a regular file
  (a clear error for a FIFO, which would block the reader, a device such as ``/dev/zero``, which
  never ends, a socket or a folder); :func:`read_input_bytes` / :func:`read_input_text` read one
  with a size bound (``O_NONBLOCK``: a FIFO swapped in is refused, never waited on).
- :func:`write_atomic` ``(path, data, inputs=())``: temporary file in the same folder, ``fsync``,
  rename; an OS error (permission, no space, read-only file system, name too long, a parent that
  is not a folder, file size limit) becomes one :class:`OutputError` line naming the path and
  the reason, and nothing is left under the final name nor a temporary file beside it. A
  temporary file of the same output left by an earlier run killed with SIGKILL (older than this
  process) is removed on the next write.
- :func:`publish` ``(tmp, path)``: rename a finished file or folder written beside ``path``
  into place (a writer that makes a folder, such as a ROS 2 bag); never deletes a non-empty
  folder.
- :func:`claim_output_dir` ``(path, force)``: create a run folder, or accept one usvid created
  (it holds the marker file ``.usvid-run``) or an empty one; a non-empty folder usvid did not
  create is refused unless ``force``. usvid never deletes files in a claimed folder.
- :func:`move_into` ``(src_dir, dst_dir)``: move the files of a temporary folder into place one by
  one (each rename atomic), leaving every other file of ``dst_dir`` alone.
"""

from __future__ import annotations

import errno
import functools
import json
import math
import os
import re
import stat
import sys
import tempfile
import time
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from usvid.errors import UsvidError

#: Marker file of a folder created (and so owned) by a usvid command.
RUN_MARKER = ".usvid-run"

_REASONS = {
    errno.EACCES: "permission denied",
    errno.EPERM: "operation not permitted",
    errno.ENOSPC: "no space left on device",
    errno.EDQUOT: "disk quota exceeded",
    errno.EROFS: "read-only file system",
    errno.ENAMETOOLONG: "file name too long",
    errno.ENOTDIR: "a parent is not a folder",
    errno.EISDIR: "is a folder",
    errno.EFBIG: "file too large (file size limit)",
    errno.ENOENT: "no such folder",
    errno.EEXIST: "a parent is not a folder",
    errno.EXDEV: "cross-device rename",
    errno.EINVAL: "invalid file name",
}


class OutputError(UsvidError):
    """An output cannot be written (OS error, or it would overwrite an input of the command)."""


def jsonable(obj: Any) -> Any:
    """``obj`` with numpy scalars/arrays, paths and non-finite floats made JSON-ready
    (NaN/inf -> null). numpy is not imported for this (``usvid --help`` spares it): without it
    loaded there is no numpy object to convert."""
    np = sys.modules.get("numpy")
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    if np is not None and isinstance(obj, np.ndarray):
        return jsonable(obj.tolist())
    if np is not None and isinstance(obj, np.generic):
        return jsonable(obj.item())
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    if isinstance(obj, Path):
        return str(obj)
    return obj


def to_json(obj: Any) -> str:
    """Serialise ``obj`` to JSON (numpy scalars/arrays converted, NaN/inf -> null)."""
    return json.dumps(jsonable(obj), indent=2, allow_nan=False)


def os_reason(exc: OSError) -> str:
    """A short human reason for an OS error (``"permission denied"``, ``"no space left on
    device"``, ...)."""
    return _REASONS.get(exc.errno or -1) or (exc.strerror or type(exc).__name__).lower()


def _resolved(p: str | Path) -> Path | None:
    try:
        return Path(os.path.realpath(os.fspath(p)))
    except (OSError, ValueError):
        return None


def _is_dir(p: Path) -> bool:
    try:
        return p.is_dir()
    except (OSError, ValueError):
        return False


def _probe(out: Path) -> None:
    """Can a file be created next to ``out``? (one temporary file, removed at once)"""
    if len(os.fsencode(out.name)) > 255 - 16:  # room for the temporary file's affixes
        raise OutputError(f"{out}: cannot write (file name too long)")
    anc = out.parent
    while not anc.exists() and anc != anc.parent:
        anc = anc.parent
    if not _is_dir(anc):
        raise OutputError(f"{out}: cannot write (a parent is not a folder)")
    try:
        fd, tmp = tempfile.mkstemp(prefix=".usvid-probe.", dir=anc)
        os.close(fd)
        os.unlink(tmp)
    except OSError as exc:
        raise _fail(out, exc) from None


def file_type(mode: int) -> str:
    """What a file of ``st_mode`` ``mode`` is, in words: ``"a regular file"``, ``"a folder"``,
    ``"a FIFO (named pipe)"``, ``"a character device"``, ``"a block device"``, ``"a socket"``."""
    for test, name in ((stat.S_ISREG, "a regular file"), (stat.S_ISDIR, "a folder"),
                       (stat.S_ISFIFO, "a FIFO (named pipe)"),
                       (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
                       (stat.S_ISSOCK, "a socket")):
        if test(mode):
            return name
    return "not a regular file"


def special_file(path: str | Path) -> str | None:
    """What ``path`` is (:func:`file_type`, symlinks followed) when it exists and is neither a
    regular file nor a folder: a device node, FIFO or socket, which no command may write over or
    read as a file; ``None`` otherwise (also when it does not exist)."""
    try:
        mode = os.stat(path).st_mode
    except (OSError, ValueError):
        return None
    if stat.S_ISREG(mode) or stat.S_ISDIR(mode):
        return None
    return file_type(mode)


def _split_glob(text: str) -> list[str]:
    return [c for c in os.path.normpath(os.path.abspath(text)).split(os.sep) if c]


_MAGIC = re.compile(r"[*?\[]")


def _glob_prefix(comps: list[str]) -> str:
    """The literal folder a glob's components start with, as a path prefix (a quick filter:
    a path outside it cannot match)."""
    lead = next((k for k, c in enumerate(comps) if _MAGIC.search(c)), len(comps))
    return os.sep + os.sep.join(comps[:lead])


def _glob_match(parts: list[str], pattern: list[str]) -> bool:
    """Path components ``parts`` matched by the glob components ``pattern`` as
    :func:`glob.glob` with ``recursive=True`` reads them (``**`` spans any number of folders,
    ``*``, ``?`` and ``[...]`` stay within one component)."""
    import fnmatch

    if not pattern:
        return not parts
    if not _MAGIC.search(pattern[0]):  # a plain name: compared, no pattern matching
        return bool(parts) and parts[0] == pattern[0] and _glob_match(parts[1:], pattern[1:])
    if pattern[0] == "**":
        return any(_glob_match(parts[i:], pattern[1:]) for i in range(len(parts) + 1))
    return bool(parts) and fnmatch.fnmatchcase(parts[0], pattern[0]) \
        and _glob_match(parts[1:], pattern[1:])


def check_outputs(outputs: Iterable[str | Path | None],
                  inputs: Iterable[str | Path | None] = (), *, probe: bool = True,
                  patterns: Iterable[str] = ()) -> None:
    """Refuse outputs that would overwrite an input of the same command, that are folders,
    device nodes, FIFOs or sockets, or that cannot be created.

    ``outputs``, ``inputs``: file paths (``None`` entries are ignored; an input folder such as a
    ROS 2 bag also protects every file inside it). Paths are compared resolved (``./``, ``..``,
    symlinks) and by device and inode (hard links). ``patterns``: globs (absolute, or relative
    to the working folder) the command reads its inputs from: an output a pattern matches would
    be read back as an input by the next run, and is refused too. ``probe``: also create and
    remove a temporary file in the output's folder (or its nearest existing ancestor), so a
    read-only or full file system, a missing permission or a too long name is reported before
    any work. Raises :class:`OutputError` naming the path:
    ``"in.dat: output would overwrite the input in.dat; choose another output path"``.
    """
    # the inputs indexed once (a campaign has thousands of logs): resolved paths, (device,
    # inode) of those that exist, and the folders among them
    by_path: dict[Path, Path] = {}
    by_id: dict[tuple[int, int], Path] = {}
    folders: dict[Path, Path] = {}
    for i in (Path(x) for x in inputs if x is not None and str(x) != ""):
        ri = _resolved(i)
        if ri is not None:
            by_path.setdefault(ri, i)
        try:
            st = os.stat(i)
        except (OSError, ValueError):
            continue
        by_id.setdefault((st.st_dev, st.st_ino), i)
        if stat.S_ISDIR(st.st_mode) and ri is not None:
            folders.setdefault(ri, i)
    globs = {g: (_glob_prefix(c), c) for g in dict.fromkeys(str(x) for x in patterns)
             for c in [_split_glob(g)]}
    for out in outputs:
        if out is None:
            continue
        o = Path(out)
        kind = special_file(o) if str(out) != "" else None
        if kind is not None:
            raise OutputError(f"{o}: is {kind}; usvid writes only regular files and never "
                              "replaces a device node, FIFO or socket: choose a file name")
        if str(out) == "" or _is_dir(o):
            raise OutputError(f"{str(out) or repr('')}: output is a folder or empty; give a "
                              "file name")
        ro = _resolved(o)
        hit = by_path.get(ro) if ro is not None else None
        if hit is None:
            try:
                st = os.stat(o)
                hit = by_id.get((st.st_dev, st.st_ino))  # a hard link of an input
            except (OSError, ValueError):
                pass
        if hit is None and ro is not None:  # inside an input folder (a ROS 2 bag)
            hit = next((folders[d] for d in ro.parents if d in folders), None)
        if hit is not None:
            raise OutputError(f"{o}: output would overwrite the input {hit}; choose another "
                              "output path")
        names = {os.path.normpath(os.path.abspath(o)), *([str(ro)] if ro is not None else [])}
        for text, (prefix, g) in globs.items():
            if any(n.startswith(prefix) and _glob_match(_split_glob(n), g) for n in names):
                raise OutputError(f"{o}: output would be read back as an input (it matches "
                                  f"the glob {text!r}); choose another output folder")
        if probe:
            _probe(o)


def _fail(path: Path, exc: OSError) -> OutputError:
    return OutputError(f"{path}: cannot write ({os_reason(exc)})")


def _make_parent(path: Path) -> None:
    parent = path.parent
    try:
        parent.mkdir(parents=True, exist_ok=True)
    except FileExistsError:  # a component exists and is not a folder
        raise OutputError(f"{path}: cannot write (a parent is not a folder)") from None
    except OSError as exc:
        raise _fail(path, exc) from None


#: When this process started using usvid [s since the epoch]: temporary files of an output
#: older than this were left by an earlier run (a SIGKILL between writing and renaming).
PROCESS_START = time.time()


def _clean_stale_temps(path: Path) -> None:
    """Remove our own temporary files of ``path`` (``.NAME.XXXXXXXX.tmp``, as
    :func:`write_atomic` names them) last modified before this process started: a process
    killed with SIGKILL between creating and renaming one leaves it. Another live writer's
    temporary file is newer (it is being written) and is left alone; errors are ignored."""
    pat = re.compile(re.escape(f".{path.name[:80]}.") + r"[A-Za-z0-9_]{8}\.tmp")
    try:
        entries = list(os.scandir(path.parent))
    except OSError:
        return
    for e in entries:
        if not pat.fullmatch(e.name):
            continue
        try:
            if e.is_file(follow_symlinks=False) and e.stat(
                    follow_symlinks=False).st_mtime < PROCESS_START:
                os.unlink(e.path)
        except OSError:
            pass


def publish(tmp: str | Path, path: str | Path) -> Path:
    """Move a finished file or folder ``tmp`` (written beside ``path``) to ``path`` with one
    atomic rename. A file replaces a file; a folder takes the place of nothing or of an empty
    folder: an existing non-empty folder (a user's data, an earlier bag) is never deleted, it
    is an :class:`OutputError`. OS errors are one-line :class:`OutputError` naming ``path``."""
    tmp, path = Path(tmp), Path(path)
    kind = special_file(path)
    if kind is not None:
        raise OutputError(f"{path}: is {kind}; usvid writes only regular files and never "
                          "replaces a device node, FIFO or socket: choose a file name")
    if tmp.is_dir():
        if path.is_dir() and any(path.iterdir()):
            raise OutputError(f"{path}: a folder with files already exists (not replaced: "
                              "remove it or choose another name)")
        if path.exists() and not path.is_dir():
            raise OutputError(f"{path}: cannot write a folder (a file has that name)")
    elif path.is_dir():
        raise OutputError(f"{path}: cannot write (is a folder)")
    try:
        os.replace(tmp, path)
    except OSError as exc:
        raise _fail(path, exc) from None
    _fsync_dir(path.parent)
    return path


def write_atomic(path: str | Path, data: str | bytes, *,
                 inputs: Iterable[str | Path | None] = ()) -> Path:
    """Write ``data`` (text as UTF-8, or bytes) to ``path`` atomically; returns the path.

    A temporary file in the same folder is written, flushed, ``fsync``-ed and renamed over
    ``path``, so an interrupted or failed write (Ctrl-C, SIGKILL, full disk) never leaves a
    half-written file under ``path``; concurrent writers leave one complete file. ``inputs``:
    paths the output must not overwrite (see :func:`check_outputs`). Raises
    :class:`OutputError` (one line naming the path and the reason) on any OS error.
    """
    path = Path(path)
    check_outputs([path], inputs, probe=False)
    _make_parent(path)
    _clean_stale_temps(path)
    mode = "wb" if isinstance(data, bytes) else "w"
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name[:80]}.", suffix=".tmp", dir=path.parent)
    except OSError as exc:
        raise _fail(path, exc) from None
    try:
        # mkstemp creates 0600; give the file the mode an ordinary open() would (0666 & ~umask)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
        with os.fdopen(fd, mode, **({} if mode == "wb" else {"encoding": "utf-8"})) as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException as exc:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        if isinstance(exc, OSError):
            raise _fail(path, exc) from None
        raise
    _fsync_dir(path.parent)
    return path


def _fsync_dir(folder: Path) -> None:
    """Make a rename durable (best effort: not every file system lets a folder be opened)."""
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def claim_output_dir(path: str | Path, *, force: bool = False, command: str = "usvid") -> Path:
    """Create the output folder ``path`` of a command, or accept an existing one it may fill.

    Accepted: a new folder (created, with the marker file ``.usvid-run``), an empty folder, or a
    folder holding the marker (a previous usvid run). A non-empty folder without the marker is
    refused with :class:`OutputError` unless ``force`` (then usvid writes its own files there and
    deletes nothing). Returns the folder.
    """
    p = Path(path)
    if str(path) == "":
        raise OutputError("'': output folder name is empty")
    if p.exists() and not p.is_dir():
        raise OutputError(f"{p}: output folder is an existing file; choose another")
    if p.is_dir():
        try:
            entries = [e.name for e in os.scandir(p)]
        except OSError as exc:
            raise OutputError(f"{p}: cannot use as output folder ({os_reason(exc)})") from None
        if entries and RUN_MARKER not in entries and not force:
            raise OutputError(
                f"{p}: output folder is not empty and was not created by usvid; choose a new "
                "or empty folder, or give --force (usvid then deletes nothing there)")
    else:
        try:
            p.mkdir(parents=True, exist_ok=True)
        except FileExistsError:
            raise OutputError(f"{p}: cannot create (a parent is not a folder)") from None
        except OSError as exc:
            raise OutputError(f"{p}: cannot create ({os_reason(exc)})") from None
    if not (p / RUN_MARKER).exists():
        write_atomic(p / RUN_MARKER, json.dumps({"created_by": command}) + "\n")
    return p


def move_into(src_dir: str | Path, dst_dir: str | Path) -> list[Path]:
    """Move every file under ``src_dir`` to the same relative path under ``dst_dir`` (each one
    an atomic rename on the same file system); files of ``dst_dir`` with other names are left
    alone. Returns the destination paths. Raises :class:`OutputError` naming the path."""
    src, dst = Path(src_dir), Path(dst_dir)
    moved = []
    for root, _dirs, files in os.walk(src):
        for name in sorted(files):
            s = Path(root) / name
            d = dst / s.relative_to(src)
            _make_parent(d)
            if d.is_dir():
                raise OutputError(f"{d}: cannot write (is a folder)")
            try:
                os.replace(s, d)
            except OSError as exc:
                raise _fail(d, exc) from None
            moved.append(d)
    return moved


# ----------------------------------------------------------------------------------------------
# inputs: regular files only, read with a bound
# ----------------------------------------------------------------------------------------------
def _refuse_type(path: str | Path, mode: int, what: str, folder: bool,
                 error: type[UsvidError]) -> None:
    if stat.S_ISREG(mode) or (folder and stat.S_ISDIR(mode)):
        return
    if stat.S_ISDIR(mode):
        raise error(f"{path}: is a folder, not a {what}")
    raise error(f"{path}: is {file_type(mode)}, not a regular file; a {what} is read only "
                "from a regular file")


def check_input(path: str | Path, what: str = "file", *, folder: bool = False,
                error: type[UsvidError] = UsvidError) -> os.stat_result:
    """The one check of a file a command reads, before it is opened: it exists and is a regular
    file (or, with ``folder``, a folder, e.g. a ROS 2 bag). A FIFO (the reader would block until
    a writer comes), a device node (``/dev/zero`` never ends), a socket, and a folder where a
    file is wanted are refused with one line naming the path and what it is. ``what`` names the
    file in the message (``"log"``, ``"model file"``); ``error`` is the class raised. Returns the
    ``os.stat`` result (symlinks followed)."""
    try:
        st = os.stat(path)
    except FileNotFoundError:
        raise error(f"{path}: cannot read the {what}: not found (no such file)") from None
    except (OSError, ValueError) as exc:
        reason = os_reason(exc) if isinstance(exc, OSError) else "invalid file name"
        raise error(f"{path}: cannot read the {what} ({reason})") from None
    _refuse_type(path, st.st_mode, what, folder, error)
    return st


def read_input_bytes(path: str | Path, what: str, max_bytes: int, *,
                     error: type[UsvidError] = UsvidError) -> bytes:
    """The bytes of the input file ``path`` (:func:`check_input`), at most ``max_bytes``: a
    larger file is an :class:`InputLimitError` naming the bound, refused before it is read.
    The file is opened read-only and non-blocking and checked again on the open descriptor, so
    a FIFO put in its place after the check is refused too, never waited on. Errors are
    ``error`` (the size bound :class:`InputLimitError` when ``error`` is the base class)."""
    check_input(path, what, error=error)
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0))
    except FileNotFoundError:
        raise error(f"{path}: cannot read the {what}: not found (no such file)") from None
    except (OSError, ValueError) as exc:
        reason = os_reason(exc) if isinstance(exc, OSError) else "invalid file name"
        raise error(f"{path}: cannot read the {what} ({reason})") from None
    with os.fdopen(fd, "rb") as fh:
        st = os.fstat(fh.fileno())
        _refuse_type(path, st.st_mode, what, False, error)
        # (the caller's error class when it names one: it may be caught as such)
        limit = InputLimitError if error is UsvidError else error
        if st.st_size > max_bytes:
            raise limit(f"{path}: {st.st_size} bytes; a {what} has at most {max_bytes} bytes")
        try:
            data = fh.read(max_bytes + 1)
        except OSError as exc:
            raise error(f"{path}: cannot read the {what} ({os_reason(exc)})") from None
    if len(data) > max_bytes:  # (grew while read)
        raise limit(f"{path}: more than {max_bytes} bytes; a {what} has at most {max_bytes} "
                    "bytes")
    return data


def read_input_text(path: str | Path, what: str, max_bytes: int, *,
                    error: type[UsvidError] = UsvidError) -> str:
    """The text of the input file ``path`` (:func:`read_input_bytes`), which must be UTF-8 (a
    leading byte-order mark is dropped): UTF-16 or other bytes are one line naming the file,
    the offset and what to do."""
    data = read_input_bytes(path, what, max_bytes, error=error)
    if data.startswith((b"\xff\xfe", b"\xfe\xff")):
        raise error(f"{path}: is UTF-16 text; save the {what} as UTF-8")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise error(f"{path}: is not UTF-8 text (byte 0x{data[exc.start]:02x} at offset "
                    f"{exc.start}); save the {what} as UTF-8") from None
    return text[1:] if text.startswith("\ufeff") else text


# ----------------------------------------------------------------------------------------------
# untrusted text: JSON and YAML with bounds
# ----------------------------------------------------------------------------------------------
#: Deepest nesting of lists/mappings accepted in a spec, model file or run file.
MAX_DEPTH = 64
#: Most YAML nodes after expanding aliases (an alias bomb of a few hundred bytes expands to
#: billions); specs hold a few hundred.
MAX_YAML_NODES = 100_000
#: Most decimal digits of a JSON integer (a float holds 308; anything longer is hostile).
MAX_INT_DIGITS = 309


class InputLimitError(UsvidError):
    """An input file exceeds a bound (size, nesting, alias expansion, number magnitude)."""


def _short(text: str, n: int = 80) -> str:
    return text if len(text) <= n else text[:n] + "..."


def _json_depth(text: str) -> int:
    """Deepest bracket nesting of a JSON text (strings skipped)."""
    import re

    import numpy as np

    stripped = re.sub(r'"(?:[^"\\]|\\.)*"', '""', text)
    b = np.frombuffer(stripped.encode("utf-8", "replace"), dtype=np.uint8)
    step = np.zeros(len(b), dtype=np.int32)
    step[(b == ord("[")) | (b == ord("{"))] = 1
    step[(b == ord("]")) | (b == ord("}"))] = -1
    return int(np.cumsum(step).max(initial=0))


def _parse_int(s: str) -> int:
    if len(s.lstrip("-")) > MAX_INT_DIGITS:
        raise InputLimitError(f"an integer of {len(s.lstrip('-'))} digits (at most "
                              f"{MAX_INT_DIGITS})")
    return int(s)


def load_json_text(text: str, source: str, *, max_depth: int = MAX_DEPTH,
                   parse_constant: Any = None) -> Any:
    """Parse untrusted JSON ``text`` with bounds: nesting at most ``max_depth``, integers of at
    most 309 digits. Raises :class:`InputLimitError` or :class:`UsvidError` (``"source line L
    column C: not valid JSON (...)"``) naming ``source``."""
    depth = _json_depth(text)
    if depth > max_depth:
        raise InputLimitError(f"{source}: nested {depth} levels deep (at most {max_depth})")
    try:
        return json.loads(text, parse_int=_parse_int, parse_constant=parse_constant)
    except InputLimitError as exc:
        raise InputLimitError(f"{source}: {exc}") from None
    except json.JSONDecodeError as exc:
        raise UsvidError(f"{source} line {exc.lineno} column {exc.colno}: not valid JSON "
                         f"({exc.msg})") from None
    except (ValueError, RecursionError) as exc:
        raise UsvidError(f"{source}: not valid JSON ({_short(str(exc))})") from None


@functools.cache
def _bounded_loader_class() -> type:
    """``yaml.SafeLoader`` refusing nodes nested deeper than its ``max_depth`` (naming its
    ``source`` and the line); made once (a class made per document cost more than parsing a
    small one)."""
    import yaml

    class Loader(yaml.SafeLoader):
        depth = 0
        max_depth = MAX_DEPTH
        source = "?"

        def compose_node(self, parent: Any, index: Any) -> Any:
            self.depth += 1
            if self.depth > self.max_depth:
                mark = self.peek_event().start_mark
                raise InputLimitError(f"{self.source} line {mark.line + 1}: nested more than "
                                      f"{self.max_depth} levels deep")
            try:
                return super().compose_node(parent, index)
            finally:
                self.depth -= 1

    return Loader


def _expanded_nodes_exceed(root: Any, max_nodes: int) -> bool:
    """True when the YAML node graph from ``root`` (``yaml.Node`` objects, aliases being shared
    nodes) has more than ``max_nodes`` nodes once every alias is expanded into a copy, or has
    a cycle (``&a [*a]``: infinitely many). Mappings count their keys and values, sequences
    their items, every node itself. Each distinct node is visited once (an alias bomb's
    billions of expanded nodes are counted as sums of its few distinct ones)."""
    import yaml

    def children(nd: Any) -> list:
        if isinstance(nd, yaml.MappingNode):
            return [x for kv in nd.value for x in kv]
        if isinstance(nd, yaml.SequenceNode):
            return nd.value
        return []

    size: dict[int, int | None] = {}  # id -> expanded size; None while its subtree is counted
    stack: list[tuple[Any, bool]] = [(root, False)]
    while stack:
        nd, done = stack.pop()
        k = id(nd)
        if done:
            total = 1 + sum(size[id(c)] for c in children(nd))  # type: ignore[misc]
            if total > max_nodes:
                return True
            size[k] = total
            continue
        if k in size:
            if size[k] is None:  # on the path being counted: a cycle
                return True
            continue
        size[k] = None
        stack.append((nd, True))
        stack.extend((c, False) for c in children(nd))
    return False


def load_yaml_text(text: str, source: str, *, max_depth: int = MAX_DEPTH,
                   max_nodes: int = MAX_YAML_NODES) -> Any:
    """Parse untrusted YAML ``text`` the safe way (``yaml.SafeLoader``: plain data only) with
    bounds: nesting at most ``max_depth``, at most ``max_nodes`` nodes once aliases are expanded
    (so an alias bomb is refused in milliseconds). Raises :class:`InputLimitError` or
    :class:`UsvidError` naming ``source`` and the line."""
    import yaml

    try:
        loader = _bounded_loader_class()(text)  # the reader refuses control characters here
    except yaml.YAMLError as exc:
        raise UsvidError(f"{source}: not usable YAML ({_short(str(exc))})") from None
    loader.max_depth, loader.source = max_depth, source
    try:
        node = loader.get_single_node()
        if node is None:
            return None
        if _expanded_nodes_exceed(node, max_nodes):
            raise InputLimitError(f"{source}: more than {max_nodes} YAML nodes once aliases "
                                  "are expanded (an alias bomb?)")
        return loader.construct_document(node)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" line {mark.line + 1}" if mark is not None else ""
        problem = getattr(exc, "problem", None) or "invalid YAML"
        raise UsvidError(f"{source}:{where} {_short(str(problem))}") from None
    except (RecursionError, ValueError, OverflowError) as exc:
        raise UsvidError(f"{source}: not usable YAML ({_short(str(exc))})") from None
    finally:
        loader.dispose()
