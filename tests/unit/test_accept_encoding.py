"""Who gets gzip (elab/api/http.py ``accepts_gzip``): the coding named with a weight above
0, or ``*`` when it is not named (RFC 9110, 12.5.3); the plain response otherwise."""

from __future__ import annotations

import pytest

from elab.api.http import accepts_gzip


@pytest.mark.parametrize(
    ("header", "gzip"),
    [
        ("gzip, deflate, br, zstd", True),  # Chromium's
        ("gzip", True),
        ("GZIP", True),
        ("x-gzip", True),
        ("br;q=1.0, gzip;q=0.5", True),
        ("gzip ; q=0.001", True),
        ("*", True),
        ("*;q=0.1", True),
        ("", False),
        ("identity", False),
        ("deflate, br", False),
        ("gzip;q=0", False),  # named, and refused
        ("gzip;q=0.0, identity", False),
        ("*, gzip;q=0", False),  # gzip's own weight wins over the wildcard's
        ("gzip;q=0, *", False),
        ("*;q=0", False),
        ("gzip;q=nope", False),  # unreadable: not taken
        ("gzip;q=nan", False),
        ("gzip;q=inf", False),
        ("gzipped", False),  # a word containing it is another coding
        (",,;q=1,", False),
    ],
)
def test_gzip_is_taken_only_where_the_header_takes_it(header: str, gzip: bool) -> None:
    assert accepts_gzip(header) is gzip
