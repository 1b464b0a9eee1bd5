"""ROS logs: ROS 1 ``.bag``, ROS 2 bags (sqlite3 ``.db3`` or MCAP storage, a folder with
``metadata.yaml`` or the storage file alone) and plain ``.mcap`` files, read and written through
``rosbags`` (pure Python, no ROS installation; optional extra ``usvid[ros]``).

Reader: every spec column names a topic and a field of its message (see :mod:`usvid.io.spec`).
Message definitions come from the bag when it stores them (ROS 1 connection headers, MCAP
schemas, ROS 2 Iron+ sqlite3 bags), so custom messages are read too; otherwise from the standard
types of ROS 1 Noetic / ROS 2 Humble. The time of a sample is the bag's log (receive) time [ns];
when it is an epoch time (after 1980) ``meta["t0_utc"]`` is set. Frames follow ROS REP 103
(earth ENU, body x forward, y left, z up): a yaw from ``sensor_msgs/Imu.orientation`` is counted
counter-clockwise from east, and ``angular_velocity.z`` is positive to port, hence ``convert: yaw``
with ``frame: enu`` and ``sign: -1`` for ``r`` in the ``ros2_usv`` preset.

Rejected records (``Trial.rejected``): ``bad_message`` (a message that does not deserialise),
``corrupt_chunk`` (the storage failed part-way: what was read before is kept and a warning finding
says where reading stopped); fields that are NaN (ROS's "not available") are absent samples. A
file that is not a bag, a missing topic, a missing field or an unknown message type is a
:class:`usvid.errors.LogReadError` naming the file, topic and field.
"""

from __future__ import annotations

import contextlib
import functools
import math
import operator
import os
import pickle
import re
import shutil
import tempfile
import threading
from collections import OrderedDict
from pathlib import Path
from typing import Any

import numpy as np

from usvid.errors import LogReadError
from usvid.files import OutputError, check_outputs, os_reason, publish
from usvid.io._messages import (
    ReadState,
    Series,
    build_trial,
    get_path,
    missing_field,
    missing_topic,
    path_steps,
    quaternion_zyx,
    raw_of,
    require,
    width,
)
from usvid.io.spec import FormatSpec
from usvid.io.writers import channel_or_none, log_start_epoch
from usvid.trial import Finding, Trial

#: Bag kinds recognised by :func:`bag_kind`.
BAG_KINDS = ("ros1", "ros2_sqlite3", "ros2_mcap", "mcap")
MCAP_MAGIC = b"\x89MCAP0\r\n"
ROS1_MAGIC = b"#ROSBAG V2.0\n"
SQLITE_MAGIC = b"SQLite format 3\x00"


def bag_kind(path: Path) -> str | None:
    """``ros1``, ``ros2_sqlite3``, ``ros2_mcap`` (a ROS 2 bag folder or its storage file) or
    ``mcap`` (a plain MCAP file) by content, ``None`` when ``path`` is none of these."""
    if path.is_dir():
        meta = path / "metadata.yaml"
        if not meta.is_file():
            return None
        text = meta.read_text(encoding="utf-8", errors="replace")
        return "ros2_mcap" if "storage_identifier: mcap" in text else "ros2_sqlite3"
    try:
        with open(path, "rb") as fh:
            head = fh.read(16)
    except OSError:
        return None
    if head.startswith(ROS1_MAGIC):
        return "ros1"
    if head.startswith(MCAP_MAGIC):
        return "ros2_mcap" if (path.parent / "metadata.yaml").is_file() else "mcap"
    if head.startswith(SQLITE_MAGIC):
        return "ros2_sqlite3"
    return None


def _open_path(path: Path, kind: str) -> Path:
    """What rosbags opens: a ``.bag`` / ``.mcap`` / ``.db3`` file or a bag folder. rosbags picks
    its storage by the suffix, so a file with another name is linked under the right one."""
    want = {"ros1": ".bag", "mcap": ".mcap", "ros2_mcap": ".mcap", "ros2_sqlite3": ".db3"}[kind]
    if path.is_dir() or path.suffix == want:
        return path
    tmp = Path(tempfile.mkdtemp(prefix="usvid-bag-"))
    link = tmp / f"log{want}"
    try:
        os.symlink(path.resolve(), link)
    except OSError:
        shutil.copyfile(path, link)
    return link


