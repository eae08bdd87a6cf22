"""``python -m lrr ARGS...``: the ``lrr`` command line from the wheel (the child process of
``lrr.bake``). SIGINT ends it at once, as it ends the binary: the output file is written
atomically and the bake's checkpoint survives for ``resume=True``."""

import signal
import sys

from lrr._lrr import main

if __name__ == "__main__":
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    sys.exit(main(sys.argv[1:]))
