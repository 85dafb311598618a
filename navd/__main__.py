"""``python -m navd`` is the ``navd`` command."""

from navd.cli import main

raise SystemExit(main())
