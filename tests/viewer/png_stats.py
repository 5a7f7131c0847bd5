"""Decodes the PNG screenshots headless Chromium writes (8-bit RGB or RGBA, not interlaced) with the
standard library's zlib and NumPy, for the viewer tests' pixel statistics."""
import struct
import zlib

import numpy as np


def _paeth(a, b, c):
    p = a + b - c
    pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
    return a if pa <= pb and pa <= pc else (b if pb <= pc else c)


def _unfilter(raw, height, stride, bpp):
    out = np.zeros((height, stride), dtype=np.uint8)
    prev = np.zeros(stride, dtype=np.int32)
    pos = 0
    for y in range(height):
        kind = raw[pos]
        line = np.frombuffer(raw, dtype=np.uint8, count=stride, offset=pos + 1).astype(np.int32)
        pos += 1 + stride
        if kind == 0:
            cur = line
        elif kind == 1:  # Sub: a running sum per channel, modulo 256
            cur = np.cumsum(line.reshape(-1, bpp), axis=0).reshape(-1) % 256
        elif kind == 2:  # Up
            cur = (line + prev) % 256
        elif kind in (3, 4):  # Average, Paeth: each byte depends on the one just decoded
            cur = [0] * stride
            lv, pv = line.tolist(), prev.tolist()
            for i in range(stride):
                a = cur[i - bpp] if i >= bpp else 0
                b = pv[i]
                if kind == 3:
                    cur[i] = (lv[i] + ((a + b) >> 1)) & 255
                else:
                    c = pv[i - bpp] if i >= bpp else 0
                    cur[i] = (lv[i] + _paeth(a, b, c)) & 255
            cur = np.array(cur, dtype=np.int32)
        else:
            raise ValueError(f"PNG filter type {kind} on row {y}")
        out[y] = cur
        prev = cur
    return out


def read_png_rgb(path):
    """The image as a float array [height, width, 3] of 0..255."""
    data = open(path, "rb").read()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise ValueError(f"{path}: not a PNG file")
    pos, idat, header = 8, b"", None
    while pos < len(data):
        length, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + length]
        pos += 12 + length
        if kind == b"IHDR":
            header = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat += body
        elif kind == b"IEND":
            break
    width, height, depth, color, _, _, interlace = header
    if depth != 8 or color not in (2, 6) or interlace != 0:
        raise ValueError(f"{path}: PNG depth {depth}, colour type {color}, interlace {interlace} not handled")
    bpp = 3 if color == 2 else 4
    pixels = _unfilter(zlib.decompress(idat), height, width * bpp, bpp).reshape(height, width, bpp)
    return pixels[:, :, :3].astype(np.float64)