def _storage_files(path: Path, kind: str) -> list[Path]:
    """The MCAP / sqlite3 storage files rosbags will open for ``path``: the file itself, or the
    files a ROS 2 bag folder's ``metadata.yaml`` lists, found in its text (a block list of plain
    names under ``relative_file_paths``, as rosbag2 and rosbags write it). Only those sure to be
    opened: none for a zstd-compressed bag or a list written another way (rosbags checks them)."""
    if kind == "ros1":
        return []
    if not path.is_dir():
        return [path]
    try:
        text = (path / "metadata.yaml").read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError):
        return []
    if re.search(r"^\s*compression_mode:\s*['\"]?[Ff][Ii][Ll][Ee]", text, re.M):
        return []
    m = re.search(r"^( *)relative_file_paths:[ \t]*\n((?:\1[ ]*- .*(?:\n|$))+)", text, re.M)
    if m is None or text.count("relative_file_paths:") != 1:
        return []
    names = [x.strip()[2:].strip() for x in m.group(2).splitlines()]
    if not all(re.fullmatch(r"[\w.\-]+\.(?:mcap|db3)", n) for n in names):
        return []
    return [path / n for n in names]


def _check_storage(path: Path, f: Path) -> None:
    """Refuse a storage file whose framing rosbags would refuse, before rosbags parses the
    bag's ``metadata.yaml`` (1.8-9 ms with ruamel.yaml, with or without its C parser) and with a
    clearer message: an MCAP file's magic, header record, footer and the record framing of its
    summary section, checked as rosbags 0.11's MCAP reader does before anything else, or the
    first queries rosbags runs on a sqlite3 storage file (through the same apsw library, up to
    the tables that grow with the bag). A file that passes is read by rosbags as before; one
    that fails would fail there too (compared on 1,500 mutated bags of each storage)."""
    try:
        with open(f, "rb") as fh:
            head = fh.read(16)
            if head.startswith(MCAP_MAGIC):
                why = _mcap_framing(fh)
            elif head.startswith(SQLITE_MAGIC):
                why = _sqlite_framing(f)
            else:
                return
    except OSError:
        return  # rosbags says why
    if why:
        raise LogReadError(f"{path}: damaged storage file {f.name} ({why})")


def _mcap_framing(fh: Any) -> str | None:
    """Why rosbags' MCAP reader cannot open the file ``fh`` (None: it may): the framing of
    the header record, the footer and the summary section's records (a record is an opcode
    byte, a little-endian uint64 length and that many bytes)."""
    size = fh.seek(0, 2)
    fh.seek(8)
    op = fh.read(9)
    if len(op) < 9 or op[0] != 0x01:
        return "MCAP: no header record after the magic"
    data_start = 17 + int.from_bytes(op[1:], "little")
    if data_start > size:
        return "MCAP: the header record runs past the end of the file (truncated?)"
    if size < 37 + 8:
        return "MCAP: no footer (truncated?)"
    fh.seek(size - 37)
    footer = fh.read(37)
    if footer[-8:] != MCAP_MAGIC:
        return "MCAP: no end magic (truncated, or not closed by the recorder?)"
    if footer[:9] != b"\x02\x14" + bytes(7):
        return "MCAP: invalid footer record"
    summary_start = int.from_bytes(footer[9:17], "little")
    if not summary_start:
        return None
    footer_start = size - 37
    if not data_start <= summary_start <= footer_start:
        return "MCAP: the footer's summary offset is outside the file's data"
    fh.seek(summary_start)
    summary = fh.read(size - summary_start)
    pos, n = 0, len(summary)
    while True:
        if pos >= n:
            return f"MCAP: the summary section at byte {summary_start} has no end record"
        if summary[pos] in (0x02, 0x0E):
            return None
        if pos + 9 > n:
            return f"MCAP: a summary record at byte {summary_start + pos} is cut by the file's end"
        length = int.from_bytes(summary[pos + 1:pos + 9], "little")
        if pos + 9 + length > n:
            return (f"MCAP: a summary record at byte {summary_start + pos} claims {length} bytes, "
                    f"past the end of the file (summary offset or records damaged)")
        pos += 9 + length


def _sqlite_framing(f: Path) -> str | None:
    """Why rosbags cannot open the sqlite3 storage file ``f`` (None: it may): rosbags 0.11's
    first queries, through rosbags' own apsw, up to the message definitions (the schema, the
    ``schema`` table, ``message_definitions``: small tables, not the ``messages`` table that
    rosbags then scans)."""
    try:
        import apsw
    except ImportError:  # another rosbags: it checks the file itself
        return None
    try:
        conn = apsw.Connection(f"file:{f}?immutable=1",
                               flags=apsw.SQLITE_OPEN_READONLY | apsw.SQLITE_OPEN_URI)
    except Exception as exc:  # noqa: BLE001 - what rosbags would meet at the same call
        return f"sqlite3: {_why(exc)}"
    try:
        cur = conn.cursor()
        row = cur.execute("SELECT count(*) FROM sqlite_master WHERE type='table' AND "
                          "name IN ('messages', 'topics')").fetchone()
        if row is None or row[0] != 2:
            return "sqlite3: no 'messages' and 'topics' tables (not a ROS 2 bag database)"
        if cur.execute("PRAGMA table_info(schema)").fetchall():
            (schema,) = cur.execute("SELECT schema_version FROM schema").fetchone() or (-1,)
            if schema >= 4:
                cur.execute("SELECT topic_type, encoding, encoded_message_definition, "
                            "type_description_hash FROM message_definitions ORDER BY id"
                            ).fetchall()
    except Exception as exc:  # noqa: BLE001 - what rosbags would meet at the same query
        return f"sqlite3: {_why(exc)}"
    finally:
        conn.close()
    return None


