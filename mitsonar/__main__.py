import sys

from mitsonar.cli import main

sys.exit(main())
