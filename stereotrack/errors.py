"""The one exception type for errors a user can cause.

The CLI prints its message on one line and exits non-zero; the message must
say what is wrong and what to do about it.
"""


class StereotrackError(Exception):
    """A problem with the user's input: a file, a setting, a device."""
