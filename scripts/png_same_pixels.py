#!/usr/bin/env python3
"""Whether two PNG files hold the same pixels (their bytes may differ: compression level,
filters). 8-bit RGB or RGBA, not interlaced, as moldgate writes them. Standard library only.

    python3 scripts/png_same_pixels.py OLD.png NEW.png

Prints the sizes and the number of differing pixels; exits 1 when they differ.
"""
import struct
import sys
import zlib


def pixels(path):
    data = open(path, "rb").read()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        sys.exit(f"{path}: not a PNG")
    pos, idat, head = 8, b"", None
    while pos < len(data):
        (length,) = struct.unpack(">I", data[pos : pos + 4])
        kind = data[pos + 4 : pos + 8]
        body = data[pos + 8 : pos + 8 + length]
        if kind == b"IHDR":
            head = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat += body
        pos += 12 + length
    width, height, depth, colour, _, _, interlace = head
    if depth != 8 or colour not in (2, 6) or interlace:
        sys.exit(f"{path}: only 8-bit RGB/RGBA without interlace")
    bpp = 3 if colour == 2 else 4
    raw = zlib.decompress(idat)
    stride = width * bpp
    out, prev = [], bytearray(stride)
    for y in range(height):
        kind = raw[y * (stride + 1)]
        line = bytearray(raw[y * (stride + 1) + 1 : (y + 1) * (stride + 1)])
        for i in range(stride):
            a = line[i - bpp] if i >= bpp else 0
            b = prev[i]
            c = prev[i - bpp] if i >= bpp else 0
            if kind == 1:
                line[i] = (line[i] + a) & 255
            elif kind == 2:
                line[i] = (line[i] + b) & 255
            elif kind == 3:
                line[i] = (line[i] + (a + b) // 2) & 255
            elif kind == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                pr = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
                line[i] = (line[i] + pr) & 255
        out.append(bytes(line))
        prev = line
    return width, height, bpp, out


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    a, b = (pixels(p) for p in sys.argv[1:])
    if a[:3] != b[:3]:
        print(f"different sizes: {a[:3]} against {b[:3]}")
        sys.exit(1)
    width, bpp = a[0], a[2]
    differ = sum(
        1
        for ra, rb in zip(a[3], b[3])
        if ra != rb
        for x in range(width)
        if ra[x * bpp : (x + 1) * bpp] != rb[x * bpp : (x + 1) * bpp]
    )
    print(f"{a[0]}x{a[1]} pixels, {differ} differ")
    sys.exit(1 if differ else 0)


if __name__ == "__main__":
    main()
