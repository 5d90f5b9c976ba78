"""E-Lab: a web laboratory for control engineering.

The core library: plant models (:mod:`elab.plants`), analysis and design
(:mod:`elab.design`) and the one simulation engine (:mod:`elab.sim`). It has no
I/O and no web dependencies, so a student can ``pip install`` it and get the
same numbers offline as the lab serves online.
"""

__version__ = "0.1.0"
