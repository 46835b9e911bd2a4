"""Frames from the wire: check type, size, pixel count and decoded size *before* decoding, then ``cv2.imdecode``.

The pixel count comes from the PNG IHDR chunk or the JPEG SOF marker, so a small file that would
decode to gigabytes (a decompression bomb) is refused without allocating it.
"""
from __future__ import annotations

import struct

import numpy as np

from nfex_core.errors import BadInput, NfexError

from .bodies import media_type

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
JPEG_MAGIC = b"\xff\xd8\xff"
ACCEPTED_TYPES = {"image/png", "image/jpeg", "image/jpg", "application/octet-stream", ""}
_SOF = {0xC0, 0xC1, 0xC2, 0xC3, 0xC5, 0xC6, 0xC7, 0xC9, 0xCA, 0xCB, 0xCD, 0xCE, 0xCF}


class PayloadTooLarge(NfexError):
    status = 413
    type = "payload-too-large"
    title = "Payload too large"
    exit_code = 2


class UnsupportedMediaType(NfexError):
    status = 415
    type = "unsupported-media-type"
    title = "Unsupported media type"
    exit_code = 2


class BadImage(BadInput):
    status = 422
    type = "bad-image"
    title = "The frame cannot be decoded"


PNG_CHANNELS = {0: 1, 2: 3, 3: 1, 4: 2, 6: 4}  # by colour type: grey, RGB, palette, grey + alpha, RGBA


def image_size(data: bytes) -> tuple[str, int, int]:
    """(format, width, height) from the header; BadImage for a truncated or corrupt header."""
    fmt, w, h, _ = image_header(data)
    return fmt, w, h


def image_header(data: bytes) -> tuple[str, int, int, int]:
    """(format, width, height, bytes the decoder writes per pixel) from the header; BadImage for a truncated or
    corrupt header."""
    if data.startswith(PNG_MAGIC):
        if len(data) < 26 or data[12:16] != b"IHDR":
            raise BadImage("the PNG header is truncated or has no IHDR chunk")
        w, h = struct.unpack(">II", data[16:24])
        depth, colour = data[24], data[25]
        return "png", w, h, PNG_CHANNELS.get(colour, 4) * max(1, depth // 8)
    if data.startswith(JPEG_MAGIC):
        i = 2
        while i + 4 <= len(data):
            if data[i] != 0xFF:
                raise BadImage(f"corrupt JPEG: expected a marker at byte {i}")
            marker = data[i + 1]
            if marker == 0xFF:
                i += 1
                continue
            if marker in (0xD8, 0x01) or 0xD0 <= marker <= 0xD7:
                i += 2
                continue
            (length,) = struct.unpack(">H", data[i + 2 : i + 4])
            if marker in _SOF:
                if i + 10 > len(data):
                    break
                precision = data[i + 4]
                h, w = struct.unpack(">HH", data[i + 5 : i + 9])
                return "jpeg", w, h, data[i + 9] * max(1, (precision + 7) // 8)
            i += 2 + length
        raise BadImage("the JPEG is truncated before its frame header (SOF)")
    raise UnsupportedMediaType("the frame is neither PNG nor JPEG (checked by its first bytes)")


def decode_frame(data: bytes, content_type: str | None, *, max_bytes: int, max_pixels: int,
                 max_decoded_bytes: int | None = None) -> np.ndarray:
    """A frame as a uint8 grey image (colour is converted; 16-bit is scaled), or a 4xx NfexError."""
    media = media_type(content_type)
    if media not in ACCEPTED_TYPES:
        raise UnsupportedMediaType(f"frame content type {media!r}; send image/png or image/jpeg")
    if not data:
        raise BadImage("the frame is empty (0 bytes)")
    if len(data) > max_bytes:
        raise PayloadTooLarge(f"the frame has {len(data)} bytes; the limit is {max_bytes}", limit=max_bytes)
    fmt, w, h, per_pixel = image_header(data)
    if w == 0 or h == 0:
        raise BadImage(f"the {fmt.upper()} header says {w}×{h} pixels")
    if w * h > max_pixels:
        raise PayloadTooLarge(f"the frame is {w}×{h} = {w * h} pixels; the limit is {max_pixels}", limit=max_pixels)
    decoded = w * h * per_pixel  # what the decoder inflates and converts: the cost of a deep or colour frame
    if max_decoded_bytes is not None and decoded > max_decoded_bytes:
        raise PayloadTooLarge(
            f"the frame decodes to {decoded} bytes ({w}×{h}, {per_pixel} bytes a pixel); the limit is {max_decoded_bytes}: "
            "send 8-bit grey or a smaller frame", limit=max_decoded_bytes)
    import cv2

    image = cv2.imdecode(np.frombuffer(data, dtype=np.uint8), cv2.IMREAD_GRAYSCALE)
    if image is None or image.size == 0:
        raise BadImage(f"OpenCV could not decode the {fmt.upper()} data (corrupt or truncated)")
    if image.shape[:2] != (h, w):
        raise BadImage(f"the decoded frame is {image.shape[1]}×{image.shape[0]}, the header says {w}×{h}")
    return image
