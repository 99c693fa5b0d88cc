#!/usr/bin/env python3
"""Regenerate the reference examples of what rosbags writes (the layout crates/crossym-io/src/bag must match).

    python3 tests/bags/dump_examples.py [--msgs msgs/msg] [--out tests/bags]

Writes bags with write_bag.py into a temporary folder (bag dir `example_bag`, so
the MCAP file is `example_bag.mcap`) and dumps:
  example_schemas.txt      the exact MCAP Schema records (name, encoding, data) of
                           all four types, the channel metadata, the rosbag2
                           Metadata record and the RIHS01 hashes
  example_metadata.yaml    metadata.yaml of a version 9 bag (rosbags' default)
  example_metadata_v8.yaml metadata.yaml of a version 8 bag (ROS 2 Jazzy's version)
  example_layout.txt       every MCAP record of a tiny bag (offsets, fields, hex)
"""

from __future__ import annotations

import argparse
import json
import struct
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
OPCODES = {0x01: 'Header', 0x02: 'Footer', 0x03: 'Schema', 0x04: 'Channel', 0x05: 'Message',
           0x06: 'Chunk', 0x07: 'MessageIndex', 0x08: 'ChunkIndex', 0x09: 'Attachment',
           0x0A: 'AttachmentIndex', 0x0B: 'Statistics', 0x0C: 'Metadata',
           0x0D: 'MetadataIndex', 0x0E: 'SummaryOffset', 0x0F: 'DataEnd'}


def write(bagdir: Path, msgs: Path, *extra: str) -> None:
    subprocess.run([sys.executable, str(HERE / 'write_bag.py'), str(bagdir), '--msgs', str(msgs),
                    *extra], check=True, stdout=subprocess.DEVNULL)


class Buf:
    def __init__(self, data: bytes, pos: int = 0) -> None:
        self.d, self.p = data, pos

    def u8(self):
        self.p += 1
        return self.d[self.p - 1]

    def u16(self):
        self.p += 2
        return struct.unpack_from('<H', self.d, self.p - 2)[0]

    def u32(self):
        self.p += 4
        return struct.unpack_from('<I', self.d, self.p - 4)[0]

    def u64(self):
        self.p += 8
        return struct.unpack_from('<Q', self.d, self.p - 8)[0]

    def raw(self, n):
        self.p += n
        return self.d[self.p - n:self.p]

    def string(self):
        return self.raw(self.u32()).decode()

    def strmap(self):
        end = self.p + 4 + self.u32()
        out = {}
        while self.p < end:
            k = self.string()
            out[k] = self.string()
        return out