def _fields(msg: Any) -> list[str]:
    names = getattr(msg, "__dataclass_fields__", {})
    return [n for n in names if not n.startswith("__") and not n.isupper()]


def read_rosbag(path: str | Path, spec: FormatSpec) -> Trial:
    """Read a ROS 1 / ROS 2 bag or an MCAP file into a multi-rate Trial (SI units, radians).

    ``t`` [s] counts from the first sample; rows are the union of the message times of all
    columns. Raises :class:`LogReadError` (one line naming the file, topic and field) when the file
    is not a bag, a topic or field of the spec is missing, or no sample is usable.
    """
    require("rosbag")
    path = Path(path)
    kind = bag_kind(path)
    if kind is None:
        raise LogReadError(f"{path}: not a ROS bag or MCAP file (no ROS 1 / MCAP / sqlite3 "
                           "header, no metadata.yaml)")
    for f in _storage_files(path, kind):
        _check_storage(path, f)
    opened = _open_path(path, kind)
    state = ReadState(meta={"bag_kind": kind})
    try:
        reader = _reader_class()([opened], default_typestore=_default_store(kind == "ros1"))
        reader.open()
    except Exception as exc:  # rosbags raises its own errors, struct/IO/sqlite errors on damage
        raise LogReadError(f"{path}: cannot open the {kind} log ({_why(exc)})") from None
    try:
        return _read_open(path, spec, reader, state)
    finally:
        try:
            reader.close()
        except Exception:  # noqa: BLE001 - closing a damaged bag must not hide the result
            pass
        if opened != path and not opened.is_dir():
            shutil.rmtree(opened.parent, ignore_errors=True)


#: Typestores built from the message definitions of bags read (see :func:`_reader_class`),
#: keyed by the definitions; the least recently used is dropped beyond ``_STORES_MAX``.
_STORES: OrderedDict[tuple, Any] = OrderedDict()
_STORES_MAX = 32
_STORES_LOCK = threading.Lock()


@functools.cache
def _default_store(ros1: bool) -> Any:
    """The standard types of ROS 1 Noetic / ROS 2 Humble (built once: a Typestore copies its
    1,000-odd definitions)."""
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)


@functools.cache
def _reader_class() -> type:
    """rosbags' ``AnyReader`` with its typestore cached across reads.

    ``AnyReader.open`` builds a new typestore from the message definitions stored in the bag on
    every open: it parses the definitions and generates Python source for the types, and the
    first message of each type then generates and compiles its (de)serialisers. That is 25-90 ms
    per bag opened for the ~10 types of a small bag, most of a small bag's read. Here the
    typestore is kept, keyed by everything it is built from (the ordered message types,
    definition formats and texts and digests of the connections, ROS 1 or 2, the default
    store when the bag stores no definitions): a bag with the same definitions as one read
    before reuses the store and its compiled code. The building and the digest check are
    rosbags 0.11's ``AnyReader._open``; only a store that was built and checked is kept. With
    another rosbags version (whose private ``_open`` may differ) the plain ``AnyReader``.
    """
    from importlib.metadata import version

    from rosbags.highlevel import AnyReader, AnyReaderError

    if tuple(version("rosbags").split(".")[:2]) != ("0", "11"):
        return AnyReader  # another rosbags' _open may differ: read without the cache
    from rosbags.interfaces import MessageDefinitionFormat
    from rosbags.typesys import Stores, get_types_from_idl, get_types_from_msg, get_typestore

    yaml_class = _cached_yaml_class()

    class CachedAnyReader(AnyReader):
        def _open(self) -> None:
            assert self.stack
            with _cached_yaml(yaml_class):
                for reader in self.readers:
                    self.stack.enter_context(reader)
            connections = [y for x in self.readers for y in x.connections]
            self.connections = connections
            key = (self.is2, id(self.default_typestore), tuple(
                (c.msgtype, c.msgdef.format.value, c.msgdef.data, c.digest)
                for c in connections))
            with _STORES_LOCK:
                store = _STORES.get(key)
                if store is not None:
                    _STORES.move_to_end(key)
            if store is None:
                store = self._build(connections)
                with _STORES_LOCK:
                    _STORES[key] = store
                    while len(_STORES) > _STORES_MAX:
                        _STORES.popitem(last=False)
            self.typestore = store

        def _build(self, connections: list) -> Any:
            typs: dict = {}
            digests: dict[str, str] = {}
            if connections:
                definitions = [x for x in connections
                               if x.msgdef.format != MessageDefinitionFormat.NONE]
                if definitions:
                    for connection in definitions:
                        if connection.msgdef.format == MessageDefinitionFormat.MSG:
                            typs.update(_parsed_types(get_types_from_msg,
                                                      connection.msgdef.data,
                                                      connection.msgtype))
                        else:
                            sep = "=" * 80 + "\n"
                            if connection.msgdef.data.startswith(f"{sep}IDL: "):
                                for msgdef in connection.msgdef.data.split(sep)[1:]:
                                    _, idl = msgdef.split("\n", 1)
                                    typs.update(_parsed_types(get_types_from_idl, idl))
                            else:
                                typs.update(_parsed_types(get_types_from_idl,
                                                          connection.msgdef.data))
                        if connection.digest:
                            digests[connection.msgtype] = connection.digest
                elif self.default_typestore:
                    typs.update(self.default_typestore.fielddefs)
                else:  # not reached: read_rosbag always passes a default store
                    raise AnyReaderError("Bag contains no type definitions.")
            store = get_typestore(Stores.EMPTY)
            store.register(typs)
            for msgtype, digest in digests.items():
                have = (store.hash_rihs01(msgtype) if self.is2
                        else store.generate_msgdef(msgtype)[1])
                if have != digest:
                    raise AnyReaderError(
                        f"Message type {msgtype!r} hash mismatch {have} != {digest}")
            return store

    return CachedAnyReader


