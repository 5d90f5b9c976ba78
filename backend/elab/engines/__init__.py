"""Engines: what steps runs, behind one protocol (:class:`~elab.engines.base.Engine`).

The batched simulation (:mod:`elab.engines.simulation`) runs in a process of its own
(:mod:`elab.engines.process`, :mod:`elab.engines.child`); the run manager talks to it
through the protocol only.
"""
