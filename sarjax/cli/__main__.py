"""``python -m sarjax.cli``: the ``sarjax`` command."""

import sys

from . import main

sys.exit(main())