#: Parsed message definitions (:func:`_parsed_types`), pickled, by parser and text; the least
#: recently used is dropped beyond ``_TYPES_MAX``; texts longer than ``_YAML_TEXT_MAX``
#: characters are not kept.
_TYPES: OrderedDict[tuple, bytes] = OrderedDict()
_TYPES_MAX = 256
_TYPES_LOCK = threading.Lock()


def _parsed_types(parse: Any, text: str, *args: Any) -> dict:
    """``parse(text, *args)`` (rosbags' ``get_types_from_msg`` / ``get_types_from_idl``: the
    field definitions of the types a message definition text declares), the result of a text
    parsed before returned again, a fresh copy (unpickled) each time.

    A bag whose stored definitions differ from every bag read before in one connection (a
    damaged or custom definition) gets a typestore of its own (:func:`_reader_class`), but
    its other connections' texts are the same as before: their parsing (rosbags' PEG parser,
    1.1-1.6 ms a text, 7 texts in the test bags, measured) is about two thirds of building
    the store. A text that does not parse raises as before (not kept)."""
    key = (parse.__name__, text, *args)
    with _TYPES_LOCK:
        blob = _TYPES.get(key)
        if blob is not None:
            _TYPES.move_to_end(key)
    if blob is not None:
        return pickle.loads(blob)
    types = parse(text, *args)
    if len(text) <= _YAML_TEXT_MAX:
        with _TYPES_LOCK:
            _TYPES[key] = pickle.dumps(types, protocol=pickle.HIGHEST_PROTOCOL)
            while len(_TYPES) > _TYPES_MAX:
                _TYPES.popitem(last=False)
    return types


#: Parsed YAML texts of ROS 2 bags (``metadata.yaml``, QoS profiles), pickled, by text; the
#: least recently used is dropped beyond ``_YAML_MAX``; texts longer than ``_YAML_TEXT_MAX``
#: characters are not kept.
_YAML: OrderedDict[str, bytes] = OrderedDict()
_YAML_MAX, _YAML_TEXT_MAX = 64, 1_000_000
_YAML_LOCK = threading.Lock()


