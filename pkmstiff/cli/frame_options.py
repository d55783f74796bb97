"""Shared command-line options: ``--frame machine|report``, ``--neglect-spindle`` and ``--skip-check NAME``
(docs/user-guide/validation-hexaglide.md items 2, 4, 9).

Not a command module (it registers no sub-command); the commands that take or print positions add these options.
"""

from __future__ import annotations

from typing import Any

from pkmstiff.admissibility.checks import ALL_CHECKS
from pkmstiff.machine.frames import FRAMES


def add_frame_argument(p: Any) -> None:
    """``--frame``: positions on the command line and in the output are in this frame."""
    p.add_argument("--frame", default="machine", choices=FRAMES,
                   help="frame of every position given and printed: 'machine' (the machine file's coordinates, "
                        "default) or 'report' (origin at the machine's report_origin, e.g. the Hexaglide's middle "
                        "guide, the frame of the dissertation's quoted positions)")


def add_spindle_argument(p: Any) -> None:
    """``--neglect-spindle``: leave the platform-spindle stiffness K_U out."""
    p.add_argument("--neglect-spindle", action="store_true",
                   help="leave the platform-spindle stiffness K_U out (platform and spindle rigid), as the "
                        "dissertation's stiffness maps at tool length 0 do (Cobet 4.2.4)")


def add_skip_check_argument(p: Any) -> None:
    """``--skip-check NAME`` (repeatable): leave a named admissibility check out (``args.skip_check``, a list)."""
    p.add_argument("--skip-check", action="append", default=[], choices=ALL_CHECKS, metavar="NAME",
                   help="leave this admissibility check out (repeatable); names: " + ", ".join(ALL_CHECKS)
                        + " (see 'pkmstiff quantities'); outputs state the checks left out")
