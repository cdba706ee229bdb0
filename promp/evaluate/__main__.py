import sys

from promp.evaluate.cli import main

sys.exit(main())