@functools.cache
def _cached_yaml_class() -> type:
    """ruamel.yaml's ``YAML`` whose safe ``load`` of a string keeps the result by text.

    rosbags 0.11 parses a ROS 2 bag's ``metadata.yaml`` on every open, and each topic's
    ``offered_qos_profiles`` string, with ``YAML(typ='safe').load`` (rosbag2/reader.py,
    rosbag2/metadata.py): 1.5-2 ms a bag with ruamel.yaml's C parser, more than the rest of
    opening a small bag (measured). The same text gives the same data, so the data of a text
    parsed before is returned again, a fresh copy (unpickled) each time; a text that does not
    parse raises from ruamel.yaml as before (not kept), and any other load is ruamel.yaml's.
    """
    from ruamel.yaml import YAML

    class CachedYAML(YAML):
        # ruamel.yaml's YAML() looks for plug-ins on the disk (a glob) when made: made here
        # only when a text is parsed or the object is used otherwise
        def __init__(self, *args: Any, **kwargs: Any) -> None:
            self.__dict__["_usvid_args"] = (args, kwargs)

        def _usvid_made(self) -> None:
            made = self.__dict__.pop("_usvid_args", None)
            if made is not None:
                YAML.__init__(self, *made[0], **made[1])

        def __getattr__(self, name: str) -> Any:
            if "_usvid_args" not in self.__dict__:
                raise AttributeError(name)
            self._usvid_made()
            return getattr(self, name)

        def load(self, stream: Any) -> Any:
            safe = self.__dict__.get("_usvid_args") == ((), {"typ": "safe"})
            if not safe or not isinstance(stream, str) or len(stream) > _YAML_TEXT_MAX:
                self._usvid_made()
                return super().load(stream)
            with _YAML_LOCK:
                blob = _YAML.get(stream)
                if blob is not None:
                    _YAML.move_to_end(stream)
            if blob is None:
                self._usvid_made()
                data = super().load(stream)
                try:
                    blob = pickle.dumps(data, protocol=pickle.HIGHEST_PROTOCOL)
                except Exception:  # noqa: BLE001 - data pickle cannot copy: not kept
                    return data
                with _YAML_LOCK:
                    _YAML[stream] = blob
                    while len(_YAML) > _YAML_MAX:
                        _YAML.popitem(last=False)
            return pickle.loads(blob)

    return CachedYAML


_YAML_SWAP_LOCK = threading.Lock()


@contextlib.contextmanager
def _cached_yaml(yaml_class: type):
    """While a ROS 2 bag's readers open (rosbags 0.11 only, see :func:`_reader_class`):
    rosbags' ``rosbag2.reader`` and ``rosbag2.metadata`` modules use :func:`_cached_yaml_class`
    for ``YAML`` (their own ``YAML`` is put back after; one swap at a time)."""
    from rosbags.rosbag2 import metadata, reader

    with _YAML_SWAP_LOCK:
        saved = reader.YAML, metadata.YAML
        reader.YAML = metadata.YAML = yaml_class
        try:
            yield
        finally:
            reader.YAML, metadata.YAML = saved


def _why(exc: BaseException) -> str:
    msg = " ".join(str(exc).split())[:160]
    return f"{type(exc).__name__}: {msg}" if msg else type(exc).__name__


def _read_open(path: Path, spec: FormatSpec, reader: Any, state: ReadState) -> Trial:
    topics = {c.topic: [] for c in reader.connections}
    for c in reader.connections:
        topics[c.topic].append(c)
    cols = []
    for col in spec.columns.values():
        if col.topic not in topics:
            if col.optional:
                continue
            raise missing_topic(path, spec, col, list(topics))
        cols.append(col)
    wanted = list(dict.fromkeys(c.topic for c in cols))  # (in spec order: not a set, whose
    # order follows the hash seed, and so did how far a damaged ROS 1 bag was read)
    ignored = {t: sum(c.msgcount for c in cs) for t, cs in topics.items() if t not in wanted}
    if ignored:
        state.meta["ignored_topics"] = ignored
        state.findings.append(Finding(
            "info", "ignored_topics",
            f"{path.name}: ignored {sum(ignored.values())} message(s) on topics not used: "
            + ", ".join(f"{k} ({v})" for k, v in sorted(ignored.items())),
            count=sum(ignored.values())))
    by_topic: dict[str, list] = {}
    for col in cols:
        by_topic.setdefault(col.topic, []).append((col, path_steps(str(col.col))))
    conns = [c for t in wanted for c in topics[t]]
    stamps: dict[str, list[int]] = {t: [] for t in wanted}
    rows: dict[str, list] = {t: [] for t in wanted}
    extract = {t: _extractor(g) for t, g in by_topic.items()}
    checked: set[str] = set()
    deser = reader.deserialize
    try:
        for conn, ts, raw in reader.messages(connections=conns):
            try:
                msg = deser(raw, conn.msgtype)
            except Exception:  # noqa: BLE001 - a message that does not deserialise
                if conn.topic not in checked and not _known_type(reader, conn.msgtype):
                    raise LogReadError(
                        f"{path}: topic '{conn.topic}': unknown message type "
                        f"'{conn.msgtype}' (no definition in the bag, not a standard type)"
                    ) from None
                state.reject("bad_message")
                continue
            topic = conn.topic
            if topic not in checked:
                by_topic[topic] = _check_fields(path, spec, msg, conn.msgtype, by_topic[topic])
                extract[topic] = _extractor(by_topic[topic])
                checked.add(topic)
            try:
                row = extract[topic](msg)
            except (AttributeError, IndexError, TypeError, ValueError):
                state.reject("bad_message")
                continue
            stamps[topic].append(ts)
            rows[topic].append(row)
    except LogReadError:
        raise
    except Exception as exc:  # storage damage part-way: keep what was read, say where
        state.reject("corrupt_chunk")
        state.findings.append(Finding(
            "warning", "log_damaged",
            f"{path.name}: reading stopped at a damaged part of the log ({_why(exc)}); "
            f"{sum(len(v) for v in stamps.values())} message(s) before it were read", count=1))
    series = []
    for topic, getters in by_topic.items():
        t, table = _as_table(stamps[topic], rows[topic], sum(width(c) for c, _ in getters),
                             state)
        k = 0
        for col, _ in getters:
            w = width(col)
            series.append(Series(col, t, table[:, k:k + w] if w > 1 else table[:, k]))
            k += w
    first = min((int(s.t_ns[0]) for s in series if len(s.t_ns)), default=0)
    epoch = 0 if first > 315_532_800 * 10**9 else None  # log time is epoch time (after 1980)
    return build_trial(path, spec, series, state, reader="rosbag", clock_epoch_ns=epoch)


