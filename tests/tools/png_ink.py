#!/usr/bin/env python3
"""Dark-pixel counts of a PNG in horizontal bands, decoded with the standard library only.

usage: png_ink.py FILE.png ROW0:ROW1 [ROW0:ROW1 ...]
prints `width height` then, per band, the number of pixels whose R, G and B are all < 128
(text and axes; the paths' colours and greys are lighter in at least one channel).
Independent of crossym's plotting code: it reads the file a user would open.
"""
import struct
import sys
import zlib


def decode(path):
    data = open(path, "rb").read()
    assert data[:8] == b"\x89PNG\r\n\x1a\n", "not a PNG"
    pos, idat, hdr = 8, b"", None
    while pos < len(data):
        (n,) = struct.unpack(">I", data[pos:pos + 4])
        kind, body = data[pos + 4:pos + 8], data[pos + 8:pos + 8 + n]
        pos += 12 + n
        if kind == b"IHDR":
            hdr = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat += body
    w, h, depth, colour, _, _, interlace = hdr
    assert depth == 8 and colour in (2, 6) and interlace == 0, f"unsupported PNG {hdr}"
    bpp = 3 if colour == 2 else 4
    raw, stride, rows, prev = zlib.decompress(idat), w * bpp, [], bytearray(w * bpp)
    for y in range(h):
        f, line = raw[y * (stride + 1)], bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for i in range(stride):
            a = line[i - bpp] if i >= bpp else 0
            b, c = prev[i], (prev[i - bpp] if i >= bpp else 0)
            if f == 1:
                line[i] = (line[i] + a) & 255
            elif f == 2:
                line[i] = (line[i] + b) & 255
            elif f == 3:
                line[i] = (line[i] + (a + b) // 2) & 255
            elif f == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                line[i] = (line[i] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        rows.append(line)
        prev = line
    return w, h, bpp, rows


def main():
    w, h, bpp, rows = decode(sys.argv[1])
    print(w, h)
    for band in sys.argv[2:]:
        r0, r1 = (int(v) for v in band.split(":"))
        n = 0
        for line in rows[max(r0, 0):min(r1, h)]:
            for x in range(w):
                px = line[x * bpp:x * bpp + 3]
                n += px[0] < 128 and px[1] < 128 and px[2] < 128
        print(n)


if __name__ == "__main__":
    main()
