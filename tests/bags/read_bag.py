#!/usr/bin/env python3
"""Read a rosbag2 bag directory (MCAP storage) two independent ways and check it.

    python3 tests/bags/read_bag.py BAGDIR [--json OUT] [--expect TOPIC=COUNT ...]
        [--records]

(a) rosbags' AnyReader (its own MCAP parser; message types come from the
    `ros2msg` schemas in the file, so crossym_msgs needs no registration), and
(b) the `mcap` library (indexed SeekingReader) with mcap_ros2's DecoderFactory,
    plus a linear StreamReader scan of every record (checks the indexes).
Every message is decoded by both, turned into plain dicts/lists and compared
whole. metadata.yaml is checked against the MCAP file. One PASS/FAIL line per
check is printed; exit status 0 only if every check passes.

--json OUT writes a summary: per topic type, count, first/last log time (ns)
and the first decoded message as a dict, plus the checks and layout facts.
--records also prints the MCAP record layout (top level and inside chunks).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import struct
import sys
from collections import Counter, defaultdict
from pathlib import Path

import yaml

CDR_LE_HEADER = b'\x00\x01\x00\x00'
OPCODES = {0x01: 'Header', 0x02: 'Footer', 0x03: 'Schema', 0x04: 'Channel', 0x05: 'Message',
           0x06: 'Chunk', 0x07: 'MessageIndex', 0x08: 'ChunkIndex', 0x09: 'Attachment',
           0x0A: 'AttachmentIndex', 0x0B: 'Statistics', 0x0C: 'Metadata',
           0x0D: 'MetadataIndex', 0x0E: 'SummaryOffset', 0x0F: 'DataEnd'}


class Checks:
    def __init__(self) -> None:
        self.items: list[dict] = []

    def add(self, name: str, ok: bool, detail: str = '') -> bool:
        self.items.append({'name': name, 'ok': bool(ok), 'detail': detail})
        shown = detail if len(detail) <= 1500 else detail[:1500] + '...'
        print(f"{'PASS' if ok else 'FAIL'}  {name}" + (f'  ({shown})' if shown else ''))
        return bool(ok)

    @property
    def ok(self) -> bool:
        return all(x['ok'] for x in self.items)


def canon(value, store=None):
    """Turn a decoded message (rosbags dataclass or mcap_ros2 object) into plain data."""
    try:
        import numpy as np
    except ImportError:  # pragma: no cover
        np = None
    if np is not None:
        if isinstance(value, np.ndarray):
            return [canon(v, store) for v in value.tolist()]
        if isinstance(value, np.generic):
            return value.item()
    if isinstance(value, (bool, int, float, str)) or value is None:
        return value
    if isinstance(value, (bytes, bytearray, memoryview)):
        return list(bytes(value))
    if isinstance(value, (list, tuple)):
        return [canon(v, store) for v in value]
    if dataclasses.is_dataclass(value):
        # rosbags message classes also carry the constants and __msgtype__ as
        # dataclass fields: take the real fields from the typestore.
        msgtype = getattr(value, '__msgtype__', None)
        if store is not None and msgtype in store.fielddefs:
            names = [f[0] for f in store.fielddefs[msgtype][1]]
        else:
            names = [f.name for f in dataclasses.fields(value)
                     if f.default is dataclasses.MISSING and not f.name.startswith('__')]
        return {n: canon(getattr(value, n), store) for n in names}
    slots = getattr(type(value), '__slots__', None)
    if slots:
        return {s: canon(getattr(value, s), store) for s in slots}
    raise TypeError(f'cannot canonicalize {type(value)!r}')


def floats(value, path=''):
    """Yield (path, float) for every float inside plain data."""
    if isinstance(value, float):
        yield path, value
    elif isinstance(value, dict):
        for k, v in value.items():
            yield from floats(v, f'{path}.{k}' if path else k)
    elif isinstance(value, list):
        for i, v in enumerate(value):
            yield from floats(v, f'{path}[{i}]')


def stamp_ns(msg: dict) -> int | None:
    try:
        s = msg['header']['stamp']
        return int(s['sec']) * 1_000_000_000 + int(s['nanosec'])
    except (KeyError, TypeError):
        return None


def msg_key(item: tuple[int, dict]) -> tuple[int, str]:
    return item[0], json.dumps(item[1], sort_keys=True)


# ---------------------------------------------------------------- readers


def read_with_rosbags(bagdir: Path, checks: Checks, hash_ok: bool):
    """Decode every message with rosbags. Returns {topic: (type, [(log_ns, dict)])}."""
    from rosbags.highlevel import AnyReader
    from rosbags.rosbag2 import Reader
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    out: dict[str, tuple[str, list]] = {}
    try:
        with AnyReader([bagdir]) as reader:
            for conn in reader.connections:
                out.setdefault(conn.topic, (conn.msgtype, []))
            for conn, ts, raw in reader.messages():
                out[conn.topic][1].append((ts, canon(reader.deserialize(raw, conn.msgtype), reader.typestore)))
        checks.add('rosbags AnyReader opens the bag and decodes every message', True,
                   f'{sum(len(v[1]) for v in out.values())} messages')
        return out
    except Exception as err:  # noqa: BLE001
        checks.add('rosbags AnyReader opens the bag and decodes every message', False,
                   f'{type(err).__name__}: {err}')

    # Fallback (e.g. a wrong type_description_hash): rosbags' rosbag2 Reader and a
    # typestore built from the schemas in the file, without AnyReader's hash check.
    out = {}
    try:
        with Reader(bagdir) as reader:
            store = get_typestore(Stores.EMPTY)
            typs = {}
            for conn in reader.connections:
                typs.update(get_types_from_msg(conn.msgdef.data, conn.msgtype))
            store.register(typs)
            for conn in reader.connections:
                out.setdefault(conn.topic, (conn.msgtype, []))
            for conn, ts, raw in reader.messages():
                out[conn.topic][1].append((ts, canon(store.deserialize_cdr(raw, conn.msgtype), store)))
        checks.add('rosbags rosbag2.Reader fallback decodes every message', True,
                   f'{sum(len(v[1]) for v in out.values())} messages')
    except Exception as err:  # noqa: BLE001
        checks.add('rosbags rosbag2.Reader fallback decodes every message', False,
                   f'{type(err).__name__}: {err}')
        return None
    return out


def read_with_mcap(mcap_path: Path, checks: Checks):
    """Decode every message with mcap + mcap_ros2. Returns (topics, raw, summary, header)."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    raw: list[tuple[str, int, int, int, bytes]] = []
    summary = header = None
    try:
        with mcap_path.open('rb') as f:
            reader = make_reader(f, validate_crcs=True)
            header = reader.get_header()
            summary = reader.get_summary()
            for _, channel, message in reader.iter_messages():
                raw.append((channel.topic, message.log_time, message.publish_time,
                            message.sequence, bytes(message.data)))
        checks.add('mcap SeekingReader reads every message record through the indexes', True,
                   f'{len(raw)} messages')
    except Exception as err:  # noqa: BLE001
        checks.add('mcap SeekingReader reads every message record through the indexes', False,
                   f'{type(err).__name__}: {err}')

    out: dict[str, tuple[str, list]] = {}
    try:
        with mcap_path.open('rb') as f:
            reader = make_reader(f, validate_crcs=True, decoder_factories=[DecoderFactory()])
            summ = reader.get_summary()
            if summ is not None:
                for ch in summ.channels.values():
                    sch = summ.schemas.get(ch.schema_id)
                    out.setdefault(ch.topic, (sch.name if sch else '', []))
            for schema, channel, message, decoded in reader.iter_decoded_messages():
                entry = out.setdefault(channel.topic, (schema.name if schema else '', []))
                entry[1].append((message.log_time, canon(decoded)))
        checks.add('mcap_ros2 DecoderFactory decodes every message', True,
                   f'{sum(len(v[1]) for v in out.values())} messages')
    except Exception as err:  # noqa: BLE001
        checks.add('mcap_ros2 DecoderFactory decodes every message', False,
                   f'{type(err).__name__}: {err}')
        out = None
    return out, raw, summary, header