def _extractor(getters: list) -> Any:
    """A function message -> tuple of the raw values of the topic's columns (all columns of a
    topic in one call, a quaternion as w, x, y, z and a vector as x, y): one C-level
    ``operator.attrgetter`` when the field paths are attribute names only (no per-value Python
    work in the loop), else the general path walk."""
    leaves: list[str] = []
    for col, steps in getters:
        base = ".".join(str(s) for s in steps)
        sub = {"yaw": "wxyz", "roll": "wxyz", "pitch": "wxyz", "speed": "xy",
               "course": "xy"}.get(col.conversion or "", "")
        leaves += [f"{base}.{a}" for a in sub] if sub else [base]
    if all(isinstance(s, str) for _, steps in getters for s in steps):
        get = operator.attrgetter(*leaves)
        return get if len(leaves) > 1 else (lambda m: (get(m),))

    def walk(m: Any) -> tuple:
        out: list[float] = []
        for col, steps in getters:
            v = raw_of(get_path(m, steps), col.conversion)
            out += v if isinstance(v, tuple) else [v]
        return tuple(out)

    return walk


def _as_table(stamps: list[int], rows: list[tuple], k: int, state: ReadState
              ) -> tuple[np.ndarray, np.ndarray]:
    """Times [ns] (N,) and values (N, k) of one topic; a row that is not k numbers (a field of
    another type in a damaged or odd message) is rejected as ``bad_message``."""
    t = np.asarray(stamps, dtype=np.int64)
    try:
        table = np.array(rows, dtype=float).reshape(len(t), k)
        return t, table
    except (TypeError, ValueError):
        pass
    good, vals = [], []
    for i, r in enumerate(rows):
        try:
            v = [float(x) for x in r]
        except (TypeError, ValueError):
            state.reject("bad_message")
            continue
        if len(v) == k:
            good.append(i)
            vals.append(v)
        else:
            state.reject("bad_message")
    return t[good], np.array(vals, dtype=float).reshape(len(good), k)


def _known_type(reader: Any, msgtype: str) -> bool:
    return msgtype in reader.typestore.fielddefs


def _check_fields(path: Path, spec: FormatSpec, msg: Any, msgtype: str, getters: list
                  ) -> list:
    """The columns of a topic whose fields its first message has (an optional column without
    its field is left out; a required one is a :class:`LogReadError`)."""
    keep = []
    for col, steps in getters:
        try:
            v = get_path(msg, steps)
        except (AttributeError, IndexError, TypeError, KeyError):
            if col.optional:
                continue
            raise missing_field(path, spec, col, msgtype, _fields(msg)) from None
        try:
            raw_of(v, col.conversion)
        except (AttributeError, TypeError, ValueError):
            want = {"yaw": "a quaternion (x, y, z, w)", "roll": "a quaternion (x, y, z, w)",
                    "pitch": "a quaternion (x, y, z, w)", "speed": "a vector (x, y)",
                    "course": "a vector (x, y)"}.get(col.conversion or "", "a number")
            raise LogReadError(
                f"{path}: {spec.source}: columns.{col.name}.field: '{col.col}' of {msgtype} on "
                f"'{col.topic}' is not {want} (got {type(v).__name__})") from None
        keep.append((col, steps))
    return keep