def describe(op: int, body: bytes) -> str:
    b = Buf(body)
    if op == 0x01:
        return f'profile={b.string()!r} library={b.string()!r}'
    if op == 0x02:
        return f'summary_start={b.u64()} summary_offset_start={b.u64()} summary_crc={b.u32()}'
    if op == 0x03:
        return f'id={b.u16()} name={b.string()!r} encoding={b.string()!r} data=<{b.u32()} bytes>'
    if op == 0x04:
        return (f'id={b.u16()} schema_id={b.u16()} topic={b.string()!r} '
                f'message_encoding={b.string()!r} metadata={b.strmap()!r}')
    if op == 0x05:
        cid, seq, lt, pt = b.u16(), b.u32(), b.u64(), b.u64()
        data = body[b.p:]
        return (f'channel_id={cid} sequence={seq} log_time={lt} publish_time={pt} '
                f'data=<{len(data)} bytes> {data[:48].hex(" ")}{" ..." if len(data) > 48 else ""}')
    if op == 0x06:
        s, e, size, crc = b.u64(), b.u64(), b.u64(), b.u32()
        comp = b.string()
        n = b.u64()
        return (f'message_start_time={s} message_end_time={e} uncompressed_size={size} '
                f'uncompressed_crc={crc} compression={comp!r} records=<{n} bytes>')
    if op == 0x07:
        cid = b.u16()
        n = b.u32() // 16
        recs = [(b.u64(), b.u64()) for _ in range(n)]
        return f'channel_id={cid} records(log_time, offset in chunk records)={recs}'
    if op == 0x08:
        s, e, cs, cl = b.u64(), b.u64(), b.u64(), b.u64()
        n = b.u32() // 10
        offs = {b.u16(): b.u64() for _ in range(n)}
        mil = b.u64()
        comp = b.string()
        return (f'message_start_time={s} message_end_time={e} chunk_start_offset={cs} '
                f'chunk_length={cl} message_index_offsets={offs} message_index_length={mil} '
                f'compression={comp!r} compressed_size={b.u64()} uncompressed_size={b.u64()}')
    if op == 0x0B:
        mc, sc, cc, ac, mdc, chc, st, et = (b.u64(), b.u16(), b.u32(), b.u32(), b.u32(), b.u32(),
                                            b.u64(), b.u64())
        n = b.u32() // 10
        counts = {b.u16(): b.u64() for _ in range(n)}
        return (f'message_count={mc} schema_count={sc} channel_count={cc} attachment_count={ac} '
                f'metadata_count={mdc} chunk_count={chc} message_start_time={st} '
                f'message_end_time={et} channel_message_counts={counts}')
    if op == 0x0C:
        name = b.string()
        md = b.strmap()
        return f'name={name!r} metadata keys={list(md)} (serialized_metadata: see example_schemas.txt)'
    if op == 0x0D:
        return f'offset={b.u64()} length={b.u64()} name={b.string()!r}'
    if op == 0x0E:
        g = b.u8()
        return f'group_opcode={g:#04x} ({OPCODES.get(g)}) group_start={b.u64()} group_length={b.u64()}'
    if op == 0x0F:
        return f'data_section_crc={b.u32()}'
    return body.hex()