def scan_records(mcap_path: Path, checks: Checks):
    """Linear scan with StreamReader: top-level layout and every message record."""
    from mcap.stream_reader import StreamReader

    top: list[str] = []
    inner: Counter = Counter()
    msgs: list[tuple[int, int, bytes]] = []
    chunks = []
    records = {}
    try:
        with mcap_path.open('rb') as f:
            for rec in StreamReader(f, emit_chunks=True, validate_crcs=True).records:
                name = type(rec).__name__
                if not top or top[-1].split(' x')[0] != name:
                    top.append(f'{name} x1')
                else:
                    n = int(top[-1].split(' x')[1]) + 1
                    top[-1] = f'{name} x{n}'
                records.setdefault(name, []).append(rec)
                if name == 'Chunk':
                    chunks.append(rec)
        with mcap_path.open('rb') as f:
            for rec in StreamReader(f, emit_chunks=False, validate_crcs=True).records:
                name = type(rec).__name__
                if name == 'Message':
                    msgs.append((rec.channel_id, rec.log_time, bytes(rec.data)))
        for ch in chunks:
            data = ch.data
            if ch.compression == 'zstd':
                import zstandard
                data = zstandard.ZstdDecompressor().decompress(data, max_output_size=ch.uncompressed_size)
            elif ch.compression == 'lz4':
                import lz4.frame
                data = lz4.frame.decompress(data)
            pos = 0
            while pos < len(data):
                op = data[pos]
                (length,) = struct.unpack_from('<Q', data, pos + 1)
                inner[OPCODES.get(op, f'op{op:#x}')] += 1
                pos += 9 + length
            if pos != len(data):
                raise ValueError(f'chunk records overrun the chunk ({pos} > {len(data)})')
        checks.add('mcap StreamReader linear scan (magic, records, CRCs if set)', True,
                   f'{len(msgs)} message records')
    except Exception as err:  # noqa: BLE001
        checks.add('mcap StreamReader linear scan (magic, records, CRCs if set)', False,
                   f'{type(err).__name__}: {err}')
        return None
    return {'top': top, 'inner': dict(inner), 'messages': msgs, 'chunks': chunks,
            'records': records}


