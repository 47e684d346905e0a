"""Exceptions raised by mkctl.

Every error a user can cause derives from :class:`MkctlError`, so that the command line (and the FMU
wrappers) can turn it into a one-line message instead of a traceback. Its text is always one short
line: a value quoted from a file (a 1 MB metadata value, a 400-digit number) is cut in the middle
(:func:`one_line`).
"""

#: Longest run of characters without a space that a message shows whole (a file path: LONGEST_PATH);
#: longer ones are cut in the middle.
LONGEST_WORD = 80
LONGEST_PATH = 1000
#: Longest message [characters]; a longer one is cut in the middle.
LONGEST_MESSAGE = 2000


def one_line(text: str, longest_word: int = LONGEST_WORD, longest: int = LONGEST_MESSAGE) -> str:
    """``text`` as one short line, so that a message quoting a file's value stays readable.

    Line breaks become spaces; a word longer than ``longest_word`` characters (:data:`LONGEST_PATH`
    for a word with a ``/``: a file's path) keeps its ends with ``...(N characters)...`` between
    them, and the whole is cut likewise at ``longest``.

    Parameters
    ----------
    text : str
        The message (anything ``str`` accepts).
    longest_word : int
        Longest word shown whole [characters]; default :data:`LONGEST_WORD`.
    longest : int
        Longest message shown whole [characters]; default :data:`LONGEST_MESSAGE`.

    Returns
    -------
    str
        The message on one line, cut in the middle where too long.
    """
    def cut(word: str, keep: int) -> str:
        if len(word) <= keep:
            return word
        half = max(keep // 2 - 12, 4)
        return f"{word[:half]}...({len(word)} characters)...{word[-half:]}"

    words = " ".join(str(text).split("\n")).split(" ")
    return cut(" ".join(cut(word, LONGEST_PATH if "/" in word else longest_word) for word in words),
               longest)


class MkctlError(Exception):
    """Base class of every error a user of mkctl can cause.

    Its text is one short line (:func:`one_line`), which the CLI prints instead of a traceback.
    """

    def __str__(self) -> str:
        return one_line(super().__str__())


class ParameterError(MkctlError, ValueError):
    """A parameter value the model cannot represent (negative mass, unknown name, ...)."""


class DomainError(MkctlError, ValueError):
    """A state or input outside the model's domain (an actuator length outside 0 < L < b, ...)."""


class MeasurementFileError(MkctlError, ValueError):
    """A measurement file that does not follow the format of model-spec section 5."""


class ResourceError(MkctlError, ValueError):
    """A job that would need more memory than this machine has (a record, a grid, a response)."""


def available_memory() -> int:
    """Bytes of memory this process can still take.

    Returns
    -------
    int
        Available physical memory [bytes] (psutil, else ``sysconf``); 8 GiB if it cannot be told.
    """
    try:
        import psutil

        return int(psutil.virtual_memory().available)
    except Exception:  # noqa: BLE001 - psutil missing or unsupported here
        import os

        try:
            return int(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
        except (ValueError, OSError, AttributeError):
            return 8 << 30


def check_memory(what: str, count: float, bytes_each: float, fraction: float = 0.5) -> None:
    """Refuse a job that would take more than a share of the memory available now.

    Parameters
    ----------
    what : str
        What the job is, as the message names it (``"a record of 1e9 samples"``).
    count : float
        Number of items (a whole number with hundreds of digits counts as infinite).
    bytes_each : float
        Memory per item [bytes].
    fraction : float
        Largest share of the available memory (:func:`available_memory`) one job may take [-].

    Raises
    ------
    ResourceError
        If ``count * bytes_each`` exceeds ``fraction`` of the available memory, or is NaN or
        infinite; the message names ``what`` and both figures.
    """
    try:
        need = float(count) * float(bytes_each)
    except OverflowError:  # a whole number with hundreds of digits
        need = float("inf")
    have = available_memory()
    if not need <= fraction * have:  # NaN and inf refused too
        raise ResourceError(f"{what} would need {_bytes(need)} of memory; this machine has "
                            f"{_bytes(have)} available "
                            f"(at most {_bytes(fraction * have)} is used for one job)")


def _bytes(count: float) -> str:
    if not count < 1e30:
        return "more than 1e30 bytes"
    for unit in ("B", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"):
        if count < 1024 or unit == "EiB":
            return f"{count:.3g} {unit}"
        count /= 1024
    return f"{count:.3g} EiB"
