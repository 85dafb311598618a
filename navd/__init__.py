"""navd: a single-process navigation daemon for small ground robots.

Subpackages, one layer each: ``lifecycle`` (event loop, messages, dispatch, supervision),
``slam``, ``estimation``, ``planning`` and ``drivers``; ``config`` holds the TOML model.
"""

__version__ = "0.1.0"
