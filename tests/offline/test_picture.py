"""The map picture's PNG encoder: streamed a band of rows at a time, it must still decode
to the image given, in the order asked for."""

from __future__ import annotations

import struct
import zlib

import numpy as np
import pytest

from navd.offline.picture import encode_png


def _decode(png: bytes) -> np.ndarray:
    """An RGB PNG with filter type 0 on every row, decoded by the format's definition."""
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    at, chunks = 8, {}
    while at < len(png):
        (length,) = struct.unpack(">I", png[at : at + 4])
        kind, data = png[at + 4 : at + 8], png[at + 8 : at + 8 + length]
        (crc,) = struct.unpack(">I", png[at + 8 + length : at + 12 + length])
        assert crc == zlib.crc32(kind + data) & 0xFFFFFFFF
        chunks[kind] = data
        at += 12 + length
    cols, rows, depth, colour = struct.unpack(">IIBB", chunks[b"IHDR"][:10])
    assert (depth, colour) == (8, 2)
    raw = np.frombuffer(zlib.decompress(chunks[b"IDAT"]), dtype=np.uint8)
    raw = raw.reshape(rows, 1 + 3 * cols)
    assert np.all(raw[:, 0] == 0)
    return raw[:, 1:].reshape(rows, cols, 3)


@pytest.mark.parametrize("rows", [1, 255, 256, 700])
def test_a_png_decodes_to_the_image_top_down_or_bottom_up(rows: int) -> None:
    rgb = np.random.default_rng(rows).integers(0, 256, (rows, 9, 3), dtype=np.uint8)
    assert np.array_equal(_decode(encode_png(rgb)), rgb)
    assert np.array_equal(_decode(encode_png(rgb, bottom_up=True)), rgb[::-1])
