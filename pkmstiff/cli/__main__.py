import sys

from pkmstiff.cli import main

sys.exit(main())
