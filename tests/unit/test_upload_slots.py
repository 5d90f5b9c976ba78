"""Large bodies received at once: a budget per identity inside the server's total."""

from __future__ import annotations

import pytest

from elab.api.http import Uploads
from elab.errors import TooMany


def test_an_identity_gets_its_share_and_others_the_rest() -> None:
    up = Uploads(3, per_identity=2)
    with up.slot("a"), up.slot("a"):
        with pytest.raises(TooMany, match="ELAB_MAX_UPLOADS_PER_IDENTITY = 2"), up.slot("a"):
            pass
        with up.slot("b"), pytest.raises(TooMany, match="ELAB_MAX_UPLOADS = 3"), up.slot("c"):
            pass
    assert up.reading == 0 and not up.by  # every slot given back, refused ones too
    with up.slot("a"), up.slot("a"):
        pass