# ---------------------------------------------------------------- checks


def check_metadata(bagdir: Path, checks: Checks):
    meta_path = bagdir / 'metadata.yaml'
    if not checks.add('metadata.yaml exists', meta_path.is_file()):
        return None
    try:
        doc = yaml.safe_load(meta_path.read_text())
    except Exception as err:  # noqa: BLE001
        checks.add('metadata.yaml parses as YAML', False, str(err))
        return None
    checks.add('metadata.yaml parses as YAML', True)
    info = doc.get('rosbag2_bagfile_information') if isinstance(doc, dict) else None
    if not checks.add('metadata.yaml has rosbag2_bagfile_information', isinstance(info, dict)):
        return None
    checks.add('metadata storage_identifier is mcap', info.get('storage_identifier') == 'mcap',
               repr(info.get('storage_identifier')))
    ver = info.get('version')
    checks.add('metadata version is an int in 4..9', isinstance(ver, int) and 4 <= ver <= 9,
               repr(ver))
    missing = [k for k in ('relative_file_paths', 'topics_with_message_count', 'message_count',
                           'starting_time', 'duration') if k not in info]
    checks.add('metadata has the required keys', not missing, f'missing {missing}' if missing else '')
    files = info.get('relative_file_paths') or []
    paths = [bagdir / Path(p).name for p in files]
    checks.add('metadata relative_file_paths: exactly one existing .mcap file',
               len(paths) == 1 and paths[0].is_file() and paths[0].suffix == '.mcap',
               repr(files))
    topics = info.get('topics_with_message_count') or []
    bad = []
    for t in topics:
        tm = t.get('topic_metadata', {})
        if not all(k in tm for k in ('name', 'type', 'serialization_format')):
            bad.append(f'keys of {tm}')
        elif tm['serialization_format'] != 'cdr':
            bad.append(f"{tm['name']}: serialization_format {tm['serialization_format']!r}")
        if not isinstance(t.get('message_count'), int):
            bad.append(f"{tm.get('name')}: message_count")
    checks.add('metadata topics: name/type/serialization_format cdr/message_count',
               not bad, '; '.join(bad))
    total = sum(t.get('message_count', 0) for t in topics)
    checks.add('metadata message_count == sum of topic message counts',
               info.get('message_count') == total, f"{info.get('message_count')} vs {total}")
    return info


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument('bagdir', type=Path)
    ap.add_argument('--json', type=Path, help='write the JSON summary here')
    ap.add_argument('--expect', action='append', default=[], metavar='TOPIC=COUNT',
                    help='also require this message count on this topic')
    ap.add_argument('--records', action='store_true', help='print the MCAP record layout')
    args = ap.parse_args()
    bagdir: Path = args.bagdir
    checks = Checks()
    summary_json: dict = {'bag': str(bagdir)}

    if not checks.add('bag directory exists', bagdir.is_dir()):
        return finish(checks, summary_json, args)

    info = check_metadata(bagdir, checks)
    if info is not None and info.get('relative_file_paths'):
        mcap_path = bagdir / Path(info['relative_file_paths'][0]).name
    else:
        found = sorted(bagdir.glob('*.mcap'))
        mcap_path = found[0] if found else bagdir / 'missing.mcap'
    if not checks.add('MCAP file exists', mcap_path.is_file(), mcap_path.name):
        return finish(checks, summary_json, args)

    # --- (b) mcap library, indexed + linear
    m_topics, m_raw, m_summary, m_header = read_with_mcap(mcap_path, checks)
    scan = scan_records(mcap_path, checks)

    layout: dict = {}
    if m_header is not None:
        layout['profile'] = m_header.profile
        layout['library'] = m_header.library
        checks.add("MCAP header profile is 'ros2'", m_header.profile == 'ros2', repr(m_header.profile))
    if m_summary is not None:
        checks.add('MCAP summary section present with statistics',
                   m_summary.statistics is not None)
        checks.add('MCAP summary has chunk indexes', len(m_summary.chunk_indexes) > 0,
                   f'{len(m_summary.chunk_indexes)} chunk(s)')
        schemas = m_summary.schemas
        channels = m_summary.channels
        enc_bad = [f'{s.name}: {s.encoding!r}' for s in schemas.values() if s.encoding != 'ros2msg']
        checks.add("every schema encoding is 'ros2msg'", not enc_bad, '; '.join(enc_bad))
        ch_bad = [f'{c.topic}: {c.message_encoding!r}' for c in channels.values()
                  if c.message_encoding != 'cdr']
        checks.add("every channel message_encoding is 'cdr'", not ch_bad, '; '.join(ch_bad))
        qos_bad = []
        for c in channels.values():
            if 'offered_qos_profiles' not in c.metadata:
                qos_bad.append(f'{c.topic}: no offered_qos_profiles')
                continue
            try:
                q = yaml.safe_load(c.metadata['offered_qos_profiles'])
                if q not in (None, '') and not isinstance(q, list):
                    qos_bad.append(f'{c.topic}: not a YAML list')
            except Exception as err:  # noqa: BLE001
                qos_bad.append(f'{c.topic}: {err}')
        checks.add('every channel metadata has offered_qos_profiles (YAML list)', not qos_bad,
                   '; '.join(qos_bad))
        layout['schemas'] = {s.name: {'id': s.id, 'encoding': s.encoding} for s in schemas.values()}
        layout['channels'] = {c.topic: {'id': c.id, 'schema_id': c.schema_id,
                                        'message_encoding': c.message_encoding,
                                        'metadata_keys': sorted(c.metadata)}
                              for c in channels.values()}
        layout['chunk_compression'] = sorted({ci.compression for ci in m_summary.chunk_indexes})
        layout['chunk_count'] = len(m_summary.chunk_indexes)
        st = m_summary.statistics
        if st is not None and m_raw:
            by_ch = Counter()
            topic_to_id = {c.topic: c.id for c in channels.values()}
            for topic, *_ in m_raw:
                by_ch[topic_to_id[topic]] += 1
            real = {k: v for k, v in by_ch.items()}
            stat = {k: v for k, v in st.channel_message_counts.items() if v}
            checks.add('MCAP statistics message_count and per-channel counts match the messages',
                       st.message_count == len(m_raw) and stat == real,
                       f'{st.message_count} vs {len(m_raw)}; {stat} vs {real}')
            lt = [r[1] for r in m_raw]
            checks.add('MCAP statistics message start/end time match the messages',
                       st.message_start_time == min(lt) and st.message_end_time == max(lt),
                       f'{st.message_start_time}..{st.message_end_time} vs {min(lt)}..{max(lt)}')
        # rosbags' MCAP metadata record
    if m_raw:
        bad = sum(1 for r in m_raw if r[4][:4] != CDR_LE_HEADER)
        checks.add('every message starts with the CDR_LE encapsulation header 00 01 00 00',
                   bad == 0, f'{bad} bad' if bad else '')
        same_pub = sum(1 for r in m_raw if r[1] == r[2])
        layout['messages_with_publish_time_eq_log_time'] = f'{same_pub}/{len(m_raw)}'
        layout['message_sequence_values'] = sorted({r[3] for r in m_raw})[:5]
    if scan is not None:
        layout['top_level_records'] = scan['top']
        layout['records_inside_chunks'] = scan['inner']
        if m_raw:
            a = sorted((r[1], r[4]) for r in m_raw)
            b = sorted((r[1], r[2]) for r in scan['messages'])
            checks.add('indexed read and linear scan see the same message records', a == b,
                       f'{len(a)} vs {len(b)}')
        md = scan['records'].get('Metadata', [])
        layout['metadata_records'] = [{'name': r.name, 'keys': sorted(r.metadata)} for r in md]
        de = scan['records'].get('DataEnd', [])
        checks.add('MCAP has exactly one DataEnd and one Footer record',
                   len(de) == 1 and len(scan['records'].get('Footer', [])) == 1)
        if args.records:
            print('MCAP top-level records:', ', '.join(scan['top']))
            print('MCAP records inside chunks:', scan['inner'])

    # --- (a) rosbags
    hash_info = check_hashes(mcap_path, info, checks)
    r_topics = read_with_rosbags(bagdir, checks, hash_info)

    # --- cross-checks
    if m_topics is not None and r_topics is not None:
        checks.add('both readers see the same topics', set(m_topics) == set(r_topics),
                   f'{sorted(m_topics)} vs {sorted(r_topics)}')
        tdiff = {t: (m_topics[t][0], r_topics[t][0]) for t in m_topics
                 if t in r_topics and m_topics[t][0] != r_topics[t][0]}
        checks.add('both readers see the same type per topic', not tdiff, str(tdiff) if tdiff else '')
        cdiff = {t: (len(m_topics[t][1]), len(r_topics[t][1])) for t in m_topics
                 if t in r_topics and len(m_topics[t][1]) != len(r_topics[t][1])}
        checks.add('both readers see the same message count per topic', not cdiff,
                   str(cdiff) if cdiff else '')
        for t in sorted(set(m_topics) & set(r_topics)):
            a = sorted(m_topics[t][1], key=msg_key)
            b = sorted(r_topics[t][1], key=msg_key)
            same_t = [x[0] for x in a] == [x[0] for x in b]
            # compare as JSON text, so that NaN == NaN (finiteness is checked apart)
            diffs = [i for i, (x, y) in enumerate(zip(a, b)) if msg_key(x) != msg_key(y)]
            detail = f'{len(a)} msgs'
            if diffs:
                i = diffs[0]
                detail = f'{len(diffs)} differ, first #{i}: mcap={a[i][1]} rosbags={b[i][1]}'
            checks.add(f'{t}: same log times and identical decoded messages in both readers',
                       same_t and not diffs and len(a) == len(b), detail)

    topics = m_topics if m_topics is not None else r_topics
    if topics:
        nonfinite = []
        for t, (_, msgs) in topics.items():
            for ts, m in msgs:
                for path, v in floats(m):
                    if not math.isfinite(v):
                        nonfinite.append(f'{t}@{ts}:{path}={v}')
        checks.add('every float in every message is finite', not nonfinite,
                   '; '.join(nonfinite[:5]))
        semantic_checks(topics, checks)
        if info is not None:
            mcounts = {t['topic_metadata']['name']: t['message_count']
                       for t in info.get('topics_with_message_count', [])
                       if 'topic_metadata' in t}
            mtypes = {t['topic_metadata']['name']: t['topic_metadata'].get('type')
                      for t in info.get('topics_with_message_count', [])
                      if 'topic_metadata' in t}
            real = {t: len(v[1]) for t, v in topics.items()}
            checks.add('metadata.yaml per-topic message counts match the MCAP file',
                       mcounts == real, f'{mcounts} vs {real}' if mcounts != real else '')
            rtypes = {t: v[0] for t, v in topics.items()}
            checks.add('metadata.yaml per-topic types match the MCAP schemas', mtypes == rtypes,
                       f'{mtypes} vs {rtypes}' if mtypes != rtypes else '')
            all_ts = [ts for _, msgs in topics.values() for ts, _ in msgs]
            if all_ts:
                start = info.get('starting_time', {}).get('nanoseconds_since_epoch')
                dur = info.get('duration', {}).get('nanoseconds')
                checks.add('metadata starting_time/duration == first log time / last-first',
                           start == min(all_ts) and dur == max(all_ts) - min(all_ts),
                           f'{start},{dur} vs {min(all_ts)},{max(all_ts) - min(all_ts)}')
                fbad = []
                for fe in info.get('files') or []:
                    if fe.get('message_count') != len(all_ts):
                        fbad.append(f"message_count {fe.get('message_count')}")
                    if fe.get('starting_time', {}).get('nanoseconds_since_epoch') != min(all_ts):
                        fbad.append('starting_time')
                    if fe.get('duration', {}).get('nanoseconds') != max(all_ts) - min(all_ts):
                        fbad.append('duration')
                    if Path(fe.get('path', '')).name != mcap_path.name:
                        fbad.append(f"path {fe.get('path')}")
                checks.add('metadata files[] entry (if any) matches the MCAP file', not fbad,
                           '; '.join(fbad))
            # rosbags' Reader matches MCAP channels to metadata topics by QoS too.
            qos_check(mcap_path, info, checks)
        for spec in args.expect:
            topic, _, n = spec.rpartition('=')
            got = len(topics.get(topic, ('', []))[1])
            checks.add(f'--expect {topic} has {n} messages', got == int(n), f'got {got}')
        summary_json['topics'] = {
            t: {
                'type': typ,
                'count': len(msgs),
                'first_log_time_ns': min(ts for ts, _ in msgs) if msgs else None,
                'last_log_time_ns': max(ts for ts, _ in msgs) if msgs else None,
                'first_message': min(msgs, key=msg_key)[1] if msgs else None,
            }
            for t, (typ, msgs) in sorted(topics.items())
        }
    summary_json['layout'] = layout
    if info is not None:
        summary_json['metadata'] = {k: info.get(k) for k in
                                    ('version', 'storage_identifier', 'ros_distro',
                                     'message_count', 'compression_format', 'compression_mode')}
    return finish(checks, summary_json, args)