def layout(path: Path) -> str:
    d = path.read_bytes()
    lines = [f'# {path.name}: {len(d)} bytes', f'0: magic {d[:8].hex(" ")}  ({d[:8]!r})']
    pos = 8
    while pos < len(d) - 8:
        op = d[pos]
        (n,) = struct.unpack_from('<Q', d, pos + 1)
        body = d[pos + 9:pos + 9 + n]
        lines.append(f'{pos}: {OPCODES.get(op, hex(op))} (op {op:#04x}, len {n}) {describe(op, body)}')
        if op == 0x06:
            b = Buf(body)
            b.u64(), b.u64(), b.u64(), b.u32()
            b.string()
            rl = b.u64()
            recs = body[b.p:b.p + rl]
            rp = 0
            while rp < len(recs):
                rop = recs[rp]
                (rn,) = struct.unpack_from('<Q', recs, rp + 1)
                lines.append(f'    chunk+{rp}: {OPCODES.get(rop, hex(rop))} (op {rop:#04x}, len {rn}) '
                             f'{describe(rop, recs[rp + 9:rp + 9 + rn])}')
                rp += 9 + rn
        pos += 9 + n
    lines.append(f'{pos}: magic {d[pos:].hex(" ")}')
    return '\n'.join(lines) + '\n'


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument('--msgs', type=Path, default=HERE.parent.parent / 'msgs' / 'msg')
    ap.add_argument('--out', type=Path, default=HERE)
    args = ap.parse_args()

    from mcap.reader import make_reader
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    with tempfile.TemporaryDirectory() as tmp:
        v9 = Path(tmp, 'v9', 'example_bag')
        v8 = Path(tmp, 'v8', 'example_bag')
        tiny = Path(tmp, 'tiny', 'example_bag')
        v8noqos = Path(tmp, 'v8noqos', 'example_bag')
        write(v9, args.msgs, '--all-topics')
        write(v8, args.msgs, '--all-topics', '--version', '8')
        write(v8noqos, args.msgs, '--version', '8', '--no-qos', '--seconds', '0.02')
        write(tiny, args.msgs, '--all-topics', '--seconds', '0.02')

        (args.out / 'example_metadata.yaml').write_text((v9 / 'metadata.yaml').read_text())
        (args.out / 'example_metadata_v8.yaml').write_text((v8 / 'metadata.yaml').read_text())
        (args.out / 'example_layout.txt').write_text(
            '# MCAP records written by rosbags 0.11.9 (write_bag.py OUT --all-topics --seconds 0.02,\n'
            '# rosbag2 version 9, default QoS). Offsets are file offsets; "chunk+N" are offsets\n'
            '# inside the uncompressed chunk records (what MessageIndex offsets refer to).\n'
            '# Every record: opcode u8, length u64 LE, body. Strings: u32 LE length + UTF-8.\n\n'
            + layout(tiny / 'example_bag.mcap')
            + '\n# Same, version 8 and --no-qos (offered_qos_profiles is then the empty string),\n'
            '# only /joint_states and /crossym/symmetry_condition:\n\n'
            + layout(v8noqos / 'example_bag.mcap'))

        out = []
        sep = '#' * 100
        out.append('# MCAP Schema/Channel/Metadata records as written by rosbags 0.11.9\n'
                   '# (tests/bags/write_bag.py --all-topics; regenerate: tests/bags/dump_examples.py).\n'
                   '# Each schema is shown twice: verbatim between the BEGIN/END lines (the data ends\n'
                   '# with one newline, which is the last line before END), then as a JSON string.\n')
        with (v9 / 'example_bag.mcap').open('rb') as f:
            reader = make_reader(f)
            summ = reader.get_summary()
            metas = list(reader.iter_metadata())
        store = get_typestore(Stores.EMPTY)
        typs = {}
        for s in summ.schemas.values():
            typs.update(get_types_from_msg(s.data.decode(), s.name))
        store.register(typs)
        want = ['sensor_msgs/msg/JointState', 'crossym_msgs/msg/Status',
                'crossym_msgs/msg/SymmetryCondition', 'std_msgs/msg/Float64MultiArray']
        by_name = {s.name: s for s in summ.schemas.values()}
        for name in want:
            s = by_name[name]
            text = s.data.decode()
            out.append(f'{sep}\n# Schema id={s.id} name={s.name!r} encoding={s.encoding!r} '
                       f'len={len(s.data)} bytes\n# RIHS01 (metadata.yaml type_description_hash): '
                       f'{store.hash_rihs01(name)}\n'
                       f'----- BEGIN schema data -----\n{text}----- END schema data -----\n'
                       f'JSON: {json.dumps(text)}\n')
        out.append(f'{sep}\n# Channels (summary section; the same records also open the first chunk)\n')
        for c in summ.channels.values():
            out.append(f'Channel id={c.id} schema_id={c.schema_id} topic={c.topic!r} '
                       f'message_encoding={c.message_encoding!r}\n'
                       f'  metadata = {json.dumps(c.metadata)}\n')
        with (v8 / 'example_bag.mcap').open('rb') as f:
            c8 = make_reader(f).get_summary().channels[1]
        out.append(f'\n# Version 8 bag: channel {c8.topic!r} metadata = {json.dumps(c8.metadata)}\n'
                   '# With no QoS given (write_bag.py --no-qos): version 9 writes "[]", '
                   'version 8 writes "".\n')
        out.append(f'{sep}\n# Metadata records (version 9 bag)\n')
        for m in metas:
            out.append(f'Metadata name={m.name!r} keys={list(m.metadata)}\n'
                       f'----- BEGIN serialized_metadata -----\n{m.metadata["serialized_metadata"]}\n'
                       '----- END serialized_metadata (no trailing newline) -----\n')
        (args.out / 'example_schemas.txt').write_text(''.join(out))
    for n in ('example_schemas.txt', 'example_metadata.yaml', 'example_metadata_v8.yaml',
              'example_layout.txt'):
        print(args.out / n)
    return 0


if __name__ == '__main__':
    sys.exit(main())
