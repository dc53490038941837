# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Text from outside (file names, keys, frame ids, parameter values) as messages show it.

Whatever a client or a file sends may be arbitrarily long; a refusal that quotes it whole
would copy it into every log line and every /diagnostics message. Every message that quotes
outside text goes through :func:`shown`, so no message grows with its input.
"""

# Characters of outside text a message quotes; the rest is replaced by a count. Enough for
# any real file path or frame id whole.
SHOWN_CHARACTERS = 160


def shown(value, limit=SHOWN_CHARACTERS):
    """``repr(value)`` cut to ``limit`` characters, saying how long the whole was.

    Parameters
    ----------
    value : object
        Usually a str; anything else is quoted by its repr as well.
    limit : int
        Characters of the repr kept.

    Returns
    -------
    str
        The repr itself when short enough, else its first and last ``limit / 2``
        characters around ``...(N characters)...``: the end of a path names the file.
    """
    if isinstance(value, str) and len(value) > limit:
        # repr of the whole would copy it (1.1 s for 300 MB, in the callback that refuses
        # it): only the ends are quoted, and the count is of the string's characters.
        half = limit // 2
        return f'{repr(value[:half])[:half]}...({len(value)} characters)...' \
               f'{repr(value[-half:])[-half:]}'
    return clipped(repr(value), limit)


def clipped(text, limit=SHOWN_CHARACTERS):
    """``str(text)`` cut to ``limit`` characters as :func:`shown` cuts a repr."""
    text = str(text)
    if len(text) <= limit:
        return text
    half = limit // 2
    return f'{text[:half]}...({len(text)} characters)...{text[-half:]}'