def check_hashes(mcap_path: Path, info, checks: Checks) -> bool:
    """metadata type_description_hash (if set) == RIHS01 that rosbags computes from the schema."""
    if info is None:
        return False
    from mcap.reader import make_reader
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore
    try:
        with mcap_path.open('rb') as f:
            summ = make_reader(f).get_summary()
        store = get_typestore(Stores.EMPTY)
        typs = {}
        for s in summ.schemas.values():
            typs.update(get_types_from_msg(s.data.decode(), s.name))
        store.register(typs)
        bad, unset, good = [], [], 0
        for t in info.get('topics_with_message_count', []):
            tm = t['topic_metadata']
            h = tm.get('type_description_hash') or ''
            if not h:
                unset.append(tm['name'])
                continue
            want = store.hash_rihs01(tm['type'])
            if h != want:
                bad.append(f"{tm['type']}: {h} != {want}")
            else:
                good += 1
        detail = f'{good} match' + (f', unset on {unset}' if unset else '')
        return checks.add('metadata type_description_hash == RIHS01 of the MCAP schema (if set)',
                          not bad, '; '.join(bad) if bad else detail)
    except Exception as err:  # noqa: BLE001
        return checks.add('metadata type_description_hash == RIHS01 of the MCAP schema (if set)',
                          False, f'{type(err).__name__}: {err}')


