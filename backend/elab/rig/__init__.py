"""The real flexible link: the rig's byte protocol and drivers, the rig emulator, the
trusted supervisor between a controller and the amplifier, and the rig queue's rules.

Nothing here speaks HTTP or imports the simulation engine; the rig engine (in
:mod:`elab.engines`) joins these parts to the recorder and the fan-out.
"""
