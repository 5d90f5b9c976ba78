"""``elab serve`` starts the fork server (:mod:`elab.jobs`) before it imports the web app,
with every module the engine and the worker pools ask for (:mod:`elab.api.preload`); one
asked for after it started is logged (each forked process then imports it itself, as the
pools' workers and the engine do)."""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

from elab.api import controllers, ident, preload
from elab.engines import process


def test_the_preload_names_what_the_engine_and_both_pools_import() -> None:
    assert process.CHILD in preload.ENGINE
    assert set(ident.JOB_MODULES) <= set(preload.ALL)
    assert set(controllers.JOB_MODULES) <= set(preload.ALL)
    assert len(set(preload.ALL)) == len(preload.ALL)  # each named once


def test_a_module_asked_for_after_the_start_is_logged(tmp_path: Path) -> None:
    """A real fork server: started with one module, asked for another later. A forked
    process has the first already; the late one is named in a warning, the first is not."""
    script = textwrap.dedent(
        """
        import logging, sys
        from elab import jobs
        logging.basicConfig(level=logging.WARNING, stream=sys.stdout, format="%(message)s")

        def has(name):
            import sys
            return name in sys.modules

        if __name__ == "__main__":
            jobs.start_fork_server(["colorsys"])
            jobs.import_in_fork_server(["colorsys"])  # already there: nothing to say
            jobs.import_in_fork_server(["wave"])
            import multiprocessing
            ctx = multiprocessing.get_context("forkserver")
            with ctx.Pool(1) as pool:
                print("in the fork:", pool.apply(has, ("colorsys",)))
        """
    )
    main = tmp_path / "main.py"  # a file: the forked process imports ``has`` from it
    main.write_text(script)
    proc = subprocess.run(
        [sys.executable, str(main)], capture_output=True, text=True, timeout=120, check=False
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "the fork server started without wave:" in proc.stdout
    assert "colorsys:" not in proc.stdout and "without colorsys" not in proc.stdout
    assert "in the fork: True" in proc.stdout
