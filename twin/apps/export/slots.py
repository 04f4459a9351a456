"""The controller's tool and base slots a program writes and selects (KRL's `TOOL_DATA`, `LOAD_DATA`, `BASE_DATA`):
never the cell's calibrated slot 1 unless the user names it (`export --tool-number`, `--base-number`)."""

from __future__ import annotations

#: The slots a program may use: KRL's `TOOL_DATA[16]`, `LOAD_DATA[16]` and `BASE_DATA[32]` (`$config.dat`).
TOOL_NUMBERS = range(1, 17)
BASE_NUMBERS = range(1, 33)
#: The slots written when none is given: the last tool, and base 16, never 1 (a cell's calibrated tool and base are
#: usually 1); the program overwrites them.
DEFAULT_TOOL_NUMBER = 16
DEFAULT_BASE_NUMBER = 16
