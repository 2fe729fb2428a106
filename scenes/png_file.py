"""Writes the small 8-bit PNG textures of the generated test scenes.

Python's standard library has no PNG writer and the scenes' generators
should need nothing beyond usd-core, so the few chunks are written here:
IHDR, an optional sRGB chunk, one zlib-compressed IDAT (filter 0 on every
row), IEND.
"""
import struct
import zlib


def write_png(path, width, height, pixels8, channels, srgb=False):
    """8-bit PNG from a flat list of width*height*channels ints (3: RGB, 4: RGBA)."""
    color_type = {3: 2, 4: 6}[channels]
    row = width * channels
    raw = b"".join(b"\x00" + bytes(pixels8[y * row:(y + 1) * row]) for y in range(height))

    def chunk(kind, data):
        body = kind + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body) & 0xFFFFFFFF)

    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n")
        f.write(chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, color_type, 0, 0, 0)))
        if srgb:
            f.write(chunk(b"sRGB", b"\x00"))
        f.write(chunk(b"IDAT", zlib.compress(raw, 9)))
        f.write(chunk(b"IEND", b""))
