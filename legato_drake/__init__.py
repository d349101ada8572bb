"""legato-drake: LEGATO cross-embodiment imitation learning on Drake."""

__version__ = "0.1.0"
