"""The recorder stores every run's rows as the stepper handed them over, in blocks of
changing groups of runs (runs join, pause, leave; ticks of different lengths)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from elab.engines.base import Block
from elab.engines.recorder import Recorder
from elab.store import SQLiteStore
from tests.unit.store.test_sqlite import NCH, record


@pytest.mark.parametrize("seed", range(6))
def test_blocks_of_changing_groups_are_stored_row_for_row(tmp_path: Path, seed: int) -> None:
    rng = np.random.default_rng(seed)
    ids = [f"r-{i:012d}" for i in range(7)]
    expected: dict[str, list[np.ndarray]] = {i: [] for i in ids}
    k = dict.fromkeys(ids, 0)
    with SQLiteStore(tmp_path / "s.sqlite3") as store:
        for i in ids:
            store.create_run(record(i))
        rec = Recorder(store)
        for i in ids:
            rec.open(i, NCH)
        for _tick in range(60):
            # a tick: the live, unpaused runs of each of two "plants", some steps long
            live = [i for i in ids if rng.random() < 0.8]
            n = int(rng.choice([1, 20, 20, 20, 7]))
            for group in (live[::2], live[1::2]):
                if not group:
                    continue
                data = rng.standard_normal((len(group), n, NCH))
                rec.append(Block(group, [k[i] for i in group], data))
                for j, i in enumerate(group):
                    expected[i].append(data[j])
                    k[i] += n
            if rng.random() < 0.15:
                rec.flush()
        rec.flush()
        for i in ids:
            want = np.concatenate(expected[i]) if expected[i] else np.zeros((0, NCH))
            np.testing.assert_array_equal(store.read(i), want)
            assert store.get_run(i).n_stored == k[i]
