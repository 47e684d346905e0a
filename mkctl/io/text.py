"""Reading a user's text file with one-line errors: the one place that turns OS errors into messages."""
from __future__ import annotations

from pathlib import Path


def read_user_text(path, error_class, what: str) -> str:
    """The text of ``path`` (UTF-8, a byte-order mark dropped); any problem raises ``error_class`` with one line
    naming the file: missing, a folder instead of ``what`` ("a measurement file"), not UTF-8, unreadable."""
    path = Path(path)
    try:
        return path.read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise error_class(f"{path}: no such file") from None
    except IsADirectoryError:
        raise error_class(f"{path}: is a folder, not {what}") from None
    except UnicodeDecodeError:
        raise error_class(f"{path}: not a text file (it is not UTF-8)") from None
    except OSError as error:
        raise error_class(f"{path}: cannot be read ({error.strerror or error})") from None


def write_text_atomic(path, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` through a temporary file beside it, renamed over ``path`` when complete:
    a reader (or a re-run after a kill) sees the old file or the new one, never half of one. Returns the path."""
    import os
    import tempfile

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    handle, temporary = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(handle, "w", encoding="utf-8", newline="") as out:
            out.write(text)
        os.replace(temporary, path)
    except BaseException:
        if os.path.exists(temporary):
            os.unlink(temporary)
        raise
    return path
