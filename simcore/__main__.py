import sys

from .cli import main
from .startup.patches import freeze_heap

code = main()
# The process ends here: its shut-down skips the objects frozen now (start-up patch gc_freeze)
freeze_heap()
sys.exit(code)
