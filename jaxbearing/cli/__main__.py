"""``python -m jaxbearing.cli``: the command line (`jaxbearing.cli.main`)."""

import sys

from . import main

sys.exit(main())