# ----------------------------------------------------------------------------------------------
# writer (the layout of the shipped ros2_usv preset)
# ----------------------------------------------------------------------------------------------
#: Topics written by :func:`write_rosbag` (those the ``ros2_usv`` preset reads).
TOPICS = {
    "fix": ("/gps/fix", "sensor_msgs/msg/NavSatFix"),
    "vel": ("/gps/fix_velocity", "geometry_msgs/msg/TwistStamped"),
    "imu": ("/imu/data", "sensor_msgs/msg/Imu"),
    "odom": ("/odometry/filtered", "nav_msgs/msg/Odometry"),
    "rudder": ("/rudder/angle", "std_msgs/msg/Float64"),
    "rudder_cmd": ("/rudder/cmd", "std_msgs/msg/Float64"),
    "rpm": ("/engine/rpm", "std_msgs/msg/Float32"),
    "left": ("/thrusters/left/cmd", "std_msgs/msg/Float64"),
    "right": ("/thrusters/right/cmd", "std_msgs/msg/Float64"),
}


def write_rosbag(trial: Trial, path: str | Path, *, storage: str = "mcap",
                 t0_utc: str | None = None) -> Path:
    """Write a Trial as a ROS bag in the ``ros2_usv`` preset's layout (atomically: written in a
    temporary folder beside ``path``, then renamed; an existing non-empty folder at ``path`` is
    an :class:`usvid.files.OutputError`, never deleted).

    ``storage``: ``"mcap"`` or ``"sqlite3"`` (a ROS 2 bag folder ``path``) or ``"ros1"`` (a ROS 1
    ``.bag`` file). Channels -> topics (REP 103 frames, SI): ``lat``/``lon`` [deg] ->
    ``/gps/fix`` (NavSatFix), ``sog``/``cog`` (or ``U``) -> ``/gps/fix_velocity`` (TwistStamped,
    ENU velocity [m/s]), ``psi``/``r`` -> ``/imu/data`` (Imu: ENU orientation with ``phi``/
    ``theta`` as its roll and pitch when given, angular velocity about z-up = ``-r`` and about
    x = ``p``; a part without a sample is NaN with covariance[0] = -1),
    ``u``/``v`` -> ``/odometry/filtered`` (body twist, y to port = ``-v``), ``delta`` /
    ``delta_cmd`` [rad, positive to starboard] -> ``/rudder/angle`` / ``/rudder/cmd`` (Float64),
    ``n`` [rps] -> ``/engine/rpm`` (Float32 [rpm]), ``n_port``/``n_stbd`` ->
    ``/thrusters/left|right/cmd`` (Float64). One message per topic per row where a channel of it
    is finite; log time = header stamp = ``t0_utc + t`` [ns].
    """
    require("rosbag")
    from rosbags.typesys import Stores, get_typestore

    if storage not in ("mcap", "sqlite3", "ros1"):
        raise ValueError(f"storage must be 'mcap', 'sqlite3' or 'ros1', got {storage!r}")
    path = Path(path)
    ros1 = storage == "ros1"
    ts = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    e0_ns = int(round(log_start_epoch(trial, t0_utc) * 1e9))
    t_ns = e0_ns + np.round(trial.t * 1e9).astype(np.int64)
    msgs = _messages(trial, ts, t_ns, ros1)
    check_outputs([path] if ros1 else [], probe=False)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=f".{path.name[:80]}.", dir=path.parent))
    except OSError as exc:
        raise OutputError(f"{path}: cannot write ({os_reason(exc)})") from None
    target = tmp / ("log.bag" if ros1 else "bag")
    try:
        if ros1:
            from rosbags.rosbag1 import Writer

            with Writer(target) as w:
                conns = {k: w.add_connection(TOPICS[k][0], TOPICS[k][1], typestore=ts)
                         for k in msgs}
                for key, stamp, msg in _ordered(msgs):
                    w.write(conns[key], stamp, ts.serialize_ros1(msg, TOPICS[key][1]))
        else:
            from rosbags.rosbag2 import StoragePlugin, Writer

            plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
            with Writer(target, version=9, storage_plugin=plugin) as w:
                conns = {k: w.add_connection(TOPICS[k][0], TOPICS[k][1], typestore=ts)
                         for k in msgs}
                for key, stamp, msg in _ordered(msgs):
                    w.write(conns[key], stamp, ts.serialize_cdr(msg, TOPICS[key][1]))
        publish(target, path)  # never deletes an existing folder at path
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return path


def _ordered(msgs: dict[str, list]) -> list:
    out = [(stamp, k, m) for k, lst in msgs.items() for stamp, m in lst]
    out.sort(key=lambda x: x[0])
    return [(k, stamp, m) for stamp, k, m in out]


