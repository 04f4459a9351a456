"""Writing a rerun recording (`.rrd`) atomically: a temporary file beside the target, then `os.replace`.

One place for every recording the project writes (`recording`, `part_recording`): a failed or interrupted
recording leaves the target as it was and no temporary file behind; the file gets the umask's permissions, and a
failed write names the target.
"""

from __future__ import annotations

import os
import uuid
from collections.abc import Callable
from pathlib import Path

import rerun as rr
import rerun.blueprint as rrb

from twin.base.csvio import make_folder
from twin.base.outputs import plain_mode, write_failure


def save_recording(
    path: str | Path,
    blueprint: rrb.Blueprint,
    log: Callable[[rr.RecordingStream], None],
    *,
    application_id: str = "tx200-twin",
) -> Path:
    """Log a recording with `log` into `path` (written atomically), with its default blueprint.

    Args:
        path: The `.rrd` file to write.
        blueprint: The viewer layout stored with the recording.
        log: Logs the recording's entities into the stream it is given.
        application_id: Rerun application id.

    Returns:
        The path written.
    """
    target = Path(path)
    make_folder(target.parent)
    tmp = target.parent / f".{target.name}.{os.getpid()}.{uuid.uuid4().hex}.tmp"
    rec = rr.RecordingStream(application_id, send_properties=False)
    try:
        rec.save(tmp, default_blueprint=blueprint)
        log(rec)
        rec.flush()
        rec.disconnect()
        plain_mode(tmp)
        os.replace(tmp, target)
    except BaseException as exc:
        rec.disconnect()
        tmp.unlink(missing_ok=True)
        if isinstance(exc, OSError):
            raise write_failure(target, exc) from None
        raise
    return target