def qos_check(mcap_path: Path, info, checks: Checks) -> None:
    from mcap.reader import make_reader
    from rosbags.rosbag2.metadata import parse_qos
    try:
        with mcap_path.open('rb') as f:
            summ = make_reader(f).get_summary()
        by_topic = {c.topic: c.metadata.get('offered_qos_profiles', '') for c in summ.channels.values()}
        bad = []
        for t in info.get('topics_with_message_count', []):
            tm = t['topic_metadata']
            a = parse_qos(tm.get('offered_qos_profiles', []))
            b = parse_qos(by_topic.get(tm['name'], ''))
            if a != b:
                bad.append(f"{tm['name']}: {a} != {b}")
        checks.add('offered_qos_profiles in metadata.yaml and MCAP channel metadata agree',
                   not bad, '; '.join(bad))
    except Exception as err:  # noqa: BLE001
        checks.add('offered_qos_profiles in metadata.yaml and MCAP channel metadata agree',
                   False, f'{type(err).__name__}: {err}')


STATUS_CODES = {0, 1, 2, 3, 4, 5, 16, 17, 18, 19, 20, 21, 22, 23, 24}


def semantic_checks(topics, checks: Checks) -> None:
    for t, (typ, msgs) in sorted(topics.items()):
        bad = []
        for ts, m in msgs:
            if typ == 'sensor_msgs/msg/JointState':
                n = len(m['name'])
                if n == 0 or len(m['position']) != n:
                    bad.append(f'@{ts}: {n} names, {len(m["position"])} positions')
                for f in ('velocity', 'effort'):
                    if len(m[f]) not in (0, n):
                        bad.append(f'@{ts}: {len(m[f])} {f}')
            elif typ == 'crossym_msgs/msg/SymmetryCondition':
                if m['reflection'] not in (1, -1) or not m['scale'] > 0:
                    bad.append(f'@{ts}: {m}')
            elif typ == 'std_msgs/msg/Float64MultiArray':
                if not m['data']:
                    bad.append(f'@{ts}: empty data')
            elif typ == 'crossym_msgs/msg/Status':
                c = m['condition']
                if m['code'] not in STATUS_CODES or c['reflection'] not in (1, -1) or not c['scale'] > 0:
                    bad.append(f'@{ts}: code {m["code"]}, condition {c}')
                # Bags recorded before Status had tracking_error lack it (their own schema).
                e = m.get('tracking_error', 0.0)
                if not (math.isfinite(e) and e >= 0):
                    bad.append(f'@{ts}: tracking_error {e}')
            if len(bad) > 3:
                break
        checks.add(f'{t}: field values plausible for {typ}', not bad, '; '.join(bad[:3]))


def finish(checks: Checks, summary_json: dict, args) -> int:
    summary_json['ok'] = checks.ok
    summary_json['checks'] = checks.items
    if args.json:
        args.json.write_text(json.dumps(summary_json, indent=2, sort_keys=False) + '\n')
    n_fail = sum(1 for x in checks.items if not x['ok'])
    total = len(checks.items)
    print(f'read_bag: ALL OK ({total} checks)' if not n_fail
          else f'read_bag: {n_fail} of {total} checks FAILED')
    return 0 if checks.ok else 1


if __name__ == '__main__':
    sys.exit(main())