def _messages(trial: Trial, ts: Any, t_ns: np.ndarray, ros1: bool) -> dict[str, list]:
    T = ts.types
    Time = T["builtin_interfaces/msg/Time"]
    Header = T["std_msgs/msg/Header"]
    V3, Q = T["geometry_msgs/msg/Vector3"], T["geometry_msgs/msg/Quaternion"]
    Twist = T["geometry_msgs/msg/Twist"]
    ch = {k: channel_or_none(trial, k) for k in
          ("lat", "lon", "sog", "cog", "psi", "r", "u", "v", "delta", "delta_cmd", "n",
           "n_port", "n_stbd", "phi", "theta", "p")}
    if ch["sog"] is None:
        ch["sog"] = channel_or_none(trial, "U")
    nan = math.nan
    cov0 = np.zeros(9)
    cov_unknown = np.r_[-1.0, np.zeros(8)]

    def fin(k: str, i: int) -> bool:
        a = ch[k]
        return a is not None and math.isfinite(a[i])

    def header(i: int, frame: str) -> Any:
        sec, ns = divmod(int(t_ns[i]), 10**9)
        stamp = Time(sec=sec, nanosec=ns)
        return Header(seq=i, stamp=stamp, frame_id=frame) if ros1 else Header(
            stamp=stamp, frame_id=frame)

    def f64(key: str, val: float) -> Any:
        return T[TOPICS[key][1]](data=float(val))

    out: dict[str, list] = {k: [] for k in TOPICS}
    for i in range(len(t_ns)):
        st = int(t_ns[i])
        if fin("lat", i) and fin("lon", i):
            status = T["sensor_msgs/msg/NavSatStatus"](status=0, service=1)
            out["fix"].append((st, T["sensor_msgs/msg/NavSatFix"](
                header=header(i, "gps"), status=status, latitude=float(ch["lat"][i]),
                longitude=float(ch["lon"][i]), altitude=0.0, position_covariance=cov0.copy(),
                position_covariance_type=0)))
        if fin("sog", i) and fin("cog", i):
            s, c = float(ch["sog"][i]), float(ch["cog"][i])
            out["vel"].append((st, T["geometry_msgs/msg/TwistStamped"](
                header=header(i, "gps"),
                twist=Twist(linear=V3(x=s * math.sin(c), y=s * math.cos(c), z=0.0),
                            angular=V3(x=0.0, y=0.0, z=0.0)))))
        if fin("psi", i) or fin("r", i):
            if fin("psi", i):
                yaw = 0.5 * math.pi - float(ch["psi"][i])  # REP 103: ENU, from east, CCW
                # FLU body: the roll as it is, the pitch negated (bow up about y to port)
                roll = float(ch["phi"][i]) if fin("phi", i) else 0.0
                pitch = -float(ch["theta"][i]) if fin("theta", i) else 0.0
                qw, qx, qy, qz = quaternion_zyx(np.array([yaw]), np.array([pitch]),
                                                np.array([roll]))[0]
                q = Q(x=float(qx), y=float(qy), z=float(qz), w=float(qw))
                qc = cov0.copy()
            else:
                q, qc = Q(x=nan, y=nan, z=nan, w=nan), cov_unknown.copy()
            if fin("r", i):
                px = float(ch["p"][i]) if fin("p", i) else 0.0
                w, wc = V3(x=px, y=0.0, z=-float(ch["r"][i])), cov0.copy()
            else:
                w, wc = V3(x=nan, y=nan, z=nan), cov_unknown.copy()
            out["imu"].append((st, T["sensor_msgs/msg/Imu"](
                header=header(i, "base_link"), orientation=q, orientation_covariance=qc,
                angular_velocity=w, angular_velocity_covariance=wc,
                linear_acceleration=V3(x=0.0, y=0.0, z=0.0),
                linear_acceleration_covariance=cov_unknown.copy())))
        if fin("u", i) or fin("v", i):
            u = float(ch["u"][i]) if fin("u", i) else nan
            v = -float(ch["v"][i]) if fin("v", i) else nan
            P = T["geometry_msgs/msg/Pose"](position=T["geometry_msgs/msg/Point"](
                x=0.0, y=0.0, z=0.0), orientation=Q(x=0.0, y=0.0, z=0.0, w=1.0))
            out["odom"].append((st, T["nav_msgs/msg/Odometry"](
                header=header(i, "odom"), child_frame_id="base_link",
                pose=T["geometry_msgs/msg/PoseWithCovariance"](pose=P,
                                                                covariance=np.zeros(36)),
                twist=T["geometry_msgs/msg/TwistWithCovariance"](
                    twist=Twist(linear=V3(x=u, y=v, z=0.0), angular=V3(x=0.0, y=0.0, z=0.0)),
                    covariance=np.zeros(36)))))
        for key, chan, f in (("rudder", "delta", 1.0), ("rudder_cmd", "delta_cmd", 1.0),
                             ("rpm", "n", 60.0), ("left", "n_port", 1.0),
                             ("right", "n_stbd", 1.0)):
            if fin(chan, i):
                out[key].append((st, f64(key, f * float(ch[chan][i]))))
    return {k: v for k, v in out.items() if v}
