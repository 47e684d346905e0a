"""Reading a user's text file with one-line errors: the one place that turns OS errors into messages."""
from __future__ import annotations

from pathlib import Path


#: Memory a text file takes once read and parsed, per byte of the file (the text, its lines, the numbers as Python
#: floats in lists, then as arrays).
BYTES_PER_CHARACTER = 12


def read_user_text(path, error_class, what: str) -> str:
    """The text of ``path`` (UTF-8, a byte-order mark dropped); any problem raises ``error_class`` with one line
    naming the file: missing, a folder instead of ``what`` ("a measurement file"), not UTF-8, unreadable."""
    from ..errors import ResourceError, check_memory

    path = Path(path)
    try:
        if path.is_file():  # a file's numbers take about ten times its size once read
            size = path.stat().st_size
            check_memory(f"{path}: reading a file of {size / 2**20:.4g} MiB", size, BYTES_PER_CHARACTER)
        return path.read_text(encoding="utf-8-sig")
    except ResourceError as error:
        raise error_class(str(error)) from None
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
