"""The real flexible link: the rig's byte protocol and drivers, the rig emulator, the
trusted supervisor between a controller and the amplifier (:mod:`~elab.rig.supervisor`)
and the settle → re-zero sequence between users (:mod:`~elab.rig.settle`). The rig queue's
rules are in :mod:`elab.rig_queue`, below both this package and :mod:`elab.store` (which
applies them atomically).

Nothing here speaks HTTP or imports the simulation engine; the rig engine (in
:mod:`elab.engines`) joins these parts to the recorder and the fan-out.
"""
