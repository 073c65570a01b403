import sys

from vecpin.cli import main

sys.exit(main())
