"""uavsim: passive bearings-only monitoring of ground targets from one UAV.

Pipeline (one module per stage, in data-flow order): world -> targets/guidance ->
sensing -> filtering -> planning -> recording -> campaign -> cli.  ``config`` is the
only module that reads files.
"""

__version__ = "0.1.0"
