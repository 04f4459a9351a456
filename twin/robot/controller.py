"""What a robot controller's programs and real-time interfaces take from a cell: the tool and base slots a program
writes and selects (KRL's `TOOL_DATA`, `LOAD_DATA`, `BASE_DATA`), and the online correction's size and rate limits
(the exported program's RSI POSCORR limits and EGM end tolerance, the compensator's and its server's alike).

A cell file's `[controller]` table gives them once (`twin.process.cell_file`), `export --tool-number`,
`--base-number`, `--max-correction-mm` and `online --max-rate-mm-s` override it, and these defaults fill what neither
gives. A program never writes the cell's calibrated slot 1 unless the user names it.
"""

from __future__ import annotations

#: The slots a program may use: KRL's `TOOL_DATA[16]`, `LOAD_DATA[16]` and `BASE_DATA[32]` (`$config.dat`).
TOOL_NUMBERS = range(1, 17)
BASE_NUMBERS = range(1, 33)
#: The slots written when none is given: the last tool, and base 16, never 1 (a cell's calibrated tool and base are
#: usually 1); the program overwrites them.
DEFAULT_TOOL_NUMBER = 16
DEFAULT_BASE_NUMBER = 16
#: The online correction's size limit when none is given [mm] (a TX200's or a KR 210's deflection on the thesis's
#: groove fits it; an IRB 6640's deepest passes reach it), and the largest a cell may allow [mm]: beyond it a
#: correction is not an arm's deflection under a forming load.
DEFAULT_MAX_CORRECTION_MM = 5.0
MAX_CORRECTION_LIMIT_MM = 50.0
#: The online correction's rate limit when none is given [mm/s], and the largest a server takes [mm/s] (5 mm in
#: 5 ms: faster is a jump, not a rate).
DEFAULT_MAX_RATE_MM_S = 20.0
MAX_RATE_MM_S = 1000.0
#: What a cell's `[controller]` table gives, by the names of the command flags that override it: the slots (their
#: ranges) and the online correction's limits (their largest and unit; taken only where a command corrects online).
SLOTS = {"tool_number": TOOL_NUMBERS, "base_number": BASE_NUMBERS}
ONLINE_LIMITS = {"max_correction_mm": (MAX_CORRECTION_LIMIT_MM, "mm"), "max_rate_mm_s": (MAX_RATE_MM_S, "mm/s")}
#: Their defaults, where neither a flag nor a cell gives them.
CONTROLLER_DEFAULTS = {"tool_number": DEFAULT_TOOL_NUMBER, "base_number": DEFAULT_BASE_NUMBER,
                       "max_correction_mm": DEFAULT_MAX_CORRECTION_MM, "max_rate_mm_s": DEFAULT_MAX_RATE_MM_S}
