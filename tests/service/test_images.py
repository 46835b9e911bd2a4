"""decode_frame: any bytes give a decoded grey frame or a 4xx NfexError, never anything else."""
from __future__ import annotations

import cv2
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from nfex_core.errors import NfexError
from service.images import decode_frame, image_size

LIMITS = {"max_bytes": 1 << 20, "max_pixels": 1 << 20}


def encoded(ext: str, image: np.ndarray) -> bytes:
    ok, buf = cv2.imencode(ext, image)
    assert ok
    return bytes(buf)


BASE = [encoded(".png", np.full((40, 60), 128, np.uint8)), encoded(".jpg", np.full((40, 60, 3), 90, np.uint8))]


@settings(max_examples=80, deadline=None)
@given(st.sampled_from(BASE), st.integers(0, 400), st.binary(max_size=64), st.sampled_from(["image/png", "image/jpeg", None]))
def test_mutated_images_never_escape_as_other_errors(base: bytes, cut: int, noise: bytes, media: str | None) -> None:
    data = base[:cut] + noise + base[cut + len(noise):]
    try:
        image = decode_frame(data, media, **LIMITS)
    except NfexError as e:
        assert 400 <= e.status < 500
    else:
        _, w, h = image_size(data)  # a mutation may change the header's size; decoding must agree with it
        assert image.dtype == np.uint8 and image.ndim == 2 and image.shape == (h, w) and h * w <= LIMITS["max_pixels"]


def test_headers_give_the_size_without_decoding() -> None:
    assert image_size(BASE[0]) == ("png", 60, 40)
    assert image_size(BASE[1]) == ("jpeg", 60, 40)
    colour = decode_frame(BASE[1], "image/jpeg", **LIMITS)
    assert colour.shape == (40, 60)  # colour arrives grey
