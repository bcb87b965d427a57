"""The exceptions femto raises, and the caller's spelling in their messages.

The library words each refusal once, naming the command's flag (``--min-peak``); a function
of this package raises it with each flag that is one of its keyword arguments written as
the keyword (:func:`keyword_spelling`): ``--min-peak`` as ``min_peak=``, ``--levels 40: ...``
as ``levels=40: ...``, a switch ``--force`` as ``force=True`` and ``--no-jitter`` as
``jitter=False``. Flags the function has no keyword for stay as they are."""

from __future__ import annotations

import functools
import inspect
import re
from typing import Any, Callable, Dict, TypeVar


class FemtoError(ValueError):
    """A stage refused its input: a bad argument, a malformed file, an impossible setting.

    ``str(e)`` is the line ``femto`` prints after ``femto: error:``, naming the file, key or
    argument, with each flag written as the function's keyword (``min_peak=``, not
    ``--min-peak``).
    """


class FemtoOSError(FemtoError, OSError):
    """A file or folder could not be opened, read, written or renamed (``errno`` is set)."""


class FemtoFileNotFoundError(FemtoOSError, FileNotFoundError):
    """A file or folder that a stage reads does not exist."""


# A flag, then optionally ":" or a space and the token after it.
_FLAG = re.compile(r"(?<![\w-])--([a-z][a-z0-9]*(?:-[a-z0-9]+)*)(?=([:= ]\S*)?)")
# A token after a flag that is prose rather than the flag's value: a lowercase word, or a
# parenthesis opening a remark.
_PROSE = re.compile(r"^(?:[a-z]+|\(.*)$")


def keyword_spelling(message: str, defaults: Dict[str, Any]) -> str:
    """``message`` with each ``--flag`` that names a keyword of ``defaults`` (keyword ->
    default value) in the keyword's spelling; see the module doc."""

    def spell(m: "re.Match[str]") -> str:
        flag = m.group(1)
        key = flag.replace("-", "_")
        if key in defaults and defaults[key] is False:
            return f"{key}=True"
        if flag.startswith("no-") and defaults.get(key[3:], None) is True:
            return f"{key[3:]}=False"
        if key not in defaults:
            return m.group(0)
        after = m.group(2) or ""
        if after.startswith(":") or after.startswith("="):
            return key
        if after.startswith(" ") and after[1:] and not _PROSE.match(after[1:]):
            return f"{key}=\x00"  # joined to its value below
        return f"{key}="

    return _FLAG.sub(spell, message).replace("=\x00 ", "=")


F = TypeVar("F", bound=Callable[..., Any])


def keyword_errors(function: F) -> F:
    """Raise ``function``'s :class:`FemtoError` messages in its keywords' spelling."""
    defaults = {
        name: p.default
        for name, p in inspect.signature(function).parameters.items()
        if p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)
    }

    @functools.wraps(function)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            return function(*args, **kwargs)
        except FemtoError as e:
            if e.args and isinstance(e.args[0], str):
                e.args = (keyword_spelling(e.args[0], defaults),) + tuple(e.args[1:])
            raise

    return wrapper  # type: ignore[return-value]
