import sys

from acder_lite.cli.main import main
from acder_lite.signals import end_on_signals

try:
    code = main()
except KeyboardInterrupt:  # a second Ctrl-C as main returned from the first
    code = 130
end_on_signals()  # only exiting now: a Ctrl-C ends the process, no traceback
sys.exit(code)
