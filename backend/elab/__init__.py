"""E-Lab: a web laboratory for control engineering.

The core library: plant models (:mod:`elab.plants`), analysis and design
(:mod:`elab.design`) and the one simulation engine (:mod:`elab.sim`). It has no
I/O and no web dependencies, so a student can ``pip install`` it and get the
same numbers offline as the lab serves online.
"""

import os

# One BLAS thread unless the user says otherwise: the lab's matrices are small, and
# OpenBLAS's worker threads cost more than they give on them (subspace identification ran
# 2× slower with them on 2 cores) and compete with the real-time stepper. Effective when
# E-Lab is imported before NumPy, as by the `elab` command.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

__version__ = "0.1.0"
